"""The eigendecomposition of a symmetric matrix after a rank-one change, as a factor of the one before.

A safe mode usually differs from the normal mode by one link: ``L_q = L + rho b b^T`` with
``b = e_i - e_j`` and ``rho`` the change of the link's weight. With ``L = U diag(w) U^T``,

.. math:: L_q = U (\\operatorname{diag}(w) + \\rho z z^T) U^T, \\qquad z = U^T b,

so the new eigenvalues are the roots of Golub's secular equation
``1 + rho sum_k z_k^2 / (w_k - x) = 0`` and the new eigenvectors are ``U F`` with F the
eigenvectors of the diagonal-plus-rank-one matrix. F is kept as a factor
(:class:`RankOneFactor`): O(N^2) to compute, and ``U F`` is never needed whole by the
certified checks, which read rows of it (``|R| N^2``) and its certificate (O(N^2), below).
Forming ``U F`` is one matrix product (O(N^3), a single GEMM) for the callers that want it.

The steps are those of LAPACK's divide and conquer (Gu and Eisenstat, SIAM J. Matrix Anal.
Appl. 16 (1995); ``dlaed2`` / ``dlaed3``):

* *deflation* of components with ``|rho z_k|`` below ``8 eps max(|w|, |rho|)`` (the pair
  ``(w_k, u_k)`` stays) and of pairs of nearly equal poles by a Givens rotation (``dlaed2``);
* the roots by LAPACK's ``dlasd4`` (the secular solver of the SVD update, for
  ``diag(d)^2 + rho z z^T`` with ``rho > 0``: poles shifted to be >= 0 and passed as square
  roots; a negative ``rho`` is handled on the negated, reversed spectrum), which returns the
  differences ``d_k - x`` to full relative accuracy;
* the vector z recomputed from the roots by Loewner's formula, so that the eigenvectors
  ``(diag(d) - x_i)^{-1} z_hat`` are orthogonal to working precision.

So ``F = P G (V ⊕ I) P_s``: a permutation P, the Givens rotations G of the deflation, the
Cauchy block V of the live poles and the sorting permutation ``P_s``. V is not stored: it is
fixed by O(m) numbers (:class:`CauchyBlock`) and each use regenerates it in blocks of rows,
so a factor costs O(N) memory and the secular solve never holds an ``m x m`` array.

Certificate of orthonormality (no ``F^T F``)
--------------------------------------------
Let ``p_j = sq_j^2`` be the poles the secular solver saw and ``x_l`` a real root with
``e_lj = p_j - x_l``; the exact Cauchy vectors ``v_l = z_hat / e_l`` satisfy, for ``l != k``,

.. math:: v_l^T v_k = \\sum_j \\frac{\\hat z_j^2}{(p_j - x_l)(p_j - x_k)}
          = \\frac{f(x_l) - f(x_k)}{r (x_l - x_k)}, \\qquad f(x) = 1 + r \\sum_j \\frac{\\hat z_j^2}{p_j - x},

for any ``r != 0`` (partial fractions). So ``|v_l^T v_k| / (||v_l|| ||v_k||)`` is at most
``(|f(x_l)| + |f(x_k)|) / (r |x_l - x_k| ||v_l|| ||v_k||)``, and Loewner's ``z_hat`` makes
``f(x_l)`` vanish up to its rounding: :func:`cauchy_certificate` bounds
``||V^T V - I||_F`` rigorously in O(m^2) for the m live poles. The real ``x_l`` is fixed
from the computed difference to its nearest pole, and every other computed difference is
compared with the exact one it stands for (relative error ``kappa``, checked below 1/2);
the root gaps come exactly as ``x_k - x_l = (p_{l+1} - x_l) + (p_k - p_{l+1}) + (x_k - p_k)``,
three nonnegative terms by interlacing. The rotations contribute ``|c^2 + s^2 - 1|`` each.

Nothing here is trusted beyond these bounds: :mod:`glocal_verify.numerics.updated_spectrum`
certifies the residual of ``U F`` a posteriori and falls back to ``eigh`` when the update is
not as accurate as ``eigh`` itself.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Sequence

import numpy as np
import scipy.linalg.lapack

from glocal_verify.numerics.rounding import EPS as _EPS
from glocal_verify.numerics.rounding import UNIT_ROUNDOFF as _U
from glocal_verify.numerics.rounding import gamma_bound as gamma

__all__ = ["CauchyBlock", "RankOneFactor", "cauchy_certificate", "eigh_rank_one_update", "eigh_updated", "rank_one_factor", "tree_rowsum"]

#: rows per block of the Loewner products and of the certificate
_BLOCK = 256


@dataclass(frozen=True, eq=False)
class CauchyBlock:
    """The ``m x m`` Cauchy block ``V`` of a factor, kept as the O(m) numbers that define it.

    Column l of V is ``y_l / n_l`` with ``y_lj = zhat_j / E_lj`` and
    ``E_lj = fl(fl(fl(sq_j - sqs_l) fl(sq_j + sqs_l)) + cstar_l)``: the computed difference
    ``p_j - x_l`` of pole ``p_j = sq_j^2`` and root ``x_l = sqs_l^2 - cstar_l`` (``sqs_l`` the
    root's nearest pole). Every product with V regenerates these entries, in blocks of
    :data:`_BLOCK` columns; elementwise IEEE operations make them the same numbers each time,
    which are the numbers :func:`cauchy_certificate` certified.

    Attributes
    ----------
    sq, sqs, cstar, zhat, norms : ndarray (m,)
        As above (``norms`` the ``n_l``).
    """

    sq: np.ndarray
    sqs: np.ndarray
    cstar: np.ndarray
    zhat: np.ndarray
    norms: np.ndarray

    @property
    def m(self) -> int:
        """The order of V."""
        return len(self.sq)

    def columns_t(self, cols: np.ndarray) -> np.ndarray:
        """``V[:, cols]^T`` (``len(cols) x m``), regenerated."""
        E = (self.sq[None, :] - self.sqs[cols, None]) * (self.sq[None, :] + self.sqs[cols, None])
        E += self.cstar[cols, None]
        np.divide(self.zhat[None, :], E, out=E)
        E /= self.norms[cols, None]
        return E

    def matmul(self, Z: np.ndarray) -> np.ndarray:
        """``V Z`` for ``Z`` of shape ``m x k``."""
        out = np.zeros((self.m, Z.shape[1]), dtype=np.result_type(Z, float))
        for a in range(0, self.m, _BLOCK):
            blk = np.arange(a, min(a + _BLOCK, self.m))
            out += self.columns_t(blk).T @ Z[blk]
        return out

    def tmatmul_abs(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(V^T z, |V|^T |z|)`` for a vector z, one regeneration (the second bounds the first's rounding)."""
        out = np.empty(self.m)
        absout = np.empty(self.m)
        az = np.abs(z)
        for a in range(0, self.m, _BLOCK):
            blk = np.arange(a, min(a + _BLOCK, self.m))
            VT = self.columns_t(blk)
            out[blk] = VT @ z
            absout[blk] = np.abs(VT) @ az
        return out, absout

    def tmatmul(self, Z: np.ndarray) -> np.ndarray:
        """``V^T Z`` for ``Z`` of shape ``m x k``."""
        out = np.empty((self.m, Z.shape[1]), dtype=np.result_type(Z, float))
        for a in range(0, self.m, _BLOCK):
            blk = np.arange(a, min(a + _BLOCK, self.m))
            out[blk] = self.columns_t(blk) @ Z
        return out


#: the block of a single live pole: V = [[1]] (E = cstar = 1)
def _unit_block() -> CauchyBlock:
    one = np.ones(1)
    return CauchyBlock(np.zeros(1), np.zeros(1), one, one, one)


@dataclass(frozen=True, eq=False)
class RankOneFactor:
    """``F`` with ``U diag(w) U^T + rho b b^T = (U F) diag(values) (U F)^T`` for an orthonormal U.

    ``F = P G (V ⊕ I) P_s`` (module docstring): ``P = I[:, order]``; ``G = R_1 ... R_t`` with
    ``R`` the Givens rotation that maps columns ``(p, k)`` of a basis to ``(c q_p + s q_k,
    c q_k - s q_p)``; V (``m x m``) acting on the live coordinates ``live``; ``P_s =
    I[:, sort]``. The matrix F meant by every bound is this exact product of the stored floats.

    Attributes
    ----------
    values : ndarray
        New eigenvalues, ascending (the i-th belongs to column i of F).
    order, live, sort : ndarray of int
        The permutations and the live coordinates.
    rot_p, rot_k : ndarray of int
        The rotated coordinate pairs, in the order the rotations were made.
    rot_c, rot_s : ndarray of float
        Their cosines and sines.
    V : CauchyBlock or None
        The Cauchy block (columns: eigenvectors in the live coordinates), kept implicitly; None
        when no pole is live.
    cauchy_gram : float
        Certified bound on ``||V^T V - I||_F`` (:func:`cauchy_certificate`).
    column_error : float
        Certified bound on ``||v_l - v_bar_l||_2`` over the columns, ``v_bar_l`` the exact unit
        Cauchy vector (so every column of V has norm at most ``1 + column_error``).
    """

    values: np.ndarray
    order: np.ndarray
    rot_p: np.ndarray
    rot_k: np.ndarray
    rot_c: np.ndarray
    rot_s: np.ndarray
    live: np.ndarray
    V: CauchyBlock | None
    sort: np.ndarray
    cauchy_gram: float
    column_error: float

    @property
    def size(self) -> int:
        """Order N."""
        return len(self.values)

    @property
    def live_size(self) -> int:
        """m, the number of live poles (the order of V)."""
        return 0 if self.V is None else self.V.m

    @cached_property
    def _live_position(self) -> np.ndarray:
        pos = np.full(self.size, -1, dtype=np.intp)
        pos[self.live] = np.arange(len(self.live))
        return pos

    @cached_property
    def rotation_defect(self) -> float:
        """Certified bound on ``||G^T G - I||_2``: ``prod (1 + |c^2 + s^2 - 1|) - 1`` (each rotation is orthogonal up to that factor)."""
        if not len(self.rot_c):
            return 0.0
        c, s = self.rot_c, self.rot_s
        delta = np.abs(c * c + s * s - 1.0) + gamma(3)
        return math.expm1(float(np.sum(np.log1p(delta)))) * (1.0 + gamma(len(delta) + 4))

    @cached_property
    def rotation_rounding(self) -> float:
        """``omega``: applying the rotations to a vector in floating point errs by at most ``omega`` times its 2-norm.

        Each rotation rounds its two new entries by ``gamma_2 (|c||a| + |s||b|)``, at most
        ``2 gamma_2 ||(a, b)||`` together, and may grow the norm by ``1 + |c^2 + s^2 - 1|``;
        over t rotations ``omega = (1 + 2 gamma_2 + max defect)^t - 1``.
        """
        t = len(self.rot_c)
        if not t:
            return 0.0
        c, s = self.rot_c, self.rot_s
        dmax = float(np.max(np.abs(c * c + s * s - 1.0))) + gamma(3)
        return math.expm1(t * math.log1p(2.0 * gamma(2) + dmax)) * (1.0 + gamma(t + 4))

    @cached_property
    def touched(self) -> int:
        """Number of coordinates some rotation touches (``G - I`` lives on them)."""
        return int(len(np.union1d(self.rot_p, self.rot_k))) if len(self.rot_p) else 0

    @cached_property
    def orthogonality(self) -> float:
        """``eta_F``: certified bound on ``||F^T F - I||_F``.

        ``F^T F - I = P_s^T (V ⊕ I)^T (G^T G - I) (V ⊕ I) P_s + P_s^T ((V^T V - I) ⊕ 0) P_s``, so
        ``eta_F <= (1 + ||V^T V - I||) sqrt(#touched) ||G^T G - I||_2 + ||V^T V - I||_F``.
        """
        g = self.cauchy_gram
        rot = (1.0 + g) * math.sqrt(self.touched) * self.rotation_defect
        return (rot + g) * (1.0 + gamma(6))

    @property
    def norm(self) -> float:
        """Certified bound on ``||F||_2``: ``sqrt(1 + eta_F)``."""
        return math.sqrt(1.0 + self.orthogonality) * (1.0 + gamma(2))

    def _rotate(self, Z: np.ndarray, transpose: bool) -> None:
        """``Z <- G^T Z`` (``transpose``) or ``Z <- G Z``, in place, on the rows of Z."""
        t = len(self.rot_c)
        steps = range(t) if transpose else range(t - 1, -1, -1)
        for r in steps:
            p, k, c, s = int(self.rot_p[r]), int(self.rot_k[r]), float(self.rot_c[r]), float(self.rot_s[r])
            zp, zk = Z[p].copy(), Z[k].copy()
            if transpose:  # R^T: (c z_p + s z_k, c z_k - s z_p)
                Z[p] = c * zp + s * zk
                Z[k] = c * zk - s * zp
            else:  # R: (c z_p - s z_k, s z_p + c z_k)
                Z[p] = c * zp - s * zk
                Z[k] = s * zp + c * zk

    def apply(self, Y: np.ndarray) -> np.ndarray:
        """``F Y`` for ``Y`` of shape ``N x k`` (a new array)."""
        Y = np.asarray(Y, dtype=float)
        Z = np.empty_like(Y)
        Z[self.sort] = Y
        if self.V is not None:
            Z[self.live] = self.V.matmul(Z[self.live])
        self._rotate(Z, transpose=False)
        out = np.empty_like(Z)
        out[self.order] = Z
        return out

    def _rotated_transpose(self, X: np.ndarray) -> np.ndarray:
        """``G^T P^T X`` (a new array): ``F^T X`` before the Cauchy block and the sorting."""
        Z = np.asarray(X, dtype=float)[self.order]
        self._rotate(Z, transpose=True)
        return Z

    def apply_transpose(self, X: np.ndarray) -> np.ndarray:
        """``F^T X`` for ``X`` of shape ``N x k`` (a new array)."""
        Z = self._rotated_transpose(X)
        if self.V is not None:
            Z[self.live] = self.V.tmatmul(Z[self.live])
        return Z[self.sort]

    def transpose_vector(self, y: np.ndarray) -> tuple[np.ndarray, float]:
        """``(fl(F^T y), e)`` with ``||fl(F^T y) - F^T y||_2 <= e``, bounded a posteriori.

        The rotations err by ``omega ||y||``; the product with ``V^T`` entrywise by
        ``gamma_{m+2} |V|^T |y|``, whose 2-norm is computed (no worst-case ``sqrt(N)``).
        """
        Z = self._rotated_transpose(y)
        err = self.rotation_rounding * float(np.linalg.norm(y)) * (1.0 + gamma(2))
        if self.V is not None:
            zl, bound = self.V.tmatmul_abs(Z[self.live])
            Z[self.live] = zl
            err += gamma(self.live_size + 2) * float(np.linalg.norm(bound)) * (1.0 + gamma(self.size + 2))
        return Z[self.sort], err

    def right_multiply(self, X: np.ndarray) -> np.ndarray:
        """``X F`` for ``X`` of shape ``r x N`` (rows of a basis carried into the new one)."""
        return np.ascontiguousarray(self.apply_transpose(np.asarray(X, dtype=float).T).T)

    def columns(self, cols: Sequence[int] | np.ndarray) -> np.ndarray:
        """``F[:, cols]`` (``N x len(cols)``): columns of V placed and rotated, no product with V."""
        cols = np.asarray(cols, dtype=np.intp)
        Z = np.zeros((self.size, len(cols)))
        src = self.sort[cols]
        pos = self._live_position[src]
        dead = pos < 0
        Z[src[dead], np.flatnonzero(dead)] = 1.0
        if self.V is not None and not np.all(dead):
            j = np.flatnonzero(~dead)
            Z[np.ix_(self.live, j)] = self.V.columns_t(pos[j]).T
        self._rotate(Z, transpose=False)
        out = np.empty_like(Z)
        out[self.order] = Z
        return out


def _tree_depth(m: int) -> int:
    """Depth ``ceil(log2 m)`` of the balanced summation tree of :func:`tree_rowsum`."""
    return max(int(m - 1).bit_length(), 0)


def tree_rowsum(X: np.ndarray) -> np.ndarray:
    """Row sums of ``X`` (``b x m``) by a balanced binary tree of depth ``ceil(log2 m)``.

    So ``|fl(sum) - sum| <= gamma_d sum |x|`` with ``d`` = :func:`_tree_depth` (Higham, §4.2)
    instead of ``gamma_{m-1}`` for an unknown order: the bound does not depend on how the
    library sums.
    """
    Y = np.array(X, dtype=float)
    m = Y.shape[1]
    if m == 0:
        return np.zeros(Y.shape[0])
    while m > 1:
        h = m // 2
        Y[:, :h] += Y[:, m - h : m]
        m -= h
    return Y[:, 0].copy()


def cauchy_certificate(sq: np.ndarray, sqs: np.ndarray, cstar: np.ndarray, zhat: np.ndarray, r: float) -> tuple[float, float, np.ndarray] | None:
    """Certified ``(||V^T V - I||_F, max_l ||v_l - v_bar_l||, norms)`` of the Cauchy block these numbers define.

    Parameters
    ----------
    sq : ndarray (m,)
        Square roots of the poles, strictly ascending (the poles are ``p_j = sq_j^2`` exactly).
    sqs, cstar : ndarray (m,)
        Root l is ``x_l = sqs_l^2 - cstar_l`` exactly: ``sqs_l`` the square root of its nearer
        neighbouring pole (l or l + 1), ``cstar_l`` the difference to it.
    zhat : ndarray (m,)
        Loewner's vector.
    r : float
        The positive weight of the secular function ``f(x) = 1 + r sum zhat_j^2 / (p_j - x)``.

    Returns
    -------
    (float, float, ndarray) or None
        The two bounds and the norms ``n_l`` of :class:`CauchyBlock` (computed by
        :func:`tree_rowsum`, whose rounding the bounds assume). None when a regenerated
        difference has the wrong sign for strict interlacing or is not within half of itself of
        the exact one (the certificate cannot be made; the caller falls back to ``eigh``).

    Notes
    -----
    Bounds used, entry by entry: the regenerated ``E_lj`` (:class:`CauchyBlock`) errs from the
    exact ``e_lj = p_j - x_l`` by at most ``gamma_2 |E| + gamma_4 |product|``, so by
    ``kappa_lj`` relatively. The computed unit vector then errs from the exact one entrywise
    by ``t_l = (1 + psi)(1 + u) / ((1 - psi)(1 - gamma_{d+3})) - 1`` relatively,
    ``psi = kappa_max (1 + u) + u``, ``d = ceil(log2 m)`` the depth of the summation tree;
    ``|f(x_l)|`` is at most the computed value plus
    ``(gamma_d + psi') (1 + psi') sum_j |r zhat_j^2 / E_lj|``. O(m^2) time, O(256 m) memory.
    """
    m = len(sq)
    if m <= 1:
        return 0.0, 0.0, np.ones(m)
    h = r * (zhat * zhat)  # r zhat_j^2, relative error <= gamma_2
    depth = _tree_depth(m)
    gm = gamma(depth + 3)  # relative error of a row norm: squares, tree sum, square root
    kmax = np.zeros(m)
    phi = np.zeros(m)
    nrm = np.zeros(m)
    a_low = np.zeros(m)  # lower bounds of p_{l+1} - x_l
    b_low = np.zeros(m)  # lower bounds of x_k - p_k
    for a in range(0, m, _BLOCK):
        b = min(a + _BLOCK, m)
        rows = np.arange(a, b)
        P = (sq[None, :] - sqs[a:b, None]) * (sq[None, :] + sqs[a:b, None])
        E = P + cstar[a:b, None]  # the entries CauchyBlock regenerates
        kap = (gamma(2) * np.abs(E) + gamma(4) * np.abs(P)) / np.abs(E) * (1.0 + gamma(4))
        del P
        kmax[a:b] = np.max(kap, axis=1)
        diag = E[rows - a, rows]
        if not np.all(diag < 0.0):
            return None
        b_low[a:b] = -diag * (1.0 - kap[rows - a, rows])
        inner = rows[rows < m - 1]
        sup = E[inner - a, inner + 1]
        if not np.all(sup > 0.0):
            return None
        a_low[inner] = sup * (1.0 - kap[inner - a, inner + 1])
        del kap
        T = h[None, :] / E
        A = tree_rowsum(np.abs(T))
        f = np.abs(1.0 + tree_rowsum(T))  # |f_hat(x_l)|
        del T
        psi1 = (1.0 + gamma(2)) * (1.0 + _U) * (1.0 + kmax[a:b]) - 1.0
        phi[a:b] = f * (1.0 + _U) + (gamma(depth) + psi1) * (1.0 + psi1) * A * (1.0 + gamma(depth)) + gamma(2)
        np.divide(zhat[None, :], E, out=E)
        nrm[a:b] = np.sqrt(tree_rowsum(E * E))
    if not (np.all(kmax < 0.5) and np.all(np.isfinite(phi)) and np.all(nrm > 0.0) and np.all(np.isfinite(nrm))):
        return None
    psi = kmax * (1.0 + _U) + _U
    t = (1.0 + psi) * (1.0 + _U) / ((1.0 - psi) * (1.0 - gm)) - 1.0
    nv = nrm / ((1.0 + gm) * (1.0 + psi)) * (1.0 - gamma(4))  # lower bounds of ||v_l||
    a_low *= 1.0 - gamma(4)
    b_low *= 1.0 - gamma(4)
    w = phi / nv  # |f(x_l)| / ||v_l||
    total = 0.0
    for a in range(0, m - 1, _BLOCK):
        b = min(a + _BLOCK, m - 1)
        l1 = sq[a + 1 : b + 1]
        pd = (sq[None, :] - l1[:, None]) * (sq[None, :] + l1[:, None]) * (1.0 - gamma(4))
        gap = a_low[a:b, None] + b_low[None, :] + np.maximum(pd, 0.0)
        beta = (w[a:b, None] / nv[None, :] + w[None, :] / nv[a:b, None]) / (r * gap)
        beta[np.arange(m)[None, :] <= np.arange(a, b)[:, None]] = 0.0  # pairs l < k only
        total += float(np.sum(beta * beta))
    G = math.sqrt(2.0 * total) * (1.0 + gamma(m * m + 12))
    vmv = math.sqrt(float(np.sum(t * t))) * (1.0 + gamma(m + 2))
    gram = (G + 2.0 * math.sqrt(1.0 + G) * vmv + vmv * vmv) * (1.0 + gamma(6))
    return gram, float(np.max(t)), nrm


def _secular_roots(sq: np.ndarray, zk: np.ndarray, rk: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    """Roots of ``1 + rk sum zk_j^2 / (sq_j^2 - x)`` by ``dlasd4``, streamed: no ``m x m`` array.

    Returns ``(roots, sqs, cstar, zhat)``: per root the square root of its nearer neighbouring
    pole and the difference to it (the data of :class:`CauchyBlock`), and Loewner's vector
    ``zhat_k^2 = (root_k - p_k) / rk * prod_{l != k} (root_l - p_k) / (p_l - p_k)`` accumulated
    over the rows as they come, as a product of ratios of moderate size (interlacing), poles
    ``p = sq^2`` the ones the solver saw, their differences factored so that close poles keep
    their relative difference. None when the solver fails or interlacing is not strict.
    """
    m = len(sq)
    roots = np.empty(m)
    sqs = np.empty(m)
    cstar = np.empty(m)
    diag = np.empty(m)
    prod = np.ones(m)
    buf = np.empty((min(_BLOCK, m), m))
    for a in range(0, m, _BLOCK):
        b = min(a + _BLOCK, m)
        D = buf[: b - a]
        for l_ in range(a, b):
            delta, sigma, work, info = scipy.linalg.lapack.dlasd4(l_, sq, zk, rk)  # the wrapper counts from 0
            if info != 0:
                return None
            np.multiply(delta, work, out=D[l_ - a])  # dk_j - root_l, to full relative accuracy
            roots[l_] = sigma * sigma
        rows = np.arange(a, b)
        diag[a:b] = D[rows - a, rows]
        right = np.full(b - a, math.inf)
        inner = rows < m - 1
        sup = D[rows[inner] - a, rows[inner] + 1]
        # strict interlacing dk_l < root_l < dk_{l+1} fixes every sign below
        if not (np.all(diag[a:b] < 0.0) and np.all(sup > 0.0)):
            return None
        right[inner] = sup
        near_right = right < -diag[a:b]
        jstar = np.where(near_right, rows + 1, rows)
        sqs[a:b] = sq[jstar]
        cstar[a:b] = np.where(near_right, right, diag[a:b])
        R = (sq[a:b, None] - sq[None, :]) * (sq[a:b, None] + sq[None, :])
        R[rows - a, rows] = 1.0
        np.divide(D, R, out=R)
        np.negative(R, out=R)
        R[rows - a, rows] = 1.0
        prod *= np.prod(R, axis=0)
    z2 = -diag / rk * prod
    if not np.all(np.isfinite(z2) & (z2 > 0.0)):
        return None
    return roots, sqs, cstar, np.copysign(np.sqrt(z2), zk)


def rank_one_factor(w: np.ndarray, z: np.ndarray, rho: float) -> RankOneFactor | None:
    """The factor F of ``diag(w) + rho z z^T = F diag(values) F^T`` (so ``U F`` for ``U diag(w) U^T + rho b b^T``, ``z = U^T b``).

    Parameters
    ----------
    w : ndarray (N,)
        Ascending eigenvalues before the change.
    z : ndarray (N,)
        ``U^T b`` as computed.
    rho : float
        The change of the link's weight (``+w`` for an added link, ``-w`` for a removed one).

    Returns
    -------
    RankOneFactor or None
        None when the secular solver reports a failure, two poles cannot be separated, or the
        orthonormality certificate cannot be made (the caller uses ``eigh``).
    """
    w = np.asarray(w, dtype=float)
    n = len(w)
    z = np.asarray(z, dtype=float)
    nz = float(np.linalg.norm(z))
    empty_i = np.zeros(0, dtype=np.intp)
    empty_f = np.zeros(0)
    if rho == 0.0 or nz == 0.0 or n == 0:
        ident = np.arange(n)
        return RankOneFactor(w.copy(), ident, empty_i, empty_i, empty_f, empty_f, empty_i, None, ident, 0.0, 0.0)
    r = rho * nz * nz
    zz = z / nz
    flip = r < 0.0
    order = np.arange(n)[::-1].copy() if flip else np.arange(n)
    d = -w[order] if flip else w.copy()
    zz = zz[order]
    r = abs(r)
    shift = float(d[0])
    d = d - shift  # >= 0, ascending
    tol = 8.0 * _EPS * max(float(np.max(np.abs(d))), r * float(np.max(np.abs(zz))), 1e-300)
    deflated = np.abs(r * zz) <= tol
    # type-2 deflation: neighbouring live poles closer than the rotation can see (dlaed2)
    live = [int(k) for k in np.flatnonzero(~deflated)]
    kept: list[int] = []
    rots: list[tuple[int, int, float, float]] = []
    p: int | None = None
    for k in live:
        if p is None:
            p = k
            continue
        s_, c_ = zz[p], zz[k]
        tau = math.hypot(c_, s_)
        c, s = c_ / tau, -s_ / tau
        t = d[k] - d[p]
        if abs(t * c * s) <= tol:
            zz[k], zz[p] = tau, 0.0
            rots.append((p, k, c, s))
            dp = d[p] * c * c + d[k] * s * s
            d[k] = d[p] * s * s + d[k] * c * c
            d[p] = dp
            deflated[p] = True
            p = k
        else:
            kept.append(p)
            p = k
    if p is not None:
        kept.append(p)
    K = np.array(kept, dtype=np.intp)
    vals = d.copy()
    V: CauchyBlock | None = None
    gram, col_err = 0.0, 0.0
    if len(K):
        dk = d[K]
        if np.any(np.diff(dk) <= 0.0):
            return None
        zk = zz[K]
        nk = float(np.linalg.norm(zk))
        rk = r * nk * nk
        zk = zk / nk
        sq = np.sqrt(dk)
        if np.any(np.diff(sq) <= 0.0):
            return None
    if len(K) == 1:  # one live pole: the root is explicit (dlasd4 returns no differences then)
        vals[K] = dk + rk
        V = _unit_block()
    elif len(K) > 1:
        sec = _secular_roots(sq, zk, rk)
        if sec is None:
            return None
        roots, sqs, cstar, zhat = sec
        cert = cauchy_certificate(sq, sqs, cstar, zhat, rk)
        if cert is None:
            return None
        gram, col_err, norms = cert
        V = CauchyBlock(sq, sqs, cstar, zhat, norms)
        vals[K] = roots
    vals = -(vals + shift) if flip else vals + shift
    idx = np.argsort(vals, kind="stable")
    rot = np.array(rots, dtype=float).reshape(-1, 4)
    values = vals[idx]
    values.setflags(write=False)
    return RankOneFactor(
        values=values,
        order=order,
        rot_p=rot[:, 0].astype(np.intp),
        rot_k=rot[:, 1].astype(np.intp),
        rot_c=rot[:, 2].copy(),
        rot_s=rot[:, 3].copy(),
        live=K,
        V=V,
        sort=idx,
        cauchy_gram=gram,
        column_error=col_err,
    )


def eigh_rank_one_update(w: np.ndarray, U: np.ndarray, i: int, j: int, rho: float) -> tuple[np.ndarray, np.ndarray] | None:
    """Eigenpairs of ``U diag(w) U^T + rho (e_i - e_j)(e_i - e_j)^T`` from those of the first term, the basis formed.

    Parameters
    ----------
    w : ndarray (N,)
        Ascending eigenvalues.
    U : ndarray (N, N)
        Orthonormal eigenvectors (columns), not modified.
    i, j : int
        The changed link (``i != j``).
    rho : float
        The change of its weight (``+w`` for an added link, ``-w`` for a removed one).

    Returns
    -------
    (ndarray, ndarray) or None
        Ascending eigenvalues and eigenvectors ``U F`` (a new array); None when
        :func:`rank_one_factor` fails (the caller uses ``eigh``).
    """
    U = np.asarray(U, dtype=float)
    F = rank_one_factor(w, U[i, :] - U[j, :], rho)
    if F is None:
        return None
    return np.array(F.values), F.right_multiply(U)


def eigh_updated(w: np.ndarray, U: np.ndarray, changes: Sequence[tuple[int, int, float]]) -> tuple[np.ndarray, np.ndarray] | None:
    """Eigenpairs after several link changes ``(i, j, rho)``, one rank-one update each, the basis formed.

    Parameters
    ----------
    w, U : ndarray
        Ascending eigenvalues and orthonormal eigenvectors of the matrix before the changes.
    changes : sequence of (int, int, float)

    Returns
    -------
    (ndarray, ndarray) or None
        None as soon as one update fails (:func:`eigh_rank_one_update`).
    """
    cur: tuple[np.ndarray, np.ndarray] | None = (np.asarray(w), np.asarray(U))
    for i, j, rho in changes:
        assert cur is not None
        cur = eigh_rank_one_update(cur[0], cur[1], i, j, rho)
        if cur is None:
            return None
    return cur
