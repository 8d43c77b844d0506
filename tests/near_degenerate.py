"""Hypothesis strategies for nearly degenerate networks, built on purpose to sit close to the
boundaries of the global conditions.

Symmetric graphs (cycles, complete graphs, stars, paths, twin agents) have repeated eigenvalues
and eigenvectors with equal entries; a perturbation of relative size 10^-k (k = 6..14) moves
them off the boundary by less than a modelling tolerance but by far more than the rounding
error, so a numeric verdict must either match exact arithmetic or say ``undecided``. Weights are
exact rationals written as strings (``"1000000001/1000000000"``), so the spec is exactly the
system meant. Weight spreads reach a factor 10^12 (the widest the loader accepts); safe modes change one
weight by 10^-15 relative, add links of weight 1e-11, or remove and add links (signed dL).
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any

import networkx as nx
from hypothesis import strategies as st

from glocal_verify import System, spec_from_dict

__all__ = ["base_graphs", "near_degenerate_specs", "near_degenerate_systems", "rational"]


def rational(q: Fraction) -> str:
    """A weight as an exact rational string for the spec."""
    return f"{q.numerator}/{q.denominator}"


@st.composite
def base_graphs(draw: st.DrawFn) -> tuple[int, dict[tuple[int, int], Fraction]]:
    """A symmetric graph on labels 1..N (N <= 7) with unit weights."""
    kind = draw(st.sampled_from(["cycle", "complete", "star", "path", "twins"]))
    n = draw(st.integers(3, 7))
    if kind == "cycle":
        G = nx.cycle_graph(n)
    elif kind == "complete":
        G = nx.complete_graph(min(n, 5))
    elif kind == "star":
        G = nx.star_graph(n - 1)
    elif kind == "path":
        G = nx.path_graph(n)
    else:  # twin agents 0 and 1: the same neighbours (2, and 3 when n > 4), not adjacent
        G = nx.path_graph(range(2, n))
        for t in (0, 1):
            G.add_edge(t, 2)
            if n > 4:
                G.add_edge(t, 3)
    G = nx.convert_node_labels_to_integers(G, first_label=1)
    edges = {(min(u, v), max(u, v)): Fraction(1) for u, v in G.edges}
    return G.number_of_nodes(), edges


@st.composite
def near_degenerate_specs(draw: st.DrawFn) -> dict[str, Any]:
    """A spec mapping: a perturbed symmetric graph, monitors, one or two near-degenerate safe modes."""
    n, edges = draw(base_graphs())
    keys = sorted(edges)
    # perturbations of relative size 10^-k and weight spreads
    for _ in range(draw(st.integers(0, 2))):
        e = draw(st.sampled_from(keys))
        k = draw(st.integers(6, 14))
        edges[e] = edges[e] * (1 + Fraction(draw(st.sampled_from([1, -1, 3])), 10**k))
    spread = draw(st.integers(0, 3)) == 0
    if spread:  # the loader's documented domain: weights within a factor 1e12 of each other
        e = draw(st.sampled_from(keys))
        p = draw(st.sampled_from([-6, 6]))
        edges[e] = edges[e] * Fraction(10) ** p
    labels = list(range(1, n + 1))
    mv = draw(st.lists(st.sampled_from(labels), unique=True, min_size=1, max_size=max(1, n // 2)))
    mx = draw(st.lists(st.sampled_from(labels), unique=True, max_size=1)) if draw(st.integers(0, 2)) == 0 else []
    modes = []
    for m in range(draw(st.integers(1, 2))):
        kind = draw(st.sampled_from(["reweight", "tiny", "signed", "eps-change"]))
        add: list[list[Any]] = []
        remove: list[list[int]] = []
        absent = [(u, v) for u in labels for v in labels if u < v and (u, v) not in edges]
        if kind in ("reweight", "eps-change") or not absent:
            e = draw(st.sampled_from(keys))
            rel = Fraction(1, 10**15) if kind == "eps-change" else Fraction(1, 10 ** draw(st.integers(6, 14)))
            remove.append(list(e))
            add.append([e[0], e[1], rational(edges[e] * (1 + rel))])
        elif kind == "tiny":
            for e in draw(st.lists(st.sampled_from(absent), unique=True, min_size=1, max_size=2)):
                add.append([e[0], e[1], "1e-6" if spread else "1e-11"])
        else:  # signed: one link removed, one added
            e = draw(st.sampled_from(keys))
            f = draw(st.sampled_from(absent))
            remove.append(list(e))
            add.append([f[0], f[1], rational(edges[e] * (1 + Fraction(1, 10 ** draw(st.integers(6, 14)))))])
        modes.append({"name": f"m{m + 1}", "add": add, "remove": remove})
    data: dict[str, Any] = {
        "format": 1,
        "name": "near-degenerate",
        "graph": {"nodes": n, "edges": [[u, v, rational(w)] for (u, v), w in sorted(edges.items())]},
        "monitor": {"positions": mx, "velocities": mv},
        "modes": modes,
    }
    if draw(st.booleans()):
        data["switching"] = {"mode": modes[0]["name"], "time": 1.0}
        data["simulation"] = {"horizon": 2.5}
    return data


@st.composite
def near_degenerate_systems(draw: st.DrawFn) -> System:
    """A :class:`System` from :func:`near_degenerate_specs`."""
    return System(spec_from_dict(draw(near_degenerate_specs())))
