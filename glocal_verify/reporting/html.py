"""A verification report as one self-contained HTML page.

:func:`to_html` writes a single page with everything inline (CSS in a ``<style>`` element,
drawings as inline SVG, no script, no font, no image or link to fetch), so it opens offline
and can be mailed or archived as one file. The page shows, in order:

1. the **assessment** the report carries (:func:`glocal_verify.answer.assessment.assess`): Problem 1
   (privacy of :math:`x(t_0)` and :math:`x^*`) and Problem 2 (is the attack stealthy, caught
   locally, exposed by which safe mode, detected under Algorithm 1 and the schedule, and the
   chain that proves it), with its warnings;
2. the **network** (:func:`glocal_verify.reporting.network_svg.network_svg`) in each mode, when
   the :class:`~glocal_verify.model.System` is given;
3. a **summary** per condition id and the **condition tables**: status, its polarity for the
   defender (✓ favourable, ✗ unfavourable, – vacuous, ? undecided: ``ConditionResult.polarity``), margin, certified error
   bound, tolerance, method (``exact (escalated)`` highlighted), fragile results, notes, and
   the witness in an expandable ``<details>`` element;
4. the **findings** of the run;
5. when simulation results are given, the **residual norms** :math:`\\|r(t)\\|_2` of every
   observer on a log scale (inline SVG), with the switching times and the attack start.

Every user string (node labels, names, descriptions, notes, witnesses) is HTML-escaped.
"""

from __future__ import annotations

import json
import math
from html import escape
from types import MappingProxyType
from typing import Any, Mapping, Sequence

import numpy as np

from glocal_verify.conditions.registry import CATALOGUE
from glocal_verify.model import System
from glocal_verify.reporting.network_svg import network_svg
from glocal_verify.reporting.assessment import assessment_of
from glocal_verify.answer.assessment import Assessment
from glocal_verify.results import ConditionResult, Method, Polarity, Report, jsonable
from glocal_verify.simulation.algorithm1 import Algorithm1Result
from glocal_verify.simulation.schedule import SimulationResult
from glocal_verify.spec.types import NORMAL_MODE
from glocal_verify.words import format_labels, format_lambda

__all__ = [
    "WITNESS_CHARS",
    "residual_svg",
    "to_html",
]

#: witnesses longer than this (as JSON text) are cut in the page
WITNESS_CHARS = 6000

_CSS = """
body { font-family: system-ui, -apple-system, "Segoe UI", sans-serif; margin: 0 auto; max-width: 1150px; padding: 16px 24px; color: #1d1d1d; line-height: 1.4; }
h1 { font-size: 1.6em; margin-bottom: 0.2em; } h2 { border-bottom: 1px solid #ccc; padding-bottom: 3px; margin-top: 1.6em; }
h3 { margin-bottom: 0.3em; } code, pre { font-family: ui-monospace, Menlo, Consolas, monospace; font-size: 0.9em; }
table { border-collapse: collapse; margin: 0.5em 0 1em 0; font-size: 0.92em; } th, td { border: 1px solid #d5d5d5; padding: 3px 7px; text-align: left; vertical-align: top; }
th { background: #f3f3f3; } td.num { text-align: right; font-variant-numeric: tabular-nums; }
.good { color: #1b7a2e; font-weight: bold; } .bad { color: #b3261e; font-weight: bold; } .unknown { color: #8a6d00; font-weight: bold; } .vacuous { color: #666; }
.badge { display: inline-block; padding: 1px 8px; border-radius: 9px; font-weight: bold; color: #fff; }
.badge.good { background: #1b7a2e; color: #fff; } .badge.bad { background: #b3261e; color: #fff; } .badge.unknown { background: #a07c00; color: #fff; }
.fragile { background: #fff2cc; } .escalated { background: #e3ecff; border-radius: 4px; padding: 0 4px; }
.assessment { border: 2px solid #444; border-radius: 8px; padding: 4px 18px 10px 18px; background: #fafafa; }
.warnings { background: #fff4e5; border-left: 4px solid #f77f00; padding: 4px 12px; }
details > summary { cursor: pointer; color: #1f4e9c; } pre.witness { max-height: 360px; overflow: auto; background: #f7f7f7; padding: 6px; white-space: pre-wrap; word-break: break-all; }
.figure { margin: 0.5em 0 1.2em 0; } .meta { color: #555; }
"""

