"""Lemma II.3 (``lemma:observability``): the ``switched-observability`` checker.

Holds when the switched pair (A_sigma, C) over the spec's mode sequence is observable,
``N_1^m = {0}``, computed by the backward recursion of
:func:`~glocal_verify.analysis.switched.switched_unobservable_subspace` (numeric, both
readings of undecided decisions) or over Q (:func:`~glocal_verify.analysis.switched.switched_unobservable_bounds_exact`).
The witness is an orthonormal basis of the unobservable subspace (at most six vectors, in
node labels). A finding rule reports when the switched subspace is not A_k-invariant.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any, Sequence

import numpy as np

from glocal_verify.analysis.modal import _apply_A
from glocal_verify.analysis.switched import (
    _check_sequence,
    certified_switched,
    mode_sequence,
    sequence_text,
    switched_unobservable_bounds_exact,
    switched_unobservable_subspace,
)
from glocal_verify.analysis.unobservable import (
    _exact_A,
    _exact_C,
    certified_unobservable,
    unobservable_subspace,
    unobservable_subspace_exact,
)
from glocal_verify.conditions.registry import (
    CheckContext,
    checker,
    finding_rule,
    result,
)
from glocal_verify.model import System
from glocal_verify.numerics.exact_subspace import _kernel, _row_closure
from glocal_verify.numerics.subspace import Subspace, decide_with_error
from glocal_verify.numerics.tolerance import DEFAULT_TOLERANCE, Decision
from glocal_verify.results import ConditionResult, Finding, Status

__all__ = [
    "switched_schedule",
    "check_switched_observability",
    "switched_subspace_not_invariant",
]

# --------------------------------------------------------------------------------------------
# witnesses


def _state_map(system: System, v: Sequence[Any] | np.ndarray, digits: int | None = 12) -> dict[str, Any]:
    n = system.n
    vals = list(v)
    if digits is None:
        return {"x": dict(zip(system.labels, vals[:n])), "v": dict(zip(system.labels, vals[n:]))}
    arr = np.asarray([float(x) for x in vals])
    big = float(np.max(np.abs(arr))) if len(arr) else 0.0
    arr = np.where(np.abs(arr) <= 1e-13 * max(big, 1.0), 0.0, arr)
    return {
        "x": {lab: round(float(x), digits) for lab, x in zip(system.labels, arr[:n])},
        "v": {lab: round(float(x), digits) for lab, x in zip(system.labels, arr[n:])},
    }


def _basis_witness(system: System, B: np.ndarray, limit: int = 6) -> list[dict[str, Any]]:
    return [_state_map(system, B[:, j]) for j in range(min(B.shape[1], limit))]


def _exact_basis_witness(system: System, B: list[list[Fraction]], limit: int = 6) -> list[dict[str, Any]]:
    return [_state_map(system, b, digits=None) for b in B[:limit]]


def _structural_witness(system: System, basis: Sequence[Sequence[Fraction]], limit: int = 6) -> list[dict[str, Any]]:
    """Exact structural vectors (0/1 indicators), normalised to unit length, as state maps."""
    out = []
    for b in list(basis)[:limit]:
        v = np.array([float(x) for x in b])
        out.append(_state_map(system, v / np.linalg.norm(v)))
    return out


def _bounds_status(lower: int, upper: int, observable_holds: bool) -> Status:
    """holds/fails/undecided for 'N = {0}' (observable_holds) or 'N != {0}' from proven dimension bounds."""
    if upper == 0:
        return Status.HOLDS if observable_holds else Status.FAILS
    if lower > 0:
        return Status.FAILS if observable_holds else Status.HOLDS
    return Status.UNDECIDED


def _numeric_ctx(ctx: CheckContext) -> CheckContext:
    return CheckContext(exact=False, tol=ctx.tol, options=ctx.options)


_FALLBACK_NOTE = (
    "exact arithmetic cannot decide this schedule: with more than two modes the switched subspace "
    "depends on transcendental exponentials exp(A_k tau_k) and the exact dwell-time-independent bounds "
    "disagree, and no certified floating-point bound decides it either: undecided (the uncertified "
    "reading of the rtol recursion is in the witness, for information only)"
)

_CERTIFIED_FALLBACK_NOTE = (
    "exact arithmetic cannot decide this schedule (more than two modes, the exact dwell-time-independent "
    "bounds disagree); the verdict is the certified numeric one (structure and certified eigenvector bounds)"
)


# --------------------------------------------------------------------------------------------
# switched-observability


def _status_from_dims(dim: int, dim_upper: int, observable_holds: bool) -> Status:
    """holds/fails for 'N = {0}' (observable_holds) or 'N != {0}'."""
    if dim_upper == 0:
        return Status.HOLDS if observable_holds else Status.FAILS
    if dim > 0:
        return Status.FAILS if observable_holds else Status.HOLDS
    return Status.UNDECIDED


def switched_schedule(system: System, ctx: CheckContext) -> tuple[list[tuple[str, float]], Subspace, dict[str, Any]] | None:
    """The spec's mode sequence (checked), its switched unobservable subspace and the witness base.

    Shared by ``switched-observability`` and ``privacy.initial-state``; None without a schedule.

    Parameters
    ----------
    system : System
    ctx : CheckContext
    """
    seq = mode_sequence(system)
    if seq is None:
        return None
    seq = _check_sequence(system, seq)
    Ssw = switched_unobservable_subspace(system, seq, ctx.tol)
    return seq, Ssw, {"sequence": [list(s) for s in seq], "schedule": sequence_text(seq)}


@checker("switched-observability")
def check_switched_observability(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Lemma II.3 (``lemma:observability``): the switched pair is observable, ``N_1^m = {0}``.

    .. math:: \\mathcal N_1^m = \\ker \\mathcal O = \\{0\\}

    with the backward recursion of :func:`switched_unobservable_subspace`. Scopes: every mode
    alone (``{"mode": q}``: observability of ``(A_q, C)``), and the spec's schedule (scope
    ``{}``; the schedule is in the witness) when :func:`mode_sequence` gives one.

    Numeric (certified): proven bounds ``lo <= dim N <= up``. Per mode
    (:func:`~glocal_verify.analysis.unobservable.certified_unobservable`): ``lo`` = the exact
    structural part ``W^x_0 x W_0`` (component indicators of the exact graph), ``up`` adds
    ``2 |g|`` for every eigenvalue cluster g of ``mu > 0`` on which injectivity of S_M is not
    proven by ``sigma_min(S_M U_g) sqrt(1 - s^2) - s - e > 0`` (Davis-Kahan sine s, rounding
    e). Schedule (:func:`~glocal_verify.analysis.switched.certified_switched`): ``lo`` = the
    exact subspace constant on the union components, ``up`` = min over the modes, exact when
    every mode is certified. Holds iff ``up = 0``, fails iff ``lo > 0``; otherwise undecided
    with the failed certificate in ``note`` and the largest sine in ``error_bound`` (a
    singular value that is merely small is never read as zero).
    Exact: per mode the rational kernel of the Krylov row closure; for the schedule the exact
    dwell-time-independent bounds of :func:`switched_unobservable_bounds_exact` (exact for two
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
    out: list[ConditionResult] = []
    cid = "switched-observability"
    for mode in system.modes:
        S = unobservable_subspace(system, mode, ctx.tol)
        if ctx.exact:
            basis = unobservable_subspace_exact(system, mode)
            status = Status.HOLDS if not basis else Status.FAILS
            witness: dict[str, Any] = {"dim": len(basis), "basis": _exact_basis_witness(system, basis)}
            margin = 0.0 if basis else S.margin
            bound, note = None, ""
        else:
            cu = certified_unobservable(system, mode)
            status = _bounds_status(cu.dim_lower, cu.dim_upper, observable_holds=True)
            if cu.dim_lower:
                witness = {"dim": cu.dim_lower, "basis": _structural_witness(system, cu.exact_basis)}
            else:
                witness = {"dim": 0, "basis": []}
            if not cu.decided:
                witness["dim_bounds"] = [cu.dim_lower, cu.dim_upper]
                witness["numeric_basis"] = _basis_witness(system, S.upper)
            margin = 0.0 if cu.dim_lower else S.margin
            bound, note = cu.error_bound, (cu.note if status is Status.UNDECIDED else "")
        out.append(result(cid, ctx, status, scope={"mode": mode}, margin=margin, witness=witness, error_bound=bound, note=note))
    schedule = switched_schedule(system, ctx)
    if schedule is None:
        return out
    seq, Ssw, base = schedule
    if ctx.exact:
        bounds = switched_unobservable_bounds_exact(system, seq)
        if bounds.dim_upper == 0 or bounds.dim_lower > 0:
            status = Status.HOLDS if bounds.dim_upper == 0 else Status.FAILS
            witness = dict(base, dim_lower=bounds.dim_lower, dim_upper=bounds.dim_upper)
            if bounds.exact_dimension:
                witness["dim"] = bounds.dim_lower
            if bounds.at_first_switch:
                witness["states_at_switch"] = _exact_basis_witness(system, bounds.at_first_switch)
                witness["note"] = "N_1^2 = exp(-A_1 tau_1) (N(A_1, C) ∩ N(A_2, C)); the basis is of the states x(t_1) at the switch"
            elif bounds.inner:
                witness["inner_basis"] = _exact_basis_witness(system, bounds.inner)
            margin = 0.0 if status is Status.FAILS else Ssw.margin
            out.append(result(cid, ctx, status, margin=margin, witness=witness))
            return out
        nctx = _numeric_ctx(ctx)
        cs = certified_switched(system, seq)
        status = _bounds_status(cs.dim_lower, cs.dim_upper, observable_holds=True)
        certified = status is not Status.UNDECIDED
        witness = dict(base, dim=Ssw.dim, basis=_basis_witness(system, Ssw.basis), exact_bounds=[bounds.dim_lower, bounds.dim_upper],
                       note=_FALLBACK_NOTE if not certified else _CERTIFIED_FALLBACK_NOTE)
        if not certified:  # neither the exact bounds nor a certified float bound decide: say so
            witness["uncertified_reading"] = _status_from_dims(Ssw.dim, Ssw.dim_upper, observable_holds=True).value
        out.append(result(cid, nctx, status, margin=0.0 if Ssw.dim else Ssw.margin, witness=witness, error_bound=cs.error_bound,
                          note=cs.note if not certified else ""))
        return out
    cs = certified_switched(system, seq)
    status = _bounds_status(cs.dim_lower, cs.dim_upper, observable_holds=True)
    witness = dict(base, dim=cs.dim_lower if cs.decided else Ssw.dim, steps=Ssw.evidence["steps"])
    witness["basis"] = _structural_witness(system, cs.inner) if cs.dim_lower else (_basis_witness(system, Ssw.basis) if not cs.decided else [])
    if not cs.decided:
        witness["dim_bounds"] = [cs.dim_lower, cs.dim_upper]
    note = cs.note if status is Status.UNDECIDED else ""
    out.append(result(cid, ctx, status, margin=0.0 if cs.dim_lower else Ssw.margin, witness=witness, error_bound=cs.error_bound, note=note))
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
    if seq is None or len(seq) < 2:
        return []
    seq = _check_sequence(system, seq)
    tol = DEFAULT_TOLERANCE
    S = switched_unobservable_subspace(system, seq, tol)
    if not S.decided or S.dim == 0:
        return []
    V = S.basis
    residuals: dict[str, float] = {}
    for m in dict.fromkeys(mm for mm, _ in seq):
        w = system.spectrum(m).values
        scale = max(system.alpha * float(np.max(np.abs(w))), system.gamma, 1.0)
        X = _apply_A(system, m, V)
        res = float(np.linalg.norm(X - V @ (V.T @ X), 2)) / scale
        if decide_with_error(res, S.error, tol) is Decision.NONZERO:
            residuals[m] = res
    if not residuals:
        return []
    n2 = 2 * system.n
    common = _kernel(_row_closure(_exact_C(system), [_exact_A(system, m) for m in dict.fromkeys(mm for mm, _ in seq)])).ncols() if system.n <= 60 else None
    return [
        Finding(
            "lemma2.switched-subspace-not-invariant",
            "The switched unobservable subspace of Lemma II.3 is not invariant under the modes' A_k",
            f"Lemma II.3 (ii) calls N_1^m 'the largest A_sigma(t)-invariant subspace contained in ker(C)'. On the schedule "
            f"{sequence_text(seq)} the recursion gives dim N_1^m = {S.dim}, and this subspace is not invariant under "
            f"{', '.join(residuals)} (relative residuals {', '.join(f'{v:.2g}' for v in residuals.values())})"
            + (f"; the largest subspace of ker C invariant under every A_k has dimension {common}." if common is not None else ".")
            + " The recursion (eqs. obsv_nullspace_1-2) is right; the description is not.",
            "Lemma II.3 (ii)",
            {"schedule": [list(x) for x in seq], "dim": S.dim, "common_invariant_dim": common, "residuals": residuals, "state_dim": n2},
        )
    ]
