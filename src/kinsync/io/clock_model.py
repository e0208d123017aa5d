"""Clock files: the model JSON (``model.json``), the PPS log, and time columns of any CSV.

``model.json`` holds every field `kinsync.clock.ClockModel` needs, floats written with
``repr`` precision so a round trip is exact::

    {"kind": "kinsync clock model", "version": 1,
     "formula": "t_gps_s = reference_gps_s + (t_local_s - reference_local_s)
                 * (1 + drift_ppm * 1e-6)",
     "reference_local_s": ..., "reference_gps_s": ..., "drift_ppm": ..., "offset_s": ...,
     "span_local_s": [first, last],
     "piecewise": null | {"knots_local_s": [...], "knots_gps_s": [...]},
     "fit": {...}}          # optional: uncertainties and fault counts, for reading

``pps.csv`` has a column ``t_local_s`` (one detected edge per row, increasing).

`read_time_column` / `write_with_column` read any CSV keeping every cell as text and
write it back with one more column, so converting a time column loses nothing.
"""

from __future__ import annotations

import csv
import json
import math
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from kinsync._typing import FloatArray
from kinsync.clock import ClockFit, ClockModel, clock_model_from_document
from kinsync.errors import InputError
from kinsync.io.atomic import atomic_path, atomic_write_text
from kinsync.io.tables import read_numeric_csv

__all__ = [
    "TextTable",
    "read_clock_model",
    "read_pps_csv",
    "read_time_column",
    "write_clock_model",
    "write_with_column",
]


def write_clock_model(model: ClockModel, path: Path, fit: ClockFit | None = None) -> None:
    """Write a clock model as JSON, atomically (with the fit's summary when given)."""
    doc = model.as_document()
    if fit is not None:
        summary = fit.as_document()
        doc["fit"] = {
            key: None
            if isinstance(summary[key], float) and not math.isfinite(summary[key])
            else summary[key]
            for key in (
                "offset_std_s",
                "drift_std_ppm",
                "residual_rms_s",
                "convention",
                "baud",
                "zda_delay_s",
                "n_pulses",
                "n_missing",
                "n_spurious",
                "n_wrong_zda",
                "n_rejected_messages",
            )
        }
    atomic_write_text(Path(path), json.dumps(doc, indent=2, allow_nan=False) + "\n")


