"""Exact and ball arithmetic the checks share: sparse products, reduction modulo a prime,
minors, Krylov matrices, number fields Q[t]/(g), polynomial determinants, eigenvalue
enclosures. Every function decides one stated fact; none searches.

Reduction modulo a prime ``p`` is the ring map Z_(p) -> F_p (rationals whose denominator
``p`` does not divide). It maps a determinant to the determinant of the reduced matrix, so a
minor that is nonzero modulo ``p`` is nonzero over Q: a rank modulo ``p`` is a lower bound on
the rank over Q.
"""

from __future__ import annotations

from typing import Any, Iterable, Sequence

from flint import fmpq, fmpq_mat, fmpq_poly, fmpz, nmod_mat, nmod_poly

from glocal_check.spec import CheckError, rational

__all__ = [
    "Field",
    "Rejected",
    "det_mod",
    "hurwitz",
    "krylov_det",
    "matvec",
    "mod",
    "poly_det_exact",
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
    xs, ys = [], []
    for s in range(degree + 1):
        M = [list(r) for r in constant]
        for i, j, c in variable:
            M[i][j] = (M[i][j] + s * c) % p
        xs.append(s)
        ys.append(int(nmod_mat(k, k, [x for r in M for x in r], p).det()) if k else 1)
    return _interpolate(xs, ys, p)


def poly_det_exact(constant: Sequence[Sequence[fmpq]], variable: Sequence[tuple[int, int, int]], degree: int) -> fmpq_poly:
    """det(K + s J) over Q (as :func:`poly_det_mod`, with exact rational determinants)."""
    k = len(constant)
    out = fmpq_poly(0)
    pts = list(range(degree + 1))
    for x in pts:
        M = [list(r) for r in constant]
        for i, j, c in variable:
            M[i][j] = M[i][j] + x * c
        y = fmpq_mat(k, k, [v for r in M for v in r]).det() if k else fmpq(1)
        basis = fmpq_poly([1])
        for z in pts:
            if z != x:
                basis = basis * fmpq_poly([-z, 1]) / (x - z)
        out += basis * y
    return out


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
    its roots are enclosed by ``fmpq_poly.complex_roots`` (validated ball enclosures of the
    roots of its squarefree factors, multiplicities counted). Reject when the enclosure fails.
    """
    n = len(F)
    if n == 0:
        return float("-inf")
    p = fmpq_mat(n, n, [x for r in F for x in r]).charpoly()
    if claim is not None:
        q = prime(claim.get("prime"))
        require([int(c) for c in reduce_poly(p, q).coeffs()] == claim.get("charpoly"), f"the characteristic polynomial is not the one stated (modulo {q})")
    try:
        roots = p.complex_roots()
    except (ValueError, ArithmeticError) as exc:
        raise Rejected(f"the eigenvalues could not be enclosed ({exc})") from None
    require(sum(m for _, m in roots) == n, "the root enclosures miss an eigenvalue")
    return max(float(r.real.upper()) for r, _ in roots)


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


