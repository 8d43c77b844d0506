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
from glocal_verify.answer.assessment import Assessment
from glocal_verify.reporting.assessment import assessment_of
from glocal_verify.results import ConditionResult, Method, Polarity, Report, json_preview
from glocal_verify.words import format_labels, format_lambda, sentence

__all__ = [
    "LEGEND",
    "attack_lines",
    "polarity_counts",
    "report_schema",
    "to_json_text",
    "to_markdown",
    "to_html_text",
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
    """The report as JSON text, its assessment included (schema ``glocal-verify/report@1``)."""
    assessment_of(report)
    return json.dumps(report.to_json(), indent=2, allow_nan=False) + "\n"


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
#: the legend of the polarity marks (one vocabulary: results.Polarity)
LEGEND = "✓ favourable for the defender, ✗ unfavourable, – vacuous (the condition's premise is absent), ? undecided."

#: what the scope key ``suspected`` means, for the summary rows
_SUSPECTED = MappingProxyType({"attack": "suspected = the spec's attacked agents", "all": "suspected = all (worst case, Remark III.2.1)"})


def _polarity(cid: str) -> str:
    info = CATALOGUE.get(cid)
    return str(info.favourable.value) if info is not None else "holds"


def _scope_set(rs: list[ConditionResult], suspected: str) -> str:
    """What the results of one summary row range over: ``global``, ``every mode and the schedule`` ..."""
    if suspected:
        return _SUSPECTED.get(suspected, suspected)
    modes = [r for r in rs if "mode" in r.scope]
    if not modes:
        return "global" if len(rs) == 1 else f"{len(rs)} scopes"
    return "each mode" + (" and the schedule" if len(modes) < len(rs) else "")


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
    return [(cid, _scope_set(groups[(cid, sus)], sus), groups[(cid, sus)]) for cid, sus in order]


def polarity_counts(rs: list[ConditionResult]) -> dict[Polarity, int]:
    """How many of ``rs`` are favourable, unfavourable, vacuous and undecided."""
    return {p: sum(1 for r in rs if r.polarity is p) for p in Polarity}


def _result_notes(r: ConditionResult, a: Assessment) -> str:
    notes = a.notes_for(r)
    if r.fragile:
        notes.append(f"fragile: margin {_fmt_num(r.margin)} is below the robustness tolerance")
    if r.method is Method.ESCALATED and not r.note.startswith("escalated"):
        notes.append("escalated to exact arithmetic")
    if r.note:
        notes.append(r.note)
    return "; ".join(n.replace("|", "/") for n in notes)


def attack_lines(a: Assessment) -> list[str]:
    """The attack's answer as Markdown lines (shared by the report and the notebook displays)."""
    at = a.attack
    if not at.present:
        return [f"**Attack (Problem 2).** {sentence(at.reason or 'not assessed')}"]
    kind = {"zda": "ZDA", "covert": "covert attack"}.get(at.kind or "", "attack")
    lam = ""
    if at.lambda0 is not None:
        src = "from the spec" if at.lambda0_source == "spec" else at.lambda0_source
        lam = f" at lambda0 = {format_lambda(at.lambda0)} ({src})"
    who = f"agent{'s' if len(at.actuators) != 1 else ''} {format_labels(at.actuators)}"
    stealth = {True: "yes", False: "**no**: the control centre sees it before any switch", None: "*undecided*"}[at.stealthy]
    lines = [f"**Attack (Problem 2): {at.verdict_words()}.** The {kind} on {who}{lam}.", "", f"- stealthy to the control centre: {stealth}"]
    if at.stealthy is not False:
        caught = {True: "yes", False: "**no**", None: "*undecided*"}[at.caught_locally]
        lines.append(f"- caught locally: {caught}" + "".join(f"; {c.cluster or 'no cluster'}: {c.reason}" for c in at.clusters))
        exposed = f"- exposed by safe modes: {', '.join(at.exposed_by_modes) or 'none'}"
        exposed += f"; not exposed by: {', '.join(at.not_exposed_by_modes)}" if at.not_exposed_by_modes else ""
        exposed += f"; unsettled: {', '.join(at.unsettled_modes)}" if at.unsettled_modes else ""
        lines.append(exposed)
        for m in at.modes:
            ans = {True: "exposes", False: "does not expose", None: "unsettled"}[m.exposes]
            lines.append(f"  - `{m.mode}` {ans}: {m.reason}" + (f" (fragile: {m.fragile})" if m.fragile else ""))
        for r in at.routes:
            title = {"algorithm 1": "Algorithm 1 (a local alarm triggers the switch)", "schedule": "the [switching] schedule (switches whatever the observers see)"}.get(r.name, r.name)
            lines.append(f"- {title}: **{r.verdict}**: {r.text()}")
    if at.deployment is not None:
        lines.append(f"- in the sampled deployment (detection.*): **{at.deployment.word}**: {at.deployment.reason}")
    return lines


def _assessment_markdown(a: Assessment, report: Report) -> list[str]:
    p = a.privacy
    lines = ["## Assessment", ""]
    if a.warnings:
        lines += ["**Warnings**", ""] + [f"- {w}" for w in a.warnings] + [""]
    lines.append(f"**Privacy (Problem 1).** Initial state x(t0): **{p.initial_state}**; consensus value x*: **{p.consensus_value}**. {p.reason}")
    lines += ["", *attack_lines(a)]
    if a.attack.present and not report.options.get("simulate"):
        lines.append("- simulation (switching.detects): not run (verify simulates on networks of at most 150 agents: simulate='auto'; 'always' forces it)")
    lines += ["", f"Derived from the results of: {', '.join(f'`{c}`' for c in a.based_on) or 'none'} (rules: docs/conditions.md, \"The answer for one attacker\" and \"The assessment\")."]
    return lines


def to_markdown(report: Report) -> str:
    """Human-readable report: the assessment, a summary table and one section per condition id.

    The assessment the report carries (:func:`~glocal_verify.reporting.assessment.assessment_of`) comes first. The
    summary has one row per condition id and scope set (the ``local.*`` ids get separate rows
    for the spec's suspected set and the worst case ``suspected = all``) with the status that
    is favourable for the defender and the count of each polarity; each result row shows its
    polarity (:data:`LEGEND`) and notes for fragile, escalated and vacuous results.
    """
    s = report.system
    a = assessment_of(report)
    lines = [f"# glocal-verify report: {s.name}", ""]
    lines += _assessment_markdown(a, report)
    lines += ["", "## System", "", f"- agents: {s.agents}", f"- modes: {', '.join(s.modes)}"]
    if s.clusters:
        lines.append(f"- clusters: {', '.join(s.clusters)}")
    opts = report.options
    lines.append(f"- method: {'exact (rational arithmetic)' if opts.get('exact') else 'numeric'}; rtol = {opts.get('rtol')}, band = {opts.get('band')}")
    by_reason: dict[str, list[str]] = {}
    for cid, why in (opts.get("skipped") or {}).items():
        if cid not in a.not_evaluated:  # those have their row in the summary
            by_reason.setdefault(why, []).append(f"`{cid}`")
    for why, ids in by_reason.items():
        lines.append(f"- not evaluated, {why}: {', '.join(ids)}")
    lines += [
        "",
        "## Summary",
        "",
        LEGEND,
        "",
        "| condition | scopes | reference | good news when | ✓ | ✗ | – | ? | notes |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for cid, scopes, rs in _summary_groups(report):
        n = polarity_counts(rs)
        extra = []
        nf = sum(1 for r in rs if r.fragile)
        ne = sum(1 for r in rs if r.method is Method.ESCALATED)
        if nf:
            extra.append(f"{nf} fragile")
        if ne:
            extra.append(f"{ne} escalated")
        extra += sorted({n for r in rs for n in a.notes_for(r)})
        counts = " | ".join(str(n[p]) for p in (Polarity.FAVOURABLE, Polarity.UNFAVOURABLE, Polarity.VACUOUS, Polarity.UNDECIDED))
        lines.append(f"| `{cid}` | {scopes} | {rs[0].reference} | {_polarity(cid)} | {counts} | {'; '.join(extra)} |")
    for cid, why in a.not_evaluated.items():
        info = CATALOGUE.get(cid)
        lines.append(f"| `{cid}` | - | {info.reference if info else ''} | {_polarity(cid)} | - | - | - | - | not evaluated: {why} |")
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
            "| scope | status | for the defender | margin | method | witness | notes |",
            "|---|---|---|---|---|---|---|",
        ]
        for r in rs:
            status = _ICON[r.status.value] + (" (fragile)" if r.fragile else "")
            lines.append(
                f"| {_scope(r)} | {status} | {r.polarity.mark} {r.polarity.value} | {_fmt_num(r.margin)} | {r.method.value} | `{_short(r.witness)}` | {_result_notes(r, a)} |"
            )
    if report.findings:
        lines += ["", "## Findings", ""]
        for f in report.findings:
            ref = f" ({f.reference})" if f.reference else ""
            lines.append(f"- **{f.title}**{ref}: {f.detail}")
    lines.append("")
    return "\n".join(lines)


def to_html_text(report: Report) -> str:
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
    assessment_of(report)
    return str(fn(report))


def render(report: Report, fmt: str) -> str:
    """Render ``report`` in ``fmt``: ``"json"`` (schema ``glocal-verify/report@1``), ``"markdown"`` or ``"html"``.

    Every format starts with the assessment the report carries (:func:`~glocal_verify.reporting.assessment.assessment_of`):
    the JSON carries it as ``assessment``, Markdown as its first section. ``"html"`` needs the
    optional module :mod:`glocal_verify.reporting.html` (:class:`GlocalVerifyError` otherwise).
    """
    if fmt == "json":
        return to_json_text(report)
    if fmt == "markdown":
        return to_markdown(report)
    if fmt == "html":
        return to_html_text(report)
    raise ValueError(f"unknown format {fmt!r} (expected one of {', '.join(FORMATS)})")
