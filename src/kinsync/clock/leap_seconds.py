"""Leap seconds: UTC <-> GPS time (SPEC section 1).

``t_gps_s = utc_posix_s - 315964800 + (GPS - UTC)`` with GPS - UTC from the one table
`LEAP_SECONDS` (18 s since 2017-01-01), looked up in one place (`leap_count_s`). A
UTC time before the GPS epoch, or after 2100 (`kinsync.clock.model.GPS_TIME_SPAN_S`: POSIX
milliseconds given for seconds), is refused. A UTC 23:59:60 on a leap-second day maps to
its own GPS second (`utc_fields_to_gps_s`); POSIX time cannot express it.
"""

from __future__ import annotations

import calendar
import time
from collections.abc import Sequence
from datetime import date
from typing import TYPE_CHECKING, overload

import numpy as np

from kinsync._typing import ArrayLike, FloatArray, IntArray
from kinsync._validate import finite_number, time_array
from kinsync.clock.model import GPS_TIME_SPAN_S
from kinsync.errors import InputError

if TYPE_CHECKING:
    from kinsync.messages import ZdaRecord


GPS_EPOCH_POSIX_S = 315_964_800
"""The GPS epoch 1980-01-06T00:00:00 UTC in POSIX seconds."""


LEAP_SECONDS: tuple[tuple[str, int], ...] = (
    ("1981-07-01", 1),
    ("1982-07-01", 2),
    ("1983-07-01", 3),
    ("1985-07-01", 4),
    ("1988-01-01", 5),
    ("1990-01-01", 6),
    ("1991-01-01", 7),
    ("1992-07-01", 8),
    ("1993-07-01", 9),
    ("1994-07-01", 10),
    ("1996-01-01", 11),
    ("1997-07-01", 12),
    ("1999-01-01", 13),
    ("2006-01-01", 14),
    ("2009-01-01", 15),
    ("2012-07-01", 16),
    ("2015-07-01", 17),
    ("2017-01-01", 18),
)
"""(UTC date from which it applies, GPS - UTC in s); 0 from the GPS epoch to 1981-07-01.

Each leap second was inserted as 23:59:60 UTC on the day before the date. Add a row
when the IERS announces a new one (Bulletin C)."""


def _posix_of_date(iso: str) -> int:
    d = date.fromisoformat(iso)
    return calendar.timegm((d.year, d.month, d.day, 0, 0, 0, 0, 0, 0))


_LEAP_POSIX_S = np.array([_posix_of_date(d) for d, _ in LEAP_SECONDS], dtype=np.float64)


_LEAP_COUNT_S = np.array([0] + [n for _, n in LEAP_SECONDS], dtype=np.int64)
_LEAP_BASE_S = _LEAP_POSIX_S + _LEAP_COUNT_S[1:]
"""``t_gps_s + GPS_EPOCH_POSIX_S`` from which each leap second is in force."""
_SECONDS_PER_DAY = 86_400


def _utc_iso(utc_posix_s: float) -> str:
    """ISO 8601 UTC of a POSIX time, to the millisecond.

    Rounded before it is split into fields, so that 59.9996 s carries into the next
    minute (it printed "53:60.000").
    """
    days, ms = divmod(round(utc_posix_s * 1000.0), _SECONDS_PER_DAY * 1000)
    d = date.fromordinal(date(1970, 1, 1).toordinal() + days)
    hh, ms = divmod(ms, 3_600_000)
    mm, ms = divmod(ms, 60_000)
    return f"{d.isoformat()}T{hh:02d}:{mm:02d}:{ms // 1000:02d}.{ms % 1000:03d}"


def leap_count_s(utc_posix_s: ArrayLike) -> IntArray:
    """GPS - UTC (s) in force at UTC instants: the one lookup of `LEAP_SECONDS`.

    Parameters
    ----------
    utc_posix_s : array_like, shape (...)
        UTC as POSIX seconds (not checked: 0 before 1981-07-01 whatever the time).

    Returns
    -------
    ndarray of int, shape (...)
    """
    idx = np.searchsorted(_LEAP_POSIX_S, utc_posix_s, side="right")
    out: IntArray = _LEAP_COUNT_S[idx]
    return out


