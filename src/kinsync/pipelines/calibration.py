"""Mount self-calibration from files: point files and trajectories in, a mount out.

`read_scan_lines` turns point files (one per line or pass) and their trajectories
into `kinsync.calibration.lines.ScanLine` s, putting every file on one time scale:

- LAS/LAZ: scanner-frame ``x, y, z`` and ``gps_time`` (adjusted standard GPS time or
  GPS seconds of week, as the header says, `kinsync.io.las.las_time_offset_s`);
- CSV/Parquet: columns ``t_s,x_m,y_m,z_m`` (scanner frame), ``t_s`` on the
  trajectory's time scale;
- trajectories: CSV or SBET (`kinsync.io.trajectory.read_trajectory_file`), one for
  all files or one per file; an SBET's seconds of week become GPS time with
  ``gps_week``;
- CIDCO LidarToolkit pass files (``.txt``, `kinsync.io.cidco`): points, per-return
  times and the trajectory in one file, so no trajectory is given with them.

`calibrate_files` runs `kinsync.calibration.estimator.calibrate_mount` on them and
writes the calibrated mount (TOML) and the calibration certificate (HTML) atomically.
Every returned point of every file is used or accounted for: files must hold at
least one return; returns outside their trajectory, or in one of its data gaps
(``CalibrationOptions.max_gap_s``), are an error, never dropped silently.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from kinsync._typing import FloatArray
from kinsync.calibration.estimator import CalibrationOptions, calibrate_mount
from kinsync.calibration.lines import ScanLine
from kinsync.calibration.result import CalibrationResult
from kinsync.errors import InputError, PointValueError
from kinsync.io.cidco import cidco_scan_line, read_cidco_pass
from kinsync.io.las import (
    check_week_rollover,
    iter_las_chunks,
    las_info,
    las_time_offset_s,
    scaled_coordinates,
)
from kinsync.io.las_crs import georeferenced_crs_name
from kinsync.io.mount_file import write_mount
from kinsync.io.points import iter_table_chunks
from kinsync.io.row_position import point_position
from kinsync.io.trajectory import TimeScale, read_trajectory_file
from kinsync.mount import Mount
from kinsync.progress import Progress, part, report
from kinsync.trajectory import Trajectory

__all__ = ["CalibrationRun", "calibrate_files", "read_scan_lines"]

_LAS = (".las", ".laz")
_TABLES = (".csv", ".parquet")
_CIDCO = ".txt"
_CHUNK = 1_000_000
_XYZ = ("x_m", "y_m", "z_m")

READ_SHARE = 0.1
"""The share of `calibrate_files`' work its progress gives to reading the files."""


@dataclass(frozen=True, eq=False)
class CalibrationRun:
    """What `calibrate_files` did.

    Attributes
    ----------
    result : CalibrationResult
    lines : tuple of ScanLine
        The lines read.
    n_points : int
        Returns read over all files.
    mount_path, report_path : Path or None
        Files written.
    """

    result: CalibrationResult
    lines: tuple[ScanLine, ...]
    n_points: int
    mount_path: Path | None
    report_path: Path | None


def _read_las(
    path: Path, traj_scale: TimeScale, gps_week: int | None
) -> tuple[FloatArray, FloatArray]:
    info = las_info(path)
    offset = las_time_offset_s(info, traj_scale, gps_week, needed_by="the calibration")
    ts, xs = [], []
    for chunk in iter_las_chunks(path, _CHUNK):
        ts.append(np.asarray(chunk.gps_time, dtype=np.float64) + offset)
        xs.append(scaled_coordinates(chunk.array, chunk.scales, chunk.offsets))
    if not ts:
        return np.empty(0), np.empty((0, 3))
    t = np.concatenate(ts)
    if t.size and np.all(np.isfinite(t)):
        check_week_rollover(info, float(t.min()) - offset, float(t.max()) - offset, gps_week)
    return t, np.concatenate(xs)


