"""Theorem III.3 (ii) and (iii): the rules of ``switching.distinct-eigenvalues`` and
``switching.eigenvector-differences``, the eigenstructure of a safe mode's Laplacian L_q.

(ii) asks N distinct eigenvalues; (iii) asks every eigenvector ``u_l`` (``l != 1``) to take
different values on the two agents of every pair of one switching component (the connected
components of the changed links, Definition A.1). Numeric decisions use the certified radius
and Davis-Kahan sines of :class:`~glocal_verify.numerics.spectrum.Spectrum`; exact ones the
characteristic polynomial over Q; the twin and modular certificates of
:mod:`glocal_verify.analysis.laplacian.twins` decide the cases in between at the cost of a hash per
agent and one characteristic polynomial modulo a prime.
"""

from __future__ import annotations

import math
from fractions import Fraction
from typing import Any

import numpy as np

from glocal_verify.analysis.laplacian.twins import distinct_eigenvalues_modular, eigenvector_differences_modular
from glocal_verify.model import System
from glocal_verify.numerics import exact as ex
from glocal_verify.numerics.rounding import EPS
from glocal_verify.results import Status, Verdict
from glocal_verify.spec.types import Label

__all__ = [
    "algebraic_root_witness",
    "distinct_eigenvalues_verdict",
    "eigenvector_difference_polynomial",
    "eigenvector_differences_verdict",
]


def _rational_orthogonal_basis(basis: list[list[Fraction]]) -> list[list[Fraction]]:
    """Gram-Schmidt over Q (no normalisation): pairwise orthogonal rational vectors, same span."""
    out: list[list[Fraction]] = []
    for b in basis:
        v = list(b)
        for o in out:
            c = sum((x * y for x, y in zip(v, o)), Fraction(0)) / sum((y * y for y in o), Fraction(0))
            v = [x - c * y for x, y in zip(v, o)]
        if any(x != 0 for x in v):
            out.append(v)
    return out


def _unit_floats(v: list[Fraction]) -> np.ndarray:
    a = np.array([float(x) for x in v])
    return a / np.linalg.norm(a)


def _rational_repeated_eigenspaces(system: System, mode: str, g: ex.flint.fmpq_poly) -> list[tuple[Fraction, list[list[Fraction]]]]:
    """Rational roots of the repeated factor g with an exact orthogonal basis of their eigenspace."""
    L = system.laplacian_exact(mode)
    out = []
    num = g.numer() if hasattr(g, "numer") else g
    for fac, _m in num.factor()[1]:
        if fac.degree() != 1:
            continue
        c = fac.coeffs()
        mu = Fraction(-int(c[0]), int(c[1]))
        M = [[L[i][j] - (mu if i == j else 0) for j in range(system.n)] for i in range(system.n)]
        out.append((mu, _rational_orthogonal_basis(ex.nullspace(M))))
    return out


def _disconnection_witness(system: System, mode: str) -> dict[str, Any]:
    comps = system.components(mode)
    vecs = []
    for c in comps[:2]:
        v = [Fraction(int(lab in c)) for lab in system.labels]
        vecs.append(system.vector_by_label(v))
    return {
        "eigenvalue": 0.0,
        "eigenvalue_exact": Fraction(0),
        "multiplicity": len(comps),
        "reason": f"the {mode} graph has {len(comps)} components: the indicators of its components span ker L_q",
        "rational_eigenvectors": vecs,
        "eigenvectors": [system.vector_by_label(_unit_floats([Fraction(int(lab in c)) for lab in system.labels])) for c in comps[:2]],
    }


