"""One chunk of a point file: read, georeferenced and made ready to write.

A `ChunkTask` names a run of points (LAS/LAZ) or data rows (CSV byte range, Parquet
row groups) that any process can read on its own; `process_chunk` reads it, runs the
kernel (`kinsync.georef.kernel.georeference`), converts to the output CRS and returns
a `ChunkOutput` with the accounting (points outside the trajectory's span, the first
bad point) and what the main process writes. It runs in this process, in pool workers
or on Dask workers (`kinsync.pipelines.schedulers`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from concurrent.futures import Executor
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Literal, TypeVar, cast

import laspy
import numpy as np
import pyarrow as pa
import pyproj

from kinsync._jit import cached_njit
from kinsync._typing import BoolArray, FloatArray
from kinsync.crs import CrsPlan, crs_plan_transformer
from kinsync.crs_axes import output_units
from kinsync.errors import InputError, PointValueError
from kinsync.georef.kernel import (
    PositionMethod,
    georeference,
    prepared_for_points,
    raise_not_finite_points,
    span_of,
)
from kinsync.georef.profile import profile_points_to_scanner
from kinsync.georef.trajectory import GeorefRecords, GeorefTrajectory
from kinsync.io.csv_lines import csv_slice_lines
from kinsync.io.las import (
    LasPointReader,
    read_las_points,
    scaled_coordinates,
    store_coordinates,
)
from kinsync.io.las_table import TableLasPlan, las_columns
from kinsync.io.points import (
    TableLayout,
    TableSlice,
    csv_text_columns,
    read_table_slice,
    slice_position,
)
from kinsync.io.row_position import point_position, position_span
from kinsync.io.table_numbers import numeric_columns
from kinsync.mount import Mount

__all__ = [
    "OUT_COLUMNS",
    "PLY_XYZ",
    "XYZ_COLUMNS",
    "ChunkContext",
    "ChunkOutput",
    "ChunkSource",
    "ChunkTask",
    "LasOutputFrame",
    "OutputKind",
    "OutsidePolicy",
    "PointColumns",
    "continuous_longitude",
    "empty_table_output",
    "outside_tally",
    "process_chunk",
]

OutputKind = Literal["same", "table", "las", "ply"]
"""What a chunk becomes: the input's own kind (LAS -> LAS, table -> table), a table
(from LAS), LAS points (from a table) or PLY vertices (from either)."""
OutsidePolicy = Literal["error", "reject"]
"""Points outside the trajectory span: an error (nothing written), or a rejected file."""
PointColumns = Literal["auto", "xyz", "profile"]
"""Which table columns give the points: x_m,y_m,z_m, range_m,angle_rad, or either."""

PLY_XYZ = ("x", "y", "z")
XYZ_COLUMNS = ("x_m", "y_m", "z_m")
"""Scanner-frame coordinates (m) in a point table."""
OUT_COLUMNS = ("X", "Y", "Z")
"""Georeferenced coordinates (output CRS) in an output table."""
_LAS_BLOCK_POINTS = 65_536  # chunks are georeferenced this many points at a time
_R = TypeVar("_R")


def _in_blocks(n: int, blocks: Executor | None, work: Callable[[int, int], _R]) -> list[_R]:
    """``work(start, stop)`` over ``[0, n)`` in `_LAS_BLOCK_POINTS` blocks; results in order.

    With an executor the blocks run concurrently: the kernel, PROJ and the integer
    storing release the interpreter lock, and each block writes its own rows. Every
    block runs even when one fails; callers report the first failure in block order,
    as a sequential run would.
    """
    bounds = [(a, min(a + _LAS_BLOCK_POINTS, n)) for a in range(0, n, _LAS_BLOCK_POINTS)]
    if blocks is None or len(bounds) < 2:  # one block: nothing to share
        return [work(a, b) for a, b in bounds]
    return list(blocks.map(lambda ab: work(*ab), bounds))


@dataclass(frozen=True, eq=False)
class ChunkSource:
    """The input file as every worker reads it."""

    path: Path
    points: Literal["xyz", "profile"]
    table: TableLayout | None = None  # None for LAS/LAZ
    las_time_offset_s: float = 0.0  # added to LAS gps_time
    total: int = 0  # LAS/LAZ: points in the file (a table's are ``table.total_rows``)
    georeferenced_crs: str | None = None  # LAS/LAZ: a map or earth CRS its header gives
    las_end_times_s: tuple[float, float] | None = None  # LAS/LAZ: first, last gps_time stored


@dataclass(frozen=True)
class LasOutputFrame:
    """Offsets and scales of a georeferenced LAS/LAZ output.

    Attributes
    ----------
    offsets : tuple of 3 float
        x, y, z header offsets, each in its axis' unit (`kinsync.crs_axes.output_units`).
    scales : tuple of 3 float
        x, y, z resolution, each in its axis' unit: 1e-4 (m, or ft for a CRS in feet,
        whose Z is in metres unless a vertical CRS in feet is given) for ECEF and
        projected CRSs; 1e-9 deg for longitude/latitude and 1e-4 m for the height of
        geographic ones.
    longitude_x : bool
        X is a longitude in degrees (a geographic CRS): it is stored within 180 deg of
        the X offset (`continuous_longitude`), so that a file across the antimeridian
        holds continuous values (180.0001 rather than -179.9999 next to 179.9999).
    """

    offsets: tuple[float, float, float]
    scales: tuple[float, float, float]
    longitude_x: bool = False


def continuous_longitude(frame: LasOutputFrame, coords: FloatArray) -> FloatArray:
    """``coords`` with X (longitude, deg) moved by whole turns to within 180 deg of the X offset.

    Parameters
    ----------
    frame : LasOutputFrame
        The output's offsets; nothing changes unless ``frame.longitude_x``.
    coords : ndarray, shape (N, 3)
        Coordinates in the output CRS, changed in place (only those more than 180 deg
        from the offset: across the antimeridian from it).

    Returns
    -------
    ndarray, shape (N, 3)
        ``coords``.
    """
    if not frame.longitude_x or not len(coords):
        return coords
    away_deg = coords[:, 0] - frame.offsets[0]
    far = np.abs(away_deg) > 180.0
    if far.any():
        coords[far, 0] = frame.offsets[0] + (away_deg[far] + 180.0) % 360.0 - 180.0
    return coords


@dataclass(frozen=True, eq=False)
class ChunkContext:
    """What every worker holds once: input, trajectory, mount and options."""

    source: ChunkSource
    traj: GeorefTrajectory | GeorefRecords
    mount: Mount
    position: PositionMethod
    crs: CrsPlan  # the transformation chosen once (`kinsync.crs.plan_ecef_to_crs`)
    outside: OutsidePolicy
    csv_text: bool = False  # table output to CSV: workers format the floats as text
    las_frame: LasOutputFrame | None = None  # LAS output: where workers store X, Y, Z
    output: OutputKind = "same"
    table_las: TableLasPlan | None = None  # table -> LAS: how columns become points
    ply_columns: tuple[str, ...] = ()  # table -> PLY: the carried (numeric) columns
    rejected_lines: bool = False  # CSV input, CSV rejected file: rejects as their input lines


@dataclass(frozen=True)
class ChunkTask:
    """One chunk: points (LAS) or data rows (tables) ``[first, first + count)``."""

    first: int
    count: int
    table_slice: TableSlice | None = None


@dataclass(frozen=True, eq=False)
class ChunkOutput:
    """What a worker sends back: accounting, and what the main process writes."""

    count: int
    outside_count: int = 0
    outside_t_min_s: float = math.inf
    outside_t_max_s: float = -math.inf
    gap_count: int = 0  # of the outside points, those inside a gap of the trajectory
    gap_t_min_s: float = math.nan
    gap_t_max_s: float = math.nan
    error: str | None = None
    columns: dict[str, Any] | None = None  # table, PLY: the output rows (CSV: floats as text)
    rejected_columns: dict[str, Any] | None = None  # rejects of a table (CSV: floats as text)
    rejected_lines: bytes | None = None  # rejects of a CSV as their lines (`rejected_lines`)
    records: np.ndarray[Any, Any] | None = None  # LAS: inside points, X/Y/Z georeferenced
    rejected_records: np.ndarray[Any, Any] | None = None


def _read_las_task(
    ctx: ChunkContext, task: ChunkTask, las_reader: LasPointReader | None
) -> laspy.ScaleAwarePointRecord:
    """Read a LAS/LAZ chunk.

    Through ``las_reader`` (kept open between chunks) or, without one, from the file
    opened for this chunk alone, decompressed in this thread.
    """
    if las_reader is not None:
        return las_reader.read(task.first, task.count)
    return read_las_points(ctx.source.path, task.first, task.count, laz_threads=False)


def _scanner_xyz(ctx: ChunkContext, columns: dict[str, np.ndarray[Any, Any]]) -> FloatArray:
    if ctx.source.points == "profile":
        return profile_points_to_scanner(
            range_m=columns["range_m"], angle_rad=columns["angle_rad"], mount=ctx.mount
        )
    return np.column_stack([columns[c] for c in XYZ_COLUMNS])


def _outside_tally_loop(
    t_s: FloatArray, offset_s: float, t_start_s: float, t_end_s: float, gaps_s: FloatArray
) -> tuple[int, float, float, int, float, float]:  # pragma: no cover - compiled by numba
    """Points with ``t_s + offset_s`` outside ``[t_start_s, t_end_s]`` (or NaN) or in a gap.

    ``gaps_s`` (2, G): start and end times of the trajectory's gaps, in order; a time
    strictly between them is outside, as the kernel decides. Returns the count and the
    time range of the finite ones, then the same for those in a gap, without temporary
    arrays (``t_s`` may be strided).
    """
    count = 0
    t_min = np.inf
    t_max = -np.inf
    n_gap = 0
    gap_min = np.inf
    gap_max = -np.inf
    g = gaps_s.shape[1]
    for i in range(t_s.shape[0]):
        t = t_s[i] + offset_s
        in_gap = False
        if g > 0 and t > gaps_s[0, 0]:
            lo = 0  # the last gap starting before t
            hi = g - 1
            while lo < hi:
                mid = (lo + hi + 1) // 2
                if gaps_s[0, mid] < t:
                    lo = mid
                else:
                    hi = mid - 1
            in_gap = t < gaps_s[1, lo]
        if in_gap or not (t >= t_start_s and t <= t_end_s):
            count += 1
            if np.isfinite(t):
                t_min = min(t_min, t)
                t_max = max(t_max, t)
            if in_gap:
                n_gap += 1
                gap_min = min(gap_min, t)
                gap_max = max(gap_max, t)
    return count, t_min, t_max, n_gap, gap_min, gap_max


outside_tally = cast(
    Callable[..., tuple[int, float, float, int, float, float]],
    cached_njit(nogil=True)(_outside_tally_loop),
)


def tallied(
    n: int,
    count: int,
    t_min_s: float,
    t_max_s: float,
    gap_count: int = 0,
    gap_t_min_s: float = math.nan,
    gap_t_max_s: float = math.nan,
) -> ChunkOutput:
    """A chunk's accounting from `outside_tally` (NaN time ranges where none)."""
    finite = math.isfinite(t_min_s)
    return ChunkOutput(
        count=n,
        outside_count=count,
        outside_t_min_s=t_min_s if finite else math.nan,
        outside_t_max_s=t_max_s if finite else math.nan,
        gap_count=gap_count,
        gap_t_min_s=gap_t_min_s if gap_count else math.nan,
        gap_t_max_s=gap_t_max_s if gap_count else math.nan,
    )


