"""The per-attacker answer: the one rule that says whether the glocal scheme detects an attacker.

Every interface (the assessment of ``verify``, every row of ``audit``, the before/after tables
of ``design``, the reports and the notebook displays) builds an :class:`AttackEvidence` from
condition statuses and calls :func:`answer_attack`. The rules (``docs/conditions.md``, "The
answer for one attacker"):

Stealthy to the control centre
    ``stealthy.zda`` (a ZDA attack) or ``stealthy.covert`` (a covert attack) holds.
Caught locally
    For every cluster the attacked actuators F meet, some local observer of that cluster has
    ``local.pencil`` (Proposition III.2 (iii), suspected set F ∩ P_i) and ``local.uio``
    holding: then every nonzero attack input through F moves some local residual, and
    Algorithm 1 raises a local alarm. A cluster whose observers all fail one of them (or that
    has none, or agents in no cluster) leaves part of F unwatched: no local alarm is
    guaranteed.
Exposed by a safe mode q (algebra)
    Theorem III.3 (i)-(iii) hold for q and the switch touches every stealthy direction at the
    attack's lambda0 (``switching.avoids-attack`` fails): the attack's part of the global
    residual is nonzero after the switch. q gives no guarantee (``exposes`` False) when one
    of (i)-(iii) fails (a touch alone proves nothing), when ``avoids-attack`` holds (the
    attacker keeps a direction the switch cannot see), when nothing is measured, or when the
    covert touch test (an over-approximation) is all there is. q is unsettled (None) only
    when a status it needs is undecided. The simulation of ``switching.detects``, when
    run, is shown next to the algebra and warned about when it disagrees; it never decides
    (one simulated initial state is not a proof, and it runs only on small networks: the
    audit could not give the same answer).
Detected
    ``direct``: not stealthy. ``Algorithm 1`` (the paper's scheme): caught locally, and some
    safe mode exposes it (the local control centre picks that mode, Algorithm 1 line 4).
    ``schedule`` (only with a ``[switching]`` schedule, which switches whatever the local
    observers see): some safe mode the schedule visits exposes it. The answer is
    ``detected`` when one route proves detection, ``undetected`` when the attack is stealthy
    and every route is decided against detection (the chain names the failed link: no
    guarantee exists for this attacker), else ``undecided``.
In the sampled deployment
    Only with a sampled ``[implementation]`` (the ``detection.*`` conditions): ``guaranteed``
    when every detector's threshold is certified (``detection.thresholds`` holds) and, for
    some safe mode, ``detection.guarantee`` holds (every admissible initial state, noise and
    disturbance raises the control centre's alarm within the horizon); ``not guaranteed``
    when the thresholds hold and that guarantee fails for every mode evaluated; else
    ``undecided``. It is a second answer, about the sampled system with noise, shown beside
    the verdict and never folded into it: sampling moves zeros, so the two systems may
    differ, and the verdict stays the statement about the paper's model.
"""

from __future__ import annotations

import dataclasses
import math
from types import MappingProxyType
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from glocal_verify import config
from glocal_verify.conditions.catalogue import THEOREM_III3_IDS as THEOREM_IDS  # the conditions of Theorem III.3 (i)-(iii), per safe mode
from glocal_verify.results import Status, jsonable
from glocal_verify.words import format_labels, format_lambda

__all__ = [
    "ANSWER_IDS",
    "ATTACK_VERDICTS",
    "DEPLOYMENT_IDS",
    "DeploymentAnswer",
    "DeploymentEvidence",
    "DeploymentMode",
    "THEOREM_IDS",
    "AttackAnswer",
    "AttackEvidence",
    "ClusterCatch",
    "LocalEvidence",
    "ModeEvidence",
    "ModeExposure",
    "Route",
    "answer_attack",
    "not_assessed",
]

