"""Sphere fitting: algebraic start, then geometric or ray refinement with a covariance.

Two layers, each usable on its own (the third, robust segmentation of a sphere from a
cloud with clutter, is `kinsync.fit.segment`):

`fit_sphere_algebraic`
    Closed-form Hyper fit (a generalised eigenproblem on the 5 x 5 moment matrix of
    the algebraic sphere ``A|x|^2 + B.x + C = 0``). Nearly unbiased, even on a
    one-sided cap, where the barycentre of the points is off by about half a radius.
`fit_sphere`
    Levenberg-Marquardt (Gauss-Newton with damping) from the algebraic start, on the
    orthogonal residual ``r_i = |x_i - c| - rho`` or, when the scanner origin is
    known, on the range residual along each beam (the ray model below). Radius free
    (4 unknowns) or known (3 unknowns). Reports the centre covariance
    ``sigma^2 (J^T J)^-1`` with ``sigma^2 = sum r^2 / (n - p)``.

Numerics. Every computation runs in coordinates centred on the data (the first point
and then the mean are subtracted, exactly for nearby points, and added back at the
end), so UTM- or ECEF-sized coordinates (1e6-6e6 m) lose nothing; the algebraic fit
also scales them to unit RMS. Points are held as a (3, N) array so that every pass
over them is a contiguous, vectorised numpy operation; a 30 000-point fit takes a few
milliseconds (``benchmarks/bench_sphere_fit.py``).

Ray model. A scanner at ``o`` measures point ``x_i`` along the unit beam
``u_i = (x_i - o) / m_i`` at range ``m_i = |x_i - o|``. The sphere (centre ``c``,
radius ``R``) predicts the range of the near intersection
``rho_i = b_i - s_i``, ``b_i = u_i . v``, ``v = c - o``,
``s_i = sqrt(b_i^2 - |v|^2 + R^2)``. The residual is ``e_i = m_i - rho_i`` (positive:
the point lies beyond the modelled surface, further from the scanner), with
``d rho / d c = u - (b u - v) / s`` and ``d rho / d R = -R / s``. With range-only
noise it is the maximum-likelihood estimator, free of the bias the orthogonal
residual has (second order in noise / radius, growing towards the silhouette; about
1 mm along the beam for 5 mm range noise on a 0.1 m sphere). Near the silhouette
``rho`` is not smooth in ``(c, R)`` (``1/s`` derivatives), so the ray model starts from
the orthogonal solution and uses the beams that meet it at less than 85 deg incidence
on its visible side; the choice depends on the beam directions only, which range noise
does not change, so it does not bias the estimate. A beam that misses the sphere
while iterating gets the continuous extension ``rho = b`` (``s = 0``); in the result
its residual is NaN.

References
----------
Al-Sharadqah, A. & Chernov, N., "Error analysis for circle fitting algorithms",
Electronic Journal of Statistics 3, 2009, 886-911 (Hyper fit; here extended to 3-D).
Taubin, G., "Estimation of planar curves, surfaces and nonplanar space curves defined
by implicit equations...", IEEE PAMI 13(11), 1991, 1115-1138.
Pratt, V., "Direct least-squares fitting of algebraic surfaces", SIGGRAPH 1987,
145-152.
Seube, N., Picard, A. & Rondeau, M., "A simple method to recover the latency time of
tactical grade IMU systems", ISPRS J. Photogramm. Remote Sens. 74, 2012, 85-89 (the
sphere-centre use in latency calibration).
Marquardt, D. W., "An algorithm for least-squares estimation of nonlinear parameters",
SIAM J. Appl. Math. 11(2), 1963, 431-441.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from kinsync._arrays import ReadOnlyArrays
from kinsync._typing import ArrayLike, BoolArray, FloatArray
from kinsync._validate import check_float_step, finite_vector
from kinsync.errors import ConvergenceError, InputError

__all__ = ["SphereFit", "fit_sphere", "fit_sphere_algebraic"]

_MIN_POINTS = 4
_DEGENERATE_SPREAD = 1e-7
"""Relative spread below which points count as collinear or coplanar."""


# --------------------------------------------------------------------------- result


@dataclass(frozen=True, eq=False)
class SphereFit(ReadOnlyArrays):
    """A fitted sphere with its uncertainty, inliers and residuals.

    Attributes
    ----------
    center_m : ndarray, shape (3,)
        Centre (m), in the frame of the input points.
    radius_m : float
        Radius (m); the given value when ``radius_fixed``.
    radius_fixed : bool
        True when the radius was given, not estimated.
    cov_center_m2 : ndarray, shape (3, 3)
        Centre covariance (m^2), ``sigma^2 (J^T J)^-1`` with
        ``sigma^2 = sum r^2 / (n - p)`` (the centre block when the radius is free).
        NaN when there are no degrees of freedom left (``n == p``).
    radius_std_m : float
        Standard deviation of the radius (m); NaN when the radius is fixed.
    residual_rms_m : float
        RMS of the final residuals of the inliers (m); beams that miss are left out.
    n_points : int
        Number of inliers used in the final fit.
    inliers : ndarray of bool, shape (N,)
        Mask into the points given: True for the points used in the final fit (all of
        them for a geometric `fit_sphere`; the ray model leaves out beams at grazing
        incidence and points on the far side; `segment_sphere` also leaves out clutter).
    residuals_m : ndarray, shape (N,)
        Residual of every input point with respect to the final sphere (m):
        orthogonal distance ``|x - c| - rho`` (``method == "geometric"``) or range
        residual ``m - rho`` along the beam (``method == "ray"``; NaN for a beam that
        misses the sphere).
    method : str
        ``"geometric"`` (orthogonal residual) or ``"ray"`` (range residual).
    iterations : int
        Levenberg-Marquardt iterations (Jacobian evaluations) of the final fit.
    """

    center_m: FloatArray
    radius_m: float
    radius_fixed: bool
    cov_center_m2: FloatArray
    radius_std_m: float
    residual_rms_m: float
    n_points: int
    inliers: BoolArray
    residuals_m: FloatArray
    method: str
    iterations: int

    def __post_init__(self) -> None:
        # Own read-only copies: a result never changes, nor aliases the caller's arrays.
        for name, dtype in (
            ("center_m", np.float64),
            ("cov_center_m2", np.float64),
            ("inliers", np.bool_),
            ("residuals_m", np.float64),
        ):
            arr = np.array(getattr(self, name), dtype=dtype, copy=True)
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        n = self.inliers.shape[0] if self.inliers.ndim == 1 else -1
        if (
            self.center_m.shape != (3,)
            or self.cov_center_m2.shape != (3, 3)
            or self.residuals_m.shape != (n,)
        ):
            msg = (
                "SphereFit: expected center_m (3,), cov_center_m2 (3, 3) and inliers, "
                f"residuals_m of one length N; got {self.center_m.shape}, "
                f"{self.cov_center_m2.shape}, {self.inliers.shape}, {self.residuals_m.shape}"
            )
            raise InputError(msg)

    @property
    def center_std_m(self) -> FloatArray:
        """Standard deviation of each centre coordinate (m), shape (3,)."""
        std: FloatArray = np.sqrt(np.diag(self.cov_center_m2))
        return std


# --------------------------------------------------------------------------- validation


def _validated_points(points_m: ArrayLike, what: str) -> FloatArray:
    """(N, 3) finite float64 points, N >= 4; float32 map or ECEF coordinates refused.

    float32 holds UTM-sized coordinates in steps of 0.5 m: 0.1 m sphere points came out
    "coplanar" (`kinsync._validate.check_float_step` says so instead, as fit_wall does).
    """
    try:
        pts = np.asarray(points_m, dtype=np.float64)
    except (TypeError, ValueError) as err:
        msg = f"{what}: points_m must be numbers, shape (N, 3) ({err})"
        raise InputError(msg) from err
    if isinstance(points_m, np.ndarray):
        check_float_step(points_m, f"{what}: points_m", "coordinate", "pass float64 coordinates")
    if pts.ndim != 2 or pts.shape[1] != 3:
        msg = f"{what}: points_m must have shape (N, 3), got {pts.shape}"
        raise InputError(msg)
    if pts.shape[0] < _MIN_POINTS:
        msg = (
            f"{what}: a sphere needs at least {_MIN_POINTS} points, got {pts.shape[0]}; "
            "check the segmentation or region of interest"
        )
        raise InputError(msg)
    if not np.isfinite(pts).all():
        row = int(np.flatnonzero(~np.isfinite(pts).all(axis=1))[0])
        msg = (
            f"{what}: non-finite coordinate at index {row} (0-based, {pts[row].tolist()}); "
            "drop NaN/inf points before fitting"
        )
        raise InputError(msg)
    return pts


def _validated_radius(radius_m: float | None, what: str) -> float | None:
    if radius_m is None:
        return None
    try:
        r = float(radius_m)
    except (TypeError, ValueError) as err:
        msg = f"{what}: radius_m must be a number, got {radius_m!r}"
        raise InputError(msg) from err
    if not math.isfinite(r) or r <= 0.0:
        msg = f"{what}: radius_m must be finite and > 0 (m), got {radius_m!r}"
        raise InputError(msg)
    return r


def _validated_origin(origin_m: ArrayLike | None, what: str) -> FloatArray | None:
    return None if origin_m is None else finite_vector(origin_m, 3, f"{what}: origin_m", " (m)")


def _centred(pts: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Reference point (3,) and coordinates about it as a contiguous (3, N) array.

    The first point is subtracted first (exact for nearby points, whatever their
    magnitude), then the mean of the small differences.
    """
    first = pts[0].copy()
    xc = np.empty((3, pts.shape[0]))
    np.subtract(pts.T, first[:, None], out=xc)
    mean = xc.mean(axis=1)
    xc -= mean[:, None]
    return first + mean, xc