def _rows(values: Any, keep: BoolArray, keep_arrow: Any) -> Any:
    """The ``keep`` rows of a numpy or pyarrow column (``keep_arrow``: ``keep`` for pyarrow)."""
    if isinstance(values, pa.Array | pa.ChunkedArray):
        return values.filter(keep_arrow)
    return values[keep]


def _output_columns(
    ctx: ChunkContext,
    columns: dict[str, Any],
    inside: BoolArray,
    all_inside: bool,
    coords: FloatArray,
) -> dict[str, Any]:
    """Every input column (inside rows); x_m,y_m,z_m replaced by X,Y,Z, or X,Y,Z added.

    Carried columns keep the file's own names (a ``--columns`` map renamed them for
    reading only), and their types and nulls (pyarrow columns stay pyarrow columns).
    """
    layout = ctx.source.table
    assert layout is not None
    out: dict[str, Any] = {}
    keep = None if all_inside else pa.array(inside)
    for name, values in columns.items():
        if ctx.source.points == "xyz" and name in XYZ_COLUMNS:
            j = XYZ_COLUMNS.index(name)
            out[OUT_COLUMNS[j]] = coords[:, j]
        else:
            out[layout.file_name(name)] = values if all_inside else _rows(values, inside, keep)
    if ctx.source.points == "profile":
        for j, name in enumerate(OUT_COLUMNS):
            out[name] = coords[:, j]
    return out


