"""Applanix SBET trajectory files (Smoothed Best Estimate of Trajectory).

An SBET is a headerless sequence of 136-byte records, each 17 little-endian float64:

====  ==========================  ====================================================
 #    field (`SBET_DTYPE` name)   meaning
====  ==========================  ====================================================
 0    ``time_sow_s``              GPS seconds of week (s)
 1    ``lat_rad``                 geodetic latitude, WGS84 (rad)
 2    ``lon_rad``                 longitude (rad)
 3    ``h_m``                     ellipsoidal height (m)
 4-6  ``vel_{x,y,z}_wander_m_s``  velocity in the wander frame (m/s)
 7    ``roll_rad``                roll (rad)
 8    ``pitch_rad``               pitch (rad)
 9    ``platform_heading_rad``    heading measured from the wander-frame x axis (rad)
 10   ``wander_angle_rad``        wander angle alpha (rad)
11-13 ``acc_{x,y,z}_body_m_s2``   body-frame accelerations (m/s2)
14-16 ``rate_{x,y,z}_body_rad_s`` body-frame angular rates (rad/s)
====  ==========================  ====================================================

Wander frame
------------
True heading is ``yaw = platform_heading - wander_angle``. The wander frame is the
locally level frame whose z axis points Down and whose x axis lies at azimuth
``-alpha`` (a positive wander angle turns x from North towards West); y completes the
right-handed triad (azimuth ``90 deg - alpha``). A heading measured from x is then the
true heading plus alpha, as the relation above requires, and the velocities rotate as

    v_N = v_x cos(alpha) + v_y sin(alpha)
    v_E = -v_x sin(alpha) + v_y cos(alpha)
    v_D = v_z

(`wander_to_ned_velocity`; `ned_to_wander_velocity` is its inverse).

What was verified, and against what: Applanix publishes no SBET specification. The
field order and units (17 little-endian doubles, angles in radians, time in GPS
seconds of week) agree with PDAL (``io/SbetCommon.hpp``: GpsTime, Y, X, Z, X/Y/Z
velocity, Roll, Pitch, Azimuth, WanderAngle, body accelerations, body angular rates)
and NOAA's ``HSTB/drivers/sbet.py`` (noaa-ocs-hydrography/drivers). The heading
relation ``true_heading = platform_heading - wander_angle`` is stated in the NAVO
PFM/ABE ``FilePOSOutput.h`` SBET reader and used by other public SBET readers; PDAL and
NOAA's driver leave the heading and the velocities in the wander frame. No public
reader found converts the wander-frame velocities, so the velocity rotation above is
derived, not copied: it is the only one consistent with that heading relation (the
platform heading is the heading measured from the wander x axis). Beware that the
"wander azimuth" of the n-vector library (Gade 2010) is measured the other way (its x
axis at azimuth ``+alpha``); an SBET's wander angle is not that angle. A trajectory
read here therefore has the right heading for any wander angle; the velocities (used
only for Hermite position interpolation between records) rely on the derivation, and
are checked against the positions before use (`kinsync.trajectory.check_velocities`):
zero velocities, velocities in other units, or left in the wander frame (wander angles
beyond about 11 deg) are caught there.

Time scale
----------
SBET times are GPS seconds of week. `read_sbet` returns them unchanged unless
``gps_week`` is given, in which case they become continuous GPS seconds
``gps_week * 604800 + sow`` (the kinsync reference scale). Some exports write GPS time
itself in the time field: a first time beyond a week and a day cannot be seconds of
week (`kinsync.io.gps_week`) and is read as GPS time, with no week added. `write_sbet` writes times
below one week as they are; continuous GPS times are written as seconds of the week of
the first record (a trajectory crossing into the next week keeps counting past
604800 s, so times stay increasing), and ``read_sbet(path, gps_week=week)`` gives the
original times back exactly.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from pathlib import Path

import numpy as np
import numpy.typing as npt

from kinsync._typing import FloatArray
from kinsync.errors import InputError
from kinsync.frames import euler_rpy_to_quaternion
from kinsync.io.gps_week import SECONDS_PER_WEEK, holds_gps_time
from kinsync.io.records import count_records, memmap_records, write_records
from kinsync.io.sanity import (
    ANGLE_RAD,
    HEIGHT_M,
    SECONDS_OF_WEEK_S,
    SPEED_M_S,
    TIME_S,
    Span,
    check_columns,
)
from kinsync.trajectory import Trajectory
from kinsync.trajectory_rows import normalise_quaternions
from kinsync.trajectory_times import validated_times

__all__ = [
    "SBET_DTYPE",
    "SBET_RECORD_BYTES",
    "SECONDS_PER_WEEK",
    "ned_to_wander_velocity",
    "read_sbet",
    "read_sbet_records",
    "sbet_gps_week",
    "sbet_holds_gps_time",
    "seconds_of_first_week",
    "wander_to_ned_velocity",
    "write_sbet",
]

SBET_DTYPE: np.dtype[np.void] = np.dtype(
    [
        ("time_sow_s", "<f8"),
        ("lat_rad", "<f8"),
        ("lon_rad", "<f8"),
        ("h_m", "<f8"),
        ("vel_x_wander_m_s", "<f8"),
        ("vel_y_wander_m_s", "<f8"),
        ("vel_z_wander_m_s", "<f8"),
        ("roll_rad", "<f8"),
        ("pitch_rad", "<f8"),
        ("platform_heading_rad", "<f8"),
        ("wander_angle_rad", "<f8"),
        ("acc_x_body_m_s2", "<f8"),
        ("acc_y_body_m_s2", "<f8"),
        ("acc_z_body_m_s2", "<f8"),
        ("rate_x_body_rad_s", "<f8"),
        ("rate_y_body_rad_s", "<f8"),
        ("rate_z_body_rad_s", "<f8"),
    ]
)
"""One SBET record: 17 little-endian float64 (136 bytes), names carrying units."""

SBET_RECORD_BYTES = SBET_DTYPE.itemsize
"""Size of one SBET record (136 bytes)."""

_SPANS: dict[str, Span] = {
    "time_sow_s": TIME_S,
    "lat_rad": Span(-math.pi / 2, math.pi / 2, "rad", "a latitude"),
    "lon_rad": Span(  # a Trajectory's, kinsync.trajectory_rows.LONGITUDE_SPAN_DEG
        -math.pi, 2 * math.pi, "rad", "a longitude (-pi to pi or 0 to 2 pi)"
    ),
    "h_m": HEIGHT_M,
    **dict.fromkeys(("vel_x_wander_m_s", "vel_y_wander_m_s", "vel_z_wander_m_s"), SPEED_M_S),
    **dict.fromkeys(("roll_rad", "pitch_rad", "platform_heading_rad"), ANGLE_RAD),
    "wander_angle_rad": ANGLE_RAD,
}
"""Plausible values of the fields a trajectory is made of (`kinsync.io.sanity`)."""

_WEEK_SPANS: dict[str, Span] = {
    **_SPANS,
    "time_sow_s": SECONDS_OF_WEEK_S,
}
"""`_SPANS` of an SBET of GPS seconds of week (its first time tells, `holds_gps_time`)."""

_ATTITUDE_LIMITS_RAD: dict[str, tuple[float, str]] = {
    "roll_rad": (2 * math.pi, "+-2 pi"),
    "pitch_rad": (math.pi / 2, "+-pi/2"),
    "platform_heading_rad": (2 * math.pi, "+-2 pi"),
    "wander_angle_rad": (2 * math.pi, "+-2 pi"),
}
"""Largest magnitude of each angle in radians, and its span in words. A heading is held
within [0, 2 pi) or +-pi, a roll within +-pi, a pitch within +-pi/2: an angle beyond
one turn (a pitch beyond a quarter) was written in degrees."""


_MISMATCH_HINT = "the file is truncated or not an SBET (re-export or copy it again)"
"""What to do about an SBET whose length is not a whole number of records."""

_BLOCK_RECORDS = 65_536
"""Records `read_sbet` reads and converts at a time (8.9 MB): a 10 h, 200 Hz SBET
(979 MB) is never held whole, nor converted through array-sized temporaries."""


def wander_to_ned_velocity(
    vel_x_m_s: FloatArray,
    vel_y_m_s: FloatArray,
    vel_z_m_s: FloatArray,
    wander_angle_rad: FloatArray,
) -> FloatArray:
    """Wander-frame velocities to NED (see the module docstring for the convention).

    Parameters
    ----------
    vel_x_m_s, vel_y_m_s, vel_z_m_s : ndarray, shape (N,)
        Velocity components along the wander-frame axes (m/s; z Down).
    wander_angle_rad : ndarray, shape (N,)
        Wander angle alpha (rad).

    Returns
    -------
    ndarray, shape (N, 3)
        Velocity in NED (m/s).
    """
    c, s = np.cos(wander_angle_rad), np.sin(wander_angle_rad)
    return np.column_stack(
        [vel_x_m_s * c + vel_y_m_s * s, -vel_x_m_s * s + vel_y_m_s * c, vel_z_m_s]
    )


def ned_to_wander_velocity(vel_ned_m_s: FloatArray, wander_angle_rad: FloatArray) -> FloatArray:
    """NED velocities to the wander frame; inverse of `wander_to_ned_velocity`.

    Parameters
    ----------
    vel_ned_m_s : ndarray, shape (N, 3)
        Velocity in NED (m/s).
    wander_angle_rad : ndarray, shape (N,)
        Wander angle alpha (rad).

    Returns
    -------
    ndarray, shape (N, 3)
        Velocity along the wander-frame x, y, z axes (m/s; z Down).
    """
    c, s = np.cos(wander_angle_rad), np.sin(wander_angle_rad)
    n, e, d = vel_ned_m_s[:, 0], vel_ned_m_s[:, 1], vel_ned_m_s[:, 2]
    return np.column_stack([n * c - e * s, n * s + e * c, d])


def read_sbet_records(path: Path) -> np.memmap[tuple[int], np.dtype[np.void]]:
    """Memory-map the raw records of an SBET file (read-only).

    Parameters
    ----------
    path : Path
        SBET file.

    Returns
    -------
    numpy.memmap, shape (N,), dtype `SBET_DTYPE`
        The records as stored; nothing is converted or validated beyond the length.

    Raises
    ------
    InputError
        Missing or empty file, or a length that is not a multiple of 136 bytes.
    """
    return memmap_records(path, SBET_DTYPE, "SBET", _MISMATCH_HINT)


def read_sbet(path: Path, *, gps_week: int | None = None) -> Trajectory:
    """Read an SBET file into a geodetic `Trajectory`.

    Parameters
    ----------
    path : Path
        SBET file (read a block of records at a time while the trajectory is built).
    gps_week : int, optional
        GPS week of the first record. When given, times become continuous GPS seconds
        ``gps_week * 604800 + sow``; otherwise they stay GPS seconds of week. Not used
        when the time field already holds GPS time (`sbet_holds_gps_time`: a first time
        beyond a week and a day), which is read as it is.

    Returns
    -------
    Trajectory
        ``t_s`` (s; see ``gps_week``), ``lat_lon_h`` (deg, deg, m), attitude from roll,
        pitch and true heading ``platform_heading - wander_angle``, and ``vel_ned_m_s``
        rotated from the wander frame.

    Raises
    ------
    InputError
        A truncated file (bytes left over), fewer than 2 records, non-finite or
        implausible values (`kinsync.io.sanity`: a height beyond 100 km, a negative
        time in a file of seconds of week, ...), an angle
        beyond what radians hold (a roll or heading beyond +-2 pi, a pitch beyond +-pi/2:
        degrees), repeated or decreasing times (naming the file and the record, 0-based).
    """
    path = Path(path)
    if gps_week is not None and gps_week < 0:
        msg = f"{path}: gps_week must be >= 0, got {gps_week}"
        raise InputError(msg)
    if path.name.lower().startswith("smrmsg"):
        msg = (
            f"{path}: this looks like an smrmsg accuracy file (name starting with "
            "'smrmsg'), not an SBET trajectory; give the sbet_*.out file (kinsync trajectory "
            "info reports the smrmsg beside it)"
        )
        raise InputError(msg)
    n = count_records(path, SBET_DTYPE, "SBET", _MISMATCH_HINT)
    if n < 2:
        msg = f"{path}: a trajectory needs at least 2 records, the SBET holds {n}"
        raise InputError(msg)
    t, llh, vel, q, degrees = _read_blocks(path, n, gps_week)
    if degrees is not None:
        _refuse_degrees(path, degrees)
    # What `Trajectory` checks, once: the angles, positions and velocities are finite
    # and the latitudes within +-90 deg by the checks above; the times may repeat or
    # decrease, and the attitudes are normalised as a Trajectory normalises them.
    try:
        validated_times(t)
        normalise_quaternions(q)
    except InputError as err:
        text = re.sub(
            r"\brow (\d+)\b",
            lambda m: f"record {m.group(1)} (byte {int(m.group(1)) * SBET_RECORD_BYTES})",
            str(err),
        )
        msg = f"{path}: {text}"
        raise InputError(msg) from err
    return Trajectory._from_checked(t, q, lat_lon_h=llh, vel_ned_m_s=vel)


def _read_blocks(
    path: Path, n: int, gps_week: int | None
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, tuple[int, str, float] | None]:
    """An SBET's times, positions, NED velocities and attitudes, a block at a time.

    The file is never held whole, and no conversion makes array-sized temporaries: each
    value is computed element by element as on the whole file. Refuses the first
    implausible value (`_SPANS`); the first angle in degrees is returned, not refused.

    Returns
    -------
    t_s, lat_lon_h, vel_ned_m_s, q_body_to_ned : ndarray, shapes (n,), (n, 3), (n, 3), (n, 4)
        As `read_sbet` returns them, the quaternions not yet normalised.
    degrees : (int, str, float) or None
        The first angle beyond what radians hold (`_first_degrees`).
    """
    t = np.empty(n)
    llh = np.empty((n, 3))
    vel = np.empty((n, 3))
    q = np.empty((n, 4))
    week_s: float | None = None
    of_week = True  # the times are seconds of week (the first record tells)
    degrees: tuple[int, str, float] | None = None
    raw = bytearray(_BLOCK_RECORDS * SBET_RECORD_BYTES)
    try:
        with path.open("rb") as fh:
            for start in range(0, n, _BLOCK_RECORDS):
                k = min(_BLOCK_RECORDS, n - start)
                if fh.readinto(memoryview(raw)[: k * SBET_RECORD_BYTES]) != k * SBET_RECORD_BYTES:
                    msg = (
                        f"{path}: the file ended while it was read, before its {n} records "
                        "(its length when opened): was it changed meanwhile? copy it again"
                    )
                    raise InputError(msg)
                rec = np.frombuffer(raw, dtype=SBET_DTYPE, count=k)
                if start == 0:
                    of_week = not holds_gps_time(float(rec["time_sow_s"][0]))
                    if gps_week is not None and of_week:
                        week_s = gps_week * SECONDS_PER_WEEK
                # The first implausible value anywhere comes first (a block is only
                # reached when those before it had none), then the first angle in
                # degrees, then what the Trajectory checks.
                spans = _WEEK_SPANS if of_week else _SPANS
                check_columns(
                    {name: rec[name] for name in spans},
                    spans,
                    _record_namer(path, start),
                )
                if degrees is None:
                    degrees = _first_degrees(rec, start)
                rows = slice(start, start + k)
                t[rows] = rec["time_sow_s"] if week_s is None else week_s + rec["time_sow_s"]
                llh[rows, 0] = np.degrees(rec["lat_rad"])
                llh[rows, 1] = np.degrees(rec["lon_rad"])
                llh[rows, 2] = rec["h_m"]
                wander = rec["wander_angle_rad"]
                vel[rows] = wander_to_ned_velocity(
                    rec["vel_x_wander_m_s"],
                    rec["vel_y_wander_m_s"],
                    rec["vel_z_wander_m_s"],
                    wander,
                )
                q[rows] = euler_rpy_to_quaternion(
                    rec["roll_rad"], rec["pitch_rad"], rec["platform_heading_rad"] - wander
                )
    except OSError as err:
        msg = f"{path}: cannot read ({err.strerror or err})"
        raise InputError(msg) from err
    return t, llh, vel, q, degrees


def _record_namer(path: Path, first_record: int) -> Callable[[int], str]:
    """Names record ``first_record + i`` of ``path`` and its byte, for `check_columns`."""

    def where(i: int) -> str:
        return f"{path}: record {first_record + i} (byte {(first_record + i) * SBET_RECORD_BYTES})"

    return where


def _first_degrees(rec: npt.NDArray[np.void], first_record: int) -> tuple[int, str, float] | None:
    """The first angle in a block of records beyond what radians hold (`_ATTITUDE_LIMITS_RAD`).

    Returns
    -------
    (int, str, float) or None
        Its record (``first_record`` + its index in ``rec``), field and value.
    """
    first: tuple[int, str, float] | None = None
    for name, (limit, _) in _ATTITUDE_LIMITS_RAD.items():
        bad = np.abs(rec[name]) > limit
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            if first is None or first_record + i < first[0]:
                first = (first_record + i, name, float(rec[name][i]))
    return first


def _refuse_degrees(path: Path, first: tuple[int, str, float]) -> None:
    """Refuse the first angle beyond what radians can hold (`_first_degrees`)."""
    i, name, value = first
    msg = (
        f"{path}: record {i} (byte {i * SBET_RECORD_BYTES}), field {name!r}: {value!r} "
        f"is beyond {_ATTITUDE_LIMITS_RAD[name][1]} rad: the attitude looks like degrees; "
        "an SBET holds roll, pitch, heading and wander angle in radians: export it again "
        "(or convert those fields to radians)"
    )
    raise InputError(msg)


def sbet_holds_gps_time(path: Path) -> bool:
    """Whether an SBET's time field holds GPS time rather than GPS seconds of week.

    True when the first record's time lies beyond a week and a day
    (`kinsync.io.gps_week.holds_gps_time`): `read_sbet` then adds no GPS week.

    Raises
    ------
    InputError
        As `read_sbet_records` (no records, a truncated file).
    """
    rec = read_sbet_records(Path(path))
    try:
        return rec.shape[0] > 0 and holds_gps_time(float(rec["time_sow_s"][0]))
    finally:
        del rec


def sbet_gps_week(t_s: FloatArray) -> int | None:
    """The GPS week whose seconds `seconds_of_first_week` gives for times ``t_s``.

    Parameters
    ----------
    t_s : ndarray, shape (N,)
        Times (s): continuous GPS time, or already seconds of week.

    Returns
    -------
    int or None
        The week of the first time; None when the times are below one week (written
        as they are: their week is not known here) or there are none.
    """
    if len(t_s) == 0:
        return None
    week = math.floor(float(t_s[0]) / SECONDS_PER_WEEK)
    return week if week > 0 else None


def seconds_of_first_week(t_s: FloatArray) -> FloatArray:
    """Times (s) as seconds of the first record's GPS week (unchanged below one week).

    Continuous GPS times past the end of that week keep counting beyond 604800 s, so
    that they stay increasing. The week is `sbet_gps_week`.
    """
    week = sbet_gps_week(t_s)
    if week is None:
        return t_s
    out: FloatArray = t_s - week * SECONDS_PER_WEEK
    return out


def write_sbet(trajectory: Trajectory, path: Path, *, wander_angle_rad: float = 0.0) -> None:
    """Write a geodetic trajectory as an SBET file, atomically.

    Parameters
    ----------
    trajectory : Trajectory
        Geodetic trajectory (``lat_lon_h``). Times below 604800 s are written as
        seconds of week as they are; larger (continuous GPS) times as seconds of the
        first record's week.
    path : Path
        Output file; written to a temporary name and renamed when complete.
    wander_angle_rad : float, optional
        Constant wander angle alpha (rad) to write; platform heading and wander-frame
        velocities are written for it. Default 0 (wander frame = NED).

    Notes
    -----
    Velocities are written as zero when the trajectory has none (read back, zero
    velocities of a moving trajectory fail `Trajectory.velocity_check`: positions are
    then interpolated linearly, with a warning); body accelerations are written as
    zero; body angular rates come from `Trajectory.angular_rate_body_rad_s`.

    Raises
    ------
    InputError
        A local-NED trajectory, or a non-finite wander angle.
    """
    path = Path(path)
    if trajectory.lat_lon_h is None:
        msg = (
            f"{path}: write_sbet needs a geodetic trajectory (lat_lon_h); convert the "
            "local NED positions to geodetic first"
        )
        raise InputError(msg)
    if not math.isfinite(wander_angle_rad):
        msg = f"{path}: wander_angle_rad must be finite, got {wander_angle_rad}"
        raise InputError(msg)
    n = len(trajectory)
    alpha = np.full(n, float(wander_angle_rad))
    rpy = trajectory.euler_rpy_rad()
    vel = trajectory.vel_ned_m_s if trajectory.vel_ned_m_s is not None else np.zeros((n, 3))
    vel_w = ned_to_wander_velocity(vel, alpha)
    rate = trajectory.angular_rate_body_rad_s()
    rec = np.zeros(n, dtype=SBET_DTYPE)
    rec["time_sow_s"] = seconds_of_first_week(trajectory.t_s)
    rec["lat_rad"] = np.radians(trajectory.lat_lon_h[:, 0])
    rec["lon_rad"] = np.radians(trajectory.lat_lon_h[:, 1])
    rec["h_m"] = trajectory.lat_lon_h[:, 2]
    rec["vel_x_wander_m_s"] = vel_w[:, 0]
    rec["vel_y_wander_m_s"] = vel_w[:, 1]
    rec["vel_z_wander_m_s"] = vel_w[:, 2]
    rec["roll_rad"] = rpy[:, 0]
    rec["pitch_rad"] = rpy[:, 1]
    rec["platform_heading_rad"] = rpy[:, 2] + alpha
    rec["wander_angle_rad"] = alpha
    rec["rate_x_body_rad_s"] = rate[:, 0]
    rec["rate_y_body_rad_s"] = rate[:, 1]
    rec["rate_z_body_rad_s"] = rate[:, 2]
    write_records(rec, path)
