"""The patch test's drive: lines both ways at several speeds, joined by turnarounds.

For each speed (one `kinsync.sim._route.Route` per speed, driven one after the other
from a standstill between them) the platform drives the line outbound (``+u``) on the
outbound lane, turns back onto the return lane, drives the line back (``-u``), turns
again, and so on: ``passes_per_direction`` lines each way. A turnaround is a left-hand
"balloon" — a right turn of ``alpha``, a left loop of ``180 + 2 alpha``, a right turn of
``alpha`` — whose ``alpha`` puts the return line exactly ``lane spacing`` to the left
(a roundabout at each end of the street, or a wide turn in the channel); when the
lanes are wider apart than a plain U-turn, a U-turn of two quarter turns with a
straight between them. The turn radius is ``max(min_turn_radius, v^2 / a_lat)``, so a
faster block turns wider. Each block starts from a standstill far enough before the
first line to reach its cruise speed and ends far enough past its last line to stop:
the lines are driven at constant speed.

On top of the route's exact kinematics (`kinsync.sim.drive_truth.simulate_truth`) come
the platform's own motions as functions of GPS time, continuous across the blocks:
roll ``A_r sin(2 pi t / P_r)``, pitch ``A_p sin(2 pi t / P_p + pi / 3)`` and heave
``A_h sin(2 pi t / P_h + pi / 5)`` (upwards), with the vertical velocity to match.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Literal

import numpy as np
from scipy.optimize import brentq

from kinsync._typing import FloatArray
from kinsync._validate import finite_number, positive_number
from kinsync.errors import InputError
from kinsync.frames import (
    ecef_to_geodetic,
    euler_rpy_to_quaternion,
    ned_to_ecef,
    rotation_ned_to_ecef,
)
from kinsync.sim._route import (
    DEFAULT_TRANSITION_FRACTION,
    Route,
    Segment,
    Straight,
    Turn,
    turn_chord_m,
)
from kinsync.sim.drive_truth import DriveTrajectory, simulate_truth
from kinsync.sim.patch_scene import ScenarioLayout, street_to_ned
from kinsync.trajectory import Trajectory

__all__ = [
    "LineWindow",
    "PatchDrive",
    "PlatformMotion",
    "drive_patch_test",
    "turnaround",
]

_F = DEFAULT_TRANSITION_FRACTION
_MARGIN_M = 10.0
"""Extra straight beyond what speeding up or slowing down needs (m)."""
_STATIC_S = 5.0
"""Standstill at the start and the end of the drive (s)."""

Direction = Literal["outbound", "return"]


@dataclass(frozen=True)
class PlatformMotion:
    """Roll, pitch and heave of the platform (waves, or a car's body on its springs).

    Attributes
    ----------
    roll_amplitude_deg, roll_period_s : float
        Roll ``A sin(2 pi t / P)`` (deg, s), t in GPS seconds.
    pitch_amplitude_deg, pitch_period_s : float
        Pitch ``A sin(2 pi t / P + pi / 3)`` (deg, s).
    heave_amplitude_m, heave_period_s : float
        Height ``A sin(2 pi t / P + pi / 5)`` (m, s), upwards.
    """

    roll_amplitude_deg: float = 0.0
    roll_period_s: float = 6.0
    pitch_amplitude_deg: float = 0.0
    pitch_period_s: float = 8.0
    heave_amplitude_m: float = 0.0
    heave_period_s: float = 6.0

    def __post_init__(self) -> None:
        for name in ("roll_period_s", "pitch_period_s", "heave_period_s"):
            object.__setattr__(self, name, positive_number(getattr(self, name), name))
        for name in ("roll_amplitude_deg", "pitch_amplitude_deg", "heave_amplitude_m"):
            value = finite_number(getattr(self, name), name)
            if value < 0.0:
                msg = f"platform motion {name} must be >= 0, got {value}"
                raise InputError(msg)
            object.__setattr__(self, name, value)
        if self.roll_amplitude_deg > 30.0 or self.pitch_amplitude_deg > 20.0:
            msg = (
                f"platform motion: roll {self.roll_amplitude_deg} deg / pitch "
                f"{self.pitch_amplitude_deg} deg; keep them within 30 / 20 deg"
            )
            raise InputError(msg)


@dataclass(frozen=True)
class LineWindow:
    """When and how one line was driven.

    Attributes
    ----------
    name : str
        ``line_01``, ``line_02``, ... in driving order.
    t_start_s, t_end_s : float
        GPS times at which the body reference point passes the line's ends (s).
    speed_m_s : float
        Cruise speed over the line (m/s).
    heading_deg : float
        Heading of the line (deg, clockwise from North, in [0, 360)).
    direction : {"outbound", "return"}
        Along ``+u`` (outbound lane) or ``-u`` (return lane).
    """

    name: str
    t_start_s: float
    t_end_s: float
    speed_m_s: float
    heading_deg: float
    direction: Direction


@dataclass(frozen=True, eq=False)
class PatchDrive:
    """The exact drive of a patch test and where its lines are.

    Attributes
    ----------
    truth : Trajectory
        Exact motion of the body (geodetic, with velocities), GPS time.
    lines : tuple of LineWindow
    length_m : float
        Horizontal path length of the whole drive (m).
    """

    truth: Trajectory
    lines: tuple[LineWindow, ...]
    length_m: float


def _segment_length_m(seg: Segment) -> float:
    if isinstance(seg, Straight):
        return seg.length_m
    if isinstance(seg, Turn):
        return seg.radius_m * abs(math.radians(seg.angle_deg)) * (1.0 + _F)
    return 0.0


def _displacement_m(segments: tuple[Segment, ...]) -> tuple[float, float]:
    """Net displacement (forward, right) of segments in the entry frame (m)."""
    psi, fwd, right = 0.0, 0.0, 0.0
    for seg in segments:
        if isinstance(seg, Straight):
            fwd += seg.length_m * math.cos(psi)
            right += seg.length_m * math.sin(psi)
        elif isinstance(seg, Turn):
            c = turn_chord_m(seg.angle_deg, seg.radius_m, _F)
            fwd += float(c[0] * math.cos(psi) - c[1] * math.sin(psi))
            right += float(c[0] * math.sin(psi) + c[1] * math.cos(psi))
            psi += math.radians(seg.angle_deg)
    return fwd, right


@lru_cache(maxsize=64)
def turnaround(radius_m: float, offset_left_m: float) -> tuple[Segment, ...]:
    """Segments that turn the platform back onto a parallel line to its left.

    Parameters
    ----------
    radius_m : float
        Tightest radius of the turns (m), > 0.
    offset_left_m : float
        Distance between the two lines (m), > 0; the return line lies to the left.

    Returns
    -------
    tuple of Segment
        A balloon ``Turn(alpha), Turn(-(180 + 2 alpha)), Turn(alpha)`` when the offset is
        below a plain U-turn's ``2.022 R``, else ``Turn(-90), Straight, Turn(-90)``. Its
        net displacement is ``offset_left_m`` to the left (to 1e-9 m).
    """
    r = positive_number(radius_m, "turnaround radius_m")
    off = positive_number(offset_left_m, "turnaround offset_left_m")
    u_turn = float(-turn_chord_m(-180.0, r, _F)[1])
    if off >= u_turn:
        quarter = -float(turn_chord_m(-90.0, r, _F)[1])
        extra = off - 2.0 * quarter
        if extra <= 1e-9:
            return (Turn(-180.0, r),)
        return (Turn(-90.0, r), Straight(extra), Turn(-90.0, r))

    def balloon(alpha_deg: float) -> tuple[Segment, ...]:
        return (Turn(alpha_deg, r), Turn(-(180.0 + 2.0 * alpha_deg), r), Turn(alpha_deg, r))

    def miss(alpha_deg: float) -> float:
        return _displacement_m(balloon(alpha_deg))[1] + off

    alpha = float(brentq(miss, 1e-6, 89.0, xtol=1e-12))
    return balloon(alpha)


def _ramp_m(speed_m_s: float, max_acc_m_s2: float) -> float:
    """Path needed to reach ``speed_m_s`` from a standstill (the route's smooth step)."""
    return 1.875 * speed_m_s * speed_m_s / (2.0 * max_acc_m_s2)


def _turn_radius_m(speed_m_s: float, layout: ScenarioLayout) -> float:
    return max(layout.min_turn_radius_m, speed_m_s * speed_m_s / layout.lateral_acc_m_s2)


def _block_segments(
    speeds_m_s: tuple[float, ...], passes: int, layout: ScenarioLayout
) -> list[tuple[list[Segment], list[int]]]:
    """Segments of each speed block and the indices of its line segments."""
    spacing = layout.outbound_lane_w_m - layout.return_lane_w_m
    turns = [turnaround(_turn_radius_m(v, layout), spacing) for v in speeds_m_s]
    fwd = [_displacement_m(t)[0] for t in turns]
    turn_len = [sum(_segment_length_m(s) for s in t) for t in turns]
    ramps = [_ramp_m(v, layout.max_acc_m_s2) for v in speeds_m_s]
    blocks: list[tuple[list[Segment], list[int]]] = []
    gap = 5.0
    run_out_prev = 0.0
    for k, _v in enumerate(speeds_m_s):
        segs: list[Segment] = []
        if k == 0:
            segs.append(Straight(ramps[0] + _MARGIN_M))
        else:
            segs.extend(turns[k])
            segs.append(Straight(run_out_prev + fwd[k]))
        lines: list[int] = []
        for p in range(passes):
            lines.append(len(segs))
            segs.append(Straight(layout.line_length_m))
            segs.extend([Straight(gap), *turns[k], Straight(gap + fwd[k])])
            lines.append(len(segs))
            segs.append(Straight(layout.line_length_m))
            if p < passes - 1:
                segs.extend([Straight(gap), *turns[k], Straight(gap + fwd[k])])
        run_out = ramps[k] + _MARGIN_M
        if k + 1 < len(speeds_m_s):
            # the next block speeds up through its turnaround and the straight after it
            run_out = max(run_out, ramps[k + 1] + _MARGIN_M - fwd[k + 1] - turn_len[k + 1])
        segs.append(Straight(run_out))
        run_out_prev = run_out
        blocks.append((segs, lines))
    return blocks


def _start_pose(
    origin_lat_lon_h: tuple[float, float, float],
    street_azimuth_deg: float,
    start_uwd_m: tuple[float, float, float],
) -> tuple[tuple[float, float, float], float]:
    """Geodetic start position and the street's azimuth in the start's own NED frame."""
    p = street_to_ned(np.array([start_uwd_m]), street_azimuth_deg)[0]
    llh = ecef_to_geodetic(ned_to_ecef(p, *origin_lat_lon_h))
    a = math.radians(street_azimuth_deg)
    d_ecef = rotation_ned_to_ecef(origin_lat_lon_h[0], origin_lat_lon_h[1]) @ np.array(
        [math.cos(a), math.sin(a), 0.0]
    )
    d_start = rotation_ned_to_ecef(float(llh[0]), float(llh[1])).T @ d_ecef
    yaw = math.degrees(math.atan2(d_start[1], d_start[0]))
    return (float(llh[0]), float(llh[1]), float(llh[2])), yaw


def _time_at(t_s: FloatArray, s_m: FloatArray, s_target_m: float) -> float:
    """GPS time at which the path length ``s_m`` (non-decreasing) reaches ``s_target_m``."""
    k = int(np.clip(np.searchsorted(s_m, s_target_m), 1, s_m.size - 1))
    ds = s_m[k] - s_m[k - 1]
    frac = 0.0 if ds <= 0.0 else (s_target_m - s_m[k - 1]) / ds
    return float(t_s[k - 1] + frac * (t_s[k] - t_s[k - 1]))


def _with_platform_motion(traj: Trajectory, motion: PlatformMotion) -> Trajectory:
    """The trajectory with roll, pitch and heave added (functions of GPS time)."""
    assert traj.lat_lon_h is not None
    assert traj.vel_ned_m_s is not None
    t = traj.t_s
    rpy = traj.euler_rpy_rad()
    w_r = 2.0 * math.pi / motion.roll_period_s
    w_p = 2.0 * math.pi / motion.pitch_period_s
    w_h = 2.0 * math.pi / motion.heave_period_s
    roll = rpy[:, 0] + math.radians(motion.roll_amplitude_deg) * np.sin(w_r * t)
    pitch = rpy[:, 1] + math.radians(motion.pitch_amplitude_deg) * np.sin(w_p * t + math.pi / 3.0)
    llh = traj.lat_lon_h.copy()
    vel = traj.vel_ned_m_s.copy()
    llh[:, 2] += motion.heave_amplitude_m * np.sin(w_h * t + math.pi / 5.0)
    vel[:, 2] -= motion.heave_amplitude_m * w_h * np.cos(w_h * t + math.pi / 5.0)
    return Trajectory(
        t_s=t,
        q_body_to_ned=euler_rpy_to_quaternion(roll, pitch, rpy[:, 2]),
        lat_lon_h=llh,
        vel_ned_m_s=vel,
    )


def drive_patch_test(
    layout: ScenarioLayout,
    origin_lat_lon_h: tuple[float, float, float],
    street_azimuth_deg: float,
    speeds_m_s: tuple[float, ...],
    passes_per_direction: int,
    motion: PlatformMotion,
    *,
    rate_hz: float,
    t_start_s: float,
) -> PatchDrive:
    """Drive the patch test's lines (see the module docstring).

    Parameters
    ----------
    layout : ScenarioLayout
        Lines, lanes, body height, turn and speed limits.
    origin_lat_lon_h : tuple of 3 float
        Geodetic origin of the scene frame (deg, deg, m).
    street_azimuth_deg : float
        Azimuth of the outbound direction (deg).
    speeds_m_s : tuple of float
        Cruise speed of each block (m/s), driven in this order.
    passes_per_direction : int
        Lines each way per speed.
    motion : PlatformMotion
        Roll, pitch and heave added to the route's motion.
    rate_hz : float
        Trajectory record rate (Hz).
    t_start_s : float
        GPS time of the first record (s).

    Returns
    -------
    PatchDrive
        Lines named ``line_01``... in driving order.
    """
    blocks = _block_segments(speeds_m_s, passes_per_direction, layout)
    start_uwd = (
        layout.line_start_u_m - _segment_length_m(blocks[0][0][0]),
        layout.outbound_lane_w_m,
        -layout.body_height_m,
    )
    llh, yaw_deg = _start_pose(origin_lat_lon_h, street_azimuth_deg, start_uwd)
    t0 = t_start_s
    parts: list[DriveTrajectory] = []
    lines: list[LineWindow] = []
    length = 0.0
    for k, ((segs, line_idx), v) in enumerate(zip(blocks, speeds_m_s, strict=True)):
        route = Route(
            tuple(segs),
            speed_m_s=v,
            max_acc_m_s2=layout.max_acc_m_s2,
            static_s=_STATIC_S if k == 0 else 0.0,
            end_static_s=_STATIC_S if k == len(blocks) - 1 else 0.0,
        )
        span = math.ceil(route.duration_s * rate_hz - 1e-9) / rate_hz
        block = simulate_truth(
            route,
            rate_hz=rate_hz,
            origin_lat_lon_h=llh,
            initial_yaw_deg=yaw_deg,
            t_start_s=t0,
            duration_s=span,
        )
        starts = np.concatenate([[0.0], np.cumsum([_segment_length_m(s) for s in segs])])
        path_m = block.state(block.t_s).s_m
        for i in line_idx:
            ta = _time_at(block.t_s, path_m, float(starts[i]))
            tb = _time_at(block.t_s, path_m, float(starts[i + 1]))
            outbound = len(lines) % 2 == 0
            heading = street_azimuth_deg + (0.0 if outbound else 180.0)
            lines.append(
                LineWindow(
                    name=f"line_{len(lines) + 1:02d}",
                    t_start_s=ta,
                    t_end_s=tb,
                    speed_m_s=v,
                    heading_deg=heading % 360.0,
                    direction="outbound" if outbound else "return",
                )
            )
        parts.append(block)
        length += route.length_m
        assert block.lat_lon_h is not None
        end = block.lat_lon_h[-1]
        llh = (float(end[0]), float(end[1]), float(end[2]))
        yaw_deg = math.degrees(float(block.euler_rpy_rad()[-1, 2]))
        t0 = float(block.t_s[-1])
    joined = Trajectory(
        t_s=np.concatenate([p.t_s[(k > 0) :] for k, p in enumerate(parts)]),
        q_body_to_ned=np.concatenate([p.q_body_to_ned[(k > 0) :] for k, p in enumerate(parts)]),
        lat_lon_h=np.concatenate([_llh(p)[(k > 0) :] for k, p in enumerate(parts)]),
        vel_ned_m_s=np.concatenate([_vel(p)[(k > 0) :] for k, p in enumerate(parts)]),
    )
    return PatchDrive(
        truth=_with_platform_motion(joined, motion), lines=tuple(lines), length_m=length
    )


def _llh(traj: Trajectory) -> FloatArray:
    assert traj.lat_lon_h is not None
    return traj.lat_lon_h


def _vel(traj: Trajectory) -> FloatArray:
    assert traj.vel_ned_m_s is not None
    return traj.vel_ned_m_s
