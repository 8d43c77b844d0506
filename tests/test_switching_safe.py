"""switching.avoids-attack (Remark III.3.1): touches are checked against dL_q xi computed here from
the ZDA direction, and both readings of eq. unsafe_set are reported. The attacker chooses the
stealthy direction at lambda0: the switch is avoidable (holds) as soon as one stealthy direction
with an input satisfies dL_q xi = 0, and such a direction is a zero direction of (A_q, B, C)."""

from __future__ import annotations

from fractions import Fraction
from typing import Any

import networkx as nx
import numpy as np
import pytest
from hypothesis import HealthCheck, event, example, given, settings
from strategies import systems

from glocal_verify import (
    System,
    load_example,
    loads_spec,
    spec_from_dict,
    spec_from_graph,
    verify,
)
from glocal_verify.analysis.switching.avoidance import avoidance, avoidance_exact
from glocal_verify.analysis.switching.touch import Avoidance
from glocal_verify.analysis.stealthy.zda_verdict import zda_direction
from glocal_verify.results import Status
from glocal_verify.simulation.attacks import zda_attack_from_direction
from glocal_verify.simulation.engine import simulate
from glocal_verify.simulation.observer_models import ObserverBank
from glocal_verify.simulation.schedule import Schedule


def _system(G: nx.Graph, **kw: Any) -> System:
    return System(spec_from_graph(G, **kw))


@pytest.fixture(scope="module")
def paper19() -> System:
    return System(load_example("paper19"))


@pytest.mark.parametrize("exact", [False, True])
def test_paper19_case_1_does_not_touch_the_zda_and_case_2_does(paper19: System, exact: bool) -> None:
    rep = verify(paper19, ["switching.avoids-attack"], exact=exact)
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
    rep = verify(s, ["switching.avoids-attack"])
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
    rs = {r.scope["mode"]: r for r in verify(s, ["switching.avoids-attack"], exact=exact).conditions}
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
    (r,) = verify(s, ["switching.avoids-attack"], exact=exact).conditions
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
    (r,) = verify(s, ["switching.avoids-attack"], exact=exact).conditions
    assert r.witness["growth"] == "decaying"
    assert r.witness["touches_attack"] is True and r.status is Status.FAILS
    assert r.witness["predicted_residual"] == "bounded-vanishing"


# ------------------------------------------------------------------------------------------
# the attacker chooses the direction: one touched direction is not enough

#: xi = [1, 0, -1, 0] (agents 1 and 3) is a zero direction at every lambda0 and dL xi = 0
SIGNED = """
format = 1
name = "signed"
[graph]
nodes = 4
edges = [[1, 3, "1/2"], [2, 4, 2], [3, 4, 1]]
[[modes]]
name = "signed"
add = [[1, 2], [2, 3]]
remove = [[1, 3]]
[monitor]
velocities = [2]
[attack]
kind = "zda"
actuators = [1, 3, 4]
lambda0 = 1.0
"""

#: lambda0 = 0: xi = [1/2, 0, 1/2, 0, 0], u0 = [1/2, -3/2, 1] survives the switch
ZERO = """
format = 1
name = "zero"
[graph]
nodes = 5
edges = [[1, 2, 1], [2, 3, 2], [2, 4, 1], [2, 5, 2]]
[[modes]]
name = "q"
add = [[1, 3], [4, 5]]
[monitor]
velocities = [1, 4]
[attack]
kind = "zda"
actuators = [1, 2, 3]
lambda0 = 0.0
"""


def _vector(values: dict[Any, Any], labels: Any) -> np.ndarray:
    return np.array([complex(values.get(lab, 0.0)) for lab in labels])


