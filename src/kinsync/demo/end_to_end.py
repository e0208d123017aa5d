"""Demo section: the whole chain on one simulated survey, right and wrong calibration.

One drive, one scene, one truth (synchronisation, georeferencing and validation in a row):

1. **Survey.** An oval driven almost three times (`kinsync.sim.drive`: straights,
   180 deg right turns of 10 m radius, 5 m/s cruise, smooth speed ramps from the static
   start and to the final stop), sampled once by `kinsync.sim.drive.simulate_truth`.
   That one truth feeds the profile scanner (`kinsync.sim.profiler.simulate_profiler`,
   a 33 rev/s profiler with a known latency between the navigation records and the
   scanner), a navigation-grade IMU (`simulate_imu`) and RTK GNSS (`simulate_gnss`).
   The scene is `kinsync.sim.scene.build_drive_scene`'s ground and sync spheres
   (beside the first straight, passed three times) plus control spheres on both sides
   of that straight, where the vehicle passes them accelerating, cruising and braking
   (several speeds: the time-error signature needs them), and a wall on the outside
   of the first turn's entry (where the motion changes along the wall, so a time error
   bends it; the layout's own wall stands mid-turn, where uniform circular motion
   would only rotate it rigidly). Only the profiles that can see a target or the wall
   are simulated.
2. **INS/GNSS.** Static levelling with GNSS course-over-ground heading, the 28-state
   filter and the RTS smoother (`kinsync.ins.filter.run_ins`); the smoothed solution,
   compared with the truth, is the trajectory every later step uses.
3. **Method B.** The scan is synchronised on that INS trajectory
   (`kinsync.sync.object_space.synchronise_object_space`): t0 and T against the truth.
4. **Georeferencing** (`kinsync.georef.georeference`) with the estimated clock, the
   INS trajectory and the mount with the calibrated latency (the value Method A gives;
   here the simulated system's true latency).
5. **Validation** (`kinsync.validation`): control points in the vehicle frame (with
   the time and heading signature tests) and the wall's flatness and curvature, for
   (a) the correct calibration, (b) a latency 5 ms too large and (c) a period error
   that grows to 5 ms at the end of the scan.

The survey is simulated in `kinsync.demo.end_to_end_survey`, the chain run in
`kinsync.demo.end_to_end_chain`; this module makes the report section.

A Method B clock absorbs any constant latency: the clock is fitted with the latency in
the mount, and only ``t0 + latency`` is observable, so a wrong t0 and a wrong latency
give the same cloud (checked and reported). Case (b) is a latency changed after the
synchronisation, or equally a t0 off by 5 ms.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from kinsync._typing import FloatArray
from kinsync.demo.end_to_end_chain import CalibrationCase, ChainResult, run_chain
from kinsync.demo.end_to_end_survey import EndToEndConfig, simulate_survey, time_at_path
from kinsync.demo.files import write_section_files
from kinsync.demo.tolerances import (
    DETECTION,
    LATENCY_CALIBRATION,
    NO_FALSE_ALARM,
    ONE_ERROR_SOURCE,
)
from kinsync.report.end_to_end_figures import (
    clock_cases_figure,
    control_point_cases_figure,
    survey_figure,
    wall_cases_figure,
)
from kinsync.report.html import Figure, Section, Table
from kinsync.report.method_b_figures import clock_regression_figure
from kinsync.report.numbers import format_p_value, plus_minus
from kinsync.report.verdict import Check
from kinsync.validation import (
    ControlPointReport,
    FlatnessResult,
    SignatureTest,
    pass_labels,
)

__all__ = [
    "chain_document",
    "end_to_end_section",
    "mean_dy_per_pass",
]


Summary = list[tuple[str, str, str]]


# ---------------------------------------------------------------------- the survey


# ---------------------------------------------------------------------- the chain


# ---------------------------------------------------------------------- the section
def _ms(value_s: float) -> str:
    return f"{value_s * 1e3:+.2f}"


def _signature_cell(test: SignatureTest, scale: float, unit: str = "") -> str:
    if not test.testable:
        return "not testable"
    verdict = "significant" if test.significant else "not significant"
    value = plus_minus(test.estimate * scale, test.std * scale)
    return f"{value}{unit} ({format_p_value(test.p_value)}, {verdict})"


def _first_straight_spans(result: ChainResult) -> list[tuple[float, float]]:
    sv = result.survey
    return [
        (
            time_at_path(sv.truth, k * sv.lap_m),
            time_at_path(sv.truth, k * sv.lap_m + sv.config.straight_m),
        )
        for k in range(sv.config.laps + 1)
    ]


def _matching_dy(report: ControlPointReport, name: str, t_s: float) -> float | None:
    best: float | None = None
    for d in report.differences:
        if d.observation.name == name and abs(d.observation.t_s - t_s) < 1.0:
            best = d.diff_vehicle_m[1]
    return best


def mean_dy_per_pass(report: ControlPointReport) -> FloatArray:
    """Mean along-track difference dY of each pass (m), in pass order (`pass_labels`)."""
    labels = pass_labels(report.differences)
    dy = report.diff_vehicle_m()[:, 1]
    out: FloatArray = np.array([float(np.mean(dy[labels == k])) for k in np.unique(labels)])
    return out


def chain_document(result: ChainResult) -> dict[str, Any]:
    """The JSON document of the section (``end_to_end.json``).

    Returns
    -------
    dict
        ``config``, ``truth`` (latency, clock, counts), ``ins`` (forward and smoothed
        comparisons), ``method_b`` (the estimate and its errors), ``cases`` (per case:
        clock, latency, true time errors, control-point report, wall fits per pass) and
        ``t0_latency_equivalence_m``, ``walls_exact_trajectory_and_clock``.
    """
    sv = result.survey
    sim = sv.scan
    sync = result.sync
    assert result.ins.smoothed is not None
    cases: dict[str, Any] = {}
    for case in result.cases:
        cases[case.label] = {
            "t0_s": case.clock.t0_s,
            "period_s": case.clock.period_s,
            "latency_s": case.latency_s,
            "time_error_first_profile_s": case.time_error_first_s,
            "time_error_last_profile_s": case.time_error_last_s,
            "n_points": case.n_points,
            "n_outside_trajectory": case.n_outside,
            "control_points": case.control.as_document(),
            "pass_of_visit": pass_labels(case.control.differences).tolist(),
            "mean_dy_per_pass_m": mean_dy_per_pass(case.control).tolist(),
            "walls": [w.as_document() for w in case.walls],
        }
    return {
        "config": asdict(sv.config),
        "truth": {
            "latency_s": sv.mount.latency_s,
            "t0_s": sim.t0_s,
            "period_s": sim.period_s,
            "n_profiles": sim.n_profiles,
            "n_profiles_simulated": int(np.unique(sim.scan.profile).size),
            "n_returns": len(sim.scan),
            "route_length_m": sv.route.length_m,
            "duration_s": sv.truth.duration_s,
            "wall_windows_s": [list(w) for w in sv.wall_windows_s],
        },
        "ins": {
            "imu": "navigation grade, 50 Hz",
            "gnss_rate_hz": 5.0,
            "n_gnss_used": result.ins.smoothed.n_gnss_used,
            "n_gnss_rejected": result.ins.smoothed.n_gnss_rejected,
            "forward": result.forward.as_document(),
            "smoothed": result.smoothed.as_document(),
        },
        "method_b": {
            **sync.as_document(),
            "t0_error_s": sync.t0_s - sim.t0_s,
            "period_error_s": sync.period_s - sim.period_s,
        },
        "method_b_exact_trajectory": {
            "t0_s": result.sync_exact.t0_s,
            "t0_std_s": result.sync_exact.t0_std_s,
            "period_s": result.sync_exact.period_s,
            "period_std_s": result.sync_exact.period_std_s,
            "t0_error_s": result.sync_exact.t0_s - sim.t0_s,
            "period_error_s": result.sync_exact.period_s - sim.period_s,
        },
        "cases": cases,
        "t0_latency_equivalence_m": result.equivalence_m,
        "walls_exact_trajectory_and_clock": [w.as_document() for w in result.walls_exact],
    }


def _pass_names(result: ChainResult) -> list[str]:
    return [f"lap {k + 1}" for k in range(result.survey.config.laps)]


def _figures(result: ChainResult) -> list[Figure]:
    sv = result.survey
    sim = sv.scan
    assert result.ins.smoothed is not None
    x = np.linspace(0.0, sim.n_profiles - 1.0, 400)
    errors = [
        (
            c.label,
            (c.clock.t0_s - sim.t0_s)
            + x * (c.clock.period_s - sim.period_s)
            + (c.latency_s - sv.mount.latency_s),
        )
        for c in result.cases
    ]
    spans = [("control", lo - sim.t0_s, hi - sim.t0_s) for lo, hi in _first_straight_spans(result)]
    spans += [("wall", lo - sim.t0_s, hi - sim.t0_s) for lo, hi in sv.wall_windows_s]
    correct = result.cases[0]
    return [
        Figure(
            caption="The survey and the INS/GNSS position error",
            png=survey_figure(sv.scene, sv.truth, sv.gnss, result.smoothed, result.ins.smoothed),
        ),
        Figure(
            caption="Method B on the INS trajectory: regression and residuals",
            png=clock_regression_figure(result.sync, title="Method B on the INS/GNSS trajectory"),
        ),
        Figure(
            caption="True time error of each calibration along the scan (shaded: the passes "
            "past the control targets and the wall)",
            png=clock_cases_figure(x * sim.period_s, errors, result.sync.time_std_s(x), spans),
        ),
        Figure(
            caption="Control points: dY per visit and against speed, correct vs wrong",
            png=control_point_cases_figure(
                [(c.label, c.control) for c in result.cases],
                pass_labels(correct.control.differences).tolist(),
            ),
        ),
        Figure(
            caption="Wall residuals per pass, correct vs wrong, on one colour scale",
            png=wall_cases_figure([(c.label, c.walls) for c in result.cases], _pass_names(result)),
        ),
    ]


def _summary_rows(result: ChainResult) -> list[tuple[str, str, str]]:
    sim = result.survey.scan
    sync = result.sync
    rms = result.smoothed.rms_pos_ned_m
    att = result.smoothed.rms_att_deg

    def verdict(case: CalibrationCase) -> str:
        te = case.control.time_error
        bent = sum(w.curvature_significant for w in case.walls)
        te_text = (
            f"{te.estimate * 1e3:+.1f} ms{'*' if te.significant else ''}"
            if te.testable
            else "not testable"
        )
        bows = "/".join(f"{w.bow_m * 1e3:.1f}" for w in case.walls)
        return f"{case.label}: time error {te_text}, wall bow {bows} mm ({bent} curved)"

    return [
        (
            "end-to-end: INS/GNSS",
            "nav-grade IMU 50 Hz + RTK 5 Hz, static alignment, smoothed vs truth",
            (
                f"position RMS N/E/D {rms[0] * 1e3:.1f}/{rms[1] * 1e3:.1f}/{rms[2] * 1e3:.1f} "
                f"mm, yaw RMS {att[2]:.4f} deg"
            ),
        ),
        (
            "end-to-end: Method B",
            "scan synchronised on the INS trajectory",
            (
                f"t0 error {(sync.t0_s - sim.t0_s) * 1e3:+.2f} ms (sigma "
                f"{sync.t0_std_s * 1e3:.2f}), T error {(sync.period_s - sim.period_s) * 1e9:+.0f}"
                f" ns (sigma {sync.period_std_s * 1e9:.0f})"
            ),
        ),
        (
            "end-to-end: validation",
            "correct vs +5 ms latency vs period error (* = significant at 99 %)",
            "; ".join(verdict(c) for c in result.cases),
        ),
    ]


def _ins_table(result: ChainResult) -> Table:
    """The forward filter and the RTS smoother against the truth."""
    assert result.ins.smoothed is not None
    rows = []
    for label, cmp, sol in (
        ("forward filter", result.forward, result.ins.forward),
        ("RTS smoothed", result.smoothed, result.ins.smoothed),
    ):
        r, a = cmp.rms_pos_ned_m, cmp.rms_att_deg
        share = cmp.within_3sigma or {}
        rows.append(
            [
                label,
                f"{r[0] * 1e3:.1f} / {r[1] * 1e3:.1f} / {r[2] * 1e3:.1f}",
                f"{a[0]:.4f} / {a[1]:.4f} / {a[2]:.4f}",
                " / ".join(f"{share.get(k, math.nan):.3f}" for k in ("pos_n", "pos_e", "pos_d")),
                f"{sol.n_gnss_used} / {sol.n_gnss_rejected}",
            ]
        )
    return Table(
        caption="INS/GNSS against the truth",
        headers=(
            "solution",
            "position RMS N / E / D (mm)",
            "attitude RMS roll / pitch / yaw (deg)",
            "share within 3 sigma N / E / D",
            "GNSS used / rejected",
        ),
        rows=rows,
    )


def _sync_table(result: ChainResult) -> Table:
    """Method B on the INS trajectory and on the exact one, against the truth."""
    sim = result.survey.scan
    n_last = sim.n_profiles - 1
    rows = [
        [
            label,
            f"{(r.t0_s - sim.t0_s) * 1e3:+.3f}",
            f"{r.t0_std_s * 1e3:.3f}",
            f"{(r.period_s - sim.period_s) * 1e9:+.1f}",
            f"{r.period_std_s * 1e9:.1f}",
            _ms((r.t0_s - sim.t0_s) + n_last * (r.period_s - sim.period_s)),
            f"{float(r.time_std_s(n_last)) * 1e3:.3f}",
            str(len(r.sightings)),
        ]
        for label, r in (
            ("INS/GNSS smoothed (used)", result.sync),
            ("exact trajectory (reference)", result.sync_exact),
        )
    ]
    return Table(
        caption=(
            f"Method B against the truth (t0 = {sim.t0_s:.4f} s, T = {sim.period_s * 1e3:.6f} ms)"
        ),
        headers=(
            "trajectory",
            "t0 error (ms)",
            "t0 sigma (ms)",
            "T error (ns)",
            "T sigma (ns)",
            f"clock error at profile {n_last} (ms)",
            "its sigma (ms)",
            "pairs",
        ),
        rows=rows,
    )


def _case_table(result: ChainResult) -> Table:
    """Each calibration case's clock and latency, and its signature tests."""
    sync = result.sync
    rows = [
        [
            c.label,
            _ms(c.clock.t0_s - sync.t0_s),
            f"{(c.clock.period_s - sync.period_s) * 1e9:+.0f}",
            f"{c.latency_s * 1e3:.2f}",
            f"{_ms(c.time_error_first_s)} .. {_ms(c.time_error_last_s)}",
            _signature_cell(c.control.time_error, 1e3),
            _signature_cell(c.control.heading_error, 1.0),
            f"{np.sqrt(np.mean(c.control.diff_vehicle_m()[:, 1] ** 2)) * 1e3:.1f}",
            " / ".join(f"{v * 1e3:+.1f}" for v in mean_dy_per_pass(c.control)),
        ]
        for c in result.cases
    ]
    return Table(
        caption="Calibration cases and the control-point signature tests",
        headers=(
            "case",
            "t0 - Method B (ms)",
            "T - Method B (ns)",
            "latency (ms)",
            "true time error, first .. last profile (ms)",
            "implied time error (ms)",
            "implied heading error (deg)",
            "RMS dY (mm)",
            "mean dY per pass (mm)",
        ),
        rows=rows,
    )


