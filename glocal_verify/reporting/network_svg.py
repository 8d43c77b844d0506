"""The network of a :class:`~glocal_verify.model.System` drawn as a standalone SVG string.

:func:`network_svg` needs no plotting library: the geometry comes from
:func:`~glocal_verify.reporting.layout.network_layout` (a seeded layout per cluster, clusters
on a circle, links routed around the agents they do not join, so the same system always gives
the same picture and no link passes through an agent) and the SVG is written as text. It shows

- the clusters (one colour each, a tinted disc behind each cluster, its name);
- the globally monitored agents (a green ring; the badge ``x``, ``v`` or ``xv`` says
  whether the position, the velocity or both are measured by the control centre);
- the local observer centres (a blue square) and the agents each measures (thin blue
  spokes; the tooltip lists the measured positions and velocities);
- the attacked actuators of the spec (a thick red outline);
- the given safe mode's switching links: added (dashed orange), removed (dotted red),
  reweighted (dash-dot orange), taken exactly from the spec's ``add``/``remove`` lists;
- the links' weights (optional: shown by default when they are not all equal);
- a legend, below the drawing (it never covers it).

Every link and every spoke is a ``<polyline>`` (two points when straight).

Every label and name is XML-escaped, so the string is safe to inline into an HTML page.
"""

from __future__ import annotations

from html import escape

from glocal_verify.model import System
from glocal_verify.reporting.layout import network_layout
from glocal_verify.words import counted
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
    msg = f"{system.name}: {counted(system.n, 'agent')}, too many to draw (at most {MAX_DRAWN_AGENTS})"
    return (
        f'<svg xmlns="http://www.w3.org/2000/svg" class="network" viewBox="0 0 {WIDTH} 40" width="{WIDTH}" height="40" '
        f'role="img" aria-label="{_attr(msg)}"><text x="10" y="24" font-family="sans-serif" font-size="13">{escape(msg)}</text></svg>'
    )


def _points(pts: list[tuple[float, float]]) -> str:
    return " ".join(f"{_fmt(x)},{_fmt(y)}" for x, y in pts)


