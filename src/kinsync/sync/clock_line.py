"""Method B steps 3 to 5: sightings matched to crossings on one clock line, and its fit.

A hypothesis is a line ``t = t0 + T x`` (``x = n + phi / 2 pi``) through two
compatible (sighting, crossing) pairs with a plausible period; `refine_assignment`
takes, for each sighting, the crossing nearest the line within its gate and refits by
weighted least squares until the assignment is stable; `candidate_assignments` gives
every distinct assignment, best first. The matching uses each pair's own sigma
(`pair_timing_std`); the final line is fitted by generalised least squares
(`gls_line`) with the pairs' full covariance (`pair_covariance`: trajectory errors
correlated in time). A sighting may be refined once per compatible crossing (with
that crossing's in-plane drift, `kinsync.sync.sightings.refine_sighting`): the
``per_pair`` sightings then give each pair its own abscissa and sigma. See
`kinsync.sync.object_space` for the whole method.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.linalg import solve_triangular
from scipy.stats import chi2 as chi2_dist

from kinsync._arrays import ReadOnlyArrays
from kinsync._typing import FloatArray, IntArray
from kinsync.errors import PeriodPriorError
from kinsync.frames import wrap_angle_rad
from kinsync.sync.config import ObjectSpaceConfig
from kinsync.sync.crossings import Crossing
from kinsync.sync.scan import ProfileScan
from kinsync.sync.sightings import Sighting, refine_sighting

__all__ = [
    "MODEL_TEST_LEVEL",
    "PERIOD_SEARCH_FACTOR",
    "PERIOD_WINDOW_SIGMA",
    "Assignment",
    "LineFit",
    "LoneMatch",
    "best_assignment",
    "candidate_assignments",
    "check_period_prior",
    "compatible_crossings",
    "gls_line",
    "implied_period_s",
    "lone_matches",
    "pair_covariance",
    "pair_timing_std",
    "position_model_note",
    "refine_assignment",
    "seen_off_the_clock",
    "tracked_sightings",
    "variance_factor",
    "weighted_line",
]


@dataclass(frozen=True, eq=False)
class LineFit(ReadOnlyArrays):
    """Weighted line ``t = t0 + T x``: estimate, a-priori covariance of (t0, T), chi2, residuals."""

    t0_s: float
    period_s: float
    covariance: FloatArray  # a-priori, unscaled
    chi2: float
    residuals_s: FloatArray


def weighted_line(x: FloatArray, t: FloatArray, std: FloatArray) -> LineFit:
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
    return LineFit(t0, T, cov, float(np.sum(w * res * res)), res)


def gls_line(x: FloatArray, t: FloatArray, cov: FloatArray) -> LineFit:
    """Generalised least squares ``t = t0 + T x`` with the full covariance of t.

    Parameters
    ----------
    x : ndarray, shape (m,)
        Clock abscissae ``n + phi / 2 pi`` (profiles).
    t : ndarray, shape (m,)
        Crossing times (s).
    cov : ndarray, shape (m, m)
        Covariance of the times' errors (s^2), symmetric positive definite.

    Returns
    -------
    LineFit
        ``covariance`` is ``(A^T C^-1 A)^-1``, ``chi2`` is ``r^T C^-1 r``.

    Notes
    -----
    With ``C = L L^T`` (Cholesky) the fit is ordinary least squares of ``L^-1 t`` on
    ``L^-1 A``; x is centred and t referred to its first value for conditioning. A
    diagonal ``cov`` gives `weighted_line`.
    """
    var = np.diag(cov)
    try:
        chol = np.linalg.cholesky(cov)
    except np.linalg.LinAlgError:  # positive semi-definite to rounding: a tiny ridge
        chol = np.linalg.cholesky(cov + np.diag(np.full(x.size, 1e-12 * float(np.max(var)))))
    w = 1.0 / var
    xm = float(np.sum(w * x) / np.sum(w))
    t_ref = float(t[0])
    A = np.column_stack([np.ones_like(x), x - xm])
    A_w = solve_triangular(chol, A, lower=True)
    t_w = solve_triangular(chol, t - t_ref, lower=True)
    cov_c = np.linalg.inv(A_w.T @ A_w)
    beta = cov_c @ (A_w.T @ t_w)
    T = float(beta[1])
    t0 = t_ref + (float(beta[0]) - T * xm)
    J = np.array([[1.0, -xm], [0.0, 1.0]])  # (t0, T) from (t at xm, T)
    res = (t - t_ref) - (float(beta[0]) + T * (x - xm))
    res_w = solve_triangular(chol, res, lower=True)
    return LineFit(t0, T, J @ cov_c @ J.T, float(res_w @ res_w), res)


def variance_factor(chi2_gls: float, chi2_own: float, dof: int) -> float:
    """A-posteriori variance factor of the final fit, 1 when the global test passes.

    The residuals widen the covariance only when they are significantly larger (95 %)
    than the full covariance says (``chi2_gls = r^T C^-1 r``) *and* than the pairs'
    own sigmas say (``chi2_own = sum (r_i / sigma_i)^2``), by the smaller factor: a
    misfit of the first kind alone is the correlation being weaker than modelled
    (near-simultaneous sightings differ more than ``rho`` allows), which leaves the
    GLS sigma of t0 and T right (`kinsync.sync.object_space`, step 5).
    """
    if dof <= 0:
        return 1.0
    limit = float(chi2_dist.ppf(0.95, dof))
    if chi2_gls > limit and chi2_own > limit:
        return min(chi2_gls, chi2_own) / dof
    return 1.0


MODEL_TEST_LEVEL = 0.99
"""Level of the test that the sightings scatter as the stated trajectory error allows."""


def position_model_note(chi2_gls: float, dof: int, std_m: float, corr_time_s: float) -> str:
    """A note when the sightings scatter about the clock more than the stated error allows.

    With the trajectory's error understated (8 cm where 2 cm was stated), the sigma of
    t0 and T came out 2-2.5 times too small over 150 drives each (the variance factor
    cannot make up for it from a handful of sightings, and the matching gate drops the
    worst of them); the full-covariance chi2 above its 99 % quantile flagged 70-88 % of
    those drives and none of the drives whose error was stated right.

    Parameters
    ----------
    chi2_gls : float
        ``r^T C^-1 r`` of the final fit.
    dof : int
        Its degrees of freedom (pairs - 2).
    std_m, corr_time_s : float
        The stated trajectory error (m) and its correlation time (s).

    Returns
    -------
    str
        The note, or ``""`` when the test passes (or has no degree of freedom).
    """
    if dof <= 0:
        return ""
    limit = float(chi2_dist.ppf(MODEL_TEST_LEVEL, dof))
    if not chi2_gls > limit:
        return ""
    return (
        f"the sightings scatter about the clock more than a trajectory error of "
        f"{std_m:g} m (correlated over {corr_time_s:g} s) allows: chi2 {chi2_gls:.1f} on "
        f"{dof} dof, above its 99 % quantile {limit:.1f}; the sigma of t0 and T rests on "
        "that error and is too small if the trajectory is worse: give its real error "
        "(--position-std-m, --position-corr-time-s; position_std_m, position_corr_time_s)"
    )


@dataclass(frozen=True)
class Assignment:
    """(sighting, crossing) pairs on one clock line, its fit and its score (lower is better)."""

    pairs: tuple[tuple[int, int], ...]  # (sighting, crossing), sighting order
    fit: LineFit
    score: float


def pair_timing_std(
    sightings: Sequence[Sighting], crossings: Sequence[Crossing], cfg: ObjectSpaceConfig, T: float
) -> FloatArray:
    """Timing sigma (s) of every (sighting, crossing) pair, shape (S, C) (module step 5)."""
    rate = np.array([abs(c.rate_m_s) for c in crossings])
    pos_part = cfg.position_std_m / np.maximum(rate, 1e-3)
    scan_part = np.array([s.profile_std for s in sightings]) * T
    out: FloatArray = np.sqrt(scan_part[:, None] ** 2 + pos_part[None, :] ** 2)
    return out


def pair_covariance(
    sightings: Sequence[Sighting],
    crossings: Sequence[Crossing],
    pairs: Sequence[tuple[int, int]],
    cfg: ObjectSpaceConfig,
    T: float,
) -> FloatArray:
    """Covariance (s^2) of the timing errors of (sighting, crossing) pairs (module step 5).

    ``C_ij = sigma_p^2 rho(t_i - t_j) (m_i . m_j) / (d'_i d'_j) + delta_ij (sigma_x,i T)^2``
    with ``rho(dt) = exp(-|dt| / position_corr_time_s)`` (the identity when the
    correlation time is 0); its diagonal is `pair_timing_std` squared.

    Parameters
    ----------
    sightings, crossings : sequence of Sighting, Crossing
    pairs : sequence of (int, int)
        (sighting, crossing) indices, m pairs.
    cfg : ObjectSpaceConfig
        ``position_std_m`` and ``position_corr_time_s``.
    T : float
        Period (s) that turns the sightings' sub-profile sigma into time.

    Returns
    -------
    ndarray, shape (m, m)
    """
    scan_part = np.array([sightings[i].profile_std for i, _ in pairs]) * T
    cov: FloatArray = np.diag(scan_part**2)
    if cfg.position_std_m > 0.0:
        chosen = [crossings[j] for _, j in pairs]
        rate = np.array([c.rate_m_s for c in chosen])
        rate = np.where(rate < 0.0, -1.0, 1.0) * np.maximum(np.abs(rate), 1e-3)
        g = np.array([c.normal_ecef for c in chosen]) / rate[:, None]  # s/m: dt = g . dp
        t = np.array([c.t_s for c in chosen])
        if cfg.position_corr_time_s > 0.0:
            rho = np.exp(-np.abs(t[:, None] - t[None, :]) / cfg.position_corr_time_s)
        else:
            rho = np.eye(len(chosen))
        cov += cfg.position_std_m**2 * rho * (g @ g.T)
    return cov


PairSightings = Mapping[tuple[int, int], Sighting]
"""A sighting refined for one candidate crossing, keyed by (sighting, crossing) index."""


@dataclass(frozen=True)
class _Compatible:
    """Every compatible (sighting, crossing) pair, flat, sightings in order.

    ``sighting``, ``crossing``: indices; ``x``: the pair's clock abscissa of the
    sighting (profiles); ``t_s``: the crossing's time (s); ``std_s``: the pair's timing
    sigma (s). Within one sighting the crossings keep the order of its ``compat`` entry.
    """

    sighting: IntArray
    crossing: IntArray
    x: FloatArray
    t_s: FloatArray
    std_s: FloatArray

    @classmethod
    def build(
        cls, x: FloatArray, t_c: FloatArray, compat: Sequence[IntArray], std: FloatArray
    ) -> _Compatible:
        """From abscissae ``x`` (shape (S,) or, per pair, (S, C)) and sigmas (S, C)."""
        sighting = np.repeat(np.arange(len(compat), dtype=np.int64), [js.size for js in compat])
        crossing = (
            np.concatenate([np.asarray(js, dtype=np.int64) for js in compat])
            if compat
            else np.zeros(0, dtype=np.int64)
        )
        x_pair = x[sighting] if x.ndim == 1 else x[sighting, crossing]
        return cls(sighting, crossing, x_pair, t_c[crossing], std[sighting, crossing])


def _first_of_groups(keys: IntArray) -> IntArray:
    """Positions where a sorted key array starts a new group."""
    start = np.ones(keys.size, dtype=bool)
    start[1:] = keys[1:] != keys[:-1]
    return np.flatnonzero(start)


def _assign(pairs: _Compatible, t0: float, T: float, cfg: ObjectSpaceConfig) -> IntArray:
    """Indices into ``pairs`` of one assignment to the line ``t = t0 + T x``.

    Each sighting takes its compatible crossing nearest the line (the first of equals),
    kept within ``max(gate_sigma sigma, min_gate_profiles T)``; a crossing claimed by
    several sightings goes to the smallest ``|error| / sigma`` (the first of equals).
    """
    err = np.abs(pairs.t_s - (t0 + T * pairs.x))
    by_sighting = np.lexsort((err, pairs.sighting))  # stable: ties keep compat order
    nearest = by_sighting[_first_of_groups(pairs.sighting[by_sighting])]
    gate = np.maximum(cfg.gate_sigma * pairs.std_s[nearest], cfg.min_gate_profiles * T)
    kept = nearest[err[nearest] <= gate]
    z = err[kept] / pairs.std_s[kept]
    by_crossing = np.lexsort((pairs.sighting[kept], z, pairs.crossing[kept]))
    won: IntArray = kept[by_crossing[_first_of_groups(pairs.crossing[kept][by_crossing])]]
    return won


def refine_assignment(
    seed_t0: float,
    seed_T: float,
    x: FloatArray,
    t_c: FloatArray,
    compat: list[IntArray],
    std: FloatArray,
    cfg: ObjectSpaceConfig,
    period_bounds_s: tuple[float, float] | None = None,
) -> Assignment | None:
    """Iterate one hypothesis (seed t0, T) to a stable assignment, or None (module step 3).

    ``x``: the sightings' abscissae, shape (S,), or each pair's, shape (S, C);
    ``std``: the pairs' timing sigmas (s), shape (S, C). ``period_bounds_s`` (s)
    replaces the prior's window ``period_prior_s (1 +- tol)``.
    """
    pairs = _Compatible.build(x, t_c, compat, std)
    return _refine(seed_t0, seed_T, pairs, cfg, period_bounds_s or _prior_window(cfg))


def _prior_window(cfg: ObjectSpaceConfig) -> tuple[float, float]:
    """Periods (s) within the prior's relative tolerance."""
    return (
        cfg.period_prior_s * (1.0 - cfg.period_tolerance),
        cfg.period_prior_s * (1.0 + cfg.period_tolerance),
    )


