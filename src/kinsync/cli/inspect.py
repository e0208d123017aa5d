"""``kinsync mount check|from-points``, ``kinsync trajectory info|export``.

Check a mount, read back the mount a point file was made with, summarise and convert
trajectories.
"""

from __future__ import annotations

import warnings as pywarnings
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import numpy as np
import typer

from kinsync.cli._options import GPS_WEEK_SPAN_HELP, MaxGapOpt, refuse_unused_gps_week
from kinsync.cli._output import console, print_json, quantity_table, warn
from kinsync.cli._progress import progress_display
from kinsync.clock.leap_seconds import PLAUSIBLE_DATE_GPS_S, gps_to_utc_iso
from kinsync.errors import InputError, KinsyncWarning
from kinsync.io.mount_file import read_mount
from kinsync.io.smrmsg import find_smrmsg_companion, read_smrmsg
from kinsync.mount import Mount, StdCorrelation
from kinsync.progress import Progress as ProgressCallback
from kinsync.progress import report

if TYPE_CHECKING:
    from kinsync.trajectory_velocity import VelocityCheck

mount_app = typer.Typer(help="Mount (system calibration) TOML files.")
trajectory_app = typer.Typer(help="Trajectory files.")

_TIME_DECIMALS = 6
"""Durations and intervals of `trajectory info` are rounded to 1 us (float64 steps)."""
_TIME_ROWS = ("t_start_s", "t_end_s")
"""Rows of times (GPS time near 1.4e9 s): printed to the ms, as `trajectory export` does."""


def _print_quantities(title: str, rows: dict[str, str]) -> None:
    table = quantity_table(title)
    for key, value in rows.items():
        table.add_row(key, value)
    console.print(table)


JsonOpt = Annotated[bool, typer.Option("--json", help="Print one JSON object instead of a table.")]


@mount_app.command("check")
def mount_check(
    path: Annotated[Path, typer.Argument(help="Mount TOML file.")], as_json: JsonOpt = False
) -> None:
    """Validate a mount TOML file and print its values and boresight matrix."""
    mount = read_mount(path)
    doc: dict[str, Any] = {
        **mount.as_document(),
        "R_scanner_to_body": mount.R_scanner_to_body.tolist(),
    }
    if as_json:
        print_json(doc)
        return
    rows = _mount_rows(mount)
    for i, row in enumerate(mount.R_scanner_to_body):
        label = "R_scanner_to_body (boresight)" if i == 0 else ""
        rows[label or " " * (i + 1)] = "  ".join(f"{v:+.6f}" for v in row)
    _print_quantities(f"Mount {path}", rows)


def _mount_rows(mount: Mount) -> dict[str, str]:
    """A mount's values and sigmas as table rows (``%g``: six significant digits)."""
    doc = mount.as_document()
    rows = {
        key: ", ".join(f"{v:g}" for v in doc[key])
        for key in ("lever_arm_body_m", "boresight_rpy_deg", "antenna_lever_arm_body_m")
    }
    rows["latency_s"] = f"{mount.latency_s:g}"
    if mount.profiler_azimuth_deg is not None:
        rows["profiler_azimuth_deg"] = f"{mount.profiler_azimuth_deg:g}"
    for key, value in (doc["uncertainty"] or {}).items():
        if value is not None and key != "correlation":
            shown = ", ".join(f"{v:g}" for v in value) if isinstance(value, list) else f"{value:g}"
            rows[f"sigma {key}"] = shown
    if mount.uncertainty is not None and mount.uncertainty.correlation is not None:
        rows["correlation of the errors"] = _strongest_pairs(mount.uncertainty.correlation)
    return rows


