"""A stop signal that lands inside a callback from C, or in llvmlite, is not lost.

Python runs a signal handler in whatever Python code the main thread executes next.
When that is a callback from C (numba's compiler notifying its cache through llvmlite,
which CI caught: the SIGTERM was printed as "Exception ignored in
_raw_object_cache_notify", the run finished and published its output, then exited 143
saying the outputs were removed), the exception cannot propagate. These tests run
`main` in-process with a tiny command that raises the signal inside a ctypes callback.
A signal that lands in llvmlite's Python code is held until that code
returns: an exception raised in the middle of numba's compiler crashed the process
(exit 139) as llvmlite objects were disposed of twice.
"""

from __future__ import annotations

import ctypes
import os
import signal
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
import typer

import kinsync.cli
import kinsync.cli.app
from kinsync.cli import main
from kinsync.errors import InputError


def _signal_inside_callback(signum: int) -> None:
    """Send ``signum`` to this process from inside a callback called through C."""

    def callback() -> None:
        os.kill(os.getpid(), signum)
        for _ in range(100):  # the handler runs at one of these bytecodes, in the callback
            time.sleep(0.001)

    ctypes.CFUNCTYPE(None)(callback)()


def _app(out: Path, work_s: float, *, fail: bool = False) -> typer.Typer:
    app = typer.Typer()

    @app.command()
    def work(signal_name: str = "SIGTERM") -> None:
        _signal_inside_callback(int(signal.Signals[signal_name]))
        if fail:
            msg = "no compiled object yet"  # what numba raises after a cut callback
            raise RuntimeError(msg)
        end = time.monotonic() + work_s
        while time.monotonic() < end:
            time.sleep(0.005)
        out.write_text("complete\n")

    @app.command()
    def other() -> None:  # a group of two: "work" is named on the command line
        raise InputError("unused")

    return app


def _run(monkeypatch: pytest.MonkeyPatch, app: typer.Typer, *args: str) -> int:
    monkeypatch.setattr(kinsync.cli.app, "app", app)
    with pytest.raises(SystemExit) as stop:
        main(["work", *args])
    assert isinstance(stop.value.code, int)
    return stop.value.code


def _app_of(work: Callable[[], None]) -> typer.Typer:
    """A program whose command ``work`` runs ``work`` (and a second, so it is named)."""
    app = typer.Typer()
    app.command("work")(work)

    @app.command()
    def other() -> None:
        raise InputError("unused")

    return app


def _llvmlite_like_step() -> Callable[[int, list[str]], None]:
    """`_COMPILER_LIKE`'s function, defined in a module named as llvmlite's."""
    namespace: dict[str, Any] = {"__name__": "llvmlite.binding.stand_in"}
    exec(_COMPILER_LIKE, namespace)
    step: Callable[[int, list[str]], None] = namespace["compile_step"]
    return step


@pytest.mark.parametrize(("name", "code"), [("SIGTERM", 143), ("SIGINT", 130)])
def test_a_signal_swallowed_in_a_callback_still_stops_the_command(
    monkeypatch: pytest.MonkeyPatch,
    capfd: pytest.CaptureFixture[str],
    tmp_path: Path,
    name: str,
    code: int,
) -> None:
    out = tmp_path / "out.txt"
    assert _run(monkeypatch, _app(out, work_s=5.0), "--signal-name", name) == code
    err = capfd.readouterr().err
    assert err.strip() == f"kinsync: interrupted by {name}; unfinished outputs removed"
    assert not out.exists()  # stopped within the work, not after 5 s


