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
8           LiDAR time (s; time scale not documented), stored as a 32-bit float
9-11        the return in the LiDAR frame (m); a 2-D profiler, first component ~0
12-14       heading, pitch, roll of the vessel at that time (deg)
15-17       latitude, longitude (deg; 32-bit floats) and ellipsoidal height (m) of
            the vessel reference point
==========  =====================================================================

`read_cidco_pass` reads every column as written. `cidco_scan_line` turns a pass into
what the mount calibration consumes (`kinsync.calibration.lines.ScanLine`): the returns
in the scanner frame, a time for each, and the vessel trajectory recovered from the
acquisition's own georeferencing; `read_cidco_lines` does it for a whole folder.

How the acquisition georeferenced (recovered from the 12 passes)
----------------------------------------------------------------
``P_ecef = X + R_ned->ecef(lat_X, lon_X) · Rz(heading) Ry(-pitch) Rx(roll) · (R_s^b · x_lidar + L)``

with the angles of columns 12-14, ``R_s^b = Rx(180 deg)`` exactly (the LiDAR frame is the
body frame turned about x: no boresight calibration had been applied) and
``L = (-0.602, -0.065, -0.356)`` m: `ACQUISITION_MOUNT`. ``X``, recovered per return
from columns 1-3 with this formula, is the vessel reference point of columns 15-17:
its ellipsoidal height equals column 17 to 1 µm RMS, and its latitude and longitude
rounded to 32-bit floats equal columns 15-16 on all 3197 returns. A least-squares fit
of the mount with a smooth (cubic) vessel path per pass finds this boresight to
1e-4 deg and reproduces columns 1-3 to 0.02 mm RMS (0.14 mm at most).

Note the **negated pitch**: the acquisition applied column 13 as ``Ry(-pitch)``. The
data set's README model (``Ry(+pitch)``, boresight ``[180.0017, -4.3601, -0.0433]``
deg, lever arm ``[0.2307, -0.0794, -0.3701]`` m) is a first-order approximation of it
(its boresight pitch absorbs twice the mean trim of ~2.2 deg): it leaves residuals
proportional to ``2 · pitch + boresight pitch`` times the within-line scan
displacement (0.7 / 0.8 mm RMS north / east, up to 4 mm) and a vessel point 0.7 m
behind columns 15-16.

Which attitude the scan lines carry
-----------------------------------
``attitude="din"`` (default) reads columns 12-14 as kinsync's DIN 9300 yaw, pitch, roll
(pitch positive bow up), the vessel's physical attitude: with a boresight fitted to
make the spheres of different passes coincide, every pass gives a round sphere
(free radius 0.190-0.212 m, 3.9-5.4 mm RMS). With the acquisition's negated pitch no
mount and no latency removes the distortion that the pitch changes inside a pass
leave (free radius 0.17-0.28 m, up to 15 mm RMS; sphere1/passage_3, pitching at
3 deg/s, stays at 0.28 m), and reading roll with the other sign is worse still. So
the acquisition's columns 1-3 carry a sign error in pitch, and the calibration
should see the DIN attitude; georeferencing such a line with `ACQUISITION_MOUNT`
then differs from columns 1-3 by 0.3-0.5 m. ``attitude="acquisition"`` gives the
acquisition's attitude (pitch = -column 13): with `ACQUISITION_MOUNT` it reproduces
columns 1-3 to a few µm. Both carry the same vessel positions ``X``.

