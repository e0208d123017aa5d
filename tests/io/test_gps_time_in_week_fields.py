"""Times that already hold GPS time where seconds of week are expected, and SBET attitude
written in degrees (review G, defects 1 and 2).

An SBET whose time field held GPS time (1.4e9 s) was read as seconds of week: with a
GPS week it landed in 2069, without one `trajectory info` called 1.4e9 s "GPS seconds
of week". An SBET with its attitude in degrees was read as radians (heading 1145 "rad"),
with exit 0 and points moved by metres.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from kinsync.errors import InputError
from kinsync.io.gps_week import WEEK_SECONDS_MAX_S, holds_gps_time
from kinsync.io.las import check_week_seconds
from kinsync.io.pos_text import pos_text_takes_gps_week, read_pos_text
from kinsync.io.sbet import (
    SECONDS_PER_WEEK,
    read_sbet,
    read_sbet_records,
    sbet_holds_gps_time,
    write_sbet,
)
from kinsync.io.smrmsg import SmrmsgData, read_smrmsg, write_smrmsg
from kinsync.io.trajectory import (
    read_trajectory_file,
    trajectory_already_gps_time,
    trajectory_takes_gps_week,
)
from kinsync.trajectory import Trajectory

WEEK = 2345
T_GPS0 = WEEK * SECONDS_PER_WEEK + 345600.0


def _trajectory(t0: float, n: int = 40) -> Trajectory:
    t = t0 + 0.01 * np.arange(n)
    llh = np.column_stack([46.8 + 1e-7 * np.arange(n), np.full(n, -71.2), np.full(n, 10.0)])
    return Trajectory.from_euler(
        t,
        np.full(n, 0.02),
        np.full(n, -0.03),
        np.linspace(2.0, 2.1, n),
        lat_lon_h=llh,
        vel_ned_m_s=np.zeros((n, 3)),
    )


def _gps_time_sbet(tmp_path: Path) -> Path:
    """An SBET whose time field holds GPS time (write_sbet writes seconds of week)."""
    path = tmp_path / "gps.out"
    write_sbet(_trajectory(345600.0), path)
    rec = np.array(read_sbet_records(path))
    rec["time_sow_s"] += WEEK * SECONDS_PER_WEEK
    rec.tofile(path)
    return path


def test_sbet_time_field_holding_gps_time_is_read_as_gps_time(tmp_path: Path) -> None:
    path = _gps_time_sbet(tmp_path)
    expected = T_GPS0 + 0.01 * np.arange(40)
    assert sbet_holds_gps_time(path)
    for week in (None, WEEK):  # a week given for another input is not added again
        traj, scale = read_trajectory_file(path, gps_week=week)
        assert scale == "gps"
        np.testing.assert_array_equal(traj.t_s, expected)
    assert not trajectory_takes_gps_week(path)
    assert trajectory_already_gps_time(path)


def test_seconds_of_week_past_the_rollover_still_take_the_week(tmp_path: Path) -> None:
    """A week-crossing SBET keeps counting past 604800 s: still seconds of week."""
    path = tmp_path / "cross.out"
    write_sbet(_trajectory(WEEK * SECONDS_PER_WEEK + 604799.9), path)
    assert float(read_sbet_records(path)["time_sow_s"][-1]) > SECONDS_PER_WEEK
    assert not sbet_holds_gps_time(path)
    assert trajectory_takes_gps_week(path)
    traj, scale = read_trajectory_file(path)
    assert scale == "week"
    traj, scale = read_trajectory_file(path, gps_week=WEEK)
    assert scale == "gps"
    assert traj.t_start_s == pytest.approx(WEEK * SECONDS_PER_WEEK + 604799.9, abs=1e-6)


def test_the_bound_is_the_one_las_uses() -> None:
    assert not holds_gps_time(SECONDS_PER_WEEK + 3600.0)
    assert holds_gps_time(WEEK_SECONDS_MAX_S + 1.0)
    assert not holds_gps_time(math.nan)


def test_las_week_header_refuses_times_beyond_the_same_bound() -> None:
    class _Info:
        gps_time_type = "week"
        path = Path("x.las")

    check_week_seconds(_Info(), (0.0, WEEK_SECONDS_MAX_S))  # type: ignore[arg-type]
    with pytest.raises(InputError, match="cannot be GPS seconds of week"):
        check_week_seconds(_Info(), (0.0, WEEK_SECONDS_MAX_S + 1.0))  # type: ignore[arg-type]


def test_smrmsg_holding_gps_time_takes_no_week(tmp_path: Path) -> None:
    path = tmp_path / "smrmsg_a.out"
    t = T_GPS0 + np.arange(5.0)
    data = SmrmsgData(
        t_s=t, std_pos_ned_m=np.full((5, 3), 0.02), std_vel_ned_m_s=np.full((5, 3), 0.01),
        std_rpy_rad=np.full((5, 3), 1e-4),
    )  # fmt: skip
    write_smrmsg(data, path)
    raw = np.fromfile(path, "<f8").reshape(5, 10)
    raw[:, 0] = t  # the time field holds GPS time
    raw.tofile(path)
    np.testing.assert_array_equal(read_smrmsg(path, gps_week=WEEK).t_s, t)
    np.testing.assert_array_equal(read_smrmsg(path).t_s, t)


IE_TEXT = """\
Program:     Inertial Explorer Version 8.90

   GPSTime       Latitude      Longitude      H-Ell      Roll     Pitch    Heading
     (sec)          (deg)          (deg)        (m)     (deg)     (deg)      (deg)
