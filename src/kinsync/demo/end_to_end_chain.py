"""The end-to-end demo's chain: INS/GNSS, Method B, georeferencing and validation.

`run_chain` processes the survey of `kinsync.demo.end_to_end_survey` as a user would:
the smoothed INS/GNSS trajectory, the profile clock from sync points on it, the cloud
georeferenced with the estimated clock, and the validation of control points and the
wall for the correct calibration, a latency 5 ms too large and a period error.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from kinsync.clock.profile import ProfileClock
from kinsync.demo.end_to_end_survey import (
    CONTROL_RADIUS_M,
    TARGET_INTENSITY_MIN,
    Survey,
    georeference_scan,
    wall_selection,
)
from kinsync.ins.alignment import align_static_gnss_heading
from kinsync.ins.compare import Comparison, compare_to_truth
from kinsync.ins.filter import InsResult, run_ins
from kinsync.sim.profiler import exactly_known
from kinsync.sync.config import ObjectSpaceConfig
from kinsync.sync.object_space import ObjectSpaceResult, synchronise_object_space
from kinsync.trajectory import Trajectory
from kinsync.validation import (
    CloudPoints,
    ControlPointReport,
    FlatnessResult,
    fit_wall,
    validate_control_points,
)

__all__ = [
    "CASE_LABELS",
    "CalibrationCase",
    "ChainResult",
    "run_chain",
]

CASE_LABELS = ("correct", "latency +5 ms", "period error")
"""Keys of the three calibration cases in the JSON document."""


@dataclass(frozen=True, eq=False)
class CalibrationCase:
    """One calibration applied to the scan and what validation says of it.

    Attributes
    ----------
    label : str
        One of `CASE_LABELS`.
    clock : ProfileClock
        Clock used.
    latency_s : float
        Latency used (s).
    time_error_first_s, time_error_last_s : float
        True time error of the returns of the first and the last profile (s): record
        read minus record that should have been read.
    n_points, n_outside : int
        Returns georeferenced, and left out (outside the trajectory's span).
    control : ControlPointReport
    walls : tuple of FlatnessResult
        One per pass through the turn beside the wall.
    """

    label: str
    clock: ProfileClock
    latency_s: float
    time_error_first_s: float
    time_error_last_s: float
    n_points: int
    n_outside: int
    control: ControlPointReport
    walls: tuple[FlatnessResult, ...]


@dataclass(frozen=True, eq=False)
class ChainResult:
    """Every step of the chain on one survey.

    Attributes
    ----------
    survey : Survey
    ins : InsResult
        Forward filter and smoothed solution.
    forward, smoothed : Comparison
        Each against the truth.
    trajectory : Trajectory
        The smoothed solution, used from Method B on.
    sync : ObjectSpaceResult
        Method B on that trajectory.
    sync_exact : ObjectSpaceResult
        Method B on the exact trajectory (reference: what the INS error costs).
    cases : tuple of CalibrationCase
        In the order of `CASE_LABELS`.
    equivalence_m : float
        Largest distance between the cloud of case (b) and the one made with t0 off by
        the same amount and the correct latency (m): only ``t0 + latency`` counts.
    walls_exact : tuple of FlatnessResult
        The wall passes georeferenced with the exact trajectory and the true clock
        (reference: how flat the simulated wall is without any estimation error).
    """

    survey: Survey
    ins: InsResult
    forward: Comparison
    smoothed: Comparison
    trajectory: Trajectory
    sync: ObjectSpaceResult
    sync_exact: ObjectSpaceResult
    cases: tuple[CalibrationCase, ...]
    equivalence_m: float
    walls_exact: tuple[FlatnessResult, ...]


def _walls(survey: Survey, cloud: CloudPoints) -> tuple[FlatnessResult, ...]:
    tolerance = survey.config.wall_tolerance_m
    return tuple(
        fit_wall(wall_selection(survey, cloud, w), min_bow_m=tolerance)
        for w in survey.wall_windows_s
    )


def _case(
    survey: Survey,
    trajectory: Trajectory,
    label: str,
    clock: ProfileClock,
    latency_s: float,
) -> CalibrationCase:
    sim = survey.scan
    cloud, n_out = georeference_scan(survey, trajectory, clock, latency_s)
    report = validate_control_points(
        cloud,
        survey.control,
        trajectory,
        centre="sphere",
        target_radius_m=CONTROL_RADIUS_M,
        min_intensity=TARGET_INTENSITY_MIN,
    )
    walls = _walls(survey, cloud)

    def error(x: float) -> float:
        read = clock.t0_s + x * clock.period_s + latency_s
        true = sim.t0_s + x * sim.period_s + survey.mount.latency_s
        return read - true

    return CalibrationCase(
        label=label,
        clock=clock,
        latency_s=latency_s,
        time_error_first_s=error(0.0),
        time_error_last_s=error(float(sim.n_profiles - 1)),
        n_points=len(cloud),
        n_outside=n_out,
        control=report,
        walls=walls,
    )


def run_chain(survey: Survey, progress: Callable[[str], None] | None = None) -> ChainResult:
    """INS/GNSS, Method B, georeferencing and validation for the three calibrations.

    Parameters
    ----------
    survey : Survey
        From `simulate_survey`.
    progress : callable, optional
        Called with a short label as each step starts.

    Returns
    -------
    ChainResult
    """
    cfg = survey.config
    if progress:
        progress("end-to-end: INS/GNSS filter and smoother")
    init = align_static_gnss_heading(
        survey.imu,
        survey.gnss,
        static_s=cfg.static_s - 2.0,
        antenna_lever_arm_body_m=survey.mount.antenna_lever_arm_body_m,
    )
    ins = run_ins(survey.imu, survey.gnss, survey.ins_config, init, smooth=True)
    assert ins.smoothed is not None
    trajectory = ins.smoothed.to_trajectory()
    if progress:
        progress("end-to-end: Method B on the INS trajectory")
    horizontal_std_m = float(np.sqrt(np.mean(ins.smoothed.std_pos_ned_m[:, :2] ** 2)))
    mount = exactly_known(survey.mount)  # the simulation's: exact
    sync = synchronise_object_space(
        survey.scan.scan,
        trajectory,
        mount,
        survey.sync_points,
        ObjectSpaceConfig(position_std_m=horizontal_std_m),
    )
    sync_exact = synchronise_object_space(
        survey.scan.scan,
        survey.truth,
        mount,
        survey.sync_points,
        ObjectSpaceConfig(position_std_m=0.0),
    )
    if progress:
        progress("end-to-end: georeferencing and validation, right and wrong calibration")
    tau = survey.mount.latency_s
    last_profile = survey.scan.n_profiles - 1
    clocks = (
        (sync.clock, tau),
        (sync.clock, tau + cfg.latency_error_s),
        (
            ProfileClock(sync.t0_s, sync.period_s + cfg.clock_error_s / last_profile),
            tau,
        ),
    )
    cases = tuple(
        _case(survey, trajectory, label, clock, latency)
        for label, (clock, latency) in zip(CASE_LABELS, clocks, strict=True)
    )
    shifted, _ = georeference_scan(
        survey, trajectory, ProfileClock(sync.t0_s + cfg.latency_error_s, sync.period_s), tau
    )
    late, _ = georeference_scan(survey, trajectory, sync.clock, tau + cfg.latency_error_s)
    equivalence = float(np.max(np.linalg.norm(shifted.pos_ecef_m - late.pos_ecef_m, axis=1)))
    exact_cloud, _ = georeference_scan(
        survey, survey.truth, ProfileClock(survey.scan.t0_s, survey.scan.period_s), tau
    )
    return ChainResult(
        survey=survey,
        ins=ins,
        forward=compare_to_truth(ins.forward, survey.truth),
        smoothed=compare_to_truth(ins.smoothed, survey.truth),
        trajectory=trajectory,
        sync=sync,
        sync_exact=sync_exact,
        cases=cases,
        equivalence_m=equivalence,
        walls_exact=_walls(survey, exact_cloud),
    )
