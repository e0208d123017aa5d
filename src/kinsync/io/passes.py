"""Pass folders of a rotating-table latency test (Method A, SPEC section 2).

A pass folder holds ``passes.csv`` and one point file per pass::

    passes.csv          file,rate_deg_s[,axis_n,axis_e,axis_d]
    pass_000.csv        x_m,y_m,z_m[,t_s,intensity,...]   (or .las / .laz)
    ...

``passes.csv`` lists one pass per line: ``file`` (relative to the folder), the signed
table rate ``rate_deg_s`` from the table controller (positive = right-handed about the
axis; about +Down: clockwise seen from above) and, optionally, the unit rotation axis
``axis_n,axis_e,axis_d`` in the table-centred NED frame (default ``0,0,1``). An axis
column left empty on a line takes the default only when all three are empty.

A pass file holds the georeferenced points of one pass in the table-centred NED frame
(metres), sphere and clutter (floor, stand, stray points) alike:

- CSV with a header containing ``x_m,y_m,z_m``; a ``t_s`` column, when present, gives
  the point times (s); other columns are ignored.
- LAS/LAZ (laspy; LAZ through the lazrs backend): ``x, y, z`` are the NED
  coordinates, ``gps_time`` the point time. With the global-encoding bit "adjusted
  standard GPS time" set, ``gps_time`` is GPS time - 1e9 s and is read back as GPS
  time; otherwise it is taken as written (GPS week seconds or the acquisition clock).

`write_passes` writes every file through a temporary name and a rename, and writes
``passes.csv`` last, so a folder whose ``passes.csv`` exists is complete.
"""

from __future__ import annotations

import os
import stat
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import laspy
import numpy as np

from kinsync._text import counted
from kinsync._typing import FloatArray
from kinsync.errors import InputError, KinsyncWarning
from kinsync.io.atomic import atomic_path
from kinsync.io.las import ADJUSTED_GPS_OFFSET_S, LasPointReader, scaled_coordinates
from kinsync.io.las_header import stamp_kinsync_header
from kinsync.io.las_writer import ErrorKeepingFile
from kinsync.io.sanity import (
    LENGTH_M,
    TIME_S,
    Span,
    check_columns,
    check_not_link_loop,
    check_values,
    link_loop_error,
    not_a_regular_file,
)
from kinsync.io.tables import read_csv_rows, read_numeric_csv, write_numeric_csv
from kinsync.latency.passes import SpherePass
from kinsync.progress import Progress, report

__all__ = [
    "PASSES_CSV",
    "PassFileFormat",
    "PassIndexRow",
    "pass_file_name",
    "read_pass_file",
    "read_pass_index",
    "read_passes",
    "write_passes",
]

PASSES_CSV = "passes.csv"
"""Name of the index file of a pass folder."""

PassFileFormat = Literal["csv", "las", "laz"]

_XYZ = ("x_m", "y_m", "z_m")
_AXIS = ("axis_n", "axis_e", "axis_d")
_DEFAULT_AXIS = (0.0, 0.0, 1.0)
_FORMATS: tuple[PassFileFormat, ...] = ("csv", "las", "laz")
_SUFFIXES = (".csv", ".las", ".laz")

_INDEX_SPANS: dict[str, Span] = {
    "rate_deg_s": Span(-1000.0, 1000.0, "deg/s", "a table rate"),
    **dict.fromkeys(_AXIS, Span(-1e6, 1e6, "", "an axis component (the axis is normalised)")),
}
_POINT_SPANS: dict[str, Span] = {**dict.fromkeys(_XYZ, LENGTH_M), "t_s": TIME_S}
"""Plausible values in passes.csv and in a pass file (`kinsync.io.sanity`)."""


# ---------------------------------------------------------------------- reading
@dataclass(frozen=True)
class PassIndexRow:
    """One data line of passes.csv."""

    line: int
    file: str
    rate_deg_s: float
    axis_ned: tuple[float, float, float]


