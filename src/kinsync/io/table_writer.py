"""Point tables in CSV or Parquet, written in chunks, atomically.

Writing (`TableChunkWriter`) goes through a temporary file renamed on success. CSV is
written by `kinsync.io.csv_text`: numbers bare, floats in the shortest form that reads
back to the same value (with ``.0`` added to integral values so that ``1.0`` reads back
as a float: every value comes back exactly), text quoted only when it holds a comma, a
quote or a line break. `csv_text_columns` does the float formatting ahead, so that
worker processes can take it off the writing process. Reading is `kinsync.io.points`.
"""

from __future__ import annotations

from collections.abc import Mapping
from contextlib import ExitStack
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from kinsync.errors import InputError
from kinsync.io.atomic import atomic_path, finish_then_publish
from kinsync.io.csv_text import csv_header_bytes, csv_rows_bytes, float_text

__all__ = ["PARQUET_ROW_GROUP_ROWS", "TableChunkWriter", "csv_text_columns", "table_suffix"]

_SUFFIXES = (".csv", ".parquet")

PARQUET_ROW_GROUP_ROWS = 1 << 20
"""Rows of each row group of a Parquet table (the last one shorter), pyarrow's default.

Whatever the chunks written, so that a file does not depend on how its rows were cut
(``--chunk-points``): the same rows give the same bytes."""


def table_suffix(path: Path) -> str:
    """``.csv`` or ``.parquet`` (lower case) of a table's path.

    Raises
    ------
    InputError
        Any other suffix.
    """
    suffix = path.suffix.lower()
    if suffix not in _SUFFIXES:
        msg = f"{path}: unknown table type {path.suffix!r}; use .csv or .parquet"
        raise InputError(msg)
    return suffix


def _arrow_column(name: str, values: Any) -> Any:
    if isinstance(values, pa.Array | pa.ChunkedArray):
        return values
    arr = np.asarray(values)
    if arr.ndim != 1:
        msg = f"column {name!r}: expected a 1-D array, got shape {arr.shape}"
        raise InputError(msg)
    try:
        return pa.array(arr)
    except (pa.ArrowException, TypeError, ValueError) as err:
        msg = f"column {name!r}: cannot store dtype {arr.dtype} in a table ({err})"
        raise InputError(msg) from err


def _is_float(values: Any) -> bool:
    if isinstance(values, pa.Array | pa.ChunkedArray):
        return bool(pa.types.is_floating(values.type))
    return bool(np.asarray(values).dtype.kind == "f")


def csv_text_columns(columns: Mapping[str, Any]) -> dict[str, Any]:
    """Float columns turned into the text a ``.csv`` `TableChunkWriter` writes for them.

    Lets another process do that formatting, the costly part of writing a CSV: the
    writer takes the text columns (pyarrow string arrays) as they are, and the file is
    byte for byte the one it writes from the floats. Other columns are unchanged.

    Parameters
    ----------
    columns : mapping of str to ndarray or pyarrow array, each of shape (M,)
        A chunk as `TableChunkWriter.write` takes it.

    Returns
    -------
    dict of str to ndarray or pyarrow.Array
        The same columns, in order, floats as text.
    """
    return {
        name: float_text(
            values if isinstance(values, pa.Array | pa.ChunkedArray) else pa.array(values)
        )
        if _is_float(values)
        else values
        for name, values in columns.items()
    }


def _column_length(values: Any) -> int:
    if isinstance(values, pa.Array | pa.ChunkedArray):
        return len(values)
    return int(np.shape(values)[0]) if np.ndim(values) else -1


