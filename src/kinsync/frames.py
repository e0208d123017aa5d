"""Rotations and reference frames.

DIN 9300 / aerospace Euler angles (roll, pitch, yaw) <-> rotation matrices and
scalar-first unit quaternions; the NED <-> ECEF rotation at a latitude/longitude;
geodetic <-> ECEF on WGS84 through pyproj; body (Forward-Right-Down) <-> vehicle
(X right, Y forward, Z up) frame for reports.

All functions are vectorised over leading dimensions: a rotation argument of shape
``(..., 3, 3)`` or ``(..., 4)`` and vectors of shape ``(..., 3)`` broadcast together.
Angles are radians unless the name ends in ``_deg``.

References
----------
DIN 9300 / ISO 1151 flight-mechanics axis conventions; Titterton & Weston,
*Strapdown Inertial Navigation Technology*, 2nd ed., IET 2004, ch. 3 (frames and
attitude representations).
"""

from __future__ import annotations

from functools import lru_cache
from typing import TYPE_CHECKING

import numpy as np

from kinsync._typing import ArrayLike, FloatArray
from kinsync.errors import InputError

# pyproj and scipy load when a function needs them: every command imports this module,
# and most never touch either (start-up time and memory of the command line).
if TYPE_CHECKING:
    from pyproj import Transformer

WGS84_A_M = 6378137.0
"""WGS84 semi-major axis (m)."""
WGS84_F = 1.0 / 298.257223563
"""WGS84 flattening."""
WGS84_B_M = WGS84_A_M * (1.0 - WGS84_F)
"""WGS84 semi-minor axis (m)."""

__all__ = [
    "WGS84_A_M",
    "WGS84_B_M",
    "WGS84_F",
    "body_to_vehicle",
    "ecef_to_geodetic",
    "ecef_to_ned",
    "euler_rpy_to_matrix",
    "euler_rpy_to_quaternion",
    "geodetic_to_ecef",
    "longitude_span_deg",
    "matrix_to_euler_rpy",
    "matrix_to_quaternion",
    "mean_longitude_deg",
    "ned_to_ecef",
    "ned_to_vehicle",
    "quaternion_to_euler_rpy",
    "quaternion_to_matrix",
    "rot_x",
    "rot_y",
    "rot_z",
    "rotation_ned_to_ecef",
    "skew",
    "vehicle_to_body",
    "wrap_angle_rad",
]


def _as_float(values: ArrayLike, name: str) -> FloatArray:
    """Convert to a float64 array and reject non-finite values with a clear message."""
    try:
        arr = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError) as err:
        msg = f"{name}: expected numbers, got {values!r}"
        raise InputError(msg) from err
    if not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))[0]
        msg = f"{name}: non-finite value at index {tuple(int(i) for i in bad)}"
        raise InputError(msg)
    return arr


def _elementary(angle_rad: ArrayLike, axis: int) -> FloatArray:
    """Right-handed rotation matrices about one coordinate axis, shape ``(..., 3, 3)``."""
    a = _as_float(angle_rad, "angle_rad")
    c, s = np.cos(a), np.sin(a)
    out = np.zeros((*a.shape, 3, 3))
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    out[..., axis, axis] = 1.0
    out[..., i, i] = c
    out[..., j, j] = c
    out[..., i, j] = -s
    out[..., j, i] = s
    return out


