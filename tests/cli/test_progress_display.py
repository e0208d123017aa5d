"""How commands show progress: a bar on a terminal, stage lines otherwise, none on stdout."""

from __future__ import annotations

import io
import json
from collections.abc import Callable
from pathlib import Path

import numba
import pytest
from rich.console import Console

from kinsync.cli import _progress
from kinsync.cli._progress import COMPILING, progress_display
from kinsync.errors import InputError
from kinsync.progress import Stages

RunCli = Callable[[list[str]], tuple[int, str, str]]  # fixture run_cli in conftest.py


@pytest.fixture
def no_hold(monkeypatch: pytest.MonkeyPatch) -> None:
    """Stage lines from the first report, as for work that has run `HOLD_S` seconds."""
    monkeypatch.setattr(_progress, "HOLD_S", 0.0)


def _lines(err: str) -> list[str]:
    return [line.rsplit(" (", 1)[0] for line in err.splitlines()]


@pytest.mark.usefixtures("no_hold")
def test_one_line_per_stage_when_not_a_terminal(capsys: pytest.CaptureFixture[str]) -> None:
    with progress_display("job") as progress:
        stages = Stages(progress, {"read": 1.0, "work": 3.0})
        stages.start("read")
        work = stages.start("work")
        assert work is not None
        for i in range(10):
            work(i / 10, "work")
        stages.finish()
    captured = capsys.readouterr()
    assert captured.out == ""
    assert _lines(captured.err) == ["kinsync: job: read", "kinsync: job: work"]
    assert "\x1b" not in captured.err
    assert all(line.endswith(" s)") for line in captured.err.splitlines())


def test_a_failure_as_the_work_starts_leaves_no_stage_line(
    capsys: pytest.CaptureFixture[str],
) -> None:
    with pytest.raises(InputError), progress_display("job") as progress:  # noqa: PT012
        stages = Stages(progress, {"read": 1.0, "work": 1.0})
        stages.start("read")
        stages.say("reading 1 file")
        stages.start("work")  # the bar moved on, no work done yet
        raise InputError("one file given: need two")  # found while reading: one error line
    assert capsys.readouterr().err == ""


