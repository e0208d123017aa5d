"""Tests of kinsync.trajectory against analytic motion."""

from __future__ import annotations

import dataclasses
import math
import re

import numpy as np
import numpy.typing as npt
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from scipy.spatial.transform import Rotation

from kinsync.errors import InputError, OutsideSpanError
from kinsync.frames import (
    ecef_to_geodetic,
    euler_rpy_to_quaternion,
    geodetic_to_ecef,
    ned_to_ecef,
    rotation_ned_to_ecef,
)
from kinsync.trajectory import Trajectory, TrajectorySample

FloatArray = npt.NDArray[np.float64]

T0 = 1_400_000_000.0
"""A GPS-like start time (s): large times must not cost precision."""
ORIGIN = (46.8, 7.15, 550.0)
IDENTITY_Q = np.array([1.0, 0.0, 0.0, 0.0])


def _wxyz(rot: Rotation) -> FloatArray:
    """Scalar-first quaternions of a scipy rotation (stack)."""
    return np.asarray(rot.as_quat()[..., [3, 0, 1, 2]], dtype=np.float64)


def _rotation(q_wxyz: FloatArray) -> Rotation:
    return Rotation.from_quat(np.asarray(q_wxyz)[..., [1, 2, 3, 0]])


def _angle_between(R_true: FloatArray, R_test: FloatArray) -> FloatArray:
    """Rotation angle (rad) of ``R_true^T @ R_test`` for stacks of matrices."""
    delta = np.swapaxes(R_true, -1, -2) @ R_test
    return np.asarray(Rotation.from_matrix(delta).magnitude(), dtype=np.float64)


def _times(n: int, dt: float, seed: int, jitter: float = 0.2) -> FloatArray:
    """Strictly increasing record times from T0 with some irregularity."""
    rng = np.random.default_rng(seed)
    steps = dt * (1.0 + jitter * rng.uniform(-1.0, 1.0, size=n - 1))
    return T0 + np.concatenate([[0.0], np.cumsum(steps)])


def _query_times(t: FloatArray, m: int, seed: int) -> FloatArray:
    """Random times inside the span, both ends included."""
    rng = np.random.default_rng(seed)
    inner = t[0] + (t[-1] - t[0]) * rng.uniform(0.0, 1.0, size=m)
    return np.concatenate([[t[0], t[-1]], inner, t[1:-1:7]])


def _identity_q(n: int) -> FloatArray:
    return np.tile(IDENTITY_Q, (n, 1))


def _local(
    t: FloatArray,
    pos: FloatArray,
    q: FloatArray | None = None,
    vel: FloatArray | None = None,
) -> Trajectory:
    return Trajectory(
        t_s=t,
        q_body_to_ned=_identity_q(t.size) if q is None else q,
        pos_ned_m=pos,
        origin_lat_lon_h=ORIGIN,
        vel_ned_m_s=vel,
    )


def _pos(sample: TrajectorySample) -> FloatArray:
    assert sample.pos_ned_m is not None
    return sample.pos_ned_m


def _llh(sample: TrajectorySample) -> FloatArray:
    assert sample.lat_lon_h is not None
    return sample.lat_lon_h


# ---------------------------------------------------------------- position, local NED


def test_constant_velocity_is_exact_linear_and_hermite() -> None:
    t = _times(60, 0.1, seed=10)
    p0 = np.array([12.0, -30.0, 2.5])
    v = np.array([8.0, -13.5, 0.4])
    pos = p0 + np.outer(t - T0, v)
    traj = _local(t, pos, vel=np.tile(v, (t.size, 1)))
    tq = _query_times(t, 500, seed=11)
    truth = p0 + np.outer(tq - T0, v)
    for method in ("linear", "hermite", "auto"):
        sample = traj.interpolate(tq, position=method)
        assert sample.lat_lon_h is None
        assert sample.origin_lat_lon_h == ORIGIN
        assert np.all(sample.inside)
        assert_allclose(_pos(sample), truth, rtol=0, atol=1e-9)
    # Without velocities "auto" is linear and still exact.
    assert_allclose(_pos(_local(t, pos).interpolate(tq)), truth, rtol=0, atol=1e-9)
    # ECEF positions follow the local frame.
    assert_allclose(
        traj.interpolate(tq).pos_ecef_m(), ned_to_ecef(truth, *ORIGIN), rtol=0, atol=1e-6
    )


def test_cubic_motion_hermite_exact_linear_not() -> None:
    t = _times(25, 1.0, seed=12)
    a = np.array([[5.0, -3.0, 1.0], [4.0, 7.0, -0.5], [0.3, -0.2, 0.05], [-0.02, 0.015, 0.001]])

    def position(tt: FloatArray) -> FloatArray:
        tau = (tt - T0)[:, None]
        return np.asarray(a[0] + a[1] * tau + a[2] * tau**2 + a[3] * tau**3, dtype=np.float64)

    def velocity(tt: FloatArray) -> FloatArray:
        tau = (tt - T0)[:, None]
        return np.asarray(a[1] + 2 * a[2] * tau + 3 * a[3] * tau**2, dtype=np.float64)

    traj = _local(t, position(t), vel=velocity(t))
    tq = _query_times(t, 500, seed=13)
    truth = position(tq)
    hermite = _pos(traj.interpolate(tq, position="hermite"))
    assert_allclose(hermite, truth, rtol=0, atol=1e-9)
    assert_allclose(_pos(traj.interpolate(tq)), hermite, rtol=0, atol=0)  # auto = Hermite
    linear_err = np.max(np.abs(_pos(traj.interpolate(tq, position="linear")) - truth))
    assert linear_err > 1e-2
    # At the records both methods return the records.
    for method in ("linear", "hermite"):
        assert_allclose(_pos(traj.interpolate(t, position=method)), position(t), atol=1e-9)


