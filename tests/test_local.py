"""Proposition III.2 per cluster and observer: known cases, witnesses checked against the pencil."""

from __future__ import annotations

from fractions import Fraction

import networkx as nx
import numpy as np
import pytest

from glocal_verify import System, load_example, spec_from_graph, verify
from glocal_verify.analysis.local.cases import LocalCase, full_pencil, local_cases
from glocal_verify.cli import main
from glocal_verify.results import ConditionResult, Status

LOCAL = ["local.k-connected", "local.rank", "local.pencil", "local.uio"]


@pytest.fixture(scope="module")
def paper19() -> System:
    return System(load_example("paper19"))


def _results(system: System, cid: str, exact: bool = False) -> dict[tuple[str, object, str], ConditionResult]:
    return {(r.scope["cluster"], r.scope["observer"], r.scope["suspected"]): r for r in verify(system, [cid], exact=exact).conditions}


def _case(system: System, cluster: str, center: object, kind: str) -> LocalCase:
    (c,) = [c for c in local_cases(system) if c.model.name == cluster and c.observer.center == center and c.kind == kind]
    return c


def _vector(case: LocalCase, d: dict) -> np.ndarray:  # type: ignore[type-arg]
    """[x; u_B; u_E] of a witness direction, in the column order of the full pencil."""
    nodes = case.model.nodes
    pos = {str(k): v for k, v in d["positions"].items()}
    vel = {str(k): v for k, v in d["velocities"].items()}
    att = {str(k): v for k, v in d["attack_input"].items()}
    cpl = {str(k): v for k, v in d["coupling_input"].items()}
    x = [complex(pos.get(str(a), 0)) for a in nodes] + [complex(vel.get(str(a), 0)) for a in nodes]
    u = [complex(att.get(str(a), 0)) for a in case.suspected] + [complex(cpl.get(str(a), 0)) for a in case.model.boundary]
    return np.array(x + u)


def test_paper19_reports_all_four_local_conditions_for_every_observer_and_both_suspected_sets(paper19: System) -> None:
    rep = verify(paper19, LOCAL)
    for cid in LOCAL:
        scopes = {(r.scope["cluster"], r.scope["observer"], r.scope["suspected"]) for r in rep.results(cid)}
        assert scopes == {(c, o, k) for c, o in [("P1", 5), ("P1", 6), ("P2", 10), ("P3", 13)] for k in ("attack", "all")}


def test_the_cli_reports_the_local_conditions_of_paper19(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["verify", "--example", "paper19", "--only", "local.*", "--format", "json", "--quiet"]) == 0
    out = capsys.readouterr().out
    for cid in LOCAL:
        assert f'"id": "{cid}"' in out


@pytest.mark.parametrize("exact", [False, True])
def test_observer_5_detects_the_zda_on_agents_3_and_4(paper19: System, exact: bool) -> None:
    r = _results(paper19, "local.pencil", exact)[("P1", 5, "attack")]
    assert r.status is Status.HOLDS
    assert r.witness["suspected_agents"] == [3, 4]


@pytest.mark.parametrize("exact", [False, True])
def test_observer_6_misses_it_with_a_direction_that_moves_3_and_4_and_kills_the_pencil(paper19: System, exact: bool) -> None:
    r = _results(paper19, "local.pencil", exact)[("P1", 6, "attack")]
    assert r.status is Status.FAILS
    assert r.witness["full_normal_column_rank"] is False
    d = r.witness["direction"]
    assert d["moves"] == [3, 4]
    pos = d["positions"]
    assert pos[4] / pos[3] == pytest.approx(-2.0)  # xi = e3 - 2 e4 of the paper19 construction
    case = _case(paper19, "P1", 6, "attack")
    v = _vector(case, d)
    P = full_pencil(case, d["lambda"])
    assert np.linalg.norm(P @ v) <= 1e-9 * np.linalg.norm(P, 2) * np.linalg.norm(v)
    # normal-rank deficiency: the pencil is singular at other lam too
    for lam in (0.0, 2.0, -0.3 + 1.1j):
        s = np.linalg.svd(full_pencil(case, lam), compute_uv=False)
        assert s[-1] < 1e-12 * s[0]


