"""The ``kinsync`` command-line program (typer).

Commands are thin: parse options, call the library, print. One JSON object on stdout
with ``--json``, a rich table otherwise. Exit status 0 on success, 2 on bad input
(a `KinsyncError` or a usage error, reported in one line on stderr), 1 on any other
failure (set ``KINSYNC_DEBUG=1`` to see its traceback).
"""

from __future__ import annotations

import os
import sys
from collections.abc import Sequence

import typer

from kinsync.cli._options import expand_multi_value_options
from kinsync.cli.app import app
from kinsync.errors import KinsyncError

__all__ = ["app", "main"]


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def main(argv: Sequence[str] | None = None) -> None:
    """Run the program; never returns (exits with the command's status)."""
    args = expand_multi_value_options(sys.argv[1:] if argv is None else argv)
    try:
        result = app(args=args, prog_name="kinsync", standalone_mode=False)
    except KinsyncError as err:
        print(f"kinsync: error: {_one_line(str(err))}", file=sys.stderr)
        sys.exit(2)
    except typer.Abort:
        print("kinsync: aborted", file=sys.stderr)
        sys.exit(1)
    except Exception as err:
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
    sys.exit(result if isinstance(result, int) else 0)