def distinct_eigenvalues_verdict(system: System, mode: str, exact: bool = False) -> Verdict:
    """Theorem III.3 (ii) for one safe mode: L_q has N distinct eigenvalues.

    Numeric (certified): every gap ``w_{i+1} - w_i > 2 rho`` (``rho`` the rigorous radius
    :attr:`Spectrum.error_radius <glocal_verify.numerics.spectrum.Spectrum.error_radius>`,
    Weyl) proves it; a disconnected graph (exact structure) repeats 0; otherwise
    :func:`~glocal_verify.analysis.laplacian.twins.distinct_eigenvalues_modular` decides exactly when
    it can, and the verdict is undecided with ``error_bound = 2 rho``. Exact: the
    characteristic polynomial is squarefree over Q.

    Parameters
    ----------
    system : System
    mode : str
        A safe mode.
    exact : bool

    Returns
    -------
    Verdict
        Margin: the smallest gap (absolute; ``relative_gap`` in the witness), 0 on failure.
        Witness: the closest pair and the radius, or a repeated eigenvalue with eigenvectors.
    """
    sp = system.spectrum(mode)
    w = sp.values
    gaps = np.diff(w)
    k = int(np.argmin(gaps)) if len(gaps) else 0
    margin = float(gaps[k]) if len(gaps) else float("inf")
    rho = sp.error_radius
    closest = {"closest_pair": [k + 1, k + 2], "eigenvalues": [float(w[k]), float(w[k + 1])]} if len(gaps) else {}
    witness: dict[str, Any] = {}
    bound: float | None = None
    note = ""
    if exact:
        p = ex.charpoly(system.laplacian_exact(mode))
        if ex.is_squarefree(p):
            status = Status.HOLDS
            witness = dict(closest)
        else:
            status = Status.FAILS
            margin = 0.0
            g = ex.repeated_factor(p)
            witness = {"repeated_factor": ex.poly_str(g), "charpoly_degree": int(p.degree())}
            spaces = _rational_repeated_eigenspaces(system, mode, g)
            if spaces:
                witness["rational_eigenspaces"] = [
                    {"eigenvalue": mu, "basis": [system.vector_by_label(b) for b in basis]} for mu, basis in spaces
                ]
                mu, basis = spaces[0]
                witness["eigenvalue"] = float(mu)
                witness["eigenvalue_exact"] = mu
                witness["multiplicity"] = len(basis)
                witness["eigenvectors"] = [system.vector_by_label(_unit_floats(b)) for b in basis[:2]]
    else:
        bound = 2.0 * rho
        if len(system.components(mode)) > 1:
            status = Status.FAILS
            margin = 0.0
            witness = _disconnection_witness(system, mode)
        elif all(len(c) == 1 for c in sp.clusters):
            status = Status.HOLDS
            witness = dict(closest, certified_radius=rho)
        elif (decided := distinct_eigenvalues_modular(system, mode)) is not None:
            status, witness = decided.status, dict(decided.witness)
            if status is Status.FAILS:
                margin = 0.0
            else:
                witness = dict(closest, **witness)
        else:
            status = Status.UNDECIDED
            c = next(c for c in sp.clusters if len(c) > 1)
            j = c[0]
            witness = {
                "closest_pair": [j + 1, j + 2],
                "eigenvalues": [float(w[j]), float(w[j + 1])],
                "gap": float(w[j + 1] - w[j]),
                "certified_radius": rho,
            }
            note = (
                f"eigenvalues {j + 1} and {j + 2} differ by {float(w[j + 1] - w[j]):.3g}, not more than twice the "
                f"certified rounding radius 2 rho = {bound:.3g} (Weyl): they may coincide"
            )
    if len(gaps) and sp.scale > 0 and "relative_gap" not in witness and status is not Status.FAILS:
        witness["relative_gap"] = margin / sp.scale
    return Verdict(status, margin=margin, error_bound=bound, witness=witness, exact=exact, note=note)


# --------------------------------------------------------------------------------------------
# Theorem III.3 (iii)


def _pairs(system: System, mode: str) -> list[tuple[Label, Label]]:
    out = []
    for comp in system.switching_components(mode):
        for a in range(len(comp)):
            for b in range(a + 1, len(comp)):
                out.append((comp[a], comp[b]))
    return out


