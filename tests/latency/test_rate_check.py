"""The table rate each pass's data show, against the rate passes.csv states."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from kinsync.errors import InputError, KinsyncWarning
from kinsync.latency.passes import SpherePass
from kinsync.latency.rate_check import (
    RatesUncheckedWarning,
    attitude_rate_deg_s,
    attitude_rate_offsets,
    attitude_rate_std_deg_s,
    check_pass_rates,
    points_azimuth_rate_deg_s,
)
from kinsync.latency.sphere import estimate_latency_sphere
from kinsync.sim.rotating_table import simulate_rotating_table
from kinsync.sim.table_config import RotatingTableConfig


def _swept_points(rate_deg_s: float, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Returns of a profile scanner on the axis (+Down) turning at ``rate_deg_s``.

    The scan plane is vertical and turns with the table: each return lies at the beam's
    azimuth (North = 0, clockwise seen from above), 1.2 to 1.6 m out.
    """
    rng = np.random.default_rng(seed)
    t = np.sort(rng.uniform(0.0, 10.0 / abs(rate_deg_s), 2000))
    azimuth = np.radians(100.0 + rate_deg_s * t)
    horizontal = rng.uniform(1.2, 1.6, t.size)
    down = rng.uniform(-0.3, 0.3, t.size)
    points = np.column_stack([horizontal * np.cos(azimuth), horizontal * np.sin(azimuth), down])
    return points, 1.4e9 + t


@pytest.mark.parametrize("rate_deg_s", [2.0, -2.0, 18.0])
def test_points_turn_with_the_stated_sign_about_down(rate_deg_s: float) -> None:
    points, t = _swept_points(rate_deg_s)
    shown = points_azimuth_rate_deg_s(points, t, (0.0, 0.0, 1.0))
    assert shown == pytest.approx(rate_deg_s, rel=1e-6)
    # about -Down the same turn is negative
    flipped = points_azimuth_rate_deg_s(points, t, (0.0, 0.0, -1.0))
    assert flipped == pytest.approx(-rate_deg_s, rel=1e-6)


def test_points_that_do_not_sweep_are_not_judged() -> None:
    points, t = _swept_points(2.0)
    rng = np.random.default_rng(1)
    assert points_azimuth_rate_deg_s(points, rng.permutation(t), (0.0, 0.0, 1.0)) is None


def test_attitude_turning_about_down_shows_a_positive_rate() -> None:
    t = np.arange(0.0, 30.0, 0.01)
    yaw = np.radians(80.0 + 12.0 * t)  # past a full turn: summed record by record
    rotations = Rotation.from_euler("ZYX", np.column_stack([yaw, 0 * t, 0 * t])).as_matrix()
    assert attitude_rate_deg_s(t, rotations, (0.0, 0.0, 1.0)) == pytest.approx(12.0)
    tilted = (math.sin(0.1), 0.0, math.cos(0.1))
    assert attitude_rate_deg_s(t, rotations, tilted) == pytest.approx(12.0 * math.cos(0.1))


def _pass(name: str, stated: float, shown: float, *, times: bool = True) -> SpherePass:
    points, t = _swept_points(shown)
    return SpherePass(name, stated, points, t_s=t if times else None)


def test_a_pass_turning_against_its_rate_is_named() -> None:
    passes = [_pass(f"p{k}.csv", r, r) for k, r in enumerate((6.0, -6.0, 6.0, -6.0))]
    check_pass_rates(passes)  # consistent: nothing raised
    passes[2] = _pass("p2.csv", -6.0, 6.0)
    with pytest.raises(InputError, match=r"1 of 4 passes turns the other way") as info:
        check_pass_rates(passes)
    assert "p2.csv: stated -6 deg/s, shows +6 deg/s" in str(info.value)
    assert "p0.csv" not in str(info.value)
    # without point times nothing can be judged
    passes[2] = _pass("p2.csv", -6.0, 6.0, times=False)
    check_pass_rates(passes)


def test_rates_in_rad_s_are_named_as_such() -> None:
    passes = [_pass(f"p{k}.csv", math.radians(r), r) for k, r in enumerate((2.0, -2.0))]
    with pytest.raises(InputError, match=r"look like rad/s"):
        check_pass_rates(passes)


