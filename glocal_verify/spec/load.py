"""System specifications: TOML files (format 1) and library-built specs.

A specification describes the paper's closed loop (eq. ``cl_sys``): the normal communication
graph, the safe modes as link changes, the cluster partition with local observers, the global
monitors, an optional attack, and simulation settings. Structural checks use the JSON Schema
shipped in ``glocal_verify/spec/schemas/spec.schema.json``; semantic checks (unknown nodes, duplicate
edges, non-positive weights, overlapping clusters ...) follow in :func:`spec_from_dict`. Every
problem raises :class:`~glocal_verify.errors.SpecError` naming the key path, e.g.
``clusters[2].observers[0].center: node 25 is not in the graph``.

Weights and gains are kept as exact rationals (:class:`fractions.Fraction`): an integer stays an
integer, a TOML float is read through its shortest decimal form (``0.1`` is 1/10), and a string
such as ``"1/3"`` is read as the rational it spells. Exact mode works on these values; numeric
mode converts them to floats.
"""

from __future__ import annotations

import json
import math
import tomllib
from fractions import Fraction
from importlib import resources
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

import jsonschema
import networkx as nx

from glocal_verify.errors import SpecError
from glocal_verify.spec.types import (
    ATTACK_KINDS,
    NORMAL_MODE,
    AttackSpec,
    ClusterSpec,
    EdgeSpec,
    Label,
    ModeSpec,
    MonitorSpec,
    ObserverSpec,
    SimulationSpec,
    SwitchingSpec,
    SwitchStep,
    SystemSpec,
)

__all__ = [
    "load_spec",
    "loads_spec",
    "spec_from_dict",
    "spec_from_graph",
]

# --------------------------------------------------------------------------------------------
# loading


def _schema() -> dict[str, Any]:
    text = resources.files("glocal_verify.spec").joinpath("schemas/spec.schema.json").read_text()
    return json.loads(text)


_SCHEMA: dict[str, Any] | None = None


def _path_text(parts: Iterable[Any]) -> str:
    out = ""
    for p in parts:
        if isinstance(p, int):
            out += f"[{p}]"
        else:
            out += f".{p}" if out else str(p)
    return out


def _schema_error(err: jsonschema.ValidationError, source: str | None) -> SpecError:
    path = _path_text(err.absolute_path)
    v = err.validator
    if v == "required":
        missing = [k for k in err.validator_value if k not in (err.instance or {})]
        return SpecError(path or "<top>", f"missing required key {missing[0]!r}", source)
    if v == "additionalProperties":
        allowed = sorted((err.schema.get("properties") or {}).keys())
        extra = sorted(set(err.instance) - set(allowed)) if isinstance(err.instance, dict) else []
        key = extra[0] if extra else "?"
        return SpecError(
            _path_text(list(err.absolute_path) + [key]),
            f"unknown key (allowed here: {', '.join(allowed)})",
            source,
        )
    if v == "const" and path == "format":
        return SpecError("format", f"only format 1 is supported, got {err.instance!r}", source)
    if v in ("minItems", "maxItems") and path.startswith(("graph.edges", "modes")):
        return SpecError(path, f"an edge is [i, j] or [i, j, weight], got {err.instance!r}", source)
    if v == "anyOf" or v == "type":
        return SpecError(path or "<top>", f"unexpected value {err.instance!r} ({_expected(err)})", source)
    return SpecError(path or "<top>", err.message, source)


def _expected(err: jsonschema.ValidationError) -> str:
    schema = err.schema
    if "type" in schema:
        return f"expected {schema['type']}"
    if "$ref" in schema:
        return f"expected {schema['$ref'].rsplit('/', 1)[-1]}"
    kinds = []
    for sub in schema.get("anyOf", []):
        if "type" in sub:
            kinds.append(str(sub["type"]))
        elif "$ref" in sub:
            kinds.append(sub["$ref"].rsplit("/", 1)[-1])
    return "expected " + " or ".join(kinds) if kinds else "invalid value"


