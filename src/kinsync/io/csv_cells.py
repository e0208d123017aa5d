"""The first bad row of a CSV point table, named for the user (file line and column).

pyarrow's CSV reader says a row is bad but not which: the readers of
`kinsync.io.points` read the file (or a slice's bytes) again with the ``csv`` module to
name it.
"""

from __future__ import annotations

import csv
import io
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from kinsync.errors import InputError
from kinsync.io.sanity import not_utf8_cell
from kinsync.io.text_lines import cut_line_hint

__all__ = [
    "DATE_TEXT",
    "PARSE_ERROR",
    "blank_row_error",
    "comment_hint",
    "decimal_comma_hint",
    "first_bad_cell",
    "is_date_text",
    "locate_bad_csv_cell",
    "quoted_line_break",
]

_COMMENT_MARKS = ("#", "//", ";")
_WHOLE_NUMBER = re.compile(r"[+-]?[0-9]+")

PARSE_ERROR = "CSV parse error"  # pyarrow's message for a row with another field count


def blank_row_error(path: Path, line: int, cells: Sequence[str]) -> InputError | None:
    """The error for a row of blank cells (``,,,,``, spaces or a tab), None for another row.

    A truly empty line is skipped by every reader; a spreadsheet's empty row (only
    separators) or a line of spaces is not empty to the CSV parser, which counts it as a
    row whose cells are not numbers.

    Parameters
    ----------
    path : Path
        The file, for the message.
    line : int
        The row's file line (1-based).
    cells : sequence of str
        The row's cells as the ``csv`` module read them (none for an empty line).

    Returns
    -------
    InputError or None
        The error naming the line, or None when the row is empty or holds a value.
    """
    if not cells or any(c.strip() for c in cells):
        return None
    if len(cells) == 1:  # a one-column table's empty value is written '""'
        if not cells[0]:
            return None
        return InputError(f"{path}: line {line}: only spaces or tabs, no value; remove the line")
    return InputError(
        f"{path}: line {line}: a row of empty cells (only commas, as a spreadsheet writes "
        "for an empty row), no value; remove the line"
    )


def comment_hint(cells: Sequence[str]) -> str:
    """``"; it looks like a comment ..."`` for a row starting with ``#``, ``//`` or ``;``.

    Parameters
    ----------
    cells : sequence of str
        The row's cells.

    Returns
    -------
    str
        Words to add to the message about the row, or ``""``.
    """
    first = cells[0].lstrip() if cells else ""
    if not first.startswith(_COMMENT_MARKS):
        return ""
    return "; it looks like a comment, which kinsync does not read in data: remove the line"


_DATE_TIME = re.compile(r"\s*\d{4}-\d{2}-\d{2}[T ]\d{2}:\d{2}.*")

DATE_TEXT = (
    "is a date and time as text, not a number: kinsync reads times as numbers of seconds "
    "(a GPS time as seconds since 1980-01-06); convert the whole column (in Python, "
    "kinsync.clock.utc_to_gps_s takes UTC seconds since 1970)"
)
"""What a cell holding an ISO-8601 date and time is told (it said only 'not a number')."""


def is_date_text(cell: str) -> bool:
    """Whether a cell holds a date and time as text (``2024-05-17T16:53:02Z``)."""
    return _DATE_TIME.fullmatch(cell) is not None


def _not_a_number(cell: str) -> tuple[str, str]:
    """What a cell that is not a number is, and what to do (for `first_bad_cell`)."""
    if not cell:
        return "empty cell", "; fix or remove the row"
    if is_date_text(cell):  # a whole column of them: not a row to fix
        return f"{cell[:80]!r} {DATE_TEXT}", ""
    return f"{cell[:80]!r} is not a number", "; fix or remove the row"


def decimal_comma_hint(cells: Sequence[str], width: int) -> str:
    """``"; numbers with a decimal comma? ..."`` for a row split into too many integers.

    A value written with a decimal comma (``46,8``) is two fields to a comma-separated
    reader: a row of more fields than the header's ``width``, each a whole number, is
    most likely that.

    Parameters
    ----------
    cells : sequence of str
        The row's cells.
    width : int
        The header's number of columns.

    Returns
    -------
    str
        Words to add to the message about the row, or ``""``.
    """
    if len(cells) <= width or not all(_WHOLE_NUMBER.fullmatch(c.strip()) for c in cells):
        return ""
    return (
        "; numbers written with a decimal comma? kinsync reads a point as the decimal "
        "mark: export the file with points (and commas between the columns)"
    )


