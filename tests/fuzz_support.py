"""Spec fuzzing support: base specs, a tiny TOML writer, spec mutators and ``run_cli``.

The mutators take *valid* specifications (the bundled ``paper19.toml`` and small generated
ones from :func:`glocal_verify.design.generators.random_clustered_spec` and
:func:`glocal_verify.spec.spec_from_graph`) and break them in the ways real files break:
keys dropped or duplicated, types changed, extreme numbers (NaN, inf, ``2**63-1``,
``"1e9999999"``, ``-1e308`` ...), unicode and 10^5-character labels, nested arrays 10^4 deep,
odd mode names (``".."``, ``"../../x"``, NUL bytes), references to missing nodes, huge
horizons and tiny steps, ``gamma = 2**63-1``, ``lambda0 = -1e308``, labels ``[1, "1", 2]``.

The mutation engine draws every choice through a :class:`Chooser`, so the same code backs

- the hypothesis strategies (:func:`mutated_specs`, :func:`mutants_of_kind`), which shrink, and
- the stand-alone campaign (``tests/fuzz_campaign.py``), which uses :class:`RandomChooser`
  and needs neither pytest nor hypothesis.

:func:`run_cli` runs ``glocal_verify.cli.main`` in-process (or in a forked child with an
``RLIMIT_AS`` bound) under a SIGALRM time budget and classifies the outcome:

======== ================================================================
ok          exit 0 or 1
clean-error exit 2, at most 4 stderr lines, no ``Traceback``
traceback   an exception escaped ``main`` or ``Traceback`` is in the output
multi-line  exit 2 with more than 4 stderr lines
hang        the time budget ran out
blowup      ``MemoryError``
crash       (forked runs only) the child died without reporting (signal, OOM killer)
bad-exit    any other exit code
======== ================================================================
"""

from __future__ import annotations

import contextlib
import copy
import io
import json
import math
import os
import random
import re
import resource
import signal
import socket
import stat
import sys
import tempfile
import threading
import time
import tomllib
import traceback
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path
from typing import Any, Callable, Iterator, Sequence

ROOT = Path(__file__).resolve().parents[1]
PAPER19 = ROOT / "glocal_verify" / "spec" / "data" / "paper19.toml"

OUTCOMES = ("ok", "clean-error", "traceback", "multi-line", "hang", "blowup", "crash", "bad-exit")
GOOD_OUTCOMES = ("ok", "clean-error")
MAX_ERROR_LINES = 4

# ---------------------------------------------------------------------------------------------
# a tiny TOML writer


@dataclass(frozen=True)
class RawToml:
    """A value written verbatim (e.g. an array nested 10^4 deep, which a recursive writer
    could not produce)."""

    text: str

    def __repr__(self) -> str:  # keep descriptions short
        return f"RawToml({self.text[:40]!r}{'...' if len(self.text) > 40 else ''} [{len(self.text)} chars])"


_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")


def _key(k: str) -> str:
    return k if _BARE_KEY.match(k) else _string(k)


def _string(s: str) -> str:
    out = ['"']
    for ch in s:
        o = ord(ch)
        if ch == '"':
            out.append('\\"')
        elif ch == "\\":
            out.append("\\\\")
        elif o < 0x20 or o == 0x7F:
            out.append(f"\\u{o:04X}")
        else:
            out.append(ch)
    out.append('"')
    return "".join(out)


def _scalar(v: Any) -> str:
    if isinstance(v, RawToml):
        return v.text
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        r = repr(v)
        return r if any(c in r for c in ".en") else r + ".0"
    if isinstance(v, Fraction):
        return _string(str(v))
    if isinstance(v, str):
        return _string(v)
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_key(str(k))} = {_scalar(x)}" for k, x in v.items()) + "}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_scalar(x) for x in v) + "]"
    raise TypeError(f"cannot write {type(v).__name__} as TOML")


def _is_aot(v: Any) -> bool:
    return isinstance(v, list) and len(v) > 0 and all(isinstance(x, dict) for x in v)


def toml_dumps(data: dict[str, Any]) -> str:
    """Write ``data`` as TOML: sub-dicts become ``[tables]``, non-empty lists of dicts
    ``[[arrays of tables]]``, everything else inline."""
    lines: list[str] = []

    def table(prefix: list[str], d: dict[str, Any], header: str | None) -> None:
        plain = [(k, v) for k, v in d.items() if not isinstance(v, dict) and not _is_aot(v)]
        subs = [(k, v) for k, v in d.items() if isinstance(v, dict)]
        aots = [(k, v) for k, v in d.items() if _is_aot(v)]
        if header is not None:
            lines.append(header)
        for k, v in plain:
            lines.append(f"{_key(str(k))} = {_scalar(v)}")
        for k, v in subs:
            p = prefix + [str(k)]
            table(p, v, "[" + ".".join(map(_key, p)) + "]")
        for k, v in aots:
            p = prefix + [str(k)]
            for item in v:
                table(p, item, "[[" + ".".join(map(_key, p)) + "]]")

    table([], data, None)
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------------------------------
# base specs


def _num(q: Fraction) -> Any:
    return int(q) if q.denominator == 1 else str(q)


def spec_to_dict(spec: Any) -> dict[str, Any]:
    """A :class:`~glocal_verify.spec.SystemSpec` as a mapping shaped like the TOML file."""
    d: dict[str, Any] = {"format": 1, "name": spec.name}
    if spec.description:
        d["description"] = spec.description
    d["dynamics"] = {"alpha": _num(spec.alpha), "gamma": _num(spec.gamma)}
    nodes = list(spec.nodes)
    d["graph"] = {
        "nodes": len(nodes) if nodes == list(range(1, len(nodes) + 1)) else nodes,
        "edges": [[e.u, e.v, _num(e.weight)] for e in spec.edges],
    }
    if spec.modes:
        modes = []
        for m in spec.modes:
            md: dict[str, Any] = {"name": m.name}
            if m.description:
                md["description"] = m.description
            if m.add:
                md["add"] = [[e.u, e.v, _num(e.weight)] for e in m.add]
            if m.remove:
                md["remove"] = [list(p) for p in m.remove]
            modes.append(md)
        d["modes"] = modes
    if spec.clusters:
        cl = []
        for c in spec.clusters:
            obs = []
            for o in c.observers:
                od: dict[str, Any] = {"center": o.center}
                if o.positions is not None:
                    od["positions"] = list(o.positions)
                if o.velocities is not None:
                    od["velocities"] = list(o.velocities)
                if o.poles is not None:
                    od["poles"] = [_num(p) for p in o.poles]
                obs.append(od)
            cd: dict[str, Any] = {"name": c.name, "nodes": list(c.nodes)}
            if obs:
                cd["observers"] = obs
            cl.append(cd)
        d["clusters"] = cl
    d["monitor"] = {"positions": list(spec.monitor.positions), "velocities": list(spec.monitor.velocities)}
    a = spec.attack
    if a is not None:
        ad: dict[str, Any] = {"kind": a.kind, "actuators": list(a.actuators)}
        if a.sensors:
            ad["sensors"] = list(a.sensors)
        if a.lambda0 is not None:
            ad["lambda0"] = a.lambda0.real if a.lambda0.imag == 0 else [a.lambda0.real, a.lambda0.imag]
        ad["start"] = a.start
        if a.signal is not None:
            ad["signal"] = a.signal
        ad["amplitude"] = a.amplitude
        ad["frequency"] = a.frequency
        d["attack"] = ad
    s = spec.switching
    if s is not None:
        sd: dict[str, Any] = {}
        if s.mode is not None:
            sd["mode"] = s.mode
        if s.time is not None:
            sd["time"] = s.time
        if s.sequence:
            sd["sequence"] = [{"mode": st_.mode, "duration": st_.duration} for st_ in s.sequence]
        d["switching"] = sd
    sim = spec.simulation
    d["simulation"] = {"horizon": sim.horizon, "step": sim.step, "seed": sim.seed}
    return d


def _paper19(short: bool) -> dict[str, Any]:
    d = tomllib.loads(PAPER19.read_text(encoding="utf-8"))
    if short:  # switch at t = 10 still inside the horizon; 240 output steps instead of 3000
        d["name"] = "paper19-short"
        d["simulation"] = {"horizon": 12.0, "step": 0.05}
    return d


def _from_graph_specs() -> list[tuple[str, dict[str, Any]]]:
    import networkx as nx

    from glocal_verify.spec import spec_from_graph

    sim = {"horizon": 3.0, "step": 0.05}
    out = []
    g = nx.cycle_graph(range(1, 9))
    g.add_edge(2, 4, weight=2)
    g.add_edge(6, 8, weight=3)
    s = spec_from_graph(
        g,
        name="cycle8",
        modes={"s1": {"add": [(1, 3)]}, "s2": {"add": [(5, 7, 2)], "remove": [(5, 6)]}},
        clusters={"A": [1, 2, 3, 4], "B": [5, 6, 7, 8]},
        observers={"A": [1], "B": [{"center": 5, "positions": [5, 6, 7, 8], "velocities": [5, 6, 7, 8]}]},
        monitor_velocities=[1, 5],
        attack={"kind": "zda", "actuators": [2, 3]},
        switching={"mode": "s1", "time": 1.0},
        simulation=sim,
    )
    out.append(("cycle8", spec_to_dict(s)))
    g = nx.path_graph(["a", "b", "c", "d", "e"])
    nx.set_edge_attributes(g, {("a", "b"): "1/3", ("c", "d"): 2.5}, "weight")
    s = spec_from_graph(
        g,
        name="path5-str",
        gamma="3/2",
        modes={"m": {"add": [("a", "c")]}},
        clusters={"L": ["a", "b"], "R": ["c", "d", "e"]},
        observers={"L": ["b"], "R": ["d"]},
        monitor_positions=["e"],
        monitor_velocities=["b", "e"],
        attack={"kind": "covert", "actuators": ["d"], "sensors": ["e"], "signal": "sine", "amplitude": 0.5, "frequency": 2.0},
        switching={"sequence": [{"mode": "m", "duration": 1.0}, {"mode": "normal", "duration": 1.0}]},
        simulation=sim,
    )
    out.append(("path5-str", spec_to_dict(s)))
    return out


_BASES: list[tuple[str, dict[str, Any]]] | None = None

