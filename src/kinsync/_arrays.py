"""Array helpers shared by the containers."""

from __future__ import annotations

import numpy as np

from kinsync._typing import ArrayLike, FloatArray

__all__ = ["readonly_array"]


def readonly_array(values: ArrayLike, *, copy: bool = True) -> FloatArray:
    """``values`` as a read-only, C-contiguous float64 array (containers hold these).

    With ``copy=False`` an array that already is contiguous float64 is flagged read-only
    in place instead of copied: only for arrays the caller has just made and owns.
    """
    if copy:
        out = np.array(values, dtype=np.float64, copy=True, order="C")
    else:
        out = np.ascontiguousarray(values, dtype=np.float64)
    out.setflags(write=False)
    return out
