"""Zero-dynamics attacks of the normal mode (Proposition II.4 (ii)), numeric.

The 2N-sized pencil of eq. ``zda_cond`` reduces in the eigenbasis of L_1 to an N-sized pencil
in ``s = lambda^2 + gamma lambda`` (:class:`ModalPencil`); :func:`zda_analysis` returns every zero
with its direction (xi, u0), growth class and verification; the witness direction the rule
picks is :func:`~glocal_verify.analysis.stealthy.zda_verdict.zda_direction`. The generic dense path on (A_1, B, C) is kept for
small systems and tests. Results are kept on ``system.analysis``.

The reduction (Definition II.2, eq. ``zda_cond``)
    A stealthy ZDA of (A_1, B, C, 0) is a zeroing direction ([x~_0; u_0], u_0 != 0) of the
    Rosenbrock pencil at some lambda_0; u_0 = 0 directions are unobservable modes, not
    attacks. With s = lambda^2 + gamma lambda the 2N-sized pencil reduces exactly to an
    N-sized one: x~_0 = [xi; lambda xi] with

    .. math::

        (sI + \\alpha L)\\,\\xi = S_F^\\top u_0,\\qquad S_{M_x}\\xi = 0,\\qquad
        \\lambda \\ne 0 \\Rightarrow S_{M_v}\\xi = 0,

    so ``dim ker P(lambda) = dim ker Q_lambda(s)`` with the pencil in s

    .. math::

        Q(s) = \\begin{bmatrix} sI + \\alpha L & -S_F^\\top \\\\ S_M & 0 \\end{bmatrix}

    (for lambda = 0 only the position rows S_{M_x} remain). Hence nrank P = N + nrank Q, P is
    left-invertible iff Q is, and the nonzero finite zeros of P are the roots lambda of
    lambda^2 + gamma lambda = s over the zeros s of Q; lambda = 0 is a zero iff
    dim ker Q_0 exceeds the normal kernel dimension N + m - nrank Q.

Structured numeric path (default)
    In the modal coordinates of L = U diag(mu) U^T, Q(s) is the Rosenbrock pencil of the
    N-state system (-alpha diag(mu), U_F^T, U_M, 0); :func:`glocal_verify.numerics.pencil.analyze_pencil`
    gives its normal rank and zeros in s. Every resulting lambda is then verified on the full
    2N pencil without forming it: the kernel of Q(s) is computed by eliminating the modes
    far from -s (eta_k = (U_F^T u)_k / (s + alpha mu_k)) and taking the small kernel of the
    remaining (near-pole modes, u) system; the direction is mapped back to
    x~_0 = [xi; lambda xi] and its residual

    .. math:: \\rho = \\frac{\\lVert P(\\lambda)[\\tilde x_0; u_0] \\rVert}
              {\\lVert P(\\lambda) \\rVert_{lb}\\, \\lVert [\\tilde x_0; u_0] \\rVert}

    is decided with the tolerance, where ||P(lambda)||_lb = max(||lambda I - A||_2, 1) is a
    lower bound of the pencil norm computed blockwise from the modal 2 x 2 blocks (a lower
    bound makes "zero" harder to reach: conservative for "a ZDA exists"). The input part is
    an attack when ||u_0|| / ||[x~_0; u_0]|| is nonzero at the tolerance.
    Cost: one symmetric eigendecomposition, one N-sized deflation and QZ, O(N^2) per zero.

Dense path (``method="dense"``)
    :func:`glocal_verify.numerics.pencil.analyze_pencil` on the 2N-sized (A_1, B, C): for small systems
    and for the tests that compare the two.

Exact path (:func:`~glocal_verify.analysis.stealthy.zda_exact.zda_analysis_exact`)
    The N-sized pencil in s over Q (:func:`glocal_verify.numerics.pencil_exact.analyze_pencil_exact`) gives
    left-invertibility and the zero polynomial z(s); the lambda-zeros are the roots of
    z(lambda^2 + gamma lambda) factored over Q, and for each irreducible factor g the kernel
    of Q(lambda^2 + gamma lambda) is computed exactly in Q[lambda]/(g), which decides whether
    an input direction exists and gives the direction. First, when the maximal minors of the
    reduced pencil prove (modulo a prime, :mod:`glocal_verify.numerics.minors`) that no
    kernel vector at any lambda != 0 has an input part, the same answer is assembled from the
    exact twin modes and the one rational kernel at lambda = 0 (no V* iteration; the result
    equals the general path's field by field).
"""

from __future__ import annotations