def empty_table_output(ctx: ChunkContext) -> dict[str, Any]:
    """The output columns of a table with no data rows, typed as a full chunk's would be.

    Written when an input table holds no points, so that the output still has the
    header (CSV) or schema (Parquet) a chunk would give it: every input column with its
    type (floats as text for CSV), ``x_m,y_m,z_m`` replaced by ``X,Y,Z`` or those added.
    """
    layout = ctx.source.table
    assert layout is not None
    float_type = pa.string() if ctx.csv_text else pa.float64()
    types: dict[str, Any] = {}
    for field in layout.schema:
        name = layout.kinsync_name(field.name)
        if ctx.source.points == "xyz" and name in XYZ_COLUMNS:
            types[OUT_COLUMNS[XYZ_COLUMNS.index(name)]] = float_type
        elif ctx.csv_text and pa.types.is_floating(field.type):
            types[field.name] = pa.string()
        else:
            types[field.name] = field.type
    if ctx.source.points == "profile":
        types |= dict.fromkeys(OUT_COLUMNS, float_type)
    return {name: pa.array([], type=t) for name, t in types.items()}


def process_chunk(
    ctx: ChunkContext,
    task: ChunkTask,
    tally_only: bool,
    las_reader: LasPointReader | None = None,
    blocks: Executor | None = None,
) -> ChunkOutput:
    """Read and georeference one chunk (in a worker or in the main process).

    Read errors raise; errors of the points themselves (non-finite values) come back
    in ``error`` with the chunk's accounting, so that the main process can still count
    points outside the span after an earlier chunk failed. ``blocks``, a thread pool,
    georeferences and transforms the chunk's blocks concurrently (the serial run on a
    machine of several cores); the output is the same without.
    """
    if ctx.source.table is None:
        return _process_las_task(ctx, task, tally_only, las_reader, blocks)
    return _process_table_task(ctx, task, tally_only, blocks)


