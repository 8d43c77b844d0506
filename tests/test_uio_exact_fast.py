"""The fast exact UIO existence test agrees with the Fraction-list reference it replaced."""

from __future__ import annotations

import pytest

from fractions import Fraction
from typing import Any
from unittest import mock

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from strategies import clustered_systems

from glocal_verify import System, load_example, verify
from glocal_verify.observers import uio_verdict as local
from glocal_verify.observers.uio_existence import uio_existence_exact


def _checked_against_reference() -> tuple[Any, list[int]]:
    """A stand-in for ``local.uio_existence_exact`` that also runs the reference and asserts
    that both give the same verdict, ranks, unobservable polynomial and h."""
    seen = [0]

    def both(A: Any, E: Any, C: Any) -> Any:
        fast = uio_existence_exact(A, E, C)
        ref = uio_existence_exact(A, E, C, _reference=True)
        assert fast == ref
        seen[0] += 1
        return fast

    return both, seen


@st.composite
def _exact_triples(draw: st.DrawFn) -> tuple[list[list[Fraction]], list[list[Fraction]], list[list[Fraction]]]:
    """Small rational A, unit-column E and 0/1 C (possibly with no rows)."""
    n = draw(st.integers(1, 7))
    entry = st.fractions(min_value=-3, max_value=3, max_denominator=3)
    A = [[draw(entry) for _ in range(n)] for _ in range(n)]
    cols = draw(st.lists(st.integers(0, n - 1), unique=True, max_size=min(2, n)))
    E = [[Fraction(int(i == c)) for c in cols] for i in range(n)]
    p = draw(st.integers(0, n))
    C = [[Fraction(draw(st.integers(0, 1))) for _ in range(n)] for _ in range(p)]
    return A, E, C


@pytest.mark.slow
@settings(max_examples=150, deadline=None)
@given(_exact_triples())
def test_the_fast_exact_uio_existence_equals_the_reference_on_random_rational_data(triple: tuple[Any, Any, Any]) -> None:
    A, E, C = triple
    if not E[0]:
        E = [[] for _ in A]
    assert uio_existence_exact(A, E, C) == uio_existence_exact(A, E, C, _reference=True)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(clustered_systems(max_n=12))
def test_exact_local_uio_on_random_clustered_networks_agrees_with_the_reference(system: System) -> None:
    both, _ = _checked_against_reference()
    with mock.patch.object(local, "uio_existence_exact", both):
        verify(system, only=["local.uio"], exact=True, exact_budget=None)


def test_exact_local_uio_on_paper19_agrees_with_the_reference_in_every_mode() -> None:
    both, seen = _checked_against_reference()
    with mock.patch.object(local, "uio_existence_exact", both):
        report = verify(System(load_example("paper19")), only=["local.uio"], exact=True, exact_budget=None)
    assert seen[0] > 0
    assert report is not None
