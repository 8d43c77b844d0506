"""The deployment of a system: the detectors the toolkit designed, their thresholds and the schedule.

:func:`design_deployment` computes, once, everything a vehicle, a MATLAB/Octave script or a ROS
node needs to run the detectors the toolkit designed and simulated, as one frozen
:class:`Deployment`:

- the central observer of eq. ``obs_cent`` (:class:`CentralDesign`: ``A``, ``C``, the gain
  ``H``, ``F = A - H C``; :math:`\\dot z = F z + H y`, :math:`r_0 = y - C z`), designed by
  :func:`~glocal_verify.observers.central.design_central_observer`;
- every local unknown-input observer of eqs. ``obs_decent``, ``uio_conds_1``-``uio_conds_3``
  (:class:`LocalDesign`: the normal-mode design of
  :func:`~glocal_verify.observers.uio.local_uio`, the selection ``S`` of its cluster's state,
  the residual maps and the mode-matched ``F``, ``K`` it switches to after a topology switch);
- the attack-free thresholds the simulator uses (:class:`DeployedThresholds`, from
  :func:`~glocal_verify.simulation.thresholds.attack_free_thresholds` for the spec's switching
  schedule), the monitor sets, the modes' Laplacians and the switching schedule.

The observers are exactly the :class:`~glocal_verify.simulation.observer_models.ObserverBank`
that :func:`~glocal_verify.simulation.engine.simulate` runs (the same designs, bit for bit).
Renderers write this value as it is (:mod:`glocal_verify.reporting.export`: ``.mat``, JSON,
``.npz``); they compute nothing of it.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np

from glocal_verify.errors import NotApplicableError
from glocal_verify.model import System
from glocal_verify.runtime.lines import write_line
from glocal_verify.observers.central import design_central_observer
from glocal_verify.observers.uio import UnknownInputObserver
from glocal_verify.observers.uio_modes import ModeDesigns
from glocal_verify.simulation.sampled_deployment import SampledDeployment, sampled_deployment
from glocal_verify.simulation.observer_models import ObserverBank, ObserverModel, central_observer_model, cluster_embedding, local_designs, local_observer_model
from glocal_verify.simulation.schedule import ANY_MODE, Schedule
from glocal_verify.simulation.thresholds import ThresholdRule, attack_free_thresholds
from glocal_verify.spec.types import NORMAL_MODE, Label

__all__ = [
    "CentralDesign",
    "DeployedThresholds",
    "Deployment",
    "LocalDesign",
    "ModeDesign",
    "ObserverEnvelope",
    "SwitchLinks",
    "deployment_checks",
    "design_deployment",
    "schedule_end",
]


@dataclass(frozen=True, eq=False, slots=True)
class CentralDesign:
    """The central observer as deployed: :math:`\\dot z = F z + H y`, :math:`r_0 = y - C z`, ``z(0) = 0``.

    Attributes
    ----------
    mode : str
        The mode it is designed for (the normal mode; ``A`` is kept in every mode).
    channels : tuple of str
        The globally monitored output channels, the rows of ``C``.
    A, C, H, F : ndarray
        The normal-mode model, the output map, the gain and ``F = A - H C``.
    eigenvalues : ndarray
        The eigenvalues of ``F`` (complex).
    stability_margin : float
    method : str
        How ``H`` was designed.
    """

    mode: str
    channels: tuple[str, ...]
    A: np.ndarray
    C: np.ndarray
    H: np.ndarray
    F: np.ndarray
    eigenvalues: np.ndarray
    stability_margin: float
    method: str


@dataclass(frozen=True, eq=False, slots=True)
class ModeDesign:
    """The design a local observer switches to in one mode whose cluster matrices differ.

    Attributes
    ----------
    mode : str
    uio : UnknownInputObserver
        The design for the mode's ``A^i_q``, ``E^i_q``: ``h``, ``T``, ``A1``, ``K1``, ``F``, ``K``.
    Ry : ndarray
        ``I - C_loc h_q``.
    reset : ndarray
        ``h_1 - h_q``: at the switch from the normal mode, ``z <- z + reset y`` (zero when ``h``
        does not change). Between two other modes p, q the reset is ``h_p - h_q``.
    """

    mode: str
    uio: UnknownInputObserver
    Ry: np.ndarray
    reset: np.ndarray


@dataclass(frozen=True, eq=False, slots=True)
class LocalDesign:
    """One local unknown-input observer as deployed.

    :math:`\\dot z = F_q z + K_q y`, :math:`\\hat x = z + h_q y`,
    :math:`r = y - C_{loc} \\hat x = R_{y,q} y - R_z z`, ``z(0) = -h y(0)`` (:math:`\\hat x(0) = 0`),
    ``y = C_loc S x``; at a switch from p to q, ``z <- z + (h_p - h_q) y``.

    Attributes
    ----------
    name : str
        The observer's name in the simulator's bank.
    uio : UnknownInputObserver
        Its normal-mode design (:func:`~glocal_verify.observers.uio.local_uio`): the cluster,
        the measured agents, ``C_loc`` (``uio.C``), ``E``, ``A``, ``h``, ``T``, ``A1``, ``K1``
        and the certified Hurwitz verdict on its ``F``.
    channels : tuple of str
        Its measured channels, the rows of ``C_loc``.
    S : ndarray
        The selection of the cluster's state from the whole state x.
    F, K : ndarray
        The dynamics it runs in any mode without a mode-matched design.
    Ry, Rz : ndarray
        The residual maps ``I - C_loc h`` and ``C_loc``.
    designs : tuple of ModeDesign
        The mode-matched designs (every mode whose ``A^i_q`` or ``E^i_q`` differs and has a UIO).
    not_decoupled : tuple of (str, str)
        Modes whose cluster matrices differ but have no UIO (the normal-mode design keeps
        running there, not decoupled), and why.
    notes : tuple of str
    """

    name: str
    uio: UnknownInputObserver
    channels: tuple[str, ...]
    S: np.ndarray
    F: np.ndarray
    K: np.ndarray
    Ry: np.ndarray
    Rz: np.ndarray
    designs: tuple[ModeDesign, ...]
    not_decoupled: tuple[tuple[str, str], ...]
    notes: tuple[str, ...]

    def design(self, mode: str) -> UnknownInputObserver:
        """The design that runs in ``mode``."""
        return next((d.uio for d in self.designs if d.mode == mode), self.uio)


@dataclass(frozen=True, eq=False, slots=True)
class ObserverEnvelope:
    """The attack-free envelope of one observer's residual: ``envelope[t, k]`` per channel k."""

    name: str
    channels: tuple[str, ...]
    envelope: np.ndarray


