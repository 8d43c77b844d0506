"""Replay of a measured log through the exported detectors and Algorithm 1 (``glocal-verify replay``).

A deployment file (:mod:`glocal_verify.reporting.export`, schema version 2) holds the sampled
detectors of every mode of the schedule, their certified thresholds and Algorithm 1's switching
logic. :func:`replay` runs exactly that on a recorded log:

1. **The log** (:func:`read_log`): a CSV file with a header, or an ``.npz`` archive; a time
   column ``t`` (or ``time``) and one column per measured channel, named as in the file
   (``x:LABEL`` a position, ``v:LABEL`` a velocity). A unit may follow a name in brackets,
   ``v:7 [km/h]``, ``t [ms]``; values are converted to the file's units (s, m, m/s); a name
   without a unit is taken in those units; an unknown unit is refused.
2. **The detectors' period** (:func:`resample`), by this rule: the detector sample k is at
   ``t0 + k h`` (``t0`` the first timestamp unless given); it takes the log row nearest to that
   time when it lies within ``tolerance * h`` (default a quarter period), else it is missing.
   Rows are sorted by time and duplicate timestamps keep their first row. A missing sample or a
   non-finite value is filled by linear interpolation in time between the nearest valid
   samples of its channel (held at the ends); a channel with more than ``max_gap`` consecutive
   missing samples, or none at all, is refused. Every action is reported.
3. **Algorithm 1** (:func:`replay`): every detector of the active mode runs from ``z = 0``
   (``z+ = Fo z + Go y``, ``r = Ry y - Rz z``; the reset ``z <- z + (H_p - H_q) y`` when the mode
   changes); a local residual above its threshold is a local alarm; the first one switches to
   the safe mode ``switch_delay`` samples later (the timed schedule stops there); after the
   switch the control centre's residual is compared with the after-switch threshold of the
   switch's block. The margins are ``theta - |r|`` per channel.
4. **The noise premise.** The thresholds hold for noise within ``[uncertainty]``. For an alarm
   the replay reports the largest fourth difference ``|y[k-2] - 4 y[k-1] + 6 y[k] - 4 y[k+1] +
   y[k+2]| / 16`` of each channel before it, divided by the channel's noise bound (the samples
   next to a mode switch left out, where the acceleration jumps): noise within its bound
   contributes at most the bound, the sampled loop's own signal ``h^4 |y''''| / 16`` (1e-8 of
   its fourth derivative at h = 0.01 s). A ratio above 1 (plus the tunable ``replay_noise_slack``)
   says the measurement is rougher than the premise allows: the guarantee did not apply.
"""

from __future__ import annotations

import csv
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from glocal_verify import config
from glocal_verify.errors import GlocalVerifyError, shorten
from glocal_verify.results import jsonable

__all__ = ["ReplayError", "MeasuredLog", "read_log", "Resampled", "resample", "Alarm", "ReplayResult", "replay", "replay_channels", "UNITS"]


class ReplayError(GlocalVerifyError, ValueError):
    """A log or deployment file that cannot be replayed (one line: what and where)."""


#: unit factors to the file's units, by the kind of column
UNITS: Mapping[str, Mapping[str, float]] = MappingProxyType(
    {
        "t": MappingProxyType({"s": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6, "ns": 1e-9, "min": 60.0}),
        "x": MappingProxyType({"m": 1.0, "cm": 1e-2, "mm": 1e-3, "km": 1e3}),
        "v": MappingProxyType({"m/s": 1.0, "cm/s": 1e-2, "mm/s": 1e-3, "km/h": 1.0 / 3.6}),
    }
)

_HEADER = re.compile(r"^\s*(?P<name>[^\[\]]+?)\s*(\[\s*(?P<unit>[^\]]*?)\s*\])?\s*$")


@dataclass(frozen=True, slots=True)
class MeasuredLog:
    """A recorded log in the file's units.

    Attributes
    ----------
    t : ndarray
        Timestamps (s), as recorded (not sorted).
    columns : mapping of str to ndarray
        Per channel name, its values.
    units : mapping of str to str
        The unit each column was given in (``"s"``, ``"m"``, ``"m/s"`` when none was given).
    source : str
    """

    t: np.ndarray
    columns: Mapping[str, np.ndarray]
    units: Mapping[str, str]
    source: str