def _number(cell: str, column: str, where: str) -> float:
    try:
        value = float(cell)
    except ValueError:
        msg = f"{where}, column {column!r}: {cell[:80]!r} is not a number"
        raise InputError(msg) from None
    check_values([value], _INDEX_SPANS[column], f"{where}, column {column!r}")
    return value


def read_pass_index(index_path: Path) -> list[PassIndexRow]:
    """Parse passes.csv into rows; errors name the file and the line.

    A pass file listed twice (the same path after normalisation) is an `InputError`
    naming both lines: it would be counted twice.
    """
    if not index_path.exists():
        msg = f"{index_path}: file not found; a pass folder needs a {PASSES_CSV} index"
        raise InputError(msg)
    records = read_csv_rows(index_path, f"pass index ({PASSES_CSV})")
    if not records:
        msg = f"{index_path}: empty file; expected a header file,rate_deg_s"
        raise InputError(msg)
    header_line, header_row = records[0]
    header = [h.strip() for h in header_row]
    dupes = sorted({h for h in header if header.count(h) > 1})
    if dupes:
        msg = f"{index_path}: line {header_line}: duplicated column(s) {dupes} in the header"
        raise InputError(msg)
    missing = [c for c in ("file", "rate_deg_s") if c not in header]
    if missing:
        msg = (
            f"{index_path}: line {header_line}: missing column(s) {missing}; the header has "
            f"{header}; expected file,rate_deg_s[,axis_n,axis_e,axis_d]"
        )
        raise InputError(msg)
    axis_present = [c for c in _AXIS if c in header]
    if axis_present and len(axis_present) != 3:
        absent = [c for c in _AXIS if c not in header]
        msg = (
            f"{index_path}: line {header_line}: the axis is given partially (columns "
            f"{axis_present}, missing {absent}); give all of axis_n,axis_e,axis_d "
            "or none (default 0,0,1 = +Down)"
        )
        raise InputError(msg)
    col = {name: i for i, name in enumerate(header)}
    rows = [_parse_index_row(index_path, line, r, header, col) for line, r in records[1:]]
    out = [r for r in rows if r is not None]
    if not out:
        msg = f"{index_path}: no passes listed; add one line per pass: file,rate_deg_s"
        raise InputError(msg)
    first_line: dict[str, int] = {}
    for r in out:
        key = os.path.normpath(r.file)
        if key in first_line:
            msg = (
                f"{index_path}: line {r.line}: pass file {r.file[:80]!r} listed twice (lines "
                f"{first_line[key]} and {r.line}); a pass counted twice shrinks the latency's "
                "sigma: remove one of the lines"
            )
            raise InputError(msg)
        first_line[key] = r.line
    return out


def _warn_unlisted(folder: Path, rows: Sequence[PassIndexRow]) -> None:
    """Warn about pass-like files (.csv, .las, .laz) in ``folder`` that passes.csv omits."""
    listed = {os.path.normpath(r.file) for r in rows}
    try:
        names = sorted(
            p.name
            for p in folder.iterdir()
            if p.suffix.lower() in _SUFFIXES and p.name != PASSES_CSV and p.name not in listed
        )
    except OSError:
        return  # the listed files were read; an unreadable listing hides nothing we used
    if names:
        shown = ", ".join(names[:5]) + (f" and {len(names) - 5} more" if len(names) > 5 else "")
        warnings.warn(
            f"{folder}: {counted(len(names), 'file')} not listed in {PASSES_CSV}, left out: "
            f"{shown}; add a line per pass to {PASSES_CSV} to use them",
            KinsyncWarning,
            stacklevel=3,
        )


