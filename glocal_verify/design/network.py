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
   attacks the audit did not see); the monitors of steps 5 and 6 together stay within
   ``monitor_budget``;
7. **schedule** -- a set a mode exposes but no local observer can raise an alarm for (an
   attack on a boundary agent: Proposition III.2 (iii) fails there at every lambda) is never
   switched for under Algorithm 1; a ``[switching]`` schedule through the exposing modes
   switches whatever the observers see, and detects it;
8. **re-audit** of the designed spec, with the answer ``verify`` gives (:mod:`glocal_verify.answer.attack`).

Every change is listed with what it achieves (:attr:`NetworkDesign.changes`, the designed
spec's header, the command's summary). When a requirement is not met the design is still
returned (the best one within the budgets) and :attr:`NetworkDesign.unmet` names each
obstacle, one line each, with the sets it concerns.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

from glocal_verify import config
from glocal_verify.conditions.cost import CostEstimate, SpecSizes
from glocal_verify.conditions.design_cost import estimate_monitor_step, estimate_whole_design
from glocal_verify.design.audit import AuditResult, audit
from glocal_verify.design.monitors import MonitorDesign, design_monitors
from glocal_verify.design.placement import ObserverProposal, place_cluster
from glocal_verify.design.pruning import Blueprint, Edit, audit_sets, prune
from glocal_verify.design.symmetry import split_normal_weights, with_monitors
from glocal_verify.design.safe_modes import (
    DEFAULT_WEIGHTS,
    SafeModeDesign,
    design_safe_modes,
    with_modes,
)
from glocal_verify.errors import GlocalVerifyError, NotApplicableError
from glocal_verify.model import System
from glocal_verify.spec.types import (
    Label,
    MonitorSpec,
    ObserverSpec,
    SystemSpec,
)

__all__ = ["CONFIRM_LIMIT", "DesignChange", "NetworkDesign", "before_table", "design_comments", "design_network"]

#: claims of each proposed safe mode re-verified before the whole design is audited (the audit
#: decides the others: every set it reports detected is checked by the rules of ``verify``)
CONFIRM_LIMIT = 64


@dataclass(frozen=True, slots=True)
class DesignChange:
    """One change the design made to the spec, and what it achieves.

    Attributes
    ----------
    kind : {"monitor", "observer", "mode", "schedule", "weight"}
    action : str
        ``added``, ``replaced``, ``moved``, ``changed``.
    subject : str
        What changed, e.g. ``velocity monitor at 8`` or ``mode designed-1 (add 4-7 (w=1))``.
    achieves : str
        Why, in one sentence (which condition or attack it serves).
    moved : tuple of attack sets
        The sets the audit shows it moves toward detected: without it they fall back (empty
        for the move of position monitors, which serves privacy).
    """

    kind: str
    action: str
    subject: str
    achieves: str
    moved: tuple[tuple[Label, ...], ...] = ()

    def text(self) -> str:
        """``"added velocity monitor at 8: ...; moves 3 attack set(s) toward detected: {1, 2}, ..."``."""
        moved = f"; moves {len(self.moved)} attack set(s) toward detected: {_sets_text(self.moved)}" if self.moved else ""
        return f"{self.action} {self.subject}: {self.achieves}{moved}"

    def to_json(self) -> dict[str, Any]:
        return {"kind": self.kind, "action": self.action, "subject": self.subject, "achieves": self.achieves, "moved": [list(F) for F in self.moved]}


