"""Witness directions of many actuator sets at one exponent, vectorised over the sets.

An audit asks, for thousands of actuator sets F of one size, whether the 2N pencil of eq.
``zda_cond`` has a kernel vector with u0 != 0 at one exponent lambda0 (the spec's, or 0, or 1).
:meth:`glocal_verify.analysis.stealthy.zda.ModalPencil.direction` answers for one set in O(N (m + p)) plus
an O(N^2) verification, but its cost at N = 200 is mostly the interpreter's: some hundred
small array operations per set. :func:`batch_directions` performs the same computation on a
stack of sets:

* the parts that do not depend on F are formed once: s = lambda0^2 + gamma lambda0, the modes
  J with s + alpha mu_k zero at the tolerance, and G = U_O[:, far] diag(1 / (s + alpha mu))
  U[:, far]^T (p x N), whose columns F are the reduced matrix block of every set;
* the reduced matrices K_F = [[0, U[F, J]^T], [U_O[:, J], G[:, F]]] are stacked and decomposed
  by one batched SVD; the rank bounds, the largest-input vector of the certain kernel, its
  modal screen and its verification on the full 2N pencil are evaluated on the stack.

A set is answered only in the case :meth:`ModalPencil.direction` settles on its first candidate: the
certain kernel is not empty and its largest-input vector is screened *and* verified with a
residual that is zero and an input part that is nonzero at the tolerance. Every other set gets
None and is left to the per-set method, so the decisions are that method's: the same
candidate, the same bounds (:meth:`ModalPencil._screen`, :meth:`ModalPencil.verify`) and the same
tolerance; only the rounding of the products may differ in the last bits.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from glocal_verify.analysis.stealthy.zda import ModalPencil
from glocal_verify.model import System
from glocal_verify.numerics.tolerance import Decision, Tolerance
from glocal_verify.spec.types import Label

__all__ = ["BatchDirection", "batch_directions"]


@dataclass(frozen=True, slots=True)
class BatchDirection:
    """The verified kernel vector of one set, as :meth:`ModalPencil.direction` returns it.

    Attributes
    ----------
    xi : ndarray
        Position part (length N).
    u : ndarray
        Input part (length |F|).
    residual : float
        Backward error on the full 2N pencil (relative to a lower bound of its norm).
    dim_lo, dim_hi : int
        Kernel dimension bounds of the reduced matrix (certainly zero / not certainly nonzero
        singular values).
    normalized : (ndarray, ndarray) or None
        (xi, u) scaled as :func:`glocal_verify.analysis.stealthy.zda.normalize_direction` scales them (computed
        for the whole batch at once; the same floating-point operations per entry).
    """

    xi: np.ndarray
    u: np.ndarray
    residual: float
    dim_lo: int
    dim_hi: int
    normalized: tuple[np.ndarray, np.ndarray] | None = None

    def as_found(self) -> tuple[tuple[np.ndarray, np.ndarray, float, Decision, Decision], Decision, int, int]:
        """The tuple :meth:`ModalPencil.direction` returns for this set."""
        return (self.xi, self.u, self.residual, Decision.ZERO, Decision.NONZERO), Decision.ZERO, self.dim_lo, self.dim_hi


def _decide(values: np.ndarray, scale: np.ndarray | float, tol: Tolerance) -> np.ndarray:
    """:meth:`Tolerance.decide` on arrays: 0 zero, 1 nonzero, 2 undecided (positive finite scales)."""
    r = np.abs(values) / scale
    return np.where(r <= tol.rtol, 0, np.where(r > tol.upper, 1, 2))


def batch_directions(system: System, tol: Tolerance, lam: complex, sets: Sequence[tuple[Label, ...]]) -> list[BatchDirection | None]:
    """The direction of :meth:`ModalPencil.direction` at ``lam`` for each set, or None (module docstring).

    Parameters
    ----------
    system : System
    tol : Tolerance
        The tolerance of the per-set method.
    lam : complex
        The exponent lambda0.
    sets : sequence of label tuples
        Actuator sets; sets of different sizes are handled group by group.

    Returns
    -------
    list
        Per set, a :class:`BatchDirection` when the set is settled by its first candidate (a
        proven ZDA at ``lam`` with u0 != 0), else None (use the per-set method).
    """
    out: list[BatchDirection | None] = [None] * len(sets)
    if not sets or system.n == 0:
        return out
    sp = system.spectrum()
    ortho = float(sp.orthogonality_error)
    if not ortho < 0.5:
        return out
    by_size: dict[int, list[int]] = {}
    for i, F in enumerate(sets):
        if len(F) > 0:
            by_size.setdefault(len(F), []).append(i)
    ref = ModalPencil(system, tuple(sets[0]), tol)
    for idx in by_size.values():
        for i, d in zip(idx, _group(system, ref, tol, complex(lam), [sets[i] for i in idx], ortho, float(np.linalg.norm(sp.residuals)))):
            out[i] = d
    return out


def _group(system: System, md: ModalPencil, tol: Tolerance, lam: complex, sets: Sequence[tuple[Label, ...]], ortho: float, r_fro: float) -> list[BatchDirection | None]:
    """:func:`batch_directions` for sets of one size m."""
    N, alpha, gamma = md.N, md.alpha, md.gamma
    mu, U = md.mu, md.U
    res: list[BatchDirection | None] = [None] * len(sets)
    s = lam * lam + gamma * lam
    Mx, Mv = md.Mx, md.Mv
    rows_out = Mx if lam == 0 else md.M
    d: np.ndarray = s + alpha * mu
    near = np.abs(d) / md.mu_scale <= tol.rtol
    J, far = np.flatnonzero(near), np.flatnonzero(~near)
    UO = U[rows_out, :]
    p, nJ = len(rows_out), len(J)
    Fi = np.array([system.idx(F) for F in sets], dtype=np.intp)  # (B, m)
    B, m = Fi.shape
    ncols = nJ + m
    if nJ + p == 0:
        return res  # the per-set method's identity basis: left to it
    s1 = max(1.0, float(np.max(1.0 / np.abs(d[far]), initial=0.0)))
    # a real exponent (0, 1, or a real spec lambda0) keeps every array real: the same
    # decisions at a quarter of the complex arithmetic (the per-set method's vectors then
    # have zero imaginary parts, which normalize_direction drops)
    dtype = float if lam.imag == 0 else complex
    lam_d: complex | float = lam
    if dtype is float:
        s, d, lam_d = s.real, d.real, lam.real
    UF = U[Fi, :]  # (B, m, N)
    K = np.zeros((B, nJ + p, ncols), dtype=dtype)
    K[:, :nJ, nJ:] = np.swapaxes(UF[:, :, J], 1, 2)
    K[:, nJ:, :nJ] = UO[:, J]
    if len(far):
        G = (UO[:, far] / d[far]) @ U[:, far].T  # (p, N): the far block of every set
        K[:, nJ:, nJ:] = np.swapaxes(G[:, Fi], 0, 1)
    _, sv, Vh = np.linalg.svd(K, full_matrices=True)
    sv = np.concatenate([sv, np.zeros((B, ncols - sv.shape[1]))], axis=1)
    notzero = np.sum(sv > tol.rtol * s1, axis=1)
    cert = np.sum(sv > tol.upper * s1, axis=1)
    pnl = md.pencil_norm_lb(lam)
    L = md.L
    for nz in np.unique(notzero):
        if nz >= ncols:
            continue  # no certain kernel: the first candidate is another one
        g = np.flatnonzero(notzero == nz)
        kb = np.conj(np.swapaxes(Vh[g][:, nz:, :], 1, 2))  # (b, ncols, r)
        r = kb.shape[2]
        if m and r > 1:
            _, _, Wh = np.linalg.svd(kb[:, nJ:, :], full_matrices=True)
            v = np.einsum("bij,bj->bi", kb, np.conj(Wh[:, 0, :]))
        else:
            v = kb[:, :, 0]
        u = v[:, nJ:]
        eta = np.zeros((len(g), N), dtype=dtype)
        eta[:, J] = v[:, :nJ]
        UFg = UF[g]
        UFtu = np.einsum("bmn,bm->bn", UFg, u)
        if len(far):
            eta[:, far] = UFtu[:, far] / d[far]
        # the modal screen (ModalPencil._screen)
        r_m = (s + alpha * mu) * eta - UFtu
        outp = np.concatenate([eta @ U[Mx, :].T, lam_d * (eta @ U[Mv, :].T)], axis=1)
        e_n, u_n, rm_n = (np.linalg.norm(x, axis=1) for x in (eta, u, r_m))
        num = np.hypot(rm_n, np.linalg.norm(outp, axis=1))
        vnorm = np.sqrt((1.0 + abs(lam) ** 2) * e_n**2 + u_n**2)
        ok = vnorm > 0
        vn = np.where(ok, vnorm, 1.0)
        err_num = ortho * (rm_n + u_n) + alpha * r_fro * e_n + 1e-14 * (num + vnorm)
        lo_ = np.maximum(0.0, num - err_num) / (pnl * vn * math.sqrt(1.0 + ortho))
        hi_ = (num + err_num) / (pnl * vn * math.sqrt(max(1.0 - ortho, 1e-300)))
        ok &= (_decide(lo_, 1.0, tol) == 0) & (_decide(hi_, 1.0, tol) == 0)
        v_lo = np.sqrt((1.0 + abs(lam) ** 2) * e_n**2 * (1.0 - ortho) + u_n**2)
        v_hi = np.sqrt((1.0 + abs(lam) ** 2) * e_n**2 * (1.0 + ortho) + u_n**2)
        ok &= (_decide(u_n, np.where(ok, v_hi, 1.0), tol) == 1) & (_decide(u_n, np.where(ok, v_lo, 1.0), tol) == 1)
        if not np.any(ok):
            continue
        # verification on the full 2N pencil (ModalPencil.verify)
        xi = eta @ U.T if dtype is float else eta.real @ U.T + 1j * (eta.imag @ U.T)
        Fsel = np.zeros((len(g), N), dtype=dtype)
        np.put_along_axis(Fsel, Fi[g], u, axis=1)
        r_dyn = s * xi + alpha * np.asarray(L @ xi.T).T - Fsel
        r_out = np.concatenate([xi[:, Mx], lam_d * xi[:, Mv]], axis=1)
        num2 = np.sqrt(np.linalg.norm(r_dyn, axis=1) ** 2 + np.linalg.norm(r_out, axis=1) ** 2)
        vnorm2 = np.sqrt((1.0 + abs(lam) ** 2) * np.linalg.norm(xi, axis=1) ** 2 + u_n**2)
        ok &= vnorm2 > 0
        vn2 = np.where(vnorm2 > 0, vnorm2, 1.0)
        resid = num2 / (pnl * vn2)
        ok &= (_decide(resid, 1.0, tol) == 0) & (_decide(u_n, vn2, tol) == 1)
        lo, hi = ncols - int(nz), ncols - cert[g]
        rows = np.flatnonzero(ok)
        for j, nrm in zip(rows, _normalized_rows(xi[rows], u[rows])):
            res[int(g[j])] = BatchDirection(xi[j], u[j], float(resid[j]), lo, int(hi[j]), nrm)
    return res


def _normalized_rows(X: np.ndarray, Uin: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """Row j: (X[j], Uin[j]) / X[j, k], k its largest entry, real when the imaginary parts are
    below 1e-14 of the largest entry: :func:`glocal_verify.analysis.stealthy.zda.normalize_direction` of each row,
    the divisions and comparisons done once for the batch (entry by entry the same operations)."""
    if len(X) == 0:
        return []
    k = np.argmax(np.abs(X), axis=1)
    c = X[np.arange(len(X)), k]
    live = c != 0
    cs = np.where(live, c, 1)[:, None]
    if not np.iscomplexobj(X):
        Xn, Un = X / cs, Uin / cs
        return [(Xn[j], Un[j]) if live[j] else (X[j], Uin[j]) for j in range(len(X))]
    V = np.concatenate([X, Uin], axis=1) / cs
    real = np.abs(V.imag).max(axis=1) <= 1e-14 * np.abs(V).max(axis=1)
    n = X.shape[1]
    out = []
    for j in range(len(X)):
        if not live[j]:
            out.append((X[j], Uin[j]))
            continue
        v = V[j].real.copy() if real[j] else V[j]
        out.append((v[:n], v[n:]))
    return out
