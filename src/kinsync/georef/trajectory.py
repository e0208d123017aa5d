"""Trajectory preparation for georeferencing (SPEC section 5).

`GeorefTrajectory` precomputes, once per trajectory record, the ECEF position, the
ECEF velocity (when the trajectory has velocities) and the body -> ECEF attitude
``q_body_to_ecef = q(R_ned_to_ecef(lat, lon)) ⊗ q_body_to_ned``, after the latency
correction of SPEC section 1 (a point at ``t`` uses the record tagged
``t + latency_s``). The kernel (`kinsync.georef.kernel`) then interpolates, per point,
the ECEF position and the body -> ECEF attitude by slerp. Slerping the composed
quaternion instead of composing separately interpolated NED and body rotations changes
the attitude by far less than 1e-9 rad at vehicle speeds: the NED frame turns by only
``v·dt/R_earth`` per record (``tests/georef/test_georef.py`` shows it).

Velocities that disagree with the positions (`kinsync.trajectory.check_velocities`:
zero, scaled, swapped or unrotated velocities of a converted file) are dropped here,
with a `kinsync.trajectory.VelocityConsistencyWarning`: the kernel then interpolates
positions linearly, as for a trajectory without velocities, and
`GeorefTrajectory.velocity_warning` keeps the reason.

Data gaps (`kinsync.trajectory_gaps.trajectory_gaps`: record intervals longer than
``max_gap_s``, by default `kinsync.trajectory_gaps.GAP_FACTOR` times the median record
interval) are not interpolated across: the kernel treats a point strictly inside a gap
like a point outside the span (NaN, ``inside == False``), and `GeorefTrajectory.contains`
says which times it will georeference.

References
----------
Shoemake, K., "Animating rotation with quaternion curves", SIGGRAPH 1985 (slerp).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np

from kinsync._arrays import readonly_array
from kinsync._typing import ArrayLike, BoolArray, FloatArray
from kinsync._validate import time_array
from kinsync.errors import InputError
from kinsync.frames import (
    geodetic_to_ecef,
    ned_to_ecef,
    quaternion_ned_to_ecef,
    quaternion_to_matrix,
    rotation_ned_to_ecef,
)
from kinsync.mount import MAX_LATENCY_S
from kinsync.trajectory import Trajectory, VelocityConsistencyWarning
from kinsync.trajectory_gaps import TrajectoryGap, max_gap_for, trajectory_gaps

__all__ = [
    "GeorefTrajectory",
]


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
    velocity_warning : str or None
        Why the source trajectory's velocities were dropped (they disagree with its
        positions; positions are then interpolated linearly), or None.
    max_gap_s : float
        Longest record interval (s) interpolated across; longer ones are gaps.
    gaps : tuple of TrajectoryGap
        The record intervals longer than ``max_gap_s`` (scanner time scale), in order.
    max_gap_given : bool
        Whether ``max_gap_s`` was given (``--max-gap-s``), not the default.
    """

    trajectory: Trajectory
    latency_s: float
    t_s: FloatArray
    pos_ecef_m: FloatArray
    vel_ecef_m_s: FloatArray | None
    q_body_to_ecef: FloatArray
    rotvec_interval_body: FloatArray
    velocity_warning: str | None = None
    max_gap_s: float = math.inf
    gaps: tuple[TrajectoryGap, ...] = ()
    max_gap_given: bool = False

    @classmethod
    def from_trajectory(
        cls, trajectory: Trajectory, latency_s: float = 0.0, max_gap_s: float | None = None
    ) -> GeorefTrajectory:
        """Precompute ECEF positions, velocities and body -> ECEF attitudes.

        Parameters
        ----------
        trajectory : Trajectory
            Records at their own time tags (geodetic, or local NED about an origin).
        latency_s : float
            Latency tau (s), SPEC section 1: a point at ``t`` uses the record tagged
            ``t + tau``.
        max_gap_s : float, optional
            Longest record interval (s) to interpolate across; default
            `kinsync.trajectory_gaps.GAP_FACTOR` times the median record interval
            (`kinsync.trajectory_gaps.max_gap_for`). Points inside a longer interval (a data
            gap) are treated as outside the span.

        Returns
        -------
        GeorefTrajectory
            Without velocities (``vel_ecef_m_s`` None, ``velocity_warning`` saying why)
            when the trajectory's velocities disagree with its positions; a
            `VelocityConsistencyWarning` is issued then.

        Raises
        ------
        InputError
            A non-finite latency, or one beyond `kinsync.mount.MAX_LATENCY_S` (a
            time-scale or unit mistake, not a latency); a ``max_gap_s`` that is not
            a positive number.
        """
        if not math.isfinite(latency_s):
            msg = f"georeference latency_s must be finite, got {latency_s!r}"
            raise InputError(msg)
        if abs(latency_s) > MAX_LATENCY_S:
            msg = (
                f"georeference latency_s = {latency_s!r} s is beyond +-{MAX_LATENCY_S:g} s: "
                "a latency is a delay of milliseconds; a larger offset is a time-scale or "
                "unit mistake (put the trajectory and the points on one time scale)"
            )
            raise InputError(msg)
        check = trajectory.velocity_check
        velocity_warning = None
        if check is not None and not check.consistent:
            velocity_warning = check.message
            warnings.warn(velocity_warning, VelocityConsistencyWarning, stacklevel=2)
            trajectory = replace(trajectory, vel_ned_m_s=None)
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
        gap_limit_s = max_gap_for(corrected.t_s, max_gap_s)
        return cls(
            trajectory=corrected,
            latency_s=float(latency_s),
            t_s=readonly_array(corrected.t_s, copy=False),
            pos_ecef_m=readonly_array(pos, copy=False),
            vel_ecef_m_s=None if vel is None else readonly_array(vel, copy=False),
            q_body_to_ecef=readonly_array(q, copy=False),
            rotvec_interval_body=readonly_array(rotvec, copy=False),
            velocity_warning=velocity_warning,
            max_gap_s=gap_limit_s,
            max_gap_given=max_gap_s is not None,
            gaps=trajectory_gaps(corrected.t_s, gap_limit_s),
        )

    def __len__(self) -> int:
        return int(self.t_s.size)

    @cached_property
    def _poly_linear(self) -> FloatArray:
        """Per interval ``p(s) = c0 + s c1 + s² c2 + s³ c3`` (linear), shape (N-1, 4, 3)."""
        p0, p1 = self.pos_ecef_m[:-1], self.pos_ecef_m[1:]
        zero = np.zeros_like(p0)
        return readonly_array(np.stack([p0, p1 - p0, zero, zero], axis=1), copy=False)

    @cached_property
    def _poly_hermite(self) -> FloatArray:
        """Per interval cubic Hermite coefficients in ``s`` (ECEF, m), shape (N-1, 4, 3)."""
        assert self.vel_ecef_m_s is not None
        h = np.diff(self.t_s)[:, None]
        p0, p1 = self.pos_ecef_m[:-1], self.pos_ecef_m[1:]
        m0, m1 = h * self.vel_ecef_m_s[:-1], h * self.vel_ecef_m_s[1:]
        dp = p1 - p0
        return readonly_array(
            np.stack([p0, m0, 3.0 * dp - 2.0 * m0 - m1, m0 + m1 - 2.0 * dp], axis=1), copy=False
        )

    @cached_property
    def _inv_interval_s(self) -> FloatArray:
        """``1 / (t[k+1] - t[k])`` per interval (1/s), shape (N-1,): no division per point."""
        return readonly_array(1.0 / np.diff(self.t_s), copy=False)

    @cached_property
    def _R_body_to_ecef_left(self) -> FloatArray:
        """Rotation matrix of each interval's left record, body -> ECEF, shape (N-1, 3, 3)."""
        return readonly_array(quaternion_to_matrix(self.q_body_to_ecef[:-1]), copy=False)

    @cached_property
    def gap_bounds_s(self) -> FloatArray:
        """Start and end times (s) of the gaps, shape (2, G), read-only."""
        bounds = np.array(
            [[g.t_start_s for g in self.gaps], [g.t_end_s for g in self.gaps]], dtype=np.float64
        ).reshape(2, len(self.gaps))
        return readonly_array(bounds, copy=False)

    def contains(self, t_s: ArrayLike) -> BoolArray:
        """True where a time (s, scanner time scale) can be georeferenced.

        Within ``[t_start_s, t_end_s]`` and not strictly inside a gap; same shape as
        ``t_s``.

        Parameters
        ----------
        t_s : array_like, any shape
            Point times (s) on the scanner's time scale (the trajectory's record times
            corrected for the latency); NaN is never contained.

        Returns
        -------
        ndarray of bool, same shape as ``t_s``
            The gaps are `gaps` (record intervals longer than `max_gap_s`).

        Raises
        ------
        InputError
            ``t_s`` not numbers of seconds (datetime64, text, a float dtype too coarse
            for the times: `kinsync._validate.time_array`).
        """
        t = time_array(t_s, "contains t_s")
        out: BoolArray = (t >= self.t_start_s) & (t <= self.t_end_s)
        for gap in self.gaps:
            out &= ~((t > gap.t_start_s) & (t < gap.t_end_s))
        return out

    @property
    def t_start_s(self) -> float:
        """First record time on the scanner's time scale (s)."""
        return float(self.t_s[0])

    @property
    def t_end_s(self) -> float:
        """Last record time on the scanner's time scale (s)."""
        return float(self.t_s[-1])