def _check_after_gps_epoch(utc_posix_s: FloatArray) -> None:
    early = utc_posix_s < GPS_EPOCH_POSIX_S
    if np.any(early):
        first = float(utc_posix_s[early][0])
        msg = (
            f"UTC {_utc_iso(first)} is before the GPS epoch 1980-01-06T00:00:00: GPS time "
            "is not defined there; check the date fields of the log"
        )
        raise InputError(msg)


def gps_minus_utc_s(utc_posix_s: float) -> int:
    """GPS - UTC (leap seconds since 1980) in force at a UTC instant.

    Parameters
    ----------
    utc_posix_s : float
        UTC as POSIX seconds (s since 1970-01-01T00:00:00 UTC, leap seconds not
        counted), on or after the GPS epoch.

    Returns
    -------
    int
        Seconds (0 before 1981-07-01, 18 since 2017-01-01).

    Raises
    ------
    InputError
        A non-finite time or a time before the GPS epoch.
    """
    t = np.array([finite_number(utc_posix_s, "utc_posix_s")])
    _check_after_gps_epoch(t)
    return int(leap_count_s(t)[0])


def utc_to_gps_s(utc_posix_s: ArrayLike) -> FloatArray:
    """UTC (POSIX seconds or datetime64) to GPS time (s since the GPS epoch), vectorised.

    Parameters
    ----------
    utc_posix_s : array_like, shape (...)
        UTC as POSIX seconds (float64), or as a numpy datetime64 array of any unit
        (read as UTC: datetime64 counts no leap seconds, as POSIX time), from
        1980-01-06T00:00:00 to 2100-01-01. A POSIX time cannot express 23:59:60; use
        `utc_fields_to_gps_s` for a leap second itself.

    Returns
    -------
    ndarray, shape (...)
        ``utc_posix_s - 315964800 + (GPS - UTC)``, within
        `kinsync.clock.model.GPS_TIME_SPAN_S`.

    Raises
    ------
    InputError
        Non-numeric or non-finite values (NaT), timedelta64, a float dtype too coarse
        for 1 us (float32), a time before the GPS epoch, or one after 2100 (POSIX
        milliseconds, microseconds or nanoseconds given for seconds).
    """
    raw = np.asarray(utc_posix_s)
    if raw.dtype.kind == "M":  # any unit to float seconds; NaT becomes NaN
        raw = (raw - np.datetime64(0, "s")) / np.timedelta64(1, "s")
    t = time_array(raw, "utc_posix_s", clock="utc")
    if not np.all(np.isfinite(t)):
        msg = "utc_posix_s: every time must be finite"
        raise InputError(msg)
    flat = t.reshape(-1)
    _check_after_gps_epoch(flat)
    out = flat - GPS_EPOCH_POSIX_S + leap_count_s(flat)
    _check_before_2100(flat, out)
    return out.reshape(t.shape)


_UNITS_PER_S = (
    ("milliseconds", 1e3, "1000"),
    ("microseconds", 1e6, "1e6"),
    ("nanoseconds", 1e9, "1e9"),
)
_POSIX_2100_S = _posix_of_date("2100-01-01")


def _check_before_2100(utc_posix_s: FloatArray, t_gps_s: FloatArray) -> None:
    """Refuse a UTC time whose GPS time lies beyond `GPS_TIME_SPAN_S` (after 2100)."""
    late = t_gps_s > GPS_TIME_SPAN_S[1]
    if not np.any(late):
        return
    i = int(np.flatnonzero(late)[0])
    value = float(utc_posix_s[i])
    hint = "check the unit"
    for unit, per_s, per_s_text in _UNITS_PER_S:
        if GPS_EPOCH_POSIX_S <= value / per_s <= _POSIX_2100_S:
            hint = f"are these {unit} since 1970? divide them by {per_s_text}"
            break
    msg = (
        f"utc_posix_s: {value!r} (index {i}) is after the year 2100, not a UTC time of a "
        f"survey in POSIX seconds (about 1.7e9 in 2024); {hint}"
    )
    raise InputError(msg)


