"""An audit as text: its JSON streamed row by row, and its Markdown table.

Both render an :class:`~glocal_verify.design.audit_records.AuditResult` as it is given; the
JSON is exactly ``json.dumps(result.to_json(), indent=2)`` (schema ``glocal-verify/audit@1``,
``reporting/schemas/audit.schema.json``).
"""

from __future__ import annotations

import json
from collections.abc import Iterator

from glocal_verify.design.audit_records import AuditResult
from glocal_verify.numerics.collection import deferred_full_collections
from glocal_verify.reporting.audit_json import IndentedJson
from glocal_verify.results import audit_jsonable

__all__ = ["audit_json_chunks", "audit_markdown"]


def audit_json_chunks(result: AuditResult) -> Iterator[str]:
    """``json.dumps(result.to_json(), indent=2)``, one row at a time.

    The text is the same, but only one row's JSON form exists at any moment: an audit of
    500,500 sets writes about 1.4 GB of JSON, which as one document would take several
    times that in memory.
    """
    head = json.dumps(result.json_head(), indent=2)
    yield head[: -len("\n}")] + ',\n  "rows": ['
    writer = IndentedJson()
    with deferred_full_collections():  # the rows are millions of live objects: no full collection rescans them meanwhile
        for k, r in enumerate(result.rows):
            yield ("\n    " if k == 0 else ",\n    ") + writer.text(r.json_form(), 2)
    yield ("\n  ]" if result.rows else "]") + ',\n  "summary": ' + json.dumps(audit_jsonable(result.summary()), indent=2).replace("\n", "\n  ") + "\n}"


def audit_markdown(result: AuditResult) -> str:
    """A table with one line per set, the undetected sets first."""
    s = result.summary()
    c = s["counts"]
    lines = [
        f"# Attack audit: {result.system}",
        "",
        (f"{s['sets']} sets of 1..{result.max_attackers} compromised actuators: {c['detected']} detected, "
        f"{c['undetected']} undetected, {c['undecided']} undecided; {s['stealthy']} admit a stealthy ZDA."),
        "",
        "Safe modes meeting Theorem III.3 (i)-(iii): "
        + (", ".join(m for m, ok in result.modes.items() if ok) or "none"),
        "",
        "| actuators | stealthy | growth | lambda0 | caught locally by | exposed by modes | verdict | why |",
        "|---|---|---|---|---|---|---|---|",
    ]
    order = {"undetected": 0, "undecided": 1, "detected": 2}
    for r in sorted(result.rows, key=lambda r: order[r.verdict]):
        lam = "-" if r.lambda0 is None else f"{r.lambda0.real:.4g}{'' if r.lambda0.imag == 0 else f'{r.lambda0.imag:+.4g}i'}"
        caught = ", ".join(f"{cl}@{o}" for cl, o in r.caught_locally_by) or "-"
        st = "undecided" if r.stealthy is None else ("yes" if r.stealthy else "no")
        why = r.chain.replace("|", "/")
        lines.append(
            f"| {', '.join(map(str, r.actuators))} | {st} | {r.growth} | {lam} | {caught} | {', '.join(r.exposed_by_modes) or '-'} | {r.verdict} | {why} |"
        )
    return "\n".join(lines) + "\n"