def test_hermite_needs_velocities_and_method_is_checked() -> None:
    t = T0 + np.arange(5.0)
    traj = _local(t, np.zeros((5, 3)))
    with pytest.raises(InputError, match="vel_ned_m_s"):
        traj.interpolate(t[1], position="hermite")
    with pytest.raises(InputError, match="position method"):
        traj.interpolate(t[1], position="cubic")  # type: ignore[arg-type]


# ---------------------------------------------------------------- position, geodetic


def _east_line(t: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Straight ECEF line starting East at 20 m/s from lat 46.8: (ecef, llh, vel_ned)."""
    lat0, lon0, h0 = 46.8, 7.15, 550.0
    p0 = geodetic_to_ecef(lat0, lon0, h0)
    v_ecef = 20.0 * rotation_ned_to_ecef(lat0, lon0)[:, 1]
    ecef = p0 + np.outer(t - T0, v_ecef)
    llh = ecef_to_geodetic(ecef)
    R = rotation_ned_to_ecef(llh[:, 0], llh[:, 1])
    vel_ned = np.einsum("nji,j->ni", R, v_ecef)
    return ecef, llh, vel_ned


def test_geodetic_hermite_beats_linear() -> None:
    t = T0 + np.arange(61.0)  # 1 Hz
    _, llh, vel_ned = _east_line(t)
    assert_allclose(vel_ned[0], [0.0, 20.0, 0.0], atol=1e-12)
    traj = Trajectory(t_s=t, q_body_to_ned=_identity_q(t.size), lat_lon_h=llh, vel_ned_m_s=vel_ned)
    assert traj.is_geodetic
    tq = T0 + np.linspace(0.0, 60.0, 1201)  # dense truth, 20 per interval
    truth_ecef, _, _ = _east_line(tq)
    hermite_err = np.linalg.norm(traj.interpolate(tq).pos_ecef_m() - truth_ecef, axis=1)
    linear = traj.interpolate(tq, position="linear")
    linear_err = np.linalg.norm(linear.pos_ecef_m() - truth_ecef, axis=1)
    assert float(np.max(linear_err)) > 1e-6  # the line leaves the ellipsoid: h is curved
    assert float(np.max(hermite_err)) < 1e-7
    assert float(np.max(hermite_err)) < float(np.max(linear_err)) / 50.0
    # At the records, both reproduce the input exactly.
    assert_allclose(_llh(traj.interpolate(t)), llh, rtol=0, atol=1e-12)
    assert_allclose(traj.interpolate(t).pos_ecef_m(), geodetic_to_ecef(*llh.T), atol=1e-9)


def test_longitude_wraps_across_antimeridian() -> None:
    t = T0 + np.array([0.0, 1.0])
    llh = np.array([[10.0, 179.9999, 100.0], [10.0, -179.9999, 100.0]])
    traj = Trajectory(t_s=t, q_body_to_ned=_identity_q(2), lat_lon_h=llh)
    out = _llh(traj.interpolate(T0 + np.array([0.25, 0.5, 0.75])))
    assert_allclose(abs(out[1, 1]), 180.0, atol=1e-9)  # not 0
    assert_allclose(out[0, 1], 179.99995, atol=1e-9)
    assert_allclose(out[2, 1], -179.99995, atol=1e-9)
    assert np.all((out[:, 1] >= -180.0) & (out[:, 1] <= 180.0))
    assert_allclose(out[:, 0], 10.0, atol=0)
    mid_ecef = traj.interpolate(T0 + 0.5).pos_ecef_m()[0]
    assert_allclose(mid_ecef, geodetic_to_ecef(10.0, 180.0, 100.0), atol=1e-6)

    # With velocities (Hermite), over several records that cross the antimeridian.
    t4 = T0 + np.arange(4.0)
    lon = np.array([179.9997, 179.9999, -179.9999, -179.9997])
    llh4 = np.column_stack([np.full(4, 10.0), lon, np.full(4, 100.0)])
    east_m_per_deg = (
        np.linalg.norm(
            geodetic_to_ecef(10.0, 0.5e-4, 100.0) - geodetic_to_ecef(10.0, -0.5e-4, 100.0)
        )
        / 1e-4
    )
    v_east = 2e-4 * east_m_per_deg
    vel = np.tile([0.0, v_east, 0.0], (4, 1))
    traj4 = Trajectory(t_s=t4, q_body_to_ned=_identity_q(4), lat_lon_h=llh4, vel_ned_m_s=vel)
    tq = T0 + np.linspace(0.0, 3.0, 31)
    out4 = _llh(traj4.interpolate(tq))
    lon_unwrapped = np.unwrap(out4[:, 1], period=360.0)
    assert np.all(np.diff(lon_unwrapped) > 0.0)  # monotonic through the wrap
    assert np.max(np.abs(np.diff(lon_unwrapped))) < 1e-4
    assert_allclose(abs(out4[15, 1]), 180.0, atol=1e-9)


# ---------------------------------------------------------------- attitude


def test_constant_yaw_rate_slerp_exact() -> None:
    rate = math.radians(30.0)  # 30 deg/s about Down, 10 Hz records
    roll, pitch, yaw0 = 0.1, -0.05, 2.0
    t = T0 + 0.1 * np.arange(101.0)  # 10 s: yaw passes through +-180 deg

    def truth(tt: FloatArray) -> Rotation:
        yaw = yaw0 + rate * (tt - T0)
        n = tt.size
        angles = np.column_stack([yaw, np.full(n, pitch), np.full(n, roll)])
        return Rotation.from_euler("ZYX", angles)  # intrinsic: Rz(yaw) Ry(pitch) Rx(roll)

    traj = _local(t, np.zeros((t.size, 3)), q=_wxyz(truth(t)))
    tq = _query_times(t, 400, seed=14)
    sample = traj.interpolate(tq)
    err = _angle_between(truth(tq).as_matrix(), sample.R_body_to_ned)
    assert float(np.max(err)) < 1e-10
    assert np.all(sample.q_body_to_ned[:, 0] >= 0.0)
    assert_allclose(np.linalg.norm(sample.q_body_to_ned, axis=1), 1.0, atol=1e-14)
    # A constant rate about the navigation Down axis is a constant body rate too.
    R0 = truth(np.array([T0])).as_matrix()[0]
    w_body = R0.T @ np.array([0.0, 0.0, rate])
    rates = traj.angular_rate_body_rad_s()
    assert rates.shape == (t.size, 3)
    assert_allclose(rates, np.tile(w_body, (t.size, 1)), rtol=0, atol=1e-9)
    # Heading recovered from the trajectory's Euler angles.
    rpy = traj.euler_rpy_rad()
    assert rpy.shape == (t.size, 3)
    assert_allclose(rpy[:, :2], np.tile([roll, pitch], (t.size, 1)), atol=1e-12)
    yaw_expected = yaw0 + rate * (t - T0)
    assert_allclose(np.angle(np.exp(1j * (rpy[:, 2] - yaw_expected))), 0.0, atol=1e-12)


def test_constant_3d_body_rate_slerp_exact() -> None:
    rng = np.random.default_rng(15)
    R0 = Rotation.from_rotvec(rng.uniform(-2.0, 2.0, size=3))
    w = np.array([0.3, -0.5, 0.8])  # rad/s, body frame
    t = _times(80, 0.1, seed=16)

    def truth(tt: FloatArray) -> Rotation:
        # R(t) = R0 @ expm(skew(w) (t - T0))
        return R0 * Rotation.from_rotvec(np.outer(tt - T0, w))

    traj = _local(t, np.zeros((t.size, 3)), q=_wxyz(truth(t)))
    tq = _query_times(t, 400, seed=17)
    err = _angle_between(truth(tq).as_matrix(), traj.interpolate(tq).R_body_to_ned)
    assert float(np.max(err)) < 1e-10
    assert_allclose(traj.angular_rate_body_rad_s(), np.tile(w, (t.size, 1)), rtol=0, atol=1e-9)


def test_slerp_takes_shortest_path_whatever_the_quaternion_sign() -> None:
    w = np.array([0.0, 0.2, 0.1])
    t = T0 + 0.5 * np.arange(10.0)
    q = _wxyz(Rotation.from_rotvec(np.outer(t - T0, w)))
    flipped = q * np.where(np.arange(10) % 2 == 0, 1.0, -1.0)[:, None]
    tq = _query_times(t, 100, seed=18)
    a = _local(t, np.zeros((10, 3)), q=q).interpolate(tq)
    b = _local(t, np.zeros((10, 3)), q=flipped).interpolate(tq)
    assert_allclose(b.q_body_to_ned, a.q_body_to_ned, atol=1e-14)
    assert_allclose(
        _local(t, np.zeros((10, 3)), q=flipped).angular_rate_body_rad_s(),
        np.tile(w, (10, 1)),
        atol=1e-12,
    )


def test_from_euler_matches_quaternions() -> None:
    t = T0 + np.arange(4.0)
    roll = np.array([0.1, 0.2, -0.3, 0.0])
    pitch = np.array([0.0, -0.1, 0.2, 0.3])
    yaw = np.array([3.0, -3.1, 1.0, 0.5])
    traj = Trajectory.from_euler(
        t, roll, pitch, yaw, pos_ned_m=np.zeros((4, 3)), origin_lat_lon_h=ORIGIN
    )
    assert_allclose(traj.q_body_to_ned, euler_rpy_to_quaternion(roll, pitch, yaw), atol=1e-15)
    assert_allclose(traj.euler_rpy_rad(), np.column_stack([roll, pitch, yaw]), atol=1e-12)


# ---------------------------------------------------------------- span, masking


def _small_local() -> Trajectory:
    t = T0 + np.array([0.0, 1.0, 2.5, 4.0])
    pos = np.outer(t - T0, [1.0, 2.0, -0.5])
    q = _wxyz(Rotation.from_rotvec(np.outer(t - T0, [0.0, 0.0, 0.1])))
    return _local(t, pos, q=q)


def test_outside_span_raises_with_time_and_span() -> None:
    traj = _small_local()
    assert issubclass(OutsideSpanError, InputError)
    for t_bad in (T0 - 0.5, T0 + 4.25):
        with pytest.raises(OutsideSpanError) as info:
            traj.interpolate([T0 + 1.0, t_bad, T0 + 2.0])
        message = str(info.value)
        assert f"t={t_bad!r}" in message
        assert f"[{T0!r}, {T0 + 4.0!r}]" in message
        assert "np.float64" not in message
    with pytest.raises(OutsideSpanError):
        traj.interpolate(T0 + 4.0 + 1e-6)
    with pytest.raises(InputError, match="not finite"):
        traj.interpolate([T0 + 1.0, math.nan])


def test_mask_outside_gives_nan_rows() -> None:
    traj = _small_local()
    tq = T0 + np.array([-1.0, 0.5, 3.0, 4.0, 9.0, 0.0])
    inside_expected = np.array([False, True, True, True, False, True])
    sample = traj.interpolate(tq, mask_outside=True)
    assert_array_equal(sample.inside, inside_expected)
    assert_array_equal(sample.t_s, tq)
    assert np.all(np.isnan(sample.q_body_to_ned[~inside_expected]))
    assert np.all(np.isnan(_pos(sample)[~inside_expected]))
    assert np.all(np.isnan(sample.R_body_to_ned[~inside_expected]))
    assert np.all(np.isnan(sample.pos_ecef_m()[~inside_expected]))
    reference = traj.interpolate(tq[inside_expected])
    assert_allclose(sample.q_body_to_ned[inside_expected], reference.q_body_to_ned, atol=0)
    assert_allclose(_pos(sample)[inside_expected], _pos(reference), atol=0)
    assert_allclose(_pos(reference), np.outer(tq[inside_expected] - T0, [1.0, 2.0, -0.5]))
    assert not np.any(np.isnan(reference.R_body_to_ned))
    # All outside: nothing to interpolate, all NaN, no error.
    none_inside = traj.interpolate(T0 + np.array([-2.0, 5.0]), mask_outside=True)
    assert not np.any(none_inside.inside)
    assert np.all(np.isnan(none_inside.pos_ecef_m()))
    assert np.all(np.isnan(none_inside.R_body_to_ned))


def test_mask_outside_geodetic() -> None:
    t = T0 + np.arange(3.0)
    llh = np.array([[46.8, 7.0, 500.0], [46.8001, 7.0001, 501.0], [46.8002, 7.0002, 502.0]])
    traj = Trajectory(t_s=t, q_body_to_ned=_identity_q(3), lat_lon_h=llh)
    sample = traj.interpolate(T0 + np.array([0.5, 7.0]), mask_outside=True)
    out = _llh(sample)
    assert_array_equal(sample.inside, [True, False])
    assert_allclose(out[0], [46.80005, 7.00005, 500.5], rtol=0, atol=1e-9)
    assert np.all(np.isnan(out[1]))
    assert sample.pos_ned_m is None


def test_contains_duration_and_span() -> None:
    traj = _small_local()
    assert len(traj) == 4
    assert not traj.is_geodetic
    assert traj.t_start_s == T0
    assert traj.t_end_s == T0 + 4.0
    assert traj.duration_s == 4.0
    assert traj.contains(T0 + 2.0)
    assert traj.contains(T0)  # both ends included
    assert traj.contains(T0 + 4.0)
    assert not traj.contains(T0 - 1e-6)
    mask = traj.contains(T0 + np.array([[-1.0, 0.0], [4.0, 4.5]]))
    assert mask.shape == (2, 2)
    assert_array_equal(mask, [[False, True], [True, False]])


# ---------------------------------------------------------------- time shifts, slicing


def test_shifted_moves_record_times() -> None:
    traj = _small_local()
    dt = 0.37
    moved = traj.shifted(dt)
    assert_array_equal(moved.t_s, traj.t_s + dt)
    assert_array_equal(moved.q_body_to_ned, traj.q_body_to_ned)
    tq = T0 + np.array([0.0, 0.3, 1.7, 3.3])
    a, b = traj.interpolate(tq), moved.interpolate(tq + dt)
    assert_allclose(_pos(b), _pos(a), atol=1e-9)
    assert_allclose(b.q_body_to_ned, a.q_body_to_ned, atol=1e-12)
    assert moved.origin_lat_lon_h == traj.origin_lat_lon_h
    with pytest.raises(InputError, match="finite"):
        traj.shifted(math.inf)


@pytest.mark.parametrize("geodetic", [True, False])
def test_shifted_is_a_new_trajectory_of_the_shifted_times_sharing_the_rest(
    geodetic: bool,
) -> None:
    """Only the times are checked again: the other arrays, checked and read-only, are
    shared instead of checked and copied (georef shifts a whole 10 h trajectory); the
    result is, bit for bit, what a new Trajectory of the shifted times holds."""
    rng = np.random.default_rng(3)
    n = 200
    t = 1.4e9 + 0.005 * np.arange(n)
    rpy = rng.uniform(-3.0, 3.0, (3, n)) * np.array([[1.0], [0.5], [1.0]])  # pitch in +-pi/2
    pos = np.column_stack([46.8 + 1e-6 * np.arange(n), -71.2 + 2e-6 * np.arange(n), 50 + t * 0])
    where = {"lat_lon_h": pos} if geodetic else {"pos_ned_m": pos, "origin_lat_lon_h": (46, 7, 0)}
    traj = Trajectory.from_euler(t, *rpy, vel_ned_m_s=rng.normal(size=(n, 3)), **where)
    moved = traj.shifted(-0.0123)
    fresh = Trajectory(
        t_s=traj.t_s - 0.0123,
        q_body_to_ned=traj.q_body_to_ned,
        lat_lon_h=traj.lat_lon_h,
        pos_ned_m=traj.pos_ned_m,
        origin_lat_lon_h=traj.origin_lat_lon_h,
        vel_ned_m_s=traj.vel_ned_m_s,
    )
    for name in ("t_s", "q_body_to_ned", "lat_lon_h", "pos_ned_m", "vel_ned_m_s"):
        a, b = getattr(moved, name), getattr(fresh, name)
        if b is None:
            assert a is None
            continue
        assert a.tobytes() == b.tobytes(), name
        assert not a.flags.writeable
    assert moved.origin_lat_lon_h == fresh.origin_lat_lon_h
    assert moved.gaps() == fresh.gaps()
    assert type(moved) is Trajectory
    kept = traj.lat_lon_h if geodetic else traj.pos_ned_m
    assert kept is not None
    assert np.shares_memory(moved.vel_ned_m_s, traj.vel_ned_m_s)
    assert np.shares_memory(moved.lat_lon_h if geodetic else moved.pos_ned_m, kept)


def test_shifted_still_refuses_times_rounded_together() -> None:
    traj = Trajectory.from_euler(
        [0.0, 1e-9, 1.0], [0, 0, 0], [0, 0, 0], [0, 0, 0], lat_lon_h=np.zeros((3, 3))
    )
    with pytest.raises(InputError, match="repeated time in row 1"):
        traj.shifted(1e9)


@pytest.mark.parametrize("tau", [0.013, -0.021])
def test_corrected_for_latency_reads_record_t_plus_tau(tau: float) -> None:
    traj = _small_local()
    corrected = traj.corrected_for_latency(tau)
    assert_allclose(corrected.t_s, traj.t_s - tau, rtol=0, atol=1e-6)
    tq = T0 + np.array([0.1, 1.3, 2.5, 3.9])
    a = corrected.interpolate(tq)
    b = traj.interpolate(tq + tau)
    assert_allclose(_pos(a), _pos(b), atol=1e-9)
    assert_allclose(a.q_body_to_ned, b.q_body_to_ned, atol=1e-12)


def test_latency_correction_recovers_physical_attitude() -> None:
    # Navigation records lag the scanner by tau: the record tagged t holds the state of
    # t - tau (SPEC section 1). The corrected trajectory at t gives the state of t.
    tau = 0.023
    w = np.array([0.0, 0.0, math.radians(30.0)])
    t = T0 + 0.1 * np.arange(50.0)

    def truth(tt: FloatArray) -> Rotation:
        return Rotation.from_rotvec(np.outer(tt - T0, w))

    lagged = _local(t, np.zeros((50, 3)), q=_wxyz(truth(t - tau)))
    tq = T0 + np.linspace(0.5, 4.0, 50)
    corrected = lagged.corrected_for_latency(tau).interpolate(tq)
    assert float(np.max(_angle_between(truth(tq).as_matrix(), corrected.R_body_to_ned))) < 1e-10
    uncorrected = lagged.interpolate(tq)
    lag_err = _angle_between(truth(tq).as_matrix(), uncorrected.R_body_to_ned)
    assert_allclose(lag_err, tau * w[2], rtol=1e-6)


def test_sliced() -> None:
    t = T0 + np.arange(10.0)
    pos = np.outer(t - T0, [1.0, 0.0, 0.0])
    vel = np.tile([1.0, 0.0, 0.0], (10, 1))
    traj = _local(t, pos, vel=vel)
    part = traj.sliced(T0 + 2.0, T0 + 5.5)
    assert_array_equal(part.t_s, T0 + np.array([2.0, 3.0, 4.0, 5.0]))
    assert part.pos_ned_m is not None
    assert part.vel_ned_m_s is not None
    assert_array_equal(part.pos_ned_m[:, 0], [2.0, 3.0, 4.0, 5.0])
    assert part.vel_ned_m_s.shape == (4, 3)
    assert part.origin_lat_lon_h == ORIGIN
    assert part.duration_s == 3.0
    assert not part.t_s.flags.writeable
    with pytest.raises(InputError, match="fewer than 2"):
        traj.sliced(T0 + 2.5, T0 + 3.5)


# ---------------------------------------------------------------- construction checks


def _valid_arrays(n: int = 5) -> tuple[FloatArray, FloatArray, FloatArray]:
    t = T0 + np.arange(float(n))
    return t, _identity_q(n), np.zeros((n, 3))


def test_repeated_time_names_row() -> None:
    t, q, pos = _valid_arrays()
    t[3] = t[2]
    with pytest.raises(InputError, match=r"repeated.*row 3") as info:
        _local(t, pos, q=q)
    assert "np.float64" not in str(info.value)


def test_decreasing_time_names_row() -> None:
    t, q, pos = _valid_arrays()
    t[3] = t[2] - 0.5
    with pytest.raises(InputError, match=r"decreasing.*row 3"):
        _local(t, pos, q=q)


def test_decreasing_time_advises_sorting() -> None:
    t, q, pos = _valid_arrays()
    t[3] = t[2] - 0.5
    with pytest.raises(InputError, match="sort the records and drop duplicates"):
        _local(t, pos, q=q)


@pytest.mark.parametrize("week", [0, 2345], ids=["seconds-of-week", "continuous"])
def test_a_gps_week_rollover_is_named_and_sorting_is_not_advised(week: int) -> None:
    # Sorting a rolled-over file would put its end before its start.
    t, q, pos = _valid_arrays(6)
    t = week * 604_800.0 + np.array([604_798.0, 604_798.5, 604_799.0, 604_799.5, 0.0, 0.5])
    with pytest.raises(InputError) as info:
        _local(t, pos, q=q)
    message = str(info.value)
    assert "decreasing time in row 4" in message
    assert "the GPS week rolls over there" in message
    assert "counting past 604800 s" in message
    assert "sort" not in message


def test_a_jump_back_of_a_day_is_not_a_rollover() -> None:
    t, q, pos = _valid_arrays(4)
    t = np.array([200_000.0, 200_001.0, 113_600.0, 113_601.0])
    with pytest.raises(InputError, match="sort the records"):
        _local(t, pos, q=q)


def test_nan_time_names_row() -> None:
    t, q, pos = _valid_arrays()
    t[1] = math.nan
    with pytest.raises(InputError, match="row 1"):
        _local(t, pos, q=q)


def test_nan_position_names_row() -> None:
    t, q, pos = _valid_arrays()
    pos[2, 1] = math.nan
    with pytest.raises(InputError, match=r"pos_ned_m.*row 2"):
        _local(t, pos, q=q)
    llh = np.tile([46.8, 7.0, 500.0], (5, 1))
    llh[4, 2] = math.inf
    with pytest.raises(InputError, match=r"lat_lon_h.*row 4"):
        Trajectory(t_s=t, q_body_to_ned=q, lat_lon_h=llh)


def test_nan_quaternion_and_velocity_name_row() -> None:
    t, q, pos = _valid_arrays()
    q_bad = q.copy()
    q_bad[3, 2] = math.nan
    with pytest.raises(InputError, match=r"q_body_to_ned.*row 3"):
        _local(t, pos, q=q_bad)
    vel = np.zeros((5, 3))
    vel[0, 0] = math.nan
    with pytest.raises(InputError, match=r"vel_ned_m_s.*row 0"):
        _local(t, pos, q=q, vel=vel)


def test_non_unit_quaternion_names_row() -> None:
    t, q, pos = _valid_arrays()
    q[1] = [1.0, 0.0, 0.1, 0.0]
    with pytest.raises(InputError, match=r"row 1.*norm"):
        _local(t, pos, q=q)
    # Within the tolerance a quaternion is accepted and stored normalised.
    q[1] = [1.0 + 5e-7, 0.0, 0.0, 0.0]
    traj = _local(t, pos, q=q)
    assert_allclose(np.linalg.norm(traj.q_body_to_ned, axis=1), 1.0, atol=1e-15)


def test_latitude_out_of_range_names_row() -> None:
    t, q, _ = _valid_arrays()
    llh = np.tile([46.8, 7.0, 500.0], (5, 1))
    llh[2, 0] = 95.0
    with pytest.raises(InputError, match=r"latitude.*row 2"):
        Trajectory(t_s=t, q_body_to_ned=q, lat_lon_h=llh)
    with pytest.raises(InputError, match="latitude"):
        Trajectory(
            t_s=t, q_body_to_ned=q, pos_ned_m=np.zeros((5, 3)), origin_lat_lon_h=(95.0, 0.0, 0.0)
        )


@pytest.mark.parametrize("lon_deg", [400.0, 360.5, -180.5, -300.0])
def test_longitude_outside_every_convention_names_row(lon_deg: float) -> None:
    """A longitude of 400 deg (or -300) was accepted and georeferenced as if it were 40."""
    t, q, _ = _valid_arrays()
    llh = np.tile([46.8, 7.0, 500.0], (5, 1))
    llh[3, 1] = lon_deg
    with pytest.raises(
        InputError,
        match=rf"^trajectory lat_lon_h: longitude {lon_deg} outside \[-180, 360\] in row 3: "
        r"give longitudes in degrees, from -180 to 180 \(east positive\) or from 0 to 360$",
    ):
        Trajectory(t_s=t, q_body_to_ned=q, lat_lon_h=llh)
    with pytest.raises(InputError, match=r"^trajectory origin_lat_lon_h: longitude .* row 0"):
        Trajectory(
            t_s=t, q_body_to_ned=q, pos_ned_m=np.zeros((5, 3)), origin_lat_lon_h=(46.8, lon_deg, 0)
        )


def test_longitudes_from_0_to_360_are_those_from_minus_180_to_180() -> None:
    """-180 to 180 and 0 to 360 (both ends included) give the same positions."""
    t, q, _ = _valid_arrays()
    west = np.tile([46.8, -71.2, 50.0], (5, 1))
    west[:, 1] += 0.001 * np.arange(5)
    east = west.copy()
    east[:, 1] += 360.0  # 288.8 deg
    a = Trajectory(t_s=t, q_body_to_ned=q, lat_lon_h=west).interpolate(t[:-1] + 0.5)
    b = Trajectory(t_s=t, q_body_to_ned=q, lat_lon_h=east).interpolate(t[:-1] + 0.5)
    assert_allclose(b.pos_ecef_m(), a.pos_ecef_m(), rtol=0.0, atol=1e-6)
    for ends in ([-180.0, -179.9], [359.9, 360.0]):
        llh = np.tile([46.8, 0.0, 50.0], (2, 1))
        llh[:, 1] = ends
        kept = Trajectory(t_s=t[:2], q_body_to_ned=q[:2], lat_lon_h=llh).lat_lon_h
        assert kept is not None
        assert kept[1, 1] == ends[1]


def test_mismatched_lengths() -> None:
    t, q, pos = _valid_arrays()
    with pytest.raises(InputError, match=r"q_body_to_ned.*\(5, 4\)"):
        _local(t, pos, q=q[:4])
    with pytest.raises(InputError, match=r"pos_ned_m.*\(5, 3\)"):
        _local(t, pos[:4], q=q)
    with pytest.raises(InputError, match=r"vel_ned_m_s.*\(5, 3\)"):
        _local(t, pos, q=q, vel=np.zeros((6, 3)))
    with pytest.raises(InputError, match="lat_lon_h"):
        Trajectory(t_s=t, q_body_to_ned=q, lat_lon_h=np.zeros((5, 2)))


def test_position_kind_must_be_exactly_one() -> None:
    t, q, pos = _valid_arrays()
    llh = np.tile([46.8, 7.0, 500.0], (5, 1))
    with pytest.raises(InputError, match="exactly one"):
        Trajectory(t_s=t, q_body_to_ned=q)
    with pytest.raises(InputError, match="exactly one"):
        Trajectory(t_s=t, q_body_to_ned=q, lat_lon_h=llh, pos_ned_m=pos, origin_lat_lon_h=ORIGIN)
    with pytest.raises(InputError, match="origin_lat_lon_h"):
        Trajectory(t_s=t, q_body_to_ned=q, pos_ned_m=pos)
    with pytest.raises(InputError, match="origin_lat_lon_h"):
        Trajectory(t_s=t, q_body_to_ned=q, lat_lon_h=llh, origin_lat_lon_h=ORIGIN)


def test_fewer_than_two_rows() -> None:
    with pytest.raises(InputError, match="at least 2"):
        Trajectory(
            t_s=np.array([T0]),
            q_body_to_ned=_identity_q(1),
            pos_ned_m=np.zeros((1, 3)),
            origin_lat_lon_h=ORIGIN,
        )
    with pytest.raises(InputError, match="at least 2"):
        Trajectory(
            t_s=np.array([]),
            q_body_to_ned=np.zeros((0, 4)),
            pos_ned_m=np.zeros((0, 3)),
            origin_lat_lon_h=ORIGIN,
        )


def test_arrays_are_read_only_copies() -> None:
    t, q, pos = _valid_arrays()
    vel = np.zeros((5, 3))
    traj = _local(t, pos, q=q, vel=vel)
    assert traj.pos_ned_m is not None
    assert traj.vel_ned_m_s is not None
    for arr in (traj.t_s, traj.q_body_to_ned, traj.pos_ned_m, traj.vel_ned_m_s):
        assert not arr.flags.writeable
        with pytest.raises(ValueError, match="read-only"):
            arr[0] = 1.0
    # Changing the caller's arrays afterwards does not change the trajectory.
    t[0] = T0 - 100.0
    pos[0, 0] = 99.0
    q[0] = [0.0, 1.0, 0.0, 0.0]
    assert traj.t_s[0] == T0
    assert traj.pos_ned_m[0, 0] == 0.0
    assert_array_equal(traj.q_body_to_ned[0], IDENTITY_Q)
    with pytest.raises(dataclasses.FrozenInstanceError):
        traj.t_s = t  # type: ignore[misc]
    geo = Trajectory(t_s=t[1:], q_body_to_ned=q[1:], lat_lon_h=np.tile([46.8, 7.0, 500.0], (4, 1)))
    assert geo.lat_lon_h is not None
    assert not geo.lat_lon_h.flags.writeable


# ------------------------------------------------------------------ time and angle types
def _gps_line(n: int = 100) -> tuple[FloatArray, FloatArray, FloatArray]:
    t: FloatArray = 1.4e9 + 0.1 * np.arange(n, dtype=np.float64)
    llh: FloatArray = np.column_stack(
        [46.8 + 1e-5 * (t - t[0]), np.full(n, -71.2), np.full(n, 30.0)]
    )
    return t, np.zeros(n), llh


def test_float32_gps_times_are_refused_with_their_step() -> None:
    """float32 holds 128 s steps near 1.4e9 s: interpolate sampled 28 s away, and the
    constructor spoke of a repeated time only."""
    t, z, llh = _gps_line()
    with pytest.raises(InputError, match=r"t_s: float32 times near 1\.4e\+09 s .* steps of 128 s"):
        Trajectory.from_euler(t.astype(np.float32), z, z, z, lat_lon_h=llh)
    with pytest.raises(InputError, match=r"trajectory t_s: float32 .*pass float64 times"):
        Trajectory(t_s=t.astype(np.float32), q_body_to_ned=_identity_q(t.size), lat_lon_h=llh)
    traj = Trajectory.from_euler(t, z, z, z, lat_lon_h=llh)
    with pytest.raises(InputError, match=r"interpolation times t_s: float32 .*128 s"):
        traj.interpolate(t[3:5].astype(np.float32))
    with pytest.raises(InputError, match=r"float16"):
        traj.contains(np.array([1.0], dtype=np.float16) * 100)
    # float32 fine enough where the times are small (a step below 1 us up to 16 s)
    local = Trajectory.from_euler(
        np.arange(10, dtype=np.float32),
        np.zeros(10),
        np.zeros(10),
        np.zeros(10),
        pos_ned_m=np.zeros((10, 3)),
        origin_lat_lon_h=ORIGIN,
    )
    assert local.t_s.dtype == np.float64


@pytest.mark.parametrize(
    ("times", "fragment"),
    [
        (np.datetime64("2024-01-01") + np.arange(100).astype("timedelta64[ms]"), "datetime64"),
        (np.arange(100).astype("timedelta64[s]"), "timedelta64"),
        (np.array(["a"] * 100), "text"),
        (np.arange(100.0).astype(object), "Python object"),
    ],
)
def test_times_that_are_not_float_seconds_are_refused(times: object, fragment: str) -> None:
    """datetime64[ms] was read as ms since 1970 taken for seconds; text raised a raw
    ValueError."""
    t, z, llh = _gps_line()
    with pytest.raises(InputError, match=rf"trajectory t_s: expected .*{fragment}.*1980-01-06"):
        Trajectory.from_euler(times, z, z, z, lat_lon_h=llh)  # type: ignore[arg-type]
    traj = Trajectory.from_euler(t, z, z, z, lat_lon_h=llh)
    with pytest.raises(InputError, match=rf"interpolation times t_s: .*{fragment}"):
        traj.interpolate(times[:2])  # type: ignore[index]


@pytest.mark.parametrize(
    ("roll", "shape"),
    [(np.zeros(99), "(99,)"), (np.zeros((100, 1)), "(100, 1)"), (0.0, "()")],
)
def test_euler_angles_of_another_shape_are_named(roll: object, shape: str) -> None:
    """Length N-1 raised numpy's broadcast error; (N, 1) spoke of a q_body_to_ned the
    caller never gave."""
    t, z, llh = _gps_line()
    with pytest.raises(
        InputError, match=rf"roll_rad: expected shape \(100,\) .* got {re.escape(shape)}"
    ):
        Trajectory.from_euler(t, roll, z, z, lat_lon_h=llh)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("which", "value", "fragment"),
    [
        (1, 30.0, r"pitch_rad: 30 rad in row 0 is beyond \+-pi/2 .*30 deg = 0\.523599 rad"),
        (1, -1.6, r"pitch_rad: -1\.6 rad in row 0 is beyond \+-pi/2"),
        (0, 45.0, r"roll_rad: 45 rad in row 0 is beyond \+-2 pi .*wrap_angle_rad"),
        (2, 1000.0, r"yaw_rad: 1000 rad in row 0 is beyond \+-2 pi .*wrap_angle_rad"),
    ],
)
def test_euler_angles_in_degrees_are_refused_naming_the_argument(
    which: int, value: float, fragment: str
) -> None:
    """A pitch of 30 (degrees, given for radians) built a trajectory 1719 deg nose-up
    and georeference returned points: the command line refuses such angles, the API
    took them."""
    t, z, llh = _gps_line()
    rpy = [z, z, z]
    rpy[which] = np.full(t.size, value)
    with pytest.raises(InputError, match=fragment):
        Trajectory.from_euler(t, *rpy, lat_lon_h=llh)
    # The limits themselves are attitudes: pitch +-90 deg, roll and yaw +-360 deg.
    edge = np.radians([360.0, 90.0, -360.0])
    traj = Trajectory.from_euler(t, *(np.full(t.size, a) for a in edge), lat_lon_h=llh)
    assert len(traj) == t.size


def test_float32_geodetic_positions_are_refused_naming_the_argument() -> None:
    """float32 holds latitudes near 47 deg in steps of 3.8e-6 deg (0.4 m): the
    interpolated ECEF positions were 0.28 m off, silently (float32 ECEF was refused)."""
    t, z, llh = _gps_line()
    fragment = r"trajectory lat_lon_h \(latitude, longitude\): float32 degrees near 71\.2 deg"
    with pytest.raises(InputError, match=rf"{fragment}.*pass float64"):
        Trajectory.from_euler(t, z, z, z, lat_lon_h=llh.astype(np.float32))
    with pytest.raises(InputError, match=rf"{fragment}.*pass float64"):
        Trajectory(t_s=t, q_body_to_ned=_identity_q(t.size), lat_lon_h=llh.astype(np.float32))
    # float32 holds degrees near the null meridian on the equator finely, not 5 km heights
    high = np.column_stack([llh[:, :2] * 1e-5, np.full(t.size, 5000.0)]).astype(np.float32)
    with pytest.raises(InputError, match=r"lat_lon_h \(height\): float32 .*near 5000 m"):
        Trajectory.from_euler(t, z, z, z, lat_lon_h=high)
    ned = np.full((t.size, 3), 5000.0, dtype=np.float32)  # 0.5 mm steps
    with pytest.raises(InputError, match=r"trajectory pos_ned_m: float32 coordinates"):
        Trajectory.from_euler(t, z, z, z, pos_ned_m=ned, origin_lat_lon_h=ORIGIN)
    # float32 holds a position close to the origin finely enough
    local = Trajectory.from_euler(
        t, z, z, z, pos_ned_m=ned * np.float32(0.01), origin_lat_lon_h=ORIGIN
    )
    assert local.pos_ned_m is not None
    assert local.pos_ned_m.dtype == np.float64


def test_float16_euler_angles_are_refused_naming_the_argument() -> None:
    """float16 holds a yaw near 2 rad in steps of 2e-3 rad: the trajectory was built
    4.8e-4 rad off although ANGLE_STEP_RAD (1 urad) calls float16 too coarse."""
    t, z, llh = _gps_line()
    yaw = np.linspace(1.0, 2.0, t.size)
    with pytest.raises(InputError, match=r"trajectory yaw_rad: float16 angles .*pass float64"):
        Trajectory.from_euler(t, z, z, yaw.astype(np.float16), lat_lon_h=llh)
    traj = Trajectory.from_euler(t, z, z, yaw.astype(np.float32), lat_lon_h=llh)  # 1.2e-7 rad
    assert_allclose(traj.euler_rpy_rad()[:, 2], yaw, atol=1e-6)


def test_an_interpolated_sample_owns_its_times() -> None:
    """The sample kept the caller's array of times: writing to it changed the sample."""
    t, z, llh = _gps_line()
    traj = Trajectory.from_euler(t, z, z, z, lat_lon_h=llh)
    wanted = t[3:6] + 0.05
    sample = traj.interpolate(wanted)
    wanted[0] = 0.0
    assert sample.t_s[0] == t[3] + 0.05
    for arr in (sample.t_s, sample.inside):
        assert not arr.flags.writeable


@pytest.mark.parametrize("latency_s", [1e300, -11.0, math.inf, math.nan])
def test_an_absurd_latency_is_named_not_taken_for_repeated_times(latency_s: float) -> None:
    # 1e300 gave "repeated time in row 1" (every time shifted to -1e300).
    t = np.arange(10, dtype=np.float64) * 0.1 + 1.4e9
    q = np.tile([1.0, 0.0, 0.0, 0.0], (10, 1))
    tr = Trajectory(t, q, lat_lon_h=np.tile([46.8, -71.2, 10.0], (10, 1)))
    with pytest.raises(InputError, match=r"^latency_s"):
        tr.corrected_for_latency(latency_s)
    assert tr.corrected_for_latency(-10.0).t_s[0] == t[0] + 10.0


def test_complex_or_boolean_times_are_refused() -> None:
    q = np.tile([1.0, 0.0, 0.0, 0.0], (2, 1))
    llh = np.tile([46.8, -71.2, 10.0], (2, 1))
    for t, kind in (
        (np.array([1.4e9, 1.4e9 + 1]) + 1j, "complex"),
        (np.array([False, True]), "boolean"),
    ):
        with pytest.raises(InputError, match=rf"^trajectory t_s: expected numbers, got {kind}"):
            Trajectory(t, q, lat_lon_h=llh)  # type: ignore[arg-type]
