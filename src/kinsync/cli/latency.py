"""``kinsync latency``: Method A estimation from sphere passes, and experiment planning."""

from __future__ import annotations

import warnings
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from rich.table import Table

from kinsync._text import counted
from kinsync.cli._bounds import bounds_for
from kinsync.cli._help import literal
from kinsync.cli._options import MaxGapOpt, parse_rates
from kinsync.cli._output import console, print_json, warn
from kinsync.cli._progress import progress_display
from kinsync.errors import InputError
from kinsync.io.atomic import atomic_write_bytes
from kinsync.progress import Stages

if TYPE_CHECKING:
    from kinsync.latency.planning import TableDesign
    from kinsync.latency.sphere import SphereLatencyResult
    from kinsync.mount import Mount

app = typer.Typer(help="Total IMU-LiDAR latency from a sphere on a rotating table (Method A).")

JsonOpt = Annotated[bool, typer.Option("--json", help="Print one JSON object instead of a table.")]


def _print_sphere_result(
    result: SphereLatencyResult, applied_s: float, fig_path: Path | None
) -> None:
    """The per-rate table and the summary lines of ``latency sphere``."""
    total_s = result.latency_s + applied_s
    table = Table(title="Method A: latency per table rate (exact rotation model)")
    for col in (
        "rate (deg/s)",
        "points",
        "centre σ (mm)",
        "latency (ms)",
        "latency σ (ms)",
        "first-order (ms)",
        "model χ² (2 dof)",
    ):
        table.add_column(col, justify="right")
    for r in result.per_rate:
        table.add_row(*r.row_text())
    console.print(table)
    if applied_s != 0.0:
        console.print(
            f"the mount's latency_s {applied_s * 1e3:.4f} ms was applied before the fit: "
            f"the per-rate latencies are on top of it (residual "
            f"{result.latency_s * 1e3:.4f} ms)",
            markup=False,
        )
    console.print(
        f"latency {total_s * 1e3:.4f} ± {result.latency_std_s * 1e3:.4f} ms "
        f"(tau > 0: navigation lags the scanner); {result.agreement_text()}",
        markup=False,
    )
    if result.pass_scatter is not None:
        console.print(result.pass_scatter.text(), markup=False, highlight=False)
    for rejected in result.rejected_passes:
        console.print(
            f"rejected: {rejected.source} ({rejected.rate_deg_s:+g} deg/s): {rejected.reason}",
            markup=False,
            highlight=False,
        )
    if result.unpaired_rates_deg_s:
        console.print(
            f"left out (passes of one sign only): {list(result.unpaired_rates_deg_s)} deg/s"
        )
    if result.roi is not None:
        console.print(result.roi.summary_text(), markup=False, highlight=False)
    console.print(f"passes used: {result.n_passes_used} of {result.n_passes}", highlight=False)
    if fig_path is not None:
        console.print(f"figure: {fig_path}")


def _warn_about_rates(result: SphereLatencyResult, folder: Path) -> None:
    """Warn when the rates disagree, their sign and unit went unchecked, or the radius is off."""
    if result.rates_disagree:
        warn(
            f"{folder}: the table rates disagree ({result.agreement_text()}); "
            "check each pass's signed rate (deg/s) and axis in passes.csv: a wrong sign, "
            "unit or axis biases the latency, which the wider sigma does not remove"
        )
    if result.rates_unchecked_text():  # with --raw, the attitude log checks them too
        warn(f"{folder}: {result.rates_unchecked_text()}")
    if result.radius_contradiction_text():
        warn(f"{folder}: {result.radius_contradiction_text()}")
    if result.pass_scatter is not None and not result.pass_scatter.measured:
        warn(
            f"{folder}: one pass per rate and direction: an attitude error shared by the "
            "points of a pass (the INS's drift between passes) cannot be measured and is "
            "not in the sigma; scan at least 2 passes per rate and direction (5 measure it "
            "well)"
        )


def _applied_mount(folder: Path, raw: bool, mount_file: Path | None) -> Mount | None:
    """The mount the passes were georeferenced with, or None (no latency applied).

    ``raw/mount.toml`` with ``--raw``, else ``--mount``.
    """
    from kinsync.io.mount_file import read_mount  # noqa: PLC0415
    from kinsync.io.raw_passes import RAW_DIR, RAW_MOUNT_TOML  # noqa: PLC0415

    if raw:
        return read_mount(folder / RAW_DIR / RAW_MOUNT_TOML)
    return None if mount_file is None else read_mount(mount_file)


