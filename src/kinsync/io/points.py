"""Point tables in CSV or Parquet, read and written in chunks of bounded size.

A point table holds one point per row and any number of columns; the georeferencing
pipeline needs some of them (``t_s,x_m,y_m,z_m`` or ``t_s,range_m,angle_rad``) and
carries every other column through unchanged.

Reading (`iter_table_chunks`) streams the file with pyarrow: Parquet by row batches
(``ParquetFile.iter_batches``), CSV with pyarrow's streaming reader. Chunks are dicts of
numpy arrays (with ``arrow``, pyarrow arrays for the columns that are not required), one
per column in file order, each of at most ``chunk_points`` rows.
Required columns come back as float64 (an empty or non-numeric cell is an error naming
the file, the row and the column); other columns keep their type: Parquet's stored
type, or for CSV the type pyarrow infers from the first block (int64, float64, bool,
string). CSV cannot say float32 from float64: such a column reads back as float64.

Random access (`plan_table_slices`, `read_table_slice`): the table is cut once into
slices that any process can read on its own, so that workers read their chunks
themselves and every run, serial or parallel, sees the same chunks. A CSV is cut at line
boundaries into byte ranges of exactly ``chunk_points`` data rows (one pass counting
the line ends, LF, CRLF or a CR alone as pyarrow reads them (`kinsync.io.text_lines`);
empty lines are skipped, as pyarrow does); column types are inferred once
from the file's first MiB (pyarrow's default block) and fixed for every slice. Like
pyarrow's own reader (its default ``newlines_in_values=False``) this assumes no line
break inside a quoted value: the planning pass refuses one, naming the first line that
ends inside quotes (`kinsync.io.csv_cells.quoted_line_break`), so that every scheduler
gives the same message. A Parquet file is cut at row-group boundaries: consecutive
row groups are merged up to ``chunk_points`` rows, and a row group larger than that is
read in pieces of ``chunk_points`` rows (read in order, each row is decoded once:
`kinsync.io.parquet_slices`). Slices never hold more than ``chunk_points`` rows.

Writing (`TableChunkWriter`, `csv_text_columns`) lives in `kinsync.io.table_writer`
and is re-exported here.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pyarrow as pa
import pyarrow.csv as pa_csv
import pyarrow.parquet as pq

from kinsync._validate import check_float_step
from kinsync.errors import InputError
from kinsync.io.arrow_signals import signals_left_to_python
from kinsync.io.column_map import ColumnMap
from kinsync.io.csv_cells import PARSE_ERROR as _PARSE_ERROR
from kinsync.io.csv_cells import first_bad_cell as _first_bad_cell
from kinsync.io.csv_cells import locate_bad_csv_cell as _locate_bad_csv_cell
from kinsync.io.csv_cells import quoted_line_break
from kinsync.io.csv_stream import csv_batches as _csv_batches
from kinsync.io.parquet_slices import read_row_group_piece, read_row_groups
from kinsync.io.row_position import point_position
from kinsync.io.sanity import check_text_file, require_file
from kinsync.io.table_writer import TableChunkWriter, csv_text_columns, table_suffix
from kinsync.io.text_lines import (
    CR,
    LF,
    csv_header_row,
    line_end_indices,
    read_first_line,
    warn_if_unended,
)

__all__ = [
    "TableChunkWriter",
    "TableLayout",
    "TableSlice",
    "count_table_rows",
    "csv_text_columns",
    "iter_table_chunks",
    "plan_table_slices",
    "read_table_slice",
    "slice_position",
    "table_columns",
]


def _suffix(path: Path) -> str:
    return table_suffix(path)


def _check_exists(path: Path) -> None:
    require_file(path, "point table")


def _csv_header(path: Path) -> list[str]:
    check_text_file(path, "point table (CSV)")
    row = csv_header_row(path)
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


def _check_required(
    path: Path, names: Sequence[str], required: Sequence[str], columns: ColumnMap | None = None
) -> None:
    missing = [c for c in required if c not in names]
    if missing:
        what = (
            f"rename the columns or give a table with {list(required)}"
            if columns is None
            else columns.hint([columns.kinsync_name(c) for c in missing])
        )
        msg = f"{path}: missing column(s) {missing}; the file has columns {list(names)}; {what}"
        raise InputError(msg)
    dupes = sorted({c for c in names if list(names).count(c) > 1})
    if dupes:
        msg = f"{path}: duplicated column name(s) {dupes}; give each column a unique name"
        raise InputError(msg)


def _mapped_required(
    path: Path, names: Sequence[str], required: Sequence[str], columns: ColumnMap | None
) -> tuple[list[str], tuple[tuple[str, str], ...]]:
    """The file's names of the required columns, and the renames to apply after reading.

    Checks the map against the file and the required columns' presence (`_check_required`).
    """
    if columns is None:
        _check_required(path, names, required)
        return list(required), ()
    columns.check_file(path, names)
    file_required = [columns.file_name(c) for c in required]
    _check_required(path, names, file_required, columns)
    return file_required, columns.renames()


def _renamed(
    chunk: dict[str, np.ndarray[Any, Any]], renames: Sequence[tuple[str, str]]
) -> dict[str, np.ndarray[Any, Any]]:
    """A chunk with the file's mapped columns under their kinsync names (order kept)."""
    if not renames:
        return chunk
    to = dict(renames)
    return {to.get(name, name): values for name, values in chunk.items()}


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
    path: Path,
    table: Any,
    required: Sequence[str],
    where: Callable[[int], str],
    *,
    arrow: bool = False,
) -> dict[str, Any]:
    """The columns of a table chunk, required ones checked and float64.

    The others are numpy arrays, or with ``arrow`` the pyarrow arrays they are (their
    types and nulls kept: numpy would turn an integer column with nulls into floats).
    ``where(i)`` names the chunk's row ``i`` in the file (`point_position`).
    """
    out: dict[str, Any] = {}
    for name in table.column_names:
        col = table.column(name)
        if name in required:
            if col.null_count:
                idx = int(np.flatnonzero(col.is_null().to_numpy(zero_copy_only=False))[0])
                what = "empty cell" if _suffix(path) == ".csv" else "no value (null)"
                msg = (
                    f"{path}: {where(idx)}, column {name!r}: {what}; "
                    "every point needs a number there: fix or remove the row"
                )
                raise InputError(msg)
            if pa.types.is_boolean(col.type):  # float(True) is 1.0: every range 1 m
                msg = (
                    f"{path}: column {name!r} holds true/false values (column type bool); "
                    "store numbers there (integer or floating)"
                )
                raise InputError(msg)
            if not (pa.types.is_floating(col.type) or pa.types.is_integer(col.type)):
                values = col.to_numpy(zero_copy_only=False)
                for i, v in enumerate(values):
                    try:
                        float(v)
                    except (TypeError, ValueError):
                        msg = (
                            f"{path}: {where(i)}, column {name!r}: {v!r} is "
                            f"not a number (column type {col.type}); store numbers there"
                        )
                        raise InputError(msg) from None
                out[name] = np.asarray(values.astype(np.float64))
                continue
            stored = col.to_numpy(zero_copy_only=False)
            # a float32 column is already rounded (times near 1.3e9 s to 128 s); an
            # intensity (a relative strength) needs no particular step
            if name != "intensity":
                check_float_step(stored, f"{path}: column {name!r}", _float_kind(name))
            out[name] = np.asarray(stored, dtype=np.float64)
        else:
            out[name] = col if arrow else col.to_numpy(zero_copy_only=False)
    return out


