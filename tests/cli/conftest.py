"""Run the ``kinsync`` entry point in-process and collect exit code, stdout and stderr."""

from __future__ import annotations

import re
from collections.abc import Callable

import pytest

from kinsync.cli import main

RunCli = Callable[[list[str]], tuple[int, str, str]]
OneLineError = Callable[..., None]


@pytest.fixture
def run_cli(capsys: pytest.CaptureFixture[str]) -> RunCli:
    def run(argv: list[str]) -> tuple[int, str, str]:
        with pytest.raises(SystemExit) as exc:
            main(argv)
        captured = capsys.readouterr()
        code = exc.value.code
        return (code if isinstance(code, int) else 0), captured.out, captured.err

    return run


# a stage line of a command that ran past HOLD_S (README: "kinsync: ins run: smoother
# (6.1 s)"): under a loaded machine a refused command may write them before its error
_PROGRESS_LINE = re.compile(r"kinsync: (?!error:|warning:)[a-z -]+: [^\n]+ \(\d+\.\d s\)")


def _assert_one_line_error(code: int, out: str, err: str, *fragments: str) -> None:
    """Exit 2, nothing on stdout, one line on stderr naming every fragment, no traceback.

    Stage lines may come before it when the command took over five seconds (the progress
    contract in README): the error is the last line and the only other kind of line.
    """
    assert code == 2, err
    assert out == ""
    assert err.endswith("\n"), err
    *stages, last = err[:-1].split("\n")
    assert all(_PROGRESS_LINE.fullmatch(line) for line in stages), err
    err = last + "\n"
    assert err.startswith("kinsync: error: ")
    assert "Traceback" not in err
    for frag in fragments:
        assert frag in err, err


@pytest.fixture
def assert_one_line_error() -> OneLineError:
    return _assert_one_line_error
