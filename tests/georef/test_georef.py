"""Direct georeferencing kernel: analytic truth, numpy reference, latency, masks, errors."""

from __future__ import annotations

import math
import pickle
from collections.abc import Callable
from dataclasses import replace
from typing import cast

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from kinsync.budget import beach_scenario, latency_beam_error
from kinsync.errors import InputError, PointValueError
from kinsync.frames import (
    ecef_to_ned,
    euler_rpy_to_matrix,
    geodetic_to_ecef,
    matrix_to_quaternion,
    quaternion_to_matrix,
    rotation_ned_to_ecef,
)
from kinsync.georef import (
    GeorefTrajectory,
    PositionMethod,
    georeference,
    georeference_numpy,
    georeference_profile,
    profile_points_to_scanner,
)
from kinsync.georef.trajectory import GeorefRecords, _interval_rotvec
from kinsync.mount import Mount
from kinsync.sim.turning_scan import TurningVehicle
from kinsync.trajectory import Trajectory

ORIGIN = (46.8, -71.2, 10.0)
RATE_HZ = 100.0
SPEED_M_S = 20.0
TURN_RATE_RAD_S = 0.1  # radius 200 m
ECEF_ULPS = 5e-9  # m: five units in the last place of an ECEF coordinate near 4.6e6 m
MOUNT = Mount(lever_arm_body_m=(0.8, -0.3, -1.2), boresight_rpy_deg=(0.4, -0.7, 91.0))


VEHICLE = TurningVehicle(
    origin_lat_lon_h=ORIGIN, speed_m_s=SPEED_M_S, turn_rate_rad_s=TURN_RATE_RAD_S
)


