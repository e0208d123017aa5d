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
   sweeps P from far away: crossings farther than ``max_range_m`` are dropped. A
   sign change across a data gap of the trajectory (`kinsync.trajectory_gaps`) cannot
   be timed (the trajectory there would be a guess interpolated across the hole): it
   is left out and reported (`ObjectSpaceResult.crossings_in_gaps`), and a sighting
   of that pass stays unmatched.
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
   fit by about 0.015 (1 deg beams, 3 mm range noise). That fit takes the target to
   stand still in the plane, but it moves: a plane slanted by ``[profiler]
   azimuth_deg`` az slides over the point ``tan(az)`` as fast as it sweeps it, and in
   a turn the scanner slides sideways and the sweep slows. Only the cap facing the
   scanner is seen, so the fit put x_P where that cap was nearest: 0.3 profile off at
   10 deg, up to 1 at 20 deg, 2 at 35 deg, on opposite sides of the scan in opposite
   directions, so that sightings were left unmatched and the clock "ambiguous" (0.15
   profile in the oval's turns at 0 deg). Each cluster is therefore fitted again for
   each compatible crossing (step 3) along that crossing's track of the point
   (`Crossing.track`: its distance to the plane and its motion within it, sampled
   from the trajectory 3 s either side), the returns timed with the prior period
   times a fitted scale; matching uses these fits, and after matching each matched
   sighting is fitted once more along its crossing's track timed with the estimated
   period.
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
   the result *ambiguous* (reported, with the alternatives), unless the pulses rule
   it out (step 6). Sightings left unmatched (control targets, glints) are reported,
   never used. One near a crossing of a sync point that the clock leaves unused
   (compatible, within `kinsync.sync.point_checks.NEAR_CROSSING_M` along the track)
   is that point seen a little off: with sync points 0.1-0.5 m off (a datum or epoch
   mix-up) the two sightings that showed it were left out and t0 was 4-7 sigma off,
   silently; a `KinsyncWarning` now names them, with how far off they are.

   **A wrong prior.** Two pairs always fit a line exactly, so a prior far from the
   true period still gave an "assignment": two sightings matched by chance, chi2 0,
   the rest unmatched (2 of 18 sightings, exit 0, with a prior 9 % off; three by
   chance on a 5 min looped drive). The search is therefore also made over periods
   within a factor `PERIOD_SEARCH_FACTOR` of the prior
   (`kinsync.sync.clock_line.best_assignment`, which refines only the lines that
   already hold more sightings than the best within the prior's window: milliseconds
   on the oval, under 0.1 s on a 5 min looped drive with 60 sightings). When a period
   outside the window (by more than three of its sigmas: nearer, it is the window's
   own, estimated just outside, and taken) fits more sightings, and at least three,
   the prior excluded what the data show: `kinsync.errors.PeriodPriorError` naming
   ``--period-prior-s``, how many sightings each period fits and the period the data
   suggest (also as attributes, for a caller that retries). Control targets, glints
   and far passes stay unmatched on a correct clock (6 of 18 sightings matched in the
   default simulation, 23 of 60 on the looped drive), so the matched fraction itself
   says nothing and is not tested. A clock from two pairs only, which nothing can
   check (no residual, and a wrong prior cannot be told from a right one when no third
   sighting fits any period), comes with a `KinsyncWarning`; when it leaves out a
   sighting that lies where a sync point is seen, that one matched alone is another
   clock (`kinsync.sync.clock_line.lone_matches`) and the result is ambiguous unless
   the pulses rule those out (S2 seen once, two sightings of S1 a lap apart fitted a
   clock 132 s late, 7300 sigma, exit 0).
4. **Regression.** The pairs ``(x_P = n_P + phi_P / 2 pi, t_P)`` give t0 and T by
   generalised least squares with the covariance of step 5. Regressing on x_P
   applies the helix correction ``t_P - (phi_P / 2 pi) T = t0 + n_P T`` with the
   *estimated* T exactly (the issue's "iterate once with the estimated T" converges
   in this one linear step); each matched sighting reports its correction
   ``(phi_P / 2 pi) T``.
5. **Uncertainty.** A pair's timing error has two parts. The *scan part* is the
   sighting's sub-profile sigma times T (fit covariance and ``profile_model_std`` in
   quadrature, or ``centroid_profile_std``), independent between sightings. The
   *position part*: a trajectory position error ``dp`` at the crossing moves the scan
   plane by ``m_i . dp`` along its normal and the crossing by ``m_i . dp(t_i) / d'_i``
   (m_i the unit plane normal at the crossing, d'_i the rate of the signed distance,
   m/s: `Crossing.normal_ecef`, `Crossing.rate_m_s`). INS/GNSS position errors are
   correlated in time over 10-20 s, so sightings a few seconds apart (several sync
   points passed on one pass) share most of theirs. With an isotropic first-order
   Gauss-Markov error (sigma_p = ``position_std_m`` on every axis, correlation
   ``rho(dt) = exp(-|dt| / tau_c)``, tau_c = ``position_corr_time_s``) the pairs'
   covariance is::

       C_ij = sigma_p^2 rho(t_i - t_j) (m_i . m_j) / (d'_i d'_j) + delta_ij (sigma_x,i T)^2

   Its diagonal is each pair's own sigma, ``sigma_i^2 = (sigma_x,i T)^2 +
   (sigma_p / |d'_i|)^2``; ``tau_c = 0`` makes it diagonal (errors independent between
   sightings, weighted least squares, the model before). C is positive definite: an
   exponential correlation in time times the Gram matrix of ``m_i / d'_i`` (a Schur
   product) plus a positive diagonal. On opposite headings ``m_i / d'_i`` changes
   sign: one north error makes one crossing early and the other late. t0 and T come
   from generalised least squares, covariance ``(A^T C^-1 A)^-1``, chi2
   ``r^T C^-1 r``; the matching of step 3 keeps the diagonal sigmas (it only chooses
   pairs). In simulation (`benchmarks/bench_sync_sigma.py`, 15 s Gauss-Markov errors)
   the independent model's sigma of t0 and T was 1.75-1.95 times too small with two
   sync points passed 2.6 s apart on each of two passes (1.25-1.4 times without the
   twin targets); with C the spread over the sigma is 0.9-1.0, and within 0.8-1.2 for
   true correlation times of 5 s and 40 s and for the smooth spline errors of
   `kinsync.sim.nav_noise`.

   The covariance is scaled by the a-posteriori variance factor ``chi2 / (m - 2)``
   when there are more than two pairs and the global test (chi2 above its 95 %
   quantile) fails both with C and with the pairs' own sigmas (``sum (r_i /
   sigma_i)^2``), by the smaller factor: the residuals set the sigma when they show
   significantly more scatter than expected, the a-priori covariance is the floor. A
   failure with C alone says that near-simultaneous sightings differ more than
   ``rho`` allows, i.e. the errors are less correlated than modelled; scaling by the
   GLS chi2 then made the sigma up to 2.4 times too large, while the unscaled GLS
   sigma stayed within 0.9-1.15 of the spread for true correlation times from 0.3 s
   to 15 s. Sync-point coordinate errors are not modelled apart (a point's error is
   shared by all its passes, however far apart): survey them well below
   ``position_std_m``.
