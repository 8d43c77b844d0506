"""Remark III.3.1 (``rmk:Safe_topology_switching``): does a safe-mode switch touch the attack?

After the switch to mode q the centralized observer's error dynamics (eq. ``obs_cent_error``)
are driven by the discrepancy (A_q - A_1) x = [0; -alpha dL_q x] with dL_q = L_q - L_1. With
x = x_bar + x~ (attack-free part plus the attack's part, Proposition II.4), dL_q x_bar tends
to dL_q (consensus) = 0, so what matters is dL_q applied to the states the attack moves.

ZDA: the attacker chooses the direction
    At the exponent lambda0 of the attack, with s = lambda0^2 + gamma lambda0, the stealthy
    directions are the kernel Z of the N-sized system of ``stealthy.zda``
    (:mod:`glocal_verify.conditions.stealthy`)

    .. math::

        (sI + \\alpha L_1)\\,\\xi = S_F^\\top u_0,\\qquad S_{M_x}\\xi = 0,\\qquad
        \\lambda_0 \\ne 0 \\Rightarrow S_{M_v}\\xi = 0,

    x~(t) = [xi; lambda0 xi] e^{lambda0 t}. When Z has dimension > 1 (always when the system
    is not left-invertible) the attacker picks the direction, so the switch is *avoidable*
    iff some (xi, u0) in Z has

    .. math:: \\Delta L_q\\, \\xi = 0, \\qquad u_0 \\ne 0 .

    Then (sI + alpha L_q) xi = (sI + alpha L_1) xi = S_F^T u0, i.e. x0 = [xi; lambda0 xi] is a
    zero direction of (A_q, B, C) too: the attack survives the switch and the discrepancy it
    causes is zero (bounded and vanishing residual). If *every* stealthy direction at lambda0
    is touched, the residual follows e^{lambda0 t} (unbounded for Re lambda0 > 0, unless the
    discrepancy hides in an unobservable eigenspace of L_q -- see ``switching.detects``).
    Checking one chosen direction, as an earlier version did, is unsound both ways round: a
    touched witness does not mean the attacker cannot avoid the switch.

    The decision is the kernel of the stacked N-sized system

    .. math::

        \\begin{bmatrix} sI + \\alpha L_1 & -S_F^\\top \\\\ S_{\\mathrm{out}} & 0 \\\\
        \\Delta L_q[D, :] & 0 \\end{bmatrix}
        \\begin{bmatrix} \\xi \\\\ u_0 \\end{bmatrix} = 0

    (S_out = S_{M_x} for lambda0 = 0, S_M otherwise; only the rows D of the switching
    components, the other rows of dL_q are zero): avoidable iff its u0-part is nonzero.
    lambda0 is the spec's ``attack.lambda0`` when a stealthy ZDA exists there, else the
    exponent of ``stealthy.zda``'s witness direction (fastest-growing zero, or lambda0 = 1 when
    the system is not left-invertible and no zero is unstable) -- the same rule as
    :func:`glocal_verify.analysis.stealthy.zda.zda_analysis`. The verdict concerns that lambda0 only.

covert attack
    x~ stays in the attack-reachable subspace, inside span{e_j : j connected to F} for
    positions (and velocities); the switch touches it iff a switched link has an endpoint
    connected to F. This coordinate subspace contains the reachable subspace of (A_1, B), so
    "does not touch" (holds) is sound; "touches" (fails) is an over-approximation: the
    attacker's u_a may keep x~ in a smaller subspace that the switch does not touch.

The paper never defines X_q in eq. ``unsafe_set`` (X_q ∩ Z = ∅), and the two places that use
it disagree: the remark says the discrepancy is "bounded and vanishing if" eq. ``unsafe_set``
holds, while Section IV says "only case 2 meets (unsafe_set) ... the global residual for case
1 is bounded and vanishing ... while that of case 2 is unbounded" -- and case 2 is the switch
that touches the attacked agents. Reading the remark, X_q ∩ Z = ∅ means "the switch does not
touch the attack"; reading Section IV it means the opposite. The verdict of
``switching.avoids-attack`` follows the remark: **holds := the switch does not touch the attack**
(an avoiding stealthy direction exists); both readings are spelled out in every witness, and
a report-level finding states the contradiction.

Numeric path (modal, N-sized, cheap for large N)
    In the modal coordinates of L_1 = U diag(mu) U^T, with d_k = s + alpha mu_k, the first
    block reads d_k eta_k = (U_F^T u0)_k (xi = U eta). Modes with |d_k| > 1 are eliminated
    exactly, eta_k = (U_F^T u0)_k / d_k; the others stay unknowns with their exact rows, so
    the reduced matrix

    .. math::

        S = \\begin{bmatrix} D_J & -U_{F,J}^\\top \\\\ U_{\\mathrm{out},J} &
        U_{\\mathrm{out},f} D_f^{-1} U_{F,f}^\\top \\end{bmatrix}

    has the same kernel as the stacked system's first two blocks. Dividing each eliminated row
    by |d_k| (a row scaling: same kernel) gives a reference matrix with O(1) entries whose
    singular values are within a factor 3 of those of S; the rank of S is decided with
    :class:`~glocal_verify.numerics.tolerance.Tolerance` against max(1, ||S||_2): singular values
    <= rtol * scale span the certain kernel Z_c, those <= rtol * band * scale the possible
    kernel Z_p. Within Z (basis orthonormalised in xi, so ||xi|| = 1 for unit coefficients)
    the switch condition dL_q xi = 0 is decided on the singular values of
    dL_q[D, D] X[D] / ||dL_q||_2 (scale 1), and the input part ||u0|| against
    ||[x0; u0]|| = sqrt((1 + |lambda0|^2) + ||u0||^2) -- the rule ``stealthy.zda`` uses.
    ``holds``: the chosen direction of ``stealthy.zda`` is certainly untouched, or the certain
    avoiding subspace carries a certainly nonzero input and that direction verifies on the
    full pencil (residual as in :mod:`glocal_verify.conditions.stealthy`) with dL_q xi = 0 at the
    tolerance. ``fails``: the chosen direction is certainly touched and no direction of the
    possible avoiding subspace of Z_p carries an input that is not certainly zero. Otherwise
    ``undecided``. Cost: the symmetric eigendecomposition of L_1 (cached), one SVD of size
    (|J| + p) x (|J| + |F|) with |J| the modes with |s + alpha mu_k| <= 1, O(N^2 dim Z).

Exact path
    Rational lambda0: the kernel of the stacked system over Q (:func:`glocal_verify.numerics.exact.
    nullspace`, flint). Irrational or complex lambda0 (minimal polynomial g of degree > 1):
    the kernel over the number field Q[x]/(g) (:func:`glocal_verify.numerics.pencil_exact.kernel_over_field`,
    Gaussian elimination with entries reduced mod g -- g is irreducible, so Q[x]/(g) is a
    field and the answer holds at every root of g). The u0-rank of the kernel decides; no
    numeric shortcut and never ``undecided``.
"""

