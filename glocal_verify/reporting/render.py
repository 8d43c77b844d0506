"""Rendering of a :class:`~glocal_verify.results.Report` as JSON, Markdown or HTML, each led by the assessment.

The JSON shape is ``glocal-verify/report@1``, described by the JSON Schema shipped in
``glocal_verify/reporting/schemas/report.schema.json`` (:func:`report_schema`).
"""

from __future__ import annotations

import importlib
import json
from importlib import resources
from types import MappingProxyType
from typing import Any

import jsonschema

from glocal_verify.conditions.registry import CATALOGUE
from glocal_verify.errors import GlocalVerifyError
from glocal_verify.reporting.assessment import DETECTS_MAX_AGENTS, Assessment, assess, with_assessment
from glocal_verify.results import ConditionResult, Method, Report, json_preview

__all__ = [
    "report_schema",
    "to_json_text",
    "to_markdown",
    "to_html",
    "validate_report_json",
    "render",
]

#: the formats of :func:`render` (``html`` needs the optional :mod:`glocal_verify.reporting.html`)
FORMATS = ("json", "markdown", "html")


def report_schema() -> dict[str, Any]:
    """The JSON Schema of the report (draft 2020-12)."""
    return json.loads(resources.files("glocal_verify.reporting").joinpath("schemas/report.schema.json").read_text())


def validate_report_json(data: dict[str, Any]) -> None:
    """Raise :class:`jsonschema.ValidationError` if ``data`` is not a valid report."""
    jsonschema.Draft202012Validator(report_schema()).validate(data)


def to_json_text(report: Report) -> str:
    """The report as JSON text, with its assessment attached (schema ``glocal-verify/report@1``)."""
    return json.dumps(with_assessment(report).to_json(), indent=2, allow_nan=False) + "\n"


def _fmt_num(x: Any) -> str:
    if x is None:
        return "-"
    if isinstance(x, float):
        return f"{x:.4g}"
    return str(x)


def _scope(r: ConditionResult) -> str:
    if not r.scope:
        return "global"
    return ", ".join(f"{k}={v}" for k, v in r.scope.items())


def _short(obj: Any, limit: int = 110) -> str:
    return json_preview(obj, limit)


_ICON = MappingProxyType({"holds": "holds", "fails": "**fails**", "undecided": "*undecided*"})
_FAV = MappingProxyType({True: "✓", False: "✗", None: "?"})

#: what the scope key ``suspected`` means, for the summary rows
_SUSPECTED = MappingProxyType({"attack": "suspected = the spec's attacked agents", "all": "suspected = all (worst case, Remark III.2.1)"})


def _polarity(cid: str) -> str:
    info = CATALOGUE.get(cid)
    return str(info.favourable.value) if info is not None else "holds"


def _summary_groups(report: Report) -> list[tuple[str, str, list[ConditionResult]]]:
    """(id, scope set, results): one row per id, split by ``suspected`` (spec's set vs worst case)."""
    order: list[tuple[str, str]] = []
    groups: dict[tuple[str, str], list[ConditionResult]] = {}
    for r in report.conditions:
        key = (r.id, str(r.scope.get("suspected", "")))
        if key not in groups:
            order.append(key)
            groups[key] = []
        groups[key].append(r)
    return [(cid, _SUSPECTED.get(sus, ""), groups[(cid, sus)]) for cid, sus in order]


def _result_notes(r: ConditionResult, a: Assessment) -> str:
    notes = a.notes_for(r)
    if r.fragile:
        notes.append(f"fragile: margin {_fmt_num(r.margin)} is below the robustness tolerance")
    if r.method is Method.ESCALATED:
        notes.append("escalated to exact arithmetic")
    if r.note:
        notes.append(r.note)
    return "; ".join(n.replace("|", "/") for n in notes)


def _assessment_markdown(a: Assessment) -> list[str]:
    p, at = a.privacy, a.attack
    lines = ["## Assessment", ""]
    if a.warnings:
        lines += ["**Warnings**", ""] + [f"- {w}" for w in a.warnings] + [""]
    lines.append(f"**Privacy (Problem 1).** Initial state x(t0): **{p.initial_state}**; consensus value x*: **{p.consensus_value}**. {p.reason}")
    lines.append("")
    if not at.present:
        lines.append(f"**Attack (Problem 2).** {at.reason[0].upper() + at.reason[1:]}")
    else:
        kind = {"zda": "ZDA", "covert": "covert attack"}.get(at.kind or "", "attack")
        lam = ""
        if at.lambda0 is not None:
            src = "from the spec" if at.lambda0_source == "spec" else str(at.lambda0_source)
            lam = f" at lambda0 = {_fmt_lambda(at.lambda0)} ({src})"
        stealth = {True: "stealthy to the control centre", False: "**not stealthy**: the control centre sees it", None: "stealth *undecided*"}[at.stealthy]
        caught = ", ".join(f"observer {c.observer} ({c.cluster})" for c in at.caught_locally_by) or "no local observer"
        lines += [
            f"**Attack (Problem 2).** {kind} on agents {', '.join(str(x) for x in at.actuators)}{lam}: {stealth}.",
            "",
            f"- caught locally by: {caught}",
            f"- exposed by safe modes: {', '.join(at.exposed_by_modes) or 'none'}"
            + (f"; not exposed by: {', '.join(at.not_exposed_by_modes)}" if at.not_exposed_by_modes else "")
            + (f"; unsettled: {', '.join(at.unsettled_modes)}" if at.unsettled_modes else ""),
        ]
        for m in at.modes:
            ans = {True: "exposes", False: "does not expose", None: "unsettled"}[m.exposes]
            lines.append(f"  - `{m.mode}` {ans} ({m.by}): {m.reason}")
        if not at.simulated:
            lines.append(
                f"- switching.detects (simulation) was not run: verify(..., options={{'simulate': True}}) runs it on networks of at most {DETECTS_MAX_AGENTS} agents"
            )
        lines += ["", f"**Verdict: {at.verdict}.** {at.reason}"]
    lines += ["", f"Derived from the results of: {', '.join(f'`{c}`' for c in a.based_on) or 'none'} (rules: docs/conditions.md, \"The assessment\")."]
    return lines


