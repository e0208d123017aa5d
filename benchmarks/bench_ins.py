"""INS/GNSS filter throughput on the NaveGo synthetic set (87 450 IMU epochs, 5 Hz GNSS).

Prints, after JIT warm-up, on one core:

- forward filter IMU epochs per second (covariance propagated every epoch, position and
  velocity updates), and its ratio to 42 000 epochs/s, the C++ reference's rate on
  this machine class (target >= 1, aim 2);
- forward filter + RTS smoother, epochs per second;
- a straightforward numpy (non-numba) forward filter (`kinsync.ins._reference`) on the
  first ``NUMPY_EPOCHS`` epochs, and the compiled loop's speed-up over it;
- the RMS errors of the three solutions against the truth, and the smoother's memory
  (checkpoints) against storing three 15×15 matrices per epoch.

Run: ``.venv/bin/python benchmarks/bench_ins.py [--data DIR]``.
"""

from __future__ import annotations

import os

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import argparse
import dataclasses
import json
import math
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from kinsync.ins._reference import forward_numpy
from kinsync.ins.config import InsConfig
from kinsync.ins.earth import radii_m
from kinsync.ins.filter import forward_pass, gnss_epochs, new_gnss_log, run_ins
from kinsync.ins.measurements import GnssData, ImuData
from kinsync.ins.solution import InitialState, NavSolution
from kinsync.io.tables import read_numeric_csv

REFERENCE_EPOCHS_S = 42_000.0
NUMPY_EPOCHS = 5_000
DEFAULT_DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "navego-synthetic"


def best_of(fn: Callable[[], object], repeat: int = 3) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def load(data: Path) -> tuple[ImuData, GnssData, dict[str, np.ndarray], InsConfig, InitialState]:
    imu_c = read_numeric_csv(data / "imu.csv", ["t_s"]).columns
    gn = read_numeric_csv(data / "gnss.csv", ["t_s"]).columns
    tr = read_numeric_csv(data / "truth.csv", ["t_s"]).columns
    spec = json.loads((data / "imu_gnss_spec.json").read_text())
    imu = ImuData(
        imu_c["t_s"],
        np.column_stack([imu_c[f"gyro_{a}_rad_s"] for a in "xyz"]),
        np.column_stack([imu_c[f"acc_{a}_m_s2"] for a in "xyz"]),
    )
    m = gn["t_s"].size
    gnss = GnssData(
        gn["t_s"], gn["lat_deg"], gn["lon_deg"], gn["h_m"], np.full((m, 3), np.nan),
        np.column_stack([gn["vn_m_s"], gn["ve_m_s"], gn["vd_m_s"]]),
    )  # fmt: skip
    # NaveGo convention: turn-on biases known, residual σ = 10 x instability.
    config = InsConfig(
        gyro_arw_rad_s_rthz=spec["arw"][0],
        acc_vrw_m_s2_rthz=spec["vrw"][0],
        gyro_bias_sigma_rad_s=10 * spec["gb_dyn"][0],
        acc_bias_sigma_m_s2=10 * spec["ab_dyn"][0],
        gyro_bias_instability_rad_s=spec["gb_dyn"][0],
        acc_bias_instability_m_s2=spec["ab_dyn"][0],
        gyro_bias_corr_time_s=spec["gb_corr"][0],
        acc_bias_corr_time_s=spec["ab_corr"][0],
        gnss_std_pos_ned_m=tuple(spec["gnss"]["stdm"]),
        gnss_std_vel_ned_m_s=tuple(spec["gnss"]["stdv"]),
        init_std_att_rad=tuple(spec["ini_align_err"]),
    )
    init = InitialState(
        t_s=float(tr["t_s"][0]),
        lat_deg=float(tr["lat_deg"][0]),
        lon_deg=float(tr["lon_deg"][0]),
        h_m=float(tr["h_m"][0]),
        vel_ned_m_s=(float(tr["vn_m_s"][0]), float(tr["ve_m_s"][0]), float(tr["vd_m_s"][0])),
        rpy_rad=(
            math.radians(tr["roll_deg"][0]),
            math.radians(tr["pitch_deg"][0]),
            math.radians(tr["yaw_deg"][0]),
        ),
        gyro_bias_rad_s=tuple(spec["gb_sta"]),
        acc_bias_m_s2=tuple(spec["ab_sta"]),
    )
    return imu, gnss, tr, config, init