def locate_bad_csv_cell(path: Path, required: Sequence[str]) -> InputError | None:
    """Scan a CSV for the first bad row (`first_bad_cell`)."""
    with path.open(newline="", encoding="utf-8-sig", errors="surrogateescape") as fh:
        reader = csv.reader(fh)
        try:
            header = [c.strip() for c in next(reader)]
        except (csv.Error, StopIteration) as err:
            return InputError(f"{path}: cannot read the header ({err})")
        return first_bad_cell(path, reader, header, required, first_line=0)


def first_bad_cell(
    path: Path,
    reader: Any,
    header: Sequence[str],
    required: Sequence[str],
    *,
    first_line: int,
) -> InputError | None:
    """First bad row read by ``reader`` (a ``csv.reader``), or None.

    Bad: a required cell empty or not a number, or a row with another number of fields
    than the header. The reader's line 1 is file line ``first_line + 1``. A byte that
    is not UTF-8 in any cell (text decoded with ``errors="surrogateescape"``) and a line
    the ``csv`` module cannot read are bad too.
    """
    cols = [(name, list(header).index(name)) for name in required]
    while True:
        try:
            cells = next(reader)
        except StopIteration:
            return None
        except csv.Error as err:
            line = first_line + reader.line_num
            return InputError(f"{path}: line {line}: cannot read as CSV ({err})")
        if (blank := blank_row_error(path, first_line + reader.line_num, cells)) is not None:
            return blank
        if not cells:
            continue
        for cell in cells:
            if (bad := not_utf8_cell(path, first_line + reader.line_num, cell)) is not None:
                return bad
        if len(cells) != len(header):
            msg = (
                f"{path}: line {first_line + reader.line_num}: {len(cells)} "
                f"field(s) where the header has {len(header)}; fix the row (a comma too many "
                "or too few, or a value holding a comma that needs quotes)"
                f"{comment_hint(cells)}{decimal_comma_hint(cells, len(header))}"
                f"{cut_line_hint(path, first_line + reader.line_num)}"
            )
            return InputError(msg)
        for name, i in cols:
            cell = cells[i].strip() if i < len(cells) else ""
            try:
                float(cell)
            except ValueError:
                what, advice = _not_a_number(cell)
            else:
                # Python reads '1_000', Arabic-Indic or full-width digits and a no-break
                # space; the CSV parser does not (and named the row by its own count).
                if cells[i].isascii() and "_" not in cell:
                    continue
                what = (
                    f"{cell[:80]!r} is not a plain number (digits 0-9, a point, a sign, an "
                    "exponent; no '_', other digits or spaces)"
                )
                advice = "; fix or remove the row"
            msg = (
                f"{path}: line {first_line + reader.line_num}, column "
                f"{name!r}: {what}{advice}"
                f"{comment_hint(cells)}{cut_line_hint(path, first_line + reader.line_num)}"
            )
            return InputError(msg)


def quoted_line_break(path: Path, data: bytes, line: int) -> InputError | None:
    """The error for a line that ends inside a quoted value, None for one that does not.

    A line with an odd number of quote characters ends inside quotes when its quotes
    open and close values (``"two`` then ``lines"`` on the next line), but not when one
    stands inside an unquoted value (``12"`` for inches): the ``csv`` module reads the
    line alone to tell.

    Parameters
    ----------
    path : Path
        The CSV file, for the message.
    data : bytes
        The line, its line end included.
    line : int
        Its file line (1-based), for the message.

    Returns
    -------
    InputError or None
        The error naming the line and saying what to do, or None.
    """
    text = data.decode("utf-8", errors="surrogateescape")
    try:
        cells = next(csv.reader(io.StringIO(text, newline="")), [])
    except csv.Error:  # a NUL byte: the readers name it
        return None
    if not any("\n" in cell or "\r" in cell for cell in cells):
        return None
    return InputError(
        f"{path}: line {line}: a quoted value holds a line break (the line ends inside "
        "quotes), which kinsync does not read; remove the line breaks from the values, "
        "or close the quote"
    )
