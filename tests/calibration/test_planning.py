"""The planner: predicted sigma and status of a survey design, before the survey."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kinsync.calibration.estimator import CalibrationOptions
from kinsync.calibration.planning import NavigationErrors, PlanResult, plan_calibration
from kinsync.errors import InputError
from kinsync.mount import MountUncertainty
from kinsync.sim.patch_config import PatchTestConfig
from kinsync.sim.patch_test import simulate_patch_test

ALL = CalibrationOptions(estimate=("boresight", "lever", "latency"))
QUIET = {"range_noise_m": 0.0, "std_pos_ned_m": (0.0,) * 3, "std_att_deg": (0.0,) * 3}


def _plan(errors: NavigationErrors | None = None, **config: object) -> PlanResult:
    cfg = PatchTestConfig(scenario="vehicle", density=0.03, **QUIET, **config)  # type: ignore[arg-type]
    sim = simulate_patch_test(cfg)
    return plan_calibration(sim.lines, sim.mount_true, ALL, errors)


def _std(plan: PlanResult, name: str) -> float:
    return next(p.std for p in plan.parameters if p.name == name)


def test_vehicle_design() -> None:
    plan = _plan()
    status = {p.name: p.status for p in plan.parameters}
    assert status["lever_z_m"] == "unobservable"
    assert all(s in ("estimated", "weak") for n, s in status.items() if n != "lever_z_m")
    for p in plan.parameters:
        if p.status != "unobservable":
            # the navigation errors a line shares dominate the range noise
            assert p.std > 3.0 * p.std_noise_only > 0.0
    assert any("lever z" in a for a in plan.advice)
    doc = plan.as_document()
    assert doc["parameters"]["lever_z_m"]["std"] is None
    assert doc["assumed_errors"]["corr_time_s"] == 15.0


def test_sigma_scales_with_the_assumed_errors() -> None:
    quiet = _plan(NavigationErrors(position_std_m=0.0, attitude_std_deg=(0.0, 0.0, 0.0)))
    noisy = _plan(NavigationErrors(position_std_m=0.04))
    for name in ("boresight_roll_deg", "lever_y_m", "latency_ms"):
        assert _std(quiet, name) < _std(noisy, name)
        assert math.isclose(
            next(p.std_noise_only for p in quiet.parameters if p.name == name),
            _std(quiet, name),
            rel_tol=1e-9,
        )


def test_position_sigma_per_axis() -> None:
    one = _plan(NavigationErrors(position_std_m=0.02))
    same = _plan(NavigationErrors(position_std_m=(0.02, 0.02, 0.02)))
    worse_height = _plan(NavigationErrors(position_std_m=(0.02, 0.02, 0.06)))
    worse_north = _plan(NavigationErrors(position_std_m=(0.06, 0.02, 0.02)))
    for p, q in zip(one.parameters, same.parameters, strict=True):
        assert p.std == q.std or (math.isnan(p.std) and math.isnan(q.std))
    # The roll boresight is told by the ground's heights; a north error hardly moves it.
    roll = [_std(p, "boresight_roll_deg") for p in (one, worse_height, worse_north)]
    assert roll[1] > 1.2 * roll[0], roll
    assert roll[2] < roll[1], roll
    assert worse_height.as_document()["assumed_errors"]["position_std_m"] == [0.02, 0.02, 0.06]


@pytest.mark.parametrize("bad", [(0.02, 0.02), (0.02, math.nan, 0.02), (0.02, 0.02, -0.01)])
def test_position_sigma_refused(bad: tuple[float, ...]) -> None:
    with pytest.raises(InputError, match=r"position sigma|planning errors"):
        NavigationErrors(position_std_m=bad)  # type: ignore[arg-type]


def test_one_speed_leaves_the_latency_undetermined() -> None:
    plan = _plan(speeds_m_s=(8.0,))
    assert {p.name: p.status for p in plan.parameters}["latency_ms"] != "estimated"


@pytest.mark.parametrize(
    "kwargs",
    [{"range_noise_m": 0.0}, {"position_std_m": -1.0}, {"corr_time_s": 0.0},
     {"attitude_std_deg": (0.0, float("nan"), 0.0)}],
)  # fmt: skip
def test_bad_errors(kwargs: dict[str, object]) -> None:
    with pytest.raises(InputError):
        NavigationErrors(**kwargs)  # type: ignore[arg-type]


def test_a_range_noise_of_zero_is_named() -> None:
    with pytest.raises(InputError, match=r"^range noise \(--range-noise-m\) must be .* got 0\.0"):
        NavigationErrors(range_noise_m=0.0)


def test_held_values_stated_sigma_reaches_the_planned_sigma() -> None:
    sim = simulate_patch_test(PatchTestConfig(scenario="vehicle", density=0.03, **QUIET))  # type: ignore[arg-type]
    opts = CalibrationOptions(estimate=("boresight", "latency"))
    exact = plan_calibration(sim.lines, sim.mount_true, opts)
    lever = MountUncertainty(lever_arm_body_m=(0.02, 0.02, 0.02))
    held = plan_calibration(sim.lines, sim.mount_true, opts, held=lever)
    for before, after in zip(exact.parameters, held.parameters, strict=True):
        assert after.status in (before.status, "weak"), before.name
        if not math.isfinite(before.std):
            assert not math.isfinite(after.std)
            continue
        assert before.std_held == 0.0
        assert after.std_noise_only == before.std_noise_only
        assert after.std == pytest.approx(math.hypot(before.std, after.std_held), rel=1e-9)
    latency = next(p for p in held.parameters if p.name == "latency_ms")
    assert latency.std_held > 0.5  # ms: 2 cm of lever x is ~1 ms of latency at these speeds
    doc = held.as_document()
    assert doc["held"]["lever_x_m"]["std"] == pytest.approx(0.02)
    assert doc["held"]["lever_x_m"]["per_reference_error"]["latency_ms"] < 0.0
    assert doc["parameters"]["latency_ms"]["std_held"] == pytest.approx(latency.std_held)
    # the same sensitivity as the estimator's: x forward, the latency takes it up as v dt
    d = held.held.sensitivity[held.held.estimated.index(6), 3]
    assert d == pytest.approx(exact.held.sensitivity[exact.held.estimated.index(6), 3])
    assert exact.as_document()["held"]["lever_x_m"]["std"] is None  # taken as exact


def test_a_held_value_known_too_poorly_leaves_the_estimates_unobservable() -> None:
    # A lever arm known to 0.9 m: the yaw's sigma was printed as a weak +-22 deg, the
    # latency's as a weak +-100 ms; the status reads the total, so they are unobservable,
    # with what the lever arm's sigma would have to be.
    sim = simulate_patch_test(PatchTestConfig(scenario="vehicle", density=0.03, **QUIET))  # type: ignore[arg-type]
    opts = CalibrationOptions(estimate=("boresight", "latency"))
    lever = MountUncertainty(lever_arm_body_m=(0.9, 0.9, 0.9))
    plan = plan_calibration(sim.lines, sim.mount_true, opts, held=lever)
    for p in plan.parameters:
        assert p.status == ("fixed" if p.name.startswith("lever") else "unobservable"), p.name
        assert not math.isfinite(p.std)
    yaw = next(r for r in plan.unobservable_reasons if r.startswith("boresight_yaw_deg"))
    assert "(more than 1): these data give +-" in yaw
    assert "the rest is the stated sigma of the held lever_y_m" in yaw
    advice = next(a for a in plan.advice if a.startswith("boresight_yaw_deg: "))
    assert "lever_y_m known to +-0.0" in advice
    assert "instead of +-0.9" in advice
    assert not any("a better trajectory" in a for a in plan.advice)


def test_predicted_feature_scales_are_what_the_estimator_finds() -> None:
    # The plan weighs each feature by the noise scale it predicts from the navigation
    # errors; the estimator measures that scale from the residuals of noisy data.
    from kinsync.calibration.adjustment import adjust  # noqa: PLC0415
    from kinsync.calibration.estimator import find_features  # noqa: PLC0415
    from kinsync.calibration.model import LineModel, local_frame_for  # noqa: PLC0415
    from kinsync.calibration.parameters import mount_values  # noqa: PLC0415
    from kinsync.calibration.planning import _navigation_scatter  # noqa: PLC0415

    cfg = PatchTestConfig(scenario="vessel", density=0.05, seed=1)
    sim = simulate_patch_test(cfg)
    cache: dict[int, object] = {}
    models = [LineModel.prepare(line, cache) for line in sim.lines]  # type: ignore[arg-type]
    frame = local_frame_for(list(sim.lines))
    values = mount_values(sim.mount_true)
    opts = CalibrationOptions(estimate=("boresight", "latency"))
    features, observations = find_features(models, values, frame, opts)
    solution = adjust(models, observations, features, values, (0, 1, 2, 6), frame)
    measured = np.array([f.sigma_m for f in solution.features])
    errors = NavigationErrors(
        range_noise_m=cfg.range_noise_m,
        position_std_m=float(np.mean(cfg.std_pos_ned_m)),
        attitude_std_deg=cfg.std_att_deg,
        corr_time_s=cfg.error_corr_time_s,
    )
    scatter = _navigation_scatter(models, observations, features, values, frame, errors)
    predicted = np.hypot(cfg.range_noise_m, np.array(scatter))
    assert 0.8 < float(np.median(measured / predicted)) < 1.4
    assert float(np.median(predicted)) > 2.0 * cfg.range_noise_m  # navigation dominates
