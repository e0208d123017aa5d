"""Demo section: mount self-calibration from survey lines (boresight, lever arm, latency).

Two simulated patch tests (`kinsync.sim.patch_test`) are written as a survey's files
(``patch-test-vehicle/``, ``patch-test-vessel/``: SBET, one LAZ per line, the nominal
mount, the truth), read back and calibrated through the same pipeline as ``kinsync
calibrate mount`` asking for everything; the planner's prediction for the same design
stands beside each result. When the CIDCO data sit in ``../shared``, the boresight is
calibrated on the 12 real sphere passes. The vehicle's lines are calibrated once more the
way most surveys are, lever arm held (``--estimate boresight,latency``) with its 3 cm
uncertainty stated in the mount file: the sigma with and without what the held lever
arm's error does (`kinsync.calibration.held`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from kinsync.calibration.estimator import CalibrationOptions, calibrate_mount
from kinsync.calibration.parameters import LATENCY, REPORT_SCALE, mount_values
from kinsync.calibration.planning import NavigationErrors, PlanResult, plan_calibration
from kinsync.calibration.result import CalibrationResult
from kinsync.demo.files import write_section_files
from kinsync.demo.tolerances import LATENCY_CALIBRATION, SIGMA_CONSISTENT
from kinsync.fit import segment_sphere
from kinsync.frames import ecef_to_geodetic, rotation_ned_to_ecef
from kinsync.io.cidco import ACQUISITION_MOUNT, read_cidco_lines, read_cidco_pass
from kinsync.io.mount_file import read_mount, write_mount
from kinsync.mount import MountUncertainty
from kinsync.pipelines.calibration import calibrate_files
from kinsync.report.calibration import overlap_figure
from kinsync.report.html import Figure, Section, Table
from kinsync.report.verdict import COVERAGE_FACTOR, Check
from kinsync.sim.patch_config import PatchTestConfig, Scenario
from kinsync.sim.patch_test import PatchTestSimulation, simulate_patch_test, write_patch_test

__all__ = ["calibration_section"]

Summary = list[tuple[str, str, str]]

ALL = ("boresight", "lever", "latency")
DENSITY: dict[Scenario, float] = {"vehicle": 0.05, "vessel": 0.1}
SEED: dict[Scenario, int] = {"vehicle": 11, "vessel": 12}
CIDCO_ESTIMATE = ("boresight", "lever_z", "latency")
HELD_ESTIMATE = ("boresight", "latency")
HELD_LEVER_STD_M = 0.03
"""The lever arm's stated uncertainty in the held-lever calibration (m, each axis): a
taped lever arm; the simulator's nominal lever arm is 3/-2/4 cm off."""


@dataclass(frozen=True, eq=False)
class _ScenarioRun:
    scenario: Scenario
    truth: np.ndarray  # seven values, report units
    result: CalibrationResult
    plan: PlanResult
    n_points: int
    gps_week: int
    design: PatchTestSimulation  # the same design without errors, as the plan sees it


def _drawn_errors(config: PatchTestConfig) -> NavigationErrors:
    """The errors the simulation draws, as the plan takes them."""
    return NavigationErrors(
        config.range_noise_m, config.std_pos_ned_m, config.std_att_deg, config.error_corr_time_s
    )


def _run_scenario(scenario: Scenario, out_dir: Path) -> _ScenarioRun:
    """Simulate, write the files, calibrate them as the CLI does, plan the same design."""
    config = PatchTestConfig(scenario=scenario, density=DENSITY[scenario], seed=SEED[scenario])
    sim = simulate_patch_test(config)
    folder = out_dir / f"patch-test-{scenario}"
    write_patch_test(sim, folder)
    run = calibrate_files(
        sorted(folder.glob("line_*.laz")),
        [folder / "trajectory.out"],
        read_mount(folder / "mount.toml"),
        CalibrationOptions(estimate=ALL),
        gps_week=sim.gps_week,
    )
    design = simulate_patch_test(
        PatchTestConfig(
            scenario=scenario,
            density=DENSITY[scenario],
            range_noise_m=0.0,
            std_pos_ned_m=(0.0, 0.0, 0.0),
            std_att_deg=(0.0, 0.0, 0.0),
        )
    )
    plan = plan_calibration(
        design.lines, design.mount_true, CalibrationOptions(estimate=ALL), _drawn_errors(config)
    )
    truth = mount_values(sim.mount_true) * REPORT_SCALE
    return _ScenarioRun(scenario, truth, run.result, plan, run.n_points, sim.gps_week, design)


