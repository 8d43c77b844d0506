"""Unobservable subspaces and the observability/privacy checkers on known cases.

Ground truth in this file: exact ranks of small observability matrices over Q (built here, in
tests only), dense reference computations with ``scipy.linalg.expm``, and the defining
property of an unobservable state (its output vanishes).
"""

from __future__ import annotations

import json
from fractions import Fraction
from typing import Any

import flint
import networkx as nx
import numpy as np
import pytest
import scipy.linalg

from glocal_verify import System, load_example, spec_from_dict, spec_from_graph, verify
from glocal_verify.analysis.unobservable.modal import block_exponentials, modal_exponential
from glocal_verify.analysis.unobservable.switched import (
    mode_sequence,
    switched_unobservable_bounds_exact,
    switched_unobservable_subspace,
)
from glocal_verify.analysis.unobservable.subspace import (
    unobservable_subspace,
    unobservable_subspace_exact,
)
from glocal_verify.cli import main
from glocal_verify.numerics.staircase import unobservable_subspace_dense
from glocal_verify.numerics.tolerance import principal_sines
from glocal_verify.results import ConditionResult, Method, Status

NEW_IDS = [
    "switched-observability",
    "privacy.unobservable",
    "privacy.initial-state",
    "privacy.consensus-value",
    "switching.eigenvector-differences",
    "central.observer",
]


def _system(G: nx.Graph, **kw: Any) -> System:
    return System(spec_from_graph(nx.relabel_nodes(G, {v: v + 1 for v in G}) if 0 in G else G, **kw))


def exact_observability_rank(system: System, mode: str = "normal") -> int:
    """Rank over Q of (C, C A, ..., C A^{2N-1}) -- ground truth for small systems, tests only."""
    n2 = 2 * system.n
    L = system.laplacian_exact(mode)
    al, ga = system.alpha_q, system.gamma_q
    A = flint.fmpq_mat(n2, n2)
    for i in range(system.n):
        A[i, system.n + i] = 1
        A[system.n + i, system.n + i] = flint.fmpq(-ga.numerator, ga.denominator)
        for j in range(system.n):
            x = -al * L[i][j]
            A[system.n + i, j] = flint.fmpq(x.numerator, x.denominator)
    C = flint.fmpq_mat(system.C().astype(int).tolist()) if system.C().shape[0] else flint.fmpq_mat(0, n2)
    blocks = []
    M = C
    for _ in range(n2):
        blocks.append(M)
        M = M * A
    rows = [[blk[r, c] for c in range(n2)] for blk in blocks for r in range(blk.nrows())]
    if not rows:
        return 0
    return int(flint.fmpq_mat(rows).rank())


def _output_derivatives(A: np.ndarray, C: np.ndarray, v: np.ndarray, k: int) -> list[float]:
    """||C A^j v|| / ||A||^j, j < k: the scaled output derivatives at t = 0."""
    out = []
    scale = max(np.linalg.norm(A, 2), 1.0)
    x = v.copy()
    for j in range(k):
        out.append(float(np.linalg.norm(C @ x)) / scale**j)
        x = A @ x
    return out


GRAPHS = {
    "path6-end": (nx.path_graph(6), {"monitor_velocities": [1]}),
    "path6-middle": (nx.path_graph(6), {"monitor_velocities": [3]}),
    "cycle6": (nx.cycle_graph(6), {"monitor_velocities": [1]}),
    "star7": (nx.star_graph(6), {"monitor_velocities": [2]}),
    "star7-center-position": (nx.star_graph(6), {"monitor_positions": [1]}),
    "complete5": (nx.complete_graph(5), {"monitor_velocities": [1, 2]}),
    "grid2x3": (nx.convert_node_labels_to_integers(nx.grid_2d_graph(2, 3)), {"monitor_velocities": [1]}),
    "disconnected": (nx.union(nx.path_graph(3), nx.path_graph(3), rename=("a", "b")), {"monitor_velocities": ["a0"]}),
    "mixed": (nx.path_graph(5), {"monitor_positions": [2], "monitor_velocities": [5]}),
    "nothing-monitored": (nx.path_graph(4), {}),
}


