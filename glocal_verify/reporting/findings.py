"""Generate ``reports/findings.md`` from the bundled counterexample specs.

The counterexamples ship with the package (``glocal_verify/spec/data/findings/*.toml``, the
bundled examples ``findings/NAME``: ``glocal-verify example findings/NAME`` prints one), so
``glocal-verify findings`` writes the same report from an installed wheel as from the
repository. Each is a system specification with a ``[finding]`` table::

    [finding]
    claim = "Remark III.2.1: B^i = I can be used to select local monitors"
    reference = "Remark III.2.1"
    paper_says = "..."
    explanation = "..."
    conditions = ["local.pencil"]
    expect = [{id = "local.pencil", status = "fails", suspected = "all"}]

:func:`build_findings_report` verifies every spec with the listed conditions (numeric and
exact), checks that the verdicts match ``expect`` and renders the Markdown (the paper errors
of ``proofs_checks`` need sympy, ``pip install 'glocal-verify[proofs]'``; without it the report
says they were not run); textual findings
(places where the paper is inconsistent without a system to show it) are listed from
:data:`TEXTUAL_FINDINGS`. Regenerate with ``glocal-verify findings``.
"""

from __future__ import annotations

import importlib.util
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

from glocal_verify.conditions.registry import implemented_ids, verify
from glocal_verify.errors import SpecError
from glocal_verify.model import System
from glocal_verify.reporting.words import counted
from glocal_verify.results import ALIASES, ConditionResult, json_preview
from glocal_verify.spec import load_spec, loads_spec
from glocal_verify.spec.examples import example_text, finding_names

__all__ = [
    "FindingCase",
    "TEXTUAL_FINDINGS",
    "load_cases",
    "check_case",
    "proofs_available",
    "build_findings_report",
]

#: the command that installs what the proof-check section needs
PROOFS_INSTALL = "pip install 'glocal-verify[proofs]'"

TEXTUAL_FINDINGS: list[tuple[str, str, str]] = [
    (
        "Section IV: global residual indices",
        "Section IV",
        "The text fixes the global monitors as M_v = {7, 12, 14} but then names the global residuals "
        "r_{0_i}, i in {1, 12, 14}; agent 1 is not monitored. The bundled paper19 follows M_v = {7, 12, 14}.",
    ),
    (
        "Section IV: Figure 2 is missing",
        "Section IV, Figure 2",
        "The communication topology of the example exists only as an empty \\includegraphics; "
        "the bundled example paper19 (`glocal-verify example paper19` prints it) reconstructs a graph "
        "that fits every sentence and cites them.",
    ),
]


@dataclass(frozen=True, slots=True)
class FindingCase:
    """A counterexample spec with its claim and the verdicts it must produce.

    ``source`` is how the report names it: the bundled example ``findings/NAME``, or the file
    path of a spec read from a folder (``--dir``); ``bundled`` says which.
    """

    source: str
    bundled: bool
    system: System
    claim: str
    reference: str
    paper_says: str
    explanation: str
    conditions: tuple[str, ...]
    expect: tuple[dict[str, Any], ...]


def load_cases(directory: str | Path | None = None) -> list[FindingCase]:
    """The counterexample specs bundled with the package (``directory`` None, sorted by name)
    or those of ``directory`` (its ``*.toml`` files, sorted by file name).

    Raises
    ------
    SpecError
        When ``directory`` holds no ``*.toml`` file or a spec has no ``[finding]`` table.
    """
    specs = []
    if directory is None:
        specs = [(name, True, loads_spec(example_text(name), source=f"<example {name}>")) for name in finding_names()]
    else:
        folder = Path(directory)
        if not folder.is_dir():
            raise SpecError("", f"{folder} is not a folder of counterexample specs")
        specs = [(p.as_posix(), False, load_spec(p)) for p in sorted(folder.glob("*.toml"))]
    if not specs:
        where = "the package (its data folder glocal_verify/spec/data/findings/ is missing)" if directory is None else str(directory)
        raise SpecError("", f"no counterexample specs (*.toml) in {where}")
    out = []
    for source, bundled, spec in specs:
        f = spec.finding
        if not f:
            raise SpecError("finding", "a findings spec needs a [finding] table", source)
        out.append(
            FindingCase(
                source,
                bundled,
                System(spec),
                str(f["claim"]),
                str(f["reference"]),
                str(f.get("paper_says", "")),
                str(f.get("explanation", "")),
                tuple(ALIASES.get(c, c) for c in f.get("conditions", [])),
                tuple({**dict(e), "id": ALIASES.get(e["id"], e["id"])} for e in f.get("expect", [])),
            )
        )
    return out


def _matches(r: ConditionResult, e: dict[str, Any]) -> bool:
    if r.id != e["id"]:
        return False
    return all(r.scope.get(k) == v for k, v in e.items() if k not in ("id", "status"))


