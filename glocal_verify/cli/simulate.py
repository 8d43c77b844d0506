"""``glocal-verify simulate``."""

from __future__ import annotations

import argparse
import contextlib
import sys
from pathlib import Path
from typing import Any, Callable

from glocal_verify.cli.common import PROG, UsageError, check_out_dir, load_system, spec_inputs, wrote
from glocal_verify.runtime.lines import write_line
from glocal_verify.spec.examples import example_names

__all__ = ["register"]

#: default parent of the output folder: ``./glocal-out/<safe spec name>`` in the working folder
DEFAULT_OUT = "glocal-out"


def cmd_simulate(args: argparse.Namespace) -> int:
    """Run Algorithm 1 (or the case study) and write its folder; every check comes first."""
    from glocal_verify.design.case_study import run_case_study, simulate_system
    from glocal_verify.reporting.output import check_output_dir, safe_component
    from glocal_verify.reporting.simulation_report import (
        write_case_study,
        write_simulation,
    )
    from glocal_verify.simulation.engine import allow_large, check_size, estimate_size
    from glocal_verify.simulation.thresholds import ThresholdRule

    if args.cases and (args.mode or args.no_switch):
        raise UsageError("--cases simulates every safe mode: drop --mode/--no-switch")
    inputs = spec_inputs(args)
    if args.out is not None:
        check_out_dir(args.out, inputs=inputs)
    system = load_system(args)
    from glocal_verify.design.placement import connectivity_warnings

    for line in connectivity_warnings(system):
        write_line(f"{PROG}: {line}")
    out = Path(args.out) if args.out is not None else Path(DEFAULT_OUT) / safe_component(system.name)
    check_out_dir(out, inputs=inputs)
    sim = system.spec.simulation
    # refuse absurd horizons before anything is allocated (the engine checks every run too)
    check_size(estimate_size(system.n, float(sim.horizon), float(sim.step)), allow=args.allow_large)
    progress = sys.stderr.isatty() and not args.quiet
    phase: Callable[[str], None] | None = None
    if not args.quiet:
        phase = lambda text: write_line(f"{PROG}: {text}")  # noqa: E731
    rule = ThresholdRule(kind=args.threshold)
    figures = not args.no_figures
    with allow_large() if args.allow_large else contextlib.nullcontext():
        if args.cases:
            command = " ".join(["glocal-verify simulate"] + ([f"--example {args.example}"] if args.example else [str(args.spec)]) + ["--cases"] + (["--out", str(args.out)] if args.out else []))
            study = run_case_study(system, rule=rule, method=args.method, progress=progress, phase=phase)
            write_case_study(study, out, command=command, figures=figures, phase=phase, inputs=inputs)
            for oc in study.outcomes:
                det = "detected" if oc.detected else "not detected"
                agree = "" if oc.agrees is None else ("  (agrees with the paper)" if oc.agrees else "  (DISAGREES with the paper)")
                print(f"{oc.case.name:10s} {oc.case.system.name:16s} global residual after switch: {oc.observed:10s} {det}{agree}")
        else:
            run = simulate_system(system, mode=args.mode, no_switch=args.no_switch, trigger=args.trigger, rule=rule, method=args.method, progress=progress, phase=phase)
            write_simulation(system, run, out, figures=figures, phase=phase, inputs=inputs)
            res = run.result
            for e in res.events:
                print(f"t = {e.time:8.3f}  {e.kind:30s} {e.detail}")
    wrote(out)
    return 0


def register(sub: Any) -> None:
    """Add the ``simulate`` subcommand."""
    sm = sub.add_parser("simulate", help="simulate attack, observers and Algorithm 1 exactly; write a JSON summary and figures")
    sm.add_argument("spec", nargs="?", help="system specification (TOML, format 1)")
    sm.add_argument("--example", metavar="NAME", help=f"use a bundled example ({', '.join(example_names())})")
    sm.add_argument("--out", metavar="DIR", help=f"output folder (default ./{DEFAULT_OUT}/<name>); written all or nothing")
    sm.add_argument("--mode", metavar="NAME", help="safe mode to switch to (default: the spec's switching.mode, or the best-ranked one)")
    sm.add_argument("--no-switch", action="store_true", help="stay in the normal mode")
    sm.add_argument("--trigger", choices=("auto", "schedule", "local"), default="auto", help="switch at the spec's time (schedule) or after the first local detection (local); auto: schedule if the spec gives a time")
    sm.add_argument("--cases", action="store_true", help="one run per safe mode (companion specs <name>-<mode> carry a case's own attack); writes the outcome table and Figure 2")
    sm.add_argument("--method", choices=("auto", "dense", "modal"), default="auto", help="exact propagator (default auto: dense up to 600 states)")
    sm.add_argument("--threshold", choices=("envelope", "calibrated"), default="envelope", help="threshold rule (default: exact attack-free envelope)")
    sm.add_argument("--no-figures", action="store_true", help="write the JSON/Markdown only (matplotlib is not loaded)")
    sm.add_argument("--allow-large", action="store_true", help="lift the size limits (1e7 samples, 2 GiB of stored trajectories)")
    sm.add_argument("--quiet", action="store_true", help="no progress on stderr")
    sm.set_defaults(func=cmd_simulate)