def _refine(
    seed_t0: float,
    seed_T: float,
    compatible: _Compatible,
    cfg: ObjectSpaceConfig,
    period_bounds_s: tuple[float, float],
) -> Assignment | None:
    t0, T = seed_t0, seed_T
    lo, hi = period_bounds_s
    previous: tuple[tuple[int, int], ...] | None = None
    for _ in range(10):
        won = _assign(compatible, t0, T, cfg)
        if won.size < 2:
            return None
        xs = compatible.x[won]
        if np.ptp(xs) <= 0.0:
            return None
        chosen_s, chosen_c = compatible.sighting[won].tolist(), compatible.crossing[won].tolist()
        pairs = tuple(sorted(zip(chosen_s, chosen_c, strict=True)))
        if pairs == previous:
            break
        previous = pairs
        order = np.lexsort((compatible.crossing[won], compatible.sighting[won]))
        chosen = won[order]
        fit = weighted_line(compatible.x[chosen], compatible.t_s[chosen], compatible.std_s[chosen])
        t0, T = fit.t0_s, fit.period_s
        if not lo <= T <= hi:
            return None
    assert previous is not None
    prior = ((fit.period_s - cfg.period_prior_s) / (cfg.period_tolerance * cfg.period_prior_s)) ** 2
    return Assignment(pairs=previous, fit=fit, score=fit.chi2 + prior)


