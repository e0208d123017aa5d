"""Helpers shared by the validation modules: validated point arrays and least squares."""

from __future__ import annotations

import numpy as np

from kinsync._typing import ArrayLike, FloatArray
from kinsync.errors import InputError

__all__ = [
    "finite_rows",
    "lstsq",
]


def finite_rows(values: ArrayLike, n: int | None, width: int | None, name: str) -> FloatArray:
    """``values`` as a read-only float64 array of ``n`` rows (``width`` columns, or 1-D).

    Raises `InputError`, prefixed with ``name``, for non-numbers, a wrong shape or the
    first non-finite row.
    """
    try:
        arr = np.array(values, dtype=np.float64)
    except (TypeError, ValueError) as err:
        msg = f"{name}: expected numbers ({err})"
        raise InputError(msg) from err
    shape_ok = (arr.ndim == 2 and arr.shape[1] == width) if width else arr.ndim == 1
    if not shape_ok or (n is not None and arr.shape[0] != n):
        want = f"({'N' if n is None else n}, {width})" if width else f"({n},)"
        msg = f"{name}: expected shape {want}, got {arr.shape}"
        raise InputError(msg)
    bad = ~np.isfinite(arr) if arr.ndim == 1 else ~np.all(np.isfinite(arr), axis=1)
    if np.any(bad):
        row = int(np.flatnonzero(bad)[0])
        msg = f"{name}: non-finite value at index {row} (0-based); drop or fix it"
        raise InputError(msg)
    arr.setflags(write=False)
    return arr


def lstsq(design: FloatArray, y: FloatArray) -> FloatArray:
    """Least-squares coefficients of ``design @ x = y``."""
    coef, *_ = np.linalg.lstsq(design, y, rcond=None)
    out: FloatArray = np.asarray(coef, dtype=np.float64)
    return out
