"""The ``kinsync`` command-line program (typer).

Commands are thin: parse options, call the library, print. One JSON object on stdout
with ``--json``, a rich table otherwise. Exit status 0 on success, 2 on bad input
(a `KinsyncError` or a usage error, reported in one line on stderr), 128 + the signal
number when interrupted (130 for Ctrl-C / SIGINT, 143 for SIGTERM: unfinished outputs
are removed on the way out, as on any error), 1 on any other failure (set
``KINSYNC_DEBUG=1`` to see its traceback).
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

from kinsync.errors import InputError, KinsyncError, KinsyncWarning

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


def _raise_interrupted(signum: int, _frame: FrameType | None) -> None:
    _RECEIVED.append(signum)
    raise Interrupted(signum)


@contextmanager
def _stop_signals_unwind() -> Iterator[None]:
    """SIGINT and SIGTERM raise `Interrupted`: every ``finally`` runs (temporaries go)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    stops = (signal.SIGINT, signal.SIGTERM)
    _RECEIVED.clear()
    before = {s: signal.signal(s, _raise_interrupted) for s in stops}
    try:
        yield
    finally:
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
    print(f"kinsync: interrupted by {name}; unfinished outputs removed", file=sys.stderr)
    sys.exit(128 + signum)


@contextmanager
def _warnings_on_one_line() -> Iterator[None]:
    """A `KinsyncWarning` is printed once, ``kinsync: warning: ...``, on stderr.

    The warnings are held until the command ends and printed only when it succeeds: a
    command that fails prints its one error line and nothing else.
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
                held.append(f"kinsync: warning: {_one_line(str(message))}")
                return None
            return show(message, category, filename, lineno, file, line)

        warnings.showwarning = one_line
        yield
    for text in held:
        print(text, file=sys.stderr)


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


def main(argv: Sequence[str] | None = None) -> None:
    """Run the program; never returns (exits with the command's status)."""
    try:
        # Ctrl-C is handled from here on, the heavy imports included (numpy, every
        # command module): an interruption during them exits 130 in one line.
        with _stop_signals_unwind(), _warnings_on_one_line():
            import typer.main  # noqa: PLC0415

            from kinsync.cli._options import (  # noqa: PLC0415
                expand_multi_value_options,
                refuse_repeated_options,
            )
            from kinsync.cli.app import app  # noqa: PLC0415

            args = expand_multi_value_options(sys.argv[1:] if argv is None else argv)
            _check_arguments_are_text(args)
            # The click command built once: it checks the options before running them.
            command = typer.main.get_command(app)
            refuse_repeated_options(command, args)
            result = command(args=args, prog_name="kinsync", standalone_mode=False)
    except KinsyncError as err:
        print(f"kinsync: error: {_one_line(str(err))}", file=sys.stderr)
        sys.exit(2)
    except KeyboardInterrupt as err:
        _exit_interrupted(_signal_of(err) or int(signal.SIGINT))
    except Exception as err:
        signum = _signal_of(err)
        if signum is not None:
            _exit_interrupted(signum)
        code = getattr(err, "exit_code", None)
        fmt = getattr(err, "format_message", None)
        if isinstance(code, int) and fmt is None:  # Exit raised by a command or --version
            sys.exit(code)
        if isinstance(code, int) and callable(fmt):  # usage error: bad option or value
            message = _one_line(str(fmt()))
            if message:  # empty when help was shown for a bare group
                print(f"kinsync: error: {message} (see --help)", file=sys.stderr)
            sys.exit(code)
        if os.environ.get("KINSYNC_DEBUG"):
            raise
        print(
            f"kinsync: internal error: {type(err).__name__}: {_one_line(str(err))} "
            "(set KINSYNC_DEBUG=1 for a traceback)",
            file=sys.stderr,
        )
        sys.exit(1)
    if _RECEIVED:  # typer turned the interruption into a return value of 130
        _exit_interrupted(_RECEIVED[0])
    sys.exit(result if isinstance(result, int) else 0)
