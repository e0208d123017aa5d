"""Method A estimator: total latency from sphere centres at +omega and -omega.

Passes are pooled per signed table rate; one sphere centre is fitted per pool (robust
segmentation from clutter, then a range-noise-weighted fit along the scanner rays).
A pass with no usable sphere (fewer than `MIN_SPHERE_POINTS_PER_PASS` of its points on
the sphere fitted at its rate) is rejected, reported with the reason, and the pool
refitted without it.
With latency tau the georeferenced sphere is rotated about the table axis by
``-omega tau`` (SPEC section 2): ``c_k = Rot(-w_k tau) c`` for each pool k with rate
vector ``w_k``. Per rate, the two pools give (c, tau) by weighted Gauss-Newton on that
exact rotation model with the full 3-D rate vectors; the rates are combined by
inverse variance into one ``tau +- sigma``, with a chi-square test of their agreement;
when the test rejects agreement (p < `RATES_DISAGREE_P`) the sigma is scaled by the Birge
ratio ``sqrt(chi2 / dof)`` and the result says so. The published first-order formula
is reported beside each rate for comparison. Each pass's own centre is fitted too, and
their scatter beyond their points' noise (an error shared by a pass) enters every
pool's covariance (`kinsync.latency.pass_scatter`).

References
----------
Seube, N., Picard, A., Rondeau, M., "A simple method to recover the latency time of
tactical grade IMU systems", ISPRS J. Photogramm. Remote Sens. 74 (2012) 85-89.
"""

from __future__ import annotations

import contextlib
import itertools
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from scipy import stats
from scipy.spatial.transform import Rotation

from kinsync._arrays import ReadOnlyArrays, readonly_array
from kinsync._text import counted, format_p_value
from kinsync._typing import ArrayLike, BoolArray, FloatArray
from kinsync._validate import finite_vector, positive_number, seed_number
from kinsync.errors import ConvergenceError, InputError, ObservabilityError
from kinsync.fit import SphereFit, fit_sphere, segment_sphere
from kinsync.frames import skew
from kinsync.latency.model_check import (
    check_rotation_model,
    model_p_value,
    radius_contradiction,
)
from kinsync.latency.pairing import RejectedPass, left_without_partner, pair_groups
from kinsync.latency.pass_scatter import (
    PassCentres,
    PassScatter,
    estimate_pass_scatter,
    fit_pass_centres,
    pool_scatter_cov_m2,
)
from kinsync.latency.passes import SpherePass, check_distinct_passes, pass_sequence
from kinsync.latency.planning import (
    DEFAULT_MAX_INCIDENCE_DEG,
    MIN_SPHERE_POINTS_PER_PASS,
    checked_max_incidence_deg,
)
from kinsync.latency.rate_check import (
    rate_check_counts,
    unchecked_rates_text,
    warn_unchecked_rates,
)
from kinsync.latency.roi import RoiCrop, checked_roi, crop_passes
from kinsync.latency.sphere_failures import pool_failure as _pool_failure
from kinsync.progress import Progress, report
from kinsync.robust import robust_sigma

__all__ = [
    "DEFAULT_MAX_INCIDENCE_DEG",
    "MIN_SPHERE_POINTS_PER_PASS",
    "RATES_DISAGREE_P",
    "PoolFit",
    "RateLatency",
    "RejectedPass",
    "SphereLatencyResult",
    "estimate_latency_sphere",
    "fit_pool",
    "latency_from_pool_pair",
]

_TAIL_CUT_SIGMA = 4.0
_MIN_AXIS_SINE = 1e-3
RATES_DISAGREE_P = 0.01
"""Below this p-value of the chi-square test between rates the rates disagree: the
latency sigma is scaled by the Birge ratio and the result is flagged."""


