"""The compiled per-line plane fit against the plain numpy loop it replaced."""

from __future__ import annotations

import numpy as np
import pytest

from kinsync._typing import BoolArray, FloatArray, IntArray
from kinsync.calibration.line_detrend import detrend_lines, detrend_lines_numpy

_SETTINGS = {"min_fit": 12, "iterations": 3, "tukey_c": 4.685, "min_scale_m": 2e-4}


def _plane_lines(seed: int, sizes: list[int]) -> tuple[FloatArray, BoolArray, FloatArray, IntArray]:
    """Lines crossing a plane: each its own offset and tilt, noise, outliers, lost returns."""
    rng = np.random.default_rng(seed)
    n = sum(sizes)
    group = np.repeat(np.arange(len(sizes)), sizes)
    uv = rng.uniform(-5.0, 5.0, (n, 2))
    jac = np.column_stack([uv, -np.ones(n)])
    line_params = rng.normal(0.0, [0.002, 0.002, 0.03], (len(sizes), 3))
    e = np.einsum("ni,ni->n", jac, line_params[group]) + rng.normal(0.0, 0.005, n)
    outliers = rng.random(n) < 0.08
    e[outliers] += rng.uniform(0.1, 1.5, np.count_nonzero(outliers))
    ok = rng.random(n) > 0.05
    e[~ok] = 0.0
    return e, ok, jac, group


@pytest.mark.parametrize("seed", range(6))
def test_matches_the_numpy_loop(seed: int) -> None:
    # Long lines, short ones (median only), one below the fit's minimum, a single return.
    sizes = [400, 3, 11, 12, 13, 60, 1, 2500, 25]
    e, ok, jac, group = _plane_lines(seed, sizes)
    got = detrend_lines(e, ok, jac, group, **_SETTINGS)  # type: ignore[arg-type]
    want = detrend_lines_numpy(e, ok, jac, group, **_SETTINGS)  # type: ignore[arg-type]
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    assert not np.shares_memory(got, e)


def test_line_with_no_good_return_is_left_alone() -> None:
    e, ok, jac, group = _plane_lines(7, [30, 30])
    ok[:30] = False
    e[:30] = 0.25
    got = detrend_lines(e, ok, jac, group, **_SETTINGS)  # type: ignore[arg-type]
    np.testing.assert_array_equal(got[:30], 0.25)
    want = detrend_lines_numpy(e, ok, jac, group, **_SETTINGS)  # type: ignore[arg-type]
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)


def test_fit_removes_a_line_offset_and_tilt_but_keeps_an_outlier() -> None:
    rng = np.random.default_rng(3)
    n = 200
    uv = rng.uniform(-4.0, 4.0, (n, 2))
    jac = np.column_stack([uv, -np.ones(n)])
    e = 0.05 + 0.01 * uv[:, 0] - 0.004 * uv[:, 1] + rng.normal(0.0, 0.002, n)
    e[17] += 0.5  # a bush
    got = detrend_lines(e, np.ones(n, bool), jac, np.zeros(n, np.int64), **_SETTINGS)  # type: ignore[arg-type]
    rest = np.delete(got, 17)
    assert np.std(rest) < 0.0025
    assert abs(np.mean(rest)) < 5e-4
    assert got[17] == pytest.approx(0.5, abs=0.01)


def test_empty_input() -> None:
    empty = np.zeros(0)
    got = detrend_lines(
        empty,
        np.zeros(0, bool),
        np.zeros((0, 3)),
        np.zeros(0, np.int64),
        **_SETTINGS,  # type: ignore[arg-type]
    )
    assert got.shape == (0,)
