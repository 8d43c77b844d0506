"""The messages a new user meets in the first hour (issue 50): progress lines in order and
never after completion, checkers announced only when they have something to evaluate, ids
never capitalised, the deployment answer and the headline naming the real reason and the
route that detects, reproducible reports and estimates within a factor of two."""

from __future__ import annotations

import dataclasses
import re
import time
from pathlib import Path

import pytest

from glocal_verify.answer.attack import Route
from glocal_verify.answer.run import simulates, verify
from glocal_verify.conditions.registry import check_conditions, implemented_ids
from glocal_verify.model import System
from glocal_verify.results import Report
from glocal_verify.spec.examples import example_names, load_example
from glocal_verify.spec.load import loads_spec

from guarantee_checks.__main__ import UNCERTAINTY

ROOT = Path(__file__).resolve().parent.parent

#: a sampled deployment of paper19 whose P2 observer measures only its centre's neighbours:
#: its sampled decoupling fails (rank(C E_d) = 1 < rank(E_d) = 2), and P2 holds no attacked agent
#: (the deployment of guarantee_checks)
DEPLOYMENT = UNCERTAINTY


@pytest.fixture(scope="module")
def paper19() -> System:
    return System(load_example("paper19"))


@pytest.fixture(scope="module")
def paper19_report(paper19: System) -> Report:
    return verify(paper19, simulate="never")


# ------------------------------------------------------------------------------------------
# progress


def _clocked(monkeypatch: pytest.MonkeyPatch) -> list[float]:
    now = [0.0]
    monkeypatch.setattr(time, "monotonic", lambda: now[0])
    return now


