"""Method A estimator: inject a latency through the simulator's physics, recover it."""

from __future__ import annotations

import itertools
import math
import re
from dataclasses import replace
from functools import cache

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from tests.fit.test_fit import edge_clutter

from kinsync.errors import InputError, ObservabilityError
from kinsync.fit import SphereFit
from kinsync.latency.passes import SpherePass, check_distinct_passes
from kinsync.latency.planning import TableDesign, plan_latency_experiment
from kinsync.latency.sphere import (
    PoolFit,
    SphereLatencyResult,
    estimate_latency_sphere,
    fit_pool,
    latency_from_pool_pair,
)
from kinsync.sim.rotating_table import simulate_rotating_table
from kinsync.sim.table_config import RotatingTableConfig

TAU_S = 0.00421


@cache
def default_simulation() -> tuple[SpherePass, ...]:
    return simulate_rotating_table(RotatingTableConfig(latency_s=TAU_S, seed=1)).passes


@pytest.mark.slow
def test_default_setup_recovers_the_latency_within_3_sigma_and_0p1_ms() -> None:
    result = estimate_latency_sphere(default_simulation(), radius_m=0.1)
    err = result.latency_s - TAU_S
    assert abs(err) < 3 * result.latency_std_s, (result.latency_s, result.latency_std_s)
    assert result.latency_std_s <= 1e-4
    sig = [r.latency_std_s for r in result.per_rate]
    assert all(b < a for a, b in itertools.pairwise(sig)), sig
    assert [r.rate_deg_s for r in result.per_rate] == [2, 4, 6, 10, 14, 18]
    assert result.p_value_between_rates > 1e-3
    np.testing.assert_allclose(result.sphere_radius_m, 0.1)
    # Reported sigma close to the planner's bound for the same design.
    plan = plan_latency_experiment(TableDesign())
    assert result.latency_std_s == pytest.approx(plan.latency_std_s, rel=0.2)
    # Every pass's clutter was left out: far fewer points used than given.
    for r in result.per_rate:
        assert r.plus.n_points < r.plus.n_points_in
        assert abs(r.latency_first_order_s - r.latency_s) < 0.1 * r.latency_std_s


def test_free_radius_gives_the_same_latency() -> None:
    passes = [p for p in default_simulation() if abs(p.rate_deg_s) in (6.0, 18.0)]
    known = estimate_latency_sphere(passes, radius_m=0.1)
    free = estimate_latency_sphere(passes)
    assert not free.radius_fixed
    assert free.sphere_radius_m == pytest.approx(0.1, abs=2e-4)
    assert abs(free.latency_s - known.latency_s) < known.latency_std_s


def small_simulation(
    tau_s: float, seed: int, rates: tuple[float, ...] = (18.0,)
) -> tuple[SpherePass, ...]:
    cfg = RotatingTableConfig(latency_s=tau_s, rates_deg_s=rates, passes=3, seed=seed)
    return simulate_rotating_table(cfg).passes


def test_negative_latency_comes_back_negative() -> None:
    result = estimate_latency_sphere(small_simulation(-0.0123, seed=5), radius_m=0.1)
    assert abs(result.latency_s + 0.0123) < max(4 * result.latency_std_s, 2e-4)


def test_tilted_table_uses_the_full_rate_vector() -> None:
    # Rotate the whole experiment rigidly: a table whose axis is 40 deg off vertical.
    tilt = Rotation.from_rotvec(np.radians(40.0) * np.array([0.6, 0.8, 0.0]))
    passes = [
        SpherePass(
            source=p.source,
            rate_deg_s=p.rate_deg_s,
            points_ned_m=tilt.apply(np.array(p.points_ned_m)),
            axis_ned=tuple(tilt.apply(np.array(p.axis_ned))),
        )
        for p in small_simulation(0.02, seed=7, rates=(10.0,))
    ]
    result = estimate_latency_sphere(passes, radius_m=0.1)
    assert abs(result.latency_s - 0.02) < max(4 * result.latency_std_s, 2e-4)
    # Using only the vertical component of the rate would be off by 1/cos(40 deg).
    assert abs(result.latency_s - 0.02 / math.cos(math.radians(40.0))) > 10 * result.latency_std_s


