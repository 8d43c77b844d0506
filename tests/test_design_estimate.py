"""The whole design's estimate counts the work the design does: attack sets audited and claims checked.

The estimate (:mod:`glocal_verify.conditions.design_cost`) multiplies counts by per-unit
seconds; the counts are what can be tested without timing anything. The run's audits are
counted where every audit of ``design`` goes through (``audit_chunks``), its checks where each
claimed set is decided against a proposed mode (``decide_zda`` in the safe-mode phase).
"""

from __future__ import annotations

import math
from typing import Any

import pytest

from glocal_verify import config
from glocal_verify.conditions.cost import SpecSizes
from glocal_verify.conditions.design_cost import design_work, estimate_safe_modes, estimate_whole_design
from glocal_verify.design.generators import symmetric_clusters_spec
from glocal_verify.model import System
from glocal_verify.spec import load_example

#: how far above the counts of the run the up-front counts may be
SMALL_FACTOR = 4.0


def _counted_design(monkeypatch: pytest.MonkeyPatch, spec: Any) -> tuple[int, int]:
    """(attack sets audited, claims checked) by ``design_network`` on ``spec`` with the defaults."""
    import glocal_verify.design.audit as audit_mod
    import glocal_verify.design.pruning as pruning
    import glocal_verify.design.safe_modes as safe_modes
    from glocal_verify.design.network import design_network

    counts = {"audited": 0, "checks": 0}
    chunks, decide = audit_mod.audit_chunks, safe_modes.decide_zda

    def counted_chunks(system: Any, sets: Any, *a: Any, **k: Any) -> Any:
        counts["audited"] += len(sets)
        return chunks(system, sets, *a, **k)

    def counted_decide(*a: Any, **k: Any) -> Any:
        counts["checks"] += 1
        return decide(*a, **k)

    monkeypatch.setattr(audit_mod, "audit_chunks", counted_chunks)
    monkeypatch.setattr(pruning, "audit_chunks", counted_chunks)
    monkeypatch.setattr(safe_modes, "decide_zda", counted_decide)
    design_network(System(spec))
    return counts["audited"], counts["checks"]


def _assert_bounds(spec: Any, audited: int, checks: int) -> None:
    from glocal_verify.design.network import CONFIRM_LIMIT

    work = design_work(SpecSizes.from_spec(spec), confirm_limit=CONFIRM_LIMIT, moves_positions=bool(spec.monitor.positions))
    assert audited <= work.audited <= SMALL_FACTOR * audited, (audited, work)
    assert checks <= work.checks <= SMALL_FACTOR * checks, (checks, work)


def test_the_up_front_counts_bound_the_audits_and_checks_of_a_small_symmetric_network(monkeypatch: pytest.MonkeyPatch) -> None:
    # measured 2026-12-08: 288 sets audited (78, 66, 66, 78) and 64 checks; the model says 468 and 78
    spec = symmetric_clusters_spec(12, 3, seed=1, degree=3.0)
    _assert_bounds(spec, *_counted_design(monkeypatch, spec))


@pytest.mark.slow
def test_the_up_front_counts_bound_the_audits_and_checks_of_paper19(monkeypatch: pytest.MonkeyPatch) -> None:
    # measured 2026-12-08: 675 sets audited (pruning 131 of them) and 80 checks; the model says 1,140 and 190
    spec = load_example("paper19")
    _assert_bounds(spec, *_counted_design(monkeypatch, spec))


def test_the_safe_mode_phase_checks_at_most_budget_times_confirm_limit_claims() -> None:
    # 200 agents in 8 symmetric clusters: 19,900 targets, but each of the 3 modes checks its first 64 claims
    sizes = SpecSizes.from_spec(symmetric_clusters_spec(200, 8, seed=1, degree=8.0))
    assert design_work(sizes, budget=3, confirm_limit=64, movable=19908, targets=19900).checks == 192
    assert design_work(sizes, budget=3, confirm_limit=64, movable=100, targets=50).checks == 50
    est = estimate_whole_design(sizes, budget=3, confirm_limit=64, movable=19908, targets=19900, from_safe_modes=True)
    check = estimate_safe_modes(sizes, 192).seconds - estimate_safe_modes(sizes, 0).seconds
    assert dict(est.phases)["design: checks of 192 undetected attack sets against the proposed modes"] == pytest.approx(check)


@pytest.mark.parametrize("n, clusters", [(19, 0), (60, 3), (200, 8)])
def test_what_is_left_at_the_safe_mode_phase_is_never_estimated_above_the_up_front_estimate(n: int, clusters: int) -> None:
    spec = load_example("paper19") if clusters == 0 else symmetric_clusters_spec(n, clusters, seed=1, degree=8.0)
    sizes = SpecSizes.from_spec(spec)
    whole = estimate_whole_design(sizes, budget=3, confirm_limit=64).seconds
    r = sizes.n + math.comb(sizes.n, 2)
    for movable in (0, 1, r // 3, r):
        for targets in (0, movable // 2, movable):
            left = estimate_whole_design(sizes, budget=3, confirm_limit=64, movable=movable, targets=targets, from_safe_modes=True)
            assert left.seconds <= whole, (movable, targets)


def test_the_design_is_not_refused_at_its_safe_mode_phase_after_the_up_front_estimate_accepted_it(monkeypatch: pytest.MonkeyPatch) -> None:
    # the 200-agent design of 2026-12-07: 3 min up front, then 17 min for the safe-mode phase (every
    # target counted as a check) and a refusal; the phase now estimates what is left by the same model
    from glocal_verify.conditions.cost import CostEstimate
    from glocal_verify.design.network import CONFIRM_LIMIT, design_network

    spec = symmetric_clusters_spec(12, 3, seed=1, degree=3.0)
    sizes = SpecSizes.from_spec(spec)
    seen: list[CostEstimate] = []
    with config.override(safe_mode_check_seconds=1.0):  # slow checks: the phase is most of the design
        design_network(System(spec), admit=seen.append, prune_changes=False)
        whole = estimate_whole_design(sizes, confirm_limit=CONFIRM_LIMIT)
    assert seen and all(e.seconds <= whole.seconds for e in seen)
    assert any("checks of 66 undetected attack sets" in name for name, _ in seen[0].phases)  # 66 targets, below 3 x 64
    assert seen[0].command == "the rest of design"


def test_the_monitor_step_estimate_adds_the_audit_with_its_monitors_and_their_pruning_as_new_work() -> None:
    from glocal_verify.conditions.design_cost import audit_seconds, estimate_monitor_step

    sizes = SpecSizes.from_spec(symmetric_clusters_spec(100, 4, seed=1, degree=8.0))
    alone = estimate_monitor_step(sizes, 6, 2)
    both = estimate_monitor_step(sizes, 6, 2, movable=4954, pruned=3)
    # measured 2026-12-08: the step audited 4,954 movable sets with its 2 monitors, and pruning audited each of 3 monitors on them
    more = design_work(sizes, movable=4954, monitors=3, from_safe_modes=True)
    less = design_work(sizes, movable=4954, monitors=0, from_safe_modes=True)
    assert more.audited - less.audited == 4 * 4954
    extra = sum(audit_seconds(sizes, 2, more).values()) - sum(audit_seconds(sizes, 2, less).values())
    assert both.seconds - alone.seconds == pytest.approx(extra)
    assert "not in the first estimate" in both.describe()
