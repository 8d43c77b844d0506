"""``glocal-verify draw``: the communication network of one mode as an SVG picture."""

from __future__ import annotations

import argparse
import importlib
from typing import Any

from glocal_verify.cli.common import UsageError, check_out_file, load_system, spec_inputs, write_output
from glocal_verify.spec.examples import example_names
from glocal_verify.spec.types import NORMAL_MODE

__all__ = ["register"]


def cmd_draw(args: argparse.Namespace) -> int:
    """Render the network of ``--mode`` with :func:`glocal_verify.reporting.network_svg.network_svg`."""
    check_out_file(args)
    try:
        module = importlib.import_module("glocal_verify.reporting.network_svg")
    except ModuleNotFoundError as exc:
        if exc.name != "glocal_verify.reporting.network_svg":
            raise
        raise UsageError("draw is not available: glocal_verify.reporting.network_svg is not installed") from None
    network_svg = getattr(module, "network_svg", None)
    if network_svg is None:
        raise UsageError("draw is not available: glocal_verify.reporting.network_svg has no network_svg(system, mode)")
    system = load_system(args)
    system.check_mode(args.mode)
    svg = str(network_svg(system, args.mode) if args.weights is None else network_svg(system, args.mode, weights=args.weights))
    write_output(svg if svg.endswith("\n") else svg + "\n", args.out, inputs=spec_inputs(args))
    return 0


def register(sub: Any) -> None:
    """Add the ``draw`` subcommand."""
    d = sub.add_parser("draw", help="draw the communication network of a mode as SVG")
    d.add_argument("spec", nargs="?", help="system specification (TOML, format 1)")
    d.add_argument("--example", metavar="NAME", help=f"use a bundled example ({', '.join(example_names())})")
    d.add_argument("--mode", metavar="NAME", default=NORMAL_MODE, help=f"mode to draw (default {NORMAL_MODE})")
    d.add_argument(
        "--weights",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="write each link's weight halfway along it (default: when the links' weights are not all equal)",
    )
    d.add_argument("--out", metavar="FILE", help="write the SVG to FILE instead of stdout")
    d.set_defaults(func=cmd_draw)
