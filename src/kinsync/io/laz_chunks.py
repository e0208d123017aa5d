"""Where the points of a LAZ file lie: its LAZ chunk table, read and checked.

lazrs's own seek assumes fixed-size chunks (it lands on wrong points in a COPC file,
or fails after allocating gigabytes), so kinsync locates points itself from the chunk
table (`laz_chunks`) and decompresses whole chunks
(``lazrs.decompress_points_with_chunk_table``, as laspy's COPC reader does).
"""

from __future__ import annotations

import os
import struct
from dataclasses import dataclass
from pathlib import Path
from typing import Any, BinaryIO, NoReturn

import laspy
import lazrs
import numpy as np

from kinsync._arrays import ReadOnlyArrays
from kinsync.errors import InputError

__all__ = ["LazChunks", "laz_chunks", "point_count_fields", "points_text"]

_LAZ_CHUNKED_COMPRESSORS = (2, 3)  # LASzip "pointwise chunked" and "layered chunked"
_LAZ_LAYERED = 3
_MIN_LAZ_CHUNK_BYTES = 20
"""A LAZ chunk holds its first point uncompressed: at least a point of format 0."""


@dataclass(frozen=True, eq=False)
class LazChunks(ReadOnlyArrays):
    """Where the points of a LAZ file lie: its LAZ chunk table, checked against the file.

    Chunk ``k`` holds points ``first_point[k] .. first_point[k + 1] - 1`` compressed in
    bytes ``first_byte[k] .. first_byte[k + 1] - 1`` of the file.
    """

    record_data: bytes  # the LASzip VLR, as lazrs reads it
    first_point: np.ndarray[Any, np.dtype[np.int64]]  # shape (K + 1,)
    first_byte: np.ndarray[Any, np.dtype[np.int64]]  # shape (K + 1,)

    def chunk_of(self, point: int) -> int:
        """Index of the chunk holding point ``point``."""
        return int(np.searchsorted(self.first_point, point, side="right")) - 1


def points_text(first: int, last: int) -> str:
    """Points ``first .. last`` (0-based, inclusive) as messages count them: from 1.

    ``"points 97..100"``, or ``"point 100"`` for one; every message naming LAS points
    counts them from 1, as ``point 101 of 54191`` does.
    """
    if first == last:
        return f"point {first + 1}"
    return f"points {first + 1}..{last + 1}"


def _laz_corrupt(path: Path, n: int, what: str) -> InputError:
    return InputError(
        f"{path}: {what}; the file is truncated or corrupt (its {n} points cannot be "
        "located): copy it again or rewrite it with a LAZ tool"
    )


def _laz_vlr(path: Path, header: laspy.LasHeader) -> tuple[bytes, Any]:
    """The LASzip VLR's bytes and its ``lazrs.LazVlr``, checked against the header."""
    n = int(header.point_count)
    try:
        record_data = bytes(header.vlrs.get("LasZipVlr")[0].record_data)
    except IndexError:
        raise _laz_corrupt(path, n, "the LAZ description (laszip VLR) is missing") from None
    try:
        laz_vlr = lazrs.LazVlr(record_data)
    except lazrs.LazrsError as err:
        what = f"the LAZ description (laszip VLR) is unreadable ({err})"
        raise _laz_corrupt(path, n, what) from err
    compressor = int.from_bytes(record_data[:2], "little")
    if compressor not in _LAZ_CHUNKED_COMPRESSORS:
        msg = (
            f"{path}: LAZ compressor {compressor} (LASzip without chunks) is not supported; "
            "rewrite the file with a current LAZ tool (laszip, PDAL)"
        )
        raise InputError(msg)
    if laz_vlr.item_size() != header.point_format.size:
        what = (
            f"the LAZ description says points of {laz_vlr.item_size()} bytes, the header "
            f"{header.point_format.size}"
        )
        raise _laz_corrupt(path, n, what)
    return record_data, laz_vlr


def _laz_table_offset(path: Path, fh: BinaryIO, header: laspy.LasHeader, file_size: int) -> int:
    """Where the LAZ chunk table starts (byte), checked to lie in the file."""
    data_start = int(header.offset_to_point_data)
    fh.seek(data_start)
    raw = fh.read(8)
    table_at = int.from_bytes(raw, "little", signed=True) if len(raw) == 8 else -1
    if table_at <= data_start and file_size >= data_start + 16:
        # A writer that could not seek back stores the offset in the last 8 bytes.
        fh.seek(file_size - 8)
        table_at = int.from_bytes(fh.read(8), "little", signed=True)
    if not data_start + 8 <= table_at <= file_size - 8:
        what = (
            f"the LAZ chunk table (at byte {table_at}) lies outside the file "
            f"({file_size} bytes, points from byte {data_start})"
        )
        raise _laz_corrupt(path, int(header.point_count), what)
    return table_at


