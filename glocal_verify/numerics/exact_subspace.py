"""Subspaces over Q with python-flint: row bases, kernels, closures under a matrix, annihilators,
and exact kernel vectors recovered from float candidates."""

from __future__ import annotations

from glocal_verify import config

import math
from fractions import Fraction
from typing import Any, Sequence

import flint
import numpy as np

__all__ = [
    "annihilator",
    "cols_closure",
    "kernel_basis",
    "qmat",
    "rational_kernel_vector",
    "rationalised",
    "row_basis",
    "row_closure",
    "stack_rows",
    "to_fraction_cols",
]

# --------------------------------------------------------------------------------------------
# exact (rational) subspaces


def qmat(rows: Sequence[Sequence[Fraction | int]], ncols: int) -> flint.fmpq_mat:
    """The rational matrix with the given rows (``ncols`` columns, also when there are no rows)."""
    flat: list[Any] = []
    for r in rows:
        for x in r:
            if not x:
                flat.append(0)
            elif isinstance(x, Fraction):
                flat.append(x.numerator if x.denominator == 1 else flint.fmpq(x.numerator, x.denominator))
            else:
                flat.append(flint.fmpq(x))
    return flint.fmpq_mat(len(rows), ncols, flat)


def stack_rows(mats: Sequence[flint.fmpq_mat], ncols: int) -> flint.fmpq_mat:
    """The rows of ``mats`` stacked into one matrix of ``ncols`` columns."""
    entries: list[Any] = []
    m = 0
    for M in mats:
        if M.nrows():
            entries.extend(M.entries())
            m += M.nrows()
    return flint.fmpq_mat(m, ncols, entries)


def row_basis(M: flint.fmpq_mat) -> flint.fmpq_mat:
    """RREF rows spanning the row space of M (no zero rows)."""
    n = M.ncols()
    if M.nrows() == 0:
        return flint.fmpq_mat(0, n, [])
    R, r = M.rref()
    r = int(r)
    return flint.fmpq_mat(r, n, R.entries()[: r * n])


def row_closure(R0: flint.fmpq_mat, mats: Sequence[flint.fmpq_mat]) -> flint.fmpq_mat:
    """Smallest row space containing R0's rows and closed under right multiplication by each matrix.

    Its kernel is the largest subspace of ker(R0) invariant under every matrix. Returned as its
    reduced row echelon form (unique for the row space, so independent of the method).

    Method: the closure modulo word-sized primes (:func:`_closure_mod`), lifted by the Chinese
    remainder theorem and rational reconstruction to a candidate RREF over Q, which is then
    *proved* (:func:`_lift_closure`): its kernel K satisfies R0 K = 0 and M K = K T for every
    matrix M exactly, so ker K^perp is an invariant subspace of ker R0 of dimension n - r, while
    the rank r_p of the closure mod p is at most the rank over Q (reduction mod p of integer
    vectors cannot raise rank), so dim of the largest invariant subspace is at most n - r_p = n - r.
    When no candidate is proved within ``max_primes`` (:mod:`glocal_verify.config`) primes, the dense rational iteration
    (:func:`_row_closure_direct`) decides. No tolerance either way.
    """
    n = R0.ncols()
    if n and R0.nrows() and mats and all(M.nrows() == n and M.ncols() == n for M in mats):
        lifted = _lift_closure(R0, mats)
        if lifted is not None:
            return lifted
    return _row_closure_direct(R0, mats)


def _row_closure_direct(R0: flint.fmpq_mat, mats: Sequence[flint.fmpq_mat]) -> flint.fmpq_mat:
    """:func:`row_closure` by dense rational elimination (RREF of the stacked products per step)."""
    n = R0.ncols()
    B = row_basis(R0)
    while True:
        r = B.nrows()
        if r == n or r == 0:
            return B
        new = [B * M for M in mats]
        B2 = row_basis(stack_rows([B, *new], n))
        if B2.nrows() == r:
            return B
        B = B2


def kernel_basis(R: flint.fmpq_mat) -> flint.fmpq_mat:
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


def annihilator(X: flint.fmpq_mat) -> flint.fmpq_mat:
    """Rows spanning the orthogonal complement of the column space of X."""
    K = kernel_basis(X.transpose())
    return K.transpose()


def cols_closure(X: flint.fmpq_mat, A: flint.fmpq_mat) -> flint.fmpq_mat:
    """Smallest A-invariant subspace containing the columns of X (as columns)."""
    if X.ncols() == 0:
        return X
    return row_basis(row_closure(X.transpose(), [A.transpose()])).transpose()


