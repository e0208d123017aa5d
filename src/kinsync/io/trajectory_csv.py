"""Trajectory CSV files.

Columns ``t_s,lat_deg,lon_deg,h_m,roll_deg,pitch_deg,yaw_deg``, optionally followed
by ``vn_m_s,ve_m_s,vd_m_s``.

Times are read as they are (the caller knows the scale, GPS time by default);
attitude is DIN 9300 roll, pitch, yaw in degrees, roll and yaw within ±360°, pitch
within ±90° (a file whose attitude columns hold radians is refused: every value within
±π and a yaw that follows the course over ground only when read as radians; a static or
slow trajectory whose every angle lies within ±π is read with a warning, the unit
unchecked); velocities in NED (m/s) are optional
and, when present, enable cubic Hermite position interpolation.
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np

from kinsync._typing import FloatArray
from kinsync.errors import InputError, KinsyncWarning
from kinsync.frames import wrap_angle_rad
from kinsync.io.gps_week import check_not_future
from kinsync.io.sanity import (
    HEADING_DEG,
    HEIGHT_M,
    LATITUDE_DEG,
    LONGITUDE_DEG,
    PITCH_DEG,
    ROLL_DEG,
    SPEED_M_S,
    TIME_S,
    Span,
    check_columns,
)
from kinsync.io.tables import read_numeric_csv, rows_to_lines, write_numeric_csv
from kinsync.trajectory import Trajectory

__all__ = ["read_trajectory_csv", "write_trajectory_csv"]

RADIANS_COURSE_DEG = 20.0
"""Yaw read as radians within this of the course over ground (median, deg) ..."""
DEGREES_COURSE_DEG = 45.0
"""... and read as degrees beyond this: the attitude columns hold radians."""

YAW_OFF_COURSE_DEG = 45.0
"""A yaw more than this (deg) from the course over ground is off course: a crabbing
vessel or an aircraft in a cross wind stays within 30 deg of it."""
YAW_OFF_SHARE = 0.1
"""When more than this share of the moving records are off course (`YAW_OFF_COURSE_DEG`)
and another yaw convention leaves fewer than `YAW_CONVENTION_OFF_SHARE` off course, with
a median within `YAW_CONVENTION_FITS_DEG`, a warning names that convention. A share,
not the median: a drive along one diagonal reads the same in ENU except in its turns."""
YAW_CONVENTION_OFF_SHARE = 0.02
YAW_CONVENTION_FITS_DEG = 15.0
YAW_TURN_DEG = 90.0
"""The course must turn by this much (deg) for the conventions to be told apart: on a
straight track any constant offset between yaw and course fits one of them by chance."""

_YAW_CONVENTIONS: tuple[tuple[str, str, float, float], ...] = (
    # (convention, conversion, sign, offset deg): the yaw read = sign * yaw + offset
    ("counter-clockwise from east (ENU)", "yaw = 90 - yaw_enu, pitch = -pitch_enu", -1.0, 90.0),
    ("counter-clockwise from north", "yaw = -yaw_ccw", -1.0, 0.0),
    ("of the body's -x axis (X backwards)", "yaw + 180, and check the IMU's axes", 1.0, 180.0),
    ("of a body axis 90 deg right of x", "yaw + 90, and check the IMU's axes", 1.0, 90.0),
    ("of a body axis 90 deg left of x", "yaw - 90, and check the IMU's axes", 1.0, -90.0),
)
"""Yaw conventions a file may have been written in, and the yaw kinsync reads from them."""

REQUIRED = ("t_s", "lat_deg", "lon_deg", "h_m", "roll_deg", "pitch_deg", "yaw_deg")
VELOCITY = ("vn_m_s", "ve_m_s", "vd_m_s")

SPANS: dict[str, Span] = {
    "t_s": TIME_S,
    "lat_deg": LATITUDE_DEG,
    "lon_deg": LONGITUDE_DEG,
    "h_m": HEIGHT_M,
    "roll_deg": ROLL_DEG,
    "pitch_deg": PITCH_DEG,
    "yaw_deg": HEADING_DEG,
    **dict.fromkeys(VELOCITY, SPEED_M_S),
}
"""Plausible values of each column (`kinsync.io.sanity`)."""


def read_trajectory_csv(path: Path) -> Trajectory:
    """Read a trajectory CSV; errors name the file and the line at fault.

    Raises
    ------
    InputError
        As `kinsync.io.tables.read_numeric_csv`; fewer than 2 records, a value that is
        not finite or not plausible (`SPANS`; a GPS time after today, most likely Unix
        time: `kinsync.io.gps_week.check_not_future`), and what `Trajectory` refuses (repeated
        or decreasing times, ...), naming the line.
    """
    table = read_numeric_csv(Path(path), REQUIRED, VELOCITY)
    c = table.columns
    if table.n_rows < 2:
        msg = f"{path}: a trajectory needs at least 2 records, found {table.n_rows}"
        raise InputError(msg)
    check_columns(c, SPANS, lambda row: f"{path}: line {table.line_of_row(row)}")
    check_not_future(c["t_s"], lambda row: f"{path}: line {table.line_of_row(row)}, column 't_s'")
    present = [v in c for v in VELOCITY]
    if any(present) and not all(present):
        msg = f"{path}: give all of {list(VELOCITY)} or none, found only some"
        raise InputError(msg)
    vel = np.column_stack([c[v] for v in VELOCITY]) if all(present) else None
    try:
        traj = Trajectory.from_euler(
            c["t_s"],
            np.radians(c["roll_deg"]),
            np.radians(c["pitch_deg"]),
            np.radians(c["yaw_deg"]),
            lat_lon_h=np.column_stack([c["lat_deg"], c["lon_deg"], c["h_m"]]),
            vel_ned_m_s=vel,
        )
    except InputError as err:
        # Trajectory names 0-based data rows; give the file line as well.
        msg = f"{path}: {rows_to_lines(str(err), table.line_of_row)}"
        raise InputError(msg) from err
    _refuse_radians(path, c, traj)
    _warn_yaw_convention(path, traj)
    return traj


def _refuse_radians(path: Path, c: dict[str, FloatArray], traj: Trajectory) -> None:
    """Refuse attitude columns that hold radians; warn when that cannot be told.

    Every value lies within ±π, and the yaw follows the course over ground only when
    read as radians (`Trajectory.heading_against_course`). A static or slow trajectory
    has no course over ground: every value within ±π then gives a `KinsyncWarning`.
    """
    attitude = np.column_stack([c["roll_deg"], c["pitch_deg"], c["yaw_deg"]])
    if np.abs(attitude).max() > math.pi + 1e-9:
        return
    medians = traj.heading_against_course()
    if medians is None:
        warnings.warn(
            f"{path}: every value of roll_deg, pitch_deg and yaw_deg lies within +-pi "
            "(+-3.1416), as radians would, and the unit could not be checked: the trajectory "
            "is static or moves too slowly (below 1 m/s) to compare yaw_deg with the course "
            "over ground; if these columns hold radians, convert them to degrees",
            KinsyncWarning,
            stacklevel=3,
        )
        return
    as_deg, as_rad = medians
    if as_rad < RADIANS_COURSE_DEG and as_deg > DEGREES_COURSE_DEG:
        msg = (
            f"{path}: roll_deg, pitch_deg and yaw_deg look like radians: every value lies "
            f"within +-pi, and yaw_deg read as radians follows the course over ground (median "
            f"difference {as_rad:.1f} deg) where read as degrees it does not ({as_deg:.1f} "
            "deg); convert the attitude columns to degrees"
        )
        raise InputError(msg)


def _warn_yaw_convention(path: Path, traj: Trajectory) -> None:
    """Warn when the yaw follows the course over ground only in another convention.

    kinsync reads yaw clockwise from north (DIN 9300, NED). A yaw written counter-
    clockwise from east (ENU) or from north, or of a body axis other than x, georeferences
    every point off by metres, and the velocities check nothing of it. On a trajectory
    that moves and turns by `YAW_TURN_DEG` (`Trajectory.course_and_yaw_rad`), a yaw more
    than `YAW_OFF_COURSE_DEG` off the course on more than `YAW_OFF_SHARE` of the moving
    records, while another convention follows it (`YAW_CONVENTION_OFF_SHARE`,
    `YAW_CONVENTION_FITS_DEG`), gives a `KinsyncWarning` naming that convention. A
    warning, not a refusal: a platform may truly move backwards or sideways throughout (a
    pushed trolley, a hovering aircraft).
    """
    course, yaw = traj.course_and_yaw_rad()
    if course.size < 10 or np.ptp(np.unwrap(course)) < math.radians(YAW_TURN_DEG):
        return

    def off_course_deg(angle_rad: FloatArray) -> FloatArray:
        off: FloatArray = np.degrees(np.abs(wrap_angle_rad(angle_rad - course)))
        return off

    as_given = off_course_deg(yaw)
    share = float(np.mean(as_given > YAW_OFF_COURSE_DEG))
    if share <= YAW_OFF_SHARE:
        return
    fits = []
    for name, conversion, sign, offset_deg in _YAW_CONVENTIONS:
        off = off_course_deg(sign * yaw + math.radians(offset_deg))
        median = float(np.median(off))
        if (
            median <= YAW_CONVENTION_FITS_DEG
            and np.mean(off > YAW_OFF_COURSE_DEG) < YAW_CONVENTION_OFF_SHARE
        ):
            fits.append((median, name, conversion))
    if not fits:
        return
    off_median, name, conversion = min(fits)
    warnings.warn(
        f"{path}: yaw_deg is more than {YAW_OFF_COURSE_DEG:g} deg off the course over ground "
        f"on {share:.0%} of {course.size} moving records (median "
        f"{float(np.median(as_given)):.0f} deg), where a yaw written {name} would follow it "
        f"(median {off_median:.1f} deg): kinsync reads the yaw of the body's x axis "
        f"(forward) clockwise from north (DIN 9300, NED); convert it ({conversion}) unless "
        "the platform truly moved that way throughout",
        KinsyncWarning,
        stacklevel=3,
    )


def write_trajectory_csv(trajectory: Trajectory, path: Path) -> None:
    """Write a geodetic trajectory as CSV (velocities included when present)."""
    if trajectory.lat_lon_h is None:
        msg = "write_trajectory_csv: only geodetic trajectories (lat_lon_h) can be written"
        raise InputError(msg)
    rpy = np.degrees(trajectory.euler_rpy_rad())
    cols = {
        "t_s": trajectory.t_s,
        "lat_deg": trajectory.lat_lon_h[:, 0],
        "lon_deg": trajectory.lat_lon_h[:, 1],
        "h_m": trajectory.lat_lon_h[:, 2],
        "roll_deg": rpy[:, 0],
        "pitch_deg": rpy[:, 1],
        "yaw_deg": rpy[:, 2],
    }
    if trajectory.vel_ned_m_s is not None:
        for i, name in enumerate(VELOCITY):
            cols[name] = trajectory.vel_ned_m_s[:, i]
    write_numeric_csv(Path(path), cols)
