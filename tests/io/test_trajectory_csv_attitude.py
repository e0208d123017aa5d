"""A trajectory CSV whose degree columns hold radians is refused, not read 57x too small.

Found by a review: `validate control-points` on such a file drove the southbound passes
backwards and halved the time error's sigma, with exit 0.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from kinsync._typing import FloatArray
from kinsync.errors import InputError, KinsyncWarning
from kinsync.io.trajectory_csv import read_trajectory_csv

HEADER = "t_s,lat_deg,lon_deg,h_m,roll_deg,pitch_deg,yaw_deg\n"


def _moving_yaw(
    path: Path, t: FloatArray, lat: FloatArray, lon: FloatArray, yaw: FloatArray
) -> Path:
    """A trajectory CSV at 10 m height, roll 0.5 and pitch -1 deg, the yaw given (deg)."""
    rows = [
        f"{1.4e9 + ti:.3f},{la:.10f},{lo:.10f},10.0,0.5,-1.0,{y:.6f}"
        for ti, la, lo, y in zip(t, lat, lon, yaw, strict=True)
    ]
    path.write_text(HEADER + "\n".join(rows) + "\n")
    return path


def _lines(tmp_path: Path, *, crab_deg: float = 0.0, radians: bool = False) -> Path:
    """Two 60 s lines on bearing 60 then 240 deg at 5 m/s, 10 Hz; yaw = course + crab."""
    t = np.arange(0.0, 120.0, 0.1)
    along = np.where(t < 60.0, 5.0 * t, 5.0 * (120.0 - t))
    bearing = math.radians(60.0)
    lat = 46.8 + np.degrees(along * math.cos(bearing) / 6.37e6)
    lon = -71.2 + np.degrees(along * math.sin(bearing) / (6.37e6 * math.cos(math.radians(46.8))))
    yaw = np.where(t < 60.0, 60.0, 240.0) + crab_deg
    yaw = (yaw + 180.0) % 360.0 - 180.0
    roll = 1.5 * np.sin(t / 3.0)
    pitch = -2.0 + 0.5 * np.cos(t / 4.0)
    att = np.column_stack([roll, pitch, yaw])
    if radians:
        att = np.radians(att)
    rows = [
        f"{1.4e9 + ti:.3f},{la:.10f},{lo:.10f},10.0,{a[0]:.8f},{a[1]:.8f},{a[2]:.8f}"
        for ti, la, lo, a in zip(t, lat, lon, att, strict=True)
    ]
    path = tmp_path / "traj.csv"
    path.write_text(HEADER + "\n".join(rows) + "\n")
    return path


def test_radians_under_degree_columns_are_refused(tmp_path: Path) -> None:
    path = _lines(tmp_path, radians=True)
    with pytest.raises(InputError) as info:
        read_trajectory_csv(path)
    message = str(info.value)
    assert message.startswith(f"{path}: roll_deg, pitch_deg and yaw_deg look like radians")
    assert "convert the attitude columns to degrees" in message


@pytest.mark.parametrize("crab_deg", [0.0, 15.0, -25.0])
def test_degrees_are_read_even_when_the_vessel_crabs(tmp_path: Path, crab_deg: float) -> None:
    traj = read_trajectory_csv(_lines(tmp_path, crab_deg=crab_deg))
    medians = traj.heading_against_course()
    assert medians is not None
    assert medians[0] == pytest.approx(abs(crab_deg), abs=0.5)  # spherical Earth here


def test_small_angles_without_motion_are_read(tmp_path: Path) -> None:
    """A rotating table or a moored vessel: no course to judge by, read with a warning."""
    t = np.arange(0.0, 60.0, 0.1)
    rows = [f"{ti:.3f},46.8,-71.2,10.0,0.01,-0.02,{math.sin(ti):.6f}" for ti in t]
    path = tmp_path / "still.csv"
    path.write_text(HEADER + "\n".join(rows) + "\n")
    with pytest.warns(KinsyncWarning, match="could not be checked"):
        traj = read_trajectory_csv(path)
    assert traj.heading_against_course() is None


def test_static_angles_within_pi_warn_that_the_unit_was_not_checked(tmp_path: Path) -> None:
    """Review G: a static or slow trajectory with attitude in radians passed silently."""
    t = np.arange(0.0, 60.0, 0.1)
    rows = [f"{1.4e9 + ti:.3f},46.8,-71.2,10.0,0.01,-0.02,{math.sin(ti):.6f}" for ti in t]
    path = tmp_path / "still.csv"
    path.write_text(HEADER + "\n".join(rows) + "\n")
    with pytest.warns(KinsyncWarning) as caught:
        read_trajectory_csv(path)
    (message,) = [str(w.message) for w in caught]
    assert message.startswith(f"{path}: every value of roll_deg, pitch_deg and yaw_deg")
    assert "could not be checked" in message
    assert "static or moves too slowly" in message


@pytest.mark.parametrize("yaw_deg", [60.0, 1.5])
def test_moving_degrees_do_not_warn(tmp_path: Path, yaw_deg: float) -> None:
    """Degrees on the move, even small angles: the course over ground decides."""
    t = np.arange(0.0, 60.0, 0.1)
    bearing = math.radians(yaw_deg)
    along = 5.0 * t
    lat = 46.8 + np.degrees(along * math.cos(bearing) / 6.37e6)
    lon = -71.2 + np.degrees(along * math.sin(bearing) / (6.37e6 * math.cos(math.radians(46.8))))
    path = _moving_yaw(tmp_path / "moving.csv", t, lat, lon, np.full(t.size, yaw_deg))
    with warnings.catch_warnings():
        warnings.simplefilter("error", KinsyncWarning)
        read_trajectory_csv(path)


@pytest.mark.parametrize(
    ("column", "value", "span"),
    [
        ("pitch_deg", 95.0, "-90 to 90 deg"),
        ("pitch_deg", -90.5, "-90 to 90 deg"),
        ("roll_deg", 400.0, "-360 to 360 deg"),
        ("yaw_deg", -361.0, "-360 to 360 deg"),
    ],
)
def test_angles_beyond_their_span_are_refused(
    tmp_path: Path, column: str, value: float, span: str
) -> None:
    """Review G: pitch 95 deg and roll 400 deg were read (a mount refuses beyond 360)."""
    angles = {"roll_deg": 1.0, "pitch_deg": 2.0, "yaw_deg": 30.0, column: value}
    rows = [
        f"{1.4e9 + i:.1f},46.8,-71.2,10.0,{angles['roll_deg']},{angles['pitch_deg']},"
        f"{angles['yaw_deg'] if i else 30.0}"
        for i in range(3)
    ]
    path = tmp_path / "bad.csv"
    path.write_text(HEADER + "\n".join(rows) + "\n")
    with pytest.raises(InputError) as info:
        read_trajectory_csv(path)
    line = 2 if column != "yaw_deg" else 3
    assert str(info.value).startswith(f"{path}: line {line}, column {column!r}: {value!r}")
    assert span in str(info.value)


def _circle(tmp_path: Path, yaw_of_file: Callable[[FloatArray], FloatArray]) -> Path:
    """A 100 m circle at 5 m/s (every heading), 10 Hz; the file's yaw from the true one."""
    t = np.arange(0.0, 150.0, 0.1)
    phase = 5.0 * t / 100.0  # rad along the circle, clockwise seen from above
    north, east = 100.0 * np.sin(phase), 100.0 - 100.0 * np.cos(phase)
    heading = np.degrees(phase)  # the course, clockwise from north
    yaw = (yaw_of_file(heading) + 180.0) % 360.0 - 180.0
    lat = 46.8 + np.degrees(north / 6.37e6)
    lon = -71.2 + np.degrees(east / (6.37e6 * math.cos(math.radians(46.8))))
    return _moving_yaw(tmp_path / "circle.csv", t, lat, lon, yaw)


