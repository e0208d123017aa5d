"""Every numeric option of every command is finite and inside a declared span (issue 15,
classes 3-5): absurd values are refused before any work, in one line, exit 2."""

from __future__ import annotations

import inspect
import re
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from kinsync.cli._bounds import bounds_for
from kinsync.cli._guard import OUTPUT_PARAMETERS, numeric_parameters, path_parameters

from ._commands import commands

RunCli = Callable[[list[str]], tuple[int, str, str]]  # fixture run_cli in conftest.py
OneLineError = Callable[..., None]  # fixture assert_one_line_error in conftest.py

REQUIRED_VALUES = {"--box": "0,0,0,1,1,1", "--baud": "115200", "--bytes": "80"}


def _numeric_options() -> Iterator[tuple[tuple[str, ...], Callable[..., Any], str, str]]:
    for path, callback in commands():
        for name, option in numeric_parameters(callback).items():
            yield path, callback, name, option


def test_every_numeric_option_has_a_span() -> None:
    missing = [
        f"{' '.join(path)} {option}"
        for path, _, _, option in _numeric_options()
        if bounds_for(" ".join(path), option) is None
    ]
    assert not missing


def _base_argv(path: tuple[str, ...], callback: Callable[..., Any], tmp: Path) -> list[str]:
    """The command with every required option given (dummy files: the check comes first)."""
    argv = [*path]
    signature = inspect.signature(callback)
    spelled = {**path_parameters(callback), **numeric_parameters(callback)}
    for name, param in signature.parameters.items():
        if param.default is not inspect.Parameter.empty:
            continue
        option = spelled.get(name)
        if option is None:
            option = "--" + name.replace("_", "-")
        if name in path_parameters(callback):
            f = tmp / (f"{name}.dat" if name not in OUTPUT_PARAMETERS else "out.dat")
            if name not in OUTPUT_PARAMETERS:
                f.write_text("x\n")
            argv += [str(f)] if option.isupper() else [option, str(f)]
        else:
            argv += [option, REQUIRED_VALUES.get(option, "1")]
    return argv


def _outside_cases() -> Iterator[Any]:
    for path, callback, name, option in _numeric_options():
        span = bounds_for(" ".join(path), option)
        assert span is not None
        is_int = "int" in str(inspect.signature(callback).parameters[name].annotation)
        step = 1 if is_int else max(abs(span.low), abs(span.high), 1.0) * 1e-6
        values = [span.low - step, span.high + step]
        values = [int(v) for v in values] if is_int else [*values, float("nan"), float("inf")]
        for v in values:
            yield pytest.param(
                path, callback, option, repr(v), id=f"{' '.join(path)} {option} {v!r}"
            )


def _argv_without(
    path: tuple[str, ...], callback: Callable[..., Any], tmp_path: Path, option: str
) -> list[str]:
    """The command's working arguments without ``option`` (a required one has a value)."""
    argv = _base_argv(path, callback, tmp_path)
    if option in argv:
        i = argv.index(option)
        del argv[i : i + 2]
    return argv


@pytest.mark.parametrize(("path", "callback", "option", "value"), list(_outside_cases()))
def test_values_outside_the_span_are_refused(
    run_cli: RunCli,
    assert_one_line_error: OneLineError,
    tmp_path: Path,
    path: tuple[str, ...],
    callback: Callable[..., Any],
    option: str,
    value: str,
) -> None:
    argv = _argv_without(path, callback, tmp_path, option)
    code, out, err = run_cli([*argv, option, value])
    assert_one_line_error(code, out, err, option)
    reasons = ("not a finite number", "outside the span kinsync accepts", "Invalid value for")
    assert any(r in err for r in reasons), err


def _int_options() -> Iterator[Any]:
    for path, callback, name, option in _numeric_options():
        annotation = str(inspect.signature(callback).parameters[name].annotation)
        if re.match(r"(Annotated\[)?int\b", annotation):
            yield pytest.param(path, callback, option, id=f"{' '.join(path)} {option}")


