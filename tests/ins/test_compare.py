"""Comparison with a truth trajectory: injected errors are recovered; 3σ shares."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from kinsync.errors import InputError
from kinsync.frames import (
    ecef_to_geodetic,
    geodetic_to_ecef,
    ned_to_ecef,
    quaternion_to_euler_rpy,
    rotation_ned_to_ecef,
)
from kinsync.ins.compare import compare_to_truth
from kinsync.ins.solution import NavSolution
from kinsync.trajectory import Trajectory

ORIGIN = (-32.8, -68.8, 700.0)
RADIUS_M = 200.0
OMEGA_RAD_S = 0.05


def _path(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Circle in the origin's NED frame: positions (m), velocities (m/s), DIN 9300 rpy (rad)."""
    a = OMEGA_RAD_S * t
    pos = np.column_stack([RADIUS_M * np.sin(a), RADIUS_M * (1.0 - np.cos(a)), -0.1 * t])
    vel = np.column_stack(
        [
            RADIUS_M * OMEGA_RAD_S * np.cos(a),
            RADIUS_M * OMEGA_RAD_S * np.sin(a),
            np.full_like(t, -0.1),
        ]
    )
    yaw = (a + math.pi) % (2 * math.pi) - math.pi  # crosses +-180 deg
    rpy = np.column_stack([0.05 * np.sin(0.3 * t), 0.02 * np.cos(0.2 * t), yaw])
    return pos, vel, rpy


def _geodetic(pos_ned: np.ndarray) -> np.ndarray:
    return ecef_to_geodetic(ned_to_ecef(pos_ned, *ORIGIN))


def _truth(t: np.ndarray | None = None) -> Trajectory:
    t = np.arange(0.0, 100.0, 0.1) if t is None else t
    pos, vel, rpy = _path(t)
    return Trajectory.from_euler(
        t, rpy[:, 0], rpy[:, 1], rpy[:, 2], lat_lon_h=_geodetic(pos), vel_ned_m_s=vel
    )


def _offset_ned(llh: np.ndarray, d_ned_m: np.ndarray) -> np.ndarray:
    """Positions moved by ``d_ned_m`` in the local NED frame at each position."""
    ecef = geodetic_to_ecef(llh[:, 0], llh[:, 1], llh[:, 2])
    R = rotation_ned_to_ecef(llh[:, 0], llh[:, 1])
    return ecef_to_geodetic(ecef + np.einsum("nij,nj->ni", R, d_ned_m))


def _solution(
    t: np.ndarray,
    d_pos: np.ndarray,
    d_vel: np.ndarray,
    d_rpy: np.ndarray,
    sigma: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
    d_rot: np.ndarray | None = None,
) -> NavSolution:
    pos, vel, rpy = _path(t)
    llh = _offset_ned(_geodetic(pos), np.broadcast_to(d_pos, pos.shape))
    rpy = rpy + d_rpy
    if d_rot is not None:  # misorientation about N, E, D: R_sol = exp(d_rot) R_truth
        R = Rotation.from_rotvec(d_rot) * Rotation.from_euler("ZYX", rpy[:, ::-1])
        rpy = R.as_euler("ZYX")[:, ::-1]
    n = t.size
    s_pos, s_vel, s_att = sigma if sigma is not None else (np.ones((n, 3)),) * 3
    return NavSolution(
        t_s=t,
        lat_deg=llh[:, 0],
        lon_deg=llh[:, 1],
        h_m=llh[:, 2],
        vel_ned_m_s=vel + d_vel,
        rpy_rad=rpy,
        std_pos_ned_m=s_pos,
        std_vel_ned_m_s=s_vel,
        std_att_rad=s_att,
        gyro_bias_rad_s=np.zeros((n, 3)),
        acc_bias_m_s2=np.zeros((n, 3)),
        std_gyro_bias_rad_s=np.ones((n, 3)),
        std_acc_bias_m_s2=np.ones((n, 3)),
    )


def test_identical_solution_has_no_error() -> None:
    truth = _truth()
    cmp = compare_to_truth(truth, truth)
    assert cmp.n_epochs == len(truth)
    np.testing.assert_allclose(cmp.rms_pos_ned_m, 0.0, atol=1e-8)
    np.testing.assert_allclose(cmp.max_att_deg, 0.0, atol=1e-10)
    assert cmp.rms_vel_ned_m_s == (0.0, 0.0, 0.0)
    assert cmp.within_3sigma is None


