"""Every tunable is read where it is in force: a ``config.override`` reaches every place that uses it.

Two halves. On the source: no module keeps a tunable in a constant of its own (no read of
``config`` at import, in a module or class body or in a default argument), an argument named
after a tunable defaults to "the value in force", and every name read is a tunable. On the
behaviour: a property test over all tunables (the resolver returns the value in force), and one
check per family of tunables that its readers follow an override.
"""

from __future__ import annotations

import ast
import dataclasses
import math
from fractions import Fraction
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from glocal_verify import System, config, load_example
from glocal_verify.errors import NotApplicableError
from glocal_verify.spec.types import ImplementationSpec

from test_architecture import PACKAGE

_READS = ("get", "default", "resolve")


def _config_calls(node: ast.AST) -> list[ast.Call]:
    return [n for n in ast.walk(node) if isinstance(n, ast.Call) and isinstance(n.func, ast.Attribute) and isinstance(n.func.value, ast.Name) and n.func.value.id == "config" and n.func.attr in _READS]


def _eager_config_calls(node: ast.AST) -> list[ast.Call]:
    """The reads of ``config`` that run when ``node`` is evaluated (not those inside a lambda,
    such as a dataclass field's ``default_factory``, which run at each construction)."""
    if isinstance(node, ast.Lambda):
        return []
    f = node.func if isinstance(node, ast.Call) else None
    here = [node] if isinstance(f, ast.Attribute) and isinstance(f.value, ast.Name) and f.value.id == "config" and f.attr in _READS else []
    return here + [c for child in ast.iter_child_nodes(node) for c in _eager_config_calls(child)]


def _sources() -> list[tuple[str, ast.Module]]:
    return [(str(p.relative_to(PACKAGE)), ast.parse(p.read_text(encoding="utf-8"))) for p in sorted(PACKAGE.rglob("*.py")) if p.name != "config.py"]


def test_no_module_reads_a_tunable_at_import_into_a_constant_or_a_default() -> None:
    frozen = []
    for name, tree in _sources():
        bodies = [tree.body] + [n.body for n in ast.walk(tree) if isinstance(n, ast.ClassDef)]
        for body in bodies:
            for node in body:
                if isinstance(node, (ast.Assign, ast.AnnAssign, ast.AugAssign)) and node.value is not None and _eager_config_calls(node.value):
                    frozen.append(f"{name}:{node.lineno} {ast.unparse(node)[:80]}")
        for fn in ast.walk(tree):
            if isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
                for d in [*fn.args.defaults, *(d for d in fn.args.kw_defaults if d is not None)]:
                    if _eager_config_calls(d):
                        frozen.append(f"{name}:{fn.lineno} default {ast.unparse(d)[:80]}")
    assert not frozen, frozen


def test_an_argument_named_after_a_tunable_defaults_to_the_value_in_force() -> None:
    """``exact_budget=30.0`` written in a signature would not follow an override."""
    literal = []
    for name, tree in _sources():
        for fn in ast.walk(tree):
            if not isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            args = [*fn.args.posonlyargs, *fn.args.args]
            pairs = list(zip(args[len(args) - len(fn.args.defaults):], fn.args.defaults)) + list(zip(fn.args.kwonlyargs, fn.args.kw_defaults))
            for arg, d in pairs:
                if arg.arg in config.TUNABLES and d is not None and not (isinstance(d, ast.Constant) and d.value is None) and ast.unparse(d) != "config.IN_FORCE":
                    literal.append(f"{name}:{fn.lineno} {fn.name}({arg.arg}={ast.unparse(d)})")
    assert not literal, literal


def test_every_tunable_read_names_a_tunable() -> None:
    unknown = []
    for name, tree in _sources():
        for call in _config_calls(tree):
            if call.args and isinstance(call.args[0], ast.Constant) and call.args[0].value not in config.TUNABLES:
                unknown.append(f"{name}:{call.lineno} {call.args[0].value!r}")
    assert not unknown, unknown


def _valid(t: config.Tunable) -> st.SearchStrategy[Any]:
    if isinstance(t.default, tuple):
        return st.lists(st.floats(0.0, 1.0), min_size=1, max_size=4).map(tuple)
    if isinstance(t.default, int):
        return st.integers(0, 10**6)
    return st.floats(0.0, 1e9, allow_nan=False)


@settings(max_examples=200, deadline=None)
@given(st.sampled_from(sorted(config.TUNABLES)).flatmap(lambda n: st.tuples(st.just(n), _valid(config.TUNABLES[n]))))
def test_every_tunable_overridden_is_what_the_resolver_reads_and_nothing_else_moves(pair: tuple[str, Any]) -> None:
    name, value = pair
    before = dict(config.defaults())
    with config.override(**{name: value}):
        got = config.get(name)
        assert config.resolve(name) == got == config.resolve(name, config.IN_FORCE) == config.defaults()[name]
        assert got == (tuple(float(x) for x in value) if isinstance(value, tuple) else value)
        assert config.resolve(name, "given") == "given"  # the argument wins
        assert {k: v for k, v in config.defaults().items() if k != name} == {k: v for k, v in before.items() if k != name}
    assert dict(config.defaults()) == before


