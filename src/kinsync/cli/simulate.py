"""``kinsync simulate``: make realistic test data with known truth."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from kinsync.cli._options import parse_rates
from kinsync.cli._output import console, fmt, print_json, quantity_table
from kinsync.cli._progress import progress_display
from kinsync.cli.clock import parse_convention
from kinsync.errors import InputError
from kinsync.io.atomic import output_folder
from kinsync.progress import Stages

# The simulators (scipy, numba, laspy, pyarrow) load inside the commands, only when they run.
if TYPE_CHECKING:
    from kinsync.io.passes import PassFileFormat
    from kinsync.sim.drive import DriveSimulation
    from kinsync.sim.patch_test import PatchTestSimulation
    from kinsync.sim.rotating_table import RotatingTableSimulation

app = typer.Typer(help="Simulate test data (pass folders, logs) with known ground truth.")

_FORMATS: dict[str, PassFileFormat] = {"csv": "csv", "las": "las", "laz": "laz"}
TABLE_MAX_RATE_DEG_S = 369.0
"""Largest ``--rates-deg-s`` of ``simulate rotating-table``: the simulated scanner and
sphere's `kinsync.sim.table_config.max_usable_rate_deg_s` (a test keeps them equal)."""
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
    latency_ms: Annotated[
        float,
        typer.Option(
            help="IMU latency (ms), without the FIFO; > 0: the IMU records lag the scanner."
        ),
    ] = 4.21,
    rates_deg_s: Annotated[
        str,
        typer.Option(
            help=(
                f"Comma-separated table rate magnitudes (deg/s), each up to "
                f"{TABLE_MAX_RATE_DEG_S:g} (faster, a pass can miss the sphere); both signs."
            )
        ),
    ] = "2,4,6,10,14,18",
    passes: Annotated[
        int,
        typer.Option(
            help="Passes per rate and direction; with --rates-deg-s, at most 500,000 "
            "profiles in all."
        ),
    ] = 15,
    seed: Annotated[int, typer.Option(help="Random seed (same seed, same data).")] = 1,
    range_noise_m: Annotated[
        float, typer.Option(help="Range noise along the beam, 1 sigma (m).")
    ] = 0.002,
    fifo_bytes: Annotated[int, typer.Option(help="Serial receive FIFO depth (bytes).")] = 0,
    baud: Annotated[
        float | None,
        typer.Option(
            help="Serial line rate of the FIFO (bit/s), 8N1; with --fifo-bytes (default 115200)."
        ),
    ] = None,
    pass_attitude_error_deg: Annotated[
        float,
        typer.Option(
            help="Attitude error constant over each pass, drawn anew per pass, about each "
            "NED axis (deg, 1 sigma; an INS's drift between passes)."
        ),
    ] = 0.0,
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
    from kinsync.sim.rotating_table import (  # noqa: PLC0415
        simulate_rotating_table,
        size_problem,
        write_simulation,
    )
    from kinsync.sim.table_config import RotatingTableConfig, too_fast_text  # noqa: PLC0415

    fmt_key = file_format.strip().lower()
    if fmt_key not in _FORMATS:
        msg = f"--format must be csv, las or laz, got {file_format!r}"
        raise InputError(msg)
    output_folder(out, "give a folder to write the passes to", create=False, option="--out")
    if passes < 1:
        msg = f"--passes must be at least 1, got {passes}"
        raise InputError(msg)
    if not math.isfinite(latency_ms):
        msg = f"--latency-ms must be finite, got {latency_ms}"
        raise InputError(msg)
    if baud is not None and fifo_bytes == 0:
        msg = (
            "--baud is the line rate that empties the serial FIFO; without --fifo-bytes "
            "there is no FIFO and it would not be used: drop it, or give --fifo-bytes"
        )
        raise InputError(msg)
    rates = parse_rates(rates_deg_s)
    limit = RotatingTableConfig().max_rate_deg_s
    for pos, rate in enumerate(rates, start=1):
        if rate > limit:
            reason = too_fast_text(rate, limit, RotatingTableConfig.profile_rate_hz)
            msg = f"--rates-deg-s {rates_deg_s!r}: item {pos} ({rate:g}): {reason}"
            raise InputError(msg)
    config = RotatingTableConfig(
        latency_s=latency_ms * 1e-3,
        rates_deg_s=rates,
        passes=passes,
        seed=seed,
        range_noise_m=range_noise_m,
        fifo_bytes=fifo_bytes,
        pass_attitude_error_deg=pass_attitude_error_deg,
    )
    if baud is not None:
        config = replace(config, baud=baud)
    problem = size_problem(config, rates_name="--rates-deg-s", passes_name="--passes")
    if problem is not None:
        raise InputError(problem)
    with progress_display("simulate rotating-table") as progress:
        stages = Stages(progress, {"simulating passes": 3.0, "writing files": 1.0})
        sim = simulate_rotating_table(config, progress=stages.start("simulating passes"))
        stages.start("writing files")
        write_simulation(sim, out, file_format=_FORMATS[fmt_key], raw=raw)
        stages.finish()
    doc = summary(sim, out, fmt_key, raw)
    if as_json:
        print_json(doc)
        return
    table = quantity_table(f"Rotating-table simulation written to {out}")
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
    from kinsync.sim.clock import (  # noqa: PLC0415
        ClockSimConfig,
        simulate_clock,
        write_clock_simulation,
    )

    output_folder(out, "give a folder to write the logs to", create=False, option="--out")
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
    table = quantity_table(f"PPS + NMEA clock simulation written to {out}")
    table.add_row("PPS lines (pps.csv)", str(doc["n_pps_lines"]))
    table.add_row("NMEA lines (nmea.csv)", str(doc["n_nmea_lines"]))
    table.add_row("truth offset at first edge (s)", fmt(truth["offset_s"], 1.0, 9))
    table.add_row("truth drift (ppm)", fmt(truth["drift_ppm"], 1.0, 9))
    table.add_row("missing / spurious pulses", f"{truth['n_missing']} / {truth['n_spurious']}")
    table.add_row("wrong ZDAs / bad lines", f"{truth['n_wrong_zda']} / {truth['n_bad_lines']}")
    table.add_row("ZDA convention", config.convention)
    console.print(table)
    console.print(f"truth: {out / 'truth.json'}")


