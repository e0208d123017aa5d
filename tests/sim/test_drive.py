"""Drive simulator: route geometry, inverse mechanisation, IMU errors, GNSS, files."""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from kinsync.errors import InputError
from kinsync.frames import (
    ecef_to_ned,
    euler_rpy_to_matrix,
    geodetic_to_ecef,
    quaternion_to_matrix,
    rotation_ned_to_ecef,
)
from kinsync.ins.earth import OMEGA_IE_RAD_S, normal_gravity_m_s2, radii_m
from kinsync.ins.strapdown import free_inertial
from kinsync.io.ins_config import read_ins_config
from kinsync.io.tables import read_numeric_csv
from kinsync.sim.drive import (
    DriveSimConfig,
    Route,
    Segment,
    Stop,
    Straight,
    Turn,
    figure_eight_route,
    initial_state,
    oval_route,
    simulate_drive,
    survey_lines_route,
    turn_chord_m,
    write_drive_simulation,
)
from kinsync.sim.drive_truth import DriveTrajectory, simulate_truth
from kinsync.sim.gnss import simulate_gnss
from kinsync.sim.imu import ImuErrorModel, ideal_imu_mean, simulate_imu
from kinsync.sim.nav_noise import noisy_trajectory
from kinsync.trajectory import Trajectory

DEG_H = math.pi / 180.0 / 3600.0
MG = 9.80665e-3


def local_ned(traj: Trajectory, origin: tuple[float, float, float] | None = None) -> np.ndarray:
    """Positions of a geodetic trajectory in the NED frame at its first record (m)."""
    assert traj.lat_lon_h is not None
    llh = traj.lat_lon_h
    o = origin or (float(llh[0, 0]), float(llh[0, 1]), float(llh[0, 2]))
    out: np.ndarray = ecef_to_ned(geodetic_to_ecef(llh[:, 0], llh[:, 1], llh[:, 2]), *o)
    return out


def rotation_angle_rad(R_a: np.ndarray, R_b: np.ndarray) -> np.ndarray:
    """Angle of R_a^T R_b per row (rad), accurate near zero."""
    d = np.einsum("nji,njk->nik", R_a, R_b)
    out: np.ndarray = np.linalg.norm(Rotation.from_matrix(d).as_rotvec(), axis=1)
    return out


# ---------------------------------------------------------------------- geometry
def test_oval_closes_and_speeds_and_rates_as_specified() -> None:
    speed, radius, straight = 2.0, 10.0, 40.0
    route = oval_route(speed_m_s=speed, straight_m=straight, radius_m=radius, laps=2, static_s=5)
    assert route.length_m == pytest.approx(2 * (2 * straight + 2 * math.pi * radius * 1.25))
    # Away from the poles the heading is measured from the local meridian, which turns
    # by dlon sin(lat) as the vehicle moves east: a flat-Earth oval driven on the
    # ellipsoid misses its start by about path * width * tan(lat) / R (< 1 mm here); on
    # the equator it closes to rounding.
    width = turn_chord_m(180.0, radius, route.transition_fraction)[1]
    for lat, bound in ((0.0, 1e-6), (46.8, route.length_m * width * math.tan(0.82) / 6.37e6)):
        truth = simulate_truth(route, rate_hz=50.0, origin_lat_lon_h=(lat, -71.2, 10.0))
        ned = local_ned(truth)
        assert np.linalg.norm(ned[-1]) < bound
    yaw = np.unwrap(truth.euler_rpy_rad()[:, 2])
    assert yaw[-1] - yaw[0] == pytest.approx(4 * math.pi, abs=1e-9)
    assert truth.duration_s == pytest.approx(route.duration_s, abs=0.02)
    state = truth.state(truth.t_s)
    assert truth.vel_ned_m_s is not None
    horizontal = np.hypot(truth.vel_ned_m_s[:, 0], truth.vel_ned_m_s[:, 1])
    np.testing.assert_allclose(horizontal, state.speed_m_s, atol=1e-12)
    assert horizontal.max() == pytest.approx(speed, abs=1e-12)
    assert np.all(horizontal[truth.t_s < 5.0] == 0.0)  # static start
    yaw_rate = state.rpy_rate_rad_s[:, 2]
    assert np.abs(yaw_rate).max() == pytest.approx(speed / radius, rel=1e-9)
    # The curvature plateau holds 1/R over R pi (1 - f) per turn: time at V/R.
    at_plateau = np.abs(yaw_rate - speed / radius) < 1e-9
    plateau_s = 4 * radius * math.pi * (1 - route.transition_fraction) / speed
    assert np.count_nonzero(at_plateau) / 50.0 == pytest.approx(plateau_s, abs=4 / 50.0)
    # The speed ramps: peak acceleration as configured.
    assert np.abs(state.acc_m_s2).max() == pytest.approx(route.max_acc_m_s2, rel=1e-3)


