"""Remark III.3.1 (``rmk:Safe_topology_switching``): does a safe-mode switch touch the attack?

After the switch to mode q the centralized observer's error dynamics (eq. ``obs_cent_error``)
are driven by the discrepancy (A_q - A_1) x = [0; -alpha dL_q x] with dL_q = L_q - L_1. With
x = x_bar + x~ (attack-free part plus the attack's part, Proposition II.4), dL_q x_bar tends
to dL_q (consensus) = 0, so what matters is dL_q applied to the states the attack moves:

* ZDA: x~(t) = [xi; lambda0 xi] e^{lambda0 t}; the switch *touches* the attack iff
  dL_q xi != 0. If it does not, the discrepancy vanishes and the residual is bounded and
  vanishing; if it does, the residual follows e^{lambda0 t} (unbounded for Re lambda0 > 0).
* covert attack: x~ stays in the attack-reachable subspace, inside span{e_j : j connected
  to F} for positions (and velocities); the switch touches it iff a switched link has an
  endpoint connected to F. (This coordinate subspace contains the reachable subspace of
  (A_1, B), so "does not touch" is sound; "touches" may be conservative.)

The paper never defines X_q in eq. ``unsafe_set`` (X_q ∩ Z = ∅), and the two places that use
it disagree: the remark says the discrepancy is "bounded and vanishing if" eq. ``unsafe_set``
holds, while Section IV says "only case 2 meets (unsafe_set) ... the global residual for case
1 is bounded and vanishing ... while that of case 2 is unbounded" -- and case 2 is the switch
that touches the attacked agents. Reading the remark, X_q ∩ Z = ∅ means "the switch does not
touch the attack"; reading Section IV it means the opposite. The verdict of
``switching.safe`` follows the remark: **holds := the switch does not touch the attack**;
both readings are spelled out in every witness, and a report-level finding states the
contradiction.
"""

from __future__ import annotations

from typing import Any, Sequence

import flint
import numpy as np

from .linalg import Decision
from .model import System
from .registry import CheckContext, checker, finding_rule, result
from .results import ConditionResult, Finding, Status
from .spec import Label
from .stealthy import (
    GROWTH_DECAYING,
    GROWTH_PERSISTENT,
    GROWTH_UNBOUNDED,
    reachable_agents,
    zda_analysis,
    zda_analysis_exact,
)

__all__ = ["check_safe", "delta_norm", "remark_contradiction"]

PRED_BOUNDED_VANISHING = "bounded-vanishing"
PRED_UNBOUNDED = "unbounded"
PRED_BOUNDED = "bounded"


def delta_norm(system: System, mode: str) -> float:
    """||dL_q||_2, computed blockwise over the switching components D_c (dL_q is zero elsewhere).

    Parameters
    ----------
    system : System
        The system.
    mode : str
        A safe mode.
    """
    dL = system.delta_laplacian(mode)
    best = 0.0
    for comp in system.switching_components(mode):
        idx = system.idx(comp)
        w = np.linalg.eigvalsh(dL[np.ix_(idx, idx)])
        best = max(best, float(np.max(np.abs(w), initial=0.0)))
    return best


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


def _predict(touches: bool, growth: str) -> str:
    if not touches:
        return PRED_BOUNDED_VANISHING
    if growth == GROWTH_UNBOUNDED:
        return PRED_UNBOUNDED
    if growth == GROWTH_DECAYING:
        return PRED_BOUNDED_VANISHING
    return PRED_BOUNDED


def _zda_results(system: System, ctx: CheckContext) -> list[ConditionResult]:
    lam_opt = ctx.options.get("lambda0")
    out: list[ConditionResult] = []
    if ctx.exact:
        ea = zda_analysis_exact(system, lambda0=lam_opt)
        d_ex = ea.direction
        exists, decided = ea.exists, True
    else:
        za = zda_analysis(system, ctx.tol, lambda0=lam_opt)
        d_num = za.direction
        exists, decided = za.exists, za.decided
    for mode in system.safe_modes:
        base: dict[str, Any] = {"attack_kind": "zda", "switching_links": _links_json(system, mode)}
        if not exists:
            status = Status.HOLDS if decided else Status.UNDECIDED
            remark, sec4 = _readings(False if decided else None, PRED_BOUNDED)
            base.update(
                touches_attack=False if decided else None,
                note="no stealthy ZDA for this attack (stealthy.zda fails): Z = {0}, nothing to touch",
                predicted_residual=PRED_BOUNDED_VANISHING,
                reading_remark=remark,
                reading_section_iv=sec4,
            )
            out.append(result("switching.safe", ctx, status, scope={"mode": mode}, margin=0.0, witness=base))
            continue
        if ctx.exact:
            assert d_ex is not None
            L = system.delta_laplacian_exact(mode)
            g = d_ex.field
            touched = []
            for i in range(system.n):  # (dL_q xi)_i in Q[x]/(g), exactly
                acc = flint.fmpq_poly(0)
                for j, v in enumerate(d_ex.xi_field):
                    if L[i][j] != 0:
                        acc = acc + v * flint.fmpq(L[i][j].numerator, L[i][j].denominator)
                if not (acc % g).is_zero():
                    touched.append(system.labels[i])
            touches = bool(touched)
            growth = d_ex.growth
            lam = d_ex.value
            xi = d_ex.xi
            dLxi = system.delta_laplacian(mode) @ xi
            nrm = delta_norm(system, mode) * float(np.linalg.norm(xi))
            margin = float(np.linalg.norm(dLxi)) / nrm if nrm > 0 else 0.0
            status = Status.FAILS if touches else Status.HOLDS
            base["lambda0_exact"] = str(d_ex.rational) if d_ex.rational is not None else d_ex.factor
        else:
            assert d_num is not None
            xi = d_num.xi
            dLxi = system.delta_laplacian(mode) @ xi
            nrm = delta_norm(system, mode) * float(np.linalg.norm(xi))
            val = float(np.linalg.norm(dLxi))
            dec = ctx.tol.decide(val, nrm)
            margin = val / nrm if nrm > 0 else 0.0
            big = float(np.max(np.abs(dLxi), initial=0.0))
            touched = [lab for lab, v in zip(system.labels, dLxi) if big > 0 and ctx.tol.decide(abs(v), nrm) is Decision.NONZERO]
            growth = d_num.growth
            lam = d_num.value
            if dec is Decision.UNDECIDED:
                status, touches_opt = Status.UNDECIDED, None
            else:
                touches_opt = dec is Decision.NONZERO
                status = Status.FAILS if touches_opt else Status.HOLDS
            touches = bool(touches_opt)
            if touches_opt is None:
                remark, sec4 = _readings(None, "undecided")
                base.update(
                    touches_attack=None,
                    lambda0=[lam.real, lam.imag],
                    growth=growth,
                    predicted_residual="undecided",
                    reading_remark=remark,
                    reading_section_iv=sec4,
                )
                out.append(result("switching.safe", ctx, status, scope={"mode": mode}, margin=margin, witness=base))
                continue
        predicted = _predict(touches, growth)
        remark, sec4 = _readings(touches, predicted)
        base.update(
            touches_attack=touches,
            lambda0=[lam.real, lam.imag],
            growth=growth,
            moved_by_attack=_support(system, xi),
            touched_agents=touched,
            predicted_residual=predicted,
            reading_remark=remark,
            reading_section_iv=sec4,
        )
        out.append(result("switching.safe", ctx, status, scope={"mode": mode}, margin=margin, witness=base))
    return out