def compatible_crossings(
    sightings: Sequence[Sighting], crossings: Sequence[Crossing], cfg: ObjectSpaceConfig
) -> list[IntArray]:
    """Each sighting's compatible crossings (indices, ascending), module step 3.

    A sighting and a crossing are compatible when the sighting's angle and range are
    within ``angle_gate_rad`` and ``range_gate_m`` of the crossing's.
    """
    ang_c = np.array([c.angle_rad for c in crossings])
    rng_c = np.array([c.range_m for c in crossings])
    compat: list[IntArray] = []
    for s in sightings:
        d_ang = np.abs(wrap_angle_rad(ang_c - s.angle_rad))
        ok = (d_ang <= cfg.angle_gate_rad) & (np.abs(rng_c - s.range_m) <= cfg.range_gate_m)
        compat.append(np.flatnonzero(ok).astype(np.int64))
    return compat


def _compatible_pairs(
    sightings: Sequence[Sighting],
    crossings: Sequence[Crossing],
    cfg: ObjectSpaceConfig,
    per_pair: PairSightings | None = None,
) -> tuple[FloatArray, FloatArray, list[IntArray], _Compatible]:
    """Abscissae x (S, C), crossing times, each sighting's compatible crossings, the pairs.

    ``x[i, j]`` is sighting i's abscissa as refined for crossing j (``per_pair``), or
    its own where ``per_pair`` has no entry; the pair's sigma likewise.
    """
    t_c = np.array([c.t_s for c in crossings])
    compat = compatible_crossings(sightings, crossings, cfg)
    std = pair_timing_std(sightings, crossings, cfg, cfg.period_prior_s)
    x = np.repeat(np.array([s.x for s in sightings], dtype=np.float64)[:, None], len(crossings), 1)
    if per_pair:
        keys = list(per_pair)
        refined = [per_pair[key] for key in keys]
        rows = np.array([i for i, _ in keys], dtype=np.int64)
        cols = np.array([j for _, j in keys], dtype=np.int64)
        x[rows, cols] = [s.x for s in refined]
        std[rows, cols] = pair_timing_std(refined, crossings, cfg, cfg.period_prior_s)[
            np.arange(len(keys)), cols
        ]
    return x, t_c, compat, _Compatible.build(x, t_c, compat, std)


