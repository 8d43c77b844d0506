"""The unknown-input observer of eqs. obs_decent-uio_conds_3, designed and then simulated."""

from __future__ import annotations

from fractions import Fraction

import networkx as nx
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from glocal_verify import NotApplicableError, System, load_example, spec_from_graph
from glocal_verify.uio import (
    UnknownInputObserver,
    default_poles,
    design_uio,
    is_hurwitz_exact,
    local_uio,
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
    B = cm.B([3, 4])
    nx_ = len(x0)

    def rhs(t: float, w: np.ndarray) -> np.ndarray:
        x, z = w[:nx_], w[nx_:]
        y = uio.measure(x)
        return np.concatenate([cm.A @ x + cm.E @ d(t) + B @ u(t), uio.derivative(z, y)])

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
    from glocal_verify.spec import example_text, loads_spec

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
    assert is_hurwitz_exact([Fraction(x).limit_denominator(10**6) for x in c]) is hurwitz
