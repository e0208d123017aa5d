"""Error-state filter (modified φ-angle model, turn-on bias, instability, scale factors): Φ,
error model, lever arm, χ² gate, feedback, biases, alignment."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from scipy.linalg import expm
from scipy.spatial.transform import Rotation
from scipy.stats import chi2

from kinsync.errors import InputError, ObservabilityError
from kinsync.frames import euler_rpy_to_quaternion, quaternion_to_matrix
from kinsync.ins._ekf import (
    N_ERR_SCALE,
    corrected_imu,
    feedback,
    system_matrix,
    transition_from_system,
)
from kinsync.ins._reference import forward_numpy
from kinsync.ins.alignment import align_static_gnss_heading, standstill_end_s
from kinsync.ins.config import InsConfig
from kinsync.ins.earth import OMEGA_IE_RAD_S, radii_m
from kinsync.ins.file_rows import FileRows
from kinsync.ins.filter import (
    GnssStatus,
    InsResult,
    filter_params,
    forward_pass,
    new_gnss_log,
    run_ins,
    transition_matrix,
)
from kinsync.ins.gnss_observation import gnss_epochs, observation
from kinsync.ins.measurements import GnssData, ImuData
from kinsync.ins.solution import InitialState, NavSolution
from kinsync.ins.strapdown import (
    I_BG,
    I_MG,
    check_imu_gaps,
    free_inertial,
    mech_step,
    start_epoch,
)

SimDrive = Callable[..., tuple[ImuData, ImuData, GnssData, NavSolution, InitialState]]
Errors = Callable[..., Any]  # fixture errors_of in conftest.py

GYRO_ARW = math.radians(0.1) / 60.0  # 0.1 deg/sqrt(h)
ACC_VRW = 0.05 / 60.0  # 0.05 m/s/sqrt(h)
BG = (math.radians(0.05), math.radians(-0.08), math.radians(0.06))
BA = (0.05, -0.08, 0.1)
CONFIG = InsConfig(
    gyro_arw_rad_s_rthz=GYRO_ARW,
    acc_vrw_m_s2_rthz=ACC_VRW,
    gyro_bias_sigma_rad_s=math.radians(0.1),
    acc_bias_sigma_m_s2=0.2,
    gyro_bias_instability_rad_s=1e-6,
    acc_bias_instability_m_s2=1e-5,
    gyro_bias_corr_time_s=3600.0,
    acc_bias_corr_time_s=3600.0,
    gnss_std_pos_ned_m=(0.5, 0.5, 1.0),
    gnss_std_vel_ned_m_s=(0.05, 0.05, 0.05),
    init_std_att_rad=(0.002, 0.002, 0.005),
    init_std_vel_ned_m_s=(0.05, 0.05, 0.05),
    init_std_pos_ned_m=(0.5, 0.5, 1.0),
)


def _state(
    lat: float = 0.8,
    h: float = 500.0,
    v: tuple[float, float, float] = (30.0, -20.0, 2.0),
    rpy: tuple[float, float, float] = (0.2, -0.3, 2.0),
) -> np.ndarray:
    s = np.zeros(28)
    s[0], s[1], s[2] = lat, 0.3, h
    s[3:6] = v
    s[6:10] = euler_rpy_to_quaternion(*rpy)
    s[10:13] = (1e-3, -2e-3, 5e-4)  # turn-on biases
    s[13:16] = (0.05, -0.1, 0.2)
    s[16:19] = (2e-5, 1e-5, -3e-5)  # instabilities
    s[19:22] = (1e-3, -2e-3, 5e-4)
    s[22:25] = (300e-6, -500e-6, 200e-6)  # scale factors
    s[25:28] = (-100e-6, 400e-6, 250e-6)
    return s


def _rot(rotvec: np.ndarray) -> np.ndarray:
    out: np.ndarray = Rotation.from_rotvec(rotvec).as_matrix()
    return out


def _error(nominal: np.ndarray, true: np.ndarray) -> np.ndarray:
    """Error state (27) of ``nominal`` relative to ``true``: the filter's definition, the
    exact inverse of the feedback (``true = nominal ⊖ x``)."""
    E = quaternion_to_matrix(nominal[6:10]) @ quaternion_to_matrix(true[6:10]).T
    phi = -Rotation.from_matrix(E).as_rotvec()  # C(nominal) = Rot(-φ) C(true)
    r_m, r_n = radii_m(true[0])
    return np.concatenate(
        [
            phi,
            nominal[3:6] - _rot(phi).T @ true[3:6],  # v(true) = Rot(φ) (v(nominal) - δv')
            [
                (nominal[0] - true[0]) * (r_m + true[2]),
                (nominal[1] - true[1]) * (r_n + true[2]) * math.cos(true[0]),
                -(nominal[2] - true[2]),
            ],
            true[10:28] - nominal[10:28],
        ]
    )


def _perturbed(true: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Nominal state with error ``x`` (the inverse of the feedback for one error kind)."""
    s = true.copy()
    feedback(s, -x, np.empty(4), np.empty(4), np.empty((3, 3)))
    return s


def _F(s: np.ndarray, gyro: np.ndarray, acc: np.ndarray, tau: float = 100.0) -> np.ndarray:
    F = np.zeros((N_ERR_SCALE, N_ERR_SCALE))
    w_b, f_b = np.empty(3), np.empty(3)
    corrected_imu(s, gyro, acc, w_b, f_b)
    system_matrix(s, w_b, f_b, tau, tau, np.empty((3, 3)), F)
    return F


@pytest.fixture(scope="module")
def drive(sim_drive: SimDrive) -> tuple[ImuData, ImuData, GnssData, NavSolution, InitialState]:
    return sim_drive(
        duration_s=240.0, static_s=20.0, seed=3, gyro_bias_rad_s=BG, acc_bias_m_s2=BA,
        gyro_arw=GYRO_ARW, acc_vrw=ACC_VRW,
    )  # fmt: skip


