"""Stealthy attacks (Proposition II.4): ZDA witnesses checked against the full 2N pencil,
covert-attack channels checked against the Markov parameters C A^k B."""

from __future__ import annotations

from typing import Any

import networkx as nx
import numpy as np
import pytest
from hypothesis import given, settings
from strategies import systems

from glocal_verify import System, load_example, spec_from_graph, verify
from glocal_verify.analysis.stealthy.covert import covert_required_channels
from glocal_verify.analysis.stealthy.zda import zda_analysis
from glocal_verify.analysis.stealthy.zda_verdict import zda_direction
from glocal_verify.analysis.stealthy.zda_exact import zda_analysis_exact
from glocal_verify.errors import ModelError, NotApplicableError
from glocal_verify.results import ConditionResult, Status


def _system(G: nx.Graph, **kw: Any) -> System:
    return System(spec_from_graph(G, **kw))


def _one(system: System, cid: str, exact: bool = False, **options: Any) -> ConditionResult:
    rs = verify(system, [cid], exact=exact, options=options).conditions
    assert len(rs) == 1
    return rs[0]


def _pencil_residuals(system: System, lam: complex, x0: np.ndarray, u0: np.ndarray) -> tuple[float, float]:
    """Relative residuals of the two block rows of eq. zda_cond on the dense 2N matrices."""
    A, B, C = system.A(), system.B(), system.C()
    n = A.shape[0]
    dyn = (lam * np.eye(n) - A) @ x0 - B @ u0
    out = C @ x0
    scale = (np.linalg.norm(lam * np.eye(n) - A, 2) + 1.0) * np.linalg.norm(np.concatenate([x0, u0]))
    return float(np.linalg.norm(dyn) / scale), float(np.linalg.norm(out) / scale)


def _twins(ratio: int = 2) -> System:
    # agents 3 and 4 see the neighbours 2 and 5 with weights in the ratio `ratio`:1
    G = nx.Graph()
    G.add_weighted_edges_from(
        [(1, 2, 1), (2, 3, ratio), (2, 4, 1), (3, 5, ratio), (4, 5, 1), (5, 6, 1), (6, 7, 1), (1, 7, 2)]
    )
    return _system(G, monitor_velocities=[1, 6], attack={"kind": "zda", "actuators": [3, 4]})


@pytest.fixture(scope="module")
def paper19() -> System:
    return System(load_example("paper19"))


def test_the_zda_direction_zeroes_the_output_and_satisfies_the_full_pencil(paper19: System) -> None:
    d = zda_direction(paper19)
    assert d is not None and d.lambda0 == pytest.approx(0.5)
    dyn, out = _pencil_residuals(paper19, d.lambda0, d.x0, d.u0)
    assert dyn < 1e-12 and out < 1e-12
    assert np.linalg.norm(d.u0) > 0.1
    assert np.allclose(d.x0, np.concatenate([d.xi, d.lambda0 * d.xi]))


def test_paper19_is_not_left_invertible_and_its_zda_moves_exactly_agents_3_and_4(paper19: System) -> None:
    za = zda_analysis(paper19)
    assert not za.left_invertible and za.decided
    assert za.normal_rank == 2 * 19 + 2 - 1 and za.normal_kernel_dim == 1
    r = _one(paper19, "stealthy.zda")
    assert r.status is Status.HOLDS and r.margin == float("inf")
    w = r.witness
    assert w["left_invertible"] is False
    assert w["direction"]["moved"] == [3, 4]
    assert w["direction"]["lambda0"] == [0.5, 0.0] and w["direction"]["growth"] == "unbounded"
    xi = np.array([w["direction"]["xi"].get(lab, 0.0) for lab in paper19.labels], dtype=complex)
    u0 = np.array([w["direction"]["u0"][lab] for lab in paper19.attacked], dtype=complex)
    dyn, out = _pencil_residuals(paper19, 0.5, np.concatenate([xi, 0.5 * xi]), u0)
    assert dyn < 1e-12 and out < 1e-12


def test_paper19_numeric_and_exact_zda_verdicts_agree(paper19: System) -> None:
    rn = _one(paper19, "stealthy.zda")
    re_ = _one(paper19, "stealthy.zda", exact=True)
    assert rn.status is re_.status is Status.HOLDS
    for key in ("left_invertible", "normal_rank", "normal_kernel_dim", "zeros_total"):
        assert rn.witness[key] == re_.witness[key], key
    assert re_.witness["direction"]["moved"] == [3, 4] and re_.witness["direction"]["lambda_exact"] == "1/2"
    assert re_.witness["direction"]["xi"] == {3: -0.5, 4: 1.0}
    num = sorted((round(z["lambda"][0], 7), round(z["lambda"][1], 7)) for z in rn.witness["zeros"])
    exa = sorted((round(z["lambda"][0], 7), round(z["lambda"][1], 7)) for z in re_.witness["zeros"])
    assert num == exa


