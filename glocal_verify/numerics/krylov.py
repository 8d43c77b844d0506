"""Krylov degrees modulo a prime: exact lower bounds on dim span{b, A b, A^2 b, ...} for a sparse rational A.

For a rational matrix ``A`` and vector ``b`` the Krylov space ``K(A, b) = span{A^k b}`` over Q
has dimension ``d_Q(b)``, the degree of the minimal polynomial of ``b`` with respect to ``A``.
Reduced modulo a prime ``p`` that divides no denominator, every minor of the Krylov matrix
``[b, A b, ..., A^(n-1) b]`` is reduced too, so its rank over F_p is at most its rank over
Q. For any ``w`` the scalar sequence ``s_k = w^T A^k b (mod p)`` satisfies every recurrence
the vectors ``A^k b (mod p)`` satisfy, and the shortest recurrence that generates a prefix of
it (Berlekamp-Massey, python-flint's ``fmpz_mod_poly_ctx.minpoly``) is no longer than that of
the whole sequence. Hence

.. math:: \\deg \\operatorname{minpoly}(s_0, \\dots, s_{2m-1}) \\le d_{F_p}(b) \\le d_Q(b),

whatever ``p`` and ``w``: the degree found is a proven lower bound. A random ``w`` and a
large ``p`` make it equal to ``d_Q(b)`` with probability about ``1 - n / p``; a smaller
degree proves nothing and the caller falls back to another certificate.

The cost is ``2 m`` sparse products modulo ``p`` (int64 arithmetic, ``p`` chosen so that no
row's sum of products can overflow) and one Berlekamp-Massey of length ``2 m``: about
``O(m (nnz + n))``, against ``O(n^3)`` for a characteristic polynomial. For a symmetric ``A``
(a Laplacian) the degree counts the distinct eigenvalues on whose eigenspaces ``b`` has a
nonzero component; :mod:`glocal_verify.analysis.twins` turns that into certificates of
Theorem III.3 (ii) and (iii).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from fractions import Fraction

import numpy as np
import scipy.sparse as sps

from glocal_verify.numerics.minors import _mod, prime_for

__all__ = ["KrylovDegree", "krylov_degree_mod"]


@dataclass(frozen=True, slots=True)
class KrylovDegree:
    """A proven lower bound on the dimension of a Krylov space over Q.

    Attributes
    ----------
    degree : int
        ``deg minpoly(w^T A^k b mod p)``, at most ``dim K(A, b)`` over Q.
    prime : int
        The prime ``p``.
    terms : int
        The length of the sequence given to Berlekamp-Massey.
    """

    degree: int
    prime: int
    terms: int


def krylov_degree_mod(
    size: int,
    entries: Mapping[tuple[int, int], Fraction],
    start: Mapping[int, int] | None,
    bound: int,
    *,
    seed: int = 0,
    prime_below: int | None = None,
) -> KrylovDegree:
    """A lower bound on ``dim K(A, b)`` over Q, proven modulo a prime (module docstring).

    Parameters
    ----------
    size : int
        ``n``.
    entries : mapping
        ``{(i, j): A_ij}``, the nonzero entries, exact.
    start : mapping of int to int, or None
        ``b`` by its nonzero entries; None: a random integer vector (drawn with ``seed``).
    bound : int
        The degree of interest ``m``: the sequence has ``2 m`` terms, enough for
        Berlekamp-Massey to find a recurrence of degree ``m`` when there is one.
    seed : int
        Seeds ``w`` (and ``b`` when ``start`` is None); the bound holds for every seed.
    prime_below : int, optional
        Take the prime below this (and below the overflow limit): a second attempt with
        another prime makes an unlucky prime unlikely twice.

    Returns
    -------
    KrylovDegree
    """
    rows = np.zeros(size, dtype=np.int64)
    for i, _j in entries:
        rows[i] += 1
    widest = max(int(rows.max(initial=0)), 1)
    # every row sum of products (each < p^2) and every dot product term stays below 2^63
    limit = min(2**31, math.isqrt((2**62) // widest), prime_below or 2**31)
    p = prime_for(list(entries.values()), limit=limit)
    keys = list(entries)
    data = np.array([_mod(Fraction(entries[k]), p) for k in keys], dtype=np.int64)
    r = np.array([k[0] for k in keys], dtype=np.int64)
    c = np.array([k[1] for k in keys], dtype=np.int64)
    A = sps.csr_matrix((data, (r, c)), shape=(size, size), dtype=np.int64)
    rng = np.random.default_rng(seed)
    w = rng.integers(1, p, size=size, dtype=np.int64)
    if start is None:
        x = rng.integers(0, p, size=size, dtype=np.int64)
    else:
        x = np.zeros(size, dtype=np.int64)
        for i, v in start.items():
            x[i] = int(v) % p
    terms = 2 * bound
    seq = [0] * terms
    for k in range(terms):
        seq[k] = int(((w * x) % p).sum() % p)
        if k + 1 < terms:
            x = (A @ x) % p
    from flint import fmpz_mod_poly_ctx

    degree = int(fmpz_mod_poly_ctx(p).minpoly(seq).degree())
    return KrylovDegree(degree, p, terms)
