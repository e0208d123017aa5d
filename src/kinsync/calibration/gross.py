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
- `search_yaw`: when the directions share few walls, the boresight yaw is searched all
  the way round for one under which they do, and the calibration starts there; not at
  long range (`MAX_WALL_RANGE_M`: airborne strips), where a start within what a crew
  knows shares few walls too;
- `residual_rise`: a fit that leaves the features' residuals larger than the starting
  mount did (lines from two scanners, or a wrong start).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from kinsync._typing import FloatArray, IntArray
from kinsync.calibration.adjustment import Observation
from kinsync.calibration.features import Feature, PlaneFeature
from kinsync.calibration.lines import ScanLine
from kinsync.calibration.observability import UNOBSERVABLE_THRESHOLDS
from kinsync.calibration.parameters import BORESIGHT, PARAMETER_NAMES, REPORT_SCALE
from kinsync.calibration.planes import PatchOptions
from kinsync.errors import ConvergenceError, InputError
from kinsync.frames import quaternion_to_euler_rpy, wrap_angle_rad
from kinsync.time_spans import SAME_TIME_SHARE, recorded_together

__all__ = [
    "LINKED_SHARE",
    "MAX_FEATURE_ROUNDS",
    "MAX_WALL_RANGE_M",
    "RESIDUAL_RISE",
    "SAME_TIME_SHARE",
    "SAME_WAY_DEG",
    "YAW_SEARCH_STEP_DEG",
    "DirectionLinks",
    "at_start",
    "direction_links",
    "far_from_start",
    "line_directions",
    "line_heading_rad",
    "lines_at_the_same_time",
    "residual_rise",
    "search_yaw",
    "stuck_at_start",
    "unlinked_directions",
    "wall_range_m",
]

MAX_FEATURE_ROUNDS = 4
"""Times the features are found again with the solution before the last solve."""

SAME_WAY_DEG = 45.0
"""A line whose mean heading is within this (deg) of the first line's runs its way, within
this of the reverse the other way; the rest (cross lines, 90 deg off) run neither and are
not compared (an airborne patch test's cross strips counted as run the first strip's way,
so the walls they shared with it were counted as seen one way only)."""


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

YAW_SEARCH_STEP_DEG = 5.0
"""Step of the search over the boresight's yaw when the start shares few walls between
the directions (a start within 3-8 deg converges; 10 deg off, 4 of 30 walls are shared,
15 deg off none)."""

_MIN_UNLINKED = 2
"""Non-ground features each direction must see alone before the warning speaks."""

MAX_WALL_RANGE_M = PatchOptions().max_line_offset_m / math.tan(
    math.radians(UNOBSERVABLE_THRESHOLDS[BORESIGHT[2]])
)
"""Median range (m) of the returns on walls, roofs and spheres beyond which few of them
shared by the two directions tells nothing of a start grossly wrong (57 m). There the
boresight a crew knows anyway (1 deg) moves a return by more than the 1 m by which the
patch search still pairs two lines' planes (`PatchOptions.max_line_offset_m`): a start a
few tenths of a degree off shares few walls too. Airborne strips at 1000 m, started
0.1-0.2 deg off the true boresight, shared 26 of 81, and the search moved the yaw 15 deg
away for it; the simulated vehicle's walls are at 12 m, the vessel's at 26 m."""

_SHIFT_DEG = 0.1
"""The boresight error whose shift of a return at the walls' range a warning names."""


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


def at_start(values: FloatArray, start: FloatArray, estimated: Sequence[int]) -> bool:
    """Whether a solve left every estimate exactly at its start (no step was taken).

    Parameters
    ----------
    values, start : ndarray, shape (7,)
        The solution and its starting values (rad, m, s).
    estimated : sequence of int
        The estimated parameters (none: False).

    Returns
    -------
    bool
    """
    return bool(estimated) and all(values[i] == start[i] for i in estimated)


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
    if not at_start(values, start, estimated):
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
            if recorded_together(spans[a], spans[b]):
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


@dataclass(frozen=True)
class DirectionLinks:
    """How many walls, roofs and spheres the lines of each direction see, alike or alone.

    Attributes
    ----------
    linked : int
        Non-ground features seen by lines of both directions.
    forward_alone, backward_alone : int
        Non-ground features seen by lines of one direction only (the first line's, the
        other).
    """

    linked: int
    forward_alone: int
    backward_alone: int

    @property
    def total(self) -> int:
        """Every non-ground feature."""
        return self.linked + self.forward_alone + self.backward_alone

    @property
    def unlinked(self) -> bool:
        """Fewer than `LINKED_SHARE` seen alike, and at least two by each direction alone."""
        return (
            min(self.forward_alone, self.backward_alone) >= _MIN_UNLINKED
            and self.linked <= LINKED_SHARE * self.total
        )


