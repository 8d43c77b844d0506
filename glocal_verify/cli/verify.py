"""``glocal-verify verify``, ``conditions``, ``example`` and ``findings``."""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import sys
from typing import TYPE_CHECKING, Any, Callable

from glocal_verify import config
from glocal_verify.cli.common import (
    PROG,
    UsageError,
    add_allow_large,
    check_cost,
    check_out_file,
    ids_arg,
    load_system,
    spec_inputs,
    write_output,
)
from glocal_verify.conditions.catalogue import CATALOGUE
from glocal_verify.runtime.lines import write_line
from glocal_verify.spec.examples import example_names, example_text, finding_names

if TYPE_CHECKING:
    from glocal_verify.model import System

__all__ = ["register"]

#: report formats offered by ``--format`` (glocal_verify.reporting.render.FORMATS)
VERIFY_FORMATS = ("json", "markdown", "html")


def make_report(system: System, only: Any = None, **options: Any) -> Any:
    """The report of :func:`glocal_verify.answer.run.verify` (the library's ``verify``), imported when a command runs."""
    from glocal_verify.answer.run import verify

    return verify(system, only, **options)


def render_report(report: Any, fmt: str, system: System | None = None) -> str:
    """The report in ``fmt``; the HTML page also draws the network of ``system``."""
    if fmt == "html":
        from glocal_verify.reporting.html import to_html

        return to_html(report, system)
    from glocal_verify.reporting.render import render

    return render(report, fmt)


def _graph_labels(text: str | None, nodes: Any, flag: str) -> list[Any]:
    """Labels of ``--velocities`` / ``--positions``: each token as the graph spells it (int or str)."""
    out: list[Any] = []
    by_text = {str(v): v for v in nodes}
    for tok in ids_arg(text, flag, allow_empty=True) or []:
        if tok not in by_text:
            raise UsageError(f"{flag}: agent {tok} is not a node of the --graph file")
        out.append(by_text[tok])
    return out


def _graph_system(args: argparse.Namespace) -> System:
    """The system of ``--graph FILE`` with the monitored agents of ``--velocities``/``--positions``."""
    if args.spec or args.example:
        raise UsageError("give one of SPEC, --example or --graph")
    try:
        from glocal_verify.spec import spec_from_graph
        from glocal_verify.spec.graph_files import load_graph
    except ImportError as exc:
        raise UsageError(f"--graph is not available in this installation ({exc})") from None
    from pathlib import Path

    G = load_graph(args.graph)
    vel = _graph_labels(args.velocities, G.nodes, "--velocities")
    pos = _graph_labels(args.positions, G.nodes, "--positions")
    spec = spec_from_graph(G, name=Path(args.graph).stem or "graph", monitor_velocities=vel, monitor_positions=pos)
    from glocal_verify.model import System

    return System(spec)


def cmd_verify(args: argparse.Namespace) -> int:
    from glocal_verify.conditions.registry import implemented_ids, resolve_ids
    from glocal_verify.numerics.tolerance import Tolerance

    only = ids_arg(args.only, "--only")
    require = resolve_ids(ids_arg(args.require, "--require") or [])
    require_holds = resolve_ids(ids_arg(args.require_holds, "--require-holds") or [])
    if only is not None:
        named = [t for t in only if not t.endswith(("*", "."))]
        only = resolve_ids(only)
        missing = [c for c in resolve_ids(named) if c not in implemented_ids()]
        if missing:
            raise UsageError(f"--only: no checker implements {', '.join(missing)} yet")
    try:
        d = Tolerance()  # the defaults of rtol and band live there; parsing the command line loads no numerics
        tol = Tolerance(d.rtol if args.rtol is None else args.rtol, d.band if args.band is None else args.band)
    except ValueError as exc:
        raise UsageError(f"--rtol/--band: {exc}") from None
    args.exact_budget = float(config.resolve("exact_budget", args.exact_budget))
    args.fragile_below = float(config.resolve("fragile_below", args.fragile_below))
    if not (args.exact_budget >= 0.0):
        raise UsageError(f"--exact-budget: {args.exact_budget} must be >= 0 seconds (0 or inf: no limit)")
    if math.isinf(args.exact_budget):
        args.exact_budget = 0.0  # no limit
    if not (args.fragile_below >= 0.0):
        raise UsageError(f"--fragile-below: {args.fragile_below} must be >= 0")
    if (args.velocities or args.positions) and not args.graph:
        raise UsageError("--velocities/--positions need --graph FILE")
    check_out_file(args)  # before any computation: a bad --out fails at once
    if args.certificates:
        if args.certificates == args.out:
            raise UsageError("--certificates: give a file other than --out")
        check_out_file(argparse.Namespace(**{**vars(args), "out": args.certificates}))
    system = _graph_system(args) if args.graph else load_system(args)
    progress: Callable[[str], None] | None = None
    if not args.quiet:  # one line per checker, on a terminal or in a log (--quiet: none)
        progress = lambda cid: write_line(f"checking {cid} ...")  # noqa: E731
    from glocal_verify.answer.run import simulates

    simulate = simulates(system, args.simulate)
    from glocal_verify.conditions.cost import SpecSizes, estimate_verify

    budget = args.exact_budget if (args.escalate == "auto" and args.exact_budget > 0) else None
    est = estimate_verify(SpecSizes.from_spec(system.spec), only, exact=args.exact, simulate=simulate, exact_budget=budget)
    check_cost(est, args, how=("--only CONDITION to run fewer checkers",) if only is None else ())
    from glocal_verify.simulation.limits import allow_large

    with allow_large() if args.allow_large else contextlib.nullcontext():
        report = make_report(
            system,
            only,
            exact=args.exact,
            tol=tol,
            simulate=args.simulate,
            progress=progress,
            escalate=args.escalate,
            exact_budget=args.exact_budget if args.exact_budget > 0 else None,
            fragile_below=args.fragile_below,
        )
    try:
        text = render_report(report, args.format, system)
    except ValueError as exc:
        raise UsageError(f"--format {args.format}: {exc}") from None
    write_output(text, args.out, inputs=spec_inputs(args))
    if args.certificates:
        from glocal_verify.certificates import certificate_json

        write_output(certificate_json(system, report), args.certificates, inputs=spec_inputs(args))
    from glocal_verify.answer.gate import require as gate, require_holds as gate_holds

    bad = list(gate(report, require).failures) if require else []
    if require_holds:
        bad += [f"{line} (--require-holds)" for line in gate_holds(report, require_holds).failures]
    if bad:
        for line in bad:
            write_line(f"{PROG}: required condition not met: {line}")
        return 1
    return 0


