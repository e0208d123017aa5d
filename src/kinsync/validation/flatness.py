"""Flatness of a wall scanned while driving: plane fit and a test for curvature (SPEC section 7).

Points of a wall, in a local NED frame at their centroid
(ECEF-sized coordinates are never fitted directly). Plane by total least squares
(SVD); in-plane axes ``u`` (horizontal along the wall) and ``v`` (up the wall), the
residual ``w`` along the normal. Gross outliers are rejected against the quadratic
surface below (so that a real bend is not mistaken for outliers): points whose
residual exceeds ``outlier_k`` (4) times the robust sigma ``1.4826 MAD`` of the
current inliers, iterated to a stable set (10 passes at most). Residual statistics
(RMS, max, percentiles of ``|w|``) are those of the inliers from the plane. Curvature:
``w = a + b u + c v + d u² + e uv + f v²`` (ordinary least squares on the same
inliers), Wald test of the three quadratic terms ``q = (d, e, f)``::

    V = (BᵀB)⁻¹ (Sᵀ C S + σ² BᵀB) (BᵀB)⁻¹
    F = qᵀ V_q⁻¹ q / 3,   p = 1 - F_{3, n-6}(F)

A wall is scanned while driving along it, so ``u`` follows time, and a navigation
error (a GNSS/INS position error correlated over seconds) moves whole profiles
together: the errors are correlated along ``u``. The plain extra-sum-of-squares
F-test counted every one of ~50,000 points as independent and flagged a correctly
calibrated wall under 2 mm of trajectory error correlated over 0.5 s. So the
residuals are averaged in bins along ``u`` (at most 120, at least 5 cm wide; ``S``
sums the design's rows per bin), and the bin means are fitted, by restricted maximum
likelihood with the plane's and the bow's trend ``1, u, u²`` left out, with a
first-order Gauss-Markov error along ``u`` (``C = s² exp(-|Δu| / ℓ)``) plus the white
noise ``σ²`` (the scatter within bins). ``s`` and ``ℓ`` are reported. Contiguous
blocks with a cluster-robust covariance were tried first and held the level only with
blocks several correlation lengths long, too few for the test. Limits: ``s`` and ``ℓ``
are estimated, so the test runs a little above its level under correlated errors
(about 2-5 % at the nominal 1 %, by simulation); an error correlated over longer than
the wall's drive time (or smooth, not Gauss-Markov) bends the wall like a
calibration error, and the data cannot tell them apart.

``curvature_significant`` when ``p < 1 - level`` and the bow is at least
``min_bow_m`` (0 by default: the statistical test alone; give a tolerance to flag only
bends that matter on a large, imperfect real wall). The bow (sagitta) is the
peak-to-valley of (quadratic surface - plane) over the inliers; its standard deviation
(over draws of ``q`` from the same covariance ``V_q``) is `FlatnessResult.bow_std_m`. A
peak-to-valley of noise is positive: on a flat wall the bow is of the order of its
sigma, not 0, and small selections give large bows. A time error bends a wall only
where the motion changes along it (a uniform circular motion rotates the whole cloud
rigidly about the turn centre, which the plane absorbs); entering a tight curve it
does. A bend is not specific to the time error: a lever arm or boresight error bends
the same wall (a 5 cm lever arm along x about as much as 5 ms); ``kinsync validate
control-points`` separates the time error.

References
----------
Patterson, H. D. & Thompson, R., "Recovery of inter-block information when block sizes
are unequal", *Biometrika* 58(3), 545-554, 1971 (restricted maximum likelihood).
Cressie, N., *Statistics for Spatial Data*, rev. ed., Wiley 1993 (exponential
covariance with a nugget, universal kriging trend).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import linalg, optimize, stats

from kinsync._arrays import FrozenMapping, ReadOnlyArrays, readonly_array
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
    "MIN_EXTENT_RATIO",
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

_DRIVE_BINS = 120
"""Most bins along u for the fit of the correlated error (the REML cost is cubic in them)."""

_BOW_DRAWS = 400
"""Draws of the quadratic terms for the bow's standard deviation."""

_BOW_POINTS = 2000
"""Most inliers the drawn bows are evaluated on (spread over the inlier list)."""