def _georeference_blocks(
    ctx: ChunkContext, t: FloatArray, xyz: FloatArray, blocks: Executor | None
) -> tuple[FloatArray, BoolArray]:
    """`georeference` of a chunk's points, block by block (the same values and errors)."""
    n = t.size
    pos = np.empty((n, 3))
    inside = np.empty(n, dtype=np.bool_)
    traj = prepared_for_points(ctx.traj, t)  # once for the chunk's blocks

    def work(a: int, b: int) -> bool:
        try:
            pos[a:b], inside[a:b] = georeference(
                t[a:b], xyz[a:b], traj, ctx.mount, position=ctx.position
            )
        except InputError:
            return False
        return True

    if not all(_in_blocks(n, blocks, work)):  # the whole chunk's error: its first bad point
        return georeference(t, xyz, traj, ctx.mount, position=ctx.position)
    return pos, inside


def _to_crs_blocks(ctx: ChunkContext, pos: FloatArray, blocks: Executor | None) -> FloatArray:
    """ECEF -> the output CRS, block by block (PROJ transforms point by point)."""
    to_crs = crs_plan_transformer(ctx.crs)
    if to_crs is None:
        return pos
    transform = to_crs
    coords = np.empty_like(pos)

    def work(a: int, b: int) -> None:
        coords[a:b] = transform(pos[a:b])

    _in_blocks(len(pos), blocks, work)
    return coords


