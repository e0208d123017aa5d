"""Rotating-table simulator: determinism, point counts, geometry and the latency sign."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from kinsync._typing import FloatArray
from kinsync.errors import InputError
from kinsync.frames import euler_rpy_to_matrix
from kinsync.io.mount_file import read_mount
from kinsync.io.passes import read_passes
from kinsync.latency.sphere import MIN_SPHERE_POINTS_PER_PASS, estimate_latency_sphere
from kinsync.pipelines.raw_passes import read_raw_passes
from kinsync.sim.rotating_table import (
    MAX_TABLE_PROFILES,
    RotatingTableSimulation,
    simulate_rotating_table,
    size_problem,
    write_simulation,
)
from kinsync.sim.table_config import (
    LABEL_FLOOR,
    LABEL_SPHERE,
    LABEL_STAND,
    LABEL_STRAY,
    RotatingTableConfig,
    max_usable_rate_deg_s,
    worst_sphere_points_per_pass,
)

QUIET: dict[str, Any] = {
    "range_noise_m": 0.0,
    "imu_attitude_noise_deg": 0.0,
    "rate_regulation_noise_rel": 0.0,
    "levelling_error_arcsec_max": 0.0,
    "optical_centre_offset_max_m": 0.0,
}


def _small(**kwargs: Any) -> RotatingTableConfig:
    base: dict[str, Any] = {"rates_deg_s": (6.0,), "passes": 1}
    base.update(kwargs)
    return RotatingTableConfig(**base)


def _fit_sphere(x: FloatArray) -> tuple[FloatArray, float]:
    """Algebraic start, then least squares on ||x - c|| - r."""
    A = np.column_stack([2.0 * x, np.ones(len(x))])
    sol = np.linalg.lstsq(A, np.sum(x * x, axis=1), rcond=None)[0]
    c0 = sol[:3]
    r0 = math.sqrt(sol[3] + c0 @ c0)

    def residuals(p: FloatArray) -> FloatArray:
        out: FloatArray = np.linalg.norm(x - p[:3], axis=1) - p[3]
        return out

    res = least_squares(
        residuals,
        np.r_[c0, r0],
        xtol=1e-15,
        ftol=1e-15,
        gtol=1e-15,
    )
    centre: FloatArray = np.asarray(res.x[:3], dtype=np.float64)
    return centre, float(res.x[3])


def _rot_about(axis: FloatArray, angle_rad: float) -> FloatArray:
    k = np.asarray(axis) / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    R: FloatArray = np.eye(3) + math.sin(angle_rad) * K + (1 - math.cos(angle_rad)) * K @ K
    return R


def _sphere_points(sim: RotatingTableSimulation, i: int) -> FloatArray:
    pts: FloatArray = sim.passes[i].points_ned_m[sim.point_labels[i] == LABEL_SPHERE]
    return pts


def test_deterministic_for_a_seed() -> None:
    a = simulate_rotating_table(_small(passes=1, seed=3))
    b = simulate_rotating_table(_small(passes=1, seed=3))
    c = simulate_rotating_table(_small(passes=1, seed=4))
    assert a.truth == b.truth
    for p, q in zip(a.passes, b.passes, strict=True):
        np.testing.assert_array_equal(p.points_ned_m, q.points_ned_m)
        assert p.t_s is not None
        assert q.t_s is not None
        np.testing.assert_array_equal(p.t_s, q.t_s)
    assert a.truth["sphere_center_ned_m"] != c.truth["sphere_center_ned_m"]


def test_a_pass_attitude_error_moves_each_pass_and_leaves_every_other_draw() -> None:
    plain = simulate_rotating_table(_small(passes=3, seed=3))
    shared = simulate_rotating_table(_small(passes=3, seed=3, pass_attitude_error_deg=0.01))
    scene = ("sphere_center_ned_m", "axis_ned_true", "optical_centre_offset_body_m")
    for key in scene:
        assert shared.truth[key] == plain.truth[key]
    errors = np.array([p["attitude_error_ned_deg"] for p in shared.truth["passes"]])
    assert errors.shape == (6, 3)
    assert len({tuple(e) for e in errors}) == 6  # drawn anew for each pass
    assert 0.002 < float(np.std(errors)) < 0.03
    assert all(p["attitude_error_ned_deg"] == [0.0, 0.0, 0.0] for p in plain.truth["passes"])
    # Without other noise, each pass's sphere is turned by its own error about the origin.
    quiet = simulate_rotating_table(
        _small(passes=2, seed=3, latency_s=0.0, pass_attitude_error_deg=0.01, **QUIET)
    )
    centre = np.array(quiet.truth["sphere_center_ned_m"])
    for i, p in enumerate(quiet.truth["passes"]):
        turned = Rotation.from_rotvec(np.radians(p["attitude_error_ned_deg"])).apply(centre)
        assert np.linalg.norm(turned - centre) > 2e-5  # 0.26 mm at 1.5 m per 0.01 deg, 1 sigma
        fitted, _ = _fit_sphere(_sphere_points(quiet, i))
        np.testing.assert_allclose(fitted, turned, atol=2e-6)
    with pytest.raises(InputError, match="pass_attitude_error_deg must be >= 0"):
        _small(pass_attitude_error_deg=-0.1)


def test_pass_layout_and_points_per_pass_at_6_deg_s() -> None:
    sim = simulate_rotating_table(_small(passes=2))
    assert [p.rate_deg_s for p in sim.passes] == [6.0, -6.0, 6.0, -6.0]
    assert all(p.axis_ned == (0.0, 0.0, 1.0) for p in sim.passes)  # nominal axis
    for i, p in enumerate(sim.passes):
        n_sphere = int(np.count_nonzero(sim.point_labels[i] == LABEL_SPHERE))
        assert 1500 <= n_sphere <= 2500
        assert sim.truth["passes"][i]["n_sphere"] == n_sphere
        assert p.t_s is not None
        assert np.all(np.diff(p.t_s) >= 0.0)
    starts = [p["t_start_s"] for p in sim.truth["passes"]]
    ends = [p["t_end_s"] for p in sim.truth["passes"]]
    assert all(e < s for e, s in zip(ends[:-1], starts[1:], strict=True))


def test_clutter_is_present() -> None:
    sim = simulate_rotating_table(_small())
    labels = sim.point_labels[0]
    counts = np.bincount(labels, minlength=4)
    assert counts[LABEL_STAND] > 50
    assert counts[LABEL_FLOOR] > 500
    assert counts[LABEL_STRAY] == round(0.01 * (labels.size - counts[LABEL_STRAY]))
    c = np.array(sim.truth["sphere_center_ned_m"])
    pts = sim.passes[0].points_ned_m
    # Everything lies in the exported box; floor and stand are away from the sphere.
    assert np.all(np.abs(pts - c) <= 0.3 + 1e-12)
    floor = pts[labels == LABEL_FLOOR]
    assert np.all(np.abs(floor[:, 2] - (c[2] + 0.28)) < 0.02)
    stand = pts[labels == LABEL_STAND]
    assert np.all(np.hypot(*(stand[:, :2] - c[:2]).T) < 0.015 + 0.01)


def test_zero_latency_puts_points_on_the_true_sphere() -> None:
    sim = simulate_rotating_table(_small(latency_s=0.0, rates_deg_s=(6.0, 18.0), **QUIET))
    c = np.array(sim.truth["sphere_center_ned_m"])
    for i in range(len(sim.passes)):
        d = np.linalg.norm(_sphere_points(sim, i) - c, axis=1)
        assert np.max(np.abs(d - 0.1)) < 1e-6


def test_result_does_not_depend_on_the_boresight() -> None:
    cfg = _small(latency_s=0.0, boresight_rpy_deg=(0.4, -0.3, 25.0), **QUIET)
    sim = simulate_rotating_table(cfg)
    c = np.array(sim.truth["sphere_center_ned_m"])
    for i in range(len(sim.passes)):
        pts = _sphere_points(sim, i)
        assert 1500 <= pts.shape[0] <= 2500
        assert np.max(np.abs(np.linalg.norm(pts - c, axis=1) - 0.1)) < 1e-6


@pytest.mark.parametrize(("latency_s", "fifo_bytes"), [(0.00421, 0), (0.002, 64)])
def test_latency_turns_the_centres_by_minus_omega_tau(latency_s: float, fifo_bytes: int) -> None:
    """The + pass centre is Rot(-omega tau) c, the - pass centre Rot(+omega tau) c."""
    sim = simulate_rotating_table(
        _small(latency_s=latency_s, fifo_bytes=fifo_bytes, rates_deg_s=(10.0,), **QUIET)
    )
    tau = latency_s + fifo_bytes * 10 / 115200
    assert sim.truth["latency_s"] == pytest.approx(tau, rel=1e-12)
    c = np.array(sim.truth["sphere_center_ned_m"])
    axis = np.array(sim.truth["axis_ned_true"])
    omega = math.radians(10.0)
    plus, _ = _fit_sphere(_sphere_points(sim, 0))
    minus, radius = _fit_sphere(_sphere_points(sim, 1))
    assert sim.passes[0].rate_deg_s > 0 > sim.passes[1].rate_deg_s
    assert radius == pytest.approx(0.1, abs=1e-9)
    np.testing.assert_allclose(plus, _rot_about(axis, -omega * tau) @ c, rtol=0, atol=1e-8)
    np.testing.assert_allclose(minus, _rot_about(axis, +omega * tau) @ c, rtol=0, atol=1e-8)
    # Separation of the pooled centres: 2 |omega| tau, as Method A reads it.
    angle = math.atan2(minus[0] * plus[1] - minus[1] * plus[0], minus[:2] @ plus[:2])
    assert angle == pytest.approx(-2 * omega * tau, rel=1e-5)


def test_noise_defaults_keep_the_centre_close() -> None:
    """With all noise on (defaults), a pass's fitted centre moves by about omega tau r."""
    sim = simulate_rotating_table(_small(rates_deg_s=(18.0,)))
    c = np.array(sim.truth["sphere_center_ned_m"])
    plus, radius = _fit_sphere(_sphere_points(sim, 0))
    assert radius == pytest.approx(0.1, abs=5e-4)
    shift = math.radians(18.0) * 0.00421 * 1.5
    assert np.linalg.norm(plus - c) == pytest.approx(shift, abs=3e-4)
    assert 0 < sim.truth["levelling_error_arcsec"] <= 15.0
    assert 0 < sim.truth["optical_centre_offset_m"] <= 5e-4


