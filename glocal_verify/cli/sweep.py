"""``glocal-verify sweep``: an ensemble of networks on Dask (or in this process), results in Parquet or CSV."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from glocal_verify.cli.common import PROG, UsageError, add_allow_large, add_dask_options
from glocal_verify.runtime.lines import write_line

__all__ = ["register"]


def _check_sweep_cost(est: Any, args: argparse.Namespace) -> None:
    """Refuse a sweep above the limits (unless ``--allow-large``), in one line with the estimate."""
    from glocal_verify.conditions.cost import CostEstimate, default_limits, format_bytes, format_seconds
    from glocal_verify.simulation.limits import refuse

    limits = default_limits()
    over = [w for w, bad in (("time", est.seconds > limits.seconds), ("memory", est.bytes > limits.bytes)) if bad]
    if over:
        refuse(
            f"sweep: estimated {est.describe()}, above the {' and '.join(over)} limit{'s' if len(over) > 1 else ''} ({format_seconds(limits.seconds)}, "
            f"{format_bytes(limits.bytes)}); rerun with --allow-large to run it anyway, or with fewer seeds, grid values or agents",
            allow=bool(args.allow_large), estimate=CostEstimate("sweep", est.largest, est.seconds, est.bytes), limits=limits,
        )


def cmd_sweep(args: argparse.Namespace) -> int:
    from glocal_verify.design.sweep import compute_sweep, load_sweep, sweep_rates
    from glocal_verify.design.sweep_cost import estimate_sweep
    from glocal_verify.reporting.sweep_report import sweep_outputs, write_sweep

    if args.workers < 1:
        raise UsageError("--workers must be at least 1")
    if args.chunk < 1:
        raise UsageError("--chunk must be at least 1")
    plan = load_sweep(args.sweep)
    _, parts, _ = sweep_outputs(plan, args.out, figures=not args.no_figures)  # before any work
    done = [p.stem for p in parts.glob("*.json")] if parts.is_dir() else []
    est = estimate_sweep(plan, workers=args.workers, scheduler=args.scheduler, skip=done)
    _check_sweep_cost(est, args)
    quiet = args.quiet
    if not quiet:
        where = f"scheduler {args.scheduler}" if args.scheduler else ("in this process (workers would not pay off)" if est.in_process else f"{args.workers} local workers")
        write_line(f"sweep: {est.members} members to compute ({len(done)} resumed), estimated {est.totals()}, {where}")
    bar: Any = None
    if sys.stderr.isatty() and not quiet:
        from tqdm import tqdm

        bar = tqdm(total=est.members, unit="member", file=sys.stderr)

        def progress(line: str) -> None:
            done_now = int(line.split("/", 1)[0])
            bar.update(done_now - bar.n)

    else:

        def progress(line: str) -> None:
            if not quiet:
                write_line(f"sweep: {line}")

    def notice(line: str) -> None:
        write_line(f"{PROG}: {line}")

    try:
        run = compute_sweep(
            plan, parts, scheduler=args.scheduler, workers=0 if est.in_process else args.workers, chunk_size=args.chunk,
            progress=progress, dashboard=args.dashboard, notice=notice,
        )
    finally:
        if bar is not None:
            bar.close()
    res = write_sweep(run, plan, args.out, rates=sweep_rates(run.rows, plan.grid), figures=not args.no_figures)
    failed = len({r["member"] for r in res.rows if r.get("status") == "error"})
    write_line(f"wrote {res.out} ({len(res.rows)} rows; {res.computed} members computed, {res.resumed} resumed, {failed} failed)")
    if res.summary is not None:
        write_line(f"wrote {res.summary}")
    return 0


def register(sub: Any) -> None:
    """Add the ``sweep`` subcommand."""
    s = sub.add_parser("sweep", help="run an ensemble of networks (a sweep file) on Dask; write Parquet/CSV and a summary")
    s.add_argument("sweep", help="sweep file (TOML: [ensemble] and [compute])")
    s.add_argument("--out", required=True, metavar="FILE", help="results file, .parquet or .csv (parts for resuming go to FILE.parts/)")
    s.add_argument("--scheduler", metavar="ADDRESS", help="an existing Dask scheduler, e.g. tcp://127.0.0.1:8786 (default: an embedded LocalCluster)")
    s.add_argument("--workers", type=int, default=2, metavar="N", help="worker processes of the embedded cluster (default 2; a sweep too small for them to pay off runs in this process)")
    s.add_argument("--chunk", type=int, default=4, metavar="M", help="members per task (default 4)")
    s.add_argument("--no-figures", action="store_true", help="summary without plots")
    s.add_argument("--quiet", action="store_true", help="no progress on stderr")
    add_allow_large(s)
    add_dask_options(s)
    s.set_defaults(func=cmd_sweep)