def _process_table_task(
    ctx: ChunkContext, task: ChunkTask, tally_only: bool, blocks: Executor | None
) -> ChunkOutput:
    """`process_chunk` for a table slice."""
    layout = ctx.source.table
    assert layout is not None
    assert task.table_slice is not None
    columns = read_table_slice(layout, task.table_slice, arrow=True)
    t = columns["t_s"]
    traj, src = ctx.traj, ctx.source
    base = tallied(
        int(t.size), *outside_tally(t, 0.0, traj.t_start_s, traj.t_end_s, traj.gap_bounds_s)
    )
    if tally_only:
        return base
    try:
        xyz = _scanner_xyz(ctx, columns)
        pos, inside = _georeference_blocks(ctx, t, xyz, blocks)
    except PointValueError as err:
        return replace(base, error=_point_value_text(ctx, task, err))
    except InputError as err:
        return replace(base, error=f"{src.path}: {_task_span(ctx, task)}: {err}")
    all_inside = bool(inside.all())
    if not all_inside and ctx.outside == "error":
        return base
    if not all_inside:
        pos = pos[inside]
    coords = _to_crs_blocks(ctx, pos, blocks)
    not_finite = ~np.isfinite(coords).all(axis=1)
    if not_finite.any():  # finite inputs, absurd combination (a trajectory, a CRS)
        row = int(np.flatnonzero(inside)[np.flatnonzero(not_finite)[0]])
        error = (
            f"{src.path}: {_task_position(ctx, task, row)}: georeferences to "
            f"{coords[not_finite][0]} "
            f"in {ctx.crs}, not a finite coordinate; check the trajectory and the CRS"
        )
        return replace(base, error=error)
    return _table_output(ctx, task, base, t, columns, inside, coords)


def _table_output(
    ctx: ChunkContext,
    task: ChunkTask,
    base: ChunkOutput,
    t: FloatArray,
    columns: dict[str, Any],
    inside: BoolArray,
    coords: FloatArray,
) -> ChunkOutput:
    """The georeferenced rows of a table slice as the output wants them, and its rejects."""
    layout = ctx.source.table
    assert layout is not None
    assert task.table_slice is not None
    all_inside = bool(inside.all())
    rejected = None
    if not all_inside and ctx.rejected_lines:  # the input's own lines
        base = replace(base, rejected_lines=csv_slice_lines(layout, task.table_slice, ~inside))
    elif not all_inside:
        outside, outside_arrow = ~inside, pa.array(~inside)
        rejected = {
            layout.file_name(k): _rows(v, outside, outside_arrow) for k, v in columns.items()
        }
    if ctx.output == "las":
        return _table_las_output(ctx, task, base, t, columns, inside, all_inside, coords, rejected)
    if ctx.output == "ply":
        kept = numeric_columns(layout, columns, _slice_where(ctx, task), inside)
        ply = {axis: coords[:, j] for j, axis in enumerate(PLY_XYZ)}
        ply |= {
            n: _inside(kept[layout.kinsync_name(n)], inside, all_inside) for n in ctx.ply_columns
        }
        return replace(base, columns=ply, rejected_columns=rejected)
    out_columns = _output_columns(ctx, columns, inside, all_inside, coords)
    if ctx.csv_text:
        out_columns = csv_text_columns(out_columns)
        rejected = None if rejected is None else csv_text_columns(rejected)
    return replace(base, columns=out_columns, rejected_columns=rejected)


def _inside(
    values: np.ndarray[Any, Any], inside: BoolArray, all_inside: bool
) -> np.ndarray[Any, Any]:
    return values if all_inside else values[inside]


