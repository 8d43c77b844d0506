"""Certified bounds of the eigendecomposition, checked in exact rational arithmetic."""

from __future__ import annotations

from fractions import Fraction

import flint
import numpy as np
import pytest

from glocal_verify import System
from glocal_verify.design.generators import random_clustered_spec
from glocal_verify.numerics.spectrum import Spectrum


def _exact_orthogonality_loss_squared(U: np.ndarray) -> Fraction:
    """``||U^T U - I||_F^2`` of the floating-point matrix U, exactly (every double is a rational)."""
    n = U.shape[0]
    X = flint.fmpq_mat(n, n, [flint.fmpq(*Fraction(float(x)).as_integer_ratio()) for x in U.ravel()])
    G = X.transpose() * X - flint.fmpq_mat(n, n, [int(i == j) for i in range(n) for j in range(n)])
    total = sum((G[i, j] ** 2 for i in range(n) for j in range(n)), flint.fmpq(0))
    return Fraction(int(total.p), int(total.q))


@pytest.mark.parametrize("n,clusters,seed", [(12, 2, 0), (30, 3, 1), (40, 4, 5)])
def test_the_orthogonality_bound_is_at_least_the_exact_loss_of_orthonormality(n: int, clusters: int, seed: int) -> None:
    sp = Spectrum(System(random_clustered_spec(n, clusters, seed=seed)).laplacian())
    eta = Fraction(sp.orthogonality_error)
    assert eta**2 >= _exact_orthogonality_loss_squared(sp.vectors)


def test_the_orthogonality_bound_covers_a_matrix_far_from_orthonormal() -> None:
    # the bound is checked on the vectors the Spectrum holds: replace them by a perturbed copy
    sp = Spectrum(System(random_clustered_spec(20, 2, seed=3)).laplacian())
    w, U = sp.values, sp.vectors.copy()
    U[:, 0] *= 1.0 + 1e-6
    U.setflags(write=False)
    sp.__dict__["_pairs"] = (w, U)  # the cached_property slot
    eta = Fraction(sp.orthogonality_error)
    exact = _exact_orthogonality_loss_squared(U)
    assert eta**2 >= exact and exact > 0