def to_fraction_cols(K: flint.fmpq_mat) -> list[list[Fraction]]:
    """The columns of ``K`` as lists of Fractions."""
    out = []
    for c in range(K.ncols()):
        out.append([Fraction(int(K[r, c].p), int(K[r, c].q)) for r in range(K.nrows())])
    return out


# --------------------------------------------------------------------------------------------
# closure modulo primes, lifted to Q and proved


def _primes_below(bound: int, count: int) -> list[int]:
    """The ``count`` largest primes below ``bound`` (deterministic)."""
    out: list[int] = []
    q = bound - 1
    while len(out) < count and q > 2:
        if flint.fmpz(q).is_prime():
            out.append(q)
        q -= 1
    return out


def _int_entries(M: flint.fmpq_mat) -> tuple[list[int], int, int]:
    """Integer entries (row-major) of ``d M`` for the common denominator d, with the shape."""
    Z, _d = M.numer_denom()
    return [int(x) for x in Z.entries()], M.nrows(), M.ncols()


def _mod_array(ints: tuple[list[int], int, int], p: int) -> np.ndarray:
    vals, m, n = ints
    return np.array([x % p for x in vals], dtype=np.float64).reshape(m, n)


def _rref_mod(X: np.ndarray, p: int) -> tuple[np.ndarray, list[int]]:
    """RREF over GF(p) of a float64 matrix of integers in [0, p): its nonzero rows and pivots.

    Exact in float64 while n p^2 < 2^53 (every product and sum is an integer below 2^53).
    """
    X = X.copy()
    c, n = X.shape
    piv: list[int] = []
    r, col0 = 0, 0
    while r < c and col0 < n:
        cols = np.flatnonzero(X[r:, col0:].any(axis=0))
        if cols.size == 0:
            break
        col = col0 + int(cols[0])
        k = r + int(np.flatnonzero(X[r:, col])[0])
        if k != r:
            X[[r, k]] = X[[k, r]]
        X[r] = X[r] * float(pow(int(X[r, col]), -1, p)) % p
        f = X[:, col].copy()
        f[r] = 0
        if f.any():
            X = (X - np.outer(f, X[r]) % p) % p
        piv.append(col)
        r += 1
        col0 = col + 1
    return X[:r], piv


def _closure_mod(R0: np.ndarray, mats: Sequence[np.ndarray], p: int) -> tuple[np.ndarray, list[int]]:
    """RREF over GF(p) of the smallest row space containing R0 and closed under each matrix.

    Frontier iteration: only the rows new in a step are multiplied in the next one (E_{k+1} =
    E_k + F_k M spans E_k M when F_k spans E_k modulo E_{k-1}). float64 arrays of residues;
    exact while n p^2 < 2^53.
    """
    n = R0.shape[1]
    E, P = _rref_mod(R0, p)
    F = E
    while F.shape[0] and len(P) < n:
        cand = np.vstack([F @ M % p for M in mats])
        if P:
            cand = (cand - cand[:, P] @ E % p) % p
        G, Q = _rref_mod(cand, p)
        if not Q:
            break
        E = (E - E[:, Q] @ G % p) % p if P else E
        E = np.vstack([E, G]) if P else G
        P = P + Q
        order = np.argsort(P)
        E = E[order]
        P = [P[i] for i in order]
        F = G
    return E, P


