"""Validation of a georeferenced cloud: control points in the vehicle frame, wall flatness.

SPEC section 7. Two checks, each on plain containers, plus a file layer that streams a
cloud (CSV/Parquet from ``kinsync georef``, or LAS/LAZ) and keeps only what it needs.

**Control points** (`validate_control_points`). Each retro-reflective target is taken
from the cloud where it is brightest:

1. Points within ``search_radius_m`` of the surveyed position (each point goes to its
   nearest control point).
2. Intensity threshold: ``min_intensity`` when given, else Otsu's threshold of the
   intensities in that neighbourhood, accepted only when the bright class is at least
   ``AUTO_CONTRAST`` (2) times brighter on average than the dull one (a target needs
   a dull background in the radius: board, pole, wall or ground).
3. Visits: the bright points are split in time wherever consecutive points are more
   than ``visit_gap_s`` apart, so each pass of the vehicle gives one observation.
4. Centre of each visit with at least ``min_points`` points: ``"tukey"`` (default;
   Tukey-biweight location per axis, c = 4.685 robust sigma, from the median: flat
   discs), ``"median"`` (per-axis median) or ``"sphere"`` (spherical targets of known
   radius: RANSAC + robust sphere fit, `kinsync.fit.segment_sphere`).

The difference cloud - control is expressed in the vehicle frame (X right, Y forward,
Z up) of the attitude at the visit's time (median GPS time of its points), read from
the trajectory at that time. Alongside: the vehicle's forward speed, its yaw rate and
the target's position relative to the vehicle (``lateral_m`` = X, left < 0 < right).

The signatures are tested in one linear model of the along-track differences with
both regressors at once (`signature_tests`)::

    dY_i = c + tau · s_i - psi · X_i + b_pass(i) + f_i · g_target(i) + e_i

``s_i`` is the along-track (Y) velocity of the target point carried with the vehicle,
``v + omega x r`` in the vehicle frame, at the visit (the vehicle speed when driving
straight; exact rigid-body kinematics in a curve), ``X_i`` the target's lateral
position. A time error ``tau`` (the latency applied minus the true one) moves every
point by ``tau (v + omega x r)``; a heading misorientation ``psi`` (rotation of the
cloud about the vehicle's down axis, DIN 9300 yaw sense) moves it along-track by
``-psi X``: opposite signs left and right. The intercept ``c`` takes a constant
along-track offset (lever arm, survey datum). Fitting both at once keeps each test
free of the other signature. The noise is not assumed independent between visits:
``b`` is an offset shared by the visits of one pass (a GNSS error; passes split by
`pass_labels`) and ``g`` the horizontal survey error of each control point, seen along
the vehicle's forward direction ``f_i`` (driving past a target both ways flips its
survey error and its side together, so a survey error alone looks like a heading
error at that target). The three variances are estimated by restricted maximum
likelihood from the data, the coefficients by generalised least squares, and each
slope gets a two-sided t-test with Satterthwaite's degrees of freedom; a signature is
*significant* when ``p < 1 - level`` (``level = 0.99`` by default). Treating the
visits as independent instead would call pass and survey errors significant
signatures. A term is tested only when the data can tell it: the along-track
velocities must span at least ``MIN_SPEED_SPAN_M_S`` (2 m/s) over at least 3 passes,
and targets must be seen on both sides; otherwise it is reported as not testable and
left out of the model. Drive each speed in both directions.

**Flatness** (`fit_wall`). Points of a wall, in a local NED frame at their centroid
(ECEF-sized coordinates are never fitted directly). Plane by total least squares
(SVD); in-plane axes ``u`` (horizontal along the wall) and ``v`` (up the wall), the
residual ``w`` along the normal. Gross outliers are rejected against the quadratic
surface below (so that a real bend is not mistaken for outliers): points whose
residual exceeds ``outlier_k`` (4) times the robust sigma ``1.4826 MAD`` of the
current inliers, iterated to a stable set (10 passes at most). Residual statistics
(RMS, max, percentiles of ``|w|``) are those of the inliers from the plane. Curvature:
``w = a + b u + c v + d u² + e uv + f v²`` against the plane ``w = a + b u + c v``
(ordinary least squares on the same inliers), F-test of the three quadratic terms::

    F = ((RSS_plane - RSS_quad) / 3) / (RSS_quad / (n - 6)),   p = 1 - F_{3, n-6}(F)

``curvature_significant`` when ``p < 1 - level`` and the bow is at least
``min_bow_m`` (0 by default: the statistical test alone; give a tolerance to flag only
bends that matter on a large, imperfect real wall). The bow (sagitta) is the
peak-to-valley of (quadratic surface - plane) over the inliers. A time error bends a
wall only where the motion changes along it (a uniform circular motion rotates the
whole cloud rigidly about the turn centre, which the plane absorbs); entering a tight
curve it does.

References
----------
Otsu, N., "A threshold selection method from gray-level histograms", IEEE Trans.
Systems, Man and Cybernetics 9(1), 1979, 62-66.
Mosteller, F. & Tukey, J. W., *Data Analysis and Regression*, Addison-Wesley 1977
(biweight location).
Draper, N. R. & Smith, H., *Applied Regression Analysis*, 3rd ed., Wiley 1998 (t- and
extra-sum-of-squares F-tests).
Patterson, H. D. & Thompson, R., Biometrika 58(3), 1971, 545-554 (REML); Satterthwaite,
F. E., Biometrics Bulletin 2(6), 1946, 110-114.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
from scipy import stats
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from kinsync._typing import ArrayLike, BoolArray, FloatArray, IntArray
from kinsync._validate import finite_number, positive_number
from kinsync.crs import crs_to_ecef_transformer
from kinsync.errors import ConvergenceError, InputError, KinsyncError
from kinsync.fit import segment_sphere
from kinsync.frames import (
    body_to_vehicle,
    ecef_to_geodetic,
    ecef_to_ned,
    rotation_ned_to_ecef,
)
from kinsync.io.cloud import CloudExtent, check_finite_chunk, cloud_crs, iter_cloud
from kinsync.io.control_points import ControlPoints, read_control_points
from kinsync.io.trajectory import read_trajectory_file
from kinsync.robust import robust_sigma, robust_sigma_per_column
from kinsync.trajectory import Trajectory

__all__ = [
    "AUTO_CONTRAST",
    "MIN_SPEED_SPAN_M_S",
    "PASS_GAP_S",
    "Box",
    "CentreMethod",
    "CloudPoints",
    "ControlPointDifference",
    "ControlPointReport",
    "FlatnessResult",
    "MissingTarget",
    "SignatureTest",
    "SignatureTests",
    "TargetObservation",
    "control_point_differences",
    "control_points_file",
    "extract_targets",
    "fit_wall",
    "flatness_file",
    "nearest_control",
    "otsu_threshold",
    "parse_box",
    "pass_labels",
    "select_box",
    "signature_tests",
    "validate_control_points",
]

CentreMethod = Literal["tukey", "median", "sphere"]
Box = tuple[float, float, float, float, float, float]
"""``(xmin, ymin, zmin, xmax, ymax, zmax)`` in the cloud's CRS."""

