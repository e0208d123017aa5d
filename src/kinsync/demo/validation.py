"""Demo section for validation: correct against wrong calibration.

Control targets beside a road, driven at 5-20 m/s both ways, georeferenced with the
correct mount, with a 2 ms latency error and with a 0.1 deg boresight yaw error; a wall
on the outside of a tight right turn, georeferenced with the correct clock and with a
5 ms error. Every cloud comes from the compiled georeferencing kernel.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from kinsync.demo.tolerances import DETECTION, LATENCY_CALIBRATION, NO_FALSE_ALARM
from kinsync.georef import GeorefTrajectory, georeference
from kinsync.io.atomic import atomic_write_bytes, atomic_write_text
from kinsync.mount import Mount
from kinsync.report.html import Figure, Section, Table
from kinsync.report.numbers import format_p_value
from kinsync.report.validation_figures import (
    control_point_figure,
    plus_minus,
    wall_residual_figure,
)
from kinsync.report.verdict import Check
from kinsync.sim.validation_scene import (
    ControlTargetScene,
    SimulatedScan,
    WallScene,
    control_target_scene,
    curved_wall_scene,
)
from kinsync.validation import (
    CloudPoints,
    ControlPointReport,
    FlatnessResult,
    SignatureTest,
    fit_wall,
    select_box,
    validate_control_points,
)

__all__ = ["validation_section"]

Summary = list[tuple[str, str, str]]

LATENCY_ERROR_S = 0.002
HEADING_ERROR_DEG = 0.1
WALL_LATENCY_ERROR_S = 0.005
SCENE_SEED = 3
"""Seed of the control-target and wall scenes."""


def _cloud(scan: SimulatedScan, mount: Mount) -> CloudPoints:
    traj = GeorefTrajectory.from_trajectory(scan.trajectory, mount.latency_s)
    pos, inside = georeference(scan.t_s, scan.xyz_scanner_m, traj, mount)
    return CloudPoints(pos[inside], scan.t_s[inside], scan.intensity[inside])


def _cell(test: SignatureTest, scale: float) -> str:
    if not test.testable:
        return "not testable"
    verdict = "significant" if test.significant else "not significant"
    value = plus_minus(test.estimate * scale, test.std * scale)
    return f"{value} ({format_p_value(test.p_value)}, {verdict})"


@dataclass(frozen=True, eq=False)
class _ValidationRun:
    """The two scenes and their results, correct calibration first."""

    scene: ControlTargetScene
    reports: list[tuple[str, ControlPointReport]]
    wall: WallScene
    walls: list[tuple[str, FlatnessResult]]


def _control_point_reports(scene: ControlTargetScene) -> list[tuple[str, ControlPointReport]]:
    """Control-point reports with the correct, the late and the yawed mount."""
    scan = scene.scan
    b = scan.mount.boresight_rpy_deg
    cases: list[tuple[str, Mount]] = [
        ("correct calibration", scan.mount),
        ("latency error 2 ms", scan.mount.with_latency(LATENCY_ERROR_S)),
        (
            "boresight yaw error 0.1 deg",
            replace(scan.mount, boresight_rpy_deg=(b[0], b[1], b[2] + HEADING_ERROR_DEG)),
        ),
    ]
    reports: list[tuple[str, ControlPointReport]] = []
    for label, mount in cases:
        report = validate_control_points(
            _cloud(scan, mount),
            scene.control,
            scan.trajectory,
            centre="sphere",
            target_radius_m=scene.target_radius_m,
        )
        reports.append((label, report))
    return reports


def _wall_fits(wall: WallScene) -> list[tuple[str, FlatnessResult]]:
    """Wall flatness with the correct clock and with a 5 ms time error."""
    walls: list[tuple[str, FlatnessResult]] = []
    for label, latency in (("correct clock", 0.0), ("5 ms time error", WALL_LATENCY_ERROR_S)):
        cloud = _cloud(wall.scan, wall.scan.mount.with_latency(latency))
        walls.append(
            (label, fit_wall(cloud.pos_ecef_m[select_box(cloud.pos_ecef_m, wall.box_ecef_m)]))
        )
    return walls


def _simulate_and_validate() -> _ValidationRun:
    """Both scenes georeferenced right and wrong, and validated."""
    scene = control_target_scene(seed=SCENE_SEED)
    reports = _control_point_reports(scene)
    wall = curved_wall_scene(seed=SCENE_SEED)
    return _ValidationRun(scene=scene, reports=reports, wall=wall, walls=_wall_fits(wall))


def _document(run: _ValidationRun) -> dict[str, object]:
    """What ``validation.json`` holds: the reports (without the visits), truth and walls."""
    return {
        "control_points": {
            label: {
                k: v for k, v in r.as_document().items() if k not in ("observations", "missing")
            }
            for label, r in run.reports
        },
        "truth": {
            "latency_error_s": LATENCY_ERROR_S,
            "heading_error_deg": HEADING_ERROR_DEG,
            "wall_latency_error_s": WALL_LATENCY_ERROR_S,
        },
        "wall": {label: r.as_document() for label, r in run.walls},
    }


def _summary_rows(run: _ValidationRun) -> Summary:
    """The control-point and the wall rows of the terminal summary."""
    late = run.reports[1][1].time_error
    yaw = run.reports[2][1].heading_error
    clean = run.reports[0][1]
    false_alarm = clean.time_error.significant or clean.heading_error.significant
    wall, walls = run.wall, run.walls
    return [
        (
            "validation",
            "control targets 5-20 m/s, 2 ms latency / 0.1 deg yaw error",
            (
                f"time error {plus_minus(late.estimate * 1e3, late.std * 1e3)} ms, heading "
                f"{plus_minus(yaw.estimate, yaw.std)} deg; correct calibration: "
                + ("a signature flagged (false alarm)" if false_alarm else "nothing significant")
            ),
        ),
        (
            "validation",
            f"wall in a {wall.radius_m:g} m turn at {wall.speed_m_s:g} m/s, 5 ms error",
            (
                f"bow {walls[1][1].bow_m * 1e3:.1f} mm (F {walls[1][1].f_statistic:.0f}); "
                f"correct clock: bow {walls[0][1].bow_m * 1e3:.2f} mm, "
                f"{format_p_value(walls[0][1].p_value)}"
            ),
        ),
    ]


def _tables(run: _ValidationRun) -> tuple[Table, ...]:
    """The control-point signature tests and the wall flatness tests."""
    cp_rows = [
        [
            label,
            str(len(r.differences)),
            _cell(r.time_error, 1e3),
            _cell(r.heading_error, 1.0),
            f"{np.sqrt(np.mean(r.diff_vehicle_m()[:, 1] ** 2)) * 1e3:.1f}",
        ]
        for label, r in run.reports
    ]
    wall_rows = [
        [
            label,
            f"{r.rms_m * 1e3:.2f}",
            f"{r.bow_m * 1e3:.2f}",
            f"{r.f_statistic:.3g}",
            format_p_value(r.p_value, prefix=False),
            "yes" if r.curvature_significant else "no",
        ]
        for label, r in run.walls
    ]
    return (
        Table(
            caption="Control points: implied errors (estimate ± sigma, p-value)",
            headers=("case", "visits", "time error (ms)", "heading error (deg)", "RMS dY (mm)"),
            rows=cp_rows,
        ),
        Table(
            caption="Wall flatness: plane residuals and the curvature test",
            headers=("case", "RMS (mm)", "bow (mm)", "F", "p-value", "curvature at 99 %"),
            rows=wall_rows,
        ),
    )


def _paragraphs(run: _ValidationRun) -> tuple[str, ...]:
    """The two scenes and what each error does to them, in words."""
    scene, wall = run.scene, run.wall
    return (
        (
            f"{len(scene.control)} retro-reflective spheres (radius "
            f"{scene.target_radius_m:g} m) on both sides of a road, driven at "
            f"{', '.join(f'{v:g}' for v in sorted(set(scene.speeds_m_s)))} m/s in both "
            "directions by a profiler (250 profiles/s, 0.1 deg, 5 mm range noise) with "
            "2 mm survey and trajectory noise. Each visit's target is found by "
            "intensity and fitted as a sphere; the difference cloud - control is "
            "expressed in the vehicle frame at the moment of scanning. A time error "
            "shows as dY growing with speed, a heading error as dY of opposite sign "
            "left and right; both slopes are tested in one mixed model (pass and "
            "survey errors as random effects, Satterthwaite t-tests at 99 %)."
        ),
        (
            f"A 25 m wall on the outside of a right turn (radius {wall.radius_m:g} m at "
            f"{wall.speed_m_s:g} m/s, yaw rate up to "
            f"{np.degrees(wall.speed_m_s / wall.radius_m):.0f} deg/s), 6-10 m from the "
            "scanner, 5 mm range noise. A time error displaces each profile by "
            "tau (v + omega x r), which changes along the wall as the vehicle enters "
            "the turn: the wall bends. The residual RMS barely moves; the F-test of a "
            "quadratic surface against the plane does."
        ),
    )


def _checks(run: _ValidationRun) -> tuple[Check, ...]:
    """Validation's verdict: each error found, the correct calibration left alone."""
    clean, late, yawed = (r for _, r in run.reports)
    (_, wall_ok), (_, wall_late) = run.walls
    return (
        Check(
            f"a {LATENCY_ERROR_S * 1e3:g} ms latency error flagged by the control points "
            "(time signature)",
            late.time_error.p_value,
            DETECTION,
        ),
        Check(
            f"the {LATENCY_ERROR_S * 1e3:g} ms latency error as the control points measure it, "
            "minus the truth",
            (late.time_error.estimate - LATENCY_ERROR_S) * 1e3,
            LATENCY_CALIBRATION,
            late.time_error.std * 1e3,
        ),
        Check(
            f"a {HEADING_ERROR_DEG:g} deg boresight yaw error flagged (heading signature)",
            yawed.heading_error.p_value,
            DETECTION,
        ),
        Check(
            "correct calibration: time signature flagged by chance",
            clean.time_error.p_value,
            NO_FALSE_ALARM,
        ),
        Check(
            "correct calibration: heading signature flagged by chance",
            clean.heading_error.p_value,
            NO_FALSE_ALARM,
        ),
        Check(
            f"a {WALL_LATENCY_ERROR_S * 1e3:g} ms time error in the turn bends the wall "
            "(curvature test)",
            wall_late.p_value,
            DETECTION,
            detail=f"bow {wall_late.bow_m * 1e3:.1f} mm",
        ),
        Check(
            "correct clock: the wall found curved by chance",
            wall_ok.p_value,
            NO_FALSE_ALARM,
            detail=f"bow {wall_ok.bow_m * 1e3:.2f} mm",
        ),
    )


