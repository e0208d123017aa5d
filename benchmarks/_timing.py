"""Timing shared by the benchmarks (run as scripts: this folder is on their path)."""

from __future__ import annotations

import re
import sys
import time
from collections.abc import Callable
from pathlib import Path

__all__ = ["best_of", "georef_command", "max_rss_mib"]


def best_of(fn: Callable[[], object], repeat: int = 3) -> float:
    """Least wall time (s) of ``repeat`` runs of ``fn``: the run least disturbed."""
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def georef_command(folder: Path, points: Path, out: Path, *extra: str) -> list[str]:
    """``kinsync georef`` of ``points`` to ``out`` under ``/usr/bin/time -v`` (peak memory).

    The trajectory and mount are ``folder``'s ``traj.csv`` and ``mount.toml``.
    """
    kinsync = str(Path(sys.executable).with_name("kinsync"))
    return [
        *("/usr/bin/time", "-v", kinsync, "georef", "--points", str(points)),
        *("--trajectory", str(folder / "traj.csv"), "--mount", str(folder / "mount.toml")),
        *("--out", str(out), *extra),
    ]


def max_rss_mib(time_stderr: str) -> float:
    """The maximum resident set size (MiB) GNU ``time -v`` reported, -1 when none."""
    match = re.search(r"Maximum resident set size \(kbytes\): (\d+)", time_stderr)
    return int(match.group(1)) / 1024 if match else -1.0
