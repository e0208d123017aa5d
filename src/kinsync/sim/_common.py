"""Helpers shared by the drive simulation's modules: 3-vectors, checks and random streams."""

from __future__ import annotations

from collections.abc import Iterable

from kinsync._validate import finite_number
from kinsync.errors import InputError

Vector3 = tuple[float, float, float]
"""Three numbers (a vector in a named frame, or per-axis values)."""

# Random streams of one seed: the IMU errors, the GNSS noise and the trajectory noise
# draw from independent generators, so changing one leaves the others as they were.
_IMU_STREAM = 1
_GNSS_STREAM = 2
_NOISE_STREAM = 3


def _vector3(value: object, name: str) -> Vector3:
    if not isinstance(value, Iterable):
        msg = f"{name}: expected 3 numbers, got {value!r}"
        raise InputError(msg)
    vals = tuple(value)
    if len(vals) != 3:
        msg = f"{name}: expected 3 numbers, got {len(vals)}"
        raise InputError(msg)
    x, y, z = (finite_number(v, f"{name}[{i}]") for i, v in enumerate(vals))
    return (x, y, z)


def _non_negative(value: object, name: str) -> float:
    out = finite_number(value, name)
    if out < 0.0:
        msg = f"{name} must be >= 0, got {value!r}"
        raise InputError(msg)
    return out
