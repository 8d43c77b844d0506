"""Random clustered networks for benchmarks, property tests and design studies.

:func:`random_clustered_spec` builds a validated :class:`~glocal_verify.spec.types.SystemSpec`:
clusters are sparse connected random graphs (a random spanning tree plus a few chords, integer
weights), consecutive clusters are joined by a few inter-cluster edges, a handful of agents
are velocity-monitored, each safe mode adds an intra-cluster link at a monitored agent, each
cluster's observers sit at boundary agents and measure their neighbours and the cluster's boundary
(so Proposition III.2 (ii) holds), and a ZDA attacks two interior (not boundary, not monitored)
agents of the first cluster.
"""

from __future__ import annotations

from types import MappingProxyType

import inspect
import math
from typing import Any, Mapping

import numpy as np

from glocal_verify.errors import SpecError
from glocal_verify.spec import spec_from_dict
from glocal_verify.spec.types import MAX_EDGES, MAX_MODES, MAX_NODES, TIME_MAX, TIME_MIN, WEIGHT_MAX, SystemSpec

__all__ = [
    "GENERATOR_DEFAULTS",
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
    data: dict[str, Any] = {
        "format": 1,
        "name": f"random-{n}-{clusters}-s{seed}",
        "graph": {"nodes": n, "edges": [[u, v, w] for (u, v), w in sorted(edges.items())]},
        "modes": mode_list,
        "clusters": cluster_tables,
        "monitor": {"positions": [], "velocities": mon},
        "simulation": {"horizon": horizon, "step": step, "seed": seed},
    }
    if attack:
        boundary = {a for key in edges for a in key if (a in members[0]) != (next(b for b in key if b != a) in members[0])}
        first = [a for a in members[0] if a not in mon and a not in boundary]
        if len(first) < 2:
            raise SpecError("attack", f"the first cluster has {len(first)} interior unmonitored agent(s); a ZDA needs two (use attack=False or more agents)")
        data["attack"] = {"kind": "zda", "actuators": [int(a) for a in rng.choice(first, size=2, replace=False)]}
        if mode_list:
            data["switching"] = {"mode": mode_list[0]["name"], "time": horizon / 3}
    return spec_from_dict(data)


#: the default arguments of :func:`random_clustered_spec` (all but ``n``, ``attack``)
GENERATOR_DEFAULTS: Mapping[str, Any] = MappingProxyType({
    k: p.default for k, p in inspect.signature(random_clustered_spec).parameters.items() if p.default is not inspect.Parameter.empty and k != "attack"
})


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
