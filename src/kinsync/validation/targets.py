"""Control targets taken from a georeferenced cloud where they are brightest (SPEC section 7).

Each retro-reflective target is taken
from the cloud where it is brightest:

1. Points within ``search_radius_m`` of the surveyed position (each point goes to its
   nearest control point).
2. Intensity threshold: ``min_intensity`` when given, else Otsu's threshold of the
   intensities in that neighbourhood, accepted only when the bright class is at least
   ``AUTO_CONTRAST`` (2) times brighter on average than the dull one. A neighbourhood
   that is bright throughout (a target on a post, nothing else within the radius) is
   judged against the whole cloud instead: when its median intensity is at least
   ``AUTO_CONTRAST`` times the cloud's, the threshold is the geometric mean of the two
   medians.
3. Visits: the bright points are split in time wherever consecutive points are more
   than ``visit_gap_s`` apart, so each pass of the vehicle gives one observation.
4. Centre of each visit with at least ``min_points`` points: ``"tukey"`` (default;
   Tukey-biweight location per axis, c = 4.685 robust sigma, from the median: flat
   discs), ``"median"`` (per-axis median) or ``"sphere"`` (spherical targets of known
   radius: RANSAC + robust sphere fit, `kinsync.fit.segment_sphere`).

References
----------
Otsu, N., "A threshold selection method from gray-level histograms", IEEE Trans.
Systems, Man and Cybernetics 9(1), 1979, 62-66.
Mosteller, F. & Tukey, J. W., *Data Analysis and Regression*, Addison-Wesley 1977
(biweight location).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.spatial import cKDTree

from kinsync._arrays import ReadOnlyArrays
from kinsync._typing import ArrayLike, FloatArray, IntArray
from kinsync._validate import ecef_array, finite_number, positive_number, time_array
from kinsync.errors import ConvergenceError, InputError
from kinsync.fit import segment_sphere
from kinsync.frames import (
    rotation_ned_to_ecef,
)
from kinsync.robust import robust_sigma, robust_sigma_per_column
from kinsync.validation._common import finite_rows
from kinsync.validation.control_points import ControlPoints

__all__ = [
    "AUTO_CONTRAST",
    "CentreMethod",
    "CloudPoints",
    "MissingTarget",
    "TargetObservation",
    "check_extraction_options",
    "extract_targets",
    "nearest_control",
    "otsu_threshold",
]

CentreMethod = Literal["tukey", "median", "sphere"]
"""How a target's centre is taken from its bright points (see the module docstring)."""
_CENTRES: tuple[CentreMethod, ...] = ("tukey", "median", "sphere")


AUTO_CONTRAST = 2.0
"""Least ratio of the mean intensities (bright / dull) an automatic threshold accepts."""


_TUKEY_C = 4.685


@dataclass(frozen=True, eq=False)
class CloudPoints(ReadOnlyArrays):
    """Georeferenced points with their time and intensity.

    Parameters
    ----------
    pos_ecef_m : array_like, shape (N, 3)
        Positions, ECEF WGS84 (m).
    t_s : array_like, shape (N,), optional
        Measurement times (s), on the trajectory's time scale (GPS time).
    intensity : array_like, shape (N,), optional
        Return intensity (any scale; retro-reflective targets are the bright returns).

    Raises
    ------
    InputError
        Wrong shapes, non-finite values.
    """

    pos_ecef_m: FloatArray
    t_s: FloatArray | None = None
    intensity: FloatArray | None = None

    def __post_init__(self) -> None:
        pos = finite_rows(
            ecef_array(self.pos_ecef_m, "cloud pos_ecef_m"), None, 3, "cloud pos_ecef_m"
        )
        n = pos.shape[0]
        object.__setattr__(self, "pos_ecef_m", pos)
        if self.t_s is not None:
            object.__setattr__(
                self, "t_s", finite_rows(time_array(self.t_s, "cloud t_s"), n, None, "cloud t_s")
            )
        if self.intensity is not None:
            inten = finite_rows(self.intensity, n, None, "cloud intensity")
            object.__setattr__(self, "intensity", inten)

    def __len__(self) -> int:
        return int(self.pos_ecef_m.shape[0])


