"""A small self-consistent drive simulator for the INS filter and smoother tests.

The vehicle follows analytic speed, heading, roll and pitch profiles (static first,
then a smooth drive-off, turns and gentle roll/pitch oscillations). Interval-mean
body rates and specific forces (3-point Gauss–Legendre over each IMU interval) are
computed from the kinematics on the rotating Earth; the *truth* is the strapdown
mechanisation of these clean samples (so filter errors are measured against exactly
what a perfect sensor would give), GNSS fixes are the truth at the antenna plus white
noise, and the IMU given to the filter is the clean one plus constant biases and white
noise.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from kinsync._typing import FloatArray
from kinsync.frames import euler_rpy_to_matrix
from kinsync.ins.earth import OMEGA_IE_RAD_S, normal_gravity_m_s2, radii_m
from kinsync.ins.measurements import GnssData, ImuData
from kinsync.ins.solution import InitialState, NavSolution
from kinsync.ins.strapdown import free_inertial

SimDrive = Callable[..., tuple[ImuData, ImuData, GnssData, NavSolution, InitialState]]

LAT0_DEG, LON0_DEG, H0_M = 46.8, -71.2, 50.0
_GL_NODES = np.array([-math.sqrt(3.0 / 5.0), 0.0, math.sqrt(3.0 / 5.0)])
_GL_WEIGHTS = np.array([5.0, 8.0, 5.0]) / 18.0


def _smoothstep(u: FloatArray) -> FloatArray:
    u = np.clip(u, 0.0, 1.0)
    out: FloatArray = u * u * (3.0 - 2.0 * u)
    return out


class _Profile:
    def __init__(self, static_s: float, speed_m_s: float, heading0_rad: float, turns: bool):
        self.static_s = static_s
        self.speed = speed_m_s
        self.psi0 = heading0_rad
        self.turns = turns

    def euler_speed(self, t: FloatArray) -> tuple[FloatArray, ...]:
        tau = t - self.static_s
        m = _smoothstep(tau / 8.0)
        s = m * (self.speed + 1.0 * np.sin(0.13 * tau))
        turn = (1.6 * (1.0 - np.cos(2.0 * math.pi * tau / 50.0)) + 0.4 * np.sin(0.21 * tau)) * (
            1.0 if self.turns else 0.0
        )
        psi = self.psi0 + m * turn
        roll = m * (0.04 * np.sin(0.7 * tau) + 0.02 * np.sin(1.9 * tau))
        pitch = m * (0.03 * np.sin(0.31 * tau) + 0.01 * np.sin(1.3 * tau))
        return roll, pitch, psi, s

    def vel_ned(self, t: FloatArray) -> FloatArray:
        _, pitch, psi, s = self.euler_speed(t)
        return np.column_stack(
            [s * np.cos(psi) * np.cos(pitch), s * np.sin(psi) * np.cos(pitch), -s * np.sin(pitch)]
        )


def _rates(
    prof: _Profile, t: FloatArray, lat: FloatArray, h: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Body rate w.r.t. inertial space and specific force at times t (body frame)."""
    d = 1e-4
    r, p, y, _ = prof.euler_speed(t)
    rp, pp, yp, _ = prof.euler_speed(t + d)
    rm, pm, ym, _ = prof.euler_speed(t - d)
    rd, pd, yd = (rp - rm) / (2 * d), (pp - pm) / (2 * d), (yp - ym) / (2 * d)
    w_nb = np.column_stack(
        [
            rd - yd * np.sin(p),
            pd * np.cos(r) + yd * np.sin(r) * np.cos(p),
            -pd * np.sin(r) + yd * np.cos(r) * np.cos(p),
        ]
    )
    v = prof.vel_ned(t)
    vdot = (prof.vel_ned(t + d) - prof.vel_ned(t - d)) / (2 * d)
    r_m, r_n = radii_m(lat)
    w_ie = np.column_stack([OMEGA_IE_RAD_S * np.cos(lat), 0.0 * lat, -OMEGA_IE_RAD_S * np.sin(lat)])
    w_en = np.column_stack(
        [v[:, 1] / (r_n + h), -v[:, 0] / (r_m + h), -v[:, 1] * np.tan(lat) / (r_n + h)]
    )
    g = normal_gravity_m_s2(lat, h)
    f_n = vdot + np.cross(2.0 * w_ie + w_en, v) - np.column_stack([0 * g, 0 * g, g])
    R = euler_rpy_to_matrix(r, p, y)
    w_ib = w_nb + np.einsum("nji,nj->ni", R, w_ie + w_en)
    f_b = np.einsum("nji,nj->ni", R, f_n)
    return w_ib, f_b


