"""The unknown-input observer of eqs. obs_decent-uio_conds_3, designed and then simulated."""

from __future__ import annotations

from fractions import Fraction

import networkx as nx
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp
from strategies import clustered_systems

from glocal_verify import config
from glocal_verify import NotApplicableError, System, load_example, spec_from_graph
from glocal_verify.observers.uio import UnknownInputObserver, design_uio, local_uio
from glocal_verify.numerics.hurwitz import routh_hurwitz
from glocal_verify.observers.uio_existence import (
    default_poles,
    observable_split,
    uio_existence,
)


@pytest.fixture(scope="module")
def paper19() -> System:
    return System(load_example("paper19"))


def _observer(system: System, cluster: str, center: int) -> UnknownInputObserver:
    (obs,) = [o for o in system.observers(cluster) if o.center == center]
    return local_uio(system, obs)


def _zda_of_agents_3_and_4(system: System, lam: float) -> tuple[np.ndarray, np.ndarray]:
    """Cluster P1 state x0 = [xi; lam xi] and input u0 with (s I + alpha L) xi = S_F^T u0."""
    cm = system.cluster_model("P1")
    n = len(cm.nodes)
    xi = np.zeros(n)
    xi[cm.nodes.index(3)], xi[cm.nodes.index(4)] = 1.0, -2.0
    s = lam * lam + system.gamma * lam
    r = (s * np.eye(n) + system.alpha * cm.L) @ xi
    assert set(np.flatnonzero(np.abs(r) > 1e-12)) <= {cm.nodes.index(3), cm.nodes.index(4)}
    u0 = r[[cm.nodes.index(3), cm.nodes.index(4)]]
    return np.concatenate([xi, lam * xi]), u0


def _simulate(uio: UnknownInputObserver, system: System, x0: np.ndarray, u, d, t_end: float):  # type: ignore[no-untyped-def]
    """Cluster x' = A x + E d(t) + B u(t) and observer z' = F z + K y, x_hat(0) = 0."""
    cm = system.cluster_model(uio.cluster)
    A, B = cm.A, cm.B([3, 4])
    nx_ = len(x0)

    def rhs(t: float, w: np.ndarray) -> np.ndarray:
        x, z = w[:nx_], w[nx_:]
        y = uio.measure(x)
        return np.concatenate([A @ x + cm.E @ d(t) + B @ u(t), uio.derivative(z, y)])

    z0 = uio.initial_state(uio.measure(x0))
    ts = np.linspace(0.0, t_end, 301)
    sol = solve_ivp(rhs, (0.0, t_end), np.concatenate([x0, z0]), t_eval=ts, rtol=1e-10, atol=1e-12, method="DOP853")
    X, Z = sol.y[:nx_], sol.y[nx_:]
    err = np.array([X[:, k] - uio.estimate(Z[:, k], uio.measure(X[:, k])) for k in range(len(ts))])
    res = np.array([uio.residual(Z[:, k], uio.measure(X[:, k])) for k in range(len(ts))])
    return ts, X.T, err, res


def test_the_designed_uio_meets_the_conditions_of_chen_patton_zhang(paper19: System) -> None:
    uio = _observer(paper19, "P1", 5)
    n = uio.F.shape[0]
    assert np.allclose((uio.h @ uio.C - np.eye(n)) @ uio.E, 0.0, atol=1e-12)
    assert np.allclose(uio.T, np.eye(n) - uio.h @ uio.C)
    assert np.allclose(uio.A1, uio.T @ uio.A)
    assert np.allclose(uio.F, uio.A1 - uio.K1 @ uio.C)
    assert np.allclose(uio.K, uio.K1 + uio.F @ uio.h)
    # the error equation has no term in the cluster state nor in the neighbour input
    assert np.allclose(uio.T @ uio.A - uio.F @ uio.T - uio.K @ uio.C, 0.0, atol=1e-9)
    assert np.max(np.linalg.eigvals(uio.F).real) < 0
    assert uio.decoupling_residual < 1e-12 and uio.error_residual < 1e-9


