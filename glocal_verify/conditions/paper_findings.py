"""Report-level findings that follow from a system and its verdicts.

Each rule is registered with :func:`~glocal_verify.conditions.registry.finding_rule` and adds a
:class:`~glocal_verify.results.Finding` to every report where it applies. Rules belonging to
one paper result live in that result's module; this module holds the ones about the paper's
problem statements.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Sequence

from glocal_verify.conditions.registry import finding_rule
from glocal_verify.model import System
from glocal_verify.results import ConditionResult, Finding
from glocal_verify.spec.types import Label

__all__ = [
    "topology_revealed",
    "intersection_wording",
]

@finding_rule
def topology_revealed(system: System, results: Sequence[ConditionResult]) -> list[Finding]:
    """Problem 1 (ii) has no checkable statement; say what the outputs do reveal.

    With y_v = S_{M_v} v, the first Markov parameter gives
    d/dt y_v = -alpha S_{M_v} L_q x - gamma y_v: the rows of L_q of the velocity-monitored
    agents (their neighbours and weights) enter the output map directly, so anyone who
    identifies the input-output behaviour learns them.
    """
    mv = list(system.monitored_velocities)
    if not mv:
        return []
    rows = {}
    for a in mv:
        rows[str(a)] = {str(b): float(w) for b, w in _row(system, a).items()}
    return [
        Finding(
            "problem1.topology",
            "Problem 1 (ii) is not a checkable condition; the outputs reveal the monitored agents' rows of L",
            "The paper asks that the topology be non-reconstructable but states no condition. "
            "C A_q = [S_Mx, 0; -alpha S_Mv L_q, -gamma S_Mv] contains the rows of L_q of the "
            f"velocity-monitored agents {mv}: their neighbour sets and weights are exposed to whoever "
            "identifies the output map (in every mode).",
            "Problem 1 (ii)",
            {"revealed_rows_normal_mode": rows},
        )
    ]


def _row(system: System, a: Label) -> dict[Label, Fraction]:
    out: dict[Label, Fraction] = {}
    for key, w in system.edges().items():
        if a in key:
            (b,) = tuple(key - {a})
            out[b] = w
    return out


@finding_rule
def intersection_wording(system: System, results: Sequence[ConditionResult]) -> list[Finding]:
    """Theorem III.3 (i) and eq. ``cond_suff_0`` write an intersection of subspaces "= emptyset"."""
    if not any(r.id == "switching.image-kernel" for r in results):
        return []
    return [
        Finding(
            "theorem3.empty-intersection",
            "Theorem III.3 (i) asks an intersection of subspaces to be empty",
            "Im(dL_q) ∩ ker([S_Mx; S_Mv]) always contains 0, so '= emptyset' can never hold; the toolkit "
            "checks the intended '= {0}', i.e. rank(S_M dL_q) = rank(dL_q).",
            "Theorem III.3 (i), eq. cond_suff_0",
        )
    ]
