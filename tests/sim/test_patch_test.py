"""Patch-test simulator: scenes, drive, geometry of the returns, latency sign, files."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from kinsync._typing import FloatArray
from kinsync.calibration.lines import ScanLine
from kinsync.errors import InputError
from kinsync.georef import GeorefTrajectory, georeference
from kinsync.io.las import las_info, read_las_points
from kinsync.io.mount_file import read_mount
from kinsync.io.sbet import read_sbet
from kinsync.mount import Mount
from kinsync.sim.patch_route import PlatformMotion, _displacement_m, turnaround
from kinsync.sim.patch_scene import PatchTestScene, ScenePlane, SceneSphere
from kinsync.sim.patch_test import (
    PatchTestConfig,
    PatchTestSimulation,
    Scenario,
    check_patch_test_folder,
    patch_test_files,
    simulate_patch_test,
    write_patch_test,
)
from kinsync.trajectory import Trajectory


def _small(scenario: Scenario = "vehicle", **kwargs: Any) -> PatchTestConfig:
    """A small, fast set-up (about 30 000 / 8 000 returns, well under a second)."""
    return PatchTestConfig(
        scenario=scenario, density=0.01, passes_per_direction=1, nav_rate_hz=50.0, **kwargs
    )


@pytest.fixture(scope="module")
def vehicle() -> PatchTestSimulation:
    return simulate_patch_test(_small(spheres=True))


@pytest.fixture(scope="module")
def vessel() -> PatchTestSimulation:
    return simulate_patch_test(_small("vessel"))


@pytest.fixture(scope="module")
def exact_vehicle() -> PatchTestSimulation:
    """No navigation errors, a large latency: the mount and the latency alone."""
    cfg = _small(std_pos_ned_m=(0.0, 0.0, 0.0), std_att_deg=(0.0, 0.0, 0.0), latency_error_s=0.02)
    return simulate_patch_test(cfg)


def _distances_m(
    sim: PatchTestSimulation, line_index: int, trajectory: Trajectory, mount: Mount
) -> FloatArray:
    """Distance of a line's georeferenced returns to the feature each one hit (m)."""
    line = sim.lines[line_index]
    gtraj = GeorefTrajectory.from_trajectory(trajectory, mount.latency_s)
    pos, inside = georeference(line.t_s, line.xyz_scanner_m, gtraj, mount)
    assert np.all(inside)
    local = sim.scene.ecef_to_scene(pos)
    return sim.scene.distance_to_hit_feature_m(local, sim.line_hit_ids[line_index])


def _rms(x: FloatArray) -> float:
    return float(np.sqrt(np.mean(x * x)))


# ------------------------------------------------------------------------------ scene
def test_vehicle_scene_has_walls_of_several_azimuths_and_pitched_roofs(
    vehicle: PatchTestSimulation,
) -> None:
    scene = vehicle.scene
    walls = [p for p in scene.planes if p.kind == "wall"]
    roofs = [p for p in scene.planes if p.kind == "roof"]
    assert [p.kind for p in scene.planes].count("ground") == 1
    axes = {
        round(math.degrees(math.atan2(p.normal_ned[1], p.normal_ned[0])) % 180.0) for p in walls
    }
    assert len(axes) >= 3  # wall azimuths, modulo the facing side
    pitches = sorted(round(math.degrees(math.acos(-p.normal_ned[2]))) for p in roofs)
    assert min(pitches) >= 20
    assert max(pitches) <= 35
    for roof in roofs:  # every roof plane has its twin on the other side of the ridge
        n = np.array(roof.normal_ned)
        twin = np.array([-n[0], -n[1], n[2]])
        assert any(np.allclose(np.array(r.normal_ned), twin, atol=1e-9) for r in roofs)
    assert len(scene.spheres) == 2
    names = [f.name for f in scene.features]
    assert len(set(names)) == len(names)


def test_vessel_scene_quay_wall_sloping_shore_and_spheres(vessel: PatchTestSimulation) -> None:
    scene = vessel.scene
    by_name = {p.name: p for p in scene.planes}
    quay = by_name["quay wall"]
    assert abs(quay.normal_ned[2]) < 1e-12
    shore = by_name["shore"]
    assert math.degrees(math.acos(-shore.normal_ned[2])) == pytest.approx(15.0, abs=1e-9)
    assert scene.water_hit_id == 0
    assert all(p.hit_id != 0 for p in scene.planes)  # the water is no feature
    assert [s.radius_m for s in scene.spheres] == [0.4, 0.4]


