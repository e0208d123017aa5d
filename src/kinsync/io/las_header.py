"""LAS/LAZ headers, checked against the file before laspy parses them.

laspy reads past the end of its header bytes without complaint (a VLR count of 2**31
is two billion empty VLRs) and raises whatever its parsing meets in damaged bytes;
`read_las_header` checks the header's sizes, VLRs and EVLRs against the file first, and
the header's point count against the file (an uncompressed file's size, a LAZ file's
chunk table and chunks), so that a truncated or corrupt file is an `InputError` naming
what is missing, and a count below the points the file holds one naming both counts.
A LAS 1.4 header with the 64-bit count 0 takes the legacy 32-bit count (laspy reads
only the 64-bit one); scale factors must be finite and non-zero, offsets finite.
"""

from __future__ import annotations

import datetime as dt
import io
import math
import os
import struct
from pathlib import Path
from typing import BinaryIO

import laspy
from laspy.vlrs.vlrlist import VLRList

from kinsync.errors import InputError
from kinsync.io.laz_chunks import LazChunks, laz_chunks, point_count_fields, points_text
from kinsync.io.provenance import run_time_utc, software

__all__ = [
    "creation_date",
    "generating_software",
    "las_header",
    "las_suffix",
    "open_las_file",
    "read_las_header",
    "read_las_layout",
    "set_global_encoding_bit",
    "stamp_kinsync_header",
    "writable_las_version",
]

_LAS_MAX_MINOR = 4  # LAS 1.0 to 1.4
_LAS_HEADER_MIN_BYTES = 227  # LAS 1.0-1.2 header; 1.3 and 1.4 are longer
_LAS_MAX_POINT_FORMAT = 10  # LAS 1.4 point data record formats 0 to 10
_LAZ_FORMAT_BITS = 0x3F  # a LAZ file sets bit 7 (and some writers bit 6) of the format byte
_VLR_HEADER_BYTES = 54
_EVLR_HEADER_BYTES = 60
_GENERATING_SOFTWARE_BYTES = 32
_LOWEST_WRITABLE = ((3, "1.2"), (5, "1.3"), (10, "1.4"))
"""The LAS version a LAS 1.0 header is written as, by point format (up to 3, 5, 10):
laspy cannot write 1.0; 1.2 holds its formats and nearly all software reads it."""


def creation_date() -> dt.date:
    """The creation date of the LAS/LAZ files kinsync writes: today (UTC).

    Or, when the environment sets ``SOURCE_DATE_EPOCH`` (seconds since 1970-01-01
    UTC, the reproducible-builds convention), that time's UTC date: the same inputs
    then give byte-identical outputs on any day (two runs either side of midnight
    differed in their headers). See `kinsync.io.provenance.run_time_utc`.

    Raises
    ------
    InputError
        ``SOURCE_DATE_EPOCH`` set to something other than a whole number of seconds
        within the years 1970-9999.
    """
    return run_time_utc().date()


def generating_software() -> str:
    """The Generating Software of every LAS/LAZ kinsync writes (at most 32 ASCII bytes).

    `kinsync.io.provenance.software`: the version, and the commit from a checkout.
    """
    return software()[:_GENERATING_SOFTWARE_BYTES]


def stamp_kinsync_header(header: laspy.LasHeader) -> None:
    """Mark a header as written by kinsync: Generating Software, creation date.

    Generating Software becomes ``"kinsync <version>"`` and the creation date
    `creation_date` (today, UTC, or ``SOURCE_DATE_EPOCH``'s date); everything else,
    the System Identifier included, is kept.
    """
    header.generating_software = generating_software()
    header.creation_date = creation_date()


def writable_las_version(header: laspy.LasHeader) -> str | None:
    """Give a header laspy cannot write (LAS 1.0) the lowest version that it can.

    LAS 1.0 is read (its point formats 0 and 1 are those of LAS 1.2, and kinsync
    reads its global encoding as LAS 1.2 does), but laspy writes LAS 1.1 to 1.4 only:
    the header becomes LAS 1.2 (1.3 or 1.4 for a point format only they hold), the
    point format and everything else unchanged.

    Returns
    -------
    str or None
        What changed, one sentence (``"it is LAS 1.0, ..."``); None when the version
        is kept.
    """
    old = str(header.version)
    if int(header.version.minor) != 0:
        return None
    pf = int(header.point_format.id)
    new = next(v for top, v in _LOWEST_WRITABLE if pf <= top)
    header.version = laspy.header.Version.from_str(new)
    return (
        f"it is LAS {old}, which kinsync cannot write (its LAS writer, laspy, writes "
        f"LAS 1.1 to 1.4): its LAS/LAZ outputs are LAS {new}, with the same point format "
        f"({pf}), points and records"
    )


