"""Robust segmentation of a sphere from a cloud with clutter (floor, stand, walls).

`segment_sphere`: RANSAC on minimal 4-point spheres (solved in batches) drawn locally
(NAPSAC: three points near a random first one, so that clutter away from the sphere
hardly lowers the chance of an all-inlier sample), scored on a random subset then on
all points, hypotheses rejected by the known radius or radius bounds; then an
iteratively reweighted (Tukey biweight) refinement, an inlier threshold from a robust
scale (`kinsync.robust`), and a final least-squares `kinsync.fit.sphere.fit_sphere` on
the inliers, along the scanner rays when the scanner origin is known.

References
----------
Fischler, M. A. & Bolles, R. C., "Random sample consensus...", Communications of the
ACM 24(6), 1981, 381-395 (RANSAC).
Mosteller, F. & Tukey, J. W., *Data Analysis and Regression*, Addison-Wesley 1977
(biweight).
Myatt, D. R., Torr, P. H. S., Nasuto, S. J., Bishop, J. M., Craddock, R., "NAPSAC:
high noise, high dimensional robust estimation - it's in the bag", BMVC 2002 (local
sampling).
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass, replace

import numpy as np

from kinsync._typing import ArrayLike, BoolArray, FloatArray, IntArray
from kinsync.errors import ConvergenceError, InputError
from kinsync.fit.sphere import (
    _MIN_POINTS,
    SphereFit,
    _centred,
    _check_not_degenerate,
    _fit_local,
    _levenberg_marquardt,
    _LocalFit,
    _ortho_model,
    _ray_residuals_all,
    _validated_origin,
    _validated_points,
    _validated_radius,
)
from kinsync.robust import robust_sigma

__all__ = [
    "segment_sphere",
]

_MIN_INLIERS = 10
"""Fewest inliers `segment_sphere` accepts as a sphere."""


_PLANE_TO_SPHERE_RMS = 1.25
"""A segmented sphere must fit its inliers this much better (RMS) than a plane does."""


_FACE_CONE_SHARE = 0.8
"""Beams within this share of the sphere's apparent radius (seen from the scanner) are
the face the blocking check looks at; grazing beams near the rim, where a return may mix
the sphere's edge with what lies behind it, are left out."""


_MAX_BLOCKED_SHARE = 0.1
"""Most returns from inside a segmented sphere or in front of its face, as a share of
its inliers on that face."""


_BLOCKED_MARGIN = 2.0
"""A return counts as inside a segmented sphere or in front of it when it lies this many
inlier bands off its surface (the band is about 3 robust sigma of the distances to the
surface over the whole cap; noise on the face, met head-on, is larger)."""


_MIN_BLOCKED = 3
"""Fewest such returns that reject a segmented sphere (one or two may be strays)."""


_MIN_FACE_SHARE = 0.25
"""Least share of a segmented sphere's inliers on the central part of its face: a scanner
sampling evenly in angle puts about 0.64 (``_FACE_CONE_SHARE ** 2``) of the returns of a
sphere in full view there; a chance fit to surfaces cutting through a sphere's outline
puts its inliers along its rim."""


_TUKEY_C = 4.685


_HYPOTHESIS_BATCH = 256


_SUBSET_SIZE = 1024
"""Points each hypothesis is scored on first (a random subset)."""


_SAMPLE_POOL_SIZE = 2048
"""Most points minimal samples are drawn from (a random subset holding the scoring one)."""


_SAMPLES_PER_NEIGHBOURHOOD = 8
"""Minimal samples drawn around each random first point (local sampling)."""


_TOP_HYPOTHESES = 16


_RANSAC_CONFIDENCE = 0.999


_KNOWN_RADIUS_TOLERANCE = 0.2
"""Relative radius tolerance of a RANSAC hypothesis when the radius is known."""


_KNOWN_RADIUS_RATIO = 1.5
"""Largest ratio between the free-radius fit of the inliers and a known radius."""


