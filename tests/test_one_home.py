"""Shared maths and shared decisions have one home each, and every caller reaches it.

A rule's callers are checked with the profile hook of ``test_one_answer`` (the code object of
the one function must run under each caller); a piece of vocabulary written once is checked
on the source (no second literal of it anywhere else).
"""

from __future__ import annotations

import ast
import dataclasses
from fractions import Fraction
from typing import Any, Callable

import flint
import pytest

from glocal_verify import System, load_example, verify
from glocal_verify.analysis.local import cases as local_cases_module
from glocal_verify.analysis.local import pencil as local_pencil
from glocal_verify.analysis.stealthy.zda_verdict import decide_zda, zda_direction
from glocal_verify.design import audit_local
from glocal_verify.design.audit import audit
from glocal_verify.numerics import cluster_transfer, hurwitz, pencil_exact, rounding
from glocal_verify.results import Status, growth_of_sign, vector_json
from glocal_verify.simulation import limits
from glocal_verify.spec.types import ImplementationSpec

from test_architecture import PACKAGE
from test_one_answer import _called


def _reached(fn: Callable[..., Any], run: Callable[[], Any]) -> bool:
    """Whether ``fn``'s code runs during ``run()`` (an exception of ``run`` is part of the run)."""

    def go() -> None:
        try:
            run()
        except Exception:  # noqa: BLE001 - a refusal is what some callers do
            pass

    return bool(_called({"rule": fn.__code__}, go))


@pytest.fixture(scope="module")
def paper19() -> System:
    return System(load_example("paper19"))


def _strings(tree: ast.AST) -> list[tuple[int, str]]:
    """String constants of a module outside docstrings."""
    docs = {id(n.body[0].value) for n in ast.walk(tree) if isinstance(n, (ast.Module, ast.FunctionDef, ast.ClassDef, ast.AsyncFunctionDef)) and n.body and isinstance(n.body[0], ast.Expr)}
    return [(n.lineno, n.value) for n in ast.walk(tree) if isinstance(n, ast.Constant) and isinstance(n.value, str) and id(n) not in docs]


# ------------------------------------------------------------------------------------------
# exact stability: numerics/hurwitz.py


def test_the_exact_hurwitz_test_is_the_one_the_central_observer_and_the_uio_existence_call(paper19: System) -> None:
    from glocal_verify.observers.central import design_central_observer
    from glocal_verify.observers.central_verdict import observable_hurwitz_exact

    obsv = design_central_observer(paper19, method="riccati")
    assert _reached(hurwitz.routh_hurwitz_poly, lambda: observable_hurwitz_exact(paper19, obsv))
    from glocal_verify.observers.uio_existence import uio_existence_exact

    # the input on agent 1 is decoupled by measuring it; state 2, unmeasured, is the unobservable part
    E, C = [[1], [0]], [[1, 0]]
    assert _reached(hurwitz.routh_hurwitz_poly, lambda: uio_existence_exact([[-1, 0], [0, -2]], E, C))
    assert uio_existence_exact([[-1, 0], [0, -2]], E, C).status is Status.HOLDS
    assert uio_existence_exact([[-1, 0], [0, 2]], E, C).status is Status.FAILS


def test_the_exact_schur_test_is_the_one_the_sampled_local_uio_calls(paper19: System) -> None:
    sampled = System(dataclasses.replace(paper19.spec, implementation=ImplementationSpec(Fraction(1, 10), controller="sampled")))
    assert _reached(hurwitz.schur_cohn, lambda: verify(sampled, ["sampled.local-uio"], exact=True))


def test_the_exact_stability_tests_decide_by_their_definition() -> None:
    s = flint.fmpq_poly([0, 1])
    assert hurwitz.routh_hurwitz_poly((s + 1) * (s + 2) * (s * s + s + 1))
    assert not hurwitz.routh_hurwitz_poly((s + 1) * (s * s + 1))  # roots on the axis
    assert hurwitz.routh_hurwitz([Fraction(1), Fraction(3), Fraction(2)]) is hurwitz.routh_hurwitz_poly((s + 1) * (s + 2))
    assert hurwitz.schur_cohn((2 * s - 1) * (3 * s + 1))  # roots 1/2, -1/3
    assert not hurwitz.schur_cohn((s - 1) * (2 * s + 1))  # a root on the unit circle
    A = flint.fmpq_mat([[flint.fmpq(1, 2), 0], [0, 2]])
    assert hurwitz.unobservable_schur_stable(A, flint.fmpq_mat([[0, 1]]))  # hides only the mode 1/2
    assert not hurwitz.unobservable_schur_stable(A, flint.fmpq_mat([[1, 0]]))  # hides the mode 2


