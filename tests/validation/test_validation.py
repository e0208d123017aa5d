"""Validation by simulation: control points in the vehicle frame, wall flatness/curvature.

Clouds come from `kinsync.sim.validation_scene` (a profiler on a vehicle passing
targets at 5-20 m/s both ways; a wall on the outside of a tight right turn) and the
compiled georeferencing kernel, with errors injected through the mount (latency,
boresight yaw). Estimates are checked against the estimator's own sigma and an
absolute bound.
"""

from __future__ import annotations

import math
import pickle
from dataclasses import replace
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from tests._trajectory_holes import with_gap

from kinsync.cli._box import parse_box
from kinsync.errors import InputError
from kinsync.frames import ecef_to_ned, euler_rpy_to_matrix, ned_to_ecef
from kinsync.georef import GeorefTrajectory, georeference
from kinsync.mount import Mount
from kinsync.sim.validation_scene import (
    ControlTargetScene,
    SimulatedScan,
    control_target_scene,
    curved_wall_scene,
)
from kinsync.trajectory import Trajectory
from kinsync.validation import (
    CentreMethod,
    CloudPoints,
    ControlPointDifference,
    ControlPointReport,
    TargetObservation,
    control_point_differences,
    extract_targets,
    fit_wall,
    otsu_threshold,
    pass_labels,
    select_box,
    signature_tests,
    validate_control_points,
)
from kinsync.validation.control_points import ControlPoints
from kinsync.validation.targets import AUTO_CONTRAST, nearest_control

LATENCY_ERROR_S = 0.002
YAW_ERROR_DEG = 0.1


def _cloud(scan: SimulatedScan, mount: Mount) -> CloudPoints:
    traj = GeorefTrajectory.from_trajectory(scan.trajectory, mount.latency_s)
    pos, inside = georeference(scan.t_s, scan.xyz_scanner_m, traj, mount)
    assert inside.all()
    return CloudPoints(pos, scan.t_s, scan.intensity)


def _yawed(mount: Mount, d_yaw_deg: float) -> Mount:
    r, p, y = mount.boresight_rpy_deg
    return replace(mount, boresight_rpy_deg=(r, p, y + d_yaw_deg))


@pytest.fixture(scope="module")
def scene() -> ControlTargetScene:
    return control_target_scene(seed=11)


@pytest.fixture(scope="module")
def reports(scene: ControlTargetScene) -> dict[str, ControlPointReport]:
    scan = scene.scan
    mounts = {
        "correct": scan.mount,
        "late": scan.mount.with_latency(LATENCY_ERROR_S),
        "yaw": _yawed(scan.mount, YAW_ERROR_DEG),
    }
    return {
        key: validate_control_points(
            _cloud(scan, m),
            scene.control,
            scan.trajectory,
            centre="sphere",
            target_radius_m=scene.target_radius_m,
        )
        for key, m in mounts.items()
    }


# ------------------------------------------------------------------ control points
def test_every_visit_is_found(
    scene: ControlTargetScene, reports: dict[str, ControlPointReport]
) -> None:
    rep = reports["correct"]
    n_passes = len(scene.speeds_m_s)
    assert len(rep.differences) == len(scene.control) * n_passes
    assert rep.missing == ()
    assert rep.n_passes == n_passes
    counts = {n: sum(d.observation.name == n for d in rep.differences) for n in scene.control.names}
    assert set(counts.values()) == {n_passes}
    speeds = sorted({round(d.speed_m_s) for d in rep.differences})
    assert speeds == sorted({round(v) for v in scene.speeds_m_s})


def test_vehicle_frame_sides_follow_the_direction_of_travel(
    reports: dict[str, ControlPointReport],
) -> None:
    # West targets are on the left driving north (heading 0) and on the right driving south.
    for d in reports["correct"].differences:
        north = abs(d.heading_deg) < 1.0
        assert north or abs(abs(d.heading_deg) - 180.0) < 1.0
        west = d.observation.name.startswith("W")
        assert (d.side == "left") == (west == north)
        assert 3.0 < abs(d.lateral_m) < 11.0
        assert abs(d.forward_m) < 1.0  # the profile plane is across the direction of travel
        assert abs(d.yaw_rate_deg_s) < 0.1
        assert d.along_speed_m_s == pytest.approx(d.speed_m_s, abs=0.05)


def test_correct_calibration_shows_no_signature(reports: dict[str, ControlPointReport]) -> None:
    rep = reports["correct"]
    assert rep.time_error.testable
    assert rep.heading_error.testable
    assert not rep.time_error.significant
    assert not rep.heading_error.significant
    assert abs(rep.time_error.estimate) < 4 * rep.time_error.std
    assert abs(rep.heading_error.estimate) < 4 * rep.heading_error.std
    # Differences at the level of the simulated noise: 2 mm survey, 2 mm trajectory.
    rms = np.sqrt(np.mean(rep.diff_vehicle_m() ** 2, axis=0))
    assert np.all(rms < 0.006)
    assert 0.5e-3 < rep.residual_std_m < 4e-3


def test_time_error_shows_as_speed_times_error(reports: dict[str, ControlPointReport]) -> None:
    rep = reports["late"]
    te = rep.time_error
    assert te.significant
    assert te.p_value < 1e-4
    assert abs(te.estimate - LATENCY_ERROR_S) < 4 * te.std
    assert abs(te.estimate - LATENCY_ERROR_S) < 0.2 * LATENCY_ERROR_S
    assert te.std < 0.1e-3
    assert not rep.heading_error.significant
    # Each visit: dY = speed x 2 ms on top of the correct run's difference; dX, dZ unmoved.
    correct = reports["correct"]
    for late, ok in zip(rep.differences, correct.differences, strict=True):
        assert late.observation.name == ok.observation.name
        shift = np.subtract(late.diff_vehicle_m, ok.diff_vehicle_m)
        assert shift[1] == pytest.approx(ok.speed_m_s * LATENCY_ERROR_S, abs=0.003)
        assert abs(shift[0]) < 0.003
        assert abs(shift[2]) < 0.003