@pytest.mark.parametrize("name", ["vehicle", "vessel"])
def test_features_outlines_lie_on_their_planes_and_normals_face_out(
    name: str, vehicle: PatchTestSimulation, vessel: PatchTestSimulation
) -> None:
    sim = vehicle if name == "vehicle" else vessel
    for plane in sim.scene.planes:
        outline = np.array(plane.outline_ned_m)
        assert np.max(np.abs(plane.distance_m(outline))) < 1e-9
        assert np.linalg.norm(plane.normal_ned) == pytest.approx(1.0)
        if plane.kind in ("ground", "roof", "shore", "deck"):
            assert plane.normal_ned[2] < 0.0  # up
    # the returns come from the side the normal points to
    for line, hit in zip(sim.lines, sim.line_hit_ids, strict=True):
        gtraj = GeorefTrajectory.from_trajectory(sim.truth_trajectory, 0.0)
        mount = sim.mount_true.with_latency(0.0)
        origin, _ = georeference(line.t_s, np.zeros_like(line.xyz_scanner_m), gtraj, mount)
        scanner = sim.scene.ecef_to_scene(origin)
        for plane in sim.scene.planes:
            m = hit == plane.hit_id
            if np.any(m):
                assert np.all(plane.distance_m(scanner[m]) > 0.0), plane.name


def test_feature_containers_validate_and_serialise() -> None:
    with pytest.raises(InputError, match="unit vector"):
        ScenePlane("p", "wall", (0, 0, 0), (1.0, 1.0, 0.0), ((0, 0, 0), (1, 0, 0), (1, 1, 0)), 1)
    with pytest.raises(InputError, match="kind"):
        ScenePlane("p", "floor", (0, 0, 0), (0, 0, 1.0), ((0, 0, 0), (1, 0, 0), (1, 1, 0)), 1)  # type: ignore[arg-type]
    with pytest.raises(InputError, match="radius_m"):
        SceneSphere("s", (0.0, 0.0, 0.0), 0.0, 3)
    s = SceneSphere("s", (1.0, 2.0, 3.0), 0.5, 3)
    assert s.distance_m(np.array([[1.0, 2.0, 4.0]]))[0] == pytest.approx(0.5)
    assert json.loads(json.dumps(s.as_document()))["radius_m"] == 0.5


# ------------------------------------------------------------------------------ drive
@pytest.mark.parametrize(
    ("radius_m", "offset_m"), [(12.0, 3.5), (57.6, 3.5), (15.0, 18.0), (5.0, 18.0)]
)
def test_turnaround_reverses_onto_the_lane_to_the_left(radius_m: float, offset_m: float) -> None:
    segs = turnaround(radius_m, offset_m)
    fwd, right = _displacement_m(segs)
    assert right == pytest.approx(-offset_m, abs=1e-9)
    assert fwd == pytest.approx(0.0, abs=1e-6)
    heading = sum(getattr(s, "angle_deg", 0.0) for s in segs)
    assert heading == pytest.approx(-180.0)