def synthetic_pool(rate_vector: np.ndarray, centre: np.ndarray, cov: np.ndarray) -> PoolFit:
    fit = SphereFit(
        center_m=centre,
        radius_m=0.1,
        radius_fixed=True,
        cov_center_m2=cov,
        radius_std_m=math.nan,
        residual_rms_m=0.002,
        n_points=1000,
        inliers=np.ones(1000, dtype=bool),
        residuals_m=np.zeros(1000),
        method="ray",
        iterations=1,
    )
    rate_deg = math.degrees(float(np.linalg.norm(rate_vector)))
    return PoolFit(
        rate_deg_s=rate_deg,
        rate_vector_ned_rad_s=rate_vector,
        n_passes=1,
        n_points_in=1000,
        n_points=1000,
        fit=fit,
        sources=("synthetic",),
    )


def test_exact_rotation_model_is_exact_where_first_order_is_not() -> None:
    axis = np.array([0.3, -0.2, 0.93])
    axis /= np.linalg.norm(axis)
    w = math.radians(30.0) * axis
    c = np.array([1.2, -0.8, 0.3])
    tau = 0.08  # 2.4 deg of rotation: first order is visibly off
    cov = np.eye(3) * 1e-10
    plus = synthetic_pool(w, Rotation.from_rotvec(-w * tau).apply(c), cov)
    minus = synthetic_pool(-w, Rotation.from_rotvec(w * tau).apply(c), cov)
    r = latency_from_pool_pair(plus, minus)
    assert r.latency_s == pytest.approx(tau, rel=1e-10)
    np.testing.assert_allclose(r.center_ned_m, c, atol=1e-12)
    assert abs(r.latency_first_order_s / tau - 1.0) > 1e-4
    assert r.chi2 < 1e-12


def test_reported_sigma_matches_monte_carlo_spread() -> None:
    rng = np.random.default_rng(11)
    w = math.radians(6.0) * np.array([0.0, 0.0, 1.0])
    c = np.array([1.5, 0.2, 0.0])
    cov = np.diag([4e-10, 1e-10, 2e-10])
    chol = np.linalg.cholesky(cov)
    taus, sigmas = [], []
    for _ in range(2000):
        plus = synthetic_pool(
            w, Rotation.from_rotvec(-w * TAU_S).apply(c) + chol @ rng.normal(size=3), cov
        )
        minus = synthetic_pool(
            -w, Rotation.from_rotvec(w * TAU_S).apply(c) + chol @ rng.normal(size=3), cov
        )
        r = latency_from_pool_pair(plus, minus)
        taus.append(r.latency_s)
        sigmas.append(r.latency_std_s)
    spread = float(np.std(taus, ddof=1))
    assert spread == pytest.approx(float(np.mean(sigmas)), rel=0.08)
    assert abs(np.mean(taus) - TAU_S) < 4 * spread / math.sqrt(len(taus))


def test_pipeline_sigma_is_honest_over_repeats() -> None:
    taus, sigmas = [], []
    for seed in range(30):
        result = estimate_latency_sphere(small_simulation(TAU_S, seed=100 + seed), radius_m=0.1)
        taus.append(result.latency_s)
        sigmas.append(result.latency_std_s)
    z = (np.array(taus) - TAU_S) / np.array(sigmas)
    # 30 standardised errors: their RMS is 1 +- 0.13 for an honest sigma; allow 0.6-1.4.
    assert 0.6 < float(np.sqrt(np.mean(z**2))) < 1.4, z


@pytest.mark.slow
def test_sigma_is_honest_when_the_passes_share_an_attitude_error() -> None:
    # 0.005 deg per pass and NED axis (an INS's drift between passes): the points'
    # noise alone gave standardised errors of RMS 2.4 over these 20 runs, and 4 of them
    # were refused as "not a rotation about the stated axis".
    z = []
    for seed in range(300, 320):
        cfg = RotatingTableConfig(
            latency_s=TAU_S,
            rates_deg_s=(6.0, 18.0),
            passes=5,
            seed=seed,
            pass_attitude_error_deg=0.005,
        )
        result = estimate_latency_sphere(simulate_rotating_table(cfg).passes, radius_m=0.1)
        scatter = result.pass_scatter
        assert scatter is not None
        assert scatter.significant
        # Every pool's covariance gained the scatter of its mean of 5 passes.
        for r in result.per_rate:
            assert np.trace(r.plus.between_pass_cov_m2) > 0.0
        z.append((result.latency_s - TAU_S) / result.latency_std_s)
    # 20 standardised errors: their RMS is 1 +- 0.16 for an honest sigma; allow 0.6-1.4.
    assert 0.6 < float(np.sqrt(np.mean(np.square(z)))) < 1.4, z


