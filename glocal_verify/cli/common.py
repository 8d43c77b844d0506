"""Shared pieces of the command line: the parser class, usage errors, loading and writing."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from glocal_verify.errors import GlocalVerifyError
from glocal_verify.model import System
from glocal_verify.spec import load_spec
from glocal_verify.spec.examples import load_example

__all__ = ["PROG", "UsageError", "Parser", "ids_arg", "load_system", "write_output"]

PROG = "glocal-verify"


class UsageError(GlocalVerifyError):
    pass


class Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # type: ignore[override]
        raise UsageError(message)


def ids_arg(text: str | None) -> list[str] | None:
    if text is None:
        return None
    return [t for t in (x.strip() for x in text.split(",")) if t]


def load_system(args: argparse.Namespace) -> System:
    if args.example and args.spec:
        raise UsageError("give either SPEC or --example, not both")
    if args.example:
        return System(load_example(args.example))
    if not args.spec:
        raise UsageError("a SPEC file or --example NAME is required")
    return System(load_spec(args.spec))


def write_output(text: str, out: str | None) -> None:
    if out:
        p = Path(out)
        try:
            p.parent.mkdir(parents=True, exist_ok=True)
            p.write_text(text, encoding="utf-8")
        except OSError as exc:
            raise UsageError(f"--out {out}: cannot write ({exc.strerror})") from None
    else:
        sys.stdout.write(text)


