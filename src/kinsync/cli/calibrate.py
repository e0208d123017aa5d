"""``kinsync calibrate``: mount self-calibration from survey lines, and its planner."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.table import Table

from kinsync._text import counted
from kinsync.cli._bounds import bounds_for, check_numeric_option
from kinsync.cli._help import literal
from kinsync.cli._options import GPS_WEEK_SPAN_HELP, MaxGapOpt, refuse_unused_gps_week
from kinsync.cli._output import console, print_json, warn
from kinsync.cli._progress import progress_display
from kinsync.errors import InputError
from kinsync.io.atomic import atomic_write_text
from kinsync.io.mount_file import read_mount
from kinsync.mount import MountUncertainty
from kinsync.progress import Stages

if TYPE_CHECKING:
    from kinsync.calibration.estimator import CalibrationOptions
    from kinsync.calibration.planning import PlanResult
    from kinsync.calibration.result import CalibrationResult

app = typer.Typer(
    help="Mount self-calibration (boresight, lever arm, latency) from survey lines.",
    no_args_is_help=True,
)

JsonOpt = Annotated[bool, typer.Option("--json", help="Print one JSON object, nothing else.")]
EstimateOpt = Annotated[
    str,
    typer.Option(
        "--estimate",
        help="Parameter groups to estimate: boresight, lever (or lever_xy, lever_z), latency.",
    ),
]
FeaturesOpt = Annotated[
    str,
    typer.Option(
        "--features",
        help="'planes': planar patches found where the lines overlap (ground, walls, roofs); "
        "'spheres': sphere targets seen on several lines.",
    ),
]
RadiusOpt = Annotated[
    float | None,
    typer.Option("--sphere-radius-m", help="Known sphere radius (m); fitted when not given."),
]
PatchVoxelOpt = Annotated[
    float | None,
    typer.Option(
        "--patch-voxel-m",
        help="Edge of the cells the planar patches are found in (m; default 2). With "
        "--patch-min-points-per-line it sets the density a line needs: 15 returns in a 2 m "
        "cell is about 3.75 returns/m2; sparse airborne strips need larger cells.",
    ),
]
PatchMinPointsOpt = Annotated[
    int | None,
    typer.Option(
        "--patch-min-points-per-line",
        help="Returns a line needs in a cell for its plane to count (default 15).",
    ),
]
PatchThicknessOpt = Annotated[
    float | None,
    typer.Option(
        "--patch-max-thickness-m",
        help="Largest thickness of a line's returns in a cell for it to be flat (m; default "
        "0.05): above the scanner's range noise, below a car's or a bush's depth.",
    ),
]


PATCH_OPTIONS = {
    "voxel_m": "--patch-voxel-m",
    "min_points_per_line": "--patch-min-points-per-line",
    "max_thickness_m": "--patch-max-thickness-m",
}
"""The `PatchOptions` fields `calibrate mount` takes, with their options."""


def _options(
    features: str,
    estimate: str,
    sphere_radius_m: float | None,
    max_gap_s: float | None = None,
    patch: tuple[float | None, int | None, float | None] = (None, None, None),
) -> CalibrationOptions:
    """The calibration's options from the command's.

    ``patch``: --patch-voxel-m, --patch-min-points-per-line and --patch-max-thickness-m
    as given (None: the default).
    """
    from kinsync.calibration.estimator import CalibrationOptions  # noqa: PLC0415
    from kinsync.calibration.parameters import estimated_indices  # noqa: PLC0415
    from kinsync.calibration.planes import PatchOptions  # noqa: PLC0415
    from kinsync.calibration.spheres import SphereOptions  # noqa: PLC0415

    if features not in ("planes", "spheres"):
        msg = f"--features must be planes or spheres, got {features!r}"
        raise InputError(msg)
    groups = tuple(g.strip() for g in estimate.split(",") if g.strip())
    estimated_indices(groups)
    if sphere_radius_m is not None and features != "spheres":
        msg = "--sphere-radius-m applies to --features spheres"
        raise InputError(msg)
    given = {
        name: value for name, value in zip(PATCH_OPTIONS, patch, strict=True) if value is not None
    }
    if given and features != "planes":
        named = ", ".join(PATCH_OPTIONS[name] for name in given)
        msg = f"{named} appl{'ies' if len(given) == 1 else 'y'} to --features planes"
        raise InputError(msg)
    return CalibrationOptions(
        features=features,  # type: ignore[arg-type]
        estimate=groups,
        patches=PatchOptions(**given),  # type: ignore[arg-type]
        spheres=SphereOptions(radius_m=sphere_radius_m),
        max_gap_s=max_gap_s,
    )


def _fmt(value: float, digits: int = 4) -> str:
    return "-" if not math.isfinite(value) else f"{value:.{digits}g}"


def _print_result(result: CalibrationResult) -> None:
    table = Table(title="Mount calibration")
    split = any(p.held_std > 0.0 for p in result.parameters)
    cols = ("parameter", "prior", "calibrated", "sigma", *(("data", "held") if split else ()))
    for col in (*cols, "status"):
        table.add_column(col, justify="left" if col in ("parameter", "status") else "right")
    for p in result.parameters:
        parts = (_fmt(p.data_std, 2), _fmt(p.held_std, 2)) if split else ()
        table.add_row(p.name, _fmt(p.prior, 6), _fmt(p.value, 6), _fmt(p.std, 2), *parts, p.status)
    console.print(table)
    console.print(f"sigma: {result.sigma_method}")
    if result.held is not None:
        for line in result.held.lines():
            console.print(f"held: {line}")

    for name, reason in result.rejected_lines:
        console.print(f"rejected line {name}: {reason}")
    _print_undetermined(result.unobservable_reasons, result.advice)
    console.print(
        f"{counted(len(result.features), 'feature')}, {counted(len(result.lines), 'line')}; "
        "residual RMS "
        f"{result.residual_rms_before_m * 100:.2f} cm -> {result.residual_rms_after_m * 100:.2f} cm"
    )


def _write_certificate(result: CalibrationResult, path: Path) -> None:
    from kinsync.report.calibration import calibration_certificate  # noqa: PLC0415

    atomic_write_text(path, calibration_certificate(result))


_PLAN_MONTE_CARLO = (
    "against a 64-run Monte Carlo of the same designs (benchmarks/bench_calibration_sigma.py) "
    "the spread of the estimates was 0.83-1.27 times the planned sigma on the vehicle (roll "
    "boresight 1.27, yaw 1.08) and 0.80-1.36 on the vessel (latency 1.36, pitch 1.22); the "
    "statuses held"
)
"""How far the plan was from the spread it predicts: printed with every plan (README)."""


@app.command("mount")
def mount(
    points: Annotated[
        list[Path],
        typer.Option(
            "--points",
            help="Scanner-frame points, one file per line or pass: .las/.laz (gps_time) or "
            ".csv/.parquet with t_s,x_m,y_m,z_m, or CIDCO LidarToolkit pass files (.txt, "
            "with their own trajectory). Several files after one flag (a shell glob: "
            "--points lines/*.laz), or the flag repeated.",
        ),
    ],
    mount_file: Annotated[
        Path,
        typer.Option(
            "--mount",
            help=literal(
                "The mount the data were acquired with (TOML): the starting values. The "
                "standard deviations in its [uncertainty] table of the values held (not "
                "estimated) are added to the sigma of those estimated."
            ),
        ),
    ],
    trajectory: Annotated[
        list[Path] | None,
        typer.Option(
            "--trajectory",
            help="Trajectory (.csv, SBET, or POSPac / IE text export): one for all files, "
            "or one per --points file, in the same order, after one flag or the flag "
            "repeated (none with CIDCO pass files).",
        ),
    ] = None,
    features: FeaturesOpt = "planes",
    sphere_radius_m: RadiusOpt = None,
    patch_voxel_m: PatchVoxelOpt = None,
    patch_min_points_per_line: PatchMinPointsOpt = None,
    patch_max_thickness_m: PatchThicknessOpt = None,
    estimate: EstimateOpt = "boresight,latency",
    gps_week: Annotated[
        int | None,
        typer.Option(
            "--gps-week",
            help="GPS week of SBET / LAS seconds-of-week times. " + GPS_WEEK_SPAN_HELP,
        ),
    ] = None,
    out: Annotated[
        Path | None, typer.Option("--out", help="Write the calibrated mount (TOML) here.")
    ] = None,
    report: Annotated[
        Path | None,
        typer.Option("--report", help="Write the calibration certificate (HTML) here."),
    ] = None,
    max_gap_s: MaxGapOpt = None,
    as_json: JsonOpt = False,
) -> None:
    """Calibrate boresight, lever arm and latency from overlapping lines.

    Returns in a data gap of their trajectory (see --max-gap-s) are refused, as returns
    outside it are.
    """
    from kinsync.pipelines.calibration import calibrate_files  # noqa: PLC0415

    patch = (patch_voxel_m, patch_min_points_per_line, patch_max_thickness_m)
    opts = _options(features, estimate, sphere_radius_m, max_gap_s, patch)
    trajectory = trajectory or []
    refuse_unused_gps_week(gps_week, trajectories=trajectory, points=points)
    prior = read_mount(mount_file)
    with progress_display("calibrate mount") as progress:
        run = calibrate_files(
            points,
            trajectory,
            prior,
            opts,
            gps_week=gps_week,
            mount_out=out,
            report_out=report,
            write_report=_write_certificate,
            progress=progress,
            mount_source=mount_file,
        )
    for line in (*run.result.warnings, *run.result.held_advice):
        warn(line)
    if as_json:
        doc: dict[str, Any] = run.result.as_document()
        doc["n_points"] = run.n_points
        if opts.features == "planes":
            doc["patch_options"] = {name: getattr(opts.patches, name) for name in PATCH_OPTIONS}
        print_json(doc)
        return
    _print_result(run.result)
    for path in (run.mount_path, run.report_path):
        if path is not None:
            console.print(f"wrote {path}")
    if run.mount_path is not None:
        for note in run.result.uncertainty_notes:
            console.print(f"note: {note}")


@app.command("plan")
def plan(
    scenario: Annotated[
        str,
        typer.Option("--scenario", help="Simulated survey design: vehicle or vessel."),
    ] = "vehicle",
    features: FeaturesOpt = "planes",
    estimate: EstimateOpt = "boresight,lever,latency",
    speeds_m_s: Annotated[
        str | None,
        typer.Option("--speeds-m-s", help="Line speeds, comma-separated (m/s)."),
    ] = None,
    passes: Annotated[
        int, typer.Option("--passes", help="Lines per direction and speed.", min=1)
    ] = 2,
    range_noise_m: Annotated[
        float, typer.Option("--range-noise-m", help="Scanner range noise (m).")
    ] = 0.01,
    position_std_m: Annotated[
        str,
        typer.Option(
            "--position-std-m",
            help="Trajectory position error (m): one sigma for every axis, or N,E,D "
            "(heights are often 1.5-2 times worse).",
        ),
    ] = "0.02,0.02,0.03",
    attitude_std_deg: Annotated[
        str,
        typer.Option(
            "--attitude-std-deg",
            help="Trajectory misorientation (deg): one sigma for every axis, or about "
            "N,E,D (heading is often 2 times worse).",
        ),
    ] = "0.005,0.005,0.01",
    corr_time_s: Annotated[
        float,
        typer.Option("--corr-time-s", help="Correlation time of the trajectory errors (s)."),
    ] = 15.0,
    lever_std_m: Annotated[
        str | None,
        typer.Option(
            "--lever-std-m",
            help="How well the lever arm is known where the calibration holds it (not "
            "estimated, or not determined): one sigma, or x,y,z (m). Added to the planned "
            "sigma of the estimates; without it a held value is taken as exact.",
        ),
    ] = None,
    boresight_std_deg: Annotated[
        str | None,
        typer.Option(
            "--boresight-std-deg",
            help="As --lever-std-m, for the boresight: one sigma, or roll,pitch,yaw (deg).",
        ),
    ] = None,
    latency_std_ms: Annotated[
        float | None,
        typer.Option("--latency-std-ms", help="As --lever-std-m, for the latency (ms)."),
    ] = None,
    held_mount: Annotated[
        Path | None,
        typer.Option(
            "--mount",
            help=literal(
                "A mount whose [uncertainty] (and [uncertainty.correlation]) gives how well "
                "the held values are known, e.g. an earlier calibration's --out: instead of "
                "--lever-std-m / --boresight-std-deg / --latency-std-ms. Its values are not "
                "used (the design is the scenario's)."
            ),
        ),
    ] = None,
    as_json: JsonOpt = False,
) -> None:
    """Predict each parameter's sigma and status for a survey design, before the survey."""
    from kinsync.calibration.planning import NavigationErrors, plan_calibration  # noqa: PLC0415
    from kinsync.sim.patch_test import PatchTestConfig, simulate_patch_test  # noqa: PLC0415

    opts = _options(features, estimate, None)
    held = _held_uncertainty(lever_std_m, boresight_std_deg, latency_std_ms)
    if held_mount is not None:
        if held is not None:
            msg = (
                "--mount gives the held values' sigma (its [uncertainty]): drop "
                "--lever-std-m / --boresight-std-deg / --latency-std-ms, or --mount"
            )
            raise InputError(msg)
        held = read_mount(held_mount).uncertainty
        if held is None:
            msg = (
                f"--mount {held_mount}: the mount has no [uncertainty] table, so it says "
                "nothing of how well the held values are known; give one, or the sigma "
                "options"
            )
            raise InputError(msg)
    att = _one_or_three(attitude_std_deg, "--attitude-std-deg")
    pos_ned = _one_or_three(position_std_m, "--position-std-m")
    errors = NavigationErrors(range_noise_m, pos_ned, (att[0], att[1], att[2]), corr_time_s)
    speeds = None if speeds_m_s is None else _floats(speeds_m_s, "--speeds-m-s", None)
    if scenario not in ("vehicle", "vessel"):
        msg = f"--scenario must be vehicle or vessel, got {scenario!r}"
        raise InputError(msg)
    if opts.features == "spheres":  # the sphere search found none and blamed files
        msg = (
            "--features spheres: the simulated vehicle design has no sphere targets, and the "
            "vessel design's two spheres get too few returns per line to plan with; plan with "
            "--features planes (walls, roofs, ground)"
            if scenario == "vehicle"
            else "--features spheres: the simulated vessel design's two spheres get too few "
            "returns per line to plan with, and the vehicle design has none; plan with "
            "--features planes (quay wall and deck, shed, shore)"
        )
        raise InputError(msg)
    config = PatchTestConfig(
        scenario=scenario,  # type: ignore[arg-type]
        speeds_m_s=speeds,
        passes_per_direction=passes,
        range_noise_m=0.0,
        std_pos_ned_m=(0.0, 0.0, 0.0),
        std_att_deg=(0.0, 0.0, 0.0),
        density=0.25,
    )
    with progress_display("calibrate plan") as progress:  # 20-60 s with many passes
        stages = Stages(progress, {"simulating the design": 2.0, "predicting": 1.0})
        stages.start("simulating the design", f"simulating the {scenario} design")
        sim = simulate_patch_test(config)
        stages.start("predicting", f"predicting from {counted(len(sim.lines), 'line')}")
        result = plan_calibration(sim.lines, sim.mount_true, opts, errors, held)
        stages.finish()
    if as_json:
        doc = result.as_document()
        doc["notes"] = [
            *_unused_held_sigma(result, None if held_mount else held),
            _PLAN_MONTE_CARLO,
        ]
        print_json(doc)
        return
    table = Table(title=f"Calibration plan: {scenario}, {counted(result.n_lines, 'line')}")
    split = any(p.std_held > 0.0 for p in result.parameters)
    cols = ("parameter", "status", "sigma", "sigma (no navigation errors)", *(("held",) * split))
    for col in cols:
        table.add_column(col, justify="left" if col in ("parameter", "status") else "right")
    for p in result.parameters:
        held_part = (_fmt(p.std_held if math.isfinite(p.std) else math.nan, 2),) * split
        table.add_row(p.name, p.status, _fmt(p.std, 2), _fmt(p.std_noise_only, 2), *held_part)
    console.print(table)
    e = result.errors
    console.print(
        f"assumed: range noise {e.range_noise_m:g} m; trajectory position "
        f"{'/'.join(f'{v:g}' for v in e.position_std_ned_m)} m N/E/D and misorientation "
        f"{'/'.join(f'{v:g}' for v in e.attitude_std_deg)} deg about N/E/D, correlated over "
        f"{e.corr_time_s:g} s"
    )
    if result.held.estimated:
        for line in result.held.lines():
            console.print(f"held: {line}")
    _print_undetermined(result.unobservable_reasons, result.advice)
    for note in _unused_held_sigma(result, None if held_mount else held):
        console.print(f"note: {note}")
    console.print(f"note: {_PLAN_MONTE_CARLO}")


