"""Record times of a trajectory: finite, strictly increasing, one time scale.

A decreasing time is named with the row, and a step back of about a week from the end of
a GPS week to its start is named a week rollover: what seconds-of-week exports (SBET,
POSPac, Inertial Explorer) read with one GPS week show there, which sorting would
scramble. Likewise a pulse log whose clock was stepped back (`backward_step_s`) is told
from one with shuffled lines.
"""

from __future__ import annotations

import numpy as np

from kinsync._typing import ArrayLike, FloatArray
from kinsync._validate import time_array
from kinsync.errors import InputError

__all__ = ["backward_step_s", "validated_times"]

_SECONDS_PER_WEEK = 604_800.0


_REGULAR_SPACING = 0.1
"""Pulse intervals within this fraction of the usual one are regular (`backward_step_s`)."""
_STEP_CONTEXT = 3
"""Regular intervals looked at after a backward step (fewer at the end of a log)."""


def backward_step_s(t: FloatArray, row: int) -> float | None:
    """Size of a backward step of the local clock at a pulse out of order, or None.

    ``row`` is a pulse that does not follow its predecessor. A step back by one second
    or more puts it at or before pulse ``row - 1``, and the pulses go on rising from
    there, one interval apart as before (sorting would interleave two stretches of
    clock). Lines swapped or repeated leave a repeated time or a doubled interval
    around the disorder instead: None.

    Parameters
    ----------
    t : ndarray, shape (N,)
        Pulse times (s, local clock), in file order.
    row : int
        Index of the first pulse with ``t[row] <= t[row - 1]`` (1 <= row < N).

    Returns
    -------
    float or None
        The step (s, negative): ``t[row] - t[row - 1]`` less the usual interval.
    """
    d = np.diff(t)
    rising = d[d > 0.0]
    if len(rising) == 0 or not 1 <= row < len(t) or t[row] >= t[row - 1]:
        return None
    interval = float(np.median(rising))
    around = d[max(row - 2, 0) : row - 1]
    after = d[row : row + _STEP_CONTEXT]
    if len(after) == 0:
        return None
    near = np.abs(np.r_[around, after] - interval) <= _REGULAR_SPACING * interval
    if not np.all(near):
        return None
    return float(d[row - 1] - interval)


def _week_rollover(before_s: float, after_s: float) -> bool:
    """A step back of about a week, from late in a GPS week to early in one.

    What seconds-of-week times read with one GPS week for the whole file (SBET, POSPac
    and Inertial Explorer exports) show where the week rolls over.
    """
    back = before_s - after_s
    late, early = before_s % _SECONDS_PER_WEEK, after_s % _SECONDS_PER_WEEK
    return 0.5 * _SECONDS_PER_WEEK < back <= _SECONDS_PER_WEEK + 1.0 and early < late


def validated_times(values: ArrayLike) -> FloatArray:
    """1-D, finite, strictly increasing record times of a trajectory (s).

    Parameters
    ----------
    values : array_like, shape (N,)
        Record times (s), N >= 2.

    Returns
    -------
    ndarray, shape (N,)
        The times as float64.

    Raises
    ------
    InputError
        Naming the 0-based row: not numbers (datetime64, text, or a float dtype too
        coarse for the times: `kinsync._validate.time_array`), fewer than 2,
        non-finite, repeated or decreasing (a GPS week rollover named as such).
    """
    t = time_array(values, "trajectory t_s")
    if t.ndim != 1 or t.size < 2:
        msg = f"trajectory t_s: expected a 1-D array of at least 2 times, got shape {t.shape}"
        raise InputError(msg)
    if not np.all(np.isfinite(t)):
        row = int(np.flatnonzero(~np.isfinite(t))[0])
        msg = f"trajectory t_s: non-finite time in row {row}"
        raise InputError(msg)
    dt = np.diff(t)
    if np.any(dt <= 0.0):
        row = int(np.flatnonzero(dt <= 0.0)[0]) + 1
        kind = "repeated" if dt[row - 1] == 0.0 else "decreasing"
        before, after = float(t[row - 1]), float(t[row])
        where = f"trajectory t_s: {kind} time in row {row} (t_s={after!r} after {before!r})"
        if _week_rollover(before, after):
            msg = (
                f"{where}: the GPS week rolls over there (seconds of the week start again "
                "from 0); a trajectory needs one time scale: export it with times counting "
                "past 604800 s, or split it at that record and give each part its GPS week"
            )
        else:
            msg = (
                f"{where}; times must be strictly increasing: sort the records and drop duplicates"
            )
        raise InputError(msg)
    return t