@dataclass(frozen=True)
class NetworkDesign:
    """The designed specification, every change it made and the evidence for each.

    Attributes
    ----------
    spec : SystemSpec
        The complete designed specification (a partial design when :attr:`unmet` is not empty:
        the best one found within the budgets).
    monitors : MonitorDesign
    observers : tuple of ObserverProposal
    safe_modes : SafeModeDesign
    before, after : AuditResult
        Audits of the original and of the designed spec (one answer per set: the rule of
        ``verify``).
    targets : tuple of attack sets
        Stealthy sets no mode exposed after steps 1-2 (to be exposed by safe modes).
    unmet : tuple of str
        What no design within the budgets achieves, one line per obstacle (with the sets it
        concerns and what would remove it).
    added_monitors : tuple of (label, attack set)
        Velocity monitors added in step 5, each with the target whose stealthy direction chose it.
    changes : tuple of DesignChange
        Every change to the spec (monitors, observers, modes, schedule) with what it achieves.
    notes : tuple of str
    blueprint : Blueprint, optional
        The base spec and every edit the design considered (:mod:`glocal_verify.design.pruning`).
    kept : frozenset of Edit
        The edits of :attr:`spec`.
    change_edits : tuple of tuples of Edit
        Per change, the edits it stands for (:meth:`without`).
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
    changes: tuple[DesignChange, ...] = ()
    notes: tuple[str, ...] = field(default_factory=tuple)
    blueprint: Blueprint | None = None
    kept: frozenset[Edit] = frozenset()
    change_edits: tuple[tuple[Edit, ...], ...] = ()

    def without(self, k: int) -> SystemSpec:
        """The designed spec without change ``k`` of :attr:`changes` (its edits removed).

        Raises
        ------
        NotApplicableError
            For a change that stands for no edit (the move of position monitors).
        """
        es = self.change_edits[k] if k < len(self.change_edits) else ()
        if self.blueprint is None or not es:
            raise NotApplicableError(f"change {k} ({self.changes[k].subject}) cannot be removed on its own")
        return self.blueprint.build(self.kept - set(es))

    @property
    def complete(self) -> bool:
        """Every requirement met."""
        return not self.unmet

    def summary(self) -> list[str]:
        """The before/after counts, every change and every unmet requirement, one line each."""
        b, a = self.before.summary()["counts"], self.after.summary()["counts"]
        n = len(self.after.rows)
        head = f"undetected {b['undetected']} -> {a['undetected']}"
        if b["undecided"] or a["undecided"]:
            head += f", undecided {b['undecided']} -> {a['undecided']}"
        lines = [
            f"{head} of {n} attack sets",
            f"audit before: {b['detected']} detected, {b['undetected']} undetected, {b['undecided']} undecided of {n} attack sets",
            f"audit after:  {a['detected']} detected, {a['undetected']} undetected, {a['undecided']} undecided",
        ]
        lines += [f"- {c.text()}" for c in self.changes] or (["- no change moves an attack set toward detected"] if b["undetected"] or b["undecided"] else ["- no change was needed"])
        lines += [f"NOT MET: {u}" for u in self.unmet]
        return lines

    def _repr_html_(self) -> str:
        from html import escape

        lines = self.summary()
        head = "incomplete design" if self.unmet else "design"
        items = "".join(f"<li>{escape(x)}</li>" for x in lines[3:])
        return f"<div><p><b>{escape(head)}</b>: {escape(lines[0])}</p><p>{escape(lines[1])}<br>{escape(lines[2])}</p><ul>{items}</ul></div>"

    def __repr__(self) -> str:
        a = self.after.summary()["counts"]
        return f"<NetworkDesign {self.before.system}: {len(self.changes)} changes; after: {a['undetected']} undetected, {a['undecided']} undecided{'; incomplete' if self.unmet else ''}>"


def _velocity_only(spec: SystemSpec) -> SystemSpec:
    mon = spec.monitor
    vel = set(mon.positions) | set(mon.velocities)
    order = {a: i for i, a in enumerate(spec.nodes)}
    new = MonitorSpec((), tuple(sorted(vel, key=order.__getitem__)))
    attack = spec.attack
    if attack is not None and attack.sensors:
        attack = dataclasses.replace(attack, sensors=tuple(a for a in attack.sensors if a in vel))
    return dataclasses.replace(spec, monitor=new, attack=attack)


def _observers(system: System, exact_limit: int | None) -> tuple[dict[tuple[str, Label], ObserverSpec], list[ObserverProposal], list[str]]:
    """Step 2: one more (or a wider) observer per cluster for its interior agents (or the spec's attack).

    At a centre that already has an observer the new one measures what both measure: more
    measured agents keep Proposition III.2 (ii) and (iii) (more output rows keep the pencil's
    column rank), so no set the old observer catches is lost.
    """
    props: list[ObserverProposal] = []
    notes: list[str] = []
    out: dict[tuple[str, Label], ObserverSpec] = {}
    for c in system.clusters:
        prop: ObserverProposal | None = None
        for suspected in ("interior", "attack"):
            try:
                prop = place_cluster(system, c.name, suspected, exact_limit=exact_limit, progress=False)
                break
            except GlocalVerifyError as exc:
                notes.append(f"{c.name}: no observer for the {suspected} agents ({exc})")
        if prop is None:
            continue
        measured = set(prop.measured)
        for o in c.observers:
            if o.center == prop.center:
                lo = system.resolve_observer(c, o)
                measured |= set(lo.positions) & set(lo.velocities)
        order = {a: k for k, a in enumerate(c.nodes)}
        meas = tuple(sorted(measured, key=lambda a: order.get(a, len(order))))
        if any(o.center == prop.center and o.positions == meas and o.velocities == meas for o in c.observers):
            continue
        props.append(dataclasses.replace(prop, measured=meas))
        out[(c.name, prop.center)] = ObserverSpec(prop.center, meas, meas)
    return out, props, notes


def before_table(
    system: System, max_attackers: int = 2, candidates: Sequence[Label] | None = None, progress: Callable[[int, int], None] | None = None
) -> AuditResult:
    """Design's before-table: the audit of the spec as given (every row the answer ``verify`` gives for that attack).

    Parameters
    ----------
    system : System
    max_attackers : int
    candidates : sequence of labels, optional
    progress : callable, optional
        Called with (attack sets done, total) as the audit goes.
    """
    return audit(system, max_attackers, candidates, None, progress)


def design_network(
    system: System,
    *,
    budget: int = 3,
    max_attackers: int = 2,
    candidates: Sequence[Label] | None = None,
    weights: Sequence[Any] = DEFAULT_WEIGHTS,
    place: bool = True,
    exact_limit: int | None = None,
    max_links: int | None = None,
    monitor_budget: int = 3,
    schedule_dwell: float | None = None,
    normal_weights: bool = False,
    prune_changes: bool = True,
    progress: Callable[[str], None] | None = None,
    tick: Callable[[int, int], None] | None = None,
    admit: Callable[[CostEstimate], None] | None = None,
) -> NetworkDesign:
    """Design monitors, local observers, safe modes and, where needed, a switching schedule (module docstring).

    Parameters
    ----------
    system : System
    budget : int
        Largest number of designed safe modes.
    max_links : int, optional
        Largest number of link changes in one safe mode (one-link modes are tried first).
        None: two for the combinatorial search, as many as the interlacing bound asks for a
        mode that breaks a symmetry of L_1 (:mod:`glocal_verify.design.symmetry`).
    max_attackers : int
        k of the audits.
    candidates : sequence of labels, optional
        Actuators the audits consider (default all).
    weights : sequence of Fraction
        Weights of added links of one-link modes.
    place : bool
        Add local observers (step 2).
    exact_limit : int, optional
        Exhaustive-search limit of the observer placement (default: the tunable
        ``placement_exact_limit`` of :mod:`glocal_verify.config` in force).
    monitor_budget : int
        Largest number of velocity monitors the design adds in all.
    schedule_dwell : float, optional
        Largest stay in each mode of a designed ``[switching]`` schedule (default: the
        horizon shared equally, so the schedule fits it).
    normal_weights : bool
        Where L_1 has repeated eigenvalues, change weights of the normal graph's links so that
        they split (off by default: the normal graph is the user's); the change is listed.
    prune_changes : bool
        Remove every change the audit does not need (:mod:`glocal_verify.design.pruning`).
    progress : callable, optional
        Called with one line as each step starts, with the attack sets left.
    tick : callable, optional
        Called with (attack sets done, total) within the long steps.
    admit : callable, optional
        Called with the estimate of what is left of the design
        (:func:`glocal_verify.conditions.design_cost.estimate_whole_design` with the movable sets
        and the targets counted: the up-front model, so never above its estimate for the same
        spec) once the audit with the observers has counted the undetected sets, before the
        safe-mode phase starts, and with that of the monitor step
        (:func:`glocal_verify.conditions.design_cost.estimate_monitor_step`, new work: it runs
        only when the safe modes leave sets unexposed) before that step; it may raise
        (:class:`~glocal_verify.conditions.cost.SizeLimitError`) to refuse the run.

    Returns
    -------
    NetworkDesign
        Also when some requirement is not met: the best design within the budgets, with
        :attr:`NetworkDesign.unmet` naming each obstacle.
    """
    say = progress if progress is not None else (lambda line: None)
    say("auditing the spec as given")
    before = before_table(system, max_attackers, candidates, tick)
    base = _velocity_only(system.spec)
    base_rows = {r.actuators: r for r in before.rows}
    if base != system.spec:
        say("auditing the spec with its position monitors moved to velocities (privacy)")
        base_rows = {r.actuators: r for r in audit(System(base), max_attackers, candidates, None, tick).rows}
    movable = [F for F, r in base_rows.items() if r.verdict != "detected"]
    say(f"{len(movable)} of {len(base_rows)} attack sets not detected: the design works on them")
    notes: list[str] = []
    normal: dict[tuple[Label, Label], Fraction] = {}
    spec = base
    if normal_weights and movable:
        normal, why = split_normal_weights(System(base))
        if why:
            notes.append(why)
        spec = Blueprint(base, weights=normal).build([Edit("weight", k) for k in normal])
    props: list[ObserverProposal] = []
    obs: dict[tuple[str, Label], ObserverSpec] = {}
    if place and spec.clusters and movable:
        say("placing local observers")
        obs, props, more = _observers(System(spec), exact_limit)
        notes += more
        spec = Blueprint(spec, observers=obs).build([Edit("observer", k) for k in obs])
    mid_sys = System(spec)
    if spec != base:
        say(f"auditing the {len(movable)} attack sets not detected, with the observers")
        mid = audit_sets(spec, movable, tick)
    else:
        mid = {F: base_rows[F] for F in movable}
    targets = tuple(F for F in movable if mid[F].verdict != "detected" and mid[F].stealthy is True and not mid[F].exposed_by_modes)
    lambdas = {F: r.lambda0 for F, r in mid.items() if r.lambda0 is not None}
    if targets:
        if admit is not None:
            # what is left of the design, by the model of the up-front estimate with the sets now counted (never above it)
            admit(estimate_whole_design(SpecSizes.from_spec(system.spec), max_attackers=max_attackers, place=place, budget=budget,
                                        confirm_limit=CONFIRM_LIMIT, movable=len(movable), targets=len(targets), from_safe_modes=True))
        say(f"designing safe modes for {len(targets)} undetected attack sets")
        safe = design_safe_modes(mid_sys, targets, None, budget, weights=weights, lambdas=lambdas, max_links=max_links,
                                 monitor_room=monitor_budget, confirm_limit=CONFIRM_LIMIT, progress=say, tick=tick)
    else:
        safe = SafeModeDesign((), (), {}, 0, 0.0, 0)

    def blueprint(safe: SafeModeDesign, monitors: Sequence[Label]) -> Blueprint:
        # the schedule is always proposed with the modes: pruning keeps it only where no local alarm would switch
        return Blueprint(base, monitors=tuple(dict.fromkeys(monitors)), observers=obs,
                         modes={m.name: tuple((c.u, c.v, c.weight, c.remove, c.was) for c in m.links) for m in safe.modes},
                         descriptions={m.name: m.mode_spec().description for m in safe.modes}, schedule=bool(safe.modes), weights=normal, dwell=schedule_dwell)

    bp = blueprint(safe, safe.monitors)
    say(f"auditing the {len(movable)} attack sets the design can move, with its {len(safe.modes)} safe mode(s)")
    rows = audit_sets(bp.build(bp.edits()), movable, tick)
    added: list[tuple[Label, tuple[Label, ...]]] = []
    room = monitor_budget - len(safe.monitors)
    pending = [F for F in targets if rows[F].verdict != "detected"]
    if pending and room > 0:
        if admit is not None:
            admit(estimate_monitor_step(SpecSizes.from_spec(spec), len(pending), room, exact=mid_sys.n <= config.get("safe_modes_exact_max_agents"), movable=len(movable),
                                        pruned=len(safe.monitors) + room, max_attackers=max_attackers))
        spec = with_modes(with_monitors(spec, safe.monitors), [m.mode_spec() for m in safe.modes], keep=True)
        spec, added, safe = _monitor_unexposed(spec, pending, room, safe, budget, weights, max_links, say, tick)
    say("choosing the global monitors")
    bp = blueprint(safe, [*safe.monitors, *(a for a, _ in added)])
    spec = bp.build(bp.edits())
    mon = design_monitors(System(spec), required=spec.monitor.velocities, verify_design=False)
    extra = [a for a in mon.velocities if a not in spec.monitor.velocities]
    room = monitor_budget - len(safe.monitors) - len(added)
    if extra and len(extra) > room:
        notes.append(
            f"Theorem III.3 (i) and Lemma A.2 in every mode (the spec's own included) would need {len(extra)} more velocity monitor(s) "
            f"({', '.join(map(str, extra))}); the monitor budget leaves {max(room, 0)}, so none was added"
        )
        extra = []
    bp = blueprint(safe, [*safe.monitors, *(a for a, _ in added), *extra])
    if added or extra:
        say(f"auditing the {len(movable)} attack sets the design can move")
        rows = audit_sets(bp.build(bp.edits()), movable, tick)
    kept = frozenset(bp.edits())
    moved: dict[Edit, tuple[tuple[Label, ...], ...]] = {}
    if prune_changes and kept:
        say(f"checking that each of the {len(kept)} changes earns its place")
        kept, moved, rows = prune(bp, movable, known=rows, say=say, tick=tick)
    spec = bp.build(kept)
    final = System(spec)
    say("auditing the design")
    after = audit(final, max_attackers, candidates, None, tick)
    mon = design_monitors(final, required=spec.monitor.velocities)
    unmet = [f"{cid}: {mon.verification[cid]} on the designed spec" for cid, st in mon.verification.items() if st != "holds" and cid.startswith("privacy.")]
    unmet += _obstacles(after, safe, [(a, F) for a, F in added if Edit("monitor", (a,)) in kept])
    changes, edits = _changes(system.spec, bp, kept, moved, props, safe, added, extra)
    if spec.simulation.horizon != system.spec.simulation.horizon:
        notes.append(f"the horizon was extended from {system.spec.simulation.horizon:g} s to {spec.simulation.horizon:g} s so that the designed schedule fits")
    return NetworkDesign(spec, mon, tuple(p for p in props if Edit("observer", (p.cluster, p.center)) in kept), safe, before, after, targets,
                         tuple(unmet), tuple((a, F) for a, F in added if Edit("monitor", (a,)) in kept), tuple(changes), tuple(notes), bp, kept, tuple(edits))


def _obstacles(after: AuditResult, safe: SafeModeDesign, added: Sequence[tuple[Label, tuple[Label, ...]]]) -> list[str]:
    """One line per obstacle that leaves sets undetected or undecided, with the sets it concerns."""
    groups: dict[str, list[tuple[Label, ...]]] = {}
    for r in after.rows:
        if r.verdict == "detected":
            continue
        key = ",".join(map(str, r.actuators))
        if key in safe.unexposed:
            why = f"no safe mode within the budget exposes it: {safe.unexposed[key]}"
            if added:
                why += f" ({len(added)} added velocity monitor(s) did not remove its ZDA)"
        else:
            chain = r.answer.chain if r.answer is not None else (str(r.witness.get("reason", "")),)
            why = f"{r.verdict}: {chain[-2] if len(chain) > 2 and chain[-1] == 'no switch' else chain[-1]}"
        groups.setdefault(why, []).append(r.actuators)
    out = []
    for why, sets in sorted(groups.items(), key=lambda kv: -len(kv[1])):
        shown = "; ".join("{" + ", ".join(map(str, F)) + "}" for F in sets[:6]) + (f" and {len(sets) - 6} more" if len(sets) > 6 else "")
        out.append(f"{len(sets)} attack set(s) ({shown}): {why}")
    return out


def _sets_text(sets: Sequence[tuple[Label, ...]], shown: int = 4) -> str:
    out = ", ".join("{" + ", ".join(map(str, F)) + "}" for F in sets[:shown])
    return out + (f" and {len(sets) - shown} more" if len(sets) > shown else "")


def _changes(
    old: SystemSpec,
    bp: Blueprint,
    kept: frozenset[Edit],
    moved: Mapping[Edit, tuple[tuple[Label, ...], ...]],
    props: Sequence[ObserverProposal],
    safe: SafeModeDesign,
    added: Sequence[tuple[Label, tuple[Label, ...]]],
    extra: Sequence[Label],
) -> tuple[list[DesignChange], list[tuple[Edit, ...]]]:
    """Every kept change with what it achieves and the sets it moves, and the edits each stands for."""
    out: list[DesignChange] = []
    edits: list[tuple[Edit, ...]] = []

    def put(kind: str, action: str, subject: str, achieves: str, es: Sequence[Edit], sets: Sequence[tuple[Label, ...]] | None = None) -> None:
        if sets is None:
            sets = tuple(dict.fromkeys(F for e in es for F in moved.get(e, ())))
        out.append(DesignChange(kind, action, subject, achieves, tuple(sets)))
        edits.append(tuple(es))

    for a in old.monitor.positions:
        put("monitor", "moved", f"position monitor at {a} to its velocity", "no position is measured, so [1; 0] stays unobservable: x(t0) and x* stay private (Lemma III.1)", (), ())
    for (u, v), w in bp.weights.items():
        e = Edit("weight", (u, v))
        if e in kept:
            put("weight", "changed", f"weight of the normal graph's link {u}-{v} to {w}", "splits a repeated eigenvalue of L_1, so that safe modes can meet Theorem III.3 (ii)-(iii)", (e,))
    why_monitor = {a: f"the stealthy direction of the attack on {{{', '.join(map(str, F))}}}, which no safe mode within the budget touched, is largest there" for a, F in added}
    for m in safe.modes:
        for a in m.monitors:
            why_monitor.setdefault(a, f"Theorem III.3 (i) of {m.name}: each of its tree components of c changed links needs c monitored agents")
    for a in extra:
        why_monitor.setdefault(a, "Theorem III.3 (i) for the designed modes (every switching component meets a monitor)")
    for a in bp.monitors:
        e = Edit("monitor", (a,))
        if e in kept:
            put("monitor", "added", f"velocity monitor at {a}", why_monitor.get(a, "Theorem III.3 (i)"), (e,))
    before_obs = {(c.name, o.center): o for c in old.clusters for o in c.observers}
    for p in props:
        e = Edit("observer", (p.cluster, p.center))
        if e not in kept:
            continue
        what = f"Proposition III.2 (ii), (iii) and its UIO hold for suspected {list(p.suspected)}, so a local alarm is raised for every attack on them"
        if (p.cluster, p.center) in before_obs:
            o = before_obs[(p.cluster, p.center)]
            was = "its neighbours" if o.positions is None else f"{list(o.positions)}"
            put("observer", "replaced", f"observer at {p.center} of {p.cluster}: now measures {list(p.measured)} (was {was})", what, (e,))
        else:
            put("observer", "added", f"observer at {p.center} of {p.cluster} measuring {list(p.measured)}", what, (e,))
    for m in safe.modes:
        es = tuple(Edit("link", (m.name, k)) for k in range(len(m.links)) if Edit("link", (m.name, k)) in kept)
        if not es:
            continue
        links = [c for k, c in enumerate(m.links) if Edit("link", (m.name, k)) in kept]
        desc = " + ".join(c.describe() for c in links)
        each = f"; each of its {len(links)} links is needed (without any one, Theorem III.3 fails or fewer sets are exposed)" if len(links) > 1 else ""
        put("mode", "added", f"mode {m.name} ({desc})",
            f"Theorem III.3 (i)-(iii) hold ({m.method}) and the switch touches every stealthy direction of the attack sets it exposes{each}", es)
    if Edit("schedule") in kept:
        sw = bp.build(kept).switching
        text = " -> ".join(f"{st.mode}({st.duration:g})" for st in sw.sequence) if sw is not None else ""
        put("schedule", "added", f"[switching] schedule {text}",
            "switches to the designed modes whatever the local observers see, within the horizon: exposes attacks no local observer can raise an alarm for (e.g. on boundary agents)", (Edit("schedule"),))
    return out, edits


def _monitor_unexposed(
    spec: SystemSpec,
    targets: Sequence[tuple[Label, ...]],
    budget: int,
    safe: SafeModeDesign,
    mode_budget: int,
    weights: Sequence[Any],
    max_links: int | None,
    say: Callable[[str], None] | None = None,
    tick: Callable[[int, int], None] | None = None,
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

    if say is None:
        say = lambda line: None  # noqa: E731
    added: list[tuple[Label, tuple[Label, ...]]] = []
    left = list(targets)
    while left and len(added) < budget:
        system = System(spec)
        say(f"auditing the {len(left)} attack sets no safe mode exposes, for a velocity monitor")
        chunks = audit_chunks(system, left, chunk_size=200)
        parts = []
        for c in chunks:
            parts.append(c())
            if tick is not None:
                tick(sum(map(len, parts)), len(left))
        rows = merge_chunks(system, max(len(F) for F in left), system.labels, parts, chunks[0].shared.modes).rows
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
            say(f"designing safe modes for {len(left)} attack sets with the velocity monitor at {agent}")
            more = design_safe_modes(System(spec), left, None, room, weights=weights, max_links=max_links, progress=say, tick=tick)
            first = len(safe.modes) + 1
            renamed = tuple(dataclasses.replace(m, name=f"designed-{first + i}") for i, m in enumerate(more.modes))
            spec = with_modes(spec, [m.mode_spec() for m in renamed], keep=True)
            exposed = {",".join(map(str, F2)) for m in renamed for F2 in m.exposes}
            safe = dataclasses.replace(safe, modes=safe.modes + renamed, unexposed={k: v for k, v in safe.unexposed.items() if k not in exposed})
    return spec, added, safe


def _witness_xis(system: System, rows: Sequence[Any]) -> dict[tuple[Label, ...], Any]:
    """The position part xi of each row's witness ZDA (the proven direction at the row's lambda0).

    Rows keep xi out of their witness above 100 agents, so it is computed again: for all rows
    of one lambda0 at once (:func:`glocal_verify.analysis.stealthy.zda_batch.batch_directions`), the
    per-set method for the sets the batch leaves open. Not a fresh zero set per set (an O(N^3)
    pencil analysis each, minutes for thousands of targets at N = 200).
    """
    from glocal_verify.analysis.stealthy.zda import ModalPencil
    from glocal_verify.analysis.stealthy.zda_batch import batch_directions
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
            found = ModalPencil(system, F, DEFAULT_TOLERANCE).direction(lam)[0]
            if found is not None and found[3] is Decision.ZERO and found[4] is Decision.NONZERO:
                out[F] = found[0]
    return out


def design_comments(d: NetworkDesign) -> str:
    """TOML comment lines naming every change of the design and what it achieves, and what it does not meet.

    Parameters
    ----------
    d : NetworkDesign
    """
    lines = [f"# Designed by glocal-verify design from {d.before.system!r} (audit k = {d.after.max_attackers}).", "#"]
    lines += [f"# {line}" for line in d.summary()]
    return "\n".join(lines) + "\n"
