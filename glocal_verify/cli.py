"""The ``glocal-verify`` command: a thin layer over the library.

Exit codes: 0 report written; 1 a condition named in ``--require`` fails or is undecided;
2 bad input or usage (one line on stderr, no traceback).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Callable, Sequence

from glocal_verify.conditions.registry import (
    CATALOGUE,
    implemented_ids,
    resolve_ids,
    verify,
)
from glocal_verify.errors import GlocalVerifyError
from glocal_verify.model import System
from glocal_verify.numerics.tolerance import Tolerance
from glocal_verify.reporting.render import FORMATS, render
from glocal_verify.results import Status
from glocal_verify.spec import load_spec
from glocal_verify.spec.examples import example_names, example_text, load_example

__all__ = [
    "main",
    "build_parser",
]

PROG = "glocal-verify"


class _UsageError(GlocalVerifyError):
    pass


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # type: ignore[override]
        raise _UsageError(message)


def _ids(text: str | None) -> list[str] | None:
    if text is None:
        return None
    return [t for t in (x.strip() for x in text.split(",")) if t]


def _load_system(args: argparse.Namespace) -> System:
    if args.example and args.spec:
        raise _UsageError("give either SPEC or --example, not both")
    if args.example:
        return System(load_example(args.example))
    if not args.spec:
        raise _UsageError("a SPEC file or --example NAME is required")
    return System(load_spec(args.spec))


def _write(text: str, out: str | None) -> None:
    if out:
        p = Path(out)
        try:
            p.parent.mkdir(parents=True, exist_ok=True)
            p.write_text(text, encoding="utf-8")
        except OSError as exc:
            raise _UsageError(f"--out {out}: cannot write ({exc.strerror})") from None
    else:
        sys.stdout.write(text)


def cmd_verify(args: argparse.Namespace) -> int:
    only = _ids(args.only)
    require = resolve_ids(_ids(args.require) or [])
    if only is not None:
        named = [t for t in only if not t.endswith(("*", "."))]
        only = resolve_ids(only)
        missing = [c for c in resolve_ids(named) if c not in implemented_ids()]
        if missing:
            raise _UsageError(f"--only: no checker implements {', '.join(missing)} yet")
    try:
        tol = Tolerance(args.rtol, args.band)
    except ValueError as exc:
        raise _UsageError(f"--rtol/--band: {exc}") from None
    system = _load_system(args)
    progress: Callable[[str], None] | None = None
    if sys.stderr.isatty() and not args.quiet:
        progress = lambda cid: print(f"checking {cid} ...", file=sys.stderr)  # noqa: E731
    report = verify(system, only, exact=args.exact, tol=tol, progress=progress)
    _write(render(report, args.format), args.out)
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

    _write(build_findings_report(args.dir), args.out)
    return 0


def cmd_place_observers(args: argparse.Namespace) -> int:
    import json

    from glocal_verify.design.placement import parse_suspected, place_observers

    system = _load_system(args)
    suspected = parse_suspected(system, args.suspected)
    placement = place_observers(system, args.cluster, suspected, exact_limit=args.exact_limit, progress=not args.quiet)
    text = placement.to_toml() if args.format == "toml" else json.dumps(placement.to_json(), indent=2) + "\n"
    _write(text, args.out)
    return 0


def cmd_simulate(args: argparse.Namespace) -> int:
    from glocal_verify.reporting.simulation_report import (
        write_case_study,
        write_simulation,
    )
    from glocal_verify.simulation.thresholds import ThresholdRule

    system = _load_system(args)
    if args.cases and (args.mode or args.no_switch):
        raise _UsageError("--cases simulates every safe mode: drop --mode/--no-switch")
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


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog=PROG, description="Check the conditions of the glocal attack-detection paper on a concrete network.")
    sub = p.add_subparsers(dest="command", parser_class=_Parser)

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

    po = sub.add_parser("place-observers", help="propose local observers satisfying Proposition III.2 (ii), (iii) and UIO existence")
    po.add_argument("spec", nargs="?", help="system specification (TOML, format 1)")
    po.add_argument("--example", metavar="NAME", help="use a bundled example")
    po.add_argument("--cluster", metavar="NAME", help="only this cluster")
    po.add_argument("--suspected", default="attack", metavar="SET", help="attack (default), interior, all, or a comma-separated agent list")
    po.add_argument("--exact-limit", type=int, default=2000, metavar="N", help="candidate sets the exhaustive search may visit per cluster (0: greedy only)")
    po.add_argument("--format", choices=("toml", "json"), default="toml", help="toml: the spec fragment to paste (default)")
    po.add_argument("--out", metavar="FILE", help="write to FILE instead of stdout")
    po.add_argument("--quiet", action="store_true", help="no progress on stderr")
    po.set_defaults(func=cmd_place_observers)

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
    return p


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        if not getattr(args, "func", None):
            parser.print_help(sys.stderr)
            return 2
        return int(args.func(args))
    except GlocalVerifyError as exc:
        print(f"{PROG}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
