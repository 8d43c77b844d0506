"""Sweeps: population questions over ensembles of networks, run on Dask.

A sweep file (TOML) declares an *ensemble* and what to *compute* for each member::

    [ensemble]
    generator = "random-clustered"          # glocal_verify's random clustered network generator
    agents = [30, 50]                       # a list is a grid axis; a scalar is fixed
    clusters = 3
    seeds = { start = 0, count = 10 }
    # or, instead of a generator:  specs = "folder/of/specs"   (every *.toml in it)

    [compute]
    conditions = ["privacy.*", "switching.*"]
    exact = false                           # exact rational arithmetic for every member
    escalate = "auto"                       # re-decide numeric undecided results exactly

Every member (one point of the parameter grid and one seed, or one spec file) becomes one
task; a task builds the member's system, runs :func:`~glocal_verify.conditions.registry.check_conditions`
and returns one row per condition result (member parameters, seed, condition id, scope,
status, margin, method, favourable, fragile) -- or, when the member fails, one row with the
error class and message: a failing member never aborts the sweep.

Execution is ``dask.distributed``: an embedded ``LocalCluster`` on this machine by default
(``workers`` processes, one thread each), or an existing cluster given by its scheduler
address (``tcp://host:8786``) unchanged. Each finished member is written at once, atomically,
to a parts folder beside the output (``<out>.parts/<member>.json``); a sweep started again
with the same output skips the members already there (resume). :func:`compute_sweep` returns
the rows, :func:`sweep_rates` the rate of ``holds`` per condition against each grid parameter
(Wilson 95% intervals); the results file (Parquet through pyarrow, or CSV), the Markdown
summary and its plots are written from them by :mod:`glocal_verify.reporting.sweep_report`.
"""

from __future__ import annotations

import itertools
import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any, Callable, Mapping, Sequence

from glocal_verify import config
from glocal_verify.errors import GlocalVerifyError, SpecError
from glocal_verify.runtime.files import make_folders, remove_empty_folders, write_bytes_atomic
from glocal_verify.spec.prepare import prepare, read_toml
from glocal_verify.words import slug

__all__ = [
    "AxisRates",
    "Member",
    "RateCell",
    "SweepPlan",
    "SweepRates",
    "SweepRun",
    "compute_sweep",
    "load_sweep",
    "plan_from_dict",
    "run_member",
    "sweep_rates",
    "wilson_interval",
    "GENERATORS",
    "COLUMNS",
]

#: generators a sweep may name, and the sweep key -> generator keyword of each
GENERATORS: Mapping[str, Mapping[str, str]] = MappingProxyType({
    "random-clustered": MappingProxyType({
        "agents": "n",
        "clusters": "clusters",
        "chords": "chords",
        "cut_edges": "cut_edges",
        "monitors": "monitors",
        "modes": "modes",
        "max_weight": "max_weight",
        "attack": "attack",
        "observers_per_cluster": "observers_per_cluster",
        "horizon": "horizon",
        "step": "step",
    })
})

#: columns of the results file, in order (member parameters come first as ``param.<name>``)
COLUMNS = (
    "member",
    "source",
    "seed",
    "condition",
    "scope",
    "status",
    "margin",
    "method",
    "favourable",
    "fragile",
    "error_class",
    "error",
    "seconds",
)

#: largest seed of a generated member (numpy's generators take any non-negative integer; the
#: results file stores it as a 64-bit integer)
SEED_MAX = 2**63 - 1

@dataclass(frozen=True, slots=True)
class Member:
    """One member of an ensemble: a generated network (parameters and seed) or a spec file.

    Attributes
    ----------
    key : str
        Stable, file-name-safe identifier (used for the resume parts).
    params : mapping
        Grid parameters of a generated member (sweep keys), empty for a spec file.
    seed : int or None
        Seed of a generated member.
    spec_path : str or None
        Path of a spec-file member.
    generator : str or None
        Generator name of a generated member.
    """

    key: str
    params: Mapping[str, Any]
    seed: int | None
    spec_path: str | None = None
    generator: str | None = None

    @property
    def source(self) -> str:
        """How to reproduce the member: the generator call or the spec path."""
        if self.spec_path is not None:
            return self.spec_path
        args = ", ".join(f"{k}={v!r}" for k, v in self.params.items())
        return f"{self.generator}({args}, seed={self.seed})"


