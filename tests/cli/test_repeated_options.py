"""An option that takes one value, given twice, is refused (click kept the last one)."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import pytest
import typer.main

from kinsync.cli._options import expand_multi_value_options, refuse_repeated_options
from kinsync.cli.app import app
from kinsync.errors import InputError

RunCli = Callable[[list[str]], tuple[int, str, str]]  # fixture run_cli in conftest.py
OneLineError = Callable[..., None]  # fixture assert_one_line_error in conftest.py

COMMAND = typer.main.get_command(app)


def _leaves(command: Any, path: tuple[str, ...] = ()) -> Iterator[tuple[tuple[str, ...], Any]]:
    subs = getattr(command, "commands", None)
    if isinstance(subs, dict):
        for name, sub in subs.items():
            yield from _leaves(sub, (*path, name))
    else:
        yield path, command


def _single_valued(command: Any) -> list[str]:
    return [
        p.opts[0]
        for p in command.params
        if p.param_type_name == "option" and not (p.multiple or p.is_flag)
    ]


CASES = [(path, opt) for path, cmd in _leaves(COMMAND) for opt in _single_valued(cmd)]


def test_every_command_has_single_valued_options() -> None:
    paths = {path for path, _ in CASES}
    assert ("georef",) in paths
    assert ("calibrate", "mount") in paths
    assert len(CASES) > 100  # every option of every command, not a sample


@pytest.mark.parametrize(("path", "option"), CASES, ids=[" ".join((*p, o)) for p, o in CASES])
def test_each_single_valued_option_given_twice_is_refused(
    path: tuple[str, ...], option: str
) -> None:
    args = expand_multi_value_options([*path, option, "A", option, "B"])
    with pytest.raises(InputError, match=f"{option} given 2 times \\('A', 'B'\\)"):
        refuse_repeated_options(COMMAND, args)
    with pytest.raises(InputError, match=f"{option} given 2 times \\('A', 'B'\\)"):
        refuse_repeated_options(COMMAND, [*path, f"{option}=A", option, "B"])
    refuse_repeated_options(COMMAND, [*path, option, "A"])  # once is fine


def test_multi_value_options_flags_and_values_are_not_counted() -> None:
    # --points takes several values; --json is a flag; a value equal to an option's
    # name after "--" is an argument.
    args = expand_multi_value_options(
        ["calibrate", "mount", "--points", "a.laz", "b.laz", "--json", "--json"]
    )
    refuse_repeated_options(COMMAND, args)
    refuse_repeated_options(COMMAND, ["latency", "sphere", "--", "--json", "--json"])
    refuse_repeated_options(COMMAND, ["nonexistent", "--out", "a", "--out", "b"])
    refuse_repeated_options(COMMAND, ["--version"])


def test_a_value_that_looks_like_an_option_is_a_value() -> None:
    # click reads --out's value "--seed" as the folder name: one --seed, not two.
    refuse_repeated_options(COMMAND, ["simulate", "validation", "--out", "--seed", "--seed", "3"])
    with pytest.raises(InputError, match=r"--seed given 2 times \('3', '4'\)"):
        refuse_repeated_options(
            COMMAND, ["simulate", "validation", "--out", "--seed", "--seed", "3", "--seed", "4"]
        )


def test_help_wins_over_a_repeated_option(run_cli: RunCli) -> None:
    code, out, err = run_cli(["georef", "--help", "--mount", "a.toml", "--mount", "b.toml"])
    assert code == 0, err
    assert "Usage: kinsync georef" in out


def test_the_program_refuses_before_any_work(
    run_cli: RunCli, assert_one_line_error: OneLineError
) -> None:
    # Neither mount file exists: the repetition is named, not a missing file.
    code, out, err = run_cli(
        ["georef", "--points", "p.laz", "--trajectory", "t.out", "--mount", "a.toml",
         "--out", "x.laz", "--mount", "b.toml"]
    )  # fmt: skip
    assert_one_line_error(code, out, err, "--mount given 2 times ('a.toml', 'b.toml')")
