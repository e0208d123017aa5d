"""Direct georeferencing of scanner points: the compiled kernel and its numpy reference.

SPEC section 5::

    x_ecef = p_ecef(t) + R_ned^ecef(lat, lon) · R_b^n(t) · (a_s + R_s^b · x_s)

with the trajectory read at each point's time ``t`` after the latency correction of
SPEC section 1 (a point at ``t`` uses the record tagged ``t + latency_s``).

`GeorefTrajectory` precomputes, once per trajectory record, the ECEF position, the
ECEF velocity (when the trajectory has velocities) and the body -> ECEF attitude
``q_body_to_ecef = q(R_ned_to_ecef(lat, lon)) ⊗ q_body_to_ned``. The kernel then
interpolates, per point, the ECEF position (linear, or cubic Hermite with the ECEF
velocities) and the body -> ECEF attitude by slerp, in one compiled loop (numba,
single thread). Slerping the composed quaternion instead of composing separately
interpolated NED and body rotations changes the attitude by far less than 1e-9 rad
at vehicle speeds: the NED frame turns by only ``v·dt/R_earth`` per record
(``tests/test_georef.py`` shows it).

Points outside the trajectory's span are never extrapolated: they come back NaN with
``inside == False`` and the caller decides (error or reject).

2D profile scanners give a range and a mirror angle instead of x, y, z:
`georeference_profile` puts them in the scanner frame with the mount's fixed azimuth
(``x_s = R_2d^s · x_2d``, `profile_points_to_scanner`) and georeferences them the same way.

`georeference_file` streams a file through this kernel in chunks. The input is cut
once into chunks that any process can read on its own (LAS/LAZ by seek, CSV by byte
range at line boundaries, Parquet by row group); each chunk is read, georeferenced and
turned into what is to be written in one task, in this process or in worker processes
(a process pool, or a Dask cluster), and this process writes the results in input order.
So workers also share the reading and decompression, and every scheduler writes the
same output.

References
----------
Shoemake, K., "Animating rotation with quaternion curves", SIGGRAPH 1985 (slerp).
"""

from __future__ import annotations

import importlib
import math
import multiprocessing
import time
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Future, ProcessPoolExecutor, ThreadPoolExecutor
from concurrent.futures import wait as futures_wait
from contextlib import ExitStack
from dataclasses import dataclass, replace
from functools import cached_property, lru_cache
from pathlib import Path
from typing import Any, Literal, cast

import laspy
import numpy as np
import pyproj
from numba import njit

from kinsync._typing import ArrayLike, BoolArray, FloatArray
from kinsync.errors import InputError
from kinsync.frames import (
    geodetic_to_ecef,
    ned_to_ecef,
    quaternion_ned_to_ecef,
    quaternion_to_matrix,
    rotation_ned_to_ecef,
)
from kinsync.io.las import (
    LasChunkWriter,
    LasPointReader,
    las_end_times,
    las_info,
    read_las_points,
    scaled_coordinates,
    store_coordinates,
)
from kinsync.io.passes import ADJUSTED_GPS_OFFSET_S
from kinsync.io.points import (
    TableChunkWriter,
    TableLayout,
    TableSlice,
    csv_text_columns,
    plan_table_slices,
    read_table_slice,
    table_columns,
)
from kinsync.io.sbet import SECONDS_PER_WEEK, read_sbet
from kinsync.io.trajectory_csv import read_trajectory_csv
from kinsync.mount import Mount
from kinsync.trajectory import Trajectory

__all__ = [
    "GeorefSummary",
    "GeorefTrajectory",
    "OutsidePolicy",
    "PointColumns",
    "PositionMethod",
    "georeference",
    "georeference_file",
    "georeference_numpy",
    "georeference_profile",
    "profile_points_to_scanner",
    "read_trajectory_file",
    "rejected_path_for",
    "validated_scanner_points",
]

PositionMethod = Literal["auto", "linear", "hermite"]

_LATENCY_MATCH_TOL_S = 1e-12


def _quaternion_multiply(p: FloatArray, q: FloatArray) -> FloatArray:
    """Hamilton product ``p ⊗ q`` of scalar-first quaternions, shapes broadcast to (N, 4)."""
    pw, px, py, pz = np.moveaxis(p, -1, 0)
    qw, qx, qy, qz = np.moveaxis(q, -1, 0)
    return np.stack(
        [
            pw * qw - px * qx - py * qy - pz * qz,
            pw * qx + px * qw + py * qz - pz * qy,
            pw * qy - px * qz + py * qw + pz * qx,
            pw * qz + px * qy - py * qx + pz * qw,
        ],
        axis=-1,
    )


def _interval_rotvec(q: FloatArray) -> FloatArray:
    """Rotation vector of each increment ``q[k]* ⊗ q[k+1]``, shortest arc, shape (N-1, 3).

    The increment is in the frame of the left record (rad); scalar-first unit
    quaternions in. Equal to scipy's ``(R[:-1].inv() * R[1:]).as_rotvec()`` without its
    per-element overhead (0.25 s for 120 000 records).
    """
    conj = q[:-1] * np.array([1.0, -1.0, -1.0, -1.0])
    rel = _quaternion_multiply(conj, q[1:])
    rel[rel[:, 0] < 0.0] *= -1.0  # shortest arc: w >= 0
    w = np.minimum(rel[:, 0], 1.0)
    vec = rel[:, 1:]
    sin_half = np.linalg.norm(vec, axis=1)
    angle = 2.0 * np.arctan2(sin_half, w)
    small = angle < 1e-3
    # angle / sin(angle / 2); its series where the quotient loses digits
    a2 = angle * angle
    scale = np.where(
        small,
        2.0 + a2 / 12.0 + 7.0 * a2 * a2 / 2880.0,
        angle / np.where(small, 1.0, sin_half),
    )
    rotvec: FloatArray = vec * scale[:, None]
    return rotvec


def _readonly(arr: FloatArray) -> FloatArray:
    out = np.ascontiguousarray(arr, dtype=np.float64)
    out.setflags(write=False)
    return out


