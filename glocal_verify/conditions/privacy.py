"""Privacy conditions: Lemma III.1 (``lemma:Inv_unobs_subspace``) and Problem 1.

Lemma III.1: span{[1; 0]} is an A_q-invariant unobservable subspace of the switched system
provided [1; 0] lies in ker C and every G_q is connected and undirected. Each checker reports
the rule of :mod:`glocal_verify.analysis.unobservable.privacy` in every mode and on the spec's schedule.
"""

from __future__ import annotations

from glocal_verify.analysis.unobservable.privacy import (
    connected_verdict,
    consensus_unobservable_verdict,
    consensus_value_verdict,
    initial_state_verdict,
    kernel_verdict,
    schedule_consensus_unobservable_verdict,
    schedule_consensus_value_verdict,
    schedule_initial_state_verdict,
)
from glocal_verify.analysis.unobservable.switched import mode_sequence
from glocal_verify.conditions.registry import CheckContext, checker, verdict_result
from glocal_verify.model import System
from glocal_verify.results import ConditionResult

__all__ = [
    "check_privacy_unobservable",
    "check_privacy_initial_state",
    "check_privacy_consensus_value",
    "check_connected",
    "check_kernel",
]


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
    cid = "privacy.unobservable"
    out = [verdict_result(cid, ctx, consensus_unobservable_verdict(system, mode, ctx.tol, ctx.exact), scope={"mode": mode}) for mode in system.modes]
    seq = mode_sequence(system)
    if seq is not None:
        out.append(verdict_result(cid, ctx, schedule_consensus_unobservable_verdict(system, seq, ctx.tol, ctx.exact)))
    return out


@checker("privacy.initial-state")
def check_privacy_initial_state(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Problem 1 (i) (``prob:privacy``): the initial state x(t0) cannot be reconstructed.

    .. math:: \\mathcal N_1^m \\neq \\{0\\}

    (Lemma II.3: x(t0) is reconstructable iff the unobservable subspace is trivial). Scopes:
    every mode alone and the spec's schedule (scope ``{}``) if any. Numeric and exact
    decisions as in :func:`~glocal_verify.conditions.observability.check_switched_observability`, with holds and fails exchanged.

    Margin
        The number of independent unobservable directions (``dim N``; 0 on failure). The
        condition is a rank condition; its numerical robustness is the margin of
        ``switched-observability``.
    Witness
        A nonzero vector of N (orthonormal numeric or rational exact) that produces the same
        output as the zero state; on failure the observability margin.
    """
    cid = "privacy.initial-state"
    out = [verdict_result(cid, ctx, initial_state_verdict(system, mode, ctx.tol, ctx.exact), scope={"mode": mode}) for mode in system.modes]
    seq = mode_sequence(system)
    if seq is not None:
        out.append(verdict_result(cid, ctx, schedule_initial_state_verdict(system, seq, ctx.tol, ctx.exact)))
    return out


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
    monitor (no rounding involved). Schedule: :func:`~glocal_verify.analysis.unobservable.privacy.certified_consensus` (structure and the
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
    cid = "privacy.consensus-value"
    out = [verdict_result(cid, ctx, consensus_value_verdict(system, mode, ctx.tol, ctx.exact), scope={"mode": mode}) for mode in system.modes]
    seq = mode_sequence(system)
    if seq is not None:
        out.append(verdict_result(cid, ctx, schedule_consensus_value_verdict(system, seq, ctx.tol, ctx.exact)))
    return out


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
    return [verdict_result("privacy.connected", ctx, connected_verdict(system, mode), scope={"mode": mode}) for mode in system.modes]


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
    return [verdict_result("privacy.kernel", ctx, kernel_verdict(system))]
