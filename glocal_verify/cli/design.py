"""``glocal-verify design``: monitors, local observers and safe modes that leave no attacker hidden."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from glocal_verify.runtime.files import STDOUT
from glocal_verify.cli.common import PROG, UsageError, add_allow_large, check_cost, check_out_file, count_progress, load_system, spec_inputs, write_output
from glocal_verify.runtime.lines import write_line

__all__ = ["register"]


def _assessment_lines(system: Any, label: str, exact: bool) -> list[str]:
    """Privacy and detection lines of ``verify``'s assessment (the same answer as the audit rows)."""
    from glocal_verify.answer.run import verify
    from glocal_verify.conditions.catalogue import DESIGN_ASSESSMENT_IDS

    a = verify(system, list(DESIGN_ASSESSMENT_IDS), exact=exact, simulate="never").assessment
    pr, at = a.privacy, a.attack
    out = [f"{label}: privacy of x(t0) {pr.initial_state}, of x* {pr.consensus_value}"]
    if at.present:
        out.append(f"{label}: {at.reason}")
    return out


def cmd_design(args: argparse.Namespace) -> int:
    from glocal_verify.design.network import design_comments, design_network

    check_out_file(args)  # a bad --out (the input spec, a symbolic link) fails before the design
    system = load_system(args)
    if args.budget < 1:
        raise UsageError(f"--budget: must be at least 1 safe mode, not {args.budget}")
    if args.max_attackers < 1 or args.max_attackers > system.n:
        raise UsageError(f"--max-attackers: must be between 1 and the number of agents ({system.n}), not {args.max_attackers}")
    if args.max_links is not None and args.max_links < 1:
        raise UsageError(f"--max-links: must be at least 1, not {args.max_links}")
    from glocal_verify.conditions.cost import SpecSizes
    from glocal_verify.conditions.design_cost import estimate_whole_design
    from glocal_verify.design.network import CONFIRM_LIMIT

    exact = not args.numeric and system.n <= 60
    est = estimate_whole_design(SpecSizes.from_spec(system.spec), max_attackers=args.max_attackers, place=not args.keep_observers, exact_assessment=exact,
                                budget=args.budget, confirm_limit=CONFIRM_LIMIT, moves_positions=bool(system.spec.monitor.positions))
    check_cost(est, args, how=("a smaller --max-attackers",))
    say = None if args.quiet else (lambda line: write_line(f"design: {line} ..."))
    tick = count_progress(args.quiet, prefix="design")
    d = design_network(
        system, budget=args.budget, max_attackers=args.max_attackers, place=not args.keep_observers, max_links=args.max_links,
        normal_weights=args.normal_weights, progress=say, tick=tick,
        admit=lambda est: check_cost(est, args, how=("a smaller --max-attackers, or more monitors or observers in the spec",)),
    )
    from glocal_verify.model import System
    from glocal_verify.spec.writer import dump_spec

    text = design_comments(d) + dump_spec(d.spec)
    write_output(text, args.out, inputs=spec_inputs(args))
    if say is not None:
        say("assessing the spec before and after")
    lines = d.summary() + [f"note: {n}" for n in d.notes]
    lines += _assessment_lines(system, "before", exact)
    lines += _assessment_lines(System(d.spec), "after ", exact)
    write_line("\n".join(lines), sys.stderr if args.out in (None, STDOUT) else sys.stdout)
    if d.unmet:
        write_line(f"{PROG}: the design above is partial: {len(d.unmet)} requirement(s) not met (see NOT MET)")
        return 1
    return 0


def register(sub: Any) -> None:
    """Add the ``design`` subcommand."""
    p = sub.add_parser("design", help="design monitors, local observers and safe modes so that no audited attacker stays hidden")
    p.add_argument("spec", nargs="?", help="system specification (TOML, format 1)")
    p.add_argument("--example", metavar="NAME", help="use a bundled example")
    p.add_argument("--out", metavar="DESIGNED.toml", help="write the designed spec here (default stdout)")
    p.add_argument("--budget", type=int, default=3, metavar="N", help="largest number of designed safe modes (default 3; the added velocity monitors have their own budget of 3)")
    p.add_argument("--max-links", type=int, default=None, metavar="K",
                   help="largest number of link changes in one safe mode (one-link modes are tried first; default: 2, and as many as a symmetry of the normal graph needs)")
    p.add_argument("--normal-weights", action="store_true",
                   help="where L_1 has repeated eigenvalues, change weights of the normal graph's links so that they split (the change is listed)")
    p.add_argument("--max-attackers", type=int, default=2, metavar="K", help="k of the audit (default 2)")
    p.add_argument("--keep-observers", action="store_true", help="keep the spec's local observers instead of placing new ones")
    # the former spelling of --keep-observers, still accepted
    p.add_argument("--no-observers", dest="keep_observers", action="store_true", help=argparse.SUPPRESS)
    p.add_argument("--numeric", action="store_true", help="before/after assessment in floating point (default exact for N <= 60)")
    p.add_argument("--quiet", action="store_true")
    add_allow_large(p)
    p.set_defaults(func=cmd_design)
