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
    object-space --json`` prints): ``t(n, phi) = t0_s + (n + phi / 2 pi) period_s``.
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.csv as pa_csv

from kinsync._typing import ArrayLike, FloatArray, IntArray
from kinsync.errors import InputError
from kinsync.frames import geodetic_to_ecef
from kinsync.io.atomic import atomic_path
from kinsync.io.points import TableChunkWriter, iter_table_chunks
from kinsync.io.tables import read_csv_rows, read_numeric_csv, write_numeric_csv
from kinsync.mount import Mount

__all__ = [
    "APPLY_COLUMNS",
    "SCAN_COLUMNS",
    "SYNC_POINT_COLUMNS",
    "ProfileScan",
    "SyncPoints",
    "apply_profile_clock",
    "check_profile_numbers",
    "read_clock_document",
    "read_profile_scan",
    "read_pulses",
    "read_sync_points",
    "write_profile_scan",
    "write_pulses",
    "write_sync_points",
]

SCAN_COLUMNS = ("profile", "angle_rad", "range_m", "intensity")
APPLY_COLUMNS = ("t_s", "x_m", "y_m", "z_m")
"""Columns `apply_profile_clock` adds: time (s) and scanner-frame coordinates (m)."""
SYNC_POINT_COLUMNS = ("name", "lat_deg", "lon_deg", "h_m")
_READ_CHUNK = 1 << 20


def _row_text(row: int, line_offset: int | None) -> str:
    """``row 5`` or ``row 5 (line 7)`` when rows map to file lines."""
    return f"row {row}" if line_offset is None else f"row {row} (line {row + line_offset})"


def check_profile_numbers(
    profile: ArrayLike, source: str, line_offset: int | None = None, row_offset: int = 0
) -> IntArray:
    """Profile numbers as int64: whole, >= 0 and never decreasing.

    Parameters
    ----------
    profile : array_like, shape (N,)
        Profile number of each return.
    source : str
        Name used in messages (file path).
    line_offset : int, optional
        File line of data row 0 (2 for a CSV with a header), to name lines.
    row_offset : int
        Data row of ``profile[0]`` (for chunks of a longer table).

    Raises
    ------
    InputError
        Naming the first row that is not finite, not whole, negative or smaller than
        the row before.
    """
    p = np.asarray(profile, dtype=np.float64)
    bad = ~np.isfinite(p) | (p != np.round(p)) | (p < 0)
    if np.any(bad):
        row = int(np.flatnonzero(bad)[0])
        msg = (
            f"{source}: column 'profile', {_row_text(row + row_offset, line_offset)}: "
            f"{p[row]!r} is not a profile number (a whole number >= 0)"
        )
        raise InputError(msg)
    down = np.diff(p) < 0
    if np.any(down):
        row = int(np.flatnonzero(down)[0]) + 1
        msg = (
            f"{source}: column 'profile', {_row_text(row + row_offset, line_offset)}: profile "
            f"number {int(p[row])} after {int(p[row - 1])}; profile numbers must not decrease "
            "(returns in acquisition order): sort the scan by profile, keeping the order "
            "within each profile"
        )
        raise InputError(msg)
    return p.astype(np.int64)


def _finite_column(values: ArrayLike, name: str, n: int, source: str) -> FloatArray:
    arr = np.asarray(values, dtype=np.float64)
    if arr.shape != (n,):
        msg = f"{source}: column {name!r} has shape {arr.shape}, expected ({n},) like 'profile'"
        raise InputError(msg)
    bad = ~np.isfinite(arr)
    if np.any(bad):
        row = int(np.flatnonzero(bad)[0])
        msg = f"{source}: column {name!r}, row {row}: {arr[row]!r} is not a finite number"
        raise InputError(msg)
    out = np.array(arr, dtype=np.float64, copy=True)
    out.setflags(write=False)
    return out


