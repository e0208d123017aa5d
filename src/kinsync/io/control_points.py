"""Control-point files: independently surveyed target coordinates (CSV).

One control point per row, a header naming the columns, in one of two forms::

    name,lat_deg,lon_deg,h_m        geodetic WGS84 (deg, deg, ellipsoidal height m)
    name,x_m,y_m,z_m                ECEF WGS84 (EPSG:4978, m)

Other columns (a description, a survey sigma, ...) are allowed and ignored. Names are
text (surrounding spaces removed), non-empty and unique; blank lines are skipped. A file
holding both coordinate forms is refused: which one is meant cannot be guessed.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import Literal

import numpy as np

from kinsync._typing import FloatArray
from kinsync._validate import ECEF_HEIGHT_RANGE_M, GROUND_BAND_TEXT, off_ground_text
from kinsync.errors import InputError
from kinsync.frames import ecef_to_geodetic
from kinsync.io.atomic import atomic_path
from kinsync.io.csv_cells import comment_hint, decimal_comma_hint
from kinsync.io.sanity import (
    HEIGHT_M,
    LATITUDE_DEG,
    LENGTH_M,
    LONGITUDE_DEG,
    Span,
    check_values,
)
from kinsync.io.tables import read_csv_rows
from kinsync.validation.control_points import ControlPoints

__all__ = [
    "read_control_points",
    "write_control_points",
]


GEODETIC_COLUMNS = ("lat_deg", "lon_deg", "h_m")
ECEF_COLUMNS = ("x_m", "y_m", "z_m")
_SPANS: dict[str, Span] = {
    "lat_deg": LATITUDE_DEG,
    "lon_deg": LONGITUDE_DEG,
    "h_m": HEIGHT_M,
    **dict.fromkeys(ECEF_COLUMNS, LENGTH_M),
}
"""Plausible coordinates (`kinsync.io.sanity`)."""


def _coordinate_columns(path: Path, header: list[str]) -> tuple[str, ...]:
    has_geo = [c in header for c in GEODETIC_COLUMNS]
    has_ecef = [c in header for c in ECEF_COLUMNS]
    if all(has_geo) and all(has_ecef):
        msg = (
            f"{path}: the header has both geodetic {list(GEODETIC_COLUMNS)} and ECEF "
            f"{list(ECEF_COLUMNS)} columns; keep one set"
        )
        raise InputError(msg)
    if all(has_geo):
        return GEODETIC_COLUMNS
    if all(has_ecef):
        return ECEF_COLUMNS
    msg = (
        f"{path}: missing coordinate columns; the header has {header}; give "
        f"name,{','.join(GEODETIC_COLUMNS)} (geodetic WGS84) or "
        f"name,{','.join(ECEF_COLUMNS)} (ECEF)"
    )
    raise InputError(msg)


def _parse_row(
    path: Path,
    line: int,
    row: list[str],
    width: int,
    i_name: int,
    coords: tuple[str, ...],
    idx: list[int],
) -> tuple[str, FloatArray]:
    """Name and the three coordinates of one data row; errors name the line."""
    if len(row) != width:
        hint = comment_hint(row) + decimal_comma_hint(row, width)
        msg = f"{path}: line {line} has {len(row)} fields, the header has {width}{hint}"
        raise InputError(msg)
    name = row[i_name].strip()
    if not name:
        msg = f"{path}: line {line}: empty name; name every control point"
        raise InputError(msg)
    out = np.empty(3)
    for j, (col, i) in enumerate(zip(coords, idx, strict=True)):
        cell = row[i].strip()
        try:
            value = float(cell)
        except ValueError:
            value = math.nan
        if not math.isfinite(value):
            msg = f"{path}: line {line}, column {col!r}: {cell[:80]!r} is not a finite number"
            raise InputError(msg)
        check_values([value], _SPANS[col], f"{path}: line {line}, column {col!r}")
        out[j] = value
    return name, out


def _refuse_off_ground(
    path: Path, lines: list[int], values: FloatArray, coords: tuple[str, ...]
) -> None:
    """Refuse a point not near the ground (`ECEF_HEIGHT_RANGE_M`), naming its line.

    ``values`` (N, 3) are the rows' coordinates in the file's form ``coords``, on the
    file ``lines``. A surveyed control point lies on the ground: a geodetic height out
    there is in another unit (mm), an ECEF point is not ECEF (local or projected).
    """
    geodetic = coords == GEODETIC_COLUMNS
    height_m = values[:, 2] if geodetic else ecef_to_geodetic(values)[:, 2]
    low, high = ECEF_HEIGHT_RANGE_M
    bad = np.flatnonzero((height_m < low) | (height_m > high))
    if bad.size == 0:
        return
    k = int(bad[0])
    if geodetic:
        msg = (
            f"{path}: line {lines[k]}, column 'h_m': height {values[k, 2]!r} m is not near "
            f"the ground ({GROUND_BAND_TEXT}), where a surveyed control point lies: heights "
            "in mm or another unit? give ellipsoidal heights in metres"
        )
    else:
        msg = (
            f"{path}: line {lines[k]}: point {values[k].tolist()} "
            f"{off_ground_text(float(height_m[k]))}: these are not ECEF coordinates (local "
            "or projected coordinates?); convert them to ECEF x_m,y_m,z_m (m) or give "
            "name,lat_deg,lon_deg,h_m"
        )
    raise InputError(msg)


def read_control_points(path: Path) -> ControlPoints:
    """Read a control-point CSV (geodetic or ECEF, see the module docstring).

    Parameters
    ----------
    path : Path
        CSV file with a header row.

    Returns
    -------
    ControlPoints
        Positions in ECEF (geodetic input converted through pyproj).

    Raises
    ------
    InputError
        Missing or unreadable file, empty file, no data rows, no ``name`` column,
        missing or ambiguous coordinate columns, duplicated column names, a row with
        another number of fields than the header, an empty or duplicated name, a cell
        that is not a finite number, an implausible coordinate (`kinsync.io.sanity`: a
        latitude outside [-90, 90], a height beyond 100 km, ...), a point not near the
        ground (a height in mm, coordinates that are not ECEF) (each naming the line).
    """
    path = Path(path)
    records = read_csv_rows(path, "control point file")
    if not records:
        msg = f"{path}: empty file; expected a header such as name,lat_deg,lon_deg,h_m"
        raise InputError(msg)
    header = [c.strip() for c in records[0][1]]
    dupes = sorted({c for c in header if header.count(c) > 1})
    if dupes:
        msg = f"{path}: duplicated column(s) {dupes} in the header"
        raise InputError(msg)
    if "name" not in header:
        msg = f"{path}: missing column 'name'; the header has {header}{comment_hint(header)}"
        raise InputError(msg)
    coords = _coordinate_columns(path, header)
    body = records[1:]
    if not body:
        msg = f"{path}: no control points after the header"
        raise InputError(msg)
    i_name = header.index("name")
    idx = [header.index(c) for c in coords]
    names: list[str] = []
    values = np.empty((len(body), 3))
    seen: dict[str, int] = {}
    for k, (line, row) in enumerate(body):
        name, values[k] = _parse_row(path, line, row, len(header), i_name, coords, idx)
        if name in seen:
            msg = f"{path}: line {line}: name {name!r} already used on line {seen[name]}"
            raise InputError(msg)
        seen[name] = line
        names.append(name)
    _refuse_off_ground(path, [line for line, _ in body], values, coords)
    if coords == GEODETIC_COLUMNS:
        return ControlPoints.from_geodetic(
            names, values[:, 0], values[:, 1], values[:, 2], source=str(path)
        )
    return ControlPoints(names=tuple(names), pos_ecef_m=values, source=str(path))


def write_control_points(
    points: ControlPoints, path: Path, *, form: Literal["geodetic", "ecef"] = "geodetic"
) -> None:
    """Write control points as CSV (floats in ``repr`` precision), atomically.

    Parameters
    ----------
    points : ControlPoints
    path : Path
        Output CSV.
    form : {"geodetic", "ecef"}
        ``name,lat_deg,lon_deg,h_m`` or ``name,x_m,y_m,z_m``.

    Raises
    ------
    InputError
        Unknown form, missing output folder.
    """
    if form == "geodetic":
        header, values = GEODETIC_COLUMNS, points.lat_lon_h()
    elif form == "ecef":
        header, values = ECEF_COLUMNS, points.pos_ecef_m
    else:
        msg = f"write_control_points: form must be 'geodetic' or 'ecef', got {form!r}"
        raise InputError(msg)
    with atomic_path(Path(path)) as tmp, tmp.open("w", encoding="utf-8", newline="") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(["name", *header])
        for name, row in zip(points.names, values.tolist(), strict=True):
            writer.writerow([name, *(repr(float(v)) for v in row)])
