"""Which attackers can hide in the network? An audit over every small set of compromised actuators.

For every set F of 1..k actuators among the candidates, :func:`audit` answers the questions of
Problem 2 with the checkers' own analyses, reusing one spectral decomposition per mode:

* **stealthy** -- does a stealthy ZDA exist for (A_1, B_F, C, 0) (Proposition II.4 (ii),
  ``stealthy.zda``): the system is not left-invertible, or the Rosenbrock pencil has a zero
  with an input direction u0 != 0. ``growth`` is the class of the fastest such ZDA
  (``unbounded`` also when the system is not left-invertible: every lambda0 is available),
  ``null`` when none exists; ``lambda0`` is the exponent ``stealthy.zda`` reports as witness
  (the spec's ``attack.lambda0`` when a ZDA exists there, else the fastest-growing zero, else 1).
* **caught_locally_by** -- the local observers of the clusters F meets for which
  Proposition III.2 (iii) holds with the suspected set F ∩ P_i (``local.pencil``) and the
  unknown-input observer exists and verifies (``local.uio``).
* **exposed_by_modes** -- the safe modes q for which Theorem III.3 (i)-(iii) hold and every
  stealthy direction at lambda0 is touched by the switch, dL_q xi != 0
  (``switching.avoids-attack`` fails, :mod:`glocal_verify.analysis.switching.avoidance`).
* **verdict** -- ``detected`` when no stealthy ZDA exists, or every cluster F meets has a
  catching observer (any nonzero attack input has a nonzero part in some such cluster, whose
  pencil has full column rank for every lam), or some safe mode exposes it; ``undetected``
  when a stealthy ZDA exists and every one of these tests is decided against detection;
  ``undecided`` otherwise.

Structural screen
    A separator of fewer than |F| agents between F and M proves the system not
    left-invertible for every choice of the weights
    (:func:`glocal_verify.design.audit_screens.disjoint_paths`, with the proof).

Tolerances and exactness
    Every numeric decision is the checkers' (``DEFAULT_TOLERANCE`` unless given). A numeric
    ``undecided`` part of a row is re-decided in exact arithmetic (the spec's weights are
    rational) when ``exact_fallback`` is on (default for N <= 20; for N <= 60 only where the
    row's verdict depends on it), as ``verify`` escalates; ``exact=True`` decides every row
    over Q.

Chunks
    :func:`audit_chunks` splits the sets into picklable callables (:class:`AuditChunk`) that
    return rows; an executor (e.g. Dask) may run them anywhere and :func:`merge_chunks`
    assembles the :class:`AuditResult`.
"""

from __future__ import annotations

import dataclasses
import functools
import itertools
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from glocal_verify import config
from glocal_verify.analysis.switching.avoidance import decide_avoidance
from glocal_verify.analysis.stealthy.zda_screens import disjoint_paths, global_tables
from glocal_verify.analysis.stealthy.zda_verdict import ZdaOptions, ZdaVerdict, decide_zda, prepare_witnesses, proven_single
from glocal_verify.answer.attack import THEOREM_IDS, AttackAnswer, AttackEvidence, LocalEvidence, ModeEvidence, answer_attack
from glocal_verify.conditions.registry import system_info, check_conditions
from glocal_verify.conditions.safe_switch import predicted_residual
from glocal_verify.design.audit_local import local_part
from glocal_verify.design.audit_records import AUDIT_SCHEMA_ID, AuditResult, AuditRow, SharedParts
from glocal_verify.errors import ArgumentError, ModelError, NotApplicableError
from glocal_verify.model import System
from glocal_verify.numerics.collection import deferred_full_collections, release_freed_memory
from glocal_verify.numerics.minors import GroundedTables
from glocal_verify.numerics.tolerance import DEFAULT_TOLERANCE, Tolerance
from glocal_verify.results import Status, vector_json
from glocal_verify.spec.arguments import choice_arg, integer_arg
from glocal_verify.spec.types import Label

