"""End-to-end demo section: one survey through INS/GNSS, Method B, georef and validation.

The section runs once (module fixture); the tests check what it claims against the
simulation's truth, against the estimators' own sigmas, and against a direct
recomputation of its numbers.
"""

from __future__ import annotations

import itertools
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from kinsync._typing import FloatArray
from kinsync.clock.profile import ProfileClock
from kinsync.demo.end_to_end import end_to_end_section
from kinsync.demo.end_to_end_chain import CASE_LABELS
from kinsync.demo.end_to_end_survey import (
    EndToEndConfig,
    georeference_scan,
    simulate_survey,
    wall_selection,
)
from kinsync.errors import InputError
from kinsync.frames import ned_to_ecef
from kinsync.ins.alignment import align_static_gnss_heading
from kinsync.ins.compare import compare_to_truth
from kinsync.ins.filter import run_ins
from kinsync.report.end_to_end_figures import (
    clock_cases_figure,
    control_point_cases_figure,
    wall_cases_figure,
)
from kinsync.report.html import Section, render_report
from kinsync.validation import fit_wall

CORRECT, LATE, DRIFT = CASE_LABELS


@dataclass(frozen=True)
class _Run:
    out_dir: Path
    section: Section
    doc: dict[str, Any]
    summary: list[tuple[str, str, str]]
    labels: list[str]


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> _Run:
    out_dir = tmp_path_factory.mktemp("end_to_end")
    summary: list[tuple[str, str, str]] = []
    labels: list[str] = []
    section, doc = end_to_end_section(out_dir, summary, labels.append)
    return _Run(out_dir, section, doc, summary, labels)


def _saved(run: _Run) -> dict[str, Any]:
    out: dict[str, Any] = json.loads((run.out_dir / "end_to_end.json").read_text())
    return out


def test_section_figures_files_and_summary(run: _Run) -> None:
    assert "End to end" in run.section.title
    assert len(run.section.figures) == 5
    for i, fig in enumerate(run.section.figures, start=1):
        assert fig.png.startswith(b"\x89PNG")
        assert (run.out_dir / f"end_to_end_{i}.png").read_bytes() == fig.png
    assert _saved(run) == json.loads(json.dumps(run.doc, allow_nan=True))
    assert not list(run.out_dir.glob("*.part"))
    assert [row[0] for row in run.summary] == [
        "end-to-end: INS/GNSS",
        "end-to-end: Method B",
        "end-to-end: validation",
    ]
    assert all(label.startswith("end-to-end") for label in run.labels)
    assert len(run.labels) == 4
    html = render_report("t", "i", [run.section])
    assert html.count("<img") == 5
    assert html.count("<table>") == 5
    # one row per control-point visit of the correct case, one per case and wall pass
    visits = run.section.tables[3]
    assert len(visits.rows) == run.doc["cases"][CORRECT]["control_points"]["n_observations"]
    assert len(run.section.tables[4].rows) == len(CASE_LABELS) * EndToEndConfig().laps


def test_ins_solution_against_truth(run: _Run) -> None:
    ins = _saved(run)["ins"]
    smoothed, forward = ins["smoothed"], ins["forward"]
    # RTK at 1-2 cm, navigation-grade IMU: millimetres after smoothing, never worse
    # than the forward filter, and consistent with the reported sigma.
    assert max(smoothed["rms_pos_ned_m"]) < 0.01
    assert smoothed["rms_att_deg"][2] < 0.02
    for axis in range(3):
        assert smoothed["rms_pos_ned_m"][axis] <= forward["rms_pos_ned_m"][axis]
    assert min(smoothed["within_3sigma"][k] for k in ("pos_n", "pos_e", "pos_d")) > 0.8
    assert ins["n_gnss_rejected"] <= 0.01 * ins["n_gnss_used"]


def test_method_b_on_the_ins_trajectory(run: _Run) -> None:
    saved = _saved(run)
    truth, est, exact = saved["truth"], saved["method_b"], saved["method_b_exact_trajectory"]
    assert est["t0_error_s"] == est["t0_s"] - truth["t0_s"]
    assert est["period_error_s"] == est["period_s"] - truth["period_s"]
    assert abs(est["t0_error_s"]) < 4.0 * est["t0_std_s"]
    assert abs(est["period_error_s"]) < 4.0 * est["period_std_s"]
    assert abs(est["t0_error_s"]) < 2e-3
    assert abs(est["period_error_s"]) < 1e-6
    assert not est["ambiguous"]
    # on the exact trajectory the same scan gives a far better clock
    assert abs(exact["t0_error_s"]) < 4.0 * exact["t0_std_s"]
    assert exact["t0_std_s"] < est["t0_std_s"]


