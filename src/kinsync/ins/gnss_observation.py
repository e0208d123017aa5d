"""GNSS observation model of the loosely coupled filter: lever-arm rows and the χ² gate.

Compiled pieces called by the forward loop (`kinsync.ins.filter`) for each GNSS epoch:

- **Observations** (`observation`). ``z = INS - GNSS`` at the antenna:
  position ``p_ant = p + C_b^n l`` with ``H = [[(C l)×], 0, I, 0, ...]``; velocity
  ``v_ant = v + C_b^n (ω_ib × l) - ω_ie × (C_b^n l)``, whose error in the states of
  `kinsync.ins._ekf` (``δv = δv' + [v×] φ``) has
  ``H = [[(C(ω×l))×] - [ω_ie×][(C l)×] + [v×], I, 0, -C_b^n [l×] (δb_g, δm_g), ...,
  -C_b^n [l×] diag(ω) (δs_g)]`` (Groves 2013, ch. 14, written for the misorientation
  ``C(nominal) = (I - [φ×]) C(true)``). ``ω`` is the sample corrected with the sensor
  estimates. The GNSS position is moved to the IMU epoch with the INS velocity
  (``p + v (t_imu - t_gnss)``).
- **χ² statistic** (`gate_stat`). ``ν^T S^{-1} ν`` of a 3-row block (position or
  velocity) with the predicted ``S = H P H^T + R``; the filter compares it with
  ``χ²₃(gate_probability)``.

`gnss_epochs` assigns each GNSS epoch to its nearest IMU epoch (Python, once per run).

The error state and its order are those of `kinsync.ins._ekf`.

References
----------
P. D. Groves, *Principles of GNSS, Inertial, and Multisensor Integrated Navigation
Systems*, 2nd ed., Artech House, 2013, ch. 14 (loosely coupled integration, lever arm)
and ch. 17 (innovation-based outlier detection).
"""

from __future__ import annotations

import math

import numpy as np

from kinsync._jit import cached_njit
from kinsync._typing import FloatArray, IntArray
from kinsync.ins._ekf import N_ERR_SCALE, P_ARM, X_BG, X_MG, X_SG
from kinsync.ins.earth import A_M, E2, OMEGA_IE_RAD_S
from kinsync.ins.strapdown import I_BG, I_H, I_LAT, I_LON, I_MG, I_Q, I_SG, I_VEL, quat_to_dcm

__all__ = ["MAX_ROWS", "gate_stat", "gnss_epochs", "observation"]

MAX_ROWS = 6
"""Observation rows per GNSS epoch: position (N, E, D) then velocity (N, E, D)."""

_jit = cached_njit()


def _skew_into(
    v0: float, v1: float, v2: float, M: FloatArray, r: int, c: int, sign: float
) -> None:  # pragma: no cover
    """Add ``sign · [v×]`` into the 3x3 block of ``M`` at (r, c)."""
    M[r, c + 1] += -sign * v2
    M[r, c + 2] += sign * v1
    M[r + 1, c] += sign * v2
    M[r + 1, c + 2] += -sign * v0
    M[r + 2, c] += -sign * v1
    M[r + 2, c + 1] += sign * v0


skew_into = _jit(_skew_into)


