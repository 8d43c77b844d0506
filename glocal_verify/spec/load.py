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

Every number is checked against its documented domain and every array against its size limit
(:mod:`glocal_verify.spec.types`, "Domains and limits"): weights in :math:`[10^{-12}, 10^{12}]`
within a factor :math:`10^{12}` of each other, gains in :math:`[10^{-12}, 10^{12}]` within a factor :math:`10^{12}`, closed-loop stiffness
:math:`\\max(\\alpha w_{\\max}, \\gamma^2)/\\min(\\alpha w_{\\min}, \\gamma^2) \\le 10^{12}`, :math:`|\\lambda_0|` parts at most
:math:`10^6`, observer poles in :math:`[-10^6, -10^{-6}]`, times in :math:`[10^{-6}, 10^6]`, at most
:math:`10^8` output samples, :math:`N \\le 10^5`, at most :math:`10^6` edges, nesting at most 64
levels. Number strings are bounded (length, exponent) before they become rationals, so
``"1e9999999"`` is refused at once. Messages echo values cut to about 80 characters.

Validation is linear in the size of the spec: the mapping is first copied without recursion
(:func:`glocal_verify.spec.prepare.prepare`), the JSON Schema checks a copy whose long arrays are
cut to their first item, and plain loops check the rest of those arrays with the schema's
messages (:func:`glocal_verify.spec.prepare.check_items`); a 10,000-agent spec validates in a
fraction of a second.
"""

from __future__ import annotations

import json
import math
import numbers
import os
import re
from decimal import Decimal
from fractions import Fraction
from importlib import resources
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

import jsonschema
import networkx as nx

from glocal_verify.errors import ArgumentError, SpecError
from glocal_verify.spec.deployment import read_implementation, read_uncertainty
from glocal_verify.spec.prepare import (
    MAX_FILE_BYTES,
    NumberTextError,
    bounded_rational,
    check_items,
    clip,
    elide,
    nesting_site,
    parse_toml,
    path_text,
    plain_scalar,
    prepare,
    read_toml,
    show,
)
from glocal_verify.spec.types import (
    AMPLITUDE_MAX,
    ATTACK_KINDS,
    GAIN_MAX,
    GAIN_MIN,
    GAIN_RATIO_MAX,
    LAMBDA0_MAX,
    MAX_DEPTH,
    MAX_EXPONENT,
    MAX_LABEL,
    MAX_NODES,
    MAX_SAMPLES,
    MAX_TEXT,
    NORMAL_MODE,
    POLE_MAX,
    POLE_MIN,
    SEED_MAX,
    STIFFNESS_MAX,
    TIME_MAX,
    TIME_MIN,
    WEIGHT_MAX,
    WEIGHT_MIN,
    WEIGHT_RATIO_MAX,
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
    "as_spec",
    "load_spec",
    "loads_spec",
    "spec_from_dict",
    "spec_from_graph",
]

# --------------------------------------------------------------------------------------------
# loading


def _schema() -> dict[str, Any]:
    """The spec's JSON Schema, read from the package (76 us: read per validation, not kept)."""
    text = resources.files("glocal_verify.spec").joinpath("schemas/spec.schema.json").read_text()
    return json.loads(text)