@pytest.mark.parametrize("name", ["vehicle", "vessel"])
def test_lines_both_ways_at_two_speeds_on_their_lanes(
    name: str, vehicle: PatchTestSimulation, vessel: PatchTestSimulation
) -> None:
    sim = vehicle if name == "vehicle" else vessel
    cfg = sim.config
    assert cfg.speeds_m_s is not None
    assert len(sim.lines) == 2 * cfg.passes_per_direction * len(cfg.speeds_m_s) == 4
    assert [w.direction for w in sim.line_windows] == ["outbound", "return"] * 2
    assert [w.speed_m_s for w in sim.line_windows] == [cfg.speeds_m_s[0]] * 2 + [
        cfg.speeds_m_s[1]
    ] * 2
    assert [line.name for line in sim.lines] == ["line_01", "line_02", "line_03", "line_04"]
    lay = sim.scene.layout
    truth = sim.truth_trajectory
    for window in sim.line_windows:
        m = (truth.t_s >= window.t_start_s) & (truth.t_s <= window.t_end_s)
        assert truth.vel_ned_m_s is not None
        speed = np.hypot(truth.vel_ned_m_s[m, 0], truth.vel_ned_m_s[m, 1])
        assert np.allclose(speed, window.speed_m_s, rtol=1e-9)  # constant over the line
        course = np.degrees(np.arctan2(truth.vel_ned_m_s[m, 1], truth.vel_ned_m_s[m, 0]))
        assert np.allclose((course - window.heading_deg + 180.0) % 360.0 - 180.0, 0.0, atol=0.01)
        duration = window.t_end_s - window.t_start_s
        assert duration == pytest.approx(lay.line_length_m / window.speed_m_s, rel=1e-6)
    for line, window in zip(sim.lines, sim.line_windows, strict=True):
        assert line.t_start_s >= window.t_start_s
        assert line.t_end_s <= window.t_end_s
        assert np.all(line.trajectory.contains(line.t_s + sim.mount_true.latency_s))


def test_every_line_sees_features_seen_by_every_other(
    vehicle: PatchTestSimulation, vessel: PatchTestSimulation
) -> None:
    for sim, least in ((vehicle, 12), (vessel, 5)):
        seen = [set(np.unique(h).tolist()) for h in sim.line_hit_ids]
        common = set.intersection(*seen)
        assert len(common) >= least, sim.config.scenario


def test_vessel_spheres_are_seen_on_every_pass() -> None:
    cfg = PatchTestConfig(scenario="vessel", density=0.2, passes_per_direction=1, nav_rate_hz=20.0)
    sim = simulate_patch_test(cfg)
    for hit in sim.line_hit_ids:
        for sphere in sim.scene.spheres:
            assert np.count_nonzero(hit == sphere.hit_id) >= 3


# ---------------------------------------------------------------------------- geometry
@pytest.mark.parametrize("name", ["vehicle", "vessel"])
def test_true_mount_and_exact_trajectory_put_returns_on_the_scene(
    name: str, vehicle: PatchTestSimulation, vessel: PatchTestSimulation
) -> None:
    sim = vehicle if name == "vehicle" else vessel
    sigma = sim.config.range_noise_m
    tau = sim.mount_true.latency_s
    for i in range(len(sim.lines)):
        # the exact trajectory, tagged tau late as the navigation is
        d = _distances_m(sim, i, sim.truth_trajectory.shifted(tau), sim.mount_true)
        assert _rms(d) <= 1.05 * sigma  # the noise is along the beam: at most sigma
        assert np.max(np.abs(d)) < 6.0 * sigma


@pytest.mark.parametrize("name", ["vehicle", "vessel"])
def test_navigation_and_true_mount_within_the_trajectory_errors_nominal_off(
    name: str, vehicle: PatchTestSimulation, vessel: PatchTestSimulation
) -> None:
    sim = vehicle if name == "vehicle" else vessel
    for i, line in enumerate(sim.lines):
        exact = _rms(
            _distances_m(
                sim, i, sim.truth_trajectory.shifted(sim.mount_true.latency_s), sim.mount_true
            )
        )
        nav = _rms(_distances_m(sim, i, line.trajectory, sim.mount_true))
        nominal = _rms(_distances_m(sim, i, line.trajectory, sim.mount_nominal))
        assert exact < nav < 0.07  # a few cm: 2-3 cm position, 0.005-0.01 deg attitude
        assert nominal > 0.045
        # the mount errors alone, with the exact trajectory
        off = _distances_m(
            sim,
            i,
            sim.truth_trajectory.shifted(sim.mount_true.latency_s),
            replace(sim.mount_nominal, latency_s=sim.mount_true.latency_s),
        )
        assert _rms(off) > 4.0 * exact


