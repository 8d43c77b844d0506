"""Design on symmetric networks: modes that break a repeated spectrum, and every change earns its place."""

from __future__ import annotations

import os
from fractions import Fraction
from typing import Any

import pytest

from glocal_verify.conditions.registry import check_conditions
from glocal_verify.design.audit import audit
from glocal_verify.design.generators import symmetric_clusters_spec
from glocal_verify.design.network import NetworkDesign, design_network
from glocal_verify.design.pruning import RANK
from glocal_verify.design.one_link import one_link_screen as _screen
from glocal_verify.design.safe_modes import LinkCandidate, _admissible, default_candidates, design_safe_modes, eigenvector_error
from glocal_verify.design.symmetry import exact_multiplicity, symmetry_obstacle
from glocal_verify.model import System
from glocal_verify.results import Status
from glocal_verify.spec import load_example, loads_spec

THEOREM = ["switching.image-kernel", "switching.distinct-eigenvalues", "switching.eigenvector-differences"]
FUZZ = os.environ.get("GLOCAL_PROFILE") == "fuzz"

#: three copies of K4 joined in a ring, unit weights, one observer per cluster (its
#: neighbours), a velocity monitor per cluster and a ZDA on the twins 3, 4: L_1 has the
#: eigenvalue 4 six times and two more eigenvalues twice (the rotation of the ring)
SYM12 = """
format = 1
name = "sym12"
[graph]
nodes = 12
edges = [
  [1, 2], [1, 3], [1, 4], [2, 3], [2, 4], [3, 4],
  [5, 6], [5, 7], [5, 8], [6, 7], [6, 8], [7, 8],
  [9, 10], [9, 11], [9, 12], [10, 11], [10, 12], [11, 12],
  [2, 5], [6, 9], [10, 1],
]
[[clusters]]
name = "P1"
nodes = [1, 2, 3, 4]
[[clusters.observers]]
center = 1
[[clusters]]
name = "P2"
nodes = [5, 6, 7, 8]
[[clusters.observers]]
center = 5
[[clusters]]
name = "P3"
nodes = [9, 10, 11, 12]
[[clusters.observers]]
center = 9
[monitor]
velocities = [1, 5, 9]
[attack]
kind = "zda"
actuators = [3, 4]
[simulation]
horizon = 30.0
"""


@pytest.fixture(scope="module")
def sym12() -> System:
    return System(loads_spec(SYM12, "sym12.toml"))


@pytest.fixture(scope="module")
def designed(sym12: System) -> NetworkDesign:
    return design_network(sym12, max_attackers=2)


def _theorem_holds_exactly(spec: Any) -> None:
    """verify --exact of Theorem III.3 (i)-(iii): every safe mode holds."""
    rep = check_conditions(System(spec), THEOREM, exact=True)
    assert {r.status for r in rep.conditions} <= {Status.HOLDS}


def test_the_symmetric_twelve_agent_network_is_designed_with_no_undetected_attacker(sym12: System, designed: NetworkDesign) -> None:
    assert exact_multiplicity(sym12) == 6
    before = designed.before.summary()["counts"]
    after = designed.after.summary()["counts"]
    assert before["undetected"] > 0 and after["undetected"] == 0 and after["undecided"] == 0
    assert designed.summary()[0] == f"undetected {before['undetected']} -> 0 of 78 attack sets"
    assert not designed.unmet
    _theorem_holds_exactly(designed.spec)
    # the mode that breaks the symmetry changes as many links as the multiplicity asks
    assert max(len(System(designed.spec).switching_links(q)) for q in designed.spec.mode_names[1:]) >= 6


def test_the_designed_schedule_fits_the_horizon(designed: NetworkDesign) -> None:
    sw = designed.spec.switching
    if sw is not None:
        assert sum(st.duration for st in sw.sequence) <= designed.spec.simulation.horizon + 1e-9


def test_every_change_names_the_sets_it_moves_and_removing_it_makes_the_audit_worse(designed: NetworkDesign) -> None:
    after = {r.actuators: r.verdict for r in designed.after.rows}
    assert designed.changes
    for k, change in enumerate(designed.changes):
        if change.action == "moved":  # privacy, not detection
            continue
        assert change.moved, change.subject
        assert "moves" in change.text()
        rows = {r.actuators: r.verdict for r in audit(System(designed.without(k)), 2).rows}
        fell = [F for F in change.moved if RANK[rows[F]] < RANK[after[F]]]
        assert fell, change.subject


