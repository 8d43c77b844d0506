"""``glocal-verify export``: the designed observers, thresholds and schedule as a deployment file."""

from __future__ import annotations

import argparse
import contextlib
from pathlib import Path
from typing import Any

from glocal_verify.cli.common import PROG, UsageError, add_allow_large, check_cost, check_out_file, load_system, wrote
from glocal_verify.runtime.files import STDOUT
from glocal_verify.runtime.lines import write_line
from glocal_verify.spec.examples import example_names

__all__ = ["register"]


def cmd_export(args: argparse.Namespace) -> int:
    """Write the :func:`~glocal_verify.simulation.deployment.design_deployment` of SPEC to ``--out``
    (:func:`glocal_verify.reporting.export.export_observers`)."""
    from glocal_verify.reporting.export import EXPORT_FORMATS, export_observers
    from glocal_verify.simulation.deployment import design_deployment

    check_out_file(args)  # before any work: '' or a missing folder fails at once
    out = Path(args.out)
    fmt = args.format or out.suffix.lower().lstrip(".")
    if fmt not in EXPORT_FORMATS:
        if args.out == STDOUT:
            raise UsageError(f"--out -: give --format ({', '.join(EXPORT_FORMATS)}): standard output has no suffix to name one")
        raise UsageError(f"--format: give one of {', '.join(EXPORT_FORMATS)} (the suffix of {out.name!r} names none)")
    system = load_system(args)
    from glocal_verify.conditions.cost import SpecSizes
    from glocal_verify.conditions.export_cost import estimate_export
    from glocal_verify.simulation.limits import allow_large

    est = estimate_export(SpecSizes.from_spec(system.spec), fmt, thresholds=not args.no_thresholds)
    check_cost(est, args, how=("--no-thresholds, or the compressed .mat/.npz formats",))
    if not args.quiet:
        what = "observers and schedule" if args.no_thresholds else "observers, attack-free thresholds and schedule"
        write_line(f"{PROG}: designing the {what} of {system.name} ({system.n} agents) ...")
    with allow_large() if args.allow_large else contextlib.nullcontext():
        deployment = design_deployment(system, thresholds=not args.no_thresholds, progress=not args.quiet)
    for note in deployment.notes:  # what the file cannot promise (also in its notes)
        write_line(f"{PROG}: warning: {note}")
    wrote(export_observers(deployment, out, fmt))
    return 0


def register(sub: Any) -> None:
    """Add the ``export`` subcommand."""
    e = sub.add_parser(
        "export",
        help="write the designed observers, thresholds, monitor sets and switching schedule for deployment (MATLAB .mat, JSON, .npz; docs/export.md)",
    )
    e.add_argument("spec", nargs="?", help="system specification (TOML, format 1)")
    e.add_argument("--example", metavar="NAME", help=f"use a bundled example ({', '.join(example_names())})")
    e.add_argument("--format", choices=("mat", "json", "npz"), help="file format (default: the suffix of --out)")
    e.add_argument("--out", metavar="FILE", required=True, help="the file to write (atomically; a device or FIFO in place; - for standard output, with --format)")
    e.add_argument("--no-thresholds", action="store_true", help="leave out the attack-free thresholds (they take a simulation of the spec's horizon)")
    e.add_argument("--quiet", action="store_true", help="no progress on stderr")
    add_allow_large(e)
    e.set_defaults(func=cmd_export)