Per-return times
----------------
The profiler's head turns once per scan line, 50 lines/s. A return's time is
``t = t0 + T · (n + phi / 360 deg)``, ``T = 0.02 s``, ``n`` the scan line (counted
from the pass's first line), ``phi = atan2(z, y)`` its scan angle from columns 10-11.
A new scan line starts where ``phi`` drops. Column 8 is this time rounded to a 32-bit
float (7.8 ms steps near 77 000 s): ``n`` follows from it, and ``t0`` is the middle of
the interval of values for which every return's time rounds to its column 8. Evidence:
the attitude of columns 12-14 changes inside a line at ``T / 360 deg`` per degree of
scan angle (the ratio of within-line to line-to-line attitude rates is 1.0), so the
acquisition took each return's attitude at this time; the recovered vessel positions
are smoothest for that slope (17.7 µm RMS about a cubic per pass, 30.7 µm if a line's
returns share one time, 30.7 µm for twice the slope); and on the three passes where
column 8 steps inside a scan line the interval of ``t0`` is one return wide (2 µs),
while a slope of zero shrinks it to a point and the opposite sign leaves none.

References
----------
CIDCO LidarToolkit, ``test/data/PortDeQuebec`` (MIT licence, (c) 2021 CIDCO).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from kinsync._arrays import ReadOnlyArrays
from kinsync._typing import FloatArray, IntArray
from kinsync.calibration.lines import ScanLine
from kinsync.errors import InputError
from kinsync.frames import (
    ecef_to_geodetic,
    euler_rpy_to_matrix,
    euler_rpy_to_quaternion,
    rotation_ned_to_ecef,
)
from kinsync.io.sanity import (
    ANGLE_DEG,
    HEIGHT_M,
    INTENSITY,
    LATITUDE_DEG,
    LENGTH_M,
    LONGITUDE_DEG,
    MAX_TEXT_ROWS_BYTES,
    TIME_S,
    check_columns,
    check_text_file,
    not_utf8_cell,
)
from kinsync.io.text_lines import cut_line_hint, warn_if_unended
from kinsync.mount import Mount
from kinsync.trajectory import Trajectory

__all__ = [
    "ACQUISITION_MOUNT",
    "CIDCO_COLUMNS",
    "CIDCO_LINE_PERIOD_S",
    "DEFAULT_PAD_S",
    "AttitudeConvention",
    "CidcoPass",
    "CidcoTiming",
    "cidco_attitude_rpy_rad",
    "cidco_return_times",
    "cidco_scan_line",
    "cidco_trajectory",
    "cidco_vessel_position_ecef_m",
    "read_cidco_lines",
    "read_cidco_pass",
]

CIDCO_COLUMNS = 17
"""Number of space-separated numbers on each line of a pass file."""

CIDCO_LINE_PERIOD_S = 0.02
"""Scan line period of the profiler (s): 50 lines/s, one turn of the head per line."""

ACQUISITION_MOUNT = Mount(
    lever_arm_body_m=(-0.602, -0.065, -0.356),
    boresight_rpy_deg=(180.0, 0.0, 0.0),
    latency_s=0.0,
)
"""The mount the acquisition software georeferenced columns 1-3 with, kinsync convention.

Scanner (the LiDAR frame of columns 9-11) -> body FRD: turned 180 deg about x, nothing
else; lever arm from the vessel reference point (the point of columns 15-17), body
frame (m). With the acquisition's attitude (``attitude="acquisition"``, pitch =
-column 13) it reproduces columns 1-3; with the DIN attitude it is the calibration's
starting point (no boresight calibrated).
"""

AttitudeConvention = Literal["din", "acquisition"]
"""How columns 12-14 become kinsync's DIN 9300 attitude (see the module doc):
``"din"`` roll, pitch, yaw = columns 14, 13, 12 (the vessel's attitude);
``"acquisition"`` pitch = -column 13 (what the acquisition software applied)."""

DEFAULT_PAD_S = CIDCO_LINE_PERIOD_S
"""How far (s) the trajectory of `cidco_scan_line` extends beyond the first/last return."""

_CIDCO_FILES = "sphere*/passage_*.txt"
_COLUMNS = (
    ("ECEF x", LENGTH_M),
    ("ECEF y", LENGTH_M),
    ("ECEF z", LENGTH_M),
    ("local x", LENGTH_M),
    ("local y", LENGTH_M),
    ("local z", LENGTH_M),
    ("intensity", INTENSITY),
    ("LiDAR time", TIME_S),
    ("LiDAR x", LENGTH_M),
    ("LiDAR y", LENGTH_M),
    ("LiDAR z", LENGTH_M),
    ("heading", ANGLE_DEG),
    ("pitch", ANGLE_DEG),
    ("roll", ANGLE_DEG),
    ("latitude", LATITUDE_DEG),
    ("longitude", LONGITUDE_DEG),
    ("height", HEIGHT_M),
)
_COLUMN_NAMES = tuple(f"{k} ({name})" for k, (name, _) in enumerate(_COLUMNS, start=1))
_SPANS = tuple(span for _, span in _COLUMNS)
"""Plausible values of the 17 columns (`kinsync.io.sanity`)."""
_STAMP_TOLERANCE_S = 1e-3
"""Largest misfit (s), beyond the 32-bit rounding, of column 8 to the rebuilt times."""


@dataclass(frozen=True, eq=False)
class CidcoPass(ReadOnlyArrays):
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
        LiDAR time (s; scale not documented; 32-bit float in the files) (column 8).
    points_lidar_m : ndarray, shape (N, 3)
        Returns in the LiDAR frame (m) (columns 9-11).
    heading_deg, pitch_deg, roll_deg : ndarray, shape (N,)
        Vessel attitude at the return's time (deg) (columns 12-14); the file's pitch is
        positive bow down (kinsync's DIN 9300 pitch is its negative).
    lat_deg, lon_deg : ndarray, shape (N,)
        Vessel geodetic latitude and longitude, WGS84 (deg) (columns 15-16; 32-bit
        floats in the files, about 0.4 m and 0.6 m steps).
    h_m : ndarray, shape (N,)
        Vessel ellipsoidal height (m) (column 17).
    file_line : ndarray of int or None, shape (N,)
        1-based line number of each return in its file (blank lines skipped), for
        messages; None when the pass was not read from a file.
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
    file_line: IntArray | None = None

    @property
    def n_points(self) -> int:
        """Number of returns."""
        return int(self.points_ecef_m.shape[0])

    @property
    def range_m(self) -> FloatArray:
        """Range of each return from the LiDAR (m), shape (N,)."""
        r: FloatArray = np.linalg.norm(self.points_lidar_m, axis=1)
        return r

    @property
    def name(self) -> str:
        """``sphere1/passage_3`` for ``.../sphere1/passage_3.txt``: folder and stem."""
        path = Path(self.source)
        return f"{path.parent.name}/{path.stem}" if path.parent.name else path.stem

    def where(self, index: int) -> str:
        """``file: line L`` of return ``index`` (its row when not read from a file)."""
        if self.file_line is None:
            return f"{self.source}: return {index}"
        return f"{self.source}: line {int(self.file_line[index])}"


def _locate_bad_line(path: Path, text: str) -> InputError:
    for line_no, line in enumerate(text.splitlines(), start=1):
        fields = line.split()
        if not fields:
            continue
        if len(fields) != CIDCO_COLUMNS:
            return InputError(
                f"{path}: line {line_no} has {len(fields)} numbers, expected {CIDCO_COLUMNS} "
                "(ECEF xyz, local xyz, intensity, time, LiDAR xyz, heading pitch roll, "
                "lat lon h)"
                + (cut_line_hint(path, line_no) or "; is this a CIDCO LidarToolkit pass file?")
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
        Missing or unreadable file, not a text file or larger than 256 MiB
        (`kinsync.io.sanity.check_text_file`), no data, a line with another number of
        fields, a non-numeric, non-finite or implausible value (`kinsync.io.sanity`; the
        message names the file, line and column).
    """
    path = Path(path)
    check_text_file(path, "CIDCO pass file", max_bytes=MAX_TEXT_ROWS_BYTES)
    warn_if_unended(path, first_data_line=1)
    try:  # a UTF-8 byte-order mark (Windows editors) is skipped, as by every CSV reader
        text = path.read_text(encoding="utf-8-sig", errors="surrogateescape")
    except OSError as err:
        msg = f"{path}: cannot read ({err})"
        raise InputError(msg) from err
    numbered = [(no, ln) for no, ln in enumerate(text.splitlines(), start=1) if ln.strip()]
    for no, ln in numbered:
        error = not_utf8_cell(path, no, ln)
        if error is not None:
            raise error
    if not numbered:
        msg = f"{path}: no data; expected lines of {CIDCO_COLUMNS} numbers"
        raise InputError(msg)
    try:
        data = np.loadtxt([ln for _, ln in numbered], dtype=np.float64, ndmin=2, comments=None)
    except ValueError as err:
        raise _locate_bad_line(path, text) from err
    if data.shape[1] != CIDCO_COLUMNS or not np.isfinite(data).all():
        raise _locate_bad_line(path, text)
    file_line = np.array([no for no, _ in numbered], dtype=np.int64)
    check_columns(
        dict(zip(_COLUMN_NAMES, data.T, strict=True)),
        dict(zip(_COLUMN_NAMES, _SPANS, strict=True)),
        lambda row: f"{path}: line {int(file_line[row])}",
    )
    file_line.setflags(write=False)
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
        file_line=file_line,
    )


# --------------------------------------------------------------------------- timing


@dataclass(frozen=True, eq=False)
class CidcoTiming(ReadOnlyArrays):
    """Per-return times of a pass, rebuilt from the scan angle and column 8.

    Attributes
    ----------
    t_s : ndarray, shape (N,)
        Time of each return (s, column 8's time scale): ``t0 + T (n + phi / 360)``.
    scan_angle_deg : ndarray, shape (N,)
        Scan angle ``phi = atan2(z, y)`` of the LiDAR-frame return (deg), kept within
        180 deg of the pass's mean direction (no wrap inside a pass).
    line_index : ndarray of int, shape (N,)
        Index of the return's scan line among the pass's lines (0, 1, ...).
    line_number : ndarray of int, shape (N,)
        Scan line count ``n`` since the pass's first line (lines without returns count).
    t0_s : float
        Time of scan angle 0 in line ``n = 0`` (s).
    t0_interval_s : tuple of float
        Values of ``t0`` for which every time rounds (32-bit) to its column 8; the
        chosen ``t0`` is the middle. ``(nan, nan)`` when column 8 is not 32-bit
        rounded as expected (``t0`` is then the median fit).
    max_stamp_misfit_s : float
        Largest ``|column 8 - t|`` (s).
    """

    t_s: FloatArray
    scan_angle_deg: FloatArray
    line_index: IntArray
    line_number: IntArray
    t0_s: float
    t0_interval_s: tuple[float, float]
    max_stamp_misfit_s: float

    @property
    def n_lines(self) -> int:
        """Number of scan lines holding returns."""
        return int(self.line_index[-1]) + 1


def _scan_angle_deg(p: CidcoPass) -> FloatArray:
    y, z = p.points_lidar_m[:, 1], p.points_lidar_m[:, 2]
    at_origin = (y == 0.0) & (z == 0.0)
    if np.any(at_origin):
        i = int(np.flatnonzero(at_origin)[0])
        msg = f"{p.where(i)}: LiDAR return (columns 10-11) at the origin: no scan angle"
        raise InputError(msg)
    phi = np.arctan2(z, y)
    mean_dir = math.atan2(float(np.sin(phi).sum()), float(np.cos(phi).sum()))
    wrapped = (phi - mean_dir + math.pi) % (2.0 * math.pi) - math.pi + mean_dir
    return np.degrees(wrapped)


def _stamp_half_steps(stamps: FloatArray) -> tuple[FloatArray, FloatArray] | None:
    """Distances (s) to the 32-bit rounding boundaries below and above each stamp.

    None when a stamp is not a 32-bit float (the file holds full-precision times).
    """
    s32 = stamps.astype(np.float32)
    if not np.array_equal(s32.astype(np.float64), stamps):
        return None
    below = np.nextafter(s32, np.float32(-np.inf)).astype(np.float64)
    above = np.nextafter(s32, np.float32(np.inf)).astype(np.float64)
    return 0.5 * (stamps - below), 0.5 * (above - stamps)


def _line_numbers(p: CidcoPass, phi_deg: FloatArray) -> tuple[IntArray, IntArray]:
    """Scan line index (among lines with returns) and count ``n`` of each return."""
    period = CIDCO_LINE_PERIOD_S
    steps = _stamp_half_steps(p.t_lidar_s)
    if steps is not None and 2.0 * float(np.max(steps[1])) >= 0.5 * period:
        msg = (
            f"{p.source}: column 8 (LiDAR time) is stored with {2.0 * float(np.max(steps[1])):.3g} "
            f"s steps, too coarse to number {1.0 / period:.0f} Hz scan lines"
        )
        raise InputError(msg)
    line_start = p.t_lidar_s - period * phi_deg / 360.0
    number = np.rint((line_start - line_start[0]) / period).astype(np.int64)
    new_line = np.r_[True, (np.diff(phi_deg) < 0.0) | (np.diff(number) != 0)]
    index = np.cumsum(new_line).astype(np.int64) - 1
    index.setflags(write=False)
    number.setflags(write=False)
    starts = np.flatnonzero(new_line)
    back = np.flatnonzero(np.diff(number[starts]) <= 0)
    if back.size:
        i = int(starts[back[0] + 1])
        msg = (
            f"{p.where(i)}: a new scan line starts here (the scan angle drops) but its LiDAR "
            f"time {float(p.t_lidar_s[i])!r} (column 8) does not advance by a line period "
            f"({period} s) from the line before: the returns must be in time order, one "
            f"{1.0 / period:.0f} Hz profiler"
        )
        raise InputError(msg)
    return index, number


def cidco_return_times(p: CidcoPass) -> CidcoTiming:
    """Rebuild each return's time from its scan line and scan angle (see the module doc).

    Parameters
    ----------
    p : CidcoPass
        The pass, returns in file (time) order.

    Returns
    -------
    CidcoTiming
        Times increasing from line to line, and within a line as the scan angle does.

    Raises
    ------
    InputError
        A return at the LiDAR origin, column 8 too coarse or out of time order, or a
        column 8 that misses the rebuilt time by more than its 32-bit rounding plus 1 ms
        (the message names the file and line).
    """
    phi = _scan_angle_deg(p)
    index, number = _line_numbers(p, phi)
    offset = CIDCO_LINE_PERIOD_S * (number + phi / 360.0)
    stamps = p.t_lidar_s
    steps = _stamp_half_steps(stamps)
    interval = (math.nan, math.nan)
    t0 = float(np.median(stamps - offset))
    tolerance = np.full(stamps.size, _STAMP_TOLERANCE_S)
    if steps is not None:
        lo = float(np.max(stamps - steps[0] - offset))
        hi = float(np.min(stamps + steps[1] - offset))
        if lo <= hi:
            interval = (lo, hi)
            t0 = 0.5 * (lo + hi)
        tolerance += np.maximum(steps[0], steps[1])
    t = t0 + offset
    misfit = np.abs(stamps - t)
    bad = misfit > tolerance
    if np.any(bad):
        i = int(np.argmax(misfit - tolerance))
        msg = (
            f"{p.where(i)}: LiDAR time {float(stamps[i])!r} (column 8) is {misfit[i] * 1e3:.2f} ms "
            f"from the time rebuilt for a {1.0 / CIDCO_LINE_PERIOD_S:.0f} Hz profiler "
            f"(scan line {int(number[i])}, scan angle {phi[i]:.4f} deg); "
            f"{int(np.count_nonzero(bad))} return(s) misfit: is this one pass of a CIDCO profiler?"
        )
        raise InputError(msg)
    return CidcoTiming(
        t_s=_frozen(t),
        scan_angle_deg=_frozen(phi),
        line_index=index,
        line_number=number,
        t0_s=t0,
        t0_interval_s=interval,
        max_stamp_misfit_s=float(misfit.max()),
    )


# --------------------------------------------------------------------------- trajectory


def _check_attitude(attitude: str) -> None:
    if attitude not in ("din", "acquisition"):
        msg = f"attitude must be 'din' or 'acquisition', got {attitude!r}"
        raise InputError(msg)


def cidco_attitude_rpy_rad(p: CidcoPass, attitude: AttitudeConvention = "din") -> FloatArray:
    """DIN 9300 attitude body -> NED at each return from columns 12-14, shape (N, 3) (rad).

    ``(roll, pitch, yaw) = (column 14, column 13, column 12)`` for ``"din"``, with the
    pitch negated for ``"acquisition"`` (see the module doc).
    """
    _check_attitude(attitude)
    sign = 1.0 if attitude == "din" else -1.0
    rpy: FloatArray = np.radians(np.column_stack([p.roll_deg, sign * p.pitch_deg, p.heading_deg]))
    return rpy


def cidco_vessel_position_ecef_m(p: CidcoPass) -> FloatArray:
    """Vessel reference point at each return, ECEF (m), shape (N, 3), from columns 1-3.

    Inverts the acquisition's georeferencing (module doc) with `ACQUISITION_MOUNT` and
    the acquisition's attitude: ``X = P_ecef - R_ned->ecef(lat_X, lon_X) · R_b^n ·
    (R_s^b · x_lidar + L)``, the rotation to ECEF taken at X itself (the 32-bit
    columns 15-16 start one iteration). Its height is column 17 and its latitude and
    longitude round (32-bit) to columns 15-16 on the Port de Québec passes.
    """
    rpy = cidco_attitude_rpy_rad(p, "acquisition")
    R_bn = euler_rpy_to_matrix(rpy[:, 0], rpy[:, 1], rpy[:, 2])
    mount = ACQUISITION_MOUNT
    body = mount.lever_arm_body_m_array + p.points_lidar_m @ mount.R_scanner_to_body.T
    offset_ned = np.einsum("nij,nj->ni", R_bn, body)
    lat, lon = p.lat_deg, p.lon_deg
    pos = p.points_ecef_m
    for _ in range(2):
        R_ne = rotation_ned_to_ecef(lat, lon)
        pos = p.points_ecef_m - np.einsum("nij,nj->ni", R_ne, offset_ned)
        llh = ecef_to_geodetic(pos)
        lat, lon = llh[:, 0], llh[:, 1]
    return pos


def _line_fits(
    t: FloatArray, values: FloatArray, starts: IntArray
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Straight-line fit of ``values`` (N, k) against ``t`` over each contiguous line.

    Returns the mean time (L,), the value at the mean time (L, k) and the slope (L, k).
    """
    counts = np.diff(np.r_[starts, t.size])
    t_mean = np.add.reduceat(t, starts) / counts
    v_mean = np.add.reduceat(values, starts, axis=0) / counts[:, None]
    dt = t - np.repeat(t_mean, counts)
    dv = values - np.repeat(v_mean, counts, axis=0)
    sxx = np.add.reduceat(dt * dt, starts)
    sxy = np.add.reduceat(dt[:, None] * dv, starts, axis=0)
    slope = np.zeros_like(v_mean)
    ok = sxx > 0.0
    slope[ok] = sxy[ok] / sxx[ok, None]
    return t_mean, v_mean, slope


def _end_rates(t_mean: FloatArray, v_mean: FloatArray, slope: FloatArray) -> FloatArray:
    """Rate of change (per s) at the start and the end of the pass, shape (2, k)."""
    if t_mean.size < 2:
        return np.vstack([slope[0], slope[-1]])
    first = (v_mean[1] - v_mean[0]) / (t_mean[1] - t_mean[0])
    last = (v_mean[-1] - v_mean[-2]) / (t_mean[-1] - t_mean[-2])
    return np.vstack([first, last])


def _trajectory_records(
    t: FloatArray, states: FloatArray, starts: IntArray, pad_s: float
) -> tuple[FloatArray, FloatArray]:
    """Record times and states: each line's first and last return, plus the pads."""
    ends = np.r_[starts[1:], t.size] - 1
    t_mean, v_mean, slope = _line_fits(t, states, starts)
    t_rec = np.column_stack([t[starts], t[ends]]).ravel()
    v_rec = np.stack(
        [
            v_mean + slope * (t[starts] - t_mean)[:, None],
            v_mean + slope * (t[ends] - t_mean)[:, None],
        ],
        axis=1,
    ).reshape(-1, states.shape[1])
    keep = np.r_[True, np.diff(t_rec) > 0.0]
    t_rec, v_rec = t_rec[keep], v_rec[keep]
    if pad_s > 0.0:
        rates = _end_rates(t_mean, v_mean, slope)
        t_rec = np.r_[t_rec[0] - pad_s, t_rec, t_rec[-1] + pad_s]
        v_rec = np.vstack([v_rec[0] - pad_s * rates[0], v_rec, v_rec[-1] + pad_s * rates[1]])
    return t_rec, v_rec


def _check_pad(pad_s: float) -> float:
    if isinstance(pad_s, bool) or not isinstance(pad_s, int | float) or not math.isfinite(pad_s):
        msg = f"pad_s must be a finite number of seconds, got {pad_s!r}"
        raise InputError(msg)
    if pad_s < 0.0:
        msg = f"pad_s must be >= 0 s, got {pad_s!r}"
        raise InputError(msg)
    return float(pad_s)


def cidco_trajectory(
    p: CidcoPass,
    timing: CidcoTiming,
    *,
    attitude: AttitudeConvention = "din",
    pad_s: float = DEFAULT_PAD_S,
) -> Trajectory:
    """The vessel trajectory of a pass, on column 8's time scale.

    Positions from `cidco_vessel_position_ecef_m`, attitude from `cidco_attitude_rpy_rad`.
    Per scan line, position (ECEF) and Euler angles are fitted by a straight line in
    time (which averages out the 32-bit rounding of columns 9-14); the trajectory holds
    that fit at the line's first and last return (one record for a one-return line),
    so every return lies inside it and interpolation inside a line follows the
    acquisition's own states. Between lines (20 ms) position is interpolated linearly
    and attitude by slerp, without velocities: leaving a line out and interpolating
    over the 40 ms gap misses its position by 0.04 mm RMS (0.2 mm at most) and cubic
    Hermite with velocities from the neighbouring lines does no better; the attitude
    misses by 0.002 deg RMS (0.005 deg at most). With ``pad_s > 0`` one record
    ``pad_s`` before the first return and one after the last continue the end lines'
    motion at the constant rate between the two end lines (inside the line when there
    is one), so that a latency of up to ``pad_s`` keeps every return inside the span.

    Parameters
    ----------
    p : CidcoPass
    timing : CidcoTiming
        From `cidco_return_times`.
    attitude : {"din", "acquisition"}
        How columns 12-14 become the attitude (`AttitudeConvention`).
    pad_s : float
        Extension beyond the first and last return (s), >= 0.

    Returns
    -------
    Trajectory
        Geodetic WGS84 positions of the vessel reference point (height = column 17)
        and body (FRD) -> NED attitude, no velocities.

    Raises
    ------
    InputError
        A bad ``attitude`` or ``pad_s``, or ``pad_s == 0`` with fewer than two distinct
        return times.
    """
    pad = _check_pad(pad_s)
    rpy = cidco_attitude_rpy_rad(p, attitude)
    pos = cidco_vessel_position_ecef_m(p)
    rpy_unwrapped = np.column_stack([rpy[:, :2], np.unwrap(rpy[:, 2])])
    starts = np.flatnonzero(np.r_[True, np.diff(timing.line_index) != 0])
    t_rec, v_rec = _trajectory_records(timing.t_s, np.hstack([pos, rpy_unwrapped]), starts, pad)
    if t_rec.size < 2:
        msg = (
            f"{p.source}: a trajectory needs returns at two distinct times or pad_s > 0; "
            f"got {p.n_points} return(s) and pad_s = {pad}"
        )
        raise InputError(msg)
    return Trajectory(
        t_s=t_rec,
        q_body_to_ned=euler_rpy_to_quaternion(v_rec[:, 3], v_rec[:, 4], v_rec[:, 5]),
        lat_lon_h=ecef_to_geodetic(v_rec[:, :3]),
    )


def cidco_scan_line(
    p: CidcoPass,
    *,
    name: str | None = None,
    attitude: AttitudeConvention = "din",
    pad_s: float = DEFAULT_PAD_S,
) -> ScanLine:
    """A pass as the mount calibration consumes it: scanner-frame returns, times, trajectory.

    Every return is kept (sphere and clutter alike: the calibration segments). The
    scanner frame is the LiDAR frame of columns 9-11 (`ACQUISITION_MOUNT` turns it
    180 deg about x into the body frame), the times come from `cidco_return_times` and
    the trajectory from `cidco_trajectory` (records at their own tags). With
    ``attitude="acquisition"``, georeferencing the line with `ACQUISITION_MOUNT`
    reproduces columns 1-3; the default ``"din"`` is the vessel's attitude, which the
    calibration should see (module doc).

    Parameters
    ----------
    p : CidcoPass
    name : str, optional
        Name of the line; default `CidcoPass.name` (``sphere1/passage_3``).
    attitude : {"din", "acquisition"}
        How columns 12-14 become the attitude (`AttitudeConvention`).
    pad_s : float
        Trajectory extension beyond the first and last return (s); see `cidco_trajectory`.

    Returns
    -------
    ScanLine

    Raises
    ------
    InputError
        See `cidco_return_times` and `cidco_trajectory`.
    """
    _check_attitude(attitude)
    timing = cidco_return_times(p)
    trajectory = cidco_trajectory(p, timing, attitude=attitude, pad_s=pad_s)
    return ScanLine(
        name=p.name if name is None else name,
        t_s=timing.t_s,
        xyz_scanner_m=p.points_lidar_m,
        trajectory=trajectory,
    )


def _natural_key(path: Path) -> tuple[object, ...]:
    parts = re.split(r"(\d+)", f"{path.parent.name}/{path.name}")
    return tuple(int(s) if s.isdigit() else s for s in parts)


def read_cidco_lines(
    folder: Path | str,
    *,
    attitude: AttitudeConvention = "din",
    pad_s: float = DEFAULT_PAD_S,
) -> tuple[ScanLine, ...]:
    """Every ``sphere*/passage_*.txt`` of a folder as a `ScanLine` (``sphere1/passage_3``).

    Parameters
    ----------
    folder : Path or str
        The data set's folder (holding ``sphere1/``, ``sphere2/``).
    attitude : {"din", "acquisition"}
        How columns 12-14 become the attitude (`AttitudeConvention`).
    pad_s : float
        Trajectory extension beyond each pass's first and last return (s).

    Returns
    -------
    tuple of ScanLine
        In natural order (sphere1/passage_1, ..., sphere1/passage_10, ..., sphere2/...).

    Raises
    ------
    InputError
        Missing folder, no pass file, or a bad pass file (the message names it).
    """
    _check_attitude(attitude)
    _check_pad(pad_s)
    root = Path(folder)
    if not root.is_dir():
        msg = f"{root}: not a folder; expected the CIDCO data set's folder"
        raise InputError(msg)
    paths = sorted(root.glob(_CIDCO_FILES), key=_natural_key)
    if not paths:
        msg = f"{root}: no pass file matches {_CIDCO_FILES}"
        raise InputError(msg)
    return tuple(
        cidco_scan_line(read_cidco_pass(path), attitude=attitude, pad_s=pad_s) for path in paths
    )
