"""The ``glocal-verify`` command: a thin layer over the library.

Exit codes: 0 report written; 1 a condition named in ``--require`` fails or is undecided;
2 bad input or usage (one line on stderr, no traceback); 130 interrupted (Ctrl-C: one line
``glocal-verify: interrupted``), 143 terminated (``SIGTERM``) and 129 hung up (``SIGHUP``),
each with one line; outputs are written atomically, so nothing partial is left, and every
child process ends with the command (:mod:`glocal_verify.runtime.processes`); 141 when the
reader of standard output went away (``| head``); 70 an internal error (a bug: please report).
Every ``--out`` prints ``wrote <path>`` on stderr; unless ``--quiet``, a command silent for
10 s says it is still working (:mod:`.heartbeat`).

One module per group of subcommands, each with a ``register(subparsers)`` function, listed in
:data:`COMMAND_MODULES`; :mod:`.common` holds what they share.

Layer: the top; imports the library, and nothing imports it.
"""

from __future__ import annotations

from types import MappingProxyType

import importlib
import os
import sys
import warnings
from typing import Sequence

from glocal_verify.version import __version__
from glocal_verify.cli.common import PROG, Parser, UsageError
from glocal_verify.cli.heartbeat import Heartbeat
from glocal_verify.errors import GlocalVerifyError, shorten
from glocal_verify.runtime.lines import tracked_stderr, write_line
from glocal_verify.runtime.processes import StopRequest, Stopped, signal_name, stop_on_signals

__all__ = ["main", "entry_point", "build_parser", "COMMAND_MODULES"]

#: exit code of an internal error (a bug, never the user's input): EX_SOFTWARE of sysexits.h
INTERNAL_ERROR = 70
#: most BLAS threads ``--threads`` accepts (threadpoolctl passes the count to C as an int)
MAX_THREADS = 4096
#: exit code when standard output is closed by its reader (128 + SIGPIPE, as a shell reports it)
BROKEN_PIPE = 141

#: the one line printed for each stop signal
_STOP_LINES = MappingProxyType({"SIGINT": "interrupted", "SIGTERM": "terminated (SIGTERM)", "SIGHUP": "hung up (SIGHUP)"})

#: modules of this package that add subcommands, in the order ``--help`` lists them
COMMAND_MODULES = ("verify", "placement", "simulate", "audit", "design", "sweep", "draw", "export", "replay")


def build_parser() -> Parser:
    """The argument parser with every subcommand of :data:`COMMAND_MODULES`."""
    p = Parser(prog=PROG, description="Check the conditions of the glocal attack-detection paper on a concrete network.")
    p.add_argument("--version", action="version", version=f"{PROG} {__version__}")
    p.add_argument("--threads", type=int, metavar="N", help="BLAS threads for the large factorizations (default: every core, at most OPENBLAS_NUM_THREADS, OMP_NUM_THREADS or MKL_NUM_THREADS when set; loops over small matrices use one)")
    sub = p.add_subparsers(dest="command", parser_class=Parser)
    for name in COMMAND_MODULES:
        importlib.import_module(f"{__name__}.{name}").register(sub)
    return p


def _say(line: str) -> None:
    """One line on stderr, on a fresh line, if stderr is still there (after a hang-up it may not be)."""
    try:
        write_line(f"{PROG}: {line}", fresh=True)
    except (OSError, ValueError):
        pass


def _stop_line(signum: int) -> str:
    name = signal_name(signum)
    return _STOP_LINES.get(name, f"stopped ({name})")


def entry_point() -> int:
    """The ``glocal-verify`` process: :func:`main` on ``sys.argv[1:]`` as the process's whole work.

    On return the stop signals stay ignored (``stop_on_signals(final=True)``): a ``SIGTERM``
    during the interpreter's shutdown, after the command's last write, no longer kills the
    process by the default action (exit -15); it ends with the command's own status.
    """
    return main(final=True)


def main(argv: Sequence[str] | None = None, *, final: bool = False) -> int:
    """Run the command line ``argv`` (default ``sys.argv[1:]``); return the exit code.

    ``final``: this call is the process's whole work (:func:`entry_point`); in-process callers
    keep the default, which restores the previous signal handlers."""
    warnings.simplefilter("ignore", RuntimeWarning)  # overflow notes of numpy: a verdict says what they mean
    with tracked_stderr():  # so that a stop line never lands behind an unfinished line
        try:
            with stop_on_signals(on_force=lambda signum: _say(f"{_stop_line(signum)} again: stopped at once"), final=final) as stop:
                return _run(argv, stop)
        except Stopped as exc:  # a signal between the handlers' installation and _run's own handling
            _say(_stop_line(exc.signum))
            return exc.exit_code


def _run(argv: Sequence[str] | None, stop: StopRequest | None = None) -> int:
    try:
        parser = build_parser()
        args = parser.parse_args(argv)
        if args.threads is not None:
            if not 1 <= args.threads <= MAX_THREADS:
                raise UsageError(f"--threads: must be between 1 and {MAX_THREADS}, not {str(args.threads)[:40]}")
            from glocal_verify.numerics.threads import set_default_threads

            set_default_threads(args.threads)
        if not getattr(args, "func", None):
            parser.print_help(sys.stderr)
            return 2
        with Heartbeat(PROG, args.command, enabled=not getattr(args, "quiet", False)):
            return int(args.func(args))
    except GlocalVerifyError as exc:
        write_line(f"{PROG}: error: {shorten(str(exc))}", fresh=True)
        return 2
    except SystemExit as exc:  # --help, --version
        return exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
    except Stopped as exc:
        _say(_stop_line(exc.signum))
        return exc.exit_code
    except KeyboardInterrupt:
        _say("interrupted")
        return 130
    except BrokenPipeError:  # the reader of stdout went away (| head): nothing more to say
        _silence_stdout()
        return BROKEN_PIPE
    except MemoryError:
        write_line(f"{PROG}: error: out of memory: the problem is too large for this machine (the size limits are explained in docs/performance.md of the glocal-verify source, \"Size limits and estimates\")", fresh=True)
        return 2
    except Exception as exc:  # a bug of the toolkit: one line for the user, the traceback on request
        if stop is not None and stop.signum is not None:
            # the stop in disguise (a signal during an extension's import becomes an ImportError)
            _say(_stop_line(stop.signum))
            return 128 + stop.signum
        if os.environ.get("GLOCAL_DEBUG"):
            raise
        first = str(exc).splitlines()[0][:200] if str(exc) else ""
        write_line(f"{PROG}: internal error ({type(exc).__name__}: {first}); please report it (GLOCAL_DEBUG=1 shows the traceback)", fresh=True)
        return INTERNAL_ERROR


def _silence_stdout() -> None:
    """Point stdout at the null device, so that the interpreter's last flush stays quiet."""
    try:
        fd = os.open(os.devnull, os.O_WRONLY)
        os.dup2(fd, sys.stdout.fileno())
        os.close(fd)
    except (OSError, ValueError, AttributeError):  # captured or replaced stdout: no descriptor
        pass


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
