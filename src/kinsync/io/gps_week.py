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
`FUTURE_SLACK_S`), the clock the ``--gps-week`` bound uses too (`gps_time_now_s`);
both live in `kinsync._unix_time`, which the algorithms use too (a clock fit refuses
ZDA times in Unix seconds the same way), and are named here for the readers.
"""

from __future__ import annotations

from kinsync._unix_time import (
    FUTURE_SLACK_S,
    GPS_EPOCH_UNIX_S,
    UNIX_MINUS_GPS_S,
    check_not_future,
    future_time_text,
    gps_time_now_s,
)

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
