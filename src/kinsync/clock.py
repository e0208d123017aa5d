"""PPS + ZDA time tagging: the local acquisition clock mapped to GPS time (SPEC section 6).

An acquisition computer time-tags, with its own drifting clock, every edge of a GNSS
receiver's pulse per second (PPS) and the arrival of each ZDA message that names the
UTC second of an edge. This module turns those two logs into a `ClockModel`

    ``t_gps_s = reference_gps_s + (t_local_s - reference_local_s) * (1 + drift_ppm * 1e-6)``

(GPS time: continuous seconds since 1980-01-06T00:00:00, SPEC section 1). ``drift_ppm
> 0`` means the local clock runs slow: one local second lasts ``1 + drift_ppm * 1e-6``
GPS seconds. ``reference_local_s`` is the local time of the first good pulse and
``reference_gps_s`` the fitted GPS time of that instant; ``offset_s = reference_gps_s
- reference_local_s`` is the clock offset there.

Pairing a ZDA with its pulse
    The ZDA's arrival time is the end of its reception. Its transmission started
    ``(len(sentence) + 2) * bits_per_byte / baud`` earlier (the ``+ 2`` is the CR LF;
    `kinsync.budget.serial_transmission_time_s`). By default (``"preceding"``) a ZDA
    names the UTC time of the last PPS edge before its transmission started; with
    ``"following"`` (the other vendor convention, a message announcing the next
    second) it names the first edge after.

Robust fit (`fit_clock`)
    1. The pulses alone fix a 1 s grid: the local period is the median of the
       intervals that are whole seconds within 1 %, the grid phase the circular mean
       of the pulse phases refined by a median; every pulse gets the nearest count.
    2. Pulses off the grid are rejected iteratively: least squares of count on local
       time over the kept pulses, residuals of all pulses, robust scale 1.4826 * MAD,
       keep ``|residual| <= max(6 * scale, 1 us)`` (one pulse per count, the closest),
       until the kept set no longer changes. The threshold starts at 0.1 s and shrinks
       at most tenfold per pass, so an outlier that tilts the first fit cannot drag the
       good pulses out with it. Rejected pulses are *spurious*.
    3. Each ZDA names a count on that grid (the last count before its transmission
       start, or the next one); the difference between the ZDA's GPS second and that
       count is the grid's absolute label. The label most ZDAs agree on (a strict
       majority is required) is adopted; a ZDA that disagrees names the *wrong
       second* and is rejected. A ZDA whose named second has no good pulse (missing,
       or outside the log) is *unpaired* and rejected too.
    4. Final least squares of the GPS seconds of the good pulses on their local times;
       the covariance of offset and drift uses the residual variance ``RSS / (n - 2)``.
       GPS seconds inside the span of good pulses that have no good pulse are
       *missing*.

Optionally (``piecewise=True``) the model also interpolates linearly between
consecutive good pulses, passing exactly through them; outside their span it refuses
by default (`ClockModel.apply`).

Leap seconds
    ``t_gps_s = utc_posix_s - 315964800 + (GPS - UTC)`` with GPS - UTC from
    `LEAP_SECONDS` (18 s since 2017-01-01). A UTC time before the GPS epoch is refused.
    A ZDA reading 23:59:60 on a leap-second day maps to its own GPS second.
"""

from __future__ import annotations

import bisect
import calendar
import math
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import date
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from kinsync._typing import ArrayLike, BoolArray, FloatArray, IntArray
from kinsync._validate import finite_number, positive_number
from kinsync.budget import Parity, serial_transmission_time_s
from kinsync.errors import InputError, ObservabilityError, OutsideSpanError

if TYPE_CHECKING:
    from kinsync.io.nmea import NmeaLog, ZdaRecord

__all__ = [
    "CLOCK_FORMULA",
    "GPS_EPOCH_POSIX_S",
    "LEAP_SECONDS",
    "ClockFit",
    "ClockModel",
    "Convention",
    "OutsidePolicy",
    "clock_model_from_document",
    "fit_clock",
    "fit_clock_to_log",
    "gps_minus_utc_s",
    "gps_to_utc_posix_s",
    "message_transmission_time_s",
    "utc_fields_to_gps_s",
    "utc_to_gps_s",
    "zda_to_gps_s",
]

Convention = Literal["preceding", "following"]
"""Which PPS edge a ZDA names: the last before its transmission, or the next one."""

OutsidePolicy = Literal["extrapolate", "raise", "nan"]
"""What `ClockModel.apply` does with a time outside the span of the fitted pulses."""

CONVENTIONS: tuple[Convention, ...] = ("preceding", "following")
OUTSIDE_POLICIES: tuple[OutsidePolicy, ...] = ("extrapolate", "raise", "nan")

CLOCK_FORMULA = (
    "t_gps_s = reference_gps_s + (t_local_s - reference_local_s) * (1 + drift_ppm * 1e-6)"
)
"""The linear clock model, as written in model files and JSON output."""

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
_LEAP_COUNT_S = np.array([n for _, n in LEAP_SECONDS], dtype=np.int64)
_LEAP_POSIX_LIST = _LEAP_POSIX_S.tolist()

_SECONDS_PER_DAY = 86_400
_PERIOD_TOLERANCE = 0.01
"""Pulse intervals within 1 % of a whole number of seconds set the local period."""
_COARSE_TOLERANCE_S = 0.1
"""Pulses within this of the coarse grid seed the robust fit."""
_REJECT_SIGMAS = 6.0
_MIN_REJECT_THRESHOLD_S = 1e-6
_MAD_TO_SIGMA = 1.4826
_MAX_ITERATIONS = 50
_THRESHOLD_SHRINK = 10.0
_WHOLE_SECOND_TOLERANCE_S = 1e-3
"""A ZDA must name a whole second to this tolerance."""


