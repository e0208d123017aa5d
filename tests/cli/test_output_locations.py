"""Every output of every command is checked where it will be written, before any work.

Class 4 of issue 15: ``--out`` an existing folder or a read-only folder used to end in
an internal error (exit 1) after the work was done. The cases are generated from the
commands themselves (as in ``test_outputs_never_replace_inputs.py``): each output is
given as an existing folder, in a missing folder, in a folder where no file can be
created (``/sys`` refuses even root; ``/proc/self`` takes no new file) and, for folder
outputs, below a file and as the current folder (``--out .``, empty or not: it ran the
whole command, then refused its own temporary folder). Each run must stop with exit 2
and one line naming the option, before any input is read (the inputs here are not valid
files).
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from kinsync.cli._guard import (
    OUTPUT_PARAMETERS,
    OUTPUT_SUFFIXES,
    output_is_folder,
    path_parameters,
)
from kinsync.errors import InputError
from kinsync.io.atomic import atomic_path, check_output_location

from ._commands import EXTRA_REQUIRED, commands

RunCli = Callable[[list[str]], tuple[int, str, str]]  # fixture run_cli in conftest.py
OneLineError = Callable[..., None]  # fixture assert_one_line_error in conftest.py

UNWRITABLE = [d for d in (Path("/sys"), Path("/proc/self")) if d.is_dir()]


def _cases() -> Iterator[Any]:
    for path, callback in commands():
        command = " ".join(path)
        for out in (p for p in path_parameters(callback) if p in OUTPUT_PARAMETERS):
            folder = output_is_folder(command, out)
            kinds = ["missing_folder"]
            kinds += ["below_a_file", "current_empty", "current"] if folder else ["existing_folder"]
            kinds += [f"unwritable:{d}" for d in UNWRITABLE]
            for kind in kinds:
                yield pytest.param(path, callback, out, kind, id=f"{command}:{out}:{kind}")


def _argv(path: tuple[str, ...], callback: Callable[..., Any], tmp: Path) -> list[str]:
    """The command with every required path given as a (not valid) input file."""
    signature = inspect.signature(callback)
    argv = [*path]
    for name, option in path_parameters(callback).items():
        if name in OUTPUT_PARAMETERS:
            continue
        if signature.parameters[name].default is inspect.Parameter.empty:
            f = tmp / f"{name}.dat"
            f.write_text("not read\n")
            argv += [str(f)] if option.isupper() else [option, str(f)]
    return [*argv, *EXTRA_REQUIRED.get(path, [])]


@pytest.mark.parametrize(("path", "callback", "out", "kind"), list(_cases()))
def test_an_output_that_cannot_be_written_is_refused_before_any_work(
    run_cli: RunCli,
    assert_one_line_error: OneLineError,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    path: tuple[str, ...],
    callback: Callable[..., Any],
    out: str,
    kind: str,
) -> None:
    option = path_parameters(callback)[out]
    suffix = OUTPUT_SUFFIXES.get(out, ".png")
    if kind == "existing_folder":
        (tmp_path / f"dir{suffix}").mkdir()
        given, fragment = tmp_path / f"dir{suffix}", "is an existing folder"
    elif kind == "missing_folder":
        given, fragment = tmp_path / "none" / f"o{suffix}", "does not exist"
    elif kind in ("current_empty", "current"):
        # `--out .` ran the whole command, then refused its own temporary folder
        here = tmp_path / "here"
        here.mkdir()
        monkeypatch.chdir(here if kind == "current_empty" else tmp_path)
        given, fragment = Path(), "is the current folder"
    elif kind == "below_a_file":
        (tmp_path / "file").write_text("x")
        given, fragment = tmp_path / "file" / "sub", "is a file, not a folder"
    else:
        given, fragment = Path(kind.split(":", 1)[1]) / f"o{suffix}", "cannot write in the folder"
    argv = [*_argv(path, callback, tmp_path), option, str(given)]
    before = sorted(tmp_path.rglob("*"))
    code, o, e = run_cli(argv)
    assert_one_line_error(code, o, e, f"{option} {given}", fragment)
    assert sorted(tmp_path.rglob("*")) == before  # nothing written, no probe left


def test_the_probe_leaves_nothing(tmp_path: Path) -> None:
    check_output_location(tmp_path / "o.csv", "--out")
    check_output_location(tmp_path / "new", "--out", folder=True)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("folder", UNWRITABLE, ids=str)
def test_atomic_path_refuses_an_unwritable_folder_as_an_input_error(folder: Path) -> None:
    with (
        pytest.raises(InputError, match="cannot write in the folder"),
        atomic_path(folder / "o.csv"),
    ):
        pass


def _fixed_format_outputs() -> Iterator[Any]:
    for path, callback in commands():
        for out in (p for p in path_parameters(callback) if p in OUTPUT_SUFFIXES):
            yield pytest.param(path, callback, out, id=f"{' '.join(path)}:{out}")


@pytest.mark.parametrize(("path", "callback", "out"), list(_fixed_format_outputs()))
def test_an_output_of_one_format_refuses_another_suffix(
    run_cli: RunCli,
    assert_one_line_error: OneLineError,
    tmp_path: Path,
    path: tuple[str, ...],
    callback: Callable[..., Any],
    out: str,
) -> None:
    # A PNG was written into fig.jpg, HTML into report.pdf, JSON into model.toml.
    option = path_parameters(callback)[out]
    given = tmp_path / "o.jpg"
    suffix = OUTPUT_SUFFIXES[out]
    fragment = f"{option} {given}: this output is {suffix[1:].upper()}; give a {suffix} file"
    assert_one_line_error(
        *run_cli([*_argv(path, callback, tmp_path), option, str(given)]), fragment
    )
    assert not given.exists()


def _output_pairs() -> Iterator[Any]:
    for path, callback in commands():
        command = " ".join(path)
        outs = [
            p
            for p in path_parameters(callback)
            if p in OUTPUT_PARAMETERS and not output_is_folder(command, p)
        ]
        for i, first in enumerate(outs):
            for second in outs[i + 1 :]:
                yield pytest.param(path, callback, first, second, id=f"{command}:{first}={second}")


PAIRS = list(_output_pairs())


def test_commands_with_two_file_outputs_are_covered() -> None:
    ids = {p.id for p in PAIRS}
    assert "clock fit:model_out=figure" in ids
    assert "calibrate mount:out=report" in ids


@pytest.mark.parametrize("by_link", [False, True], ids=["same-path", "symlink"])
@pytest.mark.parametrize(("path", "callback", "first", "second"), PAIRS)
def test_two_outputs_naming_one_file_are_refused_before_any_work(
    run_cli: RunCli,
    assert_one_line_error: OneLineError,
    tmp_path: Path,
    path: tuple[str, ...],
    callback: Callable[..., Any],
    first: str,
    second: str,
    by_link: bool,
) -> None:
    # calibrate mount --out cal.toml --report cal.toml wrote the HTML report over the
    # calibrated mount, with exit 0.
    spelled = path_parameters(callback)
    suffix = OUTPUT_SUFFIXES.get(first, ".csv")  # the same file for both outputs
    target = tmp_path / f"same{suffix}"
    other = tmp_path / f"link{suffix}"
    if by_link:
        other.symlink_to(target)
    argv = [*_argv(path, callback, tmp_path), spelled[first], str(target)]
    argv += [spelled[second], str(other if by_link else target)]
    assert_one_line_error(*run_cli(argv), "are the same file", spelled[first], spelled[second])
    assert not target.exists()


def test_an_output_that_cannot_be_replaced_is_an_input_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # An immutable existing output (chattr +i) ended in an internal error (exit 1) when
    # the finished temporary file was renamed onto it.
    out = tmp_path / "out.csv"
    out.write_text("old\n")

    def refuse(self: Path, target: Path) -> Path:
        raise PermissionError(1, "Operation not permitted", str(self), None, str(target))

    monkeypatch.setattr(Path, "replace", refuse)
    with (
        pytest.raises(InputError, match=r"out\.csv: cannot replace it \(Operation not permitted\)"),
        atomic_path(out) as tmp,
    ):
        tmp.write_text("new\n")
    monkeypatch.undo()
    assert out.read_text() == "old\n"
    assert [p.name for p in tmp_path.iterdir()] == ["out.csv"]
