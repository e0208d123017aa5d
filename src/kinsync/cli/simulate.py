"""``kinsync simulate``: make realistic test data with known truth."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from kinsync.cli._options import parse_rates
from kinsync.cli._output import console, err_console, fmt, print_json
from kinsync.cli.clock import parse_convention
from kinsync.errors import InputError
from kinsync.io.passes import PassFileFormat
from kinsync.sim.clock import ClockSimConfig, simulate_clock, write_clock_simulation
from kinsync.sim.rotating_table import (
    RotatingTableConfig,
    RotatingTableSimulation,
    simulate_rotating_table,
    write_simulation,
)

app = typer.Typer(help="Simulate test data (pass folders, logs) with known ground truth.")

_FORMATS: dict[str, PassFileFormat] = {"csv": "csv", "las": "las", "laz": "laz"}
JsonOpt = Annotated[bool, typer.Option("--json", help="Print one JSON object instead of a table.")]


def summary(sim: RotatingTableSimulation, out: Path, file_format: str, raw: bool) -> dict[str, Any]:
    """JSON-ready summary of a written simulation (what the command prints)."""
    truth = sim.truth
    return {
        "out": str(out),
        "format": file_format,
        "raw": raw,
        "seed": truth["seed"],
        "n_passes": truth["n_passes"],
        "n_points": truth["n_points"],
        "latency_s": truth["latency_s"],
        "imu_latency_s": truth["imu_latency_s"],
        "fifo_delay_s": truth["fifo_delay_s"],
        "sphere_center_ned_m": truth["sphere_center_ned_m"],
        "sphere_radius_m": truth["sphere_radius_m"],
        "mean_sphere_points_per_pass_by_rate": truth["mean_sphere_points_per_pass_by_rate"],
    }


@app.command("rotating-table")
def rotating_table(
    out: Annotated[Path, typer.Option(help="Output folder (pass folder + truth.json).")],
    latency_ms: Annotated[float, typer.Option(help="IMU latency (ms), without the FIFO.")] = 4.21,
    rates_deg_s: Annotated[
        str, typer.Option(help="Comma-separated table rate magnitudes (deg/s); both signs.")
    ] = "2,4,6,10,14,18",
    passes: Annotated[int, typer.Option(help="Passes per rate and direction.")] = 15,
    seed: Annotated[int, typer.Option(help="Random seed (same seed, same data).")] = 1,
    range_noise_m: Annotated[
        float, typer.Option(help="Range noise along the beam, 1 sigma (m).")
    ] = 0.002,
    fifo_bytes: Annotated[int, typer.Option(help="Serial receive FIFO depth (bytes).")] = 0,
    baud: Annotated[float, typer.Option(help="Serial line rate (bit/s), 8N1.")] = 115200.0,
    file_format: Annotated[
        str, typer.Option("--format", help="Pass file format: csv, las or laz.")
    ] = "csv",
    raw: Annotated[
        bool,
        typer.Option(
            "--raw", help="Also write scanner-frame points, the attitude log and mount.toml."
        ),
    ] = False,
    as_json: JsonOpt = False,
) -> None:
    """Simulate a rotating-table latency test (Method A) and write its pass folder."""
    fmt_key = file_format.strip().lower()
    if fmt_key not in _FORMATS:
        msg = f"--format must be csv, las or laz, got {file_format!r}"
        raise InputError(msg)
    if out.exists() and not out.is_dir():
        msg = f"--out {out}: exists and is not a folder; give a folder to write the passes to"
        raise InputError(msg)
    if passes < 1:
        msg = f"--passes must be at least 1, got {passes}"
        raise InputError(msg)
    if not math.isfinite(latency_ms):
        msg = f"--latency-ms must be finite, got {latency_ms}"
        raise InputError(msg)
    config = RotatingTableConfig(
        latency_s=latency_ms * 1e-3,
        rates_deg_s=parse_rates(rates_deg_s),
        passes=passes,
        seed=seed,
        range_noise_m=range_noise_m,
        fifo_bytes=fifo_bytes,
        baud=baud,
    )
    with Progress(
        TextColumn("simulate"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("passes"),
        TimeElapsedColumn(),
        console=err_console,
        transient=True,
    ) as bar:
        task = bar.add_task("passes", total=len(config.signed_rates_deg_s))
        sim = simulate_rotating_table(
            config, progress=lambda done, _total: bar.update(task, completed=done)
        )
    with err_console.status("writing files"):
        write_simulation(sim, out, file_format=_FORMATS[fmt_key], raw=raw)
    doc = summary(sim, out, fmt_key, raw)
    if as_json:
        print_json(doc)
        return
    table = Table(title=f"Rotating-table simulation written to {out}")
    table.add_column("quantity")
    table.add_column("value", justify="right")
    table.add_row("passes written", str(doc["n_passes"]))
    table.add_row("points (sphere and clutter)", str(doc["n_points"]))
    table.add_row("truth latency (ms)", fmt(doc["latency_s"], 1e3, 6))
    table.add_row("  IMU latency (ms)", fmt(doc["imu_latency_s"], 1e3, 6))
    table.add_row("  FIFO delay (ms)", fmt(doc["fifo_delay_s"], 1e3, 6))
    for rate, n in doc["mean_sphere_points_per_pass_by_rate"].items():
        table.add_row(f"sphere points per pass at {rate} deg/s", f"{n:.0f}")
    console.print(table)
    console.print(f"truth: {out / 'truth.json'}")


@app.command("clock")
def clock(
    out: Annotated[Path, typer.Option(help="Output folder (pps.csv, nmea.csv, truth.json).")],
    offset_s: Annotated[
        float, typer.Option(help="GPS minus local time at the first edge (s).")
    ] = 0.37,
    drift_ppm: Annotated[
        float, typer.Option(help="Local clock rate error (ppm); > 0: it runs slow.")
    ] = 25.0,
    jitter_us: Annotated[float, typer.Option(help="PPS edge jitter, 1 sigma (us).")] = 1.0,
    duration_s: Annotated[float, typer.Option(help="Log length (s).")] = 600.0,
    missing: Annotated[int, typer.Option(help="PPS edges not detected.")] = 3,
    spurious: Annotated[int, typer.Option(help="Spurious PPS edges added.")] = 2,
    bad_zda: Annotated[int, typer.Option(help="ZDAs naming a wrong second.")] = 1,
    bad_lines: Annotated[
        int, typer.Option(help="GGA/RMC/HDT lines corrupted (bad checksum, truncated).")
    ] = 2,
    seed: Annotated[int, typer.Option(help="Random seed (same seed, same data).")] = 1,
    baud: Annotated[float, typer.Option(help="NMEA serial line rate (bit/s), 8N1.")] = 115200.0,
    zda_delay_ms: Annotated[
        float, typer.Option(help="Edge to start of the ZDA transmission (ms).")
    ] = 15.0,
    convention: Annotated[
        str, typer.Option(help="Which edge a ZDA names: preceding or following.")
    ] = "preceding",
    as_json: JsonOpt = False,
) -> None:
    """Simulate a PPS log and an NMEA log of a drifting acquisition clock."""
    if out.exists() and not out.is_dir():
        msg = f"--out {out}: exists and is not a folder; give a folder to write the logs to"
        raise InputError(msg)
    config = ClockSimConfig(
        offset_s=offset_s,
        drift_ppm=drift_ppm,
        jitter_us=jitter_us,
        duration_s=duration_s,
        missing=missing,
        spurious=spurious,
        bad_zda=bad_zda,
        bad_lines=bad_lines,
        seed=seed,
        baud=baud,
        zda_delay_ms=zda_delay_ms,
        convention=parse_convention(convention),
    )
    sim = simulate_clock(config)
    write_clock_simulation(sim, out)
    truth = sim.truth
    doc = {
        "out": str(out),
        "files": ["pps.csv", "nmea.csv", "truth.json"],
        "seed": seed,
        "convention": config.convention,
        "offset_s": truth["offset_s"],
        "drift_ppm": truth["drift_ppm"],
        "reference_local_s": truth["reference_local_s"],
        "reference_gps_s": truth["reference_gps_s"],
        "n_pps_lines": len(sim.pps_t_local_s),
        "n_nmea_lines": len(sim.nmea_sentences),
        "n_missing": truth["n_missing"],
        "n_spurious": truth["n_spurious"],
        "n_wrong_zda": truth["n_wrong_zda"],
        "n_bad_lines": truth["n_bad_lines"],
        "n_rejected_messages": truth["n_rejected_messages"],
    }
    if as_json:
        print_json(doc)
        return
    table = Table(title=f"PPS + NMEA clock simulation written to {out}")
    table.add_column("quantity")
    table.add_column("value", justify="right")
    table.add_row("PPS lines (pps.csv)", str(doc["n_pps_lines"]))
    table.add_row("NMEA lines (nmea.csv)", str(doc["n_nmea_lines"]))
    table.add_row("truth offset at first edge (s)", fmt(truth["offset_s"], 1.0, 9))
    table.add_row("truth drift (ppm)", fmt(truth["drift_ppm"], 1.0, 9))
    table.add_row("missing / spurious pulses", f"{truth['n_missing']} / {truth['n_spurious']}")
    table.add_row("wrong ZDAs / bad lines", f"{truth['n_wrong_zda']} / {truth['n_bad_lines']}")
    table.add_row("ZDA convention", config.convention)
    console.print(table)
    console.print(f"truth: {out / 'truth.json'}")
