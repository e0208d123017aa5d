"""Direct georeferencing of scanner points: the compiled kernel and its numpy reference.

SPEC section 5::

    x_ecef = p_ecef(t) + R_ned^ecef(lat, lon) · R_b^n(t) · (a_s + R_s^b · x_s)

with the trajectory read at each point's time ``t`` after the latency correction of
SPEC section 1 (a point at ``t`` uses the record tagged ``t + latency_s``), prepared
once as a `kinsync.georef.trajectory.GeorefTrajectory`. The kernel interpolates, per
point, the ECEF position (linear, or cubic Hermite with the ECEF velocities) and the
body -> ECEF attitude by slerp, in one compiled loop (numba, single thread).

Points outside the trajectory's span are never extrapolated, and points strictly inside
a data gap of the trajectory (a record interval longer than
`GeorefTrajectory.max_gap_s`) are not interpolated across it: both come back NaN with
``inside == False`` and the caller decides (error or reject).

References
----------
Shoemake, K., "Animating rotation with quaternion curves", SIGGRAPH 1985 (slerp).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Literal, cast

import numpy as np

from kinsync._jit import cached_njit
from kinsync._typing import ArrayLike, BoolArray, FloatArray
from kinsync._validate import time_array
from kinsync.errors import InputError, PointValueError
from kinsync.frames import (
    rotation_ned_to_ecef,
)
from kinsync.georef.trajectory import GeorefRecords, GeorefTrajectory
from kinsync.mount import Mount

__all__ = [
    "MAX_SCANNER_RANGE_M",
    "PositionMethod",
    "check_latency",
    "georeference",
    "georeference_numpy",
    "point_value_error",
    "prepared_for_points",
    "raise_not_finite_points",
    "span_of",
    "use_hermite",
    "validated_scanner_points",
]

MAX_SCANNER_RANGE_M = 100_000.0
"""Largest scanner-frame coordinate accepted (m): beyond any laser scanner's reach, and a
bound that keeps every georeferenced coordinate finite and meaningful."""

PositionMethod = Literal["auto", "linear", "hermite"]
"""Position interpolation: linear, cubic Hermite with velocities, or Hermite when they exist."""

_LATENCY_MATCH_TOL_S = 1e-12


def _georef_loop(  # noqa: PLR0915 - one flat loop is what numba compiles best
    t_s: FloatArray,
    xyz_scanner_m: FloatArray,
    t_rec_s: FloatArray,
    inv_interval_s: FloatArray,
    poly_ecef_m: FloatArray,
    R_left_body_to_ecef: FloatArray,
    rotvec_interval_body: FloatArray,
    max_interval_s: float,
    lever_arm_body_m: FloatArray,
    R_scanner_to_body: FloatArray,
    out_ecef_m: FloatArray,
    inside: BoolArray,
) -> int:  # pragma: no cover - compiled by numba; its results are tested
    """One pass over the points; compiled with numba below (see `georeference`).

    Per interval k: ``1 / (t[k+1] - t[k])``, position polynomial
    ``c0 + s c1 + s² c2 + s³ c3`` in the interval fraction s (linear or cubic Hermite,
    ECEF), the left record's body -> ECEF matrix and the slerp increment (rotation
    vector, body frame). A point strictly inside an interval longer than
    ``max_interval_s`` (a gap) is outside, as is one outside the records. Returns the
    index of the first point with a non-finite time or
    a coordinate not within ±`MAX_SCANNER_RANGE_M` (the loop stops there), or -1.
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
            math.isfinite(ti)
            and abs(sx) <= MAX_SCANNER_RANGE_M
            and abs(sy) <= MAX_SCANNER_RANGE_M
            and abs(sz) <= MAX_SCANNER_RANGE_M
        ):  # also false for nan and inf
            return i
        if not (ti >= t_first and ti <= t_last):
            out_ecef_m[i, 0] = np.nan
            out_ecef_m[i, 1] = np.nan
            out_ecef_m[i, 2] = np.nan
            inside[i] = False
            continue
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
        if t_rec_s[k + 1] - t_rec_s[k] > max_interval_s and ti > t_rec_s[k]:  # in a gap
            out_ecef_m[i, 0] = np.nan
            out_ecef_m[i, 1] = np.nan
            out_ecef_m[i, 2] = np.nan
            inside[i] = False
            continue
        inside[i] = True
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
    Callable[..., int], cached_njit(fastmath={"contract"}, nogil=True)(_georef_loop)
)