import cmath
import math
from dataclasses import dataclass, field
from typing import Any, Iterable, Sequence

import numpy as np

from glocal_verify.derived import Kind
from glocal_verify.errors import NotApplicableError
from glocal_verify.model import System
from glocal_verify.numerics.balancing import block_norm
from glocal_verify.numerics.pencil import (
    PencilAnalysis,
    cluster_points as _cluster,
    analyze_pencil,
    direction_at,
    pencil_matrix,
)
from glocal_verify.numerics.tolerance import DEFAULT_TOLERANCE, Decision, Tolerance
from glocal_verify.results import GROWTH_DECAYING, GROWTH_PERSISTENT, GROWTH_UNBOUNDED, GROWTH_UNDECIDED, growth_of_sign
from glocal_verify.spec.types import Label

__all__ = [
    "ZdaZero",
    "ZdaDirection",
    "ZdaAnalysis",
    "zda_analysis",
    "ModalPencil",
    "normalize_direction",
    "growth_class",
    "GROWTH_UNBOUNDED",
    "GROWTH_PERSISTENT",
    "GROWTH_DECAYING",
    "GROWTH_UNDECIDED",
]

#: derived results this module keeps on the system (glocal_verify.derived)
_ZDA_KIND: Kind[ZdaAnalysis] = Kind("zda", __name__, "ZdaAnalysis")

#: the growth classes of a zero-dynamics attack by Re(lambda0) are those of
#: :mod:`glocal_verify.results` (``GROWTH_*``, :func:`~glocal_verify.results.growth_of_sign`), named here too

# ------------------------------------------------------------------------------------------
# records


@dataclass(frozen=True, slots=True)
class ZdaDirection:
    """A stealthy ZDA: u_a(t) = u0 exp(lambda0 t) from x~(0) = x0 keeps C x~ = 0.

    Attributes
    ----------
    lambda0 : complex
        The exponent.
    xi : ndarray
        Position part of the direction (length N, ordered like ``System.labels``), scaled so
        that its largest entry is 1.
    u0 : ndarray
        Attack input amplitudes, ordered like ``system.attacked`` (or the actuators asked for).
    x0 : ndarray
        The initial state [xi; lambda0 xi] in R^{2N} / C^{2N}.
    residual : float
        Verification residual on the full pencil (see the module docstring); 0 for exact
        directions at rational lambda0.
    """

    lambda0: complex
    xi: np.ndarray
    u0: np.ndarray
    x0: np.ndarray
    residual: float = 0.0


@dataclass(frozen=True, slots=True)
class ZdaZero:
    """A verified finite zero of the 2N pencil with its direction (numeric).

    Attributes
    ----------
    value : complex
        lambda0.
    s : complex
        lambda0^2 + gamma lambda0.
    xi, u0 : ndarray
        Direction (xi scaled to max |xi_k| = 1).
    residual : float
        Verification residual on the full pencil.
    growth : str
        ``unbounded`` (Re > 0), ``persistent`` (Re = 0), ``decaying`` (Re < 0) or
        ``undecided`` (Re in the tolerance band), Re decided against ``rtol * ||A||``.
    multiplicity : int
        Multiplicity carried over from the zero in s.
    attack : bool
        True when u0 != 0 (a stealthy ZDA); False for an unobservable mode.
    """

    value: complex
    s: complex
    xi: np.ndarray
    u0: np.ndarray
    residual: float
    growth: str
    multiplicity: int = 1
    attack: bool = True

    def direction(self) -> ZdaDirection:
        """This zero as a :class:`ZdaDirection`."""
        return ZdaDirection(self.value, self.xi, self.u0, np.concatenate([self.xi, self.value * self.xi]), self.residual)


@dataclass(frozen=True, slots=True)
class ZdaAnalysis:
    """Stealthy ZDAs of (A_1, B, C, 0) for an actuator set (numeric).

    Attributes
    ----------
    actuators : tuple of labels
        F.
    left_invertible : bool
        Full normal column rank of the 2N pencil.
    normal_rank : int
        Normal rank of the 2N pencil (N + nrank Q).
    normal_kernel_dim : int
        2N + m - normal_rank: dimension of the zeroing directions at a generic lambda.
    zeros : tuple of ZdaZero
        Verified zeros with u0 != 0, fastest growing first.
    unobservable : tuple of ZdaZero
        Verified zeros whose directions all have u0 = 0 (unobservable modes; not attacks).
    direction : ZdaZero or None
        The stealthy ZDA reported as witness (see :func:`zda_analysis`).
    direction_source : str
        Why that direction was chosen.
    decided : bool
        False when a rank, zero or input decision fell in the undecided band.
    tolerance : float
        ``rtol`` used.
    method : str
        ``structured`` or ``dense``.
    notes : tuple of str
        Reasons for undecided parts, rejected candidates, ...
    """

    actuators: tuple[Label, ...]
    left_invertible: bool
    normal_rank: int
    normal_kernel_dim: int
    zeros: tuple[ZdaZero, ...]
    unobservable: tuple[ZdaZero, ...]
    direction: ZdaZero | None
    direction_source: str
    decided: bool
    tolerance: float
    method: str
    notes: tuple[str, ...] = field(default_factory=tuple)

    @property
    def exists(self) -> bool:
        """A verified stealthy ZDA is available."""
        return self.direction is not None