#: a sampled deployment for the bases that get one: per-channel noise, a held disturbance, a
#: sampled controller (the [uncertainty] and [implementation] sections of docs/spec.md)
_DEPLOYMENT = {
    "uncertainty": {"initial_state": 1.0, "noise": 0.001, "disturbance": 0.001},
    "implementation": {"period": 0.05, "controller": "sampled", "switch_delay": 1},
}


def _with_deployment(name: str, data: dict[str, Any]) -> dict[str, Any]:
    d = copy.deepcopy(data)
    d["name"] = f"{name}-sampled"
    d.update(copy.deepcopy(_DEPLOYMENT))
    if name.startswith("paper19"):  # per-channel noise keys of paper19's monitors
        d["uncertainty"]["noise"] = {"v:1": 0.002, "x:*": 0.001, "*": 0.001}
    return d


def base_specs() -> list[tuple[str, dict[str, Any]]]:
    """(name, mapping) of every base spec; all are valid and fast to verify."""
    global _BASES
    if _BASES is None:
        from glocal_verify.design.generators import random_clustered_spec

        bases = [("paper19", _paper19(False)), ("paper19-short", _paper19(True))]
        for n, c, seed in [(10, 2, 0), (12, 2, 3), (12, 3, 1), (14, 3, 2)]:
            s = random_clustered_spec(n, c, seed=seed, monitors=3, horizon=3.0, step=0.05, observers_per_cluster=2 if seed % 2 else 1)
            bases.append((s.name, spec_to_dict(s)))
        bases += _from_graph_specs()
        bases += [(f"{name}-sampled", _with_deployment(name, d)) for name, d in bases if name in ("paper19-short", "cycle8", "path5-str")]
        _BASES = bases
    return _BASES


# ---------------------------------------------------------------------------------------------
# choosers


class Chooser:
    """Where the mutation engine gets its random choices."""

    def choice(self, seq: Sequence[Any]) -> Any:
        raise NotImplementedError

    def integer(self, lo: int, hi: int) -> int:
        raise NotImplementedError


class RandomChooser(Chooser):
    def __init__(self, seed: int | None = None) -> None:
        self.rng = random.Random(seed)

    def choice(self, seq: Sequence[Any]) -> Any:
        return seq[self.rng.randrange(len(seq))]

    def integer(self, lo: int, hi: int) -> int:
        return self.rng.randint(lo, hi)


class DrawChooser(Chooser):
    """Choices drawn by hypothesis (so failures shrink)."""

    def __init__(self, draw: Any) -> None:
        from hypothesis import strategies as st

        self.draw = draw
        self.st = st

    def choice(self, seq: Sequence[Any]) -> Any:
        return seq[self.draw(self.st.integers(0, len(seq) - 1))]

    def integer(self, lo: int, hi: int) -> int:
        return int(self.draw(self.st.integers(lo, hi)))


# ---------------------------------------------------------------------------------------------
# paths into the mapping

PathT = tuple[Any, ...]


def path_text(path: PathT) -> str:
    out = ""
    for p in path:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else str(p))
    return out or "<top>"


def walk(data: Any, path: PathT = ()) -> Iterator[tuple[PathT, Any]]:
    """Every (path, value) below ``data`` (the root excluded), depth first."""
    if isinstance(data, dict):
        for k, v in data.items():
            yield (*path, k), v
            yield from walk(v, (*path, k))
    elif isinstance(data, list):
        for i, v in enumerate(data):
            yield (*path, i), v
            yield from walk(v, (*path, i))


def get_at(data: Any, path: PathT) -> Any:
    for p in path:
        data = data[p]
    return data


def set_at(data: Any, path: PathT, value: Any) -> None:
    get_at(data, path[:-1])[path[-1]] = value


def del_at(data: Any, path: PathT) -> None:
    del get_at(data, path[:-1])[path[-1]]


_I = r"\[\d+\]"
LABEL_REF = re.compile(
    rf"^(graph\.edges{_I}\[[01]\]|modes{_I}\.(add{_I}\[[01]\]|remove{_I}\[[01]\])|clusters{_I}\.nodes{_I}"
    rf"|clusters{_I}\.observers{_I}\.(center|positions{_I}|velocities{_I})|monitor\.(positions|velocities){_I}"
    rf"|attack\.(actuators|sensors){_I})$"
)
LABEL_DEF = re.compile(rf"^graph\.nodes{_I}$")
NUMBER = re.compile(
    rf"^(dynamics\.(alpha|gamma)|graph\.nodes|graph\.edges{_I}\[2\]|modes{_I}\.add{_I}\[2\]|clusters{_I}\.observers{_I}\.poles{_I}"
    rf"|attack\.(lambda0|lambda0\[[01]\]|start|amplitude|frequency)|switching\.(time|sequence{_I}\.duration)"
    rf"|simulation\.(horizon|step|seed))$"
)


def node_labels(data: dict[str, Any]) -> list[Any]:
    nodes = data.get("graph", {}).get("nodes", [])
    if isinstance(nodes, int) and not isinstance(nodes, bool):
        return list(range(1, min(nodes, 10**6) + 1))
    return list(nodes) if isinstance(nodes, list) else []


def _rename_node(data: dict[str, Any], old: Any, new: Any) -> None:
    """Rename node ``old`` to ``new`` everywhere (turning ``nodes = N`` into a list)."""
    g = data["graph"]
    if isinstance(g.get("nodes"), int):
        g["nodes"] = list(range(1, g["nodes"] + 1))
    for p, v in list(walk(data)):
        t = path_text(p)
        if (LABEL_REF.match(t) or LABEL_DEF.match(t)) and v == old and type(v) is type(old):
            set_at(data, p, new)


# ---------------------------------------------------------------------------------------------
# mutations

NAN, INF = float("nan"), float("inf")
EXTREME_NUMBERS: list[Any] = [
    NAN, INF, -INF, 0, -0.0, 5e-324, 1e-308, 1e308, -1e308, 2**63 - 1, -(2**63), 10**400, 1e16, 1e-16, -1,
    "1e9999999", "-1e308", "1e-9999999", "abc", "1/0", "0/5", " 3/4 ", "9" * 5000, "1e308", "nan", "inf",
]
TYPE_VALUES: list[Any] = ["str", "", 7, 0, -3, 2.5, 1.0, 2.0, [1, 2], [], ["x"], {"k": 1}, {}, True, False, [[1, 2], [3]]]
ODD_MODE_NAMES = ["..", ".", "../../x", "x/../../y", "/tmp/abs-mode", "a\x00b", "\x00", "con", "x" * 300, "a\nb", "\u202egnp.exe", " ", "normal ", "*", "a:b"]
UNICODE_LABELS = ["ノード", "🙂", "e\u0301", "\u202eRTL", "ß", "\u00a0", "Ω" * 50, "a\tb", "\x7f", "\x00"]
DEEP_DEPTHS = [50, 900, 10_000]


@dataclass
class Mutant:
    """A mutated spec: its TOML text and how it was made."""

    base: str
    kinds: list[str]
    mutations: list[str]
    text: str
    data: dict[str, Any] = field(repr=False, default_factory=dict)

    @property
    def description(self) -> str:
        return f"{self.base}: " + "; ".join(self.mutations)

    def __repr__(self) -> str:  # what hypothesis prints for a falsifying example
        snippet = self.text if len(self.text) < 3000 else self.text[:3000] + f"\n... ({len(self.text)} chars)"
        return f"Mutant({self.description!r})\n--- spec ---\n{snippet}"


def _short(v: Any) -> str:
    r = repr(v)
    return r if len(r) <= 60 else r[:40] + f"...<{len(r)} chars>"


def _m_drop_key(d: dict[str, Any], c: Chooser) -> str:
    paths = [p for p, _ in walk(d) if isinstance(get_at(d, p[:-1]), dict)]
    p = c.choice(paths)
    del_at(d, p)
    return f"drop {path_text(p)}"


def _m_duplicate_item(d: dict[str, Any], c: Chooser) -> str:
    paths = [p for p, v in walk(d) if isinstance(v, list) and v]
    if not paths:
        return _m_drop_key(d, c)
    p = c.choice(paths)
    lst = get_at(d, p)
    i = c.integer(0, len(lst) - 1)
    lst.insert(i + 1, copy.deepcopy(lst[i]))
    return f"duplicate {path_text(p)}[{i}]"


def _m_type_change(d: dict[str, Any], c: Chooser) -> str:
    paths = [p for p, _ in walk(d)]
    p = c.choice(paths)
    v = copy.deepcopy(c.choice(TYPE_VALUES))
    set_at(d, p, v)
    return f"set {path_text(p)} = {_short(v)}"


def _m_extreme_number(d: dict[str, Any], c: Chooser) -> str:
    paths = [p for p, v in walk(d) if NUMBER.match(path_text(p)) and not isinstance(v, (dict, list))]
    if not paths:
        return _m_type_change(d, c)
    p = c.choice(paths)
    v = c.choice(EXTREME_NUMBERS)
    set_at(d, p, v)
    return f"set {path_text(p)} = {_short(v)}"


def _m_missing_node(d: dict[str, Any], c: Chooser) -> str:
    paths = [p for p, v in walk(d) if LABEL_REF.match(path_text(p))]
    if not paths:
        return _m_type_change(d, c)
    p = c.choice(paths)
    labels = node_labels(d)
    ints = [x for x in labels if isinstance(x, int)]
    ghost = c.choice([max(ints, default=0) + 1, 25, 0, -1, 2**63 - 1, 10**30, "ghost", "1"])
    if ghost in labels:
        ghost = "ghost-node"
    set_at(d, p, ghost)
    return f"set {path_text(p)} = {_short(ghost)} (not a node)"


def _m_rename_label(d: dict[str, Any], c: Chooser, pool: Sequence[Any], kind: str) -> str:
    labels = node_labels(d)
    what = c.choice(["node", "cluster", "name"]) if labels else "name"
    new = c.choice(pool)
    if what == "node":
        old = c.choice(labels)
        _rename_node(d, old, new)
        return f"rename node {old!r} -> {_short(new)} everywhere"
    if what == "cluster" and d.get("clusters"):
        k = c.integer(0, len(d["clusters"]) - 1)
        d["clusters"][k]["name"] = new
        return f"set clusters[{k}].name = {_short(new)}"
    d["name"] = new
    return f"set name = {_short(new)}"


def _m_long_label(d: dict[str, Any], c: Chooser) -> str:
    n = c.choice([10**5, 5000, 300])
    return _m_rename_label(d, c, ["L" * n, "é" * n, "9" * n], "long")