@dataclass(frozen=True, eq=False)
class ProfileScan:
    """Returns of a 2D profile scanner, without times (SPEC section 4).

    Attributes
    ----------
    profile : ndarray of int64, shape (N,)
        Profile number n of each return, >= 0, never decreasing.
    angle_rad : ndarray, shape (N,)
        Mirror angle phi from nadir, positive towards the scanner's +Y (rad).
    range_m : ndarray, shape (N,)
        Range (m), >= 0.
    intensity : ndarray, shape (N,)
        Return intensity (unit of the scanner).
    source : str
        Where the scan came from (file path), for messages.
    """

    profile: IntArray
    angle_rad: FloatArray
    range_m: FloatArray
    intensity: FloatArray
    source: str = "<scan>"

    def __post_init__(self) -> None:
        prof = check_profile_numbers(self.profile, self.source)
        n = prof.size
        if prof.ndim != 1 or n == 0:
            msg = f"{self.source}: the scan has no returns; expected columns {list(SCAN_COLUMNS)}"
            raise InputError(msg)
        prof.setflags(write=False)
        object.__setattr__(self, "profile", prof)
        for name in ("angle_rad", "range_m", "intensity"):
            object.__setattr__(
                self, name, _finite_column(getattr(self, name), name, n, self.source)
            )
        neg = self.range_m < 0
        if np.any(neg):
            row = int(np.flatnonzero(neg)[0])
            msg = f"{self.source}: column 'range_m', row {row}: negative range {self.range_m[row]}"
            raise InputError(msg)

    def __len__(self) -> int:
        return int(self.profile.size)

    @property
    def n_profiles(self) -> int:
        """Profiles spanned, ``last profile number + 1`` (profiles without returns count)."""
        return int(self.profile[-1]) + 1


def read_profile_scan(path: Path) -> ProfileScan:
    """Read a scan table (``.csv`` or ``.parquet``) with ``profile,angle_rad,range_m,intensity``.

    Other columns are ignored here (``kinsync sync apply`` carries them through).

    Raises
    ------
    InputError
        Missing file or columns, a non-numeric cell, or a bad profile number (naming the
        row and, for CSV, the line).
    """
    path = Path(path)
    parts: dict[str, list[FloatArray]] = {c: [] for c in SCAN_COLUMNS}
    for chunk in iter_table_chunks(path, _READ_CHUNK, SCAN_COLUMNS):
        for c in SCAN_COLUMNS:
            parts[c].append(chunk[c])
    if not parts["profile"] or sum(a.size for a in parts["profile"]) == 0:
        msg = f"{path}: the scan has no data rows; expected columns {list(SCAN_COLUMNS)}"
        raise InputError(msg)
    cols = {c: np.concatenate(v) for c, v in parts.items()}
    line_offset = 2 if path.suffix.lower() == ".csv" else None
    profile = check_profile_numbers(cols["profile"], str(path), line_offset)
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


@dataclass(frozen=True, eq=False)
class SyncPoints:
    """Named targets with known WGS84 coordinates (sync points or control points).

    Attributes
    ----------
    names : tuple of str
        Unique, non-empty names.
    lat_lon_h : ndarray, shape (K, 3)
        Latitude (deg), longitude (deg), ellipsoidal height (m) of each target centre.
    source : str
        Where they came from (file path), for messages.
    """

    names: tuple[str, ...]
    lat_lon_h: FloatArray
    source: str = "<sync points>"

    def __post_init__(self) -> None:
        names = tuple(str(n) for n in self.names)
        llh = np.asarray(self.lat_lon_h, dtype=np.float64)
        if llh.ndim != 2 or llh.shape[1] != 3 or llh.shape[0] != len(names):
            msg = (
                f"{self.source}: expected one (lat_deg, lon_deg, h_m) row per name "
                f"({len(names)} names), got shape {llh.shape}"
            )
            raise InputError(msg)
        if not names:
            msg = f"{self.source}: no points; expected rows of {','.join(SYNC_POINT_COLUMNS)}"
            raise InputError(msg)
        for i, name in enumerate(names):
            if not name.strip():
                msg = f"{self.source}: point {i} has an empty name"
                raise InputError(msg)
            if names.count(name) > 1:
                msg = f"{self.source}: name {name!r} appears more than once; names must be unique"
                raise InputError(msg)
        bad = ~np.all(np.isfinite(llh), axis=1) | (np.abs(llh[:, 0]) > 90.0)
        if np.any(bad):
            i = int(np.flatnonzero(bad)[0])
            msg = (
                f"{self.source}: point {names[i]!r}: lat/lon/h {llh[i].tolist()} is not a "
                "finite WGS84 position with latitude in [-90, 90]"
            )
            raise InputError(msg)
        llh = llh.copy()
        llh.setflags(write=False)
        object.__setattr__(self, "names", names)
        object.__setattr__(self, "lat_lon_h", llh)

    def __len__(self) -> int:
        return len(self.names)

    def pos_ecef_m(self) -> FloatArray:
        """Target centres in ECEF (m), shape (K, 3)."""
        return geodetic_to_ecef(self.lat_lon_h[:, 0], self.lat_lon_h[:, 1], self.lat_lon_h[:, 2])