@pytest.mark.parametrize("exact", [False, True])
def test_twins_with_proportional_neighbourhoods_lose_rank_at_every_lambda(exact: bool) -> None:
    s = _twins()
    r = _one(s, "stealthy.zda", exact)
    assert r.status is Status.HOLDS and r.witness["left_invertible"] is False
    d = r.witness["direction"]
    assert d["lambda0"] == [1.0, 0.0] and d["growth"] == "unbounded" and d["moved"] == [3, 4]
    xi = np.array([complex(*v) if isinstance(v, list) else v for v in (d["xi"].get(lab, 0.0) for lab in s.labels)])
    assert xi[2] == pytest.approx(-0.5 * xi[3])  # e3 - 2 e4 up to scale: the weights are 2:1
    # the same holds for the spec's own exponent
    s2 = _system(nx.Graph(s.graph()), monitor_velocities=[1, 6], attack={"kind": "zda", "actuators": [3, 4], "lambda0": 2})
    d2 = _one(s2, "stealthy.zda", exact).witness["direction"]
    assert d2["lambda0"] == [2.0, 0.0] and d2["source"] == "requested lambda0"


@pytest.mark.parametrize("exact", [False, True])
def test_three_attacked_agents_watched_by_two_sensors_are_not_left_invertible(exact: bool) -> None:
    s = _system(nx.cycle_graph(range(1, 9)), monitor_velocities=[1, 5], attack={"kind": "zda", "actuators": [2, 3, 7]})
    r = _one(s, "stealthy.zda", exact)
    assert r.status is Status.HOLDS and r.witness["left_invertible"] is False
    assert r.witness["normal_kernel_dim"] >= 1
    d = zda_direction(s) if not exact else zda_analysis_exact(s).direction.direction()  # type: ignore[union-attr]
    assert d is not None and d.lambda0 == 1.0
    dyn, out = _pencil_residuals(s, d.lambda0, d.x0, d.u0)
    assert dyn < 1e-12 and out < 1e-12 and np.linalg.norm(d.u0) > 0.1


@pytest.mark.parametrize("exact", [False, True])
def test_a_single_monitored_attacker_has_no_stealthy_zda(exact: bool) -> None:
    # the attacked agent's own velocity is monitored: C B != 0 square, zeros are those of
    # the remaining path; a path 1-2-3 with actuator = monitor = 1 has decaying zeros only
    s = _system(nx.path_graph(range(1, 4)), monitor_velocities=[1], attack={"kind": "zda", "actuators": [1]})
    r = _one(s, "stealthy.zda", exact)
    assert r.witness["left_invertible"] is True
    for z in r.witness["zeros"]:
        assert z["growth"] in ("decaying", "persistent")
    if r.status is Status.HOLDS:
        assert r.margin is not None and r.margin <= 0.0


@pytest.mark.parametrize("exact", [False, True])
def test_a_left_invertible_system_without_zeros_fails(exact: bool) -> None:
    # 1 attacker, its velocity and its neighbour's position monitored on an edge graph
    s = _system(nx.path_graph(range(1, 3)), monitor_velocities=[1, 2], monitor_positions=[1], attack={"kind": "zda", "actuators": [2]})
    r = _one(s, "stealthy.zda", exact)
    assert r.status is Status.FAILS and r.witness["zeros"] == [] and r.margin == float("-inf")


def test_the_spec_lambda0_that_is_no_zero_falls_back_to_the_fastest_zero() -> None:
    # path 1-2-3, attack at 2, velocity of 1 monitored: agent 3 hanging on 2 gives the zeros
    # s = -alpha (lambda^2 + lambda + 1 = 0), decaying; 0.5 is no zero
    s = _system(nx.path_graph(range(1, 4)), monitor_velocities=[1], attack={"kind": "zda", "actuators": [2], "lambda0": 0.5})
    za = zda_analysis(s)
    assert za.left_invertible
    assert za.direction is not None and za.direction_source == "fastest-growing zero"
    assert za.direction.value.real == pytest.approx(-0.5) and abs(za.direction.value.imag) == pytest.approx(np.sqrt(3) / 2)
    assert za.direction.growth == "decaying"
    assert any("requested lambda0" in n for n in za.notes)
    assert zda_direction(s, lambda0=0.5) is None
    d = za.direction.direction()
    dyn, out = _pencil_residuals(s, d.lambda0, d.x0, d.u0)
    assert dyn < 1e-12 and out < 1e-12
    # the consensus mode (lambda = 0, u = 0) is reported as unobservable, not as an attack
    assert [z.value for z in za.unobservable] == [0j]


