"""Straightforward numpy implementation of the forward filter (no numba).

The same equations as `kinsync.ins.filter` (modified φ-angle error model, turn-on
bias, bias instability and optional scale factor states: `kinsync.ins._ekf`) written
the way a first Python version would be: per epoch, the strapdown step with numpy
vectors and rotation matrices, a dense ``F`` assembled from 3×3 blocks,
``Φ = I + FΔt + (FΔt)²/2`` and ``P ← Φ P Φ^T + G Q_c G^T Δt`` as dense matrix
products, and one joint Kalman update per GNSS epoch (``K = P H^T S^{-1}``, Joseph
form). It is the speed baseline of
``benchmarks/bench_ins.py`` and an independent check of the compiled loop's
structured products and sequential scalar updates (``tests/ins/test_filter.py``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation
from scipy.special import chdtri

from kinsync._typing import FloatArray
from kinsync.frames import euler_rpy_to_matrix
from kinsync.ins.config import InsConfig
from kinsync.ins.earth import OMEGA_IE_RAD_S, normal_gravity_m_s2, radii_m
from kinsync.ins.filter import initial_covariance, starting_estimates
from kinsync.ins.gnss_observation import gnss_epochs
from kinsync.ins.measurements import GnssData, ImuData
from kinsync.ins.solution import InitialState
from kinsync.ins.strapdown import start_epoch

__all__ = ["forward_numpy"]

_I3 = np.eye(3)

ObservationBlock = tuple[FloatArray, FloatArray, FloatArray]
"""``(H (3, n), z (3,), r (3,))``: rows, INS-minus-GNSS values and noise variances."""

_BG, _BA, _MG, _MA, _SG, _SA = (slice(9 + 3 * i, 12 + 3 * i) for i in range(6))
"""Error-state blocks of the sensor errors (`kinsync.ins._ekf`)."""


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
    gyro_instability_rad_s: FloatArray
    acc_instability_m_s2: FloatArray
    gyro_scale: FloatArray
    acc_scale: FloatArray
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
            gyro_instability_rad_s=np.zeros(3),
            acc_instability_m_s2=np.zeros(3),
            gyro_scale=np.zeros(3),
            acc_scale=np.zeros(3),
            dtheta_prev_rad=np.zeros(3),
            dv_prev_m_s=np.zeros(3),
        )

    def state_row(self) -> list[float]:
        """The compiled loop's layout: lat, lon, h, v, q (w, x, y, z), sensor errors."""
        q = Rotation.from_matrix(self.R_body_to_ned).as_quat()
        return [
            self.lat_rad, self.lon_rad, self.h_m, *self.vel_ned_m_s, q[3], q[0], q[1], q[2],
            *self.gyro_bias_rad_s, *self.acc_bias_m_s2, *self.gyro_instability_rad_s,
            *self.acc_instability_m_s2, *self.gyro_scale, *self.acc_scale,
        ]  # fmt: skip

    def corrected(self, gyro: FloatArray, acc: FloatArray) -> tuple[FloatArray, FloatArray]:
        """The IMU sample corrected with the sensor error estimates."""
        w_b = (gyro - self.gyro_bias_rad_s - self.gyro_instability_rad_s) / (1 + self.gyro_scale)
        f_b = (acc - self.acc_bias_m_s2 - self.acc_instability_m_s2) / (1 + self.acc_scale)
        return w_b, f_b


def _earth_rates(nav: _Nav) -> tuple[float, float, FloatArray, FloatArray]:
    """Meridian and normal radii (m), ``ω_ie`` and ``ω_en`` (rad/s, NED) at ``nav``."""
    lat, h, v = nav.lat_rad, nav.h_m, nav.vel_ned_m_s
    r_m, r_n = radii_m(lat)
    rmh, rnh = r_m + h, r_n + h
    sl, cl, tl = math.sin(lat), math.cos(lat), math.tan(lat)
    w_ie = OMEGA_IE_RAD_S * np.array([cl, 0.0, -sl])
    w_en = np.array([v[1] / rnh, -v[0] / rmh, -v[1] * tl / rnh])
    return r_m, r_n, w_ie, w_en


def _gnss_std(gnss: GnssData, config: InsConfig) -> tuple[FloatArray, FloatArray]:
    """Position (m) and velocity (m/s) σ per GNSS epoch, NaN replaced by the defaults."""
    std_p = np.where(
        np.isnan(gnss.std_pos_ned_m), np.array(config.gnss_std_pos_ned_m), gnss.std_pos_ned_m
    )
    std_v = np.tile(np.array(config.gnss_std_vel_ned_m_s), (len(gnss), 1))
    if gnss.std_vel_ned_m_s is not None:
        std_v = np.where(np.isnan(gnss.std_vel_ned_m_s), std_v, gnss.std_vel_ned_m_s)
    return std_p, std_v


