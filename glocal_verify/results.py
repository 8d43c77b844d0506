"""Verdicts: :class:`ConditionResult`, :class:`Finding` and :class:`Report`.

Every checker returns :class:`ConditionResult` values with the fields fixed by
``docs/conditions.md``: ``id``, ``scope``, ``status`` (holds / fails / undecided), ``margin``,
``tolerance``, ``method`` (numeric / exact), ``witness``, ``reference`` and ``statement``.
``undecided`` means the numbers cannot separate the cases at the tolerance used; it is never
turned into ``holds``. Exact results never are ``undecided``.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from enum import Enum
from fractions import Fraction
from types import MappingProxyType
from typing import Any, Mapping, Sequence

import numpy as np

from glocal_verify.errors import ArgumentError, UnknownConditionError, did_you_mean, shorten
__all__ = [
    "GROWTH_DECAYING",
    "GROWTH_NULL",
    "GROWTH_PERSISTENT",
    "GROWTH_UNBOUNDED",
    "GROWTH_UNDECIDED",
    "Status",
    "Method",
    "Polarity",
    "Verdict",
    "id_polarity",
    "polarity_of",
    "ConditionResult",
    "Finding",
    "Report",
    "SystemInfo",
    "AttackScenario",
    "ScheduleInfo",
    "audit_jsonable",
    "growth_of_sign",
    "growth_rank",
    "vector_json",
    "jsonable",
    "json_preview",
    "REPORT_SCHEMA_ID",
]


REPORT_SCHEMA_ID = "glocal-verify/report@1"

#: condition ids renamed, still accepted for one release: old id -> current id (none at present;
#: ``switching.safe``, renamed ``switching.avoids-attack``, has had its release: docs/conditions.md)
ALIASES: Mapping[str, str] = MappingProxyType({})


class Status(str, Enum):
    """Three-valued verdict."""

    HOLDS = "holds"
    FAILS = "fails"
    UNDECIDED = "undecided"

    def __str__(self) -> str:
        return self.value


#: the growth classes of an attack signal u0 exp(lambda0 t) (sampled: u0 z0^k): by the sign of
#: Re lambda0 (of |z0| - 1); ``null`` when there is no such attack, ``undecided`` when the sign
#: is not known
GROWTH_UNBOUNDED = "unbounded"
GROWTH_PERSISTENT = "persistent"
GROWTH_DECAYING = "decaying"
GROWTH_UNDECIDED = "undecided"
GROWTH_NULL = "null"

#: the growth classes from the mildest to the fastest (``undecided`` below ``unbounded``: it may be anything but that)
_GROWTH_ORDER = MappingProxyType({GROWTH_NULL: 0, GROWTH_DECAYING: 1, GROWTH_PERSISTENT: 2, GROWTH_UNDECIDED: 3, GROWTH_UNBOUNDED: 4})


def growth_of_sign(sign: int) -> str:
    """The growth class of an attack whose exponent has real part of sign ``sign`` (1, 0, -1).

    The one mapping of the package: exact signs (python-flint), decided numeric signs and the
    sampled loop's ``|z0| - 1`` all come here.

    Parameters
    ----------
    sign : int
        The sign of Re lambda0 (or of ``|z0| - 1``): 1, 0 or -1.
    """
    return GROWTH_UNBOUNDED if sign > 0 else GROWTH_PERSISTENT if sign == 0 else GROWTH_DECAYING


def growth_rank(g: str) -> int:
    """Order of the growth classes: null < decaying < persistent < undecided < unbounded (an unknown class ranks as undecided).

    Parameters
    ----------
    g : str
    """
    return _GROWTH_ORDER.get(g, 3)


class Method(str, Enum):
    """How a verdict was reached."""

    NUMERIC = "numeric"
    EXACT = "exact"
    #: the numeric run was undecided and exact arithmetic decided it
    ESCALATED = "exact (escalated)"

    def __str__(self) -> str:
        return self.value


class Polarity(str, Enum):
    """What a verdict means for the defender: one vocabulary for every report, repr and gate.

    ``favourable`` / ``unfavourable``: the status is good / bad news for the defender (the
    catalogue's polarity of the condition: for ``stealthy.*`` and ``switching.avoids-attack``
    ``holds`` is bad news). ``vacuous``: the condition's premise is absent (no stealthy ZDA to
    avoid, no attacked agent in the cluster, no global monitor ...), so its status says
    nothing either way; the result names the premise. ``undecided``: the status is undecided.
    """

    FAVOURABLE = "favourable"
    UNFAVOURABLE = "unfavourable"
    VACUOUS = "vacuous"
    UNDECIDED = "undecided"

    def __str__(self) -> str:
        return self.value

    @property
    def mark(self) -> str:
        """One character for tables: ✓ favourable, ✗ unfavourable, – vacuous, ? undecided."""
        return {"favourable": "✓", "unfavourable": "✗", "vacuous": "–", "undecided": "?"}[self.value]


def polarity_of(status: Status, good: Status, premise: str | None = None) -> Polarity:
    """The polarity of ``status`` for a condition whose good news is ``good`` (the one rule).

    Parameters
    ----------
    status : Status
    good : Status
        ``HOLDS`` or ``FAILS``: the status that is good news for the defender.
    premise : str or None
        The absent premise, when the verdict is vacuous.
    """
    if status is Status.UNDECIDED:
        return Polarity.UNDECIDED
    if premise:
        return Polarity.VACUOUS
    return Polarity.FAVOURABLE if status is good else Polarity.UNFAVOURABLE


def id_polarity(results: "Sequence[ConditionResult]") -> Polarity | None:
    """The polarity of a condition id over all its results (the rule of ``--require`` and the summaries).

    ``unfavourable`` if one result is; else ``undecided`` if one is; else ``vacuous`` if all
    are; else ``favourable`` (every result favourable or vacuous, at least one favourable).
    None when there is no result (not evaluated).
    """
    pols = [r.polarity for r in results]
    if not pols:
        return None
    for p in (Polarity.UNFAVOURABLE, Polarity.UNDECIDED):
        if p in pols:
            return p
    if all(p is Polarity.VACUOUS for p in pols):
        return Polarity.VACUOUS
    return Polarity.FAVOURABLE


@dataclass(frozen=True, slots=True)
class Verdict:
    """A condition's decision in one scope, as the analysis layer returns it (no id, scope or wording).

    The checker of ``glocal_verify.conditions`` adds the condition id, the scope, the
    catalogue's reference, statement and polarity, and the tolerance of its run
    (``glocal_verify.conditions.registry.verdict_result``).

    Attributes
    ----------
    status : Status
    margin : float or None
        Distance from the boundary on the scale the condition documents.
    error_bound : float or None
        The certified bound on the floating-point error of the quantity decided.
    witness : mapping
        What proves the verdict, in the user's node labels.
    exact : bool
        Decided in exact arithmetic. An exact run whose verdict is neither exact nor
        combinatorial fell back to a certified numeric decision (its result says ``numeric``).
    combinatorial : bool
        No rounding involved (no tolerance recorded), in either arithmetic.
    premise : str or None
        Set when the condition's premise is absent: the verdict is vacuous, and this says
        which premise.
    note : str
        Why the verdict is undecided (which bound failed), or what decided it.
    """

    status: Status
    margin: float | None = None
    error_bound: float | None = None
    witness: Mapping[str, Any] = field(default_factory=dict)
    exact: bool = False          # decided in exact arithmetic
    combinatorial: bool = False  # no rounding involved (no tolerance recorded)
    premise: str | None = None   # set when the condition's premise is absent: the verdict is vacuous, and this says which premise
    note: str = ""


@dataclass(frozen=True, slots=True)
class ConditionResult:
    """The verdict of one condition in one scope.

    Attributes
    ----------
    id : str
        Public condition id (``docs/conditions.md``), e.g. ``"switching.image-kernel"``.
    scope : mapping
        ``{"mode": ..., "cluster": ..., "observer": ..., "suspected": ...}``; empty when global.
    status : Status
    margin : float or None
        Distance from the boundary of the condition on the scale the checker documents;
        ``None`` only where no meaningful scale exists.
    tolerance : float or None
        Relative tolerance used for the numeric decision; ``None`` for exact or purely
        combinatorial decisions.
    method : Method
    witness : mapping
        What proves the verdict, in the user's node labels.
    reference : str
        Place in the paper, e.g. ``"Theorem III.3 (i)"``.
    statement : str
        One line stating the condition.
    favourable : bool or None
        Is this status good for the defender (polarity of the catalogue)? None when undecided.
        A vacuous result keeps the catalogue's reading here; :attr:`polarity` says ``vacuous``.
    fragile : bool
        The margin is below the robustness tolerance (``--fragile-below``): the verdict is
        certain but the exact system is close to the boundary (detection or privacy would be
        weak). Never changes the status.
    error_bound : float or None
        The certified bound on the floating-point error of the quantity decided (numeric
        results whose checker records it).
    note : str
        Why a result is undecided (which bound failed, what would decide it), or what
        escalation did.
    premise : str or None
        Set when the condition's premise is absent on this system (e.g. "no stealthy ZDA exists:
        there is nothing to avoid"): the status holds or fails vacuously and :attr:`polarity`
        is ``vacuous``.
    """

    id: str
    scope: Mapping[str, Any]
    status: Status
    margin: float | None
    tolerance: float | None
    method: Method
    witness: Mapping[str, Any]
    reference: str
    statement: str
    favourable: bool | None = None
    fragile: bool = False
    error_bound: float | None = None
    note: str = ""
    premise: str | None = None

    @property
    def polarity(self) -> Polarity:
        """Favourable, unfavourable, vacuous or undecided (:func:`polarity_of`)."""
        if self.status is Status.UNDECIDED:
            return Polarity.UNDECIDED
        if self.premise:
            return Polarity.VACUOUS
        return Polarity.FAVOURABLE if self.favourable else Polarity.UNFAVOURABLE

    @property
    def holds(self) -> bool:
        return self.status is Status.HOLDS

    def __repr__(self) -> str:
        scope = ", ".join(f"{k}={v}" for k, v in self.scope.items()) or "global"
        return f"<ConditionResult {self.id} [{scope}]: {self.status.value}, {self.polarity.value}{', fragile' if self.fragile else ''}>"

    def _repr_html_(self) -> str:
        """The verdict first, then what proves it (Jupyter); every string is HTML-escaped."""
        from html import escape

        scope = ", ".join(f"{k} = {v}" for k, v in self.scope.items()) or "global"
        extra = f"<br>premise absent: {escape(self.premise)}" if self.premise else (f"<br>{escape(self.note)}" if self.note else "")
        return (
            f"<div><p><b>{self.polarity.mark} {escape(self.id)}: {escape(self.status.value)} ({escape(self.polarity.value)})</b> "
            f"&mdash; {escape(scope)}, {escape(self.reference)}</p><p>{escape(self.statement)}{extra}</p>"
            f"<p>margin {escape(str(self.margin))}, method {escape(self.method.value)}; witness: <code>{escape(json_preview(self.witness, 200))}</code></p></div>"
        )

    @property
    def fails(self) -> bool:
        return self.status is Status.FAILS

    def to_json(self) -> dict[str, Any]:
        return {
            "id": self.id,
            "scope": jsonable(dict(self.scope)),
            "status": self.status.value,
            "margin": jsonable(self.margin),
            "tolerance": self.tolerance,
            "method": self.method.value,
            "witness": jsonable(dict(self.witness)),
            "reference": self.reference,
            "statement": self.statement,
            "favourable": self.favourable,
            "polarity": self.polarity.value,
            "premise": self.premise,
            "fragile": self.fragile,
            "error_bound": jsonable(self.error_bound),
            "note": self.note,
        }


@dataclass(frozen=True, slots=True)
class Finding:
    """A place where the paper is loose or wrong, as shown on this system."""

    id: str
    title: str
    detail: str
    reference: str = ""
    data: Mapping[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        return {"id": self.id, "title": self.title, "detail": self.detail, "reference": self.reference, "data": jsonable(dict(self.data))}


@dataclass(frozen=True, slots=True)
class AttackScenario:
    """The spec's attack as the per-attacker answer reads it.

    Attributes
    ----------
    kind : {"zda", "covert"}
    actuators : tuple of labels
        F.
    by_cluster : tuple of (cluster name or None, labels, observer centres)
        F split by cluster, in the spec's cluster order, with the centres of that cluster's
        local observers; None holds the agents in no cluster (no local observer watches them).
    lambda0 : complex or None
        The spec's exponent.
    """

    kind: str
    actuators: tuple[Any, ...]
    by_cluster: tuple[tuple[str | None, tuple[Any, ...], tuple[Any, ...]], ...] = ()
    lambda0: complex | None = None

    def to_json(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "actuators": jsonable(list(self.actuators)),
            "by_cluster": [{"cluster": c, "agents": jsonable(list(a)), "observers": jsonable(list(o))} for c, a, o in self.by_cluster],
            "lambda0": jsonable(self.lambda0),
        }


@dataclass(frozen=True, slots=True)
class ScheduleInfo:
    """A ``[switching]`` schedule: the defender switches at fixed times, whatever the local observers see.

    Attributes
    ----------
    modes : tuple of str
        The safe modes it visits, in order of first visit.
    text : str
        The schedule in words, e.g. ``"normal until t = 10, then case-2"``.
    """

    modes: tuple[str, ...]
    text: str

    def to_json(self) -> dict[str, Any]:
        return {"modes": list(self.modes), "text": self.text}


@dataclass(frozen=True, slots=True)
class SystemInfo:
    """What a report says of the verified system (the answer reads the attack and the schedule here).

    Attributes
    ----------
    name : str
    agents : int
    modes : tuple of str
    clusters : tuple of str
    attack : AttackScenario or None
        The spec's ``[attack]``.
    schedule : ScheduleInfo or None
        The spec's ``[switching]`` schedule (None: switches only on a local alarm, Algorithm 1).
    monitored : bool
        The control centre measures something (M_x or M_v non-empty).
    """

    name: str
    agents: int
    modes: tuple[str, ...]
    clusters: tuple[str, ...] = ()
    attack: AttackScenario | None = None
    schedule: ScheduleInfo | None = None
    monitored: bool = True


@dataclass(frozen=True, slots=True)
class Report:
    """All verdicts of one verification run.

    Attributes
    ----------
    system : SystemInfo
    conditions : tuple of ConditionResult
    findings : tuple of Finding
    options : mapping
        The options of the run (``verify``'s keywords and the ids it ran).
    assessment : Assessment or None
        The report's bottom line (Problem 1 privacy, Problem 2 detection, warnings),
        derived from ``conditions`` alone by ``glocal_verify.answer.assessment.assess``;
        :func:`glocal_verify.verify` attaches it (this layer cannot compute it). Any object
        with a ``to_json()`` method.
    """

    system: SystemInfo
    conditions: tuple[ConditionResult, ...]
    findings: tuple[Finding, ...] = ()
    options: Mapping[str, Any] = field(default_factory=dict)
    assessment: Any = None

    def results(self, cid: str) -> list[ConditionResult]:
        """All results with condition id ``cid`` (an old id of :data:`ALIASES` names its new one)."""
        cid = ALIASES.get(cid, cid)
        return [r for r in self.conditions if r.id == cid]

    def ids(self) -> list[str]:
        """The condition ids with results, in report order."""
        return list(dict.fromkeys(r.id for r in self.conditions))

    def __getitem__(self, cid: str) -> tuple[ConditionResult, ...]:
        """``report["privacy.kernel"]``: the results of one id.

        Raises
        ------
        UnknownConditionError
            (a :class:`KeyError`) no result has this id: the message names the closest ids
            of the report, or all of them.
        ArgumentError
            ``cid`` is not a string.
        """
        if not isinstance(cid, str):
            raise ArgumentError(f"report[...]: a condition id is a string (e.g. report['privacy.kernel']), got {type(cid).__name__}")
        rs = self.results(cid)
        if not rs:
            ids = self.ids()
            hint = did_you_mean(cid, ids, otherwise=f" (this report has {', '.join(ids) or 'no result'})")
            raise UnknownConditionError(f"{shorten(repr(cid), 80)}: no result with this id in this report{hint}")
        return tuple(rs)

    def __iter__(self) -> Any:
        """Iterate over the condition ids, as a mapping does (``for cid in report``)."""
        return iter(self.ids())

    def __len__(self) -> int:
        return len(self.ids())

    def __contains__(self, cid: object) -> bool:
        return isinstance(cid, str) and bool(self.results(cid))

    def items(self) -> list[tuple[str, tuple[ConditionResult, ...]]]:
        """(id, results) pairs in report order."""
        return [(cid, self[cid]) for cid in self.ids()]

    def to_json(self) -> dict[str, Any]:
        """The report as JSON (schema ``glocal-verify/report@1``); ``assessment`` when attached."""
        out: dict[str, Any] = {
            "schema": REPORT_SCHEMA_ID,
            "system": {
                "name": self.system.name,
                "agents": self.system.agents,
                "modes": list(self.system.modes),
                "clusters": list(self.system.clusters),
                "attack": None if self.system.attack is None else self.system.attack.to_json(),
                "schedule": None if self.system.schedule is None else self.system.schedule.to_json(),
                "monitored": self.system.monitored,
            },
        }
        if self.assessment is not None:
            out["assessment"] = jsonable(self.assessment.to_json())
        out["options"] = jsonable(dict(self.options))
        out["conditions"] = [r.to_json() for r in self.conditions]
        out["findings"] = [f.to_json() for f in self.findings]
        return out

    def _summary_rows(self) -> list[tuple[Any, ...]]:
        """Per condition id (first-seen order): favourable, unfavourable, vacuous, undecided, fragile."""
        out = []
        for cid in self.ids():
            rs = self.results(cid)
            out.append((cid, *(sum(1 for r in rs if r.polarity is p) for p in Polarity), sum(1 for r in rs if r.fragile)))
        return out

    def _headline(self) -> str:
        s = self.system
        n = {st: sum(1 for r in self.conditions if r.status is st) for st in Status}
        return (
            f"{s.name}: {s.agents} agents, {len(s.modes)} mode{'' if len(s.modes) == 1 else 's'}, {len(self.conditions)} results "
            f"({n[Status.HOLDS]} holds, {n[Status.FAILS]} fails, {n[Status.UNDECIDED]} undecided), "
            f"{len(self.findings)} finding{'' if len(self.findings) == 1 else 's'}"
        )

    def summary(self) -> str:
        """A small text table: per condition id, the count of each polarity.

        Columns ``favourable``, ``unfavourable``, ``vacuous``, ``undecided`` count the results
        by what they mean for the defender (:attr:`ConditionResult.polarity`); ``fragile``
        counts results whose margin is below the robustness tolerance.
        """
        head = ("condition", "favourable", "unfavourable", "vacuous", "undecided", "fragile")
        rows = [tuple(str(x) for x in row) for row in self._summary_rows()]
        width = max([len(head[0])] + [len(r[0]) for r in rows])
        fmt = "{:<" + str(width) + "}" + "".join(" {:>" + str(len(h)) + "}" for h in head[1:])
        lines = [self._headline(), fmt.format(*head)] + [fmt.format(*r) for r in rows]
        return "\n".join(lines)

    def _answer_line(self) -> str:
        a = self.assessment
        return a.headline() if a is not None and hasattr(a, "headline") else ""

    def _repr_markdown_(self) -> str:
        """The answer, then the summary as a Markdown table (Jupyter)."""
        lines = [
            f"**{self._answer_line() or 'glocal-verify report'}**",
            "",
            self._headline(),
            "",
            "| condition | ✓ favourable | ✗ unfavourable | – vacuous | ? undecided | fragile |",
            "|---|---|---|---|---|---|",
        ]
        lines += [f"| `{cid}` | " + " | ".join(str(x) for x in rest) + " |" for cid, *rest in self._summary_rows()]
        return "\n".join(lines) + "\n"

    def _repr_html_(self) -> str:
        """The summary as an HTML table (Jupyter); every string is HTML-escaped."""
        from html import escape

        head = "".join(f"<th>{h}</th>" for h in ("condition", "✓ favourable", "✗ unfavourable", "– vacuous", "? undecided", "fragile"))
        body = "".join(
            f"<tr><td><code>{escape(cid)}</code></td>" + "".join(f"<td>{x}</td>" for x in rest) + "</tr>" for cid, *rest in self._summary_rows()
        )
        answer = escape(self._answer_line())
        lead = f"<p><b>{answer}</b></p>" if answer else ""
        return f"<div>{lead}<p>glocal-verify report {escape(self._headline())}</p><table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table></div>"

    def __repr__(self) -> str:
        s = self.system
        n = {p: sum(1 for r in self.conditions if r.polarity is p) for p in Polarity}
        counts = ", ".join(f"{n[p]} {p.value}" for p in Polarity if n[p])
        answer = self._answer_line()
        return f"<Report {s.name}: {answer + '; ' if answer else ''}{len(self.conditions)} results ({counts})>"


def jsonable(x: Any) -> Any:
    """Convert numpy scalars, complex numbers, fractions and tuples into JSON-ready values.

    Complex numbers become ``[re, im]`` pairs (plain numbers when the imaginary part is
    exactly zero); fractions become floats; non-finite floats become strings.
    """
    if x is None or isinstance(x, (bool, str)):
        return x
    if isinstance(x, Enum):
        return x.value
    if isinstance(x, (int, np.integer)):
        return int(x)
    if isinstance(x, Fraction):
        return float(x) if x.denominator != 1 else int(x)
    if isinstance(x, (float, np.floating)):
        f = float(x)
        return f if math.isfinite(f) else str(f)
    if isinstance(x, (complex, np.complexfloating)):
        c = complex(x)
        if c.imag == 0.0:
            return jsonable(c.real)
        return [jsonable(c.real), jsonable(c.imag)]
    if isinstance(x, np.ndarray):
        return [jsonable(v) for v in x.tolist()]
    if isinstance(x, Mapping):
        return {str(k): jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple, set, frozenset)):
        return [jsonable(v) for v in x]
    if hasattr(x, "p") and hasattr(x, "q"):  # flint.fmpq
        return jsonable(Fraction(int(x.p), int(x.q)))
    return str(x)


class _PreviewFull(Exception):
    """Raised by :func:`json_preview` once the text is longer than its limit."""


def json_preview(x: Any, limit: int, separators: tuple[str, str] = (", ", ": ")) -> str:
    """``json.dumps(jsonable(x), separators=separators)``, cut to ``limit`` characters with "...".

    The text is encoded from the front and encoding stops once it passes ``limit``: a witness
    with N-long vectors costs what its first ``limit`` characters cost, not O(N) conversions.
    The result equals the full encoding when that fits, else its first ``limit - 3``
    characters followed by "...".
    """
    item_sep, key_sep = separators
    parts: list[str] = []
    size = 0

    def emit(text: str) -> None:
        nonlocal size
        parts.append(text)
        size += len(text)
        if size > limit:
            raise _PreviewFull

    def walk(v: Any) -> None:
        if isinstance(v, Mapping):
            emit("{")
            for i, (k, w) in enumerate(v.items()):
                if i:
                    emit(item_sep)
                emit(json.dumps(str(k)))
                emit(key_sep)
                walk(w)
            emit("}")
        elif isinstance(v, np.ndarray):
            walk(v.tolist())  # Python scalars, as jsonable reads an array (one C-level conversion)
        elif isinstance(v, (list, tuple, set, frozenset)):
            emit("[")
            for i, w in enumerate(v):
                if i:
                    emit(item_sep)
                walk(w)
            emit("]")
        else:
            emit(json.dumps(jsonable(v), separators=separators))

    try:
        walk(x)
    except _PreviewFull:
        text = "".join(parts)
        return text[: limit - 3] + "..."
    return "".join(parts)


def vector_json(labels: Sequence[Any], v: Any, *, cut: float | None = None, zeros: bool = False) -> dict[Any, Any]:
    """A witness vector by label at full double precision: the one encoding of xi and u0 of a ZDA.

    An entry is a float when its imaginary part is exactly 0, else a Python complex (``[re,
    im]`` in JSON, :func:`jsonable` and :func:`audit_jsonable`).

    Parameters
    ----------
    labels : sequence
        The key of each entry (agent labels; the audit passes them as strings).
    v : array_like
        The vector, one entry per label.
    cut : float, optional
        Keep only the entries above ``cut`` times the largest magnitude (none when that is 0
        or not finite): the audit's rows, at the tolerance's rtol. Default: no relative cut,
        so a tiny entry is kept and the residual is not lost.
    zeros : bool
        Keep the entries that are exactly 0.0 too (an input direction u0, listed whole).
    """
    a = np.asarray(v)
    keep: Any = range(len(labels))
    if cut is not None:
        mag = np.abs(a)
        big = float(np.max(mag, initial=0.0))
        if big <= 0.0 or not math.isfinite(big):
            return {}
        keep = np.flatnonzero(mag / big > cut).tolist()
    out: dict[Any, Any] = {}
    for k in keep:
        c = complex(a[k])
        if zeros or c != 0:
            out[labels[k]] = c.real if c.imag == 0 else c
    return out


def audit_jsonable(x: Any) -> Any:
    """An audit value in JSON form: tuples as lists, complex numbers as ``[re, im]``,
    non-finite floats as strings, numpy scalars as Python numbers, statuses as their value."""
    if isinstance(x, dict):
        return {str(k): audit_jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [audit_jsonable(v) for v in x]
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
