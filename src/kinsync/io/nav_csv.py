"""Navigation solution and truth trajectory CSV files.

**Solution** (`write_nav_csv` / `read_nav_csv`), one row per IMU epoch::

    t_s,lat_deg,lon_deg,h_m,vn_m_s,ve_m_s,vd_m_s,roll_deg,pitch_deg,yaw_deg
    std_n_m,std_e_m,std_d_m,std_vn_m_s,std_ve_m_s,std_vd_m_s,
    std_roll_deg,std_pitch_deg,std_yaw_deg
    gyro_bias_x_rad_s,gyro_bias_y_rad_s,gyro_bias_z_rad_s,
    acc_bias_x_m_s2,acc_bias_y_m_s2,acc_bias_z_m_s2,
    std_gyro_bias_x_rad_s,std_gyro_bias_y_rad_s,std_gyro_bias_z_rad_s,
    std_acc_bias_x_m_s2,std_acc_bias_y_m_s2,std_acc_bias_z_m_s2
    [gyro_scale_x_ppm,...,acc_scale_z_ppm,std_gyro_scale_x_ppm,...,std_acc_scale_z_ppm]

The twelve scale factor columns are written when the filter modelled scale factors
and read when present (all twelve or none).

Position: WGS84 geodetic of the IMU reference point; velocity over the Earth in NED;
attitude DIN 9300 roll, pitch, yaw (deg) body -> NED; biases in the body frame.

The filter's attitude σ is the σ of the **misorientation about the N, E and D axes**;
the columns ``std_roll_deg, std_pitch_deg, std_yaw_deg`` hold those three values as
they are. This is an approximation of the Euler-angle σ: roll and pitch σ equal the N
and E values only at yaw 0 (in general each mixes both through the heading, and the
cross-covariances are not kept), and yaw σ equals the D value for small pitch. Kept
this way the file reads back into exactly the filter's quantities, which
`kinsync.ins.compare` tests against the misorientation about N, E, D.

``smoothed`` and the GNSS counts of a `NavSolution` are not stored; `read_nav_csv`
returns False and 0 for them.

**Truth / plain trajectory**: the first ten columns without σ (the NaveGo ``truth.csv``
layout), read by `read_truth_csv` into a `Trajectory` with velocities through
`kinsync.io.trajectory_csv.read_trajectory_csv` (which reads these columns by name, in
any order, velocities optional).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from kinsync._typing import FloatArray
from kinsync.errors import InputError
from kinsync.ins.solution import NavSolution
from kinsync.io.sanity import (
    ACCELERATION_M_S2,
    ANGLE_DEG,
    ANGULAR_RATE_RAD_S,
    LENGTH_M,
    SPEED_M_S,
    Span,
    check_columns,
    check_text_file,
)
from kinsync.io.sbet import read_sbet, sbet_holds_gps_time
from kinsync.io.tables import NumericTable, read_numeric_csv, write_numeric_csv
from kinsync.io.text_lines import csv_header_row
from kinsync.io.trajectory_csv import SPANS, read_trajectory_csv
from kinsync.trajectory import Trajectory

__all__ = [
    "NAV_BIAS_COLUMNS",
    "NAV_COLUMNS",
    "NAV_SCALE_COLUMNS",
    "NAV_STD_COLUMNS",
    "navigation_takes_gps_week",
    "read_nav_csv",
    "read_navigation",
    "read_truth_csv",
    "write_nav_csv",
    "write_truth_csv",
]

NAV_COLUMNS = (
    "t_s",
    "lat_deg",
    "lon_deg",
    "h_m",
    "vn_m_s",
    "ve_m_s",
    "vd_m_s",
    "roll_deg",
    "pitch_deg",
    "yaw_deg",
)
"""State columns (also the truth layout)."""

NAV_STD_COLUMNS = (
    "std_n_m",
    "std_e_m",
    "std_d_m",
    "std_vn_m_s",
    "std_ve_m_s",
    "std_vd_m_s",
    "std_roll_deg",
    "std_pitch_deg",
    "std_yaw_deg",
)
"""1σ columns of position, velocity and attitude (misorientation about N, E, D)."""

NAV_BIAS_COLUMNS = tuple(
    f"{prefix}{kind}_bias_{axis}_{unit}"
    for prefix in ("", "std_")
    for kind, unit in (("gyro", "rad_s"), ("acc", "m_s2"))
    for axis in "xyz"
)
"""Bias estimates (turn-on plus instability) and their 1σ, body frame."""

NAV_SCALE_COLUMNS = tuple(
    f"{prefix}{kind}_scale_{axis}_ppm"
    for prefix in ("", "std_")
    for kind in ("gyro", "acc")
    for axis in "xyz"
)
"""Scale factor estimates and their 1σ (ppm), optional."""

_SBET_SUFFIXES = (".sbet", ".out")


def _triple(c: dict[str, FloatArray], names: tuple[str, ...]) -> FloatArray:
    return np.column_stack([c[n] for n in names])


def write_nav_csv(solution: NavSolution, path: Path) -> None:
    """Write a navigation solution with σ and biases as CSV, atomically.

    Parameters
    ----------
    solution : NavSolution
        Solution at the IMU rate.
    path : Path
        Output file (columns in the module docstring; floats in round-trip precision).
    """
    rpy_deg = np.degrees(solution.rpy_rad)
    cols: dict[str, FloatArray] = {
        "t_s": solution.t_s,
        "lat_deg": solution.lat_deg,
        "lon_deg": solution.lon_deg,
        "h_m": solution.h_m,
    }
    blocks: list[tuple[tuple[str, ...], FloatArray]] = [
        (NAV_COLUMNS[4:7], solution.vel_ned_m_s),
        (NAV_COLUMNS[7:10], rpy_deg),
        (NAV_STD_COLUMNS[0:3], solution.std_pos_ned_m),
        (NAV_STD_COLUMNS[3:6], solution.std_vel_ned_m_s),
        (NAV_STD_COLUMNS[6:9], np.degrees(solution.std_att_rad)),
        (NAV_BIAS_COLUMNS[0:3], solution.gyro_bias_rad_s),
        (NAV_BIAS_COLUMNS[3:6], solution.acc_bias_m_s2),
        (NAV_BIAS_COLUMNS[6:9], solution.std_gyro_bias_rad_s),
        (NAV_BIAS_COLUMNS[9:12], solution.std_acc_bias_m_s2),
    ]
    scales = (
        solution.gyro_scale_ppm,
        solution.acc_scale_ppm,
        solution.std_gyro_scale_ppm,
        solution.std_acc_scale_ppm,
    )
    if all(a is not None for a in scales):
        blocks += [
            (NAV_SCALE_COLUMNS[3 * i : 3 * i + 3], a) for i, a in enumerate(scales) if a is not None
        ]
    n = len(solution)
    for names, arr in blocks:
        a = np.asarray(arr, dtype=np.float64)
        if a.shape != (n, 3):
            msg = f"write_nav_csv: {names} expected shape ({n}, 3), got {a.shape}"
            raise InputError(msg)
        for i, name in enumerate(names):
            cols[name] = a[:, i]
    write_numeric_csv(Path(path), cols)


_SPANS: dict[str, Span] = {
    **SPANS,
    **{n: LENGTH_M.positive(0.0, "a position standard deviation") for n in NAV_STD_COLUMNS[0:3]},
    **{n: SPEED_M_S.positive(0.0, "a velocity standard deviation") for n in NAV_STD_COLUMNS[3:6]},
    **{n: ANGLE_DEG.positive(0.0, "an attitude standard deviation") for n in NAV_STD_COLUMNS[6:9]},
    **dict.fromkeys(NAV_BIAS_COLUMNS[0:3], ANGULAR_RATE_RAD_S),
    **dict.fromkeys(NAV_BIAS_COLUMNS[3:6], ACCELERATION_M_S2),
    **{
        n: ANGULAR_RATE_RAD_S.positive(0.0, "a gyro bias standard deviation")
        for n in NAV_BIAS_COLUMNS[6:9]
    },
    **{
        n: ACCELERATION_M_S2.positive(0.0, "an accelerometer bias standard deviation")
        for n in NAV_BIAS_COLUMNS[9:12]
    },
    **dict.fromkeys(NAV_SCALE_COLUMNS[0:6], Span(-1e6, 1e6, "ppm", "a scale factor")),
    **{
        n: Span(0.0, 1e6, "ppm", "a scale factor standard deviation")
        for n in NAV_SCALE_COLUMNS[6:12]
    },
}
"""Plausible values of each column of a solution (`kinsync.io.sanity`)."""


def _check_solution_table(table: NumericTable) -> None:
    """Finite, plausible cells (σ >= 0), strictly increasing times (naming lines)."""
    c = table.columns
    check_columns(c, _SPANS, lambda row: f"{table.source}: line {table.line_of_row(row)}")
    dt = np.diff(c["t_s"])
    if (dt <= 0.0).any():
        row = int(np.flatnonzero(dt <= 0.0)[0]) + 1
        kind = "repeated" if dt[row - 1] == 0.0 else "decreasing"
        msg = (
            f"{table.source}: line {table.line_of_row(row)}: {kind} time t_s="
            f"{c['t_s'][row]!r}; times must increase strictly"
        )
        raise InputError(msg)


def read_nav_csv(path: Path) -> NavSolution:
    """Read a solution CSV written by `write_nav_csv` (every column required).

    Parameters
    ----------
    path : Path
        CSV file.

    Returns
    -------
    NavSolution
        With ``smoothed=False`` and GNSS counts 0 (not stored in the file).

    Raises
    ------
    InputError
        Missing file or columns, a non-numeric, non-finite or implausible cell
        (`kinsync.io.sanity`: a latitude outside [-90, 90], a negative σ, ...), fewer
        than 2 rows, repeated or decreasing times (each naming the line).
    """
    path = Path(path)
    table = read_numeric_csv(path, NAV_COLUMNS + NAV_STD_COLUMNS + NAV_BIAS_COLUMNS)
    if table.n_rows < 2:
        msg = f"{path}: a navigation solution needs at least 2 records, found {table.n_rows}"
        raise InputError(msg)
    _check_solution_table(table)
    c = table.columns
    present = [name in c for name in NAV_SCALE_COLUMNS]
    if any(present) and not all(present):
        missing = [name for name, here in zip(NAV_SCALE_COLUMNS, present, strict=True) if not here]
        msg = f"{path}: give all twelve scale factor columns or none; missing {missing}"
        raise InputError(msg)
    scales = [
        _triple(c, NAV_SCALE_COLUMNS[3 * i : 3 * i + 3]) if all(present) else None for i in range(4)
    ]
    return NavSolution(
        t_s=c["t_s"],
        lat_deg=c["lat_deg"],
        lon_deg=c["lon_deg"],
        h_m=c["h_m"],
        vel_ned_m_s=_triple(c, NAV_COLUMNS[4:7]),
        rpy_rad=np.radians(_triple(c, NAV_COLUMNS[7:10])),
        std_pos_ned_m=_triple(c, NAV_STD_COLUMNS[0:3]),
        std_vel_ned_m_s=_triple(c, NAV_STD_COLUMNS[3:6]),
        std_att_rad=np.radians(_triple(c, NAV_STD_COLUMNS[6:9])),
        gyro_bias_rad_s=_triple(c, NAV_BIAS_COLUMNS[0:3]),
        acc_bias_m_s2=_triple(c, NAV_BIAS_COLUMNS[3:6]),
        std_gyro_bias_rad_s=_triple(c, NAV_BIAS_COLUMNS[6:9]),
        std_acc_bias_m_s2=_triple(c, NAV_BIAS_COLUMNS[9:12]),
        gyro_scale_ppm=scales[0],
        acc_scale_ppm=scales[1],
        std_gyro_scale_ppm=scales[2],
        std_acc_scale_ppm=scales[3],
    )


def read_truth_csv(path: Path) -> Trajectory:
    """Read a truth trajectory (``t_s,lat_deg,lon_deg,h_m,vn_m_s,ve_m_s,vd_m_s,roll_deg,...``).

    Parameters
    ----------
    path : Path
        CSV with the ten `NAV_COLUMNS` (any order; extra columns ignored).

    Returns
    -------
    Trajectory
        Geodetic, attitude from DIN 9300 Euler angles, with NED velocities.

    Raises
    ------
    InputError
        As `kinsync.io.trajectory_csv.read_trajectory_csv`, and when the velocity
        columns are absent.
    """
    path = Path(path)
    traj = read_trajectory_csv(path)
    if traj.vel_ned_m_s is None:
        msg = f"{path}: a truth trajectory needs the velocity columns vn_m_s,ve_m_s,vd_m_s"
        raise InputError(msg)
    return traj


def write_truth_csv(trajectory: Trajectory, path: Path) -> None:
    """Write a geodetic trajectory with velocities in the truth layout, atomically.

    Columns ``t_s,lat_deg,lon_deg,h_m,vn_m_s,ve_m_s,vd_m_s,roll_deg,pitch_deg,yaw_deg``
    (the NaveGo ``truth.csv`` layout); `read_truth_csv` reads it back exactly.

    Raises
    ------
    InputError
        A local-NED trajectory or one without velocities.
    """
    if trajectory.lat_lon_h is None or trajectory.vel_ned_m_s is None:
        msg = "write_truth_csv: the trajectory needs geodetic positions and NED velocities"
        raise InputError(msg)
    llh, vel = trajectory.lat_lon_h, trajectory.vel_ned_m_s
    rpy = np.degrees(trajectory.euler_rpy_rad())
    write_numeric_csv(
        Path(path),
        {
            "t_s": trajectory.t_s,
            "lat_deg": llh[:, 0],
            "lon_deg": llh[:, 1],
            "h_m": llh[:, 2],
            "vn_m_s": vel[:, 0],
            "ve_m_s": vel[:, 1],
            "vd_m_s": vel[:, 2],
            "roll_deg": rpy[:, 0],
            "pitch_deg": rpy[:, 1],
            "yaw_deg": rpy[:, 2],
        },
    )


def _csv_header(path: Path) -> list[str]:
    check_text_file(path, "navigation CSV file")
    return [h.strip() for h in csv_header_row(path) or []]


def navigation_takes_gps_week(path: Path) -> bool:
    """Whether a GPS week applies to this navigation file (`read_navigation`).

    An SBET holding GPS seconds of week, not one whose times already hold GPS time
    (`kinsync.io.sbet.sbet_holds_gps_time`); an SBET that cannot be read counts as
    taking one (its reader names what is wrong).
    """
    if Path(path).suffix.lower() not in _SBET_SUFFIXES:
        return False
    try:
        return not sbet_holds_gps_time(Path(path))
    except InputError:
        return True


def read_navigation(path: Path, *, gps_week: int | None = None) -> NavSolution | Trajectory:
    """Read a navigation file of any kind kinsync writes, by suffix and header.

    Parameters
    ----------
    path : Path
        ``.sbet``/``.out`` (SBET, see `kinsync.io.sbet.read_sbet`), or ``.csv``: a
        solution with σ (any σ column in the header -> `read_nav_csv`), otherwise a
        trajectory (`read_trajectory_csv`, velocities optional).
    gps_week : int, optional
        GPS week of SBET seconds-of-week times, to put them on GPS time.

    Returns
    -------
    NavSolution or Trajectory
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix in _SBET_SUFFIXES:
        return read_sbet(path, gps_week=gps_week)
    if suffix != ".csv":
        msg = f"{path}: unknown navigation file type {suffix!r}; expected .csv, .sbet or .out"
        raise InputError(msg)
    header = _csv_header(path)
    if any(h in NAV_STD_COLUMNS for h in header):
        return read_nav_csv(path)
    return read_trajectory_csv(path)