def _table_las_output(
    ctx: ChunkContext,
    task: ChunkTask,
    base: ChunkOutput,
    t: FloatArray,
    columns: dict[str, np.ndarray[Any, Any]],
    inside: BoolArray,
    all_inside: bool,
    coords: FloatArray,
    rejected: dict[str, Any] | None,
) -> ChunkOutput:
    """Table rows -> LAS points of the plan's format, X, Y, Z stored for the output frame."""
    plan, frame, layout = ctx.table_las, ctx.las_frame, ctx.source.table
    assert plan is not None
    assert frame is not None
    assert layout is not None
    kept = numeric_columns(layout, columns, _slice_where(ctx, task), inside)
    wanted = {n: _inside(kept[n], inside, all_inside) for n in plan.standard}
    wanted |= {n: _inside(kept[n], inside, all_inside) for n, _ in plan.extra}
    rows = np.flatnonzero(inside)
    records, error = plan.records(_inside(t, inside, all_inside), wanted)
    if error is not None:
        where = _task_position(ctx, task, int(rows[error[0]]))
        return replace(base, error=f"{ctx.source.path}: {where}, {error[1]}")
    coords = continuous_longitude(frame, coords)
    bad = store_coordinates(records, coords, frame.offsets, frame.scales)
    if bad >= 0:
        where = _task_position(ctx, task, int(rows[bad]))
        return replace(base, error=_las_storage_error(ctx, where, coords[bad]))
    return replace(base, records=records, rejected_columns=rejected)


def _process_las_task(
    ctx: ChunkContext,
    task: ChunkTask,
    tally_only: bool,
    las_reader: LasPointReader | None,
    blocks: Executor | None,
) -> ChunkOutput:
    """`process_chunk` for LAS/LAZ: georeference in blocks, X, Y, Z stored in place.

    The chunk is processed ``_LAS_BLOCK_POINTS`` at a time, so that no chunk-sized
    float array is made (fresh large arrays cost page faults on every chunk) and the
    blocks stay in cache; the georeferenced coordinates go straight into the records'
    integers with the output's offsets and scales. Points outside the span keep their
    scanner-frame integers (they are written unchanged to the rejected file).
    """
    record = _read_las_task(ctx, task, las_reader)
    traj, src, frame = ctx.traj, ctx.source, ctx.las_frame
    array = record.array
    gps_time = array["gps_time"]
    n = len(array)
    base = tallied(
        n,
        *outside_tally(
            gps_time, src.las_time_offset_s, traj.t_start_s, traj.t_end_s, traj.gap_bounds_s
        ),
    )
    if tally_only:
        return base
    if ctx.output in ("table", "ply"):
        return _las_table_output(ctx, task, base, record, blocks)
    assert frame is not None
    to_crs = crs_plan_transformer(ctx.crs)
    inside = np.empty(n, dtype=np.bool_)
    traj = _prepared_for_las(ctx, gps_time)

    def work(start: int, stop: int) -> str | None:
        """Georeference one block into its records; the error message, if any."""
        block = array[start:stop]
        t = gps_time[start:stop] + src.las_time_offset_s
        xyz = scaled_coordinates(block, record.scales, record.offsets)
        try:
            pos, block_inside = georeference(t, xyz, traj, ctx.mount, position=ctx.position)
        except InputError as err:
            return _las_chunk_error(ctx, task, record, err)
        coords = pos if to_crs is None else continuous_longitude(frame, to_crs(pos))
        bad = store_coordinates(block, coords, frame.offsets, frame.scales, block_inside)
        if bad >= 0:
            return _las_storage_error(ctx, _task_position(ctx, task, start + bad), coords[bad])
        inside[start:stop] = block_inside
        return None

    error = next((e for e in _in_blocks(n, blocks, work) if e is not None), None)
    if error is not None:
        return replace(base, error=error)
    all_inside = bool(inside.all())
    if not all_inside and ctx.outside == "error":
        return base
    return replace(
        base,
        records=array if all_inside else array[inside],
        rejected_records=None if all_inside else array[~inside],
    )