def test_velocity_is_the_derivative_of_the_positions() -> None:
    route = figure_eight_route(laps=1, static_s=2.0)
    rate = 100.0
    truth = simulate_truth(
        route,
        rate_hz=rate,
        roll_amplitude_deg=3.0,
        pitch_amplitude_deg=1.0,
        undulation_amplitude_m=1.0,
        undulation_wavelength_m=30.0,
    )
    assert truth.lat_lon_h is not None
    assert truth.vel_ned_m_s is not None
    llh = truth.lat_lon_h
    ecef = geodetic_to_ecef(llh[:, 0], llh[:, 1], llh[:, 2])
    R_ne = rotation_ned_to_ecef(llh[1:-1, 0], llh[1:-1, 1])
    v_fd = np.einsum("nji,nj->ni", R_ne, (ecef[2:] - ecef[:-2]) * (rate / 2.0))
    # Central differences err by dt^2/6 |v'''| (|v'''| < 1 m/s^4 for these motions).
    err = v_fd - truth.vel_ned_m_s[1:-1]
    assert np.abs(err).max() < (1.0 / rate) ** 2 / 6.0 * 1.0
    # Height follows the undulation exactly, attitude follows the path heading.
    state = truth.state(truth.t_s)
    np.testing.assert_allclose(llh[:, 2], 10.0 + state.height_m, atol=1e-9)


def test_acceleration_and_angular_rate_are_continuous() -> None:
    route = oval_route(radius_m=5.0, straight_m=10.0, speed_m_s=3.0, static_s=1.0)
    truth = simulate_truth(route, rate_hz=200.0)
    state = truth.state(truth.t_s)
    acc_step = np.abs(np.diff(state.acc_ned_m_s2, axis=0)).max()
    rate_step = np.abs(np.diff(state.rpy_rate_rad_s, axis=0)).max()
    # A curvature or acceleration jump would step by V^2/R = 1.8 m/s^2 and V/R = 0.6
    # rad/s; the smooth ramps bound the step by jerk * dt with jerk < 5 m/s^3 here.
    assert np.abs(state.acc_ned_m_s2).max() > 1.5
    assert acc_step < 5.0 / 200.0
    assert rate_step < 5.0 / 200.0


@settings(max_examples=15, deadline=None)
@given(
    st.lists(
        st.one_of(
            st.builds(Straight, st.floats(1.0, 30.0)),
            st.builds(
                Turn,
                st.sampled_from([-270.0, -90.0, -30.0, 45.0, 120.0, 360.0]),
                st.floats(3.0, 20.0),
            ),
            st.builds(Stop, st.floats(0.5, 3.0)),
        ),
        min_size=1,
        max_size=6,
    ).filter(lambda segs: any(not isinstance(s, Stop) for s in segs)),
    st.floats(0.5, 5.0),
)
def test_any_route_turns_by_its_angles_within_its_speed(segs: list[Segment], speed: float) -> None:
    route = Route(tuple(segs), speed_m_s=speed, static_s=1.0, end_static_s=1.0)
    truth = simulate_truth(route, rate_hz=20.0)
    state = truth.state(truth.t_s)
    total = sum(math.radians(s.angle_deg) for s in segs if isinstance(s, Turn))
    assert state.rpy_rad[-1, 2] == pytest.approx(total, abs=1e-9)
    assert state.s_m[-1] == pytest.approx(route.length_m, rel=1e-12)
    assert state.speed_m_s.max() <= speed + 1e-12
    assert state.speed_m_s[0] == state.speed_m_s[-1] == 0.0
    n_stops = sum(isinstance(s, Stop) for s in segs)
    assert truth.duration_s >= 2.0 + sum(s.duration_s for s in segs if isinstance(s, Stop)) - 0.05
    if n_stops == 0:
        # One block: distance = V T_a + V T_c, time = 2 T_a + T_c.
        v = min(speed, math.sqrt(route.length_m * route.max_acc_m_s2 / 1.875))
        t_a = 1.875 * v / route.max_acc_m_s2
        assert route.duration_s == pytest.approx(2.0 + 2 * t_a + (route.length_m - v * t_a) / v)


def test_figure_eight_and_survey_lines_geometry() -> None:
    laps = 2
    route = figure_eight_route(laps=laps, static_s=0.0, radius_m=6.0, crossing_angle_deg=60.0)
    truth = simulate_truth(route, rate_hz=50.0, origin_lat_lon_h=(0.0, 10.0, 0.0))
    ned = local_ned(truth)
    dist = np.hypot(ned[:, 0], ned[:, 1])
    # The crossing point is passed twice per lap (start and end included: 2 laps + 1):
    # runs of records within 0.5 m, each passing through it (on a straight leg the
    # chord between records is the path).
    near = dist < 0.5
    starts = np.flatnonzero(np.diff(near.astype(int)) == 1) + 1
    ends = np.flatnonzero(np.diff(near.astype(int)) == -1) + 1
    runs = list(zip(np.concatenate([[0], starts]), [*ends, len(ned)], strict=True))
    assert len(runs) == 2 * laps + 1
    for lo, hi in runs:
        a, b = ned[lo : hi - 1, :2], ned[lo + 1 : hi, :2]
        ab = b - a
        u = np.clip(-np.sum(a * ab, axis=1) / np.maximum(np.sum(ab * ab, axis=1), 1e-30), 0, 1)
        assert np.hypot(*(a + u[:, None] * ab).T).min() < 1e-6
    assert dist[-1] < 1e-6
    lines = survey_lines_route(line_length_m=50.0, line_spacing_m=12.0, n_lines=3, static_s=0.0)
    truth = simulate_truth(lines, rate_hz=50.0, origin_lat_lon_h=(0.0, 10.0, 0.0))
    ned = local_ned(truth)
    state = truth.state(truth.t_s)
    on_line = np.abs(state.rpy_rate_rad_s[:, 2]) < 1e-12
    heading = np.cos(state.rpy_rad[:, 2])
    for k, sign in enumerate((1.0, -1.0, 1.0)):
        sel = on_line & (np.abs(heading - sign) < 1e-12) & (np.abs(ned[:, 1] - 12.0 * k) < 1.0)
        assert np.count_nonzero(sel) > 10
        np.testing.assert_allclose(ned[sel, 1], 12.0 * k, atol=1e-6)


