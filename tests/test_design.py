"""Designed safe modes, monitors and networks: every claim is re-checked by the checkers."""

from __future__ import annotations

import dataclasses
import itertools
from fractions import Fraction
from typing import Any

import numpy as np
import pytest

from glocal_verify.cli import main
from glocal_verify.conditions.registry import check_conditions
from glocal_verify.design.audit import audit
from glocal_verify.design.monitors import _blocks, _f, design_monitors
from glocal_verify.design.safe_modes import (
    LinkCandidate,
    ProposedMode,
    _admissible,
    default_candidates,
    design_safe_modes,
    eigenvector_error,
    with_attack,
    with_modes,
)
from glocal_verify.errors import GlocalVerifyError
from glocal_verify.model import System
from glocal_verify.results import Status
from glocal_verify.spec import load_example, load_spec
from glocal_verify.spec.types import MonitorSpec

THEOREM = ["switching.image-kernel", "switching.distinct-eigenvalues", "switching.eigenvector-differences"]


@pytest.fixture(scope="module")
def paper19() -> System:
    return System(load_example("paper19"))


def _mode_system(system: System, c: LinkCandidate) -> System:
    return System(with_modes(system.spec, [ProposedMode("m", c, ()).mode_spec()], keep=False))


def _theorem_statuses(system: System, exact: bool) -> set[Status]:
    rep = check_conditions(system, THEOREM, exact=exact)
    return {r.status for r in rep.conditions}


def test_one_link_theorem_admits_exactly_the_modes_the_exact_checkers_accept(paper19: System) -> None:
    cands = [c for c in default_candidates(paper19, (Fraction(1),)) if not c.remove]
    ok = _admissible(paper19, cands, eigenvector_error(paper19))
    rng = np.random.default_rng(0)
    picks = list(rng.choice(np.flatnonzero(ok), 3, replace=False)) + list(rng.choice(np.flatnonzero(~ok), 3, replace=False))
    for k in picks:
        sts = _theorem_statuses(_mode_system(paper19, cands[k]), exact=True)
        assert (sts == {Status.HOLDS}) is bool(ok[k]), cands[k]


def test_a_removal_that_disconnects_the_graph_is_never_admitted(paper19: System) -> None:
    bridge = LinkCandidate(7, 8, Fraction(2), True)
    assert not _admissible(paper19, [bridge], eigenvector_error(paper19))[0]


def test_designed_modes_expose_the_targets_and_the_checkers_confirm_it(paper19: System) -> None:
    sub = audit(paper19, 2, [7, 8, 13])
    targets = [r.actuators for r in sub.rows if r.verdict == "undetected"]
    assert targets
    lambdas = {r.actuators: r.lambda0 for r in sub.rows if r.lambda0 is not None}
    d = design_safe_modes(paper19, targets, None, 3, lambdas=lambdas)
    assert d.complete and d.modes
    assert {F for m in d.modes for F in m.exposes} == set(targets)
    assert d.evaluations_per_second > 0 and d.admissible > 0
    for m in d.modes:
        F = m.exposes[0]
        spec = with_attack(with_modes(paper19.spec, [m.mode_spec()], keep=False), F)
        rep = check_conditions(System(spec), THEOREM + ["switching.avoids-attack"], exact=True)
        assert all(r.status is Status.HOLDS for r in rep.conditions if r.id in THEOREM)
        assert [r.status for r in rep.results("switching.avoids-attack")] == [Status.FAILS]


def test_a_budget_too_small_names_the_attacks_left_exposed(paper19: System) -> None:
    sub = audit(paper19, 2, [7, 8, 13])
    targets = [r.actuators for r in sub.rows if r.verdict == "undetected"]
    lambdas = {r.actuators: r.lambda0 for r in sub.rows if r.lambda0 is not None}
    only = [LinkCandidate(1, 7, Fraction(1))]
    d = design_safe_modes(paper19, targets, only, 1, lambdas=lambdas)
    assert not d.complete
    assert all("touches" in why or "budget" in why or "Theorem" in why for why in d.unexposed.values())


def test_empty_candidate_set_and_zero_budget_are_refused(paper19: System) -> None:
    with pytest.raises(GlocalVerifyError, match="empty"):
        design_safe_modes(paper19, [(3, 4)], [], 1, lambdas={(3, 4): 0.5})
    with pytest.raises(GlocalVerifyError, match="at least 1"):
        design_safe_modes(paper19, [(3, 4)], None, 0, lambdas={(3, 4): 0.5})