def check_case(case: FindingCase, exact: bool = False) -> tuple[list[ConditionResult], list[str]]:
    """Verify a case; return its results and the list of unmet expectations (empty if all met)."""
    ids = [c for c in case.conditions if c in implemented_ids()]
    results = list(verify(case.system, ids, exact=exact).conditions) if ids else []
    problems = []
    for e in case.expect:
        if e["id"] not in implemented_ids():
            problems.append(f"{e['id']}: not implemented")
            continue
        hits = [r for r in results if _matches(r, e)]
        if not hits:
            problems.append(f"{e['id']} {e}: no matching result")
        for r in hits:
            if r.status.value != e["status"]:
                problems.append(f"{e['id']} {dict(r.scope)}: expected {e['status']}, got {r.status.value}")
    return results, problems


def _short(obj: Any, limit: int = 140) -> str:
    return json_preview(obj, limit)


def proofs_available() -> bool:
    """Whether the proof checks can run (they need sympy, the ``proofs`` extra)."""
    return importlib.util.find_spec("sympy") is not None


def proof_findings() -> list[tuple[str, str, str, str]]:
    """Paper errors documented by ``proofs_checks``: (step, equation, explanation, verdict).

    Only the steps marked as paper errors are run (each is an exact symbolic or rational
    computation); the verdict is ``EXPECTED-FAIL`` when the error is confirmed.
    """
    from proofs_checks.core import all_steps, check

    out = []
    for step in all_steps():
        if step.paper_error:
            o = check(step)
            out.append((f"{step.module}.{step.name}", step.equation, step.paper_error, o.verdict.value))
    return out


def build_findings_report(
    directory: str | Path | None = None, extra: Sequence[tuple[str, str, str]] = (), proofs: bool = True
) -> str:
    """Markdown of every finding: counterexample specs (verified now), the paper errors that
    ``proofs_checks`` exhibits (run now when ``proofs``; a line says they were not run when
    sympy is missing, see :func:`proofs_available`) and textual findings.

    Parameters
    ----------
    directory : str or Path, optional
        A folder of counterexample specs; default: the ones bundled with the package.
    extra : sequence of (title, reference, detail)
        More textual findings.
    proofs : bool
        Run the proof checks' paper errors.
    """
    cases = load_cases(directory)
    origin = (
        "the counterexample specs bundled with\nthe package (the examples `findings/NAME`: `glocal-verify example findings/NAME` prints one)"
        if directory is None
        else f"the specs in `{Path(directory).as_posix()}`"
    )
    lines = [
        "# Findings: where the paper is loose or wrong",
        "",
        f"Generated by `glocal-verify findings` from {origin}; never edited by hand.",
        "Each counterexample is reproducible with the command shown; the verdicts below were computed",
        "when this file was generated, numerically and in exact rational arithmetic.",
        "",
    ]
    for k, case in enumerate(cases, 1):
        num, pn = check_case(case)
        exa, pe = check_case(case, exact=True)
        only = ",".join(case.conditions)
        arg = f"--example {case.source}" if case.bundled else case.source
        lines += [
            f"## {k}. {case.claim}",
            "",
            f"- paper: {case.reference}" + (f" — {case.paper_says}" if case.paper_says else ""),
            f"- counterexample: `{case.source}` ({counted(case.system.n, 'agent')})",
            f"- reproduce: `glocal-verify verify {arg}" + (f" --only {only}" if only else "") + " --exact`",
        ]
        if case.explanation:
            lines.append(f"- why: {case.explanation}")
        status = "confirmed" if not pn and not pe else "NOT CONFIRMED: " + "; ".join(pn + pe)
        lines += [f"- status: {status}", "", "| condition | scope | numeric | exact | witness (exact) |", "|---|---|---|---|---|"]
        for rn in num:
            re_ = next((r for r in exa if r.id == rn.id and dict(r.scope) == dict(rn.scope)), None)
            scope = ", ".join(f"{a}={b}" for a, b in rn.scope.items()) or "global"
            lines.append(
                f"| `{rn.id}` | {scope} | {rn.status.value} | {re_.status.value if re_ else '-'} | `{_short(re_.witness if re_ else rn.witness)}` |"
            )
        lines.append("")
    if proofs and not proofs_available():
        lines += [
            "## Paper errors exhibited by the proof checks",
            "",
            f"Not run: the proof checks need sympy (`{PROOFS_INSTALL}`).",
            "",
        ]
    elif proofs:
        rows = proof_findings()
        lines += [
            "## Paper errors exhibited by the proof checks",
            "",
            "Each is a step of `python -m proofs_checks` (exact symbolic or rational computation); "
            "reproduce one with `python -m proofs_checks --only <step>`.",
            "",
            "| step | paper equation | what is wrong | verdict |",
            "|---|---|---|---|",
        ]
        for name, eq, why, verdict in rows:
            lines.append(f"| `{name}` | `{eq}` | {why} | {verdict} |")
        lines.append("")
    all_textual = list(TEXTUAL_FINDINGS) + list(extra)
    if all_textual:
        lines += ["## Findings in the text", ""]
        for title, ref, detail in all_textual:
            lines.append(f"- **{title}** ({ref}): {detail}")
        lines.append("")
    return "\n".join(lines)