# ------------------------------------------------------------------------------------------
# helpers shared by the paths


def _actuators(system: System, actuators: Iterable[Label] | None) -> tuple[Label, ...]:
    F = tuple(actuators) if actuators is not None else system.attacked
    if not F:
        raise NotApplicableError("a zero-dynamics attack needs attacked actuators (attack.actuators)")
    system.idx(F)  # validates the labels
    if len(set(F)) != len(F):
        raise NotApplicableError(f"attacked actuators listed twice: {list(F)}")
    return F


def requested_lambda0(system: System, lambda0: complex | float | Sequence[float] | None = None) -> complex | None:
    """The requested exponent: ``lambda0`` when given (a number or ``[re, im]``), else the spec's ``attack.lambda0``."""
    if lambda0 is None:
        return system.spec.attack.lambda0 if system.spec.attack is not None else None
    if isinstance(lambda0, (list, tuple)):
        return complex(float(lambda0[0]), float(lambda0[1]))
    return complex(lambda0)  # type: ignore[arg-type]


def growth_class(lam: complex, scale: float, tol: Tolerance) -> str:
    """The growth class of a computed zero: Re lambda decided against ``scale`` at ``tol`` (undecided in the band)."""
    d = tol.decide(lam.real, scale)
    if d is Decision.UNDECIDED:
        return GROWTH_UNDECIDED
    return growth_of_sign(0 if d is Decision.ZERO else 1 if lam.real > 0 else -1)