def _read_only(a: FloatArray) -> FloatArray:
    """A read-only view of ``a`` (no copy)."""
    view = a.view()
    view.flags.writeable = False
    return view


def _shaped_points(
    t_s: ArrayLike, xyz_scanner_m: ArrayLike, what: str = "georeference"
) -> tuple[FloatArray, FloatArray]:
    t = np.ascontiguousarray(time_array(t_s, f"{what}: point times t_s"))
    try:
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


def point_value_error(
    what: str, bad: BoolArray, field: str, problem: str, advice: str, n: int
) -> PointValueError:
    """A `PointValueError` for the first of the ``bad`` points (of ``n``)."""
    row = int(np.flatnonzero(bad)[0])
    count = int(np.count_nonzero(bad))
    msg = (
        f"{what}: point at index {row} (0-based, of {n}), {field}: {problem}; "
        f"{count} such point(s): {advice}"
    )
    return PointValueError(msg, index=row, count=count, field=field, problem=problem, advice=advice)


def raise_not_finite_points(t: FloatArray, xyz: FloatArray, what: str = "georeference") -> None:
    """Raise `PointValueError` naming the first bad point (by index), if any.

    A bad point has a non-finite time or coordinate, or a coordinate beyond
    ±`MAX_SCANNER_RANGE_M`.
    """
    bad_t = ~np.isfinite(t)
    if np.any(bad_t):
        row = int(np.flatnonzero(bad_t)[0])
        problem = f"point time {float(t[row])!r} is not finite"
        raise point_value_error(what, bad_t, "t", problem, "drop or fix them", t.size)
    finite = np.isfinite(xyz)
    bad_xyz = ~np.all(finite, axis=1)
    if np.any(bad_xyz):
        row = int(np.flatnonzero(bad_xyz)[0])
        axis = int(np.flatnonzero(~finite[row])[0])
        problem = (
            f"{float(xyz[row, axis])!r} is not finite (scanner coordinates {xyz[row].tolist()})"
        )
        raise point_value_error(what, bad_xyz, "xyz"[axis], problem, "drop or fix them", t.size)
    within = np.abs(xyz) <= MAX_SCANNER_RANGE_M
    far = ~np.all(within, axis=1)
    if np.any(far):
        row = int(np.flatnonzero(far)[0])
        axis = int(np.flatnonzero(~within[row])[0])
        problem = (
            f"scanner coordinates {xyz[row].tolist()} m, beyond the "
            f"{MAX_SCANNER_RANGE_M:.0f} m any laser scanner reaches"
        )
        advice = "are these scanner-frame coordinates in metres?"
        raise point_value_error(what, far, "xyz"[axis], problem, advice, t.size)


def validated_scanner_points(
    t_s: ArrayLike, xyz_scanner_m: ArrayLike, what: str = "georeference"
) -> tuple[FloatArray, FloatArray]:
    """Point times (N,) and scanner-frame coordinates (N, 3) as finite float64 arrays.

    Raises `InputError`, prefixed with ``what``, naming the first bad shape or point.

    Parameters
    ----------
    t_s : array_like, shape (N,)
        Point times (s) on the scanner's time scale.
    xyz_scanner_m : array_like, shape (N, 3)
        Points in the scanner frame (m).
    what : str
        What is being done, the prefix of a message; default ``"georeference"``.

    Returns
    -------
    t_s : ndarray of float64, shape (N,)
        The times, contiguous.
    xyz_scanner_m : ndarray of float64, shape (N, 3)
        The coordinates, contiguous.

    Raises
    ------
    InputError
        Times or coordinates that are not numbers (times: datetime64, text, a float
        dtype too coarse for the times), times not 1-D, or coordinates not of shape
        (N, 3).
    PointValueError
        A non-finite time or coordinate, or a coordinate beyond
        +-`MAX_SCANNER_RANGE_M`, naming the first such point (0-based index).
    """
    t, xyz = _shaped_points(t_s, xyz_scanner_m, what)
    raise_not_finite_points(t, xyz, what)
    return t, xyz


