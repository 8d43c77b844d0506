"""Hypothesis strategies for clustered multi-agent networks, shared by all tests.

Every strategy draws *specification mappings* shaped like the TOML file and returns a
validated :class:`~glocal_verify.model.System`, so the spec validation path is exercised too.
"""

from __future__ import annotations

from typing import Any

import networkx as nx
import numpy as np
from hypothesis import strategies as st

from glocal_verify import System, spec_from_dict

__all__ = [
    "weights",
    "graphs",
    "systems",
    "special_graphs",
    "clustered_systems",
    "assert_numeric_matches_exact",
    "assert_completeness_sound",
    "faster_zero_system",
    "dense_laplacian",
    "extended_product",
]


def dense_laplacian(n: int, links: list[tuple[int, int, float]]) -> np.ndarray:
    """The dense Laplacian of weighted links ``(i, j, w)`` on indices ``0 .. n-1`` (a link listed twice counts twice)."""
    L = np.zeros((n, n))
    for i, j, w in links:
        L[i, j] -= w
        L[j, i] -= w
        L[i, i] += w
        L[j, j] += w
    return L


def extended_product(sp: Any) -> tuple[np.ndarray, float]:
    """The exact basis ``U F_1 ... F_s`` of a factored spectrum in extended precision, and how far its rotations may move it.

    The factors are formed densely (exact but for the rounding of their rotations, at most
    ``3 sqrt(N) rotation_rounding`` per factor in Frobenius norm) and multiplied in
    ``numpy.longdouble``, so the certified bounds can be checked against what they bound.
    """
    n = sp.size
    U = np.asarray(sp.base.vectors).astype(np.longdouble)
    widen = 0.0
    for F in sp.factors:
        U = U @ F.apply(np.eye(n)).astype(np.longdouble)
        widen += 3.0 * float(np.sqrt(n)) * F.rotation_rounding
    return U, widen


def weights(integer: bool = True) -> st.SearchStrategy[Any]:
    if integer:
        return st.integers(1, 4)
    return st.sampled_from([0.5, 1.0, 1.5, 2.0, 2.5, 3.0])


@st.composite
def graphs(draw: st.DrawFn, min_n: int = 2, max_n: int = 12, connected: bool = True, integer: bool = True) -> tuple[int, list[list[Any]]]:
    """(N, edges) of an undirected weighted graph on labels 1..N (connected unless asked)."""
    n = draw(st.integers(min_n, max_n))
    edges: dict[tuple[int, int], Any] = {}
    if connected:
        order = draw(st.permutations(list(range(1, n + 1))))
        for k in range(1, n):
            parent = order[draw(st.integers(0, k - 1))]
            u, v = sorted((order[k], parent))
            edges[(u, v)] = draw(weights(integer))
    extra = draw(st.lists(st.tuples(st.integers(1, n), st.integers(1, n)), max_size=2 * n))
    for u, v in extra:
        if u != v:
            a, b = sorted((u, v))
            edges.setdefault((a, b), draw(weights(integer)))
    return n, [[u, v, w] for (u, v), w in sorted(edges.items())]