def test_no_module_but_numerics_hurwitz_runs_a_routh_or_schur_cohn_recursion() -> None:
    names = {"routh_hurwitz", "routh_hurwitz_poly", "_routh_hurwitz_rational", "schur_cohn", "is_hurwitz_exact", "schur_stable_exact", "_detectable_exact", "hurwitz_enclosure"}
    defined = [f"{p.relative_to(PACKAGE)}:{n.name}" for p in PACKAGE.rglob("*.py") for n in ast.walk(ast.parse(p.read_text(encoding="utf-8")))
               if isinstance(n, ast.FunctionDef) and n.name in names and p.name != "hurwitz.py"]
    assert not defined, defined


# ------------------------------------------------------------------------------------------
# elimination modulo f, rounding constants


def test_every_elimination_modulo_f_runs_the_one_echelon_form() -> None:
    x = flint.fmpq_poly([0, 1])
    f = x * x + 1  # irreducible: Q[x]/(f) = Q(i)
    M = [[x, flint.fmpq_poly(1), x + 2], [flint.fmpq_poly(-1), x, 2 * x - 1]]  # row 2 = x row 1 modulo f
    assert _reached(pencil_exact.echelon_mod, lambda: pencil_exact.rank_over_field(M, f, 3))
    assert _reached(pencil_exact.echelon_mod, lambda: pencil_exact.kernel_over_field(M, f, 3))
    assert _reached(pencil_exact.echelon_mod, lambda: cluster_transfer.fraction_free_kernel(M, f, 3))
    dim, v = cluster_transfer.fraction_free_kernel(M, f, 3)
    assert dim == 3 - pencil_exact.rank_over_field(M, f, 3) == len(pencil_exact.kernel_over_field(M, f, 3).basis) == 2
    assert v is not None and all((sum((a * b for a, b in zip(row, v)), flint.fmpq_poly(0)) % f).is_zero() for row in M)


def test_the_rounding_constants_are_defined_once_in_numerics_rounding() -> None:
    copies = []
    for p in PACKAGE.rglob("*.py"):
        if p.name == "rounding.py":
            continue
        text = p.read_text(encoding="utf-8")
        for node in ast.parse(text).body:
            if isinstance(node, (ast.Assign, ast.AnnAssign)):
                targets = node.targets if isinstance(node, ast.Assign) else [node.target]
                if any(isinstance(t, ast.Name) and t.id.lstrip("_") in ("EPS", "U", "SVD_BACKWARD_CONSTANT") for t in targets):
                    copies.append(f"{p.relative_to(PACKAGE)}:{node.lineno}")
        if "finfo(float).eps" in text or "finfo(np.float64).eps" in text:
            copies.append(f"{p.relative_to(PACKAGE)}: finfo(...).eps")
    assert not copies, copies
    assert rounding.UNIT_ROUNDOFF == rounding.EPS / 2 == 2.0**-53


# ------------------------------------------------------------------------------------------
# vocabulary written once: growth classes, the ids of Theorem III.3


def test_the_growth_classes_are_named_by_one_mapping() -> None:
    assert [growth_of_sign(s) for s in (1, 0, -1)] == ["unbounded", "persistent", "decaying"]
    strays = [f"{p.relative_to(PACKAGE)}:{line}" for p in PACKAGE.rglob("*.py") if p.name != "results.py" and p.suffix == ".py"
              for line, text in _strings(ast.parse(p.read_text(encoding="utf-8"))) if text == "decaying"]
    assert not strays, strays


def test_the_conditions_of_theorem_iii3_are_listed_once() -> None:
    ids = ("switching.image-kernel", "switching.distinct-eigenvalues", "switching.eigenvector-differences")
    lists = [f"{p.relative_to(PACKAGE)}:{n.lineno}" for p in PACKAGE.rglob("*.py") for n in ast.walk(ast.parse(p.read_text(encoding="utf-8")))
             if isinstance(n, ast.Tuple) and tuple(getattr(e, "value", None) for e in n.elts) == ids]
    assert lists == ["conditions/catalogue.py:" + lists[0].split(":")[1]], lists


# ------------------------------------------------------------------------------------------
# the witness of a ZDA: one encoder, one direction