@pytest.mark.parametrize("name", list(GRAPHS))
def test_the_modal_formula_matches_exact_observability_ranks(name: str) -> None:
    G, kw = GRAPHS[name]
    s = _system(G, **kw)
    S = unobservable_subspace(s)
    D = unobservable_subspace_dense(s.A(), s.C())
    E = unobservable_subspace_exact(s, "normal")
    truth = 2 * s.n - exact_observability_rank(s)
    assert S.decided and D.decided
    assert S.dim == D.dim == len(E) == truth
    assert principal_sines(S.basis, D.basis).max(initial=0.0) < 1e-8
    # the rational basis spans the same space
    if truth:
        Eq = np.array([[float(x) for x in v] for v in E]).T
        Q, _ = np.linalg.qr(Eq)
        assert principal_sines(S.basis, Q).max() < 1e-8


def test_the_double_root_gamma_squared_equal_to_four_alpha_mu_keeps_the_formula() -> None:
    # K3 has mu = 3 twice; alpha = 1/3, gamma = 2 gives gamma^2 = 4 alpha mu: A has a Jordan chain
    data = {
        "format": 1,
        "dynamics": {"alpha": "1/3", "gamma": 2},
        "graph": {"nodes": 3, "edges": [[1, 2], [2, 3], [1, 3]]},
        "monitor": {"velocities": [1]},
    }
    s = System(spec_from_dict(data))
    A = s.A()
    lam = np.linalg.eigvals(A)
    assert np.sum(np.abs(lam + 1.0) < 1e-6) == 4  # lam = -1 four times (two Jordan chains)
    S = unobservable_subspace(s)
    assert S.dim == 2 * 3 - exact_observability_rank(s) == 3  # [1;0] and W_3 x W_3 (dim 1 each slot)
    for v in S.basis.T:
        assert max(_output_derivatives(A, s.C(), v, 6)) < 1e-12
    # the 2x2 exponential is continuous through the double root
    for mu in (3.0, 3.0 * (1 + 1e-9), 3.0 * (1 - 1e-9)):
        p = block_exponentials(np.array([mu]), 1 / 3, 2.0, 0.7)
        ref = scipy.linalg.expm(0.7 * np.array([[0.0, 1.0], [-mu / 3, -2.0]]))
        assert np.allclose([p[0][0], p[1][0], p[2][0], p[3][0]], ref.ravel(), atol=1e-13)


@pytest.mark.parametrize("t", [0.3, 2.0, -1.5, -10.0])
@pytest.mark.parametrize("gamma", [0.5, 2.0])
def test_modal_exponentials_match_expm_of_the_state_matrix(t: float, gamma: float) -> None:
    G = nx.Graph()
    G.add_weighted_edges_from([(1, 2, 1), (2, 3, 3), (3, 4, 1), (1, 4, 2), (2, 4, 1)])
    s = System(spec_from_graph(G, gamma=gamma, alpha=1, monitor_velocities=[1]))
    X = np.random.default_rng(0).standard_normal((8, 3))
    ref = scipy.linalg.expm(t * s.A()) @ X
    got = modal_exponential(s, "normal", t, X)
    assert np.allclose(got, ref, rtol=1e-10, atol=1e-10 * np.abs(ref).max())


def test_unobservable_basis_vectors_produce_no_output_derivatives() -> None:
    s = System(load_example("paper19"))
    for mode in s.modes:
        S = unobservable_subspace(s, mode)
        A = s.A(mode)
        for v in S.basis.T:
            assert max(_output_derivatives(A, s.C(), v, 8)) < 1e-10


def test_velocity_only_monitors_keep_the_consensus_direction_unobservable_and_position_monitors_do_not() -> None:
    for exact in (False, True):
        s = _system(nx.path_graph(5), monitor_velocities=[1, 5])
        rs = verify(s, ["privacy.unobservable"], exact=exact).conditions
        assert [r.status for r in rs] == [Status.HOLDS]
        assert rs[0].margin is not None and rs[0].margin < 1e-12
        s2 = _system(nx.path_graph(5), monitor_velocities=[1], monitor_positions=[3])
        rs2 = verify(s2, ["privacy.unobservable"], exact=exact).conditions
        assert [r.status for r in rs2] == [Status.FAILS]
        assert rs2[0].witness["position_monitors"] == [3]
        assert rs2[0].margin is not None and rs2[0].margin > 0.1


def test_an_observable_pair_fails_privacy_and_holds_observability() -> None:
    # the position of an end agent of a path sees everything
    s = _system(nx.path_graph(5), monitor_positions=[1])
    for exact in (False, True):
        rep = verify(s, ["switched-observability", "privacy.initial-state", "privacy.consensus-value"], exact=exact)
        st = {r.id: r.status for r in rep.conditions}
        assert st == {"switched-observability": Status.HOLDS, "privacy.initial-state": Status.FAILS, "privacy.consensus-value": Status.FAILS}


