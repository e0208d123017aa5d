"""A planar drive and a 2-D profiler scanning rectangles, discs and spheres (validation scenes).

The machinery of `kinsync.sim.validation_scene`: a planar drive in the tangent NED
frame at `ORIGIN_LAT_LON_H` (`_PlanarDrive`, heading and position integrated on a
1 ms grid and interpolated by cubic Hermite splines), the scene's objects, the
profiler's beams from the pose at each beam's own time, and the ray casting that keeps
the nearest hit with its intensity and range noise.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicHermiteSpline

from kinsync._typing import FloatArray
from kinsync.frames import (
    ecef_to_geodetic,
    euler_rpy_to_matrix,
    geodetic_to_ecef,
    matrix_to_quaternion,
    rotation_ned_to_ecef,
)
from kinsync.mount import Mount

__all__ = ["ORIGIN_LAT_LON_H", "tangent_to_ecef"]

ORIGIN_LAT_LON_H = (46.8, -71.2, 10.0)
"""Tangent-frame origin of the scenes (deg, deg, m): the road surface at the start."""

_FINE_DT_S = 1e-3


_PAD_RAD = math.radians(1.5)


class _PlanarDrive:
    """Planar motion from speed and yaw-rate functions, integrated on a fine grid."""

    def __init__(
        self,
        duration_s: float,
        speed_fn: Callable[[FloatArray], FloatArray],
        yaw_rate_fn: Callable[[FloatArray], FloatArray],
        start_ne_m: tuple[float, float],
        yaw0_rad: float,
        body_height_m: float,
        roll_per_lateral_accel_deg: float,
        oscillation_deg: tuple[float, float],
    ) -> None:
        t = np.arange(-1.0, duration_s + 1.0 + _FINE_DT_S / 2, _FINE_DT_S)
        v = speed_fn(t)
        w = yaw_rate_fn(t)
        dt = np.diff(t)
        psi = yaw0_rad + np.concatenate([[0.0], np.cumsum(0.5 * (w[1:] + w[:-1]) * dt)])
        i0 = int(np.argmin(np.abs(t)))
        psi -= psi[i0] - yaw0_rad
        vn, ve = v * np.cos(psi), v * np.sin(psi)
        n = np.concatenate([[0.0], np.cumsum(0.5 * (vn[1:] + vn[:-1]) * dt)])
        e = np.concatenate([[0.0], np.cumsum(0.5 * (ve[1:] + ve[:-1]) * dt)])
        n += start_ne_m[0] - n[i0]
        e += start_ne_m[1] - e[i0]
        self._n = CubicHermiteSpline(t, n, vn)
        self._e = CubicHermiteSpline(t, e, ve)
        self._psi = CubicHermiteSpline(t, psi, w)
        self._speed_fn = speed_fn
        self._yaw_rate_fn = yaw_rate_fn
        self.body_height_m = body_height_m
        self.roll_gain_rad = math.radians(roll_per_lateral_accel_deg)
        self.osc_rad = (math.radians(oscillation_deg[0]), math.radians(oscillation_deg[1]))
        self.duration_s = duration_s

    def state(self, t_rel_s: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Position (m) and velocity (m/s) in the tangent NED frame, R_body_to_tangent."""
        t = np.asarray(t_rel_s, dtype=np.float64)
        psi = self._psi(t)
        v = self._speed_fn(t)
        w = self._yaw_rate_fn(t)
        pos = np.column_stack([self._n(t), self._e(t), np.full(t.shape, -self.body_height_m)])
        vel = np.column_stack([v * np.cos(psi), v * np.sin(psi), np.zeros(t.shape)])
        roll = -self.roll_gain_rad * v * w + self.osc_rad[0] * np.sin(2 * np.pi * 0.7 * t)
        pitch = self.osc_rad[1] * np.sin(2 * np.pi * 0.4 * t + 0.3)
        return pos, vel, euler_rpy_to_matrix(roll, pitch, psi)


