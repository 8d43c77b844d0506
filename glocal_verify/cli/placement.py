"""``glocal-verify place-observers``."""

from __future__ import annotations

import argparse
from typing import Any

from glocal_verify.cli.common import PROG, add_allow_large, check_cost, check_out_file, load_system, spec_inputs, write_output
from glocal_verify.runtime.lines import write_line

__all__ = ["register"]


def cmd_place_observers(args: argparse.Namespace) -> int:
    import json

    from glocal_verify.design.placement import parse_suspected, place_observers

    check_out_file(args)  # a bad --out fails before the search
    system = load_system(args)
    suspected = parse_suspected(system, args.suspected)
    if system.clusters:  # without clusters place_observers says so at once
        from glocal_verify.conditions.cost import SpecSizes, estimate_place_observers

        check_cost(estimate_place_observers(SpecSizes.from_spec(system.spec), args.cluster), args, how=() if args.cluster else ("--cluster NAME to place one cluster's observers",))
    placement = place_observers(system, args.cluster, suspected, exact_limit=args.exact_limit, progress=not args.quiet)
    for line in placement.warnings:
        write_line(f"{PROG}: {line}")
    text = placement.to_toml() if args.format == "toml" else json.dumps(placement.to_json(), indent=2) + "\n"
    write_output(text, args.out, inputs=spec_inputs(args))
    return 0



def register(sub: Any) -> None:
    """Add the ``place-observers`` subcommand."""
    po = sub.add_parser("place-observers", help="propose local observers satisfying Proposition III.2 (ii), (iii) and UIO existence")
    po.add_argument("spec", nargs="?", help="system specification (TOML, format 1)")
    po.add_argument("--example", metavar="NAME", help="use a bundled example")
    po.add_argument("--cluster", metavar="NAME", help="only this cluster")
    po.add_argument("--suspected", default="attack", metavar="SET", help="attack (default), interior, all, or a comma-separated agent list")
    po.add_argument("--exact-limit", type=int, default=None, metavar="N", help="candidate sets the exhaustive search may visit per cluster (0: greedy only; default: the tunable placement_exact_limit, 2000)")
    po.add_argument("--format", choices=("toml", "json"), default="toml", help="toml: the spec fragment to paste (default)")
    po.add_argument("--out", metavar="FILE", help="write to FILE instead of stdout")
    po.add_argument("--quiet", action="store_true", help="no progress on stderr")
    add_allow_large(po)
    po.set_defaults(func=cmd_place_observers)

