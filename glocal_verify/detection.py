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
the box :func:`~glocal_verify.simulate.random_initial_state` draws from) the tight bound of
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
Theorem III.3 from :func:`glocal_verify.registry.verify`). ``trigger="schedule"`` switches at
the spec's ``switching.time`` (the paper's figures, where node 5 "can trigger either of case
1's or case 2's switching topologies"); ``trigger="local"`` switches one output step after the
first local detection (the sampled Algorithm 1). The control centre detects when the global
residual crosses its threshold after the switch.
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np

from .errors import GlocalVerifyError, ModelError, NotApplicableError
from .model import System
from .registry import CheckContext, checker, implemented_ids, verify
from .results import ConditionResult, Method, Status, jsonable
from .simulate import (
    AttackModel,
    ObserverBank,
    Schedule,
    SimulationResult,
    attack_from_spec,
    random_initial_state,
    simulate,
    zda_attack_from_direction,
)
from .spec import NORMAL_MODE, Label

__all__ = [
    "THEOREM_III3_IDS",
    "ThresholdRule",
    "Thresholds",
    "Crossing",
    "Event",
    "ModeRanking",
    "PostSwitch",
    "Algorithm1Result",
    "attack_free_thresholds",
    "first_crossing",
    "rank_safe_modes",
    "classify_post_switch",
    "algorithm1",
    "check_detects",
    "CaseSpec",
    "CaseOutcome",
    "PAPER_CLAIMS",
    "cases_for",
    "companion_systems",
    "run_case",
    "case_findings",
]

#: the conditions Algorithm 1 (line 4) evaluates for a safe mode
THEOREM_III3_IDS = ("switching.image-kernel", "switching.distinct-eigenvalues", "switching.eigenvector-differences")

#: largest network on which ``switching.detects`` simulates (each mode: one 2N-column batch)
DETECTS_MAX_AGENTS = 150


# --------------------------------------------------------------------------------------------
# thresholds


@dataclass(frozen=True, slots=True)
class ThresholdRule:
    """How residual thresholds are set (module docstring).

    Attributes
    ----------
    kind : str
        ``"envelope"`` (exact worst case over the box of attack-free initial states) or
        ``"calibrated"`` (``factor`` x the maximum over ``runs`` random attack-free runs).
    box : float
        Half-width b of the admissible attack-free initial states, ``|x0_bar|_inf <= b``.
    rounding : float
        Rounding allowance relative to ``max(box, ||s(t)||_2)``.
    runs, factor, seed : int, float, int
        Parameters of the calibrated rule.
    """

    kind: str = "envelope"
    box: float = 1.0
    rounding: float = 1e-9
    runs: int = 16
    factor: float = 2.0
    seed: int = 12345

    def describe(self) -> str:
        """One sentence stating the rule."""
        if self.kind == "envelope":
            return (
                f"exact attack-free envelope: sup of |r_k(t)| over all initial states with |x0|_inf <= {self.box:g} "
                f"(observers from x_hat(0) = 0, the defender's switching schedule included), plus a rounding "
                f"allowance of {self.rounding:g} x max({self.box:g}, ||state||_2)"
            )
        return (
            f"calibrated: {self.factor:g} x the largest |r_k(t)| over {self.runs} random attack-free runs "
            f"(|x0|_inf <= {self.box:g}), plus a rounding allowance of {self.rounding:g} x max({self.box:g}, ||state||_2)"
        )


@dataclass(frozen=True, slots=True)
class Thresholds:
    """Attack-free envelopes per observer and the rule that made them.

    Attributes
    ----------
    rule : ThresholdRule
    t : ndarray
        Sample times.
    envelope : mapping of str to ndarray
        Per observer, (K + 1, q) attack-free bound of each residual component.
    schedule : Schedule
        The schedule the envelope was computed for.
    """

    rule: ThresholdRule
    t: np.ndarray
    envelope: Mapping[str, np.ndarray]
    schedule: Schedule

    def bound(self, name: str, state_scale: np.ndarray) -> np.ndarray:
        """Threshold of observer ``name`` for a run whose state norm is ``state_scale`` (K + 1,)."""
        env = self.envelope[name]
        k = min(len(env), len(state_scale))
        allow = self.rule.rounding * np.maximum(self.rule.box, state_scale[:k])
        return env[:k] + allow[:, None]


