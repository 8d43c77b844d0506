"""The fast design path of the unknown-input observers meets the conditions it states.

On random clustered networks large enough for the reduced Hurwitz certificate (cluster states
>= 150), every designed observer satisfies the decoupling condition of Proposition III.2
(rank(C E) = rank(E), T E = 0), the error identity T A - F T - K C = 0 of eq.
``obs_decent_error``, and its Hurwitz verdict agrees with the dense certificate and with an
independent eigenvalue computation. The building blocks (closed-form square placement,
triangular condition numbers, sparse Krylov split) are checked against their definitions.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from glocal_verify import config
from glocal_verify import System
from glocal_verify.design.generators import random_clustered_spec
from glocal_verify.numerics.tolerance import DEFAULT_TOLERANCE
from glocal_verify.numerics import hurwitz
from glocal_verify.observers import uio_existence as ue
from glocal_verify.observers.uio import design_uio, local_uio
from glocal_verify.results import Status


@pytest.fixture(scope="module", params=[3, 7])
def network(request: pytest.FixtureRequest) -> System:
    return System(random_clustered_spec(240, clusters=3, seed=request.param))


def _designs(system: System) -> list[tuple[np.ndarray, np.ndarray, np.ndarray, dict]]:  # type: ignore[type-arg]
    out = []
    for lo in system.observers():
        cm = system.cluster_model(lo.cluster)
        C = cm.C(lo.positions, lo.velocities)
        _, d = design_uio(cm.A, cm.E, C, gamma=system.gamma)
        out.append((cm.A, cm.E, C, d))
    return out


def test_the_random_clusters_are_large_enough_for_the_reduced_certificate(network: System) -> None:
    for lo in network.observers():
        assert 2 * len(network.cluster_model(lo.cluster).nodes) >= config.get("uio_reduced_min_states")


def test_designed_observers_meet_the_decoupling_condition_of_proposition_III_2(network: System) -> None:
    for A, E, C, d in _designs(network):
        assert np.linalg.matrix_rank(C @ E) == np.linalg.matrix_rank(E)
        assert np.linalg.norm(d["T"] @ E) <= 1e-10 * max(1.0, float(np.linalg.norm(E)))
        assert d["decoupling_residual"] <= 1e-12


def test_designed_observers_satisfy_the_error_identity(network: System) -> None:
    for A, E, C, d in _designs(network):
        res = d["T"] @ A - d["F"] @ d["T"] - d["K"] @ C
        assert np.linalg.norm(res) <= 1e-10 * (np.linalg.norm(A) + np.linalg.norm(d["F"]))
        assert d["error_residual"] <= 1e-12
        assert np.allclose(d["F"], d["A1"] - d["K1"] @ C)
        assert np.allclose(d["K"], d["K1"] + d["F"] @ d["h"])


def test_the_reduced_certificate_agrees_with_the_dense_one(network: System) -> None:
    for A, E, C, d in _designs(network):
        cert = hurwitz.hurwitz_certificate(d["F"], DEFAULT_TOLERANCE)
        st, ratio = cert.status, cert.ratio
        assert d["hurwitz"] is st
        assert d["hurwitz_ratio"] == pytest.approx(ratio, rel=1e-3)


def test_certified_observers_have_every_eigenvalue_of_F_in_the_open_left_half_plane(network: System) -> None:
    for A, E, C, d in _designs(network):
        w = np.linalg.eigvals(d["F"])
        reported = d["eigenvalues"]
        assert len(reported) == len(w)
        assert max(float(np.min(np.abs(w - z))) for z in reported) <= 1e-8 * max(1.0, float(np.max(np.abs(w))))
        if d["hurwitz"] is Status.HOLDS:
            assert np.max(w.real) < 0
            assert d["hurwitz_margin"] == pytest.approx(-float(np.max(w.real)), rel=1e-6, abs=1e-9)


def test_the_default_design_moves_only_slow_modes_to_the_left_of_09_sigma(network: System) -> None:
    for A, E, C, d in _designs(network):
        if d["notes"]:  # the ladder moved fewer modes; its own test covers it
            continue
        sigma = network.gamma / 2
        assert np.all(np.asarray(d["poles"]).real <= -0.9 * sigma + 1e-9)


def test_local_uio_on_a_large_cluster_gives_a_certified_observer() -> None:
    system = System(random_clustered_spec(240, clusters=3, seed=3))
    lo = next(iter(system.observers()))
    obs = local_uio(system, lo)
    assert obs.n_states >= config.get("uio_reduced_min_states")
    assert obs.hurwitz is Status.HOLDS
    assert np.max(np.linalg.eigvals(obs.F).real) < 0


@pytest.mark.parametrize("seed", range(6))
def test_the_square_placement_puts_the_poles_where_asked_and_matches_place_poles(seed: int) -> None:
    from scipy.signal import place_poles

    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 9))
    X = rng.standard_normal((n, n))
    B = rng.standard_normal((n, n))
    p = np.asarray(ue.default_poles(np.linalg.eigvals(X), 1.0), dtype=complex)
    G = ue._place_square(X, B, p)
    assert G is not None
    assert ue._placed(X - B @ G, p)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ref = place_poles(X, B, p.real if np.all(p.imag == 0) else p).gain_matrix
    assert np.allclose(G, ref, rtol=1e-6, atol=1e-8 * max(1.0, float(np.abs(ref).max())))


@pytest.mark.parametrize("seed", range(4))
def test_triangular_condition_numbers_match_their_definition(seed: int) -> None:
    import scipy.linalg

    rng = np.random.default_rng(seed)
    n = 12
    M = rng.standard_normal((n, n))
    S, _ = scipy.linalg.schur(M, output="real")
    Tc = hurwitz._real_to_complex_schur(S)
    assert np.allclose(np.tril(Tc, -1), 0.0)
    w0 = np.linalg.eigvals(M)
    assert max(float(np.min(np.abs(w0 - z))) for z in np.diag(Tc)) <= 1e-10 * float(np.max(np.abs(w0)))
    kappa = hurwitz._triangular_kappa(Tc)
    w, vl, vr = scipy.linalg.eig(Tc, left=True, right=True)
    ref = np.linalg.norm(vl, axis=0) * np.linalg.norm(vr, axis=0) / np.abs(np.sum(vl.conj() * vr, axis=0))
    twin = np.zeros(n, dtype=bool)
    twin[np.flatnonzero(np.diag(S, -1) != 0.0) + 1] = True  # second members of conjugate pairs
    paired = hurwitz._triangular_kappa(Tc, twin)
    for i, z in enumerate(np.diag(Tc)):
        j = int(np.argmin(np.abs(w - z)))
        assert kappa[i] == pytest.approx(ref[j], rel=1e-6)
        assert paired[i] == pytest.approx(ref[j], rel=1e-6)


def test_the_sparse_krylov_split_spans_the_same_subspaces_as_the_dense_one(network: System, monkeypatch: pytest.MonkeyPatch) -> None:
    lo = next(iter(network.observers()))
    cm = network.cluster_model(lo.cluster)
    C = cm.C(lo.positions, lo.velocities)
    ex = ue.uio_existence(cm.A, cm.E, C)
    assert ex.A1 is not None and ex.split is not None
    with config.override(sparse_min=10**9):
        dense = ue.observable_split(ex.A1, C)
        sp = ex.split
        assert sp.Qo.shape == dense.Qo.shape and sp.decided == dense.decided
        # same subspace: the projections onto them agree
        assert np.linalg.norm(sp.Qo @ sp.Qo.T - dense.Qo @ dense.Qo.T, 2) <= 1e-6
        if sp.Qu.shape[1]:
            assert np.linalg.norm(C @ sp.Qu) <= 1e-9 * max(1.0, float(np.linalg.norm(C)))
            AQ = ex.A1 @ sp.Qu
            assert np.linalg.norm(AQ - sp.Qu @ (sp.Qu.T @ AQ)) <= 1e-6 * max(1.0, float(np.linalg.norm(ex.A1, 2)))


def test_large_cluster_designs_are_certified_without_the_dense_eigendecomposition(network: System, monkeypatch: pytest.MonkeyPatch) -> None:
    import glocal_verify.observers.uio as uio

    def dense(F: np.ndarray, tol: object) -> None:
        raise AssertionError("dense certificate used")

    monkeypatch.setattr(uio, "hurwitz_eigenvalues", dense)
    for A, E, C, d in _designs(network):
        assert d["hurwitz"] is Status.HOLDS


def test_the_slow_mode_ladder_keeps_the_reduced_certificate_exact(network: System, monkeypatch: pytest.MonkeyPatch) -> None:
    import glocal_verify.observers.uio as uio

    real = uio._certify
    calls: list[int] = []

    def first_undecided(F, Qo, Qu, red, tol):  # type: ignore[no-untyped-def]
        got = real(F, Qo, Qu, red, tol)
        calls.append(1)
        return hurwitz.HurwitzCertificate(Status.UNDECIDED, got.ratio, got.eigenvalues) if len(calls) == 1 else got

    monkeypatch.setattr(uio, "_certify", first_undecided)
    with config.override(uio_ladder_gain=0.0):
        lo = next(iter(network.observers()))
        cm = network.cluster_model(lo.cluster)
        C = cm.C(lo.positions, lo.velocities)
        _, d = design_uio(cm.A, cm.E, C, gamma=network.gamma)
        assert len(calls) >= 2 and any("retried moving only" in n for n in d["notes"])
        cert = hurwitz.hurwitz_certificate(d["F"], DEFAULT_TOLERANCE)
        st, ratio = cert.status, cert.ratio
        assert d["hurwitz"] is st
        assert d["hurwitz_ratio"] == pytest.approx(ratio, rel=1e-3)
        w = np.linalg.eigvals(d["F"])
        assert max(float(np.min(np.abs(w - z))) for z in d["eigenvalues"]) <= 1e-8 * max(1.0, float(np.max(np.abs(w))))
