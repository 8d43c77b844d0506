"""Safe-mode spectra by rank-one updates: checked against the definition (residual, orthonormality)
and against a fresh eigendecomposition, and the verdicts against the eigh path."""

from __future__ import annotations

import networkx as nx
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from strategies import assert_numeric_matches_exact, dense_laplacian, graphs, systems

import glocal_verify.model as model
from glocal_verify import config
from glocal_verify import System, verify
from glocal_verify.design.generators import random_clustered_spec
from glocal_verify.numerics.rank_one import eigh_rank_one_update, eigh_updated
from glocal_verify.numerics.rounding import EPS
from glocal_verify.numerics.spectrum import Spectrum
from glocal_verify.numerics.updated_spectrum import UpdatedSpectrum, update_spectrum


def _assert_eigendecomposition(L: np.ndarray, w: np.ndarray, U: np.ndarray) -> None:
    """(w, U) is an orthonormal eigendecomposition of L to eigh's accuracy (the definition)."""
    n = L.shape[0]
    scale = max(1.0, float(np.abs(np.linalg.eigvalsh(L)).max()))
    assert np.all(np.diff(w) >= 0.0)
    assert np.linalg.norm(U.T @ U - np.eye(n)) <= 100 * n * EPS
    assert np.linalg.norm(L @ U - U * w) <= 100 * n * EPS * scale
    assert np.max(np.abs(w - np.linalg.eigvalsh(L))) <= 100 * n * EPS * scale


def _change(n: int, edges: list[tuple[int, int, float]], data: st.DataObject) -> tuple[int, int, float]:
    """A link change: remove or reweight an existing link, or add a new one."""
    existing = {(i, j): w for i, j, w in edges}
    kind = data.draw(st.sampled_from(["add", "remove", "reweight"]))
    if kind != "add" or len(existing) == n * (n - 1) // 2:
        (i, j) = data.draw(st.sampled_from(sorted(existing)))
        if kind == "remove":
            return i, j, -existing[(i, j)]
        return i, j, data.draw(st.sampled_from([-0.5, 0.5, 2.0])) * existing[(i, j)]
    free = [(i, j) for i in range(n) for j in range(i + 1, n) if (i, j) not in existing]
    i, j = data.draw(st.sampled_from(free))
    return i, j, float(data.draw(st.sampled_from([0.5, 1.0, 3.0])))


@settings(max_examples=80, deadline=None)
@given(graphs(min_n=2, max_n=25, integer=True), st.data())
def test_a_rank_one_update_is_an_eigendecomposition_of_the_changed_laplacian(graph: tuple[int, list[list[int]]], data: st.DataObject) -> None:
    n, raw = graph
    edges = [(int(u) - 1, int(v) - 1, float(w)) for u, v, w in raw]
    L0 = dense_laplacian(n, edges)
    w0, U0 = np.linalg.eigh(L0)
    i, j, rho = _change(n, edges, data)
    L1 = L0 + dense_laplacian(n, [(i, j, rho)])
    got = eigh_rank_one_update(w0, U0, i, j, rho)
    assert got is not None
    _assert_eigendecomposition(L1, *got)


@pytest.mark.parametrize(
    "name,G",
    [
        ("star (eigenvalue 1 of multiplicity 9)", nx.star_graph(10)),
        ("complete graph (one eigenvalue of multiplicity N - 1)", nx.complete_graph(12)),
        ("cycle (every eigenvalue but two doubled)", nx.cycle_graph(16)),
        ("hypercube (high multiplicities)", nx.convert_node_labels_to_integers(nx.hypercube_graph(4))),
    ],
)
def test_repeated_eigenvalues_are_deflated_and_the_update_stays_orthonormal(name: str, G: nx.Graph) -> None:
    n = G.number_of_nodes()
    edges = [(int(u), int(v), 1.0) for u, v in G.edges()]
    L0 = dense_laplacian(n, edges)
    w0, U0 = np.linalg.eigh(L0)
    for i, j, rho in [(edges[0][0], edges[0][1], -1.0), (0, n - 1, 2.0) if not G.has_edge(0, n - 1) else (0, n - 1, 0.5)]:
        got = eigh_rank_one_update(w0, U0, i, j, rho)
        assert got is not None, name
        _assert_eigendecomposition(L0 + dense_laplacian(n, [(i, j, rho)]), *got)