def _held_lever(out_dir: Path, vehicle: _ScenarioRun) -> tuple[CalibrationResult, PlanResult]:
    """The vehicle's files again, lever arm held with its stated uncertainty; its plan."""
    folder = out_dir / "patch-test-vehicle"
    unc = MountUncertainty(lever_arm_body_m=(HELD_LEVER_STD_M,) * 3)
    mount_path = folder / "mount_lever_uncertainty.toml"
    write_mount(replace(read_mount(folder / "mount.toml"), uncertainty=unc), mount_path)
    run = calibrate_files(
        sorted(folder.glob("line_*.laz")),
        [folder / "trajectory.out"],
        read_mount(mount_path),
        CalibrationOptions(estimate=HELD_ESTIMATE),
        gps_week=vehicle.gps_week,
    )
    design = vehicle.design
    plan = plan_calibration(
        design.lines,
        design.mount_true,
        CalibrationOptions(estimate=HELD_ESTIMATE),
        vehicle.plan.errors,
        held=unc,
    )
    return run.result, plan


@dataclass(frozen=True)
class _LaterRun:
    """A later survey that holds the vessel's calibrated mount and estimates the latency."""

    result: CalibrationResult
    truth_ms: float
    independent_ms: float  # the latency's sigma with the held values taken as independent
    mount_path: Path


def _later_survey(out_dir: Path, vessel: _ScenarioRun) -> _LaterRun:
    """The vessel's calibrated mount, written and read back, held on a new survey.

    The same design and true mount with new navigation errors and range noise; only the
    latency is estimated, so the boresight and lever arm come from the written mount,
    with their correlations.
    """
    path = out_dir / "patch-test-vessel" / "calibrated.toml"
    write_mount(vessel.result.mount, path)
    calibrated = read_mount(path)
    config = PatchTestConfig(scenario="vessel", density=DENSITY["vessel"], seed=SEED["vessel"])
    later = simulate_patch_test(replace(config, seed=SEED["vessel"] + 100).with_nominal(calibrated))
    result = calibrate_mount(later.lines, calibrated, CalibrationOptions(estimate=("latency",)))
    latency = result.parameter("latency_ms")
    assert result.held is not None
    j = result.held.estimated.index(LATENCY)
    held_ms = float(result.held.std_if_independent[j] * REPORT_SCALE[LATENCY])
    return _LaterRun(
        result=result,
        truth_ms=float(later.mount_true.latency_s * 1000.0),
        independent_ms=math.hypot(latency.data_std, held_ms),
        mount_path=path,
    )


def _later_table(later: _LaterRun) -> Table:
    lat = later.result.parameter("latency_ms")
    err = lat.value - later.truth_ms
    rows = [
        ["σ with the correlations (written)", _fmt(lat.std), _fmt(abs(err) / lat.std)],
        ["  of which the data", _fmt(lat.data_std), "-"],
        ["  of which the held values", _fmt(lat.held_std), "-"],
        ["σ if the held errors were independent", _fmt(later.independent_ms),
         _fmt(abs(err) / later.independent_ms)],
    ]  # fmt: skip
    return Table(
        caption=(
            f"later vessel survey holding {later.mount_path.name}: latency "
            f"{lat.value:.3f} ms for a true {later.truth_ms:.3f} ms (error {err:+.3f} ms)"
        ),
        headers=("latency (ms)", "value", "|error| / σ"),
        rows=tuple(tuple(r) for r in rows),
    )


def _later_paragraph(later: _LaterRun) -> str:
    lat = later.result.parameter("latency_ms")
    return (
        "A calibration's estimates are correlated: the same speed changes tell the "
        "latency from the lever arm x, the same walls the pitch from the yaw. The "
        "calibrated mount carries those correlations in `[uncertainty.correlation]` beside "
        "the σ (`kinsync mount check` prints the strongest). A later survey that holds "
        "that mount and estimates only the latency adds what the held values' errors do "
        f"with their full covariance: here {lat.held_std:.2f} ms, for {lat.std:.2f} ms in "
        f"all; taken as independent the same σ would give {later.independent_ms:.2f} ms. "
        "`benchmarks/bench_calibration_two_stage.py` repeats this over 30 surveys."
    )