def _applied_mount_file(folder: Path, raw: bool, mount_file: Path | None) -> Path:
    """The file of the mount the passes were georeferenced with (`_applied_mount`'s)."""
    from kinsync.io.raw_passes import RAW_DIR, RAW_MOUNT_TOML  # noqa: PLC0415

    source = folder / RAW_DIR / RAW_MOUNT_TOML if raw else mount_file
    assert source is not None  # _check_mount_options: --mount-out needs a mount
    return source


def _write_mount_with_latency(
    mount: Mount, total_s: float, std_s: float, path: Path, source: Path
) -> None:
    """``mount`` (read from ``source``) with the measured total latency and its sigma.

    The sigma goes in ``[uncertainty]``. The sphere measures the latency on its own:
    correlations the mount gave for the latency no longer hold and are dropped.
    """
    from kinsync.io.mount_file import write_mount  # noqa: PLC0415
    from kinsync.mount import MountUncertainty  # noqa: PLC0415
    from kinsync.mount_slips import derived_mounts  # noqa: PLC0415

    unc = (mount.uncertainty or MountUncertainty()).with_independent(latency_s=std_s)
    with derived_mounts():  # a measured latency: no unit slip to warn of
        measured = replace(mount, latency_s=total_s, uncertainty=unc)
    write_mount(measured, path, derived_from=source)


def _check_mount_options(raw: bool, mount_file: Path | None, mount_out: Path | None) -> None:
    if raw and mount_file is not None:
        msg = (
            "--mount names the mount the pass files were georeferenced with; with --raw that "
            "is FOLDER/raw/mount.toml: drop --mount"
        )
        raise InputError(msg)
    if mount_out is not None and mount_file is None and not raw:
        msg = (
            "--mount-out writes the measured latency into a mount: give --mount, the mount "
            "the pass files were georeferenced with (latency_s = 0.0 if none was applied)"
        )
        raise InputError(msg)


