"""Scene panels: flat convex polygons of any orientation, cast with the other primitives."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from kinsync._typing import FloatArray
from kinsync.errors import InputError
from kinsync.sim.scene import NO_HIT, Panel, Scene, Target, Wall

ORIGIN = (46.8, -71.2, 10.0)

ROOF = Panel.rectangle((10.0, -5.0, -3.0), (0.0, 10.0, 0.0), (4.0, 0.0, -4.0), "roof")
"""A 45 deg roof: 10 m along East, rising towards North from D = -3 to D = -7."""

GABLE = Panel(
    ((0.0, 20.0, 0.0), (0.0, 30.0, 0.0), (0.0, 30.0, -5.0), (0.0, 25.0, -8.0), (0.0, 20.0, -5.0)),
    "gable",
)
"""A pentagonal gable end in the plane N = 0, East 20..30 m, 5 m to the eaves, 8 m ridge."""


def _unit(v: list[float]) -> FloatArray:
    a = np.array(v, dtype=np.float64)
    out: FloatArray = a / np.linalg.norm(a)
    return out


def test_panel_geometry() -> None:
    assert np.allclose(np.abs(ROOF.normal_ned), _unit([1.0, 0.0, 1.0]))
    assert ROOF.area_m2 == pytest.approx(10.0 * 4.0 * math.sqrt(2.0))
    assert np.allclose(ROOF.centroid_ned_m, [12.0, 0.0, -5.0])
    assert GABLE.area_m2 == pytest.approx(10.0 * 5.0 + 0.5 * 10.0 * 3.0)
    centre, radius = GABLE.bounding_sphere()
    assert np.all(np.linalg.norm(GABLE.vertices_array_ned_m - centre, axis=1) <= radius + 1e-12)


def test_rays_hit_panels_at_the_exact_range_and_miss_outside() -> None:
    scene = Scene(origin_lat_lon_h=ORIGIN, ground_down_m=2.0, panels=(ROOF, GABLE))
    assert scene.first_panel_id == 1
    assert scene.first_target_id == 3
    origins = np.array(
        [[12.0, 0.0, 1.0], [12.0, 0.0, 1.0], [-10.0, 25.0, -7.0], [-10.0, 21.0, -7.0]]
    )
    dirs = np.array([[0.0, 0.0, -1.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    rng, hit = scene.cast(origins, dirs, 100.0)
    # up from under the roof: its plane N + D = 7 is at D = -5 above N = 12
    assert rng[0] == pytest.approx(6.0)
    assert hit[0] == 1
    assert rng[1] == pytest.approx(1.0)  # down to the ground
    assert hit[1] == 0
    assert rng[2] == pytest.approx(10.0)  # into the gable, below the ridge
    assert hit[2] == 2
    assert hit[3] == NO_HIT  # above the eave line, outside the triangle
    assert np.isinf(rng[3])


def test_panels_keep_walls_and_targets_numbering() -> None:
    wall = Wall(start_ne_m=(0.0, 5.0), end_ne_m=(10.0, 5.0), top_down_m=-1.0, bottom_down_m=2.0)
    target = Target("S1", (30.0, 0.0, 0.0), radius_m=0.5)
    plain = Scene(ORIGIN, 2.0, walls=(wall,), targets=(target,))
    assert plain.first_target_id == 2
    scene = Scene(ORIGIN, 2.0, walls=(wall,), targets=(target,), panels=(ROOF,))
    assert scene.first_panel_id == 2
    assert scene.first_target_id == 3
    o = np.zeros((3, 3))
    d = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], _unit([12.0, 0.0, -5.0])])
    _, hit = scene.cast(o, d, 100.0)
    assert hit[0] == 1  # wall
    assert hit[1] == 3  # sphere
    assert hit[2] == 2  # roof


def test_panels_out_of_reach_are_skipped_without_changing_results() -> None:
    far = Panel.rectangle((500.0, -5.0, -5.0), (0.0, 10.0, 0.0), (0.0, 0.0, 10.0), "far")
    scene = Scene(ORIGIN, 2.0, panels=(ROOF, far))
    d = np.array([[1.0, 0.0, 0.0], _unit([12.0, 0.0, -5.0])])
    o = np.zeros((2, 3))
    r_near, hit_near = scene.cast(o, d, 100.0)
    r_far, hit_far = scene.cast(o, d, 1000.0)
    assert hit_near[0] == NO_HIT
    assert hit_far[0] == 2
    assert r_far[0] == pytest.approx(500.0)
    assert hit_near[1] == hit_far[1] == 1
    assert r_near[1] == r_far[1]


@pytest.mark.parametrize(
    ("vertices", "fragment"),
    [
        (((0.0, 0.0, 0.0), (1.0, 0.0, 0.0)), "at least 3 vertices"),
        (((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (1.0, 1.0, 0.0)), "coincide"),
        (((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (2.0, 0.0, 0.0)), "no area"),
        (((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (1.0, 1.0, 0.0), (0.0, 1.0, 0.1)), "not coplanar"),
        (
            ((0.0, 0.0, 0.0), (2.0, 0.0, 0.0), (1.0, 0.5, 0.0), (2.0, 2.0, 0.0), (0.0, 2.0, 0.0)),
            "not convex",
        ),
        (((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (1.0, math.nan, 0.0)), "vertex 2"),
    ],
)
def test_bad_panels_are_input_errors(
    vertices: tuple[tuple[float, float, float], ...], fragment: str
) -> None:
    with pytest.raises(InputError) as info:
        Panel(vertices, "p")
    assert fragment in str(info.value)
    assert "'p'" in str(info.value)


@settings(max_examples=40, deadline=None)
@given(
    s=st.floats(0.02, 0.98),
    t=st.floats(0.02, 0.98),
    tilt=st.floats(-80.0, 80.0),
    azimuth=st.floats(0.0, 360.0),
)
def test_a_ray_to_any_point_of_a_panel_hits_it_there(
    s: float, t: float, tilt: float, azimuth: float
) -> None:
    a, b = math.radians(azimuth), math.radians(tilt)
    u = (3.0 * math.cos(a), 3.0 * math.sin(a), 0.0)
    v = (-2.0 * math.sin(a) * math.cos(b), 2.0 * math.cos(a) * math.cos(b), -2.0 * math.sin(b))
    panel = Panel.rectangle((5.0, 5.0, -1.0), u, v)
    target = np.array([5.0, 5.0, -1.0]) + s * np.array(u) + t * np.array(v)
    origin = np.array([[0.0, 0.0, -20.0]])
    d = (target - origin) / np.linalg.norm(target - origin)
    rng, hit = Scene(ORIGIN, 1e6, panels=(panel,)).cast(origin, d, 200.0)
    assert hit[0] == 1
    assert rng[0] == pytest.approx(float(np.linalg.norm(target - origin[0])), rel=1e-12)