__all__ = [
    "AUDIT_SCHEMA_ID",
    "AuditChunk",
    "AuditResult",
    "AuditRow",
    "LocalSinglesChunk",
    "attack_sets",
    "audit",
    "audit_chunks",
    "disjoint_paths",
    "local_singles_chunks",
    "merge_chunks",
    "mode_conditions",
    "mode_theorem",
    "seed_chunks",
]


# ------------------------------------------------------------------------------------------
# shared, set-independent parts


def attack_sets(system: System, max_attackers: int = 2, candidates: Iterable[Label] | None = None) -> list[tuple[Label, ...]]:
    """Every set of 1..``max_attackers`` candidate actuators, by size then label order.

    Parameters
    ----------
    system : System
    max_attackers : int
        k >= 1, at most the number of candidates.
    candidates : iterable of labels, optional
        Default every agent.

    Raises
    ------
    NotApplicableError
        k < 1 or larger than the number of candidates, or no candidates.
    ModelError
        A candidate is not in the graph.
    """
    cand = _candidates(system, candidates)
    k = int(max_attackers)
    if k < 1:
        raise NotApplicableError(f"--max-attackers: must be at least 1, not {k}")
    if k > len(cand):
        raise NotApplicableError(f"--max-attackers: {k} is larger than the number of candidate agents ({len(cand)})")
    return [F for size in range(1, k + 1) for F in itertools.combinations(cand, size)]


def _candidates(system: System, candidates: Iterable[Label] | None) -> tuple[Label, ...]:
    if candidates is None:
        return system.labels
    raw = list(candidates)
    bad = [a for a in raw if a not in system.index]
    if bad:
        raise ModelError(f"--agents: {', '.join(map(str, bad))} {'is' if len(bad) == 1 else 'are'} not in the graph")
    if not raw:
        raise NotApplicableError("--agents: the candidate set is empty")
    want = set(raw)
    return tuple(a for a in system.labels if a in want)


def mode_theorem(system: System, tol: Tolerance = DEFAULT_TOLERANCE, *, exact: bool = False) -> dict[str, dict[str, Status]]:
    """Theorem III.3 (i)-(iii) per safe mode, by their checkers (independent of the attack).

    Numeric ``undecided`` results are escalated to exact arithmetic as ``verify`` escalates them.

    Returns
    -------
    dict
        ``{mode: {condition id: Status}}``.
    """
    if not system.safe_modes:
        return {}
    rep = check_conditions(system, list(THEOREM_IDS), exact=exact, tol=tol)
    return {mode: {r.id: r.status for r in rep.conditions if r.scope.get("mode") == mode} for mode in system.safe_modes}


def mode_conditions(system: System, tol: Tolerance = DEFAULT_TOLERANCE, *, exact: bool = False) -> dict[str, bool | None]:
    """Theorem III.3 (i)-(iii) per safe mode: True when all hold, False when one fails, None otherwise."""
    return _theorem_ok(mode_theorem(system, tol, exact=exact))


def _theorem_ok(theorem: Mapping[str, Mapping[str, Status]]) -> dict[str, bool | None]:
    out: dict[str, bool | None] = {}
    for mode, sts in theorem.items():
        st = list(sts.values())
        out[mode] = False if any(s is Status.FAILS for s in st) else (True if st and all(s is Status.HOLDS for s in st) else None)
    return out


class _ProcessMemo:
    """The memo of the chunks one process runs: one dict, seeded once by phase one.

    What a chunk keeps between its sets is per network, agent, observer or suspected set
    (the minor tables' polynomials and random combinations, local verdicts, components); the
    per-set entries are removed once used. The chunks a process runs share it, as the serial
    audit always did: a Dask worker that started each chunk from the seed alone rebuilt the
    same per-network entries 1,250 times (at N = 1000, k = 2: the random combinations of the
    minor certificate were 37 % of the workers' time). It travels empty: each worker builds
    its own. Workers run one task at a time (``threads_per_worker=1``); with more threads the
    chunks still read consistent entries (each is written once, whole) and at worst compute
    one twice.
    """

    def __init__(self) -> None:
        self._memo: dict[Any, Any] | None = None

    def __reduce__(self) -> tuple[type, tuple[()]]:
        return (_ProcessMemo, ())

    def memo(self, seed: Mapping[Any, Any]) -> dict[Any, Any]:
        """The process's memo, seeded with ``seed`` on first use."""
        if self._memo is None:
            self._memo = dict(seed)
        return self._memo


