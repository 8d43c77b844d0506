"""The tunables live in one place, documented, readable by name and overridable for a block of code."""

from __future__ import annotations

import ast
import math

import pytest

from glocal_verify import System, config, load_example, verify
from glocal_verify.analysis.local.cases import local_cases
from glocal_verify.analysis.local.pencil import pencil_verdict
from glocal_verify.errors import ConfigError, GlocalVerifyError

from test_architecture import PACKAGE


def test_every_tunable_says_what_it_decides_in_which_unit_why_and_where() -> None:
    assert len(config.TUNABLES) >= 45
    for name, t in config.TUNABLES.items():
        assert t.name == name and name == name.lower()
        assert t.unit and t.meaning and t.why, name
        assert (PACKAGE.parent / (t.home.replace(".", "/") + ".py")).exists(), (name, t.home)


def test_every_tunable_is_read_by_the_module_that_owns_it() -> None:
    for name, t in config.TUNABLES.items():
        text = (PACKAGE.parent / (t.home.replace(".", "/") + ".py")).read_text(encoding="utf-8")
        assert f'"{name}"' in text or f"'{name}'" in text, (name, t.home)


def test_an_override_holds_inside_its_block_only_and_a_reset_restores_the_defaults() -> None:
    before = config.get("dense_max_agents")
    with config.override(dense_max_agents=99, fragile_below=0.5):
        assert config.get("dense_max_agents") == 99 and config.defaults()["fragile_below"] == 0.5
    assert config.get("dense_max_agents") == before
    try:
        config.set_defaults(max_seconds=1.0)
        assert config.get("max_seconds") == 1.0
    finally:
        config.reset_defaults()
    assert config.get("max_seconds") == config.default("max_seconds")
    with pytest.raises(RuntimeError):
        with config.override(max_primes=1):
            raise RuntimeError
    assert config.get("max_primes") == config.default("max_primes")


def test_an_unknown_name_or_a_bad_value_is_refused_with_one_line() -> None:
    with pytest.raises(ConfigError, match="did you mean dense_max_agents"):
        config.get("dense_max_agent")
    for bad in ({"dense_max_agents": 1.5}, {"dense_max_agents": -1}, {"fragile_below": math.nan}, {"slow_ladder": ()}, {"max_seconds": "1"}):
        with pytest.raises(ConfigError) as info:
            config.set_defaults(**bad)
        assert isinstance(info.value, (ValueError, GlocalVerifyError)) and "\n" not in str(info.value)
    assert config.get("dense_max_agents") == config.default("dense_max_agents")


def test_modules_read_a_tunable_when_they_use_it() -> None:
    system = System(load_example("paper19"))
    case = local_cases(system)[0]
    assert len(case.model.nodes) <= config.get("dense_max_agents")
    assert pencil_verdict(system, case, margin=False).witness["method"] == "dense"
    with config.override(dense_max_agents=len(case.model.nodes) - 1):
        assert pencil_verdict(system, case, margin=False).witness["method"] == "structured"
    with config.override(fragile_below=10.0):
        assert any(r.fragile for r in verify(system, ["switching.image-kernel"]).conditions)
    assert not any(r.fragile for r in verify(system, ["switching.image-kernel"]).conditions)


def test_no_tunable_default_is_written_twice() -> None:
    """A module keeps a tunable's value only as ``NAME = config.get/default("name")``, never as a literal of its own."""
    literals = []
    for path in PACKAGE.rglob("*.py"):
        if path.name == "config.py":
            continue
        for node in ast.parse(path.read_text(encoding="utf-8")).body:
            if isinstance(node, ast.Assign) and len(node.targets) == 1 and isinstance(node.targets[0], ast.Name):
                name = node.targets[0].id.lstrip("_").lower()
                if name in config.TUNABLES and isinstance(node.value, ast.Constant):
                    literals.append(f"{path.name}: {node.targets[0].id}")
    assert not literals, literals