@dataclass(frozen=True, eq=False)
class GeorefTrajectory:
    """A trajectory precomputed for georeferencing, on the scanner's time scale.

    Build it with `GeorefTrajectory.from_trajectory`; arrays are read-only.

    Attributes
    ----------
    trajectory : Trajectory
        The source trajectory already corrected for ``latency_s``
        (``Trajectory.corrected_for_latency``); the numpy reference interpolates it.
    latency_s : float
        Latency tau (s) the records were corrected for (SPEC section 1).
    t_s : ndarray, shape (N,)
        Record times on the scanner's time scale (s), strictly increasing.
    pos_ecef_m : ndarray, shape (N, 3)
        Body reference point position, ECEF (m).
    vel_ecef_m_s : ndarray or None, shape (N, 3)
        Velocity, ECEF (m/s); None when the trajectory has no velocities.
    q_body_to_ecef : ndarray, shape (N, 4)
        Attitude body (FRD) -> ECEF, scalar-first unit quaternions.
    rotvec_interval_body : ndarray, shape (N-1, 3)
        Rotation vector (rad, body frame of the left record) of each record-to-record
        increment of ``q_body_to_ecef``, shortest arc: the slerp increments.
    """

    trajectory: Trajectory
    latency_s: float
    t_s: FloatArray
    pos_ecef_m: FloatArray
    vel_ecef_m_s: FloatArray | None
    q_body_to_ecef: FloatArray
    rotvec_interval_body: FloatArray

    @classmethod
    def from_trajectory(cls, trajectory: Trajectory, latency_s: float = 0.0) -> GeorefTrajectory:
        """Precompute ECEF positions, velocities and body -> ECEF attitudes.

        Parameters
        ----------
        trajectory : Trajectory
            Records at their own time tags (geodetic, or local NED about an origin).
        latency_s : float
            Latency tau (s), SPEC section 1: a point at ``t`` uses the record tagged
            ``t + tau``.

        Returns
        -------
        GeorefTrajectory

        Raises
        ------
        InputError
            A non-finite latency.
        """
        if not math.isfinite(latency_s):
            msg = f"georeference latency_s must be finite, got {latency_s!r}"
            raise InputError(msg)
        corrected = trajectory.corrected_for_latency(float(latency_s))
        if corrected.lat_lon_h is not None:
            lat, lon, h = corrected.lat_lon_h.T
            pos = geodetic_to_ecef(lat, lon, h)
        else:
            assert corrected.pos_ned_m is not None
            assert corrected.origin_lat_lon_h is not None
            lat0, lon0, h0 = corrected.origin_lat_lon_h
            lat, lon = np.asarray(lat0), np.asarray(lon0)
            pos = ned_to_ecef(corrected.pos_ned_m, lat0, lon0, h0)
        vel: FloatArray | None = None
        if corrected.vel_ned_m_s is not None:
            R_ne = rotation_ned_to_ecef(lat, lon)
            v_ned = corrected.vel_ned_m_s
            vel = v_ned @ R_ne.T if R_ne.ndim == 2 else np.einsum("nij,nj->ni", R_ne, v_ned)
        q = _quaternion_multiply(quaternion_ned_to_ecef(lat, lon), corrected.q_body_to_ned)
        q /= np.linalg.norm(q, axis=1, keepdims=True)
        q[q[:, 0] < 0.0] *= -1.0
        rotvec = _interval_rotvec(q)
        return cls(
            trajectory=corrected,
            latency_s=float(latency_s),
            t_s=_readonly(corrected.t_s),
            pos_ecef_m=_readonly(pos),
            vel_ecef_m_s=None if vel is None else _readonly(vel),
            q_body_to_ecef=_readonly(q),
            rotvec_interval_body=_readonly(rotvec),
        )

    def __len__(self) -> int:
        return int(self.t_s.size)

    @cached_property
    def _poly_linear(self) -> FloatArray:
        """Per interval ``p(s) = c0 + s c1 + s² c2 + s³ c3`` (linear), shape (N-1, 4, 3)."""
        p0, p1 = self.pos_ecef_m[:-1], self.pos_ecef_m[1:]
        zero = np.zeros_like(p0)
        return _readonly(np.stack([p0, p1 - p0, zero, zero], axis=1))

    @cached_property
    def _poly_hermite(self) -> FloatArray:
        """Per interval cubic Hermite coefficients in ``s`` (ECEF, m), shape (N-1, 4, 3)."""
        assert self.vel_ecef_m_s is not None
        h = np.diff(self.t_s)[:, None]
        p0, p1 = self.pos_ecef_m[:-1], self.pos_ecef_m[1:]
        m0, m1 = h * self.vel_ecef_m_s[:-1], h * self.vel_ecef_m_s[1:]
        dp = p1 - p0
        return _readonly(np.stack([p0, m0, 3.0 * dp - 2.0 * m0 - m1, m0 + m1 - 2.0 * dp], axis=1))

    @cached_property
    def _inv_interval_s(self) -> FloatArray:
        """``1 / (t[k+1] - t[k])`` per interval (1/s), shape (N-1,): no division per point."""
        return _readonly(1.0 / np.diff(self.t_s))

    @cached_property
    def _R_body_to_ecef_left(self) -> FloatArray:
        """Rotation matrix of each interval's left record, body -> ECEF, shape (N-1, 3, 3)."""
        return _readonly(quaternion_to_matrix(self.q_body_to_ecef[:-1]))

    @property
    def t_start_s(self) -> float:
        """First record time on the scanner's time scale (s)."""
        return float(self.t_s[0])

    @property
    def t_end_s(self) -> float:
        """Last record time on the scanner's time scale (s)."""
        return float(self.t_s[-1])


# ---------------------------------------------------------------------- the kernel
def _georef_loop(  # noqa: PLR0915 - one flat loop is what numba compiles best
    t_s: FloatArray,
    xyz_scanner_m: FloatArray,
    t_rec_s: FloatArray,
    inv_interval_s: FloatArray,
    poly_ecef_m: FloatArray,
    R_left_body_to_ecef: FloatArray,
    rotvec_interval_body: FloatArray,
    lever_arm_body_m: FloatArray,
    R_scanner_to_body: FloatArray,
    out_ecef_m: FloatArray,
    inside: BoolArray,
) -> int:  # pragma: no cover - compiled by numba; its results are tested
    """One pass over the points; compiled with numba below (see `georeference`).

    Per interval k: ``1 / (t[k+1] - t[k])``, position polynomial
    ``c0 + s c1 + s² c2 + s³ c3`` in the interval fraction s (linear or cubic Hermite,
    ECEF), the left record's body -> ECEF matrix and the slerp increment (rotation
    vector, body frame). Returns the index of the first point with a non-finite time or
    coordinate (the loop stops there), or -1.
    """
    n = t_s.shape[0]
    m = t_rec_s.shape[0]
    t_first = t_rec_s[0]
    t_last = t_rec_s[m - 1]
    k = 0
    ax, ay, az = lever_arm_body_m[0], lever_arm_body_m[1], lever_arm_body_m[2]
    r00, r01, r02 = R_scanner_to_body[0, 0], R_scanner_to_body[0, 1], R_scanner_to_body[0, 2]
    r10, r11, r12 = R_scanner_to_body[1, 0], R_scanner_to_body[1, 1], R_scanner_to_body[1, 2]
    r20, r21, r22 = R_scanner_to_body[2, 0], R_scanner_to_body[2, 1], R_scanner_to_body[2, 2]
    for i in range(n):
        ti = t_s[i]
        sx = xyz_scanner_m[i, 0]
        sy = xyz_scanner_m[i, 1]
        sz = xyz_scanner_m[i, 2]
        if not (
            math.isfinite(ti) and math.isfinite(sx) and math.isfinite(sy) and math.isfinite(sz)
        ):
            return i
        if not (ti >= t_first and ti <= t_last):
            out_ecef_m[i, 0] = np.nan
            out_ecef_m[i, 1] = np.nan
            out_ecef_m[i, 2] = np.nan
            inside[i] = False
            continue
        inside[i] = True
        # Bracket: t_rec[k] <= ti < t_rec[k+1] (k = m-2 at the last record). Monotone
        # cursor for sorted times (same or next interval), binary search otherwise.
        if not (t_rec_s[k] <= ti and (ti < t_rec_s[k + 1] or k == m - 2)):
            if k + 2 < m and t_rec_s[k + 1] <= ti and (ti < t_rec_s[k + 2] or k + 2 == m - 1):
                k += 1
            else:
                lo = 0
                hi = m - 2
                while lo < hi:
                    mid = (lo + hi + 1) // 2
                    if t_rec_s[mid] <= ti:
                        lo = mid
                    else:
                        hi = mid - 1
                k = lo
        s = (ti - t_rec_s[k]) * inv_interval_s[k]
        # Body vector b = a_s + R_s^b · x_s.
        bx = ax + r00 * sx + r01 * sy + r02 * sz
        by = ay + r10 * sx + r11 * sy + r12 * sz
        bz = az + r20 * sx + r21 * sy + r22 * sz
        # Slerp q = q_k ⊗ exp(s · rotvec_k / 2): rotate b by the increment dq = (c, sh·v)
        # first, then by the left record's matrix. cos(a/2) and sin(a/2)/a are even in a:
        # their Taylor series in a² are exact to rounding below a = 0.01 rad (the usual
        # per-record increment), which saves a square root and two transcendentals.
        vx = s * rotvec_interval_body[k, 0]
        vy = s * rotvec_interval_body[k, 1]
        vz = s * rotvec_interval_body[k, 2]
        a2 = vx * vx + vy * vy + vz * vz
        if a2 < 1e-4:
            c = 1.0 - a2 * (1.0 / 8.0 - a2 * (1.0 / 384.0 - a2 * (1.0 / 46080.0)))
            sh = 0.5 - a2 * (1.0 / 48.0 - a2 * (1.0 / 3840.0 - a2 * (1.0 / 645120.0)))
        else:
            a = math.sqrt(a2)
            c = math.cos(0.5 * a)
            sh = math.sin(0.5 * a) / a
        ux = sh * vx
        uy = sh * vy
        uz = sh * vz
        # b' = b + c·t + u × t with t = 2 u × b.
        tx = 2.0 * (uy * bz - uz * by)
        ty = 2.0 * (uz * bx - ux * bz)
        tz = 2.0 * (ux * by - uy * bx)
        ex = bx + c * tx + (uy * tz - uz * ty)
        ey = by + c * ty + (uz * tx - ux * tz)
        ez = bz + c * tz + (ux * ty - uy * tx)
        # Position polynomial (Horner) + R_k · b'.
        out_ecef_m[i, 0] = (
            poly_ecef_m[k, 0, 0]
            + s * (poly_ecef_m[k, 1, 0] + s * (poly_ecef_m[k, 2, 0] + s * poly_ecef_m[k, 3, 0]))
        ) + (
            R_left_body_to_ecef[k, 0, 0] * ex
            + R_left_body_to_ecef[k, 0, 1] * ey
            + R_left_body_to_ecef[k, 0, 2] * ez
        )
        out_ecef_m[i, 1] = (
            poly_ecef_m[k, 0, 1]
            + s * (poly_ecef_m[k, 1, 1] + s * (poly_ecef_m[k, 2, 1] + s * poly_ecef_m[k, 3, 1]))
        ) + (
            R_left_body_to_ecef[k, 1, 0] * ex
            + R_left_body_to_ecef[k, 1, 1] * ey
            + R_left_body_to_ecef[k, 1, 2] * ez
        )
        out_ecef_m[i, 2] = (
            poly_ecef_m[k, 0, 2]
            + s * (poly_ecef_m[k, 1, 2] + s * (poly_ecef_m[k, 2, 2] + s * poly_ecef_m[k, 3, 2]))
        ) + (
            R_left_body_to_ecef[k, 2, 0] * ex
            + R_left_body_to_ecef[k, 2, 1] * ey
            + R_left_body_to_ecef[k, 2, 2] * ez
        )
    return -1


