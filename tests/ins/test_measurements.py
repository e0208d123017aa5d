"""The measurement containers own their arrays."""

from __future__ import annotations

import numpy as np

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
