"""Argument and value checks shared by the library and the readers (messages name the value).

Scalars: `finite_number`, `positive_number`. Arrays of times, coordinates and angles:
`time_array`, `coordinate_array`, `ecef_array`, `degree_array`, `geodetic_array`,
`angle_array`, one check each wherever the API takes them, so that a float32 or
datetime64 array is refused the same way everywhere (and as the readers refuse such a
column, `check_float_step`).
`Span` is the plausible range of one kind of quantity; `check_values`, `check_quantity`
and `check_columns` refuse the first value outside it, naming where it came from (the
readers' value guards, `kinsync.io.sanity`, and containers such as
`kinsync.ins.config.InsConfig`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import Literal

import numpy as np
import numpy.typing as npt

from kinsync._typing import ArrayLike, FloatArray
from kinsync.errors import InputError
from kinsync.frames import WGS84_A_M, WGS84_B_M

__all__ = [
    "ANGLE_STEP_RAD",
    "COORDINATE_STEP_M",
    "DEGREE_STEP_DEG",
    "ECEF_HEIGHT_RANGE_M",
    "GROUND_BAND_TEXT",
    "TIME_STEP_S",
    "Span",
    "angle_array",
    "check_columns",
    "check_float_step",
    "check_quantity",
    "check_values",
    "coordinate_array",
    "degree_array",
    "ecef_array",
    "ecef_height_m",
    "finite_number",
    "finite_vector",
    "geodetic_array",
    "name_tuple",
    "off_ground_text",
    "positive_number",
    "profile_arrays",
    "seed_number",
    "time_array",
    "time_number",
]

TIME_STEP_S = 1e-6
"""Coarsest step (s) a float dtype may hold times in: 1 us (float32 holds 128 s near 1.4e9 s)."""

COORDINATE_STEP_M = 1e-4
"""Coarsest step (m) a float dtype may hold coordinates in: 0.1 mm (float32: 0.5 m near 6.4e6 m)."""

ANGLE_STEP_RAD = 1e-6
"""Coarsest step (rad) a float dtype may hold angles in: 1 urad, 0.1 mm at 100 m (float32
holds 2.4e-7 rad near pi, float16 1e-3 rad)."""


DEGREE_STEP_DEG = math.degrees(COORDINATE_STEP_M / WGS84_A_M)
"""Coarsest step (deg) a float dtype may hold latitudes and longitudes in: 9e-10 deg,
`COORDINATE_STEP_M` (0.1 mm) along the equator (float32 holds 3.8e-6 deg, 0.4 m, near
47 deg)."""

ECEF_HEIGHT_RANGE_M = (-12_000.0, 10_000.0)
"""Heights (m) above the WGS84 ellipsoid of points kinsync takes as ECEF (ground points).

The deepest sea floor lies about 11 km below the ellipsoid and the highest summit 8.8 km
above it. Local (NED, ENU, scanner) coordinates lie thousands of km inside the Earth. A
map grid's coordinates read as ECEF lie on the equator; UTM northings of 6.30e6 to
6.45e6 m (57 to 58 degrees north) fall within the Earth's radii, and all but a band of
about 22 km of them outside these heights: a check of the frame, not of accuracy.
"""

_CLOCK_ADVICE = {
    "gps": (
        "give GPS seconds as float64 (seconds since 1980-01-06, ahead of UTC by its leap "
        "seconds: kinsync.clock.utc_to_gps_s converts UTC given as POSIX seconds or "
        "datetime64)"
    ),
    "local": "give the logger's clock readings as float64 seconds",
    "utc": (
        "give UTC as float64 POSIX seconds (since 1970-01-01, leap seconds not counted) "
        "or as datetime64"
    ),
}


def finite_number(value: object, name: str) -> float:
    """Return ``value`` as a finite float, or raise `InputError` naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        msg = f"{name}: expected a number, got {value!r}"
        raise InputError(msg)
    out = float(value)
    if not math.isfinite(out):
        msg = f"{name}: must be finite, got {value!r}"
        raise InputError(msg)
    return out


def seed_number(value: object, name: str) -> int:
    """A random generator's seed: a whole number >= 0, or `InputError` naming ``name``.

    Parameters
    ----------
    value : object
        What the caller gave.
    name : str
        The argument, for the message.
    """
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
        msg = f"{name}: expected a whole number >= 0 (a random seed), got {value!r}"
        raise InputError(msg)
    return int(value)


