"""Figures of Method B: the clock regression, its residuals and the clock error along a drive."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import matplotlib as mpl

mpl.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from kinsync._typing import FloatArray
from kinsync.report.figures import png_bytes
from kinsync.report.style import report_figure
from kinsync.sync.object_space import ObjectSpaceResult

__all__ = ["clock_error_figure", "clock_regression_figure"]

_MARKERS = ("o", "s", "^", "D", "v", "P")


@report_figure
def clock_regression_figure(result: ObjectSpaceResult, title: str = "") -> bytes:
    """Sightings and the fitted clock line, with the residuals and their sigmas.

    Parameters
    ----------
    result : ObjectSpaceResult
        The estimate to show.
    title : str
        Figure title.

    Returns
    -------
    bytes
        PNG image: left, time of each crossing against its clock abscissa
        ``n + phi / 2 pi`` with the fitted line; right, residuals (ms) with 1-sigma bars.
    """
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(12, 4.2))
    x = np.array([s.profile + s.angle_rad / (2 * np.pi) for s in result.sightings])
    t = np.array([s.t_s for s in result.sightings])
    names = sorted({s.name for s in result.sightings})
    grid = np.linspace(0.0, max(float(x.max()), 1.0) * 1.05, 50)
    ax.plot(grid, result.period_s * grid, color="0.4", lw=1.0, label="fitted clock")
    for k, name in enumerate(names):
        on = np.array([s.name == name for s in result.sightings])
        mk = _MARKERS[k % len(_MARKERS)]
        ax.plot(x[on], t[on] - result.t0_s, mk, ms=6, label=f"sync point {name}")
        res = np.array([s.residual_s for s in result.sightings])[on] * 1e3
        std = np.array([s.std_s for s in result.sightings])[on] * 1e3
        ax2.errorbar(x[on], res, yerr=std, fmt=mk, ms=5, capsize=3, label=name)
    ax.set_xlabel("profile number + mirror angle / 2 pi")
    ax.set_ylabel("crossing time - t0 (s)")
    ax.set_title(
        title or f"T = {result.period_s * 1e3:.6f} ms, t0 sigma {result.t0_std_s * 1e3:.2f} ms"
    )
    ax.grid(visible=True, alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")
    ax2.axhline(0.0, color="0.4", lw=0.8)
    ax2.set_xlabel("profile number + mirror angle / 2 pi")
    ax2.set_ylabel("residual (ms), 1-sigma bars")
    ax2.set_title("regression residuals")
    ax2.grid(visible=True, alpha=0.3)
    return png_bytes(fig)


@report_figure
def clock_error_figure(
    profile: FloatArray,
    cases: Sequence[tuple[str, FloatArray, FloatArray]],
    speed_m_s: float,
) -> bytes:
    """Clock error along the drive against its propagated sigma.

    Parameters
    ----------
    profile : ndarray, shape (P,)
        Profile numbers.
    cases : sequence of (label, error_s, std_s)
        Estimated minus true profile start time (s) and the propagated sigma (s),
        each shape (P,).
    speed_m_s : float
        Vehicle speed (m/s) for the along-track axis on the right.

    Returns
    -------
    bytes
        PNG image.
    """
    fig, ax = plt.subplots(figsize=(10, 3.8))
    for label, err, std in cases:
        (line,) = ax.plot(profile, err * 1e3, lw=1.5, label=f"{label}: estimate - truth")
        ax.fill_between(
            profile,
            -3e3 * std,
            3e3 * std,
            color=line.get_color(),
            alpha=0.15,
            label=f"{label}: ±3σ",
        )
    ax.set_xlabel("profile number")
    ax.set_ylabel("clock error (ms)")
    ax.grid(visible=True, alpha=0.3)
    ax.legend(fontsize=8, loc="upper left", ncols=2)

    def ms_to_mm(ms: Any) -> Any:
        return np.asarray(ms) * speed_m_s

    def mm_to_ms(mm: Any) -> Any:
        return np.asarray(mm) / speed_m_s

    right = ax.secondary_yaxis("right", functions=(ms_to_mm, mm_to_ms))
    right.set_ylabel(f"along-track error at {speed_m_s:g} m/s (mm)")
    ax.set_title("Clock error along the drive (a period error dT grows as N dT)")
    return png_bytes(fig)
