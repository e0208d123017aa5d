"""Demo sections for Method A and sphere fitting on real returns.

Simulate a rotating-table campaign, estimate, plan; and fit the real sphere passes of
the CIDCO set when ``../shared`` is beside the checkout.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from kinsync._text import counted
from kinsync.demo.files import write_section_files
from kinsync.demo.reference_data import reference_candidates
from kinsync.demo.tolerances import LATENCY_TABLE, ONE_ERROR_SOURCE, SIGMA_CONSISTENT
from kinsync.fit import SphereFit, segment_sphere
from kinsync.io.cidco import read_cidco_pass
from kinsync.io.passes import read_passes
from kinsync.latency.passes import SpherePass
from kinsync.latency.planning import LatencyPlan, TableDesign, plan_latency_experiment
from kinsync.latency.sphere import SphereLatencyResult, estimate_latency_sphere
from kinsync.report.fit_figures import sphere_residual_figure
from kinsync.report.html import Figure, Section, Table
from kinsync.report.latency_figures import latency_per_rate_figure, plan_figure
from kinsync.report.verdict import Check
from kinsync.sim.rotating_table import simulate_rotating_table, write_simulation
from kinsync.sim.table_config import RotatingTableConfig

__all__ = ["cidco_candidates", "cidco_section", "find_cidco_folder", "method_a_section"]

Summary = list[tuple[str, str, str]]

DEMO_LATENCY_S = 0.00421
TABLE_SEED = 1
"""Seed of the simulated rotating-table campaign."""


@dataclass(frozen=True, eq=False)
class _MethodARun:
    """The simulated campaign as read back, its estimate and the planner's bound."""

    truth: dict[str, Any]
    passes: list[SpherePass]
    result: SphereLatencyResult
    plan: LatencyPlan


def _simulate_and_estimate(out_dir: Path, progress: Callable[[str], None] | None) -> _MethodARun:
    """Simulate the table into ``method-a-passes/``, read it back, estimate and plan."""
    config = RotatingTableConfig(latency_s=DEMO_LATENCY_S, seed=TABLE_SEED)
    if progress:
        progress("Method A: simulating the rotating table")
    sim = simulate_rotating_table(config)
    folder = out_dir / "method-a-passes"
    write_simulation(sim, folder, file_format="laz")
    if progress:
        progress("Method A: fitting spheres and estimating the latency")
    passes = read_passes(folder)
    result = estimate_latency_sphere(passes, radius_m=config.sphere_radius_m)
    plan = plan_latency_experiment(TableDesign())
    return _MethodARun(truth=sim.truth, passes=passes, result=result, plan=plan)


def _summary_row(run: _MethodARun) -> tuple[str, str, str]:
    """The (capability, scenario, result) row of the terminal summary."""
    result = run.result
    err_ms = (result.latency_s - DEMO_LATENCY_S) * 1e3
    return (
        "Method A latency",
        f"simulated table, tau = {DEMO_LATENCY_S * 1e3:g} ms, {counted(len(run.passes), 'pass')}",
        (
            f"{result.latency_s * 1e3:.4f} +- {result.latency_std_s * 1e3:.4f} ms "
            f"(error {err_ms:+.4f} ms; plan predicted {run.plan.latency_std_s * 1e3:.4f})"
        ),
    )


def _rate_table(run: _MethodARun) -> Table:
    """Latency per table rate, with the planner's sigma beside the estimate's."""
    rows = [
        [*r.row_text(), f"{p.latency_std_s * 1e3:.4f}"]
        for r, p in zip(run.result.per_rate, run.plan.per_rate, strict=True)
    ]
    return Table(
        caption="Latency per table rate",
        headers=(
            "rate (deg/s)",
            "points",
            "centre sigma (mm)",
            "latency (ms)",
            "latency sigma (ms)",
            "first-order (ms)",
            "planner sigma (ms)",
        ),
        rows=rows,
    )


