"""The audit with ``growth="verdict"``: the verdicts of the full audit, at the cost of one ZDA per set.

A set whose stealthiness one proven ZDA settles skips the zero set unless the exposure test
needs the fastest zero. Every claim is checked against the full audit and against the
definitions: the separator against networkx's node connectivity, the witness direction
against the 2N pencil of eq. ``zda_cond``.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import networkx as nx
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from strategies import clustered_systems

from glocal_verify import config
from glocal_verify import System
from glocal_verify.design.audit import audit
from glocal_verify.analysis.stealthy.zda_screens import disjoint_paths
from glocal_verify.design.generators import random_clustered_spec
from glocal_verify.errors import GlocalVerifyError

_RANK = {"null": 0, "decaying": 1, "persistent": 2, "unbounded": 4}


def _menger(system: System, F: tuple[Any, ...]) -> int:
    G = nx.Graph()
    G.add_nodes_from(system.labels)
    G.add_edges_from(tuple(k) for k in system.edges())
    src, snk = ("__source__",), ("__sink__",)
    G.add_edges_from((src, f) for f in F)
    G.add_edges_from((m, snk) for m in system.monitored)
    return int(nx.algorithms.connectivity.local_node_connectivity(G, src, snk))


@settings(max_examples=40, deadline=None)
@given(clustered_systems(max_n=12), st.data())
def test_the_flow_separator_counts_the_vertex_disjoint_paths_networkx_counts(system: System, data: st.DataObject) -> None:
    F = tuple(data.draw(st.lists(st.sampled_from(system.labels), min_size=1, max_size=3, unique=True)))
    assert disjoint_paths(system, F) == _menger(system, F)


def _pencil_residual(system: System, F: tuple[Any, ...], d: dict[str, Any]) -> float:
    """||P(lambda0) [x; u]|| / ||[x; u]|| for the row's witness, from the closed loop of eq. ``cl_sys``."""
    n = system.n
    lam = complex(*d["lambda0"])
    xi = np.zeros(n, complex)
    for lab, v in d["xi"].items():
        xi[system.labels.index(next(a for a in system.labels if str(a) == lab))] = complex(*v) if isinstance(v, list) else v
    u = np.array([complex(*d["u0"][str(a)]) if isinstance(d["u0"][str(a)], list) else d["u0"][str(a)] for a in F], complex)
    L = system.laplacian()
    x = np.concatenate([xi, lam * xi])
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-system.alpha * L, -system.gamma * np.eye(n)]])
    B = np.zeros((2 * n, len(F)))
    for j, a in enumerate(F):
        B[n + system.index[a], j] = 1.0
    C = np.vstack([np.eye(2 * n)[[system.index[a] for a in system.monitored_positions]],
                   np.eye(2 * n)[[n + system.index[a] for a in system.monitored_velocities]]])
    r = np.concatenate([(lam * np.eye(2 * n) - A) @ x - B @ u, C @ x])
    return float(np.linalg.norm(r) / np.linalg.norm(np.concatenate([x, u])))


@pytest.fixture(scope="module", params=["with safe modes", "without safe modes"])
def generated(request: pytest.FixtureRequest) -> System:
    # velocity-only monitors: every pair has a persistent ZDA at lambda0 = 0. With safe modes
    # that meet Theorem III.3 the exposure test needs the fastest zero of every stealthy set;
    # without, no verdict does.
    spec = random_clustered_spec(30, 3, seed=7)
    if request.param == "without safe modes":
        spec = dataclasses.replace(spec, modes=spec.modes[:1])
    return System(spec)


@pytest.fixture(scope="module")
def both(generated: System) -> tuple[Any, Any]:
    cands = list(generated.labels[:6]) + list(generated.labels[-6:])
    return audit(generated, 2, cands, growth="verdict"), audit(generated, 2, cands, growth="full")


@pytest.mark.slow
def test_verdict_growth_gives_every_verdict_of_the_full_audit(both: tuple[Any, Any]) -> None:
    lazy, full = both
    key = lambda r: (r.stealthy, r.verdict, r.caught_locally_by, r.exposed_by_modes)
    assert {r.actuators: key(r) for r in lazy.rows} == {r.actuators: key(r) for r in full.rows}


