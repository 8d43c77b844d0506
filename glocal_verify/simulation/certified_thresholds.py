"""Certified detection thresholds of the sampled implementation (Algorithm 1's ``threshold``).

The paper leaves the thresholds to future work ("an upper bound on the estimation error of
observers in the attack-free case", Section III.E). For the sampled detectors of
:mod:`glocal_verify.observers.sampled`, attack-free and before any switch, every residual is
linear in the uncertainty: with the observer's exact error equation

.. math::

    \\epsilon_{k+1} = F \\epsilon_k + G_w w_k - K_n n_k,\\qquad r_k = C_e \\epsilon_k + D_n n_k,\\qquad
    \\epsilon_0 = P_x x_0 \\ (\\text{or } P_e e_0 + P_n n_0),

and the rows :math:`\\ell_m = C_e F^m` (:func:`~glocal_verify.numerics.certified_rows.certified_rows`),

.. math::

    r_{k,j} = \\ell_k P x_0 - \\sum_{i<k} \\ell_{k-1-i} K_n n_i + \\sum_{i<k} \\ell_{k-1-i} G_w w_i + D_n n_k .

Over the admissible set of ``[uncertainty]`` -- the box ``|x_0|_inf <= b`` (or the box of initial
errors), ``|n_{i,c}| <= nbar_c`` per channel and sample, and the disturbance
``|d_a(t)| <= dbar`` per agent, whose sampled effect is
:math:`w_a = (\\int_0^h (h - s) d_a\\,ds,\\ \\int_0^h d_a\\,ds)` -- these terms are independent, so the
supremum of :math:`|r_{k,j}|` is the sum of their suprema, each attained by a sign pattern:

.. math::

    B_{k,j} = b \\sum_c |(\\ell_k P)_{jc}| + \\sum_{m<k} \\sum_c |(\\ell_m K_n)_{jc}| \\bar n_c
              + \\bar d \\sum_{m<k} \\sum_a \\int_0^h |(\\ell_m G_w)_{j,a}\\, t + (\\ell_m G_w)_{j,N+a}|\\,dt
              + \\sum_c |(D_n)_{jc}| \\bar n_c .

(The last integral is the support function of the disturbance set, in closed form.) ``B`` is
the **exact** worst case up to rounding; the threshold is
:math:`\\theta_{k,j} = (1 + \\rho)\\,\\bar B_{k,j} + \\rho\\,s` with :math:`\\bar B` a certified upper
bound of ``B`` (the rows' a-posteriori errors and the rounding of every sum added) and
:math:`\\rho` = ``ROUNDING`` the detectors' own rounding allowance relative to the uncertainty
scale ``s = b + max nbar + h dbar``. **No attack-free run crosses it**, for every admissible
initial state, noise and disturbance (the proof is the formula). Beyond the computed horizon
the constant tail bounds every later sample: the initial term by the certified decay of the
rows, the sums by their certified totals (:meth:`RowSequence.tail_norms`).

**Gaussian noise.** With ``noise_std`` the noise has, on top of the bounded part, a Gaussian part
(independent over channels and samples); its contribution to :math:`r_{k,j}` is Gaussian with
variance :math:`\\sigma_{k,j}^2 = \\sum_{m<k} \\sum_c (\\ell_m K_n)_{jc}^2 \\sigma_c^2 + \\sum_c (D_n)_{jc}^2 \\sigma_c^2`.
The threshold is :math:`\\theta = (1 + \\rho)(\\bar B + z \\bar\\sigma) + \\rho s` and the probability of a
false alarm of the observer over the K samples of the horizon is at most
:math:`K q\\,\\operatorname{erfc}(z / \\sqrt 2)` (union bound, evaluated in ball arithmetic), with
z chosen so that the total over the observers is the spec's ``false_alarm``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any, Mapping

import flint
import numpy as np

from glocal_verify.errors import NotApplicableError
from glocal_verify.model import System
from glocal_verify.numerics.certified_rows import RowSequence, abs_row_sums, certified_rows, exact_to_float, upper
from glocal_verify.numerics.rounding import gamma_bound
from glocal_verify.observers.sampled import SampledObserver, sampled_observers
from glocal_verify.analysis.sampled.loop import implementation_of
from glocal_verify.results import jsonable
from glocal_verify.simulation.limits import THRESHOLD_KNOBS, SizeEstimate, check_size, estimate_threshold_size, threshold_samples
from glocal_verify.spec.arguments import real_arg
from glocal_verify.spec.types import ImplementationSpec, UncertaintySpec

__all__ = [
    "ROUNDING",
    "DEFAULT_FALSE_ALARM",
    "UncertaintyModel",
    "uncertainty_model",
    "ObserverThreshold",
    "CertifiedThresholds",
    "certified_thresholds",
    "disturbance_support",
    "disturbance_rows",
]

#: the detectors' rounding allowance, relative to the uncertainty scale (the project's rtol)
ROUNDING = 1e-9
#: false-alarm probability over the horizon when the spec gives a Gaussian part but no target
DEFAULT_FALSE_ALARM = Fraction(1, 10**6)


@dataclass(frozen=True, slots=True)
class UncertaintyModel:
    """The admissible set of one run, as floats per observer channel.

    Attributes
    ----------
    box : float
        Half-width of the initial box.
    initial : str
        ``"state"`` (box on ``x_0``, observers from 0) or ``"error"`` (box on each observer's
        initial estimation error).
    disturbance : float
        ``dbar``.
    spec : UncertaintySpec
        Where the numbers came from (exact).
    """

    box: float
    initial: str
    disturbance: float
    spec: UncertaintySpec

    def noise(self, channels: tuple[str, ...]) -> np.ndarray:
        """Amplitude bounds of the channels (exact rationals rounded up to floats)."""
        return np.array([_up(self.spec.noise_bound(c)) for c in channels])

    def sigma(self, channels: tuple[str, ...]) -> np.ndarray:
        """Gaussian standard deviations of the channels (rounded up)."""
        return np.array([_up(self.spec.noise_sigma(c)) for c in channels])

    def scale(self, period: float) -> float:
        """``b + max nbar + h dbar``: the scale of the rounding allowance."""
        nb = max([float(v) for _, v in self.spec.noise] or [0.0])
        return self.box + nb + period * self.disturbance


def _up(q: Fraction) -> float:
    f = float(q)
    return f if Fraction(f) >= q else math.nextafter(f, math.inf)


def uncertainty_model(system: System, uncertainty: UncertaintySpec | None = None) -> UncertaintyModel:
    """The spec's ``[uncertainty]`` (or the given one; default: the box of half-width 1, no noise)."""
    u = uncertainty if uncertainty is not None else (system.spec.uncertainty or UncertaintySpec())
    return UncertaintyModel(_up(u.box), "error" if u.initial_error is not None else "state", _up(u.disturbance), u)