def _held_uncertainty(
    lever_std_m: str | None, boresight_std_deg: str | None, latency_std_ms: float | None
) -> MountUncertainty | None:
    """The planned held values' sigma from the options (None when none is given).

    Each is refused beyond what a mount file's ``[uncertainty]`` is read without a
    warning (1 m, 5 deg, 100 ms): a unit mistake, or a value too poorly known for the
    linear propagation the plan makes.
    """
    from kinsync.mount import WARN_STD  # noqa: PLC0415

    def vector(text: str | None, option: str, limit: float) -> tuple[float, float, float] | None:
        if text is None:
            return None
        values = _one_or_three(text, option)
        if max(values) > limit:
            msg = (
                f"{option} {text!r}: a sigma beyond {limit:g} is a unit mistake or too "
                "poorly known to plan with; estimate the value instead"
            )
            raise InputError(msg)
        return values

    lever = vector(lever_std_m, "--lever-std-m", WARN_STD["lever_arm_body_m"])
    bore = vector(boresight_std_deg, "--boresight-std-deg", WARN_STD["boresight_rpy_deg"])
    if lever is None and bore is None and latency_std_ms is None:
        return None
    latency = None if latency_std_ms is None else latency_std_ms / 1000.0
    return MountUncertainty(lever, bore, latency)


