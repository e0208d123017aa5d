"""Input checks: gaps, time spans, units, static start, initial state; errors and warnings
name rows."""

from __future__ import annotations

import dataclasses
import math
import re
from pathlib import Path

import numpy as np
import pytest

from kinsync.errors import InputError
from kinsync.ins.checks import (
    check_gnss_rejections,
    check_initial_state,
    check_inputs,
    gnss_within_imu_span,
)
from kinsync.ins.config import InsConfig
from kinsync.ins.earth import normal_gravity_m_s2
from kinsync.ins.file_rows import FileRows
from kinsync.ins.measurements import GnssData, ImuData
from kinsync.ins.solution import InitialState
from kinsync.io.gnss_csv import read_gnss_csv
from kinsync.io.imu_csv import read_imu_csv
from kinsync.io.ins_config import read_ins_config

NAVEGO = Path(__file__).resolve().parents[3] / "shared" / "data" / "navego-synthetic"
CONFIG = InsConfig(1e-4, 1e-3, 1e-3, 0.01, 1e-5, 1e-4, max_imu_gap_s=0.1)
LAT, H = 46.8, 50.0
G = float(normal_gravity_m_s2(math.radians(LAT), H))
T0 = 5000.0
RATE_HZ = 100.0
STATIC_S = 3.0
DURATION_S = 30.0


def _imu(*, static: bool = True, yaw_rate: float = 0.1, seed: int = 0) -> ImuData:
    """Level vehicle: static for STATIC_S (if asked), then accelerating and turning."""
    rng = np.random.default_rng(seed)
    t = T0 + np.arange(0.0, DURATION_S, 1.0 / RATE_HZ)
    moving = (t - T0 >= STATIC_S) if static else np.ones(t.size, dtype=bool)
    gyro = rng.normal(0.0, 1e-3, (t.size, 3))
    gyro[moving, 2] += yaw_rate
    acc = rng.normal(0.0, 0.02, (t.size, 3))
    acc[:, 2] -= G
    acc[moving, 0] += 1.0
    return ImuData(t_s=t, gyro_body_rad_s=gyro, acc_body_m_s2=acc)


def _gnss(*, static: bool = True, t_s: np.ndarray | None = None) -> GnssData:
    t = T0 + np.arange(0.0, DURATION_S, 1.0) if t_s is None else t_s
    speed = np.clip(t - T0 - (STATIC_S if static else -1.0), 0.0, None)
    vel = np.column_stack([speed, np.zeros_like(t), np.zeros_like(t)])
    return GnssData(
        t_s=t,
        lat_deg=np.full(t.size, LAT),
        lon_deg=np.full(t.size, 6.6),
        h_m=np.full(t.size, H),
        std_pos_ned_m=np.full((t.size, 3), np.nan),
        vel_ned_m_s=vel,
    )


def _with(imu: ImuData, **changes: np.ndarray) -> ImuData:
    return dataclasses.replace(imu, **changes)


def test_clean_inputs_give_no_warning() -> None:
    assert check_inputs(_imu(), _gnss(), CONFIG) == []
    assert check_inputs(_imu(static=False), _gnss(static=False), CONFIG) == []


def test_navego_inputs_pass() -> None:
    imu = read_imu_csv(NAVEGO / "imu.csv")
    gnss = read_gnss_csv(NAVEGO / "gnss.csv")
    cfg = read_ins_config(Path(__file__).resolve().parents[2] / "configs/navego-adis16488.toml")
    assert check_inputs(imu, gnss, cfg) == []