def span_of(t: FloatArray) -> tuple[float, float]:
    """Earliest and latest of point times ``t`` (s), NaN left out (NaN, NaN: none)."""
    t_min, t_max = float(np.min(t, initial=math.inf)), float(np.max(t, initial=-math.inf))
    if math.isnan(t_min) or math.isnan(t_max):  # min and max are NaN when any time is
        t_min = float(np.nanmin(t)) if not np.isnan(t).all() else math.nan
        t_max = float(np.nanmax(t)) if not np.isnan(t).all() else math.nan
    elif t_min > t_max:  # no points
        return math.nan, math.nan
    return t_min, t_max


def prepared_for_points(
    traj: GeorefTrajectory | GeorefRecords, t_s: FloatArray
) -> GeorefTrajectory:
    """The trajectory prepared over the records that points at times ``t_s`` (s) need.

    A `GeorefRecords` prepares the records bracketing the points' span
    (`GeorefRecords.prepared_for`); a `GeorefTrajectory` is prepared already.
    Infinite times count (they lie outside the span either way); NaN ones do not.
    """
    t_min, t_max = span_of(np.asarray(t_s, dtype=np.float64))
    return traj.prepared_for(t_min, t_max)


def use_hermite(traj: GeorefTrajectory | GeorefRecords, position: str) -> bool:
    """Whether ``position`` means cubic Hermite for ``traj``; `InputError` if it cannot."""
    if position not in ("auto", "linear", "hermite"):
        msg = f"georeference: position method must be auto, linear or hermite, got {position!r}"
        raise InputError(msg)
    if position == "hermite" and not traj.has_velocities:
        msg = (
            "georeference: Hermite position interpolation needs trajectory velocities "
            "(vel_ned_m_s); use position='linear' or a trajectory with velocities"
        )
        raise InputError(msg)
    return position == "hermite" or (position == "auto" and traj.has_velocities)


def check_latency(traj: GeorefTrajectory | GeorefRecords, mount: Mount) -> None:
    """Raise `InputError` unless ``traj`` was corrected for ``mount.latency_s``."""
    if not isinstance(traj, (GeorefTrajectory, GeorefRecords)):
        msg = (
            f"georeference traj: expected a GeorefTrajectory, got {type(traj).__name__}; "
            "build it with GeorefTrajectory.from_trajectory(trajectory, "
            "latency_s=mount.latency_s)"
        )
        raise InputError(msg)
    if not isinstance(mount, Mount):
        msg = f"georeference mount: expected a kinsync.Mount, got {type(mount).__name__}"
        raise InputError(msg)
    if abs(traj.latency_s - mount.latency_s) > _LATENCY_MATCH_TOL_S:
        msg = (
            f"georeference: the trajectory was corrected for latency {traj.latency_s!r} s but "
            f"the mount says {mount.latency_s!r} s; build it with "
            "GeorefTrajectory.from_trajectory(trajectory, latency_s=mount.latency_s)"
        )
        raise InputError(msg)


