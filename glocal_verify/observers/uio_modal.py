"""The default UIO design and its Hurwitz certificate from the cluster's modal structure.

With the interior decomposition of :mod:`glocal_verify.analysis.local.cluster_modal`
(L_II U = U diag(mu), g = U^T L_Ib), the columns

* z^a_k = [u_k; 0], z^c_k = [0; u_k] of the interior modes whose eigenvalues
  lam^2 + gamma lam + alpha mu_k = 0 both have Re <= -theta sigma (kept, a 2 x 2 block
  [[0, 1], [-a_k, -gamma]], a_k = fl(alpha mu_k));
* phi^-_k = z^a_k + lam^-_k z^c_k (kept) and phi^+_k = z^a_k + lam^+_k z^c_k (moved) of the
  overdamped modes with lam^+_k > -theta sigma;
* beta^p_j = [-L_II^{-1} L_Ib e_j; e_j | 0] and beta^v_j = [(gamma / alpha) L_II^{-2} L_Ib e_j; 0 |
  -L_II^{-1} L_Ib e_j; e_j] of the boundary (A_1 beta^v_j = beta^p_j, A_1 beta^p_j = 0),

form a basis Phi = [Phi_K, Phi_m] in which A_1 = blkdiag(D_1, A_m) with A_m =
blkdiag(diag(lam^+), [[0, I], [0, 0]]). The moved system (A_m, C Phi_m) has m = |S| + 2 |dP_i|
states. Its observable part gets the default poles (:func:`~glocal_verify.observers.uio_existence.default_poles`) by
a small pole placement, G; K_1 = Phi_m G keeps every kept mode where it is, and

.. math:: \\Phi^{-1} F \\Phi = \\begin{bmatrix} D_1 & 0 \\\\ -G C \\Phi_K & A_m - G C \\Phi_m \\end{bmatrix},
          \\qquad F = A_1 - K_1 C,

so eig(F) = eig(D_1) ∪ eig(F_m): the same eigenvalues as the dense ordered-Schur design of
:func:`glocal_verify.observers.uio.design_uio`, from n-sized symmetric work and m-sized dense work.

Certificate (:func:`modal_certificate`). With F_m = W diag(nu) W^{-1}, Phi' = [Phi_K, Psi],
Psi = fl(Phi_m W), and D = [[D_1, 0], [Q, diag(nu)]] (Q = -(W^{-1} G) C Phi_K), the residual
R = F_exact Phi' - Phi' D is bounded rigorously (its floating-point evaluation, gamma_k bounds,
and ||fl A - A_exact||_2), sigma_min(Phi') from below by sigma_min(U) >= sqrt(1 - ||U^T U - I||_2),
the block triangular coefficients (||V_k^{-1}||, 1 + ||Y||_F), sigma_min(W) minus its SVD error
and the rounding of forming the columns. Then Phi'^{-1} F_exact Phi' = D + E with
||E||_2 <= eps_E = ||R||_2 / sigma_min(Phi'), and for Re lam >= 0 (maximum principle; D is
Hurwitz) ||(D - lam)^{-1}||_2 <= rho = rho_1 + rho_2 + rho_2 ||Q||_2 rho_1 with rho_1 the
worst 2 x 2 Schur bound 1/d_1 + 1/d_2 + |tau| / (d_1 d_2) (d_i = -Re lam_i) and rho_2 =
1 / min(-Re nu). F_exact is Hurwitz when eps_E rho < 1: D + E - lam = (D - lam)(I + (D -
lam)^{-1} E) is then invertible on the closed right half-plane.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np
import scipy.sparse

from glocal_verify import config
from glocal_verify.analysis.local.cluster_modal import InteriorModes
from glocal_verify.numerics.rounding import EPS, gamma_bound, svd_error
from glocal_verify.errors import NotApplicableError
from glocal_verify.numerics.tolerance import DEFAULT_TOLERANCE, Decision, Tolerance
from glocal_verify.observers.uio_existence import (
    _observable_split,
    _place_dual,
    default_poles,
)
from glocal_verify.results import Status

__all__ = ["ModalCertificate", "ModalUIODesign", "design_uio_modal", "modal_certificate"]



@dataclass(frozen=True, slots=True)
class ModalCertificate:
    """The structured Hurwitz certificate of F_exact = (I - h C) A_exact - K_1 C.

    Attributes
    ----------
    certified : bool
        eps_E rho < 1 (and D Hurwitz): F_exact has no eigenvalue with Re >= 0.
    perturbation : float
        eps_E, upper bound of ||Phi'^{-1} F_exact Phi' - D||_2.
    resolvent : float
        rho, upper bound of ||(D - lam)^{-1}||_2 on Re lam >= 0.
    residual : float
        Upper bound of ||F_exact Phi' - Phi' D||_2.
    sigma_min : float
        Lower bound of sigma_min(Phi').
    abscissa_upper : float
        An upper bound of the spectral abscissa of F_exact (-s for the largest tried shift s
        at which the certificate still holds; +inf when not certified).
    note : str
        Which bound failed, when not certified.
    """

    certified: bool
    perturbation: float
    resolvent: float
    residual: float
    sigma_min: float
    abscissa_upper: float
    note: str = ""


@dataclass(frozen=True, slots=True)
class ModalUIODesign:
    """A default-pole UIO design in modal coordinates (see the module docstring).

    Attributes
    ----------
    theta : float
        Modes with Re > -theta sigma were moved.
    K1 : ndarray
        Gain (2n x p); F = A_1 - K_1 C.
    kept, moved : ndarray
        Eigenvalues of D_1 (kept) and of F_m (placed and unobservable moved ones).
    poles : ndarray
        Kept eigenvalues followed by the requested poles of the moved observable part.
    detectable : Status
        Whether every moved mode with Re >= 0 (the boundary block) is observable.
    unobservable : ndarray
        Eigenvalues of unobservable modes: kept planes whose eigenvector vanishes on the
        measured agents (by singular values at ``tol``) and unobservable moved modes.
    unstable_mode : tuple or None
        (eigenvalue, state vector) of an unobservable moved mode with Re >= 0.
    certificate : ModalCertificate or None
        None when the design did not produce a Hurwitz F_m.
    gain_norm : float
        ||K_1||_F.
    notes : tuple of str
    """

    theta: float
    K1: np.ndarray
    kept: np.ndarray
    moved: np.ndarray
    poles: np.ndarray
    detectable: Status
    unobservable: np.ndarray
    unstable_mode: tuple[complex, np.ndarray] | None
    certificate: ModalCertificate | None
    gain_norm: float
    notes: tuple[str, ...] = field(default_factory=tuple)

    @property
    def eigenvalues(self) -> np.ndarray:
        """Eigenvalues of F: kept then moved."""
        return np.concatenate([self.kept.astype(complex), self.moved.astype(complex)])


def _roots(a: np.ndarray, gamma: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(real, lam_minus, lam_plus) of lam^2 + gamma lam + a = 0 per entry, stable formulas
    (lam^+ = -2 a / (gamma + sqrt(gamma^2 - 4 a)) avoids the cancellation for small a)."""
    disc = gamma * gamma - 4.0 * a
    real = disc > 0.0
    sq = np.sqrt(np.where(real, disc, 0.0))
    lm = np.where(real, (-gamma - sq) / 2.0, -gamma / 2.0)
    lp = np.where(real, -2.0 * a / (gamma + sq), -gamma / 2.0)
    return real, lm, lp


class _Basis:
    """Columns of Phi in state coordinates and their coefficients (internal)."""

    def __init__(self, modes: InteriorModes, alpha: float, gamma: float, theta: float) -> None:
        n, I, b = modes.size, modes.interior, modes.boundary
        self.n, self.nb = n, len(b)
        self.a = alpha * modes.mu
        real, lm, lp = _roots(self.a, gamma)
        self.S = np.flatnonzero(real & (lp > -theta * gamma / 2.0))
        self.K = np.setdiff1d(np.arange(len(modes.mu)), self.S)
        self.lm_S, self.lp_S = lm[self.S], lp[self.S]
        self.real_K, self.lm_K, self.lp_K = real[self.K], lm[self.K], lp[self.K]
        U = modes.U
        nb = self.nb
        if nb and (len(modes.mu) and float(modes.mu[0]) <= 0.0):
            raise NotApplicableError("the interior block L_II is not positive definite: the boundary block is not separated")
        mu = modes.mu
        # coefficients of beta^p (a-part) and beta^v (a- and c-parts) on the interior modes
        ga = -modes.g / mu[:, None] if nb else np.zeros((len(mu), 0))
        gv = (gamma / alpha) * modes.g / (mu * mu)[:, None] if nb else np.zeros((len(mu), 0))
        Ya = np.hstack([ga, gv])  # a-coordinates of [beta^p, beta^v]
        Yc = np.hstack([np.zeros_like(ga), ga])  # c-coordinates
        # columns scaled to about unit norm by powers of 2 (exact): sb is the scaled unit entry
        norms = np.sqrt(1.0 + np.sum(Ya * Ya, axis=0) + np.sum(Yc * Yc, axis=0))
        self.sb = np.exp2(-np.round(np.log2(norms))) if len(norms) else np.ones(0)
        self.Ya, self.Yc = Ya * self.sb, Yc * self.sb
        m = len(self.S) + 2 * nb
        self.m = m
        Pm = np.zeros((2 * n, m))
        US = U[:, self.S]
        Pm[I, : len(self.S)] = US
        Pm[n + I, : len(self.S)] = US * self.lp_S
        Pm[I, len(self.S) :] = U @ self.Ya
        Pm[n + I, len(self.S) :] = U @ self.Yc
        Pm[b, len(self.S) + np.arange(nb)] = self.sb[:nb]
        Pm[n + b, len(self.S) + nb + np.arange(nb)] = self.sb[nb:]
        self.Pm = Pm
        # rounding of forming the moved columns and the S-kept columns against Z M~
        absU = np.abs(U)
        dY = np.abs(absU @ np.abs(self.Ya)) + np.abs(absU @ np.abs(self.Yc))
        self.dPhi = gamma_bound(len(mu) + 2) * float(np.linalg.norm(dY)) + (EPS / 2) * float(
            np.sqrt(np.sum((self.lp_S**2 + self.lm_S**2) * np.sum(US * US, axis=0)))
        )
        Am = np.zeros((m, m))
        Am[np.arange(len(self.S)), np.arange(len(self.S))] = self.lp_S
        Am[len(self.S) + np.arange(nb), len(self.S) + nb + np.arange(nb)] = self.sb[nb:] / self.sb[:nb]  # A_1 beta^v = beta^p
        self.Am = Am

    def kept_eigenvalues(self, gamma: float) -> np.ndarray:
        """Eigenvalues of D_1: both roots of each kept plane, then lam^- of the S modes."""
        aK = self.a[self.K]
        im = np.sqrt(np.maximum(4.0 * aK - gamma * gamma, 0.0)) / 2.0
        first = np.where(self.real_K, self.lp_K + 0j, -gamma / 2.0 + 1j * im)
        second = np.where(self.real_K, self.lm_K + 0j, -gamma / 2.0 - 1j * im)
        return np.concatenate([first, second, self.lm_S + 0j])


def _state_rows(modes: InteriorModes, pos: Sequence[int], vel: Sequence[int]) -> tuple[list[int], list[int]]:
    """Rows of C that read interior agents (as interior indices) for positions and velocities."""
    where = {int(a): r for r, a in enumerate(modes.interior)}
    return [where[i] for i in pos if i in where], [where[i] for i in vel if i in where]


def _kept_unobservable(modes: InteriorModes, B: _Basis, rows: list[int], gamma: float, tol: Tolerance) -> np.ndarray:
    """Eigenvalues of kept planes invisible at the measured interior agents (witness only).

    Eigenvalues of L_II closer than rtol * band * max(|mu|, 1) are grouped; a group loses
    dim - rank(U[measured, group]) planes (rank by singular values at ``tol``)."""
    if not len(B.K):
        return np.zeros(0, dtype=complex)
    mu = modes.mu[B.K]
    scale = max(float(np.max(np.abs(modes.mu))), 1.0)
    out: list[complex] = []
    kept = B.kept_eigenvalues(gamma)
    nK = len(B.K)
    start = 0
    for k in range(1, nK + 1):
        if k < nK and mu[k] - mu[k - 1] <= tol.upper * scale:
            continue
        grp = np.arange(start, k)
        M = modes.U[np.ix_(np.asarray(rows, dtype=int), B.K[grp])] if rows else np.zeros((0, len(grp)))
        s = np.linalg.svd(M, compute_uv=False) if M.size else np.zeros(0)
        r = int(np.sum(s > tol.upper))
        for j in grp[: len(grp) - r]:
            out += [complex(kept[j]), complex(kept[nK + j])]
        start = k
    return np.asarray(out, dtype=complex)


def _schur_resolvent(d1: np.ndarray, d2: np.ndarray, tau: np.ndarray) -> float:
    """max over blocks of 1/d1 + 1/d2 + tau / (d1 d2), rounded up (every d > 0)."""
    if not len(d1):
        return 0.0
    v = 1.0 / d1 + 1.0 / d2 + tau / (d1 * d2)
    return float(np.max(v)) * (1.0 + 16 * EPS)


def modal_certificate(
    A1: Any, modes: InteriorModes, B: _Basis, K1: np.ndarray, G: np.ndarray, C_rows: np.ndarray, nu: np.ndarray, W: np.ndarray, gamma: float, input_error: float
) -> ModalCertificate:
    """The certificate of the module docstring for one design.

    Parameters
    ----------
    A1 : sparse matrix
        (I - h C) fl(A^i) (CSR, 2n x 2n).
    modes : InteriorModes
    B : _Basis
        The modal basis of the design.
    K1, G : ndarray
        K_1 = Phi_m G and G (m x p).
    C_rows : ndarray of int
        State indices measured by C (its rows are unit vectors, in this order).
    nu, W : ndarray
        Eigenvalues and unit eigenvectors of F_m = A_m - G C Phi_m.
    gamma : float
    input_error : float
        Upper bound of ||fl(A^i) - A^i_exact||_2 (the projector I - h C has norm 1).
    """
    n, I = B.n, modes.interior
    U = modes.U
    m = B.m
    r = int(np.max(np.diff(A1.indptr))) if A1.shape[0] else 0
    # kept part: d_i = -Re of the kept eigenvalues (lower bounds), Schur coupling tau
    aK = B.a[B.K]
    if len(aK) and np.any(aK <= 0.0):
        return ModalCertificate(False, math.inf, math.inf, math.inf, 0.0, math.inf, "a kept plane has alpha mu <= 0")
    # the eigenvalues of [[0, 1], [-a, -gamma]] have distances d_1 <= d_2 to the imaginary
    # axis with d_1 + d_2 = gamma (real roots) or d_1 = d_2 = gamma / 2: d_2 >= gamma / 2 and
    # d_1 = 2 a / (gamma + sqrt(gamma^2 - 4 a)) >= 2 a / (gamma + sqrt(upper bound of the
    # discriminant)) (near critical damping the computed discriminant has an absolute error
    # of a few eps gamma^2, which a relative allowance on the roots would not cover);
    # |tau|^2 = ||block||_F^2 - |lam_1|^2 - |lam_2|^2 <= 1 + a^2 + gamma^2 - 2 |a| (AM-GM)
    disc_hi = (gamma * gamma - 4.0 * aK) + 4 * EPS * (gamma * gamma + 4.0 * np.abs(aK))
    sq_hi = np.sqrt(np.maximum(disc_hi, 0.0)) * (1.0 + 2 * EPS)
    d1 = np.minimum(gamma / 2.0, 2.0 * aK / (gamma + sq_hi)) * (1.0 - 8 * EPS)
    d2 = np.full(len(aK), gamma / 2.0 * (1.0 - 2 * EPS))
    tau = np.sqrt((1.0 - aK) ** 2 + gamma * gamma) * (1.0 + 16 * EPS)
    dS = -B.lm_S * (1.0 - 16 * EPS)
    if np.any(d1 <= 0) or np.any(d2 <= 0) or np.any(dS <= 0) or np.any(nu.real >= 0):
        return ModalCertificate(False, math.inf, math.inf, math.inf, 0.0, math.inf, "D is not Hurwitz")
    # residual of the kept a-columns: velocity rows of I, fl(A[vI, I]) u_k + a_k u_k
    AvII = A1[n + I][:, I]
    UK = U[:, B.K]
    RK = AvII @ UK + UK * aK
    gk = gamma_bound(r + 3)
    dRK = gk * float(np.linalg.norm(abs(AvII) @ np.abs(UK) + np.abs(UK) * np.abs(aK)))
    # S-kept columns phi^- (explicit, 2n x |S|)
    PS = np.zeros((2 * n, len(B.S)))
    PS[I] = U[:, B.S]
    PS[n + I] = U[:, B.S] * B.lm_S
    RS = A1 @ PS - PS * B.lm_S
    dRS = gk * float(np.linalg.norm(abs(A1) @ np.abs(PS) + np.abs(PS) * np.abs(B.lm_S)))
    # rows of C Phi_K: K a-columns, K c-columns, S-kept
    CPK = np.zeros((len(C_rows), 2 * len(B.K) + len(B.S)))
    for row, st in enumerate(C_rows):
        st = int(st)
        loc = st % n
        where = np.flatnonzero(I == loc)
        if not len(where):
            continue  # boundary state: no kept column touches it
        q = int(where[0])
        if st < n:
            CPK[row, : len(B.K)] = U[q, B.K]
        else:
            CPK[row, len(B.K) : 2 * len(B.K)] = U[q, B.K]
        CPK[row, 2 * len(B.K) :] = PS[st]
    # moved part
    Psi = B.Pm @ W
    gm = 2.0 * gamma_bound(2 * (m + 3))
    dPsi = gm * float(np.linalg.norm(np.abs(B.Pm) @ np.abs(W)))
    CPsi = Psi[C_rows]
    Rm = A1 @ Psi - K1 @ CPsi - Psi * nu
    gr = 2.0 * gamma_bound(2 * (r + len(C_rows) + 4))
    dRm = gr * float(np.linalg.norm(abs(A1) @ np.abs(Psi) + np.abs(K1) @ np.abs(CPsi) + np.abs(Psi) * np.abs(nu)))
    WG = np.linalg.solve(W, G.astype(complex)) if m else np.zeros((0, len(C_rows)), dtype=complex)
    Kd = K1 - Psi @ WG
    dKd = gm * float(np.linalg.norm(np.abs(K1) + np.abs(Psi) @ np.abs(WG)))
    nKd = float(np.linalg.norm(Kd)) * (1 + 4 * EPS * Kd.size) + dKd
    nCPK = float(np.linalg.norm(CPK)) * (1 + 4 * EPS * CPK.size)
    fro = lambda M: float(np.linalg.norm(M)) * (1.0 + 4 * EPS * max(M.size, 1))  # noqa: E731
    nRK = fro(RK) + dRK + fro(RS) + dRS + nKd * nCPK
    nRm = fro(Rm) + dRm
    normK = math.sqrt(fro(UK) ** 2 * 2 + fro(PS) ** 2)
    normPsi = fro(Psi) + dPsi
    residual = (math.hypot(nRK, nRm) + input_error * math.hypot(normK, normPsi)) * (1.0 + 8 * EPS)
    # sigma_min(Phi') >= s_Z s_M s_W - ||dPhi|| ||W'|| - ||dPsi||
    sZ = math.sqrt(max(0.0, 1.0 - modes.orthogonality)) * (1.0 - 4 * EPS) if len(I) else 1.0
    sM = _coefficient_sigma_min(B)
    sw = np.linalg.svd(W, compute_uv=False) if m else np.ones(1)
    sW = min(1.0, float(sw[-1]) - svd_error(W)) if m else 1.0
    nW = max(1.0, fro(W)) if m else 1.0
    smin = (sZ * sM * sW - B.dPhi * nW - dPsi) * (1.0 - 8 * EPS)
    if smin <= 0.0:
        return ModalCertificate(False, math.inf, math.inf, residual, smin, math.inf, f"sigma_min of the modal basis is not bounded away from 0 (lower bound {smin:.3g})")
    nQ = float(np.linalg.norm(WG)) * (1 + 4 * EPS * WG.size) * nCPK
    dnu = -nu.real * (1.0 - 16 * EPS)

    dmin = min([float(np.min(x)) for x in (d1, d2, dS, dnu) if len(x)] or [1.0])

    def scaled(t: float, s: float) -> tuple[float, float, float, float]:
        """(eps_E, rho, residual, sigma_min) for the basis [Phi_K, t Psi]: the coupling block
        becomes Q / t, the moved residual t R_m, sigma_min >= min(1, t) sigma_min(Phi')."""
        res_t = (math.hypot(nRK, t * nRm) + input_error * math.hypot(normK, t * normPsi)) * (1.0 + 8 * EPS)
        sm_t = smin * min(1.0, t) * (1.0 - 4 * EPS)
        e_t = res_t / sm_t * (1.0 + 4 * EPS)
        return e_t, rho(s, nQ / t), res_t, sm_t

    def rho(s: float, q: float) -> float:
        """Upper bound of ||(D_t - lam)^{-1}||_2 for Re lam >= -s (pointwise block bounds)."""
        if np.any(d1 <= s) or np.any(d2 <= s) or np.any(dS <= s) or np.any(dnu <= s):
            return math.inf
        r1 = max(_schur_resolvent(d1 - s, d2 - s, tau), float(np.max(1.0 / (dS - s))) if len(dS) else 0.0)
        r2 = float(np.max(1.0 / (dnu - s))) if len(dnu) else 0.0
        return (r1 + r2 + r2 * q * r1) * (1.0 + 16 * EPS)

    ts = [10.0**k for k in range(-2, 9)]
    best = min(ts, key=lambda t: (lambda e: e[0] * e[1])(scaled(t, 0.0)))
    e0, r0, res0, sm0 = scaled(best, 0.0)
    if not e0 * r0 < 1.0:
        return ModalCertificate(
            False, e0, r0, res0, sm0, math.inf,
            f"perturbation bound {e0:.3g} times the resolvent bound {r0:.3g} of the modal form is not below 1",
        )
    top = 0.0
    for frac in (0.5, 0.25, 0.1):
        e_s, r_s, _, _ = scaled(best, frac * dmin)
        if e_s * r_s < 1.0:
            top = -frac * dmin
            break
    return ModalCertificate(True, e0, r0, res0, sm0, top)


def _coefficient_sigma_min(B: _Basis) -> float:
    """Lower bound of sigma_min(M~), M~ the coefficients of [Phi_K, Phi_m] in the basis Z.

    Ordering the coordinates as (kept planes, S planes and boundary) and the columns as
    (kept, S-kept, moved), M~ = [[I, X], [0, M_s]] with X = the boundary columns' kept-plane
    coefficients and M_s small (2 |S| + 2 |dP_i|). Then
    ||M~^{-1}||_2 <= 1 + sqrt(1 + ||X||_F^2) / sigma_min(M_s), with sigma_min(M_s) from its SVD
    minus :func:`~glocal_verify.numerics.rounding.svd_error`.
    """
    nS, nb = len(B.S), B.nb
    k = 2 * nS + 2 * nb
    if k == 0:
        return 1.0
    Ms = np.zeros((k, k))
    iS = np.arange(nS)
    Ms[iS, iS] = 1.0  # a-coordinate of phi^-
    Ms[nS + iS, iS] = B.lm_S  # c-coordinate of phi^-
    Ms[iS, nS + iS] = 1.0
    Ms[nS + iS, nS + iS] = B.lp_S
    Ms[:nS, 2 * nS :] = B.Ya[B.S]
    Ms[nS : 2 * nS, 2 * nS :] = B.Yc[B.S]
    Ms[2 * nS :, 2 * nS :] = np.diag(B.sb)
    sv = np.linalg.svd(Ms, compute_uv=False)
    s_low = float(sv[-1]) - svd_error(Ms)
    if s_low <= 0.0:
        return 0.0
    X = math.hypot(float(np.linalg.norm(B.Ya[B.K])), float(np.linalg.norm(B.Yc[B.K]))) * (1.0 + 8 * EPS)
    return 1.0 / (1.0 + math.sqrt(1.0 + X * X) / s_low) * (1.0 - 8 * EPS)


def design_uio_modal(
    A: np.ndarray | scipy.sparse.spmatrix,
    modes: InteriorModes,
    positions: Sequence[int],
    velocities: Sequence[int],
    *,
    alpha: float,
    gamma: float,
    tol: Tolerance = DEFAULT_TOLERANCE,
    input_error: float = 0.0,
) -> ModalUIODesign:
    """Design the default-pole UIO of a cluster in modal coordinates and certify it.

    Parameters
    ----------
    A : ndarray or scipy.sparse matrix
        fl(A^i) (2n x 2n; :attr:`ClusterModel.A_sparse <glocal_verify.model.ClusterModel.A_sparse>`
        avoids the dense array); only its sparse structure is used (the decoupled A_1 = (I - h C) A).
    modes : InteriorModes
        :func:`~glocal_verify.analysis.local.cluster_modal.interior_modes` of the same block.
    positions, velocities : sequence of int
        Cluster indices measured by C_loc (the rows of C, positions first). Every boundary
        agent must be among ``velocities`` (rank condition).
    alpha, gamma : float
        Gains of the agents.
    tol : Tolerance
        Rank decisions of the small observable split and of the placement.
    input_error : float
        ||fl(A^i) - A^i_exact||_2 bound (:func:`~glocal_verify.analysis.local.cluster_modal.state_rounding_bound`).

    Notes
    -----
    Cost: the products with U of the boundary columns (n^2 |dP_i|), a sparse product of A_1
    with the kept columns (nnz(L) n), an m-sized split, placement and eigen-decomposition,
    and the certificate's O(n^2 (m + p)) residuals. With an uncertified design and a large
    gain the slow modes are moved along ``slow_ladder`` (:mod:`glocal_verify.config`)
    as in the dense design.
    """
    n = modes.size
    if not set(int(b) for b in modes.boundary) <= set(int(v) for v in velocities):
        raise NotApplicableError("no UIO: rank(C E) = rank(E) fails (a boundary agent's velocity is not measured)")
    C_rows = np.asarray([int(i) for i in positions] + [n + int(i) for i in velocities], dtype=int)
    T = np.ones(2 * n)
    T[n + modes.boundary] = 0.0
    A1 = scipy.sparse.csr_matrix(scipy.sparse.diags(T) @ scipy.sparse.csr_matrix(A))
    A1.eliminate_zeros()
    rows_i = sorted(set(_state_rows(modes, positions, velocities)[0]) | set(_state_rows(modes, positions, velocities)[1]))
    notes: list[str] = []
    best: ModalUIODesign | None = None
    prev = config.get("slow_ladder")[0]
    for theta in config.get("slow_ladder"):
        B = _Basis(modes, alpha, gamma, theta)
        got = _design_one(A1, modes, B, C_rows, rows_i, gamma, tol, input_error, theta)
        if best is not None:
            cert0 = best.certificate
            notes.append(
                f"default placement (modes with Re > -{prev:g} sigma moved) not certified Hurwitz "
                f"({cert0.note if cert0 else 'no Hurwitz F_m'}; ||K1||_F {best.gain_norm:.3g}); retried moving only Re > -{theta:g} sigma"
            )
        best = got
        prev = theta
        if got.detectable is not Status.HOLDS or (got.certificate is not None and got.certificate.certified):
            break
        scale = max(float(abs(A1).sum(axis=1).max()), 1.0)
        if got.gain_norm <= config.get("uio_ladder_gain") * scale or B.m == 2 * B.nb:
            break
    assert best is not None
    return dataclasses.replace(best, notes=tuple(notes))


def _design_one(
    A1: Any, modes: InteriorModes, B: _Basis, C_rows: np.ndarray, rows_i: list[int], gamma: float, tol: Tolerance, input_error: float, theta: float
) -> ModalUIODesign:
    """One rung of the ladder: split, place and certify the moved block of ``B``."""
    m, p = B.m, len(C_rows)
    kept = B.kept_eigenvalues(gamma)
    unobs_kept = _kept_unobservable(modes, B, rows_i, gamma, tol)
    Cm = B.Pm[C_rows]
    Am = B.Am
    scale = max(float(np.linalg.norm(Am, 2)) if m else 0.0, float(np.linalg.norm(Cm, 2)) if Cm.size else 0.0, 1.0)
    split = _observable_split(Am, Cm, tol, scale)
    Qo, Qu = split.Qo, split.Qu
    unstable: tuple[complex, np.ndarray] | None = None
    un_m = np.zeros(0, dtype=complex)
    det = Status.HOLDS if split.decided else Status.UNDECIDED
    if Qu.shape[1]:
        Auu = Qu.T @ Am @ Qu
        un_m, Wu = np.linalg.eig(Auu)
        dec = [tol.decide(min(z.real, 0.0), scale) for z in un_m]
        bad = [k for k, z in enumerate(un_m) if z.real >= 0 or dec[k] is Decision.ZERO]
        if bad:
            k = max(bad, key=lambda j: un_m[j].real)
            unstable = (complex(un_m[k]), B.Pm @ (Qu @ Wu[:, k]))
            det = Status.FAILS
        elif any(d is Decision.UNDECIDED for d in dec):
            det = Status.UNDECIDED
    unobs = np.concatenate([unobs_kept, un_m.astype(complex)])
    empty = np.zeros((2 * B.n, p))
    if det is not Status.HOLDS:
        return ModalUIODesign(theta, empty, kept, un_m, kept, det, unobs, unstable, None, 0.0)
    no = Qo.shape[1]
    if no == m:
        Qo = np.eye(m)
        lam_m = np.concatenate([B.lp_S.astype(complex), np.zeros(2 * B.nb, dtype=complex)])
    else:
        lam_m = np.linalg.eigvals(Qo.T @ Am @ Qo) if no else np.zeros(0, dtype=complex)
    want = default_poles(lam_m, gamma) if no else np.zeros(0)
    if no:
        Aoo, Co = Qo.T @ Am @ Qo, Cm @ Qo
        Lo = _place_dual(Aoo.T, Co.T, np.asarray(want), tol).T
        G = Qo @ Lo
    else:
        G = np.zeros((m, p))
    K1 = B.Pm @ G
    Fm = Am - G @ Cm
    nu, W = np.linalg.eig(Fm) if m else (np.zeros(0, dtype=complex), np.zeros((0, 0), dtype=complex))
    poles = np.concatenate([kept, np.asarray(want, dtype=complex)])
    if np.all(poles.imag == 0):
        poles = poles.real
    cert = modal_certificate(A1, modes, B, K1, G, C_rows, nu.astype(complex), W.astype(complex), gamma, input_error)
    return ModalUIODesign(theta, K1, kept, nu, poles, det, unobs, None, cert, float(np.linalg.norm(K1)))