def test_no_observer_or_monitor_that_moves_nothing_is_kept(designed: NetworkDesign) -> None:
    kinds = [c.kind for c in designed.changes]
    assert all(c.moved for c in designed.changes if c.kind in ("observer", "monitor") and c.action == "added")
    assert kinds.count("monitor") <= 3


def test_the_interlacing_bound_proves_that_no_mode_exists_with_too_few_monitors(sym12: System) -> None:
    import dataclasses

    from glocal_verify.spec.types import MonitorSpec

    one = System(dataclasses.replace(sym12.spec, monitor=MonitorSpec((), (1,))))
    why = symmetry_obstacle(one, monitor_room=2, max_links=None)
    assert why.startswith("proven") and "multiplicity 6" in why and "rank(dL_q) >= 5" in why
    assert symmetry_obstacle(sym12, monitor_room=3, max_links=None) == ""
    assert "6 monitored agents" in symmetry_obstacle(sym12, monitor_room=2, max_links=None)  # (iii) within the options
    assert symmetry_obstacle(sym12, monitor_room=3, max_links=1).startswith("proven")
    rows = audit(one, 2, [3, 4])
    targets = [r.actuators for r in rows.rows if r.verdict == "undetected"]
    lam = {r.actuators: r.lambda0 for r in rows.rows if r.lambda0 is not None}
    d = design_safe_modes(one, targets, None, 2, lambdas=lam, monitor_room=2)
    assert not d.modes and all("proven" in why for why in d.unexposed.values())


def test_the_one_link_screen_only_filters_and_the_rule_functions_admit(monkeypatch: pytest.MonkeyPatch) -> None:
    import glocal_verify.design.safe_modes as sm

    paper19 = System(load_example("paper19"))
    cands = [c for c in default_candidates(paper19, (Fraction(1),)) if not c.remove][:40]
    err = eigenvector_error(paper19)
    screened = _screen(paper19, cands, err)
    admitted = _admissible(paper19, cands, err)
    assert admitted.any() and not (admitted & ~screened).any()
    # every "yes" is the rule functions': when they say no, nothing is admitted
    monkeypatch.setattr(sm, "theorem_verdicts", lambda system, mode: {"switching.image-kernel": Status.UNDECIDED})
    assert not _admissible(paper19, cands, err).any()


def test_a_reweighted_link_is_written_as_a_removal_and_an_addition(sym12: System) -> None:
    from glocal_verify.design.safe_modes import ProposedMode

    m = ProposedMode("m", LinkCandidate(1, 2, Fraction(5, 2), False, Fraction(1)), ()).mode_spec()
    assert m.remove == ((1, 2),) and m.add[0].weight == Fraction(5, 2)
    from glocal_verify.design.safe_modes import with_modes

    assert System(with_modes(sym12.spec, [m])).edges("m")[frozenset((1, 2))] == Fraction(5, 2)


def test_changing_the_normal_weights_is_an_option_that_says_what_it_changed(sym12: System) -> None:
    d = design_network(sym12, max_attackers=1, normal_weights=True, place=False)
    assert any("certified simple" in n for n in d.notes)
    assert d.after.summary()["counts"]["undetected"] == 0


def _generated_case(n: int, clusters: int, seed: int, degree: float) -> None:
    spec = symmetric_clusters_spec(n, clusters, seed=seed, degree=degree)
    d = design_network(System(spec), max_attackers=2, place=False)
    after = {r.actuators: r.verdict for r in d.after.rows}
    if any(v == "undetected" for F, v in after.items() if len(F) == 1):  # every single attacker detected, or the obstacle proven
        assert any("proven" in u for u in d.unmet), d.summary()
    if any(v == "undetected" for v in after.values()):
        assert d.unmet, d.summary()
    _theorem_holds_exactly(d.spec)  # every designed mode passes verify --exact of Theorem III.3 (i)-(iii)


@pytest.mark.parametrize("n, clusters, seed, degree", [(12, 3, 0, 3.0), (15, 3, 2, 2.5), (16, 4, 1, 2.5)])
def test_generated_symmetric_networks_are_designed_or_proven_impossible(n: int, clusters: int, seed: int, degree: float) -> None:
    _generated_case(n, clusters, seed, degree)


@pytest.mark.skipif(not FUZZ, reason="20 networks, minutes: GLOCAL_PROFILE=fuzz")
@pytest.mark.parametrize("seed", range(20))
def test_twenty_generated_symmetric_networks_are_designed_or_proven_impossible(seed: int) -> None:
    n, clusters = [(12, 3), (15, 3), (16, 4), (18, 3), (20, 4)][seed % 5]
    _generated_case(n, clusters, seed, 2.0 + (seed % 3) * 0.5)