def normalize_direction(xi: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(xi, u) / xi_k with k the largest entry of xi; real when the imaginary parts are below
    1e-14 of the largest entry."""
    k = int(np.argmax(np.abs(xi)))
    c = xi[k]
    if c == 0:
        return xi, u
    if not np.iscomplexobj(xi):
        return xi / c, u / c
    v = np.concatenate([xi, u]) / c
    if np.iscomplexobj(v):
        big = float(np.abs(v).max())
        if float(np.abs(v.imag).max()) <= 1e-14 * big:
            v = v.real.copy()
    return v[: len(xi)], v[len(xi) :]


# ------------------------------------------------------------------------------------------
# structured numeric path


class ModalPencil:
    """Modal data of the normal mode for one actuator set."""

    def __init__(self, system: System, F: tuple[Label, ...], tol: Tolerance) -> None:
        self.system = system
        self.tol = tol
        self.N = system.n
        self.alpha, self.gamma = system.alpha, system.gamma
        self.sp = system.spectrum()
        self.mu = np.asarray(self.sp.values)
        self.F = system.idx(F)
        self.M = system.idx(system.monitored)
        self.Mx = system.idx(system.monitored_positions)
        self.Mv = system.idx(system.monitored_velocities)
        self.L = system.laplacian_sparse()
        # the rows of U every kernel and screen reads (copied once, not per candidate; computed
        # through the factors when the spectrum is kept factored, never the whole basis)
        self.UF, self.UM, self.UMx, self.UMv = (self.sp.rows(idx) for idx in (self.F, self.M, self.Mx, self.Mv))
        self.mu_scale = max(self.alpha * float(np.max(np.abs(self.mu), initial=0.0)), 1.0)
        # ||A||_2 bound used for growth decisions and lambda ~ 0 decisions
        self.A_scale = float(self._blocks_norm(0.0))

    @property
    def U(self) -> np.ndarray:
        """The whole eigenvector matrix (formed on first use for a factored spectrum: the audit's batched forms read it)."""
        return np.asarray(self.sp.vectors)

    def _blocks_norm(self, lam: complex) -> float:
        """||lam I - A||_2 from the 2 x 2 modal blocks [[lam, -1], [alpha mu, lam + gamma]].

        sigma_max^2 = (f + sqrt(f^2 - 4 |det|^2)) / 2 with f the squared Frobenius norm.
        """
        if len(self.mu) == 0:
            return 1.0
        a, b = lam, -1.0
        c, d = self.alpha * self.mu, lam + self.gamma
        f = abs(a) ** 2 + abs(b) ** 2 + np.abs(c) ** 2 + abs(d) ** 2
        det = np.abs(a * d - b * c) ** 2
        s2 = (f + np.sqrt(np.maximum(f * f - 4.0 * det, 0.0))) / 2.0
        return float(np.sqrt(np.max(s2)))

    def pencil_norm_lb(self, lam: complex) -> float:
        return max(self._blocks_norm(lam), 1.0)

    def s_pencil(self) -> PencilAnalysis:
        """The N-sized pencil [s I + alpha diag(mu), -U_F^T; U_M, 0] (candidates for its zeros).

        Deflated without balancing: the state matrix is diagonal and U_F^T, U_M are rows of an
        orthogonal matrix, already the scaling a balancing aims at. A power-of-two balancing
        reads every nonzero, the rounding noise of localised eigenvectors included: on weakly
        coupled clusters (N = 4000) it scaled states by up to 2^47 and lifted the data norm
        from ~alpha max mu to ~1e14, so that the relative rank decisions of the deflation
        discarded whole output blocks and reported a normal rank below N + m.
        """
        As = np.diag(-self.alpha * self.mu)
        B, C = self.UF.T, self.UM
        # decision scale: the 2-norm of the block norms (||A|| = alpha max|mu| exactly, B and C thin),
        # an upper bound of ||[A B; C 0]||_2, at every N as above 600 agents (the exact norm would
        # be an SVD of the whole (N + p) x (N + m) matrix per set)
        scale = block_norm(self.alpha * float(np.max(np.abs(self.mu), initial=0.0)), B, C, np.zeros((C.shape[0], B.shape[1])))
        return analyze_pencil(As, B, C, tol=self.tol, verify=False, balance=False, scale=scale if scale > 0.0 else None)

    def kernel(self, lam: complex, near_band: bool = False) -> tuple[list[tuple[np.ndarray, np.ndarray]], int, int]:
        """Candidate kernel vectors (eta, u) of Q_lam(s), with the kernel dimension bounds.

        Modes with s + alpha mu_k zero at the tolerance (``near_band``: or undecided) are kept
        as unknowns (their row reads U_F^T u = 0); the others are eliminated exactly,
        eta_k = (U_F^T u)_k / (s + alpha mu_k). The reduced matrix K is decided against
        max(1, max_far 1 / |s + alpha mu_k|), a bound of ||K|| that does not shrink with K.
        Candidates: the largest-input vector of the certain kernel, of the possible kernel,
        and the last right singular vector. Returns (candidates, dim_lo, dim_hi): dim_lo
        counts the singular values that are certainly zero, dim_hi those not certainly
        nonzero.
        """
        s = lam * lam + self.gamma * lam
        rows_out = self.Mx if lam == 0 else self.M
        # a real exponent keeps the reduced matrix real (the batched form,
        # glocal_verify.analysis.stealthy.zda_batch, decomposes the same real matrices)
        dtype = float if complex(lam).imag == 0 else complex
        d: np.ndarray = s + self.alpha * self.mu
        if dtype is float:
            d = d.real
        ratio = np.abs(d) / self.mu_scale  # Tolerance.decide, vectorised
        near_mask = ratio <= (self.tol.upper if near_band else self.tol.rtol)
        J = np.flatnonzero(near_mask)
        far = np.flatnonzero(~near_mask)
        m, p, nJ = len(self.F), len(rows_out), len(J)
        UF = self.UF
        UO = self.UMx if lam == 0 else self.UM
        Gf = (UO[:, far] / d[far]) @ UF[:, far].T if len(far) else np.zeros((p, m), dtype=dtype)
        K = np.zeros((nJ + p, nJ + m), dtype=dtype)
        K[:nJ, nJ:] = UF[:, J].T
        K[nJ:, :nJ] = UO[:, J]
        K[nJ:, nJ:] = Gf
        ncols = nJ + m
        bases: list[np.ndarray] = []
        if K.shape[0] == 0:
            bases.append(np.eye(ncols, dtype=dtype))
            lo = hi = ncols
        else:
            s1 = max(1.0, float(np.max(1.0 / np.abs(d[far]), initial=0.0)))
            _, sv, Vh = np.linalg.svd(K, full_matrices=True)
            sv = np.concatenate([sv, np.zeros(ncols - len(sv))])
            cert = int(np.sum(sv > self.tol.upper * s1))
            notzero = int(np.sum(sv > self.tol.rtol * s1))
            lo, hi = ncols - notzero, ncols - cert
            if notzero < ncols:
                bases.append(Vh[notzero:].conj().T)
            if cert < notzero:
                bases.append(Vh[cert:].conj().T)
            bases.append(Vh[-1:].conj().T)
        cands: list[tuple[np.ndarray, np.ndarray]] = []
        for kb in bases:
            if m and kb.shape[1] > 1:
                _, _, Wh = np.linalg.svd(kb[nJ:], full_matrices=True)
                v = kb @ Wh[0].conj()
            else:
                v = kb[:, 0]
            eta = np.zeros(self.N, dtype=complex)
            u = v[nJ:]
            eta[J] = v[:nJ]
            if len(far):
                eta[far] = (UF[:, far].T @ u) / d[far]
            cands.append((eta, u))
        return cands, lo, hi

    def _screen(self, lam: complex, eta: np.ndarray, u: np.ndarray) -> tuple[Decision, Decision, float] | None:
        """:meth:`verify`'s two decisions from modal coordinates in O(N (m + p)), or None when unsure.

        With xi = U eta, L U = U diag(mu) + R and U^T U = I + E (||E||_F <= eta_U):
        ||r_dyn|| differs from ||(s + alpha mu) eta - U_F^T u|| by at most
        eta_U (||.|| + ||u||) + alpha ||R||_F ||eta||, the outputs xi[M] = U[M, :] eta are
        formed directly, and ||xi|| = ||eta|| up to a factor sqrt(1 +- eta_U). A decision is
        returned only when both ends of the resulting interval decide alike; the caller then
        verifies the chosen vector on the full pencil anyway.
        """
        sp = self.system.spectrum()
        ortho = sp.orthogonality_error
        if not ortho < 0.5:
            return None
        s = lam * lam + self.gamma * lam
        r_m = (s + self.alpha * self.mu) * eta - self.UF.T @ u
        out = np.concatenate([self.UMx @ eta, lam * (self.UMv @ eta)])
        e_n, u_n, rm_n = float(np.linalg.norm(eta)), float(np.linalg.norm(u)), float(np.linalg.norm(r_m))
        num = math.hypot(rm_n, float(np.linalg.norm(out)))
        vnorm = math.sqrt((1.0 + abs(lam) ** 2) * e_n**2 + u_n**2)
        if vnorm == 0.0:
            return None
        r_fro = sp.residual_frobenius
        # the rows of a factored basis are computed: their typical entry error (a screen, not a proof)
        rows_err = sp.entry_estimate * (math.sqrt(self.N) * float(np.sum(np.abs(u))) + math.sqrt(len(self.M)) * (1.0 + abs(lam)) * float(np.sum(np.abs(eta))))
        err_num = ortho * (rm_n + u_n) + self.alpha * r_fro * e_n + 1e-14 * (num + vnorm) + rows_err
        pnl = self.pencil_norm_lb(lam)
        lo = max(0.0, num - err_num) / (pnl * vnorm * math.sqrt(1.0 + ortho))
        hi = (num + err_num) / (pnl * vnorm * math.sqrt(max(1.0 - ortho, 1e-300)))
        dres = self.tol.decide(lo, 1.0)
        if self.tol.decide(hi, 1.0) is not dres:
            return None
        v_lo = math.sqrt((1.0 + abs(lam) ** 2) * e_n**2 * (1.0 - ortho) + u_n**2)
        v_hi = math.sqrt((1.0 + abs(lam) ** 2) * e_n**2 * (1.0 + ortho) + u_n**2)
        du = self.tol.decide(u_n, v_hi)
        if self.tol.decide(u_n, v_lo) is not du:
            return None
        return dres, du, u_n / max(e_n, 1e-300)

    def direction(self, lam: complex) -> tuple[tuple[np.ndarray, np.ndarray, float, Decision, Decision] | None, Decision, int, int]:
        """The verified kernel vector with the largest input part at ``lam``.

        Returns ((xi, u, residual, residual decision, input decision) or None, best residual
        decision seen, dim_lo, dim_hi) -- the dimension bounds of the pass that keeps only
        the modes with s + alpha mu_k certainly zero.

        The candidates are screened in modal coordinates (:meth:`_screen`, O(N (m + p)) each
        instead of two O(N^2) products) and only the chosen one is verified on the full
        pencil; when a screen is unsure, or the full verification of the chosen vector does
        not confirm its screened decisions, every candidate is verified in full
        (:meth:`_direction_full`), so the result is the full method's.
        """
        picked = self._select(lam, screened=True)
        if picked is None:
            return self._direction_full(lam)
        best, best_dec, lo, hi = picked
        if best is None:
            return None, best_dec, lo, hi
        eta, u, _, dres_s, du_s = best
        xi, u2, res, dres, du = self.verify(lam, eta, u)
        if dres is not dres_s or du is not du_s:
            return self._direction_full(lam)
        return (xi, u2, res, dres, du), best_dec, lo, hi

    def _direction_full(self, lam: complex) -> tuple[tuple[np.ndarray, np.ndarray, float, Decision, Decision] | None, Decision, int, int]:
        """:meth:`direction` with every candidate verified on the full pencil (the reference)."""
        picked = self._select(lam, screened=False)
        assert picked is not None
        best, best_dec, lo, hi = picked
        if best is None:
            return None, best_dec, lo, hi
        eta, u, _, _, _ = best
        return self.verify(lam, eta, u), best_dec, lo, hi

    def _select(self, lam: complex, screened: bool) -> tuple[Any, Decision, int, int] | None:
        """The candidate (eta, u, input fraction, residual decision, input decision) with the
        largest input part among those whose residual is zero; None when a screen is unsure."""
        best: tuple[np.ndarray, np.ndarray, float, Decision, Decision] | None = None
        best_dec = Decision.NONZERO
        lo = hi = 0
        for near_band in (False, True):
            cands, lo_, hi_ = self.kernel(lam, near_band)
            if not near_band:
                lo, hi = lo_, hi_
            for eta, u in cands:
                if screened:
                    sc = self._screen(lam, eta, u)
                    if sc is None:
                        return None
                    dres, du, frac = sc
                else:
                    xi, u2, _, dres, du = self.verify(lam, eta, u)
                    frac = float(np.linalg.norm(u2)) / max(float(np.linalg.norm(xi)), 1e-300)
                if dres is Decision.ZERO:
                    best_dec = Decision.ZERO
                    if best is None or frac > best[2]:
                        best = (eta, u, frac, dres, du)
                    if du is Decision.NONZERO:
                        break  # the first candidate is the largest-input vector of the certain kernel
                elif dres is Decision.UNDECIDED and best_dec is Decision.NONZERO:
                    best_dec = Decision.UNDECIDED
            if best is not None:
                break
        return best, best_dec, lo, hi

    def verify(self, lam: complex, eta: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray, float, Decision, Decision]:
        """Map (eta, u) to (xi, u), residual on the full 2N pencil and the two decisions."""
        xi = self.sp.apply(eta[:, None])[:, 0]  # real and imaginary parts apart: no complex copy of U
        s = lam * lam + self.gamma * lam
        Fsel = np.zeros(self.N, dtype=complex)
        Fsel[self.F] = u
        r_dyn = s * xi + self.alpha * (self.L @ xi) - Fsel
        r_out = np.concatenate([xi[self.Mx], lam * xi[self.Mv]])
        num = math.sqrt(float(np.linalg.norm(r_dyn)) ** 2 + float(np.linalg.norm(r_out)) ** 2)
        vnorm = math.sqrt((1.0 + abs(lam) ** 2) * float(np.linalg.norm(xi)) ** 2 + float(np.linalg.norm(u)) ** 2)
        if vnorm == 0.0:
            return xi, u, 1.0, Decision.NONZERO, Decision.ZERO
        res = num / (self.pencil_norm_lb(lam) * vnorm)
        return xi, u, res, self.tol.decide(res, 1.0), self.tol.decide(float(np.linalg.norm(u)), vnorm)


def zda_analysis(
    system: System,
    tol: Tolerance = DEFAULT_TOLERANCE,
    actuators: Iterable[Label] | None = None,
    *,
    lambda0: complex | float | Sequence[float] | None = None,
    method: str = "structured",
) -> ZdaAnalysis:
    """Stealthy zero-dynamics attacks of the normal mode (Proposition II.4 (ii), eq. ``zda_cond``).

    .. math::

        \\begin{bmatrix} \\lambda_0 I - A_1 & -B \\\\ C & 0 \\end{bmatrix}
        \\begin{bmatrix} \\tilde x_0 \\\\ u_0 \\end{bmatrix} = 0,\\qquad u_0 \\neq 0

    Parameters
    ----------
    system : System
        The multi-agent system (normal mode).
    tol : Tolerance
        Rank decisions of the N-sized pencil against ``||[A_s B_s; C_s 0]||_2``; verification
        residuals of the full pencil and input parts (see the module docstring).
    actuators : iterable of labels, optional
        F; default the spec's ``attack.actuators``.
    lambda0 : complex, float or [re, im], optional
        The exponent the witness direction should use; default the spec's
        ``attack.lambda0``.
    method : {"structured", "dense"}
        Structured modal path (default) or the generic dense pencil on (A_1, B, C).

    Returns
    -------
    ZdaAnalysis
        The witness direction is: at ``lambda0`` if a stealthy ZDA exists there; else the
        fastest-growing zero with u0 != 0; but when the system is not left-invertible and no
        zero is unbounded, the direction at lambda0 = 1 (an unstable ZDA exists at every
        lambda0 but finitely many).

    Raises
    ------
    NotApplicableError
        Without attacked actuators; ModelError for unknown labels.
    """
    F = _actuators(system, actuators)
    lam_req = requested_lambda0(system, lambda0)
    if method not in ("structured", "dense"):
        raise NotApplicableError(f"unknown ZDA method {method!r} (expected 'structured' or 'dense')")
    return _ZDA_KIND.get(
        system, (tol, F, lam_req, method), lambda: _structured(system, F, tol, lam_req) if method == "structured" else _dense(system, F, tol, lam_req)
    )


def _pick(
    zeros: list[ZdaZero],
    left_inv: bool,
    lam_req: complex | None,
    at: Any,
) -> tuple[ZdaZero | None, str, list[str]]:
    notes: list[str] = []
    if lam_req is not None:
        z = at(lam_req)
        if z is not None:
            return z, "requested lambda0", notes
        notes.append(f"no stealthy ZDA at the requested lambda0 = {lam_req}")
    best = max(zeros, key=lambda z: z.value.real) if zeros else None
    if not left_inv and (best is None or best.growth != GROWTH_UNBOUNDED):
        z = at(1.0 + 0j)
        if z is not None:
            return z, "lambda0 = 1 (not left-invertible: a ZDA exists at every lambda0)", notes
    if best is not None:
        return best, "fastest-growing zero", notes
    return None, "none", notes


def _structured(system: System, F: tuple[Label, ...], tol: Tolerance, lam_req: complex | None) -> ZdaAnalysis:
    md = ModalPencil(system, F, tol)
    N, m = md.N, len(F)
    pa = md.s_pencil()
    decided = pa.decided
    notes = list(pa.notes)
    k0 = N + m - pa.normal_rank
    left_inv = pa.full_normal_column_rank
    # lambda candidates from the zeros in s
    cands: list[tuple[complex, int]] = []
    for z in pa.zeros:
        s = z.value
        sq = cmath.sqrt(md.gamma**2 + 4 * s)
        roots = [(-md.gamma + sq) / 2, (-md.gamma - sq) / 2]
        if tol.decide(abs(sq), md.A_scale) is Decision.ZERO:
            roots = [-md.gamma / 2 + 0j]
        for lam in roots:
            d0 = tol.decide(abs(lam), md.A_scale)
            if d0 is Decision.ZERO:
                continue  # lambda = 0 is decided on Q_0 below
            cands.append((complex(lam), z.multiplicity * (2 if len(roots) == 1 else 1)))
    clusters = _cluster([c[0] for c in cands], math.sqrt(tol.upper) * md.A_scale)

    def build(lam: complex, mult: int, rank_drop: bool = False) -> tuple[ZdaZero | None, Decision, Decision]:
        # rank_drop: lam must be a zero, i.e. dim ker Q > k0. When the pencil is left-invertible
        # (k0 = 0) a verified kernel vector proves it; otherwise a kernel vector exists at every
        # lam and the dimension of the reduced kernel decides.
        found, dres, lo, hi = md.direction(lam)
        if rank_drop and k0 > 0:
            if hi <= k0:
                return None, Decision.NONZERO, Decision.ZERO
            if lo <= k0:
                return None, Decision.UNDECIDED, Decision.ZERO
        if found is None:
            return None, dres, Decision.ZERO
        xi, u, res, _, du = found
        xi_n, u_n = normalize_direction(xi, u)
        zz = ZdaZero(lam, lam * lam + md.gamma * lam, xi_n, u_n, res, growth_class(lam, md.A_scale, tol), mult, du is Decision.NONZERO)
        return zz, Decision.ZERO, du

    attack: list[ZdaZero] = []
    unobs: list[ZdaZero] = []
    for c in clusters:
        # a cluster of close candidates: first as one multiple zero (their mean), else one by one
        trials: list[list[tuple[complex, int]]] = []
        if len(c) > 1:
            trials.append([(complex(np.mean([cands[i][0] for i in c])), sum(cands[i][1] for i in c))])
        trials.append([cands[i] for i in c])
        for t_idx, trial in enumerate(trials):
            built = [(lam, mult, *build(lam, mult, rank_drop=True)) for lam, mult in trial]
            if t_idx + 1 < len(trials) and any(b[2] is None for b in built):
                continue
            for lam, mult, zz, dres, du in built:
                if zz is None:
                    decided = False
                    notes.append(f"candidate zero {lam:.6g} failed verification on the full pencil ({dres.value})")
                    continue
                if du is Decision.UNDECIDED:
                    decided = False
                    notes.append(f"zero {lam:.6g}: input part undecided")
                (attack if zz.attack else unobs).append(zz)
            break
    # lambda = 0: dim ker Q_0 against the normal kernel dimension
    found0, dres0, lo0, hi0 = md.direction(0j)
    if hi0 > k0:
        if lo0 <= k0:
            decided = False
            notes.append("whether lambda = 0 is a zero is undecided")
        elif found0 is not None:
            xi, u, res, _, du = found0
            xi_n, u_n = normalize_direction(xi, u)
            zz0 = ZdaZero(0j, 0j, xi_n, u_n, res, GROWTH_PERSISTENT, lo0 - k0, du is Decision.NONZERO)
            (attack if zz0.attack else unobs).append(zz0)
            if du is Decision.UNDECIDED:
                decided = False
                notes.append("zero 0: input part undecided")
        else:
            decided = False
            notes.append(f"zero 0 failed verification ({dres0.value})")
    attack.sort(key=lambda z: (-z.value.real, -abs(z.value.imag)))
    unobs.sort(key=lambda z: (-z.value.real, -abs(z.value.imag)))

    def at(lam: complex) -> ZdaZero | None:
        lam = complex(lam)
        zz, _, du = build(lam, 1)
        if zz is None or du is not Decision.NONZERO:
            return None
        return zz

    direction, source, more = _pick(attack, left_inv, lam_req, at)
    notes += more
    return ZdaAnalysis(
        F, left_inv, N + pa.normal_rank, k0, tuple(attack), tuple(unobs), direction, source, decided, tol.rtol, "structured", tuple(notes)
    )


def _dense(system: System, F: tuple[Label, ...], tol: Tolerance, lam_req: complex | None) -> ZdaAnalysis:
    N = system.n
    A, B, C = system.A(), system.B(F), system.C()
    pa = analyze_pencil(A, B, C, tol=tol)
    a_scale = float(np.linalg.norm(A, 2)) if A.size else 1.0
    decided = pa.decided
    notes = list(pa.notes)
    attack: list[ZdaZero] = []
    unobs: list[ZdaZero] = []

    def make(lam: complex, x: np.ndarray, u: np.ndarray, res: float, mult: int) -> ZdaZero | None:
        nonlocal decided
        du = tol.decide(float(np.linalg.norm(u)), float(np.linalg.norm(np.concatenate([x, u]))))
        if du is Decision.UNDECIDED:
            decided = False
            notes.append(f"zero {lam:.6g}: input part undecided")
        xi_n, u_n = normalize_direction(x[:N].astype(complex), u.astype(complex))
        return ZdaZero(lam, lam * lam + system.gamma * lam, xi_n, u_n, res, growth_class(lam, a_scale, tol), mult, du is Decision.NONZERO)

    for z in pa.zeros:
        if not z.verified:
            continue
        zz = make(z.value, z.x, z.u, z.residual, z.multiplicity)
        if zz is not None:
            (attack if zz.attack else unobs).append(zz)

    def at(lam: complex) -> ZdaZero | None:
        d = direction_at(A, B, C, None, lam, tol)
        if d is None:
            return None
        x, u = d
        P = pencil_matrix(A, B, C, None, lam)
        v = np.concatenate([x, u])
        res = float(np.linalg.norm(P @ v) / (np.linalg.norm(P, 2) * np.linalg.norm(v)))
        if tol.decide(float(np.linalg.norm(u)), 1.0) is not Decision.NONZERO:
            return None
        return make(complex(lam), x, u, res, 1)

    direction, source, more = _pick(attack, pa.full_normal_column_rank, lam_req, at)
    notes += more
    k0 = 2 * N + len(F) - pa.normal_rank
    return ZdaAnalysis(
        F, pa.full_normal_column_rank, pa.normal_rank, k0, tuple(attack), tuple(unobs), direction, source, decided, tol.rtol, "dense", tuple(notes)
    )