def rot_x(angle_rad: ArrayLike) -> FloatArray:
    """Rotation matrix about X (active, right-handed).

    Parameters
    ----------
    angle_rad : array_like, shape (...)
        Rotation angle (rad).

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    return _elementary(angle_rad, 0)


def rot_y(angle_rad: ArrayLike) -> FloatArray:
    """Rotation matrix about Y (active, right-handed), shape ``(..., 3, 3)``.

    Parameters
    ----------
    angle_rad : array_like, shape (...)
        Rotation angle (rad), positive right-handed about the Y axis.

    Returns
    -------
    ndarray, shape (..., 3, 3)

    Raises
    ------
    InputError
        ``angle_rad`` not numbers, or not finite.
    """
    return _elementary(angle_rad, 1)


def rot_z(angle_rad: ArrayLike) -> FloatArray:
    """Rotation matrix about Z (active, right-handed), shape ``(..., 3, 3)``.

    Parameters
    ----------
    angle_rad : array_like, shape (...)
        Rotation angle (rad), positive right-handed about the Z axis.

    Returns
    -------
    ndarray, shape (..., 3, 3)

    Raises
    ------
    InputError
        ``angle_rad`` not numbers, or not finite.
    """
    return _elementary(angle_rad, 2)


def skew(vec: ArrayLike) -> FloatArray:
    """Cross-product matrix: ``skew(a) @ b == np.cross(a, b)``.

    Parameters
    ----------
    vec : array_like, shape (..., 3)

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    v = _as_float(vec, "vec")
    out = np.zeros((*v.shape[:-1], 3, 3))
    out[..., 0, 1] = -v[..., 2]
    out[..., 0, 2] = v[..., 1]
    out[..., 1, 0] = v[..., 2]
    out[..., 1, 2] = -v[..., 0]
    out[..., 2, 0] = -v[..., 1]
    out[..., 2, 1] = v[..., 0]
    return out


def euler_rpy_to_matrix(
    roll_rad: ArrayLike, pitch_rad: ArrayLike, yaw_rad: ArrayLike
) -> FloatArray:
    """DIN 9300 Euler angles to the body -> navigation rotation matrix.

    ``R_body_to_ned = Rz(yaw) @ Ry(pitch) @ Rx(roll)``.

    Parameters
    ----------
    roll_rad, pitch_rad, yaw_rad : array_like, broadcastable shapes (...)
        Roll about body X, pitch about body Y, yaw (heading) about Down (rad).

    Returns
    -------
    ndarray, shape (..., 3, 3)
        ``R_body_to_ned``: takes body (FRD) vectors to NED.
    """
    r, p, y = np.broadcast_arrays(
        _as_float(roll_rad, "roll_rad"),
        _as_float(pitch_rad, "pitch_rad"),
        _as_float(yaw_rad, "yaw_rad"),
    )
    cr, sr = np.cos(r), np.sin(r)
    cp, sp = np.cos(p), np.sin(p)
    cy, sy = np.cos(y), np.sin(y)
    out = np.empty((*r.shape, 3, 3))
    out[..., 0, 0] = cy * cp
    out[..., 0, 1] = cy * sp * sr - sy * cr
    out[..., 0, 2] = cy * sp * cr + sy * sr
    out[..., 1, 0] = sy * cp
    out[..., 1, 1] = sy * sp * sr + cy * cr
    out[..., 1, 2] = sy * sp * cr - cy * sr
    out[..., 2, 0] = -sp
    out[..., 2, 1] = cp * sr
    out[..., 2, 2] = cp * cr
    return out


def matrix_to_euler_rpy(R_body_to_ned: ArrayLike) -> FloatArray:
    """Rotation matrix to DIN 9300 Euler angles.

    Parameters
    ----------
    R_body_to_ned : array_like, shape (..., 3, 3)
        Proper rotation matrices.

    Returns
    -------
    ndarray, shape (..., 3)
        ``(roll, pitch, yaw)`` in rad; roll and yaw in ``(-pi, pi]``, pitch in
        ``[-pi/2, pi/2]``. At pitch = +-90 deg (gimbal lock) roll is set to zero and the
        remaining rotation goes to yaw; near it the angles still reproduce ``R``.

    References
    ----------
    Shoemake, K., "Euler angle conversion", Graphics Gems IV, 1994, 222-229.
    """
    R = _as_float(R_body_to_ned, "R_body_to_ned")
    if R.shape[-2:] != (3, 3):
        msg = f"R_body_to_ned: expected shape (..., 3, 3), got {R.shape}"
        raise InputError(msg)
    # Shoemake's form: pitch from atan2 (accurate near +-90 deg), yaw from the roll just
    # found, so the angles reproduce R to rounding error at every pitch.
    c_pitch = np.hypot(R[..., 2, 1], R[..., 2, 2])
    pitch = np.arctan2(-R[..., 2, 0], c_pitch)
    # At exact gimbal lock only yaw -+ roll is defined: take roll = 0.
    roll = np.where(c_pitch > 1e-12, np.arctan2(R[..., 2, 1], R[..., 2, 2]), 0.0)
    cr, sr = np.cos(roll), np.sin(roll)
    yaw = np.arctan2(sr * R[..., 0, 2] - cr * R[..., 0, 1], cr * R[..., 1, 1] - sr * R[..., 1, 2])
    return np.stack([roll, pitch, yaw], axis=-1)


