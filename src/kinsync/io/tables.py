"""Numeric CSV tables with a header row.

A fast path reads the whole file with numpy; if that fails, a second pass finds the
first bad cell and reports its line and column, so a user can fix the file.
"""

from __future__ import annotations

import csv
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.csv as pa_csv

from kinsync._arrays import ReadOnlyArrays
from kinsync._text import reads_as_number
from kinsync._typing import FloatArray
from kinsync.errors import InputError
from kinsync.io.arrow_signals import signals_left_to_python
from kinsync.io.atomic import atomic_path
from kinsync.io.csv_cells import (
    DATE_TEXT,
    blank_row_error,
    comment_hint,
    decimal_comma_hint,
    is_date_text,
)
from kinsync.io.row_position import csv_line_of_row
from kinsync.io.sanity import (
    MAX_TABLE_BYTES,
    MAX_TEXT_ROWS_BYTES,
    TIME_S,
    check_text_file,
    check_values,
    not_utf8_cell,
)
from kinsync.io.text_lines import (
    csv_header_row,
    cut_line_hint,
    refuse_other_separator,
    warn_if_unended,
)

__all__ = [
    "NumericTable",
    "read_csv_rows",
    "read_numeric_csv",
    "read_time_column",
    "rows_to_lines",
    "write_numeric_csv",
]


@dataclass(frozen=True, eq=False)
class NumericTable(ReadOnlyArrays):
    """Columns of a numeric CSV file.

    Attributes
    ----------
    source : str
        File the table came from (for messages).
    columns : dict of str to ndarray, shape (N,)
        The columns asked for (required, and optional ones present) and every other
        column that holds numbers only, by header name, float64.
    header : tuple of str
        Every column name of the file, in order (a text column is not in ``columns``).
    """

    source: str
    columns: dict[str, FloatArray]
    header: tuple[str, ...] = ()

    @property
    def n_rows(self) -> int:
        """Number of data rows."""
        return len(next(iter(self.columns.values()))) if self.columns else 0

    def line_of_row(self, row: int) -> int:
        """File line number (1-based, header = line 1) of a 0-based data row.

        Empty lines are not rows (the reader skips them) but count as lines: the file
        is read up to the row (messages only) when the source is a file.
        """
        path = Path(self.source)
        line = csv_line_of_row(path, row) if path.is_file() else None
        return row + 2 if line is None else line


def rows_to_lines(text: str, line_of_row: Callable[[int], int]) -> str:
    """Add the file line to every ``row N`` (0-based data row) of a message.

    Containers (`kinsync.trajectory.Trajectory`, ...) name the rows of their arrays; a
    reader re-raises their errors with the line of the file a user opens.
    """
    return re.sub(
        r"\brow (\d+)\b",
        lambda m: f"row {m.group(1)} (line {line_of_row(int(m.group(1)))})",
        text,
    )


def _locate_bad_cell(
    path: Path, header: list[str], wanted: Sequence[str], empty_is_nan: Sequence[str] = ()
) -> InputError:
    err = _first_bad_cell(path, header, wanted, empty_is_nan)
    return InputError(f"{path}: cannot read as a numeric CSV table") if err is None else err


def _first_bad_cell(
    path: Path, header: list[str], wanted: Sequence[str], empty_is_nan: Sequence[str] = ()
) -> InputError | None:
    """The first ragged row, or cell of a ``wanted`` column that is not a plain number.

    An empty cell of an ``empty_is_nan`` column is a number (NaN).
    """
    blank_ok = set(empty_is_nan)
    read = set(wanted)
    with path.open(newline="", encoding="utf-8-sig", errors="surrogateescape") as fh:
        reader = csv.reader(fh)
        try:
            next(reader)
            for line_no, row in enumerate(reader, start=2):
                if (blank := blank_row_error(path, line_no, row)) is not None:
                    return blank
                if not row:
                    continue
                if len(row) != len(header):
                    return InputError(
                        f"{path}: line {line_no} has {len(row)} fields, the header has "
                        f"{len(header)}{comment_hint(row)}"
                        f"{decimal_comma_hint(row, len(header))}{cut_line_hint(path, line_no)}"
                    )
                for name, cell in zip(header, row, strict=True):
                    if name not in read or (name in blank_ok and not cell):
                        continue
                    if (err := not_utf8_cell(path, line_no, cell)) is not None:
                        return err
                    try:
                        float(cell)
                    except ValueError:
                        what = DATE_TEXT if is_date_text(cell) else "is not a number"
                    else:  # Python reads '1_000' and other digits; the CSV parser does not
                        if cell.isascii() and "_" not in cell:
                            continue
                        what = (
                            "is not a plain number (digits 0-9, a point, a sign, an exponent; "
                            "no '_', other digits or spaces)"
                        )
                    return InputError(
                        f"{path}: line {line_no}, column {name!r}: {cell[:80]!r} {what}"
                        f"{comment_hint(row)}{cut_line_hint(path, line_no)}"
                    )
        except csv.Error as err:
            return InputError(f"{path}: line {reader.line_num}: cannot read as CSV ({err})")
    return None


