"""One exact budget per ``verify`` call, enforced even inside long C calls; and the cheap exact
certificates (twin modes, verified unobservable vectors) that keep large networks from
needing escalation at all."""

from __future__ import annotations

from fractions import Fraction
import networkx as nx
import numpy as np
import pytest

import glocal_verify.conditions.registry as registry
from glocal_verify import config
from glocal_verify import System, spec_from_graph, verify
from glocal_verify.analysis.unobservable.subspace import certified_unobservable
from glocal_verify.numerics.deadline import DeadlineExceeded, call_with_deadline, hard_deadlines_available
from glocal_verify.results import ConditionResult, Status

pytestmark = pytest.mark.skipif(not hard_deadlines_available(), reason="hard deadlines need os.fork")


def _forever() -> int:
    # one builtin call that never returns to the interpreter: a signal handler cannot stop it
    return sum(range(10**15))


def test_a_deadline_returns_the_value_of_a_quick_computation() -> None:
    assert call_with_deadline(lambda: {"x": [1, 2, 3]}, 30.0) == {"x": [1, 2, 3]}


def test_a_deadline_re_raises_the_computations_own_exception() -> None:
    def boom() -> None:
        raise ZeroDivisionError("inside")

    with pytest.raises(ZeroDivisionError, match="inside"):
        call_with_deadline(boom, 30.0)


def test_a_deadline_stops_a_computation_stuck_in_one_c_call() -> None:
    with pytest.raises(DeadlineExceeded):
        call_with_deadline(_forever, 0.5)


def test_a_large_result_comes_back_through_the_pipe_whole() -> None:
    big = np.arange(3 * 10**5, dtype=float)
    got = call_with_deadline(lambda: big * 2, 30.0)
    assert np.array_equal(got, big * 2)


def _graph_with_twin_leaves() -> nx.Graph:
    # path 5 - 6 - 1 with leaves 2, 3, 4 on agent 1: the leaves are twins (equal rows of L)
    G = nx.Graph()
    G.add_edges_from([(5, 6), (6, 1), (1, 2), (1, 3), (1, 4)])
    return G


def test_two_twin_modes_with_one_eigenvalue_fail_distinct_eigenvalues_without_escalation() -> None:
    s = System(spec_from_graph(_graph_with_twin_leaves(), monitor_velocities=[5], modes={"safe": {"add": [(5, 1)]}}))
    [r] = verify(s, ["switching.distinct-eigenvalues"], escalate="never").conditions
    assert r.status is Status.FAILS
    L = s.laplacian("safe")
    mu = r.witness["eigenvalue"]
    u1, u2 = (np.array([v[lab] for lab in s.labels]) for v in r.witness["eigenvectors"])
    for u in (u1, u2):
        assert np.allclose(L @ u, mu * u, atol=1e-12)
    assert abs(u1 @ u2) < 1e-12
    Lq = s.laplacian_exact("safe")
    for v in r.witness["rational_eigenvectors"]:
        x = [Fraction(v[lab]) for lab in s.labels]
        Lx = [sum((Lq[i][j] * x[j] for j in range(s.n)), Fraction(0)) for i in range(s.n)]
        assert Lx == [r.witness["eigenvalue_exact"] * xi for xi in x]


def test_a_path_proves_distinct_eigenvalues_by_the_modular_certificate_too() -> None:
    from glocal_verify.analysis.laplacian.twins import distinct_eigenvalues_modular

    s = System(spec_from_graph(nx.path_graph(range(1, 9)), monitor_velocities=[8], modes={"longer": {"remove": [(7, 8)], "add": [(1, 8)]}}))
    decided = distinct_eigenvalues_modular(s, "longer")
    assert decided is not None and decided.status is Status.HOLDS


def test_unmonitored_twin_leaves_give_an_exactly_verified_unobservable_subspace() -> None:
    s = System(spec_from_graph(_graph_with_twin_leaves(), monitor_velocities=[5]))
    cu = certified_unobservable(s)
    # W = span(e2 - e3, e2 - e4), N ⊇ W x W, beside [1; 0] (no position monitor)
    assert cu.decided and cu.dim_lower == len(cu.structural) + 4 == 5
    assert len(cu.verified) == 4
    n = s.n
    L = s.laplacian_exact()
    alpha, gamma = Fraction(s.alpha_q), Fraction(s.gamma_q)
    M = set(s.idx(s.monitored))
    for b in cu.verified:
        x, v = list(b[:n]), list(b[n:])
        assert all(x[i] == 0 and v[i] == 0 for i in M)  # C b = 0 (every monitor reads x_i or v_i)
        # A b = [v; -alpha L x - gamma v] lies in span(verified): its x- and v-parts are in W
        Lx = [sum((L[i][j] * x[j] for j in range(n)), Fraction(0)) for i in range(n)]
        Ab = v + [-alpha * Lx[i] - gamma * v[i] for i in range(n)]
        W = np.array([[float(y) for y in w] for w in cu.verified])
        coef, *_ = np.linalg.lstsq(W.T, np.array([float(y) for y in Ab]), rcond=None)
        assert np.allclose(W.T @ coef, [float(y) for y in Ab], atol=1e-12)


def test_the_central_observer_is_decided_numerically_when_the_unobservable_part_is_twin_modes() -> None:
    s = System(spec_from_graph(_graph_with_twin_leaves(), monitor_velocities=[5], monitor_positions=[6]))
    [r] = verify(s, ["central.observer"], escalate="never").conditions
    assert r.status is not Status.UNDECIDED, r.note