def _observation(  # noqa: PLR0915 - one flat function is what numba compiles best
    s: FloatArray,
    gyro: FloatArray,
    params: FloatArray,
    dt_shift: float,
    g_llh: FloatArray,
    g_vel: FloatArray,
    C: FloatArray,
    H: FloatArray,
    z: FloatArray,
) -> None:  # pragma: no cover - compiled by numba
    """Rows of ``H`` (6, n) and ``z`` (6,) (INS minus GNSS at the antenna).

    ``dt_shift = t_imu - t_gnss``; rows 3..5 are filled only when ``g_vel`` is finite.
    """
    lat = s[I_LAT]
    h = s[I_H]
    sl = math.sin(lat)
    cl = math.cos(lat)
    den = 1.0 - E2 * sl * sl
    r_n = A_M / math.sqrt(den)
    r_m = A_M * (1.0 - E2) / (den * math.sqrt(den))
    quat_to_dcm(s[I_Q : I_Q + 4], C)
    l0, l1, l2 = params[P_ARM], params[P_ARM + 1], params[P_ARM + 2]
    ln0 = C[0, 0] * l0 + C[0, 1] * l1 + C[0, 2] * l2
    ln1 = C[1, 0] * l0 + C[1, 1] * l1 + C[1, 2] * l2
    ln2 = C[2, 0] * l0 + C[2, 1] * l1 + C[2, 2] * l2
    vn, ve, vd = s[I_VEL], s[I_VEL + 1], s[I_VEL + 2]
    dlon = s[I_LON] - g_llh[1]
    dlon = (dlon + math.pi) % (2.0 * math.pi) - math.pi
    z[0] = (lat - g_llh[0]) * (r_m + h) + ln0 - vn * dt_shift
    z[1] = dlon * (r_n + h) * cl + ln1 - ve * dt_shift
    z[2] = -(h - g_llh[2]) + ln2 - vd * dt_shift
    n = H.shape[1]
    for i in range(MAX_ROWS):
        for j in range(n):
            H[i, j] = 0.0
    skew_into(ln0, ln1, ln2, H, 0, 0, 1.0)
    for i in range(3):
        H[i, 6 + i] = 1.0
    if not math.isfinite(g_vel[0]):
        return
    # Velocity at the antenna: v + C (ω × l) - ω_ie × (C l).
    w0 = (gyro[0] - s[I_BG] - s[I_MG]) / (1.0 + s[I_SG])
    w1 = (gyro[1] - s[I_BG + 1] - s[I_MG + 1]) / (1.0 + s[I_SG + 1])
    w2 = (gyro[2] - s[I_BG + 2] - s[I_MG + 2]) / (1.0 + s[I_SG + 2])
    wl0 = w1 * l2 - w2 * l1
    wl1 = w2 * l0 - w0 * l2
    wl2 = w0 * l1 - w1 * l0
    cw0 = C[0, 0] * wl0 + C[0, 1] * wl1 + C[0, 2] * wl2
    cw1 = C[1, 0] * wl0 + C[1, 1] * wl1 + C[1, 2] * wl2
    cw2 = C[2, 0] * wl0 + C[2, 1] * wl1 + C[2, 2] * wl2
    e0 = OMEGA_IE_RAD_S * cl
    e2 = -OMEGA_IE_RAD_S * sl
    # ω_ie × (C l) with ω_ie = (e0, 0, e2)
    x0 = -e2 * ln1
    x1 = e2 * ln0 - e0 * ln2
    x2 = e0 * ln1
    z[3] = vn + cw0 - x0 - g_vel[0]
    z[4] = ve + cw1 - x1 - g_vel[1]
    z[5] = vd + cw2 - x2 - g_vel[2]
    skew_into(cw0, cw1, cw2, H, 3, 0, 1.0)
    # - [ω_ie×][(C l)×]
    Wx = np.zeros((3, 3))
    Lx = np.zeros((3, 3))
    skew_into(e0, 0.0, e2, Wx, 0, 0, 1.0)
    skew_into(ln0, ln1, ln2, Lx, 0, 0, 1.0)
    for i in range(3):
        for j in range(3):
            acc = 0.0
            for m in range(3):
                acc += Wx[i, m] * Lx[m, j]
            H[3 + i, j] -= acc
        H[3 + i, 3 + i] = 1.0
    # δv = δv' + [v×] φ
    skew_into(vn, ve, vd, H, 3, 0, 1.0)
    # -C [l×] for the gyro bias states, times diag(ω) for the scale factors
    w = (w0, w1, w2)
    for i in range(3):
        cl0 = -(C[i, 1] * l2 - C[i, 2] * l1)
        cl1 = -(-C[i, 0] * l2 + C[i, 2] * l0)
        cl2 = -(C[i, 0] * l1 - C[i, 1] * l0)
        for base in (X_BG, X_MG):
            H[3 + i, base] = cl0
            H[3 + i, base + 1] = cl1
            H[3 + i, base + 2] = cl2
        if n >= N_ERR_SCALE:
            H[3 + i, X_SG] = cl0 * w[0]
            H[3 + i, X_SG + 1] = cl1 * w[1]
            H[3 + i, X_SG + 2] = cl2 * w[2]


