"""Shared pieces of the command line: the parser class, usage errors, loading and writing."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Iterable

from glocal_verify.errors import GlocalVerifyError
from glocal_verify.reporting.output import check_output_dir, check_output_file, write_text_atomic
from glocal_verify.runtime.files import STDOUT
from glocal_verify.runtime.lines import write_line

if TYPE_CHECKING:
    from glocal_verify.conditions.cost import CostEstimate
    from glocal_verify.model import System

__all__ = [
    "PROG",
    "UsageError",
    "Parser",
    "ids_arg",
    "load_system",
    "spec_inputs",
    "check_out_file",
    "check_out_dir",
    "wrote",
    "write_output",
    "add_allow_large",
    "add_dask_options",
    "check_cost",
    "ETA_WINDOW",
    "LINE_SECONDS",
    "count_progress",
]

PROG = "glocal-verify"


class UsageError(GlocalVerifyError):
    """A bad command line (one line on stderr, exit code 2)."""


class Parser(argparse.ArgumentParser):
    """An argument parser whose errors raise :class:`UsageError` instead of exiting."""

    def error(self, message: str) -> None:  # type: ignore[override]
        raise UsageError(message)


def ids_arg(text: str | None, option: str, *, allow_empty: bool = False) -> list[str] | None:
    """Split the comma-separated value of ``option`` (None stays None; blanks between commas are dropped).

    A value that names nothing (``''``, ``','``, spaces) is a usage error: a gate such as
    ``--require`` given an empty list would otherwise pass every report, and ``--only ''``
    would silently run every checker. ``allow_empty``: an empty list is a meaningful value
    (``--velocities ''``: no agent).

    Raises
    ------
    UsageError
        The value names nothing.
    """
    if text is None:
        return None
    items = [t for t in (x.strip() for x in text.split(",")) if t]
    if not items and not allow_empty:
        raise UsageError(f"{option}: the list is empty ({text[:20]!r}); name at least one (comma-separated)")
    return items


def load_system(args: argparse.Namespace) -> System:
    """The :class:`System` of ``SPEC`` or ``--example NAME`` (exactly one of them)."""
    from glocal_verify.model import System
    from glocal_verify.spec.examples import load_example
    from glocal_verify.spec.load import load_spec

    if args.example and args.spec:
        raise UsageError("give either SPEC or --example, not both")
    if args.example:
        return System(load_example(args.example))
    if not args.spec:
        raise UsageError("a SPEC file or --example NAME is required")
    return System(load_spec(args.spec))


def spec_inputs(args: argparse.Namespace) -> list[str]:
    """The files a command reads (its SPEC and ``--graph``), which ``--out`` must not overwrite."""
    return [str(x) for x in (getattr(args, "spec", None), getattr(args, "graph", None)) if x]


def check_out_file(args: argparse.Namespace, *, inputs: Iterable[str] = ()) -> None:
    """Check ``args.out`` (a file) before computing: not a symbolic link, not an input (the
    SPEC, ``--graph`` and ``inputs``), in a writable folder
    (:func:`~glocal_verify.reporting.output.check_output_file`)."""
    out = getattr(args, "out", None)
    if out is not None:
        check_output_file(out, inputs=[*spec_inputs(args), *inputs])


def check_out_dir(path: str | Path, *, inputs: Iterable[str] = ()) -> Path:
    """Check an output folder before computing (:func:`~glocal_verify.reporting.output.check_output_dir`):
    not a symbolic link, not an input, writable."""
    return check_output_dir(path, inputs=inputs)


def wrote(path: str | Path) -> None:
    """Tell the user where the output went: one line ``wrote <path>`` on stderr (nothing for
    ``-``, standard output)."""
    if str(path) != STDOUT:
        write_line(f"wrote {path}")


def write_output(text: str | Iterable[str], out: str | None, *, inputs: Iterable[str] = ()) -> None:
    """Write ``text`` to the file ``out`` atomically (and say so on stderr), or to stdout.

    Parameters
    ----------
    text : str or iterable of str
        The text, or its chunks (streamed: a long report is never held whole)
    out : str, optional
        Output file (a regular file atomically, a character device or FIFO in place:
        :func:`~glocal_verify.runtime.files.write_bytes_atomic`); None or ``-``: standard output.
    inputs : iterable of str
        Files the command read; ``out`` must not be one of them.
    """
    if out is not None and out != STDOUT:
        p = check_output_file(out, inputs=inputs)
        write_text_atomic(p, text)
        wrote(p)
    elif isinstance(text, str):
        sys.stdout.write(text)
    else:
        for chunk in text:
            sys.stdout.write(chunk)




#: help of ``--allow-large`` (``simulate`` has its own: its limits are samples and bytes)
ALLOW_LARGE_HELP = "run even when the estimated time or memory exceeds the limits (10 min; min(8 GiB, 80%% of the available memory))"


def add_allow_large(parser: argparse.ArgumentParser) -> None:
    """Add ``--allow-large`` (see :func:`check_cost`) to a subcommand's parser.

    Parameters
    ----------
    parser : argparse.ArgumentParser
    """
    parser.add_argument("--allow-large", action="store_true", help=ALLOW_LARGE_HELP)


#: the dashboard address of ``--dashboard`` given without one
DASHBOARD_DEFAULT = "127.0.0.1:8787"


def add_dask_options(parser: argparse.ArgumentParser) -> None:
    """Add ``--dashboard [ADDRESS]`` (the embedded Dask cluster's dashboard; none by default).

    Parameters
    ----------
    parser : argparse.ArgumentParser
    """
    parser.add_argument(
        "--dashboard", nargs="?", const=DASHBOARD_DEFAULT, metavar="ADDRESS",
        help=f"serve the embedded Dask cluster's dashboard (default address {DASHBOARD_DEFAULT}; another port when it is taken)",
    )


def check_cost(est: CostEstimate, args: argparse.Namespace, *, how: Iterable[str] = ()) -> None:
    """Refuse a run whose estimate exceeds the limits, or announce a long one, before it starts.

    Above the limits of :func:`glocal_verify.conditions.cost.default_limits` (unless
    ``--allow-large``) this raises :class:`~glocal_verify.conditions.cost.SizeLimitError`: one
    line on stderr, exit code 2. Otherwise, when the estimate exceeds
    the tunable ``notice_seconds`` (:mod:`glocal_verify.config`) (or a limit, with ``--allow-large``),
    one line with the estimate goes to stderr, unless ``--quiet``.

    Parameters
    ----------
    est : CostEstimate
        From :mod:`glocal_verify.conditions.cost` (``estimate_verify`` ...).
    args : argparse.Namespace
        Reads ``allow_large`` and ``quiet``.
    how : iterable of str
        Further ways out for the refusal line (``"--only CONDITION to run fewer checkers"``).
    """
    from glocal_verify.conditions import cost

    limits = cost.default_limits()
    allow = bool(getattr(args, "allow_large", False))
    cost.check_limits(est, limits, allow=allow, how=tuple(how))
    if getattr(args, "quiet", False):
        return
    over = cost.refusal(est, limits)
    if over is not None:
        write_line(f"{PROG}: {est.command} of {est.n} agents: estimated {est.describe()}, above the {over} limit; running anyway (--allow-large)")
    elif est.seconds > limits.notice_seconds:
        write_line(f"{PROG}: {est.command} of {est.n} agents: estimated {est.describe()}")


#: the time left is extrapolated from the rate of the last this many seconds of progress
ETA_WINDOW = 120.0
#: at most one progress line per this many seconds when stderr is not a terminal
LINE_SECONDS = 10.0


def count_progress(quiet: bool, unit: str = "attack sets", prefix: str = "audit") -> Callable[[int, int], None] | None:
    """A progress callback ``(done, total)``: a bar with ETA on a terminal; otherwise lines on stderr.

    A new ``total``, or a ``done`` that goes back, starts a new phase (the design calls it for
    several audits and checks in turn): a new bar, a new clock, a new rate. Off a terminal a
    phase prints

    - ``<prefix>: <total> <unit> ...`` when it starts (a first call with ``done == 0``), so
      that the heartbeat's still-working lines name it;
    - at most once per :data:`LINE_SECONDS` in between, ``<prefix>: <done>/<total> <unit>, <s>
      s elapsed, about <s> s left`` (the phase's own clock);
    - when it ends, ``<prefix>: <total>/<total> <unit> in <s> s``: never a time left at
      completion.

    The time left is the units left over the rate of the last :data:`ETA_WINDOW` seconds
    (from the first report on, so the set-up before it does not count): sets differ widely in
    cost (a set that needs its whole zero set costs a thousand times a screened one), and the
    recent rate follows the mix the chunks actually hold.

    Parameters
    ----------
    quiet : bool
        ``--quiet``: no callback (None).
    unit : str
        What is counted (``"attack sets"``, ``"tasks"``).
    prefix : str
        The command named at the start of each line.
    """
    if quiet:
        return None
    import collections
    import time

    seen: collections.deque[tuple[float, int]] = collections.deque()
    phase: dict[str, Any] = {"total": None, "start": 0.0, "lines": 0, "last": 0.0}

    def eta(done: int, total: int) -> tuple[float, float]:
        """(seconds of the phase so far, seconds left or NaN); a new phase starts its clock."""
        now = time.monotonic()
        if phase["total"] != total or (seen and done < seen[-1][1]) or (done == 0 and phase["lines"]):  # a new phase
            seen.clear()
            phase.update(total=total, start=now, lines=0, last=now)
        if done == 0:  # the phase's start: its set-up does not count in the rate
            return 0.0, float("nan")
        seen.append((now, done))
        while len(seen) > 2 and now - seen[1][0] >= ETA_WINDOW:
            seen.popleft()
        (t0, d0) = seen[0]
        if done <= d0 or now <= t0:
            return now - phase["start"], float("nan")
        return now - phase["start"], (total - done) * (now - t0) / (done - d0)

    if not sys.stderr.isatty():

        def line(done: int, total: int) -> None:
            elapsed, left = eta(done, total)
            now = time.monotonic()
            if done >= total:
                text = f"{prefix}: {done}/{total} {unit} in {elapsed:.0f} s"
            elif not phase["lines"] and done == 0:
                text = f"{prefix}: {total} {unit} ..."
            elif now - phase["last"] < LINE_SECONDS:
                return
            else:
                tail = f", about {left:.0f} s left" if left == left else ""
                text = f"{prefix}: {done}/{total} {unit}, {elapsed:.0f} s elapsed{tail}"
            phase["lines"] += 1
            phase["last"] = now
            write_line(text)

        return line
    from tqdm import tqdm

    bar: dict[str, Any] = {}

    def tick(done: int, total: int) -> None:
        if "bar" not in bar or bar["bar"].total != total or bar["bar"].n > done:
            # tqdm's own remaining time averages over the whole run: show the windowed one
            bar["bar"] = tqdm(total=total, desc=f"{prefix}: {unit}", leave=False, bar_format="{desc}: {percentage:3.0f}%|{bar}| {n_fmt}/{total_fmt} [{elapsed}{postfix}]")
        b = bar["bar"]
        b.update(done - b.n)
        if done >= total:
            b.close()
            return
        _, left = eta(done, total)
        if left == left:  # not NaN
            b.set_postfix_str(f"about {left:.0f} s left", refresh=True)

    return tick