def test_constant_errors_are_recovered() -> None:
    t = np.arange(0.0, 100.0, 0.1)
    d_pos = np.array([1.0, -2.0, 0.5])
    d_vel = np.array([0.1, 0.2, -0.3])
    d_rpy = np.radians([0.2, -0.1, 3.0])  # yaw error across the +-180 deg wrap
    cmp = compare_to_truth(_solution(t, d_pos, d_vel, d_rpy), _truth())
    assert cmp.n_epochs == t.size
    np.testing.assert_allclose(cmp.err_pos_ned_m, np.broadcast_to(d_pos, (t.size, 3)), atol=1e-6)
    np.testing.assert_allclose(cmp.rms_pos_ned_m, np.abs(d_pos), atol=1e-6)
    np.testing.assert_allclose(cmp.max_pos_ned_m, np.abs(d_pos), atol=1e-6)
    assert cmp.rms_vel_ned_m_s is not None
    np.testing.assert_allclose(cmp.rms_vel_ned_m_s, np.abs(d_vel), atol=1e-12)
    np.testing.assert_allclose(cmp.rms_att_deg, np.abs(np.degrees(d_rpy)), atol=1e-9)
    np.testing.assert_allclose(cmp.max_att_deg, np.abs(np.degrees(d_rpy)), atol=1e-9)
    assert np.all(np.abs(cmp.err_att_deg) < 3.1)  # wrapped, never ~357 deg


def test_yaw_error_is_a_misorientation_about_down() -> None:
    t = np.arange(0.0, 100.0, 0.1)
    delta = math.radians(1.5)
    cmp = compare_to_truth(
        _solution(t, np.zeros(3), np.zeros(3), np.array([0, 0, delta])), _truth()
    )
    np.testing.assert_allclose(
        cmp.err_misorientation_ned_rad, [[0.0, 0.0, delta]] * t.size, atol=1e-12
    )


def test_near_90_deg_pitch_the_misorientation_is_the_error_to_read() -> None:
    """At 89.99 deg pitch a 0.005 deg misorientation about North reads as 26.6 deg of roll
    and of yaw difference (gimbal lock); the misorientation RMS and the pitch are given."""
    t = np.arange(0.0, 10.0, 0.1)
    pitch = np.full_like(t, math.radians(89.99))
    llh = np.tile([46.8, -71.2, 10.0], (t.size, 1))
    truth = Trajectory.from_euler(t, np.zeros_like(t), pitch, np.zeros_like(t), lat_lon_h=llh)
    turned = Rotation.from_rotvec([math.radians(0.005), 0.0, 0.0]) * Rotation.from_euler(
        "ZYX", np.column_stack([np.zeros_like(t), pitch, np.zeros_like(t)])
    )
    rpy = turned.as_euler("ZYX")[:, ::-1]
    solution = Trajectory.from_euler(t, rpy[:, 0], rpy[:, 1], rpy[:, 2], lat_lon_h=llh)
    cmp = compare_to_truth(solution, truth)
    assert cmp.rms_att_deg[0] > 20.0  # roll and yaw differences mean nothing here
    np.testing.assert_allclose(cmp.rms_misorientation_ned_deg, [0.005, 0.0, 0.0], atol=1e-9)
    assert cmp.max_abs_pitch_deg == pytest.approx(89.99)
    doc = cmp.as_document()
    assert doc["max_abs_pitch_deg"] == pytest.approx(89.99)
    assert doc["rms_misorientation_ned_deg"][0] == pytest.approx(0.005)


def test_truth_is_interpolated_and_only_the_overlap_compared() -> None:
    t = np.arange(-5.0, 110.0, 0.0371)  # other epochs, starting before and ending after
    cmp = compare_to_truth(_solution(t, np.zeros(3), np.zeros(3), np.zeros(3)), _truth())
    inside = (t >= 0.0) & (t <= 99.9 + 1e-9)
    assert cmp.n_epochs == np.count_nonzero(inside)
    np.testing.assert_array_equal(cmp.t_s, t[inside])
    assert max(cmp.max_pos_ned_m) < 1e-3  # cubic Hermite between 0.1 s truth records
    assert max(cmp.max_att_deg) < 1e-3  # slerp of a slowly varying attitude
    assert cmp.max_vel_ned_m_s is not None
    assert max(cmp.max_vel_ned_m_s) < 1e-3