def _unit(name: str, unit: str | None, where: str) -> tuple[str, float]:
    kind = "t" if name.lower() in ("t", "time") else name.split(":", 1)[0]
    table = UNITS.get(kind)
    if table is None:
        return unit or "", 1.0
    if not unit:
        return next(iter(table)), 1.0
    if unit not in table:
        raise ReplayError(f"{where}: column {name!r}: unknown unit {unit!r} (known: {', '.join(table)})")
    return unit, table[unit]


def read_log(path: str | Path) -> MeasuredLog:
    """Read a CSV (with a header) or ``.npz`` log (module docstring).

    Raises
    ------
    ReplayError
        For an unreadable file, no time column, an unknown unit or a non-numeric value.
    """
    p = Path(path)
    where = shorten(str(p), 100)
    raw: dict[str, np.ndarray] = {}
    try:
        if p.suffix.lower() == ".npz":
            with np.load(p, allow_pickle=False) as z:
                for k in z.files:
                    raw[k] = np.asarray(z[k], dtype=float).reshape(-1)
        else:
            with p.open(newline="", encoding="utf-8") as f:
                header = next(csv.reader(f), None)
            if not header:
                raise ReplayError(f"{where}: empty log (a CSV header naming t and the channels comes first)")
            data = np.genfromtxt(p, delimiter=",", skip_header=1, dtype=float, ndmin=2, invalid_raise=True)
            if data.size and data.shape[1] != len(header):
                raise ReplayError(f"{where}: {data.shape[1]} columns of values under a header of {len(header)}")
            data = data.reshape(-1, len(header))
            for j, h in enumerate(header):
                raw[h] = data[:, j]
    except ReplayError:
        raise
    except OSError as exc:
        raise ReplayError(f"{where}: cannot read ({exc.strerror or exc})") from None
    except Exception as exc:  # noqa: BLE001 - parsers of an untrusted file
        raise ReplayError(f"{where}: not a readable log ({type(exc).__name__}: {shorten(str(exc), 100)})") from None
    columns: dict[str, np.ndarray] = {}
    units: dict[str, str] = {}
    t = None
    for key, values in raw.items():
        m = _HEADER.match(key)
        if m is None:
            raise ReplayError(f"{where}: column {key!r}: not a name with an optional [unit]")
        name = m.group("name").strip()
        unit, factor = _unit(name, m.group("unit"), where)
        if name.lower() in ("t", "time"):
            t, units["t"] = values * factor, unit
        else:
            if name in columns:
                raise ReplayError(f"{where}: column {name!r} appears twice")
            columns[name], units[name] = values * factor, unit
    if t is None:
        raise ReplayError(f"{where}: no time column (name one t or time, in seconds or with a unit: t [ms])")
    return MeasuredLog(t, columns, units, str(p))


@dataclass(frozen=True, slots=True)
class Resampled:
    """The log at the detectors' period.

    Attributes
    ----------
    t : ndarray
        (K,) the detector sample times ``t0 + k h`` (relative to t0: ``k h``).
    y : mapping of str to ndarray
        Per channel, (K,) values.
    filled : mapping of str to ndarray
        Per channel, (K,) whether the value was filled (missing sample or non-finite value).
    actions : tuple of str
        What the rule did, in words.
    t0 : float
    """

    t: np.ndarray
    y: Mapping[str, np.ndarray]
    filled: Mapping[str, np.ndarray]
    actions: tuple[str, ...]
    t0: float