@st.composite
def special_graphs(draw: st.DrawFn) -> tuple[int, list[list[Any]]]:
    """Graphs with repeated Laplacian eigenvalues: cycles, complete graphs, stars, paths."""
    kind = draw(st.sampled_from(["cycle", "complete", "star", "path", "grid"]))
    n = draw(st.integers(3, 9))
    G = {
        "cycle": nx.cycle_graph(n),
        "complete": nx.complete_graph(min(n, 6)),
        "star": nx.star_graph(n - 1),
        "path": nx.path_graph(n),
        "grid": nx.grid_2d_graph(2, max(2, n // 2)),
    }[kind]
    G = nx.convert_node_labels_to_integers(G, first_label=1)
    return G.number_of_nodes(), [[u, v, 1] for u, v in G.edges]


@st.composite
def systems(
    draw: st.DrawFn,
    max_n: int = 12,
    connected: bool | None = None,
    integer: bool = True,
    special: bool = True,
    max_modes: int = 2,
) -> System:
    """A System with random monitors, safe modes (link changes) and maybe an attack."""
    conn = draw(st.booleans()) if connected is None else connected
    if special and draw(st.integers(0, 4)) == 0:
        n, edges = draw(special_graphs())
    else:
        n, edges = draw(graphs(max_n=max_n, connected=conn, integer=integer))
    labels = list(range(1, n + 1))
    mv = draw(st.lists(st.sampled_from(labels), unique=True, max_size=max(1, n // 2)))
    mx = draw(st.lists(st.sampled_from(labels), unique=True, max_size=2)) if draw(st.integers(0, 3)) == 0 else []
    present = {(min(e[0], e[1]), max(e[0], e[1])) for e in edges}
    modes = []
    for k in range(draw(st.integers(0, max_modes))):
        pairs = draw(st.lists(st.tuples(st.sampled_from(labels), st.sampled_from(labels)), min_size=1, max_size=3))
        add, remove, seen = [], [], set()
        for u, v in pairs:
            if u == v:
                continue
            key = (min(u, v), max(u, v))
            if key in seen:
                continue
            seen.add(key)
            if key in present:
                remove.append(list(key))
            else:
                add.append([key[0], key[1], draw(weights(integer))])
        if add or remove:
            modes.append({"name": f"m{k + 1}", "add": add, "remove": remove})
    data: dict[str, Any] = {
        "format": 1,
        "name": "hyp",
        "graph": {"nodes": n, "edges": edges},
        "monitor": {"positions": mx, "velocities": mv},
        "modes": modes,
    }
    if draw(st.booleans()):
        data["attack"] = {"kind": "zda", "actuators": draw(st.lists(st.sampled_from(labels), unique=True, min_size=1, max_size=3))}
    return System(spec_from_dict(data))


@st.composite
def clustered_systems(draw: st.DrawFn, max_n: int = 14, integer: bool = True) -> System:
    """A connected System partitioned into 2-3 clusters, each with one observer."""
    n, edges = draw(graphs(min_n=4, max_n=max_n, connected=True, integer=integer))
    labels = list(range(1, n + 1))
    k = draw(st.integers(2, min(3, n // 2)))
    cuts = sorted(draw(st.lists(st.integers(1, n - 1), unique=True, min_size=k - 1, max_size=k - 1)))
    bounds = [0] + cuts + [n]
    clusters = []
    for i in range(k):
        members = labels[bounds[i] : bounds[i + 1]]
        center = draw(st.sampled_from(members))
        clusters.append({"name": f"P{i + 1}", "nodes": members, "observers": [{"center": center}]})
    mv = draw(st.lists(st.sampled_from(labels), unique=True, min_size=1, max_size=max(1, n // 3)))
    attack = {"kind": "zda", "actuators": draw(st.lists(st.sampled_from(labels), unique=True, min_size=1, max_size=2))}
    data = {
        "format": 1,
        "name": "hyp-clustered",
        "graph": {"nodes": n, "edges": edges},
        "clusters": clusters,
        "monitor": {"velocities": mv},
        "attack": attack,
    }
    return System(spec_from_dict(data))


def assert_numeric_matches_exact(system: System, ids: list[str]) -> None:
    """Numeric and exact verdicts of ``ids`` agree: exact is never undecided, and a decided
    numeric verdict equals the exact one (a numeric ``holds`` that exact arithmetic calls
    ``fails`` is a bug of the highest priority)."""
    from glocal_verify import verify
    from glocal_verify.results import Status

    def key(r: Any) -> tuple[str, tuple[tuple[str, Any], ...]]:
        return (r.id, tuple(sorted(r.scope.items())))

    num = {key(r): r for r in verify(system, ids).conditions}
    exa = {key(r): r for r in verify(system, ids, exact=True).conditions}
    assert num.keys() == exa.keys()
    for k, rn in num.items():
        re_ = exa[k]
        assert re_.status is not Status.UNDECIDED
        if rn.status is not Status.UNDECIDED:
            assert rn.status is re_.status, (k, rn.witness, re_.witness)


def faster_zero_system() -> tuple[System, tuple[int, ...]]:
    """Five agents whose pencil in s has the zero s = 7 (x^2 + x - 7 in lambda): lambda = (sqrt 29 - 1) / 2 > 0; F = (5, 1)."""
    from glocal_verify import spec_from_graph

    G = nx.Graph()
    G.add_weighted_edges_from([(1, 2, 2), (1, 3, 1), (1, 4, 1), (2, 4, 3), (3, 5, 2), (4, 5, 3)])
    return System(spec_from_graph(G, monitor_velocities=[4, 3])), (5, 1)


def assert_completeness_sound(system: System, F: tuple[Any, ...]) -> None:
    """A completeness claim of the ZDA zero set agrees with the exact analysis over Q.

    ``complete`` says: left-invertible, and every zero lambda != 0 (attacks and unobservable
    modes alike) has Re lambda < 0.
    """
    from glocal_verify.analysis.stealthy.zda_completeness import zero_set_completeness
    from glocal_verify.analysis.stealthy.zda_exact import zda_analysis_exact

    c = zero_set_completeness(system, F)
    if not c.complete:
        return
    ea = zda_analysis_exact(system, F)
    assert ea.left_invertible, f"completeness claimed, but the exact pencil is not left-invertible: {c.text}"
    for z in (*ea.zeros, *ea.unobservable):
        if z.rational is not None and z.rational == 0:
            continue
        assert z.real_sign < 0, f"completeness claimed ({c.text}), but the exact zero {z.value} ({z.factor}) has Re lambda >= 0"
