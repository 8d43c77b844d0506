"""The generic support of the exact ZDA matrix is the same with and without forming its rows."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from glocal_verify import System
from glocal_verify.analysis.stealthy.zda_certificate import exact_q_pattern, exact_q_rows
from glocal_verify.spec import load_example
from strategies import clustered_systems


@settings(max_examples=25, deadline=None)
@given(clustered_systems(max_n=10), st.data())
def test_the_pattern_without_rows_equals_the_support_of_the_exact_rows(system: System, data: st.DataObject) -> None:
    F = data.draw(st.lists(st.integers(0, system.n - 1), min_size=1, max_size=3))
    M = system.idx(system.monitored)
    assert np.array_equal(exact_q_pattern(system, F, M), exact_q_rows(system, F, M, None)[1])


def test_the_pattern_without_rows_equals_the_support_on_paper19() -> None:
    system = System(load_example("paper19"))
    F = system.idx(system.attacked)
    M = system.idx(system.monitored)
    assert np.array_equal(exact_q_pattern(system, F, M), exact_q_rows(system, F, M, None)[1])