# ---------------------------------------------------------------------- Φ and F
def test_transition_matrix_matches_expm() -> None:
    F = _F(_state(), np.array([0.3, -0.2, 0.5]), np.array([2.0, -1.0, -9.5]))
    for dt in (0.005, 0.02, 0.1):
        Phi = transition_matrix(F, dt)
        ref = expm(F * dt)
        bound = np.linalg.norm(F * dt, 2) ** 3 / 6.0 * math.exp(np.linalg.norm(F * dt, 2))
        assert np.abs(Phi - ref).max() <= bound
        assert np.abs(Phi - ref).max() > 0.0  # second order, not exact
        kernel = np.zeros((N_ERR_SCALE, N_ERR_SCALE))
        transition_from_system(F, dt, kernel)  # the filter's structured version
        np.testing.assert_allclose(kernel, Phi, rtol=0, atol=1e-15)
    # third-order convergence: halving dt divides the truncation error by ~8
    e1 = np.abs(transition_matrix(F, 0.2) - expm(F * 0.2)).max()
    e2 = np.abs(transition_matrix(F, 0.1) - expm(F * 0.1)).max()
    assert 6.0 < e1 / e2 < 10.0


def test_transition_matrix_rejects_bad_input() -> None:
    with pytest.raises(InputError, match="square"):
        transition_matrix(np.zeros((3, 4)), 0.1)
    with pytest.raises(InputError, match="square"):
        transition_matrix(np.full((2, 2), np.nan), 0.1)
    with pytest.raises(InputError, match="dt_s"):
        transition_matrix(np.zeros((2, 2)), math.inf)


def test_error_model_matches_the_nonlinear_mechanisation() -> None:
    """Φ·x over one IMU step against the difference of two mechanised states."""
    true = _state()
    gyro = np.array([0.3, -0.2, 0.5])
    acc = np.array([2.0, -1.0, -9.5])
    dt = 0.01
    # the instabilities' decay is not part of the mechanisation (the filter applies it)
    Phi = transition_matrix(_F(true, gyro, acc, tau=1e12), dt)

    first = coning = True

    def step(s: np.ndarray) -> np.ndarray:
        s = s.copy()
        scratch = (np.empty(4), np.empty(4), np.empty((3, 3)))
        mech_step(s, np.zeros(6), gyro, acc, dt, first, coning, *scratch)
        return s

    true1 = step(true)
    eps = np.array([1e-5] * 3 + [1e-3] * 3 + [1.0] * 3 + ([1e-6] * 3 + [1e-4] * 3) * 2 + [1e-4] * 6)
    for i in range(N_ERR_SCALE):
        x = np.zeros(N_ERR_SCALE)
        x[i] = eps[i]
        nominal = _perturbed(true, x)
        np.testing.assert_allclose(_error(nominal, true), x, atol=1e-9 * eps[i] + 1e-13)
        e1 = _error(step(nominal), true1)
        pred = Phi @ x
        # agreement to a few per cent of the propagated error (remaining terms are
        # O(Δt³) or below the double-precision resolution of latitude/longitude)
        assert np.abs(e1 - pred).max() <= 0.02 * np.abs(pred).max() + 2e-9, i


# ---------------------------------------------------------------------- observations
def test_lever_arm_observation_geometry() -> None:
    """z = 0 when the GNSS sees the exact antenna; z ≈ H x for a small error x."""
    cfg = dataclasses.replace(CONFIG, antenna_lever_arm_body_m=(1.2, -0.4, -1.5))
    params = filter_params(cfg, use_velocity=True)
    true = _state(v=(12.0, 5.0, 0.5))
    gyro = np.array([0.05, -0.1, 0.3])
    C = quaternion_to_matrix(true[6:10])
    arm = np.array(cfg.antenna_lever_arm_body_m)
    arm_n = C @ arm
    r_m, r_n = radii_m(true[0])
    w = (gyro - true[10:13] - true[16:19]) / (1.0 + true[22:25])
    w_ie = np.array([OMEGA_IE_RAD_S * math.cos(true[0]), 0.0, -OMEGA_IE_RAD_S * math.sin(true[0])])
    g_llh = np.array(
        [
            true[0] + arm_n[0] / (r_m + true[2]),
            true[1] + arm_n[1] / ((r_n + true[2]) * math.cos(true[0])),
            true[2] - arm_n[2],
        ]
    )
    g_vel = true[3:6] + C @ np.cross(w, arm) - np.cross(w_ie, arm_n)
    H = np.zeros((6, N_ERR_SCALE))
    z = np.zeros(6)
    observation(true, gyro, params, 0.0, g_llh, g_vel, np.empty((3, 3)), H, z)
    np.testing.assert_allclose(z, 0.0, atol=1e-8)
    rng = np.random.default_rng(1)
    scale = np.array(
        [1e-4] * 3 + [1e-2] * 3 + [0.5] * 3 + ([1e-4] * 3 + [1e-2] * 3) * 2 + [1e-3] * 6
    )
    for _ in range(5):
        x = rng.normal(0.0, 1.0, N_ERR_SCALE) * scale
        zx = np.zeros(6)
        observation(_perturbed(true, x), gyro, params, 0.0, g_llh, g_vel, np.empty((3, 3)), H, zx)
        np.testing.assert_allclose(zx, H @ x, atol=1e-3 * np.abs(H @ x).max())
    # the time shift of the GNSS epoch is applied with the INS velocity
    observation(true, gyro, params, 0.004, g_llh, g_vel, np.empty((3, 3)), H, z)
    np.testing.assert_allclose(z[:3], -0.004 * true[3:6], atol=1e-8)


