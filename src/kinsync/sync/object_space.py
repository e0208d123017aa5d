"""Method B: a profile scanner's clock from sync points in object space (SPEC section 4).

A 2D profiler records profile numbers n and mirror angles phi but no usable time; its
clock is ``t(n, phi) = t0 + (n + phi / 2 pi) T``. A few targets of known position (the
*sync points*, retro-reflective, best at the start and the end of the drive) fix t0
and T. The algorithm:

1. **Geometric time** (`find_crossings`). With the trajectory and the mount (lever
   arm, boresight, latency, ``[profiler]`` azimuth) the scan plane is known at every
   time: origin ``o(t)`` (scanner centre) and normal ``m(t) = R_s^e(t) Rz(az) e_x``. The
   signed distance ``d_P(t) = m(t) . (P - o(t))`` of a sync point P changes sign where
   the mirror sweeps over P. Sign changes are bracketed between consecutive trajectory
   records and each root is found with Brent's method on the trajectory interpolated
   exactly as georeferencing does it (`kinsync.georef.georeference`: cubic Hermite
   positions with velocities, slerp attitude). At a root the mirror angle phi_P at
   which P lies in the plane, the range and the rate ``d'(t)`` (m/s) are recorded.
   A looped drive gives several crossings per point, and the infinite plane also
   sweeps P from far away: crossings farther than ``max_range_m`` are dropped.
2. **Scanner time** (`detect_sightings`). Returns at least ``intensity_threshold``
   bright are clustered in (profile, angle, range) space (neighbours within
   ``cluster_gap_profiles`` profiles, ``cluster_gap_rad`` and ``cluster_gap_m``);
   clusters of at least ``min_returns`` returns are sightings. The sub-profile
   position of a sighting is refined by a sphere fit (the retro-reflective targets
   are spheres): each return, at profile-plane coordinates
   ``(y, z) = r (sin phi, cos phi)`` and clock abscissa ``x = n + phi / 2 pi``, lies on
   a sphere in ``(s (x - x_P), y, z)``, where s is the plane's sweep (m per profile);
   a Levenberg-Marquardt fit of ``(x_P, y_c, z_c, R, s)`` gives the abscissa x_P at
   which the plane passes through the centre, the centre's mirror angle
   ``phi_P = atan2(y_c, z_c)`` and range, and the standard deviation of x_P from the
   fit's covariance. An intensity-weighted centroid of profile numbers and angles
   replaces the fit when it cannot be made (fewer than ``sphere_min_returns`` returns
   or three profiles, no convergence, an implausible sphere), with an a-priori sigma
   ``centroid_profile_std`` (plus a term for sparse clusters): sampling a round target
   every 0.35-0.45 radii, the centroid is off by 0.11 profile RMS in simulation, the
   fit by about 0.015 (1 deg beams, 3 mm range noise). After matching, each sphere
   sighting is fitted again with the sweep and the in-plane drift of its crossing
   (the scanner, ahead of the body's turning point, slides sideways in a turn: left
   out, this biased the fit by 0.15 profile in the oval's turns).
3. **Identification and ambiguity.** The clock offset t0 is unknown, so a sighting
   cannot be matched to a crossing by time alone. It is matched by position and by
   relative timing: a sighting is *compatible* with a crossing when its angle and
   range agree with the crossing's within ``angle_gate_rad`` and ``range_gate_m``
   (the target is where the geometry puts it); any two compatible pairs of different
   sightings define a line ``t = t0 + T x`` with ``x = n + phi / 2 pi``, a hypothesis
   when its slope lies within ``period_tolerance`` (relative) of ``period_prior_s``.
   Each hypothesis takes, for every sighting, the compatible crossing nearest the
   line, keeps it when within ``gate_sigma`` standard deviations (at least
   ``min_gate_profiles`` profiles), refits the kept pairs by weighted least squares
   and repeats until the assignment is stable. The assignment matching most
   sightings wins, then the smallest ``chi2 + ((T - T_prior) / (tol T_prior))^2``; a
   different assignment with as many matches within ``ambiguity_chi2`` of it makes
   the result *ambiguous* (reported, with the alternatives). Sightings left unmatched
   (control targets, glints) are reported, never used.
4. **Regression.** The pairs ``(x_P = n_P + phi_P / 2 pi, t_P)`` give t0 and T by
   weighted least squares. Regressing on x_P applies the helix correction
   ``t_P - (phi_P / 2 pi) T = t0 + n_P T`` with the *estimated* T exactly (the issue's
   "iterate once with the estimated T" converges in this one linear step); each
   matched sighting reports its correction ``(phi_P / 2 pi) T``.
5. **Uncertainty.** Each pair's timing sigma is
   ``sigma_i^2 = (sigma_x,i T)^2 + (position_std_m / |d'(t_P)|)^2``: the sighting's
   sub-profile sigma (fit covariance and ``profile_model_std`` in quadrature, or
   ``centroid_profile_std``) and the trajectory
   and sync-point position error along the plane normal turned into time by the
   plane's speed over the point. The covariance ``(A^T W A)^-1`` is scaled by the
   a-posteriori variance factor ``chi2 / (m - 2)`` when there are more than two pairs
   and the global test fails (chi2 above its 95 % quantile): the residuals set the
   sigma when they show significantly more scatter than expected, the a-priori sigmas
   are the floor. Position errors are taken as independent between sightings (true for
   trajectory noise correlated over less than the time between passes).
6. **Counting faults** (`pulse_offset`). Hardware pulses, one per profile on GPS time,
   are matched to the clock where it is best known: at the profile n_ref of least
   time variance (the sightings' weighted centre) the pulse m nearest to
   ``t(n_ref, 0)`` gives ``k = m - n_ref``, so that ``pulse[n + k]`` belongs to profile
   n (an extra first pulse gives k = 1). The misfit of that pulse (in profiles) and
   the clock's sigma there (in profiles) say whether the count is sure: it is when
   the misfit is within 0.25 profile and three sigmas within half a profile. A pulse
   train with a gap (a missing pulse) or a period that disagrees with the estimate is
   an error: the offset would change along the scan.

The period error budget of SPEC section 3 follows: a period error dT shifts profile N
by ``N dT`` (`kinsync.budget.period_error_budget`); `ObjectSpaceResult.time_std_s`
propagates the full covariance to any profile.

References
----------
Method B of SPEC section 4: kinematic laser scanning validation with a Leica HDS 4500
profiler and a Honeywell Lasernav II INS/GPS (software synchronisation in object
space). Brent, R. P., "Algorithms for Minimization without Derivatives", 1973
(root finding).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from scipy.optimize import brentq, least_squares
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree
from scipy.stats import chi2 as chi2_dist

from kinsync._typing import ArrayLike, FloatArray, IntArray
from kinsync._validate import finite_number, positive_number
from kinsync.clock.profile import ProfileClock
from kinsync.errors import InputError, ObservabilityError
from kinsync.frames import quaternion_to_matrix
from kinsync.georef import GeorefTrajectory, georeference
from kinsync.io.profile_scan import ProfileScan, SyncPoints
from kinsync.mount import Mount
from kinsync.trajectory import Trajectory

__all__ = [
    "Alternative",
    "Crossing",
    "MatchedSighting",
    "ObjectSpaceConfig",
    "ObjectSpaceResult",
    "ProfileClock",
    "PulseOffset",
    "Sighting",
    "detect_sightings",
    "find_crossings",
    "pulse_offset",
    "require_profiler_azimuth",
    "synchronise_object_space",
]


@dataclass(frozen=True)
class ObjectSpaceConfig:
    """Settings of the object-space synchronisation (defaults suit a 33 rev/s profiler).

    Attributes
    ----------
    period_prior_s : float
        Prior mirror period T (s).
    period_tolerance : float
        Relative tolerance of the prior: hypotheses need ``|T / prior - 1| <= tol``.
    intensity_threshold : float
        Returns at least this bright are target candidates (scanner's intensity unit).
    min_returns : int
        Fewest returns that make a sighting (isolated glints are rejected).
    cluster_gap_profiles : float
        Returns of one target are at most this many profiles apart.
    cluster_gap_rad : float
        ... and this far apart in mirror angle (rad).
    cluster_gap_m : float
        ... and this far apart in range (m).
    max_range_m : float
        Crossings farther from the scanner are not candidates (m).
    angle_gate_rad : float
        A sighting and a crossing are compatible within this mirror-angle difference.
    range_gate_m : float
        ... and this range difference (m); it must exceed the target radius.
    refinement : {"sphere", "centroid"}
        Sub-profile refinement: sphere fit (with centroid fallback) or centroid only.
    sphere_min_returns : int
        Fewest returns for the sphere fit.
    centroid_profile_std : float
        A-priori sigma of a centroid sub-profile position (profiles).
    profile_model_std : float
        Model error of the sphere fit, added in quadrature to its covariance sigma
        (profiles): the centre drifts in the plane during the sweep and the fit sees
        one side of the sphere (>= 0; 0 by default: with the drift modelled, the
        simulated spread is within the fit's sigma).
    position_std_m : float
        A-priori sigma of the trajectory and sync-point positions along the plane
        normal (m); 0 for an exact (simulated) trajectory.
    gate_sigma : float
        Inlier gate of a hypothesis, in timing sigmas.
    min_gate_profiles : float
        The gate is never narrower than this many profiles.
    ambiguity_chi2 : float
        Another assignment within this chi-square of the best is an ambiguity.
    max_sync_distance_m : float
        A sync point farther than this from every trajectory position is an input error
        (wrong datum, swapped latitude and longitude, another site).
    """

    period_prior_s: float = 0.0303
    period_tolerance: float = 0.01
    intensity_threshold: float = 0.8
    min_returns: int = 3
    cluster_gap_profiles: float = 2.0
    cluster_gap_rad: float = math.radians(3.0)
    cluster_gap_m: float = 0.5
    max_range_m: float = 80.0
    angle_gate_rad: float = math.radians(5.0)
    range_gate_m: float = 1.0
    refinement: Literal["sphere", "centroid"] = "sphere"
    sphere_min_returns: int = 8
    centroid_profile_std: float = 0.12
    profile_model_std: float = 0.0
    position_std_m: float = 0.02
    gate_sigma: float = 5.0
    min_gate_profiles: float = 1.0
    ambiguity_chi2: float = 9.0
    max_sync_distance_m: float = 5000.0

    def __post_init__(self) -> None:
        positive_number(self.period_prior_s, "--period-prior-s")
        tol = positive_number(self.period_tolerance, "--period-tolerance")
        if tol >= 0.5:
            msg = f"--period-tolerance is relative (0.01 = 1 %); {tol} is too wide (< 0.5)"
            raise InputError(msg)
        finite_number(self.intensity_threshold, "intensity_threshold")
        for name in ("min_returns", "sphere_min_returns"):
            value = getattr(self, name)
            if isinstance(value, bool) or int(value) != value or value < 1:
                msg = f"{name} must be a whole number >= 1, got {value!r}"
                raise InputError(msg)
        if self.refinement not in ("sphere", "centroid"):
            msg = f"refinement must be 'sphere' or 'centroid', got {self.refinement!r}"
            raise InputError(msg)
        for name in (
            "cluster_gap_profiles",
            "cluster_gap_rad",
            "cluster_gap_m",
            "max_range_m",
            "angle_gate_rad",
            "range_gate_m",
            "centroid_profile_std",
            "gate_sigma",
            "min_gate_profiles",
            "ambiguity_chi2",
            "max_sync_distance_m",
        ):
            positive_number(getattr(self, name), name)
        for name in ("position_std_m", "profile_model_std"):
            if finite_number(getattr(self, name), name) < 0.0:
                msg = f"{name} must be >= 0, got {getattr(self, name)!r}"
                raise InputError(msg)


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


@dataclass(frozen=True)
class Crossing:
    """A zero crossing of a sync point's distance to the scan plane.

    Attributes
    ----------
    name : str
        Sync point.
    t_s : float
        Time of the crossing (s, trajectory time scale, after the mount's latency).
    angle_rad : float
        Mirror angle at which the point lies in the scan plane (rad).
    range_m : float
        Distance from the scanner origin to the point (m).
    rate_m_s : float
        ``d d_P / dt`` at the crossing (m/s): how fast the plane sweeps the point.
    drift_m_s : tuple of 2 float
        Velocity of the point within the profile plane, along the plane's
        ``(r sin phi, r cos phi)`` axes (m/s): the scanner moves sideways in a turn.
    """

    name: str
    t_s: float
    angle_rad: float
    range_m: float
    rate_m_s: float
    drift_m_s: tuple[float, float] = (0.0, 0.0)


@dataclass(frozen=True)
class MatchedSighting:
    """A sighting matched to a crossing: one (x, t) pair of the regression.

    Attributes
    ----------
    name : str
        Sync point.
    profile, angle_rad, range_m : float
        The sighting (sub-profile number, mirror angle (rad), range (m)).
    t_s : float
        Geometric time of the crossing (s).
    crossing_angle_rad, crossing_range_m : float
        Where the geometry puts the point (rad, m).
    helix_correction_s : float
        ``(phi_P / 2 pi) T`` with the estimated T (s): ``t_s`` minus this is the start
        of profile n_P.
    residual_s : float
        ``t_s - t(n_P, phi_P)`` with the estimated clock (s).
    std_s : float
        A-priori timing sigma of the pair (s).
    """

    name: str
    profile: float
    angle_rad: float
    range_m: float
    t_s: float
    crossing_angle_rad: float
    crossing_range_m: float
    helix_correction_s: float
    residual_s: float
    std_s: float

    def as_document(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {
            "name": self.name,
            "profile": self.profile,
            "angle_rad": self.angle_rad,
            "range_m": self.range_m,
            "t_s": self.t_s,
            "crossing_angle_rad": self.crossing_angle_rad,
            "crossing_range_m": self.crossing_range_m,
            "helix_correction_s": self.helix_correction_s,
            "residual_s": self.residual_s,
            "std_s": self.std_s,
        }


@dataclass(frozen=True)
class Alternative:
    """Another assignment of sightings to crossings and its clock."""

    t0_s: float
    period_s: float
    n_matched: int
    chi2: float


@dataclass(frozen=True)
class PulseOffset:
    """Integer offset between hardware pulses and profile numbers.

    Attributes
    ----------
    offset : int
        k: ``pulse[n + k]`` is the pulse of profile n (1 with one extra first pulse).
    fraction : float
        Misfit of the matched pulse to the predicted profile start (profiles).
    std : float
        Sigma of the predicted profile start where the pulse was matched (profiles).
    reference_profile : int
        Profile at which the pulse was matched (least clock variance).
    """

    offset: int
    fraction: float
    std: float
    reference_profile: int

    @property
    def sure(self) -> bool:
        """True when the misfit is within 0.25 profile and 3 sigma within 0.5 profile."""
        return abs(self.fraction) <= 0.25 and 3.0 * self.std <= 0.5


@dataclass(frozen=True)
class ObjectSpaceResult:
    """The profile clock found from sync points, with its uncertainty.

    Attributes
    ----------
    t0_s, period_s : float
        The clock ``t(n, phi) = t0 + (n + phi / 2 pi) T`` (s).
    t0_std_s, period_std_s : float
        Standard deviations (s).
    covariance : tuple of tuple of float
        2 x 2 covariance of (t0, T) (s^2).
    chi2 : float
        Weighted sum of squared residuals with the a-priori sigmas.
    sigma_scale : float
        ``sqrt(chi2 / (m - 2))`` when the global test widened the a-priori sigmas,
        else 1 (always 1 with two pairs).
    sightings : tuple of MatchedSighting
        The regression pairs, in profile order.
    unmatched : tuple of Sighting
        Sightings matched to no sync-point crossing (control targets, glints...).
    n_crossings : dict of str to int
        Candidate crossings found per sync point.
    ambiguous : bool
        Another assignment fits almost as well (see ``alternatives``).
    alternatives : tuple of Alternative
        The runner-up assignments with as many matches, best first (at most 5).
    pulses : PulseOffset or None
        Offset between hardware pulses and profile numbers, when pulses were given.
    """

    t0_s: float
    period_s: float
    t0_std_s: float
    period_std_s: float
    covariance: tuple[tuple[float, float], tuple[float, float]]
    chi2: float
    sigma_scale: float
    sightings: tuple[MatchedSighting, ...]
    unmatched: tuple[Sighting, ...]
    n_crossings: dict[str, int] = field(default_factory=dict)
    ambiguous: bool = False
    alternatives: tuple[Alternative, ...] = ()
    pulses: PulseOffset | None = None

    @property
    def clock(self) -> ProfileClock:
        """The estimated clock."""
        return ProfileClock(self.t0_s, self.period_s)

    @property
    def residuals_s(self) -> FloatArray:
        """Residuals of the regression pairs (s), shape (m,)."""
        return np.array([s.residual_s for s in self.sightings])

    def time_std_s(self, profile: ArrayLike) -> FloatArray:
        """Standard deviation (s) of ``t(n, 0)`` at profile numbers n, from the covariance."""
        n = np.asarray(profile, dtype=np.float64)
        (c00, c01), (_, c11) = self.covariance
        out: FloatArray = np.sqrt(np.maximum(c00 + 2.0 * n * c01 + n * n * c11, 0.0))
        return out

    def as_document(self) -> dict[str, Any]:
        """JSON-ready dict (what ``kinsync sync object-space --json`` prints)."""
        return {
            "t0_s": self.t0_s,
            "t0_std_s": self.t0_std_s,
            "period_s": self.period_s,
            "period_std_s": self.period_std_s,
            "covariance": [list(row) for row in self.covariance],
            "chi2": self.chi2,
            "sigma_scale": self.sigma_scale,
            "residuals_s": self.residuals_s.tolist(),
            "sightings": [s.as_document() for s in self.sightings],
            "unmatched_sightings": [
                {
                    "profile": s.profile,
                    "angle_rad": s.angle_rad,
                    "range_m": s.range_m,
                    "n_returns": s.n_returns,
                }
                for s in self.unmatched
            ],
            "n_crossings": dict(self.n_crossings),
            "ambiguous": self.ambiguous,
            "alternatives": [
                {"t0_s": a.t0_s, "period_s": a.period_s, "n_matched": a.n_matched, "chi2": a.chi2}
                for a in self.alternatives
            ],
            "pulse_offset": None if self.pulses is None else self.pulses.offset,
            "pulse_offset_fraction": None if self.pulses is None else self.pulses.fraction,
            "pulse_offset_std_profiles": None if self.pulses is None else self.pulses.std,
            "pulse_offset_sure": None if self.pulses is None else self.pulses.sure,
        }


# ---------------------------------------------------------------------- geometry
def require_profiler_azimuth(mount: Mount, source: str = "mount") -> float:
    """The mount's ``[profiler] azimuth_deg`` in radians, or an `InputError` saying so."""
    if mount.profiler_azimuth_deg is None:
        msg = (
            f"{source}: no [profiler] azimuth_deg; Method B needs the azimuth of the profile "
            "plane in the scanner frame: add a [profiler] table with azimuth_deg (0 when the "
            "scan plane is the scanner's Y-Z plane)"
        )
        raise InputError(msg)
    return math.radians(mount.profiler_azimuth_deg)


def _plane_normal_scanner(azimuth_rad: float) -> FloatArray:
    """Normal of the profile plane in the scanner frame: ``Rz(az) e_x``."""
    return np.array([math.cos(azimuth_rad), math.sin(azimuth_rad), 0.0])


def _check_sync_distance(
    gtraj: GeorefTrajectory, points: SyncPoints, pos_ecef: FloatArray, limit_m: float
) -> None:
    step = max(1, len(gtraj) // 20000)
    sampled = gtraj.pos_ecef_m[::step]
    for name, p in zip(points.names, pos_ecef, strict=True):
        dist = float(np.min(np.linalg.norm(sampled - p, axis=1)))
        if dist > limit_m:
            msg = (
                f"{points.source}: sync point {name!r} lies {dist / 1000.0:.3g} km from the "
                f"nearest trajectory position (limit {limit_m / 1000.0:g} km): the sync points "
                "and the trajectory are not in the same frame or place; check the datum, "
                "latitude/longitude order and signs, and that both files belong to this survey"
            )
            raise InputError(msg)


def find_crossings(
    trajectory: Trajectory,
    mount: Mount,
    sync_points: SyncPoints,
    config: ObjectSpaceConfig | None = None,
) -> tuple[Crossing, ...]:
    """Times at which the scan plane sweeps over each sync point (step 1 of the module).

    Parameters
    ----------
    trajectory : Trajectory
        Body trajectory at its record tags (the mount's latency is applied here).
    mount : Mount
        Lever arm, boresight, latency and ``[profiler] azimuth_deg``.
    sync_points : SyncPoints
        Target centres (WGS84).
    config : ObjectSpaceConfig, optional
        ``max_range_m`` and ``max_sync_distance_m`` are used.

    Returns
    -------
    tuple of Crossing
        In time order.

    Raises
    ------
    InputError
        A mount without ``[profiler]``; a sync point farther than
        ``max_sync_distance_m`` from the trajectory.
    """
    cfg = config or ObjectSpaceConfig()
    az = require_profiler_azimuth(mount)
    gtraj = GeorefTrajectory.from_trajectory(trajectory, mount.latency_s)
    pos_p = sync_points.pos_ecef_m()
    _check_sync_distance(gtraj, sync_points, pos_p, cfg.max_sync_distance_m)
    n_s = _plane_normal_scanner(az)
    R_be = quaternion_to_matrix(gtraj.q_body_to_ecef)
    origin = gtraj.pos_ecef_m + R_be @ mount.lever_arm_body_m_array
    normal = R_be @ (mount.R_scanner_to_body @ n_s)
    probe = np.vstack([np.zeros(3), np.eye(3)])  # scanner origin and axes

    def distance(t: float, p: FloatArray) -> float:
        xyz, _ = georeference(np.array([t, t]), np.vstack([np.zeros(3), n_s]), gtraj, mount)
        return float(np.dot(xyz[1] - xyz[0], p - xyz[0]))

    def in_plane(t: float, p: FloatArray) -> tuple[float, float, float]:
        """Profile-plane coordinates (r sin phi, r cos phi) of p and its range (m)."""
        xyz, _ = georeference(np.full(4, t), probe, gtraj, mount)
        v = (xyz[1:] - xyz[0]) @ (p - xyz[0])  # rows: scanner axes in ECEF
        y_plane = -math.sin(az) * v[0] + math.cos(az) * v[1]
        return y_plane, float(v[2]), float(np.linalg.norm(v))

    out: list[Crossing] = []
    t_rec = gtraj.t_s
    for name, p in zip(sync_points.names, pos_p, strict=True):
        rel = p - origin
        d = np.einsum("ij,ij->i", normal, rel)
        near = np.linalg.norm(rel, axis=1) <= cfg.max_range_m
        sign_change = (np.sign(d[:-1]) != np.sign(d[1:])) | (d[:-1] == 0.0)
        for k in np.flatnonzero(sign_change & (near[:-1] | near[1:])):
            a, b = float(t_rec[k]), float(t_rec[k + 1])
            fa, fb = distance(a, p), distance(b, p)
            if fa == 0.0:
                t_c = a
            elif fa * fb > 0.0:
                continue
            else:
                t_c = float(brentq(distance, a, b, args=(p,), xtol=1e-10, rtol=1e-15))
            y_c, z_c, rng_m = in_plane(t_c, p)
            if rng_m > cfg.max_range_m:
                continue
            h = min(1e-3, 0.25 * (b - a))
            lo, hi = max(t_c - h, gtraj.t_start_s), min(t_c + h, gtraj.t_end_s)
            rate = (distance(hi, p) - distance(lo, p)) / (hi - lo)
            y_lo, z_lo, _ = in_plane(lo, p)
            y_hi, z_hi, _ = in_plane(hi, p)
            out.append(
                Crossing(
                    name=name,
                    t_s=t_c,
                    angle_rad=math.atan2(y_c, z_c),
                    range_m=rng_m,
                    rate_m_s=rate,
                    drift_m_s=((y_hi - y_lo) / (hi - lo), (z_hi - z_lo) / (hi - lo)),
                )
            )
    out.sort(key=lambda c: c.t_s)
    return tuple(out)


# ---------------------------------------------------------------------- scan side
def _sphere_refine(
    prof: FloatArray,
    ang: FloatArray,
    rng_m: FloatArray,
    cfg: ObjectSpaceConfig,
    motion: tuple[float, float, float] | None = None,
) -> tuple[float, float, float, float] | None:
    """Sphere fit of one cluster: ``(x_P, phi_P, centre range, sigma of x_P)`` or None.

    Each return lies on a sphere in ``(s (x - x_P), y, z)`` (module step 2). Without
    ``motion`` the five unknowns ``(x_P, y_c, z_c, R, s)`` are fitted by
    Levenberg-Marquardt (detection). With ``motion = (s, a_y, a_z)`` from the matched
    crossing's geometry (m per profile: the plane's sweep over the point and the
    centre's drift within the plane as the scanner slides sideways in a turn), s is
    fixed and the centre moves by ``(a_y, a_z)`` per profile; four unknowns remain.
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
    if motion is None:
        p0.append(2.0 * radius0 / span)
        a_y = a_z = 0.0
    else:
        a_y, a_z = motion[1], motion[2]

    def residuals(p: FloatArray) -> FloatArray:
        dx = x - p[0]
        sweep = p[4] if motion is None else motion[0]
        out: FloatArray = (
            np.sqrt((sweep * dx) ** 2 + (y - p[1] - a_y * dx) ** 2 + (z - p[2] - a_z * dx) ** 2)
            - p[3]
        )
        return out

    n_par = len(p0)
    try:
        sol = least_squares(residuals, np.array(p0), method="lm", x_scale="jac")
        jac = np.asarray(sol.jac, dtype=np.float64)
        cov = np.linalg.inv(jac.T @ jac) * float(np.sum(sol.fun**2)) / (prof.size - n_par)
    except (ValueError, np.linalg.LinAlgError):
        return None
    x_p, y_c, z_c, radius = (float(v) for v in sol.x[:4])
    std_x = float(np.sqrt(max(cov[0, 0], 0.0)))
    plausible = (
        sol.success
        and 0.0 < radius < 5.0 * radius0 + 0.05
        and (motion is not None or abs(float(sol.x[4])) > 0.0)
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


def _sighting(
    scan: ProfileScan,
    idx: IntArray,
    cfg: ObjectSpaceConfig,
    motion: tuple[float, float, float] | None = None,
) -> Sighting:
    """Refine one cluster: sphere fit, or the intensity-weighted centroid as fallback."""
    prof = scan.profile[idx].astype(np.float64)
    ang = scan.angle_rad[idx]
    rng_m = scan.range_m[idx]
    first, last = int(prof.min()), int(prof.max())
    fitted = None
    if cfg.refinement == "sphere":
        fitted = _sphere_refine(prof, ang, rng_m, cfg, motion)
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
    return tuple(s for s, _ in _detect(scan, config or ObjectSpaceConfig()))


def _detect(scan: ProfileScan, cfg: ObjectSpaceConfig) -> list[tuple[Sighting, IntArray]]:
    found = [(_sighting(scan, idx, cfg), idx) for idx in _clusters(scan, cfg)]
    found.sort(key=lambda item: item[0].x)
    return found


# ---------------------------------------------------------------------- regression
@dataclass(frozen=True)
class _Fit:
    t0_s: float
    period_s: float
    covariance: FloatArray  # a-priori, unscaled
    chi2: float
    residuals_s: FloatArray


def _weighted_line(x: FloatArray, t: FloatArray, std: FloatArray) -> _Fit:
    """Weighted least squares ``t = t0 + T x``; x is centred for conditioning."""
    w = 1.0 / std**2
    xm = float(np.sum(w * x) / np.sum(w))
    A = np.column_stack([np.ones_like(x), x - xm])
    N = A.T @ (A * w[:, None])
    cov_c = np.linalg.inv(N)
    beta = cov_c @ (A.T @ (w * t))
    T = float(beta[1])
    t0 = float(beta[0]) - T * xm
    J = np.array([[1.0, -xm], [0.0, 1.0]])  # (t0, T) from (t at xm, T)
    cov = J @ cov_c @ J.T
    res = t - (t0 + T * x)
    return _Fit(t0, T, cov, float(np.sum(w * res * res)), res)


@dataclass(frozen=True)
class _Assignment:
    pairs: tuple[tuple[int, int], ...]  # (sighting, crossing), sighting order
    fit: _Fit
    score: float


def _pair_std(
    sightings: Sequence[Sighting], crossings: Sequence[Crossing], cfg: ObjectSpaceConfig, T: float
) -> FloatArray:
    """Timing sigma (s) of every (sighting, crossing) pair, shape (S, C) (module step 5)."""
    rate = np.array([abs(c.rate_m_s) for c in crossings])
    pos_part = cfg.position_std_m / np.maximum(rate, 1e-3)
    scan_part = np.array([s.profile_std for s in sightings]) * T
    out: FloatArray = np.sqrt(scan_part[:, None] ** 2 + pos_part[None, :] ** 2)
    return out


def _refine(
    seed_t0: float,
    seed_T: float,
    x: FloatArray,
    t_c: FloatArray,
    compat: list[IntArray],
    std: FloatArray,
    cfg: ObjectSpaceConfig,
) -> _Assignment | None:
    t0, T = seed_t0, seed_T
    previous: tuple[tuple[int, int], ...] | None = None
    lo = cfg.period_prior_s * (1.0 - cfg.period_tolerance)
    hi = cfg.period_prior_s * (1.0 + cfg.period_tolerance)
    for _ in range(10):
        claimed: dict[int, tuple[float, int]] = {}
        for i, js in enumerate(compat):
            if js.size == 0:
                continue
            err = t_c[js] - (t0 + T * x[i])
            k = int(np.argmin(np.abs(err)))
            j = int(js[k])
            gate = max(cfg.gate_sigma * std[i, j], cfg.min_gate_profiles * T)
            if abs(err[k]) > gate:
                continue
            z = abs(err[k]) / std[i, j]
            if j not in claimed or z < claimed[j][0]:
                claimed[j] = (z, i)
        pairs = tuple(sorted((i, j) for j, (_, i) in claimed.items()))
        if len(pairs) < 2:
            return None
        xs = np.array([x[i] for i, _ in pairs])
        if np.ptp(xs) <= 0.0:
            return None
        if pairs == previous:
            break
        previous = pairs
        fit = _weighted_line(
            xs, np.array([t_c[j] for _, j in pairs]), np.array([std[i, j] for i, j in pairs])
        )
        t0, T = fit.t0_s, fit.period_s
        if not lo <= T <= hi:
            return None
    assert previous is not None
    prior = ((fit.period_s - cfg.period_prior_s) / (cfg.period_tolerance * cfg.period_prior_s)) ** 2
    return _Assignment(pairs=previous, fit=fit, score=fit.chi2 + prior)


def _assignments(
    sightings: Sequence[Sighting], crossings: Sequence[Crossing], cfg: ObjectSpaceConfig
) -> list[_Assignment]:
    """Every distinct assignment reached from a two-pair hypothesis, best first."""
    x = np.array([s.x for s in sightings])
    t_c = np.array([c.t_s for c in crossings])
    std = _pair_std(sightings, crossings, cfg, cfg.period_prior_s)
    ang_c = np.array([c.angle_rad for c in crossings])
    rng_c = np.array([c.range_m for c in crossings])
    compat: list[IntArray] = []
    for s in sightings:
        d_ang = np.abs(np.angle(np.exp(1j * (ang_c - s.angle_rad))))
        ok = (d_ang <= cfg.angle_gate_rad) & (np.abs(rng_c - s.range_m) <= cfg.range_gate_m)
        compat.append(np.flatnonzero(ok).astype(np.int64))
    lo = cfg.period_prior_s * (1.0 - cfg.period_tolerance)
    hi = cfg.period_prior_s * (1.0 + cfg.period_tolerance)
    found: dict[tuple[tuple[int, int], ...], _Assignment] = {}
    # A hypothesis seeded by two pairs of one assignment already found leads back to
    # it: skip those (keeps the search near-linear in the number of assignments).
    member: dict[tuple[int, int], set[int]] = {}
    for i in range(len(sightings)):
        for i2 in range(i + 1, len(sightings)):
            dx = x[i2] - x[i]
            if dx <= 0.0:
                continue
            for j in compat[i]:
                for j2 in compat[i2]:
                    T = (t_c[j2] - t_c[j]) / dx
                    if j == j2 or not lo <= T <= hi:
                        continue
                    if member.get((i, int(j)), set()) & member.get((i2, int(j2)), set()):
                        continue
                    a = _refine(t_c[j] - T * x[i], T, x, t_c, compat, std, cfg)
                    if a is None or a.pairs in found:
                        continue
                    found[a.pairs] = a
                    for pair in a.pairs:
                        member.setdefault(pair, set()).add(len(found))
    return sorted(found.values(), key=lambda a: (-len(a.pairs), a.score))


def pulse_offset(
    pulses_t_s: ArrayLike,
    clock: ProfileClock,
    *,
    reference_profile: int = 0,
    time_std_s: float = 0.0,
    period_std_s: float = 0.0,
    source: str = "pulses",
) -> PulseOffset:
    """Integer offset k between pulses and profiles: ``pulse[n + k]`` belongs to profile n.

    Parameters
    ----------
    pulses_t_s : array_like, shape (P,)
        Pulse times (s), strictly increasing, one per profile (maybe one more first).
    clock : ProfileClock
        The estimated clock; a pulse marks ``t(n, 0)``.
    reference_profile : int
        Profile at which to match (best: where the clock is best known).
    time_std_s : float
        Sigma of ``t(reference_profile, 0)`` (s).
    period_std_s : float
        Sigma of the clock's period (s), to judge the pulse train's period.
    source : str
        Name for messages.

    Returns
    -------
    PulseOffset

    Raises
    ------
    InputError
        Fewer than two pulses, non-finite or non-increasing times.
    ObservabilityError
        A gap in the pulse train (a missing pulse), or a pulse period that disagrees
        with the clock's: the offset would not be one number along the scan.
    """
    p = np.asarray(pulses_t_s, dtype=np.float64)
    if p.ndim != 1 or p.size < 2 or not np.all(np.isfinite(p)) or np.any(np.diff(p) <= 0):
        msg = f"{source}: pulse times must be at least 2 finite, strictly increasing times"
        raise InputError(msg)
    step = np.diff(p)
    median_step = float(np.median(step))
    gap = step > 1.5 * median_step
    if np.any(gap):
        m = int(np.flatnonzero(gap)[0])
        msg = (
            f"{source}: pulse {m + 1} comes {step[m] / median_step:.2f} periods after pulse "
            f"{m} (t_s={p[m]!r}): a pulse is missing, so pulses and profiles cannot be "
            "counted with one offset; fill the gap or cut the scan there"
        )
        raise ObservabilityError(msg)
    n = np.arange(p.size, dtype=np.float64)
    pulse_period = float(np.polyfit(n, p, 1)[0])
    tolerance = 5.0 * period_std_s + 1e-5 * clock.period_s
    if abs(pulse_period - clock.period_s) > tolerance:
        msg = (
            f"{source}: the pulses come every {pulse_period!r} s but the estimated period is "
            f"{clock.period_s!r} s (tolerance {tolerance:.3g} s): they are not this scanner's "
            "profile pulses, or not on the trajectory's time scale"
        )
        raise ObservabilityError(msg)
    predicted = clock.t0_s + reference_profile * clock.period_s
    m_star = int(np.argmin(np.abs(p - predicted)))
    return PulseOffset(
        offset=m_star - int(reference_profile),
        fraction=float((p[m_star] - predicted) / clock.period_s),
        std=float(time_std_s) / clock.period_s,
        reference_profile=int(reference_profile),
    )


# ---------------------------------------------------------------------- the method
def synchronise_object_space(
    scan: ProfileScan,
    trajectory: Trajectory,
    mount: Mount,
    sync_points: SyncPoints,
    config: ObjectSpaceConfig | None = None,
    *,
    pulses_t_s: ArrayLike | None = None,
) -> ObjectSpaceResult:
    """Find the profile clock t0, T from sync points in object space (SPEC section 4).

    Parameters
    ----------
    scan : ProfileScan
        Profile numbers, mirror angles, ranges and intensities, no times.
    trajectory : Trajectory
        Body trajectory on GPS time.
    mount : Mount
        Lever arm (m, body FRD), boresight, latency (s) and ``[profiler] azimuth_deg``.
    sync_points : SyncPoints
        Target centres (WGS84).
    config : ObjectSpaceConfig, optional
    pulses_t_s : array_like, shape (P,), optional
        Hardware profile pulses (s); their integer offset to the profile numbers is
        reported.

    Returns
    -------
    ObjectSpaceResult

    Raises
    ------
    InputError
        A mount without ``[profiler]``; sync points far from the trajectory.
    ObservabilityError
        Fewer than two distinct sightings; no sync point crossed by the scan plane; no
        assignment of sightings to crossings with a period within the prior tolerance.
    """
    cfg = config or ObjectSpaceConfig()
    require_profiler_azimuth(mount)
    detected = _detect(scan, cfg)
    sightings = [d for d, _ in detected]
    distinct = len({round(s.x, 6) for s in sightings})
    if distinct < 2:
        msg = (
            f"{scan.source}: {len(sightings)} target sighting(s) found (returns with intensity "
            f">= {cfg.intensity_threshold:g}, at least {cfg.min_returns} per target); at least "
            "two distinct sightings of the sync points are needed: check the intensity "
            "threshold and that the retro-reflective targets were scanned"
        )
        raise ObservabilityError(msg)
    crossings = find_crossings(trajectory, mount, sync_points, cfg)
    n_cross = {name: sum(c.name == name for c in crossings) for name in sync_points.names}
    if not crossings:
        msg = (
            f"{sync_points.source}: the scan plane never crosses a sync point within "
            f"{cfg.max_range_m:g} m along the trajectory ({trajectory.t_start_s!r} .. "
            f"{trajectory.t_end_s!r} s): check the sync point coordinates, the mount "
            "(lever arm, boresight, [profiler] azimuth_deg) and the trajectory"
        )
        raise ObservabilityError(msg)
    ranked = _assignments(sightings, crossings, cfg)
    if not ranked:
        never = [n for n, c in n_cross.items() if c == 0]
        msg = (
            f"no assignment of the {len(sightings)} sighting(s) to the {len(crossings)} "
            f"crossing(s) gives a period within {cfg.period_tolerance:g} (relative) of "
            f"{cfg.period_prior_s!r} s"
            + (f"; sync point(s) {never} are never crossed" if never else "")
            + ": check --period-prior-s/--period-tolerance, the mount and the sync points"
        )
        raise ObservabilityError(msg)
    best = ranked[0]
    rivals = [
        a
        for a in ranked[1:]
        if len(a.pairs) == len(best.pairs) and a.score - best.score <= cfg.ambiguity_chi2
    ]
    # Refit the matched sphere sightings with their crossing's sweep and drift.
    period = best.fit.period_s
    for i, j in best.pairs:
        if sightings[i].refinement == "sphere":
            c = crossings[j]
            motion = (c.rate_m_s * period, c.drift_m_s[0] * period, c.drift_m_s[1] * period)
            sightings[i] = _sighting(scan, detected[i][1], cfg, motion)
    return _result(
        best, rivals, ranked, sightings, crossings, n_cross, cfg, pulses_t_s, scan.n_profiles
    )


def _result(
    best: _Assignment,
    rivals: list[_Assignment],
    ranked: list[_Assignment],
    sightings: Sequence[Sighting],
    crossings: Sequence[Crossing],
    n_cross: dict[str, int],
    cfg: ObjectSpaceConfig,
    pulses_t_s: ArrayLike | None,
    n_profiles: int,
) -> ObjectSpaceResult:
    fit = best.fit
    std = _pair_std(sightings, crossings, cfg, fit.period_s)
    xs = np.array([sightings[i].x for i, _ in best.pairs])
    ts = np.array([crossings[j].t_s for _, j in best.pairs])
    stds = np.array([std[i, j] for i, j in best.pairs])
    fit = _weighted_line(xs, ts, stds)  # final T in the scan-side sigma
    m = len(best.pairs)
    dof = m - 2
    # Global test of the adjustment: widen by the a-posteriori variance factor only
    # when the residuals are significantly larger than the a-priori sigmas say.
    scale = fit.chi2 / dof if dof > 0 and fit.chi2 > chi2_dist.ppf(0.95, dof) else 1.0
    cov = fit.covariance * scale
    matched = []
    for (i, j), res, sd in zip(best.pairs, fit.residuals_s, stds, strict=True):
        s, c = sightings[i], crossings[j]
        matched.append(
            MatchedSighting(
                name=c.name,
                profile=s.profile,
                angle_rad=s.angle_rad,
                range_m=s.range_m,
                t_s=c.t_s,
                crossing_angle_rad=c.angle_rad,
                crossing_range_m=c.range_m,
                helix_correction_s=s.angle_rad / math.tau * fit.period_s,
                residual_s=float(res),
                std_s=float(sd),
            )
        )
    used = {i for i, _ in best.pairs}
    pulses: PulseOffset | None = None
    if pulses_t_s is not None:
        n_ref = int(np.clip(round(-cov[0, 1] / cov[1, 1]), 0, max(n_profiles - 1, 0)))
        time_var = cov[0, 0] + 2.0 * n_ref * cov[0, 1] + n_ref * n_ref * cov[1, 1]
        pulses = pulse_offset(
            pulses_t_s,
            ProfileClock(fit.t0_s, fit.period_s),
            reference_profile=n_ref,
            time_std_s=math.sqrt(max(time_var, 0.0)),
            period_std_s=math.sqrt(cov[1, 1]),
        )
    alternatives = tuple(
        Alternative(a.fit.t0_s, a.fit.period_s, len(a.pairs), a.fit.chi2)
        for a in (rivals or [a for a in ranked[1:] if len(a.pairs) == m])[:5]
    )
    return ObjectSpaceResult(
        t0_s=fit.t0_s,
        period_s=fit.period_s,
        t0_std_s=math.sqrt(cov[0, 0]),
        period_std_s=math.sqrt(cov[1, 1]),
        covariance=((float(cov[0, 0]), float(cov[0, 1])), (float(cov[1, 0]), float(cov[1, 1]))),
        chi2=fit.chi2,
        sigma_scale=math.sqrt(scale),
        sightings=tuple(matched),
        unmatched=tuple(s for k, s in enumerate(sightings) if k not in used),
        n_crossings=n_cross,
        ambiguous=bool(rivals),
        alternatives=alternatives,
        pulses=pulses,
    )