def _minimal_spheres(quads: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Spheres through 4 points each, batched.

    Parameters
    ----------
    quads : ndarray, shape (H, 4, 3)
        Four points per hypothesis (centred coordinates, m).

    Returns
    -------
    centres : ndarray, shape (H, 3)
        NaN for degenerate (coplanar) quadruples.
    radii : ndarray, shape (H,)
    """
    p0 = quads[:, 0]
    q1, q2, q3 = (quads[:, k] - p0 for k in (1, 2, 3))
    c23, c31, c12 = np.cross(q2, q3), np.cross(q3, q1), np.cross(q1, q2)
    det = np.einsum("ij,ij->i", q1, c23)
    n1, n2, n3 = (np.einsum("ij,ij->i", q, q) for q in (q1, q2, q3))
    # Coplanar (or nearly): |det| tiny against the product of the edge lengths.
    scale = np.sqrt(n1 * n2 * n3)
    good = np.abs(det) > 1e-9 * scale
    safe_det = np.where(good, det, 1.0)
    rel = (0.5 * (n1[:, None] * c23 + n2[:, None] * c31 + n3[:, None] * c12)) / safe_det[:, None]
    rel[~good] = np.nan
    return p0 + rel, np.sqrt(np.einsum("ij,ij->i", rel, rel))


def _hypothesis_residuals(
    xc_sub: FloatArray, sq_sub: FloatArray, centres: FloatArray, radii: FloatArray
) -> FloatArray:
    """|distance - radius| of (3, S) points to H spheres, shape (H, S)."""
    # In place: with all points (top hypotheses x N) the temporaries dominate.
    res: FloatArray = centres @ xc_sub
    res *= -2.0
    res += sq_sub[None, :]
    res += np.einsum("ij,ij->i", centres, centres)[:, None]
    np.maximum(res, 0.0, out=res)
    np.sqrt(res, out=res)
    res -= radii[:, None]
    np.abs(res, out=res)
    return res


@dataclass(frozen=True)
class _Hypothesis:
    centre: FloatArray
    radius: float
    n_inliers: int
    tried: int
    admissible: int


def _local_samples(
    pool: FloatArray, sq_pool: FloatArray, rng: np.random.Generator, n_first: int, reach: float
) -> IntArray:
    """Minimal samples drawn locally (NAPSAC): a random first point, three near it.

    Each first point gets `_SAMPLES_PER_NEIGHBOURHOOD` samples whose other three points
    are drawn (with replacement) among the pool's points within ``reach`` of it. First
    points with fewer than three neighbours give none.

    Parameters
    ----------
    pool : ndarray, shape (3, M)
        Points samples are drawn from (centred coordinates, m).
    sq_pool : ndarray, shape (M,)
        Their squared norms (m^2).
    rng : numpy.random.Generator
    n_first : int
        First points to draw.
    reach : float
        Neighbourhood radius (m).

    Returns
    -------
    ndarray of int, shape (H, 4)
        Indices into the pool; ``H <= n_first * _SAMPLES_PER_NEIGHBOURHOOD``; the first
        column is the first point. Samples may repeat a point (see `_distinct`).
    """
    m_pool = pool.shape[1]
    first = rng.integers(0, m_pool, size=n_first)
    d2 = sq_pool[first][:, None] + sq_pool[None, :] - 2.0 * (pool.T[first] @ pool)
    near = d2 <= reach * reach
    near[np.arange(n_first), first] = False
    cums = np.cumsum(near, axis=1, dtype=np.int32)
    counts = cums[:, -1]
    # The k-th neighbour (1-based) of row i is the first column where cums reaches k:
    # one searchsorted over the rows laid end to end (offset so they stay sorted).
    per = _SAMPLES_PER_NEIGHBOURHOOD
    ranks = np.floor(rng.random((n_first, per, 3)) * counts[:, None, None]).astype(np.int64) + 1
    offset = (np.arange(n_first, dtype=np.int64) * (m_pool + 1))[:, None, None]
    flat = np.searchsorted((cums + offset[:, :, 0]).ravel(), (ranks + offset).ravel())
    others = flat.reshape(n_first, per, 3) - (np.arange(n_first) * m_pool)[:, None, None]
    quads = np.concatenate(
        [np.broadcast_to(first[:, None, None], (n_first, per, 1)), others], axis=2
    )
    return quads[counts >= 3].reshape(-1, 4)


def _distinct(idx: IntArray) -> IntArray:
    """The rows of an (H, 4) index array whose four indices differ."""
    keep = (
        (idx[:, 0] != idx[:, 1])
        & (idx[:, 0] != idx[:, 2])
        & (idx[:, 0] != idx[:, 3])
        & (idx[:, 1] != idx[:, 2])
        & (idx[:, 1] != idx[:, 3])
        & (idx[:, 2] != idx[:, 3])
    )
    kept: IntArray = idx[keep]
    return kept


def _samples_needed(xc_sub: FloatArray, sq_sub: FloatArray, inlier: BoolArray, reach: float) -> int:
    """Samples to draw for `_RANSAC_CONFIDENCE` of one all-inlier sample (local sampling).

    A sample is all-inlier when its first point is an inlier and so are its three
    others, drawn among the points within ``reach`` of it: from the inlier point ``p``,
    each with probability ``lam_p``, the share of inliers among the points near it. The
    chance of at least one all-inlier sample in a neighbourhood's
    `_SAMPLES_PER_NEIGHBOURHOOD` is averaged over the first points (the scoring subset).
    """
    n_sub = xc_sub.shape[1]
    d2 = sq_sub[inlier][:, None] + sq_sub[None, :] - 2.0 * (xc_sub[:, inlier].T @ xc_sub)
    near = d2 <= reach * reach
    n_near = near.sum(axis=1) - 1  # not the point itself
    n_in_near = near[:, inlier].sum(axis=1) - 1
    lam = np.clip(n_in_near / np.maximum(n_near, 1), 0.0, 1.0)
    per = _SAMPLES_PER_NEIGHBOURHOOD
    p_group = float((1.0 - (1.0 - lam**3) ** per).sum()) / n_sub
    if p_group >= 1.0:
        return 0
    if p_group <= 0.0:
        return sys.maxsize
    groups = math.ceil(math.log(1.0 - _RANSAC_CONFIDENCE) / math.log1p(-p_group))
    return per * groups


def _ransac(
    xc: FloatArray,
    rng: np.random.Generator,
    radius_lo: float,
    radius_hi: float,
    threshold: float,
    max_hypotheses: int,
) -> _Hypothesis | None:
    """Best sphere hypothesis by MSAC score (subset, then all points) or None.

    Minimal samples are drawn locally (`_local_samples`, within ``2 (radius_hi +
    threshold)`` of a random first point) from a random pool of up to
    `_SAMPLE_POOL_SIZE` points, so that clutter away from the sphere (floor, walls)
    hardly lowers the chance of an all-inlier sample.
    """
    n = xc.shape[1]
    pool_idx = rng.choice(n, size=min(n, _SAMPLE_POOL_SIZE), replace=False)
    pool = xc[:, pool_idx]
    sq_pool = np.einsum("ij,ij->j", pool, pool)
    # The pool is in random order: its head is a random scoring subset.
    n_sub = min(n, _SUBSET_SIZE)
    xc_sub = pool[:, :n_sub]
    sq_sub = sq_pool[:n_sub]
    reach = 2.0 * (radius_hi + threshold)
    t2 = threshold * threshold
    kept_c: list[FloatArray] = []
    kept_r: list[FloatArray] = []
    kept_score: list[FloatArray] = []
    tried = 0
    admissible = 0
    best_ratio = 0.0
    needed = max_hypotheses
    n_first = _HYPOTHESIS_BATCH // _SAMPLES_PER_NEIGHBOURHOOD
    while tried < min(needed, max_hypotheses):
        batch = min(n_first, -(-(max_hypotheses - tried) // _SAMPLES_PER_NEIGHBOURHOOD))
        idx = _local_samples(pool, sq_pool, rng, batch, reach)
        tried += batch * _SAMPLES_PER_NEIGHBOURHOOD
        idx = _distinct(idx)
        centres, radii = _minimal_spheres(pool.T[idx])
        ok = np.isfinite(radii) & (radii >= radius_lo) & (radii <= radius_hi)
        if not ok.any():
            continue
        centres, radii = centres[ok], radii[ok]
        admissible += len(radii)
        res = _hypothesis_residuals(xc_sub, sq_sub, centres, radii)
        score = np.minimum(res * res, t2).sum(axis=1)
        kept_c.append(centres)
        kept_r.append(radii)
        kept_score.append(score)
        inliers = res < threshold
        n_in = inliers.sum(axis=1)
        k = int(np.argmax(n_in))
        ratio = float(n_in[k]) / n_sub
        if ratio > best_ratio:
            best_ratio = ratio
            needed = _samples_needed(xc_sub, sq_sub, inliers[k], reach)
    if not kept_c:
        return None
    centres = np.concatenate(kept_c)
    radii = np.concatenate(kept_r)
    top = np.argsort(np.concatenate(kept_score), kind="stable")[:_TOP_HYPOTHESES]
    k, n_inliers = _best_on_all(xc, centres[top], radii[top], threshold)
    return _Hypothesis(
        centre=centres[top[k]],
        radius=float(radii[top[k]]),
        n_inliers=n_inliers,
        tried=tried,
        admissible=admissible,
    )


def _best_on_all(
    xc: FloatArray, centres: FloatArray, radii: FloatArray, threshold: float
) -> tuple[int, int]:
    """Index of the hypothesis with the best MSAC score on all points, and its inliers.

    Parameters
    ----------
    xc : ndarray, shape (3, N)
        All points (centred coordinates, m).
    centres : ndarray, shape (H, 3)
    radii : ndarray, shape (H,)
        Hypotheses (m).
    threshold : float
        Inlier threshold and truncation of the squared residual (m).
    """
    sq_all = np.einsum("ij,ij->j", xc, xc)
    res_all = _hypothesis_residuals(xc, sq_all, centres, radii)
    n_inliers_all = (res_all < threshold).sum(axis=1)
    np.square(res_all, out=res_all)
    np.minimum(res_all, threshold * threshold, out=res_all)
    k = int(np.argmin(res_all.sum(axis=1)))
    return k, int(n_inliers_all[k])


def _robust_sigma(abs_res: FloatArray, band: float, floor: float) -> float:
    """1.4826 x median |r| of the residuals inside the band (floored); band/3 if too few."""
    inside = abs_res[abs_res < band]
    if inside.size < _MIN_INLIERS:
        return max(band / 3.0, floor)
    return max(robust_sigma(inside), floor)


def _irls_tukey(
    xc: FloatArray,
    p0: FloatArray,
    radius_fixed: float | None,
    band0: float,
    sigma_fixed: float | None,
    floor: float,
) -> tuple[FloatArray, float]:
    """Tukey-biweight IRLS on the orthogonal residual; returns parameters and sigma."""
    res_fn, jac_fn = _ortho_model(xc, radius_fixed)
    p = p0.copy()
    e, _ = res_fn(p)
    abs_e = np.abs(e)
    band = band0
    sigma = sigma_fixed if sigma_fixed is not None else _robust_sigma(abs_e, band, floor)
    for _ in range(20):
        c = _TUKEY_C * sigma
        u = e / c
        w = np.where(np.abs(u) < 1.0, (1.0 - u * u) ** 2, 0.0)
        if int((w > 0.0).sum()) < _MIN_POINTS:
            break
        lm = _levenberg_marquardt(res_fn, jac_fn, p, w, 5, 1e-3 * sigma)
        step = float(np.linalg.norm(lm.params - p))
        p, e = lm.params, lm.residuals
        abs_e = np.abs(e)
        if sigma_fixed is None:
            sigma = _robust_sigma(abs_e, 3.0 * sigma, floor)
        if step < 1e-3 * sigma:
            break
    return p, sigma


def _plane_rms(xc: FloatArray) -> float:
    centred = xc - xc.mean(axis=1, keepdims=True)
    eig = np.linalg.eigvalsh((centred @ centred.T) / xc.shape[1])
    return float(np.sqrt(max(eig[0], 0.0)))


def _fit_inliers(
    xc: FloatArray,
    mask: BoolArray,
    p: FloatArray,
    radius_fixed: float | None,
    origin_local: FloatArray | None,
    what: str,
) -> tuple[_LocalFit, BoolArray]:
    """Least squares on the masked points, recentred on them for conditioning.

    Returns the fit (centre in the coordinates of ``xc``) and the mask, into all
    points, of those used in it.
    """
    sub = np.ascontiguousarray(xc[:, mask])
    sub_ref = sub.mean(axis=1)
    sub -= sub_ref[:, None]
    p_start = p.copy()
    p_start[:3] -= sub_ref
    origin_sub = None if origin_local is None else origin_local - sub_ref
    fit = _fit_local(sub, radius_fixed, origin_sub, 50, 1e-10, what, p0=p_start)
    used = np.zeros(xc.shape[1], dtype=bool)
    used[np.flatnonzero(mask)[fit.used]] = True
    return replace(fit, centre=fit.centre + sub_ref), used


@dataclass(frozen=True)
class _RadiusWindow:
    lo: float  # admissible hypothesis radii (m)
    hi: float
    reference: float  # radius scale for the default threshold and floors (m)
    text: str  # for messages


def _check_segment_options(
    radius: float | None,
    radius_bounds_m: tuple[float, float] | None,
    inlier_threshold_m: float | None,
    max_hypotheses: int,
) -> None:
    what = "segment_sphere"
    if radius is not None and radius_bounds_m is not None:
        msg = f"{what}: give radius_m or radius_bounds_m, not both"
        raise InputError(msg)
    if max_hypotheses < 1:
        msg = f"{what}: max_hypotheses must be >= 1, got {max_hypotheses}"
        raise InputError(msg)
    if inlier_threshold_m is not None and not (
        math.isfinite(inlier_threshold_m) and inlier_threshold_m > 0.0
    ):
        msg = f"{what}: inlier_threshold_m must be finite and > 0 (m), got {inlier_threshold_m!r}"
        raise InputError(msg)


def _radius_window(
    radius: float | None, radius_bounds_m: tuple[float, float] | None, diagonal_m: float
) -> _RadiusWindow:
    if radius is not None:
        return _RadiusWindow(
            radius * (1.0 - _KNOWN_RADIUS_TOLERANCE),
            radius * (1.0 + _KNOWN_RADIUS_TOLERANCE),
            radius,
            f"radius {radius:g} m",
        )
    if radius_bounds_m is None:
        return _RadiusWindow(0.0, diagonal_m, 0.2 * diagonal_m, "any radius")
    try:
        lo, hi = (float(v) for v in radius_bounds_m)
    except (TypeError, ValueError) as err:
        msg = f"segment_sphere: radius_bounds_m must be (min, max) in m, got {radius_bounds_m!r}"
        raise InputError(msg) from err
    if not (math.isfinite(lo) and math.isfinite(hi) and 0.0 < lo < hi):
        msg = (
            "segment_sphere: radius_bounds_m must satisfy 0 < min < max (m), got "
            f"{radius_bounds_m!r}"
        )
        raise InputError(msg)
    return _RadiusWindow(lo, hi, math.sqrt(lo * hi), f"radius {lo:g}-{hi:g} m")


def _hypothesis_start(
    xc: FloatArray, hyp: _Hypothesis, radius: float | None, threshold: float
) -> FloatArray:
    """Start parameters from a hypothesis; for a known radius, moved along the cap axis.

    The centre moves along the mean direction of the hypothesis' inliers by the radius
    difference, so that the known radius fits where the hypothesis did.
    """
    if radius is None:
        return np.append(hyp.centre, hyp.radius)
    diff = xc - hyp.centre[:, None]
    dist = np.sqrt(np.einsum("ij,ij->j", diff, diff))
    near = np.abs(dist - hyp.radius) < threshold
    mean_dir = (diff[:, near] / dist[near]).mean(axis=1)
    start: FloatArray = hyp.centre + (hyp.radius - radius) * mean_dir
    return start


def _fit_until_stable(
    xc: FloatArray,
    p: FloatArray,
    radius: float | None,
    origin_local: FloatArray | None,
    threshold: float,
    nothing: str,
    hyp: _Hypothesis,
) -> tuple[_LocalFit, BoolArray, FloatArray]:
    """Least squares on |r| <= threshold, repeated until the inliers stop changing.

    Returns the last fit, the mask of the points it used and the orthogonal residuals
    of every point to it.
    """
    res_fn, _ = _ortho_model(xc, radius)
    e_orth, _ = res_fn(p)
    inliers = np.abs(e_orth) <= threshold
    fitted: tuple[_LocalFit, BoolArray] | None = None
    for _ in range(3):
        if int(inliers.sum()) < _MIN_INLIERS:
            break
        try:
            fitted = _fit_inliers(xc, inliers, p, radius, origin_local, "segment_sphere")
        except ConvergenceError as err:
            msg = (
                f"{nothing}: the {int(inliers.sum())} inliers of the best hypothesis "
                f"(radius {hyp.radius:.4g} m) do not converge to a sphere ({err})"
            )
            raise InputError(msg) from err
        p = fitted[0].params if radius is None else fitted[0].centre
        e_orth, _ = res_fn(p)
        new_inliers = np.abs(e_orth) <= threshold
        if np.array_equal(new_inliers, inliers):
            break
        inliers = new_inliers
    if fitted is None:
        msg = (
            f"{nothing}: best hypothesis had {hyp.n_inliers} inliers, "
            f"{int(inliers.sum())} after robust refinement (threshold {threshold:.3g} m); "
            f"at least {_MIN_INLIERS} are needed"
        )
        raise InputError(msg)
    return fitted[0], fitted[1], e_orth


def _check_is_sphere(
    xc: FloatArray,
    fit: _LocalFit,
    used: BoolArray,
    e_orth: FloatArray,
    radius: float | None,
    window: _RadiusWindow,
    nothing: str,
) -> None:
    """Reject a candidate that is not a sphere of the requested size."""
    k = int(used.sum())
    if radius is None and not window.lo <= fit.radius <= window.hi:
        msg = f"{nothing}: the best candidate ({k} inliers) has radius {fit.radius:.4g} m"
        raise InputError(msg)
    sphere_rms = float(np.sqrt(np.mean(e_orth[used] ** 2)))
    plane_rms = _plane_rms(xc[:, used])
    if plane_rms < _PLANE_TO_SPHERE_RMS * sphere_rms:
        msg = (
            f"{nothing}: the best candidate's {k} inliers fit a plane about as well as a "
            f"sphere (plane RMS {plane_rms * 1e3:.3g} mm, sphere RMS {sphere_rms * 1e3:.3g} "
            f"mm, radius {fit.radius:.4g} m); check the radius or the region of interest"
        )
        raise InputError(msg)
    if radius is None:
        return
    try:
        free = _fit_inliers(xc, used, np.append(fit.centre, radius), None, None, "segment_sphere")[
            0
        ]
    except ConvergenceError as err:
        msg = f"{nothing}: the best candidate's {k} inliers do not converge to a free sphere"
        raise InputError(msg) from err
    if not 1.0 / _KNOWN_RADIUS_RATIO <= free.radius / radius <= _KNOWN_RADIUS_RATIO:
        msg = (
            f"{nothing}: the best candidate's {k} inliers fit a sphere of radius "
            f"{free.radius:.4g} m (RMS {free.rms * 1e3:.3g} mm, against {fit.rms * 1e3:.3g} "
            "mm with the given radius); check radius_m (a diameter?)"
        )
        raise InputError(msg)


def _check_seen_as_solid(
    xc: FloatArray,
    fit: _LocalFit,
    origin_local: FloatArray,
    threshold: float,
    nothing: str,
    ref: FloatArray,
) -> None:
    """Reject a candidate that does not look like a solid sphere seen from the scanner.

    A scanner sampling evenly in angle puts about ``_FACE_CONE_SHARE ** 2`` of a
    sphere's returns on the central part of its face (the beams within
    `_FACE_CONE_SHARE` of its apparent radius); fewer than `_MIN_FACE_SHARE` of the
    points within ``threshold`` of the candidate there mean its inliers lie along its
    rim, where other surfaces cut through it. And a solid sphere stops every beam that
    meets its face: the returns on those beams must lie on it or behind it. Returns
    inside it or in front of it (more than `_BLOCKED_MARGIN` bands off its surface),
    at least `_MIN_BLOCKED` and more than `_MAX_BLOCKED_SHARE` of those on the face,
    mean a chance fit to surfaces that cut through it, such as the edge or corner where
    a floor meets a wall. Returns behind it are allowed: a pooled pass in which the
    sphere was not in view sees what lies behind it.

    Parameters
    ----------
    xc : ndarray, shape (3, N)
        All points (centred coordinates, m).
    fit : _LocalFit
        The candidate (centre in the same coordinates, radius in m).
    origin_local : ndarray, shape (3,)
        Scanner origin (centred coordinates, m).
    threshold : float
        Inlier band (m): returns within it of the surface are on the sphere.
    nothing : str
        Start of the message.
    ref : ndarray, shape (3,)
        Offset of the centred coordinates (m), for the message.
    """
    to_centre = fit.centre - origin_local
    d = float(np.linalg.norm(to_centre))
    rays = xc - origin_local[:, None]
    ranges = np.sqrt(np.einsum("ij,ij->j", rays, rays))
    along = (to_centre @ rays) / np.maximum(ranges, np.finfo(float).tiny)  # b = u . (c - o)
    sin_cone = _FACE_CONE_SHARE * fit.radius / d
    on_face = along >= d * math.sqrt(max(1.0 - sin_cone * sin_cone, 0.0))
    diff = xc - fit.centre[:, None]
    dist = np.sqrt(np.einsum("ij,ij->j", diff, diff))
    near_range = along - np.sqrt(np.maximum(along * along - d * d + fit.radius**2, 0.0))
    on = on_face & (np.abs(dist - fit.radius) <= threshold)
    margin = _BLOCKED_MARGIN * threshold
    inside = on_face & (dist < fit.radius - margin)
    in_front = on_face & (dist > fit.radius + margin) & (ranges < near_range)
    n_on, n_inside, n_front = int(on.sum()), int(inside.sum()), int(in_front.sum())
    n_band = int((np.abs(dist - fit.radius) <= threshold).sum())
    where = (
        f"the best candidate (centre {(ref + fit.centre).round(3).tolist()}, radius "
        f"{fit.radius:.4g} m, {n_band} points within {threshold:.3g} m of it)"
    )
    if n_on < _MIN_FACE_SHARE * n_band:
        msg = (
            f"{nothing}: {where} is no sphere seen from origin_m: of those points only "
            f"{n_on} {'lies' if n_on == 1 else 'lie'} on the central part of its face (a "
            f"sphere in view puts about {_FACE_CONE_SHARE**2:.0%} of its returns there), the "
            "rest near its rim or on its far side, where surfaces such as a floor and a wall "
            "may cut through it; check the radius or the region of interest"
        )
        raise InputError(msg)
    n_blocked = n_inside + n_front
    if n_blocked < _MIN_BLOCKED or n_blocked <= _MAX_BLOCKED_SHARE * n_on:
        return
    msg = (
        f"{nothing}: {where} is no solid sphere: of the returns on beams through the "
        f"central part of its face as seen from origin_m, {n_on} lie on it but "
        f"{n_inside} inside it and {n_front} in front of it, where a sphere "
        "would have stopped the beam (a chance fit to where surfaces such as a floor and "
        "a wall meet); check the radius or the region of interest"
    )
    raise InputError(msg)


def segment_sphere(
    points_m: ArrayLike,
    *,
    radius_m: float | None = None,
    radius_bounds_m: tuple[float, float] | None = None,
    inlier_threshold_m: float | None = None,
    origin_m: ArrayLike | None = None,
    max_hypotheses: int = 20000,
    seed: int = 0,
) -> SphereFit:
    """Find a sphere in a cluttered cloud and fit it (RANSAC, robust refinement, LSQ).

    1. RANSAC: minimal spheres through 4 points, solved in batches, drawn from a
       random pool of up to 2048 points: a random first point and three among the
       points within twice the largest admissible radius (plus the inlier band) of it
       (NAPSAC), 8 samples
       per first point; hypotheses whose radius is off the known radius (by more than
       20 %) or outside ``radius_bounds_m`` are rejected; the rest are scored (MSAC,
       truncated squared residual) on a random subset of up to 1024 points, the best
       16 again on all points. Sampling stops once 99.9 % confidence of an all-inlier
       sample is reached (from the best hypothesis' inlier share near each of its
       inliers), or after ``max_hypotheses``.
    2. Refinement: iteratively reweighted least squares with Tukey's biweight
       (``c = 4.685 sigma``), ``sigma = 1.4826 MAD`` of the residuals near the sphere.
    3. Inliers: ``|r| <= inlier_threshold_m``, by default ``3 sigma`` (with a floor of
       1e-6 of the radius); final least squares `fit_sphere` on the inliers (ray
       model with ``origin_m``), repeated until the inlier set is stable (3 rounds at
       most).
    4. Checks: at least 10 inliers; the inliers must fit a sphere clearly better
       (RMS at least 1.25 x smaller) than a plane; a free radius must lie within
       ``radius_bounds_m``; with a known radius, a free-radius fit of the inliers must
       lie within a factor 1.5 of it (catches a diameter given as a radius). With
       ``origin_m``, the candidate must look like a solid sphere seen from there: at
       least a quarter of the points within the band of it on the central part of
       its face (the beams within 0.8 of its apparent radius; about 64 % for a
       sphere in full view); and of the returns on those beams, those inside it or
       in front of it, where a sphere would have stopped the beam, must be fewer
       than 3 or at most 10 % as many as those on it (returns behind it are allowed:
       a pooled pass may not have had the sphere in view). This refuses chance fits
       to the edge or corner where a floor meets a wall. Else no sphere was found.

    Parameters
    ----------
    points_m : array_like, shape (N, 3)
        Cloud (m), any Cartesian frame, with clutter (floor, stand, strays). N >= 4.
    radius_m : float, optional
        Known radius (m); the final fit keeps it fixed.
    radius_bounds_m : tuple of float, optional
        ``(min, max)`` radius (m) of an admissible sphere when the radius is free.
        Without either, hypotheses larger than the cloud's bounding-box diagonal are
        rejected.
    inlier_threshold_m : float, optional
        Largest |orthogonal residual| (m) of an inlier. Default from a robust scale.
    origin_m : array_like, shape (3,), optional
        Scanner origin (m), same frame; the final fit uses the ray model.
    max_hypotheses : int
        Most minimal samples drawn (reached only when no hypothesis reaches the
        confidence: a pool without a clear sphere).
    seed : int
        Seed of the random generator (results are reproducible).

    Returns
    -------
    SphereFit
        ``inliers`` and ``residuals_m`` refer to every point given.

    Raises
    ------
    InputError
        Bad input (shape, NaN, radius, bounds, threshold), degenerate cloud, or no
        sphere found (message gives the best hypothesis and its inlier count).
    ConvergenceError
        The final least-squares fit did not converge.

    References
    ----------
    Fischler & Bolles 1981 (RANSAC); Torr & Zisserman, "MLESAC", CVIU 78, 2000
    (truncated-quadratic scoring); Al-Sharadqah & Chernov 2009; Seube et al. 2012.
    """
    what = "segment_sphere"
    pts = _validated_points(points_m, what)
    radius = _validated_radius(radius_m, what)
    origin = _validated_origin(origin_m, what)
    _check_segment_options(radius, radius_bounds_m, inlier_threshold_m, max_hypotheses)
    n = pts.shape[0]
    ref, xc = _centred(pts)
    spread = _check_not_degenerate(xc, what)
    window = _radius_window(radius, radius_bounds_m, float(np.linalg.norm(np.ptp(xc, axis=1))))
    nothing = f"{what}: no sphere of {window.text} found among {n} points"
    threshold0 = inlier_threshold_m if inlier_threshold_m is not None else 0.05 * window.reference
    hyp = _ransac(xc, np.random.default_rng(seed), window.lo, window.hi, threshold0, max_hypotheses)
    if hyp is None:
        msg = (
            f"{nothing}: none of the {max_hypotheses} minimal samples gave an admissible "
            f"sphere (cloud spread {spread:.3g} m); check the radius or the region of interest"
        )
        raise InputError(msg)
    if hyp.n_inliers < _MIN_INLIERS:
        msg = (
            f"{nothing}: best hypothesis had {hyp.n_inliers} inliers within "
            f"{threshold0:.3g} m (centre {(ref + hyp.centre).round(4).tolist()}, radius "
            f"{hyp.radius:.4g} m; {hyp.admissible} admissible of {hyp.tried} samples); at "
            f"least {_MIN_INLIERS} are needed"
        )
        raise InputError(msg)

    p0 = _hypothesis_start(xc, hyp, radius, threshold0)
    sigma_fixed = None if inlier_threshold_m is None else inlier_threshold_m / 3.0
    p, sigma = _irls_tukey(xc, p0, radius, threshold0, sigma_fixed, 1e-6 * window.reference)
    threshold = inlier_threshold_m if inlier_threshold_m is not None else 3.0 * sigma
    origin_local = None if origin is None else origin - ref
    fit, used, e_orth = _fit_until_stable(xc, p, radius, origin_local, threshold, nothing, hyp)
    _check_is_sphere(xc, fit, used, e_orth, radius, window, nothing)
    if origin_local is not None:
        _check_seen_as_solid(xc, fit, origin_local, threshold, nothing, ref)
    if fit.method == "ray":
        assert origin_local is not None
        residuals, _, _ = _ray_residuals_all(xc, origin_local, fit.centre, fit.radius)
    else:
        residuals = e_orth
    return fit.sphere_fit(ref, used, residuals, radius_fixed=radius is not None)
