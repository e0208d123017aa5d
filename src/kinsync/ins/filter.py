"""Loosely coupled INS/GNSS: 21- or 27-state error-state Kalman filter (SPEC section 6).

The error state, its dynamics ``F``, the transition matrix ``Φ = I + FΔt + F²Δt²/2``
and the closed-loop feedback are described in `kinsync.ins._ekf`: misorientation
(rad, NED), velocity error of the modified φ-angle model (m/s, NED), position error in
metres North/East/Down, and per sensor axis a turn-on bias (random constant), a bias
instability (first-order Gauss–Markov) and, when configured, a scale factor error;
after a levelled standstill, the second-order vertical support of the tilt
(`kinsync.ins.standstill`).

Forward pass, one compiled loop over the IMU epochs (run in chunks of
`CHUNK_EPOCHS` so that Python can report progress): for each epoch, ``Φ`` and ``Q``
from the state at the start of the interval, ``P ← Φ P Φ^T + Q``, one strapdown step
(`kinsync.ins.strapdown`), the expected second-order tilt error removed from the
velocity (`kinsync.ins._ekf.tilt_gravity_mean`; after a levelled standstill its
vertical part is the estimate of one more state, `kinsync.ins.standstill`), then every
GNSS epoch assigned to this IMU epoch:

- **Timing.** A GNSS epoch is processed at the nearest IMU epoch ``t_k``; its
  position is moved to ``t_k`` with the INS velocity (``p + v (t_k - t_gnss)``, at most
  half an IMU interval). GNSS epochs more than half an interval outside the IMU span
  from the initial epoch on are ignored (`GnssStatus.OUTSIDE`).
- **Observations.** ``z = INS - GNSS`` at the antenna, position and (optionally)
  velocity rows with the lever arm (`kinsync.ins.gnss_observation`). Standard
  deviations given as NaN take the configured defaults.
- **χ² gate.** Position and velocity innovations are each tested against
  ``ν^T S^{-1} ν <= χ²₃(gate_probability)`` with the predicted ``S = H P H^T + R``; if
  either fails the epoch is rejected as a whole (a receiver that produced one bad
  block is not trusted for the other).
- **Update and feedback.** Accepted rows are applied as sequential scalar updates
  (exact for the diagonal ``R``), the error state is fed back into the mechanisation
  (closed loop) and reset to zero.

`run_ins` checks its inputs, initial state and χ² rejections as ``kinsync ins run``
does (`kinsync.ins.checks`): it refuses what the command refuses, with the same
messages, and returns the warnings in `InsResult.warnings`.

The compiled loop reads and writes named tuples of arrays (`ImuArrays`, `GnssArrays`,
`FilterState`, `ForwardOutput`, `GnssLog` and the smoother's
`kinsync.ins.forward_run.CheckpointStore`), which numba compiles like separate array
arguments.

When smoothing is requested, the forward pass also stores a compact *checkpoint* per
GNSS update (the prior and posterior covariance, the accepted rows of ``H``, their
variances and ``z``) and one every `CHECKPOINT_EVERY` epochs
(`kinsync.ins.forward_run`); `kinsync.ins.smoother` recomputes ``Φ`` and the
covariances between checkpoints from the stored nominal states, so the memory is
O(n · 52 + m · 1 000) floats (n IMU epochs, m GNSS updates, 21 states), not three
21×21 matrices per epoch; the smoother adds none per epoch (`kinsync.ins.smoother`).

References
----------
P. D. Groves, *Principles of GNSS, Inertial, and Multisensor Integrated Navigation
Systems*, 2nd ed., Artech House, 2013, ch. 14 (loosely coupled integration, lever arm)
and ch. 17 (innovation-based outlier detection). P. S. Maybeck, *Stochastic Models,
Estimation, and Control*, vol. 1, Academic Press 1979, ch. 6.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import replace
from enum import IntEnum
from typing import Any, NamedTuple, cast

import numpy as np
from scipy.special import chdtri

from kinsync._jit import cached_njit
from kinsync._typing import FloatArray, IntArray
from kinsync.errors import ConvergenceError, InputError
from kinsync.frames import euler_rpy_to_matrix
from kinsync.ins._ekf import (
    N_ERR,
    N_ERR_SCALE,
    N_OUT,
    N_PARAMS,
    P_ARM,
    P_FEJ_END,
    P_GATE,
    P_QC_ATT,
    P_QC_BA,
    P_QC_BG,
    P_QC_VEL,
    P_TAU_A,
    P_TAU_G,
    P_TILT_MEAN,
    P_USE_VEL,
    X_BA,
    X_BG,
    X_MA,
    X_MG,
    X_SA,
    X_SG,
    feedback,
    propagate_cov,
    propagate_support,
    remove_support,
    scalar_update,
    solution_std,
    step_matrices,
    support_index,
    tilt_gravity_mean,
)
from kinsync.ins.checks import (
    check_gnss_rejections,
    check_initial_state,
    check_inputs,
    with_warnings,
)
from kinsync.ins.config import InsConfig
from kinsync.ins.earth import OMEGA_IE_RAD_S, normal_gravity_m_s2
from kinsync.ins.file_rows import FileRows
from kinsync.ins.forward_run import (
    CHECKPOINT_EVERY,
    CheckpointStore,
    ForwardRun,
    checkpoints_from_store,
    new_checkpoint_store,
)
from kinsync.ins.gnss_observation import MAX_ROWS, gate_stat, gnss_epochs, observation
from kinsync.ins.measurements import GnssData, ImuData
from kinsync.ins.result import InsResult
from kinsync.ins.smoother import smooth_forward_run
from kinsync.ins.solution import InitialState, NavSolution
from kinsync.ins.standstill import standstill_params, with_vertical_support
from kinsync.ins.strapdown import (
    I_H,
    I_LAT,
    I_MA,
    I_MG,
    N_PREV,
    N_STATE,
    check_imu_gaps,
    initial_state_vector,
    mech_step,
    nav_solution_from_states,
    start_epoch,
)
from kinsync.progress import Progress, part, report

__all__ = [
    "CHUNK_EPOCHS",
    "GnssStatus",
    "InsResult",
    "run_ins",
    "transition_matrix",
]

CHUNK_EPOCHS = 10_000
"""IMU epochs per call of the compiled loop (progress is reported between calls)."""
MAX_ABS_HEIGHT_M = 1.0e6
"""A mechanised height beyond ±1000 km means the solution diverged."""
MAX_ABS_LAT_RAD = 1.5707
"""A mechanised latitude beyond this (just short of π/2) means the solution diverged."""

_jit = cached_njit()


class GnssStatus(IntEnum):
    """What the filter did with a GNSS epoch."""

    OUTSIDE = 0
    """Outside the IMU span (from the initial epoch on): ignored."""
    USED = 1
    """Passed the χ² gate and updated the filter."""
    REJECTED = 2
    """Failed the χ² gate (position or velocity)."""


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
class ImuArrays(NamedTuple):
    """IMU samples as the compiled loop reads them (the arrays of `ImuData`).

    Attributes
    ----------
    t_s : ndarray, shape (n,)
        Sample times (s), strictly increasing.
    gyro_body_rad_s : ndarray, shape (n, 3)
        Angular rate of the body w.r.t. inertial space, body FRD (rad/s).
    acc_body_m_s2 : ndarray, shape (n, 3)
        Specific force, body FRD (m/s^2).
    """

    t_s: FloatArray
    gyro_body_rad_s: FloatArray
    acc_body_m_s2: FloatArray


class GnssArrays(NamedTuple):
    """GNSS epochs as the compiled loop reads them (see `GnssData`).

    Attributes
    ----------
    t_s : ndarray, shape (m,)
        Epoch times (s).
    imu_epoch : ndarray of int, shape (m,)
        IMU epoch at which each GNSS epoch is processed; -1 outside the IMU span
        (`gnss_epochs`).
    lat_lon_rad_h_m : ndarray, shape (m, 3)
        Antenna latitude, longitude (rad) and ellipsoidal height (m), WGS84.
    vel_ned_m_s : ndarray, shape (m, 3)
        Antenna velocity, NED (m/s); NaN rows where no velocity is used.
    obs_var : ndarray, shape (m, 6)
        Noise variances of the observation rows: position N, E, D (m^2), then
        velocity N, E, D (m^2/s^2), configured defaults in place of NaN σ.
    """

    t_s: FloatArray
    imu_epoch: IntArray
    lat_lon_rad_h_m: FloatArray
    vel_ned_m_s: FloatArray
    obs_var: FloatArray


class FilterState(NamedTuple):
    """The filter's state between two calls of the compiled loop (updated in place).

    Attributes
    ----------
    nominal : ndarray, shape (31,)
        Nominal navigation state in the layout of `kinsync.ins.strapdown`: latitude,
        longitude (rad), height (m), velocity NED (m/s), ``q_body_to_ned`` (w, x, y, z),
        the sensor error estimates (turn-on biases, instabilities, scale factors) and
        the second-order vertical support ``ĉ`` of a levelled standstill.
    increments_prev : ndarray, shape (6,)
        Previous interval's bias-corrected ``Δθ`` (rad) and ``Δv`` (m/s), body frame
        (coning and sculling corrections).
    P : ndarray, shape (n, n)
        Error-state covariance (order of `kinsync.ins._ekf`; n = 21, or 27 with scale
        factors, plus one after a levelled standstill).
    """

    nominal: FloatArray
    increments_prev: FloatArray
    P: FloatArray


class ForwardOutput(NamedTuple):
    """Per-epoch output of the compiled loop, indexed by absolute IMU epoch.

    Attributes
    ----------
    states : ndarray, shape (n, 31)
        Nominal state after the epoch's updates (layout of `FilterState.nominal`).
    std : ndarray, shape (n, 21)
        1σ of the solution (`kinsync.ins._ekf.solution_std`).
    """

    states: FloatArray
    std: FloatArray


class GnssLog(NamedTuple):
    """What the compiled loop did with each GNSS epoch (written in place).

    Attributes
    ----------
    next_index : ndarray of int, shape (1,)
        First GNSS epoch the loop has not visited yet.
    status : ndarray of int, shape (m,)
        `GnssStatus` of each epoch (`GnssStatus.OUTSIDE` until visited).
    innovation : ndarray, shape (m, 6)
        GNSS minus predicted antenna position N, E, D (m) and velocity N, E, D (m/s)
        before the update (or the gate's rejection); NaN where not visited.
    innovation_std_pos_ned_m : ndarray, shape (m, 3)
        ``sqrt(diag S)`` of the position innovations (m); NaN where not visited.
    """

    next_index: IntArray
    status: IntArray
    innovation: FloatArray
    innovation_std_pos_ned_m: FloatArray


def new_gnss_log(m: int) -> GnssLog:
    """Empty `GnssLog` for ``m`` GNSS epochs (all `GnssStatus.OUTSIDE`, NaN innovations)."""
    return GnssLog(
        next_index=np.zeros(1, dtype=np.int64),
        status=np.full(m, GnssStatus.OUTSIDE, dtype=np.int64),
        innovation=np.full((m, MAX_ROWS), np.nan),
        innovation_std_pos_ned_m=np.full((m, 3), np.nan),
    )


def _add_plain_checkpoint(
    checkpoints: CheckpointStore, k: int, P: FloatArray
) -> None:  # pragma: no cover - compiled by numba
    """Store a checkpoint without update (``P^- = P^+ = P``) at IMU epoch ``k``."""
    c = checkpoints.n_filled[0]
    checkpoints.epoch[c] = k
    n = P.shape[0]
    for i in range(n):  # element loops: see `copy_matrix`
        for j in range(n):
            checkpoints.P_minus[c, i, j] = P[i, j]
            checkpoints.P_plus[c, i, j] = P[i, j]
    checkpoints.nrows[c] = 0
    checkpoints.n_filled[0] = c + 1
    checkpoints.last_epoch[0] = k


def _copy_vector(dst: FloatArray, src: FloatArray) -> None:  # pragma: no cover - numba
    """``dst[:] = src`` as a loop.

    numba's slice assignment compiles its broadcasting shape-error path (string
    formatting) with it: seconds of a user's first run for nothing.
    """
    for i in range(src.shape[0]):
        dst[i] = src[i]


def _copy_matrix(dst: FloatArray, src: FloatArray) -> None:  # pragma: no cover - numba
    """``dst[:, :] = src`` as a loop (see `copy_vector`)."""
    for i in range(src.shape[0]):
        for j in range(src.shape[1]):
            dst[i, j] = src[i, j]


copy_vector = _jit(_copy_vector)
copy_matrix = _jit(_copy_matrix)
add_plain_checkpoint = _jit(_add_plain_checkpoint)


def _forward_loop(  # noqa: PLR0912, PLR0915 - one flat loop is what numba compiles best
    k_begin: int,
    k_end: int,
    k0: int,
    imu: ImuArrays,
    gnss: GnssArrays,
    params: FloatArray,
    filt: FilterState,
    out: ForwardOutput,
    log: GnssLog,
    checkpoints: CheckpointStore,
) -> int:  # pragma: no cover - compiled by numba; tested through run_ins
    """Forward filter over epochs ``k_begin .. k_end-1`` (see the module docstring).

    ``filt``, ``out``, ``log`` and ``checkpoints`` are updated in place, so that the
    next chunk continues where this one stopped; ``k0`` is the initial epoch.
    Returns -1, or the first epoch whose state or covariance is not finite, whose
    latitude passes a pole or whose height leaves ±`MAX_ABS_HEIGHT_M` (the loop stops).
    """
    m = gnss.t_s.shape[0]
    nominal = filt.nominal
    P = filt.P
    n_err = P.shape[0]
    qa = np.empty(4)
    qb = np.empty(4)
    C = np.empty((3, 3))
    F = np.zeros((n_err, n_err))
    Phi = np.zeros((n_err, n_err))
    q = np.empty(n_err)
    q_nav = np.empty((6, 6))
    T = np.empty((9, n_err))
    w_b = np.empty(3)
    f_b = np.empty(3)
    H = np.zeros((MAX_ROWS, n_err))
    z = np.empty(MAX_ROWS)
    r = np.empty(MAX_ROWS)
    x = np.zeros(n_err)
    ph = np.empty(n_err)
    hrow = np.empty(n_err)
    decay_g = 0.0
    decay_a = 0.0
    dt_decay = -1.0
    sd_p = np.empty(3)
    sd_v = np.empty(3)
    nan3 = np.full(3, np.nan)
    coning = True
    use_vel = params[P_USE_VEL] > 0.5
    tilt_mean = params[P_TILT_MEAN] > 0.5
    i_support = support_index(n_err)
    gate = params[P_GATE]
    for k in range(k_begin, k_end):
        if k > k0:
            dt = imu.t_s[k] - imu.t_s[k - 1]
            acc_k = imu.acc_body_m_s2[k]
            gyro_k = imu.gyro_body_rad_s[k]
            step_matrices(
                nominal, gyro_k, acc_k, dt, imu.t_s[k - 1], params, w_b, f_b, C, F, Phi, q,
                q_nav,
            )  # fmt: skip
            propagate_cov(P, Phi, q, q_nav, T)
            if i_support >= 0:
                g_c = normal_gravity_m_s2(nominal[I_LAT], nominal[I_H])
                propagate_support(P, nominal, i_support, g_c)
            mech_step(
                nominal, filt.increments_prev, gyro_k, acc_k, dt, k == k0 + 1,
                coning, qa, qb, C,
            )  # fmt: skip
            moving = imu.t_s[k - 1] >= params[P_FEJ_END]
            if i_support >= 0:
                remove_support(P, nominal, dt, tilt_mean and moving)
            elif tilt_mean and moving:
                tilt_gravity_mean(P, nominal, dt)
            if dt != dt_decay:  # the instability estimates decay as their model says
                dt_decay = dt
                decay_g = math.exp(-dt / params[P_TAU_G])
                decay_a = math.exp(-dt / params[P_TAU_A])
            for i in range(3):
                nominal[I_MG + i] *= decay_g
                nominal[I_MA + i] *= decay_a
            ok_k = True
            for i in range(N_STATE):
                ok_k = ok_k and math.isfinite(nominal[i])
            for i in range(n_err):
                ok_k = ok_k and math.isfinite(P[i, i])
            ok_k = (
                ok_k
                and abs(nominal[I_LAT]) < MAX_ABS_LAT_RAD
                and abs(nominal[I_H]) < MAX_ABS_HEIGHT_M
            )
            if not ok_k:
                return k
        elif checkpoints.enabled:
            add_plain_checkpoint(checkpoints, k, P)
        while log.next_index[0] < m and gnss.imu_epoch[log.next_index[0]] <= k:
            j = log.next_index[0]
            log.next_index[0] = j + 1
            if gnss.imu_epoch[j] < k:
                continue
            with_vel = use_vel and math.isfinite(gnss.vel_ned_m_s[j, 0])
            observation(
                nominal, imu.gyro_body_rad_s[k], params, imu.t_s[k] - gnss.t_s[j],
                gnss.lat_lon_rad_h_m[j], gnss.vel_ned_m_s[j] if with_vel else nan3, C, H, z,
            )  # fmt: skip
            for i in range(MAX_ROWS):
                r[i] = gnss.obs_var[j, i]
            ok = True
            for block in range(2 if with_vel else 1):  # position, then velocity rows
                # a row offset known only at run time: one compiled gate_stat, not two
                d2 = gate_stat(P, H, 3 * block, r, z, sd_v if block else sd_p)
                ok = ok and d2 <= gate
            for i in range(3):  # a rejected epoch's too: the gate's diagnosis reads them
                log.innovation[j, i] = -z[i]
                log.innovation_std_pos_ned_m[j, i] = sd_p[i]
                if with_vel:
                    log.innovation[j, 3 + i] = -z[3 + i]
            if not ok:
                log.status[j] = GnssStatus.REJECTED
                continue
            log.status[j] = GnssStatus.USED
            nrows = 6 if with_vel else 3
            if checkpoints.enabled:
                c = checkpoints.n_filled[0]
                checkpoints.epoch[c] = k
                copy_matrix(checkpoints.P_minus[c], P)
            for i in range(n_err):
                x[i] = 0.0
            for i in range(nrows):
                for jj in range(n_err):
                    hrow[jj] = H[i, jj]
                scalar_update(P, x, hrow, r[i], z[i], ph)
            feedback(nominal, x, qa, qb, C)
            if checkpoints.enabled:
                c = checkpoints.n_filled[0]
                copy_matrix(checkpoints.P_plus[c], P)
                copy_matrix(checkpoints.H[c], H)
                copy_vector(checkpoints.r[c], r)
                copy_vector(checkpoints.z[c], z)
                checkpoints.nrows[c] = nrows
                checkpoints.n_filled[0] = c + 1
                checkpoints.last_epoch[0] = k
        if checkpoints.enabled and k - checkpoints.last_epoch[0] >= checkpoints.every_epochs:
            add_plain_checkpoint(checkpoints, k, P)
        copy_vector(out.states[k], nominal)
        solution_std(P, nominal, out.std[k])
    return -1


_forward_kernel = cast(Callable[..., int], _jit(_forward_loop))


# ---------------------------------------------------------------------- Python side
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
    p[P_GATE] = float(chdtri(3, 1.0 - config.gate_probability))  # chi-square(3) quantile
    p[P_USE_VEL] = 1.0 if use_velocity else 0.0
    p[P_TILT_MEAN] = 1.0
    p[P_FEJ_END] = -math.inf
    return p


def initial_covariance(config: InsConfig, init: InitialState) -> FloatArray:
    """Initial error covariance (n, n) from the configured σ.

    n is 21, or 27 with scale factors (`InsConfig.models_scale_factors`); the state
    a levelled standstill adds is not in it (`kinsync.ins.standstill`). Attitude,
    NED velocity, position and sensor errors are independent; the velocity state of
    the modified φ-angle model, ``δv' = δv - [v×] φ``, is correlated with the attitude
    through the initial velocity ``v``. The turn-on bias σ is the calibration's when
    one is given, else the datasheet's turn-on σ.

    When roll and pitch were levelled from a static period
    (``init.levelling_std_rad`` set), the levelled tilt is wrong by the horizontal
    accelerometer error over g (Groves 2013, sec. 5.6.2): ``φ_N = (C δf)_E / g``,
    ``φ_E = -(C δf)_N / g`` with ``δf = δb_a + δm_a``, plus the levelling noise
    (σ ``levelling_std_rad``), instead of the configured σ. The tilt is correlated
    with the accelerometer states accordingly (through ``C`` of the levelled attitude),
    and the measured gyro bias below with that whole tilt. Left independent, the tilt
    and the horizontal accelerometer error each kept their σ while at rest the data
    measure only their difference, so the filter halved the tilt variance: normalised
    roll/pitch errors of RMS 1.45 over 5-60 s at rest (12 simulated MEMS static starts),
    about √2. With the correlation, the first-estimates Jacobian and no second-order
    tilt mean during the standstill (`standstill_params`): 0.95, and 1.23 / 1.19 over
    60-85 s and 85-110 s after driving off (1.61 / 1.19 before); smoothed, 1.09 / 1.03
    / 1.00 (unchanged). At rest the vertical accelerometer bias cannot be told from
    the second-order vertical support of the unknown tilt (``½ g θ²``, 0.25 mg for the
    MEMS preset), which the filter then carries as one more state
    (`kinsync.ins.standstill.with_vertical_support`, added to this covariance by the
    forward pass): without it the smoothed vertical bias at rest was off by 0.28 mg
    RMS against a σ of 0.022 mg.

    When the gyro bias was measured as the mean rate of a static period
    (``init.gyro_bias_std_rad_s`` set, and no calibration in ``config``), that mean
    measured turn-on bias plus instability less the Earth rate resolved with the
    estimated attitude: ``δb_g = ε - δm_g - C^T [ω_ie×] φ``, with ``ε`` the mean's
    noise (σ ``gyro_bias_std_rad_s``), instead of the turn-on σ. The last term is the
    Earth rate resolved with the wrong attitude; in the attitude error's dynamics it
    cancels the ``-[ω_ie×] φ`` term, so a static vehicle keeps its attitude error, as
    it does. Without these correlations the filter expects a tilt error to turn with
    the Earth (0.2 m of position over a minute for 1 deg of tilt), sees that it does
    not, and takes that for information on the tilt; left at the turn-on σ, the gyro
    bias also lets the heading wander while the vehicle stands still.
    """
    n = N_ERR_SCALE if config.models_scale_factors else N_ERR
    sig = np.zeros(n)
    gyro = config.init_gyro_bias_std_rad_s or (config.gyro_bias_sigma_rad_s,) * 3
    acc = config.init_acc_bias_std_m_s2 or (config.acc_bias_sigma_m_s2,) * 3
    sig[0:3] = config.init_std_att_rad
    if init.levelling_std_rad is not None:
        sig[0:2] = init.levelling_std_rad  # the rest of the tilt: the acc states, via S
    sig[3:6] = config.init_std_vel_ned_m_s
    sig[6:9] = config.init_std_pos_ned_m
    sig[X_BG : X_BG + 3] = gyro
    sig[X_BA : X_BA + 3] = acc
    sig[X_MG : X_MG + 3] = config.gyro_bias_instability_rad_s
    sig[X_MA : X_MA + 3] = config.acc_bias_instability_m_s2
    if n > X_SG:
        sig[X_SG : X_SG + 3] = config.gyro_scale_factor_sigma_ppm * 1e-6
        sig[X_SA : X_SA + 3] = config.acc_scale_factor_sigma_ppm * 1e-6
    measured_gyro = init.gyro_bias_std_rad_s is not None and config.init_gyro_bias_rad_s is None
    if measured_gyro:
        sig[X_BG : X_BG + 3] = init.gyro_bias_std_rad_s
    P = np.diag(sig**2)
    S = _static_start_transform(init, n, measured_gyro=measured_gyro)
    P = S @ P @ S.T
    v = np.asarray(init.vel_ned_m_s, dtype=np.float64)
    V = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    T = np.eye(n)
    T[3:6, 0:3] = -V  # δv' = δv - [v×] φ
    out: FloatArray = T @ P @ T.T
    return out


def _static_start_transform(init: InitialState, n: int, *, measured_gyro: bool) -> FloatArray:
    """``T`` (n, n): error state = ``T`` × independent errors after a static start.

    Identity, plus the accelerometer error over g in the roll and pitch rows of a
    levelled attitude, and ``-δm_g - C^T [ω_ie×] φ`` in the turn-on gyro bias rows of
    a gyro bias measured as a static mean rate (`initial_covariance`).
    """
    T = np.eye(n)
    C = euler_rpy_to_matrix(*init.rpy_rad)
    if init.levelling_std_rad is not None:
        g = float(normal_gravity_m_s2(math.radians(init.lat_deg), init.h_m))
        for x in (X_BA, X_MA):  # φ_N = (C δf)_E / g, φ_E = -(C δf)_N / g
            T[0, x : x + 3] = C[1] / g
            T[1, x : x + 3] = -C[0] / g
    if measured_gyro:
        lat = math.radians(init.lat_deg)
        w = OMEGA_IE_RAD_S * np.array([math.cos(lat), 0.0, -math.sin(lat)])
        W = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
        T[X_BG : X_BG + 3] -= T[X_MG : X_MG + 3]  # - δm_g
        T[X_BG : X_BG + 3] -= C.T @ W @ T[0:3]  # - C^T [ω_ie×] φ, the whole tilt
    return T


def starting_estimates(config: InsConfig, init: InitialState) -> InitialState:
    """``init`` with the configured calibrated turn-on biases, when the config has them.

    Raises
    ------
    InputError
        ``init`` and ``config`` give different turn-on biases of one sensor (say which
        to use).
    """
    changes: dict[str, Any] = {}
    for sensor, given, known in (
        ("gyro", init.gyro_bias_rad_s, config.init_gyro_bias_rad_s),
        ("acc", init.acc_bias_m_s2, config.init_acc_bias_m_s2),
    ):
        if known is None:
            continue
        if any(float(b) != 0.0 for b in given) and tuple(given) != tuple(known):
            msg = (
                f"the {sensor} turn-on bias differs between the initial state ({given}) and "
                f"the configuration's [init] ({known}); give it in one place"
            )
            raise InputError(msg)
        changes["gyro_bias_rad_s" if sensor == "gyro" else "acc_bias_m_s2"] = tuple(known)
    return replace(init, **changes) if changes else init


def _gnss_arrays(
    gnss: GnssData, imu_epoch: IntArray, config: InsConfig, *, use_velocity: bool
) -> GnssArrays:
    """The loop's view of ``gnss``: radians, NaN σ replaced by the configured defaults."""
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
    return GnssArrays(
        t_s=gnss.t_s, imu_epoch=imu_epoch, lat_lon_rad_h_m=llh, vel_ned_m_s=vel, obs_var=var
    )


