"""Planning a calibration survey: each parameter's predicted sigma and status.

Before the survey, from its design: simulated lines (noise-free) over the planned
scene with the planned mount. The prediction uses the estimator's own model
(`kinsync.calibration.adjustment`): the same features, the same reduced normal
matrix ``S`` and the same observability analysis, with two error sources:

- range noise ``range_noise_m`` along each beam (what the formal sigma holds);
- navigation errors, correlated in time (what the jackknife of the estimator holds):
  a position error (N, E, D) and a misorientation (about N, E, D, through the body
  reference point) that follow a first-order Gauss-Markov process with the
  trajectory's standard deviations and correlation time ``corr_time_s``, independent
  between lines. Each line's error is represented at knots ``corr_time_s / 3`` apart
  (linear in between) with correlation ``R = exp(-|t_i - t_j| / corr_time_s)``.

The estimator weighs each feature by its own noise scale, the robust spread of its
residuals, which the navigation errors dominate (2-14 cm against 1 cm of range noise on
the simulated vessel). The plan predicts that scale: the range noise and the RMS
residual the navigation errors leave after the feature's own fit (``(I - H_f) G xi``,
per feature; on simulated data the estimator's scales came out 0.86-1.12 times the
prediction, median over features). With those weights ``W``, ``S`` the reduced normal
matrix and ``U = J_theta' W (I - H_f) G`` the reduced gradient that unit knot errors
put on the mount parameters (``H_f`` the projector on the features), the covariance
is the sandwich ``S^-1 (M_noise + U (R (x) diag(sigma_c^2)) U') S^-1``, ``M_noise`` the
range noise's part. The sensitivity to held values (`kinsync.calibration.held`) uses
the same ``S``. Weighting every feature by the range noise alone, as the plan did
before, gave the vessel's latency 4x too little sensitivity to a held lever arm.

A parameter is ``unobservable`` by the information test, or when its predicted sigma
exceeds what a crew knows without calibrating (the estimator's rule after its
solution), ``weak`` above the thresholds of `kinsync.calibration.observability`. Both
read the total sigma, the held values' stated sigma included
(`kinsync.calibration.held.hold_too_uncertain`).

Checked against the Monte Carlo of `benchmarks/bench_calibration_sigma.py` (30 runs,
density 0.1, the same designs, planned with the errors the simulation draws: 2/2/3 cm
N/E/D and 0.005/0.005/0.01 deg, correlated over 20 s): empirical spread / planned
sigma 0.84-1.39 on the vehicle (roll boresight 1.39, yaw 1.23) and 0.65-1.24 on the
vessel. With a lever arm held at 2 cm the planned sigma is 0.89-1.34 times the
estimator's own (vessel latency 6.2 against 4.9 ms, vessel roll 1.34, vehicle roll
1.17). The statuses agreed. (The roll's 2.9 and the vessel latency's 2.3 of before
came from the estimator setting aside the ends of a line's drift across a plane, and
from a plan given 2 cm heights where the simulation drew 3 cm.) The sensitivity to a
held value depends on the returns per feature (vessel, lever y -> latency: 1.7-1.9 ms
per cm at density 0.1, 0.6-0.9 at 0.25, in the plan and the estimator alike).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import sparse

from kinsync._typing import FloatArray, IntArray
from kinsync.calibration.adjustment import (
    FeatureReturns,
    Observation,
    ObservationLayout,
    georeference_observed,
    incidence_factor,
    reduced_normal_matrix,
)
from kinsync.calibration.estimator import CalibrationOptions, find_features
from kinsync.calibration.features import Feature
from kinsync.calibration.held import (
    HeldEffect,
    covariance_of_uncertainty,
    effect_of_held,
    hold_too_uncertain,
)
from kinsync.calibration.line_checks import check_arguments
from kinsync.calibration.lines import ScanLine
from kinsync.calibration.model import LineModel, LocalFrame, local_frame_for
from kinsync.calibration.observability import (
    UNOBSERVABLE_THRESHOLDS,
    Observability,
    analyse,
    status_of,
)
from kinsync.calibration.parameters import (
    PARAMETER_NAMES,
    REPORT_SCALE,
    estimated_indices,
    mount_values,
)
from kinsync.calibration.uncertainty import MIN_HONEST_DOF, MIN_JACKKNIFE_GROUPS
from kinsync.errors import InputError
from kinsync.georef.trajectory import GeorefTrajectory
from kinsync.mount import Mount, MountUncertainty

__all__ = ["NavigationErrors", "PlanResult", "PlannedParameter", "plan_calibration"]


@dataclass(frozen=True)
class NavigationErrors:
    """Errors assumed for the plan (one sigma).

    Attributes
    ----------
    range_noise_m : float
        Scanner range noise along the beam (m).
    position_std_m : float or tuple of 3 float
        Trajectory position error (m): one sigma for every axis, or N, E, D (a
        GNSS/INS height is typically 1.5-2 times worse than its horizontal position).
    attitude_std_deg : tuple of 3 float
        Trajectory misorientation about N, E, D (deg).
    corr_time_s : float
        Correlation time of the trajectory errors (s): first-order Gauss-Markov.
    """

    range_noise_m: float = 0.01
    position_std_m: float | tuple[float, float, float] = (0.02, 0.02, 0.03)
    attitude_std_deg: tuple[float, float, float] = (0.005, 0.005, 0.01)
    corr_time_s: float = 15.0

    def __post_init__(self) -> None:
        if not isinstance(self.position_std_m, int | float) and len(self.position_std_m) != 3:
            msg = f"position sigma: one number or N, E, D, got {self.position_std_m!r}"
            raise InputError(msg)
        if not (math.isfinite(self.range_noise_m) and self.range_noise_m > 0.0):
            msg = (
                f"range noise (--range-noise-m) must be a number of metres > 0, got "
                f"{self.range_noise_m!r}: the plan weighs each return by it"
            )
            raise InputError(msg)
        for what, values in (
            ("trajectory position sigma (--position-std-m)", self.position_std_ned_m),
            ("trajectory misorientation sigma (--attitude-std-deg)", self.attitude_std_deg),
        ):
            if not all(math.isfinite(v) and v >= 0.0 for v in values):
                msg = f"{what} must be finite and >= 0, got {tuple(values)!r}"
                raise InputError(msg)
        if not (math.isfinite(self.corr_time_s) and self.corr_time_s > 0.0):
            msg = f"--corr-time-s must be a number of seconds > 0, got {self.corr_time_s!r}"
            raise InputError(msg)

    @property
    def position_std_ned_m(self) -> tuple[float, float, float]:
        """The position sigma per axis, N, E, D (m)."""
        p = self.position_std_m
        if isinstance(p, int | float):
            return (float(p), float(p), float(p))
        return (float(p[0]), float(p[1]), float(p[2]))

    @property
    def pose_std(self) -> FloatArray:
        """Position N, E, D (m) and misorientation about N, E, D (rad), shape (6,)."""
        att = [math.radians(a) for a in self.attitude_std_deg]
        return np.array([*self.position_std_ned_m, *att])


@dataclass(frozen=True)
class PlannedParameter:
    """One parameter's prediction (report units).

    ``std`` holds every error source: range noise, navigation errors and the held
    values' stated sigma (``std_held``, added in quadrature); NaN where not estimated.
    """

    name: str
    status: str
    std: float
    std_noise_only: float
    std_held: float = 0.0

    def as_document(self) -> dict[str, Any]:
        """``{"status", "std", "std_noise_only", "std_held"}`` (null where not estimated)."""

        def num(v: float) -> float | None:
            return v if math.isfinite(v) else None

        return {
            "status": self.status,
            "std": num(self.std),
            "std_noise_only": num(self.std_noise_only),
            "std_held": num(self.std_held) if math.isfinite(self.std) else None,
        }


@dataclass(frozen=True, eq=False)
class PlanResult:
    """A calibration plan's prediction.

    Attributes
    ----------
    parameters : tuple of PlannedParameter
        All seven parameters (``fixed`` when not asked for).
    n_features : int
        Features the estimator would use.
    n_lines : int
    unobservable_reasons, advice : tuple of str
        As in `kinsync.calibration.result.CalibrationResult`.
    errors : NavigationErrors
        The errors assumed.
    held : HeldEffect
        How the held values' errors reach the estimates (their stated sigma in
        ``held.held_std``; NaN where taken as exact).
    """

    parameters: tuple[PlannedParameter, ...]
    n_features: int
    n_lines: int
    unobservable_reasons: tuple[str, ...]
    advice: tuple[str, ...]
    errors: NavigationErrors
    held: HeldEffect

    def as_document(self) -> dict[str, Any]:
        """The ``kinsync calibrate plan --json`` document."""
        return {
            "parameters": {p.name: p.as_document() for p in self.parameters},
            "n_features": self.n_features,
            "n_lines": self.n_lines,
            "unobservable": list(self.unobservable_reasons),
            "advice": list(self.advice),
            "assumed_errors": {
                "range_noise_m": self.errors.range_noise_m,
                "position_std_m": list(self.errors.position_std_ned_m),
                "attitude_std_deg": list(self.errors.attitude_std_deg),
                "corr_time_s": self.errors.corr_time_s,
            },
            "held": self.held.document(),
        }


@dataclass(frozen=True, eq=False)
class _Knots:
    """Each line's pose-error knots, ``corr_time_s / 3`` apart, and their correlation.

    ``R`` is block-diagonal (lines are independent): only each line's block is kept,
    ``blocks[line]`` (n_line, n_line); ``size`` is the number of knots over all lines.
    """

    times: dict[int, FloatArray]
    first: dict[int, int]
    blocks: dict[int, FloatArray]
    size: int

    @classmethod
    def build(
        cls, models: Sequence[LineModel], layout: ObservationLayout, corr_time_s: float
    ) -> _Knots:
        times, first = {}, {}
        n = 0
        for li in sorted(layout.by_line):
            t = models[li].line.t_s[layout.by_line[li]]
            t0, t1 = float(np.min(t)), float(np.max(t))
            count = max(2, int(np.ceil(3.0 * (t1 - t0) / corr_time_s)) + 1)
            times[li], first[li] = np.linspace(t0, t1, count), n
            n += count
        blocks = {
            li: np.exp(-np.abs(kt[:, None] - kt[None, :]) / corr_time_s) for li, kt in times.items()
        }
        return cls(times, first, blocks, n)

    def covariance_quadratic(self, U: FloatArray, pose_sd: FloatArray) -> FloatArray:
        """``U (R (x) diag(pose_sd^2)) U'`` for ``U`` (k, 6 K), line block by line block."""
        k = U.shape[0]
        out = np.zeros((k, k))
        for li, block in self.blocks.items():
            j = 6 * self.first[li]
            u = U[:, j : j + 6 * block.shape[0]].reshape(k, block.shape[0], 6) * pose_sd
            out += np.einsum("kac,ab,jbc->kj", u, block, u)
        return out

    def design(self, line: IntArray, t: FloatArray, g6: FloatArray) -> sparse.csr_matrix:
        """Sparse ``G`` (n, 6 K): each return's six pose gradients on its two knots."""
        n = t.size
        cols = np.empty((n, 12), dtype=np.int64)
        vals = np.empty((n, 12))
        for li in np.unique(line):
            on = np.flatnonzero(line == li)
            kt = self.times[int(li)]
            j = np.clip(np.searchsorted(kt, t[on], side="right") - 1, 0, kt.size - 2)
            a = np.clip((t[on] - kt[j]) / (kt[j + 1] - kt[j]), 0.0, 1.0)
            base = 6 * (self.first[int(li)] + j)
            for c in range(6):
                cols[on, c], vals[on, c] = base + c, (1.0 - a) * g6[on, c]
                cols[on, 6 + c], vals[on, 6 + c] = base + 6 + c, a * g6[on, c]
        rows = np.repeat(np.arange(n), 12)
        shape = (n, 6 * self.size)
        return sparse.csr_matrix((vals.ravel(), (rows, cols.ravel())), shape=shape)


