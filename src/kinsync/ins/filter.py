"""Loosely coupled INS/GNSS: 15-state error-state Kalman filter (SPEC section 6).

The error state, its dynamics ``F``, the transition matrix ``Φ = I + FΔt + F²Δt²/2``
and the closed-loop feedback are described in `kinsync.ins._ekf`: misorientation
(rad, NED), velocity error (m/s, NED), position error in metres North/East/Down, gyro
drift (rad/s) and accelerometer bias (m/s^2) as first-order Gauss–Markov processes.

Forward pass, one compiled loop over the IMU epochs (run in chunks of
`CHUNK_EPOCHS` so that Python can report progress): for each epoch, ``Φ`` and ``Q``
from the state at the start of the interval, ``P ← Φ P Φ^T + Q``, one strapdown step
(`kinsync.ins.strapdown`), then every GNSS epoch assigned to this IMU epoch:

- **Timing.** A GNSS epoch is processed at the nearest IMU epoch ``t_k``; its
  position is moved to ``t_k`` with the INS velocity (``p + v (t_k - t_gnss)``, at most
  half an IMU interval). GNSS epochs more than half an interval outside the IMU span
  from the initial epoch on are ignored (`GnssStatus.OUTSIDE`).
- **Observations.** ``z = INS - GNSS`` at the antenna:
  position ``p_ant = p + C_b^n l`` with ``H = [[(C l)×], 0, I, 0, 0]``; velocity
  ``v_ant = v + C_b^n (ω_ib × l) - ω_ie × (C_b^n l)`` with
  ``H = [[(C(ω×l))×] - [ω_ie×][(C l)×], I, 0, -C_b^n [l×], 0]`` (Groves 2013,
  ch. 14, written for the misorientation ``C(nominal) = (I - [φ×]) C(true)``).
  Standard deviations given as NaN take the configured defaults.
- **χ² gate.** Position and velocity innovations are each tested against
  ``ν^T S^{-1} ν <= χ²₃(gate_probability)`` with the predicted ``S = H P H^T + R``; if
  either fails the epoch is rejected as a whole (a receiver that produced one bad
  block is not trusted for the other).
- **Update and feedback.** Accepted rows are applied as sequential scalar updates
  (exact for the diagonal ``R``), the error state is fed back into the mechanisation
  (closed loop) and reset to zero.

When smoothing is requested, the forward pass also stores a compact *checkpoint* per
GNSS update (the prior and posterior covariance, the accepted rows of ``H``, their
variances and ``z``) and one every `CHECKPOINT_EVERY` epochs; `kinsync.ins.smoother`
recomputes ``Φ`` and the covariances between checkpoints from the stored nominal
states, so the memory is O(n · 31 + m · 600) floats instead of three 15×15 matrices
per epoch.

References
----------
P. D. Groves, *Principles of GNSS, Inertial, and Multisensor Integrated Navigation
Systems*, 2nd ed., Artech House, 2013, ch. 14 (loosely coupled integration, lever arm)
and ch. 17 (innovation-based outlier detection). P. S. Maybeck, *Stochastic Models,
Estimation, and Control*, vol. 1, Academic Press 1979, ch. 6.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import IntEnum
from typing import Any, cast

import numpy as np
from numba import njit
from scipy.stats import chi2

from kinsync._typing import FloatArray, IntArray
from kinsync.errors import InputError, ObservabilityError
from kinsync.frames import euler_rpy_to_matrix
from kinsync.ins._ekf import (
    N_ERR,
    N_PARAMS,
    P_ARM,
    P_GATE,
    P_QC_ATT,
    P_QC_BA,
    P_QC_BG,
    P_QC_VEL,
    P_TAU_A,
    P_TAU_G,
    P_USE_VEL,
    feedback,
    propagate_cov,
    scalar_update,
    step_matrices,
)
from kinsync.ins.config import InsConfig
from kinsync.ins.earth import A_M, E2, OMEGA_IE_RAD_S, normal_gravity_m_s2, radii_m
from kinsync.ins.measurements import GnssData, ImuData
from kinsync.ins.solution import InitialState, NavSolution
from kinsync.ins.strapdown import (
    I_BG,
    I_H,
    I_LAT,
    I_LON,
    I_Q,
    I_VEL,
    N_PREV,
    N_STATE,
    check_imu_gaps,
    initial_state_vector,
    mech_step,
    nav_solution_from_states,
    quat_to_dcm,
    start_epoch,
)

__all__ = [
    "CHECKPOINT_EVERY",
    "CHUNK_EPOCHS",
    "GnssStatus",
    "InsResult",
    "align_static_gnss_heading",
    "run_ins",
    "transition_matrix",
]

CHUNK_EPOCHS = 10_000
"""IMU epochs per call of the compiled loop (progress is reported between calls)."""
CHECKPOINT_EVERY = 2_000
"""Longest run of IMU epochs between two smoother checkpoints."""
MAX_ROWS = 6  # observation rows per GNSS epoch (position 3 + velocity 3)
MAX_ABS_HEIGHT_M = 1.0e6
"""A mechanised height beyond ±1000 km means the solution diverged."""

_jit = cast(Callable[[Callable[..., Any]], Callable[..., Any]], njit(cache=True))


class GnssStatus(IntEnum):
    """What the filter did with a GNSS epoch."""

    OUTSIDE = 0
    """Outside the IMU span (from the initial epoch on): ignored."""
    USED = 1
    """Passed the χ² gate and updated the filter."""
    REJECTED = 2
    """Failed the χ² gate (position or velocity)."""


@dataclass(frozen=True, eq=False)
class InsResult:
    """Forward (and optionally smoothed) INS/GNSS solution.

    Attributes
    ----------
    forward : NavSolution
        Forward-filter solution at the IMU epochs from the initial epoch on.
    smoothed : NavSolution or None
        RTS-smoothed solution on the same epochs, when requested.
    innovations_pos_ned_m : ndarray, shape (m_in, 3)
        GNSS minus predicted antenna position (N, E, D, m) before the update, one row
        per GNSS epoch inside the IMU span; NaN rows for epochs rejected by the gate.
    gnss_rejected_t_s : ndarray, shape (r,)
        Times of the GNSS epochs rejected by the χ² gate (s).
    innovations_t_s : ndarray, shape (m_in,)
        GNSS times of the innovation rows (s).
    innovations_vel_ned_m_s : ndarray, shape (m_in, 3)
        GNSS minus predicted antenna velocity (m/s); NaN where velocities were not
        used or the epoch was rejected.
    innovation_std_pos_ned_m : ndarray, shape (m_in, 3)
        Predicted standard deviation ``sqrt(diag S)`` of each position innovation (m);
        NaN for rejected epochs.
    gnss_status : ndarray of int, shape (m,)
        `GnssStatus` of every GNSS epoch of the input.
    """

    forward: NavSolution
    smoothed: NavSolution | None
    innovations_pos_ned_m: FloatArray
    gnss_rejected_t_s: FloatArray
    innovations_t_s: FloatArray = field(default_factory=lambda: np.empty(0))
    innovations_vel_ned_m_s: FloatArray = field(default_factory=lambda: np.empty((0, 3)))
    innovation_std_pos_ned_m: FloatArray = field(default_factory=lambda: np.empty((0, 3)))
    gnss_status: IntArray = field(default_factory=lambda: np.empty(0, dtype=np.int64))


def transition_matrix(F: FloatArray, dt_s: float) -> FloatArray:
    """Second-order transition matrix ``Φ = I + FΔt + F²Δt²/2``.

    Parameters
    ----------
    F : ndarray, shape (n, n)
        Continuous-time system matrix (1/s).
    dt_s : float
        Interval (s).

    Returns
    -------
    ndarray, shape (n, n)
        ``Φ``; the truncation error against ``expm(FΔt)`` is ``O(‖F‖³Δt³)/6``.

    Raises
    ------
    InputError
        ``F`` is not a finite square matrix or ``dt_s`` is not finite.
    """
    Fm = np.asarray(F, dtype=np.float64)
    if Fm.ndim != 2 or Fm.shape[0] != Fm.shape[1] or not np.isfinite(Fm).all():
        msg = f"transition_matrix: F must be a finite square matrix, got shape {Fm.shape}"
        raise InputError(msg)
    if not math.isfinite(dt_s):
        msg = f"transition_matrix: dt_s must be finite, got {dt_s!r}"
        raise InputError(msg)
    Fd = Fm * dt_s
    out: FloatArray = np.eye(Fm.shape[0]) + Fd + 0.5 * (Fd @ Fd)
    return out


# ---------------------------------------------------------------------- compiled loop
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
    """Rows of ``H`` (6, 15) and ``z`` (6,) (INS minus GNSS at the antenna).

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
    for i in range(MAX_ROWS):
        for j in range(N_ERR):
            H[i, j] = 0.0
    skew_into(ln0, ln1, ln2, H, 0, 0, 1.0)
    for i in range(3):
        H[i, 6 + i] = 1.0
    if not math.isfinite(g_vel[0]):
        return
    # Velocity at the antenna: v + C (ω × l) - ω_ie × (C l).
    w0 = gyro[0] - s[I_BG]
    w1 = gyro[1] - s[I_BG + 1]
    w2 = gyro[2] - s[I_BG + 2]
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
    # -C [l×]
    for i in range(3):
        H[3 + i, 9 + 0] = -(C[i, 1] * l2 - C[i, 2] * l1)
        H[3 + i, 9 + 1] = -(-C[i, 0] * l2 + C[i, 2] * l0)
        H[3 + i, 9 + 2] = -(C[i, 0] * l1 - C[i, 1] * l0)


