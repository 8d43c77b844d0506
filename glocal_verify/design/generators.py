"""Random clustered networks for benchmarks, property tests and design studies.

Four generators:

- :func:`random_clustered_spec`, the friendly family (below);
- :func:`adverse_clustered_spec`, networks built the way people draw them: stochastic-block-model
  clusters of 30-300 agents with mean degree 3-10, links between consecutive or random pairs of
  clusters, observers that measure only their neighbours (the spec's default), their
  neighbours and the cluster's boundary, or the whole cluster; :func:`adverse_family` draws its
  members across that range (the benchmarks report the worst of them);
- :func:`symmetric_clusters_spec`, copies of one random cluster joined in a ring (a symmetry of
  the weighted graph: repeated eigenvalues of L_1);
- :func:`structured_clustered_spec`, identical copies of one cluster, a class of twin leaves,
  weights p^2 / 10^6 or p^2 / 10^7 for large primes p, symmetries broken by 10^-9..10^-15 and
  position or velocity monitors; :func:`structured_family` draws its members across that range.

:func:`random_clustered_spec` builds a validated :class:`~glocal_verify.spec.types.SystemSpec`:
clusters are sparse connected random graphs (a random spanning tree plus a few chords, integer
weights), consecutive clusters are joined by a few inter-cluster edges, a handful of agents
are velocity-monitored, each safe mode adds an intra-cluster link at a monitored agent, each
cluster's observers sit at boundary agents and measure their neighbours and the cluster's boundary
(so Proposition III.2 (ii) holds), and a ZDA attacks two interior (not boundary, not monitored)
agents of the first cluster.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from types import MappingProxyType

import inspect
import math
from typing import Any, Mapping

import numpy as np

from glocal_verify.errors import SpecError
from glocal_verify.spec import spec_from_dict
from glocal_verify.spec.types import MAX_EDGES, MAX_MODES, MAX_NODES, TIME_MAX, TIME_MIN, WEIGHT_MAX, SystemSpec

__all__ = [
    "ADVERSE_LINKS",
    "ADVERSE_MEASURES",
    "AdverseMember",
    "GENERATOR_DEFAULTS",
    "STRUCTURED_ATTACKS",
    "STRUCTURED_JOINS",
    "STRUCTURED_MONITORS",
    "STRUCTURED_WEIGHTS",
    "StructuredMember",
    "adverse_clustered_spec",
    "adverse_family",
    "check_generator_arguments",
    "random_clustered_spec",
    "structured_clustered_spec",
    "structured_family",
    "symmetric_clusters_spec",
]

def _count(value: Any, name: str, lo: int, hi: int | None = None) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise SpecError(name, f"expected an integer, got {type(value).__name__}")
    if value < lo or (hi is not None and value > hi):
        raise SpecError(name, f"must be in [{lo}, {hi if hi is not None else 'inf'}], got {int(value)}")


def check_generator_arguments(
    n: Any, clusters: Any, seed: Any, chords: Any, cut_edges: Any, monitors: Any, modes: Any,
    max_weight: Any, observers_per_cluster: Any, horizon: Any, step: Any,
) -> None:
    """Refuse arguments of :func:`random_clustered_spec` outside their domain: a
    :class:`SpecError` whose path is the argument's name (a sweep checks its whole grid with
    it before any member runs).

    Parameters
    ----------
    n, clusters, seed, chords, cut_edges, monitors, modes, max_weight, observers_per_cluster, horizon, step
        As for :func:`random_clustered_spec`.
    """
    _count(clusters, "clusters", 1, MAX_NODES // 2)
    _count(n, "n", 2 * int(clusters), MAX_NODES)
    _count(seed, "seed", 0, 2**63 - 1)
    _count(cut_edges, "cut_edges", 0, MAX_EDGES)
    if monitors is not None:
        _count(monitors, "monitors", 0, int(n))
    _count(modes, "modes", 0, MAX_MODES)
    _count(max_weight, "max_weight", 1, int(WEIGHT_MAX))
    _count(observers_per_cluster, "observers_per_cluster", 0, int(n))
    for name, x, lo, hi in (("chords", chords, 0.0, 100.0), ("horizon", horizon, TIME_MIN, TIME_MAX), ("step", step, TIME_MIN, TIME_MAX)):
        if isinstance(x, bool) or not isinstance(x, (int, float, np.integer, np.floating)) or not math.isfinite(float(x)):
            raise SpecError(name, f"expected a finite number, got {x!r}"[:120])
        if not lo <= float(x) <= hi:
            raise SpecError(name, f"must be in [{lo:g}, {hi:g}], got {float(x):g}")


def random_clustered_spec(
    n: int,
    clusters: int = 3,
    *,
    seed: int = 0,
    chords: float = 0.5,
    cut_edges: int = 2,
    monitors: int | None = None,
    modes: int = 2,
    max_weight: int = 3,
    attack: bool = True,
    observers_per_cluster: int = 1,
    horizon: float = 30.0,
    step: float = 0.05,
) -> SystemSpec:
    """A connected clustered network of ``n`` agents.

    Parameters
    ----------
    n : int
        Number of agents (labels 1..n).
    clusters : int
        Number of clusters (contiguous label ranges of near-equal size).
    seed : int
        Seed of the random generator (same seed, same network).
    chords : float
        Extra intra-cluster edges per agent (on top of a spanning tree).
    cut_edges : int
        Inter-cluster edges between consecutive clusters.
    monitors : int, optional
        Velocity-monitored agents (default ``max(3, n // 100)``).
    modes : int
        Safe modes; each adds one intra-cluster link at a monitored agent.
    max_weight : int
        Edge weights are drawn uniformly from 1..max_weight.
    attack : bool
        Add a ZDA on two interior agents of the first cluster (and a scheduled switch).
    observers_per_cluster : int
        Local observers per cluster, centred at boundary agents first.
    horizon, step : float
        The ``[simulation]`` table.

    Raises
    ------
    SpecError
        For arguments outside their domain (one line naming the argument): ``n`` must be an
        integer with ``2 * clusters <= n <= MAX_NODES``, ``clusters >= 1``, ``chords`` finite and
        ``>= 0``, counts ``>= 0``, ``1 <= max_weight <= WEIGHT_MAX``, and ``horizon``/``step`` in
        the spec's time domain (:mod:`glocal_verify.spec.types`).
    """
    check_generator_arguments(n, clusters, seed, chords, cut_edges, monitors, modes, max_weight, observers_per_cluster, horizon, step)
    rng = np.random.default_rng(seed)
    bounds = np.linspace(0, n, clusters + 1).round().astype(int)
    members = [list(range(bounds[k] + 1, bounds[k + 1] + 1)) for k in range(clusters)]
    edges: dict[tuple[int, int], int] = {}

    def add(u: int, v: int) -> None:
        a, b = (u, v) if u < v else (v, u)
        if a != b and (a, b) not in edges:
            edges[(a, b)] = int(rng.integers(1, max_weight + 1))

    for nodes in members:
        order = list(rng.permutation(nodes))
        for k in range(1, len(order)):
            add(int(order[k]), int(order[int(rng.integers(0, k))]))
        for _ in range(int(chords * len(nodes))):
            u, v = rng.choice(nodes, 2, replace=False)
            add(int(u), int(v))
    for k in range(clusters - 1):
        for _ in range(cut_edges):
            add(int(rng.choice(members[k])), int(rng.choice(members[k + 1])))
    n_mon = monitors if monitors is not None else max(3, n // 100)
    mon = sorted(int(x) for x in rng.choice(np.arange(1, n + 1), size=min(n_mon, n), replace=False))
    mode_list: list[dict[str, Any]] = []
    for q in range(modes):
        for _ in range(100):
            m = int(rng.choice(mon))
            cl = next(c for c in members if m in c)
            other = int(rng.choice(cl))
            key = (min(m, other), max(m, other))
            if other != m and key not in edges:
                mode_list.append({"name": f"safe-{q + 1}", "add": [[key[0], key[1], 1]]})
                break
    cluster_tables = []
    for k, nodes in enumerate(members):
        inside = set(nodes)
        bnd = sorted({a for (u, v) in edges for a in (u, v) if a in inside and ((u in inside) != (v in inside))})
        pool = bnd + [a for a in nodes if a not in bnd]
        observers = []
        for c in pool[: min(observers_per_cluster, len(nodes))]:
            # centre at a boundary agent; it measures its in-cluster neighbours and the cluster's
            # boundary agents, so Proposition III.2 (ii) holds by construction
            nb = {b for (u, v) in edges for b in (u, v) if c in (u, v) and b != c and b in inside}
            meas = sorted(nb | set(bnd) | {c})
            observers.append({"center": c, "positions": meas, "velocities": meas})
        cluster_tables.append({"name": f"P{k + 1}", "nodes": nodes, "observers": observers})
    data = _clustered_data(f"random-{n}-{clusters}-s{seed}", n, edges, mode_list, cluster_tables, mon, (horizon, step, seed))
    if attack:
        boundary = {a for key in edges for a in key if (a in members[0]) != (next(b for b in key if b != a) in members[0])}
        _attach_zda(data, rng, members[0], set(mon) | boundary)
    return spec_from_dict(data)


def _clustered_data(name: str, n: int, edges: Mapping[tuple[int, int], Any], modes: list[dict[str, Any]], clusters: list[dict[str, Any]],
                    monitored: list[int], simulation: tuple[float, float, int]) -> dict[str, Any]:
    """The spec table of a generated clustered network (velocity monitors only)."""
    horizon, step, seed = simulation
    return {
        "format": 1,
        "name": name,
        "graph": {"nodes": n, "edges": [[u, v, w] for (u, v), w in sorted(edges.items())]},
        "modes": modes,
        "clusters": clusters,
        "monitor": {"positions": [], "velocities": monitored},
        "simulation": {"horizon": horizon, "step": step, "seed": seed},
    }


def _attach_zda(data: dict[str, Any], rng: np.random.Generator, first_cluster: list[int], excluded: set[int]) -> None:
    """A two-agent ZDA on interior unmonitored agents of the first cluster, and the switch to the first mode at a third of the horizon."""
    first = [a for a in first_cluster if a not in excluded]
    if len(first) < 2:
        raise SpecError("attack", f"the first cluster has {len(first)} interior unmonitored agent(s); a ZDA needs two (use attack=False or more agents)")
    data["attack"] = {"kind": "zda", "actuators": [int(a) for a in rng.choice(first, size=2, replace=False)]}
    if data["modes"]:
        data["switching"] = {"mode": data["modes"][0]["name"], "time": data["simulation"]["horizon"] / 3}


#: the default arguments of :func:`random_clustered_spec` (all but ``n``, ``attack``)
GENERATOR_DEFAULTS: Mapping[str, Any] = MappingProxyType({
    k: p.default for k, p in inspect.signature(random_clustered_spec).parameters.items() if p.default is not inspect.Parameter.empty and k != "attack"
})


# -- the adverse family -----------------------------------------------------------------------

#: how the clusters of :func:`adverse_clustered_spec` are linked
ADVERSE_LINKS = ("consecutive", "random")
#: what the observers of :func:`adverse_clustered_spec` measure
ADVERSE_MEASURES = ("neighbours", "boundary", "cluster")


def _sbm_cluster(rng: np.random.Generator, nodes: list[int], degree: float, add: Any) -> None:
    """A connected random graph on ``nodes`` of mean degree about ``degree``: a random recursive
    tree (every agent attaches to an earlier one) plus uniform random pairs (the block of a
    stochastic block model, conditioned on being connected)."""
    order = [int(x) for x in rng.permutation(nodes)]
    for k in range(1, len(order)):
        add(order[k], order[int(rng.integers(0, k))])
    n = len(nodes)
    target = min(n * (n - 1) // 2, max(n - 1, int(round(degree * n / 2))))
    have = n - 1
    tries = 0
    while have < target and tries < 20 * target:
        tries += 1
        u, v = rng.choice(n, 2, replace=False)
        if add(order[int(u)], order[int(v)]):
            have += 1


def adverse_clustered_spec(
    n: int,
    *,
    seed: int = 0,
    cluster_size: int = 100,
    degree: float = 8.0,
    links: str = "random",
    cut_edges: int = 2,
    measure: str = "neighbours",
    modes: int = 1,
    attack: bool = True,
    monitors: int | None = None,
    max_weight: int = 3,
    horizon: float = 30.0,
    step: float = 0.05,
) -> SystemSpec:
    """A clustered network of ``n`` agents drawn the way people draw them.

    Each cluster (``round(n / cluster_size)`` of them, sizes within 30 % of each other) is a
    connected random graph of mean degree ``degree`` (stochastic block model); every linked
    pair of clusters shares ``cut_edges`` links between random agents; one observer per cluster
    sits at a random agent; ``monitors`` velocity-monitored agents; each safe mode adds one
    link inside a cluster at a monitored agent; the ZDA attacks two agents of the first cluster
    that are neither monitored nor on its boundary.

    Parameters
    ----------
    n : int
        Number of agents (labels 1..n).
    seed : int
        Seed of the random generator (same arguments, same network).
    cluster_size : int
        Mean cluster size (30-300 in the family).
    degree : float
        Mean degree inside a cluster (3-10 in the family).
    links : {"consecutive", "random"}
        Clusters linked in a chain, or along a random tree of clusters plus one random pair per
        two clusters.
    cut_edges : int
        Links per linked pair of clusters.
    measure : {"neighbours", "boundary", "cluster"}
        The observer measures the positions and velocities of its centre and neighbours (the
        spec's default set, left implicit), also of its cluster's boundary agents, or of every
        agent of its cluster.
    modes : int
        Safe modes.
    attack : bool
        Add a two-agent ZDA in the first cluster (and a switch to the first safe mode).
    monitors : int, optional
        Velocity-monitored agents (default ``max(3, n // 100)``).
    max_weight : int
        Weights are drawn uniformly from 1..max_weight.
    horizon, step : float
        The ``[simulation]`` table.

    Raises
    ------
    SpecError
        For arguments outside their domain (one line naming the argument).
    """
    clusters = max(1, int(round(n / max(int(cluster_size), 1)))) if isinstance(cluster_size, (int, np.integer)) and not isinstance(cluster_size, bool) else 0
    check_generator_arguments(n, max(clusters, 1), seed, 0.0, cut_edges, monitors, modes, max_weight, 1, horizon, step)
    _count(cluster_size, "cluster_size", 4, MAX_NODES)
    if isinstance(degree, bool) or not isinstance(degree, (int, float, np.integer, np.floating)) or not 1.0 <= float(degree) <= 100.0:
        raise SpecError("degree", f"expected a number in [1, 100], got {degree!r}"[:120])
    if links not in ADVERSE_LINKS:
        raise SpecError("links", f"must be one of {', '.join(ADVERSE_LINKS)}, got {links!r}"[:120])
    if measure not in ADVERSE_MEASURES:
        raise SpecError("measure", f"must be one of {', '.join(ADVERSE_MEASURES)}, got {measure!r}"[:120])
    rng = np.random.default_rng(seed)
    # cluster sizes within 30 % of each other, summing to n, each at least 4
    weights = rng.uniform(0.85, 1.15, clusters)
    bounds = np.concatenate([[0], np.cumsum(weights) / weights.sum() * n]).round().astype(int)
    members = [list(range(bounds[k] + 1, bounds[k + 1] + 1)) for k in range(clusters)]
    members = [m for m in members if m]
    edges: dict[tuple[int, int], int] = {}

    def add(u: int, v: int) -> bool:
        a, b = (u, v) if u < v else (v, u)
        if a == b or (a, b) in edges:
            return False
        edges[(a, b)] = int(rng.integers(1, max_weight + 1))
        return True

    for nodes in members:
        _sbm_cluster(rng, nodes, float(degree), add)
    k = len(members)
    if links == "consecutive":
        pairs = [(c, c + 1) for c in range(k - 1)]
    else:
        perm = [int(x) for x in rng.permutation(k)]
        pairs = [(perm[c], perm[int(rng.integers(0, c))]) for c in range(1, k)]
        seen = {tuple(sorted(p)) for p in pairs}
        for _ in range(k // 2 if k > 2 else 0):
            a, b = (int(x) for x in rng.choice(k, 2, replace=False))
            if tuple(sorted((a, b))) not in seen:
                seen.add(tuple(sorted((a, b))))
                pairs.append((a, b))
    for a, b in pairs:
        for _ in range(cut_edges):
            add(int(rng.choice(members[a])), int(rng.choice(members[b])))
    n_mon = monitors if monitors is not None else max(3, n // 100)
    mon = sorted(int(x) for x in rng.choice(np.arange(1, n + 1), size=min(n_mon, n), replace=False))
    where = {a: c for c, nodes in enumerate(members) for a in nodes}
    mode_list = _safe_modes(rng, modes, mon, edges, lambda m: int(rng.choice(members[where[m]])))
    boundary = {a for (u, v) in edges for a in (u, v) if where[u] != where[v]}
    cluster_tables = []
    for c, nodes in enumerate(members):
        centre = int(rng.choice(nodes))
        obs: dict[str, Any] = {"center": centre}
        if measure != "neighbours":
            if measure == "cluster":
                meas = list(nodes)
            else:
                nb = {b for (u, v) in edges for b in (u, v) if centre in (u, v) and where[u] == where[v]}
                meas = sorted(nb | {a for a in nodes if a in boundary} | {centre})
            obs.update({"positions": meas, "velocities": meas})
        cluster_tables.append({"name": f"P{c + 1}", "nodes": nodes, "observers": [obs]})
    name = f"adverse-{n}-c{cluster_size}-d{float(degree):g}-{links}-{measure}-m{modes}{'' if attack else '-noattack'}-s{seed}"
    data = _clustered_data(name, n, edges, mode_list, cluster_tables, mon, (horizon, step, seed))
    if attack:
        _attach_zda(data, rng, members[0], set(mon) | set(boundary))
    return spec_from_dict(data)


def _safe_modes(rng: np.random.Generator, modes: int, monitored: list[int], edges: Mapping[tuple[int, int], Any], partner: Any) -> list[dict[str, Any]]:
    """``modes`` safe modes, each one new link of weight 1 between a monitored agent m and ``partner(m)`` (up to 100 draws each)."""
    out: list[dict[str, Any]] = []
    for q in range(modes):
        for _ in range(100):
            m = int(rng.choice(monitored))
            other = partner(m)
            key = (min(m, other), max(m, other))
            if other != m and key not in edges and all(key != tuple(md["add"][0][:2]) for md in out):
                out.append({"name": f"safe-{q + 1}", "add": [[key[0], key[1], 1]]})
                break
    return out


@dataclass(frozen=True, slots=True)
class AdverseMember:
    """One member of the adverse family: the arguments of :func:`adverse_clustered_spec`.

    Attributes
    ----------
    n, seed, cluster_size, degree, links, cut_edges, measure, modes, attack
        As for :func:`adverse_clustered_spec`.
    """

    n: int
    seed: int
    cluster_size: int
    degree: float
    links: str
    cut_edges: int
    measure: str
    modes: int
    attack: bool

    @property
    def label(self) -> str:
        """A short description for tables: ``c100 d8 random neighbours m1 zda s0``."""
        return f"c{self.cluster_size} d{self.degree:g} {self.links} {self.measure} m{self.modes} {'zda' if self.attack else 'no attack'} s{self.seed}"

    def spec(self) -> SystemSpec:
        """The member's network."""
        return adverse_clustered_spec(
            self.n, seed=self.seed, cluster_size=self.cluster_size, degree=self.degree, links=self.links,
            cut_edges=self.cut_edges, measure=self.measure, modes=self.modes, attack=self.attack,
        )


def adverse_family(n: int, members: int = 6, *, seed: int = 0) -> list[AdverseMember]:
    """``members`` members of the adverse family at ``n`` agents, spread across its range.

    The first member is the network users bring most often (clusters of about 100 agents of
    mean degree 8, random links between clusters, observers measuring their neighbours only,
    one safe mode, a ZDA); the others draw the cluster size log-uniformly in [30, 300] (at most
    ``n / 2``), the mean degree in [3, 10], the links, the measured set (neighbours only half
    of the time), 0-3 safe modes and the attack (present three times in four).

    Parameters
    ----------
    n : int
        Agents of every member.
    members : int
        How many members.
    seed : int
        Seed of the draw (member i's network has seed ``seed + i``).
    """
    _count(members, "members", 0, 10_000)
    rng = np.random.default_rng([seed, int(n)])
    out = [AdverseMember(n, seed, min(100, max(4, n // 2)), 8.0, "random", 2, "neighbours", 1, True)][:members]
    top = max(30, min(300, n // 2))
    while len(out) < members:
        size = int(round(math.exp(rng.uniform(math.log(min(30, top)), math.log(top)))))
        measure = "neighbours" if rng.random() < 0.5 else str(rng.choice(["boundary", "cluster"]))
        out.append(AdverseMember(
            n, seed + len(out), size, round(float(rng.uniform(3.0, 10.0)), 1), str(rng.choice(ADVERSE_LINKS)), int(rng.integers(1, 4)),
            measure, int(rng.integers(0, 4)), bool(rng.random() < 0.75),
        ))
    return out


def symmetric_clusters_spec(
    n: int,
    clusters: int = 3,
    *,
    seed: int = 0,
    degree: float = 4.0,
    cut_edges: int = 1,
    monitors_per_cluster: int = 1,
    horizon: float = 30.0,
    step: float = 0.05,
) -> SystemSpec:
    """A network of ``clusters`` copies of one random cluster, joined in a ring: a symmetry of the weighted graph.

    Every link has weight 1; each cluster is the same connected random graph (a random spanning
    tree plus chords up to a mean degree of about ``degree``); cluster k is joined to cluster
    k + 1 (mod ``clusters``) by ``cut_edges`` links between the same two template agents, so a
    rotation maps the network onto itself and L_1 repeats eigenvalues (twin agents of the
    template repeat them further). Each cluster has its velocity monitors at the same template
    agents and one observer, at its first boundary agent, measuring its neighbours (the spec's
    default); a ZDA attacks two unmonitored agents of the first cluster (interior ones when
    there are two).

    Parameters
    ----------
    n : int
        Number of agents (labels 1..n), a multiple of ``clusters``; each cluster has at least 4.
    clusters : int
    seed : int
    degree : float
        Mean degree inside a cluster (about).
    cut_edges : int
        Links between consecutive clusters.
    monitors_per_cluster : int
        Velocity-monitored agents per cluster.
    horizon, step : float
        The ``[simulation]`` table.

    Raises
    ------
    SpecError
        For arguments outside their domain (one line naming the argument).
    """
    _count(clusters, "clusters", 1, MAX_NODES // 4)
    _count(n, "n", 4 * int(clusters), MAX_NODES)
    _count(seed, "seed", 0, 2**63 - 1)
    _count(cut_edges, "cut_edges", 1, 8)
    _count(monitors_per_cluster, "monitors_per_cluster", 0, 8)
    if n % clusters:
        raise SpecError("n", f"must be a multiple of clusters ({clusters}), got {n}")
    size = n // clusters
    rng = np.random.default_rng(seed)
    template: set[tuple[int, int]] = set()
    order = list(rng.permutation(size))
    for k in range(1, size):
        a, b = int(order[k]), int(order[int(rng.integers(0, k))])
        template.add((min(a, b), max(a, b)))
    want = min(int(round(degree * size / 2)), size * (size - 1) // 2)
    while len(template) < want:
        a, b = (int(x) for x in rng.choice(size, 2, replace=False))
        template.add((min(a, b), max(a, b)))
    ends = [tuple(int(x) for x in rng.choice(size, 2, replace=False)) for _ in range(cut_edges)]
    boundary = sorted({e for pair in ends for e in pair})
    inner = [a for a in range(size) if a not in boundary]
    mons = sorted(int(x) for x in rng.choice(inner or list(range(size)), size=min(monitors_per_cluster, len(inner) or size), replace=False))
    edges = []
    for c in range(clusters):
        off = c * size + 1
        edges += [[off + a, off + b, 1] for a, b in sorted(template)]
    if clusters > 1:
        for c in range(clusters if clusters > 2 else 1):
            nxt = (c + 1) % clusters
            edges += [[c * size + 1 + a, nxt * size + 1 + b, 1] for a, b in ends]
    free = [a for a in inner if a not in mons]
    if len(free) < 2:
        free = [a for a in range(size) if a not in mons]
    if len(free) < 2:
        raise SpecError("n", f"a cluster of {size} agents leaves {len(free)} interior unmonitored agent(s); a ZDA needs two")
    attacked = [1 + int(a) for a in rng.choice(free, 2, replace=False)]
    data: dict[str, Any] = {
        "format": 1,
        "name": f"symmetric-{n}-{clusters}-s{seed}",
        "graph": {"nodes": n, "edges": edges},
        "clusters": [{"name": f"P{c + 1}", "nodes": list(range(c * size + 1, (c + 1) * size + 1)), "observers": [{"center": c * size + 1 + boundary[0]}]}
                     for c in range(clusters)],
        "monitor": {"positions": [], "velocities": [c * size + 1 + a for c in range(clusters) for a in mons]},
        "attack": {"kind": "zda", "actuators": sorted(attacked)},
        "simulation": {"horizon": horizon, "step": step, "seed": seed},
    }
    return spec_from_dict(data)


# -- the structured family ----------------------------------------------------------------------

#: how the identical clusters of :func:`structured_clustered_spec` are joined to the rest
STRUCTURED_JOINS = ("hub", "ring", "asymmetric")
#: the weight palettes of :func:`structured_clustered_spec`: small integers, or p^2 / 10^6 and
#: p^2 / 10^7 for the largest primes below 2^24 and 2^30 (those a modular certificate tries first)
STRUCTURED_WEIGHTS = ("small", "prime24", "prime30")
#: which agents the ZDA of :func:`structured_clustered_spec` attacks
STRUCTURED_ATTACKS = ("inside", "across", "twins")
#: which states the monitors of :func:`structured_clustered_spec` measure
STRUCTURED_MONITORS = ("velocities", "positions", "both")

_PRIME_WEIGHTS: Mapping[str, Fraction] = MappingProxyType({"prime24": Fraction(16777213**2, 10**6), "prime30": Fraction(1073741789**2, 10**7)})


def _rational(q: Fraction) -> str | int:
    return int(q) if q.denominator == 1 else f"{q.numerator}/{q.denominator}"


def structured_clustered_spec(
    n: int,
    *,
    seed: int = 0,
    clusters: int = 2,
    cluster_size: int = 15,
    twins: int = 10,
    weights: str = "small",
    join: str = "hub",
    breaking: int = 0,
    monitors: str = "velocities",
    monitored: int = 2,
    attack: str = "across",
    attacked: int = 2,
    modes: int = 0,
    horizon: float = 30.0,
    step: float = 0.05,
) -> SystemSpec:
    """A network of identical clusters, a class of twin leaves and a random rest around a hub.

    Agent 1 is the hub; ``clusters`` copies of one random cluster of ``cluster_size`` agents
    (a random recursive tree plus chords, mean degree about 3, the same weights in every copy);
    ``twins`` leaves hanging from one agent of the rest with the same weight (a twin class); the
    rest (the other agents, with the hub) is a random connected graph. Every copy is joined to
    the hub at the same template agent (``join="hub"``), also to the next copy in a ring
    (``"ring"``; both a symmetry of the weighted graph), or at a random template agent to a
    random agent of the rest with a random weight (``"asymmetric"``: the copies stay identical
    blocks of L_1, the graph has no symmetry). ``breaking`` = k > 0 multiplies one weight by
    1 + 10^-k (k = 9..15): a twin leaf's link when twins are attacked, else a link of the
    second copy at the copy of an attacked agent, so the zeros the symmetry makes (at lambda0 =
    0 and elsewhere) exist only up to that perturbation. Monitors sit at the hub, at agents of
    the rest and at the same template agents of every copy (symmetric), measuring velocities,
    positions or both. The ZDA attacks ``attacked`` agents of the first copy (``"inside"``),
    the same template agent of ``attacked`` copies (``"across"``), or ``attacked`` twin leaves.
    Each safe mode adds a link of weight 1 at a monitored agent.

    Parameters
    ----------
    n : int
        Number of agents (labels 1..n); ``clusters * cluster_size + twins + 2 <= n``.
    seed : int
        Seed of the random generator (same arguments, same network).
    clusters : int
        Identical copies (1-8; 2-4 in the family).
    cluster_size : int
        Agents per copy (at least 3; 15-50 in the family).
    twins : int
        Twin leaves (at least 2; 10-40 in the family).
    weights : {"small", "prime24", "prime30"}
        Weights drawn from 1..3, or from {1, 2, p^2 / 10^6} (p = 2^24 - 3) or {1, 2, p^2 / 10^7}
        (p = 2^30 - 35): exact rationals.
    join : {"hub", "ring", "asymmetric"}
    breaking : int
        0 (exact symmetry) or k in 9..15: one weight times 1 + 10^-k.
    monitors : {"velocities", "positions", "both"}
    monitored : int
        Monitored agents (at least 1).
    attack : {"inside", "across", "twins"}
    attacked : int
        Attacked agents (2-3).
    modes : int
        Safe modes (0-2 in the family).
    horizon, step : float
        The ``[simulation]`` table.

    Raises
    ------
    SpecError
        For arguments outside their domain (one line naming the argument).
    """
    _count(clusters, "clusters", 1, 8)
    _count(cluster_size, "cluster_size", 3, MAX_NODES)
    _count(twins, "twins", 2, MAX_NODES)
    _count(n, "n", int(clusters) * int(cluster_size) + int(twins) + 2, MAX_NODES)
    _count(breaking, "breaking", 0, 15)
    _count(monitored, "monitored", 1, int(n))
    _count(attacked, "attacked", 1, 3)
    check_generator_arguments(n, 1, seed, 0.0, 0, None, modes, 1, 1, horizon, step)
    for name, value, allowed in (("weights", weights, STRUCTURED_WEIGHTS), ("join", join, STRUCTURED_JOINS),
                                 ("monitors", monitors, STRUCTURED_MONITORS), ("attack", attack, STRUCTURED_ATTACKS)):
        if value not in allowed:
            raise SpecError(name, f"must be one of {', '.join(allowed)}, got {value!r}"[:120])
    if 0 < breaking < 9:
        raise SpecError("breaking", f"must be 0 or in [9, 15], got {breaking}")
    if attack == "across" and attacked > clusters:
        raise SpecError("attacked", f"an attack across copies needs as many copies as attacked agents ({attacked} > {clusters})")
    if attacked > (twins if attack == "twins" else cluster_size):
        raise SpecError("attacked", f"{attacked} attacked agents do not fit in {twins if attack == 'twins' else cluster_size} {'twins' if attack == 'twins' else 'agents of a copy'}")
    rng = np.random.default_rng(seed)
    big = _PRIME_WEIGHTS.get(weights)

    def weight() -> Fraction:
        if big is None:
            return Fraction(int(rng.integers(1, 4)))
        return (Fraction(1), Fraction(2), big)[int(rng.integers(0, 3))]

    # the template copy, on 0..cluster_size-1
    template: dict[tuple[int, int], Fraction] = {}

    def add_template(u: int, v: int) -> bool:
        a, b = (u, v) if u < v else (v, u)
        if a == b or (a, b) in template:
            return False
        template[(a, b)] = weight()
        return True

    _sbm_cluster(rng, list(range(cluster_size)), 3.0, add_template)
    offsets = [2 + c * cluster_size for c in range(clusters)]
    first_twin = offsets[-1] + cluster_size
    rest = [1] + list(range(first_twin + twins, n + 1))
    edges: dict[tuple[int, int], Fraction] = {}

    def add(u: int, v: int, w: Fraction | None = None) -> bool:
        a, b = (u, v) if u < v else (v, u)
        if a == b or (a, b) in edges:
            return False
        edges[(a, b)] = weight() if w is None else w
        return True

    for off in offsets:
        for (a, b), w in template.items():
            add(off + a, off + b, w)
    _sbm_cluster(rng, rest, 3.0, add)
    port = int(rng.integers(0, cluster_size))
    for c, off in enumerate(offsets):
        if join == "asymmetric":
            add(off + int(rng.integers(0, cluster_size)), int(rng.choice(rest)))
        else:
            add(1, off + port, Fraction(1))
    if join == "ring" and clusters > 1:
        a, b = (int(x) for x in rng.choice(cluster_size, 2, replace=False))
        for c in range(clusters if clusters > 2 else 1):
            add(offsets[c] + a, offsets[(c + 1) % clusters] + b, Fraction(1))
    parent, w_twin = int(rng.choice(rest)), weight()
    leaves = list(range(first_twin, first_twin + twins))
    for t in leaves:
        add(parent, t, w_twin)
    # the attack, then the monitors (never an attacked agent), then the broken weight
    if attack == "twins":
        F = [int(x) for x in rng.choice(leaves, attacked, replace=False)]
    elif attack == "across":
        a = int(rng.integers(0, cluster_size))
        F = [offsets[c] + a for c in range(attacked)]
    else:
        F = [offsets[0] + int(x) for x in rng.choice(cluster_size, attacked, replace=False)]
    spots: list[list[int]] = [[1]] + [[r] for r in rest[1:]] + [[off + a for off in offsets] for a in range(cluster_size)] + [[t] for t in leaves]
    spots = [s for s in spots if not set(s) & set(F)]
    mon: list[int] = []
    for k in rng.permutation(len(spots)):
        if len(mon) >= monitored:
            break
        if not mon or len(mon) + len(spots[int(k)]) <= monitored:
            mon += spots[int(k)]
    mon = sorted(set(mon))
    if breaking:
        if attack == "twins":
            key = (min(parent, F[0]), max(parent, F[0]))
        else:
            a = F[0] - offsets[0] if attack == "inside" else F[1] - offsets[1]
            touching = sorted(e for e in template if a in e)
            e = touching[int(rng.integers(0, len(touching)))]
            key = (offsets[1 % clusters] + e[0], offsets[1 % clusters] + e[1])
        edges[key] = edges[key] * (1 + Fraction(1, 10**breaking))
    mode_list = _safe_modes(rng, modes, mon, edges, lambda m: int(rng.integers(1, n + 1)))
    parts = [(f"C{c + 1}", list(range(off, off + cluster_size))) for c, off in enumerate(offsets)] + [("rest", sorted(rest + leaves))]
    cluster_tables = [{"name": name, "nodes": nodes, "observers": [{"center": nodes[0]}]} for name, nodes in parts]
    name = (f"structured-{n}-c{clusters}x{cluster_size}-t{twins}-{weights}-{join}-b{breaking}-{monitors}{monitored}"
            f"-{attack}{attacked}-m{modes}-s{seed}")
    data = _clustered_data(name, n, {k: _rational(w) for k, w in edges.items()}, mode_list, cluster_tables, [], (horizon, step, seed))
    # both: every monitored velocity, the positions of about half of those agents
    positions = {"velocities": [], "positions": mon, "both": mon[: max(1, len(mon) // 2)]}[monitors]
    data["monitor"] = {"positions": positions, "velocities": mon if monitors != "positions" else []}
    data["attack"] = {"kind": "zda", "actuators": sorted(F)}
    if mode_list:
        data["switching"] = {"mode": mode_list[0]["name"], "time": horizon / 3}
    return spec_from_dict(data)


@dataclass(frozen=True, slots=True)
class StructuredMember:
    """One member of the structured family: the arguments of :func:`structured_clustered_spec`.

    Attributes
    ----------
    n, seed, clusters, cluster_size, twins, weights, join, breaking, monitors, monitored, attack, attacked, modes
        As for :func:`structured_clustered_spec`.
    """

    n: int
    seed: int
    clusters: int
    cluster_size: int
    twins: int
    weights: str
    join: str
    breaking: int
    monitors: str
    monitored: int
    attack: str
    attacked: int
    modes: int

    @property
    def label(self) -> str:
        """A short description for tables: ``3x20 t12 prime30 hub b12 positions2 across2 m1 s4``."""
        return (f"{self.clusters}x{self.cluster_size} t{self.twins} {self.weights} {self.join} b{self.breaking} "
                f"{self.monitors}{self.monitored} {self.attack}{self.attacked} m{self.modes} s{self.seed}")

    def spec(self) -> SystemSpec:
        """The member's network."""
        return structured_clustered_spec(
            self.n, seed=self.seed, clusters=self.clusters, cluster_size=self.cluster_size, twins=self.twins, weights=self.weights,
            join=self.join, breaking=self.breaking, monitors=self.monitors, monitored=self.monitored, attack=self.attack,
            attacked=self.attacked, modes=self.modes,
        )


def structured_family(n: int, members: int = 6, *, seed: int = 0) -> list[StructuredMember]:
    """``members`` members of the structured family at ``n`` agents, spread across its adverse end.

    Each member draws 2-4 identical copies of 15-50 agents and 10-40 twin leaves (scaled down
    below n = 60: copies of at least 3 agents, at least 2 twins), so that they fit in ``n``
    with at least two agents of rest; the weights (small integers a third of the time, else
    p^2 / 10^6 or p^2 / 10^7 for large primes p), the join (hub, ring, asymmetric), the broken
    symmetry (none a quarter of the time, else one weight times 1 + 10^-k, k = 9..15), the
    monitors (velocities, positions only, both; 1 to 3 + n / 15 monitored agents), the attack
    (2-3 agents inside one copy, across copies, on twins) and 0-2 safe modes.

    Parameters
    ----------
    n : int
        Agents of every member (at least 12).
    members : int
        How many members.
    seed : int
        Seed of the draw (member i's network has seed ``seed + i``).
    """
    _count(members, "members", 0, 10_000)
    _count(n, "n", 12, MAX_NODES)
    rng = np.random.default_rng([seed, int(n), 47])
    lo_size, hi_size = (15, 50) if n >= 60 else (3, max(3, n // 5))
    lo_twins, hi_twins = (10, 40) if n >= 60 else (2, max(2, n // 6))
    out: list[StructuredMember] = []
    while len(out) < members:
        k = int(rng.integers(2, 5))
        size = int(round(math.exp(rng.uniform(math.log(lo_size), math.log(hi_size + 0.5)))))
        twins = int(rng.integers(lo_twins, hi_twins + 1))
        size = min(size, (n - 2 - twins) // k)
        if size < lo_size:
            continue
        attack = str(rng.choice(STRUCTURED_ATTACKS))
        attacked = int(rng.integers(2, 4))
        attacked = min(attacked, k if attack == "across" else twins if attack == "twins" else size)
        breaking = 0 if rng.random() < 0.25 else int(rng.integers(9, 16))
        out.append(StructuredMember(
            n, seed + len(out), k, size, twins, str(rng.choice(STRUCTURED_WEIGHTS)), str(rng.choice(STRUCTURED_JOINS)), breaking,
            str(rng.choice(STRUCTURED_MONITORS)), int(rng.integers(1, 4 + n // 15)), attack, attacked, int(rng.integers(0, 3)),
        ))
    return out
