"""The Rosenbrock system pencil over Q: normal rank, invariant zeros and directions in number fields.

Zeros are the roots of irreducible factors over Q; directions are kernels over Q[x]/(f),
evaluated at certified root enclosures (python-flint ``acb``, :class:`RootEnclosures`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from functools import cached_property
from typing import Any, Sequence

import flint
import numpy as np

from glocal_verify.errors import ModelError, NotApplicableError
from glocal_verify.numerics import exact as ex
from glocal_verify.numerics.pencil import _normalize_phase
from glocal_verify.numerics.rounding import EPS, svd_error

__all__ = [
    "ExactZero",
    "ExactPencilAnalysis",
    "analyze_pencil_exact",
    "FieldKernel",
    "RootEnclosures",
    "kernel_over_field",
    "rank_over_field",
    "poly_pencil",
    "classify_real_parts",
    "echelon_mod", "eval_at_root", "inv_mod", "rational_kernel",
    "RankBounds",
    "rounding_error",
    "structural_rank",
    "rank_bounds",
]

# ------------------------------------------------------------------------------------------
# exact


def _check_rows(M: ex.Rows, nrows: int, ncols: int, name: str) -> None:
    if len(M) != nrows or any(len(r) != ncols for r in M):
        raise ModelError(f"{name} must be {nrows} x {ncols}")


def _v_star_exact(A: Any, B: Any, C: Any) -> Any:
    """Largest (A, B)-invariant subspace in ker C (columns of an fmpq_mat)."""
    n = A.nrows()
    V = rational_kernel(C) if C.nrows() else _identity(n)
    while True:
        W = _hstack(V, B) if B.ncols() else V
        if W.ncols() == 0:
            Wperp = _identity(n)
        else:
            Wperp = rational_kernel(W.transpose()).transpose()
        stack = _vstack(C, Wperp * A) if C.nrows() else Wperp * A
        Vn = rational_kernel(stack) if stack.nrows() else _identity(n)
        if Vn.ncols() == V.ncols():
            return V
        V = Vn


def _fq(x: Any) -> Any:
    if isinstance(x, Fraction):
        return flint.fmpq(x.numerator, x.denominator)
    return flint.fmpq(x)


def _mat(rows: Sequence[Sequence[Any]], nrows: int, ncols: int) -> Any:
    flat = [_fq(x) for r in rows for x in r]
    return flint.fmpq_mat(nrows, ncols, flat) if flat else flint.fmpq_mat(nrows, ncols)


def _cols(M: Any, idx: Sequence[int]) -> Any:
    rows = M.tolist()
    return _mat([[r[j] for j in idx] for r in rows], M.nrows(), len(idx))


def _hstack(*Ms: Any) -> Any:
    nr = Ms[0].nrows()
    rows = [[] for _ in range(nr)]  # type: list[list[Any]]
    for M in Ms:
        for i, r in enumerate(M.tolist()):
            rows[i].extend(r)
    return _mat(rows, nr, sum(M.ncols() for M in Ms))


def _vstack(*Ms: Any) -> Any:
    nc = Ms[0].ncols()
    rows: list[list[Any]] = []
    for M in Ms:
        rows.extend(M.tolist())
    return _mat(rows, len(rows), nc)


def _pivots(R: Any, r: int) -> list[int]:
    piv = []
    for i in range(r):
        for j in range(R.ncols()):
            if R[i, j] != 0:
                piv.append(j)
                break
    return piv


def rational_kernel(M: Any) -> Any:
    """Basis of the right kernel over Q as the columns of an fmpq_mat."""
    n = M.ncols()
    if M.nrows() == 0:
        return _mat([[int(i == j) for j in range(n)] for i in range(n)], n, n)
    R, r = M.rref()
    piv = _pivots(R, int(r))
    free = [j for j in range(n) if j not in piv]
    cols = []
    for f in free:
        v = [flint.fmpq(0)] * n
        v[f] = flint.fmpq(1)
        for i, pj in enumerate(piv):
            v[pj] = -R[i, f]
        cols.append(v)
    return _mat([[c[i] for c in cols] for i in range(n)], n, len(cols))


def _colspace(M: Any) -> Any:
    """Independent columns of M spanning Im M."""
    if M.ncols() == 0 or M.nrows() == 0:
        return flint.fmpq_mat(M.nrows(), 0)
    R, r = M.rref()
    return _cols(M, _pivots(R, int(r)))


def _intersect(X: Any, Y: Any) -> Any:
    n = X.nrows()
    if X.ncols() == 0 or Y.ncols() == 0:
        return flint.fmpq_mat(n, 0)
    K = rational_kernel(_hstack(X, -Y))
    if K.ncols() == 0:
        return flint.fmpq_mat(n, 0)
    Ka = _mat(K.tolist()[: X.ncols()], X.ncols(), K.ncols())
    return _colspace(X * Ka)


def _solve_particular(M: Any, RHS: Any) -> Any:
    """A solution X of M X = RHS (free variables zero); raises if inconsistent."""
    nc = M.ncols()
    R, r = _hstack(M, RHS).rref()
    piv = _pivots(R, int(r))
    if any(j >= nc for j in piv):
        raise AssertionError("inconsistent linear system in the geometric algorithm; please report")
    X = [[flint.fmpq(0)] * RHS.ncols() for _ in range(nc)]
    for i, j in enumerate(piv):
        for k in range(RHS.ncols()):
            X[j][k] = R[i, nc + k]
    return _mat(X, nc, RHS.ncols())


def _identity(n: int) -> Any:
    return _mat([[int(i == j) for j in range(n)] for i in range(n)], n, n)


def poly_pencil(A: ex.Rows, B: ex.Rows, C: ex.Rows, n: int, m: int, p: int) -> list[list[Any]]:
    """The pencil [[x I - A, -B], [C, 0]] with ``fmpq_poly`` entries in the variable x.

    Parameters
    ----------
    A, B, C : rows of rationals
        System matrices (n x n, n x m, p x n).
    n, m, p : int
        Dimensions (needed when B or C has no columns or rows).
    """
    x = flint.fmpq_poly([0, 1])
    rows: list[list[Any]] = []
    for i in range(n):
        row = [(x if i == j else flint.fmpq_poly(0)) - _fq(A[i][j]) for j in range(n)]
        row += [flint.fmpq_poly(-_fq(B[i][k])) for k in range(m)]
        rows.append(row)
    for i in range(p):
        rows.append([flint.fmpq_poly(_fq(C[i][j])) for j in range(n)] + [flint.fmpq_poly(0)] * m)
    return rows


def inv_mod(a: Any, f: Any) -> Any:
    """The inverse of ``a`` in the field Q[x]/(f) (f irreducible)."""
    g, s, _t = a.xgcd(f)
    if g.degree() != 0:
        raise AssertionError("division by a zero divisor of Q[x]/(f): f is not irreducible")
    return s / g[0]


def echelon_mod(M: Sequence[Sequence[Any]], f: Any, ncols: int, *, fraction_free: bool = False) -> tuple[list[list[Any]], list[int]]:
    """Gauss-Jordan elimination of a polynomial matrix over the field Q[x]/(f) (f irreducible).

    The one elimination modulo f of the package: :func:`rank_over_field`,
    :func:`kernel_over_field` and :func:`~glocal_verify.numerics.cluster_transfer.fraction_free_kernel`
    read its result. Each pivot (the first entry of its column that is nonzero modulo f, an
    exact test on residues) clears its column in every other row. With ``fraction_free`` False
    the pivot row is first scaled by the pivot's inverse (:func:`inv_mod`; the reduced row
    echelon form, unique); with ``fraction_free`` True every other row i becomes
    ``p row_i - c row_r`` (p the pivot, c the entry of row i in its column): a multiplication
    by the unit p and a row operation, so the row space and the rank are those of M without
    the field inverse (whose cofactors have huge coefficients).

    Parameters
    ----------
    M : rows of fmpq_poly
        The polynomial matrix; its entries need not be reduced modulo f.
    f : fmpq_poly
        The modulus, irreducible over Q.
    ncols : int
        Columns of M (it may have no rows).
    fraction_free : bool

    Returns
    -------
    (rows, pivots)
        The first ``rank`` rows of the eliminated matrix (residues mod f) and the pivot column of each.
    """
    rows = [[e % f for e in row] for row in M]
    piv: list[int] = []
    r = 0
    for col in range(ncols):
        k = next((i for i in range(r, len(rows)) if not rows[i][col].is_zero()), None)
        if k is None:
            continue
        rows[r], rows[k] = rows[k], rows[r]
        p = rows[r][col]
        if not fraction_free:
            inv = inv_mod(p, f)
            rows[r] = [(e * inv) % f for e in rows[r]]
        for i in range(len(rows)):
            if i != r and not rows[i][col].is_zero():
                c = rows[i][col]
                rows[i] = [(p * a - c * b) % f for a, b in zip(rows[i], rows[r])] if fraction_free else [(a - c * b) % f for a, b in zip(rows[i], rows[r])]
        piv.append(col)
        r += 1
        if r == len(rows):
            break
    return rows[:r], piv


def rank_over_field(M: Sequence[Sequence[Any]], f: Any, ncols: int) -> int:
    """Exact rank of a matrix of polynomials evaluated at a root of the irreducible ``f``.

    Computed in the field Q[x]/(f(x)); by Galois symmetry the result is the rank at every
    root of f.

    Parameters
    ----------
    M : rows of ``fmpq_poly``
        The matrix.
    f : fmpq_poly
        Irreducible polynomial over Q.
    ncols : int
        Number of columns (needed when M has no rows).
    """
    if not M:
        return 0
    if f.degree() == 1:
        return int(ex.at_rational_root(M, f, ncols).rank())
    _, piv = echelon_mod(M, f, ncols)
    return len(piv)



@dataclass(frozen=True)
class FieldKernel:
    """Right kernel over Q[x]/(f): basis vectors with ``fmpq_poly`` entries (reduced mod f)."""

    f: Any
    basis: tuple[tuple[Any, ...], ...]

    @cached_property
    def enclosures(self) -> RootEnclosures:
        """Root balls of ``f``, isolated once for every evaluation of this kernel."""
        return RootEnclosures(self.f)

    def evaluate(self, root: complex) -> list[np.ndarray]:
        """Numeric basis vectors at a complex root of f.

        Parameters
        ----------
        root : complex
            A root of ``f``.
        """
        return [eval_at_root(v, self.f, root, self.enclosures) for v in self.basis]


def _poly_eval(p: Any, z: complex) -> complex:
    """p(z) in double precision (Horner); fine for rational z, see :func:`eval_at_root`."""
    acc = 0j
    for c in reversed(p.coeffs()):
        acc = acc * z + float(Fraction(int(c.p), int(c.q)))
    return acc


class RootEnclosures:
    """Certified enclosures (python-flint ``acb`` balls) of the complex roots of one polynomial.

    The roots are isolated once per working precision and kept on this object, which the
    caller holds for as long as it evaluates residues modulo the same polynomial (a
    :class:`FieldKernel` owns one).

    Parameters
    ----------
    f : fmpq_poly
        A squarefree polynomial.
    """

    def __init__(self, f: Any) -> None:
        self.f = f
        self._by_precision: dict[int, list[Any]] = {}

    def at(self, prec: int) -> list[Any]:
        """The root balls at ``prec`` bits.

        Parameters
        ----------
        prec : int
            Working precision in bits.
        """
        if prec not in self._by_precision:
            old = flint.ctx.prec
            try:
                flint.ctx.prec = prec
                self._by_precision[prec] = [r for r, _ in self.f.complex_roots()]
            finally:
                flint.ctx.prec = old
        return self._by_precision[prec]


def _mid(a: Any) -> complex:
    return complex(float(a.real.mid()), float(a.imag.mid()))


def eval_at_root(polys: Sequence[Any], f: Any, root: complex, enclosures: RootEnclosures | None = None) -> np.ndarray:
    """Values of residues mod ``f`` at the root of ``f`` nearest to ``root``, to full double
    precision: ball arithmetic from 256 bits up until every ball is below 1e-17 of the
    largest value (double-precision Horner loses digits when the residues have high degree
    and large coefficients).

    Parameters
    ----------
    polys : sequence of fmpq_poly
        The residues (e.g. a kernel vector over Q[x]/(f)).
    f : fmpq_poly
        Irreducible polynomial.
    root : complex
        Approximation of the wanted root.
    enclosures : RootEnclosures, optional
        The root balls of ``f`` already isolated (reused across calls); default new ones.
    """
    if f.degree() <= 1:
        return np.array([_poly_eval(q, root) for q in polys], dtype=complex)
    enc = enclosures if enclosures is not None else RootEnclosures(f)
    prec = 256
    while True:
        r = min(enc.at(prec), key=lambda a: abs(_mid(a) - root))
        old = flint.ctx.prec
        try:
            flint.ctx.prec = prec
            vals = [flint.acb_poly(q)(r) for q in polys]
        finally:
            flint.ctx.prec = old
        out = np.array([_mid(v) for v in vals], dtype=complex)
        big = float(np.max(np.abs(out), initial=0.0))
        rad = max((float(v.real.rad()) + float(v.imag.rad()) for v in vals), default=0.0)
        if rad <= 1e-17 * big or prec >= 16384:
            return out
        prec *= 4


def kernel_over_field(M: Sequence[Sequence[Any]], f: Any, ncols: int) -> FieldKernel:
    """Exact right kernel of a polynomial matrix at the roots of the irreducible ``f``.

    Parameters
    ----------
    M : rows of ``fmpq_poly``
        The matrix.
    f : fmpq_poly
        Irreducible polynomial over Q.
    ncols : int
        Number of columns.
    """
    if not M:
        return FieldKernel(f, tuple(tuple(flint.fmpq_poly(int(i == j)) for i in range(ncols)) for j in range(ncols)))
    if f.degree() == 1:  # Q[x]/(f) = Q: flint's RREF over Q (the RREF is unique, so the same basis)
        Kq = rational_kernel(ex.at_rational_root(M, f, ncols))
        return FieldKernel(f, tuple(tuple(flint.fmpq_poly(Kq[i, c]) for i in range(ncols)) for c in range(Kq.ncols())))
    R, piv = echelon_mod(M, f, ncols)
    free = [j for j in range(ncols) if j not in piv]
    basis = []
    for fr in free:
        v = [flint.fmpq_poly(0)] * ncols
        v[fr] = flint.fmpq_poly(1)
        for row, pj in zip(R, piv):
            v[pj] = (-row[fr]) % f
        basis.append(tuple(v))
    return FieldKernel(f, tuple(basis))


def classify_real_parts(f: Any) -> list[tuple[complex, int]]:
    """Roots of the irreducible ``f`` with the exact sign of their real parts.

    Returns ``[(root, sign)]`` with ``sign`` in {-1, 0, +1}. Signs come from certified
    arb enclosures; a root whose enclosure straddles Re = 0 is purely imaginary exactly when
    the number of such roots equals the number of real roots of gcd(Re f(iy), Im f(iy))
    (otherwise the precision is raised).

    Parameters
    ----------
    f : fmpq_poly
        Irreducible polynomial over Q (squarefree suffices).
    """
    coeffs = [Fraction(int(c.p), int(c.q)) for c in f.coeffs()]
    if len(coeffs) == 2:
        r = -coeffs[0] / coeffs[1]
        return [(complex(float(r)), (r > 0) - (r < 0))]
    re_c = [Fraction(0)] * len(coeffs)
    im_c = [Fraction(0)] * len(coeffs)
    for k, c in enumerate(coeffs):  # f(iy) = sum c_k i^k y^k
        if k % 4 == 0:
            re_c[k] = c
        elif k % 4 == 1:
            im_c[k] = c
        elif k % 4 == 2:
            re_c[k] = -c
        else:
            im_c[k] = -c
    g = flint.fmpq_poly([_fq(c) for c in re_c]).gcd(flint.fmpq_poly([_fq(c) for c in im_c]))
    n_imag = 0
    if g.degree() > 0:
        roots_g: Any = g.complex_roots()
        n_imag = len([rt for rt in roots_g if rt[0].imag == 0])
    old = flint.ctx.prec
    try:
        prec, cap = 64, max(8192, 4 * f.degree() * (ex.coefficient_bits([f]) + f.degree().bit_length()) + 256)  # root separation: ~ d log2(H d)
        while prec <= cap:
            flint.ctx.prec = prec
            roots = [r for r, _ in f.complex_roots()]
            out: list[tuple[complex, int]] = []
            ambiguous = 0
            for r in roots:
                val = complex(float(r.real.mid()), float(r.imag.mid()))
                if r.real > 0:
                    out.append((val, 1))
                elif r.real < 0:
                    out.append((val, -1))
                else:
                    ambiguous += 1
                    out.append((complex(0.0, val.imag), 0))
            if ambiguous == n_imag:
                return out
            prec = min(prec * 4, cap) if prec < cap else cap + 1
    finally:
        flint.ctx.prec = old
    raise AssertionError(f"cannot separate the real parts of the roots of {f} from 0")  # pragma: no cover


@dataclass(frozen=True, slots=True)
class ExactZero:
    """One root of an irreducible factor of the zero polynomial (exact analysis).

    Attributes
    ----------
    value : complex
        The zero (exact when ``rational`` is set, else a certified 53-bit approximation).
    rational : Fraction or None
        The zero when it is rational.
    factor : str
        Its irreducible factor over Q (variable ``x``).
    multiplicity : int
        Multiplicity of the factor in the zero polynomial.
    real_sign : int
        Exact sign of Re(value): -1, 0 or +1.
    input_direction : bool
        True when ker P(value) holds a direction with u != 0, decided exactly in
        Q[x]/(factor): ``dim ker P(z) > dim ker [[z I - A], [C]]``.
    x, u : ndarray
        A zeroing direction (exact kernel basis vector over Q[x]/(factor), evaluated at the
        root; one with u != 0 when there is one). Complex arrays.
    """

    value: complex
    rational: Fraction | None
    factor: str
    multiplicity: int
    real_sign: int
    input_direction: bool
    x: np.ndarray
    u: np.ndarray


@dataclass(frozen=True, slots=True)
class ExactPencilAnalysis:
    """Normal rank, V*, R* and the invariant zeros of (A, B, C, 0) over Q.

    Attributes
    ----------
    n_states, n_inputs, n_outputs : int
    normal_rank : int
    full_normal_column_rank : bool
        Left-invertible: B injective and V* ∩ Im B = {0}.
    v_star : tuple of tuple of Fraction
        A basis of V* (largest (A, B)-invariant subspace in ker C).
    r_star_dim : int
        dim R* (largest controllability subspace in V*); 0 when left-invertible.
    zero_polynomial : fmpq_poly
        Monic characteristic polynomial of A + B F on V*/R*; its roots are the invariant
        zeros (rank drops below the normal rank).
    factors : tuple of (fmpq_poly, int)
        Monic irreducible factors with multiplicities.
    zeros : tuple of ExactZero
        Every root of every factor.
    """

    n_states: int
    n_inputs: int
    n_outputs: int
    normal_rank: int
    full_normal_column_rank: bool
    v_star: tuple[tuple[Fraction, ...], ...]
    r_star_dim: int
    zero_polynomial: Any
    factors: tuple[tuple[Any, int], ...]
    zeros: tuple[ExactZero, ...]

    @property
    def left_invertible(self) -> bool:
        """Alias of :attr:`full_normal_column_rank`."""
        return self.full_normal_column_rank


def analyze_pencil_exact(
    A: ex.Rows, B: ex.Rows, C: ex.Rows, D: ex.Rows | None = None, *, directions: bool = True, n_inputs: int | None = None
) -> ExactPencilAnalysis:
    """Exact geometric analysis of the Rosenbrock pencil of (A, B, C, 0) over Q.

    .. math::

        \\mathcal V_0 = \\ker C,\\quad \\mathcal V_{k+1} = \\ker C \\cap A^{-1}(\\mathcal V_k +
        \\operatorname{Im} B);\\qquad \\mathcal R_0 = 0,\\quad \\mathcal R_{k+1} =
        \\mathcal V^* \\cap (A \\mathcal R_k + \\operatorname{Im} B)

    Left-invertible iff ker B = 0 and V* ∩ Im B = {0}; invariant zeros = sigma(A + B F |
    V*/R*); full column rank for every lambda iff left-invertible and V* = {0}. The normal
    rank is the exact rank of P at the first integer that is not a zero. No tolerance.

    Parameters
    ----------
    A, B, C : rows of rationals
        System matrices as row lists of :class:`fractions.Fraction` or ints (B with no
        columns: rows of empty lists, or ``[]`` when n = 0).
    D : rows of rationals, optional
        Must be None or zero: only D = 0 is supported (the geometric formulas above are the
        D = 0 ones). A nonzero D raises :class:`~glocal_verify.errors.NotApplicableError`.
    n_inputs : int, optional
        m, needed only when it cannot be read from B (no states).
    directions : bool
        Compute, for every zero, the exact ``input_direction`` flag and a direction
        (one field elimination per irreducible factor). ``False`` leaves ``x``/``u`` empty
        and ``input_direction`` False.

    Returns
    -------
    ExactPencilAnalysis
    """
    n = len(A)
    m = n_inputs if n_inputs is not None else (len(B[0]) if B else 0)
    p = len(C)
    _check_rows(A, n, n, "A")
    if B and any(len(r) != m for r in B):
        raise ModelError(f"B must be {n} x {m}")
    _check_rows(C, p, n, "C")
    if D is not None and any(Fraction(x) != 0 for r in D for x in r):
        raise NotApplicableError("analyze_pencil_exact supports D = 0 only")
    Am = _mat(A, n, n)
    Bm = _mat(B, n, m) if m else flint.fmpq_mat(n, 0)
    Cm = _mat(C, p, n) if p else flint.fmpq_mat(0, n)
    V = _v_star_exact(Am, Bm, Cm)
    k = V.ncols()
    b_rank = int(Bm.rank()) if m else 0
    vb = _intersect(V, Bm).ncols() if (m and k) else 0
    left_inv = b_rank == m and vb == 0
    # R*
    R = flint.fmpq_mat(n, 0)
    if m and k:
        while True:
            Y = _colspace(_hstack(Am * R, Bm)) if R.ncols() else _colspace(Bm)
            Rn = _intersect(V, Y)
            if Rn.ncols() == R.ncols():
                break
            R = Rn
    # restricted map of A + B F on V* (any particular solution defines a friend F)
    if k:
        VB = _hstack(V, Bm) if m else V
        sol = _solve_particular(VB, Am * V)
        T = _mat(sol.tolist()[:k], k, k)
        r = R.ncols()
        if r:
            Rc = _solve_particular(V, R)
            Rr, rr = Rc.transpose().rref()
            piv = _pivots(Rr, int(rr))
            S = [[int(i == j) for j in range(k) if j not in piv] for i in range(k)]
            Bas = _hstack(Rc, _mat(S, k, k - r)) if k - r else Rc
            Tp = Bas.inv() * T * Bas
            rows = Tp.tolist()
            if any(rows[i][j] != 0 for i in range(r, k) for j in range(r)):  # pragma: no cover
                raise AssertionError("R* is not invariant under A + B F; please report")
            Q = _mat([row[r:] for row in rows[r:]], k - r, k - r)
        else:
            Q = T
        z = Q.charpoly() if Q.nrows() else flint.fmpq_poly(1)
    else:
        z = flint.fmpq_poly(1)
    # normal rank: rank at the first integer point that is not a zero
    P = poly_pencil(A, B, C, n, m, p)
    t = 0
    while z(t) == 0:
        t += 1
    rows_t = [[e(t) for e in row] for row in P]
    normal_rank = int(_mat(rows_t, n + p, n + m).rank()) if (n + p) and (n + m) else 0
    if (normal_rank == n + m) != left_inv:  # pragma: no cover - a theorem, kept as a self-check
        raise AssertionError(f"normal rank {normal_rank} disagrees with left-invertibility {left_inv}; please report")
    factors: list[tuple[Any, int]] = []
    if z.degree() > 0:
        _, facs = z.factor()
        for f, mult in facs:
            factors.append((f / f.leading_coefficient(), int(mult)))
    zeros: list[ExactZero] = []
    PxC = [row[:n] for row in P[:n]] + [row[:n] for row in P[n:]]  # [[x I - A], [C]]
    for f, mult in factors:
        roots = classify_real_parts(f)
        rational = None
        if f.degree() == 1:
            c = f.coeffs()
            rational = -Fraction(int(c[0].p), int(c[0].q))
        if directions:
            dk = (n + m) - rank_over_field(P, f, n + m)
            du = n - rank_over_field(PxC, f, n)
            has_u = dk > du
            K = kernel_over_field(P, f, n + m)
            pick = next((v for v in K.basis if any(not e.is_zero() for e in v[n:])), K.basis[0] if K.basis else None)
        else:
            has_u, pick = False, None
        for root, sign in roots:
            value = complex(float(rational)) if rational is not None else root
            if pick is not None:
                vec = eval_at_root(pick, f, value, K.enclosures)
                vec = _normalize_phase(vec)
                xs, us = vec[:n], vec[n:]
            else:
                xs, us = np.zeros(0), np.zeros(0)
            zeros.append(ExactZero(value, rational, str(f), mult, sign, has_u, xs, us))
    vbasis = tuple(tuple(ex.to_fraction(V[i, j]) for i in range(n)) for j in range(k))
    zeros.sort(key=lambda zz: (-zz.value.real, -abs(zz.value.imag)))
    return ExactPencilAnalysis(n, m, p, normal_rank, left_inv, vbasis, R.ncols(), z, tuple(factors), tuple(zeros))


# ------------------------------------------------------------------------------------------
# floating-point certificates (rigorous bounds that make a numeric verdict exact-sound)
def rounding_error(M: np.ndarray, exact: Sequence[Sequence[Any]], support: np.ndarray | None = None) -> float:
    """Rigorous upper bound of ``||M - M_exact||_2`` for a float matrix and its exact rows.

    The difference is formed entry by entry in rational arithmetic (``Fraction``), so the
    bound includes every rounding of the data (weights, degree sums, gains); its Frobenius
    norm is returned rounded upwards (a relative ``(k + 4) eps`` allowance for the k
    floating-point operations of the norm itself).

    Parameters
    ----------
    M : ndarray
        Real float matrix.
    exact : rows of Fraction (or int)
        The exact matrix it stands for, same shape.
    support : ndarray of bool, optional
        A superset of the exact nonzeros: only these and the nonzeros of M are compared.
    """
    M = np.asarray(M, dtype=float)
    d = np.zeros(M.shape)
    where = np.ones(M.shape, dtype=bool) if support is None else np.asarray(support, dtype=bool) | (M != 0)
    for i, j in zip(*(ix.tolist() for ix in np.nonzero(where))):
        if M[i, j] != 0.0 or exact[i][j] != 0:
            d[i, j] = abs(float(Fraction(float(M[i, j])) - Fraction(exact[i][j])))
    k = d.size
    # float(Fraction) rounds to nearest: at most a relative eps / 2 per entry
    return float(np.linalg.norm(d)) * (1.0 + (k + 4) * EPS) + 1e-300 if np.any(d) else 0.0


def structural_rank(pattern: np.ndarray) -> int:
    """Structural (term) rank: the size of a maximum matching of the bipartite row-column
    graph of the nonzero pattern. Every matrix with this pattern (entries outside it are
    exactly zero; entries inside may be anything, zero included) has rank <= this number,
    so it is a rigorous upper bound read off the exact support.

    Parameters
    ----------
    pattern : ndarray of bool
        True where an entry may be nonzero.
    """
    import scipy.sparse
    from scipy.sparse.csgraph import maximum_bipartite_matching

    P = np.asarray(pattern, dtype=bool)
    if P.size == 0 or not P.any():
        return 0
    match = maximum_bipartite_matching(scipy.sparse.csr_matrix(P.astype(np.int8)), perm_type="column")
    return int(np.sum(match >= 0))


@dataclass(frozen=True, slots=True)
class RankBounds:
    """Certified bounds ``lower <= rank(M_exact) <= upper`` of the exact matrix a float stands for.

    Attributes
    ----------
    lower : int
        Singular values certainly nonzero: sigma_i > ``error_bound`` (Weyl: |sigma_i(M_exact)
        - sigma_i(computed)| <= ||M - M_exact||_2 + SVD backward error).
    upper : int
        Structural rank of the exact support, or a smaller bound given by the caller (from
        exact kernel vectors); never more than min(m, n).
    error_bound : float
        ``||M - M_exact||_2 + svd_error(M)``.
    singular_values : ndarray
        Computed singular values, descending.
    """

    lower: int
    upper: int
    error_bound: float
    singular_values: np.ndarray

    @property
    def decided(self) -> bool:
        """The bounds meet: the exact rank is known."""
        return self.lower == self.upper

    @property
    def gap(self) -> float:
        """How far the bound is from separating: the first singular value counted as
        possibly zero divided by ``error_bound`` (> 1 would have certified it nonzero)."""
        s = self.singular_values
        if self.lower >= len(s) or self.error_bound <= 0:
            return 0.0
        return float(s[self.lower] / self.error_bound)


def rank_bounds(
    M: np.ndarray,
    *,
    input_error: float = 0.0,
    pattern: np.ndarray | None = None,
    upper: int | None = None,
) -> RankBounds:
    """Certified rank bounds of the exact matrix represented by ``M`` (:class:`RankBounds`).

    Parameters
    ----------
    M : ndarray
        The float matrix (real or complex) as computed.
    input_error : float
        Upper bound of ``||M - M_exact||_2`` (:func:`rounding_error`; 0 when M is exact, e.g.
        a 0/1 selection).
    pattern : ndarray of bool, optional
        Exact support of M_exact (default: the nonzeros of M, valid when no nonzero exact
        entry underflows to 0).
    upper : int, optional
        An additional rigorous upper bound (e.g. columns minus exactly known kernel vectors).
    """
    M = np.asarray(M)
    r_max = min(M.shape) if M.size else 0
    if M.size == 0:
        return RankBounds(0, 0, 0.0, np.zeros(0))
    s = np.linalg.svd(M, compute_uv=False)
    err = float(input_error) + svd_error(M)
    lo = int(np.sum(s > err))
    up = structural_rank(M != 0 if pattern is None else pattern)
    if upper is not None:
        up = min(up, int(upper))
    up = min(up, r_max)
    return RankBounds(min(lo, up), up, err, s)
