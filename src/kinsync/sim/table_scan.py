"""The rotating-table simulator's scene and the scanning of one pass.

The sphere on its stand above a floor (`_Scene`, drawn at random positions within the
configured tolerances), the table's turning with its rate regulation noise (`_Rotor`),
and the beams of the profile scanner cast against the scene over one pass
(`_Simulator`), in chunks that bound memory; see `kinsync.sim.rotating_table` for the
physical model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from kinsync._typing import BoolArray, FloatArray, IntArray
from kinsync.errors import InputError
from kinsync.frames import euler_rpy_to_matrix, quaternion_to_matrix
from kinsync.sim.table_config import (
    LABEL_FLOOR,
    LABEL_SPHERE,
    LABEL_STAND,
    LABEL_STRAY,
    RotatingTableConfig,
)
from kinsync.trajectory import Trajectory

_N_REGULATION_SINUSOIDS = 3


_REGULATION_FREQ_HZ = (0.2, 2.0)


_IMU_PAD_S = 0.2
_PASS_ERROR_STREAM = 7
"""Second seed word of the per-pass attitude error's random stream."""
"""Attitude records before and after each pass (s)."""


_MAX_BEAMS_PER_CHUNK = 400_000


_MIRROR_WINDOW_MARGIN_M = 0.05


_MIRROR_WINDOW_DILATE = 2


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
        # Its own stream: the per-pass attitude error leaves the other draws unchanged.
        self.pass_error_rng = np.random.default_rng([cfg.seed, _PASS_ERROR_STREAM])

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
    def pass_attitude_error_rad(self) -> FloatArray:
        """The next pass's attitude error, a rotation vector (3,), NED (rad); zeros if none."""
        sigma = math.radians(self.cfg.pass_attitude_error_deg)
        if sigma == 0.0:
            return np.zeros(3)
        drawn: FloatArray = self.pass_error_rng.normal(0.0, sigma, 3)
        return drawn

    def attitude_records(
        self, timing: _PassTiming, pass_error_rad: FloatArray | None = None
    ) -> tuple[FloatArray, FloatArray]:
        """Tags (s) and quaternions (w, x, y, z) of the IMU records around a pass.

        ``pass_error_rad``: a rotation vector (NED, rad) applied to every record of the
        pass (`pass_attitude_error_rad`); None for none.
        """
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
        measured = true_rot * noise
        if pass_error_rad is not None and np.any(pass_error_rad):  # one NED-frame error
            measured = Rotation.from_rotvec(pass_error_rad) * measured
        xyzw = measured.as_quat()
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
