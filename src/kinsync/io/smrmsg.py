"""Applanix ``smrmsg`` files: the accuracy (RMS) companion of an SBET.

POSPac writes, beside a smoothed trajectory ``sbet_<name>.out``, its estimated
accuracy ``smrmsg_<name>.out``: a headerless sequence of 80-byte records, each 10
little-endian float64 (usually one record per second):

====  =============================  =================================================
 #    field (`SMRMSG_DTYPE` name)    meaning
====  =============================  =================================================
 0    ``time_sow_s``                 GPS seconds of week (s)
 1-3  ``std_{north,east,down}_m``    position RMS error, North, East, Down (m)
 4-6  ``std_vel_{n,e,d}_m_s``        velocity RMS error, North, East, Down (m/s)
 7    ``std_roll_arcmin``            roll RMS error (arc minutes)
 8    ``std_pitch_arcmin``           pitch RMS error (arc minutes)
 9    ``std_heading_arcmin``         heading RMS error (arc minutes)
====  =============================  =================================================

Applanix publishes no specification; the layout above is what three independent public
readers agree on: PDAL's ``readers.smrmsg`` (``io/SbetSmrmsgReader.cpp``: 10 little-endian
doubles per record, GpsTime then North/East/Down position RMS, North/East/Down velocity
RMS, Roll/Pitch/Heading RMS; file length a multiple of 80 bytes, checked against a real
file in ``test/unit/io/SmrmsgReaderTest.cpp``), NOAA's ``HSTB/drivers/sbet.py``
(noaa-ocs-hydrography/drivers: same order, attitude "arc minutes", converted with
``/ 60`` to degrees) and the NAVO PFM/ABE ``FilePOSOutput`` RMS reader (same order,
attitude multiplied by an arc-to-degree factor, and the ``SBET`` -> ``SMRMSG`` name
swap used below). PDAL's test file has roll/pitch ~0.24 and heading ~3.0 in these
fields, plausible as arc minutes (0.004 and 0.05 deg), not as degrees or radians.

The values are RMS errors of the smoothed solution, used here as 1-sigma standard
deviations.

Companion file
--------------
`find_smrmsg_companion` looks beside an SBET for, in order: the name with its leading
``sbet`` replaced by ``smrmsg`` in any letter case (``sbet_mission1.out`` ->
``smrmsg_mission1.out``, ``SBET_A.OUT`` -> ``SMRMSG_A.OUT``, the POSPac convention),
then the single file of the folder named ``smrmsg*.out`` (any case) when there is
exactly one. Nothing else is guessed.

Time scale
----------
As for SBET (`kinsync.io.sbet`): GPS seconds of week unless ``gps_week`` is given;
times beyond a week and a day are GPS time already and are read as they are.
Records are returned in file order (some exports are not time-sorted).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from kinsync._arrays import ReadOnlyArrays
from kinsync._typing import FloatArray
from kinsync.errors import InputError
from kinsync.io.gps_week import SECONDS_PER_WEEK, holds_gps_time
from kinsync.io.records import memmap_records, write_records
from kinsync.io.sanity import (
    ANGLE_DEG,
    LENGTH_M,
    SECONDS_OF_WEEK_S,
    SPEED_M_S,
    TIME_S,
    Span,
    check_columns,
)
from kinsync.io.sbet import seconds_of_first_week

__all__ = [
    "SMRMSG_DTYPE",
    "SMRMSG_RECORD_BYTES",
    "SmrmsgData",
    "find_smrmsg_companion",
    "read_smrmsg",
    "read_smrmsg_records",
    "smrmsg_companion_path",
    "write_smrmsg",
]

SMRMSG_DTYPE: np.dtype[np.void] = np.dtype(
    [
        ("time_sow_s", "<f8"),
        ("std_north_m", "<f8"),
        ("std_east_m", "<f8"),
        ("std_down_m", "<f8"),
        ("std_vel_n_m_s", "<f8"),
        ("std_vel_e_m_s", "<f8"),
        ("std_vel_d_m_s", "<f8"),
        ("std_roll_arcmin", "<f8"),
        ("std_pitch_arcmin", "<f8"),
        ("std_heading_arcmin", "<f8"),
    ]
)
"""One smrmsg record: 10 little-endian float64 (80 bytes), names carrying units."""

SMRMSG_RECORD_BYTES = SMRMSG_DTYPE.itemsize
"""Size of one smrmsg record (80 bytes)."""

_ARCMIN_TO_RAD = math.pi / (180.0 * 60.0)
_FIELDS = len(SMRMSG_DTYPE.names or ())
_SPANS: dict[str, Span] = {
    "time_sow_s": TIME_S,
    **dict.fromkeys(
        ("std_north_m", "std_east_m", "std_down_m"),
        LENGTH_M.positive(0.0, "a position standard deviation"),
    ),
    **dict.fromkeys(
        ("std_vel_n_m_s", "std_vel_e_m_s", "std_vel_d_m_s"),
        SPEED_M_S.positive(0.0, "a velocity standard deviation"),
    ),
    **dict.fromkeys(
        ("std_roll_arcmin", "std_pitch_arcmin", "std_heading_arcmin"),
        Span(0.0, 60.0 * ANGLE_DEG.high, "arcmin", "an attitude standard deviation"),
    ),
}
"""Plausible values of each field (`kinsync.io.sanity`)."""


def _float_block(value: object, shape: tuple[int, ...], name: str) -> FloatArray:
    try:
        arr = np.array(value, dtype=np.float64)
    except (TypeError, ValueError) as err:
        msg = f"SmrmsgData.{name}: expected numbers ({err})"
        raise InputError(msg) from err
    if arr.shape != shape:
        msg = f"SmrmsgData.{name}: expected shape {shape}, got {arr.shape}"
        raise InputError(msg)
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, eq=False)
class SmrmsgData(ReadOnlyArrays):
    """Accuracy of a smoothed trajectory, one row per smrmsg record.

    Attributes
    ----------
    t_s : ndarray, shape (N,)
        Record times (s): GPS seconds of week, or GPS time when read with a week.
    std_pos_ned_m : ndarray, shape (N, 3)
        Position standard deviation North, East, Down (m).
    std_vel_ned_m_s : ndarray, shape (N, 3)
        Velocity standard deviation North, East, Down (m/s).
    std_rpy_rad : ndarray, shape (N, 3)
        Roll, pitch, heading standard deviation (rad).

    Raises
    ------
    InputError
        Mismatched shapes, non-finite values or negative standard deviations (naming
        the first bad row).
    """

    t_s: FloatArray
    std_pos_ned_m: FloatArray
    std_vel_ned_m_s: FloatArray
    std_rpy_rad: FloatArray

    def __post_init__(self) -> None:
        t = np.array(self.t_s, dtype=np.float64)
        if t.ndim != 1:
            msg = f"SmrmsgData.t_s: expected a 1-D array, got shape {t.shape}"
            raise InputError(msg)
        n = t.size
        t.setflags(write=False)
        object.__setattr__(self, "t_s", t)
        for name in ("std_pos_ned_m", "std_vel_ned_m_s", "std_rpy_rad"):
            object.__setattr__(self, name, _float_block(getattr(self, name), (n, 3), name))
        table = np.column_stack([t, self.std_pos_ned_m, self.std_vel_ned_m_s, self.std_rpy_rad])
        bad = ~np.all(np.isfinite(table), axis=1)
        if np.any(bad):
            row = int(np.flatnonzero(bad)[0])
            msg = f"SmrmsgData row {row}: non-finite value(s) {table[row].tolist()}"
            raise InputError(msg)
        negative = np.any(table[:, 1:] < 0.0, axis=1)
        if np.any(negative):
            row = int(np.flatnonzero(negative)[0])
            msg = f"SmrmsgData row {row}: negative standard deviation(s) {table[row, 1:].tolist()}"
            raise InputError(msg)

    def __len__(self) -> int:
        return int(self.t_s.size)


def read_smrmsg_records(path: Path) -> np.memmap[tuple[int], np.dtype[np.void]]:
    """Memory-map the raw records of an smrmsg file (read-only).

    Returns
    -------
    numpy.memmap, shape (N,), dtype `SMRMSG_DTYPE`
        The records as stored; nothing converted or validated beyond the length.

    Raises
    ------
    InputError
        Missing or empty file, or a length that is not a multiple of 80 bytes.
    """
    return memmap_records(
        path,
        SMRMSG_DTYPE,
        "smrmsg",
        "the file is truncated or not an smrmsg file (an SBET has 136-byte records)",
    )


def read_smrmsg(path: Path, *, gps_week: int | None = None) -> SmrmsgData:
    """Read an smrmsg file (memory-mapped) into `SmrmsgData`.

    Parameters
    ----------
    path : Path
        smrmsg file.
    gps_week : int, optional
        GPS week of the first record: times become ``gps_week * 604800 + sow``; not used
        when the times already hold GPS time (a first time beyond a week and a day,
        `kinsync.io.gps_week.holds_gps_time`), as in `kinsync.io.sbet.read_sbet`.

    Returns
    -------
    SmrmsgData
        Attitude converted from arc minutes to radians.

    Raises
    ------
    InputError
        A truncated or empty file, non-finite or implausible values, a negative RMS, a
        negative time in a file of seconds of week (naming the file and the record,
        0-based, with its byte offset).
    """
    path = Path(path)
    if gps_week is not None and gps_week < 0:
        msg = f"{path}: gps_week must be >= 0, got {gps_week}"
        raise InputError(msg)
    rec = read_smrmsg_records(path)
    values = np.array(rec.view("<f8").reshape(len(rec), _FIELDS), dtype=np.float64)
    del rec  # closes the map
    of_week = len(values) > 0 and not holds_gps_time(float(values[0, 0]))
    check_columns(
        dict(zip(SMRMSG_DTYPE.names or (), values.T, strict=True)),
        _SPANS | {"time_sow_s": SECONDS_OF_WEEK_S} if of_week else _SPANS,
        lambda i: f"{path}: record {i} (byte {i * SMRMSG_RECORD_BYTES})",
    )
    t = values[:, 0]
    if gps_week is not None and not (len(t) and holds_gps_time(float(t[0]))):
        t = gps_week * SECONDS_PER_WEEK + t
    try:
        return SmrmsgData(
            t_s=t,
            std_pos_ned_m=values[:, 1:4],
            std_vel_ned_m_s=values[:, 4:7],
            std_rpy_rad=values[:, 7:10] * _ARCMIN_TO_RAD,
        )
    except InputError as err:
        text = re.sub(
            r"\bSmrmsgData row (\d+)\b",
            lambda m: f"record {m.group(1)} (byte {int(m.group(1)) * SMRMSG_RECORD_BYTES})",
            str(err),
        )
        msg = f"{path}: {text}"
        raise InputError(msg) from err


def write_smrmsg(data: SmrmsgData, path: Path) -> None:
    """Write `SmrmsgData` as an smrmsg file, atomically.

    Times below 604800 s are written as they are; larger (continuous GPS) times as
    seconds of the first record's week, as `kinsync.io.sbet.write_sbet` does. Attitude
    is written in arc minutes.
    """
    path = Path(path)
    rec = np.zeros(len(data), dtype=SMRMSG_DTYPE)
    rec["time_sow_s"] = seconds_of_first_week(data.t_s)
    for i, name in enumerate(("std_north_m", "std_east_m", "std_down_m")):
        rec[name] = data.std_pos_ned_m[:, i]
    for i, name in enumerate(("std_vel_n_m_s", "std_vel_e_m_s", "std_vel_d_m_s")):
        rec[name] = data.std_vel_ned_m_s[:, i]
    for i, name in enumerate(("std_roll_arcmin", "std_pitch_arcmin", "std_heading_arcmin")):
        rec[name] = data.std_rpy_rad[:, i] / _ARCMIN_TO_RAD
    write_records(rec, path)


def smrmsg_companion_path(sbet_path: Path) -> Path:
    """Where to write the smrmsg of an SBET: the name `find_smrmsg_companion` tries first.

    Parameters
    ----------
    sbet_path : Path
        The SBET file.

    Returns
    -------
    Path
        Beside it: ``smrmsg<rest>`` for ``sbet<rest>`` (``SMRMSG<rest>`` for
        ``SBET<rest>``, the POSPac convention); for any other name
        ``smrmsg_<stem>.out``, which `find_smrmsg_companion` finds only as the only
        ``smrmsg*.out`` of the folder.
    """
    sbet_path = Path(sbet_path)
    name = sbet_path.name
    if name.lower().startswith("sbet"):
        prefix = "SMRMSG" if name[:4].isupper() else "smrmsg"
        return sbet_path.with_name(prefix + name[4:])
    return sbet_path.with_name(f"smrmsg_{sbet_path.stem}.out")


def find_smrmsg_companion(sbet_path: Path) -> Path | None:
    """The smrmsg file that goes with an SBET, or None (see the module docstring).

    Parameters
    ----------
    sbet_path : Path
        The SBET file.

    Returns
    -------
    Path or None
        ``smrmsg<rest>`` for ``sbet<rest>`` (any letter case) when it exists, else the
        only ``smrmsg*.out`` of the folder, else None.
    """
    sbet_path = Path(sbet_path)
    folder = sbet_path.parent
    try:
        entries = [p for p in folder.iterdir() if p.is_file()]
    except OSError:
        return None
    name = sbet_path.name
    if name.lower().startswith("sbet"):
        wanted = ("smrmsg" + name[4:]).lower()
        same = [p for p in entries if p.name.lower() == wanted]
        exact = [p for p in same if p.name[6:] == name[4:]]
        if exact or same:
            return (exact or same)[0]
    candidates = [
        p
        for p in entries
        if p.name.lower().startswith("smrmsg") and p.suffix.lower() == ".out" and p != sbet_path
    ]
    return candidates[0] if len(candidates) == 1 else None
