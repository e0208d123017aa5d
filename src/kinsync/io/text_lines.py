"""Line ends of a text file read as bytes, and a CSV's header row, as every reader sees them.

A line ends with a line feed (LF), a carriage return and a line feed (CRLF), or a
carriage return alone (CR: old Mac files, some loggers). Python's ``csv`` module (on a
file opened with ``newline=""``) and pyarrow's CSV reader both end lines so, and the
readers that cut a file by bytes (`kinsync.io.points` slices, `kinsync.io.csv_lines`)
must find the same lines, or a CR-only file reads as a header and no data row.
`line_end_indices` finds them in a block of bytes, `read_first_line` gives a file's
first line with its end, and `csv_header_row` reads a CSV's header row without
decoding the rest of the file, so that a byte that is not UTF-8 further on is named
by its own line (by the reader of the data rows), not blamed on the header.

`warn_if_unended` is the one check every text reader makes of a file's end: a file cut
mid-write (a logger stopped, a copy broken off) ends mid-number without a line end, and
its last number reads as complete (yaw 17 for 179.999983). It warns, naming the last line;
it does not refuse, as many tools write no final line end.
"""

from __future__ import annotations

import csv
import warnings
from pathlib import Path
from typing import IO, Any

import numpy as np

from kinsync.errors import InputError, KinsyncWarning
from kinsync.io.sanity import not_utf8_cell

__all__ = [
    "CR",
    "LF",
    "csv_header_row",
    "cut_line_hint",
    "line_end_indices",
    "read_first_line",
    "refuse_other_separator",
    "unended_last_line",
    "warn_if_unended",
]

LF, CR = 10, 13
_BLOCK_BYTES = 1 << 16
_COUNT_BLOCK_BYTES = 1 << 22
_BLANK = b" \t,;"  # a last line of these only holds no value to cut


def line_end_indices(arr: np.ndarray[Any, Any], next_byte: int | None) -> np.ndarray[Any, Any]:
    """Indices of the bytes that end a line: every LF, and every CR not followed by LF.

    Parameters
    ----------
    arr : ndarray of uint8, shape (N,)
        A block of the file.
    next_byte : int or None
        The file's byte after the block (None at the end of the file): it says whether
        a CR that ends the block is the first half of a CRLF.

    Returns
    -------
    ndarray of int64, shape (M,)
        Increasing indices into ``arr``; a CRLF counts once, at its LF.
    """
    if arr.size == 0:
        return np.empty(0, dtype=np.int64)
    lf = arr == LF
    lf_after = np.empty_like(lf)
    lf_after[:-1] = lf[1:]
    lf_after[-1] = next_byte == LF
    return np.flatnonzero(lf | ((arr == CR) & ~lf_after)).astype(np.int64)


def read_first_line(fh: IO[bytes]) -> bytes:
    """The first line of a binary file from its current position, its line end included.

    The line end is LF, CRLF or CR (`line_end_indices`); a file without one gives all
    its bytes.
    """
    data = b""
    searched = 0
    while True:
        block = fh.read(_BLOCK_BYTES)
        data += block
        ends = [i for i in (data.find(b"\n", searched), data.find(b"\r", searched)) if i >= 0]
        if ends:
            end = min(ends)
            if data[end] == LF:
                return data[: end + 1]
            if end + 1 < len(data):  # a CR: CRLF, or a CR alone
                return data[: end + 2] if data[end + 1] == LF else data[: end + 1]
            if not block:
                return data
            searched = end
            continue
        if not block:
            return data
        searched = len(data)


def csv_header_row(path: Path) -> list[str] | None:
    """The first row of a CSV file (a BOM skipped), None for an empty file.

    Only what the header needs is decoded: a byte that is not UTF-8 on a later line is
    left to the reader of the data rows, which names its line.

    Raises
    ------
    InputError
        An unreadable file, a header the ``csv`` module cannot read, or a byte in the
        header that is not UTF-8 (naming the line).
    """
    try:
        with path.open(newline="", encoding="utf-8-sig", errors="surrogateescape") as fh:
            reader = csv.reader(fh)
            row = next(reader, None)
            line = reader.line_num
    except (OSError, csv.Error) as err:
        msg = f"{path}: cannot read the header ({err})"
        raise InputError(msg) from err
    for cell in row or []:
        if (bad := not_utf8_cell(path, line, cell)) is not None:
            raise bad
    refuse_other_separator(path, row)
    return row


