"""A vehicle turning at constant rate with roll and pitch oscillation, and a scan with truth.

Exact motion in the tangent NED frame at an origin (circle of radius ``speed / turn
rate``, a slow height wave, roll and pitch oscillations); geodetic records at a given
rate with NED velocities; scanner-frame points at given times whose exact ECEF position
follows from the analytic motion. Used to bound georeferencing errors and by the demo.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from kinsync._typing import FloatArray
from kinsync.frames import (
    ecef_to_geodetic,
    euler_rpy_to_matrix,
    geodetic_to_ecef,
    matrix_to_quaternion,
    rotation_ned_to_ecef,
)
from kinsync.mount import Mount
from kinsync.trajectory import Trajectory

__all__ = ["TurningVehicle"]


@dataclass(frozen=True)
class TurningVehicle:
    """Analytic motion (defaults: 20 m/s on a 200 m radius, roll 2 deg at 0.2 Hz).

    Attributes
    ----------
    origin_lat_lon_h : tuple of float
        Tangent-frame origin (deg, deg, m).
    speed_m_s, turn_rate_rad_s : float
        Speed and yaw rate.
    roll_amplitude_deg, roll_frequency_hz, pitch_amplitude_deg, pitch_frequency_hz : float
        Attitude oscillations.
    t0_s : float
        Time of the motion's start on the record time scale (s).
    """

    origin_lat_lon_h: tuple[float, float, float] = (46.8, -71.2, 10.0)
    speed_m_s: float = 20.0
    turn_rate_rad_s: float = 0.1
    roll_amplitude_deg: float = 2.0
    roll_frequency_hz: float = 0.2
    pitch_amplitude_deg: float = 1.0
    pitch_frequency_hz: float = 0.13
    t0_s: float = 1.0e9

    def tangent_state(self, t_rel_s: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Position (m), velocity (m/s) in the tangent NED frame and R_body_to_tangent."""
        t = np.asarray(t_rel_s, dtype=np.float64)
        w = self.turn_rate_rad_s
        r = self.speed_m_s / w
        pos = np.column_stack([r * np.sin(w * t), r * (1 - np.cos(w * t)), -0.5 * np.sin(0.2 * t)])
        vel = np.column_stack(
            [r * w * np.cos(w * t), r * w * np.sin(w * t), -0.1 * np.cos(0.2 * t)]
        )
        roll = math.radians(self.roll_amplitude_deg) * np.sin(
            2 * np.pi * self.roll_frequency_hz * t
        )
        pitch = math.radians(self.pitch_amplitude_deg) * np.sin(
            2 * np.pi * self.pitch_frequency_hz * t + 0.3
        )
        return pos, vel, euler_rpy_to_matrix(roll, pitch, w * t)

    def trajectory(self, duration_s: float, rate_hz: float = 100.0) -> Trajectory:
        """Geodetic records of the motion at ``rate_hz`` with NED velocities."""
        t = np.arange(0.0, duration_s + 0.5 / rate_hz, 1.0 / rate_hz)
        pos, vel, R_bt = self.tangent_state(t)
        R_te = rotation_ned_to_ecef(self.origin_lat_lon_h[0], self.origin_lat_lon_h[1])
        ecef = geodetic_to_ecef(*self.origin_lat_lon_h) + pos @ R_te.T
        llh = ecef_to_geodetic(ecef)
        R_ne = rotation_ned_to_ecef(llh[:, 0], llh[:, 1])
        R_bn = np.einsum("nji,jk,nkl->nil", R_ne, R_te, R_bt)  # R_ne^T R_te R_bt
        vel_ned = np.einsum("nji,jk,nk->ni", R_ne, R_te, vel)
        return Trajectory(
            t_s=t + self.t0_s,
            q_body_to_ned=matrix_to_quaternion(R_bn),
            lat_lon_h=llh,
            vel_ned_m_s=vel_ned,
        )

    def truth_ecef_m(
        self, t_rel_s: FloatArray, xyz_scanner_m: FloatArray, mount: Mount
    ) -> FloatArray:
        """Exact ECEF position (m) of scanner-frame points measured at ``t0_s + t_rel_s``."""
        pos, _, R_bt = self.tangent_state(t_rel_s)
        R_te = rotation_ned_to_ecef(self.origin_lat_lon_h[0], self.origin_lat_lon_h[1])
        body = mount.lever_arm_body_m_array + np.asarray(xyz_scanner_m) @ mount.R_scanner_to_body.T
        local = pos + np.einsum("nij,nj->ni", R_bt, body)
        out: FloatArray = geodetic_to_ecef(*self.origin_lat_lon_h) + local @ R_te.T
        return out

    @staticmethod
    def scan(n: int, rng: np.random.Generator, t_end_s: float) -> tuple[FloatArray, FloatArray]:
        """Profile-like scan: relative times in the span, points 3-30 m from the scanner."""
        t_rel = np.sort(rng.uniform(0.05, t_end_s - 0.05, n))
        angle = rng.uniform(0, 2 * np.pi, n)
        rng_m = rng.uniform(3.0, 30.0, n)
        xyz = np.column_stack([rng.normal(0, 0.5, n), rng_m * np.cos(angle), rng_m * np.sin(angle)])
        return t_rel, xyz
