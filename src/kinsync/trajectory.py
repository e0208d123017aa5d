"""Time-indexed position and attitude of a vehicle: the `Trajectory` container.

A trajectory holds strictly increasing times, positions (geodetic WGS84, or local NED
about a geodetic origin), body -> NED attitude as unit quaternions and, optionally,
NED velocities. It interpolates at arbitrary times, vectorised: position linearly, or
by cubic Hermite splines where velocities exist; attitude by spherical linear
interpolation (slerp). Times outside the span raise `OutsideSpanError` or, on request,
come back masked (NaN and ``inside == False``); nothing is extrapolated, nor
interpolated across a data gap (`kinsync.trajectory_gaps`): a time inside one is
treated like a time outside the span.

Velocities are checked against the positions before Hermite uses them
(`Trajectory.velocity_check`, `check_velocities`): converted or synthesised files
often carry zero, scaled, swapped or unrotated velocities, and a Hermite spline through
such velocities bends every position between records (0.28 m where the records say
1.0 m in a two-record case). Inconsistent velocities are not refused, because the
positions georeferencing needs are still good: "auto" interpolation falls back to
linear, as for a trajectory without velocities, and says so with a
`VelocityConsistencyWarning` that the command line shows. Linear costs ``h² a / 8``
(16 micrometres at 200 Hz and 5 m/s²) where Hermite through wrong velocities costs up
to ``0.096 h |velocity error|`` (1 cm at 200 Hz and 20 m/s, metres at 1 Hz). An
explicit ``position="hermite"`` with such velocities is refused.

References
----------
Shoemake, K., "Animating rotation with quaternion curves", SIGGRAPH 1985 (slerp).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Literal

import numpy as np

from kinsync._arrays import ReadOnlyArrays, readonly_array
from kinsync._typing import ArrayLike, BoolArray, FloatArray, IntArray
from kinsync._validate import (
    angle_array,
    coordinate_array,
    finite_number,
    geodetic_array,
    time_array,
)
from kinsync.errors import InputError, OutsideSpanError
from kinsync.frames import (
    WGS84_A_M,
    WGS84_F,
    euler_rpy_to_quaternion,
    geodetic_to_ecef,
    ned_to_ecef,
    quaternion_to_euler_rpy,
    quaternion_to_matrix,
    wrap_angle_rad,
)
from kinsync.mount import MAX_LATENCY_S
from kinsync.trajectory_gaps import (
    TrajectoryGap,
    gap_index,
    gap_threshold_text,
    max_gap_for,
    trajectory_gaps,
)
from kinsync.trajectory_rows import (
    check_euler_rad,
    check_heights,
    check_latitudes,
    check_longitudes,
    first_bad_row,
    validated_rows,
    validated_unit_quaternions,
)
from kinsync.trajectory_times import validated_times
from kinsync.trajectory_velocity import (
    VELOCITY_CHECK_ATOL_M,
    VELOCITY_CHECK_RTOL,
    VELOCITY_CHECK_WINDOW_S,
    VELOCITY_HINT,
    VelocityCheck,
    VelocityConsistencyWarning,
    check_velocities,
)

__all__ = [
    "VELOCITY_CHECK_ATOL_M",
    "VELOCITY_CHECK_RTOL",
    "VELOCITY_CHECK_WINDOW_S",
    "Trajectory",
    "TrajectorySample",
    "VelocityCheck",
    "VelocityConsistencyWarning",
    "check_velocities",
]

PositionMethod = Literal["auto", "linear", "hermite"]


def _meridian_and_normal_radii_m(lat_deg: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Meridian (M) and prime-vertical (N) radii of curvature of WGS84 (m)."""
    e2 = WGS84_F * (2.0 - WGS84_F)
    s2 = np.sin(np.radians(lat_deg)) ** 2
    w = np.sqrt(1.0 - e2 * s2)
    return WGS84_A_M * (1.0 - e2) / w**3, WGS84_A_M / w


