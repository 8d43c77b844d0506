"""The evidence of :func:`~glocal_verify.answer.attack.answer_attack`, read from a report's results.

A report holds one result per condition and scope; for the spec's attack the answer reads
``stealthy.zda`` / ``stealthy.covert`` (global), ``local.pencil`` and ``local.uio`` with the
suspected set ``attack`` (per cluster and observer), Theorem III.3 (i)-(iii) and
``switching.avoids-attack`` (per safe mode), ``switching.detects`` when it was simulated, and
``detection.thresholds`` / ``detection.guarantee`` in a sampled deployment.
The attack, its split by cluster and the schedule come from :attr:`Report.system`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from glocal_verify.answer.attack import THEOREM_IDS, AttackEvidence, DeploymentEvidence, DeploymentMode, LocalEvidence, ModeEvidence
from glocal_verify.words import format_lambda
from glocal_verify.results import ConditionResult, Report, Status

__all__ = ["combine", "deployment_of", "evidence_from_report", "lambda0_of"]


def combine(statuses: Sequence[Status]) -> Status | None:
    """All hold -> HOLDS; one fails -> FAILS; else UNDECIDED; nothing -> None."""
    if not statuses:
        return None
    if any(s is Status.FAILS for s in statuses):
        return Status.FAILS
    if all(s is Status.HOLDS for s in statuses):
        return Status.HOLDS
    return Status.UNDECIDED


def _pair(x: Any) -> complex | None:
    if isinstance(x, (list, tuple)) and len(x) == 2:
        return complex(float(x[0]), float(x[1]))
    if isinstance(x, (int, float)):
        return complex(float(x))
    return None


def lambda0_of(report: Report) -> tuple[complex | None, str]:
    """The exponent the ZDA verdicts concern and where it comes from (``stealthy.zda``'s witness direction).

    The source is ``spec`` when the spec's ``attack.lambda0`` admits a stealthy ZDA, else
    ``substituted: ...`` naming the exponent used.
    """
    atk = report.system.attack
    for r in report.results("stealthy.zda"):
        d = r.witness.get("direction")
        if isinstance(d, Mapping):
            src = str(d.get("source", ""))
            if src == "requested lambda0":
                return _pair(d.get("lambda0")), "spec"
            if atk is not None and atk.lambda0 is not None:
                return _pair(d.get("lambda0")), f"substituted: the spec's lambda0 = {format_lambda(atk.lambda0)} admits no stealthy ZDA; the {src} is used"
            return _pair(d.get("lambda0")), f"substituted: the spec gives no lambda0; the {src} is used"
    for r in report.results("switching.avoids-attack"):
        lam = _pair(r.witness.get("lambda0"))
        if lam is not None:
            return lam, "see switching.avoids-attack (lambda0_rule)"
    return (None if atk is None else atk.lambda0), ("spec" if atk is not None and atk.lambda0 is not None else "")


def _by_mode(rs: Sequence[ConditionResult], mode: str) -> ConditionResult | None:
    return next((r for r in rs if r.scope.get("mode") == mode), None)


def _number(x: Any) -> float | None:
    return float(x) if isinstance(x, (int, float)) and not isinstance(x, bool) else None


def deployment_of(report: Report) -> DeploymentEvidence | None:
    """The ``detection.*`` evidence for the spec's attack (None when the report has none)."""
    thresholds, guarantees = report.results("detection.thresholds"), report.results("detection.guarantee")
    if not thresholds and not guarantees:
        return None
    modes = []
    for r in guarantees:
        w = r.witness
        modes.append(
            DeploymentMode(
                str(r.scope.get("mode")), r.status, None if w.get("detected_by") is None else str(w.get("detected_by")),
                _number(w.get("within")), _number(w.get("global_detection")), _number(w.get("size")), _number(w.get("min_size")), r.note,
            )
        )
    atk = report.system.attack
    watching = {"central"} | {f"{c}@{o}" for c, _, obs in (atk.by_cluster if atk is not None else ()) if c is not None for o in obs}
    def watches(r: ConditionResult) -> bool:
        return atk is None or str(r.scope.get("observer", "central")) in watching

    left = tuple((str(r.scope.get("observer")), r.note) for r in thresholds if not watches(r) and r.status is not Status.HOLDS)
    return DeploymentEvidence(combine([r.status for r in thresholds if watches(r)]), tuple(modes), left)


def evidence_from_report(report: Report) -> AttackEvidence | None:
    """The evidence for the spec's attack (None when the report has no attack).

    Parameters
    ----------
    report : Report

    Returns
    -------
    AttackEvidence or None
    """
    atk = report.system.attack
    if atk is None:
        return None
    sid = "stealthy.zda" if atk.kind == "zda" else "stealthy.covert"
    stealthy = combine([r.status for r in report.results(sid)])
    lam, source = lambda0_of(report)
    local: list[LocalEvidence] = []
    pencils = {(r.scope.get("cluster"), repr(r.scope.get("observer"))): r for r in report.results("local.pencil") if r.scope.get("suspected") == "attack"}
    uios = {(r.scope.get("cluster"), repr(r.scope.get("observer"))): r for r in report.results("local.uio") if r.scope.get("suspected") == "attack"}
    for cluster, agents, observers in atk.by_cluster:
        if cluster is None:
            continue
        for o in observers:
            p, u = pencils.get((cluster, repr(o))), uios.get((cluster, repr(o)))
            local.append(LocalEvidence(cluster, o, tuple(agents), None if p is None else p.status, None if u is None else u.status))
    theorem = {cid: report.results(cid) for cid in THEOREM_IDS}
    avoids, detects = report.results("switching.avoids-attack"), report.results("switching.detects")
    modes = []
    for q in report.system.modes[1:]:
        th = {cid: r.status for cid, rs in theorem.items() if (r := _by_mode(rs, q)) is not None}
        av, sim = _by_mode(avoids, q), _by_mode(detects, q)
        post = sim.witness.get("post_switch") if sim is not None else None
        modes.append(
            ModeEvidence(
                q,
                th,
                None if av is None else av.status,
                None if av is None or av.status is not Status.FAILS or av.margin is None else float(av.margin),
                "" if av is None else str(av.witness.get("predicted_residual", "") or ""),
                None if sim is None else sim.status,
                str(post.get("summary", "")) if isinstance(post, Mapping) else "",
            )
        )
    sched = report.system.schedule
    return AttackEvidence(
        atk.kind, tuple(atk.actuators), tuple(atk.by_cluster), stealthy, lam, source, tuple(local), tuple(modes),
        None if sched is None else tuple(sched.modes), "" if sched is None else sched.text, report.system.monitored, deployment_of(report),
        _number(report.options.get("fragile_below")),
    )
