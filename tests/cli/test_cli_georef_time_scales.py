"""kinsync georef: points outside the trajectory's span are never rejected silently.

Rejected points get a warning naming them; a run none of whose points lies within the
span is an error naming both spans and the time-scale mix-up the times show (no output).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import laspy
import numpy as np
import pytest

from kinsync.io.mount_file import write_mount
from kinsync.io.sbet import SECONDS_PER_WEEK, write_sbet
from kinsync.io.trajectory_csv import write_trajectory_csv
from kinsync.mount import Mount
from kinsync.pipelines.georef_times import PointTimes, time_scale_hint
from kinsync.trajectory import Trajectory

RunCli = Callable[[list[str]], tuple[int, str, str]]  # fixture run_cli in conftest.py
OneLineError = Callable[..., None]  # fixture assert_one_line_error in conftest.py

T0 = 1.3e9  # GPS seconds
WEEK = math.floor(T0 / SECONDS_PER_WEEK)
SOW0 = T0 - WEEK * SECONDS_PER_WEEK  # T0 as GPS seconds of week


def _trajectory() -> Trajectory:
    t = T0 + np.arange(0.0, 10.0, 0.01)
    s = t - T0
    llh = np.column_stack([46.8 + 1e-5 * s, -71.2 + 2e-5 * s, 10.0 + 0.1 * s])
    return Trajectory.from_euler(t, 0.0 * s, 0.0 * s, 0.3 + 0.05 * s, lat_lon_h=llh)


@pytest.fixture
def files(tmp_path: Path) -> dict[str, Path]:
    traj = _trajectory()
    write_trajectory_csv(traj, tmp_path / "traj.csv")
    write_sbet(traj, tmp_path / "traj.out")
    write_mount(Mount(lever_arm_body_m=(0.5, 0.1, -1.0)), tmp_path / "mount.toml")
    return {"dir": tmp_path, "csv": tmp_path / "traj.csv", "sbet": tmp_path / "traj.out"}


def _csv(path: Path, times: list[float]) -> Path:
    rows = "".join(f"{t!r},1.0,5.0,-1.5\n" for t in times)
    path.write_text("time,sx,sy,sz\n" + rows, encoding="utf-8")
    return path


def _args(files: dict[str, Path], points: Path, traj: Path, out: Path, *extra: str) -> list[str]:
    columns = ["--columns", "t_s=time,x_m=sx,y_m=sy,z_m=sz"] if points.suffix == ".csv" else []
    return [
        "georef",
        "--points",
        str(points),
        *columns,
        "--trajectory",
        str(traj),
        "--mount",
        str(files["dir"] / "mount.toml"),
        "--out",
        str(out),
        *extra,
    ]


def test_rejected_points_outside_the_span_are_named_on_stderr(
    run_cli: RunCli, files: dict[str, Path]
) -> None:
    points = _csv(files["dir"] / "p.csv", [T0 - 5.0, T0 + 1.0, T0 + 2.0, T0 + 20.0])
    out = files["dir"] / "q.csv"
    code, _, err = run_cli(_args(files, points, files["csv"], out, "--outside", "reject"))
    assert code == 0, err
    warnings = [line for line in err.splitlines() if "outside the trajectory span" in line]
    assert len(warnings) == 1, err
    assert warnings[0].startswith("kinsync: warning: ")
    assert f"2 point(s) with times {T0 - 5.0!r} .. {T0 + 20.0!r} s" in warnings[0]
    assert f"[{T0!r}, {T0 + 9.99!r}] s" in warnings[0]
    assert "q.rejected.csv" in warnings[0]
    assert len(out.read_text(encoding="utf-8").splitlines()) == 3  # header + 2 points


@pytest.mark.parametrize("outside", ["error", "reject"])
def test_points_on_gps_time_with_an_sbet_in_seconds_of_week_need_gps_week(
    run_cli: RunCli, files: dict[str, Path], assert_one_line_error: OneLineError, outside: str
) -> None:
    # The reviewer's case: every point rejected, exit 0, nothing on stderr.
    points = _csv(files["dir"] / "p.csv", [T0 + 1.0, T0 + 1.5])
    out = files["dir"] / "q.csv"
    code, stdout, err = run_cli(_args(files, points, files["sbet"], out, "--outside", outside))
    assert_one_line_error(
        code,
        stdout,
        err,
        "p.csv: no point lies within the trajectory's time span",
        f"the 2 point(s) have times {T0 + 1.0!r} .. {T0 + 1.5!r} s",
        f"the trajectory runs {SOW0!r} .. ",
        "GPS seconds of week",
        "the points carry GPS time (times beyond a week), the trajectory GPS seconds of "
        "week; give --gps-week",
    )
    assert not out.exists()
    assert not (files["dir"] / "q.rejected.csv").exists()


@pytest.mark.parametrize("outside", ["error", "reject"])
def test_table_times_in_seconds_of_week_against_gps_time_are_named(
    run_cli: RunCli, files: dict[str, Path], assert_one_line_error: OneLineError, outside: str
) -> None:
    points = _csv(files["dir"] / "p.csv", [SOW0 + 1.0])
    out = files["dir"] / "q.csv"
    week = ["--gps-week", str(WEEK)]
    code, stdout, err = run_cli(
        _args(files, points, files["sbet"], out, *week, "--outside", outside)
    )
    assert_one_line_error(
        code,
        stdout,
        err,
        "no point lies within the trajectory's time span",
        f"the point times ({SOW0 + 1.0:.10g} s) look like GPS seconds of week; a point table "
        "must carry the trajectory's time scale (GPS time since 1980 here)",
    )
    assert "(--gps-week)" not in err
    assert not out.exists()


def test_some_table_times_in_seconds_of_week_are_named_in_the_warning(
    run_cli: RunCli, files: dict[str, Path]
) -> None:
    points = _csv(files["dir"] / "p.csv", [SOW0 + 1.0, T0 + 1.0])
    out = files["dir"] / "q.csv"
    code, _, err = run_cli(_args(files, points, files["csv"], out, "--outside", "reject"))
    assert code == 0, err
    assert "kinsync: warning: " in err
    assert "look like GPS seconds of week" in err
    code, _, err = run_cli(_args(files, points, files["csv"], out))
    assert code == 2
    assert "check the time scales (the point times" in err
    assert "(--gps-week)" not in err


def test_a_trajectory_csv_in_seconds_of_week_is_named_with_the_week_to_add(
    run_cli: RunCli, files: dict[str, Path], assert_one_line_error: OneLineError
) -> None:
    """`trajectory export` without --gps-week writes such a CSV: the error called its times
    GPS time since 1980 and advised --gps-week, which was then refused as unused."""
    traj = _trajectory()
    sow = files["dir"] / "sow.csv"
    write_trajectory_csv(
        Trajectory(traj.t_s - WEEK * SECONDS_PER_WEEK, traj.q_body_to_ned, traj.lat_lon_h), sow
    )
    points = _csv(files["dir"] / "p.csv", [T0 + 1.0, T0 + 2.0])
    out = files["dir"] / "q.csv"
    code, stdout, err = run_cli(_args(files, points, sow, out))
    assert_one_line_error(
        code,
        stdout,
        err,
        "look like GPS seconds of week, but a trajectory table (CSV) is read as GPS time",
        f"the points lie in GPS week {WEEK}: add {WEEK} x 604800 = "
        f"{WEEK * SECONDS_PER_WEEK:.0f} s to its t_s",
        f"--gps-week {WEEK}",
    )
    code, stdout, err = run_cli(_args(files, points, sow, out, "--gps-week", str(WEEK)))
    assert_one_line_error(
        code,
        stdout,
        err,
        f"the times of {sow} (from {SOW0:.10g} s) look like GPS seconds of week",
        f"add {WEEK} x 604800",
    )
    assert not out.exists()


def test_a_las_file_saying_adjusted_time_but_holding_seconds_of_week(
    run_cli: RunCli, files: dict[str, Path], assert_one_line_error: OneLineError
) -> None:
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales = np.array([1e-4, 1e-4, 1e-4])
    header.offsets = np.zeros(3)
    header.global_encoding.gps_time_type = laspy.header.GpsTimeType.STANDARD
    las = laspy.LasData(header)
    n = 50
    las.x, las.y, las.z = np.zeros(n), np.full(n, 5.0), np.full(n, -1.5)
    las.gps_time = SOW0 + np.linspace(1.0, 2.0, n)  # seconds of week, not GPS time - 1e9
    points = files["dir"] / "scan.las"
    las.write(points)
    out = files["dir"] / "q.las"
    week = ["--gps-week", str(WEEK)]
    code, stdout, err = run_cli(
        _args(files, points, files["sbet"], out, *week, "--outside", "reject")
    )
    assert_one_line_error(
        code,
        stdout,
        err,
        "scan.las: no point lies within the trajectory's time span",
        "look like GPS seconds of week, but its header says adjusted standard GPS time",
        "GpsTimeType.WEEK_TIME",
    )
    assert not out.exists()
    assert not (files["dir"] / "q.rejected.las").exists()


def test_a_wrong_gps_week_is_named() -> None:
    times = PointTimes("gps", gps_week=WEEK + 1)
    start = (WEEK + 1) * SECONDS_PER_WEEK + SOW0
    hint = time_scale_hint(times, T0 + 1.0, T0 + 2.0, start, start + 10.0)
    assert hint is not None
    assert f"the points lie in GPS week {WEEK}, the trajectory in GPS week {WEEK + 1}" in hint
    assert f"--gps-week {WEEK + 1}" in hint
    assert time_scale_hint(times, T0 + 1.0, T0 + 2.0, T0 + 100.0, T0 + 200.0) is None
    # points near the largest float: their sum overflowed, exit 1 (OverflowError)
    assert time_scale_hint(times, 1e308, 1.5e308, start, start + 10.0) is None


@pytest.mark.parametrize("t_s", [-1e308, -5.0])
def test_negative_table_times_are_not_called_seconds_of_week(t_s: float) -> None:
    # -1e308 s was said to "look like GPS seconds of week" (add 604800 s times the week).
    times = PointTimes("gps")
    hint = time_scale_hint(times, t_s, t_s, T0, T0 + 10.0)
    assert hint is None or "seconds of week" not in hint
    hint = time_scale_hint(times, 5.0, 6.0, T0, T0 + 10.0)
    assert hint is not None
    assert "look like GPS seconds of week" in hint


def _sbet_in_gps_time(files: dict[str, Path]) -> Path:
    """The trajectory as an SBET whose time field holds GPS time, not seconds of week."""
    rec = np.fromfile(files["sbet"], "<f8").reshape(-1, 17)
    rec[:, 0] += WEEK * SECONDS_PER_WEEK
    path = files["dir"] / "gps.out"
    rec.tofile(path)
    return path


def test_an_sbet_whose_times_are_gps_time_is_read_as_such(
    run_cli: RunCli, files: dict[str, Path], assert_one_line_error: OneLineError
) -> None:
    """Review G: read as seconds of week, it lay in 2069 or missed every point."""
    sbet = _sbet_in_gps_time(files)
    points = _csv(files["dir"] / "p.csv", [T0 + 1.0, T0 + 1.5])
    out = files["dir"] / "q.csv"
    code, _, err = run_cli(_args(files, points, sbet, out))
    assert code == 0, err
    reference = files["dir"] / "r.csv"
    code, _, err = run_cli(_args(files, points, files["csv"], reference))
    assert code == 0, err
    assert out.read_text(encoding="utf-8") == reference.read_text(encoding="utf-8")
    code, stdout, err = run_cli(
        _args(files, points, sbet, files["dir"] / "w.csv", "--gps-week", str(WEEK))
    )
    assert_one_line_error(
        code, stdout, err, f"--gps-week {WEEK}: the times of {sbet} are already GPS time",
        "drop it",
    )  # fmt: skip