# fastmath "contract" only: multiply-adds may fuse into FMA instructions (about 20 %
# faster on CPUs that have them; each fused result is rounded once instead of twice, so
# outputs can differ from an unfused build by an ulp, ~1e-9 m in ECEF). No other
# fast-math assumption: NaN and infinity checks stay exact.
_georef_kernel = cast(
    Callable[..., int], njit(cache=True, fastmath={"contract"}, nogil=True)(_georef_loop)
)


# ---------------------------------------------------------------------- validation
def _shaped_points(
    t_s: ArrayLike, xyz_scanner_m: ArrayLike, what: str = "georeference"
) -> tuple[FloatArray, FloatArray]:
    try:
        t = np.ascontiguousarray(t_s, dtype=np.float64)
        xyz = np.ascontiguousarray(xyz_scanner_m, dtype=np.float64)
    except (TypeError, ValueError) as err:
        msg = f"{what}: point times and coordinates must be numbers ({err})"
        raise InputError(msg) from err
    if t.ndim != 1:
        msg = f"{what}: point times t_s must be 1-D, got shape {t.shape}"
        raise InputError(msg)
    if xyz.shape != (t.size, 3):
        msg = f"{what}: xyz_scanner_m must have shape ({t.size}, 3) to match t_s, got {xyz.shape}"
        raise InputError(msg)
    return t, xyz


def _raise_not_finite(t: FloatArray, xyz: FloatArray, what: str = "georeference") -> None:
    """Raise `InputError` naming the first non-finite point time or coordinate, if any."""
    bad_t = ~np.isfinite(t)
    if np.any(bad_t):
        row = int(np.flatnonzero(bad_t)[0])
        msg = (
            f"{what}: point time at index {row} is not finite ({float(t[row])!r}); "
            f"{int(np.count_nonzero(bad_t))} such point(s): drop or fix them"
        )
        raise InputError(msg)
    bad_xyz = ~np.all(np.isfinite(xyz), axis=1)
    if np.any(bad_xyz):
        row = int(np.flatnonzero(bad_xyz)[0])
        msg = (
            f"{what}: scanner coordinates at index {row} are not finite (point {row} of "
            f"{t.size}: {xyz[row].tolist()}); {int(np.count_nonzero(bad_xyz))} such point(s): "
            "drop or fix them"
        )
        raise InputError(msg)


def validated_scanner_points(
    t_s: ArrayLike, xyz_scanner_m: ArrayLike, what: str = "georeference"
) -> tuple[FloatArray, FloatArray]:
    """Point times (N,) and scanner-frame coordinates (N, 3) as finite float64 arrays.

    Raises `InputError`, prefixed with ``what``, naming the first bad shape or point.
    """
    t, xyz = _shaped_points(t_s, xyz_scanner_m, what)
    _raise_not_finite(t, xyz, what)
    return t, xyz


def _use_hermite(traj: GeorefTrajectory, position: str) -> bool:
    if position not in ("auto", "linear", "hermite"):
        msg = f"georeference: position method must be auto, linear or hermite, got {position!r}"
        raise InputError(msg)
    if position == "hermite" and traj.vel_ecef_m_s is None:
        msg = (
            "georeference: Hermite position interpolation needs trajectory velocities "
            "(vel_ned_m_s); use position='linear' or a trajectory with velocities"
        )
        raise InputError(msg)
    return position == "hermite" or (position == "auto" and traj.vel_ecef_m_s is not None)


def _check_latency(traj: GeorefTrajectory, mount: Mount) -> None:
    if abs(traj.latency_s - mount.latency_s) > _LATENCY_MATCH_TOL_S:
        msg = (
            f"georeference: the trajectory was corrected for latency {traj.latency_s!r} s but "
            f"the mount says {mount.latency_s!r} s; build it with "
            "GeorefTrajectory.from_trajectory(trajectory, latency_s=mount.latency_s)"
        )
        raise InputError(msg)


# ---------------------------------------------------------------------- public API
def georeference(
    t_s: ArrayLike,
    xyz_scanner_m: ArrayLike,
    traj: GeorefTrajectory,
    mount: Mount,
    *,
    position: PositionMethod = "auto",
) -> tuple[FloatArray, BoolArray]:
    """Georeference scanner points into ECEF (compiled kernel, one thread).

    Parameters
    ----------
    t_s : array_like, shape (N,)
        Point times (s) on the scanner's time scale, any order (sorted is fastest).
    xyz_scanner_m : array_like, shape (N, 3)
        Points in the scanner frame (m).
    traj : GeorefTrajectory
        Precomputed trajectory, corrected for ``mount.latency_s``.
    mount : Mount
        Lever arm (m, body frame FRD), boresight scanner -> body and latency (s).
    position : {"auto", "linear", "hermite"}
        Position interpolation: linear, or cubic Hermite with the ECEF velocities
        ("auto" picks Hermite when velocities exist).

    Returns
    -------
    pos_ecef_m : ndarray, shape (N, 3)
        Georeferenced points, ECEF (m); NaN where outside the trajectory's span.
    inside : ndarray of bool, shape (N,)
        True where the point time lies within ``[traj.t_start_s, traj.t_end_s]``.

    Raises
    ------
    InputError
        Non-finite times or coordinates, mismatched shapes, Hermite without
        velocities, or a mount latency that differs from the trajectory's.
    """
    t, xyz = _shaped_points(t_s, xyz_scanner_m)
    _check_latency(traj, mount)
    hermite = _use_hermite(traj, position)
    out = np.empty((t.size, 3))
    inside = np.empty(t.size, dtype=np.bool_)
    first_bad = _georef_kernel(
        t,
        xyz,
        traj.t_s,
        traj._inv_interval_s,
        traj._poly_hermite if hermite else traj._poly_linear,
        traj._R_body_to_ecef_left,
        traj.rotvec_interval_body,
        np.ascontiguousarray(mount.lever_arm_body_m_array),
        np.ascontiguousarray(mount.R_scanner_to_body),
        out,
        inside,
    )
    if first_bad >= 0:
        _raise_not_finite(t, xyz)
    return out, inside


def georeference_numpy(
    t_s: ArrayLike,
    xyz_scanner_m: ArrayLike,
    traj: GeorefTrajectory,
    mount: Mount,
    *,
    position: PositionMethod = "auto",
) -> tuple[FloatArray, BoolArray]:
    """Georeference scanner points into ECEF, vectorised numpy (the reference).

    The straightforward implementation of the same chain through
    `Trajectory.interpolate` (position in the trajectory's own coordinates, attitude
    slerped body -> NED, then rotated to ECEF at the interpolated position); kept as
    the reference for the kernel and as the benchmark baseline. Parameters, returns
    and errors as in `georeference`.
    """
    t, xyz = validated_scanner_points(t_s, xyz_scanner_m)
    _check_latency(traj, mount)
    hermite = _use_hermite(traj, position)
    sample = traj.trajectory.interpolate(
        t, position="hermite" if hermite else "linear", mask_outside=True
    )
    inside = sample.inside
    out = np.full((t.size, 3), np.nan)
    if not np.any(inside):
        return out, inside
    body = mount.lever_arm_body_m_array + xyz[inside] @ mount.R_scanner_to_body.T
    R_bn = sample.R_body_to_ned[inside]
    if sample.lat_lon_h is not None:
        llh = sample.lat_lon_h[inside]
        R_ne = rotation_ned_to_ecef(llh[:, 0], llh[:, 1])
        R_be = np.einsum("nij,njk->nik", R_ne, R_bn)
    else:
        assert sample.origin_lat_lon_h is not None
        lat0, lon0, _ = sample.origin_lat_lon_h
        R_be = np.einsum("ij,njk->nik", rotation_ned_to_ecef(lat0, lon0), R_bn)
    out[inside] = sample.pos_ecef_m()[inside] + np.einsum("nij,nj->ni", R_be, body)
    return out, inside


# ---------------------------------------------------------------------- file pipeline
OutsidePolicy = Literal["error", "reject"]
TimeScale = Literal["gps", "week"]

