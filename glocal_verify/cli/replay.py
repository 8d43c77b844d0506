"""``glocal-verify replay``: a measured log through the exported detectors and Algorithm 1."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from glocal_verify.cli.common import PROG, UsageError, add_allow_large, check_cost, wrote, write_output
from glocal_verify.runtime.lines import write_line

__all__ = ["register"]

#: seconds per sample and detector state entry of the replay loop (measured: 19 agents, 5 detectors)
_SECONDS_PER_ENTRY = 2e-8
#: bytes of memory per byte of a CSV log (parsed floats and the resampled copies)
_BYTES_PER_LOG_BYTE = 6.0


def cmd_replay(args: argparse.Namespace) -> int:
    """Replay LOG through the detectors of FILE (module docstring of :mod:`glocal_verify.simulation.replay`)."""
    from glocal_verify.conditions.cost import CostEstimate
    from glocal_verify.reporting.export import read_deployment
    from glocal_verify.reporting.output import check_output_file
    from glocal_verify.reporting.replay_report import replay_json, replay_text, write_replay_figure
    from glocal_verify.simulation.replay import read_log, replay, replay_channels, resample

    if not 0 < args.tolerance <= 0.5:
        raise UsageError("--tolerance: give a fraction of the period in (0, 0.5]")
    if args.max_gap < 0:
        raise UsageError("--max-gap: give a number of samples >= 0")
    inputs = [args.file, args.log]
    if args.out is not None and args.out != "-":
        check_output_file(args.out, inputs=inputs)
    if args.figure is not None:
        if Path(args.figure).suffix.lower() not in (".png", ".svg"):
            raise UsageError(f"--figure: give a .png or .svg file (not {Path(args.figure).name!r})")
        check_output_file(args.figure, inputs=inputs)
    for f in inputs:
        if not Path(f).is_file():
            raise UsageError(f"{f}: no such file")
    tree = read_deployment(args.file)
    channels = replay_channels(tree, args.file)
    size = Path(args.log).stat().st_size
    order = sum(max(len(m["Fo"]) for m in d["modes"]) ** 2 for d in tree["sampled"]["detectors"])
    period = float(tree["sampled"]["period"])
    rows = size / max(12.0 * (len(channels) + 1), 1.0)
    check_cost(CostEstimate("replay", int(tree["system"]["n"]), rows * (order + len(channels)) * _SECONDS_PER_ENTRY, size * _BYTES_PER_LOG_BYTE), args, how=("a shorter log",))
    if not args.quiet:
        write_line(f"{PROG}: reading {args.log} ({size / 1e6:.3g} MB) ...")
    log = read_log(args.log)
    data = resample(log, channels, period, t0=args.t0, tolerance=args.tolerance, max_gap=args.max_gap)
    if not args.quiet:
        write_line(f"{PROG}: running {len(tree['sampled']['detectors'])} detectors over {len(data.t)} samples ...")

    def progress(done: int, total: int) -> None:
        if not args.quiet and total > 20000 and done % (4096 * 16) < 4096:
            write_line(f"{PROG}: replay: {done} of {total} samples")

    result = replay(tree, data, where=args.file, progress=progress)
    text = replay_text(result, log=args.log, deployment=args.file)
    if args.out is not None and args.out != "-":
        body = replay_json(result, log=args.log, deployment=args.file) if args.out.lower().endswith(".json") else text
        write_output(body, args.out, inputs=inputs)
        if not args.quiet:
            print(text, end="")
    else:
        print(text, end="")
    if args.figure is not None:
        wrote(write_replay_figure(result, args.figure))
    return 0


def register(sub: Any) -> None:
    """Add the ``replay`` subcommand."""
    r = sub.add_parser(
        "replay",
        help="run the exported detectors and Algorithm 1 on a measured log (CSV or .npz with timestamps): alarms, margins, the noise premise, a plot",
    )
    r.add_argument("file", metavar="FILE", help="deployment file written by glocal-verify export (.mat, .json or .npz, schema version 2)")
    r.add_argument("log", metavar="LOG", help="measured log: CSV with a header (t and the channels named as in FILE, e.g. v:7 [m/s]) or .npz")
    r.add_argument("--out", metavar="FILE", help="write the report here (.json: the summary as JSON; else text); - or none: standard output")
    r.add_argument("--figure", metavar="PLOT", help="draw the residuals over their thresholds into this .png or .svg")
    r.add_argument("--t0", type=float, metavar="SECONDS", help="the log's time of the detectors' first sample (default its first timestamp)")
    r.add_argument("--tolerance", type=float, default=0.25, metavar="FRACTION", help="largest offset of a log row from a detector sample, in periods (default 0.25)")
    r.add_argument("--max-gap", type=int, default=3, metavar="SAMPLES", help="longest run of missing samples filled by interpolation (default 3; longer: refused)")
    r.add_argument("--quiet", action="store_true", help="no progress on stderr")
    add_allow_large(r)
    r.set_defaults(func=cmd_replay)
