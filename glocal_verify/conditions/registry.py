"""The condition catalogue and the checker registry.

Each condition of ``docs/conditions.md`` has a public id, a paper reference and a one-line
statement (:data:`CATALOGUE`). Checker functions register themselves with :func:`checker`;
:func:`check_conditions` runs the registered checkers on a :class:`~glocal_verify.model.System` and
collects a :class:`~glocal_verify.results.Report`.
"""

from __future__ import annotations

import dataclasses
import importlib
import math
import time
from types import MappingProxyType
from dataclasses import dataclass, field
from typing import Any, Callable, Iterable, Mapping, Sequence

import numpy as np
import scipy.linalg

from glocal_verify import config
from glocal_verify.conditions.catalogue import CATALOGUE, ConditionInfo
from glocal_verify.conditions.premises import missing_input, vacuous_premise
from glocal_verify.errors import ArgumentError, GlocalVerifyError, ModelError, UnknownConditionError, did_you_mean, shorten
from glocal_verify.model import System
from glocal_verify.numerics.deadline import DeadlineExceeded, call_with_deadline
from glocal_verify.numerics.tolerance import DEFAULT_TOLERANCE, Tolerance
from glocal_verify.spec.arguments import callable_arg, choice_arg, id_list_arg, mapping_arg, real_arg
from glocal_verify.results import (
    ALIASES,
    AttackScenario,
    ScheduleInfo,
    ConditionResult,
    Finding,
    Method,
    Report,
    Status,
    SystemInfo,
    Verdict,
)

__all__ = [
    "ConditionInfo",
    "CATALOGUE",
    "CheckContext",
    "checker",
    "expect_system",
    "finding_rule",
    "result",
    "verdict_result",
    "implemented_ids",
    "resolve_ids",
    "system_info",
    "check_conditions",
]

