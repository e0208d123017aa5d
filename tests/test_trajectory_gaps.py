"""`Trajectory` never interpolates across a data gap: a time inside one is outside.

A record interval over `GAP_FACTOR` median intervals (or an explicit ``max_gap_s``) is
a gap (`kinsync.trajectory_gaps`); `Trajectory.contains` is False strictly inside it and
`Trajectory.interpolate` raises there naming the gap, or masks on request.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from kinsync.errors import InputError, OutsideSpanError
from kinsync.frames import wrap_angle_rad
from kinsync.trajectory import Trajectory
from kinsync.trajectory_gaps import (
    TrajectoryGap,
    gap_index,
    gap_threshold_shown_s,
    gap_threshold_text,
    max_gap_for,
)

T0 = 1.4e9
HOLE = (T0 + 30.0, T0 + 40.0)  # records removed strictly between these times


def _turning(hole: tuple[float, float] | None = HOLE) -> Trajectory:
    """100 Hz on a 20 m circle at 5 m/s, with a 10 s hole."""
    t = T0 + np.round(np.arange(0.0, 60.0, 0.01), 2)
    if hole is not None:
        t = t[~((t > hole[0]) & (t < hole[1]))]
    w = 5.0 / 20.0
    s = t - T0
    pos = np.column_stack([20.0 * np.sin(w * s), 20.0 * (1.0 - np.cos(w * s)), 0.0 * s])
    vel = np.column_stack([5.0 * np.cos(w * s), 5.0 * np.sin(w * s), 0.0 * s])
    yaw = wrap_angle_rad(w * s)
    return Trajectory.from_euler(
        t, 0.0 * s, 0.0 * s, yaw, pos_ned_m=pos, origin_lat_lon_h=(46.8, -71.2, 10.0),
        vel_ned_m_s=vel,
    )  # fmt: skip


def test_gap_index_finds_the_gap_strictly_around_each_time() -> None:
    gaps = (TrajectoryGap(1.0, 2.0), TrajectoryGap(5.0, 9.0))
    t = np.array([0.0, 1.0, 1.5, 2.0, 3.0, 5.0, 5.0001, 8.9999, 9.0, 10.0])
    np.testing.assert_array_equal(gap_index(t, gaps), [-1, -1, 0, -1, -1, -1, 1, 1, -1, -1])
    assert gap_index(np.array([[1.5, 6.0]]), gaps).shape == (1, 2)
    np.testing.assert_array_equal(gap_index(t, ()), -np.ones(t.size))


def test_an_infinite_threshold_finds_no_gap_and_nan_is_refused() -> None:
    t = _turning().t_s
    assert max_gap_for(t, math.inf) == math.inf
    assert _turning().gaps(math.inf) == ()
    for bad in (0.0, -1.0, math.nan):
        with pytest.raises(InputError, match="max-gap-s"):
            max_gap_for(t, bad)


def test_a_bad_threshold_from_python_names_the_argument() -> None:
    """GeorefTrajectory.from_trajectory(max_gap_s=-1) named only the option --max-gap-s."""
    from kinsync.georef import GeorefTrajectory  # noqa: PLC0415

    with pytest.raises(
        InputError,
        match=r"^max_gap_s \(--max-gap-s\), the longest trajectory record interval to "
        r"interpolate across, must be a positive number of seconds \(math\.inf: no gap\), "
        r"got -1$",
    ):
        GeorefTrajectory.from_trajectory(_turning(), max_gap_s=-1)


def test_contains_is_false_strictly_inside_a_gap() -> None:
    traj = _turning()
    (gap,) = traj.gaps()
    assert (gap.t_start_s, gap.t_end_s) == pytest.approx(HOLE)
    t = np.array([T0 + 10.0, HOLE[0], T0 + 35.0, HOLE[1], T0 + 59.0])
    np.testing.assert_array_equal(traj.contains(t), [True, True, False, True, True])
    assert traj.contains(t, max_gap_s=math.inf).all()  # the span alone
    assert traj.contains(t, max_gap_s=20.0).all()  # a threshold above the gap
    assert traj.contains(t, max_gap_s=5.0).tolist() == [True, True, False, True, True]


def test_interpolating_in_a_gap_is_an_error_naming_it() -> None:
    traj = _turning()
    t = np.array([T0 + 10.0, T0 + 33.0, T0 + 36.0])
    with pytest.raises(OutsideSpanError) as err:
        traj.interpolate(t)
    msg = str(err.value)
    assert f"t={T0 + 33.0!r} (index 1, 2 time(s) in all)" in msg
    assert "data gap" in msg
    assert traj.gaps()[0].describe() in msg
    assert "interpolate across" in msg
    # the threshold, to 1 us: 0.1 s, where 10 median intervals near 1.4e9 s are 0.0999999 s
    assert max_gap_for(traj.t_s) != 0.1
    assert "record intervals longer than 0.1 s (the gap threshold" in msg
    # a threshold the user set is named as theirs, not as the default it replaced
    given = r"longer than 5 s \(the gap threshold given with --max-gap-s\)"
    with pytest.raises(OutsideSpanError, match=given):
        traj.interpolate(t, max_gap_s=5.0)
    # outside the span: the span message, as before
    with pytest.raises(OutsideSpanError, match="outside the trajectory span"):
        traj.interpolate([T0 - 1.0])


def test_masked_times_in_a_gap_come_back_nan_and_never_a_guess() -> None:
    traj, full = _turning(), _turning(hole=None)
    t = T0 + np.array([10.0, 30.0, 33.0, 36.0, 40.0, 50.0])
    sample = traj.interpolate(t, mask_outside=True)
    assert sample.inside.tolist() == [True, True, False, False, True, True]
    assert sample.pos_ned_m is not None
    assert np.isnan(sample.pos_ned_m[~sample.inside]).all()
    assert np.isnan(sample.q_body_to_ned[~sample.inside]).all()
    truth = full.interpolate(t)
    assert truth.pos_ned_m is not None
    np.testing.assert_allclose(sample.pos_ned_m[sample.inside], truth.pos_ned_m[sample.inside])
    # What interpolating across the hole would have given: metres off the circle.
    across = traj.interpolate(t, max_gap_s=math.inf)
    assert across.pos_ned_m is not None
    miss_m = np.linalg.norm(across.pos_ned_m[2] - truth.pos_ned_m[2])
    assert miss_m > 1.0


def test_a_shifted_trajectory_keeps_its_gaps_on_the_new_time_scale() -> None:
    late = _turning().corrected_for_latency(0.004)
    (gap,) = late.gaps()
    assert gap.t_start_s == pytest.approx(HOLE[0] - 0.004)
    assert not late.contains(T0 + 35.0)


def test_a_regular_trajectory_has_no_gap() -> None:
    traj = _turning(hole=None)
    assert traj.gaps() == ()
    assert traj.contains(traj.t_s).all()


@pytest.mark.parametrize(("rate_hz", "shown"), [(100.0, "0.1"), (200.0, "0.05"), (10.0, "1")])
def test_the_default_threshold_is_shown_to_1_us(rate_hz: float, shown: str) -> None:
    """Ten median intervals of times near 1.4e9 s carry ten times their 0.24 us steps: the
    messages said "longer than 0.0999999 s" at 100 Hz, where trajectory info said 0.1."""
    t = 1.4e9 + np.arange(1000) / rate_hz
    limit = max_gap_for(t)
    text = gap_threshold_text(limit)
    assert f"record intervals longer than {shown} s (the gap threshold: --max-gap-s" in text
    assert f"{gap_threshold_shown_s(limit):g}" == shown
    # a threshold given is named as given; no threshold stays infinite
    assert "longer than 0.0999999 s (the gap threshold given" in gap_threshold_text(
        0.0999999, given=True
    )
    assert gap_threshold_shown_s(math.inf) == math.inf
