"""Gross errors of a calibration's inputs (`kinsync.calibration.gross`): lines recorded
at the same time, a solution stuck at its start or far from it, walls that the two
directions never share, a fit worse than the start."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace

import numpy as np
import pytest

from kinsync._typing import FloatArray
from kinsync.calibration import estimator
from kinsync.calibration.adjustment import Observation
from kinsync.calibration.estimator import CalibrationOptions, calibrate_mount
from kinsync.calibration.features import Feature, PlaneFeature, SphereFeature
from kinsync.calibration.gross import (
    LINKED_SHARE,
    MAX_WALL_RANGE_M,
    _directions,
    far_from_start,
    line_heading_rad,
    lines_at_the_same_time,
    residual_rise,
    search_yaw,
    stuck_at_start,
    unlinked_directions,
    wall_range_m,
)
from kinsync.calibration.lines import ScanLine
from kinsync.calibration.planes import PatchOptions
from kinsync.errors import ConvergenceError

from .conftest import NOMINAL, Synthetic, line_truth

ALL = (0, 1, 2, 3, 4, 5, 6)


def _line(name: str, t0: float, heading_deg: float, duration_s: float = 20.0) -> ScanLine:
    traj = line_truth(t0, heading_deg, 5.0, (0.0, 0.0), duration_s, np.random.default_rng(1))
    t = np.linspace(t0 + 0.5, t0 + duration_s - 0.5, 50)
    return ScanLine(name, t, np.ones((t.size, 3)), traj)


def test_lines_recorded_at_the_same_time_are_refused() -> None:
    a = _line("line_01.laz", 1000.0, 20.0)
    copy = ScanLine("copy_01.laz", a.t_s, a.xyz_scanner_m, a.trajectory)
    later = _line("line_02.laz", 1030.0, 200.0)
    err = lines_at_the_same_time([a, later, copy])
    assert err is not None
    assert "'line_01.laz' and 'copy_01.laz' were recorded at the same time" in str(err)
    assert "given twice" in str(err)
    assert "two scanners" in str(err)
    assert lines_at_the_same_time([a, later]) is None
    # Touching or barely overlapping spans (a line cut in two) are separate lines.
    tail = _line("line_01b.laz", 1000.0 + 18.0, 20.0)
    assert lines_at_the_same_time([a, tail]) is None


def test_a_solution_that_never_left_its_start_is_an_error() -> None:
    start = np.array([0.0, -0.5, 0.7, -0.8, 0.0, -1.75, 0.0])
    err = stuck_at_start(start.copy(), start, ALL, 0.114)
    assert isinstance(err, ConvergenceError)
    assert "did not move from the starting mount" in str(err)
    assert "11.4 cm RMS" in str(err)
    moved = start.copy()
    moved[6] += 1e-9
    assert stuck_at_start(moved, start, ALL, 0.114) is None
    assert stuck_at_start(start.copy(), start, (), 0.114) is None


def test_far_from_start_is_beyond_what_a_crew_knows() -> None:
    start = np.zeros(7)
    step = np.zeros(7)
    step[2] = math.radians(1.5)
    assert far_from_start(start + step, start, ALL)
    assert not far_from_start(start + step, start, (0, 1, 3, 4, 5, 6))  # yaw held
    step[2] = math.radians(0.5)
    assert not far_from_start(start + step, start, ALL)
    lever = np.zeros(7)
    lever[3] = 0.2
    assert far_from_start(lever, start, ALL)
    latency = np.zeros(7)
    latency[6] = 0.02
    assert far_from_start(latency, start, ALL)


def test_a_fit_worse_than_the_start_is_named() -> None:
    text = residual_rise(0.1035, 0.1101)
    assert text is not None
    assert "10.3 cm -> 11 cm" in text
    assert residual_rise(0.10, 0.101) is None  # within the trimmed RMS's wobble
    assert residual_rise(0.10, 0.05) is None
    assert residual_rise(math.nan, 0.05) is None


def _wall(azimuth_deg: float) -> PlaneFeature:
    a = math.radians(azimuth_deg)
    return PlaneFeature(np.array([math.cos(a), math.sin(a), 0.0]), 0.0, np.zeros(3))


def _ground() -> PlaneFeature:
    return PlaneFeature(np.array([0.0, 0.0, -1.0]), 0.0, np.zeros(3))


def _seen(who: list[set[int]]) -> list[Observation]:
    idx = np.arange(3)
    return [Observation(i, k, idx) for k, lines in enumerate(who) for i in sorted(lines)]


@pytest.fixture(scope="module")
def four_lines() -> list[ScanLine]:
    """Lines 0 and 2 driven at 20 deg, 1 and 3 at 200 deg."""
    return [_line(f"line_0{i + 1}", 1000.0 + 30.0 * i, 20.0 + 180.0 * (i % 2)) for i in range(4)]


def test_line_heading_is_the_mean_yaw(four_lines: list[ScanLine]) -> None:
    assert math.degrees(line_heading_rad(four_lines[0])) == pytest.approx(20.0, abs=0.01)
    assert math.degrees(line_heading_rad(four_lines[1])) == pytest.approx(-160.0, abs=0.01)


def test_walls_never_shared_by_the_two_directions_are_a_warning(
    four_lines: list[ScanLine],
) -> None:
    # Each direction sees its own walls (a boresight far off): three each, one ground
    # shared by all. The ground looks alike whatever the heading and is not counted.
    features: list[Feature] = [_ground(), *(_wall(a) for a in (0, 30, 60, 90, 120, 150))]
    who = [{0, 1, 2, 3}, {0, 2}, {0, 2}, {0, 2}, {1, 3}, {1, 3}, {1, 3}]
    text = unlinked_directions(four_lines, _seen(who), features)
    assert text is not None
    assert text.startswith("0 of 6 walls, roofs or spheres are seen alike")
    assert "line_01, line_03 (heading 20 deg) see 3 more" in text
    assert "line_02, line_04 (heading -160 deg) 3 more" in text
    assert "starting mount is likely grossly wrong" in text
    # A sphere counts like a wall.
    spheres: list[Feature] = [SphereFeature(np.zeros(3), 0.2, radius_known=True)] * 4
    assert unlinked_directions(four_lines, _seen([{0}, {2}, {1}, {3}]), spheres) is not None


def test_walls_shared_by_both_directions_or_one_direction_are_no_warning(
    four_lines: list[ScanLine],
) -> None:
    walls: list[Feature] = [_wall(a) for a in range(0, 180, 20)]  # nine walls
    # Four of nine seen alike (above the share), the rest by one direction each.
    linked = math.ceil(LINKED_SHARE * 9) + 1
    who = [{0, 1}] * linked + [{0, 2}, {1, 3}] * ((9 - linked) // 2) + [{0}] * ((9 - linked) % 2)
    assert unlinked_directions(four_lines, _seen(who), walls) is None
    # One direction alone sees walls the other never passes (fewer than two each way).
    assert unlinked_directions(four_lines, _seen([{0, 2}] * 5 + [{1, 3}]), walls[:6]) is None
    # Lines all driven one way: nothing to compare.
    same_way = [four_lines[0], four_lines[2]]
    assert unlinked_directions(same_way, _seen([{0}, {1}] * 3), walls[:6]) is None
    # Ground seen by one direction only is no evidence.
    grounds: list[Feature] = [_ground()] * 4
    assert unlinked_directions(four_lines, _seen([{0}, {2}, {1}, {3}]), grounds) is None


def test_the_yaw_search_finds_the_yaw_under_which_the_directions_share_walls(
    four_lines: list[ScanLine],
) -> None:
    walls: list[Feature] = [_wall(a) for a in range(0, 180, 20)]
    shared = _seen([{0, 1}] * 7 + [{0, 2}, {1, 3}])
    apart = _seen([{0, 2}] * 5 + [{1, 3}] * 4)
    asked: list[float] = []

    def find(values: np.ndarray) -> tuple[list[Feature], list[Observation]]:
        yaw = math.degrees(float(values[2]))
        asked.append(yaw)
        return walls, shared if abs(yaw - 30.0) < 3.0 else apart

    prior = np.zeros(7)
    prior[2] = math.radians(120.0)
    found = search_yaw(four_lines, prior, find)
    assert found is not None
    start, note = found
    assert math.degrees(start[2]) == pytest.approx(30.0)
    np.testing.assert_array_equal(np.delete(start, 2), np.delete(prior, 2))
    assert len(asked) == 72  # the prior and 71 turns of 5 deg
    assert "starting boresight yaw 120.0 deg" in note
    assert "(0 of 9 shared)" in note
    assert "found 30.0 deg (7 of 9 shared)" in note
    # A prior whose walls are shared is kept, without a search.
    prior[2] = math.radians(30.0)
    assert search_yaw(four_lines, prior, find) is None
    # No yaw shares them: nothing to start from.
    prior[2] = math.radians(120.0)
    assert search_yaw(four_lines, prior, lambda _: (walls, apart)) is None


def test_a_yaw_moved_by_the_search_alone_is_no_estimate(
    synthetic: Callable[..., Synthetic], monkeypatch: pytest.MonkeyPatch
) -> None:
    # Ground only, noisy returns: these lines give the yaw to +-1.96 deg, more than a
    # crew knows (1 deg), so it is held at its prior and printed as no number. When a
    # yaw search moved the start 15 deg from the prior, the solution's 15 deg from the
    # prior (the search's, not the adjustment's) passed for a move of the data beyond
    # 3 sigma, and the yaw was printed -2.01 +- 1.96 'weak' (on airborne strips 15.89 +-
    # 4.71 deg 'weak' for a true 1.1 deg).
    syn = synthetic(
        planes=("ground",), roll_amp_rad=0.05, repeats=2, speeds=(5.0,), n_per_plane=300,
        nav_errors=True, range_noise_m=0.06,
    )  # fmt: skip
    patches = PatchOptions(voxel_m=4.0, min_points_per_line=5, max_patch_m=20.0,
                           max_thickness_m=0.3)  # fmt: skip
    opt = CalibrationOptions(estimate=("boresight",), patches=patches)
    prior = replace(NOMINAL, boresight_rpy_deg=(0.0, 0.0, -15.0))

    def searched(*args: object) -> tuple[FloatArray, str]:
        start = np.array(args[1], dtype=np.float64)  # search_yaw(lines, prior, find, say)
        start[2] += math.radians(15.0)
        return start, "the calibration started there"

    monkeypatch.setattr(estimator, "search_yaw", searched)
    result = calibrate_mount(syn.lines, prior, opt)
    yaw = result.parameter("boresight_yaw_deg")
    assert yaw.status == "unobservable"
    assert yaw.value == -15.0
    assert math.isnan(yaw.std)
    assert any(
        r.startswith("boresight_yaw_deg is determined only to") for r in result.unobservable_reasons
    ), result.unobservable_reasons
    assert "the calibration started there" in result.warnings


def _far(line: ScanLine, range_m: float) -> ScanLine:
    """The line with its returns ``range_m`` below the scanner (an airborne strip)."""
    xyz = np.zeros_like(line.xyz_scanner_m)
    xyz[:, 2] = range_m
    return ScanLine(line.name, line.t_s, xyz, line.trajectory)


def test_walls_apart_at_airborne_range_are_not_searched_for(four_lines: list[ScanLine]) -> None:
    # At 1000 m, 0.1 deg of boresight moves a return by 1.7 m: a start within what a crew
    # knows leaves the walls of the two directions apart. On airborne strips started 0.1-0.2
    # deg off (26 of 81 roofs shared) the search moved the yaw 15 deg from a start 0.2 deg
    # off, and the warning blamed a boresight off by tens of degrees.
    walls: list[Feature] = [_wall(a) for a in range(0, 180, 20)]
    shared = _seen([{0, 1}] * 7 + [{0, 2}, {1, 3}])
    apart = _seen([{0, 2}] * 5 + [{1, 3}] * 4)
    asked: list[float] = []

    def find(values: np.ndarray) -> tuple[list[Feature], list[Observation]]:
        asked.append(math.degrees(float(values[2])))
        return walls, shared if abs(asked[-1] - 30.0) < 3.0 else apart

    prior = np.zeros(7)
    prior[2] = math.radians(120.0)
    strips = [_far(line, 1000.0) for line in four_lines]
    assert wall_range_m(strips, apart, walls) == pytest.approx(1000.0)
    assert search_yaw(strips, prior, find) is None
    assert asked == [pytest.approx(120.0)]  # the prior's walls only: no yaw searched
    text = unlinked_directions(strips, apart, walls)
    assert text is not None
    assert text.startswith("0 of 9 walls, roofs or spheres are seen alike")
    assert "At their median range, 1000 m, 0.1 deg of boresight moves a return by 1.7 m" in text
    assert "calibrate again with the calibrated mount as the start" in text
    assert "tens of degrees" not in text
    # Within the range where a crew's 1 deg pairs the walls, the search runs as before.
    near = [_far(line, 0.9 * MAX_WALL_RANGE_M) for line in four_lines]
    found = search_yaw(near, prior, find)
    assert found is not None
    assert math.degrees(found[0][2]) == pytest.approx(30.0)
    assert "tens of degrees" in str(unlinked_directions(near, apart, walls))


def test_cross_lines_run_neither_way(four_lines: list[ScanLine]) -> None:
    # An airborne patch test flies cross strips too. Lines 80 deg off the first counted as
    # run its way, so the walls only they share were counted as seen one way alone: 3 of
    # 11 shared made a warning (and a yaw search) where the two directions share 3 of 7.
    cross = [_line("cross_01", 1200.0, 100.0), _line("cross_02", 1230.0, 300.0)]
    lines: list[ScanLine] = [*four_lines, *cross]
    walls: list[Feature] = [_wall(a) for a in range(0, 176, 16)]
    who = [{0, 1}] * 3 + [{4, 5}] * 4 + [{0, 2}] * 2 + [{1, 3}] * 2
    assert unlinked_directions(lines, _seen(who), walls) is None
    # Their walls shared with a line of one direction count for that direction.
    who = [{0, 1}] * 3 + [{0, 4}] * 4 + [{0, 2}] * 2 + [{1, 3}] * 2
    text = unlinked_directions(lines, _seen(who), walls)
    assert text is not None
    assert text.startswith("3 of 11 walls")
    assert "line_01, line_03 (heading 20 deg) see 6 more" in text


@pytest.mark.parametrize("first", [0, 1, 2])
def test_the_directions_do_not_depend_on_the_lines_order(first: int) -> None:
    """A cross line given first (a glob that sorts cross.laz before strip1.laz) left the
    genuine opposite pair uncompared: headings 0, 88, 268 deg gave 'nothing to compare',
    88, 268, 0 gave the pair."""
    headings = np.radians(np.array([0.0, 88.0, 268.0]))
    order = np.roll(np.arange(3), -first)
    way = _directions(headings[order])
    assert way is not None
    got = dict(zip(order.tolist(), way.tolist(), strict=True))
    assert got[0] == 0  # the cross line
    assert {got[1], got[2]} == {1, -1}
    assert got[1] == 1  # the axis is 88 deg (268 mod 180): 88 runs its way
    # the most populated axis wins, in any order
    many = np.radians(np.array([90.0, 0.0, 180.0, 2.0, 178.0, 270.0]))
    for perm in ([0, 1, 2, 3, 4, 5], [5, 4, 3, 2, 1, 0], [2, 0, 4, 1, 5, 3]):
        w = _directions(many[perm])
        assert w is not None
        back = dict(zip(perm, w.tolist(), strict=True))
        assert [back[i] for i in range(6)] == [0, 1, -1, 1, -1, 0]
    assert _directions(np.radians(np.array([0.0, 90.0, 10.0]))) is None  # no opposite pair
