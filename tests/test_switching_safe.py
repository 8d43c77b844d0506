"""switching.safe (Remark III.3.1): touches are checked against dL_q xi computed here from
the ZDA direction, and both readings of eq. unsafe_set are reported."""

from __future__ import annotations

from typing import Any

import networkx as nx
import numpy as np
import pytest

from glocal_verify import System, load_example, spec_from_graph, verify
from glocal_verify.results import Status
from glocal_verify.stealthy import zda_direction


def _system(G: nx.Graph, **kw: Any) -> System:
    return System(spec_from_graph(G, **kw))


@pytest.fixture(scope="module")
def paper19() -> System:
    return System(load_example("paper19"))


@pytest.mark.parametrize("exact", [False, True])
def test_paper19_case_1_does_not_touch_the_zda_and_case_2_does(paper19: System, exact: bool) -> None:
    rep = verify(paper19, ["switching.safe"], exact=exact)
    rs = {r.scope["mode"]: r for r in rep.conditions}
    d = zda_direction(paper19)
    assert d is not None
    for mode, r in rs.items():
        dLxi = paper19.delta_laplacian(mode) @ d.xi
        touches = bool(np.linalg.norm(dLxi) > 1e-9 * np.linalg.norm(d.xi))
        assert r.witness["touches_attack"] is touches
        assert r.status is (Status.FAILS if touches else Status.HOLDS)
        assert r.witness["touched_agents"] == [lab for lab, v in zip(paper19.labels, dLxi) if abs(v) > 1e-9]
        assert r.witness["reading_remark"]["condition_holds"] is (not touches)
        assert r.witness["reading_section_iv"]["condition_holds"] is touches
    assert rs["case-1"].witness["predicted_residual"] == "bounded-vanishing"
    assert rs["case-2"].witness["predicted_residual"] == "unbounded"
    assert rs["case-2"].witness["touched_agents"] == [4, 7]
    (f,) = [f for f in rep.findings if f.id == "remark-iii31.unsafe-set"]
    assert f.data["modes"]["case-2"]["touches_attack"] is True


def test_the_finding_needs_an_attack_and_safe_modes() -> None:
    s = _system(nx.path_graph(range(1, 6)), monitor_velocities=[5], modes={"q": {"add": [(1, 3)]}})
    rep = verify(s, ["switching.safe"])
    assert rep.conditions == () and not [f for f in rep.findings if f.id == "remark-iii31.unsafe-set"]


@pytest.mark.parametrize("exact", [False, True])
def test_a_covert_attack_is_touched_only_by_links_in_its_component(exact: bool) -> None:
    G = nx.path_graph(range(1, 5))
    G.add_edges_from([(5, 6), (6, 7)])
    s = _system(
        G,
        monitor_velocities=[4, 7],
        attack={"kind": "covert", "actuators": [1], "sensors": [4]},
        modes={"near": {"add": [(2, 4)]}, "far": {"add": [(5, 7)]}},
    )
    rs = {r.scope["mode"]: r for r in verify(s, ["switching.safe"], exact=exact).conditions}
    assert rs["near"].status is Status.FAILS and rs["near"].witness["links_touching"] == [[2, 4, 1.0]]
    assert rs["far"].status is Status.HOLDS and rs["far"].witness["predicted_residual"] == "bounded-vanishing"
    # the coordinate subspace of the reachable agents: dL_far vanishes on it
    R = [s.index[a] for a in rs["near"].witness["reachable_agents"]]
    assert np.allclose(s.delta_laplacian("far")[:, R], 0.0)
    assert not np.allclose(s.delta_laplacian("near")[:, R], 0.0)


@pytest.mark.parametrize("exact", [False, True])
def test_without_a_stealthy_zda_the_switch_holds_vacuously(exact: bool) -> None:
    s = _system(
        nx.path_graph(range(1, 3)),
        monitor_velocities=[1, 2],
        monitor_positions=[1],
        attack={"kind": "zda", "actuators": [2]},
        modes={"q": {"remove": [(1, 2)]}},
    )
    (r,) = verify(s, ["switching.safe"], exact=exact).conditions
    assert r.status is Status.HOLDS and r.witness["touches_attack"] is False and "no stealthy ZDA" in r.witness["note"]


@pytest.mark.parametrize("exact", [False, True])
def test_a_decaying_zda_touched_by_the_switch_predicts_a_vanishing_residual(exact: bool) -> None:
    # path 1-2-3 with the attack at 2 and the velocity of 1 monitored: the only stealthy ZDA
    # decays (lambda^2 + lambda + 1 = 0) and moves agents 2 and 3
    s = _system(
        nx.path_graph(range(1, 4)),
        monitor_velocities=[1],
        attack={"kind": "zda", "actuators": [2]},
        modes={"q": {"add": [(1, 3)]}},
    )
    (r,) = verify(s, ["switching.safe"], exact=exact).conditions
    assert r.witness["growth"] == "decaying"
    assert r.witness["touches_attack"] is True and r.status is Status.FAILS
    assert r.witness["predicted_residual"] == "bounded-vanishing"