def _check_stealthy_and_avoiding(system: System, mode: str, lam: complex, xi: np.ndarray, u0: np.ndarray) -> None:
    """(s I + alpha L_1) xi = S_F^T u0, the output constraints, dL_q xi = 0, u0 != 0, and
    x0 = [xi; lambda0 xi] is a zero direction of (A_q, B, C) (dense 2N pencil)."""
    s = lam * lam + system.gamma * lam
    L1 = system.laplacian()
    F = system.idx(system.attacked)
    SFu = np.zeros(system.n, dtype=complex)
    SFu[F] = u0
    scale = (abs(s) + system.alpha * np.linalg.norm(L1, 2) + 1.0) * (np.linalg.norm(xi) + np.linalg.norm(u0))
    assert np.linalg.norm((s * np.eye(system.n) + system.alpha * L1) @ xi - SFu) <= 1e-9 * scale
    assert np.linalg.norm(xi[system.idx(system.monitored_positions)]) <= 1e-9 * np.linalg.norm(xi)
    if lam != 0:
        assert np.linalg.norm(xi[system.idx(system.monitored_velocities)]) <= 1e-9 * np.linalg.norm(xi)
    dL = system.delta_laplacian(mode)
    assert np.linalg.norm(dL @ xi) <= 1e-9 * np.linalg.norm(dL, 2) * np.linalg.norm(xi)
    assert np.linalg.norm(u0) > 1e-6 * np.linalg.norm(xi)
    A, B, C = system.A(mode), system.B(), system.C()
    x0 = np.concatenate([xi, lam * xi])
    n2 = A.shape[0]
    pscale = (np.linalg.norm(lam * np.eye(n2) - A, 2) + 1.0) * (np.linalg.norm(x0) + np.linalg.norm(u0))
    assert np.linalg.norm((lam * np.eye(n2) - A) @ x0 - B @ u0) <= 1e-9 * pscale
    assert np.linalg.norm(C @ x0) <= 1e-9 * pscale


def _check_witness(system: System, mode: str, w: dict[str, Any]) -> None:
    ad = w["avoiding_direction"]
    lam = complex(ad["lambda0"][0], ad["lambda0"][1])
    _check_stealthy_and_avoiding(system, mode, lam, _vector(ad["xi"], system.labels), _vector(ad["u0"], system.attacked))


@pytest.mark.parametrize("exact", [False, True])
@pytest.mark.parametrize("text, expected_xi", [(SIGNED, [1, 0, -1, 0]), (ZERO, [1, 0, 1, 0, 0])])
def test_a_switch_that_touches_the_chosen_direction_is_avoided_by_another_one(text: str, expected_xi: list[int], exact: bool) -> None:
    system = System(loads_spec(text))
    (mode,) = system.safe_modes
    (r,) = verify(system, ["switching.avoids-attack"], exact=exact).conditions
    w = r.witness
    assert r.status is Status.HOLDS, w
    assert w["touches_attack"] is False and w["avoidable"] is True and w["avoiding_dimension"] >= 1
    assert w["predicted_residual"] == "bounded-vanishing" and w["touched_agents"] == []
    assert w["reading_remark"]["condition_holds"] is True and w["reading_section_iv"]["condition_holds"] is False
    # the direction stealthy.zda reports is touched (the old one-direction test said "touches")
    chosen = w["chosen_direction"]
    assert chosen["touched"] is True and chosen["touched_agents"]
    xi_c = _vector(chosen["xi"], system.labels)
    assert np.linalg.norm(system.delta_laplacian(mode) @ xi_c) > 1e-3
    assert w["avoiding_direction"]["source"] == "kernel of the stacked system"
    _check_witness(system, mode, w)
    assert r.margin is not None and r.margin <= 1e-12
    if exact:
        xe = [Fraction(w["avoiding_direction"]["xi_exact"].get(lab, "0")) for lab in system.labels]
        assert xe == [Fraction(v) for v in expected_xi]
        ue = [Fraction(w["avoiding_direction"]["u0_exact"][lab]) for lab in system.attacked]
        # exact check of the definition over Q
        lam = Fraction(w["lambda0_exact"])
        sq = lam * lam + system.gamma_q * lam
        L1, dL = system.laplacian_exact(), system.delta_laplacian_exact(mode)
        F = system.idx(system.attacked)
        for i in range(system.n):
            lhs = sq * xe[i] + system.alpha_q * sum((L1[i][j] * xe[j] for j in range(system.n)), Fraction(0))
            assert lhs == (ue[F.index(i)] if i in F else 0)
            assert sum((dL[i][j] * xe[j] for j in range(system.n)), Fraction(0)) == 0
        assert all(xe[i] == 0 for i in system.idx(system.monitored_velocities)) or lam == 0
        assert any(u != 0 for u in ue)


