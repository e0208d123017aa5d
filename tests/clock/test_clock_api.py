"""The clock's Python API used directly (as from a notebook), not through the files."""

from __future__ import annotations

import numpy as np
import pytest

from kinsync._unix_time import UNIX_MINUS_GPS_S
from kinsync.clock import ClockModel, fit_clock, utc_to_gps_s
from kinsync.errors import InputError
from kinsync.sim.clock import ClockSimConfig, simulate_clock


def test_fit_clock_refuses_zda_times_given_as_unix_seconds() -> None:
    """Unix seconds read as GPS time gave a model ten years late, without a word."""
    sim = simulate_clock(ClockSimConfig(duration_s=30.0, seed=3))
    assert fit_clock(sim.pps_t_local_s, sim.zda_t_local_s, sim.zda_gps_s, sim.zda_n_bytes)
    as_unix = sim.zda_gps_s + UNIX_MINUS_GPS_S
    with pytest.raises(InputError, match=r"^zda_gps_s: index 0 \(0-based\): .* looks like Unix"):
        fit_clock(sim.pps_t_local_s, sim.zda_t_local_s, as_unix, sim.zda_n_bytes)


def test_clock_model_refuses_a_reference_after_today() -> None:
    unix_s = 1_704_067_200.0  # 2024-01-01 as Unix time: 2034 as GPS time
    ClockModel(10.0, float(utc_to_gps_s(unix_s)), 0.0, (10.0, 20.0))
    with pytest.raises(InputError, match=r"^clock: reference_gps_s: .* looks like Unix time"):
        ClockModel(10.0, unix_s, 0.0, (10.0, 20.0))
    knots_gps = np.array([1.4e9, unix_s])
    with pytest.raises(InputError, match=r"^clock: knots_gps_s: .* after today"):
        ClockModel(10.0, 1.4e9, 0.0, (10.0, 20.0), np.array([10.0, 20.0]), knots_gps)
