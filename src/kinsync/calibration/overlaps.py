"""How well the lines agree on each feature: the overlap differences, before and after.

For every (feature, line): where that line alone puts the feature, relative to where
all lines together put it, in the local NED frame (m):

- plane: the median signed distance of the line's returns to the common plane, along
  its normal (a wall one line sees 4 cm in front of the others);
- sphere: the centre fitted to the line's returns alone (with the feature's radius)
  minus the common centre.

With a correct mount and latency the differences shrink to the navigation and range
errors; their scatter per feature (horizontal and vertical) is what a surveyor reads
off a sphere or a wall.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from kinsync._typing import FloatArray
from kinsync.calibration.adjustment import Observation
from kinsync.calibration.features import Feature
from kinsync.calibration.model import LineModel, LocalFrame
from kinsync.errors import KinsyncError
from kinsync.fit.sphere import fit_sphere

__all__ = ["LineOverlap", "overlap_differences", "scatter_m"]


@dataclass(frozen=True)
class LineOverlap:
    """One line's view of one feature, relative to all lines'.

    Attributes
    ----------
    feature : int
        Index of the feature.
    line : str
        Name of the line.
    offset_ned_m : tuple of 3 float
        Where the line alone puts the feature minus where all lines put it, local NED
        (m); NaN when the line's returns cannot be fitted alone.
    normal_m : float
        A plane's offset along its normal (m, signed); NaN for a sphere.
    """

    feature: int
    line: str
    offset_ned_m: tuple[float, float, float]
    normal_m: float = math.nan

    @property
    def horizontal_m(self) -> float:
        """Horizontal length of the offset (m)."""
        return math.hypot(self.offset_ned_m[0], self.offset_ned_m[1])

    @property
    def vertical_m(self) -> float:
        """Vertical component of the offset (m, down positive)."""
        return self.offset_ned_m[2]


def _offset(feature: Feature, x: FloatArray) -> tuple[FloatArray, float]:
    if len(x) < 4:
        return np.full(3, np.nan), math.nan
    if feature.kind == "plane":
        d = float(np.median(feature.residuals(x)))
        return feature.normal * d, d  # type: ignore[union-attr]
    try:
        fit = fit_sphere(x, radius_m=feature.radius_m)  # type: ignore[union-attr]
    except KinsyncError:
        return np.full(3, np.nan), math.nan
    return fit.center_m - feature.centre_m, math.nan  # type: ignore[union-attr]


def overlap_differences(
    models: Sequence[LineModel],
    observations: Sequence[Observation],
    features: Sequence[Feature],
    values: FloatArray,
    frame: LocalFrame,
) -> tuple[LineOverlap, ...]:
    """Every (feature, line)'s offset with the mount ``values`` and the ``features``."""
    out = []
    for o in observations:
        x = models[o.line].points(o.index, values, frame)
        x = x[np.all(np.isfinite(x), axis=1)]
        off, along = _offset(features[o.feature], x)
        out.append(
            LineOverlap(
                feature=o.feature,
                line=models[o.line].line.name,
                offset_ned_m=(float(off[0]), float(off[1]), float(off[2])),
                normal_m=along,
            )
        )
    return tuple(out)


def scatter_m(overlaps: Sequence[LineOverlap], feature: int) -> tuple[float, float]:
    """RMS horizontal and vertical scatter of one feature's line offsets about their mean."""
    off = np.array([o.offset_ned_m for o in overlaps if o.feature == feature])
    off = off[np.all(np.isfinite(off), axis=1)]
    if off.shape[0] < 2:
        return math.nan, math.nan
    dev = off - off.mean(axis=0)
    horizontal = float(np.sqrt(np.mean(dev[:, 0] ** 2 + dev[:, 1] ** 2)))
    vertical = float(np.sqrt(np.mean(dev[:, 2] ** 2)))
    return horizontal, vertical