#: a status is coloured by what it means for the defender (green good news, red bad news, grey vacuous)
_POL_CLASS = MappingProxyType({Polarity.FAVOURABLE: "good", Polarity.UNFAVOURABLE: "bad", Polarity.VACUOUS: "vacuous", Polarity.UNDECIDED: "unknown"})


def _e(x: Any) -> str:
    return escape(str(x), quote=True)


def _num(x: Any) -> str:
    if x is None:
        return "-"
    if isinstance(x, float):
        return f"{x:.4g}" if math.isfinite(x) else str(x)
    return _e(x)


def _scope(r: ConditionResult) -> str:
    if not r.scope:
        return "global"
    return ", ".join(f"{k} = {v}" for k, v in r.scope.items())


def _mark(r: ConditionResult) -> str:
    p = r.polarity
    title = {Polarity.FAVOURABLE: "good news for the defender", Polarity.UNFAVOURABLE: "bad news for the defender",
             Polarity.VACUOUS: f"vacuous: {r.premise}", Polarity.UNDECIDED: "undecided"}[p]
    return f'<span class="{_POL_CLASS[p]}" title="{_e(title)}">{p.mark} {p.value}</span>'


def _badge(text: str, good: bool | None) -> str:
    cls = "good" if good is True else "bad" if good is False else "unknown"
    return f'<span class="badge {cls}">{_e(text)}</span>'


def _witness(w: Mapping[str, Any]) -> str:
    text = json.dumps(jsonable(dict(w)), indent=1, ensure_ascii=False)
    if len(text) > WITNESS_CHARS:
        text = text[:WITNESS_CHARS] + f"\n... (cut: {len(text)} characters in all; the JSON report has the whole witness)"
    return f'<details><summary>witness</summary><pre class="witness">{_e(text)}</pre></details>'


# --------------------------------------------------------------------------------------------
# assessment


def _assessment(report: Report) -> tuple[str, Assessment]:
    """The assessment block and the Assessment object."""
    a = assessment_of(report)
    return _assessment_block(a), a


