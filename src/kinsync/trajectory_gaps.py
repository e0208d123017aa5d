"""Data gaps of a trajectory: record intervals too long to interpolate across.

A record interval longer than `GAP_FACTOR` times the median record interval (or than an
explicit ``max_gap_s``) is a gap: positions and attitudes interpolated across it are a
guess, not a measurement. Georeferencing (`kinsync.georef.trajectory.GeorefTrajectory`)
treats points in a gap like points outside the trajectory's span, and
``kinsync trajectory info`` warns about gaps.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from kinsync._typing import ArrayLike
from kinsync.errors import InputError

__all__ = [
    "GAP_FACTOR",
    "TrajectoryGap",
    "max_gap_for",
    "trajectory_gaps",
]

GAP_FACTOR = 10.0
"""A record interval longer than this many median record intervals is a data gap: a
trajectory interpolated across it is a guess (a 10 s hole in a drive bends positions by
decimetres), not a measurement. Georeferencing treats points in a gap like points
outside the span."""


@dataclass(frozen=True)
class TrajectoryGap:
    """A data gap: two consecutive records further apart than the gap threshold.

    Attributes
    ----------
    t_start_s, t_end_s : float
        Times (s) of the records on either side of the gap.
    """

    t_start_s: float
    t_end_s: float

    @property
    def length_s(self) -> float:
        """Length of the gap (s)."""
        return self.t_end_s - self.t_start_s

    def describe(self) -> str:
        """``start .. end s (length s)``, for messages."""
        return f"{self.t_start_s!r} .. {self.t_end_s!r} s ({self.length_s:.6g} s)"


def max_gap_for(t_s: ArrayLike, max_gap_s: float | None = None) -> float:
    """The gap threshold (s) for record times ``t_s``.

    Parameters
    ----------
    t_s : array_like, shape (N,)
        Record times (s), strictly increasing.
    max_gap_s : float, optional
        An explicit threshold (s, positive); default `GAP_FACTOR` times the median
        record interval (infinite with fewer than two intervals: one interval is no
        evidence of a gap).

    Returns
    -------
    float
        Record intervals longer than this are gaps.

    Raises
    ------
    InputError
        ``max_gap_s`` not a positive number.
    """
    if max_gap_s is not None:
        if not (math.isfinite(max_gap_s) and max_gap_s > 0.0):
            msg = (
                "the longest trajectory gap to interpolate across (--max-gap-s) must be a "
                f"positive number of seconds, got {max_gap_s!r}"
            )
            raise InputError(msg)
        return float(max_gap_s)
    dt = np.diff(np.asarray(t_s, dtype=np.float64))
    if dt.size < 2:
        return math.inf
    return GAP_FACTOR * float(np.median(dt))


def trajectory_gaps(t_s: ArrayLike, max_gap_s: float) -> tuple[TrajectoryGap, ...]:
    """The record intervals of ``t_s`` longer than ``max_gap_s`` (s), in time order."""
    t = np.asarray(t_s, dtype=np.float64)
    k = np.flatnonzero(np.diff(t) > max_gap_s)
    return tuple(TrajectoryGap(float(t[i]), float(t[i + 1])) for i in k)