def _pose_designs(
    models: Sequence[LineModel],
    observations: Sequence[Observation],
    features: Sequence[Feature],
    values: FloatArray,
    estimated: tuple[int, ...],
    frame: LocalFrame,
    corr_time_s: float,
) -> tuple[_Knots, list[tuple[int, Feature, FeatureReturns, list[int], sparse.csr_matrix]]]:
    """The knots, and per feature seen: its returns and ``G``, what unit pose errors do.

    ``G`` (n, 6 K) gives each return's residual change per unit position error (N, E,
    D) and misorientation (about N, E, D) at its line's knots: a position error moves
    every return; a misorientation turns the returns about the body reference point,
    ``grad . (omega x arm) = omega . (arm x grad)``. Each item is ``(feature index,
    feature, its returns at the state, the lines that see it, G)``.
    """
    layout = ObservationLayout(models, observations, len(features))
    knots = _Knots.build(models, layout, corr_time_s)
    geo = georeference_observed(models, layout.by_line, values, estimated, frame)
    body = {li: models[li].body_positions(idx, values, frame) for li, idx in layout.by_line.items()}
    t_obs = {li: models[li].line.t_s[idx] for li, idx in layout.by_line.items()}
    rets = layout.gather(geo)
    out = []
    for fi, feature in enumerate(features):
        parts = [(li, sl) for f, li, sl in layout.slices if f == fi]
        if not parts:
            continue
        ret = rets[fi]
        line = np.concatenate([np.full(sl.stop - sl.start, li) for li, sl in parts])
        t = np.concatenate([t_obs[li][sl] for li, sl in parts])
        arm = np.concatenate([geo[li][0][sl] - body[li][sl] for li, sl in parts])
        grad = feature.gradient_x(ret.x)
        G = knots.design(line, t, np.concatenate([grad, np.cross(arm, grad)], axis=1))
        out.append((fi, feature, ret, sorted({li for li, _ in parts}), G))
    return knots, out