def eigenvector_difference_polynomial(L: list[list[Fraction]], i: int, j: int) -> ex.flint.fmpq_poly:
    """q_ij(mu) = (e_i - e_j)^T adj(mu I - L) (e_i - e_j), exactly.

    By the matrix determinant lemma, ``det(M + b b^T) = det M + b^T adj(M) b``; with
    ``M = mu I - L`` and ``b = e_i - e_j``,

    .. math:: q_{ij}(\\mu) = \\det(\\mu I - (L - b b^\\top)) - \\det(\\mu I - L),

    the difference of two characteristic polynomials (``L - b b^T`` is L with the weight of the
    pair {i, j} lowered by 1). For a simple eigenvalue ``mu_l`` with unit eigenvector ``u_l``,
    ``adj(mu_l I - L) = p'(mu_l) u_l u_l^T``, hence ``q_ij(mu_l) = p'(mu_l) (u_l(i) - u_l(j))^2``.

    Parameters
    ----------
    L : list of list of Fraction
        A symmetric rational matrix (a Laplacian).
    i, j : int
        0-based indices, ``i != j``.
    """
    M = [list(r) for r in L]
    M[i][i] -= 1
    M[j][j] -= 1
    M[i][j] += 1
    M[j][i] += 1
    return ex.charpoly(M) - ex.charpoly(L)


_REPEATED_REASON = (
    "repeated eigenvalue: (iii) presupposes (ii); in an eigenspace of dimension >= 2 some unit "
    "eigenvector has u(i) = u(j), and an orthonormal eigenbasis U_q containing it violates (iii)"
)


def _equal_pair_vector(E: np.ndarray, i: int, j: int) -> np.ndarray:
    """A unit vector of span(E) (orthonormal columns, >= 2) with u(i) = u(j) (float)."""
    row = (E[i] - E[j])[None, :]
    _, _, Vh = np.linalg.svd(row, full_matrices=True)
    u = E @ Vh[-1]
    u = u / np.linalg.norm(u)
    return np.asarray(np.where(np.abs(u) <= 1e-14, 0.0, u))


def _exact_equal_pair_vector(basis: list[list[Fraction]], i: int, j: int) -> list[Fraction] | None:
    """A nonzero rational vector of span(basis) (>= 2 vectors) with v(i) = v(j)."""
    if len(basis) < 2:
        return None
    row = [[b[i] - b[j] for b in basis]]
    for c in ex.nullspace(row, ncols=len(basis)):
        v = [sum((cc * b[t] for cc, b in zip(c, basis)), Fraction(0)) for t in range(len(basis[0]))]
        if any(x != 0 for x in v):
            return v
    return None


def _disconnected_pair_witness(system: System, mode: str, pair: tuple[Label, Label]) -> dict[str, Any]:
    """Exact witness of a repeated eigenvalue 0 (disconnected graph): a kernel vector equal on the pair."""
    comps = system.components(mode)
    ci = next(c for c in comps if pair[0] in c)
    if pair[1] in ci:
        v = [Fraction(int(lab in ci)) for lab in system.labels]
    else:
        v = [Fraction(1)] * system.n
    return {
        "reason": _REPEATED_REASON + f" (here 0, the graph has {len(comps)} components)",
        "eigenvalue": 0.0,
        "eigenvalue_exact": Fraction(0),
        "multiplicity": len(comps),
        "pair": list(pair),
        "eigenvector": system.vector_by_label(_unit_floats(v), digits=15),
        "eigenvector_exact": system.vector_by_label(v),
        "difference": 0.0,
    }