def _figures(run: _MethodARun) -> tuple[Figure, ...]:
    """Latency per rate, the +6 deg/s pool's sphere residuals and the planner."""
    six = next(r for r in run.result.per_rate if r.rate_deg_s == 6.0)
    pooled = np.concatenate(
        [p.points_ned_m for p in run.passes if p.rate_deg_s == six.plus.rate_deg_s]
    )
    return (
        Figure(
            caption="Latency per table rate (exact model, 1-sigma bars), the first-order "
            "formula, the combined estimate and the truth; right: pool centres pushed apart "
            "by omega*tau*D",
            png=latency_per_rate_figure(run.result, truth_latency_s=DEMO_LATENCY_S),
        ),
        Figure(
            caption="Sphere fit of the +6 deg/s pool (15 passes, clutter removed): residuals",
            png=sphere_residual_figure([("+6 deg/s pool, radius 0.1 m", six.plus.fit)], [pooled]),
        ),
        Figure(
            caption="Planner: Cramér-Rao latency sigma per rate and against passes",
            png=plan_figure(run.plan),
        ),
    )


def _scatter_text(result: SphereLatencyResult) -> str:
    """The passes' own centres against their pools, in words (an error shared by a pass)."""
    if result.pass_scatter is None:
        return "the passes' own centres were not fitted"
    return f"each pass's own centre against its pool: {result.pass_scatter.text()}"


def _paragraphs(run: _MethodARun) -> tuple[str, ...]:
    """The campaign and its result, in words."""
    result, plan = run.result, run.plan
    return (
        (
            "A profile scanner and an IMU turn on a table (6 rates, 15 passes each way, "
            "2 mm range noise, levelling error, optical centre off the axis, floor and "
            f"stand clutter) past a sphere of radius {run.truth['sphere_radius_m']:g} m at "
            "1.5 m. The IMU records lag the "
            f"scanner by {DEMO_LATENCY_S * 1e3:g} ms; the simulated acquisition software "
            "georeferences with them and writes one LAZ file per pass. kinsync reads the "
            "folder, segments the sphere from the clutter, fits one centre per signed "
            "rate along the scanner rays and estimates the latency from the rotation "
            "between the clockwise and counter-clockwise centres."
        ),
        (
            f"Result: {result.latency_s * 1e3:.4f} +- {result.latency_std_s * 1e3:.4f} ms "
            f"against {DEMO_LATENCY_S * 1e3:g} ms; {result.agreement_text()}; "
            f"{_scatter_text(result)}. "
            "Planner bound for this design: "
            f"{plan.latency_std_s * 1e3:.4f} ms; "
            f"{plan.passes_for_target(1e-4)} pass(es) per rate and direction reach 0.1 ms."
        ),
    )


def _checks(run: _MethodARun) -> tuple[Check, ...]:
    """Method A's verdict: the latency against the truth, and whether its σ is honest."""
    result = run.result
    err_ms = (result.latency_s - DEMO_LATENCY_S) * 1e3
    std_ms = result.latency_std_s * 1e3
    return (
        Check(
            "latency error against the simulated truth",
            err_ms,
            LATENCY_TABLE,
            std_ms,
            detail=f"estimate {result.latency_s * 1e3:.4f} ms, truth {DEMO_LATENCY_S * 1e3:g} ms",
        ),
        Check(
            "latency error in units of its stated σ",
            abs(err_ms) / std_ms,
            SIGMA_CONSISTENT,
        ),
    )


def _sphere_checks(worst: tuple[str, float], others_mm: float) -> tuple[Check, ...]:
    """The real passes' verdict: every pass fits a sphere of radius 0.2 m to 10 mm RMS."""
    name, rms_mm = worst
    return (
        Check(
            "worst pass's residual RMS with the nominal 0.2 m radius",
            rms_mm,
            ONE_ERROR_SOURCE,
            detail=f"{name}; every other pass {others_mm:.1f} mm or less",
        ),
    )


def method_a_section(
    out_dir: Path, summary: Summary, progress: Callable[[str], None] | None = None
) -> Section:
    """Simulate the published set-up, write it as a pass folder, read it back, estimate."""
    run = _simulate_and_estimate(out_dir, progress)
    summary.append(_summary_row(run))
    figures = _figures(run)
    doc = {"estimate": run.result.as_document(), "plan": run.plan.as_document(), "truth": run.truth}
    write_section_files(out_dir, "method_a", figures, doc)
    return Section(
        title="Method A: latency from a sphere on a rotating table",
        paragraphs=_paragraphs(run),
        tables=(_rate_table(run),),
        figures=figures,
        checks=_checks(run),
    )


def cidco_candidates() -> list[Path]:
    """Where the CIDCO passes are looked for (`kinsync.demo.reference_data`)."""
    return reference_candidates("cidco-port-de-quebec")