def test_lever_arm_is_needed_end_to_end(sim_drive: SimDrive, errors_of: Errors) -> None:
    arm = (1.5, -0.5, -1.8)
    _, imu, gnss, truth, init = sim_drive(
        duration_s=90.0, seed=4, gyro_arw=GYRO_ARW, acc_vrw=ACC_VRW, lever_arm_body_m=arm
    )
    with_arm = run_ins(imu, gnss, dataclasses.replace(CONFIG, antenna_lever_arm_body_m=arm), init)
    pos_ok = np.sqrt(np.mean(errors_of(with_arm.forward, truth)[0] ** 2, axis=0))
    assert (pos_ok < 0.3).all()
    assert with_arm.warnings == ()
    # without it the IMU and the GNSS disagree: the gate rejects too many epochs (41 %)
    with pytest.raises(InputError, match=r"chi-square gate rejected .*antenna lever arm"):
        run_ins(imu, gnss, CONFIG, init)


# ---------------------------------------------------------------------- gate, feedback
def test_gate_rejects_a_100_m_outlier(drive: Any, errors_of: Errors) -> None:
    _, imu, gnss, truth, init = drive
    j = 700  # 140 s, while driving
    lat = gnss.lat_deg.copy()
    lat[j] += np.degrees(100.0 / 6.37e6)  # 100 m north
    bad = dataclasses.replace(gnss, lat_deg=lat)
    res = run_ins(imu, bad, CONFIG, init)
    assert res.gnss_rejected_t_s.tolist() == [gnss.t_s[j]]
    assert res.forward.n_gnss_rejected == 1
    assert res.forward.n_gnss_used == len(gnss) - 1
    assert np.isnan(res.innovations_pos_ned_m[j]).all()
    assert np.isnan(res.innovations_vel_ned_m_s[j]).all()
    assert res.gnss_status[j] == GnssStatus.REJECTED
    assert np.isfinite(np.delete(res.innovations_pos_ned_m, j, axis=0)).all()
    dpos = errors_of(res.forward, truth)[0]
    k = int(np.searchsorted(res.forward.t_s, gnss.t_s[j]))
    assert np.abs(dpos[k - 5 : k + 50]).max() < 1.0  # the solution did not jump


GATE_EPOCH = 700
"""GNSS epoch (140 s, while driving) where the gate tests place their outliers."""


