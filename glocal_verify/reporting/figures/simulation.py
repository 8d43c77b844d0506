"""Figures like the paper's Figure 2 and the files ``glocal-verify simulate`` writes.

Every figure is drawn on a bare :class:`matplotlib.figure.Figure` with the Agg canvas (no
pyplot, no global backend change) and saved as PNG and SVG. Colours follow the paper's
caption: positions blue, velocities green, agents moved by the attack red; in the graph, green
nodes are globally monitored agents, blue nodes local control centres, red-bordered nodes
attacked actuators, red-filled nodes agents moved by the attack, and dashed edges the switching
links.

Residual panels use a logarithmic magnitude axis so that "invisible to rounding level" and
"grows without bound" are both readable: global residual channels are drawn as |r_0,k(t)| with
their thresholds (dashed), local observers as max_k |r_k(t)| / threshold_k (detection when the
curve exceeds 1).
"""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np
from matplotlib.artist import Artist
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from glocal_verify.model import System
from glocal_verify.design.case_study import CaseOutcome
from glocal_verify.reporting.figures.canvas import figure_bytes
from glocal_verify.reporting.figures.network import draw_network
from glocal_verify.reporting.output import write_bytes_atomic
from glocal_verify.simulation.algorithm1 import Algorithm1Result
from glocal_verify.spec.types import NORMAL_MODE

__all__ = [
    "plot_run",
    "plot_cases",
    "save_figure",
]

BLUE, GREEN, RED, GREY, ORANGE, PURPLE = "#1f4e9c", "#2e8b57", "#d62728", "#9a9a9a", "#ff7f0e", "#7b3f9e"


def save_figure(fig: Figure, stem: Path) -> list[Path]:
    """Save ``fig`` as ``stem.png`` (150 dpi) and ``stem.svg``, each written atomically
    (:func:`~glocal_verify.reporting.output.write_bytes_atomic`); return the paths.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    stem : Path
        Path without the extension.
    """
    out = []
    for ext, data in figure_bytes(fig).items():
        out.append(write_bytes_atomic(stem.with_name(f"{stem.name}.{ext}"), data))
    return out


# --------------------------------------------------------------------------------------------
# panels


def _switch_lines(ax: Axes, res: Algorithm1Result) -> None:
    for t, m in res.schedule.segments[1:]:
        ax.axvline(t, color="k", ls=":", lw=1.0)
        ax.annotate(f"switch to {m}", (t, 1.0), xycoords=("data", "axes fraction"), xytext=(3, -10), textcoords="offset points", fontsize=7)


def _legend_outside(ax: Axes, handles: Sequence[Artist]) -> None:
    """The legend right of the axes, where it cannot cover a curve (constrained layout makes room)."""
    ax.legend(handles=handles, fontsize=6, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, frameon=False)


def _states_panel(ax: Axes, system: System, res: Algorithm1Result) -> None:
    sim = res.simulation
    if sim.x is None:
        ax.text(0.5, 0.5, "states not recorded", ha="center", transform=ax.transAxes)
        return
    moved = set(res.attack.moved) if res.attack else set()
    n = system.n
    t = sim.t
    for i, lab in enumerate(system.labels):
        if lab in moved:
            continue
        ax.plot(t, sim.x[:, i], color=BLUE, lw=0.6, alpha=0.7)
        ax.plot(t, sim.x[:, n + i], color=GREEN, lw=0.6, alpha=0.7)
    for i, lab in enumerate(system.labels):
        if lab in moved:
            ax.plot(t, sim.x[:, i], color=RED, lw=1.2)
            ax.plot(t, sim.x[:, n + i], color=RED, lw=1.0, ls="--")
    ax.set_yscale("symlog", linthresh=1.0)
    ax.set_ylabel("state (symlog)")
    handles = [
        Line2D([], [], color=BLUE, label="positions"),
        Line2D([], [], color=GREEN, label="velocities"),
    ]
    if moved:
        handles += [
            Line2D([], [], color=RED, label=f"position, moved by attack {sorted(moved, key=str)}"),
            Line2D([], [], color=RED, ls="--", label="velocity, moved by attack"),
        ]
    _legend_outside(ax, handles)
    _switch_lines(ax, res)


def _positive(a: np.ndarray, floor: float = 1e-18) -> np.ndarray:
    return np.maximum(np.abs(a), floor)


def _global_panel(ax: Axes, res: Algorithm1Result) -> None:
    sim = res.simulation
    if "central" not in sim.residuals:
        ax.text(0.5, 0.5, "no centralized observer", ha="center", transform=ax.transAxes)
        return
    r = sim.residuals["central"]
    thr = res.thresholds.bound("central", sim.state_scale)
    colors = [PURPLE, ORANGE, "#8c564b", "#17becf", "#bcbd22", "#e377c2"]
    for k, ch in enumerate(sim.channels["central"]):
        c = colors[k % len(colors)]
        ax.plot(sim.t, _positive(r[:, k]), color=c, lw=1.0, label=f"|r0| on {ch}")
        ax.plot(sim.t, thr[:, k], color=c, lw=0.8, ls="--")
    ax.set_yscale("log")
    ax.set_ylabel("global residual |r0,k|")
    ga = res.global_after
    if ga is not None and ga.detected and ga.time is not None:
        ax.axvline(ga.time, color=RED, lw=1.0)
        ax.annotate(f"detected t = {ga.time:.2f}", (ga.time, 0.05), xycoords=("data", "axes fraction"), xytext=(3, 0), textcoords="offset points", fontsize=7, color=RED)
    handles, _ = ax.get_legend_handles_labels()
    handles.append(Line2D([], [], color="k", ls="--", lw=0.8, label="thresholds (dashed)"))
    _legend_outside(ax, handles)
    _switch_lines(ax, res)


