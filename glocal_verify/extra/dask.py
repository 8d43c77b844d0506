"""Dask as the executor of work that outgrows one process: sweeps and audits.

:func:`dask_client` opens an embedded ``LocalCluster`` on this machine (worker processes with
one thread each, on 127.0.0.1) or connects to an existing cluster by its scheduler address,
unchanged. :func:`run_on_dask` submits independent picklable callables (an audit's
:class:`~glocal_verify.design.audit.AuditChunk`, a sweep's member chunk) and yields their
results as they complete, so that the caller writes or merges them at once.

Defaults that suit a laptop:

* no dashboard unless asked for (``dashboard="127.0.0.1:8787"``); the scheduler's own HTTP
  server takes a free port, so no "Port 8787 is already in use" warning appears, and when an
  asked-for port is taken the caller gets one line with the port used instead;
* :func:`workers_pay_off`: a run whose estimated work is below what starting the workers costs
  (:data:`DASK_OVERHEAD_SECONDS`; ``audit --workers 2`` of the 19-agent example took 6.0 s
  against 2.3 s in one process) is better run in this process, and the commands do so;
* the embedded workers die with this process (:func:`dask_setup` asks the kernel for it, see
  :mod:`glocal_verify.runtime.processes`), ignore the terminal's Ctrl-C (this process decides)
  and log only errors; when a command is stopped its workers are killed at once, so a Ctrl-C
  prints one line, not the tracebacks of workers shutting down.
"""

from __future__ import annotations

import contextlib
import dataclasses
import gc
import logging
import os
import signal
import sys
import threading
import warnings
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any, TypeVar

from glocal_verify.errors import ArgumentError
from glocal_verify.runtime.processes import defer_stop_signals, die_with_parent

__all__ = ["DASK_OVERHEAD_SECONDS", "DaskExecutor", "dask_client", "dask_executor", "dask_setup", "run_on_dask", "workers_pay_off"]

T = TypeVar("T")


#: seconds that starting an embedded cluster, importing the toolkit in its workers and sending
#: them the shared data add to a run (measured: 1.6 s for an empty 2-worker cluster with the
#: imports, 3.7 s more than the serial run for ``audit --example paper19 --workers 2``)
DASK_OVERHEAD_SECONDS = 4.0


def workers_pay_off(serial_seconds: float, workers: int) -> bool:
    """Whether ``workers`` local processes finish sooner than this process alone.

    With :math:`W = \\min(\\text{workers}, \\text{cores})` and :math:`t` the estimated work in one
    process, the workers take about :math:`D + t / W` (:math:`D` =
    :data:`DASK_OVERHEAD_SECONDS`): they pay off when :math:`t > D\\, W / (W - 1)`, never for
    :math:`W = 1`.

    Parameters
    ----------
    serial_seconds : float
        Estimated seconds of the work in one process (start-up of the command excluded).
    workers : int
        Worker processes asked for.
    """
    w = min(int(workers), os.cpu_count() or 1)
    return w > 1 and serial_seconds > DASK_OVERHEAD_SECONDS * w / (w - 1)


def dask_setup(worker: Any) -> None:
    """Set-up of every embedded worker process (a Dask preload: this module is named in
    ``LocalCluster(preload=...)``): die with the process that started the cluster, and leave a
    terminal's Ctrl-C to it.

    Parameters
    ----------
    worker : distributed.Worker
    """
    die_with_parent()
    if os.getppid() == 1:  # the starting process ended before the request
        os._exit(1)
    try:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    except ValueError:  # pragma: no cover - not the worker's main thread
        pass