from __future__ import annotations

import dataclasses
from typing import Any, Sequence

import numpy as np

from glocal_verify.analysis.switching.avoidance import decide_avoidance
from glocal_verify.analysis.switching.touch import Avoidance
from glocal_verify.analysis.stealthy.covert import reachable_agents
from glocal_verify.analysis.stealthy.zda import (
    GROWTH_DECAYING,
    GROWTH_PERSISTENT,
    GROWTH_UNBOUNDED,
    ZdaDirection,
    requested_lambda0,
)
from glocal_verify.analysis.stealthy.zda_verdict import ZdaOptions, decide_zda
from glocal_verify.conditions.registry import (
    CheckContext,
    checker,
    finding_rule,
    result,
)
from glocal_verify.conditions.stealthy import direction_json
from glocal_verify.model import System
from glocal_verify.numerics.tolerance import Tolerance
from glocal_verify.results import ConditionResult, Finding, Status, growth_of_sign
from glocal_verify.spec.types import Label

__all__ = [
    "check_safe",
    "predicted_residual",
    "remark_contradiction",
]

PRED_BOUNDED_VANISHING = "bounded-vanishing"
PRED_UNBOUNDED = "unbounded"
PRED_BOUNDED = "bounded"

MARGIN_SCALE = (
    "holds: ||dL_q xi|| / (||dL_q||_2 ||xi||) of the avoiding direction (0 exactly, rounding level numerically); "
    "fails: the smallest ||dL_q xi|| / (||dL_q||_2 ||xi||) over the stealthy directions at lambda0, modulo the "
    "input-free ones (u0 = 0, which an attacker may add at no cost) -- in [0, 1], 0 iff avoidable"
)