@dataclass(frozen=True, eq=False)
class PoolFit(ReadOnlyArrays):
    """Sphere fit of all passes at one signed rate.

    Attributes
    ----------
    rate_deg_s : float
        Signed table rate (deg/s).
    rate_vector_ned_rad_s : ndarray, shape (3,)
        Signed rate vector, table-centred NED (rad/s).
    n_passes : int
        Passes pooled.
    n_points_in : int
        Points given (sphere and clutter).
    n_points : int
        Points used in the final centre fit.
    fit : SphereFit
        The final fit (centre, radius, covariance, residuals).
    sources : tuple of str
        Where the pooled passes came from.
    n_points_per_pass : tuple of int
        Points of each pass (in the order of ``sources``) used in the final centre fit;
        empty when not known.
    free_radius_m, free_radius_std_m : float
        With a given radius: the radius and its sigma fitted freely to the same points,
        to test the given one (`kinsync.latency.model_check.radius_contradiction`);
        nan otherwise.
    pass_centres : PassCentres or None
        Each pass's own centre on the same points (`kinsync.latency.pass_scatter`).
    between_pass_cov_m2 : ndarray, shape (3, 3)
        What errors shared by a pass add to the centre's covariance (m^2, NED; zero
        until `kinsync.latency.pass_scatter` has measured them).
    """

    rate_deg_s: float
    rate_vector_ned_rad_s: FloatArray
    n_passes: int
    n_points_in: int
    n_points: int
    fit: SphereFit
    sources: tuple[str, ...]
    n_points_per_pass: tuple[int, ...] = ()
    free_radius_m: float = math.nan
    free_radius_std_m: float = math.nan
    pass_centres: PassCentres | None = None
    between_pass_cov_m2: FloatArray = field(default_factory=lambda: np.zeros((3, 3)))

    def __post_init__(self) -> None:
        # Own read-only copies, as SphereFit's arrays: a result never changes.
        object.__setattr__(
            self, "rate_vector_ned_rad_s", readonly_array(self.rate_vector_ned_rad_s)
        )
        object.__setattr__(self, "between_pass_cov_m2", readonly_array(self.between_pass_cov_m2))

    @property
    def center_cov_m2(self) -> FloatArray:
        """Centre covariance (3, 3), NED (m^2): the points' noise plus the passes' shared errors."""
        cov: FloatArray = self.fit.cov_center_m2 + self.between_pass_cov_m2
        return cov

    @property
    def center_std_m(self) -> float:
        """Centre standard deviation, RMS over the three axes (m), as `center_cov_m2`."""
        return float(np.sqrt(np.trace(self.center_cov_m2) / 3.0))


@dataclass(frozen=True, eq=False)
class RateLatency(ReadOnlyArrays):
    """Latency from the pair of pools at one rate.

    Attributes
    ----------
    rate_deg_s : float
        Table rate magnitude (deg/s).
    n_points : int
        Points used in both centre fits.
    center_std_m : float
        RMS of the two pools' centre standard deviations (m).
    latency_s, latency_std_s : float
        Estimate of tau and its standard deviation (s), exact rotation model.
    latency_first_order_s : float
        The published first-order formula: the separation of the two centres projected
        on ``(w+ - w-) x c`` divided by its norm (s).
    center_ned_m : ndarray, shape (3,)
        Sphere centre with the latency removed, table-centred NED (m).
    chi2 : float
        Weighted misfit of the 6 centre coordinates to the 4-parameter model (2 dof;
        about 2 with correct input, far more with a wrong axis or points not
        table-centred: `kinsync.latency.model_check`).
    plus, minus : PoolFit
        The pools at +omega and -omega.
    """

    rate_deg_s: float
    n_points: int
    center_std_m: float
    latency_s: float
    latency_std_s: float
    latency_first_order_s: float
    center_ned_m: FloatArray
    chi2: float
    plus: PoolFit
    minus: PoolFit

    def __post_init__(self) -> None:
        # Own read-only copy, as SphereFit's arrays: a result never changes.
        object.__setattr__(self, "center_ned_m", readonly_array(self.center_ned_m))

    def row_text(self) -> tuple[str, ...]:
        """Rate, points, centre sigma (mm), latency, sigma, first-order (ms), model chi2."""
        return (
            f"{self.rate_deg_s:g}",
            str(self.n_points),
            f"{self.center_std_m * 1e3:.4f}",
            f"{self.latency_s * 1e3:.4f}",
            f"{self.latency_std_s * 1e3:.4f}",
            f"{self.latency_first_order_s * 1e3:.4f}",
            f"{self.chi2:.2f}",
        )