#: the answers of :func:`answer_attack` (``not assessed``: no attack)
ATTACK_VERDICTS = ("detected", "undetected", "undecided", "not assessed")
#: every condition the answer reads (``switching.detects`` only to show it beside the algebra)
ANSWER_IDS = ("stealthy.zda", "stealthy.covert", "local.pencil", "local.uio", *THEOREM_IDS, "switching.avoids-attack", "switching.detects")
#: the conditions the deployment answer reads (only with a sampled ``[implementation]``)
DEPLOYMENT_IDS = ("detection.thresholds", "detection.guarantee")
_LABEL = MappingProxyType({"switching.image-kernel": "(i)", "switching.distinct-eigenvalues": "(ii)", "switching.eigenvector-differences": "(iii)"})


def _agents(F: Sequence[Any]) -> str:
    return f"agent{'s' if len(F) != 1 else ''} {format_labels(F)}"


# ------------------------------------------------------------------------------------------
# evidence


@dataclass(frozen=True, slots=True)
class LocalEvidence:
    """One local observer's Proposition III.2 verdicts for the attacked agents of its cluster.

    Attributes
    ----------
    cluster : str
    observer : label
        Its centre.
    suspected : tuple of labels
        F ∩ P_i.
    pencil, uio : Status or None
        ``local.pencil`` and ``local.uio`` with that suspected set (None: not evaluated).
    """

    cluster: str
    observer: Any
    suspected: tuple[Any, ...]
    pencil: Status | None
    uio: Status | None

    @property
    def catches(self) -> bool | None:
        """True when both hold, False when one fails (a failing pencil settles it alone), None otherwise."""
        if self.pencil is Status.HOLDS and self.uio is Status.HOLDS:
            return True
        if Status.FAILS in (self.pencil, self.uio):
            return False
        return None

    @property
    def name(self) -> str:
        """``"P1@5"``."""
        return f"{self.cluster}@{self.observer}"


@dataclass(frozen=True, slots=True)
class ModeEvidence:
    """What the conditions say about one safe mode for this attack.

    Attributes
    ----------
    mode : str
    theorem : mapping of str to Status
        Theorem III.3 (i)-(iii) by condition id (an id missing: not evaluated).
    avoids : Status or None
        ``switching.avoids-attack`` (None: not evaluated).
    touch_margin : float or None
        Its margin on ``fails`` (how strongly the switch touches the attack).
    predicted : str
        Its predicted residual (``unbounded``, ``bounded``, ...), when known.
    simulated : Status or None
        ``switching.detects`` for this mode, when it was simulated.
    simulation : str
        What the simulation saw (e.g. ``"unbounded (grows like e^(0.5 t))"``).
    """

    mode: str
    theorem: Mapping[str, Status] = field(default_factory=dict)
    avoids: Status | None = None
    touch_margin: float | None = None
    predicted: str = ""
    simulated: Status | None = None
    simulation: str = ""


@dataclass(frozen=True, slots=True)
class DeploymentMode:
    """``detection.guarantee`` for one safe mode of a sampled deployment.

    Attributes
    ----------
    mode : str
    guarantee : Status
    detected_by : str or None
        The local observer whose alarm is guaranteed first (``"P1@5"``).
    local_within : float or None
        Seconds after the attack starts by which that local alarm is guaranteed.
    detection_time : float or None
        Seconds after the attack starts by which the control centre's alarm is guaranteed.
    size, min_size : float or None
        The attack's amplitude and the smallest amplitude guaranteed to be detected.
    note : str
        Why the guarantee fails or is undecided.
    """

    mode: str
    guarantee: Status
    detected_by: str | None = None
    local_within: float | None = None
    detection_time: float | None = None
    size: float | None = None
    min_size: float | None = None
    note: str = ""


@dataclass(frozen=True, slots=True)
class DeploymentEvidence:
    """What the ``detection.*`` conditions say about the spec's attack in its sampled deployment.

    Attributes
    ----------
    thresholds : Status or None
        ``detection.thresholds`` over the detectors that have the attack to detect: the
        control centre's and the observers of the clusters the attack meets (None: not
        evaluated).
    modes : tuple of DeploymentMode
    left_out : tuple of (detector, note)
        Detectors whose threshold is not certified but that have nothing to detect (their
        cluster holds no attacked agent): the answer does not wait for them, and says so.
    """

    thresholds: Status | None
    modes: tuple[DeploymentMode, ...] = ()
    left_out: tuple[tuple[str, str], ...] = ()