def line_directions(lines: Sequence[ScanLine]) -> IntArray | None:
    """Which lines run one way along the survey's main axis, which the other, or None.

    The axis is the one most lines run along either way (within `SAME_WAY_DEG`) with at
    least one line each way; a tie goes to the smaller axis angle (0-180 deg from
    north). It depends on the lines' headings only, not on their order: it followed the
    first line, so a cross line given first left a genuine opposite pair uncompared.

    Parameters
    ----------
    lines : sequence of ScanLine
        The lines.

    Returns
    -------
    ndarray of int, shape (len(lines),) or None
        1 for the lines run along the axis's angle, -1 for those run the other way, 0
        for the rest (cross lines); None when a line's heading is unknown or no two
        lines run opposite ways (nothing to compare).
    """
    return _directions(np.array([line_heading_rad(line) for line in lines]))


def _directions(heading_rad: FloatArray) -> IntArray | None:
    """`line_directions` from the lines' headings (rad)."""
    if not np.all(np.isfinite(heading_rad)):
        return None
    best: tuple[tuple[int, float], IntArray] | None = None
    for axis in np.unique(np.mod(heading_rad, math.pi)).tolist():
        off = np.abs(wrap_angle_rad(heading_rad - axis))
        way: IntArray = np.zeros(off.size, dtype=np.int64)
        way[off <= math.radians(SAME_WAY_DEG)] = 1
        way[off >= math.radians(180.0 - SAME_WAY_DEG)] = -1
        key = (int(np.count_nonzero(way)), -axis)
        if np.any(way == 1) and np.any(way == -1) and (best is None or key > best[0]):
            best = (key, way)
    return None if best is None else best[1]


def direction_links(
    way: IntArray, observations: Sequence[Observation], features: Sequence[Feature]
) -> DirectionLinks:
    """Count the non-ground features seen by both directions and by one alone.

    A feature seen by cross lines alone (``way`` 0) is not counted.

    Parameters
    ----------
    way : ndarray of int, shape (n_lines,)
        `line_directions` of the lines (indices as in ``observations``).
    observations : sequence of Observation
        Which lines see which feature.
    features : sequence of Feature
        The features.

    Returns
    -------
    DirectionLinks
    """
    seen: dict[int, set[int]] = {}
    for o in observations:
        seen.setdefault(o.feature, set()).add(o.line)
    counts = {"linked": 0, 1: 0, -1: 0}
    for k, who in seen.items():
        ways = {int(way[i]) for i in who} - {0}
        if not ways or not _non_ground(features[k]):
            continue
        counts["linked" if len(ways) == 2 else ways.pop()] += 1
    return DirectionLinks(counts["linked"], counts[1], counts[-1])


def wall_range_m(
    lines: Sequence[ScanLine], observations: Sequence[Observation], features: Sequence[Feature]
) -> float:
    """Median range from the scanner of the returns on walls, roofs and spheres.

    Parameters
    ----------
    lines : sequence of ScanLine
        The lines (indices as in ``observations``).
    observations : sequence of Observation
        Which returns of which line lie on which feature.
    features : sequence of Feature
        The features.

    Returns
    -------
    float
        The median range (m, the norm of the scanner-frame returns); NaN when no return
        lies on a wall, a roof or a sphere.
    """
    ranges = [
        np.linalg.norm(lines[o.line].xyz_scanner_m[o.index], axis=1)
        for o in observations
        if o.index.size and _non_ground(features[o.feature])
    ]
    return float(np.median(np.concatenate(ranges))) if ranges else math.nan


