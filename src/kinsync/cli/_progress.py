"""How long commands show their progress on stderr (`kinsync.progress` reports it).

On a terminal: a bar with the stage, the percentage, the time left and the time spent,
removed when the command ends. Otherwise (a log file, a pipe, a test): one plain line
per stage, ``kinsync: TITLE: STAGE (12.3 s)`` with the time since the command started,
and no escape codes. These lines are held back until the work has run `HOLD_S`
seconds and dropped if it ends before: a quick command stays quiet, and bad input found
as the work starts stays the one error line that every command promises. A timer
thread writes the held lines at the `HOLD_S`-th second even when the work reports nothing
then (a long loop without progress callbacks); every line is written whole, under one
lock, so the timer's lines and the work's never mix. When numba
compiles kernels (a cache miss: the first run after an install or an upgrade), the
display says so once, so that a user knows why the first run is slower.
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

from rich.progress import (
    BarColumn,
    Progress,
    TaskProgressColumn,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)

from kinsync.cli._output import err_console
from kinsync.progress import Progress as ProgressCallback

__all__ = ["COMPILING", "HOLD_S", "progress_display"]

COMPILING = "compiling numba kernels (first run only, cached for the next)"
HOLD_S = 5.0
"""Stage lines are written once the work has run this long (s); none for quicker work."""


def _write_line(line: str) -> None:
    """Write ``line`` and its line end in one call.

    A stop signal that came between the text and the line end (two writes in
    ``print``) left the line open, and the "interrupted" message was glued onto it.
    """
    sys.stderr.write(line + "\n")
    sys.stderr.flush()


class _Display:
    """Turns ``(fraction, stage)`` reports into a bar or into stage lines."""

    def __init__(
        self, title: str, bar: Progress | None, clock: Callable[[], float] = time.perf_counter
    ) -> None:
        self.title = title
        self.bar = bar
        self.task = bar.add_task(title, total=1.0) if bar is not None else None
        self.clock = clock
        self.start = clock()
        self.lock = threading.RLock()  # the work's reports and the timer's release
        self.released = threading.Event()  # set once the held lines are written
        self.stage: str | None = None
        self.fraction = 0.0
        self.said_compiling = False
        self.listener: Any = None
        self.held: list[str] | None = []  # stage lines not written yet; None once released

    def __call__(self, fraction: float, stage: str, /) -> None:
        with self.lock:
            self._report(fraction, stage)

    def _report(self, fraction: float, stage: str, /) -> None:
        self.fraction = max(self.fraction, min(1.0, fraction))  # the bar never goes back
        self._listen_for_compilation()
        if self.bar is not None and self.task is not None:
            self.bar.update(
                self.task, completed=self.fraction, description=f"{self.title}: {stage}"
            )
        elif stage != self.stage:
            self._line(stage)
        self.stage = stage
        self._release_when_due()

    def _release_when_due(self) -> None:
        if self.held is not None and self._seconds() >= HOLD_S:
            self.release()

    def tick(self) -> float:
        """Write the held lines once the work has run `HOLD_S` (the timer calls this).

        Returns the seconds until they are due (<= 0 once written).
        """
        with self.lock:
            self._release_when_due()
            return -1.0 if self.held is None else HOLD_S - self._seconds()

    def _seconds(self) -> float:
        return self.clock() - self.start

    def _line(self, text: str) -> None:
        line = f"kinsync: {self.title}: {text} ({self._seconds():.1f} s)"
        if self.held is None:
            _write_line(line)
        else:
            self.held.append(line)

    def release(self) -> None:
        """Write the stage lines held so far, and the next ones as they come."""
        with self.lock:
            held, self.held = self.held or [], None
            for line in held:
                _write_line(line)
            self.released.set()

    def compiling(self) -> None:
        """Say numba compiles: on the bar until the next report; one line otherwise."""
        with self.lock:
            self._compiling()

    def _compiling(self) -> None:
        if self.bar is not None and self.task is not None:
            self.bar.update(self.task, description=f"{self.title}: {self.stage}, {COMPILING}")
        elif not self.said_compiling:
            self._line(COMPILING)
            self._release_when_due()
        self.said_compiling = True

    def _listen_for_compilation(self) -> None:
        """Once numba is loaded (by the work itself), hear when it compiles."""
        if self.listener is not None or "numba" not in sys.modules:
            return
        from numba.core import event  # noqa: PLC0415 - only once the work has loaded numba

        display = self

        class Listener(event.Listener):
            """numba's compile events (a cache miss; loading from the cache sends none)."""

            def on_start(self, _event: object) -> None:
                display.compiling()

            def on_end(self, _event: object) -> None:
                return None

        self.listener = Listener()
        event.register("numba:compile", self.listener)  # type: ignore[no-untyped-call]

    def close(self) -> None:
        """Stop listening to numba (the lines still held are dropped: the work was quick)."""
        if self.listener is not None:
            from numba.core import event  # noqa: PLC0415

            event.unregister("numba:compile", self.listener)  # type: ignore[no-untyped-call]
            self.listener = None


_TIMER_POLL_S = 0.5
"""Longest wait of the timer between two looks at the clock (s)."""


class _Timer:
    """A daemon thread that writes the held stage lines when they are due.

    The work may report nothing for minutes (one long loop); the lines it reported
    before are then written at the `HOLD_S`-th second all the same. The thread looks
    at the display's clock at least every `_TIMER_POLL_S` and ends once the lines are
    written or the display closes.
    """

    def __init__(self, display: _Display) -> None:
        self.display = display
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._run, name="kinsync-progress", daemon=True)
        self.thread.start()

    def _run(self) -> None:
        while True:
            due_s = self.display.tick()
            if due_s <= 0.0 or self.stop.wait(min(max(due_s, 0.01), _TIMER_POLL_S)):
                return

    def close(self) -> None:
        """Stop the thread (a line it is writing is written whole first)."""
        self.stop.set()
        self.thread.join(timeout=5.0)


@contextmanager
def progress_display(
    title: str, *, clock: Callable[[], float] = time.perf_counter
) -> Iterator[ProgressCallback]:
    """A `kinsync.progress.Progress` shown on stderr for the duration of the block.

    Parameters
    ----------
    title : str
        What runs, as the user typed it (``"ins run"``, ``"georef"``).
    clock : callable, optional
        Seconds of a monotonic clock (tests give a fake one).

    Yields
    ------
    Progress
        The callback to pass to the work.
    """
    if err_console.is_terminal:
        with Progress(
            TextColumn("{task.description}", markup=False),  # a file name is shown as written
            BarColumn(),
            TaskProgressColumn(),
            TimeRemainingColumn(),
            TimeElapsedColumn(),
            console=err_console,
            transient=True,
        ) as bar:
            display = _Display(title, bar, clock)
            try:
                yield display
            finally:
                display.close()
    else:
        display = _Display(title, None, clock)
        timer = _Timer(display)
        try:
            yield display
        finally:
            timer.close()
            display.close()