def test_fifo_adds_bytes_times_ten_over_baud() -> None:
    sim = simulate_rotating_table(_small(fifo_bytes=16, baud=9600.0))
    assert sim.truth["fifo_delay_s"] == pytest.approx(16 * 10 / 9600)
    assert sim.truth["latency_s"] == pytest.approx(0.00421 + 16 * 10 / 9600)
    assert sim.truth["imu_latency_s"] == 0.00421


def test_progress_is_reported() -> None:
    seen: list[tuple[float, str]] = []
    simulate_rotating_table(_small(), progress=lambda f, stage: seen.append((f, stage)))
    assert seen == [
        (0.0, "simulating passes"),
        (0.5, "simulating passes"),
        (1.0, "simulating passes"),
    ]


@pytest.mark.parametrize(
    ("kwargs", "fragment"),
    [
        ({"passes": 0}, "passes must be at least 1"),
        ({"passes": 1.5}, "whole number"),
        ({"rates_deg_s": ()}, "rates_deg_s is empty"),
        ({"rates_deg_s": (2.0, 0.0)}, "rate magnitudes > 0"),
        ({"rates_deg_s": (-2.0,)}, "rate magnitudes > 0"),
        ({"rates_deg_s": (float("nan"),)}, "finite"),
        ({"rates_deg_s": (6.0, 1000.0)}, "holds 1000: .* the largest usable rate is 369 deg/s"),
        ({"rates_deg_s": (30.0,), "angular_step_deg": 5.0}, "the largest usable rate is 28.1"),
        ({"angular_step_deg": 8.0}, "no rate is, with this angular step and sphere"),
        # Points per pass scale as 1 / rate: it ran until killed.
        ({"rates_deg_s": (0.001,)}, "rates_deg_s 0.001 with passes 1: the passes would scan"),
        ({"range_noise_m": -1.0}, "range_noise_m must be >= 0"),
        ({"fifo_bytes": -1}, "fifo_bytes"),
        ({"sphere_range_m": 0.3}, "sphere_range_m"),
        ({"boresight_rpy_deg": (90.0, 0, 0), "sphere_elevation_m": 0.5}, "no beam of the"),
    ],
)
def test_bad_config(kwargs: dict[str, Any], fragment: str) -> None:
    with pytest.raises(InputError, match=fragment):
        simulate_rotating_table(_small(**kwargs))


