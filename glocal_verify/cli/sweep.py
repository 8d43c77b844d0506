"""``glocal-verify sweep``: an ensemble of networks on Dask, results in Parquet or CSV."""

from __future__ import annotations

import argparse
import sys
from typing import Any

__all__ = ["register"]


def cmd_sweep(args: argparse.Namespace) -> int:
    from glocal_verify.cli.common import UsageError
    from glocal_verify.design.sweep import load_sweep, run_sweep

    if args.workers < 1:
        raise UsageError("--workers must be at least 1")
    plan = load_sweep(args.sweep)
    tty = sys.stderr.isatty() and not args.quiet
    bar: Any = None
    if tty:
        from tqdm import tqdm

        bar = tqdm(total=len(plan.members), unit="member", file=sys.stderr)

        def progress(line: str) -> None:
            done = int(line.split("/", 1)[0])
            bar.update(done - bar.n)

    else:

        def progress(line: str) -> None:
            if not args.quiet:
                print(f"sweep: {line}", file=sys.stderr, flush=True)

    print(f"sweep: {len(plan.members)} members, {'scheduler ' + args.scheduler if args.scheduler else f'{args.workers} local workers'}", file=sys.stderr)
    try:
        res = run_sweep(plan, args.out, scheduler=args.scheduler, workers=args.workers, chunk_size=args.chunk, figures=not args.no_figures, progress=progress)
    finally:
        if bar is not None:
            bar.close()
    failed = len({r["member"] for r in res.rows if r.get("status") == "error"})
    print(f"wrote {res.out} ({len(res.rows)} rows; {res.computed} members computed, {res.resumed} resumed, {failed} failed)", file=sys.stderr)
    if res.summary is not None:
        print(f"wrote {res.summary}", file=sys.stderr)
    return 0


def register(sub: Any) -> None:
    """Add the ``sweep`` subcommand."""
    s = sub.add_parser("sweep", help="run an ensemble of networks (a sweep file) on Dask; write Parquet/CSV and a summary")
    s.add_argument("sweep", help="sweep file (TOML: [ensemble] and [compute])")
    s.add_argument("--out", required=True, metavar="FILE", help="results file, .parquet or .csv (parts for resuming go to FILE.parts/)")
    s.add_argument("--scheduler", metavar="ADDRESS", help="an existing Dask scheduler, e.g. tcp://127.0.0.1:8786 (default: an embedded LocalCluster)")
    s.add_argument("--workers", type=int, default=2, metavar="N", help="worker processes of the embedded cluster (default 2)")
    s.add_argument("--chunk", type=int, default=4, metavar="M", help="members per task (default 4)")
    s.add_argument("--no-figures", action="store_true", help="summary without plots")
    s.add_argument("--quiet", action="store_true", help="no progress on stderr")
    s.set_defaults(func=cmd_sweep)