_MAX_CORRELATION_SPANS = 10.0
"""Longest correlation fitted, in wall lengths: beyond it a Gauss-Markov error is a
random walk over the wall, set by ``s²/ℓ`` alone (the fit would drift to both huge)."""

_DRIVE_BIN_M = 0.05
"""Narrowest bin along u (m): a profile's spacing at 5 m/s and 100 Hz."""

MIN_EXTENT_RATIO = 0.05
"""Least extent of the inliers across their longest direction in the wall's plane,
as a fraction of their length.

A quadratic term across a strip narrower than this (one scanner profile is 2 cm by
4 m) is fitted to the scanner's geometry within a profile, not to the wall's shape.
"""


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
    "quadratic_cov",
)
"""The arrays of a `FlatnessResult` (read-only copies)."""


@dataclass(frozen=True, eq=False)
class FlatnessResult(ReadOnlyArrays):
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
        Their standard deviations (with the error correlated along ``u``).
    quadratic_cov : ndarray, shape (6, 6)
        Their covariance.
    f_statistic, p_value : float
        Wald test of the quadratic terms against the plane, with errors correlated
        along the wall: ``F = X² / 3`` on ``(3, n_points - 6)`` degrees of freedom
        and its p-value.
    drive_noise_m, drive_correlation_m : float
        Standard deviation (m) and correlation length along ``u`` (m) of the error
        correlated along the drive (a trajectory error), fitted to the residuals.
    white_noise_m : float
        Standard deviation of the independent noise (m).
    bow_m : float
        Peak-to-valley of (quadratic surface - plane) over the inliers (m); biased
        positive (a peak-to-valley of noise is never below 0).
    bow_std_m : float
        Standard deviation of `bow_m` (m): of the peak-to-valley over draws of the
        quadratic terms from their covariance.
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
    percentiles_m: Mapping[str, float]
    quadratic_m: FloatArray
    quadratic_std_m: FloatArray
    quadratic_cov: FloatArray
    f_statistic: float
    p_value: float
    drive_noise_m: float
    drive_correlation_m: float
    white_noise_m: float
    bow_m: float
    bow_std_m: float
    level: float
    min_bow_m: float
    curvature_significant: bool
    outlier_k: float
    rule: str = field(default="")

    def __post_init__(self) -> None:
        # Own read-only copies, as SphereFit's arrays: a result never changes.
        for name in _ARRAY_FIELDS:
            object.__setattr__(self, name, readonly_array(getattr(self, name)))
        object.__setattr__(self, "percentiles_m", FrozenMapping(self.percentiles_m))

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

    @property
    def verdict(self) -> str:
        """What the curvature test says, and what it cannot tell (the CLI's verdict line)."""
        if self.curvature_significant:
            return (
                "the wall is bent: a time error OR a mount error (lever arm, boresight) "
                "bends a wall scanned in a turn; kinsync validate control-points "
                "separates the time error"
            )
        return (
            "no bend found: no proof of synchronisation unless the wall was scanned while "
            "the motion changed (entering a tight turn); along a straight or a steady "
            "turn a time error does not bend a wall; kinsync validate control-points "
            "measures the time error"
        )

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
            "drive_noise_m": self.drive_noise_m,
            "drive_correlation_m": self.drive_correlation_m,
            "white_noise_m": self.white_noise_m,
            "bow_m": self.bow_m,
            "bow_std_m": self.bow_std_m,
            "verdict": self.verdict,
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
        Fewer than 10 points (or inliers), collinear points, inliers whose extent
        along or up the wall is under 5 % of the other (one scanner profile), a
        rank-deficient quadratic design, bad options; points in a float dtype too
        coarse for them (float32 ECEF) or not near the Earth's surface (local
        coordinates given as ECEF).

    References
    ----------
    Patterson & Thompson 1971 (REML); Cressie 1993 (exponential covariance).
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
    _check_extent(u, v)
    B = _design(u, v, 6)
    if np.linalg.matrix_rank(B) < 6 or m <= 6:
        msg = (
            f"the {m} wall points do not determine a quadratic surface (they lie on too few "
            "lines); enlarge the box"
        )
        raise InputError(msg)
    quad = lstsq(B, w)
    plane = lstsq(B[:, :3], w)
    cov, drive_sd, drive_ell, white_sd = _drive_cov(B, w - B @ quad, u)
    f_stat, p_val = _wald(quad[3:], cov[3:, 3:], m - 6)
    bend = _bend(quad, plane, u, v)
    bow = float(np.ptp(bend))
    bow_std = _bow_std(B, bend, quad[3:], cov[3:, 3:])
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
        quadratic_cov=cov,
        f_statistic=float(f_stat),
        p_value=p_val,
        drive_noise_m=drive_sd,
        drive_correlation_m=drive_ell,
        white_noise_m=white_sd,
        bow_m=bow,
        bow_std_m=bow_std,
        level=level,
        min_bow_m=float(min_bow_m),
        curvature_significant=significant,
        outlier_k=float(outlier_k),
        rule=(
            f"|residual from the quadratic surface - median| > {outlier_k:g} x 1.4826 MAD, "
            f"iterated ({max_iterations} passes at most)"
        ),
    )


