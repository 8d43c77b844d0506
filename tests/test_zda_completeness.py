"""Examples of the completeness proof of the ZDA zero set (analysis.stealthy.zda_completeness, numerics.zero_count).

What the proof may claim is cross-checked against exact arithmetic in
``tests/properties/test_zda_completeness.py``; here: the cases it must refuse (a faster zero, a
separator, zeros of unknown location), the exactly known zeros it counts, the realistic family,
and the rule of ``stealthy.zda`` when the separator proves a system not left-invertible.
"""

from __future__ import annotations

import pytest
import re
from fractions import Fraction

import flint
import networkx as nx
from strategies import assert_completeness_sound, faster_zero_system

from glocal_verify import System, spec_from_graph
from glocal_verify.analysis.laplacian.twins import laplacian_entries
from glocal_verify.analysis.stealthy.zda_completeness import zero_set_completeness
from glocal_verify.analysis.stealthy.zda_exact import zda_analysis_exact
from glocal_verify.analysis.stealthy.zda_verdict import decide_zda
from glocal_verify.design.generators import random_clustered_spec
from glocal_verify.numerics.zero_count import zero_count_bound_mod_p
from glocal_verify.results import Status
from glocal_verify.spec.types import NORMAL_MODE


def _twin_example() -> tuple[System, tuple[int, ...]]:
    """Eight agents where the attacked agent 8 and agent 3 are twins (the mode e_8 - e_3 at s = -4 is an exact zero)."""
    G = nx.Graph()
    G.add_weighted_edges_from([(1, 4, 2), (1, 6, 1), (1, 7, 1), (2, 4, 1), (2, 7, 1), (3, 6, 2), (3, 8, 1), (4, 6, 1), (5, 7, 1), (6, 8, 2)])
    return System(spec_from_graph(G, monitor_velocities=[2, 4, 6])), (8, 1)


def test_a_genuinely_faster_zero_is_not_certified() -> None:
    system, F = faster_zero_system()
    ea = zda_analysis_exact(system, F)
    assert any(z.real_sign > 0 for z in ea.zeros)  # the example keeps its point
    c = zero_set_completeness(system, F)
    assert not c.complete
    assert c.count is not None and c.count.bound is not None and c.count.bound >= 1
    assert "not excluded" in c.text


def test_an_exact_twin_mode_meeting_f_is_counted_as_a_known_zero() -> None:
    system, F = _twin_example()
    c = zero_set_completeness(system, F)
    assert_completeness_sound(system, F)
    assert c.complete, c.text
    assert "twin modes meeting the inputs" in c.text


def test_a_system_proved_not_left_invertible_is_never_complete() -> None:
    # every path from {1, 2} to the monitor 5 passes through agent 3: one vertex-disjoint path for two inputs
    G = nx.Graph()
    G.add_weighted_edges_from([(1, 3, 1), (2, 3, 2), (3, 4, 1), (4, 5, 3), (1, 2, 1)])
    system = System(spec_from_graph(G, monitor_velocities=[5, 4]))
    c = zero_set_completeness(system, (1, 2))
    assert not c.complete
    assert "not left-invertible" in c.text
    assert not zda_analysis_exact(system, (1, 2)).left_invertible


def test_the_modular_count_bounds_the_exact_number_of_zeros_on_small_networks() -> None:
    # deg gcd mod p >= deg z, z the exact zero polynomial of the pencil in s (no quotient taken here)
    checked = 0
    for seed in range(8):
        system = System(random_clustered_spec(12, 2, seed=seed, modes=1, monitors=3))
        F = system.attacked
        ea = zda_analysis_exact(system, F)
        if not ea.left_invertible:
            continue
        x = flint.fmpq_poly([0, 1])
        text = re.sub(r"(\d+)/(\d+)", r"Q(\1, \2)", ea.s_zero_polynomial.replace("^", "**"))
        z = eval(text, {"x": x, "Q": flint.fmpq})  # the exact polynomial's own text
        ent = {k: -Fraction(system.alpha_q) * v for k, v in laplacian_entries(system, NORMAL_MODE).items()}
        cb = zero_count_bound_mod_p(system.n, ent, system.idx(F), system.idx(system.monitored))
        if cb.bound is not None:
            assert cb.bound >= (z.degree() if isinstance(z, flint.fmpq_poly) else 0)
            assert cb.left_invertible
            checked += 1
    assert checked >= 3


