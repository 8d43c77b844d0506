"""Small exact instances of the paper's model (eq. ``cl_sys``) for the proof checks.

Agents are 0-based in code; notes and docstrings speak of agents 1..N (the paper's labels).
All numbers are ``sympy.Rational``; random instances come from a seeded ``random.Random``
so that every run checks the same graphs.
"""

from __future__ import annotations

import random
from typing import Iterable, Mapping, Sequence

import sympy as sp

__all__ = [
    "Edges",
    "laplacian",
    "selection",
    "state_matrix",
    "input_matrix",
    "output_matrix",
    "path",
    "complete",
    "star",
    "cycle",
    "random_edges",
    "WEIGHTS",
    "noncomm",
    "block_diag_nc",
]

Edges = Mapping[tuple[int, int], sp.Rational]

#: Rational edge weights used by random instances.
WEIGHTS: tuple[sp.Rational, ...] = tuple(sp.Rational(x) for x in ("1", "2", "3", "1/2", "2/3", "3/2", "5/4"))


def laplacian(n: int, edges: Edges) -> sp.Matrix:
    """L with l_ii = sum_j a_ij and l_ij = -a_ij for the undirected weighted edges given."""
    L = sp.zeros(n, n)
    for (i, j), w in edges.items():
        L[i, j] -= w
        L[j, i] -= w
        L[i, i] += w
        L[j, j] += w
    return L


def selection(idx: Sequence[int], n: int) -> sp.Matrix:
    """S_X: rows e_i^T for i in ``idx`` (a 0 x n matrix when ``idx`` is empty)."""
    S = sp.zeros(len(idx), n)
    for r, i in enumerate(idx):
        S[r, i] = 1
    return S


def state_matrix(L: sp.Matrix, alpha: sp.Expr, gamma: sp.Expr) -> sp.Matrix:
    """A = [[0, I], [-alpha L, -gamma I]] (eq. ``cl_sys``)."""
    n = L.shape[0]
    return sp.Matrix(sp.BlockMatrix([[sp.zeros(n, n), sp.eye(n)], [-alpha * L, -gamma * sp.eye(n)]]))


def input_matrix(F: Sequence[int], n: int) -> sp.Matrix:
    """B = [0; S_F^T] (eq. ``cl_sys``)."""
    return sp.Matrix.vstack(sp.zeros(n, len(F)), selection(F, n).T)


def output_matrix(Mx: Sequence[int], Mv: Sequence[int], n: int) -> sp.Matrix:
    """C = blkdiag(S_{M_x}, S_{M_v}) (eqs. ``cl_sys``, ``measurments``)."""
    return sp.Matrix(
        sp.BlockMatrix(
            [
                [selection(Mx, n), sp.zeros(len(Mx), n)],
                [sp.zeros(len(Mv), n), selection(Mv, n)],
            ]
        )
    ) if (Mx or Mv) else sp.zeros(0, 2 * n)


def path(n: int, w: sp.Rational = sp.Integer(1)) -> dict[tuple[int, int], sp.Rational]:
    return {(i, i + 1): w for i in range(n - 1)}


def cycle(n: int) -> dict[tuple[int, int], sp.Rational]:
    e = path(n)
    e[(0, n - 1)] = sp.Integer(1)
    return e


def complete(n: int) -> dict[tuple[int, int], sp.Rational]:
    return {(i, j): sp.Integer(1) for i in range(n) for j in range(i + 1, n)}


def star(n: int) -> dict[tuple[int, int], sp.Rational]:
    return {(0, j): sp.Integer(1) for j in range(1, n)}


def random_edges(rng: random.Random, n: int, p: float, weights: Iterable[sp.Rational] = WEIGHTS) -> dict[tuple[int, int], sp.Rational]:
    """An Erdos-Renyi edge set with rational weights (may be disconnected)."""
    ws = list(weights)
    return {(i, j): rng.choice(ws) for i in range(n) for j in range(i + 1, n) if rng.random() < p}


def noncomm(names: str) -> tuple[sp.Symbol, ...]:
    """Non-commutative symbols: matrix blocks of any conforming size (1 is the identity)."""
    out = sp.symbols(names, commutative=False)
    return out if isinstance(out, tuple) else (out,)


def block_diag_nc(*blocks: sp.Expr) -> sp.Matrix:
    """Block-diagonal matrix of non-commutative blocks."""
    k = len(blocks)
    M = sp.zeros(k, k)
    for i, b in enumerate(blocks):
        M[i, i] = b
    return M
