"""``glocal-verify simulate``."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from glocal_verify.cli.common import PROG, UsageError, load_system
from glocal_verify.spec.examples import example_names

__all__ = ["register"]


def cmd_simulate(args: argparse.Namespace) -> int:
    from glocal_verify.reporting.simulation_report import (
        write_case_study,
        write_simulation,
    )
    from glocal_verify.simulation.thresholds import ThresholdRule

    system = load_system(args)
    if args.cases and (args.mode or args.no_switch):
        raise UsageError("--cases simulates every safe mode: drop --mode/--no-switch")
    progress = sys.stderr.isatty() and not args.quiet
    rule = ThresholdRule(kind=args.threshold)
    if args.cases:
        out = Path(args.out or f"reports/{system.name}")
        command = " ".join(["glocal-verify simulate"] + ([f"--example {args.example}"] if args.example else [str(args.spec)]) + ["--cases"] + (["--out", str(args.out)] if args.out else []))
        outcomes, paths = write_case_study(system, out, rule=rule, method=args.method, progress=progress, command=command)
        for oc in outcomes:
            det = "detected" if oc.detected else "not detected"
            agree = "" if oc.agrees is None else ("  (agrees with the paper)" if oc.agrees else "  (DISAGREES with the paper)")
            print(f"{oc.case.name:10s} {oc.case.system.name:16s} global residual after switch: {oc.observed:10s} {det}{agree}")
    else:
        out = Path(args.out or f"simulation-{system.name}")
        res, paths = write_simulation(system, out, mode=args.mode, no_switch=args.no_switch, trigger=args.trigger, rule=rule, method=args.method, progress=progress)
        for e in res.events:
            print(f"t = {e.time:8.3f}  {e.kind:30s} {e.detail}")
        if res.simulation.interrupted:
            print(f"{PROG}: interrupted: partial results written", file=sys.stderr)
    print(f"wrote {len(paths)} files to {out}", file=sys.stderr)
    return 0



def register(sub: Any) -> None:
    """Add the ``simulate`` subcommand."""
    sm = sub.add_parser("simulate", help="simulate attack, observers and Algorithm 1 exactly; write a JSON summary and figures")
    sm.add_argument("spec", nargs="?", help="system specification (TOML, format 1)")
    sm.add_argument("--example", metavar="NAME", help=f"use a bundled example ({', '.join(example_names())})")
    sm.add_argument("--out", metavar="DIR", help="output folder (default simulation-<name>, with --cases reports/<name>)")
    sm.add_argument("--mode", metavar="NAME", help="safe mode to switch to (default: the spec's switching.mode, or the best-ranked one)")
    sm.add_argument("--no-switch", action="store_true", help="stay in the normal mode")
    sm.add_argument("--trigger", choices=("auto", "schedule", "local"), default="auto", help="switch at the spec's time (schedule) or after the first local detection (local); auto: schedule if the spec gives a time")
    sm.add_argument("--cases", action="store_true", help="one run per safe mode (companion specs <name>-<mode> carry a case's own attack); writes the outcome table and Figure 2")
    sm.add_argument("--method", choices=("auto", "dense", "modal"), default="auto", help="exact propagator (default auto: dense up to 600 states)")
    sm.add_argument("--threshold", choices=("envelope", "calibrated"), default="envelope", help="threshold rule (default: exact attack-free envelope)")
    sm.add_argument("--quiet", action="store_true", help="no progress on stderr")
    sm.set_defaults(func=cmd_simulate)
