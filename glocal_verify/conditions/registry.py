"""The condition catalogue and the checker registry.

Each condition of ``docs/conditions.md`` has a public id, a paper reference and a one-line
statement (:data:`CATALOGUE`). Checker functions register themselves with :func:`checker`;
:func:`verify` runs the registered checkers on a :class:`~glocal_verify.model.System` and
collects a :class:`~glocal_verify.results.Report`.
"""

from __future__ import annotations

import difflib
import importlib
from dataclasses import dataclass, field
from typing import Any, Callable, Iterable, Mapping, Sequence

from glocal_verify.errors import UnknownConditionError
from glocal_verify.model import System
from glocal_verify.numerics.tolerance import DEFAULT_TOLERANCE, Tolerance
from glocal_verify.results import (
    ConditionResult,
    Finding,
    Method,
    Report,
    Status,
    SystemInfo,
)

__all__ = [
    "ConditionInfo",
    "CATALOGUE",
    "CheckContext",
    "checker",
    "finding_rule",
    "result",
    "implemented_ids",
    "resolve_ids",
    "verify",
]

@dataclass(frozen=True, slots=True)
class ConditionInfo:
    """Catalogue entry of a condition."""

    id: str
    reference: str
    statement: str


_ENTRIES = [
    ("switched-observability", "Lemma II.3", "The switched pair (A_sigma, C) over the mode sequence is observable: N_1^m = {0}."),
    ("stealthy.zda", "Proposition II.4 (ii), Definition II.2", "A stealthy zero-dynamics attack exists for (A_1, B, C, 0)."),
    ("stealthy.covert", "Proposition II.4 (i)", "A covert attack is feasible: every monitored channel reached by u_a is compromised."),
    ("privacy.connected", "Lemma III.1", "The communication graph G_q is connected."),
    ("privacy.kernel", "Lemma III.1", "[1; 0] lies in ker C (no position of any agent is monitored globally)."),
    ("privacy.unobservable", "Lemma III.1", "span{[1; 0]} is A_q-invariant and unobservable in every mode and for the switched system."),
    ("privacy.initial-state", "Problem 1 (i)", "The initial state x(t0) cannot be reconstructed from the global measurements."),
    ("privacy.consensus-value", "Problem 1 (i)", "The consensus value x* = (1/N) 1^T x(t0) cannot be reconstructed."),
    ("local.k-connected", "Proposition III.2 (i)", "The observer centre has degree >= inter-cluster edges + suspected agents of the cluster."),
    ("local.rank", "Proposition III.2 (ii)", "rank(C_loc E^i) = rank(E^i)."),
    ("local.pencil", "Proposition III.2 (iii)", "[[lam I - A^i, -B^i, E^i], [C_loc, 0, 0]] has full column rank for every complex lam."),
    ("local.uio", "Proposition III.2, eqs. uio_conds_1-uio_conds_3", "An unknown-input observer for the cluster exists and is verified."),
    ("central.observer", "eq. obs_cent", "A_1 - H C is stable on the observable part; fixed unobservable eigenvalues reported."),
    ("switching.image-kernel", "Theorem III.3 (i)", "Im(dL_q) ∩ ker([S_Mx; S_Mv]) = {0}, i.e. rank(S_M dL_q) = rank(dL_q)."),
    ("switching.distinct-eigenvalues", "Theorem III.3 (ii)", "L_q has N distinct eigenvalues."),
    ("switching.eigenvector-differences", "Theorem III.3 (iii)", "[U_q]_{i,l} != [U_q]_{j,l} for every l != 1 and every pair i != j in one component D_c."),
    ("switching.coverage", "Lemma A.2", "Every component D_c of the switching links contains a globally monitored agent."),
    ("switching.safe", "Remark III.3.1, eq. unsafe_set", "The switch does not touch the attack: some stealthy direction at lambda0 has dL_q xi = 0 (remark's reading; both readings reported)."),
    ("switching.detects", "Theorem III.3 (conclusion)", "After the switch the global residual leaves its attack-free band (simulation)."),
]

CATALOGUE: dict[str, ConditionInfo] = {cid: ConditionInfo(cid, ref, st) for cid, ref, st in _ENTRIES}

#: modules of this package that register checkers and finding rules (imported on first use)
CHECKER_MODULES = ("privacy", "switching", "observability", "stealthy", "safe_switch", "central", "local", "detects", "paper_findings")


@dataclass(frozen=True, slots=True)
class CheckContext:
    """Options every checker receives.

    Attributes
    ----------
    exact : bool
        Decide with exact rational arithmetic (python-flint) instead of floating point.
    tol : Tolerance
        Numeric tolerance (recorded in numeric results).
    options : mapping
        Free-form extra options (e.g. ``{"lambda0": 0.5}``).
    """

    exact: bool = False
    tol: Tolerance = DEFAULT_TOLERANCE
    options: Mapping[str, Any] = field(default_factory=dict)

    @property
    def method(self) -> Method:
        return Method.EXACT if self.exact else Method.NUMERIC