def _m_unicode_label(d: dict[str, Any], c: Chooser) -> str:
    return _m_rename_label(d, c, UNICODE_LABELS, "unicode")


def _deep(depth: int, leaf: str = "1") -> RawToml:
    return RawToml("[" * depth + leaf + "]" * depth)


def _m_deep_nesting(d: dict[str, Any], c: Chooser) -> str:
    depth = c.choice(DEEP_DEPTHS)
    targets = [p for p, v in walk(d) if isinstance(v, list)] + [("graph", "nodes"), ("graph", "edges")]
    p = c.choice(targets)
    try:
        set_at(d, p, _deep(depth))
    except (KeyError, IndexError, TypeError):
        d["graph"] = {"nodes": 3, "edges": _deep(depth)}
        p = ("graph", "edges")
    return f"set {path_text(p)} = array nested {depth} deep"


def _m_odd_mode(d: dict[str, Any], c: Chooser) -> str:
    name = c.choice(ODD_MODE_NAMES)
    modes = d.get("modes")
    if not modes or not isinstance(modes, list) or not all(isinstance(m, dict) for m in modes):
        labels = node_labels(d) or [1, 2]
        d["modes"] = [{"name": name, "add": [[labels[0], labels[-1]]]}]
        k, old = 0, None
    else:
        k = c.integer(0, len(modes) - 1)
        old = modes[k].get("name")
        modes[k]["name"] = name
    sw = d.get("switching")
    if isinstance(sw, dict):
        if old is None or sw.get("mode") == old or "mode" not in sw:
            sw["mode"] = name
            sw.setdefault("time", 1.0)
        for s in sw.get("sequence", []) if isinstance(sw.get("sequence"), list) else []:
            if isinstance(s, dict) and s.get("mode") == old:
                s["mode"] = name
    else:
        d["switching"] = {"mode": name, "time": 1.0}
    return f"name modes[{k}] (and switching.mode) {_short(name)}"


def _m_huge_time(d: dict[str, Any], c: Chooser) -> str:
    sim = d.setdefault("simulation", {}) if isinstance(d.get("simulation", {}), dict) else {}
    d["simulation"] = sim
    variant = c.choice(
        [
            {"horizon": 1e16},
            {"horizon": 1e16, "step": 1e15},
            {"horizon": 1e300, "step": 1e299},
            {"horizon": 1e8, "step": 1.0},
            {"step": 1e-12},
            {"step": 5e-324},
            {"horizon": 1e-300, "step": 1e-300},
            {"horizon": 3.0, "step": 2.9999999999},
            {"seed": 2**63 - 1},
            {"seed": -1},
            {"seed": 10**30},
        ]
    )
    sim.update(variant)
    extra = ""
    if c.choice([False, True]) and isinstance(d.get("switching"), dict) and "time" in d["switching"]:
        d["switching"]["time"] = c.choice([1e15, 1e-300, 1e308])
        extra = f", switching.time = {d['switching']['time']!r}"
    return "simulation " + ", ".join(f"{k} = {_short(v)}" for k, v in variant.items()) + extra


def _m_gains(d: dict[str, Any], c: Chooser) -> str:
    dyn = d.get("dynamics") if isinstance(d.get("dynamics"), dict) else {}
    d["dynamics"] = dyn
    key = c.choice(["gamma", "gamma", "alpha"])
    v = c.choice([2**63 - 1, 1e300, "1/9223372036854775807", 1e-300, "1e-300", 10**30])
    dyn[key] = v
    return f"set dynamics.{key} = {_short(v)}"


def _m_lambda0(d: dict[str, Any], c: Chooser) -> str:
    atk = d.get("attack")
    if not isinstance(atk, dict):
        labels = node_labels(d) or [1]
        atk = d["attack"] = {"kind": "zda", "actuators": [labels[0]]}
    v = c.choice([-1e308, 1e308, [1e308, -1e308], [0.0, 1e308], [-1e308, 1e308], "1e9999999", "-1e308", 745.2, 1e4, [0.0, 5e-324]])
    atk["lambda0"] = v
    if atk.get("kind") != "zda":
        atk["kind"] = "zda"
        atk.pop("sensors", None)
    return f"set attack.lambda0 = {_short(v)}"


def _m_mixed_labels(d: dict[str, Any], c: Chooser) -> str:
    labels = node_labels(d)
    ints = [x for x in labels if isinstance(x, int)]
    if not ints:  # string labels: add an integer twin instead
        s = labels[0] if labels else "a"
        twin: Any = 1
        anchor = s
    else:
        anchor = ints[0]
        twin = str(anchor)
    g = d["graph"]
    if isinstance(g.get("nodes"), int):
        g["nodes"] = list(range(1, g["nodes"] + 1))
    nodes = g["nodes"] if isinstance(g.get("nodes"), list) else []
    if twin not in nodes:
        nodes.insert(1, twin)
    g["nodes"] = nodes
    variant = c.choice(["edge+cluster", "isolated", "monitor"])
    if variant in ("edge+cluster", "monitor") and isinstance(g.get("edges"), list):
        g["edges"].append([twin, anchor, 1])
    cl = d.get("clusters")
    if variant != "isolated" and isinstance(cl, list) and cl and isinstance(cl[0], dict) and isinstance(cl[0].get("nodes"), list):
        cl[0]["nodes"].append(twin)
    if variant == "monitor" and isinstance(d.get("monitor"), dict):
        d["monitor"].setdefault("velocities", []).append(twin)
    return f"graph.nodes = [{anchor!r}, {twin!r}, ...] ({variant})"


#: values at the edges of the documented domains (glocal_verify.spec.types), by field
DOMAIN_EDGES: dict[str, list[Any]] = {
    "weight": [10**12, "1e-12", "999999999999", 1e-6, 1e6],
    "gain": [10**12, "1e-12", 10**6, "1e-6", 1000],
    "lambda0": [1e6, -1e6, [1e6, -1e6], [0.0, 1e6], 23.0],
    "pole": [-1e6, -1e-6],
    "time": [1e6, 1e-6, 0.5e6],
}


def _m_domain_edge(d: dict[str, Any], c: Chooser) -> str:
    """Set a number to the edge of its documented domain (the loader accepts it): probes the
    numerics inside the domain. Opt-in (``--kinds domain-edge``), not in the default kinds."""
    field_ = c.choice(["weight", "gain", "lambda0", "pole", "time"])
    v = copy.deepcopy(c.choice(DOMAIN_EDGES[field_]))
    if field_ == "weight":
        paths = [p for p, x in walk(d) if re.match(rf"^(graph\.edges{_I}\[2\]|modes{_I}\.add{_I}\[2\])$", path_text(p))]
        if not paths:
            return _m_type_change(d, c)
        p = c.choice(paths)
        set_at(d, p, v)
        return f"set {path_text(p)} = {_short(v)}"
    if field_ == "gain":
        key = c.choice(["alpha", "gamma"])
        dyn = d.get("dynamics") if isinstance(d.get("dynamics"), dict) else {}
        d["dynamics"] = dyn
        dyn[key] = v
        return f"set dynamics.{key} = {_short(v)}"
    if field_ == "lambda0":
        return _m_lambda0_value(d, v)
    if field_ == "pole":
        paths = [p for p, x in walk(d) if re.match(rf"^clusters{_I}\.observers{_I}$", path_text(p)) and isinstance(x, dict)]
        if not paths:
            return _m_type_change(d, c)
        p = c.choice(paths)
        get_at(d, p)["poles"] = [v, -1, -2, -3]
        return f"set {path_text(p)}.poles = [{v}, -1, -2, -3]"
    sim = d.get("simulation") if isinstance(d.get("simulation"), dict) else {}
    d["simulation"] = sim
    key = c.choice(["horizon", "switch"])
    if key == "switch" and isinstance(d.get("switching"), dict) and "time" in d["switching"]:
        d["switching"]["time"] = v
        return f"set switching.time = {v}"
    sim["horizon"], sim["step"] = v, max(v / 1000.0, 1e-6)
    return f"set simulation.horizon = {v}, step = {sim['step']}"


def _m_lambda0_value(d: dict[str, Any], v: Any) -> str:
    atk = d.get("attack")
    if not isinstance(atk, dict):
        labels = node_labels(d) or [1]
        atk = d["attack"] = {"kind": "zda", "actuators": [labels[0]]}
    atk["lambda0"] = v
    if atk.get("kind") != "zda":
        atk["kind"] = "zda"
        atk.pop("sensors", None)
    return f"set attack.lambda0 = {_short(v)}"


#: kind -> mutator; every kind has explicit regression tests in test_spec_fuzzer.py
MUTATORS: dict[str, Callable[[dict[str, Any], Chooser], str]] = {
    "drop-key": _m_drop_key,
    "duplicate-item": _m_duplicate_item,
    "type-change": _m_type_change,
    "extreme-number": _m_extreme_number,
    "missing-node": _m_missing_node,
    "long-label": _m_long_label,
    "unicode-label": _m_unicode_label,
    "deep-nesting": _m_deep_nesting,
    "odd-mode-name": _m_odd_mode,
    "huge-time": _m_huge_time,
    "huge-gain": _m_gains,
    "lambda0": _m_lambda0,
    "mixed-labels": _m_mixed_labels,
    "domain-edge": _m_domain_edge,
}
TEXT_KINDS = ("duplicate-key",)
#: kinds used unless asked otherwise: domain-edge probes numerics inside the domain (opt-in)
OPT_IN_KINDS = ("domain-edge",)
KINDS = tuple(k for k in MUTATORS if k not in OPT_IN_KINDS) + TEXT_KINDS
#: kinds that may legitimately take long in simulate (the "deliberate extreme mutations")
EXTREME_KINDS = ("huge-time", "lambda0", "huge-gain")


def _duplicate_key_line(text: str, c: Chooser) -> tuple[str, str]:
    lines = text.split("\n")
    cands = [i for i, ln in enumerate(lines) if re.match(r'^[A-Za-z0-9_"-]+ = ', ln)]
    if not cands:
        return text + "format = 1\n", "duplicate key 'format'"
    i = c.choice(cands)
    lines.insert(i + 1, lines[i])
    key = lines[i].split(" = ", 1)[0]
    # find the table the key sits in
    table = next((lines[j] for j in range(i, -1, -1) if lines[j].startswith("[")), "<top>")
    return "\n".join(lines), f"duplicate key {key} in {table}"