@dataclass(frozen=True, eq=False)
class TrajectorySample(ReadOnlyArrays):
    """States of a trajectory interpolated at requested times.

    Its arrays are its own (the requested times are copied) and read-only.

    Attributes
    ----------
    t_s : ndarray, shape (M,)
        Requested times (s, the trajectory's time scale).
    q_body_to_ned : ndarray, shape (M, 4)
        Attitude, scalar-first unit quaternions (NaN where outside the span).
    lat_lon_h : ndarray or None, shape (M, 3)
        Geodetic position (lat_deg, lon_deg, h_m) for a geodetic trajectory.
    pos_ned_m : ndarray or None, shape (M, 3)
        Local NED position (m) for a local trajectory.
    origin_lat_lon_h : tuple of float or None
        Geodetic origin of ``pos_ned_m``.
    inside : ndarray of bool, shape (M,)
        True where the time lies within the trajectory's span.
    """

    t_s: FloatArray
    q_body_to_ned: FloatArray
    lat_lon_h: FloatArray | None
    pos_ned_m: FloatArray | None
    origin_lat_lon_h: tuple[float, float, float] | None
    inside: BoolArray

    @property
    def R_body_to_ned(self) -> FloatArray:
        """Attitude matrices, shape (M, 3, 3) (NaN where outside the span)."""
        out = np.full((len(self.t_s), 3, 3), np.nan)
        if np.any(self.inside):
            out[self.inside] = quaternion_to_matrix(self.q_body_to_ned[self.inside])
        return out

    def pos_ecef_m(self) -> FloatArray:
        """Positions in ECEF (m), shape (M, 3) (NaN where outside the span)."""
        out = np.full((len(self.t_s), 3), np.nan)
        if not np.any(self.inside):
            return out
        if self.lat_lon_h is not None:
            p = self.lat_lon_h[self.inside]
            out[self.inside] = geodetic_to_ecef(p[:, 0], p[:, 1], p[:, 2])
        else:
            assert self.pos_ned_m is not None
            assert self.origin_lat_lon_h is not None
            out[self.inside] = ned_to_ecef(self.pos_ned_m[self.inside], *self.origin_lat_lon_h)
        return out


