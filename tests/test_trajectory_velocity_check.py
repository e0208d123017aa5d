"""The velocity check of `kinsync.trajectory`: Hermite only with velocities that fit the positions.

Converted or synthesised trajectories often carry zero, scaled, swapped or unrotated
velocities; cubic Hermite through them bends every position between records. Honest
trajectories (simulated drives, the NaveGo reference, noisy navigation solutions) must
pass the check silently; broken ones fall back to linear with a warning (or, asked for
Hermite explicitly, are refused).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest

from kinsync.errors import InputError
from kinsync.georef import GeorefTrajectory, georeference, georeference_numpy
from kinsync.io.nav_csv import read_truth_csv
from kinsync.io.sbet import SBET_DTYPE, read_sbet, write_sbet
from kinsync.io.trajectory_csv import read_trajectory_csv, write_trajectory_csv
from kinsync.mount import Mount
from kinsync.sim._route import oval_route, survey_lines_route
from kinsync.sim.drive_truth import simulate_truth
from kinsync.sim.nav_noise import gauss_markov_trajectory, noisy_trajectory
from kinsync.trajectory import (
    VELOCITY_CHECK_ATOL_M,
    VELOCITY_CHECK_RTOL,
    Trajectory,
    VelocityCheck,
    VelocityConsistencyWarning,
    check_velocities,
)

FloatArray = npt.NDArray[np.float64]

NAVEGO_TRUTH = Path(__file__).resolve().parents[2] / "shared" / "data" / "navego-synthetic"
MOUNT = Mount(lever_arm_body_m=(0.3, -0.2, -1.2), boresight_rpy_deg=(0.4, -0.2, 89.0))


def _with_velocities(traj: Trajectory, vel: FloatArray | None) -> Trajectory:
    return Trajectory(
        t_s=traj.t_s,
        q_body_to_ned=traj.q_body_to_ned,
        lat_lon_h=traj.lat_lon_h,
        pos_ned_m=traj.pos_ned_m,
        origin_lat_lon_h=traj.origin_lat_lon_h,
        vel_ned_m_s=vel,
    )


@pytest.fixture(scope="module")
def drive() -> Trajectory:
    """A 200 Hz oval drive with roll, pitch and heave: honest velocities."""
    return simulate_truth(
        oval_route(speed_m_s=8.0, straight_m=60.0, radius_m=15.0, static_s=5.0),
        rate_hz=200.0,
        t_start_s=1.4e9,
        roll_amplitude_deg=3.0,
        pitch_amplitude_deg=2.0,
        undulation_amplitude_m=0.3,
        undulation_wavelength_m=20.0,
    )


def _vel(traj: Trajectory) -> FloatArray:
    assert traj.vel_ned_m_s is not None
    return np.asarray(traj.vel_ned_m_s)


def _silent_check(traj: Trajectory) -> VelocityCheck:
    """The check, asserting it passes and that interpolation uses Hermite without a warning."""
    check = traj.velocity_check
    assert check is not None
    assert check.consistent, check.as_document()
    assert check.message == ""
    t = traj.t_s[0] + traj.duration_s * np.linspace(0.0, 1.0, 101)
    with warnings.catch_warnings():
        warnings.simplefilter("error", VelocityConsistencyWarning)
        auto = traj.interpolate(t).pos_ecef_m()
    np.testing.assert_array_equal(auto, traj.interpolate(t, position="hermite").pos_ecef_m())
    return check


# ---------------------------------------------------------------- honest trajectories pass


def test_simulated_drive_passes_silently(drive: Trajectory) -> None:
    check = _silent_check(drive)
    assert check.velocity_scale == pytest.approx(1.0, abs=1e-6)
    assert check.window_s == pytest.approx(1.0, rel=1e-4)  # times near 1.4e9 s
    # Honest velocities miss the displacement by nanometres here, far inside the bound.
    assert check.rms_mismatch_horizontal_m < 1e-6
    assert check.rms_mismatch_vertical_m < 1e-6


@pytest.mark.parametrize("rate_hz", [1.0, 5.0, 50.0])
def test_survey_lines_at_low_rates_pass(rate_hz: float) -> None:
    """15 m/s with turns and a 1 m heave of 4 s period: the worst honest case measured."""
    traj = simulate_truth(
        survey_lines_route(speed_m_s=15.0, line_length_m=300.0, static_s=5.0),
        rate_hz=rate_hz,
        undulation_amplitude_m=1.0,
        undulation_wavelength_m=60.0,
    )
    check = _silent_check(traj)
    ratio_h = check.rms_mismatch_horizontal_m / check.rms_displacement_horizontal_m
    assert ratio_h < VELOCITY_CHECK_RTOL / 2  # margin: at least twice below the bound


def test_navigation_noise_passes(drive: Trajectory) -> None:
    _silent_check(noisy_trajectory(drive, seed=4))
    _silent_check(gauss_markov_trajectory(drive, std_m=0.05, corr_time_s=1.0, seed=5))


def test_standing_vehicle_with_position_noise_and_zero_velocities_passes() -> None:
    """Zero velocities are right for a standing vehicle, whatever the position noise."""
    rng = np.random.default_rng(8)
    n = 2000
    t = np.arange(n, dtype=np.float64) * 0.01
    pos = rng.normal(0.0, 0.01, (n, 3))  # 1 cm of white noise at 100 Hz: 1.4 m/s apparent
    traj = Trajectory(
        t_s=t,
        q_body_to_ned=np.tile([1.0, 0.0, 0.0, 0.0], (n, 1)),
        pos_ned_m=pos,
        origin_lat_lon_h=(46.8, -71.2, 10.0),
        vel_ned_m_s=np.zeros((n, 3)),
    )
    _silent_check(traj)


@pytest.mark.skipif(not NAVEGO_TRUTH.is_dir(), reason="NaveGo synthetic set not present")
def test_navego_reference_trajectory_passes() -> None:
    truth = read_truth_csv(NAVEGO_TRUTH / "truth.csv")
    check = _silent_check(truth)
    assert check.rms_mismatch_horizontal_m < 1e-3 * check.rms_displacement_horizontal_m
    zero = _with_velocities(truth, np.zeros((len(truth), 3))).velocity_check
    assert zero is not None
    assert not zero.consistent


def test_sbet_written_and_read_keeps_passing(drive: Trajectory, tmp_path: Path) -> None:
    path = tmp_path / "drive.out"
    write_sbet(drive, path, wander_angle_rad=math.radians(25.0))
    _silent_check(read_sbet(path))


# ---------------------------------------------------------------- broken velocities


def _zero(v: FloatArray) -> FloatArray:
    return np.zeros_like(v)


def _kmh_as_m_s(v: FloatArray) -> FloatArray:
    return v * 3.6


def _halved(v: FloatArray) -> FloatArray:
    return v * 0.5


def _swapped_north_east(v: FloatArray) -> FloatArray:
    return np.asarray(v[:, [1, 0, 2]])


def _up_for_down(v: FloatArray) -> FloatArray:
    return np.asarray(v * np.array([1.0, 1.0, -1.0]), dtype=np.float64)


BROKEN: dict[str, Callable[[FloatArray], FloatArray]] = {
    "zero": _zero,
    "km/h as m/s": _kmh_as_m_s,
    "halved": _halved,
    "north and east swapped": _swapped_north_east,
    "up for down": _up_for_down,
}


def _rewrite_sbet_velocities(
    path: Path, fix: Callable[[FloatArray], FloatArray], wander_rad: float
) -> None:
    """Break the stored velocities of an SBET (wander angle ``wander_rad``) in place."""
    rec = np.fromfile(path, dtype=SBET_DTYPE)
    c, s = math.cos(wander_rad), math.sin(wander_rad)
    x, y = rec["vel_x_wander_m_s"], rec["vel_y_wander_m_s"]
    ned = np.column_stack([x * c + y * s, -x * s + y * c, rec["vel_z_wander_m_s"]])
    bad = fix(ned)
    rec["vel_x_wander_m_s"] = bad[:, 0] * c - bad[:, 1] * s
    rec["vel_y_wander_m_s"] = bad[:, 0] * s + bad[:, 1] * c
    rec["vel_z_wander_m_s"] = bad[:, 2]
    rec.tofile(path)


@pytest.mark.parametrize("kind", list(BROKEN))
def test_broken_sbet_velocities_fall_back_to_linear_with_a_warning(
    drive: Trajectory, tmp_path: Path, kind: str
) -> None:
    path = tmp_path / "broken.out"
    wander = math.radians(-40.0)
    write_sbet(drive, path, wander_angle_rad=wander)
    _rewrite_sbet_velocities(path, BROKEN[kind], wander)
    traj = read_sbet(path)
    check = traj.velocity_check
    assert check is not None
    assert not check.consistent
    assert "positions are interpolated linearly" in check.message
    t = traj.t_start_s + np.linspace(0.0, traj.duration_s, 777)
    with pytest.warns(VelocityConsistencyWarning, match="disagree with the positions"):
        auto = traj.interpolate(t)
    linear = traj.interpolate(t, position="linear")
    assert auto.lat_lon_h is not None
    assert linear.lat_lon_h is not None
    np.testing.assert_array_equal(auto.lat_lon_h, linear.lat_lon_h)
    with pytest.raises(InputError, match="Hermite position interpolation refused"):
        traj.interpolate(t, position="hermite")


def test_broken_kinds_are_told_apart_by_the_scale(drive: Trajectory) -> None:
    vel = _vel(drive)
    expected = {"zero": 0.0, "km/h as m/s": 3.6, "halved": 0.5}
    for kind, scale in expected.items():
        check = _with_velocities(drive, BROKEN[kind](vel)).velocity_check
        assert check is not None
        assert check.velocity_scale == pytest.approx(scale, abs=1e-6)
    zero = _with_velocities(drive, np.zeros_like(vel)).velocity_check
    assert zero is not None
    assert "velocities are zero" in zero.message
    kmh = _with_velocities(drive, vel * 3.6).velocity_check
    assert kmh is not None
    assert "3.6 times the displacement" in kmh.message
    # Down sign flipped: only the vertical mismatch shows it (twice the vertical motion).
    flipped = _with_velocities(drive, _up_for_down(vel)).velocity_check
    assert flipped is not None
    assert flipped.rms_mismatch_horizontal_m < 1e-6
    assert flipped.rms_mismatch_vertical_m == pytest.approx(
        2.0 * flipped.rms_displacement_vertical_m, rel=1e-3
    )


def test_two_records_with_zero_velocities_give_the_linear_height() -> None:
    """The issue's case: Hermite through zero velocities put 0.28 m where linear says 1.0 m."""
    traj = Trajectory.from_euler(
        [100.0, 110.0],
        [0.0, 0.0],
        [0.0, 0.0],
        [0.0, 0.0],
        lat_lon_h=[[46.8, -71.2, 0.0], [46.8, -71.2, 10.0]],
        vel_ned_m_s=np.zeros((2, 3)),
    )
    s = 0.1  # t = 101 s
    assert (3 * s**2 - 2 * s**3) * 10.0 == pytest.approx(0.28)  # what Hermite gave
    with pytest.warns(VelocityConsistencyWarning, match="velocities are zero"):
        sample = traj.interpolate([101.0])
    assert sample.lat_lon_h is not None
    assert sample.lat_lon_h[0, 2] == pytest.approx(1.0, abs=1e-12)
    check = traj.velocity_check
    assert check is not None
    assert check.window_s == 10.0
    assert check.n_windows == 1
    assert check.rms_mismatch_vertical_m == pytest.approx(10.0)
    # The georeferencing kernel drops the velocities too: the point lands 1.0 m up.
    with pytest.warns(VelocityConsistencyWarning):
        gt = GeorefTrajectory.from_trajectory(traj)
    assert gt.vel_ecef_m_s is None
    assert gt.velocity_warning is not None
    out, inside = georeference([101.0], [[0.0, 0.0, 0.0]], gt, Mount())
    assert inside.all()
    ref = traj.interpolate([101.0], position="linear").pos_ecef_m()
    np.testing.assert_allclose(out, ref, rtol=0, atol=1e-6)