# --------------------------------------------------------------------------- UTC / GPS


def _utc_iso(utc_posix_s: float) -> str:
    days = math.floor(utc_posix_s / _SECONDS_PER_DAY)
    d = date.fromordinal(date(1970, 1, 1).toordinal() + days)
    rest = utc_posix_s - days * _SECONDS_PER_DAY
    hh, rem = divmod(rest, 3600.0)
    mm, ss = divmod(rem, 60.0)
    return f"{d.isoformat()}T{int(hh):02d}:{int(mm):02d}:{ss:06.3f}"


def _leap_count_at(utc_posix_s: FloatArray) -> IntArray:
    idx = np.searchsorted(_LEAP_POSIX_S, utc_posix_s, side="right")
    padded = np.concatenate(([0], _LEAP_COUNT_S))
    return padded[idx]


def _leap_count_scalar(utc_posix_s: float) -> int:
    i = bisect.bisect_right(_LEAP_POSIX_LIST, utc_posix_s)
    return LEAP_SECONDS[i - 1][1] if i else 0


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
    return int(_leap_count_at(t)[0])


def utc_to_gps_s(utc_posix_s: ArrayLike) -> FloatArray:
    """UTC (POSIX seconds) to GPS time (s since the GPS epoch), vectorised.

    Parameters
    ----------
    utc_posix_s : array_like, shape (...)
        UTC as POSIX seconds, on or after 1980-01-06T00:00:00. A POSIX time cannot
        express 23:59:60; use `utc_fields_to_gps_s` for a leap second itself.

    Returns
    -------
    ndarray, shape (...)
        ``utc_posix_s - 315964800 + (GPS - UTC)``.

    Raises
    ------
    InputError
        Non-numeric or non-finite values, or a time before the GPS epoch.
    """
    try:
        t = np.asarray(utc_posix_s, dtype=np.float64)
    except (TypeError, ValueError) as err:
        msg = f"utc_posix_s: expected numbers ({err})"
        raise InputError(msg) from err
    if not np.all(np.isfinite(t)):
        msg = "utc_posix_s: every time must be finite"
        raise InputError(msg)
    flat = t.reshape(-1)
    _check_after_gps_epoch(flat)
    out = flat - GPS_EPOCH_POSIX_S + _leap_count_at(flat)
    return out.reshape(t.shape)


def gps_to_utc_posix_s(t_gps_s: float) -> float:
    """GPS time to UTC POSIX seconds (inverse of `utc_to_gps_s`).

    During an inserted leap second (23:59:60) POSIX time repeats: the result is the
    POSIX time of the following 00:00:00.
    """
    g = finite_number(t_gps_s, "t_gps_s")
    if g < 0.0:
        msg = f"t_gps_s: {g} is before the GPS epoch"
        raise InputError(msg)
    base = g + GPS_EPOCH_POSIX_S
    for leap in range(len(LEAP_SECONDS), -1, -1):
        if _leap_count_scalar(base - leap) == leap:
            return base - leap
    # Inside an inserted leap second: no POSIX time; give the following 00:00:00.
    for leap in range(len(LEAP_SECONDS)):
        if _leap_count_scalar(base - leap) == leap + 1:
            return float(_LEAP_POSIX_S[leap])
    msg = f"t_gps_s: {g} has no UTC time in the leap-second table"  # pragma: no cover
    raise InputError(msg)  # pragma: no cover


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
    leap_today = _leap_count_scalar(probe)
    if tod >= _SECONDS_PER_DAY:
        next_day = _leap_count_scalar(day_start + _SECONDS_PER_DAY)
        if next_day != leap_today + 1:
            msg = (
                f"UTC {d.isoformat()} 23:59:60: no leap second was inserted at the end of "
                "that day (see kinsync.clock.LEAP_SECONDS)"
            )
            raise InputError(msg)
    return day_start + tod - GPS_EPOCH_POSIX_S + leap_today


def zda_to_gps_s(record: ZdaRecord) -> float:
    """GPS time of the UTC instant a ZDA names (its date and time fields; zones ignored).

    The ZDA's local-zone fields describe the receiver's local time zone; the time and
    date fields are UTC whatever they say.
    """
    return utc_fields_to_gps_s(record.year, record.month, record.day, record.utc_time_of_day_s)


def message_transmission_time_s(
    sentence: str,
    baud: float,
    data_bits: int = 8,
    parity: Parity | str = "none",
    stop_bits: float = 1.0,
) -> float:
    """Time to send an NMEA sentence and its CR LF over a serial line (s).

    ``(len(sentence) + 2) * bits_per_byte / baud`` through
    `kinsync.budget.serial_transmission_time_s` (the FIFO delay of ``budget serial``).

    Parameters
    ----------
    sentence : str
        The sentence as sent, ``$`` to checksum, without the line end.
    baud : float
        Line rate (bit/s).
    data_bits, parity, stop_bits
        Frame format (default 8N1: 10 bits per byte).
    """
    n_bytes = len(sentence.encode("ascii", errors="replace")) + 2
    return serial_transmission_time_s(n_bytes, baud, data_bits, parity, stop_bits)


# --------------------------------------------------------------------------- model


def _readonly(values: ArrayLike) -> FloatArray:
    out = np.array(values, dtype=np.float64, copy=True)
    out.setflags(write=False)
    return out