_LAS_SUFFIXES = (".las", ".laz")
_TABLE_SUFFIXES = (".csv", ".parquet")
_XYZ_COLUMNS = ("x_m", "y_m", "z_m")
_OUT_COLUMNS = ("X", "Y", "Z")
_ECEF_CRS = "EPSG:4978"
_LAS_SCALE_M = 1e-4
_LAS_SCALE_DEG = 1e-7
_LAS_OFFSET_ROUND = 1000.0
_LAS_BLOCK_POINTS = 65_536  # LAS chunks are georeferenced this many points at a time


@dataclass(frozen=True)
class GeorefSummary:
    """Accounting of one georeferencing run over a file.

    Attributes
    ----------
    points_in : int
        Points read.
    points_out : int
        Points georeferenced and written to the output.
    points_rejected : int
        Points outside the trajectory's span written to the rejected file.
    seconds : float
        Wall-clock time of the run (s).
    rejected_path : Path or None
        The rejected-points file, when one was written.
    """

    points_in: int
    points_out: int
    points_rejected: int
    seconds: float
    rejected_path: Path | None = None

    @property
    def points_per_s(self) -> float:
        """Throughput, points read per second."""
        return self.points_in / self.seconds if self.seconds > 0.0 else math.inf

    def as_document(self) -> dict[str, int | float]:
        """The ``--json`` summary of ``kinsync georef``."""
        return {
            "points_in": self.points_in,
            "points_out": self.points_out,
            "points_rejected": self.points_rejected,
            "seconds": self.seconds,
            "points_per_s": self.points_per_s,
        }


