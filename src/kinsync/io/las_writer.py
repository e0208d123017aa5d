"""LAS/LAZ output written in chunks: new x, y, z, everything else carried (laspy + lazrs).

`LasChunkWriter` writes chunks whose x, y, z are replaced by new float64 coordinates
(e.g. georeferenced ECEF), every other dimension carried through byte for byte, with
the input header's point format, VLRs, EVLRs and extra dimensions, new scales and
offsets, and the output CRS; its Generating Software is ``kinsync <version>`` and its
creation date today's (UTC), its System Identifier the input's. A LAS 1.0 input, which
laspy cannot write, gives LAS 1.2 (said in its ``notes``). Not carried, and said so in
its ``notes`` (`las_output_notes`): waveform data packets (the wave packet fields of the
points are zeroed and the header's waveform flags, pointer and descriptors cleared, so
that nothing points to data that is not there) and a COPC index (it addresses the
input's LAZ chunks). The min and max of each Extra Bytes descriptor that declares them
are those of the points written (`kinsync.io.las_extra_bytes`). Given a kinsync
record, it holds it in a VLR in place of the input's (`kinsync.io.point_provenance`).
The file appears only when complete.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Mapping
from contextlib import ExitStack
from pathlib import Path
from types import TracebackType
from typing import Any, BinaryIO

import laspy
import numpy as np
import pyproj
from laspy.vlrs.vlrlist import VLRList

from kinsync._typing import FloatArray
from kinsync.errors import InputError
from kinsync.io.atomic import atomic_path, cannot_write_error, finish_then_publish
from kinsync.io.las_coordinates import store_scaled
from kinsync.io.las_crs import set_las_crs
from kinsync.io.las_extra_bytes import ExtraBytesRange
from kinsync.io.las_header import (
    las_suffix,
    set_global_encoding_bit,
    stamp_kinsync_header,
    writable_las_version,
)
from kinsync.io.point_provenance import set_las_record

__all__ = ["ErrorKeepingFile", "LasChunkWriter", "las_output_notes"]


_LAZ_BACKEND = next(
    (b for b in (laspy.LazBackend.LazrsParallel, laspy.LazBackend.Lazrs) if b.is_available()),
    laspy.LazBackend.Lazrs,
)
"""lazrs with its thread pool where available: LAZ chunks compress in parallel."""


class ErrorKeepingFile:
    """A binary file that keeps the `OSError` its ``write`` raised (a full disk).

    lazrs reports a failed write as a bare ``LazrsError: IoError: Failed to call
    write``, the `OSError` lost: given this file instead of ``fh``, the error is kept in
    `error` for the message (`kinsync.io.atomic.cannot_write_error`).

    Parameters
    ----------
    fh : BinaryIO
        The open file; every attribute but ``write`` is its own.

    Attributes
    ----------
    error : OSError or None
        The last error of ``write``; None while every write succeeded.
    """

    def __init__(self, fh: BinaryIO) -> None:
        self._fh = fh
        self.error: OSError | None = None

    def write(self, data: Any) -> int:
        """Write ``data`` (bytes-like) to the file, keeping an `OSError` before raising it."""
        try:
            return self._fh.write(data)
        except OSError as err:
            self.error = err
            raise

    def __getattr__(self, name: str) -> Any:
        return getattr(self._fh, name)


def las_output_notes(template_header: laspy.LasHeader) -> tuple[str, ...]:
    """What a `LasChunkWriter` with this template will not carry (its ``notes``).

    Parameters
    ----------
    template_header : laspy.LasHeader
        Header of the input (`kinsync.io.las_header.las_header`); not changed.

    Returns
    -------
    tuple of str
        One sentence per thing not carried (waveform data packets, a COPC index) or
        changed (a LAS 1.0 version, which is written as LAS 1.2).
    """
    return _writable_header(copy.deepcopy(template_header))[1]


def _writable_header(header: laspy.LasHeader) -> tuple[bool, tuple[str, ...]]:
    """`_drop_uncarried`, then a version laspy writes and kinsync's stamp; the notes."""
    zero_wave, notes = _drop_uncarried(header)
    version = writable_las_version(header)
    stamp_kinsync_header(header)
    return zero_wave, notes + ((version,) if version else ())


_WAVE_FIELDS = (
    "wavepacket_index",
    "wavepacket_offset",
    "wavepacket_size",
    "return_point_wave_location",
    "x_t",
    "y_t",
    "z_t",
)
"""Per-point wave packet fields of point formats 4, 5, 9 and 10."""


def _is_waveform_record(vlr: Any) -> bool:
    """A wave packet descriptor (VLR 100-354) or the waveform data packets (EVLR 65535)."""
    return bool(
        vlr.user_id == "LASF_Spec" and (100 <= vlr.record_id <= 354 or vlr.record_id == 65535)
    )


