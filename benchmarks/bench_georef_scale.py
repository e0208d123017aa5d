"""Scale-out of ``kinsync georef``: throughput with 1, 2, 4, ... process-pool and Dask workers.

Writes a multi-million-point scan (LAZ, or a CSV/Parquet table with ``--input``) and
georeferences it to geographic coordinates (EPSG:4979, so the workers do the kernel and
the CRS transform) with the serial path (its blocks in one thread per CPU, and in one
thread as a baseline), with ``scheduler="processes"`` and with a
dask.distributed ``LocalCluster`` (one thread per worker process, the cluster started
before timing, as a running cluster is used) for each worker count the machine has;
prints points/s and the ratio to 1 worker of the same kind. The workers
read their own chunks (LAZ by seek and decompression, CSV by byte range, Parquet by row
group) and send back the records with their georeferenced integers; the main process
only writes (for LAZ it compresses), so that writing is the ceiling.

Each configuration runs ``--repeat`` times and the best time is kept; on a shared
machine the figures are still noisy.

Usage: ``python benchmarks/bench_georef_scale.py [--points N] [--chunk-points N]
[--input laz|csv|parquet] [--repeat N] [--workers 1,2,4,...] [--schedulers processes,dask]``
"""

from __future__ import annotations

import argparse
import importlib
import logging
import math
import os
import sys
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import laspy
import numpy as np

from kinsync.frames import wrap_angle_rad
from kinsync.io.points import TableChunkWriter
from kinsync.io.trajectory_csv import write_trajectory_csv
from kinsync.mount import Mount
from kinsync.pipelines import schedulers
from kinsync.pipelines.georef import georeference_file
from kinsync.trajectory import Trajectory

T0 = 1.3e9
distributed: Any = importlib.import_module("dask.distributed")  # untyped
MOUNT = Mount(lever_arm_body_m=(0.5, 0.1, -1.0), boresight_rpy_deg=(0.5, -0.3, 90.0))


def write_inputs(folder: Path, n_points: int, kind: str) -> Path:
    folder.mkdir(exist_ok=True)
    t = T0 + np.arange(0.0, 100.0, 0.005)
    s = t - T0
    llh = np.column_stack([46.8 + 1e-5 * s, -71.2 + 2e-5 * s, 10.0 + 0.1 * s])
    traj = Trajectory.from_euler(
        t, 0.02 * np.sin(s), 0.01 * np.cos(0.5 * s), wrap_angle_rad(0.3 + 0.05 * s), lat_lon_h=llh
    )
    write_trajectory_csv(traj, folder / "traj.csv")
    rng = np.random.default_rng(1)
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales = np.array([1e-4, 1e-4, 1e-4])
    header.offsets = np.zeros(3)
    header.global_encoding.gps_time_type = laspy.header.GpsTimeType.STANDARD
    las = laspy.LasData(header)
    las.x = rng.uniform(-1, 1, n_points)
    las.y = rng.uniform(-20, 20, n_points)
    las.z = rng.uniform(-5, 5, n_points)
    las.gps_time = T0 - 1e9 + np.linspace(0.1, 99.9, n_points)  # adjusted GPS time
    las.intensity = rng.integers(0, 1000, n_points).astype(np.uint16)
    if kind == "laz":
        las.write(folder / "scan.laz")
        return folder / "scan.laz"
    path = folder / f"scan.{kind}"
    with TableChunkWriter(path) as writer:
        for i in range(0, n_points, 500_000):
            part = slice(i, i + 500_000)
            writer.write(
                {
                    "t_s": np.asarray(las.gps_time[part]) + 1e9,
                    "x_m": np.asarray(las.x[part]),
                    "y_m": np.asarray(las.y[part]),
                    "z_m": np.asarray(las.z[part]),
                    "intensity": np.asarray(las.intensity[part]),
                }
            )
    return path


@contextmanager
def one_block_thread() -> Iterator[None]:
    """The serial run as it was before its block threads: one thread georeferences."""
    name = "usable_cpus"  # the serial runner's thread count (not exported)
    before = getattr(schedulers, name)
    setattr(schedulers, name, lambda: 1)
    try:
        yield
    finally:
        setattr(schedulers, name, before)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--points", type=int, default=4_000_000)
    parser.add_argument("--chunk-points", type=int, default=500_000)
    parser.add_argument("--input", choices=("laz", "csv", "parquet"), default="laz")
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument(
        "--workers", help="worker counts, comma-separated (default 1, 2, 4, ... up to the cores)"
    )
    parser.add_argument(
        "--schedulers", default="processes,dask", help="which of processes,dask to run"
    )
    args = parser.parse_args()
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    cores = cores or 1
    counts = (
        [int(w) for w in args.workers.split(",")]
        if args.workers
        else [w for w in (1, 2, 4, 8, 16, 32, 64) if w <= max(cores, 2)]
    )
    kinds = args.schedulers.split(",")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        scan = write_inputs(folder, args.points, args.input)
        out = folder / ("out.laz" if args.input == "laz" else f"out.{args.input}")
        rows: list[tuple[str, float]] = []

        def run(label: str, scheduler: str, workers: int | None, path: Path = scan) -> float:
            best = math.inf
            for _ in range(args.repeat):
                start = time.perf_counter()
                georeference_file(
                    path,
                    folder / "traj.csv",
                    MOUNT,
                    out,
                    crs="EPSG:4979",
                    chunk_points=args.chunk_points,
                    scheduler=scheduler,
                    workers=workers,
                )
                best = min(best, time.perf_counter() - start)
            if path == scan:
                rows.append((label, args.points / best))
                print(f"  {label}: {args.points / best / 1e6:.2f} Mpts/s", file=sys.stderr)
            return best

        run("local (serial)", "local", None)  # also warms the JIT cache
        rows.clear()
        run("local (serial)", "local", None)
        with one_block_thread():
            run("local, 1 block thread", "local", None)
        for w in counts if "processes" in kinds else ():
            run(f"processes, {w} worker(s)", "processes", w)
        for w in counts if "dask" in kinds else ():  # a running cluster: start-up not counted
            with distributed.LocalCluster(
                n_workers=w,
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
                silence_logs=logging.CRITICAL,  # a worker's heartbeat at close is no result
            ) as cluster:
                run(f"dask, {w} worker(s)", str(cluster.scheduler_address), w)
        tiny = write_inputs(folder / "tiny", 1000, args.input)
        startup = {w: run("", "processes", w, tiny) - run("", "local", None, tiny) for w in (1, 2)}
        # (a 1000-point file is one chunk: one worker starts whatever the count)
    base = {"local (serial)": rows[0][1], "local": rows[0][1]} | {
        kind: next(rate for label, rate in rows if label.startswith(f"{kind}, {counts[0]} "))
        for kind in kinds
    }
    kind = args.input.upper()
    print(
        f"georef {kind} -> {kind} (EPSG:4979), {args.points:,} points, "
        f"{args.chunk_points:,}-point chunks, {cores} core(s), best of {args.repeat}"
    )
    print(f"{'scheduler':<28}{'Mpts/s':>10}{f'vs {counts[0]} worker(s)':>18}{'vs serial':>11}")
    for label, rate in rows:
        one = base[label.split(",")[0]]
        serial = base["local (serial)"]
        print(f"{label:<28}{rate / 1e6:>10.2f}{rate / one:>17.2f}x{rate / serial:>10.2f}x")
    print(
        "process-pool start-up (a 1000-point file, pool minus serial): "
        + ", ".join(f"{w} worker(s) {t:.1f} s" for w, t in startup.items())
    )


if __name__ == "__main__":
    main()