# ------------------------------------------------------------------------------------------
# checker


def _readings(touches: bool | None, predicted: str) -> tuple[dict[str, Any], dict[str, Any]]:
    remark = {
        "meaning": "X_q ∩ Z = ∅ read as: the switch does not touch the states Z the attack moves (dL_q Z = 0)",
        "condition_holds": None if touches is None else (not touches),
        "predicts": PRED_BOUNDED_VANISHING if touches is False else f"no guarantee ({predicted})",
    }
    section_iv = {
        "meaning": "Section IV: 'only case 2 meets (unsafe_set)', and case 2 is the switch that touches the attacked agents",
        "condition_holds": touches,
        "predicts": (
            "unbounded residual (as case 2)" if touches else "bounded and vanishing residual (as case 1)"
        )
        if touches is not None
        else "undecided",
    }
    return remark, section_iv


def _links_json(system: System, mode: str) -> list[list[Any]]:
    return [[u, v, float(dw)] for u, v, dw in system.switching_links(mode)]


def predicted_residual(touches: bool, growth: str) -> str:
    """The global residual Remark III.3.1 predicts after a switch: ``bounded-vanishing`` when the
    switch does not touch the attack (or the attack decays), ``unbounded`` for an unbounded
    attack it touches, ``bounded`` otherwise (the one mapping; the audit's rows read it too).

    Parameters
    ----------
    touches : bool
        The switch touches the attack direction.
    growth : str
        The attack's growth class.
    """
    if not touches:
        return PRED_BOUNDED_VANISHING
    if growth == GROWTH_UNBOUNDED:
        return PRED_UNBOUNDED
    if growth == GROWTH_DECAYING:
        return PRED_BOUNDED_VANISHING
    return PRED_BOUNDED


def _direction_json(system: System, F: Sequence[Label], d: ZdaDirection, tol: Tolerance) -> dict[str, Any]:
    return {"lambda0": [d.lambda0.real, d.lambda0.imag], **direction_json(system, F, d.xi, d.u0, tol)}


