"""The ``kinsync`` command-line program (typer).

Commands are thin: parse options, call the library, print. One JSON object on stdout
with ``--json``, a rich table otherwise. Exit status 0 on success, 2 on bad input
(a `KinsyncError` or a usage error, reported in one line on stderr; a closed stdout
too) and on a full disk or disk quota (the output named, its partial file removed),
128 + the signal number when interrupted (130 for Ctrl-C / SIGINT, 143 for SIGTERM:
unfinished outputs are removed on the way out, as on any error, and the outputs
already complete are named), 141 (128 + SIGPIPE), quietly, when stdout's reader goes
away (`kinsync.cli._streams`), 1 on any other failure (set ``KINSYNC_DEBUG=1`` to see
its traceback).
"""

from __future__ import annotations

import os
import signal
import sys
import threading
import warnings
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from types import FrameType
from typing import Any, TextIO

from kinsync._text import first_few
from kinsync.cli._record import (
    WARNING_PREFIX,
    drop_run,
    record_warning,
    start_run,
    write_held_json,
)
from kinsync.cli._streams import (
    OutputPipeClosed,
    check_stdout_open,
    exit_output_pipe_closed,
    output_pipe_closed,
    pipe_closed_in_every_console,
    quiet_closed_stderr,
    use_plain_symbols,
)
from kinsync.errors import DiskFullError, InputError, KinsyncError, KinsyncWarning
from kinsync.io.provenance import set_command

__all__ = ["app", "main"]


def __getattr__(name: str) -> Any:
    """``app``, the typer application, imported when first used (it loads every command)."""
    if name == "app":
        from kinsync.cli.app import app  # noqa: PLC0415

        return app
    msg = f"module 'kinsync.cli' has no attribute {name!r}"
    raise AttributeError(msg)


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


class Interrupted(KeyboardInterrupt):
    """A stop signal (SIGINT or SIGTERM) received while a command runs."""

    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


_RECEIVED: list[int] = []
"""Stop signals received during this run (typer returns 130 for any KeyboardInterrupt)."""


_DEFERRED: set[int] = set()
"""Stop signals received and not raised yet (to be sent again)."""

_UNSAFE_MODULES = ("llvmlite",)
"""Code that a stop signal must not interrupt: an exception raised inside llvmlite's
Python code (between a call into LLVM that takes a module over and the line that
records it) left an object to be disposed of twice, and the unwinding crashed the
process (exit 139, 2 of 170 SIGTERMs sent to ``ins run`` as numba compiled its
kernels). llvmlite's calls are short: numba's own code, which runs for seconds while
it compiles, stays interruptible."""

_STATE = {"active": False, "in_hook": False, "raised": 0, "run": 0, "published": 0}
"""Whether the handlers are installed; whether the unraisable hook is running; the
signal whose `Interrupted` is unwinding the command (0: none); which run; how many
outputs the process had published when the run started."""

TYPER_INTERRUPTED = 130
"""What typer returns (standalone_mode=False) for a KeyboardInterrupt out of a command."""

REDELIVER_AFTER_S = 0.05
"""Delay before a deferred stop signal is sent again (s)."""


def _inside_unsafe_code(frame: FrameType | None) -> bool:
    """Whether the interrupted Python code runs within llvmlite."""
    while frame is not None:
        module = str(frame.f_globals.get("__name__", ""))
        if module.split(".", 1)[0] in _UNSAFE_MODULES:
            return True
        frame = frame.f_back
    return False


def _raise_interrupted(signum: int, frame: FrameType | None) -> None:
    _RECEIVED.append(signum)
    if _STATE["raised"]:  # the command is already unwinding: let its clean-up finish
        return
    if not _STATE["active"]:  # came as the command ended: it has finished
        _DEFERRED.add(signum)
        return
    if _STATE["in_hook"] or _inside_unsafe_code(frame):  # raised when it is safe
        _redeliver_later(signum)
        return
    _DEFERRED.clear()  # a signal held back earlier is this interruption too
    _STATE["raised"] = signum
    raise Interrupted(signum)


_ACTIVE_LOCK = threading.Lock()
"""Held while the handlers are removed, so that no signal is sent again once they are."""


