"""Demo section and figure for PPS + ZDA time tagging (SPEC section 6).

Simulate the issue's scenario (10 minutes, 25 ppm drift, 1 us edge jitter, 3 missing
and 2 spurious pulses, one ZDA naming the wrong second, two corrupted NMEA lines),
write it as ``pps.csv`` / ``nmea.csv``, read it back, fit, and compare with the truth.
"""

from __future__ import annotations

import json
from pathlib import Path

import matplotlib as mpl

mpl.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from kinsync._typing import FloatArray
from kinsync.clock import ClockFit, fit_clock_to_log
from kinsync.io.atomic import atomic_write_bytes, atomic_write_text
from kinsync.io.clock_model import read_pps_csv, write_clock_model
from kinsync.io.nmea import read_nmea_log
from kinsync.report.figures import png_bytes
from kinsync.report.html import Figure, Section, Table
from kinsync.sim.clock import ClockSimConfig, simulate_clock, write_clock_simulation

__all__ = ["clock_residual_figure", "clock_section"]

Summary = list[tuple[str, str, str]]


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
    ax.plot(x, fit.residuals_s * 1e6, ".", ms=3, color="tab:blue", label="good pulses")
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
            color="tab:red",
            label="spurious pulse (off the grid)",
        )
    for i, tz in enumerate(fit.wrong_zda_t_local_s):
        ax.axvline(
            tz - t0, color="tab:orange", ls="--", lw=1, label="wrong ZDA" if i == 0 else None
        )
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
        ax2.plot(np.asarray(tt) - t0, np.asarray(err) * 1e6, ".", ms=3, color="tab:green")
        band = 3.0 * fit.mapped_std_s(np.asarray(tt)) * 1e6
        ax2.fill_between(np.asarray(tt) - t0, -band, band, color="tab:green", alpha=0.15)
        ax2.set_xlabel("local time since first good pulse (s)")
        ax2.set_ylabel("mapped time - truth (us)")
        ax2.set_title("model error at every true edge (band: 3 sigma)")
    else:
        ax2.hist(fit.residuals_s * 1e6, bins=40, color="tab:blue")
        ax2.set_xlabel("residual (us)")
        ax2.set_ylabel("pulses")
        ax2.set_title("residual distribution")
    ax2.grid(visible=True, alpha=0.3)
    return png_bytes(fig)


def clock_section(out_dir: Path, summary: Summary) -> Section:
    """Simulate, write, read back and fit the issue's PPS + ZDA scenario."""
    config = ClockSimConfig()
    sim = simulate_clock(config)
    folder = out_dir / "clock"
    write_clock_simulation(sim, folder)
    log = read_nmea_log(folder / "nmea.csv")
    fit = fit_clock_to_log(read_pps_csv(folder / "pps.csv"), log, baud=config.baud)
    write_clock_model(fit.model, folder / "model.json", fit)
    truth = sim.truth
    edges_local = np.asarray(truth["edges_t_local_s"])
    err = fit.model.apply(edges_local) - np.asarray(truth["edges_gps_s"])
    max_err_us = float(np.max(np.abs(err))) * 1e6
    drift_err = fit.model.drift_ppm - config.drift_ppm
    true_offset = float(sim.true_gps_s(fit.model.reference_local_s)) - fit.model.reference_local_s
    offset_err = fit.model.offset_s - true_offset
    atomic_write_text(
        out_dir / "clock.json",
        json.dumps(
            {
                "fit": fit.as_document(),
                "truth": {k: v for k, v in truth.items() if k not in ("edges_gps_s",)},
                "max_mapped_error_s": max_err_us * 1e-6,
                "drift_error_ppm": drift_err,
                "offset_error_s": offset_err,
            },
            indent=2,
        )
        + "\n",
    )
    png = clock_residual_figure(fit, (edges_local, err))
    atomic_write_bytes(out_dir / "clock_1.png", png)
    summary.append(
        (
            "clock model (PPS + ZDA)",
            "10 min, 25 ppm, 1 us jitter, 3 missing + 2 spurious pulses, 1 wrong ZDA",
            (
                f"drift error {drift_err * 1e3:+.3f} ppb, max mapped error {max_err_us:.2f} us, "
                f"faults {fit.n_missing}/{fit.n_spurious}/{fit.n_wrong_zda}"
            ),
        )
    )
    rows = [
        [
            "offset at reference (s)",
            f"{fit.model.offset_s:.9f}",
            f"{true_offset:.9f}",
            f"{offset_err * 1e6:+.3f} us",
            f"{fit.offset_std_s * 1e6:.3f} us",
        ],
        [
            "drift (ppm)",
            f"{fit.model.drift_ppm:.6f}",
            f"{config.drift_ppm:.6f}",
            f"{drift_err:+.6f}",
            f"{fit.drift_std_ppm:.6f}",
        ],
        ["mapped time, every true edge", "-", "-", f"max {max_err_us:.3f} us", "-"],
    ]
    fault_rows = [
        ["missing pulses", str(fit.n_missing), str(truth["n_missing"])],
        ["spurious pulses", str(fit.n_spurious), str(truth["n_spurious"])],
        ["ZDAs naming a wrong second", str(fit.n_wrong_zda), str(truth["n_wrong_zda"])],
        ["bad NMEA lines (checksum, truncated)", str(fit.n_bad_lines), str(truth["n_bad_lines"])],
        [
            "rejected messages (bad lines + wrong + unpaired ZDAs)",
            str(fit.n_rejected_messages),
            str(truth["n_rejected_messages"]),
        ],
        ["pulses used", str(fit.n_pulses), str(truth["n_pulses"])],
    ]
    return Section(
        title="PPS + ZDA time tagging: local clock to GPS time (SPEC section 6)",
        paragraphs=(
            (
                "An acquisition computer whose clock runs 25 ppm slow and 0.37 s behind GPS "
                "tags the receiver's pulse per second (1 us jitter) and the NMEA sentences it "
                "receives at 115200 baud (ZDA 15 ms after each edge, then GGA, RMC, HDT). "
                "Three pulses are lost, two spurious edges are added, one ZDA names the wrong "
                "second and two lines are corrupted. kinsync reads pps.csv and nmea.csv, "
                "finds the 1 s grid of the pulses, names its seconds with the ZDAs (their "
                "transmission time removed), rejects what does not fit and fits offset and "
                "drift by least squares."
            ),
            (
                f"Model: t_gps_s = {fit.model.reference_gps_s!r} + (t_local_s - "
                f"{fit.model.reference_local_s!r}) * (1 + {fit.model.drift_ppm:.6f}e-6). "
                f"ZDA transmission starts {fit.zda_delay_s * 1e3:.2f} ms after the edge it "
                "names."
            ),
        ),
        tables=(
            Table(
                caption="Fitted against true clock model",
                headers=("quantity", "fitted", "truth", "error", "1 sigma"),
                rows=rows,
            ),
            Table(
                caption="Faults found against faults simulated",
                headers=("fault", "found", "simulated"),
                rows=fault_rows,
            ),
        ),
        figures=(
            Figure(
                caption="Left: residuals of the good pulses, missing pulses (dotted), spurious "
                "pulses (red, off scale) and the wrong ZDA (dashed). Right: the model's "
                "error at every true edge against its 3-sigma band",
                png=png,
            ),
        ),
    )
