"""A rolling, turning trajectory and a scan over it, for the georeferencing pipeline tests."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from tests._las import las_points

from kinsync.io.trajectory_csv import write_trajectory_csv
from kinsync.trajectory import Trajectory

T0 = 1.3e9  # GPS time of the trajectory's first sample (s)


def write_trajectory(path: Path, duration_s: float) -> None:
    """A 100 Hz trajectory of ``duration_s`` from `T0`, near Québec City, as CSV."""
    t = T0 + np.arange(0.0, duration_s, 0.01)
    s = t - T0
    llh = np.column_stack([46.8 + 1e-5 * s, -71.2 + 2e-5 * s, 10.0 + 0.1 * s])
    traj = Trajectory.from_euler(
        t, 0.02 * np.sin(s), 0.01 * np.cos(0.5 * s), 0.3 + 0.05 * s, lat_lon_h=llh
    )
    write_trajectory_csv(traj, path)


def scan_columns(n: int, duration_s: float, seed: int) -> dict[str, np.ndarray]:
    """``n`` scanner points, ``t_s`` sorted from 0.5 s before the trajectory to 0.1 s
    before its end (so some lie outside its span), with an integer ``intensity``."""
    rng = np.random.default_rng(seed)
    return {
        "t_s": T0 + np.sort(rng.uniform(-0.5, duration_s - 0.1, n)),
        "x_m": rng.uniform(-1, 1, n),
        "y_m": rng.uniform(-20, 20, n),
        "z_m": rng.uniform(-5, 5, n),
        "intensity": rng.integers(0, 1000, n),
    }


def write_laz(cols: dict[str, np.ndarray], path: Path) -> None:
    """The columns as a LAZ file written by laspy (intensity as LAS intensity)."""
    las = las_points(cols)
    las.intensity = cols["intensity"].astype(np.uint16)
    las.write(path)
