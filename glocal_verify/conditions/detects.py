"""The ``switching.detects`` checker: Theorem III.3's conclusion, decided by simulation.

For each safe mode, Algorithm 1 is simulated with the schedule trigger against the attacker's
best choice of direction (one that avoids the switching links when one exists); the status
says whether the global residual of the normal-mode observer leaves its attack-free envelope
after the switch. Also :func:`rank_safe_modes` (Algorithm 1, line 4: Theorem III.3 (i)-(iii)
verdicts per safe mode) and :func:`algorithm1`, which runs
:func:`~glocal_verify.simulation.algorithm1.run_algorithm1` with that ranking.
"""

from __future__ import annotations

import math
from typing import Any, Mapping, Sequence

import numpy as np

from glocal_verify import config
from glocal_verify.conditions.catalogue import THEOREM_III3_IDS
from glocal_verify.conditions.premises import missing_input
from glocal_verify.conditions.registry import (
    CheckContext,
    checker,
    implemented_ids,
    check_conditions,
)
from glocal_verify.derived import Kind
from glocal_verify.errors import GlocalVerifyError, NotApplicableError
from glocal_verify.model import System
from glocal_verify.results import ConditionResult, Method, Status
from glocal_verify.simulation.algorithm1 import (
    Algorithm1Result,
    ModeRanking,
    run_algorithm1,
)
from glocal_verify.simulation.attacks import (
    AttackModel,
    attack_from_spec,
    zda_attack_from_direction,
)
from glocal_verify.simulation.observer_models import ObserverBank
from glocal_verify.simulation.schedule import Schedule, random_initial_state
from glocal_verify.simulation.thresholds import ThresholdRule

__all__ = [
    "THEOREM_III3_IDS",
    "rank_safe_modes",
    "check_detects",
    "algorithm1",
    "zda_touch",
    "zda_touched",
]

#: the switching.detects results per (tolerance, size limit), kept on the system
_DETECTS_KIND: Kind[list[ConditionResult]] = Kind("switching.detects", __name__, "list[ConditionResult]")




def rank_safe_modes(system: System, modes: Sequence[str] | None = None) -> tuple[ModeRanking, ...]:
    """Rank safe modes by Theorem III.3 (i)-(iii): eligible modes first, then by score.

    Uses :func:`glocal_verify.conditions.registry.check_conditions` with :data:`THEOREM_III3_IDS`. The score of a
    mode is the smallest of its margins on a relative scale: sigma_min of (i) (in [0, 1]),
    the smallest eigenvalue gap of (ii) divided by ||L_q||_2, and the margin of (iii) as its
    checker reports it.

    Parameters
    ----------
    system : System
    modes : sequence of str, optional
        Default: every safe mode.
    """
    wanted = list(system.safe_modes if modes is None else modes)
    ids = [c for c in THEOREM_III3_IDS if c in implemented_ids()]
    report = check_conditions(system, ids) if ids and wanted else None
    out = []
    for q in wanted:
        st: dict[str, Status | None] = {}
        mg: dict[str, float | None] = {}
        for cid in THEOREM_III3_IDS:
            rs = [r for r in report.results(cid) if r.scope.get("mode") == q] if report else []
            if not rs:
                st[cid], mg[cid] = None, None
                continue
            r = rs[0]
            st[cid] = r.status
            m = r.margin
            if cid == "switching.distinct-eigenvalues" and m is not None:
                w = system.spectrum(q).values
                m = float(m) / max(float(np.max(np.abs(w))), 1e-300)
            mg[cid] = m
        evaluated = [s for s in st.values() if s is not None]
        eligible = bool(evaluated) and all(s is Status.HOLDS for s in evaluated)
        vals = [float(v) for v in mg.values() if v is not None and math.isfinite(float(v))]
        score = min(vals) if vals else 0.0
        out.append(ModeRanking(q, st, mg, eligible, score))
    out.sort(key=lambda r: (not r.eligible, -r.score))
    return tuple(out)


# --------------------------------------------------------------------------------------------
# the switching.detects checker


def zda_touch(system: System, mode: str, attack: AttackModel) -> float | None:
    """||dL_q xi|| / ||xi|| (complex xi allowed): how strongly the switch touches the ZDA (Remark III.3.1), a magnitude; None without xi.

    Whether it touches it is :func:`zda_touched`, the rule's decision."""
    if attack.xi is None:
        return None
    xi = np.asarray(attack.xi)
    return float(np.linalg.norm(system.delta_laplacian_sparse(mode) @ xi) / max(float(np.linalg.norm(xi)), 1e-300))


