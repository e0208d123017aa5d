"""What a command prints for a script: its warnings, and its JSON document once it ends.

Every ``kinsync: warning: ...`` line a run prints on stderr is recorded here (`warn`
for the commands' own, `record_warning` for the `KinsyncWarning`s the entry point
prints), and a command's ``--json`` document (`hold_json`) is written when the command
has ended (`write_held_json`), with every warning printed added under ``"warnings"``:
a script tells a clean run from a warned one from the JSON alone. Loaded by the entry
point before any command, so it imports nothing heavy.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Mapping
from typing import Any

from kinsync.io.provenance import run_record

__all__ = [
    "WARNING_PREFIX",
    "drop_run",
    "hold_json",
    "one_line",
    "record_warning",
    "start_run",
    "warn",
    "write_held_json",
]

WARNING_PREFIX = "kinsync: warning: "

_WARNINGS: list[str] = []
"""The warnings printed during this run, in order (the text after the prefix)."""

_PENDING: list[tuple[Mapping[str, Any], Callable[[Any], str]]] = []
"""The JSON document of this run and its encoding, until the command ends."""

_STATE = {"holding": False}
"""Whether a run is under way (the entry point's): JSON is held until it ends."""


def one_line(text: object) -> str:
    """``text`` on one line, runs of white space as one space."""
    return " ".join(str(text).split())


def start_run() -> None:
    """Forget any earlier run's warnings and JSON; hold this run's JSON until it ends."""
    _WARNINGS.clear()
    _PENDING.clear()
    _STATE["holding"] = True


def drop_run() -> None:
    """End the run without writing its JSON (it failed: only its error line is printed)."""
    _PENDING.clear()
    _STATE["holding"] = False


def record_warning(text: str) -> None:
    """Note a warning printed on stderr (``text``: the words after ``kinsync: warning:``)."""
    _WARNINGS.append(one_line(text))


def warn(text: str) -> None:
    """Print ``kinsync: warning: text`` on one line on stderr and record it for ``--json``."""
    line = one_line(text)
    record_warning(line)
    print(WARNING_PREFIX + line, file=sys.stderr, flush=True)


def _with_warnings(doc: Mapping[str, Any]) -> dict[str, Any]:
    """``doc`` with a ``warnings`` list holding every warning printed, each once.

    And a ``provenance`` record (`kinsync.io.provenance.run_record`) unless it has one.

    The document's own warnings come first, as it lists them; then each printed warning
    it does not list (compared on one line), in the order printed.
    """
    listed = doc.get("warnings")
    merged = [str(w) for w in listed] if isinstance(listed, list | tuple) else []
    seen = {one_line(w) for w in merged}
    for text in _WARNINGS:
        if text not in seen:
            merged.append(text)
            seen.add(text)
    # what produced it: the software (and commit), the command, the time (UTC)
    return {**doc, "warnings": merged, "provenance": doc.get("provenance") or run_record()}


def hold_json(doc: Mapping[str, Any], encode: Callable[[Any], str]) -> None:
    """Keep a command's JSON document until the command ends (write it now outside a run).

    Parameters
    ----------
    doc
        The document; ``encode`` must accept it.
    encode
        ``encode(doc) -> str``: the document as one line of JSON.
    """
    if _STATE["holding"]:
        _PENDING.append((doc, encode))
    else:
        sys.stdout.write(encode(_with_warnings(doc)) + "\n")


def write_held_json() -> None:
    """Write the held JSON document, if any, with the run's warnings; end the run."""
    pending = list(_PENDING)
    drop_run()
    for doc, encode in pending:
        sys.stdout.write(encode(_with_warnings(doc)) + "\n")
    sys.stdout.flush()
