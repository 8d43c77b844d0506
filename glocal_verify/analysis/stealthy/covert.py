"""Covert attacks (Proposition II.4 (i)): the agents an attack reaches and the channels it must own."""

from __future__ import annotations

from typing import Iterable

from glocal_verify.analysis.stealthy.zda import _actuators
from glocal_verify.errors import NotApplicableError
from glocal_verify.model import System
from glocal_verify.spec.types import Label

__all__ = [
    "channel_label",
    "covert_required_channels",
    "reachable_agents",
]

# ------------------------------------------------------------------------------------------
# covert attacks


def reachable_agents(system: System, actuators: Iterable[Label] | None = None) -> list[Label]:
    """Agents whose state u_a can move: the connected components (normal mode) that contain
    an attacked actuator, in label order.

    Parameters
    ----------
    system : System
        The system.
    actuators : iterable of labels, optional
        F; default the spec's attacked actuators.
    """
    F = set(_actuators(system, actuators))
    out: list[Label] = []
    for comp in system.components():
        if F & set(comp):
            out.extend(comp)
    return sorted(out, key=system.index.__getitem__)


def covert_required_channels(system: System) -> list[str]:
    """Monitored output channels reached by the attack input u_a (normal mode).

    A channel (a row c of C) is reached iff c A_1^k B != 0 for some k. Structurally, for
    positive weights: with d = dist(j, a) in the graph, the (j, a) entry of L^d is a sum over
    shortest paths of products of the off-diagonal entries -w, all of sign (-1)^d, so it is
    nonzero and lower powers vanish; expanding (lambda^2 + gamma lambda + alpha L)^{-1} in
    1/lambda, the first Markov parameter from u_a to x_j is (-alpha)^d (L^d)_{ja} at
    k = 2d + 1, and to v_j at k = 2d. Hence x:j and v:j are reached iff j is connected to
    some attacked agent; no tolerance is involved.

    Parameters
    ----------
    system : System
        The system; F is its ``attack.actuators``.

    Returns
    -------
    list of str
        Channel names (``"x:<label>"``, ``"v:<label>"``) in the order of
        :meth:`System.output_channels`.
    """
    R = set(reachable_agents(system))
    out = []
    for ch in system.output_channels():
        lab = channel_label(system, ch)
        if lab in R:
            out.append(ch)
    return out


def channel_label(system: System, ch: str) -> Label:
    """The agent of an output channel name (``"x:<label>"`` or ``"v:<label>"``).

    Parameters
    ----------
    system : System
    ch : str
        A name of :meth:`System.output_channels`.
    """
    kind, _, rest = ch.partition(":")
    for lab in system.labels:
        if str(lab) == rest:
            return lab
    raise NotApplicableError(f"unknown channel {ch!r}")  # pragma: no cover
