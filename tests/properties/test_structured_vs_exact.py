"""Never a wrong verdict on the structured family: numeric ``stealthy.zda`` against exact arithmetic at N <= 60.

Members of :func:`glocal_verify.design.generators.structured_family` (identical copies, twin
leaves, weights p^2 / 10^6 or p^2 / 10^7, symmetries broken by 10^-9..10^-15, position or velocity
monitors, a ZDA inside a copy, across copies or on twins), scaled down. A decided numeric
verdict must be the exact one (``ZdaOptions(exact=True)``). The exact reference of a pencil that
is not left-invertible runs the dense V* iteration over Q (minutes at N = 40): such members are
drawn at N <= 24.
"""

from __future__ import annotations

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from glocal_verify import System
from glocal_verify.analysis.stealthy.zda_exact import has_fast_exact_path
from glocal_verify.analysis.stealthy.zda_verdict import ZdaOptions, decide_zda
from glocal_verify.design.generators import structured_family
from glocal_verify.results import Status


@st.composite
def structured_members(draw: st.DrawFn, max_n: int = 60) -> System:
    seed = draw(st.integers(0, 10_000))
    system = System(structured_family(draw(st.integers(24, max_n)), 1, seed=seed)[0].spec())
    if not has_fast_exact_path(system):
        system = System(structured_family(draw(st.integers(12, 24)), 1, seed=seed)[0].spec())
    return system


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(structured_members())
def test_a_decided_numeric_zda_verdict_on_a_structured_member_is_the_exact_one(system: System) -> None:
    numeric = decide_zda(system)
    exact = decide_zda(system, options=ZdaOptions(exact=True))
    if numeric.status is not Status.UNDECIDED:
        assert numeric.status is exact.status, (system.spec.name, numeric.proof, numeric.note)
    if numeric.left_invertible is not None:
        assert numeric.left_invertible == exact.left_invertible, (system.spec.name, numeric.proof)