def zda_touched(system: System, mode: str, attack: AttackModel, tol: Any = None) -> bool | None:
    """Does the switch to ``mode`` touch the simulated ZDA's direction? The touch test of
    ``switching.avoids-attack`` (:func:`~glocal_verify.analysis.switching.avoidance.direction_touch`):
    True, False, or None when undecided or without xi.

    Parameters
    ----------
    system : System
    mode : str
    attack : AttackModel
    tol : Tolerance, optional
        Default: the project's default tolerance.
    """
    from glocal_verify.analysis.switching.avoidance import direction_touch

    if attack.xi is None:
        return None
    t = direction_touch(system, mode, np.asarray(attack.xi)) if tol is None else direction_touch(system, mode, np.asarray(attack.xi), tol)
    return t.touched


@checker("switching.detects")
def check_detects(system: System, ctx: CheckContext) -> list[ConditionResult]:
    """Theorem III.3's conclusion, checked by simulation (opt-in).

    For every safe mode q: simulate the spec's attack (``stealthy.zda`` direction, or the
    covert attack) from a random attack-free initial state in the box, the centralized
    observer of eq. ``obs_cent`` (normal-mode model), and a switch to q at the spec's switching
    time; the condition **holds** when, after the switch, the global residual
    :math:`r_0 = y - C\\hat x` leaves its attack-free band (:class:`ThresholdRule`, exact
    envelope over :math:`\\|\\bar x_0\\|_\\infty \\le 1` including the switch, plus the rounding
    allowance ``rtol * max(1, ||s(t)||_2)``). Formally, with :math:`t_1` the switching time,

    .. math:: \\exists\\, t \\ge t_1,\\ k:\\ |r_{0,k}(t)| > \\theta_k(t).

    Opt-in: it runs only when the check context has ``options["simulate"]`` true (e.g.
    ``check_conditions(system, ["switching.detects"], options={"simulate": True})``; ``glocal-verify
    simulate`` reports it), the spec has an attack and a ``[switching]`` table, the system has
    at most ``options["max_agents"]`` agents (default 150) and the numeric path is requested
    (a simulation has no exact counterpart: in exact mode the checker returns nothing).

    Tolerance rule
        The attack-induced part of the residual (the attack-only run, exact by linearity)
        relative to ``max(1, ||s||_2)`` is decided with the context tolerance: zero at or below
        ``rtol``, nonzero above ``rtol * band``. A crossing by a residual whose attack part is
        not certainly nonzero is ``undecided`` (rounding could have caused it).
    Margin
        log10 of the largest post-switch ratio |r_k| / threshold_k (> 0 iff crossed).
    Witness
        switch time, detection time and channel, delay, post-switch behaviour (attack part
        invisible / vanishing / unbounded, exponential rate), ||dL_q xi|| / ||xi|| for a ZDA,
        the attack (kind, lambda0, moved agents), the threshold rule, horizon, step, seed.
    """
    if missing_input(system, "switching.detects", exact=ctx.exact, options=ctx.options) is not None:
        return []
    spec = system.spec
    limit = int(ctx.options.get("max_agents", config.get("detects_max_agents")))
    params = (ctx.tol.rtol, ctx.tol.band, limit)
    kept = _DETECTS_KIND.peek(system, params)
    if kept is not None:
        return list(kept)
    out: list[ConditionResult] = []

    def res(mode: str, status: Status, margin: float | None, witness: Mapping[str, Any]) -> ConditionResult:
        # through the registry's one constructor: the catalogue's polarity, never fragile
        # (the margin is a log-ratio, not a distance)
        from glocal_verify.conditions.registry import result

        note = (str(witness.get("note", "")) or "the simulation does not settle it (see the witness)") if status is Status.UNDECIDED else ""
        return result("switching.detects", ctx, status, scope={"mode": mode}, margin=margin, witness=witness, note=note)

    if system.n > limit:
        for q in system.safe_modes:
            out.append(res(q, Status.UNDECIDED, None, {"note": f"not simulated: {system.n} agents > max_agents = {limit}"}))
        return out
    try:
        atk = attack_from_spec(system)
        bank = ObserverBank.for_system(system, local=False)
        if "central" not in bank.names:
            raise NotApplicableError("; ".join(bank.notes) or "no centralized observer")
        base = Schedule.from_spec(system)
    except (GlocalVerifyError, ImportError) as exc:
        for q in system.safe_modes:
            out.append(res(q, Status.UNDECIDED, None, {"note": f"cannot simulate: {exc}"}))
        return out
    if not base.switch_times:
        return []
    rule = ThresholdRule(rounding=ctx.tol.rtol)
    xbar = random_initial_state(system, rule.box)
    for q in system.safe_modes:
        atk_q, chosen_by = _attacker_choice(system, q, atk, ctx)
        try:
            r = algorithm1(system, attack=atk_q, observers=bank, rule=rule, mode=q, trigger="schedule", x0=xbar)
        except GlocalVerifyError as exc:
            out.append(res(q, Status.UNDECIDED, None, {"note": f"not simulated: {exc}"}))
            continue
        ga = r.global_after
        assert ga is not None and r.post_switch is not None and r.switch_time is not None
        peak = r.post_switch.attack_peak
        dec = ctx.tol.decide(peak, 1.0)
        if not ga.detected:
            status = Status.FAILS
        elif dec.value == "nonzero":
            status = Status.HOLDS
        else:
            status = Status.UNDECIDED
        margin = math.log10(ga.peak_ratio) if ga.peak_ratio > 0 else -math.inf
        witness: dict[str, Any] = {
            "switch_time": r.switch_time,
            "detected": ga.detected,
            "detection_time": ga.time,
            "delay": (ga.time - r.switch_time) if ga.time is not None else None,
            "channel": ga.channel,
            "peak_ratio": ga.peak_ratio,
            "post_switch": r.post_switch.to_json(),
            "attack": atk_q.describe() if atk_q else None,
            "attack_direction": chosen_by,
            "threshold_rule": rule.describe(),
            "horizon": float(r.simulation.t[-1]),
            "step": float(r.simulation.t[1] - r.simulation.t[0]),
            "seed": spec.simulation.seed,
        }
        if atk_q is not None:
            d = zda_touch(system, q, atk_q)
            if d is not None:
                witness["dL_xi_relative"] = d
        if r.global_before is not None and r.global_before.detected:
            witness["note"] = "the global residual already crossed before the switch: the attack is not stealthy for this observer"
        out.append(res(q, status, margin, witness))
    _DETECTS_KIND.put(system, params, list(out))
    return out