def _remove_records(records: Any, drop: Callable[[Any], bool]) -> int:
    """Remove the VLRs for which ``drop`` is true from a VLR list, in place; how many."""
    if records is None:
        return 0
    doomed = [i for i, vlr in enumerate(records) if drop(vlr)]
    for i in reversed(doomed):
        del records[i]
    return len(doomed)


def _drop_uncarried(header: laspy.LasHeader) -> tuple[bool, tuple[str, ...]]:
    """Remove from a header what a rewritten file cannot carry; say what went.

    Waveform data packets (LAS 1.3/1.4 internal record, or an external ``.wdp`` file)
    are not carried: they are not copied, the header's waveform flags and pointer are
    cleared and the wave packet descriptors removed (the points' wave packet fields are
    zeroed by the writer). A COPC index (``copc`` VLR and hierarchy EVLR) is removed:
    it addresses the input's LAZ chunks. Returns whether the points' wave packet
    fields must be zeroed, and one note per thing dropped.
    """
    notes: list[str] = []
    encoding = header.global_encoding
    internal = bool(encoding.waveform_data_packets_internal)
    external = bool(encoding.waveform_data_packets_external)
    start = int(getattr(header, "start_of_waveform_data_packet_record", 0) or 0)
    n_records = _remove_records(header.vlrs, _is_waveform_record)
    n_records += _remove_records(header.evlrs, _is_waveform_record)
    waveform = bool(internal or external or start or n_records)
    if waveform:
        where = []
        if internal or start:
            where.append(f"internal, from byte {start}" if start else "internal")
        if external:
            where.append("in an external .wdp file")
        notes.append(
            f"waveform data packets ({'; '.join(where) or 'descriptors only'}) are not "
            "carried: kinsync georeferences the points, not their waveforms; the output's "
            "header has no waveform flags, pointer or descriptors and its points' wave "
            "packet fields are 0"
        )
        waveform_bits = encoding.WAVEFORM_INTERNAL_MASK | encoding.WAVEFORM_EXTERNAL_MASK
        set_global_encoding_bit(header, waveform_bits, on=False)
        header.start_of_waveform_data_packet_record = 0
    if _remove_records(header.vlrs, lambda v: v.user_id == "copc") + _remove_records(
        header.evlrs, lambda v: v.user_id == "copc"
    ):
        notes.append(
            "its COPC index is not carried: the output is a plain LAS/LAZ in the input's "
            "point order (the octree would not match the georeferenced points); re-index it "
            "(e.g. PDAL writers.copc, untwine) if COPC is needed"
        )
    names = set(header.point_format.dimension_names)
    return waveform and names.issuperset(_WAVE_FIELDS), tuple(notes)


