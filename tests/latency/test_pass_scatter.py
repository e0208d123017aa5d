"""Errors shared by a pass: the passes' own centres against their pools (Method A)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from kinsync.errors import InputError
from kinsync.latency.pass_scatter import (
    CHECK_UPPER_P,
    PassCentres,
    PassScatter,
    estimate_pass_scatter,
    pool_scatter_cov_m2,
)

# A shared error mostly along East (a heading error at a sphere due North), some Down.
B_TRUE = np.diag([0.0, 0.08e-3, 0.03e-3]) ** 2


def _pools(
    rng: np.random.Generator, between: np.ndarray, n_pools: int = 6, n_passes: int = 5
) -> list[PassCentres]:
    """Pools whose passes' centres carry their own noise (a different level per pool)
    plus a shared ``between`` covariance."""
    pools = []
    for k in range(n_pools):
        noise_std = (0.02e-3, 0.04e-3, 0.07e-3)[k % 3]  # slow rates: many points
        covs = np.repeat((noise_std**2 * np.eye(3))[None], n_passes, axis=0)
        truth = np.array([1.5, 0.0, 0.0]) + 1e-3 * k
        shared = rng.multivariate_normal(np.zeros(3), between, size=n_passes)
        noise = rng.normal(0.0, noise_std, size=(n_passes, 3))
        pools.append(PassCentres(truth + shared + noise, covs))
    return pools


def test_an_injected_between_pass_covariance_is_recovered_and_flagged() -> None:
    rng = np.random.default_rng(3)
    fits = [estimate_pass_scatter(_pools(rng, B_TRUE)) for _ in range(60)]
    mean_cov = np.mean([f.cov_m2 for f in fits], axis=0)
    # The East variance within 15 % of the truth on average (REML is nearly unbiased).
    assert mean_cov[1, 1] == pytest.approx(B_TRUE[1, 1], rel=0.15)
    assert mean_cov[2, 2] == pytest.approx(B_TRUE[2, 2], rel=0.3)
    assert abs(mean_cov[0, 0]) < 0.1 * B_TRUE[1, 1]
    assert all(f.significant for f in fits)
    assert fits[0].dof == 3 * 6 * 4
    assert fits[0].n_passes == 30
    assert fits[0].n_pools == 6
    assert np.abs(fits[0].direction_ned[1]) > 0.9
    assert "beyond their points' noise" in fits[0].text()
    assert "the sigma includes it" in fits[0].text()


def test_no_shared_error_passes_the_test_at_its_level() -> None:
    rng = np.random.default_rng(5)
    fits = [estimate_pass_scatter(_pools(rng, np.zeros((3, 3)))) for _ in range(100)]
    # Q is chi-square on its dof: mean Q / dof 1 +- 0.017 over 100 draws; about 1 %
    # of them below p = 0.01.
    assert np.mean([f.chi2 / f.dof for f in fits]) == pytest.approx(1.0, abs=0.08)
    assert np.mean([f.significant for f in fits]) < 0.05
    assert "agree with their points' noise" in next(f for f in fits if not f.significant).text()
    # What it adds is small against the best pool's own noise (0.02 mm per pass).
    assert np.median([f.std_m for f in fits]) < 0.02e-3


def test_one_pass_per_pool_is_not_measured_and_says_so() -> None:
    rng = np.random.default_rng(1)
    fit = estimate_pass_scatter(_pools(rng, B_TRUE, n_passes=1))
    assert not fit.measured
    assert not fit.significant
    assert fit.dof == 0
    assert fit.n_pools == 0
    assert fit.n_passes == 6
    assert math.isnan(fit.p_value)
    assert np.all(fit.cov_m2 == 0.0)
    assert np.all(fit.upper_cov_m2() == 0.0)
    assert "not measured" in fit.text()
    assert fit.as_document()["measured"] is False
    assert fit.as_document()["chi2"] is None


def test_failed_pass_fits_are_left_out() -> None:
    rng = np.random.default_rng(2)
    pools = _pools(rng, B_TRUE)
    centres = np.array(pools[0].centers_ned_m)
    centres[1] = np.nan
    pools[0] = PassCentres(centres, pools[0].covs_m2)
    fit = estimate_pass_scatter(pools)
    assert fit.n_passes == 29
    assert fit.dof == 3 * (6 * 4 - 1)


def test_a_pool_gains_the_between_pass_covariance_of_its_weighted_mean() -> None:
    covs = np.repeat((1e-10 * np.eye(3))[None], 4, axis=0)
    pool = PassCentres(np.zeros((4, 3)), covs)
    scatter = PassScatter(B_TRUE, 10.0, 9, 4, 1)
    np.testing.assert_allclose(pool_scatter_cov_m2(pool, scatter), B_TRUE / 4, rtol=1e-12)
    # Unequal weights: the mean leans on the quiet pass, which carries B whole.
    covs[0] *= 1e-4
    leaning = PassCentres(np.zeros((4, 3)), covs)
    np.testing.assert_allclose(pool_scatter_cov_m2(leaning, scatter), B_TRUE, rtol=1e-3)


def test_the_model_test_takes_the_scatter_at_its_upper_bound() -> None:
    scatter = PassScatter(B_TRUE, 50.0, 12, 6, 2)
    factor = 4 / stats.chi2.ppf(CHECK_UPPER_P, 4)
    np.testing.assert_allclose(scatter.upper_cov_m2(), B_TRUE * factor)
    assert factor > 10  # 4 pass-dof per direction measure a variance poorly


def test_centres_and_covariances_of_the_wrong_shape_are_refused() -> None:
    with pytest.raises(InputError, match=r"expected \(N, 3\) and \(N, 3, 3\)"):
        PassCentres(np.zeros((3, 3)), np.zeros((2, 3, 3)))
    frozen = PassCentres(np.zeros((2, 3)), np.ones((2, 3, 3)))
    assert not frozen.centers_ned_m.flags.writeable


def _rated_pools(
    rng: np.random.Generator, stds_m: tuple[float, ...], n_passes: int = 5
) -> tuple[list[PassCentres], list[float]]:
    """Two pools (both signs) per rate, each rate's passes sharing an isotropic error of its
    own size (an error that grows with the rate)."""
    pools, rates = [], []
    for rate, std in zip((2.0, 6.0, 18.0), stds_m, strict=True):
        for sign in (1.0, -1.0):
            noise_std = 0.02e-3 * math.sqrt(rate / 2.0)  # fewer points at faster rates
            covs = np.repeat((noise_std**2 * np.eye(3))[None], n_passes, axis=0)
            centres = np.array([1.5, 0.0, 0.0]) + rng.normal(0.0, std, (n_passes, 3))
            pools.append(PassCentres(centres + rng.normal(0.0, noise_std, (n_passes, 3)), covs))
            rates.append(sign * rate)
    return pools, rates


def test_a_rate_whose_passes_scatter_more_carries_its_own_covariance() -> None:
    # 0.03, 0.09, 0.27 mm at 2, 6, 18 deg/s: the common covariance (about the middle)
    # would leave the fast rate's sigma too small (Monte Carlo: RMS error / sigma 1.49).
    rng = np.random.default_rng(8)
    owned = []
    for _ in range(20):
        pools, rates = _rated_pools(rng, (0.03e-3, 0.09e-3, 0.27e-3))
        fit = estimate_pass_scatter(pools, rates)
        assert [r.rate_deg_s for r in fit.rates] == [2.0, 6.0, 18.0]
        fast = fit.for_rate(-18.0)
        owned.append(fast is not fit)
        if fast is not fit:
            assert fast.std_m > fit.std_m
            assert "at 18 deg/s they scatter more than that" in fit.text()
            assert fit.as_document()["rates"][2]["own_std_mm"] == pytest.approx(fast.std_m * 1e3)
    assert np.mean(owned) > 0.8


def test_rates_that_share_one_scatter_keep_the_common_covariance() -> None:
    rng = np.random.default_rng(9)
    owned = 0
    for _ in range(40):
        pools, rates = _rated_pools(rng, (0.08e-3, 0.08e-3, 0.08e-3))
        fit = estimate_pass_scatter(pools, rates)
        owned += sum(r.own is not None for r in fit.rates)
        assert fit.for_rate(2.0) is fit or fit.rates[0].own is not None
    assert owned <= 4  # 120 rate tests at p < 0.01


def test_a_scatter_thousands_of_times_a_passes_own_sigma_is_measured() -> None:
    # A quiet scanner on a drifting INS: the estimate stopped at 148 of a pass's sigmas.
    rng = np.random.default_rng(4)
    between = np.diag([0.0, 20e-3, 5e-3]) ** 2  # 20 mm against 0.02-0.07 mm per pass
    fits = [estimate_pass_scatter(_pools(rng, between)) for _ in range(20)]
    assert np.mean([f.cov_m2[1, 1] for f in fits]) == pytest.approx(between[1, 1], rel=0.25)
