"""numba's settings in the environment, checked when the program starts.

``NUMBA_NUM_THREADS=0`` ended in ``internal error: ValueError: Number of threads
specified must be > 0.`` (exit 1); ``NUMBA_NUM_THREADS=abc`` or ``NUMBA_OPT=abc`` ran
(exit 0) after numba printed a RuntimeWarning holding a Python traceback. Each is now
refused in one line naming the variable, before any work.
"""

from __future__ import annotations

from collections.abc import Callable

import pytest

RunCli = Callable[[list[str]], tuple[int, str, str]]
OneLineError = Callable[..., None]

BUDGET = ["budget", "serial", "--baud", "9600", "--bytes", "4"]


@pytest.mark.parametrize(
    ("name", "value"),
    [
        ("NUMBA_NUM_THREADS", "0"),
        ("NUMBA_NUM_THREADS", "-2"),
        ("NUMBA_NUM_THREADS", "abc"),
        ("NUMBA_NUM_THREADS", ""),
        ("NUMBA_NUM_THREADS", "2.5"),
        ("NUMBA_OPT", "abc"),
        ("NUMBA_OPT", "4"),
    ],
)
def test_a_setting_numba_cannot_use_is_refused(
    run_cli: RunCli,
    assert_one_line_error: OneLineError,
    monkeypatch: pytest.MonkeyPatch,
    name: str,
    value: str,
) -> None:
    monkeypatch.setenv(name, value)
    code, out, err = run_cli(BUDGET)
    assert_one_line_error(code, out, err, f"{name}={value!r}", "correct or unset it")


USABLE = [("NUMBA_NUM_THREADS", "1"), ("NUMBA_NUM_THREADS", " 4 "), ("NUMBA_OPT", "max")]


@pytest.mark.parametrize(("name", "value"), USABLE)
def test_a_usable_setting_is_accepted(
    run_cli: RunCli, monkeypatch: pytest.MonkeyPatch, name: str, value: str
) -> None:
    monkeypatch.setenv(name, value)
    code, _, err = run_cli(BUDGET)
    assert code == 0, err
    assert err == ""
