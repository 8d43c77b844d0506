"""Exact and ball arithmetic the checks share: sparse products, reduction modulo a prime,
minors, Krylov matrices, number fields Q[t]/(g), polynomial determinants, eigenvalue
enclosures. Every function decides one stated fact; none searches.

Reduction modulo a prime ``p`` is the ring map Z_(p) -> F_p (rationals whose denominator
``p`` does not divide). It maps a determinant to the determinant of the reduced matrix, so a
minor that is nonzero modulo ``p`` is nonzero over Q: a rank modulo ``p`` is a lower bound on
the rank over Q.
"""

from __future__ import annotations

from itertools import permutations
from operator import mul
from typing import Any, Iterable, Sequence

from flint import fmpq, fmpq_mat, fmpq_poly, fmpz, fmpz_mat, nmod_mat, nmod_poly

from glocal_check.spec import CheckError, rational

__all__ = [
    "Field",
    "Rejected",
    "det_mod",
    "hurwitz",
    "hurwitz_poly",
    "integer_matrix",
    "lyapunov",
    "positive_definite",
    "poly_det",
    "krylov_det",
    "matvec",
    "mod",
    "combination_det",
    "exact_degree",
    "pencil_minors",
    "poly_det_mod",
    "reduce_poly",
    "prime",
    "rank_exact",
    "unit",
]


class Rejected(Exception):
    """The certificate does not prove its claim; the message says which check failed."""


def require(ok: bool, why: str) -> None:
    """Reject unless ``ok``."""
    if not ok:
        raise Rejected(why)


def matvec(rows: Sequence[dict[int, Any]], v: Sequence[Any], zero: Any = 0) -> list[Any]:
    """``M v`` for a sparse matrix given by rows ``{column: entry}``."""
    out = []
    for r in rows:
        acc = zero
        for j, a in r.items():
            if v[j]:
                acc = acc + a * v[j]
        out.append(acc)
    return out


# -------------------------------------------------------------------------------------------
# modulo a prime


def prime(p: Any) -> int:
    """``p`` if it is a prime between 2^20 and 2^62 (word-sized, large enough that a chance
    vanishing is unlikely), else reject."""
    require(isinstance(p, int) and not isinstance(p, bool) and 2**20 < p < 2**62, f"prime {p!r} out of range (2^20, 2^62)")
    require(fmpz(p).is_prime(), f"{p} is not a prime")
    return p


def mod(q: fmpq, p: int) -> int:
    """The image of the rational ``q`` in F_p (reject when ``p`` divides its denominator)."""
    num, den = int(q.p), int(q.q)
    require(den % p != 0, f"the prime {p} divides a denominator of the system ({den})")
    return num * pow(den, -1, p) % p


def det_mod(rows: Sequence[Sequence[fmpq]] | Sequence[Sequence[int]], p: int) -> int:
    """The determinant modulo ``p`` of a square matrix of rationals (or of residues)."""
    k = len(rows)
    if k == 0:
        return 1
    require(all(len(r) == k for r in rows), "a minor that is not square")
    flat = [x if isinstance(x, int) else mod(x, p) for r in rows for x in r]
    return int(nmod_mat(k, k, flat, p).det())


def minor_of(dense_rows: Sequence[Sequence[fmpq]], rows: Sequence[int], cols: Sequence[int], p: int) -> int:
    """The minor of ``dense_rows`` on ``rows`` x ``cols`` modulo ``p``."""
    n_r, n_c = len(dense_rows), len(dense_rows[0]) if dense_rows else 0
    require(all(isinstance(r, int) and 0 <= r < n_r for r in rows) and len(set(rows)) == len(rows), "minor rows out of range or repeated")
    require(all(isinstance(c, int) and 0 <= c < n_c for c in cols) and len(set(cols)) == len(cols), "minor columns out of range or repeated")
    return det_mod([[dense_rows[r][c] for c in cols] for r in rows], p)


def mod_matrix(rows: Sequence[dict[int, fmpq]], n: int, p: int) -> nmod_mat:
    """A sparse rational matrix (rows ``{column: entry}``, ``n`` columns) modulo ``p``."""
    flat = [0] * (len(rows) * n)
    for i, r in enumerate(rows):
        for j, a in r.items():
            flat[i * n + j] = mod(a, p)
    return nmod_mat(len(rows), n, flat, p)


