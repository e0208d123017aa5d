"""Cheap checks a reader makes before it trusts a file: size, text, plausible numbers.

File guards, before anything is allocated
    `check_text_file` reads the first 64 KiB of a text file and refuses NUL bytes (a
    binary file, UTF-16 text, or a sparse file of zeros) and, for a table, a first line
    that does not end within that block (a header is never that long); a reader that
    holds the whole file in memory gives its bound and a larger file is refused with
    its size. A 10 GB file of NUL bytes named ``.csv`` thus costs one 64 KiB read
    instead of 10 GB of memory. `check_record_file` does the same for a file of
    fixed-size binary records (SBET, smrmsg): a size bound, and a first block of
    records that is all zero bytes (times repeated from the first record) refused
    before the file is mapped.

Value guards, after parsing
    Every number a reader returns must be finite and inside the `Span` of what it is: a
    time in seconds, a latitude, a height, a velocity, ... (`check_values`,
    `check_columns`). The spans lie far beyond real data but close enough that squares
    and products of the values stay finite in float64, so a finite-but-absurd value
    (1e308 m, a time of 1e300 s) is refused with its file, line and column instead of
    overflowing somewhere downstream into an internal error or a non-finite result.
    (`Span`, `check_values` and `check_columns` live in `kinsync._validate`, where the
    containers' own checks use them too.)
"""

from __future__ import annotations

import errno
import json
import math
import os
import stat
from pathlib import Path
from typing import Any

from kinsync._text import shown_value
from kinsync._validate import Span, check_columns, check_values
from kinsync.errors import InputError
from kinsync.trajectory_rows import HEIGHT_SPAN_M

__all__ = [
    "ACCELERATION_M_S2",
    "ANGLE_DEG",
    "ANGLE_RAD",
    "ANGULAR_RATE_RAD_S",
    "HEADING_DEG",
    "HEIGHT_M",
    "INTENSITY",
    "LATITUDE_DEG",
    "LENGTH_M",
    "LONGITUDE_DEG",
    "MAX_JSON_BYTES",
    "MAX_TABLE_BYTES",
    "MAX_TEXT_ROWS_BYTES",
    "PITCH_DEG",
    "PROBE_BYTES",
    "ROLL_DEG",
    "SECONDS_OF_WEEK_S",
    "SPEED_M_S",
    "TIME_S",
    "Span",
    "check_columns",
    "check_name_length",
    "check_not_link_loop",
    "check_record_file",
    "check_text_file",
    "check_values",
    "is_file_there",
    "link_loop_error",
    "load_json",
    "name_too_long_error",
    "not_a_regular_file",
    "not_utf8_cell",
    "regular_file_size",
    "require_file",
    "size_text",
]

PROBE_BYTES = 1 << 16
"""Bytes read at the start of a file for the NUL-byte and first-line checks (64 KiB)."""

MAX_TABLE_BYTES = 4 << 30
"""Largest numeric CSV read whole into memory (4 GiB; a day of 200 Hz IMU data is
about 2 GB). Reading it needs about as much memory again."""

MAX_TEXT_ROWS_BYTES = 256 << 20
"""Largest CSV kept cell by cell as text (256 MiB): Python strings take about ten times
the file's size in memory."""

MAX_JSON_BYTES = 64 << 20
"""Largest JSON document read (64 MiB; a clock model with a knot per pulse of a day is
about 4 MB)."""


def size_text(n_bytes: float) -> str:
    """``12.3 GiB``, ``64 KiB``, ``100 bytes``: a file size for a message."""
    for unit, scale in (("GiB", 1 << 30), ("MiB", 1 << 20), ("KiB", 1 << 10)):
        if n_bytes >= scale:
            return f"{n_bytes / scale:.3g} {unit}"
    return f"{int(n_bytes)} bytes"