def mutate(base: str, data: dict[str, Any], kinds: Sequence[str], c: Chooser) -> Mutant:
    """Apply the mutation ``kinds`` (in order) to a deep copy of ``data``."""
    d = copy.deepcopy(data)
    descs = []
    text_kinds = []
    for k in kinds:
        if k in TEXT_KINDS:
            text_kinds.append(k)
            continue
        try:
            descs.append(MUTATORS[k](d, c))
        except (OverflowError, MemoryError, TypeError, ValueError, KeyError, IndexError, AttributeError):
            # an earlier mutation left a shape this mutator cannot work on (e.g. nodes = 2**63 - 1)
            descs.append(f"({k} not applicable) " + _m_type_change(d, c))
    text = toml_dumps(d)
    for _ in text_kinds:
        text, desc = _duplicate_key_line(text, c)
        descs.append(desc)
    return Mutant(base, list(kinds), descs, text, d)


def random_mutant(c: Chooser, *, max_mutations: int = 3, kinds: Sequence[str] = KINDS, bases: Sequence[str] | None = None) -> Mutant:
    """A base spec with 1..max_mutations mutations drawn through ``c``."""
    all_bases = base_specs()
    pool = [b for b in all_bases if bases is None or b[0] in bases]
    name, data = c.choice(pool)
    n = c.choice([k for k, w in ((1, 6), (2, 3), (3, 1)) if k <= max_mutations for _ in range(w)])
    chosen = [c.choice(list(kinds)) for _ in range(n)]
    return mutate(name, data, chosen, c)


# ---------------------------------------------------------------------------------------------
# hypothesis strategies (optional: the campaign script runs without hypothesis)

# hypothesis is imported only when a strategy is asked for: the campaign's per-run interpreter
# imports this module for run_cli and should not pay for hypothesis.


def mutated_specs(max_mutations: int = 3, kinds: Sequence[str] = KINDS, bases: Sequence[str] | None = None) -> Any:
    """Strategy: a valid base spec broken by 1..max_mutations mutations (any of ``kinds``)."""
    from hypothesis import strategies as st

    @st.composite
    def _mutants(draw: Any) -> Mutant:
        return random_mutant(DrawChooser(draw), max_mutations=max_mutations, kinds=kinds, bases=bases)

    return _mutants()


def mutants_of_kind(kind: str, bases: Sequence[str] | None = None) -> Any:
    """Strategy: exactly one mutation of ``kind``."""
    return mutated_specs(max_mutations=1, kinds=(kind,), bases=bases)


def valid_specs() -> Any:
    """Strategy: the unmutated base specs."""
    from hypothesis import strategies as st

    return st.sampled_from([Mutant(n, [], [], toml_dumps(d), d) for n, d in base_specs()])


# ---------------------------------------------------------------------------------------------
# running the CLI


class FuzzTimeout(BaseException):
    """Raised by the SIGALRM handler; a BaseException so library ``except Exception`` blocks
    do not swallow it."""


@dataclass
class RunResult:
    outcome: str
    rc: int | None
    stdout: str
    stderr: str
    exc_type: str | None = None
    exc_message: str | None = None
    innermost: str | None = None  # file:line of the innermost traceback frame
    innermost_project: str | None = None  # innermost frame inside glocal_verify/
    elapsed: float = 0.0

    @property
    def stderr_lines(self) -> list[str]:
        return [ln for ln in self.stderr.splitlines() if ln.strip()]

    @property
    def last_stderr_line(self) -> str:
        lines = self.stderr_lines
        return lines[-1] if lines else ""

    @property
    def good(self) -> bool:
        return self.outcome in GOOD_OUTCOMES

    def summary(self) -> str:
        where = f" at {self.innermost_project or self.innermost}" if self.innermost else ""
        exc = f" {self.exc_type}: {(self.exc_message or '')[:300]}{where}" if self.exc_type else ""
        return f"{self.outcome} (rc={self.rc}, {self.elapsed:.1f}s){exc}; last stderr line: {self.last_stderr_line[:300]!r}"

    def to_json(self) -> dict[str, Any]:
        return {
            "outcome": self.outcome,
            "rc": self.rc,
            "stdout": self.stdout[:2000],
            "stderr": self.stderr[-20000:],
            "exc_type": self.exc_type,
            "exc_message": (self.exc_message or "")[:1000],
            "innermost": self.innermost,
            "innermost_project": self.innermost_project,
            "elapsed": self.elapsed,
        }


def _rel(filename: str) -> str:
    for marker in ("/glocal_verify/", "/site-packages/", "/lib/python3"):
        i = filename.rfind(marker)
        if i >= 0:
            return filename[i + 1 :]
    return filename


def frames_of(tb: Any) -> tuple[str | None, str | None]:
    """(innermost file:line, innermost glocal_verify file:line) of a traceback."""
    frames = [f for f in traceback.extract_tb(tb) if not f.filename.endswith("fuzz_support.py")]  # drop _alarm
    if not frames:
        return None, None
    inner = f"{_rel(frames[-1].filename)}:{frames[-1].lineno}"
    proj = next((f"{_rel(f.filename)}:{f.lineno}" for f in reversed(frames) if "/glocal_verify/" in f.filename), None)
    return inner, proj


_FH_FRAME = re.compile(r'^\s*File "([^"]+)", line (\d+)', re.M)


def stack_frames(dump: str) -> tuple[str | None, str | None]:
    """(innermost, innermost glocal_verify) file:line of a faulthandler dump (most recent first)."""
    frames = [(f, int(n)) for f, n in _FH_FRAME.findall(dump)]
    if not frames:
        return None, None
    inner = f"{_rel(frames[0][0])}:{frames[0][1]}"
    proj = next((f"{_rel(f)}:{n}" for f, n in frames if "/glocal_verify/" in f), None)
    return inner, proj


def classify(rc: int | None, stdout: str, stderr: str, exc: BaseException | None = None) -> str:
    if isinstance(exc, FuzzTimeout):
        return "hang"
    if isinstance(exc, MemoryError):
        return "blowup"
    if exc is not None:
        return "traceback"
    if "Traceback (most recent call last)" in stderr or "Traceback (most recent call last)" in stdout:
        return "traceback"
    if rc in (0, 1):
        return "ok"
    if rc == 2:
        lines = [ln for ln in stderr.splitlines() if ln.strip()]
        return "clean-error" if len(lines) <= MAX_ERROR_LINES else "multi-line"
    return "bad-exit"


def _alarm(signum: int, frame: Any) -> None:
    raise FuzzTimeout()


def _run_here(argv: Sequence[str], timeout_s: float) -> RunResult:
    from glocal_verify.cli import main

    out, err = io.StringIO(), io.StringIO()
    rc: int | None = None
    exc: BaseException | None = None
    old = signal.signal(signal.SIGALRM, _alarm)
    signal.setitimer(signal.ITIMER_REAL, timeout_s)
    t0 = time.monotonic()
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                rc = main(list(argv))
            except SystemExit as e:  # argparse or library code calling sys.exit
                rc = e.code if isinstance(e.code, int) else (0 if e.code is None else 2)
                if not isinstance(e.code, int) and e.code is not None:
                    print(e.code, file=sys.stderr)
    except BaseException as e:  # noqa: BLE001 - the point is to catch everything main lets out
        exc = e
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)
    elapsed = time.monotonic() - t0
    inner = proj = None
    if exc is not None:
        inner, proj = frames_of(exc.__traceback__)
        if isinstance(exc, KeyboardInterrupt):  # a real ^C of the test run
            raise exc
    return RunResult(
        classify(rc, out.getvalue(), err.getvalue(), exc),
        rc,
        out.getvalue(),
        err.getvalue(),
        type(exc).__name__ if exc is not None else None,
        str(exc)[:2000] if exc is not None else None,
        inner,
        proj,
        elapsed,
    )


def _warm_imports() -> None:
    """Import the CLI and what its commands load lazily, in the parent, so that every forked
    run starts warm (otherwise each child pays the 2-3 s import)."""
    import importlib

    for name in ("glocal_verify.cli", "glocal_verify.conditions.registry", "glocal_verify.design.placement", "glocal_verify.simulation.engine"):
        with contextlib.suppress(ImportError):
            importlib.import_module(name)


def _run_forked(argv: Sequence[str], timeout_s: float, memory_bytes: int | None, cwd: str | None = None, fsize: int | None = None) -> RunResult:
    import select

    _warm_imports()

    r, w = os.pipe()
    dump = tempfile.TemporaryFile()
    t0 = time.monotonic()
    pid = os.fork()
    if pid == 0:  # child
        try:
            os.close(r)
            # C-level writes must not reach the parent's stdin/stdout (the campaign's warm
            # worker speaks JSON lines on them)
            devnull = os.open(os.devnull, os.O_RDWR)
            os.dup2(devnull, 0)
            os.dup2(devnull, 1)
            import faulthandler

            # if the run is stuck in C code the SIGALRM handler never runs: leave a stack dump
            faulthandler.dump_traceback_later(timeout_s + 10.0, file=dump)
            if memory_bytes:
                resource.setrlimit(resource.RLIMIT_AS, (memory_bytes, memory_bytes))
            if cwd:
                os.chdir(cwd)
            if fsize is not None:  # a full disk: writes past fsize bytes fail with EFBIG
                signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
                resource.setrlimit(resource.RLIMIT_FSIZE, (fsize, fsize))
            res = _run_here(argv, timeout_s)
            payload = json.dumps(res.to_json()).encode()
        except BaseException as e:  # noqa: BLE001
            payload = json.dumps({"outcome": "blowup" if isinstance(e, MemoryError) else "crash", "rc": None, "stdout": "", "stderr": repr(e)[:2000]}).encode()
        try:
            with os.fdopen(w, "wb") as f:
                f.write(payload)
        finally:
            os._exit(0)
    os.close(w)
    chunks: list[bytes] = []
    deadline = t0 + timeout_s + 15.0  # the child's own SIGALRM fires first unless stuck in C
    killed = False
    try:
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                os.kill(pid, signal.SIGKILL)
                killed = True
                break
            ready, _, _ = select.select([r], [], [], min(left, 1.0))
            if ready:
                b = os.read(r, 1 << 16)
                if not b:
                    break
                chunks.append(b)
    finally:
        os.close(r)
        _, status = os.waitpid(pid, 0)
    elapsed = time.monotonic() - t0
    dump.seek(0)
    stack = dump.read().decode(errors="replace")
    dump.close()
    if killed:
        inner, proj = stack_frames(stack)
        return RunResult("hang", None, "", stack, "FuzzTimeout", "killed after the time budget (stuck outside Python code)", inner, proj, elapsed)
    try:
        d = json.loads(b"".join(chunks).decode())
    except ValueError:
        sig = os.WTERMSIG(status) if os.WIFSIGNALED(status) else None
        return RunResult("crash", None, "", "", f"signal {sig}" if sig else "no result", None, elapsed=elapsed)
    return RunResult(
        d["outcome"], d.get("rc"), d.get("stdout", ""), d.get("stderr", ""), d.get("exc_type"), d.get("exc_message"),
        d.get("innermost"), d.get("innermost_project"), d.get("elapsed", elapsed),
    )


