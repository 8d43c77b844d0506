"""The batched witness directions of an audit: the per-set method's decisions, and kernel vectors by definition."""

from __future__ import annotations

import itertools
import random

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
import pytest

from glocal_verify import System, load_example
from glocal_verify.analysis.stealthy.zda import ModalPencil
from glocal_verify.analysis.stealthy.zda_batch import batch_directions
from glocal_verify.design.generators import random_clustered_spec
from glocal_verify.numerics.tolerance import DEFAULT_TOLERANCE, Decision

SYSTEMS = [("paper19", None), ("random-30", (30, 2, 0)), ("random-60", (60, 3, 2))]


def _system(name: str, args: tuple[int, int, int] | None) -> System:
    return System(load_example("paper19")) if args is None else System(random_clustered_spec(args[0], args[1], seed=args[2]))


def _sets(system: System) -> list[tuple[object, ...]]:
    labels = list(system.index)
    rng = random.Random(3)
    pairs = list(itertools.combinations(labels, 2))
    triples = list(itertools.combinations(labels, 3))
    return [(a,) for a in labels[:6]] + rng.sample(pairs, min(120, len(pairs))) + rng.sample(triples, 20)


@pytest.mark.parametrize("name,args", SYSTEMS)
@pytest.mark.parametrize("lam", [0j, 1.0 + 0j, -0.3 + 0.7j])
def test_every_batched_direction_is_the_per_set_direction_and_a_kernel_vector_of_the_2n_pencil(name: str, args: tuple[int, int, int] | None, lam: complex) -> None:
    system = _system(name, args)
    sets = _sets(system)
    got = batch_directions(system, DEFAULT_TOLERANCE, lam, sets)
    A, C = system.A(), system.C()
    for F, g in zip(sets, got):
        want = ModalPencil(system, F, DEFAULT_TOLERANCE).direction(lam)
        if g is None:
            continue
        (xi, u, res, dres, du), best, lo, hi = g.as_found()
        (xi2, u2, _, dres2, du2), best2, lo2, hi2 = want  # type: ignore[misc]
        assert (dres, du, best, lo, hi) == (dres2, du2, best2, lo2, hi2)
        assert np.allclose(xi, xi2, atol=1e-10) and np.allclose(u, u2, atol=1e-10)
        # the definition: [lam I - A, -B; C, 0] [x; u] = 0 with x = [xi; lam xi], u != 0
        x = np.concatenate([xi, lam * xi])
        B = system.B(F)
        r = np.concatenate([lam * x - A @ x - B @ u, C @ x])
        scale = np.linalg.norm(np.block([[A, B], [C, np.zeros((C.shape[0], B.shape[1]))]]), 2) + abs(lam)
        assert np.linalg.norm(r) <= 1e-8 * scale * np.linalg.norm(np.concatenate([x, u]))
        assert np.linalg.norm(u) > 1e-6 * np.linalg.norm(np.concatenate([x, u]))


@pytest.mark.parametrize("name,args", SYSTEMS)
def test_the_batch_answers_every_set_the_per_set_method_settles_on_its_first_candidate_at_zero(name: str, args: tuple[int, int, int] | None) -> None:
    system = _system(name, args)
    sets = _sets(system)
    got = batch_directions(system, DEFAULT_TOLERANCE, 0j, sets)
    proven = [w[0] is not None and w[0][3] is Decision.ZERO and w[0][4] is Decision.NONZERO for w in (ModalPencil(system, F, DEFAULT_TOLERANCE).direction(0j) for F in sets)]
    answered = [g is not None for g in got]
    assert all(p for p, a in zip(proven, answered) if a)  # never more than the per-set method
    assert sum(answered) >= 0.9 * sum(proven)  # and nearly all of it (the rest go to that method)


@settings(max_examples=200, deadline=None)
@given(st.integers(1, 6), st.integers(1, 8), st.integers(1, 3), st.booleans(), st.booleans(), st.integers(0, 2**31 - 1))
def test_the_batch_normalisation_of_each_row_equals_the_per_set_normalisation(rows: int, n: int, m: int, complex_: bool, near_real: bool, seed: int) -> None:
    from glocal_verify.analysis.stealthy.zda import normalize_direction
    from glocal_verify.analysis.stealthy.zda_batch import _normalized_rows

    rng = np.random.default_rng(seed)
    X = rng.integers(-2, 3, size=(rows, n)).astype(float)  # small integers: ties of the largest entry and zero rows occur
    U = rng.standard_normal((rows, m))
    if complex_:
        X = X + 1j * (1e-16 if near_real else 1.0) * rng.integers(-2, 3, size=(rows, n))
        U = U + 0j
    for j, (xn, un) in enumerate(_normalized_rows(X, U)):
        xr, ur = normalize_direction(X[j], U[j])
        assert xn.dtype == xr.dtype and un.dtype == ur.dtype
        assert np.array_equal(xn, xr) and np.array_equal(un, ur)