def test_the_default_poles_move_only_the_slow_observable_modes(paper19: System) -> None:
    uio = _observer(paper19, "P1", 5)
    assert np.max(uio.eigenvalues.real) <= -0.45 + 1e-6
    mu = np.linalg.eigvals(uio.A1)  # everything is observable here
    want = default_poles(mu, 1.0)
    for p in want:
        assert np.min(np.abs(uio.eigenvalues - p)) < 1e-6
    assert uio.hurwitz.value == "holds" and uio.hurwitz_ratio > 1e3


def test_default_poles_spread_repeated_eigenvalues_and_keep_conjugate_pairs() -> None:
    p = default_poles(np.array([0.5, 0.5, -3.0, 1 + 2j, 1 - 2j, -0.95]), 2.0)
    assert len(set(np.round(p, 9))) == 6
    assert np.all(p.real <= -0.9)
    assert p[2] == -3.0 and p[5] == -0.95  # fast enough already: kept
    assert np.isclose(p[0], -1.5) and np.isclose(p[3], np.conj(p[4])) and np.isclose(p[3], -2 + 2j)


def test_user_poles_are_used_and_missing_ones_are_filled_to_their_left() -> None:
    G = nx.path_graph([1, 2, 3, 4])
    spec = spec_from_graph(
        G,
        clusters={"A": [1, 2], "B": [3, 4]},
        observers={"A": [{"center": 1, "positions": [1, 2], "velocities": [1, 2], "poles": [-3, -4]}], "B": [3]},
    )
    s = System(spec)
    uio = local_uio(s, s.observers("A")[0])
    ev = np.sort(uio.eigenvalues.real)
    assert np.isclose(ev[-1], -3.0, atol=1e-6) and np.isclose(ev[-2], -4.0, atol=1e-6)
    assert np.all(ev[:-2] < -4.0 - 1e-6) and uio.notes


def test_the_error_vanishes_without_attack_whatever_the_neighbours_do(paper19: System) -> None:
    uio = _observer(paper19, "P1", 5)
    rng = np.random.default_rng(3)
    x0 = rng.normal(size=14)
    # a growing, oscillating neighbour input through the cut edge 7-8
    ts, X, err, res = _simulate(uio, paper19, x0, lambda t: np.zeros(2), lambda t: np.array([3 * np.sin(2 * t) + 0.5 * t]), 45.0)
    assert np.linalg.norm(err[0]) > 0.1
    assert np.linalg.norm(err[-1]) < 1e-5 * np.linalg.norm(err[0])
    assert np.linalg.norm(res[-1]) < 1e-5
    assert np.linalg.norm(X[-1]) > 1.0  # the cluster itself does not settle: d keeps driving it


def test_a_zda_on_agents_3_and_4_keeps_the_error_of_observer_5_away_from_zero(paper19: System) -> None:
    uio = _observer(paper19, "P1", 5)
    lam = 0.5
    x0, u0 = _zda_of_agents_3_and_4(paper19, lam)
    ts, X, err, res = _simulate(uio, paper19, x0, lambda t: u0 * np.exp(lam * t), lambda t: np.array([np.cos(t)]), 12.0)
    # with x_hat(0) = 0 the error starts at x0 and, instead of decaying, grows with the attack
    assert np.linalg.norm(err[-1]) > 10 * np.linalg.norm(err[0])
    assert np.linalg.norm(res[-1]) > 10 * np.linalg.norm(res[0])


def test_the_same_zda_keeps_the_residual_of_observer_6_at_zero(paper19: System) -> None:
    # observer 6 does not see agents 3 and 4: local.pencil fails there, and the residual shows why
    uio = _observer(paper19, "P1", 6)
    lam = 0.5
    x0, u0 = _zda_of_agents_3_and_4(paper19, lam)
    ts, X, err, res = _simulate(uio, paper19, x0, lambda t: u0 * np.exp(lam * t), lambda t: np.zeros(1), 12.0)
    assert np.max(np.abs(res)) < 1e-7 * np.max(np.abs(X))
    assert np.linalg.norm(err[-1]) > 10 * np.linalg.norm(err[0])