# ---------------------------------------------------------------------- inverse mechanisation
def test_static_imu_measures_gravity_and_earth_rate() -> None:
    route = Route((Straight(10.0),), static_s=10.0)
    yaw = 30.0
    truth = simulate_truth(route, rate_hz=100.0, initial_yaw_deg=yaw, duration_s=5.0)
    imu, _ = simulate_imu(truth, ImuErrorModel.error_free(rate_hz=100.0))
    lat = math.radians(46.8)
    g = float(normal_gravity_m_s2(lat, 10.0))
    np.testing.assert_allclose(
        imu.acc_body_m_s2, np.tile([0.0, 0.0, -g], (len(imu), 1)), atol=1e-12
    )
    w_ned = OMEGA_IE_RAD_S * np.array([math.cos(lat), 0.0, -math.sin(lat)])
    R_nb = euler_rpy_to_matrix(0.0, 0.0, math.radians(yaw)).T
    np.testing.assert_allclose(
        imu.gyro_body_rad_s, np.tile(R_nb @ w_ned, (len(imu), 1)), atol=1e-18
    )


def test_constant_speed_east_and_steady_turn() -> None:
    speed = 10.0
    route = Route((Straight(2000.0),), speed_m_s=speed, max_acc_m_s2=2.0)
    truth = simulate_truth(route, rate_hz=100.0, initial_yaw_deg=90.0, duration_s=60.0)
    imu, _ = simulate_imu(truth, ImuErrorModel.error_free(rate_hz=100.0))
    cruise = (imu.t_s > 20.0) & (imu.t_s < 60.0)
    sample = truth.interpolate(imu.t_s[cruise])
    assert sample.lat_lon_h is not None
    lat = np.radians(sample.lat_lon_h[:, 0])
    h = sample.lat_lon_h[:, 2]
    _r_m, r_n = radii_m(lat)
    W, V = OMEGA_IE_RAD_S, speed
    # Heading east, level: body x = East, y = South, z = Down (Groves eq. 5.54 terms).
    f_expected = np.column_stack(
        [
            np.zeros_like(lat),
            -V * (2 * W * np.sin(lat) + V * np.tan(lat) / (r_n + h)),
            V * (2 * W * np.cos(lat) + V / (r_n + h)) - normal_gravity_m_s2(lat, h),
        ]
    )
    w_expected = np.column_stack(
        [
            np.zeros_like(lat),
            -(W * np.cos(lat) + V / (r_n + h)),
            -W * np.sin(lat) - V * np.tan(lat) / (r_n + h),
        ]
    )
    np.testing.assert_allclose(imu.acc_body_m_s2[cruise], f_expected, atol=1e-9)
    np.testing.assert_allclose(imu.gyro_body_rad_s[cruise], w_expected, atol=1e-13)

    # Steady right turn on the curvature plateau: centripetal V^2/R to the right, yaw
    # rate V/R, plus Earth-rate and Coriolis terms of at most 2 Omega V + V^2/R_earth.
    radius, speed = 20.0, 4.0
    route = Route((Straight(5.0), Turn(720.0, radius)), speed_m_s=speed)
    truth = simulate_truth(route, rate_hz=100.0, duration_s=40.0)
    imu, _ = simulate_imu(truth, ImuErrorModel.error_free(rate_hz=100.0))
    state = truth.state(imu.t_s)
    steady = (np.abs(state.rpy_rate_rad_s[:, 2] - speed / radius) < 1e-12) & (state.acc_m_s2 == 0.0)
    assert np.count_nonzero(steady) > 500
    small = 2 * OMEGA_IE_RAD_S * speed + speed**2 / 6.3e6
    f = imu.acc_body_m_s2[steady]
    assert np.abs(f[:, 0]).max() < small
    assert np.abs(f[:, 1] - speed**2 / radius).max() < small
    assert np.abs(imu.gyro_body_rad_s[steady, 2] - speed / radius).max() < OMEGA_IE_RAD_S