def _navigation_gradients(
    models: Sequence[LineModel],
    observations: Sequence[Observation],
    features: Sequence[Feature],
    values: FloatArray,
    estimated: tuple[int, ...],
    frame: LocalFrame,
    err: NavigationErrors,
    scales: Sequence[float],
) -> tuple[FloatArray, _Knots]:
    """``U = J_theta' W (I - H_f) G`` (k, 6 K) and the knots (their correlation ``R``).

    ``W`` weighs each feature's returns with its noise scale ``scales`` (m, as the
    estimator's per-feature scales) and the incidence factor.
    """
    knots, designs = _pose_designs(
        models, observations, features, values, estimated, frame, err.corr_time_s
    )
    U = np.zeros((len(estimated), 6 * knots.size))
    for fi, feature, ret, _, G in designs:
        grad = feature.gradient_x(ret.x)
        jt = np.einsum("ni,nik->nk", grad, ret.jac)
        jf = feature.jacobian(ret.x)
        w = 1.0 / (scales[fi] * incidence_factor(feature, ret)) ** 2
        B = (jt * w[:, None]).T @ jf
        WG = sparse.csr_matrix(G.multiply(w[:, None]))
        C_inv_FtWG = np.linalg.pinv(jf.T @ (jf * w[:, None])) @ np.asarray(WG.T @ jf).T
        U += np.asarray((WG.T @ jt).T) - B @ C_inv_FtWG
    return U, knots


