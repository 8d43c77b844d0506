"""Signals and child processes: a run stops the same way whatever stops it, and leaves no process behind.

Stop signals
    ``SIGINT`` (Ctrl-C), ``SIGTERM`` (``kill``, a job scheduler, a container stopping) and
    ``SIGHUP`` (the terminal closing). Inside :func:`stop_on_signals` each of them raises
    :class:`Stopped` in the main thread, a :class:`KeyboardInterrupt` carrying the signal, so
    that every ``finally`` and ``except BaseException`` block of the toolkit (temporary files,
    staging folders, Dask clusters, forked exact computations) cleans up exactly as for Ctrl-C.
    The command line then prints one line and exits with ``128 + signal number`` (130, 143,
    129). A second stop signal while the first is being handled ends the process at once
    (``os._exit``; children die with it, see below). :func:`defer_stop_signals` holds the
    signals for the few system calls that move finished files into place.

Child processes
    Every process the toolkit starts dies with the process that started it:

    * a forked computation (:mod:`glocal_verify.numerics.deadline`) calls
      :func:`after_fork_in_child` first: on Linux it asks the kernel for ``SIGKILL`` when its
      parent ends (``prctl(PR_SET_PDEATHSIG)``; checked against a parent that ended before the
      call), ignores ``SIGINT`` (a terminal's Ctrl-C reaches the whole process group; the
      parent decides) and takes the default, immediate action for ``SIGTERM`` and ``SIGHUP``;
      the parent kills it (``SIGKILL``) on any exception, a stop signal included;
    * an embedded Dask worker (:mod:`glocal_verify.extra.dask`) does the same in its
      set-up; its cluster is closed, or its processes killed, when the command stops.

    Where ``prctl`` does not exist (not Linux) the parent's clean-up is the only guarantee: a
    parent killed by ``SIGKILL`` there can leave a computation running until it finishes.

Layer: runtime; imports only the standard library.
"""

from __future__ import annotations

import contextlib
import ctypes
import gc
import os
import signal
import sys
import threading
from collections.abc import Callable, Iterator
from types import FrameType
from typing import Any

__all__ = [
    "StopRequest",
    "STOP_SIGNALS",
    "Stopped",
    "signal_name",
    "stop_on_signals",
    "defer_stop_signals",
    "die_with_parent",
    "after_fork_in_child",
]

#: the signals that stop a run like Ctrl-C (those that exist on this platform)
STOP_SIGNALS: tuple[int, ...] = tuple(getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, name))

#: prctl option of Linux: the signal sent to this process when its parent ends
_PR_SET_PDEATHSIG = 1


class Stopped(KeyboardInterrupt):
    """A run stopped by a signal (``SIGINT``, ``SIGTERM`` or ``SIGHUP``).

    A :class:`KeyboardInterrupt`, so that ``except Exception`` never swallows it and every
    clean-up written for Ctrl-C runs.

    Parameters
    ----------
    signum : int
        The signal number.

    Attributes
    ----------
    signum : int
    exit_code : int
        ``128 + signum``, the exit status a shell reports for a process ended by the signal.
    """

    def __init__(self, signum: int) -> None:
        super().__init__(signal_name(signum))
        self.signum = int(signum)
        self.exit_code = 128 + int(signum)


def signal_name(signum: int) -> str:
    """``"SIGTERM"`` for 15 (the number as text when the platform has no name for it)."""
    try:
        return signal.Signals(signum).name
    except ValueError:
        return f"signal {signum}"


def _main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


class StopRequest:
    """The stop signal a :func:`stop_on_signals` block received, if any (``signum``).

    A caller whose own error handling may see the stop only in disguise (a signal during an
    extension module's import surfaces as an ``ImportError``) asks it whether the failure is
    really a stop.
    """

    __slots__ = ("signum",)

    def __init__(self) -> None:
        self.signum: int | None = None

    def __repr__(self) -> str:
        return f"StopRequest({'none' if self.signum is None else signal_name(self.signum)})"