def _avoidance_result(
    system: System, ctx: CheckContext, F: Sequence[Label], av: Avoidance, extra: dict[str, Any] | None = None, cert: dict[str, Any] | None = None
) -> ConditionResult:
    tol = ctx.tol
    touches = None if av.status is Status.UNDECIDED else av.status is Status.FAILS
    chosen = _direction_json(system, F, av.chosen, tol)
    chosen.update(source=av.chosen_source, touched=av.chosen_touched, touched_agents=list(av.chosen_touched_agents))
    w: dict[str, Any] = {
        "attack_kind": "zda",
        "switching_links": _links_json(system, av.mode),
        "lambda0": [av.lambda0.real, av.lambda0.imag],
        "lambda0_rule": "the spec's attack.lambda0 when a stealthy ZDA exists there, else the exponent of stealthy.zda's direction; the verdict concerns this lambda0 only",
        "growth": av.growth,
        "touches_attack": touches,
        "avoidable": None if touches is None else not touches,
        "avoiding_dimension": av.dimension,
        "chosen_direction": chosen,
        "margin_scale": MARGIN_SCALE,
    }
    if av.status is Status.HOLDS:
        assert av.direction is not None
        ad = _direction_json(system, F, av.direction, tol)
        ad.update(source=av.direction_source, dL_residual=av.dl_residual, pencil_residual=av.direction.residual)
        if av.exact_xi is not None and av.exact_u0 is not None:
            ad["xi_exact"] = {lab: str(x) for lab, x in zip(system.labels, av.exact_xi) if x != 0}
            ad["u0_exact"] = {lab: str(x) for lab, x in zip(F, av.exact_u0)}
        w["avoiding_direction"] = ad
        w["moved_by_attack"] = ad["moved"]
        w["touched_agents"] = []
        w["predicted_residual"] = PRED_BOUNDED_VANISHING
    elif av.status is Status.FAILS:
        w["moved_by_attack"] = chosen["moved"]
        w["touched_agents"] = list(av.chosen_touched_agents)
        w["predicted_residual"] = predicted_residual(True, av.growth)
    else:
        w["moved_by_attack"] = chosen["moved"]
        w["touched_agents"] = list(av.chosen_touched_agents)
        w["predicted_residual"] = "undecided"
    remark, sec4 = _readings(touches, w["predicted_residual"])
    w["reading_remark"], w["reading_section_iv"] = remark, sec4
    if av.notes:
        w["notes"] = list(av.notes)
    w.update(extra or {})
    if cert is None:
        return result("switching.avoids-attack", ctx, av.status, scope={"mode": av.mode}, margin=av.margin, witness=w)
    w["certificate"] = cert
    note = str(cert.get("note", "")) if av.status is Status.UNDECIDED else ""
    return result("switching.avoids-attack", ctx, av.status, scope={"mode": av.mode}, margin=av.margin, witness=w, error_bound=cert.get("error_bound"), note=note)


def _zda_results(system: System, ctx: CheckContext) -> list[ConditionResult]:
    zda = decide_zda(system, system.attacked, ZdaOptions(lambda0=requested_lambda0(system, ctx.options.get("lambda0")), tol=ctx.tol, exact=ctx.exact))
    F = zda.actuators
    out: list[ConditionResult] = []
    memo: dict[Any, Any] = {}
    for mode in system.safe_modes:
        v = decide_avoidance(system, mode, zda, tol=ctx.tol, memo=memo)
        if v.avoidance is None:
            decided = v.status is not Status.UNDECIDED
            remark, sec4 = _readings(False if decided else None, PRED_BOUNDED)
            base: dict[str, Any] = {
                "attack_kind": "zda",
                "switching_links": _links_json(system, mode),
                "touches_attack": False if decided else None,
                "avoidable": True if decided else None,
                "note": "no stealthy ZDA for this attack (stealthy.zda fails): Z = {0}, nothing to touch",
                "predicted_residual": PRED_BOUNDED_VANISHING,
                "reading_remark": remark,
                "reading_section_iv": sec4,
            }
            note = "" if decided else f"the absence of a stealthy ZDA is not certified: {zda.note}"
            out.append(result("switching.avoids-attack", ctx, v.status, scope={"mode": mode}, margin=0.0, witness=base, note=note, premise=v.premise))
            continue
        if ctx.exact:
            assert zda.exact_analysis is not None and zda.exact_analysis.direction is not None
            d_ex = zda.exact_analysis.direction
            lam_ex = str(d_ex.rational) if d_ex.rational is not None else d_ex.factor
            out.append(_avoidance_result(system, ctx, F, v.avoidance, {"lambda0_exact": lam_ex}))
            continue
        out.append(_avoidance_result(system, ctx, F, v.avoidance, cert=dict(v.certificate)))
    return out