def link_loop_error(path: Path | str, err: OSError, what: str) -> InputError | None:
    """The error for a path that is a loop of symbolic links (``ELOOP``), or None.

    A link that leads back to itself, directly or through other links, names no file;
    the system's "Too many levels of symbolic links" does not say so plainly.

    Parameters
    ----------
    path : Path or str
        The path given, or how the message names it.
    err : OSError
        The error met reaching it.
    what : str
        What it should be, for the message ("SBET file", "pass folder").
    """
    if err.errno != errno.ELOOP:
        return None
    return InputError(
        f"{path}: symbolic link loop (the link leads back to itself, directly or through "
        f"other links); give the path of the {what} itself"
    )


def check_not_link_loop(path: Path, what: str, shown: str | None = None) -> None:
    """Refuse a path that is a loop of symbolic links: it names no file or folder.

    Parameters
    ----------
    path : Path
        The path.
    what : str
        What it should be, for the message ("pass folder").
    shown : str, optional
        How the message names it (``"--in a.csv"``); default: the path.

    Raises
    ------
    InputError
        ``path`` (or a folder on it) is a loop of symbolic links.
    """
    try:
        path.stat()
    except OSError as err:
        loop = link_loop_error(path if shown is None else shown, err, what)
        if loop is not None:
            raise loop from None


NAME_MAX_BYTES = 255
"""The longest file or folder name most file systems take (ext4, XFS, Btrfs, tmpfs, NTFS)."""


def name_too_long_error(path: Path | str, shown: str | None = None) -> InputError:
    """The error for a path the system refused as too long (``ENAMETOOLONG``).

    Parameters
    ----------
    path : Path or str
        The path.
    shown : str, optional
        How the message names it (``"--out a.csv"``); default: the path.

    Returns
    -------
    InputError
        Naming the longest name in the path and its length in bytes, or the length of
        the whole path when no one name is too long.
    """
    names = [os.fsencode(part) for part in Path(path).parts] or [b""]
    longest = max(names, key=len)
    where = str(path) if shown is None else shown
    if len(longest) > NAME_MAX_BYTES:
        start = longest[:24].decode("utf-8", "ignore")
        return InputError(
            f"{where}: the name {start}... is {len(longest)} bytes long, more than file "
            f"systems allow (at most {NAME_MAX_BYTES} on most); give a shorter name"
        )
    return InputError(
        f"{where}: the path is {len(os.fsencode(str(path)))} bytes long, more than the "
        "system allows; give a shorter path (or run kinsync from a folder nearer to it)"
    )


def check_name_length(path: Path, shown: str | None = None) -> None:
    """Refuse a path the system cannot look up because a name in it is too long.

    Parameters
    ----------
    path : Path
        An input or output path (an output may not exist yet).
    shown : str, optional
        How the message names it (``"--out a.csv"``); default: the path.

    Raises
    ------
    InputError
        Looking ``path`` up fails with ``ENAMETOOLONG`` (a name over the file system's
        limit, 255 bytes on most, or a path over the system's).
    """
    try:
        Path(path).stat()
    except OSError as err:
        if err.errno == errno.ENAMETOOLONG:
            raise name_too_long_error(path, shown) from None


def is_file_there(path: Path) -> bool:
    """Whether ``path`` is an existing file; False where it cannot be looked up at all.

    `Path.is_file` raises for a name too long for the file system (``ENAMETOOLONG``),
    which no file can have: such a path is simply not a file.

    Parameters
    ----------
    path : Path
        The path.
    """
    try:
        return path.is_file()
    except OSError:
        return False


def regular_file_size(path: Path, what: str) -> int:
    """Size of a regular file; a missing file, a folder or a device is an `InputError`.

    Parameters
    ----------
    path : Path
        The file.
    what : str
        What it should be, for messages ("trajectory export", "point table").

    Returns
    -------
    int
        The file's size (bytes).

    Raises
    ------
    InputError
        A missing file, a symbolic link loop, a folder, a device or a pipe (a FIFO or
        ``/dev/zero`` reads as endless or empty data, never as the file meant).
    """
    try:
        st = path.stat()
    except FileNotFoundError as err:
        msg = f"{path}: {what} not found"
        raise InputError(msg) from err
    except OSError as err:
        loop = link_loop_error(path, err, what)
        if loop is not None:
            raise loop from err
        msg = f"{path}: cannot read the {what} ({err.strerror or err})"
        raise InputError(msg) from err
    if stat.S_ISDIR(st.st_mode):
        msg = f"{path}: cannot read the {what}: this is a folder; give the file itself"
        raise InputError(msg)
    if not stat.S_ISREG(st.st_mode):
        raise not_a_regular_file(path, what)
    return int(st.st_size)