def attack_free_thresholds(
    system: System,
    observers: ObserverBank,
    schedule: Schedule,
    rule: ThresholdRule = ThresholdRule(),
    *,
    horizon: float | None = None,
    step: float | None = None,
    method: str = "auto",
) -> Thresholds:
    """Attack-free residual envelopes for ``schedule`` (module docstring).

    Parameters
    ----------
    system : System
    observers : ObserverBank
    schedule : Schedule
        The defender's schedule (switches included in the envelope).
    rule : ThresholdRule
    horizon, step : float, optional
        Default: the spec's simulation settings.
    method : str
        Simulation method (:func:`~glocal_verify.simulate.simulate`).
    """
    n2 = 2 * system.n
    if rule.kind == "envelope":
        X = rule.box * np.eye(n2)
        res = simulate(system, schedule=schedule, observers=observers, x0=X, horizon=horizon, step=step, method=method, batch_reduce="abs-sum")
        env = {k: v.copy() for k, v in res.residuals.items()}
    elif rule.kind == "calibrated":
        rng = np.random.default_rng(rule.seed)
        X = rng.uniform(-rule.box, rule.box, size=(n2, rule.runs))
        res = simulate(system, schedule=schedule, observers=observers, x0=X, horizon=horizon, step=step, method=method, batch_reduce="max-abs")
        env = {k: rule.factor * v for k, v in res.residuals.items()}
    else:
        raise ModelError(f"unknown threshold rule {rule.kind!r} (expected envelope or calibrated)")
    return Thresholds(rule, res.t, env, schedule)


# --------------------------------------------------------------------------------------------
# crossings


@dataclass(frozen=True, slots=True)
class Crossing:
    """First threshold crossing of one observer in a time window (or none).

    Attributes
    ----------
    observer : str
    time : float or None
        First sample time with |r_k| > threshold_k for some k (None: no crossing).
    channel : str or None
        The component that crossed first.
    peak_ratio : float
        max over the window and components of |r_k| / threshold_k.
    peak_time : float or None
        Where that maximum is reached.
    window : (float, float)
    """

    observer: str
    time: float | None
    channel: str | None
    peak_ratio: float
    peak_time: float | None
    window: tuple[float, float]

    @property
    def detected(self) -> bool:
        """True when the residual crossed its threshold in the window."""
        return self.time is not None

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return jsonable(
            {
                "observer": self.observer,
                "detected": self.detected,
                "time": self.time,
                "channel": self.channel,
                "peak_ratio": self.peak_ratio,
                "peak_time": self.peak_time,
                "window": list(self.window),
            }
        )


def first_crossing(
    result: SimulationResult,
    thresholds: Thresholds,
    observer: str,
    start: float = 0.0,
    stop: float = math.inf,
) -> Crossing:
    """First sample in ``[start, stop)`` at which a residual component of ``observer`` exceeds
    its threshold.

    Parameters
    ----------
    result : SimulationResult
    thresholds : Thresholds
    observer : str
    start, stop : float
        Time window (half-open).
    """
    r = np.abs(result.residuals[observer])
    thr = thresholds.bound(observer, result.state_scale)
    k = min(len(r), len(thr))
    r, thr, t = r[:k], thr[:k], result.t[:k]
    mask = (t >= start - 1e-12) & (t < stop - 1e-12)
    win = (float(start), float(min(stop, t[-1] if len(t) else stop)))
    if not np.any(mask) or r.shape[1] == 0:
        return Crossing(observer, None, None, 0.0, None, win)
    ratio = np.where(thr > 0, r / np.where(thr > 0, thr, 1.0), np.where(r > 0, np.inf, 0.0))
    rw = ratio[mask]
    tw = t[mask]
    flat = int(np.argmax(rw))
    i_peak, _ = np.unravel_index(flat, rw.shape)
    over = np.any(rw > 1.0, axis=1)
    ch = result.channels[observer]
    if not np.any(over):
        return Crossing(observer, None, None, float(rw.max()), float(tw[i_peak]), win)
    i = int(np.argmax(over))
    j = int(np.argmax(rw[i]))
    return Crossing(observer, float(tw[i]), ch[j], float(rw.max()), float(tw[i_peak]), win)


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


