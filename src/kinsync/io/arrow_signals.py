"""pyarrow's CSV reads without its own SIGINT/SIGTERM cancellation: no signal is lost.

For the length of a ``pyarrow.csv.read_csv`` in the main thread, pyarrow swaps in a C
handler for every stop signal that has a Python handler; the handler passes the signal
through a pipe to a thread of pyarrow's own, and a signal that comes as the read ends
can be lost there, never reaching Python (measured: 2 of 60 SIGTERMs sent to
``kinsync ins run`` as it started, on two loaded cores, were lost; the run went on,
finished and published its output). Without it, Python's own handler sees the signal
as soon as the read returns (a 100 MB numeric table reads in about 0.2 s; point files
are read in blocks). The switch is pyarrow's public ``enable_signal_handlers``, which
has no getter: it is turned off while any kinsync read runs, in any thread, and back
on (pyarrow's default) after the last one.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager

import pyarrow as pa

__all__ = ["signals_left_to_python"]

_LOCK = threading.Lock()
_READS = [0]
"""kinsync reads running now, in every thread."""


@contextmanager
def signals_left_to_python() -> Iterator[None]:
    """Within the block, pyarrow's reads leave SIGINT and SIGTERM to Python's handlers."""
    with _LOCK:
        _READS[0] += 1
        if _READS[0] == 1:
            pa.enable_signal_handlers(enable=False)
    try:
        yield
    finally:
        with _LOCK:
            _READS[0] -= 1
            if _READS[0] == 0:
                pa.enable_signal_handlers(enable=True)
