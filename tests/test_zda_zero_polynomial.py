"""The zero polynomial proved by minors and kernels is the one of the dense V* iteration, and the exact ZDA analysis built on it is the reference one."""

from __future__ import annotations

import pytest
import itertools
import random
from fractions import Fraction
from typing import Any

import flint
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from glocal_verify.analysis.stealthy.zda_exact import _proved_zero_polynomial, zda_analysis_exact
from glocal_verify.model import System
from glocal_verify.numerics.pencil_exact import analyze_pencil_exact
from glocal_verify.numerics.zero_polynomial import left_invertible_zero_polynomial, poly_det
from glocal_verify.spec import load_example
from glocal_verify.spec.types import Label
from tests.strategies import clustered_systems, systems
from tests.test_zda_exact_fast import _same_analysis


def _adjugate_columns(n: int, A: dict[tuple[int, int], Fraction], F: list[int]) -> tuple[Any, list[list[Any]]]:
    """det(sI - A) and adj(sI - A) S_F^T over Q, by Faddeev-LeVerrier (as ``_transfer`` does)."""
    Am = flint.fmpq_mat(n, n, [flint.fmpq(A.get((i, j), Fraction(0)).numerator, A.get((i, j), Fraction(0)).denominator) for i in range(n) for j in range(n)])
    d = Am.charpoly()
    c = d.coeffs()
    EF = flint.fmpq_mat(n, len(F), [int(F[k] == i) for i in range(n) for k in range(len(F))])
    W, Ws = EF, [EF]
    for j in range(n - 1, 0, -1):
        W = Am * W + EF * c[j]
        Ws.append(W)
    Ws.reverse()
    return d, [[flint.fmpq_poly([Wj[i, k] for Wj in Ws]) for k in range(len(F))] for i in range(n)]


def _compare_with_dense(n: int, A: dict[tuple[int, int], Fraction], F: list[int], M: list[int], seed: int = 0) -> bool:
    """The proof, when it is found, equals the dense zero polynomial of a left-invertible system; True when found."""
    d, P = _adjugate_columns(n, A, F)
    proof = left_invertible_zero_polynomial(n, A, F, M, d, P, seed=seed)
    if proof is None:
        return False
    rows = [[A.get((i, j), Fraction(0)) for j in range(n)] for i in range(n)]
    es = analyze_pencil_exact(rows, [[Fraction(int(F[k] == i)) for k in range(len(F))] for i in range(n)], [[Fraction(int(j == r)) for j in range(n)] for r in M], directions=False, n_inputs=len(F))
    assert es.left_invertible
    assert proof.zero_polynomial == es.zero_polynomial
    return True


def _random_system(rng: random.Random) -> tuple[int, dict[tuple[int, int], Fraction], list[int], list[int]]:
    n = rng.randint(2, 9)
    A = {(i, j): Fraction(rng.randint(-3, 3), rng.randint(1, 3)) for i in range(n) for j in range(n) if rng.random() < 0.35}
    A = {k: v for k, v in A.items() if v != 0}
    m = rng.randint(1, min(3, n))
    F = rng.sample(range(n), m)
    M = rng.sample(range(n), rng.randint(m, min(n, m + 2)))
    return n, A, F, M


def test_the_proved_zero_polynomial_equals_the_dense_one_on_random_rational_systems() -> None:
    found = 0
    for seed in range(60):
        found += _compare_with_dense(*_random_system(random.Random(seed)), seed=seed)
    assert found > 20  # the proof is exercised, not only its refusals


def test_a_zero_with_a_jordan_chain_is_refused_not_misreported() -> None:
    # x1' = x2, x2' = u, x3' = 0 * x3 + x1 ... : A = nilpotent chain on an unobserved part gives (s)^2 with one kernel vector
    n = 4
    A = {(0, 1): Fraction(1), (2, 3): Fraction(1)}  # states 2, 3: a Jordan block at 0, unobserved and uncontrolled
    F, M = [1], [0]
    d, P = _adjugate_columns(n, A, F)
    proof = left_invertible_zero_polynomial(n, A, F, M, d, P)
    rows = [[A.get((i, j), Fraction(0)) for j in range(n)] for i in range(n)]
    es = analyze_pencil_exact(rows, [[Fraction(int(i == 1))] for i in range(n)], [[Fraction(int(j == 0)) for j in range(n)]], directions=False, n_inputs=1)
    assert proof is None or proof.zero_polynomial == es.zero_polynomial
    assert es.zero_polynomial == flint.fmpq_poly([0, 0, 1])


def test_a_system_that_is_not_left_invertible_gets_no_proof() -> None:
    n = 3
    A = {(0, 1): Fraction(1), (1, 2): Fraction(1)}
    d, P = _adjugate_columns(n, A, [0, 1])
    assert left_invertible_zero_polynomial(n, A, [0, 1], [2], d, P) is None  # fewer outputs than inputs


@given(st.integers(1, 4), st.lists(st.integers(-3, 3), min_size=16, max_size=16), st.integers(-5, 5))
def test_the_bareiss_determinant_of_a_polynomial_matrix_is_exact(k: int, coeffs: list[int], t: int) -> None:
    M = [[flint.fmpq_poly([coeffs[(i * 4 + j) % 16], coeffs[(i + 3 * j) % 16], flint.fmpq(coeffs[(2 * i + j) % 16], 2)]) for j in range(k)] for i in range(k)]
    at_t = flint.fmpq_mat(k, k, [M[i][j](t) for i in range(k) for j in range(k)]).det()
    assert poly_det(M)(t) == at_t


def _compare_paths(system: System, F: tuple[Label, ...] | None = None, lambda0: Any = None) -> bool:
    """The general path with the proved zero polynomial returns the dense reference, field by field; True when the proof applied."""
    F_lab = tuple(F) if F is not None else system.attacked
    if not F_lab or not system.monitored:
        return False
    applied = _proved_zero_polynomial(system, system.idx(F_lab)) is not None
    fast = zda_analysis_exact(system, F_lab, lambda0=lambda0, _general=True)
    dense = zda_analysis_exact(system, F_lab, lambda0=lambda0, _general=True, _dense=True)
    _same_analysis(fast, dense)
    return applied


@settings(max_examples=30, deadline=None, suppress_health_check=list(HealthCheck))
@given(systems(max_n=8), st.data())
def test_the_exact_zda_analysis_on_the_proved_zero_polynomial_is_the_dense_one_on_random_networks(system: System, data: st.DataObject) -> None:
    if not system.monitored:
        return
    F = tuple(data.draw(st.lists(st.sampled_from(list(system.labels)), unique=True, min_size=1, max_size=3)))
    lam = data.draw(st.sampled_from([None, 0.0, 1.0, 0.5]))
    _compare_paths(system, F, lam)


@settings(max_examples=15, deadline=None, suppress_health_check=list(HealthCheck))
@given(clustered_systems(max_n=10))
def test_the_exact_zda_analysis_on_the_proved_zero_polynomial_is_the_dense_one_on_clustered_networks(system: System) -> None:
    _compare_paths(system)
    _compare_paths(system, lambda0=0.0)


@pytest.mark.slow
def test_the_exact_zda_analysis_on_the_proved_zero_polynomial_is_the_dense_one_on_paper19() -> None:
    system = System(load_example("paper19"))
    applied = sum(_compare_paths(system, F) for k in (1, 2) for F in itertools.combinations(system.labels, k))
    assert applied > 0
    assert not _compare_paths(system)  # the spec's attack on {3, 4} is not left-invertible: the dense path, the same answer
    _compare_paths(system, lambda0=0.0)
