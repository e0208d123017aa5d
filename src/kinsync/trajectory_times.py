"""Record times of a trajectory: finite, strictly increasing, one time scale.

A decreasing time is named with the row, and a step back of about a week from the end of
a GPS week to its start is named a week rollover: what seconds-of-week exports (SBET,
POSPac, Inertial Explorer) read with one GPS week show there, which sorting would
scramble.
"""

from __future__ import annotations

import numpy as np

from kinsync._typing import ArrayLike, FloatArray
from kinsync.errors import InputError

__all__ = ["validated_times"]

_SECONDS_PER_WEEK = 604_800.0


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
        Naming the 0-based row: not numbers, fewer than 2, non-finite, repeated or
        decreasing (a GPS week rollover named as such).
    """
    try:
        t = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError) as err:
        msg = f"trajectory t_s: expected numbers ({err})"
        raise InputError(msg) from err
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