def _check_not_degenerate(xc: FloatArray, what: str) -> float:
    """Raise if the centred points are collinear or coplanar; return their RMS spread (m)."""
    scatter = (xc @ xc.T) / xc.shape[1]
    eig = np.linalg.eigvalsh(scatter)  # ascending
    spread = float(np.sqrt(max(eig[2], 0.0)))
    if spread == 0.0:
        msg = f"{what}: all {xc.shape[1]} points coincide; a sphere is not determined"
        raise InputError(msg)
    second = float(np.sqrt(max(eig[1], 0.0)))
    third = float(np.sqrt(max(eig[0], 0.0)))
    if second <= _DEGENERATE_SPREAD * spread:
        msg = (
            f"{what}: the {xc.shape[1]} points are collinear (spread {spread:.3g} m along a "
            f"line, {second:.3g} m across); a sphere is not determined"
        )
        raise InputError(msg)
    if third <= _DEGENERATE_SPREAD * spread:
        msg = (
            f"{what}: the {xc.shape[1]} points are coplanar (out-of-plane spread "
            f"{third:.3g} m for {spread:.3g} m in plane); a sphere is not determined"
        )
        raise InputError(msg)
    return spread


# --------------------------------------------------------------------------- algebraic


def _hyper_local(xc: FloatArray, what: str) -> tuple[FloatArray, float]:
    """Hyper fit of centred (3, N) points; centre in the same centred coordinates."""
    n = xc.shape[1]
    scale = float(np.sqrt(np.einsum("ij,ij->", xc, xc) / n))
    z = np.empty((5, n))
    np.multiply(xc, 1.0 / scale, out=z[1:4])
    np.einsum("ij,ij->j", z[1:4], z[1:4], out=z[0])
    z[4] = 1.0
    moments = (z @ z.T) / n
    # Hyper constraint 2 * Taubin - Pratt, theta = (A, B1, B2, B3, C).
    mean_sq = moments[0, 4]
    mean_x = moments[1:4, 4]
    hyper = np.zeros((5, 5))
    hyper[0, 0] = 8.0 * mean_sq
    hyper[0, 1:4] = hyper[1:4, 0] = 4.0 * mean_x
    hyper[0, 4] = hyper[4, 0] = 2.0
    hyper[1:4, 1:4] = np.eye(3)
    _, eigvecs = np.linalg.eig(np.linalg.solve(hyper, moments))
    vecs = np.real(eigvecs)
    quad_h = np.einsum("ik,ij,jk->k", vecs, hyper, vecs)
    quad_m = np.einsum("ik,ij,jk->k", vecs, moments, vecs)
    ok = quad_h > 0.0
    if not ok.any():
        msg = f"{what}: the algebraic sphere fit found no admissible solution"
        raise InputError(msg)
    ratio = np.where(ok, quad_m / np.where(ok, quad_h, 1.0), np.inf)
    theta = vecs[:, int(np.argmin(ratio))]
    a, b, c = theta[0], theta[1:4], theta[4]
    radius_sq = float(b @ b - 4.0 * a * c)
    if abs(a) <= 1e-12 * math.sqrt(max(radius_sq, 0.0)) or radius_sq <= 0.0:
        msg = (
            f"{what}: the {n} points are (nearly) coplanar: the algebraic fit finds a plane, "
            "not a sphere"
        )
        raise InputError(msg)
    centre = -b / (2.0 * a) * scale
    radius = math.sqrt(radius_sq) / (2.0 * abs(a)) * scale
    return centre, radius