_OTHER_SEPARATORS = ((";", "semicolon"), ("\t", "tab"))
_SHOWN_CHARS = 80


def refuse_other_separator(path: Path, row: list[str] | None) -> None:
    """Refuse a header of one column that semicolons or tabs split into several.

    Parameters
    ----------
    path : Path
        The file, for the message.
    row : list of str or None
        Its header row as the ``csv`` module read it with commas (None: an empty file).

    Raises
    ------
    InputError
        A header of one cell holding a semicolon or a tab.

    Notes
    -----
    Such a file was written with another separator (a spreadsheet set to a decimal comma
    writes semicolons): read with commas, its whole header is one column name, and a
    reader would go on to blame the missing columns or the user's column map.
    """
    if row is None or len(row) != 1:
        return
    header = row[0]
    for separator, name in _OTHER_SEPARATORS:
        if separator in header:
            shown = header if len(header) <= _SHOWN_CHARS else header[:_SHOWN_CHARS] + "..."
            msg = (
                f"{path}: line 1: the file looks {name}-separated (its header {shown!r} "
                f"has no comma); use commas: kinsync reads comma-separated files with a "
                "point as the decimal mark"
            )
            raise InputError(msg)


def unended_last_line(path: Path) -> int | None:
    """The file line (1-based) of a last line that holds text but no line end after it.

    Parameters
    ----------
    path : Path
        A text file.

    Returns
    -------
    int or None
        The last line's number when the file ends without a line end (LF, CRLF or CR)
        after a line holding something other than blanks and separators; None for a
        file that ends with one, an empty file, or a file that cannot be read (its
        reader says why).
    """
    try:
        with Path(path).open("rb") as fh:
            size = fh.seek(0, 2)
            if size == 0:
                return None
            start = max(0, size - _BLOCK_BYTES)
            fh.seek(start)
            tail = fh.read()
            if tail[-1:] in (b"\n", b"\r"):
                return None
            last = tail[max(tail.rfind(b"\n"), tail.rfind(b"\r")) + 1 :]
            if not last.strip(_BLANK):
                return None
            fh.seek(0)
            ends = 0
            block = fh.read(_COUNT_BLOCK_BYTES)
            while block:
                after = fh.read(_COUNT_BLOCK_BYTES)
                arr = np.frombuffer(block, dtype=np.uint8)
                ends += int(line_end_indices(arr, after[0] if after else None).size)
                block = after
    except OSError:
        return None
    return ends + 1


def warn_if_unended(path: Path, *, first_data_line: int = 2) -> None:
    """Warn (`KinsyncWarning`) when a text file ends without a line end after its data.

    A file cut short ends mid-row, its last number read as complete (11.1 for 11.199): the
    warning names the last line to check. Not refused: many tools write no final line end.
    Every text reader (CSV tables, point tables, exports, pass files) calls this.

    Parameters
    ----------
    path : Path
        The file just read (or about to be).
    first_data_line : int
        File line (1-based) of the first data row: a last line before it (a header only)
        is not warned about.
    """
    line = unended_last_line(path)
    if line is None or line < first_data_line:
        return
    warnings.warn(
        f"{path}: the file ends without a line end: if it was cut, its last row is "
        f"incomplete: check line {line}",
        KinsyncWarning,
        stacklevel=1,  # one place: a file read twice is warned about once
    )


def cut_line_hint(path: Path, line: int) -> str:
    """Words to add to an error naming ``line`` when it is a last line without a line end.

    Parameters
    ----------
    path : Path
        The file the error is about.
    line : int
        The file line (1-based) the error names.

    Returns
    -------
    str
        ``"; it is the last line and the file ends without a line end: ..."`` when the
        line may have been cut mid-write, else ``""`` (a failing command prints its
        error only, not the warnings: the error itself must say it).
    """
    if unended_last_line(path) != line:
        return ""
    return (
        "; it is the last line and the file ends without a line end: the file was "
        "probably cut mid-write, remove that line or copy the file again"
    )