@dataclass(frozen=True, slots=True)
class AttackEvidence:
    """Everything :func:`answer_attack` reads about one attacker (condition statuses only).

    Attributes
    ----------
    kind : {"zda", "covert"}
    actuators : tuple of labels
        F.
    by_cluster : tuple of (cluster or None, labels, observer centres)
        F split by cluster, with each cluster's observers (None: agents in no cluster).
    stealthy : Status or None
        ``stealthy.zda`` / ``stealthy.covert`` (None: not evaluated).
    lambda0 : complex or None
        The exponent the ZDA verdicts concern.
    lambda0_source : str
    local : tuple of LocalEvidence
        Observers of the clusters F meets.
    modes : tuple of ModeEvidence
        Every safe mode.
    schedule : tuple of str or None
        The safe modes a ``[switching]`` schedule visits (None: no schedule).
    schedule_text : str
    monitored : bool
        The control centre measures something.
    deployment : DeploymentEvidence or None
        The ``detection.*`` results (None: no sampled ``[implementation]`` or not evaluated).
    fragile_below : float or None
        The robustness tolerance of the run the evidence comes from (``verify``'s
        ``fragile_below``); None: the tunable ``fragile_below`` in force when answering.
    """

    kind: str
    actuators: tuple[Any, ...]
    by_cluster: tuple[tuple[str | None, tuple[Any, ...], tuple[Any, ...]], ...]
    stealthy: Status | None
    lambda0: complex | None = None
    lambda0_source: str = ""
    local: tuple[LocalEvidence, ...] = ()
    modes: tuple[ModeEvidence, ...] = ()
    schedule: tuple[str, ...] | None = None
    schedule_text: str = ""
    monitored: bool = True
    deployment: DeploymentEvidence | None = None
    fragile_below: float | None = None


# ------------------------------------------------------------------------------------------
# the answer


@dataclass(frozen=True, slots=True)
class ClusterCatch:
    """Does a local observer of one cluster the attack meets catch every attack input there?"""

    cluster: str | None
    suspected: tuple[Any, ...]
    caught: bool | None
    by: tuple[Any, ...]
    reason: str

    def to_json(self) -> dict[str, Any]:
        return {"cluster": self.cluster, "suspected": jsonable(list(self.suspected)), "caught": self.caught, "by": jsonable(list(self.by)), "reason": self.reason}


@dataclass(frozen=True, slots=True)
class ModeExposure:
    """Does switching to one safe mode expose the attack to the control centre? (algebra)

    Attributes
    ----------
    mode : str
    exposes : bool or None
        None: unsettled (the theorem promises nothing either way, or a result is undecided).
    reason : str
    simulated : bool or None
        ``switching.detects`` for this mode when it was simulated and decided.
    agrees : bool or None
        The simulation agrees with the algebra (None: not simulated, or one side open).
    fragile : str
        Set when the switch touches the attack only by a relative signal below the
        robustness tolerance (the exposure is exact but tiny).
    """

    mode: str
    exposes: bool | None
    reason: str
    simulated: bool | None = None
    agrees: bool | None = None
    fragile: str = ""

    def to_json(self) -> dict[str, Any]:
        return {"mode": self.mode, "exposes": self.exposes, "reason": self.reason, "simulated": self.simulated, "agrees": self.agrees, "fragile": self.fragile}


@dataclass(frozen=True, slots=True)
class Route:
    """One way the glocal scheme may detect the attacker, and what it concludes.

    Attributes
    ----------
    name : {"direct", "algorithm 1", "schedule"}
    verdict : {"detected", "undetected", "undecided"}
    chain : tuple of str
        The steps that prove the verdict, e.g. ``("stealthy (ZDA at lambda0 = 0.5)", "caught
        by P1@5", "switch to case-2 (...)", "unbounded global residual")``; for ``undetected``
        the last steps name the failed link.
    """

    name: str
    verdict: str
    chain: tuple[str, ...]

    def text(self) -> str:
        """The chain joined by arrows."""
        return " -> ".join(self.chain)

    def to_json(self) -> dict[str, Any]:
        return {"name": self.name, "verdict": self.verdict, "chain": list(self.chain)}