@dataclass(frozen=True)
class _Shared:
    """What every set reuses: the system, its mode verdicts, the schedule, options."""

    system: System
    tol: Tolerance
    theorem: Mapping[str, Mapping[str, Status]]
    lambda0: complex | None
    exact: bool
    exact_fallback: bool
    screen: bool
    minors: GroundedTables | None = None
    local_seed: Mapping[Any, Any] = field(default_factory=dict)
    #: the exact fallback of the ZDA and safe-mode parts: "always" (with ``exact_fallback``),
    #: "verdicts" (only for rows whose verdict is otherwise undecided) or "never" (this pass)
    zda_fallback: str = "always"
    #: "full": every stealthy set gets its whole zero set (growth, fastest zero); "verdict":
    #: only when the verdict depends on it (see :func:`audit`)
    growth: str = "full"
    schedule: tuple[str, ...] | None = None
    schedule_text: str = ""
    #: the table of repeated row parts of the process that keeps the rows (:meth:`AuditChunk.receive`)
    row_parts: SharedParts = field(default_factory=SharedParts, compare=False, repr=False)
    #: the memo of the chunks run in one process (:class:`_ProcessMemo`)
    process_memo: _ProcessMemo = field(default_factory=_ProcessMemo, compare=False, repr=False)

    @functools.cached_property
    def modes(self) -> dict[str, bool | None]:
        """Theorem III.3 (i)-(iii) per safe mode (True, False or None); read every set, kept (read-only)."""
        return _theorem_ok(self.theorem)

    def zda_options(self, growth: str | None = None) -> ZdaOptions:
        """The options of :func:`~glocal_verify.analysis.stealthy.zda_verdict.decide_zda` for this pass."""
        return ZdaOptions(
            self.lambda0, self.tol, self.exact, growth or self.growth, self.screen and not self.exact, self.minors, _zda_fallback(self), completeness="count"
        )


def _shared(system: System, tol: Tolerance, exact: bool, exact_fallback: bool | str | None, screen: bool, growth: str | None = None) -> _Shared:
    if growth is None:
        growth = "full" if system.n <= config.get("growth_full_max_agents") else "verdict"
    if growth not in ("full", "verdict"):
        raise NotApplicableError(f"growth: must be 'full' or 'verdict', not {growth!r}")
    if exact_fallback is None:
        n = system.n
        exact_fallback = True if n <= config.get("exact_fallback_full_agents") else "verdicts" if n <= config.get("exact_fallback_max_agents") else False
    if exact_fallback not in (True, False, "verdicts"):
        raise NotApplicableError(f"exact_fallback: must be True, False or 'verdicts', not {exact_fallback!r}")
    system.spectrum()  # the one eigendecomposition of L_1 every set reuses
    lam = system.spec.attack.lambda0 if system.spec.attack is not None else None
    tables = global_tables(system) if screen and not exact and system.monitored else None
    info = system_info(system)
    sched = info.schedule
    return _Shared(system, tol, mode_theorem(system, tol, exact=exact), lam, exact, bool(exact_fallback), screen, tables,
                   zda_fallback="verdicts" if exact_fallback == "verdicts" else "always", growth=growth,
                   schedule=None if sched is None else sched.modes, schedule_text="" if sched is None else sched.text)


# ------------------------------------------------------------------------------------------
# one set


