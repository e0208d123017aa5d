"""Point tables in CSV or Parquet, read and written in chunks of bounded size.

A point table holds one point per row and any number of columns; the georeferencing
pipeline needs some of them (``t_s,x_m,y_m,z_m`` or ``t_s,range_m,angle_rad``) and
carries every other column through unchanged.

Reading (`iter_table_chunks`) streams the file with pyarrow: Parquet by row batches
(``ParquetFile.iter_batches``), CSV with pyarrow's streaming reader. Chunks are dicts of
numpy arrays, one per column in file order, each of at most ``chunk_points`` rows.
Required columns come back as float64 (an empty or non-numeric cell is an error naming
the file, the row and the column); other columns keep their type: Parquet's stored
type, or for CSV the type pyarrow infers from the first block (int64, float64, bool,
string). CSV cannot say float32 from float64: such a column reads back as float64.

Writing (`TableChunkWriter`) goes through a temporary file renamed on success.
Float columns are written to CSV in numpy's shortest round-trip form (always with a
``.`` or exponent, so ``1.0`` reads back as a float and every value exactly).
"""

from __future__ import annotations

import csv
import sys
from collections.abc import Iterator, Mapping, Sequence
from contextlib import ExitStack
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.csv as pa_csv
import pyarrow.parquet as pq

from kinsync.errors import InputError
from kinsync.io.atomic import atomic_path

__all__ = ["TableChunkWriter", "count_table_rows", "iter_table_chunks", "table_columns"]

_SUFFIXES = (".csv", ".parquet")


def _suffix(path: Path) -> str:
    suffix = path.suffix.lower()
    if suffix not in _SUFFIXES:
        msg = f"{path}: unknown table type {path.suffix!r}; use .csv or .parquet"
        raise InputError(msg)
    return suffix


def _check_exists(path: Path) -> None:
    if not path.is_file():
        msg = f"{path}: file not found"
        raise InputError(msg)


def _csv_header(path: Path) -> list[str]:
    try:
        with path.open(newline="", encoding="utf-8") as fh:
            row = next(csv.reader(fh), None)
    except (OSError, UnicodeDecodeError, csv.Error) as err:
        msg = f"{path}: cannot read the header ({err})"
        raise InputError(msg) from err
    if not row or all(not c.strip() for c in row):
        msg = f"{path}: empty file; expected a header line naming the columns"
        raise InputError(msg)
    return [c.strip() for c in row]


def table_columns(path: Path) -> list[str]:
    """Column names of a CSV or Parquet table, in file order.

    Raises
    ------
    InputError
        Missing file, unknown suffix, empty CSV, unreadable Parquet.
    """
    path = Path(path)
    suffix = _suffix(path)
    _check_exists(path)
    if suffix == ".csv":
        return _csv_header(path)
    try:
        return list(pq.ParquetFile(path).schema_arrow.names)
    except (pa.ArrowException, OSError) as err:
        msg = f"{path}: cannot read as Parquet ({err})"
        raise InputError(msg) from err


def _check_required(path: Path, names: Sequence[str], required: Sequence[str]) -> None:
    missing = [c for c in required if c not in names]
    if missing:
        msg = (
            f"{path}: missing column(s) {missing}; the file has columns {list(names)}; "
            f"rename the columns or give a table with {list(required)}"
        )
        raise InputError(msg)
    dupes = sorted({c for c in names if list(names).count(c) > 1})
    if dupes:
        msg = f"{path}: duplicated column name(s) {dupes}; give each column a unique name"
        raise InputError(msg)


def _locate_bad_csv_cell(path: Path, required: Sequence[str]) -> InputError | None:
    """Scan a CSV for the first empty or non-numeric cell of a required column."""
    with path.open(newline="", encoding="utf-8") as fh:
        reader = csv.reader(fh)
        header = [c.strip() for c in next(reader)]
        cols = [(name, header.index(name)) for name in required]
        row = -1
        for cells in reader:
            if not cells or all(not c.strip() for c in cells):
                continue
            row += 1
            for name, i in cols:
                cell = cells[i].strip() if i < len(cells) else ""
                try:
                    float(cell)
                except ValueError:
                    what = "empty cell" if not cell else f"{cell!r} is not a number"
                    msg = (
                        f"{path}: line {reader.line_num} (data row {row}), column {name!r}: "
                        f"{what}; fix or remove the row"
                    )
                    return InputError(msg)
    return None


