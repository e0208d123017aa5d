"""LAS coordinates: float coordinates to the stored int32 X, Y, Z and back (numba loops).

One pass over the points per axis, without laspy's per-dimension copies: `store_coordinates`
(floats -> integers for a header's offsets and scales, checking each fits in int32) and
`scaled_coordinates` (integers -> floats).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, cast

import numpy as np

from kinsync._jit import cached_njit
from kinsync._typing import ArrayLike, FloatArray

__all__ = ["scaled_coordinates", "store_coordinates", "store_scaled"]

_INT32_MAX = float(np.iinfo(np.int32).max)


def _store_scaled_loop(
    values: FloatArray,
    offset: float,
    scale: float,
    out: np.ndarray[Any, Any],
    mask: np.ndarray[Any, Any] | None,
) -> int:
    """``out[i] = rint((values[i] - offset) / scale)`` as int32 where ``mask`` (or everywhere).

    Returns the index of the first value that is not finite or does not fit in int32
    (``out`` is then incomplete), or -1. The same arithmetic as
    ``np.round((v - offset) / scale)`` (round half to even).
    """
    for i in range(values.shape[0]):
        if mask is not None and not mask[i]:
            continue
        q = np.rint((values[i] - offset) / scale)
        if not (abs(q) <= _INT32_MAX):  # also catches NaN
            return i
        out[i] = np.int32(q)
    return -1


store_scaled = cast(Callable[..., int], cached_njit(nogil=True)(_store_scaled_loop))
"""Compiled `_store_scaled_loop`: ``(values, offset, scale, out, mask) -> first bad index``."""


def store_coordinates(
    array: np.ndarray[Any, Any],
    xyz: FloatArray,
    offsets: tuple[float, float, float],
    scales: tuple[float, float, float],
    mask: np.ndarray[Any, Any] | None = None,
) -> int:
    """Store coordinates as the LAS integers ``X, Y, Z`` of a point array, in place.

    Parameters
    ----------
    array : structured ndarray, shape (N,)
        Point records (``ScaleAwarePointRecord.array``) with int32 fields X, Y, Z.
    xyz : ndarray, shape (N, 3)
        Coordinates (units of the output CRS) to store.
    offsets, scales : tuple of 3 float
        The LAS header's offsets and scales the integers are meant for.
    mask : ndarray of bool, shape (N,), optional
        Store only these points; the others keep their integers.

    Returns
    -------
    int
        Index of the first coordinate that is not finite or out of the int32 range for
        this offset and scale (nothing stored from there on in that axis), or -1.
    """
    first_bad = -1
    for j, name in enumerate(("X", "Y", "Z")):
        i = store_scaled(xyz[:, j], float(offsets[j]), float(scales[j]), array[name], mask)
        if i >= 0 and (first_bad < 0 or i < first_bad):
            first_bad = i
    return first_bad


def _scale_into_loop(
    X: np.ndarray[Any, Any],
    Y: np.ndarray[Any, Any],
    Z: np.ndarray[Any, Any],
    scales: FloatArray,
    offsets: FloatArray,
    out: FloatArray,
) -> None:
    for i in range(X.shape[0]):
        out[i, 0] = X[i] * scales[0] + offsets[0]
        out[i, 1] = Y[i] * scales[1] + offsets[1]
        out[i, 2] = Z[i] * scales[2] + offsets[2]


_scale_into = cast(Callable[..., None], cached_njit(nogil=True)(_scale_into_loop))


def scaled_coordinates(
    array: np.ndarray[Any, Any], scales: ArrayLike, offsets: ArrayLike
) -> FloatArray:
    """x, y, z of LAS point records as one (N, 3) float64 array (integers × scale + offset).

    Parameters
    ----------
    array : structured ndarray, shape (N,)
        Point records (``ScaleAwarePointRecord.array``) with int32 fields X, Y, Z.
    scales, offsets : array_like, shape (3,)
        The header's scales and offsets.

    Returns
    -------
    ndarray, shape (N, 3)
        One pass over the stored integers, without laspy's per-dimension copies; the
        same values as ``np.column_stack([record.x, record.y, record.z])``.
    """
    out = np.empty((array.shape[0], 3))
    _scale_into(
        array["X"],
        array["Y"],
        array["Z"],
        np.asarray(scales, dtype=np.float64),
        np.asarray(offsets, dtype=np.float64),
        out,
    )
    return out
