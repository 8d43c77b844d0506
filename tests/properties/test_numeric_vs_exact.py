"""Numeric and exact verdicts agree on random integer-weight systems (N <= 12).

A numeric ``holds`` that exact arithmetic calls ``fails`` (or the reverse) is a bug of the
highest priority; a numeric ``undecided`` is allowed but must be rare.
"""

from __future__ import annotations

from hypothesis import given
from strategies import assert_numeric_matches_exact, systems

from glocal_verify import System, verify
from glocal_verify.results import Status

FOUNDATION = ["privacy.connected", "privacy.kernel", "switching.image-kernel", "switching.distinct-eigenvalues", "switching.coverage"]


@given(systems(max_n=12))
def test_numeric_and_exact_verdicts_agree_on_integer_weight_graphs(system: System) -> None:
    assert_numeric_matches_exact(system, FOUNDATION)


@given(systems(max_n=12))
def test_image_kernel_implies_coverage_lemma_a2(system: System) -> None:
    rs = verify(system, ["switching.image-kernel", "switching.coverage"], exact=True).conditions
    ik = {r.scope["mode"]: r.status for r in rs if r.id == "switching.image-kernel"}
    cov = {r.scope["mode"]: r.status for r in rs if r.id == "switching.coverage"}
    for mode, st in ik.items():
        if st is Status.HOLDS:
            assert cov[mode] is Status.HOLDS