def _assessment_block(a: Assessment) -> str:
    p, at = a.privacy, a.attack
    good = {"protected": True, "exposed": False}
    verdict_good = {"detected": True, "undetected": False}.get(at.verdict)
    out = ['<section class="assessment" id="assessment"><h2>Assessment</h2>']
    if at.present:
        out.append(f"<p><b>Attack:</b> {_badge(at.verdict, verdict_good)} {_e(at.reason)}</p>")
    if a.warnings:
        out.append('<div class="warnings"><b>Warnings</b><ul>' + "".join(f"<li>{_e(w)}</li>" for w in a.warnings) + "</ul></div>")
    out.append(
        "<h3>Privacy (Problem 1)</h3><p>Initial state x(t0): "
        f"{_badge(p.initial_state, good.get(p.initial_state))}; consensus value x*: "
        f"{_badge(p.consensus_value, good.get(p.consensus_value))}. {_e(p.reason)}</p>"
    )
    out.append("<h3>Attack detection (Problem 2)</h3>")
    if not at.present:
        out.append(f"<p>{_e(at.reason)}</p>")
    else:
        kind = {"zda": "zero-dynamics attack (ZDA)", "covert": "covert attack"}.get(at.kind or "", "attack")
        lam = ""
        if at.lambda0 is not None:
            lam = f" at lambda0 = {format_lambda(at.lambda0)}" + (f" ({at.lambda0_source})" if at.lambda0_source and at.lambda0_source != "spec" else "")
        stealth = {True: ("stealthy to the control centre", False), False: ("not stealthy: the control centre sees it", True), None: ("stealth undecided", None)}[at.stealthy]
        items = [f"<li>{_e(kind)} on agents {_e(format_labels(at.actuators))}{_e(lam)}: {_badge(stealth[0], stealth[1])}</li>"]
        if at.stealthy is not False:
            caught = {True: "yes", False: "no", None: "undecided"}[at.caught_locally]
            items.append(f"<li>caught locally: {_badge(caught, at.caught_locally)}<ul>" + "".join(f"<li>{_e(c.cluster or 'no cluster')}: {_e(c.reason)}</li>" for c in at.clusters) + "</ul></li>")
            items.append(
                f"<li>exposed by safe modes: {_e(', '.join(at.exposed_by_modes) or 'none')}"
                + (f"; not exposed by: {_e(', '.join(at.not_exposed_by_modes))}" if at.not_exposed_by_modes else "")
                + (f"; unsettled: {_e(', '.join(at.unsettled_modes))}" if at.unsettled_modes else "")
                + "</li>"
            )
            for r in at.routes:
                items.append(f"<li>{_e(r.name)}: {_badge(r.verdict, {'detected': True, 'undetected': False}.get(r.verdict))} {_e(r.text())}</li>")
        if at.deployment is not None:
            d = at.deployment
            items.append(f"<li>in the sampled deployment (detection.*): {_badge(d.word, d.guaranteed)} {_e(d.reason)}</li>")
        out.append("<ul>" + "".join(items) + "</ul>")
        if at.modes:
            rows = "".join(
                f"<tr><td><code>{_e(m.mode)}</code></td><td>{_badge({True: 'exposes', False: 'does not expose', None: 'unsettled'}[m.exposes], m.exposes)}</td>"
                f"<td>{_e({True: 'detects', False: 'does not detect', None: '-'}[m.simulated])}</td><td>{_e(m.reason)}</td></tr>"
                for m in at.modes
            )
            out.append(f"<table><thead><tr><th>safe mode</th><th>after the switch (algebra)</th><th>simulation</th><th>why</th></tr></thead><tbody>{rows}</tbody></table>")
    if a.based_on:
        out.append(f'<p class="meta">Derived from the results of: {_e(", ".join(a.based_on))}.</p>')
    out.append("</section>")
    return "".join(out)


# --------------------------------------------------------------------------------------------
# conditions


def _polarity(cid: str) -> str:
    info = CATALOGUE.get(cid)
    return str(info.favourable.value) if info is not None else "holds"


def _groups(report: Report) -> list[tuple[str, list[ConditionResult]]]:
    order: list[str] = []
    groups: dict[str, list[ConditionResult]] = {}
    for r in report.conditions:
        if r.id not in groups:
            order.append(r.id)
            groups[r.id] = []
        groups[r.id].append(r)
    return [(cid, groups[cid]) for cid in order]


def _anchor(cid: str) -> str:
    return "cond-" + "".join(c if c.isalnum() else "-" for c in cid)


def _summary(report: Report) -> str:
    rows = []
    for cid, rs in _groups(report):
        n = {pol: sum(1 for r in rs if r.polarity is pol) for pol in Polarity}
        extra = []
        if nf := sum(1 for r in rs if r.fragile):
            extra.append(f"{nf} fragile")
        if ne := sum(1 for r in rs if r.method is Method.ESCALATED):
            extra.append(f"{ne} exact (escalated)")
        rows.append(
            f'<tr><td><a href="#{_anchor(cid)}"><code>{_e(cid)}</code></a></td><td>{_e(rs[0].reference)}</td><td>{_e(_polarity(cid))}</td>'
            f'<td class="num good">{n[Polarity.FAVOURABLE] or ""}</td><td class="num bad">{n[Polarity.UNFAVOURABLE] or ""}</td>'
            f'<td class="num vacuous">{n[Polarity.VACUOUS] or ""}</td><td class="num unknown">{n[Polarity.UNDECIDED] or ""}</td><td>{_e(", ".join(extra))}</td></tr>'
        )
    return (
        "<h2>Summary</h2><p>✓ favourable for the defender, ✗ unfavourable, – vacuous (the condition's premise is absent), ? undecided.</p>"
        "<table><thead><tr><th>condition</th><th>reference</th><th>good news when</th><th>✓ favourable</th><th>✗ unfavourable</th>"
        "<th>– vacuous</th><th>? undecided</th><th>notes</th></tr></thead><tbody>" + "".join(rows) + "</tbody></table>"
    )