def test_heading_error_shows_as_opposite_offsets_left_and_right(
    reports: dict[str, ControlPointReport],
) -> None:
    rep = reports["yaw"]
    he = rep.heading_error
    assert he.significant
    assert he.p_value < 1e-4
    assert abs(he.estimate - YAW_ERROR_DEG) < 4 * he.std
    assert abs(he.estimate - YAW_ERROR_DEG) < 0.2 * YAW_ERROR_DEG
    # The t statistic is the reported estimate over its sigma (it had the other sign).
    assert he.t_statistic == pytest.approx(he.estimate / he.std, rel=1e-12)
    te = rep.time_error
    assert te.t_statistic == pytest.approx(te.estimate / te.std, rel=1e-12)
    assert not rep.time_error.significant
    correct = reports["correct"]
    shifts = np.array(
        [
            (d.lateral_m, d.diff_vehicle_m[1] - ok.diff_vehicle_m[1])
            for d, ok in zip(rep.differences, correct.differences, strict=True)
        ]
    )
    left, right = shifts[shifts[:, 0] < 0], shifts[shifts[:, 0] > 0]
    assert np.all(left[:, 1] > 0.005)  # a clockwise yaw error pushes the left side forward
    assert np.all(right[:, 1] < -0.003)


def _difference(
    obs: TargetObservation, dy_m: float, speed_m_s: float, direction: int, lateral_m: float
) -> ControlPointDifference:
    return ControlPointDifference(
        observation=obs,
        diff_vehicle_m=(0.0, dy_m, 0.0),
        diff_ned_m=(direction * dy_m, 0.0, 0.0),
        speed_m_s=speed_m_s,
        along_speed_m_s=speed_m_s,
        heading_deg=0.0 if direction > 0 else 180.0,
        yaw_rate_deg_s=0.0,
        lateral_m=lateral_m,
        forward_m=0.0,
        up_m=0.0,
    )


def test_reported_sigma_matches_the_spread_of_the_mixed_model() -> None:
    """Monte Carlo of the signature test with pass, survey and visit noise (no signature).

    Treating the 64 visits as independent would under-state the sigma of both slopes
    (pass errors alias into the speed slope, survey errors into the heading slope) and
    flag signatures that are not there; the mixed model's t-statistics stay calibrated.
    """
    rng = np.random.default_rng(0)
    targets = [(f"T{i}", x) for i, x in enumerate((-8.0, -6.5, -7.5, -9.0, 5.0, 6.0, 4.5, 7.0))]
    passes = [(v, d) for v in (5.0, 10.0, 15.0, 20.0) for d in (1, -1)]
    t_time, t_head = [], []
    false_alarms = 0
    for _ in range(100):
        survey = rng.normal(0.0, 0.004, len(targets))  # north error of each target
        diffs = []
        for k, (v, direction) in enumerate(passes):
            common = rng.normal(0.0, 0.002)
            for j, (name, x) in enumerate(targets):
                lateral = x * direction
                dy = common + direction * survey[j] + rng.normal(0.0, 0.002)
                obs = TargetObservation(name, k, 100.0 * k + j, (0, 0, 0), (0, 0, 0), 50, 1.0)
                diffs.append(_difference(obs, dy, v, direction, lateral))
        tests = signature_tests(tuple(diffs))
        t_time.append(tests.time_error.t_statistic)
        t_head.append(tests.heading_error.t_statistic)
        false_alarms += tests.time_error.significant + tests.heading_error.significant
    assert 0.7 < float(np.std(t_time)) < 1.45
    assert 0.7 < float(np.std(t_head)) < 1.45
    assert false_alarms <= 6  # 200 tests at 1 %: 2 expected


def test_untestable_signatures_say_why(reports: dict[str, ControlPointReport]) -> None:
    diffs = reports["late"].differences
    fast = tuple(d for d in diffs if d.speed_m_s > 19.0)
    tests = signature_tests(fast)
    assert not tests.time_error.testable
    assert "several speeds" in tests.time_error.reason
    assert not tests.time_error.significant
    assert math.isnan(tests.time_error.estimate)
    assert tests.heading_error.testable
    one_side = tuple(d for d in diffs if d.side == "left")
    tests = signature_tests(one_side)
    assert not tests.heading_error.testable
    assert "one side" in tests.heading_error.reason
    assert tests.time_error.testable
    assert tests.time_error.estimate == pytest.approx(LATENCY_ERROR_S, rel=0.2)
    few_passes = tuple(d for d in diffs if d.observation.visit in (0, 2))  # 5 and 10 m/s
    assert "passes" in signature_tests(few_passes).time_error.reason
    with pytest.raises(InputError, match="level"):
        signature_tests(diffs, level=1.5)


def test_pass_labels() -> None:
    def obs(name: str, t: float) -> ControlPointDifference:
        o = TargetObservation(name, 0, t, (0, 0, 0), (0, 0, 0), 10, 1.0)
        return _difference(o, 0.0, 5.0, 1, 1.0)

    diffs = (obs("A", 0.0), obs("B", 1.0), obs("A", 2.0), obs("B", 30.0), obs("C", 31.0))
    np.testing.assert_array_equal(pass_labels(diffs), [0, 0, 1, 2, 2])
    np.testing.assert_array_equal(pass_labels(diffs[::-1]), [2, 2, 1, 0, 0])