def test_removing_a_bridge_doubles_the_zero_eigenvalue() -> None:
    G = nx.barbell_graph(6, 0)  # two K6 joined by one bridge (5, 6)
    n = G.number_of_nodes()
    edges = [(int(u), int(v), 1.0) for u, v in G.edges()]
    L0 = dense_laplacian(n, edges)
    w0, U0 = np.linalg.eigh(L0)
    got = eigh_rank_one_update(w0, U0, 5, 6, -1.0)
    assert got is not None
    w1, U1 = got
    _assert_eigendecomposition(L0 + dense_laplacian(n, [(5, 6, -1.0)]), w1, U1)
    assert np.all(np.abs(w1[:2]) < 1e-12) and w1[2] > 0.1


def test_successive_updates_compose() -> None:
    G = nx.connected_watts_strogatz_graph(60, 4, 0.3, seed=1)
    edges = [(int(u), int(v), 1.0) for u, v in G.edges()]
    L0 = dense_laplacian(60, edges)
    w0, U0 = np.linalg.eigh(L0)
    changes = [(0, 30, 1.0), (edges[3][0], edges[3][1], -1.0), (5, 45, 0.5)]
    got = eigh_updated(w0, U0, changes)
    assert got is not None
    _assert_eigendecomposition(L0 + dense_laplacian(60, changes), *got)


def test_the_updated_spectrum_certifies_itself_and_encloses_the_exact_eigenvalues() -> None:
    system = System(random_clustered_spec(600, 3, seed=7))
    for mode in system.modes[1:]:
        sp = system.spectrum(mode)
        assert isinstance(sp, UpdatedSpectrum), "the safe mode's spectrum was not an update"
        fresh = Spectrum(system.laplacian(mode))
        assert np.max(np.abs(sp.values - fresh.values)) <= sp.error_radius + fresh.error_radius
        L = system.laplacian(mode)
        U = sp.vectors
        _assert_eigendecomposition(L, sp.values, U)
        # the certified bounds hold for the formed basis, whose entries are within entry_error of
        # the exact product the bounds are about (the definitions, measured directly)
        n = system.n
        widen = n * sp.entry_error
        assert np.linalg.norm(U.T @ U - np.eye(n)) <= sp.orthogonality_error + 2.0 * widen + widen**2
        col = np.linalg.norm(L @ U - U * sp.values, axis=0)
        assert np.all(col <= sp.residuals + (np.abs(L).sum(axis=1).max() + np.abs(sp.values)) * np.sqrt(n) * sp.entry_error)


def test_a_poor_update_is_refused_and_eigh_decides() -> None:
    system = System(random_clustered_spec(120, 3, seed=2))
    base = system.spectrum()
    L1 = system.laplacian(system.modes[1])
    # a wrong change (not the one between the matrices): the residual check refuses it
    assert update_spectrum(L1, base, [(0, 1, 5.0)]) is None


@pytest.mark.slow
def test_verdicts_with_updated_safe_mode_spectra_equal_those_with_fresh_eigendecompositions(monkeypatch: pytest.MonkeyPatch) -> None:
    spec = random_clustered_spec(520, 3, seed=11)
    updated = verify(System(spec))
    with config.override(rank_one_min_agents=10**9):
        fresh = verify(System(spec))
    assert [(c.id, c.status) for c in updated.conditions] == [(c.id, c.status) for c in fresh.conditions]


#: the checkers that read a safe mode's spectrum
SPECTRAL = ["switching.distinct-eigenvalues", "switching.eigenvector-differences", "switched-observability", "privacy.kernel"]


@settings(max_examples=40, deadline=None)
@given(systems(max_n=10, max_modes=2))
def test_numeric_verdicts_from_updated_spectra_never_contradict_exact_arithmetic(system: System) -> None:
    # force the update path at every size (it serves N >= 500 by default): a fresh System reads
    # the threshold when it builds each safe mode's spectrum
    with config.override(rank_one_min_agents=0):
        fresh = System(system.spec)
        assert_numeric_matches_exact(fresh, SPECTRAL)
