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
from collections.abc import Callable, Iterator, Sequence
from contextlib import ExitStack
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Literal

import laspy
import numpy as np
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
from kinsync.errors import InputError
from kinsync.georef.kernel import PositionMethod, check_latency, use_hermite
from kinsync.georef.profile import PROFILE_COLUMNS
from kinsync.georef.trajectory import GeorefTrajectory
from kinsync.io.las import (
    las_end_times,
    las_header,
    las_info,
    las_time_offset_s,
)
from kinsync.io.las_writer import LasChunkWriter, las_output_notes
from kinsync.io.points import (
    TableChunkWriter,
    plan_table_slices,
    table_columns,
)
from kinsync.io.trajectory import TimeScale, read_trajectory_file
from kinsync.mount import Mount
from kinsync.pipelines.georef_chunks import (
    OUT_COLUMNS,
    XYZ_COLUMNS,
    ChunkContext,
    ChunkOutput,
    ChunkSource,
    ChunkTask,
    LasOutputFrame,
    OutsidePolicy,
    PointColumns,
    empty_table_output,
)
from kinsync.pipelines.schedulers import SerialRunner, in_order, make_runner
from kinsync.pipelines.write_behind import WriteBehind

__all__ = [
    "GeorefSummary",
    "OutsidePolicy",
    "PointColumns",
    "georeference_file",
    "rejected_path_for",
]

_LAS_SUFFIXES = (".las", ".laz")
_TABLE_SUFFIXES = (".csv", ".parquet")
_ECEF_CRS = "EPSG:4978"
_LAS_SCALE_M = 1e-4
_LAS_SCALE_DEG = 1e-7
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
    """

    points_in: int
    points_out: int
    points_rejected: int
    seconds: float
    rejected_path: Path | None = None
    warnings: tuple[str, ...] = ()
    crs: CrsTransformInfo | None = None

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
            "seconds": self.seconds,
            "points_per_s": self.points_per_s,
            "crs": None if self.crs is None else self.crs.as_document(),
            "warnings": list(self.warnings),
        }


def rejected_path_for(out_path: Path) -> Path:
    """``OUT.rejected.<ext>``: where points outside the trajectory span go."""
    out_path = Path(out_path)
    return out_path.with_name(f"{out_path.stem}.rejected{out_path.suffix}")


class _OutsideTally:
    """Counts and time range of points outside the span."""

    def __init__(self) -> None:
        self.count = 0
        self.t_min_s = math.inf
        self.t_max_s = -math.inf

    def add(self, count: int, t_min_s: float, t_max_s: float) -> None:
        if count:
            self.count += count
            self.t_min_s = min(self.t_min_s, t_min_s)
            self.t_max_s = max(self.t_max_s, t_max_s)

    def error(self, points_path: Path, traj: GeorefTrajectory, out_path: Path) -> InputError:
        msg = (
            f"{points_path}: {self.count} point(s) with times {self.t_min_s!r} .. "
            f"{self.t_max_s!r} s lie outside the trajectory span [{traj.t_start_s!r}, "
            f"{traj.t_end_s!r}] s (latency {traj.latency_s!r} s applied); kinsync does not "
            "extrapolate: give a trajectory that covers them, check the time scales "
            f"(--gps-week), or pass --outside reject to write them to "
            f"{rejected_path_for(out_path)}"
        )
        return InputError(msg)


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
    progress: Callable[[int, int | None], None] | None = None,
    scheduler: str = "local",
    workers: int | None = None,
    point_columns: PointColumns = "auto",
    profiler_azimuth_deg: float | None = None,
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
        Output; format from the suffix. LAS/LAZ input goes to ``.las``/``.laz`` with
        every attribute and VLR kept; table input to ``.csv``/``.parquet`` with every
        input column kept and the coordinates in ``crs`` as ``X,Y,Z`` (replacing
        ``x_m,y_m,z_m`` in place, or appended after the columns of a profile file).
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
        range (nothing written), or written unchanged to ``OUT.rejected.<ext>``.
    gps_week : int, optional
        GPS week for SBET and LAS seconds-of-week times (see `read_trajectory_file`).
    position : {"auto", "linear", "hermite"}
        Position interpolation (see `georeference`).
    progress : callable, optional
        Called after each chunk with (points done, total points or None).
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

    Returns
    -------
    GeorefSummary

    Raises
    ------
    InputError
        Unknown suffixes or unsupported input/output pair, missing or ambiguous
        columns, a profile file without an azimuth, NaN points, mixed time scales,
        points outside the span (with ``outside="error"``).
    """
    start = time.perf_counter()
    points_path, out_path = Path(points_path), Path(out_path)
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
    if out_suffix not in _LAS_SUFFIXES + _TABLE_SUFFIXES:
        msg = (
            f"{out_path}: unknown output type {out_path.suffix!r}; use .las, .laz, .csv or .parquet"
        )
        raise InputError(msg)
    if (in_suffix in _LAS_SUFFIXES) != (out_suffix in _LAS_SUFFIXES):
        msg = (
            f"{out_path}: {in_suffix} input can be written to "
            f"{'.las/.laz' if in_suffix in _LAS_SUFFIXES else '.csv/.parquet'} only "
            "(conversion between LAS and tables is not supported yet)"
        )
        raise InputError(msg)
    if not points_path.is_file():
        msg = f"{points_path}: file not found"
        raise InputError(msg)
    trajectory, traj_scale = read_trajectory_file(trajectory_path, gps_week=gps_week)
    traj = GeorefTrajectory.from_trajectory(trajectory, latency_s=mount.latency_s)
    use_hermite(traj, position)
    check_latency(traj, mount)
    crs_plan, crs_info = _plan_crs(traj, traj_scale, crs, geoid, epoch_year, trajectory_crs)
    template: Any = None
    las_frame: LasOutputFrame | None = None
    if in_suffix in _LAS_SUFFIXES:
        if point_columns == "profile" or profiler_azimuth_deg is not None:
            msg = (
                f"{points_path}: LAS/LAZ points are x, y, z in the scanner frame; "
                "--point-columns profile and --profiler-azimuth-deg apply to CSV/Parquet "
                "tables with range_m,angle_rad"
            )
            raise InputError(msg)
        template, source, tasks, total = _plan_las(points_path, chunk_points, traj_scale, gps_week)
        las_frame = _las_output_frame(source, total, traj, crs_plan)
    else:
        source, tasks, total, mount = _plan_table(
            points_path, chunk_points, mount, point_columns, profiler_azimuth_deg
        )
    ctx = ChunkContext(
        source, traj, mount, position, crs_plan, outside, out_suffix == ".csv", las_frame
    )
    tally = _OutsideTally()
    with ExitStack() as stack:
        runner = make_runner(ctx, scheduler, workers)
        stack.callback(runner.close)
        if template is not None:
            counts = _write_las(ctx, template, tasks, total, out_path, progress, tally, runner)
        else:
            counts = _write_table(ctx, tasks, total, out_path, progress, tally, runner)
    points_in, points_out, points_rejected = counts
    return GeorefSummary(
        points_in=points_in,
        points_out=points_out,
        points_rejected=points_rejected,
        seconds=time.perf_counter() - start,
        rejected_path=rejected_path_for(out_path) if points_rejected else None,
        warnings=_las_warnings(points_path, template) + crs_info.warnings,
        crs=crs_info,
    )


