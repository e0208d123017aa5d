"""Method A experiment planning: Cramér-Rao bounds of the sphere centre and the latency.

Before renting a rotating table, a surveyor wants to know which rates and how many
passes reach a target latency precision. For a design (scanner range noise, angular
step and profile rate, sphere radius and range, rates, passes) the planner lays the
scanner's ray grid over the sphere's angular disc for one pass, sums the Fisher
information of every return's range (``d range / d centre = n / cos(theta)``, n the
surface normal, theta the incidence), averages over the grid's phase against the sphere
(a lattice of phases spread evenly over one profile spacing and one angular step, each
rate its own), scales by the passes pooled, and propagates the centre covariances of
the +omega and -omega pools through the exact rotation model to the latency. Returns
more oblique than the estimator's incidence cap are left out, as in the estimator.

The bound holds for range noise only; attitude noise, table regulation and levelling
errors are not in it (the Monte Carlo benchmark measures how close the estimator
comes).

References
----------
Kay, S. M., *Fundamentals of Statistical Signal Processing: Estimation Theory*,
Prentice Hall 1993, ch. 3 (Cramér-Rao lower bound).
Seube, N., Picard, A., Rondeau, M., ISPRS J. Photogramm. Remote Sens. 74 (2012) 85-89.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from kinsync._typing import FloatArray
from kinsync._validate import finite_number, positive_number
from kinsync.errors import InputError, ObservabilityError

__all__ = [
    "DEFAULT_MAX_INCIDENCE_DEG",
    "MIN_MAX_INCIDENCE_DEG",
    "MIN_SPHERE_POINTS_PER_PASS",
    "LatencyPlan",
    "RatePlan",
    "TableDesign",
    "checked_max_incidence_deg",
    "max_usable_rate_deg_s",
    "plan_latency_experiment",
    "too_fast_text",
    "worst_sphere_points_per_pass",
]

DEFAULT_MAX_INCIDENCE_DEG = 80.0
"""Returns hitting the sphere more obliquely than this are left out of the centre fit
(estimator and planner alike): near grazing the range derivative grows without bound
and real returns degrade."""

MIN_MAX_INCIDENCE_DEG = 10.0
"""Smallest incidence cap (deg) accepted: a tighter cap keeps only a small patch of the
sphere facing the scanner, too little surface for a centre; a value this small is most
likely radians given as degrees (1.4 rad is 80 deg)."""


def checked_max_incidence_deg(value: object) -> float:
    """``max_incidence_deg`` as a float in [`MIN_MAX_INCIDENCE_DEG`, 90), else `InputError`.

    One check for the planner (`TableDesign`) and the estimator
    (`kinsync.latency.sphere.estimate_latency_sphere`, `~kinsync.latency.sphere.fit_pool`).
    """
    cap = finite_number(value, "max_incidence_deg")
    if not MIN_MAX_INCIDENCE_DEG <= cap < 90.0:
        msg = (
            f"max_incidence_deg must lie in [{MIN_MAX_INCIDENCE_DEG:g}, 90) degrees, got "
            f"{value!r}; the default is {DEFAULT_MAX_INCIDENCE_DEG:g} (give degrees, not radians)"
        )
        raise InputError(msg)
    return cap


MIN_SPHERE_POINTS_PER_PASS = 10
"""A pass with fewer points on the sphere fitted at its rate is left out (no usable
sphere): `kinsync.latency.sphere` rejects it, the simulator and the planner refuse a rate
at which a pass can hold fewer (`max_usable_rate_deg_s`)."""

_PHASE_PROFILES = 4096  # phases x profiles across the sphere, at least
_MIN_PHASES = 16  # slow rates: many profiles a pass, the phase hardly matters
_MAX_PHASES = 1024  # fast rates: one or two profiles a pass, the phase decides the pass
_GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0  # the lattice's step of the beam phase
_MAX_RAYS_PER_PASS = 2e7  # 2e7 rays x 3 float64 ~ 0.5 GB at a time
_MAX_CONDITION = 1e12  # of the pass's Fisher information: beyond, the fit is singular


@dataclass(frozen=True)
class TableDesign:
    """A rotating-table latency experiment.

    Attributes
    ----------
    sphere_range_m : float
        Horizontal distance from the table axis (scanner) to the sphere centre (m).
    sphere_radius_m : float
        Sphere radius (m).
    range_noise_m : float
        Scanner range noise, one sigma along the beam (m).
    angular_step_deg : float
        Mirror angular step within a profile (deg).
    profile_rate_hz : float
        Profiles per second.
    rates_deg_s : tuple of float
        Table rates (deg/s), each run clockwise and counter-clockwise.
    passes : int
        Passes per rate and direction.
    sphere_elevation_deg : float
        Elevation of the sphere centre seen from the scanner (deg).
    radius_known : bool
        True when the radius is fixed in the fit (a calibrated sphere).
    max_incidence_deg : float
        Incidence cap of the estimator (deg).
    pass_attitude_error_deg : float
        Attitude error shared by every point of a pass, drawn anew per pass, 1 sigma per
        NED axis (deg; an INS's drift between passes): it moves each pass's sphere by
        ``e x c`` and adds ``sigma^2 (|c|^2 I - c c^T) / passes`` to each pool's centre
        covariance (`kinsync.latency.pass_scatter`). Default 0.
    """

    sphere_range_m: float = 1.5
    sphere_radius_m: float = 0.1
    range_noise_m: float = 0.002
    angular_step_deg: float = 0.2
    profile_rate_hz: float = 50.0
    rates_deg_s: tuple[float, ...] = (2.0, 4.0, 6.0, 10.0, 14.0, 18.0)
    passes: int = 15
    sphere_elevation_deg: float = 0.0
    radius_known: bool = True
    max_incidence_deg: float = DEFAULT_MAX_INCIDENCE_DEG
    pass_attitude_error_deg: float = 0.0

    def __post_init__(self) -> None:
        for name in (
            "sphere_range_m",
            "sphere_radius_m",
            "range_noise_m",
            "angular_step_deg",
            "profile_rate_hz",
        ):
            positive_number(getattr(self, name), name)
        if self.sphere_radius_m >= self.sphere_range_m:
            msg = "sphere_radius_m must be smaller than sphere_range_m (scanner outside the sphere)"
            raise InputError(msg)
        if not self.rates_deg_s:
            msg = "rates_deg_s: give at least one table rate"
            raise InputError(msg)
        rates = tuple(
            positive_number(abs(r), "every rate in rates_deg_s") for r in self.rates_deg_s
        )
        object.__setattr__(self, "rates_deg_s", rates)
        if isinstance(self.passes, bool) or int(self.passes) != self.passes or self.passes < 1:
            msg = f"passes must be a whole number >= 1, got {self.passes!r}"
            raise InputError(msg)
        object.__setattr__(
            self, "max_incidence_deg", checked_max_incidence_deg(self.max_incidence_deg)
        )
        error = finite_number(self.pass_attitude_error_deg, "pass_attitude_error_deg")
        if error < 0.0:
            msg = f"pass_attitude_error_deg must be >= 0 (deg, 1 sigma), got {error!r}"
            raise InputError(msg)
        object.__setattr__(self, "pass_attitude_error_deg", error)
        if abs(self.sphere_elevation_deg) >= 89.0:
            msg = (
                "sphere_elevation_deg: a sphere on the table axis has no latency signal; "
                f"got {self.sphere_elevation_deg!r}"
            )
            raise ObservabilityError(msg)


@dataclass(frozen=True, eq=False)
class RatePlan:
    """Predicted precision at one rate.

    Attributes
    ----------
    rate_deg_s : float
    points_per_pass : float
        Expected sphere returns per pass (all incidences).
    n_points : float
        Sphere returns in both pools (all incidences).
    center_std_m : float
        Centre sigma of one pool, RMS over the axes (m).
    center_tangential_std_m : float
        Centre sigma across the line of sight, horizontally: the direction the latency
        moves the centre (m).
    latency_std_s : float
        Cramér-Rao bound of the latency from this rate alone (s).
    """

    rate_deg_s: float
    points_per_pass: float
    n_points: float
    center_std_m: float
    center_tangential_std_m: float
    latency_std_s: float


@dataclass(frozen=True, eq=False)
class LatencyPlan:
    """Predicted precision of a design.

    Attributes
    ----------
    design : TableDesign
    per_rate : tuple of RatePlan
    latency_std_s : float
        Bound of the combined latency (s).
    """

    design: TableDesign
    per_rate: tuple[RatePlan, ...]
    latency_std_s: float

    def passes_for_target(self, target_latency_std_s: float) -> int:
        """Passes per rate and direction that reach a target latency sigma (s).

        The bound falls as one over the square root of the passes pooled, so the
        design's passes are scaled by ``(latency_std_s / target) ** 2``.

        Parameters
        ----------
        target_latency_std_s : float
            Target 1-sigma of the combined latency (s), > 0.

        Returns
        -------
        int
            Passes per rate and direction, at least 1 (rounded up).

        Raises
        ------
        InputError
            ``target_latency_std_s`` not a positive finite number.
        """
        target = positive_number(target_latency_std_s, "target_latency_std_s")
        ratio = (self.latency_std_s / target) ** 2
        return max(1, math.ceil(self.design.passes * ratio - 1e-9))

    def as_document(self, target_latency_std_s: float = 1e-4) -> dict[str, Any]:
        """JSON-ready summary (what ``kinsync latency plan --json`` prints).

        Parameters
        ----------
        target_latency_std_s : float
            Target 1-sigma of the combined latency (s), > 0, for
            ``passes_for_target``; default 1e-4 (0.1 ms).

        Returns
        -------
        dict
            ``latency_std_ms``, ``passes_for_target``, ``target_latency_std_ms``,
            ``passes``, ``pass_attitude_error_deg`` and ``per_rate`` (a list, per rate:
            ``rate_deg_s``, ``points_per_pass``, ``center_std_m``,
            ``center_tangential_std_m``, ``latency_std_ms``). Latencies in ms, the
            centre's in m.

        Raises
        ------
        InputError
            ``target_latency_std_s`` not a positive finite number.
        """
        return {
            "latency_std_ms": self.latency_std_s * 1e3,
            "passes_for_target": self.passes_for_target(target_latency_std_s),
            "target_latency_std_ms": target_latency_std_s * 1e3,
            "passes": self.design.passes,
            "pass_attitude_error_deg": self.design.pass_attitude_error_deg,
            "per_rate": [
                {
                    "rate_deg_s": r.rate_deg_s,
                    "points_per_pass": r.points_per_pass,
                    "center_std_m": r.center_std_m,
                    "center_tangential_std_m": r.center_tangential_std_m,
                    "latency_std_ms": r.latency_std_s * 1e3,
                }
                for r in self.per_rate
            ],
        }


_WORST_PHASES = 256  # profile phases over one profile spacing, for the worst case
_MAX_PHASE_CELLS = 1 << 16  # phases x profiles evaluated at most (slow rates: fewer phases)


def _sphere_disc_rad(
    sphere_radius_m: float,
    sphere_range_m: float,
    sphere_elevation_m: float,
    max_incidence_deg: float = DEFAULT_MAX_INCIDENCE_DEG,
) -> float:
    """Angular radius (rad) of the part of the sphere the estimator uses, seen from the axis.

    A return at angle ``a`` from the sphere centre's direction meets the surface at an
    incidence ``i`` with ``sin i = (D / r) sin a`` (``D`` the centre's distance): the returns
    below the incidence cap ``max_incidence_deg`` lie within this disc.
    """
    distance_m = math.hypot(sphere_range_m, sphere_elevation_m)
    cap = math.radians(max_incidence_deg)
    return math.asin(min(1.0, sphere_radius_m * math.sin(cap) / distance_m))


def worst_sphere_points_per_pass(
    rate_deg_s: float,
    *,
    profile_rate_hz: float,
    angular_step_deg: float,
    sphere_radius_m: float,
    sphere_range_m: float,
    sphere_elevation_m: float = 0.0,
    max_incidence_deg: float = DEFAULT_MAX_INCIDENCE_DEG,
) -> int:
    """Fewest sphere returns a pass at ``rate_deg_s`` holds, whatever the profiles' phase.

    The scan plane turns with the table, so consecutive profiles cross the sphere
    ``rate_deg_s / profile_rate_hz`` degrees apart; each puts a beam every
    ``angular_step_deg`` on its chord of the disc the estimator uses (returns below its
    incidence cap). The count is the least over the phase of the profiles against the
    sphere (no noise, no clutter).

    Parameters
    ----------
    rate_deg_s : float
        Table rate (deg/s); its sign does not matter.
    profile_rate_hz : float
        Profiles per second.
    angular_step_deg : float
        Angle between the beams of a profile (deg).
    sphere_radius_m, sphere_range_m, sphere_elevation_m : float
        Sphere radius, horizontal distance from the axis and height above the scanner (m).
    max_incidence_deg : float
        Incidence cap of the estimator (deg); default `DEFAULT_MAX_INCIDENCE_DEG`.

    Returns
    -------
    int
        Returns on the sphere in the worst pass (0 when a pass can miss it).
    """
    half = _sphere_disc_rad(sphere_radius_m, sphere_range_m, sphere_elevation_m, max_incidence_deg)
    elevation = math.atan2(sphere_elevation_m, sphere_range_m)
    spacing = math.radians(abs(rate_deg_s) / profile_rate_hz) * math.cos(elevation)
    step = math.radians(angular_step_deg)
    n_profiles = math.ceil(2.0 * half / spacing) + 1
    n_phases = max(8, min(_WORST_PHASES, _MAX_PHASE_CELLS // n_profiles))  # slow rates: fewer
    phase = np.arange(n_phases)[:, None] / n_phases * spacing
    offset = -half + phase + spacing * np.arange(n_profiles)[None, :]  # (phases, profiles)
    chord = 2.0 * np.sqrt(np.maximum(half * half - offset * offset, 0.0))
    beams = np.floor(chord / step)
    return int(np.min(np.sum(beams, axis=1)))


@functools.lru_cache(maxsize=64)
def max_usable_rate_deg_s(
    *,
    profile_rate_hz: float,
    angular_step_deg: float,
    sphere_radius_m: float,
    sphere_range_m: float,
    sphere_elevation_m: float = 0.0,
    max_incidence_deg: float = DEFAULT_MAX_INCIDENCE_DEG,
) -> float:
    """Largest table rate (deg/s, 3 significant digits) at which every pass is usable.

    Every pass then holds at least `MIN_SPHERE_POINTS_PER_PASS` returns on the sphere
    (`worst_sphere_points_per_pass`), the fewest ``latency sphere`` fits; faster, the
    profiles are so far apart that a pass can cross the sphere with one profile or none,
    and the estimator leaves it out.

    Parameters
    ----------
    profile_rate_hz, angular_step_deg, sphere_radius_m, sphere_range_m, sphere_elevation_m
        As in `worst_sphere_points_per_pass`.
    max_incidence_deg : float
        As in `worst_sphere_points_per_pass`.

    Returns
    -------
    float
        The rate (deg/s), rounded down to 3 significant digits.
    """

    def usable(rate: float) -> bool:
        n = worst_sphere_points_per_pass(
            rate,
            profile_rate_hz=profile_rate_hz,
            angular_step_deg=angular_step_deg,
            sphere_radius_m=sphere_radius_m,
            sphere_range_m=sphere_range_m,
            sphere_elevation_m=sphere_elevation_m,
            max_incidence_deg=max_incidence_deg,
        )
        return n >= MIN_SPHERE_POINTS_PER_PASS

    # Beyond the disc's width a profile can miss the sphere: no pass above it is usable.
    half = _sphere_disc_rad(sphere_radius_m, sphere_range_m, sphere_elevation_m, max_incidence_deg)
    elevation = math.atan2(sphere_elevation_m, sphere_range_m)
    hi = math.degrees(2.0 * half / math.cos(elevation)) * profile_rate_hz
    lo = hi / 100.0
    if not usable(lo):
        return 0.0
    for _ in range(40):
        mid = math.sqrt(lo * hi)
        lo, hi = (mid, hi) if usable(mid) else (lo, mid)
    digits = 2 - math.floor(math.log10(lo))
    rounded = math.floor(lo * 10.0**digits) / 10.0**digits
    return rounded if usable(rounded) else lo


def too_fast_text(rate_deg_s: float, max_rate_deg_s: float, profile_rate_hz: float) -> str:
    """Why ``rate_deg_s`` (above `max_usable_rate_deg_s`) is refused, for a message.

    Parameters
    ----------
    rate_deg_s : float
        The rate refused (deg/s); its sign does not matter.
    max_rate_deg_s : float
        `max_usable_rate_deg_s` of the scanner and sphere (deg/s); 0 when none is.
    profile_rate_hz : float
        Profiles per second.

    Returns
    -------
    str
        The reason, and the largest usable rate.
    """
    fix = (
        f"the largest usable rate is {max_rate_deg_s:g} deg/s"
        if max_rate_deg_s > 0.0
        else "no rate is, with this angular step and sphere: scan more finely, or use a "
        "larger or nearer sphere"
    )
    return (
        f"at {abs(rate_deg_s):g} deg/s the profiles cross the sphere "
        f"{abs(rate_deg_s) / profile_rate_hz:.3g} deg apart, so a pass may hold fewer than "
        f"{MIN_SPHERE_POINTS_PER_PASS} returns on it, too few for latency sphere to use it; "
        f"{fix}"
    )


def _phase_count(n_profiles: float) -> int:
    """Grid phases averaged over for a pass that crosses the sphere with ``n_profiles``."""
    return int(min(_MAX_PHASES, max(_MIN_PHASES, math.ceil(_PHASE_PROFILES / n_profiles))))


def _pass_information(
    design: TableDesign, rate_deg_s: float, shift: tuple[float, float]
) -> tuple[FloatArray, float]:
    """Expected 4x4 Fisher information (centre, radius) of one pass, and its point count.

    The expectation is over the phase of the profiles and of the beams against the
    sphere, on a rank-1 lattice: phase k of n puts the profiles ``(k + shift[0]) / n``
    of a profile spacing and the beams ``k * golden + shift[1]`` (modulo 1) of an
    angular step off the sphere's centre. A few random phases did not converge at fast
    rates, where a pass crosses the sphere with one or two profiles.
    """
    d = design.sphere_range_m
    r = design.sphere_radius_m
    el_c = math.radians(design.sphere_elevation_deg)
    centre = d / math.cos(el_c) * np.array([math.cos(el_c), 0.0, -math.sin(el_c)])
    dist = float(np.linalg.norm(centre))
    half = math.asin(r / dist)
    d_az = math.radians(rate_deg_s / design.profile_rate_hz)
    d_el = math.radians(design.angular_step_deg)
    cos_cap = math.cos(math.radians(design.max_incidence_deg))
    info = np.zeros((4, 4))
    hits = 0.0
    span_el = half / max(math.cos(el_c), 1e-6)
    n_profiles = 2.1 * half / max(math.cos(el_c), 1e-6) / abs(d_az) + 2
    n_rays = n_profiles * (2.1 * span_el / d_el + 2)
    if n_rays > _MAX_RAYS_PER_PASS:
        msg = (
            f"at {rate_deg_s:g} deg/s a pass would trace {n_rays:.3g} rays over the sphere "
            f"(more than {_MAX_RAYS_PER_PASS:.0e}): the angular step "
            f"({design.angular_step_deg:g} deg) or the profile spacing (rate / profile rate "
            f"= {rate_deg_s / design.profile_rate_hz:g} deg) is too fine; coarsen them"
        )
        raise InputError(msg)
    n_phases = _phase_count(n_profiles)
    for k in range(n_phases):
        phase_az = ((k + shift[0]) / n_phases) % 1.0
        phase_el = (k * _GOLDEN + shift[1]) % 1.0
        az = np.arange(-half * 1.05, half * 1.05, d_az) + phase_az * d_az
        az = az / max(math.cos(el_c), 1e-6)
        el = el_c + np.arange(-span_el * 1.05, span_el * 1.05, d_el) + phase_el * d_el
        a, e = np.meshgrid(az, el, indexing="ij")
        u = np.stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), -np.sin(e)], axis=-1).reshape(
            -1, 3
        )
        b = u @ centre
        disc = b * b - dist * dist + r * r
        hit = disc > 0.0
        u, b, disc = u[hit], b[hit], disc[hit]
        rng_m = b - np.sqrt(disc)
        normal = (u * rng_m[:, None] - centre) / r
        cos = np.abs(np.einsum("ij,ij->i", u, normal))
        hits += float(len(u))
        use = cos >= cos_cap
        g = np.column_stack([normal[use] / cos[use, None], -1.0 / cos[use]])
        info += g.T @ g
    info /= n_phases * design.range_noise_m**2
    return info, hits / n_phases


def _lattice_shift(seed: int, rate_deg_s: float) -> tuple[float, float]:
    """Random shift of a rate's phase lattice, drawn from the seed and the rate alone."""
    rate_bits = int(np.float64(rate_deg_s).view(np.uint64))
    shift = np.random.default_rng([seed, rate_bits]).uniform(0.0, 1.0, 2)
    return float(shift[0]), float(shift[1])


def plan_latency_experiment(design: TableDesign, seed: int = 0) -> LatencyPlan:
    """Cramér-Rao prediction of centre and latency precision for a design.

    Parameters
    ----------
    design : TableDesign
    seed : int
        Seed (>= 0) of the random shift of each rate's lattice of grid phases; a rate's
        figures depend on the seed and that rate only, not on the other rates.

    Returns
    -------
    LatencyPlan

    Raises
    ------
    InputError
        A pass would trace too many rays, or a rate is faster than
        `max_usable_rate_deg_s`: a pass there may hold fewer than
        `MIN_SPHERE_POINTS_PER_PASS` returns on the sphere, and the estimator leaves it
        out (the simulator refuses such a rate too).
    ObservabilityError
        A pass puts too few returns on the sphere, or too narrow a cap, to fit its centre.
    """
    el_c = math.radians(design.sphere_elevation_deg)
    centre = (
        design.sphere_range_m / math.cos(el_c) * np.array([math.cos(el_c), 0.0, -math.sin(el_c)])
    )
    tangential = np.array([0.0, 1.0, 0.0])
    # A rotation error e (NED, iid per axis) moves a pass's sphere by e x c.
    sigma_rad = math.radians(design.pass_attitude_error_deg)
    shared_m2 = sigma_rad**2 * (float(centre @ centre) * np.eye(3) - np.outer(centre, centre))
    max_rate_deg_s = max_usable_rate_deg_s(
        profile_rate_hz=design.profile_rate_hz,
        angular_step_deg=design.angular_step_deg,
        sphere_radius_m=design.sphere_radius_m,
        sphere_range_m=design.sphere_range_m,
        sphere_elevation_m=design.sphere_range_m * math.tan(el_c),
        max_incidence_deg=design.max_incidence_deg,
    )
    rows: list[RatePlan] = []
    for rate in design.rates_deg_s:
        info_pass, per_pass = _pass_information(design, rate, _lattice_shift(seed, rate))
        info = info_pass * design.passes
        used = info if not design.radius_known else info[:3, :3]
        if per_pass < MIN_SPHERE_POINTS_PER_PASS or np.linalg.cond(used) > _MAX_CONDITION:
            msg = (
                f"at {rate:g} deg/s a pass puts {per_pass:.3g} points on the sphere, too few "
                "or too narrow a cap to fit its centre: the sphere is too small or too far "
                f"({design.sphere_radius_m:g} m at {design.sphere_range_m:g} m) for the "
                f"angular step ({design.angular_step_deg:g} deg) and the profile spacing "
                f"({rate / design.profile_rate_hz:g} deg); bring it closer, use a larger "
                "sphere, or scan more finely"
            )
            raise ObservabilityError(msg)
        if rate > max_rate_deg_s:
            raise InputError(too_fast_text(rate, max_rate_deg_s, design.profile_rate_hz))
        cov = np.linalg.inv(info[:3, :3]) if design.radius_known else np.linalg.inv(info)[:3, :3]
        cov = cov + shared_m2 / design.passes  # the pool's mean of passes
        w = math.radians(rate) * np.array([0.0, 0.0, 1.0])
        jac = np.zeros((6, 4))
        jac[:3, :3] = np.eye(3)
        jac[3:, :3] = np.eye(3)
        jac[:3, 3] = -np.cross(w, centre)
        jac[3:, 3] = np.cross(w, centre)
        weight = np.zeros((6, 6))
        weight[:3, :3] = np.linalg.inv(cov)
        weight[3:, 3:] = weight[:3, :3]
        cov_theta = np.linalg.inv(jac.T @ weight @ jac)
        rows.append(
            RatePlan(
                rate_deg_s=rate,
                points_per_pass=per_pass,
                n_points=2.0 * design.passes * per_pass,
                center_std_m=float(np.sqrt(np.trace(cov) / 3.0)),
                center_tangential_std_m=float(np.sqrt(tangential @ cov @ tangential)),
                latency_std_s=float(np.sqrt(cov_theta[3, 3])),
            )
        )
    combined = float(np.sum([1.0 / r.latency_std_s**2 for r in rows]) ** -0.5)
    return LatencyPlan(design=design, per_rate=tuple(rows), latency_std_s=combined)
