"""LAS/LAZ point clouds, read and written in chunks (laspy; LAZ through lazrs).

Reading: `las_info` reads the header only; `iter_las_chunks` streams the points as
``laspy.ScaleAwarePointRecord`` chunks (``laspy.open(...).chunk_iterator``);
`read_las_points` / `LasPointReader` read any run of points on their own (``seek``
then ``read_points``; LAZ seeks through its chunk table), so that separate processes
can each read their own part of one file.

GPS time: with the global-encoding bit "adjusted standard GPS time" set
(``gps_time_type == "adjusted_standard"``), ``gps_time`` is GPS time - 1e9 s
(`kinsync.io.passes.ADJUSTED_GPS_OFFSET_S`); otherwise it is GPS seconds of week
(``"week"``). These readers return ``gps_time`` as stored; the caller converts.

Writing: `LasChunkWriter` writes chunks whose x, y, z are replaced by new float64
coordinates (e.g. georeferenced ECEF), every other dimension carried through byte for
byte, with the input header's point format, VLRs, EVLRs and extra dimensions, new
scales and offsets, and the output CRS. The file appears only when complete.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Iterator
from contextlib import ExitStack, suppress
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import Any, BinaryIO, Literal, cast

import laspy
import numpy as np
import pyproj
from laspy.vlrs.vlrlist import VLRList
from numba import njit

from kinsync._typing import ArrayLike, FloatArray
from kinsync.errors import InputError
from kinsync.io.atomic import atomic_path
from kinsync.io.sbet import SECONDS_PER_WEEK
from kinsync.io.trajectory import TimeScale

__all__ = [
    "ADJUSTED_GPS_OFFSET_S",
    "LasChunkWriter",
    "LasInfo",
    "LasPointReader",
    "iter_las_chunks",
    "las_end_times",
    "las_info",
    "las_time_offset_s",
    "read_las_points",
    "scaled_coordinates",
    "store_coordinates",
]

_CRS_VLR_NAMES = (
    "WktCoordinateSystemVlr",
    "GeoKeyDirectoryVlr",
    "GeoAsciiParamsVlr",
    "GeoDoubleParamsVlr",
)


_INT32_MAX = float(np.iinfo(np.int32).max)


def _store_scaled_loop(
    values: FloatArray,
    offset: float,
    scale: float,
    out: np.ndarray[Any, Any],
    mask: np.ndarray[Any, Any] | None,
) -> int:
    """``out[i] = rint((values[i] - offset) / scale)`` as int32 where ``mask`` (or everywhere).

    Returns the index of the first value that is not finite or does not fit in int32
    (``out`` is then incomplete), or -1. The same arithmetic as
    ``np.round((v - offset) / scale)`` (round half to even).
    """
    for i in range(values.shape[0]):
        if mask is not None and not mask[i]:
            continue
        q = np.rint((values[i] - offset) / scale)
        if not (abs(q) <= _INT32_MAX):  # also catches NaN
            return i
        out[i] = np.int32(q)
    return -1


_store_scaled = cast(Callable[..., int], njit(cache=True, nogil=True)(_store_scaled_loop))


def store_coordinates(
    array: np.ndarray[Any, Any],
    xyz: FloatArray,
    offsets: tuple[float, float, float],
    scales: tuple[float, float, float],
    mask: np.ndarray[Any, Any] | None = None,
) -> int:
    """Store coordinates as the LAS integers ``X, Y, Z`` of a point array, in place.

    Parameters
    ----------
    array : structured ndarray, shape (N,)
        Point records (``ScaleAwarePointRecord.array``) with int32 fields X, Y, Z.
    xyz : ndarray, shape (N, 3)
        Coordinates (units of the output CRS) to store.
    offsets, scales : tuple of 3 float
        The LAS header's offsets and scales the integers are meant for.
    mask : ndarray of bool, shape (N,), optional
        Store only these points; the others keep their integers.

    Returns
    -------
    int
        Index of the first coordinate that is not finite or out of the int32 range for
        this offset and scale (nothing stored from there on in that axis), or -1.
    """
    first_bad = -1
    for j, name in enumerate(("X", "Y", "Z")):
        i = _store_scaled(xyz[:, j], float(offsets[j]), float(scales[j]), array[name], mask)
        if i >= 0 and (first_bad < 0 or i < first_bad):
            first_bad = i
    return first_bad


def _scale_into_loop(
    X: np.ndarray[Any, Any],
    Y: np.ndarray[Any, Any],
    Z: np.ndarray[Any, Any],
    scales: FloatArray,
    offsets: FloatArray,
    out: FloatArray,
) -> None:
    for i in range(X.shape[0]):
        out[i, 0] = X[i] * scales[0] + offsets[0]
        out[i, 1] = Y[i] * scales[1] + offsets[1]
        out[i, 2] = Z[i] * scales[2] + offsets[2]


_scale_into = cast(Callable[..., None], njit(cache=True, nogil=True)(_scale_into_loop))


def scaled_coordinates(
    array: np.ndarray[Any, Any], scales: ArrayLike, offsets: ArrayLike
) -> FloatArray:
    """x, y, z of LAS point records as one (N, 3) float64 array (integers × scale + offset).

    Parameters
    ----------
    array : structured ndarray, shape (N,)
        Point records (``ScaleAwarePointRecord.array``) with int32 fields X, Y, Z.
    scales, offsets : array_like, shape (3,)
        The header's scales and offsets.

    Returns
    -------
    ndarray, shape (N, 3)
        One pass over the stored integers, without laspy's per-dimension copies; the
        same values as ``np.column_stack([record.x, record.y, record.z])``.
    """
    out = np.empty((array.shape[0], 3))
    _scale_into(
        array["X"],
        array["Y"],
        array["Z"],
        np.asarray(scales, dtype=np.float64),
        np.asarray(offsets, dtype=np.float64),
        out,
    )
    return out


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
        The CRS as WKT, or None when the file has none (or one pyproj cannot parse).
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


def _suffix(path: Path) -> str:
    suffix = path.suffix.lower()
    if suffix not in (".las", ".laz"):
        msg = f"{path}: unknown point cloud type {path.suffix!r}; use .las or .laz"
        raise InputError(msg)
    return suffix


_LAZ_BACKEND = next(
    (b for b in (laspy.LazBackend.LazrsParallel, laspy.LazBackend.Lazrs) if b.is_available()),
    laspy.LazBackend.Lazrs,
)
"""lazrs with its thread pool where available: LAZ chunks (de)compress in parallel."""


def _open_reader(path: Path) -> Any:
    _suffix(path)
    try:
        return laspy.open(path, laz_backend=_LAZ_BACKEND)
    except FileNotFoundError as err:
        msg = f"{path}: file not found"
        raise InputError(msg) from err
    except (laspy.errors.LaspyException, OSError, ValueError) as err:
        msg = f"{path}: cannot read as LAS/LAZ ({err}); check that the file is complete"
        raise InputError(msg) from err


ADJUSTED_GPS_OFFSET_S = 1.0e9
"""LAS "adjusted standard GPS time" is GPS time minus this (s)."""


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
            "needs a time per point"
        )
        raise InputError(msg)
    if info.gps_time_type == "adjusted_standard":
        if traj_scale == "week":
            msg = (
                f"{path}: the points carry adjusted standard GPS time, the trajectory GPS "
                "seconds of week; give --gps-week so that kinsync can put both on GPS time"
            )
            raise InputError(msg)
        return ADJUSTED_GPS_OFFSET_S
    if traj_scale == "gps":
        if gps_week is None:
            msg = (
                f"{path}: the points carry GPS seconds of week, the trajectory GPS time; "
                "give --gps-week so that kinsync can put both on GPS time"
            )
            raise InputError(msg)
        return gps_week * SECONDS_PER_WEEK
    return 0.0


def las_info(path: Path) -> LasInfo:
    """Read the header of a LAS/LAZ file (no points).

    Raises
    ------
    InputError
        Missing file, unknown suffix, unreadable header.
    """
    path = Path(path)
    with _open_reader(path) as reader:
        header = reader.header
        try:
            crs = header.parse_crs()
        except (pyproj.exceptions.CRSError, laspy.errors.LaspyException, ValueError):
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

    Two points are read (LAZ: the last one decompresses its LAZ chunk only); None for a
    file without points.

    Raises
    ------
    InputError
        Missing or unreadable file, a point format without ``gps_time``, a truncated file.
    """
    with LasPointReader(path) as reader:
        if reader.point_count == 0:
            return None
        if "gps_time" not in reader.point_format.dimension_names:
            msg = f"{reader.path}: point format {reader.point_format.id} has no gps_time"
            raise InputError(msg)
        first = float(reader.read(0, 1).array["gps_time"][0])
        last = float(reader.read(reader.point_count - 1, 1).array["gps_time"][0])
    return first, last