def _later_check(later: _LaterRun) -> Check:
    lat = later.result.parameter("latency_ms")
    return Check(
        "later vessel survey holding the calibrated mount (with its correlations): latency "
        "error in units of its stated σ",
        abs(lat.value - later.truth_ms) / lat.std,
        SIGMA_CONSISTENT,
        detail=f"σ {lat.std:.2f} ms; {later.independent_ms:.2f} ms if taken as independent",
    )


def _held_scores(result: CalibrationResult, truth: np.ndarray) -> tuple[float, float, str]:
    """Largest |error| / sigma with the held part, and with the data's sigma alone."""
    rows = [
        (abs(p.value - truth[i]), p.std, p.data_std, p.name)
        for i, p in enumerate(result.parameters)
        if p.status in ("estimated", "weak")
    ]
    if not rows:
        return math.nan, math.nan, "none determined"
    total = max(rows, key=lambda r: r[0] / r[1])
    return total[0] / total[1], max(r[0] / r[2] for r in rows), total[3]


def _held_table(result: CalibrationResult, plan: PlanResult, truth: np.ndarray) -> Table:
    rows = []
    for i, (p, planned) in enumerate(zip(result.parameters, plan.parameters, strict=True)):
        determined = p.status in ("estimated", "weak")
        err = p.value - truth[i]
        rows.append(
            [
                p.name,
                f"{truth[i]:.4f}",
                calibrated_cell(p.value, p.status),
                _fmt(err) if determined else "-",
                _fmt(p.data_std),
                _fmt(abs(err) / p.data_std) if determined else "-",
                _fmt(p.std),
                _fmt(abs(err) / p.std) if determined else "-",
                _fmt(planned.std),
                p.status,
            ]
        )
    headers = ("parameter", "truth", "calibrated", "error", "sigma, data", "|error| / sigma",
               "sigma with held lever", "|error| / sigma", "planned sigma", "status")  # fmt: skip
    caption = (
        "vehicle patch test, lever arm held (3/-2/4 cm off, stated sigma "
        f"{HELD_LEVER_STD_M * 100:.0f} cm per axis): --estimate boresight,latency"
    )
    return Table(caption=caption, headers=headers, rows=rows)


def _held_check(result: CalibrationResult, truth: np.ndarray) -> Check:
    score, data_only, name = _held_scores(result, truth)
    return Check(
        "simulated vehicle patch test, lever arm held with its stated uncertainty: largest "
        "error of a determined parameter, in units of its stated σ",
        score,
        SIGMA_CONSISTENT,
        detail=f"{name}; with the data's σ alone (lever arm taken as exact) {data_only:.1f} σ",
    )


def calibrated_cell(value: float, status: str) -> str:
    """The "calibrated" cell: the value when determined, else what it was held at."""
    return f"{value:.4f}" if status in ("estimated", "weak") else f"held at {value:.4f}"


def _fmt(value: float, digits: int = 3) -> str:
    return "-" if not math.isfinite(value) else f"{value:.{digits}g}"


def _scenario_table(run: _ScenarioRun) -> Table:
    rows = []
    for i, (p, planned) in enumerate(zip(run.result.parameters, run.plan.parameters, strict=True)):
        determined = p.status in ("estimated", "weak")
        rows.append(
            [
                p.name,
                f"{run.truth[i]:.4f}",
                calibrated_cell(p.value, p.status),
                _fmt(p.value - run.truth[i]) if determined else "-",
                _fmt(p.std),
                _fmt(p.formal_std),
                _fmt(planned.std),
                p.status,
            ]
        )
    headers = ("parameter", "truth", "calibrated", "error", "sigma", "formal sigma",
               "planned sigma", "status")  # fmt: skip
    caption = (
        f"{run.scenario} patch test: {len(run.result.lines)} lines, {run.n_points} returns, "
        f"{len(run.result.features)} planar patches"
    )
    return Table(caption=caption, headers=headers, rows=rows)


def _acquired_scatter_m(folder: Path) -> list[tuple[str, float, float]]:
    """Per sphere: horizontal and vertical scatter of the centres fitted to columns 1-3."""
    centres: dict[str, list[np.ndarray]] = {}
    for path in sorted(folder.glob("sphere*/passage_*.txt")):
        fit = segment_sphere(read_cidco_pass(path).points_ecef_m, radius_bounds_m=(0.1, 0.4))
        centres.setdefault(path.parent.name, []).append(fit.center_m)
    out = []
    for name, cs in centres.items():
        c = np.array(cs)
        lat, lon, _ = ecef_to_geodetic(c.mean(axis=0))
        ned = (c - c.mean(axis=0)) @ rotation_ned_to_ecef(float(lat), float(lon))
        h = float(np.sqrt(np.mean(ned[:, 0] ** 2 + ned[:, 1] ** 2)))
        out.append((name, h, float(np.sqrt(np.mean(ned[:, 2] ** 2)))))
    return out