@dataclass(frozen=True, eq=False)
class SphereLatencyResult(ReadOnlyArrays):
    """Combined Method A result.

    Attributes
    ----------
    latency_s : float
        Inverse-variance combination over rates (s).
    latency_std_s : float
        Its sigma (s): `latency_formal_std_s` times `sigma_scale`.
    latency_formal_std_s : float
        The inverse-variance sigma from the per-rate sigmas alone (s).
    sigma_scale : float
        1 when the rates agree; the Birge ratio ``sqrt(chi2 / dof)`` when the chi-square
        test rejects their agreement (p < `RATES_DISAGREE_P`): the rates then scatter
        more than their sigmas allow, and the sigma is widened to that scatter. A
        disagreement usually means a systematic effect the model lacks (a rate's sign or
        unit wrong in ``passes.csv``, a tilted axis given as vertical), which widening
        does not remove: see `rates_disagree`.
    per_rate : tuple of RateLatency
        By increasing rate.
    sphere_center_ned_m : ndarray, shape (3,)
        Sphere centre with latency removed (weighted over rates), NED (m).
    sphere_radius_m : float
        Given radius, or the mean fitted radius.
    radius_fixed : bool
        True when the radius was given.
    chi2_between_rates : float
        ``sum((tau_r - tau)^2 / sigma_r^2)``; ``dof_between_rates = n_rates - 1``.
    dof_between_rates : int
    p_value_between_rates : float
        Probability of a chi-square at least this large if the rates agree (nan for one
        rate); a small value flags a systematic effect not in the model.
    unpaired_rates_deg_s : tuple of float
        Rates left out because only passes of one sign were given, or only passes of
        one sign hold a usable sphere (see ``rejected_passes``).
    n_passes : int
        Passes read.
    rejected_passes : tuple of RejectedPass
        Passes left out of the estimate, each with the reason: fewer than
        `MIN_SPHERE_POINTS_PER_PASS` of its points on the sphere fitted at its rate, or no
        sphere found at its rate at all.
    unpaired_passes : tuple of RejectedPass
        Passes left out because no pass of the opposite sign at their rate (about the
        same axis) was given, or none of those holds a usable sphere, each with the
        reason (``n_sphere_points`` 0 where its rate was not fitted). ``n_passes`` is
        `n_passes_used` plus the rejected and the unpaired passes.
    roi : RoiCrop or None
        The region of interest and the points of each pass outside it (left out before
        segmentation); None when none was given. Point counts elsewhere in the result
        are of the points inside it.
    n_passes_rate_checked : int
        Passes whose points confirmed the sign and size of their stated rate
        (`kinsync.latency.rate_check`); the others (no point times, or points that do
        not turn about the stated axis) were not checked: see `rates_unchecked_text`.
    n_passes_unswept : int
        Of those not checked, the passes whose points have times but do not turn about
        the stated axis (a wrong axis, points not table-centred, a scanner that does not
        sweep with the table).
    pass_scatter : PassScatter or None
        How far the passes' own centres scatter about their pools beyond their points'
        noise (an attitude error shared by a pass), with its chi-square test; its
        covariance is in every pool's and so in every sigma
        (`kinsync.latency.pass_scatter`). ``measured`` False with one pass per rate and
        direction: the sigmas then count the points' noise only.
    """

    latency_s: float
    latency_std_s: float
    latency_formal_std_s: float
    sigma_scale: float
    per_rate: tuple[RateLatency, ...]
    sphere_center_ned_m: FloatArray
    sphere_radius_m: float
    radius_fixed: bool
    chi2_between_rates: float
    dof_between_rates: int
    p_value_between_rates: float
    unpaired_rates_deg_s: tuple[float, ...]
    n_passes: int
    rejected_passes: tuple[RejectedPass, ...] = ()
    roi: RoiCrop | None = None
    unpaired_passes: tuple[RejectedPass, ...] = ()
    n_passes_rate_checked: int = 0
    n_passes_unswept: int = 0
    pass_scatter: PassScatter | None = None

    def __post_init__(self) -> None:
        # Own read-only copy, as SphereFit's arrays: a result never changes.
        object.__setattr__(self, "sphere_center_ned_m", readonly_array(self.sphere_center_ned_m))

    @property
    def rates_disagree(self) -> bool:
        """True when the chi-square test rejects the rates' agreement (p < 0.01)."""
        return self.dof_between_rates > 0 and self.p_value_between_rates < RATES_DISAGREE_P

    def agreement_text(self) -> str:
        """The chi-square test between rates in words.

        E.g. ``rates agree: chi2 1.20 on 2 dof, p = 0.55``; with one rate, that no test
        was possible; when the test rejects agreement, the widened sigma's factor. Not
        "rates agree" when the points did not check every stated rate: flipped signs or
        rad/s agree just as well (`rates_unchecked_text`).
        """
        if self.dof_between_rates == 0:
            return "one rate: its agreement with other rates is not tested"
        test = (
            f"chi2 {self.chi2_between_rates:.2f} on {self.dof_between_rates} dof, "
            f"{format_p_value(self.p_value_between_rates)}"
        )
        if not self.rates_disagree:
            if self.rates_unchecked_text():  # a wrong sign or unit agrees as well
                return f"per-rate latencies agree: {test} (rates' sign and unit not checked)"
            return f"rates agree: {test}"
        return (
            f"rates DISAGREE: {test}; sigma widened x{self.sigma_scale:.2f} to their scatter "
            f"(formal {self.latency_formal_std_s * 1e3:.4f} ms)"
        )

    def radius_contradiction_text(self) -> str:
        """The given radius against the radius each pool's points show; "" if they agree."""
        if not self.radius_fixed:
            return ""
        pools = [
            (pool.rate_deg_s, pool.free_radius_m, pool.free_radius_std_m)
            for r in self.per_rate
            for pool in (r.plus, r.minus)
        ]
        return radius_contradiction(self.sphere_radius_m, pools)

    def rates_unchecked_text(self) -> str:
        """Which passes' stated rates the points did not check, in words; "" if none."""
        return unchecked_rates_text(
            self.n_passes_rate_checked, self.n_passes, self.n_passes_unswept
        )

    @property
    def n_passes_used(self) -> int:
        """Passes in the estimate: those read, less the rejected and the unpaired ones."""
        return sum(r.plus.n_passes + r.minus.n_passes for r in self.per_rate)

    def as_document(self) -> dict[str, Any]:
        """JSON-ready summary (what ``kinsync latency sphere --json`` prints)."""
        return {
            "latency_ms": self.latency_s * 1e3,
            "latency_std_ms": self.latency_std_s * 1e3,
            "latency_formal_std_ms": self.latency_formal_std_s * 1e3,
            "sigma_scale": self.sigma_scale,
            "per_rate": [
                {
                    "rate_deg_s": r.rate_deg_s,
                    "n_points": r.n_points,
                    "center_std_m": r.center_std_m,
                    "latency_ms": r.latency_s * 1e3,
                    "latency_std_ms": r.latency_std_s * 1e3,
                    "latency_first_order_ms": r.latency_first_order_s * 1e3,
                    "n_passes": r.plus.n_passes + r.minus.n_passes,
                    "n_points_in": r.plus.n_points_in + r.minus.n_points_in,
                    "chi2": r.chi2,
                    "chi2_p_value": model_p_value(r.chi2),
                }
                for r in self.per_rate
            ],
            "sphere": {
                "center_ned_m": self.sphere_center_ned_m.tolist(),
                "radius_m": self.sphere_radius_m,
                "radius_fixed": self.radius_fixed,
            },
            "consistency": {
                "chi2_between_rates": self.chi2_between_rates,
                "dof": self.dof_between_rates,
                "p_value": self.p_value_between_rates,
                "rates_disagree": self.rates_disagree,
                "n_passes_rate_checked": self.n_passes_rate_checked,
                "n_passes_unswept": self.n_passes_unswept,
            },
            "unpaired_rates_deg_s": list(self.unpaired_rates_deg_s),
            "n_passes": self.n_passes,
            "n_passes_used": self.n_passes_used,
            "rejected_passes": [r.as_document() for r in self.rejected_passes],
            "unpaired_passes": [r.as_document() for r in self.unpaired_passes],
            "roi": None if self.roi is None else self.roi.as_document(),
            "pass_scatter": None if self.pass_scatter is None else self.pass_scatter.as_document(),
        }