def _chunk_table(
    path: Path, fh: BinaryIO, header: laspy.LasHeader, laz_vlr: Any, file_size: int
) -> tuple[np.ndarray[Any, np.dtype[np.int64]], np.ndarray[Any, np.dtype[np.int64]]]:
    """The chunk table's point counts and each chunk's first byte (one more: the end).

    No chunk at all (an empty file) gives empty counts.
    """
    n = int(header.point_count)
    data_start = int(header.offset_to_point_data)
    table_at = _laz_table_offset(path, fh, header, file_size)
    fh.seek(table_at)
    _version, n_chunks = struct.unpack("<II", fh.read(8))
    chunks_bytes = table_at - data_start - 8
    if n_chunks == 0 and n == 0:  # an empty file
        return np.zeros(0, np.int64), np.full(1, data_start + 8, np.int64)
    # + 1: a writer may close the file with an empty chunk (a few bytes, no point)
    if n_chunks > chunks_bytes // _MIN_LAZ_CHUNK_BYTES + 1 or n_chunks == 0:
        what = f"the LAZ chunk table lists {n_chunks} chunks in {chunks_bytes} bytes"
        raise _laz_corrupt(path, n, what)
    fh.seek(table_at)
    try:
        entries = lazrs.read_chunk_table_only(fh, laz_vlr)
    except lazrs.LazrsError as err:
        what = f"the LAZ chunk table (at byte {table_at}) is unreadable ({err})"
        raise _laz_corrupt(path, n, what) from err
    if any(not (0 <= int(e[0]) < 2**40 and 0 <= int(e[1]) <= chunks_bytes) for e in entries):
        what = f"the LAZ chunk table (at byte {table_at}) lists impossible chunk sizes"
        raise _laz_corrupt(path, n, what)
    sizes = np.array([int(e[1]) for e in entries], dtype=np.int64)
    counts = np.array([int(e[0]) for e in entries], dtype=np.int64)
    # A chunk stores its first point uncompressed: one of fewer bytes holds no point.
    variable = laz_vlr.uses_variable_size_chunks()
    while len(sizes) and sizes[-1] < header.point_format.size and (counts[-1] == 0 or not variable):
        sizes, counts = sizes[:-1], counts[:-1]
    first_byte = data_start + 8 + np.concatenate([[0], np.cumsum(sizes)])
    if first_byte[-1] > table_at:
        what = (
            f"the LAZ chunks ({int(sizes.sum())} bytes) do not fit between the points' "
            f"start (byte {data_start}) and the chunk table (byte {table_at})"
        )
        raise _laz_corrupt(path, n, what)
    return counts, first_byte.astype(np.int64)


def _chunk_counts(
    path: Path,
    fh: BinaryIO,
    header: laspy.LasHeader,
    laz_vlr: Any,
    table: np.ndarray[Any, np.dtype[np.int64]],
    first_byte: np.ndarray[Any, np.dtype[np.int64]],
) -> tuple[list[int], str]:
    """How many points each chunk holds, and where that comes from (for messages).

    Variable-size chunks (COPC): the chunk table. Fixed-size chunks: the chunk size,
    the last chunk the rest, which only the header and, for layered chunks (point
    formats 6-10), the chunk itself store: a layered chunk starts with its first point
    uncompressed, then its point count. A fixed-size pointwise chunk (formats 0-5) does
    not store it; `_check_last_pointwise_chunk` checks it another way.
    """
    n = int(header.point_count)
    if laz_vlr.uses_variable_size_chunks() or len(table) == 0:
        return [int(c) for c in table], "the LAZ chunk table holds"
    # Python integers: a header count near 2**64 must not overflow int64.
    chunk_size = int(laz_vlr.chunk_size())
    if int.from_bytes(laz_vlr.record_data()[:2], "little") == _LAZ_LAYERED:
        k = len(table) - 1
        a, b = int(first_byte[k]), int(first_byte[k + 1])
        at = a + int(header.point_format.size)
        fh.seek(at)
        raw = fh.read(4)
        last = int.from_bytes(raw, "little")
        if at + 4 > b or not 0 < last <= chunk_size:
            what = (
                f"LAZ chunk {k + 1} (from point {chunk_size * k + 1}, bytes {a}..{b - 1}) has no "
                f"valid point count ({last} for chunks of {chunk_size})"
            )
            raise _laz_corrupt(path, n, what)
        return [chunk_size] * k + [last], "the LAZ chunks hold"
    if n <= chunk_size * (len(table) - 1):
        _refuse_count(
            path,
            header,
            f"the LAZ chunk table lists {len(table)} chunks of {chunk_size} points, "
            f"more than {chunk_size * (len(table) - 1)} points",
        )
    return [min(chunk_size, n - chunk_size * k) for k in range(len(table))], (
        "the LAZ chunk table holds"
    )