def _eigvec_numeric(system: System, mode: str) -> Verdict:
    """Certified numeric decision of (iii) (see :func:`eigenvector_differences_verdict`)."""
    sp = system.spectrum(mode)
    w = sp.values
    n = system.n
    pairs = _pairs(system, mode)
    if not pairs:
        return Verdict(Status.HOLDS, margin=1.0, error_bound=0.0, witness={"note": "the mode changes no link: no pair to check"}, premise="the mode changes no link")
    if n < 2:
        return Verdict(Status.HOLDS, margin=1.0, error_bound=0.0, witness={"note": "a single agent"})
    idx = [tuple(system.idx(p)) for p in pairs]
    ii = np.array([a for a, _ in idx])
    jj = np.array([b for _, b in idx])
    R = sp.rows(np.concatenate([ii, jj]))  # the rows the pairs read (|M| N^2 per factor of a factored spectrum)
    D = np.abs(R[: len(ii)] - R[len(ii) :])  # pairs x N
    cols = list(range(1, n))  # l != 1
    sub = D[:, cols]
    flat = int(np.argmin(sub))
    pk, lk = divmod(flat, len(cols))
    margin = float(sub[pk, lk])
    if len(system.components(mode)) > 1:
        return Verdict(Status.FAILS, margin=0.0, error_bound=0.0, witness=_disconnected_pair_witness(system, mode, pairs[0]))
    multi = [c for c in sp.clusters if len(c) > 1]
    if multi:
        c = multi[0]
        wit = {
            "reason": "eigenvalues l and l+1 may coincide: their gap is within the certified rounding radius",
            "l": c[0] + 1,
            "eigenvalues": [float(w[c[0]]), float(w[c[0] + 1])],
            "pairs_checked": len(pairs),
        }
        note = (
            f"eigenvalues {c[0] + 1} and {c[0] + 2} differ by {float(w[c[0] + 1] - w[c[0]]):.3g} <= 2 rho = "
            f"{2 * sp.error_radius:.3g}: (ii) is not certified, so the eigenvectors are not determined"
        )
        return Verdict(Status.UNDECIDED, margin=margin, error_bound=2 * sp.error_radius, witness=wit, note=note)
    eta = sp.orthogonality_error
    err = np.full(n, math.inf)
    for l in cols:
        # Davis-Kahan: the exact unit eigenvector u_l (sign-aligned) has ||u_hat - u_l|| <= sqrt(2) sin + eta,
        # so the difference of two entries moves by at most sqrt(2) times that
        err[l] = 2.0 * sp.subspace_sine((l,)) + 2.0 * eta + 4.0 * EPS + 2.0 * sp.entry_error
    worst: tuple[float, int, int] | None = None
    for l in cols:
        for p_i in range(len(pairs)):
            d = float(D[p_i, l])
            if not d > err[l]:
                slack = d - err[l]
                if worst is None or slack < worst[0]:
                    worst = (slack, p_i, l)
    if worst is not None:
        _, p_i, l = worst
        wit = {
            "pair": list(pairs[p_i]),
            "l": l + 1,
            "eigenvalue": float(w[l]),
            "entries": [float(R[p_i, l]), float(R[len(ii) + p_i, l])],
            "difference": float(D[p_i, l]),
            "error_bound": float(err[l]),
            "pairs_checked": len(pairs),
        }
        note = (
            f"|u_{l + 1}({pairs[p_i][0]}) - u_{l + 1}({pairs[p_i][1]})| = {float(D[p_i, l]):.3g} is not above its "
            f"Davis-Kahan bound {float(err[l]):.3g}: a difference that is merely small proves no equality"
        )
        return Verdict(Status.UNDECIDED, margin=margin, error_bound=float(err[l]), witness=wit, note=note)
    l = cols[lk]
    wit = {
        "closest": {"pair": list(pairs[pk]), "l": l + 1, "eigenvalue": float(w[l]),
                    "entries": [float(R[pk, l]), float(R[len(ii) + pk, l])], "error_bound": float(err[l])},
        "pairs_checked": len(pairs),
    }
    return Verdict(Status.HOLDS, margin=margin, error_bound=float(np.max(err[1:])), witness=wit)


def _dyadic(x: Any) -> Fraction:
    """An exact binary rational from an arb midpoint or radius."""
    m, e = x.man_exp()
    m, e = int(m), int(e)
    return Fraction(m * 2**e) if e >= 0 else Fraction(m, 2 ** (-e))


def _eval_q(poly: ex.flint.fmpz_poly, x: Fraction) -> Fraction:
    acc = Fraction(0)
    for c in reversed(poly.coeffs()):
        acc = acc * x + int(c)
    return acc


