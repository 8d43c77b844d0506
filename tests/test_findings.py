"""Every bundled counterexample spec (``findings/NAME``) still produces the verdicts it documents."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from glocal_verify.cli import main
from glocal_verify.design.findings import check_case, load_cases, verify_findings
from glocal_verify.reporting.findings import findings_markdown

CASES = load_cases()


@pytest.mark.parametrize("case", CASES, ids=[c.source.removeprefix("findings/") for c in CASES])
@pytest.mark.parametrize("exact", [False, True])
def test_each_counterexample_reproduces_its_documented_verdicts(case, exact: bool) -> None:  # type: ignore[no-untyped-def]
    _, problems = check_case(case, exact=exact)
    assert problems == []


def test_the_findings_report_regenerates_and_confirms_every_case(tmp_path: Path) -> None:
    text = findings_markdown(verify_findings())
    assert "NOT CONFIRMED" not in text
    assert "UNEXPECTED-PASS" not in text and "| ERROR |" not in text and "| UNDECIDED |" not in text
    assert text.count("\n## ") >= len(CASES) and "Paper errors exhibited by the proof checks" in text
    out = tmp_path / "findings.md"
    assert main(["findings", "--out", str(out)]) == 0
    assert out.read_text() == text


def test_every_counterexample_the_report_names_can_be_run_as_it_says(capsys: pytest.CaptureFixture[str]) -> None:
    text = findings_markdown(verify_findings(proofs=False))
    names = re.findall(r"^- counterexample: `([^`]+)`", text, flags=re.M)
    assert names == [c.source for c in CASES]
    commands = re.findall(r"^- reproduce: `glocal-verify (verify --example \S+ --only \S+ --exact)`", text, flags=re.M)
    assert len(commands) == len(CASES)
    assert main(commands[0].split() + ["--quiet", "--escalate", "never"]) == 0
    assert "glocal_verify/data/" not in text and "reports/findings/" not in text


def test_a_folder_of_specs_is_named_by_its_paths_and_an_empty_one_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from glocal_verify.spec.examples import example_text

    folder = tmp_path / "mine"
    folder.mkdir()
    (folder / "covert.toml").write_text(example_text("findings/prop-ii4-covert-needs-sensors"), encoding="utf-8")
    text = findings_markdown(verify_findings(folder, proofs=False))
    path = (folder / "covert.toml").as_posix()
    assert f"- counterexample: `{path}`" in text and f"glocal-verify verify {path} --only" in text
    empty = tmp_path / "empty"
    empty.mkdir()
    assert main(["findings", "--dir", str(empty)]) == 2
    err = capsys.readouterr().err
    assert "no counterexample specs (*.toml) in" in err and len(err.strip().splitlines()) == 1
