"""glocal-verify: formal checks of the glocal stealthy-attack detection conditions.

Quick start::

    from glocal_verify import System, load_example, verify
    report = verify(System(load_example("paper19")))
    for r in report.conditions:
        print(r.id, r.scope, r.status)

The package re-exports what users call: specs and systems, ``verify`` and the report types,
the analyses behind the checkers (pencils, ZDA directions, unobservable subspaces), observer
designs (central, unknown-input), observer placement, the simulator, attacks and Algorithm 1.

Layout, lowest layer first (each subpackage imports only the ones before it):
``errors``, ``results`` and ``spec`` (data and verdict types), ``numerics`` (certified matrix
decisions, exact arithmetic, pencils), ``model`` (``System`` and its explicit ``Analysis``
state), ``analysis`` (the paper's objects on a system), ``observers`` (UIO and central designs),
``simulation`` (propagators, attacks, thresholds, Algorithm 1), ``conditions`` (catalogue,
registry and checkers), ``answer`` (the one answer per attacker, the assessment, ``verify``,
``--require``), ``design`` (placement, audit, generators), ``reporting`` (renderers,
figures, case study, findings) and ``cli``.
"""

from types import MappingProxyType
from typing import Mapping, TYPE_CHECKING

from glocal_verify._lazy import lazy_getattr
from glocal_verify.version import __version__

if TYPE_CHECKING:  # the names below load on first use (PEP 562): `import glocal_verify` stays light
    from glocal_verify.analysis.stealthy.covert import covert_required_channels
    from glocal_verify.analysis.unobservable.switched import switched_unobservable_subspace
    from glocal_verify.analysis.unobservable.subspace import unobservable_subspace
    from glocal_verify.analysis.stealthy.zda import ZdaDirection
    from glocal_verify.analysis.stealthy.zda_verdict import ZdaOptions, ZdaVerdict, decide_zda, zda_direction
    from glocal_verify.conditions.detects import algorithm1
    from glocal_verify.answer.run import verify
    from glocal_verify.conditions.registry import (
        CATALOGUE,
        CheckContext,
        implemented_ids,
    )
    from glocal_verify.design.generators import random_clustered_spec
    from glocal_verify.design.placement import Placement, place_observers
    from glocal_verify.errors import (
        ArgumentError,
        GlocalVerifyError,
        ModelError,
        NotApplicableError,
        SpecError,
        UnknownConditionError,
    )
    from glocal_verify.model import Analysis, ClusterModel, LocalObserver, System
    from glocal_verify.numerics.pencil import PencilAnalysis, analyze_pencil
    from glocal_verify.numerics.pencil_exact import analyze_pencil_exact
    from glocal_verify.numerics.spectrum import Spectrum
    from glocal_verify.numerics.subspace import Subspace
    from glocal_verify.numerics.tolerance import DEFAULT_TOLERANCE, Tolerance
    from glocal_verify.observers.central import CentralObserver, design_central_observer
    from glocal_verify.observers.uio import UnknownInputObserver, design_uio, local_uio
    from glocal_verify.answer.assessment import Assessment, assess
    from glocal_verify.answer.attack import AttackAnswer, answer_attack
    from glocal_verify.answer.gate import require
    from glocal_verify.reporting.render import (
        render,
        report_schema,
        validate_report_json,
    )
    from glocal_verify.results import ConditionResult, Finding, Method, Polarity, Report, Status
    from glocal_verify.simulation.attacks import covert_attack, zda_attack
    from glocal_verify.simulation.engine import simulate
    from glocal_verify.simulation.schedule import Schedule, SimulationResult
    from glocal_verify.simulation.thresholds import attack_free_thresholds
    from glocal_verify.spec import (
        SystemSpec,
        dump_spec,
        example_names,
        load_example,
        load_graph,
        load_spec,
        loads_spec,
        spec_from_dict,
        spec_from_graph,
    )

