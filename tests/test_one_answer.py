"""One answer everywhere: the cases a new user tried (a weighted ring, paper19), the gate, and library = command line."""

from __future__ import annotations

import dataclasses
import json
from typing import Any

import pytest

from glocal_verify import System, load_example, loads_spec, verify
from glocal_verify.answer.attack import AttackAnswer
from glocal_verify.reporting.audit_text import audit_markdown
from glocal_verify.cli import main
from glocal_verify.design.audit import audit
from glocal_verify.design.network import before_table, design_network
from glocal_verify.reporting.render import to_markdown
from glocal_verify.results import Polarity, Status
from glocal_verify.spec.types import AttackSpec

#: a 12-agent weighted ring, two clusters with one observer each, velocity monitors on 3 and 9,
#: a safe mode adding link 3-9 and a ZDA on agent 5 (the case of the issue that asked for one answer)
RING = """
format = 1
name = "ring12"
[graph]
nodes = 12
edges = [[1,2,1],[2,3,2],[3,4,1],[4,5,3],[5,6,1],[6,7,2],[7,8,1],[8,9,2],[9,10,1],[10,11,3],[11,12,1],[12,1,2]]
[[modes]]
name = "link-3-9"
add = [[3, 9]]
[[clusters]]
name = "A"
nodes = [1, 2, 3, 4, 5, 6]
[[clusters.observers]]
center = 2
[[clusters]]
name = "B"
nodes = [7, 8, 9, 10, 11, 12]
[[clusters.observers]]
center = 10
[monitor]
velocities = [3, 9]
[attack]
kind = "zda"
actuators = [5]
"""


def _key(a: AttackAnswer) -> tuple[Any, ...]:
    return (a.verdict, tuple((r.name, r.verdict, r.chain[1:]) for r in a.routes), a.stealthy, a.caught_locally, a.caught_locally_by,
            a.exposed_by_modes, a.not_exposed_by_modes, a.unsettled_modes)


def _with(system: System, F: tuple[Any, ...]) -> System:
    atk = system.spec.attack
    attack = dataclasses.replace(atk, actuators=F) if atk is not None else AttackSpec("zda", F)
    return System(dataclasses.replace(system.spec, attack=attack))


@pytest.fixture(scope="module")
def ring() -> System:
    return System(loads_spec(RING, "ring12.toml"))


@pytest.fixture(scope="module")
def paper19() -> System:
    return System(load_example("paper19"))


@pytest.mark.slow
def test_every_ring_attacker_gets_the_same_answer_from_audit_verify_and_designs_before_table(ring: System) -> None:
    rows = audit(ring, 2).rows
    before = before_table(ring, 2).rows
    for row, brow in zip(rows, before):
        assert row.answer is not None and brow.answer is not None
        a = verify(_with(ring, row.actuators), simulate="never").assessment.attack
        assert _key(row.answer) == _key(a) == _key(brow.answer), (row.actuators, row.chain, a.reason)
        assert row.verdict == a.verdict and row.chain == " -> ".join(a.chain)


