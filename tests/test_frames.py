"""Tests of kinsync.frames: Euler/matrix/quaternion, NED/ECEF, geodetic, vehicle frame."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import numpy.typing as npt
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose, assert_array_equal
from pyproj import Transformer
from scipy.spatial.transform import Rotation

from kinsync.errors import InputError
from kinsync.frames import (
    WGS84_A_M,
    WGS84_B_M,
    body_to_vehicle,
    ecef_to_geodetic,
    ecef_to_ned,
    euler_rpy_to_matrix,
    euler_rpy_to_quaternion,
    geodetic_to_ecef,
    longitude_span_deg,
    matrix_to_euler_rpy,
    matrix_to_quaternion,
    mean_longitude_deg,
    ned_to_ecef,
    ned_to_vehicle,
    quaternion_ned_to_ecef,
    quaternion_to_euler_rpy,
    quaternion_to_matrix,
    rot_x,
    rot_y,
    rot_z,
    rotation_ned_to_ecef,
    skew,
    vehicle_to_body,
)

FloatArray = npt.NDArray[np.float64]

HALF_PI = math.pi / 2
PITCH_MARGIN = 1e-3
"""Stay this far (rad) from +-90 deg pitch where Euler angles are recovered."""
REPRODUCTION_ATOL = 1e-9
"""matrix -> Euler -> matrix bound at every pitch, gimbal lock included (Shoemake's form)."""

angles = st.floats(min_value=-math.pi, max_value=math.pi, allow_nan=False)
pitches = st.floats(
    min_value=-HALF_PI + PITCH_MARGIN, max_value=HALF_PI - PITCH_MARGIN, allow_nan=False
)
unit_floats = st.floats(min_value=-1.0, max_value=1.0, allow_nan=False)
vectors = st.tuples(
    st.floats(min_value=-1e4, max_value=1e4, allow_nan=False),
    st.floats(min_value=-1e4, max_value=1e4, allow_nan=False),
    st.floats(min_value=-1e4, max_value=1e4, allow_nan=False),
)
latitudes = st.floats(min_value=-89.9, max_value=89.9, allow_nan=False)
longitudes = st.floats(min_value=-180.0, max_value=180.0, exclude_max=True, allow_nan=False)
heights = st.floats(min_value=-500.0, max_value=1e5, allow_nan=False)


@st.composite
def unit_quaternions(draw: st.DrawFn) -> FloatArray:
    """Scalar-first unit quaternions of any sign, drawn away from the zero vector."""
    q = np.array([draw(unit_floats) for _ in range(4)])
    n = float(np.linalg.norm(q))
    if n < 0.1:
        q = np.array([1.0, 0.0, 0.0, 0.0]) + q
        n = float(np.linalg.norm(q))
    return q / n


def _wrap_rad(a: FloatArray | float) -> FloatArray:
    """Wrap angles (rad) into [-pi, pi)."""
    return np.asarray((np.asarray(a) + math.pi) % (2 * math.pi) - math.pi, dtype=np.float64)


def _assert_same_angles(actual: FloatArray, expected: FloatArray, atol: float) -> None:
    assert_allclose(_wrap_rad(np.asarray(actual) - np.asarray(expected)), 0.0, atol=atol)


def _assert_rotation(R: FloatArray, atol: float = 1e-12) -> None:
    """Orthonormal with determinant +1, for a stack of matrices."""
    eye = np.broadcast_to(np.eye(3), R.shape)
    assert_allclose(np.swapaxes(R, -1, -2) @ R, eye, atol=atol)
    assert_allclose(np.linalg.det(R), 1.0, atol=atol)


def _reproduction_atol(R: FloatArray) -> float:
    """Tolerance of matrix -> Euler -> matrix: the same tight bound at every pitch."""
    del R
    return REPRODUCTION_ATOL


def _assert_same_quaternion(actual: FloatArray, expected: FloatArray, atol: float) -> None:
    """Equal up to the sign of the whole quaternion (q and -q are one rotation)."""
    sign = 1.0 if float(np.dot(actual, expected)) >= 0.0 else -1.0
    assert_allclose(actual, sign * expected, atol=atol)


# ---------------------------------------------------------------- elementary rotations


def test_elementary_rotations_are_right_handed() -> None:
    ex, ey, ez = np.eye(3)
    assert_allclose(rot_z(HALF_PI) @ ex, ey, atol=1e-15)
    assert_allclose(rot_x(HALF_PI) @ ey, ez, atol=1e-15)
    assert_allclose(rot_y(HALF_PI) @ ez, ex, atol=1e-15)
    assert_allclose(rot_z(0.0), np.eye(3), atol=0)


@settings(max_examples=100, deadline=None)
@given(angle=st.floats(min_value=-10.0, max_value=10.0, allow_nan=False))
def test_elementary_rotations_are_proper(angle: float) -> None:
    for rot in (rot_x, rot_y, rot_z):
        _assert_rotation(rot(angle))


@settings(max_examples=200, deadline=None)
@given(a=vectors, b=vectors)
def test_skew_is_cross_product(
    a: tuple[float, float, float], b: tuple[float, float, float]
) -> None:
    S = skew(a)
    assert_allclose(S @ np.array(b), np.cross(a, b), rtol=1e-12, atol=1e-6)
    assert_allclose(S, -S.T, atol=0)


def test_skew_vectorised() -> None:
    rng = np.random.default_rng(1)
    a = rng.normal(size=(4, 5, 3))
    b = rng.normal(size=(4, 5, 3))
    S = skew(a)
    assert S.shape == (4, 5, 3, 3)
    assert_allclose(np.einsum("...ij,...j->...i", S, b), np.cross(a, b), atol=1e-14)


# ---------------------------------------------------------------- Euler angles


def test_known_attitudes_din9300() -> None:
    deg90 = HALF_PI
    forward, right, _down = np.eye(3)
    # Yaw 90 deg (heading East): the nose points East.
    assert_allclose(euler_rpy_to_matrix(0.0, 0.0, deg90) @ forward, [0, 1, 0], atol=1e-15)
    # Pitch +90 deg: the nose points Up, i.e. NED (0, 0, -1).
    assert_allclose(euler_rpy_to_matrix(0.0, deg90, 0.0) @ forward, [0, 0, -1], atol=1e-15)
    # Roll +90 deg (right wing down): the right axis points Down.
    assert_allclose(euler_rpy_to_matrix(deg90, 0.0, 0.0) @ right, [0, 0, 1], atol=1e-15)
    assert_allclose(euler_rpy_to_matrix(0.0, 0.0, 0.0), np.eye(3), atol=0)


@settings(max_examples=200, deadline=None)
@given(roll=angles, pitch=angles, yaw=angles)
def test_euler_matrix_is_yaw_pitch_roll_product(roll: float, pitch: float, yaw: float) -> None:
    R = euler_rpy_to_matrix(roll, pitch, yaw)
    assert R.shape == (3, 3)
    assert_allclose(R, rot_z(yaw) @ rot_y(pitch) @ rot_x(roll), atol=1e-14)
    _assert_rotation(R)


@settings(max_examples=200, deadline=None)
@given(roll=angles, pitch=angles, yaw=angles)
def test_euler_quaternion_gives_same_matrix(roll: float, pitch: float, yaw: float) -> None:
    q = euler_rpy_to_quaternion(roll, pitch, yaw)
    assert q.shape == (4,)
    assert_allclose(np.linalg.norm(q), 1.0, atol=1e-14)
    assert q[0] >= 0.0
    assert_allclose(quaternion_to_matrix(q), euler_rpy_to_matrix(roll, pitch, yaw), atol=1e-14)
    _assert_rotation(quaternion_to_matrix(q))


@settings(max_examples=200, deadline=None)
@given(roll=angles, pitch=pitches, yaw=angles)
def test_euler_matrix_euler_round_trip(roll: float, pitch: float, yaw: float) -> None:
    rpy = matrix_to_euler_rpy(euler_rpy_to_matrix(roll, pitch, yaw))
    assert rpy.shape == (3,)
    _assert_same_angles(rpy, np.array([roll, pitch, yaw]), atol=1e-9)
    assert np.all(np.abs(rpy) <= math.pi)
    assert abs(rpy[1]) <= HALF_PI


@settings(max_examples=200, deadline=None)
@given(roll=angles, pitch=pitches, yaw=angles)
def test_euler_quaternion_euler_round_trip(roll: float, pitch: float, yaw: float) -> None:
    rpy = quaternion_to_euler_rpy(euler_rpy_to_quaternion(roll, pitch, yaw))
    _assert_same_angles(rpy, np.array([roll, pitch, yaw]), atol=1e-9)


@settings(max_examples=200, deadline=None)
@given(q=unit_quaternions())
def test_quaternion_matrix_quaternion_round_trip(q: FloatArray) -> None:
    R = quaternion_to_matrix(q)
    _assert_rotation(R)
    # Independent reference: scipy (scalar-last).
    assert_allclose(R, Rotation.from_quat(q[[1, 2, 3, 0]]).as_matrix(), atol=1e-14)
    q_back = matrix_to_quaternion(R)
    assert q_back.shape == (4,)
    assert q_back[0] >= 0.0
    assert_allclose(np.linalg.norm(q_back), 1.0, atol=1e-14)
    _assert_same_quaternion(q_back, q, atol=1e-12)


@settings(max_examples=200, deadline=None)
@given(q=unit_quaternions())
def test_matrix_quaternion_matrix_and_euler_reproduce_matrix(q: FloatArray) -> None:
    R = Rotation.from_quat(q[[1, 2, 3, 0]]).as_matrix()
    assert_allclose(quaternion_to_matrix(matrix_to_quaternion(R)), R, atol=1e-13)
    # Any proper rotation, gimbal lock included, survives matrix -> Euler -> matrix.
    rpy = matrix_to_euler_rpy(R)
    assert_allclose(euler_rpy_to_matrix(*rpy), R, atol=_reproduction_atol(R))


@settings(max_examples=200, deadline=None)
@given(roll=angles, yaw=angles, sign=st.sampled_from([-1.0, 1.0]))
def test_gimbal_lock_reproduces_matrix(roll: float, yaw: float, sign: float) -> None:
    R = euler_rpy_to_matrix(roll, sign * HALF_PI, yaw)
    rpy = matrix_to_euler_rpy(R)
    assert np.all(np.isfinite(rpy))
    assert rpy[0] == 0.0  # roll is set to zero at gimbal lock
    assert_allclose(rpy[1], sign * HALF_PI, atol=1e-15)
    assert_allclose(euler_rpy_to_matrix(*rpy), R, atol=1e-12)
    R_from_q = quaternion_to_matrix(euler_rpy_to_quaternion(*rpy))
    assert_allclose(R_from_q, R, atol=1e-12)


@settings(max_examples=200, deadline=None)
@given(
    roll=angles,
    yaw=angles,
    sign=st.sampled_from([-1.0, 1.0]),
    offset=st.floats(min_value=0.0, max_value=PITCH_MARGIN, allow_nan=False),
)
@example(roll=2.0, yaw=1.0, sign=-1.0, offset=1e-6)  # inside the lock window
@example(roll=-2.5, yaw=0.7, sign=1.0, offset=1.4e-6)  # at its edge
@example(roll=-2.5, yaw=0.7, sign=1.0, offset=1.5e-6)  # just outside
@example(roll=0.3, yaw=-3.0, sign=1.0, offset=1e-9)
def test_near_gimbal_lock_reproduces_matrix(
    roll: float, yaw: float, sign: float, offset: float
) -> None:
    # Euler angles are ill-conditioned here, but the rotation itself must survive.
    R = euler_rpy_to_matrix(roll, sign * (HALF_PI - offset), yaw)
    rpy = matrix_to_euler_rpy(R)
    assert_allclose(euler_rpy_to_matrix(*rpy), R, atol=_reproduction_atol(R))


def test_rotations_vectorised_shapes() -> None:
    rng = np.random.default_rng(2)
    roll = rng.uniform(-math.pi, math.pi, size=(4, 1))
    pitch = rng.uniform(-1.4, 1.4, size=(1, 5))
    yaw = rng.uniform(-math.pi, math.pi, size=(4, 5))
    R = euler_rpy_to_matrix(roll, pitch, yaw)
    assert R.shape == (4, 5, 3, 3)
    _assert_rotation(R)
    assert_allclose(R[2, 3], euler_rpy_to_matrix(roll[2, 0], pitch[0, 3], yaw[2, 3]), atol=0)
    assert_allclose(R, rot_z(yaw) @ rot_y(pitch) @ rot_x(roll), atol=1e-14)
    assert rot_x(yaw).shape == (4, 5, 3, 3)

    q = euler_rpy_to_quaternion(roll, pitch, yaw)
    assert q.shape == (4, 5, 4)
    assert_allclose(quaternion_to_matrix(q), R, atol=1e-14)

    q_back = matrix_to_quaternion(R)
    assert q_back.shape == (4, 5, 4)
    assert_allclose(q_back, q, atol=1e-12)  # both have w >= 0, so equal

    rpy = matrix_to_euler_rpy(R)
    assert rpy.shape == (4, 5, 3)
    expected = np.stack(np.broadcast_arrays(roll, pitch, yaw), axis=-1)
    _assert_same_angles(rpy, expected, atol=1e-10)
    assert quaternion_to_euler_rpy(q).shape == (4, 5, 3)

    # A stack containing one gimbal-lock matrix among ordinary ones.
    stack = np.stack([R[0, 0], euler_rpy_to_matrix(0.3, HALF_PI, 0.5), R[1, 1]])
    rpy_stack = matrix_to_euler_rpy(stack)
    assert_allclose(euler_rpy_to_matrix(*rpy_stack.T), stack, atol=1e-12)
    _assert_same_angles(rpy_stack[0], rpy[0, 0], atol=1e-10)


# ---------------------------------------------------------------- NED <-> ECEF rotation


def test_rotation_ned_to_ecef_known_at_origin() -> None:
    R = rotation_ned_to_ecef(0.0, 0.0)
    north, east, down = R[:, 0], R[:, 1], R[:, 2]
    assert_allclose(north, [0, 0, 1], atol=1e-15)
    assert_allclose(east, [0, 1, 0], atol=1e-15)
    assert_allclose(down, [-1, 0, 0], atol=1e-15)
    # At the north pole on the Greenwich meridian North points to -X and Down to -Z.
    R_pole = rotation_ned_to_ecef(90.0, 0.0)
    assert_allclose(R_pole[:, 0], [-1, 0, 0], atol=1e-15)
    assert_allclose(R_pole[:, 2], [0, 0, -1], atol=1e-15)


@settings(max_examples=200, deadline=None)
@given(lat=st.floats(min_value=-90.0, max_value=90.0, allow_nan=False), lon=longitudes)
def test_rotation_ned_to_ecef_is_proper(lat: float, lon: float) -> None:
    _assert_rotation(rotation_ned_to_ecef(lat, lon), atol=1e-14)


@settings(max_examples=200, deadline=None)
@given(lat=st.floats(min_value=-90.0, max_value=90.0, allow_nan=False), lon=longitudes)
def test_quaternion_ned_to_ecef_is_the_rotation_matrix(lat: float, lon: float) -> None:
    q = quaternion_ned_to_ecef(lat, lon)
    assert_allclose(np.linalg.norm(q), 1.0, atol=1e-15)
    assert_allclose(quaternion_to_matrix(q), rotation_ned_to_ecef(lat, lon), atol=2e-15)


def test_rotation_ned_to_ecef_vectorised() -> None:
    rng = np.random.default_rng(3)
    lat = rng.uniform(-90, 90, size=(6, 1))
    lon = rng.uniform(-180, 180, size=(1, 7))
    R = rotation_ned_to_ecef(lat, lon)
    assert R.shape == (6, 7, 3, 3)
    _assert_rotation(R, atol=1e-14)
    assert_allclose(R[4, 2], rotation_ned_to_ecef(lat[4, 0], lon[0, 2]), atol=0)


_PYPROJ_LLH_TO_ECEF = Transformer.from_crs("EPSG:4979", "EPSG:4978", always_xy=True)


def _pyproj_ecef(lat: float, lon: float, h: float) -> FloatArray:
    x, y, z = _PYPROJ_LLH_TO_ECEF.transform(lon, lat, h)
    return np.array([x, y, z], dtype=np.float64)


def _unit(v: FloatArray) -> FloatArray:
    return v / np.linalg.norm(v)


@settings(max_examples=100, deadline=None)
@given(
    lat=st.floats(min_value=-89.0, max_value=89.0, allow_nan=False),
    lon=longitudes,
    h=st.floats(min_value=-500.0, max_value=1e4, allow_nan=False),
)
def test_rotation_ned_to_ecef_matches_pyproj_differences(lat: float, lon: float, h: float) -> None:
    R = rotation_ned_to_ecef(lat, lon)
    d_deg = 1e-6
    north = _unit(_pyproj_ecef(lat + d_deg, lon, h) - _pyproj_ecef(lat - d_deg, lon, h))
    east = _unit(_pyproj_ecef(lat, lon + d_deg, h) - _pyproj_ecef(lat, lon - d_deg, h))
    down = _unit(_pyproj_ecef(lat, lon, h - 1.0) - _pyproj_ecef(lat, lon, h + 1.0))
    assert_allclose(R[:, 0], north, atol=1e-6)
    assert_allclose(R[:, 1], east, atol=1e-6)
    assert_allclose(R[:, 2], down, atol=1e-6)
    # Also against the module's own geodetic_to_ecef (one-sided step as in the spec).
    p0 = geodetic_to_ecef(lat, lon, h)
    assert_allclose(_unit(geodetic_to_ecef(lat + d_deg, lon, h) - p0), R[:, 0], atol=1e-6)
    assert_allclose(_unit(geodetic_to_ecef(lat, lon + d_deg, h) - p0), R[:, 1], atol=1e-6)
    assert_allclose(_unit(p0 - geodetic_to_ecef(lat, lon, h + 1e-3)), R[:, 2], atol=1e-6)


# ---------------------------------------------------------------- geodetic <-> ECEF


def test_geodetic_to_ecef_known_values() -> None:
    assert_allclose(geodetic_to_ecef(0.0, 0.0, 0.0), [6378137.0, 0.0, 0.0], rtol=0, atol=1e-6)
    assert_allclose(geodetic_to_ecef(90.0, 0.0, 0.0), [0.0, 0.0, 6356752.314245], rtol=0, atol=1e-6)
    assert_allclose(
        geodetic_to_ecef(-90.0, 0.0, 0.0), [0.0, 0.0, -6356752.314245], rtol=0, atol=1e-6
    )
    assert_allclose(geodetic_to_ecef(0.0, 90.0, 100.0), [0.0, 6378237.0, 0.0], rtol=0, atol=1e-6)
    assert_allclose(geodetic_to_ecef(0.0, 180.0, 0.0), [-6378137.0, 0.0, 0.0], rtol=0, atol=1e-6)
    assert WGS84_A_M == 6378137.0
    assert_allclose(WGS84_B_M, 6356752.314245, atol=1e-6)
    assert_allclose(ecef_to_geodetic([6378137.0, 0.0, 0.0]), [0.0, 0.0, 0.0], atol=1e-9)
    llh_pole = ecef_to_geodetic([0.0, 0.0, 6356752.314245 + 10.0])
    assert_allclose(llh_pole[[0, 2]], [90.0, 10.0], atol=1e-9)


@settings(max_examples=200, deadline=None)
@given(lat=latitudes, lon=longitudes, h=heights)
def test_geodetic_ecef_round_trip(lat: float, lon: float, h: float) -> None:
    p = geodetic_to_ecef(lat, lon, h)
    assert p.shape == (3,)
    llh = ecef_to_geodetic(p)
    assert llh.shape == (3,)
    assert_allclose(llh[0], lat, atol=1e-8)
    assert_allclose(_wrap_deg(llh[1] - lon), 0.0, atol=1e-8)
    assert_allclose(llh[2], h, atol=1e-5)
    # PROJ's closed-form inverse alone loses ~1 um of height at 9 km; refined, the
    # round trip is at the floating-point floor
    back = geodetic_to_ecef(llh[0], llh[1], llh[2])
    assert_allclose(back, p, rtol=0, atol=2e-8)


def _wrap_deg(a: float | FloatArray) -> FloatArray:
    return np.asarray((np.asarray(a) + 180.0) % 360.0 - 180.0, dtype=np.float64)


def test_geodetic_ecef_vectorised() -> None:
    rng = np.random.default_rng(4)
    lat = rng.uniform(-89.9, 89.9, size=(3, 4))
    lon = rng.uniform(-180, 180, size=(3, 4))
    h = rng.uniform(-500, 1e5, size=(3, 4))
    p = geodetic_to_ecef(lat, lon, h)
    assert p.shape == (3, 4, 3)
    assert_allclose(p[1, 2], geodetic_to_ecef(lat[1, 2], lon[1, 2], h[1, 2]), atol=0)
    llh = ecef_to_geodetic(p)
    assert llh.shape == (3, 4, 3)
    assert_allclose(llh[..., 0], lat, atol=1e-8)
    assert_allclose(_wrap_deg(llh[..., 1] - lon), 0.0, atol=1e-8)
    assert_allclose(llh[..., 2], h, atol=1e-5)


@settings(max_examples=100, deadline=None)
@given(
    lat=latitudes,
    lon=longitudes,
    h=heights,
    ned=st.tuples(
        st.floats(min_value=-5e4, max_value=5e4, allow_nan=False),
        st.floats(min_value=-5e4, max_value=5e4, allow_nan=False),
        st.floats(min_value=-5e3, max_value=5e3, allow_nan=False),
    ),
)
def test_ned_ecef_round_trip(
    lat: float, lon: float, h: float, ned: tuple[float, float, float]
) -> None:
    p = ned_to_ecef(ned, lat, lon, h)
    assert p.shape == (3,)
    assert_allclose(ecef_to_ned(p, lat, lon, h), ned, atol=1e-6)
    # The origin itself maps to the origin's ECEF position.
    assert_allclose(ned_to_ecef([0.0, 0.0, 0.0], lat, lon, h), geodetic_to_ecef(lat, lon, h))


def test_ned_ecef_local_geometry() -> None:
    lat, lon, h = 46.8, 7.15, 550.0
    # Up along the ellipsoid normal changes only the height.
    llh = ecef_to_geodetic(ned_to_ecef([0.0, 0.0, -25.0], lat, lon, h))
    assert_allclose(llh, [lat, lon, h + 25.0], atol=1e-8)
    # A small step North increases latitude only (to first order), by d / (M + h).
    e2 = (2.0 - 1.0 / 298.257223563) / 298.257223563
    w = math.sqrt(1.0 - e2 * math.sin(math.radians(lat)) ** 2)
    M = WGS84_A_M * (1.0 - e2) / w**3
    llh_n = ecef_to_geodetic(ned_to_ecef([1.0, 0.0, 0.0], lat, lon, h))
    assert_allclose(llh_n[0] - lat, math.degrees(1.0 / (M + h)), rtol=1e-6)
    assert_allclose(llh_n[1], lon, atol=1e-12)
    # Vectorised over points.
    rng = np.random.default_rng(5)
    ned = rng.uniform(-1000, 1000, size=(2, 5, 3))
    p = ned_to_ecef(ned, lat, lon, h)
    assert p.shape == (2, 5, 3)
    assert_allclose(ecef_to_ned(p, lat, lon, h), ned, atol=1e-7)


# ---------------------------------------------------------------- vehicle frame


def test_body_to_vehicle_known_axes() -> None:
    assert_array_equal(body_to_vehicle([1.0, 0.0, 0.0]), [0.0, 1.0, 0.0])  # forward -> Y
    assert_array_equal(body_to_vehicle([0.0, 1.0, 0.0]), [1.0, 0.0, 0.0])  # right -> X
    assert_array_equal(body_to_vehicle([0.0, 0.0, 1.0]), [0.0, 0.0, -1.0])  # down -> -Z
    assert_array_equal(vehicle_to_body([0.0, 0.0, 1.0]), [0.0, 0.0, -1.0])  # up -> -down


@settings(max_examples=200, deadline=None)
@given(v=vectors)
def test_body_vehicle_inverse(v: tuple[float, float, float]) -> None:
    assert_array_equal(vehicle_to_body(body_to_vehicle(v)), v)
    assert_array_equal(body_to_vehicle(vehicle_to_body(v)), v)
    assert_allclose(np.linalg.norm(body_to_vehicle(v)), np.linalg.norm(v), rtol=1e-15)


def test_body_to_vehicle_is_right_handed_and_vectorised() -> None:
    rng = np.random.default_rng(6)
    a, b = rng.normal(size=(2, 7, 3))
    va, vb = body_to_vehicle(a), body_to_vehicle(b)
    assert va.shape == (7, 3)
    # A proper rotation preserves the cross product.
    assert_allclose(np.cross(va, vb), body_to_vehicle(np.cross(a, b)), atol=1e-14)


def test_ned_to_vehicle_yaw_90() -> None:
    R = euler_rpy_to_matrix(0.0, 0.0, HALF_PI)
    assert_allclose(ned_to_vehicle([0.0, 1.0, 0.0], R), [0.0, 1.0, 0.0], atol=1e-15)  # East
    assert_allclose(ned_to_vehicle([1.0, 0.0, 0.0], R), [-1.0, 0.0, 0.0], atol=1e-15)  # left
    assert_allclose(ned_to_vehicle([0.0, 0.0, -1.0], R), [0.0, 0.0, 1.0], atol=1e-15)  # up


def test_ned_to_vehicle_vectorised() -> None:
    rng = np.random.default_rng(7)
    rpy = rng.uniform(-1.0, 1.0, size=(5, 3))
    R = euler_rpy_to_matrix(rpy[:, 0], rpy[:, 1], rpy[:, 2])
    v = rng.normal(size=(5, 3))
    out = ned_to_vehicle(v, R)
    assert out.shape == (5, 3)
    expected = body_to_vehicle(np.einsum("nji,nj->ni", R, v))
    assert_allclose(out, expected, atol=1e-14)
    assert_allclose(out[3], ned_to_vehicle(v[3], R[3]), atol=1e-15)


# ---------------------------------------------------------------- bad input

_NAN_CALLS: list[Callable[[], object]] = [
    lambda: rot_x(math.nan),
    lambda: skew([0.0, math.nan, 1.0]),
    lambda: euler_rpy_to_matrix(0.1, math.nan, 0.2),
    lambda: euler_rpy_to_quaternion(math.nan, 0.0, 0.0),
    lambda: matrix_to_euler_rpy(np.full((3, 3), math.nan)),
    lambda: matrix_to_quaternion(np.where(np.eye(3) > 0, math.nan, 0.0)),
    lambda: quaternion_to_matrix([math.nan, 0.0, 0.0, 0.0]),
    lambda: rotation_ned_to_ecef(math.nan, 0.0),
    lambda: quaternion_ned_to_ecef(0.0, math.nan),
    lambda: geodetic_to_ecef(10.0, math.nan, 0.0),
    lambda: geodetic_to_ecef(10.0, 0.0, math.inf),
    lambda: ecef_to_geodetic([math.nan, 0.0, 6.4e6]),
    lambda: ned_to_ecef([0.0, math.nan, 0.0], 10.0, 20.0, 0.0),
    lambda: ecef_to_ned([6.4e6, 0.0, math.nan], 10.0, 20.0, 0.0),
    lambda: body_to_vehicle([math.nan, 0.0, 0.0]),
    lambda: vehicle_to_body([0.0, 0.0, math.nan]),
    lambda: ned_to_vehicle([1.0, 0.0, 0.0], np.full((3, 3), math.nan)),
]


@pytest.mark.parametrize("call", _NAN_CALLS)
def test_nan_raises_input_error(call: Callable[[], object]) -> None:
    with pytest.raises(InputError, match="non-finite"):
        call()


def test_non_unit_quaternion_raises() -> None:
    with pytest.raises(InputError, match="norm"):
        quaternion_to_matrix([1.0, 0.0, 0.0, 0.1])
    with pytest.raises(InputError, match="norm"):
        quaternion_to_euler_rpy([[1.0, 0.0, 0.0, 0.0], [0.5, 0.5, 0.5, 0.0]])
    # Within the documented tolerance (1e-6) the quaternion is accepted and normalised.
    R = quaternion_to_matrix([1.0 + 5e-7, 0.0, 0.0, 0.0])
    assert_allclose(R, np.eye(3), atol=1e-15)


def test_wrong_shapes_raise() -> None:
    with pytest.raises(InputError, match="shape"):
        quaternion_to_matrix([1.0, 0.0, 0.0])
    with pytest.raises(InputError, match="shape"):
        matrix_to_euler_rpy(np.eye(4))
    with pytest.raises(InputError, match="shape"):
        matrix_to_quaternion(np.eye(2))
    with pytest.raises(InputError, match="shape"):
        ecef_to_geodetic([1.0, 2.0])
    with pytest.raises(InputError, match="expected numbers"):
        rot_x("ninety")


_BAD_LATITUDE_CALLS: list[Callable[[], object]] = [
    lambda: geodetic_to_ecef(95.0, 0.0, 0.0),
    lambda: geodetic_to_ecef([10.0, -95.0], 0.0, 0.0),
    lambda: rotation_ned_to_ecef(95.0, 0.0),
    lambda: rotation_ned_to_ecef([0.0, -90.5], 0.0),
    lambda: quaternion_ned_to_ecef([0.0, 90.5], 0.0),
    lambda: ned_to_ecef([0.0, 0.0, 0.0], 95.0, 0.0, 0.0),
    lambda: ecef_to_ned([6.4e6, 0.0, 0.0], 95.0, 0.0, 0.0),
]


@pytest.mark.parametrize("call", _BAD_LATITUDE_CALLS)
def test_latitude_out_of_range_raises(call: Callable[[], object]) -> None:
    with pytest.raises(InputError, match="latitude"):
        call()


def test_a_long_euler_conversion_in_blocks_gives_the_same_bits(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Long arrays are converted in blocks (no array-sized temporaries): the same bits."""
    from kinsync import frames  # noqa: PLC0415

    rng = np.random.default_rng(5)
    r, p, y = rng.uniform(-3.0, 3.0, (3, 10_007))
    monkeypatch.setattr(frames, "_BLOCK_ROWS", 10**9)
    whole = frames.euler_rpy_to_quaternion(r, p, y)
    monkeypatch.setattr(frames, "_BLOCK_ROWS", 1000)
    blocks = frames.euler_rpy_to_quaternion(r, p, y)
    assert np.array_equal(whole.view(np.uint64), blocks.view(np.uint64))


# ----------------------------------------------------------------- longitude arcs
def test_the_longitude_span_is_the_shortest_arc_across_the_antimeridian() -> None:
    """Review L3: min/max of 179.9999 and -179.9999 made a 360 deg span."""
    assert longitude_span_deg([179.9999, -179.9999, 180.0]) == (179.9999, -179.9999)
    assert longitude_span_deg([-72.2, -71.9, -72.0]) == (-72.2, -71.9)
    assert longitude_span_deg([179.5, 180.0]) == (179.5, 180.0)  # ends on it: not across
    assert longitude_span_deg([190.0, 200.0]) == (-170.0, -160.0)
    assert longitude_span_deg([5.0]) == (5.0, 5.0)
    with pytest.raises(InputError, match="no longitude"):
        longitude_span_deg([])


def test_the_mean_longitude_across_the_antimeridian_is_near_it() -> None:
    """Review L3: np.mean of 179.99 and -179.99 is 0, the other side of the Earth."""
    assert mean_longitude_deg([179.99, -179.99]) == pytest.approx(-180.0, abs=1e-9)
    assert mean_longitude_deg([179.99, -179.97]) == pytest.approx(-179.99, abs=1e-9)
    assert mean_longitude_deg([-72.2, -71.9]) == float(np.mean([-72.2, -71.9]))
