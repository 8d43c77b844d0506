"""The eigendecomposition of a symmetric matrix after a rank-one change, from the one before.

A safe mode usually differs from the normal mode by one link: ``L_q = L + rho b b^T`` with
``b = e_i - e_j`` and ``rho`` the change of the link's weight. With ``L = U diag(w) U^T``,

.. math:: L_q = U (\\operatorname{diag}(w) + \\rho z z^T) U^T, \\qquad z = U^T b,

so the new eigenvalues are the roots of Golub's secular equation
``1 + rho sum_k z_k^2 / (w_k - x) = 0`` and the new eigenvectors are ``U V`` with V the
eigenvectors of the diagonal-plus-rank-one matrix: O(N^2) for the roots and V, and one
matrix product (O(N^3) but a single GEMM, several times cheaper than a fresh ``syevd``).

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

Nothing here is trusted: the caller certifies the result a posteriori exactly as it does the
output of ``eigh`` (residuals ``L_q u - x u`` and the loss of orthonormality), and falls back
to ``eigh`` when those are not at the level ``eigh`` itself reaches.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np
import scipy.linalg.lapack

__all__ = ["eigh_rank_one_update", "eigh_updated"]

_EPS = float(np.finfo(float).eps)
#: rows per block of the Loewner products
_BLOCK = 256


def eigh_rank_one_update(w: np.ndarray, U: np.ndarray, i: int, j: int, rho: float) -> tuple[np.ndarray, np.ndarray] | None:
    """Eigenpairs of ``U diag(w) U^T + rho (e_i - e_j)(e_i - e_j)^T`` from those of the first term.

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
        Ascending eigenvalues and eigenvectors (a new array); None when the secular solver
        reports a failure or two poles cannot be separated (the caller uses ``eigh``).
    """
    w = np.asarray(w, dtype=float)
    n = len(w)
    z = np.asarray(U[i, :] - U[j, :], dtype=float)
    nz = float(np.linalg.norm(z))
    if rho == 0.0 or nz == 0.0 or n == 0:
        return w.copy(), np.array(U)
    r = rho * nz * nz
    zz = z / nz
    flip = r < 0.0
    order = np.arange(n)[::-1] if flip else np.arange(n)
    d = -w[order] if flip else w.copy()
    zz = zz[order]
    r = abs(r)
    Q = np.array(U[:, order])  # working copy of the basis: the Givens rotations act on it
    shift = float(d[0])
    d = d - shift  # >= 0, ascending
    tol = 8.0 * _EPS * max(float(np.max(np.abs(d))), r * float(np.max(np.abs(zz))), 1e-300)
    deflated = np.abs(r * zz) <= tol
    # type-2 deflation: neighbouring live poles closer than the rotation can see (dlaed2)
    live = [int(k) for k in np.flatnonzero(~deflated)]
    kept: list[int] = []
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
            qp, qk = Q[:, p].copy(), Q[:, k].copy()
            Q[:, p] = c * qp + s * qk
            Q[:, k] = c * qk - s * qp
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
    K = np.array(kept, dtype=int)
    vals = d.copy()
    V: np.ndarray | None = None
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
    elif len(K) > 1:
        m = len(K)
        diffT = np.empty((m, m))  # diffT[l, k] = dk[k] - root_l, to full relative accuracy
        roots = np.empty(m)
        for l_ in range(m):
            delta, sigma, work, info = scipy.linalg.lapack.dlasd4(l_, sq, zk, rk)  # the wrapper counts from 0
            if info != 0:
                return None
            np.multiply(delta, work, out=diffT[l_])
            roots[l_] = sigma * sigma
        # strict interlacing dk_l < root_l < dk_{l+1} fixes every sign below
        ar = np.arange(m)
        if not (np.all(diffT[ar, ar] < 0.0) and np.all(diffT[ar[:-1], ar[:-1] + 1] > 0.0)):
            return None
        # Loewner: z_hat_k^2 = (root_k - dk_k) / rk * prod_{l != k} (root_l - dk_k) / (dk_l - dk_k),
        # as a product of ratios (each of moderate size by interlacing, as dlaed3 forms it)
        # [l, k] = dk_l - dk_k for the poles dlasd4 saw (sq^2), factored so that close poles keep
        # their relative difference
        # (in blocks of rows l: O(block * m) temporaries)
        prod = np.ones(m)
        for a in range(0, m, _BLOCK):
            b = min(a + _BLOCK, m)
            R = (sq[a:b, None] - sq[None, :]) * (sq[a:b, None] + sq[None, :])
            R[np.arange(b - a), np.arange(a, b)] = 1.0
            np.divide(diffT[a:b], R, out=R)
            np.negative(R, out=R)
            R[np.arange(b - a), np.arange(a, b)] = 1.0
            prod *= np.prod(R, axis=0)
        z2 = -diffT[ar, ar] / rk * prod
        if not np.all(np.isfinite(z2) & (z2 > 0.0)):
            return None
        zhat = np.copysign(np.sqrt(z2), zk)
        VT = np.divide(zhat[None, :], diffT, out=diffT)  # row l: the l-th eigenvector in the live basis
        VT /= np.linalg.norm(VT, axis=1, keepdims=True)
        if not np.all(np.isfinite(VT)):
            return None
        V = VT.T
        vals[K] = roots
    vals = -(vals + shift) if flip else vals + shift
    idx = np.argsort(vals, kind="stable")
    # the new basis Q[:, K] V, in ascending order, in blocks of rows straight into the result:
    # beside U, Q and V only one more N x N array (a gathered Q[:, K], the product and its
    # sorted copy would be three; 0.8 GB each at N = 10,000)
    vecs = np.empty((n, n))
    for a in range(0, n, _BLOCK):
        blk = Q[a : a + _BLOCK]
        if V is not None:
            if len(K) == n:
                blk = blk @ V  # nothing deflated: no gathered columns
            else:
                blk = blk.copy()
                blk[:, K] = blk[:, K] @ V
        vecs[a : a + _BLOCK] = blk[:, idx]
    del Q
    return vals[idx], vecs


def eigh_updated(w: np.ndarray, U: np.ndarray, changes: Sequence[tuple[int, int, float]]) -> tuple[np.ndarray, np.ndarray] | None:
    """Eigenpairs after several link changes ``(i, j, rho)``, one rank-one update each.

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
