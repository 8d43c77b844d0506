"""How many invariant zeros a sparse selection system can have: an upper bound proven modulo a prime.

System: A (n x n, rational, given by its nonzero entries), B = S_F^T (input k acts on state
F_k), C = S_M (output j reads state M_j), D = 0, with the Rosenbrock pencil

.. math::

    P(s) = \\begin{bmatrix} sI - A & -B \\\\ C & 0 \\end{bmatrix}
    \\qquad ((n + q) \\times (n + m),\\ q = |M| \\ge m = |F|).

The bound (each step an exact statement)
    1. *Squaring down.* For an m x q matrix R, z_R(s) = det([[sI - A, -B], [R C, 0]]) is
       det(diag(I, R) P(s)); by Cauchy-Binet it is a combination of the maximal minors of P,
       so the zero polynomial of P (the gcd of its maximal minors, whose degree counts the
       finite invariant zeros with multiplicity) divides z_R. Two squarings-down R_1, R_2 give
       #zeros <= deg gcd_Q(z_1, z_2), and z_1 != 0 proves full normal column rank.
    2. *Modulo p.* Let every entry of A be a p-adic unit or integer (p divides no
       denominator), so z_R lies in Z_(p)[s]. When p does not divide the leading coefficient
       of z_1, the primitive gcd g of z_1, z_2 over Z_(p) keeps its degree modulo p (its
       leading coefficient divides lc(z_1), Gauss's lemma) and divides both reductions:
       deg gcd_Q(z_1, z_2) <= deg gcd_{F_p}(z_1 mod p, z_2 mod p). A smaller degree modulo p is
       impossible; a larger one (a spurious common factor) only weakens the bound. Beware:
       a gcd s^k modulo p does not put the zeros at 0 (s - p reduces to s); only the degree is
       used.
    3. *z_R modulo p in O(n (nnz + n)).* With chi(s) = det(sI - A) and
       f_R(s) = det(R C (sI - A)^{-1} B) = sum_k c_k s^{-k} (Markov parameters
       H_j = C A^j B, f_R = det(sum_j R H_j s^{-j-1})), z_R = chi f_R is a polynomial, so
       z_R is the polynomial part of chi times the series: its coefficients need c_0..c_n,
       i.e. H_0..H_{n-1} (n sparse products of the m columns of B). chi modulo p is the
       minimal polynomial of a scalar sequence u^T A^k v (Berlekamp-Massey on 2n terms, as in
       :mod:`glocal_verify.numerics.krylov`): it divides the minimal polynomial of A mod p,
       hence chi mod p, and *is* chi mod p exactly when its degree is n. When A is derogatory
       (a repeated eigenvalue of geometric multiplicity > 1) the degree falls short; then the
       same is tried on A - B K for a random integer K: [[sI - A + BK, -B], [RC, 0]] is
       [[sI - A, -B], [RC, 0]] [[I, 0], [-K, I]], so z_R is unchanged, and only the
       uncontrollable eigenvalues of A stay fixed.
    4. *The leading coefficient.* chi is monic, so lc(z_R) = c_rho with rho the first index
       with c_rho != 0 over Q. Modulo p the first nonzero index rho_p is >= rho. A lower bound
       of rho comes from the graph of A: (C A^j B)[t, c] = (A^j)[M_t, F_c] is zero for j below
       the length d(F_c, M_t) of the shortest walk, so by Cauchy-Binet every term of
       det(R G(w)), G(w) = sum_j C A^j B w^(j+1), has order at least m + sum_c d(F_c, M_sigma(c))
       for an injective sigma: rho >= m + (the least such sum, a linear assignment). When
       rho_p meets that bound, rho = rho_p and c_rho is a p-adic unit. Otherwise the terms
       c_k, k < rho_p, are recomputed over Z (integer Markov parameters of D A, D the common
       denominator, for the first rho_p - m powers only; the determinant of their series
       from its values at integers) and must all vanish; if one does not, p divides lc(z_1)
       and another prime is taken.
    5. *Two ways to z_R modulo p.* With few inputs (at most three), as the polynomial part
       of chi times the series det(R G(w)), expanded by permutations. With more, by values:
       z_R(x) = det(R N(x)) / chi(x)^(m-1) at n + 1 consecutive points x where chi(x) != 0,
       N(x) = C adj(xI - A) B = sum_i H_i q_i(x) with q_(n-1) = 1, q_(i-1) = x q_i + a_i
       (adj(xI - A) = sum_k x^k sum_(i<n-k) a_(k+i+1) A^i), then Newton interpolation (deg
       z_R <= n); both give the same polynomial modulo p.

The random choices (u, v, R, K, the prime, the points) decide only whether a sharp bound is
found, never whether the bound holds. Cost at n = 4000, m = 2: 2n sparse products, one
Berlekamp-Massey of length 2n and a few truncated products of degree n modulo p, about a
second; at n = 300, m = 10 (a cluster's pencil): the same products and O(n^2 (q m + m^3))
vectorised operations modulo p for the values, a few tens of milliseconds.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Mapping, Sequence

import numpy as np
import scipy.sparse as sps

from glocal_verify import config
from glocal_verify.numerics.minors import prime_for

__all__ = ["ZeroCountBound", "zero_count_bound_mod_p"]


@dataclass(frozen=True, slots=True)
class ZeroCountBound:
    """An upper bound on the number of finite invariant zeros (with multiplicity) of (A, S_F^T, S_M, 0).

    Attributes
    ----------
    bound : int or None
        ``deg gcd(z_1 mod p, z_2 mod p)``: at least the number of finite invariant zeros
        counted with multiplicity (module docstring); None when no bound was proven.
    left_invertible : bool
        z_1 != 0 was proven (full normal column rank of the pencil).
    prime : int
        The prime p (0 when none was used).
    order_at_infinity : int
        rho: z_1 has degree n - rho over Q with a p-adic unit leading coefficient.
    feedback : bool
        chi was read from A - B K (A itself was derogatory modulo p).
    note : str
        Why ``bound`` is None, or what limited it.
    """

    bound: int | None
    left_invertible: bool
    prime: int
    order_at_infinity: int = 0
    feedback: bool = False
    note: str = ""


def _signed_permutations(m: int) -> list[tuple[tuple[int, ...], int]]:
    """The permutations of range(m) with their signs (+1 / -1, by counting inversions)."""
    out = []
    for perm in itertools.permutations(range(m)):
        inversions = sum(1 for i in range(m) for j in range(i + 1, m) if perm[i] > perm[j])
        out.append((perm, -1 if inversions % 2 else 1))
    return out


def _leibniz_det(series: list[list[Any]], m: int, length: int) -> Any:
    """det of an m x m matrix of truncated power series (python-flint nmod_poly), modulo w^length."""
    total = None
    for perm, sign in _signed_permutations(m):
        term = series[0][perm[0]]
        for i in range(1, m):
            term = term.mul_low(series[i][perm[i]], length)
        term = term if sign > 0 else -term
        total = term if total is None else total + term
    return total


def _exact_leading_terms(
    size: int, entries: Mapping[tuple[int, int], Fraction], F: Sequence[int], M: Sequence[int], R: np.ndarray, upto: int
) -> int | None:
    """The first k < ``upto`` with c_k != 0 over Q (c the series of det(R C (sI - A)^{-1} B)), or None if all vanish.

    Integer Markov parameters G_j = R C (D A)^j B (D the common denominator) give
    c_k = D^{-(k - m)} c'_k with c'_k the coefficient of w^k in det(sum_j G_j w^(j+1)); only
    j < ``upto`` - m reach the orders below ``upto`` (every entry has order >= 1). That
    determinant is a polynomial of degree at most m (upto - m) in w, computed exactly from its
    values at as many integers plus one (python-flint ``fmpz_mat`` determinants) and Newton's
    interpolation over Q.
    """
    from flint import fmpz_mat

    m = len(F)
    J = max(upto - m, 0)
    if J == 0:
        return None
    D = 1
    for v in entries.values():
        D = D * v.denominator // math.gcd(D, v.denominator)
    rows: list[list[tuple[int, int]]] = [[] for _ in range(size)]
    for (i, j), v in entries.items():
        if v != 0:
            rows[j].append((i, int(v * D)))  # by column: y_new[i] += A_ij y[j]
    Rint = [[int(x) for x in r] for r in R]
    G: list[list[list[int]]] = []
    vecs = [{f: 1} for f in F]
    for _ in range(J):
        H = [[vec.get(o, 0) for vec in vecs] for o in M]  # q x m
        G.append([[sum(Rint[i][t] * H[t][j] for t in range(len(M)) if H[t][j]) for j in range(m)] for i in range(m)])
        nxt = []
        for vec in vecs:
            out: dict[int, int] = {}
            for j, y in vec.items():
                for i, a in rows[j]:
                    out[i] = out.get(i, 0) + a * y
            nxt.append({i: y for i, y in out.items() if y})
        vecs = nxt
    degree = m * J  # the entries have degree <= J
    values = []
    for x in range(degree + 1):
        P = [[sum(G[j][a][b] * x ** (j + 1) for j in range(J)) for b in range(m)] for a in range(m)]
        values.append(Fraction(int(fmpz_mat(P).det())))
    # Newton's divided differences on the points 0, 1, ..., degree, then the monomial coefficients
    d = list(values)
    for j in range(1, degree + 1):
        for i in range(degree, j - 1, -1):
            d[i] = (d[i] - d[i - 1]) / j
    poly = [d[degree]]
    for j in range(degree - 1, -1, -1):  # poly * (w - j) + d[j]
        poly = [(poly[0] * -j) + d[j]] + [poly[i - 1] - j * poly[i] for i in range(1, len(poly))] + [poly[-1]]
    for k in range(m, min(upto, len(poly))):
        if poly[k] != 0:
            return k
    return None


#: up to this many inputs z_R comes from the series expanded by permutations (m! products), above from values
_SERIES_MAX_INPUTS = 3


def _z_by_series(chi: Sequence[int], H: np.ndarray, Rs: Sequence[np.ndarray], p: int) -> list[Any]:
    """z_R modulo p for each R of ``Rs``: the polynomial part of chi times det(R G(w)) (module docstring, step 3)."""
    from flint import nmod_poly

    n, q, m = len(chi) - 1, H.shape[1], H.shape[2]
    length = n + 1
    chirev = nmod_poly(list(chi)[::-1], p)  # w^n chi(1/w)
    out = []
    for R in Rs:
        GR = np.zeros((n + 1, m, m), dtype=np.int64)
        for t in range(q):
            for i in range(m):
                GR[:, i, :] = (GR[:, i, :] + int(R[i, t]) * H[:, t, :] % p) % p
        series = [[nmod_poly([0] + [int(x) for x in GR[:n, i, j]], p) for j in range(m)] for i in range(m)]
        f = _leibniz_det(series, m, length)
        P = [int(c) for c in chirev.mul_low(f, length).coeffs()]
        P += [0] * (length - len(P))
        out.append(nmod_poly(P[::-1], p))
    return out


def _inv_mod(a: np.ndarray, p: int) -> np.ndarray:
    """a^(p-2) modulo the prime p elementwise (the inverse of every nonzero entry; p < 2^31)."""
    out = np.ones_like(a)
    base = a % p
    e = p - 2
    while e:
        if e & 1:
            out = out * base % p
        base = base * base % p
        e >>= 1
    return out


def _det_mod(mats: np.ndarray, p: int) -> np.ndarray:
    """Determinants modulo the prime p (< 2^31) of a stack of square int64 matrices (Gaussian elimination, vectorised over the stack)."""
    A = mats % p
    b, m, _ = A.shape
    det = np.ones(b, dtype=np.int64)
    rows = np.arange(b)
    for c in range(m):
        nz = A[:, c:, c] != 0
        has = nz.any(axis=1)
        det = np.where(has, det, 0)
        piv = c + np.argmax(nz, axis=1)
        swap = has & (piv != c)
        if swap.any():
            r = rows[swap]
            top, other = A[r, c, :].copy(), A[r, piv[swap], :].copy()
            A[r, c, :], A[r, piv[swap], :] = other, top
            det[swap] = (p - det[swap]) % p
        pv = np.where(has, A[:, c, c], 1)
        det = det * pv % p
        if c + 1 < m:
            f = A[:, c + 1 :, c] * _inv_mod(pv, p)[:, None] % p
            for k in range(c, m):  # column by column: products < p^2 < 2^62
                A[:, c + 1 :, k] = (A[:, c + 1 :, k] - f * A[:, c, k][:, None] % p) % p
    return det


def _z_by_values(chi: Sequence[int], H: np.ndarray, Rs: Sequence[np.ndarray], p: int, rng: np.random.Generator) -> list[Any] | None:
    """z_R modulo p for each R of ``Rs`` from its values (module docstring, step 5), or None when no run of points avoids the roots of chi."""
    from flint import nmod_poly

    n = len(chi) - 1
    m = H.shape[2]
    a = np.asarray(chi, dtype=np.int64)
    for _ in range(4):
        start = int(rng.integers(1, p - n - 2))
        x = np.arange(start, start + n + 1, dtype=np.int64)
        q = np.ones(n + 1, dtype=np.int64)
        N = np.zeros((n + 1, H.shape[1], m), dtype=np.int64)
        for i in range(n - 1, -1, -1):
            N = (N + H[i][None, :, :] * q[:, None, None]) % p
            q = (x * q + a[i]) % p  # q_(i-1); after i = 0 it is chi(x)
        if np.all(q != 0):
            break
    else:
        return None
    scale = _inv_mod(q, p)
    scale_m = np.ones_like(scale)
    for _ in range(m - 1):
        scale_m = scale_m * scale % p
    out = []
    for R in Rs:
        RN = np.zeros((n + 1, m, m), dtype=np.int64)
        for t in range(H.shape[1]):
            RN = (RN + (R[:, t][None, :, None] % p) * N[:, t, :][:, None, :] % p) % p
        vals = _det_mod(RN, p) * scale_m % p
        # Newton's divided differences on the consecutive points start, start + 1, ...
        d = vals.copy()
        for j in range(1, n + 1):
            d[j:] = (d[j:] - d[j - 1 : -1]) % p * pow(j, p - 2, p) % p
        poly = np.array([d[n]], dtype=np.int64)
        for j in range(n - 1, -1, -1):
            nxt = np.zeros(len(poly) + 1, dtype=np.int64)
            nxt[1:] = poly
            nxt[:-1] = (nxt[:-1] - poly * int(x[j]) % p) % p
            nxt[0] = (nxt[0] + d[j]) % p
            poly = nxt
        out.append(nmod_poly([int(c) for c in poly], p))
    return out


def _structural_order(n: int, keys: Sequence[tuple[int, int]], F: Sequence[int], M: Sequence[int]) -> int | None:
    """m + the least sum of walk lengths d(F_c, M_sigma(c)) over injective sigma (module docstring, step 4), or None if no such sigma."""
    from scipy.optimize import linear_sum_assignment

    nbrs: list[list[int]] = [[] for _ in range(n)]
    for i, j in keys:
        if i != j:
            nbrs[j].append(i)  # a walk F_c -> ... -> M_t reads A[next, current]
    far = n + 1
    cost = np.full((len(F), len(M)), far, dtype=np.int64)
    where = {o: t for t, o in enumerate(M)}
    for c, f in enumerate(F):
        seen = {f}
        frontier, d = [f], 0
        while frontier:
            for v in frontier:
                if v in where:
                    cost[c, where[v]] = d
            nxt = []
            for v in frontier:
                for w in nbrs[v]:
                    if w not in seen:
                        seen.add(w)
                        nxt.append(w)
            frontier, d = nxt, d + 1
    r, c_ = linear_sum_assignment(cost)
    total = int(cost[r, c_].sum())
    return None if np.any(cost[r, c_] >= far) else len(F) + total


def zero_count_bound_mod_p(
    size: int,
    entries: Mapping[tuple[int, int], Fraction],
    inputs: Sequence[int],
    outputs: Sequence[int],
    *,
    seed: int = 0,
) -> ZeroCountBound:
    """Bound the number of finite invariant zeros of (A, S_F^T, S_M, 0) from above, modulo a prime.

    .. math::

        \\#\\{\\text{zeros of } P\\} \\le \\deg \\gcd_{\\mathbb F_p}\\big(\\det(R_1 P(s)) \\bmod p,\\;
        \\det(R_2 P(s)) \\bmod p\\big)

    with the conditions of the module docstring checked (the characteristic polynomial read
    exactly modulo p, the leading coefficient of det(R_1 P) a p-adic unit, checked over Z).

    Parameters
    ----------
    size : int
        n, the number of states.
    entries : mapping
        ``{(i, j): A_ij}``, the nonzero entries of A, exact.
    inputs : sequence of int
        F, the state each input acts on (distinct).
    outputs : sequence of int
        M, the state each output reads (distinct).
    seed : int
        Seeds the random vectors, squarings-down and feedback (the bound holds for every seed).

    Returns
    -------
    ZeroCountBound
        ``bound`` None (with a ``note``) when nothing was proven: more inputs than
        ``zero_count_values_max_inputs``, fewer outputs than inputs, a characteristic polynomial
        not read exactly, an unlucky prime every time, or a leading term too deep to check
        over Z (``zero_count_exact_terms``).
    """
    F, M = list(inputs), list(outputs)
    m, q, n = len(F), len(M), size
    if m == 0 or len(set(F)) != m or len(set(M)) != q:
        return ZeroCountBound(None, False, 0, note="the inputs must be distinct and at least one")
    if q < m:
        return ZeroCountBound(None, False, 0, note=f"{q} outputs for {m} inputs: never left-invertible")
    if m > config.get("zero_count_values_max_inputs"):
        return ZeroCountBound(None, False, 0, note=f"{m} inputs, more than zero_count_values_max_inputs = {config.get('zero_count_values_max_inputs')}")
    if n > config.get("zero_count_max_states"):
        return ZeroCountBound(None, False, 0, note=f"{n} states, more than zero_count_max_states = {config.get('zero_count_max_states')}")
    from flint import fmpz_mod_poly_ctx, nmod_poly

    nnz_row = np.zeros(n, dtype=np.int64)
    for i, _j in entries:
        nnz_row[i] += 1
    widest = max(int(nnz_row.max(initial=0)), 1)
    # a row's sum of products (each < p^2) stays below 2^62
    limit = min(2**31, math.isqrt((2**62) // widest))
    keys = [k for k, v in entries.items() if v != 0]
    rng = np.random.default_rng(seed)
    notes: list[str] = []
    structural: int | None = None
    for attempt in range(config.get("zero_count_primes")):
        p = prime_for(list(entries.values()), limit=limit)
        limit = p - 1  # the next attempt takes the prime below

        def md(x: Fraction) -> int:
            return (x.numerator % p) * pow(x.denominator % p, -1, p) % p  # noqa: B023

        data = np.array([md(entries[k]) for k in keys], dtype=np.int64)
        A = sps.csr_matrix((data, ([k[0] for k in keys], [k[1] for k in keys])), shape=(n, n), dtype=np.int64)
        u = rng.integers(1, p, size=n, dtype=np.int64)
        chi = None
        feedback = False
        H: np.ndarray | None = None
        for use_k in (False, True):
            K = rng.integers(1, 256, size=(m, n), dtype=np.int64) if use_k else None
            X = np.zeros((n, m + 1), dtype=np.int64)
            X[:, 0] = rng.integers(0, p, size=n, dtype=np.int64)
            for c, f in enumerate(F):
                X[f, c + 1] = 1
            seq = [0] * (2 * n)
            Hs = np.zeros((n + 1, q, m), dtype=np.int64)
            for k in range(2 * n):
                seq[k] = int(((u * X[:, 0]) % p).sum() % p)
                if k <= n:
                    Hs[k] = X[M, 1:]
                if k == n:
                    X = X[:, :1].copy()
                Y = (A @ X) % p
                if K is not None:
                    Y[F, :] = (Y[F, :] - (K @ X) % p) % p  # (A - S_F^T K) X
                X = Y
            mp = fmpz_mod_poly_ctx(p).minpoly(seq)
            if int(mp.degree()) == n:
                chi = [int(c) for c in mp.coeffs()]
                feedback, H = use_k, Hs
                break
        if chi is None or H is None:
            notes.append(f"the characteristic polynomial was not read modulo {p} (A and A - B K derogatory: a repeated uncontrollable eigenvalue)")
            continue
        Rs = [rng.integers(0, p, size=(m, q), dtype=np.int64) for _ in range(config.get("zero_count_squarings"))]
        zs = _z_by_series(chi, H, Rs, p) if m <= _SERIES_MAX_INPUTS else _z_by_values(chi, H, Rs, p, rng)
        if zs is None:
            notes.append(f"no run of {n + 1} points avoids the roots of chi modulo {p}")
            continue
        if zs[0].is_zero():
            notes.append(f"det(R_1 P(s)) vanishes modulo {p}")
            continue
        rho = n - int(zs[0].degree())
        if structural is None:
            structural = _structural_order(n, keys, F, M) or -1
        if rho != structural:
            if rho - m > config.get("zero_count_exact_terms"):
                return ZeroCountBound(None, True, p, rho, feedback, f"the leading term of det(R_1 P(s)) lies {rho} terms deep, more than zero_count_exact_terms to check over Z")
            first = _exact_leading_terms(n, entries, F, M, Rs[0], rho)
            if first is not None:
                notes.append(f"{p} divides the leading coefficient of det(R_1 P(s)) (order {first} over Q, {rho} modulo p)")
                continue
        g = zs[0]
        for z in zs[1:]:
            g = g.gcd(z)
        return ZeroCountBound(int(g.degree()), True, p, rho, feedback)
    return ZeroCountBound(None, False, 0, note="; ".join(notes) or "no prime tried")
