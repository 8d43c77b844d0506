"""stealthy.zda when the numeric zero set is not certified: the maximal minors decide, modulo the
unobservable modes proved exactly (those of identical clusters and twins from the equitable partition)."""

from __future__ import annotations

import random

import networkx as nx
from near_degenerate_attacks import near_twin_spec, system_of

from glocal_verify import System, config, spec_from_graph
from glocal_verify.analysis.laplacian.twins import laplacian_entries
from glocal_verify.analysis.stealthy.zda_screens import global_tables
from glocal_verify.analysis.stealthy.zda_verdict import ZdaOptions, decide_zda
from glocal_verify.numerics.symmetry import equitable_cells
from glocal_verify.results import Status
from glocal_verify.spec.types import NORMAL_MODE


def test_near_twins_the_numeric_zero_set_cannot_certify_are_decided_by_the_maximal_minors_as_over_q() -> None:
    exact = decide_zda(system_of(near_twin_spec(12)), options=ZdaOptions(exact=True))
    v = decide_zda(system_of(near_twin_spec(12)))
    assert v.status is exact.status is Status.FAILS
    assert "maximal minors decide" in v.note and "maximal minor" in v.proof
    with config.override(zda_certificate_max_seconds=0.0):  # the minors' tables out of their time share
        assert decide_zda(system_of(near_twin_spec(12))).status is Status.UNDECIDED


def _copies_on_a_hub(copies: int, size: int = 9, seed: int = 0) -> System:
    """``copies`` identical random clusters joined to hub 1 at the same agent, three twin leaves on the hub; the hub's velocity is monitored."""
    rng = random.Random(seed)
    template = {(rng.randrange(k), k): rng.choice([1, 2, 3]) for k in range(1, size)}
    for _ in range(size // 2):
        a, b = sorted(rng.sample(range(size), 2))
        template.setdefault((a, b), rng.choice([1, 2, 3]))
    G = nx.Graph()
    port = rng.randrange(size)
    for c in range(copies):
        off = 2 + c * size
        G.add_weighted_edges_from((off + a, off + b, w) for (a, b), w in template.items())
        G.add_edge(1, off + port, weight=1)
    G.add_weighted_edges_from((1, 2 + copies * size + k, 2) for k in range(3))
    return System(spec_from_graph(G, monitor_velocities=[1], attack={"kind": "zda", "actuators": [2, 3]}))


def test_the_global_tables_divide_out_every_mode_of_the_equitable_partition_of_identical_clusters() -> None:
    for copies in (2, 3):
        system = _copies_on_a_hub(copies)
        M = system.idx(system.monitored)
        cells = len(set(equitable_cells(system.n, laplacian_entries(system, NORMAL_MODE), M)))
        tables = global_tables(system)
        assert tables is not None
        # the differences within the cells are unobservable (proved exactly by the tables); the
        # eigenvectors of the copies' modes are irrational, so floating point alone finds few of them
        assert tables.unobservable_dim >= system.n - cells >= (copies - 1) * 9
