"""One rule for every command: an output never replaces an input (class 1 of issue 15).

The cases are generated from the commands themselves: every ``Path`` parameter not
named as an output is an input, so a new command or option is covered the day it is
added. Each output is pointed at each input by the same path, a relative detour, a
symbolic link and a hard link; the run must stop with exit 2 before any work, naming
both options, and leave the input byte-for-byte unchanged.
"""

from __future__ import annotations

import hashlib
import inspect
import os
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from kinsync.cli._guard import OUTPUT_PARAMETERS, path_parameters

from ._commands import EXTRA_REQUIRED, commands

RunCli = Callable[[list[str]], tuple[int, str, str]]  # fixture run_cli in conftest.py
OneLineError = Callable[..., None]  # fixture assert_one_line_error in conftest.py


def _cases() -> Iterator[Any]:
    for path, callback in commands():
        params = path_parameters(callback)
        outputs = [p for p in params if p in OUTPUT_PARAMETERS]
        inputs = [p for p in params if p not in OUTPUT_PARAMETERS]
        for out in outputs:
            for inp in inputs:
                for how in ("same", "relative", "symlink", "hardlink"):
                    yield pytest.param(
                        path, callback, out, inp, how, id=f"{'-'.join(path)}:{out}={inp}:{how}"
                    )


def test_every_path_parameter_is_classified() -> None:
    """An output-like name that is not in OUTPUT_PARAMETERS would be taken for an input."""
    for path, callback in commands():
        for name in path_parameters(callback):
            looks_like_output = any(w in name for w in ("out", "figure", "png", "report", "html"))
            assert looks_like_output == (name in OUTPUT_PARAMETERS), (path, name)


def _digest(p: Path) -> str:
    return hashlib.sha256(p.read_bytes()).hexdigest()


@pytest.mark.parametrize(("path", "callback", "out", "inp", "how"), list(_cases()))
def test_output_onto_an_input_is_refused(
    run_cli: RunCli,
    assert_one_line_error: OneLineError,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    path: tuple[str, ...],
    callback: Callable[..., Any],
    out: str,
    inp: str,
    how: str,
) -> None:
    monkeypatch.chdir(tmp_path)
    spelled = path_parameters(callback)
    signature = inspect.signature(callback)
    argv: list[str] = [*path]
    files: dict[str, Path] = {}
    for name, option in spelled.items():
        if name in OUTPUT_PARAMETERS:
            continue
        f = tmp_path / f"{name}.dat"
        f.write_text(f"content of {name}\n")
        files[name] = f
        if signature.parameters[name].default is inspect.Parameter.empty or name == inp:
            argv += [str(f)] if option.isupper() else [option, str(f)]
    target = files[inp]
    if how == "same":
        given = str(target)
    elif how == "relative":
        (tmp_path / "sub").mkdir()
        given = f"sub/../{target.name}"
    elif how == "symlink":
        (tmp_path / "link.dat").symlink_to(target)
        given = "link.dat"
    else:
        os.link(target, tmp_path / "hard.dat")
        given = "hard.dat"
    before = _digest(target)
    argv += [spelled[out], given, *EXTRA_REQUIRED.get(path, [])]
    code, o, e = run_cli(argv)
    assert_one_line_error(code, o, e, f"{spelled[out]} {given}: is the input {spelled[inp]}")
    assert _digest(target) == before


def test_an_input_folder_is_refused_as_output_and_its_files_are_kept(
    run_cli: RunCli, assert_one_line_error: OneLineError, tmp_path: Path
) -> None:
    sim = tmp_path / "table"
    small = ["--rates-deg-s", "6,18", "--passes", "2"]  # the guard, not the fit, is tested
    code, _, err = run_cli(["simulate", "rotating-table", *small, "--out", str(sim)])
    assert code == 0, err
    code, o, e = run_cli(["latency", "sphere", str(sim), "--figure", str(sim)])
    assert_one_line_error(code, o, e, f"is the input folder FOLDER ({sim})")
    index = sim / "passes.csv"
    before = _digest(index)
    code, o, e = run_cli(["latency", "sphere", str(sim), "--figure", str(index)])
    assert_one_line_error(code, o, e, f"would replace a file of the input folder FOLDER ({sim})")
    assert _digest(index) == before
    code, _, err = run_cli(["latency", "sphere", str(sim), "--figure", str(sim / "fig.png")])
    assert code == 0, err  # a new file in the input folder is fine
    code, _, err = run_cli(["latency", "sphere", str(sim), "--figure", str(sim / "fig.png")])
    assert code == 0, err  # and so is replacing a figure kinsync wrote there before


def _loop_cases() -> Iterator[Any]:
    for path, callback in commands():
        params = path_parameters(callback)
        outputs = [p for p in params if p in OUTPUT_PARAMETERS]
        for inp in (p for p in params if p not in OUTPUT_PARAMETERS):
            if outputs:
                yield pytest.param(path, callback, inp, id=f"{'-'.join(path)}:{inp}")


@pytest.mark.parametrize(("path", "callback", "inp"), list(_loop_cases()))
def test_an_input_that_is_a_symbolic_link_loop_is_named(
    run_cli: RunCli,
    assert_one_line_error: OneLineError,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    path: tuple[str, ...],
    callback: Callable[..., Any],
    inp: str,
) -> None:
    # Was an internal error (exit 1): "RuntimeError: Symlink loop from ..." from
    # Path.resolve, checking that the output is not that input.
    monkeypatch.chdir(tmp_path)
    spelled = path_parameters(callback)
    signature = inspect.signature(callback)
    argv: list[str] = [*path]
    loop = tmp_path / "loop.dat"
    loop.symlink_to(loop.name)
    out = next(name for name in spelled if name in OUTPUT_PARAMETERS)
    for name, option in spelled.items():
        if name in OUTPUT_PARAMETERS:
            continue
        f = loop if name == inp else tmp_path / f"{name}.dat"
        if name != inp:
            f.write_text(f"content of {name}\n")
        if signature.parameters[name].default is inspect.Parameter.empty or name == inp:
            argv += [str(f)] if option.isupper() else [option, str(f)]
    argv += [spelled[out], str(tmp_path / "out" / "x"), *EXTRA_REQUIRED.get(path, [])]
    code, o, e = run_cli(argv)
    shown = f"{spelled[inp]} {loop}" if spelled[inp].startswith("-") else str(loop)
    assert_one_line_error(code, o, e, shown, "symbolic link loop")


def test_an_output_that_is_a_symbolic_link_loop_is_named(
    run_cli: RunCli, assert_one_line_error: OneLineError, tmp_path: Path
) -> None:
    model = tmp_path / "model.json"
    model.write_text("{}\n")
    loop = tmp_path / "out.csv"
    loop.symlink_to(loop.name)
    argv = ["clock", "apply", "--model", str(model), "--in", str(tmp_path / "in.csv")]
    code, o, e = run_cli([*argv, "--out", str(loop)])
    assert_one_line_error(code, o, e, f"--out {loop}: symbolic link loop")
    assert loop.is_symlink()
