"""GNSS CSV files: antenna positions, optional σ and NED velocities.

Columns (header row, any order; other columns are ignored)::

    t_s,lat_deg,lon_deg,h_m                 required: WGS84 geodetic, ellipsoidal height
    std_n_m,std_e_m,std_d_m                 optional: position σ N, E, D (m)
    vn_m_s,ve_m_s,vd_m_s                    optional: antenna velocity in NED (m/s)
    std_vn_m_s,std_ve_m_s,std_vd_m_s        optional (with velocities): velocity σ (m/s)

Each optional group is given whole or not at all. A ``nan`` or empty σ cell means "use
the configured default" for that epoch (`kinsync.ins.config.InsConfig`; an empty position
or velocity cell is refused); a missing σ group means the defaults for every epoch.
Epochs may be at any times (strictly increasing). Errors name the file and the line
(header = line 1).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from kinsync._typing import FloatArray
from kinsync.errors import InputError
from kinsync.ins.config import MIN_GNSS_STD
from kinsync.ins.measurements import GnssData
from kinsync.io.gps_week import check_not_future
from kinsync.io.sanity import (
    HEIGHT_M,
    LATITUDE_DEG,
    LENGTH_M,
    LONGITUDE_DEG,
    SPEED_M_S,
    TIME_S,
    Span,
    check_columns,
)
from kinsync.io.tables import NumericTable, read_numeric_csv, rows_to_lines, write_numeric_csv

__all__ = [
    "GNSS_POSITION_COLUMNS",
    "GNSS_STD_POSITION_COLUMNS",
    "GNSS_STD_VELOCITY_COLUMNS",
    "GNSS_VELOCITY_COLUMNS",
    "read_gnss_csv",
    "write_gnss_csv",
]

GNSS_POSITION_COLUMNS = ("t_s", "lat_deg", "lon_deg", "h_m")
GNSS_STD_POSITION_COLUMNS = ("std_n_m", "std_e_m", "std_d_m")
GNSS_VELOCITY_COLUMNS = ("vn_m_s", "ve_m_s", "vd_m_s")
GNSS_STD_VELOCITY_COLUMNS = ("std_vn_m_s", "std_ve_m_s", "std_vd_m_s")


def _group(table: NumericTable, names: tuple[str, ...]) -> FloatArray | None:
    c = table.columns
    present = [n in c for n in names]
    if any(present) and not all(present):
        missing = [n for n, p in zip(names, present, strict=True) if not p]
        msg = f"{table.source}: give all of {list(names)} or none; missing {missing}"
        raise InputError(msg)
    return np.column_stack([c[n] for n in names]) if all(present) else None


_SPANS: dict[str, Span] = {
    "t_s": TIME_S,
    "lat_deg": LATITUDE_DEG,
    "lon_deg": LONGITUDE_DEG,
    "h_m": HEIGHT_M,
    **dict.fromkeys(GNSS_VELOCITY_COLUMNS, SPEED_M_S),
}
"""Plausible values of the position and velocity columns (`kinsync.io.sanity`)."""

_STD_SPANS: dict[str, Span] = {
    **dict.fromkeys(
        GNSS_STD_POSITION_COLUMNS, LENGTH_M.positive(MIN_GNSS_STD, "a position standard deviation")
    ),
    **dict.fromkeys(
        GNSS_STD_VELOCITY_COLUMNS, SPEED_M_S.positive(MIN_GNSS_STD, "a velocity standard deviation")
    ),
}
"""A σ is at least 1 µm (or µm/s), as in the configuration's ``[gnss]`` σ: the filter
weighs an epoch by 1/σ²."""


def _check_positive_or_nan(table: NumericTable, names: tuple[str, ...], arr: FloatArray) -> None:
    bad = ~(np.isnan(arr) | (np.isfinite(arr) & (arr > 0.0)))
    if bad.any():
        row, col = (int(v[0]) for v in np.nonzero(bad))
        msg = (
            f"{table.source}: line {table.line_of_row(row)}, column {names[col]!r}: "
            f"{arr[row, col]!r} is not a positive standard deviation (use nan for the "
            "configured default)"
        )
        raise InputError(msg)
    check_columns(
        dict(zip(names, arr.T, strict=True)),
        _STD_SPANS,
        lambda row: f"{table.source}: line {table.line_of_row(row)}",
        allow_nan=names,
    )


def read_gnss_csv(path: Path) -> GnssData:
    """Read a GNSS CSV file (columns in the module docstring).

    Parameters
    ----------
    path : Path
        CSV file with a header row.

    Returns
    -------
    GnssData
        Antenna positions, σ (NaN where not given), velocities and their σ when given.

    Raises
    ------
    InputError
        Missing or unreadable file, missing required columns, a partial optional group,
        velocity σ without velocities, a non-numeric cell, fewer than 2 epochs,
        non-finite or implausible times (a GPS time after today: Unix time,
        `kinsync.io.gps_week.check_not_future`), positions or velocities (`kinsync.io.sanity`:
        a latitude outside [-90, 90], a height beyond 100 km, ...), repeated or
        decreasing times, a σ that is zero, negative, infinite or below 1 µm (each
        naming the line).
    """
    path = Path(path)
    table = read_numeric_csv(
        path,
        GNSS_POSITION_COLUMNS,
        GNSS_STD_POSITION_COLUMNS + GNSS_VELOCITY_COLUMNS + GNSS_STD_VELOCITY_COLUMNS,
        empty_is_nan=GNSS_STD_POSITION_COLUMNS + GNSS_STD_VELOCITY_COLUMNS,
    )
    c = table.columns
    if table.n_rows < 2:
        msg = f"{path}: a GNSS file needs at least 2 epochs, found {table.n_rows}"
        raise InputError(msg)
    std_pos = _group(table, GNSS_STD_POSITION_COLUMNS)
    vel = _group(table, GNSS_VELOCITY_COLUMNS)
    std_vel = _group(table, GNSS_STD_VELOCITY_COLUMNS)
    if std_vel is not None and vel is None:
        msg = (
            f"{path}: velocity σ columns {list(GNSS_STD_VELOCITY_COLUMNS)} without the "
            f"velocities {list(GNSS_VELOCITY_COLUMNS)}; add the velocities or drop the σ"
        )
        raise InputError(msg)
    if std_pos is None:
        std_pos = np.full((table.n_rows, 3), np.nan)
    else:
        _check_positive_or_nan(table, GNSS_STD_POSITION_COLUMNS, std_pos)
    if std_vel is not None:
        _check_positive_or_nan(table, GNSS_STD_VELOCITY_COLUMNS, std_vel)
    check_columns(c, _SPANS, lambda row: f"{path}: line {table.line_of_row(row)}")
    check_not_future(c["t_s"], lambda row: f"{path}: line {table.line_of_row(row)}, column 't_s'")
    try:
        return GnssData(
            t_s=c["t_s"],
            lat_deg=c["lat_deg"],
            lon_deg=c["lon_deg"],
            h_m=c["h_m"],
            std_pos_ned_m=std_pos,
            vel_ned_m_s=vel,
            std_vel_ned_m_s=std_vel,
        )
    except InputError as err:
        msg = f"{path}: {rows_to_lines(str(err), table.line_of_row)}"
        raise InputError(msg) from err


def write_gnss_csv(gnss: GnssData, path: Path) -> None:
    """Write GNSS epochs as CSV (round trip of `read_gnss_csv`), atomically.

    The position σ group is written when any σ is known (``nan`` cells stand for the
    default); velocities and their σ when present.
    """
    cols: dict[str, FloatArray] = {
        "t_s": gnss.t_s,
        "lat_deg": gnss.lat_deg,
        "lon_deg": gnss.lon_deg,
        "h_m": gnss.h_m,
    }
    groups: list[tuple[tuple[str, ...], FloatArray | None]] = [
        (
            GNSS_STD_POSITION_COLUMNS,
            None if np.isnan(gnss.std_pos_ned_m).all() else gnss.std_pos_ned_m,
        ),
        (GNSS_VELOCITY_COLUMNS, gnss.vel_ned_m_s),
        (GNSS_STD_VELOCITY_COLUMNS, gnss.std_vel_ned_m_s),
    ]
    for names, arr in groups:
        if arr is not None:
            for i, name in enumerate(names):
                cols[name] = arr[:, i]
    write_numeric_csv(Path(path), cols)