def test_epochs_in_a_gap_of_the_truth_are_left_out_and_counted() -> None:
    """10 s missing from the truth: the solution there is not compared with a guess.

    On the 200 m circle the truth interpolated across the hole is centimetres and
    degrees off the true path (Hermite positions with exact velocities; slerp through
    a roll that swings 0.05 rad every 21 s), which would be charged to the solution as
    its error.
    """
    t_truth = np.arange(0.0, 100.0, 0.1)
    holed = _truth(t_truth[~((t_truth > 40.0) & (t_truth < 50.0))])
    t = np.arange(-5.0, 105.0, 0.05)
    cmp = compare_to_truth(_solution(t, np.zeros(3), np.zeros(3), np.zeros(3)), holed)
    in_hole = (t > 40.0) & (t < 50.0)
    outside = (t < 0.0) | (t > 99.9 + 1e-9)
    assert cmp.n_in_truth_gaps == np.count_nonzero(in_hole)
    assert cmp.n_outside_truth == np.count_nonzero(outside)
    assert cmp.n_epochs == t.size - cmp.n_in_truth_gaps - cmp.n_outside_truth
    np.testing.assert_array_equal(cmp.t_s, t[~in_hole & ~outside])
    ((start, end),) = [(g.t_start_s, g.t_end_s) for g in cmp.truth_gaps]
    assert (start, end) == pytest.approx((40.0, 50.0))
    assert max(cmp.max_pos_ned_m) < 1e-3
    assert max(cmp.max_att_deg) < 1e-3
    doc = cmp.as_document()
    assert doc["n_epochs_in_truth_gaps"] == cmp.n_in_truth_gaps
    assert doc["n_epochs_outside_truth"] == cmp.n_outside_truth
    assert doc["truth_gaps"] == [{"t_start_s": start, "t_end_s": end}]
    assert doc["gap_threshold_s"] == cmp.truth_gap_threshold_s == pytest.approx(1.0)
    # A truth legitimately this sparse: a threshold above the hole compares those epochs.
    wide = compare_to_truth(
        _solution(t, np.zeros(3), np.zeros(3), np.zeros(3)), holed, max_gap_s=10.5
    )
    assert (wide.n_in_truth_gaps, wide.truth_gaps) == (0, ())
    assert wide.n_epochs == t.size - cmp.n_outside_truth
    assert wide.truth_gap_threshold_s == 10.5
    # what the old comparison charged to the solution: the guess across the hole
    guess = holed.interpolate(t[in_hole], max_gap_s=math.inf)
    exact = _truth(t[in_hole]).interpolate(t[in_hole])
    assert np.max(np.linalg.norm(guess.pos_ecef_m() - exact.pos_ecef_m(), axis=1)) > 0.02
    roll_deg = np.degrees(
        quaternion_to_euler_rpy(guess.q_body_to_ned)[:, 0]
        - quaternion_to_euler_rpy(exact.q_body_to_ned)[:, 0]
    )
    assert np.max(np.abs(roll_deg)) > 1.0


def test_a_solution_only_inside_a_truth_gap_is_an_error_naming_it() -> None:
    t_truth = np.arange(0.0, 100.0, 0.1)
    holed = _truth(t_truth[~((t_truth > 40.0) & (t_truth < 50.0))])
    t = np.arange(41.0, 49.0, 0.05)
    with pytest.raises(InputError, match="no common times") as err:
        compare_to_truth(_solution(t, np.zeros(3), np.zeros(3), np.zeros(3)), holed)
    assert f"the {t.size} solution epoch(s) inside it lie in its data gaps" in str(err.value)
    assert holed.gaps()[0].describe() in str(err.value)
    assert "record intervals longer than 1 s (the gap threshold: --max-gap-s" in str(err.value)
    for bad in (0.0, -1.0, math.nan):
        with pytest.raises(InputError, match="max-gap-s"):
            compare_to_truth(
                _solution(t, np.zeros(3), np.zeros(3), np.zeros(3)), holed, max_gap_s=bad
            )


def test_three_sigma_shares() -> None:
    rng = np.random.default_rng(7)
    t = np.arange(0.0, 99.0, 0.05)
    n = t.size
    s_pos = rng.uniform(0.5, 3.0, (n, 3))
    s_vel = rng.uniform(0.01, 0.1, (n, 3))
    s_att = rng.uniform(1e-3, 1e-2, (n, 3))
    e_pos, e_vel, e_att = (rng.standard_normal((n, 3)) * s for s in (s_pos, s_vel, s_att))
    sol = _solution(t, e_pos, e_vel, np.zeros(3), sigma=(s_pos, s_vel, s_att), d_rot=e_att)
    cmp = compare_to_truth(sol, _truth(t))
    np.testing.assert_allclose(cmp.err_pos_ned_m, e_pos, atol=1e-4)
    np.testing.assert_allclose(cmp.err_misorientation_ned_rad, e_att, atol=1e-9)
    assert cmp.within_3sigma is not None
    assert set(cmp.within_3sigma) == {f"{k}_{a}" for k in ("pos", "vel", "att") for a in "ned"}
    # Gaussian: 0.9973 expected; binomial sd over ~2000 epochs ~ 0.0012.
    for key, share in cmp.within_3sigma.items():
        assert 0.99 <= share <= 1.0, (key, share)
    rms_expected = np.sqrt(np.mean(s_pos**2, axis=0))
    np.testing.assert_allclose(cmp.rms_pos_ned_m, rms_expected, rtol=0.1)
    # Reported σ five times too small: about 45 % inside 3σ.
    small = _solution(
        t, e_pos, e_vel, np.zeros(3), sigma=(s_pos / 5, s_vel / 5, s_att / 5), d_rot=e_att
    )
    shares = compare_to_truth(small, _truth(t)).within_3sigma
    assert shares is not None
    for key, share in shares.items():
        assert 0.35 < share < 0.55, (key, share)