@pytest.fixture(scope="module")
def gate_prior(drive: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``z`` (6,) and the predicted ``S`` of the position and velocity blocks (3, 3) of
    GNSS epoch `GATE_EPOCH`, from the forward pass's checkpoint of that update (the
    ``P^-``, ``H``, ``r`` and ``z`` the gate saw)."""
    _, imu, gnss, _, init = drive
    g_epoch = gnss_epochs(imu.t_s, start_epoch(imu, init), gnss.t_s)
    run = forward_pass(
        imu, gnss, CONFIG, init, use_velocity=True, store=True, progress=None,
        gnss_imu_epoch=g_epoch, log=new_gnss_log(len(gnss)),
    )  # fmt: skip
    ck = run.checkpoints
    assert ck is not None
    update = np.flatnonzero((ck.epoch == g_epoch[GATE_EPOCH]) & (ck.nrows == 6))
    assert update.size == 1, "the filter did not use GNSS epoch GATE_EPOCH"
    c = int(update[0])
    S = ck.H[c] @ ck.P_minus[c] @ ck.H[c].T + np.diag(ck.r[c])
    return ck.z[c].copy(), S[:3, :3], S[3:, 3:]


def _chi2_stat(nu: np.ndarray, S: np.ndarray) -> float:
    return float(nu @ np.linalg.solve(S, nu))


@pytest.mark.parametrize("block", ["position", "velocity"])
@pytest.mark.parametrize(
    ("scale", "expected"),
    [
        pytest.param(0.95, GnssStatus.USED, id="just_inside"),
        pytest.param(1.05, GnssStatus.REJECTED, id="just_outside"),
    ],
)
def test_gate_threshold_is_chi2_3_dof_at_the_gate_probability(
    drive: Any,
    gate_prior: tuple[np.ndarray, np.ndarray, np.ndarray],
    block: str,
    scale: float,
    expected: GnssStatus,
) -> None:
    """An outlier placed so that ``ν^T S^{-1} ν = 0.95 χ²₃(p)`` is used, one at
    ``1.05 χ²₃(p)`` is rejected. A threshold with other degrees of freedom (2: 0.87 χ²₃(p),
    4: 1.11, 6: 1.32), at ``1 - p``, or a gate on a single axis (each axis carries about a
    third of the statistic here, below even χ²₁(p)) gets one of the cases wrong."""
    _, imu, gnss, _, init = drive
    j = GATE_EPOCH
    z, S_pos, S_vel = gate_prior
    gate = float(chi2.ppf(CONFIG.gate_probability, 3))
    rows = slice(0, 3) if block == "position" else slice(3, 6)
    S = S_pos if block == "position" else S_vel
    # the other block of this epoch passes by far
    if block == "position":
        assert _chi2_stat(z[3:], S_vel) < 0.5 * gate
    else:
        assert _chi2_stat(z[:3], S_pos) < 0.5 * gate
    # z (INS minus GNSS) that the outlier should produce: equal shares in whitened space
    target = np.linalg.cholesky(S) @ np.full(3, math.sqrt(scale * gate / 3.0))
    assert _chi2_stat(target, S) == pytest.approx(scale * gate, rel=1e-12)
    assert (target**2 / np.diag(S)).max() < chi2.ppf(CONFIG.gate_probability, 1)
    dz = target - z[rows]
    if block == "position":
        lat = math.radians(gnss.lat_deg[j])
        r_m, r_n = radii_m(lat)
        h = gnss.h_m[j]
        lat_deg, lon_deg, h_m = gnss.lat_deg.copy(), gnss.lon_deg.copy(), gnss.h_m.copy()
        lat_deg[j] -= math.degrees(dz[0] / (r_m + h))
        lon_deg[j] -= math.degrees(dz[1] / ((r_n + h) * math.cos(lat)))
        h_m[j] += dz[2]
        bad = dataclasses.replace(gnss, lat_deg=lat_deg, lon_deg=lon_deg, h_m=h_m)
    else:
        assert gnss.vel_ned_m_s is not None
        vel = gnss.vel_ned_m_s.copy()
        vel[j] -= dz
        bad = dataclasses.replace(gnss, vel_ned_m_s=vel)
    res = run_ins(imu, bad, CONFIG, init)
    assert res.gnss_status[j] == expected
    assert (res.gnss_status[:j] == GnssStatus.USED).all()
    if expected == GnssStatus.USED:  # the outlier produced the intended innovation
        innov = res.innovations_pos_ned_m if block == "position" else res.innovations_vel_ned_m_s
        np.testing.assert_allclose(-innov[j], target, rtol=0, atol=1e-5 * np.abs(target).max())
    else:
        assert res.gnss_rejected_t_s.tolist() == [gnss.t_s[j]]


def test_innovations_are_consistent(drive: Any) -> None:
    _, imu, gnss, _, init = drive
    res = run_ins(imu, gnss, CONFIG, init)
    nu = res.innovations_pos_ned_m[10:] / res.innovation_std_pos_ned_m[10:]
    assert res.innovations_t_s.shape == (len(gnss),)
    assert 0.8 < float(np.mean(nu**2)) < 1.2  # normalised innovations have unit variance
    assert np.abs(np.mean(nu, axis=0)).max() < 0.1


def test_closed_loop_feedback_resets_the_error_state(drive: Any) -> None:
    """Between two updates the forward solution is the pure mechanisation of the state
    left by the last update (with its bias estimates): nothing is applied twice."""
    _, imu, gnss, _, init = drive
    res = run_ins(imu, gnss, CONFIG, init).forward
    k = int(np.searchsorted(res.t_s, gnss.t_s[600]))
    restart = InitialState(
        t_s=float(res.t_s[k]),
        lat_deg=float(res.lat_deg[k]),
        lon_deg=float(res.lon_deg[k]),
        h_m=float(res.h_m[k]),
        vel_ned_m_s=tuple(res.vel_ned_m_s[k]),
        rpy_rad=tuple(res.rpy_rad[k]),
        gyro_bias_rad_s=tuple(res.gyro_bias_rad_s[k]),
        acc_bias_m_s2=tuple(res.acc_bias_m_s2[k]),
    )
    free = free_inertial(imu, restart)
    m = 20  # IMU epochs up to the next GNSS epoch (100 Hz / 5 Hz)
    np.testing.assert_allclose(free.lat_deg[1:m], res.lat_deg[k + 1 : k + m], rtol=0, atol=1e-10)
    np.testing.assert_allclose(free.vel_ned_m_s[1:m], res.vel_ned_m_s[k + 1 : k + m], atol=1e-7)
    np.testing.assert_allclose(free.rpy_rad[1:m], res.rpy_rad[k + 1 : k + m], atol=1e-9)
    # ... and the update at k + m moved the state away from the free run
    jump = abs(free.vel_ned_m_s[m] - res.vel_ned_m_s[k + m]).max()
    assert jump > 1e-5
    # the turn-on bias estimates only change at updates; the instability estimates decay
    # between them as their Gauss-Markov model says
    g_epoch = gnss_epochs(imu.t_s, start_epoch(imu, init), gnss.t_s)
    run = forward_pass(
        imu, gnss, CONFIG, init, use_velocity=True, store=False, progress=None,
        gnss_imu_epoch=g_epoch, log=new_gnss_log(len(gnss)),
    )  # fmt: skip
    kk = start_epoch(imu, init) + k
    turn_on = run.states[kk : kk + m, I_BG : I_BG + 3]
    assert (turn_on == turn_on[0]).all()
    inst = run.states[kk : kk + m, I_MG : I_MG + 3]
    assert np.abs(inst[0]).min() > 0.0
    decay = math.exp(-float(np.diff(imu.t_s[:2])[0]) / CONFIG.gyro_bias_corr_time_s)
    np.testing.assert_allclose(inst[1:], inst[:-1] * decay, rtol=1e-12)


def test_feedback_inverts_the_error_definition() -> None:
    true = _state()
    x = np.array(
        [1e-3, -2e-3, 3e-3, 0.1, -0.2, 0.05, 3.0, -4.0, 1.5, 1e-4, -1e-4, 2e-4, 0.01, 0.02, -0.03,
         2e-6, -1e-6, 3e-6, 1e-4, -2e-4, 3e-4, 5e-5, -6e-5, 7e-5, -1e-4, 2e-4, 3e-5]
    )  # fmt: skip
    nominal = _perturbed(true, x)
    # one feedback and its inverse agree but for the second-order term φ × δv'
    second_order = float(np.linalg.norm(x[:3]) * np.linalg.norm(x[3:6]))
    err = _error(nominal, true)
    assert np.abs(err[3:6] - x[3:6]).max() <= second_order
    np.testing.assert_allclose(np.delete(err, [3, 4, 5]), np.delete(x, [3, 4, 5]), atol=1e-9)
    back = nominal.copy()
    feedback(back, _error(nominal, true), np.empty(4), np.empty(4), np.empty((3, 3)))
    np.testing.assert_allclose(back[3:], true[3:], atol=1e-12)  # exact inverse
    np.testing.assert_allclose(back[:2], true[:2], atol=1e-14)
    assert back[2] == pytest.approx(true[2], abs=1e-9)


# ---------------------------------------------------------------------- simulation
def test_injected_biases_are_recovered(drive: Any, errors_of: Errors) -> None:
    _, imu, gnss, truth, init = drive
    res = run_ins(imu, gnss, CONFIG, init)
    sol = res.forward
    for est, sd, true, tol in (
        (sol.gyro_bias_rad_s[-1], sol.std_gyro_bias_rad_s[-1], BG, math.radians(0.002)),
        (sol.acc_bias_m_s2[-1], sol.std_acc_bias_m_s2[-1], BA, 0.003),
    ):
        err = est - np.asarray(true)
        assert (np.abs(err) <= 3.0 * sd).all(), (err, sd)
        assert (np.abs(err) < tol).all(), err
    dpos, dvel, datt = errors_of(sol, truth)
    assert np.sqrt(np.mean(dpos**2, axis=0)).max() < 0.3
    assert np.degrees(np.sqrt(np.mean(datt[2000:] ** 2, axis=0))).max() < 0.3
    # reported σ against actual errors: normalised errors of unit size (they are
    # correlated in time, so one run's share inside 3σ scatters; ≥ 0.99 on most seeds)
    z = np.abs(np.column_stack([dpos, dvel, datt])) / np.column_stack(
        [sol.std_pos_ned_m, sol.std_vel_ned_m_s, sol.std_att_rad]
    )
    assert (z <= 3.0).mean(axis=0).min() > 0.9
    rms_z = np.sqrt(np.mean(z**2, axis=0))
    assert (rms_z > 0.5).all()
    assert (rms_z < 1.6).all()


def test_position_only_and_nan_sigma_defaults(drive: Any) -> None:
    _, imu, gnss, _, init = drive
    nan_std = dataclasses.replace(
        gnss, std_pos_ned_m=np.full((len(gnss), 3), np.nan), std_vel_ned_m_s=None
    )
    explicit = dataclasses.replace(
        gnss,
        std_pos_ned_m=np.tile(CONFIG.gnss_std_pos_ned_m, (len(gnss), 1)),
        std_vel_ned_m_s=np.tile(CONFIG.gnss_std_vel_ned_m_s, (len(gnss), 1)),
    )
    a = run_ins(imu, nan_std, CONFIG, init).forward
    b = run_ins(imu, explicit, CONFIG, init).forward
    np.testing.assert_array_equal(a.lat_deg, b.lat_deg)
    pos_only = run_ins(imu, gnss, CONFIG, init, use_velocity=False)
    assert np.isnan(pos_only.innovations_vel_ned_m_s).all()
    assert not np.array_equal(pos_only.forward.lat_deg, b.lat_deg)
    no_vel = run_ins(
        imu, dataclasses.replace(gnss, vel_ned_m_s=None, std_vel_ned_m_s=None), CONFIG, init
    )
    np.testing.assert_array_equal(no_vel.forward.lat_deg, pos_only.forward.lat_deg)


def test_gnss_outside_the_span_is_ignored_and_progress_reported(drive: Any) -> None:
    _, imu, gnss, _, _ = drive
    k0 = 1000  # start 10 s into the record
    truth_free = free_inertial(drive[0], drive[4])
    init = InitialState(
        t_s=float(imu.t_s[k0]),
        lat_deg=float(truth_free.lat_deg[k0]),
        lon_deg=float(truth_free.lon_deg[k0]),
        h_m=float(truth_free.h_m[k0]),
        vel_ned_m_s=tuple(truth_free.vel_ned_m_s[k0]),
        rpy_rad=tuple(truth_free.rpy_rad[k0]),
    )
    reports: list[tuple[float, str]] = []
    res = run_ins(imu, gnss, CONFIG, init, progress=lambda f, stage: reports.append((f, stage)))
    before = gnss.t_s < imu.t_s[k0] - 0.005
    assert (res.gnss_status[before] == GnssStatus.OUTSIDE).all()
    assert res.forward.n_gnss_used == int(np.count_nonzero(~before))
    assert res.innovations_pos_ned_m.shape == (int(np.count_nonzero(~before)), 3)
    assert len(res.forward) == len(imu) - k0
    assert res.forward.t_s[0] == imu.t_s[k0]
    fractions = [f for f, _ in reports]
    assert fractions == sorted(fractions)
    assert fractions[0] == 0.0
    assert fractions[-1] == 1.0
    assert len(fractions) == 1 + math.ceil((len(imu) - k0) / 10_000)  # the start, each chunk
    assert {stage for _, stage in reports} == {"filter"}
    smooth: list[tuple[float, str]] = []
    run_ins(imu, gnss, CONFIG, init, smooth=True, progress=lambda f, s: smooth.append((f, s)))
    smooth_fr = [f for f, _ in smooth]
    assert smooth_fr == sorted(smooth_fr)
    assert smooth_fr[-1] == 1.0
    assert max(f for f, stage in smooth if stage == "filter") == 0.5  # the first half
    assert min(f for f, stage in smooth if stage == "smoother") == 0.5
    assert [s for _, s in smooth] == sorted(s for _, s in smooth)  # filter, then smoother


def test_bad_inputs(drive: Any) -> None:
    _, imu, gnss, _, init = drive
    t = imu.t_s.copy()
    t[5000:] += 0.5
    gap = ImuData(t, imu.gyro_body_rad_s, imu.acc_body_m_s2)
    with pytest.raises(InputError, match=r"1 gap\(s\) between IMU samples.*rows 4999 and 5000"):
        run_ins(gap, gnss, CONFIG, init)
    with pytest.raises(InputError, match=r"IMU gap of 0\.51.*row 5000"):
        check_imu_gaps(gap, 0, CONFIG.max_imu_gap_s)
    with pytest.raises(InputError, match="not an IMU sample time"):
        run_ins(imu, gnss, CONFIG, dataclasses.replace(init, t_s=1e6))
    with pytest.raises(InputError, match="ImuData"):
        run_ins(gnss, gnss, CONFIG, init)
    diverge = ImuData(imu.t_s, imu.gyro_body_rad_s * 1e6, imu.acc_body_m_s2 * 1e6)
    with pytest.raises(InputError, match="far from gravity"):  # the input checks refuse it
        run_ins(diverge, gnss, CONFIG, init)
    with pytest.raises(InputError, match=r"diverged|non-finite"):
        forward_pass(
            diverge, gnss, CONFIG, init, use_velocity=True, store=False, progress=None,
            gnss_imu_epoch=gnss_epochs(imu.t_s, start_epoch(imu, init), gnss.t_s),
            log=new_gnss_log(len(gnss)),
        )  # fmt: skip


def test_a_missing_init_or_config_is_refused_naming_it(drive: Any) -> None:
    _, imu, gnss, _, init = drive
    with pytest.raises(InputError, match=r"run_ins: init must be an InitialState, got NoneType"):
        run_ins(imu, gnss, CONFIG, None)  # type: ignore[arg-type]
    with pytest.raises(InputError, match=r"run_ins: config must be an InsConfig .*got dict"):
        run_ins(imu, gnss, {}, init)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("argument", "value"),
    [
        ("antenna_lever_arm_body_m", [0.0, 0.0]),
        ("antenna_lever_arm_body_m", (0.0, math.nan, 0.0)),
        ("antenna_lever_arm_body_m", "0.5,0,0"),
        ("gyro_bias_rad_s", [[0.0, 0.0, 0.0]]),
        ("acc_bias_m_s2", (0.0, 0.0, 0.0, 0.0)),
    ],
)
def test_alignment_refuses_a_vector_that_is_not_three_numbers(
    drive: Any, argument: str, value: object
) -> None:
    _, imu, gnss, _, _ = drive
    with pytest.raises(InputError, match=f"align_static_gnss_heading: {argument}: expected 3"):
        align_static_gnss_heading(imu, gnss, static_s=15.0, **{argument: value})  # type: ignore[arg-type]


def test_result_is_frozen(drive: Any) -> None:
    _, imu, gnss, _, init = drive
    res = run_ins(imu, gnss, CONFIG, init)
    assert isinstance(res, InsResult)
    assert res.smoothed is None
    with pytest.raises(dataclasses.FrozenInstanceError):
        res.forward = res.forward  # type: ignore[misc]


# ---------------------------------------------------------------------- alignment
def test_static_levelling_and_gnss_heading(sim_drive: SimDrive) -> None:
    _, imu, gnss, truth, _ = sim_drive(
        duration_s=60.0, static_s=20.0, seed=5, gyro_bias_rad_s=BG, acc_bias_m_s2=BA,
        gyro_arw=GYRO_ARW, acc_vrw=ACC_VRW, lever_arm_body_m=(0.5, 0.2, -1.0),
    )  # fmt: skip
    init = align_static_gnss_heading(
        imu, gnss, static_s=15.0, antenna_lever_arm_body_m=(0.5, 0.2, -1.0)
    )
    k = int(np.searchsorted(truth.t_s, init.t_s))
    assert init.t_s == imu.t_s[0]  # static: the state holds from the first epoch on
    assert init.levelling_std_rad is not None
    assert init.gyro_bias_std_rad_s is not None
    # accelerometer biases tilt the levelling by b/g (0.5 deg here); heading within 0.3 deg
    expect_roll = truth.rpy_rad[k, 0] - BA[1] / 9.81
    expect_pitch = truth.rpy_rad[k, 1] + BA[0] / 9.81
    assert init.rpy_rad[0] == pytest.approx(expect_roll, abs=2e-3)
    assert init.rpy_rad[1] == pytest.approx(expect_pitch, abs=2e-3)
    assert abs(init.rpy_rad[2] - truth.rpy_rad[k, 2]) < math.radians(0.3)
    np.testing.assert_allclose(init.gyro_bias_rad_s, BG, atol=math.radians(0.003))
    r_m, _ = radii_m(math.radians(truth.lat_deg[k]))
    assert abs(math.radians(init.lat_deg - truth.lat_deg[k]) * r_m) < 0.5  # 75 fixes of 0.5 m
    assert init.vel_ned_m_s == (0.0, 0.0, 0.0)
    # without GNSS velocities the heading comes from the displacement
    no_vel = dataclasses.replace(gnss, vel_ned_m_s=None, std_vel_ned_m_s=None)
    init2 = align_static_gnss_heading(imu, no_vel, static_s=15.0)
    assert abs(init2.rpy_rad[2] - truth.rpy_rad[k, 2]) < math.radians(3.0)
    # and the filter runs from it
    res = run_ins(
        imu,
        gnss,
        dataclasses.replace(
            CONFIG, antenna_lever_arm_body_m=(0.5, 0.2, -1.0), init_std_att_rad=(0.02, 0.02, 0.02)
        ),
        init,
    )
    assert res.forward.n_gnss_rejected == 0


def test_alignment_errors(sim_drive: SimDrive) -> None:
    _, moving, gnss_m, _, _ = sim_drive(duration_s=30.0, static_s=0.0, seed=6)
    # Each names the command line's way round (it named the Python API's only).
    with pytest.raises(ObservabilityError, match=r"no static start.*\(--static-s\).*--init-from"):
        align_static_gnss_heading(moving, gnss_m, static_s=5.0)
    _, still, gnss_s, _, _ = sim_drive(duration_s=30.0, static_s=40.0, seed=7)
    with pytest.raises(ObservabilityError, match=r"no motion.*--init-from"):
        align_static_gnss_heading(still, gnss_s, static_s=5.0)
    with pytest.raises(ObservabilityError, match=r"no motion.*--init-from"):
        align_static_gnss_heading(
            still, dataclasses.replace(gnss_s, vel_ned_m_s=None), static_s=5.0
        )
    late = dataclasses.replace(gnss_s, t_s=gnss_s.t_s + 20.0)
    with pytest.raises(
        ObservabilityError, match=r"no GNSS fix during the static period.*--static-s.*--init-from"
    ):
        align_static_gnss_heading(still, late, static_s=5.0)
    # Review N3: 18 s late (UTC vs GPS) named no file, no row and no time offset.
    utc = dataclasses.replace(gnss_s, t_s=gnss_s.t_s + 18.0)
    with pytest.raises(ObservabilityError) as info:
        align_static_gnss_heading(
            still, utc, static_s=5.0, gnss_source="rx.csv", gnss_rows=FileRows(lambda r: r + 2)
        )
    message = str(info.value)
    assert message.startswith("rx.csv: no GNSS fix during the static period")
    first = f"The first fix is at t_s {utc.t_s[0]:.3f} (row 0, line 2), 18.000 s after"
    assert first in message
    assert "GNSS times late against the IMU's? 18 s is what GPS time runs ahead of UTC" in message
    assert "--init-from" in message
    with pytest.raises(ObservabilityError, match=r"t_s [0-9.]+ \(row 0\), 20\.000 s after.*offset"):
        align_static_gnss_heading(still, late, static_s=5.0)
    with pytest.raises(ObservabilityError, match=r"shorter than the static period.*--static-s"):
        align_static_gnss_heading(still, gnss_s, static_s=100.0)
    with pytest.raises(InputError, match="static_s"):
        align_static_gnss_heading(still, gnss_s, static_s=-1.0)
    # Rates in deg/s at rest: the accelerometers and the GNSS say at rest, the gyros don't.
    _, drive, gnss_d, _, _ = sim_drive(duration_s=30.0, static_s=10.0, seed=8, gyro_arw=1e-4)
    in_deg = dataclasses.replace(drive, gyro_body_rad_s=np.degrees(drive.gyro_body_rad_s))
    align_static_gnss_heading(drive, gnss_d, static_s=5.0)  # in rad/s it levels
    with pytest.raises(ObservabilityError, match=r"show a vehicle at rest, but the gyro .*deg/s"):
        align_static_gnss_heading(in_deg, gnss_d, static_s=5.0)


@pytest.mark.parametrize("scale_ppm", [0.0, 500.0], ids=["21_states", "27_states"])
def test_compiled_loop_matches_the_numpy_reference(sim_drive: SimDrive, scale_ppm: float) -> None:
    """Dense numpy products and joint updates give the structured, sequential loop's numbers."""
    arm = (1.0, -0.5, -1.5)
    _, imu, gnss, _, init = sim_drive(
        duration_s=20.0, seed=2, gyro_bias_rad_s=BG, acc_bias_m_s2=BA, gyro_arw=GYRO_ARW,
        acc_vrw=ACC_VRW, lever_arm_body_m=arm,
    )  # fmt: skip
    cfg = dataclasses.replace(
        CONFIG,
        antenna_lever_arm_body_m=arm,
        gyro_scale_factor_sigma_ppm=scale_ppm,
        acc_scale_factor_sigma_ppm=scale_ppm,
        gyro_bias_corr_time_s=60.0,  # the instability's decay must show in 15 s
    )
    n = 1500
    states, std = forward_numpy(imu, gnss, cfg, init, n)
    fwd = run_ins(imu, gnss, cfg, init).forward
    np.testing.assert_allclose(np.degrees(states[:, 0]), fwd.lat_deg[:n], rtol=0, atol=1e-12)
    np.testing.assert_allclose(states[:, 2], fwd.h_m[:n], rtol=0, atol=1e-9)
    np.testing.assert_allclose(states[:, 3:6], fwd.vel_ned_m_s[:n], rtol=0, atol=1e-9)
    np.testing.assert_allclose(
        states[:, 10:13] + states[:, 16:19], fwd.gyro_bias_rad_s[:n], rtol=0, atol=1e-12
    )
    np.testing.assert_allclose(
        states[:, 13:16] + states[:, 19:22], fwd.acc_bias_m_s2[:n], rtol=0, atol=1e-10
    )
    assert np.abs(states[-1, 16:19]).max() > 0.0  # the instability states took part
    columns = [
        fwd.std_att_rad,
        fwd.std_vel_ned_m_s,
        fwd.std_pos_ned_m,
        fwd.std_gyro_bias_rad_s,
        fwd.std_acc_bias_m_s2,
    ]
    if scale_ppm:
        assert fwd.gyro_scale_ppm is not None
        assert fwd.acc_scale_ppm is not None
        assert fwd.std_gyro_scale_ppm is not None
        assert fwd.std_acc_scale_ppm is not None
        np.testing.assert_allclose(states[:, 22:25] * 1e6, fwd.gyro_scale_ppm[:n], atol=1e-6)
        np.testing.assert_allclose(states[:, 25:28] * 1e6, fwd.acc_scale_ppm[:n], atol=1e-6)
        columns += [fwd.std_gyro_scale_ppm * 1e-6, fwd.std_acc_scale_ppm * 1e-6]
    else:
        assert fwd.gyro_scale_ppm is None
        assert np.isnan(std[:, 15:]).all()
    sd_fwd = np.column_stack(columns)
    np.testing.assert_allclose(std[:, : sd_fwd.shape[1]], sd_fwd[:n], rtol=1e-9)


