"""Proposition III.2 (ii) and (iii): numeric and exact verdicts agree; the placement's reduced
pencil and zero forcing agree with the full pencil; the structured local.pencil (zero forcing,
reduced pencil, lifted directions) agrees with the dense generic analysis in status, normal rank
and zeros, numeric and exact (random integer-weight clusters, N <= 14)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from strategies import assert_numeric_matches_exact, clustered_systems

from glocal_verify import System, verify
from glocal_verify.analysis.local.cluster_pencil import zero_forcing_steps
from glocal_verify.analysis.local.cases import (
    LocalCase,
    full_pencil,
    local_cases,
    pencil_matrices,
    pencil_matrices_exact,
)
from glocal_verify.analysis.local.pencil import pencil_verdict, pencil_verdict_exact
from glocal_verify.design.placement import (
    _intra_neighbours,
    reduced_pencil_holds,
    zero_forcing_closure,
)
from glocal_verify.numerics.pencil import analyze_pencil
from glocal_verify.numerics.pencil_exact import analyze_pencil_exact
from glocal_verify.results import Status


@settings(max_examples=25)
@given(clustered_systems(max_n=12))
def test_numeric_and_exact_verdicts_of_ii_and_iii_agree_on_integer_weight_clusters(system: System) -> None:
    ids = ["local.rank", "local.pencil"]
    assert_numeric_matches_exact(system, ids)


def _key(r):  # type: ignore[no-untyped-def]
    return (r.id, tuple(sorted(r.scope.items())))


def _exact_iii(system: System, case: LocalCase) -> bool:
    if case.structural:
        return False
    A, G, C = pencil_matrices_exact(system, case)
    pe = analyze_pencil_exact(A, G, C, None, directions=False)
    return bool(pe.full_normal_column_rank and not pe.v_star)


@settings(max_examples=25)
@given(clustered_systems(max_n=12), st.data())
def test_the_reduced_pencil_and_zero_forcing_agree_with_the_full_pencil(system: System, data: st.DataObject) -> None:
    for case in local_cases(system):
        if case.kind != "attack" or case.structural:
            continue
        cm = case.model
        # a random measured set containing the boundary, both channels of each agent
        extra = data.draw(st.lists(st.sampled_from(list(cm.nodes)), unique=True, max_size=len(cm.nodes)))
        measured = tuple(a for a in cm.nodes if a in set(extra) | set(cm.boundary))
        from glocal_verify.model import LocalObserver

        c2 = LocalCase(cm, LocalObserver(cm.name, case.observer.center, measured, measured), "attack", case.suspected)
        truth = _exact_iii(system, c2)
        idx = {a: k for k, a in enumerate(cm.nodes)}
        inputs = sorted({idx[a] for a in cm.boundary} | {idx[a] for a in case.suspected})
        M = [idx[a] for a in measured]
        red = reduced_pencil_holds(cm, system.alpha, inputs, M)
        if red is not Status.UNDECIDED:
            assert (red is Status.HOLDS) is truth, (cm.name, measured, case.suspected)
        if len(zero_forcing_closure(_intra_neighbours(cm), M, inputs)) == len(cm.nodes):
            assert truth, (cm.name, measured, case.suspected)


# --------------------------------------------------------------------------------------------
# the structured local.pencil (zero forcing + reduced pencil + lifted directions) against the
# dense generic analysis of the 2n pencil


def _full_vector(case: LocalCase, d: dict) -> np.ndarray:  # type: ignore[type-arg]
    nodes = case.model.nodes
    pos, vel = d["positions"], d["velocities"]
    att, cpl = d["attack_input"], d["coupling_input"]
    x = [complex(pos.get(a, 0)) for a in nodes] + [complex(vel.get(a, 0)) for a in nodes]
    u = [complex(att.get(a, 0)) for a in case.suspected] + [complex(cpl.get(a, 0)) for a in case.model.boundary]
    return np.array(x + u)


def _random_case(system: System, case: LocalCase, data: st.DataObject) -> LocalCase:
    """The case's cluster with random measured positions and velocities (drawn separately, so
    velocity-only agents occur) and a random suspected set."""
    from glocal_verify.model import LocalObserver

    cm = case.model
    nodes = list(cm.nodes)
    pos = data.draw(st.lists(st.sampled_from(nodes), unique=True, max_size=len(nodes)))
    vel = data.draw(st.lists(st.sampled_from(nodes), unique=True, max_size=len(nodes)))
    if data.draw(st.booleans()):  # often (ii): every boundary velocity measured
        vel = list(dict.fromkeys(vel + list(cm.boundary)))
    susp = data.draw(st.lists(st.sampled_from(nodes), unique=True, max_size=3))
    pos_t = tuple(a for a in nodes if a in pos)
    vel_t = tuple(a for a in nodes if a in vel)
    return LocalCase(cm, LocalObserver(cm.name, case.observer.center, pos_t, vel_t), "attack", tuple(a for a in nodes if a in susp))


@settings(max_examples=30)
@given(clustered_systems(max_n=12), st.data())
def test_structured_and_dense_pencils_agree_on_status_normal_rank_and_zeros(system: System, data: st.DataObject) -> None:
    seen = set()
    for case0 in local_cases(system):
        if case0.model.name in seen:
            continue
        seen.add(case0.model.name)
        case = _random_case(system, case0, data)
        d = pencil_verdict(system, case, method="dense")
        s_ = pencil_verdict(system, case, method="structured")
        sd, md, wd, ss, ms, ws = d.status, d.margin, d.witness, s_.status, s_.margin, s_.witness
        if Status.UNDECIDED in (sd, ss):
            continue
        assert ss is sd, (case.observer, case.suspected, wd, ws)
        if ss is Status.FAILS:
            assert ms == 0.0
        else:
            assert ms > 0.0 and md > 0.0
        if case.structural:
            continue
        assert ws["normal_rank"] == wd["normal_rank"], (case.observer, case.suspected)
        assert ws["full_normal_column_rank"] is wd["full_normal_column_rank"]
        if not ws["full_normal_column_rank"]:
            v = _full_vector(case, ws["direction"])
            P = full_pencil(case, complex(ws["direction"]["lambda"]))
            assert np.linalg.norm(P @ v) <= 1e-8 * np.linalg.norm(P, 2) * np.linalg.norm(v)
            continue
        # every structured zero is a zero of the full pencil, with a verified direction
        A, G, C = pencil_matrices(case)
        dense_all = [z.value for z in analyze_pencil(A, G, C, None).zeros]
        for z in ws["zeros"]:
            lam = complex(z["lambda"])
            v = _full_vector(case, z)
            P = full_pencil(case, lam)
            assert z["verified"] is True
            assert np.linalg.norm(P @ v) <= 1e-8 * np.linalg.norm(P, 2) * np.linalg.norm(v)
            assert min(abs(lam - x) for x in dense_all) < 1e-5 * max(1.0, abs(lam)), (lam, dense_all)
        if ws.get("zero_count", 0) <= 12:
            mine = [complex(z["lambda"]) for z in ws["zeros"]]
            for x in dense_all:
                assert min(abs(x - y) for y in mine) < 1e-5 * max(1.0, abs(x)), (x, mine)


@settings(max_examples=20)
@given(clustered_systems(max_n=10), st.data())
def test_structured_exact_agrees_with_dense_exact_and_with_numeric(system: System, data: st.DataObject) -> None:
    seen = set()
    for case0 in local_cases(system):
        if case0.model.name in seen:
            continue
        seen.add(case0.model.name)
        case = _random_case(system, case0, data)
        d = pencil_verdict_exact(system, case, method="dense", margin=False)
        s_ = pencil_verdict_exact(system, case, method="structured", margin=False)
        sd, wd, ss, ws = d.status, d.witness, s_.status, s_.witness
        assert ss is sd, (case.observer, case.suspected, wd, ws)
        if not case.structural:
            assert ws["normal_rank"] == wd["normal_rank"]
            if ws["method"] == "structured" and "zero_polynomial" in ws and ss is Status.FAILS and ws["full_normal_column_rank"]:
                assert ws["zero_polynomial"] == wd["zero_polynomial"]
            for z in ws.get("zeros", []):
                if "positions" in z:
                    v = _full_vector(case, z)
                    P = full_pencil(case, complex(z["lambda"]))
                    assert np.linalg.norm(P @ v) <= 1e-8 * np.linalg.norm(P, 2) * np.linalg.norm(v)
        sn = pencil_verdict(system, case, method="structured", margin=False).status
        if sn is not Status.UNDECIDED:
            assert sn is ss


@settings(max_examples=15)
@given(clustered_systems(max_n=12))
def test_verify_with_the_structured_method_agrees_between_numeric_and_exact(system: System) -> None:
    opts = {"local_pencil_method": "structured"}
    num = {_key(r): r for r in verify(system, ["local.pencil"], options=opts).conditions}
    exa = {_key(r): r for r in verify(system, ["local.pencil"], exact=True, options=opts).conditions}
    for k, rn in num.items():
        assert exa[k].status is not Status.UNDECIDED
        if rn.status is not Status.UNDECIDED:
            assert rn.status is exa[k].status, (k, rn.witness, exa[k].witness)


@settings(max_examples=25)
@given(clustered_systems(max_n=12), st.data())
def test_a_complete_zero_forcing_means_a_triangular_minor_with_nonzero_diagonal(system: System, data: st.DataObject) -> None:
    """The proof behind zero forcing: the forcing rows and forced columns, in forcing order, form
    a lower triangular block of Q(s) whose diagonal does not depend on s."""
    cm = system.cluster_model(system.clusters[0].name)
    n = len(cm.nodes)
    M = data.draw(st.lists(st.integers(0, n - 1), unique=True, max_size=n))
    I = data.draw(st.lists(st.integers(0, n - 1), unique=True, max_size=n))
    nbrs = _intra_neighbours(cm)
    steps = zero_forcing_steps(nbrs, M, I)
    assert len(zero_forcing_closure(nbrs, M, I)) == len(set(M)) + len(steps)
    rows = [r for r, _ in steps]
    cols = [k for _, k in steps]
    assert not set(rows) & set(I) and not set(cols) & set(M)
    for s in (0.0, 1.7, -0.4 + 2.1j):
        Qs = (s * np.eye(n) + system.alpha * cm.L)[np.ix_(rows, cols)]
        assert np.allclose(np.triu(Qs, 1), 0.0)
        assert np.all(np.abs(np.diag(Qs)) > 0) and np.allclose(np.diag(Qs), np.diag(system.alpha * cm.L[np.ix_(rows, cols)]))