def read_clock_model(path: Path) -> ClockModel:
    """Read a clock model JSON file; errors name the file.

    Raises
    ------
    InputError
        Missing or unreadable file, invalid JSON (with line and column), missing or
        invalid fields.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError as err:
        msg = f"{path}: clock model file not found; write one with kinsync clock fit --model-out"
        raise InputError(msg) from err
    except (OSError, UnicodeDecodeError) as err:
        msg = f"{path}: cannot read clock model ({err})"
        raise InputError(msg) from err
    try:
        doc: Any = json.loads(text)
    except json.JSONDecodeError as err:
        msg = f"{path}: line {err.lineno}, column {err.colno}: not valid JSON ({err.msg})"
        raise InputError(msg) from err
    return clock_model_from_document(doc, source=str(path))


def read_pps_csv(path: Path) -> FloatArray:
    """Local times of the PPS edges from ``pps.csv`` (column ``t_local_s``).

    Returns
    -------
    ndarray, shape (N,)
        Edge times (s, local clock), strictly increasing.

    Raises
    ------
    InputError
        Missing file or column, no rows, a non-numeric, non-finite, repeated or
        decreasing time (with its line).
    """
    with warnings.catch_warnings():
        # numpy warns on a header-only file; it is reported below as an error.
        warnings.filterwarnings("ignore", message="loadtxt: input contained no data")
        table = read_numeric_csv(Path(path), ["t_local_s"])
    t = table.columns["t_local_s"]
    if len(t) == 0:
        msg = f"{path}: no pulses (the file has a header and no rows)"
        raise InputError(msg)
    bad = np.flatnonzero(~np.isfinite(t))
    if len(bad):
        line = table.line_of_row(int(bad[0]))
        msg = f"{path}: line {line}, column 't_local_s': {t[bad[0]]!r} is not a finite time"
        raise InputError(msg)
    steps = np.flatnonzero(np.diff(t) <= 0.0)
    if len(steps):
        row = int(steps[0]) + 1
        msg = (
            f"{path}: line {table.line_of_row(row)}, column 't_local_s': {t[row]!r} does not "
            f"follow {t[row - 1]!r} on the line before; pulses must be strictly increasing "
            "(sort the file, remove repeated lines)"
        )
        raise InputError(msg)
    return t


@dataclass(frozen=True, eq=False)
class TextTable:
    """A CSV table kept as text, so it can be written back unchanged.

    Attributes
    ----------
    source : str
        File it came from.
    header : tuple of str
        Column names as in the file.
    rows : tuple of tuple of str
        Data rows (blank lines left out), each as long as the header.
    lines : tuple of int
        File line of each row (header = line 1).
    """

    source: str
    header: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]
    lines: tuple[int, ...]


def read_time_column(path: Path, column: str) -> tuple[TextTable, FloatArray]:
    """Read a CSV with a header, keeping every cell, and parse one column as times.

    Parameters
    ----------
    path : Path
        CSV file (comma-separated, header row).
    column : str
        Name of the time column (surrounding spaces in the header ignored).

    Returns
    -------
    table : TextTable
    t_s : ndarray, shape (N,)
        The column as float64 (s).

    Raises
    ------
    InputError
        Missing or unreadable file, empty file, no such column (listing those there),
        a duplicated column name, a row with another number of fields than the header,
        no data rows, or a cell of the column that is not a finite number (with its
        line).
    """
    path = Path(path)
    try:
        with path.open(newline="", encoding="utf-8-sig") as fh:
            records = [(line, row) for line, row in enumerate(csv.reader(fh), start=1)]
    except FileNotFoundError as err:
        msg = f"{path}: file not found"
        raise InputError(msg) from err
    except (OSError, UnicodeDecodeError, csv.Error) as err:
        msg = f"{path}: cannot read as CSV ({err})"
        raise InputError(msg) from err
    records = [(line, row) for line, row in records if row and any(c.strip() for c in row)]
    if not records:
        msg = f"{path}: empty file; expected a header row with a column {column!r}"
        raise InputError(msg)
    header = tuple(records[0][1])
    names = [h.strip() for h in header]
    if names.count(column) != 1:
        what = "appears more than once in" if names.count(column) else "is not in"
        msg = f"{path}: column {column!r} {what} the header {names}; choose it with --column"
        raise InputError(msg)
    col = names.index(column)
    body = records[1:]
    if not body:
        msg = f"{path}: no data rows after the header; nothing to convert"
        raise InputError(msg)
    times = np.empty(len(body))
    for i, (line, row) in enumerate(body):
        if len(row) != len(header):
            msg = f"{path}: line {line} has {len(row)} fields, the header has {len(header)}"
            raise InputError(msg)
        cell = row[col]
        try:
            value = float(cell)
        except ValueError:
            value = math.nan
        if not math.isfinite(value):
            msg = f"{path}: line {line}, column {column!r}: {cell!r} is not a finite number"
            raise InputError(msg)
        times[i] = value
    table = TextTable(
        source=str(path),
        header=header,
        rows=tuple(tuple(row) for _, row in body),
        lines=tuple(line for line, _ in body),
    )
    return table, times


def write_with_column(path: Path, table: TextTable, name: str, values: FloatArray) -> None:
    """Write ``table`` with one more column ``name`` (floats in ``repr`` precision), atomically.

    Every original cell is written back as read; non-finite values are written ``nan``.

    Raises
    ------
    InputError
        The table already has a column ``name``, or ``values`` does not have one value
        per row.
    """
    if name in [h.strip() for h in table.header]:
        msg = f"{table.source}: already has a column {name!r}; choose another output column name"
        raise InputError(msg)
    v = np.asarray(values, dtype=np.float64)
    if v.shape != (len(table.rows),):
        msg = f"{name}: expected {len(table.rows)} values, one per row, got shape {v.shape}"
        raise InputError(msg)
    with atomic_path(Path(path)) as tmp, tmp.open("w", encoding="utf-8", newline="") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow([*table.header, name])
        for row, value in zip(table.rows, v.tolist(), strict=True):
            writer.writerow([*row, repr(value) if math.isfinite(value) else "nan"])