def _navigation_scatter(
    models: Sequence[LineModel],
    observations: Sequence[Observation],
    features: Sequence[Feature],
    values: FloatArray,
    frame: LocalFrame,
    err: NavigationErrors,
) -> list[float]:
    """Each feature's RMS residual from the navigation errors (range-equivalent, m).

    The residual a line's pose errors leave after the feature's own fit,
    ``(I - H_f) G xi`` divided by the incidence factor, as the estimator's noise scale
    sees it (`kinsync.calibration.adjustment`): its expected mean square is
    ``||diag(1/inc) (I - H_f) G L||_F^2 / n`` with ``L L' = R (x) diag(sigma_c^2)``,
    block by block over the lines that see the feature (their errors are independent).
    """
    knots, designs = _pose_designs(
        models, observations, features, values, (), frame, err.corr_time_s
    )
    pose_sd = err.pose_std
    chol: dict[int, FloatArray] = {}
    for li, kt in knots.times.items():
        block = knots.blocks[li]
        chol[li] = np.kron(np.linalg.cholesky(block + 1e-12 * np.eye(kt.size)), np.diag(pose_sd))
    out = [0.0] * len(features)
    for fi, feature, ret, lines, G_rows in designs:
        # ||D (X - H X)||^2 with X = G L, D = diag(1/inc), W = D^2, H the feature's
        # weighted fit jf C+ jf' W (C = jf' W jf): ||D X||^2 - tr(Y' C+ Y), Y = jf' W X,
        # summed line by line, so that memory is one line's block of X (returns x 6 K),
        # not every line's side by side (4.98 GB and 117 s at 16 passes, 8 at 1.73 GB).
        G = G_rows.tocsc()
        inc = incidence_factor(feature, ret)
        jf = feature.jacobian(ret.x)
        w = 1.0 / inc**2
        jw = (jf * w[:, None]).T
        spread = 0.0
        ys = []
        for li in lines:
            j = 6 * knots.first[li]
            X = np.asarray(G[:, j : j + chol[li].shape[0]] @ chol[li])
            spread += float(np.sum(w[:, None] * X * X))
            ys.append(jw @ X)
        Y = np.concatenate(ys, axis=1)
        fitted = float(np.sum(Y * (np.linalg.pinv(jf.T @ (jf * w[:, None])) @ Y)))
        out[fi] = math.sqrt(max(spread - fitted, 0.0) / max(ret.x.shape[0], 1))
    return out