@dataclass(frozen=True, eq=False, slots=True)
class DeployedThresholds:
    """The attack-free thresholds: ``threshold_k(t) = envelope[t, k] + rounding * max(box, ||s(t)||_2)``.

    Attributes
    ----------
    rule : ThresholdRule
    t : ndarray
        The sample times.
    observers : tuple of ObserverEnvelope
    """

    rule: ThresholdRule
    t: np.ndarray
    observers: tuple[ObserverEnvelope, ...]


@dataclass(frozen=True, eq=False, slots=True)
class SwitchLinks:
    """The links a safe mode changes: ``(u, v, delta weight)`` each."""

    mode: str
    links: tuple[tuple[Label, Label, Fraction], ...]


@dataclass(frozen=True, eq=False, slots=True)
class Deployment:
    """Everything a deployment of ``system`` runs: observers, thresholds, monitors and the schedule.

    Attributes
    ----------
    name : str
        The system's name.
    labels : tuple of labels
        The agents, in the order of the state ``x = [positions; velocities]``.
    alpha, gamma : float
        The controller's gains.
    laplacians : tuple of (str, ndarray)
        ``L_q`` of every mode, normal mode first.
    monitored_positions, monitored_velocities : tuple of labels
        The global monitors.
    channels : tuple of str
        The globally monitored output channels, the rows of ``C``.
    C : ndarray
        The global output map.
    central : CentralDesign or None
        None when there is no globally monitored channel or no design (``central_note`` says why).
    central_note : str
    local : tuple of LocalDesign
    horizon, step : float
        The spec's simulation horizon and step (what the thresholds cover).
    thresholds : DeployedThresholds or None
        None when not asked for or when there is no observer.
    schedule : Schedule
        The spec's switching schedule.
    switches : tuple of SwitchLinks
        The link changes of every safe mode.
    notes : tuple of str
        What the deployment cannot promise: observers that could not be designed, modes of
        the schedule without a decoupled local observer, thresholds that stop before the
        schedule ends (:func:`deployment_checks`).
    sampled : SampledDeployment or None
        With a sampled ``[implementation]``: the detectors at period h in every mode of the
        schedule, their certified thresholds over it, Algorithm 1 and the guarantee
        (:func:`~glocal_verify.simulation.sampled_deployment.sampled_deployment`).
    """

    name: str
    labels: tuple[Label, ...]
    alpha: float
    gamma: float
    laplacians: tuple[tuple[str, np.ndarray], ...]
    monitored_positions: tuple[Label, ...]
    monitored_velocities: tuple[Label, ...]
    channels: tuple[str, ...]
    C: np.ndarray
    central: CentralDesign | None
    central_note: str
    local: tuple[LocalDesign, ...]
    horizon: float
    step: float
    thresholds: DeployedThresholds | None
    schedule: Schedule
    switches: tuple[SwitchLinks, ...]
    notes: tuple[str, ...]
    sampled: SampledDeployment | None = None