@dataclass(frozen=True, slots=True)
class DeploymentAnswer:
    """The answer in the sampled deployment (module docstring, "In the sampled deployment").

    Attributes
    ----------
    guaranteed : bool or None
        Detection is certified for every admissible initial state, noise and disturbance
        (False: certified not to be; None: undecided).
    mode : str or None
        The safe mode of the guarantee.
    chain : tuple of str
        The steps of the guarantee, or the failed link.
    reason : str
        One sentence.
    detection_time : float or None
        Seconds after the attack starts by which the control centre's alarm is guaranteed.
    min_size : float or None
        The smallest attack amplitude the guarantee covers.
    left_out : tuple of (detector, note)
        Detectors left out of the answer: their threshold is not certified (the note says
        why) but their cluster holds no attacked agent, so they have nothing to detect.
    """

    guaranteed: bool | None
    mode: str | None
    chain: tuple[str, ...]
    reason: str
    detection_time: float | None = None
    min_size: float | None = None
    left_out: tuple[tuple[str, str], ...] = ()

    @property
    def word(self) -> str:
        """``guaranteed``, ``not guaranteed`` or ``undecided``."""
        return {True: "guaranteed", False: "not guaranteed", None: "undecided"}[self.guaranteed]

    def to_json(self) -> dict[str, Any]:
        return {"guaranteed": self.guaranteed, "mode": self.mode, "chain": list(self.chain), "reason": self.reason, "detection_time": self.detection_time, "min_size": self.min_size,
                "left_out": [{"detector": d, "note": n} for d, n in self.left_out]}


#: the routes of an answer as a sentence names them
ROUTE_NAMES: Mapping[str, str] = MappingProxyType({"algorithm 1": "Algorithm 1", "schedule": "the [switching] schedule", "direct": "the control centre directly"})


@dataclass(frozen=True, slots=True)
class AttackAnswer:
    """The answer for one attacker (module docstring).

    Attributes
    ----------
    kind : str or None
    actuators : tuple of labels
    lambda0 : complex or None
    lambda0_source : str
    stealthy : bool or None
    caught_locally : bool or None
        Every cluster F meets has a catching observer (None: undecided).
    caught_locally_by : tuple of (cluster, observer)
        The catching observers.
    clusters : tuple of ClusterCatch
    exposed_by_modes, not_exposed_by_modes, unsettled_modes : tuple of str
    modes : tuple of ModeExposure
    routes : tuple of Route
        ``algorithm 1``, and ``schedule`` when the spec has one (``direct`` when not stealthy).
    verdict : {"detected", "undetected", "undecided", "not assessed"}
    chain : tuple of str
        The chain of the route that decides the verdict.
    reason : str
        One sentence.
    fragile : str
        Set when detection rests only on exposures of a tiny relative size.
    warnings : tuple of str
        Disagreements between the algebra and the simulation.
    deployment : DeploymentAnswer or None
        The answer in the sampled deployment (None: no sampled ``[implementation]``).
    """

    kind: str | None
    actuators: tuple[Any, ...]
    lambda0: complex | None
    lambda0_source: str
    stealthy: bool | None
    caught_locally: bool | None
    caught_locally_by: tuple[tuple[str, Any], ...]
    clusters: tuple[ClusterCatch, ...]
    exposed_by_modes: tuple[str, ...]
    not_exposed_by_modes: tuple[str, ...]
    unsettled_modes: tuple[str, ...]
    modes: tuple[ModeExposure, ...]
    routes: tuple[Route, ...]
    verdict: str
    chain: tuple[str, ...]
    reason: str
    fragile: str = ""
    warnings: tuple[str, ...] = ()
    deployment: DeploymentAnswer | None = None

    @property
    def present(self) -> bool:
        """An attack was assessed."""
        return self.verdict != "not assessed"

    def route(self, name: str) -> Route | None:
        """The route called ``name``, if any."""
        return next((r for r in self.routes if r.name == name), None)

    def verdict_words(self) -> str:
        """The verdict with the route that proves it: ``detected (Algorithm 1 and the [switching]
        schedule)``, ``detected only through the [switching] schedule (Algorithm 1: undetected)``,
        ``detected (not stealthy)``; other verdicts as they are."""
        if self.verdict != "detected":
            return self.verdict
        by = [r for r in self.routes if r.verdict == "detected"]
        if [r.name for r in by] == ["direct"]:
            return "detected (not stealthy)"
        if len(by) == len(self.routes):
            return f"detected ({' and '.join(ROUTE_NAMES.get(r.name, r.name) for r in by)})"
        rest = "; ".join(f"{ROUTE_NAMES.get(r.name, r.name)}: {r.verdict}" for r in self.routes if r.verdict != "detected")
        return f"detected only through {' and '.join(ROUTE_NAMES.get(r.name, r.name) for r in by)} ({rest})"

    def to_json(self) -> dict[str, Any]:
        """JSON form (``assessment.attack`` of the report, ``answer`` of an audit row)."""
        return {
            "present": self.present,
            "kind": self.kind,
            "actuators": jsonable(list(self.actuators)),
            "lambda0": None if self.lambda0 is None else [complex(self.lambda0).real, complex(self.lambda0).imag],
            "lambda0_source": self.lambda0_source or None,
            "stealthy": self.stealthy,
            "caught_locally": self.caught_locally,
            "caught_locally_by": [{"cluster": c, "observer": jsonable(o)} for c, o in self.caught_locally_by],
            "clusters": [c.to_json() for c in self.clusters],
            "exposed_by_modes": list(self.exposed_by_modes),
            "not_exposed_by_modes": list(self.not_exposed_by_modes),
            "unsettled_modes": list(self.unsettled_modes),
            "modes": [m.to_json() for m in self.modes],
            "routes": [r.to_json() for r in self.routes],
            "verdict": self.verdict,
            "chain": list(self.chain),
            "reason": self.reason,
            "fragile": self.fragile,
            "warnings": list(self.warnings),
            "deployment": None if self.deployment is None else self.deployment.to_json(),
        }


