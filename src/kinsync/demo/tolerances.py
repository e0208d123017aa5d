"""The tolerances the demo report judges its checks against, in one place.

Each is fixed here, before any run, with the reason for its limit; the report lists
them all in its conclusion. They follow from one frame a surveyor can check: a
mobile-mapping survey is commonly specified to about 3 cm, so no single error source
(a latency, a clock, a boresight, the georeferencing itself) should take more than a
third of that, 10 mm, leaving room for the others (three independent 10 mm sources add
to 17 mm).
"""

from __future__ import annotations

from kinsync.report.verdict import Tolerance

__all__ = [
    "DETECTION",
    "EXACT",
    "GEOREF_KERNEL",
    "LATENCY_CALIBRATION",
    "LATENCY_TABLE",
    "NO_FALSE_ALARM",
    "ONE_ERROR_SOURCE",
    "OUTAGE_TRAJECTORY",
    "PEER_PARITY",
    "SIGMA_CONSISTENT",
    "SIGMA_COVERAGE",
    "TIME_TAGGING",
]

ONE_ERROR_SOURCE = Tolerance(
    name="one error source",
    limit=10.0,
    unit="mm",
    bound="abs_at_most",
    why=(
        "One error source (latency, clock, lever arm, trajectory) may take a third of "
        "the 3 cm survey accuracy; three independent 10 mm sources add to 17 mm."
    ),
)

GEOREF_KERNEL = Tolerance(
    name="georeferencing adds nothing",
    limit=1.0,
    unit="mm",
    bound="abs_at_most",
    why=(
        "The computation itself must add no visible error: 1 mm is a fifth of the "
        "5 mm range noise of the scanners simulated here."
    ),
)

LATENCY_TABLE = Tolerance(
    name="latency from a rotating table",
    limit=0.1,
    unit="ms",
    bound="abs_at_most",
    why=(
        "0.1 ms moves a point 0.9 mm vertically on the reference beach (10 deg slope at "
        "50 m under a 10 deg/s roll): well inside one error source's 10 mm, as a "
        "dedicated latency experiment should be."
    ),
)

LATENCY_CALIBRATION = Tolerance(
    name="latency from survey lines",
    limit=1.0,
    unit="ms",
    bound="abs_at_most",
    why=(
        "1 ms moves a point 8.7 mm vertically on the reference beach (10 deg slope at "
        "50 m under a 10 deg/s roll): one error source's 10 mm."
    ),
)

TIME_TAGGING = Tolerance(
    name="time tagging",
    limit=10.0,
    unit="µs",
    bound="abs_at_most",
    why=(
        "10 µs moves a point 0.2 mm at 20 m/s: negligible; a wrong second (1 s) or an "
        "uncorrected 25 ppm drift (15 ms after 10 minutes) misses it by orders of "
        "magnitude."
    ),
)

EXACT = Tolerance(
    name="none missed",
    limit=0.0,
    unit="",
    bound="at_most",
    why=(
        "Every fault must be found and every count must match: one missed pulse or one "
        "wrong second shifts all later times by a whole second."
    ),
)

OUTAGE_TRAJECTORY = Tolerance(
    name="trajectory through an outage",
    limit=50.0,
    unit="mm",
    bound="abs_at_most",
    why=(
        "A smoothed trajectory that bridges a short GNSS outage should stay within twice "
        "the 2 cm of the RTK fixes around it."
    ),
)

SIGMA_COVERAGE = Tolerance(
    name="σ covers the errors",
    limit=95.0,
    unit="%",
    bound="at_least",
    why=(
        "A normal error stays inside 3σ 99.7 % of the time; 95 % leaves room for errors "
        "correlated over minutes. Fewer epochs inside means the stated σ is too small."
    ),
)

SIGMA_CONSISTENT = Tolerance(
    name="σ is honest",
    limit=3.0,
    unit="σ",
    bound="at_most",
    why=(
        "An error beyond 3 standard deviations happens by chance in 0.3 % of runs: "
        "beyond it the stated σ is too small to be trusted."
    ),
)

PEER_PARITY = Tolerance(
    name="at or below the best peer",
    limit=1.0,
    unit="",
    bound="at_most",
    why=(
        "kinsync's RMS error on each axis divided by the best other open-source "
        "filter's on the same data (pyins 1.0.1 or KF-GINS, or the figure the data "
        "set's README quotes), at the peers' three decimals: above 1 is worse."
    ),
)

DETECTION = Tolerance(
    name="error detected",
    limit=0.01,
    unit="",
    bound="at_most",
    why=(
        "The validation tests decide at 99 % confidence: a real calibration error must "
        "be flagged, p ≤ 0.01."
    ),
    p_value=True,
)

NO_FALSE_ALARM = Tolerance(
    name="no false alarm",
    limit=0.01,
    unit="",
    bound="at_least",
    why=(
        "A correct calibration must not be flagged at 99 % confidence, p ≥ 0.01 (a "
        "1 % false-alarm rate per test)."
    ),
    p_value=True,
)