def rms(sol: NavSolution, tr: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    lat = np.radians(tr["lat_deg"])
    r_m, r_n = radii_m(lat)
    pos = np.column_stack(
        [
            np.radians(sol.lat_deg - tr["lat_deg"]) * (r_m + tr["h_m"]),
            np.radians(sol.lon_deg - tr["lon_deg"]) * (r_n + tr["h_m"]) * np.cos(lat),
            sol.h_m - tr["h_m"],
        ]
    )
    rpy = np.degrees(sol.rpy_rad) - np.column_stack(
        [tr["roll_deg"], tr["pitch_deg"], tr["yaw_deg"]]
    )
    rpy = (rpy + 180.0) % 360.0 - 180.0
    return np.sqrt(np.mean(pos**2, axis=0)), np.sqrt(np.mean(rpy**2, axis=0))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA)
    args = parser.parse_args()
    if not (args.data / "imu.csv").is_file():
        sys.exit(f"NaveGo data not found in {args.data}")
    imu, gnss, tr, config, init = load(args.data)
    n = len(imu)
    run_ins(imu, gnss, config, init, smooth=True)  # JIT warm-up (compiles or loads cache)

    t_fwd = best_of(lambda: run_ins(imu, gnss, config, init))
    t_smo = best_of(lambda: run_ins(imu, gnss, config, init, smooth=True))
    t_np = best_of(lambda: forward_numpy(imu, gnss, config, init, NUMPY_EPOCHS), repeat=1)
    rate_fwd = n / t_fwd
    rate_np = NUMPY_EPOCHS / t_np
    print(f"NaveGo synthetic set: {n:,} IMU epochs at 200 Hz, {len(gnss):,} GNSS epochs, one core")
    print(
        f"  forward filter (P every epoch, pos+vel)   {rate_fwd:12,.0f} epochs/s   {t_fwd:6.3f} s"
    )
    print(f"    ratio to 42 000 epochs/s (C++ reference) {rate_fwd / REFERENCE_EPOCHS_S:10.2f}")
    print(
        f"  forward + RTS smoother                     {n / t_smo:12,.0f} epochs/s   {t_smo:6.3f} s"
    )
    print(f"  numpy forward filter (first {NUMPY_EPOCHS:,} epochs)  {rate_np:9,.0f} epochs/s")
    print(f"    compiled speed-up over numpy             {rate_fwd / rate_np:10.0f}x")

    g_epoch = gnss_epochs(imu.t_s, 0, gnss.t_s)
    run = forward_pass(
        imu, gnss, config, init, use_velocity=True, store=True, progress=None,
        gnss_imu_epoch=g_epoch, log=new_gnss_log(len(gnss)),
    )  # fmt: skip
    ck = run.checkpoints
    assert ck is not None
    ck_bytes = sum(a.nbytes for a in dataclasses.astuple(ck))
    print(
        f"  smoother memory: {ck.epoch.size:,} checkpoints, {ck_bytes / 1e6:.1f} MB "
        f"(per-epoch P+, P-, Phi would be {3 * n * 15 * 15 * 8 / 1e6:.0f} MB)"
    )

    print("\nRMS errors against truth.csv (turn-on biases known, NaveGo convention):")
    print("  solution                     pos N/E/D (m)           roll/pitch/yaw (deg)")
    for label, vel in (("position only", False), ("position + velocity", True)):
        res = run_ins(imu, gnss, config, init, use_velocity=vel, smooth=True)
        assert res.smoothed is not None
        for kind, sol in (("forward", res.forward), ("smoothed", res.smoothed)):
            p, a = rms(sol, tr)
            print(
                f"  {label + ', ' + kind:28s} {p[0]:6.3f} {p[1]:6.3f} {p[2]:6.3f}"
                f"    {a[0]:6.3f} {a[1]:6.3f} {a[2]:6.3f}"
            )


if __name__ == "__main__":
    main()