"""


@pytest.mark.parametrize(("t0", "gps"), [(1418558400.0, True), (345600.0, False)])
def test_text_export_times_beyond_a_week_are_gps_time(tmp_path: Path, t0: float, gps: bool) -> None:
    path = tmp_path / "ie.txt"
    rows = [f"{t0 + 0.01 * i:.2f} 46.8 -71.2 20.0 0.5 -1.2 45.0" for i in range(3)]
    path.write_text(IE_TEXT + "\n".join(rows) + "\n")
    assert pos_text_takes_gps_week(path) is not gps
    traj, gps_time = read_pos_text(path, gps_week=WEEK)
    assert gps_time
    assert traj.t_start_s == pytest.approx(t0 + (0.0 if gps else WEEK * SECONDS_PER_WEEK))
    traj, gps_time = read_pos_text(path)
    assert gps_time is gps
    assert traj.t_start_s == pytest.approx(t0)


@pytest.mark.parametrize(
    ("field", "value", "span"),
    [
        ("platform_heading_rad", 114.6, "+-2 pi"),
        ("roll_rad", -7.0, "+-2 pi"),
        ("pitch_rad", 1.6, "+-pi/2"),
        ("wander_angle_rad", 30.0, "+-2 pi"),
    ],
)
def test_sbet_attitude_in_degrees_is_refused(
    tmp_path: Path, field: str, value: float, span: str
) -> None:
    path = tmp_path / "deg.out"
    write_sbet(_trajectory(345600.0), path)
    rec = np.array(read_sbet_records(path))
    rec[field][7:] = value
    rec.tofile(path)
    with pytest.raises(InputError) as info:
        read_sbet(path)
    message = str(info.value)
    assert message.startswith(f"{path}: record 7 (byte {7 * 136}), field {field!r}")
    assert span in message
    assert "looks like degrees" in message


def test_sbet_headings_of_real_files_are_read(tmp_path: Path) -> None:
    """Heading within [0, 2 pi) or +-pi, pitch up to pi/2: what SBETs hold."""
    path = tmp_path / "ok.out"
    write_sbet(_trajectory(345600.0), path)
    rec = np.array(read_sbet_records(path))
    rec["platform_heading_rad"] = np.linspace(0.0, 2 * math.pi - 1e-9, len(rec))
    rec["pitch_rad"][0] = math.pi / 2
    rec["roll_rad"][0] = -math.pi
    rec.tofile(path)
    read_sbet(path)
