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
nonzero component; :mod:`glocal_verify.analysis.laplacian.twins` turns that into certificates of
Theorem III.3 (ii) and (iii).

Block Krylov ranks (observability)
    For rational ``A`` (n x n) and ``C`` (q x n) the observability matrix
    ``O = [C; C A; ...; C A^(n-1)]`` has the same minors reduced modulo ``p``, so
    ``rank_{F_p} O <= rank_Q O``: a rank ``n`` modulo ``p`` proves that ``(A, C)`` is observable
    over Q, i.e. that ``[s I - A; C]`` has full column rank for every complex s (Hautus).
    :func:`krylov_rank_mod` stacks the blocks ``C A^i`` in rounds (enough blocks for rank n
    first, twice as many if the rank falls short, up to ``n``) and ranks them with
    python-flint's ``nmod_mat``: ``O(n nnz)`` for the products and about one rank of an
    ``n x n`` matrix modulo p when the first round suffices. A smaller rank proves nothing.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from fractions import Fraction

import numpy as np
import scipy.sparse as sps

from glocal_verify.numerics.minors import _mod, prime_for

__all__ = ["KrylovDegree", "KrylovRank", "krylov_degree_mod", "krylov_rank_mod"]


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


@dataclass(frozen=True, slots=True)
class KrylovRank:
    """A proven lower bound on the rank of an observability matrix over Q.

    Attributes
    ----------
    rank : int
        ``rank [C; C A; ...; C A^(b-1)]`` modulo ``prime``, at most the rank over Q.
    states : int
        ``n``: the rank that proves observability.
    prime : int
    blocks : int
        ``b``, the number of blocks ``C A^i`` stacked.
    """

    rank: int
    states: int
    prime: int
    blocks: int

    @property
    def observable(self) -> bool:
        """True when the rank proves that ``(A, C)`` is observable over Q."""
        return self.rank == self.states


def krylov_rank_mod(
    size: int,
    entries: Mapping[tuple[int, int], Fraction],
    outputs: Sequence[Mapping[int, Fraction]],
    *,
    denominators: Sequence[Fraction] = (),
) -> KrylovRank:
    """A lower bound on the rank of ``[C; C A; ...]`` over Q, proven modulo a prime (module docstring).

    Parameters
    ----------
    size : int
        ``n``.
    entries : mapping
        ``{(i, j): A_ij}``, the nonzero entries of ``A``, exact.
    outputs : sequence of mappings
        The rows of ``C``, each by its nonzero entries ``{j: C_ij}``, exact.
    denominators : sequence of Fraction
        Further rationals whose denominators the prime must not divide (e.g. a gain that
        scales ``A`` or ``C`` and is left out of them).

    Returns
    -------
    KrylovRank
    """
    from flint import nmod_mat

    q = len(outputs)
    if size == 0:
        return KrylovRank(0, 0, 2, 0)
    rows = np.zeros(size, dtype=np.int64)
    for i, _j in entries:
        rows[i] += 1
    widest = max(int(rows.max(initial=0)), 1)
    limit = min(2**31, math.isqrt((2**62) // widest))
    values = list(entries.values()) + [v for r in outputs for v in r.values()] + list(denominators)
    p = prime_for(values, limit=limit)
    if q == 0:
        return KrylovRank(0, size, p, 0)
    keys = list(entries)
    data = np.array([_mod(Fraction(entries[k]), p) for k in keys], dtype=np.int64)
    r = np.array([k[0] for k in keys], dtype=np.int64)
    c = np.array([k[1] for k in keys], dtype=np.int64)
    # row blocks multiply from the right: B A = (A^T B^T)^T
    AT = sps.csr_matrix((data, (c, r)), shape=(size, size), dtype=np.int64)
    block = np.zeros((size, q), dtype=np.int64)  # columns: the rows of C A^i
    for k, row in enumerate(outputs):
        for j, v in row.items():
            block[j, k] = _mod(Fraction(v), p)
    stacked: list[np.ndarray] = []
    want = min(size, -(-size // q) + 1)
    rank = 0
    while True:
        while len(stacked) < want:
            stacked.append(block.T.copy())
            block = (AT @ block) % p
        O = np.vstack(stacked)
        rank = int(nmod_mat(O.shape[0], size, [int(x) for x in O.ravel()], p).rank())
        if rank == size or want >= size:
            return KrylovRank(rank, size, p, len(stacked))
        want = min(size, 2 * want)