def test_csv_trajectory_with_zero_velocities_warns(drive: Trajectory, tmp_path: Path) -> None:
    path = tmp_path / "traj.csv"
    write_trajectory_csv(_with_velocities(drive, np.zeros((len(drive), 3))), path)
    traj = read_trajectory_csv(path)
    with pytest.warns(VelocityConsistencyWarning):
        traj.interpolate([traj.t_start_s + 1.234])


# ---------------------------------------------------------------- georeferencing


def test_georef_trajectory_drops_inconsistent_velocities(drive: Trajectory) -> None:
    broken = _with_velocities(drive, _swapped_north_east(_vel(drive)))
    with pytest.warns(VelocityConsistencyWarning, match="disagree"):
        gt = GeorefTrajectory.from_trajectory(broken, latency_s=0.004)
    assert gt.vel_ecef_m_s is None
    assert gt.trajectory.vel_ned_m_s is None
    assert gt.velocity_warning is not None
    assert "linearly" in gt.velocity_warning
    plain = GeorefTrajectory.from_trajectory(_with_velocities(drive, None), latency_s=0.004)
    rng = np.random.default_rng(2)
    t = np.sort(rng.uniform(drive.t_start_s + 1.0, drive.t_end_s - 1.0, 3000))
    xyz = rng.uniform(-10.0, 10.0, (t.size, 3))
    mount = Mount(latency_s=0.004)
    out, _ = georeference(t, xyz, gt, mount)
    want, _ = georeference(t, xyz, plain, mount)
    np.testing.assert_array_equal(out, want)
    ref, _ = georeference_numpy(t, xyz, gt, mount)
    assert np.abs(ref - out).max() < 1e-8
    with pytest.raises(InputError, match="velocities"):
        georeference(t, xyz, gt, mount, position="hermite")


