"""The exact touch test at lambda0 = 0: a safe mode avoids the attack iff the attack's potentials agree across its links."""

from __future__ import annotations

from fractions import Fraction
from typing import Any

import networkx as nx
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from glocal_verify import System, spec_from_dict, spec_from_graph
from glocal_verify.analysis.switching import zero_touch as zt_module
from glocal_verify.analysis.stealthy.zda import ZdaZero
from glocal_verify.analysis.switching.zero_touch import touch_at_zero, zero_touch
from glocal_verify.design.audit import audit
from glocal_verify.numerics import exact as ex
from glocal_verify.results import Status
from strategies import graphs


def _definition(system: System, F: list[int], mode: str) -> bool:
    """Some (xi, u0) with alpha L_1 xi = S_F^T u0, dL_q xi = 0 and u0 != 0, over Q (the generic nullspace)."""
    N, m = system.n, len(F)
    L = system.laplacian_exact()
    dL = system.delta_laplacian_exact(mode)
    a = system.alpha_q
    rows = [[a * L[i][j] for j in range(N)] + [Fraction(-1 if F[k] == i else 0) for k in range(m)] for i in range(N)]
    rows += [list(dL[i]) + [Fraction(0)] * m for i in range(N) if any(x != 0 for x in dL[i])]
    K = ex.nullspace(rows, N + m)
    return any(any(x != 0 for x in v[N:]) for v in K)


@st.composite
def touch_cases(draw: st.DrawFn) -> tuple[System, list[int], str]:
    n, edges = draw(graphs(min_n=4, max_n=11, connected=True))
    labels = list(range(1, n + 1))
    present = {frozenset(e[:2]) for e in edges}
    pairs = [(u, v) for u in labels for v in labels if u < v]
    change = draw(st.lists(st.sampled_from(pairs), unique=True, min_size=1, max_size=2))
    add = [[u, v, draw(st.sampled_from([1, 2, "1/2"]))] for u, v in change if frozenset((u, v)) not in present]
    remove = [[u, v] for u, v in change if frozenset((u, v)) in present]
    mode: dict[str, Any] = {"name": "q"}
    if add:
        mode["add"] = add
    if remove:
        mode["remove"] = remove
    mv = draw(st.lists(st.sampled_from(labels), unique=True, min_size=1, max_size=3))
    data = {"format": 1, "name": "touch", "graph": {"nodes": n, "edges": edges}, "modes": [mode], "monitor": {"velocities": mv}}
    system = System(spec_from_dict(data))
    F = draw(st.lists(st.sampled_from(range(n)), unique=True, min_size=2, max_size=3))
    return system, F, "q"


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(touch_cases())
def test_the_touch_test_at_zero_agrees_with_the_exact_definition_on_random_networks(case: tuple[System, list[int], str]) -> None:
    system, F, mode = case
    if len(system.components("q")) != 1:
        return  # a safe mode that disconnects G_q fails privacy.connected anyway; the test is about L_1
    (t,) = zero_touch(system, F, [mode]) or [None]
    assert t is not None
    assert t.avoids == _definition(system, F, mode)
    L, dL, a = system.laplacian_exact(), system.delta_laplacian_exact(mode), system.alpha_q
    if t.avoids:  # the witness against the definition
        assert t.xi is not None and t.u0 is not None and any(x != 0 for x in t.u0)
        for i in range(system.n):
            lhs = sum((a * L[i][j] * t.xi[j] for j in range(system.n)), Fraction(0))
            rhs = sum((t.u0[k] for k in range(len(F)) if F[k] == i), Fraction(0))
            assert lhs == rhs
            assert sum((dL[i][j] * t.xi[j] for j in range(system.n)), Fraction(0)) == 0
    else:
        assert t.rank == t.inputs == len(F) - 1


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(touch_cases())
def test_the_modular_screen_and_the_exact_solve_give_the_same_answer(case: tuple[System, list[int], str]) -> None:
    system, F, mode = case
    if len(system.components("q")) != 1:
        return
    fast = zero_touch(system, F, [mode])
    slow_system = System(system.spec)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(zt_module, "_inverse_mod", lambda s: None)
        slow = zero_touch(slow_system, F, [mode])
    assert fast is not None and slow is not None
    assert [(t.avoids, t.rank, set(t.touched_agents)) for t in fast] == [(t.avoids, t.rank, set(t.touched_agents)) for t in slow]


