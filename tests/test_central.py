"""The centralised observer (eq. ``obs_cent``): design, spectrum, the Hurwitz finding."""

from __future__ import annotations

from fractions import Fraction

import networkx as nx
import numpy as np
import pytest

from glocal_verify import System, load_example, spec_from_graph, verify
from glocal_verify.numerics.hurwitz import routh_hurwitz
from glocal_verify.observers.central import design_central_observer
from glocal_verify.results import Method, Status


def _system(G: nx.Graph, **kw: object) -> System:
    return System(spec_from_graph(G, **kw))  # type: ignore[arg-type]


def _same_spectrum(a: np.ndarray, b: np.ndarray, tol: float) -> bool:
    """Greedy matching of two eigenvalue multisets."""
    if len(a) != len(b):
        return False
    rest = list(b)
    for z in a:
        k = int(np.argmin([abs(z - y) for y in rest]))
        if abs(z - rest[k]) > tol:
            return False
        rest.pop(k)
    return True


@pytest.fixture(scope="module")
def paper19() -> System:
    return System(load_example("paper19"))


def test_zero_is_an_eigenvalue_of_every_mode_closed_loop_when_privacy_holds(paper19: System) -> None:
    obs = design_central_observer(paper19)
    e = np.concatenate([np.ones(paper19.n), np.zeros(paper19.n)])
    for mode in paper19.modes:
        M = paper19.A(mode) - obs.H @ paper19.C()
        assert np.linalg.norm(M @ e) < 1e-12  # [1; 0] is a null vector for every H
        assert np.min(np.abs(np.linalg.eigvals(M))) < 1e-9
    assert np.allclose(obs.fixed_eigenvalues, [0.0])
    rep = verify(paper19, ["central.observer"])
    assert any(f.id == "central.hurwitz-infeasible" for f in rep.findings)
    assert all(v < 1e-12 for v in rep.conditions[0].witness["consensus_null_residual"].values())


def test_the_observable_part_is_stable_and_the_spectrum_matches_dense_eigenvalues(paper19: System) -> None:
    obs = design_central_observer(paper19)
    assert obs.method == "riccati" and obs.observable_states == 2 * paper19.n - 1
    assert obs.stability_margin > 0.1
    assert np.all(obs.observable_eigenvalues.real < 0)
    dense = np.linalg.eigvals(paper19.A() - obs.H @ paper19.C())
    assert _same_spectrum(dense, obs.eigenvalues, 1e-7)
    (r,) = verify(paper19, ["central.observer"]).conditions
    assert r.status is Status.HOLDS and r.margin == pytest.approx(obs.stability_margin)


def test_a_position_monitor_makes_the_consensus_mode_observable_and_the_gain_moves_zero() -> None:
    s = _system(nx.path_graph(range(1, 6)), monitor_positions=[1], monitor_velocities=[5])
    obs = design_central_observer(s)
    assert len(obs.fixed_eigenvalues) == 0
    M = s.A() - obs.H @ s.C()
    assert np.max(np.linalg.eigvals(M).real) < -1e-3
    rep = verify(s, ["central.observer"])
    assert rep.conditions[0].status is Status.HOLDS
    assert not any(f.id == "central.hurwitz-infeasible" for f in rep.findings)


def test_pole_placement_places_the_requested_poles() -> None:
    s = _system(nx.path_graph(range(1, 4)), monitor_velocities=[1, 3])
    obs0 = design_central_observer(s)
    poles = [-1.0, -1.5, -2.0, -2.5, -3.0][: obs0.observable_states]
    obs = design_central_observer(s, poles=poles)
    assert obs.method == "place_poles" and obs.designed_states == len(poles)
    assert _same_spectrum(np.sort_complex(obs.observable_eigenvalues), np.array(poles, dtype=complex), 1e-8)
    dense = np.linalg.eigvals(s.A() - obs.H @ s.C())
    assert _same_spectrum(dense, obs.eigenvalues, 1e-7)


def test_a_number_of_poles_that_splits_no_block_names_the_admissible_sizes() -> None:
    s = _system(nx.path_graph(range(1, 5)), monitor_velocities=[1])
    with pytest.raises(ValueError, match="cumulative sizes"):
        design_central_observer(s, poles=[-1.0, -2.0, -3.0, -4.0, -5.0, -6.0, -7.0, -8.0, -9.0])


def test_a_large_sparse_network_is_designed_in_modal_coordinates() -> None:
    G = nx.connected_watts_strogatz_graph(150, 4, 0.2, seed=3)
    G = nx.relabel_nodes(G, {v: v + 1 for v in G})
    s = _system(G, monitor_velocities=[1, 50, 100])
    obs = design_central_observer(s)
    assert obs.H.shape == (300, 3) and obs.designed_states <= 100 < obs.observable_states
    assert obs.stability_margin > 0 and len(obs.fixed_eigenvalues) == obs.unobservable.dim
    # the modal spectrum is the spectrum of the dense closed loop
    dense = np.linalg.eigvals(s.A() - obs.H @ s.C())
    assert abs(np.max(dense.real) - np.max(obs.eigenvalues.real)) < 1e-8
    assert np.sum(np.abs(dense) < 1e-9) == 1


