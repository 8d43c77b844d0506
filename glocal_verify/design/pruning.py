"""Every change of a design earns its place: each is kept only if the audit shows it moves an attack set.

A design is a set of atomic edits of a base spec (:class:`Blueprint`): a velocity monitor, a
local observer, one link of a designed safe mode, the ``[switching]`` schedule, a weight of
the normal graph. :func:`prune` removes them one at a time and audits what is left on the
sets the design can move (those the base spec leaves undetected or undecided): an edit whose
removal makes no such set worse is dropped for good; the others are kept, each with the sets
that fall back without it (an edit another edit needs, such as the monitor a mode's
Theorem III.3 (i) asks for, falls back with it). Verdicts order as undetected < undecided <
detected, each row the one answer ``verify`` gives (:func:`glocal_verify.design.audit.audit`).

The order of removal is observers, monitors, links (the last one first), the schedule, the
weights: what the paper's scheme needs least is tried first.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from types import MappingProxyType

from glocal_verify.design.audit import AuditRow, audit_chunks, merge_chunks
from glocal_verify.model import System
from glocal_verify.spec.types import NORMAL_MODE, EdgeSpec, Label, ModeSpec, MonitorSpec, ObserverSpec, SwitchingSpec, SwitchStep, SystemSpec

__all__ = ["Blueprint", "Edit", "RANK", "audit_sets", "fitted_schedule", "prune", "worse"]

#: how good a verdict is for the defender
RANK: Mapping[str, int] = MappingProxyType({"undetected": 0, "undecided": 1, "detected": 2})

Sets = tuple[tuple[Label, ...], ...]


@dataclass(frozen=True)
class Edit:
    """One atomic change of a design.

    Attributes
    ----------
    kind : {"observer", "monitor", "link", "schedule", "weight"}
    key : tuple
        ``(label,)`` of a monitor, ``(cluster, centre)`` of an observer, ``(mode, k)`` of the
        k-th link of a designed mode, ``()`` of the schedule, ``(u, v)`` of a normal weight.
    """

    kind: str
    key: tuple[object, ...] = ()


_ORDER: Mapping[str, int] = MappingProxyType({"observer": 0, "monitor": 1, "link": 2, "schedule": 3, "weight": 4})


@dataclass(frozen=True)
class Blueprint:
    """A base spec and the pieces its edits add.

    Attributes
    ----------
    base : SystemSpec
        The spec every edit is applied to (positions already moved to velocities).
    monitors : tuple of labels
        Velocity monitors the design may add.
    observers : mapping
        ``(cluster, centre)`` -> the observer the design puts there (replacing one at that centre).
    modes : mapping
        Designed mode name -> its link changes, each ``(u, v, weight, remove, was)``.
    descriptions : mapping
        Designed mode name -> its description.
    schedule : bool
        The design runs a ``[switching]`` schedule through its modes.
    weights : mapping
        ``(u, v)`` -> new weight of a link of the normal graph.
    dwell : float, optional
        Largest stay in a mode of the schedule (:func:`fitted_schedule`).
    """

    base: SystemSpec
    monitors: tuple[Label, ...] = ()
    observers: Mapping[tuple[str, Label], ObserverSpec] = field(default_factory=dict)
    modes: Mapping[str, tuple[tuple[Label, Label, Fraction, bool, Fraction | None], ...]] = field(default_factory=dict)
    descriptions: Mapping[str, str] = field(default_factory=dict)
    schedule: bool = False
    weights: Mapping[tuple[Label, Label], Fraction] = field(default_factory=dict)
    dwell: float | None = None

    def edits(self) -> tuple[Edit, ...]:
        """Every edit, in the order :func:`prune` tries to remove them."""
        out = [Edit("observer", k) for k in self.observers]
        out += [Edit("monitor", (a,)) for a in self.monitors]
        out += [Edit("link", (m, k)) for m, links in self.modes.items() for k in reversed(range(len(links)))]
        out += [Edit("schedule")] if self.schedule else []
        out += [Edit("weight", k) for k in self.weights]
        return tuple(sorted(out, key=lambda e: _ORDER[e.kind]))

    def build(self, edits: Iterable[Edit]) -> SystemSpec:
        """The base spec with ``edits`` applied (a mode none of whose links is kept is left out)."""
        on = set(edits)
        spec = self.base
        weights = {k: w for k, w in self.weights.items() if Edit("weight", k) in on}
        if weights:
            new = []
            for e in spec.edges:
                w = next((x for (u, v), x in weights.items() if frozenset((u, v)) == e.key), None)
                new.append(e if w is None else dataclasses.replace(e, weight=w))
            spec = dataclasses.replace(spec, edges=tuple(new))
        mons = [a for a in self.monitors if Edit("monitor", (a,)) in on]
        if mons:
            order = {a: k for k, a in enumerate(spec.nodes)}
            vel = sorted(set(spec.monitor.velocities) | set(mons), key=order.__getitem__)
            spec = dataclasses.replace(spec, monitor=MonitorSpec(spec.monitor.positions, tuple(vel)))
        obs = {k: o for k, o in self.observers.items() if Edit("observer", k) in on}
        if obs:
            clusters = []
            for c in spec.clusters:
                mine = [o for (name, _), o in obs.items() if name == c.name]
                keep = tuple(o for o in c.observers if all(o.center != m.center for m in mine))
                clusters.append(dataclasses.replace(c, observers=keep + tuple(mine)) if mine else c)
            spec = dataclasses.replace(spec, clusters=tuple(clusters))
        edges = {e.key: e.weight for e in spec.edges}
        modes = list(spec.modes)
        for name, links in self.modes.items():
            kept = [lk for k, lk in enumerate(links) if Edit("link", (name, k)) in on]
            if not kept:
                continue
            add = tuple(EdgeSpec(u, v, w if was is None else edges.get(frozenset((u, v)), was) + (w - was)) for u, v, w, rem, was in kept if not rem)
            remove = tuple((u, v) for u, v, w, rem, was in kept if rem or was is not None)
            modes.append(ModeSpec(name, add, remove, self.descriptions.get(name, "")))
        spec = dataclasses.replace(spec, modes=tuple(modes))
        if Edit("schedule") in on:
            spec = fitted_schedule(spec, [m.name for m in modes if m.name in self.modes], self.dwell)
        return spec


def fitted_schedule(spec: SystemSpec, wanted: Sequence[str], dwell: float | None = None) -> SystemSpec:
    """``spec`` with a ``[switching]`` schedule that visits ``wanted`` after its own visits, within the horizon.

    The spec's own sequence (or scheduled switch) is kept first; the new visits share what is
    left of the horizon equally with the normal mode's first stay (each at most ``dwell``,
    default the horizon over the number of stays). When the spec's own visits leave no time,
    the horizon is extended by one stay per new visit and the spec's description says so.
    """
    sim = spec.simulation
    horizon = float(sim.horizon)
    old = spec.switching
    steps: list[SwitchStep] = []
    if old is not None and old.sequence:
        steps = list(old.sequence)
    elif old is not None and old.mode is not None:
        steps = [SwitchStep(NORMAL_MODE, float(old.time or 0.0)), SwitchStep(old.mode, 0.0)]
    visited = {st.mode for st in steps}
    new = [q for q in wanted if q not in visited]
    if not new:
        return spec
    used = sum(float(st.duration) for st in steps)
    stays = len(new) + (0 if steps else 1)
    free = horizon - used
    each = free / (stays + (1 if steps and steps[-1].duration == 0.0 else 0)) if free > 0 else 0.0
    if dwell is not None:
        each = min(each, dwell) if each > 0 else dwell
    note = ""
    if each <= 0.0:
        each = dwell if dwell is not None else horizon / max(stays, 1)
        note = f"; horizon extended from {horizon:g} s so that the designed schedule fits"
    if steps and steps[-1].duration == 0.0:
        steps[-1] = SwitchStep(steps[-1].mode, each)
    if not steps:
        steps = [SwitchStep(NORMAL_MODE, each)]
    steps += [SwitchStep(q, each) for q in new]
    total = sum(float(st.duration) for st in steps)
    out = dataclasses.replace(spec, switching=SwitchingSpec(sequence=tuple(steps)))
    if total > horizon + 1e-9:
        out = dataclasses.replace(out, simulation=dataclasses.replace(sim, horizon=total), description=(spec.description or "") + note)
    return out


def audit_sets(spec: SystemSpec, sets: Sequence[tuple[Label, ...]], tick: Callable[[int, int], None] | None = None) -> dict[tuple[Label, ...], AuditRow]:
    """The audit's row of each set in ``sets`` on ``spec`` (the one answer ``verify`` gives), by set."""
    if not sets:
        return {}
    system = System(spec)
    chunks = audit_chunks(system, list(sets), chunk_size=200)
    parts = []
    for c in chunks:
        parts.append(c())
        if tick is not None:
            tick(sum(map(len, parts)), len(sets))
    res = merge_chunks(system, max(len(F) for F in sets), system.labels, parts, chunks[0].shared.modes)
    return {r.actuators: r for r in res.rows}


