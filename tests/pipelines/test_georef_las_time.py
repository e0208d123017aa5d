"""A LAS file whose times cannot be the seconds of week its header says, or cross the
GPS week rollover."""

from __future__ import annotations

from pathlib import Path

import laspy
import numpy as np
import pytest
from tests._las import las_points
from tests.pipelines.test_georef_gaps import MOUNT, T0, _columns, gap_traj

from kinsync.errors import InputError
from kinsync.io.cloud import iter_cloud
from kinsync.io.trajectory_csv import write_trajectory_csv
from kinsync.pipelines.calibration import _read_las
from kinsync.pipelines.georef import georeference_file
from kinsync.trajectory import Trajectory

__all__ = ["gap_traj"]  # the fixture


def test_adjusted_time_with_the_encoding_bit_unset_is_named_as_such(
    tmp_path: Path, gap_traj: Path
) -> None:
    cols = _columns()
    las = las_points(cols)  # adjusted standard GPS time, ~3e8 s
    las.header.global_encoding.gps_time_type = laspy.header.GpsTimeType.WEEK_TIME
    src = tmp_path / "unset.laz"
    las.write(src)
    assert float(np.max(laspy.read(src).gps_time)) == pytest.approx(T0 + 9.9 - 1e9, abs=0.2)
    with pytest.raises(InputError) as err:
        georeference_file(src, gap_traj, MOUNT, tmp_path / "o.laz", gps_week=2000)
    msg = str(err.value)
    assert "cannot be GPS seconds of week (a week has 604800 s)" in msg
    assert "adjusted standard GPS time" in msg
    assert "bit unset" in msg
    assert "GpsTimeType.STANDARD" in msg
    assert not (tmp_path / "o.laz").exists()


WEEK = 2345
ROLLOVER_S = (WEEK + 1) * 604_800.0  # GPS time of the start of week 2346


def _rollover_files(folder: Path, order: str) -> tuple[Path, Path]:
    """Points 20 s either side of a week rollover, GPS seconds of week; a GPS-time trajectory.

    ``order``: "time" (the first point late in week 2345, the last early in 2346) or
    "mixed" (first and last both late in the week: the rollover not seen at the ends).
    """
    s = np.arange(-30.0, 30.5, 0.5)
    llh = np.column_stack([46.8 + s * 1e-4, np.full_like(s, -71.2), np.full_like(s, 10.0)])
    zeros = np.zeros_like(s)
    traj = Trajectory.from_euler(ROLLOVER_S + s, zeros, zeros, zeros, lat_lon_h=llh)
    traj_path = folder / "traj.csv"
    write_trajectory_csv(traj, traj_path)
    t = np.linspace(ROLLOVER_S - 20.0, ROLLOVER_S + 20.0, 100)
    if order == "mixed":
        t = np.r_[t[:10], t[50:], t[10:50]]
    n = len(t)
    las = las_points(
        {"t_s": t, "x_m": np.zeros(n), "y_m": np.full(n, 5.0), "z_m": np.full(n, -2.0)},
        point_format=1,
        version="1.2",
    )
    las.header.global_encoding.gps_time_type = laspy.header.GpsTimeType.WEEK_TIME
    las.gps_time = t - np.floor(t / 604_800.0) * 604_800.0
    src = folder / "roll.las"
    las.write(src)
    return src, traj_path


@pytest.mark.parametrize("order", ["time", "mixed"])
def test_a_file_crossing_the_week_rollover_is_refused_naming_it(tmp_path: Path, order: str) -> None:
    """604780 .. 604799.9, then 0 .. 20 s of week: one --gps-week cannot place both."""
    src, traj_path = _rollover_files(tmp_path, order)
    out = tmp_path / "o.laz"
    with pytest.raises(InputError) as err:
        georeference_file(src, traj_path, MOUNT, out, gps_week=WEEK, chunk_points=30)
    msg = str(err.value)
    assert "crosses the GPS week rollover" in msg
    assert "split" in msg.lower()
    assert "adjusted standard GPS time" in msg
    # splitting needs a trajectory on GPS time: the one --gps-week sets an SBET's week
    # too, so the part after the rollover put the SBET a week late (the advice went round)
    assert "with an SBET store adjusted standard time instead" in msg
    assert f"check --gps-week {WEEK}" not in msg
    if order == "time":  # seen up front, at the file's first and last points
        assert msg.startswith(f"{src}: the points hold GPS seconds of week near the end")
        assert f"--gps-week {WEEK} for the part before, --gps-week {WEEK + 1}" in msg
    assert not out.exists()


def test_calibration_and_the_control_point_check_refuse_a_rollover_alike(
    tmp_path: Path,
) -> None:
    src, _ = _rollover_files(tmp_path, "mixed")
    with pytest.raises(InputError, match="crosses the GPS week rollover"):
        _read_las(src, "gps", WEEK)
    with pytest.raises(InputError, match="crosses the GPS week rollover"):
        list(iter_cloud(src, 30, need_time=True, traj_scale="gps", gps_week=WEEK))


def test_gps_time_with_the_encoding_bit_unset_is_told_to_subtract_1e9(
    tmp_path: Path, gap_traj: Path
) -> None:
    """Setting the bit alone made the times read 1e9 s late (2.3e9 s); the advice works."""
    cols = _columns()
    las = las_points(cols)
    las.header.global_encoding.gps_time_type = laspy.header.GpsTimeType.WEEK_TIME
    las.gps_time = cols["t_s"]  # GPS time itself (1.3e9 s), the bit unset
    src = tmp_path / "gps.las"
    las.write(src)
    with pytest.raises(InputError) as err:
        georeference_file(src, gap_traj, MOUNT, tmp_path / "o.csv")
    msg = str(err.value)
    assert "most likely GPS time written with the bit unset" in msg
    assert "subtract 1e+09 s from gps_time and set the bit" in msg
    assert "las.gps_time = las.gps_time - 1e+09" in msg
    fixed = laspy.read(src)  # what the message says, done
    fixed.gps_time = fixed.gps_time - 1e9
    fixed.header.global_encoding.gps_time_type = laspy.header.GpsTimeType.STANDARD
    fixed.write(tmp_path / "fixed.las")
    georeference_file(tmp_path / "fixed.las", gap_traj, MOUNT, tmp_path / "o.csv", outside="reject")
    assert (tmp_path / "o.csv").exists()
