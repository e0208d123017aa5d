"""Where a point of a file is, in the words a user finds it by.

Readers and pipelines count the points of a file from 0, as arrays do; a user opens the
file in an editor (CSV: it numbers lines from 1, the header is line 1) or a viewer
(Parquet, LAS: rows or points counted from 1). `point_position` turns a 0-based data
row into that: ``line 3`` for a CSV, ``row 2 of 2`` for a Parquet table, ``point 2 of
2`` for a LAS/LAZ (or any other point) file. Every message that names a point of an
input file says it this way.

CSV data rows are the file's non-empty lines, as `kinsync.io.points` counts them (an
empty line or one holding only a carriage return is skipped).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

__all__ = ["csv_line_of_row", "point_position", "position_span"]

_LF, _CR = 10, 13
_NUMBER = re.compile(r"^(\D*)(\d+)(.*)$")  # "row 3 of 9": "row ", "3", " of 9"
_BLOCK_BYTES = 1 << 24


def _header_bytes(path: Path) -> int:
    with path.open("rb") as fh:
        return len(fh.readline())


def csv_line_of_row(
    path: Path, row: int, *, byte_start: int | None = None, first_line: int = 2
) -> int | None:
    """File line (1-based, header = line 1) of a CSV's data row ``row`` (0-based).

    Parameters
    ----------
    path : Path
        The CSV.
    row : int
        Data row, counted from the line at ``byte_start`` (its first non-empty line is
        row 0).
    byte_start : int, optional
        Byte offset of a line start to count from (a slice's ``byte_start``); default
        just after the header.
    first_line : int
        File line at ``byte_start`` (2 after the header).

    Returns
    -------
    int or None
        The line, or None when the file has fewer rows or cannot be read.
    """
    path = Path(path)
    try:
        start = _header_bytes(path) if byte_start is None else byte_start
        with path.open("rb") as fh:
            fh.seek(start)
            line_no, seen, prev, carry = first_line, -1, -1, 0
            # carry: bytes of the current line seen in earlier blocks (capped at 2)
            while True:
                buf = fh.read(_BLOCK_BYTES)
                if not buf:
                    break
                arr = np.frombuffer(buf, dtype=np.uint8)
                nl = np.flatnonzero(arr == _LF)
                if nl.size:
                    length = np.diff(nl, prepend=-1) - 1
                    length[0] += carry
                    before = np.where(nl > 0, arr[np.maximum(nl - 1, 0)], prev)
                    nonempty = ~((length == 0) | ((length == 1) & (before == _CR)))
                    cum = seen + np.cumsum(nonempty)
                    hit = np.flatnonzero(nonempty & (cum == row))
                    if hit.size:
                        return line_no + int(hit[0])
                    seen = int(cum[-1])
                    line_no += int(nl.size)
                    carry = min(int(arr.size - nl[-1] - 1), 2)
                else:
                    carry = min(carry + int(arr.size), 2)
                prev = int(arr[-1])
    except OSError:
        return None
    last_nonempty = carry > 1 or (carry == 1 and prev != _CR)
    return line_no if last_nonempty and seen + 1 == row else None


def point_position(
    path: Path,
    row: int,
    total: int | None,
    *,
    byte_start: int | None = None,
    first_line: int = 2,
    first_row: int = 0,
) -> str:
    """A point of a file as a user finds it: ``line N``, ``row N of M`` or ``point N of M``.

    Parameters
    ----------
    path : Path
        The file; its suffix says how its points are counted: ``.csv`` by file line
        (1-based, header = line 1), ``.parquet`` by row, anything else (LAS, LAZ) by
        point, both from 1 and with the file's count.
    row : int
        The point's 0-based data row (point) in the file.
    total : int or None
        Data rows (points) in the file (None: not said).
    byte_start, first_line, first_row : int, optional
        CSV: a place to count lines from, the start of the line holding data row
        ``first_row`` and its file line (a slice's ``byte_start``, ``first_line`` and
        ``first_row``), so that the file is not read from its start.
    """
    suffix = Path(path).suffix.lower()
    if suffix == ".csv":
        if byte_start is None:
            line = csv_line_of_row(path, row)
        else:
            line = csv_line_of_row(
                path, row - first_row, byte_start=byte_start, first_line=first_line
            )
        if line is not None:
            return f"line {line}"
    what = {".csv": "data row", ".parquet": "row"}.get(suffix, "point")
    return f"{what} {row + 1}" + ("" if total is None else f" of {total}")


def position_span(first: str, last: str) -> str:
    """Two positions of `point_position` as one span: ``lines 2..1001``, ``rows 1..9 of 9``."""
    a, b = _NUMBER.match(first), _NUMBER.match(last)
    if first == last or a is None or b is None:
        return first if first == last else f"{first} to {last}"
    return f"{a.group(1).rstrip()}s {a.group(2)}..{b.group(2)}{a.group(3)}"
