"""The block-cut tree's attach points against the definition: equal potentials for every current between the terminals."""

from __future__ import annotations

import random

import flint
import pytest

from glocal_verify.analysis.laplacian.blocks import block_cut_tree


def _graph(seed: int) -> tuple[int, list[tuple[int, int]], dict[tuple[int, int], int]]:
    """A connected graph with many cut vertices: a random tree and a few chords, weights 1..3."""
    rnd = random.Random(seed)
    n = rnd.randint(3, 18)
    edges = {(i, rnd.randrange(i)) for i in range(1, n)}
    for _ in range(rnd.randint(0, n // 2)):
        a, b = rnd.sample(range(n), 2)
        if (a, b) not in edges and (b, a) not in edges:
            edges.add((a, b))
    return n, sorted(edges), {e: rnd.randint(1, 3) for e in edges}


def _potentials(n: int, weights: dict[tuple[int, int], int], F: list[int]) -> list[list[flint.fmpq]]:
    """y_k with L y_k = e_f1 - e_fk, y_k[n - 1] = 0, over Q (the grounded Laplacian is nonsingular on a connected graph)."""
    L = flint.fmpq_mat(n - 1, n - 1)
    for (a, b), w in weights.items():
        for i, j, s in ((a, a, w), (b, b, w), (a, b, -w), (b, a, -w)):
            if i < n - 1 and j < n - 1:
                L[i, j] += s
    out = []
    for k in range(1, len(F)):
        rhs = flint.fmpq_mat(n - 1, 1)
        for idx, sign in ((F[0], 1), (F[k], -1)):
            if idx < n - 1:
                rhs[idx, 0] += sign
        y = L.solve(rhs)
        out.append([y[i, 0] for i in range(n - 1)] + [flint.fmpq(0)])
    return out


@pytest.mark.parametrize("seed", range(150))
def test_an_agent_shares_the_potential_of_its_attach_point_for_every_current_between_the_terminals(seed: int) -> None:
    n, edges, weights = _graph(seed)
    tree = block_cut_tree(range(n), edges)
    rnd = random.Random(1000 + seed)
    for m in (2, 3):
        F = rnd.sample(range(n), m)
        attach = tree.attach_points(F, range(n))
        for y in _potentials(n, weights, F):
            for v in range(n):
                assert y[v] == y[attach[v]], (seed, F, v, attach[v])


def test_the_terminals_and_the_blocks_between_them_attach_to_themselves() -> None:
    # two triangles 0-1-2 and 2-3-4 sharing the cut vertex 2, a pendant path 4-5-6
    edges = [(0, 1), (1, 2), (2, 0), (2, 3), (3, 4), (4, 2), (4, 5), (5, 6)]
    tree = block_cut_tree(range(7), edges)
    assert tree.cuts == frozenset({2, 4, 5})
    attach = tree.attach_points([0, 3], range(7))
    assert [attach[v] for v in range(7)] == [0, 1, 2, 3, 4, 4, 4]
    attach = tree.attach_points([0, 1], range(7))
    assert [attach[v] for v in range(7)] == [0, 1, 2, 2, 2, 2, 2]


def test_the_tree_rooted_at_a_vertex_puts_its_node_at_depth_zero() -> None:
    tree = block_cut_tree(range(5), [(0, 1), (1, 2), (2, 3), (3, 4)], root=4)
    assert tree.depth[tree.home[4]] == 0
    assert tree.path(tree.home[0], tree.home[4]) is not None
