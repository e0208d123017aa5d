"""``kinsync simulate drive``: files, JSON summary, table and bad options."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from tests._cli_args import with_options

from kinsync.io.ins_config import read_ins_config
from kinsync.io.tables import read_numeric_csv
from kinsync.sim.drive import DRIVE_FILES, DriveSimConfig, simulate_drive

RunCli = Callable[[list[str]], tuple[int, str, str]]  # fixture run_cli in conftest.py
OneLineError = Callable[..., None]  # fixture assert_one_line_error in conftest.py

BASE = ["simulate", "drive", "--duration-s", "40", "--static-s", "10"]


def test_json_summary_and_files(run_cli: RunCli, tmp_path: Path) -> None:
    out = tmp_path / "drive"
    argv = [*BASE, "--out", str(out), "--seed", "3", "--gnss-outage", "20:25"]
    code, stdout, _ = run_cli([*argv, "--gnss-outage", "30.5:31", "--json"])
    assert code == 0
    doc = json.loads(stdout)
    assert sorted(p.name for p in out.iterdir()) == sorted(DRIVE_FILES)
    assert doc["files"] == list(DRIVE_FILES)
    assert doc["route"] == "oval"
    assert doc["imu"] == "navigation"
    assert doc["imu_rate_hz"] == 50.0
    assert doc["n_imu"] == 40 * 50 + 1
    # 5 Hz over 40 s: 201 epochs, less 26 in [20, 25] and 3 in [30.5, 31].
    assert doc["n_gnss"] == 201 - 26 - 3
    assert doc["gnss_outages"] == [[20.0, 25.0], [30.5, 31.0]]
    assert doc["seed"] == 3
    # The command writes what the library simulates for the same set-up.
    sim = simulate_drive(
        DriveSimConfig(
            duration_s=40.0, static_s=10.0, seed=3, gnss_outages=((20.0, 25.0), (30.5, 31.0))
        )
    )
    assert doc["gyro_bias_rad_s"] == sim.imu_errors.gyro_bias_rad_s.tolist()
    imu = read_numeric_csv(out / "imu.csv", ["t_s", "gyro_z_rad_s"]).columns
    np.testing.assert_array_equal(imu["gyro_z_rad_s"], sim.imu.gyro_body_rad_s[:, 2])
    gnss = read_numeric_csv(out / "gnss.csv", ["t_s", "std_n_m"]).columns
    assert len(gnss["t_s"]) == doc["n_gnss"]
    np.testing.assert_array_equal(gnss["std_n_m"], 0.02)
    truth = json.loads((out / "truth.json").read_text())
    assert truth["seed"] == 3
    assert truth["imu_errors"]["acc_bias_m_s2"] == doc["acc_bias_m_s2"]
    assert read_ins_config(out / "ins.toml").antenna_lever_arm_body_m == (0.3, -0.2, -1.5)


def test_table_output_and_options(run_cli: RunCli, tmp_path: Path) -> None:
    out = tmp_path / "mems"
    argv = [*BASE, "--out", str(out), "--route", "loop", "--imu", "mems"]
    argv += ["--imu-rate-hz", "100", "--gnss-rate-hz", "1", "--lever-arm-m", "0,0,-2"]
    code, stdout, _ = run_cli([*argv, "--roll-amplitude-deg", "2", "--speed-m-s", "3"])
    assert code == 0
    assert "Drive simulation written to" in stdout
    assert "MEMS" in stdout
    assert "IMU samples (imu.csv)" in stdout
    assert "4001" in stdout
    assert read_ins_config(out / "ins.toml").antenna_lever_arm_body_m == (0.0, 0.0, -2.0)
    gnss = read_numeric_csv(out / "gnss.csv", ["t_s"]).columns
    assert len(gnss["t_s"]) == 41
    code, stdout, _ = run_cli([*BASE, "--out", str(tmp_path / "lines"), "--route", "lines"])
    assert code == 0
    assert "lines" in stdout


@pytest.mark.parametrize(
    ("extra", "fragments"),
    [
        (["--route", "circle"], ("--route", "circle")),
        (["--imu", "fog"], ("--imu", "fog")),
        (["--gnss-outage", "20-25"], ("--gnss-outage", "START:END")),
        (["--gnss-outage", "25:20"], ("--gnss-outage", "after START")),
        (["--gnss-outage", "0:1000"], ("epoch",)),
        (["--lever-arm-m", "1,2"], ("--lever-arm-m",)),
        (["--speed-m-s", "0"], ("--speed-m-s",)),
        (["--duration-s", "-3"], ("--duration-s",)),
        (["--imu-rate-hz", "nan"], ("--imu-rate-hz",)),
        (["--laps", "0"], ("--laps",)),
        (["--static-s", "-1"], ("--static-s -1: outside the span",)),
        (["--seed", "-2"], ("seed",)),
        (["--static-s", "45"], ("--duration-s 40 ends within the standstill (--static-s 45)",)),
    ],
)
def test_bad_options(
    run_cli: RunCli,
    assert_one_line_error: OneLineError,
    tmp_path: Path,
    extra: list[str],
    fragments: tuple[str, ...],
) -> None:
    out = tmp_path / "bad"
    code, stdout, stderr = run_cli(with_options([*BASE, "--out", str(out)], extra))
    assert_one_line_error(code, stdout, stderr, *fragments)
    assert not out.exists() or not any(out.iterdir())


def test_out_is_a_file(
    run_cli: RunCli, assert_one_line_error: OneLineError, tmp_path: Path
) -> None:
    target = tmp_path / "file.txt"
    target.write_text("x")
    code, stdout, stderr = run_cli([*BASE, "--out", str(target)])
    assert_one_line_error(code, stdout, stderr, "--out", "not a folder")


def test_out_help_names_every_file_written(run_cli: RunCli) -> None:
    """The help listed imu.csv, gnss.csv, truth.csv and truth.json, not ins.toml."""
    code, out, _ = run_cli(["simulate", "drive", "--help"])
    assert code == 0
    text = " ".join(out.replace("│", " ").split())
    for name in DRIVE_FILES:
        assert name in text, name