def krylov_det(L: nmod_mat, start: Sequence[int], length: int, drop_last_column: bool = False) -> int:
    """det modulo p of the Krylov matrix with rows ``b^T L^j``, j < ``length`` (L symmetric,
    so these are the columns ``L^j b`` transposed), without its last column when
    ``drop_last_column`` (then ``length = N - 1``).

    Built by doubling: the rows for j < 2h are those for j < h followed by those times
    ``L^h``; about log2(N) products of N x N matrices modulo p.
    """
    n, p = L.nrows(), int(L.modulus())
    R = nmod_mat(1, n, [x % p for x in start], p)
    power, have = L, 1
    while have < length:
        R = _stack([R, R * power], p)
        have *= 2
        if have < length:
            power = power * power
    cols = n - 1 if drop_last_column else n
    require(length == cols, f"Krylov matrix of {length} rows for {cols} columns")
    rows = R.tolist()[:length]
    return int(nmod_mat(cols, cols, [int(x) for r in rows for x in r[:cols]], p).det()) if cols else 1


def _stack(blocks: list[nmod_mat], p: int) -> nmod_mat:
    rows = [r for B in blocks for r in B.tolist()]
    n = blocks[0].ncols()
    return nmod_mat(len(rows), n, [int(x) for r in rows for x in r], p)


def poly_det_mod(constant: Sequence[Sequence[int]], variable: Sequence[tuple[int, int, int]], degree: int, p: int) -> nmod_poly:
    """det(K + s J) modulo p as a polynomial in s, where K is ``constant`` (residues) and J has
    the entries ``(row, column, coefficient)`` of ``variable``; ``degree`` bounds its degree
    (the number of rows of J with a nonzero entry). Evaluated at 0..degree and interpolated."""
    k = len(constant)
    require(degree + 1 < p, "degree too large for the prime")
    if k == 0:
        return nmod_poly([1], p)
    K = nmod_mat(k, k, [x for r in constant for x in r], p)
    J = nmod_mat(k, k, [0] * (k * k), p)
    for i, j, c in variable:
        J[i, j] = c
    xs = list(range(degree + 1))
    return _interpolate(xs, [int((K + J * s).det()) for s in xs], p)


def exact_degree(K: Any, rows: Sequence[int], cols: Sequence[int]) -> int:
    """The exact degree over Q of det (s I + K)[rows, cols] (s on the positions where a row is
    its own column; ``K[r]`` the sparse row ``{column: entry}``), or -1 when it is 0.

    With D = rows n cols, R' = rows \\ D, C' = cols \\ D (|R'| = |C'| = m), the minor is
    det(s I + K_DD) det W(s), W(s) = K_R'C' - K_R'D (s I + K_DD)^-1 K_DC'. The first factor is
    monic of degree |D|; in t = 1/s, W = K_R'C' - sum_k H_k t^(k+1) with H_k = K_R'D (-K_DD)^k
    K_DC' (Markov parameters, exact sparse products), so if c_j t^j is the first nonzero term
    of det W, the minor is c_j s^(|D| - j) + lower terms: degree |D| - j, and j <= |D| when it
    is not 0.
    """
    inD = set(rows) & set(cols)
    D = [r for r in rows if r in inD]
    Rp = [r for r in rows if r not in inD]
    Cp = [c for c in cols if c not in inD]
    require(len(Rp) == len(Cp) and len(Rp) <= 6, "a minor of this shape has no degree check")
    zero = fmpq(0)
    X = [{d: K[d][c] for d in D if c in K[d]} for c in Cp]  # columns of (-K_DD)^k K_DC', sparse
    W = [[fmpq_poly([K[r].get(c, zero)]) for c in Cp] for r in Rp]
    t = fmpq_poly([0, 1])
    for k in range(len(D) + 1):  # W holds the terms up to t^k: the coefficients up to t^k are final
        c = _series_det(W, k)
        if c is not None:
            return len(D) - c
        for j, col in enumerate(X):
            for i, r in enumerate(Rp):
                h = sum((x * col[d] for d, x in K[r].items() if d in col), zero)
                W[i][j] -= h * t ** (k + 1)
        X = [_step(K, col, inD) for col in X]
    return -1


