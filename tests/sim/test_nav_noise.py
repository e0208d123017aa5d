"""The first-order Gauss-Markov position error of `kinsync.sim.nav_noise`."""

from __future__ import annotations

import numpy as np
import pytest

from kinsync.errors import InputError
from kinsync.sim.nav_noise import gauss_markov_trajectory
from kinsync.trajectory import Trajectory


def _straight(n: int = 20001, dt_s: float = 0.1) -> Trajectory:
    t = np.arange(n, dtype=np.float64) * np.float64(dt_s)
    llh = np.column_stack([np.full(n, 46.8), np.full(n, -71.2), np.full(n, 10.0)])
    q = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    return Trajectory(t_s=t, q_body_to_ned=q, lat_lon_h=llh, vel_ned_m_s=np.zeros((n, 3)))


def test_sigma_and_correlation_are_the_model_s() -> None:
    truth = _straight()
    noisy = gauss_markov_trajectory(truth, std_m=0.02, corr_time_s=5.0, seed=3)
    assert noisy.lat_lon_h is not None
    north_m = (noisy.lat_lon_h[:, 0] - 46.8) * np.pi / 180.0 * 6.37e6
    assert np.std(north_m) == pytest.approx(0.02, rel=0.15)
    lag = 50  # 5 s at 10 Hz: correlation exp(-1)
    rho = np.corrcoef(north_m[:-lag], north_m[lag:])[0, 1]
    assert rho == pytest.approx(np.exp(-1.0), abs=0.1)
    assert np.array_equal(noisy.q_body_to_ned, truth.q_body_to_ned)
    again = gauss_markov_trajectory(truth, std_m=0.02, corr_time_s=5.0, seed=3)
    assert again.lat_lon_h is not None
    assert np.array_equal(again.lat_lon_h, noisy.lat_lon_h)


@pytest.mark.parametrize(("std_m", "corr_time_s"), [(-0.01, 5.0), (0.02, 0.0), (0.02, np.nan)])
def test_bad_parameters_are_input_errors(std_m: float, corr_time_s: float) -> None:
    with pytest.raises(InputError):
        gauss_markov_trajectory(_straight(10), std_m=std_m, corr_time_s=corr_time_s, seed=0)
