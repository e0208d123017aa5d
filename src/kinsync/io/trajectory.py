"""Trajectory files of any supported type (CSV, SBET), with their time scale."""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from kinsync.errors import InputError
from kinsync.io.sbet import read_sbet
from kinsync.io.trajectory_csv import read_trajectory_csv
from kinsync.trajectory import Trajectory

__all__ = ["TimeScale", "read_trajectory_file"]

TimeScale = Literal["gps", "week"]
"""Time scale of a trajectory or point file: GPS time, or GPS seconds of week."""


def read_trajectory_file(
    path: Path, *, gps_week: int | None = None
) -> tuple[Trajectory, TimeScale]:
    """Read a trajectory (CSV, or SBET ``.out``/``.sbet``) and say its time scale.

    Parameters
    ----------
    path : Path
        ``.csv`` (`kinsync.io.trajectory_csv`), or an SBET file (``.out``, ``.sbet``).
    gps_week : int, optional
        GPS week of an SBET's first record: its seconds of week become GPS time.

    Returns
    -------
    trajectory : Trajectory
    time_scale : {"gps", "week"}
        "week" for an SBET read without ``gps_week`` (GPS seconds of week), else "gps".

    Raises
    ------
    InputError
        Unknown suffix, or any error of the readers.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".csv":
        return read_trajectory_csv(path), "gps"
    if suffix in (".out", ".sbet"):
        return read_sbet(path, gps_week=gps_week), ("week" if gps_week is None else "gps")
    msg = f"{path}: unknown trajectory type {path.suffix!r}; use .csv or an SBET (.out, .sbet)"
    raise InputError(msg)
