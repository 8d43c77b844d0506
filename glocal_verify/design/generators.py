"""Random clustered networks for benchmarks, property tests and design studies.

Three generators:

- :func:`random_clustered_spec`, the friendly family (below);
- :func:`adverse_clustered_spec`, networks built the way people draw them: stochastic-block-model
  clusters of 30-300 agents with mean degree 3-10, links between consecutive or random pairs of
  clusters, observers that measure only their neighbours (the spec's default), their
  neighbours and the cluster's boundary, or the whole cluster; :func:`adverse_family` draws its
  members across that range (the benchmarks report the worst of them);
- :func:`symmetric_clusters_spec`, copies of one random cluster joined in a ring (a symmetry of
  the weighted graph: repeated eigenvalues of L_1).

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
    "adverse_clustered_spec",
    "adverse_family",
    "check_generator_arguments",
    "random_clustered_spec",
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
    mode_list: list[dict[str, Any]] = []
    for q in range(modes):
        for _ in range(100):
            m = int(rng.choice(mon))
            other = int(rng.choice(members[where[m]]))
            key = (min(m, other), max(m, other))
            if other != m and key not in edges and all(key != tuple(md["add"][0][:2]) for md in mode_list):
                mode_list.append({"name": f"safe-{q + 1}", "add": [[key[0], key[1], 1]]})
                break
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
