"""Figures of the end-to-end demo: the survey, the clocks, control points and wall per case.

Each figure compares the calibration cases of one simulated survey
(`kinsync.demo.end_to_end`): the correct calibration and the deliberately wrong
ones, on common axes and colour scales so that the damage reads at a glance.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import matplotlib as mpl

mpl.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from scipy import stats

from kinsync._typing import FloatArray
from kinsync.errors import InputError
from kinsync.frames import ecef_to_ned, geodetic_to_ecef
from kinsync.ins.compare import Comparison
from kinsync.ins.measurements import GnssData
from kinsync.ins.solution import NavSolution
from kinsync.report.figures import png_bytes
from kinsync.report.numbers import format_p_value
from kinsync.report.style import report_figure
from kinsync.sim.scene import Scene, TargetKind
from kinsync.trajectory import Trajectory
from kinsync.validation import ControlPointReport, FlatnessResult

__all__ = [
    "clock_cases_figure",
    "control_point_cases_figure",
    "survey_figure",
    "wall_cases_figure",
]

_CASE_COLOURS = ("C2", "C3", "tab:purple", "C1", "tab:brown")
_CASE_MARKERS = ("o", "s", "^", "D", "v")
_CELLS_PER_MAP = 400


def _local_ne(lat_lon_h: FloatArray, origin: tuple[float, float, float]) -> FloatArray:
    ecef = geodetic_to_ecef(lat_lon_h[:, 0], lat_lon_h[:, 1], lat_lon_h[:, 2])
    out: FloatArray = ecef_to_ned(ecef, *origin)[:, :2]
    return out


@report_figure
def survey_figure(
    scene: Scene,
    truth: Trajectory,
    gnss: GnssData,
    comparison: Comparison,
    solution: NavSolution,
) -> bytes:
    """Plan of the survey and the INS/GNSS position error against the truth.

    Left: the driven path in the scene frame (m, East right, North up), coloured by
    speed, the GNSS fixes, the wall, sync and control targets. Right: the position error
    of the solution (N, E, D, mm) along the drive with its reported 3-sigma band.

    Parameters
    ----------
    scene : Scene
        Scene of the survey (its local NED frame is the plan's frame).
    truth : Trajectory
        True trajectory, geodetic with velocities.
    gnss : GnssData
        GNSS antenna fixes.
    comparison : Comparison
        ``compare_to_truth(solution, truth)``.
    solution : NavSolution
        The solution compared (its ``std_pos_ned_m`` gives the band).

    Returns
    -------
    bytes
        PNG image.

    Raises
    ------
    InputError
        A truth without geodetic positions or velocities, or a comparison with no epoch.
    """
    if truth.lat_lon_h is None or truth.vel_ned_m_s is None:
        msg = "survey_figure: the truth must be geodetic with velocities"
        raise InputError(msg)
    if comparison.n_epochs == 0:
        msg = "survey_figure: the comparison holds no epoch"
        raise InputError(msg)
    origin = scene.origin_lat_lon_h
    path = _local_ne(truth.lat_lon_h, origin)
    speed = np.hypot(truth.vel_ned_m_s[:, 0], truth.vel_ned_m_s[:, 1])
    fixes = _local_ne(np.column_stack([gnss.lat_deg, gnss.lon_deg, gnss.h_m]), origin)
    fig, (ax_map, ax_err) = plt.subplots(
        1, 2, figsize=(14, 5.2), gridspec_kw={"width_ratios": [1, 1.3]}
    )
    step = max(1, path.shape[0] // 2000)
    art = ax_map.scatter(
        path[::step, 1], path[::step, 0], c=speed[::step], s=3, cmap="viridis", rasterized=True
    )
    fig.colorbar(art, ax=ax_map, label="speed (m/s)")
    ax_map.plot(
        fixes[:, 1], fixes[:, 0], ".", ms=1.5, color="0.6", label="GNSS fixes (antenna)",
        rasterized=True,
    )  # fmt: skip
    for k, wall in enumerate(scene.walls):
        ax_map.plot(
            [wall.start_ne_m[1], wall.end_ne_m[1]],
            [wall.start_ne_m[0], wall.end_ne_m[0]],
            color="k",
            lw=3,
            label="wall" if k == 0 else None,
        )
    kinds: tuple[tuple[TargetKind, str, str], ...] = (
        ("sync", "*", "C3"),
        ("control", "o", "C0"),
    )
    for kind, marker, colour in kinds:
        targets = scene.targets_of_kind(kind)
        if not targets:
            continue
        c = np.array([t.centre_ned_m for t in targets])
        ax_map.plot(
            c[:, 1], c[:, 0], marker, ms=9 if kind == "sync" else 5, color=colour, ls="none",
            label=f"{kind} targets",
        )  # fmt: skip
        for t, (n, e) in zip(targets, c[:, :2], strict=True):
            ax_map.annotate(t.name, (e, n), textcoords="offset points", xytext=(4, 4), fontsize=7)
    ax_map.set_aspect("equal")
    ax_map.set_xlabel("East (m)")
    ax_map.set_ylabel("North (m)")
    ax_map.set_title("Survey: path, GNSS, wall, sync and control targets")
    ax_map.grid(visible=True, alpha=0.3)
    ax_map.legend(fontsize=7, loc="upper left")
    t_rel = comparison.t_s - comparison.t_s[0]
    std = np.array(
        [np.interp(comparison.t_s, solution.t_s, solution.std_pos_ned_m[:, i]) for i in range(3)]
    ).T
    for i, (axis, colour) in enumerate(zip("NED", ("C0", "C1", "C2"), strict=True)):
        ax_err.plot(t_rel, comparison.err_pos_ned_m[:, i] * 1e3, color=colour, lw=0.8,
                    label=f"{axis} error")  # fmt: skip
        ax_err.fill_between(t_rel, -3e3 * std[:, i], 3e3 * std[:, i], color=colour, alpha=0.12)
    rms = comparison.rms_pos_ned_m
    ax_err.set_title(
        "INS/GNSS solution - truth (band: reported 3 sigma); RMS N/E/D "
        f"{rms[0] * 1e3:.1f}/{rms[1] * 1e3:.1f}/{rms[2] * 1e3:.1f} mm",
        fontsize=10,
    )
    ax_err.set_xlabel("time since the start of the solution (s)")
    ax_err.set_ylabel("position error (mm)")
    ax_err.grid(visible=True, alpha=0.3)
    ax_err.legend(fontsize=8, loc="upper right")
    return png_bytes(fig)


@report_figure
def clock_cases_figure(
    t_rel_s: FloatArray,
    cases: Sequence[tuple[str, FloatArray]],
    std_s: FloatArray,
    spans: Sequence[tuple[str, float, float]] = (),
) -> bytes:
    """True time error of each calibration case along the scan.

    Parameters
    ----------
    t_rel_s : ndarray, shape (n,)
        Time along the scan (s from its first profile).
    cases : sequence of (str, ndarray of shape (n,))
        Case label and its time error (s): record read minus record that should be.
        The first case is drawn with the band ``±3 std_s``.
    std_s : ndarray, shape (n,)
        Standard deviation of the first case's clock (s), e.g. Method B's.
    spans : sequence of (str, float, float)
        Labelled time spans to shade (s, same origin as ``t_rel_s``), e.g. the passes
        past the control targets and the wall.

    Returns
    -------
    bytes
        PNG image.
    """
    t = np.asarray(t_rel_s, dtype=np.float64)
    fig, ax = plt.subplots(figsize=(11, 4.2))
    shades = {"control": "C0", "wall": "0.4"}
    seen: set[str] = set()
    for label, lo, hi in spans:
        kind = "wall" if "wall" in label else "control"
        ax.axvspan(lo, hi, color=shades[kind], alpha=0.12,
                   label=None if kind in seen else ("wall passes" if kind == "wall"
                                                    else "control-target passes"))  # fmt: skip
        seen.add(kind)
    for k, (label, err) in enumerate(cases):
        colour = _CASE_COLOURS[k % len(_CASE_COLOURS)]
        ax.plot(t, np.asarray(err) * 1e3, color=colour, lw=1.8, label=label)
        if k == 0:
            e = np.asarray(err) * 1e3
            band = 3e3 * np.asarray(std_s)
            ax.fill_between(t, e - band, e + band, color=colour, alpha=0.2,
                            label=f"{label}: 3 sigma of the clock")  # fmt: skip
    ax.axhline(0.0, color="k", lw=0.8)
    ax.set_xlabel("time along the scan (s)")
    ax.set_ylabel("time error (ms)")
    ax.set_title("Time error of each calibration: record read minus record that should be")
    ax.grid(visible=True, alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")
    return png_bytes(fig)


def _visit_key(report: ControlPointReport) -> list[tuple[str, int]]:
    return [(d.observation.name, d.observation.visit) for d in report.differences]


@report_figure
def control_point_cases_figure(
    cases: Sequence[tuple[str, ControlPointReport]], pass_of_visit: Sequence[int] = ()
) -> bytes:
    """Along-track differences dY per control-point visit, one series per case.

    Left: dY (mm, cloud - control, vehicle frame) of every visit in time order, each
    case a series (the visits of the first case set the order; a visit missing in
    another case is left blank). Right: dY against the along-track speed of the target
    in the vehicle frame, with each case's fitted time-error line ``c + tau s`` where
    the term is testable.

    Parameters
    ----------
    cases : sequence of (str, ControlPointReport)
        Case label and its report.
    pass_of_visit : sequence of int, optional
        Pass number of each visit of the first case (for the tick labels).

    Returns
    -------
    bytes
        PNG image.

    Raises
    ------
    InputError
        No case, or a first case without differences.
    """
    if not cases or not cases[0][1].differences:
        msg = "control_point_cases_figure: the first case has no control-point differences"
        raise InputError(msg)
    keys = _visit_key(cases[0][1])
    index = {key: i for i, key in enumerate(keys)}
    fig, (ax_v, ax_s) = plt.subplots(
        1, 2, figsize=(14, 4.8), gridspec_kw={"width_ratios": [1.5, 1]}
    )
    for k, (label, report) in enumerate(cases):
        colour = _CASE_COLOURS[k % len(_CASE_COLOURS)]
        marker = _CASE_MARKERS[k % len(_CASE_MARKERS)]
        dy = report.diff_vehicle_m()[:, 1] * 1e3
        x = np.array([index.get(key, -1) for key in _visit_key(report)])
        ok = x >= 0
        ax_v.plot(x[ok], dy[ok], marker, color=colour, ms=6, ls="none", label=label)
        s = np.array([d.along_speed_m_s for d in report.differences])
        ax_s.plot(s, dy, marker, color=colour, ms=5, ls="none", label=label)
        te = report.time_error
        if te.testable and math.isfinite(report.intercept_m):
            grid = np.linspace(float(s.min()), float(s.max()), 20)
            word = "significant" if te.significant else "not significant"
            ax_s.plot(
                grid, (report.intercept_m + te.estimate * grid) * 1e3, color=colour, lw=1.2,
                label=f"fit: tau {te.estimate * 1e3:+.2f} ± {te.std * 1e3:.2f} ms ({word})",
            )  # fmt: skip
    ticks = [
        f"{name}" + (f" p{pass_of_visit[i] + 1}" if i < len(pass_of_visit) else f" v{visit}")
        for i, (name, visit) in enumerate(keys)
    ]
    ax_v.set_xticks(range(len(keys)), ticks, rotation=60, fontsize=7)
    ax_v.axhline(0.0, color="k", lw=0.8)
    ax_v.set_ylabel("dY cloud - control (mm, vehicle forward)")
    ax_v.set_title("Along-track offset of every control-point visit")
    ax_v.grid(visible=True, alpha=0.3)
    ax_v.legend(fontsize=8, loc="upper left")
    ax_s.axhline(0.0, color="k", lw=0.8)
    ax_s.set_xlabel("along-track speed of the target in the vehicle frame (m/s)")
    ax_s.set_ylabel("dY (mm)")
    ax_s.set_title("dY against speed: the slope is the time error")
    ax_s.grid(visible=True, alpha=0.3)
    ax_s.legend(fontsize=7, loc="upper left")
    return png_bytes(fig)


def _residual_grid(
    result: FlatnessResult, u_edges: FloatArray, v_edges: FloatArray
) -> np.ma.MaskedArray[tuple[int, ...], np.dtype[np.float64]]:
    grid = stats.binned_statistic_2d(
        result.u_m, result.v_m, result.residual_m * 1e3, statistic="mean", bins=[u_edges, v_edges]
    )
    return np.ma.masked_invalid(grid.statistic.T)


@report_figure
def wall_cases_figure(
    cases: Sequence[tuple[str, Sequence[FlatnessResult]]], pass_names: Sequence[str] = ()
) -> bytes:
    """Wall residual maps, one row per case, one column per pass, on one colour scale.

    Each map is the mean signed distance from the fitted plane (mm) in cells of the
    wall (u along it, v up it); the colour scale is shared by all maps (symmetric, at
    the 99th percentile of all cell means) so that a flat and a bent wall compare
    directly. The last column draws the fitted quadratic surface minus the plane along
    the middle of the wall for every pass of the case. Titles give the curvature F-test
    and the bow.

    Parameters
    ----------
    cases : sequence of (str, sequence of FlatnessResult)
        Case label and one flatness result per pass (the same number for every case).
    pass_names : sequence of str, optional
        Name of each pass (column titles).

    Returns
    -------
    bytes
        PNG image.

    Raises
    ------
    InputError
        No case, a case without passes, or cases with different numbers of passes.
    """
    if not cases or not cases[0][1]:
        msg = "wall_cases_figure: give at least one case with one pass"
        raise InputError(msg)
    n_pass = len(cases[0][1])
    if any(len(r) != n_pass for _, r in cases):
        msg = "wall_cases_figure: every case needs the same number of passes"
        raise InputError(msg)
    names = list(pass_names) + [f"pass {i + 1}" for i in range(len(pass_names), n_pass)]
    grids = []
    lim = 0.1
    for _, results in cases:
        row = []
        for r in results:
            ext_u, ext_v = max(r.extent_u_m, 1e-6), max(r.extent_v_m, 1e-6)
            ny = int(np.clip(round(math.sqrt(_CELLS_PER_MAP * ext_v / ext_u)), 4, 200))
            nx = int(np.clip(round(_CELLS_PER_MAP / ny), 4, 1000))
            u_edges = np.linspace(float(r.u_m.min()), float(r.u_m.max()), nx + 1)
            v_edges = np.linspace(float(r.v_m.min()), float(r.v_m.max()), ny + 1)
            g = _residual_grid(r, u_edges, v_edges)
            filled = g.compressed()
            if filled.size:
                lim = max(lim, float(np.percentile(np.abs(filled), 99)))
            row.append((u_edges, v_edges, g))
        grids.append(row)
    fig, axes = plt.subplots(
        len(cases),
        n_pass + 1,
        figsize=(5.0 * n_pass + 4.5, 3.3 * len(cases)),
        squeeze=False,
        layout="constrained",
    )
    art = None
    for i, ((label, results), row) in enumerate(zip(cases, grids, strict=True)):
        ax_bend = axes[i, n_pass]
        for j, (r, (u_edges, v_edges, g)) in enumerate(zip(results, row, strict=True)):
            ax = axes[i, j]
            art = ax.pcolormesh(u_edges, v_edges, g, cmap="RdBu_r", vmin=-lim, vmax=lim,
                                rasterized=True)  # fmt: skip
            if r.curvature_significant:
                word = "CURVED"
            elif r.p_value < 1.0 - r.level:
                word = f"bend below the {r.min_bow_m * 1e3:g} mm tolerance"
            else:
                word = "flat"
            ax.set_title(
                f"{label}, {names[j]}: {word}\nF {r.f_statistic:.3g}, "
                f"{format_p_value(r.p_value)}, "
                f"bow {r.bow_m * 1e3:.1f} mm, RMS {r.rms_m * 1e3:.1f} mm",
                fontsize=8,
            )
            ax.set_xlabel("u along the wall (m)", fontsize=8)
            ax.set_ylabel("v up (m)", fontsize=8)
            line_u = np.linspace(float(r.u_m.min()), float(r.u_m.max()), 100)
            line_v = np.full_like(line_u, float(np.mean(r.v_m)))
            ax_bend.plot(line_u, r.bend_m(line_u, line_v) * 1e3, lw=1.8, label=names[j])
        ax_bend.axhline(0.0, color="k", lw=0.8)
        ax_bend.set_title(f"{label}: quadratic - plane, mid-height", fontsize=8)
        ax_bend.set_xlabel("u along the wall (m)", fontsize=8)
        ax_bend.set_ylabel("bend (mm)", fontsize=8)
        ax_bend.grid(visible=True, alpha=0.3)
        ax_bend.legend(fontsize=7, loc="upper left")
    lows, highs = zip(*(axes[i, n_pass].get_ylim() for i in range(len(cases))), strict=True)
    for i in range(len(cases)):
        axes[i, n_pass].set_ylim(min(lows), max(highs))
    if art is not None:
        fig.colorbar(art, ax=axes[:, :n_pass].ravel().tolist(), label="mean residual (mm)",
                     shrink=0.8)  # fmt: skip
    return png_bytes(fig)