def _parse_outage(text: str) -> tuple[float, float]:
    """Parse ``START:END`` (s) of ``--gnss-outage``."""
    start_text, sep, end_text = text.partition(":")
    try:
        if not sep:
            raise ValueError(text)
        start, end = float(start_text), float(end_text)
    except ValueError:
        msg = f"--gnss-outage {text!r}: expected START:END in seconds, such as 120:150"
        raise InputError(msg) from None
    if not (math.isfinite(start) and math.isfinite(end)) or end <= start:
        msg = f"--gnss-outage {text!r}: END must be a finite time after START"
        raise InputError(msg)
    return start, end


def _parse_vector3(text: str, option: str) -> tuple[float, float, float]:
    """Parse ``x,y,z`` (three finite numbers)."""
    items = text.split(",")
    try:
        vals = [float(v) for v in items]
    except ValueError:
        vals = []
    if len(vals) != 3 or not all(math.isfinite(v) for v in vals):
        msg = f"{option} {text!r}: expected three comma-separated numbers such as 0.3,-0.2,-1.5"
        raise InputError(msg)
    return vals[0], vals[1], vals[2]


def drive_summary(sim: DriveSimulation, out: Path) -> dict[str, Any]:
    """JSON-ready summary of a written drive simulation (what ``simulate drive`` prints)."""
    from kinsync.sim.drive import DRIVE_FILES  # noqa: PLC0415

    c = sim.config
    err = sim.imu_errors
    return {
        "out": str(out),
        "files": list(DRIVE_FILES),
        "route": c.route,
        "route_length_m": sim.route.length_m,
        "duration_s": sim.truth.duration_s,
        "speed_m_s": c.speed_m_s,
        "imu": c.imu,
        "imu_model": err.model.name,
        "imu_rate_hz": err.model.rate_hz,
        "n_imu": len(sim.imu),
        "gnss_rate_hz": c.gnss_rate_hz,
        "n_gnss": len(sim.gnss),
        "gnss_outages": [list(o) for o in c.gnss_outages],
        "antenna_lever_arm_body_m": list(c.antenna_lever_arm_body_m),
        "seed": c.seed,
        "gyro_bias_rad_s": err.gyro_bias_rad_s.tolist(),
        "acc_bias_m_s2": err.acc_bias_m_s2.tolist(),
        "gyro_scale_ppm": err.gyro_scale_ppm.tolist(),
        "acc_scale_ppm": err.acc_scale_ppm.tolist(),
    }