@pytest.mark.parametrize("exact", [False, True])
def test_a_complex_lambda0_is_decided_over_the_number_field(exact: bool) -> None:
    # SIGNED at lambda0 = 1/2 + i: the exact path works in Q[x]/((x - 1/2)^2 + 1)
    system = System(loads_spec(SIGNED.replace("lambda0 = 1.0", "lambda0 = [0.5, 1.0]")))
    (r,) = verify(system, ["switching.avoids-attack"], exact=exact).conditions
    assert r.status is Status.HOLDS, r.witness
    assert r.witness["chosen_direction"]["touched"] is True
    if exact:
        assert r.witness["lambda0_exact"] == "x^2 + (-1)*x + 5/4"
    _check_witness(system, "signed", r.witness)


#: left-invertible, but the (complex, irrational) zero of lambda^2 + lambda + 3 has two
#: directions: stealthy.zda's is touched by the new link 2-4, x~ = e_5 is not
TWIN_ZERO = {
    "format": 1,
    "name": "twin-zero",
    "graph": {"nodes": 5, "edges": [[1, 2, 3], [2, 3, 2], [3, 4, 3], [3, 5, 3]]},
    "monitor": {"velocities": [3, 1]},
    "modes": [{"name": "q", "add": [[2, 4, 1]], "remove": []}],
    "attack": {"kind": "zda", "actuators": [3]},
}


@pytest.mark.parametrize("exact", [False, True])
def test_an_irrational_zero_with_two_directions_is_decided_over_its_field(exact: bool) -> None:
    system = System(spec_from_dict(TWIN_ZERO))
    (r,) = verify(system, ["switching.avoids-attack"], exact=exact).conditions
    assert r.status is Status.HOLDS, r.witness
    assert r.witness["chosen_direction"]["touched"] is True
    assert r.witness["avoiding_direction"]["moved"] == [5]
    if exact:
        assert r.witness["lambda0_exact"] == "x^2 + x + 3"
    _check_witness(system, "q", r.witness)


@pytest.mark.parametrize("exact", [False, True])
def test_paper19_witness_on_fails_and_holds(paper19: System, exact: bool) -> None:
    rs = {r.scope["mode"]: r for r in verify(paper19, ["switching.avoids-attack"], exact=exact).conditions}
    d = zda_direction(paper19)
    assert d is not None
    f = rs["case-2"]
    assert f.status is Status.FAILS
    assert f.witness["avoiding_dimension"] == 0 and f.witness["avoidable"] is False
    assert f.witness["chosen_direction"]["touched"] is True and f.witness["chosen_direction"]["touched_agents"] == [4, 7]
    assert "avoiding_direction" not in f.witness
    # a simple zero (one stealthy direction at lambda0): the margin is that direction's ||dL xi|| / (||dL|| ||xi||)
    dL = paper19.delta_laplacian("case-2")
    assert f.margin == pytest.approx(np.linalg.norm(dL @ d.xi) / (np.linalg.norm(dL, 2) * np.linalg.norm(d.xi)), rel=1e-9)
    for mode in ("case-1", "case-3"):
        h = rs[mode]
        assert h.status is Status.HOLDS and h.witness["avoiding_dimension"] == 1
        assert h.witness["avoiding_direction"]["source"] == "stealthy.zda"
        _check_witness(paper19, mode, h.witness)


