"""The demo: every capability run on built-in data, written as one report folder.

Sections: the error budgets of SPEC section 3; Method A on a simulated rotating-table
campaign; the PPS + ZDA clock model on simulated logs with faults; direct
georeferencing of a simulated million-point scan against analytic truth; INS/GNSS on a
simulated MEMS drive (and on the NaveGo set when ``../shared`` is present); Method B on
a simulated profile-scanner drive; the end-to-end chain on one simulated survey
(INS/GNSS -> Method B -> georeferencing -> validation) with the correct calibration, a
wrong latency and a wrong clock; validation of control points and wall flatness; and,
when the CIDCO data sit in ``../shared``, sphere fits on real vessel passes.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from kinsync.budget import (
    beach_scenario,
    latency_beam_error,
    period_error_budget,
    rolling_table_scenario,
    serial_transmission_time_s,
)
from kinsync.io.atomic import atomic_write_bytes, atomic_write_text, output_folder
from kinsync.report.demo_clock import clock_section
from kinsync.report.demo_end_to_end import end_to_end_section
from kinsync.report.demo_georef import georef_section
from kinsync.report.demo_ins import find_navego_folder, ins_section, navego_section
from kinsync.report.demo_method_a import cidco_section, find_cidco_folder, method_a_section
from kinsync.report.demo_method_b import method_b_section
from kinsync.report.demo_validation import validation_section
from kinsync.report.figures import beach_budget_figure, rolling_table_figure
from kinsync.report.html import Figure, Section, Table, render_report

__all__ = ["DemoResult", "run_demo"]

BEACH_LATENCIES_MS = (0.1, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0)
BEACH_RATES_DEG_S = (2.0, 5.0, 10.0, 20.0)
TABLE_LATENCIES_MS = (0.1, 1.0, 5.0)
SERIAL_CASES = ((115200.0, 14), (115200.0, 64), (9600.0, 14), (9600.0, 64))


@dataclass(frozen=True)
class DemoResult:
    """What the demo wrote and the headline figures it prints.

    Attributes
    ----------
    out_dir : Path
        Report folder.
    report_path : Path
        The HTML report.
    summary : tuple of (str, str, str)
        Rows of (capability, scenario, result) for the terminal summary.
    """

    out_dir: Path
    report_path: Path
    summary: tuple[tuple[str, str, str], ...]


def _mm(value_m: float | None) -> str:
    return "-" if value_m is None else f"{value_m * 1e3:.3f}"


def _budget_section(summary: list[tuple[str, str, str]]) -> tuple[Section, dict[str, object]]:
    sc = beach_scenario(50.0, 10.0, 10.0)
    rows = []
    doc_rows = []
    for ms in BEACH_LATENCIES_MS:
        b = latency_beam_error(sc, ms * 1e-3)
        rel = abs((b.vertical_error_m or 0.0) / (b.vertical_error_linear_m or math.inf) - 1.0) * 100
        rows.append(
            [
                f"{ms:g}",
                f"{math.degrees(b.attitude_error_rad):.4f}",
                _mm(b.vertical_error_m),
                _mm(b.horizontal_error_m),
                _mm(b.vertical_error_linear_m),
                f"{rel:.2f}",
            ]
        )
        doc_rows.append(
            {
                "latency_ms": ms,
                "vertical_error_m": b.vertical_error_m,
                "horizontal_error_m": b.horizontal_error_m,
                "vertical_error_linear_m": b.vertical_error_linear_m,
                "horizontal_error_linear_m": b.horizontal_error_linear_m,
            }
        )
    one_ms = latency_beam_error(sc, 1e-3)
    summary.append(
        (
            "latency budget",
            "beach 10 deg, 50 m, roll 10 deg/s, 1 ms",
            (
                f"vertical {_mm(one_ms.vertical_error_m)} mm, "
                f"horizontal {_mm(one_ms.horizontal_error_m)} mm"
            ),
        )
    )
    table_rows = []
    for ms in TABLE_LATENCIES_MS:
        worst = max(
            (
                latency_beam_error(rolling_table_scenario(el), ms * 1e-3)
                for el in (-10.0, 0.0, 10.0)
            ),
            key=lambda b: b.point_error_m,
        )
        table_rows.append(
            [f"{ms:g}", f"{math.degrees(worst.attitude_error_rad):.4f}", _mm(worst.point_error_m)]
        )
    summary.append(
        ("latency budget", "rolling table +-6 deg 1 Hz, wall 25 m, 1 ms", f"{table_rows[1][2]} mm")
    )
    serial_rows = []
    for baud, n in SERIAL_CASES:
        delay = serial_transmission_time_s(n, baud)
        serial_rows.append([f"{baud:g}", str(n), f"{delay * 1e3:.4f}"])
    summary.append(("serial budget", "14-byte FIFO at 115200 baud 8N1", f"{serial_rows[0][2]} ms"))
    period = period_error_budget(10000, 1e-6, 2.0)
    summary.append(
        (
            "period budget",
            "10000 profiles, dT = 1 us, 2 m/s",
            f"{period.time_error_s * 1e3:.3f} ms, {period.position_error_m * 1e3:.1f} mm",
        )
    )
    section = Section(
        title="Latency error budget (SPEC section 3)",
        paragraphs=(
            (
                "A latency tau under an angular rate omega is an attitude error omega*tau. "
                "Reference: a horizontal beam onto a beach sloping 10 deg at 50 m slant range "
                "under a 10 deg/s roll rate, computed with exact ray-plane geometry and the "
                "worse sign of the error; the small-angle values are shown beside them. Near "
                "grazing incidence the linearisation underestimates the error."
            ),
        ),
        tables=(
            Table(
                caption="Beach, 10 deg slope, 50 m, 10 deg/s roll",
                headers=(
                    "latency (ms)",
                    "attitude error (deg)",
                    "vertical (mm)",
                    "horizontal (mm)",
                    "vertical small-angle (mm)",
                    "small-angle off by (%)",
                ),
                rows=rows,
            ),
            Table(
                caption=(
                    "Rolling table +-6 deg at 1 Hz, turning 1 deg/s, 20 deg sector onto a wall "
                    "at 25 m (worst beam at peak roll rate)"
                ),
                headers=("latency (ms)", "attitude error (deg)", "point error (mm)"),
                rows=table_rows,
            ),
            Table(
                caption="Delay added by a serial receive FIFO (8N1: 10 bits per byte)",
                headers=("baud", "FIFO bytes", "delay (ms)"),
                rows=serial_rows,
            ),
            Table(
                caption="Profile clock: a period error accumulates as N * dT",
                headers=(
                    "profiles",
                    "period error (s)",
                    "speed (m/s)",
                    "time error (ms)",
                    "position error (mm)",
                ),
                rows=[
                    [
                        "10000",
                        "1e-06",
                        "2",
                        f"{period.time_error_s * 1e3:.3f}",
                        f"{period.position_error_m * 1e3:.1f}",
                    ]
                ],
            ),
        ),
        figures=(
            Figure(
                caption="Beach scenario: error against latency per roll rate "
                "(solid exact, dashed small-angle)",
                png=beach_budget_figure(50.0, 10.0, BEACH_RATES_DEG_S, BEACH_LATENCIES_MS),
            ),
            Figure(
                caption="Rolling table: point error across the 20 deg sector",
                png=rolling_table_figure(TABLE_LATENCIES_MS),
            ),
        ),
    )
    return section, {
        "beach": {"range_m": 50.0, "slope_deg": 10.0, "rate_deg_s": 10.0, "rows": doc_rows}
    }


def run_demo(out_dir: Path, progress: Callable[[str], None] | None = None) -> DemoResult:
    """Run every landed capability on built-in data and write the report folder.

    Parameters
    ----------
    out_dir : Path
        Folder to write (created if missing): ``report.html``, ``budget.json`` and the
        figures as PNG files.
    progress : callable, optional
        Called with a short label as each stage starts.

    Returns
    -------
    DemoResult
    """
    out_dir = output_folder(out_dir, "choose another --out")
    summary: list[tuple[str, str, str]] = []
    sections: list[Section] = []

    if progress:
        progress("error budgets")
    budget_section, budget_doc = _budget_section(summary)
    sections.append(budget_section)
    atomic_write_text(out_dir / "budget.json", json.dumps(budget_doc, indent=2) + "\n")
    for i, fig in enumerate(budget_section.figures):
        atomic_write_bytes(out_dir / f"budget_{i + 1}.png", fig.png)

    sections.append(method_a_section(out_dir, summary, progress))
    if progress:
        progress("clock model from simulated PPS + ZDA logs")
    sections.append(clock_section(out_dir, summary))
    if progress:
        progress("georeferencing a simulated scan")
    sections.append(georef_section(out_dir, summary))
    sections.append(ins_section(out_dir, summary, progress=progress)[0])
    navego = find_navego_folder()
    if navego is not None:
        sections.append(navego_section(navego, out_dir, summary, progress)[0])
    if progress:
        progress("Method B: profile scanner synchronised in object space")
    method_b, _ = method_b_section(out_dir, summary)
    sections.append(method_b)
    sections.append(end_to_end_section(out_dir, summary, progress)[0])
    if progress:
        progress("validation: control points and wall flatness, right and wrong calibration")
    sections.append(validation_section(out_dir, summary))
    cidco = find_cidco_folder()
    if cidco is not None:
        if progress:
            progress("sphere fits on the CIDCO real passes")
        sections.append(cidco_section(cidco, summary))

    if progress:
        progress("report")
    report_path = out_dir / "report.html"
    html_text = render_report(
        "kinsync demo report",
        "Every kinsync capability that has landed, run on built-in data.",
        sections,
    )
    atomic_write_text(report_path, html_text)
    return DemoResult(out_dir=out_dir, report_path=report_path, summary=tuple(summary))
