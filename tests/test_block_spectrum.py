"""A clustered normal mode decomposed cluster by cluster, its links between clusters added as rank-one factors.

Checked against the definitions: the block spectrum against its dense form, the factored
normal spectrum's certified bounds against the exact product in extended precision, its
verdicts against exact arithmetic (the block path forced at small N) and against the ``eigh``
path at the size where it starts by default.
"""

from __future__ import annotations

import math

import networkx as nx
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from strategies import assert_numeric_matches_exact, dense_laplacian, extended_product

import glocal_verify.model as model
import glocal_verify.numerics.updated_spectrum as updated_module
from glocal_verify import config
from glocal_verify import System, spec_from_dict, verify
from glocal_verify.design.generators import random_clustered_spec
from glocal_verify.numerics.block_spectrum import BlockSpectrum
from glocal_verify.numerics.spectrum import Spectrum
from glocal_verify.numerics.updated_spectrum import UpdatedSpectrum, update_spectrum

LD = np.longdouble


@st.composite
def _clustered_graph(draw: st.DrawFn) -> tuple[int, list[list[int]], list[tuple[int, int, float]]]:
    """(N, blocks of indices, links (i, j, w)): connected clusters, a few links between them."""
    sizes = draw(st.lists(st.integers(2, 9), min_size=2, max_size=4))
    blocks, links, start = [], [], 0
    for k in sizes:
        idx = list(range(start, start + k))
        G = nx.gnp_random_graph(k, 0.5, seed=draw(st.integers(0, 10**6)))
        for a in range(1, k):  # a spanning path keeps the cluster connected
            G.add_edge(a - 1, a)
        links += [(idx[u], idx[v], float(draw(st.integers(1, 3)))) for u, v in G.edges()]
        blocks.append(idx)
        start += k
    for b in range(1, len(blocks)):
        for _ in range(draw(st.integers(1, 2))):
            links.append((draw(st.sampled_from(blocks[b - 1])), draw(st.sampled_from(blocks[b])), float(draw(st.integers(1, 3)))))
    return start, blocks, links


def _split(blocks: list[list[int]], links: list[tuple[int, int, float]]) -> tuple[list[tuple[int, int, float]], list[tuple[int, int, float]]]:
    """(links inside the blocks, links between them)."""
    owner = {i: b for b, blk in enumerate(blocks) for i in blk}
    return [x for x in links if owner[x[0]] == owner[x[1]]], [x for x in links if owner[x[0]] != owner[x[1]]]


