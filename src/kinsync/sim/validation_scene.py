"""Validation scenes: control targets beside a road and a wall scanned in a tight curve.

Both scenes follow the acquisition chain, so they give what a mobile-mapping system
records and `kinsync.georef.georeference` turns into a cloud:

1. **Drive.** A planar drive in the tangent NED frame at a geodetic origin: speed
   ``v(t)`` and yaw rate ``omega(t)`` are given functions; the heading and the position
   are integrated on a 1 ms grid (trapezoid, error below 1 um) and interpolated by
   cubic Hermite splines. The body rolls with the lateral acceleration
   (``-roll_per_lateral_accel_deg * v * omega``, the body leans out of the turn) plus
   small road-induced roll and pitch oscillations. The body reference point sits
   ``body_height_m`` above the road.
2. **Trajectory.** Records at ``trajectory_rate_hz`` (geodetic, NED velocities), the
   true motion plus, optionally, a smooth position error (a first-order Gauss-Markov
   process of standard deviation ``trajectory_noise_m`` and correlation time
   ``trajectory_noise_correlation_s`` per axis): what a post-processed GNSS/INS gives.
   The records carry no latency (the true latency is zero): georeferencing with a mount
   latency ``tau`` injects a time error ``tau``.
3. **Scanner.** A 2-D profiler (`Mount.profile_to_scanner`, azimuth 0: the profile
   plane is the scanner Y-Z plane, across the direction of travel), one mirror turn per
   profile at ``profile_rate_hz``, beams every ``angle_step_deg``. A beam at mirror
   angle ``phi`` of the profile starting at ``t_p`` is measured at
   ``t = t_p + ((phi + pi) mod 2 pi) / (2 pi) T``; it is cast from the pose at that very
   time against the scene, the nearest hit kept, and its range gets Gaussian noise
   ``range_noise_m``. Only the beams that can meet an object are cast.
4. **Objects.** Rectangles (wall, target boards) and spheres; each hit carries an
   intensity (retro-reflective targets bright, boards and walls dull).

`control_target_scene` drives a straight road once per speed and direction past
targets on both sides; `curved_wall_scene` drives a straight approach into a 90 deg
right turn (yaw rate rising smoothly to ``speed / radius``) past a straight wall on
the outside of the turn: a time error displaces the wall by
``tau (v + omega x r)``, which changes along the wall as the heading, the yaw rate and
the range change, so the wall really bends (a uniform circular motion would only
rotate it rigidly about the turn centre).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from kinsync._typing import FloatArray
from kinsync._validate import positive_number
from kinsync.errors import InputError
from kinsync.io.atomic import atomic_write_text
from kinsync.io.control_points import write_control_points
from kinsync.io.mount_file import write_mount
from kinsync.io.points import TableChunkWriter
from kinsync.io.trajectory_csv import write_trajectory_csv
from kinsync.mount import Mount
from kinsync.sim.planar_scan import (
    _Disc,
    _gauss_markov,
    _Group,
    _PlanarDrive,
    _Rect,
    _scan_group,
    _Scanner,
    _Sphere,
    _tangent_to_records,
    tangent_to_ecef,
)
from kinsync.trajectory import Trajectory
from kinsync.validation.control_points import ControlPoints

__all__ = [
    "ControlTargetScene",
    "SimulatedScan",
    "WallScene",
    "control_target_scene",
    "curved_wall_scene",
    "write_scene",
]

TargetShape = Literal["sphere", "disc"]

T0_S = 1.3e9
"""GPS time of the first pass (s)."""
DEFAULT_MOUNT = Mount(
    lever_arm_body_m=(-0.6, 0.05, -0.55),
    boresight_rpy_deg=(0.2, -0.3, 0.4),
    profiler_azimuth_deg=0.0,
)
"""A roof-mounted profiler behind the IMU, with a small boresight."""

INTENSITY_RETRO = 2500.0
INTENSITY_DULL = 300.0


# ----------------------------------------------------------------------------- drive


# ----------------------------------------------------------------------------- objects


# ----------------------------------------------------------------------------- containers
@dataclass(frozen=True, eq=False)
class SimulatedScan:
    """A georeference-ready profiler scan with its trajectory and true mount.

    Attributes
    ----------
    t_s : ndarray, shape (N,)
        Point times, GPS time (s), increasing.
    xyz_scanner_m : ndarray, shape (N, 3)
        Points in the scanner frame (m).
    intensity : ndarray, shape (N,)
        Return intensity (LAS-like 0-65535, integer values stored as float64).
    trajectory : Trajectory
        Recorded trajectory (geodetic, NED velocities), true latency zero.
    mount : Mount
        The true mount (lever arm, boresight, profiler azimuth, latency 0).
    truth_tangent_m : ndarray, shape (N, 3)
        True position of every point in the scene's tangent NED frame (m).
    """

    t_s: FloatArray
    xyz_scanner_m: FloatArray
    intensity: FloatArray
    trajectory: Trajectory
    mount: Mount
    truth_tangent_m: FloatArray

    def __len__(self) -> int:
        return int(self.t_s.size)


@dataclass(frozen=True, eq=False)
class ControlTargetScene:
    """Control targets beside a road, scanned at several speeds in both directions.

    Attributes
    ----------
    scan : SimulatedScan
    control : ControlPoints
        Surveyed target centres (truth plus survey noise).
    truth_ecef_m : ndarray, shape (T, 3)
        True target centres, ECEF (m), in the order of ``control.names``.
    target_shape : {"sphere", "disc"}
    target_radius_m : float
    speeds_m_s : tuple of float
        Speed of each pass, in pass order.
    """

    scan: SimulatedScan
    control: ControlPoints
    truth_ecef_m: FloatArray
    target_shape: TargetShape
    target_radius_m: float
    speeds_m_s: tuple[float, ...]


@dataclass(frozen=True, eq=False)
class WallScene:
    """A straight wall scanned from a vehicle entering a tight right turn.

    Attributes
    ----------
    scan : SimulatedScan
    corners_ecef_m : ndarray, shape (4, 3)
        Wall corners, ECEF (m).
    box_ecef_m : tuple of 6 float
        ``(xmin, ymin, zmin, xmax, ymax, zmax)`` ECEF box around the wall (m), the
        ``--box`` that selects it.
    radius_m, speed_m_s : float
        Tightest turn radius (m) and speed (m/s); peak yaw rate ``speed / radius``.
    """

    scan: SimulatedScan
    corners_ecef_m: FloatArray
    box_ecef_m: tuple[float, float, float, float, float, float]
    radius_m: float
    speed_m_s: float


# ----------------------------------------------------------------------------- scenes
def _profile_times(t_start: float, t_end: float, rate_hz: float, phase: float) -> FloatArray:
    k0 = math.ceil((t_start - phase) * rate_hz)
    k1 = math.floor((t_end - phase) * rate_hz)
    return phase + np.arange(k0, k1 + 1) / rate_hz


def _check_target_scene(
    speeds_m_s: tuple[float, ...],
    targets_per_side: int,
    target_shape: str,
    positives: tuple[tuple[float, str], ...],
) -> None:
    if not speeds_m_s:
        msg = "control_target_scene: give at least one speed"
        raise InputError(msg)
    for v in speeds_m_s:
        positive_number(v, "control_target_scene speeds_m_s")
    for value, name in positives:
        positive_number(value, f"control_target_scene {name}")
    if targets_per_side < 1:
        msg = f"control_target_scene: targets_per_side must be >= 1, got {targets_per_side}"
        raise InputError(msg)
    if target_shape not in ("sphere", "disc"):
        msg = f"control_target_scene: target_shape must be sphere or disc, got {target_shape!r}"
        raise InputError(msg)


def _target_layout(
    targets_per_side: int, spacing_m: float, shape: TargetShape, radius_m: float
) -> tuple[list[str], list[_Group], list[FloatArray]]:
    """Names, scanned groups and true centres (tangent NED) of the targets."""
    names: list[str] = []
    groups: list[_Group] = []
    centres: list[FloatArray] = []
    lateral = np.array([5.5, 7.0, 8.5, 6.2, 7.8, 6.6])
    height = np.array([1.2, 1.8, 1.5, 1.0, 2.0, 1.4])
    for side, sign in (("W", -1.0), ("E", 1.0)):
        for i in range(targets_per_side):
            j = (i + (3 if sign > 0 else 0)) % lateral.size
            north = 30.0 + i * spacing_m + (0.35 * spacing_m if sign > 0 else 0.0)
            centre = np.array([north, sign * lateral[j], -height[j]])
            toward_road = np.array([0.0, -sign, 0.0])
            plate_offset = 0.3 if shape == "sphere" else 0.0
            rect = _Rect(
                centre=centre - plate_offset * toward_road,
                normal=toward_road,
                axis1=np.array([1.0, 0.0, 0.0]),
                axis2=np.array([0.0, 0.0, 1.0]),
                half1=0.6,
                half2=0.6,
                intensity=INTENSITY_DULL,
            )
            if shape == "sphere":
                group = _Group(rect, sphere=_Sphere(centre, radius_m, INTENSITY_RETRO))
            else:
                group = _Group(rect, disc=_Disc(centre, radius_m, INTENSITY_RETRO))
            names.append(f"{side}{i + 1}")
            groups.append(group)
            centres.append(centre)
    return names, groups, centres


def control_target_scene(
    *,
    speeds_m_s: tuple[float, ...] = (5.0, 10.0, 15.0, 20.0),
    both_directions: bool = True,
    targets_per_side: int = 4,
    target_spacing_m: float = 12.0,
    target_shape: TargetShape = "sphere",
    target_radius_m: float = 0.2,
    profile_rate_hz: float = 250.0,
    angle_step_deg: float = 0.1,
    range_noise_m: float = 0.005,
    survey_noise_m: float = 0.002,
    trajectory_noise_m: float = 0.002,
    trajectory_noise_correlation_s: float = 0.5,
    trajectory_rate_hz: float = 100.0,
    mount: Mount = DEFAULT_MOUNT,
    seed: int = 0,
) -> ControlTargetScene:
    """Drive a straight road past targets on both sides, once per speed and direction.

    The road runs north; targets stand on both sides (lateral offsets 5.5-8.5 m from
    the centreline, centres 1-2 m above the road), each in front of a dull 1.2 m
    square board facing the road (a sphere 0.3 m in front of it, or a flat disc on it).
    Northbound passes drive the right lane (1.75 m east of the centreline), southbound
    ones the other; passes are separated by 20 s gaps in time (the trajectory holds
    the records of the passes only; nothing is ever interpolated across a gap).

    Parameters
    ----------
    speeds_m_s : tuple of float
        Speed of each pass (m/s, > 0); with ``both_directions`` each is driven north
        and then south.
    both_directions : bool
        Drive every speed both ways (recommended field practice: survey-frame offsets
        then cancel between directions).
    targets_per_side : int
        Targets on each side of the road.
    target_spacing_m : float
        Distance between targets along the road (m).
    target_shape : {"sphere", "disc"}
        Retro-reflective sphere in front of the board, or retro-reflective disc on it.
    target_radius_m : float
        Sphere or disc radius (m).
    profile_rate_hz, angle_step_deg, range_noise_m : float
        Profiler: profiles per second, mirror step (deg), range noise (m, 1 sigma).
    survey_noise_m : float
        Control survey noise (m, 1 sigma per horizontal axis; 1.5x vertically).
    trajectory_noise_m, trajectory_noise_correlation_s : float
        Gauss-Markov position error of the recorded trajectory (m, s).
    trajectory_rate_hz : float
        Trajectory record rate (Hz).
    mount : Mount
        True mount (its latency is ignored: the truth has none).
    seed : int
        Random seed.

    Returns
    -------
    ControlTargetScene
    """
    _check_target_scene(
        speeds_m_s,
        targets_per_side,
        target_shape,
        (
            (target_radius_m, "target_radius_m"),
            (profile_rate_hz, "profile_rate_hz"),
            (angle_step_deg, "angle_step_deg"),
            (range_noise_m, "range_noise_m"),
            (target_spacing_m, "target_spacing_m"),
            (trajectory_rate_hz, "trajectory_rate_hz"),
            (trajectory_noise_correlation_s, "trajectory_noise_correlation_s"),
        ),
    )
    mount = Mount(
        lever_arm_body_m=mount.lever_arm_body_m,
        boresight_rpy_deg=mount.boresight_rpy_deg,
        antenna_lever_arm_body_m=mount.antenna_lever_arm_body_m,
        profiler_azimuth_deg=mount.profiler_azimuth_deg or 0.0,
    )
    rng = np.random.default_rng(seed)
    scanner = _Scanner(profile_rate_hz, math.radians(angle_step_deg), range_noise_m)
    body_height = 1.8
    names, groups, centres = _target_layout(
        targets_per_side, target_spacing_m, target_shape, target_radius_m
    )
    road_end = 30.0 + (targets_per_side - 1) * target_spacing_m + 0.35 * target_spacing_m + 30.0
    passes: list[tuple[float, int]] = []
    for v in speeds_m_s:
        passes.append((float(v), 1))
        if both_directions:
            passes.append((float(v), -1))
    t_parts, xyz_parts, int_parts, truth_parts = [], [], [], []
    rec_parts: list[tuple[FloatArray, FloatArray, FloatArray, FloatArray]] = []
    t_start = 0.0
    for v, direction in passes:
        duration = road_end / v
        start = (0.0, 1.75) if direction > 0 else (road_end, -1.75)
        drive = _PlanarDrive(
            duration,
            _constant(v),
            _constant(0.0),
            start,
            0.0 if direction > 0 else math.pi,
            body_height,
            0.0,
            (0.3, 0.2),
        )
        for group in groups:
            along = (group.rect.centre[0] - start[0]) * direction
            t_mid = along / v
            window = (0.6 + 0.5) / v
            t_prof = _profile_times(
                max(t_mid - window, 0.0),
                min(t_mid + window, duration),
                profile_rate_hz,
                rng.uniform(0, 1 / profile_rate_hz),
            )
            t_rel, xyz, inten, truth = _scan_group(drive, t_prof, group, mount, scanner, rng)
            t_parts.append(t_start + t_rel)
            xyz_parts.append(xyz)
            int_parts.append(inten)
            truth_parts.append(truth)
        t_rel, xyz, inten, truth = _road_returns(drive, np.array([0.1, duration - 0.1]), mount)
        t_parts.append(t_start + t_rel)
        xyz_parts.append(xyz)
        int_parts.append(inten)
        truth_parts.append(truth)
        t_rec = np.arange(0.0, duration + 0.5 / trajectory_rate_hz, 1.0 / trajectory_rate_hz)
        pos, vel, R_bt = drive.state(t_rec)
        pos = pos + _gauss_markov(
            t_rec.size,
            1.0 / trajectory_rate_hz,
            trajectory_noise_m,
            trajectory_noise_correlation_s,
            rng,
        )
        rec_parts.append(_tangent_to_records(T0_S + t_start + t_rec, pos, vel, R_bt))
        t_start += duration + 20.0
    scan = _assemble(t_parts, xyz_parts, int_parts, truth_parts, rec_parts, mount)
    truth_t = np.array(centres)
    noise = rng.normal(0.0, survey_noise_m, truth_t.shape) * np.array([1.0, 1.0, 1.5])
    control = ControlPoints(
        names=tuple(names), pos_ecef_m=tangent_to_ecef(truth_t + noise), source="<simulated>"
    )
    return ControlTargetScene(
        scan=scan,
        control=control,
        truth_ecef_m=tangent_to_ecef(truth_t),
        target_shape=target_shape,
        target_radius_m=float(target_radius_m),
        speeds_m_s=tuple(v for v, _ in passes),
    )


def _road_returns(
    drive: _PlanarDrive, t_rel_s: FloatArray, mount: Mount
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Dull returns from the road straight below the scanner at ``t_rel_s`` (s).

    One at each end of a pass, 0.1 s inside the trajectory's records.

    The simulated scanner casts only the beams that can meet a target, so without these
    a cloud would begin and end on a target; a real scanner records the whole pass. They
    draw no random numbers (the rest of a scene does not depend on them).
    """
    pos, _, R_bt = drive.state(t_rel_s)
    origin = pos + np.einsum("nij,j->ni", R_bt, mount.lever_arm_body_m_array)
    truth = origin * np.array([1.0, 1.0, 0.0])  # the road is the plane D = 0
    R_ts = np.einsum("nij,jk->nik", R_bt, mount.R_scanner_to_body)
    xyz = np.einsum("nji,nj->ni", R_ts, truth - origin)
    return t_rel_s, xyz, np.full(t_rel_s.size, 10.0), truth


