"""INS/GNSS on the NaveGo synthetic set (87 450 IMU epochs, 5 Hz GNSS): speed and accuracy.

Prints, after JIT warm-up, on one core:

- forward filter IMU epochs per second (21 error states, covariance propagated every
  epoch, position and velocity updates), and its ratio to 42 000 epochs/s, the C++
  reference's rate on this machine class; forward filter + RTS smoother;
- a straightforward numpy (non-numba) forward filter (`kinsync.ins._reference`) on the
  first ``NUMPY_EPOCHS`` epochs, and the compiled loop's speed-up over it;
- ``kinsync ins run`` end to end in a fresh process (warm JIT cache), forward and with
  ``--smooth``, against the targets of 5 s and 8 s, and its split measured in this
  process: start-up (a fresh process importing the CLI), reading and checking the
  inputs, the filter, the smoother, writing the solution CSV;
- the RMS errors of issue 17's conditions with the one shipped configuration
  (``configs/navego-adis16488.toml``): A (position updates, turn-on biases estimated
  from zero), B (position and velocity, estimated), C (position, biases known as a
  calibration in ``[init]``), forward and smoothed, beside the best peer's forward
  figures (pyins 1.0.1 for A and B, KF-GINS for C) rounded to their three decimals;
- the smoother's memory (checkpoints) against storing three 21×21 matrices per epoch.

Run: ``.venv/bin/python benchmarks/bench_ins.py [--data DIR]``.
"""

from __future__ import annotations

import os

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import argparse
import dataclasses
import json
import math
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from _timing import best_of
from kinsync.ins._reference import forward_numpy
from kinsync.ins.checks import check_inputs
from kinsync.ins.config import InsConfig
from kinsync.ins.earth import radii_m
from kinsync.ins.filter import forward_pass, new_gnss_log, run_ins
from kinsync.ins.gnss_observation import gnss_epochs
from kinsync.ins.measurements import GnssData, ImuData
from kinsync.ins.solution import InitialState, NavSolution
from kinsync.io.gnss_csv import read_gnss_csv
from kinsync.io.imu_csv import read_imu_csv
from kinsync.io.ins_config import read_ins_config
from kinsync.io.nav_csv import write_nav_csv
from kinsync.io.tables import read_numeric_csv
from kinsync.io.trajectory_csv import read_trajectory_csv
from kinsync.trajectory import Trajectory

REFERENCE_EPOCHS_S = 42_000.0
NUMPY_EPOCHS = 5_000
DEFAULT_DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "navego-synthetic"
SHIPPED = Path(__file__).resolve().parents[1] / "configs" / "navego-adis16488.toml"
PEERS = {
    "A": ("pyins", (1.198, 1.169, 1.553), (0.250, 0.500, 3.313)),
    "B": ("pyins", (0.333, 0.407, 0.527), (0.105, 0.087, 0.506)),
    "C": ("KF-GINS", (1.112, 1.229, 1.594), (0.182, 0.262, 1.253)),
}
"""Best peer per condition, forward solutions (issue 17: measured side by side)."""
TARGET_FORWARD_S, TARGET_SMOOTH_S = 5.0, 8.0


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