def without_sensors(system: System, sensors: Sequence[Label]) -> System:
    """``system`` with the global channels of ``sensors`` removed (the attacker owns and cancels them)."""
    bad = [a for a in sensors if a not in system.index]
    if bad:
        raise ModelError(f"--sensors: {', '.join(map(str, bad))} not in the graph")
    s = set(sensors)
    mon = system.spec.monitor
    new = dataclasses.replace(
        mon, positions=tuple(a for a in mon.positions if a not in s), velocities=tuple(a for a in mon.velocities if a not in s)
    )
    return System(dataclasses.replace(system.spec, monitor=new))


def _exposure_possible(sh: _Shared) -> bool:
    """Whether some safe mode may expose a set: Theorem III.3 is not decided to fail for it."""
    return any(ok is not False for ok in sh.modes.values())


def _zda_fallback(sh: _Shared) -> bool:
    """Whether this pass re-decides an undecided ZDA or safe-mode part over Q."""
    return sh.exact_fallback and sh.zda_fallback != "never"


def _by_cluster(system: System, F: tuple[Label, ...], memo: dict[Any, Any]) -> tuple[tuple[str | None, tuple[Label, ...], tuple[Label, ...]], ...]:
    """F split by cluster, with each cluster's observer centres (None: agents in no cluster)."""
    place = memo.get("cluster-place")
    if place is None:
        place = memo["cluster-place"] = {a: (ci, j) for ci, c in enumerate(system.clusters) for j, a in enumerate(c.nodes)}
    per: dict[int, list[Label]] = {}
    rest: list[Label] = []
    for a in sorted(F, key=lambda a: place.get(a, (len(system.clusters), 0))):
        if a in place:
            per.setdefault(place[a][0], []).append(a)
        else:
            rest.append(a)
    out: list[tuple[str | None, tuple[Label, ...], tuple[Label, ...]]] = [
        (system.clusters[ci].name, tuple(xs), tuple(o.center for o in system.clusters[ci].observers)) for ci, xs in per.items()
    ]
    if rest:
        out.append((None, tuple(rest), ()))
    return tuple(out)


def _mode_evidence(sh: _Shared, F: tuple[Label, ...], z: ZdaVerdict, mode: str, memo: dict[Any, Any]) -> tuple[ModeEvidence, dict[str, Any]]:
    """The touch test of one safe mode for the set, as evidence of the answer and as witness detail."""
    ok = sh.modes.get(mode)
    v = decide_avoidance(sh.system, mode, z, tol=sh.tol, fallback=_zda_fallback(sh), memo=memo.setdefault(("avoidance", F), {}), zero_first=True)
    av = v.avoidance
    detail: dict[str, Any] = {
        "theorem_iii3": ok,
        "switching.avoids-attack": v.status.value,
        "touches_attack": v.touches,
        "touched_agents": [str(a) for a in av.chosen_touched_agents] if av is not None else [],
    }
    margin = None
    if av is not None:
        detail["touch_margin"] = margin = float(av.margin)
    if v.premise:
        detail["premise"] = v.premise
        detail["touch_margin"] = 0.0  # as verify's vacuous result
    predicted = ""
    if v.touches and av is not None:
        predicted = predicted_residual(True, av.growth)
    ev = ModeEvidence(mode, dict(sh.theorem.get(mode, {})), v.status, margin if v.status is Status.FAILS else None, predicted)
    return ev, detail


def _unevaluated(sh: _Shared, mode: str, why: str, memo: dict[Any, Any]) -> tuple[ModeEvidence, dict[str, Any]]:
    key = ("unevaluated-mode", mode, why)  # the same objects for every row (read-only)
    if key not in memo:
        memo[key] = (
            ModeEvidence(mode, dict(sh.theorem.get(mode, {}))),
            {"theorem_iii3": sh.modes.get(mode), "switching.avoids-attack": "not evaluated", "touches_attack": None, "touched_agents": [], "note": why},
        )
    return memo[key]  # type: ignore[no-any-return]