def test_a_star_hides_its_initial_state_but_reveals_the_consensus_value_to_a_centre_position_monitor() -> None:
    # leaves are symmetric: W_1 = {v on the leaves, sum 0}; every unobservable state has zero sum
    s = _system(nx.star_graph(5), monitor_positions=[1])
    for exact in (False, True):
        rep = verify(s, ["privacy.initial-state", "privacy.consensus-value"], exact=exact)
        st = {r.id: r for r in rep.conditions}
        assert st["privacy.initial-state"].status is Status.HOLDS
        assert st["privacy.consensus-value"].status is Status.FAILS
    v = st["privacy.initial-state"].witness["vector"]
    x = np.array([float(Fraction(v["x"][a])) for a in s.labels] + [float(Fraction(v["v"][a])) for a in s.labels])
    assert np.linalg.norm(x) > 0 and max(_output_derivatives(s.A(), s.C(), x, 10)) < 1e-12


def test_the_consensus_value_witness_is_unobservable_and_not_orthogonal_to_f() -> None:
    s = System(load_example("paper19"))
    for r in verify(s, ["privacy.consensus-value"]).conditions:
        assert r.status is Status.HOLDS
        v = r.witness["vector"]
        x = np.array([v["x"][a] for a in s.labels] + [v["v"][a] for a in s.labels])
        f = np.concatenate([np.ones(s.n) / s.n, np.zeros(s.n)])
        assert abs(f @ x) > 1e-3 and abs(f @ x - r.witness["f_dot_v"]) < 1e-9
        if "mode" in r.scope:
            assert max(_output_derivatives(s.A(r.scope["mode"]), s.C(), x, 8)) < 1e-9


# --------------------------------------------------------------------------------------------
# switched systems


def _switching_path() -> System:
    # the path 4-3-1-5-2 monitored at its centre 1 is symmetric; mode "a" links 1-2, mode "b" 2-4
    G = nx.Graph([(4, 3), (3, 1), (1, 5), (5, 2)])
    return _system(G, monitor_velocities=[1], modes={"a": {"add": [(1, 2)]}, "b": {"add": [(2, 4)]}})


def _dense_switched(s: System, seq: list[tuple[str, float]]) -> np.ndarray:
    """Reference: the recursion with dense staircase subspaces and scipy expm (small systems)."""
    V = unobservable_subspace_dense(s.A(seq[-1][0]), s.C()).basis
    for mode, tau in reversed(seq[:-1]):
        P = unobservable_subspace_dense(s.A(mode), s.C()).basis
        Phi = scipy.linalg.expm(tau * s.A(mode))
        # x in span P with Phi x in span V: kernel of (I - V V^T) Phi P
        M = Phi @ P - V @ (V.T @ (Phi @ P))
        _, sv, Vh = np.linalg.svd(M)
        r = int(np.sum(sv > 1e-9 * max(1.0, sv.max(initial=0.0))))
        V, _ = np.linalg.qr(P @ Vh[r:].T)
    return V


def _schedule_output(s: System, seq: list[tuple[str, float]], x0: np.ndarray, samples: int = 7) -> float:
    """max ||y(t)|| along the schedule for x(t0) = x0 (the defining property of N_1^m)."""
    worst = 0.0
    x = x0.copy()
    for mode, tau in seq:
        A = s.A(mode)
        for t in np.linspace(0.0, tau, samples):
            worst = max(worst, float(np.linalg.norm(s.C() @ scipy.linalg.expm(t * A) @ x)))
        x = scipy.linalg.expm(tau * A) @ x
    return worst


@pytest.mark.parametrize(
    "seq",
    [
        [("normal", 1.0), ("a", 1.0)],
        [("a", 0.7), ("normal", 1.3), ("b", 1.0)],
        [("normal", 0.5), ("a", 0.5), ("b", 0.5), ("normal", 1.0)],
    ],
)
def test_the_switched_subspace_matches_a_dense_reference_and_produces_no_output(seq: list[tuple[str, float]]) -> None:
    s = _switching_path()
    S = switched_unobservable_subspace(s, seq)
    R = _dense_switched(s, seq)
    assert S.decided and S.dim == R.shape[1]
    assert principal_sines(S.basis, R).max(initial=0.0) < 1e-7
    for v in S.basis.T:
        assert _schedule_output(s, seq, v) < 1e-9
    b = switched_unobservable_bounds_exact(s, seq)
    assert b.dim_lower <= S.dim <= b.dim_upper
    if len(seq) <= 2:
        assert b.exact_dimension and b.dim_lower == S.dim


