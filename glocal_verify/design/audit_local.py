"""The local part of an audit row: which local observers catch an attack set (Proposition III.2).

A set's local part is assembled per cluster from the verdicts of ``local.pencil`` (eq.
``pencil_uio``, condition (iii)) and ``local.uio`` for the set's members in that cluster,
each status stated by the rule, which the audit lets try the exact screens that decide most
of them without a pencil analysis: a suspected agent on the boundary fails at once, a
failing member fails every set containing it (monotone screen), an exact twin mode proves a
failure, and exact maximal minors prove a success.
Verdicts are memoised per (cluster, observer, suspected set), and so are the evidence and
witness objects built from them (rows share them: the witness detail is read-only);
:func:`local_part` is called by
:mod:`glocal_verify.design.audit` for each row and, for the singles, in its first phase.
"""

from __future__ import annotations

from typing import Any

from glocal_verify.analysis.local.cases import LocalCase, PencilScreen
from glocal_verify.analysis.local.pencil import pencil_verdict, pencil_verdict_exact
from glocal_verify.answer.attack import LocalEvidence
from glocal_verify.observers.uio_verdict import uio_verdict
from glocal_verify.results import Status
from glocal_verify.spec.types import Label

__all__ = ["local_part", "pencil_status"]


def pencil_status(sh: Any, cm: Any, obs: Any, sus: tuple[Label, ...], memo: dict[Any, Any]) -> Status:
    """local.pencil for one observer and suspected set: the status of its rule, with the audit's screens.

    The rule (:func:`~glocal_verify.analysis.local.pencil.pencil_verdict`, or
    :func:`~glocal_verify.analysis.local.pencil.pencil_verdict_exact`) states every status; the
    audit only hands it the exact screens it may try first
    (:class:`~glocal_verify.analysis.local.cases.PencilScreen`): a member of the suspected set
    whose single set fails (if the pencil of eq. ``pencil_uio`` loses column rank at some lam
    for S, it does for every S' ⊇ S), a twin mode, and (numeric) exact maximal minors.
    """
    pkey = ("pencil", cm.name, obs.center, sus)
    if pkey in memo:
        return memo[pkey]  # type: ignore[no-any-return]
    case = LocalCase(cm, obs, "attack", sus)
    member = None
    if not case.structural and len(sus) > 1:
        member = next(((a, memo[("pencil-verdict", cm.name, obs.center, (a,))]) for a in sus if pencil_status(sh, cm, obs, (a,), memo) is Status.FAILS), None)
    screen = PencilScreen(member, minors=not sh.exact, cache=memo.setdefault("minors", {}), locate_zeros=False)
    if sh.exact:
        v = pencil_verdict_exact(sh.system, case, margin=False, screen=screen)
    else:
        v = pencil_verdict(sh.system, case, sh.tol, margin=False, screen=screen)
        if v.status is Status.UNDECIDED and sh.exact_fallback:
            v = pencil_verdict_exact(sh.system, case, margin=False)
    memo[("pencil-verdict", cm.name, obs.center, sus)] = v
    memo[pkey] = v.status
    return v.status


def local_part(sh: Any, F: tuple[Label, ...], memo: dict[Any, Any]) -> tuple[list[LocalEvidence], dict[str, Any]]:
    """The Proposition III.2 evidence of every observer of the clusters F meets, and the row's witness detail."""
    system = sh.system
    clusters = system.clusters
    place = memo.get("cluster-place")
    if place is None:
        # agent -> (cluster index, position in the cluster): F is split by cluster in O(|F|)
        place = memo["cluster-place"] = {a: (ci, j) for ci, c in enumerate(clusters) for j, a in enumerate(c.nodes)}
    if "cluster-observers" not in memo:
        memo["cluster-observers"] = [(system.cluster_model(c.name), system.observers(c.name)) for c in clusters]
    per_cluster: dict[int, list[Label]] = {}
    for a in sorted((a for a in F if a in place), key=place.__getitem__):
        per_cluster.setdefault(place[a][0], []).append(a)
    evidence: list[LocalEvidence] = []
    detail: dict[str, Any] = {}
    for ci, members in per_cluster.items():
        c = clusters[ci]
        sus = tuple(members)
        cm, observers = memo["cluster-observers"][ci]
        for obs in observers:
            key = (c.name, obs.center, sus)
            if key not in memo:
                ps = pencil_status(sh, cm, obs, sus, memo)
                us: Status | None = None  # not needed when the pencil fails: no UIO catches the attack then
                if ps is not Status.FAILS:
                    case = LocalCase(cm, obs, "attack", sus)
                    us = uio_verdict(system, case, sh.tol, sh.exact, cache=memo.setdefault("uio", {})).status
                    if us is Status.UNDECIDED and sh.exact_fallback and not sh.exact:
                        us = uio_verdict(system, case, sh.tol, True).status
                memo[key] = (ps, us)
            ps, us = memo[key]
            dkey = ("local-detail", key)  # one evidence and detail object per observer and suspected set:
            if dkey not in memo:  # the rows that share them share them (and pickle them once per chunk)
                memo[dkey] = (
                    LocalEvidence(c.name, obs.center, sus, ps, us),
                    {"suspected": list(sus), "local.pencil": ps.value, "local.uio": "not evaluated" if us is None else us.value},
                )
            ev, d = memo[dkey]
            detail[f"{c.name}@{obs.center}"] = d
            evidence.append(ev)
    return evidence, detail