def _cidco(folder: Path) -> tuple[CalibrationResult, list[tuple[str, float, float]]]:
    lines = read_cidco_lines(folder)
    options = CalibrationOptions(features="spheres", estimate=CIDCO_ESTIMATE)
    return calibrate_mount(lines, ACQUISITION_MOUNT, options), _acquired_scatter_m(folder)


def _cidco_table(result: CalibrationResult, acquired: list[tuple[str, float, float]]) -> Table:
    rows = []
    for (name, h_acq, v_acq), f in zip(acquired, result.features, strict=True):
        rows.append(
            [
                f"{name} ({f.description})",
                str(f.n_passes),
                f"{h_acq * 100:.1f} / {v_acq * 100:.1f}",
                f"{f.scatter_before_m[0] * 100:.1f} / {f.scatter_before_m[1] * 100:.1f}",
                f"{f.scatter_after_m[0] * 100:.1f} / {f.scatter_after_m[1] * 100:.1f}",
            ]
        )
    headers = ("sphere", "passes", "as acquired (columns 1-3)", "acquisition mount, DIN attitude",
               "calibrated")  # fmt: skip
    return Table(
        caption="Scatter of the per-pass sphere centres, horizontal / vertical RMS (cm)",
        headers=headers,
        rows=rows,
    )


def _parameter_table(result: CalibrationResult, caption: str) -> Table:
    rows = [
        [p.name, f"{p.prior:.4f}", calibrated_cell(p.value, p.status), _fmt(p.std), p.status]
        for p in result.parameters
    ]
    return Table(caption, ("parameter", "prior", "calibrated", "sigma", "status"), rows)


def _figure(result: CalibrationResult) -> bytes:
    return overlap_figure(
        result.overlaps_before,
        result.overlaps_after,
        [f.description for f in result.features],
        [f.kind for f in result.features],
    )


def _check(run: _ScenarioRun) -> Check:
    """Is the stated σ honest? The largest error of a determined parameter in σ units."""
    scores = [
        (abs(p.value - run.truth[i]) / p.std, p.name)
        for i, p in enumerate(run.result.parameters)
        if p.status in ("estimated", "weak") and p.std is not None and p.std > 0.0
    ]
    score, name = max(scores) if scores else (math.nan, "none determined")
    return Check(
        f"simulated {run.scenario} patch test: largest error of a determined parameter, "
        "in units of its stated σ",
        score,
        SIGMA_CONSISTENT,
        detail=f"{name}; {len(scores)} parameters determined",
    )


def latency_caveat(runs: Sequence[tuple[str, float, float, float]]) -> str | None:
    """What the σ checks leave unsaid about the latency, from the numbers; None if nothing.

    Parameters
    ----------
    runs : sequence of (str, float, float, float)
        Per scenario: its name, the calibrated latency, its σ and the true latency (ms).

    Returns
    -------
    str or None
        A sentence naming each latency that fails the ``latency from survey lines``
        tolerance by the report's rule (``|error| + 2σ``), with why; None when all meet it.
    """
    limit = LATENCY_CALIBRATION.limit
    out = [(n, v, sd, t) for n, v, sd, t in runs if not abs(v - t) + COVERAGE_FACTOR * sd <= limit]
    if not out:
        return None
    shown = "; ".join(f"{n} {v:.2f} ± {sd:.2f} ms for a true {t:.2f} ms" for n, v, sd, t in out)
    sigmas = [sd for _, _, sd, _ in out]
    return (
        "The self-calibration's checks test that each stated σ holds the error, not the "
        f"latency's size. Its latency here: {shown}. A σ of {min(sigmas):.1f}-"
        f"{max(sigmas):.1f} ms exceeds the {LATENCY_CALIBRATION.describe()} share of "
        f"'{LATENCY_CALIBRATION.name}' (judged |error| + 2σ): this simulated patch-test "
        "design cannot determine the latency to 1 ms. Latency at that level comes from a "
        "rotating table (Method A) or from object space (Method B)."
    )


