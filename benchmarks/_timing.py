"""Timing shared by the benchmarks (run as scripts: this folder is on their path)."""

from __future__ import annotations

import time
from collections.abc import Callable

__all__ = ["best_of"]


def best_of(fn: Callable[[], object], repeat: int = 3) -> float:
    """Least wall time (s) of ``repeat`` runs of ``fn``: the run least disturbed."""
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)