def test_verify_and_the_audit_encode_a_witness_vector_with_the_one_encoder(paper19: System) -> None:
    assert _reached(vector_json, lambda: verify(paper19, ["stealthy.zda", "switching.avoids-attack"], simulate="never"))
    assert _reached(vector_json, lambda: audit(paper19, 1, [3, 4]))
    assert vector_json(["a", "b", "c"], [1.0, 0.0, 1e-12 + 2j]) == {"a": 1.0, "c": 1e-12 + 2j}
    assert vector_json(["a", "b", "c"], [1.0, 0.0, 1e-12], cut=1e-9) == {"a": 1.0}
    assert vector_json(["a", "b"], [0.0, 1.0], zeros=True) == {"a": 0.0, "b": 1.0}
    names = {"_vec", "_xi_json", "_u_json"}
    assert not [n.name for p in PACKAGE.rglob("*.py") for n in ast.walk(ast.parse(p.read_text(encoding="utf-8"))) if isinstance(n, ast.FunctionDef) and n.name in names]


def test_the_simulated_zda_is_the_direction_of_the_rule(paper19: System) -> None:
    from glocal_verify.simulation.attacks import zda_attack

    assert _reached(decide_zda, lambda: zda_attack(paper19))
    v = decide_zda(paper19)
    atk = zda_attack(paper19)
    assert v.direction is not None and atk.lambda0 == complex(v.direction.value)
    d = zda_direction(paper19)
    assert d is not None and d.lambda0 == atk.lambda0
    at = zda_direction(paper19, lambda0=0.25)
    assert at is not None and at.lambda0 == 0.25  # exactly the exponent asked for


def test_the_package_root_exports_the_certified_rule_of_stealthy_zda() -> None:
    import glocal_verify

    assert "decide_zda" in glocal_verify.__all__ and "zda_analysis" not in glocal_verify.__all__
    assert glocal_verify.zda_direction is zda_direction and glocal_verify.decide_zda is decide_zda


# ------------------------------------------------------------------------------------------
# the one refusal of a run too large


def test_every_size_refusal_goes_through_the_one_refusal(paper19: System) -> None:
    from glocal_verify import config
    from glocal_verify.conditions.cost import CostEstimate, Limits, check_limits

    big = limits.SizeEstimate(1e12, 1e15)
    assert _reached(limits.refuse, lambda: limits.check_size(big))
    assert _reached(limits.refuse, lambda: check_limits(CostEstimate("verify", 10, 1e9, 1e15), Limits(1.0, 1.0)))
    with config.override(simulation_max_internal_steps=1):
        assert _reached(limits.refuse, lambda: limits.check_stiffness(paper19, 30.0, 0.01))
        with pytest.raises(limits.SizeLimitError):
            limits.check_stiffness(paper19, 30.0, 0.01)
        with limits.allow_large():
            limits.check_stiffness(paper19, 30.0, 0.01)  # lifted, as every refusal
    with pytest.raises(limits.SizeLimitError) as info:
        limits.check_size(big)
    assert info.value.estimate is big and "\n" not in str(info.value)


# ------------------------------------------------------------------------------------------
# the audit's local screens: the rule states every status


def test_the_audits_local_pencil_status_is_always_the_rules(paper19: System, monkeypatch: pytest.MonkeyPatch) -> None:
    stated: list[tuple[Any, Status]] = []
    for name in ("pencil_verdict", "pencil_verdict_exact"):
        real = getattr(local_pencil, name)

        def rule(system: System, case: Any, *args: Any, _real: Any = real, **kw: Any) -> Any:
            v = _real(system, case, *args, **kw)
            stated.append((case.suspected, v.status))
            return v

        monkeypatch.setattr(audit_local, name, rule)
    returned: list[tuple[Any, Status]] = []
    real_status = audit_local.pencil_status

    def status(sh: Any, cm: Any, obs: Any, sus: Any, memo: Any) -> Status:
        fresh = ("pencil", cm.name, obs.center, sus) not in memo
        st = real_status(sh, cm, obs, sus, memo)
        if fresh:
            returned.append((sus, st))
        return st

    monkeypatch.setattr(audit_local, "pencil_status", status)
    audit(paper19, 2, [3, 4, 5, 7, 8])
    assert returned and all(r in stated for r in returned), [r for r in returned if r not in stated]
    # a member that does not fail proves nothing: the rule decides the set as without the screen
    c = paper19.clusters[0]
    cm, obs = paper19.cluster_model(c.name), paper19.observers(c.name)[0]
    inside = [a for a in c.nodes if not local_cases_module.LocalCase(cm, obs, "attack", (a,)).structural]
    single = local_pencil.pencil_verdict(paper19, local_cases_module.LocalCase(cm, obs, "attack", inside[:1]), margin=False)
    assert single.status is not Status.FAILS
    pair = local_cases_module.LocalCase(cm, obs, "attack", tuple(inside[:2]))
    screened = local_pencil.pencil_verdict(paper19, pair, margin=False, screen=local_cases_module.PencilScreen((inside[0], single), minors=False))
    assert screened.status is local_pencil.pencil_verdict(paper19, pair, margin=False).status
