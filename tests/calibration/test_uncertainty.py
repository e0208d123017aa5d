"""The honest sigma: the delete-one jackknife over lines, against a Monte Carlo with
navigation errors that every return of a line shares."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest
from scipy.stats import t as student_t

from kinsync.calibration.adjustment import adjust
from kinsync.calibration.parameters import mount_values
from kinsync.calibration.uncertainty import Jackknife, jackknife

from .conftest import NOMINAL, TRUE, Synthetic
from .test_adjustment import _problem

# Everything but the lever z, which free planes cannot see (test_adjustment).
ESTIMATED = (0, 1, 2, 3, 4, 6)


def test_jackknife_covariance_is_the_spread_of_the_deleted_line_solutions(
    synthetic: Callable[..., Synthetic],
) -> None:
    syn = synthetic(seed=7, repeats=1, n_per_plane=60, nav_errors=True)
    models, obs, feats, frame, v0 = _problem(syn, NOMINAL)
    sol = adjust(models, obs, feats, v0, ESTIMATED, frame)
    groups = [(line.name, {i}) for i, line in enumerate(syn.lines)]
    jk = jackknife(models, obs, sol, frame, groups)
    m = len(groups)
    # Each row is the solution without that line: it differs from the full one.
    assert jk.estimates.shape == (m, len(ESTIMATED))
    assert np.all(np.any(jk.estimates != sol.values[list(ESTIMATED)], axis=1))
    dev = jk.estimates - jk.estimates.mean(axis=0)
    assert np.allclose(jk.covariance, (m - 1) / m * dev.T @ dev)
    assert jk.dof == m - 1
    assert jk.t95 == pytest.approx(float(student_t.ppf(0.975, m - 1)))
    # The deleted-line solutions run in threads: one at a time gives the same numbers.
    serial = jackknife(models, obs, sol, frame, groups, workers=1)
    assert np.array_equal(serial.estimates, jk.estimates)
    assert np.array_equal(
        jackknife(models, obs, sol, frame, groups, workers=3).estimates, jk.estimates
    )


def test_too_few_lines_gives_no_jackknife(synthetic: Callable[..., Synthetic]) -> None:
    syn = synthetic(seed=7, repeats=1, n_per_plane=60)
    models, obs, feats, frame, v0 = _problem(syn, NOMINAL)
    sol = adjust(models, obs, feats, v0, ESTIMATED, frame)
    groups = [(f"lines {j}", {i for i in range(len(syn.lines)) if i % 3 == j}) for j in range(3)]
    assert not jackknife(models, obs, sol, frame, groups).valid


def _one_run(synthetic: Callable[..., Synthetic], seed: int) -> tuple[np.ndarray, ...]:
    syn = synthetic(seed=seed, repeats=2, n_per_plane=60, nav_errors=True)
    models, obs, feats, frame, v0 = _problem(syn, NOMINAL)
    sol = adjust(models, obs, feats, v0, ESTIMATED, frame)
    groups = [(line.name, {i}) for i, line in enumerate(syn.lines)]
    jk = jackknife(models, obs, sol, frame, groups)
    assert jk.valid
    assert jk.dof == 7
    err = (sol.values - mount_values(TRUE))[list(ESTIMATED)]
    return err, jk.std, np.sqrt(np.diag(sol.covariance))


@pytest.mark.slow
def test_monte_carlo_spread_over_sigma_is_near_one(synthetic: Callable[..., Synthetic]) -> None:
    """8 lines with 2-3 cm / 0.005-0.015 deg navigation errors correlated over 10 s.

    30 runs: the ratio's own sampling error is about 1 / sqrt(60) = 0.13, so [0.7, 1.4]
    is a 2.5-sigma band; the formal sigma, which takes the returns as independent, is
    up to several times too small and must fail it.
    """
    runs = [_one_run(synthetic, seed) for seed in range(100, 130)]
    err = np.array([r[0] for r in runs])
    sd = err.std(axis=0, ddof=1)
    ratio = sd / np.sqrt(np.mean(np.array([r[1] for r in runs]) ** 2, axis=0))
    formal = sd / np.sqrt(np.mean(np.array([r[2] for r in runs]) ** 2, axis=0))
    assert np.all((ratio > 0.7) & (ratio < 1.4)), ratio.round(2)
    # The formal sigma fails the band: several times too small for the lever arm and
    # the latency, whose information comes from line-to-line differences.
    assert np.max(formal) > 3.0, formal.round(2)
    assert np.count_nonzero(formal > 1.4) >= 3, formal.round(2)


def test_a_jackknife_that_did_not_move_gives_no_sigma() -> None:
    # Deleted-line solutions that all return the full solution's value (a solution
    # stuck where it started: on four CIDCO passes every return had left its
    # trajectory) have a spread of exactly zero: that is no sigma, and the jackknife is
    # not valid (the formal sigma and the reason are reported instead).
    values = np.tile([3.14, -0.5, 0.02, -0.9], (4, 1))
    dev = values - values.mean(axis=0)
    jk = Jackknife(
        groups=("a", "b", "c", "d"),
        estimates=values,
        covariance=3.0 / 4.0 * (dev.T @ dev),
        failed=(),
    )
    assert not jk.valid
    moved = values + np.array([[1e-4], [-1e-4], [2e-4], [0.0]])
    dev = moved - moved.mean(axis=0)
    assert Jackknife(("a", "b", "c", "d"), moved, 3.0 / 4.0 * (dev.T @ dev), ()).valid