# ---------------------------------------------------------------------- calibrated biases
def test_calibrated_turn_on_biases_from_the_configuration(drive: Any, errors_of: Errors) -> None:
    """``[init]`` biases with their σ equal the same biases in the initial state with the
    turn-on σ set to that σ; knowing them helps early on; two different values are refused."""
    _, imu, gnss, truth, init = drive
    sig_g, sig_a = math.radians(0.002), 0.002
    via_config = dataclasses.replace(
        CONFIG,
        init_gyro_bias_rad_s=BG,
        init_gyro_bias_std_rad_s=(sig_g,) * 3,
        init_acc_bias_m_s2=BA,
        init_acc_bias_std_m_s2=(sig_a,) * 3,
    )
    a = run_ins(imu, gnss, via_config, init).forward
    b = run_ins(
        imu,
        gnss,
        dataclasses.replace(CONFIG, gyro_bias_sigma_rad_s=sig_g, acc_bias_sigma_m_s2=sig_a),
        dataclasses.replace(init, gyro_bias_rad_s=BG, acc_bias_m_s2=BA),
    ).forward
    for name in (
        "lat_deg",
        "h_m",
        "rpy_rad",
        "gyro_bias_rad_s",
        "std_att_rad",
        "std_gyro_bias_rad_s",
    ):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    # the total bias: the calibration's σ and the instability's
    total_g = math.hypot(sig_g, CONFIG.gyro_bias_instability_rad_s)
    total_a = math.hypot(sig_a, CONFIG.acc_bias_instability_m_s2)
    np.testing.assert_allclose(a.std_gyro_bias_rad_s[0], total_g, rtol=1e-6)
    np.testing.assert_allclose(a.std_acc_bias_m_s2[0], total_a, rtol=1e-6)
    estimated = run_ins(imu, gnss, CONFIG, init).forward
    early = slice(0, 6000)  # the first minute: the static start and the drive-off
    att_known = np.sqrt(np.mean(errors_of(a, truth)[2][early] ** 2))
    att_estimated = np.sqrt(np.mean(errors_of(estimated, truth)[2][early] ** 2))
    assert att_known < 0.5 * att_estimated
    twice = run_ins(imu, gnss, via_config, dataclasses.replace(init, gyro_bias_rad_s=BG))
    np.testing.assert_array_equal(twice.forward.rpy_rad, a.rpy_rad)  # the same value twice
    other = tuple(2.0 * b for b in BG)
    with pytest.raises(InputError, match=r"gyro turn-on bias differs .*give it in one place"):
        run_ins(imu, gnss, via_config, dataclasses.replace(init, gyro_bias_rad_s=other))