def _read_table(path: Path) -> tuple[FloatArray, FloatArray]:
    ts, xs = [], []
    for cols in iter_table_chunks(path, _CHUNK, ("t_s", *_XYZ)):
        ts.append(np.asarray(cols["t_s"], dtype=np.float64))
        xs.append(np.column_stack([cols[c] for c in _XYZ]).astype(np.float64))
    if not ts:
        return np.empty(0), np.empty((0, 3))
    return np.concatenate(ts), np.concatenate(xs)


def _bad_return_text(path: Path, err: PointValueError, total: int) -> str:
    """A bad return of a points file, by CSV line, Parquet row or LAS point, and column.

    A LAS/LAZ file whose header gives a map or earth CRS, with coordinates out of a
    scanner's reach, is said to be georeferenced already.
    """
    advice = err.advice
    if path.suffix.lower() in _LAS:
        column = "gps_time" if err.field == "t" else err.field
        crs = georeferenced_crs_name(las_info(path).crs_wkt) if err.field != "t" else None
        if crs is not None and "beyond the" in err.problem:
            advice = (
                f"this file is already georeferenced ({crs}); --points takes points in the "
                "scanner frame"
            )
    else:
        column = {"t": "t_s", "x": "x_m", "y": "y_m", "z": "z_m"}[err.field]
    return (
        f"{path}: {point_position(path, err.index, total)}, column {column!r}: {err.problem}; "
        f"{err.count} such point(s) in the file: {advice}"
    )


def read_scan_lines(
    points: Sequence[Path],
    trajectories: Sequence[Path],
    *,
    gps_week: int | None = None,
) -> tuple[ScanLine, ...]:
    """Read one `ScanLine` per point file.

    Parameters
    ----------
    points : sequence of Path
        Scanner-frame point files (LAS/LAZ, CSV, Parquet), one per line or pass; or
        CIDCO pass files (``.txt``), which carry their own trajectory.
    trajectories : sequence of Path
        One trajectory for all files, or one per file (same order); none with CIDCO
        pass files.
    gps_week : int, optional
        GPS week of SBET seconds-of-week times and of LAS files in seconds of week.

    Raises
    ------
    InputError
        Unknown file types, a count of trajectories that is neither 1 nor the count of
        point files, a file given twice (also under another name: a link), empty or
        unreadable files, non-finite values (naming the file).
    """
    points = [Path(p) for p in points]
    trajectories = [Path(t) for t in trajectories]
    if not points:
        msg = "give at least one points file (--points)"
        raise InputError(msg)
    _refuse_repeated(points)
    cidco = [p for p in points if p.suffix.lower() == _CIDCO]
    if cidco:
        return _read_cidco(points, cidco, trajectories)
    if len(trajectories) not in (1, len(points)):
        msg = (
            f"{len(trajectories)} trajectories for {len(points)} point files: give one "
            "trajectory for all, or one per points file in the same order"
        )
        raise InputError(msg)
    loaded: dict[Path, tuple[Trajectory, TimeScale]] = {}
    lines = []
    for i, path in enumerate(points):
        tpath = trajectories[0 if len(trajectories) == 1 else i]
        if tpath not in loaded:
            loaded[tpath] = read_trajectory_file(tpath, gps_week=gps_week)
        traj, scale = loaded[tpath]
        suffix = path.suffix.lower()
        if suffix in _LAS:
            t, xyz = _read_las(path, scale, gps_week)
        elif suffix in _TABLES:
            t, xyz = _read_table(path)
        else:
            msg = (
                f"{path}: unknown points file type {path.suffix!r}; use .las, .laz, .csv, "
                ".parquet or a CIDCO pass file (.txt)"
            )
            raise InputError(msg)
        if t.size == 0:
            msg = f"{path}: no returns in the file"
            raise InputError(msg)
        try:
            lines.append(ScanLine(path.name, t, xyz, traj))
        except PointValueError as err:  # the index is the file's row: say it as the file does
            raise InputError(_bad_return_text(path, err, t.size)) from err
        except InputError as err:
            msg = f"{path}: {err}"
            raise InputError(msg) from err
    names = [ln.name for ln in lines]
    if len(set(names)) != len(names):
        lines = [
            ScanLine(str(p), ln.t_s, ln.xyz_scanner_m, ln.trajectory)
            for p, ln in zip(points, lines, strict=True)
        ]
    return tuple(lines)


