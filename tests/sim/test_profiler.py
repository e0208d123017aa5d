"""Profile-scanner simulator: clock, geometry of the returns, drive-scan data sets."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest

from kinsync.clock.profile import ProfileClock
from kinsync.errors import InputError
from kinsync.frames import geodetic_to_ecef, rotation_ned_to_ecef
from kinsync.georef import GeorefTrajectory, georeference
from kinsync.io.mount_file import read_mount
from kinsync.io.profile_scan import read_profile_scan, read_pulses, read_sync_points
from kinsync.io.trajectory_csv import read_trajectory_csv
from kinsync.mount import Mount
from kinsync.sim.drive import oval_route
from kinsync.sim.drive_truth import simulate_truth
from kinsync.sim.profiler import (
    DRIVE_SCAN_FILES,
    MAX_DRIVE_SCAN_BEAMS,
    DriveScanConfig,
    DriveScanSimulation,
    ProfilerConfig,
    drive_scan_size_problem,
    profile_pulses,
    profiles_near_targets,
    simulate_drive_scan,
    simulate_profiler,
    write_drive_scan,
)
from kinsync.sim.scene import NO_HIT, SceneLayout, build_drive_scene
from kinsync.trajectory import Trajectory

MOUNT = Mount(
    lever_arm_body_m=(0.6, 0.1, -1.4), boresight_rpy_deg=(0.5, -0.4, 1.0), profiler_azimuth_deg=3.0
)
EXACT = ProfilerConfig(
    angular_step_deg=2.0, range_noise_m=0.0, intensity_noise=0.0, glint_fraction=0.0
)


@pytest.fixture(scope="module")
def short_drive() -> Trajectory:
    route = oval_route(speed_m_s=2.0, straight_m=15.0, radius_m=10.0, laps=1, static_s=1.0)
    return simulate_truth(route, rate_hz=50.0, t_start_s=1.4e9, duration_s=40.0)


def test_returns_follow_the_clock_and_lie_on_the_scene(short_drive: Trajectory) -> None:
    scene = build_drive_scene(short_drive, SceneLayout(n_control=2))
    cfg = dataclasses.replace(EXACT, t0_s=1.4e9 + 0.31, period_s=0.0307)
    sim = simulate_profiler(short_drive, MOUNT, scene, cfg)
    scan = sim.scan
    expected_t = 1.4e9 + 0.31 + (scan.profile + scan.angle_rad / (2 * math.pi)) * 0.0307
    np.testing.assert_allclose(sim.t_s, expected_t, rtol=0, atol=1e-9)
    clock = ProfileClock(sim.t0_s, sim.period_s)  # the clock Method B estimates
    np.testing.assert_allclose(
        clock.time_s(scan.profile, scan.angle_rad), sim.t_s, rtol=0, atol=1e-6
    )
    assert np.ptp(scan.angle_rad) > 1.0  # returns on both sides of nadir
    assert sim.n_profiles == math.floor((short_drive.t_end_s - 1.4e9 - 0.31) / 0.0307 - 0.375) + 1
    # Georeference every return with its true time: it lies on what it hit.
    gtraj = GeorefTrajectory.from_trajectory(short_drive)
    ecef, inside = georeference(
        sim.t_s,
        MOUNT.profile_to_scanner(angle_rad=scan.angle_rad, range_m=scan.range_m),
        gtraj,
        MOUNT,
    )
    assert inside.all()
    R_le = rotation_ned_to_ecef(*scene.origin_lat_lon_h[:2])
    local = (ecef - geodetic_to_ecef(*scene.origin_lat_lon_h)) @ R_le
    ground = sim.hit_id == 0
    assert ground.sum() > 0.5 * len(scan)
    np.testing.assert_allclose(local[ground, 2], scene.ground_down_m, atol=1e-6)
    for k, target in enumerate(scene.targets, start=scene.first_target_id):
        on = sim.hit_id == k
        assert on.sum() >= 3, target.name
        dist = np.linalg.norm(local[on] - np.array(target.centre_ned_m), axis=1)
        np.testing.assert_allclose(dist, target.radius_m, atol=1e-6)
        assert np.all(scan.intensity[on] == cfg.target_intensity)
    assert np.all(scan.intensity[~(sim.hit_id >= scene.first_target_id)] < 0.5)
    assert NO_HIT not in sim.hit_id
    assert np.all(scan.range_m >= cfg.min_range_m)
    assert np.all(scan.range_m <= cfg.max_range_m)


def test_near_target_profiles_reproduce_the_full_scan(short_drive: Trajectory) -> None:
    scene = build_drive_scene(short_drive, SceneLayout(n_control=1))
    cfg = dataclasses.replace(EXACT, t0_s=1.4e9 + 0.2)
    full = simulate_profiler(short_drive, MOUNT, scene, cfg)
    wanted = profiles_near_targets(short_drive, MOUNT, scene, cfg, 1.4e9 + 0.2)
    assert 0 < wanted.size < 0.2 * full.n_profiles
    part = simulate_profiler(short_drive, MOUNT, scene, cfg, profiles=wanted)
    on_target = full.hit_id >= scene.first_target_id
    assert np.isin(full.scan.profile[on_target], wanted).all()
    keep = np.isin(full.scan.profile, wanted)
    np.testing.assert_array_equal(part.scan.profile, full.scan.profile[keep])
    np.testing.assert_array_equal(part.scan.range_m, full.scan.range_m[keep])
    np.testing.assert_array_equal(part.hit_id, full.hit_id[keep])


def test_noise_and_glints(short_drive: Trajectory) -> None:
    scene = build_drive_scene(short_drive, SceneLayout(n_control=0))
    base = dataclasses.replace(EXACT, t0_s=1.4e9 + 0.2)
    exact = simulate_profiler(short_drive, MOUNT, scene, base)
    noisy = simulate_profiler(
        short_drive,
        MOUNT,
        scene,
        dataclasses.replace(base, range_noise_m=0.004, glint_fraction=0.005, seed=3),
    )
    np.testing.assert_array_equal(noisy.hit_id, exact.hit_id)
    err = noisy.scan.range_m - exact.scan.range_m
    assert 0.0035 < err.std() < 0.0045
    assert abs(err.mean()) < 0.0005
    glints = (noisy.hit_id < scene.first_target_id) & (noisy.scan.intensity > 0.8)
    assert 0.003 < glints.mean() < 0.007


def test_profiler_bad_input(short_drive: Trajectory) -> None:
    scene = build_drive_scene(short_drive, SceneLayout(n_control=0))
    with pytest.raises(InputError, match="before the trajectory"):
        simulate_profiler(short_drive, MOUNT, scene, ProfilerConfig(t0_s=1.4e9 - 1.0))
    with pytest.raises(InputError, match=r"\[profiler\]"):
        simulate_profiler(short_drive, Mount(), scene)
    with pytest.raises(InputError, match="profile numbers must lie"):
        simulate_profiler(short_drive, MOUNT, scene, profiles=[10**7])
    for kwargs, frag in [
        ({"period_s": 0.0}, "period_s"),
        ({"angle_min_deg": 10.0, "angle_max_deg": 5.0}, "field of view"),
        ({"range_noise_m": -1.0}, "range_noise_m"),
        ({"max_range_m": 0.1}, "max_range_m must exceed"),
        ({"glint_fraction": 0.5}, "glint_fraction"),
    ]:
        with pytest.raises(InputError, match=frag):
            ProfilerConfig(**kwargs)  # type: ignore[arg-type]


def test_profile_pulses() -> None:
    p = profile_pulses(100.0, 0.03, 5, jitter_s=0.0)
    np.testing.assert_allclose(p, 100.0 + 0.03 * np.arange(5))
    p1 = profile_pulses(100.0, 0.03, 5, extra_first_pulse=True, jitter_s=0.0)
    assert p1.size == 6
    assert p1[0] == pytest.approx(100.0 - 0.03)
    np.testing.assert_allclose(p1[1:], p)


@pytest.fixture(scope="module")
def drive_scan() -> DriveScanSimulation:
    return simulate_drive_scan(
        DriveScanConfig(near_targets_only=True, extra_first_pulse=True, trajectory_noise_m=0.02)
    )


def test_drive_scan_scenario(drive_scan: DriveScanSimulation) -> None:
    truth = drive_scan.truth
    passes = {t["name"]: t["passes"] for t in truth["targets"]}
    near = {name: [p for p in ps if p["n_returns"] >= 8] for name, ps in passes.items()}
    # The scenario: two sync points, at the start and at the end, each seen twice
    # close by (the far side of the oval may add sparse far sightings).
    assert len(near["S1"]) >= 2
    assert len(near["S2"]) >= 2
    t_s1 = [p["t_s"] - 1.4e9 for p in passes["S1"]]
    t_s2 = [p["t_s"] - 1.4e9 for p in passes["S2"]]
    assert min(t_s1) < 30.0
    assert max(t_s2) > 270.0
    assert truth["t0_s"] == pytest.approx(1.4e9 + 0.4371)
    assert truth["period_s"] == 0.030545
    assert truth["n_profiles"] == drive_scan.scanner.n_profiles > 9000
    assert drive_scan.pulses_t_s.size == truth["n_profiles"] + 1
    assert truth["pulse_offset"] == 1
    # Noisy trajectory: the written positions differ from the truth by about the sigma.
    a = drive_scan.trajectory.lat_lon_h
    b = drive_scan.truth_trajectory.lat_lon_h
    assert a is not None
    assert b is not None
    diff = geodetic_to_ecef(a[:, 0], a[:, 1], a[:, 2]) - geodetic_to_ecef(b[:, 0], b[:, 1], b[:, 2])
    rms = np.sqrt(np.mean(diff**2))
    assert 0.01 < rms < 0.03


def test_write_drive_scan_round_trip(drive_scan: DriveScanSimulation, tmp_path: Path) -> None:
    out = tmp_path / "set"
    write_drive_scan(drive_scan, out)
    assert sorted(p.name for p in out.iterdir()) == sorted(DRIVE_SCAN_FILES)
    scan = read_profile_scan(out / "scan.csv")
    np.testing.assert_array_equal(scan.profile, drive_scan.scanner.scan.profile)
    np.testing.assert_array_equal(scan.range_m, drive_scan.scanner.scan.range_m)
    np.testing.assert_array_equal(read_pulses(out / "pulses.csv"), drive_scan.pulses_t_s)
    assert read_mount(out / "mount.toml") == drive_scan.config.mount
    sync = read_sync_points(out / "sync_points.csv")
    assert sync.names == ("S1", "S2")
    np.testing.assert_array_equal(sync.lat_lon_h, drive_scan.sync_points.lat_lon_h)
    assert read_sync_points(out / "control_points.csv").names == ("C1", "C2", "C3", "C4")
    traj = read_trajectory_csv(out / "trajectory.csv")
    assert len(traj) == len(drive_scan.trajectory)
    truth = json.loads((out / "truth.json").read_text())
    assert truth["t0_s"] == drive_scan.truth["t0_s"]
    with pytest.raises(InputError, match="not a folder"):
        write_drive_scan(drive_scan, out / "scan.csv")


def test_drive_scan_config_checks() -> None:
    for kwargs, frag in [
        ({"duration_s": 10.0}, "at least 40 s"),
        ({"route": "square"}, "route"),
        ({"trajectory_noise_m": -0.1}, "trajectory_noise_m"),
        ({"seed": -1}, "seed"),
        ({"mount": Mount()}, r"\[profiler\]"),
        ({"period_s": 1e-5}, "more than the 65,000,000 kinsync simulates"),
        ({"duration_s": 7200.0, "period_s": 0.025}, "give a shorter duration_s or a longer"),
    ]:
        with pytest.raises(InputError, match=frag):
            DriveScanConfig(**kwargs)  # type: ignore[arg-type]


def test_drive_scan_size_limit_keeps_the_declared_durations() -> None:
    # The longest --duration-s declared (2 h) fits at the default period.
    assert drive_scan_size_problem(7200.0, DriveScanConfig().period_s) is None
    n_beams = ProfilerConfig().angles_rad().size
    assert 7200.0 / 0.030545 * n_beams <= MAX_DRIVE_SCAN_BEAMS


def test_full_short_loop_scan() -> None:
    sim = simulate_drive_scan(DriveScanConfig(route="loop", duration_s=45.0, seed=4))
    scan = sim.scanner.scan
    # Every profile was scanned: returns from the ground in (nearly) every profile.
    assert np.unique(scan.profile).size >= 0.99 * sim.scanner.n_profiles
    assert (sim.scanner.hit_id == 0).mean() > 0.8
    assert sim.truth["pulse_offset"] == 0
    assert sim.pulses_t_s.size == sim.scanner.n_profiles