def test_a_rate_three_times_too_high_is_refused() -> None:
    passes = [_pass("p0.csv", 6.0, 2.0), _pass("p1.csv", -2.0, -2.0)]
    with pytest.raises(InputError, match=r"1 of 2 passes turns otherwise.*p0.csv: stated \+6"):
        check_pass_rates(passes)


def test_points_all_around_the_axis_are_not_judged() -> None:
    # An axis given through the scene (the sphere): its azimuth says nothing of the turn.
    rng = np.random.default_rng(2)
    d = rng.normal(size=(500, 3))
    points = np.array([1.4, 0.0, 0.0]) + 0.1 * d / np.linalg.norm(d, axis=1, keepdims=True)
    t = np.linspace(0.0, 2.0, 500)
    assert points_azimuth_rate_deg_s(points, t, (1.0, 0.0, 0.0)) is None


def test_attitude_rate_offsets_name_the_passes_off_by_more_than_the_tolerance() -> None:
    rates = [("a.csv", 10.3, 10.0, 0.001), ("b.csv", -10.1, -10.0, 0.001)]
    text = attitude_rate_offsets(rates, "the attitude log attitude.csv")
    assert text.startswith("the stated table rate of 1 of 2 passes is more than 2 % off")
    assert "a.csv: stated +10.3 deg/s, shows +10 deg/s (+3.0 %)" in text
    assert "b.csv" not in text
    assert "gon" not in text
    # An offset within 5 sigma of a poorly measured rate is not refused.
    assert attitude_rate_offsets([("a.csv", 10.3, 10.0, 0.1)], "the log") == ""
    gon = [(f"p{k}.csv", 10.0 * 400 / 360, 10.0, 0.001) for k in range(3)]
    assert "rates in gon/s?" in attitude_rate_offsets(gon, "the log")


def test_attitude_rate_sigma_covers_white_attitude_noise() -> None:
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 10.0, 0.01)
    rate = np.radians(6.0)
    rates = []
    for _ in range(200):
        yaw = rate * t + rng.normal(0.0, np.radians(0.001), t.size)
        R = Rotation.from_rotvec(np.outer(yaw, [0.0, 0.0, 1.0])).as_matrix()
        shown_rate = attitude_rate_deg_s(t, R, (0.0, 0.0, 1.0))
        assert shown_rate is not None
        rates.append((shown_rate, attitude_rate_std_deg_s(t, R, (0.0, 0.0, 1.0))))
    shown = np.array([r for r, _ in rates])
    sigma = np.array([s for _, s in rates])
    # Generous: never smaller than the spread (white noise cancels in the sum).
    assert float(np.std(shown)) < float(np.median(sigma))
    assert float(np.median(sigma)) < 0.002 * 6.0  # still far inside the 2 % tolerance


def test_estimate_warns_from_python_when_the_rates_were_not_checked() -> None:
    """Without point times, passes of flipped sign gave -tau silently from Python (the
    command line warned); now a RatesUncheckedWarning carries rates_unchecked_text."""
    cfg = RotatingTableConfig(latency_s=0.004, rates_deg_s=(18.0,), passes=1, seed=4)
    passes = simulate_rotating_table(cfg).passes
    with warnings.catch_warnings():
        warnings.simplefilter("error", RatesUncheckedWarning)  # none: every rate is checked
        checked = estimate_latency_sphere(passes, radius_m=0.1)
    timeless = [SpherePass(p.source, -p.rate_deg_s, p.points_ned_m) for p in passes]
    with pytest.warns(RatesUncheckedWarning) as caught:
        flipped = estimate_latency_sphere(timeless, radius_m=0.1)
    assert flipped.latency_s == pytest.approx(-checked.latency_s, abs=3 * checked.latency_std_s)
    assert [str(w.message) for w in caught] == [flipped.rates_unchecked_text()]
    assert flipped.rates_unchecked_text().startswith("the sign and unit of the table rates")
    assert caught[0].filename == __file__  # points at the caller's line
    assert issubclass(RatesUncheckedWarning, KinsyncWarning)
