"""``glocal-verify export``: the designed observers, thresholds and schedule as a deployment file."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from glocal_verify.cli.common import PROG, UsageError, check_out_file, load_system, wrote
from glocal_verify.runtime.lines import write_line
from glocal_verify.spec.examples import example_names

__all__ = ["register"]


def cmd_export(args: argparse.Namespace) -> int:
    """Write the :func:`~glocal_verify.simulation.deployment.design_deployment` of SPEC to ``--out``
    (:func:`glocal_verify.reporting.export.export_observers`)."""
    from glocal_verify.reporting.export import EXPORT_FORMATS, export_observers
    from glocal_verify.simulation.deployment import design_deployment

    out = Path(args.out)
    fmt = args.format or out.suffix.lower().lstrip(".")
    if fmt not in EXPORT_FORMATS:
        raise UsageError(f"--format: give one of {', '.join(EXPORT_FORMATS)} (the suffix of {out.name!r} names none)")
    check_out_file(args)
    system = load_system(args)
    if not args.quiet:
        what = "observers and schedule" if args.no_thresholds else "observers, attack-free thresholds and schedule"
        write_line(f"{PROG}: designing the {what} of {system.name} ({system.n} agents) ...")
    deployment = design_deployment(system, thresholds=not args.no_thresholds, progress=not args.quiet)
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
    e.add_argument("--out", metavar="FILE", required=True, help="the file to write (atomically)")
    e.add_argument("--no-thresholds", action="store_true", help="leave out the attack-free thresholds (they take a simulation of the spec's horizon)")
    e.add_argument("--quiet", action="store_true", help="no progress on stderr")
    e.set_defaults(func=cmd_export)
