"""Multi-link safe modes: when no one-link change exposes an attack, two links may.

The six-agent network below (found by a search over ``random_clustered_spec`` networks,
written out so that it does not depend on the generator) has a stealthy ZDA on agent 3 that
no admissible one-link change exposes: the exact checkers reject every default candidate.
The design then proposes a two-link mode, and every designed mode is re-checked with
``glocal_verify.verify`` on the designed spec, exactly.
"""

from __future__ import annotations

import itertools
from fractions import Fraction
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from glocal_verify import verify
from glocal_verify.design.audit import audit
from glocal_verify.design.generators import random_clustered_spec
from glocal_verify.design.multilink import (
    image_kernel_holds,
    link_forest,
    screen_changes,
)
from glocal_verify.design.safe_modes import (
    LinkCandidate,
    ProposedMode,
    SafeModeDesign,
    default_candidates,
    design_safe_modes,
    with_attack,
    with_modes,
)
from glocal_verify.errors import GlocalVerifyError
from glocal_verify.model import System
from glocal_verify.results import Status
from glocal_verify.spec import loads_spec

THEOREM = ["switching.image-kernel", "switching.distinct-eigenvalues", "switching.eigenvector-differences"]

SIX = """
format = 1
name = "two-links-needed"

[dynamics]
alpha = 1
gamma = 1

[graph]
nodes = 6
edges = [[1, 3], [2, 3], [2, 6], [3, 6], [4, 5, 2], [5, 6, 3]]

[[clusters]]
name = "P1"
nodes = [1, 2, 3]
[[clusters.observers]]
center = 2
positions = [2, 3]
velocities = [2, 3]

[[clusters]]
name = "P2"
nodes = [4, 5, 6]
[[clusters.observers]]
center = 6
positions = [5, 6]
velocities = [5, 6]

[monitor]
positions = []
velocities = [2, 6]
"""


@pytest.fixture(scope="module")
def six() -> System:
    return System(loads_spec(SIX))


@pytest.fixture(scope="module")
def stealthy(six: System) -> tuple[list[tuple[Any, ...]], dict[tuple[Any, ...], complex]]:
    res = audit(six, 1)
    sets = [r.actuators for r in res.rows if r.stealthy]
    return sets, {r.actuators: r.lambda0 for r in res.rows if r.lambda0 is not None}


@pytest.fixture(scope="module")
def design(six: System, stealthy: tuple[list[tuple[Any, ...]], dict[tuple[Any, ...], complex]]) -> SafeModeDesign:
    sets, lam = stealthy
    return design_safe_modes(six, sets, None, 4, lambdas=lam, exact=True)


def _exposes(system: System, mode: ProposedMode, F: tuple[Any, ...]) -> bool:
    """The exact checkers: (i)-(iii) hold for the mode and the switch touches every stealthy direction of F."""
    sub = System(with_attack(with_modes(system.spec, [mode.mode_spec()], keep=False), F))
    rep = verify(sub, THEOREM + ["switching.avoids-attack"], exact=True)
    theorem = all(r.status is Status.HOLDS for r in rep.conditions if r.id in THEOREM)
    return theorem and [r.status for r in rep.results("switching.avoids-attack")] == [Status.FAILS]


def test_no_one_link_change_exposes_the_attack_on_agent_3(six: System, stealthy: tuple[list[tuple[Any, ...]], dict[tuple[Any, ...], complex]]) -> None:
    assert (3,) in stealthy[0]
    for c in default_candidates(six):
        assert not _exposes(six, ProposedMode("m", c, ()), (3,)), c.describe()


def test_one_link_design_leaves_agent_3_exposed_to_nobody(six: System, stealthy: tuple[list[tuple[Any, ...]], dict[tuple[Any, ...], complex]]) -> None:
    sets, lam = stealthy
    d = design_safe_modes(six, sets, None, 4, lambdas=lam, exact=True, max_links=1)
    assert "3" in d.unexposed and d.combinations == 0


def test_a_two_link_mode_exposes_the_attack_no_one_link_mode_exposes(design: SafeModeDesign) -> None:
    assert design.complete, design.unexposed
    multi = [m for m in design.modes if len(m.links) > 1]
    assert multi and all(len(m.links) == 2 for m in multi)
    assert any((3,) in m.exposes for m in multi)
    assert design.combinations > 0 and design.combinations_per_second > 0 and design.screened > 0
    assert design.evaluations_per_second > 0


def test_every_designed_mode_meets_its_claims_on_the_designed_spec(six: System, design: SafeModeDesign) -> None:
    spec = with_modes(six.spec, [m.mode_spec() for m in design.modes], keep=False)
    for m in design.modes:
        assert m.exposes
        for F in m.exposes:
            rep = verify(System(with_attack(spec, F)), THEOREM + ["switching.avoids-attack"], exact=True)
            for r in rep.conditions:
                if r.scope.get("mode") != m.name:
                    continue
                expected = Status.FAILS if r.id == "switching.avoids-attack" else Status.HOLDS
                assert r.status is expected, (m.describe(), F, r.id, r.status)