def test_an_unmeasured_boundary_agent_makes_the_design_refuse_with_the_reason() -> None:
    # paper19 with the P3 observer moved to 16, whose neighbours (15, 17, 18) miss the
    # boundary agent 13
    from glocal_verify.spec import loads_spec
    from glocal_verify.spec.examples import example_text

    text = example_text("paper19").replace("center = 13 ", "center = 16 ")
    system = System(loads_spec(text))
    (obs,) = system.observers("P3")
    assert obs.center == 16
    with pytest.raises(NotApplicableError, match="boundary agent"):
        local_uio(system, obs)


def test_an_unstable_unobservable_mode_of_a1_is_reported() -> None:
    # x' = A x + E d with the unknown input on the only measured state: the other state is
    # invisible after decoupling and unstable
    A = np.array([[1.0, 0.0], [1.0, -1.0]])
    E = np.array([[0.0], [1.0]])
    C = np.array([[0.0, 1.0]])
    ex = uio_existence(A, E, C)
    assert ex.status.value == "fails" and ex.unstable_mode is not None
    lam, v = ex.unstable_mode
    assert lam.real >= 0
    A1 = ex.A1
    assert A1 is not None
    assert np.allclose(A1 @ v, lam * v) and np.allclose(C @ v, 0.0)
    with pytest.raises(NotApplicableError, match="unobservable mode"):
        design_uio(A, E, C)


def test_the_observable_split_matches_the_kalman_rank_on_a_small_case() -> None:
    rng = np.random.default_rng(1)
    A = np.diag([-1.0, -2.0, -3.0, -4.0])
    C = np.array([[1.0, 1.0, 0.0, 0.0]])
    sp = observable_split(A + 0 * rng.normal(size=(4, 4)), C)
    assert sp.Qo.shape[1] == 2 and sp.Qu.shape[1] == 2 and sp.decided
    assert np.allclose(C @ sp.Qu, 0.0)
    # invariance of the unobservable subspace
    P = sp.Qu @ sp.Qu.T
    assert np.allclose(P @ A @ sp.Qu, A @ sp.Qu)


@pytest.mark.parametrize(
    ("roots", "hurwitz"),
    [([-1, -2, -3], True), ([1, -2], False), ([-1 + 2j, -1 - 2j, -0.5], True), ([2j, -2j, -1], False), ([0, -1], False), ([-1, -1, -1, -1], True)],
)
def test_the_routh_test_agrees_with_the_roots(roots: list[complex], hurwitz: bool) -> None:
    c = np.poly(roots).real[::-1]
    assert routh_hurwitz([Fraction(x).limit_denominator(10**6) for x in c][::-1]) is hurwitz


# --------------------------------------------------------------------------------------------
# at scale: structured detectability, cached designs, conditioned default placement


def test_a_near_real_conjugate_pair_keeps_its_pair_when_spread() -> None:
    # Im rounded to 8 digits is 0 for both members: they used to be counted as one repeated
    # value, only the second was shifted, and place_poles refused the broken pair
    p = default_poles(np.array([-0.1 + 1e-10j, -0.1 - 1e-10j, 0.2, 0.2, 0.1 + 1j, 0.1 - 1j, 0.1 + 1j, 0.1 - 1j]), 1.0)
    assert p[0] == np.conj(p[1])
    assert p[4] == np.conj(p[5]) and p[6] == np.conj(p[7]) and p[4] != p[6]
    assert p[2] != p[3]


def _case_matrices(system: System, cluster: str, positions: list[int], velocities: list[int]) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[int], list[int]]:
    cm = system.cluster_model(cluster)
    idx = {a: k for k, a in enumerate(cm.nodes)}
    return cm.A, cm.E, cm.C(positions, velocities), [idx[a] for a in cm.boundary], [idx[a] for a in positions]