6. **Counting faults** (`pulse_offset`). Hardware pulses, one per profile on GPS time,
   are matched to the clock where it is best known: at the profile n_ref of least
   time variance (the sightings' weighted centre) the pulse m nearest to
   ``t(n_ref, 0)`` gives ``k = m - n_ref``, so that ``pulse[n + k]`` belongs to profile
   n (an extra first pulse gives k = 1). The misfit of that pulse (in profiles) and
   the clock's sigma there (in profiles) say whether the count is sure: it is when
   the misfit is within 0.25 profile and three sigmas within half a profile. A pulse
   train with a gap (a missing pulse) or a period that disagrees with the estimate is
   an error: the offset would change along the scan.

   The offset itself is a check. One pulse per profile, P pulses for N profiles: the
   train starts with profile 0 (k = 0, or k = P - N with pulses before it) or ends
   with the last profile, so k lies within ``min(P - N, 0) - 1`` to
   ``max(P - N, 0) + 1`` (`kinsync.sync.pulses.allowed_offsets`, a first or last
   pulse lost included). "Not sure" only doubts k by one; an offset outside that
   range says that the clock is wrong by whole seconds. With sync-point heights
   0.5 m off, 2 of 18 sightings matched three ways almost equally well and the best
   was 34 s late, pulse offset 1128 for 9808 pulses and 9807 profiles: exit 0 with
   warnings. Now the pulses settle an ambiguity: rivals whose offset the train does
   not allow are ruled out (``settled_by_pulses``); a best clock it does not allow
   gives way to the one rival it does (a `KinsyncWarning` says so: the sync points
   alone could not tell them apart), which keeps its own covariance, the pulses
   being used only to choose; and with no rival, or several, that the pulses allow,
   the clock is refused (`ObservabilityError`, naming the alternatives and their
   offsets).

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
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from kinsync._arrays import FrozenMapping
from kinsync._typing import ArrayLike, FloatArray
from kinsync.clock.profile import ProfileClock
from kinsync.errors import KinsyncWarning, ObservabilityError
from kinsync.mount import Mount
from kinsync.sync.clock_line import (
    PERIOD_SEARCH_FACTOR,
    Assignment,
    LoneMatch,
    candidate_assignments,
    check_period_prior,
    gls_line,
    lone_matches,
    pair_covariance,
    position_model_note,
    seen_off_the_clock,
    tracked_sightings,
    variance_factor,
)
from kinsync.sync.config import ObjectSpaceConfig
from kinsync.sync.crossings import (
    Crossing,
    GapCrossing,
    require_profiler_azimuth,
    search_crossings,
)
from kinsync.sync.mount_effect import MountEffect, crossing_shifts, exact_text, mount_effect
from kinsync.sync.point_checks import (
    NearCrossing,
    near_crossings,
    near_crossings_text,
    no_assignment_text,
    sync_point_notes,
)
from kinsync.sync.pulses import PulseOffset, pulse_offset
from kinsync.sync.scan import ProfileScan, SyncPoints
from kinsync.sync.sightings import (
    Sighting,
    detect_clusters,
    refine_sighting,
    require_two_sightings,
)
from kinsync.trajectory import Trajectory
from kinsync.trajectory_gaps import GAP_ADVICE, gap_threshold_text

__all__ = [
    "PERIOD_SEARCH_FACTOR",
    "Alternative",
    "MatchedSighting",
    "ObjectSpaceResult",
    "synchronise_object_space",
]


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
        A-priori timing sigma of the pair (s): the square root of its diagonal element
        of the covariance (pairs a few seconds apart are correlated, module step 5).
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
    """Another assignment of sightings to crossings and its clock.

    ``pulse_offset`` is the offset the hardware pulses give this clock (module step 6),
    None without pulses or when their period disagrees with this clock's.
    """

    t0_s: float
    period_s: float
    n_matched: int
    chi2: float
    pulse_offset: int | None = None


@dataclass(frozen=True)
class ObjectSpaceResult:
    """The profile clock found from sync points, with its uncertainty.

    Attributes
    ----------
    t0_s, period_s : float
        The clock ``t(n, phi) = t0 + (n + phi / 2 pi) T`` (s).
    t0_std_s, period_std_s : float
        Standard deviations (s): the data's and the mount's stated errors
        (`kinsync.sync.mount_effect`).
    covariance : tuple of tuple of float
        2 x 2 covariance of (t0, T) (s^2), the data's and the mount's.
    data_covariance : tuple of tuple of float
        The part of ``covariance`` from the sightings and the trajectory alone (s^2).
    mount_effect : MountEffect or None
        What the mount's errors do to (t0, T), and which values are taken as exact.
    chi2 : float
        ``r^T C^-1 r``: squared residuals weighted by the pairs' a-priori covariance C
        (module step 5).
    sigma_scale : float
        Square root of the a-posteriori variance factor when the global test widened
        the a-priori covariance (module step 5), else 1 (always 1 with two pairs).
    sightings : tuple of MatchedSighting
        The regression pairs, in profile order.
    unmatched : tuple of Sighting
        Sightings matched to no sync-point crossing (control targets, glints...).
    unmatched_at : tuple of (str or None)
        For each of ``unmatched``: the sync point whose crossing lies where the sighting
        is (angle and range within ``angle_gate_rad`` and ``range_gate_m``) and, by
        this clock, within the sighting's profiles (one either side), None where none
        does. A named one is a sync point seen when the plane crossed it whose
        sub-profile position fits no clock: the geometry (mount, coordinates) or the
        sighting is wrong, and passing it again would not help.
    unmatched_near : tuple of (NearCrossing or None)
        For each of ``unmatched``: the crossing of a sync point, compatible and matched
        to no other sighting, that the clock puts within
        `kinsync.sync.point_checks.NEAR_CROSSING_M` along the track, with how far off
        (a `KinsyncWarning` names them): the point seen a little off, its coordinates
        (datum, epoch, height) or the mount wrong by about that much.
    n_crossings : Mapping of str to int
        Candidate crossings found per sync point (a read-only mapping that pickles:
        results can be pickled, copied and hashed).
    ambiguous : bool
        Another assignment fits almost as well (see ``alternatives``), or the clock
        rests on two pairs and a sighting it leaves out, matched alone, gives another
        (module step 3), and the pulses, if given, do not rule it out (step 6).
    alternatives : tuple of Alternative
        The runner-up assignments with as many matches, best first, then those lone
        matches (``n_matched`` 1, with this clock's period); at most 5.
    settled_by_pulses : bool
        Other assignments fitted almost as well, and the pulses ruled out all but this
        one (module step 6).
    pulses : PulseOffset or None
        Offset between hardware pulses and profile numbers, when pulses were given.
    crossings_in_gaps : tuple of GapCrossing
        Possible crossings left out because they fall in a data gap of the trajectory.
    gap_threshold_s : float
        Trajectory record intervals longer than this (s) were data gaps
        (`ObjectSpaceConfig.max_gap_s`, `kinsync.trajectory_gaps.max_gap_for`).
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
    n_crossings: Mapping[str, int] = field(default_factory=FrozenMapping)
    unmatched_at: tuple[str | None, ...] = ()
    unmatched_near: tuple[NearCrossing | None, ...] = ()
    ambiguous: bool = False
    alternatives: tuple[Alternative, ...] = ()
    pulses: PulseOffset | None = None
    settled_by_pulses: bool = False
    crossings_in_gaps: tuple[GapCrossing, ...] = ()
    gap_threshold_s: float = math.inf
    data_covariance: tuple[tuple[float, float], tuple[float, float]] = ((0.0, 0.0), (0.0, 0.0))
    mount_effect: MountEffect | None = None

    def __post_init__(self) -> None:
        # A frozen result holds no mutable state: a read-only copy of the counts.
        object.__setattr__(self, "n_crossings", FrozenMapping(self.n_crossings))

    @property
    def clock(self) -> ProfileClock:
        """The estimated clock."""
        return ProfileClock(self.t0_s, self.period_s)

    @property
    def residuals_s(self) -> FloatArray:
        """Residuals of the regression pairs (s), shape (m,)."""
        return np.array([s.residual_s for s in self.sightings])

    def time_std_s(self, profile: ArrayLike) -> FloatArray:
        """Standard deviation (s) of ``t(n, 0)`` at profile numbers n, from the covariance.

        ``sqrt(var(t0) + 2 n cov(t0, T) + n^2 var(T))`` with `covariance`.

        Parameters
        ----------
        profile : array_like, shape (...)
            Profile numbers n (taken as float64; fractions allowed).

        Returns
        -------
        ndarray of float64, shape (...)
            The standard deviation (s) of the clock's time at the start of each profile
            (mirror angle 0).
        """
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
            "t0_std_data_s": math.sqrt(self.data_covariance[0][0]),
            "period_std_data_s": math.sqrt(self.data_covariance[1][1]),
            "mount_effect": None if self.mount_effect is None else self.mount_effect.as_document(),
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
                    "at_crossing_of": at,
                    "near_crossing_of": None if near is None else near.as_document(),
                }
                for s, at, near in zip(
                    self.unmatched,
                    self.unmatched_at or (None,) * len(self.unmatched),
                    self.unmatched_near or (None,) * len(self.unmatched),
                    strict=True,
                )
            ],
            "n_crossings": dict(self.n_crossings),
            "crossings_in_gaps": [
                {"name": c.name, "t_start_s": c.gap.t_start_s, "t_end_s": c.gap.t_end_s}
                for c in self.crossings_in_gaps
            ],
            "gap_threshold_s": self.gap_threshold_s,
            "ambiguous": self.ambiguous,
            "settled_by_pulses": self.settled_by_pulses,
            "alternatives": [
                {
                    "t0_s": a.t0_s,
                    "period_s": a.period_s,
                    "n_matched": a.n_matched,
                    "chi2": a.chi2,
                    "pulse_offset": a.pulse_offset,
                }
                for a in self.alternatives
            ],
            "pulse_offset": None if self.pulses is None else self.pulses.offset,
            "pulse_offset_fraction": None if self.pulses is None else self.pulses.fraction,
            "pulse_offset_std_profiles": None if self.pulses is None else self.pulses.std,
            "pulse_offset_sure": None if self.pulses is None else self.pulses.sure,
        }


# ---------------------------------------------------------------------- geometry


# ---------------------------------------------------------------------- scan side


# ---------------------------------------------------------------------- regression


# ---------------------------------------------------------------------- the method
def synchronise_object_space(
    scan: ProfileScan,
    trajectory: Trajectory,
    mount: Mount,
    sync_points: SyncPoints,
    config: ObjectSpaceConfig | None = None,
    *,
    pulses_t_s: ArrayLike | None = None,
    pulses_source: str = "pulses",
    pulses_where: Callable[[int], str] | None = None,
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
    pulses_source : str
        The pulses' name in messages (their file).
    pulses_where : callable, optional
        ``pulses_where(i)`` names pulse i (0-based) as its file counts it (``"line 7"``),
        for messages; default ``"pulse i+1 of P"``.

    Returns
    -------
    ObjectSpaceResult

    Raises
    ------
    InputError
        A mount without ``[profiler]``; sync points far from the trajectory;
        `PeriodPriorError`: a period prior that excludes the clock the data show (module
        step 3, a wrong prior).
    ObservabilityError
        Fewer than two distinct sightings; no sync point crossed by the scan plane; no
        assignment of sightings to crossings with a period within the prior tolerance;
        a gap in the pulses; a clock whose pulse offset the pulse train does not allow,
        with no single rival that it allows (module step 6).

    Warns
    -----
    KinsyncWarning
        The clock rests on two sightings: nothing checks it (module step 3). The pulses
        ruled out the best assignment and took the one rival they allow (step 6). A
        sync point never crossed within ``max_range_m``, or two at one place; sightings
        left out near crossings of sync points that the clock leaves unused
        (`ObjectSpaceResult.unmatched_near`): coordinates a little off
        (`kinsync.sync.point_checks`).
    """
    cfg = config or ObjectSpaceConfig()
    require_profiler_azimuth(mount)
    detected = detect_clusters(scan, cfg)
    sightings = [d for d, _ in detected]
    require_two_sightings(scan, sightings, cfg)
    search = search_crossings(trajectory, mount, sync_points, cfg)
    crossings = search.crossings
    n_cross = {name: sum(c.name == name for c in crossings) for name in sync_points.names}
    if not crossings:
        in_gaps = (
            f" ({len(search.in_gaps)} possible crossing(s) fall in data gaps of the "
            f"trajectory, {gap_threshold_text(search.max_gap_s)}, where it is not "
            f"interpolated: {GAP_ADVICE})"
            if search.in_gaps
            else ""
        )
        msg = (
            f"{sync_points.source}: the scan plane never crosses a sync point within "
            f"{cfg.max_range_m:g} m along the trajectory ({trajectory.t_start_s!r} .. "
            f"{trajectory.t_end_s!r} s){in_gaps}: check the sync point coordinates, the "
            "mount (lever arm, boresight, [profiler] azimuth_deg) and the trajectory"
        )
        raise ObservabilityError(msg)
    for note in sync_point_notes(sync_points, search, n_cross, cfg.max_range_m):
        warnings.warn(note, KinsyncWarning, stacklevel=2)
    per_pair = tracked_sightings(scan, detected, crossings, cfg)
    ranked = candidate_assignments(sightings, crossings, cfg, per_pair=per_pair)
    own = check_period_prior(ranked, sightings, crossings, cfg, per_pair)
    if own is not None:  # the window's clock, its period estimated just outside it
        ranked = [own, *ranked]
    if not ranked:
        msg = no_assignment_text(sync_points, sightings, crossings, search, cfg)
        raise ObservabilityError(msg)
    best = ranked[0]
    if len(best.pairs) == 2:
        warnings.warn(
            f"the clock rests on 2 of {len(sightings)} sightings: two points always fit a "
            "line, so nothing checks the match or --period-prior-s; pass each sync point "
            "more than once (at the start and the end of the drive) for a check",
            KinsyncWarning,
            stacklevel=2,
        )
    m = len(best.pairs)
    rivals = [
        a for a in ranked[1:] if len(a.pairs) == m and a.score - best.score <= cfg.ambiguity_chi2
    ]
    train = (
        None
        if pulses_t_s is None
        else _PulseTrain(pulses_t_s, pulses_source, pulses_where, cfg.period_window_s)
    )

    shifts = crossing_shifts(trajectory, mount, sync_points, cfg, crossings)

    def finish(chosen: Assignment, others: Sequence[Assignment]) -> ObjectSpaceResult:
        """The result of one assignment, its matched sphere sightings refitted."""
        refined = list(sightings)
        period = chosen.fit.period_s
        for i, j in chosen.pairs:  # refit with the crossing's sweep and drift
            matched = per_pair.get((i, j), refined[i])
            refined[i] = matched
            if matched.refinement == "sphere":
                track = crossings[j].point_track()
                fixed = refine_sighting(scan, detected[i][1], cfg, track, period)
                if fixed.refinement == "sphere":  # else the matching's fit stands
                    refined[i] = fixed
        out = _result(
            chosen, others, refined, crossings, n_cross, cfg, train, scan.n_profiles, shifts, mount
        )
        return replace(out, crossings_in_gaps=search.in_gaps, gap_threshold_s=search.max_gap_s)

    runners_up = rivals or [a for a in ranked[1:] if len(a.pairs) == m]
    result = replace(finish(best, runners_up), ambiguous=bool(rivals))
    if train is not None and result.pulses is not None:
        result, best = _settle_by_pulses(
            result, best, rivals, runners_up, finish, train, scan.n_profiles
        )
    if m == 2:  # sightings left out that could be the sync points (step 3)
        result = _with_lone_matches(result, lone_matches(sightings, crossings, best, cfg, per_pair))
    for said in (
        near_crossings_text(sync_points.source, result.unmatched_near),
        exact_text(result.mount_effect, result.data_covariance),
    ):
        if said:
            warnings.warn(said, KinsyncWarning, stacklevel=2)
    return result


@dataclass(frozen=True)
class _PulseTrain:
    """Hardware pulses (s), their name and how to name pulse i in messages."""

    t_s: ArrayLike
    source: str
    where: Callable[[int], str] | None
    period_window_s: tuple[float, float] | None = None


def _pulses_of(
    t0_s: float, period_s: float, cov: FloatArray, train: _PulseTrain, n_profiles: int
) -> PulseOffset:
    """The pulse offset of the clock ``(t0_s, period_s)`` with covariance ``cov`` (step 6).

    Matched at the profile of least time variance, within the scan's profiles.
    """
    n_ref = int(np.clip(round(-cov[0, 1] / cov[1, 1]), 0, max(n_profiles - 1, 0)))
    time_var = cov[0, 0] + 2.0 * n_ref * cov[0, 1] + n_ref * n_ref * cov[1, 1]
    return pulse_offset(
        train.t_s,
        ProfileClock(t0_s, period_s),
        reference_profile=n_ref,
        time_std_s=math.sqrt(max(time_var, 0.0)),
        period_std_s=math.sqrt(cov[1, 1]),
        source=train.source,
        where=train.where,
        n_profiles=n_profiles,
        period_window_s=train.period_window_s,
    )


def _offset_of(a: Assignment, train: _PulseTrain, n_profiles: int) -> PulseOffset | None:
    """An assignment's pulse offset from its matching fit, None when the periods disagree."""
    try:
        return _pulses_of(a.fit.t0_s, a.fit.period_s, a.fit.covariance, train, n_profiles)
    except ObservabilityError:  # the pulses' period is not this clock's
        return None


def _clocks_text(items: Sequence[tuple[Assignment, PulseOffset | None]]) -> str:
    """``t0 = ... s (pulse offset k)`` for each assignment, for messages."""
    return "; ".join(
        f"t0 = {a.fit.t0_s:.6f} s, period {a.fit.period_s:.9g} s ("
        + (
            "pulse period disagrees"
            if k is None
            else f"pulse offset {k.offset}{', allowed' if k.plausible else ''}"
        )
        + ")"
        for a, k in items
    )


def _settle_by_pulses(
    result: ObjectSpaceResult,
    best: Assignment,
    rivals: Sequence[Assignment],
    runners_up: Sequence[Assignment],
    finish: Callable[[Assignment, Sequence[Assignment]], ObjectSpaceResult],
    train: _PulseTrain,
    n_profiles: int,
) -> tuple[ObjectSpaceResult, Assignment]:
    """Use the pulses to rule out assignments whose pulse offset they do not allow (step 6).

    ``result`` is the best assignment's; ``rivals`` fit almost as well (an ambiguity),
    ``runners_up`` are the alternatives reported. A best clock the pulses allow stays,
    and the rivals they rule out no longer make it ambiguous; one they do not allow
    gives way to the one rival they do (with a `KinsyncWarning`), else it is refused.
    Returns the result and the assignment it is of.

    Raises
    ------
    ObservabilityError
        The best clock's pulse offset is one the pulse train does not allow, and not
        exactly one rival's is.
    """
    assert result.pulses is not None
    offsets = {id(a): _offset_of(a, train, n_profiles) for a in (*rivals, *runners_up[:5])}

    def agrees(a: Assignment) -> bool:
        k = offsets[id(a)]
        return k is not None and k.plausible

    def listed(chosen: ObjectSpaceResult, others: Sequence[Assignment]) -> ObjectSpaceResult:
        alts = tuple(
            replace(alt, pulse_offset=None if (k := offsets.get(id(a))) is None else k.offset)
            for alt, a in zip(chosen.alternatives, others, strict=False)
        )
        return replace(chosen, alternatives=alts)

    if result.pulses.plausible:
        left = [a for a in rivals if agrees(a)]
        settled = bool(rivals) and not left
        out = replace(listed(result, runners_up), ambiguous=bool(left), settled_by_pulses=settled)
        return out, best
    p, lo_hi = result.pulses, result.pulses.allowed
    assert lo_hi is not None
    n_pulses = np.asarray(train.t_s).size
    contradiction = (
        f"{train.source}: the pulses contradict the clock from the sync points: t0 = "
        f"{result.t0_s:.6f} s, period {result.period_s:.9g} s gives pulse offset {p.offset} "
        f"(profile 0 at pulse {p.offset + 1}), but {n_pulses} pulses for {n_profiles} profiles "
        f"allow {lo_hi[0]} to {lo_hi[1]} (an extra first pulse gives 1)"
    )
    agreeing = [a for a in rivals if agrees(a)]
    if len(agreeing) == 1:
        others = [best, *(a for a in rivals if a is not agreeing[0])]
        offsets[id(best)] = p
        chosen = finish(agreeing[0], others)
        if chosen.pulses is not None and chosen.pulses.plausible:
            warnings.warn(
                f"{contradiction}; of the {len(rivals)} other match(es) of sightings to "
                f"sync-point crossings that fit almost as well, one agrees with the pulses "
                f"(pulse offset {chosen.pulses.offset}) and is taken: t0 = {chosen.t0_s:.6f} s; "
                "the sync points alone could not tell these apart: check their coordinates "
                "(heights too) and the mount",
                KinsyncWarning,
                stacklevel=3,
            )
            return replace(
                listed(chosen, others), ambiguous=False, settled_by_pulses=True
            ), agreeing[0]
    shown = [(a, offsets[id(a)]) for a in (agreeing if len(agreeing) > 1 else runners_up[:5])]
    if len(agreeing) > 1:
        others_text = (
            f"; {len(agreeing)} other matches of sightings to crossings that fit almost as well "
            f"agree with them, so the pulses cannot tell which: {_clocks_text(shown)}"
        )
    elif shown:
        others_text = (
            f"; {'the other matches' if rivals else 'other matches, which fit worse,'} of "
            f"sightings to crossings with as many sightings: {_clocks_text(shown)}"
        )
    else:
        others_text = ""
    msg = (
        f"{contradiction}{others_text}: check the sync points' coordinates (heights too), the "
        "mount (lever arm, boresight, [profiler] azimuth_deg), and that the pulses are this "
        "scan's, one per profile, on the trajectory's time scale"
    )
    raise ObservabilityError(msg)


def _with_lone_matches(result: ObjectSpaceResult, lone: Sequence[LoneMatch]) -> ObjectSpaceResult:
    """A two-pair clock and sightings that, matched alone, give other clocks (step 3).

    Each with this clock's period; they make it ambiguous unless the pulses rule them
    out: a lone clock's pulse offset is this one's plus its t0 shift in profiles.
    """
    if not lone:
        return result
    k, T = result.pulses, result.period_s

    def offset(t0_s: float) -> int | None:
        return None if k is None else k.offset + round((t0_s - result.t0_s) / T)

    alts = [Alternative(c.t0_s(T), T, 1, 0.0, offset(c.t0_s(T))) for c in lone]
    lo, hi = (-math.inf, math.inf) if k is None or k.allowed is None else k.allowed
    left = [a for a in alts if a.pulse_offset is None or lo <= a.pulse_offset <= hi]
    return replace(
        result,
        ambiguous=result.ambiguous or bool(left),
        settled_by_pulses=result.settled_by_pulses or not (left or result.ambiguous),
        # runner-ups never crowd the lone matches out of the 5 listed
        alternatives=(*result.alternatives[: 5 - min(len(left or alts), 2)], *(left or alts))[:5],
    )


def _result(
    best: Assignment,
    others: Sequence[Assignment],
    sightings: Sequence[Sighting],
    crossings: Sequence[Crossing],
    n_cross: dict[str, int],
    cfg: ObjectSpaceConfig,
    train: _PulseTrain | None,
    n_profiles: int,
    shifts_s: FloatArray,
    mount: Mount,
) -> ObjectSpaceResult:
    # Final T in the scan-side sigma; the pairs' full covariance (step 5) in a GLS fit.
    cov_t = pair_covariance(sightings, crossings, best.pairs, cfg, best.fit.period_s)
    xs = np.array([sightings[i].x for i, _ in best.pairs])
    ts = np.array([crossings[j].t_s for _, j in best.pairs])
    stds = np.sqrt(np.diag(cov_t))
    fit = gls_line(xs, ts, cov_t)
    m = len(best.pairs)
    dof = m - 2
    scale = variance_factor(fit.chi2, float(np.sum((fit.residuals_s / stds) ** 2)), dof)
    if note := position_model_note(fit.chi2, dof, cfg.position_std_m, cfg.position_corr_time_s):
        warnings.warn(note, KinsyncWarning, stacklevel=3)
    data = fit.covariance * scale
    effect = mount_effect(xs, cov_t, shifts_s[:, [j for _, j in best.pairs]], mount)
    cov = data + effect.covariance  # the mount's stated errors (kinsync.sync.mount_effect)
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
    unused = [k for k in range(len(sightings)) if k not in used]
    unmatched_at = seen_off_the_clock(
        [sightings[k] for k in unused], crossings, cfg, fit.t0_s, fit.period_s
    )
    claimed = {j for _, j in best.pairs}
    near = near_crossings(
        [sightings[k] for k in unused], crossings, claimed, cfg, fit.t0_s, fit.period_s
    )
    pulses = None if train is None else _pulses_of(fit.t0_s, fit.period_s, cov, train, n_profiles)
    alternatives = tuple(
        Alternative(a.fit.t0_s, a.fit.period_s, len(a.pairs), a.fit.chi2) for a in others[:5]
    )
    return ObjectSpaceResult(
        t0_s=fit.t0_s,
        period_s=fit.period_s,
        t0_std_s=math.sqrt(cov[0, 0]),
        period_std_s=math.sqrt(cov[1, 1]),
        covariance=((float(cov[0, 0]), float(cov[0, 1])), (float(cov[1, 0]), float(cov[1, 1]))),
        data_covariance=(
            (float(data[0, 0]), float(data[0, 1])),
            (float(data[1, 0]), float(data[1, 1])),
        ),
        mount_effect=effect,
        chi2=fit.chi2,
        sigma_scale=math.sqrt(scale),
        sightings=tuple(matched),
        unmatched=tuple(sightings[k] for k in unused),
        n_crossings=n_cross,
        unmatched_at=unmatched_at,
        unmatched_near=near,
        alternatives=alternatives,
        pulses=pulses,
    )