def fit_sphere_algebraic(points_m: ArrayLike) -> tuple[FloatArray, float]:
    """Closed-form (algebraic) sphere fit: the Hyper fit.

    Solves ``M theta = eta H theta`` for the algebraic sphere
    ``A|x|^2 + B.x + C = 0``, ``theta = (A, B, C)``, where ``M`` is the moment matrix
    of ``z_i = (|x_i|^2, x_i, 1)`` and ``H = 2 T - P`` combines Taubin's (``T``) and
    Pratt's (``P``) constraint matrices; the solution is the eigenvector with the
    smallest positive ``eta``. Computed in coordinates centred on the points and scaled
    to unit RMS. Unlike the barycentre, it is close to the true centre on a one-sided
    cap; it is the start of `fit_sphere`.

    Parameters
    ----------
    points_m : array_like, shape (N, 3)
        Points (m), any Cartesian frame (ECEF-sized coordinates are fine). N >= 4.

    Returns
    -------
    center_m : ndarray, shape (3,)
        Centre (m), same frame as the points.
    radius_m : float
        Radius (m).

    Raises
    ------
    InputError
        Wrong shape, fewer than 4 points, non-finite values, collinear or coplanar
        points.

    References
    ----------
    Al-Sharadqah & Chernov 2009 (Hyper fit); Taubin 1991; Pratt 1987.
    """
    what = "fit_sphere_algebraic"
    pts = _validated_points(points_m, what)
    ref, xc = _centred(pts)
    _check_not_degenerate(xc, what)
    centre, radius = _hyper_local(xc, what)
    return ref + centre, radius


