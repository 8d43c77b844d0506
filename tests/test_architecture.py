"""The package layout is the architecture: layers import only lower layers, state is explicit."""

from __future__ import annotations

import pytest
import ast
from dataclasses import dataclass
from pathlib import Path

import glocal_verify

PACKAGE = Path(glocal_verify.__file__).parent

#: lowest first; a module may import only its own layer and the ones before it. The package
#: root (``glocal_verify/__init__.py``) is the facade above them all: nothing imports it.
LAYERS = ["_lazy", "version", "words", "errors", "runtime", "extra", "config", "results", "derived", "spec", "numerics", "model", "analysis", "observers", "simulation", "conditions", "certificates", "answer", "design", "reporting", "cli", "__main__"]

#: the topics of analysis/, lowest first: a topic imports only the ones before it
ANALYSIS_TOPICS = ["laplacian", "unobservable", "local", "stealthy", "switching", "sampled"]

ROOT = "glocal_verify"


def _modules() -> list[tuple[str, Path]]:
    """(name relative to the package, path) of every module; a package is named by its folder."""
    out = []
    for p in sorted(PACKAGE.rglob("*.py")):
        parts = p.relative_to(PACKAGE).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out.append((".".join(parts), p))
    return out


_MODULE_NAMES = frozenset(f"{ROOT}.{n}" if n else ROOT for n, _ in _modules())


@dataclass(frozen=True)
class Import:
    """One import of a module of the package, resolved to the module it loads.

    ``target`` is the module (``glocal_verify.x.y``); ``name`` the name taken from it (None when
    the module itself is imported); ``runs`` False inside ``if TYPE_CHECKING:``; ``nested``
    True inside a function or class body.
    """

    target: str
    name: str | None
    line: int
    runs: bool
    nested: bool


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def read_imports(module: str, source: str, is_package: bool, modules: frozenset[str] = _MODULE_NAMES) -> list[Import]:
    """Every import of the package in ``source`` (the module ``module``): ``import a.b``,
    ``from a import b`` (b a module or a name), relative imports, ``from glocal_verify import x``,
    imports inside functions and ``importlib.import_module("...")`` with a constant name."""
    out: list[Import] = []
    package = module.split(".") if is_package else module.split(".")[:-1]

    def visit(node: ast.AST, runs: bool, nested: bool) -> None:
        if isinstance(node, ast.If) and _is_type_checking(node.test):
            for child in node.body:
                visit(child, False, nested)
            for child in node.orelse:
                visit(child, runs, nested)
            return
        if isinstance(node, ast.Import):
            out.extend(Import(a.name, None, node.lineno, runs, nested) for a in node.names if a.name.split(".")[0] == ROOT)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target.split(".")[0] == ROOT:
                for a in node.names:
                    sub = f"{target}.{a.name}"
                    out.append(Import(sub, None, node.lineno, runs, nested) if sub in modules else Import(target, a.name, node.lineno, runs, nested))
        elif isinstance(node, ast.Call):
            f = node.func
            called = f.attr if isinstance(f, ast.Attribute) else f.id if isinstance(f, ast.Name) else ""
            if called in ("import_module", "__import__") and node.args and isinstance(node.args[0], ast.Constant) and str(node.args[0].value).split(".")[0] == ROOT:
                out.append(Import(str(node.args[0].value), None, node.lineno, runs, nested))
        inner = nested or isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef, ast.Lambda))
        for child in ast.iter_child_nodes(node):
            visit(child, runs, inner)

    visit(ast.parse(source), True, False)
    return out


def _all_imports() -> list[tuple[str, Import]]:
    out = []
    for name, path in _modules():
        module = f"{ROOT}.{name}" if name else ROOT
        out += [(module, i) for i in read_imports(module, path.read_text(encoding="utf-8"), path.name == "__init__.py")]
    return out


def _layer(module: str) -> int | None:
    parts = module.split(".")
    if len(parts) == 1:
        return len(LAYERS)  # the facade
    return LAYERS.index(parts[1]) if parts[1] in LAYERS else None


def _topic(module: str) -> int | None:
    parts = module.split(".")
    return ANALYSIS_TOPICS.index(parts[2]) if len(parts) > 3 and parts[1] == "analysis" and parts[2] in ANALYSIS_TOPICS else None