def _predicted(
    models: Sequence[LineModel],
    observations: Sequence[Observation],
    features: Sequence[Feature],
    values: FloatArray,
    estimated: tuple[int, ...],
    frame: LocalFrame,
    err: NavigationErrors,
    scales: Sequence[float],
) -> tuple[FloatArray, FloatArray]:
    """Predicted covariance (range noise and navigation errors) and range noise alone.

    The estimator weighs each feature with its own noise scale (``scales``, m): the
    covariance is the sandwich ``S^-1 (M_noise + U (R (x) Sigma) U') S^-1`` with ``S``
    under those weights; per feature the range noise's part ``M_noise`` is ``S``'s own
    contribution times ``range_noise^2 / scale^2``, i.e. the reduced normal matrix with
    scales ``scale^2 / range_noise``. The range noise alone is ``S_0^-1`` with the
    range noise as every feature's scale.
    """
    k = len(estimated)
    if k == 0:
        return np.zeros((0, 0)), np.zeros((0, 0))

    def normal(sigmas: Sequence[float]) -> FloatArray:
        S, _, _ = reduced_normal_matrix(
            models, observations, features, values, estimated, frame, list(sigmas), robust=False
        )
        return np.asarray(S, dtype=np.float64)

    noise = err.range_noise_m
    S0_inv = np.asarray(np.linalg.pinv(normal([noise] * len(features))), dtype=np.float64)
    S_inv = np.asarray(np.linalg.pinv(normal(scales)), dtype=np.float64)
    M_noise = normal([s * s / noise for s in scales])
    U, knots = _navigation_gradients(
        models, observations, features, values, estimated, frame, err, scales
    )
    pose_sd = err.pose_std
    middle = knots.covariance_quadratic(U, pose_sd)
    cov = np.asarray(S_inv @ (M_noise + middle) @ S_inv, dtype=np.float64)
    return cov, S0_inv