def _within(test: dict[str, Any], lo_s: float, hi_s: float, k: float = 4.0) -> bool:
    """The implied time error lies within the true range, widened by k sigma."""
    est, std = test["time_error_s"], test["time_error_std_s"]
    return bool(lo_s - k * std <= est <= hi_s + k * std)


def test_correct_calibration_shows_no_signature_and_no_curvature(run: _Run) -> None:
    case = _saved(run)["cases"][CORRECT]
    cp = case["control_points"]
    assert cp["time_error"]["testable"]
    assert cp["heading_error"]["testable"]
    assert not cp["time_error"]["significant"]
    assert not cp["heading_error"]["significant"]
    lo, hi = sorted((case["time_error_first_profile_s"], case["time_error_last_profile_s"]))
    assert _within(cp["time_error"], lo, hi)
    assert abs(cp["time_error"]["time_error_s"]) < 1.5e-3
    assert max(abs(v) for v in cp["rms_vehicle_m"]) < 0.01
    tolerance = _saved(run)["config"]["wall_tolerance_m"]
    for wall in case["walls"]:
        assert not wall["curvature_significant"]
        assert wall["bow_m"] < tolerance
        assert wall["n_points"] > 1000
    assert case["n_outside_trajectory"] == 0
    # the simulated wall itself is flat: exact trajectory and true clock, no bend found
    for wall in _saved(run)["walls_exact_trajectory_and_clock"]:
        assert wall["curvature_p_value"] > 1e-3
        assert wall["bow_m"] < 0.2 * tolerance


def test_wrong_latency_is_detected_as_a_time_error_and_a_bent_wall(run: _Run) -> None:
    saved = _saved(run)
    case = saved["cases"][LATE]
    cp = case["control_points"]
    assert cp["time_error"]["significant"]
    assert not cp["heading_error"]["significant"]
    lo, hi = sorted((case["time_error_first_profile_s"], case["time_error_last_profile_s"]))
    assert _within(cp["time_error"], lo, hi)
    error_s = saved["config"]["latency_error_s"]
    assert abs(cp["time_error"]["time_error_s"] - error_s) < 0.3 * error_s
    for wall in case["walls"]:
        assert wall["curvature_significant"]
        assert wall["bow_m"] > 2.0 * saved["config"]["wall_tolerance_m"]
    # only t0 + latency is observable: a t0 off by the same amount gives the same cloud
    assert saved["t0_latency_equivalence_m"] < 1e-6


def _dy_by_visit(case: dict[str, Any]) -> dict[tuple[str, int], tuple[float, float, float]]:
    return {
        (o["name"], o["visit"]): (o["dy_m"], o["along_speed_m_s"], o["t_s"])
        for o in case["control_points"]["observations"]
    }


def test_dy_damage_is_speed_times_the_time_error(run: _Run) -> None:
    """Per visit, dY(wrong) - dY(correct) = along-track speed x (time error difference)."""
    saved = _saved(run)
    truth = saved["truth"]
    correct = _dy_by_visit(saved["cases"][CORRECT])
    for label in (LATE, DRIFT):
        case = saved["cases"][label]
        wrong = _dy_by_visit(case)
        common = sorted(set(correct) & set(wrong))
        assert len(common) >= 12
        for key in common:
            dy_ok, speed, t_s = correct[key]
            x = (t_s - truth["t0_s"]) / truth["period_s"]
            ref = saved["cases"][CORRECT]
            shift = (case["t0_s"] - ref["t0_s"]) + x * (case["period_s"] - ref["period_s"])
            shift += case["latency_s"] - ref["latency_s"]
            # the same returns, shifted rigidly by speed x shift, fitted again: the fits
            # agree to far below their own noise (0.5 mm is ten times what is seen)
            assert abs(wrong[key][0] - dy_ok - speed * shift) < 5e-4, (label, key)


def test_period_error_grows_pass_to_pass_and_bends_the_later_wall(run: _Run) -> None:
    saved = _saved(run)
    case = saved["cases"][DRIFT]
    per_pass = case["mean_dy_per_pass_m"]
    assert len(per_pass) == saved["config"]["laps"] + 1
    assert all(b > a for a, b in itertools.pairwise(per_pass))
    # the error grows by clock_error * (fraction of the scan between passes): at
    # 4-5 m/s that is more than 10 mm from the first pass to the last
    assert per_pass[-1] - per_pass[0] > 0.01
    walls = case["walls"]
    assert walls[-1]["curvature_significant"]
    assert walls[-1]["bow_m"] > walls[0]["bow_m"]
    correct = saved["cases"][CORRECT]["mean_dy_per_pass_m"]
    assert max(abs(v) for v in correct) < 0.005