def test_the_standstill_ends_when_the_vehicle_moves(sim_drive: SimDrive) -> None:
    """The filter keeps the levelled attitude in its Jacobian until the vehicle moves
    (`InitialState.static_until_s`): here it stands for 20 s, then drives off."""
    _, imu, gnss, _, _ = sim_drive(
        duration_s=60.0, static_s=20.0, seed=5, gyro_bias_rad_s=BG, acc_bias_m_s2=BA,
        gyro_arw=GYRO_ARW, acc_vrw=ACC_VRW, lever_arm_body_m=(0.5, 0.2, -1.0),
    )  # fmt: skip
    init = align_static_gnss_heading(
        imu, gnss, static_s=15.0, antenna_lever_arm_body_m=(0.5, 0.2, -1.0)
    )
    assert init.static_until_s is not None
    assert 20.0 <= init.static_until_s - imu.t_s[0] <= 21.0
    # from the IMU alone (no GNSS velocities) too
    no_vel = dataclasses.replace(gnss, vel_ned_m_s=None, std_vel_ned_m_s=None)
    k_end = int(np.searchsorted(imu.t_s, imu.t_s[0] + 15.0))
    assert 20.0 <= standstill_end_s(imu, no_vel, k_end) - imu.t_s[0] <= 21.0
    # a record that never moves stands still to its end
    still = dataclasses.replace(
        imu,
        t_s=imu.t_s[: k_end + 300],
        gyro_body_rad_s=imu.gyro_body_rad_s[: k_end + 300],
        acc_body_m_s2=imu.acc_body_m_s2[: k_end + 300],
    )
    assert standstill_end_s(still, gnss, k_end) == still.t_s[-1]


