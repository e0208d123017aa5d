"""Trajectory files of any supported type, with their time scale.

CSV (`kinsync.io.trajectory_csv`), SBET (`kinsync.io.sbet`), and the ASCII exports of
POSPac and Inertial Explorer (`kinsync.io.pos_text`), told apart by suffix: ``.csv``,
``.out``/``.sbet``, anything else is read as a text export (its header decides).
"""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Literal

from kinsync.errors import InputError
from kinsync.io.gps_week import check_not_future, holds_gps_time
from kinsync.io.pos_text import pos_text_takes_gps_week, read_pos_text, sniff_pos_text
from kinsync.io.sbet import read_sbet, sbet_holds_gps_time
from kinsync.io.trajectory_csv import read_trajectory_csv
from kinsync.trajectory import Trajectory

__all__ = [
    "TimeScale",
    "csv_first_time_s",
    "gps_week_needed_text",
    "read_trajectory_file",
    "trajectory_already_gps_time",
    "trajectory_file_format",
    "trajectory_takes_gps_week",
]

TimeScale = Literal["gps", "week"]
"""Time scale of a trajectory or point file: GPS time, or GPS seconds of week."""


def gps_week_needed_text(points: str, trajectory: TimeScale) -> str:
    """What to do when points and trajectory are on two time scales a GPS week joins.

    Parameters
    ----------
    points : str
        The points' time scale in words (``"adjusted standard GPS time"``).
    trajectory : {"gps", "week"}
        The trajectory's.
    """
    traj = "GPS seconds of week" if trajectory == "week" else "GPS time"
    return (
        f"the points carry {points}, the trajectory {traj}; give --gps-week so that kinsync "
        "can put both on GPS time"
    )


def read_trajectory_file(
    path: Path, *, gps_week: int | None = None
) -> tuple[Trajectory, TimeScale]:
    """Read a trajectory (CSV, SBET, POSPac/IE text export) and say its time scale.

    Parameters
    ----------
    path : Path
        ``.csv`` (`kinsync.io.trajectory_csv`), an SBET file (``.out``, ``.sbet``), or
        a POSPac / Inertial Explorer ASCII export (any other suffix, e.g. ``.txt``;
        `kinsync.io.pos_text`).
    gps_week : int, optional
        GPS week of an SBET's (or a text export's) first record: its seconds of week
        become GPS time. Not used for a file whose times already hold GPS time (beyond
        a week and a day, `kinsync.io.gps_week`).

    Returns
    -------
    trajectory : Trajectory
    time_scale : {"gps", "week"}
        "week" for an SBET or a text export without a week, holding seconds of week,
        read without ``gps_week`` (GPS seconds of week), else "gps".

    Raises
    ------
    InputError
        Unknown suffix, GPS times after today (most likely Unix time:
        `kinsync.io.gps_week.check_not_future`), or any error of the readers.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".csv":
        return read_trajectory_csv(path), "gps"
    if suffix in (".out", ".sbet"):
        traj = read_sbet(path, gps_week=gps_week)
        on_gps = gps_week is not None or holds_gps_time(traj.t_start_s)
        if on_gps:
            _check_not_future(path, traj)
        return traj, "gps" if on_gps else "week"
    try:
        traj, gps_time = read_pos_text(path, gps_week=gps_week)
    except InputError as err:
        if "not a recognised trajectory export" not in str(err) and "not a text file" not in str(
            err
        ):
            raise
        msg = (
            f"{err}. Trajectory files: .csv (t_s,lat_deg,lon_deg,h_m,roll_deg,pitch_deg,"
            "yaw_deg), an SBET (.out, .sbet), or a POSPac / Inertial Explorer text export"
        )
        raise InputError(msg) from err
    if gps_time:
        _check_not_future(path, traj)
    return traj, "gps" if gps_time else "week"


def _check_not_future(path: Path, traj: Trajectory) -> None:
    """Refuse a trajectory whose GPS times lie after today (Unix time, most likely)."""
    check_not_future(traj.t_s, lambda row: f"{path}: record {row + 1} (time {traj.t_s[row]!r} s)")


def trajectory_file_format(path: Path) -> Literal["csv", "sbet", "pospac", "inertial-explorer"]:
    """The kind of trajectory file `read_trajectory_file` reads ``path`` as.

    Raises
    ------
    InputError
        A text file whose layout is not recognised (see `kinsync.io.pos_text`).
    """
    suffix = Path(path).suffix.lower()
    if suffix == ".csv":
        return "csv"
    if suffix in (".out", ".sbet"):
        return "sbet"
    return sniff_pos_text(Path(path)).producer


def trajectory_takes_gps_week(path: Path) -> bool:
    """Whether a GPS week applies to this trajectory file (``--gps-week``).

    True for an SBET (GPS seconds of week) and a text export without a week column;
    False for a CSV (GPS time), a text export that gives its own week, and an SBET or
    text export whose times already hold GPS time (`kinsync.io.gps_week`). A file whose
    kind cannot be told is counted as taking one: its reader names what is wrong.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".csv":
        return False
    try:
        if suffix in (".out", ".sbet"):
            return not sbet_holds_gps_time(path)
        return pos_text_takes_gps_week(path)
    except InputError:
        return True


def trajectory_already_gps_time(path: Path) -> bool:
    """Whether an SBET or a text export without a week column stores GPS time itself.

    Its first time lies beyond a week and a day (`kinsync.io.gps_week`), so that no GPS
    week applies. False for a CSV, a text export with a week column, and a file that
    cannot be read (its reader names what is wrong).
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".csv":
        return False
    try:
        if suffix in (".out", ".sbet"):
            return sbet_holds_gps_time(path)
        return "week" not in sniff_pos_text(path).columns and not pos_text_takes_gps_week(path)
    except InputError:
        return False


def csv_first_time_s(path: Path) -> float | None:
    """The ``t_s`` of a trajectory CSV's first data row, for messages; None if unreadable.

    Parameters
    ----------
    path : Path
        A trajectory CSV (`kinsync.io.trajectory_csv`).
    """
    try:
        with Path(path).open(newline="", encoding="utf-8-sig", errors="replace") as fh:
            reader = csv.reader(fh)
            header = [h.strip() for h in next(reader, [])]
            if "t_s" not in header:
                return None
            column = header.index("t_s")
            for row in reader:
                if len(row) > column and row[column].strip():
                    return float(row[column])
    except (OSError, csv.Error, ValueError):
        return None
    return None
