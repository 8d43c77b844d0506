"""Privacy conditions: Lemma III.1 (``lemma:Inv_unobs_subspace``) and Problem 1.

Lemma III.1: span{[1; 0]} is an A_q-invariant unobservable subspace of the switched system
provided [1; 0] lies in ker C and every G_q is connected and undirected.
"""

from __future__ import annotations

import math
from fractions import Fraction
from typing import Any, Sequence

import flint
import numpy as np

from glocal_verify.analysis.switched import (
    _check_sequence,
    certified_switched,
    mode_sequence,
    sequence_text,
    switched_unobservable_bounds_exact,
    switched_unobservable_subspace,
)
from glocal_verify.analysis.unobservable import (
    _exact_N,
    certified_unobservable,
    unobservable_subspace,
    unobservable_subspace_exact,
)
from glocal_verify.conditions.observability import (
    _CERTIFIED_FALLBACK_NOTE,
    _FALLBACK_NOTE,
    _bounds_status,
    _numeric_ctx,
    _state_map,
    _status_from_dims,
    _structural_witness,
    switched_schedule,
)
from glocal_verify.conditions.registry import CheckContext, checker, result
from glocal_verify.model import System
from glocal_verify.numerics.exact_subspace import _qmat
from glocal_verify.numerics.subspace import Subspace, decide_with_error
from glocal_verify.numerics.tolerance import Decision, Tolerance
from glocal_verify.results import ConditionResult, Status

__all__ = [
    "check_privacy_unobservable",
    "check_privacy_initial_state",
    "check_privacy_consensus_value",
    "check_connected",
    "check_kernel",
]

def _consensus(system: System) -> np.ndarray:
    v = np.zeros(2 * system.n)
    v[: system.n] = 1.0 / math.sqrt(system.n)
    return v


# --------------------------------------------------------------------------------------------
# privacy (Lemma III.1, Problem 1 (i))


def _exact_in_span(K: flint.fmpq_mat, v: Sequence[Fraction]) -> bool:
    """Is the rational vector v in the column span of K?"""
    n = len(v)
    if K.ncols() == 0:
        return all(x == 0 for x in v)
    vm = _qmat([[x] for x in v], 1)
    cols = K.ncols()
    rows = [[K[i, j] for j in range(cols)] + [vm[i, 0]] for i in range(n)]
    M = flint.fmpq_mat(n, cols + 1, [x for r in rows for x in r])
    return int(M.rank()) == int(K.rank())