def test_samples_are_means_over_the_preceding_interval() -> None:
    # On the equator, level, the Earth and transport rates have no Down component, so
    # gyro z is exactly the yaw rate; heading north the specific force x is exactly
    # dv_N/dt. Sums of mean samples over (t[k-1], t[k]] then equal the increments.
    route = Route((Straight(15.0), Turn(90.0, 8.0), Straight(5.0)), speed_m_s=2.0, static_s=1.0)
    truth = simulate_truth(route, rate_hz=200.0, origin_lat_lon_h=(0.0, 0.0, 0.0))
    imu, _ = simulate_imu(truth, ImuErrorModel.error_free(rate_hz=200.0))
    dt = 1.0 / 200.0
    yaw = np.unwrap(truth.euler_rpy_rad()[:, 2])
    np.testing.assert_allclose(
        np.cumsum(imu.gyro_body_rad_s[1:, 2]) * dt, yaw[1:] - yaw[0], atol=1e-9
    )
    assert truth.vel_ned_m_s is not None
    first_leg = truth.state(truth.t_s).s_m < 15.0
    vn = truth.vel_ned_m_s[:, 0]
    cum = np.cumsum(imu.acc_body_m_s2[1:, 0]) * dt
    np.testing.assert_allclose(cum[first_leg[1:]], (vn[1:] - vn[0])[first_leg[1:]], atol=1e-9)
    # A sample at 100 Hz is the mean of the two 200 Hz samples of its interval (to the
    # quadrature error, largest where an interval holds a junction of the ramps).
    imu100, _ = simulate_imu(truth, ImuErrorModel.error_free(rate_hz=100.0))
    pair = 0.5 * (imu.gyro_body_rad_s[2::2] + imu.gyro_body_rad_s[1:-1:2])
    np.testing.assert_allclose(imu100.gyro_body_rad_s[1:], pair, rtol=0, atol=1e-9)
    pair = 0.5 * (imu.acc_body_m_s2[2::2] + imu.acc_body_m_s2[1:-1:2])
    np.testing.assert_allclose(imu100.acc_body_m_s2[1:], pair, rtol=0, atol=1e-8)
    # Off by half an interval, the pairing fails by about jerk * dt / 2.
    shifted = 0.5 * (imu.acc_body_m_s2[1:-1:2] + imu.acc_body_m_s2[:-2:2])
    assert np.abs(imu100.acc_body_m_s2[1:] - shifted).max() > 1e-4


def test_error_free_imu_mechanised_reproduces_the_truth() -> None:
    route = oval_route(straight_m=20.0, radius_m=8.0, static_s=2.0)
    kwargs = {
        "duration_s": 60.0,
        "initial_yaw_deg": 35.0,
        "roll_amplitude_deg": 2.0,
        "pitch_amplitude_deg": 1.0,
        "undulation_amplitude_m": 0.5,
    }
    pos_err = {}
    for rate in (100.0, 200.0):
        truth = simulate_truth(route, rate_hz=rate, **kwargs)  # type: ignore[arg-type]
        imu, _ = simulate_imu(truth, ImuErrorModel.error_free(rate_hz=rate))
        sol = free_inertial(imu, initial_state(truth))
        assert truth.lat_lon_h is not None
        llh = truth.lat_lon_h
        d_ecef = geodetic_to_ecef(sol.lat_deg, sol.lon_deg, sol.h_m) - geodetic_to_ecef(
            llh[:, 0], llh[:, 1], llh[:, 2]
        )
        d_ned = np.einsum("nji,nj->ni", rotation_ned_to_ecef(llh[:, 0], llh[:, 1]), d_ecef)
        pos_err[rate] = float(np.abs(d_ned).max())
        att = rotation_angle_rad(
            quaternion_to_matrix(truth.q_body_to_ned), euler_rpy_to_matrix(*sol.rpy_rad.T)
        )
        assert att.max() < 1e-5
    # The mechanisation is second order: velocity error ~ T dt^2 |a''| / 12, position
    # ~ T^2 dt^2 |a''| / 24 with |a''| < 0.5 m/s^4 (roll/pitch oscillation swinging
    # gravity): < 1.9 mm at 200 Hz over 60 s. Exact IMU data show this dt^2 law (an
    # inconsistent IMU stream would leave an error floor).
    assert pos_err[200.0] < 60.0**2 * (1 / 200.0) ** 2 * 0.5 / 24
    assert pos_err[100.0] / pos_err[200.0] > 3.0


def test_simulate_imu_needs_the_exact_kinematics() -> None:
    truth = simulate_truth(oval_route(static_s=1.0), rate_hz=10.0, duration_s=5.0)
    plain = truth.sliced(truth.t_start_s, truth.t_end_s)
    assert not isinstance(plain, DriveTrajectory)
    with pytest.raises(InputError, match="exact kinematics"):
        simulate_imu(plain, ImuErrorModel.error_free())
    with pytest.raises(InputError, match="rate_hz"):
        simulate_imu(truth, ImuErrorModel.error_free(), rate_hz=0.0)


