"""``kinsync sync``: put a profile scanner on the trajectory's time scale (Method B)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from rich.table import Table

from kinsync._text import counted
from kinsync.cli._help import literal
from kinsync.cli._options import GPS_WEEK_SPAN_HELP, MaxGapOpt, refuse_unused_gps_week
from kinsync.cli._output import console, fmt, print_json, quantity_table, warn
from kinsync.cli._progress import progress_display
from kinsync.errors import InputError, ObservabilityError
from kinsync.io.mount_file import read_mount
from kinsync.progress import Stages

if TYPE_CHECKING:
    from kinsync.mount import Mount
    from kinsync.sync.clock_mount import ClockMount
    from kinsync.sync.object_space import ObjectSpaceResult

app = typer.Typer(
    help="Synchronise a profile scanner to the trajectory in object space (Method B)."
)

JsonOpt = Annotated[bool, typer.Option("--json", help="Print one JSON object instead of a table.")]


@app.command("object-space")
def object_space(
    scan: Annotated[
        Path,
        typer.Option(
            "--scan", help="Scan table (.csv/.parquet): profile,angle_rad,range_m,intensity."
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
        Path,
        typer.Option("--mount", help=literal("Mount TOML with a [profiler] azimuth_deg.")),
    ],
    sync_points: Annotated[
        Path, typer.Option("--sync-points", help="Sync points CSV: name,lat_deg,lon_deg,h_m.")
    ],
    pulses: Annotated[
        Path | None,
        typer.Option("--pulses", help="Hardware profile pulses CSV (t_s, GPS time), optional."),
    ] = None,
    period_prior_s: Annotated[
        float,
        typer.Option(
            "--period-prior-s",
            help=(
                "Prior mirror period (s), from the scanner's datasheet or log; refused, with "
                "the period the data suggest, when a period outside its tolerance fits more "
                "sightings."
            ),
        ),
    ] = 0.0303,
    period_tolerance: Annotated[
        float,
        typer.Option("--period-tolerance", help="Relative tolerance of the prior (0.01 = 1 %)."),
    ] = 0.01,
    intensity_threshold: Annotated[
        float,
        typer.Option("--intensity-threshold", help="Returns this bright are target candidates."),
    ] = 0.8,
    position_std_m: Annotated[
        float,
        typer.Option(
            "--position-std-m",
            help="A-priori sigma of trajectory and sync-point positions (m); 0 for exact data.",
        ),
    ] = 0.02,
    position_corr_time_s: Annotated[
        float,
        typer.Option(
            "--position-corr-time-s",
            help=(
                "Correlation time of the trajectory's position error (s): sightings a few "
                "seconds apart share it; 0 takes the errors as independent."
            ),
        ),
    ] = 15.0,
    max_range_m: Annotated[
        float, typer.Option("--max-range-m", help="Farthest sync-point crossing considered (m).")
    ] = 80.0,
    gps_week: Annotated[
        int | None,
        typer.Option(
            "--gps-week",
            help="GPS week of an SBET's seconds-of-week times. " + GPS_WEEK_SPAN_HELP,
        ),
    ] = None,
    max_gap_s: MaxGapOpt = None,
    accept_ambiguous: Annotated[
        bool,
        typer.Option(
            "--accept-ambiguous",
            help=(
                "Write the best clock even when other matches of sightings to sync-point "
                "crossings fit almost as well (refused otherwise; --pulses can settle it)."
            ),
        ),
    ] = False,
    as_json: JsonOpt = False,
) -> None:
    """Find the profile clock t0, T from sync points seen in the scan."""
    # Method B (scipy.optimize), kinsync.georef and the readers load only when this runs.
    from kinsync.io.profile_scan import (  # noqa: PLC0415
        pulse_line,
        read_profile_scan,
        read_pulses,
        read_sync_points,
    )
    from kinsync.io.trajectory import read_trajectory_file  # noqa: PLC0415
    from kinsync.sync import (  # noqa: PLC0415
        ObjectSpaceConfig,
        require_profiler_azimuth,
        synchronise_object_space,
    )
    from kinsync.sync.clock_mount import ClockMount  # noqa: PLC0415

    refuse_unused_gps_week(gps_week, trajectories=[trajectory])
    config = ObjectSpaceConfig(
        period_prior_s=period_prior_s,
        period_tolerance=period_tolerance,
        intensity_threshold=intensity_threshold,
        position_std_m=position_std_m,
        position_corr_time_s=position_corr_time_s,
        max_range_m=max_range_m,
        max_gap_s=max_gap_s,
    )
    the_mount = read_mount(mount)
    require_profiler_azimuth(the_mount, str(mount))
    with progress_display("sync object-space") as progress:
        stages = Stages(progress, {"reading inputs": 1.0, "matching": 3.0})
        stages.start("reading inputs")
        the_scan = read_profile_scan(scan)
        traj, _scale = read_trajectory_file(trajectory, gps_week=gps_week)
        points = read_sync_points(sync_points)
        pulse_t = None if pulses is None else read_pulses(pulses)
        stages.start("matching", "matching sightings to sync-point crossings")
        result = synchronise_object_space(
            the_scan,
            traj,
            the_mount,
            points,
            config,
            pulses_t_s=pulse_t,
            pulses_source=str(pulses),
            pulses_where=None if pulses is None else pulse_line(pulses),
        )
        stages.finish()
    _warn_or_refuse(result, trajectory, sync_points, pulses, accept_ambiguous=accept_ambiguous)
    if as_json:
        # The clock holds the mount (1 ms of latency_s is 1 ms of t0): recorded, so that
        # sync apply can refuse another mount.
        doc = result.as_document()
        doc["mount"] = ClockMount.of(the_mount, str(mount)).as_document()
        print_json(doc)
        return
    table = quantity_table(
        f"Profile clock of {scan} from {counted(len(result.sightings), 'sighting')}"
    )
    table.add_row("t0 (s)", f"{result.t0_s:.6f}")
    table.add_row("t0 sigma (ms)", fmt(result.t0_std_s, 1e3))
    mount_cov = None if result.mount_effect is None else result.mount_effect.covariance
    if mount_cov is not None and mount_cov[0, 0] > 0.0:  # the mount file states sigma
        table.add_row("  of which the mount's (ms)", fmt(math.sqrt(mount_cov[0, 0]), 1e3))
    table.add_row("period (s)", f"{result.period_s:.9f}")
    table.add_row("period sigma (us)", fmt(result.period_std_s, 1e6))
    if mount_cov is not None and mount_cov[1, 1] > 0.0:
        table.add_row("  of which the mount's (us)", fmt(math.sqrt(mount_cov[1, 1]), 1e6))
    table.add_row("sigma scale (residuals)", fmt(result.sigma_scale))
    table.add_row("unmatched sightings", str(len(result.unmatched)))
    table.add_row("crossings in trajectory gaps (left out)", str(len(result.crossings_in_gaps)))
    settled = " (settled by the pulses)" if result.settled_by_pulses else ""
    table.add_row("ambiguous", "yes" if result.ambiguous else f"no{settled}")
    if result.pulses is not None:
        sure = "" if result.pulses.sure else " (not sure)"
        table.add_row("pulse offset", f"{result.pulses.offset}{sure}")
    console.print(table)
    cells = [
        (
            s.name,
            f"{s.profile:.3f}",
            f"{math.degrees(s.angle_rad):.2f}",
            f"{s.t_s:.4f}",
            f"{s.helix_correction_s * 1e3:.3f}",
            f"{s.residual_s * 1e3:.3f}",
        )
        for s in result.sightings
    ]
    rows = Table(title="Sightings (regression pairs)")
    headers = ("sync point", "profile", "angle (deg)", "t (s)", "helix (ms)", "residual (ms)")
    for i, col in enumerate(headers):
        # A number is never cut short on a narrow terminal or in a pipe (the times
        # showed as "1400000014…"); the headers wrap instead.
        width = max((len(row[i]) for row in cells), default=0)
        rows.add_column(col, justify="right", min_width=width, overflow="fold")
    for row in cells:
        rows.add_row(*row)
    console.print(rows)


def _warn_or_refuse(
    result: ObjectSpaceResult,
    trajectory: Path,
    sync_points: Path,
    pulses: Path | None,
    *,
    accept_ambiguous: bool,
) -> None:
    """Warn of crossings left out in trajectory gaps; refuse an ambiguous clock not accepted."""
    from kinsync.trajectory_gaps import GAP_ADVICE, gap_threshold_text  # noqa: PLC0415

    if result.crossings_in_gaps:
        gaps = result.crossings_in_gaps
        named = "; ".join(f"{c.name} in {c.gap.describe()}" for c in gaps[:3])
        more = f"; and {len(gaps) - 3} more" if len(gaps) > 3 else ""
        warn(
            f"{trajectory}: {len(gaps)} possible sync-point crossing(s) left "
            f"out, in data gaps of the trajectory ({named}{more}), "
            f"{gap_threshold_text(result.gap_threshold_s)}, where it is not interpolated; a "
            f"sighting there stays unmatched: {GAP_ADVICE}"
        )
    if result.ambiguous and not accept_ambiguous:
        raise ObservabilityError(_ambiguity_message(result, sync_points, pulses))
    if result.ambiguous:
        warn(
            f"ambiguous: {len(result.alternatives)} other assignment(s) of "
            "sightings to crossings fit almost as well; see 'alternatives'"
        )


def _ambiguity_message(result: ObjectSpaceResult, sync_points: Path, pulses: Path | None) -> str:
    """Why an ambiguous clock is refused, with the alternatives and what to do."""
    others = "; ".join(f"{a.t0_s:.6f} s" for a in result.alternatives)
    unsettled = (
        f"; the pulses ({pulses}) allow these too, so they cannot settle it"
        if pulses is not None
        else ""
    )
    settle = (
        "" if pulses is not None else "give --pulses (the scanner's GPS-timed profile pulses), "
    )
    lone = sum(a.n_matched < len(result.sightings) for a in result.alternatives)
    n_all = len(result.sightings) + len(result.unmatched)
    alone = (
        f"; the best rests on {len(result.sightings)} of {n_all} sightings, which any line "
        f"fits, and {lone} of the others each match one sighting it leaves out alone (with "
        "its period)"
        if lone
        else ""
    )
    seen_off = [name for name in result.unmatched_at if name is not None]
    if seen_off:  # passing them again would not help: they were seen, and fit no clock
        names = ", ".join(sorted(set(seen_off)))
        why = (
            f"; {len(seen_off)} sighting(s) lie where the scan plane crosses sync point(s) "
            f"{names} but fit none of these clocks: check the mount (lever arm, boresight, "
            "latency, [profiler] azimuth_deg) and the sync points' coordinates (heights too)"
        )
        advice = ""
    else:
        why = ""
        advice = "pass each sync point at the start and at the end of the drive, "
    return (
        f"{sync_points}: ambiguous: {len(result.alternatives)} other match(es) of sightings to "
        f"sync-point crossings fit almost as well as the best, t0 = {result.t0_s:.6f} s "
        f"(others: t0 = {others}), so its clock is not sure{alone}{unsettled}{why}: {settle}"
        f"{advice}"
        "or take the best with --accept-ambiguous"
    )


@app.command("apply")
def apply(
    scan: Annotated[
        Path, typer.Option("--scan", help="Scan table (.csv/.parquet) with profile,angle_rad.")
    ],
    mount: Annotated[
        Path, typer.Option("--mount", help=literal("Mount TOML with a [profiler] azimuth_deg."))
    ],
    out: Annotated[
        Path,
        typer.Option(
            "--out",
            help="Output table (.csv/.parquet): every input column + t_s,x_m,y_m,z_m.",
        ),
    ],
    t0_s: Annotated[float | None, typer.Option("--t0-s", help="Clock t0 (s).")] = None,
    period_s: Annotated[float | None, typer.Option("--period-s", help="Clock period (s).")] = None,
    clock: Annotated[
        Path | None,
        typer.Option("--clock", help="JSON with t0_s and period_s (object-space --json output)."),
    ] = None,
    chunk_points: Annotated[
        int, typer.Option("--chunk-points", help="Rows per chunk (bounds memory).", min=1)
    ] = 1_000_000,
    accept_ambiguous: Annotated[
        bool,
        typer.Option(
            "--accept-ambiguous",
            help="Apply a --clock marked ambiguous (refused otherwise: its t0 may be whole "
            "seconds off).",
        ),
    ] = False,
    as_json: JsonOpt = False,
) -> None:
    """Write the scan with a time and scanner-frame coordinates per return."""
    from kinsync.io.profile_scan import read_clock_file  # noqa: PLC0415
    from kinsync.pipelines.sync_apply import apply_profile_clock  # noqa: PLC0415
    from kinsync.sync.crossings import require_profiler_azimuth  # noqa: PLC0415

    if clock is not None and (t0_s is not None or period_s is not None):
        msg = "give either --clock or --t0-s with --period-s, not both"
        raise InputError(msg)
    if accept_ambiguous and clock is None:
        msg = "--accept-ambiguous applies to a --clock file marked ambiguous; give --clock"
        raise InputError(msg)
    clock_file = None
    if clock is not None:
        clock_file = read_clock_file(clock, accept_ambiguous=accept_ambiguous)
        t0, period = clock_file.t0_s, clock_file.period_s
    elif t0_s is not None and period_s is not None:
        t0, period = t0_s, period_s
    else:
        msg = "give the clock: --t0-s and --period-s, or --clock RESULT.json"
        raise InputError(msg)
    if not (math.isfinite(t0) and math.isfinite(period) and period > 0.0):
        msg = f"--t0-s must be finite and --period-s > 0, got {t0!r} and {period!r}"
        raise InputError(msg)
    the_mount = read_mount(mount)
    require_profiler_azimuth(the_mount, str(mount))
    if clock is not None and clock_file is not None:
        _check_clock_mount(clock, clock_file.mount, the_mount, mount)
    with progress_display("sync apply") as progress:
        stages = Stages(progress, {"time-tagging returns": 1.0})
        stages.start("time-tagging returns")
        n = apply_profile_clock(
            scan,
            out,
            t0,
            period,
            the_mount,
            chunk_points=chunk_points,
            progress=lambda done: stages.say(f"time-tagging returns: {done:,} done"),
            mount_file=mount,
            clock_file=clock,
        )
        stages.finish()
    doc = {"out": str(out), "points": n, "t0_s": t0, "period_s": period}
    if as_json:
        print_json(doc)
        return
    table = quantity_table(f"Time-tagged {scan} -> {out}")
    table.add_row("returns written", str(n))
    table.add_row("t0 (s)", f"{t0:.6f}")
    table.add_row("period (s)", f"{period:.9f}")
    console.print(table)


def _check_clock_mount(
    clock: Path, recorded: ClockMount | None, the_mount: Mount, mount: Path
) -> None:
    """Refuse a --mount other than the one the clock was fitted with; warn when unknown.

    The clock holds the mount's latency, lever arm, boresight and azimuth (object-space
    finds it from where the mount puts the scan plane): points time-tagged with it and
    georeferenced with another mount count the difference twice.
    """
    if recorded is None:
        warn(
            f"{clock}: the clock file does not record the mount it was fitted with (an "
            f"older kinsync's, or written by hand), so {mount} cannot be checked against "
            "it: georeference these points with that same mount (its latency_s, lever arm "
            "and boresight are in the clock's t0), or fit the clock again with kinsync "
            "sync object-space --json"
        )
        return
    differences = recorded.differences(the_mount)
    if differences:
        msg = (
            f"{clock}: the clock was fitted with mount {recorded.source}, and --mount "
            f"{mount} differs: {'; '.join(differences)}; the clock's t0 and period hold "
            f"those values, so points georeferenced with {mount} would be off: give "
            f"--mount {recorded.source} (and georeference with it), or fit the clock again "
            f"with kinsync sync object-space --mount {mount} --json"
        )
        raise InputError(msg)
