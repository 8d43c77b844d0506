"""The bottom line of a report: the paper's two problems answered for one network.

:func:`assess` reads a :class:`~glocal_verify.results.Report` and answers, in words a
designer reads in a minute,

- **Problem 1 (privacy)**: can the control centre reconstruct the initial state ``x(t0)``
  or the consensus value ``x* = (1/N) 1^T x(t0)``? (``protected`` / ``exposed`` /
  ``undecided``, from ``privacy.initial-state`` and ``privacy.consensus-value``);
- **Problem 2 (detection)**: is the spec's attack stealthy to the control centre
  (``stealthy.zda`` / ``stealthy.covert``), which local observers catch it
  (``local.pencil`` and ``local.uio`` with the spec's suspected set), which safe modes
  expose it after the switch (Theorem III.3 (i)-(iii) and the touch test
  ``switching.avoids-attack``, or the simulated ``switching.detects`` when it was run), and
  the overall verdict (``detected`` / ``undetected`` / ``undecided``);
- **warnings** about vacuous premises (no global monitors, a disconnected graph, no attack,
  a substituted ``lambda0``) and about results the reader must not overlook.

The assessment does no new mathematics: every answer is a boolean combination of the
statuses (and witnesses) of the report's results, so it is exactly as sound as they are; an
answer is ``undecided`` when a result it needs is undecided (or was not evaluated) and no
other result settles it. The rules are documented in ``docs/conditions.md`` ("The
assessment").

``switching.detects`` is a simulation (opt-in: ``verify(system, options={"simulate": True})``)
and runs only on networks of at most :data:`DETECTS_MAX_AGENTS` agents; on the paper's
19-agent example it adds a few seconds. When its verdict for a mode disagrees with the
algebra, the assessment says so and trusts the simulation.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, Iterable, Mapping, Sequence

from glocal_verify.conditions.detects import DETECTS_MAX_AGENTS
from glocal_verify.conditions.registry import CATALOGUE
from glocal_verify.results import ConditionResult, Report, Status, jsonable

__all__ = [
    "DETECTS_MAX_AGENTS",
    "THEOREM_IDS",
    "PrivacyAnswer",
    "LocalCatch",
    "ModeExposure",
    "PremiseNote",
    "AttackAnswer",
    "Assessment",
    "assess",
    "with_assessment",
]

#: the conditions of Theorem III.3 (i)-(iii), per safe mode
THEOREM_IDS = ("switching.image-kernel", "switching.distinct-eigenvalues", "switching.eigenvector-differences")
_LABEL = MappingProxyType({"switching.image-kernel": "(i)", "switching.distinct-eigenvalues": "(ii)", "switching.eigenvector-differences": "(iii)"})

NO_ATTACK = "no attack in the spec: use `glocal-verify audit` to check every attacker"
NO_MONITORS = "no global monitors: the control centre measures nothing"


@dataclass(frozen=True, slots=True)
class PrivacyAnswer:
    """Problem 1 (i): what the control centre cannot reconstruct.

    Attributes
    ----------
    initial_state, consensus_value : {"protected", "exposed", "undecided"}
        From ``privacy.initial-state`` and ``privacy.consensus-value`` over every evaluated
        scope (each mode and the schedule): ``protected`` when all hold, ``exposed`` when one
        fails, ``undecided`` otherwise (or when not evaluated).
    hidden_dimension : int or None
        The smallest dimension of the unobservable subspace over those scopes (the margin of
        ``privacy.initial-state``): 1 means only the common position offset is hidden.
    reason : str
    """

    initial_state: str
    consensus_value: str
    hidden_dimension: int | None
    reason: str

    def to_json(self) -> dict[str, Any]:
        """JSON form (``assessment.privacy`` of the report schema)."""
        return {"initial_state": self.initial_state, "consensus_value": self.consensus_value, "hidden_dimension": self.hidden_dimension, "reason": self.reason}


@dataclass(frozen=True, slots=True)
class LocalCatch:
    """A local observer whose residual sees the attack (Proposition III.2 (iii) and the UIO)."""

    cluster: str
    observer: Any

    def to_json(self) -> dict[str, Any]:
        """JSON form: ``{"cluster": ..., "observer": ...}``."""
        return {"cluster": self.cluster, "observer": jsonable(self.observer)}


@dataclass(frozen=True, slots=True)
class ModeExposure:
    """Does switching to one safe mode expose the attack to the control centre?

    Attributes
    ----------
    mode : str
    exposes : bool or None
        None: neither the algebra nor a simulation settles it.
    by : {"algebra", "simulation"}
        What decided ``exposes`` (the simulation wins when both speak).
    algebra : bool or None
        The algebraic answer: True when Theorem III.3 (i)-(iii) hold and the switch touches
        every stealthy direction (``switching.avoids-attack`` fails); False when the switch
        avoids the attack (``switching.avoids-attack`` holds) or nothing is measured; None
        otherwise.
    simulated : bool or None
        The decided verdict of ``switching.detects`` for this mode, if it was run.
    reason : str
    """

    mode: str
    exposes: bool | None
    by: str
    algebra: bool | None
    simulated: bool | None
    reason: str

    def to_json(self) -> dict[str, Any]:
        """JSON form (an item of ``assessment.attack.modes``)."""
        return {"mode": self.mode, "exposes": self.exposes, "by": self.by, "algebra": self.algebra, "simulated": self.simulated, "reason": self.reason}


@dataclass(frozen=True, slots=True)
class PremiseNote:
    """A premise of a condition that is absent: its results hold or fail vacuously.

    ``mode`` restricts the note to the results of one mode (None: every result of ``id``).
    """

    id: str
    mode: str | None
    note: str

    def applies(self, r: ConditionResult) -> bool:
        """Whether this note concerns result ``r``."""
        return r.id == self.id and (self.mode is None or r.scope.get("mode") == self.mode)

    def to_json(self) -> dict[str, Any]:
        """JSON form (an item of ``assessment.premises``)."""
        return {"id": self.id, "mode": self.mode, "note": self.note}


@dataclass(frozen=True, slots=True)
class AttackAnswer:
    """Problem 2: the spec's attack, and whether the glocal scheme detects it.

    Attributes
    ----------
    present : bool
        The spec has an ``[attack]`` (known from the ``stealthy.*`` results).
    kind : {"zda", "covert"} or None
        None when no result names it (no safe mode and no simulation).
    actuators : tuple
    lambda0 : tuple of float or None
        ``(re, im)`` of the exponent the ZDA verdicts concern.
    lambda0_source : str or None
        ``"spec"``, or ``"substituted: ..."`` saying which exponent replaced the spec's.
    stealthy : bool or None
        Invisible to the control centre before any switch.
    caught_locally_by : tuple of LocalCatch
        Observers (spec's suspected set) whose ``local.pencil`` and ``local.uio`` hold.
    exposed_by_modes, not_exposed_by_modes, unsettled_modes : tuple of str
    modes : tuple of ModeExposure
    simulated : bool
        ``switching.detects`` results were present.
    verdict : {"detected", "undetected", "undecided", "not assessed"}
    reason : str
        One sentence.
    """

    present: bool
    kind: str | None
    actuators: tuple[Any, ...]
    lambda0: tuple[float, float] | None
    lambda0_source: str | None
    stealthy: bool | None
    caught_locally_by: tuple[LocalCatch, ...]
    exposed_by_modes: tuple[str, ...]
    not_exposed_by_modes: tuple[str, ...]
    unsettled_modes: tuple[str, ...]
    modes: tuple[ModeExposure, ...]
    simulated: bool
    verdict: str
    reason: str

    def to_json(self) -> dict[str, Any]:
        """JSON form (``assessment.attack`` of the report schema)."""
        return {
            "present": self.present,
            "kind": self.kind,
            "actuators": jsonable(list(self.actuators)),
            "lambda0": None if self.lambda0 is None else list(self.lambda0),
            "lambda0_source": self.lambda0_source,
            "stealthy": self.stealthy,
            "caught_locally_by": [c.to_json() for c in self.caught_locally_by],
            "exposed_by_modes": list(self.exposed_by_modes),
            "not_exposed_by_modes": list(self.not_exposed_by_modes),
            "unsettled_modes": list(self.unsettled_modes),
            "modes": [m.to_json() for m in self.modes],
            "simulated": self.simulated,
            "verdict": self.verdict,
            "reason": self.reason,
        }


@dataclass(frozen=True, slots=True)
class Assessment:
    """The bottom line of a report (see the module docstring).

    Attributes
    ----------
    privacy : PrivacyAnswer
    attack : AttackAnswer
    warnings : tuple of str
        Vacuous premises and results the reader must not overlook, most important first.
    premises : tuple of PremiseNote
        Per-condition notes for the status lines of the results whose premise is absent.
    not_evaluated : mapping of str to str
        Requested condition ids without a result, and why (e.g. no ``[attack]``).
    based_on : tuple of str
        The condition ids the answers read.
    """

    privacy: PrivacyAnswer
    attack: AttackAnswer
    warnings: tuple[str, ...]
    premises: tuple[PremiseNote, ...]
    not_evaluated: Mapping[str, str]
    based_on: tuple[str, ...]

    def notes_for(self, r: ConditionResult) -> list[str]:
        """The premise notes that concern result ``r``."""
        return [p.note for p in self.premises if p.applies(r)]

    def to_json(self) -> dict[str, Any]:
        """JSON form (``assessment`` of the report schema ``glocal-verify/report@1``)."""
        return {
            "privacy": self.privacy.to_json(),
            "attack": self.attack.to_json(),
            "warnings": list(self.warnings),
            "premises": [p.to_json() for p in self.premises],
            "not_evaluated": dict(self.not_evaluated),
            "based_on": list(self.based_on),
        }


# --------------------------------------------------------------------------------------------
# helpers


def _combine(statuses: Iterable[Status]) -> Status | None:
    """All hold -> HOLDS; one fails -> FAILS; else UNDECIDED; nothing -> None."""
    st = list(statuses)
    if not st:
        return None
    if any(s is Status.FAILS for s in st):
        return Status.FAILS
    if all(s is Status.HOLDS for s in st):
        return Status.HOLDS
    return Status.UNDECIDED


def _mode_of(rs: Sequence[ConditionResult], mode: str) -> ConditionResult | None:
    for r in rs:
        if r.scope.get("mode") == mode:
            return r
    return None


def _fmt_labels(xs: Iterable[Any]) -> str:
    return ", ".join(str(x) for x in xs)


def _fmt_lambda(lam: tuple[float, float]) -> str:
    re_, im_ = lam
    if im_ == 0.0:
        return f"{re_:g}"
    return f"{re_:g} {'+' if im_ > 0 else '-'} {abs(im_):g}i"


def _fmt_spec_lambda(text: str) -> str:
    """``"(0.5+0j)"`` -> ``"0.5"`` (the analysis notes print Python complex numbers)."""
    try:
        c = complex(text.replace(" ", ""))
    except ValueError:
        return text
    return _fmt_lambda((c.real, c.imag))


def _as_pair(x: Any) -> tuple[float, float] | None:
    if isinstance(x, (list, tuple)) and len(x) == 2:
        return (float(x[0]), float(x[1]))
    if isinstance(x, (int, float)):
        return (float(x), 0.0)
    return None


def _requested(report: Report) -> list[str]:
    only = report.options.get("only")
    return list(only) if isinstance(only, (list, tuple)) else list(CATALOGUE)


def _no_monitors(report: Report) -> bool:
    """C = 0, read from the results: the normal mode hides all 2N directions, or no state is observable."""
    for r in report.results("privacy.initial-state"):
        if r.scope.get("mode") == "normal" and r.status is Status.HOLDS and r.margin is not None and int(r.margin) == 2 * report.system.agents:
            return True
    for r in report.results("central.observer"):
        design = r.witness.get("design")
        if isinstance(design, Mapping) and design.get("observable_states") == 0:
            return True
    return False


# --------------------------------------------------------------------------------------------
# Problem 1


def _privacy(report: Report, no_monitors: bool, disconnected: Sequence[str]) -> PrivacyAnswer:
    word = {Status.HOLDS: "protected", Status.FAILS: "exposed", Status.UNDECIDED: "undecided", None: "undecided"}
    init = report.results("privacy.initial-state")
    cons = report.results("privacy.consensus-value")
    s_init, s_cons = _combine(r.status for r in init), _combine(r.status for r in cons)
    dims = [int(r.margin) for r in init if r.status is Status.HOLDS and r.margin is not None]
    hidden = min(dims) if dims and s_init is Status.HOLDS else None
    parts: list[str] = []
    if no_monitors:
        parts.append("vacuously: the control centre measures nothing, so it learns nothing")
    elif s_init is None and s_cons is None:
        parts.append("privacy.initial-state and privacy.consensus-value were not evaluated")
    else:
        if s_init is Status.HOLDS:
            scopes = len(init)
            if hidden == 1:
                parts.append(
                    f"x(t0) cannot be reconstructed in any of the {scopes} evaluated scopes, but only one direction "
                    "(the common position offset) stays hidden: velocities and relative positions are revealed"
                )
            else:
                parts.append(f"x(t0) cannot be reconstructed: at least {hidden} state directions stay hidden in each of the {scopes} evaluated scopes")
        elif s_init is Status.FAILS:
            where = [str(r.scope.get("mode", "schedule")) for r in init if r.status is Status.FAILS]
            parts.append(f"x(t0) is reconstructable from the global measurements (privacy.initial-state fails in: {', '.join(where)})")
        else:
            parts.append("whether x(t0) can be reconstructed is undecided (some privacy.initial-state result is undecided)")
        if s_cons is Status.HOLDS:
            parts.append("x* is not revealed")
        elif s_cons is Status.FAILS:
            where = [str(r.scope.get("mode", "schedule")) for r in cons if r.status is Status.FAILS]
            parts.append(f"x* is revealed (privacy.consensus-value fails in: {', '.join(where)})")
        elif s_cons is Status.UNDECIDED:
            parts.append("whether x* is revealed is undecided")
        else:
            parts.append("privacy.consensus-value was not evaluated")
    if disconnected:
        parts.append(f"the graph is disconnected in {', '.join(disconnected)}, so there is no single consensus value")
    text = "; ".join(parts) + "."
    if not text.startswith("x"):  # x(t0) and x* keep their case
        text = text[0].upper() + text[1:]
    return PrivacyAnswer(word[s_init], word[s_cons], hidden, text)


# --------------------------------------------------------------------------------------------
# Problem 2


def _kind(report: Report) -> str | None:
    for r in report.results("switching.avoids-attack"):
        k = r.witness.get("attack_kind")
        if isinstance(k, str):
            return k
    for r in report.results("switching.detects"):
        a = r.witness.get("attack")
        if isinstance(a, Mapping) and isinstance(a.get("kind"), str):
            return str(a["kind"])
    return None


def _lambda0(report: Report, kind: str | None) -> tuple[tuple[float, float] | None, str | None, str | None]:
    """(lambda0, source, warning) of the ZDA verdicts, from ``stealthy.zda``'s direction."""
    if kind == "covert":
        return None, None, None
    for r in report.results("stealthy.zda"):
        d = r.witness.get("direction")
        notes = [str(n) for n in r.witness.get("notes", []) or []]
        asked = [n for n in notes if n.startswith("no stealthy ZDA at the requested lambda0")]
        if not isinstance(d, Mapping):
            if asked:
                return None, "spec", f"{asked[0]}, and none other is available"
            return None, None, None
        lam = _as_pair(d.get("lambda0"))
        src = str(d.get("source", ""))
        if src == "requested lambda0":
            return lam, "spec", None
        if asked:
            spec_lam = _fmt_spec_lambda(asked[0].split("=", 1)[-1].strip())
            text = f"substituted: the spec's lambda0 = {spec_lam} admits no stealthy ZDA; the {src} is used"
            warn = f"the spec's lambda0 = {spec_lam} admits no stealthy ZDA: the attack verdicts use lambda0 = {_fmt_lambda(lam) if lam else '?'} ({src})"
            return lam, text, warn
        return lam, f"substituted: the spec gives no lambda0; the {src} is used", None
    for r in report.results("switching.avoids-attack"):
        lam = _as_pair(r.witness.get("lambda0"))
        if lam is not None:
            return lam, "substituted: see switching.avoids-attack (lambda0_rule)", None
    return None, None, None


def _stealthy(report: Report, kind: str | None) -> Status | None:
    zda = _combine(r.status for r in report.results("stealthy.zda"))
    cov = _combine(r.status for r in report.results("stealthy.covert"))
    if kind == "zda":
        return zda
    if kind == "covert":
        return cov
    known = [s for s in (zda, cov) if s is not None]
    if any(s is Status.HOLDS for s in known):
        return Status.HOLDS
    if known and all(s is Status.FAILS for s in known):
        return Status.FAILS
    return Status.UNDECIDED if known else None


def _local(report: Report) -> tuple[list[LocalCatch], list[LocalCatch], bool]:
    """(caught, undecided, watched): observers of the spec's suspected set that see the attack."""
    uio = {(r.scope.get("cluster"), repr(r.scope.get("observer"))): r for r in report.results("local.uio") if r.scope.get("suspected") == "attack"}
    caught: list[LocalCatch] = []
    open_: list[LocalCatch] = []
    watched = False
    for p in report.results("local.pencil"):
        if p.scope.get("suspected") != "attack" or not p.witness.get("suspected_agents"):
            continue
        watched = True
        u = uio.get((p.scope.get("cluster"), repr(p.scope.get("observer"))))
        st = _combine([p.status] + ([u.status] if u is not None else [Status.UNDECIDED]))
        who = LocalCatch(str(p.scope.get("cluster")), p.scope.get("observer"))
        if st is Status.HOLDS:
            caught.append(who)
        elif st is Status.UNDECIDED:
            open_.append(who)
    return caught, open_, watched


def _algebra(report: Report, mode: str, no_monitors: bool) -> tuple[bool | None, str]:
    if no_monitors:
        return False, "nothing is measured globally, so no switch can expose anything"
    touch = _mode_of(report.results("switching.avoids-attack"), mode)
    thm = {cid: _mode_of(report.results(cid), mode) for cid in THEOREM_IDS}
    if touch is None:
        return None, "switching.avoids-attack was not evaluated"
    predicted = touch.witness.get("predicted_residual")
    if touch.status is Status.HOLDS:
        stays = {"bounded-vanishing": "bounded and vanishing", "bounded": "bounded"}.get(str(predicted), "unaffected by the attack")
        return False, f"the switch avoids a stealthy direction (switching.avoids-attack holds): the attack's part of the residual stays {stays}"
    if touch.status is Status.UNDECIDED:
        return None, "whether the switch touches the attack is undecided"
    failed = [_LABEL[c] for c, r in thm.items() if r is not None and r.status is Status.FAILS]
    unknown = [_LABEL[c] for c, r in thm.items() if r is None or r.status is Status.UNDECIDED]
    if failed:
        verb = "fails" if len(failed) == 1 else "fail"
        return None, f"the switch touches the attack but Theorem III.3 {', '.join(failed)} {verb}: no guarantee either way"
    if unknown:
        return None, f"the switch touches the attack; Theorem III.3 {', '.join(unknown)} undecided or not evaluated"
    tail = f" (predicted residual: {predicted})" if predicted and predicted != "unbounded" else ""
    return True, f"Theorem III.3 (i)-(iii) hold and the switch touches every stealthy direction{tail}"


def _modes(report: Report, safe: Sequence[str], no_monitors: bool, warnings: list[str]) -> tuple[list[ModeExposure], bool]:
    detects = report.results("switching.detects")
    out = []
    for q in safe:
        alg, why = _algebra(report, q, no_monitors)
        sim_r = _mode_of(detects, q)
        sim = None if sim_r is None or sim_r.status is Status.UNDECIDED else sim_r.status is Status.HOLDS
        if sim is None:
            extra = ""
            if sim_r is not None:
                extra = f"; switching.detects undecided ({sim_r.witness.get('note') or sim_r.note or 'see its witness'})"
            out.append(ModeExposure(q, alg, "algebra", alg, None, why + extra))
            continue
        summary = ""
        post = sim_r.witness.get("post_switch") if sim_r is not None else None
        if isinstance(post, Mapping) and post.get("summary"):
            summary = f": the residual after the switch is {post['summary']}"
        text = f"simulation: the control centre {'detects' if sim else 'does not detect'} the attack{summary}"
        if alg is not None and alg != sim:
            text += f" -- the algebra said otherwise ({why}); the simulation is trusted"
            warnings.append(f"{q}: the algebra ({'exposes' if alg else 'does not expose'}) and the simulation of switching.detects disagree; the simulation is trusted")
        out.append(ModeExposure(q, sim, "simulation", alg, sim, text))
    return out, bool(detects)


def _attack(report: Report, no_monitors: bool, warnings: list[str], not_evaluated: dict[str, str]) -> AttackAnswer:
    requested = _requested(report)
    zda_rs, cov_rs = report.results("stealthy.zda"), report.results("stealthy.covert")
    present = bool(zda_rs or cov_rs)
    safe = [m for m in report.system.modes if m != "normal"]
    if not present:
        if "stealthy.zda" in requested or "stealthy.covert" in requested:
            warnings.append(NO_ATTACK)
            for cid in ("stealthy.zda", "stealthy.covert", "switching.avoids-attack", "switching.detects"):
                if cid in requested:
                    not_evaluated[cid] = "no [attack] in the spec"
            reason = NO_ATTACK
        else:
            reason = "stealthy.zda and stealthy.covert were not evaluated (--only)"
        return AttackAnswer(False, None, (), None, None, None, (), (), (), (), (), False, "not assessed", reason)
    kind = _kind(report)
    actuators: tuple[Any, ...] = ()
    for r in zda_rs + cov_rs:
        if r.witness.get("actuators"):
            actuators = tuple(r.witness["actuators"])
            break
    lam, lam_src, lam_warn = _lambda0(report, kind)
    if lam_warn:
        warnings.append(lam_warn)
    stealth = _stealthy(report, kind)
    caught, open_, watched = _local(report)
    modes, simulated = _modes(report, safe, no_monitors, warnings)
    exposed = tuple(m.mode for m in modes if m.exposes is True)
    not_exposed = tuple(m.mode for m in modes if m.exposes is False)
    unsettled = tuple(m.mode for m in modes if m.exposes is None)
    if unsettled and not simulated:
        warnings.append(
            f"exposure by {', '.join(unsettled)} is not settled by the algebra; simulate it: "
            "`glocal-verify simulate --cases` or verify(..., options={'simulate': True})"
        )
    what = f"The {'ZDA' if kind == 'zda' else 'covert attack' if kind == 'covert' else 'attack'} on agents {_fmt_labels(actuators)}"
    who = "; ".join(f"observer {c.observer} ({c.cluster})" for c in caught)
    if stealth is Status.FAILS:
        verdict, reason = "detected", f"{what} is not stealthy: the control centre sees it before any switch."
    elif caught and exposed:
        verdict = "detected"
        reason = f"{what} is {'stealthy' if stealth is Status.HOLDS else 'possibly stealthy'} to the control centre, caught locally by {who}, and switching to {', '.join(exposed)} exposes it."
    elif stealth is Status.HOLDS and not caught and not open_:
        verdict = "undetected"
        why = "no local observer watches the attacked agents" if not watched else "no local observer's residual sees it (local.pencil or local.uio fails)"
        reason = f"{what} is stealthy to the control centre and {why}."
    elif stealth is Status.HOLDS and not exposed and not unsettled:
        verdict = "undetected"
        reason = f"{what} is stealthy to the control centre" + (f", caught locally by {who}," if caught else "") + " but no safe mode exposes it" + (" (there is no safe mode)." if not safe else ".")
    else:
        verdict = "undecided"
        known, gaps = [], []
        if stealth is Status.HOLDS:
            known.append("is stealthy to the control centre")
        else:
            gaps.append("stealth is undecided")
        if caught:
            known.append(f"is caught locally by {who}")
        elif open_:
            gaps.append("local detection is undecided")
        if unsettled and not exposed:
            gaps.append(f"whether switching to {', '.join(unsettled)} exposes it is not settled")
        head = f"{what} {' and '.join(known)}" if known else what
        reason = f"{head}, but " + ("; ".join(gaps) or "a result it needs is undecided or was not evaluated") + "."
    return AttackAnswer(True, kind, actuators, lam, lam_src, None if stealth in (None, Status.UNDECIDED) else stealth is Status.HOLDS,
                        tuple(caught), exposed, not_exposed, unsettled, tuple(modes), simulated, verdict, reason)


# --------------------------------------------------------------------------------------------
# premises and the entry point


def _premises(report: Report, no_monitors: bool, disconnected: Mapping[str, Any]) -> list[PremiseNote]:
    out: list[PremiseNote] = []
    if no_monitors:
        vac = "vacuous: no global monitors, the control centre measures nothing"
        for cid in ("privacy.kernel", "privacy.unobservable", "privacy.initial-state", "privacy.consensus-value", "central.observer", "stealthy.zda", "stealthy.covert", "switched-observability"):
            out.append(PremiseNote(cid, None, vac))
    for mode, comps in disconnected.items():
        note = f"premise of Lemma III.1 absent: the {mode} graph is disconnected ({comps}); each component converges to its own average"
        for cid in ("privacy.unobservable", "privacy.initial-state", "privacy.consensus-value"):
            out.append(PremiseNote(cid, mode, note))
    return out


def assess(report: Report) -> Assessment:
    """The bottom line of ``report``: Problem 1 (privacy), Problem 2 (detection), warnings.

    Derived from the report's condition results only (no new computation); the rules are
    in the module docstring and in ``docs/conditions.md`` ("The assessment"). In short:

    - privacy of ``x(t0)`` / ``x*``: ``protected`` iff ``privacy.initial-state`` /
      ``privacy.consensus-value`` holds in every evaluated scope, ``exposed`` iff one fails;
    - stealthy: ``stealthy.zda`` (or ``stealthy.covert``) for the spec's attack kind;
    - caught locally by: observers whose ``local.pencil`` and ``local.uio`` hold for the
      spec's suspected set (``suspected = attack``, a non-empty set of attacked agents);
    - mode q exposes the attack: the simulated ``switching.detects`` when decided, else the
      algebra (Theorem III.3 (i)-(iii) hold and ``switching.avoids-attack`` fails: yes; the
      latter holds: no; otherwise unsettled);
    - verdict: ``detected`` iff not stealthy, or caught locally and exposed by some mode;
      ``undetected`` iff stealthy and (no observer catches it, or every mode is settled and
      none exposes it); else ``undecided``.

    Parameters
    ----------
    report : Report

    Returns
    -------
    Assessment
    """
    warnings: list[str] = []
    not_evaluated: dict[str, str] = {}
    no_monitors = _no_monitors(report)
    if no_monitors:
        warnings.append(NO_MONITORS + " (privacy holds vacuously, every attack is stealthy, and no switch can expose it)")
    disconnected: dict[str, Any] = {}
    for r in report.results("privacy.connected"):
        if r.status is Status.FAILS:
            comps = r.witness.get("components")
            text = "; ".join("{" + _fmt_labels(c) + "}" for c in comps) if isinstance(comps, list) else "several components"
            disconnected[str(r.scope.get("mode", "normal"))] = text
    if disconnected:
        where = ", ".join(f"{m}: {c}" for m, c in disconnected.items())
        warnings.append(f"disconnected graph ({where}): Lemma III.1's premise fails and each component converges to its own average")
    privacy = _privacy(report, no_monitors, list(disconnected))
    attack = _attack(report, no_monitors, warnings, not_evaluated)
    undecided = [r for r in report.conditions if r.status is Status.UNDECIDED and r.id != "switching.detects"]
    if undecided:
        ids = sorted({r.id for r in undecided})
        warnings.append(f"{len(undecided)} result(s) undecided ({', '.join(ids)}): floating point could not separate the cases; try --exact")
    fragile = [r for r in report.conditions if r.fragile]
    if fragile:
        ids = sorted({r.id for r in fragile})
        warnings.append(f"{len(fragile)} fragile result(s) ({', '.join(ids)}): proven, but a small change of the weights could flip them")
    based = ["privacy.initial-state", "privacy.consensus-value", "privacy.connected", "stealthy.zda", "stealthy.covert", "local.pencil", "local.uio", *THEOREM_IDS, "switching.avoids-attack", "switching.detects"]
    present = {r.id for r in report.conditions}
    return Assessment(privacy, attack, tuple(warnings), tuple(_premises(report, no_monitors, disconnected)), not_evaluated, tuple(c for c in based if c in present))


def with_assessment(report: Report) -> Report:
    """``report`` with its :func:`assess` attached (``Report.assessment``, JSON form); idempotent."""
    if report.assessment is not None:
        return report
    return dataclasses.replace(report, assessment=assess(report).to_json())