def _step(K: Any, col: dict[int, fmpq], inD: set[int]) -> dict[int, fmpq]:
    """-K_DD col (sparse)."""
    out: dict[int, fmpq] = {}
    for e, x in col.items():
        for d, y in K[e].items():  # K symmetric in its pattern: the rows d with K[d][e] != 0
            if d in inD:
                out[d] = out.get(d, fmpq(0)) - K[d][e] * x
    return {d: x for d, x in out.items() if x != 0}


def _series_det(W: Sequence[Sequence[fmpq_poly]], order: int) -> int | None:
    """The index of the first nonzero coefficient (up to t^order) of det W, or None."""
    m = len(W)
    if m == 0:
        return 0
    det = fmpq_poly(0)
    for perm in permutations(range(m)):
        term = fmpq_poly([1])
        for i, j in enumerate(perm):
            term = fmpq_poly(list((term * W[i][j]).coeffs())[: order + 1])
        sign = (-1) ** sum(1 for a in range(m) for b in range(a + 1, m) if perm[a] > perm[b])
        det += sign * term
    cs = det.coeffs()[: order + 1]
    return next((i for i, c in enumerate(cs) if c != 0), None)


def pencil_minors(K: Any, allowed: Sequence[int], cols: Sequence[int], minors: Any, p: int) -> list[nmod_poly]:
    """The stated square minors f_k = det (s I + K)[R_k, cols] modulo p (``K[r]`` the sparse
    row {column: entry} over Q, K symmetric in its pattern; each R_k distinct rows of ``allowed``, s where a row is its own column), each of
    the degree stated; the first keeps its exact degree over Q (:func:`exact_degree`), so p does
    not divide its leading coefficient.

    Then a common factor h of the f_k over Q (primitive over Z_(p), the ring of rationals
    whose denominators p does not divide) has a unit leading coefficient (it divides lc f_1), so
    h mod p has the degree of h and divides every f_k mod p: deg h <= deg gcd_k (f_k mod p).
    """
    require(isinstance(minors, list) and bool(minors), "no minors")
    ok, out = set(allowed), []
    for k, mnr in enumerate(minors):
        R = mnr.get("rows") if isinstance(mnr, dict) else None
        require(isinstance(R, list) and len(R) == len(cols) and len(set(R)) == len(R) and all(r in ok for r in R), f"minor {k}: not {len(cols)} distinct rows of the pencil")
        var = [(i, j, 1) for i, r in enumerate(R) for j, c in enumerate(cols) if r == c]
        f = poly_det_mod([[mod(K[r][c], p) if c in K[r] else 0 for c in cols] for r in R], var, len(var), p)
        if k == 0:
            d = exact_degree(K, R, cols)
            require(d >= 0 and f.degree() == d, f"the first minor has degree {d} over Q and {f.degree()} modulo {p}: p divides its leading coefficient")
        require(f.degree() == mnr.get("degree"), f"minor {k} has degree {f.degree()} modulo {p}, not {mnr.get('degree')}")
        out.append(f)
    return out


def combination_det(K: Any, rows: Sequence[int], cols: Sequence[int], extra: Sequence[int], Y: Any, p: int) -> nmod_poly:
    """det(T[B] + Y T[E]) modulo p for T(s) = (s I + K)[rows, cols], E = ``extra`` (rows),
    B = the other rows (|B| = |cols|), Y residues (|B| x |E|). By Cauchy-Binet it is
    sum_R det([I | Y][:, R]) det T[R] over the maximal row sets R: every common factor of the
    maximal minors (modulo p) divides it."""
    E = list(extra)
    B = [r for r in rows if r not in set(E)]
    require(len(set(E)) == len(E) and set(E) <= set(rows) and len(B) == len(cols), "a combination's extra rows are not the excess rows of the pencil")
    ok = isinstance(Y, list) and len(Y) == len(B) and all(isinstance(r, list) and len(r) == len(E) and all(isinstance(x, int) and not isinstance(x, bool) for x in r) for r in Y)
    require(ok, "Y is not |B| x |E| residues")

    def mats(rr: Sequence[int]) -> tuple[nmod_mat, nmod_mat]:
        A = nmod_mat(len(rr), len(cols), [mod(K[r][c], p) if c in K[r] else 0 for r in rr for c in cols], p)
        J = nmod_mat(len(rr), len(cols), [int(r == c) for r in rr for c in cols], p)
        return A, J

    (KB, JB), (KE, JE) = mats(B), mats(E)
    Ym = nmod_mat(len(B), len(E), [x % p for r in Y for x in r], p)
    A0, A1 = KB + Ym * KE, JB + Ym * JE
    xs = list(range(len(cols) + 1))
    return _interpolate(xs, [int((A0 + A1 * s).det()) for s in xs], p)


