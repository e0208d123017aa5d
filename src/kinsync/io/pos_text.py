"""POSPac and Inertial Explorer ASCII trajectory exports.

Two text layouts are read, each found from its header, never from fixed line numbers:

* **POSPac** (Applanix "POS Export Utility"): a free-text header block (the SBET's
  name, the mapping frame, lever arm and boresight), then one line of column names
  separated by commas (``TIME, DISTANCE, EASTING, NORTHING, ELLIPSOID HEIGHT, LATITUDE,
  LONGITUDE, ELLIPSOID HEIGHT, ROLL, PITCH, HEADING, EAST VELOCITY, NORTH VELOCITY, UP
  VELOCITY, ...``), a line of units in parentheses, and rows of numbers separated by
  spaces. Angles are in degrees; roll, pitch and heading are those of the SBET (DIN 9300:
  heading, then pitch about the new y axis, then roll about x, body x forward, y right,
  z down), the heading true (the export removes the wander angle).
* **Inertial Explorer** (NovAtel/Waypoint): a header block (``Project:``, ``Program:
  Inertial Explorer ...``, ``Datum:``, ...), a line of column names separated by spaces
  (``GPSTime``, ``Week``, ``Latitude``, ``Longitude``, ``H-Ell``, ``Roll``, ``Pitch``,
  ``Heading``, ``VNorth``, ``VEast``, ``VUp``, ...; other columns such as ``Date``,
  ``HdngSD`` or ``Q`` are skipped), a line of units (``(sec)``, ``(deg)``, ``(m)``,
  ``(+/-D M S)``, ``(MDY)``) and rows separated by spaces. Latitude and longitude are
  decimal degrees, or three fields (degrees, minutes, seconds, the sign on the degrees)
  where their unit says ``D M S``. The attitude is NovAtel's (SPAN, Inertial Explorer):
  vehicle frame x right, y forward, z up; pitch right-handed about x, roll right-handed
  about y, azimuth clockwise from north, applied in the order azimuth, pitch, roll
  (intrinsic Z-X-Y, NovAtel's "Determining rotations for Inertial Explorer and SPAN").
  They are converted to the body frame of kinsync (x forward, y right, z down). The
  swap of axes makes NovAtel's Z-X-Y sequence the DIN 9300 one: the vehicle-to-ENU
  rotation ``Rz(-azimuth) Rx(pitch) Ry(roll)`` seen through the swap (FRD <-> RFU, ENU
  <-> NED) is ``Rz(heading) Ry(pitch) Rx(roll)``, so the same three numbers give the
  same attitude from either program, at any tilt (the tests check both to 1e-12).

The columns are recognised by name (`COLUMN_NAMES`, case and units ignored): a time,
latitude, longitude, ellipsoidal height, roll, pitch and heading are required;
north/east/up (or down) velocities are optional and, when given, enable Hermite
position interpolation. The producer is told by its banner (``POS Export Utility``,
``POSPac``, ``Applanix``; ``Inertial Explorer``, ``GrafNav``, ``NovAtel``, ``Waypoint``);
a file with neither is refused: the angles of another program may follow another
convention, which kinsync does not guess.

Times are GPS seconds of week (both programs' default); with a ``Week`` column they
become continuous GPS time (``week * 604800 + seconds``), else ``gps_week`` does
(`read_pos_text`), as for an SBET. Times beyond a week and a day cannot be seconds of
week: they are read as GPS time as they are (`kinsync.io.gps_week`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from kinsync._text import reads_as_number
from kinsync._typing import FloatArray
from kinsync.errors import InputError
from kinsync.frames import euler_rpy_to_quaternion, matrix_to_quaternion, rot_x, rot_y, rot_z
from kinsync.io.gps_week import SECONDS_PER_WEEK, holds_gps_time
from kinsync.io.sanity import (
    HEADING_DEG,
    HEIGHT_M,
    LATITUDE_DEG,
    LONGITUDE_DEG,
    PITCH_DEG,
    ROLL_DEG,
    SECONDS_OF_WEEK_S,
    SPEED_M_S,
    TIME_S,
    Span,
    check_columns,
    check_text_file,
)
from kinsync.io.tables import rows_to_lines
from kinsync.io.text_lines import cut_line_hint, warn_if_unended
from kinsync.trajectory import Trajectory

__all__ = [
    "COLUMN_NAMES",
    "PosTextLayout",
    "Producer",
    "pos_text_takes_gps_week",
    "read_pos_text",
    "sniff_pos_text",
]

Producer = Literal["pospac", "inertial-explorer"]
_HEADER_SCAN_LINES = 400  # the header block of either program is far shorter
_MAX_BYTES = 8 << 30

COLUMN_NAMES: dict[str, tuple[str, ...]] = {
    "t_s": ("TIME", "GPSTIME", "GPS TIME", "CORRTIME", "GPS SECONDS", "SOW"),
    "week": ("WEEK", "GPSWEEK", "GPS WEEK"),
    "lat_deg": ("LATITUDE", "LAT"),
    "lon_deg": ("LONGITUDE", "LONG", "LON"),
    "h_m": ("ELLIPSOID HEIGHT", "ELLIPSOIDAL HEIGHT", "H-ELL", "HELL", "ELL HEIGHT", "HEIGHT"),
    "roll_deg": ("ROLL",),
    "pitch_deg": ("PITCH",),
    "heading_deg": ("HEADING", "TRUE HEADING", "AZIMUTH"),
    "vn_m_s": ("NORTH VELOCITY", "VNORTH", "VN", "VEL NORTH", "VELNORTH"),
    "ve_m_s": ("EAST VELOCITY", "VEAST", "VE", "VEL EAST", "VELEAST"),
    "vu_m_s": ("UP VELOCITY", "VUP", "VU", "VEL UP", "VELUP"),
    "vd_m_s": ("DOWN VELOCITY", "VDOWN", "VD", "VEL DOWN", "VELDOWN"),
}
"""Column names recognised (upper case, units in parentheses removed) for each quantity."""

_REQUIRED = ("t_s", "lat_deg", "lon_deg", "h_m", "roll_deg", "pitch_deg", "heading_deg")
_UTC_ONLY = ("UTCTIME", "UTCTIM", "UTC TIME")
_BANNERS: tuple[tuple[str, Producer], ...] = (
    ("POS EXPORT UTILITY", "pospac"),
    ("POSPAC", "pospac"),
    ("APPLANIX", "pospac"),
    ("INERTIAL EXPLORER", "inertial-explorer"),
    ("GRAFNAV", "inertial-explorer"),
    ("NOVATEL", "inertial-explorer"),
    ("WAYPOINT", "inertial-explorer"),
)
_SPANS: dict[str, Span] = {
    "t_s": TIME_S,
    "lat_deg": LATITUDE_DEG,
    "lon_deg": LONGITUDE_DEG,
    "h_m": HEIGHT_M,
    "roll_deg": ROLL_DEG,
    "pitch_deg": PITCH_DEG,
    "heading_deg": HEADING_DEG,
    "vn_m_s": SPEED_M_S,
    "ve_m_s": SPEED_M_S,
    "vu_m_s": SPEED_M_S,
    "vd_m_s": SPEED_M_S,
}
_UNIT_TOKEN = re.compile(r"\([^)]*\)|\S+")
_FIELD_SEPARATOR = re.compile(r"[,\s]+")
_LAYOUT_HINT = (
    "kinsync reads POSPac exports (a 'POS Export Utility' header, a line of comma-separated "
    "column names such as TIME, LATITUDE, LONGITUDE, ELLIPSOID HEIGHT, ROLL, PITCH, HEADING) "
    "and Inertial Explorer exports (a 'Program: Inertial Explorer' header, a line of column "
    "names such as GPSTime Latitude Longitude H-Ell Roll Pitch Heading); or convert it to a "
    "trajectory CSV (t_s,lat_deg,lon_deg,h_m,roll_deg,pitch_deg,yaw_deg)"
)


@dataclass(frozen=True)
class PosTextLayout:
    """Where the data of an export are, as found from its header.

    Attributes
    ----------
    producer : {"pospac", "inertial-explorer"}
    header_line : int
        1-based line of the column names.
    names : tuple of str
        The column names as the file gives them.
    widths : tuple of int
        Fields each column takes in a row (3 for a latitude or longitude in D M S).
    columns : dict of str to int
        Quantity (`COLUMN_NAMES` key) -> index of its column in ``names``.
    """

    producer: Producer
    header_line: int
    names: tuple[str, ...]
    widths: tuple[int, ...]
    columns: dict[str, int]

    @property
    def fields_per_row(self) -> int:
        """Fields a data row has."""
        return sum(self.widths)


def _normalise(name: str) -> str:
    without_units = re.sub(r"\([^)]*\)|\[[^\]]*\]", " ", name)
    return " ".join(without_units.upper().replace("_", " ").split())


def _is_data(fields: list[str]) -> bool:
    """A row of numbers (at least half its fields; a date such as 04/12/2020 is not)."""
    return bool(fields) and 2 * sum(reads_as_number(f) for f in fields) >= len(fields)


def _split_names(line: str) -> list[str]:
    if "," in line:
        return [part.strip() for part in line.split(",")]
    return line.split()


def _match_columns(names: list[str]) -> dict[str, int]:
    """Quantity -> column index, the first column of each recognised name."""
    found: dict[str, int] = {}
    for index, name in enumerate(names):
        key = _normalise(name)
        for quantity, known in COLUMN_NAMES.items():
            if key in known and quantity not in found:
                found[quantity] = index
                break
    return found


def _producer(path: Path, lines: list[str], header_index: int) -> Producer:
    for line in lines[: header_index + 1]:
        upper = line.upper()
        for banner, producer in _BANNERS:
            if banner in upper:
                return producer
    msg = (
        f"{path}: the header does not say which program wrote the file (no 'POS Export "
        "Utility'/POSPac or 'Inertial Explorer'/GrafNav line): their roll, pitch and heading "
        "follow different conventions, so kinsync does not guess; keep the export's header"
    )
    raise InputError(msg)


def _widths(
    path: Path, names: list[str], unit_line: str | None, columns: dict[str, int]
) -> list[int]:
    """Fields per column: 3 for latitude and longitude in D M S, else 1.

    A column may have no unit (Inertial Explorer leaves ``Q`` blank), so units are not
    matched to columns one by one: a units line with ``D M S`` units gives both latitude
    and longitude in three fields; one with ``rad`` is refused (degrees are expected).
    """
    widths = [1] * len(names)
    if unit_line is None:
        return widths
    units = [u.upper().replace(" ", "") for u in _UNIT_TOKEN.findall(unit_line)]
    if any(u.strip("()") in ("RAD", "RADIANS") or "INRADIANS" in u for u in units):
        msg = f"{path}: its units line gives angles in radians; export them in degrees"
        raise InputError(msg)
    if sum("DMS" in u for u in units) >= 2:
        widths[columns["lat_deg"]] = widths[columns["lon_deg"]] = 3
    return widths


def _find_layout(path: Path, lines: list[str]) -> tuple[PosTextLayout, int]:
    """The layout, and the 0-based index of the first data line."""
    for index, line in enumerate(lines[:_HEADER_SCAN_LINES]):
        names = _split_names(line)
        if len(names) < len(_REQUIRED):
            continue
        columns = _match_columns(names)
        if not all(q in columns for q in ("lat_deg", "lon_deg", "roll_deg", "pitch_deg")):
            continue
        if "t_s" not in columns:
            utc = any(_normalise(n) in _UTC_ONLY for n in names)
            hint = (
                "it has UTC times only: export GPS time (GPSTime, seconds of week)"
                if utc
                else "export GPS time (TIME or GPSTime, seconds of week)"
            )
            msg = f"{path}: line {index + 1}: the column names have no GPS time; {hint}"
            raise InputError(msg)
        missing = [q for q in _REQUIRED if q not in columns]
        if missing:
            wanted = ", ".join(COLUMN_NAMES[q][0] for q in missing)
            msg = (
                f"{path}: line {index + 1}: the columns {names} lack {wanted}; export them "
                "too (names kinsync knows: kinsync.io.pos_text.COLUMN_NAMES)"
            )
            raise InputError(msg)
        producer = _producer(path, lines, index)
        data_index = index + 1
        unit_line: str | None = None
        while data_index < len(lines):
            text = lines[data_index].strip()
            if text and _is_data(_FIELD_SEPARATOR.split(text)):
                break
            if text and unit_line is None:
                unit_line = text
            data_index += 1
        widths = _widths(path, names, unit_line, columns)
        layout = PosTextLayout(producer, index + 1, tuple(names), tuple(widths), columns)
        return layout, data_index
    msg = f"{path}: not a recognised trajectory export (no line of column names found); "
    raise InputError(msg + _LAYOUT_HINT)


def sniff_pos_text(path: Path) -> PosTextLayout:
    """The layout of an export, read from its first lines (see the module docstring).

    Raises
    ------
    InputError
        Not text, no recognisable line of column names, required columns missing, no
        banner naming the program.
    """
    path = Path(path)
    check_text_file(path, "trajectory export", max_bytes=_MAX_BYTES)
    with path.open(encoding="utf-8", errors="replace") as fh:
        head = [line for _, line in zip(range(_HEADER_SCAN_LINES + 8), fh, strict=False)]
    return _find_layout(path, head)[0]


def pos_text_takes_gps_week(path: Path) -> bool:
    """Whether a GPS week applies to this export: seconds of week and no ``Week`` column.

    False for an export with a ``Week`` column (it gives its own) or whose first row's
    time lies beyond a week and a day (GPS time already, `kinsync.io.gps_week`); a
    first row that cannot be read counts as taking one (`read_pos_text` names it).

    Raises
    ------
    InputError
        As `sniff_pos_text`.
    """
    path = Path(path)
    check_text_file(path, "trajectory export", max_bytes=_MAX_BYTES)
    with path.open(encoding="utf-8", errors="replace") as fh:
        head = [line for _, line in zip(range(_HEADER_SCAN_LINES + 8), fh, strict=False)]
    layout, first = _find_layout(path, head)
    if "week" in layout.columns:
        return False
    if first >= len(head):
        return True
    fields = _FIELD_SEPARATOR.split(head[first].strip())
    start = sum(layout.widths[: layout.columns["t_s"]])
    try:
        return not holds_gps_time(float(fields[start]))
    except (ValueError, IndexError):
        return True


def _dms_to_deg(fields: list[str]) -> float:
    degrees, minutes, seconds = (float(f) for f in fields)
    sign = -1.0 if fields[0].lstrip().startswith("-") else 1.0
    return sign * (abs(degrees) + minutes / 60.0 + seconds / 3600.0)


def _parse_rows_fast(
    lines: list[str], first: int, layout: PosTextLayout
) -> tuple[dict[str, FloatArray], list[int]] | None:
    """`_parse_rows` for the common file: every line after the header a row of numbers.

    numpy parses the rows in one call (some 20 times faster than line by line); None
    when any line is not such a row (text, a date, a short row): `_parse_rows` then
    reads the file line by line and names the line at fault.
    """
    rows = [i for i in range(first, len(lines)) if lines[i].strip()]
    if not rows:
        return None
    try:
        table = np.loadtxt([lines[i] for i in rows], dtype=np.float64, ndmin=2, comments=None)
    except ValueError:
        return None
    if table.shape[1] != layout.fields_per_row:
        return None
    starts = np.concatenate([[0], np.cumsum(layout.widths)[:-1]]).astype(int).tolist()
    out: dict[str, FloatArray] = {}
    for quantity, index in layout.columns.items():
        start = starts[index]
        if layout.widths[index] == 3:
            d, m, sec = table[:, start], table[:, start + 1], table[:, start + 2]
            negative = np.array([lines[i].split()[start].startswith("-") for i in rows])
            out[quantity] = np.where(negative, -1.0, 1.0) * (np.abs(d) + m / 60 + sec / 3600)
        else:
            out[quantity] = np.ascontiguousarray(table[:, start])
    return out, [i + 1 for i in rows]


def _count_text(found: int, expected: int) -> str:
    """``2 too many`` or ``1 too few``: fields found against the header's count."""
    return f"{abs(found - expected)} too {'many' if found > expected else 'few'}"