@contextmanager
def dask_client(scheduler: str | None = None, workers: int = 2, *, dashboard: str | None = None, notice: Callable[[str], None] | None = None) -> Iterator[Any]:
    """A ``distributed.Client``: to ``scheduler`` if given, else to an embedded LocalCluster.

    The embedded cluster's nannies write their workers' settings into this process's
    environment (``MALLOC_TRIM_THRESHOLD_=65536``, one BLAS and OpenMP thread, ...); the
    environment is restored when the cluster closes, so that processes started later are not
    run with them (a trim threshold of 64 KiB made a later ``glocal-verify verify`` of 2000
    agents 50 % slower: every large temporary went back to the system and faulted in anew).
    Leaving the block by an exception (a stop signal included) kills the workers at once.

    Parameters
    ----------
    scheduler : str, optional
        Address of an existing scheduler, e.g. ``tcp://127.0.0.1:8786``.
    workers : int
        Worker processes of the embedded cluster (one thread each).
    dashboard : str, optional
        Address of the embedded cluster's dashboard (``"127.0.0.1:8787"``, ``":8787"``);
        default none.
    notice : callable, optional
        Gets one line when the dashboard had to take another port than the one asked for.
    """
    from distributed import Client, LocalCluster

    if scheduler:
        remote = _connect(scheduler)
        try:
            yield remote
        finally:
            with contextlib.suppress(Exception):
                remote.close()
        return
    environ = dict(os.environ)
    options: dict[str, Any] = {"dashboard_address": dashboard} if dashboard else {"dashboard_address": None, "scheduler_kwargs": {"dashboard_address": "127.0.0.1:0"}}
    cluster: Any = None
    client: Any = None
    ok = False
    loggers = [logging.getLogger(name) for name in ("distributed", "asyncio", "tornado")]
    levels = [lg.level for lg in loggers]
    loggers[0].setLevel(logging.ERROR)  # the scheduler runs here: its notes on closed comms are no news
    try:
        # a stop signal while the workers start would leave a half-made cluster whose clean-up at
        # exit asserts: it is held until the cluster exists, then stops the run here; the workers
        # start with SIGINT ignored (_sigint_ignored)
        with warnings.catch_warnings(record=True) as caught, defer_stop_signals(), _sigint_ignored():
            warnings.simplefilter("always")
            cluster = LocalCluster(
                n_workers=max(1, int(workers)), threads_per_worker=1, processes=True, host="127.0.0.1",
                silence_logs=logging.ERROR, preload=[__name__], **options,
            )
        moved = [str(w.message).splitlines()[0] for w in caught if "already in use" in str(w.message)]
        if moved and notice is not None:
            notice(f"{moved[0].rstrip('.')}: the Dask dashboard is at {cluster.dashboard_link}")
        client = Client(cluster)
        yield client
        ok = True
    finally:
        if cluster is not None and not ok:
            for lg in loggers:  # a stop: what the scheduler says of the workers it loses is no news either
                lg.setLevel(logging.CRITICAL + 1)
            _kill_workers(cluster)
        if client is not None:
            with contextlib.suppress(Exception):
                client.close()
        if cluster is not None:
            with contextlib.suppress(Exception):
                cluster.close(timeout=5 if ok else 2)
        for lg, lv in zip(loggers, levels):
            lg.setLevel(lv)
        os.environ.clear()
        os.environ.update(environ)


@contextmanager
def _sigint_ignored() -> Iterator[None]:
    """``SIGINT`` ignored inside the block, without losing a terminal's Ctrl-C.

    The worker processes started in the block inherit the ignoring across exec (a blocked mask
    does not survive multiprocessing's spawn), so the Ctrl-C a terminal sends to the whole
    process group cannot kill one half-started (its traceback, then "Nanny failed to start").
    A forked sentinel keeps the default action meanwhile: if it died of ``SIGINT``, the signal
    is sent again to this process when the block ends.
    """
    if threading.current_thread() is not threading.main_thread() or not hasattr(os, "fork"):
        yield
        return
    parent = os.getpid()
    pid = os.fork()
    if pid == 0:  # the sentinel: only async-signal-safe work, then wait for a signal
        try:
            signal.signal(signal.SIGINT, signal.SIG_DFL)
            die_with_parent(parent)
            while True:
                signal.pause()
        finally:
            os._exit(0)
    old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)
        done, status = os.waitpid(pid, os.WNOHANG)
        if not done:
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
        elif os.WIFSIGNALED(status) and os.WTERMSIG(status) == signal.SIGINT:
            os.kill(os.getpid(), signal.SIGINT)


#: seconds to reach a ``--scheduler`` before giving up (one line, exit 2)
SCHEDULER_TIMEOUT = 10.0


def _connect(scheduler: str) -> Any:
    """A client of the scheduler at ``scheduler``, or one :class:`ArgumentError` line.

    A TCP address is tried with a plain socket first, so that an address nobody listens on
    fails at once, without a half-made client whose clean-up prints tracebacks at exit.
    """
    import socket

    from distributed import Client
    from distributed.comm.addressing import parse_address, parse_host_port

    try:
        proto, loc = parse_address(scheduler)
        if proto in ("tcp", "tls"):
            host, port = parse_host_port(loc)
            socket.create_connection((host, int(port)), timeout=SCHEDULER_TIMEOUT).close()
    except (ValueError, TypeError, OSError) as exc:
        raise ArgumentError(f"--scheduler {scheduler!r}: cannot reach a Dask scheduler there ({str(exc).splitlines()[0][:120] if str(exc) else type(exc).__name__})") from None
    box: dict[str, Any] = {}

    def make() -> None:  # in a thread: Dask's handshake has no time limit of its own
        try:
            box["client"] = Client(scheduler, timeout=f"{SCHEDULER_TIMEOUT:g}s")
        except BaseException as exc:  # noqa: BLE001 - reported below, in one line
            box["error"] = exc

    maker = threading.Thread(target=make, name="glocal-verify scheduler connection", daemon=True)
    maker.start()
    maker.join(2 * SCHEDULER_TIMEOUT)
    if "client" in box:
        return box["client"]
    error = box.pop("error", None)
    failure = (str(error).splitlines()[0][:120] if str(error) else type(error).__name__) if error is not None else f"no answer within {2 * SCHEDULER_TIMEOUT:g} s"
    del error
    hook = sys.unraisablehook
    sys.unraisablehook = lambda unraisable: None  # the half-made client's clean-up: nothing to tell
    try:
        gc.collect()
    finally:
        sys.unraisablehook = hook
    raise ArgumentError(f"--scheduler {scheduler!r}: no Dask scheduler answered ({failure})")