observation = _jit(_observation)


def _gate_stat(
    P: FloatArray, H: FloatArray, r0: int, r: FloatArray, z: FloatArray, sd: FloatArray
) -> float:  # pragma: no cover
    """``z^T S^{-1} z`` for rows ``r0..r0+2`` with ``S = H P H^T + diag(r)``.

    ``sd`` receives ``sqrt(diag S)``; a non-positive-definite ``S`` gives infinity.
    """
    S = np.empty((3, 3))
    HP = np.empty((3, N_ERR))
    for i in range(3):
        for j in range(N_ERR):
            acc = 0.0
            for m in range(N_ERR):
                acc += H[r0 + i, m] * P[m, j]
            HP[i, j] = acc
    for i in range(3):
        for j in range(3):
            acc = 0.0
            for m in range(N_ERR):
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


def _forward_loop(  # noqa: PLR0912, PLR0915 - one flat loop is what numba compiles best
    k_begin: int,
    k_end: int,
    k0: int,
    t: FloatArray,
    gyro: FloatArray,
    acc: FloatArray,
    g_t: FloatArray,
    g_epoch: IntArray,
    g_llh: FloatArray,
    g_vel: FloatArray,
    g_var: FloatArray,
    params: FloatArray,
    state: FloatArray,
    prev: FloatArray,
    P: FloatArray,
    ctr: IntArray,
    out_state: FloatArray,
    out_std: FloatArray,
    g_status: IntArray,
    innov: FloatArray,
    innov_sd: FloatArray,
    store: bool,
    ck_every: int,
    ck_epoch: IntArray,
    ck_Pm: FloatArray,
    ck_Pp: FloatArray,
    ck_H: FloatArray,
    ck_r: FloatArray,
    ck_z: FloatArray,
    ck_nrows: IntArray,
) -> int:  # pragma: no cover - compiled by numba; tested through run_ins
    """Forward filter over epochs ``k_begin .. k_end-1`` (see the module docstring).

    ``ctr`` = [next GNSS index, number of checkpoints, epoch of the last checkpoint].
    Returns -1, or the first epoch whose state or covariance is not finite, whose
    latitude passes a pole or whose height leaves ±`MAX_ABS_HEIGHT_M` (the loop stops).
    """
    m = g_t.shape[0]
    qa = np.empty(4)
    qb = np.empty(4)
    C = np.empty((3, 3))
    F = np.zeros((N_ERR, N_ERR))
    Phi = np.zeros((N_ERR, N_ERR))
    q = np.empty(N_ERR)
    T = np.empty((9, N_ERR))
    f_b = np.empty(3)
    H = np.zeros((MAX_ROWS, N_ERR))
    z = np.empty(MAX_ROWS)
    r = np.empty(MAX_ROWS)
    x = np.zeros(N_ERR)
    ph = np.empty(N_ERR)
    hrow = np.empty(N_ERR)
    sd_p = np.empty(3)
    sd_v = np.empty(3)
    nan3 = np.full(3, np.nan)
    coning = True
    use_vel = params[P_USE_VEL] > 0.5
    gate = params[P_GATE]
    for k in range(k_begin, k_end):
        if k > k0:
            dt = t[k] - t[k - 1]
            step_matrices(state, acc[k], dt, params, f_b, C, F, Phi, q)
            propagate_cov(P, Phi, q, T)
            mech_step(state, prev, gyro[k], acc[k], dt, k == k0 + 1, coning, qa, qb, C)
            ok_k = True
            for i in range(N_STATE):
                ok_k = ok_k and math.isfinite(state[i])
            for i in range(N_ERR):
                ok_k = ok_k and math.isfinite(P[i, i])
            ok_k = ok_k and abs(state[I_LAT]) < 1.5707 and abs(state[I_H]) < MAX_ABS_HEIGHT_M
            if not ok_k:
                return k
        elif store:
            c = ctr[1]
            ck_epoch[c] = k
            ck_Pm[c] = P
            ck_Pp[c] = P
            ck_nrows[c] = 0
            ctr[1] = c + 1
            ctr[2] = k
        while ctr[0] < m and g_epoch[ctr[0]] <= k:
            j = ctr[0]
            ctr[0] = j + 1
            if g_epoch[j] < k:
                continue
            with_vel = use_vel and math.isfinite(g_vel[j, 0])
            observation(
                state, gyro[k], params, t[k] - g_t[j], g_llh[j], g_vel[j] if with_vel else nan3,
                C, H, z,
            )  # fmt: skip
            for i in range(MAX_ROWS):
                r[i] = g_var[j, i]
            d2p = gate_stat(P, H, 0, r, z, sd_p)
            ok = d2p <= gate
            if with_vel:
                d2v = gate_stat(P, H, 3, r, z, sd_v)
                ok = ok and d2v <= gate
            if not ok:
                g_status[j] = 2
                continue
            g_status[j] = 1
            nrows = 6 if with_vel else 3
            for i in range(3):
                innov[j, i] = -z[i]
                innov_sd[j, i] = sd_p[i]
                if with_vel:
                    innov[j, 3 + i] = -z[3 + i]
            if store:
                c = ctr[1]
                ck_epoch[c] = k
                ck_Pm[c] = P
            for i in range(N_ERR):
                x[i] = 0.0
            for i in range(nrows):
                for jj in range(N_ERR):
                    hrow[jj] = H[i, jj]
                scalar_update(P, x, hrow, r[i], z[i], ph)
            feedback(state, x, qa, qb)
            if store:
                c = ctr[1]
                ck_Pp[c] = P
                ck_H[c] = H
                ck_r[c] = r
                ck_z[c] = z
                ck_nrows[c] = nrows
                ctr[1] = c + 1
                ctr[2] = k
        if store and k - ctr[2] >= ck_every:
            c = ctr[1]
            ck_epoch[c] = k
            ck_Pm[c] = P
            ck_Pp[c] = P
            ck_nrows[c] = 0
            ctr[1] = c + 1
            ctr[2] = k
        out_state[k] = state
        for i in range(N_ERR):
            out_std[k, i] = math.sqrt(max(P[i, i], 0.0))
    return -1


