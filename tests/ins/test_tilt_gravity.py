"""The expected second-order tilt error (`kinsync.ins._ekf.tilt_gravity_mean`).

An uncertain tilt lowers, on average, the vertical support the mechanisation computes
from the sensed specific force: the gravity term of the velocity error is
``(I - Rot(φ)^T) g``, whose second-order part has the mean ``-½ (P - tr(P) I) g``.
The filter removes that mean from its velocity at every epoch.

- The correction is checked against the expectation sampled directly from the rotation
  (no small-angle algebra): 400 000 draws of ``φ ~ N(0, P)`` with 2-3 deg of tilt σ,
  10 deg of heading σ and correlations.
- Monte Carlo, the case it is for: NaveGo-like drives (MEMS turn-on biases of
  0.2 deg/s and 16 mg drawn per run and estimated from zero, 5 Hz GNSS of 5/5/10 m,
  position updates only, 16 m/s with 180 deg turns). Over 60-200 s, after the first
  turns, the normalised vertical accelerometer bias error and the normalised height
  error must be N(0, 1) within the tolerance of the other consistency tests (RMS below
  1.25; 16 drives at 100 Hz). Without the correction (the call removed from the loop,
  same drives) the vertical accelerometer bias showed an RMS of 1.70 and the height
  1.26: the filter learned the tilt's mean vertical error as a bias and then believed
  it to the 0.1 mg of the instability. With it: 1.09 and 1.10.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from kinsync._typing import FloatArray
from kinsync.ins._ekf import tilt_gravity_mean
from kinsync.ins.compare import compare_to_truth
from kinsync.ins.earth import normal_gravity_m_s2
from kinsync.ins.filter import run_ins
from kinsync.ins.strapdown import I_H, I_LAT, I_VEL, N_STATE
from kinsync.sim.drive import Route, Straight, Turn, initial_state
from kinsync.sim.drive_truth import DriveTrajectory, simulate_truth
from kinsync.sim.gnss import simulate_gnss
from kinsync.sim.imu import ImuErrorModel, simulate_imu

DEG = np.pi / 180.0


def test_tilt_gravity_mean_matches_the_sampled_expectation() -> None:
    sd = np.array([2.0, 3.0, 10.0]) * DEG
    corr = np.array([[1.0, 0.3, -0.4], [0.3, 1.0, 0.5], [-0.4, 0.5, 1.0]])
    P_att = corr * np.outer(sd, sd)
    n = 21
    P = np.eye(n) * 1e-6
    P[:3, :3] = P_att
    s = np.zeros(N_STATE)
    s[I_LAT], s[I_H] = 0.8, 120.0
    s[I_VEL : I_VEL + 3] = (3.0, -2.0, 0.5)
    dt = 0.01
    before = s[I_VEL : I_VEL + 3].copy()
    tilt_gravity_mean(P, s, dt)
    removed = (before - s[I_VEL : I_VEL + 3]) / dt  # the mean error rate taken away

    g = np.array([0.0, 0.0, normal_gravity_m_s2(0.8, 120.0)])
    rng = np.random.default_rng(7)
    phi = rng.multivariate_normal(np.zeros(3), P_att, size=400_000)
    rot_t = Rotation.from_rotvec(phi).inv()  # Rot(φ)^T
    samples = g - rot_t.apply(g)  # (I - Rot(φ)^T) g per draw
    mean = samples.mean(axis=0)
    se = samples.std(axis=0) / np.sqrt(len(samples))
    # 4th-order terms of the rotation are below 1 % of the 2nd-order mean here
    assert np.all(np.abs(removed - mean) < 4 * se + 0.01 * np.abs(mean) + 1e-12), (removed, mean)
    assert removed[2] > 0  # the nominal is pulled up: an uncertain tilt loses support
    # no tilt uncertainty, no correction
    P0 = np.eye(n) * 0.0
    s0 = s.copy()
    tilt_gravity_mean(P0, s0, dt)
    assert np.array_equal(s0, s)


# ---------------------------------------------------------------- Monte Carlo
RATE_HZ = 100.0
SEEDS = range(16)
WINDOW_S = (60.0, 200.0)
STD_POS = (5.0, 5.0, 10.0)
RMS_MAX = 1.25


@pytest.fixture(scope="module")
def navego_like() -> DriveTrajectory:
    route = Route(
        (
            Straight(800.0),
            Turn(180.0, 100.0),
            Straight(800.0),
            Turn(-180.0, 100.0),
            Straight(800.0),
        ),
        speed_m_s=16.0,
        max_acc_m_s2=0.8,
        static_s=0.0,
    )
    return simulate_truth(
        route, rate_hz=RATE_HZ, initial_yaw_deg=-15.0, origin_lat_lon_h=(32.0, -64.0, 725.0)
    )


def _normalised(truth: DriveTrajectory) -> tuple[FloatArray, FloatArray]:
    model = ImuErrorModel.mems(rate_hz=RATE_HZ)
    config = model.to_ins_config(
        gnss_std_pos_ned_m=STD_POS,
        init_std_att_rad=(0.5 * DEG, 0.5 * DEG, 1.0 * DEG),
        init_std_vel_ned_m_s=(0.05,) * 3,
        init_std_pos_ned_m=STD_POS,
    )
    z_acc, z_h = [], []
    for seed in SEEDS:
        imu, err = simulate_imu(truth, model, seed=seed)
        gnss = simulate_gnss(truth, rate_hz=5.0, std_pos_ned_m=STD_POS, seed=seed)
        sol = run_ins(imu, gnss, config, initial_state(truth), use_velocity=False).forward
        t = sol.t_s - sol.t_s[0]
        k = np.flatnonzero((t >= WINDOW_S[0]) & (t < WINDOW_S[1]))[::50]
        i = np.searchsorted(err.t_s, sol.t_s[k])
        ba_true = err.acc_bias_m_s2[2] + err.acc_bias_variation_m_s2[i, 2]
        z_acc.append((sol.acc_bias_m_s2[k, 2] - ba_true) / sol.std_acc_bias_m_s2[k, 2])
        cmp = compare_to_truth(sol, truth)
        z_h.append(cmp.err_pos_ned_m[k, 2] / sol.std_pos_ned_m[k, 2])
    return np.concatenate(z_acc), np.concatenate(z_h)


@pytest.mark.slow
def test_vertical_channel_is_consistent_after_the_first_turns(
    navego_like: DriveTrajectory,
) -> None:
    z_acc, z_h = _normalised(navego_like)
    rms_acc = float(np.sqrt(np.mean(z_acc**2)))
    rms_h = float(np.sqrt(np.mean(z_h**2)))
    assert rms_acc < RMS_MAX, rms_acc
    assert rms_h < RMS_MAX, rms_h
    assert rms_acc > 0.75, rms_acc  # and not hidden by an inflated σ
    assert rms_h > 0.75, rms_h


def test_correction_leaves_a_level_filter_alone() -> None:
    """A converged filter (tilt σ 0.01 deg): the correction is below 1e-6 m/s² (0.1 µg),
    far under any accelerometer's noise, and touches nothing but the velocity."""
    P = np.eye(21) * (0.01 * DEG) ** 2
    s = np.zeros(N_STATE)
    s[I_LAT] = 0.5
    before = s.copy()
    dt = 0.005
    tilt_gravity_mean(P, s, dt)
    rate = (s - before) / dt
    assert np.max(np.abs(rate)) < 1e-6
    assert np.array_equal(np.flatnonzero(rate), [I_VEL + 2])