def test_a_failure_after_a_swallowed_signal_is_the_interruption(
    monkeypatch: pytest.MonkeyPatch, capfd: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    assert _run(monkeypatch, _app(tmp_path / "o.txt", 0.0, fail=True)) == 143
    err = capfd.readouterr().err
    assert err.strip() == "kinsync: interrupted by SIGTERM; unfinished outputs removed"


def test_a_command_that_ends_before_the_signal_comes_again_says_its_outputs_are_complete(
    monkeypatch: pytest.MonkeyPatch, capfd: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    monkeypatch.setattr(kinsync.cli, "REDELIVER_AFTER_S", 30.0)
    out = tmp_path / "out.txt"
    assert _run(monkeypatch, _app(out, work_s=0.1)) == 143
    err = capfd.readouterr().err
    assert (
        err.strip() == "kinsync: SIGTERM arrived as the command finished; its outputs are complete"
    )
    assert out.read_text() == "complete\n"


def test_handlers_and_hook_are_restored_and_other_unraisable_errors_still_reported(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    seen: list[BaseException | None] = []
    monkeypatch.setattr("sys.unraisablehook", lambda u: seen.append(u.exc_value))
    term, intr = signal.getsignal(signal.SIGTERM), signal.getsignal(signal.SIGINT)

    def boom() -> None:
        raise ValueError("not a signal")

    with kinsync.cli._stop_signals_unwind():
        ctypes.CFUNCTYPE(None)(boom)()
    assert [type(e) for e in seen] == [ValueError]  # passed on to the hook before ours
    assert sys.unraisablehook.__name__ == "<lambda>"  # the one before is back
    assert (signal.getsignal(signal.SIGTERM), signal.getsignal(signal.SIGINT)) == (term, intr)


_COMPILER_LIKE = """
import os, time
def compile_step(signum, marks):
    os.kill(os.getpid(), signum)
    for _ in range(60):  # the handler runs at one of these bytecodes, in this module
        time.sleep(0.005)
    marks.append("compiled")
"""


def test_a_signal_in_llvmlite_code_waits_until_it_returns(
    monkeypatch: pytest.MonkeyPatch, capfd: pytest.CaptureFixture[str]
) -> None:
    compile_step = _llvmlite_like_step()
    marks: list[str] = []

    def work() -> None:
        compile_step(int(signal.SIGTERM), marks)
        end = time.monotonic() + 5.0
        while time.monotonic() < end:
            time.sleep(0.005)
        marks.append("worked on")

    assert _run(monkeypatch, _app_of(work)) == 143
    assert marks == ["compiled"]  # not cut inside; stopped soon after
    assert "unfinished outputs removed" in capfd.readouterr().err


def test_outputs_complete_before_the_signal_are_named(
    monkeypatch: pytest.MonkeyPatch, capfd: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    from kinsync.io.atomic import atomic_folder, atomic_write_text  # noqa: PLC0415

    done, folder = tmp_path / "done.csv", tmp_path / "sim"

    def work() -> None:
        atomic_write_text(done, "t\n")
        with atomic_folder(folder, lambda _: None, "give another folder") as tmp:
            atomic_write_text(tmp / "inner.csv", "t\n")  # goes with the folder
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(5.0)

    assert _run(monkeypatch, _app_of(work)) == 143
    err = capfd.readouterr().err.strip()
    assert err == (
        f"kinsync: interrupted by SIGTERM; written before it: {done}; unfinished outputs removed"
    )
    assert done.exists()
    assert not folder.exists()


def test_a_held_back_signal_does_not_break_into_the_clean_up_of_the_next(
    monkeypatch: pytest.MonkeyPatch, capfd: pytest.CaptureFixture[str]
) -> None:
    # SIGINT lands in llvmlite and is held back; SIGTERM then stops the command, and the
    # SIGINT sent again must not cut the clean-up short (review of this stop).
    compile_step = _llvmlite_like_step()
    marks: list[str] = []

    def work() -> None:
        compile_step(int(signal.SIGINT), marks)
        try:
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(5.0)
        finally:
            end = time.monotonic() + 0.3  # longer than the 50 ms before a resend
            while time.monotonic() < end:
                time.sleep(0.005)
            marks.append("cleaned up")

    assert _run(monkeypatch, _app_of(work)) == 143
    assert marks == ["compiled", "cleaned up"]
    assert capfd.readouterr().err.strip().startswith("kinsync: interrupted by SIGTERM")


def test_an_interruption_swallowed_by_the_command_says_its_outputs_are_complete(
    monkeypatch: pytest.MonkeyPatch, capfd: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    out = tmp_path / "out.txt"

    def work() -> None:
        try:
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(5.0)
        except BaseException:  # a library that swallows everything
            pass
        out.write_text("complete\n")

    assert _run(monkeypatch, _app_of(work)) == 143
    done = "kinsync: SIGTERM arrived as the command finished; its outputs are complete"
    assert capfd.readouterr().err.strip() == done
    assert out.read_text() == "complete\n"
