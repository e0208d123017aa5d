"""``kinsync georef``: direct georeferencing of a scanner-frame point file (SPEC section 5)."""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from kinsync.cli._help import literal
from kinsync.cli._options import GPS_WEEK_SPAN_HELP, MaxGapOpt, refuse_unused_gps_week
from kinsync.cli._output import console, fmt, print_json, quantity_table, warn
from kinsync.cli._progress import progress_display
from kinsync.errors import InputError
from kinsync.io.column_map import parse_column_map
from kinsync.io.mount_file import read_mount

if TYPE_CHECKING:
    from kinsync.mount import Mount
    from kinsync.pipelines.georef import OutsidePolicy, PointColumns

_OUTSIDE: dict[str, OutsidePolicy] = {"error": "error", "reject": "reject"}
_POINT_COLUMNS: dict[str, PointColumns] = {"auto": "auto", "xyz": "xyz", "profile": "profile"}
_COLUMN_KEYS = ("t_s", "x_m", "y_m", "z_m", "range_m", "angle_rad")
"""The point-table columns kinsync reads, which ``--columns`` may map."""


def georef(
    points: Annotated[
        Path,
        typer.Option(
            "--points",
            help="Scanner-frame points: .las/.laz (time in gps_time) or .csv/.parquet with "
            "t_s,x_m,y_m,z_m, or t_s,range_m,angle_rad for a 2D profile scanner (+ any other "
            "columns, kept; other names: --columns).",
        ),
    ],
    trajectory: Annotated[
        Path,
        typer.Option(
            "--trajectory",
            help="Trajectory: .csv (t_s,lat_deg,lon_deg,...), SBET .out/.sbet, or a POSPac / "
            "Inertial Explorer ASCII export (.txt).",
        ),
    ],
    mount: Annotated[
        Path, typer.Option("--mount", help="Mount TOML (lever arm, boresight, latency).")
    ],
    out: Annotated[
        Path,
        typer.Option(
            "--out",
            help="Output; format from the suffix, from any input: .las/.laz, .csv/.parquet "
            "(every input column or LAS dimension, X,Y,Z in --crs) or .ply (binary, x,y,z "
            "double + numeric attributes). Written under a temporary name and renamed when "
            "complete.",
        ),
    ],
    crs: Annotated[
        str,
        typer.Option(
            "--crs",
            help="Output CRS (axis order easting/longitude first), e.g. EPSG:32619 (UTM, "
            "ellipsoidal heights) or EPSG:32618+5703 (UTM + NAVD88 orthometric heights: "
            "needs PROJ's geoid grid or --geoid).",
        ),
    ] = "EPSG:4978",
    geoid: Annotated[
        Path | None,
        typer.Option(
            "--geoid",
            help="Geoid grid (GTX or GeoTIFF of N above the ellipsoid of --crs's datum) "
            "for a compound --crs: heights become H = h - N.",
        ),
    ] = None,
    epoch: Annotated[
        float | None,
        typer.Option(
            "--epoch",
            help="Coordinate epoch (decimal year, e.g. 2024.35) of a time-dependent "
            "transformation (between ITRF and NAD83(CSRS) realisations); default the "
            "trajectory's date when its times are absolute GPS time.",
        ),
    ] = None,
    trajectory_crs: Annotated[
        str,
        typer.Option(
            "--trajectory-crs",
            help="Geocentric CRS of the trajectory's positions: EPSG:4978 (WGS 84), "
            "EPSG:7789 (ITRF2014), EPSG:9988 (ITRF2020), ...",
        ),
    ] = "EPSG:4978",
    latency_ms: Annotated[
        float | None,
        typer.Option(
            "--latency-ms",
            help=(
                "Latency (ms), replacing the mount's latency_s. Sign: > 0 when the navigation"
                " data lag the scanner (a point at t takes the record tagged t + latency);"
                " a wrong sign doubles the error instead of removing it."
            ),
        ),
    ] = None,
    chunk_points: Annotated[
        int, typer.Option("--chunk-points", help="Points per chunk (bounds memory).", min=1)
    ] = 1_000_000,
    outside: Annotated[
        str,
        typer.Option(
            "--outside",
            help="Points outside the trajectory span or in one of its gaps (see --max-gap-s): "
            "'error' (default, nothing written) or 'reject' (written to OUT.rejected.<ext>).",
        ),
    ] = "error",
    max_gap_s: MaxGapOpt = None,
    gps_week: Annotated[
        int | None,
        typer.Option(
            "--gps-week",
            help="GPS week of SBET / LAS seconds-of-week times, to put them on GPS time. "
            + GPS_WEEK_SPAN_HELP,
        ),
    ] = None,
    scheduler: Annotated[
        str,
        typer.Option(
            "--scheduler",
            help=literal(
                "Where chunks are georeferenced: 'local' (this process), 'processes' (a "
                "local process pool) or tcp://HOST:PORT (a running Dask scheduler; needs "
                "kinsync[scale]). The output is identical whichever is used."
            ),
        ),
    ] = "local",
    workers: Annotated[
        int | None,
        typer.Option(
            "--workers",
            help="Processes for --scheduler processes (default: CPU count); for a Dask "
            "scheduler, workers to keep busy (default: those connected).",
            min=1,
        ),
    ] = None,
    point_columns: Annotated[
        str,
        typer.Option(
            "--point-columns",
            help="Table columns that give the points: 'xyz' (x_m,y_m,z_m), 'profile' "
            "(range_m,angle_rad) or 'auto' (the set the file has).",
        ),
    ] = "auto",
    columns: Annotated[
        str | None,
        typer.Option(
            "--columns",
            help="Your table's names of the columns kinsync reads, as KINSYNC=YOURS pairs: "
            "e.g. t_s=time,x_m=X,y_m=Y,z_m=Z (keys: " + ", ".join(_COLUMN_KEYS) + "). "
            "Carried columns keep your names.",
        ),
    ] = None,
    profiler_azimuth_deg: Annotated[
        float | None,
        typer.Option(
            "--profiler-azimuth-deg",
            help=literal(
                "Azimuth (deg) of a profile scanner's plane about the scanner Z axis, "
                "replacing the mount's [profiler] azimuth_deg (profile files only)."
            ),
        ),
    ] = None,
    as_json: Annotated[
        bool, typer.Option("--json", help="Print one JSON object instead of a table.")
    ] = False,
) -> None:
    """Georeference a point file: scanner frame + trajectory + mount -> CRS coordinates."""
    # numba, laspy and pyarrow load with the pipeline: only when this command runs.
    from kinsync.pipelines.georef import georeference_file  # noqa: PLC0415
    from kinsync.trajectory import VelocityConsistencyWarning  # noqa: PLC0415

    _check_choices(outside, point_columns, scheduler, workers)
    refuse_unused_gps_week(gps_week, trajectories=[trajectory], points=[points])
    column_map = parse_column_map(columns, _COLUMN_KEYS)
    the_mount = read_mount(mount)
    if latency_ms is not None:
        from kinsync.mount_slips import derived_mounts  # noqa: PLC0415

        with derived_mounts():  # --latency-ms has its span (cli/_bounds.py); ms, not s
            the_mount = the_mount.with_latency(latency_ms * 1e-3)
    with (
        warnings.catch_warnings(record=True) as caught,
        progress_display("georef") as progress,
    ):
        warnings.simplefilter("always", VelocityConsistencyWarning)
        summary = georeference_file(
            points,
            trajectory,
            the_mount,
            out,
            crs=crs,
            geoid=None if geoid is None else str(geoid),
            epoch_year=epoch,
            trajectory_crs=trajectory_crs,
            chunk_points=chunk_points,
            outside=_OUTSIDE[outside],
            gps_week=gps_week,
            progress=progress,
            scheduler=scheduler,
            workers=workers,
            point_columns=_POINT_COLUMNS[point_columns],
            profiler_azimuth_deg=profiler_azimuth_deg,
            columns=column_map,
            max_gap_s=max_gap_s,
            mount_file=mount,
        )
    notes = []  # trajectory velocities that disagree with the positions: said, never silent
    for w in caught:
        if issubclass(w.category, VelocityConsistencyWarning):
            notes.append(f"{trajectory}: {w.message}")
        else:
            warnings.showwarning(w.message, w.category, w.filename, w.lineno)
    notes += summary.warnings
    for note in notes:
        warn(note)
    if as_json:
        print_json({**summary.as_document(), "mount": _applied_mount(the_mount), "warnings": notes})
        return
    table = quantity_table(f"Georeferenced {points} -> {out} ({crs})")
    table.add_row("points in", str(summary.points_in))
    table.add_row("points out", str(summary.points_out))
    table.add_row(
        "points rejected (outside the trajectory span or in a gap)", str(summary.points_rejected)
    )
    table.add_row("latency (ms)", fmt(the_mount.latency_s, 1e3, 6))
    if summary.crs is not None:
        info = summary.crs
        table.add_row("CRS operation", info.operation)
        table.add_row(
            "CRS accuracy (m)", "unknown" if info.accuracy_m is None else f"{info.accuracy_m:g}"
        )
        table.add_row("heights", info.heights)
        table.add_row("units (X, Y, Z)", ", ".join(info.units))
        if info.epoch_year is not None:
            table.add_row("coordinate epoch (year)", f"{info.epoch_year:.4f}")
    table.add_row("seconds", fmt(summary.seconds))
    table.add_row("points per second", fmt(summary.points_per_s))
    console.print(table)
    if summary.crs is not None and summary.crs.proj_pipeline:
        console.print(f"PROJ pipeline: {summary.crs.proj_pipeline}", soft_wrap=True)
    if summary.rejected_path is not None:
        console.print(f"rejected points: {summary.rejected_path}")


