"""The end-to-end demo's survey: one simulated drive, scene, scan, IMU and GNSS.

An oval driven almost three times, one truth feeding a profile scanner with a known
latency, a navigation-grade IMU and RTK GNSS, over a scene with sync spheres, control
spheres on both sides of the first straight and a wall at the first turn's entry (see
`kinsync.demo.end_to_end` for why each is where it is).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from kinsync._typing import FloatArray, IntArray
from kinsync._validate import positive_number
from kinsync.clock.profile import ProfileClock
from kinsync.demo.method_a import DEMO_LATENCY_S
from kinsync.errors import InputError
from kinsync.frames import ecef_to_ned, ned_to_ecef
from kinsync.georef import GeorefTrajectory, georeference
from kinsync.ins.config import InsConfig
from kinsync.ins.measurements import GnssData, ImuData
from kinsync.mount import Mount
from kinsync.sim.drive import Route, Straight, Turn
from kinsync.sim.drive_truth import DriveTrajectory, simulate_truth
from kinsync.sim.gnss import simulate_gnss
from kinsync.sim.imu import ImuErrorModel, simulate_imu
from kinsync.sim.profiler import (
    ProfilerConfig,
    ProfilerSimulation,
    profiles_near_targets,
    simulate_profiler,
)
from kinsync.sim.scene import Scene, SceneLayout, Target, Wall, build_drive_scene
from kinsync.sim.scene import trajectory_to_local as _to_local
from kinsync.sync.scan import SyncPoints
from kinsync.trajectory import Trajectory
from kinsync.validation import (
    CloudPoints,
)
from kinsync.validation.control_points import ControlPoints

__all__ = [
    "CONTROL_RADIUS_M",
    "TARGET_INTENSITY_MIN",
    "EndToEndConfig",
    "Survey",
    "georeference_scan",
    "simulate_survey",
    "time_at_path",
    "wall_selection",
]

_START_GPS_S = 1.4e9


_T0_OFFSET_S = 0.4371


TARGET_INTENSITY_MIN = 0.8


_SYNC_RADIUS_M = 0.25


CONTROL_RADIUS_M = 0.2


_CONTROL_HEIGHT_M = 1.0


_WALL_MARGIN_M = 0.3


_WALL_BAND_M = 0.5


@dataclass(frozen=True)
class EndToEndConfig:
    """Set-up of the end-to-end survey (defaults: the demo's; shrink for tests).

    Attributes
    ----------
    speed_m_s : float
        Cruise speed (m/s).
    straight_m : float
        Length of each straight of the oval (m), >= 30.
    turn_radius_m : float
        Tightest radius of the 180 deg right turns (m).
    max_acc_m_s2 : float
        Peak longitudinal acceleration of the speed ramps (m/s^2): a gentle ramp makes
        the control targets beside the first straight pass at several speeds.
    laps : int
        Full laps before the final straight (>= 1); the first straight is driven
        ``laps + 1`` times.
    static_s : float
        Standstill at the start (s), for the static alignment.
    latency_s : float
        True latency of the navigation records behind the scanner (s).
    latency_error_s : float
        Latency error of case (b) (s).
    clock_error_s : float
        Time error reached at the last profile by the period error of case (c) (s).
    angular_step_deg : float
        Profiler beam spacing (deg).
    range_noise_m : float
        Profiler range noise, 1 sigma (m).
    gnss_std_pos_ned_m : (float, float, float)
        GNSS position noise N, E, D (m), 1 sigma.
    survey_noise_m : float
        Control-point survey noise per axis (m), 1 sigma.
    wall_offset_m, wall_before_m, wall_length_m, wall_height_m : float
        The wall: distance left of the first straight, how far before the turn's start
        it begins, its length and height (m).
    wall_tolerance_m : float
        Least bow flagged as curvature (``fit_wall``'s ``min_bow_m``, m, >= 0): with
        thousands of points the F-test alone sees sub-millimetre bends.
    seed : int
        Seed of every random draw.
    """

    speed_m_s: float = 5.0
    straight_m: float = 50.0
    turn_radius_m: float = 10.0
    max_acc_m_s2: float = 0.5
    laps: int = 2
    static_s: float = 8.0
    latency_s: float = DEMO_LATENCY_S
    latency_error_s: float = 0.005
    clock_error_s: float = 0.005
    angular_step_deg: float = 0.5
    range_noise_m: float = 0.003
    gnss_std_pos_ned_m: tuple[float, float, float] = (0.01, 0.01, 0.02)
    survey_noise_m: float = 0.002
    wall_offset_m: float = 5.0
    wall_before_m: float = 10.0
    wall_length_m: float = 25.0
    wall_height_m: float = 3.0
    wall_tolerance_m: float = 0.005
    seed: int = 1

    def __post_init__(self) -> None:
        for name in (
            "speed_m_s",
            "turn_radius_m",
            "max_acc_m_s2",
            "static_s",
            "angular_step_deg",
            "range_noise_m",
            "survey_noise_m",
            "wall_offset_m",
            "wall_before_m",
            "wall_length_m",
            "wall_height_m",
        ):
            positive_number(getattr(self, name), f"end-to-end {name}")
        if positive_number(self.straight_m, "end-to-end straight_m") < 30.0:
            msg = f"end-to-end straight_m must be at least 30 m, got {self.straight_m}"
            raise InputError(msg)
        if self.static_s < 4.0:
            msg = f"end-to-end static_s must be at least 4 s (alignment), got {self.static_s}"
            raise InputError(msg)
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            msg = f"end-to-end seed must be a whole number >= 0, got {self.seed!r}"
            raise InputError(msg)
        if isinstance(self.laps, bool) or not isinstance(self.laps, int) or self.laps < 1:
            msg = f"end-to-end laps must be a whole number >= 1, got {self.laps!r}"
            raise InputError(msg)
        if not math.isfinite(self.wall_tolerance_m) or self.wall_tolerance_m < 0.0:
            msg = f"end-to-end wall_tolerance_m must be >= 0, got {self.wall_tolerance_m!r}"
            raise InputError(msg)
        for name in ("latency_s", "latency_error_s", "clock_error_s"):
            value = getattr(self, name)
            if not math.isfinite(value):
                msg = f"end-to-end {name} must be finite, got {value!r}"
                raise InputError(msg)
        if len(self.gnss_std_pos_ned_m) != 3:
            msg = "end-to-end gnss_std_pos_ned_m: expected 3 values"
            raise InputError(msg)
        for v in self.gnss_std_pos_ned_m:
            positive_number(v, "end-to-end gnss_std_pos_ned_m")


_MOUNT = Mount(
    lever_arm_body_m=(0.6, 0.0, -1.4),
    boresight_rpy_deg=(0.2, -0.3, 0.4),
    antenna_lever_arm_body_m=(0.3, -0.2, -1.5),
    profiler_azimuth_deg=0.0,
)


_CONTROL_LAYOUT = (
    (0.06, 5.5),
    (0.2, -4.5),
    (0.35, 6.0),
    (0.5, -5.5),
    (0.65, -6.0),
    (0.9, 5.0),
)
"""Control targets: (fraction of the first straight, lateral offset m, + right); the
left side ends before the wall, which would hide them."""


@dataclass(frozen=True, eq=False)
class Survey:
    """The simulated survey and its truth.

    Attributes
    ----------
    config : EndToEndConfig
    route : Route
    truth : DriveTrajectory
        Exact motion of the body (100 Hz), on the navigation system's time tags.
    lap_m : float
        Path length of one lap (m).
    scene : Scene
        Ground, the wall, sync targets ``S1``, ``S2`` and control targets ``C1..C6``.
    wall : Wall
    mount : Mount
        True mount, latency included.
    scan : ProfilerSimulation
        The scan (profile numbers, angles, ranges, intensities) and its true clock.
    sync_points : SyncPoints
        Sync target centres (exact).
    control : ControlPoints
        Control target centres as surveyed (truth plus survey noise), ECEF.
    imu : ImuData
    gnss : GnssData
    ins_config : InsConfig
        Filter configuration matching the IMU and GNSS models.
    wall_windows_s : tuple of (float, float)
        Time windows of the vehicle's passes through the turn beside the wall (s).
    """

    config: EndToEndConfig
    route: Route
    truth: DriveTrajectory
    lap_m: float
    scene: Scene
    wall: Wall
    mount: Mount
    scan: ProfilerSimulation
    sync_points: SyncPoints
    control: ControlPoints
    imu: ImuData
    gnss: GnssData
    ins_config: InsConfig
    wall_windows_s: tuple[tuple[float, float], ...]


def _lap(cfg: EndToEndConfig) -> tuple[Straight | Turn, ...]:
    return (
        Straight(cfg.straight_m),
        Turn(180.0, cfg.turn_radius_m),
        Straight(cfg.straight_m),
        Turn(180.0, cfg.turn_radius_m),
    )


def time_at_path(truth: DriveTrajectory, path_m: float) -> float:
    """Time (s) at which the drive has covered ``path_m`` metres (nearest record)."""
    s = truth.state(truth.t_s).s_m
    k = min(int(np.searchsorted(s, path_m)), len(truth) - 1)
    return float(truth.t_s[k])


def _scene(
    cfg: EndToEndConfig, truth: DriveTrajectory, lap_m: float, rng: np.random.Generator
) -> tuple[Scene, Wall, ControlPoints, tuple[tuple[float, float], ...]]:
    base = build_drive_scene(truth, SceneLayout(n_control=0, target_radius_m=_SYNC_RADIUS_M))
    pos, R = _to_local(truth, base.origin_lat_lon_h)
    yaw = np.unwrap(np.arctan2(R[:, 1, 0], R[:, 0, 0]))
    s = truth.state(truth.t_s).s_m

    def frame(path_m: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        k = min(int(np.searchsorted(s, path_m)), len(truth) - 1)
        h = float(yaw[k])
        fwd = np.array([math.cos(h), math.sin(h)])
        right = np.array([-math.sin(h), math.cos(h)])
        return pos[k, :2], fwd, right

    centre_down = base.ground_down_m - _CONTROL_HEIGHT_M
    controls = []
    for i, (fraction, lateral) in enumerate(_CONTROL_LAYOUT):
        p, _fwd, right = frame(fraction * cfg.straight_m)
        c = p + lateral * right
        controls.append(
            Target(
                name=f"C{i + 1}",
                centre_ned_m=(float(c[0]), float(c[1]), centre_down),
                radius_m=CONTROL_RADIUS_M,
                kind="control",
            )
        )
    p_end, fwd, right = frame(cfg.straight_m)
    start = p_end - cfg.wall_offset_m * right - cfg.wall_before_m * fwd
    end = start + cfg.wall_length_m * fwd
    wall = Wall(
        start_ne_m=(float(start[0]), float(start[1])),
        end_ne_m=(float(end[0]), float(end[1])),
        top_down_m=base.ground_down_m - cfg.wall_height_m,
        bottom_down_m=base.ground_down_m,
    )
    scene = replace(base, walls=(wall,), targets=base.targets + tuple(controls))
    ned = np.array([t.centre_ned_m for t in controls])
    surveyed = ned + rng.normal(0.0, cfg.survey_noise_m, ned.shape)
    control = ControlPoints(
        names=tuple(t.name for t in controls),
        pos_ecef_m=ned_to_ecef(surveyed, *scene.origin_lat_lon_h),
        source="<end-to-end control points>",
    )
    reach = cfg.wall_before_m + cfg.wall_length_m + 10.0
    windows = tuple(
        (
            time_at_path(truth, k * lap_m + cfg.straight_m - cfg.wall_before_m - 15.0),
            time_at_path(truth, k * lap_m + cfg.straight_m + reach),
        )
        for k in range(cfg.laps)
    )
    return scene, wall, control, windows


def _wall_profiles(
    truth: Trajectory, windows: tuple[tuple[float, float], ...], pcfg: ProfilerConfig, t0_s: float
) -> IntArray:
    """Profile numbers turned while the vehicle is inside one of the time windows."""
    angles = pcfg.angles_rad()
    n_profiles = math.floor((truth.t_end_s - t0_s) / pcfg.period_s - angles[-1] / math.tau) + 1
    parts = [
        np.arange(
            math.floor((lo - t0_s) / pcfg.period_s), math.ceil((hi - t0_s) / pcfg.period_s) + 1
        )
        for lo, hi in windows
    ]
    out = np.unique(np.concatenate(parts)).astype(np.int64)
    keep: IntArray = out[(out >= 0) & (out < n_profiles)]
    return keep


def simulate_survey(config: EndToEndConfig | None = None) -> Survey:
    """Simulate the survey: one truth, its scene, scan, IMU and GNSS (module docstring).

    Parameters
    ----------
    config : EndToEndConfig, optional

    Returns
    -------
    Survey
    """
    cfg = config or EndToEndConfig()
    rng = np.random.default_rng([cfg.seed, 11])
    lap = _lap(cfg)
    route = Route(
        lap * cfg.laps + (Straight(cfg.straight_m),),
        speed_m_s=cfg.speed_m_s,
        max_acc_m_s2=cfg.max_acc_m_s2,
        static_s=cfg.static_s,
        end_static_s=2.0,
    )
    lap_m = Route(lap, speed_m_s=cfg.speed_m_s).length_m
    truth = simulate_truth(route, rate_hz=100.0, t_start_s=_START_GPS_S, initial_yaw_deg=30.0)
    scene, wall, control, windows = _scene(cfg, truth, lap_m, rng)
    mount = _MOUNT.with_latency(cfg.latency_s)
    t0 = _START_GPS_S + _T0_OFFSET_S
    pcfg = ProfilerConfig(
        t0_s=t0,
        angular_step_deg=cfg.angular_step_deg,
        range_noise_m=cfg.range_noise_m,
        seed=cfg.seed,
    )
    profiles = np.union1d(
        profiles_near_targets(truth, mount, scene, pcfg, t0),
        _wall_profiles(truth, windows, pcfg, t0),
    )
    scan = simulate_profiler(truth, mount, scene, pcfg, profiles=profiles)
    sync = scene.targets_of_kind("sync")
    sync_points = SyncPoints(
        names=tuple(t.name for t in sync),
        lat_lon_h=scene.target_lat_lon_h(sync),
        source="<end-to-end sync points>",
    )
    model = ImuErrorModel.navigation_grade()
    imu, _errors = simulate_imu(truth, model, seed=cfg.seed)
    vel_std = (0.01, 0.01, 0.02)
    gnss = simulate_gnss(
        truth,
        rate_hz=5.0,
        std_pos_ned_m=cfg.gnss_std_pos_ned_m,
        std_vel_ned_m_s=vel_std,
        antenna_lever_arm_body_m=mount.antenna_lever_arm_body_m,
        seed=cfg.seed,
    )
    ins_config = model.to_ins_config(
        gnss_std_pos_ned_m=cfg.gnss_std_pos_ned_m,
        gnss_std_vel_ned_m_s=vel_std,
        antenna_lever_arm_body_m=mount.antenna_lever_arm_body_m,
    )
    return Survey(
        config=cfg,
        route=route,
        truth=truth,
        lap_m=lap_m,
        scene=scene,
        wall=wall,
        mount=mount,
        scan=scan,
        sync_points=sync_points,
        control=control,
        imu=imu,
        gnss=gnss,
        ins_config=ins_config,
        wall_windows_s=windows,
    )


def georeference_scan(
    survey: Survey, trajectory: Trajectory, clock: ProfileClock, latency_s: float
) -> tuple[CloudPoints, int]:
    """Time and georeference the whole scan with a clock, a trajectory and a latency.

    Parameters
    ----------
    survey : Survey
    trajectory : Trajectory
        Navigation records (the INS solution), their own time tags.
    clock : ProfileClock
        Profile clock giving each return its time (s).
    latency_s : float
        Latency applied (s), SPEC section 1.

    Returns
    -------
    cloud : CloudPoints
        Returns inside the trajectory's span: ECEF positions (m), times (s), intensities.
    n_outside : int
        Returns left out because their time lies outside the trajectory's span.
    """
    scan = survey.scan.scan
    mount = survey.mount.with_latency(latency_s)
    t = clock.time_s(scan.profile, scan.angle_rad)
    xyz = mount.profile_to_scanner(angle_rad=scan.angle_rad, range_m=scan.range_m)
    traj = GeorefTrajectory.from_trajectory(trajectory, mount.latency_s)
    pos, inside = georeference(t, xyz, traj, mount)
    cloud = CloudPoints(pos[inside], t[inside], scan.intensity[inside])
    return cloud, int(inside.size - np.count_nonzero(inside))


def wall_selection(survey: Survey, cloud: CloudPoints, window_s: tuple[float, float]) -> FloatArray:
    """Cloud points of the wall scanned during one pass: what a user's box would cut out.

    A box in the wall's own frame (within 0.5 m of its plane, 0.3 m inside its edges,
    from 0.3 m above the ground to 0.3 m below its top) and the pass's time window.

    Returns
    -------
    ndarray, shape (K, 3)
        Selected points, ECEF (m).
    """
    assert cloud.t_s is not None
    w = survey.wall
    a = np.array(w.start_ne_m)
    b = np.array(w.end_ne_m)
    length = float(np.hypot(*(b - a)))
    u = (b - a) / length
    normal = np.array([-u[1], u[0]])
    local = ecef_to_ned(cloud.pos_ecef_m, *survey.scene.origin_lat_lon_h)
    rel = local[:, :2] - a
    along = rel @ u
    off = rel @ normal
    down = local[:, 2]
    m = _WALL_MARGIN_M
    keep = (
        (np.abs(off) <= _WALL_BAND_M)
        & (along >= m)
        & (along <= length - m)
        & (down <= w.bottom_down_m - m)
        & (down >= w.top_down_m + m)
        & (cloud.t_s >= window_s[0])
        & (cloud.t_s <= window_s[1])
    )
    out: FloatArray = cloud.pos_ecef_m[keep]
    return out