def test_one_pass_per_rate_and_direction_cannot_measure_the_pass_scatter() -> None:
    cfg = RotatingTableConfig(latency_s=TAU_S, rates_deg_s=(6.0, 18.0), passes=1, seed=3)
    result = estimate_latency_sphere(simulate_rotating_table(cfg).passes, radius_m=0.1)
    scatter = result.pass_scatter
    assert scatter is not None
    assert not scatter.measured
    assert "not measured" in scatter.text()
    assert result.as_document()["pass_scatter"]["measured"] is False
    for r in result.per_rate:
        assert np.all(r.plus.between_pass_cov_m2 == 0.0)


def _sign_of_rate_flipped(passes: tuple[SpherePass, ...], rate_deg_s: float) -> list[SpherePass]:
    """The passes with the signed rate of one table speed entered the wrong way round."""
    return [
        SpherePass(p.source, -p.rate_deg_s, p.points_ned_m, axis_ned=p.axis_ned)
        if abs(p.rate_deg_s) == rate_deg_s
        else p
        for p in passes
    ]


def test_rates_that_agree_keep_the_formal_sigma() -> None:
    result = estimate_latency_sphere(
        small_simulation(TAU_S, seed=7, rates=(6.0, 18.0)), radius_m=0.1
    )
    assert not result.rates_disagree
    assert result.sigma_scale == 1.0
    assert result.latency_std_s == result.latency_formal_std_s
    assert result.agreement_text().startswith("rates agree: chi2 ")
    doc = result.as_document()
    assert doc["consistency"]["rates_disagree"] is False
    assert doc["latency_std_ms"] == doc["latency_formal_std_ms"]


def test_rates_that_disagree_widen_the_sigma_by_the_birge_ratio_and_say_so() -> None:
    # One speed's clockwise and counter-clockwise labels swapped in passes.csv: that rate
    # sees -tau, the other +tau, far beyond their sigmas.
    passes = _sign_of_rate_flipped(small_simulation(TAU_S, seed=7, rates=(6.0, 18.0)), 6.0)
    result = estimate_latency_sphere(passes, radius_m=0.1)
    assert result.rates_disagree
    assert result.p_value_between_rates < 1e-3
    birge = math.sqrt(result.chi2_between_rates / result.dof_between_rates)
    assert result.sigma_scale == pytest.approx(birge, rel=1e-12)
    assert result.latency_std_s == pytest.approx(birge * result.latency_formal_std_s, rel=1e-12)
    # The formal sigma would claim an error of many sigma; the widened one covers it.
    err = abs(result.latency_s - TAU_S)
    assert err > 3 * result.latency_formal_std_s
    assert err < 3 * result.latency_std_s
    text = result.agreement_text()
    assert text.startswith("rates DISAGREE: chi2 "), text
    assert f"x{birge:.2f}" in text
    assert result.as_document()["consistency"]["rates_disagree"] is True


def test_one_pass_given_twice_is_refused() -> None:
    """A copy of a pass under another name (or a link to it) was counted as a second
    pass: every pass twice gave a sigma sqrt(2) too small, two extra ones moved the
    latency; with times or without them."""
    passes = small_simulation(TAU_S, seed=7, rates=(6.0, 18.0))
    twice = SpherePass(
        "copy_pass.csv", passes[1].rate_deg_s, passes[1].points_ned_m, t_s=passes[1].t_s
    )
    with pytest.raises(InputError, match="recorded at the same time") as err:
        estimate_latency_sphere([*passes, twice], radius_m=0.1)
    assert f"{passes[1].source} and copy_pass.csv" in str(err.value)
    assert "list each pass once" in str(err.value)
    timeless = [SpherePass(p.source, p.rate_deg_s, p.points_ned_m) for p in passes]
    shuffled = timeless[2].points_ned_m[::-1]  # the same points, in another order
    again = SpherePass("again.csv", timeless[2].rate_deg_s, shuffled)
    with pytest.raises(InputError, match=re.escape(f"{timeless[2].source} and again.csv hold")):
        estimate_latency_sphere([*timeless, again], radius_m=0.1)
    # distinct passes, in any order, are fine
    assert estimate_latency_sphere(passes[::-1], radius_m=0.1).n_passes == len(passes)
    # a pass with no point is not "the same" as another (it raised numpy's
    # zero-size-array error there)
    empty = SpherePass("empty.csv", 6.0, np.zeros((0, 3)), t_s=np.zeros(0))
    assert check_distinct_passes([passes[0], empty]) == [passes[0], empty]
    assert check_distinct_passes([empty, passes[0]]) == [empty, passes[0]]


