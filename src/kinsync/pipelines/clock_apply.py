"""A clock model's GPS times written beside a CSV's local-time column, streamed in chunks.

`kinsync clock apply` reads the local-time column alone
(`kinsync.io.tables.read_time_column`), checks it against the model's span and applies
the model (`kinsync.clock.ClockModel.apply`); `write_with_gps_time` then streams the
file in chunks, every cell carried as its text, and writes each chunk with the GPS-time
column added, atomically (`kinsync.io.table_writer.TableChunkWriter`). Memory is the
time column and one chunk. The whole file had been kept as Python strings, about 15
times its size: 4 M rows took 59 s and 2.4 GB, and a file over 256 MiB was refused.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pyarrow as pa

from kinsync._typing import FloatArray
from kinsync.errors import InputError
from kinsync.io.points import TableChunkWriter, iter_table_chunks, table_columns

__all__ = ["write_with_gps_time"]


def write_with_gps_time(
    in_path: Path,
    out_path: Path,
    out_column: str,
    t_gps_s: FloatArray,
    *,
    chunk_rows: int = 1_000_000,
    progress: Callable[[int], None] | None = None,
) -> int:
    """Write the CSV ``in_path`` again with the column ``out_column`` added, atomically.

    Every cell is written back as its text (quoted only where it holds a comma, a quote
    or a line break); the new column's floats in their shortest exact form, NaN as
    ``nan``.

    Parameters
    ----------
    in_path : Path
        The CSV whose time column gave ``t_gps_s``.
    out_path : Path
        The ``.csv`` to write.
    out_column : str
        Name of the column added.
    t_gps_s : ndarray, shape (N,)
        One value (s) per data row of ``in_path``, in file order.
    chunk_rows : int
        Rows per chunk.
    progress : callable, optional
        Called with the number of rows written after each chunk.

    Returns
    -------
    int
        Rows written.

    Raises
    ------
    InputError
        The file already has a column ``out_column``, or holds another number of rows
        than ``t_gps_s`` has values (it changed while being read).
    """
    in_path = Path(in_path)
    names = table_columns(in_path)
    if out_column.strip() in [n.strip() for n in names]:
        msg = f"{in_path}: already has a column {out_column!r}; choose another name"
        raise InputError(msg)
    values = np.asarray(t_gps_s, dtype=np.float64)
    done = 0
    with TableChunkWriter(Path(out_path)) as writer:
        for chunk in iter_table_chunks(in_path, chunk_rows, (), extra_as_text=True, arrow=True):
            n = len(next(iter(chunk.values())))
            if done + n > values.size:
                break
            writer.write(dict(chunk) | {out_column: values[done : done + n]})
            done += n
            if progress is not None:
                progress(done)
        if done != values.size:  # the writer then discards its output
            msg = (
                f"{in_path}: holds another number of rows than when its time column was "
                f"read ({values.size:,}): was it changed meanwhile? Run again"
            )
            raise InputError(msg)
        if done == 0:
            writer.write({n: pa.array([], pa.string()) for n in names} | {out_column: values})
    return done