#: public name -> module that defines it
_LAZY: Mapping[str, str] = MappingProxyType({
    "dump_spec": "glocal_verify.spec",
    "load_graph": "glocal_verify.spec",
    "Assessment": "glocal_verify.answer.assessment",
    "assess": "glocal_verify.answer.assessment",
    "AttackAnswer": "glocal_verify.answer.attack",
    "answer_attack": "glocal_verify.answer.attack",
    "require": "glocal_verify.answer.gate",
    "Polarity": "glocal_verify.results",
    "covert_required_channels": "glocal_verify.analysis.stealthy.covert",
    "switched_unobservable_subspace": "glocal_verify.analysis.unobservable.switched",
    "unobservable_subspace": "glocal_verify.analysis.unobservable.subspace",
    "ZdaDirection": "glocal_verify.analysis.stealthy.zda",
    "ZdaOptions": "glocal_verify.analysis.stealthy.zda_verdict",
    "ZdaVerdict": "glocal_verify.analysis.stealthy.zda_verdict",
    "decide_zda": "glocal_verify.analysis.stealthy.zda_verdict",
    "zda_direction": "glocal_verify.analysis.stealthy.zda_verdict",
    "algorithm1": "glocal_verify.conditions.detects",
    "CATALOGUE": "glocal_verify.conditions.registry",
    "CheckContext": "glocal_verify.conditions.registry",
    "implemented_ids": "glocal_verify.conditions.registry",
    "verify": "glocal_verify.answer.run",
    "random_clustered_spec": "glocal_verify.design.generators",
    "Placement": "glocal_verify.design.placement",
    "place_observers": "glocal_verify.design.placement",
    "ArgumentError": "glocal_verify.errors",
    "GlocalVerifyError": "glocal_verify.errors",
    "ModelError": "glocal_verify.errors",
    "NotApplicableError": "glocal_verify.errors",
    "SpecError": "glocal_verify.errors",
    "UnknownConditionError": "glocal_verify.errors",
    "Analysis": "glocal_verify.model",
    "ClusterModel": "glocal_verify.model",
    "LocalObserver": "glocal_verify.model",
    "System": "glocal_verify.model",
    "PencilAnalysis": "glocal_verify.numerics.pencil",
    "analyze_pencil": "glocal_verify.numerics.pencil",
    "analyze_pencil_exact": "glocal_verify.numerics.pencil_exact",
    "Spectrum": "glocal_verify.numerics.spectrum",
    "Subspace": "glocal_verify.numerics.subspace",
    "DEFAULT_TOLERANCE": "glocal_verify.numerics.tolerance",
    "Tolerance": "glocal_verify.numerics.tolerance",
    "CentralObserver": "glocal_verify.observers.central",
    "design_central_observer": "glocal_verify.observers.central",
    "UnknownInputObserver": "glocal_verify.observers.uio",
    "design_uio": "glocal_verify.observers.uio",
    "local_uio": "glocal_verify.observers.uio",
    "render": "glocal_verify.reporting.render",
    "report_schema": "glocal_verify.reporting.render",
    "validate_report_json": "glocal_verify.reporting.render",
    "ConditionResult": "glocal_verify.results",
    "Finding": "glocal_verify.results",
    "Method": "glocal_verify.results",
    "Report": "glocal_verify.results",
    "Status": "glocal_verify.results",
    "covert_attack": "glocal_verify.simulation.attacks",
    "zda_attack": "glocal_verify.simulation.attacks",
    "simulate": "glocal_verify.simulation.engine",
    "Schedule": "glocal_verify.simulation.schedule",
    "SimulationResult": "glocal_verify.simulation.schedule",
    "attack_free_thresholds": "glocal_verify.simulation.thresholds",
    "SystemSpec": "glocal_verify.spec",
    "example_names": "glocal_verify.spec",
    "load_example": "glocal_verify.spec",
    "load_spec": "glocal_verify.spec",
    "loads_spec": "glocal_verify.spec",
    "spec_from_dict": "glocal_verify.spec",
    "spec_from_graph": "glocal_verify.spec",
})


#: ``glocal_verify.X`` loads X from its module on first access
__getattr__ = lazy_getattr("glocal_verify", _LAZY, globals())


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


__all__ = [
    "GlocalVerifyError",
    "SpecError",
    "ModelError",
    "NotApplicableError",
    "UnknownConditionError",
    "ArgumentError",
    "Tolerance",
    "DEFAULT_TOLERANCE",
    "System",
    "Analysis",
    "Spectrum",
    "ClusterModel",
    "LocalObserver",
    "CATALOGUE",
    "CheckContext",
    "implemented_ids",
    "verify",
    "render",
    "assess",
    "Assessment",
    "AttackAnswer",
    "answer_attack",
    "require",
    "Polarity",
    "report_schema",
    "validate_report_json",
    "ConditionResult",
    "Finding",
    "Method",
    "Report",
    "Status",
    "SystemSpec",
    "example_names",
    "load_example",
    "load_spec",
    "loads_spec",
    "spec_from_dict",
    "spec_from_graph",
    "dump_spec",
    "load_graph",
    "random_clustered_spec",
    "PencilAnalysis",
    "analyze_pencil",
    "analyze_pencil_exact",
    "ZdaDirection",
    "covert_required_channels",
    "ZdaOptions",
    "ZdaVerdict",
    "decide_zda",
    "zda_direction",
    "Subspace",
    "switched_unobservable_subspace",
    "unobservable_subspace",
    "CentralObserver",
    "design_central_observer",
    "UnknownInputObserver",
    "design_uio",
    "local_uio",
    "Placement",
    "place_observers",
    "Schedule",
    "SimulationResult",
    "simulate",
    "covert_attack",
    "zda_attack",
    "algorithm1",
    "attack_free_thresholds",
]

