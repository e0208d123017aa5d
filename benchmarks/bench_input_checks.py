"""What the input checks of issue 15 cost, against the reading they guard.

Prints, each beside a baseline measured in the same run:

- the trajectory velocity check (`kinsync.trajectory.check_velocities`) on an hour of
  200 Hz records, against reading the same trajectory from an SBET file (which the
  check now follows) and against preparing it for georeferencing;
- the value checks of the trajectory CSV reader (every column finite and inside its
  span), against pyarrow reading the same CSV into float64 columns;
- `kinsync.io.las.las_info` on a LAZ file (header, VLRs and the LAZ chunk table checked
  against the file) against ``laspy.open(...).header``;
- the point-count check of a pointwise LAZ (its last chunk decompressed once per file
  and process) against laspy's header and against reading every point;
- refusing a 10 GiB sparse file given as a trajectory CSV: the time and the bytes read
  (before issue 15 the reader held the whole file in memory).

Run: ``.venv/bin/python benchmarks/bench_input_checks.py``.
"""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path

import laspy
import numpy as np
import pyarrow.csv as pa_csv

from _timing import best_of
from kinsync.errors import InputError
from kinsync.frames import ecef_to_geodetic, ned_to_ecef, wrap_angle_rad
from kinsync.georef import GeorefTrajectory
from kinsync.io import laz_chunks
from kinsync.io.las import las_info
from kinsync.io.sanity import PROBE_BYTES
from kinsync.io.sbet import read_sbet, write_sbet
from kinsync.io.trajectory_csv import read_trajectory_csv, write_trajectory_csv
from kinsync.trajectory import Trajectory, check_velocities

RATE_HZ = 200.0
DURATION_S = 3600.0
CSV_DURATION_S = 600.0
LAZ_POINTS = 5_000_000
T0 = 1.4e9


def drive(duration_s: float) -> Trajectory:
    """A vehicle on a 500 m circle at 15 m/s with heave, with exact velocities."""
    t = np.arange(0.0, duration_s, 1.0 / RATE_HZ)
    w = 15.0 / 500.0
    north, east = 500.0 * np.sin(w * t), 500.0 * (1.0 - np.cos(w * t))
    vel = np.column_stack([15.0 * np.cos(w * t), 15.0 * np.sin(w * t), -0.3 * np.cos(0.5 * t)])
    pos = np.column_stack([north, east, -0.6 * np.sin(0.5 * t)])
    llh = ecef_to_geodetic(ned_to_ecef(pos, 46.8, -71.2, 10.0))
    return Trajectory.from_euler(
        T0 + t,
        0.03 * np.sin(0.9 * t),
        0.02 * np.sin(0.6 * t),
        wrap_angle_rad(w * t),
        lat_lon_h=llh,
        vel_ned_m_s=vel,
    )


def velocity_check(folder: Path) -> None:
    write_sbet(drive(DURATION_S), folder / "t.out")
    traj = read_sbet(folder / "t.out")
    assert traj.vel_ned_m_s is not None
    n = len(traj)
    displacement = traj._displacement_ned_m()
    vel = traj.vel_ned_m_s
    check = best_of(lambda: check_velocities(traj.t_s, displacement, vel))
    fresh = best_of(lambda: check_velocities(traj.t_s, traj._displacement_ned_m(), vel))
    read = best_of(lambda: read_sbet(folder / "t.out"))
    prepare = best_of(lambda: GeorefTrajectory.from_trajectory(traj))
    result = traj.velocity_check
    assert result is not None
    print(f"velocity check, {n:,} records ({DURATION_S / 3600:g} h at {RATE_HZ:g} Hz):")
    print(f"  check_velocities alone               {check * 1e3:8.1f} ms")
    print(f"  with its NED displacements (the cost) {fresh * 1e3:7.1f} ms")
    print(
        f"  read_sbet of the same file           {read * 1e3:8.1f} ms  (ratio {fresh / read:.2f})"
    )
    print(
        f"  GeorefTrajectory.from_trajectory     {prepare * 1e3:8.1f} ms  "
        f"(check cached after the first run; ratio {fresh / prepare:.2f})"
    )
    print(
        f"  verdict on honest velocities: consistent={result.consistent}, scale "
        f"{result.velocity_scale:.6f}, relative mismatch "
        f"{result.rms_mismatch_horizontal_m / result.rms_displacement_horizontal_m:.1e}"
    )