_forward_kernel = cast(Callable[..., int], _jit(_forward_loop))


# ---------------------------------------------------------------------- Python side
@dataclass(frozen=True, eq=False)
class Checkpoints:
    """What the smoother needs from the forward pass (see the module docstring).

    Attributes
    ----------
    epoch : ndarray of int, shape (c,)
        IMU epoch of each checkpoint (non-decreasing; the first is the initial epoch).
    P_minus, P_plus : ndarray, shape (c, 15, 15)
        Error covariance before and after the checkpoint's update.
    H : ndarray, shape (c, 6, 15)
        Observation rows (the first ``nrows`` are used).
    r : ndarray, shape (c, 6)
        Their noise variances.
    z : ndarray, shape (c, 6)
        Their values (INS minus GNSS; the innovation, as the prior error is zero).
    nrows : ndarray of int, shape (c,)
        Rows used (0: no update, a plain checkpoint).
    """

    epoch: IntArray
    P_minus: FloatArray
    P_plus: FloatArray
    H: FloatArray
    r: FloatArray
    z: FloatArray
    nrows: IntArray


def filter_params(config: InsConfig, *, use_velocity: bool) -> FloatArray:
    """Parameter vector of the compiled loop for ``config``."""
    p = np.zeros(N_PARAMS)
    p[P_TAU_G] = config.gyro_bias_corr_time_s
    p[P_TAU_A] = config.acc_bias_corr_time_s
    p[P_QC_ATT] = config.gyro_arw_rad_s_rthz**2
    p[P_QC_VEL] = config.acc_vrw_m_s2_rthz**2
    p[P_QC_BG] = 2.0 * config.gyro_bias_instability_rad_s**2 / config.gyro_bias_corr_time_s
    p[P_QC_BA] = 2.0 * config.acc_bias_instability_m_s2**2 / config.acc_bias_corr_time_s
    p[P_ARM : P_ARM + 3] = config.antenna_lever_arm_body_m
    p[P_GATE] = float(chi2.ppf(config.gate_probability, 3))
    p[P_USE_VEL] = 1.0 if use_velocity else 0.0
    return p


