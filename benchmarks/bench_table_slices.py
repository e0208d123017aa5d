"""Reading a point table's planned slices, as ``kinsync georef`` does, by chunk size.

Parquet: a file of ``--rows`` rows in one row group, read slice by slice
(`kinsync.io.points.read_table_slice`, in order, as the serial run reads them) with
chunks of 1 000, 5 000, 50 000 rows and the whole group. Prints the time, the rows
pyarrow decoded (``ParquetFile.iter_batches`` and ``read_row_group`` counted) and the
ratio to the whole group read at once, the baseline measured in the same run. Each row
should be decoded once whatever the chunk size (before: chunk k decoded k chunks'
rows; 500 000 rows in 1 000-row chunks decoded 125 million rows, 9.1 s against 0.035 s
for the whole group, 5 000-row chunks 25 million, 1.0 s).

Run: ``.venv/bin/python benchmarks/bench_table_slices.py [--rows N]``.
"""

from __future__ import annotations

import argparse
import tempfile
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from _timing import best_of
from kinsync.io.points import plan_table_slices, read_table_slice

REQUIRED = ("t_s", "x_m", "y_m", "z_m")
DECODED = [0]


def _counting() -> None:
    """Count the rows pyarrow decodes for the slices (patched into ``ParquetFile``)."""
    iter_batches = pq.ParquetFile.iter_batches
    read_row_group = pq.ParquetFile.read_row_group

    def counted_batches(self: Any, *args: Any, **kwargs: Any) -> Any:
        for batch in iter_batches(self, *args, **kwargs):
            DECODED[0] += batch.num_rows
            yield batch

    def counted_group(self: Any, *args: Any, **kwargs: Any) -> Any:
        table = read_row_group(self, *args, **kwargs)
        DECODED[0] += table.num_rows
        return table

    pq.ParquetFile.iter_batches = counted_batches
    pq.ParquetFile.read_row_group = counted_group


def write_table(path: Path, n: int) -> None:
    rng = np.random.default_rng(1)
    t = 1.4e9 + np.sort(rng.uniform(0, 100, n))
    table = pa.table(
        {
            "t_s": t,
            "x_m": rng.normal(0, 10, n),
            "y_m": rng.normal(0, 10, n),
            "z_m": rng.normal(0, 1, n),
            "intensity": rng.integers(0, 4000, n).astype(np.uint16),
        }
    )
    pq.write_table(table, path, row_group_size=n)


def read_all(path: Path, chunk: int) -> int:
    layout, slices = plan_table_slices(path, chunk, REQUIRED)
    return sum(len(read_table_slice(layout, s, arrow=True)["t_s"]) for s in slices)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rows", type=int, default=500_000)
    args = parser.parse_args()
    n = args.rows
    _counting()
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "one_group.parquet"
        write_table(path, n)
        base = best_of(lambda: read_all(path, n))
        print(f"Parquet, {n:,} rows in one row group, read slice by slice (serial order)")
        print(f"{'chunk':>10} {'time s':>8} {'ratio':>6} {'rows decoded':>14} {'per row':>8}")
        for chunk in (1_000, 5_000, 50_000, n):
            DECODED[0] = 0
            assert read_all(path, chunk) == n
            decoded = DECODED[0]
            t = base if chunk == n else best_of(partial(read_all, path, chunk))
            print(f"{chunk:>10,} {t:8.3f} {t / base:6.2f} {decoded:>14,} {decoded / n:8.2f}")


if __name__ == "__main__":
    main()
