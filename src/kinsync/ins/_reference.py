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


def _skew(v: FloatArray) -> FloatArray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _rotvec_matrix(v: FloatArray) -> FloatArray:
    out: FloatArray = Rotation.from_rotvec(v).as_matrix()
    return out


def forward_numpy(  # noqa: PLR0915 - a deliberately plain transcription
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
    lat = math.radians(init.lat_deg)
    lon = math.radians(init.lon_deg)
    h = float(init.h_m)
    v = np.array(init.vel_ned_m_s, dtype=np.float64)
    C = euler_rpy_to_matrix(*init.rpy_rad)
    bg = np.array(init.gyro_bias_rad_s, dtype=np.float64)
    ba = np.array(init.acc_bias_m_s2, dtype=np.float64)
    P = initial_covariance(config)
    tau_g, tau_a = config.gyro_bias_corr_time_s, config.acc_bias_corr_time_s
    qc = np.concatenate(
        [
            [config.gyro_arw_rad_s_rthz**2] * 3,
            [config.acc_vrw_m_s2_rthz**2] * 3,
            [0.0] * 3,
            [2.0 * config.gyro_bias_instability_rad_s**2 / tau_g] * 3,
            [2.0 * config.acc_bias_instability_m_s2**2 / tau_a] * 3,
        ]
    )
    arm = np.array(config.antenna_lever_arm_body_m)
    gate = float(chi2.ppf(config.gate_probability, 3))
    g_epoch = gnss_epochs(imu.t_s, k0, gnss.t_s)
    std_p = np.where(
        np.isnan(gnss.std_pos_ned_m), np.array(config.gnss_std_pos_ned_m), gnss.std_pos_ned_m
    )
    std_v = np.tile(np.array(config.gnss_std_vel_ned_m_s), (len(gnss), 1))
    if gnss.std_vel_ned_m_s is not None:
        std_v = np.where(np.isnan(gnss.std_vel_ned_m_s), std_v, gnss.std_vel_ned_m_s)
    with_vel = use_velocity and gnss.vel_ned_m_s is not None
    prev_dth = np.zeros(3)
    prev_dv = np.zeros(3)
    states = np.zeros((n_end - k0, 16))
    stds = np.zeros((n_end - k0, 15))
    I3 = np.eye(3)
    for k in range(k0, n_end):
        if k > k0:
            dt = imu.t_s[k] - imu.t_s[k - 1]
            f_b = imu.acc_body_m_s2[k] - ba
            w_b = imu.gyro_body_rad_s[k] - bg
            # ---- error model at the start of the interval
            r_m, r_n = radii_m(lat)
            rmh, rnh = r_m + h, r_n + h
            sl, cl, tl = math.sin(lat), math.cos(lat), math.tan(lat)
            w_ie = OMEGA_IE_RAD_S * np.array([cl, 0.0, -sl])
            w_en = np.array([v[1] / rnh, -v[0] / rmh, -v[1] * tl / rnh])
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
            F[6:9, 3:6] = I3
            F[6, 6], F[6, 8] = -v[2] / rmh, v[0] / rmh
            F[7, 6], F[7, 7], F[7, 8] = v[1] * tl / rmh, -(v[2] / rnh + v[0] * tl / rmh), v[1] / rnh
            F[9:12, 9:12] = -I3 / tau_g
            F[12:15, 12:15] = -I3 / tau_a
            Fd = F * dt
            Phi = np.eye(15) + Fd + 0.5 * Fd @ Fd
            P = Phi @ P @ Phi.T + np.diag(qc * dt)
            # ---- strapdown step
            dth = w_b * dt
            dv = f_b * dt
            if k == k0 + 1:
                prev_dth, prev_dv = dth, dv
            phi = dth + np.cross(prev_dth, dth) / 12.0
            dv_b = (
                dv
                + 0.5 * np.cross(dth, dv)
                + (np.cross(prev_dth, dv) + np.cross(prev_dv, dth)) / 12.0
            )
            prev_dth, prev_dv = dth, dv
            zeta = (w_ie + w_en) * dt
            g_vec = np.array([0.0, 0.0, normal_gravity_m_s2(lat, h)])
            v_new = (
                v
                + (I3 - 0.5 * _skew(zeta)) @ (C @ dv_b)
                + (g_vec - np.cross(2.0 * w_ie + w_en, v)) * dt
            )
            h_new = h - 0.5 * (v[2] + v_new[2]) * dt
            h_mid = 0.5 * (h + h_new)
            lat_new = lat + 0.5 * (v[0] + v_new[0]) * dt / (r_m + h_mid)
            lon += 0.5 * (v[1] + v_new[1]) * dt / ((r_n + h_mid) * math.cos(0.5 * (lat + lat_new)))
            lat, h, v = lat_new, h_new, v_new
            C = _rotvec_matrix(-zeta) @ C @ _rotvec_matrix(phi)
        # ---- GNSS update(s) at this epoch
        for j in np.flatnonzero(g_epoch == k):
            r_m, r_n = radii_m(lat)
            arm_n = C @ arm
            shift = imu.t_s[k] - gnss.t_s[j]
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
                - v * shift
            )
            H_p = np.zeros((3, 15))
            H_p[:, 0:3] = _skew(arm_n)
            H_p[:, 6:9] = I3
            rows = [(H_p, z_p, std_p[j] ** 2)]
            if with_vel:
                assert gnss.vel_ned_m_s is not None
                w_ie = OMEGA_IE_RAD_S * np.array([math.cos(lat), 0.0, -math.sin(lat)])
                cw = C @ np.cross(imu.gyro_body_rad_s[k] - bg, arm)
                z_v = v + cw - np.cross(w_ie, arm_n) - gnss.vel_ned_m_s[j]
                H_v = np.zeros((3, 15))
                H_v[:, 0:3] = _skew(cw) - _skew(w_ie) @ _skew(arm_n)
                H_v[:, 3:6] = I3
                H_v[:, 9:12] = -C @ _skew(arm)
                rows.append((H_v, z_v, std_v[j] ** 2))
            ok = all(
                float(z @ np.linalg.solve(Hb @ P @ Hb.T + np.diag(r), z)) <= gate
                for Hb, z, r in rows
            )
            if not ok:
                continue
            H = np.vstack([r[0] for r in rows])
            z = np.concatenate([r[1] for r in rows])
            R = np.diag(np.concatenate([r[2] for r in rows]))
            S = H @ P @ H.T + R
            K = P @ H.T @ np.linalg.inv(S)
            x = K @ z
            IKH = np.eye(15) - K @ H
            P = IKH @ P @ IKH.T + K @ R @ K.T
            # ---- closed-loop feedback
            r_m, r_n = radii_m(lat)
            C = _rotvec_matrix(x[0:3]) @ C
            v = v - x[3:6]
            lon -= x[7] / ((r_n + h) * math.cos(lat))
            lat -= x[6] / (r_m + h)
            h += x[8]
            bg = bg + x[9:12]
            ba = ba + x[12:15]
        q = Rotation.from_matrix(C).as_quat()
        states[k - k0] = [lat, lon, h, *v, q[3], q[0], q[1], q[2], *bg, *ba]
        stds[k - k0] = np.sqrt(np.diag(P))
    return states, stds
