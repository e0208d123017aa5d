"""Every ``kinsync: warning:`` line a run prints is under ``warnings`` in its ``--json``."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np

RunCli = Callable[[list[str]], tuple[int, str, str]]  # fixture run_cli in conftest.py

PREFIX = "kinsync: warning: "


def _printed(err: str) -> list[str]:
    return [line.removeprefix(PREFIX) for line in err.splitlines() if line.startswith(PREFIX)]


def test_a_command_without_warnings_lists_none(run_cli: RunCli) -> None:
    code, out, err = run_cli(["budget", "serial", "--baud", "115200", "--bytes", "14", "--json"])
    assert code == 0, err
    assert json.loads(out)["warnings"] == []


def test_a_warning_of_an_input_check_is_in_the_json(tmp_path: Path, run_cli: RunCli) -> None:
    """A warning raised while a mount is read (a KinsyncWarning), held until the end."""
    mount = tmp_path / "mount.toml"
    mount.write_text("[mount]\nlever_arm_body_m = [0.5, 0.0, -175.0]\nlatency_s = 0.0\n")
    code, out, err = run_cli(["mount", "check", str(mount), "--json"])
    assert code == 0, err
    (printed,) = _printed(err)
    assert "lever_arm_body_m[2] = -175.0 m is beyond +-100 m" in printed
    assert json.loads(out)["warnings"] == [printed]


def test_warnings_the_result_lists_are_not_repeated(tmp_path: Path, run_cli: RunCli) -> None:
    """trajectory info lists its own warnings and prints them: each once, in order."""
    path = tmp_path / "gappy.csv"
    t = 1.4e9 + np.r_[np.arange(0.0, 10.0, 0.1), np.arange(20.0, 30.0, 0.1)]
    rows = "".join(f"{ti:.1f},46.8,-71.2,10.0,0.01,-0.02,{ti - 1.4e9:.1f}\n" for ti in t)
    path.write_text("t_s,lat_deg,lon_deg,h_m,roll_deg,pitch_deg,yaw_deg\n" + rows)
    code, out, err = run_cli(["trajectory", "info", str(path), "--json"])
    assert code == 0, err
    printed = _printed(err)
    assert any("gap" in w for w in printed), err
    assert json.loads(out)["warnings"] == printed