def test_georef_trajectory_keeps_consistent_velocities_silently(drive: Trajectory) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error", VelocityConsistencyWarning)
        gt = GeorefTrajectory.from_trajectory(drive, latency_s=-0.003)
    assert gt.vel_ecef_m_s is not None
    assert gt.velocity_warning is None


@pytest.mark.parametrize("latency_s", [1e308, -1e308, 10.5, -86400.0])
def test_absurd_latency_is_named_not_blamed_on_the_times(
    drive: Trajectory, latency_s: float
) -> None:
    with pytest.raises(InputError, match="latency_s") as info:
        GeorefTrajectory.from_trajectory(drive, latency_s=latency_s)
    assert "repeated" not in str(info.value)
    assert "10 s" in str(info.value)


# ---------------------------------------------------------------- the check itself


def test_time_shift_keeps_the_check(drive: Trajectory) -> None:
    broken = _with_velocities(drive, np.zeros((len(drive), 3)))
    check = broken.velocity_check
    assert check is not None
    shifted = broken.corrected_for_latency(0.25)
    assert "velocity_check" in shifted.__dict__  # inherited, not recomputed
    moved = shifted.velocity_check
    assert moved is not None
    assert moved.worst_t_s == pytest.approx(check.worst_t_s - 0.25)
    assert moved.consistent == check.consistent
    assert moved.rms_mismatch_horizontal_m == check.rms_mismatch_horizontal_m


