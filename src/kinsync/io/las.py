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
import math
from collections.abc import Iterator
from contextlib import ExitStack, suppress
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import Any, BinaryIO, Literal

import laspy
import numpy as np
import pyproj
from laspy.vlrs.vlrlist import VLRList

from kinsync._typing import FloatArray
from kinsync.errors import InputError
from kinsync.io.atomic import atomic_path

__all__ = [
    "LasChunkWriter",
    "LasInfo",
    "LasPointReader",
    "iter_las_chunks",
    "las_info",
    "read_las_points",
]

_CRS_VLR_NAMES = (
    "WktCoordinateSystemVlr",
    "GeoKeyDirectoryVlr",
    "GeoAsciiParamsVlr",
    "GeoDoubleParamsVlr",
)


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
    scale_m : float
        Resolution of the stored coordinates (output CRS units, e.g. m); 1e-4 m or
        finer for ECEF. Coordinates must lie within ``scale_m * 2**31`` of the offset.

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
        scale_m: float,
    ) -> None:
        self.path = Path(path)
        self._compress = _suffix(self.path) == ".laz"
        if not (math.isfinite(scale_m) and scale_m > 0.0):
            msg = f"{self.path}: scale_m must be a positive number, got {scale_m}"
            raise InputError(msg)
        offsets = np.asarray(coordinate_offset_m, dtype=np.float64)
        if offsets.shape != (3,) or not np.all(np.isfinite(offsets)):
            msg = f"{self.path}: coordinate_offset_m must be 3 finite numbers, got {offsets}"
            raise InputError(msg)
        header = copy.deepcopy(template_header)
        header.offsets = offsets
        header.scales = np.full(3, float(scale_m))
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
        *,
        reuse_chunk: bool = False,
    ) -> None:
        """Append a chunk with its coordinates replaced.

        Parameters
        ----------
        chunk : laspy.ScaleAwarePointRecord
            Points of the template's point format; every dimension but X, Y, Z is
            written unchanged.
        x, y, z : ndarray, shape (M,)
            New coordinates (output CRS units, e.g. m), float64, M = ``len(chunk)``.
        reuse_chunk : bool
            Write the new X, Y, Z into ``chunk``'s own array instead of a copy (saves a
            copy of every record; the caller must not use ``chunk`` afterwards).

        Raises
        ------
        InputError
            Outside the ``with`` block, another point format, mismatched lengths,
            non-finite coordinates, or coordinates beyond the integer range of the
            chosen scale and offset.
        """
        if self._writer is None or self._stack is None:
            msg = f"{self.path}: LasChunkWriter.write called outside its 'with' block"
            raise InputError(msg)
        if chunk.point_format != self.header.point_format:
            msg = (
                f"{self.path}: chunk has point format {chunk.point_format.id} with "
                f"dimensions {list(chunk.point_format.dimension_names)}, the output has "
                f"{self.header.point_format.id}; write chunks of the template's file"
            )
            raise InputError(msg)
        n = len(chunk)
        array = chunk.array if reuse_chunk else chunk.array.copy()
        for name, values, offset, scale in zip(
            ("X", "Y", "Z"), (x, y, z), self.header.offsets, self.header.scales, strict=True
        ):
            v = np.asarray(values, dtype=np.float64)
            if v.shape != (n,):
                msg = f"{self.path}: {name.lower()} has shape {v.shape}, the chunk {n} points"
                raise InputError(msg)
            ints = np.round((v - offset) / scale)
            bad = ~np.isfinite(ints) | (np.abs(ints) > np.iinfo(np.int32).max)
            if np.any(bad):
                i = int(np.flatnonzero(bad)[0])
                msg = (
                    f"{self.path}: point {self.points_written + i}: {name.lower()}="
                    f"{v[i]!r} cannot be stored with offset {offset} and scale {scale}; "
                    "give finite coordinates and an offset near the data (or a coarser scale)"
                )
                raise InputError(msg)
            array[name] = ints.astype(np.int32)
        record = laspy.ScaleAwarePointRecord(
            array, self.header.point_format, self.header.scales, self.header.offsets
        )
        try:
            self._writer.write_points(record)
        except (laspy.errors.LaspyException, OSError) as err:
            msg = f"{self.path}: cannot write points ({err})"
            raise InputError(msg) from err
        self.points_written += n

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