def test_a_rate_confirmed_elsewhere_counts_as_checked() -> None:
    """A raw pass's rate is judged by the attitude log too: one whose points cannot judge
    it (no times here) is counted as checked when ``rate_checked_by`` says so."""
    passes = small_simulation(TAU_S, seed=7, rates=(6.0, 18.0))
    timeless = [SpherePass(p.source, p.rate_deg_s, p.points_ned_m) for p in passes]
    confirmed = [replace(p, rate_checked_by="the attitude log imu.csv") for p in timeless[:3]]
    result = estimate_latency_sphere(confirmed + timeless[3:], radius_m=0.1)
    assert result.n_passes_rate_checked == 3
    assert f"not checked on {len(passes) - 3} of {len(passes)} passes (only 3 of" in (
        result.rates_unchecked_text()
    )
    every = [replace(p, rate_checked_by="the attitude log imu.csv") for p in timeless]
    result = estimate_latency_sphere(every, radius_m=0.1)
    assert result.n_passes_rate_checked == len(passes)
    assert result.agreement_text().startswith("rates agree: chi2 ")


def test_rates_without_point_times_are_said_to_be_unchecked() -> None:
    # Without point times every rate negated gave -tau, rad/s for deg/s 57 times tau,
    # both with "rates agree".
    passes = small_simulation(TAU_S, seed=7, rates=(6.0, 18.0))
    checked = estimate_latency_sphere(passes, radius_m=0.1)
    assert checked.n_passes_rate_checked == checked.n_passes == len(passes)
    assert checked.rates_unchecked_text() == ""
    timeless = [SpherePass(p.source, -p.rate_deg_s, p.points_ned_m) for p in passes]
    flipped = estimate_latency_sphere(timeless, radius_m=0.1)
    assert flipped.latency_s == pytest.approx(-checked.latency_s, abs=3 * checked.latency_std_s)
    assert flipped.n_passes_rate_checked == 0
    text = flipped.agreement_text()
    assert text.startswith("per-rate latencies agree: chi2 "), text
    assert "rates agree" not in text
    assert text.endswith("(rates' sign and unit not checked)")
    assert flipped.rates_unchecked_text().startswith(
        f"the sign and unit of the table rates were not checked on {len(passes)} of "
        f"{len(passes)} passes (none of them with point times"
    )
    assert flipped.as_document()["consistency"]["n_passes_rate_checked"] == 0


def test_points_with_times_that_do_not_sweep_are_not_asked_for_times() -> None:
    # Every pass had t_s, yet the text asked for "the points' times (a t_s column)":
    # points that have times but do not turn about the stated axis point at the axis
    # or the frame (here: times shuffled, as from a scanner that does not sweep).
    rng = np.random.default_rng(5)
    passes = small_simulation(TAU_S, seed=7, rates=(6.0, 18.0))
    shuffled = [replace(p, t_s=rng.permutation(np.asarray(p.t_s))) for p in passes]
    timeless = [SpherePass(p.source, p.rate_deg_s, p.points_ned_m) for p in shuffled[:2]]
    result = estimate_latency_sphere(shuffled, radius_m=0.1)
    assert result.n_passes_rate_checked == 0
    assert result.n_passes_unswept == len(passes)
    text = result.rates_unchecked_text()
    assert "their points have times (t_s) but do not turn about the stated axis" in text
    assert "axis in passes.csv" in text
    assert "table-centred" in text
    assert "give the points' times" not in text
    assert result.as_document()["consistency"]["n_passes_unswept"] == len(passes)
    mixed = estimate_latency_sphere(timeless + shuffled[2:], radius_m=0.1)
    text = mixed.rates_unchecked_text()
    assert f"{len(passes) - 2} of them have point times (t_s) but their points do not" in text
    assert "the other 2 have no point times" in text


def test_one_rate_says_agreement_is_not_tested() -> None:
    result = estimate_latency_sphere(small_simulation(TAU_S, seed=7), radius_m=0.1)
    assert result.dof_between_rates == 0
    assert not result.rates_disagree
    assert result.sigma_scale == 1.0
    assert result.agreement_text() == "one rate: its agreement with other rates is not tested"


def test_axis_pointing_at_the_sphere_is_unobservable() -> None:
    w = math.radians(6.0) * np.array([0.0, 0.0, 1.0])
    c = np.array([0.0, 0.0, 1.5])
    cov = np.eye(3) * 1e-10
    with pytest.raises(ObservabilityError, match="unobservable"):
        latency_from_pool_pair(synthetic_pool(w, c, cov), synthetic_pool(-w, c, cov))


def test_only_one_rotation_sign_is_refused() -> None:
    passes = [p for p in small_simulation(TAU_S, seed=3) if p.rate_deg_s > 0]
    with pytest.raises(InputError, match="both signs"):
        estimate_latency_sphere(passes)