def test_latency_sign_navigation_lags_by_tau(exact_vehicle: PatchTestSimulation) -> None:
    sim = exact_vehicle
    tau = sim.mount_true.latency_s
    assert tau == pytest.approx(0.02)
    nav, truth = sim.navigation, sim.truth_trajectory
    # the record tagged t + tau holds the state of t ...
    assert np.allclose(nav.t_s, truth.t_s + tau, rtol=0.0, atol=1e-6)
    assert nav.lat_lon_h is not None
    assert truth.lat_lon_h is not None
    assert np.allclose(nav.lat_lon_h, truth.lat_lon_h, rtol=0.0, atol=1e-12)
    # ... so correcting for +tau gives the truth back on the scanner's time scale
    back = nav.corrected_for_latency(tau)
    assert np.allclose(back.t_s, truth.t_s, rtol=0.0, atol=1e-6)
    # ... and on a regular grid of GPS time from start_gps_s
    step = 1.0 / sim.config.nav_rate_hz
    k = (nav.t_s - sim.config.start_gps_s) / step
    assert np.allclose(k, np.round(k), atol=1e-4)
    for i, line in enumerate(sim.lines):
        right = _rms(_distances_m(sim, i, line.trajectory, sim.mount_true))
        none = _rms(_distances_m(sim, i, line.trajectory, sim.mount_true.with_latency(0.0)))
        wrong = _rms(_distances_m(sim, i, line.trajectory, sim.mount_true.with_latency(-tau)))
        assert right <= 1.05 * sim.config.range_noise_m
        assert right < 0.6 * none < 0.6 * wrong


def test_vessel_roll_with_latency_moves_the_points(vessel: PatchTestSimulation) -> None:
    cfg = vessel.config
    assert cfg.motion is not None
    assert cfg.motion.roll_amplitude_deg == 4.0
    rpy = np.degrees(vessel.truth_trajectory.euler_rpy_rad())
    assert 3.5 < np.max(np.abs(rpy[:, 0])) <= 4.0 + 1e-9
    assert vessel.truth_trajectory.lat_lon_h is not None
    heave = vessel.truth_trajectory.lat_lon_h[:, 2]
    assert np.ptp(heave) == pytest.approx(0.3, abs=0.02)


# ----------------------------------------------------------------------- determinism
def test_same_seed_same_data_other_seed_other_noise() -> None:
    cfg = PatchTestConfig(
        scenario="vessel", density=0.003, passes_per_direction=1, nav_rate_hz=20.0
    )
    a, b = simulate_patch_test(cfg), simulate_patch_test(cfg)
    c = simulate_patch_test(replace(cfg, seed=2))
    for la, lb, lc in zip(a.lines, b.lines, c.lines, strict=True):
        assert np.array_equal(la.t_s, lb.t_s)
        assert np.array_equal(la.xyz_scanner_m, lb.xyz_scanner_m)
        assert np.array_equal(la.trajectory.lat_lon_h, lb.trajectory.lat_lon_h)  # type: ignore[arg-type]
        assert not np.array_equal(la.trajectory.lat_lon_h, lc.trajectory.lat_lon_h)  # type: ignore[arg-type]
    assert a.truth == b.truth
    assert json.loads(json.dumps(a.truth)) == a.truth


def test_density_scales_the_point_count(vehicle: PatchTestSimulation) -> None:
    half = simulate_patch_test(replace(vehicle.config, density=0.005))
    ratio = half.n_points / vehicle.n_points
    assert ratio == pytest.approx(0.5, rel=0.05)


def test_lines_are_scan_lines_with_sorted_times(vehicle: PatchTestSimulation) -> None:
    for line in vehicle.lines:
        assert isinstance(line, ScanLine)
        assert np.all(np.diff(line.t_s) >= 0.0)
        assert not line.xyz_scanner_m.flags.writeable


