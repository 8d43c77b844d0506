"""What a sweep will cost, estimated before it starts: its members times the cost of each.

:func:`estimate_sweep` reads the sizes of every member (a generated member's from its
parameters, no network built; a spec member's from its file) and prices each with
:func:`glocal_verify.conditions.cost.estimate_verify`; it also decides whether worker
processes pay off (:func:`glocal_verify.extra.dask.workers_pay_off`) or the members
should run in this process. ``glocal-verify sweep`` prints the estimate before it starts and
refuses, in one line, a sweep above the limits of
:func:`~glocal_verify.conditions.cost.default_limits` unless ``--allow-large``.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

from glocal_verify import config
from glocal_verify.design.sweep import GENERATORS, SweepPlan
from glocal_verify.errors import GlocalVerifyError

__all__ = ["MEMBER_OVERHEAD_SECONDS", "ESCALATION_AGENTS", "ESTIMATE_SAMPLE", "SweepEstimate", "estimate_sweep"]

#: seconds a member costs beyond its checkers' estimate (building the network, writing its part)
MEMBER_OVERHEAD_SECONDS = 0.05
#: a member's numeric verify re-decides its undecided results exactly within a budget of
#: ``exact_budget`` seconds (:mod:`glocal_verify.config`, the value in force); the share of that budget it spends is taken as
#: min(1, (N / ESCALATION_AGENTS)^2): measured on 8 random clustered networks each (3 clusters,
#: seeds 100-107) at N = 20 / 50 / 80 / 120, the mean member spent 0.5 % / 1 % / 20 % / 50 %
#: of the budget (the model: 2 % / 11 % / 28 % / 64 %), its members 0.1-0.6 s / 0.3-1.1 s /
#: 0.8-31 s / 2.8-32 s
ESCALATION_AGENTS = 150.0
#: members whose spec file is read for the estimate of a sweep over a folder (spread evenly)
ESTIMATE_SAMPLE = 50


@dataclass(frozen=True, slots=True)
class SweepEstimate:
    """What a sweep will cost, estimated before it starts (:func:`estimate_sweep`).

    Attributes
    ----------
    members : int
        Members still to compute (resumed ones excluded).
    largest : int
        Agents of the largest member.
    work_seconds : float
        The members' estimated seconds in one process, one after the other.
    member_bytes : float
        Peak memory of the largest member in one process.
    workers : int
        Processes that share the members (1: this process).
    in_process : bool
        Whether the members run in this process (workers would not pay off).
    seconds : float
        Estimated wall time.
    bytes : float
        Estimated peak memory of the machine (every worker at its largest member).
    """

    members: int
    largest: int
    work_seconds: float
    member_bytes: float
    workers: int
    in_process: bool
    seconds: float
    bytes: float

    def totals(self) -> str:
        """``"3.4 days and 1.2 GiB"``."""
        from glocal_verify.conditions.cost import format_bytes, format_seconds

        return f"{format_seconds(self.seconds)} and {format_bytes(self.bytes)}"

    def describe(self) -> str:
        """``"3.4 days and 1.2 GiB (1000000 members of up to 12 agents, 2 workers)"``."""
        where = "in this process" if self.in_process else (f"{self.workers} workers" if self.workers > 1 else "1 worker")
        return f"{self.totals()} ({self.members} members of up to {self.largest} agents, {where})"


def _generated_sizes(params: Mapping[str, Any], generator: str) -> Any:
    """The :class:`~glocal_verify.conditions.cost.SpecSizes` a generated member will have,
    from its parameters alone (no network is built)."""
    from glocal_verify.conditions.cost import SpecSizes
    from glocal_verify.design.generators import GENERATOR_DEFAULTS

    keys = GENERATORS[generator]
    kw = {**GENERATOR_DEFAULTS, **{keys[k]: v for k, v in params.items()}}
    n, c = int(kw["n"]), int(kw["clusters"])
    bounds = [round(n * k / c) for k in range(c + 1)]
    sizes = tuple(bounds[k + 1] - bounds[k] for k in range(c))
    monitors = kw["monitors"] if kw["monitors"] is not None else max(3, n // 100)
    return SpecSizes(
        n=n, cluster_sizes=sizes, cluster_names=tuple(f"P{k + 1}" for k in range(c)), observers=(int(kw["observers_per_cluster"]),) * c,
        changed_by_modes=(1,) * c, modes=int(kw["modes"]), mode_changes=(1,) * int(kw["modes"]), channels=int(monitors),
        attack=bool(params.get("attack", True)), cut_links=int(kw["cut_edges"]) * (c - 1), partitioned=c >= 2,
    )


def estimate_sweep(plan: SweepPlan, *, workers: int = 2, scheduler: str | None = None, skip: Iterable[str] = ()) -> SweepEstimate:
    """Estimate a sweep before it starts: the members times the cost of each.

    Each member costs :func:`~glocal_verify.conditions.cost.estimate_verify` of its sizes
    (without the command's start-up), plus :data:`MEMBER_OVERHEAD_SECONDS`, plus the expected
    exact re-decisions of a numeric run: :math:`30\\,\\min(1, (N / 150)^2)` seconds
    (the tunable ``exact_budget``, :data:`ESCALATION_AGENTS`). A generated member's sizes come
    from its parameters; a spec member's from its file (:data:`ESTIMATE_SAMPLE` files, spread
    evenly, stand for a large folder; a file that does not load counts nothing, it will be a
    failed row). The work is shared by ``workers`` processes when they pay off
    (:func:`~glocal_verify.extra.dask.workers_pay_off`), else it runs in this process;
    a remote ``scheduler`` counts as one worker and is always used.

    Parameters
    ----------
    plan : SweepPlan
    workers : int
        ``--workers``.
    scheduler : str, optional
        ``--scheduler``.
    skip : iterable of str
        Keys of members already computed (resumed).

    Returns
    -------
    SweepEstimate
    """
    from glocal_verify.conditions.cost import B_BASE, C_START, SpecSizes, estimate_verify
    from glocal_verify.extra.dask import DASK_OVERHEAD_SECONDS, workers_pay_off

    done = set(skip)
    todo = [m for m in plan.members if m.key not in done]
    conditions = None
    if plan.conditions is not None:
        from glocal_verify.conditions.registry import resolve_ids

        conditions = resolve_ids(list(plan.conditions))
    by_params: dict[Any, tuple[float, float, int]] = {}
    total = peak = 0.0
    largest = 0
    specs = [m for m in todo if m.spec_path is not None]
    step = max(1, len(specs) // ESTIMATE_SAMPLE)
    sample = {m.key for m in specs[::step]}
    scale = len(specs) / max(1, len(sample))
    key: Any
    for m in todo:
        if m.spec_path is not None:
            if m.key not in sample:
                continue
            try:
                from glocal_verify.spec import load_spec

                sizes = SpecSizes.from_spec(load_spec(m.spec_path))
            except GlocalVerifyError:
                continue
            weight, key = scale, m.key
        else:  # the members of one grid point share their parameters' mapping
            key, weight = id(m.params), 1.0
            sizes = None
        if key not in by_params:
            sizes = sizes if sizes is not None else _generated_sizes(m.params, m.generator or "")
            est = estimate_verify(sizes, conditions, exact=plan.exact, exact_budget=None)
            escalation = 0.0 if plan.exact or plan.escalate == "never" else config.get("exact_budget") * min(1.0, (sizes.n / ESCALATION_AGENTS) ** 2)
            by_params[key] = (max(0.0, est.seconds - C_START) + escalation + MEMBER_OVERHEAD_SECONDS, est.bytes, sizes.n)
        secs, nbytes, n = by_params[key]
        total += weight * secs
        peak, largest = max(peak, nbytes), max(largest, n)
    w = max(1, int(workers))
    remote = bool(scheduler)
    in_process = not remote and not workers_pay_off(total, min(w, max(1, len(todo))))
    used = 1 if in_process or remote else max(1, min(w, os.cpu_count() or 1, len(todo)))
    wall = C_START + total / used + (0.0 if in_process else DASK_OVERHEAD_SECONDS)
    nbytes = peak if in_process or remote else B_BASE + used * peak
    return SweepEstimate(len(todo), largest, total, peak, used, in_process, wall, nbytes)
