"""Mount self-calibration from survey lines: the whole estimator on containers.

`calibrate_mount` takes the lines of a survey (`ScanLine`: scanner-frame returns with
times, and the trajectory), the mount they were acquired with and which parameters to
estimate, and returns a `CalibrationResult`:

1. Every line is georeferenced with the starting mount; features seen by several
   lines are found (`kinsync.calibration.planes` for planar patches,
   `kinsync.calibration.spheres` for sphere targets).
2. Observability before solving (`kinsync.calibration.observability`): parameters the
   data cannot determine are held at their prior values and reported, with advice.
3. The adjustment (`kinsync.calibration.adjustment`): Gauss-Newton with the features
   as nuisance parameters, robust weights, the real georeferencing model.
4. Honest sigma (`kinsync.calibration.uncertainty`): the jackknife over lines, which
   holds the errors every return of a line shares; the formal sigma beside it. What
   the held parameters' stated uncertainty (the mount's ``[uncertainty]``) adds is
   added to it (`kinsync.calibration.held`); a held value taken as exact whose
   plausible error would move an estimate is named (``held_advice``).
5. Status: ``weak`` when the sigma exceeds the stated threshold, or when it is no
   honest sigma: the formal one (fewer than `MIN_JACKKNIFE_GROUPS` lines, or a
   jackknife that failed) or a jackknife with fewer than `MIN_HONEST_DOF` degrees of
   freedom (4 lines). The formal sigma is 3-30x too small on real data (on 3 CIDCO
   passes the pitch came out -8.41 +- 0.015 deg where 12 passes give -7.68 +- 0.23),
   so such an estimate is never ``estimated``; the advice says how many lines would
   give an honest sigma.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np

from kinsync._typing import FloatArray
from kinsync.calibration.adjustment import (
    Adjustment,
    AdjustmentOptions,
    Observation,
    adjust,
    reduced_normal_matrix,
)
from kinsync.calibration.features import Feature
from kinsync.calibration.gross import (
    MAX_FEATURE_ROUNDS,
    at_start,
    far_from_start,
    lines_at_the_same_time,
    residual_rise,
    search_yaw,
    stuck_at_start,
    unlinked_directions,
)
from kinsync.calibration.held import (
    HeldEffect,
    held_covariance,
    held_effect,
    held_std,
    hold_too_uncertain,
    joint_covariance,
    uncertainty_from_covariance,
    uncertainty_notes,
)
from kinsync.calibration.line_checks import check_arguments, check_lines
from kinsync.calibration.lines import ScanLine, two_passes_in_a_line, without_unspread_lines
from kinsync.calibration.model import LineModel, LocalFrame, local_frame_for
from kinsync.calibration.observability import (
    HeldAfterSolution,
    Observability,
    analyse,
    correlation,
    status_of,
)
from kinsync.calibration.overlaps import LineOverlap, overlap_differences, scatter_m
from kinsync.calibration.parameters import (
    BORESIGHT,
    DEFAULT_ESTIMATE,
    GROUPS,
    LATENCY,
    PARAMETER_NAMES,
    REPORT_SCALE,
    estimated_indices,
    gimbal_lock_warning,
    mount_from_values,
    mount_values,
    report_values,
)
from kinsync.calibration.planes import PatchOptions, find_plane_patches
from kinsync.calibration.result import CalibrationResult, FeatureSummary, ParameterEstimate
from kinsync.calibration.spheres import SphereOptions, find_sphere_targets
from kinsync.calibration.steps import CalibrationSteps
from kinsync.calibration.uncertainty import (
    MIN_HONEST_DOF,
    MIN_JACKKNIFE_GROUPS,
    Jackknife,
    jackknife,
)
from kinsync.errors import ConvergenceError, InputError
from kinsync.georef.trajectory import GeorefTrajectory
from kinsync.mount import Mount
from kinsync.progress import Progress
from kinsync.trajectory_gaps import max_gap_for

__all__ = ["CalibrationOptions", "calibrate_mount", "find_features"]

FeatureKind = Literal["planes", "spheres"]


_Found = tuple[LocalFrame, list[Feature], list[Observation]]
"""A local frame, the features found in it and who sees them."""


@dataclass(frozen=True)
class CalibrationOptions:
    """How to calibrate.

    Attributes
    ----------
    features : {"planes", "spheres"}
        Planar patches found in the lines' overlap, or sphere targets.
    estimate : tuple of str
        Parameter groups to estimate (`kinsync.calibration.parameters.GROUPS`); a
        list, a set (read in the groups' order) or ``"boresight,latency"`` text is
        stored as a tuple.
    patches : PatchOptions
        Settings of the patch search.
    spheres : SphereOptions
        Settings of the sphere search (the known radius, if any).
    adjustment : AdjustmentOptions
        Iteration settings.
    jackknife : bool
        Compute the jackknife sigma (else the formal sigma is reported); True or
        False only.
    max_gap_s : float or None
        Longest trajectory record interval (s) interpolated across; returns inside a
        longer one (a data gap) are refused like returns outside the trajectory. None
        (default): `kinsync.trajectory_gaps.GAP_FACTOR` median record intervals
        (`kinsync.trajectory_gaps.max_gap_for`); ``math.inf``: no gap.
    """

    features: FeatureKind = "planes"
    estimate: tuple[str, ...] = DEFAULT_ESTIMATE
    patches: PatchOptions = field(default_factory=PatchOptions)
    spheres: SphereOptions = field(default_factory=SphereOptions)
    adjustment: AdjustmentOptions = field(default_factory=AdjustmentOptions)
    jackknife: bool = True
    max_gap_s: float | None = None

    def __post_init__(self) -> None:
        if self.features not in ("planes", "spheres"):
            msg = f"features (--features) must be planes or spheres, got {self.features!r}"
            raise InputError(msg)
        est: object = self.estimate
        if isinstance(est, str):  # "boresight,latency", as --estimate takes them
            est = [g.strip() for g in est.split(",") if g.strip()]
        if not isinstance(est, Iterable) or isinstance(est, bytes):
            msg = f"estimate: expected a tuple of group names ({', '.join(GROUPS)}), got {est!r}"
            raise InputError(msg)
        names = tuple(est)
        estimated_indices(names)  # an unknown group fails here
        if isinstance(est, set | frozenset):  # no order of its own: the groups' order
            names = tuple(g for g in GROUPS if g in names)
        object.__setattr__(self, "estimate", names)
        if not isinstance(self.jackknife, bool | np.bool_):
            msg = f"jackknife: expected True or False, got {self.jackknife!r}"
            raise InputError(msg)
        object.__setattr__(self, "jackknife", bool(self.jackknife))
        if self.max_gap_s is not None:
            max_gap_for((), self.max_gap_s)  # a positive number of seconds, or inf


def find_features(
    models: Sequence[LineModel], values: FloatArray, frame: LocalFrame, opt: CalibrationOptions
) -> tuple[list[Feature], list[Observation]]:
    """The features of ``opt.features`` seen by several lines, with their observations.

    Sphere targets (`kinsync.calibration.spheres.find_sphere_targets`) or planar
    patches (`kinsync.calibration.planes.find_plane_patches`).

    Parameters
    ----------
    models : sequence of LineModel
        The lines, prepared for georeferencing (all their returns are searched).
    values : ndarray, shape (7,)
        The mount parameters to georeference with (rad, m, s: boresight roll, pitch,
        yaw, lever arm x, y, z in the body frame FRD, latency), as
        `kinsync.calibration.parameters.mount_values`.
    frame : LocalFrame
        Local NED frame the features are expressed in.
    opt : CalibrationOptions
        ``features`` picks the kind; ``spheres`` or ``patches`` holds its search
        settings.

    Returns
    -------
    features : list of Feature
        The features found, in the local frame (m).
    observations : list of Observation
        For each line and feature it sees, the indices of its returns on it.

    Raises
    ------
    InputError
        No feature found, or none seen by several lines (the message says what to
        check).
    """
    if opt.features == "spheres":
        targets = find_sphere_targets(models, values, frame, opt.spheres)
        return list(targets.features), list(targets.observations)
    patches = find_plane_patches(models, values, frame, opt.patches)
    return list(patches.features), list(patches.observations)


def _rms_before(
    models: Sequence[LineModel],
    observations: Sequence[Observation],
    features: Sequence[Feature],
    values: FloatArray,
    frame: LocalFrame,
) -> list[float]:
    """RMS residual of each feature with the starting mount (robust: 3-sigma trimmed)."""
    parts: list[list[FloatArray]] = [[] for _ in features]
    for o in observations:
        x = models[o.line].points(o.index, values, frame)
        ok = np.all(np.isfinite(x), axis=1)
        parts[o.feature].append(features[o.feature].residuals(x[ok]))
    out = []
    for p in parts:
        e = np.concatenate(p) if p else np.zeros(0)
        out.append(float(np.sqrt(np.mean(e**2))) if e.size else math.nan)
    return out


def _summaries(
    solution: Adjustment,
    before: list[float],
    overlaps_before: tuple[LineOverlap, ...],
    overlaps_after: tuple[LineOverlap, ...],
) -> tuple[FeatureSummary, ...]:
    return tuple(
        FeatureSummary(
            kind=f.feature.kind,
            description=f.feature.describe(),
            n_points=f.n_points,
            n_passes=f.n_lines,
            rms_before_m=before[i],
            rms_after_m=f.rms_m,
            scatter_before_m=scatter_m(overlaps_before, i),
            scatter_after_m=scatter_m(overlaps_after, i),
        )
        for i, f in enumerate(solution.features)
    )


def _pooled_rms(values: Sequence[float], weights: Sequence[int]) -> float:
    v = np.array(values)
    w = np.array(weights, dtype=np.float64)
    ok = np.isfinite(v)
    if not np.any(ok):
        return math.nan
    return float(np.sqrt(np.sum(w[ok] * v[ok] ** 2) / np.sum(w[ok])))


def _parameters(
    mount: Mount,
    requested: tuple[int, ...],
    obs: Observability,
    solution: Adjustment | None,
    std: FloatArray | None,
    honest: bool = True,
    held: HeldEffect | None = None,
) -> tuple[ParameterEstimate, ...]:
    """Every parameter's estimate; ``honest``: ``std`` is an honest sigma (else ``weak``).

    ``std`` is the data's sigma; ``held`` adds what the held parameters' stated
    uncertainty does, and the status reads the sum.
    """
    out = []
    extra = held.std if held is not None else None
    prior = report_values(mount)  # as given: held values are reported exactly so
    for i, name in enumerate(PARAMETER_NAMES):
        scale = REPORT_SCALE[i]
        value = float(prior[i])
        if i in obs.estimated and solution is not None and std is not None:
            value = float(solution.values[i]) * scale
            j = obs.estimated.index(i)
            data = float(std[j]) * scale
            added = 0.0 if extra is None else float(extra[j]) * scale
            s = math.hypot(data, added)
            formal = math.sqrt(max(float(solution.covariance[j, j]), 0.0)) * scale
            status = status_of(i, s) if honest else "weak"
        else:
            s = formal = data = added = math.nan
            status = "unobservable" if i in requested else "fixed"
        out.append(
            ParameterEstimate(
                name=name,
                value=value,
                prior=float(prior[i]),
                std=s,
                formal_std=formal,
                status=status,  # type: ignore[arg-type]
                data_std=data,
                held_std=added,
            )
        )
    return tuple(out)


def calibrate_mount(
    lines: Sequence[ScanLine],
    mount: Mount,
    options: CalibrationOptions | None = None,
    *,
    groups: Sequence[tuple[str, set[int]]] | None = None,
    progress: Progress | None = None,
) -> CalibrationResult:
    """Calibrate boresight, lever arm and latency from overlapping survey lines.

    Parameters
    ----------
    lines : sequence of ScanLine
        The lines (or passes): scanner-frame returns with times and their trajectory.
    mount : Mount
        The mount they were acquired with: the starting and prior values.
    options : CalibrationOptions, optional
        Features, parameters to estimate, search and iteration settings.
    groups : sequence of (name, set of line indices), optional
        The independent units of the jackknife; default one per line.
    progress : Progress, optional
        Called as ``progress(fraction, stage)`` (`kinsync.progress.Progress`): the share
        of the work done (0 to 1, never decreasing, 1 at the end) and what runs now
        (`kinsync.calibration.steps`).

    Returns
    -------
    CalibrationResult

    Raises
    ------
    InputError
        ``mount`` not a `Mount`, an item of ``lines`` not a `ScanLine`, fewer than two
        lines, returns outside their trajectory or in one of its data gaps
        (``options.max_gap_s``), no feature found or none seen by two lines.
    ConvergenceError
        The adjustment did not converge.
    """
    opt = options or CalibrationOptions()
    lines = check_arguments(lines, mount)
    check_lines(lines, mount.latency_s, opt.max_gap_s)
    lines, groups, no_spread = without_unspread_lines(lines, groups)
    same_time = lines_at_the_same_time(lines)
    if same_time is not None:
        raise same_time
    steps = CalibrationSteps(progress)
    result = _calibrate(lines, mount, opt, groups, no_spread, steps)
    steps.finish()
    return result


def _calibrate(
    lines: list[ScanLine],
    mount: Mount,
    opt: CalibrationOptions,
    groups: Sequence[tuple[str, set[int]]] | None,
    no_spread: tuple[tuple[str, str], ...],
    steps: CalibrationSteps,
) -> CalibrationResult:
    """`calibrate_mount` of checked lines, telling ``steps`` how far it got."""
    requested = estimated_indices(opt.estimate)
    steps.start("finding features", f"finding {opt.features} in {len(lines)} lines")
    cache: dict[int, GeorefTrajectory] = {}
    models = [LineModel.prepare(line, cache, max_gap_s=opt.max_gap_s) for line in lines]
    prior = mount_values(mount)
    memo: dict[bytes, _Found] = {}  # the features found with the prior, looked at twice
    searched = _search_yaw(lines, models, prior, requested, opt, steps.say, memo)
    start = prior if searched is None else searched[0]
    setup, solution = _solve_refinding(
        lines, models, prior, start, requested, groups, opt, steps, memo
    )
    frame, features, observations = setup.frame, setup.features, setup.observations
    kept, units, obs, before, counts = (
        setup.kept,
        setup.units,
        setup.obs,
        setup.before,
        setup.counts,
    )
    rejected = (*no_spread, *setup.rejected)
    if solution is None:
        return _unsolved(kept, mount, requested, obs, features, before, counts, rejected)
    while True:
        if solution.at_bound:
            obs = obs.without(_latency_at_bound(solution))
            if not obs.estimated:
                return _unsolved(kept, mount, requested, obs, features, before, counts, rejected)
            steps.say(f"solving for {len(obs.estimated)} parameters, {len(features)} features")
            solution = _solve_again(
                models, observations, features, prior, solution, obs, frame, opt
            )
            continue
        jk = _jackknife(
            models, observations, solution, frame, units, opt, steps.within("jackknife")
        )
        std, method = _std(solution, jk)
        steps.start("held parameters", "what the held parameters' errors do to the estimates")
        effect = held_effect(models, observations, solution, frame, held_covariance(mount))
        offsets = (solution.values - start)[list(obs.estimated)]  # a searched yaw: no move
        held = hold_too_uncertain(obs.estimated, std, _covariance(solution, jk), effect, offsets)
        if held is None:
            break
        obs = obs.without(held)
        if not obs.estimated:
            return _unsolved(kept, mount, requested, obs, features, before, counts, rejected)
        steps.say(f"solving for {len(obs.estimated)} parameters, {len(features)} features")
        solution = _solve_again(models, observations, features, prior, solution, obs, frame, opt)
    honest = jk is not None and jk.honest
    params = _parameters(mount, requested, obs, solution, std, honest, effect)
    advice = obs.advice() if honest else (*obs.advice(), _lines_advice(len(units), jk))
    covariance = _covariance(solution, jk) + effect.covariance
    fitted = [f.feature for f in solution.features]
    overlaps_before = overlap_differences(models, observations, features, prior, frame)
    overlaps_after = overlap_differences(models, observations, fitted, solution.values, frame)
    summaries = _summaries(solution, before, overlaps_before, overlaps_after)
    calibrated, notes = _calibrated_mount(mount, solution, covariance, effect, honest, requested)
    return CalibrationResult(
        mount=calibrated,
        prior=mount,
        parameters=params,
        sigma_method=method + _held_method(effect),
        correlation_names=tuple(PARAMETER_NAMES[i] for i in obs.estimated),
        correlation=correlation(covariance),
        features=summaries,
        residual_rms_before_m=_pooled_rms(before, counts),
        residual_rms_after_m=_pooled_rms(
            [s.rms_after_m for s in summaries], [s.n_points for s in summaries]
        ),
        unobservable_reasons=obs.explanation(),
        advice=advice,
        lines=tuple(line.name for line in kept),
        iterations=solution.iterations,
        overlaps_before=overlaps_before,
        overlaps_after=overlaps_after,
        rejected_lines=rejected,
        held=effect if effect.held else None,
        held_advice=effect.advice(std, requested),
        uncertainty_notes=notes,
        warnings=(
            *(() if searched is None else (searched[1],)),
            *_warnings(lines, kept, observations, features, before, counts, summaries),
            *filter(None, [gimbal_lock_warning(calibrated.boresight_rpy_deg[1])]),
        ),
        sigma_honest=honest,
    )


def _solve_refinding(
    lines: Sequence[ScanLine],
    models: Sequence[LineModel],
    prior: FloatArray,
    start: FloatArray,
    requested: tuple[int, ...],
    groups: Sequence[tuple[str, set[int]]] | None,
    opt: CalibrationOptions,
    steps: CalibrationSteps,
    memo: dict[bytes, _Found],
) -> tuple[_Setup, Adjustment | None]:
    """Features found with ``start`` and solved; found again while the solution moves far.

    ``start`` is the prior, or the prior with a searched yaw (`_search_yaw`).

    Planar patches found with a solution further from the mount they were found with
    than a crew knows anyway (`kinsync.calibration.gross.far_from_start`) are found
    again with it, up to `MAX_FEATURE_ROUNDS` times, each solve starting from the
    solution the features were found with. Spheres are not: each line's sphere is fitted
    in its own returns and only their pairing depends on the mount, and on the CIDCO
    passes (fitted radius) finding them again let the lever z, unobservable at the
    start, wander to -3.2 m. When such a solve cannot leave its start, or the features found
    again determine nothing, the round before is kept. Returns the features and their
    solution (None when the data determine no parameter).

    Raises
    ------
    ConvergenceError
        The solution never left its start (`kinsync.calibration.gross.stuck_at_start`).
    """
    rounds = 0
    last: tuple[_Setup, Adjustment | None] | None = None
    while True:
        setup = _setup(lines, models, prior, start, requested, groups, opt, memo)
        if not setup.obs.estimated:
            return last if last is not None else (setup, None)
        n_estimated, n_features = len(setup.obs.estimated), len(setup.features)
        steps.start("solving", f"solving for {n_estimated} parameters, {n_features} features")
        solution = adjust(
            models, setup.observations, setup.features, start, setup.obs.estimated,
            setup.frame, opt.adjustment,
        )  # fmt: skip
        stuck = stuck_at_start(
            solution.values, start, setup.obs.estimated, _pooled_rms(setup.before, setup.counts)
        )
        if stuck is not None:
            if last is None:
                raise stuck
            return last  # found again, no step leaves the last solution: keep it
        if (
            opt.features != "planes"
            or rounds >= MAX_FEATURE_ROUNDS
            or not far_from_start(solution.values, start, setup.obs.estimated)
        ):
            return setup, solution
        last = (setup, solution)
        rounds += 1
        start = solution.values
        steps.say("finding the features again with the mount solved so far")


def _search_yaw(
    lines: Sequence[ScanLine],
    models: Sequence[LineModel],
    prior: FloatArray,
    requested: tuple[int, ...],
    opt: CalibrationOptions,
    say: Callable[[str], None],
    memo: dict[bytes, _Found],
) -> tuple[FloatArray, str] | None:
    """`kinsync.calibration.gross.search_yaw` with this calibration's patches."""
    if opt.features != "planes" or BORESIGHT[2] not in requested:
        return None

    def find(values: FloatArray) -> tuple[list[Feature], list[Observation]]:
        kept = memo if values is prior else None  # not the 71 turned yaws
        _, features, observations = _frame_and_features(lines, models, values, opt, kept)
        return features, observations

    return search_yaw(lines, prior, find, say)


def _solve_again(
    models: Sequence[LineModel],
    observations: Sequence[Observation],
    features: Sequence[Feature],
    prior: FloatArray,
    last: Adjustment,
    obs: Observability,
    frame: LocalFrame,
    opt: CalibrationOptions,
) -> Adjustment:
    """The solution again after a parameter is held, started from the prior.

    When the features were found again with a solution far from the prior, the prior may
    lie beyond the robust band of their returns and the solve stop there at once; it is
    then started from the last solution's values (the held parameter at its prior).
    """
    solution = adjust(models, observations, features, prior, obs.estimated, frame, opt.adjustment)
    if not at_start(solution.values, prior, obs.estimated):
        return solution
    mask = np.zeros(prior.size, dtype=bool)
    mask[list(obs.estimated)] = True
    warm = np.where(mask, last.values, prior)
    return adjust(models, observations, features, warm, obs.estimated, frame, opt.adjustment)


@dataclass(frozen=True)
class _Setup:
    """The features found with one starting mount, and what follows from them."""

    frame: LocalFrame
    features: list[Feature]
    observations: list[Observation]
    rejected: tuple[tuple[str, str], ...]
    kept: list[ScanLine]
    units: list[tuple[str, set[int]]]
    obs: Observability
    before: list[float]
    counts: list[int]


def _setup(
    lines: Sequence[ScanLine],
    models: Sequence[LineModel],
    prior: FloatArray,
    start: FloatArray,
    requested: tuple[int, ...],
    groups: Sequence[tuple[str, set[int]]] | None,
    opt: CalibrationOptions,
    memo: dict[bytes, _Found],
) -> _Setup:
    """Features found with the mount ``start``, and what follows from them.

    The observability is taken there; the residuals with the prior (the mount given:
    what ``before`` reports).
    """
    frame, features, observations = _frame_and_features(lines, models, start, opt, memo)
    S, motion, _ = reduced_normal_matrix(
        models, observations, features, start, requested, frame, robust=False
    )
    used = sorted({o.line for o in observations})
    units = _units(lines, used, groups)
    honest = opt.jackknife and len(units) >= MIN_JACKKNIFE_GROUPS
    before = _rms_before(models, observations, features, prior, frame)
    return _Setup(
        frame=frame,
        features=features,
        observations=observations,
        rejected=_rejected_lines(lines, observations, opt.features),
        kept=[lines[i] for i in used],
        units=units,
        obs=analyse(S, motion, requested, honest_sigma=honest),
        before=before,
        counts=[
            sum(o.index.size for o in observations if o.feature == k) for k in range(len(features))
        ],
    )


def _warnings(
    lines: Sequence[ScanLine],
    kept: Sequence[ScanLine],
    observations: Sequence[Observation],
    features: Sequence[Feature],
    before: Sequence[float],
    counts: Sequence[int],
    summaries: Sequence[FeatureSummary],
) -> tuple[str, ...]:
    """What the user must know before trusting the estimates (`kinsync.calibration.gross`)."""
    out = list(two_passes_in_a_line(list(kept)))
    unlinked = unlinked_directions(lines, observations, features)
    if unlinked is not None:
        out.append(unlinked)
    rise = residual_rise(
        _pooled_rms(before, counts),
        _pooled_rms([s.rms_after_m for s in summaries], [s.n_points for s in summaries]),
    )
    if rise is not None:
        out.append(rise)
    return tuple(out)


def _calibrated_mount(
    mount: Mount,
    solution: Adjustment,
    covariance: FloatArray,
    effect: HeldEffect,
    honest: bool,
    requested: tuple[int, ...],
) -> tuple[Mount, tuple[str, ...]]:
    """The calibrated mount, with the covariance it is now known to; notes.

    Estimated parameters get their sigma (data and held together) when it is honest
    (else none: a formal sigma is 3-30x too small); held ones keep the prior's; the
    correlations are those of `kinsync.calibration.held.joint_covariance` (an estimate
    follows the held values' errors). An estimate that a held value taken as exact would
    move by more than half its sigma, the one it would be written with
    (`HeldEffect.exact_that_matter`), gets none either:
    its sigma holds no part of that error, and a later calibration would trust it. The
    notes say what is left out of the ``[uncertainty]`` written and why, and which
    estimate is now known less well than the mount stated.
    """
    prior_cov = held_covariance(mount)
    prior_std = held_std(mount)
    joint = joint_covariance(covariance, effect, prior_cov)
    est = list(solution.estimated)
    total_std = np.sqrt(np.maximum(np.diag(covariance), 0.0))
    exact = [(h, est[j], share) for h, j, share in effect.exact_that_matter(total_std)]
    dropped = est if not honest else sorted({e for _, e, _ in exact})
    if dropped:
        joint[dropped, :] = 0.0
        joint[:, dropped] = 0.0
        joint[dropped, dropped] = np.nan
    std = np.sqrt(np.where(np.diag(joint) >= 0.0, np.diag(joint), np.nan))
    calibrated = mount_from_values(mount, solution.values)
    notes = uncertainty_notes(prior_std, std, solution.estimated, honest, exact, requested)
    return replace(calibrated, uncertainty=uncertainty_from_covariance(joint)), notes


def _held_method(held: HeldEffect) -> str:
    """What the sigma holds of the held parameters, in words (empty when none are held)."""
    if not held.held:
        return ""
    known = [PARAMETER_NAMES[i] for i in held.held if i not in held.unknown]
    exact = [PARAMETER_NAMES[i] for i in held.unknown]
    parts = []
    if known:
        parts.append(f"plus the stated uncertainty of the held {', '.join(known)}")
    if exact:
        parts.append(f"the held {', '.join(exact)} taken as exact (no [uncertainty] given)")
    return "; " + "; ".join(parts)


def _lines_advice(n_lines: int, jk: Jackknife | None) -> str:
    """Why every estimate is ``weak`` when the sigma is not honest, and what would help."""
    if jk is None or not jk.valid:
        what = "the sigma is the formal one, 3-30x too small on real data"
    else:
        what = f"a jackknife with {jk.dof} degrees of freedom"
    return (
        f"an honest sigma: at least {MIN_HONEST_DOF + 1} independent lines or passes over "
        f"the features ({n_lines} given: {what}, so no estimate is better than weak)"
    )


def _latency_at_bound(solution: Adjustment) -> HeldAfterSolution:
    """The latency held: the solution took it to the end of the lines' trajectories."""
    assert solution.latency_bounds_s is not None
    lo, hi = (b * 1e3 for b in solution.latency_bounds_s)
    value = float(solution.values[LATENCY]) * 1e3
    reason = (
        f"the adjustment ran it to {value:+.1f} ms, the end of what the lines' trajectories "
        f"cover ({lo:+.1f} .. {hi:+.1f} ms; the trajectory is never extrapolated): these "
        "data do not determine it"
    )
    return HeldAfterSolution(LATENCY, LATENCY, math.nan, reason=reason)


def _frame_and_features(
    lines: Sequence[ScanLine],
    models: Sequence[LineModel],
    prior: FloatArray,
    opt: CalibrationOptions,
    memo: dict[bytes, _Found] | None = None,
) -> _Found:
    """The local frame of the lines that see a feature, the features and observations.

    The features are found in the frame of all the lines; when some line sees none,
    again in the frame of the lines kept, so that a rejected line changes nothing.
    ``memo`` keeps them by mount values (the yaw search and the first solve look at the
    prior's).
    """
    key = np.asarray(prior, dtype=np.float64).tobytes()
    if memo is not None and key in memo:
        return memo[key]
    frame = local_frame_for(lines)
    features, observations = find_features(models, prior, frame, opt)
    seen = sorted({o.line for o in observations})
    if 0 < len(seen) < len(lines):
        frame = local_frame_for([lines[i] for i in seen])
        features, observations = find_features(models, prior, frame, opt)
    if memo is not None:
        memo[key] = (frame, features, observations)
    return frame, features, observations


def _rejected_lines(
    lines: Sequence[ScanLine], observations: Sequence[Observation], kind: FeatureKind
) -> tuple[tuple[str, str], ...]:
    """The lines none of whose returns lie on a feature, with the reason."""
    seen = {o.line for o in observations}
    what = "sphere" if kind == "spheres" else "planar patch"
    return tuple(
        (
            line.name,
            (
                f"none of its {len(line)} returns lie on a {what} another line also sees: "
                "left out of the adjustment and of the jackknife"
            ),
        )
        for i, line in enumerate(lines)
        if i not in seen
    )


def _units(
    lines: Sequence[ScanLine], used: Sequence[int], groups: Sequence[tuple[str, set[int]]] | None
) -> list[tuple[str, set[int]]]:
    """The jackknife's units: one per line used, or the groups with a line used."""
    if groups is None:
        return [(lines[i].name, {i}) for i in used]
    return [(name, members) for name, members in groups if members & set(used)]


def _jackknife(
    models: Sequence[LineModel],
    observations: Sequence[Observation],
    solution: Adjustment,
    frame: LocalFrame,
    units: Sequence[tuple[str, set[int]]],
    opt: CalibrationOptions,
    progress: Progress | None,
) -> Jackknife | None:
    if not opt.jackknife:
        return None
    if len(units) < MIN_JACKKNIFE_GROUPS:
        return None
    return jackknife(models, observations, solution, frame, units, opt.adjustment, progress)


def _covariance(solution: Adjustment, jk: Jackknife | None) -> FloatArray:
    """The reported covariance: the jackknife's when valid, else the formal one."""
    return solution.covariance if jk is None or not jk.valid else jk.covariance


def _std(solution: Adjustment, jk: Jackknife | None) -> tuple[FloatArray, str]:
    formal = np.sqrt(np.maximum(np.diag(solution.covariance), 0.0))
    if jk is not None and jk.valid:
        return jk.std, (
            f"jackknife over {len(jk.groups)} lines (delete one line at a time): holds "
            "the errors shared by the returns of a line (navigation "
            f"errors, range biases); with {jk.dof} degrees of freedom a 95 % interval is "
            f"+-{jk.t95:.2f} sigma (Student t)"
        )
    if not np.all(np.isfinite(formal) & (formal > 0.0)):
        msg = (
            "the calibration's solution has no standard deviation (a formal sigma of zero "
            "or none): it fits nothing; estimate fewer parameters or give more lines"
        )
        raise ConvergenceError(msg)
    if jk is None:
        why = f"fewer than {MIN_JACKKNIFE_GROUPS} lines for a jackknife, or it was not asked for"
    elif jk.failed:
        why = f"without {', '.join(jk.failed)} the parameters are not determined"
    else:
        why = (
            "the jackknife's spread is zero or undefined: the deleted-line solutions did not "
            "move from the full one"
        )
    return formal, (
        f"formal ({why}): assumes independent errors from return to return and is "
        "optimistic on real data"
    )


def _unsolved(
    lines: Sequence[ScanLine],
    mount: Mount,
    requested: tuple[int, ...],
    obs: Observability,
    features: Sequence[Feature],
    before: list[float],
    counts: list[int],
    rejected: tuple[tuple[str, str], ...] = (),
) -> CalibrationResult:
    """Nothing the data can determine: the prior mount, every parameter's status, advice."""
    summaries = tuple(
        FeatureSummary(f.kind, f.describe(), counts[i], 0, before[i], before[i])
        for i, f in enumerate(features)
    )
    rms = _pooled_rms(before, counts)
    return CalibrationResult(
        mount=mount,
        prior=mount,
        parameters=_parameters(mount, requested, obs, None, None),
        sigma_method="none: no parameter could be determined",
        sigma_honest=False,
        correlation_names=(),
        correlation=np.zeros((0, 0)),
        features=summaries,
        residual_rms_before_m=rms,
        residual_rms_after_m=rms,
        unobservable_reasons=obs.explanation(),
        advice=obs.advice(),
        lines=tuple(line.name for line in lines),
        iterations=0,
        rejected_lines=rejected,
    )
