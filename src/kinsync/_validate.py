"""Scalar argument checks shared by the library (messages name the argument)."""

from __future__ import annotations

import math

import numpy as np

from kinsync.errors import InputError

__all__ = ["finite_number", "positive_number"]


def finite_number(value: object, name: str) -> float:
    """Return ``value`` as a finite float, or raise `InputError` naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        msg = f"{name}: expected a number, got {value!r}"
        raise InputError(msg)
    out = float(value)
    if not math.isfinite(out):
        msg = f"{name}: must be finite, got {value!r}"
        raise InputError(msg)
    return out


def positive_number(value: object, name: str) -> float:
    """Return ``value`` as a finite float > 0, or raise `InputError` naming ``name``."""
    out = finite_number(value, name)
    if out <= 0.0:
        msg = f"{name} must be positive, got {value!r}"
        raise InputError(msg)
    return out