def to_markdown(report: Report) -> str:
    """Human-readable report: the assessment, a summary table and one section per condition id.

    The assessment (:func:`~glocal_verify.reporting.assessment.assess`) comes first. The
    summary has one row per condition id and scope set (the ``local.*`` ids get separate rows
    for the spec's suspected set and the worst case ``suspected = all``) with the status that
    is favourable for the defender; each result row shows ✓ (favourable), ✗ (unfavourable) or
    ? (undecided) and notes for fragile, escalated and vacuous results.
    """
    s = report.system
    a = assess(report)
    lines = [f"# glocal-verify report: {s.name}", ""]
    lines += _assessment_markdown(a)
    lines += ["", "## System", "", f"- agents: {s.agents}", f"- modes: {', '.join(s.modes)}"]
    if s.clusters:
        lines.append(f"- clusters: {', '.join(s.clusters)}")
    opts = report.options
    lines.append(f"- method: {'exact (rational arithmetic)' if opts.get('exact') else 'numeric'}; rtol = {opts.get('rtol')}, band = {opts.get('band')}")
    lines += [
        "",
        "## Summary",
        "",
        "✓ favourable for the defender, ✗ unfavourable, ? undecided.",
        "",
        "| condition | scopes | reference | good news when | ✓ | ✗ | ? | notes |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for cid, scopes, rs in _summary_groups(report):
        fav = sum(1 for r in rs if r.favourable is True)
        unfav = sum(1 for r in rs if r.favourable is False)
        und = sum(1 for r in rs if r.favourable is None)
        extra = []
        nf = sum(1 for r in rs if r.fragile)
        ne = sum(1 for r in rs if r.method is Method.ESCALATED)
        if nf:
            extra.append(f"{nf} fragile")
        if ne:
            extra.append(f"{ne} escalated")
        extra += sorted({n for r in rs for n in a.notes_for(r)})
        lines.append(f"| `{cid}` | {scopes or '-'} | {rs[0].reference} | {_polarity(cid)} | {fav} | {unfav} | {und} | {'; '.join(extra)} |")
    for cid, why in a.not_evaluated.items():
        info = CATALOGUE.get(cid)
        lines.append(f"| `{cid}` | - | {info.reference if info else ''} | {_polarity(cid)} | - | - | - | not evaluated: {why} |")
    order: list[str] = []
    for r in report.conditions:
        if r.id not in order:
            order.append(r.id)
    for cid in order:
        rs = report.results(cid)
        lines += [
            "",
            f"## `{cid}` ({rs[0].reference})",
            "",
            f"{rs[0].statement} Good news for the defender: `{_polarity(cid)}`.",
            "",
            "| scope | status | good? | margin | method | witness | notes |",
            "|---|---|---|---|---|---|---|",
        ]
        for r in rs:
            status = _ICON[r.status.value] + (" (fragile)" if r.fragile else "")
            lines.append(
                f"| {_scope(r)} | {status} | {_FAV[r.favourable]} | {_fmt_num(r.margin)} | {r.method.value} | `{_short(r.witness)}` | {_result_notes(r, a)} |"
            )
    if report.findings:
        lines += ["", "## Findings", ""]
        for f in report.findings:
            ref = f" ({f.reference})" if f.reference else ""
            lines.append(f"- **{f.title}**{ref}: {f.detail}")
    lines.append("")
    return "\n".join(lines)


def _fmt_lambda(lam: tuple[float, float]) -> str:
    re_, im_ = lam
    return f"{re_:g}" if im_ == 0.0 else f"{re_:g} {'+' if im_ > 0 else '-'} {abs(im_):g}i"


def to_html(report: Report) -> str:
    """The report as a self-contained HTML page (:mod:`glocal_verify.reporting.html`, optional).

    Raises
    ------
    GlocalVerifyError
        When the HTML renderer is not available in this installation.
    """
    try:
        module = importlib.import_module("glocal_verify.reporting.html")
    except ModuleNotFoundError as exc:
        if exc.name not in ("glocal_verify.reporting.html",):
            raise
        raise GlocalVerifyError("the html format is not available: glocal_verify.reporting.html is not installed (use --format markdown or json)") from None
    fn = getattr(module, "to_html", None)
    if fn is None:
        raise GlocalVerifyError("the html format is not available: glocal_verify.reporting.html has no to_html(report)")
    return str(fn(with_assessment(report)))


def render(report: Report, fmt: str) -> str:
    """Render ``report`` in ``fmt``: ``"json"`` (schema ``glocal-verify/report@1``), ``"markdown"`` or ``"html"``.

    Every format starts with the assessment (:func:`~glocal_verify.reporting.assessment.assess`):
    the JSON carries it as ``assessment``, Markdown as its first section. ``"html"`` needs the
    optional module :mod:`glocal_verify.reporting.html` (:class:`GlocalVerifyError` otherwise).
    """
    if fmt == "json":
        return to_json_text(report)
    if fmt == "markdown":
        return to_markdown(report)
    if fmt == "html":
        return to_html(report)
    raise ValueError(f"unknown format {fmt!r} (expected one of {', '.join(FORMATS)})")