def _incidence_cos(points: FloatArray, center: FloatArray, origin: FloatArray) -> FloatArray:
    """|cos| of the angle between each ray and the sphere normal at its point."""
    ray = points - origin
    ray /= np.linalg.norm(ray, axis=1, keepdims=True)
    normal = points - center
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    cos: FloatArray = np.abs(np.einsum("ij,ij->i", ray, normal))
    return cos


def fit_pool(
    passes: Sequence[SpherePass],
    *,
    radius_m: float | None = None,
    scanner_origin_ned_m: ArrayLike | None = (0.0, 0.0, 0.0),
    max_incidence_deg: float = DEFAULT_MAX_INCIDENCE_DEG,
    seed: int = 0,
) -> PoolFit:
    """Segment and fit one sphere centre from passes at one signed rate.

    Parameters
    ----------
    passes : sequence of SpherePass
        Passes sharing one signed rate and axis.
    radius_m : float, optional
        Known sphere radius (m); estimated when None.
    scanner_origin_ned_m : array_like, shape (3,), optional
        Scanner optical centre in the table-centred frame (the table centre, by
        construction of the set-up); enables the ray-direction range model. None: fit
        orthogonal distances.
    max_incidence_deg : float
        Returns more oblique than this are excluded from the final fit (and from the
        planner's prediction, `kinsync.latency.planning`).
    seed : int
        RANSAC seed.

    Raises
    ------
    InputError
        No sphere found among the pooled points; max_incidence_deg outside
        [`~kinsync.latency.planning.MIN_MAX_INCIDENCE_DEG`, 90).
    """
    if not passes:
        msg = "fit_pool: no passes given"
        raise InputError(msg)
    max_incidence_deg = checked_max_incidence_deg(max_incidence_deg)
    seed = seed_number(seed, "seed")
    points = np.concatenate([p.points_ned_m for p in passes])
    origin = None if scanner_origin_ned_m is None else _checked_origin(scanner_origin_ned_m)
    n_text = f"{counted(len(passes), 'pass')}, {counted(len(points), 'point')}"
    label = f"rate {passes[0].rate_deg_s:+g} deg/s ({n_text})"
    try:
        seg = segment_sphere(points, radius_m=radius_m, origin_m=origin, seed=seed)
    except InputError as err:
        msg = f"{label}: {err}"
        raise InputError(msg) from err
    # Re-select the sphere points on the final model with a wide cut: segmentation's
    # 3-sigma inlier band truncates the Gaussian tails and would make the reported
    # sigma ~7 % optimistic. Candidates: near the surface, facing the scanner, below
    # the incidence cap; then cut at 4 robust sigma of the final residuals, twice.
    centre, radius = seg.center_m, seg.radius_m
    # Distance to the surface, converted to range along the ray when the origin is
    # known (range noise shows as surface distance times cos(incidence)).
    miss_m = np.abs(np.linalg.norm(points - centre, axis=1) - radius)
    keep = np.ones(len(points), dtype=bool)
    if origin is not None:
        cos_cap = math.cos(math.radians(max_incidence_deg))
        cos = _incidence_cos(points, centre, origin)
        keep &= cos >= cos_cap
        miss_m = miss_m / np.maximum(cos, cos_cap)
    band_m = (_TAIL_CUT_SIGMA + 1.0) * robust_sigma(miss_m[seg.inliers])
    keep &= miss_m <= max(band_m, 1e-6)
    final = _fit_kept(points, keep, radius_m, origin, label)
    for _ in range(2):
        resid = np.full(len(points), np.inf)
        resid[np.flatnonzero(keep)] = np.abs(final.residuals_m)
        sigma = robust_sigma(final.residuals_m, omit_nan=True)
        keep = keep & (resid <= _TAIL_CUT_SIGMA * sigma)
        final = _fit_kept(points, keep, radius_m, origin, label)
    inliers = np.zeros(len(points), dtype=bool)
    inliers[np.flatnonzero(keep)] = final.inliers
    residuals = np.full(len(points), np.nan)
    residuals[np.flatnonzero(keep)] = final.residuals_m
    fit = SphereFit(
        center_m=final.center_m,
        radius_m=final.radius_m,
        radius_fixed=final.radius_fixed,
        cov_center_m2=final.cov_center_m2,
        radius_std_m=final.radius_std_m,
        residual_rms_m=final.residual_rms_m,
        n_points=final.n_points,
        inliers=inliers,
        residuals_m=residuals,
        method=final.method,
        iterations=final.iterations,
    )
    rate_vectors = np.array([p.rate_vector_ned_rad_s for p in passes])
    bounds = np.cumsum([0, *(p.n_points for p in passes)])
    used_in = np.concatenate([[0], np.cumsum(inliers)])
    per_pass = tuple(int(used_in[b] - used_in[a]) for a, b in itertools.pairwise(bounds))
    centres = fit_pass_centres(points, bounds, inliers, final.radius_m, origin)
    free = None
    if radius_m is not None:  # the given radius, tested against the points' own
        with contextlib.suppress(InputError, ConvergenceError):
            free = fit_sphere(points[keep], radius_m=None, origin_m=origin)
    return PoolFit(
        rate_deg_s=passes[0].rate_deg_s,
        rate_vector_ned_rad_s=rate_vectors.mean(axis=0),
        n_passes=len(passes),
        n_points_in=len(points),
        n_points=final.n_points,
        fit=fit,
        sources=tuple(p.source for p in passes),
        n_points_per_pass=per_pass,
        free_radius_m=math.nan if free is None else free.radius_m,
        free_radius_std_m=math.nan if free is None else free.radius_std_m,
        pass_centres=centres,
    )