def _prepared_for_las(ctx: ChunkContext, gps_time: Any) -> GeorefTrajectory:
    """The trajectory prepared for a LAS chunk's points (no chunk-sized time array made).

    The span of ``gps_time + las_time_offset_s`` is that of ``gps_time`` moved by the
    offset: a rounded sum is monotonic, so it holds every point's time.
    """
    t_min, t_max = span_of(np.asarray(gps_time, dtype=np.float64))
    offset = ctx.source.las_time_offset_s
    return ctx.traj.prepared_for(t_min + offset, t_max + offset)


def _las_table_output(
    ctx: ChunkContext, task: ChunkTask, base: ChunkOutput, record: Any, blocks: Executor | None
) -> ChunkOutput:
    """LAS points -> table (or PLY) rows: every dimension, X, Y, Z georeferenced floats.

    Points outside the span keep their records, unchanged, for the rejected LAS file.
    """
    traj, src = ctx.traj, ctx.source
    array = record.array
    n = len(array)
    to_crs = crs_plan_transformer(ctx.crs)
    inside = np.empty(n, dtype=np.bool_)
    coords = np.empty((n, 3))
    gps_time = record.gps_time
    traj = _prepared_for_las(ctx, gps_time)

    def work(start: int, stop: int) -> str | None:
        """Georeference one block into ``coords``; the error message, if any."""
        block = array[start:stop]
        t = gps_time[start:stop] + src.las_time_offset_s
        xyz = scaled_coordinates(block, record.scales, record.offsets)
        try:
            pos, block_inside = georeference(t, xyz, traj, ctx.mount, position=ctx.position)
        except InputError as err:
            return _las_chunk_error(ctx, task, record, err)
        inside[start:stop] = block_inside
        coords[start:stop] = pos if to_crs is None else to_crs(pos)
        return None

    error = next((e for e in _in_blocks(n, blocks, work) if e is not None), None)
    if error is not None:
        return replace(base, error=error)
    all_inside = bool(inside.all())
    if not all_inside and ctx.outside == "error":
        return base
    kept = array if all_inside else array[inside]
    kept_coords = coords if all_inside else coords[inside]
    not_finite = ~np.isfinite(kept_coords).all(axis=1)
    if not_finite.any():
        at = int(np.flatnonzero(inside)[np.flatnonzero(not_finite)[0]])
        error = (
            f"{src.path}: {_task_position(ctx, task, at)}: georeferences to "
            f"{kept_coords[not_finite][0]} in {ctx.crs}, not a finite coordinate; check the "
            "trajectory and the CRS"
        )
        return replace(base, error=error)
    columns = las_columns(kept, record.point_format, kept_coords)
    if ctx.output == "ply":
        columns = {
            PLY_XYZ[OUT_COLUMNS.index(k)] if k in OUT_COLUMNS else k: v for k, v in columns.items()
        }
    elif ctx.csv_text:
        columns = csv_text_columns(columns)
    return replace(base, columns=columns, rejected_records=None if all_inside else array[~inside])


def _las_chunk_error(ctx: ChunkContext, task: ChunkTask, record: Any, err: InputError) -> str:
    """The message for a LAS chunk that failed to georeference.

    It names the chunk's first bad point as the file counts it (the failing block's own
    error names its index in the block).
    """
    t = np.asarray(record.gps_time, dtype=np.float64) + ctx.source.las_time_offset_s
    xyz = scaled_coordinates(record.array, record.scales, record.offsets)
    try:
        raise_not_finite_points(t, xyz)
    except PointValueError as chunk_err:
        return _point_value_text(ctx, task, chunk_err)
    except InputError as chunk_err:
        err = chunk_err
    return f"{ctx.source.path}: {_task_span(ctx, task)}: {err}"


