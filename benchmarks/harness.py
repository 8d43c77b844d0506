"""Timing helpers and the row type of the benchmark report."""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable

__all__ = ["Row", "best_time"]


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