def network_svg(system: System, mode: str = NORMAL_MODE, *, attack: bool = True, weights: bool | None = None) -> str:
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
    weights : bool, optional
        Write each link's weight (exact, as in the spec) halfway along it; default: when
        the links of the drawn mode do not all have the same weight.

    Returns
    -------
    str
        A standalone ``<svg>`` element (inline CSS, no external resources); node positions
        and link routes come from :func:`~glocal_verify.reporting.layout.network_layout`, so
        the output is deterministic and no link passes through an agent it does not join.
        Networks with more than :data:`MAX_DRAWN_AGENTS` agents get a one-line note instead
        of a drawing.

    Raises
    ------
    ModelError
        For an unknown mode.
    """
    system.check_mode(mode)
    if system.n > MAX_DRAWN_AGENTS:
        return _too_large(system)
    lay = network_layout(system)
    lo_x, lo_y, hi_x, hi_y = lay.bounds()
    top = 18.0  # room for the cluster names above their discs
    # one layout unit is one node radius: r pixels
    r = max(1.5, min(13.0, (WIDTH - 20) / max(hi_x - lo_x, 1e-9)))
    off_x = (WIDTH - (hi_x - lo_x) * r) / 2
    height_draw = (hi_y - lo_y) * r + top + 10

    def xy(p: tuple[float, float]) -> tuple[float, float]:
        return (off_x + (p[0] - lo_x) * r, top + (hi_y - p[1]) * r)

    def at(lab: Label) -> tuple[float, float]:
        return xy(lay.positions[lab])

    def route(u: Label, v: Label) -> list[tuple[float, float]]:
        return [xy(p) for p in lay.route(u, v)]

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
    show_weights = (len(set(current.values())) > 1) if weights is None else weights

    parts: list[str] = []
    # cluster discs
    for k, c in enumerate(system.clusters):
        name, _, centre, radius = lay.groups[k]
        cx, cy = xy(centre)
        rad = radius * r
        colour = CLUSTER_COLOURS[k % len(CLUSTER_COLOURS)]
        parts.append(
            f'<g class="cluster" data-cluster="{_attr(c.name)}"><title>cluster {escape(c.name)}: {escape(counted(len(c.nodes), "agent"))}</title>'
            f'<circle cx="{_fmt(cx)}" cy="{_fmt(cy)}" r="{_fmt(rad)}" fill="{colour}" fill-opacity="0.15" stroke="{colour}" stroke-width="1.5"/>'
            f'<text x="{_fmt(cx)}" y="{_fmt(cy - rad - 4)}" text-anchor="middle" font-weight="bold">{escape(c.name)}</text></g>'
        )
    # edges of the normal graph and of the mode
    labels: list[str] = []
    for key in sorted(set(normal) | set(current), key=lambda k: sorted(system.index[a] for a in k)):
        u, v = sorted(key, key=system.index.__getitem__)
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
            f'<polyline class="{cls}" data-ends="{_attr(u)} {_attr(v)}" points="{_points(route(u, v))}" fill="none" stroke="{colour}" '
            f'stroke-width="{width:.1f}"{style}><title>{escape(str(u))} - {escape(str(v))}: {escape(what)}</title></polyline>'
        )
        if show_weights and key in current:
            mx, my = xy(lay.midpoint(u, v))
            text = escape(str(current[key]))
            labels.append(
                f'<text class="weight" x="{_fmt(mx)}" y="{_fmt(my + 3)}" text-anchor="middle" font-size="9" fill="#444444" '
                f'stroke="#ffffff" stroke-width="3" paint-order="stroke">{text}</text>'
            )
    # what each local observer measures
    for o in observers:
        measured = [a for a in dict.fromkeys(tuple(o.positions) + tuple(o.velocities)) if a != o.center]
        tip = f"observer {o.center} of {o.cluster}: positions {list(o.positions)}, velocities {list(o.velocities)}"
        spokes = "".join(
            f'<polyline class="spoke" data-ends="{_attr(o.center)} {_attr(a)}" points="{_points(route(o.center, a))}" fill="none" stroke="{BLUE}" '
            f'stroke-width="1.3" stroke-opacity="0.6" stroke-dasharray="2 2"/>'
            for a in measured
        )
        parts.append(f'<g class="measures" data-observer="{_attr(o.center)}"><title>{escape(tip)}</title>{spokes}</g>')
    parts.extend(labels)
    # agents
    for lab in system.labels:
        x, y = at(lab)
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
            g.append(f'<circle class="monitor" cx="{_fmt(x)}" cy="{_fmt(y)}" r="{_fmt(1.35 * r)}" fill="none" stroke="{GREEN}" stroke-width="2.5"/>')
        if lab in centres:
            s = 0.95 * r
            g.append(f'<rect class="centre" x="{_fmt(x - s)}" y="{_fmt(y - s)}" width="{_fmt(2 * s)}" height="{_fmt(2 * s)}" fill="{fill}" stroke="{BLUE}" stroke-width="2.5"/>')
        else:
            stroke, sw = (RED, 3.5) if lab in attacked else ("#333333", 1.0)
            g.append(f'<circle class="node" cx="{_fmt(x)}" cy="{_fmt(y)}" r="{_fmt(r)}" fill="{fill}" stroke="{stroke}" stroke-width="{sw}"/>')
        if lab in centres and lab in attacked:
            g.append(f'<circle class="node" cx="{_fmt(x)}" cy="{_fmt(y)}" r="{_fmt(r - 1)}" fill="none" stroke="{RED}" stroke-width="3.5"/>')
        if show_labels:
            g.append(f'<text x="{_fmt(x)}" y="{_fmt(y + 3.5)}" text-anchor="middle" font-size="{max(7, int(r * 0.85))}">{escape(str(lab))}</text>')
        if badge:
            g.append(f'<text class="badge" x="{_fmt(x + 1.35 * r + 2)}" y="{_fmt(y - 1.35 * r)}" fill="{GREEN}" font-size="10" font-weight="bold">{badge}</text>')
        g.append("</g>")
        parts.append("".join(g))

    entries: list[tuple[str, str]] = []
    for k, c in enumerate(system.clusters[:10]):
        entries.append((f'<circle r="6" fill="{CLUSTER_COLOURS[k % len(CLUSTER_COLOURS)]}" stroke="#333333"/>', f"cluster {c.name} ({counted(len(c.nodes), 'agent')})"))
    if len(system.clusters) > 10:
        entries.append(("", f"... and {counted(len(system.clusters) - 10, 'more cluster')}"))
    entries.append((f'<circle r="9" fill="none" stroke="{GREEN}" stroke-width="2.5"/>', "globally monitored (badge x: position, v: velocity)"))
    entries.append((f'<rect x="-6" y="-6" width="12" height="12" fill="#ffffff" stroke="{BLUE}" stroke-width="2.5"/>', "local observer centre"))
    entries.append((f'<line x1="-8" y1="0" x2="8" y2="0" stroke="{BLUE}" stroke-width="1.3" stroke-dasharray="2 2"/>', "measured by a local observer"))
    if attacked:
        entries.append((f'<circle r="6" fill="#ffffff" stroke="{RED}" stroke-width="3.5"/>', "attacked actuator"))
    entries.append((f'<line x1="-8" y1="0" x2="8" y2="0" stroke="{GREY}" stroke-width="2"/>', "link of the normal graph" + (" (its weight halfway)" if show_weights else "")))
    if added:
        entries.append((f'<line x1="-8" y1="0" x2="8" y2="0" stroke="{ORANGE}" stroke-width="2.5" stroke-dasharray="7 4"/>', f"link added by {mode}"))
    if removed:
        entries.append((f'<line x1="-8" y1="0" x2="8" y2="0" stroke="{RED}" stroke-width="2.5" stroke-dasharray="2 4"/>', f"link removed by {mode}"))
    if reweighted:
        entries.append((f'<line x1="-8" y1="0" x2="8" y2="0" stroke="{ORANGE}" stroke-width="2.5" stroke-dasharray="8 3 2 3"/>', f"link reweighted by {mode}"))
    legend_h = 30 + ((len(entries) + 1) // 2) * LEGEND_ROW
    height = height_draw + legend_h
    title = f"{system.name}, mode {mode}: {counted(system.n, 'agent')}, {counted(len(current), 'link')}"
    head = (
        f'<svg xmlns="http://www.w3.org/2000/svg" class="network" viewBox="0 0 {WIDTH} {_fmt(height)}" width="{WIDTH}" '
        f'height="{_fmt(height)}" role="img" aria-label="{_attr(title)}" font-family="sans-serif" font-size="11">'
        f"<title>{escape(title)}</title>"
        f'<rect x="0" y="0" width="{WIDTH}" height="{_fmt(height)}" fill="#ffffff"/>'
    )
    return head + "".join(parts) + "".join(_legend(entries, height_draw + 8)) + "</svg>"
