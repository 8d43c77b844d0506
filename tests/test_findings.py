"""Every counterexample spec under reports/findings/ still produces the verdicts it documents."""

from __future__ import annotations

from pathlib import Path

import pytest

from glocal_verify.cli import main
from glocal_verify.design.findings import check_case, load_cases, verify_findings
from glocal_verify.reporting.findings import findings_markdown

ROOT = Path(__file__).resolve().parent.parent
CASES = load_cases(ROOT / "reports" / "findings")


@pytest.mark.parametrize("case", CASES, ids=[c.path.stem for c in CASES])
@pytest.mark.parametrize("exact", [False, True])
def test_each_counterexample_reproduces_its_documented_verdicts(case, exact: bool) -> None:  # type: ignore[no-untyped-def]
    _, problems = check_case(case, exact=exact)
    assert problems == []


def test_the_findings_report_regenerates_and_confirms_every_case(tmp_path: Path) -> None:
    text = findings_markdown(verify_findings(ROOT / "reports" / "findings"))
    assert "NOT CONFIRMED" not in text
    assert "UNEXPECTED-PASS" not in text and "| ERROR |" not in text and "| UNDECIDED |" not in text
    out = tmp_path / "findings.md"
    assert main(["findings", "--dir", str(ROOT / "reports" / "findings"), "--out", str(out)]) == 0
    assert out.read_text().startswith("# Findings")
