"""Hypothesis strategies for nearly degenerate *attacked* networks: near the boundaries of the
attack conditions (stealthy.zda, stealthy.covert, switching.avoids-attack) and of the local
conditions (local.rank, local.pencil, local.uio).

* near-twin agents: two agents with the same neighbours whose weights differ by a relative
  10^-k (k = 6..14); with both attacked (or their neighbourhood monitored) the exact twins give a
  ZDA at every lambda0 (xi = e_a - e_b), the perturbed ones in general do not;
* symmetric graphs (cycle, path, star, complete) with one or two weights perturbed by 10^-k;
* weight spreads up to 10^+-11 around unit weights (the loader accepts weights in
  [1e-12, 1e12] within a factor 1e12 of each other);
* attacks on 1-2 agents, an exact rational lambda0 or none, one safe mode (a reweighted link or
  a link of weight 10^-11), two clusters with one observer each.

Weights are exact rationals written as strings, so the spec is exactly the system meant.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any

import networkx as nx
from hypothesis import strategies as st

from glocal_verify import System, spec_from_dict

__all__ = ["attacked_near_degenerate_specs", "near_twin_spec", "rational", "system_of"]


def rational(q: Fraction) -> str:
    """A weight as an exact rational string for the spec."""
    return f"{q.numerator}/{q.denominator}"


def near_twin_spec(
    k: int, *, actuators: tuple[int, ...] = (1,), velocities: tuple[int, ...] = (1, 5), lambda0: str | None = None
) -> dict[str, Any]:
    """Agents 1 and 2 are near twins (neighbours 3 and 4; weight 2-4 is 1 + 10^-k) next to a
    path 3-5, 4-5, 5-6; the attacker drives ``actuators``, the velocities of ``velocities`` are
    monitored. With the defaults (F = {1}, M_v = {1, 5}) the numeric deflation used to report a
    ZDA (k >= 8) where exact arithmetic has none; with M_v = {6} it reported none where one exists."""
    eps = Fraction(1, 10**k)
    edges = [[1, 3, "1"], [1, 4, "1"], [2, 3, "1"], [2, 4, rational(1 + eps)], [3, 5, "1"], [4, 5, "1"], [5, 6, "1"]]
    attack: dict[str, Any] = {"kind": "zda", "actuators": list(actuators)}
    if lambda0 is not None:
        attack["lambda0"] = float(Fraction(lambda0))
    return {
        "format": 1,
        "name": f"near-twins-1e-{k}",
        "graph": {"nodes": 6, "edges": edges},
        "clusters": [
            {"name": "A", "nodes": [1, 2, 3], "observers": [{"center": 3}]},
            {"name": "B", "nodes": [4, 5, 6], "observers": [{"center": 5}]},
        ],
        "monitor": {"positions": [], "velocities": list(velocities)},
        "attack": attack,
        "modes": [{"name": "safe", "add": [[1, 2, "1"]], "remove": []}],
    }


def _base(kind: str, n: int) -> nx.Graph:
    if kind == "cycle":
        return nx.cycle_graph(n)
    if kind == "path":
        return nx.path_graph(n)
    if kind == "star":
        return nx.star_graph(n - 1)
    if kind == "complete":
        return nx.complete_graph(min(n, 5))
    # near twins 0 and 1 on a path 2..n-1 (same neighbours 2 and 3)
    G = nx.path_graph(range(2, n))
    for t in (0, 1):
        G.add_edge(t, 2)
        G.add_edge(t, 3)
    return G


@st.composite
def attacked_near_degenerate_specs(draw: st.DrawFn) -> dict[str, Any]:
    """A spec mapping: perturbed symmetric graph or near twins (N <= 7), monitors, an attack on
    1-2 agents, two clusters with an observer each, one safe mode."""
    kind = draw(st.sampled_from(["twins", "twins", "cycle", "path", "star", "complete"]))
    n = draw(st.integers(5, 7)) if kind == "twins" else draw(st.integers(4, 7))
    base = _base(kind, n)
    G = nx.relabel_nodes(base, {v: int(v) + 1 for v in base.nodes})
    n = G.number_of_nodes()
    edges = {(min(u, v), max(u, v)): Fraction(1) for u, v in G.edges}
    keys = sorted(edges)
    if kind == "twins":  # break the twin symmetry of agents 1, 2 by 10^-k
        k = draw(st.integers(6, 14))
        e = draw(st.sampled_from([(2, 3), (2, 4)]))
        edges[e] = edges[e] * (1 + Fraction(draw(st.sampled_from([1, -1, 3])), 10**k))
    for _ in range(draw(st.integers(0 if kind == "twins" else 1, 2))):
        e = draw(st.sampled_from(keys))
        edges[e] = edges[e] * (1 + Fraction(draw(st.sampled_from([1, -1, 3])), 10 ** draw(st.integers(6, 14))))
    spread = draw(st.integers(0, 3)) == 0
    if spread:
        e = draw(st.sampled_from(keys))
        edges[e] = edges[e] * Fraction(10) ** draw(st.sampled_from([-11, -6, 6, 11]))
    labels = list(range(1, n + 1))
    F = draw(st.lists(st.sampled_from([1, 2] if kind == "twins" else labels), unique=True, min_size=1, max_size=2))
    mv = draw(st.lists(st.sampled_from(labels), unique=True, min_size=1, max_size=max(1, n // 2)))
    mx = draw(st.lists(st.sampled_from(labels), unique=True, max_size=1)) if draw(st.integers(0, 2)) == 0 else []
    attack: dict[str, Any] = {"kind": "zda", "actuators": F}
    lam = draw(st.sampled_from([None, "1/2", "0", "-1", "2"]))
    if lam is not None:
        attack["lambda0"] = float(Fraction(lam))
    cut = draw(st.integers(2, n - 2))
    clusters = [
        {"name": "P1", "nodes": labels[:cut], "observers": [{"center": draw(st.sampled_from(labels[:cut]))}]},
        {"name": "P2", "nodes": labels[cut:], "observers": [{"center": draw(st.sampled_from(labels[cut:]))}]},
    ]
    absent = [(u, v) for u in labels for v in labels if u < v and (u, v) not in edges]
    if absent and draw(st.booleans()):
        f = draw(st.sampled_from(absent))
        mode = {"name": "safe", "add": [[f[0], f[1], "1" if spread else draw(st.sampled_from(["1", "1e-11"]))]], "remove": []}
    else:
        e = draw(st.sampled_from(keys))
        rel = Fraction(1, 10 ** draw(st.integers(6, 14)))
        mode = {"name": "safe", "add": [[e[0], e[1], rational(edges[e] * (1 + rel))]], "remove": [list(e)]}
    return {
        "format": 1,
        "name": f"near-degenerate-attack-{kind}",
        "graph": {"nodes": n, "edges": [[u, v, rational(w)] for (u, v), w in sorted(edges.items())]},
        "clusters": clusters,
        "monitor": {"positions": mx, "velocities": mv},
        "attack": attack,
        "modes": [mode],
    }


def system_of(data: dict[str, Any]) -> System:
    """The :class:`System` of a spec mapping."""
    return System(spec_from_dict(data))
