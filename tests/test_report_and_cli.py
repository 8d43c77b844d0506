"""The report: JSON schema, Markdown, --only, --require, --exact and the example command."""

from __future__ import annotations

import json
from pathlib import Path

import jsonschema
import pytest

from glocal_verify import System, load_example, validate_report_json, verify
from glocal_verify.cli import main
from glocal_verify.conditions.registry import CATALOGUE, resolve_ids
from glocal_verify.errors import UnknownConditionError


@pytest.fixture(scope="module")
def paper19() -> System:
    return System(load_example("paper19"))


def test_the_json_report_validates_against_its_schema(paper19: System) -> None:
    for exact in (False, True):
        data = verify(paper19, exact=exact).to_json()
        validate_report_json(data)
        assert data["schema"] == "glocal-verify/report@1"
        system = {k: data["system"][k] for k in ("name", "agents", "modes", "clusters")}
        assert system == {"name": "paper19", "agents": 19, "modes": ["normal", "case-1", "case-2", "case-3"], "clusters": ["P1", "P2", "P3"]}
        assert data["system"]["attack"]["by_cluster"] == [{"cluster": "P1", "agents": [3, 4], "observers": [5, 6]}]
        assert data["system"]["schedule"]["modes"] == ["case-2"] and data["system"]["monitored"] is True


def test_the_schema_rejects_a_report_with_a_bad_status(paper19: System) -> None:
    data = verify(paper19).to_json()
    data["conditions"][0]["status"] = "maybe"
    with pytest.raises(jsonschema.ValidationError):
        validate_report_json(data)


def test_cli_writes_json_to_a_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "report.json"
    assert main(["verify", "--example", "paper19", "--format", "json", "--out", str(out), "--quiet"]) == 0
    data = json.loads(out.read_text())
    validate_report_json(data)
    ids = {c["id"] for c in data["conditions"]}
    assert {"privacy.connected", "privacy.kernel", "switching.image-kernel", "switching.distinct-eigenvalues", "switching.coverage"} <= ids
    for c in data["conditions"]:
        if c["id"].startswith("switching."):
            assert c["scope"]["mode"] in {"case-1", "case-2", "case-3"}


def test_markdown_report_has_a_summary_and_a_section_per_condition(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["verify", "--example", "paper19"]) == 0
    md = capsys.readouterr().out
    assert md.startswith("# glocal-verify report: paper19")
    assert "## Summary" in md and "## `switching.image-kernel` (Theorem III.3 (i))" in md


def test_only_restricts_the_conditions(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["verify", "--example", "paper19", "--format", "json", "--only", "switching.*"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert {c["id"].split(".")[0] for c in data["conditions"]} == {"switching"}


def test_require_exits_1_when_a_required_condition_fails(capsys: pytest.CaptureFixture[str]) -> None:
    # case-3 of paper19 breaks Theorem III.3 (i) on purpose
    assert main(["verify", "--example", "paper19", "--require", "switching.image-kernel", "--quiet"]) == 1
    err = capsys.readouterr().err
    assert "switching.image-kernel [mode=case-3]: fails" in err
    assert main(["verify", "--example", "paper19", "--require", "privacy.kernel,privacy.connected"]) == 0


def test_a_mistyped_condition_id_gets_the_closest_matches(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["verify", "--example", "paper19", "--only", "switching.imagekernel"]) == 2
    assert "did you mean switching.image-kernel" in capsys.readouterr().err
    with pytest.raises(UnknownConditionError):
        resolve_ids(["privacy.kernal"])


def test_exact_and_numeric_verdicts_agree_on_paper19(paper19: System) -> None:
    # switching.detects is a simulation: it has no exact counterpart (docs/conditions.md)
    num = {(r.id, tuple(sorted(r.scope.items()))): r.status for r in verify(paper19, simulate="never").conditions}
    exa = {(r.id, tuple(sorted(r.scope.items()))): r.status for r in verify(paper19, exact=True).conditions}
    assert num == exa


def test_exact_results_have_no_tolerance_and_numeric_ones_record_it(paper19: System) -> None:
    for r in verify(paper19, exact=True).conditions:
        assert r.method.value == "exact" and r.tolerance is None
    for r in verify(paper19, only=["switching.image-kernel"]).conditions:
        assert r.method.value == "numeric" and r.tolerance == 1e-9


def test_example_prints_the_bundled_spec(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["example", "paper19"]) == 0
    text = capsys.readouterr().out
    assert 'name = "paper19"' in text and "velocities = [7, 12, 14]" in text
    assert main(["example", "--list"]) == 0
    assert "paper19" in capsys.readouterr().out


def test_conditions_lists_every_catalogue_id(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["conditions"]) == 0
    out = capsys.readouterr().out
    for cid in CATALOGUE:
        assert cid in out


def test_a_numerical_failure_inside_a_checker_is_undecided_with_its_reason_then_settled_exactly(monkeypatch: pytest.MonkeyPatch) -> None:
    import numpy as np

    from glocal_verify import System, load_example
    from glocal_verify.conditions import registry
    from glocal_verify.results import Method, Status

    registry._load()
    real = registry._CHECKERS["central.observer"]

    def fails_numerically(system: System, ctx: registry.CheckContext) -> list:
        if not ctx.exact:
            raise np.linalg.LinAlgError("SVD did not converge")
        return real(system, ctx)

    monkeypatch.setitem(registry._CHECKERS, "central.observer", fails_numerically)
    system = System(load_example("paper19"))
    (never,) = registry.check_conditions(system, ["central.observer"], escalate="never").conditions
    assert never.status is Status.UNDECIDED and "LinAlgError: SVD did not converge" in never.note
    auto = registry.check_conditions(system, ["central.observer"]).conditions
    assert auto and all(r.method is Method.ESCALATED and r.status is not Status.UNDECIDED for r in auto)
    assert [r.status for r in auto] == [r.status for r in real(system, registry.CheckContext(exact=True))]
