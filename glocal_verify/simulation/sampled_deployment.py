"""The sampled deployment: the detectors a vehicle runs at period h in every mode of the schedule,
their certified thresholds over the whole schedule, Algorithm 1's switching logic and the
detection guarantee of the spec's attack.

:func:`sampled_deployment` computes it once per system (kept on ``system.analysis``); the
``detection.*`` conditions, :func:`~glocal_verify.simulation.deployment.design_deployment` (the
file) and ``replay`` all read this one value.

The detectors (:mod:`glocal_verify.observers.sampled`) run

.. math::

    z_{k+1} = F_o z_k + G_o y_k,\\qquad r_k = R_y y_k - R_z z_k,\\qquad y_k = C x_k + n_k,\\qquad z_0 = 0,

with the matrices of the active mode; a local UIO whose decoupling matrix changes at a switch
from p to q is reset, :math:`z \\leftarrow z + (H_p - H_q) y_s`, before the sample's update. The
thresholds are those of :mod:`.schedule_thresholds`: certified upper bounds of every admissible
attack-free residual (``[uncertainty]``), per sample and per segment of the schedule, with the
tail after the last switch; and the control centre's thresholds after Algorithm 1's switch.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from glocal_verify import config
from glocal_verify.analysis.sampled.loop import implementation_of
from glocal_verify.derived import Kind
from glocal_verify.errors import NotApplicableError
from glocal_verify.model import System
from glocal_verify.simulation.certified_thresholds import certified_thresholds
from glocal_verify.simulation.guarantees import DetectionGuarantee, detection_guarantee
from glocal_verify.simulation.schedule import Schedule
from glocal_verify.observers.sampled import to_float
from glocal_verify.simulation.schedule_thresholds import DetectorSchedule, ScheduleThresholds, schedule_thresholds
from glocal_verify.spec.types import ImplementationSpec

__all__ = ["DetectorMode", "DeployedDetector", "SampledDeployment", "sampled_deployment", "deployment_horizon", "ALGORITHM1"]

#: Algorithm 1 as the deployment runs it (written into the file)
ALGORITHM1 = (
    "every sample k: run every detector of the active mode; a local residual component above its threshold is a local alarm "
    "(line 3); the first local alarm at sample k_L switches the topology to the safe mode at sample k_L + switch_delay "
    "(lines 4-5; the safe mode then persists and the timed schedule stops); from the switch sample s on, the control "
    "centre's residual is compared with the after-switch threshold of the block holding s, at m = k - s samples after it; "
    "a crossing is the control centre's alarm (lines 6-7: stealthy attack detected)"
)

@dataclass(frozen=True, eq=False, slots=True)
class DetectorMode:
    """One detector as it runs in one mode: ``z+ = Fo z + Go y``, ``r = Ry y - Rz z``, ``y = C x + n``;
    ``H`` its decoupling matrix (zero for the central observer): at a switch from p to q,
    ``z <- z + (H_p - H_q) y``. Floats of the exact rationals the certificates are about
    (every entry rounded once)."""

    mode: str
    Fo: np.ndarray
    Go: np.ndarray
    Ry: np.ndarray
    Rz: np.ndarray
    H: np.ndarray


@dataclass(frozen=True, eq=False, slots=True)
class DeployedDetector:
    """A sampled detector in every mode of the schedule it has a certified model in.

    Attributes
    ----------
    name, kind : str
    channels : tuple of str
        Its measured channels (rows of ``C``) and residual components.
    C : ndarray
        (p, 2N) its measurement map on the plant state.
    modes : tuple of DetectorMode
    """

    name: str
    kind: str
    channels: tuple[str, ...]
    C: np.ndarray
    modes: tuple[DetectorMode, ...]

    def mode(self, mode: str) -> DetectorMode | None:
        """Its matrices in ``mode`` (None when it has no certified model there)."""
        return next((m for m in self.modes if m.mode == mode), None)


_KIND: Kind["SampledDeployment"] = Kind("sampled-deployment", __name__, "SampledDeployment")


@dataclass(frozen=True, slots=True)
class SampledDeployment:
    """The detectors of a sampled deployment, their thresholds over the schedule and Algorithm 1.

    Attributes
    ----------
    implementation : ImplementationSpec
    schedule : Schedule
        The defender's timed schedule.
    safe_mode : str or None
        Algorithm 1's safe mode (the spec's ``switching.mode``).
    detectors : tuple of DeployedDetector
        What runs, per mode of the schedule (the central observer also in the safe mode).
    thresholds : ScheduleThresholds
        Per detector and sample over the schedule (the first segment is ``detection.thresholds``'
        :class:`~glocal_verify.simulation.certified_thresholds.CertifiedThresholds`), the tail,
        and the control centre's thresholds after Algorithm 1's switch.
    guarantee : DetectionGuarantee or None
        The spec's attack (``[attack]``) against these thresholds; None without an attack.
    horizon : float
        Seconds of explicit thresholds (at least the spec's horizon and the last switch).
    notes : tuple of str
        What the deployment cannot promise.
    """

    implementation: ImplementationSpec
    schedule: Schedule
    safe_mode: str | None
    detectors: tuple[DeployedDetector, ...]
    thresholds: ScheduleThresholds
    guarantee: DetectionGuarantee | None
    horizon: float
    notes: tuple[str, ...]


def deployment_horizon(system: System, schedule: Schedule, period: float) -> float:
    """The thresholds' horizon: the spec's, extended past the schedule's last switch when it
    comes later (the last mode's tail covers every later sample)."""
    T = float(system.spec.simulation.horizon)
    last = max(schedule.switch_times, default=0.0)
    return max(T, math.ceil(last / period + 1e-9) * period + period)


def sampled_deployment(system: System, implementation: ImplementationSpec | None = None) -> SampledDeployment:
    """The sampled deployment of ``system`` (module docstring), computed once and kept on the system.

    Raises
    ------
    NotApplicableError
        Without a sampled ``[implementation]``, beyond ``guarantee_max_agents`` (:mod:`glocal_verify.config`) agents, or
        when no detector can be built.
    """
    if implementation is not None:
        return _compute(system, implementation)
    return _KIND.get(system, (), lambda: _compute(system, None))


def _compute(system: System, implementation: ImplementationSpec | None) -> SampledDeployment:
    impl = implementation_of(system, implementation)
    if impl.controller != "sampled":
        raise NotApplicableError("the detectors' exact model needs a sampled controller (implementation.controller = 'sampled')")
    if system.n > (most := config.get("guarantee_max_agents")):
        raise NotApplicableError(f"{system.n} agents > {most}: the dense composites are not built")
    schedule = Schedule.from_spec(system)
    h = float(impl.period)
    T = deployment_horizon(system, schedule, h)
    notes: list[str] = []
    if T > float(system.spec.simulation.horizon):
        notes.append(f"thresholds computed to t = {T:g} s to cover the schedule (its last switch at t = {max(schedule.switch_times):g} s lies beyond the spec's horizon of {float(system.spec.simulation.horizon):g} s)")
    cert = certified_thresholds(system, implementation=impl, horizon=T)
    sw = system.spec.switching
    safe = sw.mode if sw is not None and sw.mode is not None else None
    sched = schedule_thresholds(system, cert, schedule.segments, safe_mode=safe, implementation=impl)
    notes += list(sched.notes)
    if safe is None:
        notes.append("no safe mode for Algorithm 1 (switching.mode): a local alarm switches nothing and the control centre has no after-switch threshold")
    guarantee = None
    if system.spec.attack is not None:
        first_switch = sched.segments[1][0] if len(sched.segments) > 1 else None
        try:
            guarantee = detection_guarantee(system, mode=safe, implementation=impl, thresholds=cert, after_switch=sched.after_switch, before=first_switch)
        except NotApplicableError as exc:
            notes.append(f"detection guarantee of the spec's attack: {exc}")
    detectors = tuple(_deployed(system, ds, cert, safe) for ds in sched.detectors.values())
    return SampledDeployment(impl, schedule, safe, detectors, sched, guarantee, T, tuple(dict.fromkeys(notes)))


def _deployed(system: System, ds: DetectorSchedule, cert: Any, safe: str | None) -> DeployedDetector:
    """The floats of one detector's implementation in every mode it runs in."""
    seen: dict[str, DetectorMode] = {}
    pairs = list(ds.detectors)
    if ds.kind == "central" and safe is not None and all(m != safe for m, _ in pairs) and pairs:
        pairs.append((safe, pairs[0][1]))  # the central observer keeps the normal-mode model in every mode
    for mode, d in pairs:
        if mode in seen:
            continue
        H = to_float(d.Pn) if d.kind == "local" else np.zeros((d.Fo.nrows(), d.C.nrows()))
        seen[mode] = DetectorMode(mode, to_float(d.Fo), to_float(d.Go), to_float(d.Ry), to_float(d.Rz), H)
    first = pairs[0][1] if pairs else next(o for o in cert.detectors if o.name == ds.name)
    return DeployedDetector(ds.name, ds.kind, ds.channels, to_float(first.C), tuple(seen.values()))
