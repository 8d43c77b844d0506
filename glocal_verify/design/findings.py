"""The counterexample specs, verified: what ``reports/findings.md`` shows.

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

:func:`verify_findings` verifies every spec with the listed conditions (numeric and exact),
checks that the verdicts match ``expect`` and runs the proof checks that exhibit paper errors
(they need sympy, ``pip install 'glocal-verify[proofs]'``; without it the report says they were
not run);
:func:`glocal_verify.reporting.findings.findings_markdown` renders the result with the textual
findings (places where the paper is inconsistent without a system to show it,
:data:`TEXTUAL_FINDINGS`). Regenerate with ``glocal-verify findings``.
"""

from __future__ import annotations

import importlib.util
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from glocal_verify.conditions.registry import implemented_ids, check_conditions
from glocal_verify.errors import SpecError, shorten
from glocal_verify.model import System
from glocal_verify.results import ALIASES, ConditionResult
from glocal_verify.spec import load_spec, loads_spec
from glocal_verify.spec.examples import example_text, finding_names

__all__ = [
    "CaseCheck",
    "FindingCase",
    "FindingsCheck",
    "PROOFS_INSTALL",
    "TEXTUAL_FINDINGS",
    "load_cases",
    "check_case",
    "proof_findings",
    "proofs_available",
    "verify_findings",
]

#: the command that installs what the proof-check section needs
PROOFS_INSTALL = "pip install 'glocal-verify[proofs]'"

TEXTUAL_FINDINGS: tuple[tuple[str, str, str], ...] = (
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
    (
        "Eqs. E_definition, uio_conds_1: one decoupling matrix h^i for every mode",
        "Section III.C, eqs. E_definition, obs_decent, uio_conds_1",
        "E^i is defined for sigma = 1 only and h^i carries no mode, while F, K and A-bar switch with sigma. A safe mode "
        "that adds an inter-cluster link at an agent without outside neighbour adds a column to E^i_q, and "
        "(h^i C - I) E^i_q != 0: the normal-mode h^i no longer decouples the neighbours. In the designed paper19 "
        "(tests/data/paper19-designed.toml) P2@10 in mode designed-3 (link 7-9) and P3@13 in designed-1 (link 12-17) "
        "then have residuals of order 0.1 with only agents outside their clusters moving. The toolkit designs h_q per "
        "mode (observers/uio_modes.py) and resets z <- z + (h_p - h_q) y at the switch, which keeps x_hat and the error "
        "continuous (tests/test_deployment.py checks both).",
    ),
)


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
    if directory is None:
        specs = [(name, True, loads_spec(example_text(name), source=f"<example {name}>")) for name in finding_names()]
    else:
        folder = Path(directory)
        if not os.path.isdir(folder):  # False, not an OSError, for a name too long to exist
            raise SpecError("", f"{shorten(str(folder), 120)} is not a folder of counterexample specs")
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
    results = list(check_conditions(case.system, ids, exact=exact).conditions) if ids else []
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


@dataclass(frozen=True, slots=True)
class CaseCheck:
    """One counterexample spec verified numerically and exactly.

    Attributes
    ----------
    case : FindingCase
    numeric, exact : list of ConditionResult
    numeric_problems, exact_problems : list of str
        Unmet expectations (empty when the case is confirmed).
    """

    case: FindingCase
    numeric: list[ConditionResult]
    exact: list[ConditionResult]
    numeric_problems: list[str]
    exact_problems: list[str]


@dataclass(frozen=True, slots=True)
class FindingsCheck:
    """Every counterexample spec of a folder, verified, and the paper errors of the proof checks.

    Attributes
    ----------
    cases : tuple of CaseCheck
    proofs : tuple of (step, equation, explanation, verdict) or None
        :func:`proof_findings`; None when not run.
    directory : str or None
        The folder the specs came from (None: the bundled ones).
    proofs_missing : bool
        The proof checks were asked for but sympy is not installed.
    """

    cases: tuple[CaseCheck, ...]
    proofs: tuple[tuple[str, str, str, str], ...] | None = None
    directory: str | None = None
    proofs_missing: bool = False


def verify_findings(directory: str | Path | None = None, proofs: bool = True) -> FindingsCheck:
    """Verify every counterexample spec (numeric and exact) and, with ``proofs``, run the proof
    checks that exhibit paper errors (when sympy is installed).

    Parameters
    ----------
    directory : path, optional
        A folder of counterexample specs; default: the ones bundled with the package.
    proofs : bool
    """
    checks = []
    for case in load_cases(directory):
        num, pn = check_case(case)
        exa, pe = check_case(case, exact=True)
        checks.append(CaseCheck(case, num, exa, pn, pe))
    run = proofs and proofs_available()
    where = None if directory is None else Path(directory).as_posix()
    return FindingsCheck(tuple(checks), tuple(proof_findings()) if run else None, where, proofs and not run)
