"""Option parsers shared by several commands."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Annotated

import typer

from kinsync.errors import InputError

__all__ = [
    "MAX_GAP_HELP",
    "MULTI_VALUE_OPTIONS",
    "MaxGapOpt",
    "expand_multi_value_options",
    "parse_rates",
]

MAX_GAP_HELP = (
    "Longest trajectory record interval (s) to interpolate across; times inside a longer "
    "one (a data gap) are treated as outside the trajectory's span. Default: 10 times the "
    "median record interval; the most, 86400 (a day), interpolates across any interval up "
    "to a day."
)
"""The help of ``--max-gap-s``, one wording for every command that reads a trajectory."""

MaxGapOpt = Annotated[float | None, typer.Option("--max-gap-s", help=MAX_GAP_HELP)]
"""``--max-gap-s``: the gap threshold (s) of `kinsync.trajectory_gaps.max_gap_for`."""

MULTI_VALUE_OPTIONS: dict[tuple[str, ...], tuple[str, ...]] = {
    ("calibrate", "mount"): ("--points", "--trajectory"),
}
"""Options of a command that take several values after one flag (``--points lines/*.laz``)."""


def _command_path(args: Sequence[str], depth: int) -> tuple[str, ...]:
    return tuple(a for a in args if not a.startswith("-"))[:depth]


def expand_multi_value_options(args: Sequence[str]) -> list[str]:
    """``--points A B C`` -> ``--points A --points B --points C`` where a command allows it.

    typer (click) takes one value per option flag; a shell glob gives many. For the
    commands in `MULTI_VALUE_OPTIONS`, every token after such a flag up to the next
    token starting with ``-`` is one more value of it.
    """
    out = list(args)
    for path, names in MULTI_VALUE_OPTIONS.items():
        if _command_path(args, len(path)) != path:
            continue
        out = []
        current: str | None = None
        for token in args:
            if token.startswith("-"):
                current = token if token in names else None
                out.append(token)
            elif current is not None and out[-1] != current:
                out.extend([current, token])
            else:
                out.append(token)
        return out
    return out


def parse_rates(text: str) -> tuple[float, ...]:
    """Parse a comma-separated list of table rates (deg/s) such as ``2,4,6``.

    Raises
    ------
    InputError
        An empty list or item, a non-number, a non-finite, zero or negative rate.
    """
    items = [s.strip() for s in text.split(",")]
    if not text.strip():
        msg = "--rates-deg-s is empty; give comma-separated rates such as 2,4,6,10,14,18"
        raise InputError(msg)
    rates: list[float] = []
    for pos, item in enumerate(items, start=1):
        if not item:
            msg = f"--rates-deg-s {text!r}: item {pos} is empty; give rates such as 2,4,6"
            raise InputError(msg)
        try:
            rate = float(item)
        except ValueError:
            msg = f"--rates-deg-s {text!r}: item {pos} ({item!r}) is not a number"
            raise InputError(msg) from None
        if not math.isfinite(rate) or rate <= 0.0:
            msg = (
                f"--rates-deg-s {text!r}: item {pos} ({item!r}) must be a rate magnitude "
                "> 0 deg/s (each rate runs in both directions)"
            )
            raise InputError(msg)
        rates.append(rate)
    return tuple(rates)