def set_global_encoding_bit(header: laspy.LasHeader, mask: int, *, on: bool) -> None:
    """Set (``on``) or clear one bit of the header's global encoding.

    laspy before 2.7 clears a bit with an exclusive or, which sets a bit that was clear:
    its ``global_encoding.wkt = False`` declared WKT in a fresh header, and
    ``gps_time_type = WEEK_TIME`` labelled week times as adjusted standard GPS time.

    Parameters
    ----------
    header : laspy.LasHeader
        The header to change.
    mask : int
        The bit, e.g. ``laspy.header.GlobalEncoding.WKT_MASK``.
    on : bool
        Set the bit (True) or clear it (False).
    """
    encoding = header.global_encoding
    encoding.value = (encoding.value | mask) if on else (encoding.value & ~mask)


def las_suffix(path: Path) -> str:
    """``.las`` or ``.laz`` (lower case); any other suffix is an `InputError`."""
    suffix = path.suffix.lower()
    if suffix not in (".las", ".laz"):
        msg = f"{path}: unknown point cloud type {path.suffix!r}; use .las or .laz"
        raise InputError(msg)
    return suffix


def open_las_file(path: Path) -> io.BufferedReader:
    """Open a ``.las``/``.laz`` file for reading; a missing or unreadable one is an `InputError`."""
    las_suffix(path)
    try:
        return path.open("rb")
    except FileNotFoundError as err:
        msg = f"{path}: file not found"
        raise InputError(msg) from err
    except OSError as err:
        msg = f"{path}: cannot open ({err.strerror or err})"
        raise InputError(msg) from err


_LEGACY_COUNT_AT = 107  # byte of the legacy (32-bit) point count; LAS 1.4's 64-bit one: 247
_WAVEFORM_INTERNAL_MASK = 0b10  # global encoding bit 1: waveform packets in this file


def _resolve_point_count(fh: BinaryIO, header: laspy.LasHeader) -> None:
    """Take the legacy 32-bit point count when a LAS 1.4 header leaves the 64-bit one 0.

    LAS 1.4 (R15) keeps the legacy count whenever it can hold the value, and some
    writers fill only it; laspy reads only the 64-bit count, which read as 0 points.
    PDAL and LAStools fall back to the legacy count, and so does kinsync. When both are
    set, the 64-bit count is the one LAS 1.4 defines; the file's size or its LAZ chunks
    then show whether it is right (`read_las_layout`).
    """
    if header.version.minor < 4:
        return
    fh.seek(_LEGACY_COUNT_AT)
    legacy = int.from_bytes(fh.read(4), "little")
    if int(header.point_count) == 0 and legacy > 0:
        header.point_count = legacy


def _check_scales_offsets(path: Path, header: laspy.LasHeader) -> None:
    """Scale factors must be finite and non-zero, offsets finite.

    A zero scale gives every point the offset (all points on one value), a NaN or
    infinite one no coordinate at all. A negative scale is legal and exact (the
    coordinate is still integer x scale + offset; it mirrors the stored integers), so it
    is read as it is.
    """
    for axis, scale, offset, at in zip(
        "XYZ", header.scales, header.offsets, (131, 139, 147), strict=True
    ):
        if not math.isfinite(float(scale)) or float(scale) == 0.0:
            msg = (
                f"{path}: the header's {axis} scale factor (byte {at}) is {float(scale)!r}; "
                "it must be a finite, non-zero number (e.g. 0.001): fix the header or "
                "export the file again"
            )
            raise InputError(msg)
        if not math.isfinite(float(offset)):
            msg = (
                f"{path}: the header's {axis} offset (byte {at + 24}) is {float(offset)!r}; "
                "it must be a finite number: fix the header or export the file again"
            )
            raise InputError(msg)


def _point_data_end(header: laspy.LasHeader, file_size: int) -> tuple[int, str]:
    """Where an uncompressed file's point data ends (byte) and what follows it.

    The extended VLRs (LAS 1.4) or, in LAS 1.3, the waveform packets stored in the
    file; else the end of the file.
    """
    start = int(header.offset_to_point_data)
    if header.version.minor >= 4 and int(header.number_of_evlrs) > 0:
        return min(file_size, max(start, int(header.start_of_first_evlr))), "extended VLRs"
    waveform_at = int(header.start_of_waveform_data_packet_record)
    if (
        header.version.minor == 3  # LAS 1.3
        and header.global_encoding.value & _WAVEFORM_INTERNAL_MASK
        and start < waveform_at < file_size
    ):
        return waveform_at, "waveform packets"
    return file_size, "the end of the file"


