"""Figures of the certified thresholds, the simulated residuals and the detection times.

Drawn from results they are given (:class:`~glocal_verify.simulation.certified_thresholds.CertifiedThresholds`,
:class:`~glocal_verify.simulation.sampled_runs.RunBatch`,
:class:`~glocal_verify.simulation.guarantees.DetectionGuarantee`,
:class:`~glocal_verify.analysis.sampled.scan.PeriodScan`); nothing here simulates. Each is a bare
:class:`matplotlib.figure.Figure` on the Agg canvas, rendered to PNG and SVG bytes by
:func:`render`.
"""

from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np
from matplotlib.figure import Figure

from glocal_verify.analysis.sampled.scan import PeriodScan
from glocal_verify.simulation.certified_thresholds import CertifiedThresholds
from glocal_verify.simulation.guarantees import DetectionGuarantee
from glocal_verify.simulation.sampled_runs import RunBatch

__all__ = ["thresholds_figure", "detection_figure", "detection_times_figure", "period_scan_figure"]

BLUE, GREEN, RED, GREY, ORANGE, PURPLE = "#1f4e9c", "#2e8b57", "#d62728", "#9a9a9a", "#ff7f0e", "#7b3f9e"


def thresholds_figure(th: CertifiedThresholds, batches: Sequence[RunBatch], observers: Sequence[str] | None = None) -> Figure:
    """One panel per detector: its certified threshold of every channel (the largest at each
    sample, dashed; the constant tail dotted) and the largest simulated ``|r|`` of each batch."""
    names = list(observers) if observers is not None else list(th.observers)
    fig = Figure(figsize=(10, 2.4 * len(names)))
    step = max(1, th.horizon // 600)  # maxima over blocks of samples: the envelopes, at most 600 points
    t = (np.arange(th.horizon) * th.period)[::step]

    def env(x: np.ndarray) -> np.ndarray:
        m = len(x) // step * step
        head = x[:m].reshape(-1, step).max(axis=1) if m else np.zeros(0)
        return np.concatenate([head, x[m:].max(keepdims=True)]) if m < len(x) else head
    colours = [BLUE, GREEN, ORANGE, PURPLE]
    for i, name in enumerate(names):
        ax = fig.add_subplot(len(names), 1, i + 1)
        o = th.observers[name]
        ax.semilogy(t, env(o.theta.max(axis=1)), "--", color=RED, lw=1.2, label="certified threshold (max over channels)")
        ax.axhline(float(o.tail.max()), color=RED, ls=":", lw=1.0, label="constant tail")
        for c, b in enumerate(batches):
            peak = env(b.peak[name].max(axis=1))
            ax.semilogy(t, np.maximum(peak, 1e-18), color=colours[c % len(colours)], lw=0.8, label=f"largest |r| over {b.runs} {b.kind} runs")
        ax.set_title(f"{name}: attack-free residuals never cross the certified threshold", fontsize=9)
        ax.set_ylabel("|r|")
        if i == len(names) - 1:
            ax.set_xlabel("t (s)")
        ax.legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    return fig


def detection_figure(
    th: CertifiedThresholds, g: DetectionGuarantee, batch: RunBatch, local: str, switch_theta: Mapping[int, np.ndarray] | None = None, run: int = 0
) -> Figure:
    """One attacked run: the local observer's and the central observer's residual against their
    thresholds, the local alarm, the switch and the central alarm, with the certified bounds."""
    fig = Figure(figsize=(10, 6))
    h = th.period
    t = np.arange(th.horizon) * h
    ax1 = fig.add_subplot(2, 1, 1)
    r = np.abs(batch.traces[local][:, :, run])
    ratio = (r / th.observers[local].theta).max(axis=1)
    ax1.semilogy(t, ratio, color=BLUE, lw=0.9, label=f"max_j |r_j| / theta_j ({local})")
    ax1.axhline(1.0, color=RED, ls="--", lw=1.0, label="threshold")
    lg = next((s for s in g.local if s.observer == local), None)
    if lg is not None and lg.guaranteed is not None:
        ax1.axvline(lg.guaranteed * h, color=GREEN, ls=":", label=f"certified local alarm by {lg.within:.3g} s")
    fa = int(batch.first_alarm[local][run])
    if fa >= 0:
        ax1.axvline(fa * h, color=ORANGE, lw=1.0, label=f"simulated local alarm at {fa * h:.3g} s")
    ax1.set_ylabel("residual / threshold")
    ax1.legend(fontsize=7)
    ax2 = fig.add_subplot(2, 1, 2)
    rc = np.abs(batch.traces["central"][:, :, run])
    s = int(batch.switch[run])
    thc = th.observers["central"].theta.copy()
    if s >= 0 and switch_theta is not None and s in switch_theta:
        thc[s:] = switch_theta[s]
        ax2.axvline(s * h, color=GREY, ls="-.", label=f"switch to {g.mode} at {s * h:.3g} s")
        ks = dict(g.per_switch).get(s)
        if ks is not None:
            ax2.axvline(ks * h, color=GREEN, ls=":", label=f"certified central alarm by {ks * h:.3g} s")
    ax2.semilogy(t, np.maximum((rc / thc).max(axis=1), 1e-18), color=BLUE, lw=0.9, label="max_j |r_0,j| / theta_j (central)")
    ax2.axhline(1.0, color=RED, ls="--", lw=1.0)
    ca = int(batch.central_alarm[run])
    if ca >= 0:
        ax2.axvline(ca * h, color=ORANGE, lw=1.0, label=f"simulated central alarm at {ca * h:.3g} s")
    ax2.set_xlabel("t (s)")
    ax2.set_ylabel("residual / threshold")
    ax2.legend(fontsize=7)
    fig.suptitle(f"Algorithm 1, sampled at h = {h:g} s: {g.attack.get('kind')} of size {g.size:g}", fontsize=10)
    fig.tight_layout()
    return fig


def detection_times_figure(g: DetectionGuarantee, batch: RunBatch, local: str, period: float) -> Figure:
    """Histograms of the simulated local and central alarm times against the certified bounds."""
    fig = Figure(figsize=(10, 3.2))
    ka = int(g.attack.get("start_sample", 0))
    ax1 = fig.add_subplot(1, 2, 1)
    fa = batch.first_alarm[local]
    ax1.hist((fa[fa >= 0] - ka) * period, bins=40, color=BLUE)
    lg = next((s for s in g.local if s.observer == local), None)
    if lg is not None and lg.within is not None:
        ax1.axvline(lg.within, color=RED, ls="--", label=f"certified: by {lg.within:.3g} s")
    ax1.set_xlabel(f"local alarm ({local}) after the attack starts (s)")
    ax1.legend(fontsize=7)
    ax2 = fig.add_subplot(1, 2, 2)
    ok = (batch.central_alarm >= 0) & (batch.switch >= 0)
    ax2.hist((batch.central_alarm[ok] - batch.switch[ok]) * period, bins=40, color=GREEN)
    if g.global_within is not None:
        ax2.axvline(g.global_within, color=RED, ls="--", label=f"certified: by {g.global_within:.3g} s")
    ax2.set_xlabel("central alarm after the switch (s)")
    ax2.legend(fontsize=7)
    fig.tight_layout()
    return fig


def period_scan_figure(scan: PeriodScan, period: float | None = None) -> Figure:
    """The pathological periods of a scan, one row per mode, coloured by kind."""
    modes = sorted({p.mode for p in scan.periods})
    fig = Figure(figsize=(10, 0.5 + 0.5 * max(1, len(modes))))
    ax = fig.add_subplot(1, 1, 1)
    colour = {"scalar-block": BLUE, "aliasing": ORANGE, "gamma-h-2": RED, "stability-limit": PURPLE}
    for kind, c in colour.items():
        xs = [p.period for p in scan.periods if p.kind == kind]
        ys = [modes.index(p.mode) for p in scan.periods if p.kind == kind]
        if xs:
            ax.scatter(xs, ys, s=10, color=c, label=kind)
    if period is not None:
        ax.axvline(period, color=GREEN, ls="--", label=f"h = {period:g}")
    ax.set_yticks(range(len(modes)))
    ax.set_yticklabels(modes)
    ax.set_xscale("log")
    ax.set_xlabel("sampling period h (s)")
    ax.set_title(f"pathological periods ({scan.controller} loop): {scan.count} in [{scan.h_min:g}, {scan.h_max:g}]", fontsize=9)
    ax.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    return fig
