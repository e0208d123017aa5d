"""The measurement containers: times and coordinates checked as the API promises, arrays
owned by the container."""

from __future__ import annotations

import numpy as np
import pytest

from kinsync.errors import InputError
from kinsync.ins.measurements import GnssData, ImuData

N = 100
T0 = 3000.0


def _imu_arrays() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    t = T0 + 0.005 * np.arange(N)
    return t, np.zeros((N, 3)), np.tile([0.0, 0.0, -9.81], (N, 1))


def _gnss(lat_deg: np.ndarray, h_m: np.ndarray | None = None) -> GnssData:
    n = lat_deg.size
    return GnssData(
        t_s=T0 + np.arange(float(n)),
        lat_deg=lat_deg,
        lon_deg=np.full(n, -71.2),
        h_m=np.full(n, 10.0) if h_m is None else h_m,
        std_pos_ned_m=np.full((n, 3), 0.02),
    )


def test_imu_datetime64_times_are_refused() -> None:
    """datetime64[ns] was read as nanoseconds taken for seconds (intervals of 5e6 's')."""
    ts = np.datetime64("2020-01-01T00:00:00", "ns") + np.arange(N) * np.timedelta64(5, "ms")
    _, gyro, acc = _imu_arrays()
    with pytest.raises(InputError, match=r"IMU t_s: expected seconds, got datetime64\[ns\]"):
        ImuData(ts, gyro, acc)  # type: ignore[arg-type]


def test_float32_times_are_refused() -> None:
    """float32 holds 3000 s in steps of 2.4e-4 s: the IMU times were 1.2e-4 s off."""
    t, gyro, acc = _imu_arrays()
    with pytest.raises(InputError, match=r"IMU t_s: float32 times near 3000\.5 s .*float64"):
        ImuData(t.astype(np.float32), gyro, acc)
    with pytest.raises(InputError, match=r"GNSS t_s: float32 times"):
        GnssData(
            (T0 + np.arange(5.0)).astype(np.float32),
            np.full(5, 46.8),
            np.full(5, -71.2),
            np.full(5, 10.0),
            np.full((5, 3), 0.02),
        )
    assert ImuData(t, gyro, acc).t_s[1] == t[1]  # float64 passes


def test_float32_gnss_positions_are_refused() -> None:
    """float32 latitudes are 0.2 m off near 47 deg; float32 ECEF was already refused."""
    lat = np.full(5, 46.8)
    with pytest.raises(InputError, match=r"GNSS lat_deg: float32 degrees near 46\.8 .*float64"):
        _gnss(lat.astype(np.float32))
    with pytest.raises(InputError, match=r"GNSS h_m: float16 coordinates near 10 m"):
        _gnss(lat, np.full(5, 10.0, dtype=np.float16))
    assert _gnss(lat).lat_deg.dtype == np.float64


def test_containers_copy_the_callers_arrays() -> None:
    """The caller's arrays were made read-only, and a view's base still changed the
    frozen container."""
    t, _, acc = _imu_arrays()
    base = np.zeros((N + 1, 3))
    imu = ImuData(t, base[1:], acc)
    assert t.flags.writeable
    assert acc.flags.writeable
    t[0] = 0.0
    base[5, 0] = 1.0
    assert imu.t_s[0] == T0
    assert imu.gyro_body_rad_s[4, 0] == 0.0
    assert not imu.t_s.flags.writeable
    lat = np.full(5, 46.8)
    gnss = _gnss(lat)
    assert lat.flags.writeable
    lat[0] = 0.0
    assert gnss.lat_deg[0] == 46.8
    for arr in (gnss.t_s, gnss.lat_deg, gnss.std_pos_ned_m):
        assert not arr.flags.writeable


@pytest.mark.parametrize("lon_deg", [400.0, -200.0])
def test_gnss_longitude_outside_every_convention_names_row(lon_deg: float) -> None:
    """A longitude of 400 deg was accepted (latitudes beyond 90 deg were refused)."""
    lon = np.full(5, -71.2)
    lon[2] = lon_deg
    with pytest.raises(
        InputError,
        match=rf"^GNSS lon_deg: longitude {lon_deg} outside \[-180, 360\] in row 2: give "
        "longitudes in degrees",
    ):
        GnssData(
            T0 + np.arange(5.0), np.full(5, 46.8), lon, np.full(5, 10.0), np.full((5, 3), 0.02)
        )
    lon[2] = 288.8  # 0 to 360 deg: accepted, as before
    gnss = GnssData(
        T0 + np.arange(5.0), np.full(5, 46.8), lon, np.full(5, 10.0), np.full((5, 3), 0.02)
    )
    assert gnss.lon_deg[2] == 288.8
