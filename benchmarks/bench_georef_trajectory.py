"""Georeferencing's trajectory preparation on a long SBET: whole against the points' span.

Writes a 200 Hz SBET of ``HOURS`` hours (default 1; ``python bench_georef_trajectory.py
10`` for a survey day, 7.2 M records, 1 GB of disk for a while), then times, in one run:

* a plain numpy read of the file (``np.fromfile``): the floor;
* ``read_trajectory_file``: the checked `Trajectory`;
* `GeorefRecords.from_trajectory` (the velocity-consistency check, the gaps) plus the
  records 100 s of points need, prepared (what ``kinsync georef`` does now);
* `GeorefTrajectory.from_trajectory`: every record prepared (what it did before);

and prints each figure, the checked read's ratio against the plain read and the
preparation's ratio against the whole preparation, with
the growth of this process's peak RSS over each step. Run:
``.venv/bin/python benchmarks/bench_georef_trajectory.py [HOURS]``.
"""

from __future__ import annotations

import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from kinsync.georef.trajectory import GeorefRecords, GeorefTrajectory
from kinsync.io.sbet import SBET_DTYPE
from kinsync.io.trajectory import read_trajectory_file

WEEK = 2345
T0_SOW = 216_000.0
RATE_HZ = 200.0
POINTS_SPAN_S = 100.0
LAT0, LON0 = np.radians(46.8), np.radians(-71.2)
VN, VE = 15.0 * np.cos(0.0075), 15.0 * np.sin(0.0075)  # m/s, a straight course
_E2 = 6.69437999014e-3  # WGS84 first eccentricity squared
_W = np.sqrt(1.0 - _E2 * np.sin(LAT0) ** 2)
M_RADIUS = 6378137.0 * (1.0 - _E2) / _W**3  # meridian radius of curvature (m)
N_RADIUS = 6378137.0 / _W  # prime-vertical radius of curvature (m)


def write_sbet(path: Path, hours: float) -> int:
    """A 15 m/s drive near Québec City, turning and rolling: ``hours`` at 200 Hz."""
    n = round(hours * 3600 * RATE_HZ) + 1
    with path.open("wb") as fh:
        for start in range(0, n, 1_000_000):
            k = np.arange(start, min(n, start + 1_000_000))
            s = k / RATE_HZ
            psi = 0.0075 * s + 0.3 * np.sin(0.05 * s)
            rec = np.zeros(k.size, dtype=SBET_DTYPE)
            rec["time_sow_s"] = T0_SOW + s
            rec["lat_rad"] = LAT0 + VN * s / M_RADIUS
            rec["lon_rad"] = LON0 + VE * s / (N_RADIUS * np.cos(LAT0))
            rec["h_m"] = 50.0 + 2.0 * np.sin(2 * np.pi * s / 600.0)
            rec["vel_x_wander_m_s"] = VN  # wander angle 0: north, east, down
            rec["vel_y_wander_m_s"] = VE
            rec["vel_z_wander_m_s"] = -2.0 * 2 * np.pi / 600.0 * np.cos(2 * np.pi * s / 600.0)
            rec["roll_rad"] = np.radians(np.sin(s / 7.0))
            rec["pitch_rad"] = np.radians(0.8 * np.sin(s / 11.0))
            rec["platform_heading_rad"] = np.mod(psi, 2 * np.pi)
            rec.tofile(fh)
    return n


def peak_rss_gb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6


def timed(label: str, fn: object) -> tuple[float, object]:
    before = peak_rss_gb()
    t0 = time.perf_counter()
    out = fn()  # type: ignore[operator]
    wall = time.perf_counter() - t0
    print(f"{label:<58}{wall:>9.2f} s   peak RSS +{peak_rss_gb() - before:.2f} GB")
    return wall, out


def main() -> None:
    hours = float(sys.argv[1]) if len(sys.argv) > 1 else 1.0
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "sbet.out"
        n = write_sbet(path, hours)
        print(
            f"SBET: {hours:g} h at {RATE_HZ:g} Hz, {n:,} records; points over {POINTS_SPAN_S:g} s"
        )
        floor_s, _ = timed(
            "plain numpy read (np.fromfile, the floor)", lambda: np.fromfile(path, SBET_DTYPE)
        )
        read_s, got = timed(
            "read_trajectory_file (checked Trajectory)",
            lambda: read_trajectory_file(path, gps_week=WEEK)[0],
        )
        traj = got
        t_mid = float(traj.t_s[n // 2])  # type: ignore[attr-defined]

        def span() -> object:
            records = GeorefRecords.from_trajectory(traj, 0.003)  # type: ignore[arg-type]
            return records.prepared_for(t_mid, t_mid + POINTS_SPAN_S)

        span_s, prepared = timed("now: checks + the points' span prepared", span)
        whole_s, _ = timed(
            "before: every record prepared (GeorefTrajectory)",
            lambda: GeorefTrajectory.from_trajectory(traj, 0.003),  # type: ignore[arg-type]
        )
        print(f"checked read / plain numpy read: {read_s / floor_s:.1f}")
        print(f"records prepared now: {len(prepared):,} of {n:,}")  # type: ignore[arg-type]
        print(f"preparation time, now / before: {span_s / whole_s:.3f}")


if __name__ == "__main__":
    main()