def _tangent_state(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return VEHICLE.tangent_state(t)


def _analytic_trajectory(duration_s: float = 20.0) -> Trajectory:
    return VEHICLE.trajectory(duration_s, RATE_HZ)


def _truth_ecef(t_rel: np.ndarray, xyz_scanner: np.ndarray, mount: Mount) -> np.ndarray:
    return VEHICLE.truth_ecef_m(t_rel, xyz_scanner, mount)


def _scan(n: int, rng: np.random.Generator, t_end: float = 20.0) -> tuple[np.ndarray, np.ndarray]:
    return TurningVehicle.scan(n, rng, t_end)


@pytest.fixture(scope="module")
def traj() -> Trajectory:
    return _analytic_trajectory()


def test_hermite_within_a_tenth_of_a_millimetre_of_analytic_truth(traj: Trajectory) -> None:
    rng = np.random.default_rng(5)
    t_rel, xyz = _scan(20_000, rng)
    gt = GeorefTrajectory.from_trajectory(traj)
    out, inside = georeference(t_rel + 1.0e9, xyz, gt, MOUNT)
    assert inside.all()
    err = np.linalg.norm(out - _truth_ecef(t_rel, xyz, MOUNT), axis=1)
    assert err.max() < 1e-4
    # Linear position is visibly worse on the turn (chord sag ~ v^2 dt^2 / 8 r).
    lin, _ = georeference(t_rel + 1.0e9, xyz, gt, MOUNT, position="linear")
    err_lin = np.linalg.norm(lin - _truth_ecef(t_rel, xyz, MOUNT), axis=1)
    assert err_lin.max() > err.max()
    assert err_lin.max() < 1e-3


@pytest.mark.parametrize("position", ["linear", "hermite"])
def test_kernel_matches_numpy_reference(traj: Trajectory, position: PositionMethod) -> None:
    rng = np.random.default_rng(6)
    t_rel, xyz = _scan(5_000, rng)
    gt = GeorefTrajectory.from_trajectory(traj)
    fast, in_fast = georeference(t_rel + 1.0e9, xyz, gt, MOUNT, position=position)
    ref, in_ref = georeference_numpy(t_rel + 1.0e9, xyz, gt, MOUNT, position=position)
    np.testing.assert_array_equal(in_fast, in_ref)
    # One ulp of an ECEF coordinate (~4.6e6 m) is 9.3e-10 m; the reference interpolates in
    # geodetic coordinates and converts through pyproj, so agreement is a few ulp.
    assert np.abs(fast - ref).max() < ECEF_ULPS


def test_local_ned_trajectory_matches_numpy_reference() -> None:
    t = np.arange(0.0, 10.0, 0.01)
    pos, vel, R_bt = _tangent_state(t)
    local = Trajectory(
        t_s=t,
        q_body_to_ned=matrix_to_quaternion(R_bt),
        pos_ned_m=pos,
        origin_lat_lon_h=ORIGIN,
        vel_ned_m_s=vel,
    )
    t_rel, xyz = _scan(2_000, np.random.default_rng(7), t_end=10.0)
    gt = GeorefTrajectory.from_trajectory(local)
    fast, _ = georeference(t_rel, xyz, gt, MOUNT)
    ref, _ = georeference_numpy(t_rel, xyz, gt, MOUNT)
    assert np.abs(fast - ref).max() < ECEF_ULPS
    assert np.linalg.norm(fast - _truth_ecef(t_rel, xyz, MOUNT), axis=1).max() < 1e-4


def test_slerp_of_composed_quaternion_equals_composed_interpolation(traj: Trajectory) -> None:
    """Slerping q_body_to_ecef vs R_ned_to_ecef(interpolated lat, lon) · slerp(q_body_to_ned)."""
    gt = GeorefTrajectory.from_trajectory(traj)
    t_mid = 0.5 * (gt.t_s[:-1] + gt.t_s[1:])
    t_q = np.concatenate([t_mid, gt.t_s[:-1] + 0.37 * np.diff(gt.t_s)])
    # Trajectory's slerp applied to the ECEF quaternions (positions are placeholders).
    as_ecef = Trajectory(
        t_s=gt.t_s,
        q_body_to_ned=gt.q_body_to_ecef,
        pos_ned_m=np.zeros((len(gt), 3)),
        origin_lat_lon_h=ORIGIN,
    )
    R_composed_slerp = quaternion_to_matrix(as_ecef.interpolate(t_q).q_body_to_ned)
    sample = traj.interpolate(t_q)
    assert sample.lat_lon_h is not None
    R_ne = rotation_ned_to_ecef(sample.lat_lon_h[:, 0], sample.lat_lon_h[:, 1])
    R_separate = np.einsum("nij,njk->nik", R_ne, sample.R_body_to_ned)
    dR = np.einsum("nji,njk->nik", R_separate, R_composed_slerp)
    angle = np.arccos(np.clip((np.trace(dR, axis1=1, axis2=2) - 1.0) / 2.0, -1.0, 1.0))
    # arccos is ill-conditioned near 0; use the skew part for the small angle.
    skew = 0.5 * np.stack(
        [dR[:, 2, 1] - dR[:, 1, 2], dR[:, 0, 2] - dR[:, 2, 0], dR[:, 1, 0] - dR[:, 0, 1]], axis=1
    )
    small = np.linalg.norm(skew, axis=1)
    assert np.all(angle < 1e-6)
    assert small.max() < 1e-9  # rad
    # The NED frame turns by v·dt/R_earth per record, ~3e-8 rad here: the effect is second order.
    assert 10 * small.max() < SPEED_M_S * 0.01 / 6.37e6


def test_latency_error_matches_budget_prediction() -> None:
    """A 2 ms latency error under a 10 deg/s roll: point error vs budget.latency_beam_error."""
    rate = math.radians(10.0)
    scenario = beach_scenario(range_m=50.0, slope_deg=10.0, rate_deg_s=10.0)
    tau = 0.002
    t0 = 1000.0
    t = np.arange(t0 - 1.0, t0 + 1.0 + 1e-9, 0.01)
    zeros = np.zeros_like(t)
    llh = np.tile(ORIGIN, (t.size, 1))
    records = Trajectory.from_euler(
        t, rate * (t - t0), zeros, zeros, lat_lon_h=llh, vel_ned_m_s=np.zeros((t.size, 3))
    )  # true records: no latency; heading North, rolling about North
    t_point = t0 - tau  # georeferenced with the record tagged t0: roll 0, beam due East
    eps = rate * (t_point - t0)  # true roll at the point time
    d_true = euler_rpy_to_matrix(eps, 0.0, 0.0) @ np.array([0.0, 1.0, 0.0])
    n = np.asarray(scenario.normal_ned)
    p0 = scenario.range_m * np.asarray(scenario.beam_ned)
    r_true = float(n @ p0) / float(n @ d_true)
    hit_true_ned = r_true * d_true
    mount = Mount(latency_s=tau)  # the deliberate latency error
    gt = GeorefTrajectory.from_trajectory(records, latency_s=tau)
    out, inside = georeference([t_point], [[0.0, r_true, 0.0]], gt, mount)
    assert inside.all()
    placed_ned = ecef_to_ned(out, *ORIGIN)[0]
    err = float(np.linalg.norm(placed_ned - hit_true_ned))
    predicted = latency_beam_error(scenario, tau).point_error_m
    assert err > 1e-3  # a real, visible error (~ 8 cm here)
    assert err == pytest.approx(predicted, rel=0.03)
    # With the right latency (0) the same point lands on the true hit.
    gt0 = GeorefTrajectory.from_trajectory(records)
    good, _ = georeference([t_point], [[0.0, r_true, 0.0]], gt0, Mount())
    assert np.linalg.norm(ecef_to_ned(good, *ORIGIN)[0] - hit_true_ned) < 1e-6


def test_latency_reads_record_tagged_t_plus_tau(traj: Trajectory) -> None:
    gt = GeorefTrajectory.from_trajectory(traj, latency_s=0.05)
    rec = 700
    out, _ = georeference([traj.t_s[rec] - 0.05], [[0.0, 0.0, 0.0]], gt, Mount(latency_s=0.05))
    assert np.abs(out[0] - gt.pos_ecef_m[rec]).max() < ECEF_ULPS
    assert traj.lat_lon_h is not None
    expected = geodetic_to_ecef(*traj.lat_lon_h[rec])
    assert np.abs(gt.pos_ecef_m[rec] - expected).max() < ECEF_ULPS


def test_outside_span_is_masked_nan_not_extrapolated(traj: Trajectory) -> None:
    gt = GeorefTrajectory.from_trajectory(traj)
    t = np.array([gt.t_start_s - 1e-3, gt.t_start_s, 1.0e9 + 5.0, gt.t_end_s, gt.t_end_s + 1.0])
    xyz = np.ones((5, 3))
    for fn in (georeference, georeference_numpy):
        out, inside = fn(t, xyz, gt, MOUNT)
        np.testing.assert_array_equal(inside, [False, True, True, True, False])
        assert np.isnan(out[~inside]).all()
        assert np.isfinite(out[inside]).all()
    fast, _ = georeference(t, xyz, gt, MOUNT)
    ref, _ = georeference_numpy(t, xyz, gt, MOUNT)
    assert np.abs(fast[1:4] - ref[1:4]).max() < ECEF_ULPS


def test_read_only_and_writable_points_reach_one_compiled_kernel(
    traj: Trajectory, monkeypatch: pytest.MonkeyPatch
) -> None:
    # numba compiles read-only and writable arrays apart: a second copy of the kernel
    # (about 1 s of a first run) when a caller passes frozen arrays, as calibrate mount does.
    from numba import typeof  # noqa: PLC0415

    from kinsync.georef import kernel  # noqa: PLC0415

    seen: list[tuple[str, ...]] = []
    compiled = kernel._georef_kernel

    def spy(*args: object) -> int:
        seen.append(tuple(str(typeof(a)) for a in args))  # type: ignore[no-untyped-call]
        return compiled(*args)

    monkeypatch.setattr(kernel, "_georef_kernel", spy)
    t_rel, xyz = _scan(100, np.random.default_rng(3))
    gt = GeorefTrajectory.from_trajectory(traj)
    writable, _ = georeference(t_rel + 1.0e9, xyz, gt, MOUNT)
    t_frozen, xyz_frozen = t_rel + 1.0e9, xyz.copy()
    t_frozen.flags.writeable = xyz_frozen.flags.writeable = False
    frozen, _ = georeference(t_frozen, xyz_frozen, gt, MOUNT)
    # A process-pool worker gets the trajectory and mount unpickled: read-only again
    # (kinsync._arrays.ReadOnlyArrays). Writable trajectory arrays (numpy unpickles
    # arrays writable) reach the same kernel too, not a second compile (~4 s).
    gt_worker, mount_worker = pickle.loads(pickle.dumps((gt, MOUNT)))
    assert not gt_worker.t_s.flags.writeable
    names = ("t_s", "pos_ecef_m", "q_body_to_ecef", "rotvec_interval_body")
    gt_writable = replace(gt_worker, **{n: np.array(getattr(gt, n)) for n in names})
    assert gt_writable.t_s.flags.writeable
    in_worker, _ = georeference(t_rel + 1.0e9, xyz, gt_writable, mount_worker)
    np.testing.assert_array_equal(frozen, writable)
    np.testing.assert_array_equal(in_worker, writable)
    assert seen[0] == seen[1] == seen[2]


def test_unsorted_times_give_the_same_points(traj: Trajectory) -> None:
    rng = np.random.default_rng(8)
    t_rel, xyz = _scan(3_000, rng)
    gt = GeorefTrajectory.from_trajectory(traj)
    sorted_out, _ = georeference(t_rel + 1.0e9, xyz, gt, MOUNT)
    perm = rng.permutation(t_rel.size)
    shuffled, inside = georeference(t_rel[perm] + 1.0e9, xyz[perm], gt, MOUNT)
    assert inside.all()
    np.testing.assert_array_equal(shuffled, sorted_out[perm])
    # Backwards in time and with repeats of record times.
    t_back = np.concatenate([gt.t_s[::-1], gt.t_s[::7]])
    back, _ = georeference(t_back, np.zeros((t_back.size, 3)), gt, MOUNT)
    ref, _ = georeference_numpy(t_back, np.zeros((t_back.size, 3)), gt, MOUNT)
    assert np.abs(back - ref).max() < ECEF_ULPS


AT_1 = r"point at index 1 \(0-based, of 2\)"  # the API names array indices, said so


@pytest.mark.parametrize(
    ("t", "xyz", "match"),
    [
        ([1.0e9 + 1.0, np.nan], [[0, 0, 0], [0, 0, 0]], rf"{AT_1}, t: point time nan is not"),
        ([1.0e9 + 1.0, 1.0e9 + 2.0], [[0, 0, 0], [0, np.inf, 0]], rf"{AT_1}, y: inf is not finite"),
        ([1.0e9 + 1.0], [[0, 0]], "shape"),
        ([[1.0e9]], [[0, 0, 0]], "1-D"),
        # float32 holds 64 s steps near 1e9 s: georeference said inside, 67 to 311 m off
        (
            np.array([1.0e9 + 1.0, 1.0e9 + 2.0], dtype=np.float32),
            [[0, 0, 0], [0, 0, 0]],
            r"point times t_s: float32 times near 1e\+09 s are held in steps of 64 s.*float64",
        ),
        (
            np.array(["2024-01-01", "2024-01-02"], dtype="datetime64[ns]"),
            [[0, 0, 0], [0, 0, 0]],
            r"point times t_s: expected seconds, got datetime64\[ns\].*GPS seconds",
        ),
    ],
)
def test_bad_points_raise_input_error(traj: Trajectory, t: object, xyz: object, match: str) -> None:
    gt = GeorefTrajectory.from_trajectory(traj)
    for fn in (georeference, georeference_numpy):
        with pytest.raises(InputError, match=match):
            fn(t, xyz, gt, MOUNT)  # type: ignore[arg-type]


def test_a_bad_point_error_carries_its_index_for_pipelines(traj: Trajectory) -> None:
    """Pipelines name the point as the file counts it from the error's attributes."""
    gt = GeorefTrajectory.from_trajectory(traj)
    xyz = np.array([[0, 0, 0], [0, 0, np.nan], [np.nan, 0, 0]])
    with pytest.raises(PointValueError) as err:
        georeference([1.0e9 + 1.0, 1.0e9 + 2.0, 1.0e9 + 3.0], xyz, gt, MOUNT)
    assert (err.value.index, err.value.count, err.value.field) == (1, 2, "z")
    assert err.value.problem == "nan is not finite (scanner coordinates [0.0, 0.0, nan])"


def test_option_errors(traj: Trajectory) -> None:
    gt = GeorefTrajectory.from_trajectory(traj)
    with pytest.raises(InputError, match="latency"):
        georeference([1.0e9 + 1], [[0, 0, 0]], gt, Mount(latency_s=0.01))
    with pytest.raises(InputError, match="auto, linear or hermite"):
        georeference([1.0e9 + 1], [[0, 0, 0]], gt, MOUNT, position="cubic")  # type: ignore[arg-type]
    no_vel = Trajectory(t_s=traj.t_s, q_body_to_ned=traj.q_body_to_ned, lat_lon_h=traj.lat_lon_h)
    gt_nv = GeorefTrajectory.from_trajectory(no_vel)
    assert gt_nv.vel_ecef_m_s is None
    with pytest.raises(InputError, match="velocities"):
        georeference([1.0e9 + 1], [[0, 0, 0]], gt_nv, MOUNT, position="hermite")
    out, _ = georeference([1.0e9 + 1], [[0, 0, 0]], gt_nv, MOUNT)  # auto -> linear
    assert np.isfinite(out).all()
    with pytest.raises(InputError, match="finite"):
        GeorefTrajectory.from_trajectory(traj, latency_s=math.nan)


@pytest.mark.parametrize("func", [georeference, georeference_numpy])
def test_a_plain_trajectory_or_mount_is_refused_naming_the_argument(
    traj: Trajectory, func: object
) -> None:
    georef = cast("Callable[..., object]", func)
    with pytest.raises(InputError, match=r"traj: .*GeorefTrajectory\.from_trajectory"):
        georef([1.0e9 + 1], [[0, 0, 0]], traj, MOUNT)
    gt = GeorefTrajectory.from_trajectory(traj)
    with pytest.raises(InputError, match=r"mount: expected a kinsync\.Mount, got dict"):
        georef([1.0e9 + 1], [[0, 0, 0]], gt, {"latency_s": 0.0})


@pytest.mark.parametrize("latency", [np.array([0.004]), "0.004", None, True])
def test_a_latency_that_is_not_one_number_is_refused(traj: Trajectory, latency: object) -> None:
    with pytest.raises(InputError, match="latency_s: expected a number"):
        GeorefTrajectory.from_trajectory(traj, latency_s=latency)  # type: ignore[arg-type]
    with pytest.raises(InputError, match="latency_s: expected a number"):
        GeorefRecords.from_trajectory(traj, latency_s=latency)  # type: ignore[arg-type]


def test_empty_input(traj: Trajectory) -> None:
    gt = GeorefTrajectory.from_trajectory(traj)
    out, inside = georeference(np.empty(0), np.empty((0, 3)), gt, MOUNT)
    assert out.shape == (0, 3)
    assert inside.shape == (0,)


def _profile_scan(
    n: int, rng: np.random.Generator, t_end: float = 20.0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Relative times, ranges (m) and mirror angles (rad) of a 2D profile scan."""
    t_rel = np.sort(rng.uniform(0.05, t_end - 0.05, n))
    return t_rel, rng.uniform(3.0, 30.0, n), rng.uniform(-np.pi, np.pi, n)


def _profile_truth_scanner(range_m: np.ndarray, angle_rad: np.ndarray, az_deg: float) -> np.ndarray:
    """Rz(azimuth) (0, r sin phi, r cos phi), built from a rotation matrix (SPEC section 4)."""
    profile_plane = np.column_stack(
        [np.zeros_like(range_m), range_m * np.sin(angle_rad), range_m * np.cos(angle_rad)]
    )
    Rz = euler_rpy_to_matrix(0.0, 0.0, math.radians(az_deg))
    out: np.ndarray = profile_plane @ Rz.T
    return out


@pytest.mark.parametrize("azimuth_deg", [0.0, 17.5, -90.0])
def test_profile_points_within_a_tenth_of_a_millimetre_of_analytic_truth(
    traj: Trajectory, azimuth_deg: float
) -> None:
    rng = np.random.default_rng(21)
    t_rel, r, phi = _profile_scan(20_000, rng)
    mount = Mount(
        lever_arm_body_m=MOUNT.lever_arm_body_m,
        boresight_rpy_deg=MOUNT.boresight_rpy_deg,
        profiler_azimuth_deg=azimuth_deg,
    )
    gt = GeorefTrajectory.from_trajectory(traj)
    out, inside = georeference_profile(
        t_rel + 1.0e9, range_m=r, angle_rad=phi, traj=gt, mount=mount
    )
    assert inside.all()
    truth = _truth_ecef(t_rel, _profile_truth_scanner(r, phi, azimuth_deg), mount)
    assert np.linalg.norm(out - truth, axis=1).max() < 1e-4
    # A wrong azimuth moves points by ~ r * angle: the test sees the azimuth.
    wrong = replace(mount, profiler_azimuth_deg=azimuth_deg + 0.01)
    moved, _ = georeference_profile(t_rel + 1.0e9, range_m=r, angle_rad=phi, traj=gt, mount=wrong)
    assert np.linalg.norm(moved - truth, axis=1).max() > 1e-3


@pytest.mark.parametrize(
    ("r", "phi", "mount", "match"),
    [
        ([1.0, 2.0], [0.0, 0.1], Mount(), r"\[profiler\] azimuth_deg"),
        ([1.0, np.nan], [0.0, 0.1], Mount(profiler_azimuth_deg=0.0), rf"{AT_1}, range_m: nan is"),
        (
            [1.0, 2.0],
            [np.inf, 0.1],
            Mount(profiler_azimuth_deg=0.0),
            r"0 \(0-based.*angle_rad: inf",
        ),
        (
            [1.0, -2.0],
            [0.0, 0.1],
            Mount(profiler_azimuth_deg=0.0),
            rf"{AT_1}, range_m: range -2\.0 is",
        ),
        (  # 1e308 rad (or 45 meaning degrees) was taken as an angle
            [1.0, 2.0],
            [0.0, 1e308],
            Mount(profiler_azimuth_deg=0.0),
            rf"{AT_1}, angle_rad: angle 1e\+308 rad is beyond one turn",
        ),
        (
            [1.0, 2.0],
            [0.0, -45.0],
            Mount(profiler_azimuth_deg=0.0),
            rf"{AT_1}, angle_rad: angle -45\.0 rad is beyond one turn.*radians within one turn",
        ),
        ([1.0, 2.0], [0.0], Mount(profiler_azimuth_deg=0.0), "one length"),
        ([[1.0]], [[0.0]], Mount(profiler_azimuth_deg=0.0), "1-D"),
        (["a", "b"], [0.0, 0.1], Mount(profiler_azimuth_deg=0.0), "must be numbers"),
    ],
)
def test_bad_profile_points_raise_input_error(
    r: object, phi: object, mount: Mount, match: str
) -> None:
    with pytest.raises(InputError, match=match):
        profile_points_to_scanner(range_m=r, angle_rad=phi, mount=mount)  # type: ignore[arg-type]


def test_profile_angles_up_to_one_turn_either_way_are_taken() -> None:
    mount = Mount(profiler_azimuth_deg=0.0)
    phi = np.array([-2.0 * np.pi, -np.pi, 0.0, 3.0 * np.pi / 2.0, 2.0 * np.pi])
    xyz = profile_points_to_scanner(range_m=np.ones(5), angle_rad=phi, mount=mount)
    np.testing.assert_allclose(xyz, mount.profile_to_scanner(angle_rad=phi, range_m=np.ones(5)))


def test_profile_ranges_and_angles_are_keyword_only(traj: Trajectory) -> None:
    """Mount.profile_to_scanner took (angle, range) and the georef functions (range,
    angle): swapped positionally, ranges under 2 pi m gave wrong points silently."""
    mount = Mount(profiler_azimuth_deg=0.0)
    gt = GeorefTrajectory.from_trajectory(traj)
    angle, r = np.array([0.1, 0.2]), np.array([1.5, 1.6])
    calls = (
        lambda: mount.profile_to_scanner(angle, r),  # type: ignore[call-arg]
        lambda: profile_points_to_scanner(r, angle, mount),  # type: ignore[call-arg]
        lambda: georeference_profile(gt.t_s[:2], r, angle, gt, mount),  # type: ignore[call-arg]
    )
    for call in calls:
        with pytest.raises(TypeError, match="positional argument"):
            call()
    by_name = profile_points_to_scanner(angle_rad=angle, range_m=r, mount=mount)
    np.testing.assert_allclose(
        by_name[:, 1:], np.column_stack([r * np.sin(angle), r * np.cos(angle)])
    )
    np.testing.assert_array_equal(by_name, mount.profile_to_scanner(range_m=r, angle_rad=angle))


def test_interval_rotation_vectors_equal_scipy() -> None:
    """The slerp increments (numpy) equal scipy's relative rotations, from tiny to
    near-pi angles, whatever the sign of each quaternion."""
    rng = np.random.default_rng(11)
    n = 400
    rotvecs = rng.normal(size=(n, 3)) * 10.0 ** rng.uniform(-12, 0, (n, 1))
    half_turns = np.tile([0.0, 0.0, np.pi - 1e-9], (10, 1))
    step = Rotation.from_rotvec(np.vstack([rotvecs, half_turns]))
    left = Rotation.random(n + 10, random_state=rng)
    pairs = np.empty((2 * len(left), 4))
    pairs[0::2] = left.as_quat()[:, [3, 0, 1, 2]]
    pairs[1::2] = (left * step).as_quat()[:, [3, 0, 1, 2]]
    pairs *= np.where(rng.random(len(pairs)) < 0.5, -1.0, 1.0)[:, None]  # either sign
    got = _interval_rotvec(pairs)[0::2]
    want = step.as_rotvec()
    residual = (Rotation.from_rotvec(got) * step.inv()).magnitude()
    np.testing.assert_allclose(residual, 0.0, atol=1e-14)
    np.testing.assert_array_less(np.linalg.norm(got, axis=1), np.pi + 1e-12)
    not_half_turn = np.linalg.norm(want, axis=1) < 3.0  # at pi the axis sign is arbitrary
    np.testing.assert_allclose(got[not_half_turn], want[not_half_turn], rtol=0, atol=1e-15)