def _check_las_size(path: Path, header: laspy.LasHeader, file_size: int) -> None:
    """An uncompressed file must hold exactly the header's points: else name the difference.

    Fewer whole records than the header says is a truncated file; more is a point count
    that would leave points out (a broken header).
    """
    n = int(header.point_count)
    size = int(header.point_format.size)
    start = int(header.offset_to_point_data)
    complete = max(0, (file_size - start) // size)
    if complete < n:
        held = (
            f"{points_text(0, complete - 1)} {'is' if complete == 1 else 'are'} complete"
            if complete
            else "no point is complete"
        )
        missing = f"{points_text(complete, n - 1)} {'is' if complete == n - 1 else 'are'} missing"
        msg = (
            f"{path}: the header says {n} points of {size} bytes from byte {start}, the file "
            f"ends at byte {file_size}: {held}, {missing}; the file is truncated: copy it again"
        )
        raise InputError(msg)
    end, what = _point_data_end(header, file_size)
    stored = (end - start) // size
    if stored < n:
        msg = (
            f"{path}: the header says {n} points of {size} bytes from byte {start}, but "
            f"its {what} start at byte {end}, inside them; the file is corrupt: export "
            "it again"
        )
        raise InputError(msg)
    if stored > n:
        msg = (
            f"{path}: the header says {n} points, the point data (bytes {start}..{end - 1}, "
            f"up to {what}) holds {stored} points of {size} bytes: {stored - n} would be "
            f"left out; set {point_count_fields(header)} to {stored}, or export the file again"
        )
        raise InputError(msg)


def _check_header_bytes(path: Path, fh: BinaryIO, file_size: int) -> None:
    """The header's sizes and VLR records must fit the file, before laspy parses them.

    laspy reads past the end of its header bytes without complaint (a VLR count of
    2**31 is two billion empty VLRs), so the sizes are checked here first.
    """
    fh.seek(0)
    head = fh.read(_LAS_HEADER_MIN_BYTES)
    if len(head) < _LAS_HEADER_MIN_BYTES or head[:4] != b"LASF":
        what = "does not start with 'LASF'" if head[:4] != b"LASF" else "is too short"
        msg = f"{path}: not a LAS/LAZ file (it {what}); check the file"
        raise InputError(msg)
    major, minor = head[24], head[25]
    if major != 1 or minor > _LAS_MAX_MINOR:  # before laspy reads fields it does not know
        msg = f"{path}: LAS version {major}.{minor} is not supported (1.0 to 1.4)"
        raise InputError(msg)
    format_byte = head[104]
    if format_byte & _LAZ_FORMAT_BITS > _LAS_MAX_POINT_FORMAT:
        msg = (
            f"{path}: point data format {format_byte} (header byte 104) is not a LAS point "
            f"format (0 to {_LAS_MAX_POINT_FORMAT}, plus 128 in a LAZ file); the file is "
            "corrupt or not a LAS/LAZ file"
        )
        raise InputError(msg)
    header_size, data_start, n_vlrs = struct.unpack_from("<HII", head, 94)
    if not _LAS_HEADER_MIN_BYTES <= header_size <= data_start <= file_size:
        msg = (
            f"{path}: the header says {header_size} header bytes and points from byte "
            f"{data_start}, in a file of {file_size} bytes; the file is truncated or corrupt"
        )
        raise InputError(msg)
    fh.seek(header_size)
    region = fh.read(data_start - header_size)
    at = 0
    for k in range(n_vlrs):
        length = (
            int.from_bytes(region[at + 20 : at + 22], "little")
            if at + _VLR_HEADER_BYTES <= len(region)
            else -1
        )
        if length < 0 or at + _VLR_HEADER_BYTES + length > len(region):
            msg = (
                f"{path}: VLR {k + 1} of {n_vlrs} (from byte {header_size + at}) runs past "
                f"the start of the points (byte {data_start}); the file is corrupt"
            )
            raise InputError(msg)
        at += _VLR_HEADER_BYTES + length


def read_las_header(path: Path, fh: BinaryIO, file_size: int) -> laspy.LasHeader:
    """The header, VLRs and EVLRs of an open LAS/LAZ file, every failure an `InputError`.

    The file is also checked to hold exactly the header's points (`read_las_layout`).
    """
    return read_las_layout(path, fh, file_size)[0]


def read_las_layout(
    path: Path, fh: BinaryIO, file_size: int
) -> tuple[laspy.LasHeader, LazChunks | None]:
    """The header of an open LAS/LAZ file and, for a LAZ file with points, its chunks.

    A LAS 1.4 header with the 64-bit point count 0 takes the legacy 32-bit count. The
    point count is checked against the file: an uncompressed file's point data must
    hold exactly that many points (fewer: truncated; more: points left out), a LAZ
    file's chunk table and chunks (`kinsync.io.laz_chunks.laz_chunks`) must hold them.
    Scale factors must be finite and non-zero, offsets finite.
    """
    _check_header_bytes(path, fh, file_size)
    fh.seek(0)
    try:
        header = laspy.LasHeader.read_from(fh, read_evlrs=False)
    # laspy raises whatever its parsing meets in damaged bytes (LaspyException,
    # ValueError, struct.error, UnicodeDecodeError, IndexError, ...): all mean that the
    # file is not a readable LAS/LAZ.
    except Exception as err:
        msg = (
            f"{path}: cannot read the LAS/LAZ header ({type(err).__name__}: {err}); check "
            "that the file is a complete LAS or LAZ file"
        )
        raise InputError(msg) from err
    _resolve_point_count(fh, header)
    _check_scales_offsets(path, header)
    chunks = None
    if not header.are_points_compressed:
        _check_las_size(path, header, file_size)
    elif int(header.point_count) > 0 or file_size > int(header.offset_to_point_data):
        # The chunk table must hold the header's points: a count of 2**64 - 1 would
        # otherwise plan (and allocate) work for points that are not there, a count
        # below the chunks' leave points out (0 included: any chunk is refused).
        chunks = laz_chunks(path, fh, header, file_size)
    n_evlrs = int(header.number_of_evlrs) if header.version.minor >= 4 else 0
    if n_evlrs:
        _check_evlrs(path, fh, header, file_size)
        try:
            header.read_evlrs(fh)
        except Exception as err:  # as above
            msg = (
                f"{path}: cannot read the extended VLRs at byte {header.start_of_first_evlr} "
                f"({type(err).__name__}: {err}); the file is corrupt"
            )
            raise InputError(msg) from err
    else:
        header.evlrs = VLRList() if header.version.minor >= 4 else None
    return header, chunks


def _check_evlrs(path: Path, fh: BinaryIO, header: laspy.LasHeader, file_size: int) -> None:
    """Each extended VLR's header and data must lie in the file (laspy reads short ones)."""
    n_evlrs = int(header.number_of_evlrs)
    at = int(header.start_of_first_evlr)
    for k in range(n_evlrs):
        if at < header.offset_to_point_data or at + _EVLR_HEADER_BYTES > file_size:
            what = f"at byte {at}" if k == 0 else f"{k + 1} of {n_evlrs} at byte {at}"
            msg = (
                f"{path}: the header places extended VLR {what} beyond the end of the "
                f"file ({file_size} bytes); the file is truncated or corrupt"
            )
            raise InputError(msg)
        fh.seek(at)
        raw = fh.read(_EVLR_HEADER_BYTES)
        user_id = raw[2:18].split(b"\0", 1)[0].decode("ascii", "replace")
        record_id = int.from_bytes(raw[18:20], "little")
        length = int.from_bytes(raw[20:28], "little")
        end = at + _EVLR_HEADER_BYTES + length
        if end > file_size:
            msg = (
                f"{path}: extended VLR {k + 1} of {n_evlrs} ({user_id!r}, record {record_id}) "
                f"runs from byte {at} to {end}, beyond the end of the file ({file_size} "
                "bytes); the file is truncated or corrupt"
            )
            raise InputError(msg)
        at = end


def las_header(path: Path) -> laspy.LasHeader:
    """Read the header of a LAS/LAZ file with its VLRs and EVLRs (no points).

    The template for `kinsync.io.las_writer.LasChunkWriter` (the LAZ description VLR
    is kept: writers replace it).

    Raises
    ------
    InputError
        Missing file, unknown suffix, unreadable header, VLRs or EVLRs.
    """
    path = Path(path)
    with open_las_file(path) as fh:
        return read_las_header(path, fh, os.fstat(fh.fileno()).st_size)
