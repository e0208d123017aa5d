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
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from kinsync._typing import ArrayLike, FloatArray
from kinsync.errors import InputError
from kinsync.frames import ecef_to_geodetic, geodetic_to_ecef
from kinsync.io.atomic import atomic_path
from kinsync.io.tables import read_csv_rows

__all__ = [
    "ControlPoints",
    "read_control_points",
    "write_control_points",
]

GEODETIC_COLUMNS = ("lat_deg", "lon_deg", "h_m")
ECEF_COLUMNS = ("x_m", "y_m", "z_m")


@dataclass(frozen=True, eq=False)
class ControlPoints:
    """Named control points in ECEF.

    Parameters
    ----------
    names : sequence of str
        Point names, non-empty and unique.
    pos_ecef_m : array_like, shape (N, 3)
        Surveyed positions, ECEF WGS84 (m), finite.
    source : str
        Where they came from (a file name, for messages).

    Raises
    ------
    InputError
        Empty or duplicated names, a shape that does not match, non-finite values.
    """

    names: tuple[str, ...]
    pos_ecef_m: FloatArray
    source: str = "<control points>"

    def __post_init__(self) -> None:
        names = tuple(str(n).strip() for n in self.names)
        if not names:
            msg = f"{self.source}: no control points"
            raise InputError(msg)
        empty = [i for i, n in enumerate(names) if not n]
        if empty:
            msg = f"{self.source}: control point {empty[0]} has an empty name; name every point"
            raise InputError(msg)
        dupes = sorted({n for n in names if names.count(n) > 1})
        if dupes:
            msg = f"{self.source}: duplicated control point name(s) {dupes}; names must be unique"
            raise InputError(msg)
        try:
            pos = np.array(self.pos_ecef_m, dtype=np.float64)
        except (TypeError, ValueError) as err:
            msg = f"{self.source}: control point coordinates must be numbers ({err})"
            raise InputError(msg) from err
        if pos.shape != (len(names), 3):
            msg = (
                f"{self.source}: pos_ecef_m must have shape ({len(names)}, 3) to match the "
                f"names, got {pos.shape}"
            )
            raise InputError(msg)
        bad = ~np.all(np.isfinite(pos), axis=1)
        if np.any(bad):
            i = int(np.flatnonzero(bad)[0])
            msg = f"{self.source}: control point {names[i]!r} has non-finite coordinates"
            raise InputError(msg)
        pos.setflags(write=False)
        object.__setattr__(self, "names", names)
        object.__setattr__(self, "pos_ecef_m", pos)

    @classmethod
    def from_geodetic(
        cls,
        names: tuple[str, ...] | list[str],
        lat_deg: ArrayLike,
        lon_deg: ArrayLike,
        h_m: ArrayLike,
        source: str = "<control points>",
    ) -> ControlPoints:
        """Control points from geodetic WGS84 coordinates (deg, deg, m), each shape (N,)."""
        pos = geodetic_to_ecef(lat_deg, lon_deg, h_m)
        return cls(names=tuple(names), pos_ecef_m=np.atleast_2d(pos), source=source)

    def __len__(self) -> int:
        return len(self.names)

    def lat_lon_h(self) -> FloatArray:
        """Geodetic coordinates ``(lat_deg, lon_deg, h_m)``, shape (N, 3)."""
        return ecef_to_geodetic(self.pos_ecef_m)


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
        msg = f"{path}: line {line} has {len(row)} fields, the header has {width}"
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
            msg = f"{path}: line {line}, column {col!r}: {cell!r} is not a finite number"
            raise InputError(msg)
        out[j] = value
    if coords == GEODETIC_COLUMNS and abs(out[0]) > 90.0:
        msg = f"{path}: line {line}: latitude {float(out[0])!r} outside [-90, 90]"
        raise InputError(msg)
    return name, out


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
        that is not a finite number, a latitude outside [-90, 90] (each naming the line).
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
        msg = f"{path}: missing column 'name'; the header has {header}"
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
