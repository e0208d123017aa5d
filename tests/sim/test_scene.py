"""Scene primitives, vectorised ray casting and placement along a drive."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from kinsync._typing import FloatArray
from kinsync.errors import InputError
from kinsync.sim.drive import oval_route
from kinsync.sim.drive_truth import simulate_truth
from kinsync.sim.scene import (
    NO_HIT,
    Scene,
    SceneLayout,
    Target,
    Wall,
    build_drive_scene,
    trajectory_to_local,
)
from kinsync.trajectory import Trajectory

ORIGIN = (46.8, -71.2, 10.0)
SCENE = Scene(
    origin_lat_lon_h=ORIGIN,
    ground_down_m=2.0,
    walls=(Wall(start_ne_m=(0.0, 5.0), end_ne_m=(10.0, 5.0), top_down_m=-1.0, bottom_down_m=2.0),),
    targets=(Target("S1", (2.0, -3.0, 0.5), radius_m=0.2),),
)


def _unit(v: list[float]) -> FloatArray:
    a = np.array(v, dtype=np.float64)
    out: FloatArray = a / np.linalg.norm(a)
    return out


def test_ground_wall_and_sphere_ranges_are_exact() -> None:
    origins = np.zeros((6, 3))
    dirs = np.array(
        [
            [0.0, 0.0, 1.0],  # straight down: ground at 2 m
            _unit([0.0, 1.0, 0.0]),  # east: wall at 5 m
            _unit([0.2, 1.0, 0.0]),  # wall, oblique
            _unit([2.0, -3.0, 0.5]),  # at the sphere centre
            [0.0, 0.0, -1.0],  # up: nothing
            _unit([-1.0, 1.0, 0.0]),  # east-west past the wall's end, level: nothing
        ]
    )
    rng, hit = SCENE.cast(origins, dirs, 50.0)
    assert hit.tolist() == [0, 1, 1, SCENE.first_target_id, NO_HIT, NO_HIT]
    assert rng[0] == pytest.approx(2.0)
    assert rng[1] == pytest.approx(5.0)
    assert rng[2] == pytest.approx(5.0 / dirs[2, 1])
    assert rng[3] == pytest.approx(np.linalg.norm([2.0, -3.0, 0.5]) - 0.2)
    assert np.isinf(rng[4:]).all()


def test_nearest_hit_wins_and_range_limit() -> None:
    # Looking down through the sphere: the sphere is nearer than the ground.
    origin = np.array([[2.0, -3.0, -5.0]])
    rng, hit = SCENE.cast(origin, np.array([[0.0, 0.0, 1.0]]), 50.0)
    assert hit[0] == SCENE.first_target_id
    assert rng[0] == pytest.approx(5.5 - 0.2)
    rng, hit = SCENE.cast(origin, np.array([[0.0, 0.0, 1.0]]), 5.0)
    assert hit[0] == NO_HIT
    # Above the wall's top edge: the ray passes over it and hits nothing.
    rng, hit = SCENE.cast(np.array([[5.0, 0.0, -2.0]]), np.array([[0.0, 1.0, 0.0]]), 50.0)
    assert hit[0] == NO_HIT


@given(
    az=st.floats(0.0, 2 * math.pi),
    el=st.floats(-0.1, 0.1),
    dist=st.floats(1.0, 30.0),
    radius=st.floats(0.05, 0.5),
)
@settings(max_examples=60, deadline=None)
def test_sphere_hits_lie_on_the_sphere(az: float, el: float, dist: float, radius: float) -> None:
    centre = np.array([dist * math.cos(az), dist * math.sin(az), -3.0])
    scene = Scene(ORIGIN, ground_down_m=50.0, targets=(Target("T", tuple(centre), radius),))
    base = _unit(list(centre))
    # Rays fanned around the centre direction: hits must lie on the sphere surface.
    offsets = np.linspace(-1.5, 1.5, 31) * radius / dist
    dirs = np.array([_unit(list(base + np.array([o, -o, el * o]))) for o in offsets])
    rng, hit = scene.cast(np.zeros_like(dirs), dirs, 100.0)
    on = hit == scene.first_target_id
    assert on.any()
    points = dirs[on] * rng[on, None]
    np.testing.assert_allclose(np.linalg.norm(points - centre, axis=1), radius, atol=1e-9)


def test_bad_primitives() -> None:
    with pytest.raises(InputError, match="coincide"):
        Wall((1.0, 1.0), (1.0, 1.0), -1.0, 0.0)
    with pytest.raises(InputError, match="above"):
        Wall((0.0, 0.0), (1.0, 1.0), 1.0, 0.0)
    with pytest.raises(InputError, match="radius_m"):
        Target("T", (0.0, 0.0, 0.0), radius_m=0.0)
    with pytest.raises(InputError, match="kind"):
        Target("T", (0.0, 0.0, 0.0), kind="other")  # type: ignore[arg-type]
    with pytest.raises(InputError, match="more than once"):
        Scene(ORIGIN, 0.0, targets=(Target("A", (0, 0, 0)), Target("A", (1, 0, 0))))
    with pytest.raises(InputError, match="latitude"):
        Scene((95.0, 0.0, 0.0), 0.0)


@pytest.fixture(scope="module")
def oval() -> tuple[Trajectory, Scene]:
    truth = simulate_truth(
        oval_route(speed_m_s=2.0, straight_m=20.0, radius_m=10.0, laps=1, static_s=2.0),
        rate_hz=20.0,
        origin_lat_lon_h=ORIGIN,
    )
    return truth, build_drive_scene(truth, SceneLayout(n_control=3))


def test_drive_scene_places_targets_beside_the_path(oval: tuple[Trajectory, Scene]) -> None:
    truth, scene = oval
    lay = SceneLayout()
    pos, R = trajectory_to_local(truth, scene.origin_lat_lon_h)
    assert [t.name for t in scene.targets] == ["S1", "S2", "C1", "C2", "C3"]
    assert [t.kind for t in scene.targets] == ["sync", "sync", "control", "control", "control"]
    for target in scene.targets:
        c = np.array(target.centre_ned_m)
        k = int(np.argmin(np.linalg.norm(pos[:, :2] - c[:2], axis=1)))
        lateral = R[k].T @ (c - pos[k])  # body frame at the nearest record
        expected = lay.sync_offset_m if target.kind == "sync" else lay.control_offset_m
        assert abs(lateral[1]) == pytest.approx(expected, abs=0.05)
        assert abs(lateral[0]) < 0.05
        assert c[2] == pytest.approx(scene.ground_down_m - lay.target_height_m)
    # Ground below the body reference point by the body height.
    assert scene.ground_down_m == pytest.approx(np.mean(pos[:, 2]) + lay.body_height_m)
    # Sync targets: S1 beside the path 12 m after the start, S2 12 m before the end.
    s1 = np.array(scene.targets[0].centre_ned_m)
    assert np.linalg.norm(s1[:2] - pos[0, :2]) == pytest.approx(
        math.hypot(lay.sync_lead_m, lay.sync_offset_m), abs=0.2
    )


def test_wall_stands_outside_the_tightest_curve(oval: tuple[Trajectory, Scene]) -> None:
    truth, scene = oval
    (wall,) = scene.walls
    pos, _ = trajectory_to_local(truth, scene.origin_lat_lon_h)
    mid = 0.5 * (np.array(wall.start_ne_m) + np.array(wall.end_ne_m))
    dist = np.linalg.norm(pos[:, :2] - mid, axis=1)
    assert dist.min() == pytest.approx(SceneLayout().wall_offset_m, abs=0.05)
    # Outside: farther from the oval's centre than the path there.
    centre = pos[:, :2].mean(axis=0)
    k = int(np.argmin(dist))
    assert np.linalg.norm(mid - centre) > np.linalg.norm(pos[k, :2] - centre)
    assert wall.bottom_down_m == pytest.approx(scene.ground_down_m)


def test_short_path_is_refused(oval: tuple[Trajectory, Scene]) -> None:
    truth, _ = oval
    with pytest.raises(InputError, match="sync_lead_m"):
        build_drive_scene(truth.sliced(truth.t_start_s, truth.t_start_s + 8.0))
    with pytest.raises(InputError, match="n_control"):
        SceneLayout(n_control=-1)
