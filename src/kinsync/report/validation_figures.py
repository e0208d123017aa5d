"""Figures of the validation checks: wall residual map, control points."""

from __future__ import annotations

import math

import matplotlib as mpl

mpl.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from scipy import stats

from kinsync.errors import InputError
from kinsync.report.figures import png_bytes
from kinsync.report.numbers import format_p_value, plus_minus
from kinsync.report.style import report_figure
from kinsync.validation import ControlPointReport, FlatnessResult, SignatureTest

__all__ = ["control_point_figure", "plus_minus", "wall_residual_figure"]

_POINTS_PER_CELL = 8
"""Points averaged per cell of the residual map (on average)."""
_MAX_CELLS = 20_000


def _verdict(test: SignatureTest, scale: float, unit: str) -> str:
    if not test.testable:
        return f"not testable: {test.reason}"
    word = "SIGNIFICANT" if test.significant else "not significant"
    return (
        f"{plus_minus(test.estimate * scale, test.std * scale)} {unit}, "
        f"{format_p_value(test.p_value)} ({word} at {test.level:.0%})"
    )


@report_figure
def wall_residual_figure(result: FlatnessResult, title: str = "Wall flatness") -> bytes:
    """Residual colour map of a wall and its bend along the wall.

    Left: the signed distance of the inliers from the fitted plane (mm), averaged in
    cells of the wall (u along it, v up it; about 8 points per cell, empty cells
    blank), on a diverging scale symmetric about zero at the 99th percentile of the
    cell means. Right: the median residual in bins along
    u (with the 25-75 % band) and the fitted quadratic surface minus the plane along the
    middle of the wall; the curvature F-test, p-value and bow in the title.

    Parameters
    ----------
    result : FlatnessResult
        From `kinsync.validation.fit_wall`.
    title : str
        Figure title prefix.

    Returns
    -------
    bytes
        PNG image.
    """
    u, v, w = result.u_m, result.v_m, result.residual_m * 1e3
    ext_u, ext_v = max(float(np.ptp(u)), 1e-6), max(float(np.ptp(v)), 1e-6)
    cells = min(max(u.size // _POINTS_PER_CELL, 100), _MAX_CELLS)
    ny = int(np.clip(round(math.sqrt(cells * ext_v / ext_u)), 4, 400))
    nx = int(np.clip(round(cells / ny), 4, 2000))
    grid = stats.binned_statistic_2d(u, v, w, statistic="mean", bins=[nx, ny])
    mean_mm = np.ma.masked_invalid(grid.statistic.T)
    filled = mean_mm.compressed()
    lim = max(float(np.percentile(np.abs(filled), 99)) if filled.size else 0.0, 0.1)
    fig, (ax_map, ax_bend) = plt.subplots(
        1, 2, figsize=(14, 4.6), gridspec_kw={"width_ratios": [3, 2]}
    )
    art = ax_map.pcolormesh(
        grid.x_edge, grid.y_edge, mean_mm, cmap="RdBu_r", vmin=-lim, vmax=lim, rasterized=True
    )
    fig.colorbar(
        art,
        ax=ax_map,
        label=f"mean residual per {ext_u / nx:.2g} x {ext_v / ny:.2g} m cell (mm)",
    )
    ax_map.set_xlabel("u along the wall (m)")
    ax_map.set_ylabel("v up the wall (m)")
    ax_map.set_title(
        f"{title}: RMS {result.rms_m * 1e3:.2f} mm, max {result.max_abs_m * 1e3:.1f} mm, "
        f"{result.n_points} points ({result.n_rejected} rejected)"
    )
    edges = np.linspace(float(u.min()), float(u.max()), 41)
    which = np.clip(np.digitize(u, edges) - 1, 0, edges.size - 2)
    centres, med, q25, q75 = [], [], [], []
    for k in range(edges.size - 1):
        wk = w[which == k]
        if wk.size >= 5:
            centres.append(0.5 * (edges[k] + edges[k + 1]))
            med.append(float(np.median(wk)))
            q25.append(float(np.percentile(wk, 25)))
            q75.append(float(np.percentile(wk, 75)))
    ax_bend.fill_between(centres, q25, q75, color="C0", alpha=0.2, label="25-75 % of points")
    ax_bend.plot(centres, med, "o", ms=3, color="C0", label="median residual per bin")
    line_u = np.linspace(float(u.min()), float(u.max()), 200)
    line_v = np.full_like(line_u, float(np.mean(v)))
    ax_bend.plot(
        line_u, result.bend_m(line_u, line_v) * 1e3, color="C3", lw=2,
        label="quadratic surface - plane (mid-height)",
    )  # fmt: skip
    ax_bend.axhline(0.0, color="k", lw=0.8)
    word = "SIGNIFICANT" if result.curvature_significant else "not significant"
    ax_bend.set_title(
        f"curvature {word} at {result.level:.0%}: F = {result.f_statistic:.3g}, "
        f"{format_p_value(result.p_value)}, bow {result.bow_m * 1e3:.2f} mm",
        fontsize=10,
    )
    ax_bend.set_xlabel("u along the wall (m)")
    ax_bend.set_ylabel("residual (mm)")
    ax_bend.grid(visible=True, alpha=0.3)
    ax_bend.legend(fontsize=8, loc="best")
    return png_bytes(fig)


@report_figure
def control_point_figure(report: ControlPointReport) -> bytes:
    """Along-track differences against speed and against the lateral position.

    Left: dY (mm) with the fitted heading term removed, against the along-track speed
    of the target in the vehicle frame, left and right targets apart, with the fitted
    line ``c + tau s`` (slope: the implied time error). Right: dY with the fitted time
    term removed against the lateral position X of the target (m), coloured by speed,
    with ``c - psi X`` (slope: minus the implied heading error). Untestable terms are
    not removed and get no line.

    Parameters
    ----------
    report : ControlPointReport
        From `kinsync.validation.validate_control_points`.

    Returns
    -------
    bytes
        PNG image.

    Raises
    ------
    InputError
        A report without differences.
    """
    if not report.differences:
        msg = "control_point_figure: the report has no control-point differences to draw"
        raise InputError(msg)
    dy = report.diff_vehicle_m()[:, 1] * 1e3
    s = np.array([d.along_speed_m_s for d in report.differences])
    x = np.array([d.lateral_m for d in report.differences])
    te, he = report.time_error, report.heading_error
    tau = te.estimate if te.testable else 0.0
    psi = math.radians(he.estimate) if he.testable else 0.0
    c_mm = report.intercept_m * 1e3 if math.isfinite(report.intercept_m) else 0.0
    fig, (ax_s, ax_x) = plt.subplots(1, 2, figsize=(13, 4.6))
    partial_s = dy + psi * x * 1e3
    # hollow markers of two shapes: targets at the same speed stay visible under each other
    for side, mask, colour, marker in (("left", x < 0, "C0", "o"), ("right", x >= 0, "C1", "^")):
        ax_s.plot(
            s[mask], partial_s[mask], marker, ms=6, mfc="none", mew=1.2, color=colour,
            label=f"{side} targets",
        )  # fmt: skip
    if te.testable:
        grid = np.linspace(float(s.min()), float(s.max()), 50)
        ax_s.plot(grid, c_mm + tau * grid * 1e3, color="k", lw=1.5, label="fit c + tau s")
    ax_s.set_xlabel("along-track speed of the target in the vehicle frame (m/s)")
    ax_s.set_ylabel("dY cloud - control (mm)" + (", heading term removed" if he.testable else ""))
    ax_s.set_title(f"time error: {_verdict(te, 1e3, 'ms')}", fontsize=10)
    ax_s.grid(visible=True, alpha=0.3)
    ax_s.legend(fontsize=8)
    partial_x = dy - tau * s * 1e3
    art = ax_x.scatter(x, partial_x, c=s, cmap="viridis", s=22)
    fig.colorbar(art, ax=ax_x, label="along-track speed (m/s)")
    if he.testable:
        grid = np.linspace(float(x.min()), float(x.max()), 50)
        ax_x.plot(grid, c_mm - psi * grid * 1e3, color="k", lw=1.5, label="fit c - psi X")
        ax_x.legend(fontsize=8)
    ax_x.axvline(0.0, color="0.5", lw=0.8, ls=":")
    ax_x.set_xlabel("lateral position of the target X (m, left < 0 < right)")
    ax_x.set_ylabel("dY (mm)" + (", time term removed" if te.testable else ""))
    ax_x.set_title(f"heading error: {_verdict(he, 1.0, 'deg')}", fontsize=10)
    ax_x.grid(visible=True, alpha=0.3)
    return png_bytes(fig)
