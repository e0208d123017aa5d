"""Georeferencing between formats: each output (and CSV input) against LAZ -> LAZ.

Prints, for one scanner-frame LAZ file (``--points``, 2 M by default) and a
trajectory, the wall time of ``georeference_file`` into LAZ (the baseline), LAS, CSV,
Parquet and PLY, from a CSV/Parquet copy of the same points (scanner frame) into
LAZ, and from tables to tables: the CSV to CSV, and a Parquet copy with carried columns
of several types, nulls among them (``carried``: int32, int64, uint8, float32, bool,
text), to Parquet and to CSV; each the best of ``--repeat`` runs measured in the same
process, with the ratio of its points per second to the baseline's (> 1: faster than
LAZ -> LAZ). ``--cases WORD,...`` measures only the cases whose label holds one of the
words (and the baseline).

Run: ``.venv/bin/python benchmarks/bench_georef_formats.py [--points N] [--repeat R]``.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import laspy
import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from _timing import best_of
from kinsync.frames import wrap_angle_rad
from kinsync.io.mount_file import write_mount
from kinsync.io.table_writer import TableChunkWriter
from kinsync.io.trajectory_csv import write_trajectory_csv
from kinsync.mount import Mount
from kinsync.pipelines.georef import georeference_file
from kinsync.trajectory import Trajectory

T0_GPS_S = 1.3e9
DURATION_S = 300.0
MOUNT = Mount(lever_arm_body_m=(0.8, -0.3, -1.2), boresight_rpy_deg=(0.4, -0.7, 91.0))
CRS = "EPSG:32619"


def write_inputs(folder: Path, n_points: int) -> None:
    """Trajectory CSV, mount, scanner-frame LAZ, and the same points as CSV and Parquet."""
    t = np.arange(0.0, DURATION_S, 0.005)
    w = 0.2
    llh = np.column_stack(
        [46.8 + 4.5e-4 * np.sin(w * t), -71.2 + 6.6e-4 * (1 - np.cos(w * t)), 10.0 + 0 * t]
    )
    traj = Trajectory.from_euler(
        t + T0_GPS_S,
        0.05 * np.sin(1.1 * t),
        0.02 * np.sin(0.7 * t),
        wrap_angle_rad(w * t),
        lat_lon_h=llh,
    )
    write_trajectory_csv(traj, folder / "traj.csv")
    write_mount(MOUNT, folder / "mount.toml")
    rng = np.random.default_rng(2)
    angle = rng.uniform(0, 2 * np.pi, n_points)
    cols = {
        "t_s": np.sort(rng.uniform(0.1, DURATION_S - 0.1, n_points)) + T0_GPS_S,
        "x_m": np.zeros(n_points),
        "y_m": np.round(20 * np.cos(angle), 4),
        "z_m": np.round(20 * np.sin(angle), 4),
        "intensity": rng.integers(0, 4000, n_points),
    }
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.global_encoding.gps_time_type = laspy.header.GpsTimeType.STANDARD
    header.scales = np.array([1e-4, 1e-4, 1e-4])
    header.offsets = np.zeros(3)
    las = laspy.LasData(header)
    las.x, las.y, las.z = cols["x_m"], cols["y_m"], cols["z_m"]
    las.gps_time = cols["t_s"] - 1e9
    las.intensity = cols["intensity"].astype(np.uint16)
    las.write(folder / "scan.laz")
    for name in ("scan.csv", "scan.parquet"):
        with TableChunkWriter(folder / name) as writer:
            writer.write(cols)
    k = np.arange(n_points)
    every = k % 17 == 0  # nulls
    carried = pa.table(
        {
            **{n: cols[n] for n in ("t_s", "x_m", "y_m", "z_m")},
            "intensity": pa.array(cols["intensity"].astype(np.int32), mask=every),
            "return_id": pa.array(k.astype(np.int64) + 2**40),
            "class": pa.array((k % 19).astype(np.uint8)),
            "refl": pa.array(rng.random(n_points).astype(np.float32), mask=k % 13 == 0),
            "valid": pa.array(k % 3 == 0, mask=every),
            "label": pa.array(np.char.add("p", (k % 1000).astype(str)), mask=k % 29 == 0),
        }
    )
    pq.write_table(carried, folder / "scan_carried.parquet")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--points", type=int, default=2_000_000)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument(
        "--cases",
        default="",
        help="only the cases whose label holds one of these words (comma-separated)",
    )
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        write_inputs(d, args.points)
        cases = [("scan.laz", "out.laz")] + [
            ("scan.laz", f"out{s}") for s in (".las", ".csv", ".parquet", ".ply")
        ]
        cases += [("scan.csv", "from_csv.laz"), ("scan.parquet", "from_parquet.laz")]
        cases += [("scan.csv", "from_csv.csv")]
        cases += [("scan_carried.parquet", f"carried{s}") for s in (".parquet", ".csv")]
        base = 0.0
        print(f"{args.points} points, best of {args.repeat}, CRS {CRS}")
        print(f"{'input -> output':28s} {'s':>8s} {'Mpts/s':>8s} {'vs LAZ->LAZ':>12s}")
        for src, out in cases:
            label = f"{Path(src).suffix[1:]} -> {Path(out).suffix[1:]}"
            label += " (carried)" if "carried" in src else ""
            if base and not any(word in label for word in args.cases.split(",")):
                continue

            def run(src: str = src, out: str = out) -> None:
                s = georeference_file(d / src, d / "traj.csv", MOUNT, d / out, crs=CRS)
                assert s.points_out == args.points

            seconds = best_of(run, args.repeat)
            base = base or seconds
            rate = args.points / seconds / 1e6
            print(f"{label:28s} {seconds:8.2f} {rate:8.2f} {base / seconds:12.2f}")


if __name__ == "__main__":
    main()