def test_disc_targets_with_the_robust_centroid() -> None:
    scene = control_target_scene(target_shape="disc", targets_per_side=3, seed=4)
    scan = scene.scan
    rep = validate_control_points(
        _cloud(scan, scan.mount.with_latency(LATENCY_ERROR_S)), scene.control, scan.trajectory
    )
    assert len(rep.differences) == 6 * len(scene.speeds_m_s)
    te = rep.time_error
    assert te.significant
    assert abs(te.estimate - LATENCY_ERROR_S) < 4 * te.std
    assert abs(te.estimate - LATENCY_ERROR_S) < 0.2 * LATENCY_ERROR_S
    assert not rep.heading_error.significant


def test_missing_targets_are_reported_per_point(scene: ControlTargetScene) -> None:
    scan = scene.scan
    cloud = _cloud(scan, scan.mount)
    far = scene.control.pos_ecef_m[0] + np.array([50.0, 0.0, 0.0])
    control = ControlPoints(
        (*scene.control.names, "FAR"), np.vstack([scene.control.pos_ecef_m, far])
    )
    rep = validate_control_points(
        cloud, control, scan.trajectory, centre="sphere", target_radius_m=scene.target_radius_m
    )
    assert [m.name for m in rep.missing] == ["FAR"]
    assert "no point of the cloud within 0.5 m" in rep.missing[0].reason
    assert rep.n_control_points == len(control)
    # A threshold above every return: each target is reported, and with none left it is fatal.
    _, missing = extract_targets(cloud, scene.control, min_intensity=1e9)
    assert len(missing) == len(scene.control)
    assert all("intensity >= 1e+09" in m.reason for m in missing)
    with pytest.raises(InputError, match="no control point found in the cloud"):
        validate_control_points(cloud, scene.control, scan.trajectory, min_intensity=1e9)
    # No contrast: every point equally bright.
    flat = CloudPoints(cloud.pos_ecef_m, cloud.t_s, np.full(len(cloud), 100.0))
    _, missing = extract_targets(flat, scene.control)
    assert all("no intensity contrast" in m.reason for m in missing)
    # Surveyed 1 m too high: fewer points in reach than a centre needs, no contrast to
    # blame: the message says the target is not there (was "give --min-intensity").
    up_1m = ControlPoints.from_geodetic(
        scene.control.names, *(scene.control.lat_lon_h() + np.array([0.0, 0.0, 1.0])).T
    )
    _, missing = extract_targets(cloud, up_1m, centre="sphere", target_radius_m=0.2)
    few = [m for m in missing if "point(s) of the cloud within 0.5 m" in m.reason]
    assert len(few) >= 3
    assert all("no target at the surveyed position" in m.reason for m in few)
    assert not [m for m in few if "--min-intensity" in m.reason]


def test_targets_bright_throughout_their_radius_are_judged_against_the_cloud(
    scene: ControlTargetScene,
) -> None:
    """A target on a post with nothing else within the radius: no contrast inside the
    radius, but five times the cloud's median intensity: found (it was missed before)."""
    scan = scene.scan
    cloud = _cloud(scan, scan.mount)
    rng = np.random.default_rng(5)
    owner = nearest_control(cloud.pos_ecef_m, scene.control, 0.5)
    inten = np.where(owner >= 0, 500.0, 100.0) + rng.uniform(0.0, 20.0, len(cloud))
    bright = CloudPoints(cloud.pos_ecef_m, cloud.t_s, inten)
    for j in range(len(scene.control)):
        near = inten[owner == j]
        assert otsu_threshold(near)[1] < AUTO_CONTRAST  # no contrast within the radius
    obs, missing = extract_targets(bright, scene.control)
    assert not [m for m in missing if "no intensity contrast" in m.reason]
    assert {o.name for o in obs} == set(scene.control.names)
    # Bright throughout but not against the cloud (1.5x its median): still refused.
    dim = CloudPoints(cloud.pos_ecef_m, cloud.t_s, np.where(owner >= 0, 150.0, 100.0))
    _, missing = extract_targets(dim, scene.control)
    assert len(missing) == len(scene.control)
    assert all("nor against the cloud's median intensity 100" in m.reason for m in missing)


def test_observations_of_points_not_in_control_are_refused_naming_them(
    scene: ControlTargetScene,
) -> None:
    scan = scene.scan
    obs, _ = extract_targets(
        _cloud(scan, scan.mount), scene.control, centre="sphere",
        target_radius_m=scene.target_radius_m,
    )  # fmt: skip
    first = scene.control.names[0]
    others = ControlPoints(scene.control.names[1:], scene.control.pos_ecef_m[1:])
    with pytest.raises(InputError, match=f"observations of {first} but control has no such"):
        control_point_differences(obs, others, scan.trajectory)


def test_visits_outside_the_trajectory_span_are_reported(scene: ControlTargetScene) -> None:
    scan = scene.scan
    cloud = _cloud(scan, scan.mount)
    t_rec = scan.trajectory.t_s
    first_pass_end = float(t_rec[np.argmax(np.diff(t_rec) > 1.0)])  # passes are 20 s apart
    short = scan.trajectory.sliced(scan.trajectory.t_start_s, first_pass_end)
    rep = validate_control_points(
        cloud, scene.control, short, centre="sphere", target_radius_m=scene.target_radius_m
    )
    assert len(rep.differences) == len(scene.control)
    outside = [m for m in rep.missing if "outside the trajectory span" in m.reason]
    assert len(outside) == len(scene.control) * (len(scene.speeds_m_s) - 1)
    assert all(m.t_s is not None and m.t_s > first_pass_end for m in outside)


