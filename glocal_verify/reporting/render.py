"""Rendering of a :class:`~glocal_verify.results.Report` as JSON or Markdown.

The JSON shape is ``glocal-verify/report@1``, described by the JSON Schema shipped in
``glocal_verify/reporting/schemas/report.schema.json`` (:func:`report_schema`).
"""

from __future__ import annotations

import json
from importlib import resources
from typing import Any

import jsonschema

from glocal_verify.results import ConditionResult, Report, jsonable

__all__ = [
    "report_schema",
    "to_json_text",
    "to_markdown",
    "validate_report_json",
    "render",
]

FORMATS = ("json", "markdown")


def report_schema() -> dict[str, Any]:
    """The JSON Schema of the report (draft 2020-12)."""
    return json.loads(resources.files("glocal_verify.reporting").joinpath("schemas/report.schema.json").read_text())


def validate_report_json(data: dict[str, Any]) -> None:
    """Raise :class:`jsonschema.ValidationError` if ``data`` is not a valid report."""
    jsonschema.Draft202012Validator(report_schema()).validate(data)


def to_json_text(report: Report) -> str:
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
    text = json.dumps(jsonable(obj), separators=(", ", ": "))
    return text if len(text) <= limit else text[: limit - 3] + "..."


_ICON = {"holds": "holds", "fails": "**fails**", "undecided": "*undecided*"}


def to_markdown(report: Report) -> str:
    """Human-readable report: a summary table and one section per condition id."""
    s = report.system
    lines = [
        f"# glocal-verify report: {s.name}",
        "",
        f"- agents: {s.agents}",
        f"- modes: {', '.join(s.modes)}",
    ]
    if s.clusters:
        lines.append(f"- clusters: {', '.join(s.clusters)}")
    opts = report.options
    lines.append(f"- method: {'exact (rational arithmetic)' if opts.get('exact') else 'numeric'}; rtol = {opts.get('rtol')}, band = {opts.get('band')}")
    lines += ["", "## Summary", "", "| condition | reference | holds | fails | undecided |", "|---|---|---|---|---|"]
    order: list[str] = []
    for r in report.conditions:
        if r.id not in order:
            order.append(r.id)
    for cid in order:
        rs = report.results(cid)
        counts = {k: sum(1 for r in rs if r.status.value == k) for k in ("holds", "fails", "undecided")}
        lines.append(f"| `{cid}` | {rs[0].reference} | {counts['holds']} | {counts['fails']} | {counts['undecided']} |")
    for cid in order:
        rs = report.results(cid)
        lines += ["", f"## `{cid}` ({rs[0].reference})", "", rs[0].statement, "", "| scope | status | margin | method | witness |", "|---|---|---|---|---|"]
        for r in rs:
            lines.append(f"| {_scope(r)} | {_ICON[r.status.value]} | {_fmt_num(r.margin)} | {r.method.value} | `{_short(r.witness)}` |")
    if report.findings:
        lines += ["", "## Findings", ""]
        for f in report.findings:
            ref = f" ({f.reference})" if f.reference else ""
            lines.append(f"- **{f.title}**{ref}: {f.detail}")
    lines.append("")
    return "\n".join(lines)


def render(report: Report, fmt: str) -> str:
    """Render ``report`` in ``fmt``: ``"json"`` (schema ``glocal-verify/report@1``) or ``"markdown"``."""
    if fmt == "json":
        return to_json_text(report)
    if fmt == "markdown":
        return to_markdown(report)
    raise ValueError(f"unknown format {fmt!r} (expected one of {', '.join(FORMATS)})")