@pytest.mark.parametrize("exact", [False, True])
def test_the_worst_case_fails_structurally_at_the_boundary_agent_and_becomes_a_finding(paper19: System, exact: bool) -> None:
    rep = verify(paper19, ["local.pencil"], exact=exact)
    r = [x for x in rep.conditions if x.scope == {"cluster": "P1", "observer": 5, "suspected": "all"}][0]
    assert r.status is Status.FAILS and r.witness["structural"] is True
    assert r.witness["suspected_and_boundary"] == [7]
    assert "7" in r.witness["reason"]
    case = _case(paper19, "P1", 5, "all")
    v = _vector(case, r.witness["direction"])
    for lam in (0.0, 1.0, 3j):
        assert np.linalg.norm(full_pencil(case, lam) @ v) == 0.0
    assert any(f.id == "local.boundary-attack-invisible" for f in rep.findings)


def test_a_uio_without_detection_is_reported_as_a_finding(paper19: System) -> None:
    rep = verify(paper19, ["local.pencil", "local.uio"])
    uio6 = [r for r in rep.results("local.uio") if r.scope == {"cluster": "P1", "observer": 6, "suspected": "attack"}][0]
    assert uio6.status is Status.HOLDS
    f = [f for f in rep.findings if f.id == "local.uio-without-detection"]
    assert f and {"cluster": "P1", "observer": 6, "suspected": "attack"} in f[0].data["scopes"]


def _path_clusters(measured: list[int], suspected: list[int] | None = None) -> System:
    """Path 1-2-3 | 4-5: cluster A = {1, 2, 3} with boundary agent 1 (edge 1-4)."""
    G = nx.Graph()
    G.add_weighted_edges_from([(1, 2, 1), (2, 3, 2), (1, 4, 1), (4, 5, 1)])
    return System(
        spec_from_graph(
            G,
            clusters={"A": [1, 2, 3], "B": [4, 5]},
            observers={"A": [{"center": 1, "positions": measured, "velocities": measured}], "B": [4]},
            monitor_velocities=[5],
            attack={"kind": "zda", "actuators": suspected or [5]},
        )
    )


@pytest.mark.parametrize("exact", [False, True])
def test_an_observer_measuring_only_the_boundary_fails_iii_with_finite_zeros_checked_on_the_pencil(exact: bool) -> None:
    s = _path_clusters([1])
    r = _results(s, "local.pencil", exact)[("A", 1, "attack")]
    assert r.status is Status.FAILS and r.witness["full_normal_column_rank"] is True
    zeros = r.witness["zeros"]
    assert len(zeros) == 4  # two eigenvalues mu of L[{2,3},{2,3}], two lam each
    case = _case(s, "A", 1, "attack")
    mus = np.linalg.eigvalsh(case.model.L[1:, 1:])
    for z in zeros:
        lam = complex(z["lambda"])
        s_ = lam * lam + s.gamma * lam
        assert min(abs(s_ + s.alpha * mu) for mu in mus) < 1e-8  # lam^2 + gamma lam = -alpha mu
        P = full_pencil(case, lam)
        sv = np.linalg.svd(P, compute_uv=False)
        assert sv[-1] < 1e-9 * sv[0]
        v = _vector(case, z)
        assert np.linalg.norm(P @ v) <= 1e-8 * sv[0] * np.linalg.norm(v)
        assert set(z["moves"]) <= {2, 3} and z["moves"]
    # measuring agent 3 as well removes every zero
    assert _results(_path_clusters([1, 3]), "local.pencil", exact)[("A", 1, "attack")].status is Status.HOLDS


@pytest.mark.parametrize("exact", [False, True])
def test_an_unmeasured_boundary_velocity_fails_ii_and_the_uio_naming_the_agent(exact: bool) -> None:
    s = _path_clusters([2, 3])
    r = _results(s, "local.rank", exact)[("A", 1, "attack")]
    assert r.status is Status.FAILS and r.witness["unmeasured_boundary"] == [1]
    u = _results(s, "local.uio", exact)[("A", 1, "attack")]
    assert u.status is Status.FAILS and u.witness["normal"]["unmeasured_boundary"] == [1]


