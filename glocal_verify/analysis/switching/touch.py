"""The link change of a safe mode and what it does to an attack direction (Remark III.3.1).

The switch to mode q changes the Laplacian by :math:`\\Delta L_q = L_q - L_1`, zero outside the
switching components D_q; a stealthy ZDA direction xi is *touched* by the switch when
:math:`\\Delta L_q \\xi \\ne 0`. This module holds the pieces both touch tests read: the block
:math:`\\Delta L_q[D, D]` (:func:`delta_block`), its 2-norm (:func:`block_norm`, :func:`delta_norm`)
and :class:`Avoidance`, the answer of either test (the numeric and exact ones of
:mod:`.avoidance`, the exact one at lambda0 = 0 of :mod:`.zero_touch`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np

from glocal_verify.analysis.stealthy.zda import ZdaDirection
from glocal_verify.model import System
from glocal_verify.results import Status
from glocal_verify.spec.types import Label

__all__ = ["Avoidance", "block_norm", "delta_block", "delta_norm"]


def delta_block(system: System, mode: str) -> tuple[list[int], np.ndarray]:
    """Indices D of the switching components and dL_q[D, D] (dL_q is zero outside D x D)."""
    labs = [lab for comp in system.switching_components(mode) for lab in comp]
    idx = system.idx(labs)
    pos = {i: k for k, i in enumerate(idx)}
    blk = np.zeros((len(idx), len(idx)))
    for u, v, dw in system.switching_links(mode):
        a, b = pos[system.index[u]], pos[system.index[v]]
        w = float(dw)
        blk[a, b] -= w
        blk[b, a] -= w
        blk[a, a] += w
        blk[b, b] += w
    return idx, blk


def block_norm(blk: np.ndarray) -> float:
    if blk.size == 0:
        return 0.0
    return float(np.max(np.abs(np.linalg.eigvalsh(blk)), initial=0.0))


def delta_norm(system: System, mode: str) -> float:
    """||dL_q||_2, computed on the switching components D_c (dL_q is zero elsewhere).

    Parameters
    ----------
    system : System
        The system.
    mode : str
        A safe mode.
    """
    return block_norm(delta_block(system, mode)[1])


@dataclass(frozen=True, slots=True)
class Avoidance:
    """Can a stealthy ZDA at lambda0 avoid the switch to ``mode``? (Remark III.3.1)

    Attributes
    ----------
    mode : str
        The safe mode q.
    status : Status
        ``HOLDS``: an avoiding direction exists (the switch does not touch the attack);
        ``FAILS``: every stealthy direction at lambda0 is touched; ``UNDECIDED`` (numeric only).
    lambda0 : complex
        The exponent (see the module docstring for how it is chosen).
    growth : str
        Growth class of lambda0 (``unbounded`` / ``persistent`` / ``decaying`` / ``undecided``).
    chosen : ZdaDirection
        The witness direction of ``stealthy.zda``.
    chosen_source : str
        Why ``stealthy.zda`` chose it.
    chosen_touched : bool or None
        dL_q xi != 0 for the chosen direction (None: undecided).
    chosen_touched_agents : tuple of labels
        Rows of dL_q xi (chosen direction) that are nonzero.
    direction : ZdaDirection or None
        On ``HOLDS`` the avoiding direction: the chosen one when it is untouched, else a
        vector of the avoiding subspace with the largest input part.
    direction_source : str
        ``stealthy.zda`` or ``kernel of the stacked system``.
    dimension : int or None
        Rank of the u0-part of the avoiding subspace {(xi, u0) in Z : dL_q xi = 0} (the
        number of independent inputs an avoiding attacker has). Numeric: the count of
        certainly nonzero singular values (a lower bound; at least 1 on ``HOLDS``); 0 on
        ``FAILS``; None when undecided.
    margin : float
        See ``MARGIN_SCALE``.
    dl_residual : float
        ||dL_q xi|| / (||dL_q||_2 ||xi||) of ``direction`` (on ``HOLDS``).
    exact_xi, exact_u0 : tuple of Fraction or None
        The avoiding direction over Q (exact path, rational lambda0), xi scaled to max |xi_k| = 1.
    notes : tuple of str
    """

    mode: str
    status: Status
    lambda0: complex
    growth: str
    chosen: ZdaDirection
    chosen_source: str
    chosen_touched: bool | None
    chosen_touched_agents: tuple[Label, ...]
    direction: ZdaDirection | None
    direction_source: str
    dimension: int | None
    margin: float
    dl_residual: float = math.nan
    exact_xi: tuple[Fraction, ...] | None = None
    exact_u0: tuple[Fraction, ...] | None = None
    notes: tuple[str, ...] = field(default_factory=tuple)