def _finite_times(t_local_s: ArrayLike, name: str) -> FloatArray:
    try:
        t = np.asarray(t_local_s, dtype=np.float64)
    except (TypeError, ValueError) as err:
        msg = f"{name}: expected numbers ({err})"
        raise InputError(msg) from err
    bad = ~np.isfinite(t)
    if np.any(bad):
        first = int(np.flatnonzero(bad.reshape(-1))[0])
        msg = f"{name}: value at index {first} is not finite; every time must be a number"
        raise InputError(msg)
    return t


@dataclass(frozen=True, eq=False)
class ClockModel:
    """Mapping of a local clock to GPS time (linear, optionally piecewise-linear).

    ``t_gps_s = reference_gps_s + (t_local_s - reference_local_s) * (1 + drift_ppm * 1e-6)``

    Attributes
    ----------
    reference_local_s : float
        Local time of the reference instant (s, local clock); a fit sets it to the
        first good pulse.
    reference_gps_s : float
        GPS time of the reference instant (s since the GPS epoch), full precision.
    drift_ppm : float
        Rate error of the local clock (ppm); > 0: the local clock runs slow.
    span_local_s : tuple of (float, float)
        Local times of the first and last pulse the model was fitted on.
    knots_local_s, knots_gps_s : ndarray, shape (K,), or None
        Piecewise-linear model: local and GPS times of the good pulses (K >= 2,
        strictly increasing), interpolated linearly inside the span; None for the
        linear model.
    """

    reference_local_s: float
    reference_gps_s: float
    drift_ppm: float
    span_local_s: tuple[float, float]
    knots_local_s: FloatArray | None = None
    knots_gps_s: FloatArray | None = None

    def __post_init__(self) -> None:
        for name in ("reference_local_s", "reference_gps_s", "drift_ppm"):
            object.__setattr__(self, name, finite_number(getattr(self, name), f"clock {name}"))
        if abs(self.drift_ppm) >= 1e6:
            msg = f"clock drift_ppm: {self.drift_ppm} ppm would stop or reverse the clock"
            raise InputError(msg)
        span = self.span_local_s
        if not isinstance(span, Sequence | np.ndarray) or len(span) != 2:
            msg = f"clock span_local_s: expected two times (first, last), got {span!r}"
            raise InputError(msg)
        lo = finite_number(span[0], "clock span_local_s[0]")
        hi = finite_number(span[1], "clock span_local_s[1]")
        if hi < lo:
            msg = f"clock span_local_s: last time {hi} is before first time {lo}"
            raise InputError(msg)
        object.__setattr__(self, "span_local_s", (lo, hi))
        if (self.knots_local_s is None) != (self.knots_gps_s is None):
            msg = "clock knots: give both knots_local_s and knots_gps_s, or neither"
            raise InputError(msg)
        if self.knots_local_s is not None and self.knots_gps_s is not None:
            kl = _finite_times(self.knots_local_s, "clock knots_local_s")
            kg = _finite_times(self.knots_gps_s, "clock knots_gps_s")
            if kl.ndim != 1 or kl.shape != kg.shape or len(kl) < 2:
                msg = (
                    "clock knots: knots_local_s and knots_gps_s must be 1-D, of one length, "
                    f"with at least 2 knots; got shapes {kl.shape} and {kg.shape}"
                )
                raise InputError(msg)
            if np.any(np.diff(kl) <= 0.0) or np.any(np.diff(kg) <= 0.0):
                msg = "clock knots: knot times must be strictly increasing"
                raise InputError(msg)
            if (float(kl[0]), float(kl[-1])) != (lo, hi):
                msg = (
                    f"clock knots: the knots span [{kl[0]!r}, {kl[-1]!r}] but span_local_s is "
                    f"[{lo!r}, {hi!r}]"
                )
                raise InputError(msg)
            object.__setattr__(self, "knots_local_s", _readonly(kl))
            object.__setattr__(self, "knots_gps_s", _readonly(kg))

    @property
    def offset_s(self) -> float:
        """Clock offset at the reference: ``reference_gps_s - reference_local_s`` (s)."""
        return self.reference_gps_s - self.reference_local_s

    @property
    def piecewise(self) -> bool:
        """True when the model interpolates between pulses."""
        return self.knots_local_s is not None

    def linear(self) -> ClockModel:
        """The same model without the piecewise knots."""
        return ClockModel(
            reference_local_s=self.reference_local_s,
            reference_gps_s=self.reference_gps_s,
            drift_ppm=self.drift_ppm,
            span_local_s=self.span_local_s,
        )

    def inside_span(self, t_local_s: ArrayLike) -> BoolArray:
        """Which local times lie within the span of the fitted pulses (ends included)."""
        t = _finite_times(t_local_s, "t_local_s")
        lo, hi = self.span_local_s
        return np.asarray((t >= lo) & (t <= hi), dtype=np.bool_)

    def _linear_gps_s(self, t: FloatArray) -> FloatArray:
        scale = 1.0 + self.drift_ppm * 1e-6
        return np.asarray(
            self.reference_gps_s + (t - self.reference_local_s) * scale, dtype=np.float64
        )

    def apply(self, t_local_s: ArrayLike, outside: OutsidePolicy | None = None) -> FloatArray:
        """GPS time of local timestamps.

        Parameters
        ----------
        t_local_s : array_like, shape (...)
            Local clock times (s), finite.
        outside : {"extrapolate", "raise", "nan"}, optional
            Times outside `span_local_s`: ``"extrapolate"`` uses the linear model
            (the piecewise model's linear fit too), ``"raise"`` raises
            `OutsideSpanError`, ``"nan"`` returns NaN there. Default: ``"extrapolate"``
            for the linear model, ``"raise"`` for the piecewise model (never silently).
            `inside_span` says which times were outside.

        Returns
        -------
        ndarray, shape (...)
            GPS seconds since the GPS epoch.

        Raises
        ------
        InputError
            A non-finite time or an unknown policy.
        OutsideSpanError
            A time outside the span with ``outside="raise"``.
        """
        policy: OutsidePolicy = outside or ("raise" if self.piecewise else "extrapolate")
        if policy not in OUTSIDE_POLICIES:
            msg = f"outside must be one of {', '.join(OUTSIDE_POLICIES)}, got {outside!r}"
            raise InputError(msg)
        t = _finite_times(t_local_s, "t_local_s")
        out = self._linear_gps_s(t)
        inside = self.inside_span(t)
        if self.knots_local_s is not None and self.knots_gps_s is not None:
            out = np.where(inside, np.interp(t, self.knots_local_s, self.knots_gps_s), out)
        if not np.all(inside):
            if policy == "raise":
                first = float(t.reshape(-1)[~inside.reshape(-1)][0])
                lo, hi = self.span_local_s
                kind = "piecewise " if self.piecewise else ""
                msg = (
                    f"{int(np.count_nonzero(~inside))} local time(s) lie outside the "
                    f"{kind}clock model's span [{lo!r}, {hi!r}] s (first: {first!r}); "
                    "fit the clock over a longer log, or allow extrapolation with the "
                    "linear model"
                )
                raise OutsideSpanError(msg)
            if policy == "nan":
                out = np.where(inside, out, np.nan)
        return np.asarray(out, dtype=np.float64)

    def as_document(self) -> dict[str, Any]:
        """JSON-ready document with every field needed to apply the model (full precision).

        ``offset_s`` is written for reading; `clock_model_from_document` checks that it
        agrees with the reference times.
        """
        doc: dict[str, Any] = {
            "kind": "kinsync clock model",
            "version": 1,
            "time_scale": "GPS seconds since 1980-01-06T00:00:00",
            "formula": CLOCK_FORMULA,
            "reference_local_s": self.reference_local_s,
            "reference_gps_s": self.reference_gps_s,
            "drift_ppm": self.drift_ppm,
            "offset_s": self.offset_s,
            "span_local_s": list(self.span_local_s),
            "piecewise": None,
        }
        if self.knots_local_s is not None and self.knots_gps_s is not None:
            doc["piecewise"] = {
                "knots_local_s": self.knots_local_s.tolist(),
                "knots_gps_s": self.knots_gps_s.tolist(),
            }
        return doc