def _redeliver(signum: int, run: int) -> None:
    with _ACTIVE_LOCK:
        live = _STATE["active"] and not _STATE["raised"] and _STATE["run"] == run
        if live and signum in _DEFERRED:
            os.kill(os.getpid(), signum)


def _redeliver_later(signum: int) -> None:
    _DEFERRED.add(signum)
    timer = threading.Timer(REDELIVER_AFTER_S, _redeliver, (signum, _STATE["run"]))
    timer.daemon = True
    timer.start()


def _unraisable_interrupt(previous: Any) -> Any:
    """An `Interrupted` raised inside a callback from C is sent again, not lost.

    A signal handler runs in whatever Python code the main thread executes next; when
    that is a callback from C (a ``__del__``, a weakref callback; numba's compiler
    notifying its cache through llvmlite, now deferred before it gets here) the
    exception cannot propagate: Python prints it as "Exception ignored in ..." and the
    command went on to finish, publish its outputs, then exit 143 saying they were
    removed. The signal is sent again once the callback has returned; any other
    unraisable exception goes to the previous hook.
    """

    def hook(unraisable: Any) -> None:
        _STATE["in_hook"] = True  # a signal that comes now is held back, not raised here
        try:
            err = unraisable.exc_value
            if isinstance(err, Interrupted):
                _STATE["raised"] = 0  # it did not unwind anything
                _redeliver_later(err.signum)
            else:
                previous(unraisable)
        finally:
            _STATE["in_hook"] = False

    return hook


