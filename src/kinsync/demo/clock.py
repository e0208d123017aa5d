"""Demo section and figure for PPS + ZDA time tagging: the local clock mapped to GPS time.

Simulate a demanding logging scenario (10 minutes, 25 ppm drift, 1 us edge jitter, 3 missing
and 2 spurious pulses, one ZDA naming the wrong second, two corrupted NMEA lines),
write it as ``pps.csv`` / ``nmea.csv``, read it back, fit, and compare with the truth.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import matplotlib as mpl

mpl.use("Agg")
import numpy as np

from kinsync._typing import FloatArray
from kinsync.clock import ClockFit, fit_clock_to_log
from kinsync.demo.tolerances import EXACT, TIME_TAGGING
from kinsync.io.atomic import atomic_write_bytes, atomic_write_text
from kinsync.io.clock_model import read_pps_csv, write_clock_model
from kinsync.io.nmea import read_nmea_log
from kinsync.report.clock_figures import clock_residual_figure
from kinsync.report.html import Figure, Section, Table
from kinsync.report.verdict import Check
from kinsync.sim.clock import ClockSimConfig, simulate_clock, write_clock_simulation

__all__ = ["clock_section"]

Summary = list[tuple[str, str, str]]


@dataclass(frozen=True, eq=False)
class _ClockRun:
    """The fitted clock of the simulated logs and its errors against the truth."""

    config: ClockSimConfig
    truth: dict[str, Any]
    fit: ClockFit
    edges_t_local_s: FloatArray
    edge_error_s: FloatArray  # mapped minus true GPS time of every true edge
    max_error_us: float
    drift_error_ppm: float
    true_offset_s: float
    offset_error_s: float


def _simulate_and_fit(folder: Path) -> _ClockRun:
    """Simulate the logs into ``folder``, read them back, fit and compare with the truth."""
    config = ClockSimConfig()
    sim = simulate_clock(config)
    write_clock_simulation(sim, folder)
    log = read_nmea_log(folder / "nmea.csv")
    fit = fit_clock_to_log(read_pps_csv(folder / "pps.csv"), log, baud=config.baud)
    write_clock_model(fit.model, folder / "model.json", fit)
    truth = sim.truth
    edges_local = np.asarray(truth["edges_t_local_s"])
    err = fit.model.apply(edges_local) - np.asarray(truth["edges_gps_s"])
    true_offset = float(sim.true_gps_s(fit.model.reference_local_s)) - fit.model.reference_local_s
    return _ClockRun(
        config=config,
        truth=truth,
        fit=fit,
        edges_t_local_s=edges_local,
        edge_error_s=err,
        max_error_us=float(np.max(np.abs(err))) * 1e6,
        drift_error_ppm=fit.model.drift_ppm - config.drift_ppm,
        true_offset_s=true_offset,
        offset_error_s=fit.model.offset_s - true_offset,
    )


def _document(run: _ClockRun) -> dict[str, object]:
    """What ``clock.json`` holds: the fit, the truth and the errors."""
    return {
        "fit": run.fit.as_document(),
        "truth": {k: v for k, v in run.truth.items() if k not in ("edges_gps_s",)},
        "max_mapped_error_s": run.max_error_us * 1e-6,
        "drift_error_ppm": run.drift_error_ppm,
        "offset_error_s": run.offset_error_s,
    }


def _summary_row(run: _ClockRun) -> tuple[str, str, str]:
    """The (capability, scenario, result) row of the terminal summary."""
    fit = run.fit
    return (
        "clock model (PPS + ZDA)",
        "10 min, 25 ppm, 1 us jitter, 3 missing + 2 spurious pulses, 1 wrong ZDA",
        (
            f"drift error {run.drift_error_ppm * 1e3:+.3f} ppb, max mapped error "
            f"{run.max_error_us:.2f} us, "
            f"faults {fit.n_missing}/{fit.n_spurious}/{fit.n_wrong_zda}"
        ),
    )


def _tables(run: _ClockRun) -> tuple[Table, ...]:
    """The fitted-against-true model table and the faults table."""
    fit, truth = run.fit, run.truth
    rows = [
        [
            "offset at reference (s)",
            f"{fit.model.offset_s:.9f}",
            f"{run.true_offset_s:.9f}",
            f"{run.offset_error_s * 1e6:+.3f} us",
            f"{fit.offset_std_s * 1e6:.3f} us",
        ],
        [
            "drift (ppm)",
            f"{fit.model.drift_ppm:.6f}",
            f"{run.config.drift_ppm:.6f}",
            f"{run.drift_error_ppm:+.6f}",
            f"{fit.drift_std_ppm:.6f}",
        ],
        ["mapped time, every true edge", "-", "-", f"max {run.max_error_us:.3f} us", "-"],
    ]
    fault_rows = [
        ["missing pulses", str(fit.n_missing), str(truth["n_missing"])],
        ["spurious pulses", str(fit.n_spurious), str(truth["n_spurious"])],
        ["ZDAs naming a wrong second", str(fit.n_wrong_zda), str(truth["n_wrong_zda"])],
        ["bad NMEA lines (checksum, truncated)", str(fit.n_bad_lines), str(truth["n_bad_lines"])],
        [
            "rejected messages (bad lines + wrong, unpaired, repeated ZDAs)",
            str(fit.n_rejected_messages),
            str(truth["n_rejected_messages"]),
        ],
        ["pulses used", str(fit.n_pulses), str(truth["n_pulses"])],
    ]
    return (
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
    )


def _paragraphs(fit: ClockFit) -> tuple[str, ...]:
    """The scenario and the fitted model, in words."""
    d = fit.model.time_decimals  # the reference times to what their float64 holds (1 us)
    return (
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
            f"Model: t_gps_s = {fit.model.reference_gps_s:.{d}f} + (t_local_s - "
            f"{fit.model.reference_local_s:.{d}f}) * (1 + {fit.model.drift_ppm:.6f}e-6). "
            f"ZDA transmission starts {fit.zda_delay_s * 1e3:.2f} ms after the edge it "
            "names."
        ),
    )


def _checks(run: _ClockRun) -> tuple[Check, ...]:
    """The clock's verdict: offset and mapped times against the truth, faults found."""
    fit, truth = run.fit, run.truth
    found = (fit.n_missing, fit.n_spurious, fit.n_wrong_zda, fit.n_bad_lines)
    simulated = (
        truth["n_missing"],
        truth["n_spurious"],
        truth["n_wrong_zda"],
        truth["n_bad_lines"],
    )
    wrong = sum(abs(int(a) - int(b)) for a, b in zip(found, simulated, strict=True))
    return (
        Check(
            "clock offset error at the reference epoch",
            run.offset_error_s * 1e6,
            TIME_TAGGING,
            fit.offset_std_s * 1e6,
        ),
        Check(
            "largest error of the mapped GPS time over every true pulse edge",
            run.max_error_us,
            TIME_TAGGING,
            detail=f"{len(run.edge_error_s)} edges",
        ),
        Check(
            "faults missed or invented (missing and spurious pulses, wrong ZDAs, bad lines)",
            wrong,
            EXACT,
            detail=f"found {'/'.join(map(str, found))}, simulated {'/'.join(map(str, simulated))}",
        ),
    )


def clock_section(out_dir: Path, summary: Summary) -> Section:
    """Simulate, write, read back and fit the PPS + ZDA scenario."""
    run = _simulate_and_fit(out_dir / "clock")
    atomic_write_text(out_dir / "clock.json", json.dumps(_document(run), indent=2) + "\n")
    png = clock_residual_figure(run.fit, (run.edges_t_local_s, run.edge_error_s))
    atomic_write_bytes(out_dir / "clock_1.png", png)
    summary.append(_summary_row(run))
    return Section(
        title="PPS + ZDA time tagging: local clock to GPS time",
        paragraphs=_paragraphs(run.fit),
        tables=_tables(run),
        checks=_checks(run),
        figures=(
            Figure(
                caption="Left: residuals of the good pulses, missing pulses (dotted), spurious "
                "pulses (red, off scale) and the wrong ZDA (dashed). Right: the model's "
                "error at every true edge against its 3-sigma band",
                png=png,
            ),
        ),
    )