@overload
def gps_to_utc_posix_s(t_gps_s: float) -> float: ...


@overload
def gps_to_utc_posix_s(t_gps_s: FloatArray | Sequence[float]) -> FloatArray: ...


def gps_to_utc_posix_s(t_gps_s: ArrayLike) -> float | FloatArray:
    """GPS time to UTC POSIX seconds (inverse of `utc_to_gps_s`), vectorised.

    During an inserted leap second (23:59:60) POSIX time repeats: the result is the
    POSIX time of the following 00:00:00. Each time gets the leap seconds in force at
    it.

    Parameters
    ----------
    t_gps_s : float or array_like, shape (...)
        GPS time (s since 1980-01-06T00:00:00 UTC, leap seconds not counted), >= 0:
        a number, or an array of any shape (the 0-d array `utc_to_gps_s` returns for
        one time too).

    Returns
    -------
    float or ndarray, shape (...)
        UTC as POSIX seconds (s since 1970-01-01T00:00:00 UTC, leap seconds not
        counted): a float for a number, an array of the same shape for an array.

    Raises
    ------
    InputError
        A time that is not a finite number (text, datetime64, float32: as `utc_to_gps_s`
        refuses them), or negative (before the GPS epoch), naming its index.
    """
    g = time_array(t_gps_s, "t_gps_s", clock="gps")
    flat = g.reshape(-1)
    bad = ~(np.isfinite(flat) & (flat >= 0.0))
    if np.any(bad):
        i = int(np.flatnonzero(bad)[0])
        value = float(flat[i])
        where = "" if g.ndim == 0 else f" (index {i}, 0-based)"
        why = "is before the GPS epoch" if value < 0.0 else "is not finite"
        msg = f"t_gps_s: {value!r}{where} {why}"
        raise InputError(msg)
    base = flat + GPS_EPOCH_POSIX_S
    # Leap second k is in force from UTC _LEAP_POSIX_S[k-1], that is from base = that + k.
    n = np.searchsorted(_LEAP_BASE_S, base, side="right")
    utc = base - n
    # Inside an inserted leap second (the base second before the next count): no POSIX
    # time; the following 00:00:00.
    nxt = np.minimum(n, len(_LEAP_BASE_S) - 1)
    inside = (n < len(_LEAP_BASE_S)) & (base >= _LEAP_BASE_S[nxt] - 1.0)
    out: FloatArray = np.where(inside, _LEAP_POSIX_S[nxt], utc)
    if g.ndim == 0 and not isinstance(t_gps_s, np.ndarray):
        return float(out[0])
    return out.reshape(g.shape)


def utc_fields_to_gps_s(year: int, month: int, day: int, time_of_day_s: float) -> float:
    """A UTC calendar date and time of day to GPS time, leap seconds included.

    Parameters
    ----------
    year, month, day : int
        UTC date (Gregorian), on or after 1980-01-06.
    time_of_day_s : float
        Seconds since 00:00:00 UTC of that day, in [0, 86400); up to 86401 on a day
        that ends with an inserted leap second (23:59:60 is 86400).

    Returns
    -------
    float
        GPS seconds since 1980-01-06T00:00:00.

    Raises
    ------
    InputError
        An invalid date, a time of day out of range, or a date before the GPS epoch.
    """
    try:
        d = date(int(year), int(month), int(day))
    except (TypeError, ValueError) as err:
        msg = f"UTC date {year}-{month}-{day} is not a valid date ({err})"
        raise InputError(msg) from err
    tod = finite_number(time_of_day_s, "time_of_day_s")
    day_start = float(calendar.timegm((d.year, d.month, d.day, 0, 0, 0, 0, 0, 0)))
    if day_start < GPS_EPOCH_POSIX_S:
        msg = (
            f"UTC date {d.isoformat()} is before the GPS epoch 1980-01-06: GPS time is not "
            "defined there; check the date fields of the log"
        )
        raise InputError(msg)
    if tod < 0.0 or tod >= _SECONDS_PER_DAY + 1:
        msg = f"UTC time of day {tod} s on {d.isoformat()} is outside [0, 86400]"
        raise InputError(msg)
    # The count in force during the day's last regular second applies to 23:59:60 too.
    probe = day_start + min(tod, _SECONDS_PER_DAY - 1.0)
    leap_today = int(leap_count_s(probe))
    if tod >= _SECONDS_PER_DAY:
        next_day = int(leap_count_s(day_start + _SECONDS_PER_DAY))
        if next_day != leap_today + 1:
            msg = (
                f"UTC {d.isoformat()} 23:59:60: no leap second was inserted at the end of "
                "that day (see kinsync.clock.leap_seconds.LEAP_SECONDS)"
            )
            raise InputError(msg)
    return day_start + tod - GPS_EPOCH_POSIX_S + leap_today