def _read_float_columns_arrow(
    path: Path,
    header: list[str],
    wanted: Sequence[str],
    *,
    empty_is_null: bool = False,
    only_named: bool = False,
) -> dict[str, FloatArray] | None:
    """The columns as float64 through pyarrow's multi-threaded CSV reader.

    The ``wanted`` columns must be numbers; any other column is kept when it holds
    numbers only, and left out when it holds text (a note, a flag), or with
    ``only_named`` not read at all.

    Returns None when the file is not clean numeric CSV (a non-number, an empty cell,
    a ragged row); the caller then names the first bad line. ``nan`` is a number, as
    for ``float()``; so is an empty cell with ``empty_is_null`` (NaN).
    """
    null_values = ["nan", "NaN", "-nan", "+nan", *([""] if empty_is_null else [])]
    try:
        with signals_left_to_python():
            table = pa_csv.read_csv(
                path,
                read_options=pa_csv.ReadOptions(column_names=header, skip_rows=1),
                convert_options=pa_csv.ConvertOptions(
                    include_columns=list(wanted) if only_named else [],
                    column_types=dict.fromkeys(wanted, pa.float64()),
                    null_values=null_values,
                    strings_can_be_null=False,
                    quoted_strings_can_be_null=empty_is_null,
                ),
            )
    except (pa.ArrowInvalid, pa.ArrowTypeError):
        return None
    return {
        name: np.asarray(table.column(name).to_numpy(zero_copy_only=False), dtype=np.float64)
        for name in table.column_names
        if name in wanted
        or pa.types.is_integer(table.column(name).type)
        or pa.types.is_floating(table.column(name).type)
    }


def read_numeric_csv(
    path: Path,
    required: Sequence[str],
    optional: Sequence[str] = (),
    *,
    empty_is_nan: Sequence[str] = (),
    only_named: bool = False,
) -> NumericTable:
    """Read a comma-separated numeric table with a header row.

    Parameters
    ----------
    path : Path
        CSV file.
    required : sequence of str
        Columns that must be present.
    optional : sequence of str
        Columns read when present (named in the message of a file without a header
        row). Other columns are kept when they hold numbers only; a text column (a
        note, a flag) is left out, not refused.
    empty_is_nan : sequence of str
        Columns whose empty cells read as NaN (``nan`` means "not given" there); an empty
        cell elsewhere is refused as not a number.
    only_named : bool
        Read the required and optional columns only (no memory for the others).

    Raises
    ------
    InputError
        Missing file, not a text file or larger than `MAX_TABLE_BYTES` (see
        `kinsync.io.sanity.check_text_file`), empty file, missing required columns
        (listing what is there), duplicated column names, a non-numeric cell (line and
        column), ragged rows, bytes that are not UTF-8.
    """
    path = Path(path)
    check_text_file(path, "CSV file", max_bytes=MAX_TABLE_BYTES)
    header_row = csv_header_row(path)  # a BOM is not a name
    if not header_row:
        msg = f"{path}: empty file; expected a header row with {', '.join(required)}"
        raise InputError(msg)
    header = [h.strip() for h in header_row]
    if all(reads_as_number(h) for h in header):
        shown = ",".join(header[:4]) + (",..." if len(header) > 4 else "")
        extra = f"; optional: {', '.join(optional)}" if optional else ""
        msg = (
            f"{path}: the first line holds numbers ({shown[:120]}), not column names: the "
            f"file has no header row. Add one naming the columns (required: "
            f"{', '.join(required)}{extra})"
        )
        raise InputError(msg)
    dupes = sorted({h for h in header if header.count(h) > 1})
    if dupes:
        msg = f"{path}: duplicated column(s) {dupes} in the header"
        raise InputError(msg)
    missing = [c for c in required if c not in header]
    if missing:
        msg = f"{path}: missing column(s) {missing}; the header has {header}"
        raise InputError(msg)
    wanted = [h for h in header if h in required or h in optional]
    warn_if_unended(path)
    columns = _read_float_columns_arrow(path, header, wanted, only_named=only_named)
    if columns is None and empty_is_nan:  # empty cells where they mean nan, and no other?
        if (err := _first_bad_cell(path, header, wanted, empty_is_nan)) is not None:
            raise err
        columns = _read_float_columns_arrow(
            path, header, wanted, empty_is_null=True, only_named=only_named
        )
    if columns is None:  # not clean numeric CSV: find and name the bad line
        raise _locate_bad_cell(path, header, wanted, empty_is_nan)
    return NumericTable(source=str(path), columns=columns, header=tuple(header))


