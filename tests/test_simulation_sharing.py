"""The fast paths of the simulator against their references: the row envelope's blocks, modal
columns and internal steps against the 2N-column envelope, shared observer step operators
against fresh ones, and one batched run per initial state against single runs."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from envelope_checks import assert_envelopes_agree
from glocal_verify import System, load_example, spec_from_dict
from glocal_verify.simulation import envelope as envelope_module
from glocal_verify.simulation.attacks import attack_from_spec
from glocal_verify.simulation.engine import simulate, simulate_runs
from glocal_verify.simulation.observer_models import ObserverBank
from glocal_verify.simulation.schedule import Schedule, random_initial_state
from glocal_verify.simulation.step_operators import StepOperators, observer_step_operator
from glocal_verify.simulation.thresholds import ThresholdRule, attack_free_thresholds, envelope_by_columns


def _tiny(alpha: float = 1.0, horizon: float = 3.0) -> System:
    data: dict[str, Any] = {
        "format": 1,
        "name": "tiny4",
        "dynamics": {"alpha": alpha, "gamma": 1},
        "graph": {"nodes": 4, "edges": [[1, 2, 1], [2, 3, 2], [3, 4, 1], [1, 4, 1]]},
        "modes": [{"name": "q", "add": [[1, 3, 1]]}],
        "clusters": [{"name": "A", "nodes": [1, 2], "observers": [{"center": 1}]}, {"name": "B", "nodes": [3, 4], "observers": [{"center": 4}]}],
        "monitor": {"velocities": [1, 3]},
        "simulation": {"horizon": horizon, "step": 0.05, "seed": 3},
    }
    return System(spec_from_dict(data))


@pytest.fixture(scope="module")
def tiny() -> System:
    return _tiny()


@pytest.fixture(scope="module")
def tiny_bank(tiny: System) -> ObserverBank:
    return ObserverBank.for_system(tiny)


# --------------------------------------------------------------------------------------------
# the row envelope


def test_envelope_rows_match_columns_across_two_switches_between_samples(tiny: System, tiny_bank: ObserverBank) -> None:
    sched = Schedule(((0.0, "normal"), (0.512, "q"), (1.237, "normal")))
    th = attack_free_thresholds(tiny, tiny_bank, sched, ThresholdRule(box=1.5))
    _, ref = envelope_by_columns(tiny, tiny_bank, sched, box=1.5, method="modal")
    assert_envelopes_agree(dict(th.envelope), ref)


def test_envelope_rows_match_columns_when_a_segment_holds_no_sample(tiny: System, tiny_bank: ObserverBank) -> None:
    sched = Schedule(((0.0, "normal"), (0.51, "q"), (0.53, "normal"), (2.0, "q")))
    th = attack_free_thresholds(tiny, tiny_bank, sched)
    _, ref = envelope_by_columns(tiny, tiny_bank, sched, method="modal")
    assert_envelopes_agree(dict(th.envelope), ref)


def test_envelope_rows_match_columns_with_several_internal_steps_per_output_step() -> None:
    stiff = _tiny(alpha=25.0, horizon=1.5)
    bank = ObserverBank.for_system(stiff)
    sched = Schedule(((0.0, "normal"), (0.7, "q")))
    res = simulate(stiff, schedule=sched, observers=bank, method="modal", record_states=False)
    assert res.internal_steps > 1
    th = attack_free_thresholds(stiff, bank, sched)
    _, ref = envelope_by_columns(stiff, bank, sched, method="modal")
    assert_envelopes_agree(dict(th.envelope), ref)


@pytest.mark.parametrize("doublings", [0, 1, 6])
def test_envelope_rows_match_columns_step_by_step_and_in_blocks_of_powers(
    tiny: System, tiny_bank: ObserverBank, monkeypatch: pytest.MonkeyPatch, doublings: int
) -> None:
    def fixed(steps: Any, mode: str, m: int, q: int, cols_after: int) -> int:
        return min(doublings, max(0, m.bit_length() - 1))

    monkeypatch.setattr(envelope_module, "_doublings", fixed)
    sched = Schedule(((0.0, "normal"), (1.0, "q")))
    th = attack_free_thresholds(tiny, tiny_bank, sched)
    _, ref = envelope_by_columns(tiny, tiny_bank, sched, method="modal")
    assert_envelopes_agree(dict(th.envelope), ref)


def test_envelope_rows_match_columns_on_a_random_network_whose_observers_keep_their_dynamics_after_the_switch() -> None:
    from glocal_verify.design.generators import random_clustered_spec

    s = System(random_clustered_spec(40, 2, seed=3, horizon=4.0, step=0.05))
    bank = ObserverBank.for_system(s)
    sched = Schedule.single("safe-1", 1.35)  # on the grid: no partial steps
    ops = StepOperators()
    th = attack_free_thresholds(s, bank, sched, step_operators=ops)
    _, ref = envelope_by_columns(s, bank, sched)
    assert_envelopes_agree(dict(th.envelope), ref)
    # one exponential per observer and dynamics in use: the central observer keeps A_1 after the
    # switch, a local observer without a mode-matched design keeps its own
    used = sum(len({o.dynamics_key(m) for m in ("normal", "safe-1")}) for o in bank)
    assert used < 2 * len(bank)
    assert ops.computed == used


@pytest.mark.parametrize("switch", [0.5, 1.0, 1.93])
def test_envelope_rows_continued_across_a_switch_on_the_grid_match_columns(monkeypatch: pytest.MonkeyPatch, switch: float) -> None:
    s = System(load_example("paper19"))
    bank = ObserverBank.for_system(s)
    used: list[str] = []
    across = envelope_module._across_the_switch

    def counted(steps: Any, *args: Any) -> None:
        used.append(steps.o.name)
        across(steps, *args)

    monkeypatch.setattr(envelope_module, "_across_the_switch", counted)
    sched = Schedule.single("case-2", switch)
    th = attack_free_thresholds(s, bank, sched, horizon=2.0)
    _, ref = envelope_by_columns(s, bank, sched, horizon=2.0)
    assert_envelopes_agree(dict(th.envelope), ref)
    # the observers whose dynamics do not change: the central one and a UIO with z(0) != 0
    assert set(used) == {"central", "P2@10", "P3@13"}
    assert np.any(bank["P2@10"].Z0)


# --------------------------------------------------------------------------------------------
# shared step operators


def test_a_step_operator_of_lower_taylor_order_is_the_leading_columns_of_a_higher_one(tiny_bank: ObserverBank) -> None:
    o = tiny_bank.observers[0]
    F, G = next(iter(o.F.values())), next(iter(o.G.values()))
    p = G.shape[1]
    ops = StepOperators()
    Phi8, W8 = ops.get(F, G, 8, 0.05)
    Phi5, W5 = ops.get(F, G, 5, 0.05)
    assert ops.computed == 1
    assert W8.shape[1] == 9 * p and W5.shape[1] == 6 * p
    ref_Phi, ref_W = observer_step_operator(F, G, 5, 0.05)
    assert np.max(np.abs(Phi5 - ref_Phi)) <= 1e-14 * max(1.0, float(np.abs(ref_Phi).max()))
    assert np.max(np.abs(W5 - ref_W)) <= 1e-14 * max(1.0, float(np.abs(ref_W).max()))
    # a higher order than stored is computed again; equal matrices that are other objects share
    ops.get(F, G, 10, 0.05)
    assert ops.computed == 2
    ops.get(F.copy(), G.copy(), 10, 0.05)
    ops.get(F, G, 10, 0.025)
    assert ops.computed == 3


def test_the_envelope_reuses_the_step_operators_of_the_simulations_of_one_pass() -> None:
    s = System(load_example("paper19"))
    bank = ObserverBank.for_system(s)
    sched = Schedule.single("case-2", 1.0)
    atk = attack_from_spec(s)
    ops = StepOperators()
    simulate(s, schedule=sched, attack=atk, observers=bank, horizon=2.0, method="modal", step_operators=ops)
    before = ops.computed
    assert before > 0
    shared = attack_free_thresholds(s, bank, sched, horizon=2.0, step_operators=ops)
    assert ops.computed == before
    fresh = attack_free_thresholds(s, bank, sched, horizon=2.0)
    for name, env in fresh.envelope.items():
        scale = max(1.0, float(env.max(initial=0.0)))
        assert np.max(np.abs(shared.envelope[name] - env), initial=0.0) <= 1e-12 * scale, name


# --------------------------------------------------------------------------------------------
# several runs in one batch


@pytest.mark.parametrize("method", ["dense", "modal"])
def test_simulate_runs_gives_each_run_of_simulate_with_an_attack_and_a_switch(method: str) -> None:
    s = System(load_example("paper19"))
    bank = ObserverBank.for_system(s)
    sched = Schedule.single("case-1", 0.77)
    atk = attack_from_spec(s)
    x1 = random_initial_state(s)
    x2 = np.zeros(2 * s.n)
    kw: dict[str, Any] = {"schedule": sched, "attack": atk, "observers": bank, "horizon": 2.0, "method": method}
    both = simulate_runs(s, [x1, x2], **kw)
    assert len(both) == 2
    for x0, got in zip((x1, x2), both):
        ref = simulate(s, x0=x0, **kw)
        assert got.method == ref.method and got.taylor_order == ref.taylor_order
        assert np.array_equal(got.t, ref.t)
        assert got.x is not None and ref.x is not None
        scale = max(1.0, float(np.max(ref.state_scale)))
        assert np.max(np.abs(got.x - ref.x)) <= 1e-12 * scale
        assert np.max(np.abs(got.state_scale - ref.state_scale)) <= 1e-12 * scale
        for name, r in ref.residuals.items():
            assert got.residuals[name].shape == r.shape
            assert np.max(np.abs(got.residuals[name] - r), initial=0.0) <= 1e-12 * scale, name


def test_simulate_runs_of_no_initial_state_is_empty() -> None:
    s = System(load_example("paper19"))
    assert simulate_runs(s, [], horizon=0.5) == ()