def worse(base: Mapping[tuple[Label, ...], AuditRow], other: Mapping[tuple[Label, ...], AuditRow]) -> Sets:
    """The sets whose verdict in ``other`` is worse than in ``base``."""
    return tuple(F for F, r in base.items() if F in other and RANK[other[F].verdict] < RANK[r.verdict])


def _affected(e: Edit, rows: Mapping[tuple[Label, ...], AuditRow]) -> Sets:
    """The sets whose verdict removing ``e`` can make worse, read from their rows with every edit.

    Only a detected or undecided set can get worse. A mode's link concerns the sets that mode
    exposes; an observer, those it catches; the schedule, those no observer catches (the
    schedule's route needs no local alarm); a monitor or a weight, any of them.
    """
    live = [(F, r) for F, r in rows.items() if r.verdict != "undetected"]
    if e.kind == "link":
        return tuple(F for F, r in live if e.key[0] in r.exposed_by_modes)
    if e.kind == "observer":
        tag = f"{e.key[0]}@{e.key[1]}"
        return tuple(F for F, r in live if tag in r.caught_locally_by)
    if e.kind == "schedule":
        return tuple(F for F, r in live if r.exposed_by_modes and _alarm(r) is not True)
    return tuple(F for F, _ in live)


def _certain(e: Edit, rows: Mapping[tuple[Label, ...], AuditRow], affected: Sets) -> Sets:
    """The affected sets that fall back for certain without ``e`` (no audit needed), by the routes of the answer.

    A stealthy set is detected only through a safe mode that exposes it: by Algorithm 1 (a
    local alarm, then any exposing mode) or by the schedule (an exposing mode it visits).
    Without mode q (or with q failing Theorem III.3), a detected set that only q exposes has
    no route left; without the schedule, a detected set no observer catches has none. Their
    ZDA verdicts do not change (the monitors are the same). Without a monitor, a stealthy set
    stays stealthy (a kernel vector of the pencil with more output rows is one with fewer), so
    one that only modes failing Theorem III.3 without it expose falls back too (in :func:`prune`).
    """
    if e.kind == "link":
        return tuple(F for F in affected if rows[F].verdict == "detected" and tuple(rows[F].exposed_by_modes) == (e.key[0],))
    if e.kind == "schedule":
        return tuple(F for F in affected if rows[F].verdict == "detected" and rows[F].stealthy is True and _alarm(rows[F]) is not True)
    return ()


