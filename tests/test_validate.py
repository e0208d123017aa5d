"""The shared argument checks: times and coordinates a float dtype cannot hold."""

from __future__ import annotations

import numpy as np
import pytest

from kinsync._validate import (
    DEGREE_STEP_DEG,
    ECEF_HEIGHT_RANGE_M,
    angle_array,
    check_float_step,
    check_values,
    coordinate_array,
    degree_array,
    ecef_array,
    geodetic_array,
    time_array,
)
from kinsync.errors import InputError
from kinsync.io.sanity import TIME_S


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
    # the deepest ocean floor at the pole and a summit on the equator are ground points
    ecef_array([[0.0, 0.0, -(6_356_752.3 - 11_000.0)], [6_378_137.0 + 8_800.0, 0.0, 0.0]], "p")
    lat = np.radians(45.0)  # 11.5 km below and 9.5 km above at 45 degrees
    n_m = 6_378_137.0 / np.sqrt(1.0 - 6.69437999014e-3 * np.sin(lat) ** 2)
    for h in (-11_500.0, 9_500.0):
        ecef_array(
            [[(n_m + h) * np.cos(lat), 0.0, (n_m * (1 - 6.69437999014e-3) + h) * np.sin(lat)]],
            "p",
        )
    low, high = ECEF_HEIGHT_RANGE_M
    for r in (6_378_137.0 + low - 1.0, 6_378_137.0 + high + 1.0, 5.0):
        with pytest.raises(InputError, match=r"p: point at index 1 .*not ECEF coordinates"):
            ecef_array([[6_378_137.0, 0.0, 0.0], [r, 0.0, 0.0]], "p")
    # UTM coordinates (zone 19, 57 degrees north) read as ECEF: within the Earth's radii
    # (6.30e6 to 6.45e6 m from its centre) but 34 km below the ellipsoid on the equator
    with pytest.raises(InputError, match=r"34\.\d+ km below the WGS84 ellipsoid.*not ECEF"):
        ecef_array([[332_118.5, 6_335_319.4, 11.2]], "p")
    ecef_array([[np.nan, 0.0, 0.0]], "p")  # non-finite rows are the caller's to name


def test_degrees_are_held_to_0p1_mm_on_the_ground() -> None:
    """Latitudes and longitudes need steps of 9e-10 deg (0.1 mm); float32 holds 3.8e-6 deg
    (0.4 m) near 47 deg."""
    assert DEGREE_STEP_DEG * 6_378_137.0 * np.pi / 180.0 == pytest.approx(1e-4)
    with pytest.raises(InputError, match=r"lat_deg: float32 degrees near 46\.8 deg .*float64"):
        degree_array(np.array([46.8], dtype=np.float32), "lat_deg")
    assert degree_array(np.array([1e-3], dtype=np.float32), "lat_deg").dtype == np.float64
    with pytest.raises(InputError, match=r"lat_deg: expected numbers \(deg\)"):
        degree_array(np.array(["46.8"]), "lat_deg")
    llh = np.array([[46.8, -71.2, 10.0]], dtype=np.float32)
    with pytest.raises(InputError, match=r"p \(latitude, longitude\): float32 .*71\.2 deg"):
        geodetic_array(llh, "p")
    assert geodetic_array(llh.astype(np.float64), "p").dtype == np.float64
    with pytest.raises(InputError, match=r"yaw: float16 angles near 2 rad"):
        angle_array(np.array([2.0], dtype=np.float16), "yaw")
    with pytest.raises(InputError, match=r"f\.parquet: column 'lat_deg': float32 .*double"):
        check_float_step(llh[:, 0], "f.parquet: column 'lat_deg'", "degree")


def test_a_time_in_ns_us_or_ms_is_named_with_its_divisor() -> None:
    """Each said only 'outside -1e10..1e10 s, check the unit'."""
    for value, unit, divisor in (
        (1.715964782e18, "nanoseconds", "1e9"),
        (1.715964782e15, "microseconds", "1e6"),
        (1.4e12, "milliseconds", "1000"),
    ):
        with pytest.raises(InputError) as err:
            check_values(np.array([1.4e9, value]), TIME_S, lambda i: f"t.csv: row {i}")
        msg = str(err.value)
        assert msg.startswith(f"t.csv: row 1: {value!r} is outside")
        assert f"are these {unit} (Unix or GPS time)? divide them by {divisor}" in msg
    with pytest.raises(InputError, match="check the unit and the column order"):
        check_values(np.array([1e11]), TIME_S, lambda i: f"row {i}")