def test_a_link_beyond_the_attacked_segment_of_a_path_is_exactly_untouched() -> None:
    # potentials of a current between 1 and 2 are constant on 2..8: adding 5-7 changes nothing
    spec = spec_from_graph(nx.path_graph(range(1, 9)), name="path8", modes={"q": {"add": [[5, 7]]}}, monitor_velocities=[8])
    system = System(spec)
    (t,) = zero_touch(system, system.idx((1, 2)), ["q"]) or [None]
    assert t is not None and t.avoids and t.touched_agents == ()
    (u,) = zero_touch(system, system.idx((1, 3)), ["q"]) or [None]
    assert u is not None and u.avoids


def test_the_test_does_not_apply_with_a_monitored_position_or_a_single_actuator() -> None:
    data = {"format": 1, "name": "p", "graph": {"nodes": 4, "edges": [[1, 2], [2, 3], [3, 4]]}, "modes": [{"name": "q", "add": [[1, 3]]}],
            "monitor": {"positions": [4]}}
    assert zero_touch(System(spec_from_dict(data)), [0, 1], ["q"]) is None
    data["monitor"] = {"velocities": [4]}
    assert zero_touch(System(spec_from_dict(data)), [0], ["q"]) is None


def test_an_undecided_numeric_touch_becomes_an_exact_verdict_with_its_margin() -> None:
    # two triangles joined by a bridge: the attack on 1-2 drives a current that crosses into the
    # far triangle only through the bridge, so a link there sees no potential difference
    data = {"format": 1, "name": "bridge", "graph": {"nodes": 6, "edges": [[1, 2], [2, 3], [1, 3], [3, 4], [4, 5], [5, 6], [4, 6]]},
            "modes": [{"name": "far", "add": [[5, 3]]}, {"name": "near", "remove": [[1, 3]]}], "monitor": {"velocities": [6]}}
    system = System(spec_from_dict(data))
    z = ZdaZero(0j, 0j, np.ones(6), np.array([1.0, -1.0]), 0.0, "persistent")
    far = touch_at_zero(system, "far", z, "test", system.idx((1, 2)))
    near = touch_at_zero(system, "near", z, "test", system.idx((1, 2)))
    assert far is not None and far.status is Status.HOLDS and far.direction is not None and far.exact_xi is not None
    assert near is not None and near.status is Status.FAILS and set(near.chosen_touched_agents) == {1, 3}
    assert near.margin > 1e-3 and far.margin < 1e-12  # the float potentials agree across 3-5 up to rounding


def test_an_exposure_by_a_tiny_signal_is_marked_fragile_but_stays_detected() -> None:
    from glocal_verify.answer.attack import AttackEvidence, LocalEvidence, ModeEvidence, answer_attack

    thm = {cid: Status.HOLDS for cid in ("switching.image-kernel", "switching.distinct-eigenvalues", "switching.eigenvector-differences")}

    def answer(*margins: float) -> Any:
        modes = tuple(ModeEvidence(f"m{i}", thm, Status.FAILS, m, "unbounded") for i, m in enumerate(margins))
        local = (LocalEvidence("P", 1, (1, 2), Status.HOLDS, Status.HOLDS),)
        return answer_attack(AttackEvidence("zda", (1, 2), (("P", (1, 2), (1,)),), Status.HOLDS, 0j, "spec", local, modes))

    tiny = answer(3e-13, 2e-11)
    assert tiny.verdict == "detected" and "2e-11" in tiny.fragile and all(m.fragile for m in tiny.modes)
    assert answer(1e-3).fragile == "" and answer(3e-13, 1e-3).fragile == ""  # one robust exposure suffices


