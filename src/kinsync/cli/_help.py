"""Help display fixes applied to every kinsync command.

typer 0.29 labels an on/off flag with its Python type (``--json <bool>``), which reads as if
the flag took a value, and ``--json true`` then fails with "Got unexpected extra argument".
A flag takes no value, so its help shows none (as click's own help does).
"""

from __future__ import annotations

from typing import Any

from typer.core import TyperOption

__all__ = ["install_flag_display"]

_original = TyperOption.display_type_rich


def _display_type_rich(self: TyperOption, ctx: Any) -> str | None:
    if self.is_flag and self.metavar is None:
        return None
    return _original(self, ctx)


def install_flag_display() -> None:
    """Show on/off flags without a value type in ``--help`` (idempotent)."""
    TyperOption.display_type_rich = _display_type_rich  # type: ignore[method-assign]
