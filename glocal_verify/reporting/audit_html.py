"""An attack audit as one self-contained HTML page.

:func:`audit_to_html` turns an :class:`~glocal_verify.design.audit.AuditResult` (the rows of
:func:`glocal_verify.design.audit.audit`, one per set F of compromised actuators) into a
single page with everything inline: CSS in a ``<style>`` element, the figures as inline SVG,
no script, no font, no image or link to fetch. The page shows, in order:

1. the **summary**: counts per verdict (``undetected``, ``undecided``, ``detected``) overall
   and per set size, and how many sets admit a stealthy ZDA (Proposition II.4 (ii));
2. the **Theorem III.3 verdicts per safe mode** the audit used: (i)-(iii) all hold, some fail,
   or undecided, with the number of sets each mode exposes (Remark III.3.1: the switch
   touches every stealthy direction, ``switching.avoids-attack`` fails);
3. the **figures**: for k >= 2 the agent x agent verdict heat map of
   :func:`glocal_verify.reporting.figures.audit.verdict_matrix` (cell (i, j) the set {i, j}, the
   diagonal {i}), for k = 1 one bar per agent; and the number of sets each admissible safe
   mode exposes;
4. the **table**, one row per set, the undetected sets first, then the undecided ones, then
   the detected ones (each group in the audit's order): actuators, stealthy, growth,
   lambda0, caught locally by (cluster@observer), exposed by modes, verdict, and the reason.

Every spec-provided string (system name, agent labels, cluster and mode names) is
HTML-escaped; numbers are formatted here. The page is a view of the audit: every verdict is
the audit's, nothing is re-decided.
"""

from __future__ import annotations

from html import escape
from types import MappingProxyType
from typing import Any

import numpy as np

from glocal_verify.design.audit import AuditResult, AuditRow
from glocal_verify.reporting.figures.audit import verdict_matrix

__all__ = ["VERDICT_ORDER", "audit_to_html", "exposure_svg", "heatmap_svg", "ordered_rows"]

#: the order of the table's groups (bad news first)
VERDICT_ORDER = ("undetected", "undecided", "detected")

_COLOUR = MappingProxyType({"detected": "#4caf50", "undecided": "#ffc107", "undetected": "#e53935"})
_CLASS = MappingProxyType({"detected": "good", "undecided": "unknown", "undetected": "bad"})

_CSS = """
body { font-family: system-ui, -apple-system, "Segoe UI", sans-serif; margin: 0 auto; max-width: 1150px; padding: 16px 24px; color: #1d1d1d; line-height: 1.4; }
h1 { font-size: 1.6em; margin-bottom: 0.2em; } h2 { border-bottom: 1px solid #ccc; padding-bottom: 3px; margin-top: 1.6em; }
code { font-family: ui-monospace, Menlo, Consolas, monospace; font-size: 0.9em; }
table { border-collapse: collapse; margin: 0.5em 0 1em 0; font-size: 0.92em; } th, td { border: 1px solid #d5d5d5; padding: 3px 7px; text-align: left; vertical-align: top; }
th { background: #f3f3f3; } td.num { text-align: right; font-variant-numeric: tabular-nums; }
.good { color: #1b7a2e; font-weight: bold; } .bad { color: #b3261e; font-weight: bold; } .unknown { color: #8a6d00; font-weight: bold; }
tr.undetected { background: #fdecea; } tr.undecided { background: #fff8e1; }
.figure { margin: 0.5em 0 1.2em 0; overflow-x: auto; } .meta { color: #555; } .reason { color: #555; font-size: 0.9em; }
"""


def _e(x: Any) -> str:
    return escape(str(x), quote=True)


def _lam(z: complex | None) -> str:
    if z is None:
        return "-"
    if z.imag == 0:
        return f"{z.real:.4g}"
    return f"{z.real:.4g}{z.imag:+.4g}i"


def _tri(x: bool | None, yes: str = "yes", no: str = "no") -> str:
    return "undecided" if x is None else (yes if x else no)


def ordered_rows(result: AuditResult) -> list[AuditRow]:
    """The rows, undetected first, then undecided, then detected (stable within a group).

    Parameters
    ----------
    result : AuditResult
    """
    rank = {v: i for i, v in enumerate(VERDICT_ORDER)}
    return sorted(result.rows, key=lambda r: rank.get(r.verdict, len(rank)))


# ------------------------------------------------------------------------------------------
# figures