def initial_covariance(config: InsConfig) -> FloatArray:
    """Diagonal initial error covariance (15, 15) from the configured σ."""
    sig = np.concatenate(
        [
            config.init_std_att_rad,
            config.init_std_vel_ned_m_s,
            config.init_std_pos_ned_m,
            [config.gyro_bias_sigma_rad_s] * 3,
            [config.acc_bias_sigma_m_s2] * 3,
        ]
    )
    return np.diag(sig**2)


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


def _gnss_arrays(
    gnss: GnssData, config: InsConfig, *, use_velocity: bool
) -> tuple[FloatArray, FloatArray, FloatArray]:
    m = len(gnss)
    llh = np.column_stack([np.radians(gnss.lat_deg), np.radians(gnss.lon_deg), gnss.h_m])
    var = np.empty((m, MAX_ROWS))
    std_p = np.where(
        np.isnan(gnss.std_pos_ned_m), np.asarray(config.gnss_std_pos_ned_m), gnss.std_pos_ned_m
    )
    var[:, :3] = std_p**2
    vel = np.full((m, 3), np.nan)
    var[:, 3:] = np.asarray(config.gnss_std_vel_ned_m_s) ** 2
    if use_velocity and gnss.vel_ned_m_s is not None:
        vel[:] = gnss.vel_ned_m_s
        if gnss.std_vel_ned_m_s is not None:
            sv = gnss.std_vel_ned_m_s
            var[:, 3:] = np.where(np.isnan(sv), np.asarray(config.gnss_std_vel_ned_m_s), sv) ** 2
    return llh, vel, var


