"""A trajectory CSV whose degree columns hold radians is refused, not read 57x too small.

Found by a review: `validate control-points` on such a file drove the southbound passes
backwards and halved the time error's sigma, with exit 0.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from kinsync.errors import InputError
from kinsync.io.trajectory_csv import read_trajectory_csv

HEADER = "t_s,lat_deg,lon_deg,h_m,roll_deg,pitch_deg,yaw_deg\n"


def _lines(tmp_path: Path, *, crab_deg: float = 0.0, radians: bool = False) -> Path:
    """Two 60 s lines on bearing 60 then 240 deg at 5 m/s, 10 Hz; yaw = course + crab."""
    t = np.arange(0.0, 120.0, 0.1)
    along = np.where(t < 60.0, 5.0 * t, 5.0 * (120.0 - t))
    bearing = math.radians(60.0)
    lat = 46.8 + np.degrees(along * math.cos(bearing) / 6.37e6)
    lon = -71.2 + np.degrees(along * math.sin(bearing) / (6.37e6 * math.cos(math.radians(46.8))))
    yaw = np.where(t < 60.0, 60.0, 240.0) + crab_deg
    yaw = (yaw + 180.0) % 360.0 - 180.0
    roll = 1.5 * np.sin(t / 3.0)
    pitch = -2.0 + 0.5 * np.cos(t / 4.0)
    att = np.column_stack([roll, pitch, yaw])
    if radians:
        att = np.radians(att)
    rows = [
        f"{1.4e9 + ti:.3f},{la:.10f},{lo:.10f},10.0,{a[0]:.8f},{a[1]:.8f},{a[2]:.8f}"
        for ti, la, lo, a in zip(t, lat, lon, att, strict=True)
    ]
    path = tmp_path / "traj.csv"
    path.write_text(HEADER + "\n".join(rows) + "\n")
    return path


def test_radians_under_degree_columns_are_refused(tmp_path: Path) -> None:
    path = _lines(tmp_path, radians=True)
    with pytest.raises(InputError) as info:
        read_trajectory_csv(path)
    message = str(info.value)
    assert message.startswith(f"{path}: roll_deg, pitch_deg and yaw_deg look like radians")
    assert "convert the attitude columns to degrees" in message


@pytest.mark.parametrize("crab_deg", [0.0, 15.0, -25.0])
def test_degrees_are_read_even_when_the_vessel_crabs(tmp_path: Path, crab_deg: float) -> None:
    traj = read_trajectory_csv(_lines(tmp_path, crab_deg=crab_deg))
    medians = traj.heading_against_course()
    assert medians is not None
    assert medians[0] == pytest.approx(abs(crab_deg), abs=0.5)  # spherical Earth here


def test_small_angles_without_motion_are_read(tmp_path: Path) -> None:
    """A rotating table or a moored vessel: no course to judge by, nothing refused."""
    t = np.arange(0.0, 60.0, 0.1)
    rows = [f"{ti:.3f},46.8,-71.2,10.0,0.01,-0.02,{math.sin(ti):.6f}" for ti in t]
    path = tmp_path / "still.csv"
    path.write_text(HEADER + "\n".join(rows) + "\n")
    traj = read_trajectory_csv(path)
    assert traj.heading_against_course() is None
