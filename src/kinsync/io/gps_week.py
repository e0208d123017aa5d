"""GPS seconds of week or GPS time: how a reader tells which a file's times hold.

SBET, smrmsg and the POSPac / Inertial Explorer text exports usually carry GPS seconds
of week (0 to 604800 s), which a GPS week (``--gps-week``) turns into GPS time. Some
exports write GPS time itself (seconds since 6 January 1980, about 1.4e9 s in 2024) in
the same field. A record of seconds of week may run past the week's end (a trajectory
that crosses the rollover keeps counting past 604800 s), but not by more than
`WEEK_SECONDS_SLACK_S`: a first time beyond `WEEK_SECONDS_MAX_S` cannot be seconds of
week, and the readers take such times as GPS time, adding no week (`holds_gps_time`).
A LAS/LAZ header says which of the two its points carry; `kinsync.io.las` refuses a
header that says seconds of week over times beyond the same bound.

GPS time or Unix time: a log stamped with Unix time (UTC seconds since 1970, about
315964782 s more than GPS time since 2017) reads as a GPS time about ten years after the
survey. `check_not_future` refuses GPS times later than this computer's clock (plus
`FUTURE_SLACK_S`), the clock the ``--gps-week`` bound uses too (`gps_time_now_s`).
"""

from __future__ import annotations

import datetime as dt
import time
from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from kinsync._unix_time import GPS_EPOCH_UNIX_S, UNIX_ADVICE, UNIX_MINUS_GPS_S
from kinsync.errors import InputError

__all__ = [
    "FUTURE_SLACK_S",
    "GPS_EPOCH_UNIX_S",
    "SECONDS_PER_WEEK",
    "UNIX_MINUS_GPS_S",
    "WEEK_SECONDS_MAX_S",
    "WEEK_SECONDS_SLACK_S",
    "check_not_future",
    "future_time_text",
    "gps_time_now_s",
    "holds_gps_time",
]

SECONDS_PER_WEEK = 604_800.0
"""Seconds in one GPS week."""

WEEK_SECONDS_SLACK_S = 86_400.0
"""Seconds of week a file may run past the week's end (604800 s): some loggers keep
counting across the week rollover. Beyond this, the times are not seconds of week."""

WEEK_SECONDS_MAX_S = SECONDS_PER_WEEK + WEEK_SECONDS_SLACK_S
"""Largest time (s) read as GPS seconds of week."""


def holds_gps_time(first_time_s: float) -> bool:
    """Whether times starting at ``first_time_s`` (s) are GPS time, not seconds of week.

    Parameters
    ----------
    first_time_s : float
        Time of a file's first record (s), as stored.

    Returns
    -------
    bool
        True beyond `WEEK_SECONDS_MAX_S` (a week and a day); False for NaN (the
        reader names it).
    """
    return first_time_s > WEEK_SECONDS_MAX_S


FUTURE_SLACK_S = 86_400.0
"""A GPS time up to this long (s) after this computer's clock is still accepted."""


def gps_time_now_s() -> float:
    """The computer's clock as GPS time (s since 1980-01-06), leap seconds not added.

    The ``--gps-week`` bound and `check_not_future` take "now" from here; 18 s do not
    matter to either.
    """
    return time.time() - GPS_EPOCH_UNIX_S


def _date(t_gps_s: float) -> str:
    """The UTC date of a GPS time (leap seconds not counted: a date, not a time)."""
    try:
        return (dt.datetime(1980, 1, 6) + dt.timedelta(seconds=t_gps_s)).date().isoformat()
    except OverflowError:
        return "beyond the year 9999"


def future_time_text(t_s: float, now_gps_s: float) -> str:
    """Why ``t_s`` (s), read as GPS time, cannot be one, and what to do.

    Parameters
    ----------
    t_s : float
        A time read as GPS time, later than ``now_gps_s``.
    now_gps_s : float
        This computer's clock as GPS time (`gps_time_now_s`).
    """
    said = (
        f"{t_s!r} s as GPS time (seconds since 1980-01-06) is {_date(t_s)}, after today "
        f"({_date(now_gps_s)} by this computer's clock)"
    )
    as_gps = t_s - UNIX_MINUS_GPS_S
    if 0.0 <= as_gps <= now_gps_s + FUTURE_SLACK_S:
        return (
            f"{said}: it looks like Unix time (UTC seconds since 1970-01-01, "
            f"{_date(as_gps)} as Unix time, GPS time {round(as_gps, 6)!r} s): {UNIX_ADVICE}"
        )
    return f"{said}: check the time scale and the unit of the times"


def check_not_future(t_s: npt.ArrayLike, where: Callable[[int], str]) -> None:
    """Refuse GPS times later than this computer's clock plus `FUTURE_SLACK_S`.

    Parameters
    ----------
    t_s : array_like, shape (N,)
        Times (s) read as GPS time (GPS seconds of week never reach the limit).
    where : callable
        ``where(row)`` names the row of the first time too late ("traj.csv: line 7, column 't_s'").

    Raises
    ------
    InputError
        A time beyond the limit: most likely Unix time (the message says how to convert
        it) or a computer whose clock is behind.
    """
    t = np.asarray(t_s, dtype=np.float64).ravel()
    if t.size == 0:
        return
    now = gps_time_now_s()
    late = np.flatnonzero(t > now + FUTURE_SLACK_S)
    if late.size == 0:
        return
    row = int(late[0])
    msg = (
        f"{where(row)}: {future_time_text(float(t[row]), now)} (if it is GPS time, this "
        "computer's clock is behind: set it right)"
    )
    raise InputError(msg)