def test_the_fastest_usable_rate_keeps_every_pass_usable() -> None:
    # At 1000 deg/s a pass held no profile (a crash); at 400 deg/s some passes held
    # no sphere and latency sphere left them out. The bound is the estimator's minimum.
    geometry = {
        "profile_rate_hz": 50.0,
        "angular_step_deg": 0.2,
        "sphere_radius_m": 0.1,
        "sphere_range_m": 1.5,
    }
    limit = max_usable_rate_deg_s(**geometry)
    assert worst_sphere_points_per_pass(limit, **geometry) >= MIN_SPHERE_POINTS_PER_PASS
    assert worst_sphere_points_per_pass(limit * 1.01, **geometry) < MIN_SPHERE_POINTS_PER_PASS
    assert worst_sphere_points_per_pass(400.0, **geometry) == 0  # a pass can miss it
    cfg = RotatingTableConfig(rates_deg_s=(limit,), passes=6, seed=2)
    assert cfg.max_rate_deg_s == limit
    sim = simulate_rotating_table(cfg)
    n_sphere = [int(np.count_nonzero(lab == LABEL_SPHERE)) for lab in sim.point_labels]
    assert min(n_sphere) >= MIN_SPHERE_POINTS_PER_PASS
    result = estimate_latency_sphere(sim.passes, radius_m=cfg.sphere_radius_m)
    assert result.n_passes_used == len(sim.passes)