def write_numeric_csv(path: Path, columns: dict[str, FloatArray]) -> None:
    """Write columns as CSV with a header, floats in their shortest exact form.

    Doubles are written (by pyarrow) in the shortest text that reads back to the same
    float64, like ``repr`` (``nan``/``inf`` for non-finite values) — about ten times
    faster than a Python loop for tables at the IMU rate. The file appears only when
    complete (temporary name, then rename).
    """
    names = list(columns)
    arrays = [np.asarray(columns[n], dtype=np.float64) for n in names]
    n = {a.shape for a in arrays}
    if len(n) != 1 or len(next(iter(n))) != 1:
        msg = f"write_numeric_csv: columns must be 1-D of one length, got shapes {sorted(n)}"
        raise InputError(msg)
    table = pa.table({str(i): a for i, a in enumerate(arrays)})
    with atomic_path(Path(path)) as tmp, tmp.open("wb") as fh:
        fh.write((",".join(names) + "\n").encode("utf-8"))
        pa_csv.write_csv(table, fh, pa_csv.WriteOptions(include_header=False))


def read_csv_rows(path: Path, what: str = "file") -> list[tuple[int, list[str]]]:
    """The non-blank rows of a small CSV file with their 1-based line numbers.

    A file that ends without a line end after a data row gets a warning
    (`kinsync.io.text_lines.warn_if_unended`).

    Parameters
    ----------
    path : Path
        The file (UTF-8, a BOM is skipped).
    what : str
        What the file is, for the not-found message ("control point file", ...).

    Raises
    ------
    InputError
        Missing file, not a text file or larger than `MAX_TEXT_ROWS_BYTES` (see
        `kinsync.io.sanity.check_text_file`), a file that cannot be read as CSV, or a
        byte that is not UTF-8 (naming its line).
    """
    check_text_file(Path(path), what, max_bytes=MAX_TEXT_ROWS_BYTES)
    records: list[tuple[int, list[str]]] = []
    try:
        with Path(path).open(newline="", encoding="utf-8-sig", errors="surrogateescape") as fh:
            reader = csv.reader(fh)
            line = 1  # the file line a row starts on
            for row in reader:
                if row and any(c.strip() for c in row):
                    records.append((line, row))
                line = reader.line_num + 1
    except (OSError, csv.Error) as err:
        msg = f"{path}: cannot read as CSV ({err})"
        raise InputError(msg) from err
    for line, row in records:  # a byte that is not UTF-8, named by its line
        for cell in row:
            if (bad := not_utf8_cell(Path(path), line, cell)) is not None:
                raise bad
    if records and records[0][0] == 1:  # a spreadsheet's semicolons (decimal comma)
        refuse_other_separator(Path(path), records[0][1])
    warn_if_unended(Path(path))
    return records


def read_time_column(path: Path, column: str) -> tuple[FloatArray, Callable[[int], int]]:
    """Read one column of a CSV with a header as times, and how to name a row's line.

    Only that column is read (through pyarrow): the others may hold anything, and a
    file of any size up to `MAX_TABLE_BYTES` takes 8 bytes a row
    (`kinsync.pipelines.clock_apply` then streams the file to write it back).

    Parameters
    ----------
    path : Path
        CSV file (comma-separated, header row).
    column : str
        Name of the time column (surrounding spaces in the header ignored).

    Returns
    -------
    t_s : ndarray, shape (N,)
        The column as float64 (s).
    line_of_row : callable
        The file line (1-based, header = line 1) of a 0-based data row, for messages.

    Raises
    ------
    InputError
        Missing or unreadable file, empty file, no such column (listing those there),
        a duplicated column name, a row with another number of fields than the header,
        no data rows, or a cell of the column that is not a finite number or not a
        plausible time (`kinsync.io.sanity.TIME_S`; with its line).
    """
    path = Path(path)
    check_text_file(path, "CSV file", max_bytes=MAX_TABLE_BYTES)
    names = [h.strip() for h in csv_header_row(path) or []]
    if not names:
        msg = f"{path}: empty file; expected a header row with a column {column!r}"
        raise InputError(msg)
    if names.count(column) != 1:
        what = "appears more than once in" if names.count(column) else "is not in"
        msg = f"{path}: column {column!r} {what} the header {names}; choose it with --column"
        raise InputError(msg)
    table = read_numeric_csv(path, [column], only_named=True)
    times = table.columns[column]
    if times.size == 0:
        msg = f"{path}: no data rows after the header; nothing to convert"
        raise InputError(msg)
    bad = np.flatnonzero(~np.isfinite(times))
    if bad.size:
        row = int(bad[0])
        msg = (
            f"{path}: line {table.line_of_row(row)}, column {column!r}: "
            f"{float(times[row])!r} is not a finite number"
        )
        raise InputError(msg)
    check_values(times, TIME_S, lambda i: f"{path}: line {table.line_of_row(i)}, column {column!r}")
    return times, table.line_of_row