def _kill_workers(cluster: Any) -> None:
    """``SIGKILL`` every worker process of an embedded cluster (their own children die with them)."""
    for nanny in list(getattr(cluster, "workers", {}).values()):
        pid = getattr(getattr(nanny, "process", None), "pid", None)
        if pid:
            with contextlib.suppress(OSError):
                os.kill(pid, signal.SIGKILL)


def run_on_dask(client: Any, tasks: Sequence[Callable[[], T]]) -> Iterator[tuple[int, T]]:
    """Run each zero-argument callable on the cluster; yield ``(index, result)`` as they finish.

    Tasks that are dataclasses with a ``shared`` field holding one and the same object (an
    audit's chunks share the system, its spectrum and minor tables: about 140 MB at N = 1000)
    send that object once: it is scattered to every worker and each task travels without it,
    so the client does not pickle it once per task.

    Parameters
    ----------
    client : distributed.Client
    tasks : sequence of callables
        Picklable, independent.
    """
    from distributed import as_completed

    shared = _common_shared(tasks)
    if shared is not None:
        ref = client.scatter(shared, broadcast=True, hash=False)
        futures = {client.submit(_call_shared, ref, dataclasses.replace(t, shared=None), pure=False): i for i, t in enumerate(tasks)}  # type: ignore[type-var]
    else:
        futures = {client.submit(_call, t, pure=False): i for i, t in enumerate(tasks)}
    for fut in as_completed(list(futures)):
        i = futures.pop(fut)
        result = fut.result()
        fut.release()  # a finished task's result leaves the worker at once (an audit's rows are ~1 GB)
        del fut
        yield i, result


def _common_shared(tasks: Sequence[Any]) -> Any:
    """The one object every task holds in its ``shared`` field, or None."""
    if not tasks or not all(dataclasses.is_dataclass(t) and any(f.name == "shared" for f in dataclasses.fields(t)) for t in tasks):
        return None
    first = tasks[0].shared
    return first if first is not None and all(t.shared is first for t in tasks) else None


def _call(task: Callable[[], T]) -> T:
    return task()


def _call_shared(shared: Any, stub: Any) -> Any:
    return dataclasses.replace(stub, shared=shared)()


class DaskExecutor:
    """An executor for :func:`glocal_verify.design.audit.audit`: runs its chunks on Dask.

    Called with a list of zero-argument callables, it returns their results in order; a task
    with a ``receive`` method gets each of its results passed through it in this process as
    it arrives (:meth:`glocal_verify.design.audit.AuditChunk.receive`). Used as
    a context manager it keeps one cluster (or one connection) for every call inside the block
    (an audit calls it twice: its single agents, then its sets); otherwise each call opens
    and closes its own.

    Parameters
    ----------
    scheduler : str, optional
        An existing scheduler's address (default: an embedded LocalCluster).
    workers : int
        Worker processes of the embedded cluster.
    progress : callable, optional
        ``progress(0, total)`` when a list of tasks starts, then ``progress(done, total)``
        after each finished chunk.
    dashboard, notice :
        As for :func:`dask_client`.
    """

    def __init__(
        self, scheduler: str | None = None, workers: int = 2, progress: Callable[[int, int], None] | None = None,
        *, dashboard: str | None = None, notice: Callable[[str], None] | None = None,
    ) -> None:
        self.scheduler = scheduler
        self.workers = workers
        self.progress = progress
        self.dashboard = dashboard
        self.notice = notice
        self._stack: contextlib.ExitStack | None = None
        self._client: Any = None

    def __enter__(self) -> DaskExecutor:
        self._stack = contextlib.ExitStack()
        self._client = self._stack.enter_context(dask_client(self.scheduler, self.workers, dashboard=self.dashboard, notice=self.notice))
        return self

    def __exit__(self, *exc: Any) -> None:
        stack, self._stack, self._client = self._stack, None, None
        if stack is not None:
            stack.__exit__(*exc)

    def _run(self, client: Any, tasks: Sequence[Callable[[], T]]) -> list[T]:
        out: list[Any] = [None] * len(tasks)
        if self.progress is not None:
            self.progress(0, len(tasks))
        for done, (i, res) in enumerate(run_on_dask(client, tasks), start=1):
            receive = getattr(tasks[i], "receive", None)
            out[i] = receive(res) if receive is not None else res  # e.g. an audit chunk's rows, stored compactly
            if self.progress is not None:
                self.progress(done, len(tasks))
        return out

    def __call__(self, tasks: Sequence[Callable[[], T]]) -> list[T]:
        if self._client is not None:
            return self._run(self._client, tasks)
        with dask_client(self.scheduler, self.workers, dashboard=self.dashboard, notice=self.notice) as client:
            return self._run(client, tasks)


def dask_executor(scheduler: str | None = None, workers: int = 2, progress: Callable[[int, int], None] | None = None) -> DaskExecutor:
    """A :class:`DaskExecutor` (kept for callers of the earlier function).

    Parameters
    ----------
    scheduler : str, optional
    workers : int
    progress : callable, optional
    """
    return DaskExecutor(scheduler, workers, progress)
