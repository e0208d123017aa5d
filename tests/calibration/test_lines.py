"""`ScanLine` checks its times and scanner coordinates as the other containers do."""

from __future__ import annotations

import numpy as np
import pytest

from kinsync.calibration.lines import ScanLine
from kinsync.errors import InputError
from kinsync.trajectory import Trajectory

T0 = 1.4e9


def _trajectory() -> Trajectory:
    t = T0 + np.arange(0.0, 10.0, 0.01)
    z = np.zeros(t.size)
    llh = np.column_stack([np.full(t.size, 46.8), np.full(t.size, -71.2), np.full(t.size, 10.0)])
    return Trajectory.from_euler(t, z, z, z, lat_lon_h=llh)


def test_float32_or_datetime64_times_are_refused_naming_the_line() -> None:
    """float32 holds 1.4e9 s in steps of 128 s: 1000 returns over 5 s became one time,
    and the calibration then said they lay outside the trajectory."""
    traj = _trajectory()
    t = T0 + 1.0 + np.linspace(0.0, 5.0, 1000)
    xyz = np.ones((t.size, 3))
    with pytest.raises(InputError, match=r"line 'a': t_s: float32 times near 1\.4e\+09 s .*128 s"):
        ScanLine("a", t.astype(np.float32), xyz, traj)
    posix = np.datetime64("2024-05-17T16:54:00", "ns") + np.arange(3) * np.timedelta64(1, "ms")
    with pytest.raises(InputError, match=r"line 'a': t_s: expected seconds, got datetime64"):
        ScanLine("a", posix, xyz[:3], traj)  # type: ignore[arg-type]
    with pytest.raises(InputError, match=r"line 'a': xyz_scanner_m: float16 coordinates"):
        ScanLine("a", t, xyz.astype(np.float16) * 20, traj)  # type: ignore[arg-type]
    line = ScanLine("a", t, xyz.astype(np.float32), traj)  # float32 holds 1 m to 0.1 um
    assert np.unique(line.t_s).size == t.size


def test_subset_refuses_an_index_that_does_not_fit_the_line() -> None:
    """A mask of another length or an index beyond the returns was a bare IndexError."""
    t = T0 + 1.0 + np.linspace(0.0, 5.0, 10)
    line = ScanLine("a", t, np.ones((t.size, 3)), _trajectory())
    with pytest.raises(InputError, match=r"line 'a': a mask of shape \(2,\) for 10 returns"):
        line.subset(np.ones(2, bool))
    for bad in (np.array([0, 10]), np.array([0.0, 1.0]), np.array([[0, 1]])):
        with pytest.raises(InputError, match=r"line 'a': index must be a boolean mask of 10"):
            line.subset(bad)
    np.testing.assert_array_equal(line.subset([9, 0]).t_s, t[[9, 0]])
    np.testing.assert_array_equal(line.subset(np.arange(10) % 2 == 0).t_s, t[::2])
