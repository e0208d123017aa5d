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

from kinsync._arrays import ReadOnlyArrays, readonly_array
from kinsync._typing import ArrayLike, BoolArray, FloatArray
from kinsync._validate import finite_number, time_array
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
    "GeorefRecords",
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


def _check_latency_value(latency_s: object) -> float:
    """Return the latency (s) as a float; refuse a non-number, NaN or beyond `MAX_LATENCY_S`."""
    value = finite_number(latency_s, "georeference latency_s")
    if abs(value) > MAX_LATENCY_S:
        msg = (
            f"georeference latency_s = {value!r} s is beyond +-{MAX_LATENCY_S:g} s: "
            "a latency is a delay of milliseconds; a larger offset is a time-scale or "
            "unit mistake (put the trajectory and the points on one time scale)"
        )
        raise InputError(msg)
    return value


@dataclass(frozen=True, eq=False)
class GeorefTrajectory(ReadOnlyArrays):
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
        latency_s = _check_latency_value(latency_s)
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

    @property
    def has_velocities(self) -> bool:
        """Whether positions can be interpolated by cubic Hermite (ECEF velocities)."""
        return self.vel_ecef_m_s is not None

    def prepared_for(self, t_min_s: float, t_max_s: float) -> GeorefTrajectory:
        """Itself: it is prepared over its whole span (as `GeorefRecords.prepared_for`).

        Parameters
        ----------
        t_min_s, t_max_s : float
            Earliest and latest point time (s, scanner time scale); not needed here.

        Returns
        -------
        GeorefTrajectory
            This trajectory.
        """
        del t_min_s, t_max_s
        return self

    def position_ecef_m_at(self, t_s: float) -> FloatArray:
        """ECEF position (m) at time ``t_s`` (scanner scale), linear between records.

        Parameters
        ----------
        t_s : float
            Time (s, scanner time scale), clamped to the records by ``np.interp``.

        Returns
        -------
        ndarray, shape (3,)
            ECEF position (m).
        """
        return np.array([np.interp(t_s, self.t_s, self.pos_ecef_m[:, j]) for j in range(3)])

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


PREPARE_WHOLE_SHARE = 0.25
"""A span needing more than this share of the records is prepared whole, once, and
kept (points in no time order would otherwise prepare most of the trajectory for every
chunk)."""


