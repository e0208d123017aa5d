"""Mount self-calibration time as lines grow: the compiled per-line plane fit against numpy.

`calibrate mount` weights each plane's returns about their own line's robust fit of the
plane (`kinsync.calibration.line_detrend`), at every state of the solution and of each
of the jackknife's deleted-line solutions. The jackknife is L more solutions over L
lines, so the whole run grows about as L^2, and this fit was the largest part of it.

For simulated patch tests of 8, 16 and 32 lines (the vehicle scenario, 2, 4 and 8
passes each way per speed, beams thinned to ``--density``), `calibrate_mount` runs
twice in one process, with the compiled fit and with the plain numpy loop it replaced
(`detrend_lines_numpy`, patched in). Printed: wall time of each (the jackknife's part
beside it, from the progress stages), their ratio, and the largest difference between
the two runs' estimates in units of the reported sigma (0 up to rounding: the same
arithmetic).

The jackknife's threads (``--workers``, default every CPU this process may use) run
the compiled fit without the interpreter lock; the numpy loop holds it between calls.

Run: ``make bench`` (8 and 16 lines) or ``.venv/bin/python
benchmarks/bench_calibration_lines.py [--passes 2,4,8] [--density 0.1]``.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np

from kinsync._cpus import usable_cpus
from kinsync.calibration import adjustment
from kinsync.calibration.estimator import CalibrationOptions, calibrate_mount
from kinsync.calibration.line_detrend import detrend_lines, detrend_lines_numpy
from kinsync.calibration.result import CalibrationResult
from kinsync.sim.patch_config import PatchTestConfig
from kinsync.sim.patch_test import PatchTestSimulation, simulate_patch_test


@contextmanager
def _numpy_fit() -> Iterator[None]:
    """The adjustment with the plain numpy per-line fit for the time of the block."""
    names = vars(adjustment)
    names["detrend_lines"] = detrend_lines_numpy
    try:
        yield
    finally:
        names["detrend_lines"] = detrend_lines


def _timed(sim: PatchTestSimulation) -> tuple[CalibrationResult, float, float, float]:
    """One calibration: the result, its wall time, its jackknife's and its CPU time (s)."""
    marks: dict[str, float] = {}

    def progress(_fraction: float, message: str) -> None:
        if message.startswith("jackknife:") and "jackknife" not in marks:
            marks["jackknife"] = time.perf_counter()
        elif "held parameters" in message or message.startswith("calibrating"):
            marks.setdefault("after", time.perf_counter())

    t0, cpu0 = time.perf_counter(), time.process_time()
    result = calibrate_mount(sim.lines, sim.mount_nominal, CalibrationOptions(), progress=progress)
    end, cpu = time.perf_counter(), time.process_time() - cpu0
    jk = marks.get("after", end) - marks.get("jackknife", end)
    return result, end - t0, jk, cpu


def main() -> None:
    """Simulate each design, warm the JIT up, time both fits, print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--passes", default="2,4", help="Passes each way per speed (comma list).")
    parser.add_argument("--density", type=float, default=0.1, help="Fraction of beams kept.")
    args = parser.parse_args()
    passes = [int(p) for p in args.passes.split(",")]

    warm = simulate_patch_test(PatchTestConfig(scenario="vehicle", density=0.02, seed=5))
    calibrate_mount(warm.lines, warm.mount_nominal, CalibrationOptions())

    print(f"wall s (the jackknife's part in brackets), CPU s of all threads; "
          f"{usable_cpus()} CPUs")  # fmt: skip
    print(f"{'lines':>5s} {'returns':>9s} {'compiled':>16s} {'CPU':>6s} "
          f"{'numpy':>16s} {'CPU':>6s} {'wall ratio':>10s} {'diff/sigma':>10s}")  # fmt: skip
    for p in passes:
        cfg = PatchTestConfig(
            scenario="vehicle", density=args.density, seed=11, passes_per_direction=p
        )
        sim = simulate_patch_test(cfg)
        n_returns = sum(len(line) for line in sim.lines)
        ours, t_ours, jk_ours, cpu_ours = _timed(sim)
        with _numpy_fit():
            ref, t_ref, jk_ref, cpu_ref = _timed(sim)
        diff = max(
            (abs(a.value - b.value) / a.std if a.std > 0 else abs(a.value - b.value))
            for a, b in zip(ours.parameters, ref.parameters, strict=True)
            if np.isfinite(a.value) and np.isfinite(b.value)
        )
        print(f"{len(sim.lines):5d} {n_returns:9d} {t_ours:7.1f} ({jk_ours:6.1f}) {cpu_ours:6.1f} "
              f"{t_ref:7.1f} ({jk_ref:6.1f}) {cpu_ref:6.1f} {t_ref / t_ours:10.2f} "
              f"{diff:10.2g}")  # fmt: skip


if __name__ == "__main__":
    main()