@pytest.mark.parametrize("exact", [False, True])
def test_a_marginal_unobservable_mode_of_a1_makes_the_uio_fail_with_the_mode_as_witness(exact: bool) -> None:
    # only the boundary agent's velocity is measured: T kills its velocity row, x1 integrates
    G = nx.Graph()
    G.add_weighted_edges_from([(1, 2, 1), (2, 3, 1), (1, 4, 1), (4, 5, 1)])
    s = System(
        spec_from_graph(G, clusters={"A": [1, 2, 3], "B": [4, 5]}, observers={"A": [{"center": 1, "positions": [], "velocities": [1]}], "B": [4]})
    )
    (r,) = verify(s, ["local.uio"], exact=exact).conditions[:1]
    assert r.scope == {"cluster": "A", "observer": 1, "suspected": "all"}
    assert r.status is Status.FAILS
    w = r.witness["normal"]
    if exact:
        assert w["unstable_unobservable_modes"]
    else:
        mode = w["unstable_unobservable_mode"]
        assert abs(complex(mode["eigenvalue"])) < 1e-9 and mode["positions"]


def test_k_connected_reports_the_cut_edge_count_and_rank_e() -> None:
    # agent 1 has two cut edges (to 4 and 5): the paper counts 2, rank(E) is 1
    G = nx.Graph()
    G.add_weighted_edges_from([(1, 2, 1), (2, 3, 1), (1, 4, 1), (1, 5, 1), (4, 5, 1)])
    s = System(
        spec_from_graph(G, clusters={"A": [1, 2, 3], "B": [4, 5]}, observers={"A": [2], "B": [4]}, attack={"kind": "zda", "actuators": [3]})
    )
    r = _results(s, "local.k-connected")[("A", 2, "attack")]
    w = r.witness
    assert w["degree"] == 2 and w["inter_cluster_edges"] == 2 and w["rank_E"] == 1
    assert w["required"] == 3 and w["required_with_rank_E"] == 2
    assert r.status is Status.FAILS and w["holds_with_rank_E"] is True
    assert r.margin == -1


def test_the_attack_scope_is_present_even_when_no_attacked_agent_is_in_the_cluster(paper19: System) -> None:
    r = _results(paper19, "local.pencil")[("P2", 10, "attack")]
    assert r.witness["suspected_agents"] == []
    s = System(spec_from_graph(nx.path_graph([1, 2, 3, 4]), clusters={"A": [1, 2], "B": [3, 4]}, observers={"A": [1], "B": [4]}))
    assert {k[2] for k in _results(s, "local.rank")} == {"all"}


def test_exact_results_are_never_undecided_and_agree_with_numeric_on_paper19(paper19: System) -> None:
    for cid in ("local.rank", "local.pencil", "local.uio"):
        num = _results(paper19, cid)
        exa = _results(paper19, cid, exact=True)
        for k, r in exa.items():
            assert r.status is not Status.UNDECIDED
            assert r.status is num[k].status, (cid, k)


def test_local_results_validate_against_the_report_schema(paper19: System) -> None:
    from glocal_verify import validate_report_json

    validate_report_json(verify(paper19, LOCAL).to_json())
    validate_report_json(verify(paper19, LOCAL, exact=True).to_json())


def test_rational_weights_reach_the_exact_pencil_unchanged() -> None:
    G = nx.Graph()
    G.add_edge(1, 2, weight=Fraction(1, 3))
    G.add_edge(2, 3, weight=Fraction(5, 7))
    G.add_edge(3, 4, weight=1)
    s = System(spec_from_graph(G, clusters={"A": [1, 2, 3], "B": [4]}, observers={"A": [{"center": 2, "positions": [2, 3], "velocities": [2, 3]}], "B": [4]}))
    num = _results(s, "local.pencil")
    exa = _results(s, "local.pencil", exact=True)
    for k in exa:
        assert exa[k].status is num[k].status


# --------------------------------------------------------------------------------------------
# structured path of local.pencil (zero forcing, reduced pencil, lifted directions)

METHODS = ["structured", "dense"]


def _pencil(system: System, exact: bool, method: str) -> dict[tuple[str, object, str], ConditionResult]:
    rep = verify(system, ["local.pencil"], exact=exact, options={"local_pencil_method": method})
    return {(r.scope["cluster"], r.scope["observer"], r.scope["suspected"]): r for r in rep.conditions}