def test_visits_in_a_trajectory_gap_are_reported_never_guessed(
    scene: ControlTargetScene, reports: dict[str, ControlPointReport]
) -> None:
    """A visit inside a hole of the trajectory is missing with the gap as its reason.

    Its vehicle frame, speed and turn rate would come from the records on either side
    of the hole; the other visits are what they were, even right at the hole's edges
    (the velocity and rate differences stay on the hole's side they are on).
    """
    scan = scene.scan
    full = reports["late"]
    t_visits = np.array([d.observation.t_s for d in full.differences])
    hole = (t_visits[0] - 0.3, t_visits[0] + 0.3)
    in_hole = (t_visits > hole[0]) & (t_visits < hole[1])
    holed = with_gap(scan.trajectory, *hole)
    (gap,) = [g for g in holed.gaps() if g.t_start_s < t_visits[0] < g.t_end_s]
    rep = validate_control_points(
        _cloud(scan, scan.mount.with_latency(LATENCY_ERROR_S)),
        scene.control,
        holed,
        centre="sphere",
        target_radius_m=scene.target_radius_m,
    )
    in_gap = [m for m in rep.missing if "data gap" in m.reason]
    assert len(in_gap) == int(in_hole.sum()) >= 1
    assert len(rep.missing) == len(in_gap)
    assert all(gap.describe() in m.reason for m in in_gap)
    assert len(rep.differences) == len(full.differences) - len(in_gap)
    kept = {d.observation.t_s: d for d in rep.differences}
    for d in full.differences:
        if d.observation.t_s in kept:
            k = kept[d.observation.t_s]
            assert k.diff_vehicle_m == pytest.approx(d.diff_vehicle_m, abs=1e-9)
            assert k.speed_m_s == pytest.approx(d.speed_m_s, abs=1e-6)


def test_a_visit_just_after_a_gap_is_read_from_its_own_side(
    scene: ControlTargetScene, reports: dict[str, ControlPointReport]
) -> None:
    """The +-0.05 s velocity difference of a visit 0.02 s after a hole stays out of it."""
    scan = scene.scan
    full = reports["correct"]
    d0 = full.differences[0]
    t = d0.observation.t_s
    holed = with_gap(scan.trajectory, t - 0.5, t - 0.02)
    assert any(g.t_end_s <= t < g.t_end_s + 0.05 for g in holed.gaps())
    rep = validate_control_points(
        _cloud(scan, scan.mount),
        scene.control,
        holed,
        centre="sphere",
        target_radius_m=scene.target_radius_m,
    )
    assert rep.missing == ()
    (d,) = [d for d in rep.differences if d.observation.t_s == t]
    # a one-sided difference over the records after the hole: the same motion within 1 %
    assert d.speed_m_s == pytest.approx(d0.speed_m_s, rel=0.01)
    assert d.yaw_rate_deg_s == pytest.approx(d0.yaw_rate_deg_s, abs=0.05)


def test_extraction_options_are_checked(scene: ControlTargetScene) -> None:
    cloud = _cloud(scene.scan, scene.scan.mount)
    with pytest.raises(InputError, match="needs the target radius"):
        extract_targets(cloud, scene.control, centre="sphere")
    with pytest.raises(InputError, match="smaller than the search radius"):
        extract_targets(cloud, scene.control, centre="sphere", target_radius_m=0.6)
    with pytest.raises(InputError, match="centre must be one of"):
        extract_targets(cloud, scene.control, centre="mean")  # type: ignore[arg-type]
    with pytest.raises(InputError, match="search_radius_m"):
        extract_targets(cloud, scene.control, search_radius_m=-1.0)
    with pytest.raises(InputError, match="min_points"):
        extract_targets(cloud, scene.control, min_points=2)
    with pytest.raises(InputError, match="point times"):
        extract_targets(CloudPoints(cloud.pos_ecef_m), scene.control)
    assert cloud.t_s is not None
    with pytest.raises(InputError, match="shape"):
        CloudPoints(cloud.pos_ecef_m, cloud.t_s[:-1])
    with pytest.raises(InputError, match=r"non-finite value at index 3 \(0-based\)"):
        CloudPoints(np.where(np.arange(len(cloud))[:, None] == 3, np.nan, cloud.pos_ecef_m))