def not_assessed(reason: str) -> AttackAnswer:
    """The answer when there is no attack to assess."""
    return AttackAnswer(None, (), None, "", None, None, (), (), (), (), (), (), (), "not assessed", (), reason)


def _cluster_catches(ev: AttackEvidence) -> tuple[ClusterCatch, ...]:
    out = []
    for cluster, agents, observers in ev.by_cluster:
        if cluster is None:
            out.append(ClusterCatch(None, agents, False, (), f"{_agents(agents)} belong to no cluster: no local observer watches them"))
            continue
        found = {e.observer: e for e in ev.local if e.cluster == cluster}
        mine = [found.get(o, LocalEvidence(cluster, o, agents, None, None)) for o in observers]
        by = tuple(e.observer for e in mine if e.catches is True)
        if by:
            out.append(ClusterCatch(cluster, agents, True, by, f"observer {format_labels(by)} of {cluster} meets Proposition III.2 (iii) and its UIO exists for {_agents(agents)}"))
        elif not mine:
            out.append(ClusterCatch(cluster, agents, False, (), f"{cluster} has no local observer"))
        elif all(e.catches is False for e in mine):
            # the pencil decides alone when it fails (no UIO can see a hidden input then)
            why = "; ".join(f"{e.name}: {'local.pencil' if e.pencil is Status.FAILS else 'local.uio'} fails" for e in mine)
            out.append(ClusterCatch(cluster, agents, False, (), f"no observer of {cluster} catches {_agents(agents)} ({why})"))
        else:
            open_ = [e.name + (" (not evaluated)" if None in (e.pencil, e.uio) else "") for e in mine if e.catches is None]
            out.append(ClusterCatch(cluster, agents, None, (), f"local.pencil or local.uio undecided for {format_labels(open_)}"))
    return tuple(out)