@dataclass(frozen=True, slots=True)
class SweepPlan:
    """A parsed sweep file: the members and what to compute for each.

    Attributes
    ----------
    members : tuple of Member
    conditions : tuple of str or None
        Condition ids or prefixes (None: every implemented condition).
    exact : bool
    escalate : str
    grid : mapping
        The grid axes (sweep key -> values), for the summary.
    source : str or None
        The sweep file (an input: no output may replace it).
    """

    members: tuple[Member, ...]
    conditions: tuple[str, ...] | None
    exact: bool = False
    escalate: str = "auto"
    grid: Mapping[str, tuple[Any, ...]] = field(default_factory=dict)
    source: str | None = None

    @property
    def inputs(self) -> tuple[str, ...]:
        """The files the sweep reads: the sweep file and every member's spec file."""
        return tuple(x for x in (self.source, *(m.spec_path for m in self.members)) if x)


def _fail(path: str, message: str, source: str | None) -> SpecError:
    return SpecError(path, message, source)


def plan_from_dict(data: Mapping[str, Any], source: str | None = None, base: Path | None = None) -> SweepPlan:
    """Build a :class:`SweepPlan` from the parsed TOML of a sweep file.

    Parameters
    ----------
    data : mapping
        ``{"ensemble": {...}, "compute": {...}}``.
    source : str, optional
        File name for messages.
    base : Path, optional
        Folder that a relative ``ensemble.specs`` is resolved against.

    Raises
    ------
    SpecError
        Naming the key path of the problem: the spec loader's nesting limit, an unknown key or
        generator, seeds outside ``[0, 2**63 - 1]``, a generator parameter outside its domain
        (checked for every grid point, before any member runs), more than
        ``config.get("sweep_max_members")`` members.
    """
    if not isinstance(data, Mapping):
        raise _fail("", "a sweep file is a TOML table", source)
    data = prepare(data, source)  # plain data, nesting bounded, without recursion
    unknown = set(data) - {"ensemble", "compute"}
    if unknown:
        raise _fail(sorted(unknown)[0], "unknown section (expected [ensemble] and [compute])", source)
    ens = data.get("ensemble")
    if not isinstance(ens, Mapping):
        raise _fail("ensemble", "missing [ensemble] table", source)
    comp = data.get("compute", {})
    if not isinstance(comp, Mapping):
        raise _fail("compute", "must be a table", source)
    conditions = comp.get("conditions")
    if conditions is not None:
        if not isinstance(conditions, list) or not all(isinstance(c, str) for c in conditions) or not conditions:
            raise _fail("compute.conditions", "must be a non-empty list of condition ids", source)
        from glocal_verify.conditions.registry import resolve_ids

        try:
            resolve_ids(conditions)
        except GlocalVerifyError as exc:
            raise _fail("compute.conditions", str(exc), source) from None
    exact = comp.get("exact", False)
    if not isinstance(exact, bool):
        raise _fail("compute.exact", "must be true or false", source)
    escalate = comp.get("escalate", "auto")
    if escalate not in ("auto", "never"):
        raise _fail("compute.escalate", "must be 'auto' or 'never'", source)
    extra = set(comp) - {"conditions", "exact", "escalate"}
    if extra:
        raise _fail(f"compute.{sorted(extra)[0]}", "unknown key (expected conditions, exact, escalate)", source)

    if "specs" in ens:
        if "generator" in ens:
            raise _fail("ensemble", "give either generator or specs, not both", source)
        folder = ens["specs"]
        if not isinstance(folder, str) or not folder or "\x00" in folder or len(folder) > 4096:
            raise _fail("ensemble.specs", "must be a folder path", source)
        extra_keys = set(ens) - {"specs"}
        if extra_keys:
            raise _fail(f"ensemble.{sorted(extra_keys)[0]}", "unknown key beside specs (a spec folder takes no generator parameters)", source)
        root = Path(folder) if base is None or Path(folder).is_absolute() else base / folder
        try:
            files = sorted(root.glob("*.toml")) if root.is_dir() else None
        except OSError as exc:
            raise _fail("ensemble.specs", f"cannot read the folder {folder!r} ({exc.strerror})", source) from None
        if files is None:
            raise _fail("ensemble.specs", f"{folder!r} is not a folder", source)
        if not files:
            raise _fail("ensemble.specs", f"no *.toml spec in {folder!r}", source)
        if len(files) > (limit := config.get("sweep_max_members")):
            raise _fail("ensemble.specs", f"{len(files)} specs exceed the limit of {limit} members", source)
        members = tuple(Member(key=f"spec-{i:06d}-{slug(p.stem)}", params={}, seed=None, spec_path=str(p)) for i, p in enumerate(files))
        return SweepPlan(members, tuple(conditions) if conditions else None, exact, escalate, {}, source)

    gen = ens.get("generator")
    if not isinstance(gen, str) or gen not in GENERATORS:
        raise _fail("ensemble.generator", f"unknown generator {_show(gen)} (known: {', '.join(GENERATORS)}; one name, not a list)", source)
    keys = GENERATORS[gen]
    seeds_spec = ens.get("seeds", {"start": 0, "count": 1})
    seeds = _seeds(seeds_spec, source)
    grid: dict[str, tuple[Any, ...]] = {}
    fixed: dict[str, Any] = {}
    for k, v in ens.items():
        if k in ("generator", "seeds"):
            continue
        if k not in keys:
            raise _fail(f"ensemble.{k}", f"unknown parameter of {gen} (known: {', '.join(keys)})", source)
        if isinstance(v, list):
            if not v:
                raise _fail(f"ensemble.{k}", "an empty grid axis", source)
            for i, x in enumerate(v):
                if isinstance(x, (list, dict)):
                    raise _fail(f"ensemble.{k}[{i}]", f"expected a number, got {_show(x)} (a grid axis is one flat list)", source)
            if len(set(map(repr, v))) != len(v):
                raise _fail(f"ensemble.{k}", "a grid axis lists a value twice", source)
            grid[k] = tuple(v)
        elif isinstance(v, dict):
            raise _fail(f"ensemble.{k}", f"expected a number or a list of numbers, got {_show(v)}", source)
        else:
            fixed[k] = v
    count = len(seeds) * math.prod(len(v) for v in grid.values())
    if count > (limit := config.get("sweep_max_members")):
        raise _fail("ensemble", f"{count} members exceed the limit of {limit}", source)
    axes = list(grid)
    if "agents" not in ens:
        raise _fail("ensemble.agents", "required: the number of agents of each member (a number or a list of numbers)", source)
    _check_grid(gen, fixed, grid, axes, source)
    generated: list[Member] = []
    for combo in itertools.product(*(grid[a] for a in axes)):
        params = dict(fixed)
        params.update(dict(zip(axes, combo)))
        tag = "-".join(f"{a}{slug(str(v))}" for a, v in zip(axes, combo))
        stem = f"{gen}-{tag}-seed" if tag else f"{gen}-seed"
        generated.extend(Member(key=f"{stem}{s}", params=params, seed=s, generator=gen) for s in seeds)
    return SweepPlan(tuple(generated), tuple(conditions) if conditions else None, exact, escalate, grid, source)