def test_structured_detectability_finds_the_marginal_mode_of_a_velocity_only_boundary() -> None:
    from glocal_verify.observers.uio_existence import cluster_detectability

    G = nx.Graph()
    G.add_weighted_edges_from([(1, 2, 1), (2, 3, 1), (1, 4, 1), (4, 5, 1)])
    s = System(spec_from_graph(G, clusters={"A": [1, 2, 3], "B": [4, 5]}, observers={"A": [{"center": 1, "positions": [], "velocities": [1]}], "B": [4]}))
    A, E, C, bnd, pos = _case_matrices(s, "A", [], [1])
    got = cluster_detectability(s.cluster_model("A").L, bnd, pos)
    st, p, how = got.status, got.positions, got.by
    assert st.value == "fails" and how == "rank" and p is not None
    ex = uio_existence(A, E, C)
    assert ex.status.value == "fails"
    # [p; 0] is an unobservable eigenvector of A1 at 0
    x = np.concatenate([p, np.zeros_like(p)])
    assert ex.A1 is not None
    assert np.allclose(ex.A1 @ x, 0.0) and np.allclose(C @ x, 0.0) and np.linalg.norm(x) > 0.5
    # the position of 1 too: decided by rank (1 is an input row and cannot force)
    got1 = cluster_detectability(s.cluster_model("A").L, bnd, [0])
    st1, p1, how1 = got1.status, got1.positions, got1.by
    assert st1.value == "holds" and p1 is None and how1 == "rank"
    # the position of 3: zero forcing proves it (3 forces 2, 2 forces 1)
    got2 = cluster_detectability(s.cluster_model("A").L, bnd, [2])
    st2, p2, how2 = got2.status, got2.positions, got2.by
    assert st2.value == "holds" and p2 is None and how2 == "zero forcing"


@settings(max_examples=30)
@given(clustered_systems(max_n=12), st.data())
def test_structured_and_generic_detectability_agree(system: System, data: st.DataObject) -> None:
    from glocal_verify.observers.uio_existence import cluster_detectability

    for c in system.clusters:
        cm = system.cluster_model(c.name)
        nodes = list(cm.nodes)
        pos = data.draw(st.lists(st.sampled_from(nodes), unique=True, max_size=len(nodes)))
        vel = list(dict.fromkeys(data.draw(st.lists(st.sampled_from(nodes), unique=True, max_size=len(nodes))) + list(cm.boundary)))
        A, E, C, bnd, pidx = _case_matrices(system, c.name, pos, vel)
        ex = uio_existence(A, E, C)
        assert ex.rank_condition.value == "holds"
        got = cluster_detectability(cm.L, bnd, pidx)
        st_, p = got.status, got.positions
        if ex.detectable.value != "undecided" and st_.value != "undecided":
            assert st_ is ex.detectable, (c.name, pos, vel, ex.unobservable_eigenvalues)
        if p is not None:
            x = np.concatenate([p, np.zeros_like(p)])
            assert ex.A1 is not None and np.allclose(ex.A1 @ x, 0.0, atol=1e-9) and np.allclose(C @ x, 0.0)


def test_the_observable_split_is_orthonormal_and_invariant_on_a_generated_cluster() -> None:
    from glocal_verify.design.generators import random_clustered_spec

    s = System(random_clustered_spec(150, 3, seed=4))
    (obs,) = s.observers("P2")
    cm = s.cluster_model("P2")
    C = cm.C(obs.positions, obs.velocities)
    ex = uio_existence(cm.A, cm.E, C)
    assert ex.split is not None and ex.A1 is not None
    Qo, Qu = ex.split.Qo, ex.split.Qu
    Q = np.hstack([Qo, Qu])
    assert Q.shape == (2 * len(cm.nodes), 2 * len(cm.nodes))
    assert np.allclose(Q.T @ Q, np.eye(Q.shape[1]), atol=1e-10)
    assert np.allclose(C @ Qu, 0.0, atol=1e-10)
    assert np.linalg.norm(Qo.T @ ex.A1 @ Qu) < 1e-8 * np.linalg.norm(ex.A1)  # unobservable part A1-invariant