@mount_app.command("from-points")
def mount_from_points(
    path: Annotated[
        Path,
        typer.Argument(
            help="A point file kinsync wrote: .las/.laz, .parquet or .ply of georef, .parquet "
            "of sync apply (a CSV holds no record)."
        ),
    ],
    mount_out: Annotated[
        Path | None,
        typer.Option(
            "--out",
            help="Write the mount applied as a mount TOML (values bit for bit, the original "
            "file's header comments), to georeference again with exactly it.",
        ),
    ] = None,
    as_json: JsonOpt = False,
) -> None:
    """Print the mount, trajectory and options a point file was made with (its record)."""
    from kinsync.io.atomic import atomic_write_text  # noqa: PLC0415
    from kinsync.io.point_provenance import (  # noqa: PLC0415
        read_point_record,
        record_mount,
        recorded_mount_text,
    )

    record = read_point_record(path)  # its fields' types checked
    mount = record_mount(record, path)
    # Everything is checked, and the table made, before the mount file is written.
    text = None if mount_out is None else recorded_mount_text(record, path)
    rows = {
        "made by": f"kinsync {record.get('made_by')}, {record.get('software')}",
        "at (UTC)": str(record.get("utc")),
        "command": str(record.get("command") or "- (from Python)"),
    }
    mount_file = record["mount"].get("file") or {}
    rows["mount file"] = str(mount_file.get("path", "- (built in Python)"))
    rows |= {f"  {k}": str(v) for k, v in _mount_rows(mount).items()}
    rows |= _record_rows(record)
    if mount_out is not None and text is not None:
        atomic_write_text(mount_out, text)
        rows["mount written to"] = str(mount_out)
    if as_json:
        out = None if mount_out is None else str(mount_out)
        print_json({"file": str(path), "record": record, "mount_out": out})
        return
    _print_quantities(f"kinsync record of {path}", rows)


def _record_rows(record: dict[str, Any]) -> dict[str, str]:
    """The inputs and options of a record, as table rows (all of it: --json)."""
    rows: dict[str, str] = {}
    for section in ("points", "trajectory"):
        doc = record.get(section)
        if isinstance(doc, dict):
            rows[f"{section} file"] = str(doc.get("path"))
    time = record.get("time")
    if isinstance(time, dict):
        rows["times"] = ", ".join(f"{k} {v}" for k, v in time.items() if v is not None)
    clock = record.get("clock")
    if isinstance(clock, dict):
        rows["clock t0 (s), period (s)"] = f"{clock.get('t0_s')!r}, {clock.get('period_s')!r}"
    crs = record.get("crs")
    if isinstance(crs, dict):
        rows["CRS"] = f"{crs.get('requested')} ({crs.get('target')})"
        if crs.get("epoch_year") is not None:
            rows["coordinate epoch (year)"] = f"{crs['epoch_year']:.4f}"
    if record.get("left_out"):
        rows["left out of the record"] = ", ".join(map(str, record["left_out"]))
    return rows


def _strongest_pairs(corr: StdCorrelation, shown: int = 4) -> str:
    """The ``shown`` largest correlation coefficients by size, in words."""
    names = corr.names
    pairs = sorted(
        (
            (corr.matrix[i][j], f"{names[i]}/{names[j]}")
            for i in range(len(names))
            for j in range(i + 1, len(names))
        ),
        key=lambda p: -abs(p[0]),
    )
    text = ", ".join(f"{label} {r:+.2f}" for r, label in pairs[:shown])
    rest = len(pairs) - shown
    return text + (f" (and {rest} more: --json)" if rest > 0 else "")


def _smrmsg_document(
    path: Path, gps_week: int | None, t_start_s: float, t_end_s: float
) -> dict[str, Any]:
    """Span and standard-deviation statistics (median, max) of an smrmsg file.

    The statistics are those of the records within the trajectory's span (all records
    when none is: the JSON keeps them beside ``overlaps_trajectory: false``); a σ of
    the hours before or after the trajectory says nothing of it.
    """
    data = read_smrmsg(path, gps_week=gps_week)
    within = (data.t_s >= t_start_s) & (data.t_s <= t_end_s)
    rows = within if within.any() else np.ones_like(within)

    def stats(values: np.ndarray[Any, Any]) -> dict[str, list[float]]:
        return {
            "median": np.median(values[rows], axis=0).tolist(),
            "max": np.max(values[rows], axis=0).tolist(),
        }

    t_min, t_max = float(data.t_s.min()), float(data.t_s.max())
    return {
        "path": str(path),
        "records": len(data),
        "records_within_trajectory": int(np.count_nonzero(within)),
        "t_start_s": t_min,
        "t_end_s": t_max,
        "overlaps_trajectory": bool(t_min <= t_end_s and t_max >= t_start_s),
        "std_pos_ned_m": stats(data.std_pos_ned_m),
        "std_vel_ned_m_s": stats(data.std_vel_ned_m_s),
        "std_rpy_deg": stats(np.degrees(data.std_rpy_rad)),
    }


