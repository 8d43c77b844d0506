"""Exact rational helpers shared by the proof modules (python-flint underneath).

Matrices cross the boundary as ``sympy.Matrix`` with ``Rational`` entries (what residuals are
made of) and are converted to ``flint.fmpq_mat`` for ranks, kernels and products of larger
instances. Nothing here uses floating point.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Sequence

import flint
import sympy as sp

__all__ = [
    "qmat",
    "smat",
    "rank",
    "nullspace",
    "hstack",
    "vstack",
    "zeros",
    "eye",
    "matpoly",
    "interpolate",
    "qpoly_to_sympy",
    "is_zero_mat",
]


def _fmpq(x: object) -> flint.fmpq:
    if isinstance(x, flint.fmpq):
        return x
    if isinstance(x, int):
        return flint.fmpq(x)
    if isinstance(x, Fraction):
        return flint.fmpq(x.numerator, x.denominator)
    r = sp.Rational(x)  # type: ignore[arg-type]
    if isinstance(x, sp.Basic) and x.has(sp.Float):
        raise TypeError(f"floating-point entry {x}")
    return flint.fmpq(int(r.p), int(r.q))


def qmat(M: object) -> flint.fmpq_mat:
    """A sympy matrix, an ``fmpq_mat`` or nested lists of rationals as ``fmpq_mat``."""
    if isinstance(M, flint.fmpq_mat):
        return M
    if isinstance(M, sp.MatrixBase):
        m, n = M.shape
        return flint.fmpq_mat(m, n, [_fmpq(x) for x in M])
    rows = list(M)  # type: ignore[call-overload]
    m = len(rows)
    n = len(rows[0]) if m else 0
    return flint.fmpq_mat(m, n, [_fmpq(x) for r in rows for x in r])


def smat(M: flint.fmpq_mat) -> sp.Matrix:
    """``fmpq_mat`` as a sympy matrix of ``Rational``."""
    return sp.Matrix(M.nrows(), M.ncols(), [sp.Rational(int(x.p), int(x.q)) for x in M.entries()])


def rank(M: object) -> int:
    """Exact rank over Q."""
    Q = qmat(M)
    if Q.nrows() == 0 or Q.ncols() == 0:
        return 0
    return int(Q.rank())


def nullspace(M: object) -> flint.fmpq_mat:
    """Basis of the right kernel over Q, as the columns of an ``n x k`` matrix."""
    Q = qmat(M)
    n = Q.ncols()
    if Q.nrows() == 0:
        return eye(n)
    R, r = Q.rref()
    pivots: list[int] = []
    for i in range(int(r)):
        for j in range(n):
            if R[i, j] != 0:
                pivots.append(j)
                break
    free = [j for j in range(n) if j not in pivots]
    B = flint.fmpq_mat(n, len(free))
    for c, f in enumerate(free):
        B[f, c] = 1
        for i, p in enumerate(pivots):
            B[p, c] = -R[i, f]
    return B


def zeros(m: int, n: int) -> flint.fmpq_mat:
    return flint.fmpq_mat(m, n)


def eye(n: int) -> flint.fmpq_mat:
    M = flint.fmpq_mat(n, n)
    for i in range(n):
        M[i, i] = 1
    return M


def hstack(blocks: Sequence[flint.fmpq_mat], nrows: int | None = None) -> flint.fmpq_mat:
    """Side by side (``nrows`` needed when ``blocks`` may be empty)."""
    blocks = [b for b in blocks]
    m = blocks[0].nrows() if blocks else (nrows or 0)
    n = sum(b.ncols() for b in blocks)
    out = flint.fmpq_mat(m, n)
    c0 = 0
    for b in blocks:
        for i in range(m):
            for j in range(b.ncols()):
                out[i, c0 + j] = b[i, j]
        c0 += b.ncols()
    return out


def vstack(blocks: Sequence[flint.fmpq_mat], ncols: int | None = None) -> flint.fmpq_mat:
    """One above the other (``ncols`` needed when ``blocks`` may be empty)."""
    blocks = [b for b in blocks]
    n = blocks[0].ncols() if blocks else (ncols or 0)
    m = sum(b.nrows() for b in blocks)
    out = flint.fmpq_mat(m, n)
    r0 = 0
    for b in blocks:
        for i in range(b.nrows()):
            for j in range(n):
                out[r0 + i, j] = b[i, j]
        r0 += b.nrows()
    return out


def matpoly(f: flint.fmpq_poly, M: flint.fmpq_mat) -> flint.fmpq_mat:
    """f(M) by Horner's rule."""
    n = M.nrows()
    coeffs = f.coeffs()
    out = zeros(n, n)
    for c in reversed(coeffs):
        out = out * M + eye(n) * c
    return out


def interpolate(points: Sequence[flint.fmpq], values: Sequence[flint.fmpq]) -> flint.fmpq_poly:
    """The polynomial of degree < len(points) through (points, values) (Lagrange)."""
    x = flint.fmpq_poly([0, 1])
    out = flint.fmpq_poly([0])
    for k, (xk, yk) in enumerate(zip(points, values)):
        term = flint.fmpq_poly([yk])
        for j, xj in enumerate(points):
            if j != k:
                term = term * (x - xj) / (xk - xj)
        out += term
    return out


def qpoly_to_sympy(p: flint.fmpq_poly, var: sp.Symbol) -> sp.Expr:
    """An ``fmpq_poly`` as a sympy polynomial expression in ``var``."""
    return sp.Add(*[sp.Rational(int(c.p), int(c.q)) * var**k for k, c in enumerate(p.coeffs())])


def is_zero_mat(M: flint.fmpq_mat) -> bool:
    return all(x == 0 for x in M.entries())
