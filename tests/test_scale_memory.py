"""Memory of the observability analyses: index sets and views, not N x N copies.

Ground truth: the modal parts are checked against the definition (``E`` spans eigenvectors,
``W = E ∩ ker S_M``), dimensions against exact rational ranks, and memory with ``tracemalloc``
against a small multiple of one ``N x N`` array once the spectrum (which holds ``U``) exists.
"""

from __future__ import annotations

import tracemalloc

import networkx as nx
import numpy as np

from glocal_verify import System, spec_from_graph
from glocal_verify.analysis.unobservable.modal import modal_decomposition
from glocal_verify.analysis.unobservable.switched import (
    certified_switched,
    mode_sequence,
    switched_unobservable_subspace,
)
from glocal_verify.analysis.unobservable.subspace import (
    certified_unobservable,
    unobservable_subspace,
    unobservable_subspace_exact,
)
from glocal_verify.design.generators import random_clustered_spec
from glocal_verify.numerics.tolerance import Decision


def _warm_spectra(s: System) -> None:
    """Compute what the System caches per mode (eigenpairs and their certified bounds)."""
    for mode in s.modes:
        sp = s.spectrum(mode)
        _ = (sp.residuals, sp.orthogonality_error, sp.error_radius, sp.clusters)


def test_the_parts_of_simple_eigenvalues_are_views_of_the_eigenvector_matrix() -> None:
    s = System(random_clustered_spec(120, clusters=6, seed=2))
    for mode in s.modes:
        w, U = s.eigh(mode)
        md = modal_decomposition(s, mode)
        for g in md.groups:
            if g.zero is Decision.ZERO:
                continue
            assert np.shares_memory(g.E, U)
            for part in (g.W, g.W_upper, g.Wx, g.Wx_upper):
                assert part.shape[1] == 0 or np.shares_memory(part, U)
            # E spans eigenvectors of its value; W lies in ker S_M (the definition)
            L = s.laplacian(mode)
            assert np.linalg.norm(L @ g.E - g.E * w[list(g.indices)]) < 1e-9 * max(1.0, abs(g.value))
            m = s.idx(s.monitored)
            assert g.W.shape[1] == 0 or np.linalg.norm(g.W[m, :]) < 1e-9


def test_the_observability_analyses_allocate_at_most_a_few_n_by_n_arrays() -> None:
    n = 300
    s = System(random_clustered_spec(n, clusters=15, seed=3))
    _warm_spectra(s)
    seq = mode_sequence(s)
    assert seq is not None
    tracemalloc.start()
    try:
        for mode in s.modes:
            unobservable_subspace(s, mode)
            certified_unobservable(s, mode)
        switched_unobservable_subspace(s, seq)
        certified_switched(s, seq)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    one = n * n * 8
    assert peak < 4 * one, f"peak {peak / one:.2f} N x N arrays"


def test_a_multiple_eigenvalue_with_a_proper_kernel_keeps_the_exact_dimension() -> None:
    # star with 9 leaves: mu = 1 has multiplicity 8; two leaf monitors leave a 6-dim W_1
    G = nx.star_graph(9)
    s = System(spec_from_graph(nx.relabel_nodes(G, {v: v + 1 for v in G}), monitor_velocities=[2, 3]))
    md = modal_decomposition(s)
    multiple = [g for g in md.groups if len(g.indices) > 1]
    assert multiple and multiple[0].W.shape[1] == 6
    S = unobservable_subspace(s)
    assert S.decided and S.dim == len(unobservable_subspace_exact(s, "normal"))
    C, A = s.C(), s.A()
    for v in S.basis.T:
        assert np.linalg.norm(C @ v) < 1e-12
        assert np.linalg.norm(C @ (A @ v)) < 1e-9
    cu = certified_unobservable(s)
    assert cu.dim_lower <= S.dim <= cu.dim_upper


def test_position_monitors_absent_give_the_whole_group_as_its_position_kernel_without_copies() -> None:
    s = System(random_clustered_spec(80, clusters=4, seed=1))
    assert not s.monitored_positions
    _, U = s.eigh()
    for g in modal_decomposition(s).groups:
        assert g.Wx.shape[1] == len(g.indices)
        if g.zero is not Decision.ZERO:
            assert np.shares_memory(g.Wx, U)
