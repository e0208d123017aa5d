"""Flatness of a wall scanned while driving: plane fit and a test for curvature (SPEC section 7).

Points of a wall, in a local NED frame at their centroid
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
Draper, N. R. & Smith, H., *Applied Regression Analysis*, 3rd ed., Wiley 1998
(extra-sum-of-squares F-test).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import stats

from kinsync._arrays import readonly_array
from kinsync._typing import ArrayLike, BoolArray, FloatArray
from kinsync._validate import ecef_array, finite_number, finite_vector, positive_number
from kinsync.errors import InputError
from kinsync.frames import (
    ecef_to_geodetic,
    ecef_to_ned,
)
from kinsync.robust import robust_sigma
from kinsync.validation._common import finite_rows, lstsq

__all__ = [
    "MIN_FLATNESS_POINTS",
    "Box",
    "FlatnessResult",
    "fit_wall",
    "select_box",
]

Box = tuple[float, float, float, float, float, float]
"""``(xmin, ymin, zmin, xmax, ymax, zmax)`` in the cloud's CRS."""


MIN_FLATNESS_POINTS = 10
"""Fewest points a wall fit accepts (six coefficients of the quadratic surface, and spare)."""


_ARRAY_FIELDS = (
    "centre_ned_m",
    "normal_ned",
    "u_axis_ned",
    "v_axis_ned",
    "u_m",
    "v_m",
    "residual_m",
    "quadratic_m",
    "quadratic_std_m",
)
"""The arrays of a `FlatnessResult` (read-only copies)."""


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

    def __post_init__(self) -> None:
        # Own read-only copies, as SphereFit's arrays: a result never changes.
        for name in _ARRAY_FIELDS:
            object.__setattr__(self, name, readonly_array(getattr(self, name)))

    @property
    def extent_u_m(self) -> float:
        """Extent of the inliers along u (m)."""
        return float(np.ptp(self.u_m))

    @property
    def extent_v_m(self) -> float:
        """Extent of the inliers along v (m)."""
        return float(np.ptp(self.v_m))

    def bend_m(self, u_m: ArrayLike, v_m: ArrayLike) -> FloatArray:
        """Quadratic surface minus the least-squares plane at in-plane points (m).

        Both fitted to the inliers' residuals (`quadratic_m`, and the ordinary
        least-squares plane ``w = a + b u + c v``); `bow_m` is the peak-to-valley of
        this over the inliers.

        Parameters
        ----------
        u_m, v_m : array_like, shape (M,)
            In-plane coordinates (m) along `u_axis_ned` and `v_axis_ned`, from the
            inliers' centroid (as `u_m`, `v_m`).

        Returns
        -------
        ndarray of float64, shape (M,)
            The bend along the plane's normal (m) at each point.
        """
        u = np.asarray(u_m, dtype=np.float64)
        v = np.asarray(v_m, dtype=np.float64)
        return _bend(self.quadratic_m, self._plane_ols, u, v)

    @property
    def _plane_ols(self) -> FloatArray:
        return lstsq(_design(self.u_m, self.v_m, 3), self.residual_m)

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
        quad = lstsq(_design(u[inl], v[inl], 6), w[inl])
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
        Most rejection passes (>= 0; 0: no outlier is rejected).

    Returns
    -------
    FlatnessResult

    Raises
    ------
    InputError
        Fewer than 10 points (or inliers), collinear points, a rank-deficient quadratic
        design, bad options; points in a float dtype too coarse for them (float32 ECEF)
        or not near the Earth's surface (local coordinates given as ECEF).

    References
    ----------
    Draper & Smith 1998 (extra-sum-of-squares F-test).
    """
    pts = finite_rows(ecef_array(pos_ecef_m, "wall points pos_ecef_m"), None, 3, "wall points")
    level = finite_number(level, "level")
    if not 0.0 < level < 1.0:
        msg = f"level must lie in (0, 1), e.g. 0.99, got {level}"
        raise InputError(msg)
    positive_number(outlier_k, "outlier_k")
    if isinstance(max_iterations, bool) or not isinstance(max_iterations, int | np.integer):
        msg = f"max_iterations: expected a whole number of passes, got {max_iterations!r}"
        raise InputError(msg)
    if max_iterations < 0:
        msg = f"max_iterations must be >= 0 (0: no rejection), got {max_iterations}"
        raise InputError(msg)
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
    quad = lstsq(B, w)
    A = B[:, :3]
    plane = lstsq(A, w)
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


def _box_bounds(box: object) -> tuple[FloatArray, FloatArray]:
    """``box`` as its lower and upper bounds, each shape (3,); `InputError` if not a box."""
    hint = "give (xmin, ymin, zmin, xmax, ymax, zmax)"
    b = finite_vector(box, 6, "select_box box", f" {hint[5:]}")
    for axis in range(3):
        if not b[axis] < b[axis + 3]:
            name = "xyz"[axis]
            msg = (
                f"select_box box: {name}min {float(b[axis])!r} must be below {name}max "
                f"{float(b[axis + 3])!r}; {hint}"
            )
            raise InputError(msg)
    return b[:3], b[3:]


def select_box(xyz: ArrayLike, box: Box) -> BoolArray:
    """True for the points inside the box (bounds included), shape (N,).

    Parameters
    ----------
    xyz : array_like, shape (N, 3)
        Point coordinates in the cloud's CRS (its units: m for ECEF or a projected
        CRS).
    box : Box
        ``(xmin, ymin, zmin, xmax, ymax, zmax)`` in the same CRS and units.

    Returns
    -------
    ndarray of bool, shape (N,)
        True where every coordinate lies within its bounds; a NaN coordinate is
        outside.

    Raises
    ------
    InputError
        ``xyz`` not of shape (N, 3); ``box`` not 6 finite numbers, or a minimum not
        below its maximum.
    """
    p = np.asarray(xyz, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3:
        flip = "; transpose it (xyz.T)" if p.ndim == 2 and p.shape[0] == 3 else ""
        msg = f"select_box xyz: expected points of shape (N, 3), got shape {p.shape}{flip}"
        raise InputError(msg)
    lo, hi = _box_bounds(box)
    out: BoolArray = np.all((p >= lo) & (p <= hi), axis=1)
    return out