def _doc_number(doc: dict[str, Any], key: str, where: str) -> float:
    if key not in doc:
        msg = f"{where}: missing key {key!r}; a clock model needs {CLOCK_FORMULA}"
        raise InputError(msg)
    return finite_number(doc[key], f"{where}: {key}")


def _doc_list(value: object, name: str, where: str) -> FloatArray:
    if not isinstance(value, list) or not all(
        isinstance(v, int | float) and not isinstance(v, bool) for v in value
    ):
        msg = f"{where}: {name} must be a list of numbers"
        raise InputError(msg)
    return np.asarray(value, dtype=np.float64)


def clock_model_from_document(doc: object, source: str = "<document>") -> ClockModel:
    """Build a `ClockModel` from the document `ClockModel.as_document` writes.

    Raises
    ------
    InputError
        Not an object, missing or non-numeric keys, an ``offset_s`` that disagrees
        with ``reference_gps_s - reference_local_s`` by more than 1 us (an edited file),
        or inconsistent piecewise knots.
    """
    if not isinstance(doc, dict):
        msg = f"{source}: expected a JSON object with the clock model's keys"
        raise InputError(msg)
    ref_local = _doc_number(doc, "reference_local_s", source)
    ref_gps = _doc_number(doc, "reference_gps_s", source)
    drift = _doc_number(doc, "drift_ppm", source)
    if "offset_s" in doc:
        offset = finite_number(doc["offset_s"], f"{source}: offset_s")
        if abs(offset - (ref_gps - ref_local)) > 1e-6:
            msg = (
                f"{source}: offset_s {offset!r} disagrees with reference_gps_s - "
                f"reference_local_s = {ref_gps - ref_local!r}; the model is defined by the "
                "reference times: edit those (or delete offset_s)"
            )
            raise InputError(msg)
    span = doc.get("span_local_s")
    if span is None:
        msg = f"{source}: missing key 'span_local_s' (local times of the first and last pulse)"
        raise InputError(msg)
    span_arr = _doc_list(span, "span_local_s", source)
    if span_arr.shape != (2,):
        msg = f"{source}: span_local_s must hold two times, got {span!r}"
        raise InputError(msg)
    knots_local = knots_gps = None
    pw = doc.get("piecewise")
    if pw is not None:
        if not isinstance(pw, dict):
            msg = f"{source}: piecewise must be null or an object with knots_local_s, knots_gps_s"
            raise InputError(msg)
        knots_local = _doc_list(pw.get("knots_local_s"), "piecewise.knots_local_s", source)
        knots_gps = _doc_list(pw.get("knots_gps_s"), "piecewise.knots_gps_s", source)
    try:
        return ClockModel(
            reference_local_s=ref_local,
            reference_gps_s=ref_gps,
            drift_ppm=drift,
            span_local_s=(float(span_arr[0]), float(span_arr[1])),
            knots_local_s=knots_local,
            knots_gps_s=knots_gps,
        )
    except InputError as err:
        msg = f"{source}: {err}"
        raise InputError(msg) from err


# --------------------------------------------------------------------------- fit


