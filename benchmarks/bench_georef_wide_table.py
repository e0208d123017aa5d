"""Peak memory of ``kinsync georef`` on a wide CSV (many carried columns) to LAZ.

Writes a CSV of ``--points`` scanner-frame points with ``--extra`` integer columns
besides ``t_s,x_m,y_m,z_m`` and the same points without them, then runs the real
command line (fresh processes under ``/usr/bin/time -v``, default chunk size) and prints
the maximum RSS of:

- the wide CSV to LAZ (the LAS output frame needs the first and last point's times:
  the whole first and last chunk used to be read for them, every column as Python
  text objects: 1 M rows x 65 columns peaked at 5 GB);
- the wide CSV to CSV, the baseline measured in the same run (no output frame: the
  chunks alone), and the narrow CSV to LAZ;

with the ratios of the first to each baseline (about 1 when the output frame costs
nothing beyond the chunks).

Run: ``.venv/bin/python benchmarks/bench_georef_wide_table.py [--points N] [--extra K]``.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.csv as pa_csv

from _timing import georef_command, max_rss_mib
from bench_georef_memory import DURATION_S, T0_GPS_S, write_trajectory


def write_points(path: Path, n: int, extra: int) -> None:
    rng = np.random.default_rng(5)
    angle = rng.uniform(0, 2 * np.pi, n)
    columns = {
        "t_s": T0_GPS_S + 0.1 + (DURATION_S - 0.2) / n * np.arange(n),
        "x_m": rng.normal(0.0, 0.02, n),
        "y_m": 20 * np.cos(angle),
        "z_m": 20 * np.sin(angle),
        **{f"e{i}": pa.array(np.full(n, 100 + i, dtype=np.int16)) for i in range(extra)},
    }
    pa_csv.write_csv(pa.table(columns), path)


def run(folder: Path, points: Path, out: Path) -> tuple[float, float]:
    """Max RSS (MiB) and wall time (s) of ``kinsync georef points -> out``."""
    command = georef_command(folder, points, out)
    start = time.perf_counter()
    proc = subprocess.run(command, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - start
    if proc.returncode != 0:
        sys.exit(f"kinsync georef failed ({proc.returncode}):\n{proc.stderr}")
    out.unlink()
    return max_rss_mib(proc.stderr), wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--points", type=int, default=500_000)
    parser.add_argument("--extra", type=int, default=60)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        write_trajectory(folder)
        wide, narrow = folder / "wide.csv", folder / "narrow.csv"
        write_points(wide, args.points, args.extra)
        write_points(narrow, args.points, 0)
        mib = wide.stat().st_size / 2**20
        print(f"{args.points:,} points, {args.extra} extra columns ({mib:.0f} MiB CSV)")
        cases = [
            ("wide CSV -> LAZ", wide, "geo.laz"),
            ("wide CSV -> CSV (baseline)", wide, "geo.csv"),
            ("narrow CSV -> LAZ (baseline)", narrow, "geo.laz"),
        ]
        rss = {}
        for name, points, out in cases:
            rss[name], wall = run(folder, points, folder / out)
            print(f"  {name:<30} max RSS {rss[name]:8.0f} MiB   {wall:6.1f} s")
        first = rss[cases[0][0]]
        print(f"  ratio to wide CSV -> CSV        {first / rss[cases[1][0]]:6.2f}")
        print(f"  ratio to narrow CSV -> LAZ      {first / rss[cases[2][0]]:6.2f}")


if __name__ == "__main__":
    main()