def load_spec(path: str | Path) -> SystemSpec:
    """Read and validate a TOML specification file.

    Raises
    ------
    SpecError
        If the file cannot be read, is not TOML, or fails validation. The message names
        the file and the key path.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise SpecError("", "file not found", str(p)) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise SpecError("", f"cannot read file ({exc})", str(p)) from None
    return loads_spec(text, source=str(p))


def loads_spec(text: str, source: str | None = None) -> SystemSpec:
    """Parse and validate a TOML specification given as ``text``.

    ``source`` (a file name, optional) prefixes every error message.
    """
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SpecError("", f"not valid TOML ({exc})", source) from None
    return spec_from_dict(data, source=source)


def spec_from_dict(data: Mapping[str, Any], source: str | None = None) -> SystemSpec:
    """Validate a specification given as a mapping ``data`` shaped like the TOML file.

    ``source`` (a file name, optional) prefixes every error message.
    """
    global _SCHEMA
    if _SCHEMA is None:
        _SCHEMA = _schema()
    validator = jsonschema.Draft202012Validator(_SCHEMA)
    errors = sorted(validator.iter_errors(data), key=lambda e: (len(e.absolute_path), list(map(str, e.absolute_path))))
    if errors:
        # report the shallowest, most specific problem
        best = jsonschema.exceptions.best_match(errors)
        raise _schema_error(best if best is not None else errors[0], source)
    return _Builder(data, source).build()


class _Builder:
    """Semantic validation of a schema-valid mapping."""

    def __init__(self, data: Mapping[str, Any], source: str | None) -> None:
        self.d = data
        self.source = source

    def err(self, path: str, problem: str) -> SpecError:
        return SpecError(path, problem, self.source)

    # -- scalars ----------------------------------------------------------------------------
    def rational(self, value: Any, path: str, *, positive: bool = True) -> Fraction:
        if isinstance(value, bool):
            raise self.err(path, f"expected a number, got {value!r}")
        if isinstance(value, int):
            q = Fraction(value)
        elif isinstance(value, float):
            if not math.isfinite(value):
                raise self.err(path, f"must be a finite number, got {value!r}")
            q = Fraction(repr(value))
        elif isinstance(value, str):
            try:
                q = Fraction(value.strip())
            except (ValueError, ZeroDivisionError):
                raise self.err(path, f"cannot read {value!r} as a rational number") from None
        else:
            raise self.err(path, f"expected a number, got {value!r}")
        if positive and q <= 0:
            raise self.err(path, f"must be > 0, got {value!r}")
        return q

    def real(self, value: Any, path: str, *, positive: bool = False, nonneg: bool = False) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.err(path, f"expected a number, got {value!r}")
        x = float(value)
        if not math.isfinite(x):
            raise self.err(path, f"must be a finite number, got {value!r}")
        if positive and x <= 0:
            raise self.err(path, f"must be > 0, got {value!r}")
        if nonneg and x < 0:
            raise self.err(path, f"must be >= 0, got {value!r}")
        return x

    # -- labels -----------------------------------------------------------------------------
    def node(self, value: Any, path: str) -> Label:
        if value not in self.node_set or isinstance(value, bool):
            raise self.err(path, f"node {value!r} is not in the graph")
        return value

    def node_list(self, values: Sequence[Any], path: str, *, unique: bool = True) -> tuple[Label, ...]:
        out = []
        seen: set[Any] = set()
        for k, v in enumerate(values):
            n = self.node(v, f"{path}[{k}]")
            if unique and n in seen:
                raise self.err(f"{path}[{k}]", f"node {v!r} is listed twice")
            seen.add(n)
            out.append(n)
        return tuple(out)

    # -- sections ---------------------------------------------------------------------------
    def build(self) -> SystemSpec:
        d = self.d
        dyn = d.get("dynamics", {})
        alpha = self.rational(dyn.get("alpha", 1), "dynamics.alpha")
        gamma = self.rational(dyn.get("gamma", 1), "dynamics.gamma")
        nodes = self.nodes(d["graph"]["nodes"])
        self.node_set = set(nodes)
        edges = self.edges(d["graph"]["edges"], "graph.edges")
        self.edge_keys = {e.key for e in edges}
        modes = self.modes(d.get("modes", []))
        clusters = self.clusters(d.get("clusters", []), nodes)
        monitor = self.monitor(d.get("monitor", {}))
        attack = self.attack(d.get("attack"), monitor)
        mode_names = {m.name for m in modes}
        switching = self.switching(d.get("switching"), mode_names)
        simulation = self.simulation(d.get("simulation", {}))
        return SystemSpec(
            name=str(d.get("name", Path(self.source).stem if self.source else "system")),
            nodes=nodes,
            edges=edges,
            alpha=alpha,
            gamma=gamma,
            modes=modes,
            clusters=clusters,
            monitor=monitor,
            attack=attack,
            switching=switching,
            simulation=simulation,
            description=str(d.get("description", "")),
            source=self.source,
            finding=d.get("finding"),
        )

    def nodes(self, value: Any) -> tuple[Label, ...]:
        if isinstance(value, int):
            return tuple(range(1, value + 1))
        seen: set[Any] = set()
        for k, v in enumerate(value):
            if v in seen:
                raise self.err(f"graph.nodes[{k}]", f"node {v!r} is listed twice")
            seen.add(v)
        return tuple(value)

    def edge(self, item: Sequence[Any], path: str) -> EdgeSpec:
        u = self.node(item[0], f"{path}[0]")
        v = self.node(item[1], f"{path}[1]")
        if u == v:
            raise self.err(path, f"self-loop at node {u!r}")
        w = self.rational(item[2], f"{path}[2]") if len(item) == 3 else Fraction(1)
        return EdgeSpec(u, v, w)

    def edges(self, items: Sequence[Any], path: str) -> tuple[EdgeSpec, ...]:
        out: list[EdgeSpec] = []
        seen: dict[frozenset[Label], int] = {}
        for k, item in enumerate(items):
            e = self.edge(item, f"{path}[{k}]")
            if e.key in seen:
                raise self.err(f"{path}[{k}]", f"duplicate edge {e.u!r}-{e.v!r} (already {path}[{seen[e.key]}])")
            seen[e.key] = k
            out.append(e)
        return tuple(out)

    def modes(self, items: Sequence[Mapping[str, Any]]) -> tuple[ModeSpec, ...]:
        out = []
        names: dict[str, int] = {}
        for k, m in enumerate(items):
            p = f"modes[{k}]"
            name = m["name"]
            if name == NORMAL_MODE:
                raise self.err(f"{p}.name", f"{NORMAL_MODE!r} is the name of the unswitched graph")
            if name in names:
                raise self.err(f"{p}.name", f"mode {name!r} is defined twice (also modes[{names[name]}])")
            names[name] = k
            add = self.edges(m.get("add", []), f"{p}.add")
            removed: list[tuple[Label, Label]] = []
            rkeys: set[frozenset[Label]] = set()
            for j, pair in enumerate(m.get("remove", [])):
                u = self.node(pair[0], f"{p}.remove[{j}][0]")
                v = self.node(pair[1], f"{p}.remove[{j}][1]")
                key = frozenset((u, v))
                if u == v or key not in self.edge_keys:
                    raise self.err(f"{p}.remove[{j}]", f"edge {u!r}-{v!r} is not in the graph")
                if key in rkeys:
                    raise self.err(f"{p}.remove[{j}]", f"edge {u!r}-{v!r} is removed twice")
                rkeys.add(key)
                removed.append((u, v))
            for j, e in enumerate(add):
                if e.key in self.edge_keys and e.key not in rkeys:
                    raise self.err(
                        f"{p}.add[{j}]",
                        f"edge {e.u!r}-{e.v!r} is already in the graph (remove it too to change its weight)",
                    )
            if not add and not removed:
                raise self.err(p, f"mode {name!r} changes no link")
            out.append(ModeSpec(name, add, tuple(removed), str(m.get("description", ""))))
        return tuple(out)

    def clusters(self, items: Sequence[Mapping[str, Any]], nodes: tuple[Label, ...]) -> tuple[ClusterSpec, ...]:
        if not items:
            return ()
        owner: dict[Label, str] = {}
        names: set[str] = set()
        out = []
        for k, c in enumerate(items):
            p = f"clusters[{k}]"
            if c["name"] in names:
                raise self.err(f"{p}.name", f"cluster {c['name']!r} is defined twice")
            names.add(c["name"])
            if not c["nodes"]:
                raise self.err(f"{p}.nodes", "a cluster needs at least one node")
            members = self.node_list(c["nodes"], f"{p}.nodes")
            for j, n in enumerate(members):
                if n in owner:
                    raise self.err(f"{p}.nodes[{j}]", f"node {n!r} is already in cluster {owner[n]!r}")
                owner[n] = c["name"]
            mset = set(members)
            observers = []
            centers: set[Label] = set()
            for j, o in enumerate(c.get("observers", [])):
                op = f"{p}.observers[{j}]"
                center = self.node(o["center"], f"{op}.center")
                if center not in mset:
                    raise self.err(f"{op}.center", f"node {center!r} is not in cluster {c['name']!r}")
                if center in centers:
                    raise self.err(f"{op}.center", f"cluster {c['name']!r} already has an observer at {center!r}")
                centers.add(center)
                meas: dict[str, tuple[Label, ...] | None] = {}
                for key in ("positions", "velocities"):
                    if key in o:
                        lst = self.node_list(o[key], f"{op}.{key}")
                        for i, n in enumerate(lst):
                            if n not in mset:
                                raise self.err(f"{op}.{key}[{i}]", f"node {n!r} is outside cluster {c['name']!r}")
                        meas[key] = lst
                    else:
                        meas[key] = None
                poles = None
                if "poles" in o:
                    poles = tuple(self.rational(x, f"{op}.poles[{i}]", positive=False) for i, x in enumerate(o["poles"]))
                    for i, x in enumerate(poles):
                        if x >= 0:
                            raise self.err(f"{op}.poles[{i}]", f"observer poles must be < 0, got {float(x)!r}")
                observers.append(ObserverSpec(center, meas["positions"], meas["velocities"], poles))
            out.append(ClusterSpec(c["name"], members, tuple(observers)))
        missing = [n for n in nodes if n not in owner]
        if missing:
            raise self.err("clusters", f"the clusters do not cover node(s) {', '.join(map(repr, missing[:8]))}")
        return tuple(out)

    def monitor(self, m: Mapping[str, Any]) -> MonitorSpec:
        return MonitorSpec(
            self.node_list(m.get("positions", []), "monitor.positions"),
            self.node_list(m.get("velocities", []), "monitor.velocities"),
        )

    def attack(self, a: Mapping[str, Any] | None, monitor: MonitorSpec) -> AttackSpec | None:
        if a is None:
            return None
        kind = a["kind"]
        if kind not in ATTACK_KINDS:
            raise self.err("attack.kind", f"unknown attack kind {kind!r} (expected one of: {', '.join(ATTACK_KINDS)})")
        actuators = self.node_list(a["actuators"], "attack.actuators")
        if not actuators:
            raise self.err("attack.actuators", "an attack needs at least one compromised actuator")
        sensors = self.node_list(a.get("sensors", []), "attack.sensors")
        monitored = set(monitor.positions) | set(monitor.velocities)
        for k, s in enumerate(sensors):
            if s not in monitored:
                raise self.err(f"attack.sensors[{k}]", f"node {s!r} has no globally monitored channel to compromise")
        if sensors and kind == "zda":
            raise self.err("attack.sensors", "a zero-dynamics attack uses no sensor channel (kind = 'covert' does)")
        lam: complex | None = None
        if "lambda0" in a:
            raw = a["lambda0"]
            if isinstance(raw, list):
                re_, im_ = (self.real(raw[0], "attack.lambda0[0]"), self.real(raw[1], "attack.lambda0[1]"))
                lam = complex(re_, im_)
            else:
                lam = complex(float(self.rational(raw, "attack.lambda0", positive=False)))
        start = self.real(a.get("start", 0.0), "attack.start", nonneg=True)
        signal = a.get("signal")
        if signal is not None and signal not in ("exponential", "step", "sine"):
            raise self.err("attack.signal", f"unknown signal {signal!r} (expected exponential, step or sine)")
        return AttackSpec(
            kind,
            actuators,
            sensors,
            lam,
            start,
            signal,
            self.real(a.get("amplitude", 1.0), "attack.amplitude"),
            self.real(a.get("frequency", 1.0), "attack.frequency", nonneg=True),
        )

    def switching(self, s: Mapping[str, Any] | None, mode_names: set[str]) -> SwitchingSpec | None:
        if s is None:
            return None
        known = mode_names | {NORMAL_MODE}
        mode = s.get("mode")
        if mode is not None and mode not in mode_names:
            raise self.err("switching.mode", f"no safe mode named {mode!r} (defined: {', '.join(sorted(mode_names)) or 'none'})")
        time = None
        if "time" in s:
            time = self.real(s["time"], "switching.time", positive=True)
        if mode is not None and time is None:
            raise self.err("switching", "missing required key 'time'")
        seq = []
        for k, step in enumerate(s.get("sequence", [])):
            if step["mode"] not in known:
                raise self.err(f"switching.sequence[{k}].mode", f"no mode named {step['mode']!r}")
            seq.append(SwitchStep(step["mode"], self.real(step["duration"], f"switching.sequence[{k}].duration", positive=True)))
        return SwitchingSpec(mode, time, tuple(seq))

    def simulation(self, s: Mapping[str, Any]) -> SimulationSpec:
        horizon = self.real(s.get("horizon", 30.0), "simulation.horizon", positive=True)
        step = self.real(s.get("step", 0.01), "simulation.step", positive=True)
        if step > horizon:
            raise self.err("simulation.step", f"step {step} is longer than the horizon {horizon}")
        return SimulationSpec(horizon, step, int(s.get("seed", 0)))


# --------------------------------------------------------------------------------------------
# library construction


def _label(x: Any) -> Label:
    if isinstance(x, (int, str)) and not isinstance(x, bool):
        return x
    if hasattr(x, "__index__"):
        return int(x)
    return str(x)


def _number(x: Any) -> Any:
    if isinstance(x, Fraction):
        return str(x)
    if hasattr(x, "item"):
        return x.item()
    return x


def spec_from_graph(
    graph: nx.Graph,
    *,
    name: str = "system",
    alpha: Any = 1,
    gamma: Any = 1,
    modes: Mapping[str, Mapping[str, Sequence[Any]]] | None = None,
    clusters: Mapping[str, Sequence[Label]] | None = None,
    observers: Mapping[str, Sequence[Label | Mapping[str, Any]]] | None = None,
    monitor_positions: Sequence[Label] = (),
    monitor_velocities: Sequence[Label] = (),
    attack: Mapping[str, Any] | None = None,
    switching: Mapping[str, Any] | None = None,
    simulation: Mapping[str, Any] | None = None,
    weight: str = "weight",
) -> SystemSpec:
    """Build a specification from a networkx graph and keyword arguments.

    The result goes through the same validation as a TOML file, so a design tool gets the
    same messages (with the same key paths) as a file user.

    Parameters
    ----------
    graph : networkx.Graph
        Undirected graph; edge attribute ``weight`` (default 1) is the coupling weight.
    name : str
        System name used in reports.
    alpha, gamma : number or str
        Control gains of eq. ``ctrl_proto`` (rationals such as ``"1/3"`` allowed).
    monitor_positions, monitor_velocities : sequence of labels
        Globally monitored agents M_x and M_v.
    weight : str
        Name of the edge attribute holding the weight.
    modes : mapping, optional
        ``{name: {"add": [(i, j[, w]), ...], "remove": [(i, j), ...]}}``.
    clusters : mapping, optional
        ``{name: [labels]}``.
    observers : mapping, optional
        ``{cluster name: [center, ...]}`` or ``[{"center": c, "positions": [...], ...}]``.
    attack, switching, simulation : mapping, optional
        Same keys as the TOML tables.

    Examples
    --------
    >>> import networkx as nx
    >>> spec = spec_from_graph(nx.path_graph([1, 2, 3]), monitor_velocities=[3])
    >>> spec.nodes
    (1, 2, 3)
    """
    if graph.is_directed():
        raise SpecError("graph", "the graph must be undirected")
    data: dict[str, Any] = {
        "format": 1,
        "name": name,
        "dynamics": {"alpha": _number(alpha), "gamma": _number(gamma)},
        "graph": {
            "nodes": [_label(n) for n in graph.nodes],
            "edges": [[_label(u), _label(v), _number(d.get(weight, 1))] for u, v, d in graph.edges(data=True)],
        },
        "monitor": {
            "positions": [_label(n) for n in monitor_positions],
            "velocities": [_label(n) for n in monitor_velocities],
        },
    }
    if modes:
        data["modes"] = [
            {
                "name": mname,
                "add": [[_label(e[0]), _label(e[1])] + ([_number(e[2])] if len(e) > 2 else []) for e in m.get("add", [])],
                "remove": [[_label(e[0]), _label(e[1])] for e in m.get("remove", [])],
            }
            for mname, m in modes.items()
        ]
    if clusters:
        cl = []
        for cname, members in clusters.items():
            entry: dict[str, Any] = {"name": cname, "nodes": [_label(n) for n in members]}
            obs = (observers or {}).get(cname, [])
            entry["observers"] = [dict(o) if isinstance(o, Mapping) else {"center": _label(o)} for o in obs]
            cl.append(entry)
        data["clusters"] = cl
    if attack:
        data["attack"] = dict(attack)
    if switching:
        data["switching"] = dict(switching)
    if simulation:
        data["simulation"] = dict(simulation)
    return spec_from_dict(data)
