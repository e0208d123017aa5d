"""Array type aliases used across kinsync.

Shapes, units and frames are given in each function's docstring; these aliases only
fix the dtype.
"""

from __future__ import annotations

from typing import TypeAlias

import numpy as np
import numpy.typing as npt

FloatArray: TypeAlias = npt.NDArray[np.float64]
"""float64 array of any shape."""

BoolArray: TypeAlias = npt.NDArray[np.bool_]
"""Boolean array of any shape (masks)."""

IntArray: TypeAlias = npt.NDArray[np.int64]
"""int64 array of any shape (indices, counts)."""

ArrayLike: TypeAlias = npt.ArrayLike
"""Anything numpy can turn into an array."""