def run_cli(
    argv: Sequence[str], timeout_s: float = 60.0, *, fork: bool = False, memory_bytes: int | None = None, cwd: str | None = None, fsize: int | None = None
) -> RunResult:
    """Run ``glocal_verify.cli.main(argv)`` and classify the outcome.

    In-process by default (stdout/stderr captured with ``contextlib.redirect_*``, SystemExit
    caught, a SIGALRM time budget of ``timeout_s``). With ``fork=True``, ``memory_bytes``,
    ``cwd`` or ``fsize`` the run happens in a forked child whose address space is bounded with
    ``RLIMIT_AS = memory_bytes``, working in ``cwd``, whose files may not grow past ``fsize``
    bytes (a full disk); the parent kills it if it overruns the budget inside C code.
    """
    if fork or memory_bytes or cwd or fsize is not None:
        return _run_forked(argv, timeout_s, memory_bytes, cwd, fsize)
    return _run_here(argv, timeout_s)


# ---------------------------------------------------------------------------------------------
# commands

COMMANDS = ("verify", "verify-exact", "simulate", "place-observers", "export", "verify-deployment")
#: further commands the campaign can run (``--commands``): simulate with its figures
EXTRA_COMMANDS = ("simulate-figures",)


def command_argv(command: str, spec_path: str | Path, work_dir: str | Path) -> list[str]:
    """The argv of ``command`` on ``spec_path`` (simulate writes into ``work_dir``)."""
    spec = str(spec_path)
    if command == "verify":
        return ["verify", spec]
    if command == "verify-exact":
        return ["verify", spec, "--exact"]
    if command == "simulate":
        return ["simulate", spec, "--no-figures", "--out", str(Path(work_dir) / "sim")]
    if command == "simulate-figures":
        return ["simulate", spec, "--out", str(Path(work_dir) / "sim")]
    if command == "place-observers":
        return ["place-observers", spec]
    if command == "export":
        return ["export", spec, "--quiet", "--out", str(Path(work_dir) / "deployment.json")]
    if command == "verify-deployment":
        return ["verify", spec, "--quiet", "--only", "detection.*,sampled.*"]
    raise ValueError(command)


def run_mutant(mutant: Mutant, command: str, timeout_s: float = 60.0, *, fork: bool = True, memory_bytes: int | None = 4 << 30) -> RunResult:
    """Write ``mutant`` to a temporary file and run ``command`` on it."""
    with tempfile.TemporaryDirectory(prefix="glocal-fuzz-") as tmp:
        spec = Path(tmp) / "spec.toml"
        spec.write_text(mutant.text, encoding="utf-8")
        return run_cli(command_argv(command, spec, tmp), timeout_s, fork=fork, memory_bytes=memory_bytes)


# =============================================================================================
# every surface: graph files, sweep files, command-line options, output paths, signals
#
# A Case is one run of the command line in a fresh work folder: the files it starts from, the
# links and folders set up around them, the argv (relative to the work folder), what must not
# change (the inputs, the targets of symbolic links, folders reached through a link), and
# optionally a signal sent at a moment of the run. run_case runs it and checks, besides the
# outcome classes of `classify`, the output policy: no input overwritten, nothing written
# through a link, no ".glocal-partial-*" left, no empty folder left by a failed run, and, for
# signalled runs, no process of the run's session alive after it ended.

#: the input kinds of the campaign
INPUTS = ("spec", "graph", "sweep", "options", "output", "signal")
#: outcomes the surface checks add (each a violation)
SURFACE_OUTCOMES = ("overwrote-input", "symlink-write", "partial-left", "empty-folder", "survivor", "replaced-special")
#: setup operations that make a special file, whose kind a run must leave unchanged
SPECIAL_FILES = ("chardev", "blockdev", "fifo", "socket")
ALL_OUTCOMES = OUTCOMES + SURFACE_OUTCOMES
_PARTIAL = ".glocal-partial-"


@dataclass
class Case:
    """One command-line run over hostile input (see the section comment)."""

    kind: str
    command: str
    argv: list[str]
    files: dict[str, bytes] = field(default_factory=dict)
    setup: list[tuple[str, ...]] = field(default_factory=list)
    protected: list[str] = field(default_factory=list)
    forbidden: list[str] = field(default_factory=list)
    signal: tuple[int, float] | None = None
    fsize: int | None = None
    description: str = ""

    def to_json(self) -> dict[str, Any]:
        import base64

        d = {k: getattr(self, k) for k in ("kind", "command", "argv", "setup", "protected", "forbidden", "signal", "fsize", "description")}
        d["files"] = {k: base64.b64encode(v).decode() for k, v in self.files.items()}
        return d

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> Case:
        import base64

        files = {k: base64.b64decode(v) for k, v in d.get("files", {}).items()}
        sig = tuple(d["signal"]) if d.get("signal") else None
        return cls(d["kind"], d["command"], list(d["argv"]), files, [tuple(x) for x in d.get("setup", [])], list(d.get("protected", [])),
                   list(d.get("forbidden", [])), sig, d.get("fsize"), d.get("description", ""))  # type: ignore[arg-type]


def _spec_text(name: str = "cycle8") -> bytes:
    return toml_dumps(copy.deepcopy(dict(base_specs())[name])).encode()


# ---------------------------------------------------------------------------------------------
# graph files


def _graph_texts() -> dict[str, str]:
    """The cycle8 graph (weights 1, 2 and 3) in every format load_graph reads."""
    import networkx as nx

    g = nx.cycle_graph(range(1, 9))
    nx.set_edge_attributes(g, 1, "weight")
    g.add_edge(2, 4, weight=2)
    g.add_edge(6, 8, weight=3)
    edges = [(u, v, d["weight"]) for u, v, d in g.edges(data=True)]
    return {
        ".txt": "".join(f"{u} {v} {w}\n" for u, v, w in edges),
        ".csv": "source,target,weight\n" + "".join(f"{u},{v},{w}\n" for u, v, w in edges),
        ".gml": "\n".join(nx.generate_gml(g)) + "\n",
        ".graphml": "\n".join(nx.generate_graphml(g)) + "\n",
    }


_LAUGHS = (
    '<?xml version="1.0"?>\n<!DOCTYPE lolz [<!ENTITY lol "lol">'
    + "".join(f'<!ENTITY lol{i} "{("&lol" + (str(i - 1) if i > 1 else "") + ";") * 10}">' for i in range(1, 10))
    + ']>\n<graphml xmlns="http://graphml.graphdrawing.org/xmlns"><graph edgedefault="undirected"><node id="&lol9;"/><node id="b"/>'
    '<edge source="b" target="&lol9;"/></graph></graphml>\n'
)
_XXE = (
    '<?xml version="1.0"?>\n<!DOCTYPE g [<!ENTITY x SYSTEM "file:///etc/passwd">]>\n<graphml xmlns="http://graphml.graphdrawing.org/xmlns">'
    '<graph edgedefault="undirected"><node id="&x;"/><node id="b"/><edge source="b" target="&x;"/></graph></graphml>\n'
)
GRAPH_WEIGHTS = ["nan", "inf", "-1", "0", "1e9999999", "1/0", "abc", "9" * 5000, "1e-300", "2.5", "1/3", "-0", "True", "1e308"]
GRAPH_LABELS = ["ノード", "a b", "x" * 100_000, "\u202e", "1.5", "-0", "007", "", "#", "{'a': 1}"]


def _g_mutation(ext: str, text: str, c: Chooser) -> tuple[str, str | bytes, str]:
    """(file suffix, content, description) of one mutation of a graph file."""
    lines = text.splitlines()
    what = c.choice(["deep", "garbage", "truncate", "weight", "label", "selfloop", "duplicate", "directed", "bytes", "empty", "many", "suffix", "xml"])
    if what == "deep":
        depth = c.choice([50, 900, 20_000])
        if ext == ".gml":
            return ext, "graph [\n" + "a [ " * depth + "]" * depth + "\n node [ id 1 ]\n]\n", f"GML lists nested {depth} deep"
        if ext == ".graphml":
            body = "<data key='d0'>" * depth + "1" + "</data>" * depth
            return ext, text.replace("</graph>", body + "</graph>"), f"XML nested {depth} deep"
        return ext, f"1 2 {{'weight': {'[' * depth}1{']' * depth}}}\n", f"edge data nested {depth} deep"
    if what == "xml":
        kind = c.choice(["port", "laughs", "xxe", "hyperedge", "directed-default"])
        if kind == "port":
            return ".graphml", text.replace('<node id="1">', '<node id="1"><port name="p"/>').replace('<node id="1" />', '<node id="1"><port name="p"/></node>'), "GraphML <port>"
        if kind == "laughs":
            return ".graphml", _LAUGHS, "GraphML entity expansion (billion laughs)"
        if kind == "xxe":
            return ".graphml", _XXE, "GraphML external entity"
        if kind == "hyperedge":
            return ".graphml", text.replace("</graph>", '<hyperedge><endpoint node="1"/><endpoint node="2"/></hyperedge></graph>'), "GraphML hyperedge"
        return ".graphml", text.replace('edgedefault="undirected"', 'edgedefault="directed"'), "GraphML directed"
    if what == "garbage":
        k = c.integer(0, max(0, len(text) - 1))
        junk = c.choice(["[", "]", '"', "<", ">", "&", "\x00", ",", "{", "}", "\u00ff"])
        return ext, text[:k] + junk * c.integer(1, 5) + text[k:], f"{junk!r} inserted at {k}"
    if what == "truncate":
        k = c.integer(0, max(0, len(text) - 1))
        return ext, text[:k], f"cut at {k} of {len(text)}"
    if what == "weight":
        w = c.choice(GRAPH_WEIGHTS)
        if ext in (".txt", ".csv"):
            sep = "," if ext == ".csv" else " "
            return ext, text + f"1{sep}5{sep}{w}\n", f"weight {w[:20]!r}"
        return ext, text.replace(">1<", f">{w}<", 1).replace("weight 1", f"weight {w}", 1), f"weight {w[:20]!r}"
    if what == "label":
        lab = c.choice(GRAPH_LABELS)
        if ext == ".csv":
            return ext, text + f"{lab},1,1\n", f"label {lab[:20]!r}"
        if ext == ".txt":
            return ext, text + f"{lab} 1 1\n", f"label {lab[:20]!r}"
        return ext, text.replace('"1"', json.dumps(lab), 1), f"label {lab[:20]!r}"
    if what == "selfloop":
        return ".txt", "1 1 1\n2 3 1\n", "self loop"
    if what == "duplicate":
        return ext, text + (lines[1 if ext == ".csv" else 0] + "\n" if ext in (".txt", ".csv") and lines else ""), "duplicate edge"
    if what == "directed":
        if ext == ".gml":
            return ext, text.replace("graph [", "graph [\n  directed 1\n  multigraph 1", 1), "GML directed multigraph"
        return ".graphml", text.replace('edgedefault="undirected"', 'edgedefault="directed"'), "directed"
    if what == "bytes":
        return ext, bytes(c.integer(0, 255) for _ in range(c.integer(1, 300))), "random bytes"
    if what == "empty":
        return ext, "", "empty file"
    if what == "many":
        n = c.choice([100_001, 200_000])
        return ".txt", "".join(f"{i} {i + 1}\n" for i in range(1, n)), f"a path of {n} nodes"
    return c.choice([".xml", ".json", ".toml", ""]), text, "unknown suffix"