def _clock_time_hint(lines: list[str], first: int, layout: PosTextLayout) -> str:
    """Why a row does not read, when the units line gives a clock time (``(HMS)``).

    A time in hours, minutes and seconds takes three fields (or one with colons) where
    kinsync reads one number of GPS seconds; "" when no unit between the column names and
    the first row says HMS.
    """
    for index in range(layout.header_line, first):
        units = [u.upper().replace(" ", "") for u in _UNIT_TOKEN.findall(lines[index])]
        if any("HMS" in u for u in units):
            return (
                f"; the units line (line {index + 1}) gives a time in HMS (hours minutes "
                "seconds, a clock time), which kinsync does not read: export the time as GPS "
                "seconds of week (GPSTime in seconds, unit (sec)) and no time column in HMS"
            )
    return ""


def _parse_rows(
    path: Path, lines: list[str], first: int, layout: PosTextLayout
) -> tuple[dict[str, FloatArray], list[int]]:
    """The recognised columns (float64) and the 1-based line of each row."""
    fast = _parse_rows_fast(lines, first, layout)
    if fast is not None:
        return fast
    starts = np.concatenate([[0], np.cumsum(layout.widths)[:-1]]).astype(int).tolist()
    wanted = {q: (starts[i], layout.widths[i], layout.names[i]) for q, i in layout.columns.items()}
    values: dict[str, list[float]] = {q: [] for q in wanted}
    line_of_row: list[int] = []
    ended_at: int | None = None
    for index in range(first, len(lines)):
        text = lines[index].strip()
        if not text:
            continue
        fields = _FIELD_SEPARATOR.split(text)
        if not _is_data(fields):
            ended_at = ended_at if ended_at is not None else index + 1
            continue
        if ended_at is not None:
            msg = (
                f"{path}: line {index + 1}: a data row after the text at line {ended_at}; "
                "remove the text between the rows"
            )
            raise InputError(msg)
        if len(fields) != layout.fields_per_row:
            question = (
                "is the row cut short, or a column empty?"
                if len(fields) < layout.fields_per_row
                else "are two rows joined, or a value split by a space?"
            )
            msg = (
                f"{path}: line {index + 1}: {len(fields)} fields where the header (line "
                f"{layout.header_line}) gives {layout.fields_per_row} for columns "
                f"{list(layout.names)}: {_count_text(len(fields), layout.fields_per_row)}"
            )
            hms = _clock_time_hint(lines, first, layout)
            msg += cut_line_hint(path, index + 1) or hms or f"; {question}"
            raise InputError(msg)
        for quantity, (start, width, name) in wanted.items():
            cell = fields[start : start + width]
            try:
                value = _dms_to_deg(cell) if width == 3 else float(cell[0])
            except ValueError:
                msg = (
                    f"{path}: line {index + 1}, column {name!r}: {' '.join(cell)!r} is not a number"
                )
                msg += _clock_time_hint(lines, first, layout) or "; fix or remove the row"
                raise InputError(msg) from None
            values[quantity].append(value)
        line_of_row.append(index + 1)
    return {q: np.asarray(v, dtype=np.float64) for q, v in values.items()}, line_of_row