def _refuse_repeated(points: Sequence[Path]) -> None:
    """Refuse a points file given twice, under its own name or another (a link).

    Raises
    ------
    InputError
        Naming the file (and its other name) and saying to give each line once.
    """
    seen: dict[object, int] = {}
    for i, path in enumerate(points):
        try:
            st = path.stat()
        except OSError:  # a missing file: its reader names it
            key: object = path
        else:
            key = (st.st_dev, st.st_ino)
        first = points[seen.setdefault(key, i)]
        if seen[key] == i:
            continue
        same = "" if first == path else f" (the same file as {first})"
        msg = (
            f"{path}: given twice in --points{same}; a line counted twice would weigh "
            "double in the calibration: give each line once"
        )
        raise InputError(msg)


def _read_cidco(
    points: Sequence[Path], cidco: Sequence[Path], trajectories: Sequence[Path]
) -> tuple[ScanLine, ...]:
    """CIDCO pass files: each its own line and trajectory (DIN 9300 attitude)."""
    if len(cidco) != len(points) or trajectories:
        msg = (
            f"{cidco[0]}: CIDCO pass files (.txt) carry their own trajectory; give them "
            "alone, without --trajectory and without other point files"
        )
        raise InputError(msg)
    return tuple(cidco_scan_line(read_cidco_pass(path)) for path in points)


def calibrate_files(
    points: Sequence[Path],
    trajectories: Sequence[Path],
    mount: Mount,
    options: CalibrationOptions,
    *,
    gps_week: int | None = None,
    mount_out: Path | None = None,
    report_out: Path | None = None,
    write_report: Callable[[CalibrationResult, Path], None] | None = None,
    progress: Progress | None = None,
    mount_source: Path | None = None,
) -> CalibrationRun:
    """Read the files, calibrate, write the calibrated mount and the certificate.

    Parameters
    ----------
    points, trajectories, gps_week
        As in `read_scan_lines`.
    mount : Mount
        The mount the data were acquired with (start and prior values).
    options : CalibrationOptions
    mount_out : Path, optional
        Where to write the calibrated mount (TOML, atomically).
    report_out : Path, optional
        Where to write the certificate, with ``write_report``.
    write_report : callable, optional
        ``write_report(result, path)``: the report layer's writer (the pipeline knows
        no report format).
    progress : Progress, optional
        ``progress(fraction, stage)`` (`kinsync.progress.Progress`): reading the files
        takes the first `READ_SHARE` of the work, the calibration the rest.
    mount_source : Path, optional
        The file ``mount`` was read from: the written mount says so, with what produced
        it and that file's header comments (`kinsync.io.mount_file.write_mount`).

    Returns
    -------
    CalibrationRun
    """
    report(progress, 0.0, f"reading {len(points)} point files")
    lines = read_scan_lines(points, trajectories, gps_week=gps_week)
    result = calibrate_mount(lines, mount, options, progress=part(progress, READ_SHARE, 1.0))
    if mount_out is not None:
        write_mount(result.mount, Path(mount_out), derived_from=mount_source)
    if report_out is not None and write_report is not None:
        write_report(result, Path(report_out))
    return CalibrationRun(
        result=result,
        lines=lines,
        n_points=sum(len(ln) for ln in lines),
        mount_path=None if mount_out is None else Path(mount_out),
        report_path=None if report_out is None or write_report is None else Path(report_out),
    )