@pytest.mark.parametrize(("path", "callback", "option"), list(_int_options()))
@pytest.mark.parametrize("sign", ["", "-"])
def test_an_integer_beyond_float_range_is_outside_the_span(
    run_cli: RunCli,
    assert_one_line_error: OneLineError,
    tmp_path: Path,
    path: tuple[str, ...],
    callback: Callable[..., Any],
    option: str,
    sign: str,
) -> None:
    """400 nines gave OverflowError (internal error): math.isfinite cannot take such an int."""
    argv = _argv_without(path, callback, tmp_path, option)
    code, out, err = run_cli([*argv, option, sign + "9" * 400])
    assert_one_line_error(code, out, err, option)
    ours = f"{option} {sign}(an integer of more than 308 digits): outside the span"
    assert ours in err or "Invalid value for" in err, err  # typer's own min= check


def _gps_week_commands() -> Iterator[Any]:
    for path, callback, _, option in _numeric_options():
        if option == "--gps-week":
            yield pytest.param(path, callback, id=" ".join(path))


@pytest.mark.parametrize(("path", "callback"), list(_gps_week_commands()))
@pytest.mark.parametrize(
    ("week", "fragments"),
    [
        ("297", ["10-bit week number", "add 2048"]),  # 2345 rolled over twice
        ("100", ["10-bit week number", "1024 for August 1999 to April 2019"]),
        ("5000", ["after the current GPS week"]),  # year 2075
    ],
)
def test_gps_week_outside_the_gps_era_is_refused(
    run_cli: RunCli,
    assert_one_line_error: OneLineError,
    tmp_path: Path,
    path: tuple[str, ...],
    callback: Callable[..., Any],
    week: str,
    fragments: list[str],
) -> None:
    """Review G: week 5000 was accepted, and week 100 gave times with 'no date'."""
    argv = _base_argv(path, callback, tmp_path)
    code, out, err = run_cli([*argv, "--gps-week", week])
    assert_one_line_error(code, out, err, f"--gps-week {week}", *fragments)


def test_a_full_gps_week_is_within_the_span() -> None:
    span = bounds_for("trajectory info", "--gps-week")
    assert span is not None
    assert span.low == 1024
    assert span.low <= 2345 <= span.high  # December 2024


def _declared_ranges() -> Iterator[tuple[str, float | None, float | None]]:
    """(command option, typer min, typer max) of each numeric option declaring one."""
    for path, callback in commands():
        numbers = numeric_parameters(callback)
        for name, param in inspect.signature(callback, eval_str=True).parameters.items():
            for meta in getattr(param.annotation, "__metadata__", ()):
                low, high = getattr(meta, "min", None), getattr(meta, "max", None)
                if name in numbers and (low is not None or high is not None):
                    yield f"{' '.join(path)} {numbers[name]}", low, high


def test_a_range_the_help_shows_is_the_span_kinsync_accepts() -> None:
    """--gps-week showed [x>=0] in every command's help, where 1024 to the current week
    (plus two years) is accepted: a declared range must be the option's span."""
    declared = list(_declared_ranges())
    assert declared
    wrong = []
    for where, low, high in declared:
        command, option = where.rsplit(" ", 1)
        span = bounds_for(command, option)
        assert span is not None
        if (low is not None and low != span.low) or (high is not None and high != span.high):
            wrong.append(f"{where}: declared {low}..{high}, accepted {span.low:g}..{span.high:g}")
    assert not wrong


@pytest.mark.parametrize(("path", "callback"), list(_gps_week_commands()))
def test_gps_week_help_gives_the_span(
    run_cli: RunCli, path: tuple[str, ...], callback: Callable[..., Any]
) -> None:
    assert "gps_week" in inspect.signature(callback).parameters
    code, out, _ = run_cli([*path, "--help"])
    assert code == 0
    text = " ".join(out.replace("│", " ").split())
    assert "x>=0" not in text
    assert "A full GPS week number, 1024 or more" in text
