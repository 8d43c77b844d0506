"""Cost of ``design``: the whole design up front, and what is left of it as each phase starts.

One model (:func:`design_work`) counts the design's work in its units -- attack sets audited
and claims checked against proposed safe modes -- and one function prices each unit: a set in
an audit (:func:`audit_seconds_per_set`), its test against a designed mode
(:func:`mode_test_seconds`), a check (:func:`check_seconds`). The up-front estimate
(:func:`estimate_whole_design`) and the one made when the safe-mode phase starts, once the
audits have counted the sets the design can move, come from the same functions; the monitor
step, which runs only when the safe modes leave sets unexposed, is estimated when it starts
(:func:`estimate_monitor_step`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from glocal_verify import config
from glocal_verify.conditions.catalogue import DESIGN_ASSESSMENT_IDS
from glocal_verify.conditions.cost import (
    A_AUDIT,
    B_BASE,
    CostEstimate,
    SpecSizes,
    dense_bytes,
    estimate_audit,
    estimate_place_observers,
    estimate_verify,
    phase_estimate,
)

__all__ = [
    "C_DESIGN_MODE_TEST",
    "C_DESIGN_MODE_TEST_N2",
    "PRUNE_AUDITS_PER_MODE",
    "DesignWork",
    "audit_seconds",
    "audit_seconds_per_set",
    "check_seconds",
    "design_work",
    "estimate_monitor_step",
    "estimate_safe_modes",
    "estimate_whole_design",
    "mode_test_seconds",
]


#: pruning ("every change earns its place"): audits of the sets the design can move spent on the
#: links of the designed modes, per mode. A link is audited only on the sets its mode exposes and
#: another mode also exposes (a set only its mode exposes falls back for certain), and one audit
#: serves every link whose removal makes the mode fail Theorem III.3. Measured: 131 sets for 82
#: movable with three one-link modes (paper19), none for one mode of 3 links (N = 60), 5 x 4,950
#: for three modes of 4-6 links that each expose nearly every set (N = 100)
PRUNE_AUDITS_PER_MODE = 2.0

#: an audit row's test of one attack set against one designed safe mode (which meets Theorem
#: III.3 by construction, so every set is tested against it): C_0 + C_2 N^2 seconds. Measured
#: in design's audits of the movable sets on symmetric clusters: about 2 ms at N = 60 (one mode
#: of 3 links), 1 ms at N = 100, 4.3 ms at N = 200 (one mode of 8 links: 91 s for 19,908 sets,
#: 5 s without the mode)
C_DESIGN_MODE_TEST = 1e-3
C_DESIGN_MODE_TEST_N2 = 8e-8


def estimate_safe_modes(sizes: SpecSizes, targets: int, *, exact: bool = False) -> CostEstimate:
    """Seconds and peak memory of ``design``'s safe-mode phase for ``targets`` undetected attack sets.

    The candidate links are scored against every target at once (microseconds each); what
    grows is the check of each claimed set against the proposed mode (its ZDA at the audit's
    lambda0 and the certified touch test, :mod:`glocal_verify.design.safe_modes`). The greedy
    cover claims a set about once, and each kept mode checks at most its first ``confirm_limit``
    claims (the audit of the design decides the rest): ``design`` counts T = min(targets,
    budget x confirm_limit) (:func:`design_work`), so

    .. math::

        t = T\\,(C_{check,0} + C_{check} N^2)\\,f_{exact},\\qquad m = B_{base} + 8 N^2 A_{audit}

    with T checked sets and the tunables ``safe_mode_check_seconds`` (:math:`C_{check,0}`, 2e-3 s),
    ``safe_mode_check_seconds_n2`` (:math:`C_{check}`, 8e-6 s) and ``safe_mode_check_exact_factor``
    (:math:`f_{exact}`, 5, over Q) (:func:`check_seconds`). Measured (numeric, one core): 8 ms
    per set at N = 40 (42 ms exact), 20-30 ms at N = 80-120 and 40 ms at N = 200 for one-link
    modes; for modes of 3-8 links breaking a symmetry 28 ms at N = 60, 0.2 s at N = 100 and
    0.35 s at N = 200 (the touch test of each link); 10 ms over Q on paper19.

    Parameters
    ----------
    sizes : SpecSizes
    targets : int
        Claimed attack sets checked.
    exact : bool
        The checks run over Q (``design`` does up to ``safe_modes_exact_max_agents``).

    Returns
    -------
    CostEstimate
    """
    n = sizes.n
    phases = {f"checks of {targets} undetected attack sets against the proposed modes": check_seconds(n, exact) * max(0, int(targets))}
    return phase_estimate("design", n, phases, B_BASE + A_AUDIT * dense_bytes(n), A_AUDIT)


def check_seconds(n: int, exact: bool = False) -> float:
    """Seconds of the check of one claimed attack set against a proposed safe mode (:func:`estimate_safe_modes`)."""
    per = float(config.get("safe_mode_check_seconds")) + float(config.get("safe_mode_check_seconds_n2")) * float(n) ** 2
    return per * float(config.get("safe_mode_check_exact_factor")) if exact else per


def estimate_monitor_step(
    sizes: SpecSizes, targets: int, monitors: int, *, exact: bool = False, movable: int = 0, pruned: int = 0, max_attackers: int = 2
) -> CostEstimate:
    """Seconds and peak memory of ``design``'s monitor step: up to ``monitors`` rounds for ``targets`` unexposed sets.

    Each round audits the sets left (their witness directions place the monitor), then designs
    safe modes for them again, which audits them once more for their exponents and checks
    each against the proposed modes:

    .. math::

        t = R\\,T\\,\\big(2\\,(C_{hard,0} + C_{hard}\\,g(N)) + t_{check}\\big),\\qquad m = B_{base} + 8 N^2 A_{audit}

    plus the work :func:`design_work` leaves out before it (m = 0): the audit of the M movable
    sets with the added monitors and the pruning of the monitors (each one's removal is audited
    on the M movable sets), priced as in :func:`estimate_whole_design`; with R rounds, T targets,
    :math:`t_{check}` of :func:`check_seconds`, :math:`g(N) = N^3` up to ``growth_full_max_agents`` (every such set gets its whole zero
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
    movable : int
        The sets the design can move (pruning audits each added monitor on them).
    pruned : int
        Monitors pruning will try (default ``monitors``): those the safe modes added and the step's.
    max_attackers : int

    Returns
    -------
    CostEstimate
    """
    n = sizes.n
    g = float(n) ** 3 if n <= config.get("growth_full_max_agents") else float(n) ** 2
    per_audit = float(config.get("monitor_step_set_seconds")) + float(config.get("monitor_step_set_seconds_g")) * g
    check = check_seconds(n, exact)
    t = max(0, int(targets))
    rounds = max(0, int(monitors))
    phases = {
        f"up to {rounds} monitor round(s) for {t} unexposed attack sets (the safe modes left them: not in the first estimate)": rounds * t * (2.0 * per_audit + check),
    }
    if movable and rounds:
        # the work design_work leaves out with m = 0: the audit with the monitors and their pruning
        more = design_work(sizes, max_attackers=max_attackers, movable=movable, targets=movable, monitors=pruned or rounds, from_safe_modes=True)
        less = design_work(sizes, max_attackers=max_attackers, movable=movable, targets=movable, monitors=0, from_safe_modes=True)
        extra = sum(audit_seconds(sizes, max_attackers, more).values()) - sum(audit_seconds(sizes, max_attackers, less).values())
        phases[f"the audit with the added monitors and the pruning of {pruned or rounds} monitor(s) on the {movable} movable attack sets "
               f"(the safe modes left {t} unexposed: not in the first estimate)"] = extra
    return phase_estimate("design", n, phases, B_BASE + A_AUDIT * dense_bytes(n), A_AUDIT)


@dataclass(frozen=True, slots=True)
class DesignWork:
    """The work of ``design`` in its units: attack sets audited and claims checked against proposed modes.

    Attributes
    ----------
    audits : tuple of (str, int, int)
        Each audit (or group of audits) the design makes: what it is for, the attack sets it
        audits in all, and whether each set there is tested against the designed safe modes (1)
        or not (0).
    checks : int
        Claimed attack sets checked against proposed safe modes (each mode's first
        ``confirm_limit`` claims).
    """

    audits: tuple[tuple[str, int, int], ...]
    checks: int

    @property
    def audited(self) -> int:
        """Attack sets audited in all (a set audited twice counts twice)."""
        return sum(n for _, n, _ in self.audits)


def design_work(
    sizes: SpecSizes,
    *,
    max_attackers: int = 2,
    place: bool = True,
    budget: int = 3,
    confirm_limit: int = 64,
    moves_positions: bool = False,
    movable: int | None = None,
    targets: int | None = None,
    monitors: int = 0,
    from_safe_modes: bool = False,
) -> DesignWork:
    """What ``design`` audits and checks, counted from the sizes and what the run knows so far.

    With R the attack sets of 1..k agents, M <= R those the spec leaves undetected (the sets the
    design can move; M = R before the first audit counts them), T <= M of them undetected with the
    observers (the targets of the safe modes; T = M before that audit), B = ``budget`` designed
    modes, L = ``confirm_limit`` and m the velocity monitors the design adds:

    - audits: R (the spec as given), R again when position monitors move to velocities, M with
      the observers (when placed), M with the modes and, when m > 0, M with the monitors (each
      set tested against the modes), pruning ("every change earns its place") m M for the
      monitors (each one's removal can move any set) and :data:`PRUNE_AUDITS_PER_MODE` M for the
      links of the modes (a link is audited on the sets its mode exposes and another mode also
      exposes), and R with the design;
    - checks: min(T, B L): each kept mode checks at most its first L claims, the audit of the
      design decides the rest (``CONFIRM_LIMIT`` of :mod:`glocal_verify.design.network`).

    ``from_safe_modes`` counts only what is left when the safe-mode phase starts (the run has
    counted M and T). The monitor step is not counted here (m = 0): it runs only when the safe
    modes leave sets unexposed, and :func:`estimate_monitor_step` estimates it then, with its
    audit of the movable sets and the pruning of the monitors it adds.

    Parameters
    ----------
    sizes : SpecSizes
    max_attackers : int
    place : bool
        Observers are placed.
    budget, confirm_limit : int
    moves_positions : bool
        The spec monitors positions (the design moves them to velocities and audits again).
    movable, targets : int, optional
        M and T once counted.
    monitors : int
        Velocity monitors the design adds (m; 0 before the safe modes say how many they need).
    from_safe_modes : bool
        Count from the safe-mode phase on.

    Returns
    -------
    DesignWork
    """
    r = sum(math.comb(sizes.n, j) for j in range(1, max(1, int(max_attackers)) + 1))
    m = r if movable is None else max(0, int(movable))
    t = m if targets is None else max(0, int(targets))
    b = max(0, int(budget))
    audits: list[tuple[str, int, int]] = []
    if not from_safe_modes:
        audits.append(("the spec as given", r, 0))
        if moves_positions:
            audits.append(("the spec with its position monitors moved to velocities", r, 0))
        if place:
            audits.append(("the movable sets with the observers", m, 0))
    if t:
        mons = max(0, int(monitors))
        audits.append(("the movable sets with the safe modes", m, 1 if b else 0))
        if mons:
            audits.append(("the movable sets with the monitors the design adds", m, 1 if b else 0))
        prune = int(math.ceil((mons + (PRUNE_AUDITS_PER_MODE if b else 0.0)) * m))
        audits.append(("pruning: the sets each change may move", prune, 0))
    audits.append(("the designed spec", r, 1 if b and t else 0))
    return DesignWork(tuple((what, n, q) for what, n, q in audits if n), min(t, b * max(0, int(confirm_limit))))


def audit_seconds_per_set(sizes: SpecSizes, max_attackers: int) -> float:
    """Seconds of one attack set in one of ``design``'s audits: the whole audit's estimate over its sets.

    :func:`~glocal_verify.conditions.cost.estimate_audit` without the start-up and without
    writing the rows (the design writes none), divided by its R sets.
    """
    one = estimate_audit(sizes, max_attackers)
    r = sum(math.comb(sizes.n, j) for j in range(1, max(1, min(int(max_attackers), sizes.n)) + 1))
    return sum(v for name, v in one.phases if name != "writing the rows") / max(1, r)


def audit_seconds(sizes: SpecSizes, max_attackers: int, work: DesignWork) -> dict[str, float]:
    """Seconds of each audit of ``work``: its sets times :func:`audit_seconds_per_set`, plus :func:`mode_test_seconds` each where tested."""
    per_set, per_mode = audit_seconds_per_set(sizes, max_attackers), mode_test_seconds(sizes.n)
    out: dict[str, float] = {}
    for what, n, q in work.audits:
        key = f"audits of {n} attack sets: {what}"
        out[key] = out.get(key, 0.0) + n * (per_set + q * per_mode)
    return out


def mode_test_seconds(n: int) -> float:
    """Seconds of an audit row's test of one set against one designed safe mode (:data:`C_DESIGN_MODE_TEST`)."""
    return C_DESIGN_MODE_TEST + C_DESIGN_MODE_TEST_N2 * float(n) ** 2


def estimate_whole_design(
    sizes: SpecSizes,
    *,
    max_attackers: int = 2,
    place: bool = True,
    exact_assessment: bool | None = None,
    budget: int = 3,
    confirm_limit: int = 64,
    moves_positions: bool = False,
    movable: int | None = None,
    targets: int | None = None,
    from_safe_modes: bool = False,
) -> CostEstimate:
    """Seconds and peak memory of the whole of ``design`` (or of what is left of it), for planning.

    The work is counted by :func:`design_work` (attack sets audited, claims checked) and each
    unit costs what the audit's and the check's models say:

    .. math::

        t = \\sum_a n_a\\,(t_{set} + q_a\\,t_{mode}) + \\min(T, B L)\\,t_{check} + t_{place} + 2\\,t_{assess},
        \\qquad m = \\max(m_{audit}, m_{place}, m_{assess})

    with :math:`n_a` the sets of audit a, :math:`q_a` = 1 when they are tested against the
    designed modes there (the first mode costs most: at N = 200, 4.6 ms per set with one mode of
    8 links, 5.8 ms with three, 0.26 ms without), :math:`t_{set}` of :func:`audit_seconds_per_set`, :math:`t_{mode}` of
    :func:`mode_test_seconds`, :math:`t_{check}` the check of :func:`estimate_safe_modes`, the
    placement of :func:`~glocal_verify.conditions.cost.estimate_place_observers` and the two
    assessments (``verify`` of the assessment ids, before and after). Before the first audit M
    = R: the estimate assumes every attack set is movable, which a spec without safe modes
    nearly meets (1,770 of 1,830 at N = 60), and a spec whose modes detect many sets does not
    (82 of 190 on paper19: the estimate errs high there). ``movable`` and ``targets``, once
    counted, with ``from_safe_modes``, give what is left of :func:`design_network
    <glocal_verify.design.network.design_network>` when the safe-mode phase starts (the command's
    assessments after it not counted): the same model, so never more than the up-front
    estimate for the same spec.

    Parameters
    ----------
    sizes : SpecSizes
    max_attackers : int
    place : bool
    exact_assessment : bool, optional
        The assessments run over Q (default N <= 60).
    budget : int
        Largest number of designed safe modes.
    confirm_limit : int
        Claims of each proposed mode re-verified before the audit of the design.
    moves_positions : bool
        The spec monitors positions (moved to velocities, and audited again).
    movable, targets : int, optional
        The counts of :func:`design_work`, once the run has them.
    from_safe_modes : bool
        Only what is left of the design when the safe-mode phase starts (no placement, no
        assessments).

    Returns
    -------
    CostEstimate
    """
    work = design_work(sizes, max_attackers=max_attackers, place=place, budget=budget, confirm_limit=confirm_limit,
                       moves_positions=moves_positions, movable=movable, targets=targets, from_safe_modes=from_safe_modes)
    phases = audit_seconds(sizes, max_attackers, work)
    exact = sizes.n <= int(config.get("safe_modes_exact_max_agents"))
    for name, secs in estimate_safe_modes(sizes, work.checks, exact=exact).phases:
        phases[f"design: {name}"] = secs
    exact_a = sizes.n <= 60 if exact_assessment is None else exact_assessment
    parts = [] if from_safe_modes else [(2.0, estimate_verify(sizes, DESIGN_ASSESSMENT_IDS, exact=exact_a, exact_budget=None))]
    if place and not from_safe_modes:
        parts.append((1.0, estimate_place_observers(sizes)))
    for times, est in parts:
        for name, secs in est.phases:
            key = f"{est.command}: {name}"
            phases[key] = phases.get(key, 0.0) + times * secs
    peak = max([p[1] for p in parts] + [estimate_audit(sizes, max_attackers)], key=lambda e: e.bytes)
    # what is left is announced as such: "the rest of design of 200 agents: estimated ..."
    return phase_estimate("the rest of design" if from_safe_modes else "design", sizes.n, phases, peak.bytes, peak.dense_arrays)
