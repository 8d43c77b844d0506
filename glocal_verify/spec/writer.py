"""Writing a :class:`~glocal_verify.spec.types.SystemSpec` back as TOML text (format 1).

:func:`dump_spec` is the inverse of :func:`~glocal_verify.spec.load.loads_spec`:
``loads_spec(dump_spec(spec), source=spec.source) == spec`` for every validated spec. Exact
values stay exact:

* an integer weight or gain is written as a TOML integer;
* a rational whose shortest float text reads back as the same rational (``1/10`` as
  ``0.1``, ``3/4`` as ``0.75``) is written as that TOML float, which the loader reads through
  its shortest decimal form;
* any other rational (``1/3``) is written as the string ``"1/3"``, which the loader reads as
  the rational it spells.

Floats that are not exact data (times, the attack exponent, amplitudes) are written with
``repr``, which reads back as the same float.
"""

from __future__ import annotations

import math
import re
from fractions import Fraction
from types import MappingProxyType
from typing import TYPE_CHECKING, Any, Mapping, Sequence

from glocal_verify.errors import ArgumentError

if TYPE_CHECKING:  # annotations only: the spec types call this writer (SystemSpec.to_toml)
    from glocal_verify.spec.types import (
        AttackSpec,
        ClusterSpec,
        EdgeSpec,
        ImplementationSpec,
        Label,
        ModeSpec,
        SwitchingSpec,
        SystemSpec,
        UncertaintySpec,
    )


__all__ = [
    "dump_spec",
]

_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")
_ESCAPES = MappingProxyType({'"': '\\"', "\\": "\\\\", "\b": "\\b", "\t": "\\t", "\n": "\\n", "\f": "\\f", "\r": "\\r"})


def _string(text: str) -> str:
    """A TOML basic string: quotes, backslashes and control characters escaped."""
    out = []
    for ch in text:
        if ch in _ESCAPES:
            out.append(_ESCAPES[ch])
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append(f"\\u{ord(ch):04x}")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def _key(name: str) -> str:
    return name if _BARE_KEY.match(name) else _string(name)


def _float(x: float) -> str:
    x = float(x)
    if math.isnan(x):
        return "nan"
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    text = repr(x)
    return text if any(c in text for c in ".eE") else text + ".0"


def _rational(q: Fraction) -> str:
    """Exact TOML text of a rational (module docstring)."""
    q = Fraction(q)
    if q.denominator == 1:
        return str(q.numerator)
    f = float(q)
    if math.isfinite(f) and Fraction(repr(f)) == q:
        return _float(f)
    return _string(f"{q.numerator}/{q.denominator}")


def _label(x: Label) -> str:
    return _string(x) if isinstance(x, str) else str(int(x))


def _labels(xs: Sequence[Label]) -> str:
    return "[" + ", ".join(_label(x) for x in xs) + "]"


