"""Subspaces over Q with python-flint: row bases, kernels, closures under a matrix, annihilators."""

from __future__ import annotations

from fractions import Fraction
from typing import Any, Sequence

import flint

__all__ = [
]

# --------------------------------------------------------------------------------------------
# exact (rational) subspaces


def _qmat(rows: Sequence[Sequence[Fraction | int]], ncols: int) -> flint.fmpq_mat:
    flat = []
    for r in rows:
        for x in r:
            q = x if isinstance(x, Fraction) else Fraction(x)
            flat.append(flint.fmpq(q.numerator, q.denominator))
    return flint.fmpq_mat(len(rows), ncols, flat)


def _vstack(mats: Sequence[flint.fmpq_mat], ncols: int) -> flint.fmpq_mat:
    entries: list[Any] = []
    m = 0
    for M in mats:
        if M.nrows():
            entries.extend(M.entries())
            m += M.nrows()
    return flint.fmpq_mat(m, ncols, entries)


def _row_basis(M: flint.fmpq_mat) -> flint.fmpq_mat:
    """RREF rows spanning the row space of M (no zero rows)."""
    n = M.ncols()
    if M.nrows() == 0:
        return flint.fmpq_mat(0, n, [])
    R, r = M.rref()
    r = int(r)
    return flint.fmpq_mat(r, n, R.entries()[: r * n])


def _row_closure(R0: flint.fmpq_mat, mats: Sequence[flint.fmpq_mat]) -> flint.fmpq_mat:
    """Smallest row space containing R0's rows and closed under right multiplication by each matrix.

    Its kernel is the largest subspace of ker(R0) invariant under every matrix.
    """
    n = R0.ncols()
    B = _row_basis(R0)
    while True:
        r = B.nrows()
        if r == n or r == 0:
            return B
        new = [B * M for M in mats]
        B2 = _row_basis(_vstack([B, *new], n))
        if B2.nrows() == r:
            return B
        B = B2


def _kernel(R: flint.fmpq_mat) -> flint.fmpq_mat:
    """Basis of the right kernel of R as the columns of an ``n x k`` matrix."""
    n = R.ncols()
    if R.nrows() == 0:
        return flint.fmpq_mat(n, n, [int(i == j) for i in range(n) for j in range(n)])
    E, r = R.rref()
    r = int(r)
    rows = E.tolist()[:r]
    pivots = []
    for row in rows:
        for j, x in enumerate(row):
            if x != 0:
                pivots.append(j)
                break
    free = [j for j in range(n) if j not in set(pivots)]
    K = flint.fmpq_mat(n, len(free), [0] * (n * len(free)))
    for c, f in enumerate(free):
        K[f, c] = 1
        for row, p in zip(rows, pivots):
            K[p, c] = -row[f]
    return K


def _annihilator(X: flint.fmpq_mat) -> flint.fmpq_mat:
    """Rows spanning the orthogonal complement of the column space of X."""
    K = _kernel(X.transpose())
    return K.transpose()


def _cols_closure(X: flint.fmpq_mat, A: flint.fmpq_mat) -> flint.fmpq_mat:
    """Smallest A-invariant subspace containing the columns of X (as columns)."""
    if X.ncols() == 0:
        return X
    return _row_basis(_row_closure(X.transpose(), [A.transpose()])).transpose()


def _to_fraction_cols(K: flint.fmpq_mat) -> list[list[Fraction]]:
    out = []
    for c in range(K.ncols()):
        out.append([Fraction(int(K[r, c].p), int(K[r, c].q)) for r in range(K.nrows())])
    return out