def test_routh_hurwitz_decides_exactly() -> None:
    F = Fraction
    assert routh_hurwitz([F(1), F(3), F(2)])  # (s+1)(s+2)
    assert not routh_hurwitz([F(1), F(0), F(1)])  # s^2 + 1
    assert not routh_hurwitz([F(1), F(1), F(0)])  # s (s + 1)
    assert routh_hurwitz([F(1), F(6), F(11), F(6)])  # (s+1)(s+2)(s+3)
    assert not routh_hurwitz([F(1), F(1), F(2), F(8)])  # roots with Re > 0
    assert not routh_hurwitz([F(1), F(2), F(1), F(2)])  # (s+2)(s^2+1): a zero row
    assert routh_hurwitz([F(-2), F(-3)])


@pytest.mark.parametrize("monitors", [{"monitor_velocities": [1]}, {"monitor_velocities": [2, 5]}, {"monitor_positions": [3]}])
def test_numeric_and_exact_central_verdicts_agree(monitors: dict[str, list[int]]) -> None:
    G = nx.Graph()
    G.add_weighted_edges_from([(1, 2, 1), (2, 3, 2), (3, 4, 1), (4, 5, 3), (2, 5, 1), (5, 6, 1)])
    s = _system(G, **monitors)
    (rn,) = verify(s, ["central.observer"]).conditions
    (re_,) = verify(s, ["central.observer"], exact=True).conditions
    assert re_.method is Method.EXACT and re_.status is rn.status is Status.HOLDS
    assert "Hurwitz" in re_.witness["exact"]


@pytest.mark.parametrize(
    "graph, positions, velocities",
    [
        (nx.star_graph(5), [1], [0]),  # twin leaves: an unobservable group with mu > 0
        (nx.path_graph(7), [], [3]),  # velocity only: H = 0, [1; 0] fixed
        (nx.cycle_graph(8), [0, 4], [2]),  # repeated eigenvalues, positions injected
        (nx.disjoint_union(nx.path_graph(4), nx.path_graph(3)), [0], [5]),  # a component measured in velocity only
    ],
)
def test_the_injection_design_has_the_spectrum_of_its_closed_loop(graph: nx.Graph, positions: list[int], velocities: list[int]) -> None:
    G = nx.relabel_nodes(graph, {v: v + 1 for v in graph.nodes})
    s = _system(G, monitor_positions=[p + 1 for p in positions], monitor_velocities=[v + 1 for v in velocities])
    obs = design_central_observer(s, method="injection")
    assert obs.method == "injection"
    closed = np.linalg.eigvals(s.A() - obs.H @ s.C())
    assert _same_spectrum(obs.eigenvalues, closed, 1e-7)
    assert len(obs.observable_eigenvalues) == obs.observable_states
    # every observable eigenvalue is in the open left half-plane (the theorem), and the
    # exact quotient agrees (Routh-Hurwitz over Q)
    assert np.all(obs.observable_eigenvalues.real < 0)
    from glocal_verify import config

    with config.override(central_certify_max_states=0):
        v = verify(System(s.spec), only=["central.observer"], exact=True).results("central.observer")[0]
        numeric = verify(System(s.spec), only=["central.observer"]).results("central.observer")[0]
    assert v.status is Status.HOLDS and numeric.status is Status.HOLDS
    assert numeric.witness["design"]["method"] == "injection"
    from glocal_verify.observers.central_verdict import observable_hurwitz_exact

    ok, why = observable_hurwitz_exact(s, obs)
    assert ok, why


def test_a_large_observable_part_gets_the_injection_design_and_a_decided_verdict() -> None:
    from glocal_verify.design.generators import random_clustered_spec

    s = System(random_clustered_spec(450, 4, seed=7, modes=1))
    r = verify(s, only=["central.observer"]).results("central.observer")[0]
    assert r.witness["design"]["observable_states"] > 800
    assert r.witness["design"]["method"] == "injection"
    assert r.status is Status.HOLDS
    assert "no Jordan chain" in r.witness["certificate"]["by"]


def test_the_injection_design_and_the_certified_riccati_design_agree_on_a_medium_network() -> None:
    from glocal_verify import config
    from glocal_verify.design.generators import random_clustered_spec

    s = System(random_clustered_spec(150, 3, seed=3, modes=1))
    riccati = verify(s, only=["central.observer"]).results("central.observer")[0]
    with config.override(central_certify_max_states=0):
        injection = verify(System(s.spec), only=["central.observer"]).results("central.observer")[0]
    assert riccati.witness["design"]["method"] == "riccati" and injection.witness["design"]["method"] == "injection"
    assert riccati.status is injection.status is Status.HOLDS
    # the unobservable part does not depend on the gain
    assert riccati.witness["fixed_count"] == injection.witness["fixed_count"]