def test_the_import_reader_sees_every_form_of_import() -> None:
    source = """
import importlib
from typing import TYPE_CHECKING
import glocal_verify.analysis.stealthy.zda
import glocal_verify.model as m
from glocal_verify import config, __version__
from glocal_verify.analysis.stealthy import zda
from . import render
from .render import render as r
from ..numerics.spectrum import Spectrum
if TYPE_CHECKING:
    from glocal_verify.design.audit import AuditResult
def f():
    from glocal_verify.simulation.engine import simulate
    importlib.import_module("glocal_verify.cli.verify")
"""
    got = {(i.target, i.name, i.runs, i.nested) for i in read_imports("glocal_verify.reporting.fake", source, False)}
    assert got == {
        ("glocal_verify.analysis.stealthy.zda", None, True, False),
        ("glocal_verify.model", None, True, False),
        ("glocal_verify.config", None, True, False),
        ("glocal_verify", "__version__", True, False),
        ("glocal_verify.reporting.render", None, True, False),
        ("glocal_verify.reporting.render", "render", True, False),
        ("glocal_verify.numerics.spectrum", "Spectrum", True, False),
        ("glocal_verify.design.audit", "AuditResult", False, False),
        ("glocal_verify.simulation.engine", "simulate", True, True),
        ("glocal_verify.cli.verify", None, True, True),
    }
    # a package's relative import starts from the package itself
    (pkg,) = read_imports("glocal_verify.analysis.stealthy", "from .zda import ZdaZero\n", True)
    assert pkg.target == "glocal_verify.analysis.stealthy.zda"


def test_every_import_of_the_package_names_a_module_that_exists() -> None:
    # a module moved by a restructuring leaves function-level imports that only fail when run
    missing = sorted({f"{module}:{i.line} {i.target}" for module, i in _all_imports() if i.target not in _MODULE_NAMES})
    assert not missing, missing


def test_every_module_belongs_to_a_layer() -> None:
    unknown = [name for name, _ in _modules() if name and _layer(f"{ROOT}.{name}") is None]
    assert not unknown, f"add them to LAYERS: {unknown}"


def test_no_module_imports_a_higher_layer() -> None:
    upward = []
    for module, i in _all_imports():
        if module == ROOT:
            continue  # the facade re-exports every layer
        me, other = _layer(module), _layer(i.target)
        if other is not None and me is not None and other > me:
            upward.append(f"{module}:{i.line} imports {i.target}{'.' + i.name if i.name else ''}")
        elif me == other == LAYERS.index("analysis") and (a := _topic(module)) is not None and (b := _topic(i.target)) is not None and b > a:
            upward.append(f"{module}:{i.line} imports the higher topic {i.target}")
    assert not upward, upward


def test_there_is_no_import_circle_not_even_through_a_function_level_import() -> None:
    import networkx as nx

    graph = nx.DiGraph()
    for module, i in _all_imports():
        if i.runs and i.target != module:
            graph.add_edge(module, i.target)
    circles = [sorted(c) for c in nx.strongly_connected_components(graph) if len(c) > 1]
    assert not circles, circles


def test_every_subpackage_says_what_it_holds_and_may_import() -> None:
    for init in PACKAGE.rglob("*/__init__.py"):
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


def test_no_module_imports_a_private_name_from_another_subpackage() -> None:
    leaks = []
    for module, i in _all_imports():
        home, there = module.split(".")[:2], i.target.split(".")[:2]
        if i.name and i.name.startswith("_") and not i.name.startswith("__") and home != there:
            leaks.append(f"{module}:{i.line} imports {i.name} from {i.target}")
    assert not leaks, leaks


#: the layers whose functions compute (verdicts, designs, simulations, assessments, audits):
#: reporting may read their result types and constants, never call one of their functions
_COMPUTING_LAYERS = ("analysis", "observers", "simulation", "conditions", "answer", "design")


def test_reporting_renders_results_it_is_given_and_computes_none() -> None:
    import importlib
    import inspect

    calls = []
    for module, i in _all_imports():
        if module.split(".")[1:2] != ["reporting"] or i.target.split(".")[1:2] not in ([layer] for layer in _COMPUTING_LAYERS):
            continue
        if i.name is None:
            calls.append(f"{module}:{i.line} imports the module {i.target} (its functions would be at hand)")
            continue
        value = getattr(importlib.import_module(i.target), i.name)
        if inspect.ismodule(value) or (callable(value) and not isinstance(value, type)):
            calls.append(f"{module}:{i.line} imports the function {i.target}.{i.name}")
    assert not calls, calls


