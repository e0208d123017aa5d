"""Rotating-table latency test simulator (Method A, SPEC section 2).

A profile scanner and an IMU sit on one bracket on a rotating table and scan a
precision sphere on a stand above a floor. The simulator follows the physics and the
acquisition chain, so the latency enters the data the way it does on a real table:

1. **Table.** Table-centred NED frame: origin on the table axis at the height of the
   scanner's optical centre. The true axis is +Down tilted by a levelling error
   (random magnitude up to ``levelling_error_arcsec_max``, random direction). The
   table angle is ``psi(t) = psi0 + omega t + regulation noise`` (three random
   sinusoids of relative rate noise ``rate_regulation_noise_rel``, RMS). The IMU sits
   flat on the table, so ``R_body_to_ned(t) = Rot(axis_true, psi(t)) @ R_tilt``
   (``R_tilt`` takes +Down onto the true axis). The scanner frame is the body frame
   up to a boresight (``boresight_rpy_deg``, default zero), and the scanner's optical
   centre sits a random distance up to ``optical_centre_offset_max_m`` off the axis,
   turning with the table.
2. **Scanner.** The mirror turns about the scanner Y axis: beam
   ``d_s(phi) = (cos phi, 0, -sin phi)`` in the scanner X-Z plane, ``angular_step_deg``
   apart, ``profile_rate_hz`` profiles per second on a free-running clock; a point at
   mirror angle ``phi`` of the profile starting at ``t_p`` is measured at
   ``t = t_p + (phi / 2 pi) T``. Ranges carry Gaussian noise along the beam.
3. **Scene.** Sphere (radius ``sphere_radius_m``) whose centre is ``sphere_range_m``
   from the axis horizontally, at a random azimuth, ``sphere_elevation_m`` above the
   optical centre; a vertical stand (cylinder, ``stand_radius_m``) from the floor up
   to the sphere; a horizontal floor ``floor_below_sphere_m`` below the sphere centre.
   Every beam is cast against the three and keeps the nearest hit.
4. **Attitude stream.** The IMU records at ``imu_rate_hz``; the record tagged ``t_k``
   holds the true attitude at ``t_k - tau`` with ``tau = latency_s + FIFO delay``
   (``fifo_bytes`` at ``baud``, 8N1), plus white attitude noise
   (``imu_attitude_noise_deg`` per axis): the navigation record lags the scanner
   (SPEC section 1).
5. **Acquisition software.** Each point measured at ``t`` is georeferenced with the
   attitude slerp-interpolated from the records *at their tags* at ``t``, assuming the
   optical centre on the axis: ``x_ned = R_used(t) @ R_scanner_to_body @ x_scanner``.
   The export keeps the returns in a box of ``+-roi_half_width_m`` around the sphere
   centre (the user's crop) and adds stray points (``stray_fraction`` of the kept
   points, uniform in the box).
6. **Passes.** For each rate magnitude and each sign, ``passes`` passes, alternating
   the direction (+, -, +, ...). A pass is the stretch of time during which the box
   around the sphere lies within ``pass_margin_deg`` of the scan plane.

Without noise, with a constant rate, the centre of a + pass is the true centre turned
by ``-omega tau`` about the axis and that of a - pass by ``+omega tau``.

References
----------
Seube, N., Picard, A., Rondeau, M., "A simple method to recover the latency time of
tactical grade IMU systems", ISPRS J. Photogramm. Remote Sens. 74, 2012, 85-89.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from kinsync._typing import BoolArray, FloatArray, IntArray
from kinsync._validate import finite_number
from kinsync.budget import serial_transmission_time_s
from kinsync.errors import InputError
from kinsync.frames import euler_rpy_to_matrix, quaternion_to_euler_rpy, quaternion_to_matrix
from kinsync.io.atomic import atomic_write_text, output_folder
from kinsync.io.mount_file import write_mount
from kinsync.io.passes import PassFileFormat, pass_file_name, write_passes
from kinsync.io.tables import write_numeric_csv
from kinsync.latency.passes import SpherePass
from kinsync.mount import Mount
from kinsync.trajectory import Trajectory

__all__ = [
    "LABEL_FLOOR",
    "LABEL_NAMES",
    "LABEL_SPHERE",
    "LABEL_STAND",
    "LABEL_STRAY",
    "RotatingTableConfig",
    "RotatingTableSimulation",
    "simulate_rotating_table",
    "write_simulation",
]

LABEL_SPHERE = 0
"""Point label: return from the sphere."""
LABEL_STAND = 1
"""Point label: return from the stand."""
LABEL_FLOOR = 2
"""Point label: return from the floor."""
LABEL_STRAY = 3
"""Point label: stray point (multipath, dust, mixed pixels)."""
LABEL_NAMES = ("sphere", "stand", "floor", "stray")
"""Label names by label value."""

ProgressCallback = Callable[[int, int], None]
"""Called as ``progress(passes_done, passes_total)`` after each pass."""

_N_REGULATION_SINUSOIDS = 3
_REGULATION_FREQ_HZ = (0.2, 2.0)
_IMU_PAD_S = 0.2
"""Attitude records before and after each pass (s)."""
_MAX_BEAMS_PER_CHUNK = 400_000
_MIRROR_WINDOW_MARGIN_M = 0.05
_MIRROR_WINDOW_DILATE = 2


def _check(condition: bool, message: str) -> None:
    if not condition:
        raise InputError(f"rotating-table config: {message}")


def _finite(value: float, name: str) -> float:
    return finite_number(value, f"rotating-table config: {name}")


@dataclass(frozen=True)
class RotatingTableConfig:
    """Set-up of a simulated rotating-table latency test (defaults: the published one).

    Attributes
    ----------
    latency_s : float
        IMU internal latency tau_imu (s); the total latency adds the FIFO delay.
    fifo_bytes : int
        Depth of the serial receive FIFO (bytes, >= 0); adds ``bytes * 10 / baud``.
    baud : float
        Serial line rate (bit/s), 8N1 frames.
    rates_deg_s : tuple of float
        Table rate magnitudes (deg/s, > 0); each is simulated in both directions.
    passes : int
        Passes per rate and direction (>= 1).
    seed : int
        Seed of the random generator; the simulation is deterministic for a seed.
    profile_rate_hz : float
        Mirror revolutions (profiles) per second.
    angular_step_deg : float
        Angle between consecutive beams of a profile (deg).
    range_noise_m : float
        Standard deviation of the range noise along the beam (m).
    imu_rate_hz : float
        Attitude record rate (Hz).
    imu_attitude_noise_deg : float
        White attitude noise of each record, per axis (deg, 1 sigma).
    rate_regulation_noise_rel : float
        Relative RMS noise of the table rate (smooth: three random sinusoids).
    levelling_error_arcsec_max : float
        Maximum tilt of the table axis from +Down (arcsec); drawn uniformly.
    optical_centre_offset_max_m : float
        Maximum distance of the scanner's optical centre from the axis (m); drawn
        uniformly over the disc.
    boresight_rpy_deg : tuple of 3 float
        Boresight scanner -> body (DIN 9300 roll, pitch, yaw, deg); small angles.
    sphere_radius_m : float
        Sphere radius (m); 0.1 for the 0.20 m diameter sphere.
    sphere_range_m : float
        Horizontal distance of the sphere centre from the table axis (m).
    sphere_elevation_m : float
        Height of the sphere centre above the scanner's optical centre (m).
    stand_radius_m : float
        Radius of the vertical stand under the sphere (m).
    floor_below_sphere_m : float
        Depth of the floor below the sphere centre (m).
    roi_half_width_m : float
        Half width of the exported box around the sphere centre (m).
    stray_fraction : float
        Stray points added per exported return (0 to 0.5).
    pass_margin_deg : float
        Table angle added before and after the box is in the scan plane (deg).
    pass_gap_s : float
        Time between two passes (s, >= 0.5).
    t_start_s : float
        GPS time of the first pass (s).
    site_lat_lon_h : tuple of 3 float
        Geodetic position of the table (lat_deg, lon_deg, h_m); labels the attitude
        trajectory only.
    """

    latency_s: float = 0.00421
    fifo_bytes: int = 0
    baud: float = 115200.0
    rates_deg_s: tuple[float, ...] = (2.0, 4.0, 6.0, 10.0, 14.0, 18.0)
    passes: int = 15
    seed: int = 1
    profile_rate_hz: float = 50.0
    angular_step_deg: float = 0.2
    range_noise_m: float = 0.002
    imu_rate_hz: float = 100.0
    imu_attitude_noise_deg: float = 0.001
    rate_regulation_noise_rel: float = 5e-4
    levelling_error_arcsec_max: float = 15.0
    optical_centre_offset_max_m: float = 5e-4
    boresight_rpy_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)
    sphere_radius_m: float = 0.1
    sphere_range_m: float = 1.5
    sphere_elevation_m: float = 0.0
    stand_radius_m: float = 0.015
    floor_below_sphere_m: float = 0.28
    roi_half_width_m: float = 0.3
    stray_fraction: float = 0.01
    pass_margin_deg: float = 1.0
    pass_gap_s: float = 2.0
    t_start_s: float = 1.4e9
    site_lat_lon_h: tuple[float, float, float] = (48.42, -4.47, 30.0)

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        for name in (
            "latency_s",
            "baud",
            "profile_rate_hz",
            "angular_step_deg",
            "range_noise_m",
            "imu_rate_hz",
            "imu_attitude_noise_deg",
            "rate_regulation_noise_rel",
            "levelling_error_arcsec_max",
            "optical_centre_offset_max_m",
            "sphere_radius_m",
            "sphere_range_m",
            "sphere_elevation_m",
            "stand_radius_m",
            "floor_below_sphere_m",
            "roi_half_width_m",
            "stray_fraction",
            "pass_margin_deg",
            "pass_gap_s",
            "t_start_s",
        ):
            set_(self, name, _finite(getattr(self, name), name))
        for name in ("passes", "fifo_bytes", "seed"):
            value = getattr(self, name)
            _check(
                isinstance(value, (int, np.integer)) and not isinstance(value, bool),
                f"{name} must be a whole number, got {value!r}",
            )
            set_(self, name, int(value))
        _check(self.passes >= 1, f"passes must be at least 1, got {self.passes}")
        _check(self.fifo_bytes >= 0, f"fifo_bytes must be >= 0, got {self.fifo_bytes}")
        _check(self.seed >= 0, f"seed must be >= 0, got {self.seed}")
        rates = tuple(_finite(r, "rates_deg_s") for r in self.rates_deg_s)
        _check(len(rates) > 0, "rates_deg_s is empty; give at least one rate (deg/s)")
        for r in rates:
            _check(
                r > 0.0,
                f"rates_deg_s holds {r:g}; give rate magnitudes > 0 deg/s (each rate is "
                "simulated in both directions)",
            )
        set_(self, "rates_deg_s", rates)
        bore = tuple(_finite(v, "boresight_rpy_deg") for v in self.boresight_rpy_deg)
        _check(len(bore) == 3, f"boresight_rpy_deg needs 3 angles, got {len(bore)}")
        set_(self, "boresight_rpy_deg", bore)
        site = tuple(_finite(v, "site_lat_lon_h") for v in self.site_lat_lon_h)
        _check(len(site) == 3 and abs(site[0]) <= 90.0, "site_lat_lon_h must be (lat, lon, h)")
        set_(self, "site_lat_lon_h", site)
        positive = (
            "baud",
            "profile_rate_hz",
            "angular_step_deg",
            "imu_rate_hz",
            "sphere_radius_m",
            "stand_radius_m",
            "roi_half_width_m",
        )
        for name in positive:
            _check(getattr(self, name) > 0.0, f"{name} must be > 0, got {getattr(self, name)}")
        non_negative = (
            "range_noise_m",
            "imu_attitude_noise_deg",
            "rate_regulation_noise_rel",
            "levelling_error_arcsec_max",
            "optical_centre_offset_max_m",
            "stray_fraction",
            "pass_margin_deg",
        )
        for name in non_negative:
            _check(getattr(self, name) >= 0.0, f"{name} must be >= 0, got {getattr(self, name)}")
        _check(self.angular_step_deg <= 10.0, "angular_step_deg must be <= 10 deg")
        _check(self.stray_fraction <= 0.5, "stray_fraction must be <= 0.5")
        _check(self.rate_regulation_noise_rel < 0.1, "rate_regulation_noise_rel must be < 0.1")
        _check(
            self.stand_radius_m < self.sphere_radius_m,
            "stand_radius_m must be smaller than sphere_radius_m",
        )
        _check(
            self.floor_below_sphere_m > self.sphere_radius_m,
            "floor_below_sphere_m must exceed sphere_radius_m (the sphere stands above it)",
        )
        _check(
            self.roi_half_width_m > self.sphere_radius_m,
            "roi_half_width_m must exceed sphere_radius_m so the box holds the sphere",
        )
        _check(
            self.sphere_range_m > self.roi_half_width_m * math.sqrt(3.0) + 0.05,
            "sphere_range_m must put the export box well clear of the scanner "
            f"(> {self.roi_half_width_m * math.sqrt(3.0) + 0.05:.3f} m)",
        )
        _check(
            abs(self.sphere_elevation_m) < self.sphere_range_m,
            "sphere_elevation_m must be smaller than sphere_range_m",
        )
        _check(self.pass_gap_s >= 0.5, f"pass_gap_s must be >= 0.5 s, got {self.pass_gap_s}")
        _check(abs(self.latency_s) < 0.1, f"latency_s must be within +-0.1 s, got {self.latency_s}")

    @property
    def fifo_delay_s(self) -> float:
        """Delay added by the receive FIFO, ``fifo_bytes * 10 / baud`` (s)."""
        return serial_transmission_time_s(self.fifo_bytes, self.baud)

    @property
    def total_latency_s(self) -> float:
        """Total latency tau = IMU latency + FIFO delay (s)."""
        return self.latency_s + self.fifo_delay_s

    @property
    def signed_rates_deg_s(self) -> tuple[float, ...]:
        """Signed rate of every pass, in simulation order (deg/s)."""
        return tuple(s * r for r in self.rates_deg_s for _ in range(self.passes) for s in (1, -1))


@dataclass(frozen=True, eq=False)
class RotatingTableSimulation:
    """Result of `simulate_rotating_table`.

    Attributes
    ----------
    config : RotatingTableConfig
        The set-up simulated.
    passes : tuple of SpherePass
        Exported passes: georeferenced points (table-centred NED, m) and times,
        sphere and clutter, with the signed controller rate and the nominal axis +Down.
    point_labels : tuple of ndarray, shape (N_i,)
        Per pass, the label of each point (`LABEL_SPHERE`, `LABEL_STAND`,
        `LABEL_FLOOR`, `LABEL_STRAY`).
    points_scanner_m : tuple of ndarray, shape (N_i, 3)
        Per pass, the same points in the scanner frame as the scanner measured them (m).
    attitude : Trajectory
        IMU attitude records at their tags (the stream the acquisition software used).
    truth : dict
        JSON-ready ground truth (latency, sphere centre, axis, levelling error,
        optical-centre offset, points per pass, config, seed).
    """

    config: RotatingTableConfig
    passes: tuple[SpherePass, ...]
    point_labels: tuple[IntArray, ...]
    points_scanner_m: tuple[FloatArray, ...]
    attitude: Trajectory
    truth: dict[str, Any] = field(default_factory=dict)


# ---------------------------------------------------------------------- geometry helpers
@dataclass(frozen=True)
class _Rotor:
    """Vectors split for fast rotation about one axis: ``v = parallel + perp``.

    ``Rot(axis, angle) v = parallel + perp cos(angle) + (axis x perp) sin(angle)``.
    """

    parallel: FloatArray
    perp: FloatArray
    cross: FloatArray

    def __init__(self, axis: FloatArray, vec: FloatArray) -> None:
        along = np.sum(vec * axis, axis=-1, keepdims=True) * axis
        perp = vec - along
        object.__setattr__(self, "parallel", along)
        object.__setattr__(self, "perp", perp)
        object.__setattr__(self, "cross", np.cross(axis, perp))

    def at(self, angle_rad: FloatArray, index: IntArray | None = None) -> FloatArray:
        """Rotated vectors (rows ``index`` when given) for angles broadcasting with them."""
        c = np.cos(angle_rad)[..., None]
        s = np.sin(angle_rad)[..., None]
        if index is None:
            out: FloatArray = self.parallel + self.perp * c + self.cross * s
        else:
            out = self.parallel[index] + self.perp[index] * c + self.cross[index] * s
        return out


def _in_box(points: FloatArray, lo: FloatArray, hi: FloatArray) -> BoolArray:
    inside: BoolArray = np.all((points >= lo) & (points <= hi), axis=-1)
    return inside


def _ray_hits_box(
    origin: FloatArray, direction: FloatArray, lo: FloatArray, hi: FloatArray
) -> BoolArray:
    """Slab test: does the ray ``origin + s direction`` (s >= 0) cross the box."""
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / direction
        t1 = (lo - origin) * inv
        t2 = (hi - origin) * inv
    t_near = np.nanmax(np.minimum(t1, t2), axis=-1)
    t_far = np.nanmin(np.maximum(t1, t2), axis=-1)
    hit: BoolArray = t_far >= np.maximum(t_near, 0.0)
    return hit


@dataclass(frozen=True)
class _Scene:
    """Drawn geometry of one simulation (table-centred NED, m)."""

    axis_ned: FloatArray  # true table axis, unit
    R_tilt: FloatArray  # +Down -> true axis
    offset_body_m: FloatArray  # optical centre off the axis, body frame
    sphere_center_ned_m: FloatArray
    sphere_azimuth_rad: float
    stand_top_d_m: float
    floor_d_m: float
    box_lo: FloatArray
    box_hi: FloatArray
    levelling_error_rad: float
    levelling_azimuth_rad: float
    imu_phase_s: float


def _draw_scene(cfg: RotatingTableConfig, rng: np.random.Generator) -> _Scene:
    beta = math.radians(rng.uniform(0.0, cfg.levelling_error_arcsec_max) / 3600.0)
    tilt_az = rng.uniform(0.0, 2.0 * math.pi)
    axis = np.array(
        [math.sin(beta) * math.cos(tilt_az), math.sin(beta) * math.sin(tilt_az), math.cos(beta)]
    )
    R_tilt = Rotation.from_rotvec(beta * np.array([-math.sin(tilt_az), math.cos(tilt_az), 0.0]))
    r_off = cfg.optical_centre_offset_max_m * math.sqrt(rng.uniform())
    off_az = rng.uniform(0.0, 2.0 * math.pi)
    offset = np.array([r_off * math.cos(off_az), r_off * math.sin(off_az), 0.0])
    az = rng.uniform(0.0, 2.0 * math.pi)
    rho = cfg.sphere_radius_m
    c = np.array(
        [
            cfg.sphere_range_m * math.cos(az),
            cfg.sphere_range_m * math.sin(az),
            -cfg.sphere_elevation_m,
        ]
    )
    h = cfg.roi_half_width_m
    return _Scene(
        axis_ned=axis,
        R_tilt=R_tilt.as_matrix(),
        offset_body_m=offset,
        sphere_center_ned_m=c,
        sphere_azimuth_rad=az,
        stand_top_d_m=float(c[2]) + math.sqrt(rho**2 - cfg.stand_radius_m**2),
        floor_d_m=float(c[2]) + cfg.floor_below_sphere_m,
        box_lo=c - h,
        box_hi=c + h,
        levelling_error_rad=beta,
        levelling_azimuth_rad=tilt_az,
        imu_phase_s=rng.uniform(0.0, 1.0 / cfg.imu_rate_hz),
    )


def _cast(
    origin: FloatArray, direction: FloatArray, cfg: RotatingTableConfig, scene: _Scene
) -> tuple[FloatArray, IntArray]:
    """Nearest hit of each ray on sphere, stand and floor.

    Returns the range (m, ``inf`` for no hit) and the label of each ray, shape (B,).
    """
    n = origin.shape[0]
    lam = np.full((n, 3), np.inf)
    with np.errstate(invalid="ignore", divide="ignore"):
        # Sphere.
        oc = origin - scene.sphere_center_ned_m
        b = np.einsum("ij,ij->i", direction, oc)
        c = np.einsum("ij,ij->i", oc, oc) - cfg.sphere_radius_m**2
        disc = b * b - c
        root = -b - np.sqrt(np.maximum(disc, 0.0))
        lam[:, LABEL_SPHERE] = np.where((disc >= 0.0) & (root > 0.0), root, np.inf)
        # Stand: vertical cylinder under the sphere centre, outer surface.
        o2 = oc[:, :2]
        d2 = direction[:, :2]
        a2 = np.einsum("ij,ij->i", d2, d2)
        b2 = np.einsum("ij,ij->i", o2, d2)
        c2 = np.einsum("ij,ij->i", o2, o2) - cfg.stand_radius_m**2
        disc2 = b2 * b2 - a2 * c2
        root2 = (-b2 - np.sqrt(np.maximum(disc2, 0.0))) / a2
        z2 = origin[:, 2] + root2 * direction[:, 2]
        ok2 = (
            (disc2 >= 0.0)
            & (a2 > 1e-12)
            & (root2 > 0.0)
            & (z2 >= scene.stand_top_d_m)
            & (z2 <= scene.floor_d_m)
        )
        lam[:, LABEL_STAND] = np.where(ok2, root2, np.inf)
        # Floor: horizontal plane below (Down positive).
        root3 = (scene.floor_d_m - origin[:, 2]) / direction[:, 2]
        lam[:, LABEL_FLOOR] = np.where((direction[:, 2] > 0.0) & (root3 > 0.0), root3, np.inf)
    label = np.argmin(lam, axis=1).astype(np.int64)
    return lam[np.arange(n), label], label


# ---------------------------------------------------------------------- one pass
@dataclass(frozen=True)
class _PassTiming:
    rate_deg_s: float
    t_begin_s: float
    duration_s: float
    psi_begin_rad: float
    reg_amp_rel: FloatArray  # (K,)
    reg_freq_hz: FloatArray  # (K,)
    reg_phase_rad: FloatArray  # (K,)

    def psi_rad(self, t_s: FloatArray, delay_s: float = 0.0) -> FloatArray:
        """True table angle at times ``t_s - delay_s`` (rad), any shape.

        The delay is subtracted from the time since the pass began, not from the GPS
        time itself, so that it is not rounded to the resolution of a GPS time (~0.2 us).
        """
        s = (np.asarray(t_s, dtype=np.float64) - self.t_begin_s) - delay_s
        omega = math.radians(self.rate_deg_s)
        w = 2.0 * np.pi * self.reg_freq_hz
        arg = w * s[..., None] + self.reg_phase_rad
        wobble = np.sum(self.reg_amp_rel / w * (np.cos(self.reg_phase_rad) - np.cos(arg)), axis=-1)
        out: FloatArray = self.psi_begin_rad + omega * (s + wobble)
        return out


@dataclass(frozen=True)
class _PassResult:
    points_ned_m: FloatArray
    points_scanner_m: FloatArray
    t_s: FloatArray
    labels: IntArray
    attitude_t_s: FloatArray
    attitude_q: FloatArray


def _half_width_rad(cfg: RotatingTableConfig, scene: _Scene) -> float:
    """Largest azimuth of a box corner away from the sphere azimuth (rad)."""
    c = scene.sphere_center_ned_m
    h = cfg.roi_half_width_m
    corners = np.array([[c[0] + i * h, c[1] + j * h] for i in (-1, 1) for j in (-1, 1)])
    az = np.arctan2(corners[:, 1], corners[:, 0])
    diff = (az - scene.sphere_azimuth_rad + np.pi) % (2.0 * np.pi) - np.pi
    return float(np.max(np.abs(diff)))


class _Simulator:
    """Shared state of one simulation run (scene, scanner, clocks)."""

    def __init__(self, cfg: RotatingTableConfig, rng: np.random.Generator) -> None:
        self.cfg = cfg
        self.rng = rng
        self.scene = _draw_scene(cfg, rng)
        self.tau_s = cfg.total_latency_s
        self.R_sb = euler_rpy_to_matrix(*np.radians(cfg.boresight_rpy_deg))
        n_mirror = round(360.0 / cfg.angular_step_deg)
        self.phi_rad = np.arange(n_mirror) * (2.0 * np.pi / n_mirror)
        self.d_scanner = np.column_stack(
            [np.cos(self.phi_rad), np.zeros(n_mirror), -np.sin(self.phi_rad)]
        )
        # Beam directions and optical centre at table angle 0 (NED).
        self.w_ned0 = self.d_scanner @ (self.scene.R_tilt @ self.R_sb).T
        self.offset_ned0 = self.scene.R_tilt @ self.scene.offset_body_m
        forward0 = self.scene.R_tilt @ self.R_sb @ np.array([1.0, 0.0, 0.0])
        self.psi_center_rad = self.scene.sphere_azimuth_rad - math.atan2(forward0[1], forward0[0])
        self.half_span_rad = _half_width_rad(cfg, self.scene) + math.radians(cfg.pass_margin_deg)
        self.profile_period_s = 1.0 / cfg.profile_rate_hz
        self.imu_period_s = 1.0 / cfg.imu_rate_hz
        self.R_tilt_rot = Rotation.from_matrix(self.scene.R_tilt)
        self.beam_rotor = _Rotor(self.scene.axis_ned, self.w_ned0)
        self.offset_rotor = _Rotor(self.scene.axis_ned, self.offset_ned0)
        self.window = self._mirror_window()

    # -------------------------------------------------------------- timing
    def timing(self, rate_deg_s: float, t_begin_s: float) -> _PassTiming:
        cfg = self.cfg
        k = _N_REGULATION_SINUSOIDS
        amp = np.full(k, cfg.rate_regulation_noise_rel * math.sqrt(2.0 / k))
        freq = self.rng.uniform(*_REGULATION_FREQ_HZ, size=k)
        phase = self.rng.uniform(0.0, 2.0 * np.pi, size=k)
        sign = 1.0 if rate_deg_s > 0 else -1.0
        return _PassTiming(
            rate_deg_s=rate_deg_s,
            t_begin_s=t_begin_s,
            duration_s=2.0 * self.half_span_rad / math.radians(abs(rate_deg_s)),
            psi_begin_rad=self.psi_center_rad - sign * self.half_span_rad,
            reg_amp_rel=amp,
            reg_freq_hz=freq,
            reg_phase_rad=phase,
        )

    def true_q_body_to_ned(
        self, timing: _PassTiming, t_s: FloatArray, delay_s: float = 0.0
    ) -> Rotation:
        """True body -> NED attitude at times ``t_s - delay_s``."""
        psi = timing.psi_rad(t_s, delay_s)
        return Rotation.from_rotvec(psi[:, None] * self.scene.axis_ned) * self.R_tilt_rot

    # -------------------------------------------------------------- IMU
    def attitude_records(self, timing: _PassTiming) -> tuple[FloatArray, FloatArray]:
        """Tags (s) and quaternions (w, x, y, z) of the IMU records around a pass."""
        cfg = self.cfg
        t0 = cfg.t_start_s + self.scene.imu_phase_s
        k_first = math.ceil((timing.t_begin_s - _IMU_PAD_S - t0) / self.imu_period_s)
        k_last = math.floor(
            (timing.t_begin_s + timing.duration_s + _IMU_PAD_S - t0) / self.imu_period_s
        )
        tags: FloatArray = t0 + np.arange(k_first, k_last + 1, dtype=np.float64) * self.imu_period_s
        true_rot = self.true_q_body_to_ned(timing, tags, self.tau_s)
        sigma = math.radians(cfg.imu_attitude_noise_deg)
        noise = Rotation.from_rotvec(self.rng.normal(0.0, sigma, size=(tags.size, 3)))
        xyzw = (true_rot * noise).as_quat()
        q = xyzw[:, [3, 0, 1, 2]]
        q[q[:, 0] < 0.0] *= -1.0
        return tags, q

    # -------------------------------------------------------------- scanner
    def profile_times(self, timing: _PassTiming) -> FloatArray:
        t0 = self.cfg.t_start_s
        T = self.profile_period_s
        k_first = math.ceil((timing.t_begin_s - t0) / T)
        k_last = math.floor((timing.t_begin_s + timing.duration_s - t0) / T - 1.0)
        out: FloatArray = t0 + np.arange(k_first, k_last + 1, dtype=np.float64) * T
        return out

    def _mirror_window(self) -> IntArray:
        """Mirror-angle indices whose beams can reach the export box during a pass.

        The table angle sweeps the same span in every pass (the regulation noise moves
        it by far less than the margin), so the window is found once: every mirror angle
        at 121 table angles across the span, tested against the box grown by 5 cm.
        """
        psi = self.psi_center_rad + np.linspace(-1.0, 1.0, 121) * self.half_span_rad
        origin = self.offset_rotor.at(psi)
        direction = self.beam_rotor.at(psi[:, None])
        grow = _MIRROR_WINDOW_MARGIN_M
        hit = _ray_hits_box(
            origin[:, None, :], direction, self.scene.box_lo - grow, self.scene.box_hi + grow
        )
        seen = np.any(hit, axis=0)
        n = seen.size
        idx = np.flatnonzero(seen)
        if idx.size == 0:
            msg = (
                "rotating-table config: no beam of the scanner reaches the sphere; "
                "check boresight_rpy_deg (the scan plane must be near vertical)"
            )
            raise InputError(msg)
        dil = (idx[:, None] + np.arange(-_MIRROR_WINDOW_DILATE, _MIRROR_WINDOW_DILATE + 1)) % n
        out: IntArray = np.unique(dil).astype(np.int64)
        return out

    def scan(self, timing: _PassTiming, attitude: Trajectory) -> _PassResult:
        """Cast, measure, georeference and crop the returns of one pass."""
        cfg, scene = self.cfg, self.scene
        t_profile = self.profile_times(timing)
        window = self.window
        dt_mirror = self.phi_rad[window] / (2.0 * np.pi) * self.profile_period_s
        omega = math.radians(abs(timing.rate_deg_s))
        keep_margin = (
            1.1 * omega * abs(self.tau_s) * (cfg.sphere_range_m + 2.0 * cfg.roi_half_width_m)
            + 8.0 * cfg.range_noise_m
            + 2.0 * cfg.optical_centre_offset_max_m
            + 0.01
        )
        chunk = max(1, _MAX_BEAMS_PER_CHUNK // window.size)
        t_parts: list[FloatArray] = []
        j_parts: list[IntArray] = []
        r_parts: list[FloatArray] = []
        l_parts: list[IntArray] = []
        for start in range(0, t_profile.size, chunk):
            tp = t_profile[start : start + chunk]
            t = (tp[:, None] + dt_mirror[None, :]).ravel()
            j = np.broadcast_to(window, (tp.size, window.size)).ravel()
            psi = timing.psi_rad(t)
            origin = self.offset_rotor.at(psi)
            direction = self.beam_rotor.at(psi, j)
            rng_m, label = _cast(origin, direction, cfg, scene)
            hit = np.isfinite(rng_m)
            point = origin[hit] + rng_m[hit, None] * direction[hit]
            near = _in_box(point, scene.box_lo - keep_margin, scene.box_hi + keep_margin)
            sel = np.flatnonzero(hit)[near]
            t_parts.append(t[sel])
            j_parts.append(j[sel])
            r_parts.append(rng_m[sel])
            l_parts.append(label[sel])
        t_s = np.concatenate(t_parts)
        j_idx = np.concatenate(j_parts)
        labels = np.concatenate(l_parts)
        measured_m = np.concatenate(r_parts) + self.rng.normal(0.0, cfg.range_noise_m, t_s.size)
        x_scanner = measured_m[:, None] * self.d_scanner[j_idx]
        # Acquisition software: attitude read at the point time from the records at their
        # tags, optical centre assumed on the axis.
        R_used = quaternion_to_matrix(attitude.interpolate(t_s).q_body_to_ned)
        x_ned = np.einsum("nij,nj->ni", R_used, x_scanner @ self.R_sb.T)
        crop = _in_box(x_ned, scene.box_lo, scene.box_hi)
        t_s, x_ned, x_scanner, labels = t_s[crop], x_ned[crop], x_scanner[crop], labels[crop]
        # Stray points: uniform in the exported box at random times of the pass.
        n_stray = round(cfg.stray_fraction * t_s.size)
        t_stray = timing.t_begin_s + self.rng.uniform(0.0, timing.duration_s, n_stray)
        t_stray = np.clip(t_stray, attitude.t_start_s, attitude.t_end_s)
        x_stray = self.rng.uniform(scene.box_lo, scene.box_hi, size=(n_stray, 3))
        R_stray = quaternion_to_matrix(attitude.interpolate(t_stray).q_body_to_ned)
        s_stray = np.einsum("nji,nj->ni", R_stray, x_stray) @ self.R_sb
        t_all = np.concatenate([t_s, t_stray])
        order = np.argsort(t_all, kind="stable")
        return _PassResult(
            points_ned_m=np.concatenate([x_ned, x_stray])[order],
            points_scanner_m=np.concatenate([x_scanner, s_stray])[order],
            t_s=t_all[order],
            labels=np.concatenate([labels, np.full(n_stray, LABEL_STRAY, np.int64)])[order],
            attitude_t_s=attitude.t_s,
            attitude_q=attitude.q_body_to_ned,
        )


# ---------------------------------------------------------------------- public API
def simulate_rotating_table(
    config: RotatingTableConfig | None = None, *, progress: ProgressCallback | None = None
) -> RotatingTableSimulation:
    """Simulate a rotating-table latency test.

    Parameters
    ----------
    config : RotatingTableConfig, optional
        Set-up; the defaults reproduce the published test (0.20 m sphere at 1.5 m,
        rates 2-18 deg/s, 15 passes each way, 4.21 ms IMU latency).
    progress : callable, optional
        ``progress(done, total)`` after each pass (for a progress bar).

    Returns
    -------
    RotatingTableSimulation
        Passes in simulation order: for each rate, ``passes`` pairs of a + pass then a
        - pass. Deterministic for ``config.seed``.

    Raises
    ------
    InputError
        A configuration in which the scanner never sees the sphere.
    """
    cfg = RotatingTableConfig() if config is None else config
    rng = np.random.default_rng(cfg.seed)
    sim = _Simulator(cfg, rng)
    site = cfg.site_lat_lon_h
    rates = cfg.signed_rates_deg_s
    passes: list[SpherePass] = []
    labels: list[IntArray] = []
    scanner_points: list[FloatArray] = []
    att_t: list[FloatArray] = []
    att_q: list[FloatArray] = []
    pass_truth: list[dict[str, Any]] = []
    t_begin = cfg.t_start_s
    for i, rate in enumerate(rates):
        timing = sim.timing(rate, t_begin)
        tags, q = sim.attitude_records(timing)
        attitude = Trajectory(
            t_s=tags, q_body_to_ned=q, pos_ned_m=np.zeros((tags.size, 3)), origin_lat_lon_h=site
        )
        res = sim.scan(timing, attitude)
        passes.append(
            SpherePass(
                source=f"simulated pass {i} ({rate:+g} deg/s)",
                rate_deg_s=rate,
                points_ned_m=res.points_ned_m,
                t_s=res.t_s,
            )
        )
        labels.append(res.labels)
        scanner_points.append(res.points_scanner_m)
        att_t.append(tags)
        att_q.append(q)
        counts = np.bincount(res.labels, minlength=len(LABEL_NAMES))
        pass_truth.append(
            {
                "index": i,
                "rate_deg_s": rate,
                "t_start_s": timing.t_begin_s,
                "t_end_s": timing.t_begin_s + timing.duration_s,
                "n_points": int(res.labels.size),
                **{f"n_{name}": int(counts[k]) for k, name in enumerate(LABEL_NAMES)},
            }
        )
        t_begin += timing.duration_s + cfg.pass_gap_s
        if progress is not None:
            progress(i + 1, len(rates))
    attitude_all = Trajectory(
        t_s=np.concatenate(att_t),
        q_body_to_ned=np.concatenate(att_q),
        pos_ned_m=np.zeros((sum(t.size for t in att_t), 3)),
        origin_lat_lon_h=site,
    )
    truth = _truth(cfg, sim, pass_truth)
    return RotatingTableSimulation(
        config=cfg,
        passes=tuple(passes),
        point_labels=tuple(labels),
        points_scanner_m=tuple(scanner_points),
        attitude=attitude_all,
        truth=truth,
    )


def _jsonable(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return _jsonable(value.tolist())
    if isinstance(value, np.floating | np.integer):
        return value.item()
    return value


def _truth(
    cfg: RotatingTableConfig, sim: _Simulator, pass_truth: list[dict[str, Any]]
) -> dict[str, Any]:
    scene = sim.scene
    by_rate: dict[str, list[int]] = {}
    for p in pass_truth:
        by_rate.setdefault(f"{p['rate_deg_s']:+g}", []).append(p["n_sphere"])
    doc: dict[str, Any] = _jsonable(
        {
            "description": "kinsync rotating-table simulation: ground truth (SPEC section 2)",
            "seed": cfg.seed,
            "latency_s": cfg.total_latency_s,
            "imu_latency_s": cfg.latency_s,
            "fifo_delay_s": cfg.fifo_delay_s,
            "latency_sign": "tau > 0: the attitude record tagged t describes the table at t - tau",
            "sphere_center_ned_m": scene.sphere_center_ned_m,
            "sphere_radius_m": cfg.sphere_radius_m,
            "axis_ned_true": scene.axis_ned,
            "axis_ned_nominal": [0.0, 0.0, 1.0],
            "levelling_error_arcsec": math.degrees(scene.levelling_error_rad) * 3600.0,
            "levelling_error_azimuth_deg": math.degrees(scene.levelling_azimuth_rad),
            "optical_centre_offset_m": float(np.linalg.norm(scene.offset_body_m)),
            "optical_centre_offset_body_m": scene.offset_body_m,
            "floor_d_m": scene.floor_d_m,
            "stand_top_d_m": scene.stand_top_d_m,
            "roi_box_ned_m": {"min": scene.box_lo, "max": scene.box_hi},
            "pass_span_deg": math.degrees(2.0 * sim.half_span_rad),
            "labels": list(LABEL_NAMES),
            "n_passes": len(pass_truth),
            "n_points": sum(p["n_points"] for p in pass_truth),
            "sphere_points_per_pass": [p["n_sphere"] for p in pass_truth],
            "mean_sphere_points_per_pass_by_rate": {
                k: float(np.mean(v)) for k, v in by_rate.items()
            },
            "passes": pass_truth,
            "config": asdict(cfg),
        }
    )
    return doc


def write_simulation(
    sim: RotatingTableSimulation,
    folder: Path,
    *,
    file_format: PassFileFormat = "csv",
    raw: bool = False,
) -> None:
    """Write a simulation as a pass folder plus ``truth.json``.

    Layout::

        folder/passes.csv, pass_000.<ext>, ...   (`kinsync.io.passes.write_passes`)
        folder/truth.json                         ground truth, with each pass's file
        folder/raw/pass_000.csv, ...              (raw=True) t_s,x_m,y_m,z_m, scanner frame
        folder/raw/attitude.csv                   (raw=True) t_s,roll_deg,pitch_deg,yaw_deg
        folder/raw/mount.toml                     (raw=True) boresight, zero lever arm and
                                                  latency (what the acquisition assumed)

    ``passes.csv`` is written last, so the folder is complete once it exists.

    Parameters
    ----------
    sim : RotatingTableSimulation
    folder : Path
        Output folder (created if missing).
    file_format : {"csv", "las", "laz"}
        Format of the georeferenced pass files.
    raw : bool
        Also write the scanner-frame points, the attitude log and the mount (the raw
        input of Method A).

    Raises
    ------
    InputError
        ``folder`` is an existing file, or an unknown format.
    """
    folder = output_folder(folder, "give a folder for the simulation", create=False)
    if file_format not in ("csv", "las", "laz"):
        msg = f"pass file format must be csv, las or laz, got {file_format!r}"
        raise InputError(msg)
    folder.mkdir(parents=True, exist_ok=True)
    n = len(sim.passes)
    if raw:
        raw_dir = folder / "raw"
        raw_dir.mkdir(exist_ok=True)
        for i, (p, xs) in enumerate(zip(sim.passes, sim.points_scanner_m, strict=True)):
            assert p.t_s is not None
            write_numeric_csv(
                raw_dir / pass_file_name(i, n, "csv"),
                {"t_s": p.t_s, "x_m": xs[:, 0], "y_m": xs[:, 1], "z_m": xs[:, 2]},
            )
        rpy_deg = np.degrees(quaternion_to_euler_rpy(sim.attitude.q_body_to_ned))
        write_numeric_csv(
            raw_dir / "attitude.csv",
            {
                "t_s": sim.attitude.t_s,
                "roll_deg": rpy_deg[:, 0],
                "pitch_deg": rpy_deg[:, 1],
                "yaw_deg": rpy_deg[:, 2],
            },
        )
        write_mount(Mount(boresight_rpy_deg=sim.config.boresight_rpy_deg), raw_dir / "mount.toml")
    truth = dict(sim.truth)
    truth["file_format"] = file_format
    truth["passes"] = [
        {**p, "file": pass_file_name(i, n, file_format)} for i, p in enumerate(sim.truth["passes"])
    ]
    atomic_write_text(folder / "truth.json", json.dumps(truth, indent=2) + "\n")
    write_passes(folder, sim.passes, file_format=file_format)
