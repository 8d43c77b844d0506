"""The attack-free envelope by the row (adjoint) recursion against the 2N-column reference."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from envelope_checks import assert_envelopes_agree
from glocal_verify import System, load_example, spec_from_dict
from glocal_verify.design.generators import random_clustered_spec
from glocal_verify.numerics.threads import ThreadSwitch, available_cores, blas_threads, default_threads
from glocal_verify.simulation.engine import simulate
from glocal_verify.simulation.observer_models import ObserverBank
from glocal_verify.simulation.schedule import Schedule
from glocal_verify.simulation.thresholds import attack_free_thresholds, envelope_by_columns


@pytest.fixture(scope="module")
def paper19() -> System:
    return System(load_example("paper19"))


@pytest.fixture(scope="module")
def bank(paper19: System) -> ObserverBank:
    return ObserverBank.for_system(paper19)


def _tiny() -> System:
    data: dict[str, Any] = {
        "format": 1,
        "name": "tiny4",
        "graph": {"nodes": 4, "edges": [[1, 2, 1], [2, 3, 2], [3, 4, 1], [1, 4, 1]]},
        "modes": [{"name": "q", "add": [[1, 3, 1]]}],
        "clusters": [{"name": "A", "nodes": [1, 2], "observers": [{"center": 1}]}, {"name": "B", "nodes": [3, 4], "observers": [{"center": 4}]}],
        "monitor": {"velocities": [1, 3]},
        "simulation": {"horizon": 3.0, "step": 0.05, "seed": 3},
    }
    return System(spec_from_dict(data))


def test_rows_and_columns_give_the_same_envelope_with_a_switch_between_samples(paper19: System, bank: ObserverBank) -> None:
    sched = Schedule.single("case-2", 1.013)
    th = attack_free_thresholds(paper19, bank, sched, horizon=2.5)
    t, ref = envelope_by_columns(paper19, bank, sched, horizon=2.5)
    assert np.array_equal(th.t, t)
    assert_envelopes_agree(dict(th.envelope), ref)


def test_rows_and_columns_agree_with_two_switches_on_the_grid_and_a_larger_box() -> None:
    tiny = _tiny()
    b = ObserverBank.for_system(tiny)
    sched = Schedule(((0.0, "normal"), (0.5, "q"), (1.25, "normal")))
    from glocal_verify.simulation.thresholds import ThresholdRule

    th = attack_free_thresholds(tiny, b, sched, ThresholdRule(box=2.5))
    _, ref = envelope_by_columns(tiny, b, sched, box=2.5, method="modal")
    assert_envelopes_agree(dict(th.envelope), ref)


def test_rows_and_columns_agree_on_a_random_clustered_network_with_mode_matched_observers() -> None:
    spec = random_clustered_spec(30, 3, seed=7, horizon=2.0, step=0.05)
    s = System(spec)
    b = ObserverBank.for_system(s)
    sched = Schedule.from_spec(s)
    th = attack_free_thresholds(s, b, sched)
    _, ref = envelope_by_columns(s, b, sched)
    assert_envelopes_agree(dict(th.envelope), ref)


def test_attack_free_runs_at_the_vertices_of_the_box_never_cross_the_row_envelope(paper19: System, bank: ObserverBank) -> None:
    sched = Schedule.single("case-1", 0.77)
    th = attack_free_thresholds(paper19, bank, sched, horizon=2.0)
    X = np.random.default_rng(1).choice([-1.0, 1.0], size=(38, 24))
    worst = simulate(paper19, schedule=sched, observers=bank, x0=X, horizon=2.0, batch_reduce="max-abs")
    for name, r in worst.residuals.items():
        assert np.all(r <= th.bound(name, worst.state_scale)), name


def test_progress_off_a_terminal_names_the_phase_and_its_end_without_the_internal_steps(paper19: System, bank: ObserverBank, capsys: pytest.CaptureFixture[str]) -> None:
    attack_free_thresholds(paper19, bank, Schedule.single("case-2", 0.5), horizon=1.0, progress=True)
    err = capsys.readouterr().err.splitlines()
    assert err and all(line.startswith("glocal-verify: thresholds: ") for line in err)
    news = [line for line in err if "% of the samples" not in line]  # those come every 10 s at most
    assert len(news) == 2, err  # start and end: no line per detector and segment (export printed 28-38)
    assert err[-1].startswith("glocal-verify: thresholds: done in "), err
    for jargon in ("unit states", "window sums", "segment", "2N"):
        assert not any(jargon in line for line in err), err


def test_blas_threads_never_exceeds_the_cores_and_restores_the_limit() -> None:
    from threadpoolctl import threadpool_info

    before = [i["num_threads"] for i in threadpool_info()]
    with blas_threads(10_000) as n:
        assert 1 <= n <= available_cores()
    with blas_threads(1) as n:
        assert n == 1
    assert [i["num_threads"] for i in threadpool_info()] == before


def test_a_thread_switch_sets_the_limit_inside_its_block_and_restores_it_after() -> None:
    from threadpoolctl import threadpool_info

    before = [i["num_threads"] for i in threadpool_info()]
    switch = ThreadSwitch()
    with switch.limit(1) as n:
        assert n == 1
        assert all(i["num_threads"] == 1 for i in threadpool_info())
        with switch.limit(None) as k:
            assert k == default_threads()
        assert all(i["num_threads"] == 1 for i in threadpool_info())
    with switch.limit(10_000) as n:
        assert 1 <= n <= available_cores()
    assert [i["num_threads"] for i in threadpool_info()] == before


def test_every_core_means_no_more_than_a_thread_limit_in_the_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    from glocal_verify.numerics.threads import environment_threads

    for key in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        monkeypatch.delenv(key, raising=False)
    assert environment_threads() is None and default_threads() == available_cores()
    monkeypatch.setenv("OMP_NUM_THREADS", "not a number")
    assert environment_threads() is None
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "1")
    assert default_threads() == 1
    with blas_threads(None) as n:
        assert n == 1
    with ThreadSwitch().limit(None) as n:
        assert n == 1


def test_a_nested_limit_to_the_count_in_force_keeps_it_and_the_outer_limit_survives() -> None:
    from threadpoolctl import threadpool_info

    before = [i["num_threads"] for i in threadpool_info()]
    switch = ThreadSwitch()
    with switch.limit(1):
        with switch.limit(1) as n:  # the count in force: no threadpoolctl call
            assert n == 1 and all(i["num_threads"] == 1 for i in threadpool_info())
        assert all(i["num_threads"] == 1 for i in threadpool_info())
        with blas_threads(1):
            assert all(i["num_threads"] == 1 for i in threadpool_info())
        assert all(i["num_threads"] == 1 for i in threadpool_info())
    assert [i["num_threads"] for i in threadpool_info()] == before
