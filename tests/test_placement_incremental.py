"""The greedy placement's incremental zero forcing agrees with the full closure."""

from __future__ import annotations

import random

from glocal_verify import System
from glocal_verify.analysis.local.cluster_pencil import intra_neighbours, zero_forcing_closure
from glocal_verify.design import placement as pl
from glocal_verify.design.generators import random_clustered_spec


def test_forcing_from_a_closed_set_plus_one_agent_gives_the_full_closure() -> None:
    system = System(random_clustered_spec(120, 2, seed=3))
    rng = random.Random(1)
    for c in system.clusters:
        nbrs = intra_neighbours(system.cluster_model(c.name).L)
        n = len(nbrs)
        for _ in range(40):
            inputs = set(rng.sample(range(n), rng.randint(0, 5)))
            M = set(rng.sample(range(n), rng.randint(1, n // 3)))
            Z = zero_forcing_closure(nbrs, M, inputs)
            for a in rng.sample(range(n), 8):
                assert pl._closure_size_with(nbrs, Z, inputs, a) == len(zero_forcing_closure(nbrs, M | {a}, inputs))
