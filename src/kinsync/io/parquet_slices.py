"""Planned slices of a Parquet point table read back, a large row group piece by piece.

`kinsync.io.points.plan_table_slices` cuts a row group larger than ``chunk_points``
into pieces of ``chunk_points`` rows (`kinsync.io.points.TableSlice` ``skip_rows``).
Parquet cannot start decoding in the middle of a row group: a piece read on its own
decodes every row before it, so reading the k-th piece costs k pieces and a row group
of N rows read in pieces of C rows cost N**2 / (2 C) rows decoded (500 000 rows in
pieces of 1 000: 10 s of a 13 s run).

Each thread therefore keeps a cursor: the batch reader of the row group it last read a
piece of (``ParquetFile.iter_batches``), left where that piece ended. The next piece of
the same group, at or after that row, carries on from there; any other piece starts a
new cursor. In-order reads (the serial run; a pool worker, given chunks in order,
skipping the rows of the pieces other workers read) decode each row once. The cursor
holds at most one batch of `BATCH_ROWS` rows ahead of the piece it gave, and is dropped
when a piece ends its row group.

A piece is handed on as the table the earlier reader gave, cut into the same record
batches (``min(rows, 65536)`` rows, counted from the row group's first row): a Parquet
output can depend on how the carried columns are cut.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.parquet as pq

__all__ = ["BATCH_ROWS", "forget_cursor", "read_row_group_piece", "read_row_groups"]

BATCH_ROWS = 1 << 16
"""Rows per decoded batch (and the most rows a cursor holds beyond its piece)."""


@dataclass
class _Cursor:
    """A row group's batch reader, positioned at row group row ``start``."""

    key: tuple[Any, ...]
    group_rows: int
    batches: Iterator[Any]
    start: int = 0  # row group row of pending's first row (or of the next batch)
    pending: Any = None  # the rest of the last batch read, not yet handed on


_LOCAL = threading.local()


def _key(path: Path, group: int, columns: Sequence[str] | None) -> tuple[Any, ...]:
    """The file (as it is now: a rewritten file is another file), group and columns."""
    st = path.stat()
    cols = None if columns is None else tuple(columns)
    return (str(path), st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns, group, cols)


def forget_cursor() -> None:
    """Drop this thread's cursor (its open file and decoded batch)."""
    _LOCAL.cursor = None


def _cursor(
    path: Path, group: int, skip: int, columns: Sequence[str] | None, batch_rows: int
) -> _Cursor:
    key = _key(path, group, columns)
    cur: _Cursor | None = getattr(_LOCAL, "cursor", None)
    if cur is not None and cur.key == key and cur.start <= skip:
        return cur
    forget_cursor()  # its batch freed before the new reader decodes one
    pf = pq.ParquetFile(path)
    batches = pf.iter_batches(
        batch_size=batch_rows, row_groups=[group], columns=None if columns is None else columns
    )
    cur = _Cursor(key, int(pf.metadata.row_group(group).num_rows), iter(batches))
    _LOCAL.cursor = cur
    return cur


def _pieces(cur: _Cursor, skip: int, n_rows: int) -> list[Any]:
    """Record batches of rows ``[skip, skip + n_rows)`` of the cursor's row group."""
    end = skip + n_rows
    parts: list[Any] = []
    while cur.start < end:
        if cur.pending is None:
            batch = next(cur.batches, None)
            if batch is None:  # the group ends early: the file changed (the caller says)
                break
            cur.pending = batch
        batch = cur.pending
        lo, hi = max(skip - cur.start, 0), min(end - cur.start, batch.num_rows)
        if hi > lo:
            parts.append(batch.slice(lo, hi - lo))
        if hi >= batch.num_rows:
            cur.start += batch.num_rows
            cur.pending = None
        else:
            cur.start += hi
            cur.pending = batch.slice(hi)
    return parts


def _as_read_before(table: Any, skip: int, n_rows: int) -> Any:
    """``table`` (rows ``skip..`` of a row group) in the batches the earlier reader gave.

    It read the group in batches of ``min(n_rows, 65536)`` rows from its first row and
    kept the part of each within the piece.
    """
    size = min(n_rows, 1 << 16)
    out: list[Any] = []
    lo, end = skip, skip + table.num_rows
    while lo < end:
        hi = min((lo // size + 1) * size, end)
        part = table.slice(lo - skip, hi - lo)
        if any(c.num_chunks > 1 for c in part.columns):
            part = part.combine_chunks()
        out.extend(b for b in part.to_batches() if b.num_rows)
        lo = hi
    return pa.Table.from_batches(out, schema=table.schema)


def read_row_group_piece(
    path: Path,
    group: int,
    skip: int,
    n_rows: int,
    schema: Any,
    columns: Sequence[str] | None = None,
) -> Any:
    """Rows ``[skip, skip + n_rows)`` of row group ``group``, carrying on this thread's cursor.

    Parameters
    ----------
    path : Path
        The Parquet file.
    group : int
        Row group index.
    skip : int
        Rows of the group before the piece, >= 0.
    n_rows : int
        Rows of the piece, >= 1.
    schema : pyarrow.Schema
        The table's schema for the columns read (kept when no row is read).
    columns : sequence of str, optional
        Columns to read (the file's names); all when None.

    Returns
    -------
    pyarrow.Table
        The piece: ``n_rows`` rows, fewer when the group has fewer (a changed file).

    Raises
    ------
    pyarrow.ArrowException, OSError
        An unreadable file or damaged data (the cursor is dropped).
    """
    end = skip + n_rows
    try:
        cur = _cursor(path, group, skip, columns, min(n_rows, BATCH_ROWS))
        parts = _pieces(cur, skip, n_rows)
    except BaseException:
        forget_cursor()
        raise
    if end >= cur.group_rows:
        forget_cursor()  # the group is done: its file and batch let go
    table = pa.Table.from_batches(parts, schema=schema)
    return _as_read_before(table, skip, n_rows) if table.num_rows else table


def read_row_groups(pf: Any, groups: Sequence[int], columns: Sequence[str] | None = None) -> Any:
    """Whole row groups ``groups`` of the ``ParquetFile`` ``pf`` (all or only ``columns``).

    Raises
    ------
    pyarrow.ArrowException, OSError
        An unreadable file or damaged data.
    """
    cols = None if columns is None else list(columns)
    if len(groups) > 1:
        return pf.read_row_groups(list(groups), columns=cols)
    return pf.read_row_group(groups[0], columns=cols)