def _local_panel(ax: Axes, res: Algorithm1Result) -> None:
    sim = res.simulation
    names = [nm for nm in sim.residuals if nm != "central"]
    if not names:
        ax.text(0.5, 0.5, "no local observer", ha="center", transform=ax.transAxes)
        return
    colors = [BLUE, ORANGE, GREEN, PURPLE, "#8c564b", "#17becf"]
    for k, nm in enumerate(names):
        r = np.abs(sim.residuals[nm])
        thr = res.thresholds.bound(nm, sim.state_scale)
        ratio = np.max(r / thr, axis=1) if r.shape[1] else np.zeros(len(sim.t))
        c = colors[k % len(colors)]
        ax.plot(sim.t, _positive(ratio), color=c, lw=1.0, label=f"observer {nm}")
        cr = res.local.get(nm)
        if cr is not None and cr.detected and cr.time is not None:
            ax.plot([cr.time], [max(ratio[np.searchsorted(sim.t, cr.time)], 1e-18)], marker="*", color=c, ms=9)
    ax.axhline(1.0, color="k", ls="--", lw=0.8)
    ax.set_yscale("log")
    ax.set_ylabel("local: max_k |r_k| / threshold_k")
    ax.set_xlabel("time t [s]")
    handles, _ = ax.get_legend_handles_labels()
    handles.append(Line2D([], [], color="k", ls="--", lw=0.8, label="threshold (= 1); star: local detection"))
    _legend_outside(ax, handles)
    _switch_lines(ax, res)


def _run_title(system: System, res: Algorithm1Result) -> str:
    atk = res.attack
    what = f"{atk.kind.upper()} on {list(atk.actuators)}" if atk else "no attack"
    if atk is not None and atk.lambda0 is not None:
        lam = complex(atk.lambda0)
        what += f", lambda0 = {lam.real:g}" if lam.imag == 0 else f", lambda0 = {lam.real:g}{lam.imag:+g}j"
    sw = f"switch to {res.chosen_mode} at t = {res.switch_time:g}" if res.switch_time is not None else "no switch"
    det = "control centre detects" if res.detected_globally else "control centre does not detect"
    if res.global_after is not None and res.global_after.detected and res.global_after.time is not None:
        det += f" at t = {res.global_after.time:.2f}"
    return f"{system.name}: {what}; {sw}; {det}"


def plot_run(system: System, res: Algorithm1Result) -> Figure:
    """A 2 x 2 figure of one run: states, global residual, local residuals, graph.

    Parameters
    ----------
    system : System
        The simulated system (for labels, clusters and the graph).
    res : Algorithm1Result
    """
    fig = Figure(figsize=(12, 8.5), layout="constrained")
    gs = fig.add_gridspec(3, 2, width_ratios=[1.6, 1.0])
    a = fig.add_subplot(gs[0, 0])
    b = fig.add_subplot(gs[1, 0], sharex=a)
    c = fig.add_subplot(gs[2, 0], sharex=a)
    d = fig.add_subplot(gs[:, 1])
    _states_panel(a, system, res)
    a.set_title("(a) states: positions (blue), velocities (green), moved by the attack (red)", fontsize=9)
    _global_panel(b, res)
    b.set_title("(b) global residuals of the centralized observer (normal-mode model) and thresholds", fontsize=9)
    _local_panel(c, res)
    c.set_title("(c) local residuals of the unknown-input observers, relative to their thresholds", fontsize=9)
    atk = res.attack
    draw_network(d, system, res.chosen_mode, atk.moved if atk else (), atk.actuators if atk else (), f"(d) communication topology, mode {res.chosen_mode or NORMAL_MODE}")
    fig.suptitle(_run_title(system, res), fontsize=10)
    return fig


def plot_cases(outcomes: Sequence[CaseOutcome]) -> Figure:
    """The paper's Figure 2: one column per case (states, global, local residuals, topology).

    Parameters
    ----------
    outcomes : sequence of CaseOutcome
    """
    k = len(outcomes)
    fig = Figure(figsize=(5.2 * k, 14), layout="constrained")
    gs = fig.add_gridspec(4, k, height_ratios=[1, 1, 1, 1.4])
    for j, oc in enumerate(outcomes):
        res, system = oc.result, oc.case.system
        a = fig.add_subplot(gs[0, j])
        b = fig.add_subplot(gs[1, j], sharex=a)
        c = fig.add_subplot(gs[2, j], sharex=a)
        d = fig.add_subplot(gs[3, j])
        _states_panel(a, system, res)
        verdict = "detected" if oc.detected else "not detected"
        a.set_title(f"({chr(97 + j)}) {oc.case.name}: global residual {oc.observed}, {verdict}", fontsize=9)
        _global_panel(b, res)
        _local_panel(c, res)
        atk = res.attack
        draw_network(d, system, oc.case.mode, atk.moved if atk else (), atk.actuators if atk else (), f"topology of {oc.case.name} ({system.name})")
    fig.suptitle("Privacy-preserving stealthy attack detection: the cases of Section IV (exact simulation)", fontsize=11)
    return fig