@dataclass(frozen=True, eq=False)
class ClockFit:
    """Result of `fit_clock`: the model, its uncertainty and every fault found.

    Attributes
    ----------
    model : ClockModel
        The fitted model (piecewise when asked).
    convention : {"preceding", "following"}
        Which edge a ZDA was taken to name.
    baud : float
        Serial line rate used for the ZDA transmission times (bit/s).
    t_local_s : ndarray, shape (K,)
        Local times of the good pulses (s).
    t_gps_s : ndarray, shape (K,)
        GPS seconds they mark (whole seconds).
    residuals_s : ndarray, shape (K,)
        ``t_gps_s - model(t_local_s)`` for the linear model (GPS seconds).
    residual_rms_s : float
        RMS of the residuals (s).
    offset_std_s, drift_std_ppm : float
        Standard deviations of ``reference_gps_s`` (equivalently ``offset_s``) and
        ``drift_ppm`` from the least-squares covariance scaled by ``RSS / (K - 2)``.
    offset_drift_cov : ndarray, shape (2, 2)
        Covariance of (``reference_gps_s`` in s, ``drift_ppm`` in ppm).
    n_pulses_read : int
        Pulses in the input, ``n_pulses + n_spurious``.
    missing_gps_s : ndarray, shape (n_missing,)
        GPS seconds inside the span of good pulses with no good pulse.
    spurious_t_local_s : ndarray, shape (n_spurious,)
        Local times of the pulses off the 1 s grid (or duplicates of a second).
    n_zda : int
        ZDA messages given to the fit.
    wrong_zda_t_local_s : ndarray, shape (n_wrong_zda,)
        Arrival times of ZDAs whose named second disagrees with the pulse grid.
    unpaired_zda_t_local_s : ndarray, shape (n_unpaired_zda,)
        Arrival times of ZDAs whose named second has no good pulse.
    n_bad_lines : int
        Corrupt lines of the NMEA log (bad checksum, truncated, bad field, bad time,
        ...). Well-formed sentences of types kinsync does not read (GSV, ...) are not
        messages lost, so they are not counted.
    zda_delay_s : float
        Median time from the named edge to the start of a paired ZDA's transmission
        (s): about the receiver's output delay for ``"preceding"``, negative (the delay
        minus 1 s) for ``"following"``. A value out of line with the receiver's manual
        hints at the wrong convention.
    """

    model: ClockModel
    convention: Convention
    baud: float
    t_local_s: FloatArray
    t_gps_s: FloatArray
    residuals_s: FloatArray
    residual_rms_s: float
    offset_std_s: float
    drift_std_ppm: float
    offset_drift_cov: FloatArray
    n_pulses_read: int
    missing_gps_s: FloatArray
    spurious_t_local_s: FloatArray
    n_zda: int
    wrong_zda_t_local_s: FloatArray
    unpaired_zda_t_local_s: FloatArray
    n_bad_lines: int
    zda_delay_s: float

    @property
    def n_pulses(self) -> int:
        """Good pulses used in the fit."""
        return len(self.t_local_s)

    @property
    def n_missing(self) -> int:
        """Whole GPS seconds inside the span with no good pulse."""
        return len(self.missing_gps_s)

    @property
    def n_spurious(self) -> int:
        """Pulses rejected as off the 1 s grid."""
        return len(self.spurious_t_local_s)

    @property
    def n_wrong_zda(self) -> int:
        """ZDAs naming a second that disagrees with the pulse grid."""
        return len(self.wrong_zda_t_local_s)

    @property
    def n_unpaired_zda(self) -> int:
        """ZDAs whose named second has no good pulse."""
        return len(self.unpaired_zda_t_local_s)

    @property
    def n_zda_paired(self) -> int:
        """ZDAs paired with a good pulse."""
        return self.n_zda - self.n_wrong_zda - self.n_unpaired_zda

    @property
    def n_rejected_messages(self) -> int:
        """Bad NMEA lines + wrong ZDAs + unpaired ZDAs."""
        return self.n_bad_lines + self.n_wrong_zda + self.n_unpaired_zda

    def mapped_std_s(self, t_local_s: ArrayLike) -> FloatArray:
        """Standard deviation of the linear model's GPS time at local times (s).

        Parameters
        ----------
        t_local_s : array_like, shape (...)
            Local times (s).

        Returns
        -------
        ndarray, shape (...)
            ``sqrt(J C J^T)`` with ``J = [1, (t - reference_local_s) * 1e-6]``.
        """
        t = _finite_times(t_local_s, "t_local_s")
        x = (t - self.model.reference_local_s) * 1e-6
        c = self.offset_drift_cov
        var = c[0, 0] + 2.0 * x * c[0, 1] + x * x * c[1, 1]
        return np.asarray(np.sqrt(np.maximum(var, 0.0)), dtype=np.float64)

    def as_document(self) -> dict[str, Any]:
        """JSON-ready summary (what ``kinsync clock fit --json`` prints)."""
        m = self.model
        return {
            "offset_s": m.offset_s,
            "drift_ppm": m.drift_ppm,
            "reference_local_s": m.reference_local_s,
            "reference_gps_s": m.reference_gps_s,
            "formula": CLOCK_FORMULA,
            "offset_std_s": self.offset_std_s,
            "drift_std_ppm": self.drift_std_ppm,
            "residual_rms_s": self.residual_rms_s,
            "span_local_s": list(m.span_local_s),
            "piecewise": m.piecewise,
            "convention": self.convention,
            "baud": self.baud,
            "zda_delay_s": self.zda_delay_s,
            "n_pulses": self.n_pulses,
            "n_pulses_read": self.n_pulses_read,
            "n_missing": self.n_missing,
            "n_spurious": self.n_spurious,
            "n_zda": self.n_zda,
            "n_zda_paired": self.n_zda_paired,
            "n_wrong_zda": self.n_wrong_zda,
            "n_unpaired_zda": self.n_unpaired_zda,
            "n_bad_lines": self.n_bad_lines,
            "n_rejected_messages": self.n_rejected_messages,
            "missing_gps_s": self.missing_gps_s.tolist(),
            "spurious_t_local_s": self.spurious_t_local_s.tolist(),
            "wrong_zda_t_local_s": self.wrong_zda_t_local_s.tolist(),
            "unpaired_zda_t_local_s": self.unpaired_zda_t_local_s.tolist(),
        }


