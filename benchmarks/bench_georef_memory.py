"""Peak memory of ``kinsync georef`` on a 20-million-point file in 1-million-point chunks.

Writes a scanner-frame LAZ (or LAS) of ``--points`` points chunk by chunk (bounded
memory: one chunk of points at a time), a 200 Hz trajectory CSV and a mount, then runs
the real command line ``kinsync georef ... --chunk-points N --json`` in a fresh process
under ``/usr/bin/time -v`` and prints:

- the maximum resident set size that ``time`` reports for the command (for the serial
  run the process itself; for a process pool the largest single process);
- the peak of the summed RSS of the command's whole process tree (main process plus
  pool workers), sampled from ``/proc`` every 50 ms;
- wall time and points per second (noisy on a shared machine: memory is the figure).

Target: < 1 GB peak for 20 M points with 1 M-point chunks. The files go to a temporary
folder (``--dir``, default the system's) and are removed afterwards. Linux only
(``/proc``, GNU time).

Run: ``.venv/bin/python benchmarks/bench_georef_memory.py [--points N] [--format laz|las]
[--scheduler local|processes] [--workers N]``.
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import laspy
import numpy as np

from _timing import georef_command, max_rss_mib
from kinsync.frames import ecef_to_geodetic, euler_rpy_to_matrix, matrix_to_quaternion
from kinsync.io.mount_file import write_mount
from kinsync.io.trajectory_csv import write_trajectory_csv
from kinsync.mount import Mount
from kinsync.trajectory import Trajectory

RATE_HZ = 200.0
DURATION_S = 600.0
ORIGIN = (46.8, -71.2, 10.0)
T0_GPS_S = 1.3e9
MOUNT = Mount(lever_arm_body_m=(0.8, -0.3, -1.2), boresight_rpy_deg=(0.4, -0.7, 91.0))
WRITE_CHUNK = 1_000_000


def write_trajectory(folder: Path) -> None:
    """A 200 Hz turning vehicle with roll/pitch oscillation, geodetic CSV on GPS time."""
    t = np.arange(0.0, DURATION_S, 1.0 / RATE_HZ)
    w = 10.0 / 50.0
    pos = np.column_stack([50 * np.sin(w * t), 50 * (1 - np.cos(w * t)), -0.5 * np.sin(0.3 * t)])
    R = euler_rpy_to_matrix(0.05 * np.sin(1.1 * t), 0.02 * np.sin(0.7 * t), w * t)
    local = Trajectory(
        t_s=t, q_body_to_ned=matrix_to_quaternion(R), pos_ned_m=pos, origin_lat_lon_h=ORIGIN
    )
    llh = ecef_to_geodetic(local.interpolate(t).pos_ecef_m())
    geo = Trajectory(t_s=t + T0_GPS_S, q_body_to_ned=local.q_body_to_ned, lat_lon_h=llh)
    write_trajectory_csv(geo, folder / "traj.csv")
    write_mount(MOUNT, folder / "mount.toml")


def write_scan(path: Path, n_points: int) -> None:
    """Scanner-frame points on a 20 m ring, adjusted GPS time, written one chunk at a time."""
    rng = np.random.default_rng(2)
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.global_encoding.gps_time_type = laspy.header.GpsTimeType.STANDARD
    header.scales = np.array([1e-4, 1e-4, 1e-4])
    header.offsets = np.zeros(3)
    dt = (DURATION_S - 0.2) / n_points
    with laspy.open(path, mode="w", header=header) as writer:
        for start in range(0, n_points, WRITE_CHUNK):
            n = min(WRITE_CHUNK, n_points - start)
            rec = laspy.ScaleAwarePointRecord.zeros(n, header=header)
            angle = rng.uniform(0, 2 * np.pi, n)
            rec.x = rng.normal(0.0, 0.02, n)
            rec.y = 20 * np.cos(angle)
            rec.z = 20 * np.sin(angle)
            rec.gps_time = T0_GPS_S - 1e9 + 0.1 + dt * np.arange(start, start + n)
            rec.intensity = rng.integers(0, 4000, n).astype(np.uint16)
            writer.write_points(rec)


def _tree_rss_kib(root: int) -> int:
    """Summed VmRSS (KiB) of ``root`` and its descendants, from /proc."""
    total, stack, seen = 0, [root], set()
    while stack:
        pid = stack.pop()
        if pid in seen:
            continue
        seen.add(pid)
        try:
            status = Path(f"/proc/{pid}/status").read_text()
            match = re.search(r"VmRSS:\s+(\d+)", status)
            total += int(match.group(1)) if match else 0
            for task in Path(f"/proc/{pid}/task").iterdir():
                children = (task / "children").read_text().split()
                stack.extend(int(c) for c in children)
        except (FileNotFoundError, ProcessLookupError, PermissionError):
            continue
    return total


def run_georef(folder: Path, points: Path, args: argparse.Namespace) -> dict[str, float]:
    out = folder / f"geo{points.suffix}"
    command = georef_command(
        folder,
        points,
        out,
        "--chunk-points",
        str(args.chunk_points),
        "--scheduler",
        args.scheduler,
        "--json",
    )
    if args.workers:
        command += ["--workers", str(args.workers)]
    peak = [0]
    start = time.perf_counter()
    proc = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    done = threading.Event()

    def sample() -> None:
        while not done.is_set():
            peak[0] = max(peak[0], _tree_rss_kib(proc.pid))
            done.wait(0.05)

    sampler = threading.Thread(target=sample, daemon=True)
    sampler.start()
    stdout, stderr = proc.communicate()
    done.set()
    sampler.join()
    wall = time.perf_counter() - start
    if proc.returncode != 0:
        sys.exit(f"kinsync georef failed ({proc.returncode}):\n{stderr}")
    summary = json.loads(stdout)
    out.unlink()
    return {
        "points": summary["points_out"],
        "maxrss_mib": max_rss_mib(stderr),
        "tree_peak_mib": peak[0] / 1024,
        "wall_s": wall,
        "points_per_s": summary["points_per_s"],
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--points", type=int, default=20_000_000)
    parser.add_argument("--chunk-points", type=int, default=1_000_000)
    parser.add_argument("--format", choices=("laz", "las"), default="laz")
    parser.add_argument("--scheduler", default="local")
    parser.add_argument("--workers", type=int, default=0)
    parser.add_argument("--dir", type=Path, default=None, help="Folder for the files.")
    args = parser.parse_args()
    base = args.dir or Path(tempfile.gettempdir())
    need = args.points * (30 if args.format == "las" else 12) * 2
    free = shutil.disk_usage(base).free
    if free < 2 * need:
        sys.exit(f"{base}: {free / 1e9:.1f} GB free, about {2 * need / 1e9:.1f} GB needed")
    with tempfile.TemporaryDirectory(dir=base) as tmp:
        folder = Path(tmp)
        write_trajectory(folder)
        points = folder / f"scan.{args.format}"
        t0 = time.perf_counter()
        write_scan(points, args.points)
        print(
            f"wrote {args.points:,} points to {points.name} "
            f"({points.stat().st_size / 1e6:.0f} MB) in {time.perf_counter() - t0:.0f} s"
        )
        r = run_georef(folder, points, args)
    workers = f", {args.workers} worker(s)" if args.workers else ""
    print(
        f"kinsync georef {args.format.upper()} -> {args.format.upper()}, "
        f"{args.chunk_points:,}-point chunks, --scheduler {args.scheduler}{workers}:"
    )
    print(f"  points written                     {r['points']:,.0f}")
    print(f"  max RSS (time -v, one process)     {r['maxrss_mib']:8.0f} MiB")
    print(f"  peak RSS, whole process tree       {r['tree_peak_mib']:8.0f} MiB (target < 954 MiB)")
    print(f"  wall time                          {r['wall_s']:8.1f} s")
    print(f"  throughput (its own clock)         {r['points_per_s'] / 1e6:8.2f} Mpts/s")


if __name__ == "__main__":
    main()
