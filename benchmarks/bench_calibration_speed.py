"""Mount self-calibration speed: a 10-million-point, 8-line patch test on one core.

The simulated vehicle patch test (`kinsync.sim.patch_test`, every beam at 0.3 deg
steps: about 10 million returns in 8 lines) is calibrated with
`kinsync.calibration.estimator.calibrate_mount` asking for everything (boresight,
lever arm, latency): finding the planar patches in all returns, the observability
analysis, the solution and the delete-one-line jackknife (8 more solutions). The
issue's target: under 60 s on one core after the JIT warm-up (numba compiled on a
small run first; one numba thread, one BLAS thread, the process pinned to one CPU so
that the jackknife's threads share it).

Beside it, the same least-squares problem (the same patches and thinned returns, the
same georeferencing model, the planes as free parameters, no robust weights) solved
by a plain `scipy.optimize.least_squares` (trust-region reflective, finite-difference
Jacobian over every parameter, as a user would write it), against kinsync's
adjustment alone (Gauss-Newton with the planes eliminated by their Schur complement,
analytic mount Jacobian, robust weights).

Run: ``make bench`` (or ``.venv/bin/python benchmarks/bench_calibration_speed.py
[--step-deg 0.3]``; a larger step makes a smaller problem).
"""

from __future__ import annotations

import os

for _var in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"
if hasattr(os, "sched_setaffinity"):  # one core for real: the jackknife's threads share it
    os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})

import argparse  # noqa: E402
import resource  # noqa: E402
import time  # noqa: E402
from collections.abc import Sequence  # noqa: E402

import numpy as np  # noqa: E402
from scipy.optimize import least_squares  # noqa: E402

from kinsync._typing import FloatArray  # noqa: E402
from kinsync.calibration.adjustment import Observation, adjust  # noqa: E402
from kinsync.calibration.estimator import (  # noqa: E402
    CalibrationOptions,
    calibrate_mount,
    find_features,
)
from kinsync.calibration.features import Feature  # noqa: E402
from kinsync.calibration.model import LineModel, LocalFrame, local_frame_for  # noqa: E402
from kinsync.calibration.parameters import (  # noqa: E402
    PARAMETER_NAMES,
    REPORT_SCALE,
    estimated_indices,
    mount_values,
)
from kinsync.sim.patch_config import PatchTestConfig  # noqa: E402
from kinsync.sim.patch_test import simulate_patch_test  # noqa: E402

_ALL = ("boresight", "lever", "latency")


def _scipy_solve(
    models: Sequence[LineModel],
    observations: Sequence[Observation],
    features: Sequence[Feature],
    start: FloatArray,
    estimated: tuple[int, ...],
    frame: LocalFrame,
) -> tuple[FloatArray, int]:
    """The same problem by plain least_squares; the mount values and the evaluations."""
    k = len(estimated)
    sizes = [f.n_params for f in features]
    offsets = np.cumsum([k, *sizes])

    def residuals(p: FloatArray) -> FloatArray:
        values = start.copy()
        values[list(estimated)] = p[:k]
        moved = [f.updated(p[offsets[i] : offsets[i] + sizes[i]]) for i, f in enumerate(features)]
        parts = []
        for o in observations:
            x = models[o.line].points(o.index, values, frame)
            parts.append(moved[o.feature].residuals(x))
        out = np.concatenate(parts)
        return np.where(np.isfinite(out), out, 1.0)  # outside the trajectory: 1 m

    p0 = np.zeros(offsets[-1])
    p0[:k] = start[list(estimated)]
    # Unbounded, as a user would write it: bounds on the latency (to keep it on the
    # trajectory) make trf crawl (30 evaluations moved the cost a tenth of the way).
    sol = least_squares(residuals, p0, method="trf", x_scale="jac")
    values = start.copy()
    values[list(estimated)] = sol.x[:k]
    return values, int(sol.nfev + (sol.njev or 0) * p0.size)


def main() -> None:
    """Simulate, warm the JIT up, time kinsync and scipy, print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--step-deg", type=float, default=0.3, help="Beam step (deg).")
    args = parser.parse_args()

    t0 = time.perf_counter()
    small = simulate_patch_test(PatchTestConfig(scenario="vehicle", density=0.02, seed=5))
    calibrate_mount(small.lines, small.mount_nominal, CalibrationOptions(estimate=_ALL))
    warm = time.perf_counter() - t0

    t0 = time.perf_counter()
    cfg = PatchTestConfig(scenario="vehicle", angular_step_deg=args.step_deg, seed=6)
    sim = simulate_patch_test(cfg)
    n_points = sum(len(ln) for ln in sim.lines)
    t_sim = time.perf_counter() - t0
    print(f"patch test: {len(sim.lines)} lines, {n_points / 1e6:.2f} million returns "
          f"(simulated in {t_sim:.0f} s; JIT warm-up {warm:.0f} s)")  # fmt: skip

    t0 = time.perf_counter()
    res = calibrate_mount(sim.lines, sim.mount_nominal, CalibrationOptions(estimate=_ALL))
    t_cal = time.perf_counter() - t0
    rss_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    truth = mount_values(sim.mount_true) * REPORT_SCALE
    print(f"\ncalibrate_mount (patches, observability, solution, jackknife over "
          f"{len(res.lines)} lines): {t_cal:.1f} s on one core, target < 60 s; "
          f"peak RSS {rss_mb:.0f} MiB; {len(res.features)} patches")  # fmt: skip
    print(f"{'parameter':20s} {'status':12s} {'error':>10s} {'sigma':>10s}")
    for i, p in enumerate(res.parameters):
        print(f"{p.name:20s} {p.status:12s} {p.value - truth[i]:10.3g} {p.std:10.3g}")

    # The solution alone, kinsync against scipy, on the same patches and returns.
    lines = list(sim.lines)
    models = [LineModel.prepare(line, {}) for line in lines]
    frame = local_frame_for(lines)
    start = mount_values(sim.mount_nominal)
    features, observations = find_features(models, start, frame, CalibrationOptions())
    estimated = tuple(i for i in estimated_indices(_ALL) if PARAMETER_NAMES[i] != "lever_z_m")
    n_used = sum(o.index.size for o in observations)
    t0 = time.perf_counter()
    ours = adjust(models, observations, features, start, estimated, frame)
    t_ours = time.perf_counter() - t0
    t0 = time.perf_counter()
    theirs, n_eval = _scipy_solve(models, observations, features, start, estimated, frame)
    t_scipy = time.perf_counter() - t0
    print(f"\none solution, {len(features)} planes, {n_used} thinned returns, "
          f"{len(estimated)} mount parameters (lever z held: unobservable here)")  # fmt: skip
    print(f"  kinsync adjust           {t_ours:7.2f} s  ({ours.iterations} iterations)")
    print(f"  scipy least_squares trf  {t_scipy:7.2f} s  ({n_eval} residual evaluations)")
    print(f"  ratio scipy / kinsync    {t_scipy / t_ours:7.1f}x")
    names = [PARAMETER_NAMES[i] for i in estimated]
    for who, values in (("kinsync", ours.values), ("scipy", theirs)):
        err = values[list(estimated)] * REPORT_SCALE[list(estimated)] - truth[list(estimated)]
        print(
            f"  {who} - truth: "
            + ", ".join(f"{n} {d:+.2g}" for n, d in zip(names, err, strict=True))
        )
    print("  (kinsync down-weights outliers by Tukey's biweight; scipy here is plain L2)")


if __name__ == "__main__":
    main()
