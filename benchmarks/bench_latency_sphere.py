"""Method A Monte Carlo: bias, empirical sigma, reported sigma and the Cramér-Rao plan.

Simulates the default rotating-table set-up (6 rates x 2 directions x 15 passes, 2 mm
range noise, tau = 4.21 ms) with many seeds, estimates the latency from each, and
prints bias, empirical standard deviation, mean reported standard deviation and the
planner's prediction, overall and per rate. Targets (issue "Method A"): empirical sigma
within 15 % of the prediction, |bias| below sigma/5.

Run: ``python benchmarks/bench_latency_sphere.py [--runs 100] [--workers N]``.
"""

from __future__ import annotations

import argparse
import math
import os
import time
from concurrent.futures import ProcessPoolExecutor

# One BLAS thread per worker process: with N processes each spawning N threads the
# machine thrashes (seen: 26x slower per run on 16 cores).
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402  (after the thread settings)

from kinsync.latency.planning import TableDesign, plan_latency_experiment  # noqa: E402
from kinsync.latency.sphere import estimate_latency_sphere  # noqa: E402
from kinsync.sim.rotating_table import simulate_rotating_table  # noqa: E402
from kinsync.sim.table_config import RotatingTableConfig  # noqa: E402

TAU_S = 0.00421


def one_run(seed: int, passes: int) -> tuple[float, float, list[float], list[float], float, float]:
    t0 = time.perf_counter()
    sim = simulate_rotating_table(RotatingTableConfig(latency_s=TAU_S, seed=seed, passes=passes))
    t1 = time.perf_counter()
    res = estimate_latency_sphere(sim.passes, radius_m=0.1)
    t2 = time.perf_counter()
    return (
        res.latency_s,
        res.latency_std_s,
        [r.latency_s for r in res.per_rate],
        [r.latency_std_s for r in res.per_rate],
        t1 - t0,
        t2 - t1,
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--runs", type=int, default=100)
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--passes", type=int, default=15)
    args = parser.parse_args()
    design = TableDesign(passes=args.passes)
    plan = plan_latency_experiment(design)
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        runs = list(pool.map(one_run, range(1000, 1000 + args.runs), [args.passes] * args.runs))
    wall = time.perf_counter() - t0
    tau = np.array([r[0] for r in runs])
    sig = np.array([r[1] for r in runs])
    tau_r = np.array([r[2] for r in runs])
    sig_r = np.array([r[3] for r in runs])
    sim_s = np.array([r[4] for r in runs])
    est_s = np.array([r[5] for r in runs])
    emp = float(np.std(tau, ddof=1))
    bias = float(np.mean(tau) - TAU_S)
    print(f"Method A Monte Carlo: {args.runs} runs, {args.passes} passes per rate and direction")
    print(
        f"  wall {wall:.1f} s on {args.workers} workers; per run: simulate "
        f"{np.median(sim_s):.2f} s, estimate {np.median(est_s):.2f} s (median)"
    )
    print(f"  truth                 {TAU_S * 1e3:.4f} ms")
    print(f"  mean estimate         {np.mean(tau) * 1e3:.4f} ms")
    se = emp / math.sqrt(args.runs)
    print(f"  bias                  {bias * 1e6:+.2f} us  (+- {se * 1e6:.2f} us SE)")
    print(f"  empirical sigma       {emp * 1e6:.2f} us")
    print(
        f"  mean reported sigma   {np.mean(sig) * 1e6:.2f} us  (ratio empirical/reported "
        f"{emp / np.mean(sig):.3f})"
    )
    print(
        f"  planner (CRB) sigma   {plan.latency_std_s * 1e6:.2f} us  (ratio empirical/planner "
        f"{emp / plan.latency_std_s:.3f})"
    )
    cover = float(np.mean(np.abs(tau - TAU_S) < 3 * sig))
    print(f"  |error| < 3 sigma in  {cover * 100:.0f} % of runs")
    ok_sigma = abs(emp / plan.latency_std_s - 1) <= 0.15
    ok_bias = abs(bias) < emp / 5
    verdict = {True: "met", False: "NOT met"}
    print(f"  target empirical sigma within 15 % of the prediction: {verdict[ok_sigma]}")
    print(f"  target |bias| < sigma/5 ({emp / 5 * 1e6:.2f} us): {verdict[ok_bias]}")
    head = ("rate", "bias (us)", "emp sigma", "reported", "planner", "emp/plan")
    print("\n" + "".join(f"{h:>11}" for h in head))
    for i, r in enumerate(plan.per_rate):
        e = float(np.std(tau_r[:, i], ddof=1))
        print(
            f"{r.rate_deg_s:>11g}{(np.mean(tau_r[:, i]) - TAU_S) * 1e6:>11.2f}{e * 1e6:>11.2f}"
            f"{np.mean(sig_r[:, i]) * 1e6:>11.2f}{r.latency_std_s * 1e6:>11.2f}"
            f"{e / r.latency_std_s:>11.3f}"
        )


if __name__ == "__main__":
    main()