def _unused_held_sigma(result: PlanResult, held: MountUncertainty | None) -> list[str]:
    """A note for each held-value sigma given for values the plan estimates."""
    from kinsync.calibration.parameters import (  # noqa: PLC0415
        BORESIGHT,
        LATENCY,
        LEVER,
        PARAMETER_NAMES,
    )

    if held is None:
        return []
    groups = {
        "--lever-std-m": (held.lever_arm_body_m, LEVER),
        "--boresight-std-deg": (held.boresight_rpy_deg, BORESIGHT),
        "--latency-std-ms": (held.latency_s, (LATENCY,)),
    }
    status = [p.status for p in result.parameters]
    return [
        f"{option} is not used: the plan estimates " + ", ".join(PARAMETER_NAMES[i] for i in group)
        for option, (given, group) in groups.items()
        if given is not None and all(status[i] in ("estimated", "weak") for i in group)
    ]


def _print_undetermined(reasons: tuple[str, ...], advice: tuple[str, ...]) -> None:
    """What the data could not determine, and which data would."""
    for reason in reasons:
        console.print(f"not determined: {reason}")
    for line in advice:
        console.print(f"would determine it: {line}")


def _one_or_three(text: str, option: str) -> tuple[float, float, float]:
    """An option's one number (for all three axes) or three."""
    values = _floats(text, option, None)
    if len(values) not in (1, 3):
        msg = f"{option} {text!r}: expected one number or three, got {len(values)}"
        raise InputError(msg)
    x, y, z = values * 3 if len(values) == 1 else values
    return (x, y, z)


def _floats(text: str, option: str, count: int | None) -> tuple[float, ...]:
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        msg = f"{option} {text!r}: expected comma-separated numbers"
        raise InputError(msg) from None
    if count is not None and len(values) != count:
        msg = f"{option} {text!r}: expected {count} numbers, got {len(values)}"
        raise InputError(msg)
    span = bounds_for("calibrate plan", option)
    for v in values:
        if not (math.isfinite(v) and v >= 0.0):
            if span is not None and span.low > 0.0:  # the real span (0.2 to 40 m/s), not >= 0
                check_numeric_option("calibrate plan", option, v)
            msg = f"{option} {text!r}: every value must be a finite number >= 0"
            raise InputError(msg)
        check_numeric_option("calibrate plan", option, v)
    return values
