"""The certificate fast path of ``zda_analysis_exact`` returns what the general exact path returns."""

from __future__ import annotations

import itertools
from fractions import Fraction
from typing import Any

import flint
import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from glocal_verify.analysis.stealthy.zda_exact import (
    ExactZdaAnalysis,
    ExactZdaZero,
    _certified_analysis,
    zda_analysis_exact,
)
from glocal_verify.model import System
from glocal_verify.spec import load_example
from glocal_verify.spec.types import Label
from tests.strategies import clustered_systems, systems


def _same_zero(a: ExactZdaZero | None, b: ExactZdaZero | None) -> None:
    if a is None or b is None:
        assert a is None and b is None
        return
    assert a.value == b.value
    assert a.rational == b.rational
    assert a.factor == b.factor
    assert a.real_sign == b.real_sign
    assert a.attack == b.attack
    assert a.multiplicity == b.multiplicity
    assert a.field == b.field
    assert tuple(flint.fmpq_poly(p) for p in a.xi_field) == tuple(flint.fmpq_poly(p) for p in b.xi_field)
    assert tuple(flint.fmpq_poly(p) for p in a.u0_field) == tuple(flint.fmpq_poly(p) for p in b.u0_field)
    np.testing.assert_array_equal(a.xi, b.xi)
    np.testing.assert_array_equal(a.u0, b.u0)
    assert a.growth == b.growth


def _same_analysis(fast: ExactZdaAnalysis, general: ExactZdaAnalysis) -> None:
    assert fast.actuators == general.actuators
    assert fast.left_invertible == general.left_invertible
    assert fast.normal_rank == general.normal_rank
    assert fast.normal_kernel_dim == general.normal_kernel_dim
    assert fast.s_zero_polynomial == general.s_zero_polynomial
    assert len(fast.zeros) == len(general.zeros)
    for a, b in zip(fast.zeros, general.zeros):
        _same_zero(a, b)
    assert len(fast.unobservable) == len(general.unobservable)
    for a, b in zip(fast.unobservable, general.unobservable):
        _same_zero(a, b)
    _same_zero(fast.direction, general.direction)
    assert fast.direction_source == general.direction_source
    assert fast.notes == general.notes


def _direction_satisfies_definition(system: System, F: tuple[Label, ...], z: ExactZdaZero) -> None:
    """(s I + alpha L) xi = S_F^T u0, S_M xi = 0 (S_{M_x} xi = 0 at lambda0 = 0), u0 != 0, exactly over Q."""
    assert z.rational is not None  # the fast path only ever reports lambda0 = 0
    lam = z.rational
    s = lam * lam + system.gamma_q * lam
    L = system.laplacian_exact()
    xi = [Fraction(int(flint.fmpq_poly(p)(0).p), int(flint.fmpq_poly(p)(0).q)) for p in z.xi_field]
    u0 = [Fraction(int(flint.fmpq_poly(p)(0).p), int(flint.fmpq_poly(p)(0).q)) for p in z.u0_field]
    assert any(u != 0 for u in u0)
    Fi = system.idx(F)
    for i in range(system.n):
        lhs = s * xi[i] + system.alpha_q * sum((L[i][j] * xi[j] for j in range(system.n)), Fraction(0))
        rhs = sum((u for k, u in zip(Fi, u0) if k == i), Fraction(0))
        assert lhs == rhs
    rows = system.monitored_positions if lam == 0 else system.monitored
    assert all(xi[r] == 0 for r in system.idx(rows))


def _compare(system: System, F: tuple[Label, ...] | None = None, lambda0: Any = None) -> bool:
    """Compare both paths where the certificate applies (elsewhere both are the general path); True when it applied."""
    F_lab = tuple(F) if F is not None else system.attacked
    if not F_lab or _certified_analysis(system, F_lab, system.idx(F_lab), None) is None:
        return False
    fast = zda_analysis_exact(system, F, lambda0=lambda0)
    general = zda_analysis_exact(system, F, lambda0=lambda0, _general=True)
    _same_analysis(fast, general)
    if fast.direction is not None:
        _direction_satisfies_definition(system, fast.actuators, fast.direction)
    return True


@settings(max_examples=25, deadline=None, suppress_health_check=list(HealthCheck))
@given(systems(max_n=8), st.data())
def test_fast_path_equals_general_path_on_random_systems(system: System, data: st.DataObject) -> None:
    if not system.monitored:
        return
    F = tuple(data.draw(st.lists(st.sampled_from(list(system.labels)), unique=True, min_size=1, max_size=2)))
    lam = data.draw(st.sampled_from([None, 0.0, 1.0, 0.5]))
    _compare(system, F, lam)


@settings(max_examples=15, deadline=None, suppress_health_check=list(HealthCheck))
@given(clustered_systems(max_n=9))
def test_fast_path_equals_general_path_on_clustered_systems(system: System) -> None:
    _compare(system)
    _compare(system, lambda0=0.0)


def test_fast_path_equals_general_path_on_paper19_for_every_one_and_two_actuator_set() -> None:
    system = System(load_example("paper19"))
    applied = 0
    for k in (1, 2):
        for F in itertools.combinations(system.labels, k):
            applied += _compare(system, F)
    assert applied > 0  # the certificate is exercised, not only the fallback


def test_fast_path_equals_general_path_on_paper19_at_lambda0_zero() -> None:
    system = System(load_example("paper19"))
    applied = sum(_compare(system, F, 0.0) for k in (1, 2) for F in itertools.combinations(system.labels, k))
    assert applied > 0