def _alarm(row: AuditRow) -> bool | None:
    """Whether a local alarm is guaranteed for the row's set (None: undecided or not known)."""
    return None if row.answer is None else row.answer.caught_locally


def prune(
    blueprint: Blueprint,
    sets: Sequence[tuple[Label, ...]],
    *,
    known: Mapping[tuple[Label, ...], AuditRow] | None = None,
    say: Callable[[str], None] | None = None,
    tick: Callable[[int, int], None] | None = None,
) -> tuple[frozenset[Edit], dict[Edit, Sets], dict[tuple[Label, ...], AuditRow]]:
    """Remove every edit the audit of ``sets`` does not need (module docstring).

    Removing an edit is audited only on the sets it can make worse (:func:`_affected`), and
    not on those that fall back for certain (:func:`_certain`). A link whose removal makes its
    mode fail Theorem III.3 (by the rule functions) leaves the mode no guarantee, as if the
    whole mode were gone: one audit without the mode serves every such link of it.

    Parameters
    ----------
    blueprint : Blueprint
    sets : sequence of attack sets
        The sets the design can move (those the base spec does not detect).
    known : mapping, optional
        The rows of ``sets`` with every edit, when the caller has them.
    say, tick : callable, optional
        Progress: one line per edit tried, and the audit's (sets done, total).

    Returns
    -------
    (kept edits, sets each kept edit moves, the rows of ``sets`` with every kept edit)
    """
    from glocal_verify.design.symmetry import theorem_verdicts
    from glocal_verify.results import Status

    edits = blueprint.edits()
    current = frozenset(edits)
    rows = dict(known) if known is not None else audit_sets(blueprint.build(current), sets, tick)
    no_mode: dict[tuple[str, frozenset[Edit]], Sets] = {}

    def lost_without(e: Edit) -> tuple[Sets, dict[tuple[Label, ...], AuditRow]]:
        affected = _affected(e, rows)
        if not affected:
            return (), {}
        spec = blueprint.build(current - {e})
        if e.kind == "link":
            q = str(e.key[0])
            T = System(spec)
            if q not in T.safe_modes or any(st is not Status.HOLDS for k, st in theorem_verdicts(T, q).items() if k != "pair"):
                key = (q, current)
                if key not in no_mode:
                    others = frozenset(x for x in current if not (x.kind == "link" and x.key[0] == q))
                    sure = _certain(e, rows, affected)
                    fallen = set(sure)  # once: a set built per element made this O(|affected| |sure|), minutes at N = 200
                    rest = [F for F in affected if F not in fallen]
                    no_mode[key] = tuple(sure) + worse(rows, audit_sets(blueprint.build(others), rest, tick))
                return no_mode[key], {}
        sure = _certain(e, rows, affected)
        if e.kind == "monitor":
            # fewer monitors keep every stealthy set stealthy; a designed mode whose (i) fails without it gives no guarantee
            T = System(spec)
            failing = {q for q in blueprint.modes if q in T.safe_modes
                       and any(st is not Status.HOLDS for k, st in theorem_verdicts(T, q).items() if k != "pair")}
            sure = tuple(F for F in affected if rows[F].verdict == "detected" and rows[F].stealthy is True and rows[F].exposed_by_modes
                         and set(rows[F].exposed_by_modes) <= failing)
        fallen = set(sure)
        rest = [F for F in affected if F not in fallen]
        got = audit_sets(spec, rest, tick)
        return tuple(sure) + worse(rows, got), got

    tried: dict[Edit, tuple[frozenset[Edit], Sets]] = {}
    for k, e in enumerate(edits):
        if say is not None:
            left = sum(r.verdict != "detected" for r in rows.values())
            say(f"checking that change {k + 1} of {len(edits)} ({e.kind}) earns its place ({left} of {len(sets)} movable attack sets not detected)")
        lost, got = lost_without(e)
        if not lost:
            current = current - {e}
            rows = {**rows, **got}
            continue
        tried[e] = (current, lost)
    while True:
        moved: dict[Edit, Sets] = {}
        for e in sorted(current, key=edits.index):
            seen, lost = tried[e]
            if seen != current:  # edits were removed after this one was tried: try it again
                lost = lost_without(e)[0]
                tried[e] = (current, lost)
            if not lost:  # what needed it is gone
                current = current - {e}
                rows = audit_sets(blueprint.build(current), sets, tick)
                break
            moved[e] = lost
        else:
            return current, moved, rows