def rank_safe_modes(system: System, modes: Sequence[str] | None = None) -> tuple[ModeRanking, ...]:
    """Rank safe modes by Theorem III.3 (i)-(iii): eligible modes first, then by score.

    Uses :func:`glocal_verify.registry.verify` with :data:`THEOREM_III3_IDS`. The score of a
    mode is the smallest of its margins on a relative scale: sigma_min of (i) (in [0, 1]),
    the smallest eigenvalue gap of (ii) divided by ||L_q||_2, and the margin of (iii) as its
    checker reports it.

    Parameters
    ----------
    system : System
    modes : sequence of str, optional
        Default: every safe mode.
    """
    wanted = list(system.safe_modes if modes is None else modes)
    ids = [c for c in THEOREM_III3_IDS if c in implemented_ids()]
    report = verify(system, ids) if ids and wanted else None
    out = []
    for q in wanted:
        st: dict[str, Status | None] = {}
        mg: dict[str, float | None] = {}
        for cid in THEOREM_III3_IDS:
            rs = [r for r in report.results(cid) if r.scope.get("mode") == q] if report else []
            if not rs:
                st[cid], mg[cid] = None, None
                continue
            r = rs[0]
            st[cid] = r.status
            m = r.margin
            if cid == "switching.distinct-eigenvalues" and m is not None:
                w = system.eigh(q)[0]
                m = float(m) / max(float(np.max(np.abs(w))), 1e-300)
            mg[cid] = m
        evaluated = [s for s in st.values() if s is not None]
        eligible = bool(evaluated) and all(s is Status.HOLDS for s in evaluated)
        vals = [float(v) for v in mg.values() if v is not None and math.isfinite(float(v))]
        score = min(vals) if vals else 0.0
        out.append(ModeRanking(q, st, mg, eligible, score))
    out.sort(key=lambda r: (not r.eligible, -r.score))
    return tuple(out)


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
    rounding: float = 1e-9,
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