def _fit_kept(
    points: FloatArray,
    keep: BoolArray,
    radius_m: float | None,
    origin: FloatArray | None,
    label: str,
) -> SphereFit:
    if np.count_nonzero(keep) < 10:
        msg = f"{label}: only {np.count_nonzero(keep)} sphere points left after segmentation"
        raise InputError(msg)
    return fit_sphere(points[keep], radius_m=radius_m, origin_m=origin)


def _rotated(rate_vector: FloatArray, latency_s: float, center: FloatArray) -> FloatArray:
    rotated: FloatArray = Rotation.from_rotvec(-rate_vector * latency_s).apply(np.array(center))
    return rotated


def latency_from_pool_pair(plus: PoolFit, minus: PoolFit) -> RateLatency:
    """Latency from the centres at +omega and -omega (exact rotation model).

    Unknowns: the latency-free centre c and tau; observations: the two fitted centres
    with their covariances. Model ``c_k = Rot(-w_k tau) c``; weighted Gauss-Newton from
    the first-order solution.

    Raises
    ------
    ObservabilityError
        The rotation axis points at the sphere: the centres do not move with tau.
    """
    w_p, w_m = plus.rate_vector_ned_rad_s, minus.rate_vector_ned_rad_s
    c_p, c_m = plus.fit.center_m, minus.fit.center_m
    c_mean = 0.5 * (c_p + c_m)
    dw = w_p - w_m
    lever = np.cross(dw, c_mean)
    sine = float(np.linalg.norm(lever) / (np.linalg.norm(dw) * np.linalg.norm(c_mean)))
    if not math.isfinite(sine) or sine < _MIN_AXIS_SINE:
        msg = (
            f"rate {abs(plus.rate_deg_s):g} deg/s: the rotation axis points at the sphere "
            f"(angle {math.degrees(math.asin(min(1.0, sine))):.3g} deg), so the latency "
            "does not move the sphere centre and is unobservable; place the sphere away "
            "from the table axis"
        )
        raise ObservabilityError(msg)
    # First order: c- - c+ = tau (w+ - w-) x c.
    delta = c_m - c_p
    tau_first = float(delta @ lever / (lever @ lever))

    weight = np.zeros((6, 6))
    weight[:3, :3] = np.linalg.inv(plus.center_cov_m2)
    weight[3:, 3:] = np.linalg.inv(minus.center_cov_m2)
    obs = np.concatenate([c_p, c_m])
    # Start: tau from first order, c as the mean rotated back.
    tau = tau_first
    c = 0.5 * (_rotated(w_p, -tau, c_p) + _rotated(w_m, -tau, c_m))
    jac = np.zeros((6, 4))
    for _ in range(20):
        m_p, m_m = _rotated(w_p, tau, c), _rotated(w_m, tau, c)
        resid = obs - np.concatenate([m_p, m_m])
        jac[:3, :3] = Rotation.from_rotvec(-w_p * tau).as_matrix()
        jac[3:, :3] = Rotation.from_rotvec(-w_m * tau).as_matrix()
        jac[:3, 3] = -skew(w_p) @ m_p
        jac[3:, 3] = -skew(w_m) @ m_m
        normal = jac.T @ weight @ jac
        step = np.linalg.solve(normal, jac.T @ weight @ resid)
        c = c + step[:3]
        tau += float(step[3])
        if abs(step[3]) < 1e-12 and np.max(np.abs(step[:3])) < 1e-12:
            break
    m_p, m_m = _rotated(w_p, tau, c), _rotated(w_m, tau, c)
    resid = obs - np.concatenate([m_p, m_m])
    cov = np.linalg.inv(jac.T @ weight @ jac)
    return RateLatency(
        rate_deg_s=0.5 * (abs(plus.rate_deg_s) + abs(minus.rate_deg_s)),
        n_points=plus.n_points + minus.n_points,
        center_std_m=float(np.sqrt(0.5 * (plus.center_std_m**2 + minus.center_std_m**2))),
        latency_s=tau,
        latency_std_s=float(np.sqrt(cov[3, 3])),
        latency_first_order_s=tau_first,
        center_ned_m=c,
        chi2=float(resid @ weight @ resid),
        plus=plus,
        minus=minus,
    )