def _tangent_to_records(
    t_s: FloatArray, pos_t: FloatArray, vel_t: FloatArray, R_bt: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Tangent-frame states to geodetic records (t, llh, q_body_to_ned, vel_ned)."""
    R_te = rotation_ned_to_ecef(ORIGIN_LAT_LON_H[0], ORIGIN_LAT_LON_H[1])
    ecef = geodetic_to_ecef(*ORIGIN_LAT_LON_H) + pos_t @ R_te.T
    llh = ecef_to_geodetic(ecef)
    R_ne = rotation_ned_to_ecef(llh[:, 0], llh[:, 1])
    R_bn = np.einsum("nji,jk,nkl->nil", R_ne, R_te, R_bt)
    vel_ned = np.einsum("nji,jk,nk->ni", R_ne, R_te, vel_t)
    return t_s, llh, matrix_to_quaternion(R_bn), vel_ned


def _gauss_markov(
    n: int, dt_s: float, sigma_m: float, corr_s: float, rng: np.random.Generator
) -> FloatArray:
    """(n, 3) first-order Gauss-Markov process, stationary standard deviation sigma."""
    out = np.zeros((n, 3))
    if sigma_m <= 0.0 or n == 0:
        return out
    phi = math.exp(-dt_s / corr_s)
    drive = rng.normal(0.0, sigma_m * math.sqrt(1.0 - phi * phi), (n, 3))
    out[0] = rng.normal(0.0, sigma_m, 3)
    for i in range(1, n):
        out[i] = phi * out[i - 1] + drive[i]
    return out


def tangent_to_ecef(pos_t: FloatArray) -> FloatArray:
    """Tangent-frame NED positions (m) at `ORIGIN_LAT_LON_H` to ECEF (m), shape (..., 3)."""
    R_te = rotation_ned_to_ecef(ORIGIN_LAT_LON_H[0], ORIGIN_LAT_LON_H[1])
    out: FloatArray = geodetic_to_ecef(*ORIGIN_LAT_LON_H) + np.asarray(pos_t) @ R_te.T
    return out


@dataclass(frozen=True)
class _Rect:
    """Rectangle: centre, unit normal, unit in-plane axes, half sizes (tangent frame)."""

    centre: FloatArray
    normal: FloatArray
    axis1: FloatArray
    axis2: FloatArray
    half1: float
    half2: float
    intensity: float


@dataclass(frozen=True)
class _Disc:
    """A flat disc lying on a rectangle's plane (centre, radius); a brighter patch."""

    centre: FloatArray
    radius: float
    intensity: float


@dataclass(frozen=True)
class _Sphere:
    centre: FloatArray
    radius: float
    intensity: float


@dataclass(frozen=True)
class _Group:
    """Objects scanned together: one board (or wall), an optional disc or sphere."""

    rect: _Rect
    disc: _Disc | None = None
    sphere: _Sphere | None = None


def _rows_dot(a: FloatArray, b: FloatArray) -> FloatArray:
    out: FloatArray = np.einsum("ij,ij->i", a, b)
    return out


def _rect_interval(
    o: FloatArray, e1: FloatArray, e2: FloatArray, m: FloatArray, rect: _Rect
) -> tuple[FloatArray, FloatArray]:
    """Mirror-angle interval (lo, hi) in which each profile's plane meets the rectangle.

    o, e1, e2, m: (K, 3) scanner origin, profile-plane axes (mirror angle phi measured
    from e2 towards e1) and plane normal. NaN where the plane misses the rectangle.
    """
    k = o.shape[0]
    n = np.broadcast_to(rect.normal, (k, 3))
    line = np.cross(m, n)
    norm = np.linalg.norm(line, axis=1)
    ok = norm > 1e-9
    line = line / np.where(ok, norm, 1.0)[:, None]
    A = np.stack([m, n, line], axis=1)
    A[~ok] = np.eye(3)
    rhs = np.column_stack([_rows_dot(m, o), n @ rect.centre, _rows_dot(line, o)])
    p0 = np.linalg.solve(A, rhs[..., None])[..., 0]
    s_lo = np.full(k, -np.inf)
    s_hi = np.full(k, np.inf)
    for axis, half in ((rect.axis1, rect.half1), (rect.axis2, rect.half2)):
        al = line @ axis
        off = (p0 - rect.centre) @ axis
        par = np.abs(al) < 1e-12
        ok &= ~par | (np.abs(off) <= half)
        safe = np.where(par, 1.0, al)
        a = (-half - off) / safe
        b = (half - off) / safe
        s_lo = np.where(par, s_lo, np.maximum(s_lo, np.minimum(a, b)))
        s_hi = np.where(par, s_hi, np.minimum(s_hi, np.maximum(a, b)))
    ok &= s_hi > s_lo
    s_lo = np.where(ok, s_lo, 0.0)
    s_hi = np.where(ok, s_hi, 0.0)
    ends = [p0 + s[:, None] * line - o for s in (s_lo, s_hi)]
    ang = [np.arctan2(_rows_dot(x, e1), _rows_dot(x, e2)) for x in ends]
    span = (ang[1] - ang[0] + np.pi) % (2 * np.pi) - np.pi
    lo = np.where(span >= 0, ang[0], ang[0] + span)
    hi = lo + np.abs(span)
    return np.where(ok, lo, np.nan), np.where(ok, hi, np.nan)


def _sphere_interval(
    o: FloatArray, e1: FloatArray, e2: FloatArray, m: FloatArray, sphere: _Sphere
) -> tuple[FloatArray, FloatArray]:
    """Mirror-angle interval of the circle a profile plane cuts from a sphere (or NaN)."""
    rel = sphere.centre - o
    dist = _rows_dot(rel, m)
    rho2 = sphere.radius**2 - dist**2
    ok = rho2 > 0.0
    cc = rel - dist[:, None] * m
    length = np.linalg.norm(cc, axis=1)
    half = np.arcsin(np.clip(np.sqrt(np.maximum(rho2, 0.0)) / length, 0.0, 1.0))
    mid = np.arctan2(_rows_dot(cc, e1), _rows_dot(cc, e2))
    return np.where(ok, mid - half, np.nan), np.where(ok, mid + half, np.nan)


@dataclass(frozen=True, eq=False)
class _Scanner:
    profile_rate_hz: float
    angle_step_rad: float
    range_noise_m: float
    max_range_m: float = 80.0


def _scanner_axes(
    drive: _PlanarDrive, t_rel: FloatArray, mount: Mount
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Scanner origin and profile-plane axes e1 (phi = 90 deg), e2 (nadir), normal."""
    pos, _, R_bt = drive.state(t_rel)
    R_ts = np.einsum("nij,jk->nik", R_bt, mount.R_scanner_to_body)
    az = math.radians(mount.profiler_azimuth_deg or 0.0)
    e1_s = np.array([-math.sin(az), math.cos(az), 0.0])
    e2_s = np.array([0.0, 0.0, 1.0])
    o = pos + np.einsum("nij,j->ni", R_bt, mount.lever_arm_body_m_array)
    e1 = np.einsum("nij,j->ni", R_ts, e1_s)
    e2 = np.einsum("nij,j->ni", R_ts, e2_s)
    return o, e1, e2, np.cross(e1, e2)


def _beams(
    drive: _PlanarDrive,
    t_profiles_rel: FloatArray,
    group: _Group,
    mount: Mount,
    scanner: _Scanner,
) -> tuple[FloatArray, FloatArray]:
    """Mirror angles and times of the beams that can meet a group (padded intervals)."""
    o, e1, e2, m = _scanner_axes(drive, t_profiles_rel, mount)
    lo, hi = _rect_interval(o, e1, e2, m, group.rect)
    if group.sphere is not None:
        slo, shi = _sphere_interval(o, e1, e2, m, group.sphere)
        lo = np.fmin(lo, slo)
        hi = np.fmax(hi, shi)
    ok = np.isfinite(lo)
    step = scanner.angle_step_rad
    t_p, lo, hi = t_profiles_rel[ok], lo[ok] - _PAD_RAD, hi[ok] + _PAD_RAD
    k_lo = np.ceil(lo / step).astype(np.int64)
    k_hi = np.floor(hi / step).astype(np.int64)
    counts = np.maximum(k_hi - k_lo + 1, 0)
    prof = np.repeat(np.arange(t_p.size), counts)
    first = np.repeat(np.cumsum(counts) - counts, counts)
    k = k_lo[prof] + (np.arange(prof.size) - first)
    phi = (k * step + np.pi) % (2 * np.pi) - np.pi
    t_beam = t_p[prof] + (phi + np.pi) / (2 * np.pi) / scanner.profile_rate_hz
    return phi, t_beam


def _cast(origin: FloatArray, d: FloatArray, group: _Group) -> tuple[FloatArray, FloatArray]:
    """Range of the nearest hit (inf where none) and its intensity, per beam."""
    r_best = np.full(d.shape[0], np.inf)
    rect = group.rect
    denom = d @ rect.normal
    safe = np.where(np.abs(denom) > 1e-12, denom, np.nan)
    r = ((rect.centre - origin) @ rect.normal) / safe
    x = origin + r[:, None] * d
    rel = x - rect.centre
    hit = (
        (r > 0)
        & (np.abs(rel @ rect.axis1) <= rect.half1)
        & (np.abs(rel @ rect.axis2) <= rect.half2)
    )
    r_best = np.where(hit, r, r_best)
    inten = np.where(hit, rect.intensity, 0.0)
    if group.disc is not None:
        on_disc = hit & (np.linalg.norm(x - group.disc.centre, axis=1) <= group.disc.radius)
        inten = np.where(on_disc, group.disc.intensity, inten)
    if group.sphere is not None:
        sph = group.sphere
        rel_c = sph.centre - origin
        b = _rows_dot(d, rel_c)
        disc2 = b * b - (_rows_dot(rel_c, rel_c) - sph.radius**2)
        r_s = b - np.sqrt(np.maximum(disc2, 0.0))
        hit_s = (disc2 >= 0.0) & (r_s > 0.0) & (r_s < r_best)
        r_best = np.where(hit_s, r_s, r_best)
        inten = np.where(hit_s, sph.intensity, inten)
    return r_best, inten


def _scan_group(
    drive: _PlanarDrive,
    t_profiles_rel: FloatArray,
    group: _Group,
    mount: Mount,
    scanner: _Scanner,
    rng: np.random.Generator,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Cast the beams that can meet a group; (t_rel, xyz_scanner, intensity, truth)."""
    phi, t_beam = _beams(drive, t_profiles_rel, group, mount, scanner)
    d_s = mount.profile_to_scanner(angle_rad=phi, range_m=np.ones_like(phi))
    pos, _, R_bt = drive.state(t_beam)
    R_ts = np.einsum("nij,jk->nik", R_bt, mount.R_scanner_to_body)
    origin = pos + np.einsum("nij,j->ni", R_bt, mount.lever_arm_body_m_array)
    d = np.einsum("nij,nj->ni", R_ts, d_s)
    r_best, inten = _cast(origin, d, group)
    keep = np.isfinite(r_best) & (r_best < scanner.max_range_m)
    r_true = r_best[keep]
    r_meas = r_true + rng.normal(0.0, scanner.range_noise_m, r_true.size)
    xyz = d_s[keep] * r_meas[:, None]
    truth = origin[keep] + d[keep] * r_true[:, None]
    base = inten[keep]
    noisy = base * np.exp(rng.normal(0.0, 0.1, base.size))
    return t_beam[keep], xyz, np.clip(np.round(noisy), 0, 65535), truth