def zda_to_gps_s(record: ZdaRecord) -> float:
    """GPS time of the UTC instant a ZDA names (its date and time fields; zones ignored).

    The ZDA's local-zone fields describe the receiver's local time zone; the time and
    date fields are UTC whatever they say.

    Parameters
    ----------
    record : ZdaRecord
        A parsed ZDA message: its UTC date (``year``, ``month``, ``day``) and time of
        day (``utc_time_of_day_s``, s; 86400 up to 86401 is 23:59:60).

    Returns
    -------
    float
        GPS seconds since 1980-01-06T00:00:00 (`utc_fields_to_gps_s`).

    Raises
    ------
    InputError
        A date before the GPS epoch, or a 23:59:60 on a day that ended without an
        inserted leap second.
    """
    return utc_fields_to_gps_s(record.year, record.month, record.day, record.utc_time_of_day_s)


PLAUSIBLE_DATE_GPS_S = 315_187_206.0
"""GPS time of 1990-01-01T00:00:00 UTC. Absolute GPS times of kinematic surveys come later;
earlier "GPS" times are taken as relative times (a simulation starting at 0), not dates."""


def gps_to_decimal_year(t_gps_s: float) -> float:
    """GPS time to a decimal year of UTC (2024-07-02T00:00 -> 2024.5), e.g. a coordinate epoch.

    Parameters
    ----------
    t_gps_s : float
        GPS time (s since 1980-01-06T00:00:00 UTC, leap seconds not counted).
    """
    utc = gps_to_utc_posix_s(t_gps_s)
    year = time.gmtime(utc).tm_year
    start = calendar.timegm((year, 1, 1, 0, 0, 0))
    end = calendar.timegm((year + 1, 1, 1, 0, 0, 0))
    return year + (utc - start) / (end - start)


def gps_to_utc_iso(t_gps_s: float) -> str:
    """GPS time as an ISO 8601 UTC date and time to the millisecond (``2024-07-02T00:00:00.000``).

    The time is rounded to the millisecond first, then converted: 59.9996 s is the next
    minute's 00.000; during an inserted leap second the result is ``23:59:60.xxx``.

    Raises
    ------
    InputError
        ``t_gps_s`` not a finite number, or negative (before the GPS epoch).
    """
    g = _gps_seconds(t_gps_s)
    whole_s, ms = divmod(round(g * 1000.0), 1000)
    utc = gps_to_utc_posix_s(float(whole_s))
    if float(utc_to_gps_s(utc)) != whole_s:  # inside a leap second: utc is the next 00:00
        return f"{_utc_iso(utc - 1.0)[:-6]}60.{ms:03d}"
    return _utc_iso(utc + ms / 1000.0)


def _gps_seconds(t_gps_s: float) -> float:
    """``t_gps_s`` as a float, refused when not finite or before the GPS epoch."""
    g = finite_number(t_gps_s, "t_gps_s")
    if g < 0.0:
        msg = f"t_gps_s: {g} is before the GPS epoch"
        raise InputError(msg)
    return g