def _central(system: System) -> tuple[CentralDesign | None, str]:
    C = system.C()
    if C.shape[0] == 0:
        return None, "no globally monitored channel: no central observer"
    try:
        co = design_central_observer(system)
    except (ImportError, NotApplicableError) as exc:
        return None, f"central observer: {exc}"
    H = np.asarray(co.H, dtype=float)
    A = system.A(NORMAL_MODE)
    eig = np.asarray(co.eigenvalues, dtype=complex)
    return CentralDesign(co.mode, tuple(system.output_channels()), A, C, H, A - H @ C, eig, float(co.stability_margin), co.method), ""


def _local(system: System, designs: ModeDesigns, model: ObserverModel) -> LocalDesign:
    """One local observer: its designs in every mode and the simulator's ``model`` built from them."""
    d = designs.normal
    p = d.C.shape[0]
    per_mode = tuple(ModeDesign(m, u, model.output_map(m), d.h - u.h) for m, u in designs.modes)
    return LocalDesign(
        name=model.name,
        uio=d,
        channels=tuple(model.inputs),
        S=cluster_embedding(system, d.nodes),
        F=np.asarray(model.F[ANY_MODE], dtype=float),
        K=np.asarray(model.G[ANY_MODE], dtype=float),
        Ry=np.eye(p) - d.C @ d.h,
        Rz=d.C.copy(),
        designs=per_mode,
        not_decoupled=designs.missing,
        notes=tuple(model.notes),
    )


def schedule_end(system: System, schedule: Schedule) -> float:
    """When the spec's schedule ends: a ``sequence``'s start plus its durations (its last mode
    persists after it), else the last switch."""
    sw = system.spec.switching
    if sw is not None and sw.sequence:
        return float(sw.time or 0.0) + sum(float(st.duration) for st in sw.sequence)
    return max(schedule.switch_times, default=0.0)


def deployment_checks(system: System, schedule: Schedule, local: tuple[LocalDesign, ...], horizon: float, sampled: SampledDeployment | None, thresholds: bool) -> list[str]:
    """What the deployment cannot promise, as notes: every mode of the schedule must have a
    decoupled local observer, the thresholds must cover the schedule."""
    out: list[str] = []
    modes = set(schedule.modes)
    for d in local:
        for m, why in d.not_decoupled:
            if m in modes:
                out.append(f"{d.name}: no decoupled observer in mode {m} of the schedule ({why}); its residual there moves with the neighbours and its threshold is no guarantee")
    end = schedule_end(system, schedule)
    if thresholds and end > horizon:
        out.append(f"the continuous thresholds stop at t = {horizon:g} s, before the schedule ends at t = {end:g} s")
    if thresholds and schedule.switch_times:
        out.append(f"the continuous envelope covers t <= {horizon:g} s; the last mode persists after it without an envelope (the sampled thresholds' tail covers it)" if sampled is not None else f"the continuous envelope covers t <= {horizon:g} s only; the last mode persists after it without a threshold")
    if sampled is not None:
        for name, ds in sampled.thresholds.detectors.items():
            for s, m, c in ds.segments:
                if not c:
                    out.append(f"sampled {name}: no certified threshold in mode {m} from sample {s} (t = {s * sampled.thresholds.period:g} s) on")
                    break
        if sampled.safe_mode is not None and sampled.thresholds.after_switch is None:
            out.append(f"sampled central: no certified threshold after Algorithm 1's switch to {sampled.safe_mode}")
    return out


