"""The lines of a CSV file as they are in it, byte for byte: header and chosen data rows.

Points that a pipeline cannot process are written unchanged to a rejected file; for a
CSV input "unchanged" means the input's own lines, not the values re-formatted (a time
``1300000000.123456789`` has more digits than a float64 holds, ``1.50`` would come
back as ``1.5``): so that a user can find each row in the input, and the rejected
file can be read again as the input was. `csv_header_line` gives the input's header
line, `csv_slice_lines` the lines of chosen data rows of a slice
(`kinsync.io.points.TableSlice`), and `CsvLineWriter` writes them, atomically.

Data rows are the file's non-empty lines, as `kinsync.io.points` counts them (an empty
line or one holding only a carriage return is skipped); no row holds a line break.
"""

from __future__ import annotations

from contextlib import ExitStack
from pathlib import Path
from types import TracebackType
from typing import IO, Any

import numpy as np

from kinsync._typing import BoolArray
from kinsync.errors import InputError
from kinsync.io.atomic import atomic_path, finish_then_publish
from kinsync.io.points import TableLayout, TableSlice

__all__ = ["CsvLineWriter", "csv_header_line", "csv_slice_lines"]

_LF, _CR = 10, 13


def csv_header_line(path: Path) -> bytes:
    """The first line of a CSV file, its line end included (one is added if it has none).

    Raises
    ------
    InputError
        An unreadable file.
    """
    try:
        with Path(path).open("rb") as fh:
            line = fh.readline()
    except OSError as err:
        msg = f"{path}: cannot read ({err})"
        raise InputError(msg) from err
    return line if line.endswith(b"\n") else line + b"\n"


def csv_slice_lines(layout: TableLayout, sl: TableSlice, rows: BoolArray) -> bytes:
    """The lines of the chosen data rows of a CSV slice, as they are in the file.

    Parameters
    ----------
    layout : TableLayout
        The CSV's layout (`kinsync.io.points.plan_table_slices`).
    sl : TableSlice
        The slice.
    rows : ndarray of bool, shape (``sl.n_rows``,)
        The slice's data rows to give.

    Returns
    -------
    bytes
        Those rows' lines in file order, each with its own line end (a line feed is
        added to a last line that has none).

    Raises
    ------
    InputError
        The file no longer has the slice's rows (it changed since it was planned), an
        unreadable file.
    ValueError
        ``rows`` of another shape.
    """
    path = layout.path
    if rows.shape != (sl.n_rows,):
        msg = f"rows: expected shape ({sl.n_rows},), got {rows.shape}"
        raise ValueError(msg)
    try:
        with path.open("rb") as fh:
            fh.seek(sl.byte_start)
            data = fh.read(sl.byte_end - sl.byte_start)
    except OSError as err:
        msg = f"{path}: cannot read ({err})"
        raise InputError(msg) from err
    arr = np.frombuffer(data, dtype=np.uint8)
    ends = np.flatnonzero(arr == _LF) + 1  # each line's end, its line feed included
    if arr.size and arr[-1] != _LF:
        ends = np.append(ends, arr.size)
    starts = np.zeros_like(ends)
    starts[1:] = ends[:-1]
    has_lf = arr[ends - 1] == _LF
    content = ends - starts - has_lf  # bytes before the line feed
    nonempty = np.flatnonzero((content > 1) | ((content == 1) & (arr[starts] != _CR)))
    if nonempty.size != sl.n_rows:
        msg = (
            f"{path}: lines {sl.first_line}.. hold {nonempty.size} data rows where "
            f"{sl.n_rows} were read; the file changed while it was read"
        )
        raise InputError(msg)
    chosen = nonempty[rows]
    if not chosen.size:
        return b""
    edges = np.zeros(arr.size + 1, dtype=np.int8)
    edges[starts[chosen]] = 1
    edges[ends[chosen]] -= 1
    out = arr[np.cumsum(edges[:-1]) > 0].tobytes()
    return out if has_lf[chosen[-1]] else out + b"\n"


class CsvLineWriter:
    """Write a CSV file from lines given as bytes, atomically (a context manager).

    Parameters
    ----------
    path : Path
        The output file, written under a temporary name and renamed onto ``path`` only
        when the ``with`` block ends without an exception.
    header : bytes
        Its first line, line end included (`csv_header_line`).
    """

    def __init__(self, path: Path, header: bytes) -> None:
        self.path = Path(path)
        self._header = header
        self._stack: ExitStack | None = None
        self._file: IO[bytes] | None = None

    def __enter__(self) -> CsvLineWriter:
        stack = ExitStack()
        tmp = stack.enter_context(atomic_path(self.path))
        try:
            self._file = tmp.open("wb")
            self._file.write(self._header)
        except BaseException as err:
            stack.__exit__(type(err), err, err.__traceback__)
            raise
        self._stack = stack
        return self

    def write(self, lines: bytes | Any) -> None:
        """Append data lines (bytes, or a buffer), each ended by its line end."""
        if self._file is None:
            msg = f"{self.path}: CsvLineWriter.write called outside its 'with' block"
            raise InputError(msg)
        self._file.write(lines)

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        stack, self._stack = self._stack, None
        if stack is None:
            return
        file, self._file = self._file, None

        def finish() -> None:
            if file is not None:
                file.close()

        finish_then_publish(stack, finish, exc_type, exc, tb)