@pytest.mark.parametrize("velocities", [True, False])
def test_static_alignment_on_the_antimeridian(sim_drive: SimDrive, velocities: bool) -> None:
    """Review L3: the plain mean of fixes either side of 180 deg put the start at 0 deg."""
    _, imu, gnss, _, _ = sim_drive(duration_s=60.0, static_s=20.0, seed=5)
    if not velocities:
        gnss = dataclasses.replace(gnss, vel_ned_m_s=None, std_vel_ned_m_s=None)
    init = align_static_gnss_heading(imu, gnss, static_s=15.0)
    static_lon = float(np.median(gnss.lon_deg[gnss.t_s <= imu.t_s[0] + 15.0]))
    # the same drive moved east so that the static fixes straddle 180 deg
    moved = (gnss.lon_deg - static_lon + 180.0 + 180.0) % 360.0 - 180.0
    assert moved.min() < -179.0
    assert moved.max() > 179.0
    across = align_static_gnss_heading(imu, dataclasses.replace(gnss, lon_deg=moved), static_s=15.0)
    shift = (across.lon_deg - (init.lon_deg - static_lon + 180.0) + 180.0) % 360.0 - 180.0
    _, r_n = radii_m(math.radians(init.lat_deg))
    assert abs(math.radians(shift) * r_n * math.cos(math.radians(init.lat_deg))) < 1e-3
    assert across.lat_deg == pytest.approx(init.lat_deg, abs=1e-9)
    np.testing.assert_allclose(across.rpy_rad, init.rpy_rad, rtol=0, atol=1e-6)
