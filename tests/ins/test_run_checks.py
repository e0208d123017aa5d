"""`run_ins` refuses what ``kinsync ins run`` refuses (`kinsync.ins.checks`), with the same
messages, and returns the checks' warnings in `InsResult.warnings`."""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Callable

import numpy as np
import pytest

from kinsync.errors import InputError
from kinsync.ins.config import InsConfig
from kinsync.ins.filter import run_ins
from kinsync.ins.measurements import GnssData, ImuData
from kinsync.ins.solution import InitialState, NavSolution

Drive = tuple[ImuData, ImuData, GnssData, NavSolution, InitialState]
SimDrive = Callable[..., Drive]

GYRO_ARW = math.radians(0.1) / 60.0
ACC_VRW = 0.05 / 60.0
CONFIG = InsConfig(
    gyro_arw_rad_s_rthz=GYRO_ARW,
    acc_vrw_m_s2_rthz=ACC_VRW,
    gyro_bias_sigma_rad_s=math.radians(0.1),
    acc_bias_sigma_m_s2=0.2,
    gyro_bias_instability_rad_s=1e-6,
    acc_bias_instability_m_s2=1e-5,
    gnss_std_pos_ned_m=(0.5, 0.5, 1.0),
    gnss_std_vel_ned_m_s=(0.05, 0.05, 0.05),
    init_std_att_rad=(0.002, 0.002, 0.005),
    init_std_vel_ned_m_s=(0.05, 0.05, 0.05),
    init_std_pos_ned_m=(0.5, 0.5, 1.0),
)


@pytest.fixture(scope="module")
def calm(sim_drive: SimDrive) -> Drive:
    """50 s standing, then 40 s driving: the median rate is the Earth's (7e-4 rad/s with
    noise), so rates in deg/s pass the median test and only the χ² gate can tell."""
    return sim_drive(
        duration_s=90.0, static_s=50.0, seed=4, gyro_arw=GYRO_ARW, acc_vrw=ACC_VRW
    )  # fmt: skip


def test_valid_inputs_give_no_warning(calm: Drive) -> None:
    _, imu, gnss, _, init = calm
    res = run_ins(imu, gnss, CONFIG, init)
    assert res.warnings == ()
    assert res.forward.n_gnss_rejected == 0


def test_gyro_in_deg_s_is_refused_by_the_chi_square_check(calm: Drive) -> None:
    _, imu, gnss, _, init = calm
    in_deg = ImuData(imu.t_s, np.degrees(imu.gyro_body_rad_s), imu.acc_body_m_s2)
    with pytest.raises(InputError) as info:
        run_ins(in_deg, gnss, CONFIG, init, gnss_source="rx.csv")
    message = str(info.value)
    assert message.startswith("rx.csv: the chi-square gate rejected ")
    assert "of 451 GNSS epochs" in message
    assert "Check the gyro units (rad/s, not deg/s)" in message
    # Review L5: one bad gyro value also does it, and blamed the GNSS file
    assert "a spike in an IMU record (one bad gyro or accelerometer value)" in message


def test_specific_force_in_g_and_z_up_are_refused(calm: Drive) -> None:
    _, imu, gnss, _, init = calm
    in_g = ImuData(imu.t_s, imu.gyro_body_rad_s, imu.acc_body_m_s2 / 9.80665)
    with pytest.raises(InputError, match=r"^imu\.csv: the median specific-force .*looks like g"):
        run_ins(in_g, gnss, CONFIG, init, imu_source="imu.csv")
    flu = np.array([1.0, -1.0, -1.0])
    z_up = ImuData(imu.t_s, imu.gyro_body_rad_s * flu, imu.acc_body_m_s2 * flu)
    with pytest.raises(InputError, match="Z points up"):
        run_ins(z_up, gnss, CONFIG, init)


def test_initial_attitude_in_degrees_is_refused(calm: Drive) -> None:
    _, imu, gnss, _, init = calm
    roll, pitch, yaw = (math.degrees(a) for a in init.rpy_rad)
    in_deg = dataclasses.replace(init, rpy_rad=(roll, pitch, yaw))
    with pytest.raises(InputError, match=r"rpy_rad\[2\] \(yaw\) = 30 rad .*degrees"):
        run_ins(imu, gnss, CONFIG, in_deg)


def test_initial_position_in_radians_is_refused(calm: Drive) -> None:
    _, imu, gnss, _, init = calm
    in_rad = dataclasses.replace(
        init, lat_deg=math.radians(init.lat_deg), lon_deg=math.radians(init.lon_deg)
    )
    with pytest.raises(InputError, match="lat_deg and lon_deg look like radians: give degrees"):
        run_ins(imu, gnss, CONFIG, in_rad)


def test_warnings_are_returned_and_carried_by_a_later_error(calm: Drive) -> None:
    _, imu, gnss, _, init = calm
    below = dataclasses.replace(CONFIG, antenna_lever_arm_body_m=(0.0, 0.0, 0.05))
    (warning,) = run_ins(imu, gnss, below, init).warnings
    assert warning.startswith("antenna_lever_arm_body_m z = +0.05 m")
    in_deg = ImuData(imu.t_s, np.degrees(imu.gyro_body_rad_s), imu.acc_body_m_s2)
    with pytest.raises(InputError) as info:
        run_ins(in_deg, gnss, below, init)
    message = str(info.value)
    assert "chi-square gate rejected" in message
    assert message.endswith(f"The input checks had warned: {' '.join(warning.split())}")


def test_warnings_of_input_checks_run_by_the_caller_are_kept(calm: Drive) -> None:
    _, imu, gnss, _, init = calm
    res = run_ins(imu, gnss, CONFIG, init, input_warnings=["checked earlier"])
    assert res.warnings == ("checked earlier",)


def test_gnss_heights_that_jump_are_named_as_the_cause(calm: Drive) -> None:
    """Review N3: the gate's message blamed gyro units, axes and time tags when the GNSS
    heights were at fault (heights in feet gave 19.8 % rejected, all on the down axis).
    The filter keeps the rejected epochs' innovations for that diagnosis."""
    _, imu, gnss, _, init = calm
    k = int(np.searchsorted(gnss.t_s, gnss.t_s[0] + 60.0))
    h_m = gnss.h_m.copy()
    h_m[k:] += 8.0  # σ 1 m: orthometric heights from here on, say
    jumped = dataclasses.replace(gnss, h_m=h_m)
    with pytest.raises(InputError) as info:
        run_ins(imu, jumped, CONFIG, init, gnss_source="rx.csv")
    message = str(info.value)
    assert re.search(rf"at t_s {gnss.t_s[k]:.3f}[, ]", message), message[:300]
    assert "nearly all for their height" in message
    assert "GNSS height column h_m" in message
    res = run_ins(imu, gnss, CONFIG, init)
    assert res.rejected_innovations_pos_ned_m.shape == (0, 3)
