"""The checker's own reading of a spec: the exact numbers the certificates are about.

Only the fields the certificates need are read, and nothing is validated beyond what the
reading itself needs (a spec ``glocal-verify`` refuses never gets certificates). Numbers are
exact rationals (python-flint ``fmpq``): an integer, a TOML decimal (the decimal its double
prints as, ``0.1`` is 1/10), or a string ``"1/3"`` / ``"2.5e-3"``. ``attack.lambda0`` is read
the way the verifier reads it: the double nearest to the spec's number, as the decimal that
double prints as (``0.5`` is 1/2).
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

from flint import fmpq

__all__ = ["CheckError", "Cluster", "Spec", "read_spec", "rational"]

NORMAL = "normal"


class CheckError(ValueError):
    """A spec or certificate file the checker cannot read (exit code 2)."""


def _digits(text: str) -> bool:
    return text.isascii() and text.isdigit()


def _decimal(text: str, where: str) -> fmpq:
    """The decimal ``text`` of a float (``repr``: digits, one point, an exponent) as the exact
    rational it writes, e.g. ``1.25e-3`` -> 1/800; what ``Fraction(text)`` gives, without its
    regular expression (the certificates hold hundreds of thousands of them)."""
    mant, _, exp = text.lower().partition("e")
    whole, _, frac = mant.partition(".")
    try:
        num = int(whole + frac)
        e = int(exp or "0") - len(frac)
    except ValueError:
        raise CheckError(f"{where}: not a rational number: {text[:60]!r}") from None
    return fmpq(num * 10**e) if e >= 0 else fmpq(num, 10**-e)


def rational(x: Any, where: str = "number") -> fmpq:
    """``x`` (an int, a float read from TOML, or a rational string) as an exact ``fmpq``."""
    if isinstance(x, bool):
        raise CheckError(f"{where}: expected a number, got {x!r}")
    if isinstance(x, int):
        return fmpq(x)
    if isinstance(x, float):
        return _decimal(repr(x), where)
    if isinstance(x, str):  # the certificates' "p/q": two integers, without Fraction's regular expression
        num, slash, den = x.strip().partition("/")
        if _digits(num.removeprefix("-")) and (not slash or _digits(den)) and (not slash or int(den) != 0):
            return fmpq(int(num), int(den) if slash else 1)
    try:
        q = Fraction(str(x).strip())
    except (ValueError, ZeroDivisionError):
        raise CheckError(f"{where}: not a rational number: {str(x)[:60]!r}") from None
    return fmpq(q.numerator, q.denominator)


def key(label: Any) -> str:
    """The text of a node label (the spec never has both ``1`` and ``"1"``)."""
    return str(label)


@dataclass(frozen=True)
class Observer:
    """A local observer: its centre and measured agents (indices)."""

    center: int
    positions: tuple[int, ...]
    velocities: tuple[int, ...]


@dataclass(frozen=True)
class Cluster:
    """A cluster P_i (indices) and its observers."""

    name: str
    nodes: tuple[int, ...]
    observers: tuple[Observer, ...]


@dataclass
class Spec:
    """The exact system: ``A_q = [[0, I], [-alpha L_q, -gamma I]]``, ``C = blkdiag(S_Mx, S_Mv)``."""

    labels: list[Any]
    alpha: fmpq
    gamma: fmpq
    weights: dict[str, dict[tuple[int, int], fmpq]]  # mode -> {(i, j), i < j: weight}
    positions: tuple[int, ...]  # M_x
    velocities: tuple[int, ...]  # M_v
    clusters: tuple[Cluster, ...]
    attack: dict[str, Any] | None
    schedule: tuple[str, ...]  # the modes of the switching schedule, in order (empty: none)
    index: dict[str, int] = field(default_factory=dict)
    implementation: dict[str, Any] | None = None  # {"period": h, "controller": "sampled" | "continuous"}

    @property
    def n(self) -> int:
        return len(self.labels)

    @property
    def modes(self) -> list[str]:
        return list(self.weights)

    @property
    def monitored(self) -> list[int]:
        """M = M_x u M_v, in index order."""
        return sorted(set(self.positions) | set(self.velocities))

    def idx(self, label: Any, where: str = "certificate") -> int:
        try:
            return self.index[key(label)]
        except KeyError:
            raise CheckError(f"{where}: {label!r} is not an agent of the spec") from None

    def laplacian(self, mode: str) -> list[dict[int, fmpq]]:
        """Rows of L_q as ``{column: entry}`` (diagonal included)."""
        rows: list[dict[int, fmpq]] = [{i: fmpq(0)} for i in range(self.n)]
        for (i, j), w in self.weights[mode].items():
            rows[i][j] = -w
            rows[j][i] = -w
            rows[i][i] += w
            rows[j][j] += w
        return rows

    def neighbours(self, mode: str) -> list[set[int]]:
        adj: list[set[int]] = [set() for _ in range(self.n)]
        for i, j in self.weights[mode]:
            adj[i].add(j)
            adj[j].add(i)
        return adj

    def components(self, mode: str) -> list[list[int]]:
        """Connected components of G_q (every agent in one), each sorted."""
        return _components(self.n, self.weights[mode])

    def delta(self, mode: str) -> dict[tuple[int, int], fmpq]:
        """The changed links of a safe mode: ``{(i, j): w_q - w_1}``, nonzero only."""
        a, b = self.weights[mode], self.weights[NORMAL]
        out = {}
        for k in set(a) | set(b):
            d = a.get(k, fmpq(0)) - b.get(k, fmpq(0))
            if d != 0:
                out[k] = d
        return out

    def delta_laplacian(self, mode: str) -> list[dict[int, fmpq]]:
        """Rows of dL_q = L_q - L_1 (only the rows it touches are nonempty)."""
        rows: list[dict[int, fmpq]] = [{} for _ in range(self.n)]
        for (i, j), d in self.delta(mode).items():
            rows[i][j] = rows[i].get(j, fmpq(0)) - d
            rows[j][i] = rows[j].get(i, fmpq(0)) - d
            rows[i][i] = rows[i].get(i, fmpq(0)) + d
            rows[j][j] = rows[j].get(j, fmpq(0)) + d
        return rows

    def switching_components(self, mode: str) -> list[list[int]]:
        """Definition A.1: components (>= 2 agents) of the graph of changed links."""
        return [c for c in _components(self.n, self.delta(mode)) if len(c) >= 2]

    def vector(self, entries: Any, where: str) -> list[fmpq]:
        """A sparse ``{label: rational}`` of a certificate as a dense exact vector."""
        if not isinstance(entries, dict):
            raise CheckError(f"{where}: expected {{agent: number}}")
        v = [fmpq(0)] * self.n
        for lab, x in entries.items():
            v[self.idx(lab, where)] = rational(x, where)
        return v


def _components(n: int, links: Any) -> list[list[int]]:
    parent = list(range(n))

    def find(a: int) -> int:
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    for i, j in links:
        parent[find(i)] = find(j)
    groups: dict[int, list[int]] = {}
    for i in range(n):
        groups.setdefault(find(i), []).append(i)
    return sorted(groups.values())


def read_spec(path: str) -> Spec:
    """Read the spec file at ``path`` (TOML, format 1)."""
    try:
        with open(path, "rb") as fh:
            d = tomllib.load(fh)
    except (OSError, tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise CheckError(f"{path}: cannot read the spec ({exc})") from None
    try:
        return _build(d)
    except (KeyError, TypeError, IndexError, AttributeError) as exc:
        raise CheckError(f"{path}: not a spec the checker can read ({type(exc).__name__}: {exc})") from None


def _build(d: dict[str, Any]) -> Spec:
    g = d["graph"]
    nodes = g["nodes"]
    labels = list(range(1, nodes + 1)) if isinstance(nodes, int) else list(nodes)
    index = {key(lab): k for k, lab in enumerate(labels)}
    if len(index) != len(labels):
        raise CheckError("graph.nodes: a label is listed twice")

    def at(lab: Any, where: str) -> int:
        if type(lab) not in (int, str) or key(lab) not in index:
            raise CheckError(f"{where}: {lab!r} is not in the graph")
        return index[key(lab)]

    def edge_list(items: list[Any], where: str) -> dict[tuple[int, int], fmpq]:
        out: dict[tuple[int, int], fmpq] = {}
        for k, e in enumerate(items):
            i, j = at(e[0], f"{where}[{k}]"), at(e[1], f"{where}[{k}]")
            w = rational(e[2], f"{where}[{k}][2]") if len(e) > 2 else fmpq(1)
            if i == j or w <= 0 or (min(i, j), max(i, j)) in out:
                raise CheckError(f"{where}[{k}]: not a link of positive weight between two agents, or listed twice")
            out[(min(i, j), max(i, j))] = w
        return out

    normal = edge_list(g["edges"], "graph.edges")
    weights = {NORMAL: normal}
    for k, m in enumerate(d.get("modes", [])):
        w = dict(normal)
        for r, pair in enumerate(m.get("remove", [])):
            i, j = at(pair[0], f"modes[{k}].remove[{r}]"), at(pair[1], f"modes[{k}].remove[{r}]")
            if w.pop((min(i, j), max(i, j)), None) is None:
                raise CheckError(f"modes[{k}].remove[{r}]: not a link of the graph")
        for e, x in edge_list(m.get("add", []), f"modes[{k}].add").items():
            if e in w:
                raise CheckError(f"modes[{k}].add: link already in the graph")
            w[e] = x
        if m["name"] in weights:
            raise CheckError(f"modes[{k}].name: {m['name']!r} is defined twice")
        weights[m["name"]] = w
    dyn = d.get("dynamics", {})
    mon = d.get("monitor", {})
    adj: list[set[int]] = [set() for _ in labels]
    for i, j in normal:
        adj[i].add(j)
        adj[j].add(i)
    clusters = []
    for k, c in enumerate(d.get("clusters", [])):
        members = tuple(at(x, f"clusters[{k}].nodes") for x in c["nodes"])
        obs = []
        for j, o in enumerate(c.get("observers", [])):
            centre = at(o["center"], f"clusters[{k}].observers[{j}].center")
            default = tuple(a for a in members if a == centre or a in adj[centre])
            got = {}
            for part in ("positions", "velocities"):
                got[part] = tuple(at(x, f"clusters[{k}].observers[{j}].{part}") for x in o[part]) if part in o else default
            obs.append(Observer(centre, got["positions"], got["velocities"]))
        clusters.append(Cluster(c["name"], members, tuple(obs)))
    attack = None
    if "attack" in d:
        a = d["attack"]
        lam = a.get("lambda0")
        if lam is not None:
            re, im = (lam[0], lam[1]) if isinstance(lam, list) else (lam, 0)
            lam = (rational(float(rational(re, "attack.lambda0")), "attack.lambda0"), rational(float(rational(im, "attack.lambda0")), "attack.lambda0"))
        attack = {
            "kind": a["kind"],
            "actuators": tuple(at(x, "attack.actuators") for x in a["actuators"]),
            "sensors": tuple(at(x, "attack.sensors") for x in a.get("sensors", [])),
            "lambda0": lam,
        }
    schedule: tuple[str, ...] = ()
    sw = d.get("switching")
    if sw is not None:
        if sw.get("sequence"):
            schedule = tuple(s["mode"] for s in sw["sequence"])
        elif sw.get("mode") is not None:
            horizon = float(d.get("simulation", {}).get("horizon", 30.0))
            schedule = (NORMAL,) if horizon <= float(sw["time"]) else (NORMAL, sw["mode"])
    for m in schedule:
        if m not in weights:
            raise CheckError(f"switching: no mode named {m!r}")
    impl = d.get("implementation")
    implementation = None if impl is None else {"period": rational(impl["period"], "implementation.period"), "controller": str(impl.get("controller", "sampled"))}
    return Spec(
        implementation=implementation,
        labels=labels,
        alpha=rational(dyn.get("alpha", 1), "dynamics.alpha"),
        gamma=rational(dyn.get("gamma", 1), "dynamics.gamma"),
        weights=weights,
        positions=tuple(at(x, "monitor.positions") for x in mon.get("positions", [])),
        velocities=tuple(at(x, "monitor.velocities") for x in mon.get("velocities", [])),
        clusters=tuple(clusters),
        attack=attack,
        schedule=schedule,
        index=index,
    )
