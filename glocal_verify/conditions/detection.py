"""The ``detection.*`` checkers: Algorithm 1's thresholds and detection, certified over the
whole uncertainty set of a sampled deployment.

* ``detection.thresholds`` -- every detector has a certified threshold: no attack-free run
  crosses it, for every admissible initial state, noise and disturbance
  (:func:`~glocal_verify.simulation.certified_thresholds.certified_thresholds`);
* ``detection.local-alarm`` -- every admissible run of the spec's attack raises this local
  observer's alarm within the horizon (Algorithm 1, line 3);
* ``detection.guarantee`` -- every admissible run raises the control centre's alarm within the
  horizon, after the local alarm and the switch to the safe mode (the whole of Algorithm 1;
  :func:`~glocal_verify.simulation.guarantees.detection_guarantee`).

They need ``[implementation]`` with a sampled controller (the detectors' exact model);
``[uncertainty]`` defaults to the box of half-width 1 without noise. The bounds are rigorous
floating-point bounds (no tolerance decides them): the results are ``numeric`` in both modes,
with no exact counterpart and no escalation.
"""

from __future__ import annotations

import math
from typing import Any

from glocal_verify import config
from glocal_verify.conditions.premises import missing_input
from glocal_verify.conditions.registry import CheckContext, checker, result
from glocal_verify.errors import GlocalVerifyError, NotApplicableError
from glocal_verify.derived import Kind
from glocal_verify.model import System
from glocal_verify.results import ConditionResult, Status
from glocal_verify.simulation.certified_thresholds import CertifiedThresholds
from glocal_verify.simulation.guarantees import DetectionGuarantee, detection_guarantee
from glocal_verify.simulation.sampled_deployment import SampledDeployment, sampled_deployment

__all__ = ["check_detection_thresholds", "check_local_alarm", "check_detection_guarantee", "shared_thresholds", "shared_guarantee"]


#: derived results this module keeps on the system (glocal_verify.derived)
_GUARANTEE_KIND: Kind[DetectionGuarantee] = Kind("detection-guarantee", __name__, "DetectionGuarantee")


def _numeric(ctx: CheckContext) -> CheckContext:
    """These results are numeric in both modes (certified bounds, no exact counterpart)."""
    return ctx if not ctx.exact else CheckContext(exact=False, tol=ctx.tol, options=ctx.options, fragile_below=ctx.fragile_below)


def shared_deployment(system: System) -> SampledDeployment:
    """The spec's sampled deployment (:func:`~glocal_verify.simulation.sampled_deployment.sampled_deployment`,
    computed once per system): the thresholds, schedule and guarantee the deployment file ships."""
    return sampled_deployment(system)


def shared_thresholds(system: System) -> CertifiedThresholds:
    """The spec's certified thresholds before any switch: the deployment's first segment."""
    return shared_deployment(system).thresholds.certified


def shared_guarantee(system: System, mode: str | None) -> DetectionGuarantee:
    """The spec's attack's guarantee for a switch to ``mode``: the deployment's when ``mode`` is its
    safe mode, else computed once per system and mode against the same thresholds."""
    dep = shared_deployment(system)
    if mode == dep.safe_mode and dep.guarantee is not None:
        return dep.guarantee
    sched = dep.thresholds
    first = sched.segments[1][0] if len(sched.segments) > 1 else None
    return _GUARANTEE_KIND.get(system, (mode,), lambda: detection_guarantee(system, mode=mode, thresholds=sched.certified, after_switch=sched.after_switch_to(system, mode), before=first))


