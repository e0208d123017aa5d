"""The values every numeric option accepts: one table, checked for every command.

A finite-but-absurd option value (a 1e308 m range, a 1e-9 deg angular step, a
1e-9 s correlation time) used to reach the algorithms and come back as an overflow,
a singular matrix, a 60 GiB allocation or a confident number computed from
infinities. Every numeric option of every command has an entry here, by option
spelling (``--range-m``) or, where one spelling means different things in different
commands, by command and spelling; `check_numeric_options` refuses a non-finite value
or one outside its span before the command starts. The spans are physical (what a
scanner, an IMU, a serial line or a survey can be) and computational (what runs in
minutes and fits in memory on a workstation); a test checks that every numeric option
has one.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass

from kinsync.errors import InputError
from kinsync.io.gps_week import gps_time_now_s
from kinsync.sync.config import (
    INTENSITY_THRESHOLD_SPAN,
    MAX_RANGE_SPAN_M,
    PERIOD_PRIOR_SPAN_S,
    PERIOD_TOLERANCE_SPAN,
    POSITION_CORR_TIME_SPAN_S,
    POSITION_STD_SPAN_M,
)

__all__ = ["OPTION_BOUNDS", "STANDARD_BAUDS", "Bounds", "bounds_for", "check_numeric_option"]


@dataclass(frozen=True)
class Bounds:
    """Closed span ``[low, high]`` of an option, with its unit and why.

    ``why`` says why a value below ``low`` (and, without ``why_high``, above ``high``)
    is refused; ``why_high``, when given, why a value above ``high`` is.
    """

    low: float
    high: float
    unit: str = ""
    why: str = ""
    why_high: str = ""


_DAY_S = 86_400.0
_FIRST_FULL_WEEK = 1024
"""The first GPS week a 10-bit week number cannot name (August 1999): below it, a week
is more likely a rolled-over receiver week than a survey of 1980-1999."""
_GPS_WEEK_NOW = math.floor(gps_time_now_s() / 604_800.0)
"""The current GPS week by this computer's clock (leap seconds do not change it much)."""
_WEEKS_AHEAD = 104
"""Weeks after the current one still accepted (two years: a computer clock set wrong)."""
_GPS_S_MAX = 1e10  # GPS seconds: year ~2297
STANDARD_BAUDS = frozenset(
    {110, 300, 600, 1200, 2400, 4800, 9600, 14400, 19200, 38400, 57600}
    | {115200, 230400, 460800, 921600}
)
"""Serial line rates (bit/s) receivers and loggers offer: ``--baud 115.2`` is 115200 given
in kbit/s (a 115 bit/s line would take 1.9 s for one NMEA sentence)."""