def algorithm1(
    system: System,
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
    """Run Algorithm 1 (``alg:detection_procedure``) on ``system``.

    Parameters
    ----------
    system : System
    attack : AttackModel, None or "spec"
        The attack (default: the spec's, :func:`~glocal_verify.simulate.attack_from_spec`);
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
        Attack-free initial state (default :func:`~glocal_verify.simulate.random_initial_state`
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
    bank = observers if observers is not None else ObserverBank.for_system(system)
    xbar = random_initial_state(system, rule.box) if x0 is None else np.asarray(x0, dtype=float)
    h = float(system.spec.simulation.step if step is None else step)
    notes: list[str] = []
    ranking = rank_safe_modes(system)
    sw = system.spec.switching
    trig = trigger
    if no_switch:
        trig = "none"
    elif trig == "auto":
        trig = "schedule" if (sw is not None and (sw.time is not None or sw.sequence)) else "local"
    if trig not in ("schedule", "local", "none"):
        raise ModelError(f"unknown trigger {trigger!r} (expected auto, schedule or local)")
    local_names = [o.name for o in bank if o.kind == "local"]
    chosen: str | None = None
    if trig == "none":
        sched = Schedule()
    elif trig == "schedule":
        sched = Schedule.from_spec(system, mode)
        chosen = sched.modes[-1] if len(sched.segments) > 1 else None
    else:
        # pass 1: normal mode only, find the first local detection
        s0 = Schedule()
        th0 = attack_free_thresholds(system, bank, s0, rule, horizon=horizon, step=step, method=method)
        r0 = simulate(system, schedule=s0, attack=atk, observers=bank, x0=xbar, horizon=horizon, step=step, method=method, record_states=False, progress=progress)
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
    th = attack_free_thresholds(system, bank, sched, rule, horizon=horizon, step=step, method=method)
    res = simulate(system, schedule=sched, attack=atk, observers=bank, x0=xbar, horizon=horizon, step=step, method=method, progress=progress)
    ao = None
    if atk is not None:
        ao = simulate(system, schedule=sched, attack=atk, observers=bank, x0=np.zeros(2 * system.n), horizon=horizon, step=step, method=method, progress=progress)
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


# --------------------------------------------------------------------------------------------
# the switching.detects checker


_DETECTS_CACHE: "weakref.WeakKeyDictionary[System, dict[Any, list[ConditionResult]]]" = weakref.WeakKeyDictionary()


def _dl_xi(system: System, mode: str, attack: AttackModel) -> float | None:
    """||dL_q xi|| / ||xi|| (complex xi allowed): does the switch touch the ZDA (Remark III.3.1)?"""
    if attack.xi is None:
        return None
    xi = np.asarray(attack.xi)
    return float(np.linalg.norm(system.delta_laplacian(mode) @ xi) / max(float(np.linalg.norm(xi)), 1e-300))


@checker("switching.detects")
def check_detects(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Theorem III.3's conclusion, checked by simulation (opt-in).

    For every safe mode q: simulate the spec's attack (``stealthy.zda`` direction, or the
    covert attack) from a random attack-free initial state in the box, the centralized
    observer of eq. ``obs_cent`` (normal-mode model), and a switch to q at the spec's switching
    time; the condition **holds** when, after the switch, the global residual
    :math:`r_0 = y - C\\hat x` leaves its attack-free band (:class:`ThresholdRule`, exact
    envelope over :math:`\\|\\bar x_0\\|_\\infty \\le 1` including the switch, plus the rounding
    allowance ``rtol * max(1, ||s(t)||_2)``). Formally, with :math:`t_1` the switching time,

    .. math:: \\exists\\, t \\ge t_1,\\ k:\\ |r_{0,k}(t)| > \\theta_k(t).

    Opt-in: it runs only when the check context has ``options["simulate"]`` true (e.g.
    ``verify(system, ["switching.detects"], options={"simulate": True})``; ``glocal-verify
    simulate`` reports it), the spec has an attack and a ``[switching]`` table, the system has
    at most ``options["max_agents"]`` agents (default 150) and the numeric path is requested
    (a simulation has no exact counterpart: in exact mode the checker returns nothing).

    Tolerance rule
        The attack-induced part of the residual (the attack-only run, exact by linearity)
        relative to ``max(1, ||s||_2)`` is decided with the context tolerance: zero at or below
        ``rtol``, nonzero above ``rtol * band``. A crossing by a residual whose attack part is
        not certainly nonzero is ``undecided`` (rounding could have caused it).
    Margin
        log10 of the largest post-switch ratio |r_k| / threshold_k (> 0 iff crossed).
    Witness
        switch time, detection time and channel, delay, post-switch behaviour (attack part
        invisible / vanishing / unbounded, exponential rate), ||dL_q xi|| / ||xi|| for a ZDA,
        the attack (kind, lambda0, moved agents), the threshold rule, horizon, step, seed.
    """
    if ctx.exact or not ctx.options.get("simulate"):
        return []
    spec = system.spec
    if spec.attack is None or spec.switching is None or not system.safe_modes:
        return []
    limit = int(ctx.options.get("max_agents", DETECTS_MAX_AGENTS))
    key = (ctx.tol.rtol, ctx.tol.band, limit)
    cached = _DETECTS_CACHE.get(system, {}).get(key)
    if cached is not None:
        return list(cached)
    out: list[ConditionResult] = []

    def res(mode: str, status: Status, margin: float | None, witness: Mapping[str, Any]) -> ConditionResult:
        from .registry import CATALOGUE

        info = CATALOGUE["switching.detects"]
        return ConditionResult(
            "switching.detects",
            {"mode": mode},
            status,
            margin,
            ctx.tol.rtol,
            Method.NUMERIC,
            dict(witness),
            info.reference,
            info.statement,
        )

    if system.n > limit:
        for q in system.safe_modes:
            out.append(res(q, Status.UNDECIDED, None, {"note": f"not simulated: {system.n} agents > max_agents = {limit}"}))
        return out
    try:
        atk = attack_from_spec(system)
        bank = ObserverBank.for_system(system, local=False)
        if "central" not in bank.names:
            raise NotApplicableError("; ".join(bank.notes) or "no centralized observer")
        base = Schedule.from_spec(system)
    except (GlocalVerifyError, ImportError) as exc:
        for q in system.safe_modes:
            out.append(res(q, Status.UNDECIDED, None, {"note": f"cannot simulate: {exc}"}))
        return out
    if not base.switch_times:
        return []
    rule = ThresholdRule(rounding=ctx.tol.rtol)
    xbar = random_initial_state(system, rule.box)
    for q in system.safe_modes:
        atk_q, chosen_by = _attacker_choice(system, q, atk, ctx)
        r = algorithm1(system, attack=atk_q, observers=bank, rule=rule, mode=q, trigger="schedule", x0=xbar)
        ga = r.global_after
        assert ga is not None and r.post_switch is not None and r.switch_time is not None
        peak = r.post_switch.attack_peak
        dec = ctx.tol.decide(peak, 1.0)
        if not ga.detected:
            status = Status.FAILS
        elif dec.value == "nonzero":
            status = Status.HOLDS
        else:
            status = Status.UNDECIDED
        margin = math.log10(ga.peak_ratio) if ga.peak_ratio > 0 else -math.inf
        witness: dict[str, Any] = {
            "switch_time": r.switch_time,
            "detected": ga.detected,
            "detection_time": ga.time,
            "delay": (ga.time - r.switch_time) if ga.time is not None else None,
            "channel": ga.channel,
            "peak_ratio": ga.peak_ratio,
            "post_switch": r.post_switch.to_json(),
            "attack": atk_q.describe() if atk_q else None,
            "attack_direction": chosen_by,
            "threshold_rule": rule.describe(),
            "horizon": float(r.simulation.t[-1]),
            "step": float(r.simulation.t[1] - r.simulation.t[0]),
            "seed": spec.simulation.seed,
        }
        if atk_q is not None:
            d = _dl_xi(system, q, atk_q)
            if d is not None:
                witness["dL_xi_relative"] = d
        if r.global_before is not None and r.global_before.detected:
            witness["note"] = "the global residual already crossed before the switch: the attack is not stealthy for this observer"
        out.append(res(q, status, margin, witness))
    _DETECTS_CACHE.setdefault(system, {})[key] = list(out)
    return out


def _attacker_choice(system: System, mode: str, atk: AttackModel | None, ctx: CheckContext) -> tuple[AttackModel | None, str]:
    """The ZDA an informed attacker would run against the switch to ``mode``.

    When some stealthy direction at lambda0 is not touched by the switch (``switching.safe``
    holds through :func:`glocal_verify.switching_safe.avoidance`), the attacker uses it: a
    detection verdict must hold against every stealthy direction, not only the one
    ``stealthy.zda`` happens to report.
    """
    if atk is None or atk.kind != "zda":
        return atk, "spec"
    from .switching_safe import avoidance

    av = avoidance(system, mode, ctx.tol)
    if av is None or av.status is not Status.HOLDS or av.direction is None or av.direction_source == "stealthy.zda":
        return atk, "stealthy.zda"
    a = system.spec.attack
    assert a is not None
    d = av.direction
    return (
        zda_attack_from_direction(system, d.lambda0, d.xi, d.u0, amplitude=a.amplitude, start=a.start),
        "avoiding direction of switching.safe",
    )


# --------------------------------------------------------------------------------------------
# cases (the paper's Section IV)


#: the paper's sentences per (system name, mode), with the observable outcome they predict:
#: ``"vanishing"`` -- the post-switch global residual is bounded and vanishes;
#: ``"unbounded"`` -- it grows without bound; ``"no-detection"`` -- the control centre does not detect.
PAPER_CLAIMS: dict[tuple[str, str], tuple[str, str]] = {
    ("paper19", "case-1"): (
        "vanishing",
        "Section IV: conditions (i)-(iii) are met; 'the global residual r_{0_1}(t) for case 1 is bounded and vanishing after topology switching'",
    ),
    ("paper19", "case-2"): (
        "unbounded",
        "Section IV: conditions (i)-(iii) are met; 'that of case 2 is unbounded'",
    ),
    ("paper19-case3", "case-3"): (
        "no-detection",
        "Section IV: 'none of the Theorem III.3's conditions are met in case 3, yielding the global residuals ... remain unaffected by the switching topology. Consequently, stealthy attack is not detectable'",
    ),
}

#: the sentence every case shares
PRE_SWITCH_CLAIM = "ZDA is stealthy in the global residuals before topology switching; it is detectable in a local residual"


@dataclass(frozen=True, slots=True)
class CaseSpec:
    """One case of a case study: a system (with its own attack) and the safe mode it switches to.

    Attributes
    ----------
    name : str
    system : System
    mode : str
    expect : str or None
        ``"vanishing"``, ``"unbounded"`` or ``"no-detection"`` (the paper's claim), or None.
    claim : str
        The paper's sentence.
    """

    name: str
    system: System
    mode: str
    expect: str | None = None
    claim: str = ""


@dataclass(frozen=True, slots=True)
class CaseOutcome:
    """A case's simulated outcome next to the verdicts that predicted it.

    Attributes
    ----------
    case : CaseSpec
    result : Algorithm1Result
    verdicts : mapping of condition id to status (str)
        Verdicts of the case's system in the case's mode (and the global ones).
    observed : str
        Behaviour of the post-switch global residual: ``"vanishing"``, ``"unbounded"`` or
        ``"persistent"`` (:class:`PostSwitch`).
    detected : bool
        The control centre detected the attack after the switch.
    pre_switch_ok : bool
        The attack is invisible in the global residual and detected locally before the switch.
    agrees : bool or None
        ``observed`` matches ``expect`` (None without a claim).
    """

    case: CaseSpec
    result: Algorithm1Result
    verdicts: Mapping[str, str]
    observed: str
    detected: bool
    pre_switch_ok: bool
    agrees: bool | None

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (the case table row plus the run summary)."""
        return jsonable(
            {
                "case": self.case.name,
                "system": self.case.system.name,
                "mode": self.case.mode,
                "paper_claim": self.case.claim,
                "expected": self.case.expect,
                "observed": self.observed,
                "detected": self.detected,
                "agrees": self.agrees,
                "pre_switch_ok": self.pre_switch_ok,
                "verdicts": dict(self.verdicts),
                "run": self.result.to_json(),
            }
        )


def companion_systems(system: System) -> dict[str, System]:
    """Companion specs of ``system``: for a safe mode q, a spec named ``<name>-<q>`` (hyphens
    in q optional) that carries case q's own attack.

    Bundled examples are searched for a bundled system (``paper19`` finds ``paper19-case3``
    for mode ``case-3``); for a file, ``<stem>-<q>.toml`` next to it. A companion must define
    the mode q.

    Parameters
    ----------
    system : System
    """
    from pathlib import Path

    from .spec import example_names, load_example, load_spec

    src = system.spec.source or ""
    out: dict[str, System] = {}
    for q in system.safe_modes:
        cands = [f"{system.name}-{q}", f"{system.name}-{q.replace('-', '')}"]
        found: System | None = None
        if src.startswith("<example "):
            for c in cands:
                if c in example_names():
                    found = System(load_example(c))
                    break
        elif src:
            base = Path(src)
            for c in (f"{base.stem}-{q}", f"{base.stem}-{q.replace('-', '')}"):
                p = base.with_name(f"{c}.toml")
                if p.exists():
                    found = System(load_spec(p))
                    break
        if found is not None and q in found.modes:
            out[q] = found
    return out


def cases_for(system: System, companions: Mapping[str, System] | None = None) -> list[CaseSpec]:
    """One case per safe mode of ``system``; a mode listed in ``companions`` uses that system
    (which carries the case's own attack, e.g. ``paper19-case3`` for case 3).

    Parameters
    ----------
    system : System
    companions : mapping of mode name to System, optional
    """
    out = []
    comp = dict(companions or {})
    for q in system.safe_modes:
        s = comp.get(q, system)
        exp, claim = PAPER_CLAIMS.get((s.name, q), (None, ""))
        out.append(CaseSpec(q, s, q, exp, claim))
    return out


#: condition ids whose verdicts the case table shows (those implemented)
CASE_VERDICT_IDS = (
    "stealthy.zda",
    "switching.image-kernel",
    "switching.distinct-eigenvalues",
    "switching.eigenvector-differences",
    "switching.coverage",
    "switching.safe",
)


def _verdicts(system: System, mode: str) -> dict[str, str]:
    ids = [c for c in CASE_VERDICT_IDS if c in implemented_ids()]
    out: dict[str, str] = {}
    if not ids:
        return out
    rep = verify(system, ids)
    for cid in ids:
        rs = [r for r in rep.results(cid) if r.scope.get("mode") in (None, mode)]
        if not rs:
            continue
        sts = {r.status.value for r in rs}
        out[cid] = sts.pop() if len(sts) == 1 else "mixed"
    return out


def run_case(case: CaseSpec, *, rule: ThresholdRule = ThresholdRule(), method: str = "auto", progress: bool = False) -> CaseOutcome:
    """Simulate one case with the scheduled switch and compare with the paper's claim.

    Parameters
    ----------
    case : CaseSpec
    rule : ThresholdRule
    method : str
    progress : bool
    """
    r = algorithm1(case.system, mode=case.mode, trigger="schedule", rule=rule, method=method, progress=progress)
    ps = r.post_switch
    if ps is None:
        observed = "no-switch"
    elif "unbounded" in (ps.full, ps.attack_part):
        observed = "unbounded"
    else:
        observed = ps.full
    mx = r.residual_max.get("central", {})
    pre_ok = (
        (r.global_before is None or not r.global_before.detected)
        and mx.get("attack_before_relative", 0.0) <= r.thresholds.rule.rounding
        and r.first_local is not None
    )
    agrees = None
    if case.expect == "no-detection":
        agrees = not r.detected_globally
    elif case.expect is not None:
        agrees = observed == case.expect
    return CaseOutcome(case, r, _verdicts(case.system, case.mode), observed, r.detected_globally, bool(pre_ok), agrees)


def case_findings(outcomes: Sequence[CaseOutcome]) -> list[str]:
    """Places where the simulated cases contradict the paper (Markdown sentences).

    * Theorem III.3 says (i)-(iii) are sufficient for ZDA detection when the system is not at
      consensus: a case where every evaluated condition of (i)-(iii) holds and the control
      centre does not detect is a counterexample.
    * Remark III.3.1 / Section IV: the text says only case 2 meets eq. ``unsafe_set`` and that
      case 2 is unbounded, while the remark says meeting it keeps the residual bounded and
      vanishing; the simulation says which case's switch avoids the attack (dL_q xi = 0).

    Parameters
    ----------
    outcomes : sequence of CaseOutcome
    """
    out: list[str] = []
    for oc in outcomes:
        th = [oc.verdicts.get(c) for c in THEOREM_III3_IDS]
        evaluated = [v for v in th if v is not None]
        atk = oc.result.attack
        if evaluated and all(v == "holds" for v in evaluated) and not oc.detected and atk is not None and atk.kind == "zda":
            d = _dl_xi(oc.case.system, oc.case.mode, atk)
            out.append(
                f"Theorem III.3 (sufficiency) fails on {oc.case.system.name} / {oc.case.name}: conditions "
                f"{', '.join(c for c, v in zip(THEOREM_III3_IDS, th) if v is not None)} hold, the initial state is "
                f"random (not at consensus), yet the control centre never detects the ZDA "
                f"(||dL_q xi|| / ||xi|| = {d:.1e}: the switch does not touch the agents the ZDA moves, so the "
                f"ZDA is still a zero direction of (A_q, B, C) and the residual equals the attack-free one). "
                f"The paper's 'trade-off between a faster attack detection ... and a slower detection' "
                f"(Section IV) cannot hold for such a switch on any graph: there is no detection, slow or fast. "
                f"Minimal counterexample (3 agents): reports/findings/theorem3-sufficiency-switch-avoids-zda.toml."
            )
    touch = {oc.case.name: _dl_xi(oc.case.system, oc.case.mode, oc.result.attack) for oc in outcomes if oc.result.attack is not None and oc.result.attack.xi is not None}
    bounded = [nm for nm, d in touch.items() if d is not None and d <= 1e-9 and any(o.case.name == nm and o.observed == "vanishing" for o in outcomes)]
    unbounded = [oc.case.name for oc in outcomes if oc.observed == "unbounded"]
    if any(oc.case.expect == "unbounded" for oc in outcomes) and unbounded:
        out.append(
            "Section IV vs Remark III.3.1: three sentences cannot all hold, on any graph: (a) the remark, 'the "
            "discrepancy term ... will be bounded and vanishing if (unsafe_set) holds'; (b) Section IV, 'only case 2 "
            "meets (unsafe_set)'; (c) Section IV, 'that [residual] of case 2 is unbounded'. (a) and (b) make case 2 "
            "bounded, against (c). Simulation supports (a) and (c) with X_q ∩ Z = ∅ read as 'the switch does not touch "
            f"the states the attack moves': the cases whose switch avoids the moved agents ({', '.join(bounded) or 'none'}) "
            f"are bounded and vanishing, the case whose switch touches them ({', '.join(unbounded)}) is unbounded. "
            "Sentence (b) is the one that fails: it is case 1, not case 2, that meets (unsafe_set). Touching is not "
            "sufficient either: reports/findings/remark-touching-switch-hides-zda.toml (3 agents) touches the ZDA and "
            "the residual stays exactly attack-free, because Theorem III.3 (ii) fails there."
        )
    return out
