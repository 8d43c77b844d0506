"""The network drawn on a matplotlib axes: the topology panels of the simulation figures.

The geometry is :func:`~glocal_verify.reporting.layout.network_layout`'s, in data units of
one node radius (every agent is a :class:`matplotlib.patches.Circle` of radius 1 on an axes of
equal aspect), so the drawn links keep the layout's clearance from the agents they do not
join. Colours follow the paper's Figure 2 caption: green nodes are globally monitored agents,
blue nodes local control centres, red-bordered nodes attacked actuators, red-filled nodes agents
moved by the attack, dashed links the switching links. The legend sits below the axes, outside
the drawing. Every agent's circle has the gid ``node:<label>`` and every link's line the gid
``edge:<u>:<v>``, so a test can read the drawn geometry back.
"""

from __future__ import annotations

from typing import Sequence

from matplotlib.axes import Axes
from matplotlib.lines import Line2D
from matplotlib.patches import Circle

from glocal_verify.model import System
from glocal_verify.reporting.layout import network_layout
from glocal_verify.spec.types import NORMAL_MODE, Label

__all__ = ["draw_network"]

GREEN, RED, GREY, ORANGE, CENTRE_FILL, CENTRE_EDGE = "#2e8b57", "#d62728", "#9a9a9a", "#ff7f0e", "#4a90d9", "#1f4e9c"
#: tinted cluster discs (spec order, cycled)
CLUSTER_TINTS = ("#8ecae6", "#ffb703", "#b5e48c", "#cdb4db", "#f4a261", "#90e0ef")


def draw_network(
    ax: Axes,
    system: System,
    mode: str | None,
    attack_moved: Sequence[Label],
    attacked: Sequence[Label],
    title: str,
    *,
    weights: bool | None = None,
) -> None:
    """Draw ``system``'s network with the switching links of ``mode`` on ``ax``.

    Parameters
    ----------
    ax : Axes
    system : System
    mode : str or None
        The mode whose added, removed and reweighted links are drawn (None: the normal mode).
    attack_moved, attacked : sequence of labels
        Agents the attack moves (filled red) and attacked actuators (red border).
    title : str
    weights : bool, optional
        Write each link's weight halfway along it; default: when the links of the drawn mode
        do not all have the same weight.
    """
    lay = network_layout(system)
    drawn = mode or NORMAL_MODE
    normal_edges = system.edges(NORMAL_MODE)
    mode_edges = system.edges(drawn)
    changed = {frozenset((u, v)) for u, v, _ in system.switching_links(drawn)} if drawn != NORMAL_MODE else set()
    removed = {k for k in changed if k in normal_edges and k not in mode_edges}
    added = {k for k in changed if k not in normal_edges}
    show_weights = (len(set(mode_edges.values())) > 1) if weights is None else weights
    for k, (name, _, (cx, cy), rad) in enumerate(lay.groups):
        if name is None:
            continue
        tint = CLUSTER_TINTS[k % len(CLUSTER_TINTS)]
        ax.add_patch(Circle((cx, cy), rad, facecolor=tint, alpha=0.12, edgecolor=tint, lw=1.0, zorder=0))
        ax.text(cx, cy + rad + 0.6, name, ha="center", va="bottom", fontsize=9, fontweight="bold")
    for key in sorted(set(normal_edges) | set(mode_edges), key=lambda e: sorted(system.index[a] for a in e)):
        u, v = sorted(key, key=system.index.__getitem__)
        xs, ys = zip(*lay.route(u, v))
        if key in added:
            colour, ls, lw = ORANGE, "--", 2.0
        elif key in removed:
            colour, ls, lw = GREY, ":", 2.0
        elif key in changed:
            colour, ls, lw = ORANGE, "-.", 2.0
        else:
            colour, ls, lw = GREY, "-", 0.6 + 0.4 * float(mode_edges[key])
        (line,) = ax.plot(xs, ys, color=colour, ls=ls, lw=lw, zorder=1)
        line.set_gid(f"edge:{u}:{v}")
        if show_weights and key in mode_edges:
            mx, my = lay.midpoint(u, v)
            ax.text(mx, my, str(mode_edges[key]), fontsize=5, ha="center", va="center", color="#444444", zorder=2,
                    bbox={"boxstyle": "round,pad=0.1", "fc": "white", "ec": "none", "alpha": 0.8})
    monitored = set(system.monitored)
    centres = {o.center for o in system.observers()}
    moved, att = set(attack_moved), set(attacked)
    for lab, (x, y) in lay.positions.items():
        fill = RED if lab in moved else GREEN if lab in monitored else CENTRE_FILL if lab in centres else "white"
        edge = RED if lab in att else (CENTRE_EDGE if lab in centres else "k")
        lw = 2.2 if lab in att else (1.8 if lab in centres else 0.8)
        disc = Circle((x, y), 1.0, facecolor=fill, edgecolor=edge, lw=lw, zorder=3)
        disc.set_gid(f"node:{lab}")
        ax.add_patch(disc)
        ax.text(x, y, str(lab), ha="center", va="center", fontsize=6, zorder=4)
    lo_x, lo_y, hi_x, hi_y = lay.bounds()
    ax.set_xlim(lo_x - 0.5, hi_x + 0.5)
    ax.set_ylim(lo_y - 0.5, hi_y + 3.0)
    ax.set_aspect("equal")
    handles = [
        Line2D([], [], marker="o", ls="", color=GREEN, mec="k", label="globally monitored"),
        Line2D([], [], marker="o", ls="", color=CENTRE_FILL, mec=CENTRE_EDGE, mew=2, label="local control centre"),
        Line2D([], [], marker="o", ls="", color="white", mec=RED, mew=2.5, label="attacked actuator"),
        Line2D([], [], marker="o", ls="", color=RED, mec="k", label="moved by the attack"),
        Line2D([], [], color=ORANGE, ls="--", lw=2, label="switching link (added)"),
    ]
    if removed:
        handles.append(Line2D([], [], color=GREY, ls=":", lw=2, label="switching link (removed)"))
    if changed - added - removed:
        handles.append(Line2D([], [], color=ORANGE, ls="-.", lw=2, label="switching link (reweighted)"))
    if show_weights:
        handles.append(Line2D([], [], color=GREY, lw=1, label="link (its weight halfway)"))
    ax.legend(handles=handles, fontsize=6, loc="upper center", bbox_to_anchor=(0.5, 0.0), ncol=2, frameon=False)
    ax.set_title(title, fontsize=9)
    ax.set_axis_off()
