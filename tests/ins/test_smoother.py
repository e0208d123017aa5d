"""RTS smoother: equals batch least squares on a linear model, never less certain than the
forward filter, better than it on a simulated drive, a no-op without measurements, and
rebuilds the forward covariance exactly after a levelled standstill."""

from __future__ import annotations

import dataclasses
import math
import tracemalloc
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from kinsync.errors import InputError
from kinsync.ins._ekf import (
    N_ERR,
    N_ERR_SCALE,
    X_BA,
    X_BG,
    X_MA,
    X_MG,
    propagate_cov,
    scalar_update,
)
from kinsync.ins.alignment import align_static_gnss_heading
from kinsync.ins.config import InsConfig
from kinsync.ins.filter import (
    GnssStatus,
    forward_pass,
    new_gnss_log,
    run_ins,
    transition_matrix,
)
from kinsync.ins.forward_run import Checkpoints
from kinsync.ins.gnss_observation import gnss_epochs
from kinsync.ins.measurements import GnssData, ImuData
from kinsync.ins.smoother import (
    SmoothedCovariance,
    ins_matrices,
    new_smoothed_covariance,
    smooth_checkpoints,
    smooth_forward_run,
)
from kinsync.ins.solution import InitialState, NavSolution
from kinsync.ins.strapdown import nav_solution_from_states, start_epoch
from kinsync.sim.drive import DriveSimConfig, simulate_drive

SimDrive = Callable[..., tuple[ImuData, ImuData, GnssData, NavSolution, InitialState]]
Errors = Callable[..., Any]  # fixture errors_of in conftest.py

N_EPOCHS = 41
MEAS = {0: 3, 5: 6, 10: 3, 11: 6, 20: 6, 20.5: 3, 33: 6, 40: 3}
"""Epoch -> rows; 20.5 is a second measurement at epoch 20 (two checkpoints, one epoch)."""
FORCED = (26,)  # a plain checkpoint without measurement


N = N_ERR
"""States of the linear model: the filter's 21 (navigation block dense, sensor rows
diagonal)."""


def _linear_model(rng: np.random.Generator) -> dict[str, Any]:
    """A 21-state linear model with the INS block structure of F (sensor rows diagonal)
    and of Q (a dense 6×6 attitude-velocity block plus a diagonal)."""
    dt = 0.1
    Phis = np.zeros((N_EPOCHS, N, N))
    for k in range(N_EPOCHS):
        F = np.zeros((N, N))
        F[:9, :] = rng.normal(0.0, 0.3, (9, N))
        for i in range(9, N):
            F[i, i] = -1.0 / rng.uniform(20.0, 200.0)
        Phis[k] = transition_matrix(F, dt)
    q = rng.uniform(1e-4, 1e-2, (N_EPOCHS, N))
    q[:, :6] = 0.0  # the attitude-velocity noise is in q_nav
    q_nav = np.zeros((N_EPOCHS, 6, 6))
    for k in range(N_EPOCHS):
        A = rng.normal(0.0, 0.05, (6, 6))
        q_nav[k] = A @ A.T + np.diag(rng.uniform(1e-4, 1e-2, 6))
    P0 = np.diag(rng.uniform(0.5, 2.0, N))
    m0 = rng.normal(0.0, 1.0, N)
    meas = {}
    for key, rows in MEAS.items():
        H = np.zeros((6, N))
        H[:rows] = rng.normal(0.0, 1.0, (rows, N))
        r = np.zeros(6)
        r[:rows] = rng.uniform(0.05, 0.5, rows)
        meas[key] = (int(key), H, r, rows)
    # truth and measurements
    x = rng.multivariate_normal(m0, P0)
    xs = np.zeros((N_EPOCHS, N))
    for k in range(N_EPOCHS):
        if k > 0:
            x = Phis[k] @ x + rng.multivariate_normal(np.zeros(N), _full_q(q[k], q_nav[k]))
        xs[k] = x
    ys = {}
    for key, (k, H, r, rows) in meas.items():
        ys[key] = H[:rows] @ xs[k] + rng.normal(0.0, np.sqrt(r[:rows]))
    return {
        "Phis": Phis, "q": q, "q_nav": q_nav, "P0": P0, "m0": m0, "meas": meas, "ys": ys,
        "truth": xs,
    }  # fmt: skip