_FAILURES_SHOWN = 2


def _fit_pool_rejecting(
    passes: Sequence[SpherePass],
    radius_m: float | None,
    scanner_origin_ned_m: ArrayLike | None,
    max_incidence_deg: float,
    seed: int,
    *,
    roi_given: bool = False,
) -> tuple[PoolFit | None, list[RejectedPass], str | None]:
    """Fit one pool, leaving out the passes that hold no usable sphere.

    A pass with fewer than `MIN_SPHERE_POINTS_PER_PASS` points (or fewer of its points
    on the pool's sphere) is rejected and the pool refitted without it. When no sphere
    is found among the remaining passes, all of them are rejected: the pool is None and
    the third item says why.
    """
    minimum = MIN_SPHERE_POINTS_PER_PASS
    rejected = [
        RejectedPass(
            p.source,
            p.rate_deg_s,
            p.n_points,
            0,
            f"only {counted(p.n_points, 'point')} in the pass; at least {minimum} on the "
            "sphere are needed",
        )
        for p in passes
        if p.n_points < minimum
    ]
    usable = [p for p in passes if p.n_points >= minimum]
    while usable:
        try:
            pool = fit_pool(
                usable,
                radius_m=radius_m,
                scanner_origin_ned_m=scanner_origin_ned_m,
                max_incidence_deg=max_incidence_deg,
                seed=seed,
            )
        except (InputError, ConvergenceError) as err:
            spread_m = float(np.max(np.ptp(np.concatenate([p.points_ned_m for p in usable]), 0)))
            failure = _pool_failure(err, radius_m, spread_m, roi_given=roi_given)
            reason = f"no sphere found at this rate: {failure}"
            rejected += [
                RejectedPass(p.source, p.rate_deg_s, p.n_points, 0, reason) for p in usable
            ]
            return None, rejected, failure
        short = [k for k, n in enumerate(pool.n_points_per_pass) if n < minimum]
        if not short:
            return pool, rejected, None
        rejected += [
            RejectedPass(
                usable[k].source,
                usable[k].rate_deg_s,
                usable[k].n_points,
                pool.n_points_per_pass[k],
                f"no usable sphere: {pool.n_points_per_pass[k]} of its "
                f"{counted(usable[k].n_points, 'point')} lie on the sphere fitted at this "
                f"rate (at least {minimum} needed); check that the sphere was in view",
            )
            for k in short
        ]
        usable = [p for k, p in enumerate(usable) if k not in short]
    return None, rejected, f"rate {passes[0].rate_deg_s:+g} deg/s: no pass holds a usable sphere"