def _ratrecon(a: int, m: int) -> Fraction | None:
    """The fraction u/v = a mod m with |u|, |v| <= sqrt(m / 2), or None (Wang's reconstruction)."""
    if a == 0:
        return Fraction(0)
    bound = math.isqrt(m // 2)
    r0, r1, s0, s1 = m, a % m, 0, 1
    while r1 > bound:
        q = r0 // r1
        r0, r1 = r1, r0 - q * r1
        s0, s1 = s1, s0 - q * s1
    if s1 == 0 or abs(s1) > bound or math.gcd(s1, m) != 1:
        return None
    return Fraction(r1, s1)


def _lift_closure(R0: flint.fmpq_mat, mats: Sequence[flint.fmpq_mat], primes: Sequence[int] | None = None) -> flint.fmpq_mat | None:
    """The closure of :func:`row_closure` via primes, proved over Q; None when not proved.

    ``primes`` (default the ``max_primes`` (:mod:`glocal_verify.config`) largest below sqrt(2^53 / (n + 2))) must keep
    n p^2 < 2^53; any primes are sound (unlucky ones only delay or prevent the proof).
    """
    n = R0.ncols()
    R0i = _int_entries(R0)
    Mi = [_int_entries(M) for M in mats]
    if primes is None:
        primes = _primes_below(math.isqrt((1 << 53) // (n + 2)), config.get("max_primes"))
    best: tuple[int, tuple[int, ...]] | None = None
    residues: list[list[int]] = []
    modulus = 1
    free: list[int] = []
    cand: list[list[Fraction]] | None = None
    for p in primes:
        E, P = _closure_mod(_mod_array(R0i, p), [_mod_array(M, p) for M in Mi], p)
        key = (len(P), tuple(P))
        if len(P) == n:
            return _identity_q(n)
        if best is not None and key != best:
            # a lower rank, or the same rank with later pivots, marks an unlucky prime
            if key[0] < best[0] or (key[0] == best[0] and key[1] > best[1]):
                continue
            residues, modulus, cand = [], 1, None
        best = key
        free = [j for j in range(n) if j not in set(P)]
        vals = E[:, free].astype(np.int64).tolist() if free else [[] for _ in P]
        if cand is not None and all(
            x.denominator % p != 0 and (x.numerator * pow(x.denominator, -1, p) - v) % p == 0
            for row, vrow in zip(cand, vals)
            for x, v in zip(row, vrow)
        ):
            out = _proved(R0, mats, P, free, cand, n)
            if out is not None:
                return out
        # Chinese remainder step, then reconstruct
        if not residues:
            residues = [list(row) for row in vals]
        else:
            inv = pow(modulus % p, -1, p)
            residues = [[x + modulus * (((v - x) * inv) % p) for x, v in zip(row, vrow)] for row, vrow in zip(residues, vals)]
        modulus *= p
        rec = [[_ratrecon(x, modulus) for x in row] for row in residues]
        cand = None if any(x is None for row in rec for x in row) else rec  # type: ignore[assignment]
    return None


def _identity_q(n: int) -> flint.fmpq_mat:
    return flint.fmpq_mat(n, n, [int(i == j) for i in range(n) for j in range(n)])


def _proved(
    R0: flint.fmpq_mat, mats: Sequence[flint.fmpq_mat], P: Sequence[int], free: Sequence[int], cand: Sequence[Sequence[Fraction]], n: int
) -> flint.fmpq_mat | None:
    """The RREF with pivots P and entries ``cand`` at the free columns, if its kernel is proved
    to be invariant under every matrix and to lie in ker R0 (exact products over Q)."""
    r, k = len(P), len(free)
    flat: list[Any] = [0] * (r * n)
    for i, pj in enumerate(P):
        flat[i * n + pj] = 1
        for c, x in enumerate(cand[i]):
            if x:
                flat[i * n + free[c]] = flint.fmpq(x.numerator, x.denominator)
    E = flint.fmpq_mat(r, n, flat)
    if k == 0:
        return E
    kflat: list[Any] = [0] * (n * k)
    for c, f in enumerate(free):
        kflat[f * k + c] = 1
    for i, pj in enumerate(P):
        for c, x in enumerate(cand[i]):
            if x:
                kflat[pj * k + c] = flint.fmpq(-x.numerator, x.denominator)
    K = flint.fmpq_mat(n, k, kflat)
    if not all(x == 0 for x in (R0 * K).entries()):
        return None
    for M in mats:
        MK = M * K
        T = flint.fmpq_mat(k, k, [MK[f, c] for f in free for c in range(k)])
        if MK != K * T:
            return None
    return E


def rationalised(v: np.ndarray, max_denominator: int) -> list[Fraction] | None:
    """``v`` scaled to a largest entry of 1, each entry the nearest fraction with denominator <= ``max_denominator``.

    None when ``v`` is empty, not finite, zero, or not real after the scaling.
    """
    w = np.asarray(v, dtype=complex)
    if w.size == 0 or not np.all(np.isfinite(w)):
        return None
    k = int(np.argmax(np.abs(w)))
    if w[k] == 0:
        return None
    w = w / w[k]
    if np.any(np.abs(w.imag) > 1e-9):
        return None
    return [Fraction(float(x)).limit_denominator(max_denominator) for x in w.real]


def rational_kernel_vector(rows: Sequence[Sequence[Fraction]], v: np.ndarray, max_denominator: int = 10**6) -> list[Fraction] | None:
    """An exact rational kernel vector of ``rows`` recovered from the float candidate ``v``, or None.

    v is scaled so that its largest entry is 1, each entry is replaced by the nearest fraction
    with denominator <= ``max_denominator`` (continued fractions) and ``rows @ q = 0`` is
    checked in exact arithmetic: a True check is a proof (no tolerance), a failed one proves
    nothing.

    Parameters
    ----------
    rows : exact rows
    v : ndarray
        Candidate (real, or complex with a zero imaginary part after scaling).
    max_denominator : int
    """
    q = rationalised(v, max_denominator)
    if q is None:
        return None
    for r in rows:
        if sum((r[j] * q[j] for j in range(len(q)) if r[j] != 0 and q[j] != 0), Fraction(0)) != 0:
            return None
    return q