def _visit_table(result: ChainResult) -> Table:
    """The dY of every control-point visit of the correct case, beside each case's."""
    correct = result.cases[0]
    rows = []
    for d, p in zip(
        correct.control.differences, pass_labels(correct.control.differences), strict=True
    ):
        cells = [d.observation.name, str(int(p) + 1), d.side, f"{d.along_speed_m_s:.2f}"]
        for c in result.cases:
            dy = _matching_dy(c.control, d.observation.name, d.observation.t_s)
            cells.append("-" if dy is None else f"{dy * 1e3:+.1f}")
        rows.append(cells)
    return Table(
        caption="Along-track offset dY (cloud - control, vehicle frame) per visit",
        headers=(
            "point",
            "pass",
            "side",
            "along-track speed (m/s)",
            *(f"dY {c.label} (mm)" for c in result.cases),
        ),
        rows=rows,
    )


def _wall_table(result: ChainResult) -> Table:
    """The wall's plane fit and curvature test, per case and pass."""
    names = _pass_names(result)
    rows = [
        [
            c.label,
            names[j],
            str(w.n_points),
            f"{w.rms_m * 1e3:.2f}",
            f"{w.bow_m * 1e3:.2f}",
            f"{w.f_statistic:.3g}",
            format_p_value(w.p_value, prefix=False),
            "yes" if w.curvature_significant else "no",
        ]
        for c in result.cases
        for j, w in enumerate(c.walls)
    ]
    return Table(
        caption="Wall beside the turn entry: plane fit and curvature test per pass",
        headers=(
            "case",
            "pass",
            "points",
            "RMS (mm)",
            "bow (mm)",
            "F",
            "p-value",
            f"curved (p < 0.01, bow >= {result.survey.config.wall_tolerance_m * 1e3:g} mm)",
        ),
        rows=rows,
    )