def _full_q(q: np.ndarray, q_nav: np.ndarray) -> np.ndarray:
    Q = np.diag(q)
    Q[:6, :6] += q_nav
    return Q


def _closed_loop_forward(model: dict[str, Any]) -> tuple[np.ndarray, np.ndarray, Checkpoints]:
    """Error-state filter with feedback on the linear model, storing checkpoints exactly
    as the INS forward pass does (the same compiled propagation and scalar updates)."""
    P = model["P0"].copy()
    nominal = model["m0"].copy()
    nominals = np.zeros((N_EPOCHS, N))
    fwd_var = np.zeros((N_EPOCHS, N))
    ck: dict[str, list[Any]] = {k: [] for k in ("epoch", "Pm", "Pp", "H", "r", "z", "nrows")}

    def add(
        k: int,
        Pm: np.ndarray,
        Pp: np.ndarray,
        H: np.ndarray,
        r: np.ndarray,
        z: np.ndarray,
        rows: int,
    ) -> None:
        for name, val in zip(ck, (k, Pm.copy(), Pp.copy(), H, r, z, rows), strict=True):
            ck[name].append(val)

    add(0, P, P, np.zeros((6, N)), np.zeros(6), np.zeros(6), 0)
    T = np.empty((9, N))
    ph = np.empty(N)
    for k in range(N_EPOCHS):
        if k > 0:
            nominal = model["Phis"][k] @ nominal
            propagate_cov(P, model["Phis"][k], model["q"][k], model["q_nav"][k], T)
        for key in sorted(kk for kk in model["meas"] if int(kk) == k):
            _, H, r, rows = model["meas"][key]
            z = np.zeros(6)
            z[:rows] = H[:rows] @ nominal - model["ys"][key]  # "INS minus GNSS"
            Pm = P.copy()
            x = np.zeros(N)
            for i in range(rows):
                scalar_update(P, x, H[i].copy(), r[i], z[i], ph)
            nominal = nominal - x  # feedback: true = nominal - error
            add(k, Pm, P, H, r, z, rows)
        if k in FORCED:
            add(k, P, P, np.zeros((6, N)), np.zeros(6), np.zeros(6), 0)
        nominals[k] = nominal
        fwd_var[k] = np.diag(P)
    ckp = Checkpoints(
        epoch=np.array(ck["epoch"], dtype=np.int64),
        P_minus=np.array(ck["Pm"]),
        P_plus=np.array(ck["Pp"]),
        H=np.array(ck["H"]),
        r=np.array(ck["r"]),
        z=np.array(ck["z"]),
        nrows=np.array(ck["nrows"], dtype=np.int64),
    )
    return nominals, fwd_var, ckp


