"""``glocal-verify audit``: which sets of compromised actuators can hide in the network."""

from __future__ import annotations

from types import MappingProxyType

import argparse
import contextlib
import itertools
import os
import sys
from pathlib import Path
from typing import Any, Callable, Iterable

from glocal_verify.cli.common import (
    PROG,
    UsageError,
    add_allow_large,
    add_dask_options,
    check_cost,
    check_out_dir,
    check_out_file,
    count_progress,
    load_system,
    spec_inputs,
    write_output,
    wrote,
)
from glocal_verify.reporting.output import check_output_file
from glocal_verify.runtime.files import TargetKind, target_kind
from glocal_verify.runtime.lines import write_line

__all__ = ["register"]

#: formats of ``--format`` (html: :func:`glocal_verify.reporting.audit_html.audit_to_html`)
AUDIT_FORMATS = ("json", "markdown", "html")


def _labels(system: Any, text: str | None, what: str) -> list[Any] | None:
    if text is None:
        return None
    out: list[Any] = []
    by_str = {str(a): a for a in system.labels}
    for tok in (t.strip() for t in text.split(",")):
        if not tok:
            continue
        if tok not in by_str:
            raise UsageError(f"{what}: agent {tok} is not in the graph")
        out.append(by_str[tok])
    if not out:
        raise UsageError(f"{what}: the candidate set is empty")
    return out


def _audit_outputs(args: argparse.Namespace) -> tuple[Path | None, list[str]]:
    """Check ``--out`` and ``--figure`` before the audit: (the output folder or None, inputs)."""
    inputs = spec_inputs(args)
    out_dir = Path(args.out) if args.out and (target_kind(args.out) is TargetKind.FOLDER or args.out.endswith(("/", os.sep))) else None
    if out_dir is not None:
        check_out_dir(out_dir, inputs=inputs)
        for name in (_REPORT_NAMES.get(args.format, "audit.md"), "audit.svg", "audit.png"):
            check_output_file(out_dir / name, inputs=inputs)
    elif args.out is not None:
        check_out_file(args)
    if args.figure:
        if Path(args.figure).suffix.lower() not in (".svg", ".png"):
            raise UsageError(f"--figure: {args.figure} must end in .svg or .png")
        check_output_file(args.figure, inputs=inputs, what="--figure")
    return out_dir, inputs


#: the report's file name in an output folder, by format
_REPORT_NAMES = MappingProxyType({"json": "audit.json", "html": "audit.html", "markdown": "audit.md"})