def _coordinates(path: Path, line: int, row: list[str], idx: dict[str, int]) -> list[float]:
    """``[lat_deg, lon_deg, h_m]`` of one sync-point row; errors name the line."""
    values: list[float] = []
    for col in SYNC_POINT_COLUMNS[1:]:
        cell = row[idx[col]].strip()
        try:
            value = float(cell)
        except ValueError:
            value = math.nan
        if not math.isfinite(value):
            msg = f"{path}: line {line}, column {col!r}: {cell!r} is not a finite number"
            raise InputError(msg)
        values.append(value)
    if abs(values[0]) > 90.0:
        msg = f"{path}: line {line}: latitude {values[0]} outside [-90, 90]"
        raise InputError(msg)
    return values


def read_sync_points(path: Path) -> SyncPoints:
    """Read a ``name,lat_deg,lon_deg,h_m`` CSV of sync (or control) points.

    Raises
    ------
    InputError
        Missing or unreadable file, missing columns, ragged rows, a non-numeric or
        non-finite coordinate, a latitude outside [-90, 90], empty or repeated names,
        no data rows (each naming the line).
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
        llh.append(_coordinates(path, line, row, idx))
    if not names:
        msg = f"{path}: no data rows after the header; give at least one point"
        raise InputError(msg)
    return SyncPoints(names=tuple(names), lat_lon_h=np.array(llh), source=str(path))


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
        Missing file or column, a non-numeric or non-finite time, fewer than two
        pulses, a repeated or decreasing time (naming the line).
    """
    table = read_numeric_csv(Path(path), ("t_s",))
    t = table.columns["t_s"]
    if t.size < 2:
        msg = f"{path}: {t.size} pulse(s); give one pulse time per profile (at least 2)"
        raise InputError(msg)
    bad = ~np.isfinite(t)
    if np.any(bad):
        row = int(np.flatnonzero(bad)[0])
        msg = f"{path}: line {table.line_of_row(row)}, column 't_s': not a finite time"
        raise InputError(msg)
    step = np.diff(t)
    if np.any(step <= 0):
        row = int(np.flatnonzero(step <= 0)[0]) + 1
        msg = (
            f"{path}: line {table.line_of_row(row)}: pulse time {t[row]!r} does not follow "
            f"{t[row - 1]!r}; pulse times must be strictly increasing"
        )
        raise InputError(msg)
    out: FloatArray = np.array(t, dtype=np.float64)
    return out


def write_pulses(t_s: ArrayLike, path: Path) -> None:
    """Write pulse times as a ``t_s`` CSV (exact floats), atomically."""
    write_numeric_csv(Path(path), {"t_s": np.asarray(t_s, dtype=np.float64)})


def read_clock_document(path: Path) -> tuple[float, float]:
    """Read ``(t0_s, period_s)`` from a JSON clock document (e.g. object-space output).

    Raises
    ------
    InputError
        Missing or unreadable file, invalid JSON (line and column), not an object,
        missing keys, non-finite numbers or a period <= 0.
    """
    path = Path(path)
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError as err:
        msg = f"{path}: clock file not found; write it with kinsync sync object-space --json"
        raise InputError(msg) from err
    except (OSError, UnicodeDecodeError) as err:
        msg = f"{path}: cannot read clock file ({err})"
        raise InputError(msg) from err
    except json.JSONDecodeError as err:
        msg = f"{path}: line {err.lineno}, column {err.colno}: not valid JSON ({err.msg})"
        raise InputError(msg) from err
    if not isinstance(doc, dict):
        msg = f"{path}: expected a JSON object with t0_s and period_s"
        raise InputError(msg)
    values = []
    for key in ("t0_s", "period_s"):
        value = doc.get(key)
        if (
            isinstance(value, bool)
            or not isinstance(value, int | float)
            or not math.isfinite(float(value))
        ):
            msg = f"{path}: {key!r} must be a finite number, got {value!r}"
            raise InputError(msg)
        values.append(float(value))
    if values[1] <= 0.0:
        msg = f"{path}: 'period_s' must be > 0, got {values[1]!r}"
        raise InputError(msg)
    return values[0], values[1]


