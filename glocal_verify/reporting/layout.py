"""Where the agents and links of a network drawing go: a checked layout with routed links.

Every drawing of a network (:func:`~glocal_verify.reporting.network_svg.network_svg`, the
``draw`` command, the graph panels of :mod:`~glocal_verify.reporting.figures.simulation`) takes its
geometry from :func:`network_layout`, so they all share one property: **no link passes through,
or near, an agent it does not join**. In units of the node radius (every agent is drawn as a
disc of radius 1), every point of every drawn link is farther than :data:`CLEARANCE` from the
centre of every agent that is not one of its two ends.

How
---
1. **A layout per cluster.** Each cluster (the agents of no cluster form one more group) gets a
   seeded spring layout of its own links (networkx, seed 1: the same system always gives the
   same picture), scaled so that the median distance to the nearest agent is :data:`SPACING`,
   then relaxed: agents closer than :data:`MIN_SEPARATION` are pushed apart, and an agent too
   close to a link of its cluster is pushed off it (the link's ends move the other way).
2. **Clusters on a circle**, far enough apart that their discs (the agents plus a margin of
   :data:`CLUSTER_MARGIN`) never overlap, each turned (12 angles, mirrored or not) so that its
   links to the other clusters are as short as they can be.
3. **Routed links.** A link whose straight segment comes closer than :data:`CLEARANCE` to an
   agent it does not join is routed around the agents: the shortest path in the visibility
   graph of small polygons circumscribing the agents' clearance discs (A* with the straight
   distance as heuristic; a waypoint is a polygon corner, a step is a segment that keeps the
   clearance from every other agent). The agents are at least :data:`MIN_SEPARATION` apart,
   so the polygons are disjoint and such a path always exists; the result is checked, and a
   link that could not be routed stays straight (:attr:`NetworkLayout.blocked` lists it).

Networks above :data:`ROUTE_MAX_AGENTS` agents are laid out the same way without routing
(a picture of that size is read for its clusters, not its links).
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

import networkx as nx
import numpy as np
from scipy.spatial import cKDTree

from glocal_verify.model import System
from glocal_verify.spec.types import NORMAL_MODE, Label

__all__ = [
    "CLEARANCE",
    "CLUSTER_MARGIN",
    "MIN_SEPARATION",
    "ROUTE_MAX_AGENTS",
    "SPACING",
    "NetworkLayout",
    "network_layout",
    "segment_distance",
]

Point = tuple[float, float]

#: smallest distance from an agent's centre to a link it does not join, in node radii
CLEARANCE = 1.6
#: smallest distance between two agents' centres, in node radii
MIN_SEPARATION = 4.2
#: median distance from an agent to its nearest neighbour inside a cluster, in node radii
SPACING = 6.0
#: margin of a cluster's disc around its agents' centres, in node radii
CLUSTER_MARGIN = 2.6
#: largest network whose links are routed around the agents
ROUTE_MAX_AGENTS = 400

#: corners of the polygon around each agent that routed links may bend at
_CORNERS = 8
#: the polygon's edges keep this factor above CLEARANCE from the centre
_POLYGON_SLACK = 1.04
#: relaxation sweeps inside a cluster
_SWEEPS = 40


@dataclass(frozen=True, slots=True)
class NetworkLayout:
    """Positions and link routes of a network drawing, in units of the node radius.

    Attributes
    ----------
    positions : mapping of label to (x, y)
        Agent centres (y upwards).
    routes : mapping of (u, v) to tuple of points
        The polyline of every routed pair, from ``u``'s centre to ``v``'s; a pair not listed
        is a straight segment (see :meth:`route`).
    groups : tuple of (name or None, tuple of labels, centre, radius)
        The clusters in spec order (and ``None`` for the agents of no cluster) with the disc
        that holds them.
    blocked : tuple of (u, v)
        Pairs that could not be routed clear of every other agent (empty in practice).
    clearance : float
        :data:`CLEARANCE`, the distance the routes keep from other agents' centres.
    """

    positions: Mapping[Label, Point]
    routes: Mapping[tuple[Label, Label], tuple[Point, ...]]
    groups: tuple[tuple[str | None, tuple[Label, ...], Point, float], ...]
    blocked: tuple[tuple[Label, Label], ...] = ()
    clearance: float = CLEARANCE

    def __repr__(self) -> str:
        return (
            f"NetworkLayout({len(self.positions)} agents, {len(self.groups)} groups, {len(self.routes)} routed links"
            + (f", {len(self.blocked)} blocked" if self.blocked else "")
            + f", clearance {self.clearance:g} radii)"
        )

    def route(self, u: Label, v: Label) -> tuple[Point, ...]:
        """The polyline drawn for the pair (u, v), from u's centre to v's."""
        if (u, v) in self.routes:
            return self.routes[(u, v)]
        if (v, u) in self.routes:
            return tuple(reversed(self.routes[(v, u)]))
        return (self.positions[u], self.positions[v])

    def midpoint(self, u: Label, v: Label) -> Point:
        """The point halfway along the drawn route of (u, v) (where a weight label goes)."""
        pts = np.asarray(self.route(u, v), dtype=float)
        seg = np.hypot(*np.diff(pts, axis=0).T)
        half = 0.5 * float(seg.sum())
        for k, length in enumerate(seg):
            if half <= length or k == len(seg) - 1:
                t = half / length if length > 0 else 0.0
                p = pts[k] + t * (pts[k + 1] - pts[k])
                return (float(p[0]), float(p[1]))
            half -= float(length)
        return (float(pts[0][0]), float(pts[0][1]))  # pragma: no cover - a route has a segment

    def bounds(self) -> tuple[float, float, float, float]:
        """(x_min, y_min, x_max, y_max) of the agents' discs, the cluster discs and the routes."""
        pts = [p for p in self.positions.values()] + [p for r in self.routes.values() for p in r]
        xs = [p[0] for p in pts] or [0.0]
        ys = [p[1] for p in pts] or [0.0]
        lo_x, hi_x, lo_y, hi_y = min(xs) - 1, max(xs) + 1, min(ys) - 1, max(ys) + 1
        for _, _, (cx, cy), rad in self.groups:
            lo_x, hi_x, lo_y, hi_y = min(lo_x, cx - rad), max(hi_x, cx + rad), min(lo_y, cy - rad), max(hi_y, cy + rad)
        return lo_x, lo_y, hi_x, hi_y