def cmd_audit(args: argparse.Namespace) -> int:
    from glocal_verify.design.audit import audit
    from glocal_verify.reporting.audit_text import audit_json_chunks, audit_markdown
    from glocal_verify.reporting.figures.audit import audit_figure_bytes

    if args.workers is not None and args.workers < 1:
        raise UsageError("--workers must be at least 1")
    if args.chunk < 1:
        raise UsageError(f"--chunk: must be at least 1, not {args.chunk}")
    out_dir, inputs = _audit_outputs(args)  # a bad --out fails before the audit
    system = load_system(args)
    if args.max_attackers < 1:
        raise UsageError(f"--max-attackers: must be at least 1, not {args.max_attackers}")
    cands = _labels(system, args.agents, "--agents")
    sensors = _labels(system, args.sensors, "--sensors") if args.sensors else None
    n_cand = len(cands) if cands is not None else system.n
    if args.max_attackers > n_cand:
        raise UsageError(f"--max-attackers: {args.max_attackers} is larger than the number of candidate agents ({n_cand})")
    from glocal_verify.conditions.cost import C_START, SpecSizes, estimate_audit, format_seconds
    from glocal_verify.extra.dask import DaskExecutor, workers_pay_off

    sizes = SpecSizes.from_spec(system.spec)
    serial = estimate_audit(sizes, args.max_attackers, n_cand, exact=args.exact)
    local = not args.scheduler and (args.workers is None or not workers_pay_off(serial.seconds - C_START, args.workers))
    # a remote --scheduler's size is unknown here: the estimate counts one worker
    est = serial if local else estimate_audit(sizes, args.max_attackers, n_cand, exact=args.exact, workers=args.workers or 1)
    check_cost(est, args, how=("fewer --agents, a smaller --max-attackers or more --workers",))
    if args.workers and local and not args.quiet:
        write_line(f"audit: estimated {format_seconds(serial.seconds)} in this process: {args.workers} workers would not pay off; running here")
    executor: Any = None
    if not local:
        notice = lambda line: write_line(f"{PROG}: {line}")  # noqa: E731
        executor = DaskExecutor(args.scheduler, args.workers or 2, count_progress(args.quiet, "tasks"), dashboard=args.dashboard, notice=notice)
    progress = count_progress(args.quiet)
    with executor if executor is not None else contextlib.nullcontext():
        result = audit(
            system, args.max_attackers, cands, sensors, progress, exact=args.exact, growth=args.growth, chunk_size=args.chunk, executor=executor
        )
    text: str | Iterable[str]
    if args.format == "json":
        text = itertools.chain(audit_json_chunks(result), ["\n"])  # streamed: 500,500 rows are ~1.4 GB of JSON
    elif args.format == "html":
        from glocal_verify.reporting.audit_html import audit_to_html

        text = audit_to_html(result)
    else:
        text = audit_markdown(result)
    if out_dir is not None:
        from glocal_verify.reporting.output import OutputFolder

        with OutputFolder(out_dir, inputs=inputs) as folder:
            folder.write_text(_REPORT_NAMES.get(args.format, "audit.md"), text)
            folder.write_bytes("audit.svg", audit_figure_bytes(result, "svg"))
            folder.write_bytes("audit.png", audit_figure_bytes(result, "png"))
        for path in folder.written:
            wrote(path)
    else:
        write_output(text, args.out, inputs=inputs)
    if args.figure:
        from glocal_verify.reporting.output import write_bytes_atomic

        wrote(write_bytes_atomic(args.figure, audit_figure_bytes(result, Path(args.figure).suffix.lstrip(".").lower())))
    return 0


def register(sub: Any) -> None:
    """Add the ``audit`` subcommand."""
    p = sub.add_parser("audit", help="list every set of 1..k compromised actuators with whether it can hide (stealthy ZDA, local observers, safe modes)")
    p.add_argument("spec", nargs="?", help="system specification (TOML, format 1)")
    p.add_argument("--example", metavar="NAME", help="use a bundled example")
    p.add_argument("--max-attackers", type=int, default=2, metavar="K", help="largest set size (default 2)")
    p.add_argument("--agents", metavar="LIST", help="comma-separated candidate agents (default all)")
    p.add_argument("--sensors", metavar="LIST", help="agents whose global channels the attacker also owns")
    p.add_argument("--exact", action="store_true", help="decide every row in exact arithmetic")
    p.add_argument("--format", choices=AUDIT_FORMATS, default="markdown", help="json, markdown (default) or html (one self-contained page)")
    p.add_argument("--out", metavar="F", help="file, or a folder (then audit.json|md|html, audit.svg and audit.png are written)")
    p.add_argument("--figure", metavar="FILE", help="also write the figure (.svg or .png)")
    p.add_argument("--scheduler", metavar="ADDRESS", help="run the chunks on this Dask scheduler (e.g. tcp://127.0.0.1:8786)")
    p.add_argument("--workers", type=int, metavar="N", help="run the chunks on an embedded Dask LocalCluster of N workers (when the estimate says they pay off; else in this process)")
    p.add_argument(
        "--growth",
        choices=("full", "verdict"),
        help="full: the whole zero set of every stealthy set (growth class, fastest zero); verdict: only where a verdict needs it, "
        "else one proven ZDA and a lower bound on the growth (default: full up to 60 agents, verdict above)",
    )
    p.add_argument("--chunk", type=int, default=200, metavar="M", help="attack sets per task (default 200)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    add_allow_large(p)
    add_dask_options(p)
    p.set_defaults(func=cmd_audit)