def _answer(sh: _Shared, F: tuple[Label, ...], z: ZdaVerdict, local: Sequence[LocalEvidence], modes: Sequence[ModeEvidence], memo: dict[Any, Any]) -> AttackAnswer:
    lam = None if z.direction is None else complex(z.direction.value)
    ev = AttackEvidence("zda", F, _by_cluster(sh.system, F, memo), z.status, lam, z.direction_source, tuple(local), tuple(modes), sh.schedule, sh.schedule_text,
                        bool(sh.system.monitored))
    return answer_attack(ev)


def _audit_set(sh: _Shared, F: tuple[Label, ...], memo: dict[Any, Any]) -> AuditRow:
    if sh.zda_fallback == "verdicts" and sh.exact_fallback and not sh.exact:
        # the exact ZDA analysis costs seconds per set: run it only when the verdict needs it
        row = _audit_set(dataclasses.replace(sh, zda_fallback="never"), F, memo)
        if row.verdict != "undecided":
            return row
        sh = dataclasses.replace(sh, zda_fallback="always")
    system, tol = sh.system, sh.tol
    z = decide_zda(system, F, sh.zda_options(), memo)
    local, local_detail = local_part(sh, F, memo)
    if z.status is Status.HOLDS and not z.complete and z.direction_source != "requested lambda0" and sh.system.safe_modes and _exposure_possible(sh):
        # the exposure test concerns the witness of stealthy.zda (the fastest zero): compute it
        z = decide_zda(system, F, sh.zda_options("full"), memo)
    modes: dict[str, ModeEvidence] = {}
    mode_detail: dict[str, Any] = {}
    for q in system.safe_modes:
        if sh.growth == "verdict" and sh.modes.get(q) is False:
            # a mode that fails Theorem III.3 gives no guarantee whatever the touch test says
            modes[q], mode_detail[q] = _unevaluated(sh, q, "Theorem III.3 fails for this mode: it gives no guarantee, so the touch test is not run", memo)
        else:
            modes[q], mode_detail[q] = _mode_evidence(sh, F, z, q, memo)
    ans = _answer(sh, F, z, local, list(modes.values()), memo)
    memo.pop(("avoidance", F), None)
    witness: dict[str, Any] = {"local": local_detail, "modes": mode_detail, "zda_method": z.method}
    if z.proof:
        witness["zda_proof"] = z.proof
    if z.screened:
        witness["separator"] = f"at most {disjoint_paths(system, F)} vertex-disjoint paths from F to M < |F|: not left-invertible"
    if z.left_invertible is not None:
        witness["left_invertible"] = z.left_invertible
    if not z.complete:
        witness["growth_at_least"] = z.growth_at_least
        witness["zero_set"] = "not computed: the verdict does not depend on it (growth='verdict'; growth='full' computes it)"
    if z.status is Status.UNDECIDED and z.note:
        witness["zda_note"] = z.note
    if z.direction is not None:
        d = z.direction
        xi_max = config.get("witness_xi_max_agents")
        witness["direction"] = {
            "lambda0": [d.value.real, d.value.imag],
            "source": z.direction_source,
            "xi": vector_json([str(a) for a in system.labels], d.xi, cut=tol.rtol) if system.n <= xi_max else None,
            "u0": vector_json([str(a) for a in F], d.u0, zeros=True),
            "residual": float(getattr(d, "residual", 0.0)),
        }
        if system.n > xi_max:
            witness["direction"]["xi_note"] = f"xi (N entries) omitted above {xi_max} agents; verify on this attack with this lambda0 reports it"
    if ans.fragile:
        witness["fragile"] = ans.fragile
    witness["reason"] = ans.reason
    lam = None if z.direction is None else complex(z.direction.value)
    return AuditRow(F, ans.stealthy, z.growth, lam, ans.caught_locally_by, ans.exposed_by_modes, ans.verdict, witness, ans)


# ------------------------------------------------------------------------------------------
# chunks and the driver


