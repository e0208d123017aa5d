"""Raw input of Method A: scanner-frame passes, attitude log and mount (SPEC sections 2, 5).

A pass folder written with raw data (``write_simulation(..., raw=True)``, or by hand
from a real acquisition) holds, beside the georeferenced passes of `kinsync.io.passes`::

    passes.csv              file,rate_deg_s[,axis_n,axis_e,axis_d]   (pass order, rates)
    raw/pass_000.csv        t_s,x_m,y_m,z_m     scanner frame (m), point times (s)
    raw/attitude.csv        t_s,roll_deg,pitch_deg,yaw_deg   IMU records at their tags
    raw/mount.toml          lever arm, boresight scanner -> body, latency (`kinsync.mount`)

**Naming rule.** The raw pass of the ``passes.csv`` line whose ``file`` is ``F`` is
``raw/F`` with its extension replaced by ``.csv`` (``pass_000.laz`` ->
``raw/pass_000.csv``), which is how `write_simulation` names them. The georeferenced
pass file itself need not exist: only its name, rate and axis are read.

**Frames.** Attitude angles are DIN 9300 roll, pitch, yaw (deg) of body (FRD) -> the
table-centred NED frame; the IMU sits on the table, so positions are zero (the table
centre). The attitude log becomes a local `Trajectory` with zero positions about the
nominal origin `RAW_ORIGIN_LAT_LON_H`, which attitude-only georeferencing never uses.

**Georeferencing.** A point ``x_s`` measured at ``t`` goes to the table-centred NED
frame as ``x_n = R_body_to_ned(t) @ (lever_arm_body_m + R_scanner_to_body @ x_s)`` with
the attitude of the log corrected for the latency tau (SPEC section 1): the record
tagged ``t + tau`` is read, ``attitude.corrected_for_latency(tau).interpolate(t)``.
Nothing is extrapolated: a point outside the corrected log's span is an error.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from kinsync._typing import ArrayLike, FloatArray
from kinsync.errors import InputError
from kinsync.georef import validated_scanner_points
from kinsync.io.mount_file import read_mount
from kinsync.io.passes import PASSES_CSV, _read_index
from kinsync.io.tables import NumericTable, read_numeric_csv
from kinsync.latency.passes import SpherePass
from kinsync.mount import Mount
from kinsync.trajectory import Trajectory

__all__ = [
    "RAW_ATTITUDE_CSV",
    "RAW_DIR",
    "RAW_MOUNT_TOML",
    "RAW_ORIGIN_LAT_LON_H",
    "georeference_table_points",
    "raw_pass_name",
    "read_raw_attitude",
    "read_raw_passes",
]

RAW_DIR = "raw"
"""Sub-folder of a pass folder holding the raw input."""
RAW_ATTITUDE_CSV = "attitude.csv"
"""Attitude log in the raw folder: ``t_s,roll_deg,pitch_deg,yaw_deg``."""
RAW_MOUNT_TOML = "mount.toml"
"""Mount (system calibration) in the raw folder."""
RAW_ORIGIN_LAT_LON_H = (0.0, 0.0, 0.0)
"""Nominal geodetic origin of the table-centred attitude trajectory (unused by Method A)."""

_ATTITUDE_COLUMNS = ("t_s", "roll_deg", "pitch_deg", "yaw_deg")
_RAW_PASS_COLUMNS = ("t_s", "x_m", "y_m", "z_m")


def _read_table(path: Path, columns: tuple[str, ...]) -> NumericTable:
    """`read_numeric_csv`, a header-only file coming back empty without a numpy warning."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="loadtxt: input contained no data")
        return read_numeric_csv(path, required=columns)


def raw_pass_name(file: str) -> str:
    """Raw pass file (relative to the raw folder) of a ``passes.csv`` ``file`` entry.

    The extension is replaced by ``.csv``: ``pass_000.laz`` -> ``pass_000.csv``.
    """
    return Path(file).with_suffix(".csv").as_posix()


def _first_nonfinite_line(table: NumericTable, columns: tuple[str, ...]) -> str | None:
    """``"line L, column 'c'"`` of the first non-finite cell, or None."""
    for row in range(table.n_rows):
        for name in columns:
            if not np.isfinite(table.columns[name][row]):
                return f"line {table.line_of_row(row)}, column {name!r}"
    return None