def _smrmsg_rows(doc: dict[str, Any]) -> dict[str, str]:
    rows = {
        "smrmsg": doc["path"],
        "smrmsg records": (
            f"{doc['records']} ({doc['records_within_trajectory']} within the trajectory: "
            "the statistics below are theirs)"
            if 0 < doc["records_within_trajectory"] < doc["records"]
            else str(doc["records"])
        ),
        "smrmsg span (s)": f"{doc['t_start_s']:.3f} .. {doc['t_end_s']:.3f}",
        "smrmsg overlaps the trajectory": str(doc["overlaps_trajectory"]),
    }
    if not doc["overlaps_trajectory"]:
        rows["sigma statistics"] = "not shown: no smrmsg record lies within the trajectory"
        return rows
    for key, label in (
        ("std_pos_ned_m", "sigma position N, E, D (m)"),
        ("std_vel_ned_m_s", "sigma velocity N, E, D (m/s)"),
        ("std_rpy_deg", "sigma roll, pitch, heading (deg)"),
    ):
        for stat in ("median", "max"):
            rows[f"{label}, {stat}"] = ", ".join(f"{v:.4g}" for v in doc[key][stat])
    return rows


def _velocity_rows(doc: dict[str, Any]) -> dict[str, str]:
    """Table rows of a velocity check (`kinsync.trajectory.VelocityCheck.as_document`)."""
    window = f"{doc['window_s']:.3g} s"
    scale = doc["velocity_scale"]
    return {
        "positions interpolated": "cubic Hermite (velocities agree)"
        if doc["consistent"]
        else "linearly (velocities disagree with the positions)",
        "velocity scale (1 = agree)": "-" if scale is None else f"{scale:.4g}",
        f"velocity mismatch per {window}, horizontal (m RMS)": (
            f"{doc['rms_mismatch_horizontal_m']:.3g} of {doc['rms_displacement_horizontal_m']:.3g}"
        ),
        f"velocity mismatch per {window}, vertical (m RMS)": (
            f"{doc['rms_mismatch_vertical_m']:.3g} of {doc['rms_displacement_vertical_m']:.3g}"
        ),
    }


def _speed_document(
    speed_m_s: np.ndarray[Any, Any], not_gap: np.ndarray[Any, Any]
) -> dict[str, float]:
    """Least, median and greatest ground speed (m/s) over the record intervals.

    Intervals across a data gap (``not_gap`` False) are left out, unless every one is.
    """
    if np.any(not_gap):
        speed_m_s = speed_m_s[not_gap]
    return {
        "min": float(speed_m_s.min()),
        "median": float(np.median(speed_m_s)),
        "max": float(speed_m_s.max()),
    }


def _speed_rows(doc: dict[str, float]) -> dict[str, str]:
    """The ground speed in m/s and in knots (1 kn = 1852 m / 3600 s)."""
    knots = {k: v * 3600.0 / 1852.0 for k, v in doc.items()}
    return {
        "ground speed (m/s)": (
            f"min {doc['min']:.2f}, median {doc['median']:.2f}, max {doc['max']:.2f}"
        ),
        "ground speed (kn)": (
            f"min {knots['min']:.1f}, median {knots['median']:.1f}, max {knots['max']:.1f}"
        ),
    }


def _time_document(t_start_s: float, t_end_s: float, scale: str) -> dict[str, Any]:
    """The time scale and, for absolute GPS time, the UTC dates of the span."""
    if scale == "week":
        return {
            "scale": "GPS seconds of week",
            "start_utc": None,
            "end_utc": None,
            "note": "give --gps-week for GPS time and dates",
        }
    if t_start_s < PLAUSIBLE_DATE_GPS_S:
        return {
            "scale": "GPS time",
            "start_utc": None,
            "end_utc": None,
            "note": "times before 1990: relative times (no date)",
        }
    return {
        "scale": "GPS time",
        "start_utc": gps_to_utc_iso(t_start_s),
        "end_utc": gps_to_utc_iso(t_end_s),
        "note": "",
    }