def _float_kind(name: str) -> Literal["time", "coordinate", "angle", "count"]:
    """What a required numeric column holds, for `kinsync._validate.check_float_step`."""
    if name == "t_s":
        return "time"
    if name.endswith("_rad"):
        return "angle"
    return "count" if name == "profile" else "coordinate"


def _parquet_batches(path: Path, pf: Any, chunk_points: int) -> Iterator[Any]:
    """``pf.iter_batches``, a damaged data page (bad compression, cut short) named."""
    try:
        yield from pf.iter_batches(batch_size=chunk_points)
    except (pa.ArrowException, OSError) as err:  # 'Corrupt snappy compressed data'
        why = " ".join(str(err).split())  # pyarrow's message may run over several lines
        msg = f"{path}: the Parquet data is damaged ({why}); copy or export the file again"
        raise InputError(msg) from err


def iter_table_chunks(
    path: Path,
    chunk_points: int,
    required: Sequence[str],
    *,
    extra_as_text: bool = False,
    arrow: bool = False,
    columns: ColumnMap | None = None,
) -> Iterator[dict[str, Any]]:
    """Stream a CSV or Parquet point table in chunks of at most ``chunk_points`` rows.

    Parameters
    ----------
    path : Path
        ``.csv`` (header line, comma-separated) or ``.parquet``.
    chunk_points : int
        Rows per chunk (every chunk but the last has exactly this many), >= 1.
    required : sequence of str
        Columns that must be present and numeric; returned as float64.
    extra_as_text : bool
        Read the other columns of a CSV as text (to write them back exactly as they
        were: ``007`` stays ``007``) instead of inferring their types.
    arrow : bool
        Give the columns that are not required as pyarrow arrays, with their types and
        nulls (as numpy arrays, an integer column with nulls would become floats, NaN
        for null), as `read_table_slice` does.
    columns : ColumnMap, optional
        Which of the file's columns hold the required ones (`kinsync.io.column_map`);
        they are handed on under the required (kinsync) names.

    Yields
    ------
    dict of str to ndarray (or pyarrow array), each of shape (M,)
        Every column of the file, in file order, with its type (see the module
        docstring), mapped columns renamed; M <= ``chunk_points``.

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
    required, renames = _mapped_required(path, names, required, columns)
    if suffix == ".csv":
        warn_if_unended(path)
        block = _csv_block_bytes(chunk_points, len(names))
        others = [n for n in names if n not in required]
        text = others if extra_as_text else []
        # types inferred from the first block the reader had (block reads ahead less)
        types = None if extra_as_text or not others else _csv_schema(path, required, block)
        batches: Iterator[Any] = _csv_batches(path, required, block, text, _others(types))
        total = None
    else:
        try:
            pf = pq.ParquetFile(path)
        except (pa.ArrowException, OSError) as err:
            msg = f"{path}: cannot read as Parquet ({err})"
            raise InputError(msg) from err
        batches = _parquet_batches(path, pf, chunk_points)
        total = int(pf.metadata.num_rows)
    first_row = 0

    def where(i: int) -> str:
        return point_position(path, first_row + i, total)

    try:
        for table in _rebatch(batches, chunk_points):
            chunk = _chunk_to_numpy(path, table, required, where, arrow=arrow)
            yield _renamed(chunk, renames)
            first_row += table.num_rows
    finally:  # close the CSV reader (its read-ahead threads) whatever stopped the loop
        close = getattr(batches, "close", None)
        if close is not None:
            close()


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
        try:
            return sum(int(b.num_rows) for b in reader)
        finally:
            reader.close()
    except (pa.ArrowException, OSError) as err:
        msg = f"{path}: cannot read ({err})"
        raise InputError(msg) from err


# ---------------------------------------------------------------------- random access
_SCAN_BLOCK_BYTES = 1 << 24
_SCHEMA_BLOCK_BYTES = 1 << 20  # pyarrow's default block: types inferred from the first MiB


@dataclass(frozen=True)
class TableSlice:
    """One chunk of a point table, readable on its own (`read_table_slice`).

    Attributes
    ----------
    first_row : int
        Data row (0-based, header and empty lines not counted) of the slice's first row.
    n_rows : int
        Data rows in the slice (at most the planned ``chunk_points``).
    byte_start, byte_end : int
        CSV: byte range ``[byte_start, byte_end)`` from the start of the slice's first
        line to just after its last line. Parquet: 0.
    first_line : int
        CSV: file line (1-based, header = line 1) at ``byte_start``. Parquet: 0.
    row_groups : tuple of int
        Parquet: row groups holding the slice (empty for CSV).
    skip_rows : int
        Parquet: rows of ``row_groups[0]`` before the slice (a row group larger than
        ``chunk_points`` is read in pieces); 0 otherwise.
    """

    first_row: int
    n_rows: int
    byte_start: int = 0
    byte_end: int = 0
    first_line: int = 0
    row_groups: tuple[int, ...] = ()
    skip_rows: int = 0


@dataclass(frozen=True, eq=False)
class TableLayout:
    """What a process needs to read slices of a table: path, columns and their types.

    Attributes
    ----------
    path : Path
        The table (``.csv`` or ``.parquet``).
    columns : tuple of str
        Column names in file order.
    required : tuple of str
        Columns read as float64 (they must be numbers).
    schema : pyarrow.Schema
        Column types: Parquet's stored types; for CSV the types pyarrow infers from the
        file's first MiB (required columns float64), fixed for every slice.
    total_rows : int
        Data rows in the file.
    renames : tuple of (str, str)
        ``(the file's column, kinsync name)`` applied to the slices read
        (`kinsync.io.column_map.ColumnMap.renames`); empty when nothing is mapped.
    inferred : pyarrow.Schema or None
        The types of the columns as numbers would be read: for CSV, pyarrow's
        inference from the first MiB (the slices give the columns that are not required
        as text, `kinsync.io.table_numbers.numeric_columns` converts them); for Parquet
        the stored types.
    """

    path: Path
    columns: tuple[str, ...]
    required: tuple[str, ...]
    schema: Any
    total_rows: int
    renames: tuple[tuple[str, str], ...] = ()
    inferred: Any = None

    def kinsync_name(self, column: str) -> str:
        """The name under which the file's column ``column`` is handed on."""
        return next((ours for theirs, ours in self.renames if theirs == column), column)

    def file_name(self, name: str) -> str:
        """The file's own name of the column handed on as ``name``."""
        return next((theirs for theirs, ours in self.renames if ours == name), name)


def _csv_convert_options(column_types: Mapping[str, Any], names: list[str] | None = None) -> Any:
    return pa_csv.ConvertOptions(
        column_types=dict(column_types),
        null_values=[""],
        strings_can_be_null=False,
        include_columns=names,
    )


def _csv_block_bytes(chunk_points: int, n_columns: int) -> int:
    return int(min(max(chunk_points * 16 * max(n_columns, 1), 1 << 20), 1 << 30))


def _others(schema: Any) -> dict[str, Any] | None:
    """The types of a CSV's columns by the file's names (`_csv_schema`), or None."""
    return None if schema is None else {f.name: f.type for f in schema}


def _csv_schema(path: Path, required: Sequence[str], block_bytes: int) -> Any:
    """Column types from the first block, as the streaming reader infers them.

    The block (``block_bytes``, cut after its last complete line) is read into memory
    and parsed there: a streaming reader would read ahead on pyarrow's threads, which a
    process that stops soon after (a bad cell in the first chunk) can exit under.
    """
    with path.open("rb") as fh:
        data = fh.read(block_bytes)
        if len(data) == block_bytes and fh.read(1):
            end = max(data.rfind(b"\n"), data.rfind(b"\r"))
            data = data[: end + 1] if end >= 0 else data
    try:
        with signals_left_to_python():
            table = pa_csv.read_csv(
                io.BytesIO(data),
                read_options=pa_csv.ReadOptions(use_threads=False),
                convert_options=_csv_convert_options(dict.fromkeys(required, pa.float64())),
            )
    except pa.ArrowInvalid as err:
        if "conversion error" in str(err) or _PARSE_ERROR in str(err):
            bad = _locate_bad_csv_cell(path, required)
            if bad is not None:
                raise bad from err
        msg = f"{path}: cannot read as CSV ({err})"
        raise InputError(msg) from err
    except (pa.ArrowException, OSError) as err:
        msg = f"{path}: cannot read as CSV ({err})"
        raise InputError(msg) from err
    return table.schema


def _csv_header_bytes(path: Path) -> int:
    """Byte offset just after the header line (its end LF, CRLF or CR)."""
    with path.open("rb") as fh:
        return len(read_first_line(fh))


_QUOTE = 0x22  # '"'


def _quote_check(
    path: Path,
    quotes: np.ndarray[Any, Any],
    starts: np.ndarray[Any, Any],
    ends: np.ndarray[Any, Any],
    first_line: int,
    base: int,
    block: tuple[bytes, int],
) -> int:
    """Refuse the first line that ends inside a quoted value; the new count ``base``.

    ``quotes[j]`` counts the quote characters from the data's start to line end
    ``ends[j]``; ``base`` is the count where a line last ended outside quotes. A line
    that ends inside quotes holds an odd number of them (counted from ``base`` for the
    first line); so does one with a quote inside an unquoted value (``12"``), so each
    such line is read with the ``csv`` module (`quoted_line_break`) to tell. Every line
    of the block then ends outside quotes: the new base is the last line's count. One
    pass over the block's lines, each odd one read from ``block`` (the block's bytes and
    its offset in the file) when it starts in it: a file with ``12"`` on every line was
    planned in time quadratic in its lines.

    Raises
    ------
    InputError
        A line that ends inside quotes (line ``first_line + j``).
    """
    own = np.diff(quotes, prepend=base)  # each line's own quote characters
    buf, pos = block
    for k in np.flatnonzero(own % 2 == 1).tolist():
        start, end = int(starts[k]), int(ends[k])
        if start >= pos:
            data = buf[start - pos : end + 1 - pos]
        else:  # the line began in the block before
            with path.open("rb") as fh:
                fh.seek(start)
                data = fh.read(end + 1 - start)
        err = quoted_line_break(path, data, first_line + k)
        if err is not None:
            raise err
    return int(quotes[-1]) if quotes.size else base


def _plan_csv(path: Path, chunk_points: int) -> tuple[list[TableSlice], int]:
    """Cut the data lines of a CSV into slices of ``chunk_points`` non-empty lines.

    Raises
    ------
    InputError
        A line that ends inside a quoted value (`quoted_line_break`): the slices of the
        file's lines would cut such a value and read its halves as rows.
    """
    slices: list[TableSlice] = []
    quotes_before = quotes_base = 0  # quote characters before the block; see _quote_check
    data_start = _csv_header_bytes(path)
    size = path.stat().st_size
    line_start = data_start  # start byte of the line being read
    line_no = 2  # file line number of the line starting at line_start
    slice_start, slice_line, slice_row = data_start, 2, 0
    rows_in_slice = 0  # non-empty lines since slice_start
    prev_byte = -1  # last byte of the previous block
    with path.open("rb") as fh:
        fh.seek(data_start)
        pos = data_start
        buf = fh.read(_SCAN_BLOCK_BYTES)
        while buf:
            nxt = fh.read(_SCAN_BLOCK_BYTES)  # its first byte: is a last CR half a CRLF?
            arr = np.frombuffer(buf, dtype=np.uint8)
            nl = line_end_indices(arr, nxt[0] if nxt else None)  # LF, CRLF's LF, lone CR
            q = np.flatnonzero(arr == _QUOTE)
            if nl.size:
                ends = nl + pos  # absolute offsets of the line ends
                starts = np.empty(nl.size, dtype=np.int64)
                starts[0] = line_start
                starts[1:] = ends[:-1] + 1
                before = np.where(nl > 0, arr[np.maximum(nl - 1, 0)], prev_byte)
                crlf = ((arr[nl] == LF) & (before == CR)).astype(np.int64)
                if q.size or (quotes_before - quotes_base) % 2:
                    counts = quotes_before + np.searchsorted(q, nl)
                    quotes_base = _quote_check(
                        path, counts, starts, ends, line_no, quotes_base, (buf, pos)
                    )
                nonempty = ends - starts - crlf > 0  # the line holds more than its end
                cum = rows_in_slice + np.cumsum(nonempty)
                for k in np.flatnonzero(nonempty & (cum % chunk_points == 0)).tolist():
                    end = int(ends[k]) + 1
                    slices.append(
                        TableSlice(
                            first_row=slice_row,
                            n_rows=chunk_points,
                            byte_start=slice_start,
                            byte_end=end,
                            first_line=slice_line,
                        )
                    )
                    slice_start, slice_line = end, line_no + k + 1
                    slice_row += chunk_points
                rows_in_slice = int(cum[-1]) % chunk_points
                line_no += int(nl.size)
                line_start = int(ends[-1]) + 1
            quotes_before += int(q.size)
            pos += len(buf)
            prev_byte = int(arr[-1])
            buf = nxt
    if size > line_start:  # an unterminated last line (a last CR ends a line)
        rows_in_slice += 1
    if rows_in_slice:
        slices.append(
            TableSlice(
                first_row=slice_row,
                n_rows=rows_in_slice,
                byte_start=slice_start,
                byte_end=size,
                first_line=slice_line,
            )
        )
    return slices, slice_row + rows_in_slice


def _plan_parquet(pf: Any, chunk_points: int) -> tuple[list[TableSlice], int]:
    """Slices of whole row groups (merged up to ``chunk_points`` rows) or row-group pieces."""
    slices: list[TableSlice] = []
    groups: list[int] = []
    first = rows = 0  # first row and rows of the slice being built

    def flush() -> None:
        nonlocal groups, first, rows
        if groups:
            slices.append(TableSlice(first_row=first, n_rows=rows, row_groups=tuple(groups)))
        first, groups, rows = first + rows, [], 0

    for g in range(pf.metadata.num_row_groups):
        n = int(pf.metadata.row_group(g).num_rows)
        if n == 0:
            continue
        if n > chunk_points:
            flush()
            for skip in range(0, n, chunk_points):
                take = min(chunk_points, n - skip)
                slices.append(
                    TableSlice(first_row=first, n_rows=take, row_groups=(g,), skip_rows=skip)
                )
                first += take
            continue
        if rows + n > chunk_points:
            flush()
        groups.append(g)
        rows += n
    flush()
    return slices, first


def _open_parquet(path: Path) -> Any:
    try:
        return pq.ParquetFile(path)
    except (pa.ArrowException, OSError) as err:
        msg = f"{path}: cannot read as Parquet ({err})"
        raise InputError(msg) from err


def plan_table_slices(
    path: Path, chunk_points: int, required: Sequence[str], columns: ColumnMap | None = None
) -> tuple[TableLayout, list[TableSlice]]:
    """Cut a CSV or Parquet table into independently readable slices.

    Parameters
    ----------
    path : Path
        ``.csv`` (header line, comma-separated, no line break inside a value) or
        ``.parquet``.
    chunk_points : int
        Most rows per slice, >= 1 (CSV: every slice but the last has exactly this many).
    required : sequence of str
        Columns that must be present and numeric (read as float64). The other columns
        of a CSV are read as text, so that they are written back exactly as they were
        (``007`` stays ``007``, a 2**70 integer stays whole); those of a Parquet file
        keep their types.
    columns : ColumnMap, optional
        Which of the file's columns hold the required ones; `read_table_slice` hands
        them on under the required (kinsync) names.

    Returns
    -------
    layout : TableLayout
        Path, columns, types and row count, for `read_table_slice`.
    slices : list of TableSlice
        In file order, covering every data row once.

    Raises
    ------
    InputError
        Missing file, unknown suffix, missing or duplicated columns, a line of the CSV
        that ends inside a quoted value (a line break in a value), a bad cell of a
        required column in the CSV's first block, an unreadable file.
    """
    path = Path(path)
    if chunk_points < 1:
        msg = f"{path}: chunk_points must be >= 1, got {chunk_points}"
        raise InputError(msg)
    suffix = _suffix(path)
    names = table_columns(path)
    required, renames = _mapped_required(path, names, required, columns)
    if suffix == ".csv":
        warn_if_unended(path)
        try:  # first: a quoted line break is named as such, not as the row it garbles
            slices, total = _plan_csv(path, chunk_points)
        except OSError as err:
            msg = f"{path}: cannot read ({err})"
            raise InputError(msg) from err
        guessed = _csv_schema(path, required, _SCHEMA_BLOCK_BYTES)
        schema = pa.schema(  # the header's names (stripped), required columns float64
            [
                pa.field(name, pa.float64() if name in required else pa.string())
                for name, _ in zip(names, guessed, strict=True)
            ]
        )
        inferred = pa.schema(
            [pa.field(name, f.type) for name, f in zip(names, guessed, strict=True)]
        )
    else:
        pf = _open_parquet(path)
        schema = inferred = pf.schema_arrow
        slices, total = _plan_parquet(pf, chunk_points)
    layout = TableLayout(
        path=path,
        columns=tuple(schema.names),
        required=tuple(required),
        schema=schema,
        total_rows=total,
        renames=renames,
        inferred=inferred,
    )
    return layout, slices


def _read_csv_slice(layout: TableLayout, sl: TableSlice, names: list[str] | None) -> Any:
    path = layout.path
    with path.open("rb") as fh:
        fh.seek(sl.byte_start)
        data = fh.read(sl.byte_end - sl.byte_start)
    types = {f.name: f.type for f in layout.schema}
    try:
        with signals_left_to_python():
            return pa_csv.read_csv(
                io.BytesIO(data),
                # one thread: with pyarrow's thread pool a run that stopped on a bad cell
                # right after aborted at exit now and then (exit 134, 2 of 20 runs; 0 of 30
                # without); the slices of --scheduler processes still parse in parallel
                read_options=pa_csv.ReadOptions(
                    column_names=list(layout.columns), use_threads=False
                ),
                convert_options=_csv_convert_options(types, names),
            )
    except pa.ArrowInvalid as err:
        if "conversion error" in str(err) or _PARSE_ERROR in str(err):
            text = data.decode("utf-8", errors="surrogateescape")
            reader = csv.reader(io.StringIO(text, newline=""))
            bad = _first_bad_cell(
                path,
                reader,
                layout.columns,
                layout.required,
                first_line=sl.first_line - 1,
            )
            if bad is not None:
                raise bad from err
        if "conversion error" in str(err):
            msg = (
                f"{path}: lines {sl.first_line}..: {err}; a column's values change type "
                "after the first rows (types are inferred from the first block): make the "
                "column uniform"
            )
            raise InputError(msg) from err
        msg = f"{path}: lines {sl.first_line}..: cannot read as CSV ({err})"
        raise InputError(msg) from err
    except pa.ArrowException as err:
        msg = f"{path}: lines {sl.first_line}..: cannot read as CSV ({err})"
        raise InputError(msg) from err


def _read_parquet_slice(layout: TableLayout, sl: TableSlice, names: list[str] | None) -> Any:
    """Whole row groups read at once; a piece of a larger one by `read_row_group_piece`."""
    pf = _open_parquet(layout.path)
    group = sl.row_groups[0]
    try:
        if sl.skip_rows == 0 and (
            len(sl.row_groups) > 1 or pf.metadata.row_group(group).num_rows == sl.n_rows
        ):
            return read_row_groups(pf, sl.row_groups, names)
        schema = pf.schema_arrow
        if names is not None:
            schema = pa.schema([schema.field(n) for n in names], metadata=schema.metadata)
        return read_row_group_piece(layout.path, group, sl.skip_rows, sl.n_rows, schema, names)
    except (pa.ArrowException, OSError) as err:
        msg = f"{layout.path}: row groups {list(sl.row_groups)}: cannot read ({err})"
        raise InputError(msg) from err


def read_table_slice(
    layout: TableLayout,
    sl: TableSlice,
    *,
    arrow: bool = False,
    only: Sequence[str] | None = None,
) -> dict[str, Any]:
    """Read one slice planned by `plan_table_slices`.

    Parameters
    ----------
    layout : TableLayout
    sl : TableSlice
    arrow : bool
        Give the columns that are not required as pyarrow arrays, with their types and
        nulls (as numpy arrays, an integer column with nulls would become floats, NaN
        for null).
    only : sequence of str, optional
        Read only these columns (by the names handed on: kinsync names for mapped
        columns); the others are neither converted nor checked. Every column when None.

    Returns
    -------
    dict of str to ndarray (or pyarrow array), each of shape (``sl.n_rows``,)
        Every column (or those of ``only``) in file order, with the types of
        ``layout.schema`` (required columns float64), mapped columns under their kinsync names
        (``layout.renames``), as `iter_table_chunks` gives them.

    Raises
    ------
    InputError
        An empty or non-numeric cell of a required column (naming the file line and
        data row), a value that does not fit its column's type, a file that changed
        since it was planned (another number of rows), an unreadable file.
    """
    path = layout.path
    names = None if only is None else [n for n in layout.columns if layout.kinsync_name(n) in only]
    try:
        if path.suffix.lower() == ".csv":
            table = _read_csv_slice(layout, sl, names)
        else:
            table = _read_parquet_slice(layout, sl, names)
    except OSError as err:
        msg = f"{path}: cannot read ({err})"
        raise InputError(msg) from err
    if table.num_rows != sl.n_rows:
        where = (
            f"lines {sl.first_line}.."
            if sl.first_line
            else f"rows {sl.first_row + 1}..{sl.first_row + sl.n_rows} of {layout.total_rows}"
        )
        msg = (
            f"{path}: {where}: {sl.n_rows} rows were planned, {table.num_rows} read back; "
            "the file changed while it was read, or a quoted "
            "value holds a line break (not supported: remove line breaks from values)"
        )
        raise InputError(msg)
    columns = _chunk_to_numpy(
        path, table, layout.required, lambda i: slice_position(layout, sl, i), arrow=arrow
    )
    return _renamed(columns, layout.renames)


def slice_position(layout: TableLayout, sl: TableSlice, i: int) -> str:
    """Row ``i`` of a slice as a user finds it in the file (`point_position`).

    ``line N`` for a CSV (1-based, header = line 1), ``row N of M`` for Parquet.
    """
    return point_position(
        layout.path,
        sl.first_row + i,
        layout.total_rows,
        byte_start=sl.byte_start if sl.first_line else None,
        first_line=sl.first_line or 2,
        first_row=sl.first_row,
    )