AUTO_CONTRAST = 2.0
"""Least ratio of the mean intensities (bright / dull) an automatic threshold accepts."""
MIN_SPEED_SPAN_M_S = 2.0
"""Least span of along-track velocities for the time-error term to be tested (m/s)."""
MIN_FLATNESS_POINTS = 10
PASS_GAP_S = 10.0
_REML_ITERATIONS = 100
"""Time gap between visits (s) that starts a new pass of the vehicle."""
_TUKEY_C = 4.685
_RATE_STEP_S = 0.05
_ECEF_CRS = "EPSG:4978"
_CENTRES: tuple[CentreMethod, ...] = ("tukey", "median", "sphere")


# =============================================================================== containers
def _as_rows(values: ArrayLike, n: int | None, width: int | None, name: str) -> FloatArray:
    try:
        arr = np.array(values, dtype=np.float64)
    except (TypeError, ValueError) as err:
        msg = f"{name}: expected numbers ({err})"
        raise InputError(msg) from err
    shape_ok = (arr.ndim == 2 and arr.shape[1] == width) if width else arr.ndim == 1
    if not shape_ok or (n is not None and arr.shape[0] != n):
        want = f"({'N' if n is None else n}, {width})" if width else f"({n},)"
        msg = f"{name}: expected shape {want}, got {arr.shape}"
        raise InputError(msg)
    bad = ~np.isfinite(arr) if arr.ndim == 1 else ~np.all(np.isfinite(arr), axis=1)
    if np.any(bad):
        row = int(np.flatnonzero(bad)[0])
        msg = f"{name}: non-finite value at point {row}; drop or fix it"
        raise InputError(msg)
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, eq=False)
class CloudPoints:
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
        pos = _as_rows(self.pos_ecef_m, None, 3, "cloud pos_ecef_m")
        n = pos.shape[0]
        object.__setattr__(self, "pos_ecef_m", pos)
        if self.t_s is not None:
            object.__setattr__(self, "t_s", _as_rows(self.t_s, n, None, "cloud t_s"))
        if self.intensity is not None:
            inten = _as_rows(self.intensity, n, None, "cloud intensity")
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


@dataclass(frozen=True)
class ControlPointDifference:
    """Cloud - control for one visit, in the vehicle frame at the moment of scanning.

    Attributes
    ----------
    observation : TargetObservation
    diff_vehicle_m : tuple of 3 float
        (dX right, dY forward, dZ up) of cloud - control (m).
    diff_ned_m : tuple of 3 float
        The same difference in NED at the vehicle (m).
    speed_m_s : float
        Forward speed of the vehicle (vehicle-frame Y velocity, m/s).
    along_speed_m_s : float
        Along-track (Y) velocity of the target point carried with the vehicle frame,
        ``v + omega x r`` (m/s): the time-error regressor.
    heading_deg : float
        Heading (yaw) of the vehicle at the visit (deg from north, clockwise).
    yaw_rate_deg_s : float
        Yaw rate of the vehicle (body z rate, deg/s; > 0 turning right).
    lateral_m : float
        Target position relative to the vehicle reference point, X right (m).
    forward_m, up_m : float
        The target's Y (forward) and Z (up) relative to the vehicle (m).
    """

    observation: TargetObservation
    diff_vehicle_m: tuple[float, float, float]
    diff_ned_m: tuple[float, float, float]
    speed_m_s: float
    along_speed_m_s: float
    heading_deg: float
    yaw_rate_deg_s: float
    lateral_m: float
    forward_m: float
    up_m: float

    @property
    def side(self) -> str:
        """``"left"`` or ``"right"`` of the vehicle."""
        return "left" if self.lateral_m < 0.0 else "right"


@dataclass(frozen=True)
class SignatureTest:
    """A regression coefficient tested against zero (two-sided t-test).

    Attributes
    ----------
    quantity : str
        ``"time_error"`` or ``"heading_error"``.
    unit : str
        Unit of ``estimate`` and ``std`` (``"s"`` or ``"deg"``).
    estimate, std : float
        Coefficient and its standard deviation (NaN when not testable).
    t_statistic, p_value : float
        ``estimate / std`` and the two-sided p-value (NaN when not testable).
    dof : float
        Degrees of freedom of the t-test (Satterthwaite; 0 when not testable).
    level : float
        Confidence level of the test (e.g. 0.99).
    significant : bool
        ``p_value < 1 - level``.
    testable : bool
        False when the data cannot tell the term (then ``reason`` says why).
    reason : str
        Why it is not testable (empty when testable).
    """

    quantity: str
    unit: str
    estimate: float
    std: float
    t_statistic: float
    p_value: float
    dof: float
    level: float
    significant: bool
    testable: bool
    reason: str = ""

    def as_document(self) -> dict[str, Any]:
        """JSON-ready fields, keys carrying the unit."""
        q, u = self.quantity, self.unit
        return {
            f"{q}_{u}": self.estimate,
            f"{q}_std_{u}": self.std,
            "t_statistic": self.t_statistic,
            "p_value": self.p_value,
            "dof": self.dof,
            "level": self.level,
            "significant": self.significant,
            "testable": self.testable,
            "reason": self.reason,
        }


@dataclass(frozen=True)
class SignatureTests:
    """The two signature tests of one regression and its noise estimates.

    Attributes
    ----------
    time_error, heading_error : SignatureTest
    intercept_m : float
        Constant along-track offset (m).
    residual_std_m : float
        Noise of one difference within a pass (m).
    pass_std_m : float
        Standard deviation of the offset common to a pass (m).
    survey_std_m : float
        Standard deviation of a control point's horizontal survey error, per axis (m).
    n_passes : int
        Passes found (`pass_labels`).
    """

    time_error: SignatureTest
    heading_error: SignatureTest
    intercept_m: float
    residual_std_m: float
    pass_std_m: float
    survey_std_m: float
    n_passes: int


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