def test_gap_longer_than_the_limit_is_an_error_naming_rows() -> None:
    imu = _imu()
    keep = (imu.t_s < T0 + 10.0) | (imu.t_s > T0 + 10.5)
    cut = ImuData(imu.t_s[keep], imu.gyro_body_rad_s[keep], imu.acc_body_m_s2[keep])
    k = int(np.count_nonzero(imu.t_s < T0 + 10.0))
    with pytest.raises(InputError) as exc:
        check_inputs(cut, _gnss(), CONFIG, imu_source="my_imu.csv")
    msg = str(exc.value)
    for frag in ["my_imu.csv", f"rows {k - 1} and {k}", "max_imu_gap_s = 0.1 s", "1 gap(s)"]:
        assert frag in msg, msg
    # The same gap passes with a larger limit, as a missing-samples warning.
    loose = dataclasses.replace(CONFIG, max_imu_gap_s=1.0)
    (warning,) = check_inputs(cut, _gnss(), loose, imu_source="my_imu.csv")
    assert "missing samples" in warning
    assert f"before rows {k}" in warning


def test_single_missing_sample_is_a_warning() -> None:
    imu = _imu()
    keep = np.ones(len(imu), dtype=bool)
    keep[[700, 1500]] = False
    cut = ImuData(imu.t_s[keep], imu.gyro_body_rad_s[keep], imu.acc_body_m_s2[keep])
    (warning,) = check_inputs(cut, _gnss(), CONFIG)
    assert "2 interval(s) longer than 1.5 x the median" in warning
    assert "before rows 700, 1499" in warning


def test_gnss_on_another_time_scale_is_an_error() -> None:
    gnss = _gnss(t_s=T0 + 604800.0 + np.arange(0.0, DURATION_S, 1.0))
    with pytest.raises(InputError, match=r"0 GNSS epoch.*same time scale"):
        check_inputs(_imu(), gnss, CONFIG)
    one_inside = _gnss(t_s=T0 + DURATION_S + np.arange(-0.5, 5.0, 1.0))
    with pytest.raises(InputError, match="1 GNSS epoch"):
        check_inputs(_imu(), one_inside, CONFIG)
    with pytest.raises(InputError, match="only 1 GNSS epoch"):
        gnss_within_imu_span(one_inside, _imu())


def test_gnss_epochs_outside_the_span_are_a_warning_and_trimmed() -> None:
    t = T0 + np.arange(-2.0, DURATION_S + 3.0, 1.0)  # 2 before, 3 after (last IMU: T0+29.99)
    gnss = _gnss(t_s=t)
    (warning,) = check_inputs(_imu(), gnss, CONFIG, gnss_source="rx.csv")
    assert "rx.csv: 5 GNSS epoch(s) outside the IMU span" in warning
    assert "rows 0, 1, 32, 33, 34" in warning
    inside = gnss_within_imu_span(gnss, _imu())
    np.testing.assert_array_equal(inside.t_s, t[2:32])
    assert inside.vel_ned_m_s is not None
    assert gnss.vel_ned_m_s is not None
    np.testing.assert_array_equal(inside.vel_ned_m_s, gnss.vel_ned_m_s[2:32])
    assert gnss_within_imu_span(_gnss(), _imu()) is not None


def test_gnss_outages_are_warnings() -> None:
    t = T0 + np.concatenate([np.arange(0.0, 5.0), np.arange(17.0, 18.0)])
    warnings = check_inputs(_imu(), _gnss(t_s=t), CONFIG)
    assert len(warnings) == 2, warnings
    assert "GNSS outage of 13.000 s between rows 4 and 5" in warnings[0]
    assert "no GNSS epoch in the last 12.990 s" in warnings[1]
    late = _gnss(t_s=T0 + np.arange(12.0, 30.0))
    (warning,) = check_inputs(_imu(), late, CONFIG)
    assert "no GNSS epoch in the first 12.000 s" in warning


@pytest.mark.parametrize(("scale", "unit"), [(1.0 / 9.80665, "g"), (1.0 / 0.3048, "ft/s^2")])
def test_specific_force_in_other_units_is_an_error(scale: float, unit: str) -> None:
    imu = _imu()
    bad = _with(imu, acc_body_m_s2=imu.acc_body_m_s2 * scale)
    with pytest.raises(InputError, match=f"median specific-force.*looks like {re.escape(unit)}"):
        check_inputs(bad, _gnss(), CONFIG)