def forward_pass(
    imu: ImuData,
    gnss: GnssData,
    config: InsConfig,
    init: InitialState,
    *,
    use_velocity: bool,
    store: bool,
    progress: Progress | None,
    gnss_imu_epoch: IntArray,
    log: GnssLog,
) -> ForwardRun:
    """Run the compiled forward loop in chunks of `CHUNK_EPOCHS` epochs.

    Parameters
    ----------
    imu, gnss, config, init, use_velocity
        As for `run_ins`.
    store : bool
        Store the smoother's checkpoints (`kinsync.ins.forward_run`).
    progress : Progress, optional
        Told the fraction of the epochs done (stage "filter") before the first chunk
        and after each.
    gnss_imu_epoch : ndarray of int, shape (m,)
        IMU epoch of each GNSS epoch, -1 outside the span (`gnss_epochs`).
    log : GnssLog
        Filled with the status and innovations of each GNSS epoch (`new_gnss_log`).

    Returns
    -------
    ForwardRun

    Raises
    ------
    InputError
        The solution diverged.
    """
    k0 = start_epoch(imu, init)
    n = len(imu)
    params = filter_params(config, use_velocity=use_velocity)
    imu_arrays = ImuArrays(imu.t_s, imu.gyro_body_rad_s, imu.acc_body_m_s2)
    gnss_arrays = _gnss_arrays(gnss, gnss_imu_epoch, config, use_velocity=use_velocity)
    init = starting_estimates(config, init)
    nominal, P = with_vertical_support(
        initial_state_vector(init), initial_covariance(config, init), init
    )
    params = standstill_params(params, init)
    filt = FilterState(nominal=nominal, increments_prev=np.zeros(N_PREV), P=P)
    out = ForwardOutput(states=np.zeros((n, N_STATE)), std=np.zeros((n, N_OUT)))
    n_in = int(np.count_nonzero(gnss_imu_epoch >= 0))
    checkpoints = new_checkpoint_store(
        n_in + (n - k0) // CHECKPOINT_EVERY + 2, CHECKPOINT_EVERY, filt.P.shape[0], enabled=store
    )
    bad = -1
    report(progress, 0.0, "filter")
    for k_begin in range(k0, n, CHUNK_EPOCHS):
        k_end = min(n, k_begin + CHUNK_EPOCHS)
        bad = _forward_kernel(
            k_begin, k_end, k0, imu_arrays, gnss_arrays, params, filt, out, log, checkpoints
        )
        if bad >= 0:
            break
        report(progress, (k_end - k0) / (n - k0), "filter")
    if bad >= 0:
        msg = (
            f"INS solution diverged (non-finite state, latitude past a pole or height beyond "
            f"±{MAX_ABS_HEIGHT_M:g} m) at t = {imu.t_s[bad]:.6f} s; check the "
            "IMU units (rad/s, m/s^2), axes (X forward, Y right, Z down) and the initial state"
        )
        raise InputError(msg)
    return ForwardRun(
        k0=k0,
        states=out.states,
        std=out.std,
        params=params,
        checkpoints=checkpoints_from_store(checkpoints),
        n_error_states=int(filt.P.shape[0]),
    )