def _exposure(ev: AttackEvidence, m: ModeEvidence) -> ModeExposure:
    exposes: bool | None
    if not ev.monitored:
        exposes, why = False, "nothing is measured globally, so no switch can expose anything"
    else:
        failed = [_LABEL[c] for c in THEOREM_IDS if m.theorem.get(c) is Status.FAILS]
        unknown = [_LABEL[c] for c in THEOREM_IDS if m.theorem.get(c) in (None, Status.UNDECIDED)]
        if failed:
            # the theorem is the guarantee: without it a touch proves nothing (finding 6 hides a
            # touched ZDA), so this mode gives no guarantee, whatever the touch test says
            verb = "fails" if len(failed) == 1 else "fail"
            exposes, why = False, f"no guarantee: Theorem III.3 {' '.join(failed)} {verb} for this mode"
        elif m.avoids is Status.HOLDS:
            exposes, why = False, "the attacker keeps a stealthy direction the switch does not touch (switching.avoids-attack holds): its part of the residual stays bounded and vanishing"
        elif m.avoids is None:
            exposes, why = None, "switching.avoids-attack was not evaluated"
        elif m.avoids is Status.UNDECIDED:
            exposes, why = None, "whether the switch touches the attack is undecided (switching.avoids-attack)"
        elif ev.kind == "covert":
            exposes, why = False, "no guarantee: the switch touches agents the covert attack reaches, but that test over-approximates what the attack moves"
        elif unknown:
            exposes, why = None, f"the switch touches every stealthy direction; Theorem III.3 {' '.join(unknown)} undecided or not evaluated"
        else:
            tail = f" (predicted residual: {m.predicted})" if m.predicted else ""
            exposes, why = True, f"Theorem III.3 (i)-(iii) hold and the switch touches every stealthy direction{tail}"
    sim = None if m.simulated in (None, Status.UNDECIDED) else m.simulated is Status.HOLDS
    agrees = None if sim is None or exposes is None else sim == exposes
    fragile = ""
    below = float(config.resolve("fragile_below", ev.fragile_below))
    if exposes and m.touch_margin is not None and math.isfinite(m.touch_margin) and m.touch_margin < below:
        fragile = f"{m.mode} touches the attack only by a relative signal of {m.touch_margin:.2g} (below {below:g})"
    if sim is not None:
        seen = f"; simulation: the control centre {'detects' if sim else 'does not detect'} it" + (f" ({m.simulation})" if m.simulation else "")
        if agrees is False:
            seen += " -- it disagrees with the algebra"
        why += seen
    return ModeExposure(m.mode, exposes, why, sim, agrees, fragile)


def _stealthy_step(ev: AttackEvidence, stealthy: bool | None) -> str:
    if stealthy is None:
        return "stealthy: undecided"
    what = "ZDA" if ev.kind == "zda" else "covert attack"
    lam = f" at lambda0 = {format_lambda(ev.lambda0)}" if ev.kind == "zda" and ev.lambda0 is not None else ""
    return f"stealthy ({what}{lam})"


def _residual_step(m: ModeEvidence | None) -> str:
    pred = "" if m is None else m.predicted
    return {"unbounded": "unbounded global residual", "bounded": "bounded, nonzero global residual"}.get(pred, "nonzero global residual")


def _switch_step(m: ModeExposure) -> str:
    return f"switch to {m.mode} (Theorem III.3 (i)-(iii) hold; it touches every stealthy direction)"


def _grouped(modes: Sequence[ModeExposure]) -> str:
    """``"case-1, case-3: <reason>; case-2: <reason>"`` (modes with the same reason share it)."""
    groups: dict[str, list[str]] = {}
    for m in modes:
        groups.setdefault(m.reason, []).append(m.mode)
    return "; ".join(f"{', '.join(ms)}: {why}" for why, ms in groups.items())