def iter_las_chunks(path: Path, chunk_points: int) -> Iterator[laspy.ScaleAwarePointRecord]:
    """Stream the points of a LAS/LAZ file in chunks of at most ``chunk_points``.

    Parameters
    ----------
    path : Path
        ``.las`` or ``.laz`` file.
    chunk_points : int
        Points per chunk, >= 1.

    Yields
    ------
    laspy.ScaleAwarePointRecord
        Points as stored (``x, y, z`` scaled, in the file's frame; ``gps_time`` on the
        file's time scale, see `las_info`).

    Raises
    ------
    InputError
        Missing file, unknown suffix, unreadable or truncated file.
    """
    path = Path(path)
    if chunk_points < 1:
        msg = f"{path}: chunk_points must be >= 1, got {chunk_points}"
        raise InputError(msg)
    with _open_reader(path) as reader:
        try:
            yield from reader.chunk_iterator(chunk_points)
        except (laspy.errors.LaspyException, OSError, ValueError) as err:
            msg = f"{path}: cannot read the points ({err}); check that the file is complete"
            raise InputError(msg) from err


class LasPointReader:
    """Read runs of points of one LAS/LAZ file by position, keeping the file open.

    A run that starts where the previous one ended is read on without seeking, so
    reading a file in order costs no more than `iter_las_chunks`; any other run seeks
    (LAZ: through its chunk table, decompressing from the start of the LAZ chunk that
    holds the first point). Use as a context manager, or call `close`.

    Parameters
    ----------
    path : Path
        ``.las`` or ``.laz`` file.
    laz_threads : bool
        Decompress LAZ with lazrs's thread pool (default); False decompresses in the
        calling thread, for processes that are themselves run in parallel.

    Raises
    ------
    InputError
        Missing file, unknown suffix, unreadable header.
    """

    def __init__(self, path: Path, *, laz_threads: bool = True) -> None:
        self.path = Path(path)
        backend = _LAZ_BACKEND if laz_threads else laspy.LazBackend.Lazrs
        _suffix(self.path)
        try:
            self._reader: Any = laspy.open(self.path, laz_backend=backend)
        except FileNotFoundError as err:
            msg = f"{self.path}: file not found"
            raise InputError(msg) from err
        except (laspy.errors.LaspyException, OSError, ValueError) as err:
            msg = f"{self.path}: cannot read as LAS/LAZ ({err}); check that the file is complete"
            raise InputError(msg) from err
        self.point_count = int(self._reader.header.point_count)
        self.point_format = self._reader.header.point_format
        self._position = 0

    def read(self, start: int, count: int) -> laspy.ScaleAwarePointRecord:
        """Read ``count`` points from point index ``start`` (see `read_las_points`)."""
        if start < 0 or count < 0 or start + count > self.point_count:
            msg = (
                f"{self.path}: points {start}..{start + count - 1} requested, the file holds "
                f"{self.point_count} points"
            )
            raise InputError(msg)
        try:
            if start != self._position:
                self._reader.seek(start)
                self._position = start
            points = self._reader.read_points(count)
        except (laspy.errors.LaspyException, OSError, ValueError) as err:
            self._position = -1  # unknown: seek before the next read
            msg = (
                f"{self.path}: cannot read points {start}..{start + count - 1} ({err}); "
                "check that the file is complete"
            )
            raise InputError(msg) from err
        self._position += len(points)
        if len(points) != count:
            msg = (
                f"{self.path}: points {start}..{start + count - 1}: only {len(points)} could "
                "be read; the file is truncated"
            )
            raise InputError(msg)
        return points

    def close(self) -> None:
        """Close the file."""
        self._reader.close()

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
        ``.las`` or ``.laz`` file (LAZ: seeking decompresses from the start of the LAZ
        chunk holding ``start``).
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
        Missing or unreadable file, a range beyond the file's points, a truncated file.
    """
    with LasPointReader(path, laz_threads=laz_threads) as reader:
        return reader.read(start, count)


class LasChunkWriter:
    """Write a LAS/LAZ file chunk by chunk with new x, y, z; everything else carried.

    Use as a context manager. The file is written under a temporary name beside
    ``path`` (`kinsync.io.atomic.atomic_path`) and renamed onto ``path`` only when the
    ``with`` block ends without an exception; otherwise nothing is left behind.

    Parameters
    ----------
    path : Path
        Output file; ``.laz`` is compressed (lazrs), ``.las`` is not.
    template_header : laspy.LasHeader
        Header of the input: its version, point format (extra dimensions included),
        VLRs and EVLRs are copied.
    crs : pyproj.CRS or None
        CRS of the output coordinates, written as a WKT VLR (point formats 6-10) or
        GeoTIFF keys (older formats), replacing any CRS of the template. None keeps the
        template's CRS records.
    coordinate_offset_m : tuple of float
        x, y, z offsets (m, output CRS units) stored in the header. Choose them near
        the data (e.g. the rounded first point in ECEF) so that integers stay small.
    scale_m : float or tuple of 3 float
        Resolution of the stored coordinates (output CRS units, e.g. m), one for all
        axes or x, y, z; 1e-4 m or finer for ECEF. Coordinates must lie within
        ``scale_m * 2**31`` of the offset.

    Raises
    ------
    InputError
        Unknown suffix, non-positive scale, non-finite offsets, a missing output folder.
    """

    def __init__(
        self,
        path: Path,
        template_header: laspy.LasHeader,
        crs: pyproj.CRS | None,
        coordinate_offset_m: tuple[float, float, float],
        scale_m: float | tuple[float, float, float],
    ) -> None:
        self.path = Path(path)
        self._compress = _suffix(self.path) == ".laz"
        scales = np.broadcast_to(np.asarray(scale_m, dtype=np.float64), (3,)).copy()
        if not (np.all(np.isfinite(scales)) and np.all(scales > 0.0)):
            msg = f"{self.path}: scale_m must be positive numbers, got {scale_m}"
            raise InputError(msg)
        offsets = np.asarray(coordinate_offset_m, dtype=np.float64)
        if offsets.shape != (3,) or not np.all(np.isfinite(offsets)):
            msg = f"{self.path}: coordinate_offset_m must be 3 finite numbers, got {offsets}"
            raise InputError(msg)
        header = copy.deepcopy(template_header)
        header.offsets = offsets
        header.scales = scales
        if crs is not None:
            if header.evlrs is not None:
                for name in _CRS_VLR_NAMES:
                    with suppress(IndexError):
                        header.evlrs.extract(name)
            header.add_crs(crs)
        self.header = header
        self.points_written = 0
        self._stack: ExitStack | None = None
        self._writer: Any = None

    def __enter__(self) -> LasChunkWriter:
        stack = ExitStack()
        tmp = stack.enter_context(atomic_path(self.path))
        try:
            fh: BinaryIO = stack.enter_context(tmp.open("wb"))
            if self._compress:
                self._writer = laspy.LasWriter(
                    fh,
                    self.header,
                    do_compress=True,
                    laz_backend=_LAZ_BACKEND,
                    closefd=False,
                )
            else:
                self._writer = laspy.LasWriter(fh, self.header, do_compress=False, closefd=False)
        except BaseException:
            stack.close()
            raise
        self._stack = stack
        return self

    def write(
        self,
        chunk: laspy.ScaleAwarePointRecord,
        x: FloatArray,
        y: FloatArray,
        z: FloatArray,
    ) -> None:
        """Append a chunk with its coordinates replaced (the chunk itself is not changed).

        Parameters
        ----------
        chunk : laspy.ScaleAwarePointRecord
            Points of the template's point format; every dimension but X, Y, Z is
            written unchanged.
        x, y, z : ndarray, shape (M,)
            New coordinates (output CRS units, e.g. m), float64, M = ``len(chunk)``.

        Raises
        ------
        InputError
            Outside the ``with`` block, another point format, mismatched lengths,
            non-finite coordinates, or coordinates beyond the integer range of the
            chosen scale and offset.
        """
        self._check_chunk(chunk, "write")
        n = len(chunk)
        array = chunk.array.copy()
        for name, values, offset, scale in zip(
            ("X", "Y", "Z"), (x, y, z), self.header.offsets, self.header.scales, strict=True
        ):
            v = np.asarray(values, dtype=np.float64)
            if v.shape != (n,):
                msg = f"{self.path}: {name.lower()} has shape {v.shape}, the chunk {n} points"
                raise InputError(msg)
            i = _store_scaled(v, float(offset), float(scale), array[name], None)
            if i >= 0:
                msg = (
                    f"{self.path}: point {self.points_written + i}: {name.lower()}="
                    f"{v[i]!r} cannot be stored with offset {offset} and scale {scale}; "
                    "give finite coordinates and an offset near the data (or a coarser scale)"
                )
                raise InputError(msg)
        self._write_points(array)

    def write_stored(self, chunk: laspy.ScaleAwarePointRecord) -> None:
        """Append a chunk whose X, Y, Z already hold this writer's integers.

        For points stored with `store_coordinates` and this writer's
        ``header.offsets`` and ``header.scales``: nothing is converted or copied.

        Raises
        ------
        InputError
            Outside the ``with`` block, another point format, a write error.
        """
        self._check_chunk(chunk, "write_stored")
        self._write_points(chunk.array)

    def _check_chunk(self, chunk: laspy.ScaleAwarePointRecord, method: str) -> None:
        if self._writer is None or self._stack is None:
            msg = f"{self.path}: LasChunkWriter.{method} called outside its 'with' block"
            raise InputError(msg)
        if chunk.point_format != self.header.point_format:
            msg = (
                f"{self.path}: chunk has point format {chunk.point_format.id} with "
                f"dimensions {list(chunk.point_format.dimension_names)}, the output has "
                f"{self.header.point_format.id}; write chunks of the template's file"
            )
            raise InputError(msg)

    def _write_points(self, array: np.ndarray[Any, Any]) -> None:
        record = laspy.ScaleAwarePointRecord(
            array, self.header.point_format, self.header.scales, self.header.offsets
        )
        try:
            self._writer.write_points(record)
        except (laspy.errors.LaspyException, OSError) as err:
            msg = f"{self.path}: cannot write points ({err})"
            raise InputError(msg) from err
        self.points_written += len(array)

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        stack, self._stack = self._stack, None
        writer, self._writer = self._writer, None
        if stack is None:
            return
        try:
            if exc_type is None:
                evlrs = self.header.evlrs
                if evlrs is not None and len(evlrs) > 0 and self.header.version.minor >= 4:
                    writer.write_evlrs(VLRList(evlrs))
            writer.close()
        except BaseException as err:
            stack.__exit__(type(err), err, err.__traceback__)
            raise
        stack.__exit__(exc_type, exc, tb)
