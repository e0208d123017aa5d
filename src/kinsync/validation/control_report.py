"""A cloud validated against control points, end to end on containers (SPEC section 7).

`validate_control_points` extracts the targets from the cloud
(`kinsync.validation.targets`), expresses their differences to the control points in
the vehicle frame (`kinsync.validation.differences`) and tests the time-error and
heading signatures in one mixed model (`kinsync.validation.signatures`); the
`ControlPointReport` holds all of it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from kinsync._typing import FloatArray
from kinsync._unix_time import unix_offset_text
from kinsync.errors import InputError
from kinsync.trajectory import Trajectory
from kinsync.trajectory_gaps import max_gap_for
from kinsync.validation.control_points import ControlPoints
from kinsync.validation.differences import ControlPointDifference, control_point_differences
from kinsync.validation.signatures import PASS_GAP_S, SignatureTest, signature_tests
from kinsync.validation.targets import CentreMethod, CloudPoints, MissingTarget, extract_targets

__all__ = [
    "ControlPointReport",
    "validate_control_points",
]


@dataclass(frozen=True, eq=False)
class ControlPointReport:
    """Control-point differences and the synchronisation / heading signature tests.

    Attributes
    ----------
    differences : tuple of ControlPointDifference
        One per visit found, in time order.
    missing : tuple of MissingTarget
        Control points (or visits) without an observation, with the reason.
    time_error : SignatureTest
        Implied time error (s): latency applied minus the true latency; subtract it
        from the mount's ``latency_s``.
    heading_error : SignatureTest
        Implied heading misorientation (deg), DIN 9300 yaw sense.
    intercept_m : float
        Constant along-track offset of the regression (m).
    residual_std_m : float
        Noise of one difference within a pass (m); NaN without degrees of freedom.
    pass_std_m : float
        Standard deviation of the along-track offset common to a pass (m).
    survey_std_m : float
        Standard deviation of a control point's horizontal survey error (m, per axis),
        as the repeated visits show it.
    n_passes : int
        Passes of the vehicle found among the visits.
    level : float
        Confidence level of the tests.
    n_control_points : int
        Control points given.
    gap_threshold_s : float
        Trajectory record intervals longer than this (s) were data gaps: visits inside
        one are missing (`kinsync.trajectory_gaps.max_gap_for`).
    """

    differences: tuple[ControlPointDifference, ...]
    missing: tuple[MissingTarget, ...]
    time_error: SignatureTest
    heading_error: SignatureTest
    intercept_m: float
    residual_std_m: float
    pass_std_m: float
    survey_std_m: float
    n_passes: int
    level: float
    n_control_points: int
    gap_threshold_s: float = math.inf

    def diff_vehicle_m(self) -> FloatArray:
        """All differences (dX, dY, dZ) in the vehicle frame (m), shape (K, 3)."""
        return np.array([d.diff_vehicle_m for d in self.differences]).reshape(-1, 3)

    def as_document(self) -> dict[str, Any]:
        """The ``--json`` document of ``kinsync validate control-points``."""
        diff = self.diff_vehicle_m()
        mean = diff.mean(axis=0) if diff.size else np.full(3, np.nan)
        rms = np.sqrt((diff**2).mean(axis=0)) if diff.size else np.full(3, np.nan)
        return {
            "n_control_points": self.n_control_points,
            "n_observations": len(self.differences),
            "n_missing": len(self.missing),
            "gap_threshold_s": self.gap_threshold_s,
            "level": self.level,
            "time_error": self.time_error.as_document(),
            "heading_error": self.heading_error.as_document(),
            "intercept_m": self.intercept_m,
            "residual_std_m": self.residual_std_m,
            "pass_std_m": self.pass_std_m,
            "survey_std_m": self.survey_std_m,
            "n_passes": self.n_passes,
            "mean_vehicle_m": [float(v) for v in mean],
            "rms_vehicle_m": [float(v) for v in rms],
            "observations": [
                {
                    "name": d.observation.name,
                    "visit": d.observation.visit,
                    "t_s": d.observation.t_s,
                    "n_points": d.observation.n_points,
                    "dx_m": d.diff_vehicle_m[0],
                    "dy_m": d.diff_vehicle_m[1],
                    "dz_m": d.diff_vehicle_m[2],
                    "speed_m_s": d.speed_m_s,
                    "along_speed_m_s": d.along_speed_m_s,
                    "heading_deg": d.heading_deg,
                    "yaw_rate_deg_s": d.yaw_rate_deg_s,
                    "lateral_m": d.lateral_m,
                    "side": d.side,
                    "centre_std_ned_m": list(d.observation.centre_std_ned_m),
                    "intensity_threshold": d.observation.intensity_threshold,
                }
                for d in self.differences
            ],
            "missing": [{"name": m.name, "t_s": m.t_s, "reason": m.reason} for m in self.missing],
        }


def validate_control_points(
    cloud: CloudPoints,
    control: ControlPoints,
    trajectory: Trajectory,
    *,
    search_radius_m: float = 0.5,
    min_intensity: float | None = None,
    centre: CentreMethod = "tukey",
    target_radius_m: float | None = None,
    min_points: int = 10,
    visit_gap_s: float = 1.0,
    level: float = 0.99,
    pass_gap_s: float = PASS_GAP_S,
    background_intensity: float | None = None,
    max_gap_s: float | None = None,
    cloud_span_s: tuple[float, float] | None = None,
) -> ControlPointReport:
    """Extract targets, express the differences in the vehicle frame, test the signatures.

    The options are those of `extract_targets`, `control_point_differences` (``max_gap_s``,
    the trajectory's gap threshold) and `signature_tests`.

    Parameters
    ----------
    cloud : CloudPoints
        Georeferenced points, ECEF WGS84 (m), with their times ``t_s`` (s, the
        trajectory's time scale) and intensities.
    control : ControlPoints
        Surveyed positions of the targets (ECEF, m).
    trajectory : Trajectory
        Vehicle trajectory on the cloud's time scale; its attitude gives the vehicle
        frame of each difference.
    search_radius_m : float
        Radius around each control point where its target is looked for (m), > 0;
        default 0.5.
    min_intensity : float, optional
        Intensity threshold of the targets' returns; default: Otsu's threshold in each
        neighbourhood.
    centre : {"tukey", "median", "sphere"}
        Centre estimator of a visit (default "tukey").
    target_radius_m : float, optional
        Sphere radius (m), required with ``centre="sphere"``, smaller than
        ``search_radius_m``.
    min_points : int
        Fewest bright points of a visit for a centre (>= 4); default 10.
    visit_gap_s : float
        Time gap (s, > 0) that separates two visits of a target; default 1.
    level : float
        Confidence level of the signature tests, in (0, 1); default 0.99.
    pass_gap_s : float
        Time gap (s, > 0) between visits that starts a new pass; default `PASS_GAP_S`.
    background_intensity : float, optional
        The survey's typical (median) intensity; default: the median of
        ``cloud.intensity``.
    max_gap_s : float, optional
        Longest trajectory record interval (s, > 0) interpolated across; default
        `kinsync.trajectory_gaps.GAP_FACTOR` median record intervals.
    cloud_span_s : tuple of 2 float, optional
        Times (s) of the whole cloud's first and last points, when ``cloud`` holds only
        the points near the targets; a visit within one revisit interval of either end
        may be cut and is reported missing (see `extract_targets`).

    Returns
    -------
    ControlPointReport
        The differences (vehicle frame, m), the targets missing with why, the time-error
        (s) and heading-error (deg) tests and the noise components (m).

    Raises
    ------
    InputError
        Bad options (as above), a cloud without times or intensities, every visit
        outside the trajectory's time span (the message suggests a time-scale
        mismatch), or no control point found at all (each missing one is listed with
        its reason in the message).
    """
    gap_threshold_s = max_gap_for(trajectory.t_s, max_gap_s)
    observations, missing = extract_targets(
        cloud,
        control,
        search_radius_m=search_radius_m,
        min_intensity=min_intensity,
        centre=centre,
        target_radius_m=target_radius_m,
        min_points=min_points,
        visit_gap_s=visit_gap_s,
        background_intensity=background_intensity,
        cloud_span_s=cloud_span_s,
    )
    differences, outside = control_point_differences(
        observations, control, trajectory, max_gap_s=gap_threshold_s
    )
    missing = missing + outside
    if not differences:
        t_seen = [o.t_s for o in observations]
        t0, t1 = trajectory.t_start_s, trajectory.t_end_s
        if t_seen and all(not t0 <= t <= t1 for t in t_seen):
            seen = (min(t_seen), max(t_seen))
            unix = unix_offset_text(seen, (t0, t1), "the cloud", "the trajectory")
            msg = (
                f"every control point seen in the cloud ({len(t_seen)} visits) was scanned "
                f"at a time outside the trajectory's span [{t0!r}, {t1!r}] s (visits at "
                f"{seen[0]!r} .. {seen[1]!r} s): "
                + (
                    unix
                    or "are the cloud and the trajectory on the same time scale? GPS seconds "
                    "of week against GPS time since 1980, or UTC against GPS (18 s since "
                    "2017); convert the trajectory's times to the cloud's"
                )
            )
            raise InputError(msg)
        listed = "; ".join(f"{m.name}: {m.reason}" for m in missing[:5])
        more = f" (and {len(missing) - 5} more)" if len(missing) > 5 else ""
        msg = f"no control point found in the cloud: {listed}{more}"
        raise InputError(msg)
    tests = signature_tests(differences, level, pass_gap_s)
    return ControlPointReport(
        differences=differences,
        missing=missing,
        time_error=tests.time_error,
        heading_error=tests.heading_error,
        intercept_m=tests.intercept_m,
        residual_std_m=tests.residual_std_m,
        pass_std_m=tests.pass_std_m,
        survey_std_m=tests.survey_std_m,
        n_passes=tests.n_passes,
        level=level,
        n_control_points=len(control),
        gap_threshold_s=gap_threshold_s,
    )
