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

**Georeferencing** the passes with the attitude log is done by
`kinsync.pipelines.raw_passes` (`kinsync.georef.table`); this module only reads.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from kinsync._typing import FloatArray
from kinsync.errors import InputError
from kinsync.frames import euler_rpy_to_quaternion
from kinsync.io.sanity import ANGLE_DEG, LENGTH_M, TIME_S, Span, check_columns
from kinsync.io.tables import NumericTable, read_numeric_csv
from kinsync.trajectory import Trajectory

__all__ = [
    "RAW_ATTITUDE_CSV",
    "RAW_DIR",
    "RAW_MOUNT_TOML",
    "RAW_ORIGIN_LAT_LON_H",
    "raw_pass_name",
    "read_raw_attitude",
    "read_raw_pass",
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


_SPANS: dict[str, Span] = {
    "t_s": TIME_S,
    **dict.fromkeys(("roll_deg", "pitch_deg", "yaw_deg"), ANGLE_DEG),
    **dict.fromkeys(("x_m", "y_m", "z_m"), LENGTH_M),
}
"""Plausible values of the raw files' columns (`kinsync.io.sanity`)."""


def _check_finite(table: NumericTable, columns: tuple[str, ...]) -> None:
    """Every cell of ``columns`` finite and plausible (`_SPANS`), naming the first bad one."""
    spans = {name: _SPANS[name] for name in columns}
    check_columns(
        table.columns, spans, lambda row: f"{table.source}: line {table.line_of_row(row)}"
    )


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
        Naming the file (and line): missing file or columns, a non-numeric,
        non-finite or implausible cell (`kinsync.io.sanity`), fewer than two records,
        repeated or decreasing tags.
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
        # Not Trajectory.from_euler, which refuses angles beyond a turn (degrees for
        # radians): a table's log may hold unwrapped angles (`ANGLE_DEG`).
        q = euler_rpy_to_quaternion(
            *(np.radians(table.columns[name]) for name in _ATTITUDE_COLUMNS[1:])
        )
        return Trajectory(
            t_s=t,
            q_body_to_ned=q,
            pos_ned_m=np.zeros((table.n_rows, 3)),
            origin_lat_lon_h=RAW_ORIGIN_LAT_LON_H,
        )
    except InputError as err:
        msg = f"{path}: {err}"
        raise InputError(msg) from err


def read_raw_pass(path: Path) -> tuple[FloatArray, FloatArray, NumericTable]:
    """Point times (N,), scanner-frame points (N, 3) and the table of one raw pass file."""
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
