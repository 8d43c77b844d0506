"""One question, one answer: the audit row, ``verify`` on that attack and design's before-table agree.

For every attacker set of at most two actuators on random small networks (with and without safe
modes, local observers and a ``[switching]`` schedule), the answer of
:func:`glocal_verify.answer.attack.answer_attack` read from the audit row equals the one
``verify`` attaches to the report of the spec with that attack, and the one design's
before-table lists; and ``--require`` passes exactly when every required id is favourable.
"""

from __future__ import annotations

import pytest
import dataclasses
from typing import Any

import hypothesis.strategies as st
from hypothesis import given, settings
from strategies import graphs

from glocal_verify import System, spec_from_dict, verify
from glocal_verify.answer.attack import ANSWER_IDS as ANSWER_READS
from glocal_verify.answer.attack import AttackAnswer
from glocal_verify.answer.gate import require
from glocal_verify.design.audit import audit
from glocal_verify.design.network import before_table
from glocal_verify.results import Polarity, Report
from glocal_verify.spec.types import AttackSpec

#: the conditions the answer reads, without the simulation (which never decides it)
ANSWER_IDS = [cid for cid in ANSWER_READS if cid != "switching.detects"]


@st.composite
def glocal_specs(draw: st.DrawFn, max_n: int = 8) -> dict[str, Any]:
    """A small connected network with random clusters, observers, monitors, safe modes and schedule."""
    n, edges = draw(graphs(min_n=3, max_n=max_n, connected=True))
    labels = list(range(1, n + 1))
    data: dict[str, Any] = {"format": 1, "name": "one-answer", "graph": {"nodes": n, "edges": edges}}
    k = draw(st.integers(0, 2))
    if k:
        cut = draw(st.integers(1, n - 1)) if k == 2 else n
        parts = [labels[:cut], labels[cut:]] if k == 2 else [labels]
        clusters = []
        for i, members in enumerate(parts):
            obs = [{"center": draw(st.sampled_from(members))}] if draw(st.integers(0, 3)) else []
            clusters.append({"name": f"P{i + 1}", "nodes": members, "observers": obs})
        data["clusters"] = clusters
    data["monitor"] = {"velocities": draw(st.lists(st.sampled_from(labels), unique=True, min_size=1, max_size=max(1, n // 3)))}
    present = {(min(e[0], e[1]), max(e[0], e[1])) for e in edges}
    absent = [(u, v) for u in labels for v in labels if u < v and (u, v) not in present]
    modes = []
    for q in range(draw(st.integers(0, 2))):
        if absent and draw(st.booleans()):
            u, v = draw(st.sampled_from(absent))
            modes.append({"name": f"s{q + 1}", "add": [[u, v, draw(st.integers(1, 3))]]})
        else:
            u, v = draw(st.sampled_from(sorted(present)))
            modes.append({"name": f"s{q + 1}", "remove": [[u, v]], "add": [[u, v, draw(st.integers(4, 5))]]})
    if modes:
        data["modes"] = modes
        if draw(st.booleans()):
            data["switching"] = {"mode": draw(st.sampled_from([m["name"] for m in modes])), "time": 2.0}
    data["attack"] = {"kind": "zda", "actuators": [labels[0]]}
    if draw(st.booleans()):
        data["attack"]["lambda0"] = draw(st.sampled_from([0.5, 1.0, 0.0]))
    return data


def _answer_key(a: AttackAnswer) -> tuple[Any, ...]:
    """What must be identical everywhere: the verdict, each route's verdict, and the parts."""
    return (
        a.verdict,
        tuple((r.name, r.verdict) for r in a.routes),
        a.stealthy,
        a.caught_locally,
        tuple(sorted((c, str(o)) for c, o in a.caught_locally_by)),
        a.exposed_by_modes,
        a.not_exposed_by_modes,
        a.unsettled_modes,
    )


def _verify_with(system: System, F: tuple[int, ...]) -> Report:
    spec = system.spec
    attack = dataclasses.replace(spec.attack, actuators=F) if spec.attack is not None else AttackSpec("zda", F)
    return verify(System(dataclasses.replace(spec, attack=attack)), ANSWER_IDS, simulate="never", exact_budget=None)


@pytest.mark.slow
@settings(max_examples=12)
@given(glocal_specs())
def test_the_audit_verify_and_designs_before_table_give_one_answer_for_every_small_attacker(data: dict[str, Any]) -> None:
    system = System(spec_from_dict(data))
    result = audit(system, 2)
    before = before_table(system, 2)
    assert [r.actuators for r in before.rows] == [r.actuators for r in result.rows]
    for row, brow in zip(result.rows, before.rows):
        assert row.answer is not None and brow.answer is not None
        expected = _answer_key(_verify_with(system, row.actuators).assessment.attack)
        assert _answer_key(row.answer) == expected, (row.actuators, row.answer.reason)
        assert _answer_key(brow.answer) == expected, (row.actuators, brow.answer.reason)


@st.composite
def _gated(draw: st.DrawFn) -> tuple[dict[str, Any], list[str]]:
    data = draw(glocal_specs(max_n=7))
    ids = draw(st.lists(st.sampled_from(ANSWER_IDS + ["privacy.kernel", "privacy.initial-state", "switching.coverage"]), min_size=1, max_size=3, unique=True))
    return data, ids


@settings(max_examples=12)
@given(_gated())
def test_require_passes_exactly_when_every_required_id_is_favourable(case: tuple[dict[str, Any], list[str]]) -> None:
    data, ids = case
    report = verify(System(spec_from_dict(data)), simulate="never", exact_budget=None)
    by_definition = all(
        (rs := report.results(cid))
        and all(r.polarity in (Polarity.FAVOURABLE, Polarity.VACUOUS) for r in rs)
        and any(r.polarity is Polarity.FAVOURABLE for r in rs)
        for cid in ids
    )
    outcome = require(report, ids)
    assert outcome.passed is bool(by_definition), outcome.failures
    assert outcome.passed is (not outcome.failures)
