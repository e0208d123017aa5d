"""Profile-scanner files of Method B (SPEC section 4): the scan, sync points and pulses.

Formats
-------
Scan (no times)
    CSV or Parquet, one return per row, in acquisition order:
    ``profile,angle_rad,range_m,intensity`` (+ any other columns, carried through by
    ``kinsync sync apply``). ``profile`` is the profile number n (whole, >= 0, never
    decreasing); ``angle_rad`` the mirror angle phi from nadir, positive towards the
    scanner's +Y (rad); ``range_m`` the range (m); ``intensity`` the return strength
    (any unit; retro-reflective targets must stand out).
Sync points and control points
    CSV ``name,lat_deg,lon_deg,h_m``: WGS84 geodetic latitude and longitude (deg) and
    ellipsoidal height (m) of each target centre; names unique.
Hardware profile pulses
    CSV ``t_s``: one pulse per profile on GPS time (s), strictly increasing.
Profile clock
    JSON object with numbers ``t0_s`` and ``period_s`` (what ``kinsync sync
    object-space --json`` prints): ``t(n, phi) = t0_s + (n + phi / 2 pi) period_s``;
    ``mount`` (optional: older files lack it) records the mount the clock was fitted
    with, `kinsync.sync.clock_mount.ClockMount.as_document`.
"""

from __future__ import annotations

import csv
import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.csv as pa_csv

from kinsync._text import shown_value
from kinsync._typing import ArrayLike, FloatArray
from kinsync.errors import InputError, KinsyncWarning
from kinsync.io.atomic import atomic_path
from kinsync.io.points import TableChunkWriter, iter_table_chunks
from kinsync.io.row_position import csv_line_of_row, point_position
from kinsync.io.sanity import (
    HEIGHT_M,
    INTENSITY,
    LATITUDE_DEG,
    LENGTH_M,
    LONGITUDE_DEG,
    TIME_S,
    Span,
    check_columns,
    check_values,
    load_json,
    require_file,
)
from kinsync.io.tables import read_csv_rows, read_numeric_csv, write_numeric_csv
from kinsync.io.text_lines import cut_line_hint
from kinsync.mount import MAX_PROFILE_ANGLE_RAD
from kinsync.sync.clock_mount import ClockMount
from kinsync.sync.scan import (
    SCAN_COLUMNS,
    SYNC_POINT_COLUMNS,
    ProfileScan,
    SyncPoints,
)

__all__ = [
    "ClockFile",
    "pulse_line",
    "read_clock_document",
    "read_clock_file",
    "read_profile_scan",
    "read_pulses",
    "read_sync_points",
    "write_profile_scan",
    "write_pulses",
    "write_sync_points",
]


_READ_CHUNK = 1 << 20

_SCAN_SPANS: dict[str, Span] = {
    "angle_rad": Span(
        -MAX_PROFILE_ANGLE_RAD, MAX_PROFILE_ANGLE_RAD, "rad", "a mirror angle (one turn)"
    ),
    "range_m": LENGTH_M.positive(0.0, "a range"),
    "intensity": INTENSITY,
}
"""Plausible values of the scan's columns (`kinsync.io.sanity`); the profile numbers are
checked by `ProfileScan.checked_profile_numbers`."""

_SYNC_SPANS = (LATITUDE_DEG, LONGITUDE_DEG, HEIGHT_M)
_PERIOD_S = Span(1e-5, 100.0, "s", "a profile period (as --period-s)")


def _zero_range_note(range_m: FloatArray, where: Callable[[int], str]) -> str:
    """Advice when some ranges are exactly 0 (a "no return" code), else ``""``.

    Parameters
    ----------
    range_m : ndarray, shape (N,)
        Ranges of the returns (m).
    where : callable of int to str
        Names ``range_m[i]`` as the file counts it (``line 7``, ``row 6 of 9``).

    Returns
    -------
    str
        The count and the first of the zero ranges, and why they matter:
        `kinsync sync apply` refuses them (a return at the scanner itself).
    """
    zero = np.flatnonzero(np.asarray(range_m) == 0.0)
    if zero.size == 0:
        return ""
    return (
        f"{where(int(zero[0]))}: range_m is 0 ({zero.size:,} of {np.size(range_m):,} "
        "returns), a common 'no return' code: the target search cannot match such a return "
        "to a sync point, but `kinsync sync apply` refuses them (they would lie at the "
        "scanner itself): remove the rows with range 0 from the scan"
    )


