"""Run the ``kinsync`` entry point in-process and collect exit code, stdout and stderr."""

from __future__ import annotations

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


def _assert_one_line_error(code: int, out: str, err: str, *fragments: str) -> None:
    """Exit 2, nothing on stdout, one line on stderr naming every fragment, no traceback."""
    assert code == 2, err
    assert out == ""
    assert err.count("\n") == 1, err
    assert err.startswith("kinsync: error: ")
    assert "Traceback" not in err
    for frag in fragments:
        assert frag in err, err


@pytest.fixture
def assert_one_line_error() -> OneLineError:
    return _assert_one_line_error