def test_rates_in_degrees_are_an_error() -> None:
    imu = _imu(yaw_rate=0.1)
    bad = _with(imu, gyro_body_rad_s=np.degrees(imu.gyro_body_rad_s))
    with pytest.raises(InputError, match=r"median angular-rate magnitude is 5\.\d+ rad/s.*deg/s"):
        check_inputs(bad, _gnss(), CONFIG)


def test_high_median_rate_is_a_warning() -> None:
    (warning,) = check_inputs(_imu(yaw_rate=0.5), _gnss(), CONFIG)
    assert "unusually high" in warning


def test_static_start_gravity_scale() -> None:
    imu = _imu()
    with pytest.raises(InputError) as exc:
        check_inputs(_with(imu, acc_body_m_s2=imu.acc_body_m_s2 * 0.85), _gnss(), CONFIG)
    msg = str(exc.value)
    assert "static start (rows 0-200, first 2 s)" in msg
    assert "by 15 %" in msg
    (warning,) = check_inputs(_with(imu, acc_body_m_s2=imu.acc_body_m_s2 * 1.05), _gnss(), CONFIG)
    assert "differs from normal gravity" in warning
    assert "by 5 %" in warning
    # The window length is a parameter: a 0.05 s window has too few samples to judge.
    assert (
        check_inputs(
            _with(imu, acc_body_m_s2=imu.acc_body_m_s2 * 0.85), _gnss(), CONFIG, static_s=0.05
        )
        == []
    )


def test_moving_start_is_not_judged_static() -> None:
    # 15 % low specific force, but the GNSS says the vehicle moves: no static-start test.
    imu = _imu(static=False)
    scaled = _with(imu, acc_body_m_s2=imu.acc_body_m_s2 * 0.85)
    assert check_inputs(scaled, _gnss(static=False), CONFIG) == []
    # Without GNSS velocities the accelerometer scatter decides: a static IMU is static.
    gnss = dataclasses.replace(_gnss(), vel_ned_m_s=None)
    static = _imu()
    with pytest.raises(InputError, match="static start"):
        check_inputs(_with(static, acc_body_m_s2=static.acc_body_m_s2 * 0.85), gnss, CONFIG)


def test_static_start_with_large_rates_is_an_error() -> None:
    imu = _imu()
    gyro = np.array(imu.gyro_body_rad_s)
    gyro[imu.t_s < T0 + 2.5, 0] += 1.5
    with pytest.raises(InputError, match=r"static start.*mean angular rate 1\.4999"):
        check_inputs(_with(imu, gyro_body_rad_s=gyro), _gnss(), CONFIG)


def test_gate_rejections_warn_then_refuse() -> None:
    """A matched filter rejects ~0.01 %: a few rejections pass, 5 % warns, 30 % refuses."""
    config = dataclasses.replace(CONFIG, gate_probability=0.9999)
    assert check_gnss_rejections(np.array([10.0, 20.0]), 998, config) == []
    assert check_gnss_rejections(np.array([]), 0, config) == []
    five = np.arange(100.0, 150.0, dtype=np.float64)
    (warning,) = check_gnss_rejections(five, 950, config, gnss_source="g.csv")
    assert warning.startswith("g.csv: the chi-square gate rejected 50 of 1000 GNSS epochs (5.0%")
    assert "t_s 100.000, 101.000, 102.000, 103.000, 104.000 and 45 more" in warning
    assert "deg/s" in warning
    with pytest.raises(InputError, match=r"rejected 300 of 1000 .*no solution written"):
        check_gnss_rejections(np.arange(300.0, dtype=np.float64), 700, config)


def _nu(north: float, east: float, down: float, n: int = 50) -> np.ndarray:
    """n rejected epochs' normalised innovations of these magnitudes, signs alternating."""
    signs = np.where(np.arange(n) % 2, -1.0, 1.0)[:, None]
    out: np.ndarray = signs * np.array([north, east, down])
    return out