def _tables(result: ChainResult) -> tuple[Table, ...]:
    return (
        _ins_table(result),
        _sync_table(result),
        _case_table(result),
        _visit_table(result),
        _wall_table(result),
    )


def _survey_paragraph(result: ChainResult) -> str:
    """The drive, the sensors and the scene."""
    sv = result.survey
    cfg = sv.config
    sim = sv.scan
    n_simulated = int(np.unique(sim.scan.profile).size)
    return (
        f"One simulated survey carries the whole chain. A van drives {cfg.laps} laps of an "
        f"oval ({cfg.straight_m:g} m straights, {cfg.turn_radius_m:g} m radius right turns, "
        f"{cfg.speed_m_s:g} m/s cruise), then its first straight once more, braking to a "
        f"stop: {sv.route.length_m:.0f} m in {sv.truth.duration_s:.0f} s after a static "
        "start. One truth trajectory feeds a navigation-grade IMU (50 Hz), RTK GNSS (5 Hz) "
        f"and a profile scanner ({1.0 / sim.period_s:.2f} rev/s, "
        f"{cfg.angular_step_deg:g} deg steps, {cfg.range_noise_m * 1e3:g} mm range noise) "
        "whose returns carry profile numbers and mirror angles but no time. The navigation "
        f"records lag the scanner by {sv.mount.latency_s * 1e3:.2f} ms: the latency the "
        "Method A section estimates on its simulated rotating table, used here at its true "
        "value as the calibrated one. Two sync spheres and six control spheres stand "
        "beside the first straight, passed accelerating, cruising and braking; a wall "
        "stands outside the first turn's entry. Only the profiles that can see a target or "
        f"the wall are simulated ({n_simulated} of {sim.n_profiles}, {len(sim.scan)} "
        "returns)."
    )


