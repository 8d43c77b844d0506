"""The package layout is the architecture: layers import only lower layers, state is explicit."""

from __future__ import annotations

import ast
from pathlib import Path

import glocal_verify

PACKAGE = Path(glocal_verify.__file__).parent

#: lowest first; a module may import only its own layer and the ones before it
LAYERS = ["errors", "runtime", "config", "results", "derived", "spec", "numerics", "model", "analysis", "observers", "simulation", "conditions", "certificates", "answer", "design", "reporting", "cli"]


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


#: (importing module, imported module, name): private names still imported across subpackages,
#: being moved by the answer-layer work (the ZDA and avoidance rules); nothing else may join


def test_no_module_imports_a_private_name_from_another_subpackage() -> None:
    leaks = []
    for name, path in _modules():
        home = name.split(".")[0]
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not (isinstance(node, ast.ImportFrom) and node.module and node.level == 0 and node.module.startswith("glocal_verify.")):
                continue
            target = node.module[len("glocal_verify.") :]
            if target.split(".")[0] == home:
                continue
            for alias in node.names:
                if alias.name.startswith("_"):
                    leaks.append(f"{name}:{node.lineno} imports {alias.name} from {target}")
    assert not leaks, leaks


#: library calls that compute verdicts or simulations; reporting is handed their results
_COMPUTATIONS = {"verify", "algorithm1", "simulate", "check_detects", "run_case", "run_case_study", "simulate_system", "verify_findings", "check_case", "audit"}


def test_reporting_renders_results_it_is_given_and_computes_none() -> None:
    calls = []
    for name, path in _modules():
        if name.split(".")[0] != "reporting":
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("glocal_verify."):
                calls += [f"{name}:{node.lineno} imports {a.name}" for a in node.names if a.name in _COMPUTATIONS]
    assert not calls, calls


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
