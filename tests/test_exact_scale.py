"""The fast exact paths give exactly the answers of the dense rational eliminations they replace."""

from __future__ import annotations

import random
from fractions import Fraction

import flint
import numpy as np
import pytest

from glocal_verify import System
from glocal_verify.analysis.stealthy.zda_exact import _q_matrix, transfer_kernel
from glocal_verify.numerics.exact_subspace import (
    _lift_closure,
    row_closure,
    _row_closure_direct,
)
from glocal_verify.numerics.pencil_exact import (
    echelon_mod as _echelon_mod,
    kernel_over_field,
    rank_over_field,
)
from glocal_verify.spec import load_example


def _random_q(rng: random.Random, m: int, n: int, density: float) -> flint.fmpq_mat:
    flat = [flint.fmpq(rng.randint(-3, 3), rng.randint(1, 4)) if rng.random() < density else 0 for _ in range(m * n)]
    return flint.fmpq_mat(m, n, flat)


def _block_invariant(rng: random.Random, n: int, k: int) -> tuple[flint.fmpq_mat, flint.fmpq_mat]:
    """A matrix with a rational invariant subspace of dimension k and rows C vanishing on it."""
    T = _random_q(rng, n, n, 1.0)
    while T.rank() < n:
        T = _random_q(rng, n, n, 1.0)
    blk = _random_q(rng, n, n, 0.6)
    for i in range(k, n):
        for j in range(k):
            blk[i, j] = 0
    A = T * blk * T.inv()
    C = _random_q(rng, 2, n, 0.7)
    for i in range(2):
        for j in range(k):
            C[i, j] = 0
    return C * T.inv(), A


@pytest.mark.parametrize("seed", range(12))
def test_closure_through_primes_equals_the_dense_rational_closure(seed: int) -> None:
    rng = random.Random(seed)
    n = rng.randint(3, 9)
    C, A = _block_invariant(rng, n, rng.randint(0, n - 1))
    mats = [A] if seed % 2 else [A, _random_q(rng, n, n, 0.3)]
    assert row_closure(C, mats) == _row_closure_direct(C, mats)


@pytest.mark.parametrize("seed", range(12))
def test_unlucky_small_primes_never_give_a_wrong_closure(seed: int) -> None:
    rng = random.Random(100 + seed)
    n = rng.randint(3, 8)
    C, A = _block_invariant(rng, n, rng.randint(1, n - 1))
    lifted = _lift_closure(C, [A], primes=[2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37, 41, 43, 47])
    assert lifted is None or lifted == _row_closure_direct(C, [A])


def test_closure_of_the_paper_example_matches_the_dense_closure_in_every_mode() -> None:
    from glocal_verify.analysis.unobservable.subspace import exact_A, exact_C

    system = System(load_example("paper19"))
    C = exact_C(system)
    for mode in system.modes:
        A = exact_A(system, mode)
        assert row_closure(C, [A]) == _row_closure_direct(C, [A])


def test_linear_field_kernel_is_the_same_basis_as_the_field_elimination() -> None:
    rng = random.Random(7)
    x = flint.fmpq_poly([0, 1])
    for _ in range(6):
        rows = [[flint.fmpq_poly([rng.randint(-2, 2), rng.randint(-2, 2)]) for _ in range(6)] for _ in range(4)]
        f = x - flint.fmpq(rng.randint(-3, 3), rng.randint(1, 3))
        R, piv = _echelon_mod(rows, f, 6)
        free = [j for j in range(6) if j not in piv]
        K = kernel_over_field(rows, f, 6)
        assert len(K.basis) == len(free) == 6 - rank_over_field(rows, f, 6)
        for v in K.basis:  # M v = 0 over Q[x]/(f)
            assert all((sum((e * c for e, c in zip(row, v)), flint.fmpq_poly(0)) % f).is_zero() for row in rows)
        for c, fr in enumerate(free):  # identity at the free columns: the reduced basis
            assert [K.basis[c][j] for j in free] == [flint.fmpq_poly(int(j == fr)) for j in free]


def test_transfer_kernel_equals_the_full_pencil_kernel_at_every_zero_of_the_paper_example() -> None:
    from glocal_verify.analysis.stealthy.zda_exact import zda_analysis_exact

    system = System(load_example("paper19"))
    F = system.idx(system.attacked)
    ea = zda_analysis_exact(system)
    x = flint.fmpq_poly([0, 1])
    s_poly = x * x + flint.fmpq(system.gamma_q.numerator, system.gamma_q.denominator) * x
    rows_out = system.idx(system.monitored)
    fields = {str(z.field): z.field for z in (*ea.zeros, *ea.unobservable) if z.field != x}
    fields["x - 1"] = x - 1
    checked = 0
    for g in fields.values():
        tk = transfer_kernel(system, F, g, s_poly, rows_out)
        if tk is None:
            continue
        basis, dim = tk
        full = kernel_over_field(_q_matrix(system, F, rows_out, s_poly), g, system.n + len(F))
        assert dim == len(full.basis)
        assert [tuple(e % g for e in v) for v in basis] == [tuple(v) for v in full.basis]
        checked += 1
    assert checked


def test_transfer_kernel_with_switch_rows_equals_the_stacked_kernel() -> None:
    system = System(load_example("paper19"))
    F = system.idx(system.attacked)
    x = flint.fmpq_poly([0, 1])
    s_poly = x * x + flint.fmpq(system.gamma_q.numerator, system.gamma_q.denominator) * x
    g = x * x + x + 3  # irreducible over Q, not a pole of the paper example
    rows_out = system.idx(system.monitored)
    N, m = system.n, len(F)
    for mode in system.safe_modes:
        dL = system.delta_laplacian_exact(mode)
        idx = [i for i in range(N) if any(Fraction(v) != 0 for v in dL[i])]
        extra = [dL[i] for i in idx]
        tk = transfer_kernel(system, F, g, s_poly, rows_out, extra)
        assert tk is not None
        stacked = _q_matrix(system, F, rows_out, s_poly) + [
            [flint.fmpq_poly(flint.fmpq(Fraction(v).numerator, Fraction(v).denominator)) for v in dL[i]] + [flint.fmpq_poly(0)] * m for i in idx
        ]
        full = kernel_over_field(stacked, g, N + m)
        assert tk[1] == len(full.basis)
        assert [tuple(v) for v in tk[0]] == [tuple(v) for v in full.basis]


@pytest.mark.parametrize("seed", range(40))
def test_the_routh_array_on_flint_polynomials_agrees_with_the_roots(seed: int) -> None:
    from glocal_verify.numerics.hurwitz import routh_hurwitz, routh_hurwitz_poly

    rng = random.Random(seed)
    # a product of quadratic factors with rational roots or clearly complex ones, so that the
    # sign of every real part is far from 0 (or exactly 0) and numpy's roots decide it
    q = flint.fmpq_poly([1])
    for _ in range(rng.randint(1, 5)):
        a, b = rng.choice([-3, -2, -1, 1, 2, 3]), rng.choice([-3, -2, 0, 1, 2, 3])
        q *= flint.fmpq_poly([a * b, -(a + b), 1]) if rng.random() < 0.5 else flint.fmpq_poly([a * a + b * b, -2 * a, 1])
    coeffs = [Fraction(int(c.p), int(c.q)) for c in reversed(q.coeffs())]
    roots = np.roots([float(c) for c in coeffs])
    hurwitz = bool(np.all(roots.real < -1e-6))
    assert routh_hurwitz_poly(q) is hurwitz
    assert routh_hurwitz(coeffs) is hurwitz
