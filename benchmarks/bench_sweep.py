"""Sweep throughput on Dask: the same ensemble with an embedded LocalCluster of 1 and of 2 workers.

Baseline: the members run one after the other in this process (``run_member``, no Dask);
candidates: ``compute_sweep`` and ``write_sweep`` with 1 and 2 worker processes (one thread each), start-up of the
cluster included. Members per second are in the note; on this 2-core machine 2 workers can at
best halve the time of the members themselves.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from glocal_verify.extra.dask import dask_client
from glocal_verify.design.sweep import SweepPlan, compute_sweep, plan_from_dict, run_member, sweep_rates
from glocal_verify.reporting.sweep_report import sweep_outputs, write_sweep

from .harness import Row


def _plan(agents: int, count: int) -> SweepPlan:
    return plan_from_dict(
        {
            "ensemble": {"generator": "random-clustered", "agents": [agents], "clusters": [2, 3], "seeds": {"start": 0, "count": count}},
            "compute": {"conditions": ["privacy.*", "switching.*"]},
        }
    )


def run(quick: bool) -> list[Row]:
    """The rows of this module (``quick``: a smaller ensemble)."""
    agents, count = (20, 4) if quick else (50, 12)
    plan = _plan(agents, count)
    members = list(plan.members)
    conditions = plan.conditions
    t0 = time.perf_counter()
    for m in members:
        run_member(m, conditions)
    serial = time.perf_counter() - t0
    rows: list[Row] = []
    group = f"sweep throughput: {len(members)} random clustered networks, N = {agents}, privacy.* and switching.*"
    for workers in (1, 2):
        t0 = time.perf_counter()
        with dask_client(None, workers):
            pass
        startup = time.perf_counter() - t0
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            out = Path(tmp) / "r.parquet"
            run = compute_sweep(plan, sweep_outputs(plan, out)[1], workers=workers, chunk_size=2)
            write_sweep(run, plan, out, rates=sweep_rates(run.rows, plan.grid), figures=False)
            dt = time.perf_counter() - t0
        rows.append(
            Row(group, f"{workers} worker(s)", "in-process loop (no Dask)", serial, f"Dask LocalCluster, {workers} worker process(es)", dt,
                f"{len(members) / dt:.3g} members/s with start-up, {len(members) / max(dt - startup, 1e-9):.3g}/s without "
                f"(an empty cluster starts and stops in {startup:.2g} s); in-process {len(members) / serial:.3g}/s")
        )
    return rows
