"""The frozen types of a validated specification: graph edges, modes, clusters, monitors, attack, switching, simulation.

Weights and gains are exact :class:`fractions.Fraction` values; node labels are ``int`` or
``str`` as the user wrote them (:data:`Label`). Instances are produced only by the loaders of
:mod:`glocal_verify.spec.load`, which validate them.

Domains and limits
------------------
Every number a spec holds is checked at load time against a documented domain, chosen so that
IEEE double precision (unit roundoff :math:`u = 2^{-53} \\approx 1.1 \\cdot 10^{-16}`) can carry
it through the numeric methods. The certified error bounds of the numeric checks scale like
:math:`c\\,n\\,u\\,\\|A\\|`; a coefficient :math:`w_{\\min}` is still visible above that level only
if :math:`w_{\\max} / w_{\\min} \\ll 1/u \\approx 10^{16}`. A spread of at most :math:`10^{12}`
leaves about four decimal digits above the rounding level, so a verdict can still be certified
on moderate networks; wider spreads would make nearly every numeric verdict undecided and let
exponentials and pencils overflow. The closed-loop eigenvalues solve
:math:`s^2 + \\gamma s + \\alpha\\mu = 0` for the Laplacian eigenvalues :math:`\\mu`, so their magnitudes
spread over about :math:`\\max(\\alpha w_{\\max}, \\gamma^2) / \\min(\\alpha w_{\\min}, \\gamma^2)`; that
spread is bounded by :math:`10^{12}` as well (``gamma = 1e12`` with ``alpha = 1`` overflowed the
switched-observability and observer computations). Hence

========================================  ==============================================================
weights (``graph.edges``, mode adds)      :math:`10^{-12} \\le w \\le 10^{12}` and
                                          :math:`\\max w / \\min w \\le 10^{12}` over all modes
gains ``alpha``, ``gamma``                :math:`10^{-12} \\le \\alpha, \\gamma \\le 10^{12}`,
                                          :math:`\\max(\\alpha,\\gamma)/\\min(\\alpha,\\gamma) \\le 10^{12}` and
                                          :math:`\\max(\\alpha w_{\\max}, \\gamma^2) / \\min(\\alpha w_{\\min}, \\gamma^2) \\le 10^{12}`
``attack.lambda0``                        :math:`|\\mathrm{Re}\\,\\lambda_0|, |\\mathrm{Im}\\,\\lambda_0| \\le 10^{6}`
observer poles                            :math:`-10^{6} \\le p \\le -10^{-6}`
times (horizon, switching time, dwell)    :math:`10^{-6} \\le t \\le 10^{6}`; ``start`` in :math:`[0, 10^{6}]`
``simulation.step``                       :math:`10^{-6} \\le h \\le T` and :math:`T / h \\le 10^{8}` samples
``attack.amplitude``, ``frequency``       :math:`|a| \\le 10^{12}`; :math:`0 \\le f \\le 10^{6}`
``simulation.seed``                       :math:`0 \\le s < 2^{63}`
``implementation.period``                 :math:`10^{-6} \\le h \\le 10^{6}` (exact rational), :math:`T / h \\le 10^{8}`
``uncertainty`` bounds, standard devs     :math:`0 \\le b \\le 10^{12}` (exact rationals)
``uncertainty.false_alarm``               :math:`10^{-300} \\le p < 1`
``implementation.switch_delay``           an integer :math:`0 \\le d \\le 10^{6}` periods
========================================  ==============================================================

Numbers written as strings (``"1/3"``, ``"2.5e-3"``) are at most :data:`MAX_NUMBER_TEXT`
characters with a decimal exponent of at most :data:`MAX_EXPONENT` in magnitude, checked before
the text is turned into a rational. Sizes are bounded too: :data:`MAX_NODES` agents,
:data:`MAX_EDGES` edges (normal graph plus every mode's changes), :data:`MAX_MODES` safe modes,
:data:`MAX_SWITCH_STEPS` switching entries, labels and names of at most :data:`MAX_LABEL`
characters without NUL characters, free text of at most :data:`MAX_TEXT` characters, and
tables or arrays nested at most :data:`MAX_DEPTH` levels deep.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any, Final, Mapping

from glocal_verify.errors import SpecError
from glocal_verify.spec.writer import dump_spec

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
    "UncertaintySpec",
    "ImplementationSpec",
    "SystemSpec",
    "NORMAL_MODE",
    "ATTACK_KINDS",
    "CONTROLLERS",
    "HOLDS",
    "BOUND_MAX",
    "FALSE_ALARM_MIN",
    "SWITCH_DELAY_MAX",
    "WEIGHT_MIN",
    "WEIGHT_MAX",
    "WEIGHT_RATIO_MAX",
    "GAIN_MIN",
    "GAIN_MAX",
    "GAIN_RATIO_MAX",
    "STIFFNESS_MAX",
    "LAMBDA0_MAX",
    "POLE_MIN",
    "POLE_MAX",
    "TIME_MIN",
    "TIME_MAX",
    "MAX_SAMPLES",
    "AMPLITUDE_MAX",
    "SEED_MAX",
    "MAX_NODES",
    "MAX_EDGES",
    "MAX_MODES",
    "MAX_SWITCH_STEPS",
    "MAX_LABEL",
    "MAX_TEXT",
    "MAX_DEPTH",
    "MAX_NUMBER_TEXT",
    "MAX_EXPONENT",
]

Label = int | str
NORMAL_MODE = "normal"
ATTACK_KINDS = ("zda", "covert")
#: how the consensus controllers run in a sampled implementation (``implementation.controller``)
CONTROLLERS = ("sampled", "continuous")
#: how a held signal is reconstructed between samples (``implementation.hold``)
HOLDS = ("zoh",)

# -- domains (see the module docstring for the reasons) ----------------------------------------
#: smallest and largest edge weight (exact rationals)
WEIGHT_MIN: Final = Fraction(1, 10**12)
WEIGHT_MAX: Final = Fraction(10**12)
#: largest ratio of the largest to the smallest weight, over the normal graph and every mode
WEIGHT_RATIO_MAX: Final = Fraction(10**12)
#: range of the gains alpha and gamma, and their largest ratio
GAIN_MIN: Final = Fraction(1, 10**12)
GAIN_MAX: Final = Fraction(10**12)
GAIN_RATIO_MAX: Final = Fraction(10**12)
#: largest spread max(alpha w_max, gamma^2) / min(alpha w_min, gamma^2) of the closed loop
STIFFNESS_MAX: Final = Fraction(10**12)
#: bound on |Re lambda0| and |Im lambda0|
LAMBDA0_MAX: Final = 1e6
#: observer poles p satisfy POLE_MIN <= p <= POLE_MAX (< 0)
POLE_MIN: Final = Fraction(-(10**6))
POLE_MAX: Final = Fraction(-1, 10**6)
#: positive times (horizon, step, switching time, dwell times) lie in [TIME_MIN, TIME_MAX]
TIME_MIN: Final = 1e-6
TIME_MAX: Final = 1e6
#: largest number of output samples horizon / step a spec may ask for
MAX_SAMPLES: Final = 10**8
#: bound on |attack.amplitude|
AMPLITUDE_MAX: Final = 1e12
#: simulation.seed lies in [0, SEED_MAX]
SEED_MAX: Final = 2**63 - 1
#: every bound and standard deviation of ``[uncertainty]`` lies in [0, BOUND_MAX]
BOUND_MAX: Final = Fraction(10**12)
#: ``uncertainty.false_alarm`` lies in [FALSE_ALARM_MIN, 1)
FALSE_ALARM_MIN: Final = Fraction(1, 10**300)
#: ``implementation.switch_delay`` lies in [0, SWITCH_DELAY_MAX] periods
SWITCH_DELAY_MAX: Final = 10**6

# -- sizes ------------------------------------------------------------------------------------
MAX_NODES: Final = 100_000
MAX_EDGES: Final = 1_000_000
MAX_MODES: Final = 1_000
MAX_SWITCH_STEPS: Final = 10_000
MAX_LABEL: Final = 200
MAX_TEXT: Final = 10_000
MAX_DEPTH: Final = 64
MAX_NUMBER_TEXT: Final = 100
MAX_EXPONENT: Final = 1_000


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
class UncertaintySpec:
    """What the deployment does not know: initial state or observer errors, noise, disturbance.

    Every value is an exact rational. ``noise`` and ``noise_std`` are tuples of
    ``(channel pattern, value)`` in the order written: a pattern is ``"*"`` (every measured
    channel), ``"x:*"`` / ``"v:*"`` (every position / velocity) or ``"x:<label>"`` /
    ``"v:<label>"`` (one agent's position / velocity); a later, more specific pattern wins
    (:meth:`noise_bound`).

    Attributes
    ----------
    initial_state : Fraction or None
        Half-width b of the box ``|x_i(0)|, |v_i(0)| <= b`` (observers start from 0); the
        default when neither this nor ``initial_error`` is given is 1.
    initial_error : Fraction or None
        Half-width of the box of every observer's initial estimation error instead.
    noise : tuple of (str, Fraction)
        Amplitude bounds ``|n_j(t_k)| <= bound`` of the measurement noise per channel.
    noise_std : tuple of (str, Fraction)
        Standard deviations of an optional Gaussian measurement noise (independent over
        channels and samples), on top of the bounded part.
    false_alarm : Fraction or None
        With Gaussian noise: the false-alarm probability over the horizon the thresholds are
        set for (default 1e-6).
    disturbance : Fraction
        Bound ``|d_i(t)| <= d`` of an unknown acceleration disturbance on every agent.
    """

    initial_state: Fraction | None = None
    initial_error: Fraction | None = None
    noise: tuple[tuple[str, Fraction], ...] = ()
    noise_std: tuple[tuple[str, Fraction], ...] = ()
    false_alarm: Fraction | None = None
    disturbance: Fraction = Fraction(0)

    @property
    def box(self) -> Fraction:
        """The half-width of the initial box (state or error)."""
        if self.initial_error is not None:
            return self.initial_error
        return Fraction(1) if self.initial_state is None else self.initial_state

    @property
    def gaussian(self) -> bool:
        """Whether a Gaussian noise part is given (some nonzero standard deviation)."""
        return any(v > 0 for _, v in self.noise_std)

    @staticmethod
    def _lookup(table: tuple[tuple[str, Fraction], ...], channel: str) -> Fraction:
        kind = channel.split(":", 1)[0]
        best, rank = Fraction(0), -1
        for pattern, value in table:
            r = 2 if pattern == channel else 1 if pattern == f"{kind}:*" else 0 if pattern == "*" else -1
            if r >= rank and r >= 0:
                best, rank = value, r
        return best

    def noise_bound(self, channel: str) -> Fraction:
        """The amplitude bound of channel ``"x:<label>"`` / ``"v:<label>"`` (0 when none is given)."""
        return self._lookup(self.noise, channel)

    def noise_sigma(self, channel: str) -> Fraction:
        """The Gaussian standard deviation of a channel (0 when none is given)."""
        return self._lookup(self.noise_std, channel)


@dataclass(frozen=True, slots=True)
class ImplementationSpec:
    """How the network is deployed: sampling period, hold, controllers and the switch delay.

    Attributes
    ----------
    period : Fraction
        Sampling period h (exact rational): the detectors sample every measurement at ``k h``.
    hold : str
        ``"zoh"``: every held signal (the controllers' commands, the attacker's injection) is
        constant over a period.
    controller : str
        ``"sampled"``: every agent's consensus controller samples its neighbours at ``k h``
        and holds its command (a sampled-data controller); ``"continuous"``: the consensus
        loop runs in continuous time and only the detectors sample (and the attacker holds).
    switch_delay : int
        Periods from a local alarm to the topology switch (Algorithm 1, lines 3-5).
    """

    period: Fraction
    hold: str = "zoh"
    controller: str = "sampled"
    switch_delay: int = 1


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
    uncertainty: UncertaintySpec | None = None
    implementation: ImplementationSpec | None = None
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
        return dump_spec(self)