def _combined(per_rate: Sequence[RateLatency]) -> tuple[float, float, float, int, float, float]:
    """Inverse-variance latency, its formal sigma, chi2, dof, p-value, Birge factor."""
    tau_r = np.array([r.latency_s for r in per_rate])
    weights = 1.0 / np.array([r.latency_std_s**2 for r in per_rate])
    tau = float(np.sum(weights * tau_r) / np.sum(weights))
    formal_std = float(np.sqrt(1.0 / np.sum(weights)))
    chi2 = float(np.sum((tau_r - tau) ** 2 * weights))
    dof = len(per_rate) - 1
    p_value = float(stats.chi2.sf(chi2, dof)) if dof > 0 else math.nan
    scale = math.sqrt(chi2 / dof) if dof > 0 and p_value < RATES_DISAGREE_P else 1.0
    return tau, formal_std, chi2, dof, p_value, scale


def _latencies_with_pass_scatter(
    fitted: Sequence[tuple[PoolFit, PoolFit]],
) -> tuple[PassScatter, list[RateLatency], list[tuple[float, float]]]:
    """The passes' shared scatter from every pool, added to each pool; latency per rate.

    Also each rate's rotation-model chi2 with the scatter at its upper bound, for
    `check_rotation_model`. Rates in increasing order.
    """
    pools = [pool for pair in fitted for pool in pair if pool.pass_centres is not None]
    scatter = estimate_pass_scatter(
        [p.pass_centres for p in pools if p.pass_centres is not None],
        [p.rate_deg_s for p in pools],
    )

    def widened(pool: PoolFit, between: PassScatter) -> PoolFit:
        if pool.pass_centres is None:
            return pool
        extra = pool_scatter_cov_m2(pool.pass_centres, between.for_rate(pool.rate_deg_s))
        return replace(pool, between_pass_cov_m2=extra)

    per_rate = [latency_from_pool_pair(widened(p, scatter), widened(m, scatter)) for p, m in fitted]

    # The model test counts the scatter at its upper bound: few passes can measure it low.
    def upper(pool: PoolFit) -> PoolFit:
        own = scatter.for_rate(pool.rate_deg_s)
        return widened(pool, replace(own, cov_m2=own.upper_cov_m2(), rates=()))

    checks = [
        (r.rate_deg_s, latency_from_pool_pair(upper(p), upper(m)).chi2)
        for r, (p, m) in zip(per_rate, fitted, strict=True)
    ]
    order = np.argsort([r.rate_deg_s for r in per_rate], kind="stable")
    return scatter, [per_rate[k] for k in order], [checks[k] for k in order]


def _checked_origin(origin: ArrayLike) -> FloatArray:
    """The scanner origin as 3 finite float64 numbers (m), or `InputError` naming it."""
    return finite_vector(origin, 3, "scanner_origin_ned_m", " (x, y, z, m)")