def _check_unit_quaternion(q: FloatArray, name: str, tol: float = 1e-6) -> None:
    if q.shape[-1:] != (4,):
        msg = f"{name}: expected shape (..., 4) scalar-first (w, x, y, z), got {q.shape}"
        raise InputError(msg)
    norm = np.linalg.norm(q, axis=-1)
    bad = np.abs(norm - 1.0) > tol
    if np.any(bad):
        idx = tuple(int(i) for i in np.argwhere(bad)[0])
        msg = (
            f"{name}: quaternion at index {idx} has norm {float(norm[idx]):.9g}, "
            f"expected 1 (tolerance {tol:g}); normalise it or check the column order (w, x, y, z)"
        )
        raise InputError(msg)


def quaternion_to_matrix(q_body_to_ned: ArrayLike) -> FloatArray:
    """Unit quaternion (scalar-first) to rotation matrix.

    Parameters
    ----------
    q_body_to_ned : array_like, shape (..., 4)
        ``(w, x, y, z)`` unit quaternions (norm within 1e-6 of one).

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    q = _as_float(q_body_to_ned, "q_body_to_ned")
    _check_unit_quaternion(q, "q_body_to_ned")
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    out = np.empty((*q.shape[:-1], 3, 3))
    out[..., 0, 0] = 1 - 2 * (y * y + z * z)
    out[..., 0, 1] = 2 * (x * y - w * z)
    out[..., 0, 2] = 2 * (x * z + w * y)
    out[..., 1, 0] = 2 * (x * y + w * z)
    out[..., 1, 1] = 1 - 2 * (x * x + z * z)
    out[..., 1, 2] = 2 * (y * z - w * x)
    out[..., 2, 0] = 2 * (x * z - w * y)
    out[..., 2, 1] = 2 * (y * z + w * x)
    out[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return out


def matrix_to_quaternion(R_body_to_ned: ArrayLike) -> FloatArray:
    """Rotation matrix to unit quaternion, scalar-first with ``w >= 0``.

    Parameters
    ----------
    R_body_to_ned : array_like, shape (..., 3, 3)

    Returns
    -------
    ndarray, shape (..., 4)
    """
    R = _as_float(R_body_to_ned, "R_body_to_ned")
    if R.shape[-2:] != (3, 3):
        msg = f"R_body_to_ned: expected shape (..., 3, 3), got {R.shape}"
        raise InputError(msg)
    lead = R.shape[:-2]
    from scipy.spatial.transform import Rotation  # noqa: PLC0415 - see the imports

    xyzw = Rotation.from_matrix(R.reshape(-1, 3, 3)).as_quat()
    q = xyzw[:, [3, 0, 1, 2]]
    q = np.where(q[:, :1] < 0.0, -q, q)
    return q.reshape(*lead, 4)


def euler_rpy_to_quaternion(
    roll_rad: ArrayLike, pitch_rad: ArrayLike, yaw_rad: ArrayLike
) -> FloatArray:
    """DIN 9300 Euler angles to a scalar-first unit quaternion (``w >= 0``), shape ``(..., 4)``.

    Parameters
    ----------
    roll_rad, pitch_rad, yaw_rad : array_like, broadcastable shapes (...)
        Roll about body X, pitch about body Y, yaw (heading) about Down (rad).

    Returns
    -------
    ndarray, shape (..., 4)
        ``q_body_to_ned`` as ``(w, x, y, z)``: the rotation of `euler_rpy_to_matrix`.

    Raises
    ------
    InputError
        An angle not numbers, or not finite.
    """
    r, p, y = np.broadcast_arrays(
        _as_float(roll_rad, "roll_rad"),
        _as_float(pitch_rad, "pitch_rad"),
        _as_float(yaw_rad, "yaw_rad"),
    )
    if r.ndim == 1 and r.size > _BLOCK_ROWS:  # a long trajectory: no (N,) temporaries
        out = np.empty((r.size, 4))
        for start in range(0, r.size, _BLOCK_ROWS):
            rows = slice(start, start + _BLOCK_ROWS)
            out[rows] = _euler_rpy_to_quaternion(r[rows], p[rows], y[rows])
        return out
    return _euler_rpy_to_quaternion(r, p, y)


_BLOCK_ROWS = 65_536
"""Rows converted at a time by the element-wise conversions of long arrays: the values
are those of one conversion of the whole, without its dozen array-sized temporaries
(a 10 h, 200 Hz trajectory: 58 MB each, and the page faults of allocating them)."""


def _euler_rpy_to_quaternion(r: FloatArray, p: FloatArray, y: FloatArray) -> FloatArray:
    """`euler_rpy_to_quaternion` of validated, broadcast angle arrays (rad)."""
    cr, sr = np.cos(r / 2), np.sin(r / 2)
    cp, sp = np.cos(p / 2), np.sin(p / 2)
    cy, sy = np.cos(y / 2), np.sin(y / 2)
    q = np.stack(
        [
            cy * cp * cr + sy * sp * sr,
            cy * cp * sr - sy * sp * cr,
            cy * sp * cr + sy * cp * sr,
            sy * cp * cr - cy * sp * sr,
        ],
        axis=-1,
    )
    return np.where(q[..., :1] < 0.0, -q, q)


def quaternion_to_euler_rpy(q_body_to_ned: ArrayLike) -> FloatArray:
    """Scalar-first unit quaternion to DIN 9300 ``(roll, pitch, yaw)`` (rad), shape ``(..., 3)``.

    Parameters
    ----------
    q_body_to_ned : array_like, shape (..., 4)
        ``(w, x, y, z)`` unit quaternions (norm within 1e-6 of one), body (FRD) to NED.

    Returns
    -------
    ndarray, shape (..., 3)
        ``(roll, pitch, yaw)`` in rad, with the ranges and gimbal-lock convention of
        `matrix_to_euler_rpy`.

    Raises
    ------
    InputError
        Not numbers, not finite, last axis not of length 4, or a norm not within 1e-6
        of one.
    """
    return matrix_to_euler_rpy(quaternion_to_matrix(q_body_to_ned))


def wrap_angle_rad(angle_rad: ArrayLike) -> FloatArray:
    """Angles (rad) wrapped to (-pi, pi], same shape: a difference of two headings.

    Parameters
    ----------
    angle_rad : array_like, any shape
        Angles (rad), any size; NaN stays NaN.

    Returns
    -------
    ndarray of float64, same shape as ``angle_rad``
        The same angles (rad) wrapped by whole turns into ``[-pi, pi]``; an odd
        multiple of pi comes back as pi or -pi, as rounding falls.
    """
    out: FloatArray = np.angle(np.exp(1j * np.asarray(angle_rad, dtype=np.float64)))
    return out


def longitude_span_deg(lon_deg: ArrayLike) -> tuple[float, float]:
    """West and east ends of the shortest arc of longitude that holds every value.

    Across the antimeridian the west end is the larger number (179.9 to -179.9 spans
    0.2 deg, not 359.8 deg).

    Parameters
    ----------
    lon_deg : array_like, shape (n,)
        Longitudes (deg, any range: 190 is -170), n >= 1, finite.

    Returns
    -------
    tuple of float
        (west, east) in [-180, 180]: ``west <= east`` unless the arc crosses the
        antimeridian; an arc that ends on it ends at 180 rather than -180.
    """
    lon = np.sort(_wrapped_longitude_deg(lon_deg))
    if lon.size == 0:
        msg = "longitude_span_deg: no longitude given"
        raise InputError(msg)
    gaps = np.diff(lon, append=lon[0] + 360.0)  # the gap east of each value; last across 180
    k = lon.size - 1 if gaps[-1] >= gaps.max() else int(np.argmax(gaps))
    west, east = float(lon[(k + 1) % lon.size]), float(lon[k])
    if east == -180.0 and west > east:  # ends on the antimeridian: -180 is 180
        east = 180.0
    return west, east


def mean_longitude_deg(lon_deg: ArrayLike) -> float:
    """Mean of longitudes along the shortest arc holding them (antimeridian-safe).

    Parameters
    ----------
    lon_deg : array_like, shape (n,)
        Longitudes (deg, any range), n >= 1, finite.

    Returns
    -------
    float
        The mean (deg, in [-180, 180)); the plain mean where the arc does not cross the
        antimeridian (179.99 and -179.99 average to 180, given as -180).
    """
    lon = _wrapped_longitude_deg(lon_deg)
    west, east = longitude_span_deg(lon)
    if west <= east:
        return float(np.mean(lon))
    mean = west + float(np.mean((lon - west) % 360.0))
    return float(_wrapped_longitude_deg(mean)[0])


def _wrapped_longitude_deg(lon_deg: ArrayLike) -> FloatArray:
    """Longitudes (deg) as a flat array in [-180, 180); those already there untouched."""
    lon = np.asarray(lon_deg, dtype=np.float64).ravel()
    out: FloatArray = np.where((lon >= -180.0) & (lon < 180.0), lon, (lon + 180.0) % 360.0 - 180.0)
    return out


def rotation_ned_to_ecef(lat_deg: ArrayLike, lon_deg: ArrayLike) -> FloatArray:
    """Rotation taking NED vectors at a geodetic position to ECEF.

    Parameters
    ----------
    lat_deg, lon_deg : array_like, broadcastable shapes (...)
        Geodetic latitude and longitude (deg, WGS84).

    Returns
    -------
    ndarray, shape (..., 3, 3)
        ``R_ned_to_ecef``; columns are the North, East and Down unit vectors in ECEF.
    """
    lat_checked = _as_float(lat_deg, "lat_deg")
    if np.any(np.abs(lat_checked) > 90.0):
        bad = float(lat_checked[np.abs(lat_checked) > 90.0][0])
        msg = f"lat_deg: latitude outside [-90, 90]: {bad}"
        raise InputError(msg)
    lat, lon = np.broadcast_arrays(
        np.radians(lat_checked), np.radians(_as_float(lon_deg, "lon_deg"))
    )
    sl, cl = np.sin(lat), np.cos(lat)
    so, co = np.sin(lon), np.cos(lon)
    out = np.empty((*lat.shape, 3, 3))
    out[..., 0, 0] = -sl * co
    out[..., 1, 0] = -sl * so
    out[..., 2, 0] = cl
    out[..., 0, 1] = -so
    out[..., 1, 1] = co
    out[..., 2, 1] = 0.0
    out[..., 0, 2] = -cl * co
    out[..., 1, 2] = -cl * so
    out[..., 2, 2] = -sl
    return out


def quaternion_ned_to_ecef(lat_deg: ArrayLike, lon_deg: ArrayLike) -> FloatArray:
    """`rotation_ned_to_ecef` as a scalar-first unit quaternion, without a matrix.

    ``R_ned_to_ecef = Rz(lon) Ry(-lat - 90 deg)`` (active rotations), so the quaternion
    is the product of the two elementary ones, in closed form.

    Parameters
    ----------
    lat_deg, lon_deg : array_like, broadcastable shapes (...)
        Geodetic latitude and longitude (deg, WGS84).

    Returns
    -------
    ndarray, shape (..., 4)
        ``q_ned_to_ecef``, scalar first (sign not normalised).
    """
    lat_checked = _as_float(lat_deg, "lat_deg")
    if np.any(np.abs(lat_checked) > 90.0):
        bad = float(lat_checked[np.abs(lat_checked) > 90.0][0])
        msg = f"lat_deg: latitude outside [-90, 90]: {bad}"
        raise InputError(msg)
    lat, lon = np.broadcast_arrays(
        np.radians(lat_checked), np.radians(_as_float(lon_deg, "lon_deg"))
    )
    half_lon = 0.5 * lon
    half_y = -0.5 * lat - 0.25 * np.pi
    cz, sz = np.cos(half_lon), np.sin(half_lon)
    cy, sy = np.cos(half_y), np.sin(half_y)
    # (cz, 0, 0, sz) ⊗ (cy, 0, sy, 0)
    return np.stack([cz * cy, -sz * sy, cz * sy, sz * cy], axis=-1)


@lru_cache(maxsize=1)
def _geodetic_ecef_transformer() -> Transformer:
    from pyproj import Transformer  # noqa: PLC0415 - see the imports

    # EPSG:4979 = WGS84 geographic 3-D, EPSG:4978 = WGS84 geocentric.
    return Transformer.from_crs("EPSG:4979", "EPSG:4978", always_xy=True)


def geodetic_to_ecef(lat_deg: ArrayLike, lon_deg: ArrayLike, h_m: ArrayLike) -> FloatArray:
    """Geodetic WGS84 coordinates to ECEF through pyproj.

    Parameters
    ----------
    lat_deg, lon_deg : array_like, shape (...)
        Geodetic latitude in [-90, 90] and longitude (deg).
    h_m : array_like, shape (...)
        Ellipsoidal height (m).

    Returns
    -------
    ndarray, shape (..., 3)
        ``pos_ecef_m``.
    """
    lat, lon, h = np.broadcast_arrays(
        _as_float(lat_deg, "lat_deg"), _as_float(lon_deg, "lon_deg"), _as_float(h_m, "h_m")
    )
    if np.any(np.abs(lat) > 90.0):
        msg = f"lat_deg: latitude outside [-90, 90]: {float(lat[np.abs(lat) > 90.0][0])}"
        raise InputError(msg)
    x, y, z = _geodetic_ecef_transformer().transform(lon, lat, h)
    return np.stack([np.asarray(x), np.asarray(y), np.asarray(z)], axis=-1).astype(np.float64)


def ecef_to_geodetic(pos_ecef_m: ArrayLike) -> FloatArray:
    """ECEF to geodetic WGS84 coordinates through pyproj, refined by one Newton step.

    PROJ's inverse is closed-form (Bowring) and loses about 1 µm of height at 9 km
    above the ellipsoid; one step against the exact forward transform (the residual
    taken North and Down, over the meridian radius for latitude) brings the round trip
    to the floating-point floor at any height a survey meets.

    Parameters
    ----------
    pos_ecef_m : array_like, shape (..., 3)

    Returns
    -------
    ndarray, shape (..., 3)
        ``(lat_deg, lon_deg, h_m)``.
    """
    p = _as_float(pos_ecef_m, "pos_ecef_m")
    if p.shape[-1:] != (3,):
        msg = f"pos_ecef_m: expected shape (..., 3), got {p.shape}"
        raise InputError(msg)
    lon, lat, h = (
        np.asarray(v, dtype=np.float64)
        for v in _geodetic_ecef_transformer().transform(
            p[..., 0], p[..., 1], p[..., 2], direction="INVERSE"
        )
    )
    residual = p - geodetic_to_ecef(lat, lon, h)
    R = rotation_ned_to_ecef(lat, lon)
    d_north = np.einsum("...i,...i->...", R[..., :, 0], residual)
    d_down = np.einsum("...i,...i->...", R[..., :, 2], residual)
    e2 = WGS84_F * (2.0 - WGS84_F)
    sin_lat = np.sin(np.radians(lat))
    meridian_m = WGS84_A_M * (1.0 - e2) / (1.0 - e2 * sin_lat**2) ** 1.5
    lat = lat + np.degrees(d_north / (meridian_m + h))
    h = h - d_down
    return np.stack([lat, lon, h], axis=-1)


def ned_to_ecef(
    pos_ned_m: ArrayLike, origin_lat_deg: float, origin_lon_deg: float, origin_h_m: float
) -> FloatArray:
    """Local NED coordinates about an origin to ECEF positions.

    Parameters
    ----------
    pos_ned_m : array_like, shape (..., 3)
        Position in the local-level NED frame tangent at the origin (m).
    origin_lat_deg, origin_lon_deg, origin_h_m : float
        Geodetic origin of the local frame.

    Returns
    -------
    ndarray, shape (..., 3)
        ``pos_ecef_m``.
    """
    p = _as_float(pos_ned_m, "pos_ned_m")
    origin = geodetic_to_ecef(origin_lat_deg, origin_lon_deg, origin_h_m)
    R = rotation_ned_to_ecef(origin_lat_deg, origin_lon_deg)
    rotated: FloatArray = np.einsum("ij,...j->...i", R, p)
    return origin + rotated


def ecef_to_ned(
    pos_ecef_m: ArrayLike, origin_lat_deg: float, origin_lon_deg: float, origin_h_m: float
) -> FloatArray:
    """ECEF positions to the local NED frame tangent at an origin, shape ``(..., 3)`` (m).

    The inverse of `ned_to_ecef`.

    Parameters
    ----------
    pos_ecef_m : array_like, shape (..., 3)
        Positions in WGS84 ECEF (m).
    origin_lat_deg, origin_lon_deg, origin_h_m : float
        Geodetic origin of the local frame: latitude and longitude (deg, WGS84) and
        ellipsoidal height (m).

    Returns
    -------
    ndarray, shape (..., 3)
        ``pos_ned_m``: North, East, Down of each position from the origin (m).

    Raises
    ------
    InputError
        A position or the origin not numbers or not finite, or the origin latitude
        outside [-90, 90].
    """
    p = _as_float(pos_ecef_m, "pos_ecef_m")
    origin = geodetic_to_ecef(origin_lat_deg, origin_lon_deg, origin_h_m)
    R = rotation_ned_to_ecef(origin_lat_deg, origin_lon_deg)
    local: FloatArray = np.einsum("ji,...j->...i", R, p - origin)
    return local


_BODY_TO_VEHICLE = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
"""Body FRD -> vehicle (X right, Y forward, Z up): x_v = y_b, y_v = x_b, z_v = -z_b."""


def body_to_vehicle(vec_body: ArrayLike) -> FloatArray:
    """Body (Forward-Right-Down) vectors to the vehicle frame (X right, Y forward, Z up).

    Parameters
    ----------
    vec_body : array_like, shape (..., 3)

    Returns
    -------
    ndarray, shape (..., 3)
        ``vec_vehicle``.
    """
    out: FloatArray = np.einsum("ij,...j->...i", _BODY_TO_VEHICLE, _as_float(vec_body, "vec_body"))
    return out


def vehicle_to_body(vec_vehicle: ArrayLike) -> FloatArray:
    """Vehicle-frame vectors (X right, Y forward, Z up) to body FRD, shape ``(..., 3)``.

    The inverse of `body_to_vehicle`.

    Parameters
    ----------
    vec_vehicle : array_like, shape (..., 3)
        Vectors in the vehicle frame (any unit; it is kept).

    Returns
    -------
    ndarray, shape (..., 3)
        ``vec_body``: the same vectors in the body frame (Forward-Right-Down).

    Raises
    ------
    InputError
        Not numbers, or not finite.
    """
    # The axis permutation with one sign flip is its own inverse.
    v = _as_float(vec_vehicle, "vec_vehicle")
    out: FloatArray = np.einsum("ij,...j->...i", _BODY_TO_VEHICLE, v)
    return out


def ned_to_vehicle(vec_ned: ArrayLike, R_body_to_ned: ArrayLike) -> FloatArray:
    """Express NED vectors in the vehicle frame of a body attitude.

    Parameters
    ----------
    vec_ned : array_like, shape (..., 3)
        Vectors in NED (e.g. a control-point difference, m).
    R_body_to_ned : array_like, shape (..., 3, 3)
        Attitude of the vehicle at the moment the vector applies.

    Returns
    -------
    ndarray, shape (..., 3)
        The vectors in the vehicle frame (X right, Y forward, Z up).
    """
    R = _as_float(R_body_to_ned, "R_body_to_ned")
    v_body = np.einsum("...ji,...j->...i", R, _as_float(vec_ned, "vec_ned"))
    return body_to_vehicle(v_body)