def test_gate_rejections_on_the_down_axis_name_the_gnss_heights() -> None:
    """Review N3: heights in feet left 19.8 % rejected and a message about gyro units,
    axes, time tags and the lever arm, not the heights (26 m wrong in the solution)."""
    config = dataclasses.replace(CONFIG, gate_probability=0.9999)
    times = np.arange(100.0, 150.0, dtype=np.float64)
    rows = np.arange(500, 550)
    names = FileRows(lambda r: r + 2, first_row=90)  # 90 epochs before the IMU span
    (warning,) = check_gnss_rejections(
        times, 950, config, gnss_source="g.csv", rejected_nu_ned=_nu(0.7, 0.6, 5.3),
        rejected_rows=rows, gnss_rows=names,
    )  # fmt: skip
    assert "t_s 100.000 (row 590, line 592), 101.000 (row 591, line 593)" in warning
    assert "nearly all for their height" in warning
    assert "a median 5.3 σ" in warning
    assert "h_m" in warning
    assert "feet (multiply by 0.3048)" in warning
    assert "orthometric" in warning
    assert "deg/s" not in warning
    # Off horizontally too (a time offset, deg/s rates that diverge): the general causes.
    for nu in (_nu(2.3, 2.9, 0.7), _nu(19.0, 4.0, 8.1)):
        (warning,) = check_gnss_rejections(times, 950, config, rejected_nu_ned=nu)
        assert "deg/s" in warning
        assert "feet" not in warning
    with pytest.raises(InputError, match=r"rejected 300 .*for their height.*no solution"):
        check_gnss_rejections(
            np.arange(300.0), 700, config, rejected_nu_ned=_nu(0.1, 0.1, 18.0, n=300)
        )


def test_warnings_name_the_file_lines_of_the_rows() -> None:
    """Review N3: warnings gave 0-based rows where the errors say 'row 300 (line 302)'."""
    t = T0 + np.concatenate([np.arange(0.0, 5.0), np.arange(17.0, 18.0)])
    lines = FileRows(lambda r: 2 * r + 3)  # a file with a blank line after each row
    warnings = check_inputs(_imu(), _gnss(t_s=t), CONFIG, gnss_rows=lines)
    assert "GNSS outage of 13.000 s between rows 4 (line 11) and 5 (line 13)" in warnings[0]
    assert "(last used epoch at t_s 5017.000, row 5, line 13)" in warnings[1]
    config = dataclasses.replace(CONFIG, gate_probability=0.9999)
    rejected = np.arange(100.0, 150.0, dtype=np.float64)
    names = FileRows(lambda r: r + 2, first_row=90)  # 90 epochs before the IMU span
    (warning,) = check_gnss_rejections(
        rejected, 950, config, rejected_rows=np.arange(500, 550), gnss_rows=names
    )
    assert "t_s 100.000 (row 590, line 592), 101.000 (row 591, line 593)" in warning
    init = dataclasses.replace(INIT, lat_deg=LAT + 0.02)
    with pytest.raises(InputError, match=r"\(rx\.csv row 3, line 9, t_s 5000\.000"):
        check_initial_state(init, _gnss(), CONFIG, gnss_source="rx.csv", gnss_rows=FileRows(
            lambda r: 2 * r + 3, first_row=3
        ))  # fmt: skip


@pytest.mark.parametrize("gate", [0.9, 0.99, 0.999, 0.9999])
def test_gate_refuses_a_filter_that_rejects_nearly_everything_at_any_gate(gate: float) -> None:
    """The refusal holds whatever the gate (it was skipped for a gate of 0.99 or less)."""
    config = dataclasses.replace(CONFIG, gate_probability=gate)
    with pytest.raises(InputError, match=r"rejected 2181 of 2182 .*no solution written"):
        check_gnss_rejections(np.arange(2181.0), 1, config)


