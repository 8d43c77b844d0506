"""Exact kernel vectors of sparse rational matrices, found modulo a prime and solved over Q
(Dixon's p-adic solver of python-flint), each verified exactly before it is used."""

from __future__ import annotations

from fractions import Fraction
from typing import Sequence

from flint import fmpq, fmpq_mat, fmpq_poly

from glocal_verify.certificates.encode import mod_residues, pivots_mod
from glocal_verify.model import System

__all__ = ["SparseRows", "apply", "eigenvector_in_field", "fq", "kernel_vectors", "laplacian_rows", "regular_rows"]

#: a sparse rational matrix: one ``{column: value}`` per row
SparseRows = Sequence[dict[int, fmpq]]


def apply(rows: SparseRows, v: Sequence[fmpq]) -> list[fmpq]:
    """``M v`` over Q."""
    return [sum((x * v[j] for j, x in r.items() if v[j] != 0), fmpq(0)) for r in rows]


def kernel_vectors(rows: SparseRows, ncols: int, p: int, limit: int | None = None) -> list[list[fmpq]]:
    """Exact kernel vectors of ``rows`` (one per free column modulo ``p``, at most ``limit``).

    The pivots of the matrix modulo ``p`` give a square block ``M[R, P]`` that is nonsingular
    modulo ``p`` (so over Q); each free column ``j`` gives ``v`` with ``v_j = 1`` and
    ``M[R, P] v_P = -M[R, j]``. A vector is returned only if ``M v = 0`` holds exactly on every
    row (it may fail when the rank over Q exceeds the rank modulo ``p``).
    """
    if ncols == 0:
        return []
    res = [[0] * ncols for _ in rows]
    for i, r in enumerate(rows):
        for j, x in zip(r.keys(), mod_residues(r.values(), p)):
            res[i][j] = x
    R, P = pivots_mod(res, ncols, p) if rows else ([], [])
    free = [j for j in range(ncols) if j not in set(P)][: limit if limit is not None else ncols]
    if not free:
        return []
    k = len(P)
    out = []
    X = None
    if k:
        A = fmpq_mat(k, k)
        B = fmpq_mat(k, len(free))
        for a, i in enumerate(R):
            r = rows[i]
            for b, j in enumerate(P):
                if j in r:
                    A[a, b] = r[j]
            for b, j in enumerate(free):
                if j in r:
                    B[a, b] = -r[j]
        X = A.solve(B, algorithm="dixon")  # type: ignore[call-arg]
    for b, j in enumerate(free):
        v = [fmpq(0)] * ncols
        v[j] = fmpq(1)
        if X is not None:
            for a, c in enumerate(P):
                v[c] = X[a, b]
        if all(x == 0 for x in apply(rows, v)):
            out.append(v)
    return out


def regular_rows(rows: SparseRows, s_at: Sequence[int | None], g: fmpq_poly) -> list[dict[int, fmpq]]:
    """The rational rows of ``(s J + K) v = 0`` over K = Q[s]/(g) (the regular representation).

    Row r of the matrix is ``K_r`` (rational, ``rows[r]``) plus s at column ``s_at[r]`` (None:
    no s). The unknowns are the coordinates ``v_c = sum_{k<d} v_{c,k} s^k`` (d = deg g,
    g = c_0 + ... + c_d s^d), column ``c d + k``. Multiplication by s maps s^k to s^(k+1) for
    k < d - 1 and s^(d-1) to -(c_0 + ... + c_{d-1} s^(d-1)) / c_d, so coefficient k of row r
    (s at column a) is

        sum_c K_rc v_{c,k} + v_{a,k-1} - (c_k / c_d) v_{a,d-1}        (v_{a,-1} = 0).

    A rational kernel vector of these d |rows| rows is a kernel vector over K, nonzero in K when
    nonzero; when g is irreducible K is a field and each nonzero entry is prime to g.
    """
    d = g.degree()
    c = g.coeffs()
    shift = [x / c[d] for x in c[:d]]
    out: list[dict[int, fmpq]] = []
    for r, a in zip(rows, s_at):
        for k in range(d):
            row = {b * d + k: x for b, x in r.items() if x != 0}
            if a is not None:
                if k:
                    row[a * d + k - 1] = row.get(a * d + k - 1, fmpq(0)) + 1
                if shift[k] != 0:
                    row[a * d + d - 1] = row.get(a * d + d - 1, fmpq(0)) - shift[k]
            out.append(row)
    return out


def eigenvector_in_field(rows: SparseRows, g: fmpq_poly, extra: SparseRows, p: int) -> list[fmpq_poly] | None:
    """A nonzero v over K = Q[t]/(g) with ``M v = t v`` and ``E v = 0`` (M = ``rows``, square,
    and E = ``extra``, both rational), or None when none is found: an exact kernel vector
    (:func:`kernel_vectors`, verified exactly) of the regular representation
    (:func:`regular_rows`) of ``[t I - M; E]``, N deg g rational unknowns. For d = 1
    (g = t - mu) it is the kernel of ``[M - mu I; E]`` over Q.
    """
    n, d = len(rows), g.degree()
    neg = [{b: -x for b, x in r.items()} for r in rows]
    big = regular_rows(list(neg) + list(extra), list(range(n)) + [None] * len(extra), g)
    for z in kernel_vectors(big, n * d, p, limit=d):
        return [fmpq_poly([z[a * d + k] for k in range(d)]) for a in range(n)]
    return None


def fq(x: Fraction) -> fmpq:
    """A Fraction as python-flint's ``fmpq``."""
    return fmpq(x.numerator, x.denominator)


def laplacian_rows(system: System, mode: str) -> list[dict[int, fmpq]]:
    """Rows of L_q over Q, ``{column index: entry}`` (diagonal included)."""
    rows: list[dict[int, fmpq]] = [{i: fmpq(0)} for i in range(system.n)]
    for key, w in system.edges(mode).items():
        a, b = sorted(system.index[x] for x in key)
        rows[a][b] = rows[b][a] = -fq(w)
        rows[a][a] += fq(w)
        rows[b][b] += fq(w)
    return rows