def validation_section(out_dir: Path, summary: Summary) -> Section:
    """Run the correct-vs-wrong calibration comparison on simulated data.

    Writes ``validation_control_points.png``, ``validation_wall_correct.png``,
    ``validation_wall_5ms.png`` and ``validation.json`` into ``out_dir`` and appends
    the headline figures to ``summary``.
    """
    run = _simulate_and_validate()
    cp_png = control_point_figure(run.reports[1][1])
    wall_pngs = [wall_residual_figure(r, title=f"Wall, {label}") for label, r in run.walls]
    atomic_write_bytes(out_dir / "validation_control_points.png", cp_png)
    atomic_write_bytes(out_dir / "validation_wall_correct.png", wall_pngs[0])
    atomic_write_bytes(out_dir / "validation_wall_5ms.png", wall_pngs[1])
    atomic_write_text(
        out_dir / "validation.json",
        json.dumps(_document(run), indent=2, allow_nan=True) + "\n",
    )
    summary.extend(_summary_rows(run))
    return Section(
        title="Validation: control points and wall flatness",
        checks=_checks(run),
        paragraphs=_paragraphs(run),
        tables=_tables(run),
        figures=(
            Figure(
                caption="Control points georeferenced with a 2 ms latency error: dY against "
                "speed (time error) and against the lateral position (heading)",
                png=cp_png,
            ),
            Figure(caption="Wall residuals, correct clock", png=wall_pngs[0]),
            Figure(caption="Wall residuals, 5 ms time error in the turn", png=wall_pngs[1]),
        ),
    )
