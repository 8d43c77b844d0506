"""The network of a :class:`~glocal_verify.model.System` drawn as a standalone SVG string.

:func:`network_svg` needs no plotting library: the layout comes from networkx (a seeded
spring layout per cluster, clusters placed on a circle, so the same system always gives the
same picture) and the SVG is written as text. It shows

- the clusters (one colour each, a tinted disc behind each cluster, its name);
- the globally monitored agents (a green ring; the badge ``x``, ``v`` or ``xv`` says
  whether the position, the velocity or both are measured by the control centre);
- the local observer centres (a blue square) and the agents each measures (thin blue
  spokes; the tooltip lists the measured positions and velocities);
- the attacked actuators of the spec (a thick red outline);
- the given safe mode's switching links: added (dashed orange), removed (dotted red),
  reweighted (dash-dot orange), taken exactly from the spec's ``add``/``remove`` lists;
- a legend.

Every label and name is XML-escaped, so the string is safe to inline into an HTML page.
"""

from __future__ import annotations

import math
from html import escape

import networkx as nx
import numpy as np

from glocal_verify.model import System
from glocal_verify.spec.types import NORMAL_MODE, Label

__all__ = [
    "MAX_DRAWN_AGENTS",
    "CLUSTER_COLOURS",
    "network_svg",
]

#: above this many agents the drawing is replaced by a note (a picture would be unreadable)
MAX_DRAWN_AGENTS = 1500

#: fill colours of the clusters, in spec order (cycled)
CLUSTER_COLOURS = ("#8ecae6", "#ffb703", "#b5e48c", "#cdb4db", "#f4a261", "#90e0ef", "#e9c46a", "#ffafcc", "#a3b18a", "#bde0fe")

GREEN = "#2a9d3a"
BLUE = "#1f4e9c"
RED = "#d62828"
ORANGE = "#f77f00"
GREY = "#9a9a9a"
WIDTH = 760
LEGEND_ROW = 18


def _layout(system: System) -> dict[Label, tuple[float, float]]:
    """Clusters on a circle, each laid out by a seeded spring layout (seed 1) around its spot."""
    G = system.graph(NORMAL_MODE)
    if not system.clusters:
        raw = nx.spring_layout(G, seed=1, weight=None) if G.number_of_nodes() > 1 else {n: np.zeros(2) for n in G.nodes}
        return {k: (float(v[0]), float(v[1])) for k, v in raw.items()}
    pos: dict[Label, tuple[float, float]] = {}
    kc = len(system.clusters)
    for j, c in enumerate(system.clusters):
        sub = G.subgraph(c.nodes)
        size = 0.35 * math.sqrt(len(c.nodes)) + 0.3
        inner = nx.spring_layout(sub, seed=1, weight=None, scale=size) if len(c.nodes) > 1 else {c.nodes[0]: np.zeros(2)}
        ang = 2 * math.pi * j / kc + math.pi / 2
        radius = 1.2 * size * kc / math.pi + 1.5 if kc > 1 else 0.0
        cx, cy = radius * math.cos(ang), radius * math.sin(ang)
        for lab, p in inner.items():
            pos[lab] = (cx + float(p[0]), cy + float(p[1]))
    return pos


def _attr(x: object) -> str:
    return escape(str(x), quote=True)


def _fmt(x: float) -> str:
    return f"{x:.1f}"


