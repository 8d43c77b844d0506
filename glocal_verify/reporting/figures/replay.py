"""The figure of ``glocal-verify replay``: every detector's residual over its threshold, the alarms
and Algorithm 1's switch."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from glocal_verify.simulation.replay import ReplayResult

__all__ = ["replay_figure"]


def replay_figure(result: ReplayResult) -> Figure:
    """One panel per detector: ``max_j |r_j| / theta_j`` against time (log scale), the threshold
    at 1, the alarms (dots) and the switch (a vertical line).

    Parameters
    ----------
    result : ReplayResult
    """
    names = list(result.residuals)
    fig = Figure(figsize=(9.0, 1.8 * max(1, len(names)) + 0.6))
    axes = fig.subplots(max(1, len(names)), 1, sharex=True, squeeze=False)[:, 0]
    t = result.t
    for ax, name in zip(axes, names):
        r, th = np.abs(result.residuals[name]), result.thresholds[name]
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio = np.where(np.isfinite(th) & (th > 0), r / th, np.nan)
        worst = np.nanmax(np.where(np.isfinite(ratio), ratio, -np.inf), axis=1) if ratio.shape[1] else np.full(len(t), np.nan)
        worst = np.where(np.isfinite(worst), worst, np.nan)
        ax.semilogy(t, worst, lw=0.8, color="tab:blue", label="max |r| / threshold")
        ax.axhline(1.0, color="tab:red", lw=0.8, ls="--", label="threshold")
        for a in result.alarms:
            if a.detector == name:
                ax.plot([a.time], [a.ratio], "o", color="tab:red", ms=5)
                ax.annotate(f"{a.kind} alarm {a.time:.2f} s", (a.time, a.ratio), fontsize=7, xytext=(4, 4), textcoords="offset points")
        if result.switch is not None and result.switch < len(t):
            ax.axvline(t[result.switch], color="tab:green", lw=0.8, label=f"switch to {result.safe_mode}")
        ax.set_ylabel(name, fontsize=8)
        ax.grid(True, which="both", lw=0.2)
    axes[0].legend(fontsize=7, loc="upper right")
    axes[-1].set_xlabel("t (s, from the log's t0)")
    fig.suptitle("replay: residuals over their certified thresholds", fontsize=9)
    return fig
