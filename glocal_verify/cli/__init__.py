"""The ``glocal-verify`` command: a thin layer over the library.

Exit codes: 0 report written; 1 a condition named in ``--require`` fails or is undecided;
2 bad input or usage (one line on stderr, no traceback); 130 interrupted (Ctrl-C: one line
``glocal-verify: interrupted``; outputs are written atomically, so nothing partial is left).
Every ``--out`` prints ``wrote <path>`` on stderr.

One module per group of subcommands, each with a ``register(subparsers)`` function, listed in
:data:`COMMAND_MODULES`; :mod:`.common` holds what they share.

Layer: the top; imports the library, and nothing imports it.
"""

from __future__ import annotations

import importlib
import os
import sys
import warnings
from typing import Sequence

from glocal_verify import __version__
from glocal_verify.cli.common import PROG, Parser, UsageError
from glocal_verify.errors import GlocalVerifyError

__all__ = ["main", "build_parser", "COMMAND_MODULES"]

#: exit code of an internal error (a bug, never the user's input): EX_SOFTWARE of sysexits.h
INTERNAL_ERROR = 70

#: modules of this package that add subcommands, in the order ``--help`` lists them
COMMAND_MODULES = ("verify", "placement", "simulate", "audit", "design", "sweep", "draw", "export")


def build_parser() -> Parser:
    """The argument parser with every subcommand of :data:`COMMAND_MODULES`."""
    p = Parser(prog=PROG, description="Check the conditions of the glocal attack-detection paper on a concrete network.")
    p.add_argument("--version", action="version", version=f"{PROG} {__version__}")
    p.add_argument("--threads", type=int, metavar="N", help="BLAS threads for the large factorizations (default: every core, at most OPENBLAS_NUM_THREADS, OMP_NUM_THREADS or MKL_NUM_THREADS when set; loops over small matrices use one)")
    sub = p.add_subparsers(dest="command", parser_class=Parser)
    for name in COMMAND_MODULES:
        importlib.import_module(f"{__name__}.{name}").register(sub)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line ``argv`` (default ``sys.argv[1:]``); return the exit code."""
    warnings.simplefilter("ignore", RuntimeWarning)  # overflow notes of numpy: a verdict says what they mean
    try:
        parser = build_parser()
        args = parser.parse_args(argv)
        if args.threads is not None:
            if args.threads < 1:
                raise UsageError(f"--threads: must be at least 1, not {args.threads}")
            from glocal_verify.numerics.threads import set_default_threads

            set_default_threads(args.threads)
        if not getattr(args, "func", None):
            parser.print_help(sys.stderr)
            return 2
        return int(args.func(args))
    except GlocalVerifyError as exc:
        print(f"{PROG}: error: {exc}", file=sys.stderr)
        return 2
    except SystemExit as exc:  # --help, --version
        return exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted", file=sys.stderr)
        return 130
    except MemoryError:
        print(f"{PROG}: error: out of memory: the problem is too large for this machine (the size limits are explained in docs/performance.md of the glocal-verify source, \"Size limits and estimates\")", file=sys.stderr)
        return 2
    except Exception as exc:  # a bug of the toolkit: one line for the user, the traceback on request
        if os.environ.get("GLOCAL_DEBUG"):
            raise
        first = str(exc).splitlines()[0][:200] if str(exc) else ""
        print(f"{PROG}: internal error ({type(exc).__name__}: {first}); please report it (GLOCAL_DEBUG=1 shows the traceback)", file=sys.stderr)
        return INTERNAL_ERROR


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
