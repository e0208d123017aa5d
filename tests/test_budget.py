"""Latency, serial and period budgets against hand-derived geometry."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kinsync.budget import (
    Scenario,
    beach_scenario,
    bits_per_serial_byte,
    cross_track_scenario,
    latency_beam_error,
    period_error_budget,
    rolling_table_scenario,
    serial_transmission_time_s,
)
from kinsync.errors import InputError


def beach_by_hand(range_m: float, slope_deg: float, eps_rad: float) -> tuple[float, float]:
    """Horizontal beam, ground rising at alpha through the point at range R (2-D section).

    The true beam (elevation eps towards the slope) meets the ground at
    r = R sin(alpha) / sin(alpha - eps). That range placed along the horizontal beam
    lies (r - R) tan(alpha) below the ground; the true hit is r cos(eps) from the
    scanner horizontally against R for the assumed one.
    """
    a = math.radians(slope_deg)
    r = range_m * math.sin(a) / math.sin(a - eps_rad)
    return -(r - range_m) * math.tan(a), abs(r * math.cos(eps_rad) - range_m)


@pytest.mark.parametrize("latency_ms", [0.1, 1.0, 10.0, 50.0, 200.0])
def test_beach_matches_hand_geometry(latency_ms: float) -> None:
    eps = math.radians(10.0) * latency_ms * 1e-3
    b = latency_beam_error(beach_scenario(50.0, 10.0, 10.0), latency_ms * 1e-3)
    # Worse sign: beam turned up towards the slope (longer range, nearer grazing).
    v, h = beach_by_hand(50.0, 10.0, eps)
    assert b.vertical_error_m is not None
    assert b.vertical_error_m == pytest.approx(v, rel=1e-9)
    assert b.horizontal_error_m == pytest.approx(h, rel=1e-9)
    assert b.attitude_error_rad == pytest.approx(eps, rel=1e-12)
    # The other sign is smaller.
    v_other, h_other = beach_by_hand(50.0, 10.0, -eps)
    assert abs(v_other) < abs(v)
    assert h_other < h


def test_small_angle_linearisation_off_by_more_than_one_percent_near_grazing() -> None:
    # 50 ms at 10 deg/s = 0.5 deg attitude error against a 10 deg slope.
    b = latency_beam_error(beach_scenario(50.0, 10.0, 10.0), 0.05)
    v, _ = beach_by_hand(50.0, 10.0, math.radians(0.5))
    assert b.vertical_error_m == pytest.approx(v, rel=1e-9)
    assert b.vertical_error_linear_m is not None
    # First order: vertical = R * eps.
    assert abs(b.vertical_error_linear_m) == pytest.approx(50.0 * math.radians(0.5), rel=1e-5)
    assert b.vertical_error_m is not None
    assert abs(b.vertical_error_m / b.vertical_error_linear_m - 1.0) > 0.01
    assert abs(b.horizontal_error_m / b.horizontal_error_linear_m - 1.0) > 0.01


def test_small_latency_agrees_with_first_order() -> None:
    b = latency_beam_error(beach_scenario(50.0, 10.0, 10.0), 1e-4)
    assert b.vertical_error_linear_m is not None
    assert b.vertical_error_m is not None
    assert b.vertical_error_m == pytest.approx(b.vertical_error_linear_m, rel=2e-3)
    assert b.horizontal_error_m == pytest.approx(b.horizontal_error_linear_m, rel=2e-3)


def test_first_order_values_of_a_tiny_latency_do_not_underflow() -> None:
    """Was: 1e-12 s gave vertical_error_linear_m 0.0 (exact -8.7e-12 m): the first-order
    value was the exact one at a million times smaller an angle, divided back up."""
    eps = math.radians(10.0) * 1e-12
    b = latency_beam_error(beach_scenario(50.0, 10.0, 10.0), 1e-12)
    assert b.vertical_error_linear_m is not None
    assert b.vertical_error_m is not None
    vertical = math.copysign(50.0 * eps, b.vertical_error_m)
    assert b.vertical_error_linear_m == pytest.approx(vertical, rel=1e-9, abs=0.0)
    # first order, horizontally: R eps / tan(slope)
    horizontal = 50.0 * eps / math.tan(math.radians(10.0))
    assert b.horizontal_error_linear_m == pytest.approx(horizontal, rel=1e-9, abs=0.0)
    assert b.horizontal_error_m == pytest.approx(horizontal, rel=1e-3, abs=0.0)


def test_nadir_beam_on_flat_ground_with_3d_rate() -> None:
    # Beam straight down at height 30 m; rate of 20 deg/s about the horizontal diagonal.
    axis = np.array([1.0, 1.0, 0.0]) / math.sqrt(2.0)
    rate = axis * math.radians(20.0)
    sc = Scenario(
        "nadir", 30.0, (0.0, 0.0, 1.0), (0.0, 0.0, -1.0), (float(rate[0]), float(rate[1]), 0.0)
    )
    tau = 0.02
    eps = math.radians(20.0) * tau
    b = latency_beam_error(sc, tau)
    r_true = 30.0 / math.cos(eps)
    assert b.vertical_error_m == pytest.approx(-(r_true - 30.0), rel=1e-9)
    assert b.horizontal_error_m == pytest.approx(30.0 * math.tan(eps), rel=1e-9)
    assert b.range_true_m == pytest.approx(r_true, rel=1e-12)


def test_rotation_about_the_beam_does_nothing() -> None:
    sc = Scenario("yaw", 30.0, (0.0, 0.0, 1.0), (0.0, 0.0, -1.0), (0.0, 0.0, 1.0))
    b = latency_beam_error(sc, 0.01)
    assert b.vertical_error_m == pytest.approx(0.0, abs=1e-12)
    assert b.horizontal_error_m == pytest.approx(0.0, abs=1e-12)


def test_rolling_table_wall_has_no_vertical_error_defined() -> None:
    b = latency_beam_error(rolling_table_scenario(0.0), 1e-3)
    assert b.vertical_error_m is None
    roll_rate = 2 * math.pi * math.radians(6.0)
    eps = math.hypot(roll_rate, math.radians(1.0)) * 1e-3
    assert b.attitude_error_rad == pytest.approx(eps)
    # Horizontal beam at a wall: the roll moves the hit point vertically by ~25 m * eps_roll.
    assert b.point_error_m == pytest.approx(25.0 * roll_rate * 1e-3, rel=0.02)


def test_beam_that_misses_the_surface_is_an_error() -> None:
    # 2 deg attitude error against a 1 deg slope: the raised beam never meets the ground.
    with pytest.raises(InputError, match="grazing"):
        latency_beam_error(beach_scenario(50.0, 1.0, 10.0), 0.2)


def test_attitude_error_equal_to_the_grazing_angle_is_an_error() -> None:
    # 1000 ms at 10 deg/s is 10 deg against a 10 deg slope: the true beam runs along the
    # surface. Rounding left cos ~1e-17 and a vertical error of -6.8e16 m.
    sc = beach_scenario(50.0, 10.0, 10.0)
    with pytest.raises(InputError, match="reaches or exceeds the grazing angle"):
        latency_beam_error(sc, 1.0)
    with pytest.raises(InputError, match="grazing"):
        latency_beam_error(sc, 1.0 + 1e-10)
    near = latency_beam_error(sc, 0.999)  # 0.01 deg short of grazing: a finite answer
    assert near.vertical_error_m is not None
    assert 1e2 < abs(near.vertical_error_m) < 1e6


@pytest.mark.parametrize("latency_s", [36.0, 35.0, 18.0, -36.0])
def test_attitude_error_of_half_a_turn_or_more_is_an_error(latency_s: float) -> None:
    # At 10 deg/s, 36 s is a full turn: the rotation wrapped to none and the budget read
    # 1e-11 mm; 35 s (350 deg) read as a 10 deg error of the other sign.
    with pytest.raises(InputError, match="half a turn or more"):
        latency_beam_error(beach_scenario(50.0, 10.0, 10.0), latency_s)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"range_m": -50.0}, "positive"),
        ({"range_m": 0.0}, "positive"),
        ({"range_m": math.nan}, "finite"),
        ({"slope_deg": 0.0}, "slope"),
        ({"slope_deg": 90.0}, "slope"),
        ({"rate_deg_s": math.inf}, "finite"),
    ],
)
def test_bad_beach_parameters(kwargs: dict[str, float], match: str) -> None:
    with pytest.raises(InputError, match=match):
        beach_scenario(**kwargs)


def test_bad_scenario_vectors() -> None:
    with pytest.raises(InputError, match="zero vector"):
        Scenario("x", 10.0, (0.0, 0.0, 0.0), (0.0, 0.0, -1.0), (0.0, 0.0, 0.0))
    with pytest.raises(InputError, match="parallel"):
        Scenario("x", 10.0, (1.0, 0.0, 0.0), (0.0, 0.0, -1.0), (0.0, 0.0, 0.0))
    with pytest.raises(InputError, match="latency_s"):
        latency_beam_error(beach_scenario(), math.nan)


def test_serial_fifo_delay() -> None:
    assert serial_transmission_time_s(14, 115200) == pytest.approx(14 * 10 / 115200)
    assert serial_transmission_time_s(14, 9600, 8, "even", 1) == pytest.approx(14 * 11 / 9600)
    assert serial_transmission_time_s(3, 4800, 7, "odd", 2) == pytest.approx(3 * 11 / 4800)
    assert bits_per_serial_byte(8, "none", 1.5) == 10.5
    assert serial_transmission_time_s(0, 115200) == 0.0


@pytest.mark.parametrize(
    ("args", "match"),
    [
        ((14, -115200.0), "baud"),
        ((14, 0.0), "baud"),
        ((-1, 115200.0), "bytes"),
        ((1.5, 115200.0), "bytes"),
        ((14, 115200.0, 9), "data bits"),
        ((14, 115200.0, 8, "weird"), "parity"),
        ((14, 115200.0, 8, "none", 3), "stop bits"),
    ],
)
def test_serial_bad_input(args: tuple[object, ...], match: str) -> None:
    with pytest.raises(InputError, match=match):
        serial_transmission_time_s(*args)  # type: ignore[arg-type]


def test_period_budget() -> None:
    b = period_error_budget(10000, 1e-6, 2.0)
    assert b.time_error_s == pytest.approx(0.01)
    assert b.position_error_m == pytest.approx(0.02)
    neg = period_error_budget(100, -1e-5, 3.0)
    assert neg.time_error_s == pytest.approx(-1e-3)
    assert neg.position_error_m == pytest.approx(3e-3)
    with pytest.raises(InputError, match="speed"):
        period_error_budget(10, 1e-6, -1.0)
    with pytest.raises(InputError, match="profiles"):
        period_error_budget(-3, 1e-6, 1.0)


def test_the_beach_is_the_horizontal_cross_track_beam() -> None:
    beach = beach_scenario(50.0, 10.0, 10.0)
    beam = cross_track_scenario(50.0, 10.0, 10.0, beam_deg=0.0)
    assert (beam.beam_ned, beam.normal_ned, beam.rate_ned_rad_s, beam.vel_ned_m_s) == (
        beach.beam_ned, beach.normal_ned, beach.rate_ned_rad_s, (0.0, 0.0, 0.0)
    )  # fmt: skip
    assert beach.name.startswith("beach 10 deg")


def test_speed_adds_the_misplaced_scanner_and_only_that() -> None:
    """At rest the point error is the attitude's alone; at speed the scanner of the wrong
    instant is misplaced by v tau along the track, perpendicular to the cross-track
    attitude error on flat ground."""
    still = latency_beam_error(cross_track_scenario(800.0, 0.0, 5.0, 75.0), 0.002)
    moving = latency_beam_error(cross_track_scenario(800.0, 0.0, 5.0, 75.0, 50.0), 0.002)
    assert still.position_error_m == 0.0
    assert moving.position_error_m == pytest.approx(0.1)
    assert moving.point_horizontal_error_m == pytest.approx(
        math.hypot(still.point_horizontal_error_m, 0.1), rel=1e-9
    )
    assert moving.vertical_error_m == pytest.approx(still.vertical_error_m, rel=1e-9)
    assert moving.horizontal_error_linear_m == pytest.approx(
        math.hypot(still.horizontal_error_linear_m, 0.1), rel=1e-9
    )


@pytest.mark.parametrize(
    ("kwargs", "fragment"),
    [
        ({"slope_deg": 0.0, "beam_deg": 0.0}, "a horizontal beam never meets a flat surface"),
        ({"beam_deg": 95.0}, "beam_deg"),
        ({"beam_deg": -5.0}, "beam_deg"),
        ({"slope_deg": 90.0}, "slope_deg"),
        ({"speed_m_s": -1.0}, "speed_m_s"),
        ({"speed_m_s": math.inf}, "speed_m_s"),
    ],
)
def test_cross_track_scenario_refuses_bad_geometry(kwargs: dict[str, float], fragment: str) -> None:
    with pytest.raises(InputError, match=fragment):
        cross_track_scenario(**kwargs)


def test_a_scenario_velocity_must_be_finite() -> None:
    with pytest.raises(InputError, match="vel_ned_m_s"):
        Scenario("x", 10.0, (0, 0, 1), (0, 0, -1), (0.1, 0, 0), (math.nan, 0.0, 0.0))