OPTION_BOUNDS: dict[str | tuple[str, str], Bounds] = {
    # time and latency
    "--latency-ms": Bounds(
        -10_000.0, 10_000.0, "ms", "a latency beyond 10 s is a time-scale error"
    ),
    "--gps-week": Bounds(
        _FIRST_FULL_WEEK,
        _GPS_WEEK_NOW + _WEEKS_AHEAD,
        "",
        "a full GPS week number, counted from 6 January 1980, is 1024 or more since August "
        "1999; a smaller one is a receiver's 10-bit week number, which rolls over every 1024 "
        "weeks: add 2048 for dates since April 2019, 1024 for August 1999 to April 2019",
        f"more than {_WEEKS_AHEAD} weeks after the current GPS week, {_GPS_WEEK_NOW}: check "
        "the week of the survey",
    ),
    "--latency-std-ms": Bounds(
        0.0, 100.0, "ms", "beyond, a unit mistake or too poorly known to plan with"
    ),
    "--t0-s": Bounds(-_GPS_S_MAX, _GPS_S_MAX, "s"),
    "--offset-s": Bounds(-_GPS_S_MAX, _GPS_S_MAX, "s"),
    "--drift-ppm": Bounds(-100_000.0, 100_000.0, "ppm"),
    "--jitter-us": Bounds(0.0, 100_000.0, "us"),
    "--zda-delay-ms": Bounds(0.0, 1_000.0, "ms", "a ZDA names the edge of its own second"),
    "--period-s": Bounds(  # kinsync.clock.profile.PERIOD_SPAN_S, a ProfileClock's
        1e-5,
        10.0,
        "s",
        "",
        "the period is seconds per profile, e.g. 0.0303 for 33 rev/s, not milliseconds",
    ),
    # kinsync.sync.config's spans, an ObjectSpaceConfig's
    "--period-prior-s": Bounds(*PERIOD_PRIOR_SPAN_S, "s"),
    "--period-tolerance": Bounds(*PERIOD_TOLERANCE_SPAN, "", "relative"),
    "--period-error-s": Bounds(-1.0, 1.0, "s"),
    "--target-ms": Bounds(1e-6, 1_000.0, "ms"),
    # serial line
    "--baud": Bounds(50.0, 20_000_000.0, "bit/s"),
    "--bytes": Bounds(1, 10_000_000, "bytes"),
    "--fifo-bytes": Bounds(0, 10_000_000, "bytes"),
    "--data-bits": Bounds(5, 8, "bits"),
    "--stop-bits": Bounds(1.0, 2.0, "bits"),
    # geometry
    "--range-m": Bounds(0.01, 100_000.0, "m"),
    ("latency plan", "--range-m"): Bounds(0.1, 100.0, "m", "a table scanner sees its sphere"),
    "--slope-deg": Bounds(
        0.0,
        89.0,
        "deg",
        "a slope rises towards the beam; 0 is a flat surface",
        "the vertical error needs a sloping surface, not a vertical wall",
    ),
    "--beam-deg": Bounds(0.0, 90.0, "deg", "the beam's depression: 0 horizontal, 90 nadir"),
    "--rate-deg-s": Bounds(-1_000.0, 1_000.0, "deg/s"),
    "--radius-m": Bounds(0.01, 10.0, "m", "a survey sphere"),
    "--sphere-radius-m": Bounds(0.01, 10.0, "m", "a survey sphere"),
    "--patch-voxel-m": Bounds(
        0.25,
        50.0,
        "m",
        "a smaller cell holds too few returns to tell a plane from the range noise",
        "a cell is a piece of one roof, wall or ground",
    ),
    "--patch-min-points-per-line": Bounds(3, 1_000_000, "returns", "a plane needs 3"),
    "--patch-max-thickness-m": Bounds(
        0.001, 1.0, "m", "", "two lines' planes in a cell may differ by 1 m at most"
    ),
    "--target-radius-m": Bounds(0.001, 10.0, "m", "a target's radius is > 0"),
    "--search-radius-m": Bounds(0.001, 100.0, "m", "a radius that holds no point finds nothing"),
    "--max-range-m": Bounds(*MAX_RANGE_SPAN_M, "m"),  # an ObjectSpaceConfig's
    "--profiler-azimuth-deg": Bounds(-360.0, 360.0, "deg"),
    "--epoch": Bounds(1980.0, 2100.0, "year", "a coordinate epoch, e.g. 2024.35"),
    "--angular-step-deg": Bounds(0.001, 10.0, "deg"),
    "--roll-amplitude-deg": Bounds(0.0, 45.0, "deg"),
    "--roll-period-s": Bounds(0.5, 600.0, "s"),
    # noise and navigation errors
    "--range-noise-m": Bounds(0.0, 1.0, "m", "a scanner noisier than 1 m is not calibrated"),
    "--pass-attitude-error-deg": Bounds(
        0.0, 1.0, "deg", "an INS drifting more than 1 deg between passes is not calibrated"
    ),
    ("latency plan", "--range-noise-m"): Bounds(
        1e-4,
        1.0,
        "m",
        "the plan weighs each return by the scanner's range noise, which is never 0",
        "a scanner noisier than 1 m is not calibrated",
    ),
    ("calibrate plan", "--range-noise-m"): Bounds(
        1e-4,
        1.0,
        "m",
        "the plan weighs each return by the scanner's range noise, which is never 0",
        "a scanner noisier than 1 m is not calibrated",
    ),
    "--position-std-m": Bounds(0.0, 100.0, "m"),
    ("sync object-space", "--position-std-m"): Bounds(*POSITION_STD_SPAN_M, "m"),
    ("calibrate plan", "--attitude-std-deg"): Bounds(
        0.0, 5.0, "deg", "a patch test refines a trajectory known to a fraction of a degree"
    ),
    "--position-corr-time-s": Bounds(*POSITION_CORR_TIME_SPAN_S, "s"),  # ObjectSpaceConfig's
    "--corr-time-s": Bounds(0.1, 1e5, "s", "the simulated errors are sampled at this scale"),
    ("calibrate plan", "--corr-time-s"): Bounds(
        1.0, 1e5, "s", "the plan represents the errors at knots a third of it apart"
    ),
    "--trajectory-noise-m": Bounds(0.0, 100.0, "m"),
    # platform and record
    "--speed-m-s": Bounds(0.0, 1_000.0, "m/s"),
    ("simulate drive", "--speed-m-s"): Bounds(0.1, 100.0, "m/s"),
    "--static-s": Bounds(0.0, 3_600.0, "s"),
    "--max-gap-s": Bounds(1e-4, _DAY_S, "s", "a record interval of the trajectory"),
    "--duration-s": Bounds(1.0, _DAY_S, "s"),
    ("simulate drive", "--duration-s"): Bounds(1.0, 21_600.0, "s", "6 h of IMU data in memory"),
    ("simulate drive-scan", "--duration-s"): Bounds(40.0, 7_200.0, "s"),  # DriveScanConfig's
    ("simulate clock", "--duration-s"): Bounds(
        9.0, _DAY_S, "s", "a clock fit needs at least 10 PPS edges, one a second"
    ),  # kinsync.sim.clock.MIN_DURATION_S
    "--imu-rate-hz": Bounds(1.0, 2_000.0, "Hz"),
    "--gnss-rate-hz": Bounds(0.01, 100.0, "Hz"),
    "--profile-rate-hz": Bounds(0.1, 10_000.0, "Hz"),
    "--profiles": Bounds(0, 1e12, "profiles"),
    "--laps": Bounds(1, 1_000, "laps"),
    "--passes": Bounds(1, 1_000, "passes"),
    ("simulate rotating-table", "--passes"): Bounds(1, 100, "passes per rate and direction"),
    ("simulate patch-test", "--passes"): Bounds(1, 20, "lines each way per speed"),
    ("calibrate plan", "--passes"): Bounds(1, 20, "lines each way per speed"),
    ("calibrate plan", "--speeds-m-s"): Bounds(0.2, 40.0, "m/s"),  # PatchTestConfig's span
    "--density": Bounds(1e-6, 1.0, "", "a fraction of the beams"),
    # counts, seeds, chunks
    "--seed": Bounds(0, 2**63 - 1),
    "--missing": Bounds(0, 1_000_000, "pulses"),
    "--spurious": Bounds(0, 1_000_000, "pulses"),
    "--bad-zda": Bounds(0, 1_000_000, "messages"),
    "--bad-lines": Bounds(0, 1_000_000, "lines"),
    "--chunk-points": Bounds(1, 20_000_000, "points", "a chunk is held in memory"),
    "--workers": Bounds(1, 1_024, "workers"),
    "--max-vertices": Bounds(2, 1_000_000, "vertices", "a quick-look line a viewer can draw"),
    "--min-points": Bounds(4, 1_000_000_000, "points"),
    # tests and thresholds
    "--level": Bounds(0.5, 0.9999),
    "--min-bow-mm": Bounds(0.0, 1e6, "mm"),
    "--outlier-k": Bounds(1.0, 1_000.0),
    "--min-intensity": Bounds(-1e12, 1e12),
    "--intensity-threshold": Bounds(*INTENSITY_THRESHOLD_SPAN),  # an ObjectSpaceConfig's
}


