"""Stealthy attacks of Proposition II.4 (``propo:stealthy_attacks``): ZDA and covert attacks.

Zero-dynamics attacks (Definition II.2, eq. ``zda_cond``)
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
    N-state system (-alpha diag(mu), U_F^T, U_M, 0); :func:`glocal_verify.pencil.analyze_pencil`
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
    :func:`glocal_verify.pencil.analyze_pencil` on the 2N-sized (A_1, B, C): for small systems
    and for the tests that compare the two.

Exact path (:func:`zda_analysis_exact`)
    The N-sized pencil in s over Q (:func:`glocal_verify.pencil.analyze_pencil_exact`) gives
    left-invertibility and the zero polynomial z(s); the lambda-zeros are the roots of
    z(lambda^2 + gamma lambda) factored over Q, and for each irreducible factor g the kernel
    of Q(lambda^2 + gamma lambda) is computed exactly in Q[lambda]/(g), which decides whether
    an input direction exists and gives the direction.

Covert attacks (eqs. ``ym_solution``-``covert_trajec_post``)
    u_s = C x~ cancels u_a iff the attacker owns every monitored channel that u_a reaches;
    see :func:`covert_required_channels`.
"""

from __future__ import annotations

import cmath
import math
import weakref
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any, Iterable, Sequence

import flint
import numpy as np
import scipy.sparse

from . import pencil as pn
from .errors import NotApplicableError
from .linalg import DEFAULT_TOLERANCE, Decision, Tolerance
from .model import System
from .registry import CheckContext, checker, finding_rule, result
from .results import ConditionResult, Finding, Status
from .spec import Label

__all__ = [
    "ZdaZero",
    "ZdaDirection",
    "ZdaAnalysis",
    "ExactZdaZero",
    "ExactZdaAnalysis",
    "zda_analysis",
    "zda_direction",
    "zda_analysis_exact",
    "covert_required_channels",
    "reachable_agents",
    "check_zda",
    "check_covert",
    "unobservable_zeros_finding",
    "covert_sensors_finding",
]

GROWTH_UNBOUNDED = "unbounded"
GROWTH_PERSISTENT = "persistent"
GROWTH_DECAYING = "decaying"
GROWTH_UNDECIDED = "undecided"


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


def _lambda_request(system: System, lambda0: complex | float | Sequence[float] | None) -> complex | None:
    if lambda0 is None:
        return system.spec.attack.lambda0 if system.spec.attack is not None else None
    if isinstance(lambda0, (list, tuple)):
        return complex(float(lambda0[0]), float(lambda0[1]))
    return complex(lambda0)  # type: ignore[arg-type]


def _growth(lam: complex, scale: float, tol: Tolerance) -> str:
    d = tol.decide(lam.real, scale)
    if d is Decision.ZERO:
        return GROWTH_PERSISTENT
    if d is Decision.UNDECIDED:
        return GROWTH_UNDECIDED
    return GROWTH_UNBOUNDED if lam.real > 0 else GROWTH_DECAYING