@dataclass(frozen=True)
class AuditChunk:
    """One unit of work: audit ``sets`` on ``system`` (picklable; call it to get the rows).

    Attributes
    ----------
    shared : _Shared
        The system, its Theorem III.3 verdicts per mode and the options.
    sets : tuple of tuples of labels
    """

    shared: _Shared
    sets: tuple[tuple[Label, ...], ...]

    def __call__(self) -> list[AuditRow]:
        with deferred_full_collections():
            rows = self.run(self.shared.process_memo.memo(self.shared.local_seed))
        release_freed_memory()  # the chunk's temporaries are gone: give their pages back (a worker runs thousands)
        return rows

    def receive(self, rows: Sequence[AuditRow]) -> list[AuditRow]:
        """The rows as the process that keeps them stores them: repeated parts shared
        (:class:`~glocal_verify.design.audit_records.SharedParts`, one table per audit).

        An executor calls it in the calling process as each chunk's rows arrive
        (:class:`~glocal_verify.extra.dask.DaskExecutor`); the rows are equal to
        those returned, field by field.
        """
        return self.shared.row_parts.rows(rows)

    def run(self, memo: dict[Any, Any]) -> list[AuditRow]:
        """The rows, with ``memo`` (seeded by phase one) shared with other chunks of this process.

        What it keeps between sets is per agent, observer or suspected set (the minor tables'
        polynomials, local verdicts); per-set entries are removed once used.
        """
        if self.shared.growth == "verdict" and not self.shared.exact:
            prepare_witnesses(self.shared.system, self.sets, self.shared.zda_options(), memo)
        return [_audit_set(self.shared, F, memo) for F in self.sets]


@dataclass(frozen=True)
class LocalSinglesChunk:
    """Phase one of an audit: the local verdicts of every single candidate of one cluster (picklable).

    Every set's local part is assembled from the verdicts of its members per cluster; the
    singles are shared by all sets (a pair across two clusters needs nothing else), so they
    are computed once, then seed the memo of every :class:`AuditChunk`. With
    ``growth="verdict"`` the phase also records whether the witness certificate's small
    effort proves each single (a set with a member it does not prove does not try it:
    :func:`~glocal_verify.analysis.stealthy.zda_verdict.proven_single`).
    """

    shared: _Shared
    cluster: str
    agents: tuple[Label, ...]

    def __call__(self) -> dict[Any, Any]:
        with deferred_full_collections():
            return self._verdicts()

    def _verdicts(self) -> dict[Any, Any]:
        memo: dict[Any, Any] = {}
        for a in self.agents:
            local_part(self.shared, (a,), memo)
            if self.shared.growth == "verdict" and self.shared.minors is not None and not self.shared.exact:
                proven_single(self.shared.system, a, self.shared.zda_options(), memo)
        return {k: v for k, v in memo.items() if isinstance(k, tuple)}


def local_singles_chunks(chunks: Sequence[AuditChunk], candidates: Sequence[Label]) -> list[LocalSinglesChunk]:
    """The phase-one tasks of :func:`audit` (one per cluster that holds a candidate).

    Parameters
    ----------
    chunks : sequence of AuditChunk
        From :func:`audit_chunks` (their shared part is used).
    candidates : sequence of labels
    """
    if not chunks:
        return []
    sh = chunks[0].shared
    cand = set(candidates)
    return [
        LocalSinglesChunk(sh, c.name, tuple(a for a in c.nodes if a in cand))
        for c in sh.system.clusters
        if any(a in cand for a in c.nodes) and sh.system.observers(c.name)
    ]


def seed_chunks(chunks: Sequence[AuditChunk], parts: Iterable[Mapping[Any, Any]]) -> list[AuditChunk]:
    """The chunks with their memo seeded by the results of :func:`local_singles_chunks`.

    Parameters
    ----------
    chunks : sequence of AuditChunk
    parts : iterable of mappings
        The phase-one results.
    """
    seed: dict[Any, Any] = {}
    for part in parts:
        seed.update(part)
    if not chunks:
        return []
    sh = dataclasses.replace(chunks[0].shared, local_seed=seed, process_memo=_ProcessMemo())
    return [AuditChunk(sh, ch.sets) for ch in chunks]


