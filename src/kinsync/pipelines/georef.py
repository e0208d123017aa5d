"""Georeferencing a point file: streamed in chunks through the kernel (SPEC section 5).

`georeference_file` reads a trajectory file, prepares it once
(`kinsync.georef.trajectory.GeorefTrajectory`) and streams the points through the
kernel (`kinsync.georef.kernel`). The input is cut once into chunks that any process
can read on its own (LAS/LAZ by seek, CSV by byte range at line boundaries, Parquet by
row group, `kinsync.pipelines.georef_chunks`); each chunk is read, georeferenced and
turned into what is to be written in one task, in this process or in worker processes
(a process pool, or a Dask cluster: `kinsync.pipelines.schedulers`), and this process
writes the results in input order, behind the next chunk's work
(`kinsync.pipelines.write_behind`). So workers also share the reading and
decompression, and every scheduler writes the same output. Every input point is
written, or written to the rejected file, or the run fails and writes nothing.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterator, Sequence
from contextlib import ExitStack
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Literal, cast

import numpy as np
import pyarrow as pa
import pyproj

from kinsync.clock.leap_seconds import PLAUSIBLE_DATE_GPS_S, gps_to_decimal_year
from kinsync.crs import (
    ECEF_WGS84,
    CrsPlan,
    CrsTransformInfo,
    crs_plan_transformer,
    plan_ecef_to_crs,
    sample_rows,
)
from kinsync.crs_axes import output_units
from kinsync.errors import InputError
from kinsync.georef.kernel import PositionMethod, check_latency, use_hermite
from kinsync.georef.profile import PROFILE_COLUMNS
from kinsync.georef.trajectory import GeorefRecords
from kinsync.io.atomic import published_together
from kinsync.io.column_map import ColumnMap
from kinsync.io.csv_lines import csv_header_line
from kinsync.io.las import (
    check_week_rollover,
    check_week_seconds,
    las_end_times,
    las_header,
    las_info,
    las_time_offset_s,
)
from kinsync.io.las_crs import georeferenced_crs_name
from kinsync.io.las_table import arrow_numpy_dtype, las_column_types, plan_table_las
from kinsync.io.las_writer import las_output_notes
from kinsync.io.points import (
    plan_table_slices,
    read_table_slice,
    table_columns,
)
from kinsync.io.sanity import require_file
from kinsync.io.trajectory import TimeScale, read_trajectory_file
from kinsync.mount import Mount
from kinsync.pipelines.georef_chunks import (
    OUT_COLUMNS,
    PLY_XYZ,
    XYZ_COLUMNS,
    ChunkContext,
    ChunkOutput,
    ChunkSource,
    ChunkTask,
    LasOutputFrame,
    OutputKind,
    OutsidePolicy,
    PointColumns,
    empty_table_output,
)
from kinsync.pipelines.georef_outputs import (
    CsvLinesRejectedSink,
    LasRejectedSink,
    LasSink,
    PlySink,
    Sink,
    TableRejectedSink,
    TableSink,
    ply_crs_comment,
)
from kinsync.pipelines.georef_record import RecordedTimes, georef_document
from kinsync.pipelines.georef_rejected import LAS_SUFFIXES as _LAS_SUFFIXES
from kinsync.pipelines.georef_rejected import TABLE_SUFFIXES as _TABLE_SUFFIXES
from kinsync.pipelines.georef_rejected import point_file_kind as _kind
from kinsync.pipelines.georef_rejected import rejected_path_for, remove_stale_rejected
from kinsync.pipelines.georef_times import OutsideTally, PointTimes
from kinsync.pipelines.schedulers import SerialRunner, in_order, make_runner
from kinsync.pipelines.write_behind import WriteBehind
from kinsync.progress import Progress, report

__all__ = [
    "STAGE_CHECKING_TRAJECTORY",
    "STAGE_READING_POINTS",
    "STAGE_READING_TRAJECTORY",
    "GeorefSummary",
    "OutsidePolicy",
    "PointColumns",
    "georeference_file",
    "rejected_path_for",
]

STAGE_READING_TRAJECTORY = "reading the trajectory"
STAGE_CHECKING_TRAJECTORY = "checking the trajectory (velocities, gaps)"
STAGE_READING_POINTS = "reading the points' layout"
"""Stages reported (at 0 %) before the points are georeferenced: on a long trajectory
they take most of a short run (a 10 h SBET: tens of seconds)."""

_ECEF_CRS = "EPSG:4978"
_LAS_SCALE_M = 1e-4
_LAS_SCALE_DEG = 1e-9
_LAS_OFFSET_ROUND = 1000.0


@dataclass(frozen=True)
class GeorefSummary:
    """Accounting of one georeferencing run over a file.

    Attributes
    ----------
    points_in : int
        Points read.
    points_out : int
        Points georeferenced and written to the output.
    points_rejected : int
        Points outside the trajectory's span written to the rejected file.
    seconds : float
        Wall-clock time of the run (s).
    rejected_path : Path or None
        The rejected-points file, when one was written.
    warnings : tuple of str
        What of the input the output does not carry, one sentence each naming the
        input (LAS waveform data packets, a COPC index), and what the user should know
        of the CRS transformation; empty when nothing is to be said.
    crs : CrsTransformInfo or None
        The transformation to the output CRS: PROJ pipeline, accuracy, epoch, heights.
    gap_threshold_s : float
        Trajectory record intervals longer than this (s) were data gaps (``max_gap_s``).
    """

    points_in: int
    points_out: int
    points_rejected: int
    seconds: float
    rejected_path: Path | None = None
    warnings: tuple[str, ...] = ()
    crs: CrsTransformInfo | None = None
    gap_threshold_s: float = math.inf

    @property
    def points_per_s(self) -> float:
        """Throughput, points read per second."""
        return self.points_in / self.seconds if self.seconds > 0.0 else math.inf

    def as_document(self) -> dict[str, Any]:
        """The ``--json`` summary of ``kinsync georef``."""
        return {
            "points_in": self.points_in,
            "points_out": self.points_out,
            "points_rejected": self.points_rejected,
            "rejected_file": None if self.rejected_path is None else str(self.rejected_path),
            "seconds": self.seconds,
            "points_per_s": self.points_per_s,
            "crs": None if self.crs is None else self.crs.as_document(),
            "gap_threshold_s": self.gap_threshold_s,
            "warnings": list(self.warnings),
        }


# ---------------------------------------------------------------------- file pipeline
def georeference_file(
    points_path: Path,
    trajectory_path: Path,
    mount: Mount,
    out_path: Path,
    *,
    crs: str = _ECEF_CRS,
    geoid: str | None = None,
    epoch_year: float | None = None,
    trajectory_crs: str = ECEF_WGS84,
    chunk_points: int = 1_000_000,
    outside: OutsidePolicy = "error",
    gps_week: int | None = None,
    position: PositionMethod = "auto",
    progress: Progress | None = None,
    scheduler: str = "local",
    workers: int | None = None,
    point_columns: PointColumns = "auto",
    profiler_azimuth_deg: float | None = None,
    columns: ColumnMap | None = None,
    max_gap_s: float | None = None,
    mount_file: Path | None = None,
) -> GeorefSummary:
    """Georeference a point file chunk by chunk into ``out_path`` (streaming, atomic).

    Parameters
    ----------
    points_path : Path
        Scanner-frame points: ``.las``/``.laz`` (x, y, z in the scanner frame, time in
        ``gps_time``), or ``.csv``/``.parquet`` with columns ``t_s,x_m,y_m,z_m``
        (scanner frame) or ``t_s,range_m,angle_rad`` (2D profile scanner: range and
        mirror angle, see `profile_points_to_scanner`), + any others, carried through.
    trajectory_path : Path
        Trajectory CSV or SBET (see `read_trajectory_file`).
    mount : Mount
        Lever arm, boresight and latency (the latency is applied, SPEC section 1), and
        for profile files the ``[profiler] azimuth_deg``.
    out_path : Path
        Output; format from the suffix, any input to any output:

        * ``.las``/``.laz`` from LAS/LAZ: every attribute and VLR kept, X, Y, Z replaced;
        * ``.csv``/``.parquet`` from a table: every input column kept (a Parquet
          column with its type and nulls, written to CSV as its values' text with an
          empty cell for null; a CSV column as its text), the coordinates in ``crs``
          as ``X,Y,Z`` (replacing ``x_m,y_m,z_m`` in place, or appended after the
          columns of a profile file);
        * ``.csv``/``.parquet`` from LAS/LAZ: one column per LAS dimension
          (``gps_time`` as stored, ``intensity``, ``return_number``,
          ``classification``, ..., extra bytes), ``X,Y,Z`` georeferenced floats
          (`kinsync.io.las_table`); CSV floats are written in full (shortest
          round-trip text: they read back exactly);
        * ``.las``/``.laz`` from a table: LAS 1.4 point format 6 (7 with
          ``red,green,blue``, 8 with ``nir``), ``gps_time`` from ``t_s`` (adjusted
          standard GPS time, or seconds of week with an SBET read without
          ``gps_week``), columns named as LAS dimensions (``intensity``, ...) in them,
          other numeric columns as extra dimensions, text columns not carried (a
          warning names them); X, Y, Z in steps of 1e-4 of their unit (0.1 mm; 1e-9 deg,
          0.11 mm, for longitude and latitude) with offsets from the trajectory at the
          middle of the file's time span;
        * ``.ply``: binary little-endian, ``x y z`` as double, every numeric attribute
          (LAS dimensions, or a table's numeric columns) as a property
          (`kinsync.io.ply`), text columns not carried.
    crs : str
        Output CRS (pyproj user input), default ECEF ``EPSG:4978``; a compound CRS
        (``EPSG:32618+5703``) gives orthometric heights (see `plan_ecef_to_crs`).
    geoid : str, optional
        Geoid grid (GTX, GeoTIFF) for a compound ``crs``: heights ``H = h - N``.
    epoch_year : float, optional
        Coordinate epoch (decimal year) of a time-dependent transformation; default the
        trajectory's date when its times are absolute GPS time.
    trajectory_crs : str
        Geocentric CRS of the trajectory's positions (default WGS 84, EPSG:4978).
    chunk_points : int
        Points per chunk (bounds memory): exact for LAS/LAZ and CSV (the last chunk
        fewer), at most this many for Parquet (chunks follow its row groups).
    outside : {"error", "reject"}
        Points outside the trajectory span: an error naming how many and their time
        range (nothing written), or written unchanged to ``OUT.rejected.<ext>``
        (`rejected_path_for`: the output's format for an input of its kind, else the
        input's; a CSV input's rows to a CSV rejected file as the input's own lines,
        byte for byte, under its header line; to a Parquet one as the table's
        columns), renamed into place with the output once both are complete. A run
        removes every ``OUT.rejected.<ext>`` an earlier run left there, whatever its
        input's format, but its own (a warning names each), so that the files beside
        the output always hold exactly this run's points.
    gps_week : int, optional
        GPS week for SBET and LAS seconds-of-week times (see `read_trajectory_file`).
    position : {"auto", "linear", "hermite"}
        Position interpolation (see `georeference`).
    progress : Progress, optional
        Told each stage before the points: `STAGE_READING_TRAJECTORY`,
        `STAGE_CHECKING_TRAJECTORY`, `STAGE_READING_POINTS` (at 0), then the share of
        the points done (stage "georeferencing") once the inputs are checked and after
        each chunk written.
    scheduler : str
        Where chunks are read and georeferenced: ``"local"`` (in this process,
        serial), ``"processes"`` (a local process pool) or ``"tcp://HOST:PORT"`` (an
        existing dask.distributed scheduler, extra ``kinsync[scale]``; its workers must
        be able to read ``points_path``). Each worker reads its own chunks (LAS/LAZ by
        seek, CSV by byte range, Parquet by row group) and sends back what to write;
        this process only writes, in input order, so the output is identical to the
        serial run. The trajectory is shipped once per worker.
    workers : int, optional
        Processes of the pool (default: the CPU count); for a Dask scheduler, the
        workers to keep busy (default: those connected). At most two chunks per worker
        are in flight.
    point_columns : {"auto", "xyz", "profile"}
        Which columns of a table give the points: ``x_m,y_m,z_m`` or
        ``range_m,angle_rad``; "auto" takes the set the file has (both is an error:
        choose one).
    profiler_azimuth_deg : float, optional
        Azimuth (deg) of the profile plane in the scanner frame, replacing the
        mount's ``[profiler] azimuth_deg`` (profile files only).
    columns : ColumnMap, optional
        Which columns of a table hold ``t_s``, ``x_m``, ... (`kinsync.io.column_map`);
        carried columns keep the file's names. Tables only.
    max_gap_s : float, optional
        Longest record interval (s) of the trajectory to interpolate across; default
        `kinsync.trajectory_gaps.GAP_FACTOR` (10) times its median record interval. Points
        strictly inside a longer interval (a data gap) are treated as outside the span
        (an error, or rejected with ``outside="reject"``, with a warning naming the gaps).
    mount_file : Path, optional
        The file ``mount`` was read from: the output's kinsync record names it, with its
        SHA-256 and header comments (`kinsync.pipelines.georef_record`).

    Returns
    -------
    GeorefSummary

    Raises
    ------
    InputError
        Unknown suffixes, missing or ambiguous columns, a column map that does not fit
        the file, a profile file without an azimuth, NaN points, mixed time scales,
        values that do not fit a LAS dimension, points outside the span (with
        ``outside="error"``).
    """
    start = time.perf_counter()
    points_path, out_path = Path(points_path), Path(out_path)
    _check_arguments(points_path, out_path, outside, chunk_points, point_columns, columns)
    report(progress, 0.0, STAGE_READING_TRAJECTORY)
    trajectory, traj_scale = read_trajectory_file(trajectory_path, gps_week=gps_week)
    report(progress, 0.0, STAGE_CHECKING_TRAJECTORY)
    traj = GeorefRecords.from_trajectory(trajectory, latency_s=mount.latency_s, max_gap_s=max_gap_s)
    del trajectory
    use_hermite(traj, position)
    check_latency(traj, mount)
    crs_plan, crs_info = _plan_crs(traj, traj_scale, crs, geoid, epoch_year, trajectory_crs)
    report(progress, 0.0, STAGE_READING_POINTS)
    las_input = _kind(points_path) == "las"
    out_kind = _kind(out_path)
    output: OutputKind = "same" if out_kind == _kind(points_path) else cast(OutputKind, out_kind)
    template: Any = None
    las_time_type: Literal["week", "adjusted_standard"] | None = None
    notes: list[str] = []
    if las_input:
        if point_columns == "profile" or profiler_azimuth_deg is not None:
            msg = (
                f"{points_path}: LAS/LAZ points are x, y, z in the scanner frame; "
                "--point-columns profile and --profiler-azimuth-deg apply to CSV/Parquet "
                "tables with range_m,angle_rad"
            )
            raise InputError(msg)
        template, source, tasks, total = _plan_las(points_path, chunk_points, traj_scale, gps_week)
        las_time_type = las_info(points_path).gps_time_type
        notes += _las_notes(points_path, template, output)
    else:
        source, tasks, total, mount = _plan_table(
            points_path, chunk_points, mount, point_columns, profiler_azimuth_deg, columns, output
        )
    csv_input = not las_input and points_path.suffix.lower() == ".csv"
    ctx = ChunkContext(
        source,
        traj,
        mount,
        position,
        crs_plan,
        outside,
        out_path.suffix.lower() == ".csv",
        output=output,
        rejected_lines=csv_input
        and rejected_path_for(out_path, points_path).suffix.lower() == ".csv",
    )
    if out_kind == "las":
        ctx = replace(ctx, las_frame=_las_output_frame(ctx, tasks, total))
    record = georef_document(  # the kinsync record the output keeps (None for a CSV)
        ctx,
        crs_info,
        Path(trajectory_path),
        mount_file,
        RecordedTimes(traj_scale, gps_week, las_time_type),
    )
    sink, more_notes, ctx = _sink(ctx, template, traj_scale, total, out_path, record)
    notes += [f"{points_path}: {note}" for note in more_notes]
    notes += sink.notes if isinstance(sink, LasSink) else ()  # WKT2 CRS, record shortened
    tally = OutsideTally(
        PointTimes(traj_scale, gps_week, las_time_type, ctx.source.las_time_offset_s)
    )
    with ExitStack() as stack:
        runner = make_runner(ctx, scheduler, workers)
        stack.callback(runner.close)
        counts = _write(ctx, tasks, total, out_path, progress, tally, runner, sink, template)
    points_in, points_out, points_rejected = counts
    rejected_path = rejected_path_for(out_path, points_path) if points_rejected else None
    notes += remove_stale_rejected(out_path, points_path, Path(trajectory_path), rejected_path)
    if points_rejected and template is not None and output != "same":
        notes += _rejected_las_notes(points_path, template)
    if tally.count:
        notes.append(tally.warning(points_path, traj, rejected_path_for(out_path, points_path)))
    if crs_info.time_dependent and crs_info.epoch_year is not None:
        notes.append(
            f"{out_path}: its coordinates are at coordinate epoch {crs_info.epoch_year:.4f} "
            "(a time-dependent transformation), which the file does not record (its CRS "
            "names only the datum): keep the epoch with the file"
        )
    return GeorefSummary(
        points_in=points_in,
        points_out=points_out,
        points_rejected=points_rejected,
        seconds=time.perf_counter() - start,
        rejected_path=rejected_path,
        warnings=tuple(notes) + crs_info.warnings,
        crs=crs_info,
        gap_threshold_s=traj.max_gap_s,
    )


def _plan_crs(
    traj: GeorefRecords,
    traj_scale: TimeScale,
    crs: str,
    geoid: str | None,
    epoch_year: float | None,
    trajectory_crs: str,
) -> tuple[CrsPlan, CrsTransformInfo]:
    """The output CRS transformation for the trajectory's area and date (before output)."""
    rows = list(sample_rows(len(traj.t_s)))
    t_mid_s = 0.5 * (traj.t_start_s + traj.t_end_s)
    dated = traj_scale == "gps" and t_mid_s >= PLAUSIBLE_DATE_GPS_S
    observed = gps_to_decimal_year(t_mid_s) if dated else None
    return plan_ecef_to_crs(
        crs,
        geoid=geoid,
        epoch_year=epoch_year,
        source_crs=trajectory_crs,
        sample_ecef_m=traj.pos_ecef_m_at(rows),
        observation_epoch_year=observed,
    )


def _check_arguments(
    points_path: Path,
    out_path: Path,
    outside: str,
    chunk_points: int,
    point_columns: str,
    columns: ColumnMap | None,
) -> None:
    """Refuse bad options and file types before any file is read."""
    if outside not in ("error", "reject"):
        msg = f"--outside must be error or reject, got {outside!r}"
        raise InputError(msg)
    if chunk_points < 1:
        msg = f"--chunk-points must be >= 1, got {chunk_points}"
        raise InputError(msg)
    if point_columns not in ("auto", "xyz", "profile"):
        msg = f"--point-columns must be auto, xyz or profile, got {point_columns!r}"
        raise InputError(msg)
    in_suffix, out_suffix = points_path.suffix.lower(), out_path.suffix.lower()
    if in_suffix not in _LAS_SUFFIXES + _TABLE_SUFFIXES:
        msg = (
            f"{points_path}: unknown point file type {points_path.suffix!r}; "
            "use .las, .laz, .csv or .parquet"
        )
        raise InputError(msg)
    if out_suffix not in _LAS_SUFFIXES + _TABLE_SUFFIXES + (".ply",):
        msg = (
            f"{out_path}: unknown output type {out_path.suffix!r}; use .las, .laz, .csv, "
            ".parquet or .ply"
        )
        raise InputError(msg)
    require_file(points_path, "point file")
    las_input = in_suffix in _LAS_SUFFIXES
    if las_input and columns is not None and columns.pairs:
        msg = (
            f"{columns.flag}: {points_path} is LAS/LAZ, whose points are always x, y, z and "
            f"gps_time; {columns.flag} maps the columns of CSV/Parquet tables"
        )
        raise InputError(msg)


def _las_notes(points_path: Path, template: Any, output: OutputKind) -> list[str]:
    """What of a LAS/LAZ input the output does not carry, one sentence each."""
    notes = las_output_notes(template)
    if output == "same":
        return [f"{points_path}: {note}" for note in notes]
    if any(note.startswith("waveform") for note in notes):
        return [
            (
                f"{points_path}: its waveform data packets are not carried: the output has "
                "the points' wave packet fields, not the waveforms"
            )
        ]
    return []


def _rejected_las_notes(points_path: Path, template: Any) -> list[str]:
    """What the LAS/LAZ file of rejected points changes (a LAS 1.0 written as 1.2)."""
    return [
        f"{points_path}: {note}"
        for note in las_output_notes(template)
        if note.startswith("it is LAS")
    ]


def _sink(
    ctx: ChunkContext,
    template: Any,
    traj_scale: TimeScale,
    total: int,
    out_path: Path,
    record: dict[str, Any] | None,
) -> tuple[Sink, list[str], ChunkContext]:
    """The output's sink, what it does not carry, and the context its chunks need.

    The sink keeps ``record``, the kinsync record, where its format can (not a CSV).
    """
    kind = _kind(out_path)
    crs_text = ctx.crs.crs
    layout = ctx.source.table
    target_crs = pyproj.CRS.from_user_input(crs_text)
    if kind == "las":
        frame = ctx.las_frame
        assert frame is not None
        if layout is None:
            return LasSink(out_path, template, target_crs, frame, record), [], ctx
        carried = _carried_columns(ctx)
        time_scale: Literal["gps", "week"] = "week" if traj_scale == "week" else "gps"
        try:
            plan = plan_table_las(carried, time_scale)
        except InputError as err:
            msg = f"{layout.path}: {err}"
            raise InputError(msg) from err
        notes = _dropped_note(plan.dropped, "LAS")
        header = plan.header()
        sink = LasSink(out_path, header, target_crs, frame, record)
        return sink, notes, replace(ctx, table_las=plan)
    if kind == "ply":
        units = ", ".join(output_units(target_crs))
        comments = [ply_crs_comment(crs_text, target_crs, units)]
        if layout is None:
            types = las_column_types(template.point_format)
            props = [
                (PLY_XYZ[OUT_COLUMNS.index(k)] if k in OUT_COLUMNS else k, t)
                for k, t in types.items()
            ]
            return PlySink(out_path, props, total, comments, record), [], ctx
        carried = _carried_columns(ctx, keep_time=True)
        numeric = {n: t for n, t in carried.items() if _numeric(t)}
        clash = [n for n in numeric if n in PLY_XYZ]
        if clash:
            msg = (
                f"{layout.path}: column(s) {clash} would clash with the PLY coordinates "
                "x, y, z; rename them"
            )
            raise InputError(msg)
        props = [(axis, np.dtype(np.float64)) for axis in PLY_XYZ]
        props += [(n, _numpy_dtype(t)) for n, t in numeric.items()]
        notes = _dropped_note(tuple(n for n in carried if n not in numeric), "PLY")
        ply = PlySink(out_path, props, total, comments, record)
        return ply, notes, replace(ctx, ply_columns=tuple(numeric))
    if layout is None:
        types = las_column_types(template.point_format)

        def empty_from_las() -> dict[str, Any]:
            return {
                n: pa.array(
                    [],
                    type=pa.string() if ctx.csv_text and t.kind == "f" else pa.from_numpy_dtype(t),
                )
                for n, t in types.items()
            }

        return TableSink(out_path, empty_from_las, target_crs, record), [], ctx
    return TableSink(out_path, lambda: empty_table_output(ctx), target_crs, record), [], ctx


def _carried_columns(ctx: ChunkContext, *, keep_time: bool = False) -> dict[str, Any]:
    """A table's columns that a LAS/PLY output carries (file names), with their types.

    The scanner coordinates ``x_m,y_m,z_m`` are not carried (they become the points'
    coordinates), nor is ``t_s`` unless ``keep_time`` (LAS stores it as ``gps_time``);
    the columns of a profile file are.
    """
    layout = ctx.source.table
    assert layout is not None
    used = set(XYZ_COLUMNS) if ctx.source.points == "xyz" else set()
    if not keep_time:
        used.add("t_s")
    return {f.name: f.type for f in layout.inferred if layout.kinsync_name(f.name) not in used}


def _numeric(kind: Any) -> bool:
    """Numbers, booleans, or no type at all (a CSV without rows: nothing to lose)."""
    return bool(
        pa.types.is_integer(kind)
        or pa.types.is_floating(kind)
        or pa.types.is_boolean(kind)
        or pa.types.is_null(kind)
    )


def _numpy_dtype(kind: Any) -> np.dtype[Any]:
    if pa.types.is_null(kind):
        return np.dtype(np.float64)
    return np.dtype(np.uint8) if pa.types.is_boolean(kind) else arrow_numpy_dtype(kind)


def _dropped_note(dropped: Sequence[str], what: str) -> list[str]:
    if not dropped:
        return []
    return [
        (
            f"column(s) {list(dropped)} hold text, which {what} cannot store: not carried "
            "(a CSV/Parquet output keeps every column)"
        )
    ]


def _plan_las(
    path: Path, chunk_points: int, traj_scale: TimeScale, gps_week: int | None
) -> tuple[Any, ChunkSource, list[ChunkTask], int]:
    info = las_info(path)
    template = las_header(path)
    ends = las_end_times(path) if info.point_count else None  # read once, kept in source
    if ends is not None:  # seconds of week or GPS time as the header says (not Unix time)
        check_week_seconds(info, ends)
        if ends is not None:
            check_week_rollover(info, min(ends), max(ends), gps_week)
    offset = las_time_offset_s(info, traj_scale, gps_week, needed_by="georeferencing")
    n = info.point_count
    tasks = [ChunkTask(first, min(chunk_points, n - first)) for first in range(0, n, chunk_points)]
    crs = georeferenced_crs_name(info.crs_wkt)
    source = ChunkSource(path, "xyz", None, offset, n, crs, las_end_times_s=ends)
    return template, source, tasks, n


def _file_end_times(ctx: ChunkContext, tasks: Sequence[ChunkTask], total: int) -> list[float]:
    """Times of the input's first and last point, on the trajectory's scale.

    LAS/LAZ: two points; a table: the time column of its first and last chunk only.
    """
    source = ctx.source
    if total == 0 or not tasks:
        return []
    if source.table is None:
        ends = source.las_end_times_s or las_end_times(source.path)
        return [t + source.las_time_offset_s for t in (ends or ())]
    layout = source.table
    first, last = tasks[0].table_slice, tasks[-1].table_slice
    assert first is not None
    assert last is not None
    t_first = read_table_slice(layout, first, only=("t_s",))["t_s"]
    t_last = t_first if last is first else read_table_slice(layout, last, only=("t_s",))["t_s"]
    return [float(t_first[0]), float(t_last[-1])] if len(t_first) and len(t_last) else []


def _las_output_frame(ctx: ChunkContext, tasks: Sequence[ChunkTask], total: int) -> LasOutputFrame:
    """Offsets and scales for a LAS output: the trajectory at the middle of the file's span.

    The span runs from the first point's time to the last one's (clipped to the
    trajectory; its middle when neither is usable); the offsets are the trajectory's
    position there in ``crs``, rounded (1 km, or 1 degree for longitude and latitude),
    so that a time-ordered file reaches ``2**31`` scale steps (about 214 km at 0.1 mm,
    65 km at 1e-4 ft, 2.1 deg at 1e-9 deg) either way from its middle. Scales: 1e-4 of
    each axis' unit (0.1 mm; 1e-9 deg, 0.11 mm, for longitude and latitude: 1e-7 deg
    stored them in 11 mm steps). A longitude is stored within 180 deg of its offset:
    across the antimeridian the values run on past 180 (or -180) rather than jump.
    """
    crs, traj = ctx.crs, ctx.traj
    geographic = pyproj.CRS.from_user_input(crs.crs).is_geographic
    scales = (_LAS_SCALE_DEG, _LAS_SCALE_DEG, _LAS_SCALE_M) if geographic else (_LAS_SCALE_M,) * 3
    times = [
        min(max(t, traj.t_start_s), traj.t_end_s)
        for t in _file_end_times(ctx, tasks, total)
        if math.isfinite(t)
    ]
    t_mid = 0.5 * (min(times) + max(times)) if times else 0.5 * (traj.t_start_s + traj.t_end_s)
    pos = traj.position_ecef_m_at(t_mid)[None, :]
    to_crs = crs_plan_transformer(crs)
    centre = (pos if to_crs is None else to_crs(pos))[0]
    if geographic:
        rounded = [round(centre[0]), round(centre[1]), round(centre[2] / _LAS_OFFSET_ROUND)]
        offsets = (float(rounded[0]), float(rounded[1]), rounded[2] * _LAS_OFFSET_ROUND)
    else:
        r = np.round(centre / _LAS_OFFSET_ROUND) * _LAS_OFFSET_ROUND
        offsets = (float(r[0]), float(r[1]), float(r[2]))
    longitude_x = geographic and output_units(pyproj.CRS.from_user_input(crs.crs))[0] == "degree"
    return LasOutputFrame(offsets=offsets, scales=scales, longitude_x=longitude_x)


def _table_point_set(
    path: Path, names: Sequence[str], point_columns: PointColumns
) -> Literal["xyz", "profile"]:
    has_xyz = all(c in names for c in XYZ_COLUMNS)
    has_profile = all(c in names for c in PROFILE_COLUMNS)
    xyz_text, profile_text = ",".join(XYZ_COLUMNS), ",".join(PROFILE_COLUMNS)
    if point_columns == "auto":
        if has_xyz and has_profile:
            msg = (
                f"{path}: has both {xyz_text} and {profile_text}; choose which give the "
                "points with --point-columns xyz or --point-columns profile"
            )
            raise InputError(msg)
        if not (has_xyz or has_profile):
            msg = (
                f"{path}: the points need columns t_s with {xyz_text} (scanner frame) or "
                f"t_s with {profile_text} (2D profile); the file has columns {list(names)}"
            )
            raise InputError(msg)
        return "profile" if has_profile else "xyz"
    return point_columns


def _plan_table(
    path: Path,
    chunk_points: int,
    mount: Mount,
    point_columns: PointColumns,
    profiler_azimuth_deg: float | None,
    columns: ColumnMap | None,
    output: OutputKind,
) -> tuple[ChunkSource, list[ChunkTask], int, Mount]:
    file_names = table_columns(path)
    if columns is not None:
        columns.check_file(path, file_names)
    names = file_names if columns is None else columns.kinsync_names(file_names)
    points = _table_point_set(path, names, point_columns)
    replaced = set(XYZ_COLUMNS) if points == "xyz" else set()
    carried = [f for f, k in zip(file_names, names, strict=True) if k not in replaced]
    clash = [c for c in OUT_COLUMNS if c in carried] if output == "same" else []
    if clash:
        msg = (
            f"{path}: column(s) {clash} would clash with the output coordinates "
            f"{','.join(OUT_COLUMNS)}; rename them"
        )
        raise InputError(msg)
    if points == "profile":
        azimuth = (
            profiler_azimuth_deg if profiler_azimuth_deg is not None else mount.profiler_azimuth_deg
        )
        if azimuth is None:
            msg = (
                f"{path}: a profile file (range_m, angle_rad) needs the profiler azimuth: "
                "add [profiler] azimuth_deg to the mount file or pass --profiler-azimuth-deg"
            )
            raise InputError(msg)
        try:
            mount = mount.with_profiler_azimuth(azimuth)  # warns nothing again
        except InputError as err:
            msg = f"--profiler-azimuth-deg: {err}"
            raise InputError(msg) from err
    elif profiler_azimuth_deg is not None:
        msg = (
            f"{path}: --profiler-azimuth-deg applies to profile files (range_m, angle_rad); "
            f"this file gives the points as {','.join(XYZ_COLUMNS)}"
        )
        raise InputError(msg)
    required = ("t_s", *(XYZ_COLUMNS if points == "xyz" else PROFILE_COLUMNS))
    layout, slices = plan_table_slices(path, chunk_points, required, columns)
    tasks = [ChunkTask(s.first_row, s.n_rows, s) for s in slices]
    return ChunkSource(path, points, layout), tasks, layout.total_rows, mount


def _outputs_in_order(
    ctx: ChunkContext,
    tasks: Sequence[ChunkTask],
    runner: SerialRunner,
    tally: OutsideTally,
    out_path: Path,
    progress: Progress | None,
    total: int,
) -> Iterator[ChunkOutput]:
    """The chunks to write, in input order; errors raised, outside points accounted.

    With ``outside == "error"`` the first chunk with points outside the span stops the
    writing; the remaining chunks are only read to count such points for the error.
    """
    failing = False
    n_in = 0

    def tally_only() -> bool:
        return failing

    report(progress, 0.0, "georeferencing")
    for result in in_order(tasks, runner, tally_only):
        out = result()
        n_in += out.count
        if not failing and out.error is not None:
            raise InputError(out.error)
        tally.add(out)
        if failing:
            continue
        if out.outside_count and ctx.outside == "error":
            failing = True
            continue
        yield out
        report(progress, n_in / total if total else 1.0, "georeferencing")
    if tally.none_within(n_in):  # before the outputs are complete: none is published
        raise tally.span_error(ctx.source.path, ctx.traj)
    if failing:
        raise tally.error(ctx.source.path, ctx.traj, rejected_path_for(out_path, ctx.source.path))


def _rejected_sink(ctx: ChunkContext, template: Any, out_path: Path) -> Sink:
    """The sink of the points outside the span, unchanged (`rejected_path_for`)."""
    path = rejected_path_for(out_path, ctx.source.path)
    if template is not None:
        return LasRejectedSink(path, template)
    if ctx.rejected_lines:
        return CsvLinesRejectedSink(path, csv_header_line(ctx.source.path))
    return TableRejectedSink(path)


def _write(
    ctx: ChunkContext,
    tasks: Sequence[ChunkTask],
    total: int,
    out_path: Path,
    progress: Progress | None,
    tally: OutsideTally,
    runner: SerialRunner,
    sink: Sink,
    template: Any,
) -> tuple[int, int, int]:
    """Write every chunk's points to ``sink`` and its rejects to the rejected file.

    Both files are renamed into place only once both are complete (a LAZ file's last
    chunk is written as it closes): a run that fails leaves the earlier ones as they were.
    """
    n_in = n_out = 0
    behind = WriteBehind()
    with published_together(), ExitStack() as stack:
        stack.enter_context(sink)
        stack.callback(behind.close)  # before the sink closes
        rejected: Sink | None = None
        for out in _outputs_in_order(ctx, tasks, runner, tally, out_path, progress, total):
            if (
                out.rejected_records is not None
                or out.rejected_columns is not None
                or out.rejected_lines is not None
            ):
                if rejected is None:
                    behind.wait()
                    rejected = stack.enter_context(_rejected_sink(ctx, template, out_path))
                    stack.callback(behind.close)
                behind.submit(rejected.write, out)
            behind.submit(sink.write, out)
            n_in += out.count
            n_out += out.count - out.outside_count
        behind.wait()
        if not tasks:  # no points: the output still gets its header or columns
            sink.finish_empty()
    return n_in, n_out, tally.count