def test_a_small_member_of_the_realistic_family_is_decided_with_its_reason() -> None:
    # random_clustered_spec(200, 2, seed=7, modes=1) has two attack zeros at s = (-3 +- sqrt 5) / 2 that
    # the numeric deflation does not all find: the count must not close, and the note must say so
    system = System(random_clustered_spec(200, 2, seed=7, modes=1))
    v = decide_zda(system)
    assert v.completeness is not None
    assert not v.completeness.complete and not v.zeros_exact
    assert "2 zero(s) of unknown location" in v.completeness.text


def test_the_realistic_family_is_certified_where_its_zero_set_is_complete() -> None:
    # N = 1000: the only zeros of the pencil in s are eigenvalues of -alpha L_1 (a twin of an attacked
    # agent at s = -3, and the merged twins), so lambda0 = 0 is the rule's choice, exactly
    system = System(random_clustered_spec(1000, 10, seed=7, modes=1))
    c = zero_set_completeness(system, system.attacked)
    assert c.complete, c.text
    assert "zero set complete" in c.text


def test_a_numeric_full_rank_the_separator_disproves_gives_the_witness_at_lambda0_one() -> None:
    # random_clustered_spec(2000, 20, seed=7, modes=1): one vertex-disjoint path from F = {93, 79} to M,
    # while the deflation's rank decisions report full normal rank; the rule's witness is lambda0 = 1
    system = System(random_clustered_spec(2000, 20, seed=7, modes=1))
    v = decide_zda(system)
    assert v.status is Status.HOLDS
    assert v.left_invertible is False and v.screened
    assert v.growth == "unbounded"
    assert v.direction is not None and complex(v.direction.value) == 1
    assert v.lambda0_exact
    assert "vertex-disjoint" in v.proof


@pytest.mark.slow
def test_the_cluster_step_locates_the_zeros_the_count_finds_on_the_realistic_family() -> None:
    # random_clustered_spec(800, 8, seed=7, modes=1): the pencil in s has 180 zeros of unknown location;
    # the clusters P1 and P2 (outputs at their boundary agents) hold them all, every one decaying,
    # and the pencil beyond P2 has none
    system = System(random_clustered_spec(800, 8, seed=7, modes=1))
    c = zero_set_completeness(system, system.attacked)
    assert c.complete, c.text
    assert "located by the cluster of F" in c.text and "beyond P2" in c.text


@pytest.mark.parametrize("seed", range(8))
def test_the_monitors_quotient_reused_for_an_input_set_alone_in_its_cells_gives_the_count_of_the_refined_one(seed: int) -> None:
    import itertools
    import random

    from glocal_verify.analysis.stealthy.zda_completeness import _negative_axis_only, _quotient
    from glocal_verify.design.generators import adverse_clustered_spec

    system = System(adverse_clustered_spec(40, cluster_size=20, degree=3.5, measure="neighbours", modes=0, attack=False, seed=seed))
    lap, alpha = laplacian_entries(system, NORMAL_MODE), Fraction(system.alpha_q)
    M = system.idx(system.monitored)
    base = _quotient(system.n, lap, alpha, set(M))
    pairs = list(itertools.combinations(range(system.n), 2))
    random.Random(seed).shuffle(pairs)
    for F in pairs[:12]:
        with_base = _negative_axis_only(system.n, lap, alpha, list(F), M, "P", base)
        fresh = _negative_axis_only(system.n, lap, alpha, list(F), M, "P")
        assert (with_base.proven, with_base.states, with_base.merged, with_base.text) == (fresh.proven, fresh.states, fresh.merged, fresh.text)