def _check_direction(case: LocalCase, d: dict, rtol: float = 1e-9) -> None:  # type: ignore[type-arg]
    """The witness direction is a kernel vector of the full pencil of eq. pencil_uio."""
    v = _vector(case, d)
    P = full_pencil(case, complex(d["lambda"]))
    assert np.linalg.norm(v) > 0
    assert np.linalg.norm(P @ v) <= rtol * np.linalg.norm(P, 2) * np.linalg.norm(v)


@pytest.mark.parametrize("exact", [False, True])
@pytest.mark.parametrize("method", METHODS)
def test_paper19_verdicts_are_the_same_with_both_methods(paper19: System, exact: bool, method: str) -> None:
    res = _pencil(paper19, exact, method)
    expect = {("P1", 5): "holds", ("P1", 6): "fails", ("P2", 10): "holds", ("P3", 13): "holds"}
    for (cl, obs), st in expect.items():
        r = res[(cl, obs, "attack")]
        assert r.status.value == st, (cl, obs, r.witness)
        assert r.witness["method"] == method
        w = res[(cl, obs, "all")]
        assert w.status is Status.FAILS and w.witness["structural"] is True
    assert res[("P1", 5, "all")].witness["suspected_and_boundary"] == [7]
    r6 = res[("P1", 6, "attack")]
    assert r6.witness["full_normal_column_rank"] is False and r6.witness["normal_rank"] == 16
    d = r6.witness["direction"]
    assert d["moves"] == [3, 4]
    assert d["positions"][4] / d["positions"][3] == pytest.approx(-2.0)
    case = _case(paper19, "P1", 6, "attack")
    _check_direction(case, d)
    if method == "structured":
        assert r6.witness["zero_forcing"]["complete"] is False
        assert r6.witness["zero_forcing"]["unforced"] == [3, 4]
        # P1@5 holds by zero forcing: a combinatorial proof, no rank decision
        r5 = res[("P1", 5, "attack")]
        assert r5.witness["zero_forcing"]["complete"] is True and r5.margin > 0


@pytest.mark.parametrize("exact", [False, True])
def test_the_structured_path_finds_the_finite_zeros_of_the_path_cluster(exact: bool) -> None:
    s = _path_clusters([1])
    dense = _pencil(s, exact, "dense")[("A", 1, "attack")]
    r = _pencil(s, exact, "structured")[("A", 1, "attack")]
    assert r.status is Status.FAILS and r.witness["full_normal_column_rank"] is True
    assert r.witness["normal_rank"] == dense.witness["normal_rank"] == r.witness["columns"]
    zs = sorted((complex(z["lambda"]) for z in r.witness["zeros"]), key=lambda z: (z.real, z.imag))
    zd = sorted((complex(z["lambda"]) for z in dense.witness["zeros"]), key=lambda z: (z.real, z.imag))
    assert len(zs) == len(zd) == 4
    assert np.allclose(zs, zd, atol=1e-9)
    case = _case(s, "A", 1, "attack")
    for z in r.witness["zeros"]:
        _check_direction(case, z, 1e-8)
        lam = complex(z["lambda"])
        assert abs(lam * lam + s.gamma * lam - complex(z["s"])) < 1e-8
        if not exact:
            assert z["verified"] is True and z["residual"] < 1e-12
    if exact:
        assert r.witness["zero_polynomial"] == dense.witness["zero_polynomial"]
    for ex_ in (False, True):
        assert _pencil(_path_clusters([1, 3]), ex_, "structured")[("A", 1, "attack")].status is Status.HOLDS


def _velocity_only(positions: list[int], velocities: list[int], suspected: list[int]) -> System:
    """Path 1-2-3-4 | 5 with boundary agent 4; agents can be measured in velocity only."""
    G = nx.Graph()
    G.add_weighted_edges_from([(1, 2, 1), (2, 3, 2), (3, 4, 1), (4, 5, 1)])
    return System(
        spec_from_graph(
            G,
            clusters={"A": [1, 2, 3, 4], "B": [5]},
            observers={"A": [{"center": 4, "positions": positions, "velocities": velocities}], "B": [5]},
            attack={"kind": "zda", "actuators": suspected},
        )
    )