def _assemble(
    t_parts: list[FloatArray],
    xyz_parts: list[FloatArray],
    int_parts: list[FloatArray],
    truth_parts: list[FloatArray],
    rec_parts: list[tuple[FloatArray, FloatArray, FloatArray, FloatArray]],
    mount: Mount,
) -> SimulatedScan:
    t = np.concatenate(t_parts) + T0_S
    order = np.argsort(t, kind="stable")
    traj = Trajectory(
        t_s=np.concatenate([r[0] for r in rec_parts]),
        q_body_to_ned=np.concatenate([r[2] for r in rec_parts]),
        lat_lon_h=np.concatenate([r[1] for r in rec_parts]),
        vel_ned_m_s=np.concatenate([r[3] for r in rec_parts]),
    )
    return SimulatedScan(
        t_s=t[order],
        xyz_scanner_m=np.concatenate(xyz_parts)[order],
        intensity=np.concatenate(int_parts)[order],
        trajectory=traj,
        mount=mount,
        truth_tangent_m=np.concatenate(truth_parts)[order],
    )


def _constant(value: float) -> Callable[[FloatArray], FloatArray]:
    def constant(t: FloatArray) -> FloatArray:
        return np.full(np.shape(t), float(value))

    return constant


def _turn_yaw_rate(
    t_turn_s: float, omega_max: float, turn_duration_s: float
) -> Callable[[FloatArray], FloatArray]:
    def yaw_rate(t: FloatArray) -> FloatArray:
        x = (np.asarray(t, dtype=np.float64) - t_turn_s) / turn_duration_s
        inside = (x >= 0.0) & (x <= 1.0)
        out: FloatArray = np.where(inside, omega_max * np.sin(np.pi * x) ** 2, 0.0)
        return out

    return yaw_rate


