"""Kernels of the reduced cluster pencil over a number field through the transfer function.

The reduced pencil of Proposition III.2 (iii) (:mod:`glocal_verify.analysis.local.cluster_pencil`) is

.. math:: Q(s) = (s I + \\alpha L)[R, U],\\qquad R = P_i \\setminus I,\\quad U = P_i \\setminus M,

with L the exact n x n block L[P_i, P_i], I the input agents (suspected and boundary) and M
the measured ones. For an irreducible factor f of its zero polynomial, the exact analysis
needs, over the field K = Q[s]/(f) (one root theta of f; by Galois symmetry the same at every
root),

* k_Q = dim ker Q(theta) and k_U = dim ker (theta I + alpha L)[P_i, U] (a kernel vector of
  Q(theta) with a nonzero input exists iff k_Q > k_U), and
* one exact kernel vector of Q(theta), evaluated at the roots for the witness.

The reference computes both by eliminations of the |R| x |U| and n x |U| matrices over K
(:func:`~glocal_verify.numerics.pencil_exact.rank_over_field`), each O(n^3) operations on
residues of degree deg f: minutes for a cluster of 67 agents and a factor of degree 57.

Transfer function (proof)
    Let d(s) = det(s I + alpha L) and N(s) = adj(s I + alpha L) S_I^T (n x |I|), computed
    once over Q[s] (:func:`cluster_transfer`). A vector xi on U lies in ker Q(theta) iff its
    extension by zero on M, Xi, satisfies ((theta I + alpha L) Xi)_R = 0, i.e.
    (theta I + alpha L) Xi = S_I^T u with u = ((theta I + alpha L) Xi)_I. When f does not
    divide d (theta is not a *pole*), theta I + alpha L is invertible over K and
    Xi = N(theta) u / d(theta); conversely every u with S_M N(theta) u = 0 gives such a Xi with
    Xi_M = 0. The map u -> Xi is injective (S_I^T is), so

    .. math:: k_Q = |I| - \\operatorname{rank}_K S_M N(\\theta),\\qquad k_U = 0,

    an |M| x |I| elimination over K instead of two n-sized ones, and the basis vectors u of
    ker S_M N(theta) lift to exact kernel vectors Xi_U of Q(theta). Both statements are
    identities over K: no modular or random step is involved. At a pole (f divides d) the
    function returns None and the caller eliminates over K as before.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Sequence

import flint
import numpy as np

from glocal_verify.numerics.exact import coefficient_bits
from glocal_verify.numerics.pencil_exact import RootEnclosures, echelon_mod


__all__ = ["ClusterTransfer", "TransferKernel", "adjugate_columns", "cluster_transfer", "eval_normalized", "fraction_free_kernel", "transfer_kernel"]


@dataclass(frozen=True, eq=False)
class ClusterTransfer:
    """d(s) = det(s I + alpha L) and N(s) = adj(s I + alpha L) S_I^T over Q[s].

    Attributes
    ----------
    size : int
        n, the agents of the block.
    inputs : tuple of int
        I (indices into the block), the columns of N in this order.
    charpoly : fmpq_poly
        d(s), monic of degree n.
    numerators : tuple of tuple of fmpq_poly
        N(s), n rows of |I| polynomials of degree < n.
    """

    size: int
    inputs: tuple[int, ...]
    charpoly: Any
    numerators: tuple[tuple[Any, ...], ...]


def cluster_transfer(L: Sequence[Sequence[Fraction | int]], alpha: Fraction, inputs: Sequence[int]) -> ClusterTransfer:
    """d(s) and N(s) = adj(s I + alpha L) S_I^T by Faddeev-LeVerrier on the input columns.

    .. math::

        \\operatorname{adj}(sI - A) = \\sum_{j<n} s^j B_j,\\quad B_{n-1} = I,\\quad
        B_{j-1} = A B_j + c_j I,\\qquad A = -\\alpha L,\\ d(s) = \\sum_j c_j s^j,

    so W_j = B_j S_I^T costs n products of A with an n x |I| matrix over Q (exact).

    Parameters
    ----------
    L : rows of rationals
        The exact block L[P_i, P_i] (n x n).
    alpha : Fraction
    inputs : sequence of int
        I, distinct indices into the block.

    Returns
    -------
    ClusterTransfer
    """
    n, m = len(L), len(inputs)
    a = flint.fmpq(Fraction(alpha).numerator, Fraction(alpha).denominator)
    flat = []
    for i in range(n):
        for j in range(n):
            x = Fraction(L[i][j])
            flat.append(-a * flint.fmpq(x.numerator, x.denominator))
    A = flint.fmpq_mat(n, n, flat) if n else flint.fmpq_mat(0, 0)
    if m == 0 or n == 0:
        d = A.charpoly() if n else flint.fmpq_poly(1)
        return ClusterTransfer(n, tuple(inputs), d, tuple(() for _ in range(n)))
    d, N = adjugate_columns(A, inputs)
    return ClusterTransfer(n, tuple(inputs), d, N)


def adjugate_columns(A: Any, cols: Sequence[int]) -> tuple[Any, tuple[tuple[Any, ...], ...]]:
    """det(sI - A) and the columns ``cols`` of adj(sI - A), as polynomials in s over Q.

    Faddeev-LeVerrier on the selected columns only: with d(s) = det(sI - A) = sum_j c_j s^j,
    adj(sI - A) = sum_{j < n} s^j B_j, B_{n-1} = I, B_{j-1} = A B_j + c_j I, so W_j = B_j S^T
    costs n products of A with an n x |cols| matrix (exact).

    Parameters
    ----------
    A : fmpq_mat
        n x n, n >= 1.
    cols : sequence of int
        Column indices (|cols| >= 1).

    Returns
    -------
    (d, P)
        ``d`` an fmpq_poly; ``P[i][k]`` the (i, cols[k]) entry of adj(sI - A), an fmpq_poly.
    """
    n, m = A.nrows(), len(cols)
    d = A.charpoly()
    c = d.coeffs()
    S = flint.fmpq_mat(n, m, [int(cols[k] == i) for i in range(n) for k in range(m)])
    W = S
    Ws = [W]
    for j in range(n - 1, 0, -1):
        W = A * W + S * c[j]
        Ws.append(W)
    Ws.reverse()  # Ws[j] = B_j S^T
    return d, tuple(tuple(flint.fmpq_poly([Wj[i, k] for Wj in Ws]) for k in range(m)) for i in range(n))


@dataclass(frozen=True, slots=True)
class TransferKernel:
    """ker Q(theta) over Q[s]/(f) off the poles (module docstring).

    Attributes
    ----------
    dim : int
        k_Q = dim ker Q(theta).
    unforced_dim : int
        k_U = dim ker (theta I + alpha L)[P_i, U]: 0 off the poles.
    vector : tuple of fmpq_poly or None
        The lift Xi_U (on ``cols``, residues mod f) of the first reduced basis vector of
        ker S_M N(theta); None when k_Q = 0.
    """

    dim: int
    unforced_dim: int
    vector: tuple[Any, ...] | None

    @property
    def has_input(self) -> bool:
        """A kernel vector of Q(theta) with a nonzero input exists: k_Q > k_U."""
        return self.dim > self.unforced_dim


def transfer_kernel(tr: ClusterTransfer, f: Any, measured: Sequence[int], cols: Sequence[int]) -> TransferKernel | None:
    """ker Q(theta) at the roots of the irreducible ``f`` through the transfer function.

    Parameters
    ----------
    tr : ClusterTransfer
        :func:`cluster_transfer` of the block, alpha and the inputs I of Q.
    f : fmpq_poly
        Irreducible over Q (variable s).
    measured : sequence of int
        M (the outputs; U = P_i \\ M).
    cols : sequence of int
        The columns U of Q in the order of the returned vector.

    Returns
    -------
    TransferKernel or None
        None when f divides d(s) (a pole: the caller eliminates over the field).
    """
    dg = tr.charpoly % f
    if dg.is_zero():
        return None
    m = len(tr.inputs)
    if m == 0:
        return TransferKernel(0, 0, None)
    rows = [[tr.numerators[r][k] % f for k in range(m)] for r in measured]
    dim, u = fraction_free_kernel(rows, f, m)
    if u is None:
        return TransferKernel(0, 0, None)
    # Xi = N(theta) u / d(theta); the nonzero factor 1 / d(theta) is left out (a kernel vector
    # times a nonzero scalar of the field is one), which avoids an inversion in Q[s]/(f)
    Xi: dict[int, Any] = {}
    for i in list(cols) + list(measured):
        acc = flint.fmpq_poly(0)
        for k in range(m):
            if not u[k].is_zero():
                acc += tr.numerators[i][k] * u[k]
        Xi[i] = acc % f
    if any(not Xi[r].is_zero() for r in measured):  # pragma: no cover - S_M N u = 0 by construction
        raise AssertionError("the lifted transfer kernel vector does not vanish on M; please report")
    if all(Xi[j].is_zero() for j in cols):  # pragma: no cover - u -> Xi is injective off the poles
        raise AssertionError("a nonzero transfer kernel vector lifts to zero; please report")
    return TransferKernel(dim, 0, tuple(Xi[j] for j in cols))


def fraction_free_kernel(M: Sequence[Sequence[Any]], f: Any, ncols: int) -> tuple[int, tuple[Any, ...] | None]:
    """dim ker M and one nonzero kernel vector over Q[s]/(f), without inverting in the field.

    Fraction-free Gauss-Jordan elimination (:func:`~glocal_verify.numerics.pencil_exact.echelon_mod`
    with ``fraction_free``: every other row i becomes p row_i - c row_r, so the row space and
    the rank stay those of M). In the final form each pivot row r reads
    p_r x_{piv_r} + sum_{j free} a_{rj} x_j = 0; for the first free column j the vector
    x_j = prod_t p_t, x_{piv_r} = -a_{rj} prod_{t != r} p_t, other free entries 0, is a nonzero
    kernel vector. No xgcd (the field inverse, whose cofactors have huge coefficients) is needed.

    Parameters
    ----------
    M : rows of fmpq_poly
        The matrix (entries reduced or not mod f).
    f : fmpq_poly
        Irreducible over Q.
    ncols : int

    Returns
    -------
    (dim, vector)
        ncols - rank and a kernel vector (residues mod f), or None when the kernel is 0.
    """
    rows, piv = echelon_mod(M, f, ncols, fraction_free=True)
    r = len(piv)
    free = [j for j in range(ncols) if j not in piv]
    if not free:
        return 0, None
    j = free[0]
    pivots = [rows[t][piv[t]] for t in range(r)]
    v = [flint.fmpq_poly(0)] * ncols
    prod = flint.fmpq_poly(1)
    for p in pivots:
        prod = prod * p % f
    v[j] = prod
    for t in range(r):
        others = flint.fmpq_poly(1)
        for u, p in enumerate(pivots):
            if u != t:
                others = others * p % f
        v[piv[t]] = (-rows[t][j] * others) % f
    return len(free), tuple(v)


def eval_normalized(polys: Sequence[Any], f: Any, root: complex, enclosures: RootEnclosures) -> np.ndarray | None:
    """Values of residues mod ``f`` at the root of f nearest ``root``, divided by the largest.

    Like :func:`~glocal_verify.numerics.pencil_exact.eval_at_root`, but the division by the
    entry of largest magnitude is done in ball arithmetic before rounding to double, so that
    a kernel vector with huge entries (a fraction-free one) does not overflow. The vector is
    first divided by the content of its coefficients (exactly; fraction-free eliminations leave
    large common factors). Precision from 256 bits up until every ball is below 1e-17, up to
    :func:`_precision_cap` bits (enough for the coefficients' size); if the largest entry's ball
    still holds 0 there, the vector is scaled exactly so that one nonzero entry is 1 (its
    inverse in Q[s]/(f)) and evaluated again. A nonzero residue of an irreducible f is nonzero
    at every root, so this ends; should it not (a pathological size), None is returned and the
    caller reports the zero without its direction, never an error.

    Parameters
    ----------
    polys : sequence of fmpq_poly
        A nonzero vector of residues.
    f : fmpq_poly
        Irreducible polynomial.
    root : complex
        Approximation of the wanted root.
    enclosures : RootEnclosures
        The root balls of ``f``.

    Returns
    -------
    ndarray or None
    """
    vec = _primitive(polys)
    for attempt in range(2):
        out = _eval_balls(vec, f, root, enclosures, _precision_cap(vec, f))
        if out is not None:
            return out
        if attempt == 0:
            vec = _unit_entry(vec, f)
    return None


def _eval_balls(polys: Sequence[Any], f: Any, root: complex, enclosures: RootEnclosures, cap: int) -> np.ndarray | None:
    """The normalized values at increasing precision up to ``cap`` bits (None: not separated from 0)."""
    prec = 256
    while True:
        old = flint.ctx.prec
        try:
            flint.ctx.prec = prec
            r = min(enclosures.at(prec), key=lambda a: abs(complex(float(a.real.mid()), float(a.imag.mid())) - root))
            vals = [flint.acb_poly(q)(r) for q in polys]
            mags = [abs(v).mid() for v in vals]
            k = max(range(len(vals)), key=lambda i: mags[i])
            if vals[k].contains(0):
                out = None
            else:
                q = [v / vals[k] for v in vals]
                out = np.array([complex(float(v.real.mid()), float(v.imag.mid())) for v in q], dtype=complex)
                rad = max(float(v.real.rad()) + float(v.imag.rad()) for v in q)
        finally:
            flint.ctx.prec = old
        if out is not None and (rad <= 1e-17 or prec >= cap):
            return out
        if prec >= cap:
            return None
        prec = min(prec * 4, cap)


def _precision_cap(polys: Sequence[Any], f: Any) -> int:
    """Bits enough to evaluate ``polys`` at a root of ``f`` without losing them all to
    cancellation: twice their coefficients' size plus the size of the powers of the root
    (bounded by f's coefficients), at least 16384."""
    return max(16384, 2 * (coefficient_bits(polys) + f.degree() * coefficient_bits([f])) + 256)


def _primitive(polys: Sequence[Any]) -> list[Any]:
    """``polys`` divided by the positive rational content of all their coefficients (exact)."""
    import math

    den = 1
    for q in polys:
        den = math.lcm(den, int(q.denom()))
    nums = [q.numer() * (den // int(q.denom())) for q in polys]
    g = 0
    for p in nums:
        g = math.gcd(g, int(p.content()))
    if g in (0, 1):
        return [flint.fmpq_poly(p) for p in nums]
    return [flint.fmpq_poly(p) / g for p in nums]


def _unit_entry(polys: Sequence[Any], f: Any) -> list[Any]:
    """``polys`` times the inverse in Q[s]/(f) of their first nonzero entry (that entry becomes 1)."""
    k = next(i for i, q in enumerate(polys) if not (q % f).is_zero())
    g, inv, _ = (polys[k] % f).xgcd(f)
    inv = inv / g
    return [(q * inv) % f for q in polys]
