"""Timing helpers and the row type of the benchmark report."""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

__all__ = ["Row", "Measured", "best_time", "run_command", "eigh_seconds", "write_spec", "cli", "self_peak_mib"]


@dataclass(frozen=True, slots=True)
class Row:
    """One comparison: ``candidate`` against ``baseline`` on the same input."""

    group: str
    case: str
    baseline: str
    baseline_s: float | None
    candidate: str
    candidate_s: float
    note: str = ""
    peak_mib: float | None = None
    #: undecided verdicts of the candidate's run ("3 of 57"; "" where it decides nothing)
    undecided: str = ""

    @property
    def ratio(self) -> float | None:
        """baseline time / candidate time (> 1: the candidate is faster)."""
        if self.baseline_s is None or self.candidate_s <= 0:
            return None
        return self.baseline_s / self.candidate_s


def best_time(func: Callable[[], object], repeat: int = 3, budget: float = 20.0) -> float:
    """Best wall time of ``func()`` over ``repeat`` runs (fewer if one run exceeds ``budget / repeat``)."""
    best = float("inf")
    for k in range(repeat):
        t0 = time.perf_counter()
        func()
        dt = time.perf_counter() - t0
        best = min(best, dt)
        if dt * (k + 2) > budget:
            break
    return best


@dataclass(frozen=True, slots=True)
class Measured:
    """One command run in its own process: wall and CPU seconds, peak resident memory."""

    seconds: float
    cpu_seconds: float
    peak_mib: float
    returncode: int | None
    timed_out: bool

    def describe(self, budget: float) -> str:
        """``"12.3 CPU-s"`` or ``"timed out after 600 s"`` / ``"exit 1"``."""
        if self.timed_out:
            return f"timed out after {budget:g} s (not finished)"
        code = f", exit {self.returncode}" if self.returncode not in (0, None) else ""
        return f"{self.cpu_seconds:.1f} CPU-s{code}"


def run_command(argv: Sequence[str], *, timeout: float, cwd: str | None = None, tree: bool = False) -> Measured:
    """Run ``argv`` in a child process (stdout and stderr discarded) and measure it.

    Peak memory is the child's own high-water mark (VmHWM of /proc, read every 0.1 s while it
    runs; a last-moment peak may be missed), else ``ru_maxrss`` from ``os.wait4``; with
    ``tree`` (a command that starts worker processes, e.g. ``--workers``) the largest sum of
    the resident sets of the child and all its descendants seen at those reads (psutil, a
    dependency of Dask), when that is larger. A child still running after ``timeout`` seconds
    is killed (by its pid) and reported as timed out.
    """
    t0 = time.perf_counter()
    proc = subprocess.Popen(list(argv), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=cwd)
    timed_out = False
    hwm = 0.0
    while True:
        pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
        if pid == proc.pid:
            break
        hwm = max(hwm, _vm_hwm_mib(proc.pid), _tree_rss_mib(proc.pid) if tree else 0.0)
        if time.perf_counter() - t0 > timeout:
            timed_out = True
            proc.kill()
            pid, status, usage = os.wait4(proc.pid, 0)
            break
        time.sleep(0.1)
    proc.returncode = os.waitstatus_to_exitcode(status)  # already reaped: keep Popen quiet
    dt = time.perf_counter() - t0
    # ru_maxrss of a forked child counts the parent's pages it held before exec, so a large
    # benchmark process inflates every later row: the child's own high-water mark (VmHWM, read
    # while it runs) is used where /proc has it
    peak = hwm if hwm > 0 else usage.ru_maxrss / 1024.0
    return Measured(dt, usage.ru_utime + usage.ru_stime, peak, None if timed_out else proc.returncode, timed_out)


def _tree_rss_mib(pid: int) -> float:
    """The resident memory of a process and all its descendants now, in MiB (0 if it is gone)."""
    import psutil

    try:
        root = psutil.Process(pid)
        procs = [root, *root.children(recursive=True)]
    except psutil.Error:
        return 0.0
    total = 0
    for p in procs:
        try:
            total += p.memory_info().rss
        except psutil.Error:
            continue
    return total / 2**20


def _vm_hwm_mib(pid: int) -> float:
    """The peak resident set (VmHWM) of a running process in MiB, 0 where /proc does not say."""
    try:
        with open(f"/proc/{pid}/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("VmHWM:"):
                    return float(line.split()[1]) / 1024.0
    except (OSError, ValueError, IndexError):
        return 0.0
    return 0.0


def eigh_seconds(L: np.ndarray, repeat: int = 1) -> float:
    """Best wall time of one ``numpy.linalg.eigh`` of ``L`` in this process (the yardstick)."""
    return best_time(lambda: np.linalg.eigh(L), repeat=repeat, budget=600.0)


def write_spec(spec: object, folder: Path, name: str) -> Path:
    """Write ``spec`` as TOML to ``folder/name.toml`` (for the command-line rows)."""
    from glocal_verify.spec.writer import dump_spec

    path = folder / f"{name}.toml"
    path.write_text(dump_spec(spec))  # type: ignore[arg-type]
    return path


def cli(*args: str) -> list[str]:
    """The command line of ``glocal-verify ARGS`` with this interpreter."""
    return [sys.executable, "-m", "glocal_verify.cli", *args]


def self_peak_mib() -> float:
    """Peak resident memory of this process so far (MiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