def curved_wall_scene(
    *,
    radius_m: float = 12.0,
    speed_m_s: float = 5.0,
    wall_offset_m: float = 6.0,
    wall_start_m: float = 10.0,
    wall_length_m: float = 25.0,
    wall_height_m: float = 4.0,
    approach_m: float = 15.0,
    profile_rate_hz: float = 100.0,
    angle_step_deg: float = 0.25,
    range_noise_m: float = 0.005,
    outlier_fraction: float = 0.002,
    trajectory_rate_hz: float = 100.0,
    mount: Mount = DEFAULT_MOUNT,
    seed: int = 0,
) -> WallScene:
    """A straight wall on the outside of a tight right turn, scanned by the profiler.

    The vehicle drives north along ``E = 0`` for ``approach_m``, then turns right by
    90 deg with a yaw rate ``omega(t) = omega_max sin^2(pi t / T)``,
    ``omega_max = speed / radius`` (``T = pi / omega_max``), then drives east. The
    wall is the vertical plane ``E = -wall_offset_m`` (west of the road, facing it)
    from ``N = wall_start_m`` over ``wall_length_m``, from the road up to
    ``wall_height_m``; the left half of each profile sweeps it, at ranges from
    ``wall_offset_m`` to about twice that as the heading turns. A fraction
    ``outlier_fraction`` of the returns is clutter 0.2-1 m in front of the wall.

    Parameters
    ----------
    radius_m, speed_m_s : float
        Tightest radius (m) and constant speed (m/s).
    wall_offset_m, wall_start_m, wall_length_m, wall_height_m, approach_m : float
        Geometry (m), see above.
    profile_rate_hz, angle_step_deg, range_noise_m : float
        Profiler: profiles per second, mirror step (deg), range noise (m, 1 sigma).
    outlier_fraction : float
        Fraction of returns replaced by clutter in front of the wall, in [0, 0.5).
    trajectory_rate_hz : float
        Trajectory record rate (Hz); the records carry the true motion.
    mount : Mount
        True mount (its latency is ignored).
    seed : int
        Random seed.

    Returns
    -------
    WallScene
    """
    for value, name in (
        (radius_m, "radius_m"),
        (speed_m_s, "speed_m_s"),
        (wall_offset_m, "wall_offset_m"),
        (wall_length_m, "wall_length_m"),
        (wall_height_m, "wall_height_m"),
        (approach_m, "approach_m"),
        (profile_rate_hz, "profile_rate_hz"),
        (angle_step_deg, "angle_step_deg"),
        (range_noise_m, "range_noise_m"),
        (trajectory_rate_hz, "trajectory_rate_hz"),
    ):
        positive_number(value, f"curved_wall_scene {name}")
    if not 0.0 <= outlier_fraction < 0.5:
        msg = f"curved_wall_scene: outlier_fraction must lie in [0, 0.5), got {outlier_fraction}"
        raise InputError(msg)
    mount = Mount(
        lever_arm_body_m=mount.lever_arm_body_m,
        boresight_rpy_deg=mount.boresight_rpy_deg,
        antenna_lever_arm_body_m=mount.antenna_lever_arm_body_m,
        profiler_azimuth_deg=mount.profiler_azimuth_deg or 0.0,
    )
    rng = np.random.default_rng(seed)
    omega_max = speed_m_s / radius_m
    turn_s = math.pi / omega_max
    t_turn = approach_m / speed_m_s
    duration = t_turn + turn_s + 3.0
    drive = _PlanarDrive(
        duration,
        _constant(speed_m_s),
        _turn_yaw_rate(t_turn, omega_max, turn_s),
        (0.0, 0.0),
        0.0,
        1.8,
        0.4,
        (0.05, 0.05),
    )
    wall = _Rect(
        centre=np.array([wall_start_m + wall_length_m / 2, -wall_offset_m, -wall_height_m / 2]),
        normal=np.array([0.0, 1.0, 0.0]),
        axis1=np.array([1.0, 0.0, 0.0]),
        axis2=np.array([0.0, 0.0, 1.0]),
        half1=wall_length_m / 2,
        half2=wall_height_m / 2,
        intensity=INTENSITY_DULL,
    )
    scanner = _Scanner(profile_rate_hz, math.radians(angle_step_deg), range_noise_m)
    t_prof = _profile_times(0.0, duration, profile_rate_hz, rng.uniform(0, 1 / profile_rate_hz))
    t_rel, xyz, inten, truth = _scan_group(drive, t_prof, _Group(wall), mount, scanner, rng)
    n_out = round(outlier_fraction * t_rel.size)
    if n_out:
        idx = rng.choice(t_rel.size, n_out, replace=False)
        r = np.linalg.norm(xyz[idx], axis=1)
        shorter = rng.uniform(0.2, 1.0, n_out)
        xyz[idx] *= ((r - shorter) / r)[:, None]
        inten[idx] = np.round(INTENSITY_DULL * rng.uniform(0.3, 3.0, n_out))
    t_rec = np.arange(0.0, duration + 0.5 / trajectory_rate_hz, 1.0 / trajectory_rate_hz)
    pos, vel, R_bt = drive.state(t_rec)
    scan = _assemble(
        [t_rel], [xyz], [inten], [truth], [_tangent_to_records(T0_S + t_rec, pos, vel, R_bt)], mount
    )
    signs = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], dtype=np.float64)
    corners_t = (
        wall.centre
        + signs[:, :1] * wall.half1 * wall.axis1
        + signs[:, 1:] * wall.half2 * wall.axis2
    )
    corners = tangent_to_ecef(corners_t)
    # The box also holds the clutter in front of the wall (up to 1 m) and a margin.
    near = tangent_to_ecef(corners_t + 1.2 * wall.normal)
    every = np.vstack([corners, near, tangent_to_ecef(corners_t - 0.3 * wall.normal)])
    lo = every.min(axis=0) - 0.3
    hi = every.max(axis=0) + 0.3
    box = (
        float(lo[0]),
        float(lo[1]),
        float(lo[2]),
        float(hi[0]),
        float(hi[1]),
        float(hi[2]),
    )
    return WallScene(
        scan=scan,
        corners_ecef_m=corners,
        box_ecef_m=box,
        radius_m=float(radius_m),
        speed_m_s=float(speed_m_s),
    )


