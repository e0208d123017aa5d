"""Reading georeferenced clouds for validation: CRS, time scale, streamed chunks.

A cloud is what ``kinsync georef`` writes: LAS/LAZ (coordinates in the file's CRS,
``gps_time``, ``intensity``) or CSV/Parquet with ``X,Y,Z`` (+ ``t_s``, ``intensity``).
"""

from __future__ import annotations

import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pyproj

from kinsync._typing import FloatArray
from kinsync.crs import crs_to_ecef_transformer
from kinsync.crs_axes import declared_crs, output_units
from kinsync.errors import InputError, KinsyncWarning
from kinsync.io.las import (
    check_week_rollover,
    iter_las_chunks,
    las_header,
    las_info,
    las_time_offset_s,
    scaled_coordinates,
)
from kinsync.io.las_crs import LasCrs, read_las_crs
from kinsync.io.points import count_table_rows, iter_table_chunks
from kinsync.io.row_position import point_position, position_span
from kinsync.io.trajectory import TimeScale

__all__ = [
    "CloudExtent",
    "check_finite_chunk",
    "cloud_crs",
    "iter_cloud",
]

_ECEF_CRS = "EPSG:4978"
_LAS_SUFFIXES = (".las", ".laz")
_TABLE_SUFFIXES = (".csv", ".parquet")
_XYZ = ("X", "Y", "Z")


def _file_crs(path: Path) -> LasCrs:
    """The CRS a LAS/LAZ cloud declares (a damaged CRS record: none, as `las_info`)."""
    header = las_header(path)
    try:
        return read_las_crs(header)
    except InputError as err:
        msg = f"{path}: {err}; give the cloud's CRS with --crs"
        raise InputError(msg) from err
    except Exception:  # a damaged CRS record: reported as no CRS
        return LasCrs(None)


def _same_horizontal_and_z_unit(file_crs: pyproj.CRS, given: pyproj.CRS) -> bool:
    """``given`` says what ``file_crs`` does not (the height datum) and agrees with the rest."""
    return file_crs.to_2d().equals(given.to_2d(), ignore_axis_order=True) and (
        output_units(file_crs)[2] == output_units(given)[2]
    )


def cloud_crs(path: Path, crs: str | None) -> str:
    """The cloud's CRS: given, else a LAS file's own, else ECEF.

    A LAS file whose Z has a unit but no height datum (`kinsync.io.las_crs`): without
    ``crs``, Z is taken as the ellipsoidal height in that unit, with a warning; a given
    ``crs`` supplies the datum (its horizontal part and Z unit must be the file's). A Z
    unit that is no length unit is refused without ``crs``.
    """
    if path.suffix.lower() not in _LAS_SUFFIXES:
        return crs or _ECEF_CRS
    try:
        declared = _file_crs(path)
    except InputError:
        if crs is None:
            raise
        crs_to_ecef_transformer(crs)  # Z's unit unreadable: the given CRS says it
        return crs
    file_crs = declared.crs
    if crs is None:
        if declared.note is not None:
            warnings.warn(
                f"{path}: {declared.note}; if Z is another height (e.g. NAVD88), give the "
                "cloud's CRS with --crs, a compound CRS such as EPSG:2249+6360",
                KinsyncWarning,
                stacklevel=2,
            )
        return _ECEF_CRS if file_crs is None else file_crs.to_wkt()
    crs_to_ecef_transformer(crs)  # an unknown --crs fails first
    given = pyproj.CRS.from_user_input(crs)
    if file_crs is None:
        return crs
    if any(  # EPSG:2249 is declared in 3D (Z in metres)
        c.equals(file_crs, ignore_axis_order=True) for c in (given, declared_crs(given))
    ):
        return crs
    if declared.note is not None and _same_horizontal_and_z_unit(file_crs, given):
        return crs
    msg = (
        f"{path}: the file says its CRS is {file_crs.name!r} (Z in "
        f"{output_units(file_crs)[2]}), --crs says {crs!r} (Z in {output_units(given)[2]}); "
        "omit --crs to use the file's"
    )
    raise InputError(msg)


@dataclass(eq=False)
class CloudExtent:
    """Running bounding box (and time span) of the points read so far.

    For "nothing found" messages, and the first and last point times of a whole cloud.
    """

    lo: FloatArray = field(default_factory=lambda: np.full(3, np.inf))
    hi: FloatArray = field(default_factory=lambda: np.full(3, -np.inf))
    count: int = 0
    t_first_s: float = np.inf
    t_last_s: float = -np.inf

    def add(self, xyz: FloatArray, t_s: FloatArray | None = None) -> None:
        """Grow the box by ``xyz``, shape (n, 3), in the cloud's CRS; the span by ``t_s`` (s)."""
        if xyz.shape[0]:
            self.lo = np.minimum(self.lo, xyz.min(axis=0))
            self.hi = np.maximum(self.hi, xyz.max(axis=0))
            self.count += int(xyz.shape[0])
        if t_s is not None and t_s.size:
            self.t_first_s = min(self.t_first_s, float(t_s.min()))
            self.t_last_s = max(self.t_last_s, float(t_s.max()))

    def text(self) -> str:
        """The extent in words."""
        if self.count == 0:
            return "the cloud has no points"
        return (
            f"the cloud's {self.count} points span X {self.lo[0]:.3f}..{self.hi[0]:.3f}, "
            f"Y {self.lo[1]:.3f}..{self.hi[1]:.3f}, Z {self.lo[2]:.3f}..{self.hi[2]:.3f}"
        )