def _rebatch(batches: Iterator[Any], chunk_points: int) -> Iterator[Any]:
    """Regroup record batches into tables of exactly ``chunk_points`` rows (last fewer)."""
    pending: list[Any] = []
    n_pending = 0
    for batch in batches:
        if batch.num_rows == 0:
            continue
        pending.append(batch)
        n_pending += batch.num_rows
        while n_pending >= chunk_points:
            table = pa.Table.from_batches(pending)
            yield table.slice(0, chunk_points)
            rest = table.slice(chunk_points)
            pending = rest.to_batches()
            n_pending = rest.num_rows
    if n_pending:
        yield pa.Table.from_batches(pending)


def _chunk_to_numpy(
    path: Path, table: Any, required: Sequence[str], first_row: int
) -> dict[str, np.ndarray[Any, Any]]:
    out: dict[str, np.ndarray[Any, Any]] = {}
    for name in table.column_names:
        col = table.column(name)
        if name in required:
            if col.null_count:
                idx = int(np.flatnonzero(col.is_null().to_numpy(zero_copy_only=False))[0])
                msg = (
                    f"{path}: data row {first_row + idx}, column {name!r}: empty cell; "
                    "every point needs a number there: fix or remove the row"
                )
                raise InputError(msg)
            if not (pa.types.is_floating(col.type) or pa.types.is_integer(col.type)):
                values = col.to_numpy(zero_copy_only=False)
                for i, v in enumerate(values):
                    try:
                        float(v)
                    except (TypeError, ValueError):
                        msg = (
                            f"{path}: data row {first_row + i}, column {name!r}: {v!r} is "
                            f"not a number (column type {col.type}); store numbers there"
                        )
                        raise InputError(msg) from None
                out[name] = np.asarray(values.astype(np.float64))
                continue
            out[name] = np.asarray(col.to_numpy(zero_copy_only=False), dtype=np.float64)
        else:
            out[name] = col.to_numpy(zero_copy_only=False)
    return out


def _csv_batches(path: Path, required: Sequence[str], block_bytes: int) -> Iterator[Any]:
    convert = pa_csv.ConvertOptions(
        column_types=dict.fromkeys(required, pa.float64()),
        null_values=[""],
        strings_can_be_null=False,
    )
    read = pa_csv.ReadOptions(block_size=block_bytes)
    try:
        reader = pa_csv.open_csv(path, read_options=read, convert_options=convert)
        yield from reader
    except pa.ArrowInvalid as err:
        if "conversion error" in str(err):
            bad = _locate_bad_csv_cell(path, required)
            if bad is not None:
                raise bad from err
            msg = (
                f"{path}: {err}; a column's values change type after the first rows "
                "(types are inferred from the first block): make the column uniform"
            )
            raise InputError(msg) from err
        msg = f"{path}: cannot read as CSV ({err})"
        raise InputError(msg) from err
    except (pa.ArrowException, OSError) as err:
        msg = f"{path}: cannot read as CSV ({err})"
        raise InputError(msg) from err


def iter_table_chunks(
    path: Path, chunk_points: int, required: Sequence[str]
) -> Iterator[dict[str, np.ndarray[Any, Any]]]:
    """Stream a CSV or Parquet point table in chunks of at most ``chunk_points`` rows.

    Parameters
    ----------
    path : Path
        ``.csv`` (header line, comma-separated) or ``.parquet``.
    chunk_points : int
        Rows per chunk (every chunk but the last has exactly this many), >= 1.
    required : sequence of str
        Columns that must be present and numeric; returned as float64.

    Yields
    ------
    dict of str to ndarray, each of shape (M,)
        Every column of the file, in file order, with its type (see the module
        docstring); M <= ``chunk_points``.

    Raises
    ------
    InputError
        Missing file, unknown suffix, missing required columns (naming the columns the
        file has), an empty or non-numeric cell in a required column (naming the row
        and column), an unreadable file.
    """
    path = Path(path)
    if chunk_points < 1:
        msg = f"{path}: chunk_points must be >= 1, got {chunk_points}"
        raise InputError(msg)
    suffix = _suffix(path)
    names = table_columns(path)
    _check_required(path, names, required)
    if suffix == ".csv":
        block = int(min(max(chunk_points * 16 * max(len(names), 1), 1 << 20), 1 << 30))
        batches: Iterator[Any] = _csv_batches(path, required, block)
    else:
        try:
            pf = pq.ParquetFile(path)
        except (pa.ArrowException, OSError) as err:
            msg = f"{path}: cannot read as Parquet ({err})"
            raise InputError(msg) from err
        batches = pf.iter_batches(batch_size=chunk_points)
    first_row = 0
    for table in _rebatch(batches, chunk_points):
        yield _chunk_to_numpy(path, table, required, first_row)
        first_row += table.num_rows