def _support(system: System, xi: np.ndarray) -> list[Label]:
    big = float(np.max(np.abs(xi), initial=0.0))
    return [lab for lab, v in zip(system.labels, xi) if big > 0 and abs(v) > 1e-9 * big]


def _covert_results(system: System, ctx: CheckContext) -> list[ConditionResult]:
    attack = system.spec.attack
    assert attack is not None
    R = set(reachable_agents(system))
    out: list[ConditionResult] = []
    lam = attack.lambda0
    if attack.signal == "exponential" and lam is not None:
        growth = GROWTH_UNBOUNDED if lam.real > 0 else (GROWTH_PERSISTENT if lam.real == 0 else GROWTH_DECAYING)
    else:
        growth = GROWTH_PERSISTENT  # bounded (step, sine or unspecified) input
    for mode in system.safe_modes:
        links = system.switching_links(mode)
        touching = [[u, v, float(dw)] for u, v, dw in links if u in R or v in R]
        touches = bool(touching)
        predicted = _predict(touches, growth)
        remark, sec4 = _readings(touches, predicted)
        witness: dict[str, Any] = {
            "attack_kind": "covert",
            "touches_attack": touches,
            "reachable_agents": sorted(R, key=system.index.__getitem__),
            "switching_links": _links_json(system, mode),
            "links_touching": touching,
            "predicted_residual": predicted,
            "prediction_assumes": "the covert input of the spec (attack.signal/lambda0); a bounded input when unspecified",
            "reading_remark": remark,
            "reading_section_iv": sec4,
        }
        status = Status.FAILS if touches else Status.HOLDS
        out.append(
            result("switching.safe", ctx, status, scope={"mode": mode}, margin=float(len(touching)), witness=witness, numeric_decision=False)
        )
    return out


@checker("switching.safe")
def check_safe(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Remark III.3.1, eq. ``unsafe_set``: the safe-mode switch does not touch the attack.

    .. math::

        \\text{ZDA: } \\Delta L_q\\, \\xi = 0, \\qquad
        \\text{covert: } \\Delta L_q\\, e_j = 0 \\ \\ \\forall j \\text{ connected to } F

    with xi the position part of the ZDA direction of ``stealthy.zda`` (its witness
    ``direction``). ``holds`` := the switch does not touch the attack, i.e. the remark's
    reading of eq. ``unsafe_set`` (see the module docstring for the Section IV reading, which
    is the opposite; the witness reports both). Scope: every safe mode. Needs an attack in
    the spec (no result otherwise). When no stealthy ZDA exists, Z = {0} and the verdict
    holds vacuously.

    Tolerance (ZDA, numeric): ``||dL_q xi||`` is decided against ``||dL_q||_2 ||xi||``.
    Exact: dL_q xi = 0 decided in Q[x]/(f), f the minimal polynomial of lambda0 (xi is an
    exact kernel vector). Covert: combinatorial (links of the spec), no tolerance.

    Margin
        ZDA: ``||dL_q xi|| / (||dL_q||_2 ||xi||)`` in [0, 1] (0 when the switch does not
        touch the attack); covert: the number of switched links that touch agents connected
        to F.
    Witness
        ``touches_attack``, ``lambda0`` and ``growth`` of the ZDA, ``moved_by_attack``,
        ``touched_agents`` (rows of dL_q xi that are nonzero), ``switching_links``,
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
        if r.id == "switching.safe":
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
        "it means the opposite. switching.safe follows the remark (holds = does not touch) and reports "
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
