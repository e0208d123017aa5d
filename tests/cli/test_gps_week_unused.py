"""``--gps-week`` given where no input carries GPS seconds of week is refused, not ignored.

A CSV trajectory or point table carries GPS time; the week was accepted and silently
unused (left out at stop 28). Every command with the option is covered; the inputs are
named CSV files (the refusal reads no content, only what kind of file each is).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

RunCli = Callable[[list[str]], tuple[int, str, str]]  # fixture run_cli in conftest.py
OneLineError = Callable[..., None]  # fixture assert_one_line_error in conftest.py

MESSAGE = "no input carries GPS seconds of week"


def _files(tmp_path: Path) -> dict[str, str]:
    names = ("traj.csv", "points.csv", "control.csv", "scan.csv", "sync.csv", "solution.csv")
    out = {}
    for name in names:
        (tmp_path / name).write_text("t_s\n1\n")
        out[name.split(".")[0]] = str(tmp_path / name)
    (tmp_path / "mount.toml").write_text("[mount]\n")
    out["mount"] = str(tmp_path / "mount.toml")
    out["out"] = str(tmp_path / "out")
    return out


COMMANDS: dict[str, Callable[[dict[str, str]], list[str]]] = {
    "georef": lambda f: ["georef", "--points", f["points"], "--trajectory", f["traj"],
                         "--mount", f["mount"], "--out", f["out"] + ".csv"],
    "calibrate mount": lambda f: ["calibrate", "mount", "--points", f["points"],
                                  "--trajectory", f["traj"], "--mount", f["mount"]],
    "validate control-points": lambda f: ["validate", "control-points", "--cloud", f["points"],
                                          "--control", f["control"], "--trajectory", f["traj"]],
    "sync object-space": lambda f: ["sync", "object-space", "--scan", f["scan"],
                                    "--trajectory", f["traj"], "--mount", f["mount"],
                                    "--sync-points", f["sync"]],
    "trajectory info": lambda f: ["trajectory", "info", f["traj"]],
    "trajectory export": lambda f: ["trajectory", "export", f["traj"], "--out", f["out"] + ".csv"],
    "ins compare": lambda f: ["ins", "compare", f["solution"], f["traj"]],
}  # fmt: skip


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_gps_week_with_only_gps_time_inputs_is_refused(
    run_cli: RunCli, assert_one_line_error: OneLineError, tmp_path: Path, command: str
) -> None:
    argv = [*COMMANDS[command](_files(tmp_path)), "--gps-week", "2345"]
    code, out, err = run_cli(argv)
    assert_one_line_error(code, out, err, "--gps-week 2345", MESSAGE, "drop it")
    assert not list(tmp_path.glob("out*"))


def test_gps_week_with_an_sbet_is_not_refused(run_cli: RunCli, tmp_path: Path) -> None:
    files = _files(tmp_path)
    sbet = tmp_path / "traj.sbet"
    sbet.write_bytes(b"\0" * 136 * 3)  # three zero records: read, then judged by the reader
    _, _, err = run_cli(["trajectory", "info", str(sbet), "--gps-week", "2345"])
    assert MESSAGE not in err
    _, _, err = run_cli(["ins", "compare", files["solution"], str(sbet), "--gps-week", "2345"])
    assert MESSAGE not in err


def test_a_missing_input_is_named_before_the_unused_week(run_cli: RunCli, tmp_path: Path) -> None:
    code, _, err = run_cli(
        ["trajectory", "info", str(tmp_path / "missing.csv"), "--gps-week", "2345"]
    )
    assert code == 2
    assert MESSAGE not in err
    assert "missing.csv" in err
