"""The exact ``central.observer`` pieces (characteristic polynomial by the determinant lemma, fraction-free Routh) equal their dense references."""

from __future__ import annotations

import random
from fractions import Fraction

import flint
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from glocal_verify.analysis.unobservable.subspace import exact_A, exact_C
from glocal_verify.model import System
from glocal_verify.numerics.hurwitz import _routh_hurwitz_rational, routh_hurwitz_poly
from glocal_verify.observers.central import (
    design_central_observer,
    observer_charpoly_exact,
)
from glocal_verify.spec import load_example
from tests.strategies import systems


def _dense_and_modal(system: System, mode: str, rng: random.Random) -> tuple[flint.fmpq_poly, flint.fmpq_poly]:
    n2 = 2 * system.n
    C = exact_C(system)
    p = C.nrows()
    H = flint.fmpq_mat(n2, p, [flint.fmpq(rng.randint(-4, 4), rng.randint(1, 3)) if rng.random() < 0.7 else 0 for _ in range(n2 * p)])
    A = exact_A(system, mode)
    dense = (A - H * C).charpoly() if p else A.charpoly()
    return dense, observer_charpoly_exact(system, H, mode)


@settings(max_examples=40, deadline=None, suppress_health_check=list(HealthCheck))
@given(systems(max_n=8), st.integers(0, 10**6))
def test_the_observer_characteristic_polynomial_by_the_determinant_lemma_is_the_dense_one(system: System, seed: int) -> None:
    rng = random.Random(seed)
    for mode in system.modes:
        dense, modal = _dense_and_modal(system, mode, rng)
        assert modal == dense


def test_the_observer_characteristic_polynomial_of_the_designed_gain_on_paper19_is_the_dense_one() -> None:
    system = System(load_example("paper19"))
    obsv = design_central_observer(system)
    C = exact_C(system)
    H = flint.fmpq_mat(2 * system.n, C.nrows(), [flint.fmpq(*Fraction(float(x)).as_integer_ratio()) for x in obsv.H.ravel()])
    assert observer_charpoly_exact(system, H) == (exact_A(system, obsv.mode) - H * C).charpoly()


def _polys() -> st.SearchStrategy[flint.fmpq_poly]:
    stable = st.lists(st.tuples(st.integers(-7, 2), st.integers(1, 3), st.integers(0, 3), st.booleans()), min_size=1, max_size=7).map(
        lambda fs: _from_roots(fs)
    )
    dense = st.lists(st.tuples(st.integers(-2, 9), st.integers(1, 4)), min_size=2, max_size=11).map(
        lambda cs: flint.fmpq_poly([flint.fmpq(a, b) for a, b in cs])
    )
    return st.one_of(stable, dense)


def _from_roots(fs: list[tuple[int, int, int, bool]]) -> flint.fmpq_poly:
    p = flint.fmpq_poly([1])
    for a, b, im, real in fs:
        re = flint.fmpq(a, b)
        p *= flint.fmpq_poly([-re, 1]) if real else flint.fmpq_poly([re * re + im * im, -2 * re, 1])
    return p


@settings(max_examples=400, deadline=None)
@given(_polys(), st.booleans())
def test_the_fraction_free_routh_test_agrees_with_the_rational_routh_array(q: flint.fmpq_poly, negate: bool) -> None:
    q = -q if negate else q
    assert routh_hurwitz_poly(q) == _routh_hurwitz_rational(q)