def _normalize(xi: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    k = int(np.argmax(np.abs(xi)))
    c = xi[k]
    if c == 0:
        return xi, u
    xi, u = xi / c, u / c
    big = max(float(np.max(np.abs(xi))), float(np.max(np.abs(u), initial=0.0)))
    if np.iscomplexobj(xi) and float(np.max(np.abs(xi.imag), initial=0.0)) <= 1e-14 * big and float(np.max(np.abs(u.imag), initial=0.0)) <= 1e-14 * big:
        xi, u = xi.real.copy(), u.real.copy()
    return xi, u


# ------------------------------------------------------------------------------------------
# structured numeric path


class _Modal:
    """Modal data of the normal mode for one actuator set."""

    def __init__(self, system: System, F: tuple[Label, ...], tol: Tolerance) -> None:
        self.system = system
        self.tol = tol
        self.N = system.n
        self.alpha, self.gamma = system.alpha, system.gamma
        w, U = system.eigh()
        self.mu = np.asarray(w)
        self.U = np.asarray(U)
        self.F = system.idx(F)
        self.M = system.idx(system.monitored)
        self.Mx = system.idx(system.monitored_positions)
        self.Mv = system.idx(system.monitored_velocities)
        self.L = scipy.sparse.csr_matrix(system.laplacian())
        self.mu_scale = max(self.alpha * float(np.max(np.abs(self.mu), initial=0.0)), 1.0)
        # ||A||_2 bound used for growth decisions and lambda ~ 0 decisions
        self.A_scale = float(self._blocks_norm(0.0))

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

    def s_pencil(self) -> pn.PencilAnalysis:
        As = np.diag(-self.alpha * self.mu)
        Bs = self.U[self.F, :].T
        Cs = self.U[self.M, :]
        return pn.analyze_pencil(As, Bs, Cs, tol=self.tol, verify=False)

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
        d = s + self.alpha * self.mu
        ratio = np.abs(d) / self.mu_scale  # Tolerance.decide, vectorised
        near_mask = ratio <= (self.tol.upper if near_band else self.tol.rtol)
        J = np.flatnonzero(near_mask)
        far = np.flatnonzero(~near_mask)
        m, p, nJ = len(self.F), len(rows_out), len(J)
        UF = self.U[self.F, :]
        UO = self.U[rows_out, :]
        Gf = (UO[:, far] / d[far]) @ UF[:, far].T if len(far) else np.zeros((p, m), dtype=complex)
        K = np.zeros((nJ + p, nJ + m), dtype=complex)
        K[:nJ, nJ:] = UF[:, J].T
        K[nJ:, :nJ] = UO[:, J]
        K[nJ:, nJ:] = Gf
        ncols = nJ + m
        bases: list[np.ndarray] = []
        if K.shape[0] == 0:
            bases.append(np.eye(ncols, dtype=complex))
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

    def direction(self, lam: complex) -> tuple[tuple[np.ndarray, np.ndarray, float, Decision, Decision] | None, Decision, int, int]:
        """The verified kernel vector with the largest input part at ``lam``.

        Returns ((xi, u, residual, residual decision, input decision) or None, best residual
        decision seen, dim_lo, dim_hi) -- the dimension bounds of the pass that keeps only
        the modes with s + alpha mu_k certainly zero.
        """
        best: tuple[np.ndarray, np.ndarray, float, Decision, Decision] | None = None
        best_dec = Decision.NONZERO
        lo = hi = 0
        for near_band in (False, True):
            cands, lo_, hi_ = self.kernel(lam, near_band)
            if not near_band:
                lo, hi = lo_, hi_
            for eta, u in cands:
                xi, u2, res, dres, du = self.verify(lam, eta, u)
                if dres is Decision.ZERO:
                    best_dec = Decision.ZERO
                    frac = float(np.linalg.norm(u2)) / max(float(np.linalg.norm(xi)), 1e-300)
                    if best is None or frac > float(np.linalg.norm(best[1])) / max(float(np.linalg.norm(best[0])), 1e-300):
                        best = (xi, u2, res, dres, du)
                    if du is Decision.NONZERO:
                        break  # the first candidate is the largest-input vector of the certain kernel
                elif dres is Decision.UNDECIDED and best_dec is Decision.NONZERO:
                    best_dec = Decision.UNDECIDED
            if best is not None:
                break
        return best, best_dec, lo, hi

    def verify(self, lam: complex, eta: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray, float, Decision, Decision]:
        """Map (eta, u) to (xi, u), residual on the full 2N pencil and the two decisions."""
        xi = self.U @ eta.real + 1j * (self.U @ eta.imag)  # avoids a complex copy of U
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


_CACHE: "weakref.WeakKeyDictionary[System, dict[Any, ZdaAnalysis]]" = weakref.WeakKeyDictionary()


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
    lam_req = _lambda_request(system, lambda0)
    if method not in ("structured", "dense"):
        raise NotApplicableError(f"unknown ZDA method {method!r} (expected 'structured' or 'dense')")
    key = (tol, F, lam_req, method)
    per = _CACHE.setdefault(system, {})
    if key in per:
        return per[key]
    out = _structured(system, F, tol, lam_req) if method == "structured" else _dense(system, F, tol, lam_req)
    per[key] = out
    return out


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
    md = _Modal(system, F, tol)
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
    clusters = pn._cluster([c[0] for c in cands], math.sqrt(tol.upper) * md.A_scale)

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
        xi_n, u_n = _normalize(xi, u)
        zz = ZdaZero(lam, lam * lam + md.gamma * lam, xi_n, u_n, res, _growth(lam, md.A_scale, tol), mult, du is Decision.NONZERO)
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
            xi_n, u_n = _normalize(xi, u)
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
    pa = pn.analyze_pencil(A, B, C, tol=tol)
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
        xi_n, u_n = _normalize(x[:N].astype(complex), u.astype(complex))
        return ZdaZero(lam, lam * lam + system.gamma * lam, xi_n, u_n, res, _growth(lam, a_scale, tol), mult, du is Decision.NONZERO)

    for z in pa.zeros:
        if not z.verified:
            continue
        zz = make(z.value, z.x, z.u, z.residual, z.multiplicity)
        if zz is not None:
            (attack if zz.attack else unobs).append(zz)

    def at(lam: complex) -> ZdaZero | None:
        d = pn.direction_at(A, B, C, None, lam, tol)
        if d is None:
            return None
        x, u = d
        P = pn.pencil_matrix(A, B, C, None, lam)
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


def zda_direction(system: System, lambda0: complex | None = None, tol: Tolerance = DEFAULT_TOLERANCE) -> ZdaDirection | None:
    """The stealthy ZDA direction used as witness of ``stealthy.zda`` (structured numeric path).

    Parameters
    ----------
    system : System
        The system; its ``attack.actuators`` are F.
    lambda0 : complex, optional
        If given, the direction at exactly this exponent (None when no stealthy ZDA exists
        there). If omitted: the spec's ``attack.lambda0`` when a ZDA exists there, else the
        fastest-growing zero, else (not left-invertible) lambda0 = 1.
    tol : Tolerance
        Numeric tolerance.

    Returns
    -------
    ZdaDirection or None
        None when the system has no stealthy ZDA (at ``lambda0`` when given).
    """
    if lambda0 is not None:
        md = _Modal(system, _actuators(system, None), tol)
        lam = complex(lambda0)
        found, _, _, _ = md.direction(lam)
        if found is None or found[4] is not Decision.NONZERO:
            return None
        xi_n, u_n = _normalize(found[0], found[1])
        return ZdaDirection(lam, xi_n, u_n, np.concatenate([xi_n, lam * xi_n]), found[2])
    za = zda_analysis(system, tol)
    return za.direction.direction() if za.direction is not None else None


# ------------------------------------------------------------------------------------------
# exact path


@dataclass(frozen=True, slots=True)
class ExactZdaZero:
    """A zero (or the witness exponent) of the exact analysis.

    Attributes
    ----------
    value : complex
        lambda0 (exact when ``rational`` is set; else a certified approximation).
    rational : Fraction or None
        lambda0 when rational.
    factor : str
        Its minimal polynomial over Q (variable ``x`` = lambda).
    real_sign : int
        Exact sign of Re lambda0.
    attack : bool
        ker P(lambda0) holds a direction with u0 != 0 (decided in Q[x]/(factor)).
    xi, u0 : ndarray
        The exact kernel vector (over Q[x]/(factor)) evaluated at lambda0, xi scaled to
        max |xi_k| = 1.
    xi_field : tuple
        The same xi as ``fmpq_poly`` residues modulo ``field`` (exact; used by
        ``switching.safe``).
    field : fmpq_poly
        The minimal polynomial (``factor``) as a flint object.
    multiplicity : int
        Multiplicity in z(lambda^2 + gamma lambda) (1 for a requested exponent).
    """

    value: complex
    rational: Fraction | None
    factor: str
    real_sign: int
    attack: bool
    xi: np.ndarray
    u0: np.ndarray
    xi_field: tuple[Any, ...]
    field: Any
    multiplicity: int = 1

    @property
    def growth(self) -> str:
        """``unbounded`` / ``persistent`` / ``decaying`` from the exact sign of Re lambda0."""
        return {1: GROWTH_UNBOUNDED, 0: GROWTH_PERSISTENT, -1: GROWTH_DECAYING}[self.real_sign]

    def direction(self) -> ZdaDirection:
        """This zero as a :class:`ZdaDirection` (numeric values of the exact vectors)."""
        return ZdaDirection(self.value, self.xi, self.u0, np.concatenate([self.xi, self.value * self.xi]), 0.0)


@dataclass(frozen=True, slots=True)
class ExactZdaAnalysis:
    """Stealthy ZDAs decided over Q.

    Attributes
    ----------
    actuators : tuple of labels
    left_invertible : bool
    normal_rank : int
        Of the 2N pencil.
    normal_kernel_dim : int
    s_zero_polynomial : str
        Zero polynomial of the N-sized pencil in s.
    zeros : tuple of ExactZdaZero
        Zeros with an input direction (stealthy ZDAs), fastest growing first.
    unobservable : tuple of ExactZdaZero
        Zeros all of whose directions have u0 = 0.
    direction : ExactZdaZero or None
        Witness (same selection rule as :func:`zda_analysis`).
    direction_source : str
    notes : tuple of str
    """

    actuators: tuple[Label, ...]
    left_invertible: bool
    normal_rank: int
    normal_kernel_dim: int
    s_zero_polynomial: str
    zeros: tuple[ExactZdaZero, ...]
    unobservable: tuple[ExactZdaZero, ...]
    direction: ExactZdaZero | None
    direction_source: str
    notes: tuple[str, ...] = field(default_factory=tuple)

    @property
    def exists(self) -> bool:
        """A stealthy ZDA exists."""
        return self.direction is not None


def _fq(x: Fraction) -> Any:
    return flint.fmpq(x.numerator, x.denominator)


def _q_matrix(system: System, F: Sequence[int], rows_out: Sequence[int], s_poly: Any) -> list[list[Any]]:
    """[[s(x) I + alpha L, -S_F^T], [S_out, 0]] with fmpq_poly entries."""
    N = system.n
    L = system.laplacian_exact()
    a = _fq(system.alpha_q)
    rows: list[list[Any]] = []
    for i in range(N):
        row = [flint.fmpq_poly(a * _fq(L[i][j])) + (s_poly if i == j else 0) for j in range(N)]
        row += [flint.fmpq_poly(-1 if F[k] == i else 0) for k in range(len(F))]
        rows.append(row)
    for r in rows_out:
        rows.append([flint.fmpq_poly(int(j == r)) for j in range(N)] + [flint.fmpq_poly(0)] * len(F))
    return rows


def _exact_at(system: System, F: Sequence[int], g: Any, s_poly: Any, zero_lambda: bool) -> tuple[bool, Any | None, int]:
    """(attack?, chosen kernel vector over Q[x]/g, kernel dimension) of Q at the roots of g."""
    rows_out = system.idx(system.monitored_positions) if zero_lambda else system.idx(system.monitored)
    Q = _q_matrix(system, F, rows_out, s_poly)
    N = system.n
    K = pn.kernel_over_field(Q, g, N + len(F))
    pick = next((v for v in K.basis if any(not e.is_zero() for e in v[N:])), None)
    return pick is not None, pick if pick is not None else (K.basis[0] if K.basis else None), len(K.basis)


def _exact_zero(system: System, g: Any, vec: Any, root: complex, sign: int, attack: bool, mult: int, m: int) -> ExactZdaZero:
    N = system.n
    c = g.coeffs()
    rational = None
    if g.degree() == 1:
        rational = -Fraction(int(c[0].p), int(c[0].q)) / Fraction(int(c[1].p), int(c[1].q))
        root = complex(float(rational))
    if vec is None:
        xi, u = np.zeros(N), np.zeros(m)
        xf: tuple[Any, ...] = ()
    else:
        v = pn.eval_at_root(vec, g, root)
        xi, u = _normalize(v[:N], v[N:])
        xf = tuple(vec[:N])
    return ExactZdaZero(root, rational, str(g), sign, attack, xi, u, xf, g, mult)


def zda_analysis_exact(
    system: System,
    actuators: Iterable[Label] | None = None,
    *,
    lambda0: complex | float | Sequence[float] | None = None,
) -> ExactZdaAnalysis:
    """Exact version of :func:`zda_analysis` (rational weights and gains; no tolerance).

    Parameters
    ----------
    system : System
        The system (its weights and alpha, gamma are exact rationals).
    actuators : iterable of labels, optional
        F; default the spec's attacked actuators.
    lambda0 : complex, float or [re, im], optional
        Exponent for the witness (default the spec's ``attack.lambda0``); its real and
        imaginary parts are read as exact binary rationals.

    Returns
    -------
    ExactZdaAnalysis
    """
    F_lab = _actuators(system, actuators)
    F = system.idx(F_lab)
    lam_req = _lambda_request(system, lambda0)
    N, m = system.n, len(F)
    L = system.laplacian_exact()
    a = system.alpha_q
    As = [[-a * L[i][j] for j in range(N)] for i in range(N)]
    Bs = [[Fraction(int(F[k] == i)) for k in range(m)] for i in range(N)]
    M = system.idx(system.monitored)
    Cs = [[Fraction(int(j == r)) for j in range(N)] for r in M]
    es = pn.analyze_pencil_exact(As, Bs, Cs, directions=False, n_inputs=m)
    k0 = N + m - es.normal_rank
    g_q = _fq(system.gamma_q)
    x = flint.fmpq_poly([0, 1])
    s_poly = x * x + g_q * x
    Z = es.zero_polynomial(s_poly) if es.zero_polynomial.degree() > 0 else flint.fmpq_poly(1)
    attack: list[ExactZdaZero] = []
    unobs: list[ExactZdaZero] = []
    notes: list[str] = []
    if Z.degree() > 0:
        _, facs = Z.factor()
        for g, mult in facs:
            g = g / g.leading_coefficient()
            if g == x:
                continue
            is_attack, vec, kdim = _exact_at(system, F, g, s_poly, False)
            if kdim <= k0:  # pragma: no cover - a theorem, kept as a self-check
                raise AssertionError(f"root of {g} is not a zero of the pencil; please report")
            for root, sign in pn.classify_real_parts(g):
                zz = _exact_zero(system, g, vec, root, sign, is_attack, int(mult), m)
                (attack if is_attack else unobs).append(zz)
    # lambda = 0
    g0 = x
    is_attack0, vec0, kdim0 = _exact_at(system, F, g0, s_poly, True)
    if kdim0 > k0:
        zz = _exact_zero(system, g0, vec0, 0j, 0, is_attack0, kdim0 - k0, m)
        (attack if is_attack0 else unobs).append(zz)
    attack.sort(key=lambda z: (-z.value.real, -abs(z.value.imag)))
    unobs.sort(key=lambda z: (-z.value.real, -abs(z.value.imag)))

    def at(lam: complex) -> ExactZdaZero | None:
        re, im = Fraction(lam.real), Fraction(lam.imag)
        if im == 0:
            g = x - _fq(re)
        else:
            g = (x - _fq(re)) ** 2 + _fq(im) ** 2
        is_att, vec, _ = _exact_at(system, F, g, s_poly, lam == 0)
        if not is_att:
            return None
        sign = (re > 0) - (re < 0)
        zz = _exact_zero(system, g, vec, complex(float(re), float(im)), sign, True, 1, m)
        return zz

    direction: ExactZdaZero | None = None
    source = "none"
    if lam_req is not None:
        direction = at(lam_req)
        if direction is not None:
            source = "requested lambda0"
        else:
            notes.append(f"no stealthy ZDA at the requested lambda0 = {lam_req}")
    if direction is None:
        best = attack[0] if attack else None
        if not es.left_invertible and (best is None or best.real_sign <= 0):
            direction = at(1 + 0j)
            source = "lambda0 = 1 (not left-invertible: a ZDA exists at every lambda0)"
        if direction is None and best is not None:
            direction, source = best, "fastest-growing zero"
    return ExactZdaAnalysis(
        F_lab, es.left_invertible, N + es.normal_rank, k0, str(es.zero_polynomial), tuple(attack), tuple(unobs), direction, source, tuple(notes)
    )


# ------------------------------------------------------------------------------------------
# covert attacks


def reachable_agents(system: System, actuators: Iterable[Label] | None = None) -> list[Label]:
    """Agents whose state u_a can move: the connected components (normal mode) that contain
    an attacked actuator, in label order.

    Parameters
    ----------
    system : System
        The system.
    actuators : iterable of labels, optional
        F; default the spec's attacked actuators.
    """
    F = set(_actuators(system, actuators))
    out: list[Label] = []
    for comp in system.components():
        if F & set(comp):
            out.extend(comp)
    return sorted(out, key=system.index.__getitem__)


def covert_required_channels(system: System) -> list[str]:
    """Monitored output channels reached by the attack input u_a (normal mode).

    A channel (a row c of C) is reached iff c A_1^k B != 0 for some k. Structurally, for
    positive weights: with d = dist(j, a) in the graph, the (j, a) entry of L^d is a sum over
    shortest paths of products of the off-diagonal entries -w, all of sign (-1)^d, so it is
    nonzero and lower powers vanish; expanding (lambda^2 + gamma lambda + alpha L)^{-1} in
    1/lambda, the first Markov parameter from u_a to x_j is (-alpha)^d (L^d)_{ja} at
    k = 2d + 1, and to v_j at k = 2d. Hence x:j and v:j are reached iff j is connected to
    some attacked agent; no tolerance is involved.

    Parameters
    ----------
    system : System
        The system; F is its ``attack.actuators``.

    Returns
    -------
    list of str
        Channel names (``"x:<label>"``, ``"v:<label>"``) in the order of
        :meth:`System.output_channels`.
    """
    R = set(reachable_agents(system))
    out = []
    for ch in system.output_channels():
        lab = _channel_label(system, ch)
        if lab in R:
            out.append(ch)
    return out


def _channel_label(system: System, ch: str) -> Label:
    kind, _, rest = ch.partition(":")
    for lab in system.labels:
        if str(lab) == rest:
            return lab
    raise NotApplicableError(f"unknown channel {ch!r}")  # pragma: no cover


# ------------------------------------------------------------------------------------------
# checkers


def _vec(system: System, v: np.ndarray, labels: Sequence[Label], tol: Tolerance, support_only: bool = True) -> dict[Label, Any]:
    big = float(np.max(np.abs(v), initial=0.0))
    out: dict[Label, Any] = {}
    for lab, x in zip(labels, v):
        if support_only and tol.decide(abs(x), big) is Decision.ZERO:
            continue
        c = complex(x)
        out[lab] = c.real if c.imag == 0 else c
    return out


def _moved(system: System, xi: np.ndarray, tol: Tolerance) -> list[Label]:
    big = float(np.max(np.abs(xi), initial=0.0))
    return [lab for lab, x in zip(system.labels, xi) if big > 0 and tol.decide(abs(x), big) is Decision.NONZERO]


def _zero_json(system: System, F: Sequence[Label], z: ZdaZero | ExactZdaZero, tol: Tolerance) -> dict[str, Any]:
    d: dict[str, Any] = {
        "lambda": [z.value.real, z.value.imag],
        "growth": z.growth,
        "multiplicity": z.multiplicity,
        "u0": _vec(system, z.u0, F, tol, support_only=False),
        "xi": _vec(system, z.xi, system.labels, tol),
        "moved": _moved(system, z.xi, tol),
    }
    if isinstance(z, ZdaZero):
        d["residual"] = z.residual
    else:
        d["minimal_polynomial"] = z.factor
        if z.rational is not None:
            d["lambda_exact"] = str(z.rational)
    return d


def _margin(left_inv: bool, zeros: Sequence[ZdaZero | ExactZdaZero]) -> float:
    if not left_inv:
        return math.inf
    if zeros:
        return max(z.value.real for z in zeros)
    return -math.inf


@checker("stealthy.zda")
def check_zda(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Proposition II.4 (ii), Definition II.2: a stealthy ZDA of (A_1, B, C, 0) exists.

    .. math::

        \\exists\\,\\lambda_0 \\in \\mathbb C,\\ (\\tilde x_0, u_0),\\ u_0 \\ne 0:\\quad
        \\begin{bmatrix} \\lambda_0 I - A_1 & -B \\\\ C & 0 \\end{bmatrix}
        \\begin{bmatrix} \\tilde x_0 \\\\ u_0 \\end{bmatrix} = 0

    Scope: global (normal mode), F = ``attack.actuators``. Without an attack in the spec the
    condition is not evaluated (no result). ``holds`` = a verified stealthy ZDA exists (the
    pencil is not left-invertible, or it has a zero with an input direction; note that a
    zero at lambda0 = 0 with u0 != 0 -- a constant input that shifts positions without moving
    velocities -- is a persistent, not an unbounded, ZDA). ``fails`` = left-invertible and
    no zero has an input direction. Numeric: structured modal path (option
    ``zda_method = "dense"`` for the dense pencil); tolerance rules in the module docstring.
    Exact: :func:`zda_analysis_exact`. Option ``lambda0`` overrides the spec's exponent.

    Margin
        The largest growth rate Re lambda0 of an available stealthy ZDA: +inf when the system
        is not left-invertible (every lambda0 is available), -inf when none exists.
    Witness
        ``left_invertible``, ``normal_rank`` (of the 2N pencil), ``normal_kernel_dim``,
        ``zeros`` (lambda, growth, u0, xi on its support, moved agents, residual), at most
        ``max_zeros`` (option, default 50) of them, ``zeros_total``, ``unobservable_modes``
        (zeros with u0 = 0, not attacks) and ``direction`` (lambda0, u0, xi, moved, source).
    """
    if system.spec.attack is None:
        return []
    F = system.attacked
    lam_opt = ctx.options.get("lambda0")
    max_z = int(ctx.options.get("max_zeros", 50))
    tol = ctx.tol
    ea: ExactZdaAnalysis | None = None
    za: ZdaAnalysis | None = None
    if ctx.exact:
        ea = zda_analysis_exact(system, lambda0=lam_opt)
        left_inv, nrank, k0 = ea.left_invertible, ea.normal_rank, ea.normal_kernel_dim
        zeros: Sequence[ZdaZero | ExactZdaZero] = ea.zeros
        unobs: Sequence[ZdaZero | ExactZdaZero] = ea.unobservable
        direction: ZdaZero | ExactZdaZero | None = ea.direction
        source, notes = ea.direction_source, ea.notes
        status = Status.HOLDS if ea.exists else Status.FAILS
    else:
        za = zda_analysis(system, tol, lambda0=lam_opt, method=str(ctx.options.get("zda_method", "structured")))
        left_inv, nrank, k0 = za.left_invertible, za.normal_rank, za.normal_kernel_dim
        zeros, unobs, direction = za.zeros, za.unobservable, za.direction
        source, notes = za.direction_source, za.notes
        if za.exists:
            status = Status.HOLDS
        elif za.decided:
            status = Status.FAILS
        else:
            status = Status.UNDECIDED
    N, m = system.n, len(F)
    p = len(system.output_channels())
    witness: dict[str, Any] = {
        "actuators": list(F),
        "left_invertible": left_inv,
        "normal_rank": nrank,
        "pencil_shape": [2 * N + p, 2 * N + m],
        "normal_kernel_dim": k0,
        "zeros": [_zero_json(system, F, z, tol) for z in zeros[:max_z]],
        "zeros_total": len(zeros),
        "unobservable_modes": [[z.value.real, z.value.imag] for z in unobs[:max_z]],
        "method": "exact (N-sized pencil in s over Q)" if ctx.exact else f"{za.method if za else ''} (N-sized pencil in s = lambda^2 + gamma lambda)",
    }
    if ea is not None:
        witness["s_zero_polynomial"] = ea.s_zero_polynomial
    if direction is not None:
        dj = _zero_json(system, F, direction, tol)
        dj["source"] = source
        dj["lambda0"] = dj.pop("lambda")
        witness["direction"] = dj
    if notes:
        witness["notes"] = list(notes)
    margin = _margin(left_inv, zeros)
    return [result("stealthy.zda", ctx, status, margin=margin, witness=witness)]


@checker("stealthy.covert")
def check_covert(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Proposition II.4 (i): a covert attack is feasible (eqs. ``ym_solution``-``covert_trajec_post``).

    .. math::

        \\{c \\in \\text{rows}(C) : c A_1^k B \\ne 0 \\text{ for some } k\\} \\subseteq
        \\text{channels of } F_s

    u_s = C x~ cancels u_a exactly when the attacker owns every monitored channel that u_a
    reaches (:func:`covert_required_channels`; combinatorial for positive weights, so no
    tolerance and the same verdict in numeric and exact mode). F_s = ``attack.sensors``
    (every monitored channel of a listed agent). Scope: global (normal mode). No attack in
    the spec: no result.

    Margin
        The number of reached channels the attacker does not own (0 when feasible).
    Witness
        ``required`` (reached channels), ``compromised`` (owned channels), ``missing``,
        ``reachable_agents``.
    """
    attack = system.spec.attack
    if attack is None:
        return []
    req = covert_required_channels(system)
    sensors = set(attack.sensors)
    owned = [ch for ch in system.output_channels() if _channel_label(system, ch) in sensors]
    missing = [ch for ch in req if ch not in owned]
    status = Status.FAILS if missing else Status.HOLDS
    witness: dict[str, Any] = {
        "actuators": list(system.attacked),
        "required": req,
        "compromised": owned,
        "missing": missing,
        "reachable_agents": reachable_agents(system),
    }
    return [result("stealthy.covert", ctx, status, margin=float(len(missing)), witness=witness, numeric_decision=False)]



# ------------------------------------------------------------------------------------------
# findings


@finding_rule
def unobservable_zeros_finding(system: System, results: Sequence[ConditionResult]) -> list[Finding]:
    """Definition II.2 counts zeroing directions with u0 = 0 (unobservable modes) as ZDAs."""
    out = []
    for r in results:
        if r.id != "stealthy.zda" or not r.witness.get("unobservable_modes"):
            continue
        modes = r.witness["unobservable_modes"]
        out.append(
            Finding(
                "definition-ii2.unobservable-zeros",
                "Definition II.2 admits u0 = 0: unobservable modes satisfy eq. zda_cond without any attack",
                "Definition II.2 calls lambda0 a zero whenever some (x0, u0) != (0, 0) solves eq. inv_zeros, and "
                "Proposition II.4 (ii) builds the ZDA from such a direction. A direction with u0 = 0 is an "
                "unobservable mode: u_a = u0 exp(lambda0 t) = 0 is no attack. With M_x empty (Lemma III.1's "
                "privacy) the consensus direction [1; 0] at lambda0 = 0 is always one. On this system the zeros "
                f"{modes} have only u0 = 0 directions; stealthy.zda requires u0 != 0 and does not count them.",
                "Definition II.2, Proposition II.4 (ii)",
                {"unobservable_modes": modes},
            )
        )
    return out


@finding_rule
def covert_sensors_finding(system: System, results: Sequence[ConditionResult]) -> list[Finding]:
    """Proposition II.4 (i) omits the sensor channels the cancellation needs."""
    out = []
    for r in results:
        if r.id != "stealthy.covert" or r.status is not Status.FAILS:
            continue
        missing = r.witness.get("missing", [])
        out.append(
            Finding(
                "proposition-ii4.covert-needs-sensors",
                "Proposition II.4 (i): x~(t_a) = 0 is not enough for a covert attack",
                "The proposition states that with x~(t_a) = 0 'there exists a vector u_s ... canceling out the "
                "effect of u_a on the system output', but eq. attack_model restricts supp(u_s) to the compromised "
                "channels F_s: the cancellation u_s = C x~ needs every monitored channel that u_a reaches. On this "
                f"system the attacker does not own {missing}, so no covert attack exists with these sensors. "
                "Minimal example: path 1-2, F = {1}, M_v = {2}, F_s = {}.",
                "Proposition II.4 (i), eq. attack_model",
                {"missing": missing, "required": r.witness.get("required", [])},
            )
        )
    return out