@pytest.mark.parametrize(
    ("yaw_of_file", "named"),
    [
        (lambda h: 90.0 - h, "counter-clockwise from east (ENU)"),
        (lambda h: -h, "counter-clockwise from north"),
        (lambda h: h + 180.0, "of the body's -x axis (X backwards)"),
        (lambda h: h - 90.0, "of a body axis 90 deg right of x"),
    ],
)
def test_a_yaw_in_another_convention_is_named(
    tmp_path: Path, yaw_of_file: Callable[[FloatArray], FloatArray], named: str
) -> None:
    """Review Q3: ENU, counter-clockwise or reversed yaw was read silently (points 11-13 m off)."""
    path = _circle(tmp_path, yaw_of_file)
    with pytest.warns(KinsyncWarning) as caught:
        read_trajectory_csv(path)
    (message,) = [str(w.message) for w in caught]
    assert message.startswith(f"{path}: yaw_deg is more than 45 deg off the course over ground")
    assert f"where a yaw written {named} would follow it (median 0." in message


@pytest.mark.parametrize("crab_deg", [0.0, 25.0, -30.0])
def test_a_yaw_that_follows_the_course_does_not_warn(tmp_path: Path, crab_deg: float) -> None:
    path = _circle(tmp_path, lambda h: h + crab_deg)
    with warnings.catch_warnings():
        warnings.simplefilter("error", KinsyncWarning)
        read_trajectory_csv(path)


def test_a_straight_track_with_a_yaw_off_its_course_names_no_convention(tmp_path: Path) -> None:
    # CI: a synthetic track on course 54 deg with yaw 17 +- 17 deg fitted "ENU" by chance.
    t = np.arange(0.0, 60.0, 0.1)
    lat = 46.8 + 1e-5 * t
    lon = -71.2 + 2e-5 * t
    yaw = np.degrees(0.3 + 0.3 * np.sin(t))
    path = _moving_yaw(tmp_path / "straight.csv", t, lat, lon, yaw)
    with warnings.catch_warnings():
        warnings.simplefilter("error", KinsyncWarning)
        read_trajectory_csv(path)
