"""The records of an audit: one :class:`AuditRow` per attack set, the :class:`AuditResult` and its JSON form.

JSON shape ``glocal-verify/audit@1`` (schema ``reporting/schemas/audit.schema.json``):
``{"schema", "system", "n", "max_attackers", "candidates", "rows": [...], "summary": {...}}``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Hashable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from glocal_verify.answer.attack import AttackAnswer
from glocal_verify.results import Status, audit_jsonable
from glocal_verify.spec.types import Label

__all__ = ["AUDIT_SCHEMA_ID", "VERDICTS", "AuditResult", "AuditRow", "SharedParts"]

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
        ``detected`` | ``undetected`` | ``undecided``: the answer of
        :func:`~glocal_verify.answer.attack.answer_attack`, the same rule as ``verify``'s
        assessment.
    witness : mapping
        Direction (xi, u0 by label, residual), per-observer and per-mode statuses, the reason.
    answer : AttackAnswer or None
        The whole answer (routes, the chain that proves the verdict, per-cluster catches and
        per-mode exposures).
    """

    actuators: tuple[Label, ...]
    stealthy: bool | None
    growth: str
    lambda0: complex | None
    caught_locally_by: tuple[tuple[str, Label], ...]
    exposed_by_modes: tuple[str, ...]
    verdict: str
    witness: Mapping[str, Any] = field(default_factory=dict)
    answer: AttackAnswer | None = None

    @property
    def chain(self) -> str:
        """The chain that proves the verdict (``stealthy (...) -> caught by P1@5 -> ...``)."""
        if self.answer is None:
            return str(self.witness.get("reason", ""))
        return " -> ".join(self.answer.chain)

    def __repr__(self) -> str:
        return f"<AuditRow {', '.join(map(str, self.actuators))}: {self.verdict}>"

    def to_json(self) -> dict[str, Any]:
        """The row in the ``glocal-verify/audit@1`` form."""
        return audit_jsonable(self.json_form())  # type: ignore[no-any-return]

    def json_form(self) -> dict[str, Any]:
        """The row's JSON fields before :func:`~glocal_verify.results.audit_jsonable`
        (what :class:`~glocal_verify.reporting.audit_json.IndentedJson` writes without building it)."""
        routes = [] if self.answer is None else [{"name": r.name, "verdict": r.verdict} for r in self.answer.routes]
        return {
            "actuators": self.actuators,
            "stealthy": self.stealthy,
            "growth": self.growth,
            "lambda0": None if self.lambda0 is None else complex(self.lambda0),  # always [re, im]
            "caught_locally_by": [{"cluster": c, "observer": o} for c, o in self.caught_locally_by],
            "exposed_by_modes": self.exposed_by_modes,
            "verdict": self.verdict,
            "caught_locally": None if self.answer is None else self.answer.caught_locally,
            "routes": routes,
            "chain": () if self.answer is None else self.answer.chain,
            "witness": dict(self.witness),
        }


