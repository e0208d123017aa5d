"""Figures of the INS/GNSS filter and smoother.

Error time series with their ±3σ envelopes (forward filter beside the smoothed
solution, GNSS outages shaded) and a map of the route with the solutions through an
outage.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import matplotlib as mpl

mpl.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes

from kinsync._typing import FloatArray
from kinsync.errors import InputError
from kinsync.report.figures import png_bytes
from kinsync.report.style import report_figure

__all__ = ["ErrorSeries", "error_envelope_figure", "route_map_figure"]

MAX_PLOT_POINTS = 4000
"""Samples drawn per curve; longer series are thinned to every k-th sample."""
_OUTAGE_COLOUR = "0.85"


@dataclass(frozen=True, eq=False)
class ErrorSeries:
    """One solution's errors and reported σ over time, for one column of the figure.

    Attributes
    ----------
    label : str
        Column title, e.g. "forward filter".
    t_s : ndarray, shape (n,)
        Epoch times (s).
    err : ndarray, shape (n, 3)
        Errors along three axes, in the unit of the figure (solution minus truth).
    std : ndarray, shape (n, 3)
        Reported 1σ of the same three errors, same unit.
    """

    label: str
    t_s: FloatArray
    err: FloatArray
    std: FloatArray

    def __post_init__(self) -> None:
        t = np.asarray(self.t_s, dtype=np.float64)
        err = np.asarray(self.err, dtype=np.float64)
        std = np.asarray(self.std, dtype=np.float64)
        if t.ndim != 1 or t.size < 2 or err.shape != (t.size, 3) or std.shape != (t.size, 3):
            msg = (
                f"ErrorSeries {self.label!r}: expected t_s (n,) with n >= 2 and err, std "
                f"(n, 3); got {t.shape}, {err.shape}, {std.shape}"
            )
            raise InputError(msg)
        object.__setattr__(self, "t_s", t)
        object.__setattr__(self, "err", err)
        object.__setattr__(self, "std", std)


def _thin(n: int) -> slice:
    return slice(None, None, max(1, math.ceil(n / MAX_PLOT_POINTS)))


def _shade(ax: Axes, spans: Sequence[tuple[float, float]], label: bool) -> None:
    for i, (a, b) in enumerate(spans):
        ax.axvspan(
            a, b, color=_OUTAGE_COLOUR, zorder=0,
            label="GNSS outage" if label and i == 0 else None,
        )  # fmt: skip


@report_figure
def error_envelope_figure(
    series: Sequence[ErrorSeries],
    axis_names: tuple[str, str, str],
    unit: str,
    title: str,
    outages_s: Sequence[tuple[float, float]] = (),
) -> bytes:
    """Errors against time with their ±3σ envelopes: one row per axis, one column per series.

    Each column has its own vertical scale (a forward solution drifting through an
    outage and a smoothed one differ by orders of magnitude); the share of epochs inside
    the envelope is given in each panel.

    Parameters
    ----------
    series : sequence of ErrorSeries
        Columns (e.g. forward filter, smoothed).
    axis_names : (str, str, str)
        Row labels, e.g. ("North", "East", "Down").
    unit : str
        Unit of ``err`` and ``std``, for the axis labels.
    title : str
        Figure title.
    outages_s : sequence of (start_s, end_s)
        GNSS outages to shade (s, the series' time scale).

    Returns
    -------
    bytes
        PNG image.

    Raises
    ------
    InputError
        No series.
    """
    if not series:
        msg = "error_envelope_figure: give at least one ErrorSeries"
        raise InputError(msg)
    fig, axes = plt.subplots(
        3, len(series), figsize=(6.2 * len(series), 7.5), sharex=True, squeeze=False
    )
    for col, s in enumerate(series):
        sl = _thin(s.t_s.size)
        t = s.t_s[sl]
        for row in range(3):
            ax = axes[row, col]
            _shade(ax, outages_s, label=row == 0)
            band = 3.0 * s.std[sl, row]
            ax.fill_between(t, -band, band, color="C0", alpha=0.18, lw=0, label="±3σ")
            ax.plot(t, s.err[sl, row], color="C3", lw=0.9, label="error")
            inside = float(np.mean(np.abs(s.err[:, row]) <= 3.0 * s.std[:, row]))
            ax.text(
                0.01, 0.97, f"{inside:.1%} of epochs within 3σ", transform=ax.transAxes,
                va="top", fontsize=8,
            )  # fmt: skip
            ax.grid(visible=True, alpha=0.3)
            ax.set_ylabel(f"{axis_names[row]} ({unit})")
            if row == 0:
                ax.set_title(s.label)
                ax.legend(fontsize=8, loc="upper right")
        axes[2, col].set_xlabel("time (s)")
    fig.suptitle(title)
    fig.tight_layout()
    return png_bytes(fig)


@report_figure
def route_map_figure(
    truth_ne_m: FloatArray,
    gnss_ne_m: FloatArray,
    solutions_ne_m: Sequence[tuple[str, FloatArray]],
    window: tuple[int, int],
    title: str,
) -> bytes:
    """The route from above, and a close-up of one stretch (a GNSS outage) per solution.

    Parameters
    ----------
    truth_ne_m : ndarray, shape (n, 2)
        True North, East (m) in a local frame, one row per solution epoch.
    gnss_ne_m : ndarray, shape (m, 2)
        GNSS fixes, same frame (m).
    solutions_ne_m : sequence of (str, ndarray of shape (n, 2))
        Labelled solutions on the truth's epochs, same frame (m).
    window : (int, int)
        Epoch index range ``[first, last)`` of the close-up (e.g. the outage).
    title : str
        Figure title.

    Returns
    -------
    bytes
        PNG image.

    Raises
    ------
    InputError
        Shapes that do not match or an empty window.
    """
    truth = np.asarray(truth_ne_m, dtype=np.float64)
    gnss = np.asarray(gnss_ne_m, dtype=np.float64)
    lo, hi = window
    if truth.ndim != 2 or truth.shape[1] != 2 or gnss.ndim != 2 or gnss.shape[1] != 2:
        msg = f"route_map_figure: expected (n, 2) arrays, got {truth.shape} and {gnss.shape}"
        raise InputError(msg)
    if not 0 <= lo < hi <= truth.shape[0]:
        msg = f"route_map_figure: window {window} is empty or outside 0..{truth.shape[0]}"
        raise InputError(msg)
    for label, sol in solutions_ne_m:
        if np.shape(sol) != truth.shape:
            msg = (
                f"route_map_figure: solution {label!r} has shape {np.shape(sol)}, not {truth.shape}"
            )
            raise InputError(msg)
    fig, (ax_map, ax_zoom) = plt.subplots(1, 2, figsize=(13, 5.4))
    sl = _thin(truth.shape[0])
    ax_map.plot(truth[sl, 1], truth[sl, 0], color="k", lw=1.0, label="truth")
    ax_map.plot(gnss[:, 1], gnss[:, 0], ".", ms=1.5, color="C2", label="GNSS fixes")
    ax_map.plot(
        truth[lo:hi, 1], truth[lo:hi, 0], color="C1", lw=3, alpha=0.6,
        label="GNSS outage",
    )  # fmt: skip
    ax_map.plot(truth[0, 1], truth[0, 0], "o", color="k", label="start (static alignment)")
    ax_map.set_aspect("equal", adjustable="datalim")
    ax_map.set_xlabel("East (m)")
    ax_map.set_ylabel("North (m)")
    ax_map.set_title("Route")
    ax_map.grid(visible=True, alpha=0.3)
    ax_map.legend(fontsize=8, loc="best")
    ax_zoom.plot(truth[lo:hi, 1], truth[lo:hi, 0], color="k", lw=2, label="truth")
    for i, (label, sol) in enumerate(solutions_ne_m):
        s = np.asarray(sol)
        ax_zoom.plot(s[lo:hi, 1], s[lo:hi, 0], lw=1.2, label=label)
        end = np.hypot(*(s[hi - 1] - truth[hi - 1]))
        ax_zoom.plot(s[hi - 1, 1], s[hi - 1, 0], "x", ms=7, color=ax_zoom.lines[-1].get_color())
        ax_zoom.annotate(
            f"{end:.2f} m", (s[hi - 1, 1], s[hi - 1, 0]), fontsize=8,
            xytext=(6, 4 - 12 * i), textcoords="offset points",
        )  # fmt: skip
    ax_zoom.set_aspect("equal", adjustable="datalim")
    ax_zoom.set_xlabel("East (m)")
    ax_zoom.set_ylabel("North (m)")
    ax_zoom.set_title("Through the outage (x: horizontal error at its last epoch)")
    ax_zoom.grid(visible=True, alpha=0.3)
    ax_zoom.legend(fontsize=8, loc="best")
    fig.suptitle(title)
    fig.tight_layout()
    return png_bytes(fig)