def _legend(entries: list[tuple[str, str]], y0: float) -> list[str]:
    """Two-column legend; each entry is (glyph SVG at the origin, text)."""
    out = [f'<g class="legend" transform="translate(20,{_fmt(y0)})">', '<text x="0" y="0" font-weight="bold">Legend</text>']
    col_w = (WIDTH - 40) / 2
    for k, (glyph, text) in enumerate(entries):
        x = (k % 2) * col_w
        y = 16 + (k // 2) * LEGEND_ROW
        out.append(f'<g transform="translate({_fmt(x + 10)},{_fmt(y)})">{glyph}<text x="16" y="4">{escape(text)}</text></g>')
    out.append("</g>")
    return out


def _too_large(system: System) -> str:
    msg = f"{system.name}: {system.n} agents, too many to draw (at most {MAX_DRAWN_AGENTS})"
    return (
        f'<svg xmlns="http://www.w3.org/2000/svg" class="network" viewBox="0 0 {WIDTH} 40" width="{WIDTH}" height="40" '
        f'role="img" aria-label="{_attr(msg)}"><text x="10" y="24" font-family="sans-serif" font-size="13">{escape(msg)}</text></svg>'
    )


def network_svg(system: System, mode: str = NORMAL_MODE, *, attack: bool = True) -> str:
    """Draw ``system``'s network with the switching links of ``mode`` as an SVG document.

    Parameters
    ----------
    system : System
        The system to draw.
    mode : str
        The safe mode whose added, removed and reweighted links are drawn (``"normal"``:
        none). The links are :meth:`System.switching_links` of the mode, i.e. the nonzero
        entries of :math:`\\Delta L_q = L_q - L_1` computed from the spec's exact rationals.
    attack : bool
        Outline the spec's attacked actuators in red (when the spec has an attack).

    Returns
    -------
    str
        A standalone ``<svg>`` element (inline CSS, no external resources); node positions
        come from a seeded layout, so the output is deterministic. Networks with more than
        :data:`MAX_DRAWN_AGENTS` agents get a one-line note instead of a drawing.

    Raises
    ------
    ModelError
        For an unknown mode.
    """
    system.check_mode(mode)
    if system.n > MAX_DRAWN_AGENTS:
        return _too_large(system)
    pos = _layout(system)
    xs = [p[0] for p in pos.values()]
    ys = [p[1] for p in pos.values()]
    span = max(max(xs) - min(xs), max(ys) - min(ys), 1e-9)
    r = max(4.0, min(13.0, 200.0 / math.sqrt(max(system.n, 1))))
    margin = 3 * r + 24
    scale = (WIDTH - 2 * margin) / span
    x0, y1 = min(xs), max(ys)

    pix = {lab: (margin + (px - x0) * scale, margin + (y1 - py) * scale) for lab, (px, py) in pos.items()}
    discs: list[tuple[float, float, float]] = []
    for c in system.clusters:
        pts = np.array([pix[a] for a in c.nodes])
        cx, cy = pts.mean(axis=0)
        discs.append((float(cx), float(cy), float(np.max(np.hypot(pts[:, 0] - cx, pts[:, 1] - cy))) + 2.2 * r))
    # fit nodes, discs and the cluster names into the width
    lo_x = min([p[0] - r - 8 for p in pix.values()] + [d[0] - d[2] for d in discs])
    hi_x = max([p[0] + r + 16 for p in pix.values()] + [d[0] + d[2] for d in discs])
    lo_y = min([p[1] - r - 16 for p in pix.values()] + [d[1] - d[2] - 18 for d in discs])
    hi_y = max([p[1] + r + 8 for p in pix.values()] + [d[1] + d[2] for d in discs])
    fit = min(1.0, (WIDTH - 20) / max(hi_x - lo_x, 1e-9))
    off_x = (WIDTH - (hi_x - lo_x) * fit) / 2
    height_draw = (hi_y - lo_y) * fit + 20
    final = {lab: (off_x + (px - lo_x) * fit, 10 + (py - lo_y) * fit) for lab, (px, py) in pix.items()}
    discs = [(off_x + (cx - lo_x) * fit, 10 + (cy - lo_y) * fit, rad * fit) for cx, cy, rad in discs]

    def xy(lab: Label) -> tuple[float, float]:
        return final[lab]

    cluster_of: dict[Label, int] = {}
    for k, c in enumerate(system.clusters):
        for a in c.nodes:
            cluster_of[a] = k
    normal = system.edges(NORMAL_MODE)
    current = system.edges(mode)
    changed = {frozenset((u, v)): d for u, v, d in system.switching_links(mode)} if mode != NORMAL_MODE else {}
    added = {k for k in changed if k not in normal}
    removed = {k for k in changed if k not in current}
    reweighted = set(changed) - added - removed
    monitored_x = set(system.monitored_positions)
    monitored_v = set(system.monitored_velocities)
    observers = system.observers()
    centres = {o.center for o in observers}
    attacked = set(system.attacked) if attack else set()
    show_labels = system.n <= 200

    parts: list[str] = []
    # cluster discs
    for k, c in enumerate(system.clusters):
        cx, cy, rad = discs[k]
        colour = CLUSTER_COLOURS[k % len(CLUSTER_COLOURS)]
        parts.append(
            f'<g class="cluster" data-cluster="{_attr(c.name)}"><title>cluster {escape(c.name)}: {len(c.nodes)} agents</title>'
            f'<circle cx="{_fmt(cx)}" cy="{_fmt(cy)}" r="{_fmt(rad)}" fill="{colour}" fill-opacity="0.15" stroke="{colour}" stroke-width="1.5"/>'
            f'<text x="{_fmt(cx)}" y="{_fmt(cy - rad - 4)}" text-anchor="middle" font-weight="bold">{escape(c.name)}</text></g>'
        )
    # edges of the normal graph and of the mode
    for key in sorted(set(normal) | set(current), key=lambda k: sorted(system.index[a] for a in k)):
        u, v = sorted(key, key=system.index.__getitem__)
        (ax, ay), (bx, by) = xy(u), xy(v)
        if key in added:
            style, cls, colour, width = ' stroke-dasharray="7 4"', "edge added", ORANGE, 2.5
            what = f"added by {mode} (weight {current[key]})"
        elif key in removed:
            style, cls, colour, width = ' stroke-dasharray="2 4"', "edge removed", RED, 2.5
            what = f"removed by {mode} (weight {normal[key]})"
        elif key in reweighted:
            style, cls, colour, width = ' stroke-dasharray="8 3 2 3"', "edge reweighted", ORANGE, 2.5
            what = f"reweighted by {mode}: {normal[key]} -> {current[key]}"
        else:
            w = float(current[key])
            style, cls, colour, width = "", "edge", GREY, 0.8 + 0.5 * min(w, 4.0)
            what = f"weight {current[key]}"
        parts.append(
            f'<line class="{cls}" x1="{_fmt(ax)}" y1="{_fmt(ay)}" x2="{_fmt(bx)}" y2="{_fmt(by)}" stroke="{colour}" '
            f'stroke-width="{width:.1f}"{style}><title>{escape(str(u))} - {escape(str(v))}: {escape(what)}</title></line>'
        )
    # what each local observer measures
    for o in observers:
        cx, cy = xy(o.center)
        measured = [a for a in dict.fromkeys(tuple(o.positions) + tuple(o.velocities)) if a != o.center]
        tip = f"observer {o.center} of {o.cluster}: positions {list(o.positions)}, velocities {list(o.velocities)}"
        spokes = "".join(
            f'<line x1="{_fmt(cx)}" y1="{_fmt(cy)}" x2="{_fmt(xy(a)[0])}" y2="{_fmt(xy(a)[1])}" stroke="{BLUE}" stroke-width="1.3" stroke-opacity="0.6" stroke-dasharray="2 2"/>'
            for a in measured
        )
        parts.append(f'<g class="measures" data-observer="{_attr(o.center)}"><title>{escape(tip)}</title>{spokes}</g>')
    # agents
    for lab in system.labels:
        x, y = xy(lab)
        ck = cluster_of.get(lab)
        fill = CLUSTER_COLOURS[ck % len(CLUSTER_COLOURS)] if ck is not None else "#ffffff"
        info = [f"agent {lab}"]
        if ck is not None:
            info.append(f"cluster {system.clusters[ck].name}")
        badge = ("x" if lab in monitored_x else "") + ("v" if lab in monitored_v else "")
        if badge:
            info.append(f"globally monitored ({'position' if badge == 'x' else 'velocity' if badge == 'v' else 'position and velocity'})")
        if lab in centres:
            info.append("local observer centre")
        if lab in attacked:
            info.append("attacked actuator")
        g = [f'<g class="agent" data-label="{_attr(lab)}"><title>{escape(", ".join(info))}</title>']
        if badge:
            g.append(f'<circle class="monitor" cx="{_fmt(x)}" cy="{_fmt(y)}" r="{_fmt(r + 4)}" fill="none" stroke="{GREEN}" stroke-width="2.5"/>')
        if lab in centres:
            s = r + 1.5
            g.append(f'<rect class="centre" x="{_fmt(x - s)}" y="{_fmt(y - s)}" width="{_fmt(2 * s)}" height="{_fmt(2 * s)}" fill="{fill}" stroke="{BLUE}" stroke-width="2.5"/>')
        else:
            stroke, sw = (RED, 3.5) if lab in attacked else ("#333333", 1.0)
            g.append(f'<circle class="node" cx="{_fmt(x)}" cy="{_fmt(y)}" r="{_fmt(r)}" fill="{fill}" stroke="{stroke}" stroke-width="{sw}"/>')
        if lab in centres and lab in attacked:
            g.append(f'<circle class="node" cx="{_fmt(x)}" cy="{_fmt(y)}" r="{_fmt(r - 1)}" fill="none" stroke="{RED}" stroke-width="3.5"/>')
        if show_labels:
            g.append(f'<text x="{_fmt(x)}" y="{_fmt(y + 3.5)}" text-anchor="middle" font-size="{max(7, int(r * 0.85))}">{escape(str(lab))}</text>')
        if badge:
            g.append(f'<text class="badge" x="{_fmt(x + r + 3)}" y="{_fmt(y - r - 2)}" fill="{GREEN}" font-size="10" font-weight="bold">{badge}</text>')
        g.append("</g>")
        parts.append("".join(g))

    entries: list[tuple[str, str]] = []
    for k, c in enumerate(system.clusters[:10]):
        entries.append((f'<circle r="6" fill="{CLUSTER_COLOURS[k % len(CLUSTER_COLOURS)]}" stroke="#333333"/>', f"cluster {c.name} ({len(c.nodes)} agents)"))
    if len(system.clusters) > 10:
        entries.append(("", f"... and {len(system.clusters) - 10} more clusters"))
    entries.append((f'<circle r="9" fill="none" stroke="{GREEN}" stroke-width="2.5"/>', "globally monitored (badge x: position, v: velocity)"))
    entries.append((f'<rect x="-6" y="-6" width="12" height="12" fill="#ffffff" stroke="{BLUE}" stroke-width="2.5"/>', "local observer centre"))
    entries.append((f'<line x1="-8" y1="0" x2="8" y2="0" stroke="{BLUE}" stroke-width="1.3" stroke-dasharray="2 2"/>', "measured by a local observer"))
    if attacked:
        entries.append((f'<circle r="6" fill="#ffffff" stroke="{RED}" stroke-width="3.5"/>', "attacked actuator"))
    entries.append((f'<line x1="-8" y1="0" x2="8" y2="0" stroke="{GREY}" stroke-width="2"/>', "link of the normal graph"))
    if added:
        entries.append((f'<line x1="-8" y1="0" x2="8" y2="0" stroke="{ORANGE}" stroke-width="2.5" stroke-dasharray="7 4"/>', f"link added by {mode}"))
    if removed:
        entries.append((f'<line x1="-8" y1="0" x2="8" y2="0" stroke="{RED}" stroke-width="2.5" stroke-dasharray="2 4"/>', f"link removed by {mode}"))
    if reweighted:
        entries.append((f'<line x1="-8" y1="0" x2="8" y2="0" stroke="{ORANGE}" stroke-width="2.5" stroke-dasharray="8 3 2 3"/>', f"link reweighted by {mode}"))
    legend_h = 30 + ((len(entries) + 1) // 2) * LEGEND_ROW
    height = height_draw + legend_h
    title = f"{system.name}, mode {mode}: {system.n} agents, {len(current)} links"
    head = (
        f'<svg xmlns="http://www.w3.org/2000/svg" class="network" viewBox="0 0 {WIDTH} {_fmt(height)}" width="{WIDTH}" '
        f'height="{_fmt(height)}" role="img" aria-label="{_attr(title)}" font-family="sans-serif" font-size="11">'
        f"<title>{escape(title)}</title>"
        f'<rect x="0" y="0" width="{WIDTH}" height="{_fmt(height)}" fill="#ffffff"/>'
    )
    return head + "".join(parts) + "".join(_legend(entries, height_draw + 8)) + "</svg>"
