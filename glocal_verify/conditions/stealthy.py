"""Stealthy attacks of Proposition II.4 (``propo:stealthy_attacks``): ZDA and covert attacks.

The checkers wrap the rules of :mod:`glocal_verify.analysis.stealthy` and assemble the
witnesses (the zero list, the attack direction):

``stealthy.zda`` (Definition II.2, eq. ``zda_cond``)
    The rule is :func:`~glocal_verify.analysis.stealthy.zda_verdict.decide_zda`: a zeroing
    direction ([x~_0; u_0], u_0 != 0) of the Rosenbrock pencil of (A_1, B_F, C, 0) at some
    lambda_0, found on the N-sized pencil in s = lambda^2 + gamma lambda (the reduction and
    the numeric, dense and exact paths are described in :mod:`glocal_verify.analysis.stealthy.zda`)
    and certified for the exact system (:mod:`glocal_verify.analysis.stealthy.zda_certificate`).

``stealthy.covert`` (eqs. ``ym_solution``-``covert_trajec_post``)
    u_s = C x~ cancels u_a iff the attacker owns every monitored channel that u_a reaches;
    the rule is :func:`~glocal_verify.analysis.stealthy.covert.covert_required_channels`.
"""

from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np

from glocal_verify.analysis.stealthy.covert import (
    channel_label as _channel_label,
    covert_required_channels,
    reachable_agents,
)
from glocal_verify.analysis.stealthy.zda import ZdaZero, requested_lambda0
from glocal_verify.analysis.stealthy.zda_exact import ExactZdaZero, exact_witness
from glocal_verify.analysis.stealthy.zda_verdict import ZdaOptions, decide_zda
from glocal_verify.conditions.registry import (
    CheckContext,
    checker,
    finding_rule,
    result,
)
from glocal_verify.model import System
from glocal_verify.numerics.tolerance import Decision, Tolerance
from glocal_verify.results import ConditionResult, Finding, Status, vector_json
from glocal_verify.spec.types import Label

__all__ = [
    "check_zda",
    "check_covert",
    "unobservable_zeros_finding",
    "covert_sensors_finding",
    "direction_json",
]



# ------------------------------------------------------------------------------------------
# checkers


def direction_json(system: System, F: Sequence[Label], xi: np.ndarray, u0: np.ndarray, tol: Tolerance) -> dict[str, Any]:
    """A ZDA direction in a checker's witness: ``xi`` by label (every entry not exactly 0),
    ``u0`` by actuator (every entry) and the agents it moves (:func:`~glocal_verify.results.vector_json`);
    ``stealthy.zda`` and ``switching.avoids-attack`` both write it."""
    return {"xi": vector_json(system.labels, xi), "u0": vector_json(F, u0, zeros=True), "moved": _moved(system, xi, tol)}


def _moved(system: System, xi: np.ndarray, tol: Tolerance) -> list[Label]:
    big = float(np.max(np.abs(xi), initial=0.0))
    return [lab for lab, x in zip(system.labels, xi) if big > 0 and tol.decide(abs(x), big) is Decision.NONZERO]


def _zero_json(system: System, F: Sequence[Label], z: ZdaZero | ExactZdaZero, tol: Tolerance) -> dict[str, Any]:
    d: dict[str, Any] = {
        "lambda": [z.value.real, z.value.imag],
        "growth": z.growth,
        "multiplicity": z.multiplicity,
        **direction_json(system, F, z.xi, z.u0, tol),
    }
    if isinstance(z, ZdaZero):
        d["residual"] = z.residual
    else:
        d["minimal_polynomial"] = z.factor
        if z.rational is not None:
            d["lambda_exact"] = str(z.rational)
        d.update(exact_witness(system, F, z))
    return d


def _margin(left_inv: bool | None, zeros: Sequence[ZdaZero | ExactZdaZero]) -> float:
    if left_inv is False:
        return math.inf
    if zeros:
        return max(z.value.real for z in zeros)
    return -math.inf


