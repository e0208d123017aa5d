"""Cramér-Rao planner of Method A."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from kinsync.errors import InputError, ObservabilityError
from kinsync.latency.planning import TableDesign, plan_latency_experiment


def test_points_per_pass_match_the_angular_disc() -> None:
    plan = plan_latency_experiment(TableDesign(rates_deg_s=(6.0, 18.0)))
    # Disc of angular radius asin(0.1/1.5) over a grid of (6/50 deg) x (0.2 deg) cells.
    disc_deg2 = math.pi * math.degrees(math.asin(0.1 / 1.5)) ** 2
    assert plan.per_rate[0].points_per_pass == pytest.approx(disc_deg2 / (0.12 * 0.2), rel=0.02)
    assert plan.per_rate[1].points_per_pass == pytest.approx(disc_deg2 / (0.36 * 0.2), rel=0.03)


def test_latency_sigma_falls_as_the_rate_grows() -> None:
    plan = plan_latency_experiment(TableDesign())
    sig = [r.latency_std_s for r in plan.per_rate]
    assert all(b < a for a, b in itertools.pairwise(sig))
    centre = [r.center_std_m for r in plan.per_rate]
    assert all(b > a for a, b in itertools.pairwise(centre))
    assert plan.latency_std_s < min(sig)
    expected = sum(1 / s**2 for s in sig) ** -0.5
    assert plan.latency_std_s == pytest.approx(expected)


def test_scaling_with_noise_and_passes() -> None:
    base = plan_latency_experiment(TableDesign(rates_deg_s=(6.0,)), seed=3)
    noisier = plan_latency_experiment(TableDesign(rates_deg_s=(6.0,), range_noise_m=0.004), seed=3)
    more = plan_latency_experiment(TableDesign(rates_deg_s=(6.0,), passes=60), seed=3)
    assert noisier.latency_std_s == pytest.approx(2 * base.latency_std_s, rel=1e-9)
    assert more.latency_std_s == pytest.approx(base.latency_std_s / 2, rel=1e-9)
    assert base.passes_for_target(base.latency_std_s / 2) == 60
    assert base.passes_for_target(base.latency_std_s * 10) == 1


def test_latency_sigma_matches_the_tangential_centre_sigma() -> None:
    # The latency separates the pools by 2 w tau D across the line of sight, so with
    # equal, independent pool covariances sigma_tau = sqrt(2) sigma_t / (2 w D).
    plan = plan_latency_experiment(TableDesign(rates_deg_s=(10.0,)))
    r = plan.per_rate[0]
    w = math.radians(10.0)
    assert r.latency_std_s == pytest.approx(
        math.sqrt(2) * r.center_tangential_std_m / (2 * w * 1.5), rel=0.02
    )


def test_free_radius_costs_little_across_the_line_of_sight() -> None:
    known = plan_latency_experiment(TableDesign(rates_deg_s=(6.0,)), seed=1)
    free = plan_latency_experiment(TableDesign(rates_deg_s=(6.0,), radius_known=False), seed=1)
    assert free.per_rate[0].center_std_m > known.per_rate[0].center_std_m
    assert free.latency_std_s == pytest.approx(known.latency_std_s, rel=0.05)


def test_default_design_reaches_a_tenth_of_a_millisecond() -> None:
    plan = plan_latency_experiment(TableDesign())
    assert plan.latency_std_s < 1e-4
    assert np.isfinite([r.latency_std_s for r in plan.per_rate]).all()


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"range_noise_m": -0.002}, InputError, "range_noise_m"),
        ({"sphere_radius_m": 0.0}, InputError, "sphere_radius_m"),
        ({"sphere_radius_m": 2.0}, InputError, "smaller"),
        ({"passes": 0}, InputError, "passes"),
        ({"rates_deg_s": ()}, InputError, "rate"),
        ({"rates_deg_s": (0.0, 6.0)}, InputError, "rate"),
        ({"profile_rate_hz": math.nan}, InputError, "profile_rate_hz"),
        ({"sphere_elevation_deg": 90.0}, ObservabilityError, "axis"),
    ],
)
def test_bad_designs(kwargs: dict[str, object], error: type[Exception], match: str) -> None:
    with pytest.raises(error, match=match):
        TableDesign(**kwargs)  # type: ignore[arg-type]
