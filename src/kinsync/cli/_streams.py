"""Standard output and error as a script finds them: another encoding, a closed pipe.

Loaded by the entry point before any command, so it imports nothing heavy.

- A terminal or log in an encoding without kinsync's symbols (ISO-8859-1, cp1252,
  ASCII): `use_plain_symbols` makes stdout and stderr write plain-ASCII equivalents
  (``σ`` as ``sigma``, ``χ²`` as ``chi2``, ``?`` for any other character) instead of
  failing on the first table.
- A closed stdout (``>&-``): `check_stdout_open` refuses the run before any work; a
  closed stderr (``2>&-``) is pointed at /dev/null (`quiet_closed_stderr`).
- A pipe closed by its reader (``| head -1``): `OutputPipeClosed` and
  `exit_output_pipe_closed` end the run quietly with 141, as a program killed by
  SIGPIPE does; `pipe_closed_in_every_console` makes the consoles typer builds for
  ``--help`` raise it too (rich's own ends the run with status 1, a kinsync fault).
"""

from __future__ import annotations

import codecs
import os
import select
import signal
import sys
from pathlib import Path
from typing import NoReturn, TextIO

from kinsync.errors import InputError

__all__ = [
    "PIPE_CLOSED_STATUS",
    "PLAIN_SYMBOLS",
    "OutputPipeClosed",
    "check_stdout_open",
    "exit_output_pipe_closed",
    "output_pipe_closed",
    "pipe_closed_in_every_console",
    "plain_symbols",
    "quiet_closed_stderr",
    "use_plain_symbols",
]

PLAIN_SYMBOLS: dict[str, str] = {
    "σ": "sigma",
    "χ": "chi",
    "Δ": "Delta",
    "δ": "delta",
    "φ": "phi",
    "ω": "omega",
    "π": "pi",
    "θ": "theta",
    "λ": "lambda",
    "ψ": "psi",
    "τ": "tau",
    "¹": "1",
    "²": "2",
    "³": "3",
    "µ": "u",  # micro sign
    "μ": "u",  # Greek mu
    "°": "deg",
    "±": "+-",
    "−": "-",
    "–": "-",
    "—": "-",
    "…": "...",
    "×": "x",
    "·": ".",
    "≤": "<=",
    "≥": ">=",
    "≈": "~",
    "←": "<-",
    "→": "->",
    "‖": "||",
    "√": "sqrt",
}
"""Plain-ASCII spelling of the symbols kinsync prints, for a stream that cannot encode
them; any other character it cannot encode is written as ``?``."""

ERROR_HANDLER = "kinsync-plain"
"""Name of the codec error handler (`codecs.register_error`) that writes them."""

PIPE_CLOSED_STATUS = 128 + int(getattr(signal, "SIGPIPE", 13))
"""Exit status when stdout's reader has gone (141, what ``yes | head -1`` gives
``yes`` under ``set -o pipefail``)."""

_PROBE = "".join(PLAIN_SYMBOLS)


def _plain(err: UnicodeError) -> tuple[str, int]:
    """Codec error handler: the plain spelling of the characters a stream cannot encode."""
    if not isinstance(err, UnicodeEncodeError):
        raise err
    text = err.object[err.start : err.end]
    return "".join(PLAIN_SYMBOLS.get(c, "?") for c in text), err.end


codecs.register_error(ERROR_HANDLER, _plain)


def plain_symbols(text: str, encoding: str) -> str:
    """``text`` with the characters ``encoding`` cannot write spelled plain (`PLAIN_SYMBOLS`).

    Parameters
    ----------
    text
        What is to be written.
    encoding
        The stream's encoding (an unknown one leaves ``text`` as it is).

    Returns
    -------
    str
        ``text``, or its plain spelling.
    """
    try:
        text.encode(encoding)
    except UnicodeEncodeError:
        return text.encode(encoding, ERROR_HANDLER).decode(encoding)
    except LookupError:
        return text
    return text


def _encodes_symbols(stream: TextIO) -> bool:
    encoding = getattr(stream, "encoding", None) or "utf-8"
    try:
        _PROBE.encode(encoding)
    except UnicodeEncodeError:
        return False
    except LookupError:  # an encoding Python does not know: leave the stream as it is
        return True
    return True


