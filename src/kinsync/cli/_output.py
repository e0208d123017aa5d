"""Shared output helpers: JSON on stdout, rich tables, formatting."""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from typing import Any

from rich.console import Console, HighlighterType, JustifyMethod, OverflowMethod
from rich.style import Style
from rich.table import Table
from rich.text import Text

from kinsync.cli._record import hold_json, warn
from kinsync.cli._streams import OutputPipeClosed, plain_symbols

__all__ = ["console", "err_console", "fmt", "print_json", "quantity_table", "warn"]


# Markup off: kinsync prints no styling tags, and text in square brackets (a TOML table
# such as [uncertainty], a list of names) must be shown as written, not eaten as a tag.
class _Console(Console):
    """rich's console for kinsync's streams: plain symbols, quiet end on a closed pipe.

    Symbols a stream's encoding lacks are written plain (a Latin-1 terminal's ``sigma``
    for ``σ``) before a table is laid out, so its columns stay aligned; a pipe closed by
    its reader ends the run quietly (status 141, `kinsync.cli._streams`) where rich would
    exit 1, the status of a fault.
    """

    def render_str(
        self,
        text: str,
        *,
        style: str | Style = "",
        justify: JustifyMethod | None = None,
        overflow: OverflowMethod | None = None,
        emoji: bool | None = None,
        markup: bool | None = None,
        highlight: bool | None = None,
        highlighter: HighlighterType | None = None,
    ) -> Text:
        """Text of ``text``, its symbols spelled plain where the stream cannot encode them."""
        return super().render_str(
            plain_symbols(text, self.encoding),
            style=style,
            justify=justify,
            overflow=overflow,
            emoji=emoji,
            markup=markup,
            highlight=highlight,
            highlighter=highlighter,
        )

    def on_broken_pipe(self) -> None:
        """The reader of the output went away (``| head -1``): end the run quietly."""
        self.quiet = True
        msg = "the output pipe was closed by its reader"
        raise OutputPipeClosed(msg)


console = _Console(soft_wrap=True, markup=False)
err_console = _Console(stderr=True, markup=False)


def _clean(value: Any) -> Any:
    """Make a value JSON-safe: non-finite floats become null."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, Mapping):
        return {str(k): _clean(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_clean(v) for v in value]
    return value


def _encode(obj: Any) -> str:
    return json.dumps(obj, allow_nan=False)


def print_json(obj: Mapping[str, Any]) -> None:
    """Write one JSON object on stdout, nothing else, when the command has ended.

    Its ``warnings`` list (added when absent) then holds every ``kinsync: warning:``
    line the run printed (`kinsync.cli._record`).
    """
    hold_json(_clean(obj), _encode)


def quantity_table(title: str) -> Table:
    """An empty two-column table of a command's results: quantity, value (right-aligned)."""
    table = Table(title=title)
    table.add_column("quantity")
    table.add_column("value", justify="right")
    return table


def fmt(value: float | None, unit_scale: float = 1.0, digits: int = 4) -> str:
    """Format a number for a table (``-`` for None)."""
    if value is None:
        return "-"
    return f"{value * unit_scale:.{digits}g}"
