"""Foundation checkers on known cases, with witnesses checked against their definitions."""

from __future__ import annotations

from fractions import Fraction

import networkx as nx
import numpy as np
import pytest

from glocal_verify import System, spec_from_graph, verify
from glocal_verify.results import ConditionResult, Status


def _one(system: System, cid: str, exact: bool = False, mode: str | None = None) -> ConditionResult:
    rs = [r for r in verify(system, [cid], exact=exact).conditions if mode is None or r.scope.get("mode") == mode]
    assert len(rs) == 1
    return rs[0]


def _system(G: nx.Graph, **kw: object) -> System:
    return System(spec_from_graph(G, **kw))  # type: ignore[arg-type]


@pytest.mark.parametrize("exact", [False, True])
def test_a_cycle_fails_distinct_eigenvalues(exact: bool) -> None:
    # closing a path into a cycle: the safe mode is the 6-cycle, whose eigenvalues repeat
    s = _system(nx.path_graph(range(1, 7)), monitor_velocities=[1], modes={"cycle": {"add": [(1, 6)]}})
    r = _one(s, "switching.distinct-eigenvalues", exact)
    assert r.status is Status.FAILS
    L = s.laplacian("cycle")
    if exact:
        assert "repeated_factor" in r.witness
    else:
        mu = r.witness["eigenvalue"]
        u1, u2 = (np.array([v[lab] for lab in s.labels]) for v in r.witness["eigenvectors"])
        for u in (u1, u2):
            assert np.allclose(L @ u, mu * u, atol=1e-9)
        assert abs(u1 @ u2) < 1e-9


@pytest.mark.parametrize("exact", [False, True])
def test_a_path_graph_has_distinct_eigenvalues(exact: bool) -> None:
    s2 = _system(nx.path_graph(range(1, 9)), monitor_velocities=[8], modes={"longer": {"remove": [(7, 8)], "add": [(1, 8)]}})
    r = _one(s2, "switching.distinct-eigenvalues", exact)
    assert r.status is Status.HOLDS  # the new graph is again a path: 8-1-2-...-7
    w = np.linalg.eigvalsh(s2.laplacian("longer"))
    assert r.margin == pytest.approx(np.min(np.diff(w)))


@pytest.mark.parametrize("exact", [False, True])
def test_an_unmonitored_switching_link_fails_image_kernel_with_a_vector_in_the_intersection(exact: bool) -> None:
    s = _system(nx.path_graph(range(1, 7)), monitor_velocities=[6], modes={"q": {"add": [(1, 3)]}})
    r = _one(s, "switching.image-kernel", exact)
    assert r.status is Status.FAILS
    y = np.array([float(Fraction(r.witness["vector"].get(lab, 0))) for lab in s.labels])
    dL = s.delta_laplacian("q")
    # y in Im(dL): the least-squares residual vanishes
    z, *_ = np.linalg.lstsq(dL, y, rcond=None)
    assert np.allclose(dL @ z, y, atol=1e-9) and np.linalg.norm(y) > 0
    # y in ker S_M
    assert all(abs(y[s.index[m]]) < 1e-12 for m in s.monitored)
    cov = _one(s, "switching.coverage", exact)
    assert cov.status is Status.FAILS and cov.witness["uncovered"] == [[1, 3]]


@pytest.mark.parametrize("exact", [False, True])
def test_a_monitored_switching_link_meets_image_kernel(exact: bool) -> None:
    s = _system(nx.path_graph(range(1, 7)), monitor_velocities=[3], modes={"q": {"add": [(1, 3)]}})
    r = _one(s, "switching.image-kernel", exact)
    assert r.status is Status.HOLDS
    assert r.margin == pytest.approx(np.sqrt(0.5))
    assert _one(s, "switching.coverage", exact).status is Status.HOLDS


def test_a_component_of_rank_two_needs_two_monitors() -> None:
    # a triangle of new links: dL block is a Laplacian of rank 2
    base = nx.path_graph(range(1, 8))
    s = _system(base, monitor_velocities=[5], modes={"q": {"add": [(1, 5), (5, 7), (1, 7)]}})
    r = _one(s, "switching.image-kernel")
    assert r.status is Status.FAILS and r.witness["monitors_needed"] == 2
    s2 = _system(base, monitor_velocities=[5, 7], modes={"q": {"add": [(1, 5), (5, 7), (1, 7)]}})
    assert _one(s2, "switching.image-kernel").status is Status.HOLDS


@pytest.mark.parametrize("exact", [False, True])
def test_a_disconnected_mode_fails_connected_and_names_the_components(exact: bool) -> None:
    s = _system(nx.path_graph(range(1, 5)), monitor_velocities=[4], modes={"cut": {"remove": [(2, 3)]}})
    rs = {r.scope["mode"]: r for r in verify(s, ["privacy.connected"], exact=exact).conditions}
    assert rs["normal"].status is Status.HOLDS and rs["normal"].margin > 0
    assert rs["cut"].status is Status.FAILS and rs["cut"].witness["components"] == [[1, 2], [3, 4]]


def test_velocity_only_monitors_keep_the_consensus_direction_in_ker_c() -> None:
    s = _system(nx.path_graph(range(1, 5)), monitor_velocities=[1, 4])
    assert _one(s, "privacy.kernel").status is Status.HOLDS
    s2 = _system(nx.path_graph(range(1, 5)), monitor_velocities=[1], monitor_positions=[2])
    r = _one(s2, "privacy.kernel")
    assert r.status is Status.FAILS and r.witness["position_monitors"] == [2]
    one = np.concatenate([np.ones(4), np.zeros(4)])
    assert np.linalg.norm(s2.C() @ one) > 0


def test_string_labels_are_kept_in_witnesses() -> None:
    G = nx.Graph()
    G.add_weighted_edges_from([("a", "b", 1), ("b", "c", 2), ("c", "d", 1)])
    s = _system(G, monitor_velocities=["d"], modes={"q": {"add": [("a", "c")]}})
    r = _one(s, "switching.image-kernel")
    assert r.status is Status.FAILS and set(r.witness["vector"]) == {"a", "c"}