def not_a_regular_file(path: Path | str, what: str) -> InputError:
    """The error for a device or a pipe given where a file is read."""
    todo = "give a regular file" if what == "file" else f"give the {what} as a file"
    return InputError(f"{path}: not a regular file (a device or a pipe); {todo}")


def _check_size(path: Path, size: int, what: str, max_bytes: int | None) -> None:
    if max_bytes is not None and size > max_bytes:
        msg = (
            f"{path}: {size_text(size)}, larger than the {size_text(max_bytes)} kinsync reads "
            f"into memory for a {what}; is this the right file? (split a longer record)"
        )
        raise InputError(msg)


def _read_head(path: Path, n_bytes: int, what: str) -> bytes:
    """The first ``n_bytes`` of a file (fewer if it is shorter); a read error is an InputError."""
    try:
        with path.open("rb") as fh:
            return fh.read(n_bytes)
    except OSError as err:
        msg = f"{path}: cannot read the {what} ({err.strerror or err})"
        raise InputError(msg) from err


def require_file(path: Path, what: str = "file") -> None:
    """Refuse a path that is not a regular file.

    Parameters
    ----------
    path : Path
        The file.
    what : str
        What it should be, for the message about a device or a pipe ("point table").

    Raises
    ------
    InputError
        Naming the path and what it is instead: ``file not found``, ``is a folder``, a
        symbolic link loop, or not a regular file (a device or a pipe).
    """
    try:
        st = path.stat()
    except FileNotFoundError:
        st = None
    except OSError as err:
        loop = link_loop_error(path, err, what)
        if loop is not None:
            raise loop from err
        msg = f"{path}: cannot read the {what} ({err.strerror or err})"
        raise InputError(msg) from err
    if st is not None and stat.S_ISREG(st.st_mode):
        return
    if st is not None and not stat.S_ISDIR(st.st_mode):
        raise not_a_regular_file(path, what)
    what_is = "is a folder, not a file" if st is not None else "file not found"
    msg = f"{path}: {what_is}"
    raise InputError(msg)


def check_text_file(
    path: Path,
    what: str,
    *,
    max_bytes: int | None = None,
    lines: bool = True,
    nul_after_first_line: bool = False,
) -> int:
    """Refuse a file that cannot be the text file a reader expects, reading 64 KiB at most.

    Parameters
    ----------
    path : Path
        The file.
    what : str
        What it should be, for messages ("trajectory CSV", "NMEA log").
    max_bytes : int, optional
        Largest size accepted (a reader holding the whole file in memory); no bound
        when None (a streaming reader).
    lines : bool
        The file is made of lines (a table's header, records): its first line must end
        within `PROBE_BYTES`. False for a document (JSON) that may be one long line.
    nul_after_first_line : bool
        NUL bytes are refused in the first line only (a log whose reader rejects a
        damaged line on its own).

    Returns
    -------
    int
        The file's size (bytes).

    Raises
    ------
    InputError
        A missing file, a folder or a device, a file larger than ``max_bytes``, a NUL
        byte in the first 64 KiB (binary data, UTF-16 text or a sparse file), or a first
        line longer than 64 KiB.
    """
    path = Path(path)
    size = regular_file_size(path, what)
    _check_size(path, size, what, max_bytes)
    head = _read_head(path, PROBE_BYTES, what)
    ends = [i for i in (head.find(b"\n"), head.find(b"\r")) if i >= 0]  # LF, CRLF or CR
    first_end = min(ends) if ends else -1
    nul = head.find(b"\x00", 0, first_end if nul_after_first_line else len(head))
    if nul >= 0:
        utf16 = head[:2] in (b"\xff\xfe", b"\xfe\xff") or head[1:8:2] == b"\x00" * 4
        hint = (
            "it looks like UTF-16 text: save it as UTF-8"
            if utf16
            else "is it a binary file, or a damaged or unfinished copy?"
        )
        msg = f"{path}: not a text file (byte {nul} is NUL); a {what} is text: {hint}"
        raise InputError(msg)
    if lines and len(head) == PROBE_BYTES and first_end < 0:
        msg = (
            f"{path}: the first line is longer than {size_text(PROBE_BYTES)}, too long for "
            f"a {what} (a header, or a record): is this the right file?"
        )
        raise InputError(msg)
    return size