def _batch_least_squares(model: dict[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """Minimiser of the full quadratic cost over all states and its covariance (per epoch)."""
    n = N_EPOCHS * N
    A = np.zeros((n, n))
    b = np.zeros(n)

    def blk(k: int) -> slice:
        return slice(N * k, N * k + N)

    P0i = np.linalg.inv(model["P0"])
    A[blk(0), blk(0)] += P0i
    b[blk(0)] += P0i @ model["m0"]
    for k in range(1, N_EPOCHS):
        Q = _full_q(model["q"][k], model["q_nav"][k])
        Qi = np.linalg.inv(Q)
        Phi = model["Phis"][k]
        # (x_k - Φ x_{k-1})^T Q^-1 (x_k - Φ x_{k-1})
        A[blk(k), blk(k)] += Qi
        A[blk(k), blk(k - 1)] -= Qi @ Phi
        A[blk(k - 1), blk(k)] -= Phi.T @ Qi
        A[blk(k - 1), blk(k - 1)] += Phi.T @ Qi @ Phi
    for key, (k, H, r, rows) in model["meas"].items():
        Hr = H[:rows]
        Ri = np.diag(1.0 / r[:rows])
        A[blk(k), blk(k)] += Hr.T @ Ri @ Hr
        b[blk(k)] += Hr.T @ Ri @ model["ys"][key]
    x = np.linalg.solve(A, b).reshape(N_EPOCHS, N)
    cov_all = np.linalg.inv(A)
    cov = np.array([cov_all[blk(k), blk(k)] for k in range(N_EPOCHS)])
    return x, cov


@pytest.mark.parametrize("seed", [1, 2])
def test_smoother_equals_batch_least_squares(seed: int) -> None:
    model = _linear_model(np.random.default_rng(seed))
    nominals, fwd_var, ck = _closed_loop_forward(model)
    dx = np.zeros((N_EPOCHS, N))
    cov = new_smoothed_covariance(N_EPOCHS, N)

    def fill(
        e: int, L: int, has_next: bool, Phi_buf: np.ndarray, q_buf: np.ndarray, q_nav: np.ndarray
    ) -> None:
        top = L if has_next else L - 1
        for i in range(1, top + 1):
            Phi_buf[i] = model["Phis"][e + i]
            q_buf[i] = model["q"][e + i]
            q_nav[i] = model["q_nav"][e + i]

    def done(e: int, dx_seg: np.ndarray, cov_seg: SmoothedCovariance) -> None:
        rows = slice(e, e + dx_seg.shape[0])
        dx[rows] = dx_seg
        for name in ("var", "nav", "bias_cross"):
            getattr(cov, name)[rows] = getattr(cov_seg, name)

    smooth_checkpoints(ck, N_EPOCHS - 1, fill, done)
    smoothed = nominals - dx
    x_ls, cov_ls = _batch_least_squares(model)
    var_ls = np.diagonal(cov_ls, axis1=1, axis2=2)
    scale = np.abs(x_ls).max()
    np.testing.assert_allclose(smoothed, x_ls, rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(cov.var, var_ls, rtol=1e-9)
    # the entries kept beside the variances: attitude-velocity block, bias cross terms
    np.testing.assert_allclose(cov.nav, cov_ls[:, :6, :6], rtol=0, atol=1e-9 * var_ls.max())
    for a in range(3):
        np.testing.assert_allclose(
            cov.bias_cross[:, a], cov_ls[:, X_BG + a, X_MG + a], atol=1e-9 * var_ls.max()
        )
        np.testing.assert_allclose(
            cov.bias_cross[:, 3 + a], cov_ls[:, X_BA + a, X_MA + a], atol=1e-9 * var_ls.max()
        )
    # the forward filter's last epoch is already the smoothed one
    np.testing.assert_allclose(fwd_var[-1], var_ls[-1], rtol=1e-9)
    assert (cov.var <= fwd_var * (1 + 1e-12)).all()
    # and the smoothed estimate is an estimate of the truth: normalised errors of unit size
    zeta = (smoothed - model["truth"]) / np.sqrt(cov.var)
    assert 0.5 < float(np.sqrt(np.mean(zeta**2))) < 1.5


GYRO_ARW = math.radians(0.1) / 60.0
ACC_VRW = 0.05 / 60.0
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


@pytest.fixture(scope="module")
def smoothed_run(sim_drive: SimDrive) -> tuple[Any, NavSolution]:
    _, imu, gnss, truth, init = sim_drive(
        duration_s=150.0, seed=11, gyro_bias_rad_s=(2e-4, -3e-4, 1e-4),
        acc_bias_m_s2=(0.03, -0.05, 0.04), gyro_arw=GYRO_ARW, acc_vrw=ACC_VRW,
    )  # fmt: skip
    return run_ins(imu, gnss, CONFIG, init, smooth=True, use_velocity=False), truth


def test_smoothed_sigma_never_exceeds_forward_sigma(smoothed_run: tuple[Any, NavSolution]) -> None:
    res, _ = smoothed_run
    fwd, smo = res.forward, res.smoothed
    assert smo is not None
    assert smo.smoothed
    assert not fwd.smoothed
    assert (smo.n_gnss_used, smo.n_gnss_rejected) == (fwd.n_gnss_used, fwd.n_gnss_rejected)
    for name in (
        "std_pos_ned_m",
        "std_vel_ned_m_s",
        "std_att_rad",
        "std_gyro_bias_rad_s",
        "std_acc_bias_m_s2",
    ):
        a, b = getattr(smo, name), getattr(fwd, name)
        assert (a <= b * (1 + 1e-9) + 1e-15).all(), name
        np.testing.assert_allclose(a[-1], b[-1], rtol=1e-9)
    # well inside the record the smoother is much more certain
    mid = len(fwd) // 2
    assert (smo.std_pos_ned_m[mid] < 0.8 * fwd.std_pos_ned_m[mid]).all()
    np.testing.assert_array_equal(smo.lat_deg[-1], fwd.lat_deg[-1])


def test_smoothed_errors_smaller_and_consistent(
    smoothed_run: tuple[Any, NavSolution], errors_of: Errors
) -> None:
    res, truth = smoothed_run
    e_fwd = np.column_stack(errors_of(res.forward, truth))
    e_smo = np.column_stack(errors_of(res.smoothed, truth))
    rms_fwd = np.sqrt(np.mean(e_fwd**2, axis=0))
    rms_smo = np.sqrt(np.mean(e_smo**2, axis=0))
    assert (rms_smo < rms_fwd).all(), (rms_smo, rms_fwd)
    assert (rms_smo[:3] < 0.6 * rms_fwd[:3]).all()
    smo = res.smoothed
    sd = np.column_stack([smo.std_pos_ned_m, smo.std_vel_ned_m_s, smo.std_att_rad])
    z = np.abs(e_smo) / sd
    assert (z <= 3.0).mean(axis=0).min() > 0.9
    assert (np.sqrt(np.mean(z**2, axis=0)) < 1.6).all()


def test_without_measurements_the_smoother_changes_nothing(sim_drive: SimDrive) -> None:
    _, imu, gnss, _, init = sim_drive(duration_s=30.0, seed=12, gyro_arw=GYRO_ARW, acc_vrw=ACC_VRW)
    far = dataclasses.replace(gnss, t_s=gnss.t_s + 1000.0)  # all outside the IMU span
    with pytest.raises(InputError, match="0 GNSS epoch"):  # run_ins refuses such inputs
        run_ins(imu, far, CONFIG, init, smooth=True)
    g_epoch = gnss_epochs(imu.t_s, start_epoch(imu, init), far.t_s)
    assert (g_epoch < 0).all()
    log = new_gnss_log(len(far))
    run = forward_pass(
        imu, far, CONFIG, init, use_velocity=True, store=True, progress=None,
        gnss_imu_epoch=g_epoch, log=log,
    )  # fmt: skip
    states, std = smooth_forward_run(imu, run, None)
    assert (log.status == GnssStatus.OUTSIDE).all()
    k0 = run.k0
    forward = nav_solution_from_states(imu.t_s[k0:], run.states[k0:], run.std[k0:])
    smoothed = nav_solution_from_states(imu.t_s[k0:], states[k0:], std[k0:], smoothed=True)
    np.testing.assert_array_equal(smoothed.lat_deg, forward.lat_deg)
    np.testing.assert_array_equal(smoothed.std_pos_ned_m, forward.std_pos_ned_m)


@pytest.mark.parametrize("scale_factors", [False, True], ids=["22 states", "28 states"])
def test_smoother_rebuilds_the_forward_covariance_after_a_levelled_standstill(
    scale_factors: bool,
) -> None:
    """After a static alignment the filter carries one more state, the second-order
    vertical support of the levelled tilt, whose transition follows the forward pass's
    tilt covariance (`kinsync.ins._ekf.propagate_support`). The smoother rebuilds it from
    the stored nominal states: propagating each checkpoint's posterior covariance with
    the smoother's ``Φ`` and ``Q`` gives the next checkpoint's prior, bit for bit. The
    extra state is not taken for scale factors (nor are they lost beside it)."""
    sim = simulate_drive(
        DriveSimConfig(imu="mems", imu_rate_hz=100.0, static_s=10.0, duration_s=30.0, seed=5)
    )
    config = sim.ins_config
    if scale_factors:
        config = dataclasses.replace(
            config, gyro_scale_factor_sigma_ppm=500.0, acc_scale_factor_sigma_ppm=500.0
        )
    init = align_static_gnss_heading(
        sim.imu, sim.gnss, static_s=5.0, antenna_lever_arm_body_m=config.antenna_lever_arm_body_m
    )
    g_epoch = gnss_epochs(sim.imu.t_s, 0, sim.gnss.t_s)
    run = forward_pass(
        sim.imu, sim.gnss, config, init, use_velocity=True, store=True, progress=None,
        gnss_imu_epoch=g_epoch, log=new_gnss_log(len(sim.gnss)),
    )  # fmt: skip
    ck = run.checkpoints
    assert ck is not None
    n = ck.P_plus.shape[1]
    assert n == (N_ERR_SCALE if scale_factors else N_ERR) + 1
    assert np.isnan(run.std[:, 15:21]).all() != scale_factors
    imu = sim.imu
    compared = 0
    has_next = True  # each segment ends at the next checkpoint
    for c in range(ck.epoch.size - 1):
        e, length = int(ck.epoch[c]), int(ck.epoch[c + 1] - ck.epoch[c])
        if length == 0:
            continue
        Phi = np.zeros((length + 1, n, n))
        q = np.zeros((length + 1, n))
        q_nav = np.zeros((length + 1, 6, 6))
        ins_matrices(
            e, length, has_next, imu.t_s, imu.gyro_body_rad_s, imu.acc_body_m_s2, run.states,
            run.params, Phi, q, q_nav,
        )  # fmt: skip
        P = ck.P_plus[c].copy()
        for i in range(1, length + 1):
            propagate_cov(P, Phi[i], q[i], q_nav[i], np.empty((9, n)))
        np.testing.assert_array_equal(P, ck.P_minus[c + 1])
        compared += 1
    assert compared > 100


def test_smoother_memory_does_not_grow_with_the_record_beyond_its_output() -> None:
    """The backward pass hands each segment's smoothed error and covariance over as it
    goes, so that beside the smoothed states and σ it returns it allocates one segment's
    buffers, not arrays per epoch (it held the smoothed error, its covariance entries
    and the outputs, 138 floats per IMU epoch: a 10 h record at 200 Hz needed 14 GB).
    Overwriting the forward run's arrays, it allocates nothing per epoch, and the result
    is the same bit for bit, also with the vertical support state of a levelled start
    (whose transition the smoother rebuilds from the states it overwrites)."""
    sim = simulate_drive(
        DriveSimConfig(imu="mems", imu_rate_hz=100.0, static_s=10.0, duration_s=30.0, seed=5)
    )
    config = sim.ins_config
    init = align_static_gnss_heading(
        sim.imu, sim.gnss, static_s=5.0, antenna_lever_arm_body_m=config.antenna_lever_arm_body_m
    )
    run = forward_pass(
        sim.imu, sim.gnss, config, init, use_velocity=True, store=True, progress=None,
        gnss_imu_epoch=gnss_epochs(sim.imu.t_s, 0, sim.gnss.t_s),
        log=new_gnss_log(len(sim.gnss)),
    )  # fmt: skip
    assert run.checkpoints is not None
    assert run.checkpoints.P_plus.shape[1] == N_ERR + 1  # the vertical support state
    n = run.states.shape[0]
    states, std = smooth_forward_run(sim.imu, run)  # compiled before memory is traced

    def traced_peak(smooth: Callable[[], tuple[np.ndarray, np.ndarray]]) -> tuple[int, Any]:
        tracemalloc.start()
        try:
            out = smooth()
            return tracemalloc.get_traced_memory()[1], out
        finally:
            tracemalloc.stop()

    peak, (s, d) = traced_peak(lambda: smooth_forward_run(sim.imu, run))
    assert peak <= s.nbytes + d.nbytes + 200 * n, (peak - s.nbytes - d.nbytes) / n
    np.testing.assert_array_equal(s, states)
    peak, (s, d) = traced_peak(lambda: smooth_forward_run(sim.imu, run, overwrite=True))
    assert s is run.states
    assert d is run.std
    assert peak <= 200 * n, peak / n
    np.testing.assert_array_equal(s, states)
    np.testing.assert_array_equal(d, std)