def test_no_attack_in_the_spec_gives_no_stealthy_results() -> None:
    s = _system(nx.path_graph(range(1, 5)), monitor_velocities=[4])
    assert verify(s, ["stealthy.zda", "stealthy.covert"]).conditions == ()
    with pytest.raises(NotApplicableError):
        zda_analysis(s)
    with pytest.raises(ModelError):
        zda_analysis(s, actuators=[99])


def test_structured_and_dense_paths_give_the_same_zeros_on_paper19(paper19: System) -> None:
    st = zda_analysis(paper19)
    de = zda_analysis(paper19, method="dense")
    assert st.normal_rank == de.normal_rank and st.left_invertible == de.left_invertible
    assert len(st.zeros) == len(de.zeros)
    for z in st.zeros:
        assert min(abs(z.value - w.value) for w in de.zeros) < 1e-8


def test_the_modal_s_pencil_is_decided_against_the_norm_of_its_own_data_on_weakly_coupled_clusters() -> None:
    """Rank decisions of the N-sized s-pencil are relative to its scale: a balancing that
    magnifies the rounding noise of localised eigenvectors inflates it (to ~1e8 here) and,
    at larger N, discarded whole output blocks (normal rank below N + m)."""
    from glocal_verify.analysis.stealthy.zda import ModalPencil
    from glocal_verify.design.generators import random_clustered_spec
    from glocal_verify.numerics.tolerance import DEFAULT_TOLERANCE

    system = System(random_clustered_spec(1000, 3, seed=7))
    md = ModalPencil(system, tuple(system.attacked), DEFAULT_TOLERANCE)
    pa = md.s_pencil()
    # ||[diag(a) B; C 0]||_2 <= max |a| + ||U_F|| + ||U_M|| <= max |a| + 2 (rows of an orthogonal U)
    assert pa.scale <= md.alpha * float(np.max(np.abs(md.mu))) + 2.0
    assert pa.normal_rank == system.n + len(system.attacked) and pa.full_normal_column_rank


def _markov_channels(system: System) -> list[str]:
    """Rows of C with C A^k B != 0 for some k < 2N (test-side reference, dense powers)."""
    A, B, C = system.A(), system.B(), system.C()
    reached = np.zeros(C.shape[0], dtype=bool)
    M = B.copy()
    for _ in range(A.shape[0]):
        reached |= np.abs(C @ M).max(axis=1, initial=0.0) > 1e-9 * max(1.0, np.abs(C @ M).max(initial=0.0))
        M = A @ M
        M /= max(1.0, float(np.abs(M).max()))
    return [ch for ch, r in zip(system.output_channels(), reached) if r]


@settings(max_examples=30)
@given(systems(max_n=8))
def test_covert_channels_match_the_markov_parameter_reachability(system: System) -> None:
    if not system.attacked:
        return
    assert covert_required_channels(system) == _markov_channels(system)


@pytest.mark.parametrize("exact", [False, True])
def test_a_covert_attack_is_feasible_exactly_when_the_reached_channels_are_owned(exact: bool) -> None:
    G = nx.path_graph(range(1, 6))
    G.add_edge(7, 8)
    G.add_node(6)
    base: dict[str, Any] = {"monitor_velocities": [2, 5, 8], "monitor_positions": [4]}
    s = _system(G, attack={"kind": "covert", "actuators": [1], "sensors": [2, 4, 5]}, **base)
    r = _one(s, "stealthy.covert", exact)
    assert r.status is Status.HOLDS and r.margin == 0
    assert r.witness["required"] == ["x:4", "v:2", "v:5"]  # agent 8 is in another component
    s2 = _system(G, attack={"kind": "covert", "actuators": [1], "sensors": [2]}, **base)
    r2 = _one(s2, "stealthy.covert", exact)
    assert r2.status is Status.FAILS and r2.witness["missing"] == ["x:4", "v:5"] and r2.margin == 2


def test_findings_name_the_unobservable_zeros_and_the_missing_covert_sensors() -> None:
    s = _system(nx.path_graph(range(1, 4)), monitor_velocities=[1], attack={"kind": "covert", "actuators": [2]})
    rep = verify(s, ["stealthy.zda", "stealthy.covert"])
    f = {x.id: x for x in rep.findings}
    assert f["definition-ii2.unobservable-zeros"].data["unobservable_modes"] == [[0.0, 0.0]]
    assert f["proposition-ii4.covert-needs-sensors"].data["missing"] == ["v:1"]
    # owning the channel removes the covert finding
    s2 = _system(nx.path_graph(range(1, 4)), monitor_velocities=[1], attack={"kind": "covert", "actuators": [2], "sensors": [1]})
    assert "proposition-ii4.covert-needs-sensors" not in {x.id for x in verify(s2, ["stealthy.covert"]).findings}