@app.command("drive")
def drive(
    out: Annotated[
        Path,
        typer.Option(
            help="Output folder (imu.csv, gnss.csv, truth.csv, truth.json, and ins.toml: a "
            "filter configuration matching the simulated IMU and GNSS)."
        ),
    ],
    route: Annotated[
        str, typer.Option(help="Route: oval, loop (figure-eight) or lines (survey lines).")
    ] = "oval",
    duration_s: Annotated[
        float | None, typer.Option(help="Record length (s); default: the whole route.")
    ] = None,
    laps: Annotated[
        int | None, typer.Option(help="Laps (oval, loop) or lines; default: fill the duration.")
    ] = None,
    speed_m_s: Annotated[float, typer.Option(help="Cruise speed (m/s).")] = 2.0,
    static_s: Annotated[float, typer.Option(help="Standstill at the start (s).")] = 60.0,
    imu: Annotated[
        str, typer.Option(help="IMU preset: navigation (RLG, 50 Hz) or mems (200 Hz).")
    ] = "navigation",
    imu_rate_hz: Annotated[
        float | None, typer.Option(help="IMU (and truth) rate (Hz); default the preset's.")
    ] = None,
    gnss_rate_hz: Annotated[float, typer.Option(help="GNSS epoch rate (Hz).")] = 5.0,
    gnss_outage: Annotated[
        list[str] | None,
        typer.Option(help="GNSS outage START:END (s); repeat for several."),
    ] = None,
    lever_arm_m: Annotated[
        str, typer.Option(help="IMU -> GNSS antenna lever arm x,y,z (m, body FRD).")
    ] = "0.3,-0.2,-1.5",
    roll_amplitude_deg: Annotated[
        float, typer.Option(help="Vessel roll oscillation amplitude (deg).")
    ] = 0.0,
    roll_period_s: Annotated[float, typer.Option(help="Roll oscillation period (s).")] = 6.0,
    seed: Annotated[int, typer.Option(help="Random seed (same seed, same data).")] = 1,
    as_json: JsonOpt = False,
) -> None:
    """Simulate a drive: IMU with errors, GNSS with noise and outages, and the truth."""
    from kinsync.sim.drive import (  # noqa: PLC0415
        IMU_KINDS,
        ROUTE_KINDS,
        DriveSimConfig,
        simulate_drive,
        write_drive_simulation,
    )

    route_key = route.strip().lower()
    if route_key not in ROUTE_KINDS:
        msg = f"--route must be oval, loop or lines, got {route!r}"
        raise InputError(msg)
    imu_key = imu.strip().lower()
    if imu_key not in IMU_KINDS:
        msg = f"--imu must be navigation or mems, got {imu!r}"
        raise InputError(msg)
    output_folder(out, "give a folder to write the drive to", create=False, option="--out")
    for option, value in (
        ("--speed-m-s", speed_m_s),
        ("--gnss-rate-hz", gnss_rate_hz),
        ("--duration-s", duration_s),
        ("--imu-rate-hz", imu_rate_hz),
    ):
        if value is not None and not (math.isfinite(value) and value > 0.0):
            msg = f"{option} must be a number > 0, got {value}"
            raise InputError(msg)
    if laps is not None and laps < 1:
        msg = f"--laps must be at least 1, got {laps}"
        raise InputError(msg)
    if duration_s is not None and duration_s <= static_s:
        msg = (
            f"--duration-s {duration_s:g} ends within the standstill (--static-s {static_s:g}): "
            "nothing would be driven; give a longer --duration-s or a shorter --static-s"
        )
        raise InputError(msg)
    config = DriveSimConfig(
        route=ROUTE_KINDS[ROUTE_KINDS.index(route_key)],
        speed_m_s=speed_m_s,
        laps=laps,
        duration_s=duration_s,
        static_s=static_s,
        imu=IMU_KINDS[IMU_KINDS.index(imu_key)],
        imu_rate_hz=imu_rate_hz,
        gnss_rate_hz=gnss_rate_hz,
        gnss_outages=tuple(_parse_outage(o) for o in gnss_outage or ()),
        antenna_lever_arm_body_m=_parse_vector3(lever_arm_m, "--lever-arm-m"),
        roll_amplitude_deg=roll_amplitude_deg,
        roll_period_s=roll_period_s,
        seed=seed,
    )
    with progress_display("simulate drive") as progress:
        stages = Stages(progress, {"simulating the drive": 3.0, "writing files": 1.0})
        stages.start("simulating the drive")
        sim = simulate_drive(config)
        stages.start("writing files")
        write_drive_simulation(sim, out)
        stages.finish()
    doc = drive_summary(sim, out)
    if as_json:
        print_json(doc)
        return
    table = quantity_table(f"Drive simulation written to {out}")
    table.add_row("route", f"{doc['route']} ({doc['route_length_m']:.1f} m)")
    table.add_row("duration (s)", fmt(doc["duration_s"], 1.0, 6))
    table.add_row("IMU", f"{doc['imu_model']} at {doc['imu_rate_hz']:g} Hz")
    table.add_row("IMU samples (imu.csv)", str(doc["n_imu"]))
    table.add_row("GNSS epochs (gnss.csv)", str(doc["n_gnss"]))
    table.add_row("GNSS outages", str(len(doc["gnss_outages"])))
    gb = ", ".join(fmt(b, 180.0 / math.pi * 3600.0, 3) for b in doc["gyro_bias_rad_s"])
    ab = ", ".join(fmt(b, 1e3 / 9.80665, 3) for b in doc["acc_bias_m_s2"])
    table.add_row("truth gyro turn-on bias (deg/h)", gb)
    table.add_row("truth acc turn-on bias (mg)", ab)
    console.print(table)
    console.print(f"truth: {out / 'truth.csv'}, {out / 'truth.json'}")