def use_plain_symbols() -> None:
    """Make stdout and stderr write plain ASCII for the symbols their encoding lacks.

    Only a stream whose encoding cannot write kinsync's symbols is changed (its error
    handler; its encoding stays), so a UTF-8 terminal sees ``σ`` and a Latin-1 one
    ``sigma``. rich's consoles write through these streams, so their tables follow.
    """
    for stream in (sys.stdout, sys.stderr):
        reconfigure = getattr(stream, "reconfigure", None)
        if stream is None or reconfigure is None or _encodes_symbols(stream):
            continue
        try:
            reconfigure(errors=ERROR_HANDLER)
        except (OSError, ValueError):  # not reconfigurable now: leave it
            continue


def quiet_closed_stderr() -> None:
    """Point a closed stderr (``2>&-``) at /dev/null.

    Python then sets ``sys.stderr`` to None, and ``print(..., file=sys.stderr)`` writes to
    stdout: the error line and the warnings went into the result (a ``--json`` document
    a script reads). With no stderr they are dropped; the exit status still tells.
    """
    if sys.stderr is None:
        sys.stderr = Path(os.devnull).open("w", encoding="utf-8")  # noqa: SIM115 - the run's


def check_stdout_open() -> None:
    """Refuse to run with stdout closed (``>&-``): the result would be lost.

    Raises
    ------
    InputError
        When there is no standard output (Python sets ``sys.stdout`` to None).
    """
    if sys.stdout is None:
        msg = (
            "standard output is closed: kinsync writes its result there; redirect it to a "
            "file or to /dev/null instead of closing it (>&-)"
        )
        raise InputError(msg)


class OutputPipeClosed(Exception):  # noqa: N818 (an event, not a fault)
    """stdout's (or stderr's) reader went away while a command wrote (``| head -1``)."""


def _reader_gone(stream: TextIO | None) -> bool:
    """Whether ``stream`` is a pipe or socket whose reader has gone (poll says POLLERR)."""
    try:
        fd = stream.fileno() if stream is not None else -1
    except (OSError, ValueError, AttributeError):  # no file descriptor (a test's capture)
        return False
    if fd < 0:
        return False
    if not hasattr(select, "poll"):  # no poll (Windows): trust the error, as click does
        return True
    poller = select.poll()
    poller.register(fd, select.POLLOUT)
    return any(event & (select.POLLERR | select.POLLHUP) for _, event in poller.poll(0))


def output_pipe_closed() -> bool:
    """Whether a `BrokenPipeError` just met came from stdout or stderr (their reader left).

    A broken pipe elsewhere (a worker process that died) is a fault, not the end of the
    output: it must not end the run quietly.
    """
    return _reader_gone(sys.stdout) or _reader_gone(sys.stderr)


def _raise_pipe_closed(console: object) -> None:
    setattr(console, "quiet", True)  # noqa: B010 - any rich Console
    msg = "the output pipe was closed by its reader"
    raise OutputPipeClosed(msg)


def pipe_closed_in_every_console() -> None:
    """Make every rich console raise `OutputPipeClosed` when its reader goes away.

    rich's ``Console.on_broken_pipe`` (which its docs say to override) points stdout at
    /dev/null and raises ``SystemExit(1)``: ``kinsync --help | head -1`` ended with
    status 1, the status of a kinsync fault, from the console typer builds for the
    help. Set on the class, for that console is typer's own; rich is loaded here only
    by the commands, so this is called once they are.
    """
    from rich.console import Console  # noqa: PLC0415 - loaded with the commands

    Console.on_broken_pipe = _raise_pipe_closed  # type: ignore[method-assign, assignment]


def exit_output_pipe_closed() -> NoReturn:
    """End the run quietly with `PIPE_CLOSED_STATUS` after a write to a closed pipe.

    stdout is pointed at /dev/null first, so that Python's flush at exit does not fail
    again and print "Exception ignored ... BrokenPipeError".
    """
    for stream in (sys.stdout, sys.stderr):
        try:
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, stream.fileno())
            os.close(devnull)
        except (OSError, ValueError, AttributeError):  # no file descriptor (a test's capture)
            continue
    sys.exit(PIPE_CLOSED_STATUS)
