"""The figure of a sweep: the rate of ``holds`` of each condition against one swept parameter."""

from __future__ import annotations

import math
from typing import Any, Mapping, Sequence

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

__all__ = ["rates_figure"]


def rates_figure(axis: str, values: Sequence[Any], series: Mapping[str, Sequence[tuple[float, float, float]]]) -> Figure:
    """The rate of ``holds`` of each condition against one swept parameter, with Wilson intervals.

    Parameters
    ----------
    axis : str
        The parameter's name (the x label).
    values : sequence
        Its values (the x ticks).
    series : mapping of condition id to sequence of (rate, low, high)
        One point per value; a NaN rate is drawn as a gap.

    Returns
    -------
    matplotlib.figure.Figure
        Curves that coincide stay visible (each condition is shifted sideways by a small offset
        and has its own marker and dash pattern); the legend is outside the axes.
    """
    fig = Figure(figsize=(9, 4), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    xs = list(range(len(values)))
    # curves that coincide (eight conditions all at 1.0) stay apart: each series is shifted
    # sideways by a small offset and has its own marker and dash pattern
    k = len(series)
    width = min(0.5, 0.06 * k)
    markers, dashes = "osD^vP*Xh<>p", ("-", "--", "-.", ":")
    for j, (c, pts) in enumerate(series.items()):
        shift = (j - (k - 1) / 2) * (width / max(k - 1, 1)) if k > 1 else 0.0
        ys = [p[0] for p in pts]
        lo = [max(0.0, p[0] - p[1]) if math.isfinite(p[0]) else 0.0 for p in pts]
        hi = [max(0.0, p[2] - p[0]) if math.isfinite(p[0]) else 0.0 for p in pts]
        ax.errorbar([x + shift for x in xs], ys, yerr=[lo, hi], marker=markers[j % len(markers)], ls=dashes[j % len(dashes)], ms=5, capsize=2, lw=1.2, label=c)
    ax.set_xticks(xs, [str(v) for v in values])
    ax.set_xlabel(axis)
    ax.set_ylabel("rate of holds (Wilson 95%)")
    ax.set_ylim(-0.05, 1.05)
    # outside the axes: the legend never covers a curve
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, frameon=False, title="condition (markers offset sideways)", title_fontsize=7)
    return fig