Checker = Callable[[System, CheckContext], list[ConditionResult]]
FindingRule = Callable[[System, Sequence[ConditionResult]], list[Finding]]

_CHECKERS: dict[str, Checker] = {}
_FINDINGS: list[FindingRule] = []
_loaded = False


def checker(cid: str) -> Callable[[Checker], Checker]:
    """Register ``func`` as the checker of condition ``cid`` (which must be in the catalogue)."""
    if cid not in CATALOGUE:
        raise ValueError(f"{cid!r} is not a catalogue id")

    def deco(func: Checker) -> Checker:
        _CHECKERS[cid] = func
        return func

    return deco


def finding_rule(func: FindingRule) -> FindingRule:
    """Register a rule that derives findings from a system and its verdicts."""
    _FINDINGS.append(func)
    return func


def result(
    cid: str,
    ctx: CheckContext,
    status: Status,
    *,
    scope: Mapping[str, Any] | None = None,
    margin: float | None = None,
    witness: Mapping[str, Any] | None = None,
    numeric_decision: bool = True,
) -> ConditionResult:
    """Build a :class:`ConditionResult` with the catalogue's reference and statement.

    ``numeric_decision=False`` marks a combinatorial decision (no tolerance involved).
    """
    info = CATALOGUE[cid]
    if ctx.exact and status is Status.UNDECIDED:
        raise AssertionError(f"{cid}: an exact decision cannot be undecided")
    tol = ctx.tol.rtol if (numeric_decision and not ctx.exact) else None
    return ConditionResult(
        id=cid,
        scope=dict(scope or {}),
        status=status,
        margin=None if margin is None else float(margin),
        tolerance=tol,
        method=ctx.method,
        witness=dict(witness or {}),
        reference=info.reference,
        statement=info.statement,
    )


def _load() -> None:
    global _loaded
    if _loaded:
        return
    for name in CHECKER_MODULES:
        importlib.import_module(f"{__package__}.{name}")
    _loaded = True


def implemented_ids() -> list[str]:
    """Ids with a registered checker, in catalogue order."""
    _load()
    return [cid for cid in CATALOGUE if cid in _CHECKERS]


def resolve_ids(ids: Iterable[str]) -> list[str]:
    """Validate condition ids (or prefixes ending in ``.``/``*``, e.g. ``switching.*``).

    Raises
    ------
    UnknownConditionError
        For an id that is not in the catalogue, naming the closest ids.
    """
    out: list[str] = []
    for raw in ids:
        cid = raw.strip()
        if not cid:
            continue
        if cid.endswith("*") or cid.endswith("."):
            prefix = cid.rstrip("*")
            matches = [c for c in CATALOGUE if c.startswith(prefix)]
            if not matches:
                raise UnknownConditionError(f"no condition id starts with {prefix!r}")
            out.extend(m for m in matches if m not in out)
            continue
        if cid not in CATALOGUE:
            close = difflib.get_close_matches(cid, list(CATALOGUE), n=3, cutoff=0.5)
            hint = f"; did you mean {', '.join(close)}?" if close else f"; known ids: {', '.join(CATALOGUE)}"
            raise UnknownConditionError(f"unknown condition id {cid!r}{hint}")
        if cid not in out:
            out.append(cid)
    return out


def verify(
    system: System,
    only: Iterable[str] | None = None,
    *,
    exact: bool = False,
    tol: Tolerance = DEFAULT_TOLERANCE,
    options: Mapping[str, Any] | None = None,
    progress: Callable[[str], None] | None = None,
) -> Report:
    """Run the registered checkers on ``system``.

    Parameters
    ----------
    system : System
    only : iterable of str, optional
        Condition ids (or prefixes such as ``"switching.*"``) to run; default all implemented.
    exact : bool
        Use the exact (rational) path of every checker.
    tol : Tolerance
        Numeric tolerance.
    options : mapping, optional
        Extra options passed to every checker through :class:`CheckContext`.
    progress : callable, optional
        Called with each condition id before it runs.

    Returns
    -------
    Report
    """
    _load()
    ids = resolve_ids(only) if only is not None else implemented_ids()
    ctx = CheckContext(exact=exact, tol=tol, options=dict(options or {}))
    results: list[ConditionResult] = []
    for cid in ids:
        if cid not in _CHECKERS:
            continue
        if progress:
            progress(cid)
        results.extend(_CHECKERS[cid](system, ctx))
    findings: list[Finding] = []
    for rule in _FINDINGS:
        findings.extend(rule(system, results))
    info = SystemInfo(system.name, system.n, system.modes, tuple(c.name for c in system.clusters))
    opts = {"exact": exact, "rtol": tol.rtol, "band": tol.band, "only": list(ids)}
    return Report(info, tuple(results), tuple(findings), opts)
