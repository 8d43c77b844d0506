"""The touch test of switching.avoids-attack has one home: every form reaches the rule's functions.

``decide_avoidance`` is the rule (its numeric part decides the avoiding subspace with
``avoiding_subspace`` and a direction with ``direction_touch``); ``switching.detects`` (the
attacker's choice), the case study's findings (``zda_touched``) and the safe-mode design's screen
(``_exposes``) call it instead of deciding the touch themselves.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from glocal_verify import System
from glocal_verify.analysis.switching import avoidance as rule
from glocal_verify.spec import load_example


def _recording(monkeypatch: pytest.MonkeyPatch, owner: Any, name: str) -> list[Any]:
    calls: list[Any] = []
    original = getattr(owner, name)

    def wrapper(*args: Any, **kwargs: Any) -> Any:
        calls.append(args)
        return original(*args, **kwargs)

    monkeypatch.setattr(owner, name, wrapper)
    return calls


@pytest.fixture(scope="module")
def paper19() -> System:
    return System(load_example("paper19"))


def test_the_rule_decides_the_avoiding_subspace_with_the_shared_touch_test(monkeypatch: pytest.MonkeyPatch, paper19: System) -> None:
    from glocal_verify.analysis.stealthy.zda_verdict import ZdaOptions, decide_zda

    calls = _recording(monkeypatch, rule, "avoiding_subspace")
    z = decide_zda(paper19, paper19.attacked, ZdaOptions(lambda0=paper19.spec.attack.lambda0))
    for mode in paper19.safe_modes:
        rule.decide_avoidance(paper19, mode, z)
    assert calls


def test_the_attackers_choice_of_switching_detects_calls_the_rule(monkeypatch: pytest.MonkeyPatch, paper19: System) -> None:
    from glocal_verify.conditions.detects import _attacker_choice
    from glocal_verify.conditions.registry import CheckContext
    from glocal_verify.simulation.attacks import zda_attack_from_direction

    calls = _recording(monkeypatch, rule, "decide_avoidance")
    atk = zda_attack_from_direction(paper19, 0.5, np.ones(paper19.n), np.ones(len(paper19.attacked)))
    _attacker_choice(paper19, paper19.safe_modes[0], atk, CheckContext())
    assert calls and calls[0][1] == paper19.safe_modes[0]


def test_the_case_studys_touch_is_the_rules_direction_test(monkeypatch: pytest.MonkeyPatch, paper19: System) -> None:
    from glocal_verify.conditions.detects import zda_touched
    from glocal_verify.design.case_study import case_findings, cases_for, companion_systems, run_case

    calls = _recording(monkeypatch, rule, "direction_touch")
    cases = cases_for(paper19, companion_systems(paper19))
    outcomes = [run_case(c) for c in cases]
    case_findings(outcomes)
    assert calls
    # the answer is the rule's: untouched exactly where its direction test says ZERO
    for oc in outcomes:
        atk = oc.result.attack
        if atk is not None and atk.xi is not None:
            t = rule.direction_touch(oc.case.system, oc.case.mode, np.asarray(atk.xi))
            assert zda_touched(oc.case.system, oc.case.mode, atk) == t.touched


def test_the_safe_mode_designs_screen_calls_the_rules_avoiding_subspace(monkeypatch: pytest.MonkeyPatch) -> None:
    from glocal_verify.design import safe_modes
    from glocal_verify.design.symmetry import SymmetryTarget

    assert safe_modes.avoiding_subspace is rule.avoiding_subspace
    calls = _recording(monkeypatch, safe_modes, "avoiding_subspace")
    rng = np.random.default_rng(0)
    X = np.linalg.qr(rng.standard_normal((6, 2)))[0]
    target = SymmetryTarget((1, 2), X, rng.standard_normal((2, 2)))
    exposed = safe_modes._exposes(target, 0, 3, 1e-6)
    assert calls
    # with two directions and one link, some combination avoids it and keeps an input
    assert exposed is False