def _value(v: Any) -> str:
    """Any JSON-like value (the ``[finding]`` table) as an inline TOML value."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, Fraction):
        return _rational(v)
    if isinstance(v, float):
        return _float(v)
    if isinstance(v, str):
        return _string(v)
    if isinstance(v, Mapping):
        return "{" + ", ".join(f"{_key(str(k))} = {_value(x)}" for k, x in v.items()) + "}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    raise TypeError(f"cannot write {v!r} as TOML")


def _edge(e: EdgeSpec) -> str:
    parts = [_label(e.u), _label(e.v)]
    if e.weight != 1:
        parts.append(_rational(e.weight))
    return "[" + ", ".join(parts) + "]"


def _edges(edges: Sequence[EdgeSpec], indent: str = "  ", per_line: int = 6) -> str:
    if len(edges) <= per_line:
        return "[" + ", ".join(_edge(e) for e in edges) + "]"
    rows = [", ".join(_edge(e) for e in edges[k : k + per_line]) for k in range(0, len(edges), per_line)]
    return "[\n" + ",\n".join(indent + r for r in rows) + ",\n]"


def _mode(m: ModeSpec) -> list[str]:
    out = ["", "[[modes]]", f"name = {_string(m.name)}"]
    if m.description:
        out.append(f"description = {_string(m.description)}")
    if m.add:
        out.append(f"add = {_edges(m.add)}")
    if m.remove:
        out.append("remove = [" + ", ".join(_labels(pair) for pair in m.remove) + "]")
    return out


def _cluster(c: ClusterSpec) -> list[str]:
    out = ["", "[[clusters]]", f"name = {_string(c.name)}", f"nodes = {_labels(c.nodes)}"]
    for o in c.observers:
        out += ["[[clusters.observers]]", f"center = {_label(o.center)}"]
        if o.positions is not None:
            out.append(f"positions = {_labels(o.positions)}")
        if o.velocities is not None:
            out.append(f"velocities = {_labels(o.velocities)}")
        if o.poles is not None:
            out.append("poles = [" + ", ".join(_rational(p) for p in o.poles) + "]")
    return out


def _attack(a: AttackSpec) -> list[str]:
    out = ["", "[attack]", f"kind = {_string(a.kind)}", f"actuators = {_labels(a.actuators)}"]
    if a.sensors:
        out.append(f"sensors = {_labels(a.sensors)}")
    if a.lambda0 is not None:
        lam = complex(a.lambda0)
        if lam.imag == 0.0:
            out.append(f"lambda0 = {_float(lam.real)}")
        else:
            out.append(f"lambda0 = [{_float(lam.real)}, {_float(lam.imag)}]")
    out.append(f"start = {_float(a.start)}")
    if a.signal is not None:
        out.append(f"signal = {_string(a.signal)}")
    out += [f"amplitude = {_float(a.amplitude)}", f"frequency = {_float(a.frequency)}"]
    return out


def _switching(s: SwitchingSpec) -> list[str]:
    out = ["", "[switching]"]
    if s.mode is not None:
        out.append(f"mode = {_string(s.mode)}")
    if s.time is not None:
        out.append(f"time = {_float(s.time)}")
    if s.sequence:
        steps = ", ".join(f"{{mode = {_string(st.mode)}, duration = {_float(st.duration)}}}" for st in s.sequence)
        out.append(f"sequence = [{steps}]")
    return out


def _channels(table: Sequence[tuple[str, Fraction]]) -> str:
    if len(table) == 1 and table[0][0] == "*":
        return _rational(table[0][1])
    return "{" + ", ".join(f"{_string(k)} = {_rational(v)}" for k, v in table) + "}"


def _uncertainty(u: UncertaintySpec) -> list[str]:
    out = ["", "[uncertainty]"]
    if u.initial_state is not None:
        out.append(f"initial_state = {_rational(u.initial_state)}")
    if u.initial_error is not None:
        out.append(f"initial_error = {_rational(u.initial_error)}")
    if u.noise:
        out.append(f"noise = {_channels(u.noise)}")
    if u.noise_std:
        out.append(f"noise_std = {_channels(u.noise_std)}")
    if u.false_alarm is not None:
        out.append(f"false_alarm = {_rational(u.false_alarm)}")
    if u.disturbance:
        out.append(f"disturbance = {_rational(u.disturbance)}")
    return out


def _implementation(m: ImplementationSpec) -> list[str]:
    return [
        "",
        "[implementation]",
        f"period = {_rational(m.period)}",
        f"hold = {_string(m.hold)}",
        f"controller = {_string(m.controller)}",
        f"switch_delay = {int(m.switch_delay)}",
    ]


def _table(name: str, data: Mapping[str, Any]) -> list[str]:
    return ["", f"[{name}]"] + [f"{_key(str(k))} = {_value(v)}" for k, v in data.items()]


def dump_spec(spec: SystemSpec) -> str:
    """The TOML text (format 1) of a validated specification.

    Parameters
    ----------
    spec : SystemSpec
        A validated specification (from a file, :func:`~glocal_verify.spec.load.spec_from_graph`,
        a generator ...).

    Returns
    -------
    str
        TOML text such that ``loads_spec(text, source=spec.source) == spec``: weights and gains
        are written exactly (integers, floats whose shortest text is the same rational, else
        ``"p/q"`` strings; see the module docstring), labels keep their type (``int`` or
        ``str``). Comments of the original file are not kept.

    Examples
    --------
    >>> from glocal_verify.spec import load_example, loads_spec
    >>> spec = load_example("paper19")
    >>> loads_spec(dump_spec(spec), source=spec.source) == spec
    True
    """
    if not all(hasattr(spec, a) for a in ("name", "nodes", "edges", "modes", "clusters", "monitor", "simulation")):
        # a structural check: the spec types import this writer (SystemSpec.to_toml)
        raise ArgumentError(f"dump_spec: expected a validated SystemSpec (load_spec, spec_from_graph, spec_from_dict ...), got {type(spec).__name__}")
    lines = ["# glocal-verify system specification", "format = 1", f"name = {_string(spec.name)}"]
    if spec.description:
        lines.append(f"description = {_string(spec.description)}")
    lines += ["", "[dynamics]", f"alpha = {_rational(spec.alpha)}", f"gamma = {_rational(spec.gamma)}"]
    lines += ["", "[graph]"]
    if spec.nodes == tuple(range(1, len(spec.nodes) + 1)) and all(type(x) is int for x in spec.nodes):
        lines.append(f"nodes = {len(spec.nodes)}")
    else:
        lines.append(f"nodes = {_labels(spec.nodes)}")
    lines.append(f"edges = {_edges(spec.edges)}")
    for m in spec.modes:
        lines += _mode(m)
    for c in spec.clusters:
        lines += _cluster(c)
    lines += [
        "",
        "[monitor]",
        f"positions = {_labels(spec.monitor.positions)}",
        f"velocities = {_labels(spec.monitor.velocities)}",
    ]
    if spec.attack is not None:
        lines += _attack(spec.attack)
    if spec.switching is not None:
        lines += _switching(spec.switching)
    sim = spec.simulation
    lines += ["", "[simulation]", f"horizon = {_float(sim.horizon)}", f"step = {_float(sim.step)}", f"seed = {int(sim.seed)}"]
    if spec.uncertainty is not None:
        lines += _uncertainty(spec.uncertainty)
    if spec.implementation is not None:
        lines += _implementation(spec.implementation)
    if spec.finding is not None:
        lines += _table("finding", spec.finding)
    return "\n".join(lines) + "\n"
