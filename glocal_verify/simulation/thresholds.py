"""Residual thresholds: the attack-free worst-case envelope, and the first crossing of a residual.

The paper leaves thresholds to future work; the default rule bounds every attack-free
residual over a box of initial states exactly (see :class:`ThresholdRule`).

**The envelope.** Attack-free, the residual of an observer is linear in the initial plant
state: :math:`r(t) = \\Psi(t)\\,\\bar x_0` with :math:`\\Psi(t) = R\\,\\Phi(t, 0)\\,E_0`, where
:math:`\\Phi` is the transition matrix of plant + observer under the schedule,
:math:`R = [R_y C, -R_z]` the residual map and :math:`E_0 = [I; Z_0]` the initial state map.
Over the box :math:`\\|\\bar x_0\\|_\\infty \\le b` the supremum of :math:`|r_k(t)|` is
:math:`b \\sum_j |\\Psi_{kj}(t)|` (attained at a vertex, the sign pattern of row k).

:func:`attack_free_thresholds` computes :math:`\\Psi(t)` row-wise (the adjoint recursion):
inside a segment of constant mode q starting at :math:`\\tau`,
:math:`\\Psi(\\tau + s) = Q(s)\\,P_\\tau` with :math:`Q(s) = R\\,e^{M_q s}` (q rows,
:math:`Q(s + h) = Q(s)\\,e^{M_q h}`: the exponentials of one constant matrix commute) and
:math:`P_\\tau = \\Phi(\\tau, 0) E_0` (the 2N unit initial states at the segment start, obtained
at a switch by binary powers of the step propagator: :math:`O(\\log(\\tau/h))` dense products
instead of one per step). The plant is kept in the eigenbasis of :math:`L_q` (2 x 2 modal
blocks) and the observer input over a step is its Taylor polynomial with the a priori
remainder bound of the modal simulator (:mod:`glocal_verify.simulation.engine`: same J, same
internal steps), so every step propagator is the one the simulator applies, to rounding. How
the rows and columns are computed (the rank-:math:`p(J+1)` input map, blocks of rows by powers
of the observer step, modal columns) is in :mod:`glocal_verify.simulation.envelope`. Cost per
output step and observer: about :math:`O(q\\,n_o^2 + q\\,(2N + n_o)\\,2N)` instead of
:math:`O((2N + n_o)^2 \\cdot 2N)` for propagating the 2N unit states
(:func:`envelope_by_columns`, the former computation, kept as the reference the tests compare
with).
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from glocal_verify.errors import ModelError
from glocal_verify.model import System
from glocal_verify.results import jsonable
from glocal_verify.runtime.lines import write_line
from glocal_verify.simulation.engine import simulate
from glocal_verify.simulation.envelope import Reporter, envelope_by_rows
from glocal_verify.numerics.tolerance import DEFAULT_TOLERANCE
from glocal_verify.simulation.observer_models import ObserverBank
from glocal_verify.simulation.schedule import Schedule, SimulationResult
from glocal_verify.simulation.step_operators import StepOperators

__all__ = [
    "ThresholdRule",
    "Thresholds",
    "Crossing",
    "attack_free_thresholds",
    "envelope_by_columns",
    "first_crossing",
]

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
    rounding: float = DEFAULT_TOLERANCE.rtol
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
    progress: bool = False,
    step_operators: StepOperators | None = None,
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
        Simulation method of the calibrated rule's runs
        (:func:`~glocal_verify.simulation.engine.simulate`). The envelope is always computed
        by the row recursion of the module docstring (exact to rounding, like both simulators).
    progress : bool
        Report progress on stderr: a tqdm bar with ETA when stderr is a terminal, else one
        line per phase (observer, segment, propagation to a switch).
    step_operators : StepOperators, optional
        Observer step operators shared with the simulations of the same system and step
        (:class:`~glocal_verify.simulation.step_operators.StepOperators`).
    """
    from glocal_verify.simulation.engine import check_stiffness

    check_stiffness(
        system,
        float(system.spec.simulation.horizon if horizon is None else horizon),
        float(system.spec.simulation.step if step is None else step),
    )
    if rule.kind == "envelope":
        t, env = envelope_by_rows(system, observers, schedule, rule.box, horizon, step, _reporter(progress), step_operators)
        return Thresholds(rule, t, env, schedule)
    if rule.kind == "calibrated":
        n2 = 2 * system.n
        rng = np.random.default_rng(rule.seed)
        X = rng.uniform(-rule.box, rule.box, size=(n2, rule.runs))
        res = simulate(system, schedule=schedule, observers=observers, x0=X, horizon=horizon, step=step, method=method, batch_reduce="max-abs", progress=progress and sys.stderr.isatty(), step_operators=step_operators)
        env = {k: rule.factor * v for k, v in res.residuals.items()}
        return Thresholds(rule, res.t, env, schedule)
    raise ModelError(f"unknown threshold rule {rule.kind!r} (expected envelope or calibrated)")


