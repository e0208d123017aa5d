"""stdout and stderr as a script finds them: another encoding, a closed pipe, closed stdout.

The commands run in a subprocess, as a script runs them: the encoding and the pipe are
the process's own.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from kinsync.cli._streams import PIPE_CLOSED_STATUS, output_pipe_closed, plain_symbols

PLAN = ["latency", "plan", "--rates-deg-s", "2,6", "--passes", "2", "--target-ms", "0.1"]
"""A quick command whose table says σ."""


def _env(**extra: str) -> dict[str, str]:
    src = str(Path(__file__).resolve().parents[2] / "src")
    return {**os.environ, "PYTHONPATH": src, **extra}


def _kinsync(*args: str, **kwargs: object) -> subprocess.CompletedProcess[bytes]:
    return subprocess.run(  # type: ignore[call-overload, no-any-return]
        [sys.executable, "-m", "kinsync", *args], check=False, **kwargs
    )


def test_symbols_are_spelled_plain_where_the_encoding_lacks_them() -> None:
    assert plain_symbols("χ² 3σ ± 5 µs −1 … ✓", "ascii") == "chi2 3sigma +- 5 us -1 ... ?"
    assert plain_symbols("χ² 3σ ± 5 µs", "latin-1") == "chi² 3sigma ± 5 µs"
    assert plain_symbols("χ² 3σ", "utf-8") == "χ² 3σ"


@pytest.mark.parametrize("encoding", ["latin-1", "cp1252", "ascii"])
def test_a_terminal_in_another_encoding_gets_the_table_spelled_plain(encoding: str) -> None:
    proc = _kinsync(*PLAN, capture_output=True, env=_env(PYTHONIOENCODING=encoding))
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == b""
    out = proc.stdout.decode(encoding)
    assert "latency sigma (ms)" in out
    assert "all rates: latency sigma " in out
    lines = [line for line in out.splitlines() if line.startswith("|")]
    assert len({len(line) for line in lines}) == 1, out  # the columns stay aligned


def test_an_error_naming_a_file_in_another_encoding_is_one_line(tmp_path: Path) -> None:
    missing = tmp_path / "piste_δ.csv"
    args = ["trajectory", "info", str(missing)]
    proc = _kinsync(*args, capture_output=True, env=_env(PYTHONIOENCODING="latin-1"))
    assert proc.returncode == 2
    err = proc.stderr.decode("latin-1")
    assert err.count("\n") == 1, err
    assert err.startswith("kinsync: error: ")
    assert "piste_delta.csv" in err


def _closed_pipe() -> int:
    """The write end of a pipe whose reader has already gone (``| head -0``)."""
    read_end, write_end = os.pipe()
    os.close(read_end)
    return write_end


@pytest.mark.parametrize("json_flag", [[], ["--json"]])
def test_a_pipe_closed_by_its_reader_ends_quietly_with_141(json_flag: list[str]) -> None:
    write_end = _closed_pipe()
    try:
        proc = _kinsync(*PLAN, *json_flag, stdout=write_end, stderr=subprocess.PIPE, env=_env())
    finally:
        os.close(write_end)
    assert proc.returncode == PIPE_CLOSED_STATUS == 141
    assert proc.stderr == b""


@pytest.mark.parametrize("args", [["--help"], ["georef", "--help"], ["calibrate"]])
def test_help_into_a_closed_pipe_ends_quietly_with_141(args: list[str]) -> None:
    # rich's console, which typer builds for the help, exited 1: a kinsync fault.
    write_end = _closed_pipe()
    try:
        proc = _kinsync(*args, stdout=write_end, stderr=subprocess.PIPE, env=_env())
    finally:
        os.close(write_end)
    assert proc.returncode == PIPE_CLOSED_STATUS
    assert proc.stderr == b""


def test_a_broken_pipe_elsewhere_is_not_taken_for_a_closed_output(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    assert not output_pipe_closed()  # the test's own stdout and stderr are open
    write_end = _closed_pipe()
    with os.fdopen(write_end, "w") as stream:
        monkeypatch.setattr(sys, "stdout", stream)
        assert output_pipe_closed()
        monkeypatch.undo()


def test_a_closed_stderr_keeps_the_error_out_of_stdout(tmp_path: Path) -> None:
    # Python sets sys.stderr to None and print(file=None) wrote the error to stdout.
    script = '"$0" -m kinsync mount check "$1" --json 2>&-'
    proc = subprocess.run(
        ["sh", "-c", script, sys.executable, str(tmp_path / "missing.toml")],
        capture_output=True,
        text=True,
        env=_env(),
        check=False,
    )
    assert proc.returncode == 2
    assert proc.stdout == ""


def test_a_closed_stdout_is_refused_before_any_work(tmp_path: Path) -> None:
    out = tmp_path / "clk"
    script = '"$0" -m kinsync simulate clock --duration-s 60 --out "$1" --json >&-'
    proc = subprocess.run(
        ["sh", "-c", script, sys.executable, str(out)],
        capture_output=True,
        text=True,
        env=_env(),
        check=False,
    )
    assert proc.returncode == 2
    assert proc.stderr.count("\n") == 1, proc.stderr
    assert proc.stderr.startswith("kinsync: error: standard output is closed: ")
    assert not out.exists()