def test_a_two_link_mode_spec_adds_and_removes_every_link(six: System) -> None:
    add, rem = LinkCandidate(1, 2, Fraction(2)), LinkCandidate(2, 3, Fraction(1), True)
    ms = ProposedMode("m", add, (), also=(rem,)).mode_spec()
    assert [(e.u, e.v, e.weight) for e in ms.add] == [(1, 2, 2)] and list(ms.remove) == [(2, 3)]
    assert "add 1-2 (w=2) + remove 2-3" in ms.description


def test_the_low_rank_screen_agrees_with_a_fresh_eigendecomposition(six: System) -> None:
    L = np.asarray(six.laplacian(), dtype=float)
    U, w1 = np.asarray(six.spectrum().vectors), np.asarray(six.spectrum().values)
    changes, expected = [], []
    for a, b in itertools.combinations(default_candidates(six), 2):
        pairs = [(six.index[c.u], six.index[c.v]) for c in (a, b)]
        comps = link_forest(pairs)
        if comps is None:
            continue
        deltas = [-float(c.weight) if c.remove else float(c.weight) for c in (a, b)]
        Lq = L.copy()
        for (i, j), dl in zip(pairs, deltas):
            e = np.zeros(six.n)
            e[i], e[j] = 1.0, -1.0
            Lq += dl * np.outer(e, e)
        w, V = np.linalg.eigh(Lq)
        ok = bool(w[1] > 1e-6 and np.all(np.diff(w) > 1e-6))
        ok = ok and all(np.all(np.abs(V[i, 1:] - V[j, 1:]) > 1e-6) for comp in comps for i, j in itertools.combinations(comp, 2))
        changes.append((pairs, deltas))
        expected.append(ok)
    got = screen_changes(U, w1, changes)
    assert list(got) == expected
    assert set(expected) == {True, False}


def _laplacian(n: int, edges: list[tuple[int, int, float]]) -> np.ndarray:
    L = np.zeros((n, n))
    for i, j, w in edges:
        e = np.zeros(n)
        e[i], e[j] = 1.0, -1.0
        L += w * np.outer(e, e)
    return L


def test_a_second_link_repairs_the_eigenvector_the_first_link_leaves_in_place() -> None:
    """Path 1-2-3-4-5 with weights 1, 2, 2, 1: the symmetric eigenvectors have u(1) = u(5), so the
    link 1-5 deflates them and (iii) fails for it; a second link 3-5 breaks the symmetry."""
    L = _laplacian(5, [(0, 1, 1.0), (1, 2, 2.0), (2, 3, 2.0), (3, 4, 1.0)])
    w, U = np.linalg.eigh(L)
    assert np.isclose(U[0, 2], U[4, 2])  # a symmetric eigenvector: z_3 = 0 for the link 1-5
    one = screen_changes(U, w, [([(0, 4)], [1.0])])
    two = screen_changes(U, w, [([(0, 4), (2, 4)], [1.0, 1.0])])
    wq, V = np.linalg.eigh(L + _laplacian(5, [(0, 4, 1.0), (2, 4, 1.0)]))
    assert np.all(np.diff(wq) > 1e-6) and all(np.all(np.abs(V[i, 1:] - V[j, 1:]) > 1e-6) for i, j in itertools.combinations([0, 2, 4], 2))
    assert not one[0] and two[0]


def test_image_kernel_needs_as_many_monitored_agents_as_links_in_a_component() -> None:
    assert image_kernel_holds([(0, 1), (1, 2)], {0, 2})
    assert not image_kernel_holds([(0, 1), (1, 2)], {1})
    assert image_kernel_holds([(0, 1), (2, 3)], {1, 2}) and not image_kernel_holds([(0, 1), (2, 3)], {0, 1})
    assert link_forest([(0, 1), (1, 0)]) is None and link_forest([(0, 1), (1, 2), (2, 0)]) is None


@settings(max_examples=3)
@given(st.integers(6, 8), st.integers(0, 10_000))
def test_multi_link_modes_on_random_networks_are_confirmed_by_the_exact_checkers(n: int, seed: int) -> None:
    system = System(random_clustered_spec(n, 2, seed=seed, monitors=2, modes=1, max_weight=3, attack=False))
    res = audit(system, 1)
    sets = [r.actuators for r in res.rows if r.stealthy]
    if not sets:
        return
    d = design_safe_modes(system, sets, None, 3, lambdas={r.actuators: r.lambda0 for r in res.rows if r.lambda0 is not None}, exact=True)
    for m in d.modes:
        for F in m.exposes:
            assert _exposes(system, m, F), (m.describe(), F)
    for F in sets:
        assert any(F in m.exposes for m in d.modes) or ",".join(map(str, F)) in d.unexposed


def test_max_links_below_one_is_refused(six: System) -> None:
    with pytest.raises(GlocalVerifyError, match="max_links"):
        design_safe_modes(six, [(3,)], None, 1, lambdas={(3,): -0.5 + 0.5j}, max_links=0)