def laz_chunks(path: Path, fh: BinaryIO, header: laspy.LasHeader, file_size: int) -> LazChunks:
    """Read and check the LAZ chunk table (variable-size chunks, as in COPC, included).

    lazrs's own seek assumes fixed-size chunks (it lands on wrong points in a COPC
    file, or fails after allocating gigabytes), so kinsync locates points itself: the
    chunk table gives each chunk's points and bytes, and runs of whole chunks are
    decompressed with ``lazrs.decompress_points_with_chunk_table`` (as laspy's COPC
    reader does). Every count and offset is checked against the header and the file
    size before anything is allocated; chunks that hold more points than the header
    says are refused (`_chunk_counts` says what is known of each chunk's count).
    """
    n = int(header.point_count)
    record_data, laz_vlr = _laz_vlr(path, header)
    table, first_byte = _chunk_table(path, fh, header, laz_vlr, file_size)
    counts, source = _chunk_counts(path, fh, header, laz_vlr, table, first_byte)
    held = sum(counts)
    if held > n:
        _refuse_count(path, header, f"{source} {held}")
    if held < n:
        missing = points_text(held, n - 1)
        verb = "is" if held == n - 1 else "are"
        what = f"the header says {n} points, {source} {held} ({missing} {verb} missing)"
        raise _laz_corrupt(path, n, what)
    chunks = LazChunks(
        record_data=record_data,
        first_point=np.concatenate([[0], np.cumsum(counts, dtype=np.int64)]).astype(np.int64),
        first_byte=first_byte,
    )
    if n > 0 and source == "the LAZ chunk table holds" and not laz_vlr.uses_variable_size_chunks():
        _check_last_pointwise_chunk(path, fh, header, chunks)
    return chunks


def point_count_fields(header: laspy.LasHeader) -> str:
    """Which header field(s) hold the point count, for messages."""
    if header.version.minor >= 4:
        return (
            "the point count (the 64-bit 'number of point records' at byte 247 and, for "
            "point formats 0-5, the legacy 32-bit count at byte 107)"
        )
    return "the point count (the 'number of point records' at byte 107)"


def _refuse_count(path: Path, header: laspy.LasHeader, held: str) -> NoReturn:
    """A header point count below what the LAZ chunks hold: those points would be left out."""
    n = int(header.point_count)
    msg = (
        f"{path}: the header says {n} points, {held}: the points beyond {n} would be left "
        f"out; set {point_count_fields(header)} to the number of points the file holds, "
        "or export it again"
    )
    raise InputError(msg)


_MAX_PROBE_BYTES = 1 << 28
"""A last chunk of more decompressed bytes than this is not probed (LASzip writes 50,000
points a chunk: 1.7 MB of point format 3)."""
_PROBED: set[tuple[int, ...]] = set()
"""Files whose last pointwise chunk was probed in this process (device, inode, size,
mtime, point count): a file is opened several times (header, end times, each reader)."""


def _check_last_pointwise_chunk(
    path: Path, fh: BinaryIO, header: laspy.LasHeader, chunks: LazChunks
) -> None:
    """The last fixed-size pointwise chunk (point formats 0-5) must end where its points do.

    Its point count is stored nowhere but in the header. LASzip's arithmetic coder ends
    a chunk with exactly the bytes the decoder reads for the chunk's last point, so when
    the chunk less its last byte still decompresses, the chunk holds more points than the
    header says. A chunk of one point says nothing (the coder starts at the second).
    Costs one chunk's decompression, once per file and process (`_PROBED`).
    """
    n = int(chunks.first_point[-1])
    a, b = int(chunks.first_point[-2]), n
    if b - a < 2 or (b - a) * int(header.point_format.size) > _MAX_PROBE_BYTES:
        return  # the coder starts at the second point; a chunk too large to probe
    st = os.fstat(fh.fileno())
    key = (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns, n)
    if key in _PROBED:
        return
    start, end = int(chunks.first_byte[-2]), int(chunks.first_byte[-1])
    fh.seek(start)
    data = fh.read(end - start - 1)
    out = np.empty((b - a) * int(header.point_format.size), dtype=np.uint8)
    try:
        lazrs.decompress_points_with_chunk_table(
            data, chunks.record_data, out, [(b - a, len(data))]
        )
    except lazrs.LazrsError:
        # The last byte is needed: the chunk ends with the header's last point.
        _PROBED.add(key)
        return
    _refuse_count(
        path,
        header,
        f"the last LAZ chunk (from point {a + 1}, bytes {start}..{end - 1}) holds more than "
        f"{b - a} points",
    )