def test_json_numbers_equal_a_direct_recomputation(run: _Run) -> None:
    saved = _saved(run)
    truth = saved["truth"]
    n_last = truth["n_profiles"] - 1
    for label in CASE_LABELS:
        case = saved["cases"][label]
        expected = (case["t0_s"] + n_last * case["period_s"] + case["latency_s"]) - (
            truth["t0_s"] + n_last * truth["period_s"] + truth["latency_s"]
        )
        assert math.isclose(case["time_error_last_profile_s"], expected, abs_tol=1e-12)
        obs = case["control_points"]["observations"]
        passes = np.array(case["pass_of_visit"])
        dy = np.array([o["dy_m"] for o in obs])
        means = [float(np.mean(dy[passes == k])) for k in np.unique(passes)]
        assert np.allclose(case["mean_dy_per_pass_m"], means, rtol=0.0, atol=1e-12)
        rms = float(np.sqrt(np.mean(dy**2)))
        assert math.isclose(case["control_points"]["rms_vehicle_m"][1], rms, rel_tol=1e-12)

    # Recompute the INS comparison and one wall fit from scratch.
    survey = simulate_survey(EndToEndConfig())
    assert survey.scan.t0_s == truth["t0_s"]
    assert len(survey.scan.scan) == truth["n_returns"]
    arm = survey.mount.antenna_lever_arm_body_m
    init = align_static_gnss_heading(
        survey.imu, survey.gnss, static_s=survey.config.static_s - 2.0,
        antenna_lever_arm_body_m=arm,
    )  # fmt: skip
    ins = run_ins(survey.imu, survey.gnss, survey.ins_config, init, smooth=True)
    assert ins.smoothed is not None
    cmp = compare_to_truth(ins.smoothed, survey.truth)
    assert cmp.as_document()["rms_pos_ned_m"] == saved["ins"]["smoothed"]["rms_pos_ned_m"]
    late = saved["cases"][LATE]
    cloud, n_out = georeference_scan(
        survey,
        ins.smoothed.to_trajectory(),
        ProfileClock(late["t0_s"], late["period_s"]),
        late["latency_s"],
    )
    assert len(cloud) == late["n_points"]
    assert n_out == late["n_outside_trajectory"]
    wall = fit_wall(
        wall_selection(survey, cloud, survey.wall_windows_s[0]),
        min_bow_m=survey.config.wall_tolerance_m,
    )
    assert wall.as_document() == late["walls"][0]


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("straight_m", 20.0),
        ("speed_m_s", 0.0),
        ("laps", 0),
        ("laps", True),
        ("static_s", 2.0),
        ("latency_s", math.nan),
        ("clock_error_s", math.inf),
        ("wall_tolerance_m", -0.001),
        ("gnss_std_pos_ned_m", (0.01, 0.01)),
        ("gnss_std_pos_ned_m", (0.01, 0.0, 0.02)),
        ("angular_step_deg", -0.5),
        ("seed", -1),
        ("seed", 1.5),
    ],
)
def test_bad_configuration_is_an_input_error(field: str, value: object) -> None:
    with pytest.raises(InputError):
        EndToEndConfig(**{field: value})  # type: ignore[arg-type]


def _plane_wall(bend_m: float, seed: int) -> FloatArray:
    """Points of a 10 m x 3 m wall near (46.8, -71.2), bent by ``bend_m`` at the middle."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(-5.0, 5.0, 4000)
    v = rng.uniform(0.0, 3.0, 4000)
    w = bend_m * (1.0 - (u / 5.0) ** 2) + rng.normal(0.0, 0.002, u.size)
    ned = np.column_stack([u, w, -v])
    return ned_to_ecef(ned, 46.8, -71.2, 10.0)


def test_wall_and_control_figures_reject_empty_or_ragged_input() -> None:
    flat = fit_wall(_plane_wall(0.0, 1))
    bent = fit_wall(_plane_wall(0.01, 2), min_bow_m=0.005)
    assert bent.curvature_significant
    assert not flat.curvature_significant
    png = wall_cases_figure([("flat", [flat]), ("bent", [bent])], ["pass"])
    assert png.startswith(b"\x89PNG")
    with pytest.raises(InputError):
        wall_cases_figure([])
    with pytest.raises(InputError):
        wall_cases_figure([("a", [flat]), ("b", [flat, bent])])
    with pytest.raises(InputError):
        control_point_cases_figure([])


def test_clock_cases_figure_draws_every_case() -> None:
    t = np.linspace(0.0, 100.0, 50)
    png = clock_cases_figure(
        t,
        [("a", np.zeros_like(t)), ("b", 1e-3 + 0.0 * t), ("c", 5e-5 * t)],
        np.full_like(t, 2e-4),
        [("control pass", 0.0, 10.0), ("wall pass", 20.0, 30.0)],
    )
    assert png.startswith(b"\x89PNG")