@dataclass(frozen=True)
class TargetObservation:
    """One visit of a control target, extracted from the cloud.

    Attributes
    ----------
    name : str
        Control point name.
    visit : int
        Visit number of this target (0, 1, ... in time order).
    t_s : float
        Median time of the target's points (s): the moment of scanning.
    centre_ecef_m : tuple of 3 float
        Target centre from the cloud, ECEF (m).
    centre_std_ned_m : tuple of 3 float
        Standard deviation of the centre along North, East, Down (m), from the spread
        of the points (Tukey/median) or the sphere fit's covariance.
    n_points : int
        Points the centre was computed from.
    intensity_threshold : float
        Intensity threshold used for this target.
    """

    name: str
    visit: int
    t_s: float
    centre_ecef_m: tuple[float, float, float]
    centre_std_ned_m: tuple[float, float, float]
    n_points: int
    intensity_threshold: float


@dataclass(frozen=True)
class MissingTarget:
    """A control point (or one visit of it) that gave no observation, and why."""

    name: str
    reason: str
    t_s: float | None = None


def _threshold_against_cloud(
    near: FloatArray, background: float, contrast: float
) -> tuple[float, float]:
    """Threshold of a neighbourhood bright throughout, judged against the cloud's median.

    Returns ``(threshold, contrast)``: the geometric mean of the two medians and their
    ratio when the neighbourhood is at least ``AUTO_CONTRAST`` times brighter than the
    cloud; otherwise NaN and the neighbourhood's own contrast, unchanged.
    """
    level = float(np.median(near))
    if not (math.isfinite(background) and level > 0.0):
        return math.nan, contrast
    if background <= 0.0:
        return 0.5 * level, math.inf
    ratio = level / background
    if ratio < AUTO_CONTRAST:
        return math.nan, contrast
    return math.sqrt(level * background), ratio


def _auto_threshold(near: FloatArray, background: float) -> float | str:
    """The automatic threshold of a neighbourhood, or why there is none (step 2)."""
    threshold, contrast = otsu_threshold(near)
    if math.isnan(contrast) or contrast < AUTO_CONTRAST:
        threshold, contrast = _threshold_against_cloud(near, background, contrast)
    if math.isnan(contrast) or contrast < AUTO_CONTRAST:
        return (
            f"bright/dull mean ratio {contrast:.3g} < {AUTO_CONTRAST:g}, nor against the "
            f"cloud's median intensity {background:.6g}"
        )
    return threshold


def otsu_threshold(values: ArrayLike) -> tuple[float, float]:
    """Otsu's threshold of a sample (exact, on the sorted values) and the class contrast.

    Parameters
    ----------
    values : array_like, shape (N,)
        Intensities.

    Returns
    -------
    threshold : float
        Midway between the two values the split falls between (NaN when all equal).
    contrast : float
        Mean of the upper class over mean of the lower class (inf when the lower
        mean is zero, NaN when there is no split).

    Raises
    ------
    InputError
        A value that is not finite (NaN sorts last and would shift the split).

    References
    ----------
    Otsu 1979 (IEEE SMC 9, 62-66).
    """
    raw = np.asarray(values, dtype=np.float64).ravel()
    bad = ~np.isfinite(raw)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        msg = f"otsu_threshold values[{i}] = {float(raw[i])!r} is not finite; drop it first"
        raise InputError(msg)
    v = np.sort(raw)
    n = v.size
    if n < 2 or v[0] == v[-1]:
        return math.nan, math.nan
    cs = np.cumsum(v)
    k = np.arange(1, n)
    valid = v[1:] > v[:-1]
    mu0 = cs[:-1] / k
    mu1 = (cs[-1] - cs[:-1]) / (n - k)
    between = (k / n) * (1 - k / n) * (mu0 - mu1) ** 2
    between = np.where(valid, between, -1.0)
    i = int(np.argmax(between))
    threshold = 0.5 * (v[i] + v[i + 1])
    contrast = mu1[i] / mu0[i] if mu0[i] > 0 else math.inf
    return float(threshold), float(contrast)


