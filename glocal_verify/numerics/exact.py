"""Exact rational linear algebra on top of python-flint.

Matrices are given as row lists of :class:`fractions.Fraction` (or ints) and converted to
``flint.fmpq_mat``; polynomials are ``flint.fmpq_poly``/``fmpz_poly``. No tolerance is
involved anywhere in this module: its answers are the ground truth the numeric checkers are
tested against.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Sequence

import flint

__all__ = [
    "Rows",
    "columns",
    "to_fmpq_mat",
    "to_fraction",
    "rank",
    "nullspace",
    "matmul",
    "select_rows",
    "charpoly",
    "is_squarefree",
    "repeated_factor",
    "poly_str",
    "matvec",
    "at_rational_root",
    "coefficient_bits",
    "observable_rows",
    "row_basis",
]

Rows = Sequence[Sequence[Fraction | int]]


def to_fraction(x: object) -> Fraction:
    """Convert an ``fmpq``/``fmpz``/int/Fraction to :class:`Fraction`."""
    if isinstance(x, Fraction):
        return x
    if isinstance(x, int):
        return Fraction(x)
    if isinstance(x, flint.fmpz):
        return Fraction(int(x))
    if isinstance(x, flint.fmpq):
        return Fraction(int(x.p), int(x.q))
    raise TypeError(f"not an exact number: {x!r}")


def to_fmpq_mat(rows: Rows, ncols: int | None = None) -> flint.fmpq_mat:
    """Rows of rationals as an ``fmpq_mat`` (``ncols`` needed for a matrix with no rows)."""
    m = len(rows)
    n = len(rows[0]) if m else (ncols or 0)
    flat = []
    for r in rows:
        for x in r:
            q = x if isinstance(x, Fraction) else Fraction(x)
            flat.append(flint.fmpq(q.numerator, q.denominator))
    return flint.fmpq_mat(m, n, flat)


def _rows(M: flint.fmpq_mat) -> list[list[Fraction]]:
    return [[to_fraction(M[i, j]) for j in range(M.ncols())] for i in range(M.nrows())]


def rank(rows: Rows, ncols: int | None = None) -> int:
    """Exact rank over Q."""
    if not rows:
        return 0
    return int(to_fmpq_mat(rows, ncols).rank())


def nullspace(rows: Rows, ncols: int | None = None) -> list[list[Fraction]]:
    """Basis of the right kernel over Q, one vector per free column of the RREF."""
    n = len(rows[0]) if rows else (ncols or 0)
    if not rows:
        return [[Fraction(int(i == j)) for i in range(n)] for j in range(n)]
    R, r = to_fmpq_mat(rows, ncols).rref()
    R_rows = _rows(R)[: int(r)]
    pivots: list[int] = []
    for row in R_rows:
        for j, x in enumerate(row):
            if x != 0:
                pivots.append(j)
                break
    free = [j for j in range(n) if j not in pivots]
    basis = []
    for f in free:
        v = [Fraction(0)] * n
        v[f] = Fraction(1)
        for row, p in zip(R_rows, pivots):
            v[p] = -row[f]
        basis.append(v)
    return basis


def matmul(A: Rows, B: Rows) -> list[list[Fraction]]:
    """Exact product A B."""
    if not A or not B:
        return [[] for _ in A]
    return _rows(to_fmpq_mat(A) * to_fmpq_mat(B))


def matvec(A: Rows, v: Sequence[Fraction]) -> list[Fraction]:
    """Exact product A v."""
    return [sum((Fraction(a) * b for a, b in zip(row, v)), Fraction(0)) for row in A]


def select_rows(A: Rows, idx: Sequence[int]) -> list[list[Fraction]]:
    return [[Fraction(x) for x in A[i]] for i in idx]


def charpoly(rows: Rows) -> flint.fmpq_poly:
    """Characteristic polynomial det(x I - A) over Q."""
    return to_fmpq_mat(rows).charpoly()


def is_squarefree(p: flint.fmpq_poly) -> bool:
    """True iff gcd(p, p') is constant (no repeated root over C)."""
    return p.gcd(p.derivative()).degree() <= 0


def repeated_factor(p: flint.fmpq_poly) -> flint.fmpq_poly:
    """gcd(p, p'): its roots are exactly the repeated roots of p."""
    return p.gcd(p.derivative())


def poly_str(p: flint.fmpq_poly | flint.fmpz_poly) -> str:
    """Readable form of a polynomial in ``mu``."""
    return str(p).replace("x", "mu")


def at_rational_root(M: Sequence[Sequence[flint.fmpq_poly]], f: flint.fmpq_poly, ncols: int) -> flint.fmpq_mat:
    """A matrix of polynomials evaluated at the root -f_0 / f_1 of the linear ``f``, over Q.

    Parameters
    ----------
    M : rows of ``fmpq_poly``
    f : fmpq_poly
        Of degree 1.
    ncols : int
        Number of columns (needed when M has no rows).
    """
    c = f.coeffs()
    r = -c[0] / c[1]
    return flint.fmpq_mat(len(M), ncols, [e(r) for row in M for e in row])


def coefficient_bits(polys: Sequence[flint.fmpq_poly]) -> int:
    """Bits of the largest numerator or denominator among the coefficients of ``polys`` (at
    least 1): the precision a ball evaluation needs grows with it.

    Parameters
    ----------
    polys : sequence of fmpq_poly
    """
    bits = 1
    for q in polys:
        bits = max(bits, int(q.denom()).bit_length(), max((abs(int(c)).bit_length() for c in q.numer().coeffs()), default=1))
    return bits


def columns(M: flint.fmpq_mat, idx: Sequence[int]) -> flint.fmpq_mat:
    """The columns ``idx`` of the exact matrix ``M``, in that order (a new ``fmpq_mat``)."""
    out = flint.fmpq_mat(M.nrows(), len(idx))
    for i in range(M.nrows()):
        for c, j in enumerate(idx):
            out[i, c] = M[i, j]
    return out


def row_basis(M: flint.fmpq_mat) -> flint.fmpq_mat:
    """The nonzero rows of the reduced row echelon form of ``M``: a basis of its row space."""
    R, r = M.rref()
    n = M.ncols()
    return flint.fmpq_mat(r, n, [R[i, j] for i in range(r) for j in range(n)])


def observable_rows(A: flint.fmpq_mat, C: flint.fmpq_mat) -> flint.fmpq_mat:
    """A basis of the observable rows of the rational pair (A, C): the Krylov closure of the
    rows of C under A, ``span{C, C A, C A^2, ...}``, grown until its dimension stops rising.
    Its kernel is the unobservable subspace of (A, C) (dimension n minus its rows)."""
    n = A.ncols()
    R = row_basis(C)
    while True:
        X = R * A
        S = flint.fmpq_mat(R.nrows() + X.nrows(), n, [R[i, j] for i in range(R.nrows()) for j in range(n)] + [X[i, j] for i in range(X.nrows()) for j in range(n)])
        B = row_basis(S)
        if B.nrows() == R.nrows():
            return R
        R = B
