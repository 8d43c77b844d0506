"""Privacy conditions: Lemma III.1 (``lemma:Inv_unobs_subspace``) and Problem 1.

Lemma III.1: span{[1; 0]} is an A_q-invariant unobservable subspace of the switched system
provided [1; 0] lies in ker C and every G_q is connected and undirected.
"""

from __future__ import annotations

import math

import numpy as np

from .model import System
from .registry import CheckContext, checker, result
from .results import ConditionResult, Status

__all__ = ["check_connected", "check_kernel"]


@checker("privacy.connected")
def check_connected(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Every communication graph G_q is connected (Lemma III.1's assumption).

    .. math:: \\lambda_2(L_q) > 0 \\iff G_q \\text{ connected}

    The verdict is combinatorial (connected components of the positive-weight edges, which
    the spec fixes exactly), so it has no tolerance; numeric and exact mode agree by
    construction. Scope: every mode, the normal one included.

    Margin
        The algebraic connectivity lambda_2(L_q) (0 exactly when the graph is disconnected),
        computed in floating point in both modes.
    Witness
        ``components``: the components as label lists when the graph is disconnected; on
        success the algebraic connectivity.
    """
    out = []
    for mode in system.modes:
        comps = system.components(mode)
        w, _ = system.eigh(mode)
        lam2 = float(w[1]) if system.n > 1 else 0.0
        if len(comps) == 1:
            status = Status.HOLDS
            margin = max(lam2, 0.0)
            witness: dict[str, object] = {"components": 1, "algebraic_connectivity": margin}
        else:
            status = Status.FAILS
            margin = 0.0
            witness = {"components": comps, "links_needed": len(comps) - 1}
        out.append(result("privacy.connected", ctx, status, scope={"mode": mode}, margin=margin, witness=witness, numeric_decision=False))
    return out


@checker("privacy.kernel")
def check_kernel(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """[1; 0] lies in ker C (Lemma III.1).

    .. math:: C \\begin{bmatrix} \\mathbf 1 \\\\ 0 \\end{bmatrix} = S_{M_x} \\mathbf 1 = 0
              \\iff M_x = \\emptyset

    for selection outputs. Combinatorial, no tolerance. Scope: global (C does not switch).

    Margin
        ``||C [1; 0]|| / ||[1; 0]|| = sqrt(|M_x| / N)``: 0 when the condition holds, the
        distance of the consensus direction from ker C otherwise.
    Witness
        ``position_monitors`` (the agents whose position channel reveals the consensus
        direction) and ``C_times_one`` (the nonzero output entries).
    """
    mx = list(system.monitored_positions)
    margin = math.sqrt(len(mx) / system.n) if system.n else 0.0
    if not mx:
        status = Status.HOLDS
        witness: dict[str, object] = {"position_monitors": []}
    else:
        status = Status.FAILS
        witness = {"position_monitors": mx, "C_times_one": {f"x:{a}": 1 for a in mx}}
    return [result("privacy.kernel", ctx, status, margin=margin, witness=witness, numeric_decision=False)]


def consensus_direction(system: System) -> np.ndarray:
    """The unit vector [1; 0] / sqrt(N) of R^{2N}."""
    v = np.zeros(2 * system.n)
    v[: system.n] = 1.0 / math.sqrt(system.n)
    return v
