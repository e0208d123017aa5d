"""Per-record arrays of a `~kinsync.trajectory.Trajectory`, checked against its times.

Each message names the argument and the 0-based row at fault.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from kinsync._typing import ArrayLike, BoolArray, FloatArray
from kinsync.errors import InputError

__all__ = [
    "EULER_LIMITS_DEG",
    "HEIGHT_SPAN_M",
    "LONGITUDE_SPAN_DEG",
    "check_euler_rad",
    "check_heights",
    "check_latitudes",
    "check_longitudes",
    "first_bad_row",
    "height_message",
    "longitude_message",
    "normalise_quaternions",
    "validated_rows",
    "validated_unit_quaternions",
]

EULER_LIMITS_DEG = {"roll_rad": 360.0, "pitch_rad": 90.0, "yaw_rad": 360.0}
"""Largest magnitude (deg) of each Euler angle a trajectory is built from: the spans the
command line reads attitude columns with (`kinsync.io.sanity.ROLL_DEG`, ``PITCH_DEG``,
``HEADING_DEG``). Beyond them an angle in radians is one given in degrees."""

LONGITUDE_SPAN_DEG = (-180.0, 360.0)
"""Longitudes (deg) a trajectory or GNSS fix may hold: -180 to 180 (east positive) or 0
to 360. Both give the same positions (the geodetic to ECEF conversion takes any angle)
and a trajectory across the antimeridian is unwrapped before it is interpolated; beyond
them a longitude is in no convention (radians, a shifted column, a corrupt record)."""

HEIGHT_SPAN_M = (-1.0e5, 1.0e5)
"""Ellipsoidal heights (m) a trajectory or GNSS fix may hold: 100 km below to 100 km
above the WGS84 ellipsoid, the span the file readers take (`kinsync.io.sanity.HEIGHT_M`).
The platforms kinsync serves (vessels, vehicles, aircraft, a rotating table) lie within
about 20 km of the ellipsoid, a stratospheric balloon within 50 km; a height beyond is in
no unit of a survey (millimetres, feet of a far larger number, a shifted column, 1e30),
and positions computed from it (ECEF, georeferenced points) would be as wrong."""

_QUATERNION_NORM_TOL = 1e-6
_BLOCK_ROWS = 65_536
"""Quaternions normalised at a time (`normalise_quaternions`)."""


def first_bad_row(mask: BoolArray) -> int:
    """Index of the first True of ``mask``."""
    return int(np.flatnonzero(mask)[0])


def validated_rows(values: ArrayLike | None, n: int, width: int | None, name: str) -> FloatArray:
    """``values`` as float64 of shape (n, width), or (n,) for ``width`` None; finite."""
    if np.asarray(values).dtype.kind == "c":  # numpy would drop the imaginary part, warning
        msg = f"trajectory {name}: expected real numbers, got complex values"
        raise InputError(msg)
    try:
        arr = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError) as err:
        msg = f"trajectory {name}: expected numbers ({err})"
        raise InputError(msg) from err
    shape = (n,) if width is None else (n, width)
    if arr.shape != shape:
        msg = f"trajectory {name}: expected shape {shape} to match t_s, got {arr.shape}"
        raise InputError(msg)
    finite = np.isfinite(arr) if width is None else np.all(np.isfinite(arr), axis=1)
    if not np.all(finite):
        row = first_bad_row(~finite)
        msg = f"trajectory {name}: non-finite value in row {row} ({arr[row].tolist()})"
        raise InputError(msg)
    return arr


def validated_unit_quaternions(values: ArrayLike, n: int) -> FloatArray:
    """(n, 4) quaternions of norm within tolerance of one, renormalised exactly.

    Returns a new C-contiguous array (never ``values`` itself), `normalise_quaternions`
    of a copy.
    """
    q = validated_rows(values, n, 4, "q_body_to_ned")
    unit = np.array(q, dtype=np.float64, copy=True, order="C")
    normalise_quaternions(unit)
    return unit


def normalise_quaternions(q: FloatArray) -> None:
    """Divide finite (N, 4) quaternions by their norms in place, refusing non-unit ones.

    Works ``_BLOCK_ROWS`` rows at a time: the bits of ``q / norm(q)`` without its
    array-sized temporaries (each row's norm depends on that row alone).

    Raises
    ------
    InputError
        A norm farther than 1e-6 from one, naming the first such row (0-based); rows
        before it may have been divided already.
    """
    for start in range(0, q.shape[0], _BLOCK_ROWS):
        block = q[start : start + _BLOCK_ROWS]
        norm = np.linalg.norm(block, axis=1)
        bad = np.abs(norm - 1.0) > _QUATERNION_NORM_TOL
        if np.any(bad):
            i = first_bad_row(bad)
            msg = (
                f"trajectory q_body_to_ned: row {start + i} has norm {norm[i]:.9g}, not a "
                "unit quaternion; normalise it or check the column order (w, x, y, z)"
            )
            raise InputError(msg)
        block /= norm[:, None]


def check_euler_rad(angle_rad: FloatArray, name: str) -> None:
    """Refuse an Euler angle (rad) beyond `EULER_LIMITS_DEG` of ``name``, naming its row.

    Parameters
    ----------
    angle_rad : ndarray, shape (N,)
        Finite angles (rad).
    name : str
        ``"roll_rad"``, ``"pitch_rad"`` or ``"yaw_rad"``.

    Raises
    ------
    InputError
        The first angle beyond its limit: most likely degrees given where radians are
        expected (a pitch of 30 is 1719 deg); for roll and yaw, possibly an unwrapped
        angle, to be wrapped first.
    """
    limit_deg = EULER_LIMITS_DEG[name]
    bad = np.abs(angle_rad) > math.radians(limit_deg)
    if not np.any(bad):
        return
    row = first_bad_row(bad)
    value = float(angle_rad[row])
    span = "+-pi/2 (+-90 deg)" if name == "pitch_rad" else "+-2 pi (one turn either way)"
    msg = (
        f"trajectory {name}: {value:.6g} rad in row {row} is beyond {span}: is it in "
        f"degrees? {name} takes radians ({value:.6g} deg = {math.radians(value):.6g} rad)"
    )
    if name != "pitch_rad":
        msg += "; an unwrapped angle must be wrapped first (kinsync.frames.wrap_angle_rad)"
    raise InputError(msg)


def check_latitudes(lat_deg: FloatArray, name: str) -> None:
    """Refuse a latitude (deg) outside [-90, 90], naming its row."""
    bad = np.abs(lat_deg) > 90.0
    if np.any(bad):
        row = first_bad_row(bad)
        msg = f"trajectory {name}: latitude {lat_deg[row]} outside [-90, 90] in row {row}"
        raise InputError(msg)


def longitude_message(value: float, row: int) -> str:
    """What is wrong with longitude ``value`` (deg) in ``row``, and what to give instead."""
    low, high = LONGITUDE_SPAN_DEG
    return (
        f"longitude {value} outside [{low:g}, {high:g}] in row {row}: give longitudes in "
        "degrees, from -180 to 180 (east positive) or from 0 to 360"
    )


def height_message(value: float, row: int) -> str:
    """What is wrong with ellipsoidal height ``value`` (m) in ``row``, and what to do."""
    low, high = HEIGHT_SPAN_M
    return (
        f"height {value!r} m outside [{low:g}, {high:g}] m in row {row} (0-based): give "
        "ellipsoidal heights in metres (a platform lies within 100 km of the ellipsoid)"
    )


def _check_span(
    values: FloatArray,
    span: tuple[float, float],
    message: Callable[[float, int], str],
    name: str,
) -> None:
    """Refuse a value outside ``span``, naming its row with ``message(value, row)``."""
    low, high = span
    bad = (values < low) | (values > high)
    if np.any(bad):
        row = first_bad_row(bad)
        msg = f"trajectory {name}: {message(float(values[row]), row)}"
        raise InputError(msg)


def check_heights(h_m: FloatArray, name: str) -> None:
    """Refuse an ellipsoidal height (m) outside `HEIGHT_SPAN_M`, naming its row."""
    _check_span(h_m, HEIGHT_SPAN_M, height_message, name)


def check_longitudes(lon_deg: FloatArray, name: str) -> None:
    """Refuse a longitude (deg) outside `LONGITUDE_SPAN_DEG`, naming its row."""
    _check_span(lon_deg, LONGITUDE_SPAN_DEG, longitude_message, name)
