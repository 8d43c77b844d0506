"""Cost estimates of ``design``'s later phases, made when the earlier ones have counted their attack sets.

The up-front estimate of ``design`` (:func:`glocal_verify.conditions.cost.estimate_design`)
covers its audits, the placement and the assessments; how many attack sets the safe modes
and the monitors must expose is known only after the audit with the observers. These
estimates are printed, and checked against the limits, when each phase starts.
"""

from __future__ import annotations

from glocal_verify import config
from glocal_verify.conditions.cost import A_AUDIT, B_BASE, CostEstimate, SpecSizes, dense_bytes, estimate_audit, estimate_design, phase_estimate

__all__ = ["estimate_monitor_step", "estimate_safe_modes", "estimate_whole_design"]


def estimate_safe_modes(sizes: SpecSizes, targets: int, *, exact: bool = False) -> CostEstimate:
    """Seconds and peak memory of ``design``'s safe-mode phase for ``targets`` undetected attack sets.

    The candidate links are scored against every target at once (microseconds each); what
    grows is the check of each claimed set against the proposed mode (its ZDA at the audit's
    lambda0 and the certified touch test, :mod:`glocal_verify.design.safe_modes`). The greedy
    cover claims a set about once, so

    .. math::

        t = T\\,(C_{check,0} + C_{check} N^2)\\,f_{exact},\\qquad m = B_{base} + 8 N^2 A_{audit}

    with T targets and the tunables ``safe_mode_check_seconds`` (:math:`C_{check,0}`, 1e-2 s),
    ``safe_mode_check_seconds_n2`` (:math:`C_{check}`, 1e-6 s) and ``safe_mode_check_exact_factor``
    (:math:`f_{exact}`, 5, over Q). Measured (numeric, one core): 8 ms per set at N = 40
    (42 ms exact), 20-30 ms at N = 80-120, 40 ms at N = 200; the design of 80 agents with
    2,393 targets checked 2,258 sets in 55 s on a shared machine.

    Parameters
    ----------
    sizes : SpecSizes
    targets : int
        Attack sets the safe modes must expose.
    exact : bool
        The checks run over Q (``design`` does up to ``safe_modes_exact_max_agents``).

    Returns
    -------
    CostEstimate
    """
    n = sizes.n
    per = float(config.get("safe_mode_check_seconds")) + float(config.get("safe_mode_check_seconds_n2")) * float(n) ** 2
    if exact:
        per *= float(config.get("safe_mode_check_exact_factor"))
    phases = {f"checks of {targets} undetected attack sets against the proposed modes": per * max(0, int(targets))}
    return phase_estimate("design", n, phases, B_BASE + A_AUDIT * dense_bytes(n), A_AUDIT)


def estimate_monitor_step(sizes: SpecSizes, targets: int, monitors: int, *, exact: bool = False) -> CostEstimate:
    """Seconds and peak memory of ``design``'s monitor step: up to ``monitors`` rounds for ``targets`` unexposed sets.

    Each round audits the sets left (their witness directions place the monitor), then designs
    safe modes for them again, which audits them once more for their exponents and checks
    each against the proposed modes:

    .. math::

        t = R\\,T\\,\\big(2\\,(C_{hard,0} + C_{hard}\\,g(N)) + t_{check}\\big),\\qquad m = B_{base} + 8 N^2 A_{audit}

    with R rounds, T targets, :math:`t_{check}` the check of :func:`estimate_safe_modes`,
    :math:`g(N) = N^3` up to ``growth_full_max_agents`` (every such set gets its whole zero
    set there) and :math:`N^2` above, and the tunables ``monitor_step_set_seconds``
    (:math:`C_{hard,0}`) and ``monitor_step_set_seconds_g`` (:math:`C_{hard}`). These sets
    are the hard ones (stealthy, undetected, not exposed): measured 73-80 ms each per audit at
    N = 42 on a shared machine, against 14 ms for the average set of the same audit. An
    upper bound: a round that detects every set ends the step.

    Parameters
    ----------
    sizes : SpecSizes
    targets : int
        Attack sets no safe mode exposes.
    monitors : int
        The monitor budget (rounds at most).
    exact : bool
        The safe-mode checks run over Q.

    Returns
    -------
    CostEstimate
    """
    n = sizes.n
    g = float(n) ** 3 if n <= config.get("growth_full_max_agents") else float(n) ** 2
    per_audit = float(config.get("monitor_step_set_seconds")) + float(config.get("monitor_step_set_seconds_g")) * g
    check = float(config.get("safe_mode_check_seconds")) + float(config.get("safe_mode_check_seconds_n2")) * float(n) ** 2
    if exact:
        check *= float(config.get("safe_mode_check_exact_factor"))
    t = max(0, int(targets))
    phases = {f"up to {monitors} monitor round(s) for {t} unexposed attack sets": max(0, int(monitors)) * t * (2.0 * per_audit + check)}
    return phase_estimate("design", n, phases, B_BASE + A_AUDIT * dense_bytes(n), A_AUDIT)


def estimate_whole_design(
    sizes: SpecSizes,
    *,
    max_attackers: int = 2,
    place: bool = True,
    exact_assessment: bool | None = None,
    budget: int = 3,
    monitor_budget: int = 3,
    confirm_limit: int = 64,
) -> CostEstimate:
    """Seconds and peak memory of the whole of ``design``, before it starts: an upper bound for planning.

    The later phases work on the attack sets the spec leaves undetected, unknown before the
    first audit; they are bounded here as if every set were one. Besides the two audits, the
    placement and the two assessments of :func:`~glocal_verify.conditions.cost.estimate_design`:

    .. math::

        t = t_{design} + (2 + R + p)\\, t_{audit} + B\\, L\\, t_{check},\\qquad m = \\max(m_{design}, m_{audit})

    with R = 2 + ``monitor_budget`` audits of what pruning removes (one per monitor, the mode, the
    schedule), p = 1 when observers are placed (the audit with them), B = ``budget`` modes each
    checked on ``confirm_limit`` = L sets, at most every set once (:func:`estimate_safe_modes`), and one audit of the
    sets with the modes and one of them with the monitors.

    Parameters
    ----------
    sizes : SpecSizes
    max_attackers : int
    place : bool
    exact_assessment : bool, optional
    budget : int
        Largest number of designed safe modes.
    monitor_budget : int
        Velocity monitors the design may add.
    confirm_limit : int
        Claims of each proposed mode re-verified before the audit of the design.

    Returns
    -------
    CostEstimate
    """
    head = estimate_design(sizes, max_attackers=max_attackers, place=place, exact_assessment=exact_assessment)
    one = estimate_audit(sizes, max_attackers)
    audits = 2 + (2 + max(0, int(monitor_budget))) + (1 if place else 0)
    import math

    sets = sum(math.comb(sizes.n, j) for j in range(1, max(1, int(max_attackers)) + 1))
    claims = min(sets, max(0, int(budget)) * max(0, int(confirm_limit)))
    checks = estimate_safe_modes(sizes, claims, exact=sizes.n <= int(config.get("safe_modes_exact_max_agents")))
    phases = dict(head.phases)
    phases[f"up to {audits} audits of the attack sets the design can move (safe modes, monitors, each change earning its place)"] = audits * sum(v for _, v in one.phases)
    for name, secs in checks.phases:
        phases[f"design: {name}"] = secs
    peak = max(head, one, key=lambda e: e.bytes)
    return phase_estimate("design", sizes.n, phases, peak.bytes, peak.dense_arrays)