def _covert_results(system: System, ctx: CheckContext) -> list[ConditionResult]:
    attack = system.spec.attack
    assert attack is not None
    R = set(reachable_agents(system))
    out: list[ConditionResult] = []
    lam = attack.lambda0
    if attack.signal == "exponential" and lam is not None:
        growth = growth_of_sign((lam.real > 0) - (lam.real < 0))
    else:
        growth = GROWTH_PERSISTENT  # bounded (step, sine or unspecified) input
    for mode in system.safe_modes:
        links = system.switching_links(mode)
        touching = [[u, v, float(dw)] for u, v, dw in links if u in R or v in R]
        touches = bool(touching)
        predicted = predicted_residual(touches, growth)
        remark, sec4 = _readings(touches, predicted)
        witness: dict[str, Any] = {
            "attack_kind": "covert",
            "touches_attack": touches,
            "reachable_agents": sorted(R, key=system.index.__getitem__),
            "switching_links": _links_json(system, mode),
            "links_touching": touching,
            "predicted_residual": predicted,
            "prediction_assumes": "the covert input of the spec (attack.signal/lambda0); a bounded input when unspecified",
            "soundness": "coordinate over-approximation of the reachable subspace: 'does not touch' is sound, 'touches' may be conservative",
            "reading_remark": remark,
            "reading_section_iv": sec4,
        }
        status = Status.FAILS if touches else Status.HOLDS
        out.append(
            result("switching.avoids-attack", ctx, status, scope={"mode": mode}, margin=float(len(touching)), witness=witness, numeric_decision=False)
        )
    return out