def simulate_drive(
    *,
    duration_s: float = 120.0,
    rate_hz: float = 100.0,
    static_s: float = 0.0,
    speed_m_s: float = 12.0,
    heading0_deg: float = 30.0,
    turns: bool = True,
    seed: int = 0,
    gyro_bias_rad_s: tuple[float, float, float] = (0.0, 0.0, 0.0),
    acc_bias_m_s2: tuple[float, float, float] = (0.0, 0.0, 0.0),
    gyro_arw: float = 0.0,
    acc_vrw: float = 0.0,
    gnss_hz: float = 5.0,
    gnss_std_pos_m: tuple[float, float, float] = (0.5, 0.5, 1.0),
    gnss_std_vel_m_s: float = 0.05,
    lever_arm_body_m: tuple[float, float, float] = (0.0, 0.0, 0.0),
    gnss_velocity: bool = True,
) -> tuple[ImuData, ImuData, GnssData, NavSolution, InitialState]:
    """Clean IMU, noisy IMU, GNSS, truth (mechanised clean IMU) and the initial state."""
    rng = np.random.default_rng(seed)
    prof = _Profile(static_s, speed_m_s, math.radians(heading0_deg), turns)
    dt = 1.0 / rate_hz
    n = round(duration_s * rate_hz) + 1
    t = np.asarray(np.arange(n) * dt, dtype=np.float64)
    # Approximate latitude/height for the Earth terms (trapezoidal integration).
    v = prof.vel_ned(t)
    r_m, _ = radii_m(math.radians(LAT0_DEG))
    lat = math.radians(LAT0_DEG) + np.concatenate(
        [[0.0], np.cumsum(0.5 * (v[1:, 0] + v[:-1, 0]) * dt)]
    ) / (r_m + H0_M)
    h = H0_M - np.concatenate([[0.0], np.cumsum(0.5 * (v[1:, 2] + v[:-1, 2]) * dt)])
    gyro = np.zeros((n, 3))
    acc = np.zeros((n, 3))
    for node, weight in zip(_GL_NODES, _GL_WEIGHTS, strict=True):
        tq = t - 0.5 * dt + node * 0.5 * dt
        w_ib, f_b = _rates(prof, tq, lat, h)
        gyro += weight * w_ib
        acc += weight * f_b
    clean = ImuData(t_s=t, gyro_body_rad_s=gyro, acc_body_m_s2=acc)
    r0, p0, y0, _ = prof.euler_speed(t[:1])
    v0 = v[0]
    init = InitialState(
        t_s=0.0,
        lat_deg=LAT0_DEG,
        lon_deg=LON0_DEG,
        h_m=H0_M,
        vel_ned_m_s=(float(v0[0]), float(v0[1]), float(v0[2])),
        rpy_rad=(float(r0[0]), float(p0[0]), float(y0[0])),
    )
    truth = free_inertial(clean, init)
    noisy = ImuData(
        t_s=t,
        gyro_body_rad_s=gyro
        + np.asarray(gyro_bias_rad_s)
        + rng.normal(0.0, gyro_arw * math.sqrt(rate_hz), (n, 3)),
        acc_body_m_s2=acc
        + np.asarray(acc_bias_m_s2)
        + rng.normal(0.0, acc_vrw * math.sqrt(rate_hz), (n, 3)),
    )
    step = round(rate_hz / gnss_hz)
    idx = np.arange(0, n, step)
    R = euler_rpy_to_matrix(truth.rpy_rad[idx, 0], truth.rpy_rad[idx, 1], truth.rpy_rad[idx, 2])
    arm = np.asarray(lever_arm_body_m, dtype=np.float64)
    arm_n = R @ arm
    lat_i = np.radians(truth.lat_deg[idx])
    r_m_i, r_n_i = radii_m(lat_i)
    h_i = truth.h_m[idx]
    sp = np.asarray(gnss_std_pos_m)
    noise = rng.normal(0.0, 1.0, (idx.size, 3)) * sp
    lat_g = truth.lat_deg[idx] + np.degrees((arm_n[:, 0] + noise[:, 0]) / (r_m_i + h_i))
    lon_g = truth.lon_deg[idx] + np.degrees(
        (arm_n[:, 1] + noise[:, 1]) / ((r_n_i + h_i) * np.cos(lat_i))
    )
    h_g = h_i - arm_n[:, 2] - noise[:, 2]
    w_b = gyro[idx]
    w_ie = np.column_stack(
        [OMEGA_IE_RAD_S * np.cos(lat_i), 0.0 * lat_i, -OMEGA_IE_RAD_S * np.sin(lat_i)]
    )
    vel_g = (
        truth.vel_ned_m_s[idx]
        + np.einsum("nij,nj->ni", R, np.cross(w_b, arm))
        - np.cross(w_ie, arm_n)
        + rng.normal(0.0, gnss_std_vel_m_s, (idx.size, 3))
    )
    gnss = GnssData(
        t_s=t[idx],
        lat_deg=lat_g,
        lon_deg=lon_g,
        h_m=h_g,
        std_pos_ned_m=np.tile(sp, (idx.size, 1)),
        vel_ned_m_s=vel_g if gnss_velocity else None,
        std_vel_ned_m_s=np.full((idx.size, 3), gnss_std_vel_m_s) if gnss_velocity else None,
    )
    return clean, noisy, gnss, truth, init


