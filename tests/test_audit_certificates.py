"""Exact shortcuts of the audit and the checkers: twin modes and maximal minors modulo a prime.

Each shortcut must give the answer of the full analysis it replaces: the audit with the minor
certificate against the audit without it and against exact arithmetic, the twin-mode verdicts
against the definition (an exact eigenvector with the stated entries).
"""

from __future__ import annotations

import pytest

from fractions import Fraction
from typing import Any

from hypothesis import given, settings
from hypothesis import strategies as st

from glocal_verify import System, verify
from glocal_verify.analysis.local.cases import LocalCase, twin_failure
from glocal_verify.design.audit import audit
from glocal_verify.results import Status
from glocal_verify.spec import load_example
from glocal_verify.spec.load import spec_from_dict

from strategies import clustered_systems


def _key(audit_result: Any) -> dict[tuple[Any, ...], tuple[Any, ...]]:
    return {r.actuators: (r.stealthy, r.growth, r.verdict, r.caught_locally_by, r.exposed_by_modes) for r in audit_result.rows}


@pytest.mark.slow
def test_the_minor_certificate_leaves_every_paper19_row_as_the_full_analysis_gives_it() -> None:
    system = System(load_example("paper19"))
    fast = audit(system, 2)
    slow = audit(System(load_example("paper19")), 2, screen=False)
    assert _key(fast) == _key(slow)


@settings(max_examples=8, deadline=None)
@given(clustered_systems(max_n=8))
def test_audit_rows_with_certificates_agree_with_the_full_and_the_exact_analysis(system: System) -> None:
    fast = audit(system, 2)
    slow = audit(System(system.spec), 2, screen=False)
    exact = audit(System(system.spec), 2, exact=True)
    kf, ks, ke = _key(fast), _key(slow), _key(exact)
    for F, row in kf.items():
        if row[2] != "undecided" and ks[F][2] != "undecided":
            assert row == ks[F], F
        if row[0] is not None:
            assert row[0] == ke[F][0], F  # stealthy, decided, agrees with exact arithmetic
        if row[2] != "undecided":
            assert row[2] == ke[F][2], F


def _twin_spec(extra_modes: list[dict[str, Any]] | None = None) -> System:
    # cluster P1: centre 5 - 1 - {2, 3} (twin leaves on 1) and 4 on 5; cluster P2: 6 - 7 - 8
    data = {
        "format": 1,
        "name": "twins",
        "graph": {"nodes": 8, "edges": [[5, 1, 1], [1, 2, 2], [1, 3, 2], [5, 4, 1], [4, 6, 1], [6, 7, 1], [7, 8, 1]]},
        "clusters": [
            {"name": "P1", "nodes": [1, 2, 3, 4, 5], "observers": [{"center": 5}]},
            {"name": "P2", "nodes": [6, 7, 8], "observers": [{"center": 7}]},
        ],
        "monitor": {"velocities": [5, 7]},
        "attack": {"kind": "zda", "actuators": [4]},
        "modes": extra_modes or [],
    }
    return System(spec_from_dict(data))


def test_unmeasured_twin_agents_make_the_local_pencil_fail_in_exact_arithmetic_too() -> None:
    system = _twin_spec()
    cm = system.cluster_model("P1")
    obs = system.observers("P1")[0]
    assert 2 not in obs.positions + obs.velocities and 3 not in obs.positions + obs.velocities
    proof = twin_failure(system, LocalCase(cm, obs, "attack", (4,)))
    assert proof is not None and "2" in proof and "3" in proof
    numeric = [r for r in verify(system, ["local.pencil"]).conditions if r.scope.get("cluster") == "P1"]
    exact = [r for r in verify(system, ["local.pencil"], exact=True).conditions if r.scope.get("cluster") == "P1"]
    assert numeric and all(r.status is Status.FAILS for r in numeric)
    assert exact and all(r.status is Status.FAILS for r in exact)


@given(st.sampled_from([[6, 8, 1], [4, 7, 2]]))
@settings(max_examples=2, deadline=None)
def test_twin_agents_off_the_switching_pair_make_theorem_iii3_iii_fail_with_an_exact_eigenvector(link: list[int]) -> None:
    system = _twin_spec([{"name": "safe", "add": [link]}])
    for exact in (False, True):
        (res,) = verify(system, ["switching.eigenvector-differences"], exact=exact).conditions
        assert res.status is Status.FAILS
        v = res.witness.get("eigenvector_exact")
        if v is None:
            continue  # the exact path found another failing eigenvector
        L = system.laplacian_exact("safe")
        vec = [Fraction(v.get(a, 0)) for a in system.labels]
        Lv = [sum(L[i][j] * vec[j] for j in range(system.n)) for i in range(system.n)]
        mu = Fraction(res.witness["eigenvalue_exact"])
        assert Lv == [mu * x for x in vec]
        i, j = (system.index[a] for a in res.witness["pair"])
        assert vec[i] == vec[j]


def test_the_lazy_exact_fallback_gives_the_verdicts_of_the_full_one() -> None:
    from glocal_verify.design.generators import random_clustered_spec

    # N = 32 (default "verdicts"). A wide undecided band (rtol 1e-9, band 1e7) makes the
    # growth of agent 26's zeros undecided numerically on every machine (with the default band
    # it depends on the last bits of the eigendecomposition). The lazy fallback re-decides over
    # Q only the rows whose verdict needs it (a local catch alone no longer decides a row: the
    # switch must expose the attack too); the verdicts must be those of the full fallback
    from glocal_verify.numerics.tolerance import Tolerance

    s = System(random_clustered_spec(32, 3, seed=7))
    tol = Tolerance(1e-9, 1e7)
    lazy = audit(s, 2, candidates=[26, 1, 2], tol=tol)
    full = audit(s, 2, candidates=[26, 1, 2], exact_fallback=True, tol=tol)
    assert {r.actuators: r.verdict for r in lazy.rows} == {r.actuators: r.verdict for r in full.rows}
    assert all(r.verdict != "undecided" for r in lazy.rows)
    assert all(r.growth != "undecided" for r in full.rows)
