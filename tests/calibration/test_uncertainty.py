"""The honest sigma: the jackknife over lines with its leverage correction, against a
Monte Carlo with navigation errors that every return of a line shares."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from kinsync.calibration.adjustment import adjust
from kinsync.calibration.parameters import mount_values
from kinsync.calibration.uncertainty import _leverage_corrected, jackknife

from .conftest import NOMINAL, TRUE, Synthetic
from .test_adjustment import _problem

# Everything but the lever z, which free planes cannot see (test_adjustment).
ESTIMATED = (0, 1, 2, 3, 4, 6)


def test_leverage_correction_is_the_plain_jackknife_for_exchangeable_lines() -> None:
    rng = np.random.default_rng(1)
    m, k = 8, 3
    a = rng.standard_normal((k, k))
    S = a @ a.T + k * np.eye(k)
    dev = rng.standard_normal((m, k))
    dev -= dev.mean(axis=0)
    normals = np.repeat(((m - 1) / m * S)[None], m, axis=0)
    plain = (m - 1) / m * dev.T @ dev
    assert np.allclose(_leverage_corrected(dev, normals, S), plain)


def test_leverage_correction_shrinks_a_line_that_carries_a_parameter() -> None:
    # Without line 0 only a tenth of the information on parameter 0 is left: its
    # deviation is (I - L)^-1 u and is scaled back by sqrt(0.1).
    S = np.diag([10.0, 10.0])
    dev = np.zeros((4, 2))
    dev[0] = [1.0, 0.0]
    normals = np.repeat(S[None] * 0.75, 4, axis=0)
    normals[0] = np.diag([1.0, 7.5])
    cov = _leverage_corrected(dev, normals, S)
    assert cov[0, 0] == pytest.approx(0.1)
    assert cov[1, 1] == pytest.approx(0.0)


def _one_run(synthetic: Callable[..., Synthetic], seed: int) -> tuple[np.ndarray, ...]:
    syn = synthetic(seed=seed, repeats=2, n_per_plane=60, nav_errors=True)
    models, obs, feats, frame, v0 = _problem(syn, NOMINAL)
    sol = adjust(models, obs, feats, v0, ESTIMATED, frame)
    groups = [(line.name, {i}) for i, line in enumerate(syn.lines)]
    jk = jackknife(models, obs, sol, frame, groups)
    assert jk.valid
    assert jk.dof == 7
    err = (sol.values - mount_values(TRUE))[list(ESTIMATED)]
    return err, jk.std, np.sqrt(np.diag(jk.covariance_plain)), np.sqrt(np.diag(sol.covariance))


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
    formal = sd / np.sqrt(np.mean(np.array([r[3] for r in runs]) ** 2, axis=0))
    assert np.all((ratio > 0.7) & (ratio < 1.4)), ratio.round(2)
    # The formal sigma fails the band: several times too small for the lever arm and
    # the latency, whose information comes from line-to-line differences.
    assert np.max(formal) > 3.0, formal.round(2)
    assert np.count_nonzero(formal > 1.4) >= 3, formal.round(2)