def _parse_index_row(
    index_path: Path, line: int, row: list[str], header: list[str], col: dict[str, int]
) -> PassIndexRow | None:
    if not row or all(not c.strip() for c in row):
        return None
    where = f"{index_path}: line {line}"
    if len(row) != len(header):
        msg = f"{where} has {len(row)} fields, the header has {len(header)}"
        raise InputError(msg)
    file = row[col["file"]].strip()
    if not file:
        msg = f"{where}, column 'file': empty; give the pass file relative to the folder"
        raise InputError(msg)
    rate = _number(row[col["rate_deg_s"]].strip(), "rate_deg_s", where)
    axis = _DEFAULT_AXIS
    if "axis_n" in col:
        cells = [row[col[c]].strip() for c in _AXIS]
        filled = [bool(c) for c in cells]
        if all(filled):
            n, e, d = (_number(c, name, where) for c, name in zip(cells, _AXIS, strict=True))
            axis = (n, e, d)
        elif any(filled):
            empty = [name for name, f in zip(_AXIS, filled, strict=True) if not f]
            msg = (
                f"{where}: the axis is given partially ({', '.join(empty)} empty); "
                "fill all of axis_n,axis_e,axis_d or leave all three empty for 0,0,1"
            )
            raise InputError(msg)
    return PassIndexRow(line=line, file=file, rate_deg_s=rate, axis_ned=axis)


def _read_csv_points(
    path: Path,
) -> tuple[FloatArray, FloatArray | None, Callable[[int], int]]:
    """Points, times and the file line of each data row of a CSV pass file."""
    table = read_numeric_csv(path, required=_XYZ, optional=("t_s", "intensity"))
    pts = np.column_stack([table.columns[c] for c in _XYZ]) if table.n_rows else np.empty((0, 3))
    t = table.columns.get("t_s")
    return pts, t, table.line_of_row


def _read_las_points(path: Path) -> tuple[FloatArray, FloatArray | None]:
    """Points and times of a LAS/LAZ pass file.

    Read through `kinsync.io.las.LasPointReader`, which checks the header's point count
    against the file (LAS: its size; LAZ: its chunk table) before any point is read, so
    a truncated or corrupt file is an `InputError` naming what is missing, as in
    ``calibrate`` and ``georef``.
    """
    with LasPointReader(path) as reader:
        record = reader.read(0, reader.point_count)
        adjusted = reader.gps_time_type == "adjusted_standard"
    pts = scaled_coordinates(record.array, record.scales, record.offsets)
    t: FloatArray | None = None
    if "gps_time" in record.point_format.dimension_names:
        t = np.asarray(record.array["gps_time"], dtype=np.float64)
        if adjusted:
            t = t + ADJUSTED_GPS_OFFSET_S
    return pts, t


def read_pass_file(path: Path) -> tuple[FloatArray, FloatArray | None]:
    """Read the points of one pass file (CSV, LAS or LAZ).

    Parameters
    ----------
    path : Path
        ``.csv`` with ``x_m,y_m,z_m`` columns (``t_s`` optional), or ``.las``/``.laz``.

    Returns
    -------
    points_ned_m : ndarray, shape (N, 3)
        Table-centred NED coordinates (m).
    t_s : ndarray, shape (N,), or None
        Point times (s; GPS time for LAS with adjusted standard GPS time), when the
        file has them.

    Raises
    ------
    InputError
        Missing file, unknown extension, missing ``x_m,y_m,z_m``, a non-numeric cell
        (line and column), an unreadable LAS/LAZ file, no points, a coordinate or time
        that is not finite or not plausible (`kinsync.io.sanity`).
    """
    path = Path(path)
    suffix = path.suffix.lower()
    line_of_row = None
    if suffix == ".csv":
        pts, t, line_of_row = _read_csv_points(path)
    elif suffix in (".las", ".laz"):
        pts, t = _read_las_points(path)
    else:
        msg = f"{path}: unknown pass file type {path.suffix!r}; use .csv, .las or .laz"
        raise InputError(msg)
    if pts.shape[0] == 0:
        msg = f"{path}: the pass holds no points"
        raise InputError(msg)

    def where(i: int) -> str:  # the CSV's file line, or the LAS point counted from 1
        if line_of_row is not None:
            return f"{path}: line {line_of_row(i)}"
        return f"{path}: point {i + 1} of {pts.shape[0]}"

    columns = dict(zip(_XYZ, pts.T, strict=True)) | ({} if t is None else {"t_s": t})
    check_columns(columns, _POINT_SPANS, where)
    return pts, t


