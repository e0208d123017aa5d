"""Clocks: local acquisition clocks mapped to GPS time (SPEC sections 1, 4 and 6).

- `kinsync.clock.leap_seconds`: the leap-second table, UTC <-> GPS time.
- `kinsync.clock.model`: `ClockModel`, offset and drift (optionally piecewise) of a
  local clock against GPS time.
- `kinsync.clock.fit`: `fit_clock`, the robust fit of a `ClockModel` to PPS edges and
  ZDA messages (PPS time tagging).
- `kinsync.clock.profile`: `ProfileClock`, the clock of a profile scanner's mirror
  ``t(n, phi) = t0 + (n + phi / 2 pi) T`` (Method B).
"""

from kinsync.clock.fit import (
    CONVENTIONS,
    ClockFit,
    Convention,
    fit_clock,
    fit_clock_to_log,
    message_transmission_time_s,
)
from kinsync.clock.leap_seconds import (
    GPS_EPOCH_POSIX_S,
    LEAP_SECONDS,
    gps_minus_utc_s,
    gps_to_utc_posix_s,
    utc_fields_to_gps_s,
    utc_to_gps_s,
    zda_to_gps_s,
)
from kinsync.clock.model import (
    CLOCK_FORMULA,
    EXTRAPOLATION_SPANS,
    OUTSIDE_POLICIES,
    ClockModel,
    OutsidePolicy,
)
from kinsync.clock.profile import ProfileClock

__all__ = [
    "CLOCK_FORMULA",
    "CONVENTIONS",
    "EXTRAPOLATION_SPANS",
    "GPS_EPOCH_POSIX_S",
    "LEAP_SECONDS",
    "OUTSIDE_POLICIES",
    "ClockFit",
    "ClockModel",
    "Convention",
    "OutsidePolicy",
    "ProfileClock",
    "fit_clock",
    "fit_clock_to_log",
    "gps_minus_utc_s",
    "gps_to_utc_posix_s",
    "message_transmission_time_s",
    "utc_fields_to_gps_s",
    "utc_to_gps_s",
    "zda_to_gps_s",
]