def iter_cloud(
    path: Path,
    chunk_points: int,
    *,
    need_time: bool,
    traj_scale: TimeScale = "gps",
    gps_week: int | None = None,
) -> Iterator[tuple[FloatArray, FloatArray | None, FloatArray | None]]:
    """Chunks of (xyz in the cloud's CRS, times or None, intensities or None)."""
    suffix = path.suffix.lower()
    if suffix in _LAS_SUFFIXES:
        info = las_info(path)
        time_offset_s = (
            las_time_offset_s(info, traj_scale, gps_week, needed_by="the control-point check")
            if need_time
            else 0.0
        )
        seen_s = [np.inf, -np.inf]  # smallest and largest gps_time so far, as stored
        for chunk in iter_las_chunks(path, chunk_points):
            xyz = scaled_coordinates(chunk.array, chunk.scales, chunk.offsets)
            t = None
            if need_time:
                stored = np.asarray(chunk.gps_time, dtype=np.float64)
                finite = stored[np.isfinite(stored)]
                if finite.size:
                    seen_s = [min(seen_s[0], finite.min()), max(seen_s[1], finite.max())]
                    check_week_rollover(info, float(seen_s[0]), float(seen_s[1]), gps_week)
                t = stored + time_offset_s
            yield xyz, t, np.asarray(chunk.intensity, dtype=np.float64)
        return
    if suffix not in _TABLE_SUFFIXES:
        msg = f"{path}: unknown cloud type {path.suffix!r}; use .las, .laz, .csv or .parquet"
        raise InputError(msg)
    required = (*_XYZ, "t_s", "intensity") if need_time else _XYZ
    for cols in iter_table_chunks(path, chunk_points, required):
        xyz = np.column_stack([cols[c] for c in _XYZ])
        if need_time:
            yield xyz, cols["t_s"], cols["intensity"]
        else:
            yield xyz, None, None


def check_finite_chunk(
    path: Path, xyz: FloatArray, done: int, **columns: FloatArray | None
) -> None:
    """Raise naming the file, the place and the column of the first non-finite value.

    The place is the CSV file line, or the 1-based ``row N of M`` (Parquet) or
    ``point N of M`` (LAS/LAZ), with how many such points the chunk holds.

    Parameters
    ----------
    path : Path
        The cloud (its suffix says how a row is named: CSV file line, Parquet row, LAS
        point).
    xyz : ndarray, shape (N, 3)
        The chunk's coordinates (columns ``X, Y, Z`` of a table, ``x, y, z`` of LAS).
    done : int
        Points of the file before this chunk.
    **columns : ndarray, shape (N,), or None
        Other columns to check, by the name a table gives them (``t_s``, ``intensity``;
        ``t_s`` is named ``gps_time`` for a LAS file).
    """
    suffix = path.suffix.lower()
    xyz_names = _XYZ if suffix in _TABLE_SUFFIXES else ("x", "y", "z")
    checks = {name: ~np.isfinite(xyz[:, k]) for k, name in enumerate(xyz_names)}
    checks.update({name: ~np.isfinite(v) for name, v in columns.items() if v is not None})
    first = {name: int(np.flatnonzero(bad)[0]) for name, bad in checks.items() if np.any(bad)}
    if not first:
        return
    name = min(first, key=lambda n: first[n])  # the earliest row; its first bad column
    k = first[name]
    other = columns.get(name)
    value = float(other[k]) if other is not None else float(xyz[k, xyz_names.index(name)])
    if name == "t_s" and suffix not in _TABLE_SUFFIXES:
        name = "gps_time"  # a LAS file's times
    total = _point_total(path)
    n = xyz.shape[0]
    n_bad = int(np.count_nonzero(np.logical_or.reduce(list(checks.values()))))
    if done == 0 and n == total:
        scope = "in the file"
    else:
        span = position_span(
            point_position(path, done, total), point_position(path, done + n - 1, total)
        )
        scope = f"in {span}"
    msg = (
        f"{path}: {point_position(path, done + k, total)}, column {name!r}: {value!r} is not a "
        f"finite number; {n_bad} such point(s) {scope}: drop or fix them"
    )
    raise InputError(msg)


def _point_total(path: Path) -> int | None:
    """Points of a LAS/LAZ or rows of a Parquet file (None for a CSV: named by line)."""
    suffix = path.suffix.lower()
    if suffix in _LAS_SUFFIXES:
        return las_info(path).point_count
    return count_table_rows(path) if suffix == ".parquet" else None
