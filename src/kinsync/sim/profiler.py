"""A 2D profile scanner driven along a trajectory through a scene (Method B test data).

The simulation follows the scanner (SPEC section 4):

1. **Mirror clock.** Profile n starts at ``t0 + n T``; the beam at mirror angle phi of
   profile n leaves at ``t(n, phi) = t0 + (n + phi / 2 pi) T`` (phi from nadir, positive
   towards the scanner's +Y, ``angular_step_deg`` apart over
   ``[angle_min_deg, angle_max_deg]``). The scanner keeps the profile number and the
   angle of each return, never the time.
2. **Beam.** In the scanner frame the beam points along
   ``Rz(azimuth) (0, sin phi, cos phi)`` (`kinsync.mount.Mount.profile_to_scanner`);
   the mount (lever arm, boresight, latency) and the true trajectory, interpolated at
   the beam's time exactly as `kinsync.georef.georeference` does (cubic Hermite
   positions with velocities, slerp attitude), put its origin and direction in ECEF
   and then in the scene's local NED frame.
3. **Returns.** Each beam is cast against the `kinsync.sim.scene.Scene` (ground, walls,
   retro-reflective spheres); the nearest hit within ``[min_range_m, max_range_m]`` is
   a return with Gaussian range noise (``range_noise_m``) and an intensity by surface
   (ground, wall, target) with Gaussian noise; a fraction ``glint_fraction`` of the
   other returns get a target-like intensity (isolated specular glints, which the
   target detection must reject). Beams that hit nothing give no return.

`profile_pulses` makes the hardware pulse train (one pulse per profile, optionally
one extra pulse first); `profiles_near_targets` lists the profiles that can see a
target (to simulate only those, for fast tests).

**Drive scan** (`simulate_drive_scan`, `write_drive_scan`): the complete Method B data
set. A route from `kinsync.sim.drive` (an oval at 2 m/s with 10 m radius turns, or a
figure-eight loop) is sampled at 100 Hz by `kinsync.sim.drive.simulate_truth`; the
scene (`kinsync.sim.scene.build_drive_scene`) puts two sync targets beside the road
near the start and the end, four control targets and a wall along a tight curve; the
scanner (1 deg steps over +-135 deg, 33 rev/s) sweeps it; the trajectory written is
the truth plus, optionally, smooth position noise (`kinsync.sim.drive.noisy_trajectory`,
correlated over 5 s). With the default 300 s the oval is driven twice (its straights
are stretched to fill the time), so each sync target is passed twice.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any, Literal

import numpy as np

from kinsync._typing import ArrayLike, FloatArray, IntArray
from kinsync._validate import finite_number, positive_number
from kinsync.errors import InputError
from kinsync.frames import geodetic_to_ecef, quaternion_to_matrix, rotation_ned_to_ecef
from kinsync.georef import GeorefTrajectory, georeference
from kinsync.io.atomic import atomic_write_text
from kinsync.io.mount_file import write_mount
from kinsync.io.profile_scan import write_profile_scan, write_pulses, write_sync_points
from kinsync.io.trajectory_csv import write_trajectory_csv
from kinsync.mount import Mount, MountUncertainty
from kinsync.mount_slips import derived_mounts
from kinsync.sim.drive import figure_eight_route, oval_route
from kinsync.sim.drive_truth import simulate_truth
from kinsync.sim.folder import simulation_folder
from kinsync.sim.nav_noise import noisy_trajectory
from kinsync.sim.scene import NO_HIT, Scene, SceneLayout, Target, build_drive_scene
from kinsync.sync.scan import ProfileScan, SyncPoints
from kinsync.trajectory import Trajectory

__all__ = [
    "DRIVE_SCAN_FILES",
    "MAX_DRIVE_SCAN_BEAMS",
    "DriveScanConfig",
    "DriveScanSimulation",
    "ProfilerConfig",
    "ProfilerSimulation",
    "drive_scan_size_problem",
    "exactly_known",
    "profile_pulses",
    "profiles_near_targets",
    "simulate_drive_scan",
    "simulate_profiler",
    "write_drive_scan",
]

_CHUNK_BEAMS = 400_000


def exactly_known(mount: Mount) -> Mount:
    """``mount`` with every ``[uncertainty]`` value 0: a simulation's own, exact mount.

    Method B adds the mount's stated errors to the clock's sigma and warns of the values
    it takes as exact (`kinsync.sync.mount_effect`); the truth of a simulation is exact.

    Parameters
    ----------
    mount : Mount
        The simulation's mount.
    """
    known = MountUncertainty(
        lever_arm_body_m=(0.0, 0.0, 0.0), boresight_rpy_deg=(0.0, 0.0, 0.0), latency_s=0.0
    )
    with derived_mounts():  # the mount's latency was warned of when it was made
        return replace(mount, uncertainty=known)


@dataclass(frozen=True)
class ProfilerConfig:
    """Settings of a simulated profile scanner.

    Attributes
    ----------
    period_s : float
        Mirror period T (s); 33 rev/s is about 0.0303 s.
    t0_s : float or None
        Start of profile 0 on the trajectory's time scale (s); None: 0.4 s after the
        trajectory's first record.
    angular_step_deg : float
        Angle between consecutive beams of a profile (deg).
    angle_min_deg, angle_max_deg : float
        Field of view, mirror angles from nadir (deg), within [-180, 180].
    range_noise_m : float
        Range noise, 1 sigma (m), >= 0.
    min_range_m, max_range_m : float
        Returns are kept between these ranges (m).
    ground_intensity, wall_intensity, target_intensity : float
        Mean intensity of each surface (retro-reflective targets well above the rest).
    intensity_noise : float
        Intensity noise, 1 sigma, >= 0.
    glint_fraction : float
        Fraction of non-target returns given a target-like intensity, in [0, 0.01].
    seed : int
        Random seed (same seed, same scan).
    """

    period_s: float = 0.030545
    t0_s: float | None = None
    angular_step_deg: float = 1.0
    angle_min_deg: float = -135.0
    angle_max_deg: float = 135.0
    range_noise_m: float = 0.005
    min_range_m: float = 0.5
    max_range_m: float = 50.0
    ground_intensity: float = 0.25
    wall_intensity: float = 0.45
    target_intensity: float = 0.95
    intensity_noise: float = 0.03
    glint_fraction: float = 2e-5
    seed: int = 1

    def __post_init__(self) -> None:
        positive_number(self.period_s, "profiler period_s")
        if self.t0_s is not None:
            finite_number(self.t0_s, "profiler t0_s")
        positive_number(self.angular_step_deg, "profiler angular_step_deg")
        lo = finite_number(self.angle_min_deg, "profiler angle_min_deg")
        hi = finite_number(self.angle_max_deg, "profiler angle_max_deg")
        if not -180.0 <= lo < hi <= 180.0:
            msg = f"profiler field of view [{lo}, {hi}] deg must lie within [-180, 180], min < max"
            raise InputError(msg)
        for name in ("range_noise_m", "intensity_noise"):
            if finite_number(getattr(self, name), f"profiler {name}") < 0.0:
                msg = f"profiler {name} must be >= 0, got {getattr(self, name)!r}"
                raise InputError(msg)
        lo_r = positive_number(self.min_range_m, "profiler min_range_m")
        if positive_number(self.max_range_m, "profiler max_range_m") <= lo_r:
            msg = "profiler max_range_m must exceed min_range_m"
            raise InputError(msg)
        for name in ("ground_intensity", "wall_intensity", "target_intensity"):
            finite_number(getattr(self, name), f"profiler {name}")
        glint = finite_number(self.glint_fraction, "profiler glint_fraction")
        if not 0.0 <= glint <= 0.01:
            msg = f"profiler glint_fraction must lie in [0, 0.01], got {glint}"
            raise InputError(msg)

    def angles_rad(self) -> FloatArray:
        """Mirror angles of one profile (rad), ascending, shape (A,)."""
        n = math.floor((self.angle_max_deg - self.angle_min_deg) / self.angular_step_deg)
        out: FloatArray = np.radians(self.angle_min_deg + self.angular_step_deg * np.arange(n + 1))
        return out


@dataclass(frozen=True, eq=False)
class ProfilerSimulation:
    """A simulated scan with its truth.

    Attributes
    ----------
    scan : ProfileScan
        What the scanner records: profile, angle, range, intensity.
    t_s : ndarray, shape (N,)
        True time of each return (s).
    hit_id : ndarray of int64, shape (N,)
        What each return hit (`kinsync.sim.scene.Scene.cast`; glints keep their surface).
    t0_s, period_s : float
        True clock: ``t(n, phi) = t0_s + (n + phi / 2 pi) period_s``.
    n_profiles : int
        Profiles the scanner turned (numbered ``0 .. n_profiles - 1``).
    """

    scan: ProfileScan
    t_s: FloatArray
    hit_id: IntArray
    t0_s: float
    period_s: float
    n_profiles: int


def _profile_count(truth: Trajectory, config: ProfilerConfig, t0: float) -> int:
    angles = config.angles_rad()
    T = config.period_s
    first = t0 + angles[0] / (2 * math.pi) * T
    if first < truth.t_start_s:
        msg = (
            f"profiler: profile 0 starts at {first!r} s, before the trajectory's first "
            f"record {truth.t_start_s!r} s; choose a later t0_s"
        )
        raise InputError(msg)
    n = math.floor((truth.t_end_s - t0) / T - angles[-1] / (2 * math.pi)) + 1
    if n < 1:
        msg = f"profiler: no whole profile fits between t0_s={t0!r} and the trajectory's end"
        raise InputError(msg)
    return int(n)


def simulate_profiler(
    truth: Trajectory,
    mount: Mount,
    scene: Scene,
    config: ProfilerConfig | None = None,
    *,
    profiles: ArrayLike | None = None,
) -> ProfilerSimulation:
    """Drive a profile scanner along a trajectory through a scene.

    Parameters
    ----------
    truth : Trajectory
        True motion of the body (with velocities for cubic Hermite positions).
    mount : Mount
        Lever arm, boresight, latency and the ``[profiler]`` azimuth.
    scene : Scene
        What the beams hit.
    config : ProfilerConfig, optional
    profiles : array_like of int, optional
        Simulate only these profile numbers (ascending, within the drive), e.g. those
        near the targets, for fast tests; default: every profile.

    Returns
    -------
    ProfilerSimulation

    Raises
    ------
    InputError
        A mount without ``[profiler]``, a clock start before the trajectory, profile
        numbers outside the drive, no return at all.
    """
    cfg = config or ProfilerConfig()
    if mount.profiler_azimuth_deg is None:
        msg = "profiler: the mount has no [profiler] azimuth_deg; a profile scanner needs one"
        raise InputError(msg)
    t0 = truth.t_start_s + 0.4 if cfg.t0_s is None else float(cfg.t0_s)
    n_profiles = _profile_count(truth, cfg, t0)
    if profiles is None:
        wanted = np.arange(n_profiles, dtype=np.int64)
    else:
        wanted = np.unique(np.asarray(profiles, dtype=np.int64))
        if wanted.size == 0 or wanted[0] < 0 or wanted[-1] >= n_profiles:
            msg = f"profiler: profile numbers must lie in [0, {n_profiles - 1}]"
            raise InputError(msg)
    angles = cfg.angles_rad()
    n_ang = angles.size
    unit_scanner = mount.profile_to_scanner(angle_rad=angles, range_m=np.ones(n_ang))
    gtraj = GeorefTrajectory.from_trajectory(truth, mount.latency_s)
    origin_ecef = geodetic_to_ecef(*scene.origin_lat_lon_h)
    R_le = rotation_ned_to_ecef(scene.origin_lat_lon_h[0], scene.origin_lat_lon_h[1])
    rng = np.random.default_rng(cfg.seed)
    per_chunk = max(1, _CHUNK_BEAMS // n_ang)
    intensity_of = np.full(scene.first_target_id + len(scene.targets), cfg.target_intensity)
    intensity_of[0] = cfg.ground_intensity
    intensity_of[1 : scene.first_target_id] = cfg.wall_intensity
    parts: list[tuple[IntArray, FloatArray, FloatArray, FloatArray, FloatArray, IntArray]] = []
    for start in range(0, wanted.size, per_chunk):
        prof = wanted[start : start + per_chunk]
        t = t0 + (prof[:, None] + angles[None, :] / (2 * math.pi)).ravel() * cfg.period_s
        u = np.tile(unit_scanner, (prof.size, 1))
        o_ecef, _ = georeference(t, np.zeros_like(u), gtraj, mount)
        tip_ecef, _ = georeference(t, u, gtraj, mount)
        d_loc = (tip_ecef - o_ecef) @ R_le
        d_loc /= np.linalg.norm(d_loc, axis=1, keepdims=True)
        rng_m, hit = scene.cast((o_ecef - origin_ecef) @ R_le, d_loc, cfg.max_range_m)
        idx = np.flatnonzero((hit != NO_HIT) & (rng_m >= cfg.min_range_m))
        inten = intensity_of[hit[idx]] + rng.normal(0.0, cfg.intensity_noise, idx.size)
        glint = (hit[idx] < scene.first_target_id) & (rng.random(idx.size) < cfg.glint_fraction)
        inten[glint] = cfg.target_intensity
        parts.append(
            (
                np.repeat(prof, n_ang)[idx],
                np.tile(angles, prof.size)[idx],
                rng_m[idx] + rng.normal(0.0, cfg.range_noise_m, idx.size),
                np.maximum(inten, 0.0),
                t[idx],
                hit[idx],
            )
        )
    out_p, out_a, out_r, out_i, out_t, out_h = (list(c) for c in zip(*parts, strict=True))
    profile = np.concatenate(out_p)
    if profile.size == 0:
        msg = "profiler: no beam hit anything; check the scene, the mount and the range limits"
        raise InputError(msg)
    scan = ProfileScan(
        profile=profile,
        angle_rad=np.concatenate(out_a),
        range_m=np.maximum(np.concatenate(out_r), 0.0),
        intensity=np.concatenate(out_i),
        source="<simulated scan>",
    )
    t_all = np.concatenate(out_t)
    t_all.setflags(write=False)
    hits = np.concatenate(out_h)
    hits.setflags(write=False)
    return ProfilerSimulation(
        scan=scan,
        t_s=t_all,
        hit_id=hits,
        t0_s=t0,
        period_s=float(cfg.period_s),
        n_profiles=n_profiles,
    )


def profile_pulses(
    t0_s: float,
    period_s: float,
    n_profiles: int,
    *,
    extra_first_pulse: bool = False,
    jitter_s: float = 1e-6,
    rng: np.random.Generator | None = None,
) -> FloatArray:
    """Hardware profile pulses: one at the start of each profile, ``t0 + n T``.

    Parameters
    ----------
    t0_s, period_s : float
        The scanner clock (s).
    n_profiles : int
        Profiles in the scan.
    extra_first_pulse : bool
        Add one pulse a period before profile 0 (a pulse to cut off): pulse ``n + 1``
        then belongs to profile ``n``.
    jitter_s : float
        Edge jitter, 1 sigma (s).
    rng : numpy.random.Generator, optional

    Returns
    -------
    ndarray, shape (n_profiles,) or (n_profiles + 1,)
        Pulse times (s), strictly increasing.
    """
    gen = rng or np.random.default_rng(0)
    n = np.arange(-1 if extra_first_pulse else 0, n_profiles, dtype=np.float64)
    t: FloatArray = t0_s + n * period_s + gen.normal(0.0, jitter_s, n.size)
    return t


def profiles_near_targets(
    truth: Trajectory,
    mount: Mount,
    scene: Scene,
    config: ProfilerConfig,
    t0_s: float,
    margin_m: float = 0.5,
) -> IntArray:
    """Profile numbers during which the scan plane passes within reach of a target.

    A trajectory record counts when a target centre lies within ``radius + margin_m``
    of the scan plane and within ``max_range_m`` of the scanner; its profile and the
    three on either side are returned (enough for any mirror angle).

    Parameters
    ----------
    truth : Trajectory
    mount : Mount
        With ``[profiler] azimuth_deg``.
    scene : Scene
    config : ProfilerConfig
    t0_s : float
        Start of profile 0 (s).
    margin_m : float
        Extra distance to the plane (m).

    Returns
    -------
    ndarray of int64
        Ascending, unique, within ``[0, n_profiles)``.
    """
    n_profiles = _profile_count(truth, config, t0_s)
    gtraj = GeorefTrajectory.from_trajectory(truth, mount.latency_s)
    R_be = quaternion_to_matrix(gtraj.q_body_to_ecef)
    origin = gtraj.pos_ecef_m + R_be @ mount.lever_arm_body_m_array
    az = math.radians(mount.profiler_azimuth_deg or 0.0)
    normal = R_be @ (mount.R_scanner_to_body @ np.array([math.cos(az), math.sin(az), 0.0]))
    near = np.zeros(len(gtraj), dtype=bool)
    llh = scene.target_lat_lon_h(scene.targets)
    centres = geodetic_to_ecef(llh[:, 0], llh[:, 1], llh[:, 2])
    for target, c in zip(scene.targets, centres, strict=True):
        rel = c - origin
        d = np.abs(np.einsum("ij,ij->i", normal, rel))
        near |= (d <= target.radius_m + margin_m) & (
            np.linalg.norm(rel, axis=1) <= config.max_range_m
        )
    base = np.floor((gtraj.t_s[near] - t0_s) / config.period_s).astype(np.int64)
    out = np.unique((base[:, None] + np.arange(-3, 4)[None, :]).ravel())
    keep: IntArray = out[(out >= 0) & (out < n_profiles)]
    return keep


DRIVE_SCAN_FILES = (
    "scan.csv",
    "trajectory.csv",
    "mount.toml",
    "sync_points.csv",
    "control_points.csv",
    "pulses.csv",
    "truth.json",
)
"""Files `write_drive_scan` writes (``truth.json`` last)."""

RouteName = Literal["oval", "loop"]

_DEFAULT_MOUNT = Mount(
    lever_arm_body_m=(0.6, 0.0, -1.4),
    boresight_rpy_deg=(0.2, -0.3, 0.4),
    profiler_azimuth_deg=0.0,
)


MAX_DRIVE_SCAN_BEAMS = 65_000_000
"""Most beams one drive scan casts (profiles x beams per profile): 2 h at the default
mirror period (0.030545 s) and field of view (271 beams), about 40 million returns."""


def drive_scan_size_problem(
    duration_s: float,
    period_s: float,
    profiler: ProfilerConfig | None = None,
    *,
    duration_name: str = "duration_s",
    period_name: str = "period_s",
) -> str | None:
    """Why a drive scan is too large to simulate (more than `MAX_DRIVE_SCAN_BEAMS`), or None.

    Parameters
    ----------
    duration_s, period_s : float
        Length of the drive and mirror period (s).
    profiler : ProfilerConfig, optional
        The scanner (its beams per profile); default `ProfilerConfig`.
    duration_name, period_name : str
        How the message names the two (the command's options).

    Returns
    -------
    str or None
        The reason, naming what to change; None when the scan fits.
    """
    n_beams = (profiler or ProfilerConfig()).angles_rad().size
    n_profiles = duration_s / period_s
    if n_profiles * n_beams <= MAX_DRIVE_SCAN_BEAMS:
        return None
    return (
        f"{duration_name} {duration_s:g} at {period_name} {period_s:g}: {n_profiles:,.0f} "
        f"profiles of {n_beams} beams, {n_profiles * n_beams:,.0f} beams, more than the "
        f"{MAX_DRIVE_SCAN_BEAMS:,} kinsync simulates in one run (2 h at the default "
        f"period); give a shorter {duration_name} or a longer {period_name}"
    )


@dataclass(frozen=True)
class DriveScanConfig:
    """Set-up of a simulated Method B data set (defaults: the issue's scenario).

    Attributes
    ----------
    period_s : float
        True mirror period T (s).
    t0_s : float or None
        True start of profile 0 (GPS s); None: ``start_gps_s + 0.4371``.
    seed : int
        Seed of the scan noise and the trajectory noise.
    duration_s : float
        Length of the drive (s), >= 40; with ``period_s``, at most
        `MAX_DRIVE_SCAN_BEAMS` beams (`drive_scan_size_problem`).
    route : {"oval", "loop"}
        Oval (two laps, straights stretched to fill ``duration_s``) or figure-eight
        loop (as many laps as fit).
    speed_m_s : float
        Cruise speed (m/s).
    trajectory_noise_m : float
        Position noise of the written trajectory, 1 sigma per NED axis (m), smooth
        over 5 s; 0 writes the exact trajectory.
    extra_first_pulse : bool
        Write one pulse more than profiles, first (pulse offset 1).
    start_gps_s : float
        GPS time of the route start (s).
    rate_hz : float
        Trajectory record rate (Hz).
    mount : Mount
        Scanner mount (with ``[profiler]``).
    profiler : ProfilerConfig
        Scanner settings; its ``period_s``, ``t0_s`` and ``seed`` are replaced by the
        fields above.
    layout : SceneLayout
        Where targets and the wall go.
    near_targets_only : bool
        Simulate only the profiles that can see a target (fast, for tests).
    """

    period_s: float = 0.030545
    t0_s: float | None = None
    seed: int = 1
    duration_s: float = 300.0
    route: RouteName = "oval"
    speed_m_s: float = 2.0
    trajectory_noise_m: float = 0.0
    extra_first_pulse: bool = False
    start_gps_s: float = 1.4e9
    rate_hz: float = 100.0
    mount: Mount = field(default_factory=lambda: _DEFAULT_MOUNT)
    profiler: ProfilerConfig = field(default_factory=lambda: ProfilerConfig(range_noise_m=0.003))
    layout: SceneLayout = field(default_factory=SceneLayout)
    near_targets_only: bool = False

    def __post_init__(self) -> None:
        positive_number(self.period_s, "drive scan period_s")
        if self.t0_s is not None:
            finite_number(self.t0_s, "drive scan t0_s")
        if isinstance(self.seed, bool) or int(self.seed) != self.seed or self.seed < 0:
            msg = f"drive scan: seed must be a whole number >= 0, got {self.seed!r}"
            raise InputError(msg)
        if positive_number(self.duration_s, "drive scan duration_s") < 40.0:
            msg = f"drive scan: duration_s must be at least 40 s, got {self.duration_s}"
            raise InputError(msg)
        if self.route not in ("oval", "loop"):
            msg = f"drive scan: route must be 'oval' or 'loop', got {self.route!r}"
            raise InputError(msg)
        positive_number(self.speed_m_s, "drive scan speed_m_s")
        noise = finite_number(self.trajectory_noise_m, "drive scan trajectory_noise_m")
        if noise < 0.0:
            msg = f"drive scan: trajectory_noise_m must be >= 0, got {noise}"
            raise InputError(msg)
        finite_number(self.start_gps_s, "drive scan start_gps_s")
        positive_number(self.rate_hz, "drive scan rate_hz")
        if self.mount.profiler_azimuth_deg is None:
            msg = "drive scan: the mount needs a [profiler] azimuth_deg"
            raise InputError(msg)
        problem = drive_scan_size_problem(self.duration_s, self.period_s, self.profiler)
        if problem is not None:
            raise InputError(f"drive scan: {problem}")

    @property
    def true_t0_s(self) -> float:
        """Start of profile 0 (GPS s)."""
        return self.start_gps_s + 0.4371 if self.t0_s is None else float(self.t0_s)


@dataclass(frozen=True, eq=False)
class DriveScanSimulation:
    """A simulated Method B data set and its truth.

    Attributes
    ----------
    config : DriveScanConfig
    truth_trajectory : Trajectory
        Exact motion.
    trajectory : Trajectory
        What is written to ``trajectory.csv`` (truth plus noise).
    scene : Scene
    scanner : ProfilerSimulation
        The scan with each return's true time.
    sync_points : SyncPoints
        Sync target centres (WGS84).
    control_points : SyncPoints or None
        Control target centres (WGS84); None without control targets.
    pulses_t_s : ndarray, shape (P,)
        Hardware profile pulses (GPS s).
    truth : dict
        ``truth.json``: clock, pulse offset, set-up and each target's passes.
    """

    config: DriveScanConfig
    truth_trajectory: Trajectory
    trajectory: Trajectory
    scene: Scene
    scanner: ProfilerSimulation
    sync_points: SyncPoints
    control_points: SyncPoints | None
    pulses_t_s: FloatArray
    truth: dict[str, Any]


def _route(config: DriveScanConfig) -> Any:
    static_s = 5.0
    if config.route == "loop":
        lap = figure_eight_route(speed_m_s=config.speed_m_s, laps=1, static_s=static_s)
        laps = max(1, math.ceil((config.duration_s - static_s) / (lap.duration_s - static_s)))
        return figure_eight_route(speed_m_s=config.speed_m_s, laps=laps, static_s=static_s)

    def oval(straight_m: float) -> Any:
        return oval_route(
            speed_m_s=config.speed_m_s, straight_m=straight_m, laps=2, static_s=static_s
        )

    d40, d80 = oval(40.0).duration_s, oval(80.0).duration_s
    per_m = (d80 - d40) / 40.0
    straight = max(10.0, 40.0 + (config.duration_s - d40) / per_m)
    return oval(straight)


def _passes(scene: Scene, sim: ProfilerSimulation, target: Target) -> list[dict[str, Any]]:
    ident = scene.first_target_id + scene.targets.index(target)
    hit = np.flatnonzero(sim.hit_id == ident)
    if hit.size == 0:
        return []
    prof = sim.scan.profile[hit]
    groups = np.split(np.arange(hit.size), np.flatnonzero(np.diff(prof) > 5) + 1)
    return [
        {
            "t_s": float(np.mean(sim.t_s[hit[g]])),
            "first_profile": int(prof[g].min()),
            "last_profile": int(prof[g].max()),
            "n_returns": int(g.size),
        }
        for g in groups
    ]


def simulate_drive_scan(config: DriveScanConfig | None = None) -> DriveScanSimulation:
    """Simulate a Method B data set: drive, scene, scan, pulses and truth.

    Parameters
    ----------
    config : DriveScanConfig, optional

    Returns
    -------
    DriveScanSimulation
    """
    cfg = config or DriveScanConfig()
    truth_traj = simulate_truth(
        _route(cfg),
        rate_hz=cfg.rate_hz,
        t_start_s=cfg.start_gps_s,
        duration_s=cfg.duration_s,
        initial_yaw_deg=30.0,
    )
    scene = build_drive_scene(truth_traj, cfg.layout)
    t0 = cfg.true_t0_s
    scan_cfg = ProfilerConfig(
        **{**asdict(cfg.profiler), "period_s": cfg.period_s, "t0_s": t0, "seed": cfg.seed}
    )
    profiles = (
        profiles_near_targets(truth_traj, cfg.mount, scene, scan_cfg, t0)
        if cfg.near_targets_only
        else None
    )
    scanner = simulate_profiler(truth_traj, cfg.mount, scene, scan_cfg, profiles=profiles)
    written: Trajectory = truth_traj
    if cfg.trajectory_noise_m > 0.0:
        sigma = cfg.trajectory_noise_m
        written = noisy_trajectory(
            truth_traj,
            std_pos_ned_m=(sigma, sigma, sigma),
            std_att_deg=(0.0, 0.0, 0.0),
            corr_time_s=5.0,
            seed=cfg.seed,
        )
    pulses = profile_pulses(
        t0,
        cfg.period_s,
        scanner.n_profiles,
        extra_first_pulse=cfg.extra_first_pulse,
        rng=np.random.default_rng([cfg.seed, 7]),
    )
    sync = scene.targets_of_kind("sync")
    control = scene.targets_of_kind("control")
    sync_points = SyncPoints(
        names=tuple(t.name for t in sync), lat_lon_h=scene.target_lat_lon_h(sync), source="sync"
    )
    control_points = (
        SyncPoints(
            names=tuple(t.name for t in control),
            lat_lon_h=scene.target_lat_lon_h(control),
            source="control",
        )
        if control
        else None
    )
    truth: dict[str, Any] = {
        "t0_s": t0,
        "period_s": cfg.period_s,
        "n_profiles": scanner.n_profiles,
        "n_points": len(scanner.scan),
        "pulse_offset": 1 if cfg.extra_first_pulse else 0,
        "seed": cfg.seed,
        "route": cfg.route,
        "duration_s": cfg.duration_s,
        "speed_m_s": cfg.speed_m_s,
        "trajectory_noise_m": cfg.trajectory_noise_m,
        "near_targets_only": cfg.near_targets_only,
        "profiler": asdict(scan_cfg),
        "scene": {
            "origin_lat_lon_h": list(scene.origin_lat_lon_h),
            "ground_down_m": scene.ground_down_m,
            "walls": [asdict(w) for w in scene.walls],
        },
        "targets": [
            {
                "name": t.name,
                "kind": t.kind,
                "centre_ned_m": list(t.centre_ned_m),
                "radius_m": t.radius_m,
                "passes": _passes(scene, scanner, t),
            }
            for t in scene.targets
        ],
    }
    return DriveScanSimulation(
        config=cfg,
        truth_trajectory=truth_traj,
        trajectory=written,
        scene=scene,
        scanner=scanner,
        sync_points=sync_points,
        control_points=control_points,
        pulses_t_s=pulses,
        truth=truth,
    )


def write_drive_scan(sim: DriveScanSimulation, out_dir: Path) -> None:
    """Write `DRIVE_SCAN_FILES` into ``out_dir`` (created if missing), ``truth.json`` last.

    ``control_points.csv`` is left out when the scene has no control targets.

    Raises
    ------
    InputError
        ``out_dir`` exists and is not a folder.
    """
    with simulation_folder(out_dir, "drive-scan") as out:
        write_profile_scan(sim.scanner.scan, out / "scan.csv")
        write_trajectory_csv(sim.trajectory, out / "trajectory.csv")
        write_mount(sim.config.mount, out / "mount.toml")
        write_sync_points(sim.sync_points, out / "sync_points.csv")
        if sim.control_points is not None:
            write_sync_points(sim.control_points, out / "control_points.csv")
        write_pulses(sim.pulses_t_s, out / "pulses.csv")
        atomic_write_text(out / "truth.json", json.dumps(sim.truth, indent=2) + "\n")
