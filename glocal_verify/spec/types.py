"""The frozen types of a validated specification: graph edges, modes, clusters, monitors, attack, switching, simulation.

Weights and gains are exact :class:`fractions.Fraction` values; node labels are ``int`` or
``str`` as the user wrote them (:data:`Label`). Instances are produced only by the loaders of
:mod:`glocal_verify.spec.load`, which validate them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any, Mapping

from glocal_verify.errors import SpecError

__all__ = [
    "Label",
    "EdgeSpec",
    "ModeSpec",
    "ObserverSpec",
    "ClusterSpec",
    "MonitorSpec",
    "AttackSpec",
    "SwitchStep",
    "SwitchingSpec",
    "SimulationSpec",
    "SystemSpec",
    "NORMAL_MODE",
]

Label = int | str
NORMAL_MODE = "normal"
ATTACK_KINDS = ("zda", "covert")


@dataclass(frozen=True, slots=True)
class EdgeSpec:
    """Undirected edge ``{u, v}`` with positive rational weight."""

    u: Label
    v: Label
    weight: Fraction = Fraction(1)

    @property
    def key(self) -> frozenset[Label]:
        return frozenset((self.u, self.v))


@dataclass(frozen=True, slots=True)
class ModeSpec:
    """A safe mode: the normal graph with edges added and removed."""

    name: str
    add: tuple[EdgeSpec, ...] = ()
    remove: tuple[tuple[Label, Label], ...] = ()
    description: str = ""


@dataclass(frozen=True, slots=True)
class ObserverSpec:
    """A local observer of a cluster, centred at ``center``.

    ``positions`` and ``velocities`` are ``None`` when the spec leaves them to the default
    (the centre and its neighbours inside the cluster); :class:`~glocal_verify.model.System`
    resolves the default.
    """

    center: Label
    positions: tuple[Label, ...] | None = None
    velocities: tuple[Label, ...] | None = None
    poles: tuple[Fraction, ...] | None = None


@dataclass(frozen=True, slots=True)
class ClusterSpec:
    """A cluster P_i of the partition and its local observers."""

    name: str
    nodes: tuple[Label, ...]
    observers: tuple[ObserverSpec, ...] = ()


@dataclass(frozen=True, slots=True)
class MonitorSpec:
    """Globally monitored agents: M_x (positions) and M_v (velocities)."""

    positions: tuple[Label, ...] = ()
    velocities: tuple[Label, ...] = ()


@dataclass(frozen=True, slots=True)
class AttackSpec:
    """The attack scenario: actuators F, compromised global channels F_s, ZDA exponent."""

    kind: str
    actuators: tuple[Label, ...]
    sensors: tuple[Label, ...] = ()
    lambda0: complex | None = None
    start: float = 0.0
    signal: str | None = None
    amplitude: float = 1.0
    frequency: float = 1.0


@dataclass(frozen=True, slots=True)
class SwitchStep:
    """One step of a mode sequence: ``mode`` active for ``duration`` time units."""

    mode: str
    duration: float


@dataclass(frozen=True, slots=True)
class SwitchingSpec:
    """A scheduled switch (``mode`` at ``time``) and/or an explicit mode sequence."""

    mode: str | None = None
    time: float | None = None
    sequence: tuple[SwitchStep, ...] = ()


@dataclass(frozen=True, slots=True)
class SimulationSpec:
    """Simulation horizon, output step and random seed."""

    horizon: float = 30.0
    step: float = 0.01
    seed: int = 0


@dataclass(frozen=True, slots=True)
class SystemSpec:
    """A validated system specification (format 1)."""

    name: str
    nodes: tuple[Label, ...]
    edges: tuple[EdgeSpec, ...]
    alpha: Fraction = Fraction(1)
    gamma: Fraction = Fraction(1)
    modes: tuple[ModeSpec, ...] = ()
    clusters: tuple[ClusterSpec, ...] = ()
    monitor: MonitorSpec = field(default_factory=MonitorSpec)
    attack: AttackSpec | None = None
    switching: SwitchingSpec | None = None
    simulation: SimulationSpec = field(default_factory=SimulationSpec)
    description: str = ""
    source: str | None = None
    finding: Mapping[str, Any] | None = None

    @property
    def mode_names(self) -> tuple[str, ...]:
        """``("normal", <safe modes in spec order>)``."""
        return (NORMAL_MODE,) + tuple(m.name for m in self.modes)

    def mode(self, name: str) -> ModeSpec:
        for m in self.modes:
            if m.name == name:
                return m
        raise SpecError("modes", f"no safe mode named {name!r}", self.source)

    def to_toml(self) -> str:
        """This specification as TOML text (format 1), exactly; see :func:`glocal_verify.spec.writer.dump_spec`."""
        from glocal_verify.spec.writer import dump_spec

        return dump_spec(self)