def test_local_uio_reuses_one_design_per_cluster_block_and_gets_the_same_results(monkeypatch: pytest.MonkeyPatch) -> None:
    import glocal_verify.observers.uio_verdict as local
    from glocal_verify import verify
    from glocal_verify.analysis.local.cases import local_cases
    from glocal_verify.design.generators import random_clustered_spec

    s = System(random_clustered_spec(60, 3, seed=2))
    calls: list[int] = []
    real = local.design_uio

    def counting(*a, **k):  # type: ignore[no-untyped-def]
        calls.append(1)
        return real(*a, **k)

    monkeypatch.setattr(local, "design_uio", counting)
    rep = verify(s, ["local.uio"])
    # a safe mode adds one link inside one cluster: the other clusters keep their design, and
    # the two suspected sets of an observer share it
    changed = sum(
        1 for c in s.clusters for m in s.safe_modes if not np.array_equal(s.cluster_model(c.name, m).A, s.cluster_model(c.name).A)
    )
    assert len(calls) == len(s.clusters) + changed < 2 * len(s.clusters) * len(s.modes)
    calls.clear()
    uncached = {}
    for case in local_cases(s):
        uncached[tuple(sorted(case.scope.items(), key=str))] = local.uio_verdict(s, case)
    assert len(calls) == 2 * len(s.clusters) * len(s.modes)
    for r in rep.conditions:
        got = uncached[tuple(sorted(r.scope.items(), key=str))]
        st_, mg, w = got.status, got.margin, got.witness
        assert r.status is st_ and r.margin == pytest.approx(mg)
        assert w["normal"]["eigenvalues_F"] == r.witness["normal"]["eigenvalues_F"]
        assert w.get("normal", {}).get("attack_invisible") == r.witness["normal"].get("attack_invisible")


def test_an_uncertified_large_gain_design_is_redone_moving_fewer_slow_modes(paper19: System, monkeypatch: pytest.MonkeyPatch) -> None:
    import glocal_verify.observers.uio as uio

    (obs,) = [o for o in paper19.observers("P1") if o.center == 5]
    cm = paper19.cluster_model("P1")
    C = cm.C(obs.positions, obs.velocities)
    _, d0 = design_uio(cm.A, cm.E, C, gamma=paper19.gamma)
    assert not d0["notes"] and d0["hurwitz"].value == "holds"
    # pretend the default design were not certified and its gain large: the ladder moves only
    # the modes with Re > -0.3 sigma, keeps the others where they are, and says so
    real = uio.hurwitz_eigenvalues
    seen: list[int] = []

    def first_undecided(F, tol):  # type: ignore[no-untyped-def]
        got = real(F, tol)
        seen.append(1)
        return uio.HurwitzCertificate(uio.Status.UNDECIDED, got.ratio, got.eigenvalues) if len(seen) == 1 else got

    monkeypatch.setattr(uio, "hurwitz_eigenvalues", first_undecided)
    with config.override(uio_ladder_gain=0.0):
        ex, d = design_uio(cm.A, cm.E, C, gamma=paper19.gamma)
        assert len(seen) == 2 and d["hurwitz"].value == "holds"
        assert any("retried moving only Re > -0.3 sigma" in n for n in d["notes"])
        assert ex.A1 is not None
        mu = np.linalg.eigvals(ex.A1)
        kept = [m for m in mu if m.real <= -0.3 * paper19.gamma / 2]
        for m in kept:  # not moved
            assert np.min(np.abs(d["eigenvalues"] - m)) < 1e-6
        assert np.max(d["eigenvalues"].real) < 0
        assert np.allclose(d["T"] @ cm.A - d["F"] @ d["T"] - d["K"] @ C, 0.0, atol=1e-9)
