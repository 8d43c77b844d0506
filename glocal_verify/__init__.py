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
registry and checkers), ``design`` (placement, generators), ``reporting`` (renderers,
figures, case study, findings) and ``cli``.
"""

from glocal_verify.analysis.covert import covert_required_channels
from glocal_verify.analysis.switched import switched_unobservable_subspace
from glocal_verify.analysis.unobservable import unobservable_subspace
from glocal_verify.analysis.zda import ZdaDirection, zda_analysis, zda_direction
from glocal_verify.conditions.detects import algorithm1
from glocal_verify.conditions.registry import (
    CATALOGUE,
    CheckContext,
    implemented_ids,
    verify,
)
from glocal_verify.design.generators import random_clustered_spec
from glocal_verify.design.placement import Placement, place_observers
from glocal_verify.errors import (
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
from glocal_verify.reporting.render import render, report_schema, validate_report_json
from glocal_verify.results import ConditionResult, Finding, Method, Report, Status
from glocal_verify.simulation.attacks import covert_attack, zda_attack
from glocal_verify.simulation.engine import simulate
from glocal_verify.simulation.schedule import Schedule, SimulationResult
from glocal_verify.simulation.thresholds import attack_free_thresholds
from glocal_verify.spec import (
    SystemSpec,
    example_names,
    load_example,
    load_spec,
    loads_spec,
    spec_from_dict,
    spec_from_graph,
)

__all__ = [
    "GlocalVerifyError",
    "SpecError",
    "ModelError",
    "NotApplicableError",
    "UnknownConditionError",
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
    "random_clustered_spec",
    "PencilAnalysis",
    "analyze_pencil",
    "analyze_pencil_exact",
    "ZdaDirection",
    "covert_required_channels",
    "zda_analysis",
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

__version__ = "0.1.0"
