"""Certified Hurwitz tests of a real matrix F from its eigenvalues and their condition numbers.

F is certified Hurwitz when every eigenvalue lies left of the imaginary axis by more than
``band`` times its uncertainty ``rho_i = kappa_i * delta`` (``kappa_i`` the eigenvalue
condition number, ``delta = rtol ||F||_2`` the backward error): :func:`hurwitz_certificate`
(one dense eigen-decomposition with left and right vectors), and :func:`hurwitz_reduced`
from a known block triangularisation (triangular back substitution for the condition
numbers). Used by the observer designs of :mod:`glocal_verify.observers`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from glocal_verify import config
from glocal_verify.numerics.subspace import EPS
from glocal_verify.numerics.tolerance import DEFAULT_TOLERANCE, Tolerance
from glocal_verify.results import Status

__all__ = [
    "HurwitzCertificate",
    "hurwitz_certificate",
    "hurwitz_eigenvalues",
    "hurwitz_reduced",
    "matrix_operator",
    "norm2",
]


@dataclass(frozen=True, slots=True)
class HurwitzCertificate:
    """Is F Hurwitz, allowing for eigenvalue sensitivity (:func:`hurwitz_certificate`)?

    Attributes
    ----------
    status : Status
    ratio : float
        The worst ratio -Re lambda_i / rho_i (the margin in units of uncertainty).
    eigenvalues : ndarray
        The eigenvalues of F the certificate read (empty when not kept).
    """

    status: Status
    ratio: float
    eigenvalues: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=complex))


def hurwitz_certificate(F: np.ndarray, tol: Tolerance = DEFAULT_TOLERANCE) -> HurwitzCertificate:
    """Decide whether F is Hurwitz, allowing for eigenvalue sensitivity.

    With backward error delta = rtol * ||F||_2 and kappa_i = 1 / |y_i^H x_i| the condition
    number of eigenvalue lambda_i (unit left and right eigenvectors), lambda_i is known to within
    rho_i = kappa_i * delta. F is certified Hurwitz when Re lambda_i < -band * rho_i for every i,
    certainly not Hurwitz when some Re lambda_i > band * rho_i, undecided otherwise.

    Parameters
    ----------
    F : ndarray
    tol : Tolerance

    Returns
    -------
    HurwitzCertificate
        The verdict and the worst ratio -Re lambda_i / rho_i (no eigenvalues kept).
    """
    got = hurwitz_eigenvalues(F, tol)
    return HurwitzCertificate(got.status, got.ratio)


def hurwitz_eigenvalues(F: np.ndarray, tol: Tolerance) -> HurwitzCertificate:
    """:func:`hurwitz_certificate` with the eigenvalues of F (one eigen-decomposition).

    Parameters
    ----------
    F : ndarray
    tol : Tolerance
    """
    import scipy.linalg

    if F.size == 0:
        return HurwitzCertificate(Status.HOLDS, float("inf"))
    w, vl, vr = scipy.linalg.eig(F, left=True, right=True)
    vl = vl / np.linalg.norm(vl, axis=0)
    vr = vr / np.linalg.norm(vr, axis=0)
    kappa = 1.0 / np.maximum(np.abs(np.sum(vl.conj() * vr, axis=0)), 1e-300)
    rho = kappa * tol.rtol * max(norm2(F), 1e-300)
    ratio = -w.real / rho
    return HurwitzCertificate(_decide_ratios(ratio, tol), float(np.min(ratio)), w)


def _real_to_complex_schur(S: np.ndarray) -> np.ndarray:
    """Complex upper triangular unitarily similar to the real quasi-triangular S (each 2 x 2
    block split by a Givens rotation, as :func:`scipy.linalg.rsf2csf`, without the basis)."""
    T = S.astype(complex)
    n = T.shape[0]
    for m in range(n - 1, 0, -1):
        if T[m, m - 1] != 0.0:
            mu = np.linalg.eigvals(T[m - 1 : m + 1, m - 1 : m + 1]) - T[m, m]
            r = float(np.hypot(abs(mu[0]), abs(T[m, m - 1])))
            c, sn = mu[0] / r, T[m, m - 1] / r
            G = np.array([[np.conj(c), sn], [-sn, c]])
            T[m - 1 : m + 1, m - 1 :] = G @ T[m - 1 : m + 1, m - 1 :]
            T[: m + 1, m - 1 : m + 1] = T[: m + 1, m - 1 : m + 1] @ G.conj().T
        T[m, m - 1] = 0.0
    return T


def _triangular_kappa(T: np.ndarray, twin: np.ndarray | None = None) -> np.ndarray:
    """Condition numbers kappa_i = ||x_i|| ||y_i|| / |y_i^H x_i| of the eigenvalues T[i, i] of an
    upper triangular T, from its right (x_i) and left (y_i) eigenvectors by back substitution.

    x_i has x_i[i] = 1 and zeros below i, y_i^H has y_i[i] = 1 and zeros before i, so
    y_i^H x_i = 1. A divisor T[j, j] - T[i, i] smaller than u (|Re| + |Im|) of T[i, i] is
    replaced by that value (the perturbation of LAPACK's xTREVC); a non-finite result gives
    kappa = inf (nothing can be certified from it). ``twin[i]`` True means that T[i, i] is the
    conjugate of T[i - 1, i - 1] in a T unitarily similar to a real matrix: its condition number
    is the same (conjugate eigenvectors of the real matrix) and is not computed again.
    """
    n = T.shape[0]
    lam = np.diag(T).copy()
    smin = np.maximum(EPS / 2 * (np.abs(lam.real) + np.abs(lam.imag)), np.finfo(float).tiny)
    tw = np.zeros(n, dtype=bool) if twin is None else np.asarray(twin, dtype=bool)
    cols = np.flatnonzero(~tw)  # ascending; the eigenvalues whose vectors are computed
    nc = len(cols)
    lc, sc = lam[cols], smin[cols]

    def guard(d: np.ndarray, m: np.ndarray) -> np.ndarray:
        return np.where(np.abs(d) < m, m, d)

    X = np.zeros((n, nc), dtype=complex)  # columns: right eigenvectors of T[cols, cols]
    Yh = np.zeros((nc, n), dtype=complex)  # rows: left eigenvectors (conjugated)
    X[cols, np.arange(nc)] = 1.0
    Yh[np.arange(nc), cols] = 1.0
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        for j in range(n - 2, -1, -1):
            a = int(np.searchsorted(cols, j + 1))  # columns c with cols[c] > j
            if a < nc:
                X[j, a:] = -(T[j, j + 1 :] @ X[j + 1 :, a:]) / guard(T[j, j] - lc[a:], sc[a:])
        for j in range(1, n):
            b = int(np.searchsorted(cols, j))  # rows c with cols[c] < j
            if b:
                Yh[:b, j] = -(Yh[:b, :j] @ T[:j, j]) / guard(T[j, j] - lc[:b], sc[:b])
        kc = np.linalg.norm(X, axis=0) * np.linalg.norm(Yh, axis=1)
    kappa = np.empty(n)
    kappa[cols] = kc
    for i in np.flatnonzero(tw):
        kappa[i] = kappa[i - 1]
    return np.where(np.isfinite(kappa), kappa, np.inf)


def hurwitz_reduced(F: np.ndarray, W: np.ndarray, kept: int, sub: np.ndarray, tol: Tolerance) -> HurwitzCertificate | None:
    """:func:`hurwitz_eigenvalues` from a known block triangularisation of F^T; None when it does not apply.

    W (n x n, orthonormal columns) is such that R = W^T F^T W is block upper triangular with a
    quasi-triangular leading block of size ``kept`` (2 x 2 blocks where ``sub`` is True): for
    the UIO, W = [Qo Q, Qu] with Q the ordered Schur basis of the default design (the kept
    eigenvalues stay, the moved ones and the unobservable ones form the trailing block). The
    trailing block is brought to real Schur form, the rest of R is kept upper quasi-triangular
    and the entries dropped below it (rounding, and the part of A_1 Qu outside Qu that the
    numerical observable split leaves) have Frobenius norm ``d``. Then F^T is within d (plus
    the rounding of orthogonal transformations, far below rtol ||F||_2) of a matrix similar to
    the quasi-triangular S, and the certificate of :func:`hurwitz_certificate` is applied to
    the eigenvalues of S (its diagonal blocks) and their condition numbers
    (:func:`_triangular_kappa`, invariant under the unitary similarities) with
    delta = rtol ||F||_2 + d, never smaller than the dense certificate's. Used only when
    d <= rtol ||F||_2 and the trailing block has at most ``hurwitz_reduced_tail`` (:mod:`glocal_verify.config`) states.
    """
    import scipy.linalg

    n = F.shape[0]
    m = n - kept
    if n == 0 or m > config.get("hurwitz_reduced_tail") or W.shape != (n, n) or len(sub) != max(kept - 1, 0):
        return None
    R = W.T @ np.asarray(matrix_operator(F.T) @ W)
    if m:
        S2, Z2 = scipy.linalg.schur(R[kept:, kept:], output="real")
        R[:, kept:] = R[:, kept:] @ Z2
        R[kept:, :] = Z2.T @ R[kept:, :]
        R[kept:, kept:] = S2
    keep_sub = np.zeros(max(n - 1, 0), dtype=bool)
    keep_sub[: max(kept - 1, 0)] = sub
    if m:
        keep_sub[kept:] = np.diag(R[kept:, kept:], -1) != 0.0
    S = np.triu(R)
    i = np.flatnonzero(keep_sub)
    S[i + 1, i] = R[i + 1, i]
    dropped = float(np.linalg.norm(R - S))
    delta = tol.rtol * max(norm2(F), 1e-300)
    if not dropped <= delta:
        return None
    Tc = _real_to_complex_schur(S)
    w = np.diag(Tc).copy()
    twin = np.zeros(n, dtype=bool)
    twin[i + 1] = True  # the second eigenvalue of every 2 x 2 block: the conjugate of the first
    rho = _triangular_kappa(Tc, twin) * (delta + dropped)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.where(np.isfinite(rho), -w.real / rho, 0.0)
    return HurwitzCertificate(_decide_ratios(ratio, tol), float(np.min(ratio)), w)


def norm2(M: np.ndarray) -> float:
    """``||M||_2`` (an SVD; the norm enters the uncertainty rho, so it is never underestimated)."""
    return float(np.linalg.norm(M, 2)) if M.size else 0.0


def matrix_operator(A: np.ndarray) -> Any:
    """``A`` as a CSR matrix when it is sparse (the cluster matrices A_1 are: a few nonzeros per
    row), else A itself; products A V are then O(nnz(A) k) instead of O(n^2 k) and differ from
    the dense ones only by rounding (each entry is the same sum of products)."""
    n = A.shape[0]
    if n < config.get("sparse_min") or np.count_nonzero(A) > config.get("sparse_density") * n * n:
        return A
    import scipy.sparse

    return scipy.sparse.csr_matrix(A)


def _decide_ratios(ratio: np.ndarray, tol: Tolerance) -> Status:
    """Hurwitz from the ratios -Re(w_i) / rho_i: holds when all exceed the band, fails when one is below -band."""
    if np.all(ratio > tol.band):
        return Status.HOLDS
    if np.any(ratio < -tol.band):
        return Status.FAILS
    return Status.UNDECIDED
