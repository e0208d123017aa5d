"""The shared argument checks: times and coordinates a float dtype cannot hold."""

from __future__ import annotations

import numpy as np
import pytest

from kinsync._validate import ECEF_RADIUS_RANGE_M, coordinate_array, ecef_array, time_array
from kinsync.errors import InputError


def test_float32_times_are_taken_only_while_their_step_is_within_1_us() -> None:
    below = time_array(np.array([0.5, 15.9], dtype=np.float32), "t_s")
    assert below.dtype == np.float64
    with pytest.raises(InputError, match=r"t_s: float32 times near 16 s .* steps of 1\.91e-06 s"):
        time_array(np.array([16.0], dtype=np.float32), "t_s")
    with pytest.raises(InputError, match=r"t_s: float16 times near 1 s .* 0\.000977 s"):
        time_array(np.array([1.0], dtype=np.float16), "t_s")
    assert time_array(np.arange(3), "t_s").dtype == np.float64  # whole seconds are exact
    assert time_array([np.nan, 1.4e9], "t_s")[1] == 1.4e9  # finiteness is the caller's


def test_local_clock_times_get_their_own_advice() -> None:
    with pytest.raises(InputError, match=r"t_local_s: .*logger's clock") as info:
        time_array(np.arange(2).astype("m8[s]"), "t_local_s", clock="local")
    assert "1980" not in str(info.value)


def test_coordinates_within_0p1_mm_and_ecef_near_the_earth() -> None:
    coordinate_array(np.array([[1000.0, 0.0, 0.0]], dtype=np.float32), "xyz")  # 61 um steps
    with pytest.raises(InputError, match=r"float32 coordinates near 4096 m .* 0\.000488 m"):
        coordinate_array(np.array([[4096.0, 0.0, 0.0]], dtype=np.float32), "xyz")
    low, high = ECEF_RADIUS_RANGE_M
    ecef_array([[6_356_752.0 - 11_000.0, 0.0, 0.0], [0.0, 0.0, 6_378_137.0 + 9_000.0]], "p")
    for r in (low - 1.0, high + 1.0, 5.0):
        with pytest.raises(InputError, match=r"p: point at index 1 .*not ECEF coordinates"):
            ecef_array([[6_378_137.0, 0.0, 0.0], [0.0, r, 0.0]], "p")
    ecef_array([[np.nan, 0.0, 0.0]], "p")  # non-finite rows are the caller's to name
