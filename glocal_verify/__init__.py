"""glocal-verify: formal checks of the glocal stealthy-attack detection conditions.

Quick start::

    from glocal_verify import System, load_example, verify
    report = verify(System(load_example("paper19")))
    for r in report.conditions:
        print(r.id, r.scope, r.status)
"""

from .errors import GlocalVerifyError, ModelError, NotApplicableError, SpecError, UnknownConditionError
from .linalg import DEFAULT_TOLERANCE, Tolerance
from .model import ClusterModel, LocalObserver, System
from .registry import CATALOGUE, CheckContext, implemented_ids, verify
from .report import render, report_schema, validate_report_json
from .results import ConditionResult, Finding, Method, Report, Status
from .spec import SystemSpec, example_names, load_example, load_spec, loads_spec, spec_from_dict, spec_from_graph

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
]

__version__ = "0.1.0"