def graph_case(c: Chooser) -> Case:
    """``verify --graph`` on a mutated graph file (any of the formats)."""
    texts = _graph_texts()
    ext = c.choice(list(texts))
    suffix, content, desc = _g_mutation(ext, texts[ext], c)
    name = "g" + suffix
    data = content.encode("utf-8", "surrogatepass") if isinstance(content, str) else content
    argv = ["verify", "--graph", name, "--quiet", "--simulate", "never"]
    if c.choice([False, True]):
        argv += [c.choice(["--velocities", "--positions"]), c.choice(["1,5", "99", "", "1,1", "ノード", "a b"])]
    if c.choice([False, False, True]):
        argv += ["--out", "report.md"]
    if c.integer(0, 9) == 0:
        return Case("graph", "verify --graph", ["verify", "--graph", c.choice(["missing.txt", "folder.graphml"]), "--quiet"],
                    setup=[("mkdir", "folder.graphml")], description="a missing file or a folder")
    return Case("graph", "verify --graph", argv, {name: data}, protected=[name], description=f"{ext} -> {suffix}: {desc}")


# ---------------------------------------------------------------------------------------------
# sweep files

SWEEP_BASE: dict[str, Any] = {
    "ensemble": {"generator": "random-clustered", "agents": [10], "clusters": 2, "seeds": {"start": 0, "count": 1}},
    "compute": {"conditions": ["privacy.kernel"]},
}
#: values a sweep key may take: inside the domain but small, or far outside it (never a valid
#: sweep that runs for minutes)
SWEEP_VALUES: dict[tuple[str, ...], list[Any]] = {
    ("ensemble", "agents"): [[100_000], [10**9], [0], [-5], ["x"], [10.5], [2**64], 1e308, [10, 12], 10, [[10]], [], [1e-300], [True]],
    ("ensemble", "clusters"): [0, 10**6, 5, -1, "2", 2.0, [2, 3], True],
    ("ensemble", "seeds"): [{"start": 2**64, "count": 1}, {"start": -1, "count": 1}, {"start": 0, "count": 10**6}, {"start": 0, "count": 10**7},
                            {"start": 0, "count": 0}, [2**63], [], [1, 1], [0, 1], {"start": 2**63 - 1, "count": 2}, {"count": 1}, {"start": 0},
                            {"start": 0, "count": 1, "x": 1}, "0..3", 5],
    ("ensemble", "generator"): [["random-clustered"], "x", 5, {}, "", "random-clustered ", None],
    ("ensemble", "chords"): [float("nan"), float("inf"), -1, 1e300, "a"],
    ("ensemble", "horizon"): [1e300, -1, 0, "1"],
    ("ensemble", "modes"): [10**6, -1, 0, [0, 1]],
    ("ensemble", "monitors"): [10**6, -1, 0],
    ("ensemble", "specs"): ["/", "../../", "nonexistent", "specs", "specs", "", 5, "a\u0000b", "x" * 5000],
    ("ensemble", "attack"): ["yes", 1, [True, False]],
    ("ensemble", "bogus"): [1],
    ("compute", "conditions"): [["nope"], [], "privacy.*", [1], ["privacy.*", "switching.*"], ["privacy.kernel"] * 3, [""]],
    ("compute", "exact"): ["yes", 1, True],
    ("compute", "escalate"): ["", "always", None],
    ("bogus",): [{"a": 1}],
}


def sweep_case(c: Chooser) -> Case:
    """``sweep`` on a mutated sweep file (curated values, generic mutations, raw nesting)."""
    d = copy.deepcopy(SWEEP_BASE)
    descs: list[str] = []
    files: dict[str, bytes] = {}
    for _ in range(c.choice([1, 1, 2])):
        how = c.choice(["value", "value", "value", "generic", "deep"])
        if how == "value":
            key = c.choice(list(SWEEP_VALUES))
            v = copy.deepcopy(c.choice(SWEEP_VALUES[key]))
            if v is None:
                with contextlib.suppress(KeyError):
                    del_at(d, key)
                descs.append(f"drop {'.'.join(key)}")
                continue
            tgt = d
            for k in key[:-1]:
                tgt = tgt.setdefault(k, {}) if isinstance(tgt, dict) else {}
            if isinstance(tgt, dict):
                tgt[key[-1]] = v
            if key[-1] == "specs" and isinstance(d.get("ensemble"), dict):
                for k in list(d["ensemble"]):
                    if k == "generator" or (k != "specs" and c.choice([True, True, False])):
                        del d["ensemble"][k]
                if v == "specs":
                    for i in range(c.integer(1, 2)):
                        files[f"specs/m{i}.toml"] = random_mutant(c, max_mutations=1, bases=("cycle8", "random-10-2-s0")).text.encode()
            descs.append(f"set {'.'.join(key)} = {_short(v)}")
        elif how == "generic":
            descs.append(c.choice([_m_drop_key, _m_type_change, _m_duplicate_item])(d, c))
        else:
            depth = c.choice([50, 900, 10_000])
            nested = RawToml("[" * depth + "10" + "]" * depth)
            if isinstance(d.get("ensemble"), dict):
                d["ensemble"]["agents"] = nested
            else:  # an earlier mutation changed the table's type: a fresh table holds the nesting
                d["ensemble"] = {"agents": nested}
            descs.append(f"agents nested {depth} deep")
    try:
        text = toml_dumps(d)
    except (TypeError, ValueError, RecursionError):
        text = toml_dumps(copy.deepcopy(SWEEP_BASE))
    name = c.choice(["sw.toml", "sw.toml", "sw.csv"])
    files[name] = text.encode()
    out = c.choice(["res.csv", "res.csv", "res.parquet", "sub/res.csv"])
    argv = ["sweep", name, "--out", out]
    if c.choice([True, False]):
        argv.append("--quiet")
    if c.choice([True, False]):
        argv.append("--no-figures")
    if c.choice([True, False]):
        argv += ["--workers", c.choice(["1", "2", "4"])]
    if c.integer(0, 6) == 0:  # one bad option (the sweep file is then never read)
        bad = c.choice([["--workers", c.choice(["0", "-3", "x"])], ["--chunk", c.choice(["0", "-1", "10000000000"])], ["--out", c.choice(["res.txt", name, ""])]])
        argv += bad
        descs.append(" ".join(bad))
    return Case("sweep", "sweep", argv, files, protected=[name] + [k for k in files if k.startswith("specs/")], description="; ".join(descs))


# ---------------------------------------------------------------------------------------------
# command-line options

NUMBERS = ["0", "-1", "1", "2", "1e-300", "1e308", "inf", "-inf", "nan", "abc", "", "1e16", "9" * 400, "0x10", "1_000", "1e-9", "0.5"]
INTEGERS = ["0", "-1", "1", "2", "3", "1000000000", "9" * 400, "abc", "", "1.5", "-0"]
IDS = ["privacy.*", "nope", "", ",,,", "privacy.kernel,nope", "switching.*", "local.uio", "*", "privacy.", "stealthy.zda,stealthy.zda"]
AGENTS = ["1,2", "99", "", ",", "ノード", "1,1", "1", "a b", "-1"]
OPTIONS: dict[str, list[tuple[str, list[str] | None]]] = {
    "verify": [("--format", ["json", "markdown", "html", "pdf", ""]), ("--only", IDS), ("--require", IDS), ("--rtol", NUMBERS), ("--band", NUMBERS),
               ("--simulate", ["auto", "never", "always", "x"]), ("--escalate", ["auto", "never", ""]), ("--exact-budget", NUMBERS),
               ("--fragile-below", NUMBERS), ("--exact", None), ("--quiet", None), ("--velocities", AGENTS), ("--allow-large", None)],
    "audit": [("--max-attackers", INTEGERS), ("--agents", AGENTS), ("--sensors", AGENTS), ("--format", ["json", "markdown", "html", "x"]),
              ("--growth", ["full", "verdict", "x"]), ("--chunk", INTEGERS), ("--workers", ["1", "2", "0", "-1", "64", "x"]),
              ("--scheduler", ["xyz", "tcp://127.0.0.1:1", "tcp://[::1", "", "tls://127.0.0.1:1"]), ("--exact", None), ("--quiet", None),
              ("--dashboard", ["127.0.0.1:0", ":x", "999999"])],
    "design": [("--budget", INTEGERS), ("--max-links", INTEGERS), ("--max-attackers", INTEGERS), ("--no-observers", None), ("--numeric", None),
               ("--quiet", None)],
    "place-observers": [("--cluster", ["A", "nope", "", "B"]), ("--suspected", ["attack", "interior", "all", "1,2", "99", "", "x"]),
                        ("--exact-limit", INTEGERS), ("--format", ["toml", "json", "x"]), ("--quiet", None)],
    "simulate": [("--mode", ["s1", "nope", "..", "", "normal"]), ("--no-switch", None), ("--trigger", ["auto", "schedule", "local", "x"]),
                 ("--method", ["auto", "dense", "modal", "x"]), ("--threshold", ["envelope", "calibrated", "x"]), ("--cases", None), ("--quiet", None)],
    "draw": [("--mode", ["s1", "nope", "..", "", "normal"])],
    "findings": [("--dir", ["specs", "nonexistent", ".", ""])],
    "example": [],
    "conditions": [],
}


