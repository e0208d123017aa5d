"""Writes that run behind the next chunk's work (one background thread, in order)."""

from __future__ import annotations

import contextvars
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from concurrent.futures import wait as futures_wait
from typing import Any

__all__ = ["WriteBehind"]


class WriteBehind:
    """Writes run one at a time, in order, in a background thread.

    While a chunk is compressed and written (lazrs, pyarrow and file writes release
    the GIL), the caller reads and georeferences the next one. `submit` first waits for
    the previous write and raises its error, so at most one write is in flight and a
    failed write stops the run at the next chunk. Call `close` before the writers it
    writes to are closed (it waits for a write in flight, without raising), and `wait`
    after the last chunk (it raises the last write's error).
    """

    def __init__(self) -> None:
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="kinsync-write")
        self._pending: Future[None] | None = None

    def submit(self, write: Callable[..., None], *args: Any) -> None:
        """Run ``write(*args)`` after the previous write, raising that one's error."""
        self.wait()
        # In the caller's context: a message names an output by its option (--out)
        # through a context variable (kinsync.io.atomic.named_outputs).
        context = contextvars.copy_context()
        self._pending = self._pool.submit(context.run, write, *args)

    def wait(self) -> None:
        """Wait for the write in flight, raising its error."""
        pending, self._pending = self._pending, None
        if pending is not None:
            pending.result()

    def close(self) -> None:
        """Wait for the write in flight without raising, and stop the thread."""
        pending, self._pending = self._pending, None
        if pending is not None:
            futures_wait([pending])
        self._pool.shutdown(wait=True)