@dataclass(frozen=True, eq=False)
class ForwardRun:
    """Raw output of the forward pass (internal; the smoother reads it).

    Attributes
    ----------
    k0 : int
        Initial IMU epoch; arrays below are indexed by absolute IMU epoch.
    states : ndarray, shape (n, 16)
        Nominal states after feedback (rows before ``k0`` unused).
    std : ndarray, shape (n, 15)
        1σ of the error state.
    params : ndarray
        Parameter vector of the loop.
    checkpoints : Checkpoints or None
    """

    k0: int
    states: FloatArray
    std: FloatArray
    params: FloatArray
    checkpoints: Checkpoints | None


def forward_pass(
    imu: ImuData,
    gnss: GnssData,
    config: InsConfig,
    init: InitialState,
    *,
    use_velocity: bool,
    store: bool,
    progress: Callable[[float], None] | None,
    g_epoch: IntArray,
    g_status: IntArray,
    innov: FloatArray,
    innov_sd: FloatArray,
) -> ForwardRun:
    """Run the compiled forward loop in chunks; fills the GNSS bookkeeping arrays."""
    k0 = start_epoch(imu, init)
    n = len(imu)
    params = filter_params(config, use_velocity=use_velocity)
    llh, vel, var = _gnss_arrays(gnss, config, use_velocity=use_velocity)
    state = initial_state_vector(init)
    P = initial_covariance(config)
    prev = np.zeros(N_PREV)
    ctr = np.zeros(3, dtype=np.int64)
    out_state = np.zeros((n, N_STATE))
    out_std = np.zeros((n, N_ERR))
    n_in = int(np.count_nonzero(g_epoch >= 0))
    n_ck = (n_in + (n - k0) // CHECKPOINT_EVERY + 2) if store else 1
    ck_epoch = np.zeros(n_ck, dtype=np.int64)
    ck_Pm = np.zeros((n_ck, N_ERR, N_ERR))
    ck_Pp = np.zeros((n_ck, N_ERR, N_ERR))
    ck_H = np.zeros((n_ck, MAX_ROWS, N_ERR))
    ck_r = np.zeros((n_ck, MAX_ROWS))
    ck_z = np.zeros((n_ck, MAX_ROWS))
    ck_nrows = np.zeros(n_ck, dtype=np.int64)
    for k_begin in range(k0, n, CHUNK_EPOCHS):
        k_end = min(n, k_begin + CHUNK_EPOCHS)
        bad = _forward_kernel(
            k_begin, k_end, k0, imu.t_s, imu.gyro_body_rad_s, imu.acc_body_m_s2,
            gnss.t_s, g_epoch, llh, vel, var, params, state, prev, P, ctr,
            out_state, out_std, g_status, innov, innov_sd, store, CHECKPOINT_EVERY,
            ck_epoch, ck_Pm, ck_Pp, ck_H, ck_r, ck_z, ck_nrows,
        )  # fmt: skip
        if bad >= 0:
            break
        if progress is not None:
            progress((k_end - k0) / (n - k0))
    if bad >= 0:
        msg = (
            f"INS solution diverged (non-finite state, latitude past a pole or height beyond "
            f"±{MAX_ABS_HEIGHT_M:g} m) at t = {imu.t_s[bad]:.6f} s; check the "
            "IMU units (rad/s, m/s^2), axes (X forward, Y right, Z down) and the initial state"
        )
        raise InputError(msg)
    ck: Checkpoints | None = None
    if store:
        c = int(ctr[1])
        ck = Checkpoints(
            epoch=ck_epoch[:c], P_minus=ck_Pm[:c], P_plus=ck_Pp[:c], H=ck_H[:c],
            r=ck_r[:c], z=ck_z[:c], nrows=ck_nrows[:c],
        )  # fmt: skip
    return ForwardRun(k0=k0, states=out_state, std=out_std, params=params, checkpoints=ck)


def run_ins(
    imu: ImuData,
    gnss: GnssData,
    config: InsConfig,
    init: InitialState,
    *,
    use_velocity: bool = True,
    smooth: bool = False,
    progress: Callable[[float], None] | None = None,
) -> InsResult:
    """Loosely coupled INS/GNSS forward filter, optionally RTS-smoothed.

    Parameters
    ----------
    imu : ImuData
        IMU samples (body FRD, rad/s, m/s^2); gaps longer than ``config.max_imu_gap_s``
        after the initial epoch are an error.
    gnss : GnssData
        Antenna fixes (WGS84) with σ (NaN -> ``config`` defaults) and, optionally,
        NED velocities.
    config : InsConfig
        Sensor error model, GNSS defaults, antenna lever arm, initial σ, χ² gate.
    init : InitialState
        State of the IMU reference point at one of the IMU epochs.
    use_velocity : bool
        Use GNSS velocities when ``gnss`` has them.
    smooth : bool
        Also run the Rauch–Tung–Striebel smoother (`kinsync.ins.smoother`).
    progress : callable, optional
        Called with the fraction of work done (0..1) between chunks of
        `CHUNK_EPOCHS` epochs; the forward pass is the first half when smoothing.

    Returns
    -------
    InsResult

    Raises
    ------
    InputError
        Initial time not an IMU epoch, IMU gap, non-finite initial state, divergence.
    """
    if not isinstance(imu, ImuData) or not isinstance(gnss, GnssData):
        msg = "run_ins: imu must be ImuData and gnss GnssData"
        raise InputError(msg)
    k0 = start_epoch(imu, init)
    check_imu_gaps(imu, k0, config.max_imu_gap_s)
    g_epoch = gnss_epochs(imu.t_s, k0, gnss.t_s)
    m = len(gnss)
    g_status = np.zeros(m, dtype=np.int64)
    innov = np.full((m, MAX_ROWS), np.nan)
    innov_sd = np.full((m, 3), np.nan)
    fwd_progress = progress
    if smooth and progress is not None:
        outer = progress

        def fwd_progress(f: float) -> None:
            outer(0.5 * f)

    run = forward_pass(
        imu, gnss, config, init, use_velocity=use_velocity, store=smooth,
        progress=fwd_progress, g_epoch=g_epoch, g_status=g_status, innov=innov,
        innov_sd=innov_sd,
    )  # fmt: skip
    n_used = int(np.count_nonzero(g_status == GnssStatus.USED))
    n_rej = int(np.count_nonzero(g_status == GnssStatus.REJECTED))
    t_out = imu.t_s[k0:]
    forward = nav_solution_from_states(
        t_out, run.states[k0:], run.std[k0:], n_gnss_used=n_used, n_gnss_rejected=n_rej
    )
    smoothed: NavSolution | None = None
    if smooth:
        from kinsync.ins.smoother import smooth_forward_run  # noqa: PLC0415 - import cycle

        states_s, std_s = smooth_forward_run(
            imu, run, None if progress is None else (lambda f: progress(0.5 + 0.5 * f))
        )
        smoothed = nav_solution_from_states(
            t_out, states_s[k0:], std_s[k0:], smoothed=True, n_gnss_used=n_used,
            n_gnss_rejected=n_rej,
        )  # fmt: skip
    inside = g_epoch >= 0
    return InsResult(
        forward=forward,
        smoothed=smoothed,
        innovations_pos_ned_m=innov[inside, :3],
        gnss_rejected_t_s=gnss.t_s[g_status == GnssStatus.REJECTED].copy(),
        innovations_t_s=gnss.t_s[inside].copy(),
        innovations_vel_ned_m_s=innov[inside, 3:],
        innovation_std_pos_ned_m=innov_sd[inside],
        gnss_status=g_status,
    )


# ---------------------------------------------------------------------- alignment
STATIC_ACC_STD_M_S2 = 0.3
"""Largest accelerometer standard deviation (per axis) accepted as "static" (m/s^2)."""
STATIC_GYRO_STD_RAD_S = 0.02
"""Largest gyro standard deviation (per axis) accepted as "static" (rad/s)."""
STATIC_GRAVITY_TOL_M_S2 = 0.5
"""Largest difference between the mean specific-force magnitude and normal gravity."""
STATIC_GNSS_SPEED_M_S = 0.5
"""Largest GNSS horizontal speed accepted during the static period (m/s)."""
HEADING_MIN_SPEED_M_S = 2.0
"""GNSS horizontal speed from which the course over ground is taken as heading (m/s)."""
HEADING_MIN_DISTANCE_M = 10.0
"""Without GNSS velocities: displacement from the static position that gives the heading."""


def _static_window(imu: ImuData, static_s: float) -> int:
    if not (isinstance(static_s, int | float) and math.isfinite(static_s) and static_s > 0):
        msg = f"align_static_gnss_heading: static_s must be a positive number, got {static_s!r}"
        raise InputError(msg)
    t0 = float(imu.t_s[0])
    if imu.t_s[-1] < t0 + static_s:
        msg = (
            f"no static start: the IMU record ({imu.t_s[-1] - t0:.3f} s) is shorter than the "
            f"static period static_s = {static_s} s"
        )
        raise ObservabilityError(msg)
    k_end = int(np.searchsorted(imu.t_s, t0 + static_s, side="right")) - 1
    if k_end < 10:
        msg = (
            f"no static start: only {k_end + 1} IMU samples in the first {static_s} s; "
            "a longer static_s is needed for levelling"
        )
        raise ObservabilityError(msg)
    return k_end


def _check_static(
    imu: ImuData, gnss: GnssData, k_end: int, static_s: float, lat_rad: float, h_m: float
) -> None:
    acc = imu.acc_body_m_s2[: k_end + 1]
    gyro = imu.gyro_body_rad_s[: k_end + 1]
    acc_std = float(acc.std(axis=0).max())
    gyro_std = float(gyro.std(axis=0).max())
    g = float(normal_gravity_m_s2(lat_rad, h_m))
    g_err = abs(float(np.linalg.norm(acc.mean(axis=0))) - g)
    t0 = imu.t_s[0]
    speed = 0.0
    if gnss.vel_ned_m_s is not None:
        sel = (gnss.t_s >= t0) & (gnss.t_s <= imu.t_s[k_end])
        if sel.any():
            speed = float(np.hypot(gnss.vel_ned_m_s[sel, 0], gnss.vel_ned_m_s[sel, 1]).max())
    if (
        acc_std > STATIC_ACC_STD_M_S2
        or gyro_std > STATIC_GYRO_STD_RAD_S
        or g_err > STATIC_GRAVITY_TOL_M_S2
        or speed > STATIC_GNSS_SPEED_M_S
    ):
        msg = (
            f"no static start: over the first {static_s} s (from t = {t0:.3f} s) the "
            f"accelerometer std is {acc_std:.3f} m/s^2 (limit {STATIC_ACC_STD_M_S2}), the gyro "
            f"std {gyro_std:.4f} rad/s (limit {STATIC_GYRO_STD_RAD_S}), |mean specific force| - "
            f"gravity {g_err:.3f} m/s^2 (limit {STATIC_GRAVITY_TOL_M_S2}), the GNSS speed up to "
            f"{speed:.2f} m/s (limit {STATIC_GNSS_SPEED_M_S}); start the record with the vehicle "
            "at rest, shorten static_s, or give an InitialState"
        )
        raise ObservabilityError(msg)


HEADING_WINDOW_S = 5.0
"""Course-over-ground epochs used for the heading: this long after the first one (s)."""


def _yaw_turned(
    imu: ImuData, k_end: int, gyro_bias: FloatArray, roll: float, pitch: float
) -> FloatArray:
    """Yaw turned since the end of the static period at each IMU epoch (rad, n,)."""
    w = imu.gyro_body_rad_s - gyro_bias
    rate = (w[:, 1] * math.sin(roll) + w[:, 2] * math.cos(roll)) / math.cos(pitch)
    inc = np.zeros(len(imu))
    inc[1:] = rate[1:] * np.diff(imu.t_s)
    inc[: k_end + 1] = 0.0
    out: FloatArray = np.cumsum(inc)
    return out


def _heading(
    imu: ImuData,
    gnss: GnssData,
    k_end: int,
    lat0: float,
    lon0: float,
    roll: float,
    pitch: float,
    gyro_bias: FloatArray,
    arm_body_m: FloatArray,
) -> float:
    """Heading at the end of the static period from GNSS course over ground (rad)."""
    t_end = float(imu.t_s[k_end])
    after = np.flatnonzero((gnss.t_s > t_end) & (gnss.t_s <= imu.t_s[-1]))
    turned = _yaw_turned(imu, k_end, gyro_bias, roll, pitch)
    k_of = np.clip(np.searchsorted(imu.t_s, gnss.t_s[after]), 0, len(imu) - 1)
    if gnss.vel_ned_m_s is not None:
        vel = gnss.vel_ned_m_s[after]
        speed = np.hypot(vel[:, 0], vel[:, 1])
        moving = np.flatnonzero(speed >= HEADING_MIN_SPEED_M_S)
        if moving.size == 0:
            msg = (
                f"no motion to get heading from: the GNSS horizontal speed never reaches "
                f"{HEADING_MIN_SPEED_M_S} m/s after the static period (t > {t_end:.3f} s); "
                "drive off after the static start, or give an InitialState"
            )
            raise ObservabilityError(msg)
        t_first = gnss.t_s[after[moving[0]]]
        use = moving[gnss.t_s[after[moving]] <= t_first + HEADING_WINDOW_S]
        yaw = 0.0
        for _ in range(2):  # second pass: lever-arm velocity with the first heading
            yaws = np.empty(use.size)
            for i, u in enumerate(use):
                k = int(k_of[u])
                R = euler_rpy_to_matrix(roll, pitch, yaw + turned[k])
                w = imu.gyro_body_rad_s[k] - gyro_bias
                v_imu = vel[u] - R @ np.cross(w, arm_body_m)
                yaws[i] = math.atan2(v_imu[1], v_imu[0]) - turned[k]
            wts = speed[use] ** 2
            yaw = math.atan2(float(np.sum(wts * np.sin(yaws))), float(np.sum(wts * np.cos(yaws))))
        return yaw
    r_m, r_n = radii_m(lat0)
    dn = np.radians(gnss.lat_deg[after] - math.degrees(lat0)) * r_m
    de = np.radians(gnss.lon_deg[after] - math.degrees(lon0)) * r_n * math.cos(lat0)
    sig = np.nan_to_num(np.hypot(gnss.std_pos_ned_m[after, 0], gnss.std_pos_ned_m[after, 1]))
    far = np.flatnonzero(np.hypot(dn, de) >= np.maximum(HEADING_MIN_DISTANCE_M, 10.0 * sig))
    if far.size == 0:
        msg = (
            "no motion to get heading from: no GNSS fix after the static period lies "
            f"{HEADING_MIN_DISTANCE_M} m (or 10 sigma) from the static position, and the file "
            "has no velocities; drive off after the static start, or give an InitialState"
        )
        raise ObservabilityError(msg)
    i = int(far[0])
    # bearing of the displacement, taken as the mean heading since the static end
    return math.atan2(float(de[i]), float(dn[i])) - 0.5 * float(turned[k_of[i]])


def align_static_gnss_heading(
    imu: ImuData,
    gnss: GnssData,
    *,
    static_s: float = 5.0,
    antenna_lever_arm_body_m: tuple[float, float, float] = (0.0, 0.0, 0.0),
) -> InitialState:
    """Initial state by static levelling and GNSS course-over-ground heading.

    1. The first ``static_s`` seconds of IMU data must be static (accelerometer and
       gyro standard deviations, specific-force magnitude against normal gravity, and
       GNSS speed when available, within the module's ``STATIC_*`` limits).
    2. Levelling: ``roll = atan2(-f_y, -f_z)``, ``pitch = atan2(f_x, sqrt(f_y² + f_z²))``
       from the mean specific force (accelerometer biases enter as tilt:
       1 mg ≈ 0.06°).
    3. The mean gyro output is the initial gyro drift estimate (the Earth rate,
       projected with the final attitude, is removed). MEMS gyros are far too noisy for
       gyrocompassing, so the heading comes from GNSS:
    4. Heading: the course over ground (antenna velocity minus the lever-arm term
       ``C (ω × l)``) of the GNSS epochs with a horizontal speed of at least
       `HEADING_MIN_SPEED_M_S` during `HEADING_WINDOW_S` after the first one, each
       carried back to the end of the static period by integrating the bias-corrected
       yaw rate ``(ω_y sin φ + ω_z cos φ) / cos θ``, averaged with weights ``speed²``
       (no side slip assumed). Without GNSS velocities: the bearing of the first fix
       `HEADING_MIN_DISTANCE_M` (or 10σ) away from the static position, corrected by
       half the yaw turned until then.
    5. Position: mean GNSS fix of the static period, moved from the antenna to the
       IMU with the lever arm; velocity zero.

    Parameters
    ----------
    imu : ImuData
        IMU samples starting with the static period.
    gnss : GnssData
        GNSS fixes (velocities strongly preferred).
    static_s : float
        Length of the static period at the start of ``imu`` (s).
    antenna_lever_arm_body_m : (float, float, float)
        IMU -> antenna lever arm, body frame (m).

    Returns
    -------
    InitialState
        At the last IMU epoch of the static period, with the gyro drift estimate.

    Raises
    ------
    ObservabilityError
        No static start, no GNSS fix during it, or no motion to take the heading from.
    InputError
        ``static_s`` is not a positive number.
    """
    k_end = _static_window(imu, static_s)
    t0 = float(imu.t_s[0])
    t_end = float(imu.t_s[k_end])
    in_static = (gnss.t_s >= t0) & (gnss.t_s <= t_end)
    if not in_static.any():
        msg = (
            f"no GNSS fix during the static period {t0:.3f} .. {t_end:.3f} s: the initial "
            "position is unknown; lengthen static_s or give an InitialState"
        )
        raise ObservabilityError(msg)
    lat0 = math.radians(float(gnss.lat_deg[in_static].mean()))
    lon0 = math.radians(float(gnss.lon_deg[in_static].mean()))
    h0 = float(gnss.h_m[in_static].mean())
    _check_static(imu, gnss, k_end, static_s, lat0, h0)
    f = imu.acc_body_m_s2[: k_end + 1].mean(axis=0)
    roll = math.atan2(-f[1], -f[2])
    pitch = math.atan2(f[0], math.hypot(f[1], f[2]))
    gyro_mean = imu.gyro_body_rad_s[: k_end + 1].mean(axis=0)
    arm = np.asarray(antenna_lever_arm_body_m, dtype=np.float64)
    yaw = _heading(imu, gnss, k_end, lat0, lon0, roll, pitch, gyro_mean, arm)
    yaw = (yaw + math.pi) % (2.0 * math.pi) - math.pi
    R = euler_rpy_to_matrix(roll, pitch, yaw)
    w_ie = np.array([OMEGA_IE_RAD_S * math.cos(lat0), 0.0, -OMEGA_IE_RAD_S * math.sin(lat0)])
    gyro_bias = gyro_mean - R.T @ w_ie
    arm_ned = R @ arm
    r_m, r_n = radii_m(lat0)
    lat = lat0 - arm_ned[0] / (r_m + h0)
    lon = lon0 - arm_ned[1] / ((r_n + h0) * math.cos(lat0))
    return InitialState(
        t_s=t_end,
        lat_deg=math.degrees(lat),
        lon_deg=math.degrees(lon),
        h_m=float(h0 + arm_ned[2]),
        vel_ned_m_s=(0.0, 0.0, 0.0),
        rpy_rad=(roll, pitch, yaw),
        gyro_bias_rad_s=(float(gyro_bias[0]), float(gyro_bias[1]), float(gyro_bias[2])),
    )