@pytest.mark.slow
def test_audit_rows_report_the_touch_margin_of_every_evaluated_mode() -> None:
    from glocal_verify.spec import load_example

    result = audit(System(load_example("paper19")), 2)
    for r in result.rows:
        for d in r.witness["modes"].values():
            if d["switching.avoids-attack"] in ("holds", "fails"):
                assert "touch_margin" in d


def _ladder(rungs: int, lambda0: bool) -> System:
    """A ladder of ``rungs`` rungs; the attack drives a current across the first rung, the safe mode adds a diagonal at the last."""
    G = nx.relabel_nodes(nx.ladder_graph(rungs), lambda v: v + 1)
    far = [rungs - 1, 2 * rungs]  # a diagonal of the last square
    attack: dict[str, Any] = {"kind": "zda", "actuators": [1, rungs + 1]}
    if lambda0:
        attack["lambda0"] = 0
    return System(spec_from_graph(G, name="ladder", modes={"q": {"add": [far]}}, monitor_velocities=[rungs // 2], attack=attack))


def test_verify_decides_a_far_switch_over_q_when_the_numeric_touch_test_cannot() -> None:
    from glocal_verify import verify

    system = _ladder(24, lambda0=True)
    (t,) = zero_touch(system, system.idx((1, 25)), ["q"]) or [None]
    assert t is not None and not t.avoids and t.ratio < 1e-9  # touched, by a potential difference below the tolerance
    (r,) = verify(system, ["switching.avoids-attack"]).results("switching.avoids-attack")
    assert r.status is Status.FAILS
    assert "decided over Q" in r.witness["certificate"]["by"]
    assert r.margin is not None and r.margin < 1e-9



def test_a_system_holding_flint_results_pickles_without_them_and_keeps_its_arrays() -> None:
    import pickle

    import flint

    system = _ladder(6, lambda0=True)
    system.eigh()
    zero_touch(system, system.idx((1, 7)), ["q"])
    system.analysis[("test-flint",)] = {"poly": flint.fmpq_poly([1, 2])}
    copy = pickle.loads(pickle.dumps(system))
    assert ("test-flint",) not in copy.analysis
    assert any(k[0] == "attack-potentials-mod" for k in copy.analysis)  # the potentials modulo p: a plain int64 array
    (a,) = zero_touch(copy, copy.idx((1, 7)), ["q"]) or [None]
    (b,) = zero_touch(system, system.idx((1, 7)), ["q"]) or [None]
    assert a == b


@st.composite
def velocity_only(draw: st.DrawFn) -> tuple[System, list[int]]:
    n, edges = draw(graphs(min_n=3, max_n=10, connected=draw(st.booleans())))
    labels = list(range(1, n + 1))
    mv = draw(st.lists(st.sampled_from(labels), unique=True, min_size=1, max_size=3))
    system = System(spec_from_dict({"format": 1, "name": "v", "graph": {"nodes": n, "edges": edges}, "monitor": {"velocities": mv}}))
    return system, draw(st.lists(st.sampled_from(range(n)), unique=True, min_size=1, max_size=3))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(velocity_only())
def test_a_persistent_zda_without_position_monitors_exists_iff_two_attacked_agents_share_a_component(case: tuple[System, list[int]]) -> None:
    from glocal_verify.analysis.stealthy.zda_certificate import exact_q_rows, zda_certificate

    system, F = case
    N, m = system.n, len(F)
    rows0, _ = exact_q_rows(system, F, [], Fraction(0))
    exists_at0 = ex.rank(rows0, N + m) < ex.rank([r[:N] for r in rows0], N) + m  # the definition, over Q
    comp = {system.index[a]: ci for ci, c in enumerate(system.components()) for a in c}
    assert exists_at0 == (len({comp[f] for f in F}) < m)
    cert = zda_certificate(system, [system.labels[f] for f in F])
    if exists_at0:
        assert cert.status is Status.HOLDS
    elif cert.status is Status.HOLDS:  # then a ZDA away from lambda = 0, proved another way
        assert "lambda0 = 0" not in cert.by


def test_a_set_inherits_a_proven_zda_of_a_single_member_padded_with_zero_inputs() -> None:
    from glocal_verify.analysis.stealthy.zda_screens import global_tables
    from glocal_verify.analysis.stealthy.zda_verdict import ZdaOptions, decide_zda, inherited_zda
    from glocal_verify.spec import load_example

    system = System(load_example("paper19"))
    opt = ZdaOptions(lambda0=system.spec.attack.lambda0, growth="verdict", screen=True, minors=global_tables(system))
    memo: dict[Any, Any] = {}
    singles = [a for a in system.labels if (z := decide_zda(system, (a,), opt, memo)).stealthy and z.direction is not None]
    assert singles, "paper19 has single actuators with a stealthy ZDA"
    a = singles[0]
    b = next(x for x in system.labels if x != a)
    F = tuple(sorted((a, b), key=system.index.__getitem__))
    z = inherited_zda(system, F, opt, memo)
    assert z is not None and z.stealthy is True and not z.complete and z.direction is not None
    d = z.direction
    # the definition: (s I + alpha L) xi = S_F^T u0 and the monitored outputs vanish
    L = system.laplacian()
    s = d.value * d.value + system.gamma * d.value
    xi, u = np.asarray(d.xi, dtype=complex), np.asarray(d.u0, dtype=complex)
    rhs = np.zeros(system.n, dtype=complex)
    for k, f in enumerate(system.idx(F)):
        rhs[f] += u[k]
    assert u[F.index(b)] == 0 and abs(u[F.index(a)]) > 0
    assert np.linalg.norm(s * xi + system.alpha * (L @ xi) - rhs) <= 1e-8 * (1 + np.linalg.norm(xi))
    out = system.idx(system.monitored_positions) if d.value == 0 else system.idx(system.monitored)
    assert np.linalg.norm(xi[out]) <= 1e-8 * np.linalg.norm(xi)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(touch_cases())
def test_the_cut_vertex_and_rank_proofs_and_the_sparse_modular_solve_agree_with_the_exact_definition(case: tuple[System, list[int], str]) -> None:
    # the large-network path (no exact solve): a structural avoidance, a modular touch, or no verdict
    from glocal_verify import config

    system, F, mode = case
    if len(system.components("q")) != 1:
        return
    with config.override(zero_touch_exact_max_agents=0):
        (t,) = zero_touch(System(system.spec), F, [mode]) or [None]
    if t is None:
        return  # nothing proved: the caller stays undecided
    assert t.avoids == _definition(system, F, mode)
    if t.avoids:  # the float witness against the definition
        assert t.xi_float is not None and t.u0_float is not None
        xi, u0 = np.array(t.xi_float), np.array(t.u0_float)
        L, dL = system.laplacian(), system.delta_laplacian_sparse(mode)
        rhs = np.zeros(system.n)
        for k, f in enumerate(F):
            rhs[f] += u0[k]
        assert np.linalg.norm(system.alpha * (L @ xi) - rhs) <= 1e-8 * (1 + np.linalg.norm(u0))
        assert np.linalg.norm(dL @ xi) <= 1e-8 * np.linalg.norm(xi) and np.linalg.norm(u0) > 1e-8
    else:
        assert t.rank == t.inputs == len(F) - 1


def test_the_sparse_modular_potentials_solve_the_grounded_laplacian_exactly() -> None:
    system = _ladder(12, lambda0=True)
    F = system.idx((1, 13, 5))
    pot = zt_module._potentials_mod(system, F)
    assert pot is not None
    p, Y = pot
    n = system.n - 1
    L = system.laplacian_exact()
    for k in (1, 2):
        for i in range(n):  # L_g y = e_f1 - e_fk modulo p, row by row over the exact entries
            acc = sum((L[i][j].numerator * pow(L[i][j].denominator, -1, p) * int(Y[j, k - 1]) for j in range(n) if L[i][j]), 0) % p
            want = ((i == F[0]) - (i == F[k])) % p
            assert acc == want