def resample(log: MeasuredLog, channels: Sequence[str], period: float, *, t0: float | None = None, tolerance: float = 0.25, max_gap: int = 3) -> Resampled:
    """The log's ``channels`` at the detectors' period (module docstring, rule 2).

    Raises
    ------
    ReplayError
        A channel the detectors need is not in the log, has a gap longer than ``max_gap``
        samples, or no valid sample; no timestamp is finite.
    """
    where = shorten(log.source, 100)
    missing = [c for c in channels if c not in log.columns]
    if missing:
        raise ReplayError(f"{where}: no column for the channel(s) {', '.join(missing)} the detectors measure (columns named as the file's channels: x:LABEL, v:LABEL)")
    actions: list[str] = []
    ok = np.isfinite(log.t)
    if not np.all(ok):
        actions.append(f"{int((~ok).sum())} row(s) without a finite timestamp dropped")
    order = np.argsort(log.t[ok], kind="stable")
    ts = log.t[ok][order]
    if not len(ts):
        raise ReplayError(f"{where}: no row has a finite timestamp")
    if np.any(np.diff(log.t[ok]) < 0):
        actions.append("rows sorted by time (the log was not in time order)")
    keep = np.concatenate([[True], np.diff(ts) > 0])
    if not np.all(keep):
        actions.append(f"{int((~keep).sum())} row(s) with a repeated timestamp dropped (the first kept)")
    rows = np.flatnonzero(ok)[order][keep]
    ts = ts[keep]
    start = float(ts[0]) if t0 is None else float(t0)
    h = float(period)
    K = int(math.floor((float(ts[-1]) - start) / h + tolerance)) + 1
    if K <= 0:
        raise ReplayError(f"{where}: no sample at or after t0 = {start:g} s")
    grid = start + np.arange(K) * h
    idx = np.clip(np.searchsorted(ts, grid), 1, len(ts) - 1) if len(ts) > 1 else np.zeros(K, dtype=int)
    if len(ts) > 1:
        left = idx - 1
        idx = np.where(np.abs(ts[left] - grid) <= np.abs(ts[idx] - grid), left, idx)
    dev = np.abs(ts[idx] - grid)
    hit = dev <= tolerance * h
    steps = np.diff(ts)
    actions.append(
        f"detector sample k at t0 + k h (t0 = {start:g} s, h = {h:g} s), taking the nearest row within {tolerance:g} h: "
        f"{int(hit.sum())} of {K} samples found (median log step {float(np.median(steps)) if len(steps) else math.nan:.4g} s, "
        f"largest offset used {float(dev[hit].max()) if hit.any() else 0.0:.3g} s)"
    )
    used = np.unique(idx[hit])
    if len(used) < len(ts) * 0.9 and len(ts) > K:
        actions.append(f"{len(ts) - len(used)} log row(s) between detector samples not used (the log is faster than the detectors)")
    y: dict[str, np.ndarray] = {}
    filled: dict[str, np.ndarray] = {}
    for c in channels:
        v = np.where(hit, log.columns[c][rows][idx], np.nan)
        bad = ~np.isfinite(v)
        if bad.all():
            raise ReplayError(f"{where}: channel {c} has no valid sample at the detectors' period")
        if bad.any():
            run = _longest_run(bad)
            if run[1] > max_gap:
                raise ReplayError(
                    f"{where}: channel {c} misses {run[1]} consecutive samples from t = {grid[run[0]] - start:g} s "
                    f"(more than --max-gap {max_gap}): the detectors cannot be run across the gap"
                )
            good = np.flatnonzero(~bad)
            v = v.copy()
            v[bad] = np.interp(np.flatnonzero(bad), good, v[good])
            actions.append(f"{c}: {int(bad.sum())} missing or non-finite sample(s) filled by linear interpolation (longest run {run[1]})")
        y[c] = v
        filled[c] = bad
    for c, u in log.units.items():
        if c in channels or c == "t":
            if u not in ("s", "m", "m/s"):
                actions.append(f"{c}: converted from {u}")
    return Resampled(np.arange(K) * h, y, filled, tuple(actions), start)


def _longest_run(mask: np.ndarray) -> tuple[int, int]:
    """(start, length) of the longest run of True."""
    best = (0, 0)
    k = 0
    while k < len(mask):
        if mask[k]:
            j = k
            while j < len(mask) and mask[j]:
                j += 1
            if j - k > best[1]:
                best = (k, j - k)
            k = j
        else:
            k += 1
    return best