def _conditions(report: Report, assessment: Any) -> str:
    out = ["<h2>Conditions</h2>"]
    for cid, rs in _groups(report):
        out.append(
            f'<section id="{_anchor(cid)}"><h3><code>{_e(cid)}</code> ({_e(rs[0].reference)})</h3>'
            f"<p>{_e(rs[0].statement)} Good news for the defender: <b>{_e(_polarity(cid))}</b>.</p>"
            "<table><thead><tr><th>scope</th><th>status</th><th>for the defender</th><th>margin</th><th>error bound</th>"
            "<th>tolerance</th><th>method</th><th>notes</th><th>witness</th></tr></thead><tbody>"
        )
        for r in rs:
            notes = []
            notes += [str(n) for n in assessment.notes_for(r)]
            if r.fragile:
                notes.append("fragile: the margin is below the robustness tolerance (the verdict is certain, but the system is close to the boundary)")
            if r.note:
                notes.append(r.note)
            method = f'<span class="escalated">{_e(r.method.value)}</span>' if r.method is Method.ESCALATED else _e(r.method.value)
            status = f'<span class="{_POL_CLASS[r.polarity]}">{_e(r.status.value)}</span>' + (" <b>(fragile)</b>" if r.fragile else "")
            out.append(
                f'<tr{" class=fragile" if r.fragile else ""}><td>{_e(_scope(r))}</td><td>{status}</td><td>{_mark(r)}</td>'
                f'<td class="num">{_num(r.margin)}</td><td class="num">{_num(r.error_bound)}</td><td class="num">{_num(r.tolerance)}</td>'
                f"<td>{method}</td><td>{'<br>'.join(_e(n) for n in notes)}</td><td>{_witness(r.witness)}</td></tr>"
            )
        out.append("</tbody></table></section>")
    return "".join(out)


def _findings(report: Report) -> str:
    if not report.findings:
        return ""
    items = []
    for f in report.findings:
        ref = f" ({_e(f.reference)})" if f.reference else ""
        data = ""
        if f.data:
            data = f'<details><summary>data</summary><pre class="witness">{_e(json.dumps(jsonable(dict(f.data)), indent=1, ensure_ascii=False)[:WITNESS_CHARS])}</pre></details>'
        items.append(f"<li><b>{_e(f.title)}</b>{ref}: {_e(f.detail)}{data}</li>")
    return "<h2>Findings</h2><ul>" + "".join(items) + "</ul>"


# --------------------------------------------------------------------------------------------
# network and simulation


def _network(system: System) -> str:
    sw = system.spec.switching
    first = sw.mode if sw is not None and sw.mode is not None else NORMAL_MODE
    modes = [first] + [m for m in system.modes if m != first]
    out = ["<h2>Network</h2>"]
    for mode in modes:
        desc = system.spec.mode(mode).description if mode != NORMAL_MODE else "the normal communication graph"
        title = f"mode {mode}" + (f": {desc}" if desc else "")
        out.append(f'<details class="figure"{" open" if mode == first else ""}><summary>{_e(title)}</summary>{network_svg(system, mode)}</details>')
    return "".join(out)


def _nice_step(span: float, n: int = 6) -> float:
    raw = span / max(n, 1)
    mag = 10 ** math.floor(math.log10(raw)) if raw > 0 else 1.0
    for m in (1, 2, 2.5, 5, 10):
        if m * mag >= raw:
            return m * mag
    return 10 * mag


