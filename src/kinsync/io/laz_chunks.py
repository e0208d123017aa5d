"""Where the points of a LAZ file lie: its LAZ chunk table, read and checked.

lazrs's own seek assumes fixed-size chunks (it lands on wrong points in a COPC file,
or fails after allocating gigabytes), so kinsync locates points itself from the chunk
table (`laz_chunks`) and decompresses whole chunks
(``lazrs.decompress_points_with_chunk_table``, as laspy's COPC reader does).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from pathlib import Path
from typing import Any, BinaryIO

import laspy
import lazrs
import numpy as np

from kinsync.errors import InputError

__all__ = ["LazChunks", "laz_chunks"]

_LAZ_CHUNKED_COMPRESSORS = (2, 3)  # LASzip "pointwise chunked" and "layered chunked"
_MIN_LAZ_CHUNK_BYTES = 20
"""A LAZ chunk holds its first point uncompressed: at least a point of format 0."""


@dataclass(frozen=True)
class LazChunks:
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


def laz_chunks(path: Path, fh: BinaryIO, header: laspy.LasHeader, file_size: int) -> LazChunks:
    """Read and check the LAZ chunk table (variable-size chunks, as in COPC, included).

    lazrs's own seek assumes fixed-size chunks (it lands on wrong points in a COPC
    file, or fails after allocating gigabytes), so kinsync locates points itself: the
    chunk table gives each chunk's points and bytes, and runs of whole chunks are
    decompressed with ``lazrs.decompress_points_with_chunk_table`` (as laspy's COPC
    reader does). Every count and offset is checked against the header and the file
    size before anything is allocated.
    """
    n = int(header.point_count)
    data_start = int(header.offset_to_point_data)
    record_data, laz_vlr = _laz_vlr(path, header)
    table_at = _laz_table_offset(path, fh, header, file_size)
    fh.seek(table_at)
    _version, n_chunks = struct.unpack("<II", fh.read(8))
    chunks_bytes = table_at - data_start - 8
    if n_chunks > chunks_bytes // _MIN_LAZ_CHUNK_BYTES or n_chunks == 0:
        what = f"the LAZ chunk table lists {n_chunks} chunks in {chunks_bytes} bytes"
        raise _laz_corrupt(path, n, what)
    fh.seek(table_at)
    try:
        entries = lazrs.read_chunk_table_only(fh, laz_vlr)
    except lazrs.LazrsError as err:
        what = f"the LAZ chunk table (at byte {table_at}) is unreadable ({err})"
        raise _laz_corrupt(path, n, what) from err
    if any(not (0 <= int(e[0]) < 2**40 and 0 < int(e[1]) <= chunks_bytes) for e in entries):
        what = f"the LAZ chunk table (at byte {table_at}) lists impossible chunk sizes"
        raise _laz_corrupt(path, n, what)
    counts = np.array([int(e[0]) for e in entries], dtype=np.int64)
    sizes = np.array([int(e[1]) for e in entries], dtype=np.int64)
    if not laz_vlr.uses_variable_size_chunks():
        # Fixed-size chunks: the table repeats the chunk size; the last chunk holds the rest.
        # Python integers: a header count near 2**64 must not overflow int64.
        chunk_size = int(laz_vlr.chunk_size())
        held_by = [min(chunk_size, max(0, n - chunk_size * k)) for k in range(len(counts))]
        counts = np.array([c for c in held_by if c > 0], dtype=np.int64)
        sizes = sizes[: len(counts)]
    held = int(counts.sum())
    if held != n:
        missing = f" (points {held}..{n - 1} are missing)" if held < n else ""
        what = f"the header says {n} points, the LAZ chunk table holds {held}{missing}"
        raise _laz_corrupt(path, n, what)
    first_byte = data_start + 8 + np.concatenate([[0], np.cumsum(sizes)])
    if first_byte[-1] > table_at:
        what = (
            f"the LAZ chunks ({int(sizes.sum())} bytes) do not fit between the points' "
            f"start (byte {data_start}) and the chunk table (byte {table_at})"
        )
        raise _laz_corrupt(path, n, what)
    return LazChunks(
        record_data=record_data,
        first_point=np.concatenate([[0], np.cumsum(counts)]).astype(np.int64),
        first_byte=first_byte.astype(np.int64),
    )