def _summary_text(run: _ScenarioRun) -> str:
    lat = run.result.parameter("latency_ms")
    held = [p.name for p in run.result.parameters if p.status == "unobservable"]
    text = f"latency {lat.value:.2f} +- {lat.std:.2f} ms (true {run.truth[6]:.2f})"
    return text + (f"; {', '.join(held)} not determined" if held else "")


def _paragraphs(runs: list[_ScenarioRun]) -> list[str]:
    vehicle, vessel = runs
    ratios = [p.std / p.formal_std for r in runs for p in r.result.parameters
              if p.status in ("estimated", "weak") and p.formal_std > 0.0]  # fmt: skip
    return [
        (
            "A surveyor without a rotating table calibrates the mount from the survey itself: "
            "lines driven both ways at two speeds over ground, walls and roofs. Each line is "
            "georeferenced with a candidate mount; planar patches seen by several lines are "
            "found automatically and must coincide. The estimator solves boresight, lever arm "
            "and latency with every patch as a nuisance parameter (Gauss-Newton, Tukey weights) "
            "and reports a standard deviation from the jackknife over lines, which holds the "
            "navigation errors that every return of a line shares; the formal sigma beside it "
            f"assumes independent returns and is {min(ratios):.0f}-{max(ratios):.0f} times "
            "smaller here. What the data "
            "cannot determine is held at its prior and said, with the data that would "
            "determine it."
        ),
        (
            f"Simulated: a car on a town block ({len(vehicle.result.lines)} lines, 5 and 12 m/s, "
            "a tilted 360-degree profiler) and a survey launch in a harbour channel "
            f"({len(vessel.result.lines)} lines, 2 and 4 m/s, 4-degree wave roll), with injected "
            "mount errors (boresight 0.25/-0.30/0.40 deg, lever arm 3/-2/4 cm, latency +5 ms), "
            "time-correlated navigation errors (2-3 cm, 0.005-0.01 deg, 20 s) and 1 cm range "
            "noise; the files are read back and calibrated as `kinsync calibrate mount` does. "
            "The car drives level lines, so its lever z moves every line alike and the patches "
            "absorb it: unobservable, as the planner predicts before the survey."
        ),
    ]


def _held_paragraph(result: CalibrationResult, plan: PlanResult, truth: np.ndarray) -> str:
    lat = result.parameter("latency_ms")
    planned = next(p for p in plan.parameters if p.name == "latency_ms")
    ratios = [
        r.std / q.std
        for r, q in zip(result.parameters, plan.parameters, strict=True)
        if r.status in ("estimated", "weak") and math.isfinite(q.std) and q.std > 0.0
    ]
    return (
        "Most surveys hold the lever arm at its taped value and calibrate boresight and "
        "latency. The jackknife over lines cannot see a lever-arm error: every line shares "
        "it. Here the held lever arm is 3/-2/4 cm off, and the calibration gives latency "
        f"{lat.value:.2f} ms for a true {truth[6]:.2f} ms, with a data sigma of "
        f"{lat.data_std:.2f} ms. With the lever arm's 3 cm uncertainty stated in the mount file "
        f"([uncertainty]), the sigma adds what that error does ({lat.held_std:.2f} ms, "
        "linearised at the solution) and holds the error. The certificate lists how far each "
        "held value moves each estimate; a value taken as exact that would matter is named in "
        "a warning. The planner predicts this before the survey (`kinsync calibrate plan "
        f"--estimate boresight,latency --lever-std-m {HELD_LEVER_STD_M:g}`): for this "
        f"design, a latency sigma of {planned.std:.2f} ms (the planned sigma column). The "
        f"calibration reports {min(ratios, default=math.nan):.1f}-"
        f"{max(ratios, default=math.nan):.1f} times the planned sigma: how far a held value "
        "moves an estimate depends on the returns each feature holds, which the plan's "
        "noise-free design only approximates."
    )


