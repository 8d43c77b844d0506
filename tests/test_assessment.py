"""The assessment at the top of every report: Problem 1 and Problem 2 answered, premises warned."""

from __future__ import annotations

import dataclasses
import importlib.util
import json

import pytest

from glocal_verify import System, load_example, loads_spec, validate_report_json, verify
from glocal_verify.cli import main
from glocal_verify.design.placement import connectivity_warnings
from glocal_verify.errors import GlocalVerifyError
from glocal_verify.answer.assessment import NO_ATTACK, NO_MONITORS, assess, with_assessment
from glocal_verify.answer.attack import THEOREM_IDS
from glocal_verify.reporting.render import render, to_markdown
from glocal_verify.results import Method, Report, Status

#: an 8-drone network: two clusters, velocity monitors, a ZDA on agents 2 and 3, one safe mode
DRONES = """
format = 1
name = "{name}"
[graph]
nodes = 8
edges = [[1, 2], [2, 3], [3, 4], [1, 4], [2, 4, 2], {bridge}[5, 6], [6, 7], [7, 8], [5, 8], [6, 8, 2]]
[[modes]]
name = "safe"
add = [[3, 5]]
[[clusters]]
name = "A"
nodes = [1, 2, 3, 4]
[[clusters.observers]]
center = 2
[[clusters]]
name = "B"
nodes = [5, 6, 7, 8]
[[clusters.observers]]
center = 5
{monitor}
{attack}
[switching]
mode = "safe"
time = 3.0
[simulation]
horizon = 8.0
step = 0.05
"""
MONITOR = "[monitor]\nvelocities = [1, 5, 7]"
ATTACK = '[attack]\nkind = "zda"\nactuators = [2, 3]\nlambda0 = 0.5'


def _drones(name: str, *, bridge: bool = True, monitor: bool = True, attack: bool = True) -> System:
    text = DRONES.format(name=name, bridge="[4, 5], " if bridge else "", monitor=MONITOR if monitor else "", attack=ATTACK if attack else "")
    return System(loads_spec(text, f"{name}.toml"))


@pytest.fixture(scope="module")
def paper19_report() -> Report:
    return verify(System(load_example("paper19")))


@pytest.fixture(scope="module")
def no_monitors() -> Report:
    return verify(_drones("nomon", monitor=False))


@pytest.fixture(scope="module")
def disconnected() -> System:
    return _drones("disc", bridge=False)


@pytest.fixture(scope="module")
def no_attack() -> Report:
    return verify(_drones("noattack", attack=False))


def test_paper19_privacy_is_protected_with_only_the_common_offset_hidden(paper19_report: Report) -> None:
    p = assess(paper19_report).privacy
    assert (p.initial_state, p.consensus_value) == ("protected", "protected")
    assert p.hidden_dimension == 1
    assert all(r.holds for r in paper19_report.results("privacy.initial-state"))


def test_paper19_zda_on_agents_3_and_4_is_stealthy_caught_by_observer_5_and_exposed_by_case_2(paper19_report: Report) -> None:
    a = assess(paper19_report).attack
    assert (a.kind, a.actuators, a.lambda0, a.lambda0_source) == ("zda", (3, 4), 0.5, "spec")
    assert a.stealthy is True and a.caught_locally is True
    assert a.caught_locally_by == (("P1", 5),)
    assert a.exposed_by_modes == ("case-2",)
    assert set(a.not_exposed_by_modes) == {"case-1", "case-3"}
    assert a.verdict == "detected"
    assert [(r.name, r.verdict) for r in a.routes] == [("algorithm 1", "detected"), ("schedule", "detected")]
    assert a.chain[1:] == ("caught by P1@5", "switch to case-2 (Theorem III.3 (i)-(iii) hold; it touches every stealthy direction)", "unbounded global residual")


def test_an_exposing_mode_meets_theorem_iii3_and_touches_the_attack_by_definition(paper19_report: Report) -> None:
    a = assess(paper19_report).attack
    for m in a.modes:
        touch = [r for r in paper19_report.results("switching.avoids-attack") if r.scope["mode"] == m.mode][0]
        thm = [r for cid in THEOREM_IDS for r in paper19_report.results(cid) if r.scope["mode"] == m.mode]
        if m.exposes:
            assert touch.fails and touch.witness["touches_attack"] is True and all(r.holds for r in thm)
        else:
            assert touch.holds and touch.witness["touches_attack"] is False