def read_profile_scan(path: Path) -> ProfileScan:
    """Read a scan table (``.csv`` or ``.parquet``) with ``profile,angle_rad,range_m,intensity``.

    Other columns are ignored here (``kinsync sync apply`` carries them through).

    Raises
    ------
    InputError
        Missing file or columns, a non-numeric cell, a value that is not finite or not
        plausible (`kinsync.io.sanity`), or a bad profile number (naming the CSV line
        or the Parquet row, counted from 1).

    Warns
    -----
    KinsyncWarning
        Ranges of 0, a "no return" code that `kinsync sync apply` refuses (the first
        such row and the count).
    """
    path = Path(path)
    require_file(path, "scan")  # a link loop, a pipe, a folder: named as such
    parts: dict[str, list[FloatArray]] = {c: [] for c in SCAN_COLUMNS}
    for chunk in iter_table_chunks(path, _READ_CHUNK, SCAN_COLUMNS):
        for c in SCAN_COLUMNS:
            parts[c].append(chunk[c])
    if not parts["profile"] or sum(a.size for a in parts["profile"]) == 0:
        msg = f"{path}: the scan has no data rows; expected columns {list(SCAN_COLUMNS)}"
        raise InputError(msg)
    cols = {c: np.concatenate(v) for c, v in parts.items()}
    total = int(cols["profile"].size)

    def where(row: int) -> str:  # CSV: the file line; Parquet: "row N of M"
        return f"{path}: {point_position(path, row, total)}"

    check_columns(cols, _SCAN_SPANS, where)
    profile = ProfileScan.checked_profile_numbers(
        cols["profile"], str(path), lambda i: point_position(path, i, total)
    )
    if zero_note := _zero_range_note(cols["range_m"], where):
        warnings.warn(zero_note, KinsyncWarning, stacklevel=2)
    return ProfileScan(
        profile=profile,
        angle_rad=cols["angle_rad"],
        range_m=cols["range_m"],
        intensity=cols["intensity"],
        source=str(path),
    )


def write_profile_scan(
    scan: ProfileScan, path: Path, extra: dict[str, np.ndarray[Any, Any]] | None = None
) -> None:
    """Write a scan as CSV or Parquet (by suffix), atomically, floats exactly.

    Parameters
    ----------
    scan : ProfileScan
    path : Path
        ``.csv`` or ``.parquet``.
    extra : dict of str to ndarray, shape (N,), optional
        More columns written after the scan's four (e.g. truth for tests).
    """
    cols: dict[str, np.ndarray[Any, Any]] = {
        "profile": scan.profile,
        "angle_rad": scan.angle_rad,
        "range_m": scan.range_m,
        "intensity": scan.intensity,
    }
    for name, values in (extra or {}).items():
        if name in cols:
            msg = f"write_profile_scan: extra column {name!r} clashes with a scan column"
            raise InputError(msg)
        cols[name] = np.asarray(values)
    path = Path(path)
    if path.suffix.lower() == ".csv":
        # Arrow writes float64 in shortest round-trip form (exact) ten times faster than
        # formatting each value in Python; every scan column is read back as float64.
        table = pa.table({name: np.asarray(values) for name, values in cols.items()})
        with atomic_path(path) as tmp:
            pa_csv.write_csv(table, tmp, write_options=pa_csv.WriteOptions(quoting_style="needed"))
        return
    with TableChunkWriter(path) as writer:
        step = _READ_CHUNK
        for i in range(0, len(scan), step):
            writer.write({k: v[i : i + step] for k, v in cols.items()})


def _coordinates(path: Path, line: int, row: list[str], idx: dict[str, int]) -> list[float]:
    """``[lat_deg, lon_deg, h_m]`` of one sync-point row; errors name the line."""
    values: list[float] = []
    for col, span in zip(SYNC_POINT_COLUMNS[1:], _SYNC_SPANS, strict=True):
        cell = row[idx[col]].strip()
        try:
            value = float(cell)
        except ValueError:
            value = math.nan
        if not math.isfinite(value):
            msg = f"{path}: line {line}, column {col!r}: {cell[:80]!r} is not a finite number"
            raise InputError(msg)
        check_values([value], span, f"{path}: line {line}, column {col!r}")
        values.append(value)
    return values