def test_rate_with_one_sign_is_left_out_and_reported() -> None:
    passes = list(small_simulation(TAU_S, seed=3, rates=(10.0, 18.0)))
    passes = [p for p in passes if p.rate_deg_s != -10.0]
    result = estimate_latency_sphere(passes, radius_m=0.1)
    assert result.unpaired_rates_deg_s == (10.0,)
    assert [r.rate_deg_s for r in result.per_rate] == [18.0]
    # Every pass read is used, rejected or listed as unpaired, with the reason.
    assert [(r.source, r.rate_deg_s) for r in result.unpaired_passes] == [
        (p.source, 10.0) for p in passes if p.rate_deg_s == 10.0
    ]
    assert "no pass at -10 deg/s" in result.unpaired_passes[0].reason
    _assert_every_pass_accounted_for(result)


def _assert_every_pass_accounted_for(result: SphereLatencyResult) -> None:
    doc = result.as_document()
    listed = doc["n_passes_used"] + len(doc["rejected_passes"]) + len(doc["unpaired_passes"])
    assert listed == doc["n_passes"] == result.n_passes


def _without_sphere(p: SpherePass, centre: np.ndarray, keep_first: int | None = None) -> SpherePass:
    """``p`` with every return within 0.2 m of the sphere centre removed (or all but 5)."""
    pts = np.asarray(p.points_ned_m)
    near = np.linalg.norm(pts - centre, axis=1) <= 0.2
    keep = ~near if keep_first is None else np.isin(np.arange(len(pts)), np.flatnonzero(near)[:5])
    return SpherePass(f"{p.source}-cut", p.rate_deg_s, pts[keep], axis_ned=p.axis_ned)


@pytest.mark.parametrize("keep_first", [None, 5], ids=["no-sphere", "five-points"])
def test_a_pass_without_a_usable_sphere_is_rejected_and_reported(keep_first: int | None) -> None:
    passes = list(small_simulation(TAU_S, seed=3, rates=(10.0, 18.0)))
    full = estimate_latency_sphere(passes, radius_m=0.1)
    k = next(i for i, p in enumerate(passes) if p.rate_deg_s == -18.0)
    cut = _without_sphere(passes[k], full.sphere_center_ned_m, keep_first)
    result = estimate_latency_sphere([*passes[:k], cut, *passes[k + 1 :]], radius_m=0.1)
    assert [(r.source, r.rate_deg_s, r.n_sphere_points) for r in result.rejected_passes] == [
        (cut.source, -18.0, 0)
    ]
    reason = result.rejected_passes[0].reason
    assert ("only 5 points" if keep_first else "no usable sphere: 0 of its") in reason, reason
    assert result.n_passes == len(passes)
    assert result.n_passes_used == len(passes) - 1
    doc = result.as_document()
    assert doc["n_passes_used"] == len(passes) - 1
    assert doc["rejected_passes"][0]["file"] == cut.source
    assert doc["per_rate"][1]["n_passes"] == 5
    # Left out of the estimate: the same as without the pass at all.
    without = estimate_latency_sphere([*passes[:k], *passes[k + 1 :]], radius_m=0.1)
    assert result.latency_s == pytest.approx(without.latency_s, rel=1e-9)
    assert result.latency_std_s == pytest.approx(without.latency_std_s, rel=1e-9)


def test_a_rate_whose_passes_of_one_sign_hold_no_sphere_is_left_out() -> None:
    passes = list(small_simulation(TAU_S, seed=3, rates=(10.0, 18.0)))
    centre = estimate_latency_sphere(passes, radius_m=0.1).sphere_center_ned_m
    passes = [_without_sphere(p, centre) if p.rate_deg_s == -10.0 else p for p in passes]
    result = estimate_latency_sphere(passes, radius_m=0.1)
    assert [r.rate_deg_s for r in result.per_rate] == [18.0]
    assert result.unpaired_rates_deg_s == (10.0,)
    assert len(result.rejected_passes) == 3
    assert {r.rate_deg_s for r in result.rejected_passes} == {-10.0}
    assert result.n_passes_used == 6
    assert {r.rate_deg_s for r in result.unpaired_passes} == {10.0}
    assert len(result.unpaired_passes) == 3
    assert all(r.n_sphere_points > 0 for r in result.unpaired_passes)
    assert "the passes at -10 deg/s hold no usable sphere" in result.unpaired_passes[0].reason
    _assert_every_pass_accounted_for(result)


