"""``--require``: a CI gate that passes only when every required condition is good news for the defender.

A gate written by a user must not pass when the attacker wins: ``--require stealthy.zda``
passes when no stealthy ZDA exists (the condition *fails*, which is favourable), not when one
does. :func:`require` gates on :func:`~glocal_verify.results.id_polarity`: an id passes when
its results are favourable (vacuous ones, whose premise is absent, neither help nor block,
but an id whose results are all vacuous does not pass); unfavourable, undecided, vacuous-only
and not-evaluated ids fail, each named with its scopes. :func:`require_holds` is the raw
status gate (``--require-holds``): every result ``holds``, whatever that means for the
defender.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

from glocal_verify.errors import ArgumentError
from glocal_verify.results import ConditionResult, Polarity, Report, Status, id_polarity
from glocal_verify.spec.arguments import id_list_arg, instance_arg

__all__ = ["GateOutcome", "require", "require_holds"]


@dataclass(frozen=True, slots=True)
class GateOutcome:
    """The result of a gate.

    Attributes
    ----------
    passed : bool
    ids : tuple of str
        The ids gated.
    failures : tuple of str
        One line per id or result that blocks the gate.
    """

    passed: bool
    ids: tuple[str, ...]
    failures: tuple[str, ...]

    def __bool__(self) -> bool:
        return self.passed


def _scope(r: ConditionResult) -> str:
    return ", ".join(f"{k}={v}" for k, v in r.scope.items()) or "global"


def _gate_arguments(who: str, report: object, ids: object) -> tuple[str, ...]:
    """The ids of a gate, checked: a :class:`Report` and at least one condition id (a gate that
    requires nothing would pass every report)."""
    instance_arg(who, report, Report, "a Report (from verify)")
    items = id_list_arg("ids", ids)
    if not items:
        raise ArgumentError(f"{who}: no condition id given; a gate that requires nothing passes every report")
    return tuple(items)


def require(report: Report, ids: Iterable[str]) -> GateOutcome:
    """Pass when every id in ``ids`` is favourable for the defender (module docstring).

    Parameters
    ----------
    report : Report
    ids : iterable of str
        Resolved condition ids.
    """
    ids = _gate_arguments("require", report, ids)
    bad: list[str] = []
    for cid in ids:
        rs = report.results(cid)
        pol = id_polarity(rs)
        if pol is None:
            bad.append(f"{cid}: not evaluated")
        elif pol is Polarity.VACUOUS:
            bad.append(f"{cid}: vacuous ({rs[0].premise})")
        elif pol is not Polarity.FAVOURABLE:
            for r in rs:
                if r.polarity in (Polarity.UNFAVOURABLE, Polarity.UNDECIDED):
                    bad.append(f"{cid} [{_scope(r)}]: {r.status.value}, {r.polarity.value}")
    return GateOutcome(not bad, ids, tuple(bad))


def require_holds(report: Report, ids: Iterable[str]) -> GateOutcome:
    """Pass when every result of every id in ``ids`` holds (the raw status gate, ``--require-holds``)."""
    ids = _gate_arguments("require_holds", report, ids)
    bad: list[str] = []
    for cid in ids:
        rs = report.results(cid)
        if not rs:
            bad.append(f"{cid}: not evaluated")
        bad += [f"{cid} [{_scope(r)}]: {r.status.value}" for r in rs if r.status is not Status.HOLDS]
    return GateOutcome(not bad, ids, tuple(bad))