def read_sync_points(path: Path) -> SyncPoints:
    """Read a ``name,lat_deg,lon_deg,h_m`` CSV of sync (or control) points.

    Raises
    ------
    InputError
        Missing or unreadable file, missing columns, ragged rows, a non-numeric,
        non-finite or implausible coordinate (`kinsync.io.sanity`: a latitude outside
        [-90, 90], a height beyond 100 km), empty or repeated names, no data rows (each
        naming the line).
    """
    path = Path(path)
    records = read_csv_rows(path)
    if not records:
        msg = f"{path}: empty file; expected a header {','.join(SYNC_POINT_COLUMNS)}"
        raise InputError(msg)
    header = [h.strip() for h in records[0][1]]
    missing = [c for c in SYNC_POINT_COLUMNS if c not in header]
    if missing:
        msg = f"{path}: missing column(s) {missing}; the header has {header}"
        raise InputError(msg)
    idx = {c: header.index(c) for c in SYNC_POINT_COLUMNS}
    names: list[str] = []
    llh: list[list[float]] = []
    lines: list[int] = []
    seen: dict[str, int] = {}
    for line, row in records[1:]:
        if len(row) != len(header):
            msg = f"{path}: line {line} has {len(row)} fields, the header has {len(header)}"
            raise InputError(msg)
        name = row[idx["name"]].strip()
        if not name:
            msg = f"{path}: line {line}: empty name"
            raise InputError(msg)
        if name in seen:
            msg = f"{path}: line {line}: name {name!r} already used on line {seen[name]}"
            raise InputError(msg)
        seen[name] = line
        names.append(name)
        lines.append(line)
        llh.append(_coordinates(path, line, row, idx))
    if not names:
        msg = f"{path}: no data rows after the header; give at least one point"
        raise InputError(msg)
    return SyncPoints(
        names=tuple(names), lat_lon_h=np.array(llh), source=str(path), lines=tuple(lines)
    )


def write_sync_points(points: SyncPoints, path: Path) -> None:
    """Write ``name,lat_deg,lon_deg,h_m`` (floats in ``repr`` precision), atomically."""
    with atomic_path(Path(path)) as tmp, tmp.open("w", encoding="utf-8", newline="") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(SYNC_POINT_COLUMNS)
        for name, row in zip(points.names, points.lat_lon_h.tolist(), strict=True):
            writer.writerow([name, *(repr(float(v)) for v in row)])


def read_pulses(path: Path) -> FloatArray:
    """Read hardware profile pulses: CSV column ``t_s`` (GPS time, s), strictly increasing.

    Returns
    -------
    ndarray, shape (P,)
        Pulse times (s), P >= 2.

    Raises
    ------
    InputError
        Missing file or column, a non-numeric, non-finite or implausible time
        (`kinsync.io.sanity.TIME_S`), fewer than two pulses, a repeated or decreasing
        time (naming the line).
    """
    table = read_numeric_csv(Path(path), ("t_s",))
    t = table.columns["t_s"]
    if t.size < 2:
        msg = f"{path}: {t.size} pulse(s); give one pulse time per profile (at least 2)"
        raise InputError(msg)
    check_values(t, TIME_S, lambda row: f"{path}: line {table.line_of_row(row)}, column 't_s'")
    step = np.diff(t)
    if np.any(step <= 0):
        row = int(np.flatnonzero(step <= 0)[0]) + 1
        line = table.line_of_row(row)
        msg = (
            f"{path}: line {line}: pulse time {t[row]!r} does not follow "
            f"{t[row - 1]!r}; pulse times must be strictly increasing"
            f"{cut_line_hint(Path(path), line)}"
        )
        raise InputError(msg)
    out: FloatArray = np.array(t, dtype=np.float64)
    return out


def pulse_line(path: Path) -> Callable[[int], str]:
    """``where(i)``: pulse i (0-based data row) of a pulses CSV as its file line, ``"line 7"``.

    For messages only (`kinsync.sync.pulses.pulse_offset`): the file is read up to the row
    when a message names one (empty lines count, as `read_pulses` skips them).
    """
    path = Path(path)
    return lambda i: f"line {csv_line_of_row(path, i) or i + 2}"


def write_pulses(t_s: ArrayLike, path: Path) -> None:
    """Write pulse times as a ``t_s`` CSV (exact floats), atomically."""
    write_numeric_csv(Path(path), {"t_s": np.asarray(t_s, dtype=np.float64)})


@dataclass(frozen=True)
class ClockFile:
    """A profile clock file: the clock and the mount it was fitted with.

    Attributes
    ----------
    t0_s, period_s : float
        The clock ``t(n, phi) = t0 + (n + phi / 2 pi) T`` (s).
    mount : ClockMount or None
        The mount values the clock was fitted with; None for a file without them (an
        older kinsync's, or one written by hand).
    """

    t0_s: float
    period_s: float
    mount: ClockMount | None


def read_clock_document(path: Path, *, accept_ambiguous: bool = False) -> tuple[float, float]:
    """Read ``(t0_s, period_s)`` from a JSON clock document (`read_clock_file`)."""
    clock = read_clock_file(path, accept_ambiguous=accept_ambiguous)
    return clock.t0_s, clock.period_s