@checker("privacy.unobservable")
def check_privacy_unobservable(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Lemma III.1 (``lemma:Inv_unobs_subspace``): span{[1; 0]} is A_q-invariant and unobservable.

    .. math:: A_q \\begin{bmatrix} \\mathbf 1 \\\\ 0 \\end{bmatrix} = 0, \\qquad
              \\begin{bmatrix} \\mathbf 1 \\\\ 0 \\end{bmatrix} \\in \\mathcal N(A_q, C)
              \\;\\; \\forall q, \\quad \\text{and} \\in \\mathcal N_1^m

    Scopes: every mode (``{"mode": q}``) and the spec's schedule (scope ``{}``) if any.

    Numeric (certified by structure, no rounding involved): ``A_q [1; 0] = 0`` exactly
    (Laplacian rows sum to 0 in the spec's rationals) and ``1`` spans part of ``ker L_q``, so
    ``[1; 0] in N(A_q, C)`` iff ``S_{M_x} 1 = 0`` iff ``M_x`` is empty; the same for the
    schedule (``[1; 0]`` is fixed by every ``exp(A_k t)``). The computed distance is the margin.
    Exact: ``A_q e = 0`` and e in the rational unobservable subspace. For the schedule, since
    ``A_k e = 0`` for every k, e is fixed by every ``exp(A_k t)``, so e is in ``N_1^m`` iff
    ``C e = 0`` (exact, for every dwell time). Note that connectivity, which the lemma assumes,
    is not needed: ``L_q 1 = 0`` for every undirected graph.

    Margin
        ``dist(e, N)`` (unit scale): 0 inside the subspace.
    Witness
        ``distance``, ``dim`` of the subspace, ``A_q_e_norm``; on failure the position monitors
        that see e (``C e != 0``).
    """
    out: list[ConditionResult] = []
    cid = "privacy.unobservable"
    e = _consensus(system)
    mx = list(system.monitored_positions)
    n = system.n
    for mode in system.modes:
        S = unobservable_subspace(system, mode, ctx.tol)
        Ae_norm = float(np.linalg.norm(system.laplacian_sparse(mode) @ e[:n])) * system.alpha
        dec, dist = S.contains_decision(e, ctx.tol)
        witness: dict[str, Any] = {"distance": dist, "dim": S.dim, "A_q_e_norm": Ae_norm}
        if ctx.exact:
            L = system.laplacian_exact(mode)
            invariant = all(sum(row, Fraction(0)) == 0 for row in L)
            ones = [Fraction(1)] * n + [Fraction(0)] * n
            inside = _exact_in_span(_exact_N(system, mode), ones)
            status = Status.HOLDS if (invariant and inside) else Status.FAILS
            witness["dim"] = int(_exact_N(system, mode).ncols())
        else:
            # structure: L_q 1 = 0 exactly (rational rows sum to 0) and [1; 0] in N(A_q, C) iff 1 in
            # W^x_0 = ker L_q ∩ ker S_Mx iff M_x is empty
            status = Status.FAILS if mx else Status.HOLDS
            witness["decided_by"] = "structure: A_q [1; 0] = 0 exactly; [1; 0] in ker C iff no position is monitored"
        if status is not Status.HOLDS and mx:
            witness["position_monitors"] = mx
        out.append(result(cid, ctx, status, scope={"mode": mode}, margin=dist, witness=witness))
    seq = mode_sequence(system)
    if seq is None:
        return out
    seq = _check_sequence(system, seq)
    Ssw = switched_unobservable_subspace(system, seq, ctx.tol)
    dec, dist = Ssw.contains_decision(e, ctx.tol)
    witness = {"sequence": [list(s) for s in seq], "schedule": sequence_text(seq), "distance": dist, "dim": Ssw.dim}
    if ctx.exact:
        fixed = all(all(sum(row, Fraction(0)) == 0 for row in system.laplacian_exact(m)) for m, _ in seq)
        status = Status.FAILS if (mx or not fixed) else Status.HOLDS
        witness["reason"] = "A_k [1; 0] = 0 for every mode, so [1; 0] is fixed by every exp(A_k t); it is unobservable iff C [1; 0] = 0"
    else:
        status = Status.FAILS if mx else Status.HOLDS
        witness["decided_by"] = "structure: [1; 0] is fixed by every exp(A_k t) and lies in ker C iff no position is monitored"
    if status is not Status.HOLDS and mx:
        witness["position_monitors"] = mx
    out.append(result(cid, ctx, status, margin=dist, witness=witness))
    return out


@checker("privacy.initial-state")
def check_privacy_initial_state(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Problem 1 (i) (``prob:privacy``): the initial state x(t0) cannot be reconstructed.

    .. math:: \\mathcal N_1^m \\neq \\{0\\}

    (Lemma II.3: x(t0) is reconstructable iff the unobservable subspace is trivial). Scopes:
    every mode alone and the spec's schedule (scope ``{}``) if any. Numeric and exact
    decisions as in :func:`check_switched_observability`, with holds and fails exchanged.

    Margin
        The number of independent unobservable directions (``dim N``; 0 on failure). The
        condition is a rank condition; its numerical robustness is the margin of
        ``switched-observability``.
    Witness
        A nonzero vector of N (orthonormal numeric or rational exact) that produces the same
        output as the zero state; on failure the observability margin.
    """
    out: list[ConditionResult] = []
    cid = "privacy.initial-state"
    for mode in system.modes:
        S = unobservable_subspace(system, mode, ctx.tol)
        witness: dict[str, Any]
        if ctx.exact:
            basis = unobservable_subspace_exact(system, mode)
            status = Status.HOLDS if basis else Status.FAILS
            dim = len(basis)
            witness = {"dim": dim, "vector": _state_map(system, basis[0], digits=None)} if basis else {"dim": 0, "observability_margin": S.margin}
            bound, note = None, ""
        else:
            cu = certified_unobservable(system, mode)
            status = _bounds_status(cu.dim_lower, cu.dim_upper, observable_holds=False)
            dim = cu.dim_lower
            if dim:
                witness = {"dim": dim, "vector": _structural_witness(system, cu.exact_basis, 1)[0]}
            else:
                witness = {"dim": 0, "observability_margin": S.margin}
            if not cu.decided:
                witness["dim_bounds"] = [cu.dim_lower, cu.dim_upper]
            bound, note = cu.error_bound, (cu.note if status is Status.UNDECIDED else "")
        out.append(result(cid, ctx, status, scope={"mode": mode}, margin=dim, witness=witness, error_bound=bound, note=note))
    schedule = switched_schedule(system, ctx)
    if schedule is None:
        return out
    seq, Ssw, base = schedule
    if ctx.exact:
        b = switched_unobservable_bounds_exact(system, seq)
        if b.dim_upper == 0 or b.dim_lower > 0:
            status = Status.HOLDS if b.dim_lower > 0 else Status.FAILS
            witness = dict(base, dim_lower=b.dim_lower, dim_upper=b.dim_upper)
            if status is Status.HOLDS:
                witness["vector"] = _state_map(system, b.inner[0], digits=None) if b.inner else None
                if not b.inner and b.at_first_switch:
                    witness["state_at_switch"] = _state_map(system, b.at_first_switch[0], digits=None)
            out.append(result(cid, ctx, status, margin=b.dim_lower, witness=witness))
            return out
        cs = certified_switched(system, seq)
        status = _bounds_status(cs.dim_lower, cs.dim_upper, observable_holds=False)
        certified = status is not Status.UNDECIDED
        witness = dict(base, dim=Ssw.dim, note=_CERTIFIED_FALLBACK_NOTE if certified else _FALLBACK_NOTE,
                       exact_bounds=[b.dim_lower, b.dim_upper])
        if not certified:  # neither the exact bounds nor a certified float bound decide: say so
            witness["uncertified_reading"] = _status_from_dims(Ssw.dim, Ssw.dim_upper, observable_holds=False).value
        if Ssw.dim:
            witness["vector"] = _state_map(system, Ssw.basis[:, 0])
        out.append(result(cid, _numeric_ctx(ctx), status, margin=Ssw.dim, witness=witness, error_bound=cs.error_bound,
                          note=cs.note if not certified else ""))
        return out
    cs = certified_switched(system, seq)
    status = _bounds_status(cs.dim_lower, cs.dim_upper, observable_holds=False)
    witness = dict(base, dim=cs.dim_lower)
    if cs.dim_lower:
        witness["vector"] = _structural_witness(system, cs.inner, 1)[0]
    if not cs.decided:
        witness["dim_bounds"] = [cs.dim_lower, cs.dim_upper]
    note = cs.note if status is Status.UNDECIDED else ""
    out.append(result(cid, ctx, status, margin=cs.dim_lower, witness=witness, error_bound=cs.error_bound, note=note))
    return out


def _projection_decision(S: Subspace, f: np.ndarray, tol: Tolerance) -> tuple[Status, float, np.ndarray | None]:
    """Is the unit vector f NOT orthogonal to S? (cosine of the angle between f and S)."""
    c_lo = float(np.linalg.norm(S.basis.T @ f)) if S.dim else 0.0
    c_hi = float(np.linalg.norm(S.upper.T @ f)) if S.dim_upper else 0.0
    if decide_with_error(c_lo, S.error, tol) is Decision.NONZERO:
        v = S.basis @ (S.basis.T @ f)
        return Status.HOLDS, c_lo, v / np.linalg.norm(v)
    if decide_with_error(c_hi, S.error, tol) is Decision.ZERO:
        return Status.FAILS, c_lo, None
    return Status.UNDECIDED, c_lo, None


@checker("privacy.consensus-value")
def check_privacy_consensus_value(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Problem 1 (i): the consensus value ``x* = (1/N) 1^T x(t0)`` cannot be reconstructed.

    A linear functional ``f^T x(t0)`` is reconstructable from the output iff f is orthogonal to
    the unobservable subspace (``f`` in the row space of the observability map). So with
    ``f = [1/N 1; 0]``:

    .. math:: x^* \\text{ not reconstructable} \\iff f \\not\\perp \\mathcal N_1^m,

    and then two initial states with the same output differ in x*. Scopes: every mode alone
    and the spec's schedule (scope ``{}``) if any.

    Numeric (certified): per mode exact structure: ``f`` is orthogonal to ``W_mu x W_mu`` for
    ``mu > 0`` (``W_mu`` is orthogonal to ``1``) and to the velocity slot, so ``f`` is not
    orthogonal to ``N(A_q, C)`` iff ``W^x_0 != 0`` iff some component of G_q has no position
    monitor (no rounding involved). Schedule: :func:`_certified_consensus` (structure and the
    certified per-mode bounds; undecided when they do not settle it). The cosine
    ``c = ||P_N f|| / ||f||`` of the computed subspace is only the margin.
    Exact: per mode, ``f . b != 0`` for a rational basis vector b of N. Schedule with two
    modes: ``N_1^2 = exp(-A_1 tau_1) S`` with ``S = N(A_1, C) ∩ N(A_2, C)`` rational, and
    ``exp(-A_1^T tau_1) f = (1/N) [1; kappa 1]`` with ``kappa = (1 - e^{gamma tau_1}) / gamma``, which
    is transcendental (Lindemann: ``e^r`` is transcendental for rational ``r != 0``; ``gamma`` and
    the floating-point ``tau_1`` are rational). Hence ``f`` is orthogonal to ``N_1^2`` iff
    ``sum(s_x) = sum(s_v) = 0`` for every s in S: decided exactly. Longer schedules use the exact
    inner/outer bounds and fall back to the numeric result (flagged) when they disagree.

    Margin
        The cosine ``c`` in [0, 1] (0: x* is reconstructable).
    Witness
        On success a vector v of N with ``f . v != 0`` (``f_dot_v``); exact two-mode schedule: a
        rational state ``s`` at the switch with nonzero position or velocity sum.
    """
    out: list[ConditionResult] = []
    cid = "privacy.consensus-value"
    n = system.n
    f = _consensus(system)
    for mode in system.modes:
        S = unobservable_subspace(system, mode, ctx.tol)
        status, c, v = _projection_decision(S, f, ctx.tol)
        witness: dict[str, Any] = {"cosine": c, "dim": S.dim}
        if ctx.exact:
            basis = unobservable_subspace_exact(system, mode)
            hit = next((b for b in basis if sum(b[:n], Fraction(0)) != 0), None)
            status = Status.HOLDS if hit is not None else Status.FAILS
            witness["dim"] = len(basis)
            if hit is not None:
                witness["vector"] = _state_map(system, hit, digits=None)
                witness["f_dot_v"] = sum(hit[:n], Fraction(0)) / n
        else:
            # structure: f is orthogonal to every summand W_mu x W_mu (mu > 0: W_mu is orthogonal to 1)
            # and to the velocity slot, so f is not orthogonal to N iff W^x_0 != 0
            cu = certified_unobservable(system, mode)
            pos = [b for b in cu.structural if any(b[:n])]
            status = Status.HOLDS if pos else Status.FAILS
            witness["decided_by"] = "structure: x* is hidden iff some component of G_q has no position monitor"
            if pos:
                vec = np.array([float(x) for x in pos[0]])
                vec /= np.linalg.norm(vec)
                witness["vector"] = _state_map(system, vec)
                witness["f_dot_v"] = float(np.sum(vec[:n])) / n
        out.append(result(cid, ctx, status, scope={"mode": mode}, margin=c, witness=witness))
    seq = mode_sequence(system)
    if seq is None:
        return out
    seq = _check_sequence(system, seq)
    Ssw = switched_unobservable_subspace(system, seq, ctx.tol)
    status, c, v = _projection_decision(Ssw, f, ctx.tol)
    base: dict[str, Any] = {"sequence": [list(s) for s in seq], "schedule": sequence_text(seq), "cosine": c, "dim": Ssw.dim}
    if ctx.exact:
        b = switched_unobservable_bounds_exact(system, seq)
        ex_status: Status | None = None
        witness = dict(base)
        if len(seq) == 1:
            hit = next((x for x in b.inner if sum(x[:n], Fraction(0)) != 0), None)
            ex_status = Status.HOLDS if hit is not None else Status.FAILS
            if hit is not None:
                witness["vector"] = _state_map(system, hit, digits=None)
        elif len(seq) == 2:
            hit = next((x for x in b.at_first_switch if sum(x[:n], Fraction(0)) != 0 or sum(x[n:], Fraction(0)) != 0), None)
            ex_status = Status.HOLDS if hit is not None else Status.FAILS
            witness["reason"] = "f is orthogonal to exp(-A_1 tau_1) S iff every s in S has zero position and velocity sums (kappa is transcendental)"
            if hit is not None:
                witness["state_at_switch"] = _state_map(system, hit, digits=None)
        else:
            hit = next((x for x in b.inner if sum(x[:n], Fraction(0)) != 0), None)
            if hit is not None:
                ex_status = Status.HOLDS
                witness["vector"] = _state_map(system, hit, digits=None)
            elif all(sum(x[:n], Fraction(0)) == 0 for x in b.outer):
                ex_status = Status.FAILS
        if ex_status is not None:
            out.append(result(cid, ctx, ex_status, margin=c, witness=witness))
            return out
        cstat, _, _ = _certified_consensus(system, seq)
        witness["note"] = _FALLBACK_NOTE if cstat is Status.UNDECIDED else _CERTIFIED_FALLBACK_NOTE
        out.append(result(cid, _numeric_ctx(ctx), status if cstat is Status.UNDECIDED else cstat, margin=c, witness=witness))
        return out
    status, unit, note = _certified_consensus(system, seq)
    witness = dict(base)
    if unit is not None:
        witness["vector"] = _state_map(system, unit)
        witness["f_dot_v"] = float(np.sum(unit[:n])) / n
    cs = certified_switched(system, seq)
    out.append(result(cid, ctx, status, margin=c, witness=witness, error_bound=cs.error_bound, note=note))
    return out


def _certified_consensus(system: System, seq: Sequence[tuple[str, float]]) -> tuple[Status, np.ndarray | None, str]:
    """Certified verdict of privacy.consensus-value on a schedule (structure + per-mode certificates).

    Holds when the exact subspace I of :func:`certified_switched` has a vector ``[1_c; 0]``
    (a union component without position monitor: ``f . [1_c; 0] != 0``). Fails when
    ``N_1^m = I`` is proven and I has none, or when every component of the first mode's graph
    has a position monitor (then ``W^x_0 = 0`` and f is orthogonal to ``N(A_1, C)``, which
    contains ``N_1^m``; see the per-mode argument). Undecided otherwise.
    """
    n = system.n
    cs = certified_switched(system, seq)
    pos = [b for b in cs.inner if any(b[:n])]
    if pos:
        vec = np.array([float(x) for x in pos[0]])
        return Status.HOLDS, vec / np.linalg.norm(vec), ""
    if cs.all_structural:
        return Status.FAILS, None, ""
    if cs.first_structural_positions == 0:
        return Status.FAILS, None, ""
    return Status.UNDECIDED, None, cs.note or certified_unobservable(system, seq[0][0]).note


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
        w = system.spectrum(mode).values
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