@app.command("sphere")
def sphere(
    folder: Annotated[Path, typer.Argument(help="Folder with passes.csv and the pass files.")],
    radius_m: Annotated[
        float | None, typer.Option(help="Known sphere radius (m); estimated when omitted.")
    ] = None,
    figure: Annotated[
        Path | None, typer.Option(help="Figure to write (PNG); default FOLDER/latency_sphere.png.")
    ] = None,
    no_figure: Annotated[bool, typer.Option("--no-figure", help="Write no figure.")] = False,
    orthogonal: Annotated[
        bool,
        typer.Option(
            "--orthogonal", help="Fit orthogonal distances instead of ranges along the rays."
        ),
    ] = False,
    raw: Annotated[
        bool,
        typer.Option(
            "--raw",
            help="Georeference the raw input in FOLDER/raw (scanner-frame passes, attitude.csv, "
            "mount.toml) instead of reading the pass files; the latency correction comes "
            "from raw/mount.toml.",
        ),
    ] = False,
    mount_file: Annotated[
        Path | None,
        typer.Option(
            "--mount",
            help="The mount the pass files were georeferenced with: its latency_s was applied, "
            "so the total latency is it plus the fitted one (not with --raw, which uses "
            "FOLDER/raw/mount.toml).",
        ),
    ] = None,
    mount_out: Annotated[
        Path | None,
        typer.Option(
            "--mount-out",
            help=literal(
                "Write that mount with latency_s = the total latency and its sigma in "
                "[uncertainty] (TOML), e.g. for calibrate mount to hold."
            ),
        ),
    ] = None,
    roi_m: Annotated[
        str | None,
        typer.Option(
            "--roi-m",
            help="Region of interest 'xmin,ymin,zmin,xmax,ymax,zmax' (m) around the sphere, "
            "in the pass files' frame (table-centred NED, their x_m,y_m,z_m): only the "
            "points inside are fitted (floor, walls left out); those outside are counted "
            "as excluded.",
        ),
    ] = None,
    max_gap_s: MaxGapOpt = None,
    as_json: JsonOpt = False,
) -> None:
    """Estimate the total latency from sphere passes at opposite table rates.

    With --raw, --max-gap-s is the gap threshold of the attitude log.
    """
    # The estimator (scipy.optimize, scipy.stats) and the readers load only when this
    # command runs.
    from kinsync.cli._box import parse_box  # noqa: PLC0415
    from kinsync.io.passes import read_passes  # noqa: PLC0415
    from kinsync.latency.rate_check import RatesUncheckedWarning  # noqa: PLC0415
    from kinsync.latency.sphere import estimate_latency_sphere  # noqa: PLC0415
    from kinsync.pipelines.raw_passes import read_raw_passes  # noqa: PLC0415

    if no_figure and figure is not None:
        msg = f"--figure {figure} and --no-figure contradict each other; give one of them"
        raise InputError(msg)
    _check_mount_options(raw, mount_file, mount_out)
    roi = None if roi_m is None else parse_box(roi_m, "--roi-m")
    # --mount is read before any work; raw/mount.toml after the raw folder is read.
    applied = None if raw else _applied_mount(Path(folder), raw, mount_file)
    if max_gap_s is not None and not raw:
        msg = (
            "--max-gap-s is the gap threshold of the attitude log read with --raw; the pass "
            "files are georeferenced already: give --raw, or leave --max-gap-s out"
        )
        raise InputError(msg)
    with progress_display("latency sphere") as progress:
        # Measured on the README's table (15 LAZ passes): reading 0.5 s, fitting 3 s.
        stages = Stages(progress, {"reading": 0.15, "fitting": 0.85})
        reading = stages.start("reading")
        if raw:
            passes = read_raw_passes(folder, max_gap_s=max_gap_s, progress=reading)
        else:
            passes = read_passes(folder, progress=reading)
        with warnings.catch_warnings():  # said below, naming the folder: not twice
            warnings.simplefilter("ignore", RatesUncheckedWarning)
            result = estimate_latency_sphere(
                passes,
                radius_m=radius_m,
                scanner_origin_ned_m=None if orthogonal else (0.0, 0.0, 0.0),
                progress=stages.start("fitting"),
                roi_ned_m=roi,
            )
        stages.finish()
    fig_path = None if no_figure else (figure or Path(folder) / "latency_sphere.png")
    if fig_path is not None:
        from kinsync.report.latency_figures import latency_per_rate_figure  # noqa: PLC0415

        atomic_write_bytes(fig_path, latency_per_rate_figure(result))
    doc = result.as_document()
    if fig_path is not None:
        doc["figure"] = str(fig_path)
    if raw:
        applied = _applied_mount(Path(folder), raw, mount_file)
    applied_s = 0.0 if applied is None else applied.latency_s
    total_s = result.latency_s + applied_s
    if applied is not None:
        # The passes were georeferenced with the mount's latency (raw/mount.toml's, or
        # --mount's): the fit measures what is left on top of it; the total is their
        # sum. The keys are there whenever a mount is, zero or not (as documented).
        doc |= {
            "latency_ms": total_s * 1e3,
            "mount_latency_ms": applied_s * 1e3,
            "residual_latency_ms": result.latency_s * 1e3,
        }
    _warn_about_rates(result, folder)
    if mount_out is not None:
        assert applied is not None  # _check_mount_options
        source = _applied_mount_file(Path(folder), raw, mount_file)
        _write_mount_with_latency(applied, total_s, result.latency_std_s, mount_out, source)
        doc["mount_out"] = str(mount_out)
    if as_json:
        print_json(doc)
        return
    _print_sphere_result(result, applied_s, fig_path)
    if mount_out is not None:
        console.print(f"wrote {mount_out}")


