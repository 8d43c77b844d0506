"""Lemma III.1 (``lemma:Inv_unobs_subspace``) and Problem 1 (i): the rules of the ``privacy.*`` conditions.

Each function decides one condition in one scope (a mode, or the spec's schedule) and returns
a :class:`~glocal_verify.results.Verdict`; the checkers of
:mod:`glocal_verify.conditions.privacy` wrap them. The subspaces come from
:mod:`glocal_verify.analysis.unobservable.subspace` (per mode) and
:mod:`glocal_verify.analysis.unobservable.switched` (the schedule); the certified bounds and witnesses
are those of :mod:`glocal_verify.analysis.unobservable.observability`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Sequence

import flint
import numpy as np

from glocal_verify.analysis.unobservable.observability import (
    CERTIFIED_FALLBACK_NOTE,
    FALLBACK_NOTE,
    bounds_status,
    dims_status,
    schedule_subspace,
    schedule_witness,
    state_map,
    structural_witness,
)
from glocal_verify.analysis.unobservable.switched import (
    certified_switched,
    switched_unobservable_bounds_exact,
)
from glocal_verify.analysis.unobservable.subspace import (
    certified_unobservable,
    exact_N,
    unobservable_subspace,
    unobservable_subspace_exact,
)
from glocal_verify.model import System
from glocal_verify.numerics.exact_subspace import qmat
from glocal_verify.numerics.subspace import Subspace, decide_with_error
from glocal_verify.numerics.tolerance import DEFAULT_TOLERANCE, Decision, Tolerance
from glocal_verify.results import Status, Verdict

__all__ = [
    "ConsensusDecision",
    "certified_consensus",
    "connected_verdict",
    "consensus_direction",
    "consensus_unobservable_verdict",
    "consensus_value_verdict",
    "initial_state_verdict",
    "kernel_verdict",
    "schedule_consensus_unobservable_verdict",
    "schedule_consensus_value_verdict",
    "schedule_initial_state_verdict",
]


def consensus_direction(system: System) -> np.ndarray:
    """The unit vector [1; 0] / sqrt(N) of R^{2N}.

    Parameters
    ----------
    system : System
    """
    v = np.zeros(2 * system.n)
    v[: system.n] = 1.0 / math.sqrt(system.n)
    return v


def _exact_in_span(K: flint.fmpq_mat, v: Sequence[Fraction]) -> bool:
    """Is the rational vector v in the column span of K?"""
    n = len(v)
    if K.ncols() == 0:
        return all(x == 0 for x in v)
    vm = qmat([[x] for x in v], 1)
    cols = K.ncols()
    rows = [[K[i, j] for j in range(cols)] + [vm[i, 0]] for i in range(n)]
    M = flint.fmpq_mat(n, cols + 1, [x for r in rows for x in r])
    return int(M.rank()) == int(K.rank())


# --------------------------------------------------------------------------------------------
# privacy.unobservable (Lemma III.1)


def consensus_unobservable_verdict(system: System, mode: str, tol: Tolerance = DEFAULT_TOLERANCE, exact: bool = False) -> Verdict:
    """Is span{[1; 0]} A_q-invariant and in ``N(A_q, C)``? (``privacy.unobservable``, scope ``{"mode": q}``).

    Numeric: by structure (no rounding involved): ``A_q [1; 0] = 0`` exactly and ``[1; 0]``
    lies in ``N(A_q, C)`` iff no position is monitored. Exact: ``L_q 1 = 0`` over Q and
    ``[1; 0]`` in the rational unobservable subspace.

    Parameters
    ----------
    system : System
    mode : str
    tol : Tolerance
    exact : bool

    Returns
    -------
    Verdict
        Margin ``dist(e, N)`` of the computed subspace; witness ``distance``, ``dim``,
        ``A_q_e_norm`` and, on failure, the ``position_monitors``.
    """
    e = consensus_direction(system)
    mx = list(system.monitored_positions)
    n = system.n
    S = unobservable_subspace(system, mode, tol)
    Ae_norm = float(np.linalg.norm(system.laplacian_sparse(mode) @ e[:n])) * system.alpha
    _, dist = S.contains_decision(e, tol)
    witness: dict[str, Any] = {"distance": dist, "dim": S.dim, "A_q_e_norm": Ae_norm}
    if exact:
        L = system.laplacian_exact(mode)
        invariant = all(sum(row, Fraction(0)) == 0 for row in L)
        ones = [Fraction(1)] * n + [Fraction(0)] * n
        inside = _exact_in_span(exact_N(system, mode), ones)
        status = Status.HOLDS if (invariant and inside) else Status.FAILS
        witness["dim"] = int(exact_N(system, mode).ncols())
    else:
        # structure: L_q 1 = 0 exactly (rational rows sum to 0) and [1; 0] in N(A_q, C) iff 1 in
        # W^x_0 = ker L_q ∩ ker S_Mx iff M_x is empty
        status = Status.FAILS if mx else Status.HOLDS
        witness["decided_by"] = "structure: A_q [1; 0] = 0 exactly; [1; 0] in ker C iff no position is monitored"
    if status is not Status.HOLDS and mx:
        witness["position_monitors"] = mx
    return Verdict(status, margin=dist, witness=witness, exact=exact)


def schedule_consensus_unobservable_verdict(
    system: System, sequence: Sequence[tuple[str, float]], tol: Tolerance = DEFAULT_TOLERANCE, exact: bool = False
) -> Verdict:
    """Is ``[1; 0]`` in the switched ``N_1^m`` over ``sequence``? (``privacy.unobservable``, scope ``{}``).

    ``A_k [1; 0] = 0`` for every mode, so ``[1; 0]`` is fixed by every ``exp(A_k t)`` and lies
    in ``N_1^m`` iff ``C [1; 0] = 0``: decided by structure (numeric) or over Q (exact).

    Parameters
    ----------
    system : System
    sequence : sequence of (mode, duration)
    tol : Tolerance
    exact : bool
    """
    e = consensus_direction(system)
    mx = list(system.monitored_positions)
    seq, Ssw = schedule_subspace(system, sequence, tol)
    _, dist = Ssw.contains_decision(e, tol)
    witness = dict(schedule_witness(seq), distance=dist, dim=Ssw.dim)
    if exact:
        fixed = all(all(sum(row, Fraction(0)) == 0 for row in system.laplacian_exact(m)) for m, _ in seq)
        status = Status.FAILS if (mx or not fixed) else Status.HOLDS
        witness["reason"] = "A_k [1; 0] = 0 for every mode, so [1; 0] is fixed by every exp(A_k t); it is unobservable iff C [1; 0] = 0"
    else:
        status = Status.FAILS if mx else Status.HOLDS
        witness["decided_by"] = "structure: [1; 0] is fixed by every exp(A_k t) and lies in ker C iff no position is monitored"
    if status is not Status.HOLDS and mx:
        witness["position_monitors"] = mx
    return Verdict(status, margin=dist, witness=witness, exact=exact)


# --------------------------------------------------------------------------------------------
# privacy.initial-state (Problem 1 (i))


def initial_state_verdict(system: System, mode: str, tol: Tolerance = DEFAULT_TOLERANCE, exact: bool = False) -> Verdict:
    """Is ``N(A_q, C) != {0}`` (x(t0) not reconstructable)? (``privacy.initial-state``, scope ``{"mode": q}``).

    The decision of :func:`~glocal_verify.analysis.unobservable.observability.observability_verdict` with
    holds and fails exchanged.

    Parameters
    ----------
    system : System
    mode : str
    tol : Tolerance
    exact : bool

    Returns
    -------
    Verdict
        Margin ``dim N`` (0 on failure); witness a nonzero vector of N, or the observability
        margin on failure.
    """
    S = unobservable_subspace(system, mode, tol)
    witness: dict[str, Any]
    if exact:
        basis = unobservable_subspace_exact(system, mode)
        witness = {"dim": len(basis), "vector": state_map(system, basis[0], digits=None)} if basis else {"dim": 0, "observability_margin": S.margin}
        return Verdict(Status.HOLDS if basis else Status.FAILS, margin=len(basis), witness=witness, exact=True)
    cu = certified_unobservable(system, mode)
    status = bounds_status(cu.dim_lower, cu.dim_upper, observable_holds=False)
    dim = cu.dim_lower
    if dim:
        witness = {"dim": dim, "vector": structural_witness(system, cu.exact_basis, 1)[0]}
    else:
        witness = {"dim": 0, "observability_margin": S.margin}
    if not cu.decided:
        witness["dim_bounds"] = [cu.dim_lower, cu.dim_upper]
    return Verdict(status, margin=dim, error_bound=cu.error_bound, witness=witness, note=cu.note if status is Status.UNDECIDED else "")


def schedule_initial_state_verdict(
    system: System, sequence: Sequence[tuple[str, float]], tol: Tolerance = DEFAULT_TOLERANCE, exact: bool = False
) -> Verdict:
    """Is ``N_1^m != {0}`` over ``sequence``? (``privacy.initial-state``, scope ``{}``).

    The decision of :func:`~glocal_verify.analysis.unobservable.observability.schedule_observability_verdict`
    with holds and fails exchanged (an exact run whose bounds disagree falls back to the
    certified numeric verdict, which is not ``exact``).

    Parameters
    ----------
    system : System
    sequence : sequence of (mode, duration)
    tol : Tolerance
    exact : bool
    """
    seq, Ssw = schedule_subspace(system, sequence, tol)
    base = schedule_witness(seq)
    if exact:
        b = switched_unobservable_bounds_exact(system, seq)
        if b.dim_upper == 0 or b.dim_lower > 0:
            status = Status.HOLDS if b.dim_lower > 0 else Status.FAILS
            witness = dict(base, dim_lower=b.dim_lower, dim_upper=b.dim_upper)
            if status is Status.HOLDS:
                witness["vector"] = state_map(system, b.inner[0], digits=None) if b.inner else None
                if not b.inner and b.at_first_switch:
                    witness["state_at_switch"] = state_map(system, b.at_first_switch[0], digits=None)
            return Verdict(status, margin=b.dim_lower, witness=witness, exact=True)
        cs = certified_switched(system, seq)
        status = bounds_status(cs.dim_lower, cs.dim_upper, observable_holds=False)
        certified = status is not Status.UNDECIDED
        witness = dict(base, dim=Ssw.dim, note=CERTIFIED_FALLBACK_NOTE if certified else FALLBACK_NOTE,
                       exact_bounds=[b.dim_lower, b.dim_upper])
        if not certified:  # neither the exact bounds nor a certified float bound decide: say so
            witness["uncertified_reading"] = dims_status(Ssw.dim, Ssw.dim_upper, observable_holds=False).value
        if Ssw.dim:
            witness["vector"] = state_map(system, Ssw.basis[:, 0])
        return Verdict(status, margin=Ssw.dim, error_bound=cs.error_bound, witness=witness, note=cs.note if not certified else "")
    cs = certified_switched(system, seq)
    status = bounds_status(cs.dim_lower, cs.dim_upper, observable_holds=False)
    witness = dict(base, dim=cs.dim_lower)
    if cs.dim_lower:
        witness["vector"] = structural_witness(system, cs.inner, 1)[0]
    if not cs.decided:
        witness["dim_bounds"] = [cs.dim_lower, cs.dim_upper]
    note = cs.note if status is Status.UNDECIDED else ""
    return Verdict(status, margin=cs.dim_lower, error_bound=cs.error_bound, witness=witness, note=note)


# --------------------------------------------------------------------------------------------
# privacy.consensus-value (Problem 1 (i))


@dataclass(frozen=True, slots=True)
class ConsensusDecision:
    """Is a unit vector f not orthogonal to a subspace? (the consensus functional's visibility).

    Attributes
    ----------
    status : Status
        holds: f is certainly not orthogonal (x* is hidden); fails: certainly orthogonal.
    cosine : float
        ``||P_N f||`` of the lower reading of the subspace.
    vector : ndarray or None
        On ``holds`` a unit vector of the subspace with ``f . v != 0``.
    note : str
        Why it is undecided.
    """

    status: Status
    cosine: float = 0.0
    vector: np.ndarray | None = None
    note: str = ""


def _projection_decision(S: Subspace, f: np.ndarray, tol: Tolerance) -> ConsensusDecision:
    """Is the unit vector f NOT orthogonal to S? (cosine of the angle between f and S)."""
    c_lo = float(np.linalg.norm(S.basis.T @ f)) if S.dim else 0.0
    c_hi = float(np.linalg.norm(S.upper.T @ f)) if S.dim_upper else 0.0
    if decide_with_error(c_lo, S.error, tol) is Decision.NONZERO:
        v = S.basis @ (S.basis.T @ f)
        return ConsensusDecision(Status.HOLDS, c_lo, v / np.linalg.norm(v))
    if decide_with_error(c_hi, S.error, tol) is Decision.ZERO:
        return ConsensusDecision(Status.FAILS, c_lo)
    return ConsensusDecision(Status.UNDECIDED, c_lo)


def consensus_value_verdict(system: System, mode: str, tol: Tolerance = DEFAULT_TOLERANCE, exact: bool = False) -> Verdict:
    """Is ``f = [1/N 1; 0]`` not orthogonal to ``N(A_q, C)`` (x* hidden)? (``privacy.consensus-value``, ``{"mode": q}``).

    Numeric, by exact structure: f is orthogonal to every ``W_mu x W_mu`` (``mu > 0``) and to
    the velocity slot, so it is not orthogonal to N iff some component of G_q has no
    position monitor. Exact: ``f . b != 0`` for a rational basis vector b of N.

    Parameters
    ----------
    system : System
    mode : str
    tol : Tolerance
    exact : bool

    Returns
    -------
    Verdict
        Margin the cosine ``||P_N f||``; witness ``cosine``, ``dim`` and on success a vector
        v of N with ``f_dot_v``.
    """
    n = system.n
    f = consensus_direction(system)
    S = unobservable_subspace(system, mode, tol)
    c = _projection_decision(S, f, tol).cosine
    witness: dict[str, Any] = {"cosine": c, "dim": S.dim}
    if exact:
        basis = unobservable_subspace_exact(system, mode)
        hit = next((b for b in basis if sum(b[:n], Fraction(0)) != 0), None)
        witness["dim"] = len(basis)
        if hit is not None:
            witness["vector"] = state_map(system, hit, digits=None)
            witness["f_dot_v"] = sum(hit[:n], Fraction(0)) / n
        return Verdict(Status.HOLDS if hit is not None else Status.FAILS, margin=c, witness=witness, exact=True)
    # structure: f is orthogonal to every summand W_mu x W_mu (mu > 0: W_mu is orthogonal to 1)
    # and to the velocity slot, so f is not orthogonal to N iff W^x_0 != 0
    cu = certified_unobservable(system, mode)
    pos = [b for b in cu.structural if any(b[:n])]
    witness["decided_by"] = "structure: x* is hidden iff some component of G_q has no position monitor"
    if pos:
        vec = np.array([float(x) for x in pos[0]])
        vec /= np.linalg.norm(vec)
        witness["vector"] = state_map(system, vec)
        witness["f_dot_v"] = float(np.sum(vec[:n])) / n
    return Verdict(Status.HOLDS if pos else Status.FAILS, margin=c, witness=witness)


def certified_consensus(system: System, seq: Sequence[tuple[str, float]]) -> ConsensusDecision:
    """Certified verdict of privacy.consensus-value on a schedule (structure + per-mode certificates).

    Holds when the exact subspace I of :func:`~glocal_verify.analysis.unobservable.switched.certified_switched`
    has a vector ``[1_c; 0]`` (a union component without position monitor:
    ``f . [1_c; 0] != 0``). Fails when ``N_1^m = I`` is proven and I has none, or when every
    component of the first mode's graph has a position monitor (then ``W^x_0 = 0`` and f is
    orthogonal to ``N(A_1, C)``, which contains ``N_1^m``). Undecided otherwise.

    Parameters
    ----------
    system : System
    seq : sequence of (mode, duration)
        A checked schedule.
    """
    n = system.n
    cs = certified_switched(system, seq)
    pos = [b for b in cs.inner if any(b[:n])]
    if pos:
        vec = np.array([float(x) for x in pos[0]])
        return ConsensusDecision(Status.HOLDS, vector=vec / np.linalg.norm(vec))
    if cs.all_structural:
        return ConsensusDecision(Status.FAILS)
    if cs.first_structural_positions == 0:
        return ConsensusDecision(Status.FAILS)
    return ConsensusDecision(Status.UNDECIDED, note=cs.note or certified_unobservable(system, seq[0][0]).note)


def schedule_consensus_value_verdict(
    system: System, sequence: Sequence[tuple[str, float]], tol: Tolerance = DEFAULT_TOLERANCE, exact: bool = False
) -> Verdict:
    """Is f not orthogonal to the switched ``N_1^m``? (``privacy.consensus-value``, scope ``{}``).

    Numeric: :func:`certified_consensus`. Exact: one mode as per mode; two modes:
    ``N_1^2 = exp(-A_1 tau_1) S`` with S rational and ``exp(-A_1^T tau_1) f = (1/N) [1; kappa 1]``,
    kappa transcendental (Lindemann), so f is orthogonal to ``N_1^2`` iff every s in S has
    zero position and velocity sums; longer schedules use the exact inner/outer bounds and
    fall back to the certified numeric verdict (not ``exact``) when they disagree.

    Parameters
    ----------
    system : System
    sequence : sequence of (mode, duration)
    tol : Tolerance
    exact : bool
    """
    n = system.n
    f = consensus_direction(system)
    seq, Ssw = schedule_subspace(system, sequence, tol)
    projected = _projection_decision(Ssw, f, tol)
    c = projected.cosine
    base: dict[str, Any] = dict(schedule_witness(seq), cosine=c, dim=Ssw.dim)
    if exact:
        b = switched_unobservable_bounds_exact(system, seq)
        ex_status: Status | None = None
        witness = dict(base)
        if len(seq) == 1:
            hit = next((x for x in b.inner if sum(x[:n], Fraction(0)) != 0), None)
            ex_status = Status.HOLDS if hit is not None else Status.FAILS
            if hit is not None:
                witness["vector"] = state_map(system, hit, digits=None)
        elif len(seq) == 2:
            hit = next((x for x in b.at_first_switch if sum(x[:n], Fraction(0)) != 0 or sum(x[n:], Fraction(0)) != 0), None)
            ex_status = Status.HOLDS if hit is not None else Status.FAILS
            witness["reason"] = "f is orthogonal to exp(-A_1 tau_1) S iff every s in S has zero position and velocity sums (kappa is transcendental)"
            if hit is not None:
                witness["state_at_switch"] = state_map(system, hit, digits=None)
        else:
            hit = next((x for x in b.inner if sum(x[:n], Fraction(0)) != 0), None)
            if hit is not None:
                ex_status = Status.HOLDS
                witness["vector"] = state_map(system, hit, digits=None)
            elif all(sum(x[:n], Fraction(0)) == 0 for x in b.outer):
                ex_status = Status.FAILS
        if ex_status is not None:
            return Verdict(ex_status, margin=c, witness=witness, exact=True)
        cstat = certified_consensus(system, seq).status
        witness["note"] = FALLBACK_NOTE if cstat is Status.UNDECIDED else CERTIFIED_FALLBACK_NOTE
        return Verdict(projected.status if cstat is Status.UNDECIDED else cstat, margin=c, witness=witness)
    decided = certified_consensus(system, seq)
    witness = dict(base)
    if decided.vector is not None:
        witness["vector"] = state_map(system, decided.vector)
        witness["f_dot_v"] = float(np.sum(decided.vector[:n])) / n
    return Verdict(decided.status, margin=c, error_bound=certified_switched(system, seq).error_bound, witness=witness, note=decided.note)


# --------------------------------------------------------------------------------------------
# privacy.connected and privacy.kernel (Lemma III.1's assumptions)


def connected_verdict(system: System, mode: str) -> Verdict:
    """Is the graph G_q connected? (``privacy.connected``; combinatorial, from the exact edge set).

    Parameters
    ----------
    system : System
    mode : str

    Returns
    -------
    Verdict
        Margin the algebraic connectivity lambda_2(L_q) (floating point; 0 when
        disconnected); witness the components when disconnected.
    """
    comps = system.components(mode)
    w = system.spectrum(mode).values
    lam2 = float(w[1]) if system.n > 1 else 0.0
    if len(comps) == 1:
        margin = max(lam2, 0.0)
        return Verdict(Status.HOLDS, margin=margin, witness={"components": 1, "algebraic_connectivity": margin}, combinatorial=True)
    return Verdict(Status.FAILS, margin=0.0, witness={"components": comps, "links_needed": len(comps) - 1}, combinatorial=True)


def kernel_verdict(system: System) -> Verdict:
    """Is ``[1; 0]`` in ker C, i.e. is no position monitored? (``privacy.kernel``; combinatorial).

    Parameters
    ----------
    system : System

    Returns
    -------
    Verdict
        Margin ``sqrt(|M_x| / N)``; witness the position monitors and ``C_times_one``.
    """
    mx = list(system.monitored_positions)
    margin = math.sqrt(len(mx) / system.n) if system.n else 0.0
    if not mx:
        return Verdict(Status.HOLDS, margin=margin, witness={"position_monitors": []}, combinatorial=True)
    return Verdict(Status.FAILS, margin=margin, witness={"position_monitors": mx, "C_times_one": {f"x:{a}": 1 for a in mx}}, combinatorial=True)