def test_local_catchers_see_the_spec_suspected_set_never_the_worst_case(paper19_report: Report) -> None:
    a = assess(paper19_report).attack
    for cluster, observer in a.caught_locally_by:
        for cid in ("local.pencil", "local.uio"):
            rs = [r for r in paper19_report.results(cid) if r.scope["cluster"] == cluster and r.scope["observer"] == observer]
            assert [r.status for r in rs if r.scope["suspected"] == "attack"] == [Status.HOLDS]
    pencil5 = [r for r in paper19_report.results("local.pencil") if r.scope["observer"] == 5 and r.scope["suspected"] == "attack"][0]
    assert set(pencil5.witness["suspected_agents"]) == {3, 4}


def test_the_markdown_report_starts_with_the_assessment(paper19_report: Report) -> None:
    md = to_markdown(paper19_report)
    headings = [line for line in md.splitlines() if line.startswith("## ")]
    assert headings[0] == "## Assessment"
    head = md.split("## System")[0]
    assert "**protected**" in head and "caught by P1@5" in head and "case-2" in head and "detected" in head


def test_the_summary_counts_the_spec_suspected_set_and_the_worst_case_in_separate_rows(paper19_report: Report) -> None:
    md = to_markdown(paper19_report)
    rows = [line for line in md.split("## Summary")[1].split("\n## ")[0].splitlines() if line.startswith("| `local.pencil`")]
    assert len(rows) == 2
    assert "the spec's attacked agents" in rows[0] and "suspected = all" in rows[1]


def test_every_result_row_shows_its_polarity(paper19_report: Report) -> None:
    md = to_markdown(paper19_report)
    section = md.split("## `local.pencil`")[1].split("\n## ")[0]
    rows = [line for line in section.splitlines() if line.startswith("| cluster=")]
    results = paper19_report.results("local.pencil")
    assert len(rows) == len(results)
    for row, r in zip(rows, results):
        assert row.split("|")[3].strip() == f"{r.polarity.mark} {r.polarity.value}"
    vacuous = [r for r in results if r.premise]
    assert vacuous and all(r.polarity.value == "vacuous" for r in vacuous)  # P2 and P3 hold no attacked agent


def test_fragile_and_escalated_results_are_marked_with_their_note(paper19_report: Report) -> None:
    r0 = paper19_report.results("switching.distinct-eigenvalues")[0]
    marked = dataclasses.replace(r0, fragile=True, method=Method.ESCALATED, note="escalated to exact arithmetic (0.1 s): test note")
    report = dataclasses.replace(paper19_report, conditions=tuple(marked if r is r0 else r for r in paper19_report.conditions))
    section = to_markdown(report).split("## `switching.distinct-eigenvalues`")[1].split("\n## ")[0]
    row = [line for line in section.splitlines() if f"mode={r0.scope['mode']}" in line][0]
    assert "(fragile)" in row and "exact (escalated)" in row and "test note" in row


def test_json_reports_carry_the_assessment_and_validate_against_the_schema(paper19_report: Report, no_monitors: Report, no_attack: Report) -> None:
    for report in (paper19_report, no_monitors, no_attack):
        data = json.loads(render(report, "json"))
        validate_report_json(data)
        assert data["assessment"] == json.loads(json.dumps(assess(report).to_json()))
    # verify attaches the assessment itself (library = command line)
    assert paper19_report.assessment is not None
    assert paper19_report.to_json()["assessment"]["attack"]["verdict"] == "detected"
    bare = dataclasses.replace(paper19_report, assessment=None)
    assert "assessment" not in bare.to_json() and with_assessment(bare).to_json()["assessment"]["attack"]["verdict"] == "detected"


def test_a_spec_without_monitors_warns_that_the_control_centre_measures_nothing(no_monitors: Report) -> None:
    a = assess(no_monitors)
    assert any(w.startswith(NO_MONITORS) for w in a.warnings)
    assert a.privacy.reason.startswith("Vacuously")
    assert a.attack.exposed_by_modes == () and a.attack.verdict == "undetected"
    for r in no_monitors.results("privacy.kernel") + no_monitors.results("central.observer"):
        assert r.holds and any("vacuous" in n for n in a.notes_for(r))
    md = to_markdown(no_monitors)
    central = md.split("## `central.observer`")[1].split("\n## ")[0]
    assert "vacuous: no global monitors" in central


def test_a_disconnected_graph_is_warned_in_the_assessment_and_in_the_premise_notes(disconnected: System) -> None:
    report = verify(disconnected, ["privacy.*"])
    a = assess(report)
    assert any(w.startswith("disconnected graph (normal:") for w in a.warnings)
    broken = [r for r in report.results("privacy.connected") if r.fails]
    assert [r.scope["mode"] for r in broken] == ["normal"] and len(broken[0].witness["components"]) == 2
    r = [r for r in report.results("privacy.consensus-value") if r.scope.get("mode") == "normal"][0]
    assert any("disconnected" in n for n in a.notes_for(r))