def _attacker_choice(system: System, mode: str, atk: AttackModel | None, ctx: CheckContext) -> tuple[AttackModel | None, str]:
    """The ZDA an informed attacker would run against the switch to ``mode``.

    When some stealthy direction at lambda0 is not touched by the switch (``switching.avoids-attack``
    holds, or is undecided with an avoiding direction found, through its rule
    :func:`glocal_verify.analysis.switching.avoidance.decide_avoidance`), the attacker uses it: a
    detection verdict must hold against every stealthy direction, not only the one
    ``stealthy.zda`` happens to report.
    """
    if atk is None or atk.kind != "zda":
        return atk, "spec"
    from glocal_verify.analysis.stealthy.zda import requested_lambda0
    from glocal_verify.analysis.stealthy.zda_verdict import ZdaOptions, decide_zda
    from glocal_verify.analysis.switching.avoidance import decide_avoidance

    # the rule of switching.avoids-attack; an undecided verdict keeps the numeric analysis'
    # avoiding direction, which an informed attacker would try (the simulation is the evidence)
    zda = decide_zda(system, system.attacked, ZdaOptions(lambda0=requested_lambda0(system, ctx.options.get("lambda0")), tol=ctx.tol))
    v = decide_avoidance(system, mode, zda, tol=ctx.tol)
    av = v.avoidance
    if v.status is Status.FAILS or av is None or av.direction is None or av.direction_source == "stealthy.zda":
        return atk, "stealthy.zda"
    a = system.spec.attack
    assert a is not None
    d = av.direction
    return (
        zda_attack_from_direction(system, d.lambda0, d.xi, d.u0, amplitude=a.amplitude, start=a.start),
        "avoiding direction of switching.avoids-attack",
    )


def algorithm1(system: System, **options: Any) -> Algorithm1Result:
    """Algorithm 1 (``alg:detection_procedure``) with the safe modes ranked by Theorem III.3.

    :func:`rank_safe_modes` orders the safe modes by the verdicts of conditions (i)-(iii);
    :func:`~glocal_verify.simulation.algorithm1.run_algorithm1` then runs the observers and the
    switch.

    Parameters
    ----------
    system : System
    **options
        Every keyword of :func:`~glocal_verify.simulation.algorithm1.run_algorithm1` (attack,
        observers, rule, mode, trigger, no_switch, delay, x0, horizon, step, method, progress).
    """
    return run_algorithm1(system, rank_safe_modes(system), **options)