@checker("switching.avoids-attack")
def check_safe(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Remark III.3.1, eq. ``unsafe_set``: the safe-mode switch does not touch the attack.

    .. math::

        \\text{ZDA: } \\exists\\,(\\xi, u_0):\\ (sI + \\alpha L_1)\\xi = S_F^\\top u_0,\\
        S_{\\mathrm{out}}\\xi = 0,\\ \\Delta L_q\\, \\xi = 0,\\ u_0 \\ne 0;
        \\qquad
        \\text{covert: } \\Delta L_q\\, e_j = 0 \\ \\ \\forall j \\text{ connected to } F

    with s = lambda0^2 + gamma lambda0 at the attack's lambda0 (the spec's ``attack.lambda0``
    when a stealthy ZDA exists there, else the exponent of ``stealthy.zda``'s witness
    direction; option ``lambda0`` overrides the spec) and S_out = S_{M_x} for lambda0 = 0,
    S_M otherwise. ``holds`` := the switch does not touch the attack, i.e. some stealthy
    direction at lambda0 avoids it (the attacker chooses the direction, so one touched
    direction is not enough) -- the remark's reading of eq. ``unsafe_set`` (see the module
    docstring for the Section IV reading, which is the opposite; the witness reports both).
    ``fails`` := every stealthy direction at lambda0 is touched. Scope: every safe mode.
    Needs an attack in the spec (no result otherwise). When no stealthy ZDA exists, Z = {0}
    and the verdict holds vacuously.

    Tolerance (ZDA, numeric): rank decisions of the reduced modal matrix against
    max(1, ||S||_2), of dL_q on the xi-orthonormal basis of Z against ||dL_q||_2, inputs
    against ||[x0; u0]|| (module docstring); an avoiding witness is verified on the full
    pencil. Exact: kernel over Q (rational lambda0) or over Q[x]/(g), g the minimal
    polynomial of lambda0; never undecided. Covert: combinatorial (links of the spec), no
    tolerance; "does not touch" is sound, "touches" an over-approximation.

    Certification (ZDA, numeric)
        A numeric verdict stands only when
        :func:`~glocal_verify.analysis.switching.avoidance.avoidance_certificate` proves it at the exact
        lambda0 (the requested rational exponent): Weyl lower bounds of the stacked
        [Q; dL_q] and of its xi-part (SVD backward error 8 max(m, n) eps ||M||_F plus the
        rounding of the rational data) against structural upper bounds of the exact
        support, or the avoiding direction rationalised to an exact kernel vector; the
        vacuous ``holds`` needs a certified absence of ZDAs
        (:func:`~glocal_verify.analysis.stealthy.zda_certificate.zda_certificate`). The exponent of a computed
        (irrational) zero cannot be certified: ``undecided`` with ``error_bound`` and
        ``note``, escalated to exact arithmetic by ``verify``. The margin below stays a
        relative distance (robustness), not part of the decision.

    Margin
        ZDA (``MARGIN_SCALE``): on ``holds`` ||dL_q xi|| / (||dL_q||_2 ||xi||) of the avoiding
        direction (0 exactly; rounding level numerically); on ``fails`` the smallest
        ||dL_q xi|| / (||dL_q||_2 ||xi||) over the stealthy directions at lambda0 modulo the
        input-free ones (for a simple zero of a left-invertible system: that of the unique
        direction), in (0, 1]; on ``undecided`` that of the chosen direction. Covert: the
        number of switched links that touch agents connected to F.
    Witness
        ``touches_attack`` (= not ``avoidable``), ``avoidable``, ``avoiding_dimension`` (rank
        of the u0-part of the avoiding subspace; 0 on ``fails``), ``lambda0``, ``growth``,
        ``chosen_direction`` (``stealthy.zda``'s direction with ``touched`` and
        ``touched_agents``), on ``holds`` ``avoiding_direction`` (lambda0, xi and u0 by
        label, moved agents, residuals; ``xi_exact``/``u0_exact`` over Q), ``moved_by_attack``
        and ``touched_agents`` of the direction the verdict is about, ``switching_links``,
        ``predicted_residual`` (``bounded-vanishing`` | ``unbounded`` | ``bounded``),
        ``reading_remark`` and ``reading_section_iv`` (what each reading of eq.
        ``unsafe_set`` says and predicts).
    """
    attack = system.spec.attack
    if attack is None or not system.safe_modes:
        return []
    if attack.kind == "covert":
        return _covert_results(system, ctx)
    return _zda_results(system, ctx)


@finding_rule
def remark_contradiction(system: System, results: Sequence[ConditionResult]) -> list[Finding]:
    """Remark III.3.1 and Section IV read eq. ``unsafe_set`` in opposite ways."""
    if system.spec.attack is None or not system.safe_modes:
        return []
    per_mode: dict[str, Any] = {}
    for r in results:
        if r.id == "switching.avoids-attack":
            per_mode[str(r.scope.get("mode"))] = {
                "touches_attack": r.witness.get("touches_attack"),
                "predicted_residual": r.witness.get("predicted_residual"),
            }
    detail = (
        "Remark III.3.1 says the discrepancy (A_q - A_1) x is 'bounded and vanishing if' X_q ∩ Z = ∅ "
        "(eq. unsafe_set), but never defines X_q. Section IV says 'only case 2 meets (unsafe_set)' and "
        "that case 2 (the switch touching the attacked agents 3, 4) gives the unbounded residual while "
        "case 1 (not touching) gives the bounded, vanishing one. Under the remark's reading eq. unsafe_set "
        "means 'the switch does not touch the attack' and predicts a bounded residual; under Section IV's "
        "it means the opposite. switching.avoids-attack follows the remark (holds = does not touch) and reports "
        "both readings; the algebra (dL_q x~ = 0 makes the discrepancy vanish) supports the remark's "
        "prediction and Section IV's simulation outcome, but not Section IV's wording."
    )
    if per_mode:
        detail += " On this system: " + "; ".join(
            f"{m}: touches={v['touches_attack']}, predicted residual {v['predicted_residual']}" for m, v in per_mode.items()
        ) + "."
    return [
        Finding(
            "remark-iii31.unsafe-set",
            "Remark III.3.1 and Section IV contradict each other about eq. unsafe_set",
            detail,
            "Remark III.3.1, eq. unsafe_set; Section IV",
            {"modes": per_mode},
        )
    ]
