"""The package layout is the architecture: layers import only lower layers, state is explicit."""

from __future__ import annotations

import ast
from pathlib import Path

import glocal_verify

PACKAGE = Path(glocal_verify.__file__).parent

#: lowest first; a module may import only its own layer and the ones before it
LAYERS = ["errors", "runtime", "results", "spec", "numerics", "model", "analysis", "observers", "simulation", "conditions", "design", "reporting", "cli"]


def _modules() -> list[tuple[str, Path]]:
    out = []
    for p in sorted(PACKAGE.rglob("*.py")):
        parts = p.relative_to(PACKAGE).with_suffix("").parts
        out.append((".".join(parts), p))
    return out


def _layer(dotted: str) -> int | None:
    head = dotted.split(".")[0]
    return LAYERS.index(head) if head in LAYERS else None


def _imports(path: Path) -> list[tuple[str, int]]:
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0 and node.module.startswith("glocal_verify."):
            out.append((node.module[len("glocal_verify.") :], node.lineno))
        elif isinstance(node, ast.Import):
            out += [(a.name[len("glocal_verify.") :], node.lineno) for a in node.names if a.name.startswith("glocal_verify.")]
    return out


def test_no_module_imports_a_higher_layer() -> None:
    upward = []
    for name, path in _modules():
        me = _layer(name)
        if me is None:
            continue
        for target, line in _imports(path):
            other = _layer(target)
            if other is not None and other > me:
                upward.append(f"{name}:{line} imports {target}")
    assert not upward, upward


def test_every_subpackage_says_what_it_holds_and_may_import() -> None:
    for init in PACKAGE.glob("*/__init__.py"):
        doc = ast.get_docstring(ast.parse(init.read_text(encoding="utf-8")))
        assert doc and "Layer" in doc, init


def test_no_module_level_caches_keyed_by_objects() -> None:
    for name, path in _modules():
        text = path.read_text(encoding="utf-8")
        assert "WeakKeyDictionary" not in text, name
        assert "_CACHE" not in text, name


def test_no_module_is_longer_than_about_eight_hundred_lines() -> None:
    long = {name: n for name, path in _modules() if (n := len(path.read_text(encoding="utf-8").splitlines())) > 850}
    assert not long, long


def test_proofs_checks_do_not_import_the_library() -> None:
    root = PACKAGE.parent / "proofs_checks"
    for path in root.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.module:
                assert not node.module.startswith("glocal_verify"), path
            if isinstance(node, ast.Import):
                assert not any(a.name.startswith("glocal_verify") for a in node.names), path


def test_derived_results_live_on_the_system_that_owns_them() -> None:
    from glocal_verify import System, load_example, verify

    system = System(load_example("paper19"))
    assert len(system.analysis) == 0
    verify(system, ["privacy.initial-state", "stealthy.zda"])
    kinds = system.analysis.kinds()
    assert "modal" in kinds and "zda" in kinds, kinds
    assert system.spectrum("normal") is system.spectrum("normal")
    other = System(load_example("paper19"))
    assert len(other.analysis) == 0


def test_the_package_imports_its_public_names_on_first_use() -> None:
    import importlib
    import subprocess
    import sys

    lazy = glocal_verify._LAZY  # type: ignore[attr-defined]
    assert set(glocal_verify.__all__) == set(lazy)
    for name in glocal_verify.__all__:
        assert getattr(glocal_verify, name) is getattr(importlib.import_module(lazy[name]), name)
    probe = "import sys, glocal_verify; print('numpy' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True).stdout.strip()
    assert out == "False"