def _algorithm1(ev: AttackEvidence, stealthy: bool | None, caught: bool | None, clusters: Sequence[ClusterCatch], modes: Sequence[ModeExposure]) -> Route:
    head = _stealthy_step(ev, stealthy)
    exposing = [m for m in modes if m.exposes is True]
    if caught is True and exposing:
        who = ", ".join(f"{c.cluster}@{format_labels(c.by)}" for c in clusters)
        m = exposing[0]
        ev_m = next((x for x in ev.modes if x.mode == m.mode), None)
        return Route("algorithm 1", "detected", (head, f"caught by {who}", _switch_step(m), _residual_step(ev_m)))
    if stealthy is True:
        if caught is False:
            miss = next(c for c in clusters if c.caught is False)
            return Route("algorithm 1", "undetected", (head, f"no local alarm: {miss.reason}", "no switch"))
        if not modes:
            return Route("algorithm 1", "undetected", (head, "no safe mode to switch to"))
        if all(m.exposes is False for m in modes):
            return Route("algorithm 1", "undetected", (head, "no safe mode exposes it (" + _grouped(modes) + ")"))
    gaps = []
    if caught is None:
        gaps.append("local alarm undecided (" + "; ".join(f"{c.cluster}: {c.reason}" for c in clusters if c.caught is None) + ")")
    if not exposing and any(m.exposes is None for m in modes):
        gaps.append("exposure unsettled (" + _grouped([m for m in modes if m.exposes is None]) + ")")
    return Route("algorithm 1", "undecided", (head, *gaps))


def _schedule(ev: AttackEvidence, stealthy: bool | None, modes: Sequence[ModeExposure]) -> Route | None:
    if ev.schedule is None:
        return None
    head = _stealthy_step(ev, stealthy)
    sched = f"scheduled switch ({ev.schedule_text}), whatever the local observers see"
    visited = [m for m in modes if m.mode in ev.schedule]
    hit = [m for m in visited if m.exposes is True]
    if hit:
        ev_m = next((x for x in ev.modes if x.mode == hit[0].mode), None)
        return Route("schedule", "detected", (head, sched, _switch_step(hit[0]), _residual_step(ev_m)))
    if stealthy is True and all(m.exposes is False for m in visited):
        why = "it visits no safe mode" if not visited else "; ".join(f"{m.mode} does not expose it ({m.reason})" for m in visited)
        return Route("schedule", "undetected", (head, sched, why))
    gaps = [f"{m.mode}: exposure unsettled ({m.reason})" for m in visited if m.exposes is None]
    return Route("schedule", "undecided", (head, sched, *gaps))


def _seconds(t: float | None) -> str:
    return "?" if t is None else f"{t:.3g} s"


def _deployment(dep: DeploymentEvidence | None) -> DeploymentAnswer | None:
    """The rule of "In the sampled deployment" (module docstring)."""
    if dep is None:
        return None
    answer = _deployment_answer(dep)
    if not dep.left_out:
        return answer
    names = format_labels([d for d, _ in dep.left_out])
    aside = f" Left out: {names}, whose cluster holds no attacked agent (nothing to detect there), although {'its threshold is' if len(dep.left_out) == 1 else 'their thresholds are'} not certified."
    return dataclasses.replace(answer, reason=answer.reason + aside, left_out=dep.left_out)


def _deployment_answer(dep: DeploymentEvidence) -> DeploymentAnswer:
    every = "for every admissible initial state, noise and disturbance"
    if dep.thresholds is not Status.HOLDS:
        why = "not evaluated" if dep.thresholds is None else "not certified for every detector that watches the attack (detection.thresholds undecided)"
        return DeploymentAnswer(None, None, (f"thresholds {why}",), f"The detection thresholds are {why}: no guarantee can be stated.")
    head = "certified thresholds (no attack-free run raises an alarm)"
    proven = [m for m in dep.modes if m.guarantee is Status.HOLDS]
    if proven:
        m = min(proven, key=lambda x: math.inf if x.detection_time is None else x.detection_time)
        alarm = f"the control centre's alarm within {_seconds(m.detection_time)} of the attack's start"
        if m.detected_by:
            chain: tuple[str, ...] = (head, f"local alarm by {m.detected_by} within {_seconds(m.local_within)}", f"switch to {m.mode}", alarm)
        else:  # the control centre's own alarm comes before any switch
            chain = (head, alarm + ", before any switch")
        size = "" if m.min_size is None else f"; the smallest amplitude guaranteed is {m.min_size:.3g}" + ("" if m.size is None else f" (this attack: {m.size:.3g})")
        return DeploymentAnswer(True, m.mode, chain, f"Guaranteed {every}: {' -> '.join(chain)}{size}.", m.detection_time, m.min_size)
    if dep.modes and all(m.guarantee is Status.FAILS for m in dep.modes):
        why = "; ".join(f"{m.mode}: {m.note or 'detection.guarantee fails'}" for m in dep.modes)
        sizes = [m.min_size for m in dep.modes if m.min_size is not None and math.isfinite(m.min_size)]
        hint = f" (an amplitude of at least {min(sizes):.3g} would be)" if sizes else ""
        return DeploymentAnswer(False, None, (head, f"no mode's guarantee holds ({why})"), f"Not guaranteed {every}{hint}: {why}.", None, min(sizes) if sizes else None)
    open_ = [m.mode for m in dep.modes if m.guarantee is Status.UNDECIDED]
    why = f"detection.guarantee undecided for {format_labels(open_)}" if open_ else "detection.guarantee was not evaluated"
    return DeploymentAnswer(None, None, (head, why), f"Whether detection is guaranteed {every} is undecided: {why}.")


