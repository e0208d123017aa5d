"""`NavSolution.std_rpy_rad`: roll, pitch, yaw σ from the misorientation σ about N, E, D."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from kinsync.frames import euler_rpy_to_matrix, matrix_to_euler_rpy
from kinsync.ins.solution import NavSolution

N = 40


def _solution(rpy_rad: np.ndarray, std_att_rad: np.ndarray) -> NavSolution:
    zeros = np.zeros((N, 3))
    return NavSolution(
        t_s=np.arange(N, dtype=np.float64),
        lat_deg=np.full(N, 45.0),
        lon_deg=np.full(N, -70.0),
        h_m=np.zeros(N),
        vel_ned_m_s=zeros,
        rpy_rad=rpy_rad,
        std_pos_ned_m=zeros + 0.1,
        std_vel_ned_m_s=zeros + 0.01,
        std_att_rad=std_att_rad,
        gyro_bias_rad_s=zeros,
        acc_bias_m_s2=zeros,
        std_gyro_bias_rad_s=zeros,
        std_acc_bias_m_s2=zeros,
    )


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_a_misorientation_about_one_axis_moves_the_euler_angles_by_their_sigma(
    axis: int,
) -> None:
    """With σ about one NED axis only, each Euler σ is how far that rotation moves it."""
    rng = np.random.default_rng(axis)
    rpy = np.column_stack(
        [rng.uniform(-0.5, 0.5, N), rng.uniform(-1.2, 1.2, N), rng.uniform(-3.1, 3.1, N)]
    )
    size_rad = 1e-6
    std = np.zeros((N, 3))
    std[:, axis] = size_rad
    got = _solution(rpy, std).std_rpy_rad()
    turn = np.zeros(3)
    turn[axis] = size_rad
    R = euler_rpy_to_matrix(rpy[:, 0], rpy[:, 1], rpy[:, 2])
    moved = matrix_to_euler_rpy(Rotation.from_rotvec(turn).as_matrix() @ R)
    step = np.angle(np.exp(1j * (moved - rpy)))  # wrapped to ±π
    np.testing.assert_allclose(got, np.abs(step), rtol=1e-4, atol=1e-4 * size_rad)


def test_level_and_north_the_sigmas_are_those_about_n_e_d() -> None:
    std = np.tile([1e-3, 2e-3, 3e-3], (N, 1))
    got = _solution(np.zeros((N, 3)), std).std_rpy_rad()
    np.testing.assert_allclose(got, std, rtol=1e-15)