def _tukey_location(x: FloatArray) -> tuple[float, float]:
    """Biweight location of a 1-D sample and its standard error (sandwich form)."""
    mu = float(np.median(x))
    scale = robust_sigma(x - mu)
    if scale <= 0.0:
        return mu, 0.0
    for _ in range(50):
        u = (x - mu) / (_TUKEY_C * scale)
        w = np.where(np.abs(u) < 1.0, (1.0 - u * u) ** 2, 0.0)
        new = float(np.sum(w * x) / np.sum(w))
        if abs(new - mu) < 1e-9 * scale:
            mu = new
            break
        mu = new
    u = (x - mu) / (_TUKEY_C * scale)
    w = np.where(np.abs(u) < 1.0, (1.0 - u * u) ** 2, 0.0)
    std = float(np.sqrt(np.sum((w * (x - mu)) ** 2)) / np.sum(w))
    return mu, std


def _centre_local(
    local: FloatArray, centre: CentreMethod, radius_m: float | None
) -> tuple[FloatArray, FloatArray]:
    """Centre (3,) and its standard deviation (3,) of points in a local NED frame."""
    if centre == "median":
        med = np.median(local, axis=0)
        mad = robust_sigma_per_column(local - med)
        return med, 1.2533 * mad / math.sqrt(local.shape[0])
    if centre == "tukey":
        loc = [_tukey_location(local[:, j]) for j in range(3)]
        return np.array([m for m, _ in loc]), np.array([s for _, s in loc])
    fit = segment_sphere(local, radius_m=radius_m)
    return fit.center_m, np.sqrt(np.diag(fit.cov_center_m2))


def check_extraction_options(
    search_radius_m: float,
    min_intensity: float | None,
    centre: str,
    target_radius_m: float | None,
    min_points: int,
    visit_gap_s: float,
) -> None:
    """Raise `InputError` naming the first bad target-extraction option."""
    positive_number(search_radius_m, "search_radius_m")
    if min_intensity is not None:
        finite_number(min_intensity, "min_intensity")
    if centre not in _CENTRES:
        msg = f"centre must be one of {', '.join(_CENTRES)}, got {centre!r}"
        raise InputError(msg)
    if centre == "sphere":
        if target_radius_m is None:
            msg = "centre 'sphere' needs the target radius (target_radius_m / --target-radius-m)"
            raise InputError(msg)
        positive_number(target_radius_m, "target_radius_m")
        if target_radius_m >= search_radius_m:
            msg = (
                f"target radius {target_radius_m} m must be smaller than the search radius "
                f"{search_radius_m} m; enlarge --search-radius-m"
            )
            raise InputError(msg)
    if min_points < 4:
        msg = f"min_points must be >= 4, got {min_points}"
        raise InputError(msg)
    positive_number(visit_gap_s, "visit_gap_s")


def nearest_control(
    pos_ecef_m: FloatArray, control: ControlPoints, search_radius_m: float
) -> IntArray:
    """Index of the nearest control point within ``search_radius_m`` of each point.

    Parameters
    ----------
    pos_ecef_m : ndarray, shape (N, 3)
        Points, ECEF (m).
    control : ControlPoints
    search_radius_m : float
        Reach (m).

    Returns
    -------
    ndarray of int64, shape (N,)
        Index into ``control.names``, or -1 where no control point is within reach.
    """
    tree = cKDTree(control.pos_ecef_m)
    dist, idx = tree.query(pos_ecef_m, distance_upper_bound=search_radius_m)
    out: IntArray = np.where(np.isfinite(dist), idx, -1).astype(np.int64)
    return out