def read_trajectory_file(
    path: Path, *, gps_week: int | None = None
) -> tuple[Trajectory, TimeScale]:
    """Read a trajectory (CSV, or SBET ``.out``/``.sbet``) and say its time scale.

    Parameters
    ----------
    path : Path
        ``.csv`` (`kinsync.io.trajectory_csv`), or an SBET file (``.out``, ``.sbet``).
    gps_week : int, optional
        GPS week of an SBET's first record: its seconds of week become GPS time.

    Returns
    -------
    trajectory : Trajectory
    time_scale : {"gps", "week"}
        "week" for an SBET read without ``gps_week`` (GPS seconds of week), else "gps".

    Raises
    ------
    InputError
        Unknown suffix, or any error of the readers.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".csv":
        return read_trajectory_csv(path), "gps"
    if suffix in (".out", ".sbet"):
        return read_sbet(path, gps_week=gps_week), ("week" if gps_week is None else "gps")
    msg = f"{path}: unknown trajectory type {path.suffix!r}; use .csv or an SBET (.out, .sbet)"
    raise InputError(msg)


def rejected_path_for(out_path: Path) -> Path:
    """``OUT.rejected.<ext>``: where points outside the trajectory span go."""
    out_path = Path(out_path)
    return out_path.with_name(f"{out_path.stem}.rejected{out_path.suffix}")


@lru_cache(maxsize=8)
def _ecef_transformer(crs: str) -> Callable[[FloatArray], FloatArray] | None:
    """ECEF -> ``crs`` (axis order easting/longitude first), or None for ECEF itself."""
    try:
        target = pyproj.CRS.from_user_input(crs)
    except pyproj.exceptions.CRSError as err:
        msg = f"--crs {crs!r}: unknown coordinate reference system ({err}); e.g. EPSG:4978"
        raise InputError(msg) from err
    if target == pyproj.CRS.from_epsg(4978):
        return None
    transformer = pyproj.Transformer.from_crs(pyproj.CRS.from_epsg(4978), target, always_xy=True)

    def apply(pos_ecef_m: FloatArray) -> FloatArray:
        x, y, z = transformer.transform(pos_ecef_m[:, 0], pos_ecef_m[:, 1], pos_ecef_m[:, 2])
        return np.column_stack([x, y, z]).astype(np.float64)

    return apply


class _OutsideTally:
    """Counts and time range of points outside the span."""

    def __init__(self) -> None:
        self.count = 0
        self.t_min_s = math.inf
        self.t_max_s = -math.inf

    def add(self, count: int, t_min_s: float, t_max_s: float) -> None:
        if count:
            self.count += count
            self.t_min_s = min(self.t_min_s, t_min_s)
            self.t_max_s = max(self.t_max_s, t_max_s)

    def error(self, points_path: Path, traj: GeorefTrajectory, out_path: Path) -> InputError:
        msg = (
            f"{points_path}: {self.count} point(s) with times {self.t_min_s!r} .. "
            f"{self.t_max_s!r} s lie outside the trajectory span [{traj.t_start_s!r}, "
            f"{traj.t_end_s!r}] s (latency {traj.latency_s!r} s applied); kinsync does not "
            "extrapolate: give a trajectory that covers them, check the time scales "
            f"(--gps-week), or pass --outside reject to write them to "
            f"{rejected_path_for(out_path)}"
        )
        return InputError(msg)


def _las_time_offset_s(
    path: Path, header: Any, scale: str, traj_scale: TimeScale, gps_week: int | None
) -> float:
    """What to add to a LAS file's ``gps_time`` to reach the trajectory's time scale."""
    if "gps_time" not in header.point_format.dimension_names:
        msg = (
            f"{path}: point format {header.point_format.id} has no gps_time; georeferencing "
            "needs a time per point"
        )
        raise InputError(msg)
    if scale == "adjusted_standard":
        if traj_scale == "week":
            msg = (
                f"{path}: the points carry adjusted standard GPS time, the trajectory GPS "
                "seconds of week; give --gps-week so that kinsync can put both on GPS time"
            )
            raise InputError(msg)
        return ADJUSTED_GPS_OFFSET_S
    if traj_scale == "gps":
        if gps_week is None:
            msg = (
                f"{path}: the points carry GPS seconds of week, the trajectory GPS time; "
                "give --gps-week so that kinsync can put both on GPS time"
            )
            raise InputError(msg)
        return gps_week * SECONDS_PER_WEEK
    return 0.0


# ---------------------------------------------------------------------- profile points
_PROFILE_COLUMNS = ("range_m", "angle_rad")


def profile_points_to_scanner(
    range_m: ArrayLike, angle_rad: ArrayLike, mount: Mount, what: str = "georeference"
) -> FloatArray:
    """2D profile points (range, mirror angle) in the scanner frame, validated.

    ``Rz(azimuth) · (0, r sin phi, r cos phi)`` (`Mount.profile_to_scanner`, SPEC
    sections 4 and 5) with the mount's ``[profiler] azimuth_deg``.

    Parameters
    ----------
    range_m : array_like, shape (N,)
        Ranges (m), finite and >= 0.
    angle_rad : array_like, shape (N,)
        Mirror angles phi from the scanner's Z axis, positive towards +Y (rad), finite.
    mount : Mount
        Must have ``profiler_azimuth_deg`` (the ``[profiler]`` table).
    what : str
        Prefix of error messages.

    Returns
    -------
    ndarray, shape (N, 3)
        Points in the scanner frame (m).

    Raises
    ------
    InputError
        No profiler azimuth in the mount, mismatched shapes, non-finite values, a
        negative range (each naming the first bad index).
    """
    if mount.profiler_azimuth_deg is None:
        msg = (
            f"{what}: profile points need the profiler azimuth: add [profiler] azimuth_deg "
            "to the mount (or pass --profiler-azimuth-deg)"
        )
        raise InputError(msg)
    try:
        r = np.ascontiguousarray(range_m, dtype=np.float64)
        phi = np.ascontiguousarray(angle_rad, dtype=np.float64)
    except (TypeError, ValueError) as err:
        msg = f"{what}: ranges and angles must be numbers ({err})"
        raise InputError(msg) from err
    if r.ndim != 1 or phi.shape != r.shape:
        msg = f"{what}: range_m and angle_rad must be 1-D of one length, got {r.shape}, {phi.shape}"
        raise InputError(msg)
    bad = ~(np.isfinite(r) & np.isfinite(phi))
    if np.any(bad):
        i = int(np.flatnonzero(bad)[0])
        msg = (
            f"{what}: range_m/angle_rad at index {i} not finite ({float(r[i])!r}, "
            f"{float(phi[i])!r}); {int(np.count_nonzero(bad))} such point(s): drop or fix them"
        )
        raise InputError(msg)
    negative = r < 0.0
    if np.any(negative):
        i = int(np.flatnonzero(negative)[0])
        msg = (
            f"{what}: range_m at index {i} is negative ({float(r[i])!r}); "
            f"{int(np.count_nonzero(negative))} such point(s): a range is >= 0"
        )
        raise InputError(msg)
    return mount.profile_to_scanner(phi, r)


def georeference_profile(
    t_s: ArrayLike,
    range_m: ArrayLike,
    angle_rad: ArrayLike,
    traj: GeorefTrajectory,
    mount: Mount,
    *,
    position: PositionMethod = "auto",
) -> tuple[FloatArray, BoolArray]:
    """Georeference 2D profile points (SPEC section 5 with ``R_2d^s``) into ECEF.

    Parameters
    ----------
    t_s : array_like, shape (N,)
        Point times (s) on the scanner's time scale.
    range_m, angle_rad : array_like, shape (N,)
        Range (m) and mirror angle (rad), see `profile_points_to_scanner`.
    traj : GeorefTrajectory
        Precomputed trajectory, corrected for ``mount.latency_s``.
    mount : Mount
        Lever arm, boresight, latency and ``profiler_azimuth_deg`` (required).
    position : {"auto", "linear", "hermite"}
        Position interpolation (see `georeference`).

    Returns
    -------
    pos_ecef_m : ndarray, shape (N, 3)
        Georeferenced points, ECEF (m); NaN where outside the trajectory's span.
    inside : ndarray of bool, shape (N,)
        True where the point time lies within the trajectory's span.

    Raises
    ------
    InputError
        As `profile_points_to_scanner` and `georeference`.
    """
    xyz = profile_points_to_scanner(range_m, angle_rad, mount)
    return georeference(t_s, xyz, traj, mount, position=position)


# ---------------------------------------------------------------------- chunk tasks
_DASK_CONNECT_TIMEOUT_S = 10.0
_CHUNKS_IN_FLIGHT_PER_WORKER = 2

PointColumns = Literal["auto", "xyz", "profile"]


@dataclass(frozen=True, eq=False)
class _Source:
    """The input file as every worker reads it."""

    path: Path
    points: Literal["xyz", "profile"]
    table: TableLayout | None = None  # None for LAS/LAZ
    las_time_offset_s: float = 0.0  # added to LAS gps_time


@dataclass(frozen=True)
class LasOutputFrame:
    """Offsets and scales of a georeferenced LAS/LAZ output.

    Attributes
    ----------
    offsets : tuple of 3 float
        x, y, z header offsets (output CRS units).
    scales : tuple of 3 float
        x, y, z resolution (output CRS units): 1e-4 m for ECEF and projected CRSs;
        1e-7 deg for longitude/latitude and 1e-4 m for the height of geographic ones.
    """

    offsets: tuple[float, float, float]
    scales: tuple[float, float, float]


@dataclass(frozen=True, eq=False)
class _ChunkContext:
    """What every worker holds once: input, trajectory, mount and options."""

    source: _Source
    traj: GeorefTrajectory
    mount: Mount
    position: PositionMethod
    crs: str
    outside: OutsidePolicy
    csv_text: bool = False  # table output to CSV: workers format the floats as text
    las_frame: LasOutputFrame | None = None  # LAS output: where workers store X, Y, Z


@dataclass(frozen=True)
class _Task:
    """One chunk: points (LAS) or data rows (tables) ``[first, first + count)``."""

    first: int
    count: int
    table_slice: TableSlice | None = None


@dataclass(frozen=True, eq=False)
class _ChunkOutput:
    """What a worker sends back: accounting, and what the main process writes."""

    count: int
    outside_count: int = 0
    outside_t_min_s: float = math.inf
    outside_t_max_s: float = -math.inf
    error: str | None = None
    columns: dict[str, Any] | None = None  # tables: the output rows (CSV: floats as text)
    rejected_columns: dict[str, Any] | None = None
    records: np.ndarray[Any, Any] | None = None  # LAS: inside points, X/Y/Z georeferenced
    rejected_records: np.ndarray[Any, Any] | None = None


def _read_las_task(
    ctx: _ChunkContext, task: _Task, las_reader: LasPointReader | None
) -> laspy.ScaleAwarePointRecord:
    """Read a LAS/LAZ chunk.

    Through ``las_reader`` (kept open between chunks) or, without one, from the file
    opened for this chunk alone, decompressed in this thread.
    """
    if las_reader is not None:
        return las_reader.read(task.first, task.count)
    return read_las_points(ctx.source.path, task.first, task.count, laz_threads=False)


def _scanner_xyz(ctx: _ChunkContext, columns: dict[str, np.ndarray[Any, Any]]) -> FloatArray:
    if ctx.source.points == "profile":
        return profile_points_to_scanner(columns["range_m"], columns["angle_rad"], ctx.mount)
    return np.column_stack([columns[c] for c in _XYZ_COLUMNS])


def _outside_tally_loop(
    t_s: FloatArray, offset_s: float, t_start_s: float, t_end_s: float
) -> tuple[int, float, float]:
    """Points with ``t_s + offset_s`` outside ``[t_start_s, t_end_s]`` (or NaN).

    Their count and the time range of the finite ones, without temporary arrays
    (``t_s`` may be strided).
    """
    count = 0
    t_min = np.inf
    t_max = -np.inf
    for i in range(t_s.shape[0]):
        t = t_s[i] + offset_s
        if not (t >= t_start_s and t <= t_end_s):
            count += 1
            if np.isfinite(t):
                t_min = min(t_min, t)
                t_max = max(t_max, t)
    return count, t_min, t_max


_outside_tally = cast(
    Callable[..., tuple[int, float, float]], njit(cache=True, nogil=True)(_outside_tally_loop)
)


def _tallied(n: int, count: int, t_min_s: float, t_max_s: float) -> _ChunkOutput:
    finite = math.isfinite(t_min_s)
    return _ChunkOutput(
        count=n,
        outside_count=count,
        outside_t_min_s=t_min_s if finite else math.nan,
        outside_t_max_s=t_max_s if finite else math.nan,
    )


def _output_columns(
    ctx: _ChunkContext,
    columns: dict[str, np.ndarray[Any, Any]],
    inside: BoolArray,
    all_inside: bool,
    coords: FloatArray,
) -> dict[str, np.ndarray[Any, Any]]:
    """Every input column (inside rows); x_m,y_m,z_m replaced by X,Y,Z, or X,Y,Z added."""
    out: dict[str, np.ndarray[Any, Any]] = {}
    for name, values in columns.items():
        if ctx.source.points == "xyz" and name in _XYZ_COLUMNS:
            j = _XYZ_COLUMNS.index(name)
            out[_OUT_COLUMNS[j]] = coords[:, j]
        else:
            out[name] = values if all_inside else values[inside]
    if ctx.source.points == "profile":
        for j, name in enumerate(_OUT_COLUMNS):
            out[name] = coords[:, j]
    return out


def _process_task(
    ctx: _ChunkContext, task: _Task, tally_only: bool, las_reader: LasPointReader | None = None
) -> _ChunkOutput:
    """Read and georeference one chunk (in a worker or in the main process).

    Read errors raise; errors of the points themselves (non-finite values) come back
    in ``error`` with the chunk's accounting, so that the main process can still count
    points outside the span after an earlier chunk failed.
    """
    if ctx.source.table is None:
        return _process_las_task(ctx, task, tally_only, las_reader)
    assert task.table_slice is not None
    columns = read_table_slice(ctx.source.table, task.table_slice)
    t = columns["t_s"]
    traj, src = ctx.traj, ctx.source
    base = _tallied(int(t.size), *_outside_tally(t, 0.0, traj.t_start_s, traj.t_end_s))
    if tally_only:
        return base
    try:
        xyz = _scanner_xyz(ctx, columns)
        pos, inside = georeference(t, xyz, traj, ctx.mount, position=ctx.position)
    except InputError as err:
        error = f"{src.path}: rows {task.first}..{task.first + base.count - 1}: {err}"
        return replace(base, error=error)
    all_inside = bool(inside.all())
    if not all_inside and ctx.outside == "error":
        return base
    if not all_inside:
        pos = pos[inside]
    to_crs = _ecef_transformer(ctx.crs)
    coords = pos if to_crs is None else to_crs(pos)
    out_columns = _output_columns(ctx, columns, inside, all_inside, coords)
    rejected = None if all_inside else {k: v[~inside] for k, v in columns.items()}
    if ctx.csv_text:
        out_columns = csv_text_columns(out_columns)
        rejected = None if rejected is None else csv_text_columns(rejected)
    return replace(base, columns=out_columns, rejected_columns=rejected)


def _process_las_task(
    ctx: _ChunkContext, task: _Task, tally_only: bool, las_reader: LasPointReader | None
) -> _ChunkOutput:
    """`_process_task` for LAS/LAZ: georeference in blocks, X, Y, Z stored in place.

    The chunk is processed ``_LAS_BLOCK_POINTS`` at a time, so that no chunk-sized
    float array is made (fresh large arrays cost page faults on every chunk) and the
    blocks stay in cache; the georeferenced coordinates go straight into the records'
    integers with the output's offsets and scales. Points outside the span keep their
    scanner-frame integers (they are written unchanged to the rejected file).
    """
    record = _read_las_task(ctx, task, las_reader)
    traj, src, frame = ctx.traj, ctx.source, ctx.las_frame
    assert frame is not None
    array = record.array
    gps_time = array["gps_time"]
    n = len(array)
    base = _tallied(
        n, *_outside_tally(gps_time, src.las_time_offset_s, traj.t_start_s, traj.t_end_s)
    )
    if tally_only:
        return base
    to_crs = _ecef_transformer(ctx.crs)
    inside = np.empty(n, dtype=np.bool_)
    for start in range(0, n, _LAS_BLOCK_POINTS):
        block = array[start : start + _LAS_BLOCK_POINTS]
        t = gps_time[start : start + _LAS_BLOCK_POINTS] + src.las_time_offset_s
        xyz = scaled_coordinates(block, record.scales, record.offsets)
        try:
            pos, block_inside = georeference(t, xyz, traj, ctx.mount, position=ctx.position)
        except InputError as err:
            return replace(base, error=_las_chunk_error(ctx, task, record, err))
        coords = pos if to_crs is None else to_crs(pos)
        bad = store_coordinates(block, coords, frame.offsets, frame.scales, block_inside)
        if bad >= 0:
            return replace(
                base, error=_las_storage_error(ctx, task.first + start + bad, coords[bad])
            )
        inside[start : start + len(block)] = block_inside
    all_inside = bool(inside.all())
    if not all_inside and ctx.outside == "error":
        return base
    return replace(
        base,
        records=array if all_inside else array[inside],
        rejected_records=None if all_inside else array[~inside],
    )


def _las_chunk_error(ctx: _ChunkContext, task: _Task, record: Any, err: InputError) -> str:
    """The message for a LAS chunk that failed to georeference.

    It names the first non-finite point by its index in the chunk (the failing block's
    own error names its index in the block).
    """
    t = np.asarray(record.gps_time, dtype=np.float64) + ctx.source.las_time_offset_s
    xyz = scaled_coordinates(record.array, record.scales, record.offsets)
    try:
        _raise_not_finite(t, xyz)
    except InputError as chunk_err:
        err = chunk_err
    return f"{ctx.source.path}: points {task.first}..{task.first + t.size - 1}: {err}"


def _las_storage_error(ctx: _ChunkContext, index: int, coords: FloatArray) -> str:
    frame = ctx.las_frame
    assert frame is not None
    reach = [2.0**31 * s for s in frame.scales]
    return (
        f"{ctx.source.path}: point {index} georeferences to {coords.tolist()} ({ctx.crs}), "
        f"beyond what LAS integers hold at offsets {list(frame.offsets)} and scales "
        f"{list(frame.scales)} (± {reach} around the offsets, chosen at the middle of the "
        "file's time span); split the file into shorter spans"
    )


_WORKER_CONTEXT: list[_ChunkContext] = []
_WORKER_LAS_READER: list[LasPointReader] = []


def _init_process_worker(ctx: _ChunkContext) -> None:
    """Process-pool initializer: keep the context for every chunk of this worker."""
    _WORKER_CONTEXT[:] = [ctx]
    _WORKER_LAS_READER.clear()


def _process_task_in_process(task: _Task, tally_only: bool) -> _ChunkOutput:
    """A pool worker's task; a LAS/LAZ input stays open in the worker between chunks.

    LAZ is decompressed in the worker's own thread: the pool is the parallelism.
    """
    ctx = _WORKER_CONTEXT[0]
    if ctx.source.table is None and not _WORKER_LAS_READER:
        _WORKER_LAS_READER.append(LasPointReader(ctx.source.path, laz_threads=False))
    reader = _WORKER_LAS_READER[0] if _WORKER_LAS_READER else None
    return _process_task(ctx, task, tally_only, reader)


_ChunkResult = Callable[[], _ChunkOutput]


class _Runner:
    """Serial, in-process: each chunk is read and computed when its result is asked for.

    A LAS/LAZ input stays open between chunks (read in order, without seeking) and is
    decompressed with lazrs's thread pool.
    """

    window = 1

    def __init__(self, ctx: _ChunkContext) -> None:
        self.ctx = ctx
        self._las_reader: LasPointReader | None = None

    def _reader(self) -> LasPointReader | None:
        if self.ctx.source.table is None and self._las_reader is None:
            self._las_reader = LasPointReader(self.ctx.source.path)
        return self._las_reader

    def submit(self, task: _Task, tally_only: bool) -> _ChunkResult:
        return lambda: _process_task(self.ctx, task, tally_only, self._reader())

    def close(self) -> None:
        """Close the input file, if open."""
        if self._las_reader is not None:
            self._las_reader.close()
            self._las_reader = None


class _ProcessRunner(_Runner):
    """A local process pool; the context is shipped once per worker (initializer)."""

    def __init__(self, ctx: _ChunkContext, workers: int) -> None:
        super().__init__(ctx)
        methods = multiprocessing.get_all_start_methods()
        mp_context = multiprocessing.get_context(
            "forkserver" if "forkserver" in methods else "spawn"
        )
        self.window = _CHUNKS_IN_FLIGHT_PER_WORKER * workers
        self.pool = ProcessPoolExecutor(
            max_workers=workers,
            mp_context=mp_context,
            initializer=_init_process_worker,
            initargs=(ctx,),
        )

    def submit(self, task: _Task, tally_only: bool) -> _ChunkResult:
        future: Future[_ChunkOutput] = self.pool.submit(_process_task_in_process, task, tally_only)
        return future.result

    def close(self) -> None:
        self.pool.shutdown(wait=True, cancel_futures=True)


class _DaskRunner(_Runner):
    """An existing dask.distributed scheduler; the context is broadcast once."""

    def __init__(self, ctx: _ChunkContext, address: str, workers: int | None) -> None:
        super().__init__(ctx)
        try:
            distributed: Any = importlib.import_module("dask.distributed")  # optional extra
        except ImportError as err:
            msg = (
                f"--scheduler {address} needs dask.distributed, which is not installed; "
                "install kinsync[scale] (pip install 'kinsync[scale]') or use "
                "--scheduler local|processes"
            )
            raise InputError(msg) from err
        try:
            self.client: Any = distributed.Client(address, timeout=_DASK_CONNECT_TIMEOUT_S)
        except (OSError, TimeoutError, ValueError) as err:
            reason = str(err).splitlines()[0] if str(err) else type(err).__name__
            msg = (
                f"cannot reach the Dask scheduler at {address} ({reason}); start one with "
                "'dask scheduler' and workers with 'dask worker ADDRESS', or use "
                "--scheduler local|processes"
            )
            raise InputError(msg) from err
        n_workers = workers or max(1, len(self.client.scheduler_info().get("workers", {})))
        self.window = _CHUNKS_IN_FLIGHT_PER_WORKER * n_workers
        self.ctx_future = self.client.scatter(ctx, broadcast=True)

    def submit(self, task: _Task, tally_only: bool) -> _ChunkResult:
        future = self.client.submit(_process_task, self.ctx_future, task, tally_only, pure=False)

        def result() -> _ChunkOutput:
            out: _ChunkOutput = future.result()
            return out

        return result

    def close(self) -> None:
        self.client.close()


def _make_runner(ctx: _ChunkContext, scheduler: str, workers: int | None) -> _Runner:
    if workers is not None and workers < 1:
        msg = f"--workers must be >= 1, got {workers}"
        raise InputError(msg)
    if scheduler == "local":
        return _Runner(ctx)
    if scheduler == "processes":
        return _ProcessRunner(ctx, workers or multiprocessing.cpu_count())
    if scheduler.startswith(("tcp://", "tls://")):
        return _DaskRunner(ctx, scheduler, workers)
    msg = f"--scheduler must be local, processes or tcp://HOST:PORT, got {scheduler!r}"
    raise InputError(msg)


def _in_order(
    tasks: Sequence[_Task], runner: _Runner, tally_only: Callable[[], bool]
) -> Iterator[_ChunkResult]:
    """Submit chunks ahead (at most ``runner.window`` in flight); yield them in input order.

    Each chunk's error is raised (by its result) only when its place in the input is
    reached, so that every run reports the same first error as the serial one.
    """
    pending: deque[_ChunkResult] = deque()
    upcoming = iter(tasks)
    more = True
    while True:
        while more and len(pending) < runner.window:
            task = next(upcoming, None)
            if task is None:
                more = False
            else:
                pending.append(runner.submit(task, tally_only()))
        if not pending:
            return
        yield pending.popleft()


# ---------------------------------------------------------------------- file pipeline
def georeference_file(
    points_path: Path,
    trajectory_path: Path,
    mount: Mount,
    out_path: Path,
    *,
    crs: str = _ECEF_CRS,
    chunk_points: int = 1_000_000,
    outside: OutsidePolicy = "error",
    gps_week: int | None = None,
    position: PositionMethod = "auto",
    progress: Callable[[int, int | None], None] | None = None,
    scheduler: str = "local",
    workers: int | None = None,
    point_columns: PointColumns = "auto",
    profiler_azimuth_deg: float | None = None,
) -> GeorefSummary:
    """Georeference a point file chunk by chunk into ``out_path`` (streaming, atomic).

    Parameters
    ----------
    points_path : Path
        Scanner-frame points: ``.las``/``.laz`` (x, y, z in the scanner frame, time in
        ``gps_time``), or ``.csv``/``.parquet`` with columns ``t_s,x_m,y_m,z_m``
        (scanner frame) or ``t_s,range_m,angle_rad`` (2D profile scanner: range and
        mirror angle, see `profile_points_to_scanner`), + any others, carried through.
    trajectory_path : Path
        Trajectory CSV or SBET (see `read_trajectory_file`).
    mount : Mount
        Lever arm, boresight and latency (the latency is applied, SPEC section 1), and
        for profile files the ``[profiler] azimuth_deg``.
    out_path : Path
        Output; format from the suffix. LAS/LAZ input goes to ``.las``/``.laz`` with
        every attribute and VLR kept; table input to ``.csv``/``.parquet`` with every
        input column kept and the coordinates in ``crs`` as ``X,Y,Z`` (replacing
        ``x_m,y_m,z_m`` in place, or appended after the columns of a profile file).
    crs : str
        Output CRS (pyproj user input), default ECEF ``EPSG:4978``.
    chunk_points : int
        Points per chunk (bounds memory): exact for LAS/LAZ and CSV (the last chunk
        fewer), at most this many for Parquet (chunks follow its row groups).
    outside : {"error", "reject"}
        Points outside the trajectory span: an error naming how many and their time
        range (nothing written), or written unchanged to ``OUT.rejected.<ext>``.
    gps_week : int, optional
        GPS week for SBET and LAS seconds-of-week times (see `read_trajectory_file`).
    position : {"auto", "linear", "hermite"}
        Position interpolation (see `georeference`).
    progress : callable, optional
        Called after each chunk with (points done, total points or None).
    scheduler : str
        Where chunks are read and georeferenced: ``"local"`` (in this process,
        serial), ``"processes"`` (a local process pool) or ``"tcp://HOST:PORT"`` (an
        existing dask.distributed scheduler, extra ``kinsync[scale]``; its workers must
        be able to read ``points_path``). Each worker reads its own chunks (LAS/LAZ by
        seek, CSV by byte range, Parquet by row group) and sends back what to write;
        this process only writes, in input order, so the output is identical to the
        serial run. The trajectory is shipped once per worker.
    workers : int, optional
        Processes of the pool (default: the CPU count); for a Dask scheduler, the
        workers to keep busy (default: those connected). At most two chunks per worker
        are in flight.
    point_columns : {"auto", "xyz", "profile"}
        Which columns of a table give the points: ``x_m,y_m,z_m`` or
        ``range_m,angle_rad``; "auto" takes the set the file has (both is an error:
        choose one).
    profiler_azimuth_deg : float, optional
        Azimuth (deg) of the profile plane in the scanner frame, replacing the
        mount's ``[profiler] azimuth_deg`` (profile files only).

    Returns
    -------
    GeorefSummary

    Raises
    ------
    InputError
        Unknown suffixes or unsupported input/output pair, missing or ambiguous
        columns, a profile file without an azimuth, NaN points, mixed time scales,
        points outside the span (with ``outside="error"``).
    """
    start = time.perf_counter()
    points_path, out_path = Path(points_path), Path(out_path)
    if outside not in ("error", "reject"):
        msg = f"--outside must be error or reject, got {outside!r}"
        raise InputError(msg)
    if chunk_points < 1:
        msg = f"--chunk-points must be >= 1, got {chunk_points}"
        raise InputError(msg)
    if point_columns not in ("auto", "xyz", "profile"):
        msg = f"--point-columns must be auto, xyz or profile, got {point_columns!r}"
        raise InputError(msg)
    in_suffix, out_suffix = points_path.suffix.lower(), out_path.suffix.lower()
    if in_suffix not in _LAS_SUFFIXES + _TABLE_SUFFIXES:
        msg = (
            f"{points_path}: unknown point file type {points_path.suffix!r}; "
            "use .las, .laz, .csv or .parquet"
        )
        raise InputError(msg)
    if out_suffix not in _LAS_SUFFIXES + _TABLE_SUFFIXES:
        msg = (
            f"{out_path}: unknown output type {out_path.suffix!r}; use .las, .laz, .csv or .parquet"
        )
        raise InputError(msg)
    if (in_suffix in _LAS_SUFFIXES) != (out_suffix in _LAS_SUFFIXES):
        msg = (
            f"{out_path}: {in_suffix} input can be written to "
            f"{'.las/.laz' if in_suffix in _LAS_SUFFIXES else '.csv/.parquet'} only "
            "(conversion between LAS and tables is not supported yet)"
        )
        raise InputError(msg)
    if not points_path.is_file():
        msg = f"{points_path}: file not found"
        raise InputError(msg)
    trajectory, traj_scale = read_trajectory_file(trajectory_path, gps_week=gps_week)
    traj = GeorefTrajectory.from_trajectory(trajectory, latency_s=mount.latency_s)
    _use_hermite(traj, position)
    _check_latency(traj, mount)
    _ecef_transformer(crs)  # a bad --crs fails here, before any output
    template: Any = None
    las_frame: LasOutputFrame | None = None
    if in_suffix in _LAS_SUFFIXES:
        if point_columns == "profile" or profiler_azimuth_deg is not None:
            msg = (
                f"{points_path}: LAS/LAZ points are x, y, z in the scanner frame; "
                "--point-columns profile and --profiler-azimuth-deg apply to CSV/Parquet "
                "tables with range_m,angle_rad"
            )
            raise InputError(msg)
        template, source, tasks, total = _plan_las(points_path, chunk_points, traj_scale, gps_week)
        las_frame = _las_output_frame(source, total, traj, crs)
    else:
        source, tasks, total, mount = _plan_table(
            points_path, chunk_points, mount, point_columns, profiler_azimuth_deg
        )
    ctx = _ChunkContext(
        source, traj, mount, position, crs, outside, out_suffix == ".csv", las_frame
    )
    tally = _OutsideTally()
    with ExitStack() as stack:
        runner = _make_runner(ctx, scheduler, workers)
        stack.callback(runner.close)
        if template is not None:
            counts = _write_las(ctx, template, tasks, total, out_path, progress, tally, runner)
        else:
            counts = _write_table(ctx, tasks, total, out_path, progress, tally, runner)
    points_in, points_out, points_rejected = counts
    return GeorefSummary(
        points_in=points_in,
        points_out=points_out,
        points_rejected=points_rejected,
        seconds=time.perf_counter() - start,
        rejected_path=rejected_path_for(out_path) if points_rejected else None,
    )


def _plan_las(
    path: Path, chunk_points: int, traj_scale: TimeScale, gps_week: int | None
) -> tuple[Any, _Source, list[_Task], int]:
    info = las_info(path)
    with laspy.open(path) as reader:
        template = reader.header
    offset = _las_time_offset_s(path, template, info.gps_time_type, traj_scale, gps_week)
    n = info.point_count
    tasks = [_Task(first, min(chunk_points, n - first)) for first in range(0, n, chunk_points)]
    return template, _Source(path, "xyz", None, offset), tasks, n


def _las_output_frame(
    source: _Source, n_points: int, traj: GeorefTrajectory, crs: str
) -> LasOutputFrame:
    """Offsets and scales for a LAS output: the trajectory at the middle of the file's span.

    The span runs from the first point's time to the last one's (clipped to the
    trajectory; its middle when neither is usable); the offsets are the trajectory's
    position there in ``crs``, rounded (1 km, or 1 degree for longitude and latitude),
    so that a time-ordered file reaches ``2**31`` scale steps (about 214 km at 0.1 mm)
    either way from its middle.
    """
    geographic = pyproj.CRS.from_user_input(crs).is_geographic
    scales = (_LAS_SCALE_DEG, _LAS_SCALE_DEG, _LAS_SCALE_M) if geographic else (_LAS_SCALE_M,) * 3
    ends = las_end_times(source.path) if n_points else None
    times = [
        min(max(t + source.las_time_offset_s, traj.t_start_s), traj.t_end_s)
        for t in (ends or ())
        if math.isfinite(t)
    ]
    t_mid = 0.5 * (min(times) + max(times)) if times else 0.5 * (traj.t_start_s + traj.t_end_s)
    pos = np.array([[np.interp(t_mid, traj.t_s, traj.pos_ecef_m[:, j]) for j in range(3)]])
    to_crs = _ecef_transformer(crs)
    centre = (pos if to_crs is None else to_crs(pos))[0]
    if geographic:
        rounded = [round(centre[0]), round(centre[1]), round(centre[2] / _LAS_OFFSET_ROUND)]
        offsets = (float(rounded[0]), float(rounded[1]), rounded[2] * _LAS_OFFSET_ROUND)
    else:
        r = np.round(centre / _LAS_OFFSET_ROUND) * _LAS_OFFSET_ROUND
        offsets = (float(r[0]), float(r[1]), float(r[2]))
    return LasOutputFrame(offsets=offsets, scales=scales)


def _table_point_set(
    path: Path, names: Sequence[str], point_columns: PointColumns
) -> Literal["xyz", "profile"]:
    has_xyz = all(c in names for c in _XYZ_COLUMNS)
    has_profile = all(c in names for c in _PROFILE_COLUMNS)
    xyz_text, profile_text = ",".join(_XYZ_COLUMNS), ",".join(_PROFILE_COLUMNS)
    if point_columns == "auto":
        if has_xyz and has_profile:
            msg = (
                f"{path}: has both {xyz_text} and {profile_text}; choose which give the "
                "points with --point-columns xyz or --point-columns profile"
            )
            raise InputError(msg)
        if not (has_xyz or has_profile):
            msg = (
                f"{path}: the points need columns t_s with {xyz_text} (scanner frame) or "
                f"t_s with {profile_text} (2D profile); the file has columns {list(names)}"
            )
            raise InputError(msg)
        return "profile" if has_profile else "xyz"
    return point_columns


def _plan_table(
    path: Path,
    chunk_points: int,
    mount: Mount,
    point_columns: PointColumns,
    profiler_azimuth_deg: float | None,
) -> tuple[_Source, list[_Task], int, Mount]:
    names = table_columns(path)
    points = _table_point_set(path, names, point_columns)
    clash = [c for c in _OUT_COLUMNS if c in names]
    if clash:
        msg = (
            f"{path}: column(s) {clash} would clash with the output coordinates "
            f"{','.join(_OUT_COLUMNS)}; rename them"
        )
        raise InputError(msg)
    if points == "profile":
        azimuth = (
            profiler_azimuth_deg if profiler_azimuth_deg is not None else mount.profiler_azimuth_deg
        )
        if azimuth is None:
            msg = (
                f"{path}: a profile file (range_m, angle_rad) needs the profiler azimuth: "
                "add [profiler] azimuth_deg to the mount file or pass --profiler-azimuth-deg"
            )
            raise InputError(msg)
        try:
            mount = replace(mount, profiler_azimuth_deg=azimuth)
        except InputError as err:
            msg = f"--profiler-azimuth-deg: {err}"
            raise InputError(msg) from err
    elif profiler_azimuth_deg is not None:
        msg = (
            f"{path}: --profiler-azimuth-deg applies to profile files (range_m, angle_rad); "
            f"this file gives the points as {','.join(_XYZ_COLUMNS)}"
        )
        raise InputError(msg)
    required = ("t_s", *(_XYZ_COLUMNS if points == "xyz" else _PROFILE_COLUMNS))
    layout, slices = plan_table_slices(path, chunk_points, required)
    tasks = [_Task(s.first_row, s.n_rows, s) for s in slices]
    return _Source(path, points, layout), tasks, layout.total_rows, mount


def _outputs_in_order(
    ctx: _ChunkContext,
    tasks: Sequence[_Task],
    runner: _Runner,
    tally: _OutsideTally,
    out_path: Path,
    progress: Callable[[int, int | None], None] | None,
    total: int,
) -> Iterator[_ChunkOutput]:
    """The chunks to write, in input order; errors raised, outside points accounted.

    With ``outside == "error"`` the first chunk with points outside the span stops the
    writing; the remaining chunks are only read to count such points for the error.
    """
    failing = False
    n_in = 0

    def tally_only() -> bool:
        return failing

    for result in _in_order(tasks, runner, tally_only):
        out = result()
        n_in += out.count
        if not failing and out.error is not None:
            raise InputError(out.error)
        tally.add(out.outside_count, out.outside_t_min_s, out.outside_t_max_s)
        if failing:
            continue
        if out.outside_count and ctx.outside == "error":
            failing = True
            continue
        yield out
        if progress is not None:
            progress(n_in, total)
    if failing:
        raise tally.error(ctx.source.path, ctx.traj, out_path)


class _WriteBehind:
    """Writes run one at a time, in order, in a background thread.

    While a chunk is compressed and written (lazrs, pyarrow and file writes release
    the GIL), the caller reads and georeferences the next one. `submit` first waits for
    the previous write and raises its error, so at most one write is in flight and a
    failed write stops the run at the next chunk. Call `close` before the writers it
    writes to are closed (it waits for a write in flight, without raising), and `wait`
    after the last chunk (it raises the last write's error).
    """

    def __init__(self) -> None:
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="kinsync-write")
        self._pending: Future[None] | None = None

    def submit(self, write: Callable[..., None], *args: Any) -> None:
        self.wait()
        self._pending = self._pool.submit(write, *args)

    def wait(self) -> None:
        pending, self._pending = self._pending, None
        if pending is not None:
            pending.result()

    def close(self) -> None:
        pending, self._pending = self._pending, None
        if pending is not None:
            futures_wait([pending])
        self._pool.shutdown(wait=True)


def _write_table(
    ctx: _ChunkContext,
    tasks: Sequence[_Task],
    total: int,
    out_path: Path,
    progress: Callable[[int, int | None], None] | None,
    tally: _OutsideTally,
    runner: _Runner,
) -> tuple[int, int, int]:
    n_in = n_out = 0
    behind = _WriteBehind()
    with ExitStack() as stack:
        writer = stack.enter_context(TableChunkWriter(out_path))
        stack.callback(behind.close)  # before the writer closes
        rejected: TableChunkWriter | None = None
        for out in _outputs_in_order(ctx, tasks, runner, tally, out_path, progress, total):
            if out.rejected_columns is not None:
                if rejected is None:
                    behind.wait()
                    rejected = stack.enter_context(TableChunkWriter(rejected_path_for(out_path)))
                    stack.callback(behind.close)
                behind.submit(rejected.write, out.rejected_columns)
            assert out.columns is not None
            behind.submit(writer.write, out.columns)
            n_in += out.count
            n_out += out.count - out.outside_count
        behind.wait()
    return n_in, n_out, tally.count


def _write_las(
    ctx: _ChunkContext,
    template: Any,
    tasks: Sequence[_Task],
    total: int,
    out_path: Path,
    progress: Callable[[int, int | None], None] | None,
    tally: _OutsideTally,
    runner: _Runner,
) -> tuple[int, int, int]:
    frame = ctx.las_frame
    assert frame is not None
    n_in = n_out = 0

    def records(array: np.ndarray[Any, Any]) -> laspy.ScaleAwarePointRecord:
        return laspy.ScaleAwarePointRecord(
            array, template.point_format, template.scales, template.offsets
        )

    behind = _WriteBehind()
    with ExitStack() as stack:
        target_crs = pyproj.CRS.from_user_input(ctx.crs)
        writer = stack.enter_context(
            LasChunkWriter(out_path, template, target_crs, frame.offsets, frame.scales)
        )
        stack.callback(behind.close)  # before the writer closes
        rejected: LasChunkWriter | None = None
        for out in _outputs_in_order(ctx, tasks, runner, tally, out_path, progress, total):
            if out.rejected_records is not None:
                if rejected is None:
                    behind.wait()
                    offsets = tuple(float(v) for v in template.offsets)
                    scales = tuple(float(v) for v in template.scales)
                    rejected = stack.enter_context(
                        LasChunkWriter(
                            rejected_path_for(out_path),
                            template,
                            None,
                            offsets,  # type: ignore[arg-type]
                            scales,  # type: ignore[arg-type]
                        )
                    )
                    stack.callback(behind.close)
                behind.submit(rejected.write_stored, records(out.rejected_records))
            assert out.records is not None
            if len(out.records):
                behind.submit(writer.write_stored, records(out.records))
            n_in += out.count
            n_out += len(out.records)
        behind.wait()
    return n_in, n_out, tally.count
