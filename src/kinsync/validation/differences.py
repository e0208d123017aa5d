"""Control-point differences in the vehicle frame (SPEC section 7).

The difference cloud - control is expressed in the vehicle frame (X right, Y forward,
Z up) of the attitude at the visit's time (median GPS time of its points), read from
the trajectory at that time. Alongside: the vehicle's forward speed, its yaw rate and
the target's position relative to the vehicle (``lateral_m`` = X, left < 0 < right).
A visit whose time lies outside the trajectory's span or inside one of its data gaps
(`kinsync.trajectory_gaps`: the trajectory holds no state there, only a guess
interpolated across the hole) is not used: it is reported missing with the reason.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from kinsync._typing import FloatArray
from kinsync.errors import InputError
from kinsync.frames import (
    body_to_vehicle,
    ecef_to_geodetic,
    rotation_ned_to_ecef,
)
from kinsync.trajectory import Trajectory
from kinsync.trajectory_gaps import (
    GAP_ADVICE,
    TrajectoryGap,
    gap_index,
    gap_threshold_text,
    max_gap_for,
)
from kinsync.validation.control_points import ControlPoints
from kinsync.validation.targets import MissingTarget, TargetObservation

__all__ = [
    "ControlPointDifference",
    "control_point_differences",
]

_RATE_STEP_S = 0.05


@dataclass(frozen=True)
class ControlPointDifference:
    """Cloud - control for one visit, in the vehicle frame at the moment of scanning.

    Attributes
    ----------
    observation : TargetObservation
    diff_vehicle_m : tuple of 3 float
        (dX right, dY forward, dZ up) of cloud - control (m).
    diff_ned_m : tuple of 3 float
        The same difference in NED at the vehicle (m).
    speed_m_s : float
        Forward speed of the vehicle (vehicle-frame Y velocity, m/s).
    along_speed_m_s : float
        Along-track (Y) velocity of the target point carried with the vehicle frame,
        ``v + omega x r`` (m/s): the time-error regressor.
    heading_deg : float
        Heading (yaw) of the vehicle at the visit (deg from north, clockwise).
    yaw_rate_deg_s : float
        Yaw rate of the vehicle (body z rate, deg/s; > 0 turning right).
    lateral_m : float
        Target position relative to the vehicle reference point, X right (m).
    forward_m, up_m : float
        The target's Y (forward) and Z (up) relative to the vehicle (m).
    """

    observation: TargetObservation
    diff_vehicle_m: tuple[float, float, float]
    diff_ned_m: tuple[float, float, float]
    speed_m_s: float
    along_speed_m_s: float
    heading_deg: float
    yaw_rate_deg_s: float
    lateral_m: float
    forward_m: float
    up_m: float

    @property
    def side(self) -> str:
        """``"left"`` or ``"right"`` of the vehicle."""
        return "left" if self.lateral_m < 0.0 else "right"


def _unreadable(
    trajectory: Trajectory, t_s: float, gaps: tuple[TrajectoryGap, ...], max_gap_s: float
) -> str | None:
    """Why the trajectory has no state at ``t_s`` (outside its span, in a gap), or None.

    ``gaps`` are the trajectory's gaps at the threshold ``max_gap_s`` (s).
    """
    k = int(gap_index(t_s, gaps))
    if k >= 0:
        return (
            f"visit time {t_s!r} s in a data gap of the trajectory, {gaps[k].describe()} "
            f"without a record, one of its {gap_threshold_text(max_gap_s)}: not "
            f"interpolated across ({GAP_ADVICE})"
        )
    if not trajectory.t_start_s <= t_s <= trajectory.t_end_s:
        return (
            f"visit time {t_s!r} s outside the trajectory span "
            f"[{trajectory.t_start_s!r}, {trajectory.t_end_s!r}] s"
        )
    lo, hi = _stretch(trajectory, t_s, gaps)
    if hi <= lo:
        return (
            f"visit time {t_s!r} s on a lone trajectory record between two data gaps "
            f"({gap_threshold_text(max_gap_s)}): the vehicle's velocity and turn rate are "
            f"unknown there ({GAP_ADVICE})"
        )
    return None


def _stretch(
    trajectory: Trajectory, t_s: float, gaps: tuple[TrajectoryGap, ...]
) -> tuple[float, float]:
    """The stretch of records around ``t_s`` without one of ``gaps``: (start, end) (s)."""
    lo, hi = trajectory.t_start_s, trajectory.t_end_s
    for gap in gaps:
        if gap.t_end_s <= t_s:
            lo = gap.t_end_s
        elif gap.t_start_s >= t_s:
            hi = gap.t_start_s
            break
    return lo, hi


def _states_at(
    trajectory: Trajectory, t_s: float, gaps: tuple[TrajectoryGap, ...]
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Position ECEF, R_body_to_ned, velocity NED and body rate at ``t_s``.

    ``t_s`` is one the trajectory can be read at (`_unreadable` is None). Velocity and
    rate are central differences over +-0.05 s, moved inside the stretch of records
    without a data gap near its ends.
    """
    lo, hi = _stretch(trajectory, t_s, gaps)
    h = min(_RATE_STEP_S, (hi - lo) / 2.0)
    a = max(lo, min(t_s - h, hi - 2.0 * h))  # never into a gap, even by rounding
    b = min(hi, a + 2.0 * h)
    # within one stretch without a gap of ``gaps``: the span check alone is left to do
    sample = trajectory.interpolate(np.array([t_s, a, b]), max_gap_s=math.inf)
    pos = sample.pos_ecef_m()
    llh = ecef_to_geodetic(pos[0])
    R_ne = rotation_ned_to_ecef(llh[0], llh[1])
    vel_ned = R_ne.T @ ((pos[2] - pos[1]) / (b - a))
    q = sample.q_body_to_ned[1:, [1, 2, 3, 0]]
    rate_body = (Rotation.from_quat(q[0]).inv() * Rotation.from_quat(q[1])).as_rotvec() / (b - a)
    return pos[0], sample.R_body_to_ned[0], vel_ned, rate_body