def test_designed_monitors_are_a_proven_minimum_for_cases_1_and_2(paper19: System) -> None:
    d = design_monitors(paper19, ["case-1", "case-2"])
    assert d.velocities == (7,) and d.method == "exact" and d.ok
    sys12 = System(with_modes(paper19.spec, [paper19.spec.mode("case-1"), paper19.spec.mode("case-2")], keep=False))
    empty = System(dataclasses.replace(sys12.spec, monitor=MonitorSpec((), ())))
    assert {r.status for r in check_conditions(empty, ["switching.image-kernel"], exact=True).conditions} == {Status.FAILS}


def test_exhaustive_monitors_are_no_larger_than_greedy_and_greedy_meets_its_bound(paper19: System) -> None:
    exact = design_monitors(paper19)
    greedy = design_monitors(paper19, exact_limit=0)
    assert exact.ok and greedy.ok
    assert len(exact.velocities) <= len(greedy.velocities) <= greedy.bound * len(exact.velocities)
    blocks = _blocks(paper19, paper19.safe_modes)
    goal = _f(blocks, set(range(paper19.n)))
    D = sorted({i for Dq, _ in blocks for i in Dq})
    for smaller in itertools.combinations(D, len(exact.velocities) - 1):
        assert _f(blocks, set(smaller)) < goal


def test_design_command_writes_a_spec_whose_audit_leaves_no_one_hidden(tmp_path: Any) -> None:
    out = tmp_path / "designed.toml"
    assert main(["design", "--example", "paper19", "--max-attackers", "1", "--numeric", "--quiet", "--out", str(out)]) == 0
    system = System(load_spec(out))
    assert not system.spec.monitor.positions
    res = audit(system, 1)
    assert res.summary()["counts"]["undetected"] == 0
    rep = check_conditions(system, ["privacy.initial-state", "privacy.consensus-value"], exact=True)
    assert {r.status for r in rep.conditions} == {Status.HOLDS}


@pytest.mark.parametrize("args, needle", [(["--budget", "0"], "at least 1"), (["--max-attackers", "40"], "between 1 and")])
def test_bad_design_requests_get_one_line_and_exit_2(args: list[str], needle: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["design", "--example", "paper19", "--quiet", *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and needle in err[0]


def test_a_set_no_mode_exposes_gets_a_velocity_monitor_where_its_direction_lives_and_then_a_mode() -> None:
    from glocal_verify.design.audit import audit
    from glocal_verify.design.network import _monitor_unexposed
    from glocal_verify.design.safe_modes import DEFAULT_WEIGHTS, SafeModeDesign
    from glocal_verify.spec.load import spec_from_dict
    from glocal_verify.spec.types import SwitchingSpec

    # 8 is a leaf of 4: {4} separates {4, 8} from the monitors, and no link with a monitored
    # endpoint touches the stealthy direction, which lives at the leaf
    data = {
        "format": 1,
        "name": "leaf",
        "graph": {"nodes": 8, "edges": [[1, 2, 1], [2, 3, 1], [3, 4, 1], [4, 5, 1], [5, 6, 1], [6, 7, 1], [4, 8, 1], [1, 3, 2], [5, 7, 3]]},
        "clusters": [{"name": "P1", "nodes": [1, 2, 3, 4, 8], "observers": [{"center": 1}]}, {"name": "P2", "nodes": [5, 6, 7], "observers": [{"center": 6}]}],
        "monitor": {"velocities": [1, 7]},
    }
    system = System(spec_from_dict(data))
    (before,) = [r for r in audit(system, 2, [4, 8]).rows if r.actuators == (4, 8)]
    assert before.verdict == "undetected"
    spec, added, safe = _monitor_unexposed(system.spec, [(4, 8)], 1, SafeModeDesign((), (), {}, 0, 0.0, 0), 1, DEFAULT_WEIGHTS, 2)
    assert added == [(8, (4, 8))]
    assert spec.monitor.positions == () and set(spec.monitor.velocities) == {1, 7, 8}
    after = System(spec)
    (row,) = [r for r in audit(after, 2, [4, 8]).rows if r.actuators == (4, 8)]
    assert row.exposed_by_modes == tuple(m.name for m in safe.modes) == ("designed-1",)
    # exposed, but the observer at 1 cannot raise a local alarm for {4, 8}: under Algorithm 1
    # nothing triggers the switch; a schedule that visits the mode detects it
    assert row.verdict == "undetected" and "no local alarm" in row.chain
    sched = dataclasses.replace(spec, switching=SwitchingSpec(mode="designed-1", time=5.0))
    (row,) = [r for r in audit(System(sched), 2, [4, 8]).rows if r.actuators == (4, 8)]
    assert row.verdict == "detected" and row.answer is not None and row.answer.route("schedule").verdict == "detected"
    # the checkers confirm: privacy holds with velocity-only monitors
    priv = check_conditions(after, ["privacy.*"]).conditions
    assert priv and all(r.status.value == "holds" for r in priv)