def test_one_budget_covers_every_escalation_and_stops_a_stuck_one(monkeypatch: pytest.MonkeyPatch) -> None:
    real = registry._run_checker
    exact_calls: list[str] = []

    def fake(system: System, cid: str, ctx: registry.CheckContext) -> list[ConditionResult]:
        if cid not in ("central.observer", "switching.distinct-eigenvalues"):
            return real(system, cid, ctx)
        if ctx.exact:
            exact_calls.append(cid)  # recorded in the forked child only: the list of the parent stays empty
            _forever()
        return [registry.result(cid, ctx, Status.UNDECIDED, note="the bound did not separate the cases")]

    monkeypatch.setattr(registry, "_run_checker", fake)
    s = System(spec_from_graph(nx.path_graph(range(1, 7)), monitor_velocities=[1], modes={"cycle": {"add": [(1, 6)]}}))
    rep = verify(s, ["central.observer", "switching.distinct-eigenvalues", "privacy.connected"], exact_budget=1.0)
    by_id = {r.id: r for r in rep.conditions}
    assert by_id["privacy.connected"].status is Status.HOLDS
    for cid in ("central.observer", "switching.distinct-eigenvalues"):
        r = by_id[cid]
        assert r.status is Status.UNDECIDED
        assert "--exact-budget" in r.note and "the bound did not separate the cases" in r.note
    assert exact_calls == []
    # the cheap checker was given its share first; the costly one gets what is left
    assert "stopped after 0.5" in by_id["switching.distinct-eigenvalues"].note


def test_results_keep_the_catalogue_order_after_escalation() -> None:
    s = System(spec_from_graph(nx.path_graph(range(1, 7)), monitor_velocities=[1], modes={"cycle": {"add": [(1, 6)]}}))
    ids = ["privacy.connected", "switching.distinct-eigenvalues", "switching.coverage"]
    rep = verify(s, ids)
    assert [r.id for r in rep.conditions] == [r.id for r in verify(s, ids, escalate="never").conditions]
    [r] = [r for r in rep.conditions if r.id == "switching.distinct-eigenvalues"]
    assert r.status is Status.FAILS  # the 6-cycle repeats eigenvalues; escalated within the budget


def test_an_escalation_estimated_beyond_its_share_is_not_started(monkeypatch: pytest.MonkeyPatch) -> None:
    real = registry._run_checker

    def fake(system: System, cid: str, ctx: registry.CheckContext) -> list[ConditionResult]:
        if cid != "central.observer":
            return real(system, cid, ctx)
        if ctx.exact:
            raise AssertionError("the exact run must not start")
        return [registry.result(cid, ctx, Status.UNDECIDED, note="too large for the dense certificate")]

    monkeypatch.setattr(registry, "_run_checker", fake)
    s = System(spec_from_graph(nx.path_graph(range(1, 5)), monitor_velocities=[1]))
    with config.override(exact_central_seconds_n4=1e6 / s.n**4):
        [r] = verify(s, ["central.observer"], exact_budget=30.0).conditions
    assert r.status is Status.UNDECIDED
    assert "not started" in r.note and "1e+06 s" in r.note and "--exact" in r.note


def test_the_cheap_exact_certificates_agree_with_exact_arithmetic() -> None:
    from glocal_verify.analysis.unobservable.subspace import unobservable_subspace_exact

    twins = System(spec_from_graph(_graph_with_twin_leaves(), monitor_velocities=[5], modes={"safe": {"add": [(5, 1)]}}))
    path = System(spec_from_graph(nx.path_graph(range(1, 9)), monitor_velocities=[8], modes={"longer": {"remove": [(7, 8)], "add": [(1, 8)]}}))
    for s, ids in ((twins, ["switching.distinct-eigenvalues", "privacy.unobservable", "switched-observability", "central.observer"]),
                   (path, ["switching.distinct-eigenvalues"])):
        numeric = {(r.id, repr(r.scope)): r.status for r in verify(s, ids, escalate="never").conditions}
        exact = {(r.id, repr(r.scope)): r.status for r in verify(s, ids, exact=True).conditions}
        for key, st in numeric.items():
            assert st is Status.UNDECIDED or st is exact[key], (key, st, exact[key])
    # the proven dimension is the exact one
    cu = certified_unobservable(twins)
    assert cu.decided and cu.dim_lower == len(unobservable_subspace_exact(twins))


def test_a_zda_re_decision_beyond_the_certificates_reach_is_estimated_from_below_and_not_started_within_the_default_budget() -> None:
    from glocal_verify import config
    from glocal_verify.conditions.exact_cost import exact_seconds
    from glocal_verify.conditions.registry import exact_estimate
    from glocal_verify.design.generators import random_clustered_spec

    # N = 2000: the minor certificate alone (about 46 s) exceeds zda_certificate_max_seconds,
    # so the path is unknown; the estimate is at least the fast path's
    s = System(random_clustered_spec(2000, 20, seed=7, modes=1))
    est = exact_estimate(s, "switching.avoids-attack")
    assert est is not None and est >= exact_seconds("switching.avoids-attack", 2000, zda_path="fast")
    assert config.get("escalation_estimate_fraction") * est > 30.0
