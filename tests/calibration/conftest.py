"""A small analytic patch test: returns on known planes, put into the scanner frame
through a known mount, so that the estimator's answer is known exactly.

Straight lines at constant heading over a scene of five planes (ground, two walls
along the lines, a wall across them, a 30-degree roof); the body rolls and pitches
gently. Each return is a point on a plane near the body at a random time, taken back
through the true trajectory and the true mount into the scanner frame, with range
noise along its beam. The navigation trajectory is the truth (optionally with
time-correlated errors) shifted by +tau: the record tagged ``t`` describes the state
at ``t - tau`` (SPEC section 1).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pytest

from kinsync._typing import FloatArray, IntArray
from kinsync.calibration.lines import ScanLine
from kinsync.frames import ecef_to_geodetic, geodetic_to_ecef, rotation_ned_to_ecef
from kinsync.georef import GeorefTrajectory, georeference
from kinsync.mount import Mount
from kinsync.sim.nav_noise import noisy_trajectory
from kinsync.trajectory import Trajectory

ORIGIN = (46.8, -71.2, 10.0)
R_NED_TO_ECEF = rotation_ned_to_ecef(ORIGIN[0], ORIGIN[1])
ORIGIN_ECEF = geodetic_to_ecef(*ORIGIN)
_S30, _C30 = np.sin(np.radians(30.0)), np.cos(np.radians(30.0))
PLANES: dict[str, tuple[FloatArray, FloatArray]] = {
    "ground": (np.array([0.0, 0.0, 2.0]), np.array([0.0, 0.0, -1.0])),
    "east wall": (np.array([0.0, 15.0, 0.0]), np.array([0.0, -1.0, 0.0])),
    "west wall": (np.array([0.0, -15.0, 0.0]), np.array([0.0, 1.0, 0.0])),
    "roof": (np.array([0.0, 12.0, -8.0]), np.array([0.0, -_S30, -_C30])),
    "north wall": (np.array([60.0, 0.0, 0.0]), np.array([-1.0, 0.0, 0.0])),
}
NOMINAL = Mount(lever_arm_body_m=(0.5, -0.2, -1.0), boresight_rpy_deg=(0.0, 0.0, 0.0))
TRUE = Mount(
    lever_arm_body_m=(0.52, -0.18, -1.03), boresight_rpy_deg=(0.3, -0.2, 0.4), latency_s=0.005
)
BOTH_WAYS = ((0.0, (-30.0, 0.0)), (180.0, (90.0, 0.0)))


@dataclass(frozen=True, eq=False)
class Synthetic:
    """Lines and, per line, the plane each return lies on (index into PLANES)."""

    lines: tuple[ScanLine, ...]
    labels: tuple[IntArray, ...]


def line_truth(
    t0: float, heading_deg: float, speed_m_s: float, start_ne: tuple[float, float],
    duration_s: float, rng: np.random.Generator, roll_amp_rad: float = 0.01,
) -> Trajectory:  # fmt: skip
    """A straight line at constant heading and speed, 100 Hz, with gentle roll/pitch."""
    t = t0 + np.arange(0.0, duration_s, 0.01)
    hd = np.radians(heading_deg)
    d = speed_m_s * (t - t0)
    ne = np.column_stack(
        [start_ne[0] + d * np.cos(hd), start_ne[1] + d * np.sin(hd), np.zeros_like(t)]
    )
    llh = ecef_to_geodetic(ORIGIN_ECEF + ne @ R_NED_TO_ECEF.T)
    ph = rng.uniform(0.0, 2 * np.pi, 2)
    roll = roll_amp_rad * np.sin(2.0 * (t - t0) + ph[0])
    pitch = 0.5 * roll_amp_rad * np.sin(1.3 * (t - t0) + ph[1])
    vel = np.column_stack(
        [np.full_like(t, speed_m_s * np.cos(hd)), np.full_like(t, speed_m_s * np.sin(hd)),
         np.zeros_like(t)]
    )  # fmt: skip
    return Trajectory.from_euler(
        t, roll, pitch, np.full_like(t, hd), lat_lon_h=llh, vel_ned_m_s=vel
    )


def sample_line(
    truth: Trajectory, mount: Mount, navigation: Trajectory, name: str,
    rng: np.random.Generator, planes: tuple[str, ...], n_per_plane: int, range_noise_m: float,
) -> tuple[ScanLine, IntArray]:  # fmt: skip
    """Returns on ``planes`` seen from ``truth`` through ``mount``; the line and labels."""
    g = GeorefTrajectory.from_trajectory(truth)
    identity = Mount()
    ts, xs, labels = [], [], []
    for name_plane in planes:
        p0, n = PLANES[name_plane]
        tt = rng.uniform(truth.t_start_s + 0.5, truth.t_end_s - 0.5, n_per_plane)
        zero = np.zeros((tt.size, 3))
        pe, _ = georeference(tt, zero, g, identity)
        pl = (pe - ORIGIN_ECEF) @ R_NED_TO_ECEF
        u = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
        u /= np.linalg.norm(u)
        w = np.cross(n, u)
        base = pl - np.outer((pl - p0) @ n, n)
        q = base + rng.uniform(-8, 8, (tt.size, 1)) * u + rng.uniform(-8, 8, (tt.size, 1)) * w
        C = np.empty((tt.size, 3, 3))
        for j in range(3):
            e = np.zeros((tt.size, 3))
            e[:, j] = 1.0
            col, _ = georeference(tt, e, g, identity)
            C[:, :, j] = col - pe
        xe = ORIGIN_ECEF + q @ R_NED_TO_ECEF.T
        body = np.einsum("nji,nj->ni", C, xe - pe) - np.array(mount.lever_arm_body_m)
        xs_ = body @ mount.R_scanner_to_body
        r = np.linalg.norm(xs_, axis=1, keepdims=True)
        xs_ = xs_ * (1.0 + range_noise_m * rng.standard_normal((tt.size, 1)) / r)
        ts.append(tt)
        xs.append(xs_)
        labels.append(np.full(tt.size, list(PLANES).index(name_plane)))
    t = np.concatenate(ts)
    x = np.concatenate(xs)
    lab = np.concatenate(labels)
    order = np.argsort(t)
    return ScanLine(name, t[order], x[order], navigation), lab[order]


def make_synthetic(
    *,
    seed: int = 0,
    mount: Mount = TRUE,
    speeds: tuple[float, ...] = (5.0, 12.0),
    ways: tuple[tuple[float, tuple[float, float]], ...] = BOTH_WAYS,
    repeats: int = 1,
    planes: tuple[str, ...] = tuple(PLANES),
    n_per_plane: int = 150,
    range_noise_m: float = 0.005,
    nav_errors: bool = False,
    roll_amp_rad: float = 0.01,
) -> Synthetic:
    """Lines at each speed, each way, ``repeats`` times, 100 s apart."""
    rng = np.random.default_rng(seed)
    lines, labels = [], []
    k = 0
    for _ in range(repeats):
        for speed in speeds:
            for heading, start in ways:
                truth = line_truth(1e9 + 100.0 * k, heading, speed, start, 120.0 / speed, rng,
                                   roll_amp_rad)  # fmt: skip
                nav = truth
                if nav_errors:
                    nav = noisy_trajectory(
                        truth, std_pos_ned_m=(0.02, 0.02, 0.03),
                        std_att_deg=(0.005, 0.005, 0.015), corr_time_s=10.0, seed=seed * 100 + k,
                    )  # fmt: skip
                line, lab = sample_line(
                    truth, mount, nav.shifted(mount.latency_s), f"line {k + 1}", rng, planes,
                    n_per_plane, range_noise_m,
                )  # fmt: skip
                lines.append(line)
                labels.append(lab)
                k += 1
    return Synthetic(tuple(lines), tuple(labels))


@pytest.fixture(scope="session")
def synthetic() -> Callable[..., Synthetic]:
    """The generator, for tests that need their own variant."""
    return make_synthetic