@checker("detection.thresholds")
def check_detection_thresholds(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Certified thresholds for the central observer and every local observer.

    .. math::

        \\theta_{k,j} \\ge \\sup |r_{k,j}| \\text{ over every admissible attack-free run}
        \\quad (k < K),\\qquad \\theta^{tail}_j \\text{ for every } k \\ge K

    (the supremum is the sum of the initial-state, noise and disturbance terms, each attained;
    :mod:`glocal_verify.simulation.certified_thresholds`). Holds when the detector's error
    dynamics are certified stable and the bound is finite; undecided when the certificate is
    not found, or beyond 150 agents; no result without a sampled ``[implementation]``.

    Margin
        ``1 - theta_M``: the certified contraction of the error dynamics over the window.
    Witness
        peak and tail per channel, the slack between threshold and worst case, the
        certificate (window, ``||F^m0||``, ``kappa``, largest row error), the false-alarm bound
        with Gaussian noise; ``schedule``: per segment of the defender's schedule its mode,
        whether it is covered and its peak threshold, and the tail after the last switch
        (:mod:`glocal_verify.simulation.schedule_thresholds`: the thresholds the deployment
        file ships, :func:`~glocal_verify.simulation.sampled_deployment.sampled_deployment`).
    """
    impl = system.spec.implementation
    nctx = _numeric(ctx)
    if impl is not None and impl.controller == "sampled" and system.n > (most := config.get("guarantee_max_agents")):
        return [result("detection.thresholds", nctx, Status.UNDECIDED, note=f"not computed: {system.n} agents > {most} (dense detectors)")]
    if missing_input(system, "detection.thresholds") is not None:
        return []
    try:
        th = shared_thresholds(system)
    except (NotApplicableError, GlocalVerifyError) as exc:
        return [result("detection.thresholds", nctx, Status.UNDECIDED, note=f"not computed: {exc}")]
    out = []
    schedule = shared_deployment(system).thresholds.to_json()
    for name, t in th.observers.items():
        w = {**t.to_json(), "horizon_samples": th.horizon, "schedule": schedule["detectors"].get(name)}
        cert = t.certificate
        out.append(result("detection.thresholds", nctx, Status.HOLDS, scope={"observer": name}, margin=1.0 - float(cert["theta_M"]), witness=w, error_bound=float(cert["max_row_error"])))
    for note in th.notes:
        name = note.split(":", 1)[0]
        out.append(result("detection.thresholds", nctx, Status.UNDECIDED, scope={"observer": name}, note=note))
    return out


def _modes(system: System) -> list[str]:
    sw = system.spec.switching
    if sw is not None and sw.mode is not None:
        return [sw.mode]
    return list(system.safe_modes)


@checker("detection.local-alarm")
def check_local_alarm(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Algorithm 1, line 3: every admissible run of the spec's attack raises this observer's alarm.

    .. math:: a\\,(|\\rho_{k,j}| - \\mathrm{err}_{k,j}) > 2\\,\\theta_{k,j} \\text{ for some } k \\le K,\\ j

    with ``rho`` the attack's certified part of the residual (size 1) and ``a`` the attack's
    amplitude. Fails when the run with zero initial state, noise and disturbance provably never
    crosses (it is admissible); undecided otherwise.

    Margin
        ``log10(a / min_size)`` (positive when the size exceeds the smallest guaranteed one).
    Witness
        the guaranteed sample and time after the attack's start, the channel, the smallest
        guaranteed size within the horizon, the zero run's first crossing.
    """
    if missing_input(system, "detection.local-alarm") is not None:
        return []
    nctx = _numeric(ctx)
    modes: list[str | None] = list(_modes(system)) or [None]
    try:
        g = shared_guarantee(system, modes[0])
    except (NotApplicableError, GlocalVerifyError) as exc:
        return [result("detection.local-alarm", nctx, Status.UNDECIDED, note=f"not computed: {exc}")]
    out = []
    for s in g.local:
        if s.guaranteed is not None:
            st = Status.HOLDS
        elif s.zero_run is None:
            st = Status.FAILS
        else:
            st = Status.UNDECIDED
        margin = math.log10(g.size / s.min_size) if s.min_size else -math.inf
        out.append(result("detection.local-alarm", nctx, st, scope={"observer": s.observer}, margin=margin, witness={**s.to_json(), "size": g.size, "attack": dict(g.attack)}))
    return out


@checker("detection.guarantee")
def check_detection_guarantee(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Algorithm 1 as a whole: every admissible run raises the control centre's alarm in time.

    For the spec's attack of its amplitude: a local alarm is guaranteed by ``k_L``; for every
    switch sample ``s`` in ``[k_a + d, k_L + d]`` (``d = switch_delay``) the central residual
    certainly crosses its post-switch threshold by ``k_G(s)``; holds when all of this happens
    within the horizon (or the central observer's alarm is guaranteed before any switch).
    Fails when the zero run provably escapes; undecided otherwise. One result per safe mode
    (the spec's ``switching.mode`` when given).

    Margin
        Seconds left in the horizon after the worst-case global detection (``-inf`` when none).
    Witness
        :meth:`~glocal_verify.simulation.guarantees.DetectionGuarantee.to_json`: detected_by,
        within, switch window, global_within, global_detection, min_size, per-observer stages.
    """
    if missing_input(system, "detection.guarantee") is not None:
        return []
    nctx = _numeric(ctx)
    out = []
    for q in _modes(system):
        try:
            g = shared_guarantee(system, q)
        except (NotApplicableError, GlocalVerifyError) as exc:
            out.append(result("detection.guarantee", nctx, Status.UNDECIDED, scope={"mode": q}, note=f"not computed: {exc}"))
            continue
        margin = (g.horizon - g.global_detection) if g.global_detection is not None else -math.inf
        w: dict[str, Any] = g.to_json()
        out.append(result("detection.guarantee", nctx, g.status, scope={"mode": q}, margin=margin, witness=w, note="; ".join(g.notes) if g.status is Status.UNDECIDED else ""))
    return out