_APPLIED_MOUNT_KEYS = ("lever_arm_body_m", "boresight_rpy_deg", "latency_s", "profiler_azimuth_deg")
"""What of the mount georeferencing applies (the antenna lever arm is the trajectory's)."""


def _applied_mount(mount: Mount) -> dict[str, Any]:
    """The mount the points were georeferenced with (after ``--latency-ms``), for ``--json``.

    A JSON log must say which latency and mount a run applied: the mount file's, or the
    option's override.
    """
    doc = mount.as_document()
    return {k: doc[k] for k in _APPLIED_MOUNT_KEYS}


def _check_choices(outside: str, point_columns: str, scheduler: str, workers: int | None) -> None:
    """Refuse an unknown choice, or --workers where nothing would use it, before any work."""
    if outside not in _OUTSIDE:
        msg = f"--outside must be 'error' or 'reject', got {outside!r}"
        raise InputError(msg)
    if point_columns not in _POINT_COLUMNS:
        msg = f"--point-columns must be 'auto', 'xyz' or 'profile', got {point_columns!r}"
        raise InputError(msg)
    if workers is not None and scheduler == "local":
        msg = (
            "--workers sets the processes of --scheduler processes or the workers of a Dask "
            "scheduler; --scheduler local runs every chunk in this process: drop --workers, "
            "or give --scheduler processes"
        )
        raise InputError(msg)