@app.command("plan")
def plan(
    range_m: Annotated[float, typer.Option(help="Horizontal distance axis -> sphere (m).")] = 1.5,
    radius_m: Annotated[float, typer.Option(help="Sphere radius (m).")] = 0.1,
    range_noise_m: Annotated[float, typer.Option(help="Range noise, 1 sigma (m).")] = 0.002,
    rates_deg_s: Annotated[str, typer.Option(help="Table rates (deg/s), comma-separated.")] = (
        "2,4,6,10,14,18"
    ),
    passes: Annotated[int, typer.Option(help="Passes per rate and direction.")] = 15,
    angular_step_deg: Annotated[float, typer.Option(help="Mirror angular step (deg).")] = 0.2,
    profile_rate_hz: Annotated[float, typer.Option(help="Profiles per second.")] = 50.0,
    free_radius: Annotated[
        bool, typer.Option("--free-radius", help="Radius estimated, not known.")
    ] = False,
    target_ms: Annotated[float, typer.Option(help="Target latency sigma (ms).")] = 0.1,
    pass_attitude_error_deg: Annotated[
        float,
        typer.Option(
            help="Attitude error shared by the points of a pass, drawn anew per pass, 1 sigma "
            "per NED axis (deg; the INS's drift between passes)."
        ),
    ] = 0.0,
    figure: Annotated[Path | None, typer.Option(help="Write a PNG figure here.")] = None,
    as_json: JsonOpt = False,
) -> None:
    """Predict centre and latency precision of a rotating-table experiment (Cramér-Rao)."""
    from kinsync.latency.planning import TableDesign, plan_latency_experiment  # noqa: PLC0415

    if radius_m >= range_m:
        msg = (
            f"--radius-m {radius_m:g} must be smaller than --range-m {range_m:g} (the "
            "distance from the table axis to the sphere centre): the scanner stands outside "
            "the sphere"
        )
        raise InputError(msg)
    design = TableDesign(
        sphere_range_m=range_m,
        sphere_radius_m=radius_m,
        range_noise_m=range_noise_m,
        angular_step_deg=angular_step_deg,
        profile_rate_hz=profile_rate_hz,
        rates_deg_s=parse_rates(rates_deg_s),
        passes=passes,
        radius_known=not free_radius,
        pass_attitude_error_deg=pass_attitude_error_deg,
    )
    result = plan_latency_experiment(design)
    doc = result.as_document(target_ms * 1e-3)
    passes_span = bounds_for("latency plan", "--passes")
    passes_limit = int(passes_span.high) if passes_span is not None else 1000
    doc["passes_limit"] = passes_limit
    doc["target_within_passes_limit"] = doc["passes_for_target"] <= passes_limit
    if figure is not None:
        from kinsync.report.latency_figures import plan_figure  # noqa: PLC0415  (matplotlib)

        atomic_write_bytes(figure, plan_figure(result, target_ms * 1e-3))
        doc["figure"] = str(figure)
    if as_json:
        print_json(doc)
        return
    table = Table(
        title=f"Method A plan: {counted(passes, 'pass')} each way, range noise {range_noise_m:g} m",
        caption="centre σ: of the centre fitted to one direction's passes pooled, RMS of 3 axes",
    )
    for col in ("rate (deg/s)", "points/pass", "centre σ RMS (mm)", "latency σ (ms)"):
        table.add_column(col, justify="right")
    for r in result.per_rate:
        table.add_row(
            f"{r.rate_deg_s:g}",
            f"{r.points_per_pass:.0f}",
            f"{r.center_std_m * 1e3:.4f}",
            f"{r.latency_std_s * 1e3:.4f}",
        )
    console.print(table)
    n_target = int(doc["passes_for_target"])
    verb = "reaches" if n_target == 1 else "reach"
    if doc["target_within_passes_limit"]:
        reach = f"{counted(n_target, 'pass')} per rate and direction {verb} {target_ms:g} ms"
    else:
        reach = _target_out_of_reach_text(design, target_ms, n_target, doc["passes_limit"])
    console.print(
        f"all rates: latency σ {result.latency_std_s * 1e3:.4f} ms; {reach}", markup=False
    )


def _target_out_of_reach_text(
    design: TableDesign, target_ms: float, n_target: int, limit: int
) -> str:
    """Why ``--target-ms`` needs more passes than ``--passes`` allows, and what else helps."""
    from kinsync.latency.planning import max_usable_rate_deg_s  # noqa: PLC0415

    max_rate = max_usable_rate_deg_s(
        profile_rate_hz=design.profile_rate_hz,
        angular_step_deg=design.angular_step_deg,
        sphere_radius_m=design.sphere_radius_m,
        sphere_range_m=design.sphere_range_m,
        max_incidence_deg=design.max_incidence_deg,
    )
    return (
        f"{target_ms:g} ms cannot be reached by passes alone: it would take {n_target} "
        f"passes per rate and direction, and --passes allows at most {limit}; use a closer "
        "or larger sphere (--range-m, --radius-m), a finer angular step "
        "(--angular-step-deg), a faster profile rate (--profile-rate-hz), faster table "
        f"rates (--rates-deg-s, up to {max_rate:g} deg/s here) or a less noisy scanner"
    )
