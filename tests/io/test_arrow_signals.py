"""kinsync's CSV reads leave SIGINT and SIGTERM to Python's handlers.

pyarrow's ``read_csv`` swaps in a C handler of its own for each stop signal that has a
Python handler; a signal arriving as the read ends could be lost there (the CLI's
SIGTERM test caught a run that finished and published its output). The probe below
reads the process's C-level handler (``sigaction``) from inside the read: pyarrow's
own guard, entered there, must not replace Python's.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import signal
import sys
import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow.csv as pa_csv
import pyarrow.lib as pa_lib
import pytest

from kinsync.io.arrow_signals import signals_left_to_python
from kinsync.io.points import plan_table_slices, read_table_slice
from kinsync.io.tables import read_numeric_csv

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="sigaction layout")


def _c_handler(signum: int) -> int:
    """The address of the C function that handles ``signum`` now (``sa_handler``)."""
    libc = ctypes.CDLL(ctypes.util.find_library("c"), use_errno=True)
    buf = ctypes.create_string_buffer(256)  # struct sigaction, first field sa_handler
    assert libc.sigaction(signum, None, buf) == 0
    return int(ctypes.c_void_p.from_buffer(buf).value or 0)


def _arrow_guard_replaces_python_handler() -> bool:
    """Whether pyarrow's read guard, entered now, swaps out Python's SIGTERM handler."""
    before = _c_handler(signal.SIGTERM)
    with pa_lib.SignalStopHandler():
        during = _c_handler(signal.SIGTERM)
    return during != before


@pytest.fixture
def python_sigterm_handler() -> Iterator[None]:
    old = signal.signal(signal.SIGTERM, lambda *_: None)  # pyarrow guards only these
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, old)


@pytest.fixture
def probe_inside_reads(monkeypatch: pytest.MonkeyPatch) -> list[bool]:
    """Each pyarrow CSV read records whether its guard would replace Python's handler."""
    seen: list[bool] = []
    real: Callable[..., Any] = pa_csv.read_csv

    def read_csv(*args: Any, **kwargs: Any) -> Any:
        seen.append(_arrow_guard_replaces_python_handler())
        return real(*args, **kwargs)

    monkeypatch.setattr(pa_csv, "read_csv", read_csv)
    return seen


@pytest.mark.usefixtures("python_sigterm_handler")
def test_the_probe_sees_pyarrows_guard() -> None:
    assert _arrow_guard_replaces_python_handler()  # pyarrow's default: it can fail


@pytest.mark.usefixtures("python_sigterm_handler")
def test_numeric_tables_are_read_with_pythons_handlers(
    probe_inside_reads: list[bool], tmp_path: Path
) -> None:
    path = tmp_path / "t.csv"
    path.write_text("t_s,x_m\n" + "".join(f"{i},{i * 0.5}\n" for i in range(100)))
    table = read_numeric_csv(path, ["t_s", "x_m"])
    np.testing.assert_allclose(table.columns["x_m"], 0.5 * np.arange(100))
    assert probe_inside_reads == [False]
    assert _arrow_guard_replaces_python_handler()  # pyarrow's default is back


@pytest.mark.usefixtures("python_sigterm_handler")
def test_point_csv_blocks_are_read_with_pythons_handlers(
    probe_inside_reads: list[bool], tmp_path: Path
) -> None:
    path = tmp_path / "p.csv"
    path.write_text("t_s,x_m,y_m,z_m\n" + "".join(f"{i},1,2,3\n" for i in range(50)))
    layout, slices = plan_table_slices(path, 20, ["t_s", "x_m", "y_m", "z_m"])
    rows = sum(len(read_table_slice(layout, sl)["t_s"]) for sl in slices)
    assert rows == 50
    assert len(probe_inside_reads) >= 3  # the schema block and each slice
    assert not any(probe_inside_reads)
    assert _arrow_guard_replaces_python_handler()


@pytest.mark.usefixtures("python_sigterm_handler")
def test_the_guard_stays_off_until_the_last_overlapping_read_in_any_thread_ends() -> None:
    inside, leave = threading.Event(), threading.Event()

    def reader() -> None:
        with signals_left_to_python():
            inside.set()
            leave.wait(10)

    thread = threading.Thread(target=reader)
    thread.start()
    try:
        assert inside.wait(10)
        with signals_left_to_python():
            assert not _arrow_guard_replaces_python_handler()
        assert not _arrow_guard_replaces_python_handler()  # the other read still runs
    finally:
        leave.set()
        thread.join(10)
    assert _arrow_guard_replaces_python_handler()