def disturbance_support(a: np.ndarray, b: np.ndarray, h: float) -> np.ndarray:
    """``int_0^h |a t + b| dt`` elementwise (the support function of one agent's sampled
    disturbance in the direction of a row's (position, velocity) weights), closed form."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    out = np.abs(a * h * h / 2 + b * h)
    with np.errstate(divide="ignore", invalid="ignore"):
        t0 = np.where(a != 0, -b / np.where(a != 0, a, 1.0), -1.0)
        cross = (t0 > 0) & (t0 < h)
        split = (b * b + (a * h + b) ** 2) / (2 * np.abs(np.where(a != 0, a, 1.0)))
    return np.where(cross, split, out)


def disturbance_rows(rows: RowSequence, Gw: Any, dbar: float, h: float, K: int) -> np.ndarray:
    """Certified upper bounds of the disturbance's worst effect through each row, (K, q):
    ``dbar sum_a int_0^h |(ell_m Gw)_a t + (ell_m Gw)_{N+a}| dt`` for m < K (module docstring),
    with the rows' errors and the product's rounding through the Lipschitz bound
    ``|da| h^2/2 + |db| h``."""
    Gf, Gwe = exact_to_float(Gw)
    n = Gf.shape[1] // 2
    mid = rows.mid[:K]
    G = mid @ Gf  # (K, q, 2N)
    sup = disturbance_support(G[..., :n], G[..., n:], h).sum(axis=2)
    lip = max(h * h / 2, h)
    colmax = (np.abs(Gf) + Gwe).max(axis=0).sum() if Gf.size else 0.0
    dev = gamma_bound(Gf.shape[0] + 1) * (np.abs(mid) @ np.abs(Gf)).sum(axis=2) + (np.abs(mid) @ Gwe).sum(axis=2) + rows.err[:K] * colmax
    return upper(dbar * (sup * (1 + 16 * gamma_bound(8)) + lip * dev), 2 * n + 8)  # type: ignore[no-any-return]


@dataclass(frozen=True, slots=True)
class ObserverThreshold:
    """The certified threshold of one detector.

    Attributes
    ----------
    observer, kind : str
    channels : tuple of str
    period : float
    theta : ndarray
        (K, q) thresholds at the samples ``t_k = k h``, k < K.
    tail : ndarray
        (q,) constant threshold valid at every sample k >= K.
    bound : ndarray
        (K, q) the worst-case residual ``B`` (floating point, before the certified widening).
    parts : mapping of str to ndarray
        ``"initial"``, ``"noise"``, ``"disturbance"``: (K, q) certified upper bounds of each term.
    sigma : ndarray or None
        (K, q) certified upper bounds of the Gaussian part's standard deviation.
    z : float or None
        The Gaussian multiplier.
    false_alarm : float or None
        Certified bound of this observer's false-alarm probability over the K samples.
    slack : float
        ``max (theta - B) / theta``: the relative room between the worst case and the threshold
        (the rounding allowance plus the certified error of the computation).
    certificate : mapping
        ``window``, ``theta_M`` (certified ``||F^m0||_inf``), ``kappa`` and the largest row error.
    rows : RowSequence
        The rows ``C_e F^m`` the bound was computed from (for worst-case runs).
    """

    observer: str
    kind: str
    channels: tuple[str, ...]
    period: float
    theta: np.ndarray
    tail: np.ndarray
    bound: np.ndarray
    parts: Mapping[str, np.ndarray]
    sigma: np.ndarray | None
    z: float | None
    false_alarm: float | None
    slack: float
    certificate: Mapping[str, Any]
    rows: RowSequence | None = field(default=None, repr=False, compare=False)

    @property
    def constant(self) -> np.ndarray:
        """(q,) one constant threshold valid at every sample: the larger of the peak and the tail."""
        return np.maximum(self.theta.max(axis=0), self.tail) if len(self.theta) else self.tail

    def at(self, k: np.ndarray | int) -> np.ndarray:
        """Thresholds at sample indices ``k`` (the tail beyond the horizon)."""
        k = np.asarray(k)
        K = len(self.theta)
        out = np.where((k < K)[..., None], self.theta[np.minimum(k, K - 1)], self.tail)
        return out

    def to_json(self) -> dict[str, Any]:
        """Summary (peak, tail, final value per channel, slack, certificate)."""
        return jsonable(
            {
                "observer": self.observer,
                "kind": self.kind,
                "channels": list(self.channels),
                "peak": dict(zip(self.channels, self.theta.max(axis=0).tolist())) if len(self.theta) else {},
                "tail": dict(zip(self.channels, self.tail.tolist())),
                "slack": self.slack,
                "false_alarm": self.false_alarm,
                "z": self.z,
                "certificate": dict(self.certificate),
            }
        )


@dataclass(frozen=True, slots=True)
class CertifiedThresholds:
    """Certified thresholds of every sampled detector.

    Attributes
    ----------
    period : float
    horizon : int
        K samples (``t = 0 .. (K - 1) h``).
    observers : mapping of str to ObserverThreshold
    model : UncertaintyModel
    notes : tuple of str
        Detectors that could not be built or certified, and why.
    false_alarm : float or None
        With Gaussian noise: the certified bound on the probability that some detector raises a
        false alarm within the horizon.
    """

    period: float
    horizon: int
    observers: Mapping[str, ObserverThreshold]
    model: UncertaintyModel
    notes: tuple[str, ...] = ()
    false_alarm: float | None = None
    detectors: tuple[SampledObserver, ...] = field(default=(), repr=False)

    def __getitem__(self, name: str) -> ObserverThreshold:
        return self.observers[name]

    def to_json(self) -> dict[str, Any]:
        """JSON-ready summary."""
        return jsonable(
            {
                "period": self.period,
                "horizon_samples": self.horizon,
                "observers": {k: v.to_json() for k, v in self.observers.items()},
                "false_alarm": self.false_alarm,
                "notes": list(self.notes),
            }
        )


def _row_products_abs(rows: RowSequence, X: np.ndarray, Xe: np.ndarray, K: int) -> np.ndarray:
    """Certified entrywise upper bounds of ``|(ell_m X)_{jc}|`` for m < K: (K, q, c)."""
    mid = rows.mid[:K]
    n = X.shape[0]
    prod = np.abs(mid @ X)
    err = gamma_bound(n + 1) * (np.abs(mid) @ np.abs(X)) + np.abs(mid) @ Xe
    colmax = (np.abs(X) + Xe).max(axis=0) if X.size else np.zeros(X.shape[1])
    return upper(prod + err + rows.err[:K, :, None] * colmax[None, None, :], n + 6)  # type: ignore[no-any-return]


def _threshold_of(obs: SampledObserver, model: UncertaintyModel, h: float, K: int, z: float | None) -> ObserverThreshold:
    rows = certified_rows(obs.F, obs.Ce, K)
    if not rows.certified_stable:
        raise NotApplicableError(f"{obs.name}: its error dynamics are not certified stable (no window m0 with ||F^m0|| < 1)")
    q = len(obs.channels)
    nbar = model.noise(obs.channels)
    # initial term
    if model.initial == "state":
        init = model.box * abs_row_sums(rows, obs.Px, K)
        Pinf = float(upper(np.abs(exact_to_float(obs.Px)[0]).sum(axis=1).max(initial=0.0), 64))
    else:
        init = model.box * abs_row_sums(rows, obs.Pe, K)
        Pn, _ = exact_to_float(obs.Pn)
        init = init + abs_row_sums(rows, Pn * nbar[None, :], K)
        Pinf = float(upper(np.abs(exact_to_float(obs.Pe)[0]).sum(axis=1).max(initial=0.0), 64))
    init = upper(init, 2)
    # noise through the observer (cumulative), and the direct term
    Kn, Kne = exact_to_float(obs.Kn)
    Dn, _ = exact_to_float(obs.Dn)
    direct = upper(np.abs(Dn) @ nbar, q + 2) if q else np.zeros(0)
    nz = abs_row_sums(rows, Kn * nbar[None, :], K)
    noise_c = np.zeros((K, q))
    noise_c[1:] = upper(np.cumsum(nz[: K - 1], axis=0), K + 2)
    noise = noise_c + direct[None, :]
    # disturbance (support function, cumulative)
    dist = np.zeros((K, q))
    Gw, Gwe = exact_to_float(obs.Gw)
    n = Gw.shape[1] // 2
    if model.disturbance > 0 and n:
        per = disturbance_rows(rows, obs.Gw, model.disturbance, h, K)
        dist[1:] = upper(np.cumsum(per[: K - 1], axis=0), K + 2)
    bound = init + noise + dist
    # tails
    tsup, tsum = rows.tail_norms()
    Kn_inf = float(upper((np.abs(Kn) + Kne).dot(nbar).max(initial=0.0), Kn.shape[1] + 2))
    Gw_inf = float(upper((np.abs(Gw) + Gwe).sum(axis=1).max(initial=0.0), Gw.shape[1] + 2))
    tail = upper(
        model.box * tsup * Pinf
        + (noise_c[-1] + nz[-1] + tsum * Kn_inf)
        + direct
        + (dist[-1] + (per[-1] if model.disturbance > 0 and n else 0.0) + tsum * Gw_inf * max(h * h / 2, h) * model.disturbance),
        16,
    )
    if model.initial == "error":
        Pn_f, _ = exact_to_float(obs.Pn)
        tail = upper(tail + tsup * float(np.abs(Pn_f).dot(nbar).max(initial=0.0)), 8)
    sigma = None
    fa = None
    s = model.scale(h)
    sig_c = model.sigma(obs.channels)
    if z is not None and np.any(sig_c > 0):
        A = _row_products_abs(rows, Kn, Kne, K)  # (K, q, p)
        var = np.zeros((K, q))
        var[1:] = np.cumsum(((A[: K - 1] ** 2) * (sig_c**2)[None, None, :]).sum(axis=2), axis=0)
        var = upper(var + ((np.abs(Dn) ** 2) @ (sig_c**2))[None, :], K + 2 * len(sig_c) + 8)
        sigma = np.sqrt(var) * (1 + 4 * gamma_bound(2))
        # later samples: (ell_m Kn)_jc^2 <= ||ell_m||_1^2 max_i |Kn_ic|^2, and sum_m ||ell_m||^2 <= sup * sum
        kmax = float(upper((np.abs(Kn) + Kne).max(initial=0.0), 2))
        var_tail = upper(var[-1] + (A[-1] ** 2 * (sig_c**2)[None, :]).sum(axis=1) + tsup * tsum * kmax**2 * float((sig_c**2).sum()), 16)
        sig_tail = np.sqrt(var_tail) * (1 + 4 * gamma_bound(2))
        theta = (1 + ROUNDING) * upper(bound + z * sigma, 4) + ROUNDING * s
        tail_theta = (1 + ROUNDING) * upper(tail + z * sig_tail, 4) + ROUNDING * s
        with_prec = flint.ctx.prec
        flint.ctx.prec = 64
        try:
            fa = float((flint.arb(K * q) * (flint.arb(z) / flint.arb(2).sqrt()).erfc()).upper())
        finally:
            flint.ctx.prec = with_prec
    else:
        theta = (1 + ROUNDING) * bound + ROUNDING * s
        tail_theta = (1 + ROUNDING) * tail + ROUNDING * s
    # the worst case B itself (floating point, no certified widening): the slack is theta - B
    Pm = exact_to_float(obs.Px if model.initial == "state" else obs.Pe)[0]
    est_noise = np.zeros((K, q))
    est_noise[1:] = np.cumsum(np.abs(rows.mid[: K - 1] @ (Kn * nbar[None, :])).sum(axis=2), axis=0)
    bound_est = model.box * np.abs(rows.mid[:K] @ Pm).sum(axis=2) + est_noise + (np.abs(Dn) @ nbar)[None, :] + dist
    with np.errstate(invalid="ignore", divide="ignore"):
        rel = np.where(theta > 0, (theta - bound_est) / theta, 0.0)
    cert = {"window": rows.window, "theta_M": rows.theta, "kappa": rows.kappa, "max_row_error": rows.max_error}
    return ObserverThreshold(
        obs.name, obs.kind, obs.channels, h, theta, tail_theta, bound_est, {"initial": init, "noise": noise, "disturbance": dist}, sigma, z, fa, float(np.max(rel)) if rel.size else 0.0, cert, rows
    )


def certified_thresholds(
    system: System,
    *,
    implementation: ImplementationSpec | None = None,
    uncertainty: UncertaintySpec | None = None,
    horizon: float | None = None,
    detectors: tuple[SampledObserver, ...] | None = None,
) -> CertifiedThresholds:
    """Certified thresholds of the central observer and every local UIO (module docstring).

    Parameters
    ----------
    system : System
    implementation, uncertainty : optional
        Default the spec's ``[implementation]`` and ``[uncertainty]``.
    horizon : float, optional
        Seconds of explicit thresholds (default the spec's simulation horizon); the tail
        covers every later sample.
    detectors : tuple of SampledObserver, optional
        Default :func:`~glocal_verify.observers.sampled.sampled_observers`.

    Raises
    ------
    NotApplicableError
        Without ``[implementation]``, or with the continuous loop.
    """
    impl = implementation_of(system, implementation)
    model = uncertainty_model(system, uncertainty)
    h = float(impl.period)
    T = float(system.spec.simulation.horizon) if horizon is None else real_arg("horizon", horizon, 0.0)
    K = threshold_samples(T, h)
    check_size(SizeEstimate(float(K), 0.0), what="certified thresholds", knobs=THRESHOLD_KNOBS)  # before the detectors are built
    notes: list[str] = []
    if detectors is None:
        detectors, more = sampled_observers(system, impl)
        notes += list(more)
    if not detectors:
        raise NotApplicableError("; ".join(notes) or "no detector")
    # before any (K, q, d) array: a horizon of 1e7 s would ask for hundreds of GiB
    check_size(estimate_threshold_size(K, [(len(o.channels), o.F.nrows()) for o in detectors]), what="certified thresholds", knobs=THRESHOLD_KNOBS)
    z = None
    p_total = None
    if model.spec.gaussian:
        target = model.spec.false_alarm if model.spec.false_alarm is not None else DEFAULT_FALSE_ALARM
        channels = sum(len(o.channels) for o in detectors)
        old = flint.ctx.prec
        flint.ctx.prec = 64
        try:
            per = flint.arb(flint.fmpq(target.numerator, target.denominator)) / (K * max(channels, 1))
            z = float((per.erfcinv() * flint.arb(2).sqrt()).upper())
        finally:
            flint.ctx.prec = old
    out: dict[str, ObserverThreshold] = {}
    for o in detectors:
        try:
            out[o.name] = _threshold_of(o, model, h, K, z)
        except NotApplicableError as exc:
            notes.append(str(exc))
    if z is not None:
        p_total = float(sum(t.false_alarm or 0.0 for t in out.values()))
    return CertifiedThresholds(h, K, out, model, tuple(notes), p_total, tuple(detectors))