def _show(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:50] + "..."


def _check_grid(gen: str, fixed: Mapping[str, Any], grid: Mapping[str, Sequence[Any]], axes: Sequence[str], source: str | None) -> None:
    """Check every grid point against the generator's domain before any member runs: a value
    outside it is the sweep file's error (one line naming the sweep keys), not a failed row."""
    from glocal_verify.design.generators import GENERATOR_DEFAULTS, check_generator_arguments

    keys = GENERATORS[gen]
    back = {v: k for k, v in keys.items()}
    for combo in itertools.product(*(grid[a] for a in axes)):
        params = {keys[k]: v for k, v in fixed.items()}
        params.update({keys[a]: v for a, v in zip(axes, combo)})
        if "attack" in params and not isinstance(params["attack"], bool):
            raise _fail(f"ensemble.{back['attack']}", f"expected true or false, got {_show(params['attack'])}", source)
        try:
            check_generator_arguments(**{**GENERATOR_DEFAULTS, **{k: v for k, v in params.items() if k != "attack"}})
        except (SpecError, TypeError, ValueError, OverflowError) as exc:
            if not isinstance(exc, SpecError):
                exc = SpecError("", f"cannot be used ({exc})")
            key = back.get(exc.path, exc.path)
            point = ", ".join(f"{a} = {v!r}" for a, v in zip(axes, combo) if a != key)
            raise _fail(f"ensemble.{key}", exc.problem + (f" (at the grid point {point})" if point else ""), source) from None