@contextlib.contextmanager
def stop_on_signals(on_force: Callable[[int], None] | None = None, *, final: bool = False) -> Iterator[StopRequest]:
    """Turn the stop signals into :class:`Stopped` inside the block (main thread only).

    The first stop signal raises :class:`Stopped`; a further one while that is being handled
    calls ``on_force(signum)`` (e.g. to print a line) and ends the process at once with
    ``os._exit(128 + signum)``. The previous handlers are restored on leaving the block.
    Outside the main thread (or where handlers cannot be installed) the block runs unchanged.

    A stop is never lost: where Python cannot propagate the exception (the signal arrives
    inside a finalizer or a weak-reference callback, which Python reports as "Exception
    ignored in ..." and goes on), the report is withheld (``sys.unraisablehook``) and the
    block raises :class:`Stopped` when it ends.

    Parameters
    ----------
    on_force : callable, optional
        Called with the signal number before a forced exit.
    final : bool
        The block is a process's whole work (the command line's entry point): on leaving it
        the stop signals are ignored instead of restored, so a stop that arrives during the
        interpreter's shutdown, after the command's last write, leaves the process to end
        with the command's own status instead of killing it by the default action.

    Yields
    ------
    StopRequest
        Set to the first stop signal received in the block.
    """
    request = StopRequest()
    if not _main_thread():
        yield request
        return
    hit: list[int] = []

    def handler(signum: int, frame: FrameType | None) -> None:
        if hit:
            if on_force is not None:
                with contextlib.suppress(Exception):
                    on_force(signum)
            os._exit(128 + signum)
        hit.append(signum)
        request.signum = signum
        raise Stopped(signum)

    previous_hook = sys.unraisablehook
    swallowed: list[int] = []

    def unraisable(info: Any) -> None:
        if isinstance(info.exc_value, Stopped):
            swallowed.append(info.exc_value.signum)  # raised again when the block ends
            return
        previous_hook(info)

    old: dict[int, Any] = {}
    try:
        for sig in STOP_SIGNALS:
            if signal.getsignal(sig) is signal.SIG_IGN:
                continue  # ignored on purpose (nohup, a background job): keep it
            old[sig] = signal.signal(sig, handler)
    except (ValueError, OSError):  # pragma: no cover - an embedded interpreter without signals
        pass
    sys.unraisablehook = unraisable
    try:
        yield request
    finally:
        sys.unraisablehook = previous_hook
        for sig, h in old.items():
            with contextlib.suppress(ValueError, OSError, TypeError):
                signal.signal(sig, signal.SIG_IGN if final else (h if h is not None else signal.SIG_DFL))
    if swallowed:  # the Stopped raised for it was lost where Python cannot propagate it
        raise Stopped(swallowed[0])


@contextlib.contextmanager
def defer_stop_signals() -> Iterator[None]:
    """Hold the stop signals inside the block; act on the first one held when it ends.

    For the few system calls that move finished files into place: a signal arriving between
    two renames must not leave half of the files moved. On leaving the block (normally, or by an
    exception, which then becomes the stop's context), a held signal is delivered to the handler that was installed before (which raises
    :class:`Stopped` under :func:`stop_on_signals`, ``KeyboardInterrupt`` for Python's default
    ``SIGINT`` handler, or ends the process for a default ``SIGTERM``). Main thread only;
    elsewhere the block runs unchanged.
    """
    if not _main_thread():
        yield
        return
    held: list[int] = []

    def hold(signum: int, frame: FrameType | None) -> None:
        held.append(signum)

    old: dict[int, Any] = {}
    try:
        for sig in STOP_SIGNALS:
            if signal.getsignal(sig) is not signal.SIG_IGN:
                old[sig] = signal.signal(sig, hold)
    except (ValueError, OSError):  # pragma: no cover
        pass
    try:
        yield
    finally:
        for sig, h in old.items():
            with contextlib.suppress(ValueError, OSError, TypeError):
                signal.signal(sig, h if h is not None else signal.SIG_DFL)
        if held:  # the stop comes first, also when the block failed (the failure is its context)
            _deliver(held[0], old.get(held[0]))


def _deliver(sig: int, h: Any) -> None:
    """Act on a held signal as the handler ``h`` installed before would have."""
    if callable(h):
        h(sig, None)
    elif sig == getattr(signal, "SIGINT", None):
        raise KeyboardInterrupt
    else:
        os.kill(os.getpid(), sig)  # the default action, now that it is restored


def die_with_parent(parent_pid: int | None = None) -> bool:
    """Ask the kernel to send this process ``SIGKILL`` when its parent ends (Linux).

    Parameters
    ----------
    parent_pid : int, optional
        The parent's pid as the parent saw it before starting this process: if the parent has
        already ended (this process was re-parented before the request), this process ends now.

    Returns
    -------
    bool
        Whether the request was made (False where ``prctl`` is missing).
    """
    done = False
    if sys.platform.startswith("linux"):
        try:
            libc = ctypes.CDLL(None, use_errno=True)
            done = libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) == 0
        except (OSError, AttributeError):  # pragma: no cover - a libc without prctl
            done = False
    if parent_pid is not None and os.getppid() != parent_pid:
        os._exit(1)
    return done


def after_fork_in_child(parent_pid: int) -> None:
    """Set-up of a forked child that computes for its parent and must not outlive it.

    Dies with the parent (:func:`die_with_parent`), ignores ``SIGINT`` (the parent decides
    what a Ctrl-C stops), takes the default action of ``SIGTERM`` and ``SIGHUP`` (end now) and
    drops the garbage-collection callbacks inherited from the parent's libraries (Dask's
    memory diagnosis reads the parent's process, which may be gone).

    Parameters
    ----------
    parent_pid : int
        ``os.getpid()`` of the parent, read before ``os.fork``.
    """
    die_with_parent(parent_pid)
    for sig in STOP_SIGNALS:
        with contextlib.suppress(ValueError, OSError):
            signal.signal(sig, signal.SIG_IGN if sig == signal.SIGINT else signal.SIG_DFL)
    gc.callbacks.clear()
