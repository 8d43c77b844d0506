"""Lemma II.3 (``lemma:observability``): the ``switched-observability`` checker.

Holds when the switched pair (A_sigma, C) over the spec's mode sequence is observable,
``N_1^m = {0}``; the rule (per mode and on the schedule) is
:func:`~glocal_verify.analysis.unobservable.observability.observability_verdict` and
:func:`~glocal_verify.analysis.unobservable.observability.schedule_observability_verdict`. The witness is
an orthonormal basis of the unobservable subspace (at most six vectors, in node labels). A
finding rule reports when the switched subspace is not A_k-invariant
(:func:`~glocal_verify.analysis.unobservable.observability.switched_invariance`).
"""

from __future__ import annotations

from typing import Sequence

from glocal_verify.analysis.unobservable.observability import observability_verdict, schedule_observability_verdict, switched_invariance
from glocal_verify.analysis.unobservable.switched import mode_sequence, sequence_text
from glocal_verify.conditions.registry import CheckContext, checker, finding_rule, verdict_result
from glocal_verify.model import System
from glocal_verify.results import ConditionResult, Finding

__all__ = [
    "check_switched_observability",
    "switched_subspace_not_invariant",
]


@checker("switched-observability")
def check_switched_observability(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Lemma II.3 (``lemma:observability``): the switched pair is observable, ``N_1^m = {0}``.

    .. math:: \\mathcal N_1^m = \\ker \\mathcal O = \\{0\\}

    with the backward recursion of :func:`~glocal_verify.analysis.unobservable.switched.switched_unobservable_subspace`. Scopes: every mode
    alone (``{"mode": q}``: observability of ``(A_q, C)``), and the spec's schedule (scope
    ``{}``; the schedule is in the witness) when :func:`~glocal_verify.analysis.unobservable.switched.mode_sequence` gives one.

    Numeric (certified): proven bounds ``lo <= dim N <= up``. Per mode
    (:func:`~glocal_verify.analysis.unobservable.subspace.certified_unobservable`): ``lo`` = the exact
    structural part ``W^x_0 x W_0`` (component indicators of the exact graph), ``up`` adds
    ``2 |g|`` for every eigenvalue cluster g of ``mu > 0`` on which injectivity of S_M is not
    proven by ``sigma_min(S_M U_g) sqrt(1 - s^2) - s - e > 0`` (Davis-Kahan sine s, rounding
    e). Schedule (:func:`~glocal_verify.analysis.unobservable.switched.certified_switched`): ``lo`` = the
    exact subspace constant on the union components, ``up`` = min over the modes, exact when
    every mode is certified. Holds iff ``up = 0``, fails iff ``lo > 0``; otherwise undecided
    with the failed certificate in ``note`` and the largest sine in ``error_bound`` (a
    singular value that is merely small is never read as zero).
    Exact: per mode the rational kernel of the Krylov row closure; for the schedule the exact
    dwell-time-independent bounds of :func:`~glocal_verify.analysis.unobservable.switched.switched_unobservable_bounds_exact` (exact for two
    modes). If they disagree (three or more modes), the result is the certified numeric one
    when it is decided, otherwise the numeric recursion's at ``rtol`` (not certified; the
    only uncertified verdict, flagged ``method = numeric`` with a note in the witness).

    Margin
        Per mode: min over eigen-groups of ``sigma_min(S E_mu)`` (unit scale; 0 when
        unobservable). Schedule: the smallest certainly nonzero sine of the principal angles
        met in the recursion (1.0 if none), 0 when unobservable. Computed in floating point in
        both modes.
    Witness
        ``dim`` (and ``dim_upper`` if undecided) and an orthonormal (numeric) or rational
        (exact) basis of the unobservable subspace as ``{"x": {label: ...}, "v": {label: ...}}``
        maps (at most six vectors); for the schedule the schedule itself.
    """
    cid = "switched-observability"
    out = [verdict_result(cid, ctx, observability_verdict(system, mode, ctx.tol, ctx.exact), scope={"mode": mode}) for mode in system.modes]
    seq = mode_sequence(system)
    if seq is not None:
        out.append(verdict_result(cid, ctx, schedule_observability_verdict(system, seq, ctx.tol, ctx.exact)))
    return out


# --------------------------------------------------------------------------------------------
# finding: Lemma II.3 (ii) calls N_1^m "the largest A_sigma-invariant subspace contained in ker C"


@finding_rule
def switched_subspace_not_invariant(system: System, results: Sequence[ConditionResult]) -> list[Finding]:
    """Lemma II.3 (ii): the switched unobservable subspace need not be invariant under the A_k.

    The lemma describes ``N_1^m`` as "the largest A_sigma(t)-invariant subspace contained in
    ker(C)". The recursion it gives computes the set of initial states with zero output over the
    schedule, which in general is invariant under none of the A_k; the largest subspace of
    ker C invariant under every A_k (the Krylov closure of C under all modes, computed exactly)
    can be strictly smaller. The rule fires when ``switched-observability`` ran on a schedule
    and the computed ``N_1^m`` has a certainly nonzero invariance residual
    ``||(I - V V^T) A_k V|| > rtol * band * ||A_k||`` for some mode of the schedule.
    """
    if not any(r.id == "switched-observability" and not r.scope for r in results):
        return []
    seq = mode_sequence(system)
    found = None if seq is None else switched_invariance(system, seq)
    if found is None:
        return []
    residuals, common = found.residuals, found.common_invariant_dim
    return [
        Finding(
            "lemma2.switched-subspace-not-invariant",
            "The switched unobservable subspace of Lemma II.3 is not invariant under the modes' A_k",
            f"Lemma II.3 (ii) calls N_1^m 'the largest A_sigma(t)-invariant subspace contained in ker(C)'. On the schedule "
            f"{sequence_text(found.sequence)} the recursion gives dim N_1^m = {found.dim}, and this subspace is not invariant under "
            f"{', '.join(residuals)} (relative residuals {', '.join(f'{v:.2g}' for v in residuals.values())})"
            + (f"; the largest subspace of ker C invariant under every A_k has dimension {common}." if common is not None else ".")
            + " The recursion (eqs. obsv_nullspace_1-2) is right; the description is not.",
            "Lemma II.3 (ii)",
            {"schedule": [list(x) for x in found.sequence], "dim": found.dim, "common_invariant_dim": common, "residuals": residuals, "state_dim": 2 * system.n},
        )
    ]
