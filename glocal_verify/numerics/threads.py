"""How many BLAS threads a block of code uses (threadpoolctl).

Two regimes, on a machine with few cores shared by several processes:

* loops over many small or thin matrices (per-step products of a few residual rows, 2 x 2
  modal blocks, cluster-sized SVDs in a greedy search): one thread. Thread start-up and
  synchronisation cost more than the arithmetic, and oversubscribed cores made such loops
  10-20x slower under load;
* a few large dense factorizations and products (an ``eigh`` of an N x N Laplacian, the
  squarings of a 2N x 2N propagator): every core.

:func:`blas_threads` switches between the two for the ``with`` block and restores the previous
limits afterwards. It changes no number: BLAS results may differ in the last bits between
thread counts (a different summation order), which every error bound of the package already
covers (they are stated per floating-point operation, not for one summation order).

A third case is measured, not guessed: the nonsymmetric eigensolvers (``schur``, ``eig``:
Hessenberg QR, mostly level-2 BLAS) gain little from a second thread on an idle machine
(0.67 s -> 0.58 s for a 700 x 700 Schur form) and lose 20x with one other busy process
(18 s with two threads, 0.85 s with one). Functions built on them are :func:`single_threaded`.

Where it is used: :func:`glocal_verify.simulation.thresholds.attack_free_thresholds` (one
thread for the per-step row recursion, all cores for the propagator powers at a switch); the
observer designs and Hurwitz certificates (:func:`single_threaded`). A
command-line ``--threads N`` option sets the default through :func:`set_default_threads`.
"""

from __future__ import annotations

import contextlib
import functools
import os
from contextvars import ContextVar
from typing import Any, Callable, Iterator, TypeVar

_F = TypeVar("_F", bound=Callable[..., Any])

__all__ = ["available_cores", "blas_threads", "set_default_threads", "default_threads", "environment_threads", "single_threaded", "ThreadSwitch"]

#: the thread count "all cores" means (None: every core this process may run on)
_DEFAULT: ContextVar[int | None] = ContextVar("glocal_verify_blas_threads", default=None)
#: inside a :func:`single_threaded` call (nested calls then skip the 0.5 ms re-limit)
_SINGLE: ContextVar[bool] = ContextVar("glocal_verify_single_thread", default=False)
#: the thread count an enclosing :meth:`ThreadSwitch.limit` put in force (None: none did); a
#: nested limit to the same count changes nothing and skips threadpoolctl (about 50 us a call,
#: tens of thousands of calls in an audit's deflation loops)
_IN_FORCE: ContextVar[int | None] = ContextVar("glocal_verify_threads_in_force", default=None)


def available_cores() -> int:
    """Cores this process may run on (``os.sched_getaffinity`` where available)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not on Linux
        return max(1, os.cpu_count() or 1)


#: environment variables that limit the BLAS / OpenMP pools at start-up; "every core" honours
#: the smallest one set (a run started with ``OPENBLAS_NUM_THREADS=1`` stays on one thread)
_THREAD_ENV = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def environment_threads() -> int | None:
    """The smallest positive integer among ``OPENBLAS_NUM_THREADS``, ``OMP_NUM_THREADS`` and
    ``MKL_NUM_THREADS`` (None when none is set to one)."""
    found: list[int] = []
    for key in _THREAD_ENV:
        try:
            k = int(os.environ.get(key, "").strip())
        except ValueError:
            continue
        if k >= 1:
            found.append(k)
    return min(found) if found else None


def default_threads() -> int:
    """The thread count used for ``blas_threads(None)``.

    That is :func:`set_default_threads` (``--threads N``) when set. Otherwise it is every core,
    capped by a thread limit in the environment (:func:`environment_threads`).
    """
    n = _DEFAULT.get()
    if n is not None:
        return n
    env = environment_threads()
    return available_cores() if env is None else min(env, available_cores())


def set_default_threads(n: int | None) -> None:
    """Set what "all cores" means for the rest of this context (``--threads N``; None: every core).

    Parameters
    ----------
    n : int or None
        At least 1.

    Raises
    ------
    ValueError
        For n < 1.
    """
    if n is not None and n < 1:
        raise ValueError(f"the thread count must be at least 1, not {n}")
    _DEFAULT.set(n)


@contextlib.contextmanager
def blas_threads(n: int | None) -> Iterator[int]:
    """Limit the BLAS/OpenMP thread pools to ``n`` threads inside the ``with`` block.

    Parameters
    ----------
    n : int or None
        Threads; None means :func:`default_threads` (all cores unless ``--threads`` said
        otherwise). Values above that are capped to it.

    Yields
    ------
    int
        The thread count in force. Without threadpoolctl installed the block runs unchanged.
    """
    with ThreadSwitch().limit(n) as want:  # one library scan, as threadpool_limits does
        yield want


def single_threaded(func: _F) -> _F:
    """Run ``func`` with one BLAS thread (see the module docstring); nested calls cost nothing.

    Parameters
    ----------
    func : callable
    """

    @functools.wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        if _SINGLE.get():
            return func(*args, **kwargs)
        token = _SINGLE.set(True)
        try:
            with blas_threads(1):
                return func(*args, **kwargs)
        finally:
            _SINGLE.reset(token)

    return wrapper  # type: ignore[return-value]


class ThreadSwitch:
    """Switches the BLAS thread count many times inside one loop, at a few microseconds each.

    :func:`blas_threads` finds the BLAS libraries afresh on each call (threadpoolctl reads the
    process's memory map: about 0.2 ms, 1 ms under a profiler). A loop that alternates between
    one thread for its small products and every core for its large ones creates one switch
    before the loop and calls :meth:`limit` inside it (2.5 us per switch, measured).
    """

    def __init__(self) -> None:
        try:
            from threadpoolctl import ThreadpoolController
        except ImportError:  # pragma: no cover - threadpoolctl is a dependency
            self._controller: Any = None
        else:
            self._controller = ThreadpoolController()

    @contextlib.contextmanager
    def limit(self, n: int | None) -> Iterator[int]:
        """As :func:`blas_threads`: ``n`` threads (None: :func:`default_threads`) inside the block.

        Parameters
        ----------
        n : int or None

        Yields
        ------
        int
            The thread count in force.
        """
        want = 1 if (n is not None and int(n) <= 1) else (default_threads() if n is None else max(1, min(int(n), default_threads())))
        if self._controller is None:  # pragma: no cover
            yield want
            return
        if _IN_FORCE.get() == want:
            yield want
            return
        token = _IN_FORCE.set(want)
        try:
            with self._controller.limit(limits=want):
                yield want
        finally:
            _IN_FORCE.reset(token)