def end_to_end(data: Path) -> None:
    """``kinsync ins run`` in fresh processes, and its split measured in this process."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "nav.csv"
        cmd = [
            sys.executable, "-m", "kinsync", "ins", "run", "--imu", str(data / "imu.csv"),
            "--gnss", str(data / "gnss.csv"), "--config", str(SHIPPED), "--init-from",
            str(data / "truth.csv"), "--out", str(out), "--json",
        ]  # fmt: skip

        def wall(extra: list[str]) -> float:
            start = time.perf_counter()
            subprocess.run([*cmd, *extra], check=True, capture_output=True)
            return time.perf_counter() - start

        wall([])  # warm the JIT cache and the file cache
        t_fwd = min(wall([]) for _ in range(3))
        t_smo = min(wall(["--smooth"]) for _ in range(3))
        imports = [sys.executable, "-c", "import kinsync.cli.app, kinsync.ins.filter"]
        start_up = min(
            _timed(lambda: subprocess.run(imports, check=True, capture_output=True))
            for _ in range(3)
        )

        def read() -> tuple[ImuData, GnssData, InsConfig, InitialState]:
            config = read_ins_config(SHIPPED)
            imu = read_imu_csv(data / "imu.csv")
            gnss = read_gnss_csv(data / "gnss.csv")
            check_inputs(imu, gnss, config, imu_source="imu", gnss_source="gnss", static_s=0.0)
            truth = read_trajectory_csv(data / "truth.csv")
            return imu, gnss, config, _first_epoch_state(truth)

        t_read = best_of(read)
        imu, gnss, config, init = read()
        t_filter = best_of(lambda: run_ins(imu, gnss, config, init))
        t_both = best_of(lambda: run_ins(imu, gnss, config, init, smooth=True))
        result = run_ins(imu, gnss, config, init)
        t_write = best_of(lambda: write_nav_csv(result.forward, out))
    print("\nkinsync ins run, end to end (fresh process, warm JIT cache, best of 3):")
    print(f"  forward                     {t_fwd:6.2f} s   (target <= {TARGET_FORWARD_S:g} s)")
    print(f"  --smooth                    {t_smo:6.2f} s   (target <= {TARGET_SMOOTH_S:g} s)")
    print("  split, measured in this process:")
    print(f"    start-up (python + imports) {start_up:6.2f} s")
    print(f"    read + check inputs         {t_read:6.2f} s")
    print(f"    filter (forward)            {t_filter:6.2f} s")
    print(f"    smoother                    {t_both - t_filter:6.2f} s")
    print(f"    write solution CSV          {t_write:6.2f} s")


def _timed(fn: Callable[[], object]) -> float:
    start = time.perf_counter()
    fn()
    return time.perf_counter() - start


def _first_epoch_state(truth: Trajectory) -> InitialState:
    assert truth.lat_lon_h is not None
    assert truth.vel_ned_m_s is not None
    rpy = truth.euler_rpy_rad()[0]
    return InitialState(
        t_s=float(truth.t_s[0]),
        lat_deg=float(truth.lat_lon_h[0, 0]),
        lon_deg=float(truth.lat_lon_h[0, 1]),
        h_m=float(truth.lat_lon_h[0, 2]),
        vel_ned_m_s=(
            float(truth.vel_ned_m_s[0, 0]),
            float(truth.vel_ned_m_s[0, 1]),
            float(truth.vel_ned_m_s[0, 2]),
        ),
        rpy_rad=(float(rpy[0]), float(rpy[1]), float(rpy[2])),
    )


def conditions(imu: ImuData, gnss: GnssData, tr: dict[str, np.ndarray], data: Path) -> None:
    """Issue 17's conditions with the one shipped configuration, beside the best peer."""
    spec = json.loads((data / "imu_gnss_spec.json").read_text())
    config = read_ins_config(SHIPPED)
    known = dataclasses.replace(
        config,
        init_gyro_bias_rad_s=tuple(spec["gb_sta"]),
        init_gyro_bias_std_rad_s=(10 * spec["gb_dyn"][0],) * 3,
        init_acc_bias_m_s2=tuple(spec["ab_sta"]),
        init_acc_bias_std_m_s2=(10 * spec["ab_dyn"][0],) * 3,
    )
    init = _first_epoch_state(read_trajectory_csv(data / "truth.csv"))
    print(f"\nRMS errors against truth.csv, one shipped configuration ({SHIPPED.name}):")
    print("  condition / solution          pos N/E/D (m)           roll/pitch/yaw (deg)   peer")
    for name, cfg, vel in (("A", config, False), ("B", config, True), ("C", known, False)):
        res = run_ins(imu, gnss, cfg, init, use_velocity=vel, smooth=True)
        assert res.smoothed is not None
        for kind, sol in (("forward", res.forward), ("smoothed", res.smoothed)):
            p, a = rms(sol, tr)
            line = f"  {name} {kind:26s} " + " ".join(f"{v:6.3f}" for v in p)
            line += "    " + " ".join(f"{v:6.3f}" for v in a)
            if kind == "forward":
                line += "   " + _peer_verdict(name, p, a)
            print(line)


def _peer_verdict(condition: str, pos: np.ndarray, att: np.ndarray) -> str:
    """The best peer's figures and the axes where kinsync (rounded to 3 decimals) is worse."""
    peer, pos_p, att_p = PEERS[condition]
    ours = np.round([*pos, *att], 3)
    axes = ("N", "E", "D", "roll", "pitch", "yaw")
    worse = [ax for ax, v, q in zip(axes, ours, (*pos_p, *att_p), strict=True) if v > q]
    figures = "/".join(f"{v:.3f}" for v in pos_p) + ", " + "/".join(f"{v:.3f}" for v in att_p)
    return f"{peer} {figures}: " + ("meets it" if not worse else "worse in " + ", ".join(worse))


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
    n_err = ck.P_plus.shape[1]
    print(
        f"  smoother memory: {ck.epoch.size:,} checkpoints, {ck_bytes / 1e6:.1f} MB "
        f"(per-epoch P+, P-, Phi would be {3 * n * n_err * n_err * 8 / 1e6:.0f} MB)"
    )
    end_to_end(args.data)
    conditions(imu, gnss, tr, args.data)


if __name__ == "__main__":
    main()