# --------------------------------------------------------------------------- LM core

# A model evaluates residuals e (N,) at parameters p and keeps what the Jacobian needs;
# the Jacobian (P, N) is de/dp at the same parameters.
_Residuals = Callable[[FloatArray], tuple[FloatArray, object]]
_Jacobian = Callable[[FloatArray, object], FloatArray]


@dataclass(frozen=True)
class _LMResult:
    params: FloatArray
    residuals: FloatArray
    state: object
    iterations: int
    converged: bool


def _levenberg_marquardt(
    residual_fn: _Residuals,
    jacobian_fn: _Jacobian,
    p0: FloatArray,
    weights: FloatArray | None,
    max_iterations: int,
    tol_m: float,
) -> _LMResult:
    """Weighted Levenberg-Marquardt with Marquardt's diagonal scaling.

    Converged when an accepted step is shorter than ``tol_m`` (parameters are metres),
    or when no step decreases the cost any more at machine precision.
    """
    p = p0.copy()
    e, state = residual_fn(p)
    cost = float(e @ e) if weights is None else float((weights * e) @ e)
    lam = 1e-4
    for it in range(1, max_iterations + 1):
        jac = jacobian_fn(p, state)
        jw = jac if weights is None else jac * weights
        normal = jw @ jac.T
        grad = jw @ e
        diag = np.diag(normal).copy()
        diag[diag <= 0.0] = 1.0
        while True:
            try:
                step = np.linalg.solve(normal + lam * np.diag(diag), -grad)
            except np.linalg.LinAlgError:
                step = np.full_like(p, np.nan)
            if np.isfinite(step).all():
                p_trial = p + step
                e_trial, state_trial = residual_fn(p_trial)
                cost_trial = (
                    float(e_trial @ e_trial)
                    if weights is None
                    else float((weights * e_trial) @ e_trial)
                )
                small = float(np.linalg.norm(step)) <= tol_m
                if math.isfinite(cost_trial) and cost_trial <= cost:
                    p, e, state, cost = p_trial, e_trial, state_trial, cost_trial
                    lam = max(lam * 0.1, 1e-12)
                    if small:
                        return _LMResult(p, e, state, it, converged=True)
                    break
                if small:
                    return _LMResult(p, e, state, it, converged=True)
            lam *= 10.0
            if lam > 1e12:
                # No decrease possible: at the minimum to machine precision.
                return _LMResult(p, e, state, it, converged=True)
    return _LMResult(p, e, state, max_iterations, converged=False)