def _increasing_times(values: ArrayLike, name: str) -> FloatArray:
    t = _finite_times(values, name)
    if t.ndim != 1:
        msg = f"{name}: expected a 1-D array of times, got shape {t.shape}"
        raise InputError(msg)
    steps = np.diff(t)
    if np.any(steps <= 0.0):
        i = int(np.flatnonzero(steps <= 0.0)[0]) + 1
        msg = (
            f"{name}: times must be strictly increasing; index {i} ({t[i]!r}) does not "
            f"follow index {i - 1} ({t[i - 1]!r}); sort the log and remove duplicates"
        )
        raise InputError(msg)
    return t


def _local_period_s(t: FloatArray) -> float:
    """Median local duration of one GPS second, from the whole-second pulse intervals."""
    d = np.diff(t)
    k = np.rint(d)
    ok = (k >= 1.0) & (np.abs(d - k) <= _PERIOD_TOLERANCE * k)
    if not np.any(ok):
        msg = (
            "no two pulses are a whole number of seconds apart (within 1 %): the pulse log "
            "does not look like a pulse per second; check the file and its time unit"
        )
        raise InputError(msg)
    return float(np.median(d[ok] / k[ok]))


def _wrap(x: FloatArray) -> FloatArray:
    return np.asarray(x - np.rint(x), dtype=np.float64)


def _line_fit(x: FloatArray, y: FloatArray) -> tuple[float, float]:
    """Least-squares intercept at x = 0 and slope of y on x."""
    xm = float(np.mean(x))
    ym = float(np.mean(y))
    sxx = float(np.sum((x - xm) ** 2))
    slope = float(np.sum((x - xm) * (y - ym)) / sxx) if sxx > 0.0 else 0.0
    return ym - slope * xm, slope


def _keep_closest_per_label(labels: IntArray, resid: FloatArray, keep: BoolArray) -> BoolArray:
    idx = np.flatnonzero(keep)
    order = idx[np.lexsort((np.abs(resid[idx]), labels[idx]))]
    first = np.ones(len(order), dtype=np.bool_)
    first[1:] = labels[order][1:] != labels[order][:-1]
    out = np.zeros_like(keep)
    out[order[first]] = True
    return out


def _grid_labels(t: FloatArray) -> tuple[IntArray, BoolArray, float, float]:
    """Label each pulse with a count of seconds and flag the pulses on the 1 s grid.

    Returns labels (relative counts), the good-pulse mask, and the relative model
    ``count(t) = alpha + beta * (t - t[0])`` fitted on the good pulses.
    """
    x = t - t[0]
    period = _local_period_s(t)
    beta = 1.0 / period
    tau = x * beta
    phase = _wrap(tau)
    phi0 = float(np.angle(np.mean(np.exp(2j * np.pi * phase))) / (2.0 * np.pi))
    near = np.abs(_wrap(phase - phi0)) < _COARSE_TOLERANCE_S
    if np.count_nonzero(near) < 3:
        msg = (
            f"the {len(t)} pulses do not share a 1 s grid (fewer than 3 within 0.1 s of "
            "a common phase); check that the file holds PPS edges in seconds"
        )
        raise ObservabilityError(msg)
    phi0 += float(np.median(_wrap(phase[near] - phi0)))
    # Counts start at the grid position of the first pulse: alpha = -phi0.
    alpha = -phi0
    labels = np.rint(alpha + beta * x).astype(np.int64)
    resid = labels - (alpha + beta * x)
    threshold = _COARSE_TOLERANCE_S
    good = _keep_closest_per_label(labels, resid, np.abs(resid) < threshold)
    for _ in range(_MAX_ITERATIONS):
        if np.count_nonzero(good) < 3:
            break
        alpha, beta = _line_fit(x[good], labels[good].astype(np.float64))
        u = alpha + beta * x
        labels = np.rint(u).astype(np.int64)
        resid = labels - u
        r_good = resid[good]
        scale = _MAD_TO_SIGMA * float(np.median(np.abs(r_good - np.median(r_good))))
        target = max(_REJECT_SIGMAS * scale, _MIN_REJECT_THRESHOLD_S)
        # Shrink by at most 10x per pass: a fit tilted by an outlier still inside the
        # coarse tolerance must not reject the good pulses along with it.
        threshold = max(target, threshold / _THRESHOLD_SHRINK)
        new_good = _keep_closest_per_label(labels, resid, np.abs(resid) <= threshold)
        if np.array_equal(new_good, good) and threshold == target:
            break
        good = new_good
    if np.count_nonzero(good) < 3:
        msg = (
            f"only {int(np.count_nonzero(good))} of {len(t)} pulses lie on a common 1 s grid; "
            "at least 3 are needed to fit offset, drift and their uncertainty"
        )
        raise ObservabilityError(msg)
    return labels, good, alpha, beta