def bounds_for(command: str, option: str) -> Bounds | None:
    """The span of ``option`` in ``command`` (e.g. ``"latency plan"``), if any."""
    return OPTION_BOUNDS.get((command, option)) or OPTION_BOUNDS.get(option)


_LARGEST_FLOAT_INT = int(sys.float_info.max)
"""The largest float64 (1.8e308) as an integer: a larger integer has no float64."""


def check_numeric_option(command: str, option: str, value: float) -> None:
    """Refuse a non-finite ``value`` or one outside the option's span.

    Raises
    ------
    InputError
        ``value`` is nan or infinite, or outside `bounds_for` ``(command, option)`` (an
        integer too large for a float64, more than 308 digits, is outside every span).
    """
    shown = None
    if isinstance(value, int) and abs(value) > _LARGEST_FLOAT_INT:  # float(value) overflows
        shown = f"{'-' if value < 0 else ''}(an integer of more than 308 digits)"
        value = sys.float_info.max if value > 0 else -sys.float_info.max  # beyond every span
    if not math.isfinite(value):
        msg = f"{option} {value}: not a finite number"
        raise InputError(msg)
    span = bounds_for(command, option)
    if span is None:
        if shown is not None:  # every numeric option has a span; none would mean 1.8e308
            msg = f"{option} {shown}: too large a number for any computation"
            raise InputError(msg)
        return
    if not span.low <= value <= span.high:
        unit = f" {span.unit}" if span.unit else ""
        reason = span.why_high if value > span.high and span.why_high else span.why
        why = f" ({reason})" if reason else ""
        msg = (
            f"{option} {shown or format(value, 'g')}: outside the span kinsync accepts, "
            f"{span.low:g} to {span.high:g}{unit}{why}"
        )
        raise InputError(msg)
    if option == "--baud" and value not in STANDARD_BAUDS and round(value * 1000) in STANDARD_BAUDS:
        msg = (
            f"--baud {value:g}: a line rate in kbit/s? give bit/s ({round(value * 1000)} for "
            f"{value:g} kbit/s)"
        )
        raise InputError(msg)
