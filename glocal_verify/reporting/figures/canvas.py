"""The canvas every figure is drawn on and rendered from: a bare matplotlib Figure on Agg.

No pyplot and no global backend change: a figure is a :class:`matplotlib.figure.Figure` given
the Agg canvas, rendered to bytes in memory; the caller writes them.
"""

from __future__ import annotations

import io

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

__all__ = ["FORMATS", "figure_bytes"]

#: the formats every figure is rendered in
FORMATS = ("png", "svg")


def figure_bytes(fig: Figure) -> dict[str, bytes]:
    """Render ``fig`` as PNG (150 dpi) and SVG in memory: ``{"png": ..., "svg": ...}``.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    """
    FigureCanvasAgg(fig)
    out: dict[str, bytes] = {}
    for ext in FORMATS:
        buf = io.BytesIO()
        fig.savefig(buf, format=ext, dpi=150, bbox_inches="tight")
        out[ext] = buf.getvalue()
    return out
