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

import random
from collections.abc import Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import flint
import numpy as np

from glocal_verify import config
from glocal_verify.analysis.twins import laplacian_entries
from glocal_verify.analysis.zda import GROWTH_DECAYING, GROWTH_PERSISTENT, GROWTH_UNBOUNDED, ZdaZero, normalize_direction
from glocal_verify.errors import ModelError
from glocal_verify.model import System
from glocal_verify.numerics.pencil_exact import classify_real_parts, eval_at_root, kernel_over_field
from glocal_verify.spec.types import NORMAL_MODE, Label

__all__ = ["LocalZeroProof", "prove_local_zero"]

_GROWTH_BY_SIGN = {1: GROWTH_UNBOUNDED, 0: GROWTH_PERSISTENT, -1: GROWTH_DECAYING}
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
    """

    zero: ZdaZero
    minimal_polynomial: str
    support: tuple[Label, ...]

    def text(self) -> str:
        """One line for a witness."""
        lam = self.zero.value
        return (
            f"an exact kernel vector with u0 != 0 of the pencil restricted to the {len(self.support)} agents of the attacked clusters, "
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


def _local_pencil(system: System, F: Sequence[int], S: Sequence[int]) -> tuple[list[list[Fraction]], list[list[Fraction]]]:
    """Q_S(s) = s B + C of the module docstring, as rational rows (B, C)."""
    ent = laplacian_entries(system, NORMAL_MODE)
    col = {k: c for c, k in enumerate(S)}
    m, ncols = len(F), len(S) + len(F)
    touching: dict[int, list[tuple[int, Fraction]]] = {}
    for (i, j), w in ent.items():
        if j in col:
            touching.setdefault(i, []).append((j, w))
    a = system.alpha_q
    B: list[list[Fraction]] = []
    C: list[list[Fraction]] = []
    for i in sorted(set(touching) | set(F)):
        b, c = [Fraction(0)] * ncols, [Fraction(0)] * ncols
        for j, w in touching.get(i, ()):
            c[col[j]] += a * w
        if i in col:
            b[col[i]] = Fraction(1)
        for k in range(m):
            if F[k] == i:
                c[len(S) + k] = Fraction(-1)
        B.append(b)
        C.append(c)
    for mon in system.idx(system.monitored):
        if mon in col:
            B.append([Fraction(0)] * ncols)
            C.append([Fraction(int(c == col[mon])) for c in range(ncols)])
    return B, C


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


def prove_local_zero(system: System, F: tuple[Label, ...]) -> LocalZeroProof | None:
    """The fastest-growing stealthy ZDA whose direction stays in the clusters of F, proved exactly, or None.

    Parameters
    ----------
    system : System
    F : tuple of labels
        The attacked actuators.

    Returns
    -------
    LocalZeroProof or None
        None proves nothing (no such zero, clusters too large, or an agent of F in no cluster).
    """
    for S in _supports(system, F):
        found = _fastest_local_zero(system, system.idx(F), S)
        if found is not None:
            return found
    return None


def _fastest_local_zero(system: System, Fi: Sequence[int], S: Sequence[int]) -> LocalZeroProof | None:
    """:func:`prove_local_zero` on one candidate set S."""
    Bq, Cq = _local_pencil(system, Fi, S)
    r, ncols = len(Bq), len(S) + len(Fi)
    if r < ncols:
        return None
    rng = random.Random(_SEED)
    Bm = flint.fmpq_mat(r, ncols, [_fq(x) for row in Bq for x in row])
    Cm = flint.fmpq_mat(r, ncols, [_fq(x) for row in Cq for x in row])
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
    x = flint.fmpq_poly([0, 1])
    s_of_x = x * x + _fq(system.gamma_q) * x
    rows = [[flint.fmpq_poly(_fq(c)) + (s_of_x if b else 0) for b, c in zip(brow, crow)] for brow, crow in zip(Bq, Cq)]
    best: tuple[int, float, Any, Any, complex] | None = None
    for phi, _ in g.factor()[1]:
        for psi, _ in phi(s_of_x).factor()[1]:
            if psi == x:
                continue  # lambda0 = 0: other outputs, decided elsewhere
            basis = kernel_over_field([[e % psi for e in row] for row in rows], psi, ncols).basis
            vec = next((v for v in basis if any(not e.is_zero() for e in v[len(S):])), None)
            if vec is None:
                continue
            root, sign = max(classify_real_parts(psi), key=lambda rs: (rs[1], rs[0].real))
            if best is None or (sign, root.real) > best[:2]:
                best = (sign, root.real, psi, vec, root)
    if best is None:
        return None
    sign, _, psi, vec, root = best
    v = eval_at_root(list(vec), psi, root)
    xi = np.zeros(system.n, dtype=complex)
    xi[S] = v[: len(S)]
    xi_n, u_n = normalize_direction(xi, np.asarray(v[len(S):]))
    gamma = system.gamma
    z = ZdaZero(complex(root), complex(root) ** 2 + gamma * complex(root), xi_n, u_n, 0.0, _GROWTH_BY_SIGN[sign])
    return LocalZeroProof(z, str(psi), tuple(system.labels[k] for k in S))