@app.command("drive-scan")
def drive_scan(
    out: Annotated[
        Path, typer.Option(help="Output folder (scan, trajectory, mount, targets, pulses, truth).")
    ],
    period_s: Annotated[float, typer.Option(help="True mirror period T (s).")] = 0.030545,
    t0_s: Annotated[
        float | None,
        typer.Option(help="True start of profile 0 (GPS s); default 0.4371 s after the start."),
    ] = None,
    seed: Annotated[int, typer.Option(help="Random seed (same seed, same data).", min=0)] = 1,
    duration_s: Annotated[
        float,
        typer.Option(
            help="Length of the drive (s); with --period-s, at most 65 million beams "
            "(2 h at the default period)."
        ),
    ] = 300.0,
    route: Annotated[
        str, typer.Option(help="oval (two laps) or loop (figure-eight, as many laps as fit).")
    ] = "oval",
    trajectory_noise_m: Annotated[
        float, typer.Option(help="Position noise of the written trajectory, 1 sigma per axis (m).")
    ] = 0.0,
    extra_first_pulse: Annotated[
        bool, typer.Option("--extra-first-pulse", help="One pulse more than profiles, first.")
    ] = False,
    near_targets_only: Annotated[
        bool,
        typer.Option(
            "--near-targets-only", help="Simulate only the profiles that can see a target."
        ),
    ] = False,
    as_json: JsonOpt = False,
) -> None:
    """Simulate a profile scanner driven through a scene with sync targets (Method B)."""
    from kinsync.sim.profiler import (  # noqa: PLC0415
        DRIVE_SCAN_FILES,
        DriveScanConfig,
        drive_scan_size_problem,
        simulate_drive_scan,
        write_drive_scan,
    )

    if route not in ("oval", "loop"):
        msg = f"--route must be oval or loop, got {route!r}"
        raise InputError(msg)
    output_folder(out, "give a folder to write the data set to", create=False, option="--out")
    problem = drive_scan_size_problem(
        duration_s, period_s, duration_name="--duration-s", period_name="--period-s"
    )
    if problem is not None:
        raise InputError(problem)
    config = DriveScanConfig(
        period_s=period_s,
        t0_s=t0_s,
        seed=seed,
        duration_s=duration_s,
        route="oval" if route == "oval" else "loop",
        trajectory_noise_m=trajectory_noise_m,
        extra_first_pulse=extra_first_pulse,
        near_targets_only=near_targets_only,
    )
    with progress_display("simulate drive-scan") as progress:
        stages = Stages(progress, {"simulating the drive and the scan": 3.0, "writing files": 1.0})
        stages.start("simulating the drive and the scan")
        sim = simulate_drive_scan(config)
        stages.start("writing files")
        write_drive_scan(sim, out)
        stages.finish()
    truth = sim.truth
    doc = {
        "out": str(out),
        "files": list(DRIVE_SCAN_FILES),
        "seed": seed,
        "route": route,
        "duration_s": duration_s,
        "t0_s": truth["t0_s"],
        "period_s": truth["period_s"],
        "n_profiles": truth["n_profiles"],
        "n_points": truth["n_points"],
        "pulse_offset": truth["pulse_offset"],
        "trajectory_noise_m": trajectory_noise_m,
        "passes": {t["name"]: len(t["passes"]) for t in truth["targets"]},
    }
    if as_json:
        print_json(doc)
        return
    table = quantity_table(f"Profile-scanner drive simulation written to {out}")
    table.add_row("profiles / returns", f"{doc['n_profiles']} / {doc['n_points']}")
    table.add_row("truth t0 (s)", f"{truth['t0_s']:.6f}")
    table.add_row("truth period (s)", f"{truth['period_s']:.9f}")
    table.add_row("pulse offset", str(doc["pulse_offset"]))
    for name, n in doc["passes"].items():
        table.add_row(f"passes of {name}", str(n))
    console.print(table)
    console.print(f"truth: {out / 'truth.json'}")