@dataclass(frozen=True)
class _OrthoState:
    diff: FloatArray  # (3, N) x - c
    dist: FloatArray  # (N,)


def _ortho_model(xc: FloatArray, radius_fixed: float | None) -> tuple[_Residuals, _Jacobian]:
    """Orthogonal residual |x - c| - rho; parameters (c, rho) or (c,) when fixed."""

    def residuals(p: FloatArray) -> tuple[FloatArray, object]:
        diff = xc - p[:3, None]
        dist = np.sqrt(np.einsum("ij,ij->j", diff, diff))
        rho = p[3] if radius_fixed is None else radius_fixed
        return dist - rho, _OrthoState(diff, dist)

    def jacobian(p: FloatArray, state: object) -> FloatArray:
        assert isinstance(state, _OrthoState)
        n = state.dist.shape[0]
        jac = np.empty((len(p), n))
        np.divide(state.diff, state.dist, out=jac[:3])
        np.negative(jac[:3], out=jac[:3])
        if radius_fixed is None:
            jac[3] = -1.0
        return jac

    return residuals, jacobian


@dataclass(frozen=True)
class _RayState:
    b: FloatArray  # (N,) u . v
    s: FloatArray  # (N,) sqrt(b^2 - |v|^2 + R^2), 0 where the beam misses
    hit: BoolArray  # (N,) the beam meets the sphere in front of the scanner
    v: FloatArray  # (3,) c - o
    radius: float


def _ray_model(
    xc: FloatArray,
    origin: FloatArray,
    radius_fixed: float | None,
) -> tuple[_Residuals, _Jacobian]:
    """Range residual ``m - rho`` along each beam from ``origin`` (centred coordinates).

    A beam that misses the sphere gets the continuous extension ``rho = b`` (the point
    of closest approach, ``s = 0``), so the cost stays continuous while iterating.
    """
    beams = xc - origin[:, None]
    ranges = np.sqrt(np.einsum("ij,ij->j", beams, beams))
    units = beams / ranges

    def residuals(p: FloatArray) -> tuple[FloatArray, object]:
        v = p[:3] - origin
        radius = float(p[3]) if radius_fixed is None else radius_fixed
        b = v @ units
        disc = b * b - (v @ v - radius * radius)
        s = np.sqrt(np.maximum(disc, 0.0))
        rho = b - s
        hit = (disc > 0.0) & (rho > 0.0)
        return ranges - rho, _RayState(b, s, hit, v, radius)

    def jacobian(p: FloatArray, state: object) -> FloatArray:
        assert isinstance(state, _RayState)
        jac = np.empty((len(p), state.b.shape[0]))
        # de/dc = -(u - (b u - v)/s) = u (b/s - 1) - v/s ; de/dR = R/s
        with np.errstate(divide="ignore"):
            inv_s = np.where(state.s > 0.0, 1.0 / state.s, 0.0)
        np.multiply(units, state.b * inv_s - 1.0, out=jac[:3])
        jac[:3] -= np.outer(state.v, inv_s)
        if radius_fixed is None:
            np.multiply(state.radius, inv_s, out=jac[3])
        return jac

    return residuals, jacobian


def _ray_residuals_all(
    xc: FloatArray, origin: FloatArray, centre: FloatArray, radius: float
) -> tuple[FloatArray, FloatArray, BoolArray]:
    """Range residual (NaN where the beam misses), cos(incidence) and near-side flag."""
    res_fn, _ = _ray_model(xc, origin, radius)
    e, state = res_fn(centre)
    assert isinstance(state, _RayState)
    cos_incidence = state.s / radius
    return np.where(state.hit, e, np.nan), cos_incidence, state.hit


# --------------------------------------------------------------------------- fit


def _start_params(
    xc: FloatArray, what: str, radius_fixed: float | None
) -> tuple[FloatArray, float]:
    centre, radius = _hyper_local(xc, what)
    if radius_fixed is None:
        return np.append(centre, radius), radius
    # Known radius: move the algebraic centre along the cap axis by the radius difference.
    diff = xc - centre[:, None]
    mean_dir = (diff / np.sqrt(np.einsum("ij,ij->j", diff, diff))).mean(axis=1)
    return centre + (radius - radius_fixed) * mean_dir, radius


