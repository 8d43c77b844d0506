"""A stealthy ZDA proved exactly inside the attacked agents' clusters.

Many genuine zeros of a large network live on a few agents: a leaf on the attacked agent, two
leaves of one hub, a cluster that hangs on the rest of the network by two links. The whole
zero set of the N-sized pencil is then out of reach (the exact elimination is cubic in N, the
numeric deflation gives no proof), but a zero whose direction stays inside the clusters of
the attacked agents is found and proved exactly on those clusters alone.

Reduction (proof)
    A kernel vector (xi, u) of Q_M(s) = [[s I + alpha L_1, -S_F^T], [S_M, 0]] whose xi vanishes
    outside a set S of agents satisfies every row of s I + alpha L_1 outside the closed
    neighbourhood N[S] trivially (those rows read only entries of xi outside S). So with

        Q_S(s) = [[(s I + alpha L_1)[R, S], -S_F^T[R, :]], [S_{M ∩ S}, 0]],   R = N[S] ∪ F,

    a kernel vector of Q_S(s0) padded with zeros is one of Q_M(s0), and one with u != 0 at
    s0 = lambda0^2 + gamma lambda0, lambda0 != 0, is a stealthy ZDA (the velocity outputs
    lambda0 xi_M vanish with xi_M).

Finding the zeros of Q_S (exact)
    Every point where the tall Q_S(s) loses column rank is a root of det(W Q_S(s)) for every
    W (Cauchy-Binet: a combination of its maximal minors). Two random integer W give two
    polynomials over Q (:func:`_det_poly`, one characteristic polynomial each); each
    irreducible factor phi of their gcd, and each factor g(x) of phi(x^2 + gamma x), is then
    tried by elimination over Q[x]/(g)
    (:func:`~glocal_verify.numerics.pencil_exact.kernel_over_field`). A basis vector with a
    nonzero input part proves a stealthy ZDA at every root of g (x = 0 excepted); a spurious
    factor of the gcd only yields no vector. The sign of Re lambda0 is exact
    (:func:`~glocal_verify.numerics.pencil_exact.classify_real_parts`).

S is the union of the clusters of the attacked agents, then of the attacked agents and their
neighbours, each up to ``config.get("local_zero_max_agents")`` agents: the search says nothing
about zeros whose directions leave it.
"""

from __future__ import annotations

import cmath
import random
from collections.abc import Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import flint
import numpy as np

from glocal_verify import config
from glocal_verify.analysis.laplacian.twins import laplacian_entries
from glocal_verify.analysis.stealthy.zda import GROWTH_PERSISTENT, GROWTH_UNBOUNDED, ModalPencil, ZdaZero, normalize_direction
from glocal_verify.derived import Kind
from glocal_verify.errors import ModelError
from glocal_verify.model import System
from glocal_verify.numerics.symmetry import twin_modes
from glocal_verify.numerics.pencil_exact import classify_real_parts, eval_at_root, kernel_over_field, rational_kernel
from glocal_verify.numerics.tolerance import DEFAULT_TOLERANCE, Decision, Tolerance
from glocal_verify.results import growth_of_sign
from glocal_verify.spec.types import NORMAL_MODE, Label

__all__ = ["LocalZeroProof", "prove_local_zero"]

#: the rational s0 of :func:`_rational_candidates` (one list per system: every set tries them)
_LOCAL_ZERO_CANDIDATES_KIND: Kind[tuple[Fraction, ...]] = Kind("local-zero-candidates", __name__, "tuple[Fraction, ...]")

#: seed of the random combinations W (fixed: the same network gets the same proof)
_SEED = 20261206


@dataclass(frozen=True)
class LocalZeroProof:
    """A stealthy ZDA proved exactly inside the attacked agents' clusters.

    Attributes
    ----------
    zero : ZdaZero
        The fastest-growing proven zero: lambda0 (a root of ``minimal_polynomial``, the one
        with the largest real part), its exact growth class, and its direction evaluated from
        the exact kernel vector (xi zero outside ``support``).
    minimal_polynomial : str
        g(x), irreducible over Q.
    support : tuple of labels
        S, the agents where xi may be nonzero.
    where : str
        What S is, for the witness.
    """

    zero: ZdaZero
    minimal_polynomial: str
    support: tuple[Label, ...]
    where: str = "the attacked clusters"

    def text(self) -> str:
        """One line for a witness."""
        lam = self.zero.value
        return (
            f"an exact kernel vector with u0 != 0 of the pencil restricted to the {len(self.support)} agents of {self.where}, "
            f"over Q[x]/({self.minimal_polynomial}): a stealthy ZDA at each of its roots (lambda0 = {lam.real:.6g}{lam.imag:+.6g}j, "
            f"{self.zero.growth}; exact)"
        )


