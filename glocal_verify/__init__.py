"""glocal-verify: formal checks of the glocal stealthy-attack detection conditions.

Quick start::

    from glocal_verify import System, load_example, verify
    report = verify(System(load_example("paper19")))
    for r in report.conditions:
        print(r.id, r.scope, r.status)

The package re-exports what users call: specs and systems, ``verify`` and the report types,
the analyses behind the checkers (pencils, ZDA directions, unobservable subspaces), observer
designs (central, unknown-input), observer placement, attacks and Algorithm 1. The simulator
itself is ``glocal_verify.simulate.simulate``; everything else lives in its module
(``glocal_verify.local``, ``glocal_verify.figures`` ...).
"""

from .errors import GlocalVerifyError, ModelError, NotApplicableError, SpecError, UnknownConditionError
from .linalg import DEFAULT_TOLERANCE, Tolerance
from .model import ClusterModel, LocalObserver, System
from .registry import CATALOGUE, CheckContext, implemented_ids, verify
from .report import render, report_schema, validate_report_json
from .results import ConditionResult, Finding, Method, Report, Status
from .spec import SystemSpec, example_names, load_example, load_spec, loads_spec, spec_from_dict, spec_from_graph
from .generators import random_clustered_spec
from .pencil import PencilAnalysis, analyze_pencil, analyze_pencil_exact
from .stealthy import ZdaDirection, covert_required_channels, zda_analysis, zda_direction
from .observability import Subspace, switched_unobservable_subspace, unobservable_subspace
from .central import CentralObserver, design_central_observer
from .uio import UnknownInputObserver, design_uio, local_uio
from .placement import Placement, place_observers
from .simulate import Schedule, SimulationResult, covert_attack, zda_attack
from .detection import algorithm1, attack_free_thresholds

__all__ = [
    "GlocalVerifyError",
    "SpecError",
    "ModelError",
    "NotApplicableError",
    "UnknownConditionError",
    "Tolerance",
    "DEFAULT_TOLERANCE",
    "System",
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
    "covert_attack",
    "zda_attack",
    "algorithm1",
    "attack_free_thresholds",
]

__version__ = "0.1.0"
