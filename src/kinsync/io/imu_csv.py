"""IMU CSV files: angular rates and specific forces, or angle and velocity increments.

Two forms are read (chosen by the header; give one, not both):

- **rates** ``t_s,gyro_x_rad_s,gyro_y_rad_s,gyro_z_rad_s,acc_x_m_s2,acc_y_m_s2,acc_z_m_s2``
  — angular rate of the body with respect to inertial space (rad/s) and specific force
  (m/s^2), body frame X forward, Y right, Z down; about ``(0, 0, -9.8)`` m/s^2 when level
  and static.
- **increments** ``t_s,dtheta_x_rad,dtheta_y_rad,dtheta_z_rad,dv_x_m_s,dv_y_m_s,dv_z_m_s``
  — angle (rad) and velocity (m/s) increments accumulated over ``(t[k-1], t[k]]``. They
  are converted at this boundary to mean rates over that interval,
  ``gyro[k] = dtheta[k] / (t[k] - t[k-1])`` (likewise ``acc = dv / dt``). The first row
  has no previous time: its interval is taken as the **median sampling interval** of
  the file.

Other columns are ignored. Times are read as they are (the caller knows the scale).
Errors name the file and the line (header = line 1).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Literal

import numpy as np

from kinsync._typing import FloatArray
from kinsync.errors import InputError
from kinsync.ins.measurements import ImuData
from kinsync.io.gps_week import check_not_future
from kinsync.io.sanity import (
    ACCELERATION_M_S2,
    ANGULAR_RATE_RAD_S,
    TIME_S,
    Span,
    check_columns,
)
from kinsync.io.tables import NumericTable, read_numeric_csv, rows_to_lines, write_numeric_csv

__all__ = ["IMU_INCREMENT_COLUMNS", "IMU_RATE_COLUMNS", "read_imu_csv", "write_imu_csv"]

IMU_RATE_COLUMNS = (
    "t_s",
    "gyro_x_rad_s",
    "gyro_y_rad_s",
    "gyro_z_rad_s",
    "acc_x_m_s2",
    "acc_y_m_s2",
    "acc_z_m_s2",
)
"""Header of the rate form."""

IMU_INCREMENT_COLUMNS = (
    "t_s",
    "dtheta_x_rad",
    "dtheta_y_rad",
    "dtheta_z_rad",
    "dv_x_m_s",
    "dv_y_m_s",
    "dv_z_m_s",
)
"""Header of the increment form."""

ImuForm = Literal["rates", "increments"]

_ANY = Span(-math.inf, math.inf, "", "a number")
_RATE_SPANS = (ANGULAR_RATE_RAD_S,) * 3 + (ACCELERATION_M_S2,) * 3
"""Plausible rates and specific forces (`kinsync.io.sanity`), increments once divided by
their interval."""


def _first_intervals_s(t_s: FloatArray) -> FloatArray:
    """Interval ending at each sample; the first one is the median interval (s)."""
    dt = np.empty_like(t_s)
    diffs = np.diff(t_s)
    dt[1:] = diffs
    dt[0] = np.median(diffs)
    return dt


def _rates(
    table: NumericTable, names: tuple[str, ...], form: ImuForm
) -> tuple[FloatArray, FloatArray]:
    """Angular rates and specific forces (N, 3) of a table, checked finite and plausible.

    Increments are divided by their interval; the spans are checked on the rates they
    give (when the times increase: otherwise `ImuData` names the repeated time).
    """
    c = table.columns

    def where(row: int) -> str:
        return f"{table.source}: line {table.line_of_row(row)}"

    check_columns(c, {"t_s": TIME_S, **dict.fromkeys(names[1:], _ANY)}, where)
    check_not_future(c["t_s"], lambda row: f"{where(row)}, column 't_s'")
    t = c["t_s"]
    first = np.column_stack([c[n] for n in names[1:4]])
    second = np.column_stack([c[n] for n in names[4:7]])
    if form == "increments":
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            dt = _first_intervals_s(t)[:, None]
            first = first / dt
            second = second / dt
    if np.all(np.diff(t) > 0.0):

        def where_rate(row: int) -> str:
            text = " (increment / interval since the row before)" if form == "increments" else ""
            return f"{where(row)}{text}"

        rates = dict(zip(names[1:], [*first.T, *second.T], strict=True))
        check_columns(rates, dict(zip(names[1:], _RATE_SPANS, strict=True)), where_rate)
    return first, second


def read_imu_csv(path: Path) -> ImuData:
    """Read an IMU CSV file (rate or increment form, see the module docstring).

    Parameters
    ----------
    path : Path
        CSV file with a header row.

    Returns
    -------
    ImuData
        Times (s), angular rate (rad/s) and specific force (m/s^2), body frame FRD.

    Raises
    ------
    InputError
        Missing or unreadable file, a header with neither or both forms, or only part
        of one form's columns, a non-numeric cell, fewer than 2 rows, non-finite
        values, an implausible time (a GPS time after today: Unix time,
        `kinsync.io.gps_week.check_not_future`), angular rate or specific force
        (`kinsync.io.sanity`; increments divided by their interval), repeated or
        decreasing times (naming the line; sort the file or drop the repeated records).
    """
    path = Path(path)
    table = read_numeric_csv(path, ("t_s",), IMU_RATE_COLUMNS[1:] + IMU_INCREMENT_COLUMNS[1:])
    c = table.columns
    has_rates = [name in c for name in IMU_RATE_COLUMNS[1:]]
    has_incs = [name in c for name in IMU_INCREMENT_COLUMNS[1:]]
    if any(has_rates) and any(has_incs):
        msg = (
            f"{path}: the header mixes rate columns (gyro_*_rad_s, acc_*_m_s2) and increment "
            "columns (dtheta_*_rad, dv_*_m_s); give one form only"
        )
        raise InputError(msg)
    if not any(has_rates) and not any(has_incs):
        msg = (
            f"{path}: no IMU columns; expected {','.join(IMU_RATE_COLUMNS)} (rates) or "
            f"{','.join(IMU_INCREMENT_COLUMNS)} (increments); the header has {list(table.header)}"
        )
        raise InputError(msg)
    form: ImuForm = "rates" if any(has_rates) else "increments"
    names = IMU_RATE_COLUMNS if form == "rates" else IMU_INCREMENT_COLUMNS
    missing = [n for n in names if n not in c]
    if missing:
        msg = (
            f"{path}: missing column(s) {missing} of the IMU {form} form; the header has "
            f"{list(table.header)}"
        )
        raise InputError(msg)
    if table.n_rows < 2:
        msg = f"{path}: an IMU file needs at least 2 records, found {table.n_rows}"
        raise InputError(msg)
    t = c["t_s"]
    first, second = _rates(table, names, form)
    try:
        return ImuData(t_s=t, gyro_body_rad_s=first, acc_body_m_s2=second)
    except InputError as err:
        msg = f"{path}: {rows_to_lines(str(err), table.line_of_row)}"
        raise InputError(msg) from err


def write_imu_csv(imu: ImuData, path: Path, *, form: ImuForm = "rates") -> None:
    """Write IMU samples as CSV, atomically, floats in round-trip precision.

    Parameters
    ----------
    imu : ImuData
        Samples to write.
    path : Path
        Output file.
    form : {"rates", "increments"}
        ``rates`` writes the rates as they are; ``increments`` writes
        ``rate * dt`` over ``(t[k-1], t[k]]`` (the first row over the median interval),
        the inverse of what `read_imu_csv` does.
    """
    if form not in ("rates", "increments"):
        msg = f"write_imu_csv: form must be 'rates' or 'increments', got {form!r}"
        raise InputError(msg)
    gyro, acc = imu.gyro_body_rad_s, imu.acc_body_m_s2
    names = IMU_RATE_COLUMNS
    if form == "increments":
        dt = _first_intervals_s(imu.t_s)[:, None]
        gyro, acc = gyro * dt, acc * dt
        names = IMU_INCREMENT_COLUMNS
    cols: dict[str, FloatArray] = {"t_s": imu.t_s}
    for i in range(3):
        cols[names[1 + i]] = gyro[:, i]
    for i in range(3):
        cols[names[4 + i]] = acc[:, i]
    write_numeric_csv(Path(path), cols)