def test_a_visit_cut_by_an_end_of_the_cloud_is_missing_not_biased(
    scene: ControlTargetScene,
) -> None:
    """The cloud cut in the middle of a visit: that visit is reported missing (its centre
    from the points left would be off by tens of mm), at either end; the same points
    from a longer recording (``cloud_span_s``) give the visit."""
    scan = scene.scan
    cloud = _cloud(scan, scan.mount)
    obs, missing = extract_targets(
        cloud, scene.control, centre="sphere", target_radius_m=scene.target_radius_m
    )
    assert missing == ()
    visit = obs[len(obs) // 2]
    assert cloud.t_s is not None
    assert cloud.intensity is not None
    for where, keep in (
        ("end", cloud.t_s <= visit.t_s),
        ("start", cloud.t_s >= visit.t_s),
    ):
        part = CloudPoints(cloud.pos_ecef_m[keep], cloud.t_s[keep], cloud.intensity[keep])
        kwargs: dict[str, Any] = {"centre": "sphere", "target_radius_m": scene.target_radius_m}
        got, lost = extract_targets(part, scene.control, **kwargs)
        assert visit.name in [m.name for m in lost]
        assert all(f"visit cut by the {where} of the cloud?" in m.reason for m in lost)
        # the complete visits are as they were
        assert {(o.name, o.t_s, o.centre_ecef_m) for o in got} <= {
            (o.name, o.t_s, o.centre_ecef_m) for o in obs
        }
        assert len(got) + len(lost) == sum(
            (o.t_s <= visit.t_s) if where == "end" else (o.t_s >= visit.t_s) for o in obs
        )
        span = (float(cloud.t_s.min()), float(cloud.t_s.max()))
        got, lost = extract_targets(part, scene.control, cloud_span_s=span, **kwargs)
        assert lost == ()
        assert visit.name in [o.name for o in got if abs(o.t_s - visit.t_s) < 0.5]
    # a cloud clipped around the targets (what a user keeps of a survey) is not cut: it
    # begins metres before the first target, many profiles before its first return
    clipped = nearest_control(cloud.pos_ecef_m, scene.control, 2.0) >= 0
    part = CloudPoints(cloud.pos_ecef_m[clipped], cloud.t_s[clipped], cloud.intensity[clipped])
    got, lost = extract_targets(part, scene.control, **kwargs)
    assert lost == ()
    assert [(o.name, o.t_s) for o in got] == [(o.name, o.t_s) for o in obs]
    with pytest.raises(InputError, match="does not hold the cloud's point times"):
        extract_targets(cloud, scene.control, cloud_span_s=(visit.t_s, visit.t_s + 1.0))
    for bad in ((1.0,), (2.0, 1.0), (float("nan"), 1.0)):
        with pytest.raises(InputError, match="cloud_span_s"):
            extract_targets(cloud, scene.control, cloud_span_s=bad)  # type: ignore[arg-type]


def test_median_and_tukey_centres_agree_on_a_symmetric_target() -> None:
    rng = np.random.default_rng(2)
    centre_ned = np.array([0.01, -0.02, 0.005])
    disc = rng.uniform(-0.2, 0.2, (2000, 2))
    disc = disc[np.hypot(disc[:, 0], disc[:, 1]) < 0.2]
    local = np.column_stack([disc[:, 0], np.zeros(len(disc)), disc[:, 1]]) + centre_ned
    local += rng.normal(0.0, 0.003, local.shape)
    strays = np.array([[0.4, 0.0, 0.3], [-0.35, 0.1, -0.3], [0.3, -0.2, 0.4]])
    local = np.vstack([local, strays])
    origin = (46.8, -71.2, 10.0)
    pos = ned_to_ecef(local, *origin)
    control = ControlPoints(("C",), ned_to_ecef(np.zeros((1, 3)), *origin))
    inten = np.full(len(pos), 3000.0)
    bg = ned_to_ecef(rng.uniform(-0.45, 0.45, (300, 3)) * [1, 0, 1] + [0, 0.1, 0], *origin)
    cloud = CloudPoints(
        np.vstack([pos, bg]), np.zeros(len(pos) + 300), np.concatenate([inten, np.full(300, 200.0)])
    )
    methods: tuple[CentreMethod, ...] = ("tukey", "median")
    for method in methods:
        # a cloud of one target's points, from a recording that went on before and after
        obs, missing = extract_targets(cloud, control, centre=method, cloud_span_s=(-5.0, 5.0))
        assert missing == ()
        (one,) = obs
        assert one.intensity_threshold == pytest.approx(1600.0)
        err = ecef_to_ned(np.asarray(one.centre_ecef_m), *origin) - centre_ned
        std = np.asarray(one.centre_std_ned_m)
        assert np.all(std > 0.0)
        assert np.all(np.abs(err) < 4.0 * std + 1e-4)
        assert np.linalg.norm(err) < 0.01


def test_otsu_threshold() -> None:
    rng = np.random.default_rng(1)
    values = np.concatenate([rng.normal(300, 30, 500), rng.normal(2500, 200, 80)])
    thr, contrast = otsu_threshold(values)
    assert 500 < thr < 2000
    assert contrast > 5
    assert all(math.isnan(v) for v in otsu_threshold(np.full(10, 7.0)))
    assert all(math.isnan(v) for v in otsu_threshold([1.0]))
    assert otsu_threshold([0.0, 0.0, 10.0]) == (5.0, math.inf)
    with pytest.raises(InputError, match=r"otsu_threshold values\[0\] = nan is not finite"):
        otsu_threshold([math.nan, 1.0, 2.0])
    with pytest.raises(InputError, match=r"values\[2\] = inf"):
        otsu_threshold([1.0, 2.0, math.inf])


# ------------------------------------------------------------------ flatness
def _plane_points(
    rng: np.random.Generator, n: int, noise_m: float, bend_per_m: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """Vertical wall facing north-east, 20 m x 4 m, optional bow d u^2 along it (ECEF)."""
    u = rng.uniform(-10, 10, n)
    v = rng.uniform(-2, 2, n)
    w = bend_per_m * u**2 + rng.normal(0.0, noise_m, n)
    R = euler_rpy_to_matrix(0.0, 0.0, math.radians(40.0))
    local = np.column_stack([w, u, -v]) @ R.T  # body x = normal, y = along, z = down
    return ned_to_ecef(local, 46.8, -71.2, 30.0), u


def test_flat_wall_is_not_curved_and_bow_is_measured() -> None:
    rng = np.random.default_rng(3)
    pts, _ = _plane_points(rng, 20000, 0.005)
    flat = fit_wall(pts)
    assert not flat.curvature_significant
    assert flat.rms_m == pytest.approx(0.005, rel=0.05)
    assert flat.n_rejected < 10
    assert flat.bow_m < 1e-3
    assert (
        abs(flat.normal_ned @ np.array([math.cos(math.radians(40)), math.sin(math.radians(40)), 0]))
        > 0.999
    )
    assert abs(flat.v_axis_ned[2] + 1.0) < 1e-3  # v points up
    bend = 0.0001  # 1e-4 /m: sagitta d (L/2)^2 = 10 mm over 20 m
    pts, _ = _plane_points(rng, 20000, 0.005, bend)
    bent = fit_wall(pts)
    assert bent.curvature_significant
    assert bent.p_value < 1e-6  # 8 blocks: F(3, 5), whose tail is not that of F(3, n - 6)
    assert bent.bow_m == pytest.approx(0.010, rel=0.1)
    d = bent.quadratic_m[3]
    assert abs(abs(d) - bend) < 4 * bent.quadratic_std_m[3]
    assert abs(abs(d) - bend) < 0.1 * bend
    doc = bent.as_document()
    assert doc["curvature_significant"] is True
    assert doc["bow_m"] == bent.bow_m
    # A tolerance on the bow: a 10 mm bow is not flagged below 20 mm.
    assert not fit_wall(pts, min_bow_m=0.02).curvature_significant


def test_a_wall_fit_cannot_be_changed_in_place() -> None:
    # Its arrays were writeable: r.normal_ned[:] = 0 changed the result (SphereFit's and
    # ClockFit's are read-only).
    result = fit_wall(_plane_points(np.random.default_rng(5), 500, 0.003)[0])
    arrays = {k: v for k, v in vars(result).items() if isinstance(v, np.ndarray)}
    assert len(arrays) >= 9  # centre, normal, both axes, u, v, residuals, quadratic and its sigma
    for name, array in arrays.items():
        assert not array.flags.writeable, name
        with pytest.raises(ValueError, match="read-only"):
            array[...] = 0.0
    # nor its percentiles (a plain dict), and the result still pickles
    with pytest.raises(TypeError):
        result.percentiles_m["p50"] = 0.0  # type: ignore[index]
    assert pickle.loads(pickle.dumps(result)).percentiles_m == result.percentiles_m


def test_gross_outliers_are_rejected() -> None:
    rng = np.random.default_rng(4)
    pts, _ = _plane_points(rng, 10000, 0.005)
    bad = rng.choice(len(pts), 200, replace=False)
    shift = rng.uniform(0.2, 1.0, 200)
    R = euler_rpy_to_matrix(0.0, 0.0, math.radians(40.0))
    normal_ecef = (
        ned_to_ecef(R[:, 0][None], 46.8, -71.2, 30.0)[0]
        - ned_to_ecef(np.zeros((1, 3)), 46.8, -71.2, 30.0)[0]
    )
    pts[bad] += shift[:, None] * normal_ecef
    result = fit_wall(pts)
    assert 200 <= result.n_rejected < 215
    assert result.rms_m == pytest.approx(0.005, rel=0.05)
    assert not result.curvature_significant
    assert "MAD" in result.rule


def test_curvature_test_false_alarm_rate_matches_its_level() -> None:
    rng = np.random.default_rng(5)
    p_values = np.array([fit_wall(_plane_points(rng, 300, 0.005)[0]).p_value for _ in range(200)])
    # p is uniform on a flat wall: 5 % (10 of 200) expected below 0.05.
    assert 2 <= int(np.sum(p_values < 0.05)) <= 22
    assert 0.35 < float(np.mean(p_values)) < 0.65


def _drive_error(
    rng: np.random.Generator, u: np.ndarray, sigma_m: float, corr_m: float
) -> np.ndarray:
    """Gauss-Markov error along u (a trajectory error correlated along the drive)."""
    order = np.argsort(u)
    du = np.diff(u[order], prepend=u[order][0])
    e = np.empty(u.size)
    x = rng.normal(0.0, sigma_m)
    for i, step in zip(order, du, strict=True):
        phi = math.exp(-step / corr_m)
        x = phi * x + rng.normal(0.0, sigma_m * math.sqrt(1.0 - phi * phi))
        e[i] = x
    return e


def test_curvature_test_holds_its_level_under_errors_correlated_along_the_drive() -> None:
    # A flat wall whose points carry a 2 mm trajectory error correlated over 2.5 m of
    # driving (0.5 s at 5 m/s), and 5 mm of range noise. The plain F-test counted
    # every point as independent and flagged nearly every wall.
    rng = np.random.default_rng(11)
    R = euler_rpy_to_matrix(0.0, 0.0, math.radians(40.0))
    p_values = []
    for _ in range(60):
        u = rng.uniform(-10, 10, 3000)
        v = rng.uniform(-2, 2, 3000)
        w = _drive_error(rng, u, 0.002, 2.5) + rng.normal(0.0, 0.005, 3000)
        local = np.column_stack([w, u, -v]) @ R.T
        p_values.append(fit_wall(ned_to_ecef(local, 46.8, -71.2, 30.0)).p_value)
    # 0.6 expected at 1 %; the correlation is estimated, so a few more (simulation:
    # 2-5 %); the plain F-test flagged nearly all 60.
    assert int(np.sum(np.array(p_values) < 0.01)) <= 6


def test_bow_sigma_matches_the_bow_scatter() -> None:
    # The bow was given without a sigma. On a 10 mm bend its scatter over noise draws
    # matches the reported sigma (spread / sigma about 1).
    rng = np.random.default_rng(12)
    fits = [fit_wall(_plane_points(rng, 1000, 0.01, 0.0001)[0]) for _ in range(150)]
    bows = np.array([f.bow_m for f in fits])
    sigmas = np.array([f.bow_std_m for f in fits])
    # Independent noise: the fitted correlated error is sometimes spurious, which errs
    # on the safe side (simulation: spread / sigma 0.76).
    assert 0.6 < float(np.std(bows)) / float(np.mean(sigmas)) < 1.2
    assert fits[0].as_document()["bow_std_m"] == fits[0].bow_std_m


def test_the_wall_fit_does_not_depend_on_the_points_order() -> None:
    # The bow's sigma sampled the points by their index in the file: the same 55,704
    # points gave 0.68603 mm in file order, 0.68478 shuffled.
    rng = np.random.default_rng(21)
    pts, _ = _plane_points(rng, 6000, 0.005, 0.0001)
    fits = [fit_wall(pts), fit_wall(pts[::-1]), fit_wall(pts[rng.permutation(len(pts))])]
    for other in fits[1:]:
        assert other.bow_std_m == pytest.approx(fits[0].bow_std_m, rel=1e-9)
        assert other.bow_m == pytest.approx(fits[0].bow_m, rel=1e-9)
        assert other.p_value == pytest.approx(fits[0].p_value, rel=1e-6)


def test_one_scanner_profile_is_not_a_wall() -> None:
    # A 2 cm x 4 m strip (one profile) was fitted and flagged as curved with p ~ 1e-20.
    rng = np.random.default_rng(13)
    u = rng.uniform(-0.01, 0.01, 150)
    v = np.linspace(-2, 2, 150)
    w = 0.3 * u**2 + rng.normal(0.0, 0.005, 150)
    R = euler_rpy_to_matrix(0.0, 0.0, math.radians(40.0))
    pts = ned_to_ecef(np.column_stack([w, u, -v]) @ R.T, 46.8, -71.2, 30.0)
    with pytest.raises(
        InputError,
        match=r"span 3.84 m along their longest direction .* and 0.0\d+ m across it, a strip",
    ):
        fit_wall(pts)
    # In a turn a profile crosses the wall on a slant and bent, with a stray point.
    u = 0.2 * v + 0.05 * v**2 + rng.uniform(-0.01, 0.01, 150)
    u[70] += 0.9
    pts = ned_to_ecef(np.column_stack([w, u, -v]) @ R.T, 46.8, -71.2, 30.0)
    with pytest.raises(InputError, match="a strip"):
        fit_wall(pts)


def test_wall_in_a_tight_turn_bends_with_a_time_error() -> None:
    wall = curved_wall_scene(seed=7)
    scan = wall.scan
    results = {}
    for latency in (0.0, 0.005):
        cloud = _cloud(scan, scan.mount.with_latency(latency))
        results[latency] = fit_wall(cloud.pos_ecef_m[select_box(cloud.pos_ecef_m, wall.box_ecef_m)])
    ok, late = results[0.0], results[0.005]
    assert not ok.curvature_significant
    assert ok.bow_m < 1e-3
    assert late.curvature_significant
    assert late.p_value < 1e-6
    assert late.bow_m > 0.006
    # The RMS alone hardly tells: 5 mm range noise, a few tenths of a mm more with the error.
    assert late.rms_m < 1.3 * ok.rms_m
    assert ok.rms_m == pytest.approx(0.005, rel=0.1)
    assert 0 < ok.n_rejected < 0.01 * ok.n_selected  # the simulated clutter in front


def test_rigid_shift_of_a_wall_is_not_curvature() -> None:
    # The wall stands along the straight approach only: a time error slides it along itself.
    wall = curved_wall_scene(wall_start_m=0.0, wall_length_m=12.0, approach_m=20.0, seed=8)
    scan = wall.scan
    cloud = _cloud(scan, scan.mount.with_latency(0.005))
    result = fit_wall(cloud.pos_ecef_m[select_box(cloud.pos_ecef_m, wall.box_ecef_m)])
    assert not result.curvature_significant
    assert result.bow_m < 1e-3


def test_bad_wall_selections() -> None:
    rng = np.random.default_rng(6)
    pts, _ = _plane_points(rng, 100, 0.005)
    with pytest.raises(InputError, match="too few points for a plane: 9 selected"):
        fit_wall(pts[:9])
    line = ned_to_ecef(
        np.column_stack([np.linspace(0, 5, 50), np.zeros(50), np.zeros(50)]), 46.8, -71.2, 0.0
    )
    with pytest.raises(InputError, match="lie on a line"):
        fit_wall(line)
    with pytest.raises(InputError, match="level"):
        fit_wall(pts, level=0.0)
    with pytest.raises(InputError, match="min_bow_m"):
        fit_wall(pts, min_bow_m=-1.0)
    with pytest.raises(InputError, match="non-finite"):
        fit_wall(np.vstack([pts, [[np.nan, 0, 0]]]))
    with pytest.raises(InputError, match="shape"):
        fit_wall(pts[:, :2])
    with pytest.raises(InputError, match="max_iterations: expected a whole number"):
        fit_wall(pts, max_iterations=2.5)  # type: ignore[arg-type]
    with pytest.raises(InputError, match=r"max_iterations must be >= 0 \(0: no rejection\)"):
        fit_wall(pts, max_iterations=-1)
    assert fit_wall(pts, max_iterations=0).n_rejected == 0


@pytest.mark.parametrize(
    ("xyz", "box", "pattern"),
    [
        (np.zeros((3, 10)), (0, 0, 0, 1, 1, 1), r"xyz: .*shape \(3, 10\); transpose it"),
        (np.zeros(3), (0, 0, 0, 1, 1, 1), r"xyz: expected points of shape \(N, 3\)"),
        (np.zeros((2, 3)), (0, 0, 0, 1), "box: expected 6 finite numbers"),
        (np.zeros((2, 3)), (0, 0, 0, 1, 1, math.nan), "box: expected 6 finite numbers"),
        (np.zeros((2, 3)), (0, 0, 0, 1, "a", 1), "box: expected 6 finite numbers"),
        (np.zeros((2, 3)), (0, 5, 0, 1, 1, 1), "box: ymin 5.0 must be below ymax 1.0"),
    ],
)
def test_select_box_refuses_transposed_points_and_a_box_that_is_not_one(
    xyz: np.ndarray, box: object, pattern: str
) -> None:
    with pytest.raises(InputError, match="select_box " + pattern):
        select_box(xyz, box)  # type: ignore[arg-type]


# ------------------------------------------------------------------ box parser
@settings(max_examples=60, deadline=None)
@given(
    lo=st.tuples(*[st.floats(-1e7, 1e7)] * 3),
    size=st.tuples(*[st.floats(1e-3, 1e3)] * 3),
)
def test_parse_box_round_trip(lo: tuple[float, ...], size: tuple[float, ...]) -> None:
    hi = tuple(a + b for a, b in zip(lo, size, strict=True))
    if any(h <= a for a, h in zip(lo, hi, strict=True)):
        return
    box = (*lo, *hi)
    text = ", ".join(repr(v) for v in box)
    assert parse_box(text) == box
    mid = np.array([[(a + h) / 2 for a, h in zip(lo, hi, strict=True)]])
    assert select_box(mid, parse_box(text)).tolist() == [True]
    assert select_box(np.array([lo, hi]), parse_box(text)).tolist() == [True, True]
    assert select_box(mid + np.array([[0.0, 0.0, 2 * size[2]]]), parse_box(text)).tolist() == [
        False
    ]


@pytest.mark.parametrize(
    ("text", "fragment"),
    [
        ("1,2,3,4,5", "expected 6"),
        ("1,2,3,4,5,6,7", "expected 6"),
        ("1,2,x,4,5,6", "item 3 ('x') is not a number"),
        ("1,2,3,4,inf,6", "item 5 ('inf') is not finite"),
        ("1,2,3,1,5,6", "xmin 1.0 must be below xmax 1.0"),
        ("1,9,3,4,5,6", "ymin 9.0 must be below ymax 5.0"),
        ("", "expected 6"),
    ],
)
def test_parse_box_errors(text: str, fragment: str) -> None:
    with pytest.raises(InputError, match="--box") as exc:
        parse_box(text)
    assert fragment in str(exc.value)


def test_vehicle_frame_of_a_constructed_trajectory() -> None:
    """A known attitude and a known offset: dY and dX land on the right axes."""
    origin = (46.8, -71.2, 10.0)
    t = np.arange(0.0, 10.0, 0.01) + 1e9
    yaw = math.radians(90.0)  # driving east
    pos = np.column_stack([np.zeros_like(t), 10.0 * (t - t[0]), np.zeros_like(t)])
    traj = Trajectory.from_euler(
        t, np.zeros_like(t), np.zeros_like(t), np.full_like(t, yaw),
        pos_ned_m=pos, origin_lat_lon_h=origin,
    )  # fmt: skip
    target = np.array([[6.0, 50.0, -1.0]])  # 6 m north of the road: left when driving east
    control = ControlPoints(("P",), ned_to_ecef(target, *origin))
    # The cloud sees the target 2 cm east (forward when driving east) and 1 cm down.
    x, y, z = (float(c) for c in ned_to_ecef(target + np.array([0.0, 0.02, 0.01]), *origin)[0])
    obs = TargetObservation("P", 0, float(t[0] + 5.0), (x, y, z), (0.0, 0.0, 0.0), 20, 1.0)
    (d,), missing = control_point_differences((obs,), control, traj)
    assert missing == ()
    np.testing.assert_allclose(d.diff_vehicle_m, (0.0, 0.02, -0.01), atol=1e-6)
    assert d.lateral_m == pytest.approx(-6.0, abs=1e-3)
    assert d.side == "left"
    assert d.forward_m == pytest.approx(0.0, abs=1e-3)
    assert d.up_m == pytest.approx(1.0, abs=1e-3)
    assert d.speed_m_s == pytest.approx(10.0, abs=1e-4)
    assert d.heading_deg == pytest.approx(90.0, abs=1e-6)


def test_confounded_speed_and_side_is_not_tested() -> None:
    diffs = []
    for k, (v, x) in enumerate(((5.0, -6.0), (10.0, -6.0), (20.0, 6.0), (25.0, 6.0))):
        for j in range(3):
            obs = TargetObservation(f"T{j}{k}", k, 100.0 * k + j, (0, 0, 0), (0, 0, 0), 30, 1.0)
            diffs.append(_difference(obs, 0.001 * j, v, 1, x))
    # Left targets at 5 and 10 m/s only, right ones at 20 and 25 m/s: dY on speed and on
    # side are separable (two speeds per side), so both terms stay.
    tests = signature_tests(tuple(diffs))
    assert tests.time_error.testable
    assert tests.heading_error.testable
    same = [
        _difference(d.observation, 0.0, 5.0 if d.lateral_m < 0 else 20.0, 1, d.lateral_m)
        for d in diffs
    ]
    tests = signature_tests(tuple(same))
    assert tests.time_error.testable
    assert not tests.heading_error.testable
    assert "confounded" in tests.heading_error.reason


def test_a_trajectory_on_another_time_scale_is_named(scene: ControlTargetScene) -> None:
    """Every target found, every visit outside the span: say time scale, not 'not found'."""
    scan = scene.scan
    cloud = _cloud(scan, scan.mount)
    week_s = 604800.0 * 2345  # GPS seconds of week against GPS time since 1980
    shifted = scan.trajectory.shifted(-week_s)
    with pytest.raises(InputError) as info:
        validate_control_points(
            cloud, scene.control, shifted, centre="sphere", target_radius_m=scene.target_radius_m
        )
    message = str(info.value)
    assert message.startswith("every control point seen in the cloud (")
    assert "same time scale? GPS seconds of week" in message


def test_wall_points_too_coarse_or_not_ecef_are_refused() -> None:
    """float32 ECEF (0.5 m steps) bent a flat wall by 46 mm; local NED read as ECEF gave
    an origin at the south pole, 6357 km below the ellipsoid."""
    rng = np.random.default_rng(6)
    pts, _ = _plane_points(rng, 1000, 0.003)
    with pytest.raises(InputError, match=r"pos_ecef_m: float32 .* steps of 0\.5 m.*float64"):
        fit_wall(pts.astype(np.float32))
    local = ecef_to_ned(pts, 46.8, -71.2, 30.0)
    with pytest.raises(InputError, match=r"pos_ecef_m: .*not ECEF coordinates \(local or proj"):
        fit_wall(local)
    with pytest.raises(InputError, match=r"cloud pos_ecef_m: float32"):
        CloudPoints(pos_ecef_m=pts.astype(np.float32))
    with pytest.raises(InputError, match=r"not ECEF"):
        ControlPoints(names=("A",), pos_ecef_m=local[:1])
    with pytest.raises(InputError, match=r"names: expected a sequence of names, got the single"):
        ControlPoints(names="AB", pos_ecef_m=pts[:2])  # type: ignore[arg-type]
    with pytest.raises(InputError, match=r"cloud t_s: expected seconds, got datetime64"):
        CloudPoints(pos_ecef_m=pts[:3], t_s=np.arange(3).astype("datetime64[s]"))
