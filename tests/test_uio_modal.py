"""The modal UIO design and certificate (observers/uio_modal.py) against the dense design and exact arithmetic."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from strategies import clustered_systems

from glocal_verify import NotApplicableError, System
from glocal_verify.analysis.local.cluster_modal import interior_modes, interior_modes_of, state_rounding_bound
from glocal_verify.analysis.local.cases import LocalCase, local_cases
from glocal_verify.conditions import local
from glocal_verify.observers import uio_verdict
from glocal_verify.conditions.registry import CheckContext
from glocal_verify.design.generators import random_clustered_spec
from glocal_verify.model import state_matrix
from glocal_verify.numerics import exact as ex
from glocal_verify.numerics.hurwitz import routh_hurwitz
from glocal_verify.observers.uio_modal import _Basis, design_uio_modal


def _sorted_eigs(w: dict) -> np.ndarray:  # type: ignore[type-arg]
    return np.array(sorted((complex(z) for z in w["eigenvalues_F"]), key=lambda z: (round(z.real, 6), round(z.imag, 6))))


def _match(a: np.ndarray, b: np.ndarray, tol: float) -> bool:
    """Every entry of a is within tol of an entry of b and vice versa (multisets of equal size)."""
    if len(a) != len(b):
        return False
    return all(np.min(np.abs(b - z)) <= tol for z in a) and all(np.min(np.abs(a - z)) <= tol for z in b)


def _agents_observed(system: System, case: LocalCase) -> tuple[list[int], list[int]]:
    idx = {a: k for k, a in enumerate(case.model.nodes)}
    return [idx[a] for a in case.observer.positions], [idx[a] for a in case.observer.velocities]


@pytest.mark.parametrize("seed", [1, 2, 3, 7])
def test_the_fast_uio_design_agrees_with_the_dense_one_on_generated_networks(seed: int) -> None:
    s = System(random_clustered_spec(150, 3, seed=seed))
    for case in local_cases(s):
        if case.kind != "all":
            continue
        a = uio_verdict.uio_verdict(s, case, method="modal")
        b = uio_verdict.uio_verdict(s, case, method="dense")
        assert a.status is b.status, (case.scope, a.witness, b.witness)
        for mode in s.modes:
            wa = a.witness["normal"] if mode == "normal" else a.witness["modes"][mode]
            wb = b.witness["normal"] if mode == "normal" else b.witness["modes"][mode]
            assert wa["status"] == wb["status"]
            if "eigenvalues_F" in wa and "eigenvalues_F" in wb:
                assert wa.get("method") == "modal"
                # the same default poles: the same spectrum of F (the dense design's repeated
                # poles near a Jordan block of A_1 are accurate to about sqrt(eps) only)
                assert _match(_sorted_eigs(wa), _sorted_eigs(wb), 1e-5)
                assert wa["hurwitz_margin"] == pytest.approx(wb["hurwitz_margin"], abs=1e-6)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(clustered_systems(max_n=14))
def test_the_fast_uio_verdict_agrees_with_the_dense_one_and_never_contradicts_exact_arithmetic(system: System) -> None:
    for case in local_cases(system):
        a = uio_verdict.uio_verdict(system, case, method="modal")
        b = uio_verdict.uio_verdict(system, case, method="dense")
        if a.status.value != "undecided" and b.status.value != "undecided":
            assert a.status is b.status, (case.scope, a.witness, b.witness)
        if a.status.value != "undecided":
            e = uio_verdict.uio_verdict(system, case, exact=True)
            assert e.status is a.status, (case.scope, a.witness, e.witness)


def _exact_F_is_hurwitz(system: System, case: LocalCase, K1: np.ndarray) -> bool:
    """Routh-Hurwitz on the rational characteristic polynomial of (I - hC) A_exact - K1 C."""
    cm = case.model
    n = len(cm.nodes)
    L = system.cluster_laplacian_exact(cm.name, case.mode)
    a, g = Fraction(system.alpha_q), Fraction(system.gamma_q)
    bnd = {cm.nodes.index(x) for x in cm.boundary}
    pos, vel = _agents_observed(system, case)
    C_rows = pos + [n + v for v in vel]
    F = [[Fraction(0)] * (2 * n) for _ in range(2 * n)]
    for i in range(n):
        F[i][n + i] = Fraction(1)
        if i not in bnd:
            for j in range(n):
                F[n + i][j] = -a * L[i][j]
            F[n + i][n + i] = -g
    for r, col in enumerate(C_rows):
        for i in range(2 * n):
            F[i][col] -= Fraction(float(K1[i, r]))
    M = ex.to_fmpq_mat(F, 2 * n)
    p = M.charpoly()
    coeffs = [ex.to_fraction(p[k]) for k in range(p.degree() + 1)]
    return routh_hurwitz(list(coeffs)[::-1])


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(clustered_systems(max_n=12))
def test_a_certified_modal_design_is_hurwitz_in_exact_rational_arithmetic(system: System) -> None:
    for case in local_cases(system):
        if case.kind != "all":
            continue
        cm = case.model
        pos, vel = _agents_observed(system, case)
        if not set(cm.nodes.index(x) for x in cm.boundary) <= set(vel):
            continue
        modes = interior_modes(system, cm.name, case.mode)
        try:
            md = design_uio_modal(cm.A, modes, pos, vel, alpha=system.alpha, gamma=system.gamma, input_error=state_rounding_bound(system, cm.name, case.mode))
        except NotApplicableError:  # interior block singular: the dense method applies
            continue
        if md.certificate is not None and md.certificate.certified:
            assert _exact_F_is_hurwitz(system, case, md.K1)
            assert md.certificate.abscissa_upper <= 0.0


def test_the_modal_basis_block_triangularises_the_decoupled_matrix() -> None:
    s = System(random_clustered_spec(120, 3, seed=4))
    cm = s.cluster_model("P1")
    n = len(cm.nodes)
    modes = interior_modes(s, "P1", "normal")
    B = _Basis(modes, s.alpha, s.gamma, 0.9)
    T = np.ones(2 * n)
    T[n + modes.boundary] = 0.0
    A1 = T[:, None] * cm.A
    # moved columns: A1 Phi_m = Phi_m A_m (the boundary double integrators and the slow modes)
    assert np.linalg.norm(A1 @ B.Pm - B.Pm @ B.Am) < 1e-9 * np.linalg.norm(B.Pm)
    # every kept plane [z^a, z^c] is invariant with the block [[0, 1], [-alpha mu, -gamma]]
    I = modes.interior
    for k in B.K[:20]:
        za = np.zeros(2 * n)
        za[I] = modes.U[:, k]
        zc = np.zeros(2 * n)
        zc[n + I] = modes.U[:, k]
        assert np.allclose(A1 @ za, -s.alpha * modes.mu[k] * zc, atol=1e-10)
        assert np.allclose(A1 @ zc, za - s.gamma * zc, atol=1e-12)


def test_one_interior_decomposition_serves_every_observer_and_every_unchanged_mode(monkeypatch: pytest.MonkeyPatch) -> None:
    import glocal_verify.analysis.local.cluster_modal as cmod

    s = System(random_clustered_spec(200, 3, seed=7))
    calls: list[int] = []
    real = cmod.interior_modes_of

    def counting(*a, **k):  # type: ignore[no-untyped-def]
        calls.append(1)
        return real(*a, **k)

    monkeypatch.setattr(cmod, "interior_modes_of", counting)
    ctx = CheckContext(options={"local_uio_method": "modal"})
    local.check_uio(s, ctx)
    blocks = {(c.name, s.cluster_model(c.name, m).L.tobytes(), s.cluster_model(c.name, m).boundary) for c in s.clusters for m in s.modes}
    assert len(calls) == len(blocks) < len(s.clusters) * len(s.modes)


def test_a_modal_bound_that_cannot_separate_leaves_the_verdict_undecided_with_a_note() -> None:
    s = System(random_clustered_spec(150, 3, seed=2))
    (case,) = [c for c in local_cases(s) if c.kind == "all" and c.model.name == "P1"]
    cm = case.model
    pos, vel = _agents_observed(s, case)
    modes = interior_modes(s, "P1", "normal")
    ok = design_uio_modal(cm.A, modes, pos, vel, alpha=s.alpha, gamma=s.gamma, input_error=state_rounding_bound(s, "P1", "normal"))
    assert ok.certificate is not None and ok.certificate.certified
    # an (absurd) rounding bound of A^i of 1: the perturbation bound no longer separates
    bad = design_uio_modal(cm.A, modes, pos, vel, alpha=s.alpha, gamma=s.gamma, input_error=1.0)
    assert bad.certificate is not None and not bad.certificate.certified
    assert "not below 1" in bad.certificate.note or "sigma_min" in bad.certificate.note


def test_the_interior_decomposition_bounds_its_loss_of_orthogonality() -> None:
    rng = np.random.default_rng(3)
    X = rng.random((40, 40))
    L = np.diag(np.sum(X + X.T, axis=1)) - (X + X.T) + np.eye(40)
    m = interior_modes_of(L, [0, 5, 7])
    U = m.U
    assert m.orthogonality >= np.linalg.norm(U.T @ U - np.eye(U.shape[0]), 2)
    assert np.allclose(m.g, U.T @ L[np.ix_(m.interior, m.boundary)])


@given(st.integers(0, 10_000))
@settings(max_examples=10, deadline=None)
def test_the_rounding_bound_of_the_cluster_matrix_covers_the_exact_difference(seed: int) -> None:
    s = System(random_clustered_spec(30, 2, seed=seed))
    for c in s.clusters:
        cm = s.cluster_model(c.name)
        n = len(cm.nodes)
        L = s.cluster_laplacian_exact(c.name)
        a, g = Fraction(s.alpha_q), Fraction(s.gamma_q)
        A = cm.A
        d2 = Fraction(0)
        for i in range(n):
            for j in range(n):
                d2 += (Fraction(float(A[n + i, j])) + a * L[i][j]) ** 2
            d2 += (Fraction(float(A[n + i, n + i])) + g) ** 2
        assert float(d2) ** 0.5 <= state_rounding_bound(s, c.name, "normal") * (1 + 1e-12) + 1e-300


def test_the_modal_local_uio_is_an_observer_with_the_dense_spectrum_and_a_decoupled_error() -> None:
    from glocal_verify.observers.uio import local_uio

    s = System(random_clustered_spec(150, 3, seed=3))
    for obs in s.observers():
        a = local_uio(s, obs, method="modal")
        assert "designed in modal coordinates (one eigh of the interior block)" in a.notes
        assert a.hurwitz.value == "holds"
        try:
            b = local_uio(s, obs, method="dense")
        except NotApplicableError:  # the dense observable split of the 2n-state pair can be undecided
            pass
        else:
            assert _match(np.sort_complex(a.eigenvalues), np.sort_complex(b.eigenvalues), 1e-5)
        # eq. obs_decent_error: T E = 0 and T A - F T - K C = 0
        assert np.linalg.norm(a.T @ a.E) < 1e-12
        assert np.linalg.norm(a.T @ a.A - a.F @ a.T - a.K @ a.C) < 1e-9 * np.linalg.norm(a.A)


@pytest.mark.parametrize("seed", [0, 2])
def test_a_cluster_models_sparse_state_matrix_has_the_dense_formulas_entries(seed: int) -> None:
    system = System(random_clustered_spec(30, 3, seed=seed))
    for c in system.clusters:
        for mode in system.modes:
            cm = system.cluster_model(c.name, mode)
            dense = state_matrix(cm.L, system.alpha, system.gamma)
            assert np.array_equal(cm.A, dense) and np.array_equal(cm.A_sparse.toarray(), dense)
            assert cm.A_sparse.nnz == np.count_nonzero(dense) and not cm.A.flags.writeable