@dataclass(frozen=True, eq=False)
class Trajectory(ReadOnlyArrays):
    """Time-indexed position and attitude of a vehicle.

    Exactly one of ``lat_lon_h`` (geodetic) or ``pos_ned_m`` (local, with
    ``origin_lat_lon_h``) is given. Arrays are copied and made read-only.

    Parameters
    ----------
    t_s : array_like, shape (N,)
        Record times (s, GPS time unless stated), strictly increasing, N >= 2.
    q_body_to_ned : array_like, shape (N, 4)
        Attitude body (FRD) -> NED, scalar-first unit quaternions (norm within 1e-6).
    lat_lon_h : array_like, shape (N, 3), optional
        Geodetic WGS84 position: latitude (deg, within +-90), longitude (deg, -180 to
        180 or 0 to 360: `kinsync.trajectory_rows.LONGITUDE_SPAN_DEG`), ellipsoidal
        height (m).
    pos_ned_m : array_like, shape (N, 3), optional
        Local-level NED position (m) about ``origin_lat_lon_h``.
    origin_lat_lon_h : tuple of float, optional
        Geodetic origin (lat_deg, lon_deg, h_m) of ``pos_ned_m``; required with it.
    vel_ned_m_s : array_like, shape (N, 3), optional
        Velocity in NED (m/s); enables cubic Hermite position interpolation when it
        agrees with the positions (`velocity_check`).

    Raises
    ------
    InputError
        Naming the row and column at fault: non-finite values, repeated or decreasing
        times, non-unit quaternions, mismatched lengths, missing position, a latitude
        beyond +-90 deg or a longitude outside -180 to 360 deg; naming the
        argument: times, latitudes, longitudes or heights in a float dtype too coarse
        for them (float32: `kinsync._validate.time_array`, ``geodetic_array``).
    """

    t_s: FloatArray
    q_body_to_ned: FloatArray
    lat_lon_h: FloatArray | None = None
    pos_ned_m: FloatArray | None = None
    origin_lat_lon_h: tuple[float, float, float] | None = None
    vel_ned_m_s: FloatArray | None = None
    _lon_unwrapped_deg: FloatArray | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        t = validated_times(self.t_s)
        n = t.size
        q = validated_unit_quaternions(self.q_body_to_ned, n)
        if (self.lat_lon_h is None) == (self.pos_ned_m is None):
            msg = "trajectory: give exactly one of lat_lon_h (geodetic) or pos_ned_m (local NED)"
            raise InputError(msg)
        set_ = object.__setattr__
        set_(self, "t_s", readonly_array(t))
        set_(self, "q_body_to_ned", readonly_array(q, copy=False))  # a new array
        if self.lat_lon_h is not None:
            if self.origin_lat_lon_h is not None:
                msg = "trajectory: origin_lat_lon_h applies only to a local NED trajectory"
                raise InputError(msg)
            llh = validated_rows(
                geodetic_array(self.lat_lon_h, "trajectory lat_lon_h"), n, 3, "lat_lon_h"
            )
            check_latitudes(llh[:, 0], "lat_lon_h")
            check_longitudes(llh[:, 1], "lat_lon_h")
            check_heights(llh[:, 2], "lat_lon_h")
            set_(self, "lat_lon_h", readonly_array(llh))
            set_(self, "_lon_unwrapped_deg", readonly_array(np.unwrap(llh[:, 1], period=360.0)))
        else:
            if self.origin_lat_lon_h is None:
                msg = "trajectory: pos_ned_m needs origin_lat_lon_h (lat_deg, lon_deg, h_m)"
                raise InputError(msg)
            origin = validated_rows(
                geodetic_array([self.origin_lat_lon_h], "trajectory origin_lat_lon_h"),
                1,
                3,
                "origin_lat_lon_h",
            )[0]
            check_latitudes(origin[:1], "origin_lat_lon_h")
            check_longitudes(origin[1:2], "origin_lat_lon_h")
            check_heights(origin[2:3], "origin_lat_lon_h")
            assert self.pos_ned_m is not None
            ned = coordinate_array(self.pos_ned_m, "trajectory pos_ned_m")
            set_(self, "pos_ned_m", readonly_array(validated_rows(ned, n, 3, "pos_ned_m")))
            set_(self, "origin_lat_lon_h", (float(origin[0]), float(origin[1]), float(origin[2])))
        if self.vel_ned_m_s is not None:
            vel = validated_rows(self.vel_ned_m_s, n, 3, "vel_ned_m_s")
            set_(self, "vel_ned_m_s", readonly_array(vel))

    # ------------------------------------------------------------------ constructors
    @staticmethod
    def _from_checked(
        t_s: FloatArray,
        q_body_to_ned: FloatArray,
        *,
        lat_lon_h: FloatArray | None = None,
        pos_ned_m: FloatArray | None = None,
        origin_lat_lon_h: tuple[float, float, float] | None = None,
        vel_ned_m_s: FloatArray | None = None,
        lon_unwrapped_deg: FloatArray | None = None,
    ) -> Trajectory:
        """A trajectory of arrays already checked as `Trajectory` checks them; kept as they are.

        For the few callers that have just made and checked every array (a reader that
        checked its file, `shifted`), so that they are not checked, nor copied, a
        second time. Each array must be exactly what ``__post_init__`` would store:
        float64 and C-contiguous, owned by the caller (made by it) or read-only (another
        trajectory's); ``t_s`` as `validated_times` returns it, ``q_body_to_ned`` as
        `validated_unit_quaternions` does, positions and velocities of shape (N, 3) and
        finite, latitudes within +-90 deg, longitudes within
        `kinsync.trajectory_rows.LONGITUDE_SPAN_DEG`, exactly one of ``lat_lon_h`` and
        ``pos_ned_m`` (the latter with its float ``origin_lat_lon_h``).
        ``lon_unwrapped_deg`` is that of ``lat_lon_h`` when known (another trajectory's
        with the same positions). The arrays are made read-only in place. Always a
        plain `Trajectory`.
        """
        out = object.__new__(Trajectory)  # no __post_init__; a subclass's fields unset
        set_ = object.__setattr__
        set_(out, "t_s", readonly_array(t_s, copy=False))
        set_(out, "q_body_to_ned", readonly_array(q_body_to_ned, copy=False))
        set_(out, "origin_lat_lon_h", origin_lat_lon_h)
        set_(out, "pos_ned_m", None if pos_ned_m is None else readonly_array(pos_ned_m, copy=False))
        set_(
            out,
            "vel_ned_m_s",
            None if vel_ned_m_s is None else readonly_array(vel_ned_m_s, copy=False),
        )
        set_(out, "lat_lon_h", None)
        set_(out, "_lon_unwrapped_deg", None)
        if lat_lon_h is not None:
            set_(out, "lat_lon_h", readonly_array(lat_lon_h, copy=False))
            if lon_unwrapped_deg is None:
                lon_unwrapped_deg = np.unwrap(lat_lon_h[:, 1], period=360.0)
            set_(out, "_lon_unwrapped_deg", readonly_array(lon_unwrapped_deg, copy=False))
        return out

    @classmethod
    def from_euler(
        cls,
        t_s: ArrayLike,
        roll_rad: ArrayLike,
        pitch_rad: ArrayLike,
        yaw_rad: ArrayLike,
        *,
        lat_lon_h: ArrayLike | None = None,
        pos_ned_m: ArrayLike | None = None,
        origin_lat_lon_h: tuple[float, float, float] | None = None,
        vel_ned_m_s: ArrayLike | None = None,
    ) -> Trajectory:
        """Build a trajectory from DIN 9300 Euler angles (rad), each of shape (N,) like t_s.

        Parameters
        ----------
        t_s : array_like, shape (N,)
            Record times (s, GPS time unless stated), strictly increasing, N >= 2.
        roll_rad, pitch_rad, yaw_rad : array_like, shape (N,)
            Attitude body (FRD) -> NED: roll about body X, pitch about body Y, yaw
            (heading) about Down (rad), as `kinsync.frames.euler_rpy_to_matrix`. Pitch
            within +-pi/2, roll and yaw within +-2 pi (the spans the command line reads
            degrees in, `kinsync.io.sanity`).
        lat_lon_h : array_like, shape (N, 3), optional
            Geodetic WGS84 position: latitude (deg), longitude (deg), ellipsoidal
            height (m).
        pos_ned_m : array_like, shape (N, 3), optional
            Local-level NED position (m) about ``origin_lat_lon_h``.
        origin_lat_lon_h : tuple of float, optional
            Geodetic origin (lat_deg, lon_deg, h_m) of ``pos_ned_m``; required with it.
        vel_ned_m_s : array_like, shape (N, 3), optional
            Velocity in NED (m/s), as in `Trajectory`.

        Returns
        -------
        Trajectory
            Exactly one of ``lat_lon_h`` and ``pos_ned_m`` must be given.

        Raises
        ------
        InputError
            As `Trajectory`, naming the row and column at fault; and an angle array not
            numbers, not finite, not of shape (N,), or in a float dtype too coarse for
            1 urad (float16: `kinsync._validate.angle_array`); a pitch beyond +-pi/2, a
            roll or yaw beyond +-2 pi (degrees given for radians; an unwrapped yaw must
            be wrapped first, `kinsync.frames.wrap_angle_rad`), naming the argument and
            row.
        """
        t = validated_times(t_s)
        rpy = {"roll_rad": roll_rad, "pitch_rad": pitch_rad, "yaw_rad": yaw_rad}
        angles = [
            validated_rows(angle_array(a, f"trajectory {k}"), t.size, None, k)
            for k, a in rpy.items()
        ]
        for name, angle in zip(rpy, angles, strict=True):
            check_euler_rad(angle, name)
        q = euler_rpy_to_quaternion(*angles)
        return cls(
            t_s=t,
            q_body_to_ned=q,
            lat_lon_h=None
            if lat_lon_h is None
            else geodetic_array(lat_lon_h, "trajectory lat_lon_h"),
            pos_ned_m=None
            if pos_ned_m is None
            else coordinate_array(pos_ned_m, "trajectory pos_ned_m"),
            origin_lat_lon_h=origin_lat_lon_h,
            vel_ned_m_s=None
            if vel_ned_m_s is None
            else validated_rows(vel_ned_m_s, t.size, 3, "vel_ned_m_s"),
        )

    # ------------------------------------------------------------------ properties
    def __len__(self) -> int:
        return int(self.t_s.size)

    @property
    def is_geodetic(self) -> bool:
        """True when positions are geodetic (``lat_lon_h``), False for local NED."""
        return self.lat_lon_h is not None

    @property
    def t_start_s(self) -> float:
        """First record time (s)."""
        return float(self.t_s[0])

    @property
    def t_end_s(self) -> float:
        """Last record time (s)."""
        return float(self.t_s[-1])

    @property
    def duration_s(self) -> float:
        """Time span covered, ``t_end_s - t_start_s`` (s)."""
        return self.t_end_s - self.t_start_s

    @cached_property
    def velocity_check(self) -> VelocityCheck | None:
        """Whether the velocities agree with the positions (`check_velocities`).

        None without velocities. Computed once, on first use; a time-shifted copy
        (`shifted`, `corrected_for_latency`) inherits it.
        """
        if self.vel_ned_m_s is None:
            return None
        return check_velocities(self.t_s, self._displacement_ned_m(), self.vel_ned_m_s)

    def _displacement_ned_m(self) -> FloatArray:
        """Displacement between consecutive records, local NED (m), shape (N-1, 3)."""
        if self.lat_lon_h is None:
            assert self.pos_ned_m is not None
            return np.diff(self.pos_ned_m, axis=0)
        assert self._lon_unwrapped_deg is not None
        lat, h = self.lat_lon_h[:, 0], self.lat_lon_h[:, 2]
        lat_mid, h_mid = 0.5 * (lat[:-1] + lat[1:]), 0.5 * (h[:-1] + h[1:])
        M, N = _meridian_and_normal_radii_m(lat_mid)
        with np.errstate(all="ignore"):  # absurd heights overflow; check_velocities says so
            return np.column_stack(
                [
                    np.radians(np.diff(lat)) * (M + h_mid),
                    np.radians(np.diff(self._lon_unwrapped_deg))
                    * (N + h_mid)
                    * np.cos(np.radians(lat_mid)),
                    -np.diff(h),
                ]
            )

    def ground_speed_m_s(self) -> FloatArray:
        """Horizontal speed over ground (m/s) of each record interval, from the positions.

        Shape (N-1,); not from the velocities, which may disagree (`velocity_check`).
        """
        disp = self._displacement_ned_m()
        out: FloatArray = np.hypot(disp[:, 0], disp[:, 1]) / np.diff(self.t_s)
        return out

    def euler_rpy_rad(self) -> FloatArray:
        """Attitude as DIN 9300 ``(roll, pitch, yaw)`` (rad), shape (N, 3)."""
        return quaternion_to_euler_rpy(self.q_body_to_ned)

    def course_and_yaw_rad(self, min_speed_m_s: float = 1.0) -> tuple[FloatArray, FloatArray]:
        """Course over ground and yaw (rad) over the intervals that move.

        Parameters
        ----------
        min_speed_m_s : float
            Horizontal speed (m/s) a record interval must exceed for its course to
            count; default 1.

        Returns
        -------
        course_rad, yaw_rad : ndarray, shape (M,)
            Over the M record intervals faster than ``min_speed_m_s``: the course
            ``atan2(dE, dN)`` and the yaw of the interval's first record (rad, clockwise
            from north).
        """
        disp = self._displacement_ned_m()
        dt = np.diff(self.t_s)
        moving = np.hypot(disp[:, 0], disp[:, 1]) > min_speed_m_s * dt
        course = np.arctan2(disp[moving, 1], disp[moving, 0])
        return course, self.euler_rpy_rad()[:-1, 2][moving]

    def heading_against_course(self, min_speed_m_s: float = 1.0) -> tuple[float, float] | None:
        """How well the yaw follows the course over ground, read as given and as radians.

        Over the record intervals faster than ``min_speed_m_s`` (horizontal), the
        median absolute difference between the course ``atan2(dE, dN)`` and (a) the
        yaw, (b) the yaw's degree value taken as radians (what the yaw would be had a
        file written radians under a degree column). A crabbing vessel or a reversing
        vehicle differs from its course by some degrees; yaw in radians read as degrees
        lies within ±3.2° and differs by anything.

        Parameters
        ----------
        min_speed_m_s : float
            Horizontal speed (m/s) a record interval must exceed for its course to
            count; default 1.

        Returns
        -------
        (float, float) or None
            The two medians (deg), (a) then (b), each in [0, 180]; None with fewer than
            10 such intervals.
        """
        course, yaw = self.course_and_yaw_rad(min_speed_m_s)
        if course.size < 10:
            return None

        def median_diff_deg(angle_rad: FloatArray) -> float:
            d = wrap_angle_rad(angle_rad - course)
            return float(np.degrees(np.median(np.abs(d))))

        return median_diff_deg(yaw), median_diff_deg(np.degrees(yaw))

    @cached_property
    def _default_gaps(self) -> tuple[TrajectoryGap, ...]:
        return trajectory_gaps(self.t_s, max_gap_for(self.t_s))

    def gaps(self, max_gap_s: float | None = None) -> tuple[TrajectoryGap, ...]:
        """The data gaps: record intervals longer than ``max_gap_s`` (s), in time order.

        ``max_gap_s`` defaults to `kinsync.trajectory_gaps.GAP_FACTOR` median record
        intervals (`kinsync.trajectory_gaps.max_gap_for`); ``math.inf`` finds none.

        Parameters
        ----------
        max_gap_s : float, optional
            The longest record interval (s, positive) that is not a gap; default as
            above.

        Returns
        -------
        tuple of TrajectoryGap
            Each gap's start and end record times (s, on this trajectory's time scale);
            empty when there is none.

        Raises
        ------
        InputError
            ``max_gap_s`` not a positive number.
        """
        if max_gap_s is None:
            return self._default_gaps
        return trajectory_gaps(self.t_s, max_gap_for(self.t_s, max_gap_s))

    def contains(self, t_s: ArrayLike, *, max_gap_s: float | None = None) -> BoolArray:
        """True where a time can be interpolated, same shape as ``t_s``.

        Within ``[t_start_s, t_end_s]`` and not strictly inside a data gap
        (`gaps` with ``max_gap_s``; ``math.inf``: the span alone).

        Parameters
        ----------
        t_s : array_like, any shape
            Times (s) on this trajectory's time scale; NaN is never contained.
        max_gap_s : float, optional
            The longest record interval (s, positive) that is not a gap; default as in
            `gaps`.

        Returns
        -------
        ndarray of bool, same shape as ``t_s``

        Raises
        ------
        InputError
            ``t_s`` not numbers of seconds (datetime64, text, a float dtype too coarse
            for the times: `kinsync._validate.time_array`), or ``max_gap_s`` not a
            positive number.
        """
        t = time_array(t_s, "contains t_s")
        in_span: BoolArray = (t >= self.t_start_s) & (t <= self.t_end_s)
        return in_span & (gap_index(t, self.gaps(max_gap_s)) < 0)

    # ------------------------------------------------------------------ transforms
    def shifted(self, dt_s: float) -> Trajectory:
        """Return a copy whose record times are ``t_s + dt_s``.

        Parameters
        ----------
        dt_s : float
            Time shift (s), added to every record time; positions, attitudes and
            velocities are kept.

        Returns
        -------
        Trajectory
            A new trajectory; this one is unchanged.

        Raises
        ------
        InputError
            ``dt_s`` not finite, or so large that the shifted times are no longer
            finite and strictly increasing.
        """
        dt_s = finite_number(dt_s, "time shift dt_s")
        # Only the times change: they are checked again (a huge shift can round two of
        # them together); the other arrays, checked and read-only, are shared, and the
        # attitude is renormalised as a new Trajectory would (which changes some bits).
        out = Trajectory._from_checked(
            validated_times(self.t_s + dt_s),
            validated_unit_quaternions(self.q_body_to_ned, len(self)),
            lat_lon_h=self.lat_lon_h,
            pos_ned_m=self.pos_ned_m,
            origin_lat_lon_h=self.origin_lat_lon_h,
            vel_ned_m_s=self.vel_ned_m_s,
            lon_unwrapped_deg=self._lon_unwrapped_deg,
        )
        check = self.__dict__.get("velocity_check")
        if isinstance(check, VelocityCheck):  # the check sees differences only
            out.__dict__["velocity_check"] = replace(check, worst_t_s=check.worst_t_s + dt_s)
        return out

    def corrected_for_latency(self, latency_s: float) -> Trajectory:
        """Put the records on the scanner's time scale (SPEC section 1).

        With latency ``tau > 0`` a record tagged ``t`` describes the state at
        ``t - tau``; the corrected trajectory carries it at time ``t - tau``, so
        interpolating it at a point's time ``t`` reads the record tagged ``t + tau``.

        Parameters
        ----------
        latency_s : float
            The latency tau (s), sign as `kinsync.mount.Mount.latency_s` (tau > 0: the
            navigation record lags the scanner).

        Returns
        -------
        Trajectory
            ``shifted(-latency_s)``; this one is unchanged.

        Raises
        ------
        InputError
            ``latency_s`` not a finite number, or beyond +-`kinsync.mount.MAX_LATENCY_S`
            (10 s: milliseconds given as seconds, or a time-scale mistake), as a mount
            refuses it.
        """
        tau = finite_number(latency_s, "latency_s")
        if abs(tau) > MAX_LATENCY_S:
            msg = (
                f"latency_s = {tau!r} s is beyond +-{MAX_LATENCY_S:g} s; a latency is some "
                f"milliseconds, given in seconds ({tau!r} ms would be {tau / 1e3!r}): a "
                "larger value is a unit or time-scale mistake"
            )
            raise InputError(msg)
        return self.shifted(-tau)

    def sliced(self, t_start_s: float, t_end_s: float) -> Trajectory:
        """Records with ``t_start_s <= t <= t_end_s`` (at least two must remain).

        Parameters
        ----------
        t_start_s, t_end_s : float
            First and last time kept (s, on this trajectory's time scale), both
            inclusive; no record is interpolated at either.

        Returns
        -------
        Trajectory
            A new trajectory of the records kept, with the same origin (local NED);
            this one is unchanged.

        Raises
        ------
        InputError
            Fewer than two records lie in ``[t_start_s, t_end_s]``.
        """
        keep = (self.t_s >= t_start_s) & (self.t_s <= t_end_s)
        if np.count_nonzero(keep) < 2:
            msg = f"trajectory slice [{t_start_s}, {t_end_s}] keeps fewer than 2 records"
            raise InputError(msg)

        def cut(a: FloatArray | None) -> FloatArray | None:
            return None if a is None else a[keep]

        q = cut(self.q_body_to_ned)
        assert q is not None
        return Trajectory(
            t_s=self.t_s[keep],
            q_body_to_ned=q,
            lat_lon_h=cut(self.lat_lon_h),
            pos_ned_m=cut(self.pos_ned_m),
            origin_lat_lon_h=self.origin_lat_lon_h,
            vel_ned_m_s=cut(self.vel_ned_m_s),
        )

    # ------------------------------------------------------------------ rates
    def angular_rate_body_rad_s(self) -> FloatArray:
        """Body angular rate at the record times (rad/s, body frame), shape (N, 3).

        The rotation between consecutive records gives the mean rate over each interval
        (exact for a constant rate); a record's rate is the time-weighted mean of the
        two adjacent intervals (the single adjacent interval at the ends).
        """
        from scipy.spatial.transform import Rotation  # noqa: PLC0415 - start-up of the CLI

        rot = Rotation.from_quat(self.q_body_to_ned[:, [1, 2, 3, 0]])
        dt = np.diff(self.t_s)
        interval_rate = (rot[:-1].inv() * rot[1:]).as_rotvec() / dt[:, None]
        out = np.empty((len(self), 3))
        out[0] = interval_rate[0]
        out[-1] = interval_rate[-1]
        if len(self) > 2:
            w0, w1 = dt[:-1, None], dt[1:, None]
            out[1:-1] = (interval_rate[:-1] * w0 + interval_rate[1:] * w1) / (w0 + w1)
        return out

    # ------------------------------------------------------------------ interpolation
    def _bracket(self, t: FloatArray) -> tuple[IntArray, FloatArray]:
        """Index of the left record and the fraction within the interval."""
        idx = np.searchsorted(self.t_s, t, side="right") - 1
        idx = np.clip(idx, 0, len(self) - 2).astype(np.int64)
        t0 = self.t_s[idx]
        frac = (t - t0) / (self.t_s[idx + 1] - t0)
        return idx, frac

    def _check_inside(
        self, t: FloatArray, *, mask_outside: bool, max_gap_s: float | None
    ) -> BoolArray:
        if not np.all(np.isfinite(t)):
            row = first_bad_row(~np.isfinite(t))
            msg = f"interpolation time at index {row} is not finite ({float(t[row])!r})"
            raise InputError(msg)
        inside = self.contains(t, max_gap_s=max_gap_s)
        if not mask_outside and not np.all(inside):
            row = first_bad_row(~inside)
            n_out = int(np.count_nonzero(~inside))
            gaps = self.gaps(max_gap_s)
            k = int(gap_index(t[row], gaps))
            limit_s = max_gap_for(self.t_s, max_gap_s)
            why = (
                f"in a data gap of the trajectory, {gaps[k].describe()} without a record, "
                f"one of its {gap_threshold_text(limit_s, given=max_gap_s is not None)}; "
                "kinsync does not interpolate across gaps"
                if k >= 0
                else f"outside the trajectory span [{self.t_start_s!r}, {self.t_end_s!r}]; "
                "kinsync does not extrapolate"
            )
            msg = (
                f"time t={float(t[row])!r} (index {row}, {n_out} time(s) in all) lies {why}: "
                "trim the data or ask for masked output"
            )
            raise OutsideSpanError(msg)
        return inside

    def interpolate(
        self,
        t_s: ArrayLike,
        *,
        position: PositionMethod = "auto",
        mask_outside: bool = False,
        max_gap_s: float | None = None,
    ) -> TrajectorySample:
        """Interpolate position and attitude at arbitrary times.

        Parameters
        ----------
        t_s : array_like, shape (M,)
            Times (s) on the trajectory's time scale, any order.
        position : {"auto", "linear", "hermite"}
            Position method: linear, or cubic Hermite using the velocities. "auto"
            picks Hermite when velocities exist and agree with the positions
            (`velocity_check`), else linear, with a `VelocityConsistencyWarning` when
            the velocities disagree. "hermite" with disagreeing velocities is refused.
        mask_outside : bool
            False (default): a time outside the span or inside a data gap raises
            `OutsideSpanError`. True: such times come back as NaN with
            ``inside == False``.
        max_gap_s : float, optional
            Longest record interval (s) interpolated across (`gaps`); default
            `kinsync.trajectory_gaps.GAP_FACTOR` median record intervals.

        Returns
        -------
        TrajectorySample
            Position (same kind as the trajectory) and slerp-interpolated attitude.

        Raises
        ------
        InputError
            Non-finite times, times that are not float seconds (datetime64, text, a
            float dtype too coarse for them), an unknown method, "hermite" without
            velocities or with velocities that disagree with the positions.
        OutsideSpanError
            A time outside the span or inside a data gap, unless ``mask_outside``.
        """
        t = np.array(np.atleast_1d(time_array(t_s, "interpolation times t_s")), copy=True)
        if t.ndim != 1:
            msg = f"interpolation times: expected a 1-D array, got shape {t.shape}"
            raise InputError(msg)
        inside = self._check_inside(t, mask_outside=mask_outside, max_gap_s=max_gap_s)
        use_hermite = self._use_hermite(position)

        m = t.size
        q_out = np.full((m, 4), np.nan)
        pos_out = np.full((m, 3), np.nan)
        ti = t[inside]
        if ti.size:
            idx, frac = self._bracket(ti)
            q_out[inside] = self._slerp(idx, frac)
            pos_out[inside] = self._hermite(idx, frac) if use_hermite else self._linear(idx, frac)
        if self.lat_lon_h is not None:
            pos_out[:, 1] = (pos_out[:, 1] + 180.0) % 360.0 - 180.0
        for arr in (t, inside, q_out, pos_out):  # the sample's own, as the trajectory's
            arr.setflags(write=False)
        return TrajectorySample(
            t_s=t,
            q_body_to_ned=q_out,
            lat_lon_h=pos_out if self.is_geodetic else None,
            pos_ned_m=None if self.is_geodetic else pos_out,
            origin_lat_lon_h=self.origin_lat_lon_h,
            inside=inside,
        )

    def _use_hermite(self, position: str) -> bool:
        """Whether ``position`` means Hermite here; warns when "auto" falls back."""
        if position not in ("auto", "linear", "hermite"):
            msg = f"position method must be auto, linear or hermite, got {position!r}"
            raise InputError(msg)
        if position == "linear":
            return False
        check = self.velocity_check
        if check is None:
            if position == "hermite":
                msg = "Hermite position interpolation needs velocities (vel_ned_m_s)"
                raise InputError(msg)
            return False
        if check.consistent:
            return True
        if position == "hermite":
            msg = (
                f"Hermite position interpolation refused: {check.problem}; use "
                f"position='linear' (or 'auto', which falls back to it). {VELOCITY_HINT}"
            )
            raise InputError(msg)
        warnings.warn(check.message, VelocityConsistencyWarning, stacklevel=3)
        return False

    def _position_table(self) -> FloatArray:
        if self.lat_lon_h is not None:
            assert self._lon_unwrapped_deg is not None
            return np.column_stack(
                [self.lat_lon_h[:, 0], self._lon_unwrapped_deg, self.lat_lon_h[:, 2]]
            )
        assert self.pos_ned_m is not None
        return self.pos_ned_m

    def _position_rate_table(self) -> FloatArray:
        """Time derivative of the position table's columns at the records."""
        assert self.vel_ned_m_s is not None
        v = self.vel_ned_m_s
        if self.lat_lon_h is None:
            return v
        lat, h = self.lat_lon_h[:, 0], self.lat_lon_h[:, 2]
        M, N = _meridian_and_normal_radii_m(lat)
        dlat = np.degrees(v[:, 0] / (M + h))
        dlon = np.degrees(v[:, 1] / ((N + h) * np.cos(np.radians(lat))))
        return np.column_stack([dlat, dlon, -v[:, 2]])

    def _linear(self, idx: IntArray, frac: FloatArray) -> FloatArray:
        p = self._position_table()
        return p[idx] + frac[:, None] * (p[idx + 1] - p[idx])

    def _hermite(self, idx: IntArray, frac: FloatArray) -> FloatArray:
        p = self._position_table()
        dp = self._position_rate_table()
        h = (self.t_s[idx + 1] - self.t_s[idx])[:, None]
        s = frac[:, None]
        s2, s3 = s * s, s * s * s
        return (
            (2 * s3 - 3 * s2 + 1) * p[idx]
            + (s3 - 2 * s2 + s) * h * dp[idx]
            + (-2 * s3 + 3 * s2) * p[idx + 1]
            + (s3 - s2) * h * dp[idx + 1]
        )

    @cached_property
    def _interval_rotvec_body(self) -> FloatArray:
        """Rotation vector of each record-to-record increment, body frame, shape (N-1, 3)."""
        from scipy.spatial.transform import Rotation  # noqa: PLC0415 - start-up of the CLI

        q = self.q_body_to_ned[:, [1, 2, 3, 0]]
        r0 = Rotation.from_quat(q[:-1])
        r1 = Rotation.from_quat(q[1:])
        delta: FloatArray = (r0.inv() * r1).as_rotvec()  # shortest arc, angle <= pi
        delta.setflags(write=False)
        return delta

    def _slerp(self, idx: IntArray, frac: FloatArray) -> FloatArray:
        """``q[idx] * exp(frac * delta[idx])`` with scalar-first quaternion algebra."""
        v = frac[:, None] * self._interval_rotvec_body[idx]
        angle = np.linalg.norm(v, axis=1)
        # sin(a/2)/a written with sinc so that a -> 0 is exact: sinc(x) = sin(pi x)/(pi x).
        half_sinc = 0.5 * np.sinc(angle / (2.0 * np.pi))
        dw = np.cos(0.5 * angle)
        dx, dy, dz = (v * half_sinc[:, None]).T
        q0 = self.q_body_to_ned[idx]
        w, x, y, z = q0.T
        out = np.column_stack(
            [
                w * dw - x * dx - y * dy - z * dz,
                w * dx + x * dw + y * dz - z * dy,
                w * dy - x * dz + y * dw + z * dx,
                w * dz + x * dy - y * dx + z * dw,
            ]
        )
        out[out[:, 0] < 0.0] *= -1.0
        return out