def run_ins(
    imu: ImuData, gnss: GnssData, config: InsConfig, init: InitialState, *,
    use_velocity: bool = True, smooth: bool = False, progress: Progress | None = None,
    imu_source: str = "IMU data", gnss_source: str = "GNSS data", static_s: float = 2.0,
    input_warnings: Sequence[str] | None = None, gnss_rows: FileRows | None = None,
) -> InsResult:  # fmt: skip
    """Loosely coupled INS/GNSS forward filter, optionally RTS-smoothed, with its checks.

    First `kinsync.ins.checks.check_inputs` (IMU gaps and units, GNSS within the IMU
    span) and `kinsync.ins.checks.check_initial_state`; after filtering,
    `kinsync.ins.checks.check_gnss_rejections` refuses a solution whose χ² gate rejected
    more than `kinsync.ins.checks.GATE_ERROR_SHARE` of the GNSS epochs.

    Parameters
    ----------
    imu : ImuData
        IMU samples (body FRD, rad/s, m/s^2); gaps longer than ``config.max_imu_gap_s``
        are an error.
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
    progress : Progress, optional
        Told the fraction of the work done (0..1) between chunks of `CHUNK_EPOCHS`
        epochs, stages "filter" and "smoother"; the forward pass is the first half
        when smoothing.
    imu_source, gnss_source : str
        Names of the inputs in messages (the file paths, where they came from files).
    static_s : float
        Length (s) of the start window the input checks test for a static start.
    input_warnings : sequence of str, optional
        Warnings of `kinsync.ins.checks.check_inputs` run by the caller on these inputs
        (``kinsync ins run`` checks before levelling); None (default): run it here.
    gnss_rows : FileRows, optional
        The file rows and lines of ``gnss``'s rows, for the checks' messages.

    Returns
    -------
    InsResult
        With the checks' warnings in `InsResult.warnings`.

    Raises
    ------
    InputError
        Inputs or an initial state the checks refuse, initial time not an IMU epoch,
        divergence, too many GNSS epochs rejected; after input checks that warned,
        the message ends with their warnings (they may name the cause).
    """
    if not isinstance(imu, ImuData) or not isinstance(gnss, GnssData):
        msg = "run_ins: imu must be ImuData and gnss GnssData"
        raise InputError(msg)
    if not isinstance(config, InsConfig):
        msg = f"run_ins: config must be an InsConfig (read_ins_config), got {type(config).__name__}"
        raise InputError(msg)
    if not isinstance(init, InitialState):
        msg = (
            f"run_ins: init must be an InitialState, got {type(init).__name__}; take it from "
            "align_static_gnss_heading(imu, gnss) or build one at an IMU epoch"
        )
        raise InputError(msg)
    warnings = list(input_warnings) if input_warnings is not None else check_inputs(
        imu, gnss, config, imu_source=imu_source, gnss_source=gnss_source, static_s=static_s
    )  # fmt: skip
    try:
        check_initial_state(init, gnss, config, gnss_source=gnss_source, gnss_rows=gnss_rows)
        result = _filter_and_smooth(
            imu, gnss, config, init, use_velocity=use_velocity, smooth=smooth, progress=progress
        )
        warnings += check_gnss_rejections(
            result.gnss_rejected_t_s, result.forward.n_gnss_used, config, gnss_source=gnss_source,
            rejected_nu_ned=result.rejected_innovations_pos_ned_m
            / result.rejected_innovation_std_pos_ned_m,
            rejected_rows=np.flatnonzero(result.gnss_status == GnssStatus.REJECTED),
            gnss_rows=gnss_rows,
        )  # fmt: skip
    except (InputError, ConvergenceError) as err:
        if not warnings:
            raise
        raise with_warnings(err, warnings) from err
    return replace(result, warnings=tuple(warnings))


