"""Straightforward numpy implementation of the forward filter (no numba).

The same equations as `kinsync.ins.filter` written the way a first Python version
would be: per epoch, the strapdown step with numpy vectors and rotation matrices, a
dense ``F`` assembled from 3×3 blocks, ``Φ = I + FΔt + (FΔt)²/2`` and
``P ← Φ P Φ^T + Q`` as dense matrix products, and one joint Kalman update per GNSS
epoch (``K = P H^T S^{-1}``, Joseph form). It is the speed baseline of
``benchmarks/bench_ins.py`` and an independent check of the compiled loop's
structured products and sequential scalar updates (``tests/ins/test_filter.py``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation
from scipy.stats import chi2

from kinsync._typing import FloatArray
from kinsync.frames import euler_rpy_to_matrix
from kinsync.ins.config import InsConfig
from kinsync.ins.earth import OMEGA_IE_RAD_S, normal_gravity_m_s2, radii_m
from kinsync.ins.filter import gnss_epochs, initial_covariance
from kinsync.ins.measurements import GnssData, ImuData
from kinsync.ins.solution import InitialState
from kinsync.ins.strapdown import start_epoch

__all__ = ["forward_numpy"]

_I3 = np.eye(3)

ObservationBlock = tuple[FloatArray, FloatArray, FloatArray]
"""``(H (3, 15), z (3,), r (3,))``: rows, INS-minus-GNSS values and noise variances."""


def _skew(v: FloatArray) -> FloatArray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _rotvec_matrix(v: FloatArray) -> FloatArray:
    out: FloatArray = Rotation.from_rotvec(v).as_matrix()
    return out


@dataclass(slots=True)
class _Nav:
    """Nominal navigation state of the numpy filter, replaced field by field each epoch."""

    lat_rad: float
    lon_rad: float
    h_m: float
    vel_ned_m_s: FloatArray
    R_body_to_ned: FloatArray
    gyro_bias_rad_s: FloatArray
    acc_bias_m_s2: FloatArray
    dtheta_prev_rad: FloatArray
    """Previous interval's bias-corrected angle increment, body (coning correction)."""
    dv_prev_m_s: FloatArray
    """Previous interval's bias-corrected velocity increment, body (sculling)."""

    @classmethod
    def from_initial(cls, init: InitialState) -> _Nav:
        return cls(
            lat_rad=math.radians(init.lat_deg),
            lon_rad=math.radians(init.lon_deg),
            h_m=float(init.h_m),
            vel_ned_m_s=np.array(init.vel_ned_m_s, dtype=np.float64),
            R_body_to_ned=euler_rpy_to_matrix(*init.rpy_rad),
            gyro_bias_rad_s=np.array(init.gyro_bias_rad_s, dtype=np.float64),
            acc_bias_m_s2=np.array(init.acc_bias_m_s2, dtype=np.float64),
            dtheta_prev_rad=np.zeros(3),
            dv_prev_m_s=np.zeros(3),
        )

    def state_row(self) -> list[float]:
        """The compiled loop's layout: lat, lon, h, v, q (w, x, y, z), b_g, b_a."""
        q = Rotation.from_matrix(self.R_body_to_ned).as_quat()
        return [
            self.lat_rad, self.lon_rad, self.h_m, *self.vel_ned_m_s, q[3], q[0], q[1], q[2],
            *self.gyro_bias_rad_s, *self.acc_bias_m_s2,
        ]  # fmt: skip


def _earth_rates(nav: _Nav) -> tuple[float, float, FloatArray, FloatArray]:
    """Meridian and normal radii (m), ``ω_ie`` and ``ω_en`` (rad/s, NED) at ``nav``."""
    lat, h, v = nav.lat_rad, nav.h_m, nav.vel_ned_m_s
    r_m, r_n = radii_m(lat)
    rmh, rnh = r_m + h, r_n + h
    sl, cl, tl = math.sin(lat), math.cos(lat), math.tan(lat)
    w_ie = OMEGA_IE_RAD_S * np.array([cl, 0.0, -sl])
    w_en = np.array([v[1] / rnh, -v[0] / rmh, -v[1] * tl / rnh])
    return r_m, r_n, w_ie, w_en