@dataclass(frozen=True, slots=True)
class Alarm:
    """One alarm of the replay.

    Attributes
    ----------
    detector : str
    kind : str
        ``"local"`` (Algorithm 1, line 3), ``"central"`` (the control centre after the switch,
        line 7) or ``"central-before-switch"`` (the control centre before any switch).
    sample : int
    time : float
        Seconds from t0.
    channel : str
    ratio : float
        ``|r| / theta`` at the alarm.
    noise_ratio : float
        The largest second-difference noise estimate of the detector's channels before the
        alarm over their noise bounds (module docstring, 4).
    noise_channel : str
    after_filled : bool
        Some of the detector's samples up to the alarm were filled (not measured).
    """

    detector: str
    kind: str
    sample: int
    time: float
    channel: str
    ratio: float
    noise_ratio: float
    noise_channel: str
    after_filled: bool

    @property
    def noise_exceeded(self) -> bool:
        """The measurement was rougher than ``[uncertainty]`` allows before the alarm (by more than
        the tunable ``replay_noise_slack``, :mod:`glocal_verify.config`)."""
        return self.noise_ratio > 1.0 + float(config.get("replay_noise_slack"))

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return jsonable(
            {
                "detector": self.detector, "kind": self.kind, "sample": self.sample, "time": self.time, "channel": self.channel,
                "ratio": self.ratio, "noise_ratio": self.noise_ratio, "noise_channel": self.noise_channel,
                "noise_exceeded": self.noise_exceeded, "after_filled": self.after_filled,
            }
        )  # fmt: skip


@dataclass(frozen=True, slots=True)
class ReplayResult:
    """What the vehicles' detectors did on the log.

    Attributes
    ----------
    t : ndarray
        (K,) sample times from t0.
    residuals, thresholds : mapping of str to ndarray
        Per detector, (K, q) residuals and the thresholds they were compared with (``nan``
        where none applied: a local detector after Algorithm 1's switch, a mode without a
        certified threshold).
    channels : mapping of str to tuple of str
    alarms : tuple of Alarm
        In time order; the first local one triggered the switch.
    switch : int or None
        Algorithm 1's switch sample.
    safe_mode : str
    modes : tuple of (int, str)
        The modes the detectors ran in, from the sample on.
    margins : mapping of str to mapping of str to float
        Per detector and channel, the smallest ``theta - |r|`` over the samples with a threshold.
    peak_ratio : mapping of str to float
        Per detector, the largest ``|r| / theta``.
    actions : tuple of str
        What the resampling did.
    notes : tuple of str
    """

    t: np.ndarray
    residuals: Mapping[str, np.ndarray]
    thresholds: Mapping[str, np.ndarray]
    channels: Mapping[str, tuple[str, ...]]
    alarms: tuple[Alarm, ...]
    switch: int | None
    safe_mode: str
    modes: tuple[tuple[int, str], ...]
    margins: Mapping[str, Mapping[str, float]]
    peak_ratio: Mapping[str, float]
    actions: tuple[str, ...]
    notes: tuple[str, ...] = field(default_factory=tuple)

    def to_json(self) -> dict[str, Any]:
        """Summary (no per-sample arrays)."""
        return jsonable(
            {
                "samples": len(self.t),
                "period": float(self.t[1] - self.t[0]) if len(self.t) > 1 else None,
                "alarms": [a.to_json() for a in self.alarms],
                "switch_sample": self.switch,
                "switch_time": self.t[self.switch] if self.switch is not None and self.switch < len(self.t) else None,
                "safe_mode": self.safe_mode,
                "modes": [{"sample": s, "mode": m} for s, m in self.modes],
                "margins": {k: dict(v) for k, v in self.margins.items()},
                "peak_ratio": dict(self.peak_ratio),
                "actions": list(self.actions),
                "notes": list(self.notes),
            }
        )


def _sampled(tree: Mapping[str, Any], where: str) -> Mapping[str, Any]:
    if int(tree.get("schema_version", 0)) < 2:
        raise ReplayError(f"{where}: schema version {tree.get('schema_version')} holds no sampled detectors: export the spec again with this version")
    s = tree.get("sampled", {})
    if not s or not s.get("present"):
        raise ReplayError(f"{where}: no sampled detectors ({s.get('note') or 'the spec has no [implementation]'}): replay runs the detectors of a sampled deployment")
    return s  # type: ignore[no-any-return]