def _system_matrix(
    nav: _Nav, w_b: FloatArray, f_b: FloatArray, config: InsConfig, n: int
) -> tuple[FloatArray, FloatArray]:
    """Dense error dynamics ``F`` (n, n) and noise input ``G`` (n, 3 + 3 + 6).

    ``G`` maps the white gyro noise, accelerometer noise and the instabilities' driving
    noises (in that order) into the error state.
    """
    lat, h, v, C = nav.lat_rad, nav.h_m, nav.vel_ned_m_s, nav.R_body_to_ned
    r_m, r_n, w_ie, w_en = _earth_rates(nav)
    rmh, rnh = r_m + h, r_n + h
    tl = math.tan(lat)
    Rc = np.array([[0.0, 1.0 / rnh, 0.0], [-1.0 / rmh, 0.0, 0.0], [0.0, -tl / rnh, 0.0]])
    V = _skew(v)
    g = normal_gravity_m_s2(lat, h)
    F = np.zeros((n, n))
    F[0:3, 0:3] = Rc @ V - _skew(w_ie + w_en)
    F[0:3, 3:6] = Rc
    F[0:3, 6:9] = _skew(w_ie) @ Rc
    F[3:6, 0:3] = -_skew(np.array([0.0, 0.0, g]))
    F[3:6, 3:6] = -_skew(2.0 * w_ie + w_en)
    F[5, 8] = 2.0 * g / math.sqrt(r_m * r_n)
    F[6:9, 0:3] = V
    F[6:9, 3:6] = _I3
    F[6, 6], F[6, 8] = -v[2] / rmh, v[0] / rmh
    F[7, 6], F[7, 7], F[7, 8] = v[1] * tl / rmh, -(v[2] / rnh + v[0] * tl / rmh), v[1] / rnh
    B_g = np.vstack([-C, V @ C, np.zeros((3, 3))])  # gyro error -> navigation errors
    B_a = np.vstack([np.zeros((3, 3)), C, np.zeros((3, 3))])
    F[0:9, _BG] = F[0:9, _MG] = B_g
    F[0:9, _BA] = F[0:9, _MA] = B_a
    F[_MG, _MG] = -_I3 / config.gyro_bias_corr_time_s
    F[_MA, _MA] = -_I3 / config.acc_bias_corr_time_s
    if n > 21:
        F[0:9, _SG] = B_g @ np.diag(w_b)
        F[0:9, _SA] = B_a @ np.diag(f_b)
    G = np.zeros((n, 12))
    G[0:9, 0:3] = B_g
    G[0:9, 3:6] = B_a
    G[_MG, 6:9] = _I3
    G[_MA, 9:12] = _I3
    return F, G