def _filter_and_smooth(
    imu: ImuData, gnss: GnssData, config: InsConfig, init: InitialState, *,
    use_velocity: bool, smooth: bool, progress: Progress | None,
) -> InsResult:  # fmt: skip
    """The forward filter and, when ``smooth``, the smoother (`run_ins` without checks)."""
    k0 = start_epoch(imu, init)
    check_imu_gaps(imu, k0, config.max_imu_gap_s)
    g_epoch = gnss_epochs(imu.t_s, k0, gnss.t_s)
    log = new_gnss_log(len(gnss))
    run = forward_pass(
        imu, gnss, config, init, use_velocity=use_velocity, store=smooth,
        progress=part(progress, 0.0, 0.5 if smooth else 1.0), gnss_imu_epoch=g_epoch, log=log,
    )  # fmt: skip
    n_error_states = run.n_error_states
    n_used = int(np.count_nonzero(log.status == GnssStatus.USED))
    n_rej = int(np.count_nonzero(log.status == GnssStatus.REJECTED))
    t_out = imu.t_s[k0:]
    forward = nav_solution_from_states(
        t_out, run.states[k0:], run.std[k0:], n_gnss_used=n_used, n_gnss_rejected=n_rej
    )
    smoothed: NavSolution | None = None
    if smooth:
        # `forward` holds copies; the checkpoints go before the smoothed solution is built
        states_s, std_s = smooth_forward_run(imu, run, part(progress, 0.5, 1.0), overwrite=True)
        del run
        smoothed = nav_solution_from_states(
            t_out, states_s[k0:], std_s[k0:], smoothed=True, n_gnss_used=n_used,
            n_gnss_rejected=n_rej,
        )  # fmt: skip
    inside = g_epoch >= 0
    rejected = log.status == GnssStatus.REJECTED
    rejected_innovations = log.innovation[rejected, :3], log.innovation_std_pos_ned_m[rejected]
    log.innovation[rejected] = log.innovation_std_pos_ned_m[rejected] = np.nan  # not used
    return InsResult(
        forward=forward,
        smoothed=smoothed,
        innovations_pos_ned_m=log.innovation[inside, :3],
        gnss_rejected_t_s=gnss.t_s[log.status == GnssStatus.REJECTED].copy(),
        innovations_t_s=gnss.t_s[inside].copy(),
        innovations_vel_ned_m_s=log.innovation[inside, 3:],
        innovation_std_pos_ned_m=log.innovation_std_pos_ned_m[inside],
        gnss_status=log.status,
        error_states=n_error_states,
        rejected_innovations_pos_ned_m=rejected_innovations[0],
        rejected_innovation_std_pos_ned_m=rejected_innovations[1],
    )