def test_lines_held_only_while_the_work_is_young(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    with progress_display("job") as progress:
        progress(0.5, "read")  # young work: held, however far it got
        assert capsys.readouterr().err == ""
        monkeypatch.setattr(_progress, "HOLD_S", 0.0)  # as if HOLD_S seconds had passed
        progress(0.0, "still reading")
        assert _lines(capsys.readouterr().err) == [
            "kinsync: job: read",
            "kinsync: job: still reading",
        ]
        progress(1.0, "done")
    assert _lines(capsys.readouterr().err) == ["kinsync: job: done"]


def test_quick_work_writes_no_stage_line(capsys: pytest.CaptureFixture[str]) -> None:
    with progress_display("job") as progress:
        stages = Stages(progress, {"only": 1.0})
        stages.start("only", "checking")
        stages.finish()
    assert capsys.readouterr().err == ""


def test_a_bar_with_percentage_on_a_terminal(monkeypatch: pytest.MonkeyPatch) -> None:
    screen = io.StringIO()
    console = Console(file=screen, force_terminal=True, width=120)
    monkeypatch.setattr(_progress, "err_console", console)
    with progress_display("job") as progress:
        progress(0.5, "halfway")
        progress(1.0, "done")
    shown = screen.getvalue()
    assert "job: done" in shown
    assert "100%" in shown
    assert "kinsync: job" not in shown  # no stage lines on a terminal


@pytest.mark.usefixtures("no_hold")
def test_a_compilation_is_said_once(capsys: pytest.CaptureFixture[str]) -> None:
    with progress_display("job") as progress:
        progress(0.0, "work")

        @numba.njit(cache=False)
        def add_one(x: float) -> float:  # a new function: compiled here
            return x + 1

        add_one(1)
        add_one(2.5)  # a second specialisation: not said again
        progress(1.0, "work")
    assert _lines(capsys.readouterr().err) == ["kinsync: job: work", f"kinsync: job: {COMPILING}"]


@pytest.mark.usefixtures("no_hold")
def test_json_stdout_has_no_progress_and_stderr_has_the_stages(
    run_cli: RunCli, tmp_path: Path
) -> None:
    code, stdout, stderr = run_cli(
        [
            "simulate", "rotating-table", "--rates-deg-s", "6", "--passes", "1",
            "--out", str(tmp_path / "o"), "--json",
        ]
    )  # fmt: skip
    assert code == 0, stderr
    assert stdout.count("\n") == 1
    json.loads(stdout)
    assert "kinsync:" not in stdout
    stages = [line for line in _lines(stderr) if COMPILING not in line]
    assert stages == [
        "kinsync: simulate rotating-table: simulating passes",
        "kinsync: simulate rotating-table: writing files",
    ]


@pytest.mark.usefixtures("no_hold")
@pytest.mark.parametrize("raw", [False, True], ids=["passes", "raw"])
def test_latency_sphere_shows_reading_and_fitting(
    run_cli: RunCli, tmp_path: Path, raw: bool
) -> None:
    # It showed nothing: reading ran outside the display and fitting reported only once.
    folder = tmp_path / "table"
    code, _, stderr = run_cli(
        [
            "simulate", "rotating-table", "--rates-deg-s", "6", "--passes", "2",
            "--out", str(folder), "--raw",
        ]
    )  # fmt: skip
    assert code == 0, stderr
    args = ["latency", "sphere", str(folder), "--radius-m", "0.1", "--no-figure", "--json"]
    code, stdout, stderr = run_cli([*args, "--raw"] if raw else args)
    assert code == 0, stderr
    json.loads(stdout)
    stages = [line for line in _lines(stderr) if COMPILING not in line]
    assert stages == [
        "kinsync: latency sphere: reading",
        "kinsync: latency sphere: fitting",
    ]


class _Writes(io.StringIO):
    """A stderr that keeps each write call apart."""

    def __init__(self) -> None:
        super().__init__()
        self.calls: list[str] = []

    def write(self, text: str) -> int:
        self.calls.append(text)
        return super().write(text)


@pytest.mark.usefixtures("no_hold")
def test_a_stage_line_is_written_with_its_line_end_in_one_call(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # print() writes the text and the line end apart: a stop signal between the two
    # left the line open and the "interrupted" message glued onto it.
    stderr = _Writes()
    monkeypatch.setattr("sys.stderr", stderr)
    with progress_display("job") as progress:
        progress(0.5, "reading")
    assert stderr.calls
    assert all(call.endswith("\n") and call.count("\n") == 1 for call in stderr.calls)


class _FakeClock:
    """A clock the test moves by hand (seconds)."""

    def __init__(self) -> None:
        self.now_s = 0.0

    def __call__(self) -> float:
        return self.now_s


def test_held_lines_are_written_at_the_fifth_second_without_a_report(
    capsys: pytest.CaptureFixture[str],
) -> None:
    # A long loop that reports nothing (table_scan's attitude records at 0.01 deg/s)
    # left the stage lines held until its end: the timer writes them when due.
    clock = _FakeClock()
    with progress_display("job", clock=clock) as progress:
        progress(0.0, "simulating passes")
        clock.now_s = _progress.HOLD_S - 0.1
        assert capsys.readouterr().err == ""
        clock.now_s = _progress.HOLD_S + 0.5  # no report from here on
        assert isinstance(progress, _progress._Display)
        assert progress.released.wait(timeout=60.0)  # set by the timer, not by a report
        assert capsys.readouterr().err == "kinsync: job: simulating passes (0.0 s)\n"
        clock.now_s = 7.0
        progress(1.0, "writing files")
    assert capsys.readouterr().err == "kinsync: job: writing files (7.0 s)\n"


def test_the_timer_writes_nothing_for_quick_work(capsys: pytest.CaptureFixture[str]) -> None:
    clock = _FakeClock()
    display = _progress._Display("job", None, clock)
    display(0.0, "reading")
    clock.now_s = 1.0
    assert display.tick() == pytest.approx(_progress.HOLD_S - 1.0)
    assert capsys.readouterr().err == ""
    clock.now_s = _progress.HOLD_S
    assert display.tick() <= 0.0
    assert capsys.readouterr().err == "kinsync: job: reading (0.0 s)\n"


def _georef_inputs(folder: Path) -> list[str]:
    from tests._georef_scan import scan_columns, write_trajectory  # noqa: PLC0415

    from kinsync.io.points import TableChunkWriter  # noqa: PLC0415

    write_trajectory(folder / "traj.csv", 4.0)
    cols = scan_columns(300, 3.0, 1)
    keep = cols["t_s"] >= 1.3e9
    with TableChunkWriter(folder / "p.csv") as w:
        w.write({k: v[keep] for k, v in cols.items()})
    (folder / "m.toml").write_text("[mount]\nlever_arm_body_m = [0, 0, 0]\nlatency_s = 0.0\n")
    return [
        "--points", str(folder / "p.csv"), "--trajectory", str(folder / "traj.csv"),
        "--mount", str(folder / "m.toml"),
    ]  # fmt: skip


@pytest.mark.usefixtures("no_hold")
def test_georef_names_the_stages_before_the_points(run_cli: RunCli, tmp_path: Path) -> None:
    """Reading a 10 h trajectory (half the run) had no stage line; the bar no stage name."""
    args = ["georef", *_georef_inputs(tmp_path), "--out", str(tmp_path / "g.csv"), "--json"]
    code, stdout, stderr = run_cli(args)
    assert code == 0, stderr
    json.loads(stdout)
    stages = [line for line in _lines(stderr) if COMPILING not in line]
    assert stages == [
        "kinsync: georef: reading the trajectory",
        "kinsync: georef: checking the trajectory (velocities, gaps)",
        "kinsync: georef: reading the points' layout",
        "kinsync: georef: georeferencing",
    ]


@pytest.mark.usefixtures("no_hold")
def test_trajectory_info_and_export_name_their_stages(run_cli: RunCli, tmp_path: Path) -> None:
    _georef_inputs(tmp_path)
    traj = str(tmp_path / "traj.csv")
    code, stdout, stderr = run_cli(["trajectory", "info", traj, "--json"])
    assert code == 0, stderr
    json.loads(stdout)
    assert _lines(stderr) == [
        "kinsync: trajectory info: reading the trajectory",
        "kinsync: trajectory info: checking the trajectory (velocities, gaps)",
    ]
    out = str(tmp_path / "t.csv")
    code, stdout, stderr = run_cli(["trajectory", "export", traj, "--out", out, "--json"])
    assert code == 0, stderr
    assert _lines(stderr) == [
        "kinsync: trajectory export: reading the trajectory",
        "kinsync: trajectory export: writing",
    ]
