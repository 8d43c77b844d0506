"""Dask as the executor of work that outgrows one process: sweeps and audits.

:func:`dask_client` opens an embedded ``LocalCluster`` on this machine (worker processes with
one thread each, on 127.0.0.1, no dashboard) or connects to an existing cluster by its
scheduler address, unchanged. :func:`run_on_dask` submits independent picklable callables
(an audit's :class:`~glocal_verify.design.audit.AuditChunk`, a sweep's member chunk) and
yields their results as they complete, so that the caller writes or merges them at once.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any, TypeVar

__all__ = ["dask_client", "dask_executor", "run_on_dask"]

T = TypeVar("T")


@contextmanager
def dask_client(scheduler: str | None = None, workers: int = 2) -> Iterator[Any]:
    """A ``distributed.Client``: to ``scheduler`` if given, else to an embedded LocalCluster.

    The embedded cluster's nannies write their workers' settings into this process's
    environment (``MALLOC_TRIM_THRESHOLD_=65536``, one BLAS and OpenMP thread, ...); the
    environment is restored when the cluster closes, so that processes started later are not
    run with them (a trim threshold of 64 KiB made a later ``glocal-verify verify`` of 2000
    agents 50 % slower: every large temporary went back to the system and faulted in anew).

    Parameters
    ----------
    scheduler : str, optional
        Address of an existing scheduler, e.g. ``tcp://127.0.0.1:8786``.
    workers : int
        Worker processes of the embedded cluster (one thread each).
    """
    import os

    from distributed import Client, LocalCluster

    if scheduler:
        client = Client(scheduler, timeout="60s")
        try:
            yield client
        finally:
            client.close()
        return
    environ = dict(os.environ)
    cluster = LocalCluster(n_workers=max(1, int(workers)), threads_per_worker=1, processes=True, dashboard_address=None, host="127.0.0.1")
    client = Client(cluster)
    try:
        yield client
    finally:
        client.close()
        cluster.close()
        os.environ.clear()
        os.environ.update(environ)


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
        yield futures[fut], fut.result()


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


def dask_executor(scheduler: str | None = None, workers: int = 2, progress: Callable[[int, int], None] | None = None) -> Callable[[Sequence[Callable[[], T]]], list[T]]:
    """An executor for :func:`glocal_verify.design.audit.audit`: runs its chunks on Dask.

    Parameters
    ----------
    scheduler : str, optional
        An existing scheduler's address (default: an embedded LocalCluster).
    workers : int
        Worker processes of the embedded cluster.
    progress : callable, optional
        ``progress(done, total)`` after each finished chunk.
    """

    def execute(tasks: Sequence[Callable[[], T]]) -> list[T]:
        out: list[Any] = [None] * len(tasks)
        with dask_client(scheduler, workers) as client:
            for done, (i, res) in enumerate(run_on_dask(client, tasks), start=1):
                out[i] = res
                if progress is not None:
                    progress(done, len(tasks))
        return out

    return execute
