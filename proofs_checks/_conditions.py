"""Exact tests of Theorem III.3 (i)-(iii) and Lemma A.2 on small rational instances.

These are the CONDITIONS.md readings, written again here (independently of the library) so
that the proof checks do not depend on code under test:

- (i): Im(dL) ∩ ker S_M = {0}, i.e. rank(S_M dL) = rank(dL);
- (ii): the characteristic polynomial p of L_q is squarefree;
- (iii) for a pair (i, j): gcd(p(mu)/mu, q_ij(mu)) = 1 with
  q_ij(mu) = (e_i - e_j)^T adj(mu I - L_q) (e_i - e_j);
- components D_c: connected components (>= 2 nodes) of the graph of nonzero off-diagonal
  entries of dL (Definition A.1).
"""

from __future__ import annotations

from typing import Sequence

import flint
import networkx as nx
import sympy as sp

from . import _exact as X

__all__ = [
    "condition_i",
    "intersection_dim",
    "squarefree",
    "adjugate_poly_entry",
    "adjugate_poly_matrix",
    "q_ij",
    "condition_iii_pair",
    "switch_components",
    "charpoly",
]

MU = flint.fmpq_poly([0, 1])


def _sel(M: Sequence[int], n: int) -> flint.fmpq_mat:
    S = X.zeros(len(M), n)
    for r, i in enumerate(M):
        S[r, i] = 1
    return S


def intersection_dim(dL: sp.Matrix, M: Sequence[int]) -> int:
    """dim(Im dL ∩ ker S_M), computed directly as rank(dL N) with N a basis of ker(S_M dL)."""
    D = X.qmat(dL)
    n = D.nrows()
    S = _sel(sorted(M), n)
    N = X.nullspace(S * D) if len(M) else X.eye(n)
    return X.rank(D * N) if N.ncols() else 0


def condition_i(dL: sp.Matrix, M: Sequence[int]) -> bool:
    """Theorem III.3 (i) in the reading Im(dL) ∩ ker S_M = {0}."""
    return intersection_dim(dL, M) == 0


def charpoly(L: sp.Matrix) -> flint.fmpq_poly:
    return X.qmat(L).charpoly()


def squarefree(L: sp.Matrix) -> bool:
    """Theorem III.3 (ii): N distinct eigenvalues, exactly (gcd(p, p') = 1)."""
    p = charpoly(L)
    return p.gcd(p.derivative()).degree() <= 0


def adjugate_poly_entry(L: sp.Matrix, u: sp.Matrix, v: sp.Matrix) -> flint.fmpq_poly:
    """u^T adj(mu I - L) v as a polynomial in mu (exact interpolation at N non-eigenvalues)."""
    n = L.shape[0]
    Lq = X.qmat(L)
    uq, vq = X.qmat(u.T), X.qmat(v)
    pts: list[flint.fmpq] = []
    vals: list[flint.fmpq] = []
    k = 0
    while len(pts) < n:
        m = flint.fmpq(2 * k + 1, 3)
        k += 1
        M = X.eye(n) * m - Lq
        d = M.det()
        if d == 0:
            continue
        val = (uq * M.inv() * vq)[0, 0] * d
        pts.append(m)
        vals.append(val)
    return X.interpolate(pts, vals)


def adjugate_poly_matrix(L: sp.Matrix) -> list[list[flint.fmpq_poly]]:
    """All entries of adj(mu I - L) as polynomials in mu (exact interpolation at N points)."""
    n = L.shape[0]
    Lq = X.qmat(L)
    pts: list[flint.fmpq] = []
    adjs: list[flint.fmpq_mat] = []
    k = 0
    while len(pts) < n:
        m = flint.fmpq(2 * k + 1, 3)
        k += 1
        M = X.eye(n) * m - Lq
        d = M.det()
        if d == 0:
            continue
        pts.append(m)
        adjs.append(M.inv() * d)
    return [[X.interpolate(pts, [a[r, c] for a in adjs]) for c in range(n)] for r in range(n)]


def q_ij(L: sp.Matrix, i: int, j: int) -> flint.fmpq_poly:
    """q_ij(mu) = (e_i - e_j)^T adj(mu I - L) (e_i - e_j)."""
    n = L.shape[0]
    d = sp.zeros(n, 1)
    d[i], d[j] = 1, -1
    return adjugate_poly_entry(L, d, d)


def condition_iii_pair(L: sp.Matrix, i: int, j: int) -> bool:
    """Theorem III.3 (iii) for one pair: no nonzero eigenvalue mu_l with u_l(i) = u_l(j)
    (meaningful under (ii))."""
    p = charpoly(L)
    q = q_ij(L, i, j)
    if p.coeffs()[0] == 0:
        p = p // MU
    return p.gcd(q).degree() <= 0


def switch_components(dL: sp.Matrix) -> list[list[int]]:
    """Components D_c (>= 2 nodes) of the graph of nonzero off-diagonal entries of dL."""
    n = dL.shape[0]
    G = nx.Graph()
    for a in range(n):
        for b in range(a + 1, n):
            if dL[a, b] != 0:
                G.add_edge(a, b)
    return sorted(sorted(c) for c in nx.connected_components(G))
