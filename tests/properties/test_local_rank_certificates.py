"""Exact rank certificates of Proposition III.2 (iii) against exact arithmetic.

A reported local zero at a real s is proved by the rank of the reduced pencil over Q at the
nearest rational of small denominator; whatever the rounding, a rank below the column count
is a proof, so the exact analysis of the full pencil must agree.
"""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from glocal_verify import System
from glocal_verify.analysis.local.cases import certify_pencil_verdict, local_cases
from glocal_verify.analysis.local.pencil import pencil_verdict, pencil_verdict_exact
from glocal_verify.design.generators import random_clustered_spec
from glocal_verify.results import Status


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 10_000), st.sampled_from([24, 36]))
def test_a_local_zero_proved_by_the_rank_of_the_reduced_pencil_is_an_exact_zero(seed: int, n: int) -> None:
    s = System(random_clustered_spec(n, 2, seed=seed, modes=1))
    for case in local_cases(s):
        v = certify_pencil_verdict(s, case, pencil_verdict(s, case))
        if "T(s)" not in str((v.witness.get("certificate") or {}).get("by", "")):
            continue
        assert v.status is Status.FAILS
        exact = pencil_verdict_exact(System(s.spec), case, margin=False, method="dense")
        assert exact.status is Status.FAILS, (case.scope, exact.witness)


def test_seed_7_has_a_local_zero_at_s_minus_2_without_twins_that_the_rank_over_q_proves() -> None:
    s = System(random_clustered_spec(36, 2, seed=7, modes=1))
    case = next(c for c in local_cases(s) if c.scope["cluster"] == "P1" and c.scope["suspected"] == "attack")
    v = certify_pencil_verdict(s, case, pencil_verdict(s, case))
    assert v.status is Status.FAILS
    assert "at s = -2" in v.witness["certificate"]["by"]
    assert pencil_verdict_exact(System(s.spec), case, margin=False, method="dense").status is Status.FAILS
