"""The ``central.observer`` checker and the finding that the paper's observer requirement is infeasible.

Holds when the designed gain H (:func:`~glocal_verify.observers.central.design_central_observer`)
makes ``A_1 - H C`` stable on the observable part (the rule:
:func:`~glocal_verify.observers.central_verdict.central_observer_verdict`); the fixed
unobservable eigenvalues are reported in the witness. With privacy (``[1; 0]`` in ``ker C``),
``0`` is an eigenvalue of ``A_q - H C`` for every H, so the paper's "Hurwitz in all modes" is
infeasible: a finding.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from glocal_verify.conditions.registry import (
    CheckContext,
    checker,
    finding_rule,
    verdict_result,
)
from glocal_verify.model import System
from glocal_verify.observers.central_verdict import central_observer_verdict
from glocal_verify.results import ConditionResult, Finding

__all__ = [
    "check_central_observer",
    "hurwitz_infeasible_finding",
]


@checker("central.observer")
def check_central_observer(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Centralised observer (eq. ``obs_cent``): ``A_1 - H C`` is stable on the observable part.

    .. math:: \\max \\operatorname{Re} \\lambda\\big((A_1 - H C)|_{\\mathbb R^{2N} / \\mathcal N(A_1, C)}\\big) < 0

    with H from :func:`~glocal_verify.observers.central.design_central_observer` (Riccati gain; ``options["central_poles"]`` for
    pole placement). The fixed eigenvalues (A_1 on the unobservable subspace) are reported,
    not judged. Scope: global (the gain is designed for the normal mode).

    Numeric (certified): :func:`~glocal_verify.observers.central.certify_observable_stability`,
    a Bauer-Fike bound on the eigenvalues of the observable quotient of ``A_1 - H C`` (exact
    A_1, the designed float H) over the proven unobservable subspace; holds iff every disc lies
    in ``Re < 0``, fails iff an isolated disc lies in ``Re > 0``, undecided otherwise (and
    when the unobservable subspace is not proven), with ``error_bound`` = the radius. A small
    stability margin is robustness (``margin``), never a failure by itself. Exact: the gain is rounded to its binary rationals; the characteristic
    polynomial of ``A_1 - H C`` over Q (:func:`~glocal_verify.observers.central.observer_charpoly_exact`:
    the matrix determinant lemma on the N-sized transfer numerators, no 2N x 2N matrix)
    divided by that of A_1 on the rational unobservable subspace is tested with the exact
    Routh-Hurwitz criterion (the Routh array of
    :func:`~glocal_verify.numerics.hurwitz.routh_hurwitz`, on integer rows with their contents removed).

    Margin
        The stability margin ``-max Re`` on the observable part (floating point).
    Witness
        ``design`` (method, designed and observable states, ``||H||``), the slowest observable
        eigenvalues, the fixed eigenvalues, and per mode ``||(A_q - H C)[1; 0]||`` when
        ``[1; 0] in ker C`` (a zero in every mode: see the finding).
    """
    verdict = central_observer_verdict(system, ctx.options.get("central_poles"), ctx.tol, ctx.exact)
    return [verdict_result("central.observer", ctx, verdict)]


@finding_rule
def hurwitz_infeasible_finding(system: System, results: Sequence[ConditionResult]) -> list[Finding]:
    """eq. ``obs_cent``: "A_sigma - H C Hurwitz in all modes" is infeasible when privacy holds.

    With ``M_x`` empty, ``C [1; 0] = 0`` and ``A_q [1; 0] = [0; -alpha L_q 1] = 0``, so
    ``(A_q - H C)[1; 0] = 0`` for every H and every mode q: 0 is always an eigenvalue. The rule
    fires when ``central.observer`` was checked on such a system; its data are the per-mode norms
    ``||A_q [1; 0]||`` (exactly 0: Laplacian rows sum to zero).
    """
    if not any(r.id == "central.observer" for r in results) or system.monitored_positions:
        return []
    n = system.n
    e = np.ones(n) / math.sqrt(n)
    data = {q: float(np.linalg.norm(system.alpha * (system.laplacian_sparse(q) @ e))) for q in system.modes}
    return [
        Finding(
            "central.hurwitz-infeasible",
            "No observer gain makes A_sigma - H C Hurwitz when Lemma III.1's privacy holds",
            "The paper asks an LMI for a constant H with (A_sigma - H C) Hurwitz in all modes. With no position "
            "monitored, [1; 0] is in ker C and A_q [1; 0] = 0, so (A_q - H C)[1; 0] = 0 for every H: 0 is an "
            "eigenvalue in every mode. The toolkit designs H stable on the observable part and reports the fixed "
            "eigenvalues. Minimal example: two agents, one edge, agent 2's velocity monitored.",
            "eq. obs_cent with Lemma III.1",
            {"A_q_times_consensus_norm": data, "C_times_consensus": 0},
        )
    ]