def find_cidco_folder() -> Path | None:
    """The CIDCO sphere passes in ``../shared`` beside the working folder or the checkout."""
    return next((c for c in cidco_candidates() if (c / "sphere1").is_dir()), None)


def _fit_document(fit: SphereFit) -> dict[str, Any]:
    """One sphere fit as ``cidco.json`` holds it (metres)."""
    return {
        "radius_m": float(fit.radius_m),
        "residual_rms_m": float(fit.residual_rms_m),
        "centre_std_m": [float(v) for v in fit.center_std_m],
        "centre_std_norm_m": float(np.linalg.norm(fit.center_std_m)),
    }


def cidco_section(folder: Path, out_dir: Path, summary: Summary) -> Section:
    """Fit every real CIDCO pass with free and fixed (0.2 m) radius.

    Writes ``cidco.json`` (the table's numbers per pass) and ``cidco_1.png`` (the
    residual figure) into ``out_dir``.
    """
    rows = []
    passes_doc: list[dict[str, Any]] = []
    residual_fits: list[tuple[str, SphereFit]] = []
    residual_points = []
    free_radii = []
    fixed_rms_mm: list[tuple[str, float]] = []
    for path in sorted(folder.glob("sphere*/passage_*.txt")):
        cp = read_cidco_pass(path)
        free = segment_sphere(cp.points_ecef_m, radius_bounds_m=(0.1, 0.4))
        fixed = segment_sphere(cp.points_ecef_m, radius_m=0.2)
        free_radii.append(free.radius_m)
        label = f"{path.parent.name}/{path.stem}"
        fixed_rms_mm.append((label, fixed.residual_rms_m * 1e3))
        passes_doc.append(
            {
                "pass": label,
                "returns": len(cp.points_ecef_m),
                "free_radius": _fit_document(free),
                "fixed_radius": _fit_document(fixed),
            }
        )
        rows.append(
            [
                label,
                str(len(cp.points_ecef_m)),
                f"{free.radius_m:.4f}",
                f"{free.residual_rms_m * 1e3:.1f}",
                f"{np.linalg.norm(free.center_std_m) * 1e3:.2f}",
                f"{fixed.residual_rms_m * 1e3:.1f}",
                f"{np.linalg.norm(fixed.center_std_m) * 1e3:.2f}",
            ]
        )
        if label in ("sphere1/passage_3", "sphere1/passage_4"):
            residual_fits += [(f"{label} free", free), (f"{label} fixed 0.2 m", fixed)]
            residual_points += [cp.points_ecef_m, cp.points_ecef_m]
    summary.append(
        (
            "sphere fit, real data",
            f"CIDCO Port de Quebec, {len(rows)} vessel passes",
            f"free radius {min(free_radii):.3f}-{max(free_radii):.3f} m",
        )
    )
    ranked = sorted(fixed_rms_mm, key=lambda item: item[1])
    checks = _sphere_checks(ranked[-1], ranked[-2][1] if len(ranked) > 1 else math.nan)
    figures = (
        Figure(
            caption="Residuals of a distorted pass (sphere1/passage_3) and a clean one "
            "(sphere1/passage_4), free and fixed radius",
            png=sphere_residual_figure(residual_fits, residual_points),
        ),
    )
    doc = {"folder": str(folder), "fixed_radius_m": 0.2, "free_radius_bounds_m": [0.1, 0.4],
           "passes": passes_doc}  # fmt: skip
    write_section_files(out_dir, "cidco", figures, doc)
    return Section(
        title="Sphere fitting on real returns (CIDCO, Port de Québec)",
        checks=checks,
        paragraphs=(
            (
                "Twelve vessel passes over two spherical targets (a 2D profiler, 100-490 "
                "returns each, open data from CIDCO's LidarToolkit). Every pass is segmented "
                "and fitted in ECEF with a free radius and with the nominal radius 0.2 m; the "
                "centre sigma is the norm of the three axis sigmas. sphere1/passage_3 shows "
                "per-profile stripes of +-30 mm in its residuals: a distorted pass, visible "
                "at once in the figure."
            ),
        ),
        tables=(
            Table(
                caption="Free against fixed radius",
                headers=(
                    "pass",
                    "returns",
                    "free radius (m)",
                    "free RMS (mm)",
                    "free centre sigma (mm)",
                    "fixed RMS (mm)",
                    "fixed centre sigma (mm)",
                ),
                rows=rows,
            ),
        ),
        figures=figures,
    )