class SharedParts:
    """One object per distinct part among the rows an audit keeps: the rows of 500,500 sets fit in memory.

    Most parts of a row repeat across rows: the verdict of one observer for one suspected
    agent, a route's steps, a proof that names no agent, the detail of a mode that is not
    evaluated. Rows built in a worker arrive as separate copies of each (pickle shares an
    object only within one chunk); :meth:`rows` replaces every repeated part by the first
    equal one it has seen, so the process that keeps the rows holds each once (at N = 1000,
    k = 2: about 5.7 kB per row before, measured with tracemalloc). Values are equal field by
    field: nothing a reader sees changes, and the witness is read-only.

    The parts that are unique to a row (its actuators, the witness direction's input, the
    reason naming its agents) are kept as they are, and never enter the table.
    """

    def __init__(self) -> None:
        self._table: dict[Hashable, Any] = {}

    def __reduce__(self) -> tuple[type, tuple[()]]:
        return (SharedParts, ())  # a table belongs to one process: it travels empty

    def __len__(self) -> int:
        return len(self._table)

    def rows(self, rows: Sequence[AuditRow]) -> list[AuditRow]:
        """The rows with their repeated parts shared."""
        return [self.row(r) for r in rows]

    def row(self, r: AuditRow) -> AuditRow:
        """One row with its repeated parts shared."""
        w = dict(r.witness)
        for key in ("local", "modes"):
            if isinstance(w.get(key), dict):
                inner = {self._one(k): self._json(v) for k, v in w[key].items()}
                # its values are the table's own objects now: their identities make the key
                w[key] = self._table.setdefault((key, tuple((k, id(v)) for k, v in inner.items())), inner)
        for key in ("zda_method", "zda_proof", "growth_at_least", "zero_set", "separator", "zda_note"):
            if isinstance(w.get(key), str):
                w[key] = self._one(w[key])
        d = w.get("direction")
        if isinstance(d, dict):
            d = dict(d)
            for key in ("lambda0", "source", "xi_note"):
                if key in d:
                    d[key] = self._json(d[key])
            w["direction"] = d
        a = r.answer
        if a is not None:
            a = dataclasses.replace(
                a,
                lambda0_source=self._one(a.lambda0_source),
                clusters=self._one(tuple(self._one(c) for c in a.clusters)),
                modes=self._one(tuple(self._one(m) for m in a.modes)),
                routes=self._one(tuple(self._one(dataclasses.replace(t, chain=self._chain(t.chain))) for t in a.routes)),
                chain=self._chain(a.chain),
                not_exposed_by_modes=self._one(a.not_exposed_by_modes),
                unsettled_modes=self._one(a.unsettled_modes),
            )
            if "reason" in w and w["reason"] == a.reason:
                w["reason"] = a.reason
        return dataclasses.replace(r, growth=self._one(r.growth), verdict=self._one(r.verdict), witness=w, answer=a)

    def _one(self, value: Any) -> Any:
        """The first value seen equal to ``value`` (hashable values only)."""
        return self._table.setdefault(value, value)

    def _chain(self, chain: tuple[str, ...]) -> tuple[str, ...]:
        return self._one(tuple(self._one(step) for step in chain))  # type: ignore[no-any-return]

    def _json(self, value: Any) -> Any:
        """A JSON-like value (dicts, lists, scalars) shared by its frozen form."""
        if isinstance(value, str):
            return self._one(value)
        key = _frozen(value)
        if key is None:
            return value
        return self._table.setdefault(("json", key), value)


def _frozen(value: Any) -> Hashable | None:
    """A hashable key equal exactly when two JSON-like values are (types kept: True is not 1)."""
    if isinstance(value, dict):
        items = []
        for k, v in value.items():
            fv = _frozen(v)
            if fv is None:
                return None
            items.append((k, fv))
        return ("d", tuple(items))
    if isinstance(value, list):
        parts = [_frozen(v) for v in value]
        return None if any(p is None for p in parts) else ("l", tuple(parts))
    if isinstance(value, float):
        return (float, value.hex())  # exact, and -0.0 is not 0.0 (they print differently)
    if value is None or isinstance(value, (str, bool, int)):
        return (type(value), value)
    return None


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

    def __repr__(self) -> str:
        c = self.summary()["counts"]
        return f"<AuditResult {self.system}: {len(self.rows)} sets of 1..{self.max_attackers}: {c['detected']} detected, {c['undetected']} undetected, {c['undecided']} undecided>"

    def _repr_html_(self) -> str:
        from html import escape

        c = self.summary()["counts"]
        worst = [r for r in self.rows if r.verdict != "detected"][:10]
        items = "".join(f"<tr><td>{escape(', '.join(map(str, r.actuators)))}</td><td>{escape(r.verdict)}</td><td>{escape(r.chain)}</td></tr>" for r in worst)
        more = len([r for r in self.rows if r.verdict != "detected"]) - len(worst)
        table = f"<table><tr><th>actuators</th><th>verdict</th><th>why</th></tr>{items}</table>" if items else ""
        return (
            f"<div><p><b>{c['undetected']} undetected, {c['undecided']} undecided</b> of {len(self.rows)} attack sets of 1..{self.max_attackers} "
            f"({c['detected']} detected) &mdash; audit of <code>{escape(self.system)}</code></p>{table}"
            + (f"<p>... and {more} more (glocal_verify.reporting.audit_text.audit_markdown)</p>" if more > 0 else "") + "</div>"
        )

    def to_json(self) -> dict[str, Any]:
        """``{"schema": "glocal-verify/audit@1", "system", "max_attackers", "candidates", "rows", "summary"}``."""
        return {**self.json_head(), "rows": [r.to_json() for r in self.rows], "summary": audit_jsonable(self.summary())}

    def json_head(self) -> dict[str, Any]:
        return {"schema": AUDIT_SCHEMA_ID, "system": self.system, "n": self.n, "max_attackers": self.max_attackers, "candidates": list(self.candidates)}