def _process_noise_psd(config: InsConfig) -> FloatArray:
    """Diagonal of the continuous process noise of the 15 error states."""
    tau_g, tau_a = config.gyro_bias_corr_time_s, config.acc_bias_corr_time_s
    return np.concatenate(
        [
            [config.gyro_arw_rad_s_rthz**2] * 3,
            [config.acc_vrw_m_s2_rthz**2] * 3,
            [0.0] * 3,
            [2.0 * config.gyro_bias_instability_rad_s**2 / tau_g] * 3,
            [2.0 * config.acc_bias_instability_m_s2**2 / tau_a] * 3,
        ]
    )


def _gnss_std(gnss: GnssData, config: InsConfig) -> tuple[FloatArray, FloatArray]:
    """Position (m) and velocity (m/s) σ per GNSS epoch, NaN replaced by the defaults."""
    std_p = np.where(
        np.isnan(gnss.std_pos_ned_m), np.array(config.gnss_std_pos_ned_m), gnss.std_pos_ned_m
    )
    std_v = np.tile(np.array(config.gnss_std_vel_ned_m_s), (len(gnss), 1))
    if gnss.std_vel_ned_m_s is not None:
        std_v = np.where(np.isnan(gnss.std_vel_ned_m_s), std_v, gnss.std_vel_ned_m_s)
    return std_p, std_v


def _system_matrix(nav: _Nav, f_b: FloatArray, tau_g: float, tau_a: float) -> FloatArray:
    """Dense error dynamics ``F`` (15, 15) at the start of an interval, from 3×3 blocks."""
    lat, h, v, C = nav.lat_rad, nav.h_m, nav.vel_ned_m_s, nav.R_body_to_ned
    r_m, r_n, w_ie, w_en = _earth_rates(nav)
    rmh, rnh = r_m + h, r_n + h
    sl, cl, tl = math.sin(lat), math.cos(lat), math.tan(lat)
    f_n = C @ f_b
    D_ie = np.zeros((3, 3))
    D_ie[:, 0] = OMEGA_IE_RAD_S * np.array([-sl, 0.0, -cl]) / rmh
    D_v = np.array([[0.0, 1.0 / rnh, 0.0], [-1.0 / rmh, 0.0, 0.0], [0.0, -tl / rnh, 0.0]])
    D_p = np.zeros((3, 3))
    D_p[0, 2] = v[1] / rnh**2
    D_p[1, 2] = -v[0] / rmh**2
    D_p[2, 0] = -v[1] / (cl * cl * rnh * rmh)
    D_p[2, 2] = -v[1] * tl / rnh**2
    F = np.zeros((15, 15))
    F[0:3, 0:3] = -_skew(w_ie + w_en)
    F[0:3, 3:6] = D_v
    F[0:3, 6:9] = D_ie + D_p
    F[0:3, 9:12] = -C
    F[3:6, 0:3] = _skew(f_n)
    F[3:6, 3:6] = -_skew(2.0 * w_ie + w_en) + _skew(v) @ D_v
    F[3:6, 6:9] = _skew(v) @ (2.0 * D_ie + D_p)
    F[5, 8] += 2.0 * normal_gravity_m_s2(lat, h) / math.sqrt(r_m * r_n)
    F[3:6, 12:15] = C
    F[6:9, 3:6] = _I3
    F[6, 6], F[6, 8] = -v[2] / rmh, v[0] / rmh
    F[7, 6], F[7, 7], F[7, 8] = v[1] * tl / rmh, -(v[2] / rnh + v[0] * tl / rmh), v[1] / rnh
    F[9:12, 9:12] = -_I3 / tau_g
    F[12:15, 12:15] = -_I3 / tau_a
    return F


