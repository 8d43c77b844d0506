"""Lemma II.3 (``lemma:observability``): the rule of ``switched-observability``, and its witnesses.

The verdict "the pair (A_q, C), or the switched pair over the spec's schedule, is observable"
(``N = {0}``) is decided from proven dimension bounds ``lo <= dim N <= up``:

* numeric, per mode: :func:`~glocal_verify.analysis.unobservable.subspace.certified_unobservable`
  (``lo`` the exact structural part, ``up`` adds the eigen-groups whose injectivity is not
  proven); on the schedule :func:`~glocal_verify.analysis.unobservable.switched.certified_switched`;
* exact, per mode: the rational kernel of the Krylov row closure; on the schedule the
  dwell-time-independent bounds of
  :func:`~glocal_verify.analysis.unobservable.switched.switched_unobservable_bounds_exact` (exact for two
  modes), and the certified numeric verdict when they disagree (a verdict that is not
  ``exact``: the checker reports it as ``numeric``).

The witness helpers here (state maps in node labels) are shared by the privacy rules of
:mod:`glocal_verify.analysis.unobservable.privacy`, which read the same subspaces.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Sequence

import numpy as np

from glocal_verify.analysis.unobservable.modal import apply_A
from glocal_verify.analysis.unobservable.switched import (
    certified_switched,
    check_sequence,
    sequence_text,
    switched_unobservable_bounds_exact,
    switched_unobservable_subspace,
)
from glocal_verify.analysis.unobservable.subspace import (
    certified_unobservable,
    exact_A,
    exact_C,
    unobservable_subspace,
    unobservable_subspace_exact,
)
from glocal_verify.model import System
from glocal_verify.numerics.exact_subspace import kernel_basis, row_closure
from glocal_verify.numerics.subspace import Subspace, decide_with_error
from glocal_verify.numerics.tolerance import DEFAULT_TOLERANCE, Decision, Tolerance
from glocal_verify.results import Status, Verdict

__all__ = [
    "SwitchedInvariance",
    "switched_invariance",
    "CERTIFIED_FALLBACK_NOTE",
    "FALLBACK_NOTE",
    "basis_witness",
    "bounds_status",
    "dims_status",
    "exact_basis_witness",
    "observability_verdict",
    "schedule_observability_verdict",
    "schedule_subspace",
    "schedule_witness",
    "state_map",
    "structural_witness",
]

#: the note of an exact run whose schedule neither exact arithmetic nor a certified bound decides
FALLBACK_NOTE = (
    "exact arithmetic cannot decide this schedule: with more than two modes the switched subspace "
    "depends on transcendental exponentials exp(A_k tau_k) and the exact dwell-time-independent bounds "
    "disagree, and no certified floating-point bound decides it either: undecided (the uncertified "
    "reading of the rtol recursion is in the witness, for information only)"
)

#: the note of an exact run whose schedule is decided by the certified numeric bounds
CERTIFIED_FALLBACK_NOTE = (
    "exact arithmetic cannot decide this schedule (more than two modes, the exact dwell-time-independent "
    "bounds disagree); the verdict is the certified numeric one (structure and certified eigenvector bounds)"
)


# --------------------------------------------------------------------------------------------
# witnesses


def state_map(system: System, v: Sequence[Any] | np.ndarray, digits: int | None = 12) -> dict[str, Any]:
    """A state ``[x; v]`` of R^{2N} as ``{"x": {label: ...}, "v": {label: ...}}``.

    Parameters
    ----------
    system : System
    v : sequence
        The 2N entries (floats, or Fractions with ``digits=None``).
    digits : int or None
        Round floats to this many digits (entries below 1e-13 of the largest become 0);
        None keeps the entries as they are (exact vectors).
    """
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


def basis_witness(system: System, B: np.ndarray, limit: int = 6) -> list[dict[str, Any]]:
    """The first ``limit`` columns of a float basis ``B`` as state maps.

    Parameters
    ----------
    system : System
    B : ndarray
        2N x k.
    limit : int
    """
    return [state_map(system, B[:, j]) for j in range(min(B.shape[1], limit))]


def exact_basis_witness(system: System, B: list[list[Fraction]], limit: int = 6) -> list[dict[str, Any]]:
    """The first ``limit`` rational vectors of ``B`` as (exact) state maps.

    Parameters
    ----------
    system : System
    B : list of list of Fraction
    limit : int
    """
    return [state_map(system, b, digits=None) for b in B[:limit]]


def structural_witness(system: System, basis: Sequence[Sequence[Fraction]], limit: int = 6) -> list[dict[str, Any]]:
    """Exact structural vectors (0/1 indicators), normalised to unit length, as state maps.

    Parameters
    ----------
    system : System
    basis : sequence of rational vectors
    limit : int
    """
    out = []
    for b in list(basis)[:limit]:
        v = np.array([float(x) for x in b])
        out.append(state_map(system, v / np.linalg.norm(v)))
    return out


def schedule_witness(seq: Sequence[tuple[str, float]]) -> dict[str, Any]:
    """The schedule's entries of a witness: ``sequence`` (mode, dwell time) and its ``schedule`` text.

    Parameters
    ----------
    seq : sequence of (mode, duration)
    """
    return {"sequence": [list(s) for s in seq], "schedule": sequence_text(seq)}


def bounds_status(lower: int, upper: int, observable_holds: bool) -> Status:
    """holds/fails/undecided for 'N = {0}' (``observable_holds``) or 'N != {0}' from proven bounds.

    Parameters
    ----------
    lower, upper : int
        Proven bounds ``lower <= dim N <= upper``.
    observable_holds : bool
        The condition is ``N = {0}`` (True) or ``N != {0}`` (False).
    """
    if upper == 0:
        return Status.HOLDS if observable_holds else Status.FAILS
    if lower > 0:
        return Status.FAILS if observable_holds else Status.HOLDS
    return Status.UNDECIDED


def dims_status(dim: int, dim_upper: int, observable_holds: bool) -> Status:
    """The uncertified reading of a recursion's dimensions (``dim`` its lower, ``dim_upper`` its upper reading).

    Parameters
    ----------
    dim, dim_upper : int
    observable_holds : bool
        As in :func:`bounds_status`.
    """
    if dim_upper == 0:
        return Status.HOLDS if observable_holds else Status.FAILS
    if dim > 0:
        return Status.FAILS if observable_holds else Status.HOLDS
    return Status.UNDECIDED


# --------------------------------------------------------------------------------------------
# switched-observability


def observability_verdict(system: System, mode: str, tol: Tolerance = DEFAULT_TOLERANCE, exact: bool = False) -> Verdict:
    """Is ``(A_q, C)`` observable, ``N(A_q, C) = {0}``? (``switched-observability`` in scope ``{"mode": q}``).

    Numeric: holds iff the proven upper bound of ``dim N`` is 0, fails iff its exact
    structural lower bound is positive, undecided otherwise (the failed certificate in
    ``note``, the largest sine in ``error_bound``). Exact: the rational kernel of the Krylov
    row closure.

    Parameters
    ----------
    system : System
    mode : str
    tol : Tolerance
    exact : bool

    Returns
    -------
    Verdict
        Margin: min over eigen-groups of ``sigma_min(S E_mu)``, 0 when unobservable. Witness:
        ``dim`` and a basis (at most six state maps; ``dim_bounds`` and ``numeric_basis``
        when undecided).
    """
    S = unobservable_subspace(system, mode, tol)
    if exact:
        basis = unobservable_subspace_exact(system, mode)
        witness: dict[str, Any] = {"dim": len(basis), "basis": exact_basis_witness(system, basis)}
        return Verdict(Status.HOLDS if not basis else Status.FAILS, margin=0.0 if basis else S.margin, witness=witness, exact=True)
    cu = certified_unobservable(system, mode)
    status = bounds_status(cu.dim_lower, cu.dim_upper, observable_holds=True)
    if cu.dim_lower:
        witness = {"dim": cu.dim_lower, "basis": structural_witness(system, cu.exact_basis)}
    else:
        witness = {"dim": 0, "basis": []}
    if not cu.decided:
        witness["dim_bounds"] = [cu.dim_lower, cu.dim_upper]
        witness["numeric_basis"] = basis_witness(system, S.upper)
    margin = 0.0 if cu.dim_lower else S.margin
    return Verdict(status, margin=margin, error_bound=cu.error_bound, witness=witness, note=cu.note if status is Status.UNDECIDED else "")


def schedule_subspace(system: System, sequence: Sequence[tuple[str, float]], tol: Tolerance) -> tuple[list[tuple[str, float]], Subspace]:
    """The checked schedule and its switched unobservable subspace (the recursion at ``tol``).

    Parameters
    ----------
    system : System
    sequence : sequence of (mode, duration)
    tol : Tolerance
    """
    seq = check_sequence(system, sequence)
    return seq, switched_unobservable_subspace(system, seq, tol)


def schedule_observability_verdict(system: System, sequence: Sequence[tuple[str, float]], tol: Tolerance = DEFAULT_TOLERANCE, exact: bool = False) -> Verdict:
    """Is the switched pair observable over ``sequence``, ``N_1^m = {0}``? (scope ``{}``).

    Numeric: the bounds of :func:`~glocal_verify.analysis.unobservable.switched.certified_switched` (``lo``
    the exact subspace constant on the union components, ``up`` the minimum over the modes).
    Exact: the dwell-time-independent bounds over Q; when they disagree (three or more modes)
    the certified numeric verdict, not ``exact`` (its witness says so and, when undecided,
    gives the uncertified reading of the recursion for information).

    Parameters
    ----------
    system : System
    sequence : sequence of (mode, duration)
        The schedule (:func:`~glocal_verify.analysis.unobservable.switched.mode_sequence`).
    tol : Tolerance
    exact : bool

    Returns
    -------
    Verdict
        Margin: the smallest certainly nonzero sine of the recursion (1.0 if none), 0 when
        unobservable. Witness: the schedule, ``dim`` and a basis (at most six state maps).
    """
    seq, Ssw = schedule_subspace(system, sequence, tol)
    base = schedule_witness(seq)
    if exact:
        bounds = switched_unobservable_bounds_exact(system, seq)
        if bounds.dim_upper == 0 or bounds.dim_lower > 0:
            status = Status.HOLDS if bounds.dim_upper == 0 else Status.FAILS
            witness = dict(base, dim_lower=bounds.dim_lower, dim_upper=bounds.dim_upper)
            if bounds.exact_dimension:
                witness["dim"] = bounds.dim_lower
            if bounds.at_first_switch:
                witness["states_at_switch"] = exact_basis_witness(system, bounds.at_first_switch)
                witness["note"] = "N_1^2 = exp(-A_1 tau_1) (N(A_1, C) ∩ N(A_2, C)); the basis is of the states x(t_1) at the switch"
            elif bounds.inner:
                witness["inner_basis"] = exact_basis_witness(system, bounds.inner)
            return Verdict(status, margin=0.0 if status is Status.FAILS else Ssw.margin, witness=witness, exact=True)
        cs = certified_switched(system, seq)
        status = bounds_status(cs.dim_lower, cs.dim_upper, observable_holds=True)
        certified = status is not Status.UNDECIDED
        witness = dict(base, dim=Ssw.dim, basis=basis_witness(system, Ssw.basis), exact_bounds=[bounds.dim_lower, bounds.dim_upper],
                       note=FALLBACK_NOTE if not certified else CERTIFIED_FALLBACK_NOTE)
        if not certified:  # neither the exact bounds nor a certified float bound decide: say so
            witness["uncertified_reading"] = dims_status(Ssw.dim, Ssw.dim_upper, observable_holds=True).value
        return Verdict(status, margin=0.0 if Ssw.dim else Ssw.margin, error_bound=cs.error_bound, witness=witness,
                       note=cs.note if not certified else "")
    cs = certified_switched(system, seq)
    status = bounds_status(cs.dim_lower, cs.dim_upper, observable_holds=True)
    witness = dict(base, dim=cs.dim_lower if cs.decided else Ssw.dim, steps=Ssw.evidence["steps"])
    witness["basis"] = structural_witness(system, cs.inner) if cs.dim_lower else (basis_witness(system, Ssw.basis) if not cs.decided else [])
    if not cs.decided:
        witness["dim_bounds"] = [cs.dim_lower, cs.dim_upper]
    note = cs.note if status is Status.UNDECIDED else ""
    return Verdict(status, margin=0.0 if cs.dim_lower else Ssw.margin, error_bound=cs.error_bound, witness=witness, note=note)


# --------------------------------------------------------------------------------------------
# Lemma II.3 (ii): is N_1^m invariant under the modes?


@dataclass(frozen=True, slots=True)
class SwitchedInvariance:
    """The modes of a schedule under which its switched unobservable subspace is certainly not invariant.

    Attributes
    ----------
    sequence : list of (mode, duration)
        The checked schedule.
    dim : int
        ``dim N_1^m`` (decided).
    residuals : dict
        Per mode whose invariance residual ``||(I - V V^T) A_k V|| / scale`` is certainly
        nonzero: that residual.
    common_invariant_dim : int or None
        Dimension of the largest subspace of ker C invariant under every A_k of the schedule
        (exact; None above 60 agents).
    """

    sequence: list[tuple[str, float]]
    dim: int
    residuals: dict[str, float]
    common_invariant_dim: int | None


def switched_invariance(system: System, sequence: Sequence[tuple[str, float]], tol: Tolerance = DEFAULT_TOLERANCE) -> SwitchedInvariance | None:
    """Is the switched unobservable subspace ``N_1^m`` invariant under the schedule's ``A_k``?

    Lemma II.3 (ii) calls ``N_1^m`` "the largest A_sigma(t)-invariant subspace contained in
    ker(C)"; the recursion computes the initial states with zero output over the schedule,
    in general invariant under none of the A_k. A mode counts when the computed ``N_1^m``
    (decided, nonzero) has a certainly nonzero invariance residual
    ``||(I - V V^T) A_k V|| > rtol * band * ||A_k||`` (``decide_with_error`` with the
    subspace's error).

    Parameters
    ----------
    system : System
    sequence : sequence of (mode, duration)
    tol : Tolerance

    Returns
    -------
    SwitchedInvariance or None
        None when the schedule has one mode, ``N_1^m`` is not decided or is {0}, or it is
        invariant under every mode (no certainly nonzero residual).
    """
    if len(sequence) < 2:
        return None
    seq, S = schedule_subspace(system, sequence, tol)
    if not S.decided or S.dim == 0:
        return None
    V = S.basis
    residuals: dict[str, float] = {}
    modes = list(dict.fromkeys(m for m, _ in seq))
    for m in modes:
        w = system.spectrum(m).values
        scale = max(system.alpha * float(np.max(np.abs(w))), system.gamma, 1.0)
        X = apply_A(system, m, V)
        res = float(np.linalg.norm(X - V @ (V.T @ X), 2)) / scale
        if decide_with_error(res, S.error, tol) is Decision.NONZERO:
            residuals[m] = res
    if not residuals:
        return None
    common = kernel_basis(row_closure(exact_C(system), [exact_A(system, m) for m in modes])).ncols() if system.n <= 60 else None
    return SwitchedInvariance(seq, S.dim, residuals, common)
