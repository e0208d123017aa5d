"""Run the ``kinsync`` entry point in-process and collect exit code, stdout and stderr."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from kinsync.cli import main

RunCli = Callable[[list[str]], tuple[int, str, str]]


@pytest.fixture
def run_cli(capsys: pytest.CaptureFixture[str]) -> RunCli:
    def run(argv: list[str]) -> tuple[int, str, str]:
        with pytest.raises(SystemExit) as exc:
            main(argv)
        captured = capsys.readouterr()
        code = exc.value.code
        return (code if isinstance(code, int) else 0), captured.out, captured.err

    return run