def check_record_file(path: Path, record_bytes: int, what: str, max_bytes: int) -> int:
    """Refuse a binary record file that is too large or starts with records of zeros.

    Parameters
    ----------
    path : Path
        The file.
    record_bytes : int
        Length of one record.
    what : str
        The file kind ("SBET"), for messages.
    max_bytes : int
        Largest size accepted.

    Returns
    -------
    int
        The file's size (bytes).

    Raises
    ------
    InputError
        A missing file, a folder or a device, a file larger than ``max_bytes``, or at
        least two records whose first 64 KiB are all zero bytes (a sparse or zeroed
        file: its times would all be 0).
    """
    path = Path(path)
    size = regular_file_size(path, f"{what} file")
    _check_size(path, size, f"{what} file", max_bytes)
    if size >= 2 * record_bytes:
        head = _read_head(
            path, min(PROBE_BYTES, size) // record_bytes * record_bytes, f"{what} file"
        )
        if not head.strip(b"\x00"):
            msg = (
                f"{path}: the first {len(head) // record_bytes} records ({size_text(len(head))}) "
                f"are all zero bytes: not an {what} file, or a damaged or unfinished copy"
            )
            raise InputError(msg)
    return size


def not_utf8_cell(path: Path, line: int, cell: str) -> InputError | None:
    """The error for a cell holding a byte that is not UTF-8, or None.

    The text must have been decoded with ``errors="surrogateescape"``, which keeps
    such a byte as a lone surrogate.
    """
    bad = next((c for c in cell if "\udc80" <= c <= "\udcff"), None)
    if bad is None:
        return None
    return InputError(
        f"{path}: line {line}: byte 0x{ord(bad) - 0xDC00:02X} is not UTF-8 text; save the "
        "file as UTF-8 (or remove the damaged line)"
    )


# ---------------------------------------------------------------------- plausible values
TIME_S = Span(-1e10, 1e10, "s", "a time in seconds (317 years either side of its epoch)")
"""Times: GPS time (1.4e9 s in 2024), GPS seconds of week, a local clock. Beyond 1e10 s
a float64 resolves less than 2 microseconds; a larger value is a unit mistake (ms, ns)."""

SECONDS_OF_WEEK_S = Span(0.0, TIME_S.high, "s", "a time in seconds of week (from 0 at its start)")
"""GPS seconds of week: a negative value would be read as a time of an earlier week. No end
is set: a trajectory that crosses the week's end keeps counting past 604800 s."""

LATITUDE_DEG = Span(-90.0, 90.0, "deg", "a latitude")
LONGITUDE_DEG = Span(-360.0, 360.0, "deg", "a longitude (-180 to 180 or 0 to 360)")

HEIGHT_M = Span(*HEIGHT_SPAN_M, "m", "an ellipsoidal height (100 km below or above the ellipsoid)")
"""Heights: the deepest trench and the highest aircraft lie well inside 100 km; the span
`kinsync.Trajectory` and `kinsync.ins.GnssData` hold too (`HEIGHT_SPAN_M`)."""

