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

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from kinsync._typing import FloatArray
from kinsync.clock import ClockFit, ClockModel
from kinsync.errors import InputError
from kinsync.io.atomic import atomic_write_text
from kinsync.io.sanity import TIME_S, check_values, load_json
from kinsync.io.tables import read_numeric_csv
from kinsync.io.text_lines import cut_line_hint
from kinsync.trajectory_times import backward_step_s

__all__ = [
    "read_clock_model",
    "read_pps_csv",
    "write_clock_model",
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
        Missing or unreadable file, not a small UTF-8 JSON file, invalid JSON (with line
        and column), NaN/Infinity or an integer too large for a float
        (`kinsync.io.sanity.load_json`), missing or invalid fields.
    """
    path = Path(path)
    if not path.exists():
        msg = f"{path}: clock model file not found; write one with kinsync clock fit --model-out"
        raise InputError(msg)
    doc: Any = load_json(path, "clock model file")
    return ClockModel.from_document(doc, source=str(path))


def read_pps_csv(path: Path) -> FloatArray:
    """Local times of the PPS edges from ``pps.csv`` (column ``t_local_s``).

    Returns
    -------
    ndarray, shape (N,)
        Edge times (s, local clock), strictly increasing.

    Raises
    ------
    InputError
        Missing file or column, no rows, a non-numeric, non-finite, implausible
        (`kinsync.io.sanity.TIME_S`), repeated or decreasing time (with its line; a
        backward step of the local clock is told from shuffled lines,
        `kinsync.trajectory_times.backward_step_s`).
    """
    table = read_numeric_csv(Path(path), ["t_local_s"])
    t = table.columns["t_local_s"]
    if len(t) == 0:
        msg = f"{path}: no pulses (the file has a header and no rows)"
        raise InputError(msg)
    check_values(t, TIME_S, lambda i: f"{path}: line {table.line_of_row(i)}, column 't_local_s'")
    steps = np.flatnonzero(np.diff(t) <= 0.0)
    if len(steps):
        row = int(steps[0]) + 1
        step_s = backward_step_s(t, row)
        if step_s is not None:
            before, now = float(t[row - 1]), float(t[row])
            msg = (
                f"{path}: line {table.line_of_row(row)}, column 't_local_s': {now!r} comes "
                f"{before - now:.6g} s before {before!r} on the line before and the pulses "
                "rise again from there: the local clock stepped back by about "
                f"{-step_s:.6g} s there (sorting would mix the two stretches); split the PPS "
                f"and NMEA logs at t_local_s={now!r} and fit each part on its own"
            )
            raise InputError(msg)
        line = table.line_of_row(row)
        msg = (
            f"{path}: line {line}, column 't_local_s': {t[row]!r} does not "
            f"follow {t[row - 1]!r} on the line before; pulses must be strictly increasing "
            f"(sort the file, remove repeated lines){cut_line_hint(Path(path), line)}"
        )
        raise InputError(msg)
    return t