def cmd_example(args: argparse.Namespace) -> int:
    if args.list or not args.name:
        print("\n".join(example_names() + finding_names()))
        return 0
    sys.stdout.write(example_text(args.name))
    return 0


def cmd_conditions(args: argparse.Namespace) -> int:
    """List the catalogue (without loading any checker): id, paper reference, good news when."""
    for cid, info in CATALOGUE.items():
        print(f"{cid:36s} {info.reference:48s} good for the defender when it {info.favourable.value}")
    return 0


def cmd_findings(args: argparse.Namespace) -> int:
    from glocal_verify.design.findings import PROOFS_INSTALL, proofs_available, verify_findings
    from glocal_verify.reporting.findings import findings_markdown

    from pathlib import Path

    inputs = [str(p) for p in Path(args.dir).glob("*.toml")] if args.dir and os.path.isdir(args.dir) else []
    check_out_file(args, inputs=inputs)
    if not proofs_available():
        write_line(f"{PROG}: warning: the proof checks' paper errors are left out of the report: they need sympy ({PROOFS_INSTALL})")
    write_output(findings_markdown(verify_findings(args.dir)), args.out, inputs=inputs)
    return 0



def register(sub: Any) -> None:
    """Add the ``verify``, ``example``, ``conditions`` and ``findings`` subcommands."""
    v = sub.add_parser("verify", help="check every condition and write a report")
    v.add_argument("spec", nargs="?", help="system specification (TOML, format 1)")
    v.add_argument("--example", metavar="NAME", help=f"use a bundled example ({', '.join(example_names())})")
    v.add_argument("--graph", metavar="FILE", help="build the spec from a graph file (GraphML, GML, edge list, CSV)")
    v.add_argument("--velocities", metavar="A,B,...", help="with --graph: agents whose velocity the control centre measures")
    v.add_argument("--positions", metavar="A,B,...", help="with --graph: agents whose position the control centre measures")
    v.add_argument("--format", choices=VERIFY_FORMATS, default="markdown", help="report format (default: markdown)")
    v.add_argument("--out", metavar="FILE", help="write the report to FILE instead of stdout")
    v.add_argument("--only", metavar="ID,...", help="check only these condition ids (prefixes like switching.* allowed)")
    v.add_argument("--exact", action="store_true", help="decide with exact rational arithmetic (python-flint)")
    v.add_argument("--require", metavar="ID,...", help="exit 1 unless every result of these ids is good news for the defender (favourable)")
    v.add_argument("--require-holds", metavar="ID,...", help="exit 1 unless every result of these ids has status holds (raw status, whatever it means for the defender)")
    v.add_argument("--rtol", type=float, default=None, help="relative tolerance of numeric decisions (default 1e-9)")
    v.add_argument("--band", type=float, default=None, help="undecided band factor above rtol (default 1e3)")
    v.add_argument(
        "--simulate",
        choices=("auto", "always", "never"),
        default="auto",
        help="run switching.detects (Theorem III.3's conclusion, one simulated switch per safe mode; auto: up to the tunable detects_max_agents, 150 agents)",
    )
    v.add_argument("--escalate", choices=("auto", "never"), default="auto", help="auto (default): re-decide a numeric undecided exactly within --exact-budget")
    v.add_argument("--exact-budget", type=float, default=None, metavar="SECONDS", help="one time budget for all the exact escalations of the run, in seconds (default: the tunable exact_budget, 30; 0 or inf: no limit)")
    v.add_argument("--fragile-below", type=float, default=None, metavar="X", help="mark a verdict fragile when its margin is below X (default: the tunable fragile_below, 1e-9)")
    v.add_argument("--quiet", action="store_true", help="no progress on stderr")
    v.add_argument("--certificates", metavar="FILE", help="also write a certificate of every decided verdict to FILE (JSON; check it with: python -m glocal_check SPEC FILE)")
    add_allow_large(v)
    v.set_defaults(func=cmd_verify)

    e = sub.add_parser("example", help="print a bundled example specification")
    e.add_argument("name", nargs="?", help="example name (e.g. paper19)")
    e.add_argument("--list", action="store_true", help="list the bundled examples (the counterexamples of the findings report are findings/NAME)")
    e.set_defaults(func=cmd_example)

    c = sub.add_parser("conditions", help="list the condition ids")
    c.set_defaults(func=cmd_conditions)

    f = sub.add_parser("findings", help="re-verify the bundled counterexamples and write the findings report")
    f.add_argument("--dir", metavar="FOLDER", help="verify the counterexample specs (*.toml with a [finding] table) of FOLDER instead of the bundled ones")
    f.add_argument("--out", metavar="FILE", help="write to FILE (e.g. reports/findings.md) instead of stdout")
    f.set_defaults(func=cmd_findings)

