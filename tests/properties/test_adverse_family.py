"""Never a wrong verdict on the adverse family: numeric against exact on members of N <= 60.

The members come from :func:`glocal_verify.design.generators.adverse_clustered_spec` (clusters
drawn as a stochastic block model, observers measuring only their neighbours, links between
random pairs of clusters, 0-3 safe modes, the ZDA present or absent), scaled down. Numeric
``verify`` runs with the tunables of the large-network paths forced on (the modular zero count
of the cluster pencils instead of maximal minors, the structural and sparse modular touch tests
instead of the exact solve, no dense rank bounds), so that what serves N = 2000-10,000 is
checked here against exact arithmetic: a decided numeric verdict must equal the exact one.
"""

from __future__ import annotations

from fractions import Fraction

from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from strategies import assert_numeric_matches_exact

from glocal_verify import System, config
from glocal_verify.analysis.local.cases import local_cases
from glocal_verify.analysis.local.pencil_rank_certificates import zero_count_certificate
from glocal_verify.analysis.local.pencil import pencil_verdict_exact
from glocal_verify.design.generators import ADVERSE_LINKS, ADVERSE_MEASURES, adverse_clustered_spec
from glocal_verify.errors import SpecError
from glocal_verify.results import Status

#: the conditions whose large-network paths this file checks
IDS = ["local.pencil", "stealthy.zda", "switching.avoids-attack", "switched-observability"]

#: the large-network paths, forced on at small N
LARGE_PATHS = {"minor_max_inputs": 0, "zero_touch_exact_max_agents": 0, "avoidance_dense_max_agents": 0}


@st.composite
def adverse_members(draw: st.DrawFn, max_n: int = 60, min_monitors: int = 2, max_monitors: int = 4) -> System:
    n = draw(st.integers(16, max_n))
    try:
        spec = adverse_clustered_spec(
            n,
            seed=draw(st.integers(0, 10_000)),
            cluster_size=draw(st.integers(8, max(8, n // 2))),
            degree=draw(st.sampled_from([3.0, 4.5, 6.0, 8.0])),
            links=draw(st.sampled_from(ADVERSE_LINKS)),
            cut_edges=draw(st.integers(1, 3)),
            measure=draw(st.sampled_from(ADVERSE_MEASURES)),
            modes=draw(st.integers(0, 3)),
            attack=draw(st.booleans()),
            monitors=draw(st.integers(min_monitors, max_monitors)),
        )
    except SpecError:
        assume(False)
        raise
    return System(spec)


def _ids(system: System) -> list[str]:
    """IDS, without the ZDA conditions when their exact reference would take the dense V* iteration over Q
    (a pencil that is not left-invertible: minutes at N = 40; those are checked at N <= 24 below)."""
    from glocal_verify.analysis.stealthy.zda_exact import has_fast_exact_path

    if system.spec.attack is None or has_fast_exact_path(system):
        return IDS
    return ["local.pencil", "switched-observability"]


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(adverse_members())
def test_numeric_verdicts_on_adverse_members_agree_with_exact_arithmetic(system: System) -> None:
    with config.override(**LARGE_PATHS):
        assert_numeric_matches_exact(System(system.spec), _ids(system))


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(adverse_members(max_n=24, min_monitors=1, max_monitors=1))
def test_small_adverse_members_with_one_monitor_agree_with_exact_arithmetic_on_every_condition(system: System) -> None:
    # one monitor for two attacked agents: never left-invertible, the separator proofs of the
    # ZDA and of its avoidance (lambda0 = 1) against the dense exact analysis
    with config.override(**LARGE_PATHS):
        assert_numeric_matches_exact(System(system.spec), IDS)


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(adverse_members(max_n=48))
def test_the_zero_count_certificate_of_a_cluster_pencil_is_never_contradicted_over_q(system: System) -> None:
    for case in local_cases(system):
        if case.structural:
            continue
        cert = zero_count_certificate(system, case)
        if cert is None:
            continue
        # the certificate claims full column rank at every lam != 0: the exact analysis finds no zero there
        ex = pencil_verdict_exact(system, case, margin=False)
        zeros = [z for z in ex.witness.get("zeros", []) if complex(z["lambda"]) != 0]
        assert ex.witness.get("full_normal_column_rank", True), (case.scope, cert)
        assert not zeros, (case.scope, cert, zeros)


def test_the_issue_network_scaled_down_is_decided_and_agrees_with_exact_arithmetic() -> None:
    # clusters of 20 of mean degree 6, random links, observers measuring their neighbours only
    system = System(adverse_clustered_spec(60, seed=3, cluster_size=20, degree=6.0, modes=1))
    with config.override(**LARGE_PATHS):
        fast = System(system.spec)
        assert_numeric_matches_exact(fast, _ids(system))
        from glocal_verify import verify

        rep = verify(fast, IDS)
    assert all(r.status is not Status.UNDECIDED for r in rep.conditions), [(r.id, r.scope, r.note) for r in rep.conditions if r.status is Status.UNDECIDED]


def test_every_separator_proof_of_an_avoided_switch_is_confirmed_over_q() -> None:
    # one monitor: a single agent often separates the two attacked agents from it, and a safe
    # mode far from them is then avoided at every lambda0 (here lambda0 = 1, the rule's witness)
    from glocal_verify.analysis.switching.avoidance import avoidance_exact, separator_avoidance

    proofs = 0
    for seed in range(80):
        try:
            system = System(adverse_clustered_spec(18 + seed % 6, seed=seed, cluster_size=8 + seed % 4, degree=(3.0, 4.5, 6.0)[seed % 3],
                                                   modes=1 + seed % 3, monitors=1, attack=True))
        except SpecError:
            continue
        F = system.idx(system.spec.attack.actuators)
        for mode in system.safe_modes:
            if separator_avoidance(system, mode, F, 1.0 + 0j) is None:
                continue
            proofs += 1
            ex = avoidance_exact(system, mode, lambda0=1.0)
            assert ex is not None and ex.status is Status.HOLDS, (system.name, mode)
    assert proofs >= 4  # the test keeps its point