def test_gate_warning_scales_with_the_gate_rate_and_chance() -> None:
    config = dataclasses.replace(CONFIG, gate_probability=0.99)
    # 2 % at a 1 % gate: within three times the gate's own rate.
    assert check_gnss_rejections(np.arange(20.0), 980, config) == []
    # 5 % at a 1 % gate: beyond three times its rate and beyond chance: a warning.
    (warning,) = check_gnss_rejections(np.arange(50.0), 950, config)
    assert "rejected 50 of 1000" in warning
    assert "[init] biases" in warning
    # 4 of 100 at a 0.01 % gate: a 4 % share, but 4 rejections are not chance.
    strict = dataclasses.replace(CONFIG, gate_probability=0.9999)
    assert len(check_gnss_rejections(np.arange(4.0), 96, strict)) == 1


def test_gnss_times_in_milliseconds_are_an_error() -> None:
    # 40 Hz GNSS with its times in ms: two epochs fall in the IMU span, 25 "s" apart.
    gnss = _gnss(t_s=T0 + np.arange(0.0, DURATION_S, 0.025) * 1000.0)
    with pytest.raises(InputError, match=r"2 GNSS epochs .* a median 25 s apart.*in ms or us"):
        check_inputs(_imu(), gnss, CONFIG)
    # 1 Hz GNSS in ms: one epoch in the span; the message says the spacing too.
    gnss = _gnss(t_s=T0 + np.arange(0.0, DURATION_S, 1.0) * 1000.0)
    with pytest.raises(InputError, match=r"1 GNSS epoch\(s\) .*a median 1000 s apart"):
        check_inputs(_imu(), gnss, CONFIG)


def test_imu_times_in_milliseconds_are_named() -> None:
    imu = _imu()
    slow = _with(imu, t_s=T0 + (imu.t_s - T0) * 1000.0)
    with pytest.raises(InputError, match=r"a median 10 s apart .*ms or us\? Give t_s in seconds"):
        check_inputs(slow, _gnss(), CONFIG)


def test_a_gap_setting_below_the_sampling_interval_names_the_setting() -> None:
    """Review L5: max_imu_gap_s = 1e-9 was reported as 'the IMU samples are a median 0.02 s
    apart ... are the times in ms or us?', blaming a good IMU file."""
    tiny = dataclasses.replace(CONFIG, max_imu_gap_s=1e-9)
    with pytest.raises(InputError) as info:
        check_inputs(_imu(), _gnss(), tiny, imu_source="imu.csv", config_source="cfg.toml")
    msg = str(info.value)
    assert msg.startswith("cfg.toml: [filter] max_imu_gap_s = 1e-09 s is below")
    assert "median sampling interval 0.01 s (imu.csv)" in msg
    assert "ms or us" not in msg


def test_axes_with_z_up_are_an_error() -> None:
    imu = _imu()
    flu = imu.acc_body_m_s2 * np.array([1.0, -1.0, -1.0])
    with pytest.raises(InputError, match=r"Z axis is \+9\.8.*Z points up.*negate the Y and Z"):
        check_inputs(_with(imu, acc_body_m_s2=flu), _gnss(), CONFIG)


def test_gravity_on_a_horizontal_axis_is_an_error() -> None:
    imu = _imu()
    swapped = imu.acc_body_m_s2[:, [2, 1, 0]]
    with pytest.raises(InputError, match=r"gravity lies along X.*reorder the columns"):
        check_inputs(_with(imu, acc_body_m_s2=swapped), _gnss(), CONFIG)


def test_antenna_below_the_imu_is_a_warning() -> None:
    below = dataclasses.replace(CONFIG, antenna_lever_arm_body_m=(0.3, -0.2, 1.5))
    (warning,) = check_inputs(_imu(), _gnss(), below)
    assert "1.5 m below the IMU" in warning
    above = dataclasses.replace(CONFIG, antenna_lever_arm_body_m=(0.3, -0.2, -1.5))
    assert check_inputs(_imu(), _gnss(), above) == []


# ---------------------------------------------------------------------- initial state
INIT = InitialState(
    t_s=T0, lat_deg=LAT, lon_deg=6.6, h_m=H, vel_ned_m_s=(0.0, 0.0, 0.0), rpy_rad=(0.0, 0.0, 0.0)
)