# ----------------------------------------------------------------------------- config
@pytest.mark.parametrize(
    ("kwargs", "fragment"),
    [
        ({"scenario": "plane"}, "scenario must be 'vehicle' or 'vessel'"),
        ({"density": 0.0}, "density"),
        ({"density": 1.5}, "density must lie in (0, 1]"),
        ({"passes_per_direction": 0}, "passes_per_direction"),
        ({"seed": -1}, "seed"),
        ({"speeds_m_s": ()}, "1 to 5 speeds"),
        ({"speeds_m_s": (5.0, 100.0)}, "outside [0.2, 40]"),
        ({"boresight_error_rpy_deg": (0.0, 9.0, 0.0)}, "within 5 deg"),
        ({"lever_arm_error_body_m": (0.0, 0.0, 2.0)}, "within 1 m"),
        ({"latency_error_s": math.inf}, "latency_error_s"),
        ({"nominal_mount": Mount()}, "[profiler] azimuth_deg"),
        ({"range_noise_m": -0.01}, "range_noise_m"),
        ({"max_range_m": 0.5}, "max_range_m must exceed min_range_m"),
        ({"angular_step_deg": 30.0}, "angular_step_deg"),
        ({"std_att_deg": (0.0, -1.0, 0.0)}, "std_att_deg"),
        ({"motion": PlatformMotion(roll_amplitude_deg=5.0, roll_period_s=1.0)}, None),
    ],
)
def test_bad_config_is_an_input_error(kwargs: dict[str, object], fragment: str | None) -> None:
    if fragment is None:  # a valid motion: accepted
        PatchTestConfig(**kwargs)  # type: ignore[arg-type]
        return
    with pytest.raises(InputError) as info:
        PatchTestConfig(**kwargs)  # type: ignore[arg-type]
    assert fragment in str(info.value)


def test_platform_motion_is_validated() -> None:
    with pytest.raises(InputError, match="roll_period_s"):
        PlatformMotion(roll_period_s=0.0)
    with pytest.raises(InputError, match="within 30 / 20 deg"):
        PlatformMotion(roll_amplitude_deg=45.0)


def test_scenario_defaults_and_true_mount() -> None:
    vehicle, vessel = PatchTestConfig(), PatchTestConfig(scenario="vessel")
    assert vehicle.speeds_m_s == (5.0, 12.0)
    assert vessel.speeds_m_s == (2.0, 4.0)
    assert vehicle.spheres is False
    assert vessel.spheres is True
    true = vehicle.mount_true
    nominal = vehicle.mount_nominal
    assert true.latency_s - nominal.latency_s == pytest.approx(0.005)
    assert np.allclose(
        np.subtract(true.boresight_rpy_deg, nominal.boresight_rpy_deg), (0.25, -0.3, 0.4)
    )
    assert np.allclose(
        np.subtract(true.lever_arm_body_m, nominal.lever_arm_body_m), (0.03, -0.02, 0.04)
    )
    assert true.profiler_azimuth_deg == nominal.profiler_azimuth_deg == 0.0


def test_a_line_without_returns_is_reported() -> None:
    cfg = PatchTestConfig(scenario="vessel", density=1e-6, passes_per_direction=1, nav_rate_hz=20.0)
    with pytest.raises(InputError, match="no return; raise density"):
        simulate_patch_test(cfg)


# ------------------------------------------------------------------------------ files
def test_files_read_back_with_the_project_readers(
    vehicle: PatchTestSimulation, tmp_path: Path
) -> None:
    out = tmp_path / "sim"
    written = write_patch_test(vehicle, out)
    names = [p.name for p in written]
    assert names == list(patch_test_files(4))
    assert sorted(names) == sorted(p.name for p in out.iterdir())
    truth = json.loads((out / "truth.json").read_text())
    assert truth["simulation"] == "patch-test"
    assert truth["files"] == names
    week = truth["gps_week"]
    assert week == vehicle.gps_week == 2345
    nav = read_sbet(out / "trajectory.out", gps_week=week)
    assert np.allclose(nav.t_s, vehicle.navigation.t_s, rtol=0.0, atol=1e-6)
    assert nav.lat_lon_h is not None
    assert vehicle.navigation.lat_lon_h is not None
    assert np.allclose(nav.lat_lon_h, vehicle.navigation.lat_lon_h, rtol=0.0, atol=1e-9)
    assert np.allclose(
        nav.q_body_to_ned * np.sign(nav.q_body_to_ned[:, :1]),
        vehicle.navigation.q_body_to_ned * np.sign(vehicle.navigation.q_body_to_ned[:, :1]),
        atol=1e-9,
    )
    assert read_mount(out / "mount.toml") == vehicle.mount_nominal
    assert truth["mount_true"]["latency_s"] == pytest.approx(0.005)
    for i, line in enumerate(vehicle.lines):
        path = out / f"line_{i + 1:02d}.laz"
        info = las_info(path)
        assert info.gps_time_type == "adjusted_standard"
        assert info.point_count == len(line) == truth["lines"][i]["n_points"]
        assert truth["lines"][i]["file"] == path.name
        pts = read_las_points(path, 0, info.point_count)
        xyz = np.column_stack([pts.x, pts.y, pts.z])
        assert np.max(np.abs(xyz - line.xyz_scanner_m)) <= 0.5e-4 + 1e-9
        assert np.allclose(np.asarray(pts.gps_time) + 1e9, line.t_s, rtol=0.0, atol=1e-6)
        assert set(np.asarray(pts.point_source_id).tolist()) == {i + 1}
        assert set(np.asarray(pts.return_number).tolist()) == {1}  # 1 of 1, not 0 of 0
        assert set(np.asarray(pts.number_of_returns).tolist()) == {1}


