"""The clock's Python API used directly (as from a notebook), not through the files."""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest

from kinsync._unix_time import UNIX_MINUS_GPS_S
from kinsync.clock import ClockModel, fit_clock, gps_to_utc_posix_s, utc_to_gps_s
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


def test_gps_to_utc_posix_s_takes_arrays_and_the_0d_array_utc_to_gps_s_gives() -> None:
    """It took one float only: an array, even utc_to_gps_s's own 0-d one, was refused."""
    unix_s = 1_704_067_200.0  # 2024-01-01
    g = utc_to_gps_s(unix_s)
    assert np.ndim(g) == 0
    back = gps_to_utc_posix_s(g)
    assert isinstance(back, np.ndarray)
    assert back.shape == ()
    assert float(back) == unix_s
    out = gps_to_utc_posix_s(float(g))
    assert type(out) is float
    assert out == unix_s
    # Each element gets its own leap seconds: 2016 (17 s), inside the leap second
    # 2016-12-31T23:59:60 (the next 00:00:00), 2017 (18 s), 1980 (none).
    new_year_2017 = 1_483_228_800.0
    t_gps = np.array([[1_167_264_016.0, 1_167_264_017.5], [1_167_264_018.0, 10.0]])
    want = np.array([[new_year_2017 - 1.0, new_year_2017], [new_year_2017, 315_964_810.0]])
    np.testing.assert_array_equal(gps_to_utc_posix_s(t_gps), want)
    assert gps_to_utc_posix_s(list(t_gps[0])).shape == (2,)
    with pytest.raises(InputError, match=r"^t_gps_s: -2\.0 \(index 1, 0-based\) is before"):
        gps_to_utc_posix_s(np.array([1.4e9, -2.0]))
    with pytest.raises(InputError, match=r"^t_gps_s: nan is not finite"):
        gps_to_utc_posix_s(math.nan)


def test_mapped_std_holds_the_rounding_of_the_applied_gps_time() -> None:
    """apply() returns float64 GPS times, in steps of 2.4e-7 s near 1.4e9 s: with little
    pulse jitter that rounding is the whole error, which mapped_std_s left out (it gave
    ~1e-10 s against ~7e-8 s)."""
    rng = np.random.default_rng(5)
    g0, l0, drift = 1.4e9, 1000.37, 25e-6
    gps = g0 + np.arange(120.0)
    local = l0 + (gps - g0) / (1.0 + drift)
    n_bytes = np.full(gps.size, 38)
    pps = local + rng.normal(0.0, 1e-9, gps.size)
    fit = fit_clock(pps, local + 0.015 + 38 * 10 / 115200, gps, n_bytes, baud=115200)
    m = fit.model
    t = m.reference_local_s + rng.uniform(0.0, 119.0, 2000)
    applied = m.apply(t)
    # Off the fitted line itself, computed exactly: only the rounding of apply().
    scale = 1 + Fraction(m.drift_ppm) / 10**6
    line = [
        Fraction(m.reference_gps_s) + (Fraction(x) - Fraction(m.reference_local_s)) * scale
        for x in t
    ]
    err = np.array([float(Fraction(a) - b) for a, b in zip(applied, line, strict=True)])
    std = fit.mapped_std_s(t)
    step = np.spacing(applied)
    assert np.all(np.abs(err) <= 0.5 * step * (1 + 1e-9))
    assert 0.9 < np.std(err / std) < 1.1  # the fit's own part is negligible here
    np.testing.assert_allclose(std, step / np.sqrt(12.0), rtol=0.01)
