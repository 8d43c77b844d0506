"""The structured family (identical copies, twin leaves, prime-square weights, broken symmetries)
and what it showed about ``stealthy.zda``."""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path

import pytest

from glocal_verify import System
from glocal_verify.analysis.laplacian.twins import laplacian_entries
from glocal_verify.analysis.stealthy.zda_screens import disjoint_paths
from glocal_verify.analysis.stealthy.zda_verdict import ZdaOptions, decide_zda
from glocal_verify.design.generators import structured_clustered_spec, structured_family
from glocal_verify.errors import SpecError
from glocal_verify.results import Status
from glocal_verify.spec.load import load_spec
from glocal_verify.spec.types import NORMAL_MODE


def _weights(system: System) -> dict[tuple[int, int], Fraction]:
    labels = system.labels
    return {(labels[i], labels[j]): -Fraction(w) for (i, j), w in laplacian_entries(system, NORMAL_MODE).items() if i < j and w != 0}


def test_the_copies_of_a_structured_network_are_identical_and_its_twin_leaves_share_their_parent_and_weight() -> None:
    spec = structured_clustered_spec(90, seed=5, clusters=3, cluster_size=15, twins=12, weights="prime30", join="ring", attack="across", attacked=3)
    system = System(spec)
    w = _weights(system)
    inside = [{(u - off, v - off): x for (u, v), x in w.items() if off <= u < off + 15 and off <= v < off + 15} for off in (2, 17, 32)]
    assert inside[0] == inside[1] == inside[2] and inside[0]
    leaves = range(47, 59)
    links = [[(e, x) for e, x in w.items() if t in e] for t in leaves]
    assert all(len(lk) == 1 for lk in links)
    assert len({(min(e) if max(e) == t else max(e), x) for t, lk in zip(leaves, links) for e, x in lk}) == 1
    assert Fraction(1073741789**2, 10**7) in set(w.values())
    assert set(spec.attack.actuators).isdisjoint(system.monitored)


def test_a_broken_symmetry_moves_exactly_one_weight_by_ten_to_the_minus_k() -> None:
    kw = dict(seed=2, clusters=2, cluster_size=15, twins=10, attack="twins", weights="prime24")
    exact, broken = _weights(System(structured_clustered_spec(60, **kw))), _weights(System(structured_clustered_spec(60, breaking=13, **kw)))
    moved = [e for e in exact if exact[e] != broken[e]]
    assert len(moved) == 1 and broken[moved[0]] == exact[moved[0]] * (1 + Fraction(1, 10**13))


def test_the_structured_family_spans_every_join_attack_and_monitor_kind_and_scales_down_below_sixty_agents() -> None:
    members = structured_family(150, 40) + structured_family(30, 20)
    assert {m.join for m in members} == {"hub", "ring", "asymmetric"}
    assert {m.attack for m in members} == {"inside", "across", "twins"}
    assert {m.monitors for m in members} == {"velocities", "positions", "both"}
    assert {m.weights for m in members} == {"small", "prime24", "prime30"}
    for m in members:
        assert System(m.spec()).n == m.n
        assert (2 <= m.clusters <= 4 and 15 <= m.cluster_size <= 50 and 10 <= m.twins <= 40) if m.n >= 60 else m.cluster_size >= 3


@pytest.mark.parametrize(("kw", "path"), [
    ({"clusters": 3, "cluster_size": 30}, "n"), ({"join": "star"}, "join"), ({"breaking": 4}, "breaking"),
    ({"attack": "across", "attacked": 3, "clusters": 2}, "attacked"), ({"weights": "primes"}, "weights"),
])
def test_structured_arguments_outside_their_domain_are_refused_naming_the_argument(kw: dict[str, object], path: str) -> None:
    with pytest.raises(SpecError) as err:
        structured_clustered_spec(60, **kw)  # type: ignore[arg-type]
    assert err.value.path == path


def test_a_separator_proves_the_zda_the_deflation_missed_on_identical_copies_with_prime_square_weights() -> None:
    system = System(load_spec(Path(__file__).parent / "data" / "structured-separator-missed-by-deflation.toml"))
    F = system.attacked
    v = decide_zda(system)
    assert v.numeric_analysis is not None and not v.numeric_analysis.exists  # the point of the example: the deflation decided 'fails'
    assert disjoint_paths(system, F) < len(F)  # ... where fewer disjoint paths than attackers prove a ZDA at every lambda0
    assert v.status is Status.HOLDS and v.left_invertible is False and v.growth == "unbounded"
    assert "vertex-disjoint path" in v.proof and v.note.startswith("the numeric zero set missed it")
    assert v.direction is None or complex(v.direction.value) == 1


def test_identical_copies_broken_by_one_part_in_a_billion_get_no_numeric_zda_verdict_that_exact_arithmetic_refutes() -> None:
    # a gap of the structured family (bench_structured): the numeric zero set says 'fails' but no
    # certificate proves it; exact arithmetic decides it in about a second
    system = System(load_spec(Path(__file__).parent / "data" / "structured-broken-copies-undecided.toml"))
    exact = decide_zda(system, options=ZdaOptions(exact=True))
    assert exact.status is Status.FAILS
    assert decide_zda(system).status in (Status.UNDECIDED, Status.FAILS)
