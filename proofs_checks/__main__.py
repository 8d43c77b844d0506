"""Command line: ``python -m proofs_checks [--only NAME[,NAME]] [--list] [--format text|json]``.

Runs every proof step (or the selected ones), prints a table of module, step, equation and
verdict (with the residual of every step that is not a plain PASS and the explanation of every
expected failure) and exits with status 1 on any FAIL, UNEXPECTED-PASS, UNDECIDED or ERROR.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from typing import Sequence

from .core import Outcome, Summary, Verdict, all_steps, run, select

__all__ = ["main"]


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m proofs_checks",
        description="Symbolic and exact checks of the proof steps of the paper.",
    )
    p.add_argument(
        "--only",
        metavar="NAME[,NAME]",
        help="modules, step names or module.step (shell patterns allowed), comma separated",
    )
    p.add_argument("--list", action="store_true", help="list the steps without running them")
    p.add_argument("--format", choices=("text", "json"), default="text", help="output format (default: text)")
    return p


def _clip(s: str, n: int = 160) -> str:
    s = " ".join(s.split())
    return s if len(s) <= n else s[: n - 3] + "..."


def _text_row(o: Outcome) -> str:
    s = o.step
    lines = [f"{s.module:<19} {s.name:<46} {_clip(s.equation, 34):<34} {o.verdict.value}"]
    if o.verdict is Verdict.EXPECTED_FAIL:
        lines.append(f"{'':<19}   paper error: {s.paper_error}")
        lines.append(f"{'':<19}   residual: {_clip(o.residual)}")
    elif o.verdict is not Verdict.PASS:
        if o.error:
            lines.append(f"{'':<19}   error: {o.error}")
        else:
            lines.append(f"{'':<19}   residual: {_clip(o.residual, 400)}")
        if s.paper_error:
            lines.append(f"{'':<19}   (documented paper error: {s.paper_error})")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the checks; returns the exit status."""
    args = _parser().parse_args(argv)
    steps = all_steps()
    if args.only:
        try:
            steps = select(steps, [n.strip() for n in args.only.split(",") if n.strip()])
        except KeyError as exc:
            print(f"python -m proofs_checks: {exc.args[0]}", file=sys.stderr)
            return 2
    if args.list:
        if args.format == "json":
            print(
                json.dumps(
                    [
                        {
                            "module": s.module,
                            "step": s.name,
                            "equation": s.equation,
                            "reference": s.reference,
                            "expected": s.expected,
                            "paper_error": s.paper_error,
                            "note": s.note,
                        }
                        for s in steps
                    ],
                    indent=2,
                )
            )
        else:
            for s in steps:
                tag = "  [paper error]" if s.paper_error else ""
                print(f"{s.module:<19} {s.name:<46} {s.equation}{tag}")
        return 0
    t0 = time.perf_counter()
    if args.format == "text":
        print(f"{'module':<19} {'step':<46} {'equation':<34} verdict")
        print("-" * 118)
        outcomes = run(steps, progress=lambda o: print(_text_row(o), flush=True))
    else:
        outcomes = run(steps)
    elapsed = time.perf_counter() - t0
    summary = Summary.of(outcomes)
    if args.format == "json":
        print(
            json.dumps(
                {
                    "steps": [o.as_dict() for o in outcomes],
                    "counts": summary.counts,
                    "seconds": round(elapsed, 2),
                    "exit_status": summary.exit_status,
                },
                indent=2,
            )
        )
    else:
        counts = ", ".join(f"{v} {k}" for k, v in summary.counts.items() if v)
        print("-" * 118)
        print(f"{len(outcomes)} steps in {elapsed:.1f} s: {counts}")
    return summary.exit_status


if __name__ == "__main__":
    sys.exit(main())
