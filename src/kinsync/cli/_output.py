"""Shared output helpers: JSON on stdout, rich tables, formatting."""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Mapping
from typing import Any

from rich.console import Console
from rich.table import Table

__all__ = ["console", "err_console", "fmt", "print_json", "quantity_table"]

# Markup off: kinsync prints no styling tags, and text in square brackets (a TOML table
# such as [uncertainty], a list of names) must be shown as written, not eaten as a tag.
console = Console(soft_wrap=True, markup=False)
err_console = Console(stderr=True, markup=False)


def _clean(value: Any) -> Any:
    """Make a value JSON-safe: non-finite floats become null."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, Mapping):
        return {str(k): _clean(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_clean(v) for v in value]
    return value


def print_json(obj: Mapping[str, Any]) -> None:
    """Write one JSON object on stdout, nothing else."""
    sys.stdout.write(json.dumps(_clean(obj), allow_nan=False) + "\n")


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
