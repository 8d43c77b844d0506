"""Switching schedules, simulation results and random attack-free initial states."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from glocal_verify.errors import ModelError
from glocal_verify.model import System
from glocal_verify.simulation.attacks import AttackModel
from glocal_verify.spec.types import NORMAL_MODE, Label

__all__ = [
    "Schedule",
    "SimulationResult",
    "random_initial_state",
]

#: any mode: key of :attr:`ObserverModel.F` used when a mode has no design of its own
ANY_MODE = "*"


# --------------------------------------------------------------------------------------------
# schedules


@dataclass(frozen=True, slots=True)
class Schedule:
    """Mode schedule: ``segments[k] = (start time, mode)``, the first at t = 0.

    Attributes
    ----------
    segments : tuple of (float, str)
    """

    segments: tuple[tuple[float, str], ...] = ((0.0, NORMAL_MODE),)

    def __post_init__(self) -> None:
        if not self.segments or self.segments[0][0] != 0.0:
            raise ModelError("a schedule starts at t = 0")
        times = [t for t, _ in self.segments]
        if any(b <= a for a, b in zip(times, times[1:])):
            raise ModelError(f"schedule times must increase: {times}")

    @classmethod
    def single(cls, mode: str | None, time: float | None) -> "Schedule":
        """Normal mode until ``time``, then ``mode`` (no switch when either is None)."""
        if mode is None or time is None or mode == NORMAL_MODE:
            return cls()
        return cls(((0.0, NORMAL_MODE), (float(time), mode)))

    @classmethod
    def from_spec(cls, system: System, mode: str | None = None) -> "Schedule":
        """The spec's ``[switching]`` table.

        ``mode`` + ``time``: one switch. ``sequence``: its steps one after the other, from
        ``time`` if given, else from t = 0 (the last mode persists; a first step that is
        the normal mode just delays the switches). With a sequence, ``switching.mode`` is not
        used. ``mode`` (argument) replaces the spec's switching mode (one switch at the
        spec's time, or at the first switch of the sequence).

        Parameters
        ----------
        system : System
        mode : str, optional
            Override of the safe mode.
        """
        sw = system.spec.switching
        if sw is None:
            if mode is not None:
                raise ModelError("the spec has no [switching] table: give a switching time")
            return cls()
        if mode is not None:
            system.check_mode(mode)
            if sw.time is not None:
                return cls.single(mode, sw.time)
            times = cls.from_spec(system).switch_times
            if not times:
                raise ModelError("the spec's [switching] table has no switching time")
            return cls.single(mode, times[0])
        if sw.sequence:
            t = float(sw.time) if sw.time is not None else 0.0
            segs: list[tuple[float, str]] = [(0.0, NORMAL_MODE)]
            for step in sw.sequence:
                if segs[-1][1] != step.mode:
                    if t == segs[-1][0]:
                        segs[-1] = (t, step.mode)
                    else:
                        segs.append((t, step.mode))
                t += float(step.duration)
            return cls(tuple(segs))
        return cls.single(sw.mode, sw.time)

    @property
    def switch_times(self) -> tuple[float, ...]:
        """Times at which the mode changes."""
        return tuple(t for t, _ in self.segments[1:])

    @property
    def modes(self) -> tuple[str, ...]:
        """Modes in order of activation."""
        return tuple(m for _, m in self.segments)

    def mode_at(self, t: float) -> str:
        """Active mode at time ``t`` (right-continuous)."""
        mode = self.segments[0][1]
        for s, m in self.segments:
            if t >= s:
                mode = m
        return mode

    def to_json(self) -> list[dict[str, Any]]:
        """``[{"time": t, "mode": m}, ...]``."""
        return [{"time": t, "mode": m} for t, m in self.segments]


# --------------------------------------------------------------------------------------------
# results


@dataclass(frozen=True, slots=True)
class SimulationResult:
    """Sampled trajectories of one simulation.

    Attributes
    ----------
    t : ndarray
        Sample times (K + 1,), uniform with the spec's ``simulation.step``.
    x : ndarray or None
        Plant state samples (K + 1, 2N) [positions; velocities] (None when not recorded or
        for batch runs).
    residuals : mapping of str to ndarray
        Per observer, residual samples (K + 1, q) — for batch runs reduced over the batch.
    channels : mapping of str to tuple of str
        Names of the residual components.
    state_scale : ndarray
        2-norm of the simulated state (plant, attacker copy, observers) at each sample
        (maximum over the batch): the scale of the rounding errors.
    labels : tuple of labels
    schedule : Schedule
    attack : AttackModel or None
    method : str
        ``"dense"`` or ``"modal"``.
    taylor_order : int or None
        J of the modal method (None for dense).
    internal_steps : int
        Internal steps per output step (modal method).
    interrupted : bool
        True when the run was stopped (Ctrl-C); the arrays hold the samples computed so far.
    notes : tuple of str
    """

    t: np.ndarray
    x: np.ndarray | None
    residuals: Mapping[str, np.ndarray]
    channels: Mapping[str, tuple[str, ...]]
    state_scale: np.ndarray
    labels: tuple[Label, ...]
    schedule: Schedule
    attack: AttackModel | None
    method: str
    taylor_order: int | None = None
    internal_steps: int = 1
    interrupted: bool = False
    notes: tuple[str, ...] = ()

    def __repr__(self) -> str:
        modes = " -> ".join(self.schedule.modes)
        attack = f", attack on {list(self.attack.actuators)}" if self.attack is not None else ""
        return (
            f"SimulationResult({len(self.labels)} agents, t = 0..{float(self.t[-1]) if len(self.t) else 0.0:g} s in {len(self.t)} samples, "
            f"{modes}{attack}, residuals of {len(self.residuals)} observers, {self.method})"
        )

    @property
    def n(self) -> int:
        """Number of agents."""
        return len(self.labels)

    def positions(self) -> np.ndarray:
        """Position samples (K + 1, N)."""
        if self.x is None:
            raise ModelError("the states were not recorded")
        return self.x[:, : self.n]

    def velocities(self) -> np.ndarray:
        """Velocity samples (K + 1, N)."""
        if self.x is None:
            raise ModelError("the states were not recorded")
        return self.x[:, self.n :]

    def window(self, start: float = -math.inf, stop: float = math.inf) -> np.ndarray:
        """Boolean mask of the samples with ``start <= t < stop``."""
        return (self.t >= start) & (self.t < stop)


# --------------------------------------------------------------------------------------------
# helpers


def random_initial_state(system: System, box: float = 1.0, seed: int | None = None) -> np.ndarray:
    """Attack-free initial state drawn uniformly from :math:`[-box, box]^{2N}`.

    Parameters
    ----------
    system : System
    box : float
        Half-width of the box.
    seed : int, optional
        Default ``simulation.seed`` of the spec.
    """
    rng = np.random.default_rng(system.spec.simulation.seed if seed is None else seed)
    return rng.uniform(-box, box, size=2 * system.n)
