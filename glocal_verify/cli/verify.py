"""``glocal-verify verify``, ``conditions``, ``example`` and ``findings``."""

from __future__ import annotations

import argparse
import sys
from typing import Any, Callable

from glocal_verify.cli.common import (
    PROG,
    UsageError,
    ids_arg,
    load_system,
    write_output,
)
from glocal_verify.conditions.registry import (
    CATALOGUE,
    implemented_ids,
    resolve_ids,
    verify,
)
from glocal_verify.numerics.tolerance import Tolerance
from glocal_verify.reporting.render import FORMATS, render
from glocal_verify.results import Status
from glocal_verify.spec.examples import example_names, example_text

__all__ = ["register"]


def cmd_verify(args: argparse.Namespace) -> int:
    only = ids_arg(args.only)
    require = resolve_ids(ids_arg(args.require) or [])
    if only is not None:
        named = [t for t in only if not t.endswith(("*", "."))]
        only = resolve_ids(only)
        missing = [c for c in resolve_ids(named) if c not in implemented_ids()]
        if missing:
            raise UsageError(f"--only: no checker implements {', '.join(missing)} yet")
    try:
        tol = Tolerance(args.rtol, args.band)
    except ValueError as exc:
        raise UsageError(f"--rtol/--band: {exc}") from None
    system = load_system(args)
    progress: Callable[[str], None] | None = None
    if sys.stderr.isatty() and not args.quiet:
        progress = lambda cid: print(f"checking {cid} ...", file=sys.stderr)  # noqa: E731
    report = verify(system, only, exact=args.exact, tol=tol, progress=progress)
    write_output(render(report, args.format), args.out)
    bad = []
    for cid in require:
        rs = report.results(cid)
        if not rs:
            bad.append(f"{cid}: not evaluated")
        for r in rs:
            if r.status is not Status.HOLDS:
                scope = ", ".join(f"{k}={v}" for k, v in r.scope.items()) or "global"
                bad.append(f"{cid} [{scope}]: {r.status.value}")
    if bad:
        for line in bad:
            print(f"{PROG}: required condition not met: {line}", file=sys.stderr)
        return 1
    return 0


def cmd_example(args: argparse.Namespace) -> int:
    if args.list or not args.name:
        print("\n".join(example_names()))
        return 0
    sys.stdout.write(example_text(args.name))
    return 0


def cmd_conditions(args: argparse.Namespace) -> int:
    impl = set(implemented_ids())
    for cid, info in CATALOGUE.items():
        mark = "" if cid in impl else "  (not implemented yet)"
        print(f"{cid:36s} {info.reference}{mark}")
    return 0


def cmd_findings(args: argparse.Namespace) -> int:
    from glocal_verify.reporting.findings import build_findings_report

    write_output(build_findings_report(args.dir), args.out)
    return 0



def register(sub: Any) -> None:
    """Add the ``verify``, ``example``, ``conditions`` and ``findings`` subcommands."""
    v = sub.add_parser("verify", help="check every condition and write a report")
    v.add_argument("spec", nargs="?", help="system specification (TOML, format 1)")
    v.add_argument("--example", metavar="NAME", help=f"use a bundled example ({', '.join(example_names())})")
    v.add_argument("--format", choices=FORMATS, default="markdown", help="report format (default: markdown)")
    v.add_argument("--out", metavar="FILE", help="write the report to FILE instead of stdout")
    v.add_argument("--only", metavar="ID,...", help="check only these condition ids (prefixes like switching.* allowed)")
    v.add_argument("--exact", action="store_true", help="decide with exact rational arithmetic (python-flint)")
    v.add_argument("--require", metavar="ID,...", help="exit 1 unless every result of these ids holds")
    v.add_argument("--rtol", type=float, default=Tolerance().rtol, help="relative tolerance of numeric decisions (default 1e-9)")
    v.add_argument("--band", type=float, default=Tolerance().band, help="undecided band factor above rtol (default 1e3)")
    v.add_argument("--quiet", action="store_true", help="no progress on stderr")
    v.set_defaults(func=cmd_verify)

    e = sub.add_parser("example", help="print a bundled example specification")
    e.add_argument("name", nargs="?", help="example name (e.g. paper19)")
    e.add_argument("--list", action="store_true", help="list the bundled examples")
    e.set_defaults(func=cmd_example)

    c = sub.add_parser("conditions", help="list the condition ids")
    c.set_defaults(func=cmd_conditions)

    f = sub.add_parser("findings", help="regenerate the findings report from reports/findings/*.toml")
    f.add_argument("--dir", default="reports/findings", help="folder of counterexample specs")
    f.add_argument("--out", metavar="FILE", help="write to FILE (e.g. reports/findings.md) instead of stdout")
    f.set_defaults(func=cmd_findings)

