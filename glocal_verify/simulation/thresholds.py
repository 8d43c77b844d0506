"""Residual thresholds: the attack-free worst-case envelope, and the first crossing of a residual.

The paper leaves thresholds to future work; the default rule bounds every attack-free
residual over a box of initial states exactly (see :class:`ThresholdRule`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from glocal_verify.errors import ModelError
from glocal_verify.model import System
from glocal_verify.results import jsonable
from glocal_verify.simulation.engine import simulate
from glocal_verify.simulation.observer_models import ObserverBank
from glocal_verify.simulation.schedule import Schedule, SimulationResult

__all__ = [
    "ThresholdRule",
    "Thresholds",
    "Crossing",
    "attack_free_thresholds",
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
        Simulation method (:func:`~glocal_verify.simulation.engine.simulate`).
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
