"""Help display fixes applied to every kinsync command.

Help is rendered by rich with markup on (typer's default), so text in square brackets
that looks like a style tag (``gyro_[xyz]_rad_s``, ``[profiler]``, ``kinsync[scale]``)
vanished from ``--help``. `literal` escapes it; tests/cli/test_help_text.py checks that
every bracketed text of every command's help is shown.

typer 0.29 labels an on/off flag with its Python type (``--json <bool>``), which reads as if
the flag took a value, and ``--json true`` then fails with "Got unexpected extra argument".
A flag takes no value, so its help shows none (as click's own help does). Earlier typer
releases (the declared minimum is 0.12) have no ``display_type_rich`` and show no type for a
flag, so there is nothing to change there.
"""

from __future__ import annotations

import inspect
from typing import Any

from rich.markup import escape
from typer.core import TyperOption

__all__ = ["install_flag_display", "literal", "reflowed"]


def reflowed(doc: str) -> str:
    r"""A command's docstring as ``--help`` should show it: each paragraph one line.

    typer joins the lines of the first paragraph but keeps the line ends of the others,
    where rich then wraps again at the terminal's width: a paragraph written at 88
    columns showed one or two words alone on every other line. A paragraph starting
    with ``\b`` (click's "keep as written") is kept.

    Parameters
    ----------
    doc : str
        The docstring (indented or not).

    Returns
    -------
    str
        Paragraphs separated by a blank line, each without line ends.
    """
    text = inspect.cleandoc(doc)
    return "\n\n".join(p if p.startswith("\b") else " ".join(p.split()) for p in text.split("\n\n"))


def literal(text: str) -> str:
    """Help text shown as written: square brackets are not rich markup tags."""
    return escape(text)


_original: Any = getattr(TyperOption, "display_type_rich", None)


def _display_type_rich(self: TyperOption, ctx: Any) -> str | None:
    if self.is_flag and self.metavar is None:
        return None
    result: str | None = _original(self, ctx)
    return result


def install_flag_display() -> None:
    """Show on/off flags without a value type in ``--help`` (idempotent; typer >= 0.29)."""
    if _original is not None:
        TyperOption.display_type_rich = _display_type_rich  # type: ignore[method-assign]
