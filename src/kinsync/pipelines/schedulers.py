"""Where georeferencing chunks run: this process, a local process pool or a Dask cluster.

A runner takes `ChunkTask` s and returns, for each, a callable that gives its
`ChunkOutput`; `in_order` keeps at most ``runner.window`` chunks in flight and yields
them in input order, so that every scheduler writes the same output as the serial
run and reports the same first error. Workers read their own chunks (the context,
with the prepared trajectory, is shipped once per worker: a pool worker reads it from a
temporary file, a Dask worker gets it broadcast).
"""

from __future__ import annotations

import errno
import importlib
import multiprocessing
import os
import pickle
import signal
import tempfile
import threading
import time
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Future, ProcessPoolExecutor, ThreadPoolExecutor
from pathlib import Path
from typing import Any

from kinsync._cpus import usable_cpus
from kinsync._signals import stop_signals_held
from kinsync.errors import InputError
from kinsync.io.las import LasPointReader
from kinsync.pipelines.georef_chunks import ChunkContext, ChunkOutput, ChunkTask, process_chunk

__all__ = [
    "DASK_CONNECT_TIMEOUT_S",
    "ChunkResult",
    "DaskRunner",
    "ProcessRunner",
    "SerialRunner",
    "in_order",
    "make_runner",
]

DASK_CONNECT_TIMEOUT_S = 10.0
"""How long to wait for a Dask scheduler before giving up (s)."""
_CHUNKS_IN_FLIGHT_PER_WORKER = 2

# A pool worker's context and open LAS reader, kept between its chunks.
_WORKER_CONTEXT: list[ChunkContext] = []
_WORKER_LAS_READER: list[LasPointReader] = []


_PARENT_POLL_S = 0.25


def _process_gone(pid: int) -> bool:
    """Whether process ``pid`` has ended (a zombie, not yet reaped, has ended)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    except PermissionError:
        return False
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:  # no /proc (macOS): os.kill is the answer
        return False
    return stat[stat.rindex(")") + 2 :][:1] in {"Z", "X"}


def _die_with(main_pid: int, context_path: Path) -> None:
    """End this worker as soon as the main process ``main_pid`` has ended.

    A killed main process (SIGKILL cannot be caught) must not leave workers computing
    for minutes, nor the forkserver and resource tracker that live as long as a worker
    holds their pipes, nor the pool's context file: a daemon thread checks every 0.25 s
    and removes the file before it ends the worker. Workers ignore SIGINT: a Ctrl-C
    reaches the whole process group, and the main process stops the pool.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)

    def watch() -> None:
        while not _process_gone(main_pid):
            time.sleep(_PARENT_POLL_S)
        context_path.unlink(missing_ok=True)
        os._exit(1)

    threading.Thread(target=watch, name="kinsync-main-watch", daemon=True).start()


def init_process_worker(context_path: str, main_pid: int) -> None:
    """Process-pool initializer: die with the main process; keep the context for every chunk.

    The context (with the prepared trajectory, megabytes) is read from the file the
    main process wrote once (`ProcessRunner`), not passed as an argument: the main
    process writes a new worker's arguments into a pipe and waits until the worker has
    read them all, after its imports, so megabytes of arguments made the main process
    wait about a second for each worker it started, one after another.
    """
    path = Path(context_path)
    _die_with(main_pid, path)
    with path.open("rb") as fh:
        ctx = pickle.load(fh)  # noqa: S301 - written by this run's main process
    _WORKER_CONTEXT[:] = [ctx]
    _WORKER_LAS_READER.clear()


def process_chunk_in_worker(task: ChunkTask, tally_only: bool) -> ChunkOutput:
    """A pool worker's task; a LAS/LAZ input stays open in the worker between chunks.

    LAZ is decompressed in the worker's own thread: the pool is the parallelism.
    """
    ctx = _WORKER_CONTEXT[0]
    if ctx.source.table is None and not _WORKER_LAS_READER:
        _WORKER_LAS_READER.append(LasPointReader(ctx.source.path, laz_threads=False))
    reader = _WORKER_LAS_READER[0] if _WORKER_LAS_READER else None
    return process_chunk(ctx, task, tally_only, reader)


