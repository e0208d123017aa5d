"""Simulators refuse a folder that holds another simulation (one truth.json per folder)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

from kinsync.sim.folder import SIMULATION_SIGNATURES, simulation_in

RunCli = Callable[[list[str]], tuple[int, str, str]]  # fixture run_cli in conftest.py
OneLineError = Callable[..., None]  # fixture assert_one_line_error in conftest.py

PAIRS = [(a, b) for a in SIMULATION_SIGNATURES for b in SIMULATION_SIGNATURES if a != b]


def _fake(folder: Path, simulation: str) -> dict[str, bytes]:
    folder.mkdir()
    (folder / "truth.json").write_text('{"seed": 1}\n')
    (folder / SIMULATION_SIGNATURES[simulation]).write_text("x\n")
    return {p.name: p.read_bytes() for p in folder.iterdir()}


@pytest.mark.parametrize(("held", "new"), PAIRS, ids=[f"{a}-then-{b}" for a, b in PAIRS])
def test_another_simulation_is_refused_before_any_work(
    held: str, new: str, tmp_path: Path, run_cli: RunCli, assert_one_line_error: OneLineError
) -> None:
    folder = tmp_path / "sim"
    before = _fake(folder, held)
    code, out, err = run_cli(["simulate", new, "--out", str(folder)])
    assert_one_line_error(
        code, out, err, f"--out {folder}", f"`kinsync simulate {held}`", "give another folder"
    )
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == before


def test_simulation_in_needs_the_truth_and_the_signature(tmp_path: Path) -> None:
    assert simulation_in(tmp_path / "absent") is None
    (tmp_path / "imu.csv").write_text("x\n")
    assert simulation_in(tmp_path) is None  # an IMU log of the user's, no truth.json
    (tmp_path / "truth.json").write_text("{}\n")
    assert simulation_in(tmp_path) == "drive"


def test_the_same_simulator_may_write_again_and_a_real_clash_is_refused(
    tmp_path: Path, run_cli: RunCli, assert_one_line_error: OneLineError
) -> None:
    folder = tmp_path / "clk"
    argv = ["simulate", "clock", "--duration-s", "30", "--out", str(folder), "--json"]
    assert run_cli([*argv, "--seed", "1"])[0] == 0
    assert simulation_in(folder) == "clock"
    truth = (folder / "truth.json").read_text()
    assert run_cli([*argv, "--seed", "2"])[0] == 0
    assert (folder / "truth.json").read_text() != truth
    code, out, err = run_cli(["simulate", "rotating-table", "--passes", "1", "--out", str(folder)])
    assert_one_line_error(code, out, err, "`kinsync simulate clock`")
    assert not (folder / "passes.csv").exists()


def test_a_folder_with_other_files_is_refused_before_any_work(
    tmp_path: Path, run_cli: RunCli, assert_one_line_error: OneLineError
) -> None:
    folder = tmp_path / "mine"
    folder.mkdir()
    (folder / "notes.txt").write_text("keep me\n")
    code, out, err = run_cli(["simulate", "clock", "--duration-s", "30", "--out", str(folder)])
    assert_one_line_error(code, out, err, f"--out {folder}", "other files (notes.txt)")
    assert [p.name for p in folder.iterdir()] == ["notes.txt"]
    # an earlier simulation with a file of the user's added is not replaced either
    sim = tmp_path / "clk"
    assert run_cli(["simulate", "clock", "--duration-s", "30", "--out", str(sim)])[0] == 0
    (sim / "figure.png").write_bytes(b"png")
    code, out, err = run_cli(["simulate", "clock", "--duration-s", "30", "--out", str(sim)])
    assert_one_line_error(code, out, err, "figure.png")
    assert (sim / "figure.png").read_bytes() == b"png"