def _time_rows(doc: dict[str, Any]) -> dict[str, str]:
    rows = {"time scale": doc["scale"] + (f" ({doc['note']})" if doc["note"] else "")}
    if doc["start_utc"] is not None:
        rows["span (UTC)"] = f"{doc['start_utc']} to {doc['end_utc']}"
    return rows


def _area_document(lat_lon_h: np.ndarray[Any, Any]) -> dict[str, Any]:
    from kinsync.crs import data_area  # noqa: PLC0415 - pyproj loads only when needed

    area = data_area(lat_lon_h[:, 0], lat_lon_h[:, 1], lat_lon_h[:, 2])
    return area.as_document()


def _area_rows(doc: dict[str, Any] | None) -> dict[str, str]:
    if doc is None:
        return {"extent": "local NED positions (no geodetic extent)"}
    zones = doc["zones_spanned"]
    spanned = ""
    if len(zones) > 1 and zones[0] > zones[-1]:  # across the antimeridian: 60 before 1
        spanned = f" (data span zones {', '.join(map(str, zones))}, across the antimeridian)"
    elif len(zones) > 1:
        spanned = f" (data span zones {zones[0]}-{zones[-1]})"
    polar = {"UPS North": " (UTM stops at 84 deg N)", "UPS South": " (UTM stops at 80 deg S)"}
    polar_text = polar.get(doc["utm_zone"], "")
    return {
        "latitude (deg)": f"{doc['lat_deg'][0]:.6f} to {doc['lat_deg'][1]:.6f}",
        "longitude (deg)": f"{doc['lon_deg'][0]:.6f} to {doc['lon_deg'][1]:.6f}",
        "ellipsoidal height (m)": f"{doc['h_m'][0]:.3f} to {doc['h_m'][1]:.3f}",
        "suggested UTM zone": f"{doc['utm_zone']}: {doc['utm_epsg']} (WGS 84){spanned}{polar_text}",
    }


@trajectory_app.command("info")
def trajectory_info(
    path: Annotated[
        Path,
        typer.Argument(
            help="Trajectory: CSV (t_s,lat_deg,lon_deg,h_m,roll_deg,...), SBET (.out, .sbet), "
            "or a POSPac / Inertial Explorer ASCII export (.txt)."
        ),
    ],
    gps_week: Annotated[
        int | None,
        typer.Option(
            "--gps-week",
            help="GPS week of an SBET (and its smrmsg): times become GPS time. "
            + GPS_WEEK_SPAN_HELP,
        ),
    ] = None,
    smrmsg: Annotated[
        Path | None,
        typer.Option(
            "--smrmsg",
            help="The SBET's accuracy file (default: smrmsg<rest> beside sbet<rest>, or "
            "the folder's only smrmsg*.out).",
        ),
    ] = None,
    max_gap_s: MaxGapOpt = None,
    as_json: JsonOpt = False,
) -> None:
    """Validate a trajectory: time scale, span, extent, UTM zone, rate, motion, velocities.

    Data gaps (record intervals longer than --max-gap-s) are listed with a warning:
    the other commands do not interpolate across them unless given the same --max-gap-s.

    An SBET's accuracy file (smrmsg) is summarised too.

    Velocities are checked against the positions; when they disagree a warning says so
    (on stderr, and under "warnings" with --json): georeferencing then interpolates
    positions linearly.
    """
    refuse_unused_gps_week(gps_week, trajectories=[path])
    with progress_display("trajectory info") as progress:
        doc, check = _trajectory_info(path, gps_week, max_gap_s, smrmsg, progress)
    for warning in doc["warnings"]:
        warn(warning)
    if as_json:
        print_json(doc)
        return
    nested = ("smrmsg", "velocity_check", "warnings", "time", "area", "gaps", "ground_speed_m_s")
    rows = {
        k: f"{v:.3f}" if k in _TIME_ROWS else f"{v:.10g}" if isinstance(v, float) else str(v)
        for k, v in doc.items()
        if k not in nested
    }
    rows |= _time_rows(doc["time"]) | _area_rows(doc["area"])
    rows |= _speed_rows(doc["ground_speed_m_s"])
    if check is not None:
        rows |= _velocity_rows(check.as_document())
    if "smrmsg" in doc:
        rows |= {"smrmsg": "none found"} if doc["smrmsg"] is None else _smrmsg_rows(doc["smrmsg"])
    _print_quantities(f"Trajectory {path}", rows)


