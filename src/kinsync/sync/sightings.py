"""Method B step 2, scanner time: where the bright sync targets appear in the scan.

Bright returns are clustered in (profile, angle, range) space; each cluster's
sub-profile position comes from a sphere fit (the targets are retro-reflective
spheres) or, where that cannot be made, an intensity-weighted centroid (see
`kinsync.sync.object_space` for the whole method).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from kinsync._typing import FloatArray, IntArray
from kinsync.errors import ObservabilityError
from kinsync.sync.config import ObjectSpaceConfig
from kinsync.sync.crossings import PointTrack
from kinsync.sync.scan import PROFILE_SCANNER_REACH_M, ProfileScan, long_range_note

__all__ = [
    "Sighting",
    "detect_clusters",
    "detect_sightings",
    "refine_sighting",
    "require_two_sightings",
]


@dataclass(frozen=True)
class Sighting:
    """A retro-reflective target seen in the scan's intensity image.

    Attributes
    ----------
    profile : float
        Sub-profile number n_P at which the scan plane passes through the target.
    angle_rad : float
        Mirror angle phi_P of the target centre (rad).
    range_m : float
        Range of the target centre (sphere fit) or median range of the returns
        (centroid) (m).
    n_returns : int
        Returns in the cluster.
    first_profile, last_profile : int
        Profile span of the cluster.
    profile_std : float
        A-priori sigma of ``n_P`` (profiles).
    refinement : {"sphere", "centroid"}
        How ``n_P`` was refined.
    """

    profile: float
    angle_rad: float
    range_m: float
    n_returns: int
    first_profile: int
    last_profile: int
    profile_std: float
    refinement: str

    @property
    def x(self) -> float:
        """Clock abscissa ``n_P + phi_P / 2 pi`` (profiles)."""
        return self.profile + self.angle_rad / math.tau


def _sphere_refine(
    prof: FloatArray,
    ang: FloatArray,
    rng_m: FloatArray,
    cfg: ObjectSpaceConfig,
    track: PointTrack | None = None,
    period_s: float | None = None,
) -> tuple[float, float, float, float] | None:
    """Sphere fit of one cluster: ``(x_P, phi_P, centre range, sigma of x_P)`` or None.

    Each return, at profile-plane coordinates ``(y, z)`` and abscissa x, lies on the
    sphere (module step 2). Without ``track`` the centre is taken to stay at ``(y_c,
    z_c)`` while the plane sweeps it at s m per profile: ``(s (x - x_P), y - y_c, z -
    z_c)`` has length R, and ``(x_P, y_c, z_c, R, s)`` are fitted by Levenberg-Marquardt
    (detection). With a candidate crossing's ``track`` the target moves as the
    trajectory says: at ``tau = (x - x_P) T`` from the crossing the centre is
    ``d_P(tau)`` off the plane and at ``(y_c, z_c) + (dy, dz)(tau)`` within it. With
    ``period_s`` T is that (the matched clock's), four unknowns; without it T is
    ``period_prior_s`` times a fitted scale (> 0), so that a prior a few per cent off
    does not bend the fit.

    The drift matters: a plane slanted by ``[profiler] azimuth_deg`` az moves over the
    point by ``tan(az)`` of its sweep, and the scanner slides sideways and the sweep
    slows in a turn. Only the cap facing the scanner is seen, and a fit without the
    drift puts x_P where that cap is nearest: 0.3 profile off at 10 deg, up to 1 at 20
    deg and 2 at 35 deg (2 m/s, 0.15 m spheres, 33 rev/s), 1.2 to 1.7 where a turn
    swept the target at 0.4 m/s.
    """
    if prof.size < max(cfg.sphere_min_returns, 6) or np.unique(prof).size < 3:
        return None
    x = prof + ang / math.tau
    y = rng_m * np.sin(ang)
    z = rng_m * np.cos(ang)
    span = float(np.ptp(prof)) + 1.0
    radius0 = max(0.5 * float(np.hypot(np.ptp(y), np.ptp(z))), 0.01)
    mean_yz = np.array([np.mean(y), np.mean(z)])
    dist0 = max(float(np.linalg.norm(mean_yz)), 1e-6)
    centre0 = mean_yz * (1.0 + 0.7 * radius0 / dist0)
    p0 = [float(np.mean(x)), centre0[0], centre0[1], radius0]
    if track is None:
        p0.append(2.0 * radius0 / span)  # sweep, m per profile
    elif period_s is None:
        p0.append(1.0)  # scale of the prior period

    def residuals(p: FloatArray) -> FloatArray:
        dx = x - p[0]
        if track is None:
            d, dy, dz = p[4] * dx, 0.0, 0.0
        else:
            d, dy, dz = track.at(dx * (period_s or cfg.period_prior_s * p[4]))
        out: FloatArray = np.sqrt(d**2 + (y - p[1] - dy) ** 2 + (z - p[2] - dz) ** 2) - p[3]
        return out

    def jacobian(p: FloatArray) -> FloatArray:
        """Of `residuals` along a track: d/dtau of the distance via the track's rates."""
        assert track is not None
        dx = x - p[0]
        period = period_s or cfg.period_prior_s * p[4]
        tau = dx * period
        d, dy, dz = track.at(tau)
        rate = track.rate_at(tau)
        e_y, e_z = y - p[1] - dy, z - p[2] - dz
        length = np.maximum(np.sqrt(d**2 + e_y**2 + e_z**2), 1e-12)
        along = (d * rate[0] - e_y * rate[1] - e_z * rate[2]) / length  # d length / d tau
        cols = [-along * period, -e_y / length, -e_z / length, -np.ones_like(x)]
        if period_s is None:
            cols.append(along * dx * cfg.period_prior_s)
        return np.column_stack(cols)

    n_par = len(p0)
    try:
        sol = least_squares(
            residuals,
            np.array(p0),
            jac="2-point" if track is None else jacobian,
            method="lm",
            x_scale="jac",
        )
        jac = np.asarray(sol.jac, dtype=np.float64)
        cov = np.linalg.inv(jac.T @ jac) * float(np.sum(sol.fun**2)) / (prof.size - n_par)
    except (ValueError, np.linalg.LinAlgError):
        return None
    x_p, y_c, z_c, radius = (float(v) for v in sol.x[:4])
    std_x = float(np.sqrt(max(cov[0, 0], 0.0)))
    plausible = (
        sol.success
        and 0.0 < radius < 5.0 * radius0 + 0.05
        and (n_par == 4 or (float(sol.x[4]) > 0.0 if track else float(sol.x[4]) != 0.0))
        and float(x.min()) - 0.5 <= x_p <= float(x.max()) + 0.5
        and math.isfinite(std_x)
    )
    if not plausible:
        return None
    return x_p, math.atan2(y_c, z_c), math.hypot(y_c, z_c), std_x


def _clusters(scan: ProfileScan, cfg: ObjectSpaceConfig) -> list[IntArray]:
    """Indices into the scan of each bright cluster with at least ``min_returns`` returns."""
    bright = np.flatnonzero(scan.intensity >= cfg.intensity_threshold)
    if bright.size == 0:
        return []
    scaled = np.column_stack(
        [
            scan.profile[bright] / cfg.cluster_gap_profiles,
            scan.angle_rad[bright] / cfg.cluster_gap_rad,
            scan.range_m[bright] / cfg.cluster_gap_m,
        ]
    )
    pairs = cKDTree(scaled).query_pairs(1.0, p=np.inf, output_type="ndarray")
    n = bright.size
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, labels = connected_components(graph, directed=False)
    order = np.argsort(labels, kind="stable")
    groups = np.split(order, np.flatnonzero(np.diff(labels[order])) + 1)
    return [bright[g].astype(np.int64) for g in groups if g.size >= cfg.min_returns]


def refine_sighting(
    scan: ProfileScan,
    idx: IntArray,
    cfg: ObjectSpaceConfig,
    track: PointTrack | None = None,
    period_s: float | None = None,
) -> Sighting:
    """Refine one cluster: sphere fit, or the intensity-weighted centroid as fallback.

    Parameters
    ----------
    scan : ProfileScan
    idx : ndarray of int, shape (k,)
        The cluster's returns (indices into ``scan``).
    cfg : ObjectSpaceConfig
        Refinement settings.
    track : PointTrack, optional
        A candidate crossing's motion of the target relative to the scan plane
        (`kinsync.sync.crossings.Crossing.point_track`); without it the target is
        taken to stand still in the plane, swept at a constant, fitted rate.
    period_s : float, optional
        The mirror period (s) that times the returns along ``track``; without it
        ``period_prior_s`` times a fitted scale. Ignored without ``track``.

    Returns
    -------
    Sighting
    """
    prof = scan.profile[idx].astype(np.float64)
    ang = scan.angle_rad[idx]
    rng_m = scan.range_m[idx]
    first, last = int(prof.min()), int(prof.max())
    fitted = None
    if cfg.refinement == "sphere":
        fitted = _sphere_refine(prof, ang, rng_m, cfg, track, period_s)
    if fitted is not None:
        x_p, phi_p, range_p, std_x = fitted
        return Sighting(
            profile=x_p - phi_p / math.tau,
            angle_rad=phi_p,
            range_m=range_p,
            n_returns=int(idx.size),
            first_profile=first,
            last_profile=last,
            profile_std=math.hypot(std_x, cfg.profile_model_std),
            refinement="sphere",
        )
    w = np.maximum(scan.intensity[idx], 1e-12)
    centre = float(np.sum(w * prof) / np.sum(w))
    # Sparse clusters (far targets, one return per profile or fewer) are worse: whether
    # the edge profiles catch a return is chance. 0.35 x the standard error of the mean
    # profile number matches the simulated spread of such centroids.
    spread = float(np.sum(w * (prof - centre) ** 2) / np.sum(w))
    sparse = 0.35 * math.sqrt(spread / idx.size)
    return Sighting(
        profile=centre,
        angle_rad=float(np.sum(w * ang) / np.sum(w)),
        range_m=float(np.median(rng_m)),
        n_returns=int(idx.size),
        first_profile=first,
        last_profile=last,
        profile_std=math.hypot(cfg.centroid_profile_std, sparse),
        refinement="centroid",
    )


def detect_sightings(
    scan: ProfileScan, config: ObjectSpaceConfig | None = None
) -> tuple[Sighting, ...]:
    """Retro-reflective target sightings in the scan's intensity image (step 2).

    Parameters
    ----------
    scan : ProfileScan
    config : ObjectSpaceConfig, optional
        Threshold, clustering gaps, ``min_returns`` and the refinement settings.

    Returns
    -------
    tuple of Sighting
        In order of their clock abscissa ``n_P + phi_P / 2 pi``.
    """
    return tuple(s for s, _ in detect_clusters(scan, config or ObjectSpaceConfig()))


def detect_clusters(scan: ProfileScan, cfg: ObjectSpaceConfig) -> list[tuple[Sighting, IntArray]]:
    """Every sighting with the indices of its returns, in clock order (by abscissa x)."""
    found = [(refine_sighting(scan, idx, cfg), idx) for idx in _clusters(scan, cfg)]
    found.sort(key=lambda item: item[0].x)
    return found


def require_two_sightings(
    scan: ProfileScan, sightings: Sequence[Sighting], cfg: ObjectSpaceConfig
) -> None:
    """Refuse a scan with fewer than two distinct sightings (`ObservabilityError`)."""
    if len({round(s.x, 6) for s in sightings}) >= 2:
        return
    msg = (
        f"{scan.source}: {len(sightings)} target sighting(s) found (returns with intensity "
        f">= {cfg.intensity_threshold:g}, at least {cfg.min_returns} per target); at least "
        "two distinct sightings of the sync points are needed: check the intensity "
        "threshold and that the retro-reflective targets were scanned"
    )
    n_long = int(np.count_nonzero(scan.range_m > PROFILE_SCANNER_REACH_M))
    note = long_range_note(n_long, len(scan.range_m))
    raise ObservabilityError(f"{msg}; {note}" if note else msg)