def reduce_poly(f: fmpq_poly, p: int) -> nmod_poly:
    """``f`` modulo p (rejected when p divides a denominator)."""
    return nmod_poly([mod(c, p) for c in f.coeffs()], p)


def _interpolate(xs: list[int], ys: list[int], p: int) -> nmod_poly:
    """The polynomial of degree <= len(xs) - 1 through the points (Newton's divided differences)."""
    c = list(ys)
    m = len(xs)
    for j in range(1, m):
        for i in range(m - 1, j - 1, -1):
            c[i] = (c[i] - c[i - 1]) * pow(xs[i] - xs[i - j], -1, p) % p
    out = nmod_poly([c[-1]], p)
    for i in range(m - 2, -1, -1):
        out = out * nmod_poly([-xs[i] % p, 1], p) + c[i]
    return out


# -------------------------------------------------------------------------------------------
# exact ranks over Q


def rank_exact(rows: Sequence[Sequence[fmpq]]) -> int:
    """The rank over Q of a (small) dense rational matrix."""
    if not rows or not rows[0]:
        return 0
    return int(fmpq_mat(len(rows), len(rows[0]), [x for r in rows for x in r]).rank())


# -------------------------------------------------------------------------------------------
# number fields (rings) Q[t]/(g)


class Field:
    """Arithmetic modulo a polynomial ``g`` over Q: the ring Q[t]/(g).

    A vector whose entries satisfy equations modulo ``g`` satisfies them at every root of
    ``g`` (every complex root, whether ``g`` is irreducible or not); an element ``a`` is
    nonzero at every root of ``g`` iff gcd(a, g) = 1. A rational number is the constant
    polynomial; the rational ``r`` itself is the field of ``g = t - r``.
    """

    def __init__(self, spec: Any, where: str = "field") -> None:
        if not isinstance(spec, dict) or not isinstance(spec.get("modulus"), list):
            raise Rejected(f"{where}: expected {{'modulus': [c0, c1, ...]}}")
        self.g = fmpq_poly([rational(c, where) for c in spec["modulus"]])
        require(self.g.degree() >= 1, f"{where}: the modulus must have degree >= 1")
        self.t = self.reduce(fmpq_poly([0, 1]))

    def reduce(self, a: fmpq_poly) -> fmpq_poly:
        return a % self.g

    def element(self, x: Any, where: str) -> fmpq_poly:
        """``x``: a rational, or a list of rational coefficients (lowest degree first)."""
        if isinstance(x, list):
            return self.reduce(fmpq_poly([rational(c, where) for c in x]))
        return fmpq_poly([rational(x, where)])

    def vector(self, entries: Any, index: Any, n: int, where: str) -> list[fmpq_poly]:
        if not isinstance(entries, dict):
            raise Rejected(f"{where}: expected {{agent: value}}")
        v = [fmpq_poly(0)] * n
        for lab, x in entries.items():
            v[index(lab, where)] = self.element(x, where)
        return v

    def is_zero(self, a: fmpq_poly) -> bool:
        return self.reduce(a) == 0

    def nonzero_everywhere(self, a: fmpq_poly) -> bool:
        """``a`` vanishes at no root of ``g``."""
        return self.reduce(a) != 0 and self.g.gcd(self.reduce(a)).degree() == 0

    def is_rational(self) -> bool:
        return self.g.degree() == 1

    def root_if_rational(self) -> fmpq | None:
        if self.g.degree() != 1:
            return None
        c = self.g.coeffs()
        return -c[0] / c[1]

    def apply(self, rows: Sequence[dict[int, fmpq]], v: Sequence[fmpq_poly]) -> list[fmpq_poly]:
        """``M v`` reduced modulo ``g`` (M rational, sparse rows)."""
        return [self.reduce(x) for x in matvec(rows, v, fmpq_poly(0))]