def _check_pass_file(path: Path, shown: str, folder: Path) -> None:
    """Refuse a pass file that is missing, a folder, a device or a pipe, or a link loop.

    ``shown`` names it in messages (``passes.csv: line 3: pass file 'a.csv'``).
    """
    try:
        st = path.stat()
    except FileNotFoundError:
        msg = f"{shown} not found in {folder}"
        raise InputError(msg) from None
    except OSError as err:
        loop = link_loop_error(shown, err, "pass file")
        msg = str(loop) if loop is not None else f"{shown}: {err.strerror or err}"
        raise InputError(msg) from err
    if stat.S_ISDIR(st.st_mode):
        msg = f"{shown} in {folder} is a folder, not a file; list the pass files themselves"
        raise InputError(msg)
    if not stat.S_ISREG(st.st_mode):
        raise not_a_regular_file(shown, "pass file")


def read_passes(folder: Path, *, progress: Progress | None = None) -> list[SpherePass]:
    """Read a pass folder (``passes.csv`` and the pass files it lists).

    Parameters
    ----------
    folder : Path
        Folder holding ``passes.csv``; pass files are relative to it.
    progress : Progress, optional
        Told after each pass file (`kinsync.progress`).

    Returns
    -------
    list of SpherePass
        In the order of ``passes.csv``; ``source`` is the pass file's path.

    Raises
    ------
    InputError
        Naming ``passes.csv`` and the line at fault: a missing folder or index, missing
        columns, a non-numeric or zero rate, a partial or zero axis, a pass file listed
        twice, a missing pass file, a pass file without ``x_m,y_m,z_m``, a non-numeric
        cell, an empty pass.

    Warns
    -----
    KinsyncWarning
        Naming the ``.csv``/``.las``/``.laz`` files in the folder that ``passes.csv``
        does not list (they are left out).
    """
    folder = Path(folder)
    check_not_link_loop(folder, "pass folder")
    if not folder.is_dir():
        what = "is not a folder" if folder.exists() else "not found"
        msg = f"{folder}: pass folder {what}; give the folder that holds {PASSES_CSV}"
        raise InputError(msg)
    index_path = folder / PASSES_CSV
    rows = read_pass_index(index_path)
    passes: list[SpherePass] = []
    for k, row in enumerate(rows):
        report(progress, k / len(rows), f"reading pass {k + 1} of {len(rows)}")
        where = f"{index_path}: line {row.line}"
        path = folder / row.file
        _check_pass_file(path, f"{where}: pass file {row.file[:80]!r}", folder)
        try:
            pts, t = read_pass_file(path)
            passes.append(
                SpherePass(
                    source=str(path),
                    rate_deg_s=row.rate_deg_s,
                    points_ned_m=pts,
                    axis_ned=row.axis_ned,
                    t_s=t,
                )
            )
        except InputError as err:
            msg = f"{where}: {err}"
            raise InputError(msg) from err
    report(progress, 1.0, f"read {counted(len(rows), 'pass')}")
    _warn_unlisted(folder, rows)
    return passes


# ---------------------------------------------------------------------- writing
def _las_scale_m(points_ned_m: FloatArray, source: str) -> float:
    """Finest of 1e-6 / 1e-5 m whose 32-bit integers span the pass (sub-0.1 mm kept)."""
    extent = float(np.max(np.ptp(points_ned_m, axis=0))) if points_ned_m.size else 0.0
    for scale in (1e-6, 1e-5):
        if extent < 0.9 * scale * 2**31:
            return scale
    msg = (
        f"{source}: the pass spans {extent:.0f} m, too large for LAS at 0.01 mm "
        "resolution; write it as CSV"
    )
    raise InputError(msg)


