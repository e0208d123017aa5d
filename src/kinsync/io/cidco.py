"""Reader for CIDCO LidarToolkit sphere passes (Port de Québec test data).

Each file holds one pass of a survey vessel over a spherical target: one LiDAR return
per line, 17 numbers separated by spaces (column meaning as CIDCO's LidarToolkit
reader defines it; see the data set's README):

==========  =====================================================================
columns     meaning
==========  =====================================================================
1-3         georeferenced point, ECEF (m), as produced by the acquisition software
4-6         georeferenced point in a local geodetic frame (m); origin and axes
            not documented
7           intensity (instrument units)
8           LiDAR time (s; time scale not documented)
9-11        the return in the LiDAR frame (m); a 2-D profiler, first component ~0
12-14       heading, pitch, roll of the vessel at that time (deg)
15-17       latitude, longitude (deg) and ellipsoidal height (m) of the vessel
==========  =====================================================================

References
----------
CIDCO LidarToolkit, ``test/data/PortDeQuebec`` (MIT licence, (c) 2021 CIDCO).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from kinsync._typing import FloatArray
from kinsync.errors import InputError

__all__ = ["CIDCO_COLUMNS", "CidcoPass", "read_cidco_pass"]

CIDCO_COLUMNS = 17
"""Number of space-separated numbers on each line of a pass file."""


@dataclass(frozen=True, eq=False)
class CidcoPass:
    """One vessel pass over a sphere, every column of the file, named with its unit.

    Attributes
    ----------
    source : str
        File the pass came from.
    points_ecef_m : ndarray, shape (N, 3)
        Georeferenced returns, ECEF (m) (columns 1-3).
    points_local_m : ndarray, shape (N, 3)
        Georeferenced returns in the acquisition's local geodetic frame (m; origin and
        axes not documented) (columns 4-6).
    intensity : ndarray, shape (N,)
        Return intensity (instrument units) (column 7).
    t_lidar_s : ndarray, shape (N,)
        LiDAR time (s; scale not documented) (column 8).
    points_lidar_m : ndarray, shape (N, 3)
        Returns in the LiDAR frame (m) (columns 9-11).
    heading_deg, pitch_deg, roll_deg : ndarray, shape (N,)
        Vessel attitude at the return's time (deg) (columns 12-14).
    lat_deg, lon_deg : ndarray, shape (N,)
        Vessel geodetic latitude and longitude, WGS84 (deg) (columns 15-16).
    h_m : ndarray, shape (N,)
        Vessel ellipsoidal height (m) (column 17).
    """

    source: str
    points_ecef_m: FloatArray
    points_local_m: FloatArray
    intensity: FloatArray
    t_lidar_s: FloatArray
    points_lidar_m: FloatArray
    heading_deg: FloatArray
    pitch_deg: FloatArray
    roll_deg: FloatArray
    lat_deg: FloatArray
    lon_deg: FloatArray
    h_m: FloatArray

    @property
    def n_points(self) -> int:
        """Number of returns."""
        return int(self.points_ecef_m.shape[0])

    @property
    def range_m(self) -> FloatArray:
        """Range of each return from the LiDAR (m), shape (N,)."""
        r: FloatArray = np.linalg.norm(self.points_lidar_m, axis=1)
        return r


def _locate_bad_line(path: Path, text: str) -> InputError:
    for line_no, line in enumerate(text.splitlines(), start=1):
        fields = line.split()
        if not fields:
            continue
        if len(fields) != CIDCO_COLUMNS:
            return InputError(
                f"{path}: line {line_no} has {len(fields)} numbers, expected {CIDCO_COLUMNS} "
                "(ECEF xyz, local xyz, intensity, time, LiDAR xyz, heading pitch roll, "
                "lat lon h); is this a CIDCO LidarToolkit pass file?"
            )
        for col, cell in enumerate(fields, start=1):
            try:
                value = float(cell)
            except ValueError:
                return InputError(f"{path}: line {line_no}, column {col}: {cell!r} is not a number")
            if not np.isfinite(value):
                return InputError(
                    f"{path}: line {line_no}, column {col}: non-finite value {cell!r}"
                )
    return InputError(f"{path}: cannot read as a CIDCO pass file ({CIDCO_COLUMNS} numbers a line)")


def _frozen(arr: FloatArray) -> FloatArray:
    out = np.ascontiguousarray(arr, dtype=np.float64)
    out.setflags(write=False)
    return out


def read_cidco_pass(path: Path | str) -> CidcoPass:
    """Read one CIDCO LidarToolkit pass file (17 space-separated numbers a line).

    Parameters
    ----------
    path : Path or str
        Pass file, e.g. ``sphere1/passage_1.txt``.

    Returns
    -------
    CidcoPass
        Every column, named with its unit and frame; arrays read-only.

    Raises
    ------
    InputError
        Missing or unreadable file, no data, a line with another number of fields or a
        non-numeric / non-finite value (the message names the file, line and column).
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError as err:
        msg = f"{path}: file not found"
        raise InputError(msg) from err
    except (OSError, UnicodeDecodeError) as err:
        msg = f"{path}: cannot read ({err})"
        raise InputError(msg) from err
    lines = [ln for ln in text.splitlines() if ln.strip()]
    if not lines:
        msg = f"{path}: no data; expected lines of {CIDCO_COLUMNS} numbers"
        raise InputError(msg)
    try:
        data = np.loadtxt(lines, dtype=np.float64, ndmin=2)
    except ValueError as err:
        raise _locate_bad_line(path, text) from err
    if data.shape[1] != CIDCO_COLUMNS or not np.isfinite(data).all():
        raise _locate_bad_line(path, text)
    return CidcoPass(
        source=str(path),
        points_ecef_m=_frozen(data[:, 0:3]),
        points_local_m=_frozen(data[:, 3:6]),
        intensity=_frozen(data[:, 6]),
        t_lidar_s=_frozen(data[:, 7]),
        points_lidar_m=_frozen(data[:, 8:11]),
        heading_deg=_frozen(data[:, 11]),
        pitch_deg=_frozen(data[:, 12]),
        roll_deg=_frozen(data[:, 13]),
        lat_deg=_frozen(data[:, 14]),
        lon_deg=_frozen(data[:, 15]),
        h_m=_frozen(data[:, 16]),
    )
