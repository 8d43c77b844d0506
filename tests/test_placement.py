"""Observer placement: proposals verified by the checkers, minimality, bad requests."""

from __future__ import annotations

import dataclasses
import itertools
import tomllib

import pytest

from glocal_verify import NotApplicableError, System, load_example, verify
from glocal_verify.analysis.local.cases import LocalCase
from glocal_verify.cli import main
from glocal_verify.analysis.local.pencil import pencil_verdict
from glocal_verify.design.generators import random_clustered_spec
from glocal_verify.design.placement import (
    Placement,
    place_observers,
    zero_forcing_closure,
)
from glocal_verify.model import LocalObserver
from glocal_verify.results import Status
from glocal_verify.spec.types import ClusterSpec, ObserverSpec


@pytest.fixture(scope="module")
def paper19() -> System:
    return System(load_example("paper19"))


def _with_placement(system: System, placement: Placement) -> System:
    """The system with each cluster's observers replaced by the proposal."""
    props = {p.cluster: p for p in placement.proposals}
    clusters = []
    for c in system.clusters:
        p = props.get(c.name)
        obs = (ObserverSpec(p.center, p.measured, p.measured),) if p else c.observers
        clusters.append(ClusterSpec(c.name, c.nodes, obs))
    return System(dataclasses.replace(system.spec, clusters=tuple(clusters)))


@pytest.mark.parametrize("exact", [False, True])
def test_the_paper19_placement_meets_ii_iii_and_the_uio_for_the_attack(paper19: System, exact: bool) -> None:
    pl = place_observers(paper19, progress=False)
    assert [p.cluster for p in pl.proposals] == ["P1", "P2", "P3"]
    placed = _with_placement(paper19, pl)
    rep = verify(placed, ["local.rank", "local.pencil", "local.uio"], exact=exact)
    attack = [r for r in rep.conditions if r.scope["suspected"] == "attack"]
    assert len(attack) == 9
    assert all(r.status is Status.HOLDS for r in attack), [(r.id, r.scope, r.witness) for r in attack if not r.holds]
    for p in pl.proposals:
        assert set(p.boundary) <= set(p.measured)
        assert all(v == "holds" for v in p.verification.values())


def test_the_p1_placement_is_minimal_by_brute_force(paper19: System) -> None:
    pl = place_observers(paper19, "P1", progress=False)
    (p,) = pl.proposals
    assert p.optimal and p.suspected == (3, 4)
    cm = paper19.cluster_model("P1")
    others = [a for a in cm.nodes if a != 7]
    for k in range(len(p.measured) - 1):
        for extra in itertools.combinations(others, k):
            m = (7,) + extra
            case = LocalCase(cm, LocalObserver("P1", 7, m, m), "attack", (3, 4))
            assert pencil_verdict(paper19, case, margin=False).status is not Status.HOLDS, m


def test_the_toml_fragment_parses_and_names_the_measured_sets(paper19: System) -> None:
    pl = place_observers(paper19, progress=False)
    doc = tomllib.loads(pl.to_toml())
    assert [c["name"] for c in doc["clusters"]] == ["P1", "P2", "P3"]
    for c, p in zip(doc["clusters"], pl.proposals):
        (o,) = c["observers"]
        assert o["center"] == p.center and o["positions"] == list(p.measured) == o["velocities"]
        assert c["nodes"] == list(paper19.cluster(p.cluster).nodes)


def test_place_observers_cli_prints_the_fragment(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["place-observers", "--example", "paper19", "--cluster", "P2", "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "[[clusters.observers]]" in out and 'name = "P2"' in out and "P1" not in out.split("\n", 2)[2]


def test_suspecting_a_boundary_agent_is_a_bad_request_with_the_reason(paper19: System, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(NotApplicableError, match="7 is on the boundary"):
        place_observers(paper19, "P1", "all", progress=False)
    assert main(["place-observers", "--example", "paper19", "--suspected", "all", "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "cannot be covered" in err[0] and "7-8" in err[0]
    assert main(["place-observers", "--example", "paper19", "--suspected", "3,99", "--quiet"]) == 2
    assert "99" in capsys.readouterr().err


def test_the_interior_worst_case_is_placeable_and_verified(paper19: System) -> None:
    pl = place_observers(paper19, "P2", "interior", progress=False)
    (p,) = pl.proposals
    assert p.suspected == (9, 10, 11)
    assert all(v == "holds" for v in p.verification.values())


def test_zero_forcing_forces_along_a_path_from_a_measured_end() -> None:
    nbrs = [[1], [0, 2], [1, 3], [2]]
    assert zero_forcing_closure(nbrs, {0}, []) == {0, 1, 2, 3}
    # an input row cannot force: agent 0 carries an unknown input
    assert zero_forcing_closure(nbrs, {0}, [0]) == {0}
    # a star centre with three unknown leaves forces nothing
    star = [[1, 2, 3], [0], [0], [0]]
    assert zero_forcing_closure(star, {0}, []) == {0}


@pytest.mark.parametrize("seed", [1])
def test_random_200_agent_networks_get_a_verified_placement_for_every_cluster(seed: int) -> None:
    spec = random_clustered_spec(200, 4, seed=seed)
    system = System(spec)
    # an attacked boundary agent would make the request impossible; keep the attack inside
    bad = [a for c in system.clusters for a in system.cluster_model(c.name).boundary if a in system.attacked]
    suspected: object = "attack" if not bad else tuple(a for a in system.attacked if a not in bad)
    pl = place_observers(system, suspected=suspected, exact_limit=0, progress=False)  # type: ignore[arg-type]
    assert len(pl.proposals) == 4
    for p in pl.proposals:
        assert all(v == "holds" for v in p.verification.values()), (p.cluster, p.verification)
        assert len(p.measured) >= p.lower_bound and set(p.boundary) <= set(p.measured)
        assert len(p.measured) < len(system.cluster(p.cluster).nodes)


def test_placement_and_the_local_checker_share_one_zero_forcing_and_reduced_pencil() -> None:
    import glocal_verify.analysis.local.cluster_pencil as cp
    import glocal_verify.design.placement as pl

    assert pl.zero_forcing_closure is cp.zero_forcing_closure
    assert pl.reduced_pencil_holds is cp.reduced_pencil_holds
