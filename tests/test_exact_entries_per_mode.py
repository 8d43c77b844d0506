"""The exact Laplacian entries of a safe mode, derived from the normal mode and the changed links, equal L_q built from its own edges."""

from __future__ import annotations

from fractions import Fraction

import pytest

from glocal_verify import System, load_example
from glocal_verify.analysis.laplacian.twins import laplacian_entries
from glocal_verify.design.generators import adverse_family


def _systems() -> list[System]:
    out = [System(load_example("paper19"))]
    out += [System(m.spec()) for m in adverse_family(60, 6, seed=3) if m.modes]
    return out


@pytest.mark.parametrize("k", range(6))
def test_every_mode_s_exact_entries_are_those_of_its_own_edges(k: int) -> None:
    systems = _systems()
    if k >= len(systems):
        pytest.skip("fewer members with safe modes")
    system = systems[k]
    for mode in system.modes:
        dense = system.laplacian_exact(mode)
        want = {(i, j): v for i, row in enumerate(dense) for j, v in enumerate(row) if v != 0 or (i == j and system.adjacency(mode)[system.labels[i]])}
        assert dict(laplacian_entries(system, mode)) == want, mode
        for c in system.clusters:
            idx = [system.index[a] for a in c.nodes]
            block = {(a, b): dense[i][j] for a, i in enumerate(idx) for b, j in enumerate(idx) if dense[i][j] != Fraction(0)}
            assert dict(system.cluster_laplacian_entries(c.name, mode)) == block, (mode, c.name)