observation = _jit(_observation)


def _gate_stat(
    P: FloatArray, H: FloatArray, r0: int, r: FloatArray, z: FloatArray, sd: FloatArray
) -> float:  # pragma: no cover
    """``z^T S^{-1} z`` for rows ``r0..r0+2`` with ``S = H P H^T + diag(r)``.

    ``sd`` receives ``sqrt(diag S)``; a non-positive-definite ``S`` gives infinity.
    """
    n = P.shape[0]
    S = np.empty((3, 3))
    HP = np.empty((3, n))
    for i in range(3):
        for j in range(n):
            acc = 0.0
            for m in range(n):
                acc += H[r0 + i, m] * P[m, j]
            HP[i, j] = acc
    for i in range(3):
        for j in range(3):
            acc = 0.0
            for m in range(n):
                acc += HP[i, m] * H[r0 + j, m]
            S[i, j] = acc
        S[i, i] += r[r0 + i]
        sd[i] = math.sqrt(S[i, i])
    # z^T S^{-1} z through the adjugate (S symmetric 3x3); not positive: never accepted.
    c00 = S[1, 1] * S[2, 2] - S[1, 2] * S[2, 1]
    c01 = S[0, 2] * S[2, 1] - S[0, 1] * S[2, 2]
    c02 = S[0, 1] * S[1, 2] - S[0, 2] * S[1, 1]
    c11 = S[0, 0] * S[2, 2] - S[0, 2] * S[2, 0]
    c12 = S[0, 2] * S[1, 0] - S[0, 0] * S[1, 2]
    c22 = S[0, 0] * S[1, 1] - S[0, 1] * S[1, 0]
    det = (
        S[0, 0] * c00
        + S[0, 1] * (S[1, 2] * S[2, 0] - S[1, 0] * S[2, 2])
        + S[0, 2] * (S[1, 0] * S[2, 1] - S[1, 1] * S[2, 0])
    )
    if not (det > 0.0 and math.isfinite(det)):
        return math.inf
    a, b, c = z[r0], z[r0 + 1], z[r0 + 2]
    q = a * (c00 * a + c01 * b + c02 * c) + b * (c01 * a + c11 * b + c12 * c)
    q += c * (c02 * a + c12 * b + c22 * c)
    return float(q / det)


gate_stat = _jit(_gate_stat)


def gnss_epochs(imu_t_s: FloatArray, k0: int, gnss_t_s: FloatArray) -> IntArray:
    """Nearest IMU epoch of each GNSS epoch, -1 outside ``[t[k0] - dt/2, t[-1] + dt/2]``."""
    t = imu_t_s
    idx = np.clip(np.searchsorted(t, gnss_t_s), 1, t.size - 1)
    left = t[idx - 1]
    right = t[idx]
    nearest = np.where(gnss_t_s - left <= right - gnss_t_s, idx - 1, idx)
    lo = t[k0] - 0.5 * (t[k0 + 1] - t[k0])
    hi = t[-1] + 0.5 * (t[-1] - t[-2])
    inside = (gnss_t_s >= lo) & (gnss_t_s <= hi) & (nearest >= k0)
    out: IntArray = np.where(inside, np.maximum(nearest, k0), -1).astype(np.int64)
    return out