def test_no_velocities_means_no_check(drive: Trajectory) -> None:
    traj = _with_velocities(drive, None)
    assert traj.velocity_check is None
    with pytest.raises(InputError, match="needs velocities"):
        traj.interpolate([drive.t_start_s], position="hermite")


def test_bounds_are_the_documented_ones() -> None:
    """A steady mismatch just inside and just outside rtol·displacement + atol."""
    n = 201
    t = np.arange(n) * 0.01  # 100 Hz: windows of 100 intervals
    speed = 2.0
    pos = np.column_stack([speed * t, np.zeros(n), np.zeros(n)])
    for factor, consistent in ((0.99, True), (1.01, False)):
        allowed = VELOCITY_CHECK_RTOL * speed + VELOCITY_CHECK_ATOL_M  # per 1 s window
        vel = np.column_stack([np.full(n, speed + factor * allowed), np.zeros(n), np.zeros(n)])
        check = check_velocities(t, np.diff(pos, axis=0), vel)
        assert check.consistent is consistent
        assert check.n_windows == 2
        assert check.rms_mismatch_horizontal_m == pytest.approx(factor * allowed)


def test_gaps_are_left_out() -> None:
    """A 60 s gap in a 100 Hz record: its interval cannot be held against the velocities."""
    t = np.concatenate([np.arange(0.0, 10.0, 0.01), 70.0 + np.arange(0.0, 10.0, 0.01)])
    pos = np.column_stack([3.0 * t, np.zeros_like(t), np.zeros_like(t)])
    pos[t >= 70.0, 0] += 500.0  # the vehicle went elsewhere during the gap
    vel = np.column_stack([np.full(t.size, 3.0), np.zeros(t.size), np.zeros(t.size)])
    check = check_velocities(t, np.diff(pos, axis=0), vel)
    assert check.consistent
    assert check.rms_mismatch_horizontal_m < 1e-9