def test_size_limit_keeps_the_declared_passes_at_the_default_rates() -> None:
    assert size_problem(RotatingTableConfig(passes=100)) is None  # --passes up to 100
    problem = size_problem(RotatingTableConfig(rates_deg_s=(0.01,), passes=2))
    assert problem is not None
    assert f"more than the {MAX_TABLE_PROFILES:,} kinsync simulates" in problem


def test_write_simulation_round_trip_and_truth(tmp_path: Path) -> None:
    sim = simulate_rotating_table(_small(fifo_bytes=8))
    write_simulation(sim, tmp_path / "out", file_format="laz")
    back = read_passes(tmp_path / "out")
    assert len(back) == len(sim.passes)
    for p, q in zip(sim.passes, back, strict=True):
        assert q.rate_deg_s == p.rate_deg_s
        assert np.max(np.abs(q.points_ned_m - p.points_ned_m)) <= 0.5e-6 + 1e-12
    truth = json.loads((tmp_path / "out" / "truth.json").read_text())
    for key in (
        "latency_s",
        "imu_latency_s",
        "fifo_delay_s",
        "sphere_center_ned_m",
        "sphere_radius_m",
        "axis_ned_true",
        "levelling_error_arcsec",
        "optical_centre_offset_m",
        "sphere_points_per_pass",
        "config",
        "seed",
    ):
        assert key in truth
    assert truth["latency_s"] == pytest.approx(0.00421 + 80 / 115200)
    assert [p["file"] for p in truth["passes"]] == ["pass_000.laz", "pass_001.laz"]
    assert not (tmp_path / "out" / "raw").exists()


def test_raw_output_reproduces_the_passes(tmp_path: Path) -> None:
    """Raw path of Method A: scanner points + attitude log + mount give the passes back."""
    cfg = _small(boresight_rpy_deg=(0.2, -0.1, 3.0))
    sim = simulate_rotating_table(cfg)
    write_simulation(sim, tmp_path, raw=True)
    mount = read_mount(tmp_path / "raw" / "mount.toml")
    assert mount.boresight_rpy_deg == (0.2, -0.1, 3.0)
    assert mount.latency_s == 0.0
    np.testing.assert_allclose(
        mount.R_scanner_to_body, euler_rpy_to_matrix(*np.radians([0.2, -0.1, 3.0])), atol=1e-15
    )
    rebuilt = read_raw_passes(tmp_path)
    assert len(rebuilt) == len(sim.passes)
    for p, q in zip(sim.passes, rebuilt, strict=True):
        assert q.rate_deg_s == p.rate_deg_s
        np.testing.assert_allclose(q.points_ned_m, p.points_ned_m, rtol=0, atol=1e-9)


def test_write_simulation_refuses_a_file(tmp_path: Path) -> None:
    sim = simulate_rotating_table(_small())
    f = tmp_path / "x"
    f.write_text("")
    with pytest.raises(InputError, match="not a folder"):
        write_simulation(sim, f)
