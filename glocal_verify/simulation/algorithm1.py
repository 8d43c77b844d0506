"""Residual thresholds, Algorithm 1 and the ``switching.detects`` checker.

Thresholds (the paper leaves them to future work, Section III.E)
-----------------------------------------------------------------
The rule used by default (``ThresholdRule(kind="envelope")``) is an **attack-free worst-case
envelope**, not a calibration. Without an attack every residual is linear in the attack-free
initial state :math:`\\bar x_0` (the observers start from :math:`\\hat x(0) = 0`, so their
initial estimation error is :math:`\\bar x_0` itself): :math:`r(t) = \\Psi(t) \\bar x_0`, where
:math:`\\Psi(t)` contains the observer's error dynamics and, after a switch, the switching
discrepancy :math:`(A_q - A_1)\\bar x` of eq. ``obs_cent_error_normal`` (the defender knows its
own schedule). For the admissible set :math:`\\|\\bar x_0\\|_\\infty \\le b` (``box``, default 1,
the box :func:`~glocal_verify.simulation.schedule.random_initial_state` draws from) the tight bound of
component k is

.. math:: \\sup_{\\|\\bar x_0\\|_\\infty \\le b} |r_k(t)| = b \\sum_i |\\Psi_{k i}(t)|,

computed exactly by simulating the 2N unit initial states at once (one batch run of the
exact simulator). The threshold adds a rounding allowance that absorbs the simulator's own
floating-point error, ``rounding * max(b, ||s(t)||_2)`` (default ``rounding = 1e-9``, the
project's relative tolerance; s is the simulated state): a signal below 1e-9 of the state norm
is treated as zero, i.e. the detectors model exact arithmetic, not sensor noise. By
construction, attack-free runs from any initial state in the box never cross it (tested).

``kind="calibrated"`` is offered for very large networks where the 2N-column batch is too
costly: ``factor`` times the largest residual over ``runs`` random attack-free runs (a
statistical bound, not a guarantee).

Algorithm 1
-----------
:func:`algorithm1` runs the observers; a local residual crossing its threshold is a local
detection. The safe mode is the one given (``mode``, or the spec's ``switching.mode``) or, when
none is given, the best-ranked safe mode of :func:`rank_safe_modes` (conditions (i)-(iii) of
Theorem III.3 from :func:`glocal_verify.conditions.registry.check_conditions`). ``trigger="schedule"`` switches at
the spec's ``switching.time`` (the paper's figures, where node 5 "can trigger either of case
1's or case 2's switching topologies"); ``trigger="local"`` switches one output step after the
first local detection (the sampled Algorithm 1). The control centre detects when the global
residual crosses its threshold after the switch.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np

from glocal_verify.errors import ModelError
from glocal_verify.model import System
from glocal_verify.numerics.tolerance import DEFAULT_TOLERANCE
from glocal_verify.results import Status, jsonable
from glocal_verify.simulation.attacks import AttackModel, attack_from_spec
from glocal_verify.simulation.engine import simulate, simulate_runs
from glocal_verify.simulation.observer_models import ObserverBank
from glocal_verify.simulation.schedule import (
    Schedule,
    SimulationResult,
    random_initial_state,
)
from glocal_verify.simulation.step_operators import StepOperators
from glocal_verify.simulation.thresholds import (
    Crossing,
    ThresholdRule,
    Thresholds,
    attack_free_thresholds,
    first_crossing,
)
from glocal_verify.spec.types import NORMAL_MODE

__all__ = [
    "Event",
    "ModeRanking",
    "PostSwitch",
    "Algorithm1Result",
    "classify_post_switch",
    "run_algorithm1",
]

# --------------------------------------------------------------------------------------------
# safe modes


@dataclass(frozen=True, slots=True)
class ModeRanking:
    """A safe mode with the verdicts of Theorem III.3 (i)-(iii) (Algorithm 1, line 4).

    Attributes
    ----------
    mode : str
    statuses : mapping of condition id to Status or None
        None when the condition has no checker yet.
    margins : mapping of condition id to float or None
        Margins as reported; the eigenvalue gap is divided by ||L_q||_2 to make it relative.
    eligible : bool
        Every evaluated condition holds (and at least one was evaluated).
    score : float
        The smallest relative margin (ranking key; larger is safer).
    """

    mode: str
    statuses: Mapping[str, Status | None]
    margins: Mapping[str, float | None]
    eligible: bool
    score: float

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return jsonable(
            {
                "mode": self.mode,
                "statuses": {k: (v.value if v is not None else "not evaluated") for k, v in self.statuses.items()},
                "margins": dict(self.margins),
                "eligible": self.eligible,
                "score": self.score,
            }
        )


# --------------------------------------------------------------------------------------------
# post-switch behaviour


@dataclass(frozen=True, slots=True)
class PostSwitch:
    """How the global residual behaves after the switch.

    Attributes
    ----------
    attack_part : str
        Behaviour of the attack-induced part of the global residual (the residual of the
        attack-only run, exact by linearity): ``"invisible"`` (below the rounding allowance),
        ``"unbounded"`` (grows exponentially), ``"vanishing"`` (decays) or ``"persistent"``.
    rate : float or None
        Least-squares exponential rate (1/s) of the upper envelope of the attack part (maxima
        over eight windows of the second half of the post-switch interval); above 0.01/s it
        counts as unbounded growth, below -0.01/s as vanishing.
    attack_peak : float
        Largest attack-induced global residual relative to ``max(box, ||s||_2)``.
    full : str
        Behaviour of the whole global residual: ``"unbounded"``, ``"vanishing"`` (its last
        tenth is below 10 % of its post-switch peak) or ``"persistent"``.
    tail_ratio : float
        max |r| over the last tenth / max |r| over the post-switch window.
    """

    attack_part: str
    rate: float | None
    attack_peak: float
    full: str
    tail_ratio: float

    @property
    def summary(self) -> str:
        """Short human-readable description."""
        if self.full == "unbounded" or self.attack_part == "unbounded":
            return f"unbounded (grows like e^({self.rate:.3g} t))" if self.rate is not None else "unbounded"
        base = "bounded and vanishing" if self.full == "vanishing" else "bounded"
        if self.attack_part == "invisible":
            return base + "; the attack does not reach it"
        return base + f"; attack part {self.attack_part}"

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return jsonable(
            {
                "attack_part": self.attack_part,
                "rate": self.rate,
                "attack_peak": self.attack_peak,
                "full": self.full,
                "tail_ratio": self.tail_ratio,
                "summary": self.summary,
            }
        )


def classify_post_switch(
    full: SimulationResult,
    attack_only: SimulationResult,
    switch_time: float,
    *,
    observer: str = "central",
    rounding: float = DEFAULT_TOLERANCE.rtol,
    box: float = 1.0,
) -> PostSwitch:
    """Classify the global residual after ``switch_time`` (see :class:`PostSwitch`).

    Parameters
    ----------
    full : SimulationResult
        The attacked run.
    attack_only : SimulationResult
        The same run from a zero attack-free initial state (the attack's contribution).
    switch_time : float
    observer : str
        The observer whose residual is classified (the centralized one).
    rounding, box : float
        The threshold rule's rounding allowance and box.
    """
    mask = full.t >= switch_time - 1e-12
    t = full.t[mask]
    a = np.linalg.norm(attack_only.residuals[observer][mask], axis=1)
    r = np.linalg.norm(full.residuals[observer][mask], axis=1)
    scale = np.maximum(box, full.state_scale[mask])
    rel = a / scale
    attack_peak = float(rel.max()) if len(rel) else 0.0
    rate: float | None = None
    if len(t) < 4:
        return PostSwitch("invisible" if attack_peak <= rounding else "persistent", None, attack_peak, "persistent", 1.0)
    half = t >= t[0] + 0.5 * (t[-1] - t[0])
    if attack_peak <= rounding:
        part = "invisible"
    else:
        # rate of the upper envelope: maxima over 8 consecutive windows of the second half
        # (robust to oscillation of complex exponents and to the post-switch transient)
        th_, ah = t[half], a[half]
        chunks = [c for c in np.array_split(np.arange(len(th_)), 8) if len(c)]
        tm = np.array([th_[c].mean() for c in chunks])
        am = np.array([ah[c].max() for c in chunks])
        ok = am > 0
        if np.sum(ok) >= 3:
            rate = float(np.polyfit(tm[ok], np.log(am[ok]), 1)[0])
        if rate is not None and rate > 1e-2:
            part = "unbounded"
        elif rate is not None and rate < -1e-2:
            part = "vanishing"
        else:
            part = "persistent"
    tail = t >= t[-1] - 0.1 * (t[-1] - t[0])
    peak = float(r.max()) if len(r) else 0.0
    tail_ratio = float(r[tail].max() / peak) if peak > 0 else 0.0
    if part == "unbounded":
        whole = "unbounded"
    elif tail_ratio < 0.1:
        whole = "vanishing"
    else:
        whole = "persistent"
    return PostSwitch(part, rate, attack_peak, whole, tail_ratio)


# --------------------------------------------------------------------------------------------
# Algorithm 1


@dataclass(frozen=True, slots=True)
class Event:
    """Something that happened in a run: attack start, detections, the switch."""

    time: float
    kind: str
    detail: str
    observer: str | None = None
    mode: str | None = None

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return jsonable({"time": self.time, "kind": self.kind, "detail": self.detail, "observer": self.observer, "mode": self.mode})


@dataclass(frozen=True, slots=True)
class Algorithm1Result:
    """Outcome of :func:`algorithm1`.

    Attributes
    ----------
    system : str
    trigger : str
        ``"schedule"``, ``"local"`` or ``"none"``.
    schedule : Schedule
        The schedule that was run.
    chosen_mode : str or None
        The safe mode switched to.
    switch_time : float or None
    ranking : tuple of ModeRanking
    local : mapping of str to Crossing
        Per local observer, the first crossing before the switch (whole run without one).
    local_after : mapping of str to Crossing
        Per local observer, crossings after the switch.
    global_before, global_after : Crossing or None
        The centralized observer before and after the switch (None without that observer).
    events : tuple of Event
    residual_max : mapping
        Per observer: max |r| before and after the switch, absolute and relative to the state
        norm, and the same for the attack-induced part.
    post_switch : PostSwitch or None
    simulation : SimulationResult
        The attacked run (states recorded).
    attack_only : SimulationResult or None
    thresholds : Thresholds
    x0 : ndarray
        The attack-free initial state used.
    notes : tuple of str
    """

    system: str
    trigger: str
    schedule: Schedule
    chosen_mode: str | None
    switch_time: float | None
    ranking: tuple[ModeRanking, ...]
    local: Mapping[str, Crossing]
    local_after: Mapping[str, Crossing]
    global_before: Crossing | None
    global_after: Crossing | None
    events: tuple[Event, ...]
    residual_max: Mapping[str, Mapping[str, float]]
    post_switch: PostSwitch | None
    simulation: SimulationResult
    attack_only: SimulationResult | None
    thresholds: Thresholds
    x0: np.ndarray
    notes: tuple[str, ...] = ()

    @property
    def attack(self) -> AttackModel | None:
        """The simulated attack."""
        return self.simulation.attack

    @property
    def first_local(self) -> Crossing | None:
        """The earliest local detection before the switch, if any."""
        hits = [c for c in self.local.values() if c.detected]
        return min(hits, key=lambda c: c.time or 0.0) if hits else None

    @property
    def detected_globally(self) -> bool:
        """The control centre detected the attack after the switch."""
        return self.global_after is not None and self.global_after.detected

    def to_json(self) -> dict[str, Any]:
        """The JSON summary written by ``glocal-verify simulate``."""
        sim = self.simulation
        return jsonable(
            {
                "system": self.system,
                "trigger": self.trigger,
                "schedule": self.schedule.to_json(),
                "chosen_mode": self.chosen_mode,
                "switch_time": self.switch_time,
                "attack": self.attack.describe() if self.attack else None,
                "events": [e.to_json() for e in self.events],
                "detection": {
                    "local_before_switch": {k: v.to_json() for k, v in self.local.items()},
                    "local_after_switch": {k: v.to_json() for k, v in self.local_after.items()},
                    "global_before_switch": self.global_before.to_json() if self.global_before else None,
                    "global_after_switch": self.global_after.to_json() if self.global_after else None,
                },
                "residual_max": {k: dict(v) for k, v in self.residual_max.items()},
                "post_switch": self.post_switch.to_json() if self.post_switch else None,
                "safe_mode_ranking": [r.to_json() for r in self.ranking],
                "thresholds": {"rule": self.thresholds.rule.describe(), "kind": self.thresholds.rule.kind, "box": self.thresholds.rule.box, "rounding": self.thresholds.rule.rounding},
                "simulation": {
                    "method": sim.method,
                    "taylor_order": sim.taylor_order,
                    "internal_steps": sim.internal_steps,
                    "horizon": float(sim.t[-1]) if len(sim.t) else 0.0,
                    "step": float(sim.t[1] - sim.t[0]) if len(sim.t) > 1 else None,
                    "samples": len(sim.t),
                    "interrupted": sim.interrupted,
                    "observers": list(sim.residuals),
                },
                "notes": list(self.notes) + list(sim.notes),
            }
        )


_SENTINEL = "spec"


def _maxima(res: SimulationResult, ao: SimulationResult | None, ts: float | None, box: float) -> dict[str, dict[str, float]]:
    out: dict[str, dict[str, float]] = {}
    split = ts if ts is not None else math.inf
    for name, r in res.residuals.items():
        a = np.abs(r).max(axis=1) if r.shape[1] else np.zeros(len(res.t))
        scale = np.maximum(box, res.state_scale)
        pre = res.t < split - 1e-12
        post = ~pre
        d: dict[str, float] = {
            "before": float(a[pre].max()) if np.any(pre) else 0.0,
            "after": float(a[post].max()) if np.any(post) else 0.0,
            "before_relative": float((a / scale)[pre].max()) if np.any(pre) else 0.0,
            "after_relative": float((a / scale)[post].max()) if np.any(post) else 0.0,
        }
        if ao is not None:
            b = np.abs(ao.residuals[name]).max(axis=1) if r.shape[1] else np.zeros(len(res.t))
            d["attack_before_relative"] = float((b / scale)[pre].max()) if np.any(pre) else 0.0
            d["attack_after_relative"] = float((b / scale)[post].max()) if np.any(post) else 0.0
        out[name] = d
    return out


def _modes_entered(system: System, trig: str, mode: str | None, ranking: Sequence[ModeRanking]) -> tuple[str, ...]:
    """The modes a run of :func:`run_algorithm1` can enter (the local observers get a mode-matched
    design for these only): the schedule's, or the normal mode and the one safe mode the local
    trigger would switch to (``mode``, else the best-ranked eligible one)."""
    if trig == "none":
        return (NORMAL_MODE,)
    if trig == "schedule":
        return tuple(dict.fromkeys((NORMAL_MODE,) + tuple(Schedule.from_spec(system, mode).modes)))
    if mode is not None:
        return tuple(dict.fromkeys((NORMAL_MODE, system.check_mode(mode))))
    return (NORMAL_MODE,) + tuple(r.mode for r in ranking if r.eligible)[:1]


def run_algorithm1(
    system: System,
    ranking: Sequence[ModeRanking],
    *,
    attack: AttackModel | str | None = _SENTINEL,
    observers: ObserverBank | None = None,
    rule: ThresholdRule = ThresholdRule(),
    mode: str | None = None,
    trigger: str = "auto",
    no_switch: bool = False,
    delay: float | None = None,
    x0: np.ndarray | None = None,
    horizon: float | None = None,
    step: float | None = None,
    method: str = "auto",
    progress: bool = False,
) -> Algorithm1Result:
    """Run Algorithm 1 (``alg:detection_procedure``) on ``system`` with a given ranking of safe modes.

    Line 4 of the algorithm ("identify a safe mode that satisfies Theorem III.3 (i)-(iii)")
    is a verdict, so the ranking is computed by the caller:
    :func:`glocal_verify.conditions.detects.algorithm1` passes
    :func:`~glocal_verify.conditions.detects.rank_safe_modes`.

    Parameters
    ----------
    system : System
    ranking : sequence of ModeRanking
        Safe modes, best first (eligible modes first).
    attack : AttackModel, None or "spec"
        The attack (default: the spec's, :func:`~glocal_verify.simulation.attacks.attack_from_spec`);
        None runs attack-free.
    observers : ObserverBank, optional
        Default :meth:`ObserverBank.for_system` (central observer and every local UIO).
    rule : ThresholdRule
    mode : str, optional
        Safe mode to switch to (default: the spec's ``switching.mode`` with the schedule
        trigger, the best-ranked eligible mode with the local trigger).
    trigger : str
        ``"schedule"`` (the spec's switching time), ``"local"`` (switch after the first local
        detection) or ``"auto"`` (schedule when the spec gives a switching time or sequence).
    no_switch : bool
        Never switch (the normal mode throughout).
    delay : float, optional
        Local trigger: time from the local detection to the switch (default one output step).
    x0 : ndarray, optional
        Attack-free initial state (default :func:`~glocal_verify.simulation.schedule.random_initial_state`
        with the rule's box).
    horizon, step : float, optional
        Default: the spec's simulation settings.
    method : str
        Simulation method.
    progress : bool
        Progress bars on stderr.
    """
    atk: AttackModel | None
    atk = attack_from_spec(system) if isinstance(attack, str) else attack
    xbar = random_initial_state(system, rule.box) if x0 is None else np.asarray(x0, dtype=float)
    h = float(system.spec.simulation.step if step is None else step)
    notes: list[str] = []
    ranking = tuple(ranking)
    sw = system.spec.switching
    trig = trigger
    if no_switch:
        trig = "none"
    elif trig == "auto":
        trig = "schedule" if (sw is not None and (sw.time is not None or sw.sequence)) else "local"
    if trig not in ("schedule", "local", "none"):
        raise ModelError(f"unknown trigger {trigger!r} (expected auto, schedule or local)")
    bank = observers if observers is not None else ObserverBank.for_system(system, modes=_modes_entered(system, trig, mode, ranking))
    local_names = [o.name for o in bank if o.kind == "local"]
    ops = StepOperators()  # observer step operators shared by every run below
    chosen: str | None = None
    if trig == "none":
        sched = Schedule()
    elif trig == "schedule":
        sched = Schedule.from_spec(system, mode)
        chosen = sched.modes[-1] if len(sched.segments) > 1 else None
    else:
        # pass 1: normal mode only, find the first local detection
        s0 = Schedule()
        r0 = simulate(system, schedule=s0, attack=atk, observers=bank, x0=xbar, horizon=horizon, step=step, method=method, record_states=False, progress=progress, step_operators=ops)
        th0 = attack_free_thresholds(system, bank, s0, rule, horizon=horizon, step=step, method=method, progress=progress, step_operators=ops)
        hits = [first_crossing(r0, th0, nm) for nm in local_names]
        hits = [c for c in hits if c.detected]
        if not hits:
            sched = Schedule()
            notes.append("no local residual crossed its threshold: Algorithm 1 never switches")
        else:
            first = min(hits, key=lambda c: c.time or 0.0)
            if mode is not None:
                chosen = system.check_mode(mode)
            else:
                elig = [r for r in ranking if r.eligible]
                chosen = elig[0].mode if elig else None
                if chosen is None:
                    notes.append("no safe mode satisfies Theorem III.3 (i)-(iii): Algorithm 1 cannot switch")
            ts = (first.time or 0.0) + (h if delay is None else float(delay))
            T = float(system.spec.simulation.horizon if horizon is None else horizon)
            sched = Schedule()
            if chosen is not None and ts < T:
                sched = Schedule.single(chosen, ts)
            elif chosen is not None:
                notes.append(f"the local detection at t = {first.time:g} leaves no time to switch before the horizon")
                chosen = None
    ts_ = sched.switch_times[0] if sched.switch_times else None
    # the simulations first: their Taylor order is at least the envelope's (the exosystem adds to
    # the norm bound), so the envelope reuses their observer step operators (step_operators.py);
    # the attacked run and the attack-only run (x0_bar = 0) propagate together
    x0s = [xbar] if atk is None else [xbar, np.zeros(2 * system.n)]
    runs = simulate_runs(system, x0s, schedule=sched, attack=atk, observers=bank, horizon=horizon, step=step, method=method, progress=progress, step_operators=ops)
    res = runs[0]
    ao = runs[1] if atk is not None else None
    th = attack_free_thresholds(system, bank, sched, rule, horizon=horizon, step=step, method=method, progress=progress, step_operators=ops)
    split = ts_ if ts_ is not None else math.inf
    local = {nm: first_crossing(res, th, nm, 0.0, split) for nm in local_names}
    local_after = {nm: first_crossing(res, th, nm, split) for nm in local_names} if ts_ is not None else {}
    has_central = "central" in bank.names
    gb = first_crossing(res, th, "central", 0.0, split) if has_central else None
    ga = first_crossing(res, th, "central", split) if (has_central and ts_ is not None) else None
    post = None
    if has_central and ts_ is not None and ao is not None:
        post = classify_post_switch(res, ao, ts_, rounding=rule.rounding, box=rule.box)
    events: list[Event] = []
    if atk is not None:
        events.append(Event(atk.start, "attack-start", f"{atk.kind} on actuators {list(atk.actuators)} moving agents {list(atk.moved)}"))
    for nm, c in local.items():
        if c.detected:
            events.append(Event(c.time or 0.0, "local-detection", f"local residual {nm} crosses its threshold on {c.channel}", observer=nm))
    if gb is not None and gb.detected:
        events.append(Event(gb.time or 0.0, "global-detection", f"global residual crosses its threshold on {gb.channel} before any switch", observer="central"))
    for (t, m) in sched.segments[1:]:
        events.append(Event(t, "switch", f"topology switches to {m}", mode=m))
    if ga is not None and ga.detected:
        events.append(Event(ga.time or 0.0, "global-detection", f"control centre detects the attack: global residual crosses on {ga.channel}", observer="central"))
    for nm, c in local_after.items():
        if c.detected and not local[nm].detected:
            events.append(Event(c.time or 0.0, "local-detection-after-switch", f"local residual {nm} crosses its threshold after the switch", observer=nm))
    order = {"attack-start": 0, "local-detection": 1, "global-detection": 2, "switch": 3, "local-detection-after-switch": 4}
    events.sort(key=lambda e: (e.time, order.get(e.kind, 9) + (3 if e.kind == "global-detection" and ts_ is not None and e.time >= ts_ else 0)))
    if trig == "schedule" and chosen is not None:
        rk = next((r for r in ranking if r.mode == chosen), None)
        if rk is not None and not rk.eligible:
            notes.append(f"the scheduled mode {chosen} does not satisfy Theorem III.3 (i)-(iii)")
        fl = [c for c in local.values() if c.detected]
        if not fl:
            notes.append("no local detection precedes the scheduled switch (Algorithm 1 would not have switched)")
    return Algorithm1Result(
        system.name,
        trig,
        sched,
        chosen,
        ts_,
        ranking,
        local,
        local_after,
        gb,
        ga,
        tuple(events),
        _maxima(res, ao, ts_, rule.box),
        post,
        res,
        ao,
        th,
        xbar,
        tuple(notes),
    )