LENGTH_M = Span(-1e8, 1e8, "m", "a coordinate or length (1e8 m is 16 Earth radii)")
"""Coordinates (ECEF, projected, scanner or table frame), ranges: within 1e8 m."""

SPEED_M_S = Span(-1e4, 1e4, "m/s", "a velocity (10 km/s is beyond orbital speed)")
ANGLE_DEG = Span(-1e6, 1e6, "deg", "an angle (2,800 turns, even unwrapped)")
ROLL_DEG = Span(-360.0, 360.0, "deg", "a roll (one turn either way)")
PITCH_DEG = Span(-90.0, 90.0, "deg", "a pitch (-90 to 90)")
HEADING_DEG = Span(-360.0, 360.0, "deg", "a yaw (-180 to 180 or 0 to 360)")
"""A trajectory's attitude (CSV, POSPac and Inertial Explorer text): a pitch beyond 90
deg or a roll or heading beyond a turn is no attitude (radians times 57, a column
shifted)."""
ANGLE_RAD = Span(-math.radians(1e6), math.radians(1e6), "rad", "an angle (2,800 turns)")
ANGULAR_RATE_RAD_S = Span(-1e3, 1e3, "rad/s", "an angular rate (beyond any gyro's range)")
ACCELERATION_M_S2 = Span(-1e4, 1e4, "m/s^2", "a specific force (1,000 g, beyond any IMU)")
INTENSITY = Span(-1e12, 1e12, "", "an intensity")


# ---------------------------------------------------------------------- JSON
def _no_constant(name: str) -> Any:
    msg = f"{name} is not a number JSON allows"
    raise ValueError(msg)


def _float_int(text: str) -> int:
    value = int(text)
    try:
        float(value)
    except OverflowError:
        msg = f"a {len(text.lstrip('-'))}-digit integer is too large for a float64"
        raise ValueError(msg) from None
    return value


def _unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """A JSON object's members as a dict; a key given twice is refused (not the last kept)."""
    out: dict[str, Any] = {}
    for key, value in pairs:
        if key in out:
            msg = f"key {shown_value(key)} is given twice in one object; keep one"
            raise ValueError(msg)
        out[key] = value
    return out


def load_json(path: Path, what: str) -> Any:
    """Read a small UTF-8 JSON document; numbers are plain finite JSON numbers.

    Parameters
    ----------
    path : Path
        The file (at most `MAX_JSON_BYTES`).
    what : str
        What it is, for messages ("clock model file").

    Returns
    -------
    Any
        The parsed document (a leading UTF-8 byte-order mark is dropped, as for CSV and
        TOML files). ``NaN``/``Infinity`` (which Python's parser accepts) and
        integers too long for a float64 are refused; a float literal too large for a
        float64 comes back as ``inf`` for the caller's finiteness check.

    Raises
    ------
    InputError
        Missing or unreadable file, too large, not UTF-8, invalid JSON (with line and
        column), NaN/Infinity, an integer too large for a float64 or a key given twice in
        one object (Python's parser keeps the last).
    """
    path = Path(path)
    check_text_file(path, what, max_bytes=MAX_JSON_BYTES, lines=False)
    try:
        text = path.read_bytes().decode("utf-8")
    except OSError as err:
        msg = f"{path}: cannot read the {what} ({err.strerror or err})"
        raise InputError(msg) from err
    except UnicodeDecodeError as err:
        msg = f"{path}: the {what} is not UTF-8 text (byte {err.start}: {err.reason})"
        raise InputError(msg) from err
    text = text.removeprefix("\ufeff")  # a byte-order mark, as some Windows editors write
    try:
        return json.loads(
            text, parse_constant=_no_constant, parse_int=_float_int, object_pairs_hook=_unique_keys
        )
    except json.JSONDecodeError as err:
        msg = f"{path}: line {err.lineno}, column {err.colno}: not valid JSON ({err.msg})"
        raise InputError(msg) from err
    except (ValueError, RecursionError) as err:
        msg = f"{path}: not a valid {what} ({err})"
        raise InputError(msg) from err
