"""Box text (``xmin,ymin,zmin,xmax,ymax,zmax``) of ``--box`` and ``--roi-m``, parsed."""

from __future__ import annotations

import math

from kinsync.errors import InputError
from kinsync.validation.flatness import Box

__all__ = [
    "parse_box",
]


def parse_box(text: str, option: str = "--box") -> Box:
    """Parse ``"xmin,ymin,zmin,xmax,ymax,zmax"`` (the units of the points it selects).

    ``option`` names the option in messages.

    Raises
    ------
    InputError
        Not six numbers, a non-finite value, a minimum not below its maximum.
    """
    items = [s.strip() for s in str(text).split(",")]
    if len(items) != 6:
        msg = f"{option} {text!r}: expected 6 comma-separated numbers xmin,ymin,zmin,xmax,ymax,zmax"
        raise InputError(msg)
    values: list[float] = []
    for pos, item in enumerate(items, start=1):
        try:
            value = float(item)
        except ValueError:
            msg = f"{option} {text!r}: item {pos} ({item!r}) is not a number"
            raise InputError(msg) from None
        if not math.isfinite(value):
            msg = f"{option} {text!r}: item {pos} ({item!r}) is not finite"
            raise InputError(msg)
        values.append(value)
    for axis, (lo, hi) in enumerate(zip(values[:3], values[3:], strict=True)):
        if not lo < hi:
            name = "xyz"[axis]
            msg = f"{option} {text!r}: {name}min {lo!r} must be below {name}max {hi!r}"
            raise InputError(msg)
    return (values[0], values[1], values[2], values[3], values[4], values[5])