def plan_calibration(
    lines: Sequence[ScanLine],
    mount: Mount,
    options: CalibrationOptions | None = None,
    errors: NavigationErrors | None = None,
    held: MountUncertainty | None = None,
) -> PlanResult:
    """Predict each parameter's sigma and status for a planned survey.

    Parameters
    ----------
    lines : sequence of ScanLine
        Noise-free simulated lines of the design (geometry only).
    mount : Mount
        The planned mount.
    options : CalibrationOptions, optional
        Features and parameters to estimate, as for the estimator.
    errors : NavigationErrors, optional
        Range noise and the navigation errors shared by a line.
    held : MountUncertainty, optional
        How well the values the calibration will hold (not estimated, or not
        determined) are known: their errors are added to the predicted sigma as
        ``D Sigma D'`` (`kinsync.calibration.held`), as the estimator adds them. Values
        without a sigma are taken as exact.

    Returns
    -------
    PlanResult

    Raises
    ------
    InputError
        ``mount`` not a `Mount`, an item of ``lines`` not a `ScanLine`, or no feature
        found.
    """
    lines = check_arguments(lines, mount)
    opt = options or CalibrationOptions()
    err = errors or NavigationErrors()
    requested = estimated_indices(opt.estimate)
    cache: dict[int, GeorefTrajectory] = {}
    models = [LineModel.prepare(line, cache) for line in lines]
    frame = local_frame_for(list(lines))
    values = mount_values(mount)
    features, observations = find_features(models, values, frame, opt)
    scatter = _navigation_scatter(models, observations, features, values, frame, err)
    sig = [math.hypot(err.range_noise_m, s) for s in scatter]
    S, motion, _ = reduced_normal_matrix(
        models, observations, features, values, requested, frame, sig, robust=False
    )
    obs = analyse(S, motion, requested, honest_sigma=len(lines) >= MIN_JACKKNIFE_GROUPS)
    cov, cov_noise = _predicted(
        models, observations, features, values, obs.estimated, frame, err, sig
    )
    S7, _, _ = reduced_normal_matrix(
        models, observations, features, values, tuple(range(7)), frame, sig, robust=False
    )
    held_cov = covariance_of_uncertainty(held)
    trajectory_limited: list[str] = []
    while obs.estimated:
        std = np.sqrt(np.maximum(np.diag(cov), 0.0))
        effect = effect_of_held(S7, obs.estimated, held_cov)
        dropped = hold_too_uncertain(obs.estimated, std, cov, effect)
        if dropped is None:
            break
        c = dropped.cause
        j = obs.estimated.index(c)
        alone = math.sqrt(max(float(cov_noise[j, j]), 0.0)) * float(REPORT_SCALE[c])
        if not (dropped.reason or dropped.limited_by) and alone <= UNOBSERVABLE_THRESHOLDS[c]:
            trajectory_limited.append(
                f"{PARAMETER_NAMES[c]}: a better trajectory (these lines with the range noise "
                f"alone give +-{alone:.2g}, with the trajectory errors assumed "
                f"+-{dropped.std_report:.3g}), or more lines: the trajectory errors average "
                "over lines"
            )
        obs = obs.without(dropped)
        cov, cov_noise = _predicted(
            models, observations, features, values, obs.estimated, frame, err, sig
        )
    effect = effect_of_held(S7, obs.estimated, held_cov)
    # The estimator's rule: a jackknife over fewer lines is not an honest sigma, so no
    # estimate is better than weak there; the plan says the same.
    few_lines = len(lines) < MIN_HONEST_DOF + 1
    params = _planned_parameters(obs, cov, cov_noise, effect, few_lines)
    few_lines_text = (
        f"an honest sigma: at least {MIN_HONEST_DOF + 1} independent lines or passes over "
        f"the features ({len(lines)} planned), so no estimate is better than weak"
    )
    few_lines_advice = (few_lines_text,) if few_lines else ()
    return PlanResult(
        parameters=params,
        n_features=len(features),
        n_lines=len(lines),
        unobservable_reasons=obs.explanation(),
        advice=(*trajectory_limited, *obs.advice(), *few_lines_advice),
        errors=err,
        held=effect,
    )


def _planned_parameters(
    obs: Observability,
    cov: FloatArray,
    cov_noise: FloatArray,
    effect: HeldEffect,
    few_lines: bool,
) -> tuple[PlannedParameter, ...]:
    """Every parameter's status and sigma (report units), the held part added.

    ``few_lines``: too few lines for an honest sigma, so nothing is better than weak.
    """
    est = obs.estimated
    std_all = np.full(7, math.nan)
    std_noise = np.full(7, math.nan)
    std_held = np.zeros(7)
    for j, i in enumerate(est):
        total = float(cov[j, j]) + float(effect.covariance[j, j])
        std_all[i] = math.sqrt(max(total, 0.0)) * REPORT_SCALE[i]
        std_noise[i] = math.sqrt(max(float(cov_noise[j, j]), 0.0)) * REPORT_SCALE[i]
        std_held[i] = float(effect.std[j]) * REPORT_SCALE[i]
    params = []
    for i, name in enumerate(PARAMETER_NAMES):
        if i in est:
            status = status_of(i, float(std_all[i]))
            if few_lines and status == "estimated":
                status = "weak"
        elif i in obs.held:
            status = "unobservable"
        else:
            status = "fixed"
        params.append(
            PlannedParameter(
                name, status, float(std_all[i]), float(std_noise[i]), float(std_held[i])
            )
        )
    return tuple(params)