def _spread(x: FloatArray) -> float:
    """Range of the middle 96 % of ``x``: a stray point does not widen a strip."""
    lo, hi = np.percentile(x, [2.0, 98.0])
    return float(hi - lo)


def _check_extent(u: FloatArray, v: FloatArray) -> None:
    """`InputError` when the inliers are a strip in the wall's plane (one profile).

    The length is taken along the principal axis of ``(u, v)``, the width across a
    quadratic curve fitted along it (a profile scanned in a turn crosses the wall on
    a slant, and bent), each over the middle 96 % of the points.
    """
    uv = np.column_stack([u, v])
    _, _, axes = np.linalg.svd(uv - uv.mean(axis=0), full_matrices=False)
    s_along, t_across = uv @ axes[0], uv @ axes[1]
    along = _spread(s_along)
    # across a quadratic curve, not a line: a profile in a turn is bent in the plane
    curve = np.column_stack([np.ones_like(s_along), s_along, s_along * s_along])
    across = _spread(t_across - curve @ lstsq(curve, t_across))
    if across < MIN_EXTENT_RATIO * along:
        msg = (
            f"degenerate selection: the {u.size} points span {along:.3g} m along their "
            f"longest direction in the wall's plane and {across:.3g} m across it, a strip "
            "(one scanner profile?); a curvature test needs at least "
            f"{MIN_EXTENT_RATIO:.0%} of the length across: enlarge the box"
        )
        raise InputError(msg)


def _ou_reml(
    rbar: FloatArray, ubar: FloatArray, white: FloatArray, span: float, width: float
) -> tuple[float, float]:
    """REML fit of an exponential (Gauss-Markov) covariance to bin means along u.

    ``rbar``: mean residual per bin at ``ubar``, each with white variance ``white``;
    the trend ``1, u, u²`` is left out of the likelihood (REML). Returns the process's
    standard deviation (m) and correlation length (m).
    """
    X = np.column_stack([np.ones_like(ubar), ubar, ubar * ubar])
    lag = np.abs(ubar[:, None] - ubar[None, :])

    def cost(theta: FloatArray) -> float:
        ell = min(math.exp(theta[1]), _MAX_CORRELATION_SPANS * span)
        cov = math.exp(2.0 * theta[0]) * np.exp(-lag / ell) + np.diag(white)
        try:
            c = linalg.cho_factor(cov, lower=True)
            si_x, si_r = linalg.cho_solve(c, X), linalg.cho_solve(c, rbar)
            ca = linalg.cho_factor(X.T @ si_x, lower=True)
        except linalg.LinAlgError:
            return 1e30
        xr = X.T @ si_r
        quad = float(rbar @ si_r - xr @ linalg.cho_solve(ca, xr))
        logdet = 2.0 * float(np.sum(np.log(np.diag(c[0]))) + np.sum(np.log(np.diag(ca[0]))))
        return 0.5 * (logdet + quad)

    sd0 = math.log(max(float(np.std(rbar)), 1e-6))
    best: tuple[float, FloatArray] | None = None
    for ell0 in (span / 20.0, span / 2.0):
        res = optimize.minimize(
            cost,
            np.array([sd0, math.log(max(ell0, width))]),
            method="Nelder-Mead",
            options={"xatol": 1e-3, "fatol": 1e-4, "maxiter": 400},
        )
        if best is None or float(res.fun) < best[0]:
            best = (float(res.fun), np.asarray(res.x, dtype=np.float64))
    assert best is not None
    ell_best = min(math.exp(float(best[1][1])), _MAX_CORRELATION_SPANS * span)
    return math.exp(float(best[1][0])), ell_best