def answer_attack(ev: AttackEvidence) -> AttackAnswer:
    """The answer for one attacker (the rules of the module docstring).

    Parameters
    ----------
    ev : AttackEvidence

    Returns
    -------
    AttackAnswer
    """
    stealthy = None if ev.stealthy in (None, Status.UNDECIDED) else ev.stealthy is Status.HOLDS
    clusters = _cluster_catches(ev)
    if not clusters:
        caught: bool | None = False
    elif all(c.caught is True for c in clusters):
        caught = True
    elif any(c.caught is False for c in clusters):
        caught = False
    else:
        caught = None
    caught_by = tuple((c.cluster, o) for c in clusters if c.cluster is not None for o in c.by)
    modes = tuple(_exposure(ev, m) for m in ev.modes)
    exposed = tuple(m.mode for m in modes if m.exposes is True)
    not_exposed = tuple(m.mode for m in modes if m.exposes is False)
    unsettled = tuple(m.mode for m in modes if m.exposes is None)
    warnings = tuple(f"{m.mode}: the simulation of switching.detects ({'detects' if m.simulated else 'does not detect'}) disagrees with the algebra ({'exposes' if m.exposes else 'does not expose'}); the answer follows the algebra" for m in modes if m.agrees is False)
    what = f"The {'ZDA' if ev.kind == 'zda' else 'covert attack'} on {_agents(ev.actuators)}"
    if stealthy is False:
        direct = Route("direct", "detected", (f"not stealthy ({'stealthy.zda' if ev.kind == 'zda' else 'stealthy.covert'} fails): every attack through {_agents(ev.actuators)} shows in the global residual",))
        return AttackAnswer(ev.kind, ev.actuators, ev.lambda0, ev.lambda0_source, False, caught, caught_by, clusters, exposed, not_exposed, unsettled, modes,
                            (direct,), "detected", direct.chain, f"{what} is not stealthy: the control centre sees it before any switch.", warnings=warnings,
                            deployment=_deployment(ev.deployment))
    routes = [_algorithm1(ev, stealthy, caught, clusters, modes)]
    if (sr := _schedule(ev, stealthy, modes)) is not None:
        routes.append(sr)
    verdicts = [r.verdict for r in routes]
    if "detected" in verdicts:
        verdict = "detected"
    elif stealthy is True and all(v == "undetected" for v in verdicts):
        verdict = "undetected"
    else:
        verdict = "undecided"
    decider = next((r for r in routes if r.verdict == verdict), routes[0])
    others = [r for r in routes if r is not decider]
    tail = "".join(f"; {r.name}: {r.verdict}" for r in others)
    reason = f"{what} is {verdict} ({decider.name}: {decider.text()}{tail})."
    fragile = ""
    if verdict == "detected":
        used = [m for m in modes if m.exposes is True and (decider.name != "schedule" or ev.schedule is None or m.mode in ev.schedule)]
        if used and all(m.fragile for m in used):
            fragile = "detected only by exposure, and every exposing switch is fragile: " + "; ".join(m.fragile for m in used)
    return AttackAnswer(ev.kind, ev.actuators, ev.lambda0, ev.lambda0_source, stealthy, caught, caught_by, clusters, exposed, not_exposed, unsettled, modes,
                        tuple(routes), verdict, decider.chain, reason, fragile, warnings, _deployment(ev.deployment))
