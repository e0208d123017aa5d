"""Demo section: the latency, serial and period error budgets.

A latency tau under an angular rate omega is an attitude error omega*tau, which moves a
point by the exact ray-plane geometry; a serial FIFO delays a message by its bytes'
transmission time; a profile clock's period error dT accumulates as N dT.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from kinsync.budget import (
    BeamErrorBudget,
    PeriodErrorBudget,
    Scenario,
    beach_scenario,
    latency_beam_error,
    period_error_budget,
    rolling_table_scenario,
    serial_transmission_time_s,
)
from kinsync.demo.tolerances import ONE_ERROR_SOURCE
from kinsync.report.figures import beach_budget_figure, rolling_table_figure
from kinsync.report.html import Figure, Section, Table
from kinsync.report.verdict import Check

__all__ = [
    "budget_section",
]

BEACH_LATENCIES_MS = (0.1, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0)


BEACH_RATES_DEG_S = (2.0, 5.0, 10.0, 20.0)


TABLE_LATENCIES_MS = (0.1, 1.0, 5.0)


SERIAL_CASES = ((115200.0, 14), (115200.0, 64), (9600.0, 14), (9600.0, 64))


Summary = list[tuple[str, str, str]]


@dataclass(frozen=True)
class _Budgets:
    """Every budget the section shows: table rows and the values the summary quotes."""

    beach_rows: list[list[str]]
    beach_doc_rows: list[dict[str, object]]
    beach_one_ms: BeamErrorBudget
    table_rows: list[list[str]]
    serial_rows: list[list[str]]
    period: PeriodErrorBudget


def _mm(value_m: float | None) -> str:
    return "-" if value_m is None else f"{value_m * 1e3:.3f}"


def _beach_rows(sc: Scenario) -> tuple[list[list[str]], list[dict[str, object]]]:
    """Table rows and JSON rows of the beach scenario, one per latency."""
    rows = []
    doc_rows: list[dict[str, object]] = []
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
    return rows, doc_rows


def _rolling_table_rows() -> list[list[str]]:
    """The worst beam of the rolling-table sector, one row per latency."""
    rows = []
    for ms in TABLE_LATENCIES_MS:
        worst = max(
            (
                latency_beam_error(rolling_table_scenario(el), ms * 1e-3)
                for el in (-10.0, 0.0, 10.0)
            ),
            key=lambda b: b.point_error_m,
        )
        rows.append(
            [f"{ms:g}", f"{math.degrees(worst.attitude_error_rad):.4f}", _mm(worst.point_error_m)]
        )
    return rows


def _serial_rows() -> list[list[str]]:
    """Delay of a serial receive FIFO, one row per (baud, bytes) case."""
    return [
        [f"{baud:g}", str(n), f"{serial_transmission_time_s(n, baud) * 1e3:.4f}"]
        for baud, n in SERIAL_CASES
    ]


def _budgets() -> _Budgets:
    """Compute every budget of the section."""
    sc = beach_scenario(50.0, 10.0, 10.0)
    beach_rows, beach_doc_rows = _beach_rows(sc)
    return _Budgets(
        beach_rows=beach_rows,
        beach_doc_rows=beach_doc_rows,
        beach_one_ms=latency_beam_error(sc, 1e-3),
        table_rows=_rolling_table_rows(),
        serial_rows=_serial_rows(),
        period=period_error_budget(10000, 1e-6, 2.0),
    )


def _summary_rows(budgets: _Budgets) -> Summary:
    """The (capability, scenario, result) rows of the terminal summary."""
    one_ms, period = budgets.beach_one_ms, budgets.period
    return [
        (
            "latency budget",
            "beach 10 deg, 50 m, roll 10 deg/s, 1 ms",
            (
                f"vertical {_mm(one_ms.vertical_error_m)} mm, "
                f"horizontal {_mm(one_ms.horizontal_error_m)} mm"
            ),
        ),
        (
            "latency budget",
            "rolling table +-6 deg 1 Hz, wall 25 m, 1 ms",
            f"{budgets.table_rows[1][2]} mm",
        ),
        (
            "serial budget",
            "14-byte FIFO at 115200 baud 8N1",
            f"{budgets.serial_rows[0][2]} ms",
        ),
        (
            "period budget",
            "10000 profiles, dT = 1 us, 2 m/s",
            f"{period.time_error_s * 1e3:.3f} ms, {period.position_error_m * 1e3:.1f} mm",
        ),
    ]


def _tables(budgets: _Budgets) -> tuple[Table, ...]:
    """The beach, rolling-table, serial and period tables."""
    period = budgets.period
    return (
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
            rows=budgets.beach_rows,
        ),
        Table(
            caption=(
                "Rolling table +-6 deg at 1 Hz, turning 1 deg/s, 20 deg sector onto a wall "
                "at 25 m (worst beam at peak roll rate)"
            ),
            headers=("latency (ms)", "attitude error (deg)", "point error (mm)"),
            rows=budgets.table_rows,
        ),
        Table(
            caption="Delay added by a serial receive FIFO (8N1: 10 bits per byte)",
            headers=("baud", "FIFO bytes", "delay (ms)"),
            rows=budgets.serial_rows,
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
    )


def _figures() -> tuple[Figure, ...]:
    """The beach and rolling-table figures."""
    return (
        Figure(
            caption="Beach scenario: error against latency per roll rate "
            "(solid exact, dashed small-angle)",
            png=beach_budget_figure(50.0, 10.0, BEACH_RATES_DEG_S, BEACH_LATENCIES_MS),
        ),
        Figure(
            caption="Rolling table: point error across the 20 deg sector",
            png=rolling_table_figure(TABLE_LATENCIES_MS),
        ),
    )


def _checks(budgets: _Budgets) -> tuple[Check, ...]:
    """The budget's verdict: a 1 ms latency on the beach against one error source."""
    one_ms = budgets.beach_one_ms
    return (
        Check(
            "size of the vertical error a 1 ms latency causes on the reference beach (10 deg "
            "slope at 50 m, 10 deg/s roll), exact geometry",
            abs(one_ms.vertical_error_m or 0.0) * 1e3,
            ONE_ERROR_SOURCE,
            detail=(
                f"vertical {_mm(one_ms.vertical_error_m)} mm (signed, as in the summary), "
                f"horizontal {one_ms.horizontal_error_m * 1e3:.1f} mm; computed, no noise"
            ),
        ),
    )


def budget_section(summary: Summary) -> tuple[Section, dict[str, object]]:
    """The budgets section and its JSON document; appends its rows to ``summary``."""
    budgets = _budgets()
    summary.extend(_summary_rows(budgets))
    section = Section(
        title="Latency error budget: what a timing error costs",
        paragraphs=(
            (
                "A latency tau under an angular rate omega is an attitude error omega*tau. "
                "Reference: a horizontal beam onto a beach sloping 10 deg at 50 m slant range "
                "under a 10 deg/s roll rate, computed with exact ray-plane geometry and the "
                "worse sign of the error; the small-angle values are shown beside them. Near "
                "grazing incidence the linearisation underestimates the error."
            ),
        ),
        tables=_tables(budgets),
        figures=_figures(),
        checks=_checks(budgets),
    )
    return section, {
        "beach": {
            "range_m": 50.0,
            "slope_deg": 10.0,
            "rate_deg_s": 10.0,
            "rows": budgets.beach_doc_rows,
        }
    }
