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


@pytest.mark.parametrize("n,clusters,seed", [(12, 2, 0), (40, 4, 5)])
def test_the_sparse_laplacian_holds_each_exact_entry_rounded_once(n: int, clusters: int, seed: int) -> None:
    system = System(random_clustered_spec(n, clusters, seed=seed))
    for mode in system.modes:
        S = system.laplacian_sparse(mode)
        exact = system.laplacian_exact(mode)
        dense = S.toarray()
        assert all(dense[i, j] == float(exact[i][j]) for i in range(n) for j in range(n))
        assert S.nnz == sum(1 for row in exact for x in row if x != 0)  # no stored zeros: the exact support
        assert np.array_equal(system.laplacian(mode), dense) and not S.data.flags.writeable


def test_a_spectrum_of_the_sparse_matrix_has_the_bounds_of_the_dense_one() -> None:
    system = System(random_clustered_spec(30, 3, seed=1))
    sparse, dense = Spectrum(system.laplacian_sparse()), Spectrum(system.laplacian())
    assert np.array_equal(sparse.values, dense.values) and np.array_equal(sparse.vectors, dense.vectors)
    L = system.laplacian()
    assert sparse.row_nonzeros == dense.row_nonzeros == int(np.max(np.count_nonzero(L, axis=1)))
    assert sparse.frobenius == dense.frobenius >= float(np.linalg.norm(L, "fro"))
    assert sparse.error_radius == dense.error_radius and sparse.clusters == dense.clusters
    assert np.array_equal(sparse.residuals, dense.residuals)


def test_the_frobenius_norm_bounds_the_exact_norm_of_the_rounded_matrix() -> None:
    L = System(random_clustered_spec(25, 2, seed=4)).laplacian()
    fro = Fraction(Spectrum(L).frobenius)
    assert fro**2 >= sum((Fraction(float(x)) ** 2 for x in L.ravel()), Fraction(0))