ChunkResult = Callable[[], ChunkOutput]


class SerialRunner:
    """In this process: each chunk is read and computed when its result is asked for.

    A LAS/LAZ input stays open between chunks (read in order, without seeking) and is
    decompressed with lazrs's thread pool; each chunk's blocks are georeferenced and
    transformed by a thread pool of one thread per usable CPU (the kernel and PROJ
    release the interpreter lock), so the run uses every core without starting worker
    processes.
    """

    window = 1

    def __init__(self, ctx: ChunkContext, threads: int | None = None) -> None:
        self.ctx = ctx
        self._las_reader: LasPointReader | None = None
        self._threads = threads or usable_cpus()
        self._block_pool: ThreadPoolExecutor | None = None

    def _reader(self) -> LasPointReader | None:
        if self.ctx.source.table is None and self._las_reader is None:
            self._las_reader = LasPointReader(self.ctx.source.path)
        return self._las_reader

    def _blocks(self) -> ThreadPoolExecutor | None:
        if self._block_pool is None and self._threads > 1:
            self._block_pool = ThreadPoolExecutor(self._threads, thread_name_prefix="kinsync-block")
        return self._block_pool

    def submit(self, task: ChunkTask, tally_only: bool) -> ChunkResult:
        """Start ``task`` (only counting points outside the span if ``tally_only``)."""
        return lambda: process_chunk(self.ctx, task, tally_only, self._reader(), self._blocks())

    def close(self) -> None:
        """Close the input file, if open, and stop the block threads."""
        if self._las_reader is not None:
            self._las_reader.close()
            self._las_reader = None
        if self._block_pool is not None:
            self._block_pool.shutdown(wait=True, cancel_futures=True)
            self._block_pool = None


class ProcessRunner(SerialRunner):
    """A local process pool; each worker loads the context once (initializer).

    The context is pickled once into a temporary file (``kinsync-context-PID-*`` in
    the system's temporary folder), which `close` removes; after a SIGKILL of this
    process the workers remove it as they end.
    """

    def __init__(self, ctx: ChunkContext, workers: int) -> None:
        super().__init__(ctx)
        mp_context = multiprocessing.get_context(_start_method())
        self.window = _CHUNKS_IN_FLIGHT_PER_WORKER * workers
        self.context_path = _write_context(ctx)
        try:
            self.pool = ProcessPoolExecutor(
                max_workers=workers,
                mp_context=mp_context,
                initializer=init_process_worker,
                initargs=(str(self.context_path), os.getpid()),
            )
        except BaseException:
            self.context_path.unlink(missing_ok=True)
            raise

    def submit(self, task: ChunkTask, tally_only: bool) -> ChunkResult:
        """Send ``task`` to the pool; the callable waits for its result.

        The pool may start a worker here, writing it the context through a pipe: stop
        signals are held meanwhile (delivered right after), so that an interruption
        never leaves a worker reading a truncated context (and printing a traceback).
        """
        with stop_signals_held():
            future: Future[ChunkOutput] = self.pool.submit(
                process_chunk_in_worker, task, tally_only
            )
        return future.result

    def close(self) -> None:
        """Stop the pool (chunks not yet started are cancelled); remove the context file."""
        try:
            self.pool.shutdown(wait=True, cancel_futures=True)
        finally:
            self.context_path.unlink(missing_ok=True)


def _start_method() -> str:
    """How pool workers start: from a fork server where it can run, else spawned.

    The fork server listens on a Unix socket in the temporary folder, and a socket path
    is limited to about 107 bytes: under a deep TMPDIR it cannot start ("AF_UNIX path
    too long"), so it is started here and, if it fails, workers are spawned instead
    (each imports its modules itself: slower to start, the same results).
    """
    if "forkserver" not in multiprocessing.get_all_start_methods():
        return "spawn"
    from multiprocessing import forkserver  # noqa: PLC0415 - not on Windows

    try:
        forkserver.ensure_running()
    except OSError:
        return "spawn"
    return "forkserver"