def _zda_arrays(
    zda_t_local_s: ArrayLike, zda_gps_s: ArrayLike, zda_n_bytes: ArrayLike
) -> tuple[FloatArray, FloatArray, IntArray]:
    z_t = _finite_times(zda_t_local_s, "zda_t_local_s").reshape(-1)
    z_gps = _finite_times(zda_gps_s, "zda_gps_s").reshape(-1)
    try:
        z_bytes = np.asarray(zda_n_bytes, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError) as err:
        msg = f"zda_n_bytes: expected whole numbers ({err})"
        raise InputError(msg) from err
    if len(z_t) == 0:
        msg = "no ZDA message: the GPS second of the pulses cannot be named without one"
        raise InputError(msg)
    if not (len(z_t) == len(z_gps) == len(z_bytes)):
        msg = (
            "zda_t_local_s, zda_gps_s and zda_n_bytes must have one length, got "
            f"{len(z_t)}, {len(z_gps)} and {len(z_bytes)}"
        )
        raise InputError(msg)
    if not np.all(np.isfinite(z_bytes)) or np.any(z_bytes != np.rint(z_bytes)):
        msg = "zda_n_bytes: every byte count must be a whole number"
        raise InputError(msg)
    return z_t, z_gps, z_bytes.astype(np.int64)


def _majority_label(k_zda: FloatArray) -> tuple[int, BoolArray]:
    """The absolute label most ZDAs give the grid (strict majority) and who disagrees."""
    k_int = np.rint(k_zda)
    whole = np.abs(k_zda - k_int) <= _WHOLE_SECOND_TOLERANCE_S
    values, counts = np.unique(k_int[whole], return_counts=True)
    if len(values) == 0 or 2 * int(counts.max()) <= len(k_zda):
        detail = ", ".join(
            f"{int(c)} x {v - values[0]:+.0f} s" for v, c in zip(values, counts, strict=True)
        )
        msg = (
            f"the {len(k_zda)} ZDA messages do not agree on which GPS second the pulses mark "
            f"(no strict majority: {detail or 'none names a whole second'}); check "
            "--convention, --baud and that the two logs come from the same clock"
        )
        raise InputError(msg)
    k = int(values[np.argmax(counts)])
    return k, np.asarray(~(whole & (k_int == k)), dtype=np.bool_)


def _final_least_squares(
    t_good: FloatArray, gps_good: FloatArray
) -> tuple[float, float, FloatArray, FloatArray]:
    """Reference GPS time, drift (ppm), residuals and covariance of the linear model.

    Solved in small numbers, ``(gps - gps0) - x = a + e x`` with ``x = t - t_good[0]``,
    so the drift comes out directly and the GPS magnitude costs no precision.
    """
    xg = t_good - t_good[0]
    yg = gps_good - gps_good[0]
    a, e = _line_fit(xg, yg - xg)
    resid = yg - (a + xg * (1.0 + e))
    n = len(xg)
    sigma2 = float(np.sum(resid**2)) / (n - 2)
    xm = float(np.mean(xg))
    sxx = float(np.sum((xg - xm) ** 2))
    cov = np.array(
        [
            [sigma2 * (1.0 / n + xm * xm / sxx), -sigma2 * xm / sxx * 1e6],
            [-sigma2 * xm / sxx * 1e6, sigma2 / sxx * 1e12],
        ]
    )
    return float(gps_good[0]) + a, e * 1e6, resid, cov