def test_local_ned_truth_and_document() -> None:
    t = np.arange(0.0, 50.0, 0.1)
    pos, _vel, rpy = _path(t)
    truth = Trajectory.from_euler(
        t, rpy[:, 0], rpy[:, 1], rpy[:, 2], pos_ned_m=pos, origin_lat_lon_h=ORIGIN
    )
    sol = _solution(t, np.array([0.0, 0.3, 0.0]), np.zeros(3), np.zeros(3))
    cmp = compare_to_truth(sol, truth)
    np.testing.assert_allclose(cmp.rms_pos_ned_m, [0.0, 0.3, 0.0], atol=2e-3)  # NED tilt over 200 m
    assert cmp.rms_vel_ned_m_s is None  # the truth has no velocities
    doc = cmp.as_document()
    assert set(doc) == {
        "rms_pos_ned_m",
        "rms_vel_ned_m_s",
        "rms_att_deg",
        "max_pos_ned_m",
        "max_vel_ned_m_s",
        "max_att_deg",
        "within_3sigma",
        "n_epochs",
        "n_epochs_outside_truth",
        "n_epochs_in_truth_gaps",
        "truth_gaps",
        "gap_threshold_s",
        "rms_misorientation_ned_deg",
        "max_abs_pitch_deg",
    }
    assert doc["rms_vel_ned_m_s"] is None
    assert doc["n_epochs"] == t.size
    assert doc["within_3sigma"]["pos_e"] == 1.0
    assert "vel_n" not in doc["within_3sigma"]


def test_local_ned_solution() -> None:
    t = np.arange(0.0, 50.0, 0.1)
    pos, _vel, rpy = _path(t)
    sol = Trajectory.from_euler(
        t,
        rpy[:, 0],
        rpy[:, 1],
        rpy[:, 2],
        pos_ned_m=pos + np.array([0.0, 0.0, 1.0]),
        origin_lat_lon_h=ORIGIN,
    )
    cmp = compare_to_truth(sol, _truth())
    np.testing.assert_allclose(cmp.rms_pos_ned_m, [0.0, 0.0, 1.0], atol=2e-3)
    np.testing.assert_allclose(
        np.degrees(quaternion_to_euler_rpy(sol.q_body_to_ned)), np.degrees(rpy), atol=1e-9
    )


def test_no_common_times_is_an_error() -> None:
    t = np.arange(200.0, 210.0, 0.1)
    with pytest.raises(InputError, match=r"no common times.*same time scale"):
        compare_to_truth(_solution(t, np.zeros(3), np.zeros(3), np.zeros(3)), _truth())


def _shifted_solution(shift_s: float) -> NavSolution:
    """The truth's own states, tagged ``shift_s`` early (UTC tags for a GPS-time truth)."""
    t = np.arange(30.0, 150.0, 0.2)
    sol = _solution(t + shift_s, np.zeros(3), np.zeros(3), np.zeros(3))
    return replace(sol, t_s=t)


@pytest.mark.parametrize("shift_s", [18.0, -18.0, 15.0])
def test_a_solution_a_leap_second_count_off_the_truth_is_named(shift_s: float) -> None:
    # At 10 m/s, 18 s apart read as 170-360 m of "error" with exit 0.
    whole = int(abs(shift_s))
    side = "behind" if shift_s > 0 else "ahead of"
    with pytest.raises(InputError, match=rf"matches the reference {whole} s .* {side} the refer"):
        compare_to_truth(_shifted_solution(shift_s), _truth(np.arange(0.0, 200.0, 0.1)))


def test_a_solution_genuinely_off_is_compared_not_refused() -> None:
    t = np.arange(30.0, 150.0, 0.2)
    cmp = compare_to_truth(
        _solution(t, np.array([40.0, -25.0, 3.0]), np.zeros(3), np.zeros(3)),
        _truth(np.arange(0.0, 200.0, 0.1)),
    )
    np.testing.assert_allclose(cmp.rms_pos_ned_m, [40.0, 25.0, 3.0], rtol=1e-3)
    # A shift of other than whole leap seconds is the filter's error, not a time scale.
    cmp = compare_to_truth(_shifted_solution(0.5), _truth(np.arange(0.0, 200.0, 0.1)))
    assert cmp.rms_pos_ned_m[0] > 1.0
