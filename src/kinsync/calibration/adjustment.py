"""The least-squares adjustment: mount parameters with the features as nuisances.

Every return ``i`` on feature ``k`` gives one residual ``e_i`` (its signed distance to
the feature, m). Gauss-Newton on the mount parameters ``theta`` (the estimated subset
of `kinsync.calibration.parameters`) and every feature's parameters ``f_k``, with the
features eliminated by their Schur complement, as in bundle adjustment::

    A = J_t' W J_t,   B_k = J_t' W J_k,   C_k = J_k' W J_k
    S = A - sum_k B_k C_k^-1 B_k'              (the reduced normal matrix of theta)
    S dtheta = -(g_t - sum_k B_k C_k^-1 g_k)   (g = J' W e)
    df_k = -C_k^-1 (g_k + B_k' dtheta)

with Levenberg-Marquardt damping of ``S`` when a step does not lower the weighted
cost. Weights are iteratively reweighted (each state's weights held through its step,
then held for good once the steps are small): each feature gets its own noise scale
(1.4826 MAD of its residuals, `kinsync.robust`; ground, walls and spheres differ) and
Tukey's biweight (c = 4.685) sets vegetation, cars and stray returns aside. On a
plane the biweight reads each return's residual about its own line's fit of the plane
(offset and tilt, fitted robustly to that line's returns alone): a line that sits a few
centimetres off (a navigation error), or drifts by a few millimetres while it crosses
the plane (a navigation error that changes in the seconds the plane is seen), keeps
its weight, so the estimate is a smooth function of every line's data and the
jackknife over lines (`kinsync.calibration.uncertainty`) sees its real spread.
(Weighting on the raw residuals sets such lines aside, and the jackknife then
overstated the boresight sigma up to 1.7 times on the simulated patch tests. About the
line's median alone, a 1 mm scanner on a vehicle with 2 cm navigation errors set aside
the ends of a line's drift across the ground: 1 % of the returns, but the ones that
tell the roll boresight, whose spread was 2.8 times that of plain least squares.)

A damped step damps the features' response too (``C_k + lambda diag(C_k)``): a
feature started far from its returns (a sphere at the mean of scattered sightings)
otherwise makes every damped step's cost worse, and the adjustment stopped where it
started. The latency stays within what the lines' trajectories cover
(`latency_bounds`; the trajectory is never extrapolated): a step beyond is cut at the
bound and the other parameters solved given it, and a solution on the bound is flagged
(``Adjustment.at_bound``), for it is no minimum. A return pushed out of its trajectory
costs as much as one at the edge of Tukey's band, and a solution that uses no return of
a feature is an error, never a fit of nothing.

``S`` is also the information the data hold about ``theta`` once the features are
free: `kinsync.calibration.observability` reads it before the final solution, and the
formal covariance is ``sigma0^2 S^-1``.

References
----------
Triggs, B., McLauchlan, P., Hartley, R., Fitzgibbon, A., "Bundle adjustment - a modern
synthesis", Vision Algorithms: Theory and Practice, LNCS 1883, 2000, 298-372.
Holland, P. W. & Welsch, R. E., "Robust regression using iteratively reweighted
least-squares", Commun. Stat. Theory Methods 6(9), 1977, 813-827.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from kinsync._arrays import ReadOnlyArrays
from kinsync._typing import BoolArray, FloatArray, IntArray
from kinsync.calibration.features import Feature
from kinsync.calibration.line_detrend import detrend_lines
from kinsync.calibration.model import LineModel, LocalFrame
from kinsync.calibration.parameters import LATENCY
from kinsync.errors import ConvergenceError, ObservabilityError
from kinsync.robust import robust_sigma

__all__ = [
    "LATENCY_BOUND_TOLERANCE_S",
    "Adjustment",
    "AdjustmentOptions",
    "FeatureFit",
    "FeatureReturns",
    "Observation",
    "ObservationLayout",
    "adjust",
    "georeference_observed",
    "incidence_factor",
    "latency_bounds",
    "reduced_normal_matrix",
]

_TUKEY_C = 4.685
_FREEZE_STEP = 0.1  # steps below this many formal sigmas: the robust weights are held
_DAMPING_TRIES = 8  # Levenberg-Marquardt: dampings per step, the current one then x10 each
_MIN_WITHIN_SCALE_M = 2e-4  # floor of the within-line noise scale (m)
_MIN_LINE_FIT = 12  # returns of a line on a plane needed to fit its own plane
_LINE_FIT_ITERATIONS = 3  # reweighted fits of a line's own plane
LATENCY_BOUND_TOLERANCE_S = 1e-6
"""A latency this close to `latency_bounds` (s) is on the bound."""
MIN_INCIDENCE_FACTOR = 0.05
"""Floor of ``|cos(incidence)|`` in the noise model: grazing returns are not trusted more."""


@dataclass(frozen=True, eq=False)
class Observation(ReadOnlyArrays):
    """The returns of one line on one feature.

    Attributes
    ----------
    line : int
        Index of the line (in the adjustment's line models).
    feature : int
        Index of the feature.
    index : ndarray of int, shape (n,)
        The returns of the line that lie on the feature (thinned).
    """

    line: int
    feature: int
    index: IntArray


@dataclass(frozen=True)
class AdjustmentOptions:
    """Iteration settings.

    Attributes
    ----------
    max_iterations : int
        Gauss-Newton iterations at most.
    reweight_iterations : int
        Iterations at most with the robust weights recomputed; they are then held
        (earlier when the steps become small) and Gauss-Newton converges on one cost.
    step_tolerance : float
        Converged when every parameter's step is below this fraction of its formal
        standard deviation, or when the steps are below a tenth of it and the cost no
        longer drops (the latency's numerical derivative leaves steps of ~1e-3 sigma
        that are noise, not progress).
    noise_floor_m : float
        Smallest per-feature range-noise scale (m): a feature fitted better than this
        is not trusted more.
    robust : bool
        Tukey weights (True) or plain least squares.
    """

    max_iterations: int = 40
    reweight_iterations: int = 12
    step_tolerance: float = 1e-2
    noise_floor_m: float = 2e-4
    robust: bool = True


@dataclass(frozen=True, eq=False)
class FeatureFit:
    """A feature after the adjustment, with its residual statistics.

    Attributes
    ----------
    feature : Feature
        The fitted feature.
    n_points : int
        Returns used (weight > 0).
    n_lines : int
        Lines that see it.
    sigma_m : float
        Its noise scale (robust sigma of the residuals, m).
    rms_m : float
        RMS of the residuals of the returns used (m).
    """

    feature: Feature
    n_points: int
    n_lines: int
    sigma_m: float
    rms_m: float


@dataclass(frozen=True, eq=False)
class Adjustment(ReadOnlyArrays):
    """The solution of one adjustment.

    Attributes
    ----------
    values : ndarray, shape (7,)
        All seven mount parameters (rad, m, s): the estimated ones solved, the others
        as given.
    estimated : tuple of int
        The parameters solved for.
    features : tuple of FeatureFit
        Every feature, fitted.
    normal_matrix : ndarray, shape (k, k)
        Reduced normal matrix ``S`` at the solution (weights 1 / sigma_k^2).
    raw_information : ndarray, shape (k,)
        Each parameter's motion information ``sum_i w_i |d x_i / d theta|^2``: what
        the returns' full 3-D motion would tell if every direction were seen.
    sigma0 : float
        A-posteriori unit-weight standard deviation.
    covariance : ndarray, shape (k, k)
        Formal covariance ``sigma0^2 S^-1`` (internal units).
    iterations : int
        Gauss-Newton iterations done.
    n_points : int
        Returns with a non-zero weight.
    latency_bounds_s : tuple of 2 float or None
        The latencies (s) for which every observed return stays inside its trajectory
        (`latency_bounds`); None when the latency is not estimated.
    at_bound : bool
        The latency ended on one of those bounds: the data pushed it out of the span
        their trajectories cover, so it is no minimum of the cost and not determined.
    """

    values: FloatArray
    estimated: tuple[int, ...]
    features: tuple[FeatureFit, ...]
    normal_matrix: FloatArray
    raw_information: FloatArray
    sigma0: float
    covariance: FloatArray
    iterations: int
    n_points: int
    latency_bounds_s: tuple[float, float] | None = None
    at_bound: bool = False


@dataclass(frozen=True, eq=False)
class FeatureReturns(ReadOnlyArrays):
    """One feature's returns and where they came from.

    Positions (n, 3), mount Jacobians (n, 3, k), beams (n, 3), and which of the
    feature's observations (lines) each return belongs to, (n,).
    """

    x: FloatArray
    jac: FloatArray
    beam: FloatArray
    group: IntArray


@dataclass
class _Assembled:
    cost: float
    S: FloatArray
    rhs: FloatArray
    A_diag: FloatArray  # motion information, see Adjustment.raw_information
    blocks: list[tuple[FloatArray, FloatArray, FloatArray]]  # per feature: B_k, C_k, g_k
    n_used: int
    dof_features: int


def _tukey_rho(u: FloatArray) -> FloatArray:
    """Tukey's biweight loss, bounded: ``c^2/6 (1 - (1 - (u/c)^2)^3)``, ``c^2/6`` beyond c."""
    z = np.minimum((u / _TUKEY_C) ** 2, 1.0)
    out: FloatArray = _TUKEY_C**2 / 6.0 * (1.0 - (1.0 - z) ** 3)
    return out


def _tukey(u: FloatArray) -> FloatArray:
    out: FloatArray = np.where(np.abs(u) < _TUKEY_C, (1.0 - (u / _TUKEY_C) ** 2) ** 2, 0.0)
    return out


def _georeference_points(
    models: Sequence[LineModel],
    by_line: dict[int, IntArray],
    values: FloatArray,
    frame: LocalFrame,
) -> dict[int, tuple[FloatArray, FloatArray, FloatArray]]:
    """As `georeference_observed` without the Jacobians (shape (n, 3, 0)), for costs."""
    out = {}
    for li, idx in by_line.items():
        x, beam = models[li].points_and_beams(idx, values, frame)
        out[li] = (x, np.zeros((x.shape[0], 3, 0)), beam)
    return out


def georeference_observed(
    models: Sequence[LineModel],
    by_line: dict[int, IntArray],
    values: FloatArray,
    estimated: tuple[int, ...],
    frame: LocalFrame,
) -> dict[int, tuple[FloatArray, FloatArray, FloatArray]]:
    """Per line: its observed returns' positions, mount Jacobians and beams (`LineModel`)."""
    out = {}
    for li, idx in by_line.items():
        out[li] = models[li].points_and_jacobian(idx, values, estimated, frame)
    return out


class ObservationLayout:
    """Observations grouped for assembly: per line the returns used, per feature its slices."""

    def __init__(
        self, models: Sequence[LineModel], observations: Sequence[Observation], n_features: int
    ) -> None:
        self.models = models
        per_line: dict[int, list[IntArray]] = {}
        for obs in observations:
            per_line.setdefault(obs.line, []).append(obs.index)
        self.by_line = {li: np.concatenate(parts) for li, parts in per_line.items()}
        # Where each observation's returns sit in its line's concatenated block.
        starts: dict[int, int] = dict.fromkeys(per_line, 0)
        self.slices: list[tuple[int, int, slice]] = []  # (feature, line, slice)
        for obs in observations:
            s0 = starts[obs.line]
            self.slices.append((obs.feature, obs.line, slice(s0, s0 + obs.index.size)))
            starts[obs.line] = s0 + obs.index.size
        self.n_features = n_features
        self.lines_of_feature = [
            len({li for f, li, _ in self.slices if f == k}) for k in range(n_features)
        ]

    def gather(
        self, geo: dict[int, tuple[FloatArray, FloatArray, FloatArray]]
    ) -> list[FeatureReturns]:
        """Per feature: its returns, their mount Jacobians and their beam directions."""
        parts: list[list[tuple[FloatArray, FloatArray, FloatArray]]] = [
            [] for _ in range(self.n_features)
        ]
        for f, li, sl in self.slices:
            x, jac, beam = geo[li]
            parts[f].append((x[sl], jac[sl], beam[sl]))
        k = next(iter(geo.values()))[1].shape[2] if geo else 0
        out = []
        for p in parts:
            if not p:
                empty = np.zeros(0, dtype=np.int64)
                out.append(
                    FeatureReturns(np.empty((0, 3)), np.empty((0, 3, k)), np.empty((0, 3)), empty)
                )
            else:
                group = np.concatenate([np.full(len(a), g) for g, (a, _, _) in enumerate(p)])
                out.append(
                    FeatureReturns(
                        np.concatenate([a for a, _, _ in p]),
                        np.concatenate([b for _, b, _ in p]),
                        np.concatenate([c for _, _, c in p]),
                        group.astype(np.int64),
                    )
                )
        return out


def incidence_factor(feature: Feature, ret: FeatureReturns) -> FloatArray:
    """``max(|cos(incidence)|, MIN_INCIDENCE_FACTOR)`` of each return on the feature."""
    return _at_state(feature, ret).inc


@dataclass(frozen=True)
class _AtState:
    """One feature's returns evaluated at one state of the adjustment.

    ``ok`` (n,): the position is finite (inside its trajectory); ``xs`` (n, 3): the
    positions, the feature's anchor where not ok (local frame, m); ``e`` (n,): the
    residuals, 0 where not ok (m); ``inc`` (n,): `incidence_factor`.
    """

    ok: BoolArray
    xs: FloatArray
    e: FloatArray
    inc: FloatArray


def _at_state(feature: Feature, ret: FeatureReturns) -> _AtState:
    """Residuals and incidence factors of a feature's returns, computed once per state."""
    ok = np.all(np.isfinite(ret.x), axis=1)
    xs = np.where(ok[:, None], ret.x, feature.anchor_m)
    e = np.where(ok, feature.residuals(xs), 0.0)
    cos = np.abs(np.einsum("ni,ni->n", feature.gradient_x(xs), np.nan_to_num(ret.beam)))
    return _AtState(ok, xs, e, np.maximum(cos, MIN_INCIDENCE_FACTOR))


def _line_detrended(feature: Feature, at: _AtState, group: IntArray) -> FloatArray:
    """Residuals about their own line's (observation's) fit of the plane, shape (n,).

    Each line with at least `_MIN_LINE_FIT` returns on the plane gets its own offset and
    tilt (the plane's three parameters, ``feature.jacobian``), fitted by least squares
    reweighted with Tukey's biweight (`_LINE_FIT_ITERATIONS` times, from the line's
    median): a drift of the line across the plane, a navigation error that changes
    while the plane is seen, leaves no residual, while a car or a bush stays off the
    line's fit. A line with fewer returns is centred on its median. ``group`` holds each
    line's returns in one run, as `ObservationLayout.gather` makes it. Compiled:
    `kinsync.calibration.line_detrend`.
    """
    return detrend_lines(
        at.e,
        at.ok,
        feature.jacobian(at.xs),
        group,
        min_fit=_MIN_LINE_FIT,
        iterations=_LINE_FIT_ITERATIONS,
        tukey_c=_TUKEY_C,
        min_scale_m=_MIN_WITHIN_SCALE_M,
    )


def _robust_factors(
    feature: Feature, ret: FeatureReturns, sigma: float, robust: bool, at: _AtState | None = None
) -> FloatArray:
    """Tukey weights (0..1) of a feature's returns at their current residuals.

    On a plane the residuals are taken about their own line's fit of it
    (`_line_detrended`) and scaled by their robust spread there: a return is set aside
    for lying off its own line's surface (vegetation, a car, a stray echo), never
    because its whole line sits a few centimetres off or drifts across the plane (a
    navigation error, which the jackknife accounts for). On a sphere a line's offset
    is no constant residual: the residuals and the feature's noise scale ``sigma`` are
    used as they are. ``at``: the returns already evaluated at this state (computed
    here when None).
    """
    at = at if at is not None else _at_state(feature, ret)
    ok = at.ok
    if not robust:
        flags: FloatArray = ok.astype(np.float64)
        return flags
    if feature.kind == "plane":
        u = _line_detrended(feature, at, ret.group) / at.inc
        scale = max(robust_sigma(u[ok]) if np.any(ok) else sigma, _MIN_WITHIN_SCALE_M)
    else:
        u, scale = at.e / at.inc, sigma
    out: FloatArray = np.where(ok, _tukey(u / scale), 0.0)
    return out


def _weights(at: _AtState, sigma: float, factor: FloatArray) -> FloatArray:
    """Least-squares weights ``factor / (sigma inc)^2`` (0 outside the trajectory)."""
    scale = sigma * at.inc
    out: FloatArray = np.where(at.ok, factor / scale**2, 0.0)
    return out


def _feature_cost(at: _AtState, sigma: float, robust: bool, frozen: FloatArray | None) -> float:
    """One feature's share of the cost the Levenberg-Marquardt steps compare.

    With robust weights not held, the bounded loss (Tukey's rho, its ceiling for a
    return outside the trajectory); else the weighted squares with ``frozen`` (or,
    not robust, unit factors), and for a return outside the trajectory its factor
    times ``c^2`` (the square of a residual at the edge of Tukey's band). A return
    pushed out of its trajectory must cost, never save: with its weight held and no
    residual, it used to cost nothing, and on four CIDCO passes one undamped step took
    the latency to -945 ms, moved every return out of its pass's trajectory, and the
    cost of zero was taken for a converged solution with no return used.
    """
    if robust and frozen is None:
        scale = sigma * at.inc
        rho = np.where(at.ok, _tukey_rho(at.e / scale), _TUKEY_C**2 / 6.0)
        return float(np.sum(rho))
    factor = frozen if frozen is not None else np.ones(at.ok.size)
    w = _weights(at, sigma, factor)
    lost = float(np.sum(np.where(at.ok, 0.0, factor))) * _TUKEY_C**2
    return float(np.sum(w * at.e * at.e)) + lost


def _feature_terms(
    feature: Feature,
    ret: FeatureReturns,
    sigma: float,
    robust: bool,
    frozen: FloatArray | None,
    at: _AtState | None = None,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Residuals, weights, mount Jacobian (n, k) and feature Jacobian (n, q) of one feature.

    ``frozen``: robust weights held from an earlier state (None: computed here);
    ``at``: the returns already evaluated at this state (computed here when None).
    """
    at = at if at is not None else _at_state(feature, ret)
    grad = feature.gradient_x(at.xs)
    jt = np.einsum("ni,nik->nk", grad, np.where(at.ok[:, None, None], ret.jac, 0.0))
    jf = feature.jacobian(at.xs)
    factor = _robust_factors(feature, ret, sigma, robust, at) if frozen is None else frozen
    return at.e, _weights(at, sigma, factor), jt, jf


def _cost(
    features: Sequence[Feature],
    gathered: list[FeatureReturns],
    sigmas: Sequence[float],
    robust: bool,
    frozen: Sequence[FloatArray] | None,
) -> float:
    """The cost `_assemble` would give at this state, without the normal equations."""
    cost = 0.0
    for i, (feature, ret, sigma) in enumerate(zip(features, gathered, sigmas, strict=True)):
        held = None if frozen is None else frozen[i]
        cost += _feature_cost(_at_state(feature, ret), sigma, robust, held)
    return cost


def _assemble(
    features: Sequence[Feature],
    gathered: list[FeatureReturns],
    sigmas: Sequence[float],
    robust: bool,
    k: int,
    frozen: Sequence[FloatArray] | None = None,
    weights: Sequence[FloatArray] | None = None,
    states: Sequence[_AtState] | None = None,
) -> _Assembled:
    """The normal equations, features eliminated, and the cost.

    ``frozen``: robust weights held (the cost is the weighted squares), else the cost
    is the bounded loss; ``weights``: the robust weights to use (default ``frozen``, or
    computed at this state); ``states``: the returns already evaluated at this state.
    """
    use = weights if weights is not None else frozen
    A = np.zeros((k, k))
    g_t = np.zeros(k)
    S = np.zeros((k, k))
    rhs = np.zeros(k)
    blocks = []
    motion = np.zeros(k)
    cost = 0.0
    n_used = 0
    dof_features = 0
    for i, (feature, ret, sigma) in enumerate(zip(features, gathered, sigmas, strict=True)):
        at = _at_state(feature, ret) if states is None else states[i]
        held = None if use is None else use[i]
        e, w, jt, jf = _feature_terms(feature, ret, sigma, robust, held, at)
        motion += np.einsum("n,ndk->k", w, np.nan_to_num(ret.jac) ** 2)
        cost += _feature_cost(at, sigma, robust, None if frozen is None else frozen[i])
        wjt = jt * w[:, None]
        A_k = jt.T @ wjt
        B_k = wjt.T @ jf
        C_k = jf.T @ (jf * w[:, None])
        gt_k = wjt.T @ e
        gf_k = jf.T @ (w * e)
        A += A_k
        g_t += gt_k
        try:
            Ci_B = np.linalg.solve(C_k, B_k.T)
            Ci_g = np.linalg.solve(C_k, gf_k)
        except np.linalg.LinAlgError:
            Ci_B = np.linalg.lstsq(C_k, B_k.T, rcond=None)[0]
            Ci_g = np.linalg.lstsq(C_k, gf_k, rcond=None)[0]
        S += A_k - B_k @ Ci_B
        rhs += gt_k - B_k @ Ci_g
        blocks.append((B_k, C_k, gf_k))
        used = int(np.count_nonzero(w > 0.0))
        n_used += used
        dof_features += feature.n_params if used else 0
    return _Assembled(cost, S, rhs, motion, blocks, n_used, dof_features)


def _scales(
    states: Sequence[_AtState], floor: float, previous: Sequence[float] | None
) -> list[float]:
    """Each feature's range-noise scale: robust sigma of ``e / |cos(incidence)|``."""
    out = []
    for i, at in enumerate(states):
        e = at.e[at.ok] / at.inc[at.ok] if np.any(at.ok) else np.zeros(1)
        s = robust_sigma(e)
        if previous is not None and math.isfinite(previous[i]):
            # The scale shrinks as the mount converges but never jumps up by more than
            # 2x in one iteration: a bad step cannot switch a whole feature off.
            s = min(s, 2.0 * previous[i]) if s > previous[i] else s
        out.append(max(float(s), floor))
    return out


def _solve(S: FloatArray, rhs: FloatArray, damping: float) -> FloatArray:
    d = np.diag(S).copy()
    d[d <= 0.0] = 1.0
    out: FloatArray
    try:
        out = np.asarray(-np.linalg.solve(S + damping * np.diag(d), rhs), dtype=np.float64)
        return out
    except np.linalg.LinAlgError:
        pass
    try:  # numerically singular without damping: a touch of it
        out = np.asarray(
            -np.linalg.solve(S + max(damping, 1e-9) * np.diag(d), rhs), dtype=np.float64
        )
        return out
    except np.linalg.LinAlgError as err:
        msg = "the calibration's normal matrix is singular: a parameter is not determined"
        raise ObservabilityError(msg) from err


def latency_bounds(
    models: Sequence[LineModel], by_line: dict[int, IntArray]
) -> tuple[float, float]:
    """The latencies (s) for which every observed return stays inside its trajectory.

    The trajectory is never extrapolated: a latency beyond these bounds loses returns,
    and a pass file that carries its trajectory only a few tens of milliseconds beyond
    its returns (the CIDCO passes: 20 ms) bounds the latency the data can express.

    Parameters
    ----------
    models : sequence of LineModel
    by_line : dict of int to ndarray of int
        Per line, the returns observed.

    Returns
    -------
    (lo, hi) : tuple of 2 float
        Smallest and largest latency (s); ``lo <= hi`` when the lines overlap in time
        with their trajectories.
    """
    lo, hi = -math.inf, math.inf
    for li, idx in by_line.items():
        if idx.size == 0:
            continue
        t = models[li].line.t_s[idx]
        traj = models[li].trajectory
        lo = max(lo, float(traj.t_start_s - t.min()))
        hi = min(hi, float(traj.t_end_s - t.max()))
    return lo, hi


def _solve_bounded(
    S: FloatArray,
    rhs: FloatArray,
    damping: float,
    vals: FloatArray,
    estimated: tuple[int, ...],
    bounds: tuple[float, float] | None,
) -> FloatArray:
    """`_solve`, with the latency kept within ``bounds`` (an active set of one).

    When the free step takes the latency beyond a bound, its step is set to reach the
    bound and the others are solved given it.
    """
    step = _solve(S, rhs, damping)
    if bounds is None or LATENCY not in estimated:
        return step
    j = estimated.index(LATENCY)
    target = float(vals[LATENCY] + step[j])
    clipped = min(max(target, bounds[0]), bounds[1])
    if clipped == target:
        return step
    dl = clipped - float(vals[LATENCY])
    rest = [m for m in range(len(estimated)) if m != j]
    out = np.zeros(len(estimated))
    out[j] = dl
    if rest:
        sub = np.ix_(rest, rest)
        out[rest] = _solve(S[sub], rhs[rest] + S[rest, j] * dl, damping)
    return out


def reduced_normal_matrix(
    models: Sequence[LineModel],
    observations: Sequence[Observation],
    features: Sequence[Feature],
    values: FloatArray,
    estimated: tuple[int, ...],
    frame: LocalFrame,
    sigmas: Sequence[float] | None = None,
    *,
    robust: bool = True,
    floor: float = 5e-4,
) -> tuple[FloatArray, FloatArray, list[float]]:
    """``S``, the motion information and the per-feature noise scales at a state (no step)."""
    problem = ObservationLayout(models, observations, len(features))
    geo = georeference_observed(models, problem.by_line, values, estimated, frame)
    gathered = problem.gather(geo)
    states = [_at_state(f, r) for f, r in zip(features, gathered, strict=True)]
    scales = list(sigmas) if sigmas is not None else _scales(states, floor, None)
    asm = _assemble(features, gathered, scales, robust, len(estimated), states=states)
    return asm.S, asm.A_diag, scales


def adjust(
    models: Sequence[LineModel],
    observations: Sequence[Observation],
    features: Sequence[Feature],
    values: FloatArray,
    estimated: tuple[int, ...],
    frame: LocalFrame,
    options: AdjustmentOptions | None = None,
    noise_scales_m: Sequence[float] | None = None,
) -> Adjustment:
    """Solve for the estimated mount parameters and every feature.

    Parameters
    ----------
    models : sequence of LineModel
        The lines, prepared.
    observations : sequence of Observation
        Which returns of which line lie on which feature.
    features : sequence of Feature
        First values of the features (e.g. fitted with the starting mount).
    values : ndarray, shape (7,)
        Starting mount parameters (rad, m, s); those not estimated are held.
    estimated : tuple of int
        Parameters to solve for (k of them, k >= 1).
    frame : LocalFrame
        The frame the features live in.
    options : AdjustmentOptions, optional
    noise_scales_m : sequence of float, optional
        Each feature's noise scale (m), held; default: estimated from the residuals
        as the iterations go (`kinsync.robust`).

    Returns
    -------
    Adjustment

    Raises
    ------
    ObservabilityError
        A singular normal matrix.
    ConvergenceError
        No convergence within ``max_iterations``.
    """
    opt = options or AdjustmentOptions()
    k = len(estimated)
    problem = ObservationLayout(models, observations, len(features))
    bounds = latency_bounds(models, problem.by_line) if LATENCY in estimated else None
    vals = np.array(values, dtype=np.float64)
    feats = list(features)
    sigmas: list[float] | None = None if noise_scales_m is None else list(noise_scales_m)
    frozen: list[FloatArray] | None = None
    freeze = False
    damping = 0.0
    last_cost = math.inf
    for iteration in range(1, opt.max_iterations + 1):
        geo = georeference_observed(models, problem.by_line, vals, estimated, frame)
        gathered = problem.gather(geo)
        states = [_at_state(f, r) for f, r in zip(feats, gathered, strict=True)]
        weights = frozen
        if weights is None:
            if noise_scales_m is None:
                sigmas = _scales(states, opt.noise_floor_m, sigmas)
            assert sigmas is not None
            # Iteratively reweighted: this state's weights, held through the step.
            weights = [
                _robust_factors(f, r, s, opt.robust, at)
                for f, r, s, at in zip(feats, gathered, sigmas, states, strict=True)
            ]
            if freeze:
                # Held weights make a new cost: its steps start undamped (a damping
                # left from reweighting would shrink them and fake convergence).
                frozen, damping = weights, 0.0
        assert sigmas is not None
        # Reweighting: the weights of this state, and a step is taken when it lowers the
        # bounded loss (moving returns out of the band must not look like progress);
        # then the weights are held and the last iterations minimise one fixed cost.
        asm = _assemble(feats, gathered, sigmas, opt.robust, k, frozen, weights, states)
        step, new_vals, new_feats, damping = _damped_step(
            problem, asm, feats, vals, estimated, frame, sigmas, opt, damping, frozen, bounds
        )
        vals, feats = new_vals, new_feats
        std = np.sqrt(np.maximum(np.diag(np.linalg.pinv(asm.S)), 1e-300))
        relative = float(np.max(np.abs(step) / std)) if k else 0.0
        stalled = relative < _FREEZE_STEP and asm.cost >= last_cost * (1.0 - 1e-12)
        last_cost = asm.cost if frozen is not None else math.inf
        if frozen is not None and (relative <= opt.step_tolerance or stalled):
            return _finish(
                problem, feats, vals, estimated, frame, sigmas, opt, iteration, frozen, bounds
            )
        # Reweighting settles the returns' weights; then they are held, so that the
        # last iterations minimise one fixed cost and converge.
        freeze = freeze or relative < _FREEZE_STEP or iteration >= opt.reweight_iterations
    msg = (
        f"the calibration did not converge in {opt.max_iterations} iterations; the data may "
        "not determine the parameters asked for (try fewer, or check the mount's start values)"
    )
    raise ConvergenceError(msg)


def _damped_step(
    problem: ObservationLayout,
    asm: _Assembled,
    feats: list[Feature],
    vals: FloatArray,
    estimated: tuple[int, ...],
    frame: LocalFrame,
    sigmas: list[float],
    opt: AdjustmentOptions,
    damping: float,
    frozen: Sequence[FloatArray] | None,
    bounds: tuple[float, float] | None = None,
) -> tuple[FloatArray, FloatArray, list[Feature], float]:
    """One Levenberg-Marquardt step: the damping grows tenfold until the cost drops.

    After a rejected first try, the most damped step of the schedule (a short step
    along the scaled gradient) is tried next: when even it raises the cost, the
    direction is none of descent (a reweighted step at the solution of its weights,
    or the cost's noise floor) and no damping in between helps, so a zero step is
    returned at once instead of after every damping in turn. The latency stays within
    ``bounds`` (`latency_bounds`).
    """
    schedule = [damping]
    for _ in range(_DAMPING_TRIES - 1):
        schedule.append(max(schedule[-1] * 10.0, 1e-4))
    tried: dict[int, tuple[bool, FloatArray, FloatArray, list[Feature]]] = {}

    def attempt(i: int) -> tuple[bool, FloatArray, FloatArray, list[Feature]]:
        if i not in tried:
            step = _solve_bounded(asm.S, asm.rhs, schedule[i], vals, estimated, bounds)
            new_vals = vals.copy()
            new_vals[list(estimated)] += step
            new_feats = []
            for feature, (B_k, C_k, g_k) in zip(feats, asm.blocks, strict=True):
                C_d = C_k + schedule[i] * np.diag(np.diag(C_k))
                try:
                    df = -np.linalg.solve(C_d, g_k + B_k.T @ step)
                except np.linalg.LinAlgError:
                    df = -np.linalg.lstsq(C_d, g_k + B_k.T @ step, rcond=None)[0]
                new_feats.append(feature.updated(np.asarray(df, dtype=np.float64)))
            geo = _georeference_points(problem.models, problem.by_line, new_vals, frame)
            new_cost = _cost(new_feats, problem.gather(geo), sigmas, opt.robust, frozen)
            lower = new_cost <= asm.cost * (1.0 + 1e-12) or not math.isfinite(asm.cost)
            tried[i] = (lower, step, new_vals, new_feats)
        return tried[i]

    last = len(schedule) - 1
    for i in range(len(schedule)):
        if i == 1 and not attempt(last)[0]:
            break
        lower, step, new_vals, new_feats = attempt(i)
        if lower:
            d = schedule[i]
            return step, new_vals, new_feats, d / 10.0 if d > 1e-6 else 0.0
    return np.zeros(len(estimated)), vals, feats, max(schedule[-1] * 10.0, 1e-4)


def _finish(
    problem: ObservationLayout,
    feats: list[Feature],
    vals: FloatArray,
    estimated: tuple[int, ...],
    frame: LocalFrame,
    sigmas: list[float],
    opt: AdjustmentOptions,
    iterations: int,
    frozen: Sequence[FloatArray],
    bounds: tuple[float, float] | None = None,
) -> Adjustment:
    geo = georeference_observed(problem.models, problem.by_line, vals, estimated, frame)
    gathered = problem.gather(geo)
    states = [_at_state(f, r) for f, r in zip(feats, gathered, strict=True)]
    asm = _assemble(feats, gathered, sigmas, opt.robust, len(estimated), frozen, states=states)
    empty = [i for i, at in enumerate(states) if not np.any(_weights(at, sigmas[i], frozen[i]))]
    if empty or asm.n_used <= len(estimated) + asm.dof_features:
        # Never a solution: a fit of nothing has no residual and no sigma.
        what = f"feature(s) {', '.join(map(str, empty))}" if empty else "the features"
        msg = (
            f"the calibration lost every return of {what} ({asm.n_used} returns left in use "
            f"for {len(estimated)} mount and {asm.dof_features} feature parameters): no "
            "solution; check the starting mount, --sphere-radius-m, or estimate fewer "
            "parameters"
        )
        raise ConvergenceError(msg)
    dof = asm.n_used - len(estimated) - asm.dof_features
    sigma0 = math.sqrt(asm.cost / dof)
    cov = np.asarray(sigma0**2 * np.linalg.pinv(asm.S), dtype=np.float64)
    fits = []
    for i, (feature, at) in enumerate(zip(feats, states, strict=True)):
        used = _weights(at, sigmas[i], frozen[i]) > 0.0
        rms = float(np.sqrt(np.mean(at.e[used] ** 2))) if np.any(used) else math.nan
        fits.append(
            FeatureFit(
                feature=feature,
                n_points=int(np.count_nonzero(used)),
                n_lines=problem.lines_of_feature[i],
                sigma_m=sigmas[i],
                rms_m=rms,
            )
        )
    return Adjustment(
        values=vals,
        estimated=estimated,
        features=tuple(fits),
        normal_matrix=asm.S,
        raw_information=asm.A_diag,
        sigma0=sigma0,
        covariance=cov,
        iterations=iterations,
        n_points=asm.n_used,
        latency_bounds_s=bounds,
        at_bound=bounds is not None
        and min(abs(vals[LATENCY] - bounds[0]), abs(vals[LATENCY] - bounds[1]))
        <= LATENCY_BOUND_TOLERANCE_S,
    )