def candidate_assignments(
    sightings: Sequence[Sighting],
    crossings: Sequence[Crossing],
    cfg: ObjectSpaceConfig,
    period_bounds_s: tuple[float, float] | None = None,
    per_pair: PairSightings | None = None,
) -> list[Assignment]:
    """Every distinct assignment reached from a two-pair hypothesis, best first.

    Hypotheses and assignments need a period within ``period_bounds_s`` (s), by default
    the prior's window ``period_prior_s (1 +- period_tolerance)``; best is the most
    pairs, then the smallest score. ``per_pair`` (optional) holds a sighting refined
    for one compatible crossing, keyed ``(sighting, crossing)``: that pair takes its
    abscissa and sigma (the sighting's own are the default).
    """
    x, t_c, compat, compatible = _compatible_pairs(sightings, crossings, cfg, per_pair)
    bounds = period_bounds_s or _prior_window(cfg)
    lo, hi = bounds
    found: dict[tuple[tuple[int, int], ...], Assignment] = {}
    # A hypothesis seeded by two pairs of one assignment already found leads back to
    # it: skip those (keeps the search near-linear in the number of assignments).
    member: dict[tuple[int, int], set[int]] = {}
    for i in range(len(sightings)):
        for i2 in range(i + 1, len(sightings)):
            for j in compat[i]:
                for j2 in compat[i2]:
                    # Sightings are in order of their own abscissa; a pair's may differ.
                    dx = x[i2, j2] - x[i, j]
                    if j == j2 or dx == 0.0:
                        continue
                    T = (t_c[j2] - t_c[j]) / dx
                    if not lo <= T <= hi:
                        continue
                    if member.get((i, int(j)), set()) & member.get((i2, int(j2)), set()):
                        continue
                    a = _refine(t_c[j] - T * x[i, j], T, compatible, cfg, bounds)
                    if a is None or a.pairs in found:
                        continue
                    found[a.pairs] = a
                    for pair in a.pairs:
                        member.setdefault(pair, set()).add(len(found))
    return sorted(found.values(), key=lambda a: (-len(a.pairs), a.score))