def _plan_crs(
    traj: GeorefTrajectory,
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
        sample_ecef_m=traj.pos_ecef_m[rows],
        observation_epoch_year=observed,
    )


def _las_warnings(points_path: Path, template: Any) -> tuple[str, ...]:
    """What of a LAS/LAZ input the output does not carry (none for tables)."""
    if template is None:
        return ()
    return tuple(f"{points_path}: {note}" for note in las_output_notes(template))


def _plan_las(
    path: Path, chunk_points: int, traj_scale: TimeScale, gps_week: int | None
) -> tuple[Any, ChunkSource, list[ChunkTask], int]:
    info = las_info(path)
    template = las_header(path)
    offset = las_time_offset_s(info, traj_scale, gps_week, needed_by="georeferencing")
    n = info.point_count
    tasks = [ChunkTask(first, min(chunk_points, n - first)) for first in range(0, n, chunk_points)]
    return template, ChunkSource(path, "xyz", None, offset), tasks, n


def _las_output_frame(
    source: ChunkSource, n_points: int, traj: GeorefTrajectory, crs: CrsPlan
) -> LasOutputFrame:
    """Offsets and scales for a LAS output: the trajectory at the middle of the file's span.

    The span runs from the first point's time to the last one's (clipped to the
    trajectory; its middle when neither is usable); the offsets are the trajectory's
    position there in ``crs``, rounded (1 km, or 1 degree for longitude and latitude),
    so that a time-ordered file reaches ``2**31`` scale steps (about 214 km at 0.1 mm)
    either way from its middle.
    """
    geographic = pyproj.CRS.from_user_input(crs.crs).is_geographic
    scales = (_LAS_SCALE_DEG, _LAS_SCALE_DEG, _LAS_SCALE_M) if geographic else (_LAS_SCALE_M,) * 3
    ends = las_end_times(source.path) if n_points else None
    times = [
        min(max(t + source.las_time_offset_s, traj.t_start_s), traj.t_end_s)
        for t in (ends or ())
        if math.isfinite(t)
    ]
    t_mid = 0.5 * (min(times) + max(times)) if times else 0.5 * (traj.t_start_s + traj.t_end_s)
    pos = np.array([[np.interp(t_mid, traj.t_s, traj.pos_ecef_m[:, j]) for j in range(3)]])
    to_crs = crs_plan_transformer(crs)
    centre = (pos if to_crs is None else to_crs(pos))[0]
    if geographic:
        rounded = [round(centre[0]), round(centre[1]), round(centre[2] / _LAS_OFFSET_ROUND)]
        offsets = (float(rounded[0]), float(rounded[1]), rounded[2] * _LAS_OFFSET_ROUND)
    else:
        r = np.round(centre / _LAS_OFFSET_ROUND) * _LAS_OFFSET_ROUND
        offsets = (float(r[0]), float(r[1]), float(r[2]))
    return LasOutputFrame(offsets=offsets, scales=scales)


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
) -> tuple[ChunkSource, list[ChunkTask], int, Mount]:
    names = table_columns(path)
    points = _table_point_set(path, names, point_columns)
    clash = [c for c in OUT_COLUMNS if c in names]
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
            mount = replace(mount, profiler_azimuth_deg=azimuth)
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
    layout, slices = plan_table_slices(path, chunk_points, required)
    tasks = [ChunkTask(s.first_row, s.n_rows, s) for s in slices]
    return ChunkSource(path, points, layout), tasks, layout.total_rows, mount