def test_a_rate_whose_pass_holds_only_a_corner_of_floor_and_walls_is_left_out() -> None:
    # Was: a chance "sphere" where the planes meet became the +18 deg/s centre and the
    # latency at that rate came out hundreds of ms off. Now the pass is rejected,
    # named, with the reason, and the rate is left out.
    passes = [p for p in small_simulation(TAU_S, seed=3, rates=(10.0, 18.0)) if p.rate_deg_s != 18]
    pts = edge_clutter(np.random.default_rng(120), 1000, 0.002)
    pts = pts[np.argsort(np.arctan2(pts[:, 1], pts[:, 0]))]  # in the order the table sweeps
    corner = SpherePass("corner-without-sphere.csv", 18.0, pts)
    result = estimate_latency_sphere([*passes, corner], radius_m=0.1)
    assert [r.rate_deg_s for r in result.per_rate] == [10.0]
    assert result.unpaired_rates_deg_s == (18.0,)
    [rejected] = result.rejected_passes
    assert (rejected.source, rejected.rate_deg_s) == (corner.source, 18.0)
    assert "no solid sphere" in rejected.reason, rejected.reason
    assert "seen from the table centre" in rejected.reason, rejected.reason
    assert abs(result.latency_s - TAU_S) < max(4 * result.latency_std_s, 2e-4)


def test_no_sphere_among_the_points() -> None:
    rng = np.random.default_rng(0)

    def floor() -> np.ndarray:  # each pass its own returns (one pass twice is refused)
        return np.column_stack(
            [rng.uniform(1.2, 1.8, 3000), rng.uniform(-0.3, 0.3, 3000), np.full(3000, 0.3)]
        )

    passes = [SpherePass("floor+", 6.0, floor()), SpherePass("floor-", -6.0, floor())]
    with pytest.raises(InputError, match="rate"):
        estimate_latency_sphere(passes, radius_m=0.1)


def test_bad_radius() -> None:
    with pytest.raises(InputError, match="radius"):
        estimate_latency_sphere(small_simulation(TAU_S, seed=3), radius_m=-0.1)


@pytest.mark.parametrize("radius", ["0.1", math.nan, True, np.array([0.1])])
def test_a_radius_that_is_not_a_number_is_named(radius: object) -> None:
    """A text radius was a TypeError from inside; NaN failed later, as a per-rate failure."""
    with pytest.raises(InputError, match=r"^radius_m: "):
        estimate_latency_sphere(small_simulation(TAU_S, seed=3), radius_m=radius)  # type: ignore[arg-type]


@pytest.mark.parametrize("origin", [(0.0, 0.0), (0.0, math.nan, 0.0), "origin"])
def test_a_scanner_origin_that_is_not_three_numbers_is_named_up_front(origin: object) -> None:
    """Was buried in each rate's failure, ending with advice about --radius-m."""
    passes = small_simulation(TAU_S, seed=3)
    with pytest.raises(InputError, match=r"^scanner_origin_ned_m: expected 3 finite numbers"):
        estimate_latency_sphere(passes, radius_m=0.1, scanner_origin_ned_m=origin)  # type: ignore[arg-type]
    with pytest.raises(InputError, match=r"^scanner_origin_ned_m: expected 3 finite numbers"):
        fit_pool(passes[:1], radius_m=0.1, scanner_origin_ned_m=origin)  # type: ignore[arg-type]