def _covariance(jac: FloatArray, e: FloatArray, n_params: int) -> tuple[FloatArray, float]:
    """Centre covariance (3, 3) and radius std (NaN when fixed): sigma^2 (J^T J)^-1."""
    n = e.shape[0]
    dof = n - n_params
    normal = jac @ jac.T
    if dof <= 0:
        return np.full((3, 3), np.nan), math.nan
    sigma2 = float(e @ e) / dof
    try:
        cov = sigma2 * np.linalg.inv(normal)
    except np.linalg.LinAlgError:
        return np.full((3, 3), np.inf), math.inf
    radius_std = math.sqrt(max(float(cov[3, 3]), 0.0)) if n_params == 4 else math.nan
    return 0.5 * (cov[:3, :3] + cov[:3, :3].T), radius_std


@dataclass(frozen=True)
class _LocalFit:
    centre: FloatArray  # (3,), centred coordinates
    radius: float
    cov: FloatArray
    radius_std: float
    residuals: FloatArray  # (N,) orthogonal, or range (NaN where a beam misses)
    used: BoolArray  # (N,) points in the final least squares
    rms: float
    iterations: int
    method: str

    @property
    def params(self) -> FloatArray:
        """(c, R) parameter vector."""
        return np.append(self.centre, self.radius)

    def sphere_fit(
        self, ref: FloatArray, inliers: BoolArray, residuals_m: FloatArray, *, radius_fixed: bool
    ) -> SphereFit:
        """The result in the caller's coordinates (``ref`` added back)."""
        return SphereFit(
            center_m=ref + self.centre,
            radius_m=self.radius,
            radius_fixed=radius_fixed,
            cov_center_m2=self.cov,
            radius_std_m=self.radius_std,
            residual_rms_m=self.rms,
            n_points=int(inliers.sum()),
            inliers=inliers,
            residuals_m=residuals_m,
            method=self.method,
            iterations=self.iterations,
        )


_MAX_INCIDENCE_DEG = 85.0
"""Beams meeting the sphere more obliquely are left out of the ray model."""