def finite_vector(value: object, size: int, name: str, detail: str = "") -> FloatArray:
    """``value`` as ``size`` finite float64 numbers, or `InputError` naming ``name``.

    Parameters
    ----------
    value : object
        What the caller gave (a sequence or array of numbers).
    size : int
        How many numbers.
    name : str
        The argument, for the message.
    detail : str
        Said after the count (their order and unit, e.g. ``" (x, y, z, m)"``).

    Returns
    -------
    ndarray, shape (size,)
    """
    msg = f"{name}: expected {size} finite numbers{detail}, got {value!r}"
    try:
        arr = np.array(value, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise InputError(msg) from err
    if arr.shape != (size,) or not np.isfinite(arr).all():
        raise InputError(msg)
    out: FloatArray = arr
    return out


def positive_number(value: object, name: str) -> float:
    """Return ``value`` as a finite float > 0, or raise `InputError` naming ``name``."""
    out = finite_number(value, name)
    if out <= 0.0:
        msg = f"{name} must be positive, got {value!r}"
        raise InputError(msg)
    return out


def name_tuple(values: object, name: str) -> tuple[str, ...]:
    """A sequence of names as a tuple of str; a lone str (or bytes) is refused.

    ``tuple("ab")`` is ``("a", "b")``: a single name given where a sequence is expected
    would silently become one name per character.
    """
    if isinstance(values, (str, bytes)):
        msg = (
            f"{name}: expected a sequence of names, got the single text {values!r}; "
            f"give a list or tuple, e.g. [{values!r}]"
        )
        raise InputError(msg)
    if not isinstance(values, Iterable):
        msg = f"{name}: expected a sequence of names, got {type(values).__name__}"
        raise InputError(msg)
    return tuple(str(v) for v in values)


def _refuse_coarse_floats(
    arr: np.ndarray,
    name: str,
    what: str,
    step: float,
    step_text: str,
    unit: str,
    advice: str = "",
) -> None:
    """Refuse a float dtype whose step at the values' magnitude is coarser than ``step``."""
    if arr.dtype.kind != "f" or np.finfo(arr.dtype).resolution <= np.finfo(np.float64).resolution:
        return
    finite = np.abs(arr[np.isfinite(arr)])
    if finite.size == 0:
        return
    largest = finite.max()
    spacing = float(np.spacing(largest))
    if spacing > step:
        u = f" {unit}" if unit else ""
        msg = (
            f"{name}: {arr.dtype} {what} near {float(largest):.6g}{u} are held in steps "
            f"of {spacing:.3g}{u}, coarser than the {step_text} kinsync needs (they are "
            f"already rounded: converting them back does not restore them); "
            f"{advice or f'pass float64 {what}'}"
        )
        raise InputError(msg)


def check_float_step(
    arr: np.ndarray,
    name: str,
    kind: Literal["time", "coordinate", "degree", "angle", "count"],
    advice: str = "write the column as float64 (double)",
) -> None:
    """Refuse times, coordinates, angles or counts held in a float dtype coarser than needed.

    Parameters
    ----------
    arr : ndarray
        Values as stored (any shape); float16/float32 near 1.3e9 s or 5e6 m are rounded
        to 128 s or 0.5 m. Integer and float64 arrays pass.
    name : str
        Where they are stored, for the message (file and column, or argument).
    kind : {"time", "coordinate", "degree", "angle", "count"}
        Times need steps of `TIME_STEP_S` (1 us), coordinates `COORDINATE_STEP_M` (0.1 mm),
        latitudes and longitudes `DEGREE_STEP_DEG` (0.1 mm on the ground), angles in
        radians `ANGLE_STEP_RAD` (1 urad), counts (profile numbers) steps of 1 (float16
        tells every whole number below 2048 from its neighbours, float32 below
        16,777,216).
    advice : str
        What the message tells the user to do (a reader's default: rewrite the column);
        counts always get "write the column as integers (int64)".

    Raises
    ------
    InputError
        A float dtype whose step at the values' largest magnitude is coarser.
    """
    if kind == "time":
        _refuse_coarse_floats(arr, name, "times", TIME_STEP_S, "1 us", "s", advice)
    elif kind == "angle":
        _refuse_coarse_floats(arr, name, "angles", ANGLE_STEP_RAD, "1 urad", "rad", advice)
    elif kind == "degree":
        _refuse_coarse_floats(
            arr, name, "degrees", DEGREE_STEP_DEG, _DEGREE_STEP_TEXT, "deg", advice
        )
    elif kind == "count":
        count_advice = "write the column as integers (int64)"
        _refuse_coarse_floats(arr, name, "whole numbers", 1.0, "step of 1", "", count_advice)
    else:
        _refuse_coarse_floats(arr, name, "coordinates", COORDINATE_STEP_M, "0.1 mm", "m", advice)


_DEGREE_STEP_TEXT = f"{DEGREE_STEP_DEG:.1g} deg (0.1 mm on the ground)"


def _as_float64(arr: np.ndarray, name: str, what: str) -> FloatArray:
    if arr.dtype.kind == "c":  # numpy would drop the imaginary part with a warning
        msg = f"{name}: expected real numbers as {what}, got complex values ({arr.dtype})"
        raise InputError(msg)
    try:
        return np.asarray(arr, dtype=np.float64)
    except (TypeError, ValueError) as err:
        msg = f"{name}: expected numbers as {what} ({err})"
        raise InputError(msg) from err


def time_array(
    values: ArrayLike, name: str, *, clock: Literal["gps", "local", "utc"] = "gps"
) -> FloatArray:
    """``values`` as a float64 array of times (s), any shape; not checked for finiteness.

    Parameters
    ----------
    values : array_like
        Times (s): GPS seconds (``clock="gps"``), a logger's clock readings
        (``clock="local"``) or UTC POSIX seconds (``clock="utc"``).
    name : str
        The argument as the caller wrote it, for messages.
    clock : {"gps", "local", "utc"}
        Which time scale, for the advice of a message.

    Raises
    ------
    InputError
        datetime64/timedelta64, string or object arrays (kinsync cannot tell their time
        scale), non-numbers, complex or boolean values (the imaginary part dropped, True
        read as 1 s), or a float dtype whose step at the values' magnitude is
        coarser than `TIME_STEP_S` (float32 beyond 16 s, float16).
    """
    arr = np.asarray(values)
    if arr.dtype.kind in "mM":
        msg = f"{name}: expected seconds, got {arr.dtype} values; {_CLOCK_ADVICE[clock]}"
        raise InputError(msg)
    if arr.dtype.kind in "OUSVbc":
        kind = {"U": "text", "S": "text", "b": "boolean (True/False)", "c": "complex"}.get(
            arr.dtype.kind, "Python object"
        )
        msg = f"{name}: expected numbers, got {kind} values ({arr.dtype}); {_CLOCK_ADVICE[clock]}"
        raise InputError(msg)
    _refuse_coarse_floats(arr, name, "times", TIME_STEP_S, "1 us", "s")
    return _as_float64(arr, name, "seconds")


def time_number(
    value: object, name: str, *, clock: Literal["gps", "local", "utc"] = "gps"
) -> float:
    """One time (s) as a finite float, refused as `time_array` refuses an array of them.

    Parameters
    ----------
    value : object
        A time (s): a Python int or float, or a NumPy integer or float scalar.
    name : str
        The argument as the caller wrote it, for messages.
    clock : {"gps", "local", "utc"}
        Which time scale, for the advice of a message.

    Returns
    -------
    float
        The time (s).

    Raises
    ------
    InputError
        Not a real number (text, complex, bool, datetime64), not finite, or a float
        type whose step at the value is coarser than `TIME_STEP_S` (a float32 GPS time
        is held in steps of 128 s: 1.4e9 + 0.437 s reads back 0.437 s early).
    """
    out = finite_number(value, name)
    if isinstance(value, np.floating):
        _refuse_coarse_floats(
            np.asarray(value), name, "times", TIME_STEP_S, "1 us", "s", _CLOCK_ADVICE[clock]
        )
    return out


def coordinate_array(values: ArrayLike, name: str) -> FloatArray:
    """``values`` as a float64 array of coordinates (m), any shape; not checked for finiteness.

    Raises
    ------
    InputError
        Non-numbers, or a float dtype whose step at the values' magnitude is coarser
        than `COORDINATE_STEP_M` (float32 ECEF or map-grid coordinates).
    """
    arr = np.asarray(values)
    if arr.dtype.kind in "mMOUSV":
        msg = f"{name}: expected numbers (m), got {arr.dtype} values"
        raise InputError(msg)
    _refuse_coarse_floats(arr, name, "coordinates", COORDINATE_STEP_M, "0.1 mm", "m")
    return _as_float64(arr, name, "metres")


def _numbers(values: ArrayLike, name: str, unit: str) -> np.ndarray:
    arr = np.asarray(values)
    if arr.dtype.kind in "mMOUSV":
        msg = f"{name}: expected numbers ({unit}), got {arr.dtype} values"
        raise InputError(msg)
    return arr


def degree_array(values: ArrayLike, name: str) -> FloatArray:
    """``values`` as a float64 array of latitudes or longitudes (deg), any shape.

    Not checked for finiteness nor span (the caller's).

    Parameters
    ----------
    values : array_like
        Latitudes or longitudes (deg).
    name : str
        The argument as the caller wrote it, for messages.

    Raises
    ------
    InputError
        Non-numbers, or a float dtype whose step at the values' magnitude is coarser
        than `DEGREE_STEP_DEG` (float32 or float16 latitudes and longitudes).
    """
    arr = _numbers(values, name, "deg")
    check_float_step(arr, name, "degree", "pass float64 degrees")
    return _as_float64(arr, name, "degrees")


def geodetic_array(values: ArrayLike, name: str) -> FloatArray:
    """``values`` as a float64 array of geodetic positions (..., 3): lat_deg, lon_deg, h_m.

    Not checked for finiteness, span nor shape (the caller's; an array whose last axis
    is not 3 is only converted).

    Parameters
    ----------
    values : array_like, shape (..., 3)
        Latitude (deg), longitude (deg), ellipsoidal height (m).
    name : str
        The argument as the caller wrote it, for messages.

    Raises
    ------
    InputError
        Non-numbers, or a float dtype too coarse for the latitudes and longitudes
        (`DEGREE_STEP_DEG`) or the heights (`COORDINATE_STEP_M`).
    """
    arr = _numbers(values, name, "deg, deg, m")
    if arr.ndim >= 1 and arr.shape[-1] == 3:
        advice = "pass float64 latitudes, longitudes and heights"
        check_float_step(arr[..., :2], f"{name} (latitude, longitude)", "degree", advice)
        check_float_step(arr[..., 2], f"{name} (height)", "coordinate", advice)
    return _as_float64(arr, name, "degrees and metres")


def angle_array(values: ArrayLike, name: str) -> FloatArray:
    """``values`` as a float64 array of angles (rad), any shape; not checked for finiteness.

    Parameters
    ----------
    values : array_like
        Angles (rad).
    name : str
        The argument as the caller wrote it, for messages.

    Raises
    ------
    InputError
        Non-numbers, or a float dtype whose step at the values' magnitude is coarser
        than `ANGLE_STEP_RAD` (float16 angles, float32 ones of thousands of radians).
    """
    arr = _numbers(values, name, "rad")
    check_float_step(arr, name, "angle", "pass float64 angles")
    return _as_float64(arr, name, "radians")


def ecef_array(values: ArrayLike, name: str) -> FloatArray:
    """`coordinate_array` of ECEF points (..., 3) whose finite rows lie near the ground.

    Raises
    ------
    InputError
        As `coordinate_array`, or a finite point whose height above the WGS84 ellipsoid
        lies outside `ECEF_HEIGHT_RANGE_M` (local or map-grid coordinates given as
        ECEF). Shapes are the caller's to check.
    """
    arr = coordinate_array(values, name)
    if arr.ndim == 0 or arr.shape[-1] != 3 or arr.size == 0:
        return arr
    rows = arr.reshape(-1, 3)
    height = ecef_height_m(rows)
    low, high = ECEF_HEIGHT_RANGE_M
    bad = np.isfinite(height) & ((height < low) | (height > high))
    if np.any(bad):
        row = int(np.flatnonzero(bad)[0])
        msg = (
            f"{name}: point at index {row} (0-based), {rows[row].tolist()} m, "
            f"{off_ground_text(float(height[row]))}: these are not ECEF coordinates (local "
            "or projected coordinates?); convert them to ECEF (m)"
        )
        raise InputError(msg)
    return arr


GROUND_BAND_TEXT = (
    f"{-ECEF_HEIGHT_RANGE_M[0] / 1000:g} km below to {ECEF_HEIGHT_RANGE_M[1] / 1000:g} km "
    "above the WGS84 ellipsoid"
)
"""`ECEF_HEIGHT_RANGE_M` in words, for messages."""


def off_ground_text(height_m: float) -> str:
    """Where a point of height ``height_m`` (m, `ecef_height_m`) lies, in words.

    Parameters
    ----------
    height_m : float
        Height above the WGS84 ellipsoid (m).
    """
    where = "above" if height_m > 0 else "below"
    return (
        f"lies {abs(height_m) / 1000:.4g} km {where} the WGS84 ellipsoid, not near the "
        f"ground ({GROUND_BAND_TEXT})"
    )


def ecef_height_m(rows: FloatArray) -> FloatArray:
    """Height (m) of ECEF points (n, 3) above the WGS84 ellipsoid along their radius.

    Parameters
    ----------
    rows : ndarray, shape (n, 3)
        ECEF points (m).

    The ellipsoid's radius at the point's geocentric latitude is subtracted from the
    point's; this differs from the geodetic height by under 1e-5 of it, enough to tell
    ground points from coordinates of another kind.
    """
    with np.errstate(invalid="ignore", over="ignore"):
        radius = np.linalg.norm(rows, axis=1)
        sin2 = np.divide(rows[:, 2] ** 2, radius**2, out=np.zeros_like(radius), where=radius > 0)
        cos2 = 1.0 - sin2
        surface = WGS84_A_M * WGS84_B_M / np.sqrt(WGS84_B_M**2 * cos2 + WGS84_A_M**2 * sin2)
        out: FloatArray = radius - surface
    return out


@dataclass(frozen=True)
class Span:
    """Closed span of plausible values of one kind of quantity.

    Attributes
    ----------
    low, high : float
        Bounds (inclusive).
    unit : str
        Unit of the values ("s", "m").
    what : str
        What such a value is, for messages ("a time", "an ellipsoidal height").
    """

    low: float
    high: float
    unit: str
    what: str

    def positive(self, smallest: float, what: str) -> Span:
        """The span ``[smallest, high]`` of ``what``: a standard deviation, a range, ..."""
        return Span(smallest, self.high, self.unit, what)


def _span_text(span: Span) -> str:
    unit = f" {span.unit}" if span.unit else ""
    return f"{span.low:g} to {span.high:g}{unit}"


def check_values(
    values: npt.ArrayLike,
    span: Span,
    where: Callable[[int], str] | str,
    *,
    allow_nan: bool = False,
) -> None:
    """Refuse the first value that is not finite or lies outside ``span``.

    Parameters
    ----------
    values : array_like, shape (N,)
        The values.
    span : Span
        Plausible values.
    where : callable or str
        ``where(i)`` names value ``i`` in messages ("traj.csv: line 7, column 'h_m'");
        a str names every value (a single value).
    allow_nan : bool
        NaN is accepted (it means "not given" in that column).

    Raises
    ------
    InputError
        Naming the first bad value, what it should be and the span.
    """
    v = np.asarray(values, dtype=np.float64).ravel()
    bad = _bad(v, span, allow_nan=allow_nan)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(_message(where if isinstance(where, str) else where(i), float(v[i]), span))


def check_quantity(value: float | tuple[float, ...], span: Span, name: str, note: str = "") -> None:
    """`check_values` for one named quantity: a number, or a vector's components.

    Parameters
    ----------
    value : float or tuple of float
        The number, or the vector (component ``i`` is named ``name[i]``).
    span : Span
        Its plausible values.
    name : str
        What messages call it: a field (``"max_imu_gap_s"``) or a key as written in a
        file (``"cfg.toml: [filter] max_imu_gap_s"``).
    note : str
        Appended to the name (``" (in SI units)"`` for a key given in other units).

    Raises
    ------
    InputError
        The value, or the first component, not finite or outside ``span``.
    """
    if isinstance(value, tuple):
        check_values(value, span, lambda i: f"{name}[{i}]{note}")
    else:
        check_values([value], span, f"{name}{note}")


def _bad(v: npt.NDArray[np.float64], span: Span, *, allow_nan: bool) -> npt.NDArray[np.bool_]:
    finite = np.isfinite(v)
    out = ~finite
    if allow_nan:
        out &= ~np.isnan(v)
    out[finite] |= (v[finite] < span.low) | (v[finite] > span.high)
    return out


def _message(where: str, value: float, span: Span) -> str:
    if not math.isfinite(value):
        return f"{where}: {value!r} is not a finite number; fix or remove it"
    if value < 0.0 <= span.low:  # the bound itself when above 0 (a period of 0 is refused too)
        least = (
            ">= 0"
            if span.low == 0.0
            else f"at least {span.low:g}{f' {span.unit}' if span.unit else ''}"
        )
        return f"{where}: {value!r} is negative; {span.what} is {least}: fix the value"
    if value < span.low and span.low > 0.0:
        return f"{where}: {value!r} is too small for {span.what} (at least {span.low:g}); fix it"
    return (
        f"{where}: {value!r} is outside {_span_text(span)}, the plausible span of "
        f"{span.what}; {_time_unit_hint(value, span)}"
    )


_TIME_UNITS = (
    ("milliseconds", 1e3, "1000"),
    ("microseconds", 1e6, "1e6"),
    ("nanoseconds", 1e9, "1e9"),
)
"""Units a time column is often written in by mistake, with their divisor to seconds."""
_DATE_S = (3e8, 1e10)
"""Seconds since 1970 or 1980 of a survey's date (1980 to 2297), for `_time_unit_hint`."""


def _time_unit_hint(value: float, span: Span) -> str:
    """What to do with a value outside a span: for times, the unit they look like."""
    if span.unit == "s" and span.high >= _DATE_S[1]:
        for unit, per_s, text in _TIME_UNITS:
            if _DATE_S[0] <= abs(value) / per_s <= _DATE_S[1]:
                return f"are these {unit} (Unix or GPS time)? divide them by {text} to give seconds"
    return "check the unit and the column order, or fix the value"


def check_columns(
    columns: Mapping[str, npt.ArrayLike],
    spans: Mapping[str, Span],
    where: Callable[[int], str],
    *,
    allow_nan: tuple[str, ...] = (),
) -> None:
    """`check_values` for several columns of a table, naming the first bad row.

    Parameters
    ----------
    columns : mapping of str to array_like, each of shape (N,)
        The table's columns by name.
    spans : mapping of str to Span
        Span of each column to check; columns absent from ``columns`` are skipped.
    where : callable
        ``where(row)`` names a row ("traj.csv: line 7"); the column is appended.
    allow_nan : tuple of str
        Columns in which NaN means "not given" and is accepted.

    Raises
    ------
    InputError
        Naming the earliest row holding a bad value, its column and the span.
    """
    first: tuple[int, str, float] | None = None
    for name, span in spans.items():
        if name not in columns:
            continue
        v = np.asarray(columns[name], dtype=np.float64).ravel()
        bad = _bad(v, span, allow_nan=name in allow_nan)
        if bad.any():
            row = int(np.flatnonzero(bad)[0])
            if first is None or row < first[0]:
                first = (row, name, float(v[row]))
    if first is not None:
        row, name, value = first
        raise InputError(_message(f"{where(row)}, column {name!r}", value, spans[name]))


def profile_arrays(
    angle_rad: ArrayLike, range_m: ArrayLike, max_angle_rad: float, what: str
) -> tuple[FloatArray, FloatArray]:
    """Mirror angles (rad) and ranges (m) of profile points as float64 arrays, checked.

    Parameters
    ----------
    angle_rad : array_like, shape (N,)
        Mirror angles (rad), finite and within +-``max_angle_rad``.
    range_m : array_like, shape (N,)
        Ranges (m), finite and >= 0.
    max_angle_rad : float
        Largest angle (rad, either sign): one turn (`kinsync.mount.MAX_PROFILE_ANGLE_RAD`).
    what : str
        Prefix of error messages (the function checked for).

    Returns
    -------
    angle_rad, range_m : ndarray of float64, shape (N,)

    Raises
    ------
    InputError
        Values that are not numbers, arrays not 1-D of one length, an angle not finite
        or beyond one turn, a range not finite or negative (naming the first index).
    """
    try:
        phi = np.asarray(angle_rad, dtype=np.float64)
        r = np.asarray(range_m, dtype=np.float64)
    except (TypeError, ValueError) as err:
        msg = f"{what}: angle_rad and range_m must be numbers ({err})"
        raise InputError(msg) from err
    if phi.ndim != 1 or r.shape != phi.shape:
        msg = (
            f"{what}: angle_rad and range_m must be 1-D arrays of one length, got shapes "
            f"{phi.shape} and {r.shape}"
        )
        raise InputError(msg)
    wide = ~(np.abs(phi) <= max_angle_rad)  # NaN too
    if wide.any():
        i = int(np.flatnonzero(wide)[0])
        msg = (
            f"{what}: angle_rad[{i}] = {float(phi[i])!r} is not a finite angle within one "
            f"turn (+-{max_angle_rad:.6g} rad): mirror angles are radians"
        )
        raise InputError(msg)
    bad = ~(np.isfinite(r) & (r >= 0.0))
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        msg = f"{what}: range_m[{i}] = {float(r[i])!r}: a range is a finite number >= 0 (m)"
        raise InputError(msg)
    return phi, r