# -------------------------------------------------------------------------------------------
# ball arithmetic


def hurwitz(F: Sequence[Sequence[fmpq]], claim: Any = None) -> float:
    """An upper bound on max Re of the eigenvalues of the exact rational matrix ``F``.

    The characteristic polynomial is computed exactly over Q (``fmpq_mat.charpoly``); it must
    be the one ``claim`` states (``{"prime": p, "charpoly": residues, lowest degree first}``);
    its roots are enclosed by :func:`hurwitz_poly`.
    """
    n = len(F)
    if n == 0:
        return float("-inf")
    p = fmpq_mat(n, n, [x for r in F for x in r]).charpoly()
    if claim is not None:
        q = prime(claim.get("prime"))
        require([int(c) for c in reduce_poly(p, q).coeffs()] == claim.get("charpoly"), f"the characteristic polynomial is not the one stated (modulo {q})")
    return hurwitz_poly(p)


def lyapunov(F: Sequence[Sequence[fmpq]], cert: Any, discrete: bool = False) -> None:
    """F is Hurwitz, by a Lyapunov matrix: P = P^T > 0 and Q = -(F^T P + P F) > 0 (both by
    :func:`positive_definite`, with the stated shifts and factors). For F v = lam v, v != 0:
    v* Q v = -2 Re(lam) v* P v, so Re lam < 0. ``discrete``: F is Schur stable, by P > 0 and
    Q = P - F^T P F > 0 (Stein): v* Q v = (1 - |z|^2) v* P v, so |z| < 1.

    ``cert``: ``{"P", "R_P", "R_Q"}`` upper triangles of integers scaled by 2^-scale
    (``{"scale": b, "upper": rows}``) and ``"shift_P"``, ``"shift_Q"`` (rationals). Exact
    integer products (python-flint)."""
    require(isinstance(cert, dict), "a Lyapunov certificate is a mapping")
    n = len(F)
    Pu, bP = _dyadic_upper(cert.get("P"), n, "P")
    U = fmpz_mat(n, n, [v for r in Pu for v in r])
    Pi = U + U.transpose()  # the symmetric P from its upper triangle: the diagonal counted once
    for i in range(n):
        Pi[i, i] = U[i, i]
    Fi, dF = integer_matrix(F)
    dP = 1 << bP
    G = Pi * Fi  # F^T P = (P F)^T, P symmetric: one product
    if discrete:
        Qi, dQ = Pi * (dF * dF) - Fi.transpose() * G, dF * dF * dP
    else:
        Qi, dQ = -(G + G.transpose()), dF * dP
    positive_definite(Pi, dP, rational(cert.get("shift_P"), "shift_P"), cert.get("R_P"), "P")
    positive_definite(Qi, dQ, rational(cert.get("shift_Q"), "shift_Q"), cert.get("R_Q"), "Q")


def _dyadic_upper(x: Any, n: int, what: str) -> tuple[list[list[int]], int]:
    """An n x n upper triangle of integers and its scale exponent: (rows padded with zeros, b)."""
    ok = isinstance(x, dict) and isinstance(x.get("scale"), int) and 0 <= x["scale"] <= 4096 and isinstance(x.get("upper"), list) and len(x["upper"]) == n
    require(ok and all(isinstance(r, list) and len(r) == n - i and all(type(v) is int for v in r) for i, r in enumerate(x["upper"])), f"{what} is not {{scale, upper}} of an {n} x {n} matrix")
    return [[0] * i + list(r) for i, r in enumerate(x["upper"])], x["scale"]