def _fq(x: Fraction) -> flint.fmpq:
    return flint.fmpq(x.numerator, x.denominator)


def _supports(system: System, F: Sequence[Label]) -> list[list[int]]:
    """The candidate sets S, smallest first: the clusters of F, then the clusters of F and its neighbours."""
    out: list[list[int]] = []
    for around in (list(F), [b for a in F for b in (a, *system.neighbours(a))]):
        names: set[str] = set()
        for a in around:
            try:
                names.add(system.cluster_of(a))
            except ModelError:  # an agent in no cluster: no local structure to search
                return out
        S = sorted(system.index[a] for c in system.clusters if c.name in names for a in c.nodes)
        if len(S) <= config.get("local_zero_max_agents") and S not in out:
            out.append(S)
    return out


@dataclass(frozen=True)
class _LocalPencil:
    """Q_S(s) = s B + C of the module docstring: sparse rational rows (column -> entry, nonzero only)."""

    ncols: int
    b: tuple[dict[int, Fraction], ...]
    c: tuple[dict[int, Fraction], ...]

    @property
    def nrows(self) -> int:
        return len(self.b)

    def matrices(self) -> tuple[Any, Any]:
        """(B, C) as fmpq_mat."""
        return self._mat(self.b), self._mat(self.c)

    def at(self, s0: Fraction) -> Any:
        """Q_S(s0) = s0 B + C as an fmpq_mat."""
        M = flint.fmpq_mat(self.nrows, self.ncols)
        for i, (brow, crow) in enumerate(zip(self.b, self.c)):
            for j in brow.keys() | crow.keys():
                v = s0 * brow.get(j, 0) + crow.get(j, 0)
                if v:
                    M[i, j] = _fq(v)
        return M

    def residues(self, phi: Any) -> list[list[Any]]:
        """Q_S(x) modulo ``phi``, entry by entry (fmpq_poly)."""
        zero = flint.fmpq_poly(0)
        out = []
        for brow, crow in zip(self.b, self.c):
            row = [zero] * self.ncols
            for j in brow.keys() | crow.keys():
                row[j] = flint.fmpq_poly([_fq(Fraction(crow.get(j, 0))), _fq(Fraction(brow.get(j, 0)))]) % phi
            out.append(row)
        return out

    def _mat(self, rows: Sequence[dict[int, Fraction]]) -> Any:
        M = flint.fmpq_mat(self.nrows, self.ncols)
        for i, row in enumerate(rows):
            for j, v in row.items():
                M[i, j] = _fq(v)
        return M


def _local_pencil(system: System, F: Sequence[int], S: Sequence[int]) -> _LocalPencil:
    """Q_S(s) = s B + C of the module docstring (rows R = N[S] ∪ F, then the monitors in S)."""
    ent = laplacian_entries(system, NORMAL_MODE)
    col = {k: c for c, k in enumerate(S)}
    m, ncols = len(F), len(S) + len(F)
    touching: dict[int, list[tuple[int, Fraction]]] = {}
    for (i, j), w in ent.items():
        if j in col:
            touching.setdefault(i, []).append((j, w))
    a = system.alpha_q
    B: list[dict[int, Fraction]] = []
    C: list[dict[int, Fraction]] = []
    for i in sorted(set(touching) | set(F)):
        b: dict[int, Fraction] = {}
        c: dict[int, Fraction] = {}
        for j, w in touching.get(i, ()):
            c[col[j]] = c.get(col[j], Fraction(0)) + a * w
        if i in col:
            b[col[i]] = Fraction(1)
        for k in range(m):
            if F[k] == i:
                c[len(S) + k] = Fraction(-1)
        B.append(b)
        C.append({j: v for j, v in c.items() if v})
    for mon in system.idx(system.monitored):
        if mon in col:
            B.append({})
            C.append({col[mon]: Fraction(1)})
    return _LocalPencil(ncols, tuple(B), tuple(C))