def _held(
    pairs: _Compatible, starts: IntArray, t0: FloatArray, slope: FloatArray, cfg: ObjectSpaceConfig
) -> IntArray:
    """Sightings with a compatible crossing within the gate of each line ``t0 + slope x``.

    ``starts``: where each sighting's pairs begin in ``pairs``. Lines are taken in
    blocks so that a block's (lines x pairs) arrays stay near a million elements.
    """
    out = np.empty(t0.size, dtype=np.int64)
    block = max(1, 1_000_000 // max(pairs.x.size, 1))
    for lo in range(0, t0.size, block):
        t0_b, slope_b = t0[lo : lo + block, None], slope[lo : lo + block, None]
        err = np.abs(pairs.t_s[None, :] - (t0_b + slope_b * pairs.x[None, :]))
        gate = np.maximum(cfg.gate_sigma * pairs.std_s[None, :], cfg.min_gate_profiles * slope_b)
        out[lo : lo + block] = np.logical_or.reduceat(err <= gate, starts, axis=1).sum(axis=1)
    return out


def best_assignment(
    sightings: Sequence[Sighting],
    crossings: Sequence[Crossing],
    cfg: ObjectSpaceConfig,
    period_bounds_s: tuple[float, float],
    more_than: int,
    per_pair: PairSightings | None = None,
) -> Assignment | None:
    """The assignment with the most pairs, if more than ``more_than``, over a period range.

    Searches the hypotheses of `candidate_assignments` over ``period_bounds_s`` (s),
    typically far wider than the prior's window, but refines only those whose line
    already holds more than ``more_than`` sightings (a compatible crossing within the
    gate of `refine_assignment`): all two-pair lines are checked at once, as arrays,
    and the few strong ones refined, strongest first. A line of m true pairs is seeded
    by m (m - 1) / 2 of its own pairs, the farthest apart within a fraction of a sigma
    of the final line, so it is not missed.

    Parameters
    ----------
    sightings, crossings : sequence of Sighting, Crossing
    cfg : ObjectSpaceConfig
        Gates and sigmas, as for `candidate_assignments`.
    period_bounds_s : (float, float)
        Smallest and largest period (s) of a hypothesis.
    more_than : int
        Assignments of this many pairs or fewer are not wanted.
    per_pair : Mapping of (int, int) to Sighting, optional
        Sightings refined for one compatible crossing, as for `candidate_assignments`.

    Returns
    -------
    Assignment or None
        The one with the most pairs (then the smallest score), None when none has more
        than ``more_than``.
    """
    _, _, _, pairs = _compatible_pairs(sightings, crossings, cfg, per_pair)
    lo, hi = period_bounds_s
    if pairs.x.size < 2:
        return None
    starts = _first_of_groups(pairs.sighting)
    strong: list[tuple[int, int, int, float, float]] = []  # (held, p, q, t0, T)
    for p in range(pairs.x.size - 1):
        q = np.arange(p + 1, pairs.x.size)
        dx = pairs.x[q] - pairs.x[p]
        ok = (pairs.sighting[q] != pairs.sighting[p]) & (pairs.crossing[q] != pairs.crossing[p])
        ok &= dx > 0.0
        with np.errstate(divide="ignore", invalid="ignore"):
            slope = (pairs.t_s[q] - pairs.t_s[p]) / dx
        ok &= (lo <= slope) & (slope <= hi)
        q_ok, slope = q[ok], slope[ok]
        if q_ok.size == 0:
            continue
        t0 = pairs.t_s[p] - slope * pairs.x[p]
        held = _held(pairs, starts, t0, slope, cfg)
        strong.extend(
            (int(held[k]), p, int(q_ok[k]), float(t0[k]), float(slope[k]))
            for k in np.flatnonzero(held > more_than)
        )
    strong.sort(key=lambda seed: -seed[0])
    found: dict[tuple[tuple[int, int], ...], Assignment] = {}
    member: dict[tuple[int, int], set[int]] = {}
    for _, first, second, t0_s, period_s in strong:
        key_p = (int(pairs.sighting[first]), int(pairs.crossing[first]))
        key_q = (int(pairs.sighting[second]), int(pairs.crossing[second]))
        if member.get(key_p, set()) & member.get(key_q, set()):
            continue
        a = _refine(t0_s, period_s, pairs, cfg, period_bounds_s)
        if a is None or a.pairs in found:
            continue
        found[a.pairs] = a
        for pair in a.pairs:
            member.setdefault(pair, set()).add(len(found))
    ranked = sorted(found.values(), key=lambda a: (-len(a.pairs), a.score))
    return ranked[0] if ranked and len(ranked[0].pairs) > more_than else None


def tracked_sightings(
    scan: ProfileScan,
    detected: Sequence[tuple[Sighting, IntArray]],
    crossings: Sequence[Crossing],
    cfg: ObjectSpaceConfig,
) -> PairSightings:
    """Each sighting refitted for each compatible crossing, along its track.

    ``detected``: each sighting with the indices of its returns in ``scan``
    (`kinsync.sync.sightings.detect_clusters`). See `kinsync.sync.object_space`, step 2.

    The target moves relative to the plane as the plane sweeps it (a slanted plane, a
    turn): the detection fit, which cannot know how, was off by up to a profile or two
    on a plane slanted 20-35 deg, on opposite sides of the scan in opposite directions
    (`kinsync.sync.sightings.refine_sighting`). Each candidate crossing's
    `Crossing.point_track` says how, timed with ``period_prior_s`` times a fitted
    scale. A cluster whose detection fit failed (a centroid sighting) is tried too.
    Keyed ``(sighting, crossing)``; empty unless ``refinement`` is ``"sphere"``.
    """
    out: dict[tuple[int, int], Sighting] = {}
    if cfg.refinement != "sphere":
        return out
    compat = compatible_crossings([s for s, _ in detected], crossings, cfg)
    for i, ((_, idx), js) in enumerate(zip(detected, compat, strict=True)):
        for j in js.tolist():
            out[(i, j)] = refine_sighting(scan, idx, cfg, crossings[j].point_track())
    return out


def seen_off_the_clock(
    unmatched: Sequence[Sighting],
    crossings: Sequence[Crossing],
    cfg: ObjectSpaceConfig,
    t0_s: float,
    period_s: float,
) -> tuple[str | None, ...]:
    """For each unmatched sighting, the sync point it is a sighting of by the clock, or None.

    ``(t0_s, period_s)``: the clock (s).

    A crossing compatible with the sighting (angle and range) that the clock ``(t0_s,
    period_s)`` puts within the sighting's profiles (one either side): the target was
    seen when the plane crossed it, yet its sub-profile position fits no clock line.
    Of several, the one nearest the line.
    """
    out: list[str | None] = []
    for s, js in zip(unmatched, compatible_crossings(unmatched, crossings, cfg), strict=True):
        n_c = {j: (crossings[j].t_s - t0_s) / period_s - s.angle_rad / math.tau for j in js}
        inside = [j for j, n in n_c.items() if s.first_profile - 1 <= n <= s.last_profile + 1]
        out.append(
            crossings[min(inside, key=lambda j: abs(n_c[j] - s.profile))].name if inside else None
        )
    return tuple(out)


@dataclass(frozen=True)
class LoneMatch:
    """A sighting matched alone to a compatible crossing: a clock two pairs cannot rule out.

    ``sighting``, ``crossing``: indices; ``x``: the sighting's abscissa (profiles);
    ``t_s``: the crossing's time (s).
    """

    sighting: int
    crossing: int
    x: float
    t_s: float

    def t0_s(self, period_s: float) -> float:
        """The clock's t0 (s) with the period ``period_s`` (s)."""
        return self.t_s - period_s * self.x


def lone_matches(
    sightings: Sequence[Sighting],
    crossings: Sequence[Crossing],
    best: Assignment,
    cfg: ObjectSpaceConfig,
    per_pair: PairSightings | None = None,
) -> list[LoneMatch]:
    """Sightings left out of a two-pair clock that could be the sync points instead.

    Two pairs always fit a line, so a clock from two is checked by nothing; when it
    leaves a sighting unmatched that lies where the geometry puts a sync point
    (compatible in angle and range) but off its line (beyond the gate of
    `refine_assignment`), that sighting matched alone, with a period in the prior's
    window, is another clock the data cannot rule out. On an oval drive two targets
    at one distance from the track, one lap apart, fitted a line 132 s late while the
    one true sighting of the sync point was left out (see `kinsync.sync.object_space`,
    step 3).

    Parameters
    ----------
    sightings, crossings : sequence of Sighting, Crossing
    best : Assignment
        The clock (its matching fit) and the pairs it holds.
    cfg : ObjectSpaceConfig
        Gates, sigmas and ``period_prior_s``.
    per_pair : Mapping of (int, int) to Sighting, optional
        Sightings refined for one compatible crossing, as for `candidate_assignments`.

    Returns
    -------
    list of LoneMatch
        In sighting order, then crossing order.
    """
    used = {i for i, _ in best.pairs}
    pairs = per_pair or {}
    t0, T = best.fit.t0_s, best.fit.period_s
    out: list[LoneMatch] = []
    for i, js in enumerate(compatible_crossings(sightings, crossings, cfg)):
        if i in used:
            continue
        for j in js.tolist():
            s = pairs.get((i, j), sightings[i])
            std = float(pair_timing_std([s], [crossings[j]], cfg, T)[0, 0])
            gate = max(cfg.gate_sigma * std, cfg.min_gate_profiles * T)
            if abs(crossings[j].t_s - (t0 + T * s.x)) > gate:  # not this clock's crossing
                out.append(LoneMatch(i, j, s.x, crossings[j].t_s))
    return out


PERIOD_SEARCH_FACTOR = 2.5
"""Periods from ``prior / factor`` to ``prior * factor`` are searched for a clock that fits
more sightings than the prior's window allows (`kinsync.sync.object_space`, step 3, a
wrong prior; `check_period_prior`): a prior off by a factor of two (profiles per mirror
revolution, a datasheet's line rate for its revolution rate) is still caught."""


PERIOD_WINDOW_SIGMA = 3.0
"""A clock whose estimated period lies outside the prior's window by at most this many of
its a-priori sigmas is the window's own (`check_period_prior`): with 8 cm trajectory errors
stated as 2 cm, a true period 0.84 % from the prior was estimated 1.0085 % off and refused
at a 1 % tolerance, suggesting a prior the true period did not need."""

IMPLIED_PERIOD_PAIRS = 6
"""Sighting pairs that must agree (within `IMPLIED_PERIOD_AGREE`) on one period before
`implied_period_s` gives it: four sightings of one clock make six pairs."""

IMPLIED_PERIOD_AGREE = 0.01
"""Relative spread of the periods of pairs that agree (`implied_period_s`)."""

IMPLIED_PERIOD_SPAN = 1.05
"""`check_period_prior` searches within this factor of the implied period (the median
of agreeing pairs, each off by its sightings' timing errors)."""


def implied_period_s(
    sightings: Sequence[Sighting],
    crossings: Sequence[Crossing],
    cfg: ObjectSpaceConfig,
    per_pair: PairSightings | None = None,
) -> float | None:
    """The period most sighting pairs agree on, whatever the prior (s), or None.

    Each two compatible (sighting, crossing) pairs of other sightings and crossings, the
    sightings at least a profile apart (abscissae ``x_p < x_q``, times ``t_p < t_q``),
    imply the period ``(t_q - t_p) / (x_q - x_p)``, as the hypotheses of
    `best_assignment` do; the true clock makes every pair of its own sightings agree.
    The crossings come from the geometry alone, so this finds a prior given in the
    wrong unit (30.3 for 0.0303 s), far beyond `PERIOD_SEARCH_FACTOR`.

    Parameters
    ----------
    sightings, crossings : sequence of Sighting, Crossing
    cfg : ObjectSpaceConfig
        The gates of `compatible_crossings`.
    per_pair : Mapping of (int, int) to Sighting, optional
        Sightings refined for one compatible crossing, as for `candidate_assignments`.

    Returns
    -------
    float or None
        The median period (s) of the largest group of pairs within
        `IMPLIED_PERIOD_AGREE` of each other, when it holds `IMPLIED_PERIOD_PAIRS` or
        more; else None.
    """
    _, _, _, pairs = _compatible_pairs(sightings, crossings, cfg, per_pair)
    dx = pairs.x[None, :] - pairs.x[:, None]
    dt = pairs.t_s[None, :] - pairs.t_s[:, None]
    ok = (pairs.sighting[None, :] != pairs.sighting[:, None]) & (dx >= 1.0) & (dt > 0.0)
    ok &= pairs.crossing[None, :] != pairs.crossing[:, None]
    periods = np.sort(dt[ok] / dx[ok])
    if periods.size < IMPLIED_PERIOD_PAIRS:
        return None
    support = np.searchsorted(periods, periods * (1.0 + IMPLIED_PERIOD_AGREE), side="right")
    support -= np.arange(periods.size)
    k = int(np.argmax(support))
    if support[k] < IMPLIED_PERIOD_PAIRS:
        return None
    return float(np.median(periods[k : k + support[k]]))


def check_period_prior(
    ranked: Sequence[Assignment],
    sightings: Sequence[Sighting],
    crossings: Sequence[Crossing],
    cfg: ObjectSpaceConfig,
    per_pair: PairSightings | None = None,
) -> Assignment | None:
    """Raise `PeriodPriorError` when a period outside the prior's window fits more sightings.

    See `kinsync.sync.object_space`, step 3, a wrong prior: the search runs over periods
    within a factor `PERIOD_SEARCH_FACTOR` of ``period_prior_s``; a line must hold more
    sightings than the best within the window and at least three. When it finds none,
    and the period the sighting pairs agree on (`implied_period_s`) lies beyond that
    factor (a prior in the wrong unit), the search runs again around it.

    Parameters
    ----------
    ranked : sequence of Assignment
        The assignments within the prior's window, best first (`candidate_assignments`).
    sightings, crossings : sequence of Sighting, Crossing
    cfg : ObjectSpaceConfig
        ``period_prior_s``, ``period_tolerance``, gates and sigmas.
    per_pair : Mapping of (int, int) to Sighting, optional
        Sightings refined for one compatible crossing, as for `candidate_assignments`.

    Returns
    -------
    Assignment or None
        One that fits more sightings than ``ranked[0]`` with a period within the window,
        or outside it by at most `PERIOD_WINDOW_SIGMA` of its a-priori sigma: the window's
        own clock, which the window's search missed (its period estimated just outside,
        or not reached from its seeds); None when there is none.

    Raises
    ------
    PeriodPriorError
        A period outside the window fits more sightings, and at least three, and lies
        beyond it by more than `PERIOD_WINDOW_SIGMA` of its sigma.
    """
    prior, tol = cfg.period_prior_s, cfg.period_tolerance
    n_in = len(ranked[0].pairs) if ranked else 0
    bounds = (prior / PERIOD_SEARCH_FACTOR, prior * PERIOD_SEARCH_FACTOR)
    wider = best_assignment(
        sightings, crossings, cfg, bounds, more_than=max(n_in, 2), per_pair=per_pair
    )
    implied = None if wider is not None else implied_period_s(sightings, crossings, cfg, per_pair)
    if implied is not None and not bounds[0] <= implied <= bounds[1]:  # a unit mistake
        near = (implied / IMPLIED_PERIOD_SPAN, implied * IMPLIED_PERIOD_SPAN)
        wider = best_assignment(
            sightings, crossings, cfg, near, more_than=max(n_in, 2), per_pair=per_pair
        )
    if wider is None:
        return None
    period = wider.fit.period_s
    off = period / prior - 1.0
    if abs(off) <= tol + PERIOD_WINDOW_SIGMA * math.sqrt(wider.fit.covariance[1, 1]) / prior:
        return wider  # the window's own clock (its estimate may lie just outside): take it
    widen = (
        f", or widen --period-tolerance to {math.ceil(abs(off) * 100.0) / 100.0:g}"
        if abs(off) < 0.49  # the tolerance must stay below 0.5
        else ""
    )
    ratio = period / prior
    how_far = (
        f"{off * 100.0:+.1f} %"
        if 1.0 / PERIOD_SEARCH_FACTOR <= ratio <= PERIOD_SEARCH_FACTOR
        else (f"{ratio:.4g} times it" if ratio > 1.0 else f"1/{1.0 / ratio:.4g} of it")
        + ": the prior is seconds per profile, e.g. 0.0303 for 33 rev/s"
    )
    msg = (
        f"--period-prior-s {prior:g} s: {n_in} of {len(sightings)} sightings fit a clock "
        f"with a period within {tol * 100.0:g} % of it, {len(wider.pairs)} fit one with a "
        f"period of {period:.6g} s ({how_far}): give the mirror period from "
        f"the scanner's datasheet or log (these data suggest --period-prior-s {period:.6g})" + widen
    )
    raise PeriodPriorError(
        msg,
        period_prior_s=prior,
        n_within=n_in,
        n_sightings=len(sightings),
        suggested_period_s=period,
        n_suggested=len(wider.pairs),
    )