def _strapdown_step(nav: _Nav, w_b: FloatArray, f_b: FloatArray, dt: float, first: bool) -> None:
    """One mechanisation interval with coning and sculling corrections (in place)."""
    lat, h, v, C = nav.lat_rad, nav.h_m, nav.vel_ned_m_s, nav.R_body_to_ned
    r_m, r_n, w_ie, w_en = _earth_rates(nav)
    dth = w_b * dt
    dv = f_b * dt
    if first:
        nav.dtheta_prev_rad, nav.dv_prev_m_s = dth, dv
    prev_dth, prev_dv = nav.dtheta_prev_rad, nav.dv_prev_m_s
    phi = dth + np.cross(prev_dth, dth) / 12.0
    dv_b = dv + 0.5 * np.cross(dth, dv) + (np.cross(prev_dth, dv) + np.cross(prev_dv, dth)) / 12.0
    nav.dtheta_prev_rad, nav.dv_prev_m_s = dth, dv
    zeta = (w_ie + w_en) * dt
    g_vec = np.array([0.0, 0.0, normal_gravity_m_s2(lat, h)])
    v_new = (
        v + (_I3 - 0.5 * _skew(zeta)) @ (C @ dv_b) + (g_vec - np.cross(2.0 * w_ie + w_en, v)) * dt
    )
    h_new = h - 0.5 * (v[2] + v_new[2]) * dt
    h_mid = 0.5 * (h + h_new)
    lat_new = lat + 0.5 * (v[0] + v_new[0]) * dt / (r_m + h_mid)
    nav.lon_rad += 0.5 * (v[1] + v_new[1]) * dt / ((r_n + h_mid) * math.cos(0.5 * (lat + lat_new)))
    nav.lat_rad, nav.h_m, nav.vel_ned_m_s = lat_new, h_new, v_new
    nav.R_body_to_ned = _rotvec_matrix(-zeta) @ C @ _rotvec_matrix(phi)


def _gnss_blocks(
    nav: _Nav,
    gnss: GnssData,
    j: int,
    dt_shift_s: float,
    gyro_body_rad_s: FloatArray,
    arm_body_m: FloatArray,
    var_pos_m2: FloatArray,
    var_vel_m2_s2: FloatArray | None,
) -> list[ObservationBlock]:
    """Position block and, when ``var_vel_m2_s2`` is given, velocity block of epoch ``j``.

    ``dt_shift_s = t_imu - t_gnss``; ``gyro_body_rad_s`` is the raw IMU sample.
    """
    lat, lon, h, v, C = nav.lat_rad, nav.lon_rad, nav.h_m, nav.vel_ned_m_s, nav.R_body_to_ned
    r_m, r_n = radii_m(lat)
    arm_n = C @ arm_body_m
    dlon = (lon - math.radians(gnss.lon_deg[j]) + math.pi) % (2 * math.pi) - math.pi
    z_p = (
        np.array(
            [
                (lat - math.radians(gnss.lat_deg[j])) * (r_m + h),
                dlon * (r_n + h) * math.cos(lat),
                -(h - gnss.h_m[j]),
            ]
        )
        + arm_n
        - v * dt_shift_s
    )
    H_p = np.zeros((3, 15))
    H_p[:, 0:3] = _skew(arm_n)
    H_p[:, 6:9] = _I3
    blocks = [(H_p, z_p, var_pos_m2)]
    if var_vel_m2_s2 is not None:
        assert gnss.vel_ned_m_s is not None
        w_ie = OMEGA_IE_RAD_S * np.array([math.cos(lat), 0.0, -math.sin(lat)])
        cw = C @ np.cross(gyro_body_rad_s - nav.gyro_bias_rad_s, arm_body_m)
        z_v = v + cw - np.cross(w_ie, arm_n) - gnss.vel_ned_m_s[j]
        H_v = np.zeros((3, 15))
        H_v[:, 0:3] = _skew(cw) - _skew(w_ie) @ _skew(arm_n)
        H_v[:, 3:6] = _I3
        H_v[:, 9:12] = -C @ _skew(arm_body_m)
        blocks.append((H_v, z_v, var_vel_m2_s2))
    return blocks


def _passes_gate(P: FloatArray, blocks: list[ObservationBlock], gate: float) -> bool:
    """``z^T S^{-1} z <= gate`` for every block, ``S = H P H^T + diag(r)``."""
    return all(
        float(z @ np.linalg.solve(Hb @ P @ Hb.T + np.diag(r), z)) <= gate for Hb, z, r in blocks
    )


