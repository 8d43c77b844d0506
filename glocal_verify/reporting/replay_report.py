"""The text and JSON of ``glocal-verify replay`` (a :class:`~glocal_verify.simulation.replay.ReplayResult`)."""

from __future__ import annotations

import json
import math
from pathlib import Path
from types import MappingProxyType

from glocal_verify.reporting.output import write_bytes_atomic
from glocal_verify.simulation.replay import Alarm, ReplayResult

__all__ = ["replay_text", "replay_json", "write_replay_figure"]

_KINDS = MappingProxyType({"local": "local alarm", "central": "control centre's alarm (after the switch)", "central-before-switch": "control centre's alarm (before any switch)"})


def _alarm_line(a: Alarm) -> str:
    noise = (
        f"the measured noise exceeded [uncertainty] before it ({a.noise_channel} at {a.noise_ratio:.3g} x its bound): the guarantee's premise did not hold"
        if a.noise_exceeded
        else f"the measured noise stayed within [uncertainty] before it (largest {a.noise_channel}, {a.noise_ratio:.3g} x its bound)"
    )
    filled = "; some samples before it were filled, not measured" if a.after_filled else ""
    return f"  t = {a.time:9.3f} s  {_KINDS.get(a.kind, a.kind)} of {a.detector} on {a.channel} (|r| = {a.ratio:.3g} x threshold); {noise}{filled}"


def replay_text(result: ReplayResult, *, log: str, deployment: str) -> str:
    """The replay in words: what the resampling did, the modes, the alarms with their times and
    the noise premise, the margins."""
    lines = [f"replay of {log} through {deployment}: {len(result.t)} samples, {len(result.residuals)} detectors", "resampling:"]
    lines += [f"  {a}" for a in result.actions]
    lines.append("modes: " + ", ".join(f"{m} from t = {result.t[s]:.3f} s" if s < len(result.t) else m for s, m in result.modes))
    if result.alarms:
        lines.append("alarms:")
        for a in result.alarms:
            lines.append(_alarm_line(a))
            if a.kind == "local" and result.switch is not None:
                when = result.t[result.switch] if result.switch < len(result.t) else math.nan
                lines.append(f"  t = {when:9.3f} s  switch to {result.safe_mode} (Algorithm 1, lines 4-5)")
    else:
        lines.append("alarms: none (every residual stayed below its certified threshold)")
    lines.append("margins (smallest threshold - |r| per detector and channel, over the samples with a threshold; negative: crossed):")
    for name, m in result.margins.items():
        worst = min(m.items(), key=lambda kv: kv[1] if not math.isnan(kv[1]) else math.inf) if m else ("", math.nan)
        lines.append(f"  {name:12s} smallest {worst[1]:.3g} ({worst[0]}), peak |r| / threshold {result.peak_ratio.get(name, math.nan):.3g}")
    if result.notes:
        lines.append("notes:")
        lines += [f"  {n}" for n in result.notes]
    return "\n".join(lines) + "\n"


def replay_json(result: ReplayResult, *, log: str, deployment: str) -> str:
    """The replay's summary as JSON text (no per-sample arrays)."""
    return json.dumps({"log": log, "deployment": deployment, **result.to_json()}, indent=1, allow_nan=False) + "\n"


def write_replay_figure(result: ReplayResult, path: str | Path) -> Path:
    """Draw :func:`~glocal_verify.reporting.figures.replay.replay_figure` into ``path`` (PNG or SVG by its suffix)."""
    from glocal_verify.reporting.figures.canvas import figure_bytes
    from glocal_verify.reporting.figures.replay import replay_figure

    p = Path(path)
    blobs = figure_bytes(replay_figure(result))
    ext = p.suffix.lower().lstrip(".")
    return write_bytes_atomic(p, blobs.get(ext, blobs["png"]))
