"""Proposition III.2 (ii) and (iii): numeric and exact verdicts agree; the placement's reduced
pencil and zero forcing agree with the full pencil (random integer-weight clusters, N <= 14)."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from glocal_verify import System, verify
from glocal_verify.local import LocalCase, local_cases, pencil_matrices_exact
from glocal_verify.pencil import analyze_pencil_exact
from glocal_verify.placement import _intra_neighbours, reduced_pencil_holds, zero_forcing_closure
from glocal_verify.results import Status
from strategies import clustered_systems


def _key(r):  # type: ignore[no-untyped-def]
    return (r.id, tuple(sorted(r.scope.items(), key=str)))


@settings(max_examples=25)
@given(clustered_systems(max_n=12))
def test_numeric_and_exact_verdicts_of_ii_and_iii_agree_on_integer_weight_clusters(system: System) -> None:
    ids = ["local.rank", "local.pencil"]
    num = {_key(r): r for r in verify(system, ids).conditions}
    exa = {_key(r): r for r in verify(system, ids, exact=True).conditions}
    assert num.keys() == exa.keys()
    for k, rn in num.items():
        re_ = exa[k]
        assert re_.status is not Status.UNDECIDED
        if rn.status is not Status.UNDECIDED:
            assert rn.status is re_.status, (k, rn.witness, re_.witness)


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