def estimate_latency_sphere(
    passes: Iterable[SpherePass],
    *,
    radius_m: float | None = None,
    scanner_origin_ned_m: ArrayLike | None = (0.0, 0.0, 0.0),
    max_incidence_deg: float = DEFAULT_MAX_INCIDENCE_DEG,
    seed: int = 0,
    progress: Progress | None = None,
    roi_ned_m: Sequence[float] | None = None,
) -> SphereLatencyResult:
    """Total latency from sphere passes at opposite table rates (Method A).

    Parameters
    ----------
    passes : iterable of SpherePass
        Georeferenced passes (table-centred NED) with signed controller rates (a
        generator is read once, into a tuple).
    radius_m : float, optional
        Known sphere radius (m); estimated per pool when None.
    scanner_origin_ned_m : array_like, shape (3,), optional
        Scanner optical centre in the table frame; default the origin (on the axis).
        None fits orthogonal distances instead of ranges along the rays.
    max_incidence_deg : float
        Grazing returns beyond this incidence are excluded from the centre fits.
    seed : int
        RANSAC seed.
    progress : Progress, optional
        Told after each signed rate's sphere is fitted (`kinsync.progress`).
    roi_ned_m : sequence of 6 float, optional
        Region of interest ``(x_min, y_min, z_min, x_max, y_max, z_max)``, table-centred
        NED (m), bounds included: only the points inside it are segmented and fitted
        (the rate check sees all). ``roi`` of the result counts those left out.

    Returns
    -------
    SphereLatencyResult
        tau > 0: the navigation data lag the scanner (SPEC section 1). A pass with no
        usable sphere (fewer than `MIN_SPHERE_POINTS_PER_PASS` of its points on the
        sphere fitted at its rate) is left out and listed in ``rejected_passes``; a rate
        left with passes of one sign only is listed in ``unpaired_rates_deg_s``, and those
        passes in ``unpaired_passes``.

    Warns
    -----
    RatesUncheckedWarning
        Some passes' rates could not be checked (`SphereLatencyResult.rates_unchecked_text`).

    Raises
    ------
    InputError
        No passes (or items that are not SpherePass); a ``radius_m`` that is not a
        positive number; a ``scanner_origin_ned_m`` not 3 finite numbers; max_incidence_deg outside
        [`~kinsync.latency.planning.MIN_MAX_INCIDENCE_DEG`, 90); a pass whose points
        turn the other way than its stated rate, or
        more than twice as fast or slow (`kinsync.latency.rate_check`: a wrong sign,
        rates in rad/s, points in ENU); no rate with both signs; no rate whose passes
        of both signs hold a usable sphere; a malformed ``roi_ned_m``, or one that
        leaves a pass of at least `MIN_SPHERE_POINTS_PER_PASS` points with fewer
        (`kinsync.latency.roi.crop_passes`); centres that do not fit a rotation about
        the stated axis (`kinsync.latency.model_check`: a wrong axis in passes.csv,
        points not table-centred).
    ObservabilityError
        The rotation axis points at the sphere.
    """
    passes = pass_sequence(passes)
    if not passes:
        msg = "no passes given"
        raise InputError(msg)
    max_incidence_deg = checked_max_incidence_deg(max_incidence_deg)
    seed = seed_number(seed, "seed")
    radius_m = None if radius_m is None else positive_number(radius_m, "radius_m")
    if scanner_origin_ned_m is not None:
        scanner_origin_ned_m = _checked_origin(scanner_origin_ned_m)
    roi = None if roi_ned_m is None else checked_roi(roi_ned_m)
    n_rate_checked, n_unswept = rate_check_counts(check_distinct_passes(passes))
    crop = None
    if roi is not None:
        passes, crop = crop_passes(passes, roi, MIN_SPHERE_POINTS_PER_PASS)
    pairs, unpaired, alone = pair_groups(passes)
    fitted: list[tuple[PoolFit, PoolFit]] = []
    rejected: list[RejectedPass] = []
    failures: list[str] = []
    n_pools = 2 * len(pairs)
    for i, (plus_passes, minus_passes) in enumerate(pairs):
        fits = []
        for j, side in enumerate((plus_passes, minus_passes)):
            report(
                progress,
                (2 * i + j) / n_pools,
                f"fitting the sphere at {side[0].rate_deg_s:+g} deg/s "
                f"({2 * i + j + 1} of {n_pools})",
            )
            pool, lost, failure = _fit_pool_rejecting(
                side,
                radius_m,
                scanner_origin_ned_m,
                max_incidence_deg,
                seed,
                roi_given=crop is not None,
            )
            fits.append(pool)
            rejected += lost
            if failure is not None:
                failures.append(failure)
        plus, minus = fits
        if plus is None or minus is None:
            unpaired.append(abs(plus_passes[0].rate_deg_s))
            alone += left_without_partner(plus, plus_passes) + left_without_partner(
                minus, minus_passes
            )
            continue
        fitted.append((plus, minus))
    if not fitted:
        msg = (
            "no table rate has a usable sphere in passes of both signs ("
            + "; ".join(failures[:_FAILURES_SHOWN])
            + (
                f"; and {len(failures) - _FAILURES_SHOWN} more signed rates without one"
                if len(failures) > _FAILURES_SHOWN
                else ""
            )
            + ")"
        )
        raise InputError(msg)
    report(progress, 1.0, f"fitted {counted(n_pools, 'sphere')}")
    scatter, per_rate, model_chi2 = _latencies_with_pass_scatter(fitted)
    check_rotation_model(model_chi2, n_unswept)
    tau, formal_std, chi2, dof, p_value, scale = _combined(per_rate)
    centres = np.array([r.center_ned_m for r in per_rate])
    center = np.average(
        centres, axis=0, weights=1.0 / np.array([r.center_std_m**2 for r in per_rate])
    )
    radius = (
        float(radius_m)
        if radius_m is not None
        else float(np.mean([[r.plus.fit.radius_m, r.minus.fit.radius_m] for r in per_rate]))
    )
    warn_unchecked_rates(n_rate_checked, len(passes), n_unswept)  # as the CLI warns
    return SphereLatencyResult(
        latency_s=tau,
        latency_std_s=formal_std * scale,
        latency_formal_std_s=formal_std,
        sigma_scale=scale,
        per_rate=tuple(per_rate),
        sphere_center_ned_m=center,
        sphere_radius_m=radius,
        radius_fixed=radius_m is not None,
        chi2_between_rates=chi2,
        dof_between_rates=dof,
        p_value_between_rates=p_value,
        unpaired_rates_deg_s=tuple(sorted(unpaired)),
        n_passes=len(passes),
        rejected_passes=tuple(rejected),
        roi=crop,
        unpaired_passes=tuple(alone),
        n_passes_rate_checked=n_rate_checked,
        n_passes_unswept=n_unswept,
        pass_scatter=scatter,
    )
