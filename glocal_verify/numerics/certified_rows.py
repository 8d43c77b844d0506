"""Certified impulse-response rows of a stable discrete system: :math:`\\ell_k = C M^k`.

Every certified bound on a sampled residual is a sum of terms :math:`\\ell_k X` (the residual's
response after k steps to whatever enters through X). The rows are computed in floating point,
:math:`\\hat\\ell_{k+1} = fl(\\hat\\ell_k \\hat M)` with :math:`\\hat M` the rounded exact M, and their
error is bounded a posteriori, rigorously:

**Error of the rows.** With :math:`\\delta_k = \\hat\\ell_k - \\ell_k`,
:math:`\\delta_{k+1} = \\delta_k M + \\eta_k`, :math:`|\\eta_k| \\le |\\hat\\ell_k| (E_M + \\gamma_{n} |\\hat M|)`
(E_M bounds :math:`|\\hat M - M|`; Higham, Thm 3.5), so
:math:`\\|\\delta_k\\|_1 \\le \\kappa (\\|\\delta_0\\|_1 + \\sum_{j<k} \\|\\eta_j\\|_1)` with
:math:`\\kappa = \\sup_t \\|M^t\\|_\\infty`.

**kappa and the tail, by a bootstrap.** A window :math:`m_0 = 2^i` is chosen (floating-point
squaring) and the powers :math:`\\hat P_t = fl(\\hat P_{t-1} \\hat M)`, t <= m_0, are computed. With
:math:`a = \\max_t \\|\\hat P_t\\|_\\infty` and :math:`c = \\sum_{s<m_0} \\||\\hat P_s| (E_M + \\gamma_n |\\hat M|)\\|_\\infty`,
the same argument gives :math:`\\|M^t\\| \\le a + \\kappa_0 c` for t <= m_0, where
:math:`\\kappa_0 = \\max_{t \\le m_0} \\|M^t\\|`; hence :math:`\\kappa_0 \\le a / (1 - c)` when c < 1, and
:math:`\\theta = \\|\\hat P_{m_0}\\| + \\kappa_0 c` bounds :math:`\\|M^{m_0}\\|_\\infty`. When
:math:`\\theta < 1` (this proves the spectral radius of M below 1),
:math:`\\|M^{j m_0 + r}\\| \\le \\theta^j \\kappa_0`, so :math:`\\kappa = \\kappa_0`, and beyond the last computed
window :math:`[K, K + m_0)` every row obeys
:math:`\\|\\ell_{K + j m_0 + r}\\|_1 \\le \\theta^j \\|\\ell_{K+r}\\|_1`:

.. math::

    \\sup_{k \\ge K} \\|\\ell_k\\|_1 \\le \\max_{r < m_0} \\|\\ell_{K+r}\\|_1,\\qquad
    \\sum_{k \\ge K} \\|\\ell_k\\|_1 \\le \\frac{1}{1 - \\theta} \\sum_{r < m_0} \\|\\ell_{K+r}\\|_1 .

Ball arithmetic propagated along the recursion is not used: its radii grow like the powers of
the entrywise |M|, whose spectral radius exceeds 1 for every oscillating system (measured:
1e115 relative after 5000 steps of the paper's central observer). Every floating-point sum
below is widened by :func:`upper` (its own rounding).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Iterator

import flint
import numpy as np

from glocal_verify.numerics.rounding import EPS, gamma_bound

__all__ = ["PowerCertificate", "power_certificate", "certified_orbit", "RowSequence", "certified_rows", "certified_row_chunks", "abs_row_sums", "exact_to_float", "upper", "MAX_WINDOW_LOG2"]

#: largest exponent i tried for the window 2^i of the tail certificate
MAX_WINDOW_LOG2 = 16


def upper(x: Any, ops: int = 4) -> Any:
    """``x`` (>= 0) widened by the rounding of ``ops`` floating-point operations, ``(1 + gamma_ops) x``."""
    if isinstance(x, np.ndarray):
        return x * (1.0 + gamma_bound(ops)) + 1e-300
    return float(x) * (1.0 + gamma_bound(ops)) + 1e-300


@dataclass(frozen=True, slots=True)
class RowSequence:
    """``ell_k = C M^k`` for ``k < len`` with certified errors, and the tail certificate.

    Attributes
    ----------
    mid : ndarray
        (K + window, q, n) computed rows.
    err : ndarray
        (K + window, q): ``||ell_k[j](exact) - mid_k[j]||_1 <=`` err.
    horizon : int
        K: the rows ``k < K`` are the sequence proper, ``[K, K + window)`` the tail window.
    window : int
        m0 of the tail certificate (0 when none was found: then :attr:`theta` is ``inf``).
    theta : float
        Certified ``||M^m0||_inf <= theta < 1`` (``inf`` when not certified).
    kappa : float
        Certified ``sup_t ||M^t||_inf``.
    """

    mid: np.ndarray
    err: np.ndarray
    horizon: int
    window: int
    theta: float
    kappa: float

    @property
    def certified_stable(self) -> bool:
        """The tail certificate exists (``theta < 1``): M is Schur-stable."""
        return self.theta < 1.0

    @property
    def max_error(self) -> float:
        """The largest row error (1-norm)."""
        return float(self.err.max()) if self.err.size else 0.0

    def norms(self) -> np.ndarray:
        """(len, q) certified upper bounds of ``||ell_k[j]||_1``."""
        return upper(np.abs(self.mid).sum(axis=2) + self.err, self.mid.shape[2] + 2)  # type: ignore[no-any-return]

    def tail_norms(self) -> tuple[np.ndarray, np.ndarray]:
        """Per row j: upper bounds of ``sup_{k >= K} ||ell_k[j]||_1`` and ``sum_{k >= K} ||ell_k[j]||_1``."""
        q = self.mid.shape[1]
        if not self.certified_stable:
            return np.full(q, math.inf), np.full(q, math.inf)
        nrm = self.norms()[self.horizon : self.horizon + self.window]
        return nrm.max(axis=0), upper(nrm.sum(axis=0) / (1.0 - self.theta), self.window + 4)


def _abs_norm_inf(X: np.ndarray) -> float:
    return float(upper(np.abs(X).sum(axis=1).max(initial=0.0), X.shape[1] + 2))


@dataclass(frozen=True, slots=True)
class PowerCertificate:
    """Certified bounds on the powers of M (module docstring: the bootstrap).

    Attributes
    ----------
    window : int
        m0 (0 when none was found).
    theta : float
        ``||M^m0||_inf <= theta < 1`` (``inf`` when not certified).
    kappa : float
        ``sup_t ||M^t||_inf <= kappa`` (``inf`` when not certified).
    """

    window: int
    theta: float
    kappa: float


def power_certificate(M: Any) -> PowerCertificate:
    """Window, contraction and power bound of M by the bootstrap of the module docstring."""
    Mf, Me = exact_to_float(M)
    n = Mf.shape[0]
    W = Me + gamma_bound(n + 2) * np.abs(Mf)
    window, theta, kappa = 0, math.inf, math.inf
    P = Mf.copy()
    for i in range(MAX_WINDOW_LOG2 + 1):
        if _abs_norm_inf(P) < 0.5:
            window = 1 << i
            break
        if not np.all(np.isfinite(P)) or np.abs(P).max() > 1e150:
            break
        P = P @ P
    if window:
        a, c = 1.0, 0.0  # t = 0: ||I|| = 1
        Pt = np.eye(n)
        for _ in range(window):
            c += _abs_norm_inf(np.abs(Pt) @ W)
            Pt = Pt @ Mf
            a = max(a, _abs_norm_inf(Pt))
        c = upper(c, window + 2)
        if c < 1.0:
            kappa = upper(a / (1.0 - c))
            th = upper(_abs_norm_inf(Pt) + kappa * c)
            if th < 1.0:
                theta = th
            else:
                window, kappa = 0, math.inf
        else:
            window = 0
    return PowerCertificate(window, theta, kappa)


def certified_rows(M: Any, C: Any, horizon: int, certificate: PowerCertificate | None = None) -> RowSequence:
    """The rows ``C M^k`` for ``k < horizon`` plus the tail window (module docstring).

    Parameters
    ----------
    M : fmpq_mat, arb_mat or ndarray
        The exact system matrix (n x n): rational, an enclosure, or binary floats taken exactly.
    C : fmpq_mat, arb_mat or ndarray
        q x n.
    horizon : int
        K.
    certificate : PowerCertificate, optional
        Of M, when already known.
    """
    Mf, Me = exact_to_float(M)
    Cf, Ce = exact_to_float(C)
    n = Mf.shape[0]
    W = Me + gamma_bound(n + 2) * np.abs(Mf)
    pc = certificate if certificate is not None else power_certificate(M)
    window, theta, kappa = pc.window, pc.theta, pc.kappa
    total = horizon + window
    q = Cf.shape[0]
    mid = np.empty((total, q, n))
    eta_sum = np.zeros(q)
    err = np.empty((total, q))
    e0 = upper(Ce.sum(axis=1), n + 2)
    R = Cf.copy()
    for k in range(total):
        mid[k] = R
        # ||delta_k||_1 <= kappa (||delta_0||_1 + sum_{j<k} ||eta_j||_1); without kappa: infinite
        err[k] = upper(kappa * (e0 + eta_sum), 4) if math.isfinite(kappa) else math.inf
        eta_sum = upper(eta_sum + (np.abs(R) @ W).sum(axis=1), n + 3)
        R = R @ Mf
    if not math.isfinite(kappa):
        err[:] = math.inf
    return RowSequence(mid, err, horizon, window, theta, kappa)


def certified_row_chunks(M: Any, C: Any, horizon: int, certificate: PowerCertificate | None = None, chunk: int = 256) -> Iterator[tuple[int, np.ndarray, np.ndarray]]:
    """The rows ``C M^k`` for ``k < horizon`` in chunks, with the errors of :func:`certified_rows`
    (the same recursion), without holding every row at once.

    Yields
    ------
    (k0, mid, err)
        ``mid`` (c, q, n) the rows ``k0 .. k0 + c - 1``, ``err`` (c, q) bounds of their 1-norm errors.
    """
    Mf, Me = exact_to_float(M)
    Cf, Ce = exact_to_float(C)
    n = Mf.shape[0]
    W = Me + gamma_bound(n + 2) * np.abs(Mf)
    kappa = (certificate if certificate is not None else power_certificate(M)).kappa
    q = Cf.shape[0]
    eta_sum = np.zeros(q)
    e0 = upper(Ce.sum(axis=1), n + 2)
    R = Cf.copy()
    for k0 in range(0, horizon, chunk):
        c = min(chunk, horizon - k0)
        mid = np.empty((c, q, n))
        err = np.empty((c, q))
        for k in range(c):
            mid[k] = R
            err[k] = upper(kappa * (e0 + eta_sum), 4) if math.isfinite(kappa) else math.inf
            eta_sum = upper(eta_sum + (np.abs(R) @ W).sum(axis=1), n + 3)
            R = R @ Mf
        yield k0, mid, err


def exact_to_float(X: Any) -> tuple[np.ndarray, np.ndarray]:
    """Floats of an exact matrix and an entrywise bound of their rounding error."""
    if isinstance(X, flint.fmpq_mat):
        m, n = X.nrows(), X.ncols()
        F = np.array([[float(X[i, j]) for j in range(n)] for i in range(m)]).reshape(m, n)
        return F, EPS / 2 * np.abs(F) * (1 + EPS) + 1e-300 * (F != 0)
    if isinstance(X, flint.arb_mat):
        m, n = X.nrows(), X.ncols()
        F = np.empty((m, n))
        E = np.empty((m, n))
        for i in range(m):
            for j in range(n):
                F[i, j] = float(X[i, j].mid())
                E[i, j] = float(X[i, j].rad()) + EPS * abs(F[i, j])
        return F, E * (1 + 2 * EPS)
    F = np.atleast_2d(np.asarray(X, dtype=float))
    return F, np.zeros_like(F)


def abs_row_sums(rows: RowSequence, X: Any, upto: int | None = None) -> np.ndarray:
    """Certified upper bounds of ``sum_c |(ell_k X)_{j c}|`` for every k < ``upto`` and row j.

    ``X`` exact (``fmpq_mat``), an ``arb_mat`` enclosure, or a float array taken exactly. The
    float product of the computed rows has entrywise error at most ``gamma_{n+1} |mid| |X^|``
    (Higham, Thm 3.5); the rows' own error adds ``err_k max_i |X_ic|`` per column; rounding X
    to floats adds ``|mid| err(X)``; the sums are widened by their own rounding.

    Returns
    -------
    ndarray
        (upto, q).
    """
    K = rows.mid.shape[0] if upto is None else upto
    Xf, Xe = exact_to_float(X)
    n = Xf.shape[0]
    mid = rows.mid[:K]
    prod = mid @ Xf  # (K, q, c)
    colmax = (np.abs(Xf) + Xe).max(axis=0) if Xf.size else np.zeros(Xf.shape[1])
    err = gamma_bound(n + 1) * (np.abs(mid) @ np.abs(Xf)) + np.abs(mid) @ Xe
    total = np.abs(prod).sum(axis=2) + upper(err.sum(axis=2), Xf.shape[1] + n + 4) + rows.err[:K] * upper(float(colmax.sum()), Xf.shape[1] + 2)
    return upper(total, Xf.shape[1] + 4)  # type: ignore[no-any-return]


def certified_orbit(M: Any, v: np.ndarray, steps: int, certificate: PowerCertificate | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``M^m v`` for ``m < steps`` (v real or complex, taken exactly) with certified errors.

    Returns
    -------
    (mid, err)
        (steps, n) computed vectors and (steps,) bounds on ``||M^m v - mid_m||_inf``
        (``kappa`` times the accumulated rounding, as for the rows).
    """
    Mf, Me = exact_to_float(M)
    n = Mf.shape[0]
    W = Me + gamma_bound(n + 2) * np.abs(Mf)
    pc = certificate if certificate is not None else power_certificate(M)
    v = np.asarray(v)
    mid = np.empty((steps, n), dtype=np.result_type(v.dtype, float))
    err = np.empty(steps)
    x = v.copy()
    acc = 0.0
    cplx = 2.0 if np.iscomplexobj(v) else 1.0
    for m in range(steps):
        mid[m] = x
        err[m] = upper(pc.kappa * acc, 4) if math.isfinite(pc.kappa) else math.inf
        acc = upper(acc + cplx * float((W @ np.abs(x)).max(initial=0.0)), n + 4)
        x = Mf @ x
    return mid, err
