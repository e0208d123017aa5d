"""A log stamped with Unix time is refused where GPS time is read, naming the conversion.

Unix time (UTC seconds since 1970) is GPS time plus 315964782 s since 2017: read as GPS
time it lies about ten years ahead, which no survey can. Such logs were read without a
word wherever the inputs agreed with each other (a georeferencing run took a coordinate
epoch ten years late; ``ins run`` wrote an SBET of a week no command accepts). The times
here are taken relative to this computer's clock, as the check takes them.
"""

from __future__ import annotations

import math
from pathlib import Path

import laspy
import numpy as np
import pytest
from tests._las import las_points

from kinsync.errors import InputError
from kinsync.ins.measurements import GnssData, ImuData
from kinsync.io.gnss_csv import read_gnss_csv, write_gnss_csv
from kinsync.io.gps_week import UNIX_MINUS_GPS_S, check_not_future, gps_time_now_s
from kinsync.io.imu_csv import read_imu_csv, write_imu_csv
from kinsync.io.las import check_week_seconds, las_info
from kinsync.io.sbet import write_sbet
from kinsync.io.trajectory import read_trajectory_file
from kinsync.io.trajectory_csv import write_trajectory_csv
from kinsync.trajectory import Trajectory

T_GPS = math.floor(gps_time_now_s() - 30 * 86_400.0)  # a survey a month ago, GPS time
T_UNIX = T_GPS + UNIX_MINUS_GPS_S  # the same instant, Unix time

UNIX_WORDS = (
    "after today",
    "looks like Unix time",
    f"GPS time {float(T_GPS)!r} s",
    "subtract 315964800 s and add the leap seconds (18 s since 2017",
    "kinsync.clock.utc_to_gps_s",
)


def _assert_names_unix(err: pytest.ExceptionInfo[InputError], *where: str) -> None:
    msg = str(err.value)
    for words in (*where, *UNIX_WORDS):
        assert words in msg, msg
    assert "\n" not in msg


def _traj(t0: float, n: int = 20) -> Trajectory:
    s = np.arange(n, dtype=np.float64) * 0.5
    llh = np.column_stack([46.8 + s * 1e-5, np.full(n, -71.2), np.full(n, 10.0)])
    z = np.zeros(n)
    return Trajectory.from_euler(t0 + s, z, z, np.full(n, 0.1), lat_lon_h=llh)


def test_a_trajectory_csv_in_unix_time_is_refused(tmp_path: Path) -> None:
    write_trajectory_csv(_traj(T_GPS), tmp_path / "gps.csv")
    traj, scale = read_trajectory_file(tmp_path / "gps.csv")  # GPS time: read
    assert (traj.t_start_s, scale) == (T_GPS, "gps")
    write_trajectory_csv(_traj(T_UNIX), tmp_path / "unix.csv")
    with pytest.raises(InputError) as err:
        read_trajectory_file(tmp_path / "unix.csv")
    _assert_names_unix(err, "unix.csv: line 2, column 't_s'")


def test_an_sbet_holding_unix_time_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "unix.out"
    traj = _traj(T_UNIX)
    write_sbet(traj, path)  # seconds of week
    raw = np.fromfile(path, "<f8").reshape(len(traj.t_s), 17)
    raw[:, 0] = traj.t_s  # the time field holds GPS time (here Unix time)
    raw.tofile(path)
    with pytest.raises(InputError) as err:
        read_trajectory_file(path)
    _assert_names_unix(err, "unix.out: record 1")


def test_imu_and_gnss_csv_in_unix_time_are_refused(tmp_path: Path) -> None:
    n = 30
    t = np.arange(n, dtype=np.float64) * 0.01
    acc = np.tile([0.0, 0.0, -9.8], (n, 1))
    imu = ImuData(t_s=T_UNIX + t, gyro_body_rad_s=np.zeros((n, 3)), acc_body_m_s2=acc)
    write_imu_csv(imu, tmp_path / "imu.csv")
    with pytest.raises(InputError) as err:
        read_imu_csv(tmp_path / "imu.csv")
    _assert_names_unix(err, "imu.csv: line 2, column 't_s'")
    gnss = GnssData(
        t_s=T_GPS + np.arange(5.0),
        lat_deg=np.full(5, 46.8),
        lon_deg=np.full(5, -71.2),
        h_m=np.full(5, 10.0),
        std_pos_ned_m=np.full((5, 3), 0.02),
    )
    write_gnss_csv(gnss, tmp_path / "gps.csv")
    assert read_gnss_csv(tmp_path / "gps.csv").t_s[0] == T_GPS
    gnss = GnssData(**{**gnss.__dict__, "t_s": T_GPS + np.r_[0.0, 1.0, UNIX_MINUS_GPS_S, 5e8, 6e8]})
    write_gnss_csv(gnss, tmp_path / "unix.csv")
    with pytest.raises(InputError) as err:
        read_gnss_csv(tmp_path / "unix.csv")
    _assert_names_unix(err, "unix.csv: line 4, column 't_s'")  # the first one too late


def test_a_las_file_of_adjusted_unix_time_is_refused(tmp_path: Path) -> None:
    """Stored as adjusted standard GPS time (GPS time - 1e9 s), as the header says."""
    n = 10
    cols = {"t_s": T_UNIX + np.arange(n, dtype=np.float64), "x_m": np.zeros(n)}
    las = las_points({**cols, "y_m": np.zeros(n), "z_m": np.zeros(n)})
    las.write(tmp_path / "unix.las")
    info = las_info(tmp_path / "unix.las")
    assert info.gps_time_type == "adjusted_standard"
    check_week_seconds(info, (T_GPS - 1e9, T_GPS - 1e9 + 9.0))  # GPS time: accepted
    with pytest.raises(InputError) as err:
        check_week_seconds(info, (T_UNIX - 1e9 - 9.0, T_UNIX - 1e9))
    _assert_names_unix(err, "unix.las: gps_time", "adjusted standard GPS time")
    las.header.global_encoding.gps_time_type = laspy.header.GpsTimeType.WEEK_TIME
    las.gps_time = cols["t_s"]  # Unix time with the encoding bit unset
    las.write(tmp_path / "week.las")
    with pytest.raises(InputError) as err:
        check_week_seconds(las_info(tmp_path / "week.las"), (T_UNIX - 9.0, T_UNIX))
    _assert_names_unix(err, "cannot be GPS seconds of week", "GpsTimeType.STANDARD")


def test_times_up_to_a_day_ahead_pass_and_later_ones_name_no_unix_time_when_none_fits() -> None:
    now = gps_time_now_s()
    check_not_future(np.array([0.0, 604_800.0, now + 3_600.0]), lambda row: f"row {row}")
    with pytest.raises(InputError) as err:
        check_not_future(np.array([now, 9e9]), lambda row: f"row {row}")
    msg = str(err.value)
    assert msg.startswith("row 1: 9000000000.0 s as GPS time")
    assert "check the time scale and the unit" in msg
    assert "Unix" not in msg
