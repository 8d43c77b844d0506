"""Twin agents: exact eigenvectors e_a - e_r of a Laplacian, and the decisions they settle.

Agents a != r with equal rows of L off {a, r} and equal diagonal entries are *twins*:
L (e_a - e_r) = (L_aa - L_ar)(e_a - e_r) exactly (:func:`glocal_verify.numerics.symmetry.twin_modes`).
Pendant agents hanging on the same neighbour with equal weights are the common case in
generated networks. They settle, in exact arithmetic and at the cost of a hash per agent,
questions whose floating-point answers sit on a rounding-level difference:
Theorem III.3 (iii) fails for a safe mode whose L_q has twins off a switching pair
(:func:`eigenvector_differences_modular`, which otherwise proves (iii) by Krylov degrees modulo a
prime, or by two gcds of characteristic polynomials), and Theorem III.3 (ii) fails when two
independent twin modes share an eigenvalue (:func:`distinct_eigenvalues_modular`, which
otherwise proves (ii) by a Krylov degree, or by one gcd modulo a prime). The local and global pencil certificates use the same modes
(:mod:`glocal_verify.analysis.local.cases`, :mod:`glocal_verify.design.audit`).
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any, Mapping

import numpy as np

from glocal_verify import config
from glocal_verify.derived import Kind
from glocal_verify.model import System
from glocal_verify.numerics.exact import nullspace
from glocal_verify.numerics.krylov import krylov_degree_mod
from glocal_verify.numerics.minors import charpoly_mod, prime_for
from glocal_verify.numerics.symmetry import twin_modes
from glocal_verify.spec.types import NORMAL_MODE
from glocal_verify.results import Status, Verdict

__all__ = ["distinct_eigenvalues_modular", "eigenvector_differences_modular", "laplacian_entries"]

#: derived results this module keeps on the system (glocal_verify.derived)
_CHARPOLY_MOD_KIND: Kind[tuple[int, Any]] = Kind("charpoly-mod", __name__, "tuple[int, Any]")
_LAPLACIAN_ENTRIES_KIND: Kind[Mapping[tuple[int, int], Fraction]] = Kind("laplacian-entries", __name__, "Mapping[tuple[int, int], Fraction]")


def laplacian_entries(system: System, mode: str) -> Mapping[tuple[int, int], Fraction]:
    """The nonzero entries of L_q as exact rationals, from the spec's edges (sparse).

    Built once per mode and kept on ``system.analysis``, shared by every caller: the mapping
    must not be modified.

    Parameters
    ----------
    system : System
    mode : str
    """

    mode = system.check_mode(mode)

    def update() -> Mapping[tuple[int, int], Fraction]:  # a safe mode: the normal entries and its few changed links
        ent = dict(laplacian_entries(system, NORMAL_MODE))
        adj = system.adjacency(mode)
        for a, b, d in system.switching_links(mode):
            u, v = system.index[a], system.index[b]
            for key, delta in (((u, v), -d), ((v, u), -d), ((u, u), d), ((v, v), d)):
                x = ent.get(key, Fraction(0)) + delta
                if x != 0 or (key[0] == key[1] and adj[system.labels[key[0]]]):
                    ent[key] = x
                else:
                    ent.pop(key, None)
        return ent

    def build() -> Mapping[tuple[int, int], Fraction]:
        if mode != NORMAL_MODE:
            return update()
        ent: dict[tuple[int, int], Fraction] = {}
        diag: list[list[Fraction]] = [[] for _ in range(system.n)]
        index = system.index
        for key, w in system.edges(mode).items():  # one weight per pair of agents
            u, v = (index[a] for a in key)
            ent[(u, v)] = ent[(v, u)] = -w
            diag[u].append(w)
            diag[v].append(w)
        for i, ws in enumerate(diag):
            if ws:
                ent[(i, i)] = sum(ws, Fraction(0))
        return ent

    return _LAPLACIAN_ENTRIES_KIND.get(system, (mode,), build)  # type: ignore[no-any-return]


def eigenvector_differences_modular(system: System, mode: str) -> Verdict | None:
    """Decide Theorem III.3 (iii) for ``mode`` exactly and cheaply, or return None.

    * fails: an exact twin mode e_a - e_r of L_q (:func:`glocal_verify.numerics.symmetry.twin_modes`)
      with {a, r} disjoint from a pair {i, j} of a switching component is an eigenvector with
      u(i) = u(j) = 0 (for a repeated eigenvalue (iii) fails anyway);
    * holds, by Krylov degrees (:func:`glocal_verify.numerics.krylov.krylov_degree_mod`, about
      2N sparse products per pair): dim span{L_q^k (e_i - e_j)} >= N - 1 for every pair, proven
      modulo a prime. L_q is symmetric and e_i - e_j is orthogonal to its kernel span{1} (one
      component), so e_i - e_j has a nonzero component in N - 1 distinct eigenspaces of nonzero
      eigenvalues, whose dimensions add up to N - 1: every eigenvalue is simple and every
      eigenvector u but 1 has u(i) - u(j) = u^T (e_i - e_j) != 0;
    * fails, when the Krylov degree falls short on more than ``config.get("charpoly_mod_max_agents")``
      agents: an exact eigenvector of small support found
      from the floating-point ones (:func:`_localized_failure`) with equal entries on a pair;
    * holds, when the Krylov degree falls short twice (two primes and vectors) on at most
      ``config.get("charpoly_mod_max_agents")`` agents: p = charpoly(L_q) squarefree and gcd(p / mu, q_ij) = 1 for every pair
      (q_ij(mu) = det(mu I - (L - b b^T)) - det(mu I - L), b = e_i - e_j, so that
      q_ij(mu_l) = p'(mu_l) (u_l(i) - u_l(j))^2 at a simple eigenvalue), both proved modulo a prime: p and p / mu are
      monic, so their reductions keep their degrees and a gcd of degree 0 modulo p proves
      gcd 1 over Q (Gauss's lemma, as in :mod:`glocal_verify.numerics.minors`).

    Parameters
    ----------
    system : System
    mode : str
        A safe mode.

    Returns
    -------
    Verdict or None
        The exact decision (status and witness; ``exact``), or None when neither certificate
        applies.
    """

    pairs = [(c[x], c[y]) for c in system.switching_components(mode) for x in range(len(c)) for y in range(x + 1, len(c))]
    if not pairs or len(system.components(mode)) > 1:
        return None
    n = system.n
    ent = laplacian_entries(system, mode)
    idx = [tuple(system.idx(pr)) for pr in pairs]
    w_num = system.spectrum(mode).values
    for mu, tw in twin_modes(n, ent, ()):
        for a, r in tw:
            for (i, j), pr in zip(idx, pairs):
                if {a, r}.isdisjoint((i, j)):
                    la, lr = system.labels[a], system.labels[r]
                    l = int(np.argmin(np.abs(w_num - float(mu))))
                    return Verdict(Status.FAILS, witness={
                        "pair": list(pr), "l": l + 1, "eigenvalue": float(mu), "eigenvalue_exact": mu,
                        "entries": [0.0, 0.0],
                        "eigenvector_exact": {la: Fraction(1), lr: Fraction(-1)},
                        "reason": f"{la} and {lr} are twins in L_q: e_{la} - e_{lr} is an exact eigenvector (eigenvalue {mu}) "
                        f"whose entries on the pair are both 0",
                    }, exact=True)
    krylov = _krylov_certificate(n, ent, [{i: 1, j: -1} for i, j in idx], n - 1)
    if krylov is not None:
        return Verdict(Status.HOLDS, witness={
            "pairs_checked": len(pairs),
            "certificate": f"dim span{{L_q^k (e_i - e_j)}} >= N - 1 = {n - 1} for every pair, modulo the prime {krylov} (Krylov degree, "
            "Berlekamp-Massey): N distinct eigenvalues, and every eigenvector but 1 separates every pair (exact)",
        }, exact=True)
    if n > config.get("charpoly_mod_max_agents"):
        # beyond the characteristic polynomials' reach: an exact eigenvector of small support
        return _localized_failure(system, mode, ent, idx, pairs)
    p, P = _charpoly_mod(system, mode, ent)
    if P.gcd(P.derivative()).degree() != 0 or int(P.coeffs()[0]) != 0:
        return None
    P0 = type(P)([int(c) for c in P.coeffs()[1:]], p)
    for i, j in idx:
        e2 = dict(ent)
        for key, d in (((i, i), -1), ((j, j), -1), ((i, j), 1), ((j, i), 1)):
            e2[key] = e2.get(key, Fraction(0)) + d
        if P0.gcd(charpoly_mod(n, e2, p) - P).degree() != 0:
            return None
    return Verdict(Status.HOLDS, witness={
        "pairs_checked": len(pairs),
        "certificate": f"charpoly(L_q) squarefree and gcd(p(mu)/mu, q_ij) = 1 for every pair, modulo the prime {p} (exact)",
    }, exact=True)


#: the largest support of a floating-point eigenvector tried as an exact localized one
_LOCAL_SUPPORT = 8


def _localized_failure(
    system: System, mode: str, ent: Mapping[tuple[int, int], Fraction], idx: list[tuple[int, ...]], pairs: list[tuple[Any, Any]]
) -> Verdict | None:
    """Theorem III.3 (iii) fails, proven by an exact eigenvector of small support (or None).

    A floating-point eigenvector whose entries vanish (to rounding) off at most
    ``_LOCAL_SUPPORT`` agents S is re-solved exactly: its eigenvalue rounded to a small
    rational mu != 0, the rational kernel of (L_q - mu I) restricted to the columns S and to
    the rows S ∪ N(S) (every other row of (L_q - mu I) v vanishes for v supported on S). A
    nonzero kernel vector v is an exact eigenvector of L_q for mu (not the constant one);
    a pair (i, j) with v(i) = v(j) then fails (iii), whatever the multiplicity of mu. The
    rounding only proposes; the exact check decides. This generalises the twins (support 2).
    """
    n = system.n
    sp = system.spectrum(mode)
    neighbours: dict[int, set[int]] = {}
    for i, j in ent:
        neighbours.setdefault(j, set()).add(i)
    values = np.asarray(sp.values)
    for a in range(1, n, 256):
        U = np.asarray(sp.columns(np.arange(a, min(n, a + 256))))
        for c in range(U.shape[1]):
            u = U[:, c]
            S = np.nonzero(np.abs(u) > 1e-8 * float(np.abs(u).max()))[0]
            if len(S) > _LOCAL_SUPPORT:
                continue
            mu = Fraction(float(values[a + c])).limit_denominator(1000)
            if mu == 0:
                continue
            cols = [int(x) for x in S]
            rows = sorted(set(cols).union(*(neighbours.get(x, set()) for x in cols)))
            M = [[ent.get((r, s), Fraction(0)) - (mu if r == s else 0) for s in cols] for r in rows]
            for v in nullspace(M, len(cols)):
                vec = dict(zip(cols, v))
                for (i, j), pr in zip(idx, pairs):
                    if vec.get(i, Fraction(0)) == vec.get(j, Fraction(0)):
                        exact = {system.labels[k]: x for k, x in vec.items() if x != 0}
                        return Verdict(Status.FAILS, witness={
                            "pair": list(pr), "l": a + c + 1, "eigenvalue": float(mu), "eigenvalue_exact": mu,
                            "entries": [float(vec.get(i, 0)), float(vec.get(j, 0))],
                            "eigenvector_exact": exact,
                            "reason": f"L_q has the exact eigenvector ({', '.join(f'{k}: {x}' for k, x in exact.items())}; 0 elsewhere) "
                            f"with eigenvalue {mu}, supported on {len(exact)} agents, "
                            f"whose entries on the pair {pr[0]}, {pr[1]} are equal",
                        }, exact=True)
    return None


def _krylov_certificate(n: int, ent: Mapping[tuple[int, int], Fraction], starts: list[dict[int, int] | None], need: int) -> int | None:
    """The prime that proves dim K(L_q, b) >= ``need`` for every start ``b`` (None: a random
    one), or None when two draws fall short for some ``b`` (nothing is proven then)."""
    prime = None
    for b in starts:
        for seed, below in ((0, None), (1, 2**29)):
            kd = krylov_degree_mod(n, ent, b, need, seed=seed, prime_below=below)
            if kd.degree >= need:
                prime = kd.prime
                break
        else:
            return None
    return prime


def _charpoly_mod(system: System, mode: str, ent: Mapping[tuple[int, int], Fraction]) -> tuple[int, Any]:
    """(p, charpoly(L_q) modulo p) for a prime p that divides no entry's denominator; kept on
    ``system.analysis`` (both Theorem III.3 deciders of a mode read it)."""
    def compute() -> tuple[int, Any]:
        p = prime_for(list(ent.values()))
        return p, charpoly_mod(system.n, ent, p)

    return _CHARPOLY_MOD_KIND.get(system, (mode,), compute)  # type: ignore[no-any-return]


def distinct_eigenvalues_modular(system: System, mode: str) -> Verdict | None:
    """Decide Theorem III.3 (ii) for ``mode`` exactly and cheaply, or return None.

    * fails: two independent exact twin modes e_a - e_r of L_q with the same eigenvalue mu
      (:func:`glocal_verify.numerics.symmetry.twin_modes`): mu is repeated; the witness gives
      them orthogonalised in exact arithmetic (their number is a lower bound on the
      multiplicity);
    * holds: dim span{L_q^k b} = N for a random b, proven modulo a prime
      (:func:`glocal_verify.numerics.krylov.krylov_degree_mod`): the minimal polynomial of the
      symmetric L_q has degree N, so its N eigenvalues are distinct (about 2N sparse products);
    * holds, when that falls short twice, on at most ``config.get("charpoly_mod_max_agents")``
      agents: gcd(p, p') has degree 0 modulo a prime, p = charpoly(D L_q) for the common
      denominator D (monic with integer coefficients): a repeated factor over Q would divide
      p and p' modulo every prime (Gauss's lemma), so p is squarefree and the N eigenvalues
      are distinct.

    Parameters
    ----------
    system : System
    mode : str
        A safe mode (any mode of the spec).

    Returns
    -------
    Verdict or None
        The exact decision (status and witness; ``exact``); None when neither certificate applies (the prime may divide a discriminant that is
        not 0 over Q); the caller keeps its undecided verdict and escalates.
    """
    n = system.n
    ent = laplacian_entries(system, mode)
    for mu, tw in twin_modes(n, ent, ()):
        if len(tw) < 2:
            continue
        (a1, r1), (a2, r2) = tw[0], tw[1]
        v1 = [Fraction(0)] * n
        v2 = [Fraction(0)] * n
        v1[a1], v1[r1] = Fraction(1), Fraction(-1)
        v2[a2] += 1
        v2[r2] -= 1
        c = sum((x * y for x, y in zip(v1, v2)), Fraction(0)) / 2
        v2 = [y - c * x for x, y in zip(v1, v2)]
        unit = [np.array([float(x) for x in v]) for v in (v1, v2)]
        names = ", ".join(f"{system.labels[a]} ~ {system.labels[r]}" for a, r in tw[:4])
        return Verdict(Status.FAILS, exact=True, witness={
            "eigenvalue": float(mu),
            "eigenvalue_exact": mu,
            "multiplicity_at_least": len(tw),
            "reason": f"twin agents ({names}) give {len(tw)} independent exact eigenvectors e_a - e_r of L_q with eigenvalue {mu}",
            "rational_eigenvectors": [system.vector_by_label(v) for v in (v1, v2)],
            "eigenvectors": [system.vector_by_label(u / np.linalg.norm(u)) for u in unit],
        })
    krylov = _krylov_certificate(n, ent, [None], n)
    if krylov is not None:
        return Verdict(Status.HOLDS, witness={
            "certificate": f"dim span{{L_q^k b}} = N = {n} for a random b, modulo the prime {krylov} (Krylov degree, Berlekamp-Massey): "
            "the minimal polynomial of L_q has degree N, so its eigenvalues are distinct (exact)",
        }, exact=True)
    if n > config.get("charpoly_mod_max_agents"):
        return None
    p, P = _charpoly_mod(system, mode, ent)
    if P.gcd(P.derivative()).degree() != 0:
        return None
    return Verdict(Status.HOLDS, witness={"certificate": f"charpoly(L_q) squarefree modulo the prime {p}: gcd(p, p') = 1 (exact)"}, exact=True)