def extract_targets(
    cloud: CloudPoints,
    control: ControlPoints,
    *,
    search_radius_m: float = 0.5,
    min_intensity: float | None = None,
    centre: CentreMethod = "tukey",
    target_radius_m: float | None = None,
    min_points: int = 10,
    visit_gap_s: float = 1.0,
    background_intensity: float | None = None,
    cloud_span_s: tuple[float, float] | None = None,
) -> tuple[tuple[TargetObservation, ...], tuple[MissingTarget, ...]]:
    """Find each control target in the cloud: bright points near it, one centre per visit.

    Parameters
    ----------
    cloud : CloudPoints
        Georeferenced points with ``t_s`` and ``intensity``.
    control : ControlPoints
        Surveyed positions (ECEF).
    search_radius_m : float
        Radius around each control point where its target is looked for (m).
    min_intensity : float, optional
        Intensity threshold of the target's returns; default: Otsu's threshold in
        each neighbourhood (see the module docstring).
    centre : {"tukey", "median", "sphere"}
        Centre estimator (see the module docstring).
    target_radius_m : float, optional
        Sphere radius (m), required with ``centre="sphere"``.
    min_points : int
        Fewest bright points of a visit for a centre (>= 4).
    background_intensity : float, optional
        The survey's typical (median) intensity, against which a neighbourhood bright
        throughout is judged; default: the median of ``cloud.intensity`` (give it when
        ``cloud`` holds only the points near the targets).
    visit_gap_s : float
        Time gap (s) that separates two visits of a target.
    cloud_span_s : tuple of 2 float, optional
        Times (s) of the whole cloud's first and last points; default: those of
        ``cloud.t_s`` (give it when ``cloud`` holds only the points near the targets). A
        visit whose bright points come within one revisit interval (the longest interval
        between them) of either end may have been cut by the end of the cloud (a file
        split mid-pass): it is reported missing, since a centre from part of a target is
        biased (tens of mm).

    Returns
    -------
    observations : tuple of TargetObservation
        In time order.
    missing : tuple of MissingTarget
        Targets or visits without an observation, with the reason (never fatal here).

    Raises
    ------
    InputError
        Bad options; a cloud without ``t_s`` or ``intensity``.
    """
    check_extraction_options(
        search_radius_m, min_intensity, centre, target_radius_m, min_points, visit_gap_s
    )
    if cloud.t_s is None or cloud.intensity is None:
        msg = "extract_targets: the cloud needs point times (t_s) and intensities"
        raise InputError(msg)
    span = _cloud_span(cloud.t_s, cloud_span_s)
    owner = nearest_control(cloud.pos_ecef_m, control, search_radius_m)
    observations: list[TargetObservation] = []
    missing: list[MissingTarget] = []
    llh = control.lat_lon_h()
    background = (
        float(np.median(cloud.intensity)) if background_intensity is None else background_intensity
    )
    for j, name in enumerate(control.names):
        near = np.flatnonzero(owner == j)
        if near.size == 0:
            missing.append(
                MissingTarget(name, f"no point of the cloud within {search_radius_m:g} m")
            )
            continue
        if near.size < min_points:  # no threshold could leave enough: the target is elsewhere
            missing.append(
                MissingTarget(
                    name,
                    f"only {near.size} point(s) of the cloud within {search_radius_m:g} m "
                    f"(need {min_points} on the target): the cloud holds no target at the "
                    "surveyed position; check the control point's coordinates and height "
                    "(and the trajectory's), or --search-radius-m",
                )
            )
            continue
        inten = cloud.intensity[near]
        if min_intensity is None:
            threshold = _auto_threshold(inten, background)
            if isinstance(threshold, str):
                missing.append(
                    MissingTarget(
                        name,
                        f"no intensity contrast among the {near.size} points within "
                        f"{search_radius_m:g} m ({threshold}); give --min-intensity",
                    )
                )
                continue
        else:
            threshold = float(min_intensity)
        bright = near[inten >= threshold]
        if bright.size < min_points:
            missing.append(
                MissingTarget(
                    name,
                    f"only {bright.size} point(s) with intensity >= {threshold:.6g} within "
                    f"{search_radius_m:g} m (need {min_points}); check --min-intensity and "
                    "--search-radius-m",
                )
            )
            continue
        order = bright[np.argsort(cloud.t_s[bright], kind="stable")]
        t = cloud.t_s[order]
        cuts = np.flatnonzero(np.diff(t) > visit_gap_s) + 1
        R_ne = rotation_ned_to_ecef(llh[j, 0], llh[j, 1])
        visit = 0
        for part in np.split(order, cuts):
            t_mid = float(np.median(cloud.t_s[part]))
            why = _unusable_visit(cloud.t_s[part], min_points, span, visit_gap_s)
            if why:
                missing.append(MissingTarget(name, why, t_mid))
                continue
            local = (cloud.pos_ecef_m[part] - control.pos_ecef_m[j]) @ R_ne
            try:
                c_local, std = _centre_local(local, centre, target_radius_m)
            except (InputError, ConvergenceError) as err:
                missing.append(MissingTarget(name, f"no {centre} centre: {err}", t_mid))
                continue
            c_ecef = control.pos_ecef_m[j] + R_ne @ c_local
            observations.append(
                TargetObservation(
                    name=name,
                    visit=visit,
                    t_s=t_mid,
                    centre_ecef_m=(float(c_ecef[0]), float(c_ecef[1]), float(c_ecef[2])),
                    centre_std_ned_m=(float(std[0]), float(std[1]), float(std[2])),
                    n_points=int(part.size),
                    intensity_threshold=float(threshold),
                )
            )
            visit += 1
    observations.sort(key=lambda o: o.t_s)
    return tuple(observations), tuple(missing)