def fit_clock(
    pps_t_local_s: ArrayLike,
    zda_t_local_s: ArrayLike,
    zda_gps_s: ArrayLike,
    zda_n_bytes: ArrayLike,
    *,
    baud: float = 115200.0,
    convention: Convention = "preceding",
    piecewise: bool = False,
    n_bad_lines: int = 0,
    data_bits: int = 8,
    parity: Parity | str = "none",
    stop_bits: float = 1.0,
) -> ClockFit:
    """Fit the local clock -> GPS time model from PPS edges and ZDA messages, robustly.

    Parameters
    ----------
    pps_t_local_s : array_like, shape (N,)
        Local times of the detected PPS edges (s), strictly increasing, N >= 3.
    zda_t_local_s : array_like, shape (M,)
        Local arrival times (end of reception) of the ZDA messages (s), M >= 1.
    zda_gps_s : array_like, shape (M,)
        GPS time each ZDA names (s since the GPS epoch; `zda_to_gps_s`).
    zda_n_bytes : array_like, shape (M,)
        Bytes of each ZDA on the wire, line end included (``len(sentence) + 2``).
    baud : float
        Serial line rate (bit/s).
    convention : {"preceding", "following"}
        A ZDA names the last edge before its transmission started, or the next one.
    piecewise : bool
        Also interpolate linearly between consecutive good pulses.
    n_bad_lines : int
        NMEA lines already rejected by the reader (counted in ``n_rejected_messages``).
    data_bits, parity, stop_bits
        Serial frame format (default 8N1).

    Returns
    -------
    ClockFit

    Raises
    ------
    InputError
        Too few pulses, no ZDA, mismatched shapes, non-finite or unordered times,
        pulses not one second apart, ZDAs that do not agree on the second (no strict
        majority), an unknown convention.
    ObservabilityError
        Fewer than 3 pulses on a common 1 s grid.
    """
    if convention not in CONVENTIONS:
        msg = f"convention must be 'preceding' or 'following', got {convention!r}"
        raise InputError(msg)
    rate = positive_number(baud, "baud")
    if isinstance(n_bad_lines, bool) or int(n_bad_lines) != n_bad_lines or n_bad_lines < 0:
        msg = f"n_bad_lines must be a non-negative whole number, got {n_bad_lines!r}"
        raise InputError(msg)
    t = _increasing_times(pps_t_local_s, "pps_t_local_s")
    if len(t) < 3:
        msg = f"the pulse log holds {len(t)} pulse(s); at least 3 are needed to fit a clock"
        raise InputError(msg)
    z_t, z_gps, z_bytes = _zda_arrays(zda_t_local_s, zda_gps_s, zda_n_bytes)
    tx_s = np.array(
        [serial_transmission_time_s(int(n), rate, data_bits, parity, stop_bits) for n in z_bytes]
    )

    labels, good, alpha, beta = _grid_labels(t)
    # Grid count each ZDA names: last count before the transmission start, or the next.
    start_count = alpha + beta * (z_t - tx_s - t[0])
    named = np.floor(start_count).astype(np.int64) + (1 if convention == "following" else 0)
    k, wrong = _majority_label(z_gps - named)

    gps_all = (labels + k).astype(np.float64)
    t_good = t[good]
    gps_good = gps_all[good]
    unpaired = ~wrong & ~np.isin(named, labels[good])

    ref_gps, drift_ppm, resid, cov = _final_least_squares(t_good, gps_good)
    ref_local = float(t_good[0])
    span = (float(t_good[0]), float(t_good[-1]))
    model = ClockModel(
        reference_local_s=ref_local,
        reference_gps_s=ref_gps,
        drift_ppm=drift_ppm,
        span_local_s=span,
        knots_local_s=t_good if piecewise else None,
        knots_gps_s=gps_good if piecewise else None,
    )
    full = np.arange(int(labels[good][0]), int(labels[good][-1]) + 1)
    missing = np.setdiff1d(full, labels[good]) + k
    paired = ~wrong & ~unpaired
    if np.any(paired):
        start_gps = model.linear().apply(z_t[paired] - tx_s[paired])
        zda_delay = float(np.median(start_gps - z_gps[paired]))
    else:
        zda_delay = math.nan
    return ClockFit(
        model=model,
        convention=convention,
        baud=rate,
        t_local_s=_readonly(t_good),
        t_gps_s=_readonly(gps_good),
        residuals_s=_readonly(resid),
        residual_rms_s=float(np.sqrt(np.mean(resid**2))),
        offset_std_s=math.sqrt(cov[0, 0]),
        drift_std_ppm=math.sqrt(cov[1, 1]),
        offset_drift_cov=_readonly(cov),
        n_pulses_read=len(t),
        missing_gps_s=_readonly(missing.astype(np.float64)),
        spurious_t_local_s=_readonly(t[~good]),
        n_zda=len(z_t),
        wrong_zda_t_local_s=_readonly(z_t[wrong]),
        unpaired_zda_t_local_s=_readonly(z_t[unpaired]),
        n_bad_lines=int(n_bad_lines),
        zda_delay_s=zda_delay,
    )


def fit_clock_to_log(
    pps_t_local_s: ArrayLike,
    log: NmeaLog,
    *,
    baud: float = 115200.0,
    convention: Convention = "preceding",
    piecewise: bool = False,
    data_bits: int = 8,
    parity: Parity | str = "none",
    stop_bits: float = 1.0,
) -> ClockFit:
    """`fit_clock` on an NMEA log: its ZDAs, their sentence lengths and its rejected lines.

    Parameters
    ----------
    pps_t_local_s : array_like, shape (N,)
        Local times of the PPS edges (s), strictly increasing.
    log : NmeaLog
        The parsed NMEA log (`kinsync.io.nmea.read_nmea_log`); every rejected line
        counts in ``n_rejected_messages``.
    baud, convention, piecewise, data_bits, parity, stop_bits
        As in `fit_clock`.

    Raises
    ------
    InputError
        No ZDA in the log (naming the file), a ZDA whose date has no GPS time (before
        1980-01-06; naming its line), or any error of `fit_clock`.
    """
    zda_t, zda_records, zda_sentences, zda_lines = _log_zdas(log)
    if len(zda_records) == 0:
        msg = (
            f"{log.source}: no valid ZDA sentence in the NMEA log ({len(log.records)} valid "
            f"sentence(s), {len(log.rejected)} rejected line(s)); the receiver must output "
            "ZDA to name the pulses' GPS second"
        )
        raise InputError(msg)
    gps = np.empty(len(zda_records))
    for i, record in enumerate(zda_records):
        try:
            gps[i] = zda_to_gps_s(record)
        except InputError as err:
            where = f"line {zda_lines[i]}" if zda_lines else f"ZDA number {i + 1}"
            msg = f"{log.source}: {where}: {err}"
            raise InputError(msg) from err
    n_bytes = np.array([len(s.encode("ascii", errors="replace")) + 2 for s in zda_sentences])
    return fit_clock(
        pps_t_local_s,
        zda_t,
        gps,
        n_bytes,
        baud=baud,
        convention=convention,
        piecewise=piecewise,
        n_bad_lines=sum(1 for r in log.rejected if not r.reason.startswith(_UNSUPPORTED_REASON)),
        data_bits=data_bits,
        parity=parity,
        stop_bits=stop_bits,
    )


_UNSUPPORTED_REASON = "unsupported sentence type"


def _log_zdas(log: NmeaLog) -> tuple[FloatArray, list[ZdaRecord], list[str], list[int]]:
    """ZDA arrival times, records, raw sentences and file lines of a log, in log order."""
    from kinsync.io.nmea import ZdaRecord  # noqa: PLC0415  (io imports stay out of import time)

    idx = [i for i, r in enumerate(log.records) if isinstance(r, ZdaRecord)]
    records = [r for r in log.records if isinstance(r, ZdaRecord)]
    t = np.asarray(log.t_local_s, dtype=np.float64)[idx]
    sentences = [log.raw_sentences[i] for i in idx]
    lines = [log.lines[i] for i in idx] if log.lines else []
    return t, records, sentences, lines
