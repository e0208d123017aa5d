"""CSV text of a table: numbers bare, text quoted only where it must be (RFC 4180).

pyarrow's CSV writer quotes every string value with ``quoting_style="needed"`` (its
"needed" means "of a type that may need it"), so a float written through its shortest
round-trip text came out as ``"0.1"``. This module writes the text itself, vectorised
with pyarrow compute:

* floats in the shortest text that reads back to the same float64 (pyarrow's float
  formatting), with ``.0`` added to integral values so that ``1.0`` reads back as a
  float: every value comes back exactly (NaN is written ``nan``); nulls as an empty
  field;
* integers and booleans (``true``/``false``) as pyarrow writes them, never quoted;
* text (and any other type, through its pyarrow text form) bare, or between double
  quotes with inner quotes doubled when it holds a comma, a double quote, a carriage
  return or a line feed; nulls as an empty field;
* a one-column table writes an empty value as ``""``, so that no data line is empty
  (readers skip empty lines).

Lines end with a line feed; the header names are quoted by the same rule.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc

from kinsync.errors import InputError

__all__ = ["csv_header_bytes", "csv_rows_bytes", "float_text"]

_NEEDS_QUOTES = r'[",\r\n]'


def _large(text: str) -> Any:
    return pa.scalar(text, type=pa.large_string())


def float_text(col: Any) -> Any:
    """A float column as text: shortest round-trip digits, always with ``.``, ``e`` or a name.

    pyarrow's float -> string cast gives the shortest text that reads back to the same
    value (``0.1``, ``1e-7``, ``1.23456789012e+11``), but integral values without a
    point (``1``); those get ``.0`` so that the column reads back as floats. Nulls stay
    null (written as an empty field, which reads back as null: NaN is ``nan``).
    """
    text = pc.cast(col, pa.string())
    integral = pc.utf8_is_digit(pc.utf8_ltrim(text, "-"))  # no ".", "e", "nan", "inf"
    return pc.if_else(integral, pc.binary_join_element_wise(text, ".0", ""), text)


def _quoted(text: Any, *, empty_too: bool) -> Any:
    """Text values, each quoted (inner quotes doubled) when it needs to be."""
    text = pc.fill_null(text, _large(""))
    needs = pc.match_substring_regex(text, _NEEDS_QUOTES)
    if empty_too:
        needs = pc.or_(needs, pc.equal(pc.utf8_length(text), 0))
    if not pc.any(needs).as_py():
        return text
    doubled = pc.replace_substring(text, '"', '""')
    quoted = pc.binary_join_element_wise(_large('"'), doubled, _large('"'), _large(""))
    return pc.if_else(needs, quoted, text)


def _column_text(name: str, col: Any, *, single: bool) -> Any:
    """One column as large_string CSV fields."""
    kind = col.type
    if pa.types.is_floating(kind) or pa.types.is_integer(kind) or pa.types.is_boolean(kind):
        text = float_text(col) if pa.types.is_floating(kind) else col
        return pc.fill_null(pc.cast(text, pa.large_string()), _large('""' if single else ""))
    if not (pa.types.is_string(kind) or pa.types.is_large_string(kind)):
        try:
            col = pc.cast(col, pa.large_string())
        except (pa.ArrowException, TypeError, ValueError) as err:
            msg = f"column {name!r}: cannot write type {kind} to CSV ({err})"
            raise InputError(msg) from err
    return _quoted(pc.cast(col, pa.large_string()), empty_too=single)


def csv_header_bytes(names: Sequence[str]) -> bytes:
    """The header line (a line feed ended) for these column names, quoted where needed."""
    fields = _quoted(pa.array(list(names), type=pa.large_string()), empty_too=len(names) == 1)
    return (",".join(fields.to_pylist()) + "\n").encode("utf-8")


def csv_rows_bytes(table: Any) -> Any:
    """The data lines of a pyarrow table as CSV bytes (a buffer), one line per row.

    Parameters
    ----------
    table : pyarrow.Table
        Any columns; float columns may already be text (`float_text`), taken as such.

    Returns
    -------
    pyarrow.Buffer
        The bytes, every line ended by a line feed; empty for a table without rows or
        columns.

    Raises
    ------
    InputError
        A column of a type that has no text form.
    """
    if table.num_rows == 0 or table.num_columns == 0:
        return pa.py_buffer(b"")
    single = table.num_columns == 1
    fields = [
        _column_text(name, table.column(name).combine_chunks(), single=single)
        for name in table.column_names
    ]
    joined = fields[0] if single else pc.binary_join_element_wise(*fields, _large(","))
    lines = pc.binary_join_element_wise(joined, _large(""), _large("\n"))  # each line + "\n" + ""
    _, offsets, data = lines.buffers()
    ends = np.frombuffer(offsets, dtype=np.int64)
    first, last = int(ends[lines.offset]), int(ends[lines.offset + len(lines)])
    return data.slice(first, last - first)