def test_paper19s_attack_reads_the_same_in_the_audit_verify_and_the_command(paper19: System, capsys: pytest.CaptureFixture[str]) -> None:
    (row,) = [r for r in audit(paper19, 2, [3, 4]).rows if r.actuators == (3, 4)]
    a = verify(paper19).assessment.attack
    assert row.answer is not None and _key(row.answer) == _key(a)
    assert a.verdict == "detected" and a.chain[1] == "caught by P1@5" and "switch to case-2" in a.chain[2]
    assert main(["verify", "--example", "paper19", "--format", "json", "--quiet"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["assessment"]["attack"]["verdict"] == "detected" and data["assessment"]["attack"]["chain"] == list(a.chain)


def test_the_library_returns_what_the_command_reports(paper19: System, capsys: pytest.CaptureFixture[str]) -> None:
    report = verify(paper19)
    assert main(["verify", "--example", "paper19", "--format", "json", "--quiet"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert len(report.conditions) == len(data["conditions"]) and report.assessment is not None
    assert [r["id"] for r in data["conditions"]] == [r.id for r in report.conditions]
    assert report.results("switching.detects"), "the simulation runs by default in both (simulate='auto')"


def test_simulated_results_carry_a_polarity(paper19: System) -> None:
    for r in verify(paper19).results("switching.detects"):
        assert r.polarity is not Polarity.UNDECIDED or r.status is Status.UNDECIDED
        assert r.favourable is (None if r.status is Status.UNDECIDED else r.status is Status.HOLDS)


@pytest.mark.parametrize(
    "args, code",
    [
        (["--require", "stealthy.zda"], 1),  # a stealthy ZDA exists: the attacker wins, the gate fails
        (["--require", "stealthy.covert"], 0),  # no covert attack: good news
        (["--require-holds", "stealthy.zda"], 0),  # the raw status gate says what it tests
        (["--require", "privacy.kernel,privacy.initial-state"], 0),
        (["--require", "local.pencil"], 1),  # the worst case suspected = all fails
    ],
)
def test_require_gates_on_good_news_for_the_defender(args: list[str], code: int, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["verify", "--example", "paper19", "--quiet", "--simulate", "never", *args]) == code
    err = capsys.readouterr().err
    if code:
        assert "required condition not met" in err


def test_a_result_whose_premise_is_absent_reads_vacuous_not_bad() -> None:
    # agent 1 alone with both neighbours' velocities measured: no stealthy ZDA, nothing to avoid
    spec = """
format = 1
name = "no-zda"
[graph]
nodes = 3
edges = [[1, 2], [2, 3], [1, 3]]
[[modes]]
name = "q"
remove = [[1, 3]]
[monitor]
velocities = [1, 2, 3]
[attack]
kind = "zda"
actuators = [1]
"""
    report = verify(System(loads_spec(spec, "nozda.toml")), ["stealthy.zda", "switching.avoids-attack"])
    (zda,) = report.results("stealthy.zda")
    (av,) = report.results("switching.avoids-attack")
    assert zda.status is Status.FAILS and zda.polarity is Polarity.FAVOURABLE
    assert av.status is Status.HOLDS and av.polarity is Polarity.VACUOUS and av.premise and "no stealthy ZDA" in av.premise
    section = to_markdown(report).split("## `switching.avoids-attack`")[1]
    row = [line for line in section.splitlines() if line.startswith("| mode=q")][0]
    assert "– vacuous" in row and "✗" not in row
    assert row.count("escalated to exact arithmetic") <= 1


def test_the_audit_table_says_why_for_every_row(paper19: System) -> None:
    md = audit_markdown(audit(paper19, 1, [3, 5, 7]))
    header = [line for line in md.splitlines() if line.startswith("| actuators")][0]
    assert header.rstrip().endswith("| why |")
    body = [line for line in md.splitlines() if line.startswith("| 3 |") or line.startswith("| 7 |")]
    assert body and all(" -> " in line or "not stealthy" in line for line in body)


def test_a_design_with_an_unmet_requirement_writes_the_best_partial_design_and_names_the_obstacle(tmp_path: Any, capsys: pytest.CaptureFixture[str]) -> None:
    # a ring with equal weights: its rotation symmetry repeats eigenvalues of L_1
    spec = tmp_path / "ring8.toml"
    spec.write_text(
        'format = 1\nname = "ring8"\n[graph]\nnodes = 8\nedges = [[1,2],[2,3],[3,4],[4,5],[5,6],[6,7],[7,8],[8,1]]\n'
        "[monitor]\nvelocities = [1, 5]\n"
    )
    out = tmp_path / "designed.toml"
    # one link per mode cannot break a repeated eigenvalue: the obstacle is proven, not only reported
    assert main(["design", str(spec), "--out", str(out), "--quiet", "--max-attackers", "2", "--max-links", "1"]) == 1
    text = out.read_text()
    assert "NOT MET" in text and "proven" in text and "repeated eigenvalues" in text and "would split" in text
    assert "design above is partial" in capsys.readouterr().err
    loads_spec(text, "designed.toml")  # the partial design is a valid spec


def test_a_ring_with_equal_weights_is_designed_by_a_mode_of_several_links_with_generic_weights(tmp_path: Any) -> None:
    spec = tmp_path / "ring8.toml"
    spec.write_text(
        'format = 1\nname = "ring8"\n[graph]\nnodes = 8\nedges = [[1,2],[2,3],[3,4],[4,5],[5,6],[6,7],[7,8],[8,1]]\n'
        "[monitor]\nvelocities = [1, 5]\n"
    )
    out = tmp_path / "designed.toml"
    assert main(["design", str(spec), "--out", str(out), "--quiet", "--max-attackers", "2"]) == 0
    designed = System(loads_spec(out.read_text(), "designed.toml"))
    assert any(len(designed.switching_links(q)) >= 2 for q in designed.safe_modes)
    assert audit(designed, 2).summary()["counts"]["undetected"] == 0


def test_a_design_names_every_change_and_keeps_its_monitor_budget() -> None:
    data = """
format = 1
name = "leaf"
[graph]
nodes = 8
edges = [[1, 2, 1], [2, 3, 1], [3, 4, 1], [4, 5, 1], [5, 6, 1], [6, 7, 1], [4, 8, 1], [1, 3, 2], [5, 7, 3]]
[[clusters]]
name = "P1"
nodes = [1, 2, 3, 4, 8]
[[clusters.observers]]
center = 1
[[clusters]]
name = "P2"
nodes = [5, 6, 7]
[[clusters.observers]]
center = 6
[monitor]
positions = [2]
velocities = [1, 7]
"""
    system = System(loads_spec(data, "leaf.toml"))
    d = design_network(system, max_attackers=1, monitor_budget=1)
    old_v = set(system.spec.monitor.velocities) | set(system.spec.monitor.positions)
    added = set(d.spec.monitor.velocities) - old_v
    assert len(added) <= 1 and d.spec.monitor.positions == ()
    kinds = {(c.kind, c.action) for c in d.changes}
    assert ("monitor", "moved") in kinds  # the position monitor at 2, for privacy
    for a in added:
        assert any(c.kind == "monitor" and f"at {a}" in c.subject for c in d.changes)
    for m in d.spec.modes:
        assert any(c.kind == "mode" and m.name in c.subject for c in d.changes) or m.name in {x.name for x in system.spec.modes}
    for c in d.spec.clusters:
        for o in c.observers:
            new = (c.name, o.center) not in {(x.name, y.center) for x in system.spec.clusters for y in x.observers}
            replaced = any(p.cluster == c.name and p.center == o.center for p in d.observers)
            if new or replaced:
                assert any(ch.kind == "observer" and f"observer at {o.center} of {c.name}" in ch.subject for ch in d.changes)
    assert d.summary()[0].startswith("undetected ")  # the headline: undetected before -> after
    assert all(line.startswith(("audit", "- ", "NOT MET")) for line in d.summary()[1:])


def _called(fn_codes: dict[str, Any], run: Any) -> set[str]:
    """The rule functions (by condition id) whose code ran during ``run()``."""
    import sys
    import threading

    seen: set[str] = set()
    by_code = {code: cid for cid, code in fn_codes.items()}

    def prof(frame: Any, event: str, arg: Any) -> None:
        if event == "call" and frame.f_code in by_code:
            seen.add(by_code[frame.f_code])

    sys.setprofile(prof)
    threading.setprofile(prof)
    try:
        run()
    finally:
        sys.setprofile(None)
        threading.setprofile(None)  # type: ignore[arg-type]
    return seen


def test_each_condition_the_answer_reads_is_decided_by_one_function_that_verify_and_audit_both_call(paper19: System) -> None:
    import importlib
    import re
    from pathlib import Path

    import glocal_verify

    text = (Path(glocal_verify.__file__).parent.parent / "docs" / "architecture.md").read_text(encoding="utf-8")
    rules = {m.group(1): (m.group(2).replace("/", "."), m.group(3)) for m in re.finditer(r"^\| `([a-z.-]+)` \| `(glocal_verify/[^`]+)\.py` : `(\w+)`", text, re.M)}
    read = ["stealthy.zda", "local.pencil", "local.uio", "switching.image-kernel", "switching.distinct-eigenvalues", "switching.eigenvector-differences", "switching.avoids-attack"]
    codes = {cid: getattr(importlib.import_module(rules[cid][0]), rules[cid][1]).__code__ for cid in read}
    by_verify = _called(codes, lambda: verify(paper19, simulate="never", exact_budget=None))
    by_audit = _called(codes, lambda: audit(paper19, 2, [2, 3, 4, 5, 8]))
    assert by_verify == set(read), set(read) - by_verify
    # local.pencil: the audit's screens (a suspected boundary agent, a failing subset, twins,
    # the exact minors) decide most sets before the rule is needed; some still reach it
    assert by_audit == set(read), set(read) - by_audit


def _deployed_evidence(thresholds: Status | None, *guarantees: Status) -> Any:
    from glocal_verify.answer.attack import AttackEvidence, DeploymentEvidence, DeploymentMode, LocalEvidence, ModeEvidence

    theorem = {"switching.image-kernel": Status.HOLDS, "switching.distinct-eigenvalues": Status.HOLDS, "switching.eigenvector-differences": Status.HOLDS}
    modes = tuple(DeploymentMode(f"case-{i + 1}", g, "P1@5", 1.0, 8.0 + i, 1.0, 0.0025, "the zero run escapes" if g is Status.FAILS else "") for i, g in enumerate(guarantees))
    return AttackEvidence(
        "zda", (3, 4), (("P1", (3, 4), (5,)),), Status.HOLDS, 0.0, "spec",
        (LocalEvidence("P1", 5, (3, 4), Status.HOLDS, Status.HOLDS),), (ModeEvidence("case-1", theorem, Status.FAILS),),
        deployment=DeploymentEvidence(thresholds, modes),
    )


@pytest.mark.parametrize(
    ("thresholds", "guarantees", "guaranteed"),
    [
        (Status.HOLDS, (Status.FAILS, Status.HOLDS), True),
        (Status.HOLDS, (Status.FAILS, Status.FAILS), False),
        (Status.HOLDS, (Status.FAILS, Status.UNDECIDED), None),
        (Status.UNDECIDED, (Status.HOLDS,), None),
        (Status.HOLDS, (), None),
    ],
)
def test_the_deployment_answer_needs_certified_thresholds_and_one_proven_mode(thresholds: Status, guarantees: tuple[Status, ...], guaranteed: bool | None) -> None:
    from glocal_verify.answer.attack import answer_attack

    plain = answer_attack(dataclasses.replace(_deployed_evidence(thresholds, *guarantees), deployment=None))
    a = answer_attack(_deployed_evidence(thresholds, *guarantees))
    assert a.deployment is not None and a.deployment.guaranteed is guaranteed
    # a second answer beside the verdict: the paper's model decides the verdict alone
    assert plain.deployment is None and (a.verdict, a.chain) == (plain.verdict, plain.chain) == ("detected", plain.chain)
    if guaranteed:
        assert a.deployment.mode == "case-2" and a.deployment.detection_time == 9.0
        assert "P1@5" in a.deployment.chain[1] and "case-2" in a.deployment.chain[2]
    elif guaranteed is False:
        assert "zero run escapes" in a.deployment.reason and a.deployment.min_size == 0.0025


def test_a_deployment_guarantee_by_the_control_centre_alone_names_no_switch() -> None:
    from glocal_verify.answer.attack import DeploymentEvidence, DeploymentMode, answer_attack

    ev = _deployed_evidence(Status.HOLDS)
    ev = dataclasses.replace(ev, deployment=DeploymentEvidence(Status.HOLDS, (DeploymentMode("case-1", Status.HOLDS, None, None, 0.4, 1.0, 0.01),)))
    d = answer_attack(ev).deployment
    assert d is not None and d.guaranteed is True
    assert len(d.chain) == 2 and "before any switch" in d.chain[-1] and not any("switch to" in c for c in d.chain)