# =============================================================================== extraction
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

    References
    ----------
    Otsu 1979 (IEEE SMC 9, 62-66).
    """
    v = np.sort(np.asarray(values, dtype=np.float64).ravel())
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


def _check_extraction_options(
    search_radius_m: float,
    min_intensity: float | None,
    centre: str,
    target_radius_m: float | None,
    min_points: int,
    visit_gap_s: float,
) -> None:
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
    visit_gap_s : float
        Time gap (s) that separates two visits of a target.

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
    _check_extraction_options(
        search_radius_m, min_intensity, centre, target_radius_m, min_points, visit_gap_s
    )
    if cloud.t_s is None or cloud.intensity is None:
        msg = "extract_targets: the cloud needs point times (t_s) and intensities"
        raise InputError(msg)
    owner = nearest_control(cloud.pos_ecef_m, control, search_radius_m)
    observations: list[TargetObservation] = []
    missing: list[MissingTarget] = []
    llh = control.lat_lon_h()
    for j, name in enumerate(control.names):
        near = np.flatnonzero(owner == j)
        if near.size == 0:
            missing.append(
                MissingTarget(name, f"no point of the cloud within {search_radius_m:g} m")
            )
            continue
        inten = cloud.intensity[near]
        if min_intensity is None:
            threshold, contrast = otsu_threshold(inten)
            if math.isnan(contrast) or contrast < AUTO_CONTRAST:
                missing.append(
                    MissingTarget(
                        name,
                        f"no intensity contrast among the {near.size} points within "
                        f"{search_radius_m:g} m (bright/dull mean ratio {contrast:.3g} < "
                        f"{AUTO_CONTRAST:g}); give --min-intensity",
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
            if part.size < min_points:
                missing.append(
                    MissingTarget(
                        name,
                        f"visit with only {part.size} bright point(s) (need {min_points})",
                        t_mid,
                    )
                )
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


# =============================================================================== differences
def _states_at(
    trajectory: Trajectory, t_s: float
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray] | None:
    """Position ECEF, R_body_to_ned, velocity NED and body rate at ``t_s`` (or None).

    Velocity and rate are central differences over +-0.05 s (moved inside the span
    near its ends).
    """
    if not bool(trajectory.contains(t_s)):
        return None
    h = min(_RATE_STEP_S, trajectory.duration_s / 2.0)
    mid = min(max(t_s, trajectory.t_start_s + h), trajectory.t_end_s - h)
    sample = trajectory.interpolate(np.array([t_s, mid - h, mid + h]))
    pos = sample.pos_ecef_m()
    llh = ecef_to_geodetic(pos[0])
    R_ne = rotation_ned_to_ecef(llh[0], llh[1])
    vel_ned = R_ne.T @ ((pos[2] - pos[1]) / (2.0 * h))
    q = sample.q_body_to_ned[1:, [1, 2, 3, 0]]
    rate_body = (Rotation.from_quat(q[0]).inv() * Rotation.from_quat(q[1])).as_rotvec() / (2.0 * h)
    return pos[0], sample.R_body_to_ned[0], vel_ned, rate_body


def control_point_differences(
    observations: tuple[TargetObservation, ...],
    control: ControlPoints,
    trajectory: Trajectory,
) -> tuple[tuple[ControlPointDifference, ...], tuple[MissingTarget, ...]]:
    """Express each observation's cloud - control difference in the vehicle frame.

    Parameters
    ----------
    observations : tuple of TargetObservation
        From `extract_targets`.
    control : ControlPoints
        The same control points.
    trajectory : Trajectory
        Vehicle trajectory on the cloud's time scale. The state is read at the
        observation's time (a latency of milliseconds changes the vehicle frame by far
        less than the differences' precision). Velocity and body rate come from central
        differences over +-0.05 s.

    Returns
    -------
    differences : tuple of ControlPointDifference
    missing : tuple of MissingTarget
        Observations whose time lies outside the trajectory's span.
    """
    index = {n: i for i, n in enumerate(control.names)}
    out: list[ControlPointDifference] = []
    missing: list[MissingTarget] = []
    for obs in observations:
        states = _states_at(trajectory, obs.t_s)
        if states is None:
            missing.append(
                MissingTarget(
                    obs.name,
                    f"visit time {obs.t_s!r} s outside the trajectory span "
                    f"[{trajectory.t_start_s!r}, {trajectory.t_end_s!r}] s",
                    obs.t_s,
                )
            )
            continue
        pos_ecef, R_bn, vel_ned, rate_body = states
        llh = ecef_to_geodetic(pos_ecef)
        R_ne = rotation_ned_to_ecef(llh[0], llh[1])
        target = control.pos_ecef_m[index[obs.name]]
        diff_ned = R_ne.T @ (np.asarray(obs.centre_ecef_m) - target)
        diff_v = body_to_vehicle(R_bn.T @ diff_ned)
        r_body = R_bn.T @ (R_ne.T @ (target - pos_ecef))
        r_v = body_to_vehicle(r_body)
        v_body = R_bn.T @ vel_ned
        sweep_v = body_to_vehicle(v_body + np.cross(rate_body, r_body))
        out.append(
            ControlPointDifference(
                observation=obs,
                diff_vehicle_m=(float(diff_v[0]), float(diff_v[1]), float(diff_v[2])),
                diff_ned_m=(float(diff_ned[0]), float(diff_ned[1]), float(diff_ned[2])),
                speed_m_s=float(v_body[0]),
                along_speed_m_s=float(sweep_v[1]),
                heading_deg=math.degrees(math.atan2(float(R_bn[1, 0]), float(R_bn[0, 0]))),
                yaw_rate_deg_s=math.degrees(float(rate_body[2])),
                lateral_m=float(r_v[0]),
                forward_m=float(r_v[1]),
                up_m=float(r_v[2]),
            )
        )
    return tuple(out), tuple(missing)


def _untestable(quantity: str, unit: str, level: float, reason: str) -> SignatureTest:
    nan = math.nan
    return SignatureTest(
        quantity=quantity,
        unit=unit,
        estimate=nan,
        std=nan,
        t_statistic=nan,
        p_value=nan,
        dof=0.0,
        level=level,
        significant=False,
        testable=False,
        reason=reason,
    )


def pass_labels(
    differences: tuple[ControlPointDifference, ...], pass_gap_s: float = PASS_GAP_S
) -> IntArray:
    """Number the passes of the vehicle past the control field, per difference.

    In time order, a new pass starts when the time since the previous visit exceeds
    ``pass_gap_s`` or when a target already seen in the current pass comes again.

    Returns
    -------
    ndarray of int64, shape (K,)
        Pass number of each difference (0, 1, ...), in the order given.
    """
    order = np.argsort([d.observation.t_s for d in differences], kind="stable")
    labels = np.zeros(len(differences), dtype=np.int64)
    current = -1
    seen: set[str] = set()
    last_t = -math.inf
    for i in order:
        obs = differences[int(i)].observation
        if current < 0 or obs.t_s - last_t > pass_gap_s or obs.name in seen:
            current += 1
            seen = set()
        seen.add(obs.name)
        last_t = obs.t_s
        labels[int(i)] = current
    return labels


@dataclass(frozen=True)
class _MixedFit:
    """GLS coefficients with REML variance components and Satterthwaite dof."""

    coef: FloatArray
    cov: FloatArray
    dof: FloatArray
    sigma_e: float
    sigma_by_kernel: dict[str, float]


@dataclass(frozen=True)
class _Reml:
    """One evaluation of the REML criterion at variances ``theta``."""

    value: float
    grad: FloatArray
    P: FloatArray
    Vi: FloatArray
    C: FloatArray
    beta: FloatArray


def _reml_terms(
    theta: FloatArray, y: FloatArray, design: FloatArray, derivs: list[FloatArray]
) -> _Reml:
    """Minus twice the REML log-likelihood (no constant) and its gradient in theta.

    ``V = sum theta_a D_a`` with ``D_0 = I``; ``-2 l = log|V| + log|X'V^-1X| + y'Py``,
    ``d(-2 l)/d theta_a = tr(P D_a) - y'P D_a P y``, ``P = V^-1 - V^-1 X C X'V^-1``.
    """
    V = sum((t * D for t, D in zip(theta, derivs, strict=True)), np.zeros_like(derivs[0]))
    L = np.linalg.cholesky(V)
    Vi = np.linalg.inv(V)
    ViX = Vi @ design
    M = design.T @ ViX
    C: FloatArray = np.asarray(np.linalg.inv(M), dtype=np.float64)
    beta = C @ (ViX.T @ y)
    P = Vi - ViX @ C @ ViX.T
    Py = P @ y
    _, logdet_m = np.linalg.slogdet(M)
    value = 2.0 * float(np.sum(np.log(np.diag(L)))) + float(logdet_m) + float(y @ Py)
    grad = np.array([float(np.sum(P * D)) - float(Py @ D @ Py) for D in derivs])
    return _Reml(value, grad, P, Vi, C, beta)


def _reml_fit(y: FloatArray, design: FloatArray, named: dict[str, FloatArray]) -> _MixedFit:
    """REML variance components (noise + one per kernel), GLS and Satterthwaite dof.

    ``named`` holds the covariance patterns ``Z Z^T`` of the random effects; the
    variances (>= 0; the noise >= 1e-8 of the OLS residual variance) by projected Fisher
    scoring with step halving.
    """
    n, p = design.shape
    derivs = [np.eye(n), *named.values()]
    resid = y - design @ _lstsq(design, y)
    total = max(float(resid @ resid) / max(n - p, 1), 1e-16)
    k = len(derivs)

    floor = np.full(k, 0.0)
    floor[0] = 1e-8 * total  # the noise variance stays positive: V must be invertible
    theta = np.full(k, total / k)
    fit = _reml_terms(theta, y, design, derivs)
    for _ in range(_REML_ITERATIONS):
        # Projected Fisher scoring on theta >= floor: variances at their floor that the
        # score pushes down are held; the step stops where a free one reaches its floor.
        grad = fit.grad
        PD = [fit.P @ D for D in derivs]
        info = np.array([[0.5 * float(np.sum(a * b.T)) for b in PD] for a in PD])
        free = ~((theta <= floor * (1.0 + 1e-12)) & (grad > 0.0))
        step = np.zeros(k)
        step[free] = np.linalg.pinv(info[np.ix_(free, free)]) @ (-0.5 * grad[free])
        down = step < 0.0
        reach = np.min((floor[down] - theta[down]) / step[down], initial=np.inf)
        alpha = min(1.0, float(reach))
        improved = False
        for _halving in range(30):
            trial = np.maximum(theta + alpha * step, floor)
            new = _reml_terms(trial, y, design, derivs)
            if new.value <= fit.value:
                improved = True
                break
            alpha /= 2.0
        if not improved:
            break
        moved = float(np.max(np.abs(trial - theta))) / total
        theta, fit = trial, new
        if moved < 1e-9:
            break
    # Satterthwaite: dof_j = 2 var_j^2 / (g_j' A g_j), A = inverse expected information of
    # the variances (I_ab = tr(P D_a P D_b) / 2), g_j = d var_j / d theta.
    PD = [fit.P @ D for D in derivs]
    info = np.array([[0.5 * float(np.sum(a * b.T)) for b in PD] for a in PD])
    A = np.linalg.pinv(info)
    ViX = fit.Vi @ design
    grads = np.array([np.diag(fit.C @ (ViX.T @ D @ ViX) @ fit.C) for D in derivs])
    var = np.diag(fit.C)
    denom = np.einsum("ap,ab,bp->p", grads, A, grads)
    dof = np.where(denom > 0.0, 2.0 * var**2 / np.where(denom > 0.0, denom, 1.0), n - p)
    sig = np.sqrt(theta)
    return _MixedFit(
        coef=fit.beta,
        cov=fit.C,
        dof=np.clip(dof, 1.0, max(n - p, 1)),
        sigma_e=float(sig[0]),
        sigma_by_kernel={name: float(v) for name, v in zip(named, sig[1:], strict=True)},
    )


def _forward_ne(differences: tuple[ControlPointDifference, ...]) -> FloatArray:
    """Horizontal forward unit vector (north, east) of the vehicle at each visit."""
    h = np.radians([d.heading_deg for d in differences])
    return np.column_stack([np.cos(h), np.sin(h)]).reshape(-1, 2)


def _signature_terms(
    s: FloatArray, x: FloatArray, groups: int
) -> tuple[list[FloatArray], list[str], dict[str, str]]:
    """Design columns (intercept first), the testable terms, why the others are not."""
    n = s.size
    columns = [np.ones(n)]
    names: list[str] = []
    reasons: dict[str, str] = {}
    span = float(np.ptp(s)) if n else 0.0
    if span < MIN_SPEED_SPAN_M_S:
        reasons["time"] = (
            f"along-track speeds span {span:.3g} m/s (< {MIN_SPEED_SPAN_M_S:g}): drive the "
            "targets at several speeds"
        )
    elif groups < 3:
        reasons["time"] = (
            f"{groups} pass(es): the time error rests on the passes and needs at least 3 "
            "(better: each speed in both directions)"
        )
    else:
        columns.append(s)
        names.append("time")
    if n and np.any(x < 0.0) and np.any(x > 0.0):
        columns.append(x)
        names.append("heading")
    else:
        reasons["heading"] = "targets seen on one side only: place targets on both sides"
    return columns, names, reasons


def signature_tests(
    differences: tuple[ControlPointDifference, ...],
    level: float = 0.99,
    pass_gap_s: float = PASS_GAP_S,
) -> SignatureTests:
    """Regress dY on the along-track velocity and the lateral position; t-test each slope.

    The model (a linear mixed model) is::

        dY_i = c + tau s_i - psi X_i + b_pass(i) + f_i . g_target(i) + e_i

    with three independent random terms: ``e`` the noise of one visit (variance
    ``sigma_e^2``), ``b`` an offset common to a pass (``sigma_pass^2``; passes from
    `pass_labels`: a GNSS error shared by the pass) and ``g`` a horizontal error of
    each control point's survey (``sigma_target^2`` per axis), seen along the vehicle's
    forward unit vector ``f_i``. The survey term matters: driving past a target one
    way and then the other flips both its survey error and its lateral side, so a
    survey error looks exactly like a heading error at that target, and only the
    scatter between targets tells them apart. Variance components by restricted
    maximum likelihood, coefficients by generalised least squares, each coefficient's
    t-test with Satterthwaite's degrees of freedom (small for the time error with few
    passes, or for the heading error with few targets: the test stays honest). A pass
    term needs 2 passes, a survey term a target seen twice; the time error needs 3
    passes.

    Parameters
    ----------
    differences : tuple of ControlPointDifference
    level : float
        Confidence level in (0, 1): a slope is significant when ``p < 1 - level``.
    pass_gap_s : float
        Time gap (s) between visits that starts a new pass.

    Returns
    -------
    SignatureTests

    Raises
    ------
    InputError
        ``level`` outside (0, 1), a non-positive ``pass_gap_s``.

    References
    ----------
    Patterson, H. D. & Thompson, R., "Recovery of inter-block information when block
    sizes are unequal", Biometrika 58(3), 1971, 545-554 (REML); Satterthwaite, F. E.,
    "An approximate distribution of estimates of variance components", Biometrics
    Bulletin 2(6), 1946, 110-114; Kuznetsova, A. et al., "lmerTest package", J. Stat.
    Softw. 82(13), 2017 (Satterthwaite's dof for mixed-model coefficients).
    """
    level = finite_number(level, "level")
    if not 0.0 < level < 1.0:
        msg = f"level must lie in (0, 1), e.g. 0.99, got {level}"
        raise InputError(msg)
    positive_number(pass_gap_s, "pass_gap_s")
    dy = np.array([d.diff_vehicle_m[1] for d in differences], dtype=np.float64)
    s = np.array([d.along_speed_m_s for d in differences], dtype=np.float64)
    x = np.array([d.lateral_m for d in differences], dtype=np.float64)
    labels = pass_labels(differences, pass_gap_s)
    n = dy.size
    groups = int(labels.max()) + 1 if n else 0
    columns, names, reasons = _signature_terms(s, x, groups)
    kernels: dict[str, FloatArray] = {}
    if groups >= 2:
        kernels["pass"] = (labels[:, None] == labels[None, :]).astype(np.float64)
    target = np.array([d.observation.name for d in differences])
    if n and np.unique(target).size < n:
        f = _forward_ne(differences)
        kernels["target"] = (target[:, None] == target[None, :]) * (f @ f.T)
    while n - len(columns) < 2 and names:
        dropped = names.pop()
        columns.pop()
        reasons[dropped] = f"{n} observation(s): too few to estimate the noise as well"
    while names and np.linalg.matrix_rank(np.column_stack(columns)) < len(columns):
        dropped = names.pop()
        columns.pop()
        reasons[dropped] = (
            "speed and side are confounded (each side seen at one speed only): drive every "
            "speed past targets on both sides"
        )
    if n < 2:
        reasons.update(dict.fromkeys(names, f"{n} observation(s)"))
        names = []
    fit = _reml_fit(dy, np.column_stack(columns), kernels) if n >= 2 else None
    alpha = 1.0 - level

    def test(name: str, quantity: str, unit: str, scale: float) -> SignatureTest:
        if name not in names or fit is None:
            return _untestable(quantity, unit, level, reasons[name])
        k = 1 + names.index(name)
        est, sd, dof = float(fit.coef[k]), math.sqrt(float(fit.cov[k, k])), float(fit.dof[k])
        t_stat = est / sd if sd > 0.0 else (math.copysign(math.inf, est) if est else 0.0)
        p_val = float(2.0 * stats.t.sf(abs(t_stat), dof))
        return SignatureTest(
            quantity=quantity,
            unit=unit,
            estimate=scale * est,
            std=abs(scale) * sd,
            t_statistic=t_stat,
            p_value=p_val,
            dof=dof,
            level=level,
            significant=p_val < alpha,
            testable=True,
        )

    nan = math.nan
    return SignatureTests(
        time_error=test("time", "time_error", "s", 1.0),
        heading_error=test("heading", "heading_error", "deg", -math.degrees(1.0)),
        intercept_m=float(fit.coef[0]) if fit is not None else nan,
        residual_std_m=fit.sigma_e if fit is not None else nan,
        pass_std_m=fit.sigma_by_kernel.get("pass", 0.0) if fit is not None else nan,
        survey_std_m=fit.sigma_by_kernel.get("target", 0.0) if fit is not None else nan,
        n_passes=groups,
    )


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
) -> ControlPointReport:
    """Extract targets, express the differences in the vehicle frame, test the signatures.

    Parameters are those of `extract_targets`, `control_point_differences` and
    `signature_tests`.

    Returns
    -------
    ControlPointReport

    Raises
    ------
    InputError
        Bad options, or no control point found at all (each missing one is listed with
        its reason in the message).
    """
    observations, missing = extract_targets(
        cloud,
        control,
        search_radius_m=search_radius_m,
        min_intensity=min_intensity,
        centre=centre,
        target_radius_m=target_radius_m,
        min_points=min_points,
        visit_gap_s=visit_gap_s,
    )
    differences, outside = control_point_differences(observations, control, trajectory)
    missing = missing + outside
    if not differences:
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
    )


# =============================================================================== flatness
@dataclass(frozen=True, eq=False)
class FlatnessResult:
    """Plane fit of a wall, residual statistics and the curvature test.

    Attributes
    ----------
    n_selected : int
        Points given.
    n_points : int
        Inliers used in the fits.
    n_rejected : int
        Gross outliers left out (``n_selected - n_points``).
    origin_lat_lon_h : tuple of 3 float
        Origin of the local NED frame (the centroid of the points), (deg, deg, m).
    centre_ned_m : ndarray, shape (3,)
        Centroid of the inliers in that frame (m).
    normal_ned : ndarray, shape (3,)
        Unit normal of the plane, NED.
    u_axis_ned, v_axis_ned : ndarray, shape (3,)
        In-plane unit axes, NED: ``u`` horizontal along the wall, ``v`` up the wall
        (principal axes for a near-horizontal plane).
    u_m, v_m : ndarray, shape (n_points,)
        In-plane coordinates of the inliers from the centroid (m).
    residual_m : ndarray, shape (n_points,)
        Signed distance of each inlier from the plane along the normal (m).
    rms_m, max_abs_m : float
        RMS and largest absolute residual of the inliers (m).
    percentiles_m : dict of str to float
        Percentiles 50, 90, 95, 99 of ``|residual|`` (m), keyed ``"p50"``, ...
    quadratic_m : ndarray, shape (6,)
        ``(a, b, c, d, e, f)`` of ``w = a + b u + c v + d u² + e uv + f v²``
        (m, -, -, 1/m, 1/m, 1/m).
    quadratic_std_m : ndarray, shape (6,)
        Their standard deviations.
    f_statistic, p_value : float
        F-test of the quadratic terms against the plane.
    bow_m : float
        Peak-to-valley of (quadratic surface - plane) over the inliers (m).
    level : float
        Confidence level of the test.
    min_bow_m : float
        Least bow for the curvature to be flagged (m).
    curvature_significant : bool
        ``p_value < 1 - level`` and ``bow_m >= min_bow_m``.
    outlier_k : float
        Rejection threshold in robust sigmas.
    """

    n_selected: int
    n_points: int
    n_rejected: int
    origin_lat_lon_h: tuple[float, float, float]
    centre_ned_m: FloatArray
    normal_ned: FloatArray
    u_axis_ned: FloatArray
    v_axis_ned: FloatArray
    u_m: FloatArray
    v_m: FloatArray
    residual_m: FloatArray
    rms_m: float
    max_abs_m: float
    percentiles_m: dict[str, float]
    quadratic_m: FloatArray
    quadratic_std_m: FloatArray
    f_statistic: float
    p_value: float
    bow_m: float
    level: float
    min_bow_m: float
    curvature_significant: bool
    outlier_k: float
    rule: str = field(default="")

    @property
    def extent_u_m(self) -> float:
        """Extent of the inliers along u (m)."""
        return float(np.ptp(self.u_m))

    @property
    def extent_v_m(self) -> float:
        """Extent of the inliers along v (m)."""
        return float(np.ptp(self.v_m))

    def bend_m(self, u_m: ArrayLike, v_m: ArrayLike) -> FloatArray:
        """Quadratic surface minus the least-squares plane at in-plane points (m)."""
        u = np.asarray(u_m, dtype=np.float64)
        v = np.asarray(v_m, dtype=np.float64)
        return _bend(self.quadratic_m, self._plane_ols, u, v)

    @property
    def _plane_ols(self) -> FloatArray:
        return _lstsq(_design(self.u_m, self.v_m, 3), self.residual_m)

    def as_document(self) -> dict[str, Any]:
        """The ``--json`` document of ``kinsync validate flatness``."""
        q, qs = self.quadratic_m, self.quadratic_std_m
        names = ("a_m", "b", "c", "d_per_m", "e_per_m", "f_per_m")
        return {
            "n_points": self.n_points,
            "n_selected": self.n_selected,
            "n_rejected": self.n_rejected,
            "rms_m": self.rms_m,
            "max_abs_m": self.max_abs_m,
            "percentiles_abs_m": dict(self.percentiles_m),
            "curvature_significant": self.curvature_significant,
            "curvature_f": self.f_statistic,
            "curvature_p_value": self.p_value,
            "bow_m": self.bow_m,
            "level": self.level,
            "min_bow_m": self.min_bow_m,
            "extent_u_m": self.extent_u_m,
            "extent_v_m": self.extent_v_m,
            "origin_lat_lon_h": list(self.origin_lat_lon_h),
            "centre_ned_m": self.centre_ned_m.tolist(),
            "normal_ned": self.normal_ned.tolist(),
            "quadratic": {n: float(v) for n, v in zip(names, q, strict=True)},
            "quadratic_std": {n: float(v) for n, v in zip(names, qs, strict=True)},
            "outlier_rule": self.rule,
        }


def _lstsq(design: FloatArray, y: FloatArray) -> FloatArray:
    """Least-squares coefficients of ``design @ x = y``."""
    coef, *_ = np.linalg.lstsq(design, y, rcond=None)
    out: FloatArray = np.asarray(coef, dtype=np.float64)
    return out


def _design(u: FloatArray, v: FloatArray, p: int) -> FloatArray:
    cols = [np.ones_like(u), u, v, u * u, u * v, v * v][:p]
    return np.column_stack(cols)


def _bend(quad: FloatArray, plane: FloatArray, u: FloatArray, v: FloatArray) -> FloatArray:
    out: FloatArray = _design(u, v, 6) @ quad - _design(u, v, 3) @ plane
    return out


def _plane_axes(local: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Centroid, normal, u (horizontal) and v (up-ish) axes of the TLS plane."""
    c = local.mean(axis=0)
    _, sing, vt = np.linalg.svd(local - c, full_matrices=False)
    spread = sing / math.sqrt(local.shape[0])
    if spread[1] < 1e-4 or spread[1] < 1e-6 * spread[0]:
        msg = (
            f"degenerate selection: the {local.shape[0]} points lie on a line (spread "
            f"{spread[0]:.3g} m along it, {spread[1]:.3g} m across); a plane needs an area: "
            "enlarge the box"
        )
        raise InputError(msg)
    n = vt[2] if vt[2][np.argmax(np.abs(vt[2]))] > 0.0 else -vt[2]
    up = np.array([0.0, 0.0, -1.0])
    if abs(float(n @ up)) < 0.9:
        u = np.cross(up, n)
        u /= np.linalg.norm(u)
        v = np.cross(n, u)  # the projection of up onto the plane: v points up the wall
    else:
        u = vt[0]
        v = np.cross(n, u)
    return c, n, u, v


def _robust_inliers(local: FloatArray, outlier_k: float, max_iterations: int) -> BoolArray:
    """Inliers of the quadratic surface: |r - median| <= k 1.4826 MAD, iterated."""
    n_sel = local.shape[0]
    inl = np.ones(n_sel, dtype=bool)
    for _ in range(max_iterations):
        c, n, u_ax, v_ax = _plane_axes(local[inl])
        rel = local - c
        u, v, w = rel @ u_ax, rel @ v_ax, rel @ n
        quad = _lstsq(_design(u[inl], v[inl], 6), w[inl])
        r = w - _design(u, v, 6) @ quad
        med = float(np.median(r[inl]))
        sigma = robust_sigma(r[inl] - med)
        new = np.abs(r - med) <= max(outlier_k * sigma, 1e-12)
        if int(new.sum()) < MIN_FLATNESS_POINTS:
            msg = (
                f"only {int(new.sum())} of {n_sel} points lie within {outlier_k:g} robust "
                f"sigma of the wall; at least {MIN_FLATNESS_POINTS} needed: check the box"
            )
            raise InputError(msg)
        if np.array_equal(new, inl):
            break
        inl = new
    return inl


def fit_wall(
    pos_ecef_m: ArrayLike,
    *,
    level: float = 0.99,
    outlier_k: float = 4.0,
    min_bow_m: float = 0.0,
    max_iterations: int = 10,
) -> FlatnessResult:
    """Fit a plane to wall points, reject gross outliers, test for curvature.

    Parameters
    ----------
    pos_ecef_m : array_like, shape (N, 3)
        Points of the wall, ECEF (m); N >= 10, not collinear.
    level : float
        Confidence level of the F-test, in (0, 1).
    outlier_k : float
        Rejection threshold in robust sigmas (> 0).
    min_bow_m : float
        Least bow (m, >= 0) for ``curvature_significant``.
    max_iterations : int
        Most rejection passes.

    Returns
    -------
    FlatnessResult

    Raises
    ------
    InputError
        Fewer than 10 points (or inliers), collinear points, a rank-deficient quadratic
        design, bad options.

    References
    ----------
    Draper & Smith 1998 (extra-sum-of-squares F-test).
    """
    pts = _as_rows(pos_ecef_m, None, 3, "wall points")
    level = finite_number(level, "level")
    if not 0.0 < level < 1.0:
        msg = f"level must lie in (0, 1), e.g. 0.99, got {level}"
        raise InputError(msg)
    positive_number(outlier_k, "outlier_k")
    if finite_number(min_bow_m, "min_bow_m") < 0.0:
        msg = f"min_bow_m must be >= 0, got {min_bow_m}"
        raise InputError(msg)
    n_sel = pts.shape[0]
    if n_sel < MIN_FLATNESS_POINTS:
        msg = (
            f"too few points for a plane: {n_sel} selected, at least {MIN_FLATNESS_POINTS} "
            "needed; enlarge the box"
        )
        raise InputError(msg)
    mean = pts.mean(axis=0)
    llh = ecef_to_geodetic(mean)
    origin = (float(llh[0]), float(llh[1]), float(llh[2]))
    local = ecef_to_ned(pts, *origin)
    inl = _robust_inliers(local, outlier_k, max_iterations)
    c, n, u_ax, v_ax = _plane_axes(local[inl])
    rel = local[inl] - c
    u, v, w = rel @ u_ax, rel @ v_ax, rel @ n
    m = int(inl.sum())
    B = _design(u, v, 6)
    if np.linalg.matrix_rank(B) < 6 or m <= 6:
        msg = (
            f"the {m} wall points do not determine a quadratic surface (they lie on too few "
            "lines); enlarge the box"
        )
        raise InputError(msg)
    quad = _lstsq(B, w)
    A = B[:, :3]
    plane = _lstsq(A, w)
    rss_q = float(np.sum((w - B @ quad) ** 2))
    rss_p = float(np.sum((w - A @ plane) ** 2))
    dof = m - 6
    s2 = rss_q / dof
    cov = s2 * np.linalg.inv(B.T @ B)
    if rss_q > 0.0:
        f_stat = max(rss_p - rss_q, 0.0) / 3.0 / s2
        p_val = float(stats.f.sf(f_stat, 3, dof))
    else:
        f_stat = math.inf if rss_p > 0.0 else 0.0
        p_val = 0.0 if rss_p > 0.0 else 1.0
    bow = float(np.ptp(_bend(quad, plane, u, v)))
    abs_w = np.abs(w)
    significant = bool(p_val < 1.0 - level and bow >= min_bow_m)
    return FlatnessResult(
        n_selected=n_sel,
        n_points=m,
        n_rejected=n_sel - m,
        origin_lat_lon_h=origin,
        centre_ned_m=c,
        normal_ned=n,
        u_axis_ned=u_ax,
        v_axis_ned=v_ax,
        u_m=u,
        v_m=v,
        residual_m=w,
        rms_m=float(np.sqrt(np.mean(w * w))),
        max_abs_m=float(abs_w.max()),
        percentiles_m={f"p{q}": float(np.percentile(abs_w, q)) for q in (50, 90, 95, 99)},
        quadratic_m=quad,
        quadratic_std_m=np.sqrt(np.diag(cov)),
        f_statistic=float(f_stat),
        p_value=p_val,
        bow_m=bow,
        level=level,
        min_bow_m=float(min_bow_m),
        curvature_significant=significant,
        outlier_k=float(outlier_k),
        rule=(
            f"|residual from the quadratic surface - median| > {outlier_k:g} x 1.4826 MAD, "
            f"iterated ({max_iterations} passes at most)"
        ),
    )


def parse_box(text: str) -> Box:
    """Parse ``"xmin,ymin,zmin,xmax,ymax,zmax"`` (cloud CRS units).

    Raises
    ------
    InputError
        Not six numbers, a non-finite value, a minimum not below its maximum.
    """
    items = [s.strip() for s in str(text).split(",")]
    if len(items) != 6:
        msg = f"--box {text!r}: expected 6 comma-separated numbers xmin,ymin,zmin,xmax,ymax,zmax"
        raise InputError(msg)
    values: list[float] = []
    for pos, item in enumerate(items, start=1):
        try:
            value = float(item)
        except ValueError:
            msg = f"--box {text!r}: item {pos} ({item!r}) is not a number"
            raise InputError(msg) from None
        if not math.isfinite(value):
            msg = f"--box {text!r}: item {pos} ({item!r}) is not finite"
            raise InputError(msg)
        values.append(value)
    for axis, (lo, hi) in enumerate(zip(values[:3], values[3:], strict=True)):
        if not lo < hi:
            name = "xyz"[axis]
            msg = f"--box {text!r}: {name}min {lo!r} must be below {name}max {hi!r}"
            raise InputError(msg)
    return (values[0], values[1], values[2], values[3], values[4], values[5])


def select_box(xyz: ArrayLike, box: Box) -> BoolArray:
    """True for the points inside the box (bounds included), shape (N,)."""
    p = np.asarray(xyz, dtype=np.float64)
    lo = np.asarray(box[:3])
    hi = np.asarray(box[3:])
    out: BoolArray = np.all((p >= lo) & (p <= hi), axis=1)
    return out


# =============================================================================== file layer
def control_points_file(
    cloud_path: Path,
    control_path: Path,
    trajectory_path: Path,
    *,
    crs: str | None = None,
    search_radius_m: float = 0.5,
    min_intensity: float | None = None,
    centre: CentreMethod = "tukey",
    target_radius_m: float | None = None,
    min_points: int = 10,
    level: float = 0.99,
    gps_week: int | None = None,
    chunk_points: int = 1_000_000,
) -> ControlPointReport:
    """Validate a georeferenced cloud file against a control-point file.

    Streams the cloud and keeps only the points within ``search_radius_m`` of a control
    point, then runs `validate_control_points`.

    Parameters
    ----------
    cloud_path : Path
        ``kinsync georef`` output: ``.csv``/``.parquet`` with ``X,Y,Z`` (in ``crs``),
        ``t_s`` and ``intensity``; or ``.las``/``.laz`` (``gps_time``, ``intensity``).
    control_path : Path
        Control CSV (`kinsync.io.control_points`).
    trajectory_path : Path
        Trajectory CSV or SBET (`kinsync.georef.read_trajectory_file`).
    crs : str, optional
        The cloud's CRS; default EPSG:4978, or the CRS a LAS file carries.
    gps_week : int, optional
        GPS week, for LAS seconds-of-week times or an SBET.
    chunk_points : int
        Points read per chunk (bounds memory).
    search_radius_m, min_intensity, centre, target_radius_m, min_points, level
        As in `validate_control_points`.

    Returns
    -------
    ControlPointReport

    Raises
    ------
    InputError
        Unreadable files, missing columns, unknown CRS, bad options, no point near any
        control point.
    """
    cloud_path = Path(cloud_path)
    _check_extraction_options(
        search_radius_m, min_intensity, centre, target_radius_m, min_points, 1.0
    )
    if chunk_points < 1:
        msg = f"--chunk-points must be >= 1, got {chunk_points}"
        raise InputError(msg)
    control = read_control_points(Path(control_path))
    trajectory, traj_scale = read_trajectory_file(Path(trajectory_path), gps_week=gps_week)
    if not cloud_path.is_file():
        msg = f"{cloud_path}: file not found"
        raise InputError(msg)
    crs_text = cloud_crs(cloud_path, crs)
    to_ecef = crs_to_ecef_transformer(crs_text)
    pos_parts: list[FloatArray] = []
    t_parts: list[FloatArray] = []
    i_parts: list[FloatArray] = []
    extent = CloudExtent()
    done = 0
    for xyz, t, inten in iter_cloud(
        cloud_path, chunk_points, need_time=True, traj_scale=traj_scale, gps_week=gps_week
    ):
        assert t is not None
        assert inten is not None
        check_finite_chunk(cloud_path, xyz, done, time=t, intensity=inten)
        done += xyz.shape[0]
        extent.add(xyz)
        ecef = xyz if to_ecef is None else to_ecef(xyz)
        keep = nearest_control(ecef, control, search_radius_m) >= 0
        pos_parts.append(ecef[keep])
        t_parts.append(t[keep])
        i_parts.append(inten[keep])
    pos = np.concatenate(pos_parts) if pos_parts else np.empty((0, 3))
    if pos.shape[0] == 0:
        msg = (
            f"{cloud_path}: no point within {search_radius_m:g} m of any of the "
            f"{len(control)} control points of {control_path}; {extent.text()} ({crs_text}); "
            "check --crs, the control file and --search-radius-m"
        )
        raise InputError(msg)
    cloud = CloudPoints(pos, np.concatenate(t_parts), np.concatenate(i_parts))
    try:
        return validate_control_points(
            cloud,
            control,
            trajectory,
            search_radius_m=search_radius_m,
            min_intensity=min_intensity,
            centre=centre,
            target_radius_m=target_radius_m,
            min_points=min_points,
            level=level,
        )
    except KinsyncError as err:
        msg = f"{cloud_path}: {err}"
        raise InputError(msg) from err


def flatness_file(
    cloud_path: Path,
    box: Box,
    *,
    crs: str | None = None,
    level: float = 0.99,
    outlier_k: float = 4.0,
    min_bow_m: float = 0.0,
    chunk_points: int = 1_000_000,
) -> FlatnessResult:
    """Select the points of a cloud file inside a box (cloud CRS) and run `fit_wall`.

    Parameters
    ----------
    cloud_path : Path
        ``.csv``/``.parquet`` with ``X,Y,Z`` or ``.las``/``.laz``.
    box : Box
        ``(xmin, ymin, zmin, xmax, ymax, zmax)`` in the cloud's CRS.
    crs : str, optional
        The cloud's CRS; default EPSG:4978, or the CRS a LAS file carries.
    level, outlier_k, min_bow_m
        As in `fit_wall`.
    chunk_points : int
        Points read per chunk.

    Returns
    -------
    FlatnessResult

    Raises
    ------
    InputError
        Unreadable file, missing columns, unknown CRS, an empty box (with the cloud's
        extent), too few or degenerate points.
    """
    cloud_path = Path(cloud_path)
    if chunk_points < 1:
        msg = f"--chunk-points must be >= 1, got {chunk_points}"
        raise InputError(msg)
    if not cloud_path.is_file():
        msg = f"{cloud_path}: file not found"
        raise InputError(msg)
    crs_text = cloud_crs(cloud_path, crs)
    to_ecef = crs_to_ecef_transformer(crs_text)
    parts: list[FloatArray] = []
    extent = CloudExtent()
    done = 0
    for xyz, _, _ in iter_cloud(cloud_path, chunk_points, need_time=False):
        check_finite_chunk(cloud_path, xyz, done)
        done += xyz.shape[0]
        extent.add(xyz)
        parts.append(xyz[select_box(xyz, box)])
    sel = np.concatenate(parts) if parts else np.empty((0, 3))
    box_text = ",".join(f"{v:.6g}" for v in box)
    if sel.shape[0] == 0:
        msg = f"{cloud_path}: no point inside the box {box_text}; {extent.text()} ({crs_text})"
        raise InputError(msg)
    try:
        return fit_wall(
            sel if to_ecef is None else to_ecef(sel),
            level=level,
            outlier_k=outlier_k,
            min_bow_m=min_bow_m,
        )
    except KinsyncError as err:
        msg = f"{cloud_path}, box {box_text}: {err}"
        raise InputError(msg) from err
