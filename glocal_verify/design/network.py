"""Design a whole network: monitors, local observers and safe modes, then re-audit.

:func:`design_network` chains the design steps and re-checks the result:

1. **monitors** -- positions are never monitored (M_x = ∅, the agents are moved to M_v), which
   keeps every ``privacy.*`` condition (:mod:`glocal_verify.design.monitors`);
2. **local observers** -- one more observer per cluster from
   :func:`glocal_verify.design.placement.place_cluster` for the interior agents (it then catches
   every attack on interior agents of its cluster: removing input columns keeps a full column
   rank pencil), or for the spec's attack when the interior cannot be covered; clusters that
   cannot be covered keep their observers;
3. **audit** of the monitored and observed network (:func:`glocal_verify.design.audit.audit`):
   its ``undetected`` sets are the targets;
4. **safe modes** exposing the targets (:func:`glocal_verify.design.safe_modes.design_safe_modes`,
   re-verified by the checkers, exactly for small N), appended to the spec's modes;
5. **monitors for what no mode exposes** -- a target that no safe mode within the budget
   exposes gets one more velocity monitor, at the agent where its stealthy direction deviates
   most from its median; the safe modes are designed again for the targets left (the new
   monitor makes more links meet Theorem III.3 (i)), until every target is detected or
   ``monitor_budget`` monitors were added. Another output only removes zeros (a kernel vector
   of the pencil with the new row is one without it) and keeps positions private, so no
   audited verdict gets worse;
6. **monitor check** -- :func:`glocal_verify.design.monitors.design_monitors` with the audited
   monitors required, so Theorem III.3 (i) and Lemma A.2 hold for the designed modes and
   privacy is re-verified (monitors are not removed: fewer monitors would create new stealthy
   attacks the audit did not see);
7. **re-audit** of the designed spec: every target must now be ``detected``.

What no design within the budget achieves is listed in :attr:`NetworkDesign.unmet`, one line each.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from glocal_verify.design.audit import AuditResult, audit
from glocal_verify.design.monitors import MonitorDesign, design_monitors
from glocal_verify.design.placement import ObserverProposal, place_cluster
from glocal_verify.design.safe_modes import (
    DEFAULT_WEIGHTS,
    SafeModeDesign,
    design_safe_modes,
    with_modes,
)
from glocal_verify.errors import GlocalVerifyError
from glocal_verify.model import System
from glocal_verify.spec.types import (
    ClusterSpec,
    Label,
    MonitorSpec,
    ObserverSpec,
    SystemSpec,
)

__all__ = ["NetworkDesign", "design_comments", "design_network"]


@dataclass(frozen=True)
class NetworkDesign:
    """The designed specification and the evidence for each choice.

    Attributes
    ----------
    spec : SystemSpec
        The complete designed specification.
    monitors : MonitorDesign
    observers : tuple of ObserverProposal
    added_monitors : tuple of (label, attack set)
        Velocity monitors added in step 5, each with the target whose stealthy direction chose it.
        Observers added (one per covered cluster).
    safe_modes : SafeModeDesign
    before, after : AuditResult
        Audits of the original and of the designed spec.
    targets : tuple of attack sets
        Sets undetected after steps 1-2 (to be exposed by safe modes).
    unmet : tuple of str
        Requirements no design within the budget met, with the reason.
    notes : tuple of str
    """

    spec: SystemSpec
    monitors: MonitorDesign
    observers: tuple[ObserverProposal, ...]
    safe_modes: SafeModeDesign
    before: AuditResult
    after: AuditResult
    targets: tuple[tuple[Label, ...], ...]
    unmet: tuple[str, ...] = ()
    added_monitors: tuple[tuple[Label, tuple[Label, ...]], ...] = ()
    notes: tuple[str, ...] = field(default_factory=tuple)

    @property
    def complete(self) -> bool:
        """Every requirement met."""
        return not self.unmet


def _velocity_only(spec: SystemSpec) -> SystemSpec:
    mon = spec.monitor
    vel = set(mon.positions) | set(mon.velocities)
    order = {a: i for i, a in enumerate(spec.nodes)}
    new = MonitorSpec((), tuple(sorted(vel, key=order.__getitem__)))
    attack = spec.attack
    if attack is not None and attack.sensors:
        attack = dataclasses.replace(attack, sensors=tuple(a for a in attack.sensors if a in vel))
    return dataclasses.replace(spec, monitor=new, attack=attack)


def _observers(system: System, exact_limit: int) -> tuple[SystemSpec, list[ObserverProposal], list[str]]:
    props: list[ObserverProposal] = []
    notes: list[str] = []
    clusters: list[ClusterSpec] = []
    for c in system.clusters:
        prop: ObserverProposal | None = None
        for suspected in ("interior", "attack"):
            try:
                prop = place_cluster(system, c.name, suspected, exact_limit=exact_limit, progress=False)
                break
            except GlocalVerifyError as exc:
                notes.append(f"{c.name}: no observer for the {suspected} agents ({exc})")
        if prop is None or any(o.center == prop.center and o.positions == prop.measured for o in c.observers):
            clusters.append(c)
            continue
        props.append(prop)
        obs = ObserverSpec(prop.center, prop.measured, prop.measured)
        clusters.append(dataclasses.replace(c, observers=tuple(o for o in c.observers if o.center != prop.center) + (obs,)))
    return dataclasses.replace(system.spec, clusters=tuple(clusters)), props, notes


def design_network(
    system: System,
    *,
    budget: int = 3,
    max_attackers: int = 2,
    candidates: Sequence[Label] | None = None,
    weights: Sequence[Any] = DEFAULT_WEIGHTS,
    place: bool = True,
    exact_limit: int = 2000,
    max_links: int = 2,
    monitor_budget: int = 3,
    progress: Callable[[str], None] | None = None,
) -> NetworkDesign:
    """Design monitors, local observers and safe modes for ``system`` (module docstring).

    Parameters
    ----------
    system : System
    budget : int
        Largest number of designed safe modes.
    max_links : int
        Largest number of link changes in one safe mode (one-link modes are tried first).
    max_attackers : int
        k of the audits.
    candidates : sequence of labels, optional
        Actuators the audits consider (default all).
    weights : sequence of Fraction
        Weights of added links.
    place : bool
        Add local observers (step 2).
    exact_limit : int
        Exhaustive-search limit of the observer placement.
    monitor_budget : int
        Largest number of velocity monitors step 5 adds.
    progress : callable, optional
        Called with one line as each step starts (the three audits, the placement, the safe
        modes, the monitors).

    Returns
    -------
    NetworkDesign
    """
    say = progress if progress is not None else (lambda line: None)
    say("auditing the spec as given")
    before = audit(system, max_attackers, candidates)
    spec = _velocity_only(system.spec)
    props: list[ObserverProposal] = []
    notes: list[str] = []
    if place and spec.clusters:
        say("placing local observers")
        spec, props, notes = _observers(System(spec), exact_limit)
    mid_sys = System(spec)
    say("auditing with the observers")
    mid = audit(mid_sys, max_attackers, candidates)
    targets = tuple(r.actuators for r in mid.rows if r.verdict == "undetected")
    lambdas = {r.actuators: r.lambda0 for r in mid.rows if r.lambda0 is not None}
    unmet: list[str] = []
    if targets:
        say(f"designing safe modes for {len(targets)} undetected attack sets")
        safe = design_safe_modes(mid_sys, targets, None, budget, weights=weights, lambdas=lambdas, max_links=max_links)
    else:
        safe = SafeModeDesign((), (), {}, 0, 0.0, 0)
    spec = with_modes(spec, [m.mode_spec() for m in safe.modes], keep=True)
    added: list[tuple[Label, tuple[Label, ...]]] = []
    if safe.unexposed and monitor_budget > 0:
        pending = [F for F in targets if ",".join(map(str, F)) in safe.unexposed]
        spec, added, safe = _monitor_unexposed(spec, pending, monitor_budget, safe, budget, weights, max_links)
    final = System(spec)
    say("choosing the global monitors")
    mon = design_monitors(final, required=spec.monitor.velocities)
    if mon.velocities != spec.monitor.velocities:
        spec = dataclasses.replace(spec, monitor=MonitorSpec((), mon.velocities))
        final = System(spec)
    bad = [cid for cid, st in mon.verification.items() if st != "holds" and cid.startswith("privacy.")]
    unmet += [f"{cid}: {mon.verification[cid]} on the designed spec" for cid in bad]
    say("auditing the design")
    after = audit(final, max_attackers, candidates)
    for F in targets:
        row = next(r for r in after.rows if r.actuators == F)
        key = ",".join(map(str, F))
        if row.verdict != "detected":
            why = safe.unexposed.get(key, f"still {row.verdict} after the design")
            more = f"; {len(added)} added velocity monitor(s) did not remove its ZDA" if added and key in safe.unexposed else ""
            unmet.append(f"attack on {key}: {why}{more}")
    return NetworkDesign(spec, mon, tuple(props), safe, before, after, targets, tuple(unmet), notes=tuple(notes), added_monitors=tuple(added))


def _monitor_unexposed(
    spec: SystemSpec, targets: Sequence[tuple[Label, ...]], budget: int, safe: SafeModeDesign, mode_budget: int, weights: Sequence[Any], max_links: int
) -> tuple[SystemSpec, list[tuple[Label, tuple[Label, ...]]], SafeModeDesign]:
    """Step 5 of :func:`design_network`: velocity monitors where the unexposed ZDAs live.

    The agent chosen is the unmonitored one where the targets' stealthy directions xi deviate
    most from their medians, summed over the targets left (each scaled to its largest
    deviation), so one monitor serves every set that shares an agent. A ZDA at lambda0 != 0 that is nonzero there disappears; one at
    lambda0 = 0 (which no velocity monitor sees) is often constant off a small region (e.g.
    xi = L^+ (e_a - e_b) for a leaf b of a), and the new monitor makes the links at that region
    meet Theorem III.3 (i), so the safe modes are designed again for what is left.
    """
    import numpy as np

    from glocal_verify.design.audit import audit_chunks, merge_chunks

    added: list[tuple[Label, tuple[Label, ...]]] = []
    left = list(targets)
    while left and len(added) < budget:
        system = System(spec)
        chunks = audit_chunks(system, left, chunk_size=max(1, len(left)))
        rows = merge_chunks(system, max(len(F) for F in left), system.labels, [c() for c in chunks], chunks[0].shared.modes).rows
        left = [r.actuators for r in rows if r.verdict != "detected"]
        if not left:
            break
        watched = set(spec.monitor.velocities)
        score = np.zeros(system.n)
        first_of: dict[int, tuple[Label, ...]] = {}
        xis = _witness_xis(system, [r for r in rows if r.verdict != "detected"])
        for F in left:
            xi = xis.get(F)
            if xi is None:
                continue
            dev = np.abs(xi - np.median(xi.real))
            dev[[system.index[a] for a in watched]] = 0.0
            top = float(np.max(dev, initial=0.0))
            if top > 1e-9:
                score += dev / top
                first_of.setdefault(int(np.argmax(dev)), F)
        if not np.any(score > 0):
            break
        best = int(np.argmax(score))
        agent = system.labels[best]
        F = first_of.get(best, left[0])
        idx = {a: i for i, a in enumerate(spec.nodes)}
        spec = dataclasses.replace(spec, monitor=MonitorSpec((), tuple(sorted(watched | {agent}, key=idx.__getitem__))))
        added.append((agent, F))
        room = mode_budget - len(safe.modes)
        if room > 0:
            more = design_safe_modes(System(spec), left, None, room, weights=weights, max_links=max_links)
            first = len(safe.modes) + 1
            renamed = tuple(dataclasses.replace(m, name=f"designed-{first + i}") for i, m in enumerate(more.modes))
            spec = with_modes(spec, [m.mode_spec() for m in renamed], keep=True)
            exposed = {",".join(map(str, F2)) for m in renamed for F2 in m.exposes}
            safe = dataclasses.replace(safe, modes=safe.modes + renamed, unexposed={k: v for k, v in safe.unexposed.items() if k not in exposed})
    return spec, added, safe


def _witness_xis(system: System, rows: Sequence[Any]) -> dict[tuple[Label, ...], Any]:
    """The position part xi of each row's witness ZDA (the proven direction at the row's lambda0).

    Rows keep xi out of their witness above 100 agents, so it is computed again: for all rows
    of one lambda0 at once (:func:`glocal_verify.analysis.zda_batch.batch_directions`), the
    per-set method for the sets the batch leaves open. Not a fresh zero set per set (an O(N^3)
    pencil analysis each, minutes for thousands of targets at N = 200).
    """
    from glocal_verify.analysis.zda import _Modal
    from glocal_verify.analysis.zda_batch import batch_directions
    from glocal_verify.numerics.tolerance import DEFAULT_TOLERANCE, Decision

    groups: dict[complex, list[tuple[Label, ...]]] = {}
    for r in rows:
        if r.lambda0 is not None and r.stealthy:
            groups.setdefault(complex(r.lambda0), []).append(r.actuators)
    out: dict[tuple[Label, ...], Any] = {}
    for lam, sets in groups.items():
        for F, d in zip(sets, batch_directions(system, DEFAULT_TOLERANCE, lam, sets)):
            if d is not None:
                out[F] = d.xi
                continue
            found = _Modal(system, F, DEFAULT_TOLERANCE).direction(lam)[0]
            if found is not None and found[3] is Decision.ZERO and found[4] is Decision.NONZERO:
                out[F] = found[0]
    return out


def design_comments(d: NetworkDesign) -> str:
    """TOML comment lines saying what each design choice achieves.

    Parameters
    ----------
    d : NetworkDesign
    """
    b, a = d.before.summary()["counts"], d.after.summary()["counts"]
    lines = [
        f"# Designed by glocal-verify design from {d.before.system!r}.",
        f"# Audit (k = {d.after.max_attackers}): before {b['undetected']} undetected / {b['undecided']} undecided sets,"
        f" after {a['undetected']} undetected / {a['undecided']} undecided.",
        f"# [monitor] velocities only (positions private: Lemma III.1, privacy.* {'hold' if all(v == 'holds' for k, v in d.monitors.verification.items() if k.startswith('privacy.')) else 'see verify'});"
        f" Theorem III.3 (i) and Lemma A.2 hold for every designed mode.",
    ]
    for p in d.observers:
        lines.append(
            f"# [[clusters]] {p.cluster}: observer at {p.center} measures {list(p.measured)}: Proposition III.2 (ii), (iii) and the UIO hold"
            f" for suspected {list(p.suspected)} ({'proven minimum' if p.optimal else 'greedy'} size)."
        )
    for m in d.safe_modes.modes:
        lines.append(
            f"# [[modes]] {m.name}: {m.describe()}; Theorem III.3 (i)-(iii) hold ({m.method}) and it touches every stealthy"
            f" direction of {len(m.exposes)} audited attack set(s), e.g. {[list(F) for F in m.exposes[:4]]}."
        )
    for agent, F in d.added_monitors:
        lines.append(f"# [monitor] velocity of {agent} added: the stealthy direction of the attack on {list(F)} (no safe mode within the budget touches it) is largest there.")
    for u in d.unmet:
        lines.append(f"# NOT MET: {u}")
    return "\n".join(lines) + "\n"
