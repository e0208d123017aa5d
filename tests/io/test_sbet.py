"""SBET: round trip, hand-built records, wander angle, bad input."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from kinsync.errors import InputError
from kinsync.io.sbet import (
    SBET_DTYPE,
    SECONDS_PER_WEEK,
    ned_to_wander_velocity,
    read_sbet,
    read_sbet_records,
    sbet_gps_week,
    wander_to_ned_velocity,
    write_sbet,
)
from kinsync.trajectory import Trajectory


def _trajectory(n: int = 50, t0: float = 345600.0) -> Trajectory:
    rng = np.random.default_rng(1)
    t = t0 + 0.005 * np.arange(n)
    llh = np.column_stack(
        [46.5 + 1e-6 * np.arange(n), 6.6 + 2e-6 * np.arange(n), 400.0 + rng.normal(0, 0.1, n)]
    )
    vel = rng.normal(0.0, 5.0, (n, 3))
    return Trajectory.from_euler(
        t,
        rng.uniform(-0.1, 0.1, n),
        rng.uniform(-0.1, 0.1, n),
        rng.uniform(-3.0, 3.0, n),
        lat_lon_h=llh,
        vel_ned_m_s=vel,
    )


def _assert_same(a: Trajectory, b: Trajectory) -> None:
    np.testing.assert_array_equal(a.t_s, b.t_s)
    assert a.lat_lon_h is not None
    assert b.lat_lon_h is not None
    np.testing.assert_allclose(a.lat_lon_h, b.lat_lon_h, rtol=0, atol=1e-12)
    dots = np.abs(np.sum(a.q_body_to_ned * b.q_body_to_ned, axis=1))
    np.testing.assert_allclose(dots, 1.0, atol=1e-14)
    assert a.vel_ned_m_s is not None
    assert b.vel_ned_m_s is not None
    np.testing.assert_allclose(a.vel_ned_m_s, b.vel_ned_m_s, rtol=0, atol=1e-12)


def test_dtype_is_136_bytes_of_little_endian_float64() -> None:
    assert SBET_DTYPE.itemsize == 136
    assert len(SBET_DTYPE.names or ()) == 17
    assert all(SBET_DTYPE[i] == np.dtype("<f8") for i in range(17))


def test_round_trip_seconds_of_week(tmp_path: Path) -> None:
    traj = _trajectory()
    path = tmp_path / "a.out"
    write_sbet(traj, path)
    assert path.stat().st_size == 136 * len(traj)
    _assert_same(traj, read_sbet(path))
    # Writing what was read gives the same records, bit for bit in time and position.
    rec = np.array(read_sbet_records(path))
    write_sbet(read_sbet(path), tmp_path / "b.out")
    rec2 = np.array(read_sbet_records(tmp_path / "b.out"))
    np.testing.assert_array_equal(rec["time_sow_s"], rec2["time_sow_s"])
    np.testing.assert_allclose(rec["lat_rad"], rec2["lat_rad"], rtol=0, atol=1e-15)


def test_round_trip_continuous_gps_time_with_week(tmp_path: Path) -> None:
    week = 2301
    traj = _trajectory(t0=week * SECONDS_PER_WEEK + 604799.9)  # crosses into next week
    path = tmp_path / "a.out"
    write_sbet(traj, path)
    rec = read_sbet_records(path)
    assert float(rec["time_sow_s"][0]) == pytest.approx(604799.9)
    assert float(rec["time_sow_s"][-1]) > SECONDS_PER_WEEK  # keeps counting
    _assert_same(traj, read_sbet(path, gps_week=week))
    sow = read_sbet(path)
    np.testing.assert_array_equal(sow.t_s + week * SECONDS_PER_WEEK, traj.t_s)


def test_hand_built_records_field_by_field(tmp_path: Path) -> None:
    values = np.arange(2 * 17, dtype="<f8").reshape(2, 17) * 0.01
    values[:, 0] = [1000.0, 1000.5]  # time
    values[:, 1] = [0.8, 0.8001]  # lat rad
    values[:, 2] = [0.1, 0.1002]  # lon rad
    values[:, 10] = 0.0  # wander angle
    path = tmp_path / "hand.sbet"
    path.write_bytes(values.tobytes())
    rec = read_sbet_records(path)
    assert rec.shape == (2,)
    for i, name in enumerate(SBET_DTYPE.names or ()):
        np.testing.assert_array_equal(rec[name], values[:, i], err_msg=name)
    traj = read_sbet(path)
    np.testing.assert_array_equal(traj.t_s, [1000.0, 1000.5])
    assert traj.lat_lon_h is not None
    np.testing.assert_allclose(traj.lat_lon_h[:, 0], np.degrees(values[:, 1]), rtol=1e-15)
    np.testing.assert_allclose(traj.lat_lon_h[:, 1], np.degrees(values[:, 2]), rtol=1e-15)
    np.testing.assert_array_equal(traj.lat_lon_h[:, 2], values[:, 3])
    rpy = traj.euler_rpy_rad()
    np.testing.assert_allclose(rpy, values[:, 7:10], atol=1e-12)
    assert traj.vel_ned_m_s is not None
    np.testing.assert_allclose(traj.vel_ned_m_s, values[:, 4:7], atol=1e-15)


def test_wander_angle_30_deg(tmp_path: Path) -> None:
    alpha = np.radians(30.0)
    true_heading = np.radians(10.0)
    speed = 12.0
    rec = np.zeros(3, dtype=SBET_DTYPE)
    rec["time_sow_s"] = [1.0, 2.0, 3.0]
    rec["lat_rad"] = 0.8
    rec["wander_angle_rad"] = alpha
    rec["platform_heading_rad"] = true_heading + alpha
    # Moving forward along the true heading: in the wander frame the velocity points
    # along the platform heading (x at azimuth -alpha).
    rec["vel_x_wander_m_s"] = speed * np.cos(true_heading + alpha)
    rec["vel_y_wander_m_s"] = speed * np.sin(true_heading + alpha)
    rec["vel_z_wander_m_s"] = 0.5
    path = tmp_path / "w.sbet"
    rec.tofile(path)
    traj = read_sbet(path)
    np.testing.assert_allclose(traj.euler_rpy_rad()[:, 2], true_heading, atol=1e-12)
    assert traj.vel_ned_m_s is not None
    expected = [speed * np.cos(true_heading), speed * np.sin(true_heading), 0.5]
    np.testing.assert_allclose(traj.vel_ned_m_s, np.tile(expected, (3, 1)), atol=1e-12)
    # Pure wander-x velocity: N = cos(alpha), E = -sin(alpha).
    ned = wander_to_ned_velocity(
        np.array([1.0]), np.array([0.0]), np.array([0.0]), np.array([alpha])
    )
    np.testing.assert_allclose(ned, [[np.cos(alpha), -np.sin(alpha), 0.0]], atol=1e-15)
    back = ned_to_wander_velocity(ned, np.array([alpha]))
    np.testing.assert_allclose(back, [[1.0, 0.0, 0.0]], atol=1e-15)


def test_write_with_wander_angle_reads_back(tmp_path: Path) -> None:
    traj = _trajectory()
    path = tmp_path / "w.out"
    write_sbet(traj, path, wander_angle_rad=np.radians(30.0))
    rec = read_sbet_records(path)
    np.testing.assert_allclose(rec["wander_angle_rad"], np.radians(30.0))
    _assert_same(traj, read_sbet(path))


def test_velocities_zero_when_absent(tmp_path: Path) -> None:
    traj = Trajectory.from_euler(
        [0.0, 1.0], [0.0, 0.0], [0.0, 0.0], [0.0, 0.1], lat_lon_h=[[45, 7, 0], [45, 7, 1]]
    )
    path = tmp_path / "nv.out"
    write_sbet(traj, path)
    rec = read_sbet_records(path)
    for c in ("vel_x_wander_m_s", "vel_y_wander_m_s", "vel_z_wander_m_s"):
        np.testing.assert_array_equal(rec[c], 0.0)


def test_truncated_file(tmp_path: Path) -> None:
    path = tmp_path / "t.sbet"
    path.write_bytes(b"\0" * (136 * 3 + 5))
    with pytest.raises(InputError, match=r"t\.sbet.*3 whole records and 5 bytes left over"):
        read_sbet(path)


def test_decreasing_time_names_record(tmp_path: Path) -> None:
    rec = np.zeros(5, dtype=SBET_DTYPE)
    rec["time_sow_s"] = [1.0, 2.0, 3.0, 2.5, 4.0]
    path = tmp_path / "d.sbet"
    rec.tofile(path)
    with pytest.raises(InputError, match=r"d\.sbet.*decreasing time in record 3"):
        read_sbet(path)


def test_bad_inputs(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="not found"):
        read_sbet(tmp_path / "missing.sbet")
    (tmp_path / "empty.sbet").write_bytes(b"")
    with pytest.raises(InputError, match="empty"):
        read_sbet(tmp_path / "empty.sbet")
    one = np.zeros(1, dtype=SBET_DTYPE)
    one.tofile(tmp_path / "one.sbet")
    with pytest.raises(InputError, match="at least 2 records"):
        read_sbet(tmp_path / "one.sbet")
    local = Trajectory.from_euler(
        [0.0, 1.0], [0, 0], [0, 0], [0, 0], pos_ned_m=np.zeros((2, 3)), origin_lat_lon_h=(45, 7, 0)
    )
    with pytest.raises(InputError, match="geodetic"):
        write_sbet(local, tmp_path / "x.sbet")
    assert not (tmp_path / "x.sbet").exists()


def test_smrmsg_file_given_as_sbet_is_named(tmp_path: Path) -> None:
    path = tmp_path / "smrmsg_mission.out"
    path.write_bytes(b"\0" * 1360)  # 10 SBET or 17 smrmsg records: the length cannot tell
    with pytest.raises(InputError, match="looks like an smrmsg accuracy file"):
        read_sbet(path)


def _drive_records(n: int) -> np.ndarray:
    """``n`` plausible SBET records: a drive at 200 Hz with a turning wander angle."""
    s = 0.005 * np.arange(n)
    rec = np.zeros(n, dtype=SBET_DTYPE)
    rec["time_sow_s"] = 216000.0 + s
    rec["lat_rad"] = np.radians(46.8) + 2e-6 * s
    rec["lon_rad"] = np.radians(-71.2) + 3e-6 * s
    rec["h_m"] = 50.0 + np.sin(s)
    rec["vel_x_wander_m_s"] = 12.0 + np.cos(s)
    rec["vel_y_wander_m_s"] = 5.0 * np.sin(s)
    rec["vel_z_wander_m_s"] = -0.1 * np.cos(s)
    rec["roll_rad"] = 0.02 * np.sin(s / 7.0)
    rec["pitch_rad"] = 0.01 * np.sin(s / 11.0)
    rec["platform_heading_rad"] = np.mod(0.3 * s, 2 * np.pi)
    rec["wander_angle_rad"] = 0.1 * np.sin(s / 3.0)
    return rec


def test_times_are_checked_once_per_read(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The reader checks its arrays; the Trajectory it makes does not check them again.

    (It did: ``from_euler`` checked the times, then ``Trajectory`` checked them, and
    every other array, once more, copying each.)
    """
    import kinsync.io.sbet as sbet_module  # noqa: PLC0415
    import kinsync.trajectory as trajectory_module  # noqa: PLC0415
    from kinsync.trajectory_times import validated_times  # noqa: PLC0415

    calls: list[int] = []

    def spy(values: np.ndarray) -> np.ndarray:
        calls.append(len(values))
        return validated_times(values)

    monkeypatch.setattr(trajectory_module, "validated_times", spy)
    monkeypatch.setattr(sbet_module, "validated_times", spy, raising=False)
    path = tmp_path / "drive.out"
    _drive_records(500).tofile(path)
    traj = read_sbet(path, gps_week=2345)
    assert len(traj) == 500
    assert calls == [500]