def _joint_update(P: FloatArray, blocks: list[ObservationBlock]) -> tuple[FloatArray, FloatArray]:
    """Error-state estimate ``x`` and Joseph-form ``P`` after one joint update."""
    H = np.vstack([b[0] for b in blocks])
    z = np.concatenate([b[1] for b in blocks])
    R = np.diag(np.concatenate([b[2] for b in blocks]))
    S = H @ P @ H.T + R
    K = P @ H.T @ np.linalg.inv(S)
    x = K @ z
    IKH = np.eye(15) - K @ H
    return x, IKH @ P @ IKH.T + K @ R @ K.T


def _feedback(nav: _Nav, x: FloatArray) -> None:
    """Closed-loop correction ``true ≈ nominal ⊖ x`` (in place)."""
    r_m, r_n = radii_m(nav.lat_rad)
    nav.R_body_to_ned = _rotvec_matrix(x[0:3]) @ nav.R_body_to_ned
    nav.vel_ned_m_s = nav.vel_ned_m_s - x[3:6]
    nav.lon_rad -= x[7] / ((r_n + nav.h_m) * math.cos(nav.lat_rad))
    nav.lat_rad -= x[6] / (r_m + nav.h_m)
    nav.h_m += x[8]
    nav.gyro_bias_rad_s = nav.gyro_bias_rad_s + x[9:12]
    nav.acc_bias_m_s2 = nav.acc_bias_m_s2 + x[12:15]


def forward_numpy(
    imu: ImuData,
    gnss: GnssData,
    config: InsConfig,
    init: InitialState,
    n_epochs: int,
    *,
    use_velocity: bool = True,
) -> tuple[FloatArray, FloatArray]:
    """Forward filter over the first ``n_epochs`` IMU epochs from ``init``.

    Returns
    -------
    states : ndarray, shape (n_epochs, 16)
        lat, lon (rad), h, v_NED, q_body_to_ned (w, x, y, z), gyro and acc bias
        estimates, after each epoch's update (the compiled loop's layout).
    std : ndarray, shape (n_epochs, 15)
        1σ of the error state.
    """
    k0 = start_epoch(imu, init)
    n_end = min(len(imu), k0 + n_epochs)
    nav = _Nav.from_initial(init)
    P = initial_covariance(config)
    tau_g, tau_a = config.gyro_bias_corr_time_s, config.acc_bias_corr_time_s
    qc = _process_noise_psd(config)
    arm = np.array(config.antenna_lever_arm_body_m)
    gate = float(chi2.ppf(config.gate_probability, 3))
    g_epoch = gnss_epochs(imu.t_s, k0, gnss.t_s)
    std_p, std_v = _gnss_std(gnss, config)
    with_vel = use_velocity and gnss.vel_ned_m_s is not None
    states = np.zeros((n_end - k0, 16))
    stds = np.zeros((n_end - k0, 15))
    for k in range(k0, n_end):
        if k > k0:
            dt = imu.t_s[k] - imu.t_s[k - 1]
            f_b = imu.acc_body_m_s2[k] - nav.acc_bias_m_s2
            w_b = imu.gyro_body_rad_s[k] - nav.gyro_bias_rad_s
            Fd = _system_matrix(nav, f_b, tau_g, tau_a) * dt
            Phi = np.eye(15) + Fd + 0.5 * Fd @ Fd
            P = Phi @ P @ Phi.T + np.diag(qc * dt)
            _strapdown_step(nav, w_b, f_b, dt, first=k == k0 + 1)
        for j in np.flatnonzero(g_epoch == k):
            blocks = _gnss_blocks(
                nav, gnss, int(j), imu.t_s[k] - gnss.t_s[j], imu.gyro_body_rad_s[k], arm,
                std_p[j] ** 2, std_v[j] ** 2 if with_vel else None,
            )  # fmt: skip
            if not _passes_gate(P, blocks, gate):
                continue
            x, P = _joint_update(P, blocks)
            _feedback(nav, x)
        states[k - k0] = nav.state_row()
        stds[k - k0] = np.sqrt(np.diag(P))
    return states, stds