def _cloud_span(t_s: FloatArray, given: tuple[float, float] | None) -> tuple[float, float]:
    """The cloud's first and last point times (s): ``given`` checked, or ``t_s``'s."""
    if given is None:
        return (float(np.min(t_s)), float(np.max(t_s))) if t_s.size else (np.inf, -np.inf)
    if len(given) != 2:
        msg = f"cloud_span_s must be (first, last) point times in s, got {given!r}"
        raise InputError(msg)
    first = finite_number(given[0], "cloud_span_s[0]")
    last = finite_number(given[1], "cloud_span_s[1]")
    if last < first:
        msg = f"cloud_span_s must be (first, last) point times in s, got {given!r}"
        raise InputError(msg)
    if t_s.size and (float(np.min(t_s)) < first or float(np.max(t_s)) > last):
        msg = (
            f"cloud_span_s {given!r} does not hold the cloud's point times "
            f"({float(np.min(t_s))!r} .. {float(np.max(t_s))!r} s): give the first and last "
            "point times of the whole cloud"
        )
        raise InputError(msg)
    return first, last


def _unusable_visit(
    t_s: FloatArray, min_points: int, span: tuple[float, float], visit_gap_s: float
) -> str:
    """Why a visit (its bright points' times, s) gives no centre, or ``""``.

    Too few points; or a cut by an end of the cloud. The scanner comes back to a target
    it sees every revisit interval (the longest interval between the visit's own bright
    points: a profile, a revolution); a cloud whose first point comes less than that
    before the visit's first bright point may have begun in the middle of the visit (a
    file of a survey written per line or per minute), so the target may have been seen
    before it; likewise at the end. A cloud clipped around the targets begins farther
    away (8 m at 20 m/s is 0.4 s, against 4 ms between a profiler's profiles), so its
    visits are whole.
    """
    if t_s.size < min_points:
        return f"visit with only {t_s.size} bright point(s) (need {min_points})"
    times = np.sort(t_s)
    first, last = float(times[0]), float(times[-1])
    revisit = min(float(np.max(np.diff(times))), visit_gap_s)
    if first - span[0] <= revisit:
        where, t_end, gap = "start", span[0], first - span[0]
    elif span[1] - last <= revisit:
        where, t_end, gap = "end", span[1], span[1] - last
    else:
        return ""
    return (
        f"visit cut by the {where} of the cloud? its bright points come {gap:.3g} s from "
        f"the cloud's {'first' if where == 'start' else 'last'} point (t = {t_end!r} s), "
        f"no more than the {revisit:.3g} s the scanner took to come back to the target, "
        "so part of it may be in another file and its centre biased: validate one cloud "
        "that holds the whole pass (join its files)"
    )