def _parse_speeds(text: str) -> tuple[float, ...]:
    """Parse ``--speeds-m-s`` (comma-separated speeds > 0, m/s)."""
    items = [s.strip() for s in text.split(",")]
    speeds: list[float] = []
    for pos, item in enumerate(items, start=1):
        try:
            value = float(item)
        except ValueError:
            msg = f"--speeds-m-s {text!r}: item {pos} ({item!r}) is not a number; give e.g. 5,12"
            raise InputError(msg) from None
        if not (math.isfinite(value) and value > 0.0):
            msg = f"--speeds-m-s {text!r}: item {pos} ({item!r}) must be a speed > 0 m/s"
            raise InputError(msg)
        speeds.append(value)
    return tuple(speeds)


def patch_test_summary(sim: PatchTestSimulation, out: Path, file_format: str) -> dict[str, Any]:
    """JSON-ready summary of a written patch test (what ``simulate patch-test`` prints)."""
    from kinsync.sim.patch_test import patch_test_files  # noqa: PLC0415

    truth = sim.truth
    files = patch_test_files(len(sim.lines), "las" if file_format == "las" else "laz")
    return {
        "out": str(out),
        "files": list(files),
        "scenario": truth["scenario"],
        "seed": truth["seed"],
        "format": file_format,
        "gps_week": sim.gps_week,
        "n_lines": len(sim.lines),
        "n_points": sim.n_points,
        "lines": [
            {
                "file": files[2 + i],
                "direction": doc["direction"],
                "speed_m_s": doc["speed_m_s"],
                "heading_deg": doc["heading_deg"],
                "n_points": doc["n_points"],
            }
            for i, doc in enumerate(truth["lines"])
        ],
        "mount_nominal": truth["mount_nominal"],
        "mount_true": truth["mount_true"],
        "errors": truth["errors"],
    }