def test_switching_shrinks_the_unobservable_subspace_of_a_symmetric_path() -> None:
    s = _switching_path()
    dims = {m: unobservable_subspace(s, m).dim for m in s.modes}
    assert dims == {"normal": 5, "a": 3, "b": 5}
    S = switched_unobservable_subspace(s, [("normal", 1.0), ("a", 1.0)])
    assert S.dim == 1  # only [1; 0] stays: no position is monitored
    e = np.concatenate([np.ones(5), np.zeros(5)]) / np.sqrt(5)
    assert np.linalg.norm(S.basis @ (S.basis.T @ e) - e) < 1e-9


def test_exact_bounds_can_disagree_for_three_modes_and_the_checker_then_says_it_is_numeric() -> None:
    # found by a random search: the dimension depends on the dwell times, exact bounds 1..7
    data = {
        "format": 1,
        "graph": {"nodes": 5, "edges": [[1, 4], [2, 4], [3, 4], [3, 5], [4, 5]]},
        "monitor": {"velocities": [4]},
        "modes": [{"name": "a", "add": [[2, 3]]}, {"name": "b", "remove": [[3, 4]]}],
        "switching": {"sequence": [{"mode": "normal", "duration": 1.0}, {"mode": "a", "duration": 1.0}, {"mode": "b", "duration": 1.0}]},
    }
    s = System(spec_from_dict(data))
    seq = mode_sequence(s)
    assert seq == [("normal", 1.0), ("a", 1.0), ("b", 1.0)]
    b = switched_unobservable_bounds_exact(s, seq)
    assert (b.dim_lower, b.dim_upper) == (1, 7)
    S = switched_unobservable_subspace(s, seq)
    assert S.decided and S.dim == _dense_switched(s, seq).shape[1]
    for v in S.basis.T:
        assert _schedule_output(s, seq, v) < 1e-9
    # the initial-state verdict is exact anyway (dim >= 1), the observability one is too (dim_lower > 0)
    rs = [r for r in verify(s, ["switched-observability", "privacy.initial-state", "privacy.consensus-value"], exact=True).conditions if not r.scope]
    assert all(r.method is Method.EXACT for r in rs)
    assert {r.id: r.status for r in rs} == {
        "switched-observability": Status.FAILS,
        "privacy.initial-state": Status.HOLDS,
        "privacy.consensus-value": Status.HOLDS,
    }


def test_a_numeric_fallback_in_exact_mode_is_flagged_as_numeric() -> None:
    # position monitors remove [1; 0]; on this schedule the exact bounds cannot decide observability
    data = {
        "format": 1,
        "graph": {"nodes": 5, "edges": [[1, 4], [2, 4], [3, 4], [3, 5], [4, 5]]},
        "monitor": {"positions": [4]},
        "modes": [{"name": "a", "add": [[2, 3]]}, {"name": "b", "remove": [[3, 4]]}],
        "switching": {"sequence": [{"mode": "normal", "duration": 1.0}, {"mode": "a", "duration": 1.0}, {"mode": "b", "duration": 1.0}]},
    }
    s = System(spec_from_dict(data))
    seq = mode_sequence(s)
    assert seq is not None
    b = switched_unobservable_bounds_exact(s, seq)
    S = switched_unobservable_subspace(s, seq)
    assert (b.dim_lower, b.dim_upper) == (0, 6) and S.decided and S.dim == 2
    assert S.dim == _dense_switched(s, seq).shape[1]
    for v in S.basis.T:
        assert _schedule_output(s, seq, v) < 1e-9
    (r,) = [r for r in verify(s, ["switched-observability"], exact=True).conditions if not r.scope]
    assert r.method is Method.NUMERIC and "note" in r.witness and r.tolerance is not None
    # no exact and no certified bound decides this schedule: undecided (certified verdicts,
    # issue 14); the rtol recursion's reading stays in the witness, marked uncertified
    assert r.status is Status.UNDECIDED and r.witness["exact_bounds"] == [0, 6]
    assert r.witness["uncertified_reading"] == "fails" and r.note


