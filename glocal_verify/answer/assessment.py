"""The bottom line of a report: the paper's two problems answered for one network.

:func:`assess` reads a :class:`~glocal_verify.results.Report` and answers, in words a
designer reads in a minute,

- **Problem 1 (privacy)**: can the control centre reconstruct the initial state ``x(t0)``
  or the consensus value ``x* = (1/N) 1^T x(t0)``? (``protected`` / ``exposed`` /
  ``undecided``, from ``privacy.initial-state`` and ``privacy.consensus-value``);
- **Problem 2 (detection)**: the answer for the spec's attack,
  :func:`~glocal_verify.answer.attack.answer_attack` on the evidence of the report's results
  (:func:`~glocal_verify.answer.evidence.evidence_from_report`): stealthy to the control
  centre, caught locally by which observer, exposed by which safe mode, and detected under
  Algorithm 1 and under the spec's ``[switching]`` schedule, with the chain that proves it;
- **warnings** about absent premises (no global monitors, a disconnected graph, no attack, a
  substituted ``lambda0``) and about results the reader must not overlook.

The assessment does no new mathematics: every answer is a combination of the statuses (and
witnesses) of the report's results, so it is exactly as sound as they are. The rules are in
``docs/conditions.md`` ("The answer for one attacker" and "The assessment").
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from glocal_verify.answer.attack import ANSWER_IDS, DEPLOYMENT_IDS, AttackAnswer, answer_attack, not_assessed
from glocal_verify.words import format_labels, format_lambda, sentence
from glocal_verify.answer.evidence import combine, evidence_from_report
from glocal_verify.conditions.catalogue import CATALOGUE
from glocal_verify.results import ConditionResult, Polarity, Report, Status
from glocal_verify.spec.arguments import instance_arg

__all__ = [
    "NO_ATTACK",
    "NO_MONITORS",
    "Assessment",
    "PrivacyAnswer",
    "assess",
    "with_assessment",
]

NO_ATTACK = "no attack in the spec: use `glocal-verify audit` to check every attacker"
NO_MONITORS = "no global monitors: the control centre measures nothing"


def _plural(n: int, word: str) -> str:
    return f"{n} {word}{'' if n == 1 else 's'}"


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
class Assessment:
    """The bottom line of a report (see the module docstring).

    Attributes
    ----------
    privacy : PrivacyAnswer
    attack : AttackAnswer
    warnings : tuple of str
        Absent premises and results the reader must not overlook, most important first.
    notes : mapping of (id, scope key) to tuple of str
        Notes for the status lines of single results (a disconnected graph's modes).
    not_evaluated : mapping of str to str
        Requested condition ids without a result, and why (e.g. no ``[attack]``).
    based_on : tuple of str
        The condition ids the answers read.
    """

    privacy: PrivacyAnswer
    attack: AttackAnswer
    warnings: tuple[str, ...]
    notes: Mapping[tuple[str, str], tuple[str, ...]]
    not_evaluated: Mapping[str, str]
    based_on: tuple[str, ...]

    @property
    def verdict(self) -> str:
        """The attack's verdict (``detected``, ``undetected``, ``undecided``, ``not assessed``)."""
        return self.attack.verdict

    def notes_for(self, r: ConditionResult) -> list[str]:
        """Notes for result ``r``: its vacuous premise, and the assessment's notes on its scope."""
        out = [f"vacuous: {r.premise}"] if r.premise else []
        out += list(self.notes.get((r.id, str(r.scope.get("mode"))), ()))
        return out

    def headline(self) -> str:
        """One line: the privacy answers and the attack's verdict."""
        p, a = self.privacy, self.attack
        att = "no attack in the spec" if not a.present else f"attack on {format_labels(a.actuators)}: {a.verdict_words()}"
        if a.deployment is not None:
            att += f" (sampled deployment: {a.deployment.word})"
        return f"x(t0) {p.initial_state}, x* {p.consensus_value}; {att}"

    def to_json(self) -> dict[str, Any]:
        """JSON form (``assessment`` of the report schema ``glocal-verify/report@1``)."""
        return {
            "privacy": self.privacy.to_json(),
            "attack": self.attack.to_json(),
            "warnings": list(self.warnings),
            "notes": [{"id": cid, "mode": mode, "notes": list(ns)} for (cid, mode), ns in self.notes.items()],
            "not_evaluated": dict(self.not_evaluated),
            "based_on": list(self.based_on),
        }

    def __repr__(self) -> str:
        return f"<Assessment {self.headline()}>"

    def _repr_html_(self) -> str:
        from html import escape

        items = "".join(f"<li>{escape(w)}</li>" for w in self.warnings[:5])
        return (
            f"<div><p><b>{escape(self.attack.verdict if self.attack.present else 'privacy')}</b> &mdash; {escape(self.headline())}</p>"
            f"<p>{escape(self.privacy.reason)}</p><p>{escape(self.attack.reason)}</p>" + (f"<ul>{items}</ul>" if items else "") + "</div>"
        )


# --------------------------------------------------------------------------------------------
# Problem 1


def _privacy(report: Report, no_monitors: bool, disconnected: Sequence[str]) -> PrivacyAnswer:
    word = {Status.HOLDS: "protected", Status.FAILS: "exposed", Status.UNDECIDED: "undecided", None: "undecided"}
    init = report.results("privacy.initial-state")
    cons = report.results("privacy.consensus-value")
    s_init, s_cons = combine([r.status for r in init]), combine([r.status for r in cons])
    dims = [int(r.margin) for r in init if r.status is Status.HOLDS and r.margin is not None]
    hidden = min(dims) if dims and s_init is Status.HOLDS else None
    parts: list[str] = []
    if no_monitors:
        parts.append("vacuously: the control centre measures nothing, so it learns nothing")
    elif s_init is None and s_cons is None:
        parts.append("not evaluated: privacy.initial-state and privacy.consensus-value (--only)")
    else:
        if s_init is Status.HOLDS:
            scopes = _plural(len(init), "evaluated scope")
            if hidden == 1:
                parts.append(
                    f"x(t0) cannot be reconstructed in any of the {scopes}, but only one direction "
                    "(the common position offset) stays hidden: velocities and relative positions are revealed"
                    if len(init) > 1
                    else "x(t0) cannot be reconstructed, but only one direction (the common position offset) stays hidden: velocities and relative positions are revealed"
                )
            else:
                parts.append(f"x(t0) cannot be reconstructed: at least {hidden} state directions stay hidden in each of the {scopes}")
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
    return PrivacyAnswer(word[s_init], word[s_cons], hidden, sentence("; ".join(parts)))


# --------------------------------------------------------------------------------------------
# entry point


def _requested(report: Report) -> list[str]:
    only = report.options.get("only")
    return list(only) if isinstance(only, (list, tuple)) else list(CATALOGUE)


def _attack(report: Report, warnings: list[str], not_evaluated: dict[str, str]) -> AttackAnswer:
    requested = _requested(report)
    ev = evidence_from_report(report)
    if ev is None or not (report.results("stealthy.zda") or report.results("stealthy.covert")):
        if ev is None and ("stealthy.zda" in requested or "stealthy.covert" in requested):
            warnings.append(NO_ATTACK)
            for cid in ("stealthy.zda", "stealthy.covert", "switching.avoids-attack", "switching.detects"):
                if cid in requested:
                    not_evaluated[cid] = "no [attack] in the spec"
            return not_assessed(NO_ATTACK)
        return not_assessed("not evaluated: stealthy.zda and stealthy.covert (--only)" if ev is not None or report.system.attack is None else "")
    a = answer_attack(ev)
    atk = report.system.attack
    if ev.kind == "zda" and atk is not None and atk.lambda0 is not None and ev.lambda0_source.startswith("substituted"):
        warnings.append(
            f"the spec's lambda0 = {format_lambda(atk.lambda0)} admits no stealthy ZDA: the attack verdicts use lambda0 = {format_lambda(ev.lambda0)}"
        )
    if a.unsettled_modes and a.verdict == "undecided":
        warnings.append(f"whether {', '.join(a.unsettled_modes)} expose{'s' if len(a.unsettled_modes) == 1 else ''} the attack is not settled by the algebra: see each mode's reason")
    warnings += list(a.warnings)
    if a.deployment is not None and a.verdict == "detected" and a.deployment.guaranteed is False:
        warnings.append(f"detected in the paper's model, but not guaranteed in the sampled deployment: {a.deployment.reason}")
    if a.fragile:
        warnings.append(a.fragile)
    return a


#: the note of an undecided result whose only reason is the floating-point bound (registry.result)
_BOUND_NOTE = "the certified error bound does not separate the cases"


def _undecided_warning(report: Report, undecided: Sequence[ConditionResult]) -> str:
    """One warning for the undecided results: each id with its reason, and the next step."""
    parts = []
    for cid in sorted({r.id for r in undecided}):
        rs = [r for r in undecided if r.id == cid]
        notes = sorted({r.note for r in rs if r.note and not r.note.startswith(_BOUND_NOTE)})
        if notes:
            why = "; ".join(notes[:3]) + ("; ..." if len(notes) > 3 else "")
        elif report.options.get("exact"):
            why = "the exact run fell back to floating point, which could not separate the cases"
        else:
            why = "floating point could not separate the cases; try --exact"
        parts.append(f"{cid} ({why})")
    return f"{_plural(len(undecided), 'result')} undecided: {'; '.join(parts)}"


def assess(report: Report) -> Assessment:
    """The bottom line of ``report``: Problem 1 (privacy), Problem 2 (detection), warnings.

    Derived from the report's condition results only (no new computation); the rules are in
    the module docstring and in ``docs/conditions.md``.

    Parameters
    ----------
    report : Report

    Returns
    -------
    Assessment
    """
    instance_arg("assess", report, Report, "a Report (from verify)")
    warnings: list[str] = []
    not_evaluated: dict[str, str] = {}
    no_monitors = not report.system.monitored
    if no_monitors:
        warnings.append(NO_MONITORS + " (privacy holds vacuously, every attack is stealthy, and no switch can expose it)")
    disconnected: dict[str, Any] = {}
    for r in report.results("privacy.connected"):
        if r.status is Status.FAILS:
            comps = r.witness.get("components")
            text = "; ".join("{" + format_labels(c) + "}" for c in comps) if isinstance(comps, list) else "several components"
            disconnected[str(r.scope.get("mode", "normal"))] = text
    notes: dict[tuple[str, str], tuple[str, ...]] = {}
    if disconnected:
        where = ", ".join(f"{m}: {c}" for m, c in disconnected.items())
        warnings.append(f"disconnected graph ({where}): Lemma III.1's premise fails and each component converges to its own average")
        for mode, comps in disconnected.items():
            note = f"premise of Lemma III.1 absent: the {mode} graph is disconnected ({comps}); each component converges to its own average"
            for cid in ("privacy.unobservable", "privacy.initial-state", "privacy.consensus-value"):
                notes[(cid, mode)] = (note,)
    privacy = _privacy(report, no_monitors, list(disconnected))
    attack = _attack(report, warnings, not_evaluated)
    if report.options.get("selected"):  # asked for by --only: say why each has no result
        for cid, why in (report.options.get("skipped") or {}).items():
            not_evaluated.setdefault(cid, why)
    left_out = {d for d, _ in (attack.deployment.left_out if attack.deployment is not None else ())}
    undecided = [r for r in report.conditions if r.polarity is Polarity.UNDECIDED and r.id != "switching.detects"]
    undecided = [r for r in undecided if not (r.id == "detection.thresholds" and str(r.scope.get("observer")) in left_out)]
    if undecided:
        warnings.append(_undecided_warning(report, undecided))
    for name, note in (attack.deployment.left_out if attack.deployment is not None else ()):
        warnings.append(
            f"the threshold of {name} is not certified ({note}); its cluster holds no attacked agent, so the deployment answer "
            f"does not wait for it; to certify it, let {name} measure more of its cluster (glocal-verify place-observers proposes a set)"
        )
    fragile = [r for r in report.conditions if r.fragile]
    if fragile:
        ids = sorted({r.id for r in fragile})
        warnings.append(f"{_plural(len(fragile), 'fragile result')} ({', '.join(ids)}): proven, but a small change of the weights could flip them")
    based = ["privacy.initial-state", "privacy.consensus-value", "privacy.connected", *ANSWER_IDS, *DEPLOYMENT_IDS]
    present = {r.id for r in report.conditions}
    return Assessment(privacy, attack, tuple(warnings), notes, not_evaluated, tuple(c for c in based if c in present))


def with_assessment(report: Report) -> Report:
    """``report`` with its :func:`assess` attached (:attr:`Report.assessment`); idempotent."""
    if report.assessment is not None:
        return report
    return dataclasses.replace(report, assessment=assess(report))