def heatmap_svg(result: AuditResult, *, cell: int | None = None) -> str:
    """The verdict heat map (k >= 2) or the per-agent bars (k = 1) as inline SVG.

    Parameters
    ----------
    result : AuditResult
    cell : int, optional
        Cell size in pixels (default from the number of candidates, 6..22).

    Returns
    -------
    str
        An ``<svg>`` element; each cell carries a ``<title>`` naming its set and verdict.
        Cells without a row (sets larger than two, or pairs outside the audit) stay blank.
    """
    labels = [str(a) for a in result.candidates]
    n = len(labels)
    names = {0.0: "detected", 1.0: "undecided", 2.0: "undetected"}
    if cell is None:
        cell = max(6, min(22, 640 // max(n, 1)))
    show = n <= 60
    pad = 8 + (max((len(s) for s in labels), default=1) * 7 if show else 0)
    parts: list[str] = []
    if result.max_attackers >= 2:
        M = verdict_matrix(result)
        size = pad + n * cell + 8
        parts.append(f'<svg xmlns="http://www.w3.org/2000/svg" class="heatmap" viewBox="0 0 {size} {size}" width="{size}" height="{size}" font-family="sans-serif" font-size="10">')
        parts.append(f'<rect x="{pad}" y="{pad}" width="{n * cell}" height="{n * cell}" fill="#ffffff" stroke="#888888"/>')
        for i in range(n):
            for j in range(n):
                v = M[i, j]
                if np.isnan(v):
                    continue
                verdict = names[float(v)]
                what = f"{{{labels[i]}}}" if i == j else f"{{{labels[min(i, j)]}, {labels[max(i, j)]}}}"
                parts.append(
                    f'<rect x="{pad + j * cell}" y="{pad + i * cell}" width="{cell}" height="{cell}" fill="{_COLOUR[verdict]}">'
                    f"<title>{_e(what)}: {verdict}</title></rect>"
                )
        if show:
            for i, s in enumerate(labels):
                c = pad + i * cell + cell / 2
                parts.append(f'<text x="{pad - 3}" y="{c + 3:.1f}" text-anchor="end">{_e(s)}</text>')
                parts.append(f'<text x="{c:.1f}" y="{pad - 3}" text-anchor="start" transform="rotate(-90 {c:.1f} {pad - 3})">{_e(s)}</text>')
    else:
        singles = {r.actuators[0]: r.verdict for r in result.rows if len(r.actuators) == 1}
        width, height = pad + n * cell + 8, 40 + (pad if show else 0)
        parts.append(f'<svg xmlns="http://www.w3.org/2000/svg" class="heatmap" viewBox="0 0 {width} {height}" width="{width}" height="{height}" font-family="sans-serif" font-size="10">')
        for i, a in enumerate(result.candidates):
            single = singles.get(a)
            if single is None:
                continue
            parts.append(f'<rect x="{pad + i * cell}" y="8" width="{cell}" height="24" fill="{_COLOUR[single]}"><title>{{{_e(a)}}}: {single}</title></rect>')
            if show:
                c = pad + i * cell + cell / 2
                parts.append(f'<text x="{c:.1f}" y="36" text-anchor="end" transform="rotate(-90 {c:.1f} 36)">{_e(a)}</text>')
    parts.append("</svg>")
    return "".join(parts)


def exposure_svg(result: AuditResult, *, width: int = 560) -> str:
    """Bars: for each safe mode of the audit, the number of sets it exposes, as inline SVG.

    Parameters
    ----------
    result : AuditResult
    width : int
        Width in pixels.

    Returns
    -------
    str
        An ``<svg>`` element (empty string when the system has no safe mode). A mode whose
        Theorem III.3 verdict is not ``holds`` exposes nothing by definition; its bar is
        drawn grey with its verdict.
    """
    modes = list(result.modes)
    if not modes:
        return ""
    counts = {m: sum(1 for r in result.rows if m in r.exposed_by_modes) for m in modes}
    top = max(max(counts.values()), 1)
    left, bar, gap = 140, 18, 6
    height = 12 + len(modes) * (bar + gap)
    pw = width - left - 60
    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" class="exposure" viewBox="0 0 {width} {height}" width="{width}" height="{height}" font-family="sans-serif" font-size="11">']
    for k, m in enumerate(modes):
        y = 6 + k * (bar + gap)
        ok = result.modes[m]
        w = pw * counts[m] / top
        fill = "#1f4e9c" if ok else "#9e9e9e"
        parts.append(f'<text x="{left - 6}" y="{y + bar - 5}" text-anchor="end">{_e(m)}</text>')
        parts.append(f'<rect x="{left}" y="{y}" width="{w:.1f}" height="{bar}" fill="{fill}"><title>{_e(m)}: exposes {counts[m]} set(s); Theorem III.3 {_tri(ok, "holds", "fails")}</title></rect>')
        note = f"{counts[m]}" if ok else f"{counts[m]} (Theorem III.3 {_tri(ok, 'holds', 'fails')})"
        parts.append(f'<text x="{left + w + 4:.1f}" y="{y + bar - 5}">{_e(note)}</text>')
    parts.append("</svg>")
    return "".join(parts)


# ------------------------------------------------------------------------------------------
# page


def _summary(result: AuditResult) -> str:
    s = result.summary()
    c = s["counts"]
    head = "".join(f"<th>{v}</th>" for v in VERDICT_ORDER)
    rows = [f'<tr><td>all</td><td class="num">{s["sets"]}</td>' + "".join(f'<td class="num {_CLASS[v]}">{c[v]}</td>' for v in VERDICT_ORDER) + "</tr>"]
    for size, d in sorted(s["by_size"].items(), key=lambda kv: int(kv[0])):
        rows.append(f'<tr><td>|F| = {_e(size)}</td><td class="num">{sum(d.values())}</td>' + "".join(f'<td class="num">{d[v]}</td>' for v in VERDICT_ORDER) + "</tr>")
    return (
        "<h2>Summary</h2>"
        f"<p>{s['sets']} sets of {'1' if result.max_attackers == 1 else f'1..{result.max_attackers}'} compromised actuator(s) among {len(result.candidates)} candidate agents: "
        f'<span class="bad">{c["undetected"]} undetected</span>, <span class="unknown">{c["undecided"]} undecided</span>, '
        f'<span class="good">{c["detected"]} detected</span>; {s["stealthy"]} admit a stealthy ZDA (Proposition II.4 (ii)).</p>'
        f"<table><thead><tr><th>sets</th><th>count</th>{head}</tr></thead><tbody>{''.join(rows)}</tbody></table>"
    )


def _modes(result: AuditResult) -> str:
    if not result.modes:
        return "<h2>Safe modes (Theorem III.3)</h2><p>The system has no safe mode: no set can be exposed by a switch.</p>"
    rows = []
    for m, ok in result.modes.items():
        n = sum(1 for r in result.rows if m in r.exposed_by_modes)
        verdict = _tri(ok, "(i)-(iii) hold", "some of (i)-(iii) fail")
        cls = _CLASS["detected" if ok else "undecided" if ok is None else "undetected"]
        rows.append(f'<tr><td><code>{_e(m)}</code></td><td class="{cls}">{verdict}</td><td class="num">{n}</td></tr>')
    return (
        "<h2>Safe modes (Theorem III.3)</h2>"
        "<p>A safe mode can expose a stealthy attack only when Theorem III.3 (i)-(iii) hold for it; it exposes a set when the "
        "switch touches every stealthy direction at lambda0 (Remark III.3.1, <code>switching.avoids-attack</code> fails).</p>"
        f"<table><thead><tr><th>mode</th><th>Theorem III.3</th><th>sets exposed</th></tr></thead><tbody>{''.join(rows)}</tbody></table>"
    )


def _figures(result: AuditResult) -> str:
    what = "agent x agent: cell (i, j) is the set {i, j}, the diagonal {i}" if result.max_attackers >= 2 else "one bar per agent"
    out = [
        "<h2>Who can hide</h2>",
        f'<p class="meta">{what}; green detected, amber undecided, red undetected (hover a cell for its set).</p>',
        f'<div class="figure">{heatmap_svg(result)}</div>',
    ]
    ex = exposure_svg(result)
    if ex:
        out += ['<p class="meta">Sets exposed by each safe mode (grey: Theorem III.3 does not hold or is undecided).</p>', f'<div class="figure">{ex}</div>']
    return "".join(out)


def _table(result: AuditResult) -> str:
    out = [
        "<h2>Attack sets</h2>",
        (
            '<table class="audit"><thead><tr><th>actuators</th><th>stealthy</th><th>growth</th><th>lambda0</th>'
            "<th>caught locally by</th><th>exposed by modes</th><th>verdict</th></tr></thead><tbody>"
        ),
    ]
    for r in ordered_rows(result):
        caught = ", ".join(f"{c}@{o}" for c, o in r.caught_locally_by) or "-"
        reason = str(r.witness.get("reason", ""))
        out.append(
            f'<tr class="{_e(r.verdict)}"><td>{_e(", ".join(map(str, r.actuators)))}</td><td>{_tri(r.stealthy)}</td><td>{_e(r.growth)}</td>'
            f'<td class="num">{_lam(r.lambda0)}</td><td>{_e(caught)}</td><td>{_e(", ".join(r.exposed_by_modes) or "-")}</td>'
            f'<td><span class="{_CLASS.get(r.verdict, "unknown")}">{_e(r.verdict)}</span>'
            + (f'<div class="reason">{_e(reason)}</div>' if reason else "")
            + "</td></tr>"
        )
    out.append("</tbody></table>")
    return "".join(out)


def audit_to_html(result: AuditResult) -> str:
    """The audit as one self-contained HTML page (module docstring for its contents).

    Parameters
    ----------
    result : AuditResult
        The audit, e.g. ``audit(system, 2)``.

    Returns
    -------
    str
        HTML5 text: inline CSS and SVG only, no script and no external resource; every
        spec-provided string is escaped. The table holds every row of ``result``.
    """
    title = f"glocal-verify attack audit: {result.system}"
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        f"<title>{_e(title)}</title>",
        f"<style>{_CSS}</style></head><body>",
        f"<h1>{_e(title)}</h1>",
        f'<p class="meta">{result.n} agents; candidates: {_e(", ".join(map(str, result.candidates)))}; k = {result.max_attackers}</p>',
        _summary(result),
        _modes(result),
        _figures(result),
        _table(result),
        '<p class="meta">Generated by glocal-verify. The JSON audit (--format json) holds every witness in full.</p>',
        "</body></html>",
    ]
    return "\n".join(parts) + "\n"