def count_table_rows(path: Path) -> int:
    """Number of data rows of a CSV (header excluded, blank lines skipped) or Parquet table.

    Parquet reads the footer only; CSV is parsed (one column, as text).

    Raises
    ------
    InputError
        Missing file, unknown suffix, unreadable file.
    """
    path = Path(path)
    suffix = _suffix(path)
    _check_exists(path)
    try:
        if suffix == ".parquet":
            return int(pq.ParquetFile(path).metadata.num_rows)
        first = _csv_header(path)[0]
        convert = pa_csv.ConvertOptions(include_columns=[first], column_types={first: pa.string()})
        reader = pa_csv.open_csv(path, convert_options=convert)
        return sum(int(b.num_rows) for b in reader)
    except (pa.ArrowException, OSError) as err:
        msg = f"{path}: cannot read ({err})"
        raise InputError(msg) from err


def _arrow_column(name: str, values: np.ndarray[Any, Any]) -> Any:
    arr = np.asarray(values)
    if arr.ndim != 1:
        msg = f"column {name!r}: expected a 1-D array, got shape {arr.shape}"
        raise InputError(msg)
    try:
        return pa.array(arr)
    except (pa.ArrowException, TypeError, ValueError) as err:
        msg = f"column {name!r}: cannot store dtype {arr.dtype} in a table ({err})"
        raise InputError(msg) from err


class TableChunkWriter:
    """Write a CSV or Parquet table chunk by chunk, atomically.

    Use as a context manager. The file is written under a temporary name beside
    ``path`` and renamed onto ``path`` only when the ``with`` block ends without an
    exception; otherwise nothing is left behind.

    Parameters
    ----------
    path : Path
        Output file; ``.csv`` or ``.parquet`` by suffix.

    Notes
    -----
    The first chunk fixes the schema (column names, order and types); later chunks
    must have the same columns and are cast to those types. A table with no chunk
    written is an empty file (CSV) or an empty Parquet table.
    """

    def __init__(self, path: Path) -> None:
        self.path = Path(path)
        self._suffix = _suffix(self.path)
        self._stack: ExitStack | None = None
        self._tmp: Path | None = None
        self._writer: Any = None
        self._schema: Any = None
        self.rows_written = 0

    def __enter__(self) -> TableChunkWriter:
        stack = ExitStack()
        self._tmp = stack.enter_context(atomic_path(self.path))
        self._stack = stack
        return self

    def write(self, columns: Mapping[str, np.ndarray[Any, Any]]) -> None:
        """Append one chunk: a mapping of column name to 1-D array, all one length."""
        if self._stack is None or self._tmp is None:
            msg = f"{self.path}: TableChunkWriter.write called outside its 'with' block"
            raise InputError(msg)
        lengths = {name: np.shape(v)[0] if np.ndim(v) else -1 for name, v in columns.items()}
        if len(set(lengths.values())) > 1:
            msg = f"{self.path}: columns of one chunk differ in length: {lengths}"
            raise InputError(msg)
        if self._schema is None:
            table = pa.table({n: _arrow_column(n, v) for n, v in columns.items()})
            self._schema = table.schema
            self._open(table.schema)
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

    def _open(self, schema: Any) -> None:
        assert self._tmp is not None
        if self._suffix == ".parquet":
            self._writer = pq.ParquetWriter(self._tmp, schema)
        else:
            self._writer = pa_csv.CSVWriter(
                self._tmp,
                self._csv_schema(schema),
                write_options=pa_csv.WriteOptions(quoting_style="needed"),
            )

    @staticmethod
    def _csv_schema(schema: Any) -> Any:
        fields = [
            pa.field(f.name, pa.string()) if pa.types.is_floating(f.type) else f for f in schema
        ]
        return pa.schema(fields)

    def _write_table(self, table: Any) -> None:
        if self._suffix == ".parquet":
            self._writer.write_table(table)
            return
        cols = {}
        for name in table.column_names:
            col = table.column(name)
            if pa.types.is_floating(col.type):
                text = col.to_numpy(zero_copy_only=False).astype(str)
                cols[name] = pa.array(text, type=pa.string())
            else:
                cols[name] = col
        self._writer.write_table(pa.table(cols, schema=self._csv_schema(table.schema)))

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        stack, self._stack = self._stack, None
        if stack is None:
            return
        try:
            if self._writer is not None:
                self._writer.close()
            elif exc_type is None and self._suffix == ".parquet":
                assert self._tmp is not None
                pq.write_table(pa.table({}), self._tmp)
        except BaseException:
            stack.__exit__(*sys.exc_info())
            raise
        stack.__exit__(exc_type, exc, tb)