def _sync_paragraph(result: ChainResult) -> str:
    """The INS/GNSS trajectory and Method B on it."""
    sim = result.survey.scan
    sync = result.sync
    exact = result.sync_exact
    return (
        "The INS/GNSS solution (static levelling, GNSS course-over-ground heading, 28-state "
        "filter, RTS smoother) is compared with the truth; it, not the truth, is the "
        "trajectory of every later step. Method B synchronises the scan on it: t0 "
        f"{(sync.t0_s - sim.t0_s) * 1e3:+.2f} ms (sigma {sync.t0_std_s * 1e3:.2f}) and T "
        f"{(sync.period_s - sim.period_s) * 1e9:+.0f} ns (sigma "
        f"{sync.period_std_s * 1e9:.0f}) from the truth. The INS position error along the "
        "track, divided by the speed, adds to the sightings' own timing noise: on the exact "
        f"trajectory the same scan gives t0 {(exact.t0_s - sim.t0_s) * 1e3:+.3f} ms (sigma "
        f"{exact.t0_std_s * 1e3:.3f})."
    )


def _cases_paragraph(result: ChainResult) -> str:
    """The three calibrations and the t0-latency equivalence."""
    cfg = result.survey.config
    n_last = result.survey.scan.n_profiles - 1
    same = (
        "the two clouds are identical"
        if result.equivalence_m == 0.0
        else f"the two clouds differ by at most {result.equivalence_m:.1e} m"
    )
    return (
        "The scan is then georeferenced three times: (a) the Method B clock and the "
        f"calibrated latency; (b) a latency {cfg.latency_error_s * 1e3:g} ms too large; (c) "
        f"a period error that grows to {cfg.clock_error_s * 1e3:g} ms at the last profile "
        f"({cfg.clock_error_s / n_last * 1e9:.0f} ns per profile, "
        f"{cfg.clock_error_s / n_last / result.sync.period_std_s:.0f} times Method B's sigma: "
        "a period Method B rejects). A Method B clock absorbs any constant latency (only "
        f"t0 + latency is observable), so (b) is also a t0 off by the same amount: {same}."
    )