def nav_errors(sol: NavSolution, truth: NavSolution) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Position (N, E, D m), velocity (m/s) and misorientation (rad, NED) errors.

    ``truth`` may start earlier than ``sol``; rows are matched by time.
    """
    k = np.searchsorted(truth.t_s, sol.t_s)
    assert np.allclose(truth.t_s[k], sol.t_s)
    lat = np.radians(truth.lat_deg[k])
    r_m, r_n = radii_m(lat)
    h = truth.h_m[k]
    dpos = np.column_stack(
        [
            np.radians(sol.lat_deg - truth.lat_deg[k]) * (r_m + h),
            np.radians(sol.lon_deg - truth.lon_deg[k]) * (r_n + h) * np.cos(lat),
            -(sol.h_m - h),
        ]
    )
    dvel = sol.vel_ned_m_s - truth.vel_ned_m_s[k]
    Rs = euler_rpy_to_matrix(sol.rpy_rad[:, 0], sol.rpy_rad[:, 1], sol.rpy_rad[:, 2])
    Rt = euler_rpy_to_matrix(truth.rpy_rad[k, 0], truth.rpy_rad[k, 1], truth.rpy_rad[k, 2])
    E = Rs @ np.transpose(Rt, (0, 2, 1))
    A = 0.5 * (E - np.transpose(E, (0, 2, 1)))
    datt = -np.column_stack([A[:, 2, 1], A[:, 0, 2], A[:, 1, 0]])
    return dpos, dvel, datt


@pytest.fixture(scope="session")
def sim_drive() -> SimDrive:
    return simulate_drive


@pytest.fixture(scope="session")
def errors_of() -> Callable[..., Any]:
    return nav_errors