def integer_matrix(M: Sequence[Sequence[fmpq]]) -> tuple[fmpz_mat, int]:
    """(d M as an integer matrix, d) with d the lcm of the denominators."""
    if not M or not M[0]:
        return fmpz_mat(len(M), 0, []), 1
    Z, d = fmpq_mat(len(M), len(M[0]), [x for r in M for x in r]).numer_denom()  # python-flint: Z / d == M, d the lcm
    return Z, int(d)


def positive_definite(Z: fmpz_mat, scale: int, c: fmpq, R: Any, what: str) -> None:
    """A = Z / scale (symmetric) is positive definite: with the stated R (upper triangular,
    integers scaled by 2^-b; in practice a Cholesky factor of A - c I) the residual
    E = A - c I - R^T R, computed exactly, has ||E||_F < c; then for every x,
    x^T A x = |R x|^2 + c |x|^2 + x^T E x >= (c - ||E||_2) |x|^2 > 0."""
    n = Z.nrows()
    require(c > 0, f"the shift of {what} must be positive")
    Ru, b = _dyadic_upper(R, n, f"the factor of {what}")
    Ri = fmpz_mat(n, n, [v for r in Ru for v in r])
    cn, cd = int(c.p), int(c.q)
    E = (Z * (cd << 2 * b)) - (Ri.transpose() * Ri) * (scale * cd)
    shift = cn * scale << 2 * b
    for i in range(n):  # - c I, scaled
        E[i, i] -= shift
    entries = E.entries()
    require(sum(map(mul, entries, entries)) < shift * shift, f"{what}: the residual of its factor is not below the shift")


def hurwitz_poly(p: fmpq_poly) -> float:
    """An upper bound on max Re of the complex roots of ``p`` (degree >= 1): python-flint's
    validated ball enclosures of the roots of its squarefree factors, multiplicities counted.
    Reject when the enclosure fails."""
    try:
        roots = p.complex_roots()
    except (ValueError, ArithmeticError) as exc:
        raise Rejected(f"the roots could not be enclosed ({exc})") from None
    require(sum(m for _, m in roots) == p.degree(), "the root enclosures miss a root")
    return max(float(r.real.upper()) for r, _ in roots)


def poly_det(M: Sequence[Sequence[fmpq_poly]]) -> fmpq_poly:
    """The determinant over Q[t] of a small square matrix of polynomials (fraction-free
    Gaussian elimination, Bareiss: every division is exact in Q[t])."""
    k = len(M)
    A = [list(r) for r in M]
    require(all(len(r) == k for r in A), "a minor that is not square")
    sign, prev = 1, fmpq_poly([1])
    for c in range(k):
        piv = next((r for r in range(c, k) if A[r][c] != 0), None)
        if piv is None:
            return fmpq_poly(0)
        if piv != c:
            A[c], A[piv], sign = A[piv], A[c], -sign
        for r in range(c + 1, k):
            for j in range(c + 1, k):
                A[r][j] = (A[c][c] * A[r][j] - A[r][c] * A[c][j]) // prev
        prev = A[c][c]
    return sign * A[k - 1][k - 1] if k else fmpq_poly([1])


def dense(rows: Sequence[dict[int, fmpq]], cols: Iterable[int], pick: Iterable[int] | None = None) -> list[list[fmpq]]:
    """The dense rational submatrix of sparse ``rows`` (rows ``pick``, default all) on ``cols``."""
    cols = list(cols)
    rr = range(len(rows)) if pick is None else pick
    return [[rows[i].get(j, fmpq(0)) for j in cols] for i in rr]


def unit(computed: int, claim: Any, p: int, what: str) -> None:
    """A residue the certificate states as ``[r, r^-1 mod p]``: it must be the one computed,
    and the stated inverse proves it nonzero modulo ``p``."""
    ok = isinstance(claim, list) and len(claim) == 2 and all(isinstance(x, int) and not isinstance(x, bool) for x in claim)
    require(ok, f"{what}: expected [residue, inverse]")
    require(computed == claim[0], f"{what} is {computed} modulo {p}, not {claim[0]}")
    require(claim[0] * claim[1] % p == 1, f"{what}: {claim[1]} is not the inverse of {claim[0]} modulo {p}")