def audit_chunks(
    system: System,
    sets: Sequence[Sequence[Label]],
    chunk_size: int = 500,
    *,
    tol: Tolerance = DEFAULT_TOLERANCE,
    exact: bool = False,
    exact_fallback: bool | str | None = None,
    screen: bool = True,
    growth: str | None = None,
) -> list[AuditChunk]:
    """Split an audit into independent callables (for a distributed executor).

    Each :class:`AuditChunk` carries the system (its spectrum of L_1 computed once here, so a
    local executor shares it) and the per-mode Theorem III.3 verdicts; ``chunk()`` returns its
    rows. The sets are dealt round robin (chunk i holds sets i, i + c, i + 2c, ... of the c
    chunks), so the sets of one size are spread evenly; :func:`merge_chunks` puts the rows back
    in order.

    Parameters
    ----------
    system : System
    sets : sequence of label sequences
        e.g. :func:`attack_sets`.
    chunk_size : int
        Sets per chunk (>= 1).
    tol, exact, exact_fallback, screen, growth
        As in :func:`audit`.
    """
    if chunk_size < 1:
        raise NotApplicableError(f"chunk_size must be at least 1, not {chunk_size}")
    sh = _shared(system, tol, exact, exact_fallback, screen, growth)
    norm = [tuple(sorted(F, key=system.index.__getitem__)) for F in sets]
    count = -(-len(norm) // chunk_size)
    # round robin: the costly sets (singles need the whole pencil analysis more often) are
    # spread over the chunks instead of filling the first one
    return [AuditChunk(sh, tuple(norm[i::count])) for i in range(count)]


def merge_chunks(system: System, max_attackers: int, candidates: Sequence[Label], rows: Iterable[Sequence[AuditRow]], modes: Mapping[str, bool | None]) -> AuditResult:
    """Assemble the rows returned by :class:`AuditChunk` calls into an :class:`AuditResult`.

    Parameters
    ----------
    system : System
    max_attackers : int
    candidates : sequence of labels
    rows : iterable of row lists
        The chunks' results, in any order.
    modes : mapping
        ``chunks[0].shared.modes``.
    """
    allrows = [r for part in rows for r in part]
    allrows.sort(key=lambda r: (len(r.actuators), [system.index[a] for a in r.actuators]))
    return AuditResult(system.name, system.n, max_attackers, tuple(candidates), dict(modes), tuple(allrows))


def audit(
    system: System,
    max_attackers: int = 2,
    candidates: Iterable[Label] | None = None,
    sensors: Iterable[Label] | None = None,
    progress: Callable[[int, int], None] | None = None,
    *,
    tol: Tolerance = DEFAULT_TOLERANCE,
    exact: bool = False,
    exact_fallback: bool | str | None = None,
    screen: bool = True,
    growth: str | None = None,
    chunk_size: int = 200,
    executor: Callable[[Sequence[Callable[[], Any]]], Sequence[Any]] | None = None,
) -> AuditResult:
    """Audit every set of 1..k compromised actuators among the candidates (module docstring).

    Parameters
    ----------
    system : System
    max_attackers : int
        k.
    candidates : iterable of labels, optional
        Agents whose actuators may be compromised (default all).
    sensors : iterable of labels, optional
        Agents whose global channels the attacker also owns: the attacker cancels them, so the
        audit runs with M without these agents (stealthiness needs only the other channels to
        stay zero).
    progress : callable, optional
        ``progress(0, total)`` when the sets are known, then ``progress(done, total)`` after
        each chunk (in this process; an executor reports its own).
    tol : Tolerance
        The checkers' numeric tolerance.
    exact : bool
        Decide every row over Q.
    exact_fallback : bool or "verdicts", optional
        Re-decide numeric ``undecided`` parts over Q (as ``verify`` escalates). ``"verdicts"``:
        the local parts as with True, the ZDA and safe-mode parts only for rows whose verdict
        is otherwise undecided (a row caught by a local observer keeps growth ``undecided``).
        Default: True for N <= ``config.get("exact_fallback_full_agents")``, ``"verdicts"`` up to
        ``config.get("exact_fallback_max_agents")`` (the exact ZDA analysis grows fast with N), else
        False (the part stays ``undecided``).
    screen : bool
        Use the separator screen of the module docstring.
    growth : {"full", "verdict"}, optional
        ``"full"``: every stealthy set gets the whole zero set of ``stealthy.zda`` (its growth
        class and fastest zero; one N-sized pencil analysis, O(N^3), when the minor
        certificate does not settle it). ``"verdict"``: a set whose stealthiness is proven by
        one ZDA (at the spec's lambda0, at lambda0 = 1 when the separator screen proves it not
        left-invertible, else at lambda0 = 0) skips the zero set unless the exposure test
        needs the fastest zero (some safe mode is not known to fail Theorem III.3); its growth
        is then ``undecided`` (``unbounded`` when proven) and the witness gives
        ``growth_at_least``; the touch test of a mode that fails Theorem III.3 is not
        evaluated. Verdicts, catching observers and exposing modes are those of ``"full"``.
        Default ``"full"`` up to
        ``config.get("growth_full_max_agents")`` agents, ``"verdict"`` above.
    chunk_size : int
        Sets per chunk (progress granularity; the unit of work of an executor).
    executor : callable, optional
        Runs a list of zero-argument callables and returns their results in the same order:
        first the :class:`LocalSinglesChunk` tasks (the local verdicts of single agents, one per
        cluster), then the :class:`AuditChunk` tasks (rows), e.g. :func:`glocal_verify.extra.dask.dask_executor` (Dask: an embedded
        LocalCluster or an external scheduler); default: in this process, in order.

    Returns
    -------
    AuditResult

    Raises
    ------
    ArgumentError
        ``max_attackers`` or ``chunk_size`` not an integer >= 1, an unknown ``growth``, a
        ``system`` that is not a :class:`~glocal_verify.model.System`.
    """
    if not isinstance(system, System):
        raise ArgumentError(f"audit: expected a System, got {type(system).__name__}")
    max_attackers = integer_arg("max_attackers", max_attackers, 1)
    chunk_size = integer_arg("chunk_size", chunk_size, 1)
    if growth is not None:
        choice_arg("growth", growth, ("full", "verdict"))
    with deferred_full_collections():  # the rows and memo stay alive: full collections only rescan them
        return _audit(system, max_attackers, candidates, sensors, progress, tol, exact, exact_fallback, screen, growth, chunk_size, executor)


def _audit(
    system: System,
    max_attackers: int,
    candidates: Iterable[Label] | None,
    sensors: Iterable[Label] | None,
    progress: Callable[[int, int], None] | None,
    tol: Tolerance,
    exact: bool,
    exact_fallback: bool | str | None,
    screen: bool,
    growth: str | None,
    chunk_size: int,
    executor: Callable[[Sequence[Callable[[], Any]]], Sequence[Any]] | None,
) -> AuditResult:
    if sensors is not None:
        system = without_sensors(system, list(sensors))
    sets = attack_sets(system, max_attackers, candidates)
    if progress is not None and executor is None:
        progress(0, len(sets))  # the phase starts: its set-up (the single agents) counts in it
    chunks = audit_chunks(system, sets, chunk_size, tol=tol, exact=exact, exact_fallback=exact_fallback, screen=screen, growth=growth)
    singles = local_singles_chunks(chunks, _candidates(system, candidates))
    chunks = seed_chunks(chunks, executor(singles) if executor is not None else [t() for t in singles])
    out: list[Sequence[AuditRow]] = []
    if executor is not None:
        out = list(executor(chunks))
    else:
        done = 0
        for ch in chunks:
            out.append(ch.receive(ch()))  # one memo for every chunk (_ProcessMemo)
            done += len(ch.sets)
            if progress is not None:
                progress(done, len(sets))
    modes = dict(chunks[0].shared.modes) if chunks else {}
    return merge_chunks(system, int(max_attackers), _candidates(system, candidates), out, modes)