def test_a_skipped_zero_set_leaves_a_proven_lower_bound_on_the_growth(generated: System, both: tuple[Any, Any]) -> None:
    lazy, full = both
    by = {r.actuators: r for r in full.rows}
    skipped = [r for r in lazy.rows if "growth_at_least" in r.witness]
    assert bool(skipped) is (not generated.safe_modes), "the zero set is skipped exactly when no safe mode can expose"
    for r in skipped:
        bound, exact = r.witness["growth_at_least"], by[r.actuators].growth
        assert r.growth in ("undecided", "unbounded")
        if r.growth == "unbounded":
            assert bound == "unbounded" and exact in ("unbounded", "undecided")
        if exact in _RANK:
            assert _RANK[bound] <= _RANK[exact]
        assert _pencil_residual(generated, r.actuators, r.witness["direction"]) < 1e-8
        assert any(abs(complex(*v) if isinstance(v, list) else v) > 0 for v in r.witness["direction"]["u0"].values())


def test_rows_whose_zero_set_was_computed_are_those_of_the_full_audit(both: tuple[Any, Any]) -> None:
    lazy, full = both
    by = {r.actuators: r for r in full.rows}
    for r in lazy.rows:
        if "growth_at_least" not in r.witness:
            assert (r.growth, r.lambda0) == (by[r.actuators].growth, by[r.actuators].lambda0)


def test_an_unknown_growth_option_is_refused(generated: System) -> None:
    with pytest.raises(GlocalVerifyError, match="growth"):
        audit(generated, 1, growth="fast")


def _assert_single_linkage(pts: list[complex], groups: list[list[int]], radius: float) -> dict[int, int]:
    """Every point in one group, close pairs together, no group without a close pair; the labels."""
    close = {(i, j) for i in range(len(pts)) for j in range(len(pts)) if i < j and abs(pts[i] - pts[j]) <= radius}
    label = {i: g for g, grp in enumerate(groups) for i in grp}
    assert sorted(i for grp in groups for i in grp) == list(range(len(pts)))
    assert all(label[i] == label[j] for i, j in close)
    assert all(len(grp) == 1 or any((min(i, j), max(i, j)) in close for i in grp for j in grp if i != j) for grp in groups)
    return label


def test_candidate_zeros_on_one_vertical_line_cluster_as_the_pairwise_rule_says() -> None:
    from glocal_verify.numerics.pencil import cluster_points

    # many candidates share the real part -gamma / 2 (complex zeros of s = lambda^2 + gamma lambda)
    pts = [complex(-0.5, y) for y in np.linspace(-4.0, 4.0, 801)] + [complex(-0.5, 0.0) + 1e-7, complex(3.0, 0.0)]
    _assert_single_linkage(pts, cluster_points(pts, 1e-6), 1e-6)


@pytest.mark.parametrize("seed", range(5))
def test_a_few_candidate_zeros_cluster_as_the_pairwise_rule_says_without_the_tree(seed: int) -> None:
    from glocal_verify.numerics.pencil import cluster_points

    rng = np.random.default_rng(seed)
    base = rng.normal(size=20) + 1j * rng.normal(size=20)
    # chains of near points (single linkage joins them) and exact duplicates
    pts = [complex(z) for z in base] + [complex(base[0] + 0.9e-6), complex(base[0] + 1.8e-6), complex(base[3]), complex(base[5] + 2e-6j)]
    assert len(pts) <= config.get("cluster_dense_max")
    groups = cluster_points(pts, 1e-6)
    label = _assert_single_linkage(pts, groups, 1e-6)
    assert label[0] == label[20] == label[21] and label[3] == label[22] and label[5] != label[23]
    # groups and their members are ordered by (real, imag), as on the tree path
    firsts = [pts[grp[0]] for grp in groups]
    assert firsts == sorted(firsts, key=lambda z: (z.real, z.imag))


@settings(max_examples=5, deadline=None)
@given(clustered_systems(max_n=8))
def test_verdict_growth_never_contradicts_the_exact_audit(system: System) -> None:
    lazy = audit(system, 2, growth="verdict", exact_fallback=False)
    exact = audit(system, 2, exact=True)
    by = {r.actuators: r for r in exact.rows}
    for r in lazy.rows:
        e = by[r.actuators]
        if r.stealthy is not None and e.stealthy is not None:
            assert r.stealthy == e.stealthy
        if r.verdict != "undecided" and e.verdict != "undecided":
            assert r.verdict == e.verdict
        if r.growth == "unbounded" and e.growth != "undecided":
            assert e.growth == "unbounded"