def algebraic_root_witness(factor: ex.flint.fmpq_poly, p0: ex.flint.fmpq_poly) -> dict[str, Any]:
    """A real root of ``factor`` (a factor of ``p0``) as an algebraic number with a certified enclosure.

    The root is isolated with python-flint's ``complex_roots`` (arb ball arithmetic: each
    returned ball provably contains exactly one root), on the irreducible factor of
    ``factor`` that holds it. The enclosure ``[lo, hi]`` is then re-checked in exact rational
    arithmetic: the minimal polynomial changes sign on it. The index of the root among the
    ascending roots of ``p0`` comes from the isolated real roots of ``p0`` (all simple).

    Parameters
    ----------
    factor : fmpq_poly
        Degree >= 1, dividing ``p0``, with only real roots (a factor of a charpoly of a
        symmetric matrix).
    p0 : fmpq_poly
        Squarefree polynomial whose ascending real roots are indexed.

    Returns
    -------
    dict
        ``minimal_polynomial`` (str) with its integer ``coefficients`` (ascending powers),
        ``rational`` (the Fraction, degree 1 only),
        ``enclosure`` ([lo, hi] Fractions, ``lo < root < hi``, a point for a rational root),
        ``approx`` (float) and ``index`` (0-based position among the roots of ``p0``).
    """
    num = factor.numer()
    irreducible = sorted((f for f, _ in num.factor()[1] if f.degree() >= 1), key=lambda f: f.degree())
    f = irreducible[0]
    if f.degree() == 1:
        c = f.coeffs()
        r = Fraction(-int(c[0]), int(c[1]))
        lo = hi = r
        approx = float(r)
    else:
        prec = 64
        while True:
            with_prec = ex.flint.ctx.prec
            ex.flint.ctx.prec = prec
            try:
                roots: list[Any] = [z for z, _ in f.complex_roots()]  # type: ignore[misc, has-type]
            finally:
                ex.flint.ctx.prec = with_prec
            real = [z for z in roots if z.imag.contains(0)]
            z = min(real, key=lambda t: float(t.real.mid()))
            mid, rad = _dyadic(z.real.mid()), _dyadic(z.real.rad())
            lo, hi = mid - rad - Fraction(1, 2**prec), mid + rad + Fraction(1, 2**prec)
            if _eval_q(f, lo) * _eval_q(f, hi) < 0:
                break
            prec *= 2  # pragma: no cover - arb's enclosure was too tight for a sign change
        approx = float(mid)
        r = None
    # index among the roots of p0 (squarefree, all real): arb isolates them in disjoint balls; the
    # ball meeting [lo, hi] is the root's, and the balls below it are the smaller eigenvalues
    below = -1
    prec = 64
    while below < 0:
        saved = ex.flint.ctx.prec
        ex.flint.ctx.prec = prec
        try:
            balls: list[Any] = [zz for zz, _m in p0.numer().complex_roots()]  # type: ignore[misc, has-type]
        finally:
            ex.flint.ctx.prec = saved
        ivs = sorted((_dyadic(z.real.mid()) - _dyadic(z.real.rad()), _dyadic(z.real.mid()) + _dyadic(z.real.rad())) for z in balls)
        meet = [k for k, (a, b) in enumerate(ivs) if a <= hi and lo <= b]
        if len(meet) == 1 and all(ivs[k][1] < ivs[k + 1][0] for k in range(len(ivs) - 1)):
            below = meet[0]
        else:  # pragma: no cover - balls not yet separated at this precision
            prec *= 2
    out: dict[str, Any] = {
        "minimal_polynomial": ex.poly_str(f),
        "coefficients": [int(c) for c in f.coeffs()],
        "enclosure": [lo, hi],
        "approx": approx,
        "index": below,
    }
    if r is not None:
        out["rational"] = r
    return out


