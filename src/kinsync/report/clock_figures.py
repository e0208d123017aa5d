"""Figures of the PPS + ZDA clock fit."""

from __future__ import annotations

import matplotlib as mpl

mpl.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from kinsync._typing import FloatArray
from kinsync.clock import ClockFit
from kinsync.report.figures import png_bytes
from kinsync.report.style import report_figure

__all__ = ["clock_residual_figure"]


@report_figure
def clock_residual_figure(
    fit: ClockFit, truth_error_s: tuple[FloatArray, FloatArray] | None = None
) -> bytes:
    """Residuals of the clock fit, with the missing and spurious pulses marked.

    Parameters
    ----------
    fit : ClockFit
        The fit to show.
    truth_error_s : (ndarray, ndarray), optional
        Local times (s) and mapped-time errors against the truth (s), shape (T,) each;
        plotted in a second panel when given (simulations), else a histogram of the
        residuals.

    Returns
    -------
    bytes
        PNG image.
    """
    t0 = fit.model.reference_local_s
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(12, 4.2), gridspec_kw={"width_ratios": [3, 2]})
    x = fit.t_local_s - t0
    ax.plot(x, fit.residuals_s * 1e6, ".", ms=3, color="C0", label="good pulses")
    for i, g in enumerate(fit.missing_gps_s):
        t_missing = fit.model.reference_local_s + (g - fit.model.reference_gps_s) / (
            1.0 + fit.model.drift_ppm * 1e-6
        )
        ax.axvline(
            t_missing - t0,
            color="0.5",
            ls=":",
            lw=1,
            label="missing pulse" if i == 0 else None,
        )
    if fit.n_spurious:
        top = float(np.max(np.abs(fit.residuals_s))) * 1e6 if fit.n_pulses else 1.0
        ax.plot(
            fit.spurious_t_local_s - t0,
            np.full(fit.n_spurious, 1.1 * top),
            "v",
            color="C3",
            label="spurious pulse (off the grid)",
        )
    for i, tz in enumerate(fit.wrong_zda_t_local_s):
        ax.axvline(tz - t0, color="C1", ls="--", lw=1, label="wrong ZDA" if i == 0 else None)
    ax.set_xlabel(f"local time since first good pulse {t0:.3f} (s)")
    ax.set_ylabel("residual (us)")
    ax.set_title(
        f"drift {fit.model.drift_ppm:.5f} ± {fit.drift_std_ppm:.5f} ppm, "
        f"RMS {fit.residual_rms_s * 1e6:.3f} us"
    )
    ax.grid(visible=True, alpha=0.3)
    ax.legend(fontsize=8, loc="lower right")
    if truth_error_s is not None:
        tt, err = truth_error_s
        ax2.plot(np.asarray(tt) - t0, np.asarray(err) * 1e6, ".", ms=3, color="C2")
        band = 3.0 * fit.mapped_std_s(np.asarray(tt)) * 1e6
        ax2.fill_between(np.asarray(tt) - t0, -band, band, color="C2", alpha=0.15)
        ax2.set_xlabel("local time since first good pulse (s)")
        ax2.set_ylabel("mapped time - truth (us)")
        ax2.set_title("model error at every true edge (band: 3 sigma)")
    else:
        ax2.hist(fit.residuals_s * 1e6, bins=40, color="C0")
        ax2.set_xlabel("residual (us)")
        ax2.set_ylabel("pulses")
        ax2.set_title("residual distribution")
    ax2.grid(visible=True, alpha=0.3)
    return png_bytes(fig)