def _write_context(ctx: ChunkContext) -> Path:
    """Pickle ``ctx`` into a new temporary file (readable by this user only)."""
    try:
        fd, name = tempfile.mkstemp(prefix=f"kinsync-context-{os.getpid()}-", suffix=".pickle")
    except OSError as err:  # no writable temporary folder (a read-only root file system)
        why = "no writable one found" if err.errno == errno.ENOENT else err.strerror or err
        msg = (
            f"--scheduler processes needs a temporary folder for its workers ({why}); "
            "set TMPDIR to a writable folder, or use --scheduler local"
        )
        raise InputError(msg) from None
    path = Path(name)
    try:
        with os.fdopen(fd, "wb") as fh:
            pickle.dump(ctx, fh, protocol=pickle.HIGHEST_PROTOCOL)
    except OSError as err:
        path.unlink(missing_ok=True)
        msg = (
            f"cannot write the process pool's context to {path} ({err.strerror or err}); "
            "free space in the temporary folder (or set TMPDIR), or use --scheduler local"
        )
        raise InputError(msg) from err
    except BaseException:
        path.unlink(missing_ok=True)
        raise
    return path


class DaskRunner(SerialRunner):
    """An existing dask.distributed scheduler; the context is broadcast once."""

    def __init__(self, ctx: ChunkContext, address: str, workers: int | None) -> None:
        super().__init__(ctx)
        try:
            distributed: Any = importlib.import_module("dask.distributed")  # optional extra
        except ImportError as err:
            msg = (
                f"--scheduler {address} needs dask.distributed, which is not installed; "
                "install kinsync[scale] (pip install 'kinsync[scale]') or use "
                "--scheduler local|processes"
            )
            raise InputError(msg) from err
        try:
            self.client: Any = distributed.Client(address, timeout=DASK_CONNECT_TIMEOUT_S)
        except (OSError, TimeoutError, ValueError) as err:
            reason = str(err).splitlines()[0] if str(err) else type(err).__name__
            msg = (
                f"cannot reach the Dask scheduler at {address} ({reason}); start one with "
                "'dask scheduler' and workers with 'dask worker ADDRESS', or use "
                "--scheduler local|processes"
            )
            raise InputError(msg) from err
        n_workers = workers or max(1, len(self.client.scheduler_info().get("workers", {})))
        self.window = _CHUNKS_IN_FLIGHT_PER_WORKER * n_workers
        self.ctx_future = self.client.scatter(ctx, broadcast=True)

    def submit(self, task: ChunkTask, tally_only: bool) -> ChunkResult:
        """Send ``task`` to the cluster; the callable waits for its result."""
        future = self.client.submit(process_chunk, self.ctx_future, task, tally_only, pure=False)

        def result() -> ChunkOutput:
            out: ChunkOutput = future.result()
            return out

        return result

    def close(self) -> None:
        """Disconnect from the scheduler (the cluster keeps running)."""
        self.client.close()


def make_runner(ctx: ChunkContext, scheduler: str, workers: int | None) -> SerialRunner:
    """The runner for ``--scheduler`` (local, processes or tcp://...) and ``--workers``."""
    if workers is not None and workers < 1:
        msg = f"--workers must be >= 1, got {workers}"
        raise InputError(msg)
    if scheduler == "local":
        return SerialRunner(ctx)
    if scheduler == "processes":
        return ProcessRunner(ctx, workers or usable_cpus())
    if scheduler.startswith(("tcp://", "tls://")):
        return DaskRunner(ctx, scheduler, workers)
    msg = f"--scheduler must be local, processes or tcp://HOST:PORT, got {scheduler!r}"
    raise InputError(msg)


def in_order(
    tasks: Sequence[ChunkTask], runner: SerialRunner, tally_only: Callable[[], bool]
) -> Iterator[ChunkResult]:
    """Submit chunks ahead (at most ``runner.window`` in flight); yield them in input order.

    Each chunk's error is raised (by its result) only when its place in the input is
    reached, so that every run reports the same first error as the serial one.
    """
    pending: deque[ChunkResult] = deque()
    upcoming = iter(tasks)
    more = True
    while True:
        while more and len(pending) < runner.window:
            task = next(upcoming, None)
            if task is None:
                more = False
            else:
                pending.append(runner.submit(task, tally_only()))
        if not pending:
            return
        yield pending.popleft()