def test_read_in_blocks_is_the_whole_read_bit_for_bit(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import kinsync.io.sbet as sbet_module  # noqa: PLC0415

    path = tmp_path / "drive.out"
    _drive_records(500).tofile(path)
    whole = read_sbet(path, gps_week=2345)
    monkeypatch.setattr(sbet_module, "_BLOCK_RECORDS", 7)
    blocks = read_sbet(path, gps_week=2345)
    for name in ("t_s", "q_body_to_ned", "lat_lon_h", "vel_ned_m_s"):
        a, b = getattr(whole, name), getattr(blocks, name)
        assert a.tobytes() == b.tobytes(), name
        assert not b.flags.writeable
    assert blocks.velocity_check == whole.velocity_check


def test_read_in_blocks_names_the_error_a_whole_read_names(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """An implausible value in a later block comes before degrees in an earlier one,
    which come before a repeated time in an earlier one still."""
    import kinsync.io.sbet as sbet_module  # noqa: PLC0415

    monkeypatch.setattr(sbet_module, "_BLOCK_RECORDS", 7)
    rec = _drive_records(40)
    rec["time_sow_s"][3] = rec["time_sow_s"][2]
    rec["roll_rad"][12] = 45.0
    rec["pitch_rad"][9] = 80.0
    path = tmp_path / "bad.out"
    rec.tofile(path)
    with pytest.raises(InputError, match=r"record 9 \(byte 1224\), field 'pitch_rad'"):
        read_sbet(path)
    rec["h_m"][30] = 1e6
    rec.tofile(path)
    with pytest.raises(InputError, match=r"record 30 \(byte 4080\), column 'h_m'"):
        read_sbet(path)
    rec["h_m"][30] = 50.0
    rec["roll_rad"][12] = rec["pitch_rad"][9] = 0.0
    rec.tofile(path)
    with pytest.raises(InputError, match=r"repeated time in record 3 \(byte 408\)"):
        read_sbet(path)


def test_a_longitude_a_trajectory_refuses_is_refused_naming_the_record(tmp_path: Path) -> None:
    """-200 deg (within +-2 pi rad) reached a Trajectory unchecked: the reader's spans
    stand for its checks."""
    rec = _drive_records(40)
    rec["lon_rad"][5] = math.radians(-200.0)
    path = tmp_path / "lon.out"
    rec.tofile(path)
    with pytest.raises(InputError, match=r"lon\.out: record 5 \(byte 680\), column 'lon_rad'"):
        read_sbet(path)
    rec["lon_rad"] = np.radians(288.8) + 3e-6 * np.arange(40)  # 0 to 2 pi: read as before
    rec.tofile(path)
    llh = read_sbet(path).lat_lon_h
    assert llh is not None
    assert llh[0, 1] == pytest.approx(288.8)


@pytest.mark.parametrize("gps_week", [None, 2345])
def test_negative_seconds_of_week_are_refused_naming_the_record(
    tmp_path: Path, gps_week: int | None
) -> None:
    # Were read as times of an earlier week (exit 0 from trajectory info --gps-week).
    rec = _drive_records(40)
    rec["time_sow_s"] -= 216000.0 + 1000.0
    path = tmp_path / "neg.out"
    rec.tofile(path)
    with pytest.raises(InputError, match=r"neg\.out: record 0 \(byte 0\), column 'time_sow_s'"):
        read_sbet(path, gps_week=gps_week)


def test_times_running_past_the_end_of_the_week_are_still_read(tmp_path: Path) -> None:
    rec = _drive_records(40)
    rec["time_sow_s"] += SECONDS_PER_WEEK - 216000.0 - 0.1  # 604799.9 s onwards
    path = tmp_path / "rollover.out"
    rec.tofile(path)
    traj = read_sbet(path, gps_week=2345)
    assert traj.t_s[-1] > 2346 * SECONDS_PER_WEEK


def test_the_gps_week_of_the_written_seconds_of_week() -> None:
    week_s = 2345 * SECONDS_PER_WEEK
    assert sbet_gps_week(np.array([week_s + 604_799.5, week_s + 604_800.5])) == 2345
    assert sbet_gps_week(np.array([216_000.0])) is None  # seconds of week already
    assert sbet_gps_week(np.array([])) is None