def _seeds(spec: Any, source: str | None) -> list[int]:
    if isinstance(spec, list):
        if not spec or not all(isinstance(s, int) and not isinstance(s, bool) and 0 <= s <= SEED_MAX for s in spec):
            raise _fail("ensemble.seeds", f"must be a list of integers in [0, {SEED_MAX}] or {{start, count}}", source)
        if len(spec) > (limit := config.get("sweep_max_members")):
            raise _fail("ensemble.seeds", f"{len(spec)} seeds exceed the limit of {limit} members", source)
        if len(set(spec)) != len(spec):
            raise _fail("ensemble.seeds", "a seed is listed twice", source)
        return list(spec)
    if isinstance(spec, Mapping):
        extra = set(spec) - {"start", "count"}
        if extra:
            raise _fail(f"ensemble.seeds.{sorted(extra)[0]}", "unknown key (expected start and count)", source)
        start, count = spec.get("start", 0), spec.get("count")
        if not isinstance(start, int) or isinstance(start, bool) or not 0 <= start <= SEED_MAX:
            raise _fail("ensemble.seeds.start", f"must be an integer in [0, {SEED_MAX}], got {_show(start)}", source)
        limit = config.get("sweep_max_members")
        if not isinstance(count, int) or isinstance(count, bool) or not 1 <= count <= limit:
            raise _fail("ensemble.seeds.count", f"must be an integer in [1, {limit}], got {_show(count)}", source)
        if start + count - 1 > SEED_MAX:
            raise _fail("ensemble.seeds", f"the last seed {start + count - 1} exceeds {SEED_MAX}", source)
        return list(range(start, start + count))
    raise _fail("ensemble.seeds", "must be a list of integers or {start, count}", source)


def load_sweep(path: str | Path) -> SweepPlan:
    """Read and validate a sweep file, with the spec loader's guarantees (size, nesting, one
    :class:`~glocal_verify.errors.SpecError` naming the key path).

    Parameters
    ----------
    path : str or Path
        The TOML sweep file.
    """
    data, source = read_toml(path)
    return plan_from_dict(data, source, Path(source).parent)


def _member_system(member: Member) -> Any:
    from glocal_verify.model import System

    if member.spec_path is not None:
        from glocal_verify.spec import load_spec

        return System(load_spec(member.spec_path))
    from glocal_verify.design.generators import random_clustered_spec

    keys = GENERATORS[member.generator or ""]
    kwargs = {keys[k]: v for k, v in member.params.items()}
    return System(random_clustered_spec(seed=int(member.seed or 0), **kwargs))


def run_member(member: Member, conditions: Sequence[str] | None, exact: bool = False, escalate: str = "auto") -> list[dict[str, Any]]:
    """Compute one member: its result rows (never raises for a failing member).

    Parameters
    ----------
    member : Member
    conditions : sequence of str or None
        Condition ids or prefixes.
    exact : bool
    escalate : {"auto", "never"}

    Returns
    -------
    list of dict
        One row per condition result, or one row carrying ``error_class`` and ``error``.
    """
    from glocal_verify.conditions.registry import check_conditions
    from glocal_verify.results import jsonable

    t0 = time.perf_counter()
    base: dict[str, Any] = {"member": member.key, "source": member.source, "seed": member.seed}
    base.update({f"param.{k}": v for k, v in member.params.items()})
    try:
        system = _member_system(member)
        report = check_conditions(system, list(conditions) if conditions else None, exact=exact, escalate=escalate)
    except Exception as exc:  # a member's failure is a result of the sweep, not its end
        return [{**base, "condition": None, "status": "error", "error_class": type(exc).__name__, "error": str(exc)[:500], "seconds": time.perf_counter() - t0}]
    dt = time.perf_counter() - t0
    rows = []
    for r in report.conditions:
        margin = jsonable(r.margin)
        rows.append(
            {
                **base,
                "condition": r.id,
                "scope": json.dumps(jsonable(dict(r.scope)), sort_keys=True),
                "status": r.status.value,
                "margin": margin if isinstance(margin, (int, float)) else None,
                "method": r.method.value,
                "favourable": r.favourable,
                "fragile": r.fragile,
                "error_class": None,
                "error": None,
                "seconds": dt,
            }
        )
    return rows


