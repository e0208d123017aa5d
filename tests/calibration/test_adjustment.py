"""The calibration's model and adjustment on the analytic patch test (known planes)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from kinsync.calibration.adjustment import Observation, adjust, reduced_normal_matrix
from kinsync.calibration.estimator import CalibrationOptions
from kinsync.calibration.features import Feature, plane_from_points
from kinsync.calibration.lines import ScanLine
from kinsync.calibration.model import LineModel, LocalFrame, local_frame_for
from kinsync.calibration.observability import analyse
from kinsync.calibration.parameters import (
    PARAMETER_NAMES,
    REPORT_SCALE,
    estimated_indices,
    mount_from_values,
    mount_values,
)
from kinsync.errors import InputError
from kinsync.georef import GeorefTrajectory, georeference
from kinsync.mount import Mount

from .conftest import NOMINAL, PLANES, TRUE, Synthetic

ALL = tuple(range(7))


def _problem(
    syn: Synthetic, start: Mount
) -> tuple[list[LineModel], list[Observation], list[Feature], LocalFrame, np.ndarray]:
    models = [LineModel.prepare(line, {}) for line in syn.lines]
    frame = local_frame_for(syn.lines)
    values = mount_values(start)
    observations: list[Observation] = []
    features: list[Feature] = []
    for k in range(len(PLANES)):
        pts = []
        for li, (model, lab) in enumerate(zip(models, syn.labels, strict=True)):
            idx = np.flatnonzero(lab == k)
            if idx.size:
                observations.append(Observation(li, len(features), idx))
                pts.append(model.points(idx, values, frame))
        if pts:
            features.append(plane_from_points(np.concatenate(pts)))
    return models, observations, features, frame, values


def test_model_is_the_georeferencing_kernel_and_its_jacobian_is_exact(
    synthetic: Callable[..., Synthetic],
) -> None:
    syn = synthetic(repeats=1, speeds=(8.0,), ways=((30.0, (0.0, 0.0)),), n_per_plane=80)
    line = syn.lines[0]
    mount = Mount(lever_arm_body_m=(0.4, -0.3, -1.2), boresight_rpy_deg=(179.7, -4.2, 31.0),
                  latency_s=0.004)  # fmt: skip
    model = LineModel.prepare(line)
    frame = local_frame_for([line])
    values = mount_values(mount)
    x, jac, beam = model.points_and_jacobian(None, values, ALL, frame)
    ref, _ = georeference(
        line.t_s, line.xyz_scanner_m, GeorefTrajectory.from_trajectory(line.trajectory, 0.004),
        mount,
    )  # fmt: skip
    np.testing.assert_allclose(x, frame.points(ref), rtol=0, atol=1e-7)
    np.testing.assert_allclose(np.linalg.norm(beam, axis=1), 1.0, atol=1e-9)
    steps = (1e-5, 1e-5, 1e-5, 1e-3, 1e-3, 1e-3, 1e-4)
    for k, h in enumerate(steps):
        up, down = values.copy(), values.copy()
        up[k] += h
        down[k] -= h
        fd = (model.points(None, up, frame) - model.points(None, down, frame)) / (2 * h)
        scale = np.abs(jac[:, :, k]).max()
        assert np.abs(fd - jac[:, :, k]).max() < 2e-3 * scale, PARAMETER_NAMES[k]


def test_noise_free_data_give_the_true_mount_exactly(synthetic: Callable[..., Synthetic]) -> None:
    # Large boresight angles in every axis: the rotation order must match the kernel's.
    true = Mount(lever_arm_body_m=(0.55, -0.15, -1.04), boresight_rpy_deg=(2.0, -3.0, 4.0),
                 latency_s=0.005)  # fmt: skip
    syn = synthetic(mount=true, range_noise_m=0.0)
    models, obs, feats, frame, v0 = _problem(syn, NOMINAL)
    sol = adjust(models, obs, feats, v0, ALL, frame)
    err = (sol.values - mount_values(true)) * REPORT_SCALE
    # deg, m, ms: float noise only
    assert np.all(np.abs(err) < [1e-6, 1e-6, 1e-6, 1e-6, 1e-6, 1e-5, 1e-4]), err
    assert mount_from_values(NOMINAL, sol.values).boresight_rpy_deg == pytest.approx(
        true.boresight_rpy_deg, abs=1e-6
    )


def test_injected_latency_comes_back_with_its_sign(synthetic: Callable[..., Synthetic]) -> None:
    for latency_s in (0.005, -0.005):
        true = Mount(lever_arm_body_m=NOMINAL.lever_arm_body_m, latency_s=latency_s)
        syn = synthetic(mount=true, seed=3)
        models, obs, feats, frame, v0 = _problem(syn, NOMINAL)
        sol = adjust(models, obs, feats, v0, estimated_indices("latency"), frame)
        tau = sol.values[6]
        sd = float(np.sqrt(sol.covariance[0, 0]))
        assert abs(tau - latency_s) < max(4 * sd, 2e-4), (tau, sd)


def test_noisy_estimate_within_four_formal_sigmas(synthetic: Callable[..., Synthetic]) -> None:
    # Independent range noise only: the formal sigma is the right one here.
    syn = synthetic(seed=5)
    models, obs, feats, frame, v0 = _problem(syn, NOMINAL)
    sol = adjust(models, obs, feats, v0, ALL, frame)
    err = sol.values - mount_values(TRUE)
    sd = np.sqrt(np.diag(sol.covariance))
    assert np.all(np.abs(err) < 4 * sd), (err / sd).round(2)
    assert 0.7 < sol.sigma0 < 1.3
    assert sol.iterations < 20
    for fit in sol.features:
        assert fit.n_lines == 4
        assert fit.rms_m < 0.006


def test_robust_weights_set_outliers_aside(synthetic: Callable[..., Synthetic]) -> None:
    syn = synthetic(seed=6)
    # Push 5 % of one line's returns 0.5 m along their beams (vegetation, a car).
    line = syn.lines[0]
    rng = np.random.default_rng(0)
    bad = rng.choice(len(line), len(line) // 20, replace=False)
    xyz = np.array(line.xyz_scanner_m)
    xyz[bad] *= 1.0 + 0.5 / np.linalg.norm(xyz[bad], axis=1, keepdims=True)
    lines = (ScanLine(line.name, line.t_s, xyz, line.trajectory), *syn.lines[1:])
    syn2 = Synthetic(lines, syn.labels)
    models, obs, feats, frame, v0 = _problem(syn2, NOMINAL)
    sol = adjust(models, obs, feats, v0, ALL, frame)
    err = sol.values - mount_values(TRUE)
    sd = np.sqrt(np.diag(sol.covariance))
    assert np.all(np.abs(err) < 5 * sd), (err / sd).round(2)
    assert sum(f.n_points for f in sol.features) < sum(o.index.size for o in obs) - len(bad) // 2


@pytest.mark.parametrize(
    ("case", "expected"),
    [
        ({"planes": ("ground",)}, {"lever_z_m", "boresight_yaw_deg"}),
        # one speed, no roll or pitch dynamics: latency and lever x move the returns
        # alike (the gentle roll of the other cases gives the latency a little of its own)
        ({"speeds": (8.0,), "roll_amp_rad": 0.0}, {"latency_ms"}),
        ({"speeds": (8.0,), "ways": ((0.0, (-30.0, 0.0)),)}, {"latency_ms", "lever_x_m"}),
    ],
)
def test_what_the_data_cannot_determine_is_found_before_solving(
    synthetic: Callable[..., Synthetic], case: dict[str, object], expected: set[str]
) -> None:
    syn = synthetic(seed=7, range_noise_m=0.0, **case)
    models, obs, feats, frame, v0 = _problem(syn, NOMINAL)
    S, motion, _ = reduced_normal_matrix(
        models, obs, feats, v0, ALL, frame, [0.005] * len(feats), robust=False
    )
    found = analyse(S, motion, ALL)
    held = {PARAMETER_NAMES[i] for i in found.unobservable}
    assert expected <= held, held
    assert found.advice()
    assert found.explanation()


def test_the_full_design_determines_everything_but_lever_z(
    synthetic: Callable[..., Synthetic],
) -> None:
    # Every plane here is free: a lever z moves every line the same way (absorbed).
    syn = synthetic(seed=7, range_noise_m=0.0)
    models, obs, feats, frame, v0 = _problem(syn, NOMINAL)
    S, motion, _ = reduced_normal_matrix(
        models, obs, feats, v0, ALL, frame, [0.005] * len(feats), robust=False
    )
    found = analyse(S, motion, ALL)
    assert [PARAMETER_NAMES[i] for i in found.unobservable] == ["lever_z_m"]


def test_estimate_groups() -> None:
    assert estimated_indices("boresight,latency") == (0, 1, 2, 6)
    assert estimated_indices(("lever_xy",)) == (3, 4)
    with pytest.raises(InputError, match="unknown group 'bore'"):
        estimated_indices("bore")
    with pytest.raises(InputError, match="at least one"):
        estimated_indices(" , ")


def test_options_store_the_groups_as_a_tuple_and_take_only_a_bool_jackknife() -> None:
    as_set: object = {"latency", "boresight"}
    as_list: object = ["latency"]
    as_text: object = "boresight, latency"
    both = ("boresight", "latency")
    assert CalibrationOptions(estimate=as_set).estimate == both  # type: ignore[arg-type]
    assert CalibrationOptions(estimate=as_list).estimate == ("latency",)  # type: ignore[arg-type]
    assert CalibrationOptions(estimate=as_text).estimate == both  # type: ignore[arg-type]
    numpy_false: object = np.bool_(False)  # noqa: FBT003
    assert CalibrationOptions(jackknife=numpy_false).jackknife is False  # type: ignore[arg-type]
    with pytest.raises(InputError, match=r"estimate \(--estimate\): unknown group 'bore'"):
        CalibrationOptions(estimate=("bore",))
    for bad in (3, None):
        with pytest.raises(InputError, match="estimate: expected a tuple of group names"):
            CalibrationOptions(estimate=bad)  # type: ignore[arg-type]
    for value in ("no", 0, None):
        with pytest.raises(InputError, match="jackknife: expected True or False"):
            CalibrationOptions(jackknife=value)  # type: ignore[arg-type]
    with pytest.raises(InputError, match=r"features \(--features\) must be planes or spheres"):
        CalibrationOptions(features="plane")  # type: ignore[arg-type]


def test_a_return_pushed_out_of_its_trajectory_costs_more_than_any_it_fits() -> None:
    # With the robust weights held, a return whose navigation tag left its trajectory
    # has no residual; it used to cost nothing, so a step that pushed every return out
    # (the latency to -945 ms on four CIDCO passes) lowered the cost to zero and was
    # taken as the solution. It costs what a return at the edge of the band costs.
    from kinsync.calibration import adjustment as adj  # noqa: PLC0415

    sigma = 0.01
    held = np.ones(2)
    anchor = np.zeros((2, 3))
    inside = adj._AtState(np.array([True, True]), anchor, np.array([0.0, 4.0 * sigma]), held)
    left = adj._AtState(np.array([True, False]), anchor, np.array([0.0, 0.0]), held)
    for robust in (True, False):
        frozen = held if robust else None
        assert adj._feature_cost(left, sigma, robust, frozen) > adj._feature_cost(
            inside, sigma, robust, frozen
        )
