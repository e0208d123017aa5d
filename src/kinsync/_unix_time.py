"""Unix time against GPS time: how far apart they are, and how to convert.

Unix time (UTC seconds since 1970-01-01, leap seconds not counted) runs 315964800 s
ahead of GPS time (seconds since 1980-01-06) less the leap seconds GPS time has gained
on UTC (18 s since 2017). Two logs of one survey whose times lie that far apart are one
in each (`unix_offset_text`); the readers, `kinsync.clock.fit_clock` and
`kinsync.clock.ClockModel` refuse a GPS time after today, which a Unix time is
(`check_not_future`).
"""

from __future__ import annotations

import datetime as dt
import time
from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from kinsync.errors import InputError

__all__ = [
    "FUTURE_SLACK_S",
    "GPS_EPOCH_UNIX_S",
    "UNIX_ADVICE",
    "UNIX_MINUS_GPS_S",
    "check_not_future",
    "future_time_text",
    "gps_time_now_s",
    "unix_offset_text",
]

GPS_EPOCH_UNIX_S = 315_964_800.0
"""Unix time of the GPS epoch, 1980-01-06T00:00:00 UTC (s)."""

UNIX_MINUS_GPS_S = GPS_EPOCH_UNIX_S - 18.0
"""Unix time less GPS time since 2017 (s): 315964800 s less the 18 leap seconds."""

UNIX_ADVICE = (
    "convert it to GPS time: subtract 315964800 s and add the leap seconds (18 s since "
    "2017; in Python kinsync.clock.utc_to_gps_s)"
)
"""How to turn Unix time into GPS time."""

_SLACK_S = 60.0
"""How far (s) two spans may miss each other once one is shifted by `UNIX_MINUS_GPS_S`
(older leap-second counts, logs that start a little apart)."""


def unix_offset_text(
    a_span_s: tuple[float, float], b_span_s: tuple[float, float], a_name: str, b_name: str
) -> str | None:
    """Which of two inputs looks like Unix time and which GPS time, or None.

    Parameters
    ----------
    a_span_s, b_span_s : tuple of float
        First and last time (s) of each input.
    a_name, b_name : str
        The inputs, for the text ("the points", "the trajectory").

    Returns
    -------
    str or None
        E.g. "the times of the points look like Unix time (UTC seconds since 1970),
        those of the trajectory like GPS time: about 315964782 s apart; convert ...";
        None when the spans do not lie
        that far apart.
    """
    (a0, a1), (b0, b1) = a_span_s, b_span_s
    for unix, gps, (u0, u1), (g0, g1) in (
        (a_name, b_name, (a0, a1), (b0, b1)),
        (b_name, a_name, (b0, b1), (a0, a1)),
    ):
        if u0 - UNIX_MINUS_GPS_S <= g1 + _SLACK_S and u1 - UNIX_MINUS_GPS_S >= g0 - _SLACK_S:
            return (
                f"the times of {unix} look like Unix time (UTC seconds since 1970-01-01), "
                f"those of {gps} like GPS time (seconds since 1980-01-06): about "
                f"{UNIX_MINUS_GPS_S:.0f} s apart; "
                f"{UNIX_ADVICE.replace('convert it', f'convert the times of {unix}')}"
            )
    return None


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