def _schema_error(err: jsonschema.ValidationError, source: str | None) -> SpecError:
    path = clip(path_text(err.absolute_path), 120)
    v = err.validator
    if v == "required":
        missing = [k for k in err.validator_value if k not in (err.instance or {})]
        return SpecError(path or "<top>", f"missing required key {show(missing[0])}", source)
    if v == "additionalProperties":
        allowed = sorted((err.schema.get("properties") or {}).keys())
        extra = sorted(set(err.instance) - set(allowed)) if isinstance(err.instance, dict) else []
        key = extra[0] if extra else "?"
        return SpecError(
            clip(path_text(list(err.absolute_path) + [key]), 120),
            f"unknown key (allowed here: {', '.join(allowed)})",
            source,
        )
    if v == "const" and path == "format":
        return SpecError("format", f"only format 1 is supported, got {show(err.instance)}", source)
    if v in ("minItems", "maxItems") and path.startswith(("graph.edges", "modes")):
        return SpecError(path, f"an edge is [i, j] or [i, j, weight], got {show(err.instance)}", source)
    if v == "anyOf" or v == "type":
        return SpecError(path or "<top>", f"unexpected value {show(err.instance)} ({_expected(err)})", source)
    return SpecError(path or "<top>", clip(err.message), source)


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

    Parameters
    ----------
    path : str or pathlib.Path
        The file; at most :data:`MAX_FILE_BYTES` bytes of UTF-8 TOML.

    Raises
    ------
    SpecError
        If the file cannot be read, is not TOML, or fails validation. The message names
        the file and the key path.
    """
    data, source = read_toml(path)
    return spec_from_dict(data, source=source)


def loads_spec(text: str | bytes, source: str | None = None) -> SystemSpec:
    """Parse and validate a TOML specification given as ``text``.

    Parameters
    ----------
    text : str or bytes
        TOML text (bytes are decoded as UTF-8), at most :data:`MAX_FILE_BYTES` characters.
    source : str, optional
        A file name; it prefixes every error message.

    Raises
    ------
    SpecError
        For anything but valid TOML text of a valid specification, including text that is not
        a ``str``, arrays nested deeper than :data:`~glocal_verify.spec.types.MAX_DEPTH` levels
        and integers too long to read.
    """
    return spec_from_dict(parse_toml(text, source), source=source)


def as_spec(value: Any, name: str = "spec") -> SystemSpec:
    """``value`` as a specification: itself, or a mapping shaped like the spec file validated
    by :func:`spec_from_dict` (which raises :class:`~glocal_verify.errors.SpecError`); anything
    else (``None``, a file name: load it with ``load_spec``) raises
    :class:`~glocal_verify.errors.ArgumentError` naming ``name``.

    Parameters
    ----------
    value : object
    name : str
        The argument, for the message.
    """
    if isinstance(value, SystemSpec):
        return value
    if isinstance(value, Mapping):
        return spec_from_dict(value)
    hint = " (a file name: load it with load_spec)" if isinstance(value, (str, os.PathLike)) else ""
    raise ArgumentError(f"{name}: expected a SystemSpec or a mapping shaped like the spec file, got {type(value).__name__}{hint}")


def spec_from_dict(data: Mapping[str, Any], source: str | None = None) -> SystemSpec:
    """Validate a specification given as a mapping ``data`` shaped like the TOML file.

    What a Python caller naturally passes is accepted: tuples for lists, numpy integers and
    floats (as ``int`` and ``float``), :class:`fractions.Fraction` and :class:`decimal.Decimal`
    weights and gains (read exactly), numpy integers as node labels.

    Parameters
    ----------
    data : mapping
        The specification (keys as in the TOML file).
    source : str, optional
        A file name; it prefixes every error message.

    Raises
    ------
    SpecError
        Naming the key path of the first problem: structure (JSON Schema, on a copy with the
        long arrays cut to their first item; the rest of each array is checked by plain loops
        with the same messages), sizes, domains of the numbers (see
        :mod:`glocal_verify.spec.types`) and semantics.
    """
    plain = prepare(data, source)
    skeleton, arrays = elide(plain, source)
    validator = jsonschema.Draft202012Validator(_schema())
    errors = list(validator.iter_errors(skeleton))
    if errors:
        # report the shallowest, most specific problem
        best = jsonschema.exceptions.best_match(errors)
        raise _schema_error(best if best is not None else errors[0], source)
    for path, items, kind in arrays:
        check_items(path, items, kind, source)
    return _Builder(plain, source).build()


_CONTROL = re.compile("\x00")


class _Builder:
    """Semantic validation of a schema-valid mapping."""

    def __init__(self, data: Mapping[str, Any], source: str | None) -> None:
        self.d = data
        self.source = source

    def err(self, path: str, problem: str) -> SpecError:
        return SpecError(path, problem, self.source)

    # -- scalars ----------------------------------------------------------------------------
    def rational(self, value: Any, path: str, *, lo: Fraction | None = None, hi: Fraction | None = None, positive: bool = True) -> Fraction:
        """``value`` as an exact rational in ``[lo, hi]`` (and > 0 when ``positive``).

        A string is read by :func:`~glocal_verify.spec.prepare.bounded_rational`: at most
        :data:`~glocal_verify.spec.types.MAX_NUMBER_TEXT` characters and a
        decimal exponent of at most :data:`MAX_EXPONENT`, so that ``"1e9999999"`` is refused at
        once instead of being expanded.
        """
        if isinstance(value, bool):
            raise self.err(path, f"expected a number, got {value!r}")
        if isinstance(value, Fraction):
            q = value
        elif isinstance(value, int):
            q = Fraction(value)
        elif isinstance(value, float):
            if not math.isfinite(value):
                raise self.err(path, f"must be a finite number, got {value!r}")
            q = Fraction(repr(value))
        elif isinstance(value, Decimal):
            if not value.is_finite():
                raise self.err(path, f"must be a finite number, got {show(value)}")
            if abs(value.adjusted()) > MAX_EXPONENT:
                raise self.err(path, f"{show(value)} is far outside the allowed range")
            q = Fraction(value)
        elif isinstance(value, str):
            q = self.rational_text(value, path)
        else:
            raise self.err(path, f"expected a number, got {show(value)}")
        if positive and q <= 0:
            raise self.err(path, f"must be > 0, got {show(value)}")
        if lo is not None and q < lo:
            raise self.err(path, f"must be at least {float(lo):g}, got {show(value)}")
        if hi is not None and q > hi:
            raise self.err(path, f"must be at most {float(hi):g}, got {show(value)}")
        return q

    def rational_text(self, value: str, path: str) -> Fraction:
        """The rational a string spells (``"1/3"``, ``"2.5e-3"``), bounded before conversion."""
        try:
            return bounded_rational(value)
        except NumberTextError as exc:
            why = {"long": str(exc), "range": f"{show(value)} is far outside the allowed range"}.get(exc.kind, f"cannot read {show(value)} as a rational number")
            raise self.err(path, why) from None

    def real(
        self, value: Any, path: str, *, positive: bool = False, nonneg: bool = False, lo: float | None = None, hi: float | None = None
    ) -> float:
        """``value`` as a finite float in ``[lo, hi]`` (``> 0`` or ``>= 0`` if asked)."""
        if isinstance(value, bool) or not isinstance(value, (int, float, Fraction, Decimal)):
            raise self.err(path, f"expected a number, got {show(value)}")
        if isinstance(value, Decimal) and not value.is_finite():
            raise self.err(path, f"must be a finite number, got {show(value)}")
        if isinstance(value, float) and not math.isfinite(value):
            raise self.err(path, f"must be a finite number, got {value!r}")
        if positive and value <= 0:
            raise self.err(path, f"must be > 0, got {show(value)}")
        if nonneg and value < 0:
            raise self.err(path, f"must be >= 0, got {show(value)}")
        if lo is not None and value < lo:
            raise self.err(path, f"must be at least {lo:g}, got {show(value)}")
        if hi is not None and value > hi:
            raise self.err(path, f"must be at most {hi:g}, got {show(value)}")
        return float(value)

    def time(self, value: Any, path: str) -> float:
        """A positive time in ``[TIME_MIN, TIME_MAX]``."""
        return self.real(value, path, positive=True, lo=TIME_MIN, hi=TIME_MAX)

    def text(self, value: Any, path: str, *, limit: int = MAX_TEXT, name: bool = False) -> str:
        """A string of at most ``limit`` characters; a name (``name=True``) has no NUL character."""
        if not isinstance(value, str):
            raise self.err(path, f"expected a string, got {show(value)}")
        if len(value) > limit:
            raise self.err(path, f"too long ({len(value)} characters; at most {limit}): {show(value)}")
        if name and _CONTROL.search(value):
            raise self.err(path, f"must not contain NUL characters, got {show(value)}")
        return value

    # -- labels -----------------------------------------------------------------------------
    def node(self, value: Any, path: str) -> Label:
        """``value`` as a node of the graph (an ``int`` or ``str`` label that is listed)."""
        if type(value) not in (int, str):
            raise self.err(path, f"expected an integer or string label, got {show(value)}")
        if value not in self.node_set:
            raise self.err(path, f"node {show(value)} is not in the graph")
        return value

    def node_list(self, values: Sequence[Any], path: str, *, unique: bool = True) -> tuple[Label, ...]:
        out = []
        seen: set[Any] = set()
        for k, v in enumerate(values):
            n = self.node(v, f"{path}[{k}]")
            if unique and n in seen:
                raise self.err(f"{path}[{k}]", f"node {show(v)} is listed twice")
            seen.add(n)
            out.append(n)
        return tuple(out)

    # -- sections ---------------------------------------------------------------------------
    def build(self) -> SystemSpec:
        d = self.d
        dyn = d.get("dynamics", {})
        alpha = self.rational(dyn.get("alpha", 1), "dynamics.alpha", lo=GAIN_MIN, hi=GAIN_MAX)
        gamma = self.rational(dyn.get("gamma", 1), "dynamics.gamma", lo=GAIN_MIN, hi=GAIN_MAX)
        if max(alpha, gamma) > GAIN_RATIO_MAX * min(alpha, gamma):
            raise self.err(
                "dynamics.gamma" if gamma < alpha else "dynamics.alpha",
                f"alpha = {float(alpha):g} and gamma = {float(gamma):g} differ by more than a factor {float(GAIN_RATIO_MAX):g}",
            )
        nodes = self.nodes(d["graph"]["nodes"])
        self.node_set = set(nodes)
        self.extreme: list[tuple[Fraction, str]] = []  # (weight, path) of the smallest and largest weight
        edges = self.edges(d["graph"]["edges"], "graph.edges")
        self.edge_keys = {e.key for e in edges}
        modes = self.modes(d.get("modes", []))
        self.weight_spread()
        self.stiffness(alpha, gamma)
        clusters = self.clusters(d.get("clusters", []), nodes)
        monitor = self.monitor(d.get("monitor", {}))
        attack = self.attack(d.get("attack"), monitor)
        mode_names = {m.name for m in modes}
        switching = self.switching(d.get("switching"), mode_names)
        simulation = self.simulation(d.get("simulation", {}))
        uncertainty = read_uncertainty(self, d.get("uncertainty"))
        implementation = read_implementation(self, d.get("implementation"), simulation)
        name = self.text(d["name"], "name", limit=MAX_LABEL, name=True) if "name" in d else (Path(self.source).stem[:MAX_LABEL] if self.source else "system")
        return SystemSpec(
            name=name,
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
            uncertainty=uncertainty,
            implementation=implementation,
            description=self.text(d.get("description", ""), "description"),
            source=self.source,
            finding=d.get("finding"),
        )

    def nodes(self, value: Any) -> tuple[Label, ...]:
        if type(value) is not list:
            if type(value) is not int:
                raise self.err("graph.nodes", f"expected an integer count or a list of labels, got {show(value)}")
            if value > MAX_NODES:
                raise self.err("graph.nodes", f"too many agents ({show(value)}; at most {MAX_NODES})")
            return tuple(range(1, value + 1))
        seen: set[Any] = set()
        ints: dict[str, int] = {}
        strs: dict[str, int] = {}
        for k, v in enumerate(value):
            p = f"graph.nodes[{k}]"
            if v in seen:
                raise self.err(p, f"node {show(v)} is listed twice")
            seen.add(v)
            if type(v) is str:
                self.text(v, p, limit=MAX_LABEL, name=True)
                twin = ints.get(v.strip())
                strs[v.strip()] = k
            else:
                if not -(2**63) <= v < 2**63:
                    raise self.err(p, f"integer labels must fit in 64 bits, got {show(v)}")
                twin = strs.get(str(v))
                ints[str(v)] = k
            if twin is not None:
                raise self.err(p, f"label {show(v)} is ambiguous with graph.nodes[{twin}] = {show(value[twin])} (use one kind of label)")
        return tuple(value)

    def edge(self, item: Sequence[Any], path: str) -> EdgeSpec:
        u = self.node(item[0], f"{path}[0]")
        v = self.node(item[1], f"{path}[1]")
        if u == v:
            raise self.err(path, f"self-loop at node {show(u)}")
        if len(item) == 3:
            wp = f"{path}[2]"
            w = self.rational(item[2], wp, lo=WEIGHT_MIN, hi=WEIGHT_MAX)
            ext = self.extreme
            if not ext:
                ext += [(w, wp), (w, wp)]
            elif w < ext[0][0]:
                ext[0] = (w, wp)
            elif w > ext[1][0]:
                ext[1] = (w, wp)
        else:
            w = Fraction(1)
            if not self.extreme:
                self.extreme += [(w, path), (w, path)]
            elif w < self.extreme[0][0]:
                self.extreme[0] = (w, path)
            elif w > self.extreme[1][0]:
                self.extreme[1] = (w, path)
        return EdgeSpec(u, v, w)

    def weight_spread(self) -> None:
        """Refuse weights (normal graph and modes) spread over more than :data:`WEIGHT_RATIO_MAX`."""
        if len(self.extreme) == 2:
            (lo, lo_path), (hi, hi_path) = self.extreme
            if hi > WEIGHT_RATIO_MAX * lo:
                raise self.err(
                    hi_path,
                    f"weight {float(hi):g} is {float(hi / lo):.3g} times the weight {float(lo):g} at {lo_path} "
                    f"(weights must lie within a factor {float(WEIGHT_RATIO_MAX):g} of each other)",
                )

    def stiffness(self, alpha: Fraction, gamma: Fraction) -> None:
        """Refuse gains and weights whose closed-loop eigenvalues would spread over more than
        :data:`STIFFNESS_MAX`: ``max(alpha w_max, gamma^2) / min(alpha w_min, gamma^2)``."""
        if len(self.extreme) == 2:
            lo, hi = alpha * self.extreme[0][0], alpha * self.extreme[1][0]
            g2 = gamma * gamma
            if max(hi, g2) > STIFFNESS_MAX * min(lo, g2):
                raise self.err(
                    "dynamics.gamma",  # the weights alone spread at most WEIGHT_RATIO_MAX: gamma^2 is the extreme
                    f"alpha * weight spans [{float(lo):.3g}, {float(hi):.3g}] and gamma^2 = {float(g2):.3g}: the closed-loop "
                    f"eigenvalues would spread over more than a factor {float(STIFFNESS_MAX):g}",
                )

    def edges(self, items: Sequence[Any], path: str) -> tuple[EdgeSpec, ...]:
        out: list[EdgeSpec] = []
        seen: dict[frozenset[Label], int] = {}
        for k, item in enumerate(items):
            e = self.edge(item, f"{path}[{k}]")
            if e.key in seen:
                raise self.err(f"{path}[{k}]", f"duplicate edge {show(e.u)}-{show(e.v)} (already {path}[{seen[e.key]}])")
            seen[e.key] = k
            out.append(e)
        return tuple(out)

    def modes(self, items: Sequence[Mapping[str, Any]]) -> tuple[ModeSpec, ...]:
        out = []
        names: dict[str, int] = {}
        for k, m in enumerate(items):
            p = f"modes[{k}]"
            name = self.text(m["name"], f"{p}.name", limit=MAX_LABEL, name=True)
            if name == NORMAL_MODE:
                raise self.err(f"{p}.name", f"{NORMAL_MODE!r} is the name of the unswitched graph")
            if name in names:
                raise self.err(f"{p}.name", f"mode {show(name)} is defined twice (also modes[{names[name]}])")
            names[name] = k
            add = self.edges(m.get("add", []), f"{p}.add")
            removed: list[tuple[Label, Label]] = []
            rkeys: set[frozenset[Label]] = set()
            for j, pair in enumerate(m.get("remove", [])):
                u = self.node(pair[0], f"{p}.remove[{j}][0]")
                v = self.node(pair[1], f"{p}.remove[{j}][1]")
                key = frozenset((u, v))
                if u == v or key not in self.edge_keys:
                    raise self.err(f"{p}.remove[{j}]", f"edge {show(u)}-{show(v)} is not in the graph")
                if key in rkeys:
                    raise self.err(f"{p}.remove[{j}]", f"edge {show(u)}-{show(v)} is removed twice")
                rkeys.add(key)
                removed.append((u, v))
            for j, e in enumerate(add):
                if e.key in self.edge_keys and e.key not in rkeys:
                    raise self.err(
                        f"{p}.add[{j}]",
                        f"edge {show(e.u)}-{show(e.v)} is already in the graph (remove it too to change its weight)",
                    )
            if not add and not removed:
                raise self.err(p, f"mode {show(name)} changes no link")
            out.append(ModeSpec(name, add, tuple(removed), self.text(m.get("description", ""), f"{p}.description")))
        return tuple(out)

    def clusters(self, items: Sequence[Mapping[str, Any]], nodes: tuple[Label, ...]) -> tuple[ClusterSpec, ...]:
        if not items:
            return ()
        owner: dict[Label, str] = {}
        names: set[str] = set()
        out = []
        for k, c in enumerate(items):
            p = f"clusters[{k}]"
            cname = self.text(c["name"], f"{p}.name", limit=MAX_LABEL, name=True)
            if cname in names:
                raise self.err(f"{p}.name", f"cluster {show(cname)} is defined twice")
            names.add(cname)
            if not c["nodes"]:
                raise self.err(f"{p}.nodes", "a cluster needs at least one node")
            members = self.node_list(c["nodes"], f"{p}.nodes")
            for j, n in enumerate(members):
                if n in owner:
                    raise self.err(f"{p}.nodes[{j}]", f"node {show(n)} is already in cluster {show(owner[n])}")
                owner[n] = cname
            mset = set(members)
            observers = []
            centers: set[Label] = set()
            for j, o in enumerate(c.get("observers", [])):
                op = f"{p}.observers[{j}]"
                center = self.node(o["center"], f"{op}.center")
                if center not in mset:
                    raise self.err(f"{op}.center", f"node {show(center)} is not in cluster {show(cname)}")
                if center in centers:
                    raise self.err(f"{op}.center", f"cluster {show(cname)} already has an observer at {show(center)}")
                centers.add(center)
                meas: dict[str, tuple[Label, ...] | None] = {}
                for key in ("positions", "velocities"):
                    if key in o:
                        lst = self.node_list(o[key], f"{op}.{key}")
                        for i, n in enumerate(lst):
                            if n not in mset:
                                raise self.err(f"{op}.{key}[{i}]", f"node {show(n)} is outside cluster {show(cname)}")
                        meas[key] = lst
                    else:
                        meas[key] = None
                poles = None
                if "poles" in o:
                    poles = tuple(self.pole(x, f"{op}.poles[{i}]") for i, x in enumerate(o["poles"]))
                observers.append(ObserverSpec(center, meas["positions"], meas["velocities"], poles))
            out.append(ClusterSpec(cname, members, tuple(observers)))
        missing = [n for n in nodes if n not in owner]
        if missing:
            raise self.err("clusters", f"the clusters do not cover node(s) {', '.join(map(show, missing[:8]))}{' ...' if len(missing) > 8 else ''}")
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
            raise self.err("attack.kind", f"unknown attack kind {show(kind)} (expected one of: {', '.join(ATTACK_KINDS)})")
        actuators = self.node_list(a["actuators"], "attack.actuators")
        if not actuators:
            raise self.err("attack.actuators", "an attack needs at least one compromised actuator")
        sensors = self.node_list(a.get("sensors", []), "attack.sensors")
        monitored = set(monitor.positions) | set(monitor.velocities)
        for k, s in enumerate(sensors):
            if s not in monitored:
                raise self.err(f"attack.sensors[{k}]", f"node {show(s)} has no globally monitored channel to compromise")
        if sensors and kind == "zda":
            raise self.err("attack.sensors", "a zero-dynamics attack uses no sensor channel (kind = 'covert' does)")
        lam: complex | None = None
        if "lambda0" in a:
            raw = a["lambda0"]
            if isinstance(raw, list):
                b = LAMBDA0_MAX
                re_, im_ = (self.real(raw[0], "attack.lambda0[0]", lo=-b, hi=b), self.real(raw[1], "attack.lambda0[1]", lo=-b, hi=b))
                lam = complex(re_, im_)
            else:
                big = Fraction(LAMBDA0_MAX)
                lam = complex(float(self.rational(raw, "attack.lambda0", positive=False, lo=-big, hi=big)))
        start = self.real(a.get("start", 0.0), "attack.start", nonneg=True, hi=TIME_MAX)
        signal = a.get("signal")
        if signal is not None and signal not in ("exponential", "step", "sine"):
            raise self.err("attack.signal", f"unknown signal {show(signal)} (expected exponential, step or sine)")
        return AttackSpec(
            kind,
            actuators,
            sensors,
            lam,
            start,
            signal,
            self.real(a.get("amplitude", 1.0), "attack.amplitude", lo=-AMPLITUDE_MAX, hi=AMPLITUDE_MAX),
            self.real(a.get("frequency", 1.0), "attack.frequency", nonneg=True, hi=TIME_MAX),
        )

    def switching(self, s: Mapping[str, Any] | None, mode_names: set[str]) -> SwitchingSpec | None:
        if s is None:
            return None
        known = mode_names | {NORMAL_MODE}
        mode = s.get("mode")
        if mode is not None and mode not in mode_names:
            raise self.err("switching.mode", f"no safe mode named {show(mode)} (defined: {clip(', '.join(sorted(mode_names)), 80) or 'none'})")
        time = None
        if "time" in s:
            time = self.time(s["time"], "switching.time")
        if mode is not None and time is None:
            raise self.err("switching", "missing required key 'time'")
        seq = []
        for k, step in enumerate(s.get("sequence", [])):
            if step["mode"] not in known:
                raise self.err(f"switching.sequence[{k}].mode", f"no mode named {show(step['mode'])}")
            seq.append(SwitchStep(step["mode"], self.time(step["duration"], f"switching.sequence[{k}].duration")))
        return SwitchingSpec(mode, time, tuple(seq))

    def simulation(self, s: Mapping[str, Any]) -> SimulationSpec:
        horizon = self.time(s.get("horizon", 30.0), "simulation.horizon")
        step = self.time(s.get("step", 0.01), "simulation.step")
        if step > horizon:
            raise self.err("simulation.step", f"step {step} is longer than the horizon {horizon}")
        if horizon / step > MAX_SAMPLES:
            raise self.err("simulation.step", f"horizon / step = {horizon / step:.3g} samples (at most {MAX_SAMPLES:.0e}); enlarge the step")
        seed = s.get("seed", 0)
        if type(seed) is not int:
            if not (type(seed) is float and seed.is_integer()):
                raise self.err("simulation.seed", f"expected an integer, got {show(seed)}")
            seed = int(seed)
        if not 0 <= seed <= SEED_MAX:
            raise self.err("simulation.seed", f"must be in [0, 2**63 - 1], got {show(seed)}")
        return SimulationSpec(horizon, step, seed)

    def pole(self, value: Any, path: str) -> Fraction:
        """An observer pole: an exact rational in ``[POLE_MIN, POLE_MAX]`` (negative)."""
        q = self.rational(value, path, positive=False)
        if q >= 0:
            raise self.err(path, f"observer poles must be < 0, got {show(value)}")
        if not POLE_MIN <= q <= POLE_MAX:
            raise self.err(path, f"observer poles must lie in [{float(POLE_MIN):g}, {float(POLE_MAX):g}], got {show(value)}")
        return q


# --------------------------------------------------------------------------------------------
# library construction


#: how a graph with other labels is made acceptable (the text of the refusal)
RELABEL_HINT = (
    "labels are integers or strings: relabel the graph first, e.g. "
    "nx.convert_node_labels_to_integers(G, first_label=1, label_attribute='name') "
    "(the old label stays a node attribute) or nx.relabel_nodes(G, str)"
)


def _label(x: Any) -> Any:
    """A node label as the spec writes it: ints and strings stay (a ``str`` subclass becomes
    ``str``), integer-like objects (numpy integers) become ``int``; anything else (a tuple of a
    grid graph, a float, an object) is left as it is for the validator to refuse, naming its key
    path: turning it into its text would not round-trip (``dump_spec`` would write the text,
    and results would name ``"(0, 1)"`` where the graph has ``(0, 1)``)."""
    if isinstance(x, bool):
        return x
    if isinstance(x, int):
        return int(x)
    if isinstance(x, str):
        return str(x)
    if isinstance(x, numbers.Integral):  # numpy integers (not arrays: an array is left to be refused)
        return int(x)
    return x


def _number(x: Any) -> Any:
    if isinstance(x, Fraction):
        return str(x)
    return plain_scalar(x)


def _rows(value: Any, path: str, labels: int) -> list[Any]:
    """``value`` (an iterable of edges or labels) as lists; the first ``labels`` items of each
    row are labels, the rest numbers. Raises :class:`SpecError` for what is not iterable."""
    if isinstance(value, (str, bytes)) or not isinstance(value, Iterable):
        raise SpecError(path, f"expected a list, got {show(value)}")
    out: list[Any] = []
    for k, row in enumerate(value):
        if labels == 0:
            out.append(_label(row))
        elif isinstance(row, (str, bytes)) or not isinstance(row, Iterable):
            raise SpecError(f"{path}[{k}]", f"expected an edge (i, j[, weight]), got {show(row)}")
        else:
            out.append([_label(x) if i < labels else _number(x) for i, x in enumerate(row)])
    return out


def _table(value: Any, path: str) -> dict[str, Any]:
    if not isinstance(value, Mapping):
        raise SpecError(path, f"expected a mapping, got {show(value)}")
    return dict(value)


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
        Undirected graph; edge attribute ``weight`` (default 1) is the coupling weight. Node
        labels are integers or strings (numpy integers are read as ``int``); other labels
        (the tuples of ``nx.grid_2d_graph``) are refused with a :class:`SpecError` that says
        how to relabel, since their text would not round-trip through :func:`~glocal_verify.spec.writer.dump_spec`.
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
    if not isinstance(graph, nx.Graph):
        raise SpecError("graph", f"expected a networkx.Graph, got {type(graph).__name__}")
    if not isinstance(weight, str):
        raise ArgumentError(f"weight: expected the name of an edge attribute (a string), got {show(weight)}")
    if graph.is_directed():
        raise SpecError("graph", "the graph must be undirected (got a directed graph)")
    if graph.is_multigraph():
        raise SpecError("graph", "parallel edges are not supported (got a multigraph); merge them into one weighted edge")
    for u, v in nx.selfloop_edges(graph):
        raise SpecError("graph.edges", f"self-loop at node {show(u)}")
    for k, node in enumerate(graph.nodes):
        if type(_label(node)) not in (int, str):
            raise SpecError(f"graph.nodes[{k}]", f"node {show(node)} is a {type(node).__name__}; {RELABEL_HINT}")
    data: dict[str, Any] = {
        "format": 1,
        "name": name,
        "dynamics": {"alpha": _number(alpha), "gamma": _number(gamma)},
        "graph": {
            "nodes": [_label(n) for n in graph.nodes],
            "edges": [[_label(u), _label(v), _number(d.get(weight, 1))] for u, v, d in graph.edges(data=True)],
        },
        "monitor": {
            "positions": _rows(monitor_positions, "monitor.positions", 0),
            "velocities": _rows(monitor_velocities, "monitor.velocities", 0),
        },
    }
    if modes:
        data["modes"] = []
        for k, (mname, m) in enumerate(_table(modes, "modes").items()):
            m = _table(m, f"modes[{k}]")
            data["modes"].append(
                {
                    "name": mname,
                    "add": _rows(m.get("add", []), f"modes[{k}].add", 2),
                    "remove": _rows(m.get("remove", []), f"modes[{k}].remove", 2),
                }
            )
    if clusters:
        cl = []
        obs_table = _table(observers or {}, "observers")
        for k, (cname, members) in enumerate(_table(clusters, "clusters").items()):
            entry: dict[str, Any] = {"name": cname, "nodes": _rows(members, f"clusters[{k}].nodes", 0)}
            obs = obs_table.get(cname, [])
            if isinstance(obs, (str, bytes)) or not isinstance(obs, Iterable):
                raise SpecError(f"clusters[{k}].observers", f"expected a list of centres, got {show(obs)}")
            entry["observers"] = [dict(o) if isinstance(o, Mapping) else {"center": _label(o)} for o in obs]
            cl.append(entry)
        data["clusters"] = cl
    if attack:
        data["attack"] = _table(attack, "attack")
    if switching:
        data["switching"] = _table(switching, "switching")
    if simulation:
        data["simulation"] = _table(simulation, "simulation")
    return spec_from_dict(data)