def _noise_psd(config: InsConfig) -> FloatArray:
    """PSDs of the noises ``G`` takes: gyro, accelerometer, instability driving noises."""
    return np.concatenate(
        [
            [config.gyro_arw_rad_s_rthz**2] * 3,
            [config.acc_vrw_m_s2_rthz**2] * 3,
            [2.0 * config.gyro_bias_instability_rad_s**2 / config.gyro_bias_corr_time_s] * 3,
            [2.0 * config.acc_bias_instability_m_s2**2 / config.acc_bias_corr_time_s] * 3,
        ]
    )


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
    w_b: FloatArray,
    arm_body_m: FloatArray,
    var_pos_m2: FloatArray,
    var_vel_m2_s2: FloatArray | None,
    n: int,
) -> list[ObservationBlock]:
    """Position block and, when ``var_vel_m2_s2`` is given, velocity block of epoch ``j``.

    ``dt_shift_s = t_imu - t_gnss``; ``w_b`` is the corrected gyro sample.
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
    H_p = np.zeros((3, n))
    H_p[:, 0:3] = _skew(arm_n)
    H_p[:, 6:9] = _I3
    blocks = [(H_p, z_p, var_pos_m2)]
    if var_vel_m2_s2 is not None:
        assert gnss.vel_ned_m_s is not None
        w_ie = OMEGA_IE_RAD_S * np.array([math.cos(lat), 0.0, -math.sin(lat)])
        cw = C @ np.cross(w_b, arm_body_m)
        z_v = v + cw - np.cross(w_ie, arm_n) - gnss.vel_ned_m_s[j]
        H_v = np.zeros((3, n))
        H_v[:, 0:3] = _skew(cw) - _skew(w_ie) @ _skew(arm_n) + _skew(v)
        H_v[:, 3:6] = _I3
        H_v[:, _BG] = H_v[:, _MG] = -C @ _skew(arm_body_m)
        if n > 21:
            H_v[:, _SG] = -C @ _skew(arm_body_m) @ np.diag(w_b)
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
    IKH = np.eye(P.shape[0]) - K @ H
    return x, IKH @ P @ IKH.T + K @ R @ K.T


def _feedback(nav: _Nav, x: FloatArray) -> None:
    """Closed-loop correction ``true ≈ nominal ⊖ x`` (in place)."""
    r_m, r_n = radii_m(nav.lat_rad)
    rot = _rotvec_matrix(x[0:3])
    nav.R_body_to_ned = rot @ nav.R_body_to_ned
    nav.vel_ned_m_s = rot @ (nav.vel_ned_m_s - x[3:6])
    nav.lon_rad -= x[7] / ((r_n + nav.h_m) * math.cos(nav.lat_rad))
    nav.lat_rad -= x[6] / (r_m + nav.h_m)
    nav.h_m += x[8]
    nav.gyro_bias_rad_s = nav.gyro_bias_rad_s + x[_BG]
    nav.acc_bias_m_s2 = nav.acc_bias_m_s2 + x[_BA]
    nav.gyro_instability_rad_s = nav.gyro_instability_rad_s + x[_MG]
    nav.acc_instability_m_s2 = nav.acc_instability_m_s2 + x[_MA]
    if x.size > 21:
        nav.gyro_scale = nav.gyro_scale + x[_SG]
        nav.acc_scale = nav.acc_scale + x[_SA]


def _solution_std(P: FloatArray, v: FloatArray) -> FloatArray:
    """The 21 standard deviations of `kinsync.ins._ekf.solution_std` from ``P``."""
    n = P.shape[0]
    T = np.zeros((21, n))  # solution errors as linear functions of the error state
    T[0:3, 0:3] = _I3
    T[3:6, 3:6] = _I3
    T[3:6, 0:3] = _skew(v)  # δv = δv' + [v×] φ
    T[6:9, 6:9] = _I3
    T[9:12, _BG] = T[9:12, _MG] = _I3
    T[12:15, _BA] = T[12:15, _MA] = _I3
    if n > 21:
        T[15:18, _SG] = _I3
        T[18:21, _SA] = _I3
    out: FloatArray = np.sqrt(np.maximum(np.diag(T @ P @ T.T), 0.0))
    if n <= 21:
        out[15:21] = np.nan
    return out


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
    states : ndarray, shape (n_epochs, 28)
        lat, lon (rad), h, v_NED, q_body_to_ned (w, x, y, z), turn-on biases,
        instabilities and scale factors (gyro, accelerometer), after each epoch's
        update (the first 28 columns of the compiled loop's layout).
    std : ndarray, shape (n_epochs, 21)
        1σ of the solution (`kinsync.ins._ekf.solution_std`).
    """
    k0 = start_epoch(imu, init)
    n_end = min(len(imu), k0 + n_epochs)
    init = starting_estimates(config, init)
    nav = _Nav.from_initial(init)
    P = initial_covariance(config, init)
    n = P.shape[0]
    qc = np.diag(_noise_psd(config))
    arm = np.array(config.antenna_lever_arm_body_m)
    gate = float(chdtri(3, 1.0 - config.gate_probability))  # chi-square(3) quantile
    g_epoch = gnss_epochs(imu.t_s, k0, gnss.t_s)
    std_p, std_v = _gnss_std(gnss, config)
    with_vel = use_velocity and gnss.vel_ned_m_s is not None
    states = np.zeros((n_end - k0, 28))
    stds = np.zeros((n_end - k0, 21))
    for k in range(k0, n_end):
        if k > k0:
            dt = imu.t_s[k] - imu.t_s[k - 1]
            w_b, f_b = nav.corrected(imu.gyro_body_rad_s[k], imu.acc_body_m_s2[k])
            F, G = _system_matrix(nav, w_b, f_b, config, n)
            Fd = F * dt
            Phi = np.eye(n) + Fd + 0.5 * Fd @ Fd
            P = Phi @ P @ Phi.T + G @ qc @ G.T * dt
            _strapdown_step(nav, w_b, f_b, dt, first=k == k0 + 1)
            # the expected second-order tilt error: v -= dt E[-1/2 [phi x]^2 g]
            g_vec = np.array([0.0, 0.0, normal_gravity_m_s2(nav.lat_rad, nav.h_m)])
            P_att = P[:3, :3]
            nav.vel_ned_m_s = nav.vel_ned_m_s + 0.5 * dt * (P_att - np.trace(P_att) * _I3) @ g_vec
            nav.gyro_instability_rad_s *= math.exp(-dt / config.gyro_bias_corr_time_s)
            nav.acc_instability_m_s2 *= math.exp(-dt / config.acc_bias_corr_time_s)
        for j in np.flatnonzero(g_epoch == k):
            w_b, _ = nav.corrected(imu.gyro_body_rad_s[k], imu.acc_body_m_s2[k])
            blocks = _gnss_blocks(
                nav, gnss, int(j), imu.t_s[k] - gnss.t_s[j], w_b, arm,
                std_p[j] ** 2, std_v[j] ** 2 if with_vel else None, n,
            )  # fmt: skip
            if not _passes_gate(P, blocks, gate):
                continue
            x, P = _joint_update(P, blocks)
            _feedback(nav, x)
        states[k - k0] = nav.state_row()
        stds[k - k0] = _solution_std(P, nav.vel_ned_m_s)
    return states, stds
