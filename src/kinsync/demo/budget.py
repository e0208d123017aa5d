"""Demo section: the latency and period error budgets of SPEC section 3."""

from __future__ import annotations

import math

from kinsync.budget import (
    beach_scenario,
    latency_beam_error,
    period_error_budget,
    rolling_table_scenario,
    serial_transmission_time_s,
)
from kinsync.report.figures import beach_budget_figure, rolling_table_figure
from kinsync.report.html import Figure, Section, Table

__all__ = [
    "budget_section",
]

BEACH_LATENCIES_MS = (0.1, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0)


BEACH_RATES_DEG_S = (2.0, 5.0, 10.0, 20.0)


TABLE_LATENCIES_MS = (0.1, 1.0, 5.0)


SERIAL_CASES = ((115200.0, 14), (115200.0, 64), (9600.0, 14), (9600.0, 64))


def _mm(value_m: float | None) -> str:
    return "-" if value_m is None else f"{value_m * 1e3:.3f}"


def budget_section(summary: list[tuple[str, str, str]]) -> tuple[Section, dict[str, object]]:
    """The budgets section and its JSON document; appends its rows to ``summary``."""
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