# ---------------------------------------------------------------------- error model
def test_presets_carry_the_issue_values() -> None:
    nav = ImuErrorModel.navigation_grade()
    assert nav.rate_hz == 50.0
    assert nav.gyro_bias_sigma_rad_s == pytest.approx(0.01 * DEG_H)
    assert nav.gyro_scale_sigma_ppm == 20.0
    assert nav.acc_bias_sigma_m_s2 == pytest.approx(0.06 * MG)
    assert nav.acc_scale_sigma_ppm == 5.0
    mems = ImuErrorModel.mems()
    spec = json.loads(
        (
            Path(__file__).resolve().parents[3]
            / "shared"
            / "data"
            / "navego-synthetic"
            / "imu_gnss_spec.json"
        ).read_text()
    )
    assert mems.rate_hz == spec["imu_freq_hz"]
    assert mems.gyro_arw_rad_s_rthz == pytest.approx(spec["arw"][0])
    assert mems.acc_vrw_m_s2_rthz == pytest.approx(spec["vrw"][0])
    assert mems.gyro_bias_sigma_rad_s == pytest.approx(spec["gb_sta"][0])
    assert mems.acc_bias_sigma_m_s2 == pytest.approx(spec["ab_sta"][0])
    assert mems.gyro_bias_instability_rad_s == pytest.approx(spec["gb_dyn"][0])
    assert mems.acc_bias_instability_m_s2 == pytest.approx(spec["ab_dyn"][0])
    assert mems.gyro_bias_corr_time_s == spec["gb_corr"][0]
    assert mems.gyro_arw_rad_s_rthz * math.sqrt(mems.rate_hz) == pytest.approx(spec["g_std"][0])
    cfg = nav.to_ins_config(antenna_lever_arm_body_m=(1.0, 0.0, -1.0))
    assert cfg.gyro_bias_sigma_rad_s == nav.gyro_bias_sigma_rad_s
    assert cfg.acc_vrw_m_s2_rthz == nav.acc_vrw_m_s2_rthz
    assert cfg.antenna_lever_arm_body_m == (1.0, 0.0, -1.0)
    assert ImuErrorModel.error_free().to_ins_config().gyro_arw_rad_s_rthz > 0.0
    with pytest.raises(InputError, match="to_ins_config"):
        nav.to_ins_config(no_such_field=1.0)


def test_injected_errors_appear_in_a_static_stream() -> None:
    rate, n_s = 100.0, 200.0
    route = Route((Straight(1.0),), static_s=1000.0)
    truth = simulate_truth(route, rate_hz=rate, duration_s=n_s)
    ideal, _ = simulate_imu(truth, ImuErrorModel.error_free(rate_hz=rate))
    model = ImuErrorModel(
        rate_hz=rate,
        gyro_arw_rad_s_rthz=1e-4,
        acc_vrw_m_s2_rthz=1e-3,
        gyro_bias_sigma_rad_s=1e-3,
        acc_bias_m_s2=(0.05, -0.02, 0.01),
        acc_scale_ppm=(0.0, 0.0, 2000.0),
    )
    imu, err = simulate_imu(truth, model, seed=4)
    n = len(imu)
    dg = imu.gyro_body_rad_s - ideal.gyro_body_rad_s
    da = imu.acc_body_m_s2 - ideal.acc_body_m_s2
    sg = 1e-4 * math.sqrt(rate)  # per-sample white noise sigma
    sa = 1e-3 * math.sqrt(rate)
    # Turn-on biases: the stream's mean within 4 sigma of the white noise mean.
    assert np.all(np.abs(dg.mean(axis=0) - err.gyro_bias_rad_s) < 4 * sg / math.sqrt(n))
    expected_acc = err.acc_bias_m_s2 + ideal.acc_body_m_s2.mean(axis=0) * err.acc_scale_ppm * 1e-6
    assert np.all(np.abs(da.mean(axis=0) - expected_acc) < 4 * sa / math.sqrt(n))
    np.testing.assert_array_equal(err.acc_bias_m_s2, [0.05, -0.02, 0.01])
    assert abs(expected_acc[2] - 0.01) > 0.019  # 2000 ppm of -g shows
    # White-noise densities from the sample variance (chi-square: 4 sigma of the std).
    tol = 4 / math.sqrt(2 * (n - 1))
    for d, s in ((dg, sg), (da, sa)):
        ratio = d.std(axis=0, ddof=1) / s
        assert np.all(np.abs(ratio - 1) < tol)
    # Same seed, same data; another seed, other errors.
    again, _ = simulate_imu(truth, model, seed=4)
    np.testing.assert_array_equal(again.gyro_body_rad_s, imu.gyro_body_rad_s)
    _other, err2 = simulate_imu(truth, model, seed=5)
    assert not np.array_equal(err2.gyro_bias_rad_s, err.gyro_bias_rad_s)


def test_gauss_markov_variation_has_its_sigma_and_correlation() -> None:
    rate, tau, sigma = 50.0, 0.5, 2e-4
    truth = simulate_truth(Route((Straight(1.0),), static_s=500.0), rate_hz=rate, duration_s=400.0)
    model = ImuErrorModel(
        rate_hz=rate,
        gyro_bias_instability_rad_s=sigma,
        gyro_bias_corr_time_s=tau,
        gyro_misalignment_sigma_rad=1e-3,
    )
    _imu, err = simulate_imu(truth, model, seed=2)
    b = err.gyro_bias_variation_rad_s
    # About duration / (2 tau) = 400 independent stretches per axis, 3 axes.
    assert b.std() / sigma == pytest.approx(1.0, abs=4 / math.sqrt(2 * 1200))
    lag1 = np.mean(b[1:] * b[:-1]) / np.mean(b * b)
    assert lag1 == pytest.approx(math.exp(-1 / (rate * tau)), abs=0.01)
    np.testing.assert_array_equal(np.diag(err.gyro_misalignment_rad), 0.0)
    assert np.abs(err.gyro_misalignment_rad).max() > 0.0
    np.testing.assert_allclose(err.gyro_bias_total_rad_s(), err.gyro_bias_rad_s + b)