def _bows(walls: Sequence[FlatnessResult]) -> str:
    return ", ".join(f"{w.bow_m * 1e3:.1f} mm ({format_p_value(w.p_value)})" for w in walls)


def _validation_paragraph(result: ChainResult) -> str:
    """How control points and the wall are tested."""
    correct = result.cases[0]
    return (
        "Control points: every sphere visit is found by intensity and fitted, the "
        "difference cloud - control is expressed in the vehicle frame, and the time and "
        "heading signatures are tested in one mixed model at 99 %. A time error shows as dY "
        "growing with the target's along-track speed; a period error as dY growing from "
        "pass to pass. Wall: the points of each pass through the turn are fitted with a "
        "plane and tested for curvature (F-test of a quadratic surface at 99 %). Entering "
        "the turn the displacement tau (v + omega x r) changes along the wall, so a time "
        "error bends it; the RMS barely moves. With about "
        f"{correct.walls[0].n_points} points per pass the F-test alone sees "
        "sub-millimetre bends (correct calibration: bows "
        + _bows(correct.walls)
        + "; with the exact trajectory and clock "
        + _bows(result.walls_exact)
        + ": the INS/GNSS trajectory's millimetre errors in the turn leave a small real "
        "bend), so a bend is flagged when p < 0.01 and "
        f"the bow reaches {result.survey.config.wall_tolerance_m * 1e3:g} mm. Views of the "
        "targets from the far straight give too few points and are listed as missing in the "
        "JSON document."
    )