def _attitude_quaternions(producer: Producer, c: dict[str, FloatArray]) -> FloatArray:
    """Body (x fwd, y right, z down) -> NED quaternions from the export's angles."""
    roll, pitch, heading = (np.radians(c[k]) for k in ("roll_deg", "pitch_deg", "heading_deg"))
    if producer == "pospac":
        return euler_rpy_to_quaternion(roll, pitch, heading)
    # NovAtel: vehicle (x right, y fwd, z up) -> ENU = Rz(-azimuth) Rx(pitch) Ry(roll).
    vehicle_to_enu = rot_z(-heading) @ rot_x(pitch) @ rot_y(roll)
    swap = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])  # FRD<->RFU, ENU<->NED
    return matrix_to_quaternion(swap @ vehicle_to_enu @ swap)


def read_pos_text(path: Path, *, gps_week: int | None = None) -> tuple[Trajectory, bool]:
    """Read a POSPac or Inertial Explorer ASCII trajectory export.

    Parameters
    ----------
    path : Path
        The export (any suffix; the content decides).
    gps_week : int, optional
        GPS week of the first record, for an export without a ``Week`` column: its
        seconds of week become GPS time (a trajectory crossing into the next week keeps
        counting past 604800 s, as in an SBET). Not used when the times already hold GPS
        time (a first time beyond a week and a day, `kinsync.io.gps_week`).

    Returns
    -------
    trajectory : Trajectory
    gps_time : bool
        True when the times are continuous GPS time (a ``Week`` column, ``gps_week``, or
        times beyond a week), False for GPS seconds of week.

    Raises
    ------
    InputError
        An unrecognised layout (naming the file and what kinsync reads), a row with the
        wrong number of fields or a cell that is not a number (naming the line and
        column), implausible values (a negative time of week among them), fewer than 2
        rows, times that do not increase.
    """
    path = Path(path)
    check_text_file(path, "trajectory export", max_bytes=_MAX_BYTES)
    warn_if_unended(path)
    try:
        lines = path.read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError as err:
        msg = f"{path}: cannot read ({err.strerror or err})"
        raise InputError(msg) from err
    layout, first = _find_layout(path, lines)
    c, line_of_row = _parse_rows(path, lines, first, layout)
    if len(line_of_row) < 2:
        msg = f"{path}: a trajectory needs at least 2 records, found {len(line_of_row)}"
        raise InputError(msg)
    t = c["t_s"]
    already_gps = "week" not in c and holds_gps_time(float(t[0]))
    named = {layout.names[layout.columns[q]]: v for q, v in c.items()}
    spans = {layout.names[layout.columns[q]]: span for q, span in _SPANS.items() if q in c}
    if not already_gps:  # seconds of week: a negative one would be read as an earlier week
        spans[layout.names[layout.columns["t_s"]]] = SECONDS_OF_WEEK_S
    check_columns(named, spans, lambda row: f"{path}: line {line_of_row[row]}")
    gps_time = "week" in c or already_gps or gps_week is not None
    if "week" in c:
        t = c["week"] * SECONDS_PER_WEEK + t
    elif gps_week is not None and not already_gps:
        t = gps_week * SECONDS_PER_WEEK + t
    vel = _velocity(path, c)
    try:
        traj = Trajectory(
            t_s=t,
            q_body_to_ned=_attitude_quaternions(layout.producer, c),
            lat_lon_h=np.column_stack([c["lat_deg"], c["lon_deg"], c["h_m"]]),
            vel_ned_m_s=vel,
        )
    except InputError as err:
        msg = f"{path}: {rows_to_lines(str(err), line_of_row.__getitem__)}"
        raise InputError(msg) from err
    return traj, gps_time


def _velocity(path: Path, c: dict[str, FloatArray]) -> FloatArray | None:
    """NED velocities from north, east and up (or down) columns; None when absent."""
    vertical = "vu_m_s" if "vu_m_s" in c else "vd_m_s" if "vd_m_s" in c else None
    present = [k in c for k in ("vn_m_s", "ve_m_s")] + [vertical is not None]
    if not any(present):
        return None
    if not all(present):
        msg = f"{path}: give north, east and up velocities, or none; found only some"
        raise InputError(msg)
    assert vertical is not None
    down = -c[vertical] if vertical == "vu_m_s" else c[vertical]
    return np.column_stack([c["vn_m_s"], c["ve_m_s"], down])