def replay_channels(tree: Mapping[str, Any], where: str = "deployment") -> list[str]:
    """The channels the file's detectors measure (the log's columns)."""
    s = _sampled(tree, where)
    return sorted({c for d in s["detectors"] for c in d["channels"]})


def _noise_estimate(y: np.ndarray) -> np.ndarray:
    """``|y[k-2] - 4 y[k-1] + 6 y[k] - 4 y[k+1] + y[k+2]| / 16`` at k (0 at the ends): (K,)."""
    out = np.zeros_like(y)
    if len(y) > 4:
        out[2:-2] = np.abs(y[:-4] - 4 * y[1:-3] + 6 * y[2:-2] - 4 * y[3:-1] + y[4:]) / 16
    return out


def replay(tree: Mapping[str, Any], data: Resampled, *, where: str = "deployment", progress: Callable[[int, int], None] | None = None) -> ReplayResult:
    """Run the file's detectors and Algorithm 1 on the resampled log (module docstring, 3-4).

    Parameters
    ----------
    tree : mapping
        The deployment file as :func:`~glocal_verify.reporting.export.read_deployment` reads it.
    data : Resampled
    progress : callable, optional
        ``progress(done, total)`` every few thousand samples.
    """
    s = _sampled(tree, where)
    h = float(s["period"])
    K = len(data.t)
    d = int(s["switch_delay"])
    safe = str(s.get("safe_mode") or "")
    th = s["thresholds"]
    segs = [(int(g["sample"]), str(g["mode"])) for g in th["segments"]]
    theta = {o["name"]: (np.atleast_2d(o["theta"]), np.asarray(o["tail"], dtype=float).reshape(-1)) for o in th["observers"]}
    after = s.get("after_switch", {})
    blocks = [(int(b["sample"]), np.atleast_2d(b["theta"]), np.asarray(b["tail"], dtype=float).reshape(-1)) for b in after.get("blocks", [])] if after.get("present") else []
    unc = s["uncertainty"]
    nbar = dict(zip(unc["noise_channels"], np.asarray(unc["noise"], dtype=float).reshape(-1)))
    dets = []
    for det in s["detectors"]:
        modes = {m["mode"]: m for m in det["modes"]}
        dets.append((det["name"], det["kind"], tuple(det["channels"]), modes))
    notes: list[str] = []
    res = {n: np.full((K, len(ch)), np.nan) for n, _, ch, _ in dets}
    thr = {n: np.full((K, len(ch)), np.nan) for n, _, ch, _ in dets}
    Y = {n: np.stack([data.y[c] for c in ch], axis=1) if ch else np.zeros((K, 0)) for n, _, ch, _ in dets}
    filled = {n: np.any(np.stack([data.filled[c] for c in ch], axis=1), axis=1) if ch else np.zeros(K, dtype=bool) for n, _, ch, _ in dets}
    z: dict[str, np.ndarray | None] = {}
    running: dict[str, str | None] = {}
    for n, _, _, modes in dets:
        first = modes.get(segs[0][1])
        z[n] = np.zeros(np.atleast_2d(first["Fo"]).shape[0]) if first is not None else None
        running[n] = segs[0][1] if first is not None else None
    switch: int | None = None
    alarms: list[Alarm] = []
    mode_log: list[tuple[int, str]] = []
    central_alarmed = False
    for k in range(K):
        if switch is not None and k >= switch and safe:
            mode = safe
        else:
            mode = max((g for g in segs if g[0] <= k), key=lambda g: g[0])[1]
        if not mode_log or mode_log[-1][1] != mode:
            mode_log.append((k, mode))
        after_switch = switch is not None and k >= switch
        for n, kind, ch, modes in dets:
            zn = z[n]
            if zn is None:
                continue
            y = Y[n][k]
            prev = running[n]
            if prev != mode:
                new = modes.get(mode)
                if new is None:
                    z[n] = None
                    if not (kind == "local" and after_switch):
                        notes.append(f"{n}: no matrices for mode {mode} in the file: stopped at sample {k}")
                    continue
                zn = zn + (np.atleast_2d(modes[prev]["H"]) - np.atleast_2d(new["H"])) @ y  # type: ignore[index]
                running[n] = mode
            m = modes[mode]
            r = np.atleast_2d(m["Ry"]) @ y - np.atleast_2d(m["Rz"]) @ zn
            z[n] = np.atleast_2d(m["Fo"]) @ zn + np.atleast_2d(m["Go"]) @ y
            res[n][k] = r
            if kind == "local" and after_switch:
                continue
            if kind == "central" and after_switch:
                if not blocks:
                    continue
                b0, bt, btail = max((b for b in blocks if b[0] <= switch), key=lambda b: b[0])  # type: ignore[operator]
                mm = k - switch  # type: ignore[operator]
                t_k = bt[mm] if mm < len(bt) else btail
            else:
                tk, tail = theta[n]
                t_k = tk[k] if k < len(tk) else tail
            t_k = np.where(np.isfinite(t_k), t_k, np.nan)
            thr[n][k] = t_k
            over = np.abs(r) > t_k
            if np.any(over):
                j = int(np.nanargmax(np.where(np.isfinite(t_k), np.abs(r) / np.where(t_k > 0, t_k, np.inf), -np.inf)))
                if kind == "local" and switch is None:
                    alarms.append(_alarm(n, "local", k, h, ch, r, t_k, j, Y[n], filled[n], nbar, mode_log))
                    switch = k + d if safe else None
                    if not safe:
                        notes.append("no safe mode in the file: the local alarm switches nothing")
                elif kind == "central" and not central_alarmed:
                    alarms.append(_alarm(n, "central" if after_switch else "central-before-switch", k, h, ch, r, t_k, j, Y[n], filled[n], nbar, mode_log))
                    central_alarmed = True
        if progress is not None and (k % 4096 == 0 or k == K - 1):
            progress(k + 1, K)
    margins: dict[str, dict[str, float]] = {}
    peak: dict[str, float] = {}
    for n, _, ch, _ in dets:
        a, t = np.abs(res[n]), thr[n]
        with np.errstate(invalid="ignore", divide="ignore"):
            mg = np.where(np.isfinite(t), t - a, np.nan)
            rt = np.where(np.isfinite(t) & (t > 0), a / t, np.nan)
        margins[n] = {c: (float(np.nanmin(mg[:, j])) if np.any(np.isfinite(mg[:, j])) else math.nan) for j, c in enumerate(ch)}
        peak[n] = float(np.nanmax(rt)) if np.any(np.isfinite(rt)) else math.nan
    return ReplayResult(
        data.t, res, thr, {n: ch for n, _, ch, _ in dets}, tuple(alarms), switch if switch is not None and switch < K else switch, safe, tuple(mode_log), margins, peak, data.actions, tuple(dict.fromkeys(notes))
    )


def _alarm(
    name: str, kind: str, k: int, h: float, ch: tuple[str, ...], r: np.ndarray, t_k: np.ndarray, j: int, Y: np.ndarray, filled: np.ndarray, nbar: Mapping[str, float], modes: Sequence[tuple[int, str]]
) -> Alarm:
    best, where = 0.0, ""
    skip = np.zeros(k + 1, dtype=bool)
    for s0, _ in modes[1:]:
        skip[max(0, s0 - 3) : s0 + 3] = True  # the acceleration jumps at a switch
    for c, col in enumerate(ch):
        est = float(np.where(skip, 0.0, _noise_estimate(Y[: k + 1, c])).max(initial=0.0))
        bound = float(nbar.get(col, 0.0))
        ratio = est / bound if bound > 0 else (math.inf if est > 0 else 0.0)
        if ratio >= best:
            best, where = ratio, col
    return Alarm(name, kind, k, k * h, ch[j], float(abs(r[j]) / t_k[j]) if t_k[j] > 0 else math.inf, best, where, bool(filled[: k + 1].any()))