def test_bad_error_models() -> None:
    with pytest.raises(InputError, match="rate_hz"):
        ImuErrorModel(rate_hz=-1.0)
    with pytest.raises(InputError, match="gyro_arw"):
        ImuErrorModel(gyro_arw_rad_s_rthz=-1e-3)
    with pytest.raises(InputError, match="acc_bias_m_s2"):
        ImuErrorModel(acc_bias_m_s2=(1.0, 2.0))  # type: ignore[arg-type]
    with pytest.raises(InputError, match="gyro_scale_ppm"):
        ImuErrorModel(gyro_scale_ppm=(1.0, math.nan, 0.0))


# ---------------------------------------------------------------------- GNSS
def test_gnss_lever_arm_position_and_velocity() -> None:
    route = Route((Straight(3.0), Turn(270.0, 6.0)), speed_m_s=3.0, static_s=1.0)
    truth = simulate_truth(route, rate_hz=200.0, roll_amplitude_deg=4.0, pitch_amplitude_deg=2.0)
    arm = (1.0, 0.5, -2.0)
    gnss = simulate_gnss(
        truth,
        rate_hz=200.0,
        std_pos_ned_m=(1e-12, 1e-12, 1e-12),
        std_vel_ned_m_s=(1e-12, 1e-12, 1e-12),
        antenna_lever_arm_body_m=arm,
    )
    assert len(gnss) == len(truth)
    assert truth.lat_lon_h is not None
    llh = truth.lat_lon_h
    ant_ecef = geodetic_to_ecef(gnss.lat_deg, gnss.lon_deg, gnss.h_m)
    imu_ecef = geodetic_to_ecef(llh[:, 0], llh[:, 1], llh[:, 2])
    R_ne = rotation_ned_to_ecef(llh[:, 0], llh[:, 1])
    offset_ned = np.einsum("nji,nj->ni", R_ne, ant_ecef - imu_ecef)
    expected = np.einsum("nij,j->ni", quaternion_to_matrix(truth.q_body_to_ned), arm)
    np.testing.assert_allclose(offset_ned, expected, atol=1e-6)
    # The antenna velocity is the derivative of the antenna position (central
    # differences, error dt^2/6 |v'''| < 1e-5 m/s); without the w x l term it would be
    # off by up to |w| |l| ~ 1 m/s.
    assert gnss.vel_ned_m_s is not None
    R_ant = rotation_ned_to_ecef(gnss.lat_deg[1:-1], gnss.lon_deg[1:-1])
    v_fd = np.einsum("nji,nj->ni", R_ant, (ant_ecef[2:] - ant_ecef[:-2]) * 100.0)
    assert np.abs(v_fd - gnss.vel_ned_m_s[1:-1]).max() < 1e-5
    assert truth.vel_ned_m_s is not None
    assert np.abs(gnss.vel_ned_m_s - truth.vel_ned_m_s).max() > 0.3
    # A plain trajectory (no exact kinematics): angular rates from the attitude records,
    # interpolated (error ~ dt^2 |w''| |l| / 6, well below 1 mm/s at 200 Hz).
    plain = truth.sliced(truth.t_start_s, truth.t_end_s)
    same = simulate_gnss(
        plain,
        rate_hz=200.0,
        std_pos_ned_m=(1e-12, 1e-12, 1e-12),
        std_vel_ned_m_s=(1e-12, 1e-12, 1e-12),
        antenna_lever_arm_body_m=arm,
    )
    np.testing.assert_array_equal(same.lat_deg, gnss.lat_deg)
    assert same.vel_ned_m_s is not None
    assert np.abs(same.vel_ned_m_s[1:-1] - gnss.vel_ned_m_s[1:-1]).max() < 1e-3
    no_vel = Trajectory(t_s=plain.t_s, q_body_to_ned=plain.q_body_to_ned, lat_lon_h=plain.lat_lon_h)
    with pytest.raises(InputError, match="velocities"):
        simulate_gnss(no_vel, antenna_lever_arm_body_m=arm)
    local = Trajectory(
        t_s=plain.t_s,
        q_body_to_ned=plain.q_body_to_ned,
        pos_ned_m=np.zeros((len(plain), 3)),
        origin_lat_lon_h=(0.0, 0.0, 0.0),
    )
    with pytest.raises(InputError, match="geodetic"):
        simulate_gnss(local)