def design_deployment(system: System, *, thresholds: bool = True, progress: bool = False, sampled: bool = True) -> Deployment:
    """Design the observers of ``system`` and compute their thresholds: the :class:`Deployment`.

    Parameters
    ----------
    system : System
    thresholds : bool
        Compute the attack-free thresholds for the spec's switching schedule (the exact
        envelope of :func:`~glocal_verify.simulation.thresholds.attack_free_thresholds`, over
        the spec's horizon and step, under the default :class:`ThresholdRule`); False leaves
        :attr:`Deployment.thresholds` None.
    progress : bool
        Report the thresholds' progress on stderr.
    sampled : bool
        With a sampled ``[implementation]``, include the sampled deployment (detectors per
        mode, certified thresholds over the schedule, Algorithm 1, the guarantee).

    Returns
    -------
    Deployment
        Its ``notes`` say what it cannot promise (:func:`deployment_checks`); the command
        prints them on stderr.
    """
    central, note = _central(system)
    notes: list[str] = []
    designs = local_designs(system, notes=notes)
    models = [local_observer_model(system, d) for d in designs]
    bank = ObserverBank(((central_observer_model(system, central.H),) if central is not None else ()) + tuple(models), tuple(notes))
    schedule = Schedule.from_spec(system)
    sim = system.spec.simulation
    horizon = max(float(sim.horizon), schedule_end(system, schedule))
    if horizon > float(sim.horizon):
        notes.append(f"thresholds computed to t = {horizon:g} s, where the schedule ends (the spec's horizon is {float(sim.horizon):g} s)")
    thr: DeployedThresholds | None = None
    if thresholds and len(bank):
        rule = ThresholdRule()
        th = attack_free_thresholds(system, bank, schedule, rule, horizon=horizon, progress=progress)
        envelopes = tuple(ObserverEnvelope(name, tuple(bank[name].channels), np.asarray(env, dtype=float)) for name, env in th.envelope.items())
        thr = DeployedThresholds(rule, np.asarray(th.t, dtype=float), envelopes)
    dep_sampled = None
    impl = system.spec.implementation
    if sampled and impl is not None and impl.controller == "sampled":
        if progress:
            write_line("glocal-verify: the sampled detectors of every mode and their certified thresholds over the schedule ...")
        try:
            dep_sampled = sampled_deployment(system)
        except NotApplicableError as exc:
            notes.append(f"sampled deployment: {exc}")
    local = tuple(_local(system, d, m) for d, m in zip(designs, models))
    warnings = deployment_checks(system, schedule, local, horizon, dep_sampled, thr is not None)
    if dep_sampled is not None:
        warnings += [f"sampled: {n}" for n in dep_sampled.notes]
    return Deployment(
        name=system.name,
        labels=tuple(system.labels),
        alpha=float(system.alpha),
        gamma=float(system.gamma),
        laplacians=tuple((m, system.laplacian(m)) for m in system.modes),
        monitored_positions=tuple(system.monitored_positions),
        monitored_velocities=tuple(system.monitored_velocities),
        channels=tuple(system.output_channels()),
        C=system.C(),
        central=central,
        central_note=note,
        local=local,
        horizon=horizon,
        step=float(sim.step),
        thresholds=thr,
        schedule=schedule,
        switches=tuple(SwitchLinks(m, tuple(system.switching_links(m))) for m in system.modes if m != NORMAL_MODE),
        notes=tuple(dict.fromkeys(notes + warnings)),
        sampled=dep_sampled,
    )