def _det_poly(B: Any, C: Any) -> Any:
    """det(s B + C) for square fmpq_mat B, C, as an fmpq_poly (None if it vanishes identically or no shift is found).

    With C' = sigma B + C invertible, det(s B + C) = det(C') det(I - (s - sigma) K),
    K = -C'^-1 B, and det(I - t K) = t^c chi_K(1/t) is the reversed characteristic polynomial.
    """
    c = B.nrows()
    for sigma in range(c + 1):  # det(sigma B + C) has degree <= c in sigma: c + 1 roots make it vanish identically
        Cs = B * sigma + C
        d = Cs.det()
        if d != 0:
            K = -(Cs.solve(B))
            chi = K.charpoly()
            rev = flint.fmpq_poly(list(reversed(chi.coeffs())) + [0] * (c + 1 - len(chi.coeffs())))
            return rev(flint.fmpq_poly([-sigma, 1])) * d
    return None


def prove_local_zero(system: System, F: tuple[Label, ...], tol: Tolerance = DEFAULT_TOLERANCE) -> LocalZeroProof | None:
    """The fastest-growing stealthy ZDA found inside the clusters of F, or at a known rational s0, proved exactly; or None.

    First the clusters of F, then those of F and its neighbours (:func:`_supports`); then, at
    each rational s0 where a mode of L_1 vanishes off a few agents (:func:`_rational_candidates`:
    twin eigenvalues, leaves of a monitored agent), the support of the computed direction
    with its neighbours: such a zero's direction may spread over hundreds of agents (175 at
    N = 1000 on the benchmark network).

    Parameters
    ----------
    system : System
    F : tuple of labels
        The attacked actuators.
    tol : Tolerance
        Only to compute and cut the candidate direction of the last step (nothing numeric
        enters the proof).

    Returns
    -------
    LocalZeroProof or None
        None proves nothing.
    """
    Fi = system.idx(F)
    for S in _supports(system, F):
        found = _fastest_local_zero(system, Fi, S)
        if found is not None:
            return found
    for s0 in _rational_candidates(system):
        found = _zero_at(system, F, s0, tol)
        if found is not None:
            return found
    return None


def _fastest_local_zero(system: System, Fi: Sequence[int], S: Sequence[int]) -> LocalZeroProof | None:
    """:func:`prove_local_zero` on one candidate set S: every zero of Q_S, the fastest proved one."""
    Q = _local_pencil(system, Fi, S)
    r, ncols = Q.nrows, Q.ncols
    if r < ncols:
        return None
    rng = random.Random(_SEED)
    Bm, Cm = Q.matrices()
    g = None
    for _ in range(2):
        W = flint.fmpq_mat(ncols, r, [rng.randint(-3, 3) for _ in range(ncols * r)])
        d = _det_poly(W * Bm, W * Cm)
        if d is None:
            return None
        g = d if g is None else g.gcd(d)
    assert g is not None
    if g.degree() <= 0:
        return None
    best: LocalZeroProof | None = None
    for phi, _ in g.factor()[1]:
        pr = _proof_at(system, Fi, S, Q, phi, "the attacked clusters")
        if pr is not None and (best is None or _speed(pr) > _speed(best)):
            best = pr
    return best


def _speed(pr: LocalZeroProof) -> tuple[int, float]:
    return {GROWTH_UNBOUNDED: 1, GROWTH_PERSISTENT: 0}.get(pr.zero.growth, -1), pr.zero.value.real