def test_gnss_noise_outages_and_epochs() -> None:
    truth = simulate_truth(oval_route(static_s=10.0), rate_hz=50.0, t_start_s=1000.1)
    std = (0.5, 1.0, 2.0)
    tiny = (1e-9, 1e-9, 1e-9)
    noisy = simulate_gnss(truth, rate_hz=5.0, std_pos_ned_m=std, seed=3)
    clean = simulate_gnss(truth, rate_hz=5.0, std_pos_ned_m=tiny, std_vel_ned_m_s=tiny, seed=3)
    # Epochs at whole multiples of 0.2 s within the truth span.
    assert noisy.t_s[0] == pytest.approx(1000.2)
    np.testing.assert_allclose(np.diff(noisy.t_s), 0.2, atol=1e-9)
    assert noisy.t_s[-1] <= truth.t_end_s
    np.testing.assert_array_equal(noisy.std_pos_ned_m, np.tile(std, (len(noisy), 1)))
    d = ecef_to_ned(
        geodetic_to_ecef(noisy.lat_deg, noisy.lon_deg, noisy.h_m)
        - geodetic_to_ecef(clean.lat_deg, clean.lon_deg, clean.h_m)
        + geodetic_to_ecef(46.8, -71.2, 10.0),
        46.8,
        -71.2,
        10.0,
    )
    n = len(noisy)
    ratio = d.std(axis=0, ddof=1) / np.array(std)
    assert np.all(np.abs(ratio - 1) < 4 / math.sqrt(2 * (n - 1)))
    cut = simulate_gnss(truth, rate_hz=5.0, outages=((1030.0, 1040.0), (1080.0, 1081.0)), seed=3)
    assert len(cut) == n - 51 - 6
    inside = ((cut.t_s >= 1030.0) & (cut.t_s <= 1040.0)) | ((cut.t_s >= 1080) & (cut.t_s <= 1081))
    assert not inside.any()
    with pytest.raises(InputError, match="outage 0"):
        simulate_gnss(truth, outages=((5.0, 4.0),))
    with pytest.raises(InputError, match="epoch"):
        simulate_gnss(truth, outages=((0.0, 1e6),))
    with pytest.raises(InputError, match="std_pos_ned_m"):
        simulate_gnss(truth, std_pos_ned_m=(0.0, 1.0, 1.0))


def test_noisy_trajectory_errors_are_smooth_and_consistent() -> None:
    truth = simulate_truth(oval_route(static_s=0.0), rate_hz=50.0)
    nav = noisy_trajectory(truth, std_pos_ned_m=(0.1, 0.1, 0.2), corr_time_s=2.0, seed=1)
    d = local_ned(nav, None) - local_ned(truth, None)
    rms = np.sqrt(np.mean(d**2, axis=0))
    assert np.all(rms > 0.03)
    assert np.all(rms < np.array([0.1, 0.1, 0.2]) * 2)
    # Velocities stay the derivative of the positions (Hermite interpolation).
    assert nav.vel_ned_m_s is not None
    assert nav.lat_lon_h is not None
    llh = nav.lat_lon_h
    ecef = geodetic_to_ecef(llh[:, 0], llh[:, 1], llh[:, 2])
    R_ne = rotation_ned_to_ecef(llh[1:-1, 0], llh[1:-1, 1])
    v_fd = np.einsum("nji,nj->ni", R_ne, (ecef[2:] - ecef[:-2]) * 25.0)
    assert np.abs(v_fd - nav.vel_ned_m_s[1:-1]).max() < 2e-3
    att = rotation_angle_rad(
        quaternion_to_matrix(truth.q_body_to_ned), quaternion_to_matrix(nav.q_body_to_ned)
    )
    assert 1e-5 < att.max() < math.radians(0.1)


# ---------------------------------------------------------------------- files
def test_drive_files_round_trip(tmp_path: Path) -> None:
    config = DriveSimConfig(
        route="loop", duration_s=90.0, static_s=20.0, gnss_outages=((50.0, 60.0),), seed=7
    )
    sim = simulate_drive(config)
    assert sim.truth.duration_s == pytest.approx(90.0)
    assert len(sim.imu) == len(sim.truth) == 90 * 50 + 1
    write_drive_simulation(sim, tmp_path / "drive")
    folder = tmp_path / "drive"
    imu = read_numeric_csv(folder / "imu.csv", ["t_s", "gyro_x_rad_s", "acc_z_m_s2"]).columns
    assert list(imu) == [
        "t_s",
        "gyro_x_rad_s",
        "gyro_y_rad_s",
        "gyro_z_rad_s",
        "acc_x_m_s2",
        "acc_y_m_s2",
        "acc_z_m_s2",
    ]
    np.testing.assert_array_equal(imu["t_s"], sim.imu.t_s)
    np.testing.assert_array_equal(imu["gyro_x_rad_s"], sim.imu.gyro_body_rad_s[:, 0])
    np.testing.assert_array_equal(imu["acc_z_m_s2"], sim.imu.acc_body_m_s2[:, 2])
    gnss = read_numeric_csv(folder / "gnss.csv", ["t_s", "lat_deg", "std_d_m", "vn_m_s"]).columns
    header = (folder / "gnss.csv").read_text().splitlines()[0]
    assert header.startswith("t_s,lat_deg,lon_deg,h_m,std_n_m,std_e_m,std_d_m,vn_m_s,ve_m_s,vd_m_s")
    np.testing.assert_array_equal(gnss["lat_deg"], sim.gnss.lat_deg)
    np.testing.assert_array_equal(gnss["std_d_m"], 0.04)
    assert not ((gnss["t_s"] >= 50.0) & (gnss["t_s"] <= 60.0)).any()
    truth_cols = read_numeric_csv(folder / "truth.csv", ["t_s"]).columns
    reference = (
        (Path(__file__).resolve().parents[3] / "shared" / "data" / "navego-synthetic" / "truth.csv")
        .read_text()
        .splitlines()
    )[0]
    assert ",".join(truth_cols) == reference
    rpy = np.degrees(sim.truth.euler_rpy_rad())
    np.testing.assert_array_equal(truth_cols["yaw_deg"], rpy[:, 2])
    doc = json.loads((folder / "truth.json").read_text())
    assert doc["seed"] == 7
    assert doc["imu_errors"]["gyro_bias_rad_s"] == sim.imu_errors.gyro_bias_rad_s.tolist()
    assert doc["imu_errors"]["acc_scale_ppm"] == sim.imu_errors.acc_scale_ppm.tolist()
    assert doc["initial_state"]["rpy_rad"] == list(sim.initial_state().rpy_rad)
    assert read_ins_config(folder / "ins.toml") == sim.ins_config
    assert sim.ins_config.antenna_lever_arm_body_m == config.antenna_lever_arm_body_m
    (tmp_path / "file").write_text("x")
    with pytest.raises(InputError, match="not a folder"):
        write_drive_simulation(sim, tmp_path / "file")


