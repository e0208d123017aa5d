"""The lines of a CSV file as they are in it, byte for byte: header and chosen data rows.

Points that a pipeline cannot process are written unchanged to a rejected file; for a
CSV input "unchanged" means the input's own lines, not the values re-formatted (a time
``1300000000.123456789`` has more digits than a float64 holds, ``1.50`` would come
back as ``1.5``): so that a user can find each row in the input, and the rejected
file can be read again as the input was. `csv_header_line` gives the input's header
line, `csv_slice_lines` the lines of chosen data rows of a slice
(`kinsync.io.points.TableSlice`), and `CsvLineWriter` writes them, atomically.

Data rows are the file's non-empty lines, as `kinsync.io.points` counts them: a line
ends with LF, CRLF or a CR alone (`kinsync.io.text_lines`), an empty line is skipped; no
row holds a line break.
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
from kinsync.io.text_lines import CR, LF, line_end_indices, read_first_line

__all__ = ["CsvLineWriter", "csv_header_line", "csv_slice_lines"]


def csv_header_line(path: Path) -> bytes:
    """The first line of a CSV file, its line end (LF, CRLF or CR) included (LF if none).

    Raises
    ------
    InputError
        An unreadable file.
    """
    try:
        with Path(path).open("rb") as fh:
            line = read_first_line(fh)
    except OSError as err:
        msg = f"{path}: cannot read ({err})"
        raise InputError(msg) from err
    return line if line.endswith((b"\n", b"\r")) else line + b"\n"


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
        Those rows' lines in file order, each with its own line end (LF, CRLF or CR; a
        line feed is added to a last line that has none).

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
    # a slice ends after a line end, so a CR closing it is a line end of its own
    ends = line_end_indices(arr, None) + 1  # each line's end, its line end included
    terminated = np.ones(ends.size, dtype=bool)
    if arr.size and (ends.size == 0 or ends[-1] != arr.size):
        ends = np.append(ends, arr.size)
        terminated = np.append(terminated, False)
    starts = np.zeros_like(ends)
    starts[1:] = ends[:-1]
    last = arr[np.maximum(ends - 1, 0)]
    before = arr[np.maximum(ends - 2, 0)]
    end_bytes = np.where(terminated, 1 + ((last == LF) & (before == CR) & (ends - starts >= 2)), 0)
    nonempty = np.flatnonzero(ends - starts - end_bytes > 0)
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
    return out if terminated[chosen[-1]] else out + b"\n"


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