@checker("stealthy.zda")
def check_zda(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Proposition II.4 (ii), Definition II.2: a stealthy ZDA of (A_1, B, C, 0) exists.

    .. math::

        \\exists\\,\\lambda_0 \\in \\mathbb C,\\ (\\tilde x_0, u_0),\\ u_0 \\ne 0:\\quad
        \\begin{bmatrix} \\lambda_0 I - A_1 & -B \\\\ C & 0 \\end{bmatrix}
        \\begin{bmatrix} \\tilde x_0 \\\\ u_0 \\end{bmatrix} = 0

    Scope: global (normal mode), F = ``attack.actuators``. Without an attack in the spec the
    condition is not evaluated (no result). ``holds`` = a verified stealthy ZDA exists (the
    pencil is not left-invertible, or it has a zero with an input direction; note that a
    zero at lambda0 = 0 with u0 != 0 -- a constant input that shifts positions without moving
    velocities -- is a persistent, not an unbounded, ZDA). ``fails`` = left-invertible and
    no zero has an input direction. Numeric: structured modal path (option
    ``zda_method = "dense"`` for the dense pencil); tolerance rules in
    :mod:`glocal_verify.analysis.stealthy.zda`. Exact:
    :func:`~glocal_verify.analysis.stealthy.zda_exact.zda_analysis_exact`. Option ``lambda0``
    overrides the spec's exponent.

    Certification (numeric)
        The tolerance of the deflation only *finds* candidates; a numeric ``holds``/``fails``
        is reported only when :func:`~glocal_verify.analysis.stealthy.zda_certificate.zda_certificate` proves it
        for the exact system: ``holds`` by the structural rank of the exact support (not
        left-invertible), by Weyl lower bounds (SVD backward error 8 max(m, n) eps ||M||_F
        plus the rounding of the rational data) against structural upper bounds at lambda0 =
        0, or by the requested-lambda0 direction rationalised to an exact kernel vector;
        ``fails`` by zero forcing on the exact graph (and lambda0 = 0 by zero forcing from
        M_x or the same rank bounds). Otherwise ``undecided`` with ``error_bound`` and
        ``note`` (which bound failed); ``verify(escalate="auto")`` then decides exactly.
        A small residual is never by itself a proof of a zero. The witness records the
        ``certificate``; vectors are given at full double precision (only exact zeros
        left out), and in exact mode ``xi_exact``/``u0_exact`` (rationals) or
        ``field``/``xi_residues``/``u0_residues``/``lambda0_enclosure`` (algebraic lambda0;
        :func:`~glocal_verify.analysis.stealthy.zda_exact.exact_witness`).

    Margin
        The largest growth rate Re lambda0 of an available stealthy ZDA: +inf when the system
        is not left-invertible (every lambda0 is available), -inf when none exists (a
        growth rate, not a distance to the boundary: never ``fragile``).
    Witness
        ``left_invertible``, ``normal_rank`` (of the 2N pencil), ``normal_kernel_dim``,
        ``zeros`` (lambda, growth, u0, xi on its support, moved agents, residual), at most
        ``max_zeros`` (option, default 50) of them, ``zeros_total``, ``unobservable_modes``
        (zeros with u0 = 0, not attacks) and ``direction`` (lambda0, u0, xi, moved, source).
        When the computed zero set chose lambda0 = 0 as its fastest-growing zero, ``zero_set``
        says whether that choice is proven (``complete`` and ``by``: the modular count of the
        zeros of the pencil in s, :func:`~glocal_verify.analysis.stealthy.zda_completeness.zero_set_completeness`)
        or why not (``note``); ``switching.avoids-attack`` is decided at a computed lambda0 = 0
        only when it is.
    """
    if system.spec.attack is None:
        return []
    F = system.attacked
    max_z = int(ctx.options.get("max_zeros", 50))
    tol = ctx.tol
    opt = ZdaOptions(
        lambda0=requested_lambda0(system, ctx.options.get("lambda0")),
        tol=tol,
        exact=ctx.exact,
        method=str(ctx.options.get("zda_method", "structured")),
    )
    v = decide_zda(system, F, opt)
    if v.exact_analysis is not None:
        ea = v.exact_analysis
        left_inv, nrank, k0 = ea.left_invertible, ea.normal_rank, ea.normal_kernel_dim
        zeros: Sequence[ZdaZero | ExactZdaZero] = ea.zeros
        unobs: Sequence[ZdaZero | ExactZdaZero] = ea.unobservable
        notes = ea.notes
    else:
        za = v.numeric_analysis
        assert za is not None
        left_inv, nrank, k0 = za.left_invertible, za.normal_rank, za.normal_kernel_dim
        zeros, unobs, notes = za.zeros, za.unobservable, za.notes
        if v.screened and v.left_invertible is False and za.left_invertible:
            # the separator screen proved what the deflation's rank decisions missed (decide_zda)
            left_inv, nrank, k0 = False, None, None
            notes = (*notes, f"{v.proof}; the deflation's full normal rank is a floating-point decision, wrong here")
        elif v.left_invertible is None and za.left_invertible is not None:
            # the rule did not take the deflation's left-invertibility (decide_zda): not shown as a fact
            left_inv, nrank, k0 = None, None, None
            notes = (*notes, v.note or "left-invertibility is not proven: the numeric rank decision is not certified")
    direction, source = v.direction, v.direction_source
    N, m = system.n, len(F)
    p = len(system.output_channels())
    witness: dict[str, Any] = {
        "actuators": list(F),
        "left_invertible": left_inv,
        "normal_rank": nrank,
        "pencil_shape": [2 * N + p, 2 * N + m],
        "normal_kernel_dim": k0,
        "zeros": [_zero_json(system, F, z, tol) for z in zeros[:max_z]],
        "zeros_total": len(zeros),
        "unobservable_modes": [[z.value.real, z.value.imag] for z in unobs[:max_z]],
        "method": "exact (N-sized pencil in s over Q)" if ctx.exact else f"{v.numeric_analysis.method if v.numeric_analysis else ''} (N-sized pencil in s = lambda^2 + gamma lambda)",
    }
    if v.exact_analysis is not None:
        witness["s_zero_polynomial"] = v.exact_analysis.s_zero_polynomial
    if direction is not None:
        dj = _zero_json(system, F, direction, tol)
        dj["source"] = source
        dj["lambda0"] = dj.pop("lambda")
        witness["direction"] = dj
    if notes:
        witness["notes"] = list(notes)
    margin = _margin(left_inv, zeros)
    if v.status is Status.HOLDS and not v.complete and direction is not None:
        margin = max(margin, complex(direction.value).real)  # a proven ZDA the computed zero set missed
    if ctx.exact:
        return [result("stealthy.zda", ctx, v.status, margin=margin, witness=witness)]
    cert = v.certificate
    assert cert is not None
    witness["certificate"] = {"status": None if cert.status is None else cert.status.value, "by": cert.by, "error_bound": cert.error_bound, "note": cert.note}
    if v.completeness is not None:
        witness["zero_set"] = {"complete": v.completeness.complete, "by" if v.completeness.complete else "note": v.completeness.text}
    return [result("stealthy.zda", ctx, v.status, margin=margin, witness=witness, error_bound=v.error_bound, note=v.note if v.status is Status.UNDECIDED else "")]


@checker("stealthy.covert")
def check_covert(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Proposition II.4 (i): a covert attack is feasible (eqs. ``ym_solution``-``covert_trajec_post``).

    .. math::

        \\{c \\in \\text{rows}(C) : c A_1^k B \\ne 0 \\text{ for some } k\\} \\subseteq
        \\text{channels of } F_s

    u_s = C x~ cancels u_a exactly when the attacker owns every monitored channel that u_a
    reaches (:func:`~glocal_verify.analysis.stealthy.covert.covert_required_channels`; combinatorial for positive weights, so no
    tolerance and the same verdict in numeric and exact mode). F_s = ``attack.sensors``
    (every monitored channel of a listed agent). Scope: global (normal mode). No attack in
    the spec: no result.

    Margin
        The number of reached channels the attacker does not own (0 when feasible).
    Witness
        ``required`` (reached channels), ``compromised`` (owned channels), ``missing``,
        ``reachable_agents``.
    """
    attack = system.spec.attack
    if attack is None:
        return []
    req = covert_required_channels(system)
    sensors = set(attack.sensors)
    owned = [ch for ch in system.output_channels() if _channel_label(system, ch) in sensors]
    missing = [ch for ch in req if ch not in owned]
    status = Status.FAILS if missing else Status.HOLDS
    witness: dict[str, Any] = {
        "actuators": list(system.attacked),
        "required": req,
        "compromised": owned,
        "missing": missing,
        "reachable_agents": reachable_agents(system),
    }
    return [result("stealthy.covert", ctx, status, margin=float(len(missing)), witness=witness, numeric_decision=False)]



# ------------------------------------------------------------------------------------------
# findings


@finding_rule
def unobservable_zeros_finding(system: System, results: Sequence[ConditionResult]) -> list[Finding]:
    """Definition II.2 counts zeroing directions with u0 = 0 (unobservable modes) as ZDAs."""
    out = []
    for r in results:
        if r.id != "stealthy.zda" or not r.witness.get("unobservable_modes"):
            continue
        modes = r.witness["unobservable_modes"]
        out.append(
            Finding(
                "definition-ii2.unobservable-zeros",
                "Definition II.2 admits u0 = 0: unobservable modes satisfy eq. zda_cond without any attack",
                "Definition II.2 calls lambda0 a zero whenever some (x0, u0) != (0, 0) solves eq. inv_zeros, and "
                "Proposition II.4 (ii) builds the ZDA from such a direction. A direction with u0 = 0 is an "
                "unobservable mode: u_a = u0 exp(lambda0 t) = 0 is no attack. With M_x empty (Lemma III.1's "
                "privacy) the consensus direction [1; 0] at lambda0 = 0 is always one. On this system the zeros "
                f"{modes} have only u0 = 0 directions; stealthy.zda requires u0 != 0 and does not count them.",
                "Definition II.2, Proposition II.4 (ii)",
                {"unobservable_modes": modes},
            )
        )
    return out


@finding_rule
def covert_sensors_finding(system: System, results: Sequence[ConditionResult]) -> list[Finding]:
    """Proposition II.4 (i) omits the sensor channels the cancellation needs."""
    out = []
    for r in results:
        if r.id != "stealthy.covert" or r.status is not Status.FAILS:
            continue
        missing = r.witness.get("missing", [])
        out.append(
            Finding(
                "proposition-ii4.covert-needs-sensors",
                "Proposition II.4 (i): x~(t_a) = 0 is not enough for a covert attack",
                "The proposition states that with x~(t_a) = 0 'there exists a vector u_s ... canceling out the "
                "effect of u_a on the system output', but eq. attack_model restricts supp(u_s) to the compromised "
                "channels F_s: the cancellation u_s = C x~ needs every monitored channel that u_a reaches. On this "
                f"system the attacker does not own {missing}, so no covert attack exists with these sensors. "
                "Minimal example: path 1-2, F = {1}, M_v = {2}, F_s = {}.",
                "Proposition II.4 (i), eq. attack_model",
                {"missing": missing, "required": r.witness.get("required", [])},
            )
        )
    return out