def _slice_where(ctx: ChunkContext, task: ChunkTask) -> Callable[[int], str]:
    """Row ``i`` of a table task as a user finds it in the file (`slice_position`)."""
    layout, sl = ctx.source.table, task.table_slice
    assert layout is not None
    assert sl is not None
    return lambda i: slice_position(layout, sl, i)


def _task_position(ctx: ChunkContext, task: ChunkTask, i: int) -> str:
    """Point ``i`` of a task (0-based in the task) as a user finds it in the file.

    ``line N`` (CSV, header = line 1), ``row N of M`` (Parquet), ``point N of M``
    (LAS/LAZ), counted from 1.
    """
    if ctx.source.table is not None:
        return _slice_where(ctx, task)(i)
    return point_position(ctx.source.path, task.first + i, ctx.source.total)


def _task_span(ctx: ChunkContext, task: ChunkTask) -> str:
    """The points of a task as a user finds them: ``lines 2..1001``, ``rows 1..1000 of M``."""
    return position_span(_task_position(ctx, task, 0), _task_position(ctx, task, task.count - 1))


def _point_value_text(ctx: ChunkContext, task: ChunkTask, err: PointValueError) -> str:
    """A kernel's `PointValueError` (0-based index in the task) in the file's own terms.

    Names the point (`_task_position`), the file's column and how many such points the
    chunk holds (the whole file when it is one chunk).
    """
    layout, src = ctx.source.table, ctx.source
    if layout is None:  # LAS/LAZ: its dimensions
        column = "gps_time" if err.field == "t" else err.field
        total = src.total
    else:
        column = {"t": "t_s", "x": "x_m", "y": "y_m", "z": "z_m"}.get(err.field, err.field)
        if src.points == "profile" and err.field in ("x", "y", "z"):
            column = "range_m"  # the scanner coordinates come from range and angle
        column = layout.file_name(column)
        total = layout.total_rows
    scope = (
        "in the file"
        if task.count == total
        else f"in the chunk of {_task_span(ctx, task)} (the rest of the file not checked)"
    )
    advice = err.advice
    if layout is None and src.georeferenced_crs is not None and err.field in ("x", "y", "z"):
        advice = (
            f"this file is already georeferenced ({src.georeferenced_crs}); --points takes "
            "points in the scanner frame"
        )
    return (
        f"{src.path}: {_task_position(ctx, task, err.index)}, column {column!r}: "
        f"{err.problem}; {err.count} such point(s) {scope}: {advice}"
    )


_UNIT_SYMBOLS = {"metre": "m", "degree": "deg"}
"""Short names of the usual axis units in messages; any other unit is named in full."""


def _las_storage_error(ctx: ChunkContext, where: str, coords: FloatArray) -> str:
    """The message for a point whose coordinates LAS integers cannot hold.

    Scanner coordinates are within ±`kinsync.georef.kernel.MAX_SCANNER_RANGE_M` of the
    trajectory (checked before), so a point this far from the offsets means a trajectory
    that runs too far from the middle of the file's time span: the file is too long for
    one LAS output at this resolution.
    """
    frame = ctx.las_frame
    assert frame is not None
    reach = [2.0**31 * s for s in frame.scales]
    away = [abs(float(c) - o) for c, o in zip(coords.tolist(), frame.offsets, strict=True)]
    axis = max(range(3), key=lambda j: away[j] / reach[j])
    unit_name = output_units(pyproj.CRS.from_user_input(ctx.crs.crs))[axis]
    unit = _UNIT_SYMBOLS.get(unit_name, unit_name)
    return (
        f"{ctx.source.path}: {where} georeferences to {coords.tolist()} ({ctx.crs}), "
        f"{away[axis]:.6g} {unit} from the file's reference position along {'xyz'[axis]} "
        f"(offsets {list(frame.offsets)}, the trajectory at the middle of the file's time "
        f"span, rounded); LAS integers at scales {list(frame.scales)} reach only {reach[axis]:.6g} "
        f"{unit} either way: the points are within the scanner's range of their trajectory, so the "
        "trajectory covers too long a distance for one LAS file at this resolution: split "
        "the file into shorter time spans"
    )
