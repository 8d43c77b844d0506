"""Computations with a hard wall-time limit.

An exact re-decision spends most of its time inside one call into python-flint (a rational
characteristic polynomial, a large elimination). A Python signal handler runs only between
bytecodes, so a ``SIGALRM`` cannot stop such a call: a 30 s budget ran 127 s on a 250-agent
network. :func:`call_with_deadline` therefore runs the computation in a forked child and
kills the child at the deadline; the parent keeps its state, and the child's memory is
returned to the system with it. Where ``os.fork`` is missing (not POSIX) the interval timer
is the fallback, and it is documented as soft there.

The child never outlives its parent: it asks for ``SIGKILL`` when the parent ends, ignores
the terminal's ``SIGINT`` and dies at once on ``SIGTERM``
(:func:`glocal_verify.runtime.processes.after_fork_in_child`); the parent kills it on any
exception, a stop signal included.
"""

from __future__ import annotations

import math
import os
import pickle
import select
import signal
import threading
import time
from collections.abc import Callable
from typing import Any, TypeVar

from glocal_verify.runtime.processes import after_fork_in_child

T = TypeVar("T")

#: longest single wait on the child's pipe (seconds); a longer deadline waits in several
#: steps (``select`` refuses timeouts beyond about 2^31 ms on some platforms)
_WAIT_STEP = 3600.0

__all__ = ["DeadlineExceeded", "call_with_deadline", "hard_deadlines_available"]


class DeadlineExceeded(Exception):
    """The computation did not finish within its wall-time limit (it was stopped)."""


def hard_deadlines_available() -> bool:
    """True when :func:`call_with_deadline` can stop any computation (``os.fork`` exists)."""
    return hasattr(os, "fork")


def call_with_deadline(func: Callable[[], T], seconds: float | None) -> T:
    """``func()``, stopped after ``seconds`` of wall time.

    Parameters
    ----------
    func : callable
        Takes no argument; its result (or the exception it raises) must be picklable when the
        hard limit is used.
    seconds : float or None
        Wall-time limit; ``None``, a value <= 0, ``inf`` or NaN runs ``func`` with no limit, in
        this process.

    Returns
    -------
    The value ``func()`` returned.

    Raises
    ------
    DeadlineExceeded
        The limit passed first; the child running ``func`` was killed (``SIGKILL``).
    Exception
        Whatever ``func`` raised, re-raised here.

    Notes
    -----
    With ``os.fork`` the child shares the parent's memory copy-on-write, so nothing is
    serialised on the way in; only the result travels back, through a pipe. Side effects of
    ``func`` on objects of the parent (caches) are lost. A ``KeyboardInterrupt`` while
    waiting kills the child and propagates.
    """
    if seconds is None or not 0 < seconds < math.inf:
        return func()
    if not hard_deadlines_available():
        return _soft_deadline(func, seconds)
    return _forked(func, float(seconds))


def _forked(func: Callable[[], T], seconds: float) -> T:
    read_fd, write_fd = os.pipe()
    parent = os.getpid()
    pid = os.fork()
    if pid == 0:  # the child: compute, send, leave without running the parent's exit handlers
        code = 0
        try:
            after_fork_in_child(parent)
            os.close(read_fd)
            try:
                payload = pickle.dumps(("ok", func()), protocol=pickle.HIGHEST_PROTOCOL)
            except BaseException as exc:  # noqa: BLE001 - every outcome goes back to the parent
                try:
                    payload = pickle.dumps(("err", exc), protocol=pickle.HIGHEST_PROTOCOL)
                except Exception:  # noqa: BLE001
                    payload = pickle.dumps(("err", RuntimeError(f"{type(exc).__name__}: {exc}")))
            view = memoryview(payload)
            while view:
                view = view[os.write(write_fd, view) :]
        except BaseException:  # noqa: BLE001
            code = 1
        finally:
            os._exit(code)
    os.close(write_fd)
    chunks: list[bytes] = []
    end = time.monotonic() + seconds
    try:
        while True:
            left = end - time.monotonic()
            if left <= 0:
                raise DeadlineExceeded(f"stopped after {seconds:g} s")
            ready, _, _ = select.select([read_fd], [], [], min(left, _WAIT_STEP))
            if not ready:
                continue
            chunk = os.read(read_fd, 1 << 20)
            if not chunk:
                break
            chunks.append(chunk)
    except BaseException:
        _kill(pid)
        raise
    finally:
        os.close(read_fd)
    _, status = os.waitpid(pid, 0)
    if not chunks:
        raise RuntimeError(f"the computation's process ended without a result (wait status {status})")
    kind, value = pickle.loads(b"".join(chunks))
    if kind == "err":
        raise value
    return value  # type: ignore[no-any-return]


def _kill(pid: int) -> None:
    try:
        os.kill(pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    try:
        os.waitpid(pid, 0)
    except ChildProcessError:
        pass


def _soft_deadline(func: Callable[[], T], seconds: float) -> T:
    """The interval-timer fallback: stops between bytecodes only (main thread, POSIX)."""
    usable = hasattr(signal, "setitimer") and threading.current_thread() is threading.main_thread()
    if not usable:
        return func()

    def alarm(signum: int, frame: Any) -> None:
        raise DeadlineExceeded(f"stopped after {seconds:g} s")

    old = signal.signal(signal.SIGALRM, alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)  # type: ignore[attr-defined]
    try:
        return func()
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)  # type: ignore[attr-defined]
        signal.signal(signal.SIGALRM, old)