def csv_checks(folder: Path) -> None:
    traj = drive(CSV_DURATION_S)
    path = folder / "t.csv"
    write_trajectory_csv(traj, path)
    size_mib = path.stat().st_size / 2**20
    kinsync = best_of(lambda: read_trajectory_csv(path))
    arrow = best_of(lambda: pa_csv.read_csv(path))
    print(f"\ntrajectory CSV, {len(traj):,} rows ({size_mib:.0f} MiB):")
    print(f"  read_trajectory_csv (checks included) {kinsync * 1e3:8.1f} ms")
    ratio = kinsync / arrow
    print(f"  pyarrow read_csv alone                {arrow * 1e3:8.1f} ms  (ratio {ratio:.2f})")


def _write_laz(path: Path, point_format: int, version: str, seed: int) -> Path:
    """`LAZ_POINTS` random points in 1 M-point blocks, as laspy's LAZ writer chunks them."""
    rng = np.random.default_rng(seed)
    header = laspy.LasHeader(point_format=point_format, version=version)
    header.scales = np.array([1e-4, 1e-4, 1e-4])
    header.offsets = np.zeros(3)
    with laspy.open(path, mode="w", header=header) as writer:
        for start in range(0, LAZ_POINTS, 1_000_000):
            rec = laspy.ScaleAwarePointRecord.zeros(1_000_000, header=header)
            rec.x = rng.uniform(-50, 50, 1_000_000)
            rec.y = rng.uniform(-50, 50, 1_000_000)
            rec.gps_time = start + np.arange(1_000_000) * 1e-6
            writer.write_points(rec)
    return path


def laz_header(folder: Path) -> None:
    path = _write_laz(folder / "scan.laz", point_format=6, version="1.4", seed=1)

    def laspy_header() -> None:
        with laspy.open(path) as reader:
            _ = reader.header.point_count

    ours = best_of(lambda: las_info(path), repeat=5)
    theirs = best_of(laspy_header, repeat=5)
    print(f"\nLAZ header, {LAZ_POINTS:,} points ({path.stat().st_size / 2**20:.0f} MiB):")
    print(f"  las_info (VLRs and chunk table checked) {ours * 1e3:8.2f} ms")
    ratio = ours / theirs
    print(f"  laspy.open(...).header                  {theirs * 1e3:8.2f} ms  (ratio {ratio:.2f})")


def laz_pointwise_count(folder: Path) -> None:
    """The point-count check of a pointwise LAZ (formats 0-5): its last chunk is probed.

    The first `las_info` of a file in a process decompresses that chunk less its last
    byte (`kinsync.io.laz_chunks`); later opens hit a cache. Beside: laspy's header
    alone, and reading the whole file's points (what any command then does).
    """
    path = _write_laz(folder / "pointwise.laz", point_format=1, version="1.2", seed=2)

    def first_open() -> None:
        laz_chunks._PROBED.clear()  # as for the first open of the file in a process
        las_info(path)

    def laspy_header() -> None:
        with laspy.open(path) as reader:
            _ = reader.header.point_count

    cold = best_of(first_open, repeat=5)
    warm = best_of(lambda: las_info(path), repeat=5)
    theirs = best_of(laspy_header, repeat=5)
    whole = best_of(lambda: laspy.read(path), repeat=2)
    size_mib = path.stat().st_size / 2**20
    print(f"\npointwise LAZ (format 1), {LAZ_POINTS:,} points ({size_mib:.0f} MiB):")
    print(f"  las_info, first open (last chunk probed) {cold * 1e3:8.2f} ms")
    print(f"  las_info, later opens (probe cached)     {warm * 1e3:8.2f} ms")
    print(f"  laspy.open(...).header                   {theirs * 1e3:8.2f} ms")
    ratio = cold / whole
    print(f"  laspy.read (every point)                 {whole * 1e3:8.2f} ms")
    print(f"  first open / reading every point         {ratio:8.3f}")


def sparse_refusal(folder: Path) -> None:
    path = folder / "huge.csv"
    path.touch()
    os.truncate(path, 10 << 30)
    start = time.perf_counter()
    try:
        read_trajectory_csv(path)
    except InputError as err:
        message = str(err)
    else:  # pragma: no cover - the benchmark reports a regression rather than failing
        message = "NOT REFUSED"
    seconds = time.perf_counter() - start
    print("\n10 GiB sparse file given as a trajectory CSV:")
    print(f"  refused in {seconds * 1e3:.2f} ms, at most {PROBE_BYTES // 1024} KiB read: {message}")


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        velocity_check(folder)
        csv_checks(folder)
        laz_header(folder)
        laz_pointwise_count(folder)
        sparse_refusal(folder)


if __name__ == "__main__":
    main()