def _drive_cov(
    B: FloatArray, resid: FloatArray, u: FloatArray
) -> tuple[FloatArray, float, float, float]:
    """Covariance of the least-squares coefficients under errors correlated along u.

    Returns the covariance, the correlated error's sigma (m) and correlation length
    (m), and the white noise's sigma (m).
    """
    n, k = B.shape
    span = float(np.ptp(u))
    width = max(span / _DRIVE_BINS, _DRIVE_BIN_M)
    key = np.floor((u - float(u.min())) / width).astype(np.int64)
    _, inv, count = np.unique(key, return_inverse=True, return_counts=True)
    ubar = np.bincount(inv, u) / count
    rbar = np.bincount(inv, resid) / count
    within_dof = n - count.size
    if within_dof >= 3 * count.size:  # the scatter within bins: white noise
        white2 = float(np.sum((resid - rbar[inv]) ** 2)) / within_dof
    else:  # few points per bin: the plain residual variance (upper bound)
        white2 = float(np.sum(resid * resid)) / (n - k)
    if count.size > 2 * k:
        sd, ell = _ou_reml(rbar, ubar, white2 / count, span, width)
    else:
        sd, ell = 0.0, width
    sums = np.zeros((count.size, k))
    np.add.at(sums, inv, B)
    corr = sd * sd * np.exp(-np.abs(ubar[:, None] - ubar[None, :]) / ell)
    bread = np.linalg.inv(B.T @ B)
    cov: FloatArray = bread @ (sums.T @ corr @ sums + white2 * (B.T @ B)) @ bread
    return 0.5 * (cov + cov.T), sd, ell, math.sqrt(white2)


def _bow_std(B: FloatArray, bend: FloatArray, q: FloatArray, cov_q: FloatArray) -> float:
    """Standard deviation of the bow: peak-to-valley of draws of the quadratic terms.

    ``bend = M q`` (the quadratic columns less their least-squares plane); the draws
    (`_BOW_DRAWS`, fixed seed) of ``q ~ N(q, cov_q)`` are evaluated on at most
    `_BOW_POINTS` points spread over the wall plus the bend's peak and valley, so that
    a peak or valley that moves between draws is followed.
    """
    n = B.shape[0]
    # spread along the wall, not along the file: the same points in any order give the
    # same sample (u, then v; equal (u, v) give equal rows of M)
    along = np.lexsort((B[:, 2], B[:, 1]))
    keep = np.unique(
        np.concatenate(
            [
                along[np.linspace(0, n - 1, min(n, _BOW_POINTS)).astype(np.int64)],
                [int(np.argmax(bend)), int(np.argmin(bend))],
            ]
        )
    )
    M = B[:, 3:] - B[:, :3] @ lstsq(B[:, :3], B[:, 3:])
    rng = np.random.default_rng(0)
    try:
        chol = np.linalg.cholesky(cov_q + 1e-30 * np.eye(3))
    except np.linalg.LinAlgError:
        return math.nan
    draws = q + rng.standard_normal((_BOW_DRAWS, 3)) @ chol.T
    bows = np.ptp(M[keep] @ draws.T, axis=0)
    return float(np.std(bows, ddof=1))


def _wald(q: FloatArray, cov_q: FloatArray, dof: int) -> tuple[float, float]:
    """Wald F statistic of ``q = 0`` (3 terms) and its p-value on ``(3, dof)``."""
    try:
        wald = float(q @ np.linalg.solve(cov_q, q))
    except np.linalg.LinAlgError:
        wald = math.nan
    if not math.isfinite(wald) or wald < 0.0:  # an exact fit: no scatter left
        return (math.inf, 0.0) if bool(np.any(q != 0.0)) else (0.0, 1.0)
    return wald / 3.0, float(stats.f.sf(wald / 3.0, 3, dof))


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