@contextmanager
def _stop_signals_unwind() -> Iterator[None]:
    """SIGINT and SIGTERM raise `Interrupted`: every ``finally`` runs (temporaries go)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    stops = (signal.SIGINT, signal.SIGTERM)
    _RECEIVED.clear()
    _DEFERRED.clear()
    _STATE["active"] = True
    _STATE["raised"] = 0
    _STATE["run"] += 1
    _STATE["published"] = _published_mark()
    hook_before = sys.unraisablehook
    before: dict[signal.Signals, Any] = {}
    try:
        sys.unraisablehook = _unraisable_interrupt(hook_before)
        for s in stops:
            before[s] = signal.signal(s, _raise_interrupted)
        yield
    finally:
        # First, so that a handler running while the lock is awaited raises nothing;
        # the lock then waits for a signal being sent again right now.
        _STATE["active"] = False
        with _ACTIVE_LOCK:
            pass
        sys.unraisablehook = hook_before
        for s, handler in before.items():
            signal.signal(s, handler)


def _signal_of(err: BaseException) -> int | None:
    """The stop signal behind ``err``, if any (typer turns KeyboardInterrupt into Exit(130))."""
    seen: BaseException | None = err
    while seen is not None:
        if isinstance(seen, Interrupted):
            return seen.signum
        if isinstance(seen, KeyboardInterrupt):
            return int(signal.SIGINT)
        seen = seen.__cause__ or seen.__context__
    return None


def _exit_interrupted(signum: int) -> None:
    name = signal.Signals(signum).name
    done = _published_in_this_run()
    kept = f"; written before it: {first_few(done)}" if done else ""
    print(f"kinsync: interrupted by {name}{kept}; unfinished outputs removed", file=sys.stderr)
    sys.exit(128 + signum)


def _published_mark() -> int:
    atomic = sys.modules.get("kinsync.io.atomic")  # not imported for it: start-up stays light
    return int(atomic.published_count()) if atomic is not None else 0


def _written_before(err: BaseException) -> str:
    """After a full disk, the outputs this run completed before it, as an interruption says.

    Written one after another, the earlier ones are complete and have replaced any
    earlier file: the user learns which.
    """
    if not isinstance(err, DiskFullError):
        return ""
    done = _published_in_this_run()
    return f"; written before it: {first_few(done)}" if done else ""


def _published_in_this_run() -> list[str]:
    """The outputs this run published (complete) before it was interrupted."""
    atomic = sys.modules.get("kinsync.io.atomic")
    if atomic is None:
        return []
    return [str(path) for path in atomic.published_since(_STATE["published"])]


@contextmanager
def _warnings_on_one_line() -> Iterator[None]:
    """A `KinsyncWarning` is printed once, ``kinsync: warning: ...``, on stderr.

    The warnings are held until the command ends and printed only when it succeeds: a
    command that fails prints its one error line and nothing else. Each is recorded for
    the command's ``--json`` document (`kinsync.cli._record`).
    """
    held: list[str] = []
    with warnings.catch_warnings():
        warnings.simplefilter("default", KinsyncWarning)  # once per message and place
        show = warnings.showwarning

        def one_line(
            message: Warning | str,
            category: type[Warning],
            filename: str,
            lineno: int,
            file: TextIO | None = None,
            line: str | None = None,
        ) -> Any:
            if issubclass(category, KinsyncWarning):
                held.append(_one_line(str(message)))
                return None
            return show(message, category, filename, lineno, file, line)

        warnings.showwarning = one_line
        yield
    for text in held:
        record_warning(text)
        print(WARNING_PREFIX + text, file=sys.stderr)


def _check_arguments_are_text(args: Sequence[str]) -> None:
    """Refuse an argument that is not UTF-8 text (a file name in another encoding).

    Python hands such bytes over as lone surrogates, which pyarrow, the terminal and the
    JSON output cannot encode: refused here in one line rather than failing deep inside
    a reader or a writer.
    """
    for arg in args:
        try:
            arg.encode("utf-8")
        except UnicodeEncodeError as err:
            raw = os.fsencode(arg)
            shown = raw.decode("utf-8", "backslashreplace")
            bad = arg[err.start].encode("utf-8", "surrogateescape")
            msg = (
                f"{shown}: not UTF-8 text (byte 0x{bad[0]:02X}); kinsync reads file names and "
                "arguments as UTF-8: rename the file (e.g. convmv -f latin1 -t utf8 NAME)"
            )
            raise InputError(msg) from None


def _full_disk(err: BaseException) -> str | None:
    """The one-line message for a full disk or quota met outside an output's writing.

    An output written through `kinsync.io.atomic.atomic_path` is named by its own
    message (an `InputError`); this covers any other file (a temporary one, a cache).
    """
    atomic = sys.modules.get("kinsync.io.atomic")
    if atomic is None:
        return None
    full = atomic.full_disk_cause(err)
    if full is None:
        return None
    where = full.filename if full.filename is not None else "the output"
    error = atomic.disk_full_error(str(where), full)
    return f"{error}{_written_before(error)}"


def _threads(value: str) -> bool:
    try:
        return int(value) >= 1
    except ValueError:
        return False


_NUMBA_SETTINGS = {
    "NUMBA_NUM_THREADS": (
        _threads,
        "a whole number of threads, 1 or more (e.g. NUMBA_NUM_THREADS=4)",
    ),
    "NUMBA_OPT": (
        lambda v: v in {"0", "1", "2", "3", "max"},
        "an optimisation level: 0, 1, 2, 3 or max",
    ),
}
"""numba's settings from the environment that kinsync's kernels depend on, each with its
test and what it must be. numba reads them when it is imported: a value it cannot use
ended in an internal error (``NUMBA_NUM_THREADS=0``: "Number of threads specified must
be > 0") or in a Python traceback numba prints as a warning (``NUMBA_NUM_THREADS=abc``,
``NUMBA_OPT=abc``), the run going on with its default."""


def _check_numba_environment() -> None:
    """Refuse a numba setting in the environment that numba cannot use, naming it."""
    for name, (valid, what) in _NUMBA_SETTINGS.items():
        value = os.environ.get(name)
        if value is not None and not valid(value):
            msg = f"{name}={value!r} in the environment: it must be {what}; correct or unset it"
            raise InputError(msg)


def _prepare_output() -> None:
    """Refuse a closed stdout; spell symbols plain for another encoding; start the run.

    A closed stderr is pointed at /dev/null before anything is said there (it went to
    stdout). A numba setting in the environment that numba cannot use is refused next.
    """
    quiet_closed_stderr()
    _check_numba_environment()
    check_stdout_open()
    use_plain_symbols()  # a Latin-1 or cp1252 terminal shows "sigma" for σ
    start_run()


def _run_command(argv: Sequence[str]) -> Any:
    """Load the commands and run the one ``argv`` names; return its status.

    A pipe closed under click's own output ends quietly too: click ends such a run with
    status 1, nothing said, after it replaced stdout by its ``PacifyFlushWrapper``: the
    status of a kinsync fault. The commands' own writes reach the entry point as
    `OutputPipeClosed` (`_guard`).
    """
    import typer.main  # noqa: PLC0415

    from kinsync.cli._options import (  # noqa: PLC0415
        expand_multi_value_options,
        refuse_repeated_options,
    )
    from kinsync.cli.app import app  # noqa: PLC0415

    pipe_closed_in_every_console()  # typer's help console too (| head -1: 141, not 1)
    args = expand_multi_value_options(argv)
    _check_arguments_are_text(args)
    # The click command built once: it checks the options before running them.
    command = typer.main.get_command(app)
    refuse_repeated_options(command, args)
    try:
        return command(args=args, prog_name="kinsync", standalone_mode=False)
    except SystemExit:
        if type(sys.stdout).__name__ == "PacifyFlushWrapper":
            exit_output_pipe_closed()
        raise


def main(argv: Sequence[str] | None = None) -> None:
    """Run the program; never returns (exits with the command's status)."""
    try:
        # Ctrl-C is handled from here on, the heavy imports included (numpy, every
        # command module): an interruption during them exits 130 in one line.
        with _stop_signals_unwind(), _warnings_on_one_line():
            _prepare_output()
            args = list(sys.argv[1:] if argv is None else argv)
            set_command(args)  # for the provenance of what it writes
            result = _run_command(args)
        write_held_json()  # the --json document, with the warnings just printed
        sys.stdout.flush()  # a closed pipe is met here, not at exit
    except KeyboardInterrupt as err:
        drop_run()
        _exit_interrupted(_signal_of(err) or int(signal.SIGINT))
    except Exception as err:
        drop_run()
        if isinstance(err, OutputPipeClosed) or (
            isinstance(err, BrokenPipeError) and output_pipe_closed()
        ):
            exit_output_pipe_closed()  # | head -1: quietly, 141
        # A failure once a stop signal has come is its consequence (numba's compiler,
        # cut short inside a callback, fails later with "no compiled object yet").
        signum = _signal_of(err) or (_RECEIVED[0] if _RECEIVED else None)
        if signum is not None:
            _exit_interrupted(signum)
        if isinstance(err, KinsyncError):
            print(f"kinsync: error: {_one_line(str(err))}{_written_before(err)}", file=sys.stderr)
            sys.exit(2)
        code = getattr(err, "exit_code", None)
        fmt = getattr(err, "format_message", None)
        if isinstance(code, int) and fmt is None:  # Exit raised by a command or --version
            sys.exit(code)
        if isinstance(code, int) and callable(fmt):  # usage error: bad option or value
            message = _one_line(str(fmt()))
            if message:  # empty when help was shown for a bare group
                print(f"kinsync: error: {message} (see --help)", file=sys.stderr)
            sys.exit(code)
        full = _full_disk(err)
        if full is not None:
            print(f"kinsync: error: {full}", file=sys.stderr)
            sys.exit(2)
        if os.environ.get("KINSYNC_DEBUG"):
            raise
        print(
            f"kinsync: internal error: {type(err).__name__}: {_one_line(str(err))} "
            "(set KINSYNC_DEBUG=1 for a traceback)",
            file=sys.stderr,
        )
        sys.exit(1)
    # The command returned: a signal held back and not sent again yet, or one raised
    # and then swallowed by the code it interrupted, came as it finished. (typer turns
    # an interruption that went through the command into a return value of 130.)
    raised = int(_STATE["raised"])
    late = sorted(_DEFERRED) or ([raised] if raised and result != TYPER_INTERRUPTED else [])
    if late:
        name = signal.Signals(late[0]).name
        done = f"kinsync: {name} arrived as the command finished; its outputs are complete"
        print(done, file=sys.stderr)
        sys.exit(128 + late[0])
    if _RECEIVED:  # typer turned the interruption into a return value of 130
        _exit_interrupted(raised or _RECEIVED[0])
    sys.exit(result if isinstance(result, int) else 0)