def _fit_local(
    xc: FloatArray,
    radius_fixed: float | None,
    origin_local: FloatArray | None,
    max_iterations: int,
    tol_m: float,
    what: str,
    p0: FloatArray | None = None,
) -> _LocalFit:
    """Orthogonal, then (with an origin) ray-model least squares in centred coordinates."""
    if p0 is None:
        p0, _ = _start_params(xc, what, radius_fixed)
    res_fn, jac_fn = _ortho_model(xc, radius_fixed)
    lm = _levenberg_marquardt(res_fn, jac_fn, p0, None, max_iterations, tol_m)
    if not lm.converged:
        msg = (
            f"{what}: the geometric sphere fit did not converge in {max_iterations} "
            f"iterations ({xc.shape[1]} points); raise max_iterations or check the points"
        )
        raise ConvergenceError(msg)
    n = xc.shape[1]
    n_params = 4 if radius_fixed is None else 3
    p = lm.params
    radius = float(p[3]) if radius_fixed is None else radius_fixed
    if not math.isfinite(radius) or radius <= 0.0:
        msg = f"{what}: the fit ended with a non-positive radius ({radius!r} m)"
        raise ConvergenceError(msg)
    if origin_local is None:
        e = lm.residuals
        cov, radius_std = _covariance(jac_fn(p, lm.state), e, n_params)
        rms = float(np.sqrt(e @ e / n))
        used = np.ones(n, dtype=bool)
        return _LocalFit(
            p[:3].copy(), radius, cov, radius_std, e, used, rms, lm.iterations, "geometric"
        )
    iterations = lm.iterations
    if float(np.linalg.norm(p[:3] - origin_local)) <= radius:
        msg = (
            f"{what}: origin_m lies inside the fitted sphere; the ray model needs the "
            "scanner outside the target (check origin_m and its frame)"
        )
        raise InputError(msg)
    # Beams at grazing incidence make the range model strongly nonlinear: leave them
    # out. The selection depends on the beam directions only (exact under range noise),
    # not on the measured ranges, so it does not bias the fit. Points on the far side
    # of the sphere (outward normal pointing away from the scanner) cannot be returns
    # from it: left out too.
    _, cos_inc, hit = _ray_residuals_all(xc, origin_local, p[:3], radius)
    facing = np.einsum("ij,ij->j", xc - p[:3, None], xc - origin_local[:, None]) < 0.0
    used = hit & facing & (cos_inc >= math.cos(math.radians(_MAX_INCIDENCE_DEG)))
    n_used = int(used.sum())
    if n_used < max(n_params + 1, n // 2):
        msg = (
            f"{what}: only {n_used} of {n} points face origin_m and lie on beams that meet "
            f"the fitted sphere at less than {_MAX_INCIDENCE_DEG:g} deg incidence; "
            "origin_m does not look like the scanner that saw these points (check it and "
            "its frame)"
        )
        raise InputError(msg)
    xc_used = xc if n_used == n else np.ascontiguousarray(xc[:, used])
    ray_res, ray_jac = _ray_model(xc_used, origin_local, radius_fixed)
    lm = _levenberg_marquardt(ray_res, ray_jac, p, None, max_iterations, tol_m)
    if not lm.converged:
        msg = (
            f"{what}: the ray-model sphere fit did not converge in {max_iterations} "
            f"iterations ({n_used} beams); raise max_iterations or fit without origin_m"
        )
        raise ConvergenceError(msg)
    iterations += lm.iterations
    p = lm.params
    radius = float(p[3]) if radius_fixed is None else radius_fixed
    e_used = lm.residuals
    cov, radius_std = _covariance(ray_jac(p, lm.state), e_used, n_params)
    rms = float(np.sqrt(e_used @ e_used / n_used))
    e_all, _, _ = _ray_residuals_all(xc, origin_local, p[:3], radius)
    return _LocalFit(p[:3].copy(), radius, cov, radius_std, e_all, used, rms, iterations, "ray")


def fit_sphere(
    points_m: ArrayLike,
    *,
    radius_m: float | None = None,
    origin_m: ArrayLike | None = None,
    max_iterations: int = 50,
    tol_m: float = 1e-10,
) -> SphereFit:
    """Least-squares sphere through points: algebraic start, geometric refinement.

    Starts from the Hyper fit (`fit_sphere_algebraic`, never the barycentre) and runs
    Levenberg-Marquardt on ``r_i = |x_i - c| - rho`` (radius free: 4 unknowns; given:
    3). With ``origin_m`` it then refines on the range residual along each beam (the
    ray model of this module's docstring), unbiased under range-only noise. All points
    are used: segment first (`segment_sphere`) when the cloud holds other objects.

    Parameters
    ----------
    points_m : array_like, shape (N, 3)
        Points on the sphere (m), any Cartesian frame (ECEF/UTM-sized coordinates are
        fine: the computation is centred on the points). N >= 4.
    radius_m : float, optional
        Known radius (m, > 0). Estimated when omitted.
    origin_m : array_like, shape (3,), optional
        Scanner origin (m), same frame as the points; selects the ray model.
    max_iterations : int
        Iteration limit of each Levenberg-Marquardt stage.
    tol_m : float
        Convergence tolerance on the parameter step (m).

    Returns
    -------
    SphereFit
        ``method`` is ``"geometric"`` or ``"ray"``. ``inliers`` is all True for the
        geometric fit; the ray model leaves out beams meeting the sphere at more than
        85 deg incidence and points on its far side (their ``residuals_m`` are still
        given, NaN where the beam misses).

    Raises
    ------
    InputError
        Wrong shape, fewer than 4 points, NaN/inf, non-positive radius, bad origin,
        collinear or coplanar points, origin inside the sphere.
    ConvergenceError
        No convergence within ``max_iterations``.

    References
    ----------
    Al-Sharadqah & Chernov 2009 (Hyper start); Marquardt 1963; Seube et al. 2012
    (ISPRS JPRS 74, 85-89) for the latency-calibration use.
    """
    what = "fit_sphere"
    pts = _validated_points(points_m, what)
    radius = _validated_radius(radius_m, what)
    origin = _validated_origin(origin_m, what)
    if max_iterations < 1:
        msg = f"{what}: max_iterations must be >= 1, got {max_iterations}"
        raise InputError(msg)
    if not (math.isfinite(tol_m) and tol_m > 0.0):
        msg = f"{what}: tol_m must be finite and > 0 (m), got {tol_m!r}"
        raise InputError(msg)
    ref, xc = _centred(pts)
    _check_not_degenerate(xc, what)
    origin_local = None if origin is None else origin - ref
    fit = _fit_local(xc, radius, origin_local, max_iterations, tol_m, what)
    return fit.sphere_fit(ref, fit.used, fit.residuals, radius_fixed=radius is not None)


# --------------------------------------------------------------------------- RANSAC