def control_point_differences(
    observations: tuple[TargetObservation, ...],
    control: ControlPoints,
    trajectory: Trajectory,
    *,
    max_gap_s: float | None = None,
) -> tuple[tuple[ControlPointDifference, ...], tuple[MissingTarget, ...]]:
    """Express each observation's cloud - control difference in the vehicle frame.

    Parameters
    ----------
    observations : tuple of TargetObservation
        From `extract_targets`.
    control : ControlPoints
        The same control points.
    trajectory : Trajectory
        Vehicle trajectory on the cloud's time scale. The state is read at the
        observation's time (a latency of milliseconds changes the vehicle frame by far
        less than the differences' precision). Velocity and body rate come from central
        differences over +-0.05 s.
    max_gap_s : float, optional
        Longest trajectory record interval (s) interpolated across; default
        `kinsync.trajectory_gaps.GAP_FACTOR` median record intervals
        (`kinsync.trajectory_gaps.max_gap_for`).

    Returns
    -------
    differences : tuple of ControlPointDifference
    missing : tuple of MissingTarget
        Observations whose time lies outside the trajectory's span or inside one of its
        data gaps (`kinsync.trajectory.Trajectory.gaps`), with the reason.

    Raises
    ------
    InputError
        A ``max_gap_s`` that is not a positive number; an observation whose name is not
        one of ``control``'s.
    """
    limit_s = max_gap_for(trajectory.t_s, max_gap_s)
    gaps = trajectory.gaps(max_gap_s)
    index = {n: i for i, n in enumerate(control.names)}
    unknown = sorted({obs.name for obs in observations} - set(index))
    if unknown:
        msg = (
            f"control_point_differences: observations of {', '.join(unknown)} but control "
            f"has no such point (it has {', '.join(control.names) or 'none'}); pass the "
            "control points the observations were extracted with"
        )
        raise InputError(msg)
    out: list[ControlPointDifference] = []
    missing: list[MissingTarget] = []
    for obs in observations:
        reason = _unreadable(trajectory, obs.t_s, gaps, limit_s)
        if reason is not None:
            missing.append(MissingTarget(obs.name, reason, obs.t_s))
            continue
        pos_ecef, R_bn, vel_ned, rate_body = _states_at(trajectory, obs.t_s, gaps)
        llh = ecef_to_geodetic(pos_ecef)
        R_ne = rotation_ned_to_ecef(llh[0], llh[1])
        target = control.pos_ecef_m[index[obs.name]]
        diff_ned = R_ne.T @ (np.asarray(obs.centre_ecef_m) - target)
        diff_v = body_to_vehicle(R_bn.T @ diff_ned)
        r_body = R_bn.T @ (R_ne.T @ (target - pos_ecef))
        r_v = body_to_vehicle(r_body)
        v_body = R_bn.T @ vel_ned
        sweep_v = body_to_vehicle(v_body + np.cross(rate_body, r_body))
        out.append(
            ControlPointDifference(
                observation=obs,
                diff_vehicle_m=(float(diff_v[0]), float(diff_v[1]), float(diff_v[2])),
                diff_ned_m=(float(diff_ned[0]), float(diff_ned[1]), float(diff_ned[2])),
                speed_m_s=float(v_body[0]),
                along_speed_m_s=float(sweep_v[1]),
                heading_deg=math.degrees(math.atan2(float(R_bn[1, 0]), float(R_bn[0, 0]))),
                yaw_rate_deg_s=math.degrees(float(rate_body[2])),
                lateral_m=float(r_v[0]),
                forward_m=float(r_v[1]),
                up_m=float(r_v[2]),
            )
        )
    return tuple(out), tuple(missing)