def apply_profile_clock(
    scan_path: Path,
    out_path: Path,
    t0_s: float,
    period_s: float,
    mount: Mount,
    *,
    chunk_points: int = 1_000_000,
    progress: Callable[[int], None] | None = None,
) -> int:
    """Time-tag a scan and put its returns in the scanner frame, streaming in chunks.

    Each return gets ``t_s = t0_s + (profile + angle_rad / 2 pi) period_s`` and
    ``(x_m, y_m, z_m) = Rz(azimuth) (0, r sin phi, r cos phi)`` (the mount's
    ``[profiler] azimuth_deg``), appended after every input column (all kept), ready
    for ``kinsync georef --points``.

    Parameters
    ----------
    scan_path : Path
        Scan table (``.csv`` / ``.parquet``) with ``profile,angle_rad,range_m``.
    out_path : Path
        Output table (``.csv`` / ``.parquet``), written atomically.
    t0_s, period_s : float
        The profile clock (s).
    mount : Mount
        Needs ``[profiler] azimuth_deg``.
    chunk_points : int
        Rows per chunk.
    progress : callable, optional
        Called with the number of rows done after each chunk.

    Returns
    -------
    int
        Rows written.

    Raises
    ------
    InputError
        A mount without ``[profiler]``, a bad clock, an input that already has one of
        the output columns, bad profile numbers (naming the row), unreadable files.
    """
    if mount.profiler_azimuth_deg is None:
        msg = (
            "mount: no [profiler] azimuth_deg; the scanner-frame coordinates of a profile "
            "need the profile plane's azimuth: add a [profiler] table with azimuth_deg"
        )
        raise InputError(msg)
    if not (math.isfinite(t0_s) and math.isfinite(period_s) and period_s > 0.0):
        msg = f"clock: t0_s must be finite and period_s > 0, got {t0_s!r}, {period_s!r}"
        raise InputError(msg)
    scan_path = Path(scan_path)
    required = ("profile", "angle_rad", "range_m")
    done = 0
    last_profile = 0.0
    line_offset = 2 if scan_path.suffix.lower() == ".csv" else None
    with TableChunkWriter(Path(out_path)) as writer:
        for chunk in iter_table_chunks(scan_path, chunk_points, required):
            clash = [c for c in APPLY_COLUMNS if c in chunk]
            if clash:
                msg = (
                    f"{scan_path}: already has column(s) {clash}; rename them, sync apply "
                    f"adds {list(APPLY_COLUMNS)}"
                )
                raise InputError(msg)
            if done == 0:
                check_profile_numbers(chunk["profile"], str(scan_path), line_offset)
            else:
                check_profile_numbers(
                    np.concatenate([[last_profile], chunk["profile"]]),
                    str(scan_path),
                    line_offset,
                    row_offset=done - 1,
                )
            last_profile = float(chunk["profile"][-1])
            phi = chunk["angle_rad"]
            rng_m = chunk["range_m"]
            bad = ~(np.isfinite(phi) & np.isfinite(rng_m))
            if np.any(bad):
                row = int(np.flatnonzero(bad)[0])
                msg = f"{scan_path}: data row {done + row}: angle_rad or range_m is not finite"
                raise InputError(msg)
            xyz = mount.profile_to_scanner(phi, rng_m)
            out = dict(chunk)
            out["t_s"] = t0_s + (chunk["profile"] + phi / (2.0 * math.pi)) * period_s
            out["x_m"], out["y_m"], out["z_m"] = xyz[:, 0], xyz[:, 1], xyz[:, 2]
            writer.write(out)
            done += phi.size
            if progress is not None:
                progress(done)
    return done
