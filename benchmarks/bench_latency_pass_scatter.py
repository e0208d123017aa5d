"""Method A sigma under an attitude error shared by each pass: Monte Carlo, before and after.

Simulates rotating-table experiments (tau = 4.21 ms, 2 mm range noise, the simulator's
clutter, levelling and optical-centre errors) whose attitude records carry, besides
their white noise, an error constant over each pass and drawn anew for the next
(``RotatingTableConfig.pass_attitude_error_deg``, per NED axis: an INS's slowly varying
tilt and heading error). For each condition it prints, over the runs:

- the spread of the latency errors and the RMS reported sigma, the ratio spread/sigma
  (1 is honest) and the share of runs whose 95 % interval holds the truth, for the
  shipped estimator (the passes' shared scatter measured from their own centres and
  added to each pool: `kinsync.latency.pass_scatter`) and, as the baseline measured on
  the same runs, the sigma from the points' noise alone (the estimator before it);
- the share of runs whose Q test flags the passes' scatter (p < 0.01), and the mean
  between-pass standard deviation it measured against the truth (range x error).

Run: ``.venv/bin/python benchmarks/bench_latency_pass_scatter.py [--runs 100]
[--workers N] [--quick]``.
"""

from __future__ import annotations

import argparse
import math
import os
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, replace

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402  (after the thread settings)
from scipy import stats  # noqa: E402

from kinsync.errors import InputError  # noqa: E402
from kinsync.latency.model_check import check_rotation_model  # noqa: E402
from kinsync.latency.sphere import (  # noqa: E402
    RATES_DISAGREE_P,
    RateLatency,
    estimate_latency_sphere,
    latency_from_pool_pair,
)
from kinsync.sim.rotating_table import simulate_rotating_table  # noqa: E402
from kinsync.sim.table_config import RotatingTableConfig  # noqa: E402

TAU_S = 0.00421


@dataclass(frozen=True)
class Condition:
    """One experiment design and its per-pass attitude error."""

    passes: int
    rates_deg_s: tuple[float, ...]
    error_deg: float

    @property
    def label(self) -> str:
        rates = ",".join(f"{r:g}" for r in self.rates_deg_s)
        return f"{self.passes} passes x {rates} deg/s, {self.error_deg:g} deg/pass"


def _points_only_sigma(per_rate: tuple[RateLatency, ...]) -> tuple[float, float, bool]:
    """Latency and sigma with the passes' shared scatter left out (the estimator before),
    and whether its rotation-model test would have refused the input."""
    zero = np.zeros((3, 3))
    rates = [
        latency_from_pool_pair(
            replace(r.plus, between_pass_cov_m2=zero), replace(r.minus, between_pass_cov_m2=zero)
        )
        for r in per_rate
    ]
    try:
        check_rotation_model([(r.rate_deg_s, r.chi2) for r in rates])
        refused = False
    except InputError:
        refused = True
    tau_r = np.array([r.latency_s for r in rates])
    w = 1.0 / np.array([r.latency_std_s**2 for r in rates])
    tau = float(np.sum(w * tau_r) / np.sum(w))
    sigma = math.sqrt(1.0 / float(np.sum(w)))
    dof = len(rates) - 1
    if dof > 0:
        chi2 = float(np.sum(w * (tau_r - tau) ** 2))
        if stats.chi2.sf(chi2, dof) < RATES_DISAGREE_P:
            sigma *= math.sqrt(chi2 / dof)
    return tau, sigma, refused


def one_run(args: tuple[Condition, int]) -> tuple[float, float, float, float, bool, float, bool]:
    """Errors and sigmas of one simulated experiment; NaN errors when it was refused."""
    cond, seed = args
    cfg = RotatingTableConfig(
        latency_s=TAU_S,
        seed=seed,
        passes=cond.passes,
        rates_deg_s=cond.rates_deg_s,
        pass_attitude_error_deg=cond.error_deg,
    )
    try:
        res = estimate_latency_sphere(simulate_rotating_table(cfg).passes, radius_m=0.1)
    except InputError:  # correct input refused: counted, not averaged
        return (math.nan,) * 4 + (False, math.nan, False)
    tau_old, sigma_old, old_refused = _points_only_sigma(res.per_rate)
    scatter = res.pass_scatter
    assert scatter is not None
    return (
        res.latency_s - TAU_S,
        res.latency_std_s,
        tau_old - TAU_S,
        sigma_old,
        scatter.significant,
        scatter.std_m,
        old_refused,
    )


def _row(errors: np.ndarray, sigmas: np.ndarray) -> str:
    spread = float(np.std(errors, ddof=1))
    rms_sigma = float(np.sqrt(np.mean(sigmas**2)))
    cover = float(np.mean(np.abs(errors) <= 1.96 * sigmas))
    return (
        f"spread {spread * 1e3:.4f} ms, sigma {rms_sigma * 1e3:.4f} ms, "
        f"spread/sigma {spread / rms_sigma:.2f}, 95 % cover {cover:.0%}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--runs", type=int, default=100)
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--quick", action="store_true", help="one condition, 20 runs")
    parser.add_argument("--passes", type=int, help="only the conditions with these passes")
    args = parser.parse_args()
    three = (2.0, 6.0, 18.0)
    conditions = [
        Condition(5, three, 0.0),
        Condition(5, three, 0.001),
        Condition(5, three, 0.003),
        Condition(5, three, 0.005),
        Condition(2, three, 0.0),
        Condition(2, three, 0.003),
        Condition(15, three, 0.003),
    ]
    if args.passes is not None:
        conditions = [c for c in conditions if c.passes == args.passes]
    runs = args.runs
    if args.quick:
        conditions, runs = [Condition(5, three, 0.003)], 20
    range_m = RotatingTableConfig().sphere_range_m
    print(f"Method A, tau {TAU_S * 1e3:g} ms, {runs} runs per condition, {args.workers} workers")
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        for cond in conditions:
            t1 = time.perf_counter()
            out = np.array(
                list(pool.map(one_run, [(cond, 1000 + s) for s in range(runs)])), dtype=float
            )
            refused = np.isnan(out[:, 0])
            err, sig, err_old, sig_old, flagged, std_m, old_refused = out[~refused].T
            print(f"\n{cond.label}  ({time.perf_counter() - t1:.1f} s)")
            print(
                f"  correct input refused by the rotation-model test: {np.count_nonzero(refused)} "
                f"of {runs} (points only, old: {int(np.sum(old_refused))} more of the others)"
            )
            bias_ms = np.mean(err) * 1e3
            print(f"  with pass scatter : {_row(err, sig)}, mean error {bias_ms:+.4f} ms")
            print(f"  points only (old) : {_row(err_old, sig_old)}")
            ratio = float(np.sqrt(np.mean(sig**2) / np.mean(sig_old**2)))
            truth_mm = range_m * math.radians(cond.error_deg) * 1e3
            print(
                f"  ratio of sigmas   : {ratio:.2f}; scatter flagged in {np.mean(flagged):.0%} "
                f"of runs; between-pass std {np.mean(std_m) * 1e3:.4f} mm (truth {truth_mm:.4f} mm)"
            )
    print(f"\ntotal {time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()