def _check_finite(table: NumericTable, columns: tuple[str, ...]) -> None:
    data = np.column_stack([table.columns[c] for c in columns])
    if not np.all(np.isfinite(data)):
        where = _first_nonfinite_line(table, columns)
        msg = f"{table.source}: {where}: not a finite number"
        raise InputError(msg)


def read_raw_attitude(path: Path) -> Trajectory:
    """Read a raw attitude log into a table-centred attitude trajectory.

    Parameters
    ----------
    path : Path
        CSV with ``t_s,roll_deg,pitch_deg,yaw_deg``: record tags (s, as logged, not
        corrected for latency) and DIN 9300 body (FRD) -> NED Euler angles (deg).

    Returns
    -------
    Trajectory
        Local NED trajectory with zero positions (the table centre) about
        `RAW_ORIGIN_LAT_LON_H`; attitude from the angles.

    Raises
    ------
    InputError
        Naming the file (and line): missing file or columns, a non-numeric or
        non-finite cell, fewer than two records, repeated or decreasing tags.
    """
    path = Path(path)
    if not path.is_file():
        msg = f"{path}: attitude log not found; the raw folder needs {RAW_ATTITUDE_CSV} with " + (
            ",".join(_ATTITUDE_COLUMNS)
        )
        raise InputError(msg)
    table = _read_table(path, _ATTITUDE_COLUMNS)
    if table.n_rows < 2:
        msg = f"{path}: {table.n_rows} attitude record(s); at least 2 are needed"
        raise InputError(msg)
    _check_finite(table, _ATTITUDE_COLUMNS)
    t = table.columns["t_s"]
    dt = np.diff(t)
    if np.any(dt <= 0.0):
        row = int(np.flatnonzero(dt <= 0.0)[0]) + 1
        kind = "repeated" if dt[row - 1] == 0.0 else "decreasing"
        msg = (
            f"{path}: line {table.line_of_row(row)}: {kind} time t_s={float(t[row])!r} "
            f"after {float(t[row - 1])!r}; record tags must be strictly increasing"
        )
        raise InputError(msg)
    try:
        return Trajectory.from_euler(
            t,
            np.radians(table.columns["roll_deg"]),
            np.radians(table.columns["pitch_deg"]),
            np.radians(table.columns["yaw_deg"]),
            pos_ned_m=np.zeros((table.n_rows, 3)),
            origin_lat_lon_h=RAW_ORIGIN_LAT_LON_H,
        )
    except InputError as err:
        msg = f"{path}: {err}"
        raise InputError(msg) from err


def _georeference(t: FloatArray, xs: FloatArray, corrected: Trajectory, mount: Mount) -> FloatArray:
    """Kernel on validated input, attitude already on the scanner's time scale."""
    R_body_to_ned = corrected.interpolate(t).R_body_to_ned
    x_body = mount.lever_arm_body_m_array + xs @ mount.R_scanner_to_body.T
    out: FloatArray = np.einsum("nij,nj->ni", R_body_to_ned, x_body)
    return out


def georeference_table_points(
    t_s: ArrayLike, points_scanner_m: ArrayLike, attitude: Trajectory, mount: Mount
) -> FloatArray:
    """Georeference scanner points into the table-centred NED frame (attitude only).

    ``x_ned = R_body_to_ned(t) @ (lever_arm_body_m + R_scanner_to_body @ x_scanner)``,
    the attitude read from ``attitude.corrected_for_latency(mount.latency_s)`` at the
    point times, i.e. from the record tagged ``t + tau`` (SPEC section 1). Positions of
    the trajectory are not used: the table centre is the origin.

    Parameters
    ----------
    t_s : array_like, shape (N,)
        Point times (s), the scanner's time scale.
    points_scanner_m : array_like, shape (N, 3)
        Points in the scanner frame (m).
    attitude : Trajectory
        Attitude records at their tags (body FRD -> table-centred NED), not yet
        corrected for latency.
    mount : Mount
        Lever arm (m, body), boresight scanner -> body and latency tau (s).

    Returns
    -------
    ndarray, shape (N, 3)
        Points in the table-centred NED frame (m).

    Raises
    ------
    InputError
        Mismatched shapes or non-finite input.
    OutsideSpanError
        A point time outside the corrected attitude span (never extrapolated).
    """
    t, xs = validated_scanner_points(t_s, points_scanner_m, "georeference_table_points")
    corrected = attitude.corrected_for_latency(mount.latency_s)
    return _georeference(t, xs, corrected, mount)


