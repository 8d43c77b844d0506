"""Thresholds, Algorithm 1, the switching.detects checker and the paper's Section IV cases."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from glocal_verify import System, load_example, spec_from_dict, verify
from glocal_verify.cli import main
from glocal_verify.conditions.detects import algorithm1, rank_safe_modes
from glocal_verify.design.case_study import (
    case_findings,
    cases_for,
    companion_systems,
    run_case,
)
from glocal_verify.results import Status
from glocal_verify.simulation.engine import simulate
from glocal_verify.simulation.observer_models import ObserverBank
from glocal_verify.simulation.schedule import Schedule
from glocal_verify.simulation.thresholds import (
    ThresholdRule,
    attack_free_thresholds,
    first_crossing,
)

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def paper19() -> System:
    return System(load_example("paper19"))


@pytest.fixture(scope="module")
def bank(paper19: System) -> ObserverBank:
    return ObserverBank.for_system(paper19)


def _tiny(**extra: Any) -> System:
    data: dict[str, Any] = {
        "format": 1,
        "name": "tiny4",
        "graph": {"nodes": 4, "edges": [[1, 2, 1], [2, 3, 2], [3, 4, 1], [1, 4, 1]]},
        "modes": [{"name": "q", "add": [[1, 3, 1]]}],
        "clusters": [{"name": "A", "nodes": [1, 2], "observers": [{"center": 1}]}, {"name": "B", "nodes": [3, 4], "observers": [{"center": 4}]}],
        "monitor": {"velocities": [1, 3]},
        "simulation": {"horizon": 6.0, "step": 0.05, "seed": 3},
    }
    data.update(extra)
    return System(spec_from_dict(data))


# --------------------------------------------------------------------------------------------
# thresholds


def test_attack_free_runs_from_the_box_never_cross_the_envelope(paper19: System, bank: ObserverBank) -> None:
    sched = Schedule.single("case-2", 10.0)
    th = attack_free_thresholds(paper19, bank, sched)
    rng = np.random.default_rng(0)
    # random interior points and random vertices of the box (where the sup is attained)
    X = np.hstack([rng.uniform(-1, 1, size=(38, 20)), rng.choice([-1.0, 1.0], size=(38, 20))])
    worst = simulate(paper19, schedule=sched, observers=bank, x0=X, batch_reduce="max-abs")
    for name, r in worst.residuals.items():
        env = th.envelope[name]
        assert np.all(r <= env * (1 + 1e-9) + 1e-12), name


def test_the_envelope_is_attained_at_a_vertex_of_the_box(paper19: System, bank: ObserverBank) -> None:
    sched = Schedule.single("case-1", 2.0)
    th = attack_free_thresholds(paper19, bank, sched, horizon=4.0)
    k_t, comp = 250, 0  # t = 2.5 s, first global channel
    unit = simulate(paper19, schedule=sched, observers=ObserverBank((bank["central"],)), x0=np.eye(38), horizon=4.0, batch_reduce="abs-sum")
    assert np.allclose(unit.residuals["central"][k_t], th.envelope["central"][k_t], rtol=1e-12)
    # the sign pattern of the row of Psi(t) reproduces the bound
    cols = [simulate(paper19, schedule=sched, observers=ObserverBank((bank["central"],)), x0=np.eye(38)[:, [i]], horizon=2.5, batch_reduce="max-abs").residuals["central"][-1, comp] for i in (0, 20)]
    assert all(c <= th.envelope["central"][k_t, comp] for c in cols)


def test_attack_free_algorithm1_runs_never_detect_anything(paper19: System, bank: ObserverBank) -> None:
    for seed in (1, 2):
        x0 = np.random.default_rng(seed).uniform(-1, 1, 38)
        r = algorithm1(paper19, attack=None, observers=bank, mode="case-2", trigger="schedule", x0=x0, horizon=15.0)
        assert not any(c.detected for c in r.local.values())
        assert r.global_before is not None and not r.global_before.detected
        assert r.global_after is not None and not r.global_after.detected


def test_the_calibrated_rule_is_a_multiple_of_the_largest_sampled_residual(paper19: System, bank: ObserverBank) -> None:
    rule = ThresholdRule(kind="calibrated", runs=4, factor=2.0)
    th = attack_free_thresholds(paper19, bank, Schedule(), rule, horizon=2.0)
    env = attack_free_thresholds(paper19, bank, Schedule(), horizon=2.0)
    for name in th.envelope:
        assert np.all(th.envelope[name] <= 2.0 * env.envelope[name] + 1e-12)
    assert "calibrated" in rule.describe()


# --------------------------------------------------------------------------------------------
# the paper's cases


@pytest.fixture(scope="module")
def outcomes(paper19: System) -> dict[str, Any]:
    cases = cases_for(paper19, companion_systems(paper19))
    return {c.name: run_case(c) for c in cases}


def test_case_3_is_paired_with_its_companion_spec(paper19: System) -> None:
    comp = companion_systems(paper19)
    assert list(comp) == ["case-3"] and comp["case-3"].name == "paper19-case3"
    assert comp["case-3"].attacked == (10, 11)


def test_before_the_switch_the_zda_is_invisible_globally_and_seen_locally(outcomes: dict[str, Any]) -> None:
    for name, oc in outcomes.items():
        r = oc.result
        assert oc.pre_switch_ok, name
        assert r.residual_max["central"]["attack_before_relative"] < 1e-9
        assert not r.global_before.detected
    assert outcomes["case-1"].result.local["P1@5"].detected
    assert outcomes["case-2"].result.local["P1@5"].detected
    assert outcomes["case-3"].result.local["P2@10"].detected


def test_case_1_switches_and_the_global_residual_stays_bounded_and_vanishes(outcomes: dict[str, Any]) -> None:
    oc = outcomes["case-1"]
    assert oc.observed == "vanishing" and oc.agrees
    assert oc.result.post_switch.attack_part == "invisible"
    assert not oc.detected


def test_case_2_switches_and_the_global_residual_grows_without_bound(outcomes: dict[str, Any]) -> None:
    oc = outcomes["case-2"]
    assert oc.observed == "unbounded" and oc.agrees and oc.detected
    assert oc.result.post_switch.rate == pytest.approx(0.5, abs=0.02)  # e^(lambda0 t), lambda0 = 0.5
    assert 10.0 <= oc.result.global_after.time < 10.5


def test_case_3_gives_no_detection(outcomes: dict[str, Any]) -> None:
    oc = outcomes["case-3"]
    assert not oc.detected and oc.agrees
    assert oc.result.post_switch.attack_part == "invisible"
    assert oc.result.attack.moved == (11,)


def test_the_cases_yield_the_theorem_and_remark_findings(outcomes: dict[str, Any]) -> None:
    found = case_findings(list(outcomes.values()))
    assert any("Theorem III.3 (sufficiency) fails on paper19 / case-1" in f for f in found)
    assert any("Remark III.3.1" in f for f in found)


def test_the_finding_spec_reproduces_an_undetected_zda_under_theorem_iii3() -> None:
    system = System(load_example("findings/theorem3-sufficiency-switch-avoids-zda"))
    rep = verify(system, ["switching.image-kernel", "switching.distinct-eigenvalues", "switching.eigenvector-differences", "switching.detects"], options={"simulate": True})
    assert all(r.status is Status.HOLDS for r in rep.conditions if r.id != "switching.detects")
    (d,) = rep.results("switching.detects")
    assert d.status is Status.FAILS
    assert d.witness["post_switch"]["attack_part"] == "invisible"


# --------------------------------------------------------------------------------------------
# Algorithm 1 and the checker


def test_safe_modes_meeting_theorem_iii3_rank_first(paper19: System) -> None:
    ranking = rank_safe_modes(paper19)
    assert [r.mode for r in ranking][-1] == "case-3"
    assert [r.eligible for r in ranking] == [True, True, False]
    assert all(0.0 < r.score <= 1.0 for r in ranking[:2])


def test_the_local_trigger_switches_one_step_after_the_first_local_detection(paper19: System, bank: ObserverBank) -> None:
    r = algorithm1(paper19, observers=bank, trigger="local", horizon=8.0)
    first = r.first_local
    assert first is not None and r.trigger == "local"
    assert r.switch_time == pytest.approx(first.time + 0.01)
    assert r.chosen_mode == rank_safe_modes(paper19)[0].mode
    kinds = [e.kind for e in r.events]
    assert kinds.index("local-detection") < kinds.index("switch")
    # finding: line 4 ranks by Theorem III.3's margins, which ignore the attack; on paper19 it
    # picks case-1, whose switch avoids the ZDA, and the control centre never detects
    assert r.chosen_mode == "case-1" and not r.detected_globally


def test_no_switch_keeps_the_normal_mode_and_the_attack_hidden(paper19: System, bank: ObserverBank) -> None:
    r = algorithm1(paper19, observers=bank, no_switch=True, horizon=8.0)
    assert r.schedule.segments == ((0.0, "normal"),) and r.switch_time is None
    assert not r.global_before.detected and r.global_after is None


def test_switching_detects_is_opt_in_numeric_and_matches_the_cases(paper19: System) -> None:
    assert verify(paper19, ["switching.detects"], simulate="never").conditions == ()
    assert verify(paper19, ["switching.detects"], exact=True, options={"simulate": True}).conditions == ()
    rep = verify(paper19, ["switching.detects"], options={"simulate": True})
    st = {r.scope["mode"]: r for r in rep.conditions}
    assert st["case-1"].status is Status.FAILS and st["case-2"].status is Status.HOLDS
    assert st["case-2"].margin > 0 > st["case-1"].margin
    assert st["case-1"].witness["dL_xi_relative"] < 1e-12 < st["case-2"].witness["dL_xi_relative"]
    assert all(r.method.value == "numeric" and r.tolerance == 1e-9 for r in rep.conditions)


def test_switching_detects_skips_large_networks_as_undecided(paper19: System) -> None:
    rep = verify(paper19, ["switching.detects"], options={"simulate": True, "max_agents": 10})
    assert {r.status for r in rep.conditions} == {Status.UNDECIDED}


def test_first_crossing_reports_the_peak_even_without_a_crossing(paper19: System, bank: ObserverBank) -> None:
    th = attack_free_thresholds(paper19, bank, Schedule(), horizon=3.0)
    res = simulate(paper19, observers=bank, attack=None, horizon=3.0)
    c = first_crossing(res, th, "central")
    assert not c.detected and 0.0 < c.peak_ratio <= 1.0


# --------------------------------------------------------------------------------------------
# the command


@pytest.mark.slow
def test_simulate_writes_a_json_summary_and_png_and_svg_figures(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    system = _tiny()
    spec = tmp_path / "tiny.toml"
    spec.write_text(
        'format = 1\nname = "tiny4"\n[graph]\nnodes = 4\nedges = [[1, 2, 1], [2, 3, 2], [3, 4, 1], [1, 4, 1]]\n'
        '[[modes]]\nname = "q"\nadd = [[1, 3, 1]]\n'
        '[[clusters]]\nname = "A"\nnodes = [1, 2]\n[[clusters.observers]]\ncenter = 1\n'
        '[[clusters]]\nname = "B"\nnodes = [3, 4]\n[[clusters.observers]]\ncenter = 4\n'
        '[monitor]\nvelocities = [1, 3]\n[attack]\nkind = "covert"\nactuators = [2]\nsensors = [1, 3]\namplitude = 50.0\nstart = 1.0\n'
        '[switching]\nmode = "q"\ntime = 3.0\n[simulation]\nhorizon = 6.0\nstep = 0.05\n'
    )
    assert system.n == 4
    out = tmp_path / "out"
    assert main(["simulate", str(spec), "--out", str(out), "--quiet"]) == 0
    data = json.loads((out / "simulation-q.json").read_text())
    assert data["switch_time"] == 3.0 and data["chosen_mode"] == "q"
    assert {"events", "detection", "residual_max", "post_switch", "verdicts"} <= set(data)
    assert set(data["residual_max"]["central"]) >= {"before", "after", "attack_before_relative", "attack_after_relative"}
    assert data["residual_max"]["central"]["attack_before_relative"] < 1e-9  # covert: hidden before the switch
    assert data["detection"]["global_after_switch"]["detected"]
    for ext in ("png", "svg"):
        assert (out / f"simulation-q.{ext}").stat().st_size > 10_000
    assert "switch" in capsys.readouterr().out
    assert main(["simulate", str(spec), "--out", str(out), "--no-switch", "--quiet"]) == 0
    assert json.loads((out / "simulation-normal.json").read_text())["switch_time"] is None


def test_simulate_rejects_cases_with_a_forced_mode(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["simulate", "--example", "paper19", "--cases", "--mode", "case-1"]) == 2
    assert "--cases" in capsys.readouterr().err


def test_switching_detects_simulates_the_direction_an_informed_attacker_would_choose() -> None:
    # stealthy.zda reports a direction that the switch touches, but xi = [1, 0, -1, 0] is a
    # stealthy direction at every lambda0 that the switch does not touch: the attacker uses it
    # and the control centre never detects (the bundled example findings/theorem3-signed-switch-keeps-zda)
    from glocal_verify import loads_spec

    from glocal_verify.spec.examples import example_text

    spec_text = example_text("findings/theorem3-signed-switch-keeps-zda")
    spec_text = spec_text[: spec_text.index("[finding]")]
    text = spec_text + """
[switching]
mode = "signed"
time = 2.0
[simulation]
horizon = 8.0
step = 0.05
"""
    system = System(loads_spec(text))
    (r,) = verify(system, ["switching.detects"], options={"simulate": True}).conditions
    assert r.witness["attack_direction"] == "avoiding direction of switching.avoids-attack"
    assert r.status is Status.FAILS and r.witness["detected"] is False