@settings(max_examples=60, deadline=None)
@given(_clustered_graph())
def test_a_block_spectrum_is_its_dense_eigendecomposition(case: tuple[int, list[list[int]], list[tuple[int, int, float]]]) -> None:
    n, blocks, links = case
    inside, _ = _split(blocks, links)
    L0 = dense_laplacian(n, inside)
    sp = BlockSpectrum(L0, tuple(np.array(b) for b in blocks))
    U = sp.vectors
    assert np.all(np.diff(sp.values) >= 0)
    assert np.linalg.norm(L0 @ U - U * sp.values) <= 1e-12 * n * max(1.0, float(np.abs(L0).max()))
    assert np.linalg.norm(U.T @ U - np.eye(n)) <= sp.orthogonality_error
    assert np.allclose(sp.values, np.linalg.eigvalsh(L0), atol=1e-12 * n * 10)
    rows, cols = [0, n - 1, n // 2], [0, n // 2, n - 1]
    assert np.array_equal(sp.rows(rows), U[rows])
    assert np.array_equal(sp.columns(cols), U[:, cols])
    X = np.arange(2.0 * n).reshape(n, 2)
    assert np.allclose(sp.apply(X), U @ X) and np.allclose(sp.project(X), U.T @ X)
    assert np.allclose(sp.abs_apply(X[:, 0]), np.abs(U) @ np.abs(X[:, 0]))
    assert np.allclose(sp.residuals, np.linalg.norm(L0 @ U - U * sp.values, axis=0), atol=1e-13 * n)
    with pytest.raises(ValueError):
        BlockSpectrum(dense_laplacian(n, links), tuple(np.array(b) for b in blocks))  # links between blocks: not block diagonal


@settings(max_examples=60, deadline=None)
@given(_clustered_graph())
def test_the_normal_mode_from_blocks_and_links_bounds_itself_in_extended_precision(case: tuple[int, list[list[int]], list[tuple[int, int, float]]]) -> None:
    n, blocks, links = case
    inside, cut = _split(blocks, links)
    L = dense_laplacian(n, links)
    base = BlockSpectrum(dense_laplacian(n, inside), tuple(np.array(b) for b in blocks))
    with config.override(update_accept=math.inf):
        sp = update_spectrum(L, base, cut)
    if sp is None:
        return
    U, widen = extended_product(sp)
    assert float(np.sqrt(np.sum((U.T @ U - np.eye(n, dtype=LD)) ** 2))) <= sp.orthogonality_error + widen
    R = L.astype(LD) @ U - U * sp.values.astype(LD)
    res = np.sqrt(np.sum(R**2, axis=0)).astype(float)
    assert np.all(res <= sp.residuals + widen * (np.abs(L).sum() + np.abs(sp.values)))
    assert float(np.sqrt(np.sum(R**2))) <= sp.residual_frobenius + widen * np.abs(L).sum() * n
    assert np.all(np.abs(sp.rows(range(n)) - U.astype(float)) <= sp.entry_error + widen)
    assert np.all(np.abs(sp.columns(range(n)) - U.astype(float)) <= sp.entry_error + widen)
    # the safe mode that adds a link continues the chain
    i, j = blocks[0][0], blocks[-1][-1]
    Lq = L + dense_laplacian(n, [(i, j, 1.0)])
    with config.override(update_accept=math.inf):
        sq = update_spectrum(Lq, sp, [(i, j, 1.0)])
    if sq is None:
        return
    assert len(sq.factors) == len(sp.factors) + 1 and isinstance(sq.base, BlockSpectrum)
    Uq = U @ sq.factors[-1].apply(np.eye(n)).astype(LD)
    widen += 3.0 * math.sqrt(n) * sq.factors[-1].rotation_rounding
    resq = np.sqrt(np.sum((Lq.astype(LD) @ Uq - Uq * sq.values.astype(LD)) ** 2, axis=0)).astype(float)
    assert np.all(resq <= sq.residuals + widen * (np.abs(Lq).sum() + np.abs(sq.values)))
    assert float(np.sqrt(np.sum((Uq.T @ Uq - np.eye(n, dtype=LD)) ** 2))) <= sq.orthogonality_error + widen


@st.composite
def _clustered_systems_with_modes(draw: st.DrawFn) -> System:
    n, blocks, links = draw(_clustered_graph())
    labels = list(range(1, n + 1))
    edges = {(min(i, j) + 1, max(i, j) + 1): int(w) for i, j, w in links}
    clusters = [{"name": f"P{b + 1}", "nodes": [i + 1 for i in blk], "observers": [{"center": blk[0] + 1}]} for b, blk in enumerate(blocks)]
    modes = []
    for k in range(draw(st.integers(0, 2))):
        u, v = sorted(draw(st.lists(st.sampled_from(labels), min_size=2, max_size=2, unique=True)))
        modes.append({"name": f"m{k + 1}", "remove": [[u, v]]} if (u, v) in edges else {"name": f"m{k + 1}", "add": [[u, v, 1]]})
    data = {
        "format": 1,
        "name": "hyp-blocks",
        "graph": {"nodes": n, "edges": [[u, v, w] for (u, v), w in sorted(edges.items())]},
        "clusters": clusters,
        "monitor": {"velocities": draw(st.lists(st.sampled_from(labels), unique=True, min_size=1, max_size=max(1, n // 3)))},
        "modes": modes,
        "attack": {"kind": "zda", "actuators": draw(st.lists(st.sampled_from(labels), unique=True, min_size=1, max_size=2))},
    }
    return System(spec_from_dict(data))


GLOBAL = ["switching.distinct-eigenvalues", "switching.eigenvector-differences", "switched-observability", "privacy.unobservable", "stealthy.zda"]


@pytest.mark.slow
@settings(max_examples=30, deadline=None)
@given(_clustered_systems_with_modes())
def test_numeric_verdicts_from_a_normal_mode_built_from_blocks_never_contradict_exact_arithmetic(system: System) -> None:
    with config.override(block_min_agents=0, rank_one_min_agents=0):
        fresh = System(system.spec)
        assert_numeric_matches_exact(fresh, GLOBAL)


@pytest.mark.slow
def test_the_normal_mode_of_a_large_clustered_network_is_built_from_blocks_and_gives_the_eigh_verdicts(monkeypatch: pytest.MonkeyPatch) -> None:
    spec = random_clustered_spec(config.get("block_min_agents"), 3, seed=7)
    system = System(spec)
    factored = verify(system)
    sp = system.spectrum()
    assert isinstance(sp, UpdatedSpectrum) and isinstance(sp.base, BlockSpectrum)
    for mode in system.modes:
        s = system.spectrum(mode)
        assert isinstance(s, UpdatedSpectrum) and not s.formed, f"{mode}: a check formed the whole basis"
    fresh = Spectrum(system.laplacian_sparse())
    assert np.max(np.abs(sp.values - fresh.values)) <= sp.error_radius + fresh.error_radius
    with config.override(block_min_agents=10**9, rank_one_min_agents=10**9):
        reference = verify(System(spec))
    assert [(c.id, c.scope, c.status) for c in factored.conditions] == [(c.id, c.scope, c.status) for c in reference.conditions]


@pytest.mark.slow
def test_a_normal_mode_of_many_small_clusters_is_kept_from_blocks_and_is_as_sharp_as_eigh() -> None:
    # ten clusters of 200 agents and nine links between them: the blocks' radius is far below
    # eigh's, the links cost some of it, and the result is still kept (its radius against the one
    # an eigh of the whole matrix carries)
    system = System(random_clustered_spec(config.get("block_min_agents"), 10, seed=3, cut_edges=1, chords=1.0))
    sp = system.spectrum()
    assert isinstance(sp, UpdatedSpectrum) and isinstance(sp.base, BlockSpectrum) and len(sp.factors) == 9
    fresh = Spectrum(system.laplacian_sparse())
    assert sp.error_radius <= fresh.error_radius
    assert np.max(np.abs(sp.values - fresh.values)) <= sp.error_radius + fresh.error_radius


@pytest.mark.parametrize("seed", range(60))
def test_every_laplacian_entry_is_the_exact_rational_sum_rounded_once_whatever_the_denominators(seed: int) -> None:
    import random
    from fractions import Fraction

    from glocal_verify.numerics.block_spectrum import laplacian_csr

    rnd = random.Random(seed)
    n = rnd.randint(2, 25)
    links = []
    for _ in range(rnd.randint(1, 50)):
        i, j = sorted(rnd.sample(range(n), 2))
        kind = rnd.random()
        if kind < 0.4:
            w = Fraction(rnd.randint(1, 10 ** rnd.randint(1, 30)), rnd.randint(1, 10 ** rnd.randint(0, 30)))
        elif kind < 0.8:
            w = Fraction(rnd.random())  # a double's exact value: denominators up to 2^53
        else:
            w = Fraction(rnd.randint(1, 5))
        links.append((i, j, w))
    L = laplacian_csr(n, links).toarray()
    exact = [[Fraction(0)] * n for _ in range(n)]
    for i, j, w in links:
        exact[i][j] -= w
        exact[j][i] -= w
        exact[i][i] += w
        exact[j][j] += w
    for i in range(n):
        for j in range(n):
            if i != j and exact[i][j] != 0 and sum(1 for a, b, _ in links if {a, b} == {i, j}) > 1:
                continue  # repeated links are stored as separate entries of the same link (CSR sums them)
            assert L[i, j] == float(exact[i][j]), (i, j)
