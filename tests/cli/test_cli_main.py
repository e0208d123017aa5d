"""The program's entry point: version, exit codes, one-line errors, mount/trajectory checks."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from kinsync import __version__
from kinsync.io.provenance import software
from kinsync.io.trajectory_csv import read_trajectory_csv, write_trajectory_csv
from kinsync.trajectory import Trajectory

RunCli = Callable[[list[str]], tuple[int, str, str]]  # fixture run_cli in conftest.py
OneLineError = Callable[..., None]  # fixture assert_one_line_error in conftest.py


def test_version(run_cli: RunCli) -> None:
    code, out, _ = run_cli(["--version"])
    assert code == 0
    assert out.strip() == software()  # the version, and a checkout's commit
    assert out.startswith(f"kinsync {__version__}")


def test_module_entry_point_runs_in_a_subprocess() -> None:
    proc = subprocess.run(
        [sys.executable, "-m", "kinsync", "budget", "serial", "--baud", "-1", "--bytes", "4"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 2
    assert proc.stderr.strip() == (
        "kinsync: error: --baud -1: outside the span kinsync accepts, 50 to 2e+07 bit/s"
    )
    assert proc.stdout == ""


def test_usage_errors_exit_2_in_one_line(
    run_cli: RunCli, assert_one_line_error: OneLineError
) -> None:
    code, _out, err = run_cli(["budget", "latency", "--range-m", "abc"])
    assert_one_line_error(code, _out, err, "--range-m")
    code, _out, err = run_cli(["budget", "latency", "--no-such-option"])
    assert_one_line_error(code, _out, err, "--no-such-option")
    code, _out, err = run_cli(["budget", "serial", "--bytes", "3"])
    assert_one_line_error(code, _out, err, "--baud")


def test_mount_check(tmp_path: Path, run_cli: RunCli) -> None:
    good = tmp_path / "mount.toml"
    good.write_text(
        "[mount]\nlever_arm_body_m = [0.1, 0.2, 0.3]\nboresight_rpy_deg = [0.0, 0.0, 90.0]\n"
        "antenna_lever_arm_body_m = [0.0, 0.0, -1.0]\nlatency_s = 0.0021\n"
    )
    code, out, _ = run_cli(["mount", "check", str(good), "--json"])
    assert code == 0
    doc = json.loads(out)
    assert doc["latency_s"] == 0.0021
    np.testing.assert_allclose(
        doc["R_scanner_to_body"], [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-15
    )
    code, out, _ = run_cli(["mount", "check", str(good)])
    assert code == 0
    assert "lever_arm_body_m" in out
    assert doc["uncertainty"] is None
    assert doc["profiler_azimuth_deg"] is None


def test_mount_check_shows_uncertainty_and_profiler(tmp_path: Path, run_cli: RunCli) -> None:
    path = tmp_path / "mount.toml"
    path.write_text(
        "[mount]\nlatency_s = 0.0021\n\n[profiler]\nazimuth_deg = 12.5\n\n"
        "[uncertainty]\nlever_arm_body_m = [0.01, 0.02, 0.03]\nlatency_s = 4e-05\n"
    )
    code, out, _ = run_cli(["mount", "check", str(path), "--json"])
    assert code == 0
    doc = json.loads(out)
    assert doc["profiler_azimuth_deg"] == 12.5
    assert doc["uncertainty"] == {
        "lever_arm_body_m": [0.01, 0.02, 0.03],
        "boresight_rpy_deg": None,
        "latency_s": 4e-05,
        "correlation": None,
    }
    code, out, _ = run_cli(["mount", "check", str(path)])
    assert code == 0
    assert "sigma lever_arm_body_m" in out
    assert "0.01, 0.02, 0.03" in out
    assert "sigma latency_s" in out
    assert "sigma boresight_rpy_deg" not in out
    assert "profiler_azimuth_deg" in out


def test_mount_check_warns_of_a_latency_in_milliseconds(tmp_path: Path, run_cli: RunCli) -> None:
    path = tmp_path / "mount.toml"
    path.write_text("[mount]\nlever_arm_body_m = [0.1, 0.2, 0.3]\nlatency_s = 5\n")
    code, out, err = run_cli(["mount", "check", str(path), "--json"])
    assert code == 0, err
    assert json.loads(out)["latency_s"] == 5.0
    expected = (
        f"kinsync: warning: {path}: [mount] latency_s = 5.0 s is beyond +-1 s, longer than "
        "any sensor or serial delay: latency_s is in seconds (5.0 ms would be 0.005)"
    )
    assert err.splitlines() == [expected]


def test_mount_check_malformed_toml(
    tmp_path: Path, run_cli: RunCli, assert_one_line_error: OneLineError
) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text("[mount]\nlever_arm_body_m = [0.1, 0.2\n")
    code, _out, err = run_cli(["mount", "check", str(bad)])
    assert_one_line_error(code, _out, err, str(bad), "malformed TOML")
    code, _out, err = run_cli(["mount", "check", str(tmp_path / "missing.toml")])
    assert_one_line_error(code, _out, err, "missing.toml", "not found")


HEADER = "t_s,lat_deg,lon_deg,h_m,roll_deg,pitch_deg,yaw_deg\n"


@pytest.mark.parametrize(
    ("body", "fragments"),
    [
        (
            "0,46,-71,10,0,0,0\n1,46,-71,10,0,0,1\n1,46,-71,10,0,0,2\n",
            ("repeated", "row 2", "line 4"),
        ),
        ("0,46,-71,10,0,0,0\n2,46,-71,10,0,0,1\n1,46,-71,10,0,0,2\n", ("decreasing", "row 2")),
        (
            "0,46,-71,10,0,0,0\n1,nan,-71,10,0,0,1\n2,46,-71,10,0,0,2\n",
            ("not a finite number", "line 3", "lat_deg"),
        ),
        ("0,46,-71,10,0,0,0\n1,46,-71,10,0,zz,1\n", ("line 3", "pitch_deg", "'zz'")),
        ("0,46,-71,10,0,0,0\n1,46,-71,10,0,0\n", ("line 3", "fields")),
        ("0,46,-71,10,0,0,0\n", ("at least 2",)),
    ],
)
def test_trajectory_info_bad_files(
    tmp_path: Path,
    run_cli: RunCli,
    body: str,
    fragments: tuple[str, ...],
    assert_one_line_error: OneLineError,
) -> None:
    path = tmp_path / "traj.csv"
    path.write_text(HEADER + body)
    code, _out, err = run_cli(["trajectory", "info", str(path)])
    assert_one_line_error(code, _out, err, str(path), *fragments)


def test_trajectory_missing_column(
    tmp_path: Path, run_cli: RunCli, assert_one_line_error: OneLineError
) -> None:
    path = tmp_path / "traj.csv"
    path.write_text("t_s,lat_deg,lon_deg,h_m,roll_deg,pitch_deg\n0,1,2,3,4,5\n")
    code, _out, err = run_cli(["trajectory", "info", str(path)])
    assert_one_line_error(code, _out, err, "yaw_deg", "missing column")


def test_trajectory_csv_round_trip_and_info(tmp_path: Path, run_cli: RunCli) -> None:
    t = np.arange(0.0, 10.0, 0.01) + 1.4e9
    yaw = np.radians(5.0) * (t - t[0])
    traj = Trajectory.from_euler(
        t,
        0.01 * np.sin(t),
        0.02 * np.cos(t),
        yaw,
        lat_lon_h=np.column_stack([46.8 + 1e-6 * (t - t[0]), np.full_like(t, -71.2), 10 + 0 * t]),
        vel_ned_m_s=np.column_stack([np.full_like(t, 0.11), 0 * t, 0 * t]),
    )
    path = tmp_path / "traj.csv"
    write_trajectory_csv(traj, path)
    back = read_trajectory_csv(path)
    np.testing.assert_array_equal(back.t_s, traj.t_s)
    assert back.lat_lon_h is not None
    assert traj.lat_lon_h is not None
    np.testing.assert_allclose(back.lat_lon_h, traj.lat_lon_h, rtol=0, atol=1e-12)
    np.testing.assert_allclose(back.euler_rpy_rad(), traj.euler_rpy_rad(), atol=1e-12)
    code, out, _ = run_cli(["trajectory", "info", str(path), "--json"])
    assert code == 0
    doc = json.loads(out)
    assert doc["records"] == len(t)
    assert doc["median_rate_hz"] == pytest.approx(100.0)
    assert doc["has_velocity"] is True
    assert doc["max_angular_rate_deg_s"] >= 5.0


@pytest.mark.parametrize("option", ["--pps", "--nmea"])
def test_a_file_name_that_is_not_utf8_is_one_line(
    tmp_path: Path, run_cli: RunCli, assert_one_line_error: OneLineError, option: str
) -> None:
    # It was an internal error (exit 1) where pyarrow met the name, and worked elsewhere.
    name = os.fsdecode(tmp_path / os.fsdecode(b"ok\xff.csv"))
    other = str(tmp_path / "other.csv")
    argv = ["clock", "fit", "--pps", other, "--nmea", other]
    argv[argv.index(option) + 1] = name
    code, out, err = run_cli(argv)
    assert_one_line_error(code, out, err, "ok\\xff.csv: not UTF-8 text (byte 0xFF)", "rename")
