"""Monte Carlo: the 27-state filter's σ is honest with turn-on biases and scale factors.

Both IMU presets of `kinsync.sim.imu.ImuErrorModel` with scale factor errors on: the
MEMS unit (ADIS16488-like: turn-on bias 0.2 deg/s and 16 mg, instability 6.5 deg/h and
0.1 mg over 100 s) with 1000 ppm scale factor σ on every axis, and the navigation-grade
unit (turn-on 0.01 deg/h and 0.06 mg, scale factors 20 and 5 ppm, 1 h instabilities).
Turn-on biases and scale factors are drawn per run from their σ and started from zero
in the filter (`ImuErrorModel.to_ins_config`: 27 states); the initial attitude and
velocity errors are drawn from their configured σ too. A 2-minute drive with curves
of 70-180 deg either way, a stop and a 20 s GNSS outage; GNSS at 5 Hz with the
configured σ and a 1.5 m antenna lever arm; forward filter and RTS smoother.

Over 60 runs per preset the normalised errors ``error / σ`` at six fixed epochs must be
N(0, 1) within the tolerance of ``test_smoother_consistency.py`` (pooled RMS per group of
three axes within 0.8-1.25, share within 3σ at least 0.99, each epoch and axis RMS within
0.6-1.45). Evidence: pooled RMS 1.01-1.04 (MEMS) and 0.99-1.09 (navigation grade),
shares within 3σ 0.994-1.000, per epoch and axis 0.79-1.40. The test has the power to
fail: with the scale factor states switched off (the same MEMS data, 30 runs) the
smoothed attitude shows RMS 1.47, 95.2 % within 3σ and one epoch at 2.71.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from kinsync._typing import FloatArray
from kinsync.ins.compare import compare_to_truth
from kinsync.ins.filter import run_ins
from kinsync.sim.drive import Route, Stop, Straight, Turn, initial_state
from kinsync.sim.drive_truth import DriveTrajectory, simulate_truth
from kinsync.sim.gnss import simulate_gnss
from kinsync.sim.imu import ImuErrorModel, simulate_imu

pytestmark = pytest.mark.slow

RATE_HZ = 100.0
ARM_BODY_M = (0.3, -0.2, -1.5)
INIT_STD_ATT_RAD = 1e-4
INIT_STD_VEL_M_S = 1e-3
SEEDS = range(60)
CHECK_FRACTIONS = (0.15, 0.3, 0.45, 0.6, 0.75, 0.9)
"""Epochs compared, as fractions of the drive (the outage spans 0.35-0.52)."""
RMS_BOUNDS = (0.8, 1.25)
PER_BOUNDS = (0.6, 1.45)

PRESETS = {
    "mems": (
        dataclasses.replace(
            ImuErrorModel.mems(rate_hz=RATE_HZ),
            gyro_scale_sigma_ppm=1000.0,
            acc_scale_sigma_ppm=1000.0,
        ),
        (0.5, 0.5, 1.0),
        (0.05, 0.05, 0.1),
    ),
    "navigation_grade": (
        ImuErrorModel.navigation_grade(rate_hz=RATE_HZ),
        (0.02, 0.02, 0.04),
        (0.01, 0.01, 0.02),
    ),
}


@pytest.fixture(scope="module")
def truth() -> DriveTrajectory:
    route = Route(
        (
            Straight(120.0),
            Turn(70.0, 50.0),
            Straight(80.0),
            Turn(-110.0, 40.0),
            Stop(4.0),
            Straight(120.0),
            Turn(180.0, 30.0),
            Straight(100.0),
            Turn(-90.0, 40.0),
            Straight(60.0),
        ),
        speed_m_s=10.0,
        max_acc_m_s2=1.5,
        static_s=3.0,
    )
    return simulate_truth(route, rate_hz=RATE_HZ, initial_yaw_deg=20.0)


def _normalised(truth: DriveTrajectory, preset: str) -> dict[str, FloatArray]:
    model, std_pos, std_vel = PRESETS[preset]
    config = model.to_ins_config(
        gnss_std_pos_ned_m=std_pos,
        gnss_std_vel_ned_m_s=std_vel,
        antenna_lever_arm_body_m=ARM_BODY_M,
        init_std_att_rad=(INIT_STD_ATT_RAD,) * 3,
        init_std_vel_ned_m_s=(INIT_STD_VEL_M_S,) * 3,
        init_std_pos_ned_m=(1e-3,) * 3,
    )
    assert config.models_scale_factors
    span = truth.t_s[-1] - truth.t_s[0]
    checks = truth.t_start_s + np.asarray(CHECK_FRACTIONS) * span
    outage = (0.35 * span, 0.35 * span + 20.0)
    out: dict[str, list[FloatArray]] = {"fwd": [], "smo": []}
    for seed in SEEDS:
        imu, _ = simulate_imu(truth, model, seed=seed)
        gnss = simulate_gnss(
            truth, rate_hz=5.0, std_pos_ned_m=std_pos, std_vel_ned_m_s=std_vel,
            antenna_lever_arm_body_m=ARM_BODY_M, outages=(outage,), seed=seed,
        )  # fmt: skip
        rng = np.random.default_rng(1000 + seed)
        start = initial_state(truth)
        start = dataclasses.replace(
            start,
            rpy_rad=tuple(np.asarray(start.rpy_rad) + rng.normal(0.0, INIT_STD_ATT_RAD, 3)),
            vel_ned_m_s=tuple(np.asarray(start.vel_ned_m_s) + rng.normal(0.0, INIT_STD_VEL_M_S, 3)),
        )
        res = run_ins(imu, gnss, config, start, smooth=True)
        assert res.smoothed is not None
        for key, sol in (("fwd", res.forward), ("smo", res.smoothed)):
            cmp = compare_to_truth(sol, truth)
            assert cmp.err_vel_ned_m_s is not None
            k = np.searchsorted(sol.t_s, checks)
            err = np.column_stack(
                [cmp.err_pos_ned_m[k], cmp.err_vel_ned_m_s[k], cmp.err_misorientation_ned_rad[k]]
            )
            sd = np.column_stack([sol.std_pos_ned_m[k], sol.std_vel_ned_m_s[k], sol.std_att_rad[k]])
            out[key].append(err / sd)
    return {key: np.stack(z) for key, z in out.items()}


@pytest.fixture(scope="module", params=list(PRESETS))
def normalised(request: pytest.FixtureRequest, truth: DriveTrajectory) -> dict[str, FloatArray]:
    return _normalised(truth, str(request.param))


@pytest.mark.parametrize("key", ["fwd", "smo"])
@pytest.mark.parametrize(("group", "cols"), [("pos", (0, 3)), ("vel", (3, 6)), ("att", (6, 9))])
def test_normalised_errors_are_standard_normal(
    normalised: dict[str, FloatArray], key: str, group: str, cols: tuple[int, int]
) -> None:
    z = normalised[key][:, :, cols[0] : cols[1]]
    rms = float(np.sqrt(np.mean(z**2)))
    inside = float(np.mean(np.abs(z) <= 3.0))
    assert RMS_BOUNDS[0] < rms < RMS_BOUNDS[1], (key, group, rms)
    assert inside >= 0.99, (key, group, inside)
    per = np.sqrt(np.mean(z**2, axis=0))
    assert (per > PER_BOUNDS[0]).all(), (key, group, per)
    assert (per < PER_BOUNDS[1]).all(), (key, group, per)
