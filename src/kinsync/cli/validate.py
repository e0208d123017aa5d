"""``kinsync validate``: control points in the vehicle frame and wall flatness (SPEC 7)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.table import Table

from kinsync._text import counted, format_p_value
from kinsync.cli._options import GPS_WEEK_SPAN_HELP, MaxGapOpt, refuse_unused_gps_week
from kinsync.cli._output import console, fmt, print_json, quantity_table
from kinsync.errors import InputError
from kinsync.io.atomic import atomic_write_bytes

# kinsync.validation (scipy.stats, scipy.optimize, numba) loads inside the commands.
if TYPE_CHECKING:
    from kinsync.validation import CentreMethod, SignatureTest

app = typer.Typer(
    help="Validate a georeferenced cloud: control points in the vehicle frame, wall flatness."
)

_CENTRES: dict[str, CentreMethod] = {"tukey": "tukey", "median": "median", "sphere": "sphere"}

JsonOpt = Annotated[bool, typer.Option("--json", help="Print one JSON object instead of a table.")]
CloudOpt = Annotated[
    Path,
    typer.Option(
        "--cloud",
        help="Georeferenced cloud (kinsync georef output): .csv/.parquet with X,Y,Z "
        "(+ t_s, intensity) or .las/.laz (gps_time, intensity).",
    ),
]
CrsOpt = Annotated[
    str | None,
    typer.Option(
        "--crs",
        help="CRS of the cloud's X,Y,Z (default EPSG:4978 ECEF; a LAS file's own CRS when "
        "it has one).",
    ),
]
LevelOpt = Annotated[
    float,
    typer.Option("--level", help="Confidence level of the tests, e.g. 0.99.", min=0.5, max=0.9999),
]


def _pm(value: float, std: float, scale: float) -> str:
    if not (math.isfinite(value) and math.isfinite(std)) or std <= 0.0:
        return fmt(value, scale)
    v, s = value * scale, std * scale
    decimals = max(0, 1 - math.floor(math.log10(s)))
    return f"{v:.{decimals}f} ± {s:.{decimals}f}"


def _test_row(label: str, test: SignatureTest, scale: float) -> list[str]:
    if not test.testable:
        return [label, "-", "-", "-", f"not testable: {test.reason}"]
    return [
        label,
        _pm(test.estimate, test.std, scale),
        format_p_value(test.p_value, prefix=False),
        f"{test.dof:.1f}",
        "SIGNIFICANT" if test.significant else "not significant",
    ]


@app.command("control-points")
def control_points(
    cloud: CloudOpt,
    control: Annotated[
        Path,
        typer.Option(
            "--control",
            help="Control points CSV: name,lat_deg,lon_deg,h_m (WGS84) or name,x_m,y_m,z_m (ECEF).",
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
    crs: CrsOpt = None,
    search_radius_m: Annotated[
        float,
        typer.Option(
            "--search-radius-m", help="Radius around each control point (m, 0.001 to 100)."
        ),
    ] = 0.5,
    min_intensity: Annotated[
        float | None,
        typer.Option(
            "--min-intensity",
            help="Intensity of a target return (default: Otsu's threshold per target).",
        ),
    ] = None,
    centre: Annotated[
        str,
        typer.Option(
            "--centre",
            help="Target centre: 'tukey' (robust centroid, flat discs), 'median' or 'sphere' "
            "(fit of a sphere of --target-radius-m).",
        ),
    ] = "tukey",
    target_radius_m: Annotated[
        float | None,
        typer.Option("--target-radius-m", help="Radius of spherical targets (m, 0.001 to 10)."),
    ] = None,
    min_points: Annotated[
        int, typer.Option("--min-points", help="Fewest bright points per visit.", min=4)
    ] = 10,
    level: LevelOpt = 0.99,
    gps_week: Annotated[
        int | None,
        typer.Option(
            "--gps-week",
            help="GPS week of LAS seconds-of-week times or an SBET. " + GPS_WEEK_SPAN_HELP,
        ),
    ] = None,
    png: Annotated[
        Path | None,
        typer.Option("--png", help="Write the differences figure (dY vs speed, vs X) here."),
    ] = None,
    max_gap_s: MaxGapOpt = None,
    as_json: JsonOpt = False,
) -> None:
    """Cloud - control differences in the vehicle frame; time-error and heading tests."""
    from kinsync.pipelines.validation import control_points_file  # noqa: PLC0415

    key = centre.strip().lower()
    if key not in _CENTRES:
        msg = f"--centre must be tukey, median or sphere, got {centre!r}"
        raise InputError(msg)
    if target_radius_m is not None and key != "sphere":
        msg = (
            f"--target-radius-m is the radius of --centre sphere; with --centre {key} it "
            "would not be used: drop it, or give --centre sphere"
        )
        raise InputError(msg)
    refuse_unused_gps_week(gps_week, trajectories=[trajectory], points=[cloud])
    report = control_points_file(
        cloud,
        control,
        trajectory,
        crs=crs,
        search_radius_m=search_radius_m,
        min_intensity=min_intensity,
        centre=_CENTRES[key],
        target_radius_m=target_radius_m,
        min_points=min_points,
        level=level,
        gps_week=gps_week,
        max_gap_s=max_gap_s,
    )
    if png is not None:
        from kinsync.report.validation_figures import control_point_figure  # noqa: PLC0415

        atomic_write_bytes(png, control_point_figure(report))
    if as_json:
        doc: dict[str, Any] = report.as_document()
        doc["png"] = None if png is None else str(png)
        print_json(doc)
        return
    table = Table(title=f"Control points: {cloud} - {control} (vehicle frame, mm)")
    for name in ("point", "visit", "dX right", "dY fwd", "dZ up", "speed m/s", "side", "points"):
        table.add_column(name, justify="left" if name in ("point", "side") else "right")
    for d in report.differences:
        dx, dy, dz = d.diff_vehicle_m
        table.add_row(
            d.observation.name,
            str(d.observation.visit),
            f"{dx * 1e3:.1f}",
            f"{dy * 1e3:.1f}",
            f"{dz * 1e3:.1f}",
            f"{d.speed_m_s:.2f}",
            d.side,
            str(d.observation.n_points),
        )
    console.print(table)
    tests = Table(title=f"Signature tests (two-sided t-test at {level:.2%})")
    for name in ("signature", "estimate", "p-value", "dof", "verdict"):
        tests.add_column(name, justify="left" if name in ("signature", "verdict") else "right")
    tests.add_row(*_test_row("time error (ms)", report.time_error, 1e3))
    tests.add_row(*_test_row("heading error (deg)", report.heading_error, 1.0))
    console.print(tests)
    console.print(
        f"{counted(len(report.differences), 'visit')} in {counted(report.n_passes, 'pass')}; "
        "noise per visit "
        f"{fmt(report.residual_std_m, 1e3, 3)} mm, per pass {fmt(report.pass_std_m, 1e3, 3)} mm, "
        f"survey {fmt(report.survey_std_m, 1e3, 3)} mm; along-track offset "
        f"{fmt(report.intercept_m, 1e3, 3)} mm. Time error = latency applied - true latency: "
        "subtract it from the mount's latency_s."
    )
    for m in report.missing:
        when = "" if m.t_s is None else f" (t = {m.t_s:.3f} s)"
        console.print(f"missing {m.name}{when}: {m.reason}")
    if png is not None:
        console.print(f"figure: {png}")


@app.command("flatness")
def flatness(
    cloud: CloudOpt,
    box: Annotated[
        str,
        typer.Option(
            "--box",
            help="Wall selection 'xmin,ymin,zmin,xmax,ymax,zmax' in the cloud's CRS.",
        ),
    ],
    crs: CrsOpt = None,
    level: LevelOpt = 0.99,
    min_bow_mm: Annotated[
        float,
        typer.Option(
            "--min-bow-mm",
            help="Flag curvature only when the bow reaches this (mm); 0: the test alone.",
            min=0.0,
        ),
    ] = 0.0,
    outlier_k: Annotated[
        float,
        typer.Option("--outlier-k", help="Reject points beyond k robust sigmas.", min=1.0),
    ] = 4.0,
    png: Annotated[
        Path | None, typer.Option("--png", help="Write the residual colour map here (PNG).")
    ] = None,
    as_json: JsonOpt = False,
) -> None:
    """Plane fit of a wall, residual statistics and the curvature test (time or mount error)."""
    from kinsync.cli._box import parse_box  # noqa: PLC0415
    from kinsync.pipelines.validation import flatness_file  # noqa: PLC0415

    the_box = parse_box(box)
    result = flatness_file(
        cloud, the_box, crs=crs, level=level, outlier_k=outlier_k, min_bow_m=min_bow_mm * 1e-3
    )
    if png is not None:
        from kinsync.report.validation_figures import wall_residual_figure  # noqa: PLC0415

        atomic_write_bytes(png, wall_residual_figure(result))
    if as_json:
        doc: dict[str, Any] = result.as_document()
        doc["png"] = None if png is None else str(png)
        print_json(doc)
        return
    table = quantity_table(f"Flatness of {cloud} in box {box}")
    table.add_row("points used / selected", f"{result.n_points} / {result.n_selected}")
    table.add_row("rejected (gross outliers)", str(result.n_rejected))
    table.add_row(
        "extent along / up the wall (m)", f"{result.extent_u_m:.2f} / {result.extent_v_m:.2f}"
    )
    table.add_row("residual RMS (mm)", fmt(result.rms_m, 1e3))
    table.add_row("max |residual| (mm)", fmt(result.max_abs_m, 1e3))
    for key, value in result.percentiles_m.items():
        table.add_row(f"|residual| {key} (mm)", fmt(value, 1e3))
    table.add_row(
        "bow: quadratic - plane, peak to valley (mm)",
        f"{fmt(result.bow_m, 1e3)} ± {fmt(result.bow_std_m, 1e3)} (biased up: > 0 on a flat wall)",
    )
    table.add_row(
        f"curvature F (3, {result.n_points - 6}), errors correlated along the wall",
        fmt(result.f_statistic),
    )
    table.add_row(
        "error along the wall: correlated sigma (mm) / length (m) / white (mm)",
        f"{fmt(result.drive_noise_m, 1e3)} / {fmt(result.drive_correlation_m)} / "
        f"{fmt(result.white_noise_m, 1e3)}",
    )
    table.add_row("curvature p-value", format_p_value(result.p_value, prefix=False))
    table.add_row(
        f"curvature significant at {result.level:.2%}",
        "YES" if result.curvature_significant else "no",
    )
    console.print(table)
    console.print(result.verdict)
    if png is not None:
        console.print(f"figure: {png}")