def test_drive_config_laps_fill_the_duration() -> None:
    for kind in ("oval", "loop", "lines"):
        cfg = DriveSimConfig(route=kind, duration_s=400.0, static_s=10.0)
        route = cfg.build_route()
        one = replace(cfg, laps=1, duration_s=None).build_route()
        two = replace(cfg, laps=2, duration_s=None).build_route()
        assert 400.0 <= route.duration_s < 400.0 + (two.duration_s - one.duration_s)
    mems = DriveSimConfig(imu="mems", imu_rate_hz=100.0).imu_model()
    assert mems.rate_hz == 100.0
    assert mems.gyro_arw_rad_s_rthz == ImuErrorModel.mems().gyro_arw_rad_s_rthz


@pytest.mark.parametrize(
    ("kwargs", "fragment"),
    [
        ({"route": "circle"}, "route must be"),
        ({"imu": "fog"}, "imu must be"),
        ({"speed_m_s": 0.0}, "speed_m_s"),
        ({"laps": 0}, "laps"),
        ({"seed": -1}, "seed"),
        ({"gnss_outages": ((3.0, 2.0),)}, "outage"),
        ({"antenna_lever_arm_body_m": (0.0, 1.0)}, "antenna_lever_arm_body_m"),
        ({"duration_s": -5.0}, "duration_s"),
    ],
)
def test_bad_drive_configs(kwargs: dict[str, object], fragment: str) -> None:
    with pytest.raises(InputError, match=fragment):
        DriveSimConfig(**kwargs)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("make", "fragment"),
    [
        (lambda: Route(()), "nothing to drive"),
        (lambda: Route((Stop(3.0),)), "nothing to drive"),
        (lambda: Route(("straight",)), "segment 0"),  # type: ignore[arg-type]
        (lambda: Straight(-1.0), "length_m"),
        (lambda: Turn(0.0, 5.0), "angle_deg"),
        (lambda: Turn(90.0, 0.0), "radius_m"),
        (lambda: Stop(math.inf), "duration_s"),
        (lambda: Route((Straight(1.0),), transition_fraction=0.0), "transition_fraction"),
        (lambda: Route((Straight(1.0),), static_s=-1.0), "static_s"),
        (lambda: oval_route(laps=0), "laps"),
        (lambda: figure_eight_route(crossing_angle_deg=179.0), "crossing_angle_deg"),
        (lambda: survey_lines_route(line_spacing_m=0.0), "line_spacing_m"),
        (lambda: simulate_truth(oval_route(), rate_hz=0.0), "rate_hz"),
        (lambda: simulate_truth(oval_route(), origin_lat_lon_h=(89.0, 0.0, 0.0)), "85"),
        (lambda: simulate_truth(oval_route(), roll_amplitude_deg=70.0), "roll amplitude"),
        (lambda: simulate_truth(oval_route(), undulation_amplitude_m=10.0), "undulation"),
        (lambda: simulate_truth(oval_route(), duration_s=0.001, rate_hz=10.0), "fewer than 2"),
    ],
)
def test_bad_routes_and_truth_options(make: Callable[[], object], fragment: str) -> None:
    with pytest.raises(InputError, match=fragment):
        make()


def test_ideal_imu_mean_matches_a_fine_average() -> None:
    # 4-point Gauss-Legendre mean over each interval against a 64-point midpoint rule.
    route = Route((Straight(2.0), Turn(-120.0, 4.0)), speed_m_s=3.0, static_s=0.5)
    truth = simulate_truth(route, rate_hz=50.0, roll_amplitude_deg=5.0, roll_period_s=2.0)
    t = truth.t_s[10:60]
    gyro, acc = ideal_imu_mean(truth, t)
    fine = t[:, None] - 0.02 + (np.arange(64) + 1.0)[None, :] * (0.02 / 64)
    g_fine, a_fine = ideal_imu_mean(truth, np.concatenate([[fine[0, 0] - 0.02 / 64], fine.ravel()]))
    np.testing.assert_allclose(gyro, g_fine[1:].reshape(50, 64, 3).mean(axis=1), atol=1e-8)
    np.testing.assert_allclose(acc, a_fine[1:].reshape(50, 64, 3).mean(axis=1), atol=1e-7)
