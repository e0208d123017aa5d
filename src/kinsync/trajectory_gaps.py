"""Data gaps of a trajectory: record intervals too long to interpolate across.

A record interval longer than `GAP_FACTOR` times the median record interval (or than an
explicit ``max_gap_s``) is a gap: positions and attitudes interpolated across it are a
guess, not a measurement. A time strictly inside a gap is treated like a time outside
the trajectory's span: by `kinsync.trajectory.Trajectory` (``contains`` is False there,
``interpolate`` raises or masks), by georeferencing
(`kinsync.georef.trajectory.GeorefTrajectory`) and so by every command that reads a
trajectory at given times; ``kinsync trajectory info`` warns about gaps. A time on
the record at either end of a gap is not in it. Every command that reads a trajectory
takes ``--max-gap-s`` for a trajectory whose long intervals are legitimate (an export
at a variable rate, a track with 1-5 s steps, a pause), and every message about a gap
names the threshold used (`gap_threshold_text`) and the option (`GAP_ADVICE`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from kinsync._typing import ArrayLike, IntArray
from kinsync.errors import InputError

__all__ = [
    "GAP_ADVICE",
    "GAP_FACTOR",
    "TrajectoryGap",
    "gap_index",
    "gap_threshold_shown_s",
    "gap_threshold_text",
    "max_gap_for",
    "trajectory_gaps",
]

GAP_FACTOR = 10.0
"""A record interval longer than this many median record intervals is a data gap: a
trajectory interpolated across it is a guess (a 10 s hole in a drive bends positions by
decimetres), not a measurement. Georeferencing treats points in a gap like points
outside the span."""


GAP_ADVICE = "set --max-gap-s above the gap's length to interpolate across it"
"""What a message about a gap tells the user to do when the interval is legitimate (a
variable-rate export, a track with irregular steps, a pause): every command that reads
a trajectory takes ``--max-gap-s``."""


def gap_threshold_shown_s(max_gap_s: float) -> float:
    """The default gap threshold (s) as people are shown it: to 1 us, from a rounded median.

    `max_gap_for` takes `GAP_FACTOR` times the median record interval, and times near
    1.4e9 s hold 0.24 us steps: at 100 Hz the threshold used is 0.09999990463 s, at
    200 Hz 0.05000114441 s. Shown is `GAP_FACTOR` times the median interval rounded to
    1 us (0.1 s, 0.05 s), as ``trajectory info`` shows the rate. A threshold that is not
    finite, or a median interval under 0.5 us, is returned unchanged.

    Parameters
    ----------
    max_gap_s : float
        The default threshold used (s), `max_gap_for` without ``max_gap_s``.

    Returns
    -------
    float
        The threshold to show (s).
    """
    if not math.isfinite(max_gap_s):
        return max_gap_s
    median_s = round(max_gap_s / GAP_FACTOR, 6)
    return round(GAP_FACTOR * median_s, 6) if median_s > 0.0 else max_gap_s


def gap_threshold_text(max_gap_s: float, *, given: bool = False) -> str:
    """``record intervals longer than X s (...)``: the gap threshold a message names.

    Parameters
    ----------
    max_gap_s : float
        The threshold used (s), as `max_gap_for` gives it; the default is shown as
        `gap_threshold_shown_s` (0.1 s, not 0.0999999 s).
    given : bool
        Whether the user set it (``--max-gap-s``): the message then says so, not the
        default it replaced.
    """
    if given:
        return (
            f"record intervals longer than {max_gap_s:.6g} s (the gap threshold given with "
            "--max-gap-s)"
        )
    return (
        f"record intervals longer than {gap_threshold_shown_s(max_gap_s):.6g} s (the gap "
        f"threshold: --max-gap-s, default {GAP_FACTOR:g} median record intervals)"
    )


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
        An explicit threshold (s, positive; ``math.inf``: no record interval is a gap);
        default `GAP_FACTOR` times the median record interval (infinite with fewer
        than two intervals: one interval is no evidence of a gap).

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
        if not max_gap_s > 0.0:  # NaN too
            msg = (
                "max_gap_s (--max-gap-s), the longest trajectory record interval to "
                "interpolate across, must be a positive number of seconds (math.inf: no "
                f"gap), got {max_gap_s!r}"
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


def gap_index(t_s: ArrayLike, gaps: tuple[TrajectoryGap, ...]) -> IntArray:
    """Which gap each time lies strictly inside: its index in ``gaps``, -1 for none.

    Parameters
    ----------
    t_s : array_like, any shape
        Times (s), on the time scale of the gaps.
    gaps : tuple of TrajectoryGap
        In time order, not overlapping (`trajectory_gaps`).

    Returns
    -------
    ndarray of int64, same shape as ``t_s``
        A time on a gap's start or end record is not inside it.
    """
    t = np.asarray(t_s, dtype=np.float64)
    if not gaps:
        return np.full(t.shape, -1, dtype=np.int64)
    starts = np.array([g.t_start_s for g in gaps])
    ends = np.array([g.t_end_s for g in gaps])
    k = np.searchsorted(starts, t, side="left") - 1  # the last gap starting before t
    inside = (k >= 0) & (t < ends[np.maximum(k, 0)])
    out: IntArray = np.where(inside, k, -1).astype(np.int64)
    return out