def options_case(c: Chooser) -> Case:
    """A command with 1-3 options set to values at and beyond their domains."""
    command = c.choice(list(OPTIONS))
    files = {"spec.toml": _spec_text("cycle8")}
    argv: list[str] = []
    if c.choice([False, False, False, True]):
        argv += ["--threads", c.choice(INTEGERS)]
    argv.append(command)
    if command in ("verify", "audit", "design", "place-observers", "simulate", "draw"):
        argv.append("spec.toml")
    if command == "simulate":
        argv += ["--no-figures", "--out", "sim"]
    if command == "findings":
        files["specs/m0.toml"] = random_mutant(c, max_mutations=1, bases=("cycle8",)).text.encode()
    if command == "example":
        argv.append(c.choice(["paper19", "nope", "", "../x", "--list"]))
    pool = OPTIONS[command]
    for _ in range(c.integer(1, 3) if pool else 0):
        opt, values = c.choice(pool)
        argv.append(opt)
        if values is not None:
            argv.append(c.choice(values))
    return Case("options", command, argv, files, protected=list(files), description=" ".join(argv)[:300])


# ---------------------------------------------------------------------------------------------
# output paths

#: (label, argv before the target, option, input files, whether the output is a folder)
WRITERS: list[tuple[str, list[str], str, bool]] = [
    ("verify", ["verify", "spec.toml", "--quiet"], "--out", False),
    ("verify --graph", ["verify", "--graph", "g.txt", "--quiet"], "--out", False),
    ("audit", ["audit", "spec.toml", "--quiet"], "--out", False),
    ("audit folder", ["audit", "spec.toml", "--quiet"], "--out", True),
    ("audit --figure", ["audit", "spec.toml", "--quiet"], "--figure", False),
    ("design", ["design", "spec.toml", "--quiet"], "--out", False),
    ("place-observers", ["place-observers", "spec.toml", "--quiet"], "--out", False),
    ("draw", ["draw", "spec.toml"], "--out", False),
    ("simulate", ["simulate", "spec.toml", "--no-figures", "--quiet"], "--out", True),
    ("findings", ["findings", "--dir", "specs"], "--out", False),
    ("sweep", ["sweep", "sw.csv", "--quiet", "--no-figures"], "--out", False),
    ("export", ["export", "spec.toml", "--quiet", "--format", "json"], "--out", False),
    ("export mat", ["export", "spec.toml", "--quiet", "--no-thresholds", "--format", "mat"], "--out", False),
]
TARGETS = ["input", "./input", "abs-input", "sub/../input", "missing/../input", "hardlink", "symlink-file", "symlink-to-input",
           "symlinked-folder", "inside-symlinked-folder", "folder-as-file", "file-as-folder", "deep-new", "full-disk", "plain",
           # targets of every kind (devices and FIFOs are made in the work folder, never the machine's own)
           "null-device", "full-device", "link-to-device", "fifo", "socket", "block-device", "long-name", "long-path", "dash", "empty"]


#: a bundled findings spec (with its [finding] table): the input of ``findings --dir specs``
_FINDING = ROOT / "glocal_verify" / "spec" / "data" / "findings" / "prop-ii4-covert-needs-sensors.toml"


def output_case(c: Chooser) -> Case:
    """A writing command whose output location attacks its inputs, goes through a link or is a
    special file."""
    label, argv, opt, folder = c.choice(WRITERS)
    return target_case(label, c.choice(TARGETS), c)


def target_case(label: str, target: str, c: Chooser) -> Case:
    """The writer ``label`` of :data:`WRITERS` with its output at ``target`` (one of :data:`TARGETS`)."""
    label, argv, opt, folder = next(w for w in WRITERS if w[0] == label)
    files = {"spec.toml": _spec_text("cycle8"), "g.txt": _graph_texts()[".txt"].encode(), "specs/f.toml": _FINDING.read_bytes(),
             "sw.csv": toml_dumps(SWEEP_BASE).encode(), "target.md": b"the link's target\n", "realdir/keep.txt": b"keep\n", "f.txt": b"a file\n"}
    inp = {"sweep": "sw.csv", "findings": "specs/f.toml", "verify --graph": "g.txt"}.get(label, "spec.toml")
    setup: list[tuple[str, ...]] = [("mkdir", "d")]
    forbidden: list[str] = []
    fsize = None
    suffix = ".csv" if label == "sweep" else (".svg" if label == "audit --figure" else ".md")
    if target == "input":
        out = inp
    elif target == "./input":
        out = "./" + inp
    elif target == "abs-input":
        out = "{work}/" + inp
    elif target == "sub/../input":
        setup.append(("mkdir", "sub"))
        out = "sub/../" + inp
    elif target == "missing/../input":
        out = "missing/../" + inp
    elif target == "hardlink":
        setup.append(("hardlink", "hl" + suffix, inp))
        out = "hl" + suffix
    elif target == "symlink-file":
        setup.append(("symlink", "link" + suffix, "target.md"))
        out = "link" + suffix
    elif target == "symlink-to-input":
        setup.append(("symlink", "lnk" + suffix, inp))
        out = "lnk" + suffix
    elif target in ("symlinked-folder", "inside-symlinked-folder"):
        setup.append(("symlink", "ldir", "realdir"))
        forbidden.append("realdir")
        out = "ldir" if (folder or target == "symlinked-folder") else "ldir/out" + suffix
        if folder and target == "inside-symlinked-folder":
            out = "ldir/sub"
        if label == "audit folder" and out == "ldir":
            out = "ldir/"
    elif target == "folder-as-file":
        out = "d"
    elif target == "file-as-folder":
        out = "f.txt" + ("/" if label == "audit folder" else "") if folder else "f.txt/out" + suffix
    elif target == "deep-new":
        out = "a/b/c/" + ("" if folder else "out" + suffix)
    elif target == "full-disk":
        fsize = c.choice([0, 100, 3000])
        setup.append(("mkdir", "full"))
        out = "full/" + ("" if folder else "out" + suffix)
    elif target in ("null-device", "full-device", "link-to-device"):
        setup.append(("chardev", "dev" + suffix, "7" if target == "full-device" else "3"))
        out = "dev" + suffix
        if target == "link-to-device":
            setup.append(("symlink", "devlink" + suffix, "dev" + suffix))
            out = "devlink" + suffix
    elif target == "fifo":
        setup.append(("fifo", "pipe" + suffix))
        out = "pipe" + suffix
    elif target == "socket":
        setup.append(("socket", "sock" + suffix))
        out = "sock" + suffix
    elif target == "block-device":
        setup.append(("blockdev", "disk" + suffix))
        out = "disk" + suffix
    elif target == "long-name":
        out = "n" * c.choice([256, 300, 1000]) + suffix
    elif target == "long-path":
        out = "/".join(["p" * 200] * c.choice([21, 30])) + "/out" + suffix
    elif target == "dash":
        out = "-"
    elif target == "empty":
        out = ""
    else:
        out = "out/" if folder else "out" + suffix
    if label == "audit folder" and not out.endswith("/") and target in ("deep-new", "plain", "full-disk"):
        out += "/"
    protected = ["spec.toml", "g.txt", "specs/f.toml", "sw.csv", "target.md", "f.txt"]
    return Case("output", label, argv + [opt, out], files, setup, protected, forbidden, fsize=fsize, description=f"{label}: {opt} {out} ({target})")


# ---------------------------------------------------------------------------------------------
# signals at random moments

_MID_SWEEP = {"ensemble": {"generator": "random-clustered", "agents": [80], "clusters": 3, "seeds": {"start": 0, "count": 6}}}


def _escalating_spec() -> bytes:
    from glocal_verify.design.generators import random_clustered_spec
    from glocal_verify.spec.writer import dump_spec

    return dump_spec(random_clustered_spec(80, 3, seed=100)).encode()  # its stealthy.zda escalates (a forked exact run)


#: (label, argv, files maker, longest useful moment of the signal in seconds)
SIGNALLED: list[tuple[str, list[str], Callable[[], dict[str, bytes]], float]] = [
    ("verify", ["verify", "--example", "paper19", "--out", "r.md"], dict, 3.0),
    ("verify escalating", ["verify", "esc.toml", "--simulate", "never", "--out", "r.md"], lambda: {"esc.toml": _escalating_spec()}, 14.0),
    ("verify --exact", ["verify", "spec.toml", "--exact", "--out", "r.json", "--format", "json"], lambda: {"spec.toml": _spec_text("random-14-3-s2")}, 2.5),
    ("simulate --cases", ["simulate", "--example", "paper19", "--cases", "--out", "cases"], dict, 15.0),
    ("audit", ["audit", "--example", "paper19", "--workers", "2", "--out", "a/"], dict, 3.0),
    ("design", ["design", "spec.toml", "--out", "d.toml"], lambda: {"spec.toml": _spec_text("cycle8")}, 3.5),
    ("sweep on Dask", ["sweep", "sw.toml", "--out", "r.csv"], lambda: {"sw.toml": toml_dumps(_MID_SWEEP).encode()}, 16.0),
    ("sweep in process", ["sweep", "sw.toml", "--out", "r.csv"], lambda: {"sw.toml": toml_dumps(SWEEP_BASE).encode()}, 2.8),
    ("place-observers", ["place-observers", "--example", "paper19", "--out", "p.toml"], dict, 2.5),
]
STOP_LINES = {signal.SIGINT: "glocal-verify: interrupted", signal.SIGTERM: "glocal-verify: terminated (SIGTERM)", signal.SIGHUP: "glocal-verify: hung up (SIGHUP)"}


def signal_case(c: Chooser) -> Case:
    """A command stopped by SIGINT (to its process group, as a terminal does), SIGTERM or SIGHUP."""
    label, argv, make, longest = c.choice(SIGNALLED)
    sig = c.choice([signal.SIGINT, signal.SIGTERM, signal.SIGHUP])
    at = round(0.2 + (longest - 0.2) * c.integer(0, 1000) / 1000.0, 2)
    files = make()
    return Case("signal", label, list(argv), files, protected=list(files), signal=(int(sig), at), description=f"{label}: {signal.Signals(sig).name} after {at} s")