def residual_svg(
    name: str,
    t: np.ndarray,
    r: np.ndarray,
    *,
    switch_times: Sequence[tuple[float, str]] = (),
    attack_start: float | None = None,
    width: int = 760,
    height: int = 220,
) -> str:
    """The residual norm :math:`\\|r(t)\\|_2` of one observer, log scale, as inline SVG.

    Parameters
    ----------
    name : str
        Observer name (title of the plot).
    t : ndarray
        Sample times (K + 1,).
    r : ndarray
        Residual samples (K + 1, q) (or (K + 1,)).
    switch_times : sequence of (float, str)
        Times and names of the modes switched to (dashed vertical lines).
    attack_start : float, optional
        Attack start (red vertical line).
    width, height : int
        Size in pixels.

    Notes
    -----
    At most about 600 points are drawn: each drawn point is the maximum of the norm over its
    bin of samples, so no peak is hidden. Norms below 1e-18 are drawn at 1e-18.
    """
    tt = np.asarray(t, dtype=float)
    rr = np.asarray(r, dtype=float)
    norm = np.sqrt(np.sum(rr * rr, axis=1)) if rr.ndim == 2 else np.abs(rr)
    ok = np.isfinite(norm) & np.isfinite(tt)
    left, right, top, bottom = 62, 14, 24, 30
    head = f'<svg xmlns="http://www.w3.org/2000/svg" class="residual" viewBox="0 0 {width} {height}" width="{width}" height="{height}" font-family="sans-serif" font-size="10">'
    title = f'<text x="{left}" y="15" font-weight="bold" font-size="12">{_e(name)}: ||r(t)||</text>'
    if not np.any(ok):
        return head + title + f'<text x="{left}" y="{height // 2}">no samples</text></svg>'
    tt, norm = tt[ok], np.maximum(norm[ok], 1e-18)
    bins = max(1, int(math.ceil(len(tt) / 600)))
    k = (len(tt) // bins) * bins
    tb = list(tt[:k:bins]) + ([float(tt[k])] if k < len(tt) else [])
    nb = list(norm[:k].reshape(-1, bins).max(axis=1)) + ([float(norm[k:].max())] if k < len(tt) else [])
    logs = np.log10(np.array(nb))
    y_lo, y_hi = math.floor(float(logs.min())), math.ceil(float(logs.max()))
    if y_hi - y_lo < 1:
        y_hi = y_lo + 1
    t0, t1 = float(tt[0]), float(tt[-1]) if tt[-1] > tt[0] else float(tt[0]) + 1.0
    pw, ph = width - left - right, height - top - bottom

    def px(x: float) -> float:
        return left + (x - t0) / (t1 - t0) * pw

    def py(v: float) -> float:
        return top + (y_hi - v) / (y_hi - y_lo) * ph

    parts = [head, title, f'<rect x="{left}" y="{top}" width="{pw}" height="{ph}" fill="#ffffff" stroke="#888888"/>']
    dec = max(1, int(math.ceil((y_hi - y_lo) / 8)))
    for v in range(y_lo, y_hi + 1, dec):
        parts.append(f'<line x1="{left}" y1="{py(v):.1f}" x2="{left + pw}" y2="{py(v):.1f}" stroke="#e5e5e5"/>')
        parts.append(f'<text x="{left - 4}" y="{py(v) + 3:.1f}" text-anchor="end">1e{v}</text>')
    step = _nice_step(t1 - t0)
    x = math.ceil(t0 / step) * step
    while x <= t1 + 1e-9 * step:
        parts.append(f'<text x="{px(x):.1f}" y="{top + ph + 13}" text-anchor="middle">{x:g}</text>')
        x += step
    parts.append(f'<text x="{left + pw / 2:.0f}" y="{height - 3}" text-anchor="middle">time t</text>')
    for ts, mode in switch_times:
        if t0 <= ts <= t1:
            parts.append(
                f'<line x1="{px(ts):.1f}" y1="{top}" x2="{px(ts):.1f}" y2="{top + ph}" stroke="#f77f00" stroke-dasharray="5 3"><title>switch to {_e(mode)} at t = {ts:g}</title></line>'
                f'<text x="{px(ts) + 3:.1f}" y="{top + 10}" fill="#f77f00">{_e(mode)}</text>'
            )
    if attack_start is not None and t0 <= attack_start <= t1:
        parts.append(f'<line x1="{px(attack_start):.1f}" y1="{top}" x2="{px(attack_start):.1f}" y2="{top + ph}" stroke="#d62828"><title>attack starts at t = {attack_start:g}</title></line>')
    pts = " ".join(f"{px(a):.1f},{py(b):.1f}" for a, b in zip(tb, logs))
    parts.append(f'<polyline fill="none" stroke="#1f4e9c" stroke-width="1.4" points="{pts}"/>')
    parts.append("</svg>")
    return "".join(parts)


def _runs(simulation: Any) -> list[tuple[str, SimulationResult]]:
    if simulation is None:
        return []
    if isinstance(simulation, SimulationResult):
        return [("simulation", simulation)]
    if isinstance(simulation, Algorithm1Result):
        return [("Algorithm 1", simulation.simulation)]
    if isinstance(simulation, Mapping):
        out: list[tuple[str, SimulationResult]] = []
        for name, run in simulation.items():
            out += [(f"{name}" if len(_runs(run)) == 1 else f"{name}: {sub}", res) for sub, res in _runs(run)]
        return out
    raise TypeError(f"simulation must be a SimulationResult, an Algorithm1Result or a mapping of them, got {type(simulation).__name__}")


def _simulation(simulation: Any) -> str:
    runs = _runs(simulation)
    if not runs:
        return ""
    out = ["<h2>Simulation: residuals</h2>", "<p>Euclidean norm of each observer's residual over time (log scale); orange dashed: topology switch; red: attack start.</p>"]
    for run_name, res in runs:
        segs = res.schedule.segments
        switches = [(t, m) for t, m in segs[1:]]
        start = res.attack.start if res.attack is not None else None
        out.append(f"<h3>{_e(run_name)}</h3><p class=meta>method {_e(res.method)}, {len(res.t)} samples" + (", interrupted" if res.interrupted else "") + "</p>")
        if not res.residuals:
            out.append("<p>No observer was simulated.</p>")
        for obs, arr in res.residuals.items():
            out.append(f'<div class="figure">{residual_svg(obs, res.t, arr, switch_times=switches, attack_start=start)}</div>')
    return "".join(out)


# --------------------------------------------------------------------------------------------
# page


def to_html(report: Report, system: System | None = None, simulation: Any = None) -> str:
    """The report as one self-contained HTML page (module docstring for its contents).

    Parameters
    ----------
    report : Report
        The verification report.
    system : System, optional
        The system the report is about; when given, the network is drawn in every mode
        (the spec's switching mode first).
    simulation : SimulationResult, Algorithm1Result or mapping of them, optional
        Runs whose observer residuals are plotted (a mapping gives each run a name).

    Returns
    -------
    str
        HTML5 text: inline CSS and SVG only, no script and no external resource; every user
        string is escaped.
    """
    s = report.system
    block, assessment = _assessment(report)
    opts = report.options
    method = "exact (rational arithmetic)" if opts.get("exact") else "numeric"
    meta = (
        f"{s.agents} agents; modes: {', '.join(s.modes)}"
        + (f"; clusters: {', '.join(s.clusters)}" if s.clusters else "")
        + f"; method: {method}; rtol = {opts.get('rtol')}"
    )
    desc = system.spec.description if system is not None else ""
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        f"<title>glocal-verify report: {_e(s.name)}</title>",
        f"<style>{_CSS}</style></head><body>",
        f"<h1>glocal-verify report: {_e(s.name)}</h1>",
        f'<p class="meta">{_e(meta)}</p>',
    ]
    if desc:
        parts.append(f"<p>{_e(desc)}</p>")
    parts.append(block)
    if system is not None:
        parts.append(_network(system))
    parts += [_summary(report), _conditions(report, assessment), _findings(report), _simulation(simulation)]
    parts.append('<p class="meta">Generated by glocal-verify. Witnesses prove the verdicts; the JSON report (--format json) holds them in full.</p>')
    parts.append("</body></html>")
    return "\n".join(p for p in parts if p) + "\n"
