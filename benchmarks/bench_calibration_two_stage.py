"""Two calibrations in a row: does the second one's sigma hold the first one's errors?

A crew calibrates everything on a patch test (stage 1), writes the calibrated mount with
its ``[uncertainty]``, and later calibrates only some values on another survey while the
others are held at stage 1's (stage 2: ``--estimate latency``, the boresight and lever
arm held). Stage 1's estimates are correlated (a latency and a lever arm x told apart by
the same speed changes; a pitch and a yaw by the same walls), so stage 2's sigma must add
``D Sigma D'`` with stage 1's full covariance, which the mount file now carries in
``[uncertainty.correlation]``.

Each run simulates stage 1 (`kinsync.sim.patch_test`, seed ``s``, the standard injected
mount errors), calibrates everything, then simulates stage 2 over the same design with
new navigation errors and range noise (seed ``s + 100000``), the same true mount and
stage 1's calibrated mount as the nominal one, and calibrates the latency alone. The
columns, over the runs, for each parameter stage 2 estimates:

* ``sd``: empirical spread of stage 2's errors;
* ``RMS sigma``: stage 2's reported sigma (jackknife plus the held part with stage 1's
  correlations), and ``ratio`` = sd / RMS sigma (1 when honest; [0.8, 1.25] is the
  goal, its own sampling error about 0.13 for 30 runs), ``out 95%``: errors outside
  the Student t interval;
* ``independent``: the same with the held part taken as independent errors (stage 1's
  standard deviations alone, what a mount file without correlations gave): the
  baseline.

Run: ``make bench`` or ``.venv/bin/python benchmarks/bench_calibration_two_stage.py
[--runs N] [--density D] [--scenario vessel|vehicle] [--workers W]``.
"""

from __future__ import annotations

import argparse
import math
import os
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np
from scipy.stats import t as student_t

from kinsync._typing import FloatArray
from kinsync.calibration.estimator import CalibrationOptions, calibrate_mount
from kinsync.calibration.parameters import PARAMETER_NAMES, REPORT_SCALE, mount_values
from kinsync.sim.patch_config import PatchTestConfig, Scenario
from kinsync.sim.patch_test import simulate_patch_test

STAGE_TWO = ("latency",)

Run = tuple[list[float], list[float], list[float], float, bool]


def _one_run(args: tuple[Scenario, float, int]) -> Run:
    """Stage 2's errors, reported sigma and independent-held sigma (report units); the
    t factor; whether stage 1 wrote a correlation table."""
    scenario, density, seed = args
    first = simulate_patch_test(PatchTestConfig(scenario=scenario, density=density, seed=seed))
    stage1 = calibrate_mount(
        first.lines,
        first.mount_nominal,
        CalibrationOptions(estimate=("boresight", "lever", "latency")),
    )
    calibrated = stage1.mount
    truth = mount_values(first.mount_true)
    again = PatchTestConfig(scenario=scenario, density=density, seed=seed + 100_000)
    second = simulate_patch_test(again.with_nominal(calibrated))
    stage2 = calibrate_mount(second.lines, calibrated, CalibrationOptions(estimate=STAGE_TWO))
    assert stage2.held is not None
    held_alone = stage2.held.std_if_independent
    err, std, independent = [], [], []
    for i, p in enumerate(stage2.parameters):
        err.append(p.value - float(truth[i] * REPORT_SCALE[i]))
        std.append(p.std)
        if i in stage2.held.estimated:
            part = float(held_alone[stage2.held.estimated.index(i)] * REPORT_SCALE[i])
            independent.append(math.hypot(p.data_std, part))
        else:
            independent.append(math.nan)
    t95 = float(student_t.ppf(0.975, len(stage2.lines) - 1))
    has_corr = calibrated.uncertainty is not None and calibrated.uncertainty.correlation is not None
    return err, std, independent, t95, has_corr


def _rms(values: FloatArray) -> float:
    return float(np.sqrt(np.mean(values**2)))


def main() -> None:
    """Run the Monte Carlo and print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=30)
    parser.add_argument("--density", type=float, default=0.1)
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--scenario", choices=("vehicle", "vessel"), default="vessel")
    parser.add_argument("--seed0", type=int, default=2000)
    args = parser.parse_args()
    t0 = time.perf_counter()
    jobs = [(args.scenario, args.density, args.seed0 + k) for k in range(args.runs)]
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        results = list(pool.map(_one_run, jobs))
    err = np.array([r[0] for r in results])
    std = np.array([r[1] for r in results])
    ind = np.array([r[2] for r in results])
    t95 = np.array([r[3] for r in results])
    with_corr = sum(r[4] for r in results)
    print(
        f"{args.scenario}: {args.runs} runs of two calibrations in "
        f"{time.perf_counter() - t0:.0f} s; stage 1 wrote a correlation table in {with_corr}"
    )
    print(
        f"{'parameter':20s} {'sd':>10s} {'RMS sigma':>10s} {'ratio':>6s} {'out 95%':>8s} "
        f"{'independent':>11s} {'ratio':>6s} {'out 95%':>8s}"
    )
    for i, name in enumerate(PARAMETER_NAMES):
        if not np.all(np.isfinite(ind[:, i])):
            continue
        e = err[:, i]
        sd = float(np.std(e, ddof=1))
        rs, ri = _rms(std[:, i]), _rms(ind[:, i])
        out_c = float(np.mean(np.abs(e) > t95 * std[:, i]))
        out_i = float(np.mean(np.abs(e) > t95 * ind[:, i]))
        print(
            f"{name:20s} {sd:10.3g} {rs:10.3g} {sd / rs:6.2f} {out_c:8.2f} "
            f"{ri:11.3g} {sd / ri:6.2f} {out_i:8.2f}"
        )


if __name__ == "__main__":
    main()