def _beams_on_sphere(
    rng: np.random.Generator, n: int, centre: np.ndarray, radius: float, max_incidence_deg: float
) -> tuple[np.ndarray, np.ndarray]:
    """Unit beams from the origin that meet the sphere below an incidence, and their ranges."""
    dist = float(np.linalg.norm(centre))
    axis = centre / dist
    e1 = np.cross(axis, [0.0, 0.0, 1.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    beams: list[np.ndarray] = []
    ranges: list[np.ndarray] = []
    while sum(len(b) for b in beams) < n:
        cz = rng.uniform(math.sqrt(1.0 - (radius / dist) ** 2), 1.0, n)
        phi = rng.uniform(0.0, 2.0 * np.pi, n)
        sz = np.sqrt(1.0 - cz * cz)
        u = cz[:, None] * axis + sz[:, None] * (
            np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2
        )
        b = u @ centre
        r = b - np.sqrt(np.maximum(b * b - dist * dist + radius * radius, 0.0))
        normal = (r[:, None] * u - centre) / radius
        ok = np.abs(np.einsum("ij,ij->i", u, normal)) >= math.cos(math.radians(max_incidence_deg))
        beams.append(u[ok])
        ranges.append(r[ok])
    return np.concatenate(beams)[:n], np.concatenate(ranges)[:n]


def test_pool_keeps_the_gaussian_tail_to_four_robust_sigma_and_cuts_beyond() -> None:
    # Range noise along the beams; a few returns placed on purpose near the 4-sigma cut:
    # 3.3 sigma (inside: kept) and 4.7 to 6 sigma (outside: left out). A cut made with
    # the raw median deviation (0.67 sigma) instead of the robust sigma would lose the
    # 3.3-sigma returns and ~0.7 % of the Gaussian ones; the wider first band likewise.
    rng = np.random.default_rng(21)
    centre, radius, sigma = np.array([1.5, 0.1, -0.2]), 0.1, 0.002
    offsets = np.concatenate(
        [
            sigma * rng.standard_normal(40_000),
            np.repeat([3.3, -3.3], 25) * sigma,
            np.repeat([4.7, -4.7, 6.0, -6.0], 12) * sigma,
        ]
    )
    u, r = _beams_on_sphere(rng, len(offsets), centre, radius, 70.0)
    points = (r + offsets)[:, None] * u
    near = np.abs(offsets) == 3.3 * sigma
    far = np.abs(offsets) >= 4.7 * sigma
    pool = fit_pool([SpherePass("cut", 10.0, points)], radius_m=radius)
    used = pool.fit.inliers
    assert used[near].all(), int((~used[near]).sum())
    assert not used[far].any(), int(used[far].sum())
    gaussian = ~near & ~far
    dropped = int((~used[gaussian]).sum())
    # beyond 4 sigma: 6.3e-5 of 40 000 points, about 3
    assert dropped <= 12, dropped
    assert pool.fit.residual_rms_m == pytest.approx(sigma, rel=0.02)


def test_a_scanner_origin_failure_speaks_of_the_table_frame() -> None:
    """The fitter's origin_m advice is a Python name a CLI user cannot set."""
    from kinsync.latency.sphere_failures import pool_failure  # noqa: PLC0415

    err = InputError(
        "fit_sphere: only 3 of 400 points face origin_m and lie on beams that meet the "
        "fitted sphere at less than 80 deg incidence; origin_m does not look like the "
        "scanner that saw these points (check it and its frame)"
    )
    text = pool_failure(err, 0.1)
    assert "origin_m" not in text
    assert "table frame, centred on the table axis" in text
    assert "vessel survey passes are not rotating-table passes" in text


def test_pass_times_and_rate_of_the_wrong_kind_are_named() -> None:
    """A NaN time showed as a '+nan deg/s' rate (and numpy warnings); datetime64 times
    were taken as numbers; a rate given as a 1-element array raised a TypeError."""
    p = small_simulation(TAU_S, seed=3)[0]
    n = p.n_points
    with pytest.raises(InputError, match=r"t_s: time at point index 0 \(0-based\) is not finite"):
        SpherePass(p.source, p.rate_deg_s, p.points_ned_m, t_s=np.full(n, np.nan))
    with pytest.raises(InputError, match=r"t_s: expected seconds, got datetime64\[ms\]"):
        SpherePass(p.source, p.rate_deg_s, p.points_ned_m, t_s=np.arange(n).astype("M8[ms]"))
    with pytest.raises(InputError, match=r"rate_deg_s: expected a number, got array"):
        SpherePass(p.source, np.array([6.0]), p.points_ned_m)  # type: ignore[arg-type]
    # A ragged list of points raised numpy's ValueError; complex or boolean times were
    # taken as numbers (the imaginary part dropped, True as 1 s).
    with pytest.raises(InputError, match=r"^a: points must be numbers, shape \(N, 3\)"):
        SpherePass("a", 10.0, [[1.0, 2.0, 3.0], [1.0, 2.0]])  # type: ignore[arg-type]
    for bad, kind in ((np.full(n, 1.0 + 1.0j), "complex"), (np.ones(n, bool), "boolean")):
        with pytest.raises(InputError, match=rf"t_s: expected numbers, got {kind}"):
            SpherePass(p.source, p.rate_deg_s, p.points_ned_m, t_s=bad)


@pytest.mark.parametrize("seed", ["x", -1, 1.5, True])
def test_a_seed_that_is_no_seed_is_named(seed: object) -> None:
    # seed="x" raised numpy's TypeError from inside the RANSAC.
    passes = small_simulation(TAU_S, seed=3)
    with pytest.raises(InputError, match=r"^seed: expected a whole number >= 0"):
        estimate_latency_sphere(passes, seed=seed)  # type: ignore[arg-type]


@pytest.mark.parametrize("cap", [math.nan, 0.0, 1.4, 90.0])
def test_max_incidence_is_checked_before_any_fit(cap: float) -> None:
    """NaN, 0 or 1.4 (radians?) failed later as 'no sphere found'."""
    passes = small_simulation(TAU_S, seed=3)
    with pytest.raises(InputError, match=r"max_incidence_deg"):
        estimate_latency_sphere(passes, radius_m=0.1, max_incidence_deg=cap)
    with pytest.raises(InputError, match=r"max_incidence_deg"):
        fit_pool(passes[:1], radius_m=0.1, max_incidence_deg=cap)


def test_passes_from_a_generator_are_read_and_the_result_is_read_only() -> None:
    """A generator gave 'rates found: [] deg/s'; the result's centres were writable."""
    passes = small_simulation(TAU_S, seed=3)
    result = estimate_latency_sphere((p for p in passes), radius_m=0.1)
    assert result.latency_s == estimate_latency_sphere(passes, radius_m=0.1).latency_s
    arrays = [result.sphere_center_ned_m]
    for r in result.per_rate:
        arrays += [r.center_ned_m, r.plus.rate_vector_ned_rad_s, r.minus.rate_vector_ned_rad_s]
    for a in arrays:
        assert not a.flags.writeable
    with pytest.raises(
        InputError, match=r"passes: expected a sequence of SpherePass, got SpherePass"
    ):
        estimate_latency_sphere(passes[0], radius_m=0.1)  # type: ignore[arg-type]


def _box_around(centre: np.ndarray, half_m: float) -> tuple[float, ...]:
    return (*(centre - half_m), *(centre + half_m))


def test_a_region_of_interest_leaves_out_the_points_outside_and_counts_them() -> None:
    passes = small_simulation(TAU_S, seed=3)
    plain = estimate_latency_sphere(passes, radius_m=0.1)
    assert plain.roi is None
    assert plain.as_document()["roi"] is None
    box = _box_around(np.asarray(plain.sphere_center_ned_m), 0.13)
    result = estimate_latency_sphere(passes, radius_m=0.1, roi_ned_m=box)
    lo, hi = np.array(box[:3]), np.array(box[3:])
    inside = [np.all((p.points_ned_m >= lo) & (p.points_ned_m <= hi), axis=1) for p in passes]
    assert result.roi is not None
    assert result.roi.box_ned_m == box
    assert result.roi.sources == tuple(p.source for p in passes)
    assert result.roi.n_points == tuple(p.n_points for p in passes)
    assert result.roi.n_excluded == tuple(int((~m).sum()) for m in inside)
    assert 0 < result.roi.n_excluded_total < result.roi.n_points_total
    # Only the points inside reach the fits; the sphere in the box gives the same latency.
    [rate] = result.per_rate
    assert rate.plus.n_points_in + rate.minus.n_points_in == sum(int(m.sum()) for m in inside)
    assert abs(result.latency_s - plain.latency_s) < 0.1 * plain.latency_std_s
    doc = result.as_document()["roi"]
    assert doc["n_points_excluded"] == result.roi.n_excluded_total
    assert doc["box_ned_m"] == {"min": list(box[:3]), "max": list(box[3:])}
    assert [d["file"] for d in doc["passes"]] == [p.source for p in passes]
    assert "outside it, excluded" in result.roi.summary_text()


@pytest.mark.parametrize(
    ("box", "fragment"),
    [
        ((0.0, 0.0, 0.0, 1.0, 1.0), "expected 6 finite numbers"),
        ((0.0, 0.0, 0.0, 1.0, 1.0, math.nan), "expected 6 finite numbers"),
        ((0.0, 2.0, 0.0, 1.0, 1.0, 1.0), "ymin 2 m must be below ymax 1 m"),
        (("a", 0, 0, 1, 1, 1), "expected 6 numbers"),
        ((50.0, 50.0, 50.0, 51.0, 51.0, 51.0), "keeps 0 of its"),
    ],
)
def test_a_bad_region_of_interest_is_refused(box: tuple[object, ...], fragment: str) -> None:
    passes = small_simulation(TAU_S, seed=3)
    with pytest.raises(InputError, match=r"region of interest \(roi_ned_m, --roi-m") as info:
        estimate_latency_sphere(passes, radius_m=0.1, roi_ned_m=box)  # type: ignore[arg-type]
    assert fragment in str(info.value)
    if "keeps" in fragment:  # the passes are named, with what to do
        assert passes[0].source in str(info.value)
        assert "move or widen the box" in str(info.value)
