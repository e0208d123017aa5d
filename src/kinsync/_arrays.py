"""Array helpers shared by the containers."""

from __future__ import annotations

import numpy as np

from kinsync._typing import ArrayLike, FloatArray

__all__ = ["readonly_copy"]


def readonly_copy(values: ArrayLike) -> FloatArray:
    """A read-only float64 copy of ``values``, C-contiguous (containers hold these)."""
    out = np.array(values, dtype=np.float64, copy=True, order="C")
    out.setflags(write=False)
    return out