def georeference(
    t_s: ArrayLike,
    xyz_scanner_m: ArrayLike,
    traj: GeorefTrajectory | GeorefRecords,
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
    traj : GeorefTrajectory or GeorefRecords
        Precomputed trajectory, corrected for ``mount.latency_s`` (`GeorefRecords`: the
        records the points need are prepared, `prepared_for_points`).
    mount : Mount
        Lever arm (m, body frame FRD), boresight scanner -> body and latency (s).
    position : {"auto", "linear", "hermite"}
        Position interpolation: linear, or cubic Hermite with the ECEF velocities
        ("auto" picks Hermite when velocities exist).

    Returns
    -------
    pos_ecef_m : ndarray, shape (N, 3)
        Georeferenced points, ECEF (m); NaN where outside the trajectory's span or
        inside one of its gaps.
    inside : ndarray of bool, shape (N,)
        True where the point time lies within ``[traj.t_start_s, traj.t_end_s]`` and
        not strictly inside a gap (`GeorefTrajectory.contains`).

    Raises
    ------
    InputError
        Non-finite times or coordinates, mismatched shapes, Hermite without
        velocities, or a mount latency that differs from the trajectory's.
    """
    t, xyz = _shaped_points(t_s, xyz_scanner_m)
    check_latency(traj, mount)
    hermite = use_hermite(traj, position)
    traj = prepared_for_points(traj, t)
    out = np.empty((t.size, 3))
    inside = np.empty(t.size, dtype=np.bool_)
    # numba compiles read-only and writable inputs apart: every input is passed
    # read-only, whether the caller's arrays are (the points of a whole LAS line, a
    # frozen trajectory) or not (the same trajectory unpickled in a pool worker), so
    # that one compiled kernel serves them all.
    first_bad = _georef_kernel(
        _read_only(t),
        _read_only(xyz),
        _read_only(traj.t_s),
        _read_only(traj._inv_interval_s),
        _read_only(traj._poly_hermite if hermite else traj._poly_linear),
        _read_only(traj._R_body_to_ecef_left),
        _read_only(traj.rotvec_interval_body),
        float(traj.max_gap_s),
        _read_only(np.ascontiguousarray(mount.lever_arm_body_m_array)),
        _read_only(np.ascontiguousarray(mount.R_scanner_to_body)),
        out,
        inside,
    )
    if first_bad >= 0:
        raise_not_finite_points(t, xyz)
    return out, inside


def georeference_numpy(
    t_s: ArrayLike,
    xyz_scanner_m: ArrayLike,
    traj: GeorefTrajectory | GeorefRecords,
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

    Parameters
    ----------
    t_s : array_like, shape (N,)
        Point times (s) on the scanner's time scale, any order.
    xyz_scanner_m : array_like, shape (N, 3)
        Points in the scanner frame (m).
    traj : GeorefTrajectory
        Precomputed trajectory, corrected for ``mount.latency_s``.
    mount : Mount
        Lever arm (m, body frame FRD), boresight scanner -> body and latency (s).
    position : {"auto", "linear", "hermite"}
        Position interpolation: linear, or cubic Hermite with the velocities ("auto",
        the default, picks Hermite when velocities exist).

    Returns
    -------
    pos_ecef_m : ndarray, shape (N, 3)
        Georeferenced points, ECEF (m); NaN where outside the trajectory's span or
        inside one of its gaps.
    inside : ndarray of bool, shape (N,)
        True where the point time lies within ``[traj.t_start_s, traj.t_end_s]`` and
        not strictly inside a gap (`GeorefTrajectory.contains`).

    Raises
    ------
    InputError
        Times or coordinates that are not numbers, mismatched shapes, an unknown
        ``position``, Hermite without velocities, or a mount latency that differs from
        the trajectory's.
    PointValueError
        A non-finite time or coordinate, or a coordinate beyond
        +-`MAX_SCANNER_RANGE_M`, naming the first such point.

    References
    ----------
    Shoemake, K., "Animating rotation with quaternion curves", SIGGRAPH 1985 (slerp).
    """
    t, xyz = validated_scanner_points(t_s, xyz_scanner_m)
    check_latency(traj, mount)
    hermite = use_hermite(traj, position)
    if isinstance(traj, GeorefRecords):  # the reference interpolates the whole trajectory
        traj = traj.prepared_for(-math.inf, math.inf)
    sample = traj.trajectory.interpolate(
        t, position="hermite" if hermite else "linear", mask_outside=True, max_gap_s=traj.max_gap_s
    )
    inside = sample.inside.copy()  # the caller's to change; the sample's is read-only
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