#: third-party libraries reached only from one room: the integrations of extra/ and the figures
_ROOMS = {
    "distributed": ("extra",),
    "dask": ("extra",),
    "control": ("extra",),
    "scipy.io": ("extra",),
    "matplotlib": ("reporting.figures",),
}


def test_optional_libraries_and_matplotlib_are_reached_from_their_one_room() -> None:
    strays = []
    for name, path in _modules():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else [node.module or ""] if isinstance(node, ast.ImportFrom) and not node.level else []
            for lib, rooms in _ROOMS.items():
                if any(n == lib or n.startswith(lib + ".") for n in names) and not any(name == r or name.startswith(r + ".") for r in rooms):
                    strays.append(f"{name}:{node.lineno} imports {lib}")
    assert not strays, strays


def test_every_curated_package_exports_what_its_lazy_table_names() -> None:
    import importlib

    for name, path in _modules():
        if path.name != "__init__.py" or "_LAZY" not in path.read_text(encoding="utf-8"):
            continue
        package = importlib.import_module(f"{ROOT}.{name}" if name else ROOT)
        lazy = package._LAZY
        assert set(package.__all__) == set(lazy), name
        # a public name that is also a submodule's would be the module once that is imported
        assert not {f"{package.__name__}.{public}" for public in lazy} & _MODULE_NAMES, name
        for public, home in lazy.items():
            assert getattr(package, public) is getattr(importlib.import_module(home), public), (name, public)
            assert home.startswith(package.__name__ + ".") or package.__name__ == ROOT, (name, home)


def _declared_kinds() -> dict[str, list[tuple[str, str]]]:
    """Kind name -> [(declaring module, constant name)] from every ``X = Kind("name", __name__, ...)``."""
    out: dict[str, list[tuple[str, str]]] = {}
    for name, path in _modules():
        for node in ast.parse(path.read_text(encoding="utf-8")).body:
            value = node.value if isinstance(node, (ast.Assign, ast.AnnAssign)) else None
            if isinstance(value, ast.Call) and isinstance(value.func, ast.Name) and value.func.id == "Kind":
                target = node.targets[0] if isinstance(node, ast.Assign) else node.target
                kind, owner = value.args[0], value.args[1]
                assert isinstance(kind, ast.Constant) and isinstance(owner, ast.Name) and owner.id == "__name__", f"{name}: a Kind names itself and its owner (__name__)"
                assert isinstance(target, ast.Name)
                out.setdefault(str(kind.value), []).append((name, target.id))
    return out


@pytest.mark.slow
def test_each_kind_of_derived_result_is_declared_and_written_by_one_module() -> None:
    kinds = _declared_kinds()
    assert len(kinds) >= 30
    twice = {k: v for k, v in kinds.items() if len(v) > 1}
    assert not twice, twice
    constants = {const: module for v in kinds.values() for module, const in v}
    shared = []
    for name, path in _modules():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom):
                shared += [f"{name} imports {a.name}" for a in node.names if a.name in constants and constants[a.name] != name]
    assert not shared, shared
    from glocal_verify import System, load_example, verify

    system = System(load_example("paper19"))
    verify(system, exact=False)
    undeclared = set(system.analysis.kinds()) - set(kinds)
    assert not undeclared, undeclared


def test_no_code_reaches_the_derived_results_by_a_bare_key() -> None:
    bare = []
    for name, path in _modules():
        if name == "derived":
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            target = None
            if isinstance(node, ast.Subscript):
                target = node.value
            elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "get":
                target = node.func.value
            elif isinstance(node, ast.Compare) and any(isinstance(op, (ast.In, ast.NotIn)) for op in node.ops):
                target = node.comparators[0]
            elif isinstance(node, ast.Assign):
                target = node.value
            if isinstance(target, ast.Attribute) and target.attr == "analysis":
                bare.append(f"{name}:{node.lineno}")
    assert not bare, bare


