"""Settings of the object-space synchronisation (Method B, `kinsync.sync.object_space`)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

from kinsync._validate import finite_number, positive_number
from kinsync.errors import InputError
from kinsync.trajectory_gaps import max_gap_for

__all__ = [
    "INTENSITY_THRESHOLD_SPAN",
    "MAX_RANGE_SPAN_M",
    "PERIOD_PRIOR_SPAN_S",
    "PERIOD_TOLERANCE_SPAN",
    "POSITION_CORR_TIME_SPAN_S",
    "POSITION_STD_SPAN_M",
    "ObjectSpaceConfig",
]

# The spans `ObjectSpaceConfig` accepts; ``kinsync sync object-space`` takes its options'
# spans from here (`kinsync.cli._bounds`), so the program and a Python caller agree.
PERIOD_PRIOR_SPAN_S = (1e-5, 100.0)
"""Prior mirror periods (s): 10 us to 100 s. Profilers turn with periods of 4 to 100 ms,
but a prior in the wrong unit (30.3 for 0.0303 s) is let through on purpose: the search
over periods then names the period the data suggest."""
PERIOD_TOLERANCE_SPAN = (0.0, 0.5)
"""Relative tolerances of the prior: more than 0 and less than 0.5 (both ends open)."""
INTENSITY_THRESHOLD_SPAN = (-1e12, 1e12)
"""Intensity thresholds (the scanner's intensity unit): any finite intensity a scan holds."""
MAX_RANGE_SPAN_M = (0.1, 10_000.0)
"""Farthest sync-point crossings (m) considered: 10 cm to 10 km."""
POSITION_STD_SPAN_M = (0.0, 100.0)
"""A-priori position sigmas (m): 0 (exact) to 100 m."""
POSITION_CORR_TIME_SPAN_S = (0.0, 1e6)
"""Correlation times (s) of the position error: 0 (independent) to 1e6 s (11.6 days)."""

_SPANS: dict[str, tuple[tuple[float, float], str, str]] = {
    "period_prior_s": (PERIOD_PRIOR_SPAN_S, " s", "--period-prior-s"),
    "intensity_threshold": (INTENSITY_THRESHOLD_SPAN, "", "--intensity-threshold"),
    "max_range_m": (MAX_RANGE_SPAN_M, " m", "--max-range-m"),
    "position_std_m": (POSITION_STD_SPAN_M, " m", "--position-std-m"),
    "position_corr_time_s": (POSITION_CORR_TIME_SPAN_S, " s", "--position-corr-time-s"),
}
"""Field: (closed span, unit, option of ``kinsync sync object-space``)."""


@dataclass(frozen=True)
class ObjectSpaceConfig:
    """Settings of the object-space synchronisation (defaults suit a 33 rev/s profiler).

    Attributes
    ----------
    period_prior_s : float
        Prior mirror period T (s), within `PERIOD_PRIOR_SPAN_S`.
    period_tolerance : float
        Relative tolerance of the prior: hypotheses need ``|T / prior - 1| <= tol``
        (more than 0, less than 0.5).
    intensity_threshold : float
        Returns at least this bright are target candidates (scanner's intensity unit),
        within `INTENSITY_THRESHOLD_SPAN`.
    min_returns : int
        Fewest returns that make a sighting (isolated glints are rejected).
    cluster_gap_profiles : float
        Returns of one target are at most this many profiles apart.
    cluster_gap_rad : float
        ... and this far apart in mirror angle (rad).
    cluster_gap_m : float
        ... and this far apart in range (m).
    max_range_m : float
        Crossings farther from the scanner are not candidates (m), within
        `MAX_RANGE_SPAN_M`.
    angle_gate_rad : float
        A sighting and a crossing are compatible within this mirror-angle difference.
    range_gate_m : float
        ... and this range difference (m); it must exceed the target radius.
    refinement : {"sphere", "centroid"}
        Sub-profile refinement: sphere fit (with centroid fallback) or centroid only.
    sphere_min_returns : int
        Fewest returns for the sphere fit.
    centroid_profile_std : float
        A-priori sigma of a centroid sub-profile position (profiles).
    profile_model_std : float
        Model error of the sphere fit, added in quadrature to its covariance sigma
        (profiles): the centre drifts in the plane during the sweep and the fit sees
        one side of the sphere (>= 0; 0 by default: with the drift modelled, the
        simulated spread is within the fit's sigma).
    position_std_m : float
        A-priori sigma of the trajectory and sync-point positions along the plane
        normal (m), within `POSITION_STD_SPAN_M`; 0 for an exact (simulated) trajectory.
    position_corr_time_s : float
        Correlation time of the trajectory's position error (s, within
        `POSITION_CORR_TIME_SPAN_S`): the errors at
        two crossings ``dt`` apart are correlated by ``exp(-|dt| / position_corr_time_s)``
        (first-order Gauss-Markov); 0 takes them as independent (the model before
        issue item 8). The default, 15 s, is the middle of the 10-20 s over which
        INS/GNSS position errors stay correlated; with it the simulated sigma of t0 and
        T stays within about 0.8-1.2 of the spread for true correlation times from 0.3 s to
        40 s (`kinsync.sync.object_space`, step 5).
    gate_sigma : float
        Inlier gate of a hypothesis, in timing sigmas.
    min_gate_profiles : float
        The gate is never narrower than this many profiles.
    ambiguity_chi2 : float
        Another assignment within this chi-square of the best is an ambiguity.
    max_sync_distance_m : float
        A sync point farther than this from every trajectory position is an input error
        (wrong datum, swapped latitude and longitude, another site).
    max_gap_s : float or None
        Longest trajectory record interval (s) interpolated across: a crossing in a
        longer one (a data gap) is left out. None (default):
        `kinsync.trajectory_gaps.GAP_FACTOR` median record intervals
        (`kinsync.trajectory_gaps.max_gap_for`); ``math.inf``: no gap.
    """

    period_prior_s: float = 0.0303
    period_tolerance: float = 0.01
    intensity_threshold: float = 0.8
    min_returns: int = 3
    cluster_gap_profiles: float = 2.0
    cluster_gap_rad: float = math.radians(3.0)
    cluster_gap_m: float = 0.5
    max_range_m: float = 80.0
    angle_gate_rad: float = math.radians(5.0)
    range_gate_m: float = 1.0
    refinement: Literal["sphere", "centroid"] = "sphere"
    sphere_min_returns: int = 8
    centroid_profile_std: float = 0.12
    profile_model_std: float = 0.0
    position_std_m: float = 0.02
    position_corr_time_s: float = 15.0
    gate_sigma: float = 5.0
    min_gate_profiles: float = 1.0
    ambiguity_chi2: float = 9.0
    max_sync_distance_m: float = 5000.0
    max_gap_s: float | None = None

    @property
    def period_window_s(self) -> tuple[float, float]:
        """Smallest and largest period (s) within the prior's relative tolerance."""
        return (
            self.period_prior_s * (1.0 - self.period_tolerance),
            self.period_prior_s * (1.0 + self.period_tolerance),
        )

    def __post_init__(self) -> None:
        positive_number(self.period_prior_s, "period_prior_s (--period-prior-s)")
        tol = positive_number(self.period_tolerance, "period_tolerance (--period-tolerance)")
        if tol >= PERIOD_TOLERANCE_SPAN[1]:
            msg = (
                f"period_tolerance (--period-tolerance) is relative (0.01 = 1 %); {tol} is "
                f"too wide (< {PERIOD_TOLERANCE_SPAN[1]:g})"
            )
            raise InputError(msg)
        for name, (span, unit, option) in _SPANS.items():
            value = finite_number(getattr(self, name), f"{name} ({option})")
            low, high = span
            if not low <= value <= high:
                msg = (
                    f"{name} ({option}) {value:g}{unit}: outside the span kinsync accepts, "
                    f"{low:g} to {high:g}{unit}"
                )
                raise InputError(msg)
        for name in ("min_returns", "sphere_min_returns"):
            value = getattr(self, name)
            if isinstance(value, bool) or int(value) != value or value < 1:
                msg = f"{name} must be a whole number >= 1, got {value!r}"
                raise InputError(msg)
        if self.refinement not in ("sphere", "centroid"):
            msg = f"refinement must be 'sphere' or 'centroid', got {self.refinement!r}"
            raise InputError(msg)
        for name in (
            "cluster_gap_profiles",
            "cluster_gap_rad",
            "cluster_gap_m",
            "max_range_m",
            "angle_gate_rad",
            "range_gate_m",
            "centroid_profile_std",
            "gate_sigma",
            "min_gate_profiles",
            "ambiguity_chi2",
            "max_sync_distance_m",
        ):
            positive_number(getattr(self, name), name)
        if self.max_gap_s is not None:
            max_gap_for((), self.max_gap_s)  # a positive number of seconds, or inf
        if finite_number(self.profile_model_std, "profile_model_std") < 0.0:
            msg = f"profile_model_std must be >= 0, got {self.profile_model_std!r}"
            raise InputError(msg)