def unlinked_directions(
    lines: Sequence[ScanLine], observations: Sequence[Observation], features: Sequence[Feature]
) -> str | None:
    """A warning when lines run both ways see walls, but rarely the same ones, or None.

    With a correct starting mount a wall, a roof or a sphere passed both ways is one
    feature seen by lines of both directions. A boresight several degrees off, axes in
    another order or another drive's trajectory put each direction's returns of it in
    different places: most such features are then seen by one direction only
    (`DirectionLinks.unlinked`). Beyond `MAX_WALL_RANGE_M` a start a few tenths of a
    degree off does it too, and the warning says so instead.

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
    ways = _directions(heading)
    if ways is None:
        return None
    links = direction_links(ways, observations, features)
    if not links.unlinked:
        return None
    names = {
        way: ", ".join(lines[int(i)].name for i in np.flatnonzero(ways == way)) for way in (1, -1)
    }
    deg = {
        way: math.degrees(float(np.angle(np.mean(np.exp(1j * heading[ways == way])))))
        for way in (1, -1)
    }
    seen = (
        f"{links.linked} of {links.total} walls, roofs or spheres are seen "
        f"alike by the lines driven both ways: {names[1]} (heading {deg[1]:.0f} deg) "
        f"see {links.forward_alone} more and {names[-1]} (heading {deg[-1]:.0f} deg) "
        f"{links.backward_alone} more that the other direction does not. "
    )
    range_m = wall_range_m(lines, observations, features)
    if range_m > MAX_WALL_RANGE_M:
        shift_m = range_m * math.tan(math.radians(_SHIFT_DEG))
        return seen + (
            f"At their median range, {range_m:.0f} m, {_SHIFT_DEG:g} deg of boresight moves "
            f"a return by {shift_m:.2g} m: a starting boresight a few tenths of a degree off "
            "does this, and the features were found with it. If the calibrated boresight "
            "differs from the start, calibrate again with the calibrated mount as the start; "
            "if the walls stay apart, check the starting mount and that the trajectory is "
            "these lines'"
        )
    return seen + (
        "The starting mount is likely grossly wrong (a boresight off by tens of degrees, axes "
        "in another order, a lever arm's sign) or the trajectory is not these lines'; "
        "unless the scanner sees different surfaces each way, do not trust these estimates"
    )


def search_yaw(
    lines: Sequence[ScanLine],
    prior: FloatArray,
    find: Callable[[FloatArray], tuple[Sequence[Feature], Sequence[Observation]]],
    progress: Callable[[str], None] | None = None,
) -> tuple[FloatArray, str] | None:
    """A boresight yaw whose walls both directions share, when the prior's are not shared.

    Run for lines driven both ways whose patches found with the prior are mostly seen by
    one direction alone (`DirectionLinks.unlinked`): the patches are found with the yaw
    turned in `YAW_SEARCH_STEP_DEG` steps all the way round, and the yaw with the most
    patches seen alike (and not `DirectionLinks.unlinked`; the nearest the prior's on a
    tie) is the start. A roll off by 180 deg or axes in another order are not searched.
    Nor is the yaw when the walls lie beyond `MAX_WALL_RANGE_M` (airborne strips): there
    a start within what a crew knows shares few walls too (on airborne strips, a yaw 5 to
    15 deg off, either way, shared more of them than a start 0.2 deg off did).

    Parameters
    ----------
    lines : sequence of ScanLine
        The lines.
    prior : ndarray, shape (7,)
        The starting mount's parameters (rad, m, s).
    find : callable
        ``find(values)``: the features and observations found with the mount ``values``
        (raises `InputError` when none are found).
    progress : callable, optional
        Told when the search starts.

    Returns
    -------
    tuple of (ndarray, str) or None
        The start (``prior`` with the yaw found) and a warning saying what was found;
        None when the prior's walls are shared or lie beyond `MAX_WALL_RANGE_M`, or no
        yaw shares them.
    """
    yaw = BORESIGHT[2]
    ways = line_directions(lines)
    if ways is None:
        return None
    features, observations = find(prior)
    at_prior = direction_links(ways, observations, features)
    if not at_prior.unlinked or wall_range_m(lines, observations, features) > MAX_WALL_RANGE_M:
        return None
    n = round(360.0 / YAW_SEARCH_STEP_DEG)
    if progress is not None:
        progress(f"searching the boresight yaw ({n} yaws): the two directions share few walls")
    best: tuple[tuple[int, float], FloatArray, DirectionLinks] | None = None
    for k in range(1, n):
        offset = math.radians(k * YAW_SEARCH_STEP_DEG)
        trial = prior.copy()
        trial[yaw] = float(wrap_angle_rad(prior[yaw] + offset))
        try:
            features, observations = find(trial)
        except InputError:
            continue
        links = direction_links(ways, observations, features)
        key = (links.linked, -abs(float(wrap_angle_rad(offset))))
        if not links.unlinked and links.linked > 0 and (best is None or key > best[0]):
            best = (key, trial, links)
    if best is None:
        return None
    _, trial, links = best
    note = (
        f"the starting boresight yaw {math.degrees(prior[yaw]):.1f} deg put the walls seen "
        f"both ways in different places ({at_prior.linked} of {at_prior.total} shared); a "
        f"search over the yaw in {YAW_SEARCH_STEP_DEG:g} deg steps found "
        f"{math.degrees(trial[yaw]):.1f} deg ({links.linked} of {links.total} shared) and the "
        "calibration started there: check the mount file's boresight"
    )
    return trial, note


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