@pytest.mark.parametrize("exact", [False, True])
def test_a_velocity_only_measurement_makes_lambda_0_a_zero_of_its_own(exact: bool) -> None:
    # velocity of agent 1 measured, not its position: for lam != 0 zero forcing from {1, 4}
    # proves (iii) (1 forces 2, 2 forces 3), at lam = 0 only the position of 4 is known and
    # the constant mode of {1, 2, 3} (L xi = 0 on the rows 1, 2, 3... up to the input row 3)
    # stays: lam = 0 is a zero
    s = _velocity_only([4], [1, 4], [3])
    dense = _pencil(s, exact, "dense")[("A", 4, "attack")]
    r = _pencil(s, exact, "structured")[("A", 4, "attack")]
    assert dense.status is Status.FAILS
    assert r.status is Status.FAILS, r.witness
    assert [complex(z["lambda"]) for z in dense.witness["zeros"]] == [0.0]
    assert [complex(z["lambda"]) for z in r.witness["zeros"]] == [0.0]
    _check_direction(_case(s, "A", 4, "attack"), r.witness["zeros"][0])
    # measuring the position of 1 as well removes it
    s2 = _velocity_only([1, 4], [1, 4], [3])
    assert _pencil(s2, exact, "structured")[("A", 4, "attack")].status is Status.HOLDS
    assert _pencil(s2, exact, "dense")[("A", 4, "attack")].status is Status.HOLDS


def test_the_structured_margin_is_zero_on_failure_and_positive_on_success(paper19: System) -> None:
    res = _pencil(paper19, False, "structured")
    for k, r in res.items():
        if r.status is Status.FAILS:
            assert r.margin == 0.0, k
        else:
            assert 0.0 < r.margin <= 1.0, k


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_structured_and_dense_agree_on_generated_networks_with_every_zero_verified(seed: int) -> None:
    from glocal_verify.analysis.local.pencil import pencil_verdict
    from glocal_verify.design.generators import random_clustered_spec

    system = System(random_clustered_spec(120, 3, seed=seed))
    for case in local_cases(system):
        d = pencil_verdict(system, case, method="dense", margin=False)
        s_ = pencil_verdict(system, case, method="structured", margin=False)
        sd, wd, ss, ws = d.status, d.witness, s_.status, s_.witness
        assert ss is sd, (seed, case.scope, wd, ws)
        if case.structural:
            continue
        assert ws["normal_rank"] == wd["normal_rank"]
        assert ws.get("zero_count", 0) == wd.get("zero_count", 0)
        dense_all = [complex(z["lambda"]) for z in wd["zeros"]]
        for z in ws["zeros"]:
            assert z["verified"] is True
            _check_direction(case, z, 1e-8)
            if wd.get("zero_count", 0) <= 12:
                lam = complex(z["lambda"])
                assert min(abs(lam - x) for x in dense_all) < 1e-6 * max(1.0, abs(lam))


def test_a_star_of_equal_leaves_gives_a_multiple_zero_found_by_the_symmetric_analysis() -> None:
    # centre 3 with seven unit leaves 5..11, a heavier leaf 12 and leaf 2; the boundary agent 4
    # (edge 4-1 to cluster B); velocities of 2 and 4 measured, no position: the six
    # antisymmetric leaf modes (mu = 1) are unobservable, s = -1, lam = -1/2 ± i sqrt(3)/2 with
    # multiplicity 6, and lam = 0 is a zero because no position is measured
    G = nx.Graph()
    G.add_weighted_edges_from([(3, a, 1) for a in (2, 4, 5, 6, 7, 8, 9, 10, 11)] + [(3, 12, 2), (4, 1, 1), (1, 13, 1)])
    nodes = list(range(2, 13))
    s = System(spec_from_graph(G, clusters={"A": nodes, "B": [1, 13]}, observers={"A": [{"center": 3, "positions": [], "velocities": [2, 4]}], "B": [1]}))
    case = LocalCase(s.cluster_model("A"), s.observers("A")[0], "attack", ())
    from glocal_verify.analysis.local.pencil import pencil_verdict

    d = pencil_verdict(s, case, method="dense")
    s_ = pencil_verdict(s, case, method="structured")
    sd, wd, ss, ws = d.status, d.witness, s_.status, s_.witness
    assert sd is ss is Status.FAILS
    assert ws["reduced"]["analysis"] == "symmetric"
    got = sorted(((complex(z["lambda"]), z.get("multiplicity", 1)) for z in ws["zeros"]), key=lambda t: (t[0].imag, t[0].real))
    want = sorted(((complex(z["lambda"]), z.get("multiplicity", 1)) for z in wd["zeros"]), key=lambda t: (t[0].imag, t[0].real))
    assert [m for _, m in got] == [m for _, m in want] == [6, 1, 6]
    assert np.allclose([z for z, _ in got], [z for z, _ in want], atol=1e-9)
    for z in ws["zeros"]:
        assert z["verified"] is True
        _check_direction(case, z)