def envelope_by_columns(
    system: System,
    observers: ObserverBank,
    schedule: Schedule,
    box: float = 1.0,
    *,
    horizon: float | None = None,
    step: float | None = None,
    method: str = "auto",
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """The envelope by simulating the 2N unit initial states :math:`b e_j` (reference).

    :math:`b \\sum_j |r(t; e_j)|` per residual component, from one batch simulation
    (:func:`~glocal_verify.simulation.engine.simulate` with ``batch_reduce="abs-sum"``):
    :math:`O(K (2N + n_o)^2 \\cdot 2N)` work, the computation :func:`attack_free_thresholds`
    used before the row recursion. Kept for tests and for small systems.

    Parameters
    ----------
    system, observers, schedule : System, ObserverBank, Schedule
    box : float
        Half-width b of the box of initial states.
    horizon, step, method
        As for :func:`~glocal_verify.simulation.engine.simulate`.

    Returns
    -------
    (t, envelope)
        Sample times and, per observer, the (K + 1, q) envelope.
    """
    X = box * np.eye(2 * system.n)
    res = simulate(system, schedule=schedule, observers=observers, x0=X, horizon=horizon, step=step, method=method, batch_reduce="abs-sum")
    return res.t, {k: v.copy() for k, v in res.residuals.items()}


# --------------------------------------------------------------------------------------------
# progress




#: at most one progress line per this many seconds off a terminal (as the command's counts)
LINE_SECONDS = 10.0


def _reporter(progress: bool) -> Reporter:
    """``report(phase, samples_done)``: nothing, phase lines (not a terminal) or a tqdm bar."""
    if not progress:
        return lambda phase, n: None
    if sys.stderr.isatty():
        from tqdm import tqdm

        bar: Any = None

        def report(phase: str, n: int) -> None:
            nonlocal bar
            if phase.startswith("total:"):
                bar = tqdm(total=int(phase[6:]), file=sys.stderr, desc="thresholds", unit="sample", leave=False)
                return
            if bar is None:
                return
            if phase == "done":
                bar.close()
                return
            if phase:  # the detector, not the internal step ("P1@6: the 2N unit states ...")
                bar.set_description(f"thresholds: {phase.split(':')[0].split(',')[0]}")
            bar.update(n)

        return report
    t0 = time.perf_counter()
    count = {"total": 0, "done": 0, "last": t0}

    def line(phase: str, n: int) -> None:
        # off a terminal: a line when the phase starts, at most one per LINE_SECONDS, one at
        # its end; the internal steps (segments, the unit states, window sums) are not news
        now = time.perf_counter()
        if phase.startswith("total:"):
            count.update(total=int(phase[6:]), done=0, last=now)
            write_line("glocal-verify: thresholds: bounding every detector's attack-free residual over the horizon ...")
            return
        count["done"] += n
        if phase == "done":
            write_line(f"glocal-verify: thresholds: done in {now - t0:.1f} s")
        elif count["total"] and now - count["last"] >= LINE_SECONDS:
            count["last"] = now
            share = min(count["done"] / count["total"], 1.0)
            write_line(f"glocal-verify: thresholds: {100 * share:.0f}% of the samples, {now - t0:.0f} s elapsed")

    return line


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