class LasChunkWriter:
    """Write a LAS/LAZ file chunk by chunk with new x, y, z; everything else carried.

    Everything but what a rewritten file cannot carry: waveform data packets (the
    points' wave packet fields are written as 0, the header's waveform flags, pointer
    and descriptors cleared) and a COPC index (the output is a plain LAS/LAZ). What
    was dropped is said in `notes`.

    Use as a context manager. The file is written under a temporary name beside
    ``path`` (`kinsync.io.atomic.atomic_path`) and renamed onto ``path`` only when the
    ``with`` block ends without an exception; otherwise nothing is left behind.

    Parameters
    ----------
    path : Path
        Output file; ``.laz`` is compressed (lazrs), ``.las`` is not.
    template_header : laspy.LasHeader
        Header of the input (`kinsync.io.las_header.las_header`): its version (LAS 1.2
        for 1.0), point format (extra dimensions included), System Identifier, VLRs and
        EVLRs are copied.
    crs : pyproj.CRS or None
        CRS of the output coordinates, written as a WKT VLR (WKT1 where it represents
        the CRS; point formats 6-10) or GeoTIFF keys (older formats), replacing any CRS
        of the template. None keeps the template's CRS records.
    coordinate_offset_m : tuple of float
        x, y, z offsets (m, output CRS units) stored in the header. Choose them near
        the data (e.g. the rounded first point in ECEF) so that integers stay small.
    scale_m : float or tuple of 3 float
        Resolution of the stored coordinates (output CRS units, e.g. m), one for all
        axes or x, y, z; 1e-4 m or finer for ECEF. Coordinates must lie within
        ``scale_m * 2**31`` of the offset.
    record : mapping, optional
        The kinsync record of the points (`kinsync.io.point_provenance.point_document`),
        written in a VLR (`kinsync.io.point_provenance.set_las_record`) that replaces the
        template's. None keeps the template's records as they are.

    Attributes
    ----------
    notes : tuple of str
        What of the template is not carried (waveform data, a COPC index) or changed
        (LAS 1.0 written as 1.2), one sentence each; empty when everything is kept.
    crs_note : str or None
        The warning when ``crs`` could not be declared in WKT1 and is in WKT2-2019
        (`kinsync.io.las_crs.set_las_crs`), naming the file; else None.
    record_notes : tuple of str
        What a LAS 1.2/1.3 VLR had no room for of ``record`` (naming the file); empty
        when the record was written whole.

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
        record: Mapping[str, Any] | None = None,
    ) -> None:
        self.path = Path(path)
        self._compress = las_suffix(self.path) == ".laz"
        scales = np.broadcast_to(np.asarray(scale_m, dtype=np.float64), (3,)).copy()
        if not (np.all(np.isfinite(scales)) and np.all(scales > 0.0)):
            msg = f"{self.path}: scale_m must be positive numbers, got {scale_m}"
            raise InputError(msg)
        offsets = np.asarray(coordinate_offset_m, dtype=np.float64)
        if offsets.shape != (3,) or not np.all(np.isfinite(offsets)):
            msg = f"{self.path}: coordinate_offset_m must be 3 finite numbers, got {offsets}"
            raise InputError(msg)
        header = copy.deepcopy(template_header)
        self._zero_wave, self.notes = _writable_header(header)
        header.offsets = offsets
        header.scales = scales
        self.crs_note = None if crs is None else set_las_crs(header, crs, self.path)
        self.record_notes = () if record is None else set_las_record(header, record, self.path)
        self.header = header
        self._extra_range = ExtraBytesRange(header)
        self.points_written = 0
        self._stack: ExitStack | None = None
        self._writer: Any = None
        self._file: ErrorKeepingFile | None = None

    def __enter__(self) -> LasChunkWriter:
        stack = ExitStack()
        tmp = stack.enter_context(atomic_path(self.path))
        try:
            fh: BinaryIO = stack.enter_context(tmp.open("wb"))
            self._file = ErrorKeepingFile(fh)
            if self._compress:
                self._writer = laspy.LasWriter(
                    self._file,
                    self.header,
                    do_compress=True,
                    laz_backend=_LAZ_BACKEND,
                    closefd=False,
                )
            else:
                self._writer = laspy.LasWriter(fh, self.header, do_compress=False, closefd=False)
        except BaseException as err:
            # Unwind with the error, so that atomic_path removes the temporary: a plain
            # close would rename the unfinished file onto the output.
            stack.__exit__(type(err), err, err.__traceback__)
            failed = self._write_failure(err)
            if failed is not None:
                raise cannot_write_error(self.path, failed) from err
            if isinstance(err, Exception):  # laspy's errors on a damaged template vary
                msg = (
                    f"{self.path}: cannot write the header and VLRs taken from the input "
                    f"({type(err).__name__}: {err}): they are damaged, or of a kind laspy "
                    "cannot write; rewrite the input with another LAS tool (as LAS 1.2 or "
                    "1.4) and run again"
                )
                raise InputError(msg) from err
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
            i = store_scaled(v, float(offset), float(scale), array[name], None)
            if i >= 0:
                msg = (
                    f"{self.path}: point {self.points_written + i + 1} of the output: "
                    f"{name.lower()}="
                    f"{v[i]!r} cannot be stored with offset {offset} and scale {scale}; "
                    "give finite coordinates and an offset near the data (or a coarser scale)"
                )
                raise InputError(msg)
        self._write_points(array)

    def write_stored(self, chunk: laspy.ScaleAwarePointRecord) -> None:
        """Append a chunk whose X, Y, Z already hold this writer's integers.

        For points stored with `store_coordinates` and this writer's
        ``header.offsets`` and ``header.scales``: nothing is converted or copied (wave
        packet fields not carried are zeroed in place, see `notes`).

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
        if self._zero_wave:
            for name in _WAVE_FIELDS:
                array[name] = 0
        record = laspy.ScaleAwarePointRecord(
            array, self.header.point_format, self.header.scales, self.header.offsets
        )
        try:
            self._writer.write_points(record)
        except Exception as err:
            failed = self._write_failure(err)
            if failed is not None:
                raise cannot_write_error(self.path, failed, "cannot write points") from err
            if isinstance(err, laspy.errors.LaspyException):
                msg = f"{self.path}: cannot write points ({err})"
                raise InputError(msg) from err
            raise
        self._extra_range.grow(array)
        self.points_written += len(array)

    def _write_failure(self, err: BaseException) -> OSError | None:
        """The `OSError` behind ``err``: its own, or the one lazrs reported without it."""
        if self._file is not None and self._file.error is not None:
            return self._file.error
        return err if isinstance(err, OSError) else None

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

        def finish() -> None:
            try:
                if exc_type is None:
                    evlrs = self.header.evlrs
                    if evlrs is not None and len(evlrs) > 0 and self.header.version.minor >= 4:
                        writer.write_evlrs(VLRList(evlrs))
                self._extra_range.store(writer.header)  # laspy's min/max are wrong
                writer.close()  # a LAZ file's last chunk and chunk table are written here
            except Exception as err:
                if exc_type is not None:  # the file is removed: the first error is the one
                    return
                failed = self._write_failure(err)
                if failed is None:
                    raise
                raise cannot_write_error(self.path, failed) from err

        finish_then_publish(stack, finish, exc_type, exc, tb)
