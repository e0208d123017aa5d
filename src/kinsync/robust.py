"""Robust scale: the standard deviation of Gaussian data from the median absolute deviation.

``sigma = 1.4826 · median |d|`` for deviations ``d`` from a robust centre (the median,
a fitted model): consistent for Gaussian errors (1.4826 ≈ 1 / Φ⁻¹(3/4)) and unmoved by
up to half the data being outliers. The one place kinsync defines it; every robust
rejection rule (clock pulses, sphere clutter, wall outliers, control targets) uses it.

References
----------
Rousseeuw, P. J. & Croux, C., "Alternatives to the median absolute deviation",
J. Am. Stat. Assoc. 88(424), 1993, 1273-1283.
"""

from __future__ import annotations

import numpy as np

from kinsync._typing import ArrayLike, FloatArray

__all__ = ["MAD_TO_SIGMA", "robust_sigma", "robust_sigma_per_column"]

MAD_TO_SIGMA = 1.4826
"""Median absolute deviation -> standard deviation, for Gaussian data."""


def robust_sigma(deviations: ArrayLike, *, omit_nan: bool = False) -> float:
    """``1.4826 · median |deviations|``, over all elements.

    Parameters
    ----------
    deviations : array_like, shape (...)
        Deviations from the centre (same unit as the result).
    omit_nan : bool
        Ignore NaN deviations (otherwise a NaN makes the result NaN).

    Returns
    -------
    float
        Robust standard deviation (NaN for no data).
    """
    d = np.abs(np.asarray(deviations, dtype=np.float64))
    return MAD_TO_SIGMA * float(np.nanmedian(d) if omit_nan else np.median(d))


def robust_sigma_per_column(deviations: ArrayLike) -> FloatArray:
    """``1.4826 · median |deviations|`` of each column of an ``(n, k)`` array, shape (k,)."""
    d = np.abs(np.asarray(deviations, dtype=np.float64))
    out: FloatArray = MAD_TO_SIGMA * np.median(d, axis=0)
    return out