CASE_MAKERS: dict[str, Callable[[Chooser], Case]] = {"graph": graph_case, "sweep": sweep_case, "options": options_case, "output": output_case, "signal": signal_case}


def spec_case(c: Chooser, command: str | None = None, bases: Sequence[str] | None = None) -> Case:
    """A mutated spec through one of :data:`COMMANDS` (the first campaign, as a Case)."""
    m = random_mutant(c, bases=bases)
    cmd = command or c.choice(list(COMMANDS))
    return Case("spec", cmd, command_argv(cmd, "spec.toml", "."), {"spec.toml": m.text.encode()}, protected=["spec.toml"], description=m.description[:2000])


def random_case(c: Chooser, kind: str, *, bases: Sequence[str] | None = None) -> Case:
    return spec_case(c, bases=bases) if kind == "spec" else CASE_MAKERS[kind](c)


# ---------------------------------------------------------------------------------------------
# running a case and checking the output policy


def _prepare(case: Case, work: Path) -> None:
    for name, data in case.files.items():
        p = work / name
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_bytes(data)
    for op in case.setup:
        if op[0] == "mkdir":
            (work / op[1]).mkdir(parents=True, exist_ok=True)
        elif op[0] == "symlink":
            (work / op[2]).parent.mkdir(parents=True, exist_ok=True)
            os.symlink(op[2], work / op[1])
        elif op[0] == "hardlink":
            os.link(work / op[2], work / op[1])
        elif op[0] == "chardev":  # the null (1, 3) or full (1, 7) device's numbers, in the work folder
            os.mknod(work / op[1], stat.S_IFCHR | 0o666, os.makedev(1, int(op[2])))
        elif op[0] == "blockdev":  # numbers with no driver: even a wrong open could not reach a disk
            os.mknod(work / op[1], stat.S_IFBLK | 0o600, os.makedev(0, 0))
        elif op[0] == "fifo":
            os.mkfifo(work / op[1])
        elif op[0] == "socket":
            sock = socket.socket(socket.AF_UNIX)
            sock.bind(str(work / op[1]))
            sock.close()


def _snapshot(case: Case, work: Path) -> dict[str, Any]:
    snap: dict[str, Any] = {"files": {}, "links": {}, "forbidden": {}, "dirs": set(), "kinds": {}}
    for name in case.protected:
        p = work / name
        if p.exists() and not p.is_symlink():
            snap["files"][name] = hashlib_sha(p.read_bytes())
    for op in case.setup:
        if op[0] == "symlink":
            snap["links"][op[1]] = op[2]
        if op[0] in SPECIAL_FILES:
            snap["kinds"][op[1]] = stat.S_IFMT(os.lstat(work / op[1]).st_mode)
    for name in case.forbidden:
        snap["forbidden"][name] = sorted(str(q.relative_to(work / name)) for q in (work / name).rglob("*"))
    snap["dirs"] = {str(q.relative_to(work)) for q in work.rglob("*") if q.is_dir() and not q.is_symlink()}
    return snap


def hashlib_sha(data: bytes) -> str:
    import hashlib

    return hashlib.sha256(data).hexdigest()


def check_policy(case: Case, work: Path, snap: dict[str, Any], rc: int | None) -> str | None:
    """The first output-policy violation of a finished run, or None."""
    for name, digest in snap["files"].items():
        p = work / name
        if p.is_symlink() or not p.is_file() or hashlib_sha(p.read_bytes()) != digest:
            return "overwrote-input"
    for link, target in snap["links"].items():
        p = work / link
        if not p.is_symlink() or os.readlink(p) != target:
            return "symlink-write"
    for name, kind in snap["kinds"].items():
        try:
            if stat.S_IFMT(os.lstat(work / name).st_mode) != kind:
                return "replaced-special"
        except FileNotFoundError:
            return "replaced-special"
    for name, listing in snap["forbidden"].items():
        if sorted(str(q.relative_to(work / name)) for q in (work / name).rglob("*")) != listing:
            return "symlink-write"
    for q in work.rglob("*"):
        if _PARTIAL in q.name:
            return "partial-left"
    if rc not in (0, 1):
        new_dirs = {str(q.relative_to(work)) for q in work.rglob("*") if q.is_dir() and not q.is_symlink()} - snap["dirs"]
        if any(not any((work / d).iterdir()) for d in new_dirs):
            return "empty-folder"
    return None


def _session_survivors(sid: int) -> list[str]:
    out = []
    for d in os.listdir("/proc"):
        if not d.isdigit():
            continue
        try:
            if os.getsid(int(d)) != sid:
                continue
            with open(f"/proc/{d}/stat") as fh:
                state = fh.read().rsplit(")", 1)[1].split()[0]
            if state != "Z":
                with open(f"/proc/{d}/cmdline", "rb") as fh:
                    cmd = fh.read().replace(b"\0", b" ").decode(errors="replace")[:120]
                out.append(f"{d}: {cmd}")
        except (OSError, IndexError):
            continue
    return out


def _default_stop_signals() -> None:
    """In the child before it runs: the stop signals at their default, as a shell starts a
    command. A campaign started under ``nohup`` (SIGHUP ignored) would otherwise hand its runs an
    ignored SIGHUP, which the command rightly keeps ignoring: every SIGHUP case would "hang"."""
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, signal.SIG_DFL)


def _run_signalled(case: Case, work: Path, timeout_s: float) -> RunResult:
    """Run the case as a real process in its own session and send it its signal."""
    import subprocess

    assert case.signal is not None
    sig, at = case.signal
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    argv = [a.replace("{work}", str(work)) for a in case.argv]
    t0 = time.monotonic()
    p = subprocess.Popen([sys.executable, "-m", "glocal_verify", *argv], cwd=work, env=env, stdin=subprocess.DEVNULL,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True,
                         preexec_fn=_default_stop_signals)  # noqa: PLW1509 - one thread here
    try:
        out, err = p.communicate(timeout=at)
    except subprocess.TimeoutExpired:
        try:
            os.killpg(p.pid, sig) if sig == signal.SIGINT else os.kill(p.pid, sig)
        except ProcessLookupError:
            pass
        try:
            out, err = p.communicate(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(p.pid, signal.SIGKILL)
            out, err = p.communicate()
            return RunResult("hang", None, out.decode(errors="replace"), err.decode(errors="replace"), "FuzzTimeout", f"still running {timeout_s:g} s after the signal", elapsed=time.monotonic() - t0)
    elapsed = time.monotonic() - t0
    text = err.decode(errors="replace")
    time.sleep(1.5)  # children that die with their parent need a moment to be gone
    alive = _session_survivors(p.pid)
    for line in alive:
        with contextlib.suppress(ProcessLookupError, ValueError):
            os.kill(int(line.split(":", 1)[0]), signal.SIGKILL)
    if alive:
        return RunResult("survivor", p.returncode, out.decode(errors="replace"), text + "\n" + "\n".join(alive), "survivor", alive[0], elapsed=elapsed)
    lines = [ln for ln in text.splitlines() if ln.strip()]
    noisy = [ln for ln in lines if any(w in ln for w in ("Traceback", "Warning", "Exception", "warnings.warn"))]
    if "Traceback" in text:
        outcome = "traceback"
    elif noisy:
        outcome = "multi-line"
    elif p.returncode in (0, 1):
        outcome = "ok"
    elif p.returncode == -sig and (not lines or lines[-1].startswith("wrote ")):
        # the signal came before the command started or after it had finished (its output
        # written): the signal's default action ended the interpreter, nothing was cut short
        outcome = "ok"
    elif p.returncode == 128 + sig:
        outcome = "clean-error" if lines and lines[-1] == STOP_LINES[sig] else "multi-line"
    elif p.returncode == 2:
        outcome = "clean-error" if len(lines) <= MAX_ERROR_LINES or lines[-1].startswith("glocal-verify: error") else "multi-line"
    else:
        outcome = "bad-exit"
    return RunResult(outcome, p.returncode, out.decode(errors="replace")[:2000], text[-20000:], elapsed=elapsed)


class _FifoDrain:
    """A reader of a FIFO of the work folder, as a shell's ``cat pipe`` would be: it drains what
    the command writes, and is released (by an empty writer) if the command never opens it."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.data = b""
        self._thread = threading.Thread(target=self._read, daemon=True)
        self._thread.start()

    def _read(self) -> None:
        with contextlib.suppress(OSError), open(self.path, "rb") as f:
            self.data = f.read()

    def release(self) -> None:
        if self._thread.is_alive():
            with contextlib.suppress(OSError):
                os.close(os.open(self.path, os.O_WRONLY | os.O_NONBLOCK))
        self._thread.join(timeout=10)


def run_case(case: Case, timeout_s: float = 60.0, *, memory_bytes: int | None = 4 << 30,
             runner: Callable[[list[str], float, Path, int | None], RunResult] | None = None) -> RunResult:
    """Run ``case`` in a fresh work folder and check the output policy after it.

    ``runner(argv, timeout, work, fsize)`` runs a case without a signal (default: a forked
    child of this process, :func:`run_cli`); a case with a signal always runs as a real
    process in its own session (:func:`_run_signalled`).
    """
    with tempfile.TemporaryDirectory(prefix="glocal-fuzz-") as tmp:
        work = Path(tmp)
        _prepare(case, work)
        snap = _snapshot(case, work)
        readers = [_FifoDrain(work / op[1]) for op in case.setup if op[0] == "fifo"]
        if case.signal is not None:
            res = _run_signalled(case, work, timeout_s)
        else:
            argv = [a.replace("{work}", str(work)) for a in case.argv]
            if runner is not None:
                res = runner(argv, timeout_s, work, case.fsize)
            else:
                res = run_cli(argv, timeout_s, fork=True, memory_bytes=memory_bytes, cwd=str(work), fsize=case.fsize)
        for r in readers:
            r.release()
        violation = check_policy(case, work, snap, res.rc) if res.outcome not in ("hang", "crash") else None
        with contextlib.suppress(OSError):  # a run may leave read-only folders
            for q in work.rglob("*"):
                if q.is_dir() and not q.is_symlink():
                    os.chmod(q, 0o755)
    if violation is not None:
        res.outcome = violation
    return res
