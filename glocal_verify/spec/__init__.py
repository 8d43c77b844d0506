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

from types import MappingProxyType
from typing import Mapping, TYPE_CHECKING

from glocal_verify._lazy import lazy_getattr

if TYPE_CHECKING:  # loaded on first use (PEP 562): listing examples never loads the validator
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

#: public name -> module that defines it
_LAZY: Mapping[str, str] = MappingProxyType({
    "example_names": "glocal_verify.spec.examples",
    "example_text": "glocal_verify.spec.examples",
    "load_example": "glocal_verify.spec.examples",
    "load_graph": "glocal_verify.spec.graph_files",
    "load_spec": "glocal_verify.spec.load",
    "loads_spec": "glocal_verify.spec.load",
    "spec_from_dict": "glocal_verify.spec.load",
    "spec_from_graph": "glocal_verify.spec.load",
    "ATTACK_KINDS": "glocal_verify.spec.types",
    "NORMAL_MODE": "glocal_verify.spec.types",
    "AttackSpec": "glocal_verify.spec.types",
    "ClusterSpec": "glocal_verify.spec.types",
    "EdgeSpec": "glocal_verify.spec.types",
    "Label": "glocal_verify.spec.types",
    "ModeSpec": "glocal_verify.spec.types",
    "MonitorSpec": "glocal_verify.spec.types",
    "ObserverSpec": "glocal_verify.spec.types",
    "SimulationSpec": "glocal_verify.spec.types",
    "SwitchingSpec": "glocal_verify.spec.types",
    "SwitchStep": "glocal_verify.spec.types",
    "SystemSpec": "glocal_verify.spec.types",
    "dump_spec": "glocal_verify.spec.writer",
})


#: ``glocal_verify.spec.X`` loads X from its module on first access
__getattr__ = lazy_getattr("glocal_verify.spec", _LAZY, globals())

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