def _trajectory_info(
    path: Path,
    gps_week: int | None,
    max_gap_s: float | None,
    smrmsg: Path | None,
    progress: ProgressCallback,
) -> tuple[dict[str, Any], VelocityCheck | None]:
    """The ``trajectory info`` document and its velocity check.

    Reports its stages to ``progress`` (reading, checking): a long trajectory takes a
    while.
    """
    # kinsync.georef (numba, laspy, pyarrow) loads only when this command runs.
    from kinsync.io.trajectory import (  # noqa: PLC0415
        read_trajectory_file,
        trajectory_file_format,
    )
    from kinsync.trajectory_gaps import (  # noqa: PLC0415
        GAP_ADVICE,
        gap_threshold_shown_s,
        gap_threshold_text,
        max_gap_for,
        trajectory_gaps,
    )

    report(progress, 0.0, "reading the trajectory")
    with pywarnings.catch_warnings(record=True) as caught:
        pywarnings.simplefilter("always", KinsyncWarning)
        traj, scale = read_trajectory_file(path, gps_week=gps_week)
    report(progress, 0.5, "checking the trajectory (velocities, gaps)")
    reader_warnings = []  # listed with the others (--json: under "warnings")
    for w in caught:
        if issubclass(w.category, KinsyncWarning):
            reader_warnings.append(str(w.message))
        else:
            pywarnings.showwarning(w.message, w.category, w.filename, w.lineno)
    max_gap = max_gap_for(traj.t_s, max_gap_s)
    file_format = trajectory_file_format(path)
    is_sbet = file_format == "sbet"
    if smrmsg is not None and not is_sbet:
        what = "a trajectory CSV" if file_format == "csv" else f"a {file_format} export"
        msg = f"--smrmsg: {path} is {what}; an smrmsg file goes with an SBET"
        raise InputError(msg)
    accuracy = smrmsg if smrmsg is not None else (find_smrmsg_companion(path) if is_sbet else None)
    dt = np.diff(traj.t_s)
    rate = np.degrees(np.linalg.norm(traj.angular_rate_body_rad_s(), axis=1))
    check = traj.velocity_check
    warnings = reader_warnings
    if check is not None and not check.consistent:
        warnings.append(f"{path}: {check.message}")
    gaps = trajectory_gaps(traj.t_s, max_gap)
    if gaps:
        named = "; ".join(g.describe() for g in gaps[:5])
        more = f"; and {len(gaps) - 5} more" if len(gaps) > 5 else ""
        warnings.append(
            f"{path}: {len(gaps)} gap(s), "
            f"{gap_threshold_text(max_gap, given=max_gap_s is not None)}: {named}{more}; "
            "kinsync does not interpolate across them (times there are treated as outside "
            f"the span): where such an interval is legitimate, {GAP_ADVICE} (every command "
            "that reads a trajectory takes it)"
        )
    doc: dict[str, Any] = {
        "format": file_format,
        "records": len(traj),
        "t_start_s": traj.t_start_s,
        "t_end_s": traj.t_end_s,
        # Rounded to 1 us: near 1.4e9 s a float64 time holds 0.24 us steps, so a 200 Hz
        # record read 199.9954 Hz and its 5 ms intervals 0.005000114 s.
        "duration_s": round(traj.duration_s, _TIME_DECIMALS),
        "median_rate_hz": float(1.0 / round(float(np.median(dt)), _TIME_DECIMALS)),
        "longest_interval_s": round(float(dt.max()), _TIME_DECIMALS),  # gap or not
        # The default threshold, GAP_FACTOR median intervals, from the median interval
        # rounded as above (it read 0.05000114440917969 s at 200 Hz, 10 times the
        # 0.24 us noise), as the warnings show it; a given --max-gap-s is shown as given.
        "gap_threshold_s": max_gap if max_gap_s is not None else gap_threshold_shown_s(max_gap),
        "gaps": [{"t_start_s": g.t_start_s, "t_end_s": g.t_end_s} for g in gaps],
        "max_angular_rate_deg_s": float(rate.max()),
        "ground_speed_m_s": _speed_document(traj.ground_speed_m_s(), dt <= max_gap),
        "has_velocity": traj.vel_ned_m_s is not None,
        "time": _time_document(traj.t_start_s, traj.t_end_s, scale),
        "area": None if traj.lat_lon_h is None else _area_document(traj.lat_lon_h),
        "velocity_check": None if check is None else check.as_document(),
        "warnings": warnings,
    }
    if is_sbet:
        doc["smrmsg"] = (
            None
            if accuracy is None
            else _smrmsg_document(accuracy, gps_week, traj.t_start_s, traj.t_end_s)
        )
        if doc["smrmsg"] is not None and not doc["smrmsg"]["overlaps_trajectory"]:
            sm = doc["smrmsg"]
            warnings.append(
                f"{accuracy}: the smrmsg spans {sm['t_start_s']:.3f} .. {sm['t_end_s']:.3f} s, "
                f"the trajectory {traj.t_start_s:.3f} .. {traj.t_end_s:.3f} s: they do not "
                "overlap, so its accuracies are not the trajectory's (not shown; --json keeps "
                "them); is it the smrmsg of another mission, or on another time scale?"
            )
    report(progress, 1.0, "checking the trajectory (velocities, gaps)")
    return doc, check