#: module-level state that is not a frozen constant, each with the reason it stays
_STATE_ALLOWED = {
    ("config", "_REGISTRY"): "the one registry of tunables (glocal_verify.config)",
    ("conditions.registry", "_CHECKERS"): "the checker registration: filled by @checker while the checker modules import, read-only after",
    ("conditions.registry", "_FINDINGS"): "the finding-rule registration: filled by @finding_rule the same way",
    ("conditions.registry", "_loaded"): "whether that registration has run (set once by _load)",
    ("numerics.threads", "_DEFAULT"): "a ContextVar: the BLAS thread count a `with` block sets, local to its context",
    ("numerics.threads", "_SINGLE"): "a ContextVar: inside a single_threaded call, local to its context",
    ("numerics.threads", "_IN_FORCE"): "a ContextVar: the thread count an enclosing limit put in force, local to its context",
    ("simulation.limits", "_ALLOW_LARGE"): "a ContextVar: allow_large's switch, local to its context",
}

_MUTABLE_CALLS = {"dict", "list", "set", "defaultdict", "OrderedDict", "Counter", "deque", "bytearray", "ContextVar", "WeakKeyDictionary", "WeakValueDictionary"}


def _mutable_value(value: ast.expr, classes: set[str]) -> bool:
    if isinstance(value, (ast.Dict, ast.List, ast.Set, ast.DictComp, ast.ListComp, ast.SetComp)):
        return True
    if isinstance(value, ast.Call):
        f = value.func
        name = f.id if isinstance(f, ast.Name) else f.attr if isinstance(f, ast.Attribute) else ""
        return name in _MUTABLE_CALLS or name in classes
    return False


def test_no_module_keeps_mutable_state_but_the_config_registry_and_the_checker_registration() -> None:
    found = []
    for name, path in _modules():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        classes = {n.name for n in tree.body if isinstance(n, ast.ClassDef) and not any(isinstance(d, ast.Call) and getattr(d.func, "id", "") == "dataclass" and any(k.arg == "frozen" for k in d.keywords) for d in n.decorator_list)}
        for node in tree.body:
            if isinstance(node, (ast.Assign, ast.AnnAssign)) and node.value is not None:
                target = node.targets[0] if isinstance(node, ast.Assign) else node.target
                var = getattr(target, "id", None)
                if var != "__all__" and _mutable_value(node.value, classes) and (name, var) not in _STATE_ALLOWED:
                    found.append(f"{name}:{node.lineno} {var}")
        for node in ast.walk(tree):
            if isinstance(node, ast.Global):
                found += [f"{name}:{node.lineno} global {v}" for v in node.names if (name, v) not in _STATE_ALLOWED]
    assert not found, found


#: checker modules whose rules live in analysis/ or observers/ (the rest are being consolidated)
_THIN_CHECKERS = ("conditions.privacy", "conditions.observability", "conditions.switching", "conditions.local", "conditions.central")


def test_the_checkers_only_wrap_the_rule_of_their_condition() -> None:
    thick = []
    for name, path in _modules():
        if name not in _THIN_CHECKERS:
            continue
        for node in ast.parse(path.read_text(encoding="utf-8")).body:
            if not (isinstance(node, ast.FunctionDef) and any(isinstance(d, ast.Call) and getattr(d.func, "id", "") == "checker" for d in node.decorator_list)):
                continue
            names = {n.id for n in ast.walk(node) if isinstance(n, ast.Name)}
            if "Status" in names or "result" in names or "verdict_result" not in names:
                thick.append(f"{name}.{node.name}")
    assert not thick, thick


def test_docs_architecture_names_the_one_function_holding_each_rule() -> None:
    import importlib
    import re

    from glocal_verify.conditions.catalogue import CATALOGUE

    text = (PACKAGE.parent / "docs" / "architecture.md").read_text(encoding="utf-8")
    rows = {m.group(1): m.group(2) for m in re.finditer(r"^\| `([a-z.-]+)` \| `(glocal_verify/[^`]+\.py)` : `(\w+)`", text, re.M)}
    assert set(rows) == set(CATALOGUE), set(CATALOGUE) ^ set(rows)
    for m in re.finditer(r"^\| `([a-z.-]+)` \| `(glocal_verify/[^`]+)\.py` : `(\w+)`", text, re.M):
        module = importlib.import_module(m.group(2).replace("/", "."))
        assert callable(getattr(module, m.group(3), None)), m.group(0)
