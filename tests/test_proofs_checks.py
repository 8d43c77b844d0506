"""The proof checks of ``python -m proofs_checks``, run in-process so that CI covers them.

Every step must come out as expected: ordinary steps PASS, documented paper errors
EXPECTED-FAIL. A FAIL, UNEXPECTED-PASS, UNDECIDED or ERROR anywhere fails the suite.
"""

from __future__ import annotations

import json

import pytest
import sympy as sp

from proofs_checks import MODULES, all_steps, run
from proofs_checks.__main__ import main
from proofs_checks.core import (
    Decision,
    Step,
    Summary,
    Verdict,
    check,
    decide_zero,
    select,
)


@pytest.fixture(scope="module")
def outcomes():
    return run(all_steps())


@pytest.mark.slow
def test_every_proof_step_comes_out_as_expected(outcomes):
    bad = [
        f"{o.step.qualname} [{o.step.equation}]: {o.verdict.value} {o.error or o.residual[:300]}"
        for o in outcomes
        if not o.verdict.ok
    ]
    assert not bad, "\n".join(bad)
    assert Summary.of(outcomes).exit_status == 0


def test_every_module_contributes_steps(outcomes):
    assert {o.step.module for o in outcomes} == set(MODULES)


def test_paper_errors_are_expected_failures_with_an_explanation(outcomes):
    errors = [o for o in outcomes if o.step.paper_error]
    assert len(errors) >= 10
    for o in errors:
        assert o.verdict is Verdict.EXPECTED_FAIL, o.step.qualname
        assert o.step.note, o.step.qualname


def test_step_names_are_unique_and_cite_an_equation():
    steps = all_steps()
    names = [s.qualname for s in steps]
    assert len(names) == len(set(names))
    assert all(s.equation and s.reference for s in steps)


def test_non_commutative_block_identity_is_decided_zero():
    A, B = sp.symbols("A B", commutative=False)
    a = sp.Symbol("a")
    assert decide_zero((A + B) ** 2 - A**2 - A * B - B * A - B**2) is Decision.ZERO
    assert decide_zero(a / a * A * B - A * B) is Decision.ZERO
    assert decide_zero(A * B - B * A) is Decision.NONZERO


def test_floats_are_rejected_in_residuals():
    step = Step("demo", "float", "none", "none", sp.Float(0.5) * sp.Symbol("x"))
    outcome = check(step)
    assert outcome.verdict is Verdict.ERROR and "floating-point" in outcome.error


def test_a_paper_error_that_no_longer_shows_is_an_unexpected_pass():
    step = Step("demo", "gone", "none", "none", sp.Integer(0), expected="nonzero", paper_error="claimed error")
    outcome = check(step)
    assert outcome.verdict is Verdict.UNEXPECTED_PASS
    assert Summary.of([outcome]).exit_status == 1


def test_a_symbol_residual_is_a_value_not_a_builder():
    x = sp.Symbol("x")
    assert check(Step("demo", "symbol", "none", "none", x)).verdict is Verdict.FAIL


def test_only_selects_modules_and_steps_and_suggests_close_names():
    steps = all_steps()
    assert {s.module for s in select(steps, ["lemma_iii1"])} == {"lemma_iii1"}
    assert [s.name for s in select(steps, ["appendix_c.worst_case_B_breaks_iii"])] == ["worst_case_B_breaks_iii"]
    with pytest.raises(KeyError, match="lemma_iii1"):
        select(steps, ["lemma_iii"])


def test_cli_runs_a_module_and_reports_json(capsys):
    assert main(["--only", "lemma_iii1", "--format", "json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["exit_status"] == 0
    assert {s["verdict"] for s in data["steps"]} == {"PASS"}


def test_cli_lists_without_running_and_rejects_unknown_names(capsys):
    assert main(["--list"]) == 0
    assert "worst_case_B_breaks_iii" in capsys.readouterr().out
    assert main(["--only", "no_such_check"]) == 2


def test_readme_lists_every_step():
    from pathlib import Path

    import proofs_checks

    readme = (Path(proofs_checks.__file__).parent / "README.md").read_text()
    missing = [s.qualname for s in all_steps() if f"| `{s.name}` |" not in readme]
    assert not missing, missing