class GeorefRecords:
    """A trajectory ready for georeferencing, prepared only over the spans points need.

    `GeorefTrajectory` computes ECEF positions, velocities, body -> ECEF attitudes and
    slerp increments for every record: for a 10 h, 200 Hz SBET (7.2 million records)
    georeferencing a few minutes of points, that cost most of the run's time and
    memory. This holds the records as read, checked over the whole trajectory (the
    velocity-consistency check, the data gaps, the gap threshold from the median record
    interval: the same as `GeorefTrajectory.from_trajectory`), and prepares, per chunk
    of points, a `GeorefTrajectory` of the records that bracket the chunk's times
    (`prepared_for`). Each record's prepared values are computed record by record, so
    a prepared span holds the very values the whole trajectory would: the points'
    coordinates are the same to the bit.

    Attributes
    ----------
    trajectory : Trajectory
        The source records at their own time tags (without velocities when they
        disagree with the positions).
    latency_s : float
        Latency tau (s) the records are corrected for (SPEC section 1).
    t_s : ndarray, shape (N,)
        Record times on the scanner's time scale (s): ``trajectory.t_s - latency_s``.
    velocity_warning : str or None
        Why the velocities were dropped, or None.
    max_gap_s : float
        Longest record interval (s) interpolated across.
    gaps : tuple of TrajectoryGap
        The record intervals longer than ``max_gap_s`` (scanner time scale).
    max_gap_given : bool
        Whether ``max_gap_s`` was given, not the default.
    """

    def __init__(
        self,
        trajectory: Trajectory,
        latency_s: float,
        velocity_warning: str | None,
        max_gap_s: float,
        max_gap_given: bool,
    ) -> None:
        self.trajectory = trajectory
        self.latency_s = float(latency_s)
        self.t_s: FloatArray = readonly_array(trajectory.t_s - self.latency_s, copy=False)
        self.velocity_warning = velocity_warning
        self.max_gap_s = float(max_gap_s)
        self.max_gap_given = max_gap_given
        self.gaps: tuple[TrajectoryGap, ...] = trajectory_gaps(self.t_s, self.max_gap_s)
        self._whole: GeorefTrajectory | None = None
        self._last: tuple[int, int, GeorefTrajectory] | None = None

    @classmethod
    def from_trajectory(
        cls, trajectory: Trajectory, latency_s: float = 0.0, max_gap_s: float | None = None
    ) -> GeorefRecords:
        """Check the trajectory as `GeorefTrajectory.from_trajectory` does; prepare nothing.

        Parameters, warnings and errors as `GeorefTrajectory.from_trajectory`.
        """
        latency_s = _check_latency_value(latency_s)
        check = trajectory.velocity_check
        velocity_warning = None
        if check is not None and not check.consistent:
            velocity_warning = check.message
            warnings.warn(velocity_warning, VelocityConsistencyWarning, stacklevel=2)
            trajectory = replace(trajectory, vel_ned_m_s=None)
        limit = max_gap_for(trajectory.t_s - float(latency_s), max_gap_s)
        return cls(trajectory, latency_s, velocity_warning, limit, max_gap_s is not None)

    def __len__(self) -> int:
        return int(self.t_s.size)

    def __getstate__(self) -> dict[str, object]:
        """Pickled (for a worker) without the spans prepared here."""
        return {**self.__dict__, "_whole": None, "_last": None}

    @property
    def has_velocities(self) -> bool:
        """Whether positions can be interpolated by cubic Hermite (velocities kept)."""
        return self.trajectory.vel_ned_m_s is not None

    @property
    def t_start_s(self) -> float:
        """First record time on the scanner's time scale (s)."""
        return float(self.t_s[0])

    @property
    def t_end_s(self) -> float:
        """Last record time on the scanner's time scale (s)."""
        return float(self.t_s[-1])

    @cached_property
    def gap_bounds_s(self) -> FloatArray:
        """Start and end times (s) of the gaps, shape (2, G), read-only."""
        bounds = np.array(
            [[g.t_start_s for g in self.gaps], [g.t_end_s for g in self.gaps]], dtype=np.float64
        ).reshape(2, len(self.gaps))
        return readonly_array(bounds, copy=False)

    def record_span(self, t_min_s: float, t_max_s: float) -> tuple[int, int]:
        """First and last record (0-based, inclusive) that bracket ``[t_min_s, t_max_s]``.

        Times on the scanner's time scale (s); NaN bounds give the first two records.
        At least two records; clipped to the trajectory.
        """
        n = self.t_s.size
        if not (t_min_s <= t_max_s):  # NaN: any span will do (the points are refused)
            return 0, 1
        first = int(np.searchsorted(self.t_s, t_min_s, side="right")) - 1
        last = int(np.searchsorted(self.t_s, t_max_s, side="left"))
        first = min(max(first, 0), n - 2)
        last = max(min(last, n - 1), first + 1)
        return first, last

    def prepared_rows(self, first: int, last: int) -> GeorefTrajectory:
        """`GeorefTrajectory` of records ``first..last`` (inclusive), checked as a whole."""
        if first == 0 and last == self.t_s.size - 1:
            return self._prepared_whole()
        src = self.trajectory
        rows = slice(first, last + 1)

        def cut(a: FloatArray | None) -> FloatArray | None:
            return None if a is None else a[rows]

        part = Trajectory(
            t_s=src.t_s[rows],
            q_body_to_ned=src.q_body_to_ned[rows],
            lat_lon_h=cut(src.lat_lon_h),
            pos_ned_m=cut(src.pos_ned_m),
            origin_lat_lon_h=src.origin_lat_lon_h,
            vel_ned_m_s=cut(src.vel_ned_m_s),
        )
        # The whole trajectory's velocity check holds for its records (kept or dropped).
        part.__dict__["velocity_check"] = src.velocity_check
        return replace(
            GeorefTrajectory.from_trajectory(part, self.latency_s, self.max_gap_s),
            velocity_warning=self.velocity_warning,
            max_gap_given=self.max_gap_given,
        )

    def _prepared_whole(self) -> GeorefTrajectory:
        if self._whole is None:
            whole = GeorefTrajectory.from_trajectory(
                self.trajectory, self.latency_s, self.max_gap_s
            )
            self._whole = replace(
                whole, velocity_warning=self.velocity_warning, max_gap_given=self.max_gap_given
            )
        return self._whole

    def prepared_for(self, t_min_s: float, t_max_s: float) -> GeorefTrajectory:
        """The records that points at times ``t_min_s..t_max_s`` need, prepared.

        Parameters
        ----------
        t_min_s, t_max_s : float
            Earliest and latest point time (s, scanner time scale; NaN allowed).

        Returns
        -------
        GeorefTrajectory
            Over the records bracketing the span (clipped to the trajectory): a point in
            the span is georeferenced, or found outside the span or in a gap, exactly as
            with the whole trajectory prepared. A span reaching over more than
            `PREPARE_WHOLE_SHARE` of the records gets the whole trajectory, prepared once.
        """
        if self._whole is not None:
            return self._whole
        first, last = self.record_span(t_min_s, t_max_s)
        held = self._last
        if held is not None and held[0] <= first and last <= held[1]:
            return held[2]
        if last - first > PREPARE_WHOLE_SHARE * self.t_s.size:
            return self._prepared_whole()
        prepared = self.prepared_rows(first, last)
        self._last = (first, last, prepared)
        return prepared

    def pos_ecef_m_at(self, rows: list[int]) -> FloatArray:
        """ECEF positions (m) of records ``rows``, shape (len(rows), 3).

        The values `GeorefTrajectory.pos_ecef_m` holds for them (computed record by
        record; the latency changes times only).
        """
        src = self.trajectory
        index = np.asarray(rows, dtype=np.intp)
        if src.lat_lon_h is not None:
            lat, lon, h = src.lat_lon_h[index].T
            pos: FloatArray = geodetic_to_ecef(lat, lon, h)
            return pos
        assert src.pos_ned_m is not None
        assert src.origin_lat_lon_h is not None
        return ned_to_ecef(src.pos_ned_m[index], *src.origin_lat_lon_h)

    def position_ecef_m_at(self, t_s: float) -> FloatArray:
        """ECEF position (m) at time ``t_s`` (scanner scale), linear between records.

        ``np.interp`` over the records that bracket ``t_s``: the value it gives over
        all of them.

        Parameters
        ----------
        t_s : float
            Time (s, scanner time scale), clamped to the records.

        Returns
        -------
        ndarray, shape (3,)
            ECEF position (m).
        """
        first, last = self.record_span(t_s, t_s)
        first, last = max(first - 1, 0), min(last + 1, self.t_s.size - 1)
        rows = list(range(first, last + 1))
        pos = self.pos_ecef_m_at(rows)
        t = self.t_s[first : last + 1]
        return np.array([np.interp(t_s, t, pos[:, j]) for j in range(3)])