def _write_las(path: Path, p: SpherePass, *, compress: bool) -> None:
    pts = p.points_ned_m
    scale = _las_scale_m(pts, p.source)
    header = laspy.LasHeader(point_format=0 if p.t_s is None else 6, version="1.4")
    stamp_kinsync_header(header)
    mins = pts.min(axis=0)
    header.offsets = np.floor(mins / scale) * scale
    header.scales = np.array([scale, scale, scale])
    las = laspy.LasData(header)
    las.x = pts[:, 0]
    las.y = pts[:, 1]
    las.z = pts[:, 2]
    las.return_number = np.ones(len(pts), dtype=np.uint8)  # single returns: 1 of 1
    las.number_of_returns = np.ones(len(pts), dtype=np.uint8)
    if p.t_s is not None:
        t = np.asarray(p.t_s, dtype=np.float64)
        if t.size and float(t.min()) >= ADJUSTED_GPS_OFFSET_S:
            las.header.global_encoding.gps_time_type = laspy.header.GpsTimeType.STANDARD
            t = t - ADJUSTED_GPS_OFFSET_S
        las.gps_time = t
    with atomic_path(path) as tmp, tmp.open("wb") as fh:
        if compress:
            kept = ErrorKeepingFile(fh)
            try:
                las.write(kept, do_compress=True, laz_backend=laspy.LazBackend.Lazrs)
            except Exception as err:
                if kept.error is None:
                    raise
                raise kept.error from err  # a full disk, which lazrs reports without its error
        else:
            las.write(fh, do_compress=False)


def pass_file_name(index: int, n_passes: int, file_format: PassFileFormat = "csv") -> str:
    """Name `write_passes` gives pass ``index`` of ``n_passes``: ``pass_000.csv``, ..."""
    width = max(3, len(str(max(n_passes, 1) - 1)))
    return f"pass_{index:0{width}d}.{file_format}"


def _index_cell(value: float) -> str:
    return repr(float(value))


def write_passes(
    folder: Path, passes: Sequence[SpherePass], *, file_format: PassFileFormat = "csv"
) -> None:
    """Write a pass folder that `read_passes` reads back.

    Pass files are named ``pass_000.<ext>``, ``pass_001.<ext>``, ... in the order
    given; ``passes.csv`` lists them with the rate and the axis and is written last.

    Parameters
    ----------
    folder : Path
        Output folder; created (with parents) if missing. Existing files of the same
        names are replaced.
    passes : sequence of SpherePass
        At least one pass.
    file_format : {"csv", "las", "laz"}
        CSV (``x_m,y_m,z_m[,t_s]``, exact float round trip) or LAS/LAZ 1.4 (point
        format 6 with GPS time, 0 without; coordinates at 1e-6 m resolution, offsets
        at the data's minimum).

    Raises
    ------
    InputError
        No passes, an unknown format, a folder path that is a file.
    """
    folder = Path(folder)
    if file_format not in _FORMATS:
        msg = f"pass file format must be one of {', '.join(_FORMATS)}, got {file_format!r}"
        raise InputError(msg)
    if not passes:
        msg = f"{folder}: no passes to write"
        raise InputError(msg)
    if folder.exists() and not folder.is_dir():
        msg = f"{folder}: exists and is not a folder; give a folder for the passes"
        raise InputError(msg)
    folder.mkdir(parents=True, exist_ok=True)
    lines = ["file,rate_deg_s,axis_n,axis_e,axis_d"]
    for i, p in enumerate(passes):
        name = pass_file_name(i, len(passes), file_format)
        path = folder / name
        if file_format == "csv":
            columns = {c: p.points_ned_m[:, k] for k, c in enumerate(_XYZ)}
            if p.t_s is not None:
                columns["t_s"] = np.asarray(p.t_s, dtype=np.float64)
            write_numeric_csv(path, columns)
        else:
            _write_las(path, p, compress=file_format == "laz")
        axis = ",".join(_index_cell(v) for v in p.axis_ned)
        lines.append(f"{name},{_index_cell(p.rate_deg_s)},{axis}")
    with atomic_path(folder / PASSES_CSV) as tmp:
        tmp.write_text("\n".join(lines) + "\n", encoding="utf-8")
