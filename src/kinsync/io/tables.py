"""Numeric CSV tables with a header row.

A fast path reads the whole file with numpy; if that fails, a second pass finds the
first bad cell and reports its line and column, so a user can fix the file.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from kinsync._typing import FloatArray
from kinsync.errors import InputError

__all__ = ["NumericTable", "read_numeric_csv", "write_numeric_csv"]


@dataclass(frozen=True, eq=False)
class NumericTable:
    """Columns of a numeric CSV file.

    Attributes
    ----------
    source : str
        File the table came from (for messages).
    columns : dict of str to ndarray, shape (N,)
        Every column of the file, by header name, float64.
    """

    source: str
    columns: dict[str, FloatArray]

    @property
    def n_rows(self) -> int:
        """Number of data rows."""
        return len(next(iter(self.columns.values()))) if self.columns else 0

    def line_of_row(self, row: int) -> int:
        """File line number (1-based, header = line 1) of a 0-based data row."""
        return row + 2


def _locate_bad_cell(path: Path, header: list[str]) -> InputError:
    with path.open(newline="", encoding="utf-8") as fh:
        reader = csv.reader(fh)
        next(reader)
        for line_no, row in enumerate(reader, start=2):
            if not row or all(not c.strip() for c in row):
                continue
            if len(row) != len(header):
                return InputError(
                    f"{path}: line {line_no} has {len(row)} fields, the header has {len(header)}"
                )
            for name, cell in zip(header, row, strict=True):
                try:
                    float(cell)
                except ValueError:
                    return InputError(
                        f"{path}: line {line_no}, column {name!r}: {cell!r} is not a number"
                    )
    return InputError(f"{path}: cannot read as a numeric CSV table")


def read_numeric_csv(
    path: Path, required: Sequence[str], optional: Sequence[str] = ()
) -> NumericTable:
    """Read a comma-separated numeric table with a header row.

    Parameters
    ----------
    path : Path
        CSV file.
    required : sequence of str
        Columns that must be present.
    optional : sequence of str
        Columns read when present (others are kept too; listed for documentation).

    Raises
    ------
    InputError
        Missing file, empty file, missing required columns (listing what is there),
        duplicated column names, a non-numeric cell (line and column), ragged rows.
    """
    del optional  # every column is returned; the argument documents intent at call sites
    path = Path(path)
    try:
        with path.open(newline="", encoding="utf-8") as fh:
            header_row = next(csv.reader(fh), None)
    except FileNotFoundError as err:
        msg = f"{path}: file not found"
        raise InputError(msg) from err
    except (OSError, UnicodeDecodeError) as err:
        msg = f"{path}: cannot read ({err})"
        raise InputError(msg) from err
    if not header_row:
        msg = f"{path}: empty file; expected a header row with {', '.join(required)}"
        raise InputError(msg)
    header = [h.strip() for h in header_row]
    dupes = sorted({h for h in header if header.count(h) > 1})
    if dupes:
        msg = f"{path}: duplicated column(s) {dupes} in the header"
        raise InputError(msg)
    missing = [c for c in required if c not in header]
    if missing:
        msg = f"{path}: missing column(s) {missing}; the header has {header}"
        raise InputError(msg)
    try:
        data = np.loadtxt(path, delimiter=",", skiprows=1, dtype=np.float64, ndmin=2)
    except ValueError as err:
        raise _locate_bad_cell(path, header) from err
    if data.size == 0:
        data = np.empty((0, len(header)))
    if data.shape[1] != len(header):
        raise _locate_bad_cell(path, header)
    return NumericTable(
        source=str(path), columns={name: data[:, i].copy() for i, name in enumerate(header)}
    )


def write_numeric_csv(path: Path, columns: dict[str, FloatArray]) -> None:
    """Write columns as CSV with a header, floats with ``repr`` precision (exact round trip).

    The file appears only when complete (temporary name, then rename).
    """
    from kinsync.io.atomic import atomic_path  # noqa: PLC0415  (avoid an import cycle)

    names = list(columns)
    arrays = [np.asarray(columns[n], dtype=np.float64) for n in names]
    n = {a.shape for a in arrays}
    if len(n) != 1 or len(next(iter(n))) != 1:
        msg = f"write_numeric_csv: columns must be 1-D of one length, got shapes {sorted(n)}"
        raise InputError(msg)
    with atomic_path(Path(path)) as tmp, tmp.open("w", encoding="utf-8", newline="") as fh:
        fh.write(",".join(names) + "\n")
        for row in zip(*(a.tolist() for a in arrays), strict=True):
            fh.write(",".join(repr(v) if math.isfinite(v) else "nan" for v in row) + "\n")