def _run_chunk(members: Sequence[Member], conditions: Sequence[str] | None, exact: bool, escalate: str) -> list[tuple[str, list[dict[str, Any]]]]:
    return [(m.key, run_member(m, conditions, exact, escalate)) for m in members]


@dataclass(frozen=True, slots=True)
class SweepRun:
    """What a sweep computed: its rows and how many members ran now or came from earlier parts.

    Attributes
    ----------
    rows : tuple of dict
        Every result row (:func:`run_member`), in member order.
    computed, resumed : int
        Members computed in this run and members taken from earlier parts.
    """

    rows: tuple[dict[str, Any], ...]
    computed: int
    resumed: int


def wilson_interval(successes: int, trials: int, z: float = 1.959963984540054) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion (95% by default).

    Parameters
    ----------
    successes, trials : int
    z : float
        Normal quantile (1.96 for 95%).
    """
    if trials <= 0:
        return (0.0, 1.0)
    p = successes / trials
    d = 1 + z * z / trials
    c = (p + z * z / (2 * trials)) / d
    h = z * math.sqrt(p * (1 - p) / trials + z * z / (4 * trials * trials)) / d
    return (max(0.0, c - h), min(1.0, c + h))


@dataclass(frozen=True, slots=True)
class RateCell:
    """The ``holds`` rate of one condition at one value of a grid parameter.

    Attributes
    ----------
    holds, members, undecided : int
        Members where every scope of the condition holds, members with a result, members
        where it is undecided (and fails nowhere).
    rate, low, high : float
        ``holds / members`` (NaN without members) and its Wilson 95% interval.
    """

    holds: int
    members: int
    undecided: int
    rate: float
    low: float
    high: float


@dataclass(frozen=True, slots=True)
class AxisRates:
    """The rates of every condition against one grid parameter (``"(all)"`` without a grid)."""

    axis: str
    values: tuple[Any, ...]
    rates: Mapping[str, tuple[RateCell, ...]]


@dataclass(frozen=True, slots=True)
class SweepRates:
    """The population answer of a sweep: per grid parameter, the rate of ``holds`` of each condition.

    A member's condition holds iff every scope of it holds; it is undecided if any scope is
    undecided and none fails. Failed members (rows with status ``error``) are listed apart.

    Attributes
    ----------
    members : int
    result_rows : int
        Rows that are condition results (not failures).
    errors : tuple of dict
        The rows of failed members.
    conditions : tuple of str
    axes : tuple of AxisRates
    """

    members: int
    result_rows: int
    errors: tuple[Mapping[str, Any], ...]
    conditions: tuple[str, ...]
    axes: tuple[AxisRates, ...]


def sweep_rates(rows: Sequence[Mapping[str, Any]], grid: Mapping[str, Sequence[Any]]) -> SweepRates:
    """The rate of ``holds`` per condition against each grid parameter, with Wilson 95% intervals.

    Parameters
    ----------
    rows : sequence of mapping
        Result rows of :func:`run_member`.
    grid : mapping
        Grid axes of the sweep.
    """
    members = sorted({r["member"] for r in rows})
    errors = tuple(r for r in rows if r.get("status") == "error")
    # per member and condition: holds iff every scope holds; undecided if any undecided and none fails
    verdict: dict[tuple[str, str], str] = {}
    for r in rows:
        if r.get("condition") is None:
            continue
        k = (r["member"], r["condition"])
        cur = verdict.get(k, "holds")
        st = r["status"]
        if st == "fails" or cur == "fails":
            verdict[k] = "fails"
        elif st == "undecided" or cur == "undecided":
            verdict[k] = "undecided"
        else:
            verdict[k] = "holds"
    params_of = {r["member"]: {k[len("param.") :]: v for k, v in r.items() if k.startswith("param.")} for r in rows}
    conds = sorted({c for _, c in verdict})
    axes = []
    for axis in list(grid) or ["(all)"]:
        values = tuple(grid.get(axis, ["all"]))
        rates: dict[str, tuple[RateCell, ...]] = {}
        for c in conds:
            cells = []
            for v in values:
                ms = [m for m in members if axis == "(all)" or params_of.get(m, {}).get(axis) == v]
                vs = [verdict[(m, c)] for m in ms if (m, c) in verdict]
                n, h = len(vs), sum(1 for x in vs if x == "holds")
                lo, hi = wilson_interval(h, n)
                cells.append(RateCell(h, n, sum(1 for x in vs if x == "undecided"), h / n if n else float("nan"), lo, hi))
            rates[c] = tuple(cells)
        axes.append(AxisRates(axis, values, MappingProxyType(rates)))
    return SweepRates(len(members), len(rows) - len(errors), errors, tuple(conds), tuple(axes))


def compute_sweep(
    plan: SweepPlan,
    parts: Path,
    *,
    scheduler: str | None = None,
    workers: int = 2,
    chunk_size: int = 4,
    progress: Callable[[str], None] | None = None,
    dashboard: str | None = None,
    notice: Callable[[str], None] | None = None,
) -> SweepRun:
    """Run ``plan`` (on Dask, or in this process): every member's rows, resumed from ``parts``.

    Each finished member is written at once to the parts folder (the resume state, kept on
    purpose when a run stops; no folder is left when no member finished); a member already
    there is not run again. The results file, the summary and its plots are written from the
    returned :class:`SweepRun` by :func:`glocal_verify.reporting.sweep_report.write_sweep`, at
    the locations :func:`glocal_verify.reporting.sweep_report.sweep_outputs` checked before.

    Parameters
    ----------
    plan : SweepPlan
    parts : Path
        The parts folder (``<results file>.parts``, from ``sweep_outputs``).
    scheduler : str, optional
        Address of an existing Dask scheduler (``tcp://host:8786``); default an embedded
        ``LocalCluster`` of ``workers`` processes on this machine.
    workers : int
        Worker processes of the embedded cluster; 0 runs the members in this process, in
        order (no Dask: what a small sweep should do, :func:`estimate_sweep`).
    chunk_size : int
        Members per task (amortises task overhead; members of a chunk run in sequence).
    progress : callable, optional
        Called with one line per finished chunk.
    dashboard, notice :
        The embedded cluster's dashboard address and where its one-line notices go
        (:func:`~glocal_verify.extra.dask.dask_client`).
    """
    made = make_folders(parts)
    done = {p.stem for p in parts.glob("*.json")}
    todo = [m for m in plan.members if m.key not in done]
    resumed = len(plan.members) - len(todo)
    size = max(1, int(chunk_size))
    chunks = [todo[i : i + size] for i in range(0, len(todo), size)]
    finished = 0
    t0 = time.perf_counter()

    def keep(chunk_rows: Sequence[tuple[str, list[dict[str, Any]]]]) -> None:
        nonlocal finished
        for key, member_rows in chunk_rows:
            write_bytes_atomic(parts / f"{key}.json", json.dumps(member_rows, allow_nan=True).encode("utf-8"))
            finished += 1
        if progress:
            took = time.perf_counter() - t0
            if finished >= len(todo):  # done: no time left to announce
                progress(f"{finished}/{len(todo)} members ({resumed} resumed) in {took:.0f} s")
                return
            eta = (len(todo) - finished) * took / max(finished, 1)
            progress(f"{finished}/{len(todo)} members ({resumed} resumed), {took:.0f} s elapsed, about {eta:.0f} s left")

    try:
        if chunks and (scheduler or workers > 0):
            from functools import partial

            from glocal_verify.extra.dask import dask_client, run_on_dask

            with dask_client(scheduler, workers, dashboard=dashboard, notice=notice) as client:
                tasks = [partial(_run_chunk, c, plan.conditions, plan.exact, plan.escalate) for c in chunks]
                for _, chunk_rows in run_on_dask(client, tasks):
                    keep(chunk_rows)
        else:
            for c in chunks:
                keep(_run_chunk(c, plan.conditions, plan.exact, plan.escalate))
    finally:
        if finished == 0:
            remove_empty_folders(made)  # nothing to resume from: no folder left behind
    rows: list[dict[str, Any]] = []
    for m in plan.members:
        rows.extend(json.loads((parts / f"{m.key}.json").read_text(encoding="utf-8")))
    return SweepRun(tuple(rows), len(todo), resumed)