@trajectory_app.command("export")
def trajectory_export(
    path: Annotated[
        Path,
        typer.Argument(
            help="Trajectory: CSV, SBET (.out, .sbet), or a POSPac / Inertial Explorer "
            "ASCII export (.txt)."
        ),
    ],
    out: Annotated[
        Path,
        typer.Option(
            "--out",
            help="Output: .csv/.parquet (t_s, X,Y,Z in --crs, roll/pitch/yaw, velocities) or "
            ".geojson/.kml (a WGS 84 line for a quick look).",
        ),
    ],
    crs: Annotated[
        str | None,
        typer.Option(
            "--crs",
            help="CRS of a .csv/.parquet output (axis order easting/longitude first), e.g. "
            "EPSG:32619 or EPSG:32618+5703; default EPSG:4979 (WGS 84 lon, lat, h).",
        ),
    ] = None,
    geoid: Annotated[
        Path | None,
        typer.Option("--geoid", help="Geoid grid for a compound --crs (as in georef)."),
    ] = None,
    epoch: Annotated[
        float | None,
        typer.Option("--epoch", help="Coordinate epoch (decimal year) of a time-dependent --crs."),
    ] = None,
    trajectory_crs: Annotated[
        str,
        typer.Option("--trajectory-crs", help="Geocentric CRS of the trajectory's positions."),
    ] = "EPSG:4978",
    gps_week: Annotated[
        int | None,
        typer.Option(
            "--gps-week",
            help="GPS week of seconds-of-week times (SBET, text exports). " + GPS_WEEK_SPAN_HELP,
        ),
    ] = None,
    max_vertices: Annotated[
        int | None,
        typer.Option(
            "--max-vertices",
            help="Most vertices of a .geojson/.kml line (default 2000; lines only).",
            min=2,
        ),
    ] = None,
    as_json: JsonOpt = False,
) -> None:
    """Export a trajectory: a table in any CRS, or a KML/GeoJSON line for a quick look."""
    from kinsync.pipelines.trajectory_export import export_trajectory  # noqa: PLC0415

    refuse_unused_gps_week(gps_week, trajectories=[path])
    with progress_display("trajectory export") as progress:
        result = export_trajectory(
            path,
            out,
            crs=crs,
            geoid=None if geoid is None else str(geoid),
            epoch_year=epoch,
            trajectory_crs=trajectory_crs,
            gps_week=gps_week,
            max_vertices=max_vertices,
            progress=progress,
        )
    info = result.crs
    for warning in () if info is None else info.warnings:
        warn(warning)
    if as_json:
        print_json(result.as_document())
        return
    rows = {
        "records": str(result.records),
        "written (rows or vertices)": str(result.written),
        "time scale": result.time_scale,
        "time span (s)": f"{result.t_start_s:.3f} to {result.t_end_s:.3f}",
    }
    if info is not None:
        rows |= {"CRS": info.target, "CRS operation": info.operation, "heights": info.heights}
        rows["units (X, Y, Z)"] = ", ".join(info.units)
        if info.epoch_year is not None:
            rows["coordinate epoch (year)"] = f"{info.epoch_year:.4f}"
    _print_quantities(f"Trajectory {path} -> {out}", rows)
