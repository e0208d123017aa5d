"""Strapdown mechanisation: static Earth, level constant-velocity flight, coning, inputs."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from kinsync.errors import InputError
from kinsync.frames import euler_rpy_to_matrix, quaternion_to_matrix
from kinsync.ins.earth import OMEGA_IE_RAD_S, normal_gravity_m_s2, radii_m
from kinsync.ins.measurements import ImuData
from kinsync.ins.solution import InitialState
from kinsync.ins.strapdown import free_inertial, mechanise_states, quat_mul, rotvec_to_quat

RATE_HZ = 200.0


def _ned_offsets_m(
    lat_deg: np.ndarray, lon_deg: np.ndarray, h_m: np.ndarray, ref: tuple[float, float, float]
) -> np.ndarray:
    lat0 = math.radians(ref[0])
    r_m, r_n = radii_m(lat0)
    return np.column_stack(
        [
            np.radians(lat_deg - ref[0]) * (r_m + ref[2]),
            np.radians(lon_deg - ref[1]) * (r_n + ref[2]) * math.cos(lat0),
            -(h_m - ref[2]),
        ]
    )


@pytest.mark.parametrize(
    ("lat_deg", "rpy"),
    [(45.0, (0.1, -0.05, 0.7)), (-32.8, (-0.3, 0.2, -2.5)), (70.0, (0.0, 0.0, 3.0))],
)
def test_static_on_the_rotating_earth_stays_put(
    lat_deg: float, rpy: tuple[float, float, float]
) -> None:
    h = 100.0
    lat = math.radians(lat_deg)
    R = euler_rpy_to_matrix(*rpy)
    w_ie = np.array([OMEGA_IE_RAD_S * math.cos(lat), 0.0, -OMEGA_IE_RAD_S * math.sin(lat)])
    g = normal_gravity_m_s2(lat, h)
    n = round(60.0 * RATE_HZ) + 1
    imu = ImuData(
        t_s=np.arange(n) / RATE_HZ,
        gyro_body_rad_s=np.tile(R.T @ w_ie, (n, 1)),
        acc_body_m_s2=np.tile(R.T @ np.array([0.0, 0.0, -g]), (n, 1)),
    )
    sol = free_inertial(imu, InitialState(0.0, lat_deg, 10.0, h, (0.0, 0.0, 0.0), rpy))
    drift = _ned_offsets_m(sol.lat_deg, sol.lon_deg, sol.h_m, (lat_deg, 10.0, h))
    assert len(sol) == n
    assert np.abs(drift).max() < 1e-4  # 0.1 mm in a minute
    assert np.abs(sol.vel_ned_m_s).max() < 1e-6
    assert np.abs(sol.rpy_rad - np.asarray(rpy)).max() < 1e-9
    assert np.isnan(sol.std_pos_ned_m).all()
    assert not sol.gyro_bias_rad_s.any()
    assert not sol.smoothed


def test_constant_velocity_level_flight_east() -> None:
    """Along a parallel at constant height: lat, h fixed, lon linear, attitude fixed in NED."""
    lat_deg, lon_deg, h, v_e = 45.0, 10.0, 300.0, 80.0
    lat = math.radians(lat_deg)
    _, r_n = radii_m(lat)
    w_ie = np.array([OMEGA_IE_RAD_S * math.cos(lat), 0.0, -OMEGA_IE_RAD_S * math.sin(lat)])
    w_en = np.array([v_e / (r_n + h), 0.0, -v_e * math.tan(lat) / (r_n + h)])
    v = np.array([0.0, v_e, 0.0])
    f_n = np.cross(2.0 * w_ie + w_en, v) - np.array([0.0, 0.0, normal_gravity_m_s2(lat, h)])
    rpy = (0.0, 0.02, math.pi / 2)  # slight nose-up attitude while flying level
    R = euler_rpy_to_matrix(*rpy)
    n = round(60.0 * RATE_HZ) + 1
    t = np.arange(n) / RATE_HZ
    imu = ImuData(
        t_s=t,
        gyro_body_rad_s=np.tile(R.T @ (w_ie + w_en), (n, 1)),
        acc_body_m_s2=np.tile(R.T @ f_n, (n, 1)),
    )
    sol = free_inertial(imu, InitialState(0.0, lat_deg, lon_deg, h, (0.0, v_e, 0.0), rpy))
    lon_true = lon_deg + np.degrees(v_e * t / ((r_n + h) * math.cos(lat)))
    err = _ned_offsets_m(
        sol.lat_deg, sol.lon_deg - lon_true + lon_deg, sol.h_m, (lat_deg, lon_deg, h)
    )
    assert np.abs(err).max() < 1e-3  # 4.8 km flown, < 1 mm off
    assert np.abs(sol.vel_ned_m_s - v).max() < 1e-6
    assert np.abs(sol.rpy_rad - np.asarray(rpy)).max() < 1e-9


def _coning_case(
    alpha: float, freq_hz: float, rate_hz: float, duration_s: float
) -> tuple[ImuData, np.ndarray, InitialState]:
    """Body coning about NED axes while static on the rotating Earth, exact increments."""
    lat = math.radians(30.0)
    w_ie = np.array([OMEGA_IE_RAD_S * math.cos(lat), 0.0, -OMEGA_IE_RAD_S * math.sin(lat)])
    g = normal_gravity_m_s2(lat, 0.0)
    om = 2.0 * math.pi * freq_hz

    def quat(t: np.ndarray) -> np.ndarray:
        s = math.sin(alpha / 2)
        return np.column_stack(
            [np.full_like(t, math.cos(alpha / 2)), 0 * t, s * np.cos(om * t), s * np.sin(om * t)]
        )

    def rates(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        q = quat(t)
        R = quaternion_to_matrix(q)
        w_nb = np.column_stack(
            [
                np.full_like(t, -2.0 * om * math.sin(alpha / 2) ** 2),
                -om * math.sin(alpha) * np.sin(om * t),
                om * math.sin(alpha) * np.cos(om * t),
            ]
        )
        w_ib = w_nb + np.einsum("nji,j->ni", R, w_ie)
        f_b = np.einsum("nji,j->ni", R, np.array([0.0, 0.0, -g]))
        return w_ib, f_b

    dt = 1.0 / rate_hz
    n = round(duration_s * rate_hz) + 1
    t = np.asarray(np.arange(n) * dt, dtype=np.float64)
    gyro = np.zeros((n, 3))
    acc = np.zeros((n, 3))
    sub = 8
    nodes = np.array([-math.sqrt(3 / 5), 0.0, math.sqrt(3 / 5)])
    weights = np.array([5.0, 8.0, 5.0]) / 18.0
    for i in range(sub):
        for x, w in zip(nodes, weights, strict=True):
            tq = t - dt + (i + 0.5 + 0.5 * x) * dt / sub
            w_ib, f_b = rates(tq)
            gyro += w * w_ib / sub
            acc += w * f_b / sub
    q_true = quat(t)
    rpy0 = Rotation.from_quat(q_true[0, [1, 2, 3, 0]]).as_euler("ZYX")[::-1]
    init = InitialState(0.0, 30.0, 0.0, 0.0, (0.0, 0.0, 0.0), tuple(float(a) for a in rpy0))  # type: ignore[arg-type]
    return ImuData(t_s=t, gyro_body_rad_s=gyro, acc_body_m_s2=acc), q_true, init


def test_closed_form_coning_rate_matches_the_quaternion_derivative() -> None:
    imu, q_true, _ = _coning_case(math.radians(2.0), 5.0, 1000.0, 0.2)
    # Mean rate over each interval vs the rotation between the exact attitudes.
    rot = Rotation.from_quat(q_true[:, [1, 2, 3, 0]])
    rv = (rot[:-1].inv() * rot[1:]).as_rotvec() * 1000.0
    assert np.abs(imu.gyro_body_rad_s[1:] - rv).max() < 1e-3 * np.abs(rv).max()


def _final_attitude_error(rate_hz: float, *, coning: bool) -> float:
    imu, q_true, init = _coning_case(math.radians(2.0), 5.0, rate_hz, 10.0)
    states = mechanise_states(imu, init, coning=coning)
    Rs = quaternion_to_matrix(states[-1, 6:10])
    Rt = quaternion_to_matrix(q_true[-1])
    return float(np.linalg.norm(Rotation.from_matrix(Rs @ Rt.T).as_rotvec()))


def test_coning_correction_reduces_attitude_error() -> None:
    """2° half-cone at 5 Hz: first-order drift ~ (ΩΔt)², two-sample residual ~ (ΩΔt)⁴."""
    err_on, err_off = (_final_attitude_error(100.0, coning=c) for c in (True, False))
    assert err_off > 1e-3  # 3 mrad in 10 s without the correction
    assert err_on < 0.03 * err_off
    err_on_200, err_off_200 = (_final_attitude_error(200.0, coning=c) for c in (True, False))
    assert 3.0 < err_off / err_off_200 < 5.0  # second order without
    assert err_on / err_on_200 > 10.0  # fourth order with (16 in theory)
    assert err_on_200 < 1e-5


def test_initial_state_checks() -> None:
    n = 11
    imu = ImuData(np.linspace(0.0, 0.1, n), np.zeros((n, 3)), np.tile([0.0, 0.0, -9.8], (n, 1)))
    good = InitialState(0.0, 45.0, 0.0, 0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    assert len(free_inertial(imu, good)) == n
    later = InitialState(0.05, 45.0, 0.0, 0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    assert free_inertial(imu, later).t_s[0] == pytest.approx(0.05)
    with pytest.raises(InputError, match="not an IMU sample time"):
        free_inertial(imu, InitialState(0.055, 45.0, 0.0, 0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)))
    with pytest.raises(InputError, match="not an IMU sample time"):
        free_inertial(imu, InitialState(-5.0, 45.0, 0.0, 0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)))
    with pytest.raises(InputError, match="last IMU sample"):
        free_inertial(imu, InitialState(0.1, 45.0, 0.0, 0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)))
    with pytest.raises(InputError, match="finite"):
        free_inertial(imu, InitialState(0.0, 45.0, 0.0, math.nan, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)))
    with pytest.raises(InputError, match="pole"):
        free_inertial(imu, InitialState(0.0, 90.0, 0.0, 0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)))
    with pytest.raises(InputError, match="finite"):
        free_inertial(imu, InitialState(math.inf, 45.0, 0.0, 0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)))


_angles = st.floats(-3.0, 3.0, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(_angles, _angles, _angles, _angles, _angles, _angles)
def test_quaternion_helpers_match_scipy(
    a: float, b: float, c: float, d: float, e: float, f: float
) -> None:
    qa = np.empty(4)
    qb = np.empty(4)
    out = np.empty(4)
    rotvec_to_quat(a, b, c, qa)
    rotvec_to_quat(d * 1e-5, e, f * 1e-9, qb)  # includes the small-angle series branch
    ra = Rotation.from_rotvec([a, b, c])
    rb = Rotation.from_rotvec([d * 1e-5, e, f * 1e-9])
    np.testing.assert_allclose(quaternion_to_matrix(qa), ra.as_matrix(), atol=1e-12)
    np.testing.assert_allclose(quaternion_to_matrix(qb), rb.as_matrix(), atol=1e-12)
    quat_mul(qa, qb, out)
    np.testing.assert_allclose(quaternion_to_matrix(out), (ra * rb).as_matrix(), atol=1e-12)
