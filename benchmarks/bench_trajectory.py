"""Trajectory interpolation and Euler conversion: throughput against SciPy, and accuracy.

Prints points per second for kinsync and for a SciPy baseline measured in the same run
(``scipy.spatial.transform.Slerp`` + ``np.interp`` / ``CubicHermiteSpline``), their
ratio, and the interpolation error against an analytic constant-turn motion.
Run: ``make bench`` (or ``.venv/bin/python benchmarks/bench_trajectory.py``).
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicHermiteSpline
from scipy.spatial.transform import Rotation, Slerp

from _timing import best_of
from kinsync.frames import euler_rpy_to_matrix, ned_to_ecef, wrap_angle_rad
from kinsync.trajectory import Trajectory

RATE_HZ = 200.0
DURATION_S = 600.0
N_QUERY = 1_000_000
ORIGIN = (46.8, -71.2, 10.0)


def turning_vehicle(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Constant-speed circle (radius 50 m, 10 m/s) with roll/pitch oscillation: truth."""
    w = 10.0 / 50.0
    pos = np.column_stack([50 * np.sin(w * t), 50 * (1 - np.cos(w * t)), -0.5 * np.sin(0.3 * t)])
    vel = np.column_stack([10 * np.cos(w * t), 10 * np.sin(w * t), -0.15 * np.cos(0.3 * t)])
    rpy = np.column_stack([0.05 * np.sin(1.1 * t), 0.02 * np.sin(0.7 * t), wrap_angle_rad(w * t)])
    return pos, vel, rpy, euler_rpy_to_matrix(rpy[:, 0], rpy[:, 1], rpy[:, 2])


def main() -> None:
    rng = np.random.default_rng(1)
    t = np.arange(0.0, DURATION_S, 1.0 / RATE_HZ)
    pos, vel, rpy, _ = turning_vehicle(t)
    traj = Trajectory.from_euler(
        t, rpy[:, 0], rpy[:, 1], rpy[:, 2], pos_ned_m=pos, origin_lat_lon_h=ORIGIN, vel_ned_m_s=vel
    )
    tq = np.sort(rng.uniform(t[0], t[-1], N_QUERY))
    print(f"trajectory: {len(t)} records at {RATE_HZ:g} Hz; {N_QUERY:,} query times")

    k_lin = best_of(lambda: traj.interpolate(tq, position="linear"))
    k_her = best_of(lambda: traj.interpolate(tq, position="hermite"))
    rot = Rotation.from_quat(traj.q_body_to_ned[:, [1, 2, 3, 0]])

    def scipy_linear() -> None:
        Slerp(t, rot)(tq)
        for i in range(3):
            np.interp(tq, t, pos[:, i])

    def scipy_hermite() -> None:
        Slerp(t, rot)(tq)
        CubicHermiteSpline(t, pos, vel)(tq)

    s_lin = best_of(scipy_linear)
    s_her = best_of(scipy_hermite)
    print(f"{'method':<34}{'kinsync (Mpt/s)':>16}{'scipy (Mpt/s)':>15}{'ratio':>8}")
    for name, k, s in (
        ("slerp + linear position", k_lin, s_lin),
        ("slerp + Hermite position", k_her, s_her),
    ):
        print(f"{name:<34}{N_QUERY / k / 1e6:>16.2f}{N_QUERY / s / 1e6:>15.2f}{s / k:>8.2f}")

    # Euler -> matrix.
    n = 1_000_000
    ang = rng.uniform(-1.0, 1.0, (n, 3))
    k_eul = best_of(lambda: euler_rpy_to_matrix(ang[:, 0], ang[:, 1], ang[:, 2]))
    s_eul = best_of(lambda: Rotation.from_euler("ZYX", ang[:, ::-1]).as_matrix())
    label = "Euler -> matrix (1M)"
    print(f"{label:<34}{n / k_eul / 1e6:>16.2f}{n / s_eul / 1e6:>15.2f}{s_eul / k_eul:>8.2f}")
    ned = rng.uniform(-1000, 1000, (n, 3))
    k_ecef = best_of(lambda: ned_to_ecef(ned, *ORIGIN))
    print(f"{'local NED -> ECEF (1M)':<34}{n / k_ecef / 1e6:>16.2f}")

    # Accuracy against the analytic motion, at two trajectory rates.
    print("\ninterpolation error against analytic constant-turn motion (10 m/s, r = 50 m):")
    print(f"{'rate (Hz)':>10}{'linear pos (m)':>16}{'Hermite pos (m)':>17}{'slerp att (rad)':>17}")
    for rate in (200.0, 50.0, 10.0):
        ts = np.arange(0.0, 60.0, 1.0 / rate)
        p, v, a, _ = turning_vehicle(ts)
        tr = Trajectory.from_euler(
            ts, a[:, 0], a[:, 1], a[:, 2], pos_ned_m=p, origin_lat_lon_h=ORIGIN, vel_ned_m_s=v
        )
        tt = rng.uniform(ts[0], ts[-1], 200_000)
        p_true, _, _, R_true = turning_vehicle(tt)
        lin = tr.interpolate(tt, position="linear")
        her = tr.interpolate(tt, position="hermite")
        assert lin.pos_ned_m is not None
        assert her.pos_ned_m is not None
        e_lin = np.abs(lin.pos_ned_m - p_true).max()
        e_her = np.abs(her.pos_ned_m - p_true).max()
        rel = np.einsum("nji,njk->nik", R_true, her.R_body_to_ned)
        e_att = Rotation.from_matrix(rel).magnitude().max()
        print(f"{rate:>10g}{e_lin:>16.3e}{e_her:>17.3e}{e_att:>17.3e}")


if __name__ == "__main__":
    main()