def _read_raw_pass(path: Path) -> tuple[FloatArray, FloatArray, NumericTable]:
    if not path.is_file():
        msg = f"{path}: raw pass file not found"
        raise InputError(msg)
    table = _read_table(path, _RAW_PASS_COLUMNS)
    if table.n_rows == 0:
        msg = f"{path}: the raw pass holds no points"
        raise InputError(msg)
    _check_finite(table, _RAW_PASS_COLUMNS)
    t = table.columns["t_s"]
    xs = np.column_stack([table.columns[c] for c in ("x_m", "y_m", "z_m")])
    return t, xs, table


def read_raw_passes(folder: Path, *, latency_s: float | None = None) -> list[SpherePass]:
    """Read and georeference the raw passes of a pass folder (Method A, raw input).

    Parameters
    ----------
    folder : Path
        Pass folder holding ``passes.csv`` (pass order, signed rates, axes) and the
        ``raw/`` sub-folder (``attitude.csv``, ``mount.toml`` and one
        ``t_s,x_m,y_m,z_m`` scanner-frame file per pass, named by `raw_pass_name`).
    latency_s : float, optional
        Latency tau (s) to correct the attitude for (SPEC section 1: tau > 0 reads the
        record tagged ``t + tau``); default the mount's ``latency_s``.

    Returns
    -------
    list of SpherePass
        In the order of ``passes.csv``: points georeferenced into the table-centred
        NED frame (m) with their times (s); ``source`` is the raw pass file.

    Raises
    ------
    InputError
        Naming the file and line at fault: a missing folder, ``raw/`` folder,
        ``passes.csv``, ``attitude.csv``, ``mount.toml`` or raw pass file; missing
        columns; non-numeric or non-finite cells; attitude tags not increasing; an
        empty pass; a point time outside the latency-corrected attitude span.
    """
    folder = Path(folder)
    if not folder.is_dir():
        what = "is not a folder" if folder.exists() else "not found"
        msg = f"{folder}: pass folder {what}; give the folder that holds {PASSES_CSV}"
        raise InputError(msg)
    index_path = folder / PASSES_CSV
    rows = _read_index(index_path)
    raw_dir = folder / RAW_DIR
    if not raw_dir.is_dir():
        msg = (
            f"{raw_dir}: raw folder not found; it must hold {RAW_ATTITUDE_CSV}, "
            f"{RAW_MOUNT_TOML} and one t_s,x_m,y_m,z_m file per pass"
        )
        raise InputError(msg)
    attitude_path = raw_dir / RAW_ATTITUDE_CSV
    attitude = read_raw_attitude(attitude_path)
    mount = read_mount(raw_dir / RAW_MOUNT_TOML)
    tau = mount.latency_s if latency_s is None else float(latency_s)
    if not np.isfinite(tau):
        msg = f"latency_s must be finite, got {latency_s!r}"
        raise InputError(msg)
    corrected = attitude.corrected_for_latency(tau)
    passes: list[SpherePass] = []
    for row in rows:
        where = f"{index_path}: line {row.line}"
        path = raw_dir / raw_pass_name(row.file)
        try:
            t, xs, table = _read_raw_pass(path)
            outside = ~corrected.contains(t)
            if np.any(outside):
                k = int(np.flatnonzero(outside)[0])
                msg = (
                    f"{path}: line {table.line_of_row(k)}: point time t_s={float(t[k])!r} "
                    f"({int(np.count_nonzero(outside))} point(s) in all) lies outside the "
                    f"attitude log {attitude_path} (tags [{attitude.t_start_s!r}, "
                    f"{attitude.t_end_s!r}] s, read at the tag t + tau with latency "
                    f"tau = {tau!r} s); "
                    "kinsync does not extrapolate: extend the log or trim the pass"
                )
                raise InputError(msg)
            passes.append(
                SpherePass(
                    source=str(path),
                    rate_deg_s=row.rate_deg_s,
                    points_ned_m=_georeference(t, xs, corrected, mount),
                    axis_ned=row.axis_ned,
                    t_s=t,
                )
            )
        except InputError as err:
            msg = f"{where}: {err}"
            raise InputError(msg) from err
    return passes
