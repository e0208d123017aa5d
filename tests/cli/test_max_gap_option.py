"""``--max-gap-s`` on every command that reads a trajectory: one option, one help, one span.

A trajectory whose long record intervals are legitimate (an SBET exported at a variable
rate, an NMEA track with 1-5 s steps, a pause) had its times refused or left out by every
command but ``georef``, and the messages pointed at an option those commands did not
have. Each command's own gap test (test_cli_latency, test_validate, test_ins, test_sync,
test_cli_calibrate, test_cli_georef_gaps) shows the default refusing or leaving out and a
larger ``--max-gap-s`` accepting; here: which commands take it, with what help, and that
a value that is no threshold is one line and exit 2.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from kinsync.cli._guard import numeric_parameters
from kinsync.cli._options import MAX_GAP_HELP

from ._commands import commands
from .test_option_bounds import _base_argv

RunCli = Callable[[list[str]], tuple[int, str, str]]  # fixture run_cli in conftest.py
OneLineError = Callable[..., None]  # fixture assert_one_line_error in conftest.py

READS_A_TRAJECTORY = {
    ("georef",),
    ("latency", "sphere"),  # --raw: the attitude log
    ("validate", "control-points"),
    ("ins", "run"),  # --init-from
    ("ins", "compare"),  # the reference
    ("sync", "object-space"),
    ("calibrate", "mount"),
    ("trajectory", "info"),
}
"""The commands that interpolate a trajectory file (or list its gaps). ``trajectory
export`` writes the records as they are, ``sync apply`` reads none."""


def _with_max_gap() -> dict[tuple[str, ...], Callable[..., Any]]:
    return {
        path: callback
        for path, callback in commands()
        if "--max-gap-s" in numeric_parameters(callback).values()
    }


def test_every_command_that_reads_a_trajectory_takes_max_gap_s() -> None:
    assert set(_with_max_gap()) == READS_A_TRAJECTORY
    for path, callback in commands():
        if "trajectory" in inspect.signature(callback).parameters:
            assert path in READS_A_TRAJECTORY, path


@pytest.mark.parametrize("path", sorted(READS_A_TRAJECTORY), ids=" ".join)
def test_one_help_for_every_command(path: tuple[str, ...], run_cli: RunCli) -> None:
    code, out, _ = run_cli([*path, "--help"])
    assert code == 0
    flat = " ".join(out.replace("│", " ").split())
    assert " ".join(MAX_GAP_HELP.split()) in flat, flat


@pytest.mark.parametrize("value", ["0", "-1", "nan"])
@pytest.mark.parametrize("path", sorted(READS_A_TRAJECTORY), ids=" ".join)
def test_a_threshold_that_is_no_positive_number_is_one_line_and_exit_2(
    path: tuple[str, ...],
    value: str,
    run_cli: RunCli,
    assert_one_line_error: OneLineError,
    tmp_path: Path,
) -> None:
    argv = _base_argv(path, _with_max_gap()[path], tmp_path)
    code, out, err = run_cli([*argv, "--max-gap-s", value])
    assert_one_line_error(code, out, err, f"--max-gap-s {value}")