def calibration_section(
    out_dir: Path,
    summary: Summary,
    cidco_folder: Path | None = None,
    progress: Callable[[str], None] | None = None,
) -> tuple[Section, dict[str, Any]]:
    """Calibrate the simulated vehicle and vessel patch tests (and the CIDCO passes).

    Parameters
    ----------
    out_dir : Path
        Report folder: ``patch-test-vehicle/``, ``patch-test-vessel/`` (the data sets),
        ``calibration.json`` and ``calibration_N.png`` are written there.
    summary : list of (str, str, str)
        Gets one row per calibration.
    cidco_folder : Path, optional
        The CIDCO data set: its 12 passes are calibrated too.
    progress : callable, optional
        Called with what runs now (about a minute in all, six runs).

    Returns
    -------
    section : Section
    doc : dict
        What ``calibration.json`` holds: each calibration's document and the truth.
    """
    out_dir = Path(out_dir)
    say = progress or (lambda _: None)
    runs = []
    for scenario in ("vehicle", "vessel"):
        say(f"mount self-calibration: simulated {scenario} patch test, planned and calibrated")
        runs.append(_run_scenario(scenario, out_dir))
    tables = [_scenario_table(r) for r in runs]
    pngs = [_figure(r.result) for r in runs]
    captions = [f"{r.scenario}: each line's offset from each patch, along its normal, "
                "before and after" for r in runs]  # fmt: skip
    doc: dict[str, Any] = {
        r.scenario: {"truth": r.truth.tolist(), "result": r.result.as_document(),
                     "plan": r.plan.as_document()}
        for r in runs
    }  # fmt: skip
    for r in runs:
        summary.append(("mount self-calibration", f"simulated {r.scenario} patch test",
                        _summary_text(r)))  # fmt: skip
    say("mount self-calibration: vehicle with its lever arm held (3 cm stated)")
    held, held_plan = _held_lever(out_dir, runs[0])
    held_score, data_score, _ = _held_scores(held, runs[0].truth)
    tables.append(_held_table(held, held_plan, runs[0].truth))
    doc["vehicle_lever_held"] = {"truth": runs[0].truth.tolist(), "result": held.as_document(),
                                 "plan": held_plan.as_document()}  # fmt: skip
    summary.append(("mount self-calibration", "vehicle, lever arm held (3 cm stated)",
                    (f"largest error {held_score:.1f} σ with the held lever arm's share, "
                     f"{data_score:.1f} σ without")))  # fmt: skip
    say("mount self-calibration: a later vessel survey holding the calibrated mount")
    later = _later_survey(out_dir, runs[1])
    tables.append(_later_table(later))
    doc["vessel_later"] = {"truth_latency_ms": later.truth_ms,
                           "result": later.result.as_document(),
                           "latency_std_if_independent_ms": later.independent_ms}  # fmt: skip
    latencies = [
        (
            f"simulated {r.scenario}",
            r.result.parameter("latency_ms").value,
            r.result.parameter("latency_ms").std,
            float(r.truth[6]),
        )
        for r in runs
    ]
    paragraphs = _paragraphs(runs)
    paragraphs.append(_held_paragraph(held, held_plan, runs[0].truth))
    paragraphs.append(_later_paragraph(later))
    if cidco_folder is not None:
        say("mount self-calibration: the 12 CIDCO vessel passes (real data)")
        result, acquired = _cidco(cidco_folder)
        tables += [_cidco_table(result, acquired), _parameter_table(result, "CIDCO mount")]
        pngs.append(_figure(result))
        captions.append("CIDCO: per-pass sphere centres about their mean, before and after")
        doc["cidco"] = {"result": result.as_document(), "acquired_scatter_m": acquired}
        after = max(f.scatter_after_m[0] for f in result.features)
        summary.append(("mount self-calibration, real data", "CIDCO, 12 vessel passes",
                        (f"sphere centre scatter {max(h for _, h, _ in acquired) * 100:.0f} "
                        f"cm as acquired -> {after * 100:.1f} cm")))  # fmt: skip
        paragraphs.append(
            "Real data: the 12 CIDCO passes over two spheres, acquired with no boresight "
            "calibration, read with the vessel's DIN attitude (the acquisition's own "
            "columns 1-3 carry a pitch of the other sign, `kinsync.io.cidco`). Each sphere is "
            "fitted with a free radius, one centre for all its passes; boresight, lever z and "
            "latency asked for. The passes run at one speed past the targets: latency and "
            "lever z come back not determined, the boresight does."
        )
    figures = [Figure(caption=c, png=png) for png, c in zip(pngs, captions, strict=True)]
    write_section_files(out_dir, "calibration", figures, doc)
    section = Section(
        title="Mount self-calibration from survey lines",
        checks=(
            *(_check(r) for r in runs),
            _held_check(held, runs[0].truth),
            _later_check(later),
        ),
        caveats=tuple(c for c in (latency_caveat(latencies),) if c is not None),
        paragraphs=tuple(paragraphs),
        tables=tuple(tables),
        figures=tuple(figures),
    )
    return section, doc