@app.command("patch-test")
def patch_test(
    out: Annotated[
        Path,
        typer.Option(help="Output folder (trajectory.out, mount.toml, line_NN.laz, truth.json)."),
    ],
    scenario: Annotated[
        str, typer.Option(help="vehicle (town block, 5 and 12 m/s) or vessel (harbour, 2, 4 m/s).")
    ] = "vehicle",
    seed: Annotated[int, typer.Option(help="Random seed (same seed, same data).", min=0)] = 1,
    file_format: Annotated[
        str, typer.Option("--format", help="Point files: laz (compressed) or las.")
    ] = "laz",
    latency_ms: Annotated[
        float, typer.Option(help="Latency error injected: true minus nominal (ms).")
    ] = 5.0,
    boresight_error_deg: Annotated[
        str, typer.Option(help="Boresight error roll,pitch,yaw: true minus nominal (deg).")
    ] = "0.25,-0.30,0.40",
    lever_arm_error_m: Annotated[
        str, typer.Option(help="Lever-arm error x,y,z: true minus nominal (m, body FRD).")
    ] = "0.03,-0.02,0.04",
    density: Annotated[
        float,
        typer.Option(help="Fraction of the scanner's beams simulated, in (0, 1] (1: all)."),
    ] = 1.0,
    passes: Annotated[int, typer.Option(help="Lines each way per speed.")] = 2,
    speeds_m_s: Annotated[
        str | None, typer.Option(help="Speeds of the blocks of lines (m/s), e.g. 5,12.")
    ] = None,
    spheres: Annotated[
        bool | None,
        typer.Option(
            "--spheres/--no-spheres", help="Put two spheres in the scene (default: vessel only)."
        ),
    ] = None,
    range_noise_m: Annotated[
        float, typer.Option(help="Range noise along the beam, 1 sigma (m).")
    ] = 0.01,
    as_json: JsonOpt = False,
) -> None:
    """Simulate a mount patch test: SBET, one point file per line, nominal mount, truth."""
    from kinsync.sim.patch_test import (  # noqa: PLC0415
        SCENARIOS,
        PatchTestConfig,
        check_patch_test_folder,
        simulate_patch_test,
        write_patch_test,
    )

    scenario_key = scenario.strip().lower()
    if scenario_key not in SCENARIOS:
        msg = f"--scenario must be vehicle or vessel, got {scenario!r}"
        raise InputError(msg)
    fmt_key = file_format.strip().lower()
    if fmt_key not in ("laz", "las"):
        msg = f"--format must be laz or las, got {file_format!r}"
        raise InputError(msg)
    if not (math.isfinite(density) and 0.0 < density <= 1.0):
        msg = f"--density must lie in (0, 1] (fraction of the beams), got {density}"
        raise InputError(msg)
    if passes < 1:
        msg = f"--passes must be at least 1, got {passes}"
        raise InputError(msg)
    if not math.isfinite(latency_ms):
        msg = f"--latency-ms must be finite, got {latency_ms}"
        raise InputError(msg)
    if not (math.isfinite(range_noise_m) and range_noise_m >= 0.0):
        msg = f"--range-noise-m must be a number >= 0, got {range_noise_m}"
        raise InputError(msg)
    check_patch_test_folder(out, option="--out")
    config = PatchTestConfig(
        scenario=SCENARIOS[SCENARIOS.index(scenario_key)],
        seed=seed,
        latency_error_s=latency_ms * 1e-3,
        boresight_error_rpy_deg=_parse_vector3(boresight_error_deg, "--boresight-error-deg"),
        lever_arm_error_body_m=_parse_vector3(lever_arm_error_m, "--lever-arm-error-m"),
        density=density,
        passes_per_direction=passes,
        speeds_m_s=None if speeds_m_s is None else _parse_speeds(speeds_m_s),
        spheres=spheres,
        range_noise_m=range_noise_m,
    )
    with progress_display("simulate patch-test") as progress:
        stages = Stages(progress, {"simulating the drive and the scans": 3.0, "writing files": 1.0})
        stages.start("simulating the drive and the scans")
        sim = simulate_patch_test(config)
        stages.start("writing files")
        write_patch_test(sim, out, file_format="las" if fmt_key == "las" else "laz")
        stages.finish()
    doc = patch_test_summary(sim, out, fmt_key)
    if as_json:
        print_json(doc)
        return
    _print_patch_test(doc)


def _print_patch_test(doc: dict[str, Any]) -> None:
    """The human table of ``simulate patch-test``."""
    out = Path(doc["out"])
    table = quantity_table(f"Patch-test simulation ({doc['scenario']}) written to {out}")
    table.add_row("lines / points", f"{doc['n_lines']} / {doc['n_points']}")
    table.add_row("GPS week (--gps-week)", str(doc["gps_week"]))
    err = doc["errors"]
    table.add_row("truth latency error (ms)", fmt(err["latency_s"], 1e3, 6))
    table.add_row(
        "truth boresight error r,p,y (deg)", ", ".join(fmt(v) for v in err["boresight_rpy_deg"])
    )
    table.add_row(
        "truth lever-arm error x,y,z (m)", ", ".join(fmt(v) for v in err["lever_arm_body_m"])
    )
    for line in doc["lines"]:
        table.add_row(
            f"{line['file']} ({line['direction']}, {line['speed_m_s']:g} m/s)",
            str(line["n_points"]),
        )
    console.print(table)
    console.print(f"nominal mount: {out / 'mount.toml'}; truth: {out / 'truth.json'}")