def test_place_observers_and_simulate_warn_on_a_disconnected_graph(disconnected: System, tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    assert len(connectivity_warnings(disconnected)) == 1
    spec = tmp_path / "disc.toml"
    spec.write_text(DRONES.format(name="disc", bridge="", monitor=MONITOR, attack=ATTACK))
    assert main(["place-observers", str(spec), "--quiet", "--out", str(tmp_path / "p.toml")]) == 0
    err = capsys.readouterr().err
    assert sum("warning: the normal graph is disconnected" in line for line in err.splitlines()) == 1
    # the warning comes before any simulation work: a size refusal afterwards still shows it
    huge = tmp_path / "huge.toml"
    huge.write_text(spec.read_text().replace("horizon = 8.0\nstep = 0.05", "horizon = 1e6\nstep = 0.1"))
    assert main(["simulate", str(huge), "--quiet", "--out", str(tmp_path / "sim")]) == 2
    assert "warning: the normal graph is disconnected" in capsys.readouterr().err


def test_a_spec_without_attack_says_so_and_points_to_audit(no_attack: Report) -> None:
    a = assess(no_attack)
    assert NO_ATTACK in a.warnings
    assert a.attack.present is False and a.attack.verdict == "not assessed"
    assert "stealthy.zda" in a.not_evaluated and "switching.avoids-attack" in a.not_evaluated
    assert all(r.scope["suspected"] == "all" for r in no_attack.results("local.pencil"))
    md = to_markdown(no_attack)
    assert "glocal-verify audit" in md.split("## System")[0]
    assert "| `stealthy.zda` | - |" in md and "not evaluated: no [attack] in the spec" in md


def test_a_substituted_lambda0_is_named_and_warned() -> None:
    report = verify(_drones("drones8"), ["stealthy.zda", "switching.avoids-attack"])
    a = assess(report)
    zda = report.results("stealthy.zda")[0]
    assert zda.witness["direction"]["source"] != "requested lambda0"
    assert a.attack.lambda0_source is not None and a.attack.lambda0_source.startswith("substituted: the spec's lambda0 = 0.5")
    assert a.attack.lambda0 == complex(*zda.witness["direction"]["lambda0"])
    assert any("admits no stealthy ZDA" in w for w in a.warnings)


def test_the_simulation_is_shown_beside_the_algebra_and_never_decides(disconnected: System) -> None:
    # one answer: the audit cannot simulate every set, so the verdict follows the algebra;
    # the simulation of switching.detects is reported next to it
    ids = ["stealthy.zda", "stealthy.covert", "local.pencil", "local.uio", *THEOREM_IDS, "switching.avoids-attack", "switching.detects"]
    algebra = assess(verify(disconnected, ids[:-1], simulate="never")).attack
    report = verify(disconnected, ids, simulate="always")
    sim = assess(report).attack
    detects = report.results("switching.detects")[0]
    assert (sim.verdict, sim.exposed_by_modes, sim.unsettled_modes) == (algebra.verdict, algebra.exposed_by_modes, algebra.unsettled_modes)
    mode = sim.modes[0]
    if detects.status is not Status.UNDECIDED:
        assert mode.simulated is (detects.status is Status.HOLDS) and "simulation:" in mode.reason


def test_when_algebra_and_simulation_disagree_the_answer_follows_the_algebra_and_warns(paper19_report: Report) -> None:
    touch = [r for r in paper19_report.results("switching.avoids-attack") if r.scope["mode"] == "case-2"][0]
    fake = dataclasses.replace(touch, id="switching.detects", status=Status.FAILS, favourable=False, witness={"post_switch": {"summary": "made up"}})
    report = dataclasses.replace(paper19_report, conditions=tuple(r for r in paper19_report.conditions if r.id != "switching.detects") + (fake,), assessment=None)
    a = assess(report)
    m = [m for m in a.attack.modes if m.mode == "case-2"][0]
    assert (m.exposes, m.simulated, m.agrees) == (True, False, False)
    assert "disagrees with the algebra" in m.reason
    assert any(w.startswith("case-2: the simulation of switching.detects") for w in a.warnings)
    assert a.attack.exposed_by_modes == ("case-2",) and a.attack.verdict == "detected"


def test_the_html_format_needs_its_module_or_says_so_clearly(paper19_report: Report) -> None:
    if importlib.util.find_spec("glocal_verify.reporting.html") is None:
        with pytest.raises(GlocalVerifyError, match="html format is not available"):
            render(paper19_report, "html")
    else:
        assert isinstance(render(paper19_report, "html"), str)
