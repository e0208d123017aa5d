"""Figures (matplotlib, Agg backend, PNG bytes)."""

from __future__ import annotations

import io
import itertools
from collections.abc import Sequence

import matplotlib as mpl

mpl.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from kinsync.budget import (
    beach_scenario,
    latency_beam_error,
    rolling_table_scenario,
)
from kinsync.report.style import REPORT_DPI, make_readable, report_figure

__all__ = ["beach_budget_figure", "png_bytes", "rolling_table_figure"]


def png_bytes(fig: Figure) -> bytes:
    """Render a figure to PNG bytes and close it, its text readable and its legends clear.

    See `kinsync.report.style.make_readable`.
    """
    make_readable(fig, REPORT_DPI)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=REPORT_DPI, bbox_inches="tight")
    plt.close(fig)
    return buf.getvalue()


@report_figure
def beach_budget_figure(
    range_m: float, slope_deg: float, rates_deg_s: Sequence[float], latencies_ms: Sequence[float]
) -> bytes:
    """Vertical and horizontal error against latency, exact and small-angle, per roll rate."""
    lat = np.asarray(latencies_ms, dtype=np.float64)
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
    every = max(1, len(lat) // 8)
    for rate, marker in zip(rates_deg_s, itertools.cycle("os^Dv"), strict=False):
        sc = beach_scenario(range_m, slope_deg, rate)
        budgets = [latency_beam_error(sc, ms * 1e-3) for ms in lat]
        v = np.array([abs(b.vertical_error_m or 0.0) for b in budgets]) * 1e3
        vl = np.array([abs(b.vertical_error_linear_m or 0.0) for b in budgets]) * 1e3
        h = np.array([b.horizontal_error_m for b in budgets]) * 1e3
        hl = np.array([b.horizontal_error_linear_m for b in budgets]) * 1e3
        # one colour and marker per rate; solid exact, dashed small-angle in every panel
        style = {"marker": marker, "markevery": every, "ms": 5}
        (line,) = axes[0].loglog(lat, v, ls="-", label=f"{rate:g} deg/s", **style)
        axes[0].loglog(lat, vl, "--", color=line.get_color(), alpha=0.7)
        axes[1].loglog(lat, h, ls="-", color=line.get_color(), label=f"{rate:g} deg/s", **style)
        axes[1].loglog(lat, hl, "--", color=line.get_color(), alpha=0.7)
        axes[2].semilogx(lat, (v / vl - 1.0) * 100.0, ls="-", color=line.get_color(), **style)
    axes[2].axhline(1.0, color="k", lw=0.8, ls=":")
    axes[2].set_xlabel("latency (ms)")
    axes[2].set_ylabel("exact / small-angle - 1 (%)")
    axes[2].set_title("Where the small-angle formula fails (vertical)")
    axes[2].grid(visible=True, which="both", alpha=0.3)
    for ax, what in zip(axes[:2], ("vertical", "horizontal"), strict=True):
        ax.set_xlabel("latency (ms)")
        ax.set_ylabel(f"{what} error (mm)")
        ax.grid(visible=True, which="both", alpha=0.3)
        ax.set_title(f"{what.capitalize()} error, {slope_deg:g} deg slope at {range_m:g} m")
    axes[0].legend(
        title="roll rate: solid exact,\ndashed small-angle (under\nthe solid where they agree)",
        loc="upper left",
    )
    return png_bytes(fig)


@report_figure
def rolling_table_figure(latencies_ms: Sequence[float], sector_deg: float = 20.0) -> bytes:
    """Point error across a scanned sector for a table rolling +-6 deg at 1 Hz, turning 1 deg/s."""
    elevations = np.linspace(-sector_deg / 2, sector_deg / 2, 41)
    fig, ax = plt.subplots(figsize=(6.5, 4))
    for ms in latencies_ms:
        err = [
            latency_beam_error(rolling_table_scenario(float(el)), ms * 1e-3).point_error_m * 1e3
            for el in elevations
        ]
        ax.plot(elevations, err, label=f"{ms:g} ms")
    ax.set_yscale("log")
    ax.set_xlabel("beam elevation (deg)")
    ax.set_ylabel("point error (mm)")
    ax.set_title("Rolling table, wall at 25 m: point error across the sector")
    ax.grid(visible=True, which="both", alpha=0.3)
    ax.legend(title="latency", loc="center right")
    return png_bytes(fig)