def _proof_at(system: System, Fi: Sequence[int], S: Sequence[int], Q: _LocalPencil, phi: Any, where: str) -> LocalZeroProof | None:
    """A kernel vector of Q_S with u != 0 over Q[s]/(phi) (phi irreducible), as a proof at the fastest root lambda0; or None.

    Every root lambda of a factor psi(x) of phi(x^2 + gamma x) other than x has s(lambda) a
    root of phi, so the kernel vector over Q[s]/(phi) is one at lambda (lambda != 0).
    """
    if phi.degree() == 1:  # Q[s]/(phi) = Q: one rational elimination (the same basis, the RREF being unique)
        c = phi.coeffs()
        r = -c[0] / c[1]
        K = rational_kernel(Q.at(Fraction(int(r.p), int(r.q))))
        basis = tuple(tuple(flint.fmpq_poly([K[i, col]]) for i in range(Q.ncols)) for col in range(K.ncols()))
    else:
        basis = kernel_over_field(Q.residues(phi), phi, Q.ncols).basis
    vec = next((v for v in basis if any(not e.is_zero() for e in v[len(S):])), None)
    if vec is None:
        return None
    x = flint.fmpq_poly([0, 1])
    s_of_x = x * x + _fq(system.gamma_q) * x
    best: tuple[int, float, Any, complex] | None = None
    for psi, _ in phi(s_of_x).factor()[1]:
        if psi == x:
            continue  # lambda0 = 0: other outputs, decided elsewhere
        root, sign = max(classify_real_parts(psi), key=lambda rs: (rs[1], rs[0].real))
        if best is None or (sign, root.real) > best[:2]:
            best = (sign, root.real, psi, root)
    if best is None:
        return None
    sign, _, psi, root = best
    lam = complex(root)
    s_val = lam * lam + system.gamma * lam
    v = eval_at_root(list(vec), phi, s_val)
    xi = np.zeros(system.n, dtype=complex)
    xi[list(S)] = v[: len(S)]
    xi_n, u_n = normalize_direction(xi, np.asarray(v[len(S):]))
    z = ZdaZero(lam, s_val, xi_n, u_n, 0.0, growth_of_sign(sign))
    return LocalZeroProof(z, str(psi), tuple(system.labels[k] for k in S), where)


def _rational_candidates(system: System) -> tuple[Fraction, ...]:
    """:func:`_candidates_of`, kept on the system."""
    return _LOCAL_ZERO_CANDIDATES_KIND.get(system, (), lambda: _candidates_of(system))


def _candidates_of(system: System) -> tuple[Fraction, ...]:
    """Rational s0 = -alpha mu where L_1 has a mode on a few agents: twin eigenvalues, leaves of a monitored agent.

    At such an s0 the grounded matrix s I + alpha L_1[U, U] is singular with a kernel off most
    agents, and zeros of the pencil with u != 0 are common there (a leaf on a hub, two leaves
    of one hub); the minors' common factor on the benchmark network of 1000 agents was s + 1
    for about a fifth of its agents.
    """
    out: list[Fraction] = []
    a = system.alpha_q
    ent = laplacian_entries(system, NORMAL_MODE)
    for mu, _pairs in twin_modes(system.n, ent, system.idx(system.monitored)):
        out.append(-a * Fraction(mu))
    monitored = set(system.monitored)
    for m in system.monitored:  # in the spec's order: the same candidates, and proof, every run
        for b in system.neighbours(m):
            if b not in monitored and all(c in monitored for c in system.neighbours(b)):
                i = system.index[b]
                out.append(-a * ent[(i, i)])  # its only mode in U: s0 = -alpha (weighted degree)
    return tuple(s0 for s0 in dict.fromkeys(out) if s0 != 0)


def _zero_at(system: System, F: tuple[Label, ...], s0: Fraction, tol: Tolerance) -> LocalZeroProof | None:
    """A stealthy ZDA at the rational s0, on the support of the computed direction and its neighbours."""
    gamma = system.gamma
    lam = (-gamma + cmath.sqrt(gamma * gamma + 4 * float(s0))) / 2
    found = ModalPencil(system, F, tol).direction(lam)[0]
    if found is None or found[3] is not Decision.ZERO or found[4] is not Decision.NONZERO:
        return None
    xi = np.abs(np.asarray(found[0]))
    big = float(np.max(xi, initial=0.0))
    core = [int(k) for k in np.flatnonzero(xi > tol.rtol * big)] if big > 0 else []
    ring = {int(j) for k in core for j in system.idx(system.neighbours(system.labels[k]))}
    S = sorted(set(core) | ring)
    if not core or len(S) > config.get("local_zero_support_max_agents"):
        return None
    Fi = system.idx(F)
    return _proof_at(system, Fi, S, _local_pencil(system, Fi, S), flint.fmpq_poly([_fq(-s0), 1]), "the support of the computed direction")