def write_scene(
    scene: ControlTargetScene | WallScene, folder: Path, *, points_suffix: str = ".csv"
) -> dict[str, Path]:
    """Write a scene as the files a survey gives, ready for ``kinsync georef``.

    Files: ``points<suffix>`` (``t_s,x_m,y_m,z_m,intensity``, scanner frame),
    ``trajectory.csv`` (`kinsync.io.trajectory_csv`), ``mount.toml`` (the true mount,
    latency 0) and ``control.csv`` (geodetic control points; control-target scene) or
    ``box.txt`` (the ``--box`` of the wall, ECEF; wall scene).

    Parameters
    ----------
    scene : ControlTargetScene or WallScene
    folder : Path
        Existing folder.
    points_suffix : {".csv", ".parquet"}
        Format of the point table.

    Returns
    -------
    dict of str to Path
        ``"points"``, ``"trajectory"``, ``"mount"`` and ``"control"`` or ``"box"``.

    Raises
    ------
    InputError
        A missing folder, an unknown suffix.
    """
    folder = Path(folder)
    if not folder.is_dir():
        msg = f"{folder}: folder not found; create it first"
        raise InputError(msg)
    scan = scene.scan
    paths = {
        "points": folder / f"points{points_suffix}",
        "trajectory": folder / "trajectory.csv",
        "mount": folder / "mount.toml",
    }
    with TableChunkWriter(paths["points"]) as writer:
        writer.write(
            {
                "t_s": scan.t_s,
                "x_m": scan.xyz_scanner_m[:, 0],
                "y_m": scan.xyz_scanner_m[:, 1],
                "z_m": scan.xyz_scanner_m[:, 2],
                "intensity": scan.intensity.astype(np.int64),
            }
        )
    write_trajectory_csv(scan.trajectory, paths["trajectory"])
    write_mount(scan.mount, paths["mount"])
    if isinstance(scene, ControlTargetScene):
        paths["control"] = folder / "control.csv"
        write_control_points(scene.control, paths["control"])
    else:
        paths["box"] = folder / "box.txt"
        atomic_write_text(paths["box"], ",".join(repr(v) for v in scene.box_ecef_m) + "\n")
    return paths