def test_overflowing_values_are_reported_inconsistent() -> None:
    t = np.array([0.0, 1.0, 2.0])
    dp = np.array([[1e308, 0.0, 0.0], [-1e308, 0.0, 0.0]])
    vel = np.array([[1e308, 0.0, 0.0], [-1e308, 0.0, 0.0], [1e308, 0.0, 0.0]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no numpy RuntimeWarning escapes
        check = check_velocities(t, dp, vel)
    assert not check.consistent
    assert "could not be checked" in check.message
    doc = check.as_document()
    assert doc["consistent"] is False
    assert doc["message"] == check.message


def test_shapes_are_checked() -> None:
    with pytest.raises(InputError, match="check_velocities"):
        check_velocities([0.0, 1.0], np.zeros((2, 3)), np.zeros((2, 3)))
    with pytest.raises(InputError, match="check_velocities"):
        check_velocities([0.0], np.zeros((0, 3)), np.zeros((1, 3)))


def test_document_has_every_field(drive: Trajectory) -> None:
    check = drive.velocity_check
    assert check is not None
    doc = check.as_document()
    assert set(doc) == {
        "consistent",
        "window_s",
        "n_windows",
        "rms_displacement_horizontal_m",
        "rms_displacement_vertical_m",
        "rms_mismatch_horizontal_m",
        "rms_mismatch_vertical_m",
        "velocity_scale",
        "worst_t_s",
        "message",
    }
    assert doc["consistent"] is True
    assert doc["message"] == ""


@pytest.mark.parametrize(
    ("fix", "words"),
    [
        (lambda v: v[:, [1, 0, 2]], "with north and east swapped ("),
        (lambda v: v * np.array([1.0, -1.0, 1.0]), "with the sign of east flipped"),
        (lambda v: v * np.array([-1.0, -1.0, 1.0]), "with the signs of north and east flipped"),
        (lambda v: v * np.array([1.0, 1.0, -1.0]), "with the sign of down flipped"),
        (
            lambda v: v[:, [1, 0, 2]] * np.array([1.0, 1.0, -1.0]),
            "east, north, up (ENU) velocities in the north, east, down columns",
        ),
    ],
)
def test_swapped_or_flipped_components_are_named(
    drive: Trajectory, fix: Callable[[FloatArray], FloatArray], words: str
) -> None:
    """North and east swapped were called "the velocities are zero (or nearly)"."""
    check = _with_velocities(drive, np.asarray(fix(_vel(drive)))).velocity_check
    assert check is not None
    assert not check.consistent
    assert words in check.message
    assert "are zero" not in check.message


@pytest.mark.parametrize("kind", ["zero", "km/h as m/s", "halved"])
def test_no_mix_up_is_named_for_wrong_magnitudes(drive: Trajectory, kind: str) -> None:
    check = _with_velocities(drive, BROKEN[kind](_vel(drive))).velocity_check
    assert check is not None
    assert check.mix_up is None
    assert "they match the positions" not in check.message
