"""Peak memory and time of streaming a CSV point table, as ``kinsync sync apply`` reads it.

Writes a scan CSV of ``--rows`` rows (``profile,angle_rad,range_m,intensity``) and a
wide copy with ``--extra`` more integer columns, then reads each in a fresh process with
`kinsync.io.points.iter_table_chunks` (extra columns as text, pyarrow arrays: the
reader of ``sync apply``; ``profile_scan``, ``cloud`` and the calibration reader share
it) at the default 1 000 000-row chunks and, as the baseline measured in the same run,
at 100 000-row chunks. Prints each run's maximum RSS and time, and the ratios of the
default to the baseline.

Before the fix pyarrow's block was sized to the chunk (16 bytes x columns x rows: 64 MB
for 4 columns, 480 MB for 30) and its reader decoded blocks ahead: the default chunk
peaked at 2-3 times the baseline (5.5 M rows x 30 columns: 3.11 GB against 1.42 GB).

Run: ``.venv/bin/python benchmarks/bench_csv_stream_memory.py [--rows N] [--extra K]``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.csv as pa_csv

READ = """
import json, resource, sys, time
from kinsync.io.points import iter_table_chunks
t0 = time.perf_counter()
rows = 0
for chunk in iter_table_chunks(
    sys.argv[1], int(sys.argv[2]), ("profile", "angle_rad", "range_m"),
    extra_as_text=True, arrow=True,
):
    rows += len(chunk["profile"])
wall = time.perf_counter() - t0
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print(json.dumps({"rows": rows, "wall_s": wall, "maxrss_mib": peak}))
"""


def write_scan(path: Path, n: int, extra: int) -> None:
    rng = np.random.default_rng(7)
    per_profile = 1_000
    columns = {
        "profile": np.arange(n) // per_profile,
        "angle_rad": -1.55 + 3.1 * (np.arange(n) % per_profile) / per_profile,
        "range_m": rng.uniform(2.0, 60.0, n),
        "intensity": rng.uniform(0.0, 1.0, n),
        **{f"e{i}": pa.array(np.full(n, 100 + i, dtype=np.int16)) for i in range(extra)},
    }
    pa_csv.write_csv(pa.table(columns), path)


def read(path: Path, chunk: int) -> dict[str, float]:
    proc = subprocess.run(
        [sys.executable, "-c", READ, str(path), str(chunk)],
        capture_output=True,
        text=True,
        check=False,
    )
    if proc.returncode != 0:
        sys.exit(f"reading {path} failed:\n{proc.stderr}")
    result: dict[str, float] = json.loads(proc.stdout)
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rows", type=int, default=5_000_000)
    parser.add_argument("--extra", type=int, default=26)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        for extra in (0, args.extra):
            path = Path(tmp) / f"scan{extra}.csv"
            write_scan(path, args.rows, extra)
            size = path.stat().st_size / 2**20
            print(f"{args.rows:,} rows x {4 + extra} columns ({size:.0f} MiB)")
            default, base = read(path, 1_000_000), read(path, 100_000)
            for name, r in (("1 000 000-row chunks", default), ("100 000 (baseline)", base)):
                print(f"  {name:<22} max RSS {r['maxrss_mib']:7.0f} MiB  {r['wall_s']:6.2f} s")
            rss = default["maxrss_mib"] / base["maxrss_mib"]
            speed = default["wall_s"] / base["wall_s"]
            print(f"  ratio default/baseline: RSS {rss:.2f}, time {speed:.2f}")
            path.unlink()


if __name__ == "__main__":
    main()
