"""Gross errors of a calibration's inputs: a starting mount far off, lines that cannot be.

The adjustment is linearised about the starting mount, and the features are found with
it: a boresight off by several degrees puts the returns of opposite lines on different
surfaces, so the features pair the wrong returns and the solution settles where they
put it. This module holds what the estimator does about that:

- `far_from_start`: a solution further from the mount its features were found with than
  a crew's own knowledge (`UNOBSERVABLE_THRESHOLDS`: 1 deg, 10 cm, 10 ms) has its
  features found again with the solution, up to `MAX_FEATURE_ROUNDS` times;
- `stuck_at_start`: no step lowered the misfit from the starting mount at all (every
  estimate equals its start exactly): a ConvergenceError, not a calibration;
- `lines_at_the_same_time`: two lines recorded at the same time (one file given twice
  under two names, or two scanners' lines) are refused;
- `unlinked_directions`: lines driven both ways see walls, roofs or spheres, but few
  are seen alike from both directions: the starting mount or the trajectory is grossly
  wrong (a warning: a scanner that looks to one side only sees different walls each way);
- `residual_rise`: a fit that leaves the features' residuals larger than the starting
  mount did (lines from two scanners, or a wrong start).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from kinsync._typing import FloatArray
from kinsync.calibration.adjustment import Observation
from kinsync.calibration.features import Feature, PlaneFeature
from kinsync.calibration.lines import ScanLine
from kinsync.calibration.observability import UNOBSERVABLE_THRESHOLDS
from kinsync.calibration.parameters import PARAMETER_NAMES, REPORT_SCALE
from kinsync.errors import ConvergenceError, InputError
from kinsync.frames import quaternion_to_euler_rpy, wrap_angle_rad

__all__ = [
    "LINKED_SHARE",
    "MAX_FEATURE_ROUNDS",
    "OPPOSITE_DEG",
    "RESIDUAL_RISE",
    "SAME_TIME_SHARE",
    "far_from_start",
    "line_heading_rad",
    "lines_at_the_same_time",
    "residual_rise",
    "stuck_at_start",
    "unlinked_directions",
]

MAX_FEATURE_ROUNDS = 4
"""Times the features are found again with the solution before the last solve."""

OPPOSITE_DEG = 90.0
"""Two lines whose mean headings differ by more than this (deg) run opposite ways."""

SAME_TIME_SHARE = 0.5
"""Two lines whose recording spans overlap by more than this share of the shorter one's
were recorded at the same time."""

RESIDUAL_RISE = 1.02
"""A calibrated mount whose features' RMS residual exceeds the start's by more than this
factor fits worse (the trimmed RMS may move by a little either way at a good start)."""

_GROUND_TILT_DEG = 15.0
"""A plane tilted less than this (deg) is ground: it looks alike whatever the heading."""

LINKED_SHARE = 1.0 / 3.0
"""Share of the walls, roofs and spheres that lines of both directions must see alike
(with a right start: 13 of 14-16 on the simulated vehicle; with the boresight's yaw 10
deg off: 4 of 30, 20 deg or more: none; roll or yaw 5 deg off, which converge: 19 of 36
and 20 of 28)."""

_MIN_UNLINKED = 2
"""Non-ground features each direction must see alone before the warning speaks."""


def far_from_start(values: FloatArray, start: FloatArray, estimated: Sequence[int]) -> bool:
    """Whether a solution moved an estimate beyond what a crew knows without calibrating.

    Parameters
    ----------
    values, start : ndarray, shape (7,)
        The solution and the mount its features were found with (rad, m, s).
    estimated : sequence of int
        The estimated parameters.

    Returns
    -------
    bool
        Some estimate moved more than its `UNOBSERVABLE_THRESHOLDS` (1 deg, 10 cm,
        10 ms): the returns then move by decimetres and the features found with the
        start may pair the wrong ones.
    """
    return any(
        abs(float(values[i] - start[i])) * REPORT_SCALE[i] > UNOBSERVABLE_THRESHOLDS[i]
        for i in estimated
    )


def stuck_at_start(
    values: FloatArray, start: FloatArray, estimated: Sequence[int], rms_start_m: float
) -> ConvergenceError | None:
    """The error for a solution that never left its start, or None.

    Parameters
    ----------
    values, start : ndarray, shape (7,)
        The solution and its starting values (rad, m, s).
    estimated : sequence of int
        The estimated parameters.
    rms_start_m : float
        RMS residual of the features with the starting mount (m).

    Returns
    -------
    ConvergenceError or None
        When every estimate equals its start exactly: no step of the adjustment lowered
        the misfit (with real data a start that is already the least-squares solution
        does not happen), so the features absorbed whatever is wrong with the start.
    """
    if not estimated or any(values[i] != start[i] for i in estimated):
        return None
    names = ", ".join(PARAMETER_NAMES[i] for i in estimated)
    return ConvergenceError(
        f"the calibration did not move from the starting mount: no change of {names} "
        f"lowers the features' misfit ({rms_start_m * 100:.3g} cm RMS with the starting "
        "mount), so the features were found with a mount or a trajectory that does not "
        "fit these lines. Check the starting mount (a boresight off by degrees, axes in "
        "another order, a lever arm's sign or unit) and that the trajectory is these "
        "lines' (same survey, same time scale); a start within a few degrees of the truth "
        "converges"
    )


def line_heading_rad(line: ScanLine, n_samples: int = 21) -> float:
    """Mean heading of a line (rad, circular mean of the yaw over its returns' span).

    Parameters
    ----------
    line : ScanLine
        The line.
    n_samples : int
        Trajectory samples over the span.

    Returns
    -------
    float
        Heading (rad, (-pi, pi]); NaN when the trajectory does not cover the span.
    """
    t = np.linspace(line.t_start_s, line.t_end_s, n_samples)
    inside = line.trajectory.contains(t, max_gap_s=math.inf)
    if not np.any(inside):
        return math.nan
    q = line.trajectory.interpolate(t[inside], max_gap_s=math.inf).q_body_to_ned
    yaw = quaternion_to_euler_rpy(q)[:, 2]
    return float(np.angle(np.mean(np.exp(1j * yaw))))


def lines_at_the_same_time(lines: Sequence[ScanLine]) -> InputError | None:
    """The error for two lines recorded at the same time, or None.

    One scanner records one line at a time: two lines whose spans overlap by more than
    `SAME_TIME_SHARE` of the shorter are one file given twice (a copy under another
    name, which the jackknife would count as two independent lines), or lines of two
    scanners (which have two mounts).

    Parameters
    ----------
    lines : sequence of ScanLine
        The lines.

    Returns
    -------
    InputError or None
    """
    spans = [(line.t_start_s, line.t_end_s) for line in lines]
    for a in range(len(lines)):
        for b in range(a + 1, len(lines)):
            (a0, a1), (b0, b1) = spans[a], spans[b]
            overlap = min(a1, b1) - max(a0, b0)
            shorter = min(a1 - a0, b1 - b0)
            same = overlap > SAME_TIME_SHARE * shorter if shorter > 0 else overlap >= 0
            if same:
                return InputError(
                    f"lines {lines[a].name!r} and {lines[b].name!r} were recorded at the same "
                    f"time ({a0!r} .. {a1!r} s and {b0!r} .. {b1!r} s): one scanner records one "
                    "line at a time, so this is the same line given twice (a copy under "
                    "another name) or lines of two scanners, which have two mounts; give "
                    "each line once, all from one scanner"
                )
    return None


def _non_ground(feature: Feature) -> bool:
    if isinstance(feature, PlaneFeature):
        return abs(float(feature.normal[2])) < math.cos(math.radians(_GROUND_TILT_DEG))
    return True


def unlinked_directions(
    lines: Sequence[ScanLine], observations: Sequence[Observation], features: Sequence[Feature]
) -> str | None:
    """A warning when lines run both ways see walls, but rarely the same ones, or None.

    With a correct starting mount a wall, a roof or a sphere passed both ways is one
    feature seen by lines of both directions. A boresight several degrees off, axes in
    another order or another drive's trajectory put each direction's returns of it in
    different places: most such features are then seen by one direction only (fewer
    than `LINKED_SHARE` seen alike, and at least two by each direction alone).

    Parameters
    ----------
    lines : sequence of ScanLine
        The lines (indices as in ``observations``).
    observations : sequence of Observation
        Which lines see which feature.
    features : sequence of Feature
        The features found.

    Returns
    -------
    str or None
        The warning, naming both directions' lines and their feature counts.
    """
    heading = np.array([line_heading_rad(line) for line in lines])
    if not np.all(np.isfinite(heading)):
        return None
    first = heading[0]
    forward = np.abs(wrap_angle_rad(heading - first)) <= math.radians(OPPOSITE_DEG)
    if forward.all():
        return None
    seen: dict[int, set[int]] = {}
    for o in observations:
        seen.setdefault(o.feature, set()).add(o.line)
    counts = {"linked": 0, True: 0, False: 0}
    for k, who in seen.items():
        if not _non_ground(features[k]):
            continue
        ways = {bool(forward[i]) for i in who}
        if len(ways) == 2:
            counts["linked"] += 1
        else:
            counts[ways.pop()] += 1
    alone = counts[True] + counts[False]
    if min(counts[True], counts[False]) < _MIN_UNLINKED or counts["linked"] > LINKED_SHARE * (
        counts["linked"] + alone
    ):
        return None
    names = {
        way: ", ".join(lines[int(i)].name for i in np.flatnonzero(forward == way))
        for way in (True, False)
    }
    deg = {
        way: math.degrees(float(np.angle(np.mean(np.exp(1j * heading[forward == way])))))
        for way in (True, False)
    }
    return (
        f"{counts['linked']} of {counts['linked'] + alone} walls, roofs or spheres are seen "
        f"alike by the lines driven both ways: {names[True]} (heading {deg[True]:.0f} deg) "
        f"see {counts[True]} more and {names[False]} (heading {deg[False]:.0f} deg) "
        f"{counts[False]} more that the other direction does not. The "
        "starting mount is likely grossly wrong (a boresight off by tens of degrees, axes "
        "in another order, a lever arm's sign) or the trajectory is not these lines'; "
        "unless the scanner sees different surfaces each way, do not trust these estimates"
    )


def residual_rise(rms_start_m: float, rms_after_m: float) -> str | None:
    """A warning when the fit left the features' residuals larger than the start did.

    Parameters
    ----------
    rms_start_m, rms_after_m : float
        RMS residual of the features with the starting and the calibrated mount (m).

    Returns
    -------
    str or None
    """
    if not (math.isfinite(rms_start_m) and math.isfinite(rms_after_m)):
        return None
    if rms_after_m <= RESIDUAL_RISE * rms_start_m:
        return None
    return (
        f"the calibrated mount fits the features worse than the starting mount "
        f"({rms_start_m * 100:.3g} cm -> {rms_after_m * 100:.3g} cm RMS): lines that no one "
        "mount fits (two scanners', or another drive's trajectory) or a start far off; "
        "check the lines and the trajectory before using these estimates"
    )