def _outputs_in_order(
    ctx: ChunkContext,
    tasks: Sequence[ChunkTask],
    runner: SerialRunner,
    tally: _OutsideTally,
    out_path: Path,
    progress: Callable[[int, int | None], None] | None,
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

    for result in in_order(tasks, runner, tally_only):
        out = result()
        n_in += out.count
        if not failing and out.error is not None:
            raise InputError(out.error)
        tally.add(out.outside_count, out.outside_t_min_s, out.outside_t_max_s)
        if failing:
            continue
        if out.outside_count and ctx.outside == "error":
            failing = True
            continue
        yield out
        if progress is not None:
            progress(n_in, total)
    if failing:
        raise tally.error(ctx.source.path, ctx.traj, out_path)


def _write_table(
    ctx: ChunkContext,
    tasks: Sequence[ChunkTask],
    total: int,
    out_path: Path,
    progress: Callable[[int, int | None], None] | None,
    tally: _OutsideTally,
    runner: SerialRunner,
) -> tuple[int, int, int]:
    n_in = n_out = 0
    behind = WriteBehind()
    with ExitStack() as stack:
        writer = stack.enter_context(TableChunkWriter(out_path))
        stack.callback(behind.close)  # before the writer closes
        rejected: TableChunkWriter | None = None
        for out in _outputs_in_order(ctx, tasks, runner, tally, out_path, progress, total):
            if out.rejected_columns is not None:
                if rejected is None:
                    behind.wait()
                    rejected = stack.enter_context(TableChunkWriter(rejected_path_for(out_path)))
                    stack.callback(behind.close)
                behind.submit(rejected.write, out.rejected_columns)
            assert out.columns is not None
            behind.submit(writer.write, out.columns)
            n_in += out.count
            n_out += out.count - out.outside_count
        behind.wait()
        if not tasks:  # a table without points: the output still gets its columns
            writer.write(empty_table_output(ctx))
    return n_in, n_out, tally.count


def _write_las(
    ctx: ChunkContext,
    template: Any,
    tasks: Sequence[ChunkTask],
    total: int,
    out_path: Path,
    progress: Callable[[int, int | None], None] | None,
    tally: _OutsideTally,
    runner: SerialRunner,
) -> tuple[int, int, int]:
    frame = ctx.las_frame
    assert frame is not None
    n_in = n_out = 0

    def records(array: np.ndarray[Any, Any]) -> laspy.ScaleAwarePointRecord:
        return laspy.ScaleAwarePointRecord(
            array, template.point_format, template.scales, template.offsets
        )

    behind = WriteBehind()
    with ExitStack() as stack:
        target_crs = pyproj.CRS.from_user_input(ctx.crs.crs)
        writer = stack.enter_context(
            LasChunkWriter(out_path, template, target_crs, frame.offsets, frame.scales)
        )
        stack.callback(behind.close)  # before the writer closes
        rejected: LasChunkWriter | None = None
        for out in _outputs_in_order(ctx, tasks, runner, tally, out_path, progress, total):
            if out.rejected_records is not None:
                if rejected is None:
                    behind.wait()
                    offsets = tuple(float(v) for v in template.offsets)
                    scales = tuple(float(v) for v in template.scales)
                    rejected = stack.enter_context(
                        LasChunkWriter(
                            rejected_path_for(out_path),
                            template,
                            None,
                            offsets,  # type: ignore[arg-type]
                            scales,  # type: ignore[arg-type]
                        )
                    )
                    stack.callback(behind.close)
                behind.submit(rejected.write_stored, records(out.rejected_records))
            assert out.records is not None
            if len(out.records):
                behind.submit(writer.write_stored, records(out.records))
            n_in += out.count
            n_out += len(out.records)
        behind.wait()
    return n_in, n_out, tally.count