def _eigvec_exact(system: System, mode: str, numeric: Verdict) -> Verdict:
    """The exact decision of (iii) (see :func:`eigenvector_differences_verdict`); margin and
    closest pair from the ``numeric`` one."""
    pairs = _pairs(system, mode)
    margin, nwit = numeric.margin, numeric.witness
    if not pairs:
        return Verdict(Status.HOLDS, margin=1.0, witness={"note": "the mode changes no link: no pair to check"}, exact=True, premise="the mode changes no link")
    fast = eigenvector_differences_modular(system, mode)
    if fast is not None:
        st, fwit = fast.status, dict(fast.witness)
        if st is Status.HOLDS:
            fwit = {**fwit, "closest": nwit.get("closest")}
        return Verdict(st, margin=(margin if st is Status.HOLDS else 0.0), witness=fwit, exact=True)
    L = system.laplacian_exact(mode)
    p = ex.charpoly(L)
    if not ex.is_squarefree(p):
        g = ex.repeated_factor(p)
        wit: dict[str, Any] = {"reason": _REPEATED_REASON, "repeated_factor": ex.poly_str(g), "pair": list(pairs[0])}
        i, j = system.idx(pairs[0])
        for mu, basis in _rational_repeated_eigenspaces(system, mode, g):
            v = _exact_equal_pair_vector(basis, i, j)
            if v is not None:
                wit.update(
                    eigenvalue=float(mu), eigenvalue_exact=mu, multiplicity=len(basis),
                    eigenvector=system.vector_by_label(_unit_floats(v), digits=15),
                    eigenvector_exact=system.vector_by_label(v),
                )
                return Verdict(Status.FAILS, margin=0.0, witness=wit, exact=True)
        # irrational repeated eigenvalue: the eigenvector is computed in floating point (approximate)
        sp = system.spectrum(mode)
        groups = [c for c in sp.clusters if len(c) > 1] or [
            (k, k + 1) for k in [int(np.argmin(np.diff(sp.values)))]
        ]
        c = list(groups[0])
        u = _equal_pair_vector(sp.columns(c), i, j)
        wit.update(
            eigenvalue=float(np.mean(sp.values[c])), multiplicity=len(c),
            eigenvector=system.vector_by_label(u, digits=12), eigenvector_note="floating point, approximate",
        )
        return Verdict(Status.FAILS, margin=0.0, witness=wit, exact=True)
    coeffs = p.coeffs()
    if coeffs[0] != 0:  # pragma: no cover - a Laplacian always has the eigenvalue 0
        raise AssertionError("charpoly of a Laplacian must vanish at 0")
    p0 = type(p)(coeffs[1:])  # p(mu) / mu
    sp = system.spectrum(mode)
    for a, b in pairs:
        i, j = system.idx((a, b))
        q = eigenvector_difference_polynomial(L, i, j)
        g = p0.gcd(q)
        if g.degree() >= 1:
            root = algebraic_root_witness(g, p0)
            l = int(root["index"]) + 1  # 0-based among the eigenvalues: the eigenvalue 0 comes first
            return Verdict(Status.FAILS, margin=0.0, exact=True, witness={
                "pair": [a, b],
                "l": l + 1,
                "eigenvalue": root["approx"],
                "eigenvalue_exact": {k: v for k, v in root.items() if k not in ("approx", "index")},
                "common_factor": ex.poly_str(g),
                "entries": [float(x) for x in sp.rows([i, j])[:, l]],
            })
    return Verdict(Status.HOLDS, margin=margin, witness={"pairs_checked": len(pairs), "closest": nwit.get("closest")}, exact=True)


def eigenvector_differences_verdict(system: System, mode: str, exact: bool = False) -> Verdict:
    """Theorem III.3 (iii) for one safe mode: eigenvectors separate every pair of a switching component.

    Numeric (certified): (ii) first (a cluster of the radius rho is undecided, a disconnected
    graph fails); for certified simple eigenvalues every ``|u_l(i) - u_l(j)| > err_l`` (the
    Davis-Kahan bound of the entries) proves it, a smaller difference is undecided; an
    undecided verdict is then tried by
    :func:`~glocal_verify.analysis.laplacian.twins.eigenvector_differences_modular` (exact). Exact: a
    repeated eigenvalue (``gcd(p, p') != 1``) fails, otherwise (iii) fails for (i, j) iff
    ``gcd(p(mu) / mu, q_ij) != 1`` (:func:`eigenvector_difference_polynomial`).

    Parameters
    ----------
    system : System
    mode : str
        A safe mode.
    exact : bool

    Returns
    -------
    Verdict
        Margin ``min |u_l(i) - u_l(j)|`` (floating point), 0 on failure. Witness: on failure
        the pair, ``l``, the eigenvalue and entries (exact: the common factor and
        ``eigenvalue_exact``, :func:`algebraic_root_witness`); on success the closest pair.
    """
    num = _eigvec_numeric(system, mode)
    if exact:
        return _eigvec_exact(system, mode, num)
    if num.status is Status.UNDECIDED:
        fast = eigenvector_differences_modular(system, mode)
        if fast is not None:
            witness = dict(fast.witness)
            note = f"{num.note}; decided exactly: {witness.get('reason') or witness.get('certificate')}"
            margin = num.margin if fast.status is Status.HOLDS else 0.0
            return Verdict(fast.status, margin=margin, error_bound=num.error_bound, witness=witness, note=note)
    return num