def test_las_format_and_replacing_an_earlier_patch_test(
    vehicle: PatchTestSimulation, vessel: PatchTestSimulation, tmp_path: Path
) -> None:
    out = tmp_path / "sim"
    eight = replace(
        vessel, lines=vessel.lines * 2, truth={**vessel.truth, "lines": vessel.truth["lines"] * 2}
    )
    write_patch_test(eight, out)
    assert (out / "line_08.laz").is_file()
    assert len(check_patch_test_folder(out)) == 11
    write_patch_test(vehicle, out, file_format="las")
    assert sorted(p.name for p in out.iterdir()) == sorted(patch_test_files(4, "las"))
    assert json.loads((out / "truth.json").read_text())["file_format"] == "las"


def test_refuses_a_folder_with_other_files(vehicle: PatchTestSimulation, tmp_path: Path) -> None:
    other = tmp_path / "other"
    other.mkdir()
    (other / "notes.txt").write_text("keep me")
    with pytest.raises(InputError, match="holds other files"):
        write_patch_test(vehicle, other)
    drive = tmp_path / "drive"
    drive.mkdir()
    (drive / "truth.json").write_text('{"simulation": "drive"}')
    with pytest.raises(InputError, match="holds another simulation"):
        write_patch_test(vehicle, drive)
    mixed = tmp_path / "mixed"
    write_patch_test(vehicle, mixed)
    (mixed / "extra.csv").write_text("x")
    with pytest.raises(InputError, match="earlier patch test and other files"):
        write_patch_test(vehicle, mixed)
    as_file = tmp_path / "file"
    as_file.write_text("x")
    with pytest.raises(InputError, match="exists and is not a folder"):
        write_patch_test(vehicle, as_file)
    with pytest.raises(InputError, match="laz or las"):
        write_patch_test(vehicle, tmp_path / "new", file_format="csv")  # type: ignore[arg-type]
    assert (other / "notes.txt").read_text() == "keep me"


def test_scene_document_is_complete(vessel: PatchTestSimulation) -> None:
    doc = vessel.truth["scene"]
    assert isinstance(vessel.scene, PatchTestScene)
    assert doc["origin_lat_lon_h"] == list(vessel.config.origin_lat_lon_h)
    assert {p["name"] for p in doc["planes"]} == {p.name for p in vessel.scene.planes}
    assert [s["radius_m"] for s in doc["spheres"]] == [0.4, 0.4]
    assert doc["water_returns_dropped"] is True


def test_with_nominal_keeps_the_true_mount() -> None:
    # A second survey started from an earlier calibration's mount: same truth, the
    # injected errors are what that mount still has wrong.
    config = PatchTestConfig(scenario="vessel")
    start = replace(
        config.mount_nominal,
        boresight_rpy_deg=(-89.7, -0.2, 20.3),
        lever_arm_body_m=(0.62, 1.09, -2.95),
        latency_s=0.004,
    )
    again = config.with_nominal(start)
    assert again.mount_nominal == start
    np.testing.assert_allclose(again.boresight_error_rpy_deg, (-0.05, -0.1, 0.1), atol=1e-12)
    np.testing.assert_allclose(again.lever_arm_error_body_m, (0.01, -0.01, -0.01), atol=1e-12)
    assert again.latency_error_s == pytest.approx(0.001)
    t, a = config.mount_true, again.mount_true
    np.testing.assert_allclose(a.boresight_rpy_deg, t.boresight_rpy_deg, atol=1e-12)
    np.testing.assert_allclose(a.lever_arm_body_m, t.lever_arm_body_m, atol=1e-12)
    assert a.latency_s == pytest.approx(t.latency_s)
