"""ZDA analysis cross-validation: structured (modal, N-sized) vs generic dense (2N pencil),
and numeric vs exact (rational) on integer-weight graphs, repeated eigenvalues included.

A decided numeric answer that disagrees with the other path is a bug; ``undecided`` is
allowed (and must stay rare).
"""

from __future__ import annotations

import networkx as nx
import numpy as np
from hypothesis import example, given
from hypothesis import strategies as st
from strategies import systems

from glocal_verify import System, spec_from_graph, verify
from glocal_verify.analysis.stealthy.zda import ZdaAnalysis, zda_analysis
from glocal_verify.analysis.stealthy.zda_exact import zda_analysis_exact
from glocal_verify.results import Status


def _attacked(data: st.DataObject, system: System) -> tuple[int, ...]:
    labels = list(system.labels)
    return tuple(data.draw(st.lists(st.sampled_from(labels), unique=True, min_size=1, max_size=min(3, len(labels))), label="F"))


def _same_values(a: list[complex], b: list[complex], tol: float = 1e-6) -> bool:
    def distinct(v: list[complex]) -> list[complex]:
        out: list[complex] = []
        for x in v:
            if all(abs(x - y) > 1e-9 * (1 + abs(x)) for y in out):
                out.append(x)
        return out

    a, b = distinct(a), distinct(b)
    return len(a) == len(b) and all(min(abs(x - y) for y in b) <= tol * (1 + abs(x)) for x in a)


def _check_direction(system: System, F: tuple[int, ...], za: ZdaAnalysis) -> None:
    if za.direction is None:
        return
    d = za.direction.direction()
    A, B, C = system.A(), system.B(F), system.C()
    n = A.shape[0]
    lam = d.lambda0
    v = np.concatenate([d.x0, d.u0])
    scale = (np.linalg.norm(lam * np.eye(n) - A, 2) + 1.0) * np.linalg.norm(v)
    assert np.linalg.norm((lam * np.eye(n) - A) @ d.x0 - B @ d.u0) <= 1e-8 * scale
    assert np.linalg.norm(C @ d.x0) <= 1e-8 * scale
    assert np.linalg.norm(d.u0) > 1e-6 * np.linalg.norm(v)


def _twins_example() -> System:
    G = nx.Graph()
    G.add_weighted_edges_from([(1, 2, 1), (2, 3, 2), (2, 4, 1), (3, 5, 2), (4, 5, 1), (5, 6, 1)])
    return System(spec_from_graph(G, monitor_velocities=[1, 6]))


@example(system=_twins_example(), data=None)  # type: ignore[arg-type]
@given(systems(max_n=30, integer=False), st.data())
def test_structured_and_dense_zda_analyses_agree(system: System, data: st.DataObject | None) -> None:
    F = (3, 4) if data is None else _attacked(data, system)
    stc = zda_analysis(system, actuators=F)
    den = zda_analysis(system, actuators=F, method="dense")
    _check_direction(system, F, stc)
    _check_direction(system, F, den)
    if not (stc.decided and den.decided):
        return
    assert stc.left_invertible == den.left_invertible
    assert stc.normal_rank == den.normal_rank
    assert _same_values([z.value for z in stc.zeros], [z.value for z in den.zeros])
    assert stc.exists == den.exists


@example(system=_twins_example(), data=None)  # type: ignore[arg-type]
@given(systems(max_n=12), st.data())
def test_numeric_and_exact_zda_analyses_agree_on_integer_weight_graphs(system: System, data: st.DataObject | None) -> None:
    F = (3, 4) if data is None else _attacked(data, system)
    num = zda_analysis(system, actuators=F)
    exa = zda_analysis_exact(system, actuators=F)
    assert exa.left_invertible == (exa.normal_kernel_dim == 0)
    if num.decided:
        assert num.left_invertible == exa.left_invertible
        assert num.normal_rank == exa.normal_rank
        assert _same_values([z.value for z in num.zeros], [z.value for z in exa.zeros])
        assert _same_values([z.value for z in num.unobservable], [z.value for z in exa.unobservable])
    if num.exists or num.decided:
        assert num.exists == exa.exists
    for z in exa.zeros:  # exact directions satisfy the pencil and carry an input
        d = z.direction()
        A, B, C = system.A(), system.B(F), system.C()
        n = A.shape[0]
        P = np.vstack([np.hstack([d.lambda0 * np.eye(n) - A, -B]), np.hstack([C, np.zeros((C.shape[0], len(F)))])])
        v = np.concatenate([d.x0, d.u0])
        assert np.linalg.norm(P @ v) <= 1e-8 * np.linalg.norm(P, 2) * np.linalg.norm(v)
        assert np.linalg.norm(d.u0) > 1e-9


@given(systems(max_n=10, max_modes=2))
def test_numeric_and_exact_switching_safe_agree_when_the_directions_coincide(system: System) -> None:
    if not system.attacked or not system.safe_modes:
        return
    num = zda_analysis(system)
    exa = zda_analysis_exact(system)
    if num.direction is None or exa.direction is None:
        return
    a, b = num.direction.xi, exa.direction.xi
    if abs(num.direction.value - exa.direction.value) > 1e-8 or np.linalg.norm(a - b) > 1e-8 * np.linalg.norm(b):
        return  # a multi-dimensional kernel: the two paths may pick different directions
    rn = {r.scope["mode"]: r for r in verify(system, ["switching.avoids-attack"]).conditions}
    re_ = {r.scope["mode"]: r for r in verify(system, ["switching.avoids-attack"], exact=True).conditions}
    for mode, r in re_.items():
        assert r.status is not Status.UNDECIDED
        if rn[mode].status is not Status.UNDECIDED:
            assert rn[mode].status is r.status, (mode, rn[mode].witness, r.witness)