class TableChunkWriter:
    """Write a CSV or Parquet table chunk by chunk, atomically.

    Use as a context manager. The file is written under a temporary name beside
    ``path`` and renamed onto ``path`` only when the ``with`` block ends without an
    exception; otherwise nothing is left behind.

    Parameters
    ----------
    path : Path
        Output file; ``.csv`` or ``.parquet`` by suffix.
    field_metadata : mapping of str to mapping of str to str, optional
        Parquet only: key-value metadata of columns by name (e.g. ``{"Z": {"unit":
        "metre"}}``); columns not written are ignored. A CSV has nowhere to keep it.
    metadata : mapping of str to str, optional
        Parquet only: key-value metadata of the table (the schema).

    Notes
    -----
    The first chunk fixes the schema (column names, order and types); later chunks
    must have the same columns and are cast to those types. A table with no chunk
    written is an empty file (CSV) or an empty Parquet table. A Parquet table's rows
    are held until they fill a row group of `PARQUET_ROW_GROUP_ROWS` (the last is
    shorter): its bytes do not depend on the chunks, and at most a row group and a
    chunk are held.
    """

    def __init__(
        self,
        path: Path,
        field_metadata: Mapping[str, Mapping[str, str]] | None = None,
        metadata: Mapping[str, str] | None = None,
    ) -> None:
        self.path = Path(path)
        self._suffix = table_suffix(self.path)
        self._field_metadata = dict(field_metadata or {})
        self._metadata = dict(metadata or {})
        self._stack: ExitStack | None = None
        self._tmp: Path | None = None
        self._writer: Any = None
        self._schema: Any = None
        self._held: list[Any] = []  # Parquet: tables not yet in a row group
        self._held_rows = 0
        self.rows_written = 0

    def __enter__(self) -> TableChunkWriter:
        stack = ExitStack()
        self._tmp = stack.enter_context(atomic_path(self.path))
        self._stack = stack
        return self

    def write(self, columns: Mapping[str, Any]) -> None:
        """Append one chunk: a mapping of column name to 1-D array, all one length.

        Arrays are numpy arrays, or pyarrow arrays taken as they are (e.g. the text
        columns of `csv_text_columns`).
        """
        if self._stack is None or self._tmp is None:
            msg = f"{self.path}: TableChunkWriter.write called outside its 'with' block"
            raise InputError(msg)
        lengths = {name: _column_length(v) for name, v in columns.items()}
        if len(set(lengths.values())) > 1:
            msg = f"{self.path}: columns of one chunk differ in length: {lengths}"
            raise InputError(msg)
        if self._schema is None:
            table = pa.table({n: _arrow_column(n, v) for n, v in columns.items()})
            self._schema = self._with_metadata(table.schema)
            if self._schema is not table.schema:  # the same columns, with their metadata
                table = pa.Table.from_arrays(table.columns, schema=self._schema)
            self._open(self._schema)
        else:
            names = list(self._schema.names)
            if list(columns) != names:
                msg = (
                    f"{self.path}: chunk columns {list(columns)} differ from the first "
                    f"chunk's {names}; every chunk needs the same columns in the same order"
                )
                raise InputError(msg)
            try:
                table = pa.table({n: _arrow_column(n, v) for n, v in columns.items()}).cast(
                    self._schema
                )
            except (pa.ArrowException, TypeError, ValueError) as err:
                msg = f"{self.path}: chunk does not fit the first chunk's column types ({err})"
                raise InputError(msg) from err
        self._write_table(table)
        self.rows_written += int(table.num_rows)

    def _with_metadata(self, schema: Any) -> Any:
        if self._suffix != ".parquet" or not (self._field_metadata or self._metadata):
            return schema
        fields = [
            f.with_metadata(dict(self._field_metadata[f.name]))
            if f.name in self._field_metadata
            else f
            for f in schema
        ]
        return pa.schema(fields, metadata=self._metadata or None)

    def _open(self, schema: Any) -> None:
        assert self._tmp is not None
        if self._suffix == ".parquet":
            # Dictionary encoding only where values repeat (integers, text): on
            # coordinates and times, each value distinct, it only filled a dictionary
            # page to throw it away, halving the writer's speed (the main process's
            # ceiling when pool or Dask workers georeference), and the file was 8 %
            # larger (4 M georeferenced points: 113.5 MB against 104.9 MB).
            repeat = [f.name for f in schema if not pa.types.is_floating(f.type)]
            self._writer = pq.ParquetWriter(self._tmp, schema, use_dictionary=repeat)
        else:
            self._writer = self._tmp.open("wb")
            self._writer.write(csv_header_bytes(schema.names))

    def _write_table(self, table: Any) -> None:
        if self._suffix != ".parquet":
            self._writer.write(csv_rows_bytes(table))
            return
        if table.num_rows:
            self._held.append(table)
            self._held_rows += int(table.num_rows)
        while self._held_rows >= PARQUET_ROW_GROUP_ROWS:
            self._write_row_group(PARQUET_ROW_GROUP_ROWS)

    def _write_row_group(self, rows: int) -> None:
        """Write the first ``rows`` rows held as one row group.

        Its columns are made contiguous first: pyarrow's bytes can depend on how the
        arrays it is given are cut, and these were cut by the chunks.
        """
        held = pa.concat_tables(self._held)
        group = held.slice(0, rows).combine_chunks()
        self._writer.write_table(group, row_group_size=rows)
        rest = held.slice(rows)
        self._held = [rest] if rest.num_rows else []
        self._held_rows = int(rest.num_rows)

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        stack, self._stack = self._stack, None
        if stack is None:
            return

        def finish() -> None:
            if self._writer is not None:
                if self._held_rows and exc_type is None:
                    self._write_row_group(self._held_rows)
                self._writer.close()
            elif exc_type is None and self._suffix == ".parquet":
                assert self._tmp is not None
                pq.write_table(pa.table({}), self._tmp)

        finish_then_publish(stack, finish, exc_type, exc, tb)
