"""Exact invariant subspaces from a Laplacian's symmetries (numerics.symmetry): equitable cells, their differences, twins."""

from __future__ import annotations

from fractions import Fraction

from glocal_verify.numerics.minors import verified_invariant_subspace
from glocal_verify.numerics.symmetry import equitable_cells, equitable_differences, twin_modes


def _laplacian(edges: dict[tuple[int, int], Fraction]) -> dict[tuple[int, int], Fraction]:
    L: dict[tuple[int, int], Fraction] = {}
    for (i, j), w in edges.items():
        for a, b, v in ((i, j, -w), (j, i, -w), (i, i, w), (j, j, w)):
            L[(a, b)] = L.get((a, b), Fraction(0)) + v
    return L


def _two_identical_clusters_on_a_hub() -> tuple[int, dict[tuple[int, int], Fraction]]:
    """Agent 0 is the hub; 1-4 and 5-8 are the same weighted cluster, each joined to the hub at its first agent."""
    cluster = {(0, 1): Fraction(2), (1, 2): Fraction(3), (1, 3): Fraction(1, 7), (2, 3): Fraction(5)}
    edges: dict[tuple[int, int], Fraction] = {}
    for off in (1, 5):
        edges.update({(off + a, off + b): w for (a, b), w in cluster.items()})
        edges[(0, off)] = Fraction(1)
    return 9, _laplacian(edges)


def _mul(L: dict[tuple[int, int], Fraction], x: list[Fraction]) -> list[Fraction]:
    y = [Fraction(0)] * len(x)
    for (i, j), v in L.items():
        y[i] += v * x[j]
    return y


def test_identical_clusters_on_a_hub_share_their_cells_and_the_partition_is_equitable() -> None:
    n, L = _two_identical_clusters_on_a_hub()
    cell = equitable_cells(n, L, [0])
    assert [cell[a] == cell[a + 4] for a in range(1, 5)] == [True] * 4
    assert len(set(cell)) == 5  # the hub and the four positions of the cluster
    for a in range(n):
        for b in range(n):
            if cell[a] == cell[b]:
                for c in set(cell):
                    row_sum = lambda x: sum((v for (i, j), v in L.items() if i == x and cell[j] == c), Fraction(0))  # noqa: E731
                    assert row_sum(a) == row_sum(b)


def test_the_differences_of_the_cells_span_an_exact_invariant_subspace_that_vanishes_on_the_agents_kept_apart() -> None:
    n, L = _two_identical_clusters_on_a_hub()
    rows = equitable_differences(n, L, [0])
    assert len(rows) == n - len(set(equitable_cells(n, L, [0])))
    assert all(r[0] == 0 for r in rows)
    verified = verified_invariant_subspace(n, L, [0], rows)
    assert verified is not None and len(verified[0]) == len(rows)  # L W = W B exactly, W zero on agent 0


def test_an_agent_kept_apart_leaves_a_cell_of_its_own_and_breaks_the_symmetry_it_touches() -> None:
    n, L = _two_identical_clusters_on_a_hub()
    cell = equitable_cells(n, L, [0, 2])
    assert all(cell[a] != cell[2] for a in range(n) if a != 2)
    assert cell[2] != cell[6] and cell[1] != cell[5]
    assert all(r[2] == 0 for r in equitable_differences(n, L, [0, 2]))


def test_twin_leaves_give_exact_eigenvectors_that_vanish_on_the_measured_agents() -> None:
    L = _laplacian({(0, 1): Fraction(2), (0, 2): Fraction(2), (0, 3): Fraction(2), (0, 4): Fraction(1)})
    modes = twin_modes(5, L, [3])
    assert [mu for mu, _ in modes] == [Fraction(2)]
    (mu, pairs), = modes
    assert all(3 not in p for p in pairs) and len(pairs) == 1
    a, r = pairs[0]
    x = [Fraction(0)] * 5
    x[a], x[r] = Fraction(1), Fraction(-1)
    assert _mul(L, x) == [mu * v for v in x]