def test_an_initial_state_at_the_gnss_passes() -> None:
    check_initial_state(INIT, _gnss(), CONFIG)
    # 0.9 km off, or yaw in 0..2pi, or the GNSS a minute later and 10 km away: possible
    near = dataclasses.replace(INIT, lat_deg=LAT + 0.9 / 111.2, rpy_rad=(-3.14, 1.57, 6.2))
    check_initial_state(near, _gnss(), CONFIG)
    far = dataclasses.replace(INIT, lat_deg=LAT + 10.0 / 111.2)
    check_initial_state(far, _gnss(t_s=T0 + 60.0 + np.arange(0.0, 10.0)), CONFIG)


@pytest.mark.parametrize(
    ("rpy", "words"),
    [
        ((0.0, 0.0, 35.0), "rpy_rad[2] (yaw) = 35 rad is beyond -π to 2π: is it in degrees?"),
        ((0.0, 2.0, 0.0), "rpy_rad[1] (pitch) = 2 rad is beyond ±π/2"),
        ((-4.0, 0.0, 0.0), "rpy_rad[0] (roll) = -4 rad is beyond ±π"),
    ],
)
def test_initial_angles_in_degrees_are_refused(rpy: tuple[float, float, float], words: str) -> None:
    with pytest.raises(InputError) as info:
        check_initial_state(dataclasses.replace(INIT, rpy_rad=rpy), _gnss(), CONFIG)
    assert words in str(info.value)


@pytest.mark.parametrize(
    ("lat", "lon", "words"),
    [
        (math.radians(LAT), math.radians(6.6), "look like radians: give degrees (46.8, 6.6)"),
        (6.6, LAT, "look swapped"),
        (LAT, -6.6, "south and west negative"),
        (LAT + 0.02, 6.6, "is it the state of this data set?"),
    ],
)
def test_an_initial_position_far_from_the_gnss_is_refused(
    lat: float, lon: float, words: str
) -> None:
    init = dataclasses.replace(INIT, lat_deg=lat, lon_deg=lon)
    with pytest.raises(InputError) as info:
        check_initial_state(init, _gnss(), CONFIG, gnss_source="rx.csv")
    message = str(info.value)
    assert message.startswith(f"initial state: lat_deg {lat:.8g}, lon_deg {lon:.8g} at t_s")
    assert "from the GNSS fix nearest in time (rx.csv row 0, t_s 5000.000" in message
    assert words in message


def test_a_unix_time_imu_against_gps_time_gnss_is_named() -> None:
    """It read 'GPS seconds of week vs continuous GPS time, UTC vs GPS' (never Unix)."""
    t_gps = 1.4e9 + np.arange(0.0, DURATION_S, 1.0)
    imu = _imu()
    imu = _with(imu, t_s=imu.t_s - T0 + 1.4e9 + 315_964_782.0)
    with pytest.raises(InputError) as err:
        check_inputs(imu, _gnss(t_s=t_gps), CONFIG, imu_source="imu.csv")
    msg = str(err.value)
    assert "the times of imu.csv look like Unix time (UTC seconds since 1970-01-01)" in msg
    assert "like GPS time" in msg
    assert "subtract 315964800 s and add the leap seconds (18 s since 2017" in msg


def test_gnss_times_a_leap_second_count_early_are_named() -> None:
    """GNSS in UTC, IMU in GPS time: the GNSS log 18 s early (the chi-square gate failed
    next, naming no offset; only GNSS 18 s late was named)."""
    gnss = _gnss(t_s=T0 - 18.0 + np.arange(0.0, DURATION_S, 1.0))
    warnings = check_inputs(_imu(), gnss, CONFIG, gnss_source="gnss.csv")
    named = [w for w in warnings if "18 s is what GPS time runs ahead of UTC" in w]
    assert len(named) == 1
    assert named[0].startswith("gnss.csv: the GNSS epochs start and end 18.000 s and 18.990 s")
    assert not any("ahead of UTC" in w for w in check_inputs(_imu(), _gnss(), CONFIG))
