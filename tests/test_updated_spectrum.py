"""Safe-mode spectra kept as factors of the normal one: every certified bound checked against its definition.

The factored spectrum never forms ``U_q = U F_1 ... F_s`` for the certified checks; its bounds
(loss of orthonormality, residual per column, error of computed entries) come from the factors
alone. Here the exact product is formed in extended precision (``numpy.longdouble``) and each
bound is compared with the quantity it bounds, on random graphs, repeated eigenvalues and
removed links included.
"""

from __future__ import annotations

import math

import networkx as nx
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from strategies import dense_laplacian, extended_product

import glocal_verify.numerics.updated_spectrum as updated_module
from glocal_verify import config
from glocal_verify import System, verify
from glocal_verify.design.generators import random_clustered_spec
from glocal_verify.numerics.rank_one import RankOneFactor, rank_one_factor, tree_rowsum
from glocal_verify.numerics.spectrum import Spectrum
from glocal_verify.numerics.updated_spectrum import UpdatedSpectrum, update_spectrum

LD = np.longdouble


def _dense(F: RankOneFactor) -> np.ndarray:
    """F as a dense float array (exact but for the rotations, whose rounding is ``rotation_rounding`` per column)."""
    return F.apply(np.eye(F.size))


@st.composite
def _secular_data(draw: st.DrawFn) -> tuple[np.ndarray, np.ndarray, float]:
    """Eigenvalues (with clusters and exact repeats), a vector z (some entries tiny or zero) and a weight."""
    n = draw(st.integers(2, 40))
    base = draw(st.lists(st.floats(0.0, 30.0, allow_nan=False), min_size=n, max_size=n))
    w = np.array(base)
    for k in draw(st.lists(st.integers(1, n - 1), max_size=n // 3)):
        w[k] = w[k - 1] + draw(st.sampled_from([0.0, 1e-14, 1e-9, 1e-5]))
    w = np.sort(w)
    z = np.array(draw(st.lists(st.floats(-1.0, 1.0, allow_nan=False), min_size=n, max_size=n)))
    for k in draw(st.lists(st.integers(0, n - 1), max_size=n // 3)):
        z[k] = draw(st.sampled_from([0.0, 1e-17, 1e-12]))
    rho = draw(st.sampled_from([-3.0, -1.0, -0.5, 0.5, 1.0, 2.5]))
    return w, z, rho


@settings(max_examples=120, deadline=None)
@given(_secular_data())
def test_the_factor_certificate_bounds_its_loss_of_orthonormality(data: tuple[np.ndarray, np.ndarray, float]) -> None:
    w, z, rho = data
    F = rank_one_factor(w, z, rho)
    if F is None:  # the caller then decomposes afresh; nothing is claimed
        return
    Fd = _dense(F).astype(LD)
    n = F.size
    true = float(np.sqrt(np.sum((Fd.T @ Fd - np.eye(n, dtype=LD)) ** 2)))
    # the formed columns differ from the exact factor by the rotations' rounding only
    widen = 3.0 * math.sqrt(n) * F.rotation_rounding
    assert true <= F.orthogonality + widen, (true, F.orthogonality)
    # and F diagonalizes diag(w) + rho z z^T: the definition, to the level of the certificate
    M = np.diag(w).astype(LD) + LD(rho) * np.outer(z, z).astype(LD)
    R = M @ Fd - Fd * F.values.astype(LD)
    scale = max(1.0, float(np.max(np.abs(w))), abs(rho) * float(z @ z))
    assert float(np.sqrt(np.sum(R**2))) <= 1e-12 * n * scale


def test_a_balanced_tree_sum_is_within_its_rounding_bound() -> None:
    rng = np.random.default_rng(3)
    X = rng.standard_normal((5, 1001)) * np.logspace(-8, 8, 1001)
    got = tree_rowsum(X)
    depth = (1001 - 1).bit_length()
    u = np.finfo(float).eps / 2
    for r in range(5):
        exact = math.fsum(X[r])
        assert abs(got[r] - exact) <= depth * u / (1 - depth * u) * float(np.sum(np.abs(X[r])))


@st.composite
def _graph_and_changes(draw: st.DrawFn) -> tuple[int, list[tuple[int, int, float]], list[tuple[int, int, float]]]:
    kind = draw(st.sampled_from(["random", "star", "cycle", "complete"]))
    if kind == "random":
        n = draw(st.integers(3, 30))
        G = nx.gnp_random_graph(n, draw(st.sampled_from([0.2, 0.4])), seed=draw(st.integers(0, 10**6)))
    else:
        n = draw(st.integers(4, 16))
        G = {"star": nx.star_graph(n - 1), "cycle": nx.cycle_graph(n), "complete": nx.complete_graph(n)}[kind]
    edges = [(int(u), int(v), float(draw(st.integers(1, 3)))) for u, v in G.edges()]
    existing = {(u, v): wt for u, v, wt in edges}
    changes: list[tuple[int, int, float]] = []
    for _ in range(draw(st.integers(1, 3))):
        i, j = sorted(draw(st.lists(st.integers(0, n - 1), min_size=2, max_size=2, unique=True)))
        if (i, j) in existing and draw(st.booleans()):
            changes.append((i, j, -existing.pop((i, j))))
        else:
            changes.append((i, j, float(draw(st.sampled_from([0.5, 1.0, 2.0])))))
    return n, edges, changes


@settings(max_examples=80, deadline=None)
@given(_graph_and_changes())
def test_a_factored_spectrum_bounds_its_residuals_orthonormality_and_entries(case: tuple[int, list[tuple[int, int, float]], list[tuple[int, int, float]]]) -> None:
    n, edges, changes = case
    L0 = dense_laplacian(n, edges)
    Lq = L0 + dense_laplacian(n, changes)
    base = Spectrum(L0)
    with config.override(update_accept=math.inf):  # every bound is checked, kept or not
        sp = update_spectrum(Lq, base, changes)
    if sp is None:
        return
    # the exact product the bounds are about, in extended precision
    U, widen = extended_product(sp)
    I = np.eye(n, dtype=LD)
    assert float(np.sqrt(np.sum((U.T @ U - I) ** 2))) <= sp.orthogonality_error + widen
    res = np.sqrt(np.sum((Lq.astype(LD) @ U - U * sp.values.astype(LD)) ** 2, axis=0)).astype(float)
    assert np.all(res <= sp.residuals + widen * (np.abs(Lq).sum() + np.abs(sp.values))), float(np.max(res - sp.residuals))
    rows = [changes[0][0], changes[0][1], n - 1]
    assert np.all(np.abs(sp.rows(rows) - U[rows, :].astype(float)) <= sp.entry_error + widen)
    cols = [0, n // 2, n - 1]
    assert np.all(np.abs(sp.columns(cols) - U[:, cols].astype(float)) <= sp.entry_error + widen)
    # the basis formed for callers that want it whole is the same product
    assert np.all(np.abs(sp.vectors - U.astype(float)) <= sp.entry_error + widen)
    # apply / project agree with the formed basis
    X = np.arange(2 * n, dtype=float).reshape(n, 2)
    assert np.allclose(sp.apply(X), sp.vectors @ X, atol=1e-10 * n)
    assert np.allclose(sp.project(X), sp.vectors.T @ X, atol=1e-10 * n)


def test_verify_never_forms_a_safe_mode_basis_whole() -> None:
    system = System(random_clustered_spec(600, 3, seed=7))
    report = verify(system)
    assert report.conditions
    for mode in system.safe_modes:
        sp = system.spectrum(mode)
        assert isinstance(sp, UpdatedSpectrum)
        assert not sp.formed, f"{mode}: a certified check formed U_q = U F (an N^3 product) instead of reading its rows"


def test_a_factored_spectrum_encloses_the_eigenvalues_of_a_fresh_decomposition() -> None:
    system = System(random_clustered_spec(800, 4, seed=5))
    for mode in system.safe_modes:
        sp = system.spectrum(mode)
        assert isinstance(sp, UpdatedSpectrum)
        fresh = Spectrum(system.laplacian_sparse(mode))
        assert np.max(np.abs(sp.values - fresh.values)) <= sp.error_radius + fresh.error_radius
        # the certificate is about as sharp as eigh's own (the acceptance rule keeps it so)
        assert sp.error_radius <= config.get("update_accept") * system.spectrum().error_radius
