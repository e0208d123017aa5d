"""Where georeferenced chunks go: a table, a LAS/LAZ file or a PLY file, and the rejects.

Each sink takes the `ChunkOutput` s of `kinsync.pipelines.georef_chunks` in input order
and writes what is meant for it: the ``columns`` (table, PLY) or the ``records`` (LAS)
of the points inside the trajectory span; a rejected sink writes the points outside
it, unchanged, in the format `kinsync.pipelines.georef.rejected_path_for` names
(``rejected_records`` of a LAS/LAZ input,
``rejected_lines`` of a CSV to a CSV rejected file, ``rejected_columns`` of a table).
All write atomically (their file appears when the ``with`` block ends without an
error). Given the run's kinsync record (`kinsync.io.point_provenance`), the output sinks
keep it in their file: a LAS VLR, Parquet schema metadata, PLY header comments; a CSV
has nowhere to keep it. Rejected points are written as they were read, records included.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from contextlib import AbstractContextManager
from pathlib import Path
from types import TracebackType
from typing import Any

import laspy
import numpy as np
import pyproj

from kinsync.crs_axes import coordinate_metadata
from kinsync.io.csv_lines import CsvLineWriter
from kinsync.io.las_writer import LasChunkWriter
from kinsync.io.ply import PlyChunkWriter
from kinsync.io.point_provenance import parquet_record_metadata, ply_record_comments
from kinsync.io.points import TableChunkWriter
from kinsync.pipelines.georef_chunks import ChunkOutput, LasOutputFrame

__all__ = [
    "CsvLinesRejectedSink",
    "LasRejectedSink",
    "LasSink",
    "PlySink",
    "Sink",
    "TableRejectedSink",
    "TableSink",
    "ply_crs_comment",
]

_PLY_CRS_CHARS = 200
"""Longest ``--crs`` text a PLY comment shows as given (a WKT is kilobytes long)."""


class Sink:
    """A writer of chunk outputs, used as a context manager around its file writer."""

    def __init__(self, writer: AbstractContextManager[Any]) -> None:
        self._writer = writer

    def __enter__(self) -> Sink:
        self._writer.__enter__()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self._writer.__exit__(exc_type, exc, tb)

    def write(self, out: ChunkOutput) -> None:
        """Write the part of ``out`` meant for this sink."""
        raise NotImplementedError

    def finish_empty(self) -> None:
        """Called when the input had no points at all (nothing was written)."""


class TableSink(Sink):
    """The ``columns`` of each chunk into a CSV/Parquet table.

    ``empty`` gives the columns (with their types, no rows) written when the input has
    no points, so that the table still has its header or schema. With ``crs``, a
    Parquet table says the unit of each of X, Y, Z and the CRS in its metadata
    (`kinsync.crs_axes.coordinate_metadata`); with ``record``, it holds the kinsync
    record under the key ``kinsync`` (a CSV neither).
    """

    def __init__(
        self,
        path: Path,
        empty: Callable[[], dict[str, Any]],
        crs: pyproj.CRS | None = None,
        record: Mapping[str, Any] | None = None,
    ) -> None:
        fields, metadata = ({}, {}) if crs is None else coordinate_metadata(crs)
        if record is not None:
            metadata = {**metadata, **parquet_record_metadata(record)}
        self._table = TableChunkWriter(path, fields, metadata)
        self._empty = empty
        super().__init__(self._table)

    def write(self, out: ChunkOutput) -> None:  # noqa: D102
        assert out.columns is not None
        self._table.write(out.columns)

    def finish_empty(self) -> None:  # noqa: D102
        self._table.write(self._empty())


def ply_crs_comment(crs_text: str, crs: pyproj.CRS, units: str) -> str:
    """The PLY header comment naming the output CRS, short and ASCII.

    PLY headers are ASCII and readers refuse long lines (Open3D's RPly aborts on one of
    1,024 characters): a ``--crs`` text longer than `_PLY_CRS_CHARS` or not ASCII (a
    WKT, whose degree signs are not) is shown as the CRS's name and authority code
    (non-ASCII characters escaped, cut at `_PLY_CRS_CHARS`); the record holds it whole.

    Parameters
    ----------
    crs_text : str
        ``--crs`` as given.
    crs : pyproj.CRS
        That CRS.
    units : str
        The units of x, y, z (``"metre, metre, metre"``).

    Returns
    -------
    str
        ``kinsync georef, crs <CRS>, x y z in <units>``.
    """
    shown = " ".join(crs_text.split())
    if len(shown) > _PLY_CRS_CHARS or not shown.isascii():
        authority = crs.to_authority(min_confidence=90)
        name = f"{crs.name} ({':'.join(authority)})" if authority else crs.name
        shown = " ".join(name.encode("ascii", "backslashreplace").decode("ascii").split())
        if len(shown) > _PLY_CRS_CHARS:
            shown = shown[: _PLY_CRS_CHARS - 3] + "..."
    return f"kinsync georef, crs {shown}, x y z in {units}"


class PlySink(Sink):
    """The ``columns`` of each chunk (x, y, z and attributes) into a PLY file.

    With ``record``, its kinsync record is in the last header comments.
    """

    def __init__(
        self,
        path: Path,
        properties: Sequence[tuple[str, Any]],
        max_points: int,
        comments: Sequence[str],
        record: Mapping[str, Any] | None = None,
    ) -> None:
        if record is not None:
            comments = [*comments, *ply_record_comments(record)]
        self._ply = PlyChunkWriter(path, properties, max_points, comments)
        super().__init__(self._ply)

    def write(self, out: ChunkOutput) -> None:  # noqa: D102
        assert out.columns is not None
        self._ply.write(out.columns)


class LasSink(Sink):
    """The ``records`` of each chunk (X, Y, Z already stored) into a LAS/LAZ file.

    ``notes``: the writer's ``crs_note`` (a CRS in WKT2) and ``record_notes`` (what of
    ``record`` a LAS 1.2/1.3 VLR had no room for).
    """

    def __init__(
        self,
        path: Path,
        header: laspy.LasHeader,
        crs: pyproj.CRS,
        frame: LasOutputFrame,
        record: Mapping[str, Any] | None = None,
    ) -> None:
        self._las = LasChunkWriter(path, header, crs, frame.offsets, frame.scales, record)
        crs_note = () if self._las.crs_note is None else (self._las.crs_note,)
        self.notes = crs_note + self._las.record_notes
        super().__init__(self._las)

    def write(self, out: ChunkOutput) -> None:  # noqa: D102
        assert out.records is not None
        if len(out.records):
            h = self._las.header
            self._las.write_stored(
                laspy.ScaleAwarePointRecord(out.records, h.point_format, h.scales, h.offsets)
            )


class LasRejectedSink(Sink):
    """The ``rejected_records`` of a LAS/LAZ input, unchanged, with the input's header."""

    def __init__(self, path: Path, template: laspy.LasHeader) -> None:
        offsets = tuple(float(v) for v in template.offsets)
        scales = tuple(float(v) for v in template.scales)
        self._template = template
        self._las = LasChunkWriter(path, template, None, offsets, scales)  # type: ignore[arg-type]
        super().__init__(self._las)

    def write(self, out: ChunkOutput) -> None:  # noqa: D102
        assert out.rejected_records is not None
        t = self._template
        self._las.write_stored(
            laspy.ScaleAwarePointRecord(
                np.asarray(out.rejected_records), t.point_format, t.scales, t.offsets
            )
        )


class CsvLinesRejectedSink(Sink):
    """The ``rejected_lines`` of a CSV input: its header and the rows' lines, byte for byte."""

    def __init__(self, path: Path, header: bytes) -> None:
        self._lines = CsvLineWriter(path, header)
        super().__init__(self._lines)

    def write(self, out: ChunkOutput) -> None:  # noqa: D102
        assert out.rejected_lines is not None
        self._lines.write(out.rejected_lines)


class TableRejectedSink(Sink):
    """The ``rejected_columns`` of a table input, its columns as they were."""

    def __init__(self, path: Path) -> None:
        self._table = TableChunkWriter(path)
        super().__init__(self._table)

    def write(self, out: ChunkOutput) -> None:  # noqa: D102
        assert out.rejected_columns is not None
        self._table.write(out.rejected_columns)