@pytest.mark.parametrize("seed", [0, 1])
def test_the_exact_pencil_pattern_read_from_the_support_equals_the_pattern_of_the_rational_rows(seed: int) -> None:
    from glocal_verify.analysis.local.cases import _exact_pattern_at, _exact_pencil_at
    from glocal_verify.design.generators import random_clustered_spec

    for system in (System(random_clustered_spec(24, 2, seed=seed)), System(load_example("paper19"))):
        for case in local_cases(system):
            for lam in (None, Fraction(0), -system.gamma_q, Fraction(3, 7)):
                _, want = _exact_pencil_at(system, case, lam)
                assert np.array_equal(_exact_pattern_at(system, case, lam), want)


def test_the_krawczyk_test_encloses_a_known_zero_of_a_rational_pencil_and_refuses_a_point_that_is_not_one() -> None:
    from glocal_verify.analysis.local.cluster_pencil import krawczyk_kernel

    # P(lam) = P0 + lam P1 = [[lam - 2, 1], [0, lam - 3]]: zeros 2 (kernel (1, 0)) and 3 (kernel (1, 1))
    q = Fraction
    P0 = [[q(-2), q(1)], [q(0), q(-3)]]
    P1 = [[q(1), q(0)], [q(0), q(1)]]
    pat = np.array([[True, True], [False, True]])
    for nonzero in (None, pat):
        enc = krawczyk_kernel(P0, P1, 2.0 + 1e-9j, np.array([1.0, 1e-14]), nonzero=nonzero)
        assert enc is not None and enc.lam.contains(2) and enc.nonzero([0])
        enc3 = krawczyk_kernel(P0, P1, 3.0, np.array([1.0, 1.0]), nonzero=nonzero)  # (1, 1) at lam = 3: -1 + 1 = 0
        assert enc3 is not None and enc3.lam.contains(3)
    # a constant pencil of full rank has no zero: nothing is proved
    I0 = [[q(1), q(0)], [q(0), q(1)]]
    Z1 = [[q(0), q(0)], [q(0), q(0)]]
    for nonzero in (None, np.eye(2, dtype=bool)):
        assert krawczyk_kernel(I0, Z1, 0.5, np.array([1.0, 0.0]), nonzero=nonzero) is None


def test_the_sparse_full_pencil_is_the_dense_one_and_bounds_its_norm_alike() -> None:
    from glocal_verify.analysis.local.cluster_pencil import backward_error, norm2_lower
    from glocal_verify.analysis.local.cases import full_pencil_sparse
    from glocal_verify.design.generators import random_clustered_spec

    system = System(random_clustered_spec(90, 3, seed=4))
    rng = np.random.default_rng(0)
    for case in local_cases(system)[:4]:
        for lam in (0.0, 0.4 - 1.1j):
            P, S = full_pencil(case, lam), full_pencil_sparse(case, lam)
            assert np.array_equal(S.toarray(), P)
            v = rng.standard_normal(P.shape[1]) + 1j * rng.standard_normal(P.shape[1])
            # both are lower bounds of ||P||_2 (power iteration), equal up to rounding
            assert norm2_lower(S) <= np.linalg.norm(P, 2) * (1 + 1e-12)
            assert abs(norm2_lower(S) - norm2_lower(P)) <= 1e-12 * norm2_lower(P)
            assert abs(backward_error(S, v) - backward_error(P, v)) <= 1e-12 * backward_error(P, v)


def test_the_sparse_exact_cluster_block_holds_exactly_the_nonzeros_of_the_dense_one() -> None:
    from glocal_verify.design.generators import random_clustered_spec

    for system in (System(load_example("paper19")), System(random_clustered_spec(120, 4, seed=3))):
        for mode in system.modes:
            for c in system.spec.clusters:
                L = system.cluster_laplacian_exact(c.name, mode)
                dense = {(i, j): x for i, row in enumerate(L) for j, x in enumerate(row) if x}
                assert system.cluster_laplacian_entries(c.name, mode) == dense