def test_the_schedule_comes_from_the_switching_table() -> None:
    s = System(load_example("paper19"))
    assert mode_sequence(s) == [("normal", 10.0), ("case-2", 20.0)]
    s2 = _system(nx.path_graph(3), monitor_velocities=[1])
    assert mode_sequence(s2) is None
    assert all("mode" in r.scope for r in verify(s2, ["switched-observability"]).conditions)


# --------------------------------------------------------------------------------------------
# paper19


@pytest.fixture(scope="module")
def paper19() -> System:
    return System(load_example("paper19"))


def _key(r: ConditionResult) -> tuple[str, tuple[tuple[str, Any], ...]]:
    return (r.id, tuple(sorted(r.scope.items())))


def test_paper19_gives_a_verdict_for_every_mode_and_exact_agrees(paper19: System) -> None:
    num = {_key(r): r for r in verify(paper19, NEW_IDS).conditions}
    exa = {_key(r): r for r in verify(paper19, NEW_IDS, exact=True).conditions}
    assert num.keys() == exa.keys()
    for cid in NEW_IDS:
        scoped = {k[1] for k in num if k[0] == cid}
        modes = set(paper19.modes) if cid != "switching.eigenvector-differences" else set(paper19.safe_modes)
        if cid != "central.observer":
            assert {dict(s).get("mode") for s in scoped} >= modes
    for k, r in num.items():
        assert r.status is not Status.UNDECIDED and exa[k].status is r.status, k
        assert exa[k].method is Method.EXACT
    st = {k: r.status for k, r in num.items()}
    assert st[("privacy.unobservable", ())] is Status.HOLDS
    assert st[("switched-observability", ())] is Status.FAILS
    assert st[("central.observer", ())] is Status.HOLDS


def test_paper19_cases_1_and_2_meet_eigenvector_differences_by_about_0_04_and_case_3_fails(paper19: System) -> None:
    for exact in (False, True):
        rs = {r.scope["mode"]: r for r in verify(paper19, ["switching.eigenvector-differences"], exact=exact).conditions}
        for case in ("case-1", "case-2"):
            assert rs[case].status is Status.HOLDS
            assert rs[case].margin is not None and 0.03 < rs[case].margin < 0.06
        assert rs["case-3"].status is Status.FAILS


def test_the_cli_reports_the_new_conditions_with_exact_arithmetic(tmp_path: Any) -> None:
    out = tmp_path / "r.json"
    code = main(["verify", "--example", "paper19", "--exact", "--only", ",".join(NEW_IDS), "--format", "json", "--out", str(out), "--quiet"])
    assert code == 0
    data = json.loads(out.read_text())
    assert {c["id"] for c in data["conditions"]} == set(NEW_IDS)
    assert all(c["method"] == "exact" and c["status"] != "undecided" for c in data["conditions"])
    assert any(f["id"] == "central.hurwitz-infeasible" for f in data["findings"])


def test_the_switched_subspace_need_not_be_invariant_which_lemma_ii3_claims() -> None:
    # Lemma II.3 (ii) calls N_1^m "the largest A_sigma-invariant subspace contained in ker C"
    data = {
        "format": 1,
        "graph": {"nodes": 5, "edges": [[1, 4], [2, 4], [3, 4], [3, 5], [4, 5]]},
        "monitor": {"velocities": [4]},
        "modes": [{"name": "a", "add": [[2, 3]]}, {"name": "b", "remove": [[3, 4]]}],
        "switching": {"sequence": [{"mode": "normal", "duration": 1.0}, {"mode": "a", "duration": 1.0}, {"mode": "b", "duration": 1.0}]},
    }
    s = System(spec_from_dict(data))
    seq = mode_sequence(s)
    assert seq is not None
    V = switched_unobservable_subspace(s, seq).basis
    assert V.shape[1] == 3
    for mode in s.modes:
        AV = s.A(mode) @ V
        assert np.linalg.norm(AV - V @ (V.T @ AV)) > 0.1  # invariant under no mode
    rep = verify(s, ["switched-observability"])
    (f,) = [f for f in rep.findings if f.id == "lemma2.switched-subspace-not-invariant"]
    assert f.data["dim"] == 3 and f.data["common_invariant_dim"] == 1
    # paper19's two-mode schedule keeps only [1; 0], which is invariant: no finding
    p19 = System(load_example("paper19"))
    assert not [f for f in verify(p19, ["switched-observability"]).findings if f.id.startswith("lemma2.")]