def test_the_avoiding_direction_stays_hidden_after_the_switch_in_simulation() -> None:
    data = loads_spec(SIGNED)
    system = System(data)
    av = avoidance(system, "signed")
    assert av is not None and av.status is Status.HOLDS and av.direction is not None
    sim_spec = spec_from_dict(
        {
            "format": 1,
            "name": "signed-sim",
            "graph": {"nodes": 4, "edges": [[1, 3, "1/2"], [2, 4, 2], [3, 4, 1]]},
            "modes": [{"name": "signed", "add": [[1, 2], [2, 3]], "remove": [[1, 3]]}],
            "monitor": {"velocities": [2]},
            "attack": {"kind": "zda", "actuators": [1, 3, 4], "lambda0": 1.0},
            "switching": {"mode": "signed", "time": 2.0},
            "simulation": {"horizon": 6.0, "step": 0.05},
        }
    )
    sim_sys = System(sim_spec)
    bank = ObserverBank.for_system(sim_sys, local=False)
    sched = Schedule.from_spec(sim_sys)
    d = av.direction
    run = simulate(sim_sys, schedule=sched, attack=zda_attack_from_direction(sim_sys, d.lambda0, d.xi, d.u0), observers=bank, x0=np.zeros(8), record_states=False)
    rel = np.max(np.abs(run.residuals["central"]), axis=1) / np.maximum(1.0, run.state_scale)
    assert np.max(rel) <= 1e-9  # hidden before and after the switch, while x~ grows like e^t
    chosen = av.chosen
    run2 = simulate(sim_sys, schedule=sched, attack=zda_attack_from_direction(sim_sys, chosen.lambda0, chosen.xi, chosen.u0), observers=bank, x0=np.zeros(8), record_states=False)
    rel2 = np.max(np.abs(run2.residuals["central"]), axis=1) / np.maximum(1.0, run2.state_scale)
    assert np.max(rel2[run2.t > 2.5]) > 1e-6  # the touched direction shows after the switch


def _same_lambda(a: Avoidance, b: Avoidance) -> bool:
    return min(abs(a.lambda0 - b.lambda0), abs(a.lambda0 - b.lambda0.conjugate())) <= 1e-8 * (1.0 + abs(b.lambda0))


@example(system=System(spec_from_dict(TWIN_ZERO)))
@example(system=System(loads_spec(ZERO)))
@given(systems(max_n=8, max_modes=2).filter(lambda s: bool(s.attacked and s.safe_modes)))
@settings(suppress_health_check=[HealthCheck.filter_too_much, HealthCheck.too_slow])
def test_numeric_and_exact_switching_safe_agree_and_the_avoiding_direction_survives(system: System) -> None:
    for mode in system.safe_modes:
        num = avoidance(system, mode)
        exa = avoidance_exact(system, mode)
        if exa is None:
            continue
        assert exa.status is not Status.UNDECIDED
        for av in (num, exa):
            if av is None:
                continue
            assert 0.0 <= av.margin <= 1.0 + 1e-9
            if av.status is Status.HOLDS:
                assert av.direction is not None and av.dimension is not None and av.dimension >= 1
                d = av.direction
                _check_stealthy_and_avoiding(system, mode, d.lambda0, d.xi, d.u0)
            elif av.status is Status.FAILS:
                assert av.dimension == 0 and av.chosen_touched is True and av.direction is None
        event(f"exact {exa.status.value}" + (" through another direction" if exa.status is Status.HOLDS and exa.chosen_touched else ""))
        if num is None or num.status is Status.UNDECIDED or not _same_lambda(num, exa):
            event("numeric undecided or another lambda0")
            continue
        assert num.status is exa.status, (mode, num, exa)
        assert num.dimension == exa.dimension or num.status is Status.HOLDS  # numeric: a lower bound on holds
