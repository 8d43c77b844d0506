"""The records of an audit: one :class:`AuditRow` per attack set, the :class:`AuditResult` and its JSON and Markdown forms.

JSON shape ``glocal-verify/audit@1`` (schema ``reporting/schemas/audit.schema.json``):
``{"schema", "system", "n", "max_attackers", "candidates", "rows": [...], "summary": {...}}``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from glocal_verify.results import FRAGILE_BELOW, Status
from glocal_verify.spec.types import Label

__all__ = ["AUDIT_SCHEMA_ID", "VERDICTS", "AuditResult", "AuditRow", "exposure_fragility", "undecided_reason"]

AUDIT_SCHEMA_ID = "glocal-verify/audit@1"
VERDICTS = ("detected", "undetected", "undecided")


@dataclass(frozen=True, slots=True)
class AuditRow:
    """The audit of one set F of compromised actuators.

    Attributes
    ----------
    actuators : tuple of labels
        F, in label order.
    stealthy : bool or None
        A stealthy ZDA exists (None: undecided).
    growth : str
        ``unbounded`` | ``persistent`` | ``decaying`` | ``null`` (no stealthy ZDA) | ``undecided``.
    lambda0 : complex or None
        Exponent of the witness direction (that of ``stealthy.zda``).
    caught_locally_by : tuple of (cluster, centre)
        Observers for which local.pencil (suspected F ∩ P_i) and local.uio hold.
    exposed_by_modes : tuple of str
        Safe modes meeting Theorem III.3 (i)-(iii) that touch every stealthy direction at lambda0.
    verdict : str
        ``detected`` | ``undetected`` | ``undecided`` (module docstring).
    witness : mapping
        Direction (xi, u0 by label, residual), per-observer and per-mode statuses, the reason.
    """

    actuators: tuple[Label, ...]
    stealthy: bool | None
    growth: str
    lambda0: complex | None
    caught_locally_by: tuple[tuple[str, Label], ...]
    exposed_by_modes: tuple[str, ...]
    verdict: str
    witness: Mapping[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        """The row in the ``glocal-verify/audit@1`` form."""
        return {
            "actuators": list(self.actuators),
            "stealthy": self.stealthy,
            "growth": self.growth,
            "lambda0": None if self.lambda0 is None else [self.lambda0.real, self.lambda0.imag],
            "caught_locally_by": [{"cluster": c, "observer": o} for c, o in self.caught_locally_by],
            "exposed_by_modes": list(self.exposed_by_modes),
            "verdict": self.verdict,
            "witness": _jsonable(dict(self.witness)),
        }


@dataclass(frozen=True, slots=True)
class AuditResult:
    """All rows of an audit, with the per-mode Theorem III.3 verdicts it used.

    Attributes
    ----------
    system : str
        Name of the audited system.
    n : int
        Number of agents.
    max_attackers : int
        k.
    candidates : tuple of labels
        Agents whose actuators may be compromised.
    modes : mapping
        ``{mode: True | False | None}``: Theorem III.3 (i)-(iii) all hold / some fails / undecided.
    rows : tuple of AuditRow
        Sorted by size, then labels.
    """

    system: str
    n: int
    max_attackers: int
    candidates: tuple[Label, ...]
    modes: Mapping[str, bool | None]
    rows: tuple[AuditRow, ...]

    def summary(self) -> dict[str, Any]:
        """Counts per verdict and size, and the undetected sets first (then the undecided ones)."""
        counts = {v: sum(1 for r in self.rows if r.verdict == v) for v in VERDICTS}
        by_size: dict[str, dict[str, int]] = {}
        for r in self.rows:
            d = by_size.setdefault(str(len(r.actuators)), {v: 0 for v in VERDICTS})
            d[r.verdict] += 1
        return {
            "sets": len(self.rows),
            "counts": counts,
            "by_size": by_size,
            "stealthy": sum(1 for r in self.rows if r.stealthy),
            "undetected": [list(r.actuators) for r in self.rows if r.verdict == "undetected"],
            "undecided": [list(r.actuators) for r in self.rows if r.verdict == "undecided"],
            "theorem_iii3_modes": dict(self.modes),
        }

    def to_json(self) -> dict[str, Any]:
        """``{"schema": "glocal-verify/audit@1", "system", "max_attackers", "candidates", "rows", "summary"}``."""
        return {
            "schema": AUDIT_SCHEMA_ID,
            "system": self.system,
            "n": self.n,
            "max_attackers": self.max_attackers,
            "candidates": list(self.candidates),
            "rows": [r.to_json() for r in self.rows],
            "summary": _jsonable(self.summary()),
        }

    def to_markdown(self) -> str:
        """A table with one line per set, the undetected sets first."""
        s = self.summary()
        c = s["counts"]
        lines = [
            f"# Attack audit: {self.system}",
            "",
            (f"{s['sets']} sets of 1..{self.max_attackers} compromised actuators: {c['detected']} detected, "
            f"{c['undetected']} undetected, {c['undecided']} undecided; {s['stealthy']} admit a stealthy ZDA."),
            "",
            "Safe modes meeting Theorem III.3 (i)-(iii): "
            + (", ".join(m for m, ok in self.modes.items() if ok) or "none"),
            "",
            "| actuators | stealthy | growth | lambda0 | caught locally by | exposed by modes | verdict |",
            "|---|---|---|---|---|---|---|",
        ]
        order = {"undetected": 0, "undecided": 1, "detected": 2}
        for r in sorted(self.rows, key=lambda r: order[r.verdict]):
            lam = "-" if r.lambda0 is None else f"{r.lambda0.real:.4g}{'' if r.lambda0.imag == 0 else f'{r.lambda0.imag:+.4g}i'}"
            caught = ", ".join(f"{cl}@{o}" for cl, o in r.caught_locally_by) or "-"
            st = "undecided" if r.stealthy is None else ("yes" if r.stealthy else "no")
            lines.append(
                f"| {', '.join(map(str, r.actuators))} | {st} | {r.growth} | {lam} | {caught} | {', '.join(r.exposed_by_modes) or '-'} | {r.verdict} |"
            )
        return "\n".join(lines) + "\n"


def exposure_fragility(modes: Mapping[str, Any], exposed: list[str], below: float = FRAGILE_BELOW) -> dict[str, str]:
    """``{"fragile": note}`` when every exposing mode touches the attack only by a tiny relative signal, else ``{}``.

    The touch test is decided exactly (or certified), so a tiny margin never changes the
    verdict: it says the switch exposes the attack by a residual of that relative size, which
    noise or rounding in a real network would hide.

    Parameters
    ----------
    modes : mapping
        The row's witness ``modes`` (each with ``touch_margin``).
    exposed : list of str
        The exposing modes.
    below : float
        The fragility threshold.
    """
    margins = [float(modes[q].get("touch_margin", math.inf)) for q in exposed]
    best = max(margins, default=math.inf)
    if not exposed or not best < below:
        return {}
    return {"fragile": f"detected only by exposure, and every exposing switch touches the attack by a relative signal of at most {best:.2g} (below {below:g})"}


def undecided_reason(stealthy: bool | None, local: Mapping[str, Any], modes: Mapping[str, Any], *, exact: bool, exact_fallback: bool) -> str:
    """Why a row is ``undecided``: every part that is, and what would decide it.

    A row is undecided when no part proves ``detected`` and the parts that could are not all
    decided: the existence of a stealthy ZDA, the local pencil (iii) or the UIO of an observer
    of a cluster F meets, Theorem III.3 or the touch test of a safe mode.

    Parameters
    ----------
    stealthy : bool or None
        Whether a stealthy ZDA exists (None: undecided).
    local : mapping
        The row's witness ``local``: ``{"P1@5": {"local.pencil": ..., "local.uio": ...}}``.
    modes : mapping
        The row's witness ``modes``: ``{"case-2": {"theorem_iii3": ..., "switching.avoids-attack": ...}}``.
    exact : bool
        The audit ran in exact arithmetic.
    exact_fallback : bool
        Numeric undecided parts were re-decided over Q.

    Returns
    -------
    str
        One sentence, e.g. ``"undecided: local.uio of P2@17; switching.avoids-attack of case-2
        (the certified floating-point bounds do not separate the cases; audit --exact decides
        them)"``.
    """
    parts = []
    if stealthy is None:
        parts.append("whether a stealthy ZDA exists")
    for name, d in local.items():
        for cid in ("local.pencil", "local.uio"):
            if d.get(cid) == Status.UNDECIDED.value:
                parts.append(f"{cid} of {name}")
    for mode, d in modes.items():
        if d.get("theorem_iii3") is None:
            parts.append(f"Theorem III.3 for {mode}")
        elif d.get("theorem_iii3") and d.get("switching.avoids-attack") == Status.UNDECIDED.value:
            parts.append(f"switching.avoids-attack of {mode}")
    what = "; ".join(parts) if parts else "a part of the row"
    if exact:
        how = "exact arithmetic left it open (a switching schedule of three or more modes)"
    elif exact_fallback:
        how = "neither the certified floating-point bounds nor the exact re-decision settled it"
    else:
        how = "the certified floating-point bounds do not separate the cases; audit --exact (rational weights) decides them"
    return f"undecided: {what} ({how})"


def _jsonable(x: Any) -> Any:
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, complex):
        return [x.real, x.imag]
    if isinstance(x, (np.floating, float)):
        f = float(x)
        return f if math.isfinite(f) else str(f)
    if isinstance(x, np.integer):
        return int(x)
    if isinstance(x, Status):
        return x.value
    return x
