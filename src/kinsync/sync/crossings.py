"""Method B step 1, geometric time: when the scan plane sweeps over each sync point.

With the trajectory and the mount the scan plane is known at every time; the signed
distance of a sync point to it changes sign where the mirror sweeps over the point.
The roots are bracketed between trajectory records and found with Brent's method on
the trajectory interpolated exactly as georeferencing does it (see
`kinsync.sync.object_space` for the whole method). A sign change across a data gap of
the trajectory (`kinsync.trajectory_gaps`) is not a crossing that can be timed: where
the scanner was in the hole is unknown, so it is left out and reported
(`GapCrossing`).

References
----------
Brent, R. P., "Algorithms for Minimization without Derivatives", 1973 (root finding).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from scipy.optimize import brentq

from kinsync._arrays import ReadOnlyArrays
from kinsync._typing import BoolArray, FloatArray
from kinsync.errors import InputError
from kinsync.frames import quaternion_to_matrix
from kinsync.georef import GeorefTrajectory, georeference
from kinsync.mount import Mount
from kinsync.sync.config import ObjectSpaceConfig
from kinsync.sync.scan import SyncPoints
from kinsync.trajectory import Trajectory
from kinsync.trajectory_gaps import TrajectoryGap

__all__ = [
    "TRACK_HALF_S",
    "TRACK_STEP_S",
    "Crossing",
    "CrossingSearch",
    "GapCrossing",
    "PointTrack",
    "find_crossings",
    "require_profiler_azimuth",
    "search_crossings",
]


TRACK_HALF_S = 3.0
"""A crossing's `PointTrack` reaches this far before and after it (s): a 0.5 m sphere
swept at 0.2 m/s (a turn) takes 2.5 s to pass."""

TRACK_STEP_S = 0.005
"""Sample interval of a `PointTrack` (s); linear interpolation between samples is good
to micrometres (the sweep's acceleration is below 1 m/s^2)."""


@dataclass(frozen=True, eq=False)
class PointTrack(ReadOnlyArrays):
    """A sync point's motion relative to the scan plane around one crossing.

    Attributes
    ----------
    tau_s : ndarray, shape (N,)
        Time from the crossing (s), increasing, 0 included.
    normal_m : ndarray, shape (N,)
        Signed distance ``d_P`` of the point to the scan plane (m), 0 at the crossing.
    in_plane_m : ndarray, shape (N, 2)
        The point's displacement within the plane since the crossing, along the plane's
        ``(r sin phi, r cos phi)`` axes (m).

    Notes
    -----
    A sphere sighting is fitted with it (`kinsync.sync.sightings.refine_sighting`): at
    a return's time the target's centre lies ``normal_m`` off the plane and has moved
    ``in_plane_m`` within it. Outside ``tau_s`` the ends are held.
    """

    tau_s: FloatArray
    normal_m: FloatArray
    in_plane_m: FloatArray

    @classmethod
    def linear(cls, rate_m_s: float, drift_m_s: tuple[float, float]) -> PointTrack:
        """The track of a constant sweep ``rate_m_s`` and drift ``drift_m_s`` (m/s)."""
        tau = np.array([-1.0e3, 0.0, 1.0e3])
        return cls(tau, rate_m_s * tau, np.outer(tau, np.asarray(drift_m_s, dtype=np.float64)))

    def at(self, tau_s: FloatArray) -> FloatArray:
        """``(d_P, dy, dz)`` (m) at times ``tau_s`` (s from the crossing), shape (3, k)."""
        return np.stack(
            [
                np.interp(tau_s, self.tau_s, self.normal_m),
                np.interp(tau_s, self.tau_s, self.in_plane_m[:, 0]),
                np.interp(tau_s, self.tau_s, self.in_plane_m[:, 1]),
            ]
        )

    @cached_property
    def _slopes(self) -> FloatArray:
        """Rates (m/s) over each sample interval, shape (N - 1, 3)."""
        values = np.column_stack([self.normal_m, self.in_plane_m])
        out: FloatArray = np.diff(values, axis=0) / np.diff(self.tau_s)[:, None]
        return out

    def rate_at(self, tau_s: FloatArray) -> FloatArray:
        """Time derivative of `at` (m/s), shape (3, k): the slope of the sample interval.

        Zero where the ends are held (outside ``tau_s``).
        """
        slopes = self._slopes
        k = np.searchsorted(self.tau_s, tau_s, side="right") - 1
        inside = (k >= 0) & (k < self.tau_s.size - 1)
        out: FloatArray = np.where(inside, slopes[np.clip(k, 0, slopes.shape[0] - 1)].T, 0.0)
        return out


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
    normal_ecef : tuple of 3 float
        Unit normal m of the scan plane at the crossing (ECEF), the direction in which
        ``d_P = m . (P - o)`` is measured: a position error ``dp`` of the trajectory
        moves the crossing by ``m . dp / rate_m_s`` (s); the covariance of two
        crossings' timing errors needs both normals (`kinsync.sync.object_space`,
        step 5).
    drift_m_s : tuple of 2 float
        Velocity of the point within the profile plane, along the plane's
        ``(r sin phi, r cos phi)`` axes (m/s): the scanner moves sideways in a turn,
        and a plane slanted by ``[profiler] azimuth_deg`` az moves over the point
        ``tan(az)`` as fast as it sweeps it.
    track : PointTrack or None
        The point's motion relative to the plane from `TRACK_HALF_S` before to after
        the crossing (`search_crossings` gives it); None: `point_track` makes it linear
        from ``rate_m_s`` and ``drift_m_s``.
    """

    name: str
    t_s: float
    angle_rad: float
    range_m: float
    rate_m_s: float
    normal_ecef: tuple[float, float, float]
    drift_m_s: tuple[float, float] = (0.0, 0.0)
    track: PointTrack | None = field(default=None, compare=False, repr=False)

    def point_track(self) -> PointTrack:
        """`track`, or the linear track of ``rate_m_s`` and ``drift_m_s`` without one."""
        return self.track or PointTrack.linear(self.rate_m_s, self.drift_m_s)


@dataclass(frozen=True)
class GapCrossing:
    """A sync point's distance to the scan plane changing sign across a data gap.

    The scan plane may have swept the point while the trajectory has no record: the
    time of such a crossing is unknown (interpolated across the hole it is a guess),
    so it is left out; a sighting of the point then is left unmatched.

    Attributes
    ----------
    name : str
        Sync point.
    gap : TrajectoryGap
        The gap (trajectory time scale, after the mount's latency).
    """

    name: str
    gap: TrajectoryGap


@dataclass(frozen=True)
class CrossingSearch:
    """What `search_crossings` found.

    Attributes
    ----------
    crossings : tuple of Crossing
        Timed crossings, in time order.
    in_gaps : tuple of GapCrossing
        Sign changes across data gaps of the trajectory (left out), in time order.
    max_gap_s : float
        The gap threshold used (s): record intervals longer than this are data gaps.
    distance_m : tuple of float
        Each sync point's distance to the nearest trajectory position (m, of at most
        20 000 evenly spaced records), in the order of the sync points; empty when not
        computed.
    """

    crossings: tuple[Crossing, ...]
    in_gaps: tuple[GapCrossing, ...] = ()
    max_gap_s: float = math.inf
    distance_m: tuple[float, ...] = ()


def require_profiler_azimuth(mount: Mount, source: str = "mount") -> float:
    """The mount's ``[profiler] azimuth_deg`` in radians, or an `InputError` saying so.

    Parameters
    ----------
    mount : Mount
        The scanner's mount; Method B needs its ``[profiler]`` table.
    source : str
        Where the mount came from (a file name), for the message; default ``"mount"``.

    Returns
    -------
    float
        The azimuth of the profile plane about the scanner Z axis (rad).

    Raises
    ------
    InputError
        The mount has no ``[profiler] azimuth_deg`` (``profiler_azimuth_deg`` None).
    """
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
) -> tuple[float, ...]:
    """Each point's distance (m) to the nearest of 20 000 trajectory positions at most.

    Raises `InputError` for a point farther than ``limit_m``.
    """
    step = max(1, len(gtraj) // 20000)
    sampled = gtraj.pos_ecef_m[::step]
    out: list[float] = []
    for name, p in zip(points.names, pos_ecef, strict=True):
        dist = float(np.min(np.linalg.norm(sampled - p, axis=1)))
        out.append(dist)
        if dist > limit_m:
            msg = (
                f"{points.source}: sync point {name!r} lies {dist / 1000.0:.3g} km from the "
                f"nearest trajectory position (limit {limit_m / 1000.0:g} km): the sync points "
                "and the trajectory are not in the same frame or place; check the datum, "
                "latitude/longitude order and signs, and that both files belong to this survey"
            )
            raise InputError(msg)
    return tuple(out)


def _sign_changes(
    rel: FloatArray, normal: FloatArray, max_range_m: float, is_gap: BoolArray
) -> tuple[list[int], list[int]]:
    """Record intervals where a point's distance to the scan plane changes sign.

    ``rel`` is the point minus the scanner origin and ``normal`` the plane normal at
    each record (ECEF, shape (N, 3)); intervals with neither end within
    ``max_range_m`` are skipped. Returns those to time and those across a data gap.
    """
    d = np.einsum("ij,ij->i", normal, rel)
    near = np.linalg.norm(rel, axis=1) <= max_range_m
    sign_change = (np.sign(d[:-1]) != np.sign(d[1:])) | (d[:-1] == 0.0)
    k = np.flatnonzero(sign_change & (near[:-1] | near[1:]))
    return k[~is_gap[k]].tolist(), k[is_gap[k]].tolist()


def _point_track(
    gtraj: GeorefTrajectory, mount: Mount, az: float, t_c: float, p: FloatArray
) -> PointTrack:
    """Point p's motion relative to the scan plane around the crossing at ``t_c``.

    Sampled every `TRACK_STEP_S` from `TRACK_HALF_S` before to after (held at the
    trajectory's ends); samples in a data gap of the trajectory (NaN) are dropped.
    """
    tau = np.arange(-TRACK_HALF_S, TRACK_HALF_S + 0.5 * TRACK_STEP_S, TRACK_STEP_S)
    t = np.clip(t_c + tau, gtraj.t_start_s, gtraj.t_end_s)
    probe = np.vstack([np.zeros(3), np.eye(3)])  # scanner origin and axes
    xyz, _ = georeference(np.repeat(t, 4), np.tile(probe, (t.size, 1)), gtraj, mount)
    xyz = xyz.reshape(t.size, 4, 3)
    axes = xyz[:, 1:] - xyz[:, :1]  # rows: scanner axes in ECEF
    v = np.einsum("nij,nj->ni", axes, p - xyz[:, 0])
    d = math.cos(az) * v[:, 0] + math.sin(az) * v[:, 1]
    yz = np.column_stack([-math.sin(az) * v[:, 0] + math.cos(az) * v[:, 1], v[:, 2]])
    ok = np.isfinite(d) & np.all(np.isfinite(yz), axis=1)
    at_c = yz[int(np.argmin(np.abs(tau)))]  # tau 0 is a sample
    return PointTrack(tau[ok], d[ok], yz[ok] - at_c)


def find_crossings(
    trajectory: Trajectory,
    mount: Mount,
    sync_points: SyncPoints,
    config: ObjectSpaceConfig | None = None,
) -> tuple[Crossing, ...]:
    """The timed crossings of `search_crossings` (those in data gaps left out).

    Parameters
    ----------
    trajectory : Trajectory
        Body trajectory at its record tags (the mount's latency is applied here).
    mount : Mount
        Lever arm, boresight, latency and ``[profiler] azimuth_deg``.
    sync_points : SyncPoints
        Target centres (WGS84).
    config : ObjectSpaceConfig, optional
        ``max_range_m``, ``max_sync_distance_m`` and ``max_gap_s`` are used; default
        `ObjectSpaceConfig()`.

    Returns
    -------
    tuple of Crossing
        In time order: each crossing's time (s, trajectory time scale after the
        latency), mirror angle (rad), range (m), sweep rate (m/s) and plane normal
        (ECEF).

    Raises
    ------
    InputError
        As `search_crossings`: a mount without ``[profiler]``; a sync point farther
        than ``max_sync_distance_m`` from the trajectory.

    References
    ----------
    Brent, R. P., "Algorithms for Minimization without Derivatives", 1973 (root finding).
    """
    return search_crossings(trajectory, mount, sync_points, config).crossings


def search_crossings(
    trajectory: Trajectory,
    mount: Mount,
    sync_points: SyncPoints,
    config: ObjectSpaceConfig | None = None,
) -> CrossingSearch:
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
        ``max_range_m``, ``max_sync_distance_m`` and ``max_gap_s`` are used.

    Returns
    -------
    CrossingSearch
        The crossings in time order, the sign changes across data gaps of the
        trajectory (record intervals over `GeorefTrajectory.max_gap_s`), left out, and
        each sync point's distance to the trajectory.

    Raises
    ------
    InputError
        A mount without ``[profiler]``; a sync point farther than
        ``max_sync_distance_m`` from the trajectory.
    """
    cfg = config or ObjectSpaceConfig()
    az = require_profiler_azimuth(mount)
    gtraj = GeorefTrajectory.from_trajectory(trajectory, mount.latency_s, max_gap_s=cfg.max_gap_s)
    pos_p = sync_points.pos_ecef_m()
    distance_m = _check_sync_distance(gtraj, sync_points, pos_p, cfg.max_sync_distance_m)
    n_s = _plane_normal_scanner(az)
    R_be = quaternion_to_matrix(gtraj.q_body_to_ecef)
    origin = gtraj.pos_ecef_m + R_be @ mount.lever_arm_body_m_array
    normal = R_be @ (mount.R_scanner_to_body @ n_s)
    probe = np.vstack([np.zeros(3), np.eye(3)])  # scanner origin and axes

    def plane(t: float) -> tuple[FloatArray, FloatArray]:
        """Scanner origin and unit plane normal at t (ECEF)."""
        xyz, _ = georeference(np.array([t, t]), np.vstack([np.zeros(3), n_s]), gtraj, mount)
        return xyz[0], xyz[1] - xyz[0]

    def distance(t: float, p: FloatArray) -> float:
        o, m = plane(t)
        return float(np.dot(m, p - o))

    def in_plane(t: float, p: FloatArray) -> tuple[float, float, float]:
        """Profile-plane coordinates (r sin phi, r cos phi) of p and its range (m)."""
        xyz, _ = georeference(np.full(4, t), probe, gtraj, mount)
        v = (xyz[1:] - xyz[0]) @ (p - xyz[0])  # rows: scanner axes in ECEF
        y_plane = -math.sin(az) * v[0] + math.cos(az) * v[1]
        return y_plane, float(v[2]), float(np.linalg.norm(v))

    out: list[Crossing] = []
    in_gaps: list[GapCrossing] = []
    t_rec = gtraj.t_s
    is_gap = np.diff(t_rec) > gtraj.max_gap_s
    for name, p in zip(sync_points.names, pos_p, strict=True):
        timed, gapped = _sign_changes(p - origin, normal, cfg.max_range_m, is_gap)
        in_gaps += [
            GapCrossing(name, TrajectoryGap(float(t_rec[k]), float(t_rec[k + 1]))) for k in gapped
        ]
        for k in timed:
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
            m_c = plane(t_c)[1]
            out.append(
                Crossing(
                    name=name,
                    t_s=t_c,
                    angle_rad=math.atan2(y_c, z_c),
                    range_m=rng_m,
                    rate_m_s=rate,
                    normal_ecef=(float(m_c[0]), float(m_c[1]), float(m_c[2])),
                    drift_m_s=((y_hi - y_lo) / (hi - lo), (z_hi - z_lo) / (hi - lo)),
                    track=_point_track(gtraj, mount, az, t_c, p),
                )
            )
    out.sort(key=lambda c: c.t_s)
    in_gaps.sort(key=lambda c: c.gap.t_start_s)
    return CrossingSearch(tuple(out), tuple(in_gaps), gtraj.max_gap_s, distance_m)
