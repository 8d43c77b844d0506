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
import sys
import tempfile
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


def _run_forked(argv: Sequence[str], timeout_s: float, memory_bytes: int | None) -> RunResult:
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


def run_cli(argv: Sequence[str], timeout_s: float = 60.0, *, fork: bool = False, memory_bytes: int | None = None) -> RunResult:
    """Run ``glocal_verify.cli.main(argv)`` and classify the outcome.

    In-process by default (stdout/stderr captured with ``contextlib.redirect_*``, SystemExit
    caught, a SIGALRM time budget of ``timeout_s``). With ``fork=True`` or ``memory_bytes``
    the run happens in a forked child whose address space is bounded with
    ``RLIMIT_AS = memory_bytes``; the parent kills it if it overruns the budget inside C code.
    """
    if fork or memory_bytes:
        return _run_forked(argv, timeout_s, memory_bytes)
    return _run_here(argv, timeout_s)


# ---------------------------------------------------------------------------------------------
# commands

COMMANDS = ("verify", "verify-exact", "simulate", "place-observers")
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
    raise ValueError(command)


def run_mutant(mutant: Mutant, command: str, timeout_s: float = 60.0, *, fork: bool = True, memory_bytes: int | None = 4 << 30) -> RunResult:
    """Write ``mutant`` to a temporary file and run ``command`` on it."""
    with tempfile.TemporaryDirectory(prefix="glocal-fuzz-") as tmp:
        spec = Path(tmp) / "spec.toml"
        spec.write_text(mutant.text, encoding="utf-8")
        return run_cli(command_argv(command, spec, tmp), timeout_s, fork=fork, memory_bytes=memory_bytes)
