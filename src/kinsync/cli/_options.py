"""Option parsers shared by several commands."""

from __future__ import annotations

import math

from kinsync.errors import InputError

__all__ = ["parse_rates"]


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
