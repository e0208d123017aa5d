"""LAS/LAZ point clouds, read and written in chunks (laspy; LAZ through lazrs).

Reading: `las_info` / `las_header` read the header only; `LasPointReader` (and
`read_las_points`, `iter_las_chunks` on top of it) reads any run of points on its
own, so that separate processes can each read their own part of one file: LAS from
the run's byte offset, LAZ by decompressing the LAZ chunks that hold the run, found
in the file's chunk table (fixed- or variable-size chunks: COPC files are read in
their stored point order). Before any point is read, the header's point count is
checked against the file (LAS: its size; LAZ: the chunk table and chunks, see
`kinsync.io.las_header.read_las_layout`), so that a truncated or corrupt file, or a
count that would leave points out, is an `InputError` naming the points concerned,
never a crash or a silently short read; so is any failure of laspy or lazrs on
damaged bytes.

GPS time: with the global-encoding bit "adjusted standard GPS time" set
(``gps_time_type == "adjusted_standard"``), ``gps_time`` is GPS time - 1e9 s
(`kinsync.io.passes.ADJUSTED_GPS_OFFSET_S`); otherwise it is GPS seconds of week
(``"week"``). These readers return ``gps_time`` as stored; the caller converts.

The header checks are in `kinsync.io.las_header`, the LAZ chunk table in
`kinsync.io.laz_chunks`, the coordinate conversions in `kinsync.io.las_coordinates`;
writing is `kinsync.io.las_writer.LasChunkWriter`.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import Any, Literal

import laspy
import lazrs
import numpy as np

from kinsync.errors import InputError
from kinsync.io.gps_week import (
    FUTURE_SLACK_S,
    SECONDS_PER_WEEK,
    WEEK_SECONDS_MAX_S,
    WEEK_SECONDS_SLACK_S,
    future_time_text,
    gps_time_now_s,
)
from kinsync.io.las_coordinates import scaled_coordinates, store_coordinates
from kinsync.io.las_crs import las_crs
from kinsync.io.las_header import las_header, las_suffix, open_las_file, read_las_layout
from kinsync.io.laz_chunks import LazChunks, points_text
from kinsync.io.trajectory import TimeScale, gps_week_needed_text

__all__ = [
    "ADJUSTED_GPS_OFFSET_S",
    "SOW_TRAJECTORY_ADVICE",
    "WEEK_SECONDS_SLACK_S",
    "LasInfo",
    "LasPointReader",
    "check_week_rollover",
    "check_week_seconds",
    "iter_las_chunks",
    "las_end_times",
    "las_header",
    "las_info",
    "las_takes_gps_week",
    "las_time_offset_s",
    "read_las_points",
    "scaled_coordinates",
    "store_coordinates",
]


@dataclass(frozen=True)
class LasInfo:
    """Header facts of a LAS/LAZ file.

    Attributes
    ----------
    path : Path
        The file.
    point_count : int
        Number of points.
    point_format_id : int
        LAS point data record format (0-10).
    version : str
        LAS version, e.g. ``"1.4"``.
    scales : tuple of float
        x, y, z scale factors (m per integer unit).
    offsets : tuple of float
        x, y, z offsets (m).
    crs_wkt : str or None
        The CRS as WKT, or None when the file has none (or one pyproj cannot parse, or a
        VerticalUnitsGeoKey that is no length unit: `kinsync.io.cloud.cloud_crs` refuses it).
    gps_time_type : {"week", "adjusted_standard"}
        GPS seconds of week, or adjusted standard GPS time (GPS time - 1e9 s).
    vlrs_count : int
        Number of VLRs plus EVLRs (the LAZ compression VLR not counted).
    """

    path: Path
    point_count: int
    point_format_id: int
    version: str
    scales: tuple[float, float, float]
    offsets: tuple[float, float, float]
    crs_wkt: str | None
    gps_time_type: Literal["week", "adjusted_standard"]
    vlrs_count: int


ADJUSTED_GPS_OFFSET_S = 1.0e9
"""LAS "adjusted standard GPS time" is GPS time minus this (s)."""


_NO_GPS_TIME_ADVICE = (
    "export the points from the scanner software in a point format with gps_time (1, 3 "
    "or 6-10; LAS 1.4 point format 6 is the usual one), or as a CSV/Parquet table "
    "t_s,x_m,y_m,z_m"
)
"""What to do with a point format without ``gps_time`` (0 or 2)."""


def las_time_offset_s(
    info: LasInfo, traj_scale: TimeScale, gps_week: int | None, *, needed_by: str
) -> float:
    """What to add to a LAS file's ``gps_time`` to reach a trajectory's time scale (s).

    Parameters
    ----------
    info : LasInfo
        The file's header facts (`las_info`): its point format must have ``gps_time``.
    traj_scale : {"gps", "week"}
        The trajectory's (`kinsync.io.trajectory.read_trajectory_file`).
    gps_week : int, optional
        GPS week of seconds-of-week times, when the two scales differ.
    needed_by : str
        What needs the times (``"georeferencing"``), for the message of a file without.

    Raises
    ------
    InputError
        No ``gps_time`` in the file, or scales that cannot be matched without a GPS week.
    """
    path = info.path
    if "gps_time" not in laspy.PointFormat(info.point_format_id).dimension_names:
        msg = (
            f"{path}: point format {info.point_format_id} has no gps_time; {needed_by} "
            f"needs a time per point: {_NO_GPS_TIME_ADVICE}"
        )
        raise InputError(msg)
    if info.gps_time_type == "adjusted_standard":
        if traj_scale == "week":
            msg = f"{path}: {gps_week_needed_text('adjusted standard GPS time', 'week')}"
            raise InputError(msg)
        return ADJUSTED_GPS_OFFSET_S
    if traj_scale == "gps":
        if gps_week is None:
            msg = f"{path}: {gps_week_needed_text('GPS seconds of week', 'gps')}"
            raise InputError(msg)
        return gps_week * SECONDS_PER_WEEK
    return 0.0


def check_week_seconds(info: LasInfo, end_times_s: tuple[float, float] | None) -> None:
    """Refuse ``gps_time`` values that cannot be what the header says they are.

    Parameters
    ----------
    info : LasInfo
        The file's header facts.
    end_times_s : tuple of float or None
        ``gps_time`` of the first and last point as stored (`las_end_times`).

    Raises
    ------
    InputError
        A time beyond a week (plus `WEEK_SECONDS_SLACK_S`) under a header that says
        seconds of week: most likely adjusted standard GPS time, or GPS time, written
        with the global-encoding bit unset; the message says how to set it (and, for GPS
        time, to subtract 1e9 s). Under a header that says adjusted standard GPS time, a
        GPS time after today (most likely Unix time:
        `kinsync.io.gps_week.check_not_future`).
    """
    if end_times_s is None:
        return
    t = max(end_times_s)
    now = gps_time_now_s()
    if info.gps_time_type == "adjusted_standard":
        if t + ADJUSTED_GPS_OFFSET_S > now + FUTURE_SLACK_S:
            msg = (
                f"{info.path}: gps_time {t!r} s as stored, adjusted standard GPS time "
                f"(GPS time - {ADJUSTED_GPS_OFFSET_S:.0e} s) as the header says: "
                f"{future_time_text(t + ADJUSTED_GPS_OFFSET_S, now)}"
            )
            raise InputError(msg)
        return
    if t <= WEEK_SECONDS_MAX_S:
        return
    what = (
        f"{info.path}: gps_time {t!r} s cannot be GPS seconds of week (a week has "
        f"{SECONDS_PER_WEEK:.0f} s), which is what the header says (global encoding bit 0 "
        "unset)"
    )
    set_bit = "las.header.global_encoding.gps_time_type = laspy.header.GpsTimeType.STANDARD"
    if t < ADJUSTED_GPS_OFFSET_S:
        msg = (
            f"{what}; it is most likely adjusted standard GPS time (GPS time - "
            f"{ADJUSTED_GPS_OFFSET_S:.0e} s) written with the bit unset. Set the bit (with "
            f"laspy: {set_bit}, then write the file again) or ask the software that wrote "
            "it for adjusted standard GPS time"
        )
    elif t > now + FUTURE_SLACK_S:
        msg = (
            f"{what}; {future_time_text(t, now)}; then store adjusted standard "
            f"GPS time (GPS time - {ADJUSTED_GPS_OFFSET_S:.0e} s) and set the bit ({set_bit})"
        )
    else:
        msg = (
            f"{what}; it is most likely GPS time written with the bit unset. Adjusted "
            f"standard GPS time is GPS time - {ADJUSTED_GPS_OFFSET_S:.0e} s: subtract "
            f"{ADJUSTED_GPS_OFFSET_S:.0e} s from gps_time and set the bit (with laspy: "
            f"las.gps_time = las.gps_time - {ADJUSTED_GPS_OFFSET_S:.0e}; {set_bit}; then "
            "write the file again), or ask the software that wrote it for adjusted "
            "standard GPS time"
        )
    raise InputError(msg)


def check_week_rollover(
    info: LasInfo, t_min_s: float, t_max_s: float, gps_week: int | None
) -> None:
    """Refuse GPS seconds of week that cross the week rollover (604800 s back to 0).

    One GPS week turns a LAS file's seconds of week into GPS time, for every command
    (`las_time_offset_s`); a file whose times of week start again from 0 holds two
    weeks, and the points after the rollover would be placed a week early. Times within
    a day of a week's end (or counting past it) together with times within a day of its
    start are taken as such a file (no survey file spans the rest of a week); the
    message says to split it or to store adjusted standard GPS time.

    Parameters
    ----------
    info : LasInfo
        The file's header facts; nothing is checked when it says adjusted standard time.
    t_min_s, t_max_s : float
        Smallest and largest ``gps_time`` seen (s, as stored): the first and last
        point, or every point read so far.
    gps_week : int or None
        ``--gps-week``, named in the message.

    Raises
    ------
    InputError
        Times on both sides of the rollover.
    """
    if info.gps_time_type == "adjusted_standard":
        return
    if not (t_min_s < WEEK_SECONDS_SLACK_S and t_max_s >= SECONDS_PER_WEEK - WEEK_SECONDS_SLACK_S):
        return
    weeks = (
        f"--gps-week {gps_week} for the part before, --gps-week {gps_week + 1} for the part after"
        if gps_week is not None
        else "each part with its own GPS week"
    )
    tool = f" (LAStools: las2las -week_to_adjusted {gps_week})" if gps_week is not None else ""
    msg = (
        f"{info.path}: the points hold GPS seconds of week near the end of a week "
        f"({t_max_s!r} s) and at the start of the next ({t_min_s!r} s): the file crosses "
        "the GPS week rollover (its times start again from 0), and one GPS week cannot "
        f"place both parts. Store its times as adjusted standard GPS time{tool}, or split "
        f"the file where gps_time goes back to 0 and give {weeks}{SOW_TRAJECTORY_ADVICE}"
    )
    raise InputError(msg)


SOW_TRAJECTORY_ADVICE = (  # a rolled-over point file's advice: an SBET cannot be split
    " (with a trajectory on GPS time, a CSV: --gps-week also sets the week of a trajectory "
    "in seconds of week, so with an SBET store adjusted standard time instead)"
)


def las_takes_gps_week(path: Path) -> bool:
    """Whether a GPS week applies to this point file: a LAS/LAZ header saying seconds of week.

    False for any other kind of file (a table carries GPS time). A LAS/LAZ file whose
    header cannot be read is counted as taking one: its reader names what is wrong.
    """
    try:
        las_suffix(Path(path))
    except InputError:
        return False
    try:
        return las_info(path).gps_time_type == "week"
    except InputError:
        return True


def las_info(path: Path) -> LasInfo:
    """Read the header of a LAS/LAZ file (no points).

    Raises
    ------
    InputError
        Missing file, unknown suffix, unreadable header.
    """
    path = Path(path)
    header = las_header(path)
    try:
        crs = las_crs(header)
    except Exception:  # a damaged CRS record: reported as no CRS
        crs = None
    adjusted = header.global_encoding.gps_time_type == laspy.header.GpsTimeType.STANDARD
    evlrs = header.evlrs if header.evlrs is not None else []
    sx, sy, sz = (float(v) for v in header.scales)
    ox, oy, oz = (float(v) for v in header.offsets)
    return LasInfo(
        path=path,
        point_count=int(header.point_count),
        point_format_id=int(header.point_format.id),
        version=str(header.version),
        scales=(sx, sy, sz),
        offsets=(ox, oy, oz),
        crs_wkt=None if crs is None else crs.to_wkt(),
        gps_time_type="adjusted_standard" if adjusted else "week",
        vlrs_count=sum(v.user_id != "laszip encoded" for v in header.vlrs) + len(evlrs),
    )


def las_end_times(path: Path) -> tuple[float, float] | None:
    """``gps_time`` of a LAS/LAZ file's first and last point, as stored.

    Two points are read (LAZ: the first and the last LAZ chunk are decompressed); None
    for a file without points.

    Raises
    ------
    InputError
        Missing or unreadable file, a point format without ``gps_time``, a truncated file.
    """
    with LasPointReader(path) as reader:
        if reader.point_count == 0:
            return None
        if "gps_time" not in reader.point_format.dimension_names:
            msg = (
                f"{reader.path}: point format {reader.point_format.id} has no gps_time; "
                f"{_NO_GPS_TIME_ADVICE}"
            )
            raise InputError(msg)
        first = float(reader.read(0, 1).array["gps_time"][0])
        last = float(reader.read(reader.point_count - 1, 1).array["gps_time"][0])
    return first, last


def iter_las_chunks(path: Path, chunk_points: int) -> Iterator[laspy.ScaleAwarePointRecord]:
    """Stream the points of a LAS/LAZ file in chunks of at most ``chunk_points``.

    Parameters
    ----------
    path : Path
        ``.las`` or ``.laz`` file (COPC included).
    chunk_points : int
        Points per chunk, >= 1.

    Yields
    ------
    laspy.ScaleAwarePointRecord
        Points as stored, in file order (``x, y, z`` scaled, in the file's frame;
        ``gps_time`` on the file's time scale, see `las_info`).

    Raises
    ------
    InputError
        Missing file, unknown suffix, unreadable, corrupt or truncated file.
    """
    path = Path(path)
    if chunk_points < 1:
        msg = f"{path}: chunk_points must be >= 1, got {chunk_points}"
        raise InputError(msg)
    with LasPointReader(path) as reader:
        for first in range(0, reader.point_count, chunk_points):
            yield reader.read(first, min(chunk_points, reader.point_count - first))


class LasPointReader:
    """Read runs of points of one LAS/LAZ file by position, keeping the file open.

    LAS: each run is read from its byte offset. LAZ (COPC included): the LAZ chunk
    table says which chunks hold a run; those whole chunks are decompressed (in
    parallel with lazrs's thread pool) and the run cut out; the rest of the last chunk
    is kept, so that reading a file in order decompresses every chunk once.
    The header's point count is checked against the file when it is opened: a
    truncated or inconsistent file is an error naming the missing points before any
    point is read. Use as a context manager, or call `close`.

    Parameters
    ----------
    path : Path
        ``.las`` or ``.laz`` file.
    laz_threads : bool
        Decompress LAZ with lazrs's thread pool (default); False decompresses one chunk
        at a time, for processes that are themselves run in parallel.

    Attributes
    ----------
    point_count : int
        Number of points (checked against the file).
    point_format : laspy.PointFormat
        The point data record format.
    gps_time_type : {"week", "adjusted_standard"}
        How ``gps_time`` is stored (see `LasInfo`).

    Raises
    ------
    InputError
        Missing file, unknown suffix, unreadable header, a truncated file, a LAZ chunk
        table that is missing or disagrees with the header.
    """

    def __init__(self, path: Path, *, laz_threads: bool = True) -> None:
        self.path = Path(path)
        self._threads = laz_threads
        self._fh = open_las_file(self.path)
        self._tail: tuple[int, int, np.ndarray[Any, Any]] | None = None  # LAZ: see _read_laz
        self._laz: LazChunks | None = None
        try:
            file_size = os.fstat(self._fh.fileno()).st_size
            header, self._laz = read_las_layout(self.path, self._fh, file_size)
            self.point_count = int(header.point_count)
            self.point_format: laspy.PointFormat = header.point_format
            adjusted = header.global_encoding.gps_time_type == laspy.header.GpsTimeType.STANDARD
            self.gps_time_type: Literal["week", "adjusted_standard"] = (
                "adjusted_standard" if adjusted else "week"
            )
            self._scales = np.array(header.scales, dtype=np.float64)
            self._offsets = np.array(header.offsets, dtype=np.float64)
            self._dtype = header.point_format.dtype()
            self._data_start = int(header.offset_to_point_data)
        except BaseException:
            self._fh.close()
            raise

    def read(self, start: int, count: int) -> laspy.ScaleAwarePointRecord:
        """Read ``count`` points from point index ``start`` (see `read_las_points`).

        The returned records may be changed in place by the caller.
        """
        if start < 0 or count < 0 or start + count > self.point_count:
            msg = (
                f"{self.path}: points {start}..{start + count - 1} requested, the file holds "
                f"{self.point_count} points"
            )
            raise InputError(msg)
        if count == 0:
            array = np.zeros(0, dtype=self._dtype)
        elif self._laz is not None:
            array = self._read_laz(self._laz, start, count)
        else:
            array = self._read_las(start, count)
        return laspy.ScaleAwarePointRecord(array, self.point_format, self._scales, self._offsets)

    def _read_las(self, start: int, count: int) -> np.ndarray[Any, Any]:
        array = np.empty(count, dtype=self._dtype)
        size = self._dtype.itemsize
        try:
            self._fh.seek(self._data_start + start * size)
            got = self._fh.readinto(array.view(np.uint8).data)
        except OSError as err:
            msg = f"{self.path}: cannot read {points_text(start, start + count - 1)} ({err})"
            raise InputError(msg) from err
        if got != count * size:
            msg = (
                f"{self.path}: {points_text(start + got // size, start + count - 1)} of "
                f"{self.point_count}: missing (the file became shorter while it was read); "
                "copy it again"
            )
            raise InputError(msg)
        return array

    def _read_laz(self, laz: LazChunks, start: int, count: int) -> np.ndarray[Any, Any]:
        """Points ``start .. start + count - 1``, decompressed straight into the result.

        Whole LAZ chunks inside the run are decompressed into the returned array itself;
        a chunk the run only partly covers is decompressed on its own and the part
        needed copied. ``self._tail`` keeps the undelivered end of such a chunk (chunk
        index, index of its first point kept, those points), so that the next run in
        file order starts from it instead of decompressing that chunk again. Memory
        beyond the result: one LAZ chunk.
        """
        end = start + count
        out = np.empty(count, dtype=self._dtype)
        at = start  # the next point to deliver
        old, self._tail = self._tail, None
        if old is not None and old[1] <= start < old[1] + len(old[2]):
            k, first, held = old
            stop = min(end, first + len(held))
            out[: stop - start] = held[start - first : stop - first]
            if stop < first + len(held):
                self._tail = (k, stop, held[stop - first :])
            at = stop
        fp = laz.first_point
        while at < end:
            k = laz.chunk_of(at)
            a, b = int(fp[k]), int(fp[k + 1])
            if a == at and b <= end:  # whole chunks: decompressed in place
                k_last = laz.chunk_of(end - 1)
                if int(fp[k_last + 1]) > end:
                    k_last -= 1
                stop = int(fp[k_last + 1])
                self._decompress(laz, k, k_last, out[at - start : stop - start])
                at = stop
                continue
            chunk = np.empty(b - a, dtype=self._dtype)  # a chunk the run covers in part
            self._decompress(laz, k, k, chunk)
            stop = min(end, b)
            out[at - start : stop - start] = chunk[at - a : stop - a]
            if stop < b:
                self._tail = (k, stop, chunk[stop - a :])
            at = stop
        return out

    def _decompress(self, laz: LazChunks, k0: int, k1: int, points: np.ndarray[Any, Any]) -> None:
        """Decompress chunks ``k0 .. k1`` into ``points`` (exactly their points)."""
        p0, p1 = int(laz.first_point[k0]), int(laz.first_point[k1 + 1])
        b0, b1 = int(laz.first_byte[k0]), int(laz.first_byte[k1 + 1])
        try:
            self._fh.seek(b0)
            data = self._fh.read(b1 - b0)
        except OSError as err:
            msg = f"{self.path}: cannot read {points_text(p0, p1 - 1)} ({err})"
            raise InputError(msg) from err
        if len(data) != b1 - b0:
            msg = (
                f"{self.path}: {points_text(p0, p1 - 1)} of {self.point_count}: missing (the "
                "file became shorter while it was read); copy it again"
            )
            raise InputError(msg)
        out = points.view(np.uint8)
        counts = np.diff(laz.first_point[k0 : k1 + 2])
        sizes = np.diff(laz.first_byte[k0 : k1 + 2])
        table = [(int(c), int(s)) for c, s in zip(counts, sizes, strict=True)]
        if self._threads:
            try:
                lazrs.decompress_points_with_chunk_table(data, laz.record_data, out, table)
            except lazrs.LazrsError:
                pass  # decompressed chunk by chunk below, to name the damaged one
            else:
                return
        item = self._dtype.itemsize
        for k, (c, _s) in enumerate(table, start=k0):
            pa, pb = int(laz.first_point[k]) - p0, int(laz.first_point[k + 1]) - p0
            ba, bb = int(laz.first_byte[k]) - b0, int(laz.first_byte[k + 1]) - b0
            try:
                lazrs.decompress_points_with_chunk_table(
                    data[ba:bb], laz.record_data, out[pa * item : pb * item], [table[k - k0]]
                )
            except lazrs.LazrsError as err:
                msg = (
                    f"{self.path}: {points_text(pa + p0, pb + p0 - 1)} (LAZ chunk {k + 1}, bytes "
                    f"{ba + b0}..{bb + b0 - 1}, {c} points) cannot be decompressed ({err}); "
                    "the file is corrupt: copy it again"
                )
                raise InputError(msg) from err

    def close(self) -> None:
        """Close the file."""
        self._tail = None
        self._fh.close()

    def __enter__(self) -> LasPointReader:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()


def read_las_points(
    path: Path, start: int, count: int, *, laz_threads: bool = True
) -> laspy.ScaleAwarePointRecord:
    """Read ``count`` points from point index ``start`` of a LAS/LAZ file.

    Parameters
    ----------
    path : Path
        ``.las`` or ``.laz`` file (LAZ: the LAZ chunks holding the run are decompressed).
    start : int
        Index of the first point (0-based).
    count : int
        Number of points, >= 0; ``start + count`` must not exceed the point count.
    laz_threads : bool
        See `LasPointReader`.

    Returns
    -------
    laspy.ScaleAwarePointRecord
        The points as stored, as `iter_las_chunks` gives them.

    Raises
    ------
    InputError
        Missing or unreadable file, a range beyond the file's points, a truncated or
        corrupt file.
    """
    with LasPointReader(path, laz_threads=laz_threads) as reader:
        return reader.read(start, count)
