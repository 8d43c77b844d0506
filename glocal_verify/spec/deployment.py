"""Reading the deployment tables of a spec: ``[uncertainty]`` and ``[implementation]``.

Called by the validating builder of :mod:`glocal_verify.spec.load` (``b``: its ``err``,
``rational``, ``text`` and ``node_set``), with the same rules: exact rationals, documented
domains (:mod:`glocal_verify.spec.types`, "Domains and limits"), one :class:`SpecError` naming
the key path. A channel pattern is ``"*"``, ``"x:*"``, ``"v:*"``, ``"x:<label>"`` or
``"v:<label>"``; a label that spells an integer names the integer label when the graph has one.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any, Mapping

from glocal_verify.spec.prepare import show
from glocal_verify.spec.types import (
    BOUND_MAX,
    CONTROLLERS,
    FALSE_ALARM_MIN,
    HOLDS,
    MAX_LABEL,
    MAX_SAMPLES,
    SWITCH_DELAY_MAX,
    TIME_MAX,
    TIME_MIN,
    ImplementationSpec,
    Label,
    SimulationSpec,
    UncertaintySpec,
)

__all__ = ["read_uncertainty", "read_implementation"]


def _bound(b: Any, value: Any, path: str) -> Fraction:
    """A bound or standard deviation of ``[uncertainty]``: an exact rational in ``[0, BOUND_MAX]``."""
    return b.rational(value, path, positive=False, lo=Fraction(0), hi=BOUND_MAX)


def _channels(b: Any, value: Any, path: str) -> tuple[tuple[str, Fraction], ...]:
    """A bound for every channel (a number) or a table from channel patterns to bounds."""
    if not isinstance(value, Mapping):
        return (("*", _bound(b, value, path)),)
    out = []
    for key, v in value.items():
        kp = f'{path}."{key}"' if not key.replace("_", "").isalnum() else f"{path}.{key}"
        key = b.text(key, kp, limit=MAX_LABEL, name=True).strip()
        if key != "*":
            kind, sep, label = key.partition(":")
            if not sep or kind not in ("x", "v") or not label:
                raise b.err(kp, f"a channel is \"*\", \"x:*\", \"v:*\", \"x:<label>\" or \"v:<label>\", got {show(key)}")
            if label != "*":
                node = _channel_node(b, label, kp)
                key = f"{kind}:{node}"
        out.append((key, _bound(b, v, kp)))
    return tuple(out)


def _channel_node(b: Any, text: str, path: str) -> Label:
    """The node a channel names (``"7"`` is the integer label 7 when the graph has it)."""
    if text in b.node_set:
        return text
    try:
        as_int = int(text)
    except ValueError:
        as_int = None
    if as_int is not None and as_int in b.node_set:
        return as_int
    raise b.err(path, f"node {show(text)} is not in the graph")


def read_uncertainty(b: Any, u: Mapping[str, Any] | None) -> UncertaintySpec | None:
    if u is None:
        return None
    if "initial_state" in u and "initial_error" in u:
        raise b.err("uncertainty.initial_error", "give initial_state or initial_error, not both")
    init = _bound(b, u["initial_state"], "uncertainty.initial_state") if "initial_state" in u else None
    err = _bound(b, u["initial_error"], "uncertainty.initial_error") if "initial_error" in u else None
    noise = _channels(b, u["noise"], "uncertainty.noise") if "noise" in u else ()
    std = _channels(b, u["noise_std"], "uncertainty.noise_std") if "noise_std" in u else ()
    fa = None
    if "false_alarm" in u:
        fa = b.rational(u["false_alarm"], "uncertainty.false_alarm", lo=FALSE_ALARM_MIN)
        if fa >= 1:
            raise b.err("uncertainty.false_alarm", f"must be < 1, got {show(u['false_alarm'])}")
        if not any(v > 0 for _, v in std):
            raise b.err("uncertainty.false_alarm", "a false-alarm probability needs a Gaussian part (noise_std)")
    dist = _bound(b, u["disturbance"], "uncertainty.disturbance") if "disturbance" in u else Fraction(0)
    return UncertaintySpec(init, err, noise, std, fa, dist)


def read_implementation(b: Any, m: Mapping[str, Any] | None, simulation: SimulationSpec) -> ImplementationSpec | None:
    if m is None:
        return None
    lo, hi = Fraction(TIME_MIN), Fraction(TIME_MAX)
    h = b.rational(m["period"], "implementation.period", lo=lo, hi=hi)
    if Fraction(simulation.horizon) / h > MAX_SAMPLES:
        raise b.err("implementation.period", f"horizon / period = {float(Fraction(simulation.horizon) / h):.3g} samples (at most {MAX_SAMPLES:.0e}); enlarge the period")
    hold = m.get("hold", "zoh")
    if hold not in HOLDS:
        raise b.err("implementation.hold", f"unknown hold {show(hold)} (expected one of: {', '.join(HOLDS)})")
    ctrl = m.get("controller", "sampled")
    if ctrl not in CONTROLLERS:
        raise b.err("implementation.controller", f"unknown controller {show(ctrl)} (expected one of: {', '.join(CONTROLLERS)})")
    delay = m.get("switch_delay", 1)
    if type(delay) is not int or not 0 <= delay <= SWITCH_DELAY_MAX:
        raise b.err("implementation.switch_delay", f"must be an integer in [0, {SWITCH_DELAY_MAX}], got {show(delay)}")
    return ImplementationSpec(h, hold, ctrl, delay)