# ------------------------------------------------------------------------------------------
# one behavioural check per family: the readers follow an override


@pytest.fixture(scope="module")
def paper19() -> System:
    return System(load_example("paper19"))


def test_the_fragile_cut_of_the_answer_follows_the_value_in_force() -> None:
    """answer/attack.py compared with a copy taken at import: --fragile-below and overrides were ignored."""
    from glocal_verify.answer.attack import THEOREM_IDS, AttackEvidence, ModeEvidence, answer_attack
    from glocal_verify.results import Status

    mode = ModeEvidence("q", {c: Status.HOLDS for c in THEOREM_IDS}, Status.FAILS, 1e-6, "unbounded")
    ev = AttackEvidence("zda", (1,), ((None, (1,), ()),), Status.HOLDS, 1.0, "", (), (mode,))
    assert not answer_attack(ev).modes[0].fragile
    with config.override(fragile_below=1e-3):
        assert "1e-06" in answer_attack(ev).modes[0].fragile
    assert answer_attack(dataclasses.replace(ev, fragile_below=1e-3)).modes[0].fragile  # the run's own value


def test_the_run_limits_follow_the_values_in_force(paper19: System) -> None:
    from glocal_verify.answer.run import simulates
    from glocal_verify.conditions.cost import SpecSizes, estimate_verify
    from glocal_verify.conditions.registry import check_conditions

    assert simulates(paper19)
    with config.override(detects_max_agents=paper19.n - 1):
        assert not simulates(paper19)
    sizes = SpecSizes.from_spec(paper19.spec)
    with config.override(exact_budget=123.0):
        assert estimate_verify(sizes, ["privacy.kernel"]).extra_seconds == 123.0
        assert check_conditions(paper19, ["privacy.kernel"]).options["exact_budget"] == 123.0
        assert check_conditions(paper19, ["privacy.kernel"], exact_budget=None).options["exact_budget"] is None
    with config.override(fragile_below=0.25):
        assert check_conditions(paper19, ["privacy.kernel"]).options["fragile_below"] == 0.25


def test_the_size_limits_follow_the_values_in_force(paper19: System) -> None:
    from glocal_verify.conditions.cost import CostEstimate, check_limits, default_limits
    from glocal_verify.simulation.guarantees import detection_guarantee
    from glocal_verify.simulation.limits import SizeEstimate, SizeLimitError, check_size

    check_size(SizeEstimate(1000.0, 1e6))
    with config.override(simulation_max_samples=10), pytest.raises(SizeLimitError):
        check_size(SizeEstimate(1000.0, 1e6))
    with config.override(simulation_max_bytes=10), pytest.raises(SizeLimitError):
        check_size(SizeEstimate(1000.0, 1e6))
    est = CostEstimate("verify", 19, 5.0, 1e6)
    check_limits(est)
    with config.override(max_seconds=1.0), pytest.raises(SizeLimitError):
        check_limits(est)
    with config.override(max_bytes=1.0):
        assert default_limits().bytes == 1.0
    sampled = System(dataclasses.replace(paper19.spec, implementation=ImplementationSpec(Fraction(1, 10), controller="sampled")))
    with config.override(guarantee_max_agents=paper19.n - 1), pytest.raises(NotApplicableError, match="agents >"):
        detection_guarantee(sampled)


def test_the_design_tunables_once_read_at_import_follow_the_values_in_force() -> None:
    import numpy as np

    from glocal_verify.design import multilink

    d = np.array([1.0, 2.0])
    T = np.eye(2)
    assert multilink.rank_one_update(d, T, 0, 1.0) is not None
    seen: list[int] = []
    real = config.get

    def spy(name: str) -> Any:
        seen.append(name)  # type: ignore[arg-type]
        return real(name)

    with config.override(multilink_bisection_steps=3):
        config.get = spy  # type: ignore[assignment]
        try:
            multilink.rank_one_update(d, T, 0, 1.0)
        finally:
            config.get = real  # type: ignore[assignment]
    assert "multilink_bisection_steps" in seen


def test_a_tunable_argument_wins_over_the_value_in_force_and_none_reads_it(paper19: System) -> None:
    from glocal_verify.design.monitors import design_monitors

    assert design_monitors(paper19, verify_design=False).method == "exact"  # a few agents: exhaustive by default
    with config.override(monitors_exact_max_agents=0):
        assert design_monitors(paper19, verify_design=False).method == "greedy"
        assert design_monitors(paper19, exact_limit=10**6, verify_design=False).method == "exact"
    assert math.isfinite(config.resolve("exact_budget"))