#: modules of this package that register checkers and finding rules (imported on first use)
CHECKER_MODULES = ("privacy", "switching", "observability", "stealthy", "safe_switch", "central", "local", "detects", "sampled", "detection", "paper_findings")


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
    fragile_below : float
        Robustness tolerance: a result whose margin (on a relative scale) is below it is
        marked ``fragile`` (default: the tunable ``fragile_below`` of :mod:`glocal_verify.config`, 1e-9).
    escalated : bool
        This exact run re-decides a numeric ``undecided`` (results say ``exact (escalated)``).
    """

    exact: bool = False
    tol: Tolerance = DEFAULT_TOLERANCE
    options: Mapping[str, Any] = field(default_factory=dict)
    fragile_below: float = field(default_factory=lambda: float(config.get("fragile_below")))
    escalated: bool = False

    @property
    def method(self) -> Method:
        if self.exact:
            return Method.ESCALATED if self.escalated else Method.EXACT
        return Method.NUMERIC


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
    error_bound: float | None = None,
    note: str = "",
    premise: str | None = None,
) -> ConditionResult:
    """Build a :class:`ConditionResult` with the catalogue's reference, statement and polarity.

    ``numeric_decision=False`` marks a combinatorial decision (no tolerance involved).
    ``premise`` names the condition's premise that is absent on this system: the result is
    then vacuous (:attr:`ConditionResult.polarity`) and never ``fragile``.
    ``favourable`` follows the catalogue; ``fragile`` is set when the condition's margin is a
    relative distance to its boundary and a ``holds`` lies below ``ctx.fragile_below`` (a
    failure of a rank or gap condition is an exact zero, not a distance; an undecided result
    has no known margin).
    """
    info = CATALOGUE[cid]
    if ctx.exact and status is Status.UNDECIDED:
        raise AssertionError(f"{cid}: an exact decision cannot be undecided")
    tol = ctx.tol.rtol if (numeric_decision and not ctx.exact) else None
    favourable = None if status is Status.UNDECIDED else status is info.favourable
    fragile = (
        not premise
        and info.margin_is_distance
        and status is Status.HOLDS
        and margin is not None
        and math.isfinite(float(margin))
        and abs(float(margin)) < ctx.fragile_below
    )
    if status is Status.UNDECIDED and not note:
        note = "the certified error bound does not separate the cases (see the witness)"
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
        favourable=favourable,
        fragile=bool(fragile),
        error_bound=None if error_bound is None else float(error_bound),
        note=note,
        premise=premise or None,
    )


def verdict_result(cid: str, ctx: CheckContext, verdict: Verdict, *, scope: Mapping[str, Any] | None = None) -> ConditionResult:
    """The :class:`ConditionResult` of condition ``cid`` in ``scope`` from the analysis layer's ``verdict``.

    A combinatorial verdict records no tolerance. In an exact run (``ctx.exact``) a verdict
    that is neither exact nor combinatorial is the certified numeric fallback of a question
    exact arithmetic could not settle: its result is built in a numeric context (method
    ``numeric``, the run's tolerance), the only way an exact run reports a numeric result.
    The verdict's ``premise`` (an absent premise: a vacuous verdict) becomes the result's.

    Parameters
    ----------
    cid : str
        Catalogue id.
    ctx : CheckContext
        The run's options.
    verdict : Verdict
        The decision, from ``glocal_verify.analysis`` (or ``glocal_verify.observers``).
    scope : mapping, optional
        The result's scope (empty: global).
    """
    if ctx.exact and not (verdict.exact or verdict.combinatorial):
        ctx = dataclasses.replace(ctx, exact=False, escalated=False)
    return result(
        cid,
        ctx,
        verdict.status,
        scope=scope,
        margin=verdict.margin,
        witness=verdict.witness,
        numeric_decision=not verdict.combinatorial,
        error_bound=verdict.error_bound,
        note=verdict.note,
        premise=verdict.premise,
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
            matches = [c for c in CATALOGUE if c.startswith(prefix)] + [ALIASES[a] for a in ALIASES if a.startswith(prefix)]
            if not matches:
                raise UnknownConditionError(f"no condition id starts with {prefix!r}")
            out.extend(m for m in matches if m not in out)
            continue
        cid = ALIASES.get(cid, cid)
        if cid not in CATALOGUE:
            hint = did_you_mean(cid, [*CATALOGUE, *ALIASES], otherwise=f"; known ids: {', '.join(CATALOGUE)}")
            raise UnknownConditionError(f"unknown condition id {shorten(repr(cid), 80)}{hint}")
        if cid not in out:
            out.append(cid)
    return out


def _scope_key(r: ConditionResult) -> tuple[tuple[str, str], ...]:
    return tuple(sorted((str(k), repr(v)) for k, v in r.scope.items()))


def _escalate(
    system: System, cid: str, numeric: list[ConditionResult], ctx: CheckContext, budget: float | None, spent_note: str = ""
) -> list[ConditionResult]:
    """Re-decide the undecided results of one checker in exact arithmetic (rational weights).

    Decided numeric results are kept (they are certified); each undecided one is replaced by
    the exact result of the same scope. The exact run is stopped after ``budget`` seconds
    (:func:`~glocal_verify.numerics.deadline.call_with_deadline`, a hard limit); the
    undecided results then stay, with a note saying so. ``budget == 0`` means the run's
    budget is already spent: nothing is computed and ``spent_note`` says why.
    """
    if not any(r.status is Status.UNDECIDED for r in numeric):
        return numeric

    def keep(note: str) -> list[ConditionResult]:
        return [dataclasses.replace(r, note=f"{r.note}; {note}" if r.note else note) if r.status is Status.UNDECIDED else r for r in numeric]

    if budget is not None and budget <= 0:
        return keep(spent_note or "undecided numerically; no time was left for an exact re-decision (--exact-budget)")
    exact_ctx = CheckContext(exact=True, tol=ctx.tol, options=ctx.options, fragile_below=ctx.fragile_below, escalated=True)
    t0 = time.perf_counter()
    try:
        exact = call_with_deadline(lambda: _run_checker(system, cid, exact_ctx), budget)
    except DeadlineExceeded:
        return keep(f"undecided numerically; the exact re-decision was stopped after {budget:.3g} s, its share of --exact-budget (raise it, or run --exact)")
    except ModelError as exc:
        return keep(f"undecided numerically; the exact re-decision failed too ({exc})")
    took = time.perf_counter() - t0
    if len(numeric) == 1 and "numerical_failure" in numeric[0].witness:
        why = numeric[0].note
        return [dataclasses.replace(e, note=f"escalated to exact arithmetic ({took:.2g} s): {why}") for e in exact]
    by_scope = {_scope_key(r): r for r in exact}
    out = []
    for r in numeric:
        if r.status is not Status.UNDECIDED:
            out.append(r)
            continue
        e = by_scope.get(_scope_key(r))
        if e is None:
            out.append(dataclasses.replace(r, note=f"{r.note}; the exact run has no result for this scope"))
        else:
            why = r.note or "the certified error bound did not separate the cases"
            out.append(dataclasses.replace(e, note=f"escalated to exact arithmetic ({took:.2g} s): {why}"))
    return out


#: exceptions a numerical routine may raise on data it cannot handle (non-convergence,
#: overflow, non-finite intermediate values); a checker that raises one is undecided, not a crash
NUMERICAL_FAILURES: tuple[type[BaseException], ...] = (
    np.linalg.LinAlgError,
    scipy.linalg.LinAlgError,
    ArithmeticError,  # OverflowError, ZeroDivisionError, FloatingPointError
    ValueError,  # numpy/scipy: "array must not contain infs or NaNs", QZ reordering failed ...
    RecursionError,
)


def _with_premise(system: System, r: ConditionResult) -> ConditionResult:
    """``r`` marked vacuous when its premise is absent (:func:`~glocal_verify.conditions.premises.vacuous_premise`)."""
    if r.premise or r.status is Status.UNDECIDED:
        return r
    why = vacuous_premise(system, r.id, r.scope)
    return r if why is None else dataclasses.replace(r, premise=why, fragile=False)


def _run_checker(system: System, cid: str, ctx: CheckContext) -> list[ConditionResult]:
    """Run one checker; a numerical failure of a numeric run becomes one undecided result.

    The spec's own problems are :class:`~glocal_verify.errors.GlocalVerifyError` and pass
    through. In exact mode a failure is re-raised as a :class:`ModelError` (exact results are
    never undecided).
    """
    try:
        return [_with_premise(system, r) for r in _CHECKERS[cid](system, ctx)]
    except GlocalVerifyError:
        raise
    except NUMERICAL_FAILURES as exc:
        why = f"{type(exc).__name__}: {str(exc).splitlines()[0][:160] if str(exc) else 'no message'}"
        if ctx.exact:
            raise ModelError(f"{cid}: the exact computation failed ({why})") from None
        note = f"the numerical computation failed ({why}); no verdict can be certified from it"
        return [result(cid, ctx, Status.UNDECIDED, note=note, witness={"numerical_failure": why})]


#: exact re-decisions whose cost grows fastest with N (dense rational characteristic
#: polynomials, the exact V* of a pencil with genuine zeros): escalated after the others, so
#: that they cannot spend the budget the cheap ones need
_COSTLY_EXACT: Mapping[str, int] = MappingProxyType({"central.observer": 2, "stealthy.zda": 1, "switching.avoids-attack": 1})

#: what an estimate may raise; it then gives no estimate (the budget alone limits the run)
_ESTIMATE_FAILURES: tuple[type[BaseException], ...] = (GlocalVerifyError, *NUMERICAL_FAILURES)


def exact_estimate(system: System, cid: str) -> float | None:
    """Estimated seconds of re-deciding checker ``cid`` exactly on ``system``, or None (no estimate).

    From the one exact-cost model, :func:`glocal_verify.conditions.exact_cost.exact_seconds`, for the
    checkers whose exact cost is one dense rational computation of known size:
    ``central.observer``, ``local.pencil`` and ``local.uio`` (every case of every cluster over
    Q, the local terms of ``verify --exact``'s estimate), and ``stealthy.zda`` / ``switching.avoids-attack``, whose path is
    learnt from the minor certificate (:func:`~glocal_verify.analysis.stealthy.zda_exact.has_fast_exact_path`)
    while that certificate costs at most ``zda_certificate_max_seconds``
    (:mod:`glocal_verify.config`; N <~ 1700); beyond, the path is unknown and the estimate is
    the larger of the certificate's cost and the fast path's (a lower bound of either path:
    an escalation it keeps from starting could not have finished).

    Parameters
    ----------
    system : System
    cid : str
    """
    from glocal_verify.conditions.exact_cost import exact_seconds, zda_certificate_seconds

    if cid == "central.observer":
        return exact_seconds(cid, system.n)
    if cid in ("local.pencil", "local.uio"):
        # the re-decision runs the checker over Q on every case of every cluster: the local
        # terms of the same model (``verify --exact``'s estimate)
        from glocal_verify.conditions.cost import SpecSizes, estimate_verify

        phases = dict(estimate_verify(SpecSizes.from_spec(system.spec), [cid], exact=True, exact_budget=None).phases)
        return phases.get(f"exact {cid}")
    if cid not in ("stealthy.zda", "switching.avoids-attack"):
        return None
    from glocal_verify.analysis.stealthy.zda_screens import minor_tables_affordable

    certificate = zda_certificate_seconds(system.n)
    if not minor_tables_affordable(system.n):
        # the path is unknown: the cheaper one (the fast path) bounds the cost from below
        return max(certificate, exact_seconds(cid, system.n, zda_path="fast"))
    from glocal_verify.analysis.stealthy.zda_exact import has_fast_exact_path

    try:
        fast = has_fast_exact_path(system)
    except _ESTIMATE_FAILURES:
        return None  # no estimate: the budget alone limits it
    return exact_seconds(cid, system.n, zda_path="fast" if fast else "dense")


#: checkers whose undecided result is not re-decided exactly (the simulation is the evidence)
_NOT_ESCALATED = frozenset({"switching.detects", "detection.thresholds", "detection.local-alarm", "detection.guarantee"})


def _escalate_all(
    system: System,
    per_checker: dict[str, list[ConditionResult]],
    ctx: CheckContext,
    budget: float | None,
    progress: Callable[[str], None] | None,
) -> None:
    """Escalate every undecided checker in place, within one total ``budget`` (``verify``)."""
    pending = [cid for cid, rs in per_checker.items() if cid not in _NOT_ESCALATED and any(r.status is Status.UNDECIDED for r in rs)]
    pending.sort(key=lambda cid: _COSTLY_EXACT.get(cid, 0))
    if budget is not None:
        # an escalation estimated far beyond the whole budget (a fraction of its estimate above
        # it: the model holds within a factor of about two) is not started, and takes no share
        fraction = config.get("escalation_estimate_fraction")
        estimates = {c: est for c in pending if (est := exact_estimate(system, c)) is not None}
        for cid in [c for c, est in estimates.items() if fraction * est > budget]:
            note = (
                f"undecided numerically; an exact re-decision would take at least about {estimates[cid]:.3g} s at "
                f"N = {system.n} (estimate), more than --exact-budget ({budget:g} s), so it was not started (run --exact, or raise --exact-budget)"
            )
            per_checker[cid] = _escalate(system, cid, per_checker[cid], ctx, 0.0, note)
            pending.remove(cid)
    end = None if budget is None else time.perf_counter() + budget
    for i, cid in enumerate(pending):
        share: float | None = None
        if end is not None:
            share = max(0.0, (end - time.perf_counter()) / (len(pending) - i))
        spent = f"undecided numerically; the exact budget of {budget:g} s (--exact-budget) was spent on other escalations" if budget is not None else ""
        if progress and (share is None or share > 0):
            progress(f"{cid} (exact re-decision" + (f", up to {share:.0f} s)" if share is not None else ")"))
        per_checker[cid] = _escalate(system, cid, per_checker[cid], ctx, share, spent)


def system_info(system: System) -> SystemInfo:
    """What a report says of ``system``: sizes, modes, clusters, the attack split by cluster and the schedule."""
    attack = None
    atk = system.spec.attack
    if atk is not None:
        split: list[tuple[str | None, tuple[Any, ...], tuple[Any, ...]]] = []
        for c in system.clusters:
            mine = tuple(a for a in atk.actuators if a in set(c.nodes))
            if mine:
                split.append((c.name, mine, tuple(o.center for o in c.observers)))
        placed = {a for _, xs, _ in split for a in xs}
        if rest := tuple(a for a in atk.actuators if a not in placed):
            split.append((None, rest, ()))
        attack = AttackScenario(atk.kind, tuple(atk.actuators), tuple(split), atk.lambda0)
    schedule = None
    sw = system.spec.switching
    if sw is not None and (sw.mode is not None or sw.sequence):
        if sw.sequence:
            visits = [st.mode for st in sw.sequence]
            text = " -> ".join(f"{st.mode}({st.duration:g})" for st in sw.sequence)
        else:
            visits = [str(sw.mode)]
            text = f"normal until t = {sw.time:g}, then {sw.mode}"
        safe = tuple(dict.fromkeys(m for m in visits if m != system.modes[0]))
        schedule = ScheduleInfo(safe, text)
    return SystemInfo(system.name, system.n, system.modes, tuple(c.name for c in system.clusters), attack, schedule, bool(system.monitored))
def expect_system(system: Any, who: str = "verify") -> System:
    """``system`` when it is a :class:`~glocal_verify.model.System`, else
    :class:`~glocal_verify.errors.ArgumentError` naming ``who``."""
    if not isinstance(system, System):
        raise ArgumentError(f"{who}: expected a System, got {type(system).__name__}")
    return system


def _verify_arguments(
    system: Any, only: Any, exact: Any, tol: Any, escalate: Any, exact_budget: Any, fragile_below: Any, options: Any = None, progress: Any = None
) -> tuple[System, list[str] | None, float | None, float | None]:
    """The arguments of :func:`check_conditions` checked against their documented domains
    (:class:`~glocal_verify.errors.ArgumentError` naming the first one outside)."""
    expect_system(system)
    mapping_arg("options", options)
    callable_arg("progress", progress)
    if not isinstance(exact, bool):
        raise ArgumentError(f"exact: expected True or False, got {exact!r}"[:120])
    if not isinstance(tol, Tolerance):
        raise ArgumentError(f"tol: expected a Tolerance, got {type(tol).__name__}")
    choice_arg("escalate", escalate, ("auto", "never"))
    budget = None if exact_budget is None else real_arg("exact_budget", config.resolve("exact_budget", exact_budget), 0.0, allow_inf=True)
    if budget is not None and (budget == 0.0 or math.isinf(budget)):
        budget = None  # no limit
    fb = None if fragile_below is None else real_arg("fragile_below", fragile_below, 0.0, allow_inf=True)
    return system, id_list_arg("only", only), budget, fb


def check_conditions(
    system: System,
    only: Iterable[str] | None = None,
    *,
    exact: bool = False,
    tol: Tolerance = DEFAULT_TOLERANCE,
    options: Mapping[str, Any] | None = None,
    progress: Callable[[str], None] | None = None,
    escalate: str = "auto",
    exact_budget: float | None = config.IN_FORCE,
    fragile_below: float | None = None,
) -> Report:
    """Run the registered checkers on ``system``: the report without its assessment.

    The public :func:`glocal_verify.verify` calls it, adds the simulation of
    ``switching.detects`` by one option and attaches the assessment.

    Parameters
    ----------
    system : System
    only : iterable of str, optional
        Condition ids (or prefixes such as ``"switching.*"``) to run; default all implemented.
        Old ids of :data:`ALIASES` are accepted.
    exact : bool
        Use the exact (rational) path of every checker.
    tol : Tolerance
        Numeric tolerance.
    options : mapping, optional
        Extra options passed to every checker through :class:`CheckContext`.
    progress : callable, optional
        Called with each condition id before it runs. A condition with nothing to evaluate on
        this system (:func:`~glocal_verify.conditions.premises.missing_input`: no
        ``[implementation]``, no attack ...) is neither run nor announced; the report's
        ``options["skipped"]`` says why (``options["selected"]``: ``only`` was given).
    escalate : {"auto", "never"}
        ``"auto"``: a numeric ``undecided`` is re-decided by the checker's exact path (the
        spec's weights are rational), within ``exact_budget``; the result then says
        ``method: exact (escalated)``.
    exact_budget : float or None
        Seconds of wall time for all escalated exact runs of this call together, a real
        number >= 0 (None, 0 or ``inf``: no limit; default the tunable ``exact_budget`` of
        :mod:`glocal_verify.config` in force, 30 s). They run after every numeric checker, the cheap ones first; each gets a fair
        share of what is left (what it does not use passes on) and is stopped, not merely
        warned, at the end of its share. One whose estimated cost (:func:`exact_estimate`)
        times ``escalation_estimate_fraction`` (:mod:`glocal_verify.config`) exceeds the whole
        budget is not started and takes no share; its note gives the estimate.
    fragile_below : float, optional
        Robustness tolerance, a real number >= 0: a verdict whose relative margin is below it
        is ``fragile`` (a warning; the status never changes). Default: the tunable
        ``fragile_below`` (:mod:`glocal_verify.config`, 1e-9).

    Returns
    -------
    Report

    Raises
    ------
    ArgumentError
        An argument outside its domain (a non-``System``, an unknown ``escalate``, a NaN or
        negative ``exact_budget`` ...), naming it.
    UnknownConditionError
        An id of ``only`` that is not in the catalogue.
    """
    system, only, exact_budget, fragile_below = _verify_arguments(system, only, exact, tol, escalate, exact_budget, fragile_below, options, progress)
    _load()
    ids = resolve_ids(only) if only is not None else implemented_ids()
    fragile_below = float(config.resolve("fragile_below", fragile_below))
    ctx = CheckContext(exact=exact, tol=tol, options=dict(options or {}), fragile_below=fragile_below)
    per_checker: dict[str, list[ConditionResult]] = {}
    skipped: dict[str, str] = {}
    for cid in ids:
        if cid not in _CHECKERS:
            continue
        why = missing_input(system, cid, exact=exact, options=ctx.options)
        if why is not None:  # nothing to evaluate: neither run nor announced, but said
            skipped[cid] = why
            continue
        if progress:
            progress(cid)
        per_checker[cid] = _run_checker(system, cid, ctx)
        if not per_checker[cid]:
            skipped[cid] = "the checker found nothing to evaluate on this system"
    if not exact and escalate == "auto":
        _escalate_all(system, per_checker, ctx, exact_budget, progress)
    results = [r for rs in per_checker.values() for r in rs]
    findings: list[Finding] = []
    for rule in _FINDINGS:
        try:
            findings.extend(rule(system, results))
        except NUMERICAL_FAILURES:  # a finding is an extra: its numerics failing costs no verdict
            continue
    info = system_info(system)
    opts = {
        "exact": exact,
        "rtol": tol.rtol,
        "band": tol.band,
        "only": list(ids),
        "escalate": escalate,
        "exact_budget": exact_budget,
        "fragile_below": fragile_below,
        "simulate": bool(ctx.options.get("simulate")),
        "selected": only is not None,
        "skipped": skipped,
    }
    return Report(info, tuple(results), tuple(findings), opts)
