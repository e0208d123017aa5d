"""Holding SIGINT and SIGTERM back from this thread for a few statements.

A stop signal is delivered once the block ends, so that what the block does happens
whole: a pool started with its workers (`kinsync.pipelines.schedulers`), an output
renamed into place and recorded as published (`kinsync.io.atomic`). Where the platform
has no signal masks (Windows) the block runs as it is.
"""

from __future__ import annotations

import signal
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["stop_signals_held"]


@contextmanager
def stop_signals_held() -> Iterator[None]:
    """Hold SIGINT and SIGTERM back from this thread within the block."""
    if not hasattr(signal, "pthread_sigmask"):
        yield
        return
    stops = {signal.SIGINT, signal.SIGTERM}
    before = signal.pthread_sigmask(signal.SIG_BLOCK, stops)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, before)
