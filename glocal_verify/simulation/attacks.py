"""Attack signals: zero-dynamics attacks from a direction, covert attacks, and the spec's attack.

Every attack is a linear exosystem ``w' = S w, u_a = G w`` (:class:`Exosystem`), so the
simulation stays piecewise LTI and exact.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np
import scipy.linalg

from glocal_verify.analysis.stealthy.covert import channel_label
from glocal_verify.analysis.stealthy.zda_verdict import zda_direction
from glocal_verify.errors import ModelError, NotApplicableError
from glocal_verify.model import System
from glocal_verify.spec.types import NORMAL_MODE, Label

__all__ = [
    "Exosystem",
    "AttackModel",
    "zda_attack",
    "zda_attack_from_direction",
    "covert_attack",
    "attack_from_spec",
]

# --------------------------------------------------------------------------------------------
# attack signals


@dataclass(frozen=True, slots=True)
class Exosystem:
    """Linear generator of an attack signal: :math:`\\dot w = S w`, :math:`w(t_a) = w_0`,
    :math:`u_a = G w`.

    Attributes
    ----------
    S : ndarray
        m x m generator matrix.
    w0 : ndarray
        Initial exosystem state at the attack start (m,).
    G : ndarray
        |F| x m output map to the attacked actuators (ordered like ``AttackModel.actuators``).
    """

    S: np.ndarray
    w0: np.ndarray
    G: np.ndarray

    @property
    def dim(self) -> int:
        """Exosystem order m."""
        return int(self.S.shape[0])

    def signal(self, tau: float | np.ndarray) -> np.ndarray:
        """Attack input :math:`u_a(t_a + \\tau)` for the times ``tau`` >= 0 (rows: times)."""
        taus = np.atleast_1d(np.asarray(tau, dtype=float))
        out = np.empty((len(taus), self.G.shape[0]))
        for k, s in enumerate(taus):
            out[k] = self.G @ (scipy.linalg.expm(self.S * s) @ self.w0)
        return out

    @classmethod
    def exponential(cls, u0: np.ndarray, lambda0: complex) -> "Exosystem":
        """:math:`u_a(t) = \\operatorname{Re}(u_0 e^{\\lambda_0 (t - t_a)})`.

        Parameters
        ----------
        u0 : array_like
            Input direction (complex allowed).
        lambda0 : complex
            Exponent. A real ``lambda0`` gives a 1-dimensional exosystem with
            :math:`G = \\operatorname{Re} u_0`; a complex one a 2-dimensional rotation-growth
            :math:`w = [\\operatorname{Re}, \\operatorname{Im}]\\, e^{\\lambda_0 \\tau}`.
        """
        u = np.asarray(u0, dtype=complex).ravel()
        lam = complex(lambda0)
        if lam.imag == 0.0:
            return cls(np.array([[lam.real]]), np.ones(1), u.real.reshape(-1, 1).copy())
        a, b = lam.real, lam.imag
        return cls(np.array([[a, -b], [b, a]]), np.array([1.0, 0.0]), np.column_stack([u.real, -u.imag]))

    @classmethod
    def step(cls, amplitude: float, inputs: int) -> "Exosystem":
        """A step of height ``amplitude`` on each of ``inputs`` actuators."""
        return cls(np.zeros((1, 1)), np.ones(1), float(amplitude) * np.ones((inputs, 1)))

    @classmethod
    def sine(cls, amplitude: float, frequency: float, inputs: int) -> "Exosystem":
        """``amplitude * sin(2 pi frequency (t - t_a))`` on each of ``inputs`` actuators."""
        om = 2.0 * math.pi * float(frequency)
        G = np.zeros((inputs, 2))
        G[:, 0] = float(amplitude)
        return cls(np.array([[0.0, om], [-om, 0.0]]), np.array([0.0, 1.0]), G)


@dataclass(frozen=True, slots=True)
class AttackModel:
    """An attack ready to simulate.

    Attributes
    ----------
    kind : str
        ``"zda"`` (Proposition II.4 (ii)) or ``"covert"`` (Proposition II.4 (i)).
    actuators : tuple of labels
        Attacked actuators F (columns of B, in this order).
    exosystem : Exosystem
        Generator of :math:`u_a`.
    start : float
        Attack start :math:`t_a`.
    offset : ndarray or None
        State deviation :math:`\\tilde x_0` (2N,) added to the plant state at ``start`` (ZDA).
    spoofed : tuple of str
        Global output channels (``"x:<label>"``, ``"v:<label>"``) on which the attacker
        subtracts :math:`C \\tilde x` of its copy (covert attack).
    lambda0, xi, u0 : complex, ndarray, ndarray or None
        ZDA exponent, position direction (N,) and input direction (|F|,), as scaled.
    moved : tuple of labels
        Agents whose state the attack moves (supp xi for a ZDA; the agents reached by
        :math:`u_a` for a covert attack).
    notes : tuple of str
    """

    kind: str
    actuators: tuple[Label, ...]
    exosystem: Exosystem
    start: float = 0.0
    offset: np.ndarray | None = None
    spoofed: tuple[str, ...] = ()
    lambda0: complex | None = None
    xi: np.ndarray | None = None
    u0: np.ndarray | None = None
    moved: tuple[Label, ...] = ()
    notes: tuple[str, ...] = ()

    @property
    def has_copy(self) -> bool:
        """True when the attacker runs its own copy of the normal-mode model (covert)."""
        return self.kind == "covert"

    def describe(self) -> dict[str, Any]:
        """JSON-ready summary."""
        out: dict[str, Any] = {
            "kind": self.kind,
            "actuators": list(self.actuators),
            "start": self.start,
            "moved": list(self.moved),
        }
        if self.lambda0 is not None:
            lam = complex(self.lambda0)
            out["lambda0"] = lam.real if lam.imag == 0 else [lam.real, lam.imag]
        if self.spoofed:
            out["spoofed"] = list(self.spoofed)
        if self.notes:
            out["notes"] = list(self.notes)
        return out


def _phase_normalise(xi: np.ndarray, u0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    k = int(np.argmax(np.abs(xi)))
    scale = xi[k]
    if scale == 0:
        raise NotApplicableError("the zero direction has no position component (xi = 0)")
    return xi / scale, u0 / scale


def zda_attack_from_direction(
    system: System,
    lambda0: complex,
    xi: np.ndarray,
    u0: np.ndarray,
    *,
    amplitude: float = 1.0,
    start: float = 0.0,
    actuators: Sequence[Label] | None = None,
) -> AttackModel:
    """A ZDA from a given zero direction (Definition II.2, eq. ``zda_cond``).

    Parameters
    ----------
    system : System
    lambda0 : complex
        The zero.
    xi : array_like
        Position part of the zero direction, :math:`\\tilde x_0 = [\\xi; \\lambda_0 \\xi]` (N,).
    u0 : array_like
        Input direction (|F|,), ordered like ``actuators``.
    amplitude : float
        The direction is scaled so that :math:`\\max_i |\\xi_i| =` ``amplitude`` with the
        largest entry real and positive.
    start : float
        Attack start :math:`t_a`.
    actuators : sequence of labels, optional
        Default: the spec's attacked actuators.
    """
    F = tuple(system.attacked if actuators is None else actuators)
    lam = complex(lambda0)
    x = np.asarray(xi, dtype=complex).ravel()
    u = np.asarray(u0, dtype=complex).ravel()
    if x.shape != (system.n,) or u.shape != (len(F),):
        raise ModelError(f"zero direction shapes xi {x.shape}, u0 {u.shape} do not fit N = {system.n}, |F| = {len(F)}")
    x, u = _phase_normalise(x, u)
    x, u = amplitude * x, amplitude * u
    if lam.imag == 0.0:
        x, u = x.real.astype(complex), u.real.astype(complex)
    offset = np.concatenate([x, lam * x]).real.copy()
    big = float(np.max(np.abs(x)))
    moved = tuple(lab for lab, val in zip(system.labels, x) if abs(val) > 1e-9 * big)
    return AttackModel(
        "zda",
        F,
        Exosystem.exponential(u, lam),
        float(start),
        offset,
        (),
        lam,
        x,
        u,
        moved,
    )


def zda_attack(
    system: System,
    *,
    lambda0: complex | None = None,
    amplitude: float = 1.0,
    start: float = 0.0,
) -> AttackModel:
    """The ZDA of ``stealthy.zda`` for the spec's attacked actuators.

    Parameters
    ----------
    system : System
    lambda0 : complex, optional
        Chosen zero; default the one :func:`glocal_verify.analysis.stealthy.zda_verdict.zda_direction` picks (the witness of ``stealthy.zda``'s rule).
    amplitude : float
        Scale of the direction (:func:`zda_attack_from_direction`).
    start : float
        Attack start.

    Raises
    ------
    NotApplicableError
        When no ZDA exists at ``lambda0`` (or ``stealthy`` is not available).
    """
    d = zda_direction(system, lambda0)
    if d is None:
        where = f" at lambda0 = {lambda0}" if lambda0 is not None else ""
        raise NotApplicableError(f"no zero-dynamics attack exists through actuators {list(system.attacked)}{where}")
    return zda_attack_from_direction(system, d.lambda0, d.xi, d.u0, amplitude=amplitude, start=start)


def covert_attack(
    system: System,
    *,
    signal: str = "step",
    amplitude: float = 1.0,
    frequency: float = 1.0,
    lambda0: complex | None = None,
    start: float = 0.0,
    sensors: Sequence[Label] | None = None,
    actuators: Sequence[Label] | None = None,
) -> AttackModel:
    """A covert attack (Proposition II.4 (i)): :math:`u_a` from an exosystem, :math:`u_s = C\\tilde x`.

    Parameters
    ----------
    system : System
    signal : str
        ``"step"``, ``"sine"`` or ``"exponential"`` (the same on every attacked actuator).
    amplitude, frequency : float
        Height and frequency (Hz) of the signal.
    lambda0 : complex, optional
        Exponent of an ``"exponential"`` signal (default 0.5).
    start : float
        Attack start :math:`t_a` (the copy starts from :math:`\\tilde x(t_a) = 0`).
    sensors : sequence of labels, optional
        Agents whose global channels the attacker owns (default the spec's ``attack.sensors``);
        every monitored channel of these agents is spoofed.
    actuators : sequence of labels, optional
        Default: the spec's attacked actuators.
    """
    F = tuple(system.attacked if actuators is None else actuators)
    if not F:
        raise ModelError("a covert attack needs at least one attacked actuator")
    sens = tuple(system.spec.attack.sensors if (sensors is None and system.spec.attack) else (sensors or ()))
    spoofed = tuple(ch for ch in system.output_channels() if channel_label(system, ch) in sens)
    notes: list[str] = []
    if signal == "step":
        exo = Exosystem.step(amplitude, len(F))
    elif signal == "sine":
        exo = Exosystem.sine(amplitude, frequency, len(F))
    elif signal == "exponential":
        lam = complex(0.5 if lambda0 is None else lambda0)
        if lambda0 is None:
            notes.append("exponential covert signal: lambda0 defaults to 0.5")
        exo = Exosystem.exponential(amplitude * np.ones(len(F)), lam)
    else:
        raise ModelError(f"unknown covert signal {signal!r} (expected step, sine or exponential)")
    reached = _reached_agents(system, F)
    return AttackModel(
        "covert",
        F,
        exo,
        float(start),
        None,
        spoofed,
        None if signal != "exponential" else complex(0.5 if lambda0 is None else lambda0),
        None,
        None,
        reached,
        tuple(notes),
    )


def _reached_agents(system: System, actuators: Sequence[Label]) -> tuple[Label, ...]:
    """Agents connected (normal mode) to an attacked actuator: the support the input reaches."""
    import networkx as nx

    G = system.graph(NORMAL_MODE)
    seen: set[Label] = set()
    for a in actuators:
        seen |= set(nx.node_connected_component(G, a))
    return tuple(lab for lab in system.labels if lab in seen)


def attack_from_spec(system: System) -> AttackModel | None:
    """The attack of the spec's ``[attack]`` table, or None without one.

    A ZDA uses :func:`zda_attack` (the zero of ``stealthy.zda`` at ``attack.lambda0`` when
    given), scaled by ``attack.amplitude``; a covert attack uses :func:`covert_attack` with
    ``attack.signal`` (default ``"step"``), ``amplitude``, ``frequency`` and ``sensors``.

    Parameters
    ----------
    system : System
    """
    a = system.spec.attack
    if a is None:
        return None
    if a.kind == "zda":
        return zda_attack(system, lambda0=a.lambda0, amplitude=a.amplitude, start=a.start)
    return covert_attack(
        system,
        signal=a.signal or "step",
        amplitude=a.amplitude,
        frequency=a.frequency,
        lambda0=a.lambda0,
        start=a.start,
        sensors=a.sensors,
    )