def _outcome(case: CalibrationCase) -> str:
    """One case's signature tests, mean dY per pass and wall bows, in words."""
    per_pass = " / ".join(f"{v * 1e3:+.1f}" for v in mean_dy_per_pass(case.control))
    bows = ", ".join(f"{w.bow_m * 1e3:.1f}" for w in case.walls)
    curved = sum(w.curvature_significant for w in case.walls)
    return (
        f"{case.label}: implied time error "
        f"{_signature_cell(case.control.time_error, 1e3, ' ms')}, heading "
        f"{_signature_cell(case.control.heading_error, 1.0, ' deg')}, mean dY per pass "
        f"{per_pass} mm, wall bows {bows} mm ({curved} of {len(case.walls)} passes curved)"
    )


def _paragraphs(result: ChainResult) -> tuple[str, ...]:
    return (
        _survey_paragraph(result),
        _sync_paragraph(result),
        _cases_paragraph(result),
        _validation_paragraph(result),
        (
            "Outcome. "
            + "; ".join(_outcome(c) for c in result.cases)
            + ". A period error is not a constant time error: it grows along the survey, and "
            "so do the offsets from pass to pass and the bend of the later pass."
        ),
    )


def _checks(result: ChainResult) -> tuple[Check, ...]:
    """The chain's verdict: trajectory, clock, and validation of each calibration."""
    sim, sync = result.survey.scan, result.sync
    rms_mm = np.asarray(result.smoothed.rms_pos_ned_m) * 1e3
    correct, late, period = result.cases
    checks = [
        Check(
            "smoothed INS/GNSS position error (RMS, worst of N/E/D) against the truth",
            float(rms_mm.max()),
            ONE_ERROR_SOURCE,
            detail="N/E/D " + "/".join(f"{v:.1f}" for v in rms_mm) + " mm",
        ),
        Check(
            "Method B clock offset error on the INS/GNSS trajectory",
            (sync.t0_s - sim.t0_s) * 1e3,
            LATENCY_CALIBRATION,
            sync.t0_std_s * 1e3,
        ),
        Check(
            "correct calibration: time signature of the control points flagged by chance",
            correct.control.time_error.p_value,
            NO_FALSE_ALARM,
        ),
    ]
    checks.extend(
        Check(
            f"{case.label}: flagged by the control points' time signature",
            case.control.time_error.p_value,
            DETECTION,
            detail=f"time error {_ms(case.control.time_error.estimate)} ms",
        )
        for case in (late, period)
    )
    return tuple(checks)


def end_to_end_section(
    out_dir: Path,
    summary: Summary,
    progress: Callable[[str], None] | None = None,
    *,
    config: EndToEndConfig | None = None,
) -> tuple[Section, dict[str, object]]:
    """One simulated survey through the whole chain, right and wrong calibration.

    Parameters
    ----------
    out_dir : Path
        Report folder: ``end_to_end.json`` and ``end_to_end_1.png`` ..
        ``end_to_end_5.png`` are written there.
    summary : list of (str, str, str)
        Gets three (capability, scenario, result) rows.
    progress : callable, optional
        Called with a short label as each step starts.
    config : EndToEndConfig, optional
        The survey (defaults: the demo's).

    Returns
    -------
    section : Section
    doc : dict
        What ``end_to_end.json`` holds (`chain_document`).
    """
    out = Path(out_dir)
    if progress:
        progress("end-to-end: simulating one survey (drive, scene, scan, IMU, GNSS)")
    result = run_chain(simulate_survey(config), progress)
    doc = chain_document(result)
    figures = _figures(result)
    write_section_files(out, "end_to_end", figures, doc)
    summary.extend(_summary_rows(result))
    section = Section(
        title="End to end: one survey from INS/GNSS to validation, right and wrong calibration",
        checks=_checks(result),
        paragraphs=_paragraphs(result),
        tables=_tables(result),
        figures=tuple(figures),
    )
    return section, doc
