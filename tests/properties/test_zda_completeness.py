"""The completeness proof of the ZDA zero set (analysis.stealthy.zda_completeness) against exact arithmetic.

``complete`` claims that every invariant zero lambda != 0 of (A_1, B_F, C) has Re lambda < 0
and that the system is left-invertible. The exact analysis over Q (python-flint) lists every
zero; a claim it contradicts is a soundness bug. Not concluding is always allowed.
"""

from __future__ import annotations

from hypothesis import example, given, settings
from hypothesis import strategies as st
from strategies import assert_completeness_sound, clustered_systems, faster_zero_system, systems

from glocal_verify import System


@example(system=faster_zero_system()[0], data=None)  # type: ignore[arg-type]
@settings(deadline=None)
@given(systems(max_n=12), st.data())
def test_the_certificate_never_claims_completeness_when_an_exact_analysis_finds_a_zero_it_did_not_count(system: System, data: st.DataObject) -> None:
    labels = list(system.labels)
    if data is None:
        F = faster_zero_system()[1]
    else:
        F = tuple(data.draw(st.lists(st.sampled_from(labels), unique=True, min_size=1, max_size=min(3, len(labels))), label="F"))
    if not system.monitored:
        return
    assert_completeness_sound(system, F)


@settings(deadline=None)
@given(clustered_systems(max_n=14))
def test_the_cluster_step_never_claims_completeness_that_exact_arithmetic_contradicts(system: System) -> None:
    if len(system.attacked) > len(system.monitored):
        return
    assert_completeness_sound(system, system.attacked)