def segment_distance(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distances from each of ``points`` (k x 2) to each segment from ``a[i]`` to ``b[i]``.

    ``a`` and ``b`` are one point (2,) each, giving a (k,) result, or m points (m x 2) each,
    giving an (m x k) matrix.
    """
    A, B = np.atleast_2d(a).astype(float), np.atleast_2d(b).astype(float)
    D = B - A  # m x 2
    dd = np.einsum("ij,ij->i", D, D)
    rel = points[None, :, :] - A[:, None, :]  # m x k x 2
    t = np.einsum("mkj,mj->mk", rel, D) / np.where(dd > 0, dd, 1.0)[:, None]
    t = np.clip(np.where(dd[:, None] > 0, t, 0.0), 0.0, 1.0)
    out = np.hypot(rel[..., 0] - t * D[:, None, 0], rel[..., 1] - t * D[:, None, 1])
    return out[0] if np.ndim(a) == 1 else out


# --------------------------------------------------------------------------------------------
# a cluster


def _scaled_spring(G: nx.Graph, nodes: Sequence[Label]) -> np.ndarray:
    """Seeded spring layout of ``nodes`` scaled to :data:`SPACING` (k x 2)."""
    if len(nodes) == 1:
        return np.zeros((1, 2))
    raw = nx.spring_layout(G.subgraph(nodes), seed=1, weight=None)
    P = np.array([raw[a] for a in nodes], dtype=float)
    D = np.hypot(P[:, None, 0] - P[None, :, 0], P[:, None, 1] - P[None, :, 1])
    np.fill_diagonal(D, np.inf)
    near = float(np.median(D.min(axis=1)))
    return P * (SPACING / near if near > 1e-12 else SPACING)


def _separate(P: np.ndarray) -> bool:
    """Push apart the pairs closer than :data:`MIN_SEPARATION` (one sweep); True if none was."""
    k = len(P)
    diff = P[:, None, :] - P[None, :, :]
    D = np.hypot(diff[..., 0], diff[..., 1])
    np.fill_diagonal(D, np.inf)
    close = np.argwhere(np.triu(D < MIN_SEPARATION * 1.02, 1))
    for i, j in close:
        d = P[i] - P[j]
        n = float(np.hypot(*d))
        if n < 1e-9:  # coincident: a deterministic direction
            ang = 2.0 * math.pi * (i * 7 + j * 13) / (k * 17 + 1)
            d, n = np.array([math.cos(ang), math.sin(ang)]), 1.0
        push = 0.5 * (MIN_SEPARATION * 1.05 - n) * d / n
        P[i] += push
        P[j] -= push
    return len(close) == 0


def _close_pairs(P: np.ndarray, ends: np.ndarray, within: float) -> list[tuple[int, int, float]]:
    """(link, agent, distance) for every agent closer than ``within`` to a link it does not
    join; ``ends`` (m x 2) are the links' agent indices. Candidates come from a k-d tree
    (agents within half the link's length plus ``within`` of its midpoint)."""
    A, B = P[ends[:, 0]], P[ends[:, 1]]
    near = cKDTree(P).query_ball_point(0.5 * (A + B), 0.5 * np.hypot(*(B - A).T) + within)
    m_idx = np.repeat(np.arange(len(ends)), [len(x) for x in near])
    w_idx = np.fromiter((w for x in near for w in x), dtype=int, count=len(m_idx))
    keep = (w_idx != ends[m_idx, 0]) & (w_idx != ends[m_idx, 1])
    m_idx, w_idx = m_idx[keep], w_idx[keep]
    D = B[m_idx] - A[m_idx]
    rel = P[w_idx] - A[m_idx]
    t = np.clip(np.einsum("ij,ij->i", rel, D) / np.maximum(np.einsum("ij,ij->i", D, D), 1e-12), 0.0, 1.0)
    gap = np.hypot(*(rel - t[:, None] * D).T)
    return [(int(m), int(w), float(g)) for m, w, g in zip(m_idx, w_idx, gap) if g < within]


def _clear_links(P: np.ndarray, links: Sequence[tuple[int, int]]) -> bool:
    """Push agents off the links of their cluster they do not join (one sweep); True if clear."""
    if not links:
        return True
    want = CLEARANCE * 1.5
    hits = _close_pairs(P, np.asarray(links), want)
    for m, w, g in hits:
        i, j = links[m]
        a, b = P[i], P[j]
        d = b - a
        foot = a + np.clip((P[w] - a) @ d / max(float(d @ d), 1e-12), 0.0, 1.0) * d
        away = P[w] - foot
        n = float(np.hypot(*away))
        if n < 1e-9:
            away, n = np.array([-d[1], d[0]]), float(np.hypot(*d)) or 1.0
        step = (want - g) * away / n
        P[w] += 0.6 * step
        P[i] -= 0.2 * step
        P[j] -= 0.2 * step
    return len(hits) == 0


def _cluster_layout(G: nx.Graph, nodes: Sequence[Label], clear: bool) -> np.ndarray:
    """Positions of one cluster, centred at the origin (k x 2); ``clear``: push agents off
    the cluster's links too (not only apart)."""
    P = _scaled_spring(G, nodes)
    if len(nodes) > 1:
        where = {a: k for k, a in enumerate(nodes)}
        links = [(where[u], where[v]) for u, v in G.subgraph(nodes).edges] if clear else []
        for _ in range(_SWEEPS):
            links_clear = _clear_links(P, links)
            if _separate(P) and links_clear:
                break
        for _ in range(_SWEEPS):  # separation is what the routing relies on: finish it
            if _separate(P):
                break
        else:
            D = np.hypot(P[:, None, 0] - P[None, :, 0], P[:, None, 1] - P[None, :, 1])
            np.fill_diagonal(D, np.inf)
            P *= MIN_SEPARATION * 1.05 / max(float(D.min()), 1e-9)
    return P - P.mean(axis=0)


# --------------------------------------------------------------------------------------------
# clusters on a circle


def _place_groups(radii: Sequence[float]) -> np.ndarray:
    """Centres on a circle with no two discs overlapping (equal angles, first on top)."""
    kc = len(radii)
    if kc == 1:
        return np.zeros((1, 2))
    gap = 1.5
    R = max(
        (radii[i] + radii[j] + gap) / (2.0 * math.sin(math.pi * min(j - i, kc - j + i) / kc))
        for i in range(kc)
        for j in range(i + 1, kc)
    )
    ang = math.pi / 2 - 2 * math.pi * np.arange(kc) / kc
    return R * np.column_stack([np.cos(ang), np.sin(ang)])


def _orient(local: list[np.ndarray], centres: np.ndarray, members: list[list[int]], cross: list[tuple[int, int]], group_of: np.ndarray) -> list[np.ndarray]:
    """Turn (and maybe mirror) each cluster so that its inter-cluster links are short."""
    turns = []
    for mirror in (1.0, -1.0):
        for k in range(12):
            c, s = math.cos(2 * math.pi * k / 12), math.sin(2 * math.pi * k / 12)
            turns.append(np.array([[c, -s], [s, c]]) @ np.diag([1.0, mirror]))
    shape = [L.copy() for L in local]
    n = int(group_of.size)
    pos = np.zeros((n, 2))
    for g, idx in enumerate(members):
        pos[idx] = centres[g] + shape[g]
    for _ in range(2):
        for g, idx in enumerate(members):
            mine = [(i, j) if group_of[i] == g else (j, i) for i, j in cross if (group_of[i] == g) != (group_of[j] == g)]
            if not mine or len(idx) == 1:
                continue
            where = {a: k for k, a in enumerate(idx)}
            inner = np.array([where[i] for i, _ in mine])
            outer = pos[[j for _, j in mine]]
            best, best_len = shape[g], math.inf
            for M in turns:
                cand = local[g] @ M.T
                length = float(np.hypot(*(centres[g] + cand[inner] - outer).T).sum())
                if length < best_len - 1e-9:
                    best, best_len = cand, length
            shape[g] = best
            pos[idx] = centres[g] + best
    return shape


# --------------------------------------------------------------------------------------------
# routing


def _route(P: np.ndarray, corners: np.ndarray, owner: np.ndarray, i: int, j: int, *, local: bool) -> list[np.ndarray] | None:
    """Shortest clear polyline from agent i to agent j through polygon corners (A*), or None;
    ``local``: only the corners of the agents near the straight segment."""
    start, goal = P[i], P[j]
    span = float(np.hypot(*(goal - start)))
    keep = np.ones(len(P), dtype=bool)
    keep[[i, j]] = False
    if local:
        # the corners of the agents near the straight segment; every segment between them
        # stays within `reach` of it, so agents farther than reach + CLEARANCE cannot block
        reach = span / 2 + 4 * CLEARANCE
        gap = segment_distance(P, start, goal)
        near = gap < reach
        keep &= gap < reach + 2 * CLEARANCE
    else:
        near = np.ones(len(P), dtype=bool)
    others = P[keep]
    usable = near[owner]
    pts = [start, goal] + [c for c in corners[usable]]
    V = np.array(pts)
    if len(V) > 2:
        D = np.hypot(V[2:, None, 0] - P[None, keep, 0], V[2:, None, 1] - P[None, keep, 1])
        ok = np.concatenate([[True, True], D.min(axis=1, initial=np.inf) > CLEARANCE * 1.001])
        V = V[ok]
    h = np.hypot(*(V - goal).T)
    dist = {0: 0.0}
    prev: dict[int, int] = {}
    heap = [(float(h[0]), 0)]
    done: set[int] = set()
    while heap:
        _, u = heapq.heappop(heap)
        if u in done:
            continue
        if u == 1:
            path = [1]
            while path[-1] != 0:
                path.append(prev[path[-1]])
            return [V[k] for k in reversed(path)]
        done.add(u)
        steps = np.hypot(*(V - V[u]).T)
        best = np.array([dist.get(v, math.inf) for v in range(len(V))])
        cand = dist[u] + steps
        todo = np.flatnonzero(cand < best)
        todo = todo[[v not in done and v != u for v in todo]] if len(todo) else todo
        if len(todo) and len(others):
            # the segments u -> todo that keep the clearance from every other agent
            todo = todo[segment_distance(others, np.repeat(V[u][None, :], len(todo), axis=0), V[todo]).min(axis=1) > CLEARANCE]
        for v in todo:
            dist[int(v)] = float(cand[v])
            prev[int(v)] = u
            heapq.heappush(heap, (float(cand[v] + h[v]), int(v)))
    return None


def _corners(P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Corners of the polygon around every agent (its edges keep CLEARANCE x slack) and their owners."""
    rad = CLEARANCE * _POLYGON_SLACK / math.cos(math.pi / _CORNERS)
    ang = 2 * math.pi * (np.arange(_CORNERS) + 0.5) / _CORNERS
    ring = rad * np.column_stack([np.cos(ang), np.sin(ang)])
    corners = (P[:, None, :] + ring[None, :, :]).reshape(-1, 2)
    return corners, np.repeat(np.arange(len(P)), _CORNERS)


# --------------------------------------------------------------------------------------------
# the layout


def _pairs(system: System) -> list[tuple[Label, Label]]:
    """Every pair a drawing may join: the links of every mode and each observer's spokes."""
    seen: dict[frozenset[Label], tuple[Label, Label]] = {}
    for mode in (NORMAL_MODE, *[m for m in system.modes if m != NORMAL_MODE]):
        for key in system.edges(mode):
            u, v = sorted(key, key=system.index.__getitem__)
            seen.setdefault(key, (u, v))
    for o in system.observers():
        for a in dict.fromkeys(tuple(o.positions) + tuple(o.velocities)):
            if a != o.center:
                seen.setdefault(frozenset((o.center, a)), (o.center, a))
    return list(seen.values())


def network_layout(system: System, extra: Iterable[tuple[Label, Label]] = ()) -> NetworkLayout:
    """The checked layout of ``system``'s network (module docstring).

    Parameters
    ----------
    system : System
    extra : iterable of (u, v)
        More pairs to route besides the links of every mode and the observers' spokes.

    Returns
    -------
    NetworkLayout
        Positions in node radii; every pair of the drawing is a polyline that keeps
        :data:`CLEARANCE` from every agent it does not join (networks up to
        :data:`ROUTE_MAX_AGENTS` agents).
    """
    G = system.graph(NORMAL_MODE)
    labels = list(system.labels)
    index = {a: k for k, a in enumerate(labels)}
    named: list[tuple[str | None, list[Label]]] = [(c.name, list(c.nodes)) for c in system.clusters]
    covered = {a for _, nodes in named for a in nodes}
    rest = [a for a in labels if a not in covered]
    if rest:
        named.append((None, rest))
    routed = len(labels) <= ROUTE_MAX_AGENTS
    local = [_cluster_layout(G, nodes, routed) for _, nodes in named]
    radii = [float(np.hypot(*L.T).max(initial=0.0)) + CLUSTER_MARGIN for L in local]
    centres = _place_groups(radii)
    members = [[index[a] for a in nodes] for _, nodes in named]
    group_of = np.zeros(len(labels), dtype=int)
    for g, idx in enumerate(members):
        group_of[idx] = g
    pairs = _pairs(system) + [p for p in extra]
    cross = [(index[u], index[v]) for u, v in pairs if group_of[index[u]] != group_of[index[v]]]
    if len(named) > 1:
        local = _orient(local, centres, members, cross, group_of)
    P = np.zeros((len(labels), 2))
    for g, idx in enumerate(members):
        P[idx] = centres[g] + local[g]
    routes: dict[tuple[Label, Label], tuple[Point, ...]] = {}
    blocked: list[tuple[Label, Label]] = []
    if routed and pairs:
        corners, owner = _corners(P)
        unique = list(dict.fromkeys(pairs))
        crossing = {m for m, _, _ in _close_pairs(P, np.array([(index[u], index[v]) for u, v in unique]), CLEARANCE)}
        for m in sorted(crossing):
            u, v = unique[m]
            i, j = index[u], index[v]
            path = _route(P, corners, owner, i, j, local=True) or _route(P, corners, owner, i, j, local=False)
            if path is None:
                blocked.append((u, v))
                continue
            routes[(u, v)] = tuple((float(p[0]), float(p[1])) for p in path)
    positions = {a: (float(P[k, 0]), float(P[k, 1])) for a, k in index.items()}
    groups = tuple((name, tuple(nodes), (float(centres[g][0]), float(centres[g][1])), radii[g]) for g, (name, nodes) in enumerate(named))
    return NetworkLayout(positions, routes, groups, tuple(blocked))