def read_clock_file(path: Path, *, accept_ambiguous: bool = False) -> ClockFile:
    """Read a JSON clock document (e.g. object-space output), with its mount if recorded.

    A document marked ``"ambiguous": true`` (other matches of sightings to crossings fit
    almost as well: its t0 may be whole seconds off) is refused unless
    ``accept_ambiguous``.

    Raises
    ------
    InputError
        Missing or unreadable file, invalid JSON (line and column), not an object,
        missing keys, non-finite or implausible numbers (`kinsync.io.sanity`), a period
        outside 10 µs to 100 s, an ``ambiguous`` not true or false or ``alternatives``
        not a list, a ``mount`` that is not as object-space writes it, a key given twice,
        an ambiguous clock not accepted.
    """
    path = Path(path)
    if not path.exists() and not path.is_symlink():  # a link loop "does not exist" either
        msg = f"{path}: clock file not found; write it with kinsync sync object-space --json"
        raise InputError(msg)
    require_file(path, "clock file")  # a link loop, a pipe, a folder: named as such
    doc = load_json(path, "clock file")
    if not isinstance(doc, dict):
        msg = f"{path}: expected a JSON object with t0_s and period_s"
        raise InputError(msg)
    missing = [key for key in ("t0_s", "period_s") if key not in doc]
    if missing:
        keys = ", ".join(sorted(str(k) for k in doc)[:6]) or "none"
        msg = (
            f"{path}: not a profile clock: no {' or '.join(missing)} (its keys: {keys}); give "
            "the JSON that kinsync sync object-space --json writes"
        )
        raise InputError(msg)
    values = []
    for key, span in (("t0_s", TIME_S), ("period_s", _PERIOD_S)):
        value = doc.get(key)
        if isinstance(value, bool) or not isinstance(value, int | float):
            msg = f"{path}: {key!r} must be a finite number, got {str(value)[:80]}"
            raise InputError(msg)
        check_values([float(value)], span, f"{path}: {key!r}")
        values.append(float(value))
    for key, kind, what in (("ambiguous", bool, "true or false"), ("alternatives", list, "a list")):
        if key in doc and not isinstance(doc[key], kind):  # "true" would read as settled
            msg = f"{path}: {key!r} must be {what}, got {shown_value(doc[key])}"
            raise InputError(msg + "; give the JSON that kinsync sync object-space --json writes")
    if doc.get("ambiguous") is True and not accept_ambiguous:
        others = [a.get("t0_s") for a in doc.get("alternatives", []) if isinstance(a, dict)][:3]
        listed = ", ".join(f"{t:.6f}" for t in others if isinstance(t, int | float))
        msg = (
            f"{path}: the clock is marked ambiguous: other matches of sightings to sync-point "
            f"crossings fit almost as well{f' (t0 = {listed} s)' if listed else ''}, so its "
            "t0 may be whole seconds off; run kinsync sync object-space again with --pulses "
            "to settle it, or apply it anyway with --accept-ambiguous"
        )
        raise InputError(msg)
    return ClockFile(values[0], values[1], _clock_mount(path, doc.get("mount")))


def _clock_mount(path: Path, doc: object) -> ClockMount | None:
    """The ``mount`` entry of a clock file (None when absent or null), checked."""
    if doc is None:
        return None
    advice = "; give the JSON that kinsync sync object-space --json writes"
    if not isinstance(doc, dict):
        msg = f"{path}: 'mount' must be an object, got {shown_value(doc)}{advice}"
        raise InputError(msg)
    source = doc.get("path")
    if not isinstance(source, str):
        msg = f"{path}: 'mount' must name its file in 'path', got {shown_value(source)}{advice}"
        raise InputError(msg)

    def number(key: str, value: object) -> float:
        if isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value):
            return float(value)
        msg = f"{path}: 'mount' {key!r} must be a finite number, got {shown_value(value)}"
        raise InputError(msg + advice)

    def triple(key: str) -> tuple[float, float, float]:
        value = doc.get(key)
        if not isinstance(value, list) or len(value) != 3:
            msg = f"{path}: 'mount' {key!r} must be 3 numbers, got {shown_value(value)}"
            raise InputError(msg + advice)
        x, y, z = (number(key, v) for v in value)
        return x, y, z

    azimuth = doc.get("profiler_azimuth_deg")
    return ClockMount(
        source=source,
        latency_s=number("latency_s", doc.get("latency_s")),
        lever_arm_body_m=triple("lever_arm_body_m"),
        boresight_rpy_deg=triple("boresight_rpy_deg"),
        profiler_azimuth_deg=None if azimuth is None else number("profiler_azimuth_deg", azimuth),
    )
