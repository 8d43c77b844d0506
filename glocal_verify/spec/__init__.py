"""Specifications: the data a user writes, loaded, validated and written back.

Holds the frozen spec types (:mod:`.types`), the loaders for TOML text, dicts and networkx
graphs with the one builder whose messages name the key path (:mod:`.load`), networkx graph files
(:mod:`.graph_files`), the TOML writer (:mod:`.writer`), the generated key reference
(:mod:`.reference`), the JSON schema
of the spec format (``schemas/spec.schema.json``) and the bundled examples (``data/``,
:mod:`.examples`).

Layer: lowest with :mod:`glocal_verify.errors` and :mod:`glocal_verify.results`; imports
nothing else of the package.
"""

from glocal_verify.spec.examples import example_names, example_text, load_example
from glocal_verify.spec.graph_files import load_graph
from glocal_verify.spec.load import (
    load_spec,
    loads_spec,
    spec_from_dict,
    spec_from_graph,
)
from glocal_verify.spec.types import (
    ATTACK_KINDS,
    NORMAL_MODE,
    AttackSpec,
    ClusterSpec,
    EdgeSpec,
    Label,
    ModeSpec,
    MonitorSpec,
    ObserverSpec,
    SimulationSpec,
    SwitchingSpec,
    SwitchStep,
    SystemSpec,
)
from glocal_verify.spec.writer import dump_spec

__all__ = [
    "ATTACK_KINDS",
    "NORMAL_MODE",
    "AttackSpec",
    "ClusterSpec",
    "EdgeSpec",
    "Label",
    "ModeSpec",
    "MonitorSpec",
    "ObserverSpec",
    "SimulationSpec",
    "SwitchingSpec",
    "SwitchStep",
    "SystemSpec",
    "dump_spec",
    "example_names",
    "load_graph",
    "example_text",
    "load_example",
    "load_spec",
    "loads_spec",
    "spec_from_dict",
    "spec_from_graph",
]