def test_a_phase_announces_itself_and_ends_with_its_time_never_with_a_time_left(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    from glocal_verify.cli.common import count_progress

    now = _clocked(monkeypatch)
    line = count_progress(False)
    assert line is not None
    for t, done in ((0.0, 0), (49.0, 190)):  # one chunk: the first report is the completion
        now[0] = t
        line(done, 190)
    err = capsys.readouterr().err.splitlines()
    assert err == ["audit: 190 attack sets ...", "audit: 190/190 attack sets in 49 s"], err


def test_a_new_phase_restarts_the_clock_and_the_count(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    from glocal_verify.cli.common import count_progress

    now = _clocked(monkeypatch)
    line = count_progress(False, prefix="design")
    assert line is not None
    for t, done in ((0.0, 0), (17.0, 190), (20.0, 0), (30.0, 100), (52.0, 190)):
        now[0] = t
        line(done, 190)
    err = capsys.readouterr().err.splitlines()
    assert err[:3] == ["design: 190 attack sets ...", "design: 190/190 attack sets in 17 s", "design: 190 attack sets ..."], err
    assert err[-1] == "design: 190/190 attack sets in 32 s", err
    assert not any("left" in ln for ln in err if "190/190" in ln)


def test_the_heartbeat_names_the_phase_and_never_counts_more_time_than_the_phase_then_reports(capsys: pytest.CaptureFixture[str]) -> None:
    from glocal_verify.cli.common import count_progress
    from glocal_verify.cli.heartbeat import Heartbeat

    with Heartbeat("glocal-verify", "audit", silence=0.3):
        line = count_progress(False)
        assert line is not None
        line(0, 120)
        time.sleep(1.2)
        line(120, 120)
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert err[0] == "audit: 120 attack sets ...", err
    beats = [ln for ln in err if "still working" in ln]
    assert beats and all('since "audit: 120 attack sets ..."' in ln for ln in beats), err
    assert err[-1].startswith("audit: 120/120 attack sets in "), err
    said = max(int(re.search(r"still working, (\d+) s", ln).group(1)) for ln in beats)  # type: ignore[union-attr]
    assert said <= int(re.search(r" in (\d+) s$", err[-1]).group(1)) + 1  # type: ignore[union-attr]


# ------------------------------------------------------------------------------------------
# what verify announces and reports


def test_verify_announces_no_sampled_checker_for_a_spec_without_implementation(paper19: System) -> None:
    seen: list[str] = []
    report = check_conditions(paper19, ["sampled.*", "detection.*", "privacy.kernel"], progress=seen.append)
    assert seen == ["privacy.kernel"]
    skipped = report.options["skipped"]
    assert set(skipped) == {c for c in implemented_ids() if c.startswith(("sampled.", "detection."))}
    assert all("no [implementation]" in why for why in skipped.values())


def test_an_exact_run_says_why_switching_detects_has_no_row(paper19: System) -> None:
    from glocal_verify.reporting.render import to_markdown

    seen: list[str] = []
    report = verify(paper19, ["switching.detects"], exact=True, progress=seen.append)
    assert seen == []  # never announced, then dropped
    why = report.assessment.not_evaluated["switching.detects"]  # type: ignore[union-attr]
    assert "--exact" in why
    assert "| `switching.detects` | - |" in to_markdown(report)


def test_every_checker_without_a_result_says_why(paper19: System, paper19_report: Report) -> None:
    from glocal_verify.conditions.premises import missing_input

    skipped = paper19_report.options["skipped"]
    for cid in implemented_ids():
        assert bool(paper19_report.results(cid)) != (cid in skipped), cid
        if cid in skipped:  # the rule the checkers' guards call, not a generic excuse
            assert skipped[cid] == missing_input(paper19, cid, options={"simulate": False}), cid


def test_the_report_lists_what_was_not_evaluated_under_system(paper19_report: Report) -> None:
    from glocal_verify.reporting.render import to_markdown

    md = to_markdown(paper19_report)
    assert "- not evaluated, the spec has no [implementation] (a sampled deployment): `sampled.stability`" in md


# ------------------------------------------------------------------------------------------
# words


def test_ids_never_start_a_sentence_capitalised(paper19: System) -> None:
    from glocal_verify.reporting.render import to_markdown

    md = to_markdown(verify(paper19, ["privacy.kernel"], simulate="never"))
    assert "Not evaluated: privacy.initial-state and privacy.consensus-value (--only)." in md
    assert "Not evaluated: stealthy.zda and stealthy.covert (--only)." in md
    assert not re.search(r"\b(Privacy|Stealthy|Switching|Local|Sampled|Detection)\.[a-z]", md), md[:2000]


def test_sentence_capitalises_words_and_keeps_identifiers() -> None:
    from glocal_verify.words import sentence

    assert sentence("not evaluated: stealthy.zda (--only)") == "Not evaluated: stealthy.zda (--only)."
    assert sentence("stealthy.zda holds") == "stealthy.zda holds."
    assert sentence("x(t0) cannot be reconstructed.") == "x(t0) cannot be reconstructed."


def test_the_headline_names_the_route_that_detects(paper19_report: Report) -> None:
    a = paper19_report.assessment
    assert a is not None
    assert "detected (Algorithm 1 and the [switching] schedule)" in a.headline()
    sched = a.attack.route("schedule")
    only_schedule = dataclasses.replace(a.attack, routes=(Route("algorithm 1", "undetected", ("no local alarm",)), sched))
    assert only_schedule.verdict_words() == "detected only through the [switching] schedule (Algorithm 1: undetected)"
    assert "detected only through the [switching] schedule" in dataclasses.replace(a, attack=only_schedule).headline()


def test_place_observers_never_reads_a_lower_bound_beside_a_proven_minimum() -> None:
    from glocal_verify.design.placement import ObserverProposal

    def words(n: int, lower: int, optimal: bool) -> str:
        return ObserverProposal("P1", 5, tuple(range(n)), (3, 4), (7,), (), lower, optimal, "exhaustive").size_words()

    assert "lower bound" not in words(4, 3, True) and "exhaustive search" in words(4, 3, True)
    assert "fewest possible" in words(3, 3, True)
    assert "not proven" in words(5, 3, False)


def test_the_committed_findings_report_is_the_regenerated_one_byte_for_byte() -> None:
    from glocal_verify.design.findings import verify_findings
    from glocal_verify.reporting.findings import findings_markdown

    text = findings_markdown(verify_findings())
    assert (ROOT / "reports" / "findings.md").read_text(encoding="utf-8") == text
    rows = [ln for ln in text.splitlines() if ln.startswith("| `")]
    floats = [float(x) for ln in rows for x in re.findall(r"-?\d+\.\d+(?:e[-+]?\d+)?", ln)]
    assert floats and all(x == float(f"{x:.4g}") for x in floats)  # rounded: no BLAS-dependent last digits


def test_no_cases_report_uses_a_former_id() -> None:
    from glocal_verify.results import ALIASES

    for path in (ROOT / "reports").rglob("*.md"):
        text = path.read_text(encoding="utf-8")
        for old in ALIASES:
            assert f"`{old}`" not in text and f"{old} " not in text, (path, old)


# ------------------------------------------------------------------------------------------
# the sampled deployment


@pytest.mark.slow
def test_a_detector_with_nothing_to_detect_neither_blocks_the_deployment_answer_nor_is_blamed_on_floating_point() -> None:
    full = "center = 10\npositions = [8, 9, 10, 11, 12]\nvelocities = [8, 9, 10, 11, 12]\n"
    assert full in load_example_text("paper19")
    text = load_example_text("paper19").replace(full, "center = 10\n")
    system = System(loads_spec(text + DEPLOYMENT))
    report = verify(system, exact=True)
    a = report.assessment
    assert a is not None
    assert a.attack.deployment is not None and a.attack.deployment.guaranteed is True, a.attack.deployment
    assert [d for d, _ in a.attack.deployment.left_out] == ["P2@10"]
    assert "Left out: P2@10" in a.attack.deployment.reason
    joined = " ".join(a.warnings)
    assert "rank(C E_d) = 1 < rank(E_d) = 2" in joined and "place-observers" in joined
    assert "floating point" not in joined and "try --exact" not in joined


def load_example_text(name: str) -> str:
    from glocal_verify.spec.examples import example_text

    return example_text(name)


# ------------------------------------------------------------------------------------------
# estimates


@pytest.mark.slow
@pytest.mark.parametrize("name", example_names())
def test_the_verify_and_audit_estimates_are_within_a_factor_of_two_of_the_cpu_time(name: str) -> None:
    from glocal_verify.conditions.cost import C_START, SpecSizes, estimate_audit, estimate_verify
    from glocal_verify.design.audit import audit

    spec = load_example(name)
    sizes = SpecSizes.from_spec(spec)
    for run, est in (
        (lambda s: verify(s), estimate_verify(sizes, None, simulate=simulates(System(spec)))),
        (lambda s: audit(s, 2), estimate_audit(sizes, 2)),
    ):
        system = System(spec)
        t0 = time.process_time()  # CPU seconds: what a quiet machine takes, whatever the load here
        run(system)
        took = time.process_time() - t0 + C_START  # the estimate counts the command's start-up once
        assert est.seconds / 2 <= took <= 2 * est.seconds, (est.command, took, est.seconds, est.phases)
