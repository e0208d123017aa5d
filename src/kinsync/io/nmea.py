"""NMEA 0183 sentences, TSS1 and Kongsberg EM3000 attitude records, and NMEA arrival logs.

Sentences read: ZDA (UTC time and date), GGA (position fix), RMC (minimum navigation
data), HDT (true heading) from any talker (``$GP``, ``$GN``, ``$IN``, ``$HE``, ...), and
the proprietary attitude sentence ``$PASHR`` (Applanix/NovAtel/Trimble layout). Every
sentence must carry its checksum ``*hh`` (upper- or lowercase hex) and it is verified;
a sentence without one is rejected, since a missing checksum cannot be told from a
sentence cut short. Every failure, for any ``str`` or ``bytes`` input, is an
`NmeaError` whose message is a short reason ("bad checksum (got 4A, computed 4B)",
"truncated: ...", "empty field 'day'", "not ASCII: ...", "unsupported sentence type
'GSV'"); no value is guessed, defaulted or silently dropped.

The parsing is written here rather than taken from pynmea2 or pynmeagps: both verify
checksums, but both accept garbage silently in the fields (pynmea2 leaves an
unparsable number or time as a string and reads hemisphere ``'Q'`` as latitude 0;
pynmeagps blanks an invalid time, date or latitude, returns ``None`` for a sentence
without checksum and accepts ``inf``), so every field would have to be re-validated
anyway; the five layouts are short.

The records, their units and signs are in `kinsync.messages`.

Log file
--------
``nmea.csv``: a header ``t_local_s,sentence``, then one line per received sentence: the
local arrival time (end of reception, s) and the raw sentence, CSV-quoted or not (all
after the first comma is the sentence; surrounding double quotes are removed). Lines
that cannot be used are kept in `NmeaLog.rejected` with the reason.

References
----------
NMEA 0183 Standard for Interfacing Marine Electronic Devices, v4.11 (2018).
NovAtel OEM7 Commands and Logs Reference: GPZDA, GPGGA, GPRMC, GPHDT, PASHR, TSS1.
Applanix POS MV V5 Installation and Operation Guide, tables 20 ($PASHR) and 22 (TSS1).
Kongsberg Simrad EK80/EM reference: "Kongsberg EM Attitude 3000 datagram format" and
"Teledyne TSS1 datagram format".
"""

from __future__ import annotations

import math
import re
import struct
from collections.abc import Iterator
from pathlib import Path
from typing import BinaryIO

import numpy as np

from kinsync.errors import InputError
from kinsync.io.sanity import TIME_S, check_text_file
from kinsync.messages import (
    TSS1_STATUS,
    Em3000Record,
    GgaRecord,
    HdtRecord,
    NmeaError,
    NmeaLog,
    NmeaRecord,
    PashrRecord,
    RejectedLine,
    RmcRecord,
    Tss1Record,
    ZdaRecord,
)

__all__ = [
    "NMEA_LOG_HEADER",
    "format_sentence",
    "nmea_checksum",
    "parse_em3000",
    "parse_sentence",
    "parse_tss1",
    "read_nmea_log",
]


# ---------------------------------------------------------------------- field syntax
_DECIMAL = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)")
_NUMBER = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
_UINT = re.compile(r"[0-9]{1,9}")  # bounded: no huge ints (int() caps digits, C longs overflow)
_SINT = re.compile(r"[+-]?[0-9]{1,9}")
_TIME = re.compile(r"([0-9]{2})([0-9]{2})([0-9]{2}(?:\.[0-9]+)?)")
_DATE6 = re.compile(r"([0-9]{2})([0-9]{2})([0-9]{2})")
_LAT = re.compile(r"([0-9]{2})([0-9]{2}(?:\.[0-9]*)?)")
_LON = re.compile(r"([0-9]{3})([0-9]{2}(?:\.[0-9]*)?)")
_HEX2 = re.compile(r"[0-9A-Fa-f]{2}")
_HEX4 = re.compile(r"[0-9A-Fa-f]{4}")
_DIGITS4 = re.compile(r"[0-9]{4}")
_ADDRESS = re.compile(r"[A-Z][A-Z0-9]{2,9}")

_KNOT_M_S = 1852.0 / 3600.0


def _required(cell: str, name: str) -> str:
    if cell == "":
        msg = f"empty field {name!r}"
        raise NmeaError(msg)
    return cell


def _opt_float(cell: str, name: str) -> float | None:
    if cell == "":
        return None
    if not _DECIMAL.fullmatch(cell):
        msg = f"field {name!r} is not a decimal number: {cell!r}"
        raise NmeaError(msg)
    return float(cell)


def _float(cell: str, name: str) -> float:
    if not _DECIMAL.fullmatch(_required(cell, name)):
        msg = f"field {name!r} is not a decimal number: {cell!r}"
        raise NmeaError(msg)
    return float(cell)


def _opt_int(cell: str, name: str, *, signed: bool = False) -> int | None:
    if cell == "":
        return None
    if not (_SINT if signed else _UINT).fullmatch(cell):
        msg = f"field {name!r} is not an integer (up to 9 digits): {cell!r}"
        raise NmeaError(msg)
    return int(cell)


def _int(cell: str, name: str) -> int:
    if not _UINT.fullmatch(_required(cell, name)):
        msg = f"field {name!r} is not an integer (up to 9 digits): {cell!r}"
        raise NmeaError(msg)
    return int(cell)


def _time_of_day(cell: str) -> float:
    m = _TIME.fullmatch(_required(cell, "time"))
    if m is None:
        msg = f"field 'time' is not hhmmss[.ss]: {cell!r}"
        raise NmeaError(msg)
    hh, mm, ss = int(m[1]), int(m[2]), float(m[3])
    leap = (hh, mm) == (23, 59) and ss < 61.0
    if hh > 23 or mm > 59 or (ss >= 60.0 and not leap):
        msg = f"field 'time' is not a valid UTC time: {cell!r}"
        raise NmeaError(msg)
    return hh * 3600.0 + mm * 60.0 + ss


def _angle(cell: str, hemi: str, name: str, *, lat: bool) -> float:
    pattern, layout, limit = (_LAT, "ddmm.mm", 90.0) if lat else (_LON, "dddmm.mm", 180.0)
    m = pattern.fullmatch(_required(cell, name))
    if m is None:
        msg = f"field {name!r} is not {layout}: {cell!r}"
        raise NmeaError(msg)
    minutes = float(m[2])
    if minutes >= 60.0:
        msg = f"field {name!r} has minutes >= 60: {cell!r}"
        raise NmeaError(msg)
    value = int(m[1]) + minutes / 60.0
    if value > limit:
        msg = f"field {name!r} exceeds {limit:g} degrees: {cell!r}"
        raise NmeaError(msg)
    positive, negative = ("N", "S") if lat else ("E", "W")
    hemi_name = f"{name} hemisphere"
    if _required(hemi, hemi_name) not in (positive, negative):
        msg = f"field {hemi_name!r} must be {positive} or {negative}, got {hemi!r}"
        raise NmeaError(msg)
    return -value if hemi == negative else value


def _field_count(kind: str, fields: list[str], least: int, most: int) -> None:
    n = len(fields)
    if n < least:
        msg = f"truncated: {kind} needs {least} data fields, got {n}"
        raise NmeaError(msg)
    if n > most:
        msg = f"{kind} has {n} data fields, expected at most {most}"
        raise NmeaError(msg)


_TSS1_HORIZONTAL_ACC_M_S2 = 0.0383  # 3.83 cm/s^2 per bit (NovAtel OEM7 TSS1)
_TSS1_VERTICAL_ACC_M_S2 = 0.000625  # 0.0625 cm/s^2 per bit, two's complement


_EM3000_LENGTH = 10
_EM3000_SYNC2 = 0x90
_EM3000_LAYOUT = struct.Struct("<BBhhhH")


# ---------------------------------------------------------------------- sentences
def _to_ascii(text: object) -> str:
    """``text`` (str or bytes) as ASCII str, or `NmeaError` naming the first other character."""
    if isinstance(text, bytes | bytearray | memoryview):
        raw = bytes(text)
        if not raw.isascii():
            i = next(k for k, b in enumerate(raw) if b > 0x7F)
            msg = f"not ASCII: byte 0x{raw[i]:02X} at position {i}"
            raise NmeaError(msg)
        return raw.decode("ascii")
    if isinstance(text, str):
        if not text.isascii():
            i = next(k for k, c in enumerate(text) if ord(c) > 0x7F)
            msg = f"not ASCII: {text[i]!r} at position {i}"
            raise NmeaError(msg)
        return text
    msg = f"expected str or bytes, got {type(text).__name__}"
    raise NmeaError(msg)


def _check_body(body: str) -> None:
    """Reject characters NMEA reserves or forbids between ``$`` and ``*``."""
    for i, c in enumerate(body):
        if c in "$!":
            msg = f"{c!r} inside the sentence at position {i + 1} (two sentences run together?)"
            raise NmeaError(msg)
        if c == "*":
            msg = f"'*' inside the sentence at position {i + 1}"
            raise NmeaError(msg)
        if c < " " or c == "\x7f":
            msg = f"control character 0x{ord(c):02X} inside the sentence at position {i + 1}"
            raise NmeaError(msg)


def nmea_checksum(body: str) -> int:
    """NMEA checksum: XOR of the characters between ``$`` and ``*``.

    Parameters
    ----------
    body : str
        The characters between ``$`` and ``*`` (talker, type and fields), ASCII.

    Returns
    -------
    int
        Checksum, 0..255.

    Raises
    ------
    NmeaError
        ``body`` is not an ASCII string, or contains ``$``, ``!``, ``*`` or a control
        character.
    """
    if not isinstance(body, str):
        msg = f"checksum body must be str, got {type(body).__name__}"
        raise NmeaError(msg)
    _check_body(_to_ascii(body))
    out = 0
    for c in body:
        out ^= ord(c)
    return out


def format_sentence(body: str) -> str:
    """``"$" + body + "*HH"`` with the checksum in uppercase hex, without CR LF.

    Parameters
    ----------
    body : str
        Talker, type and fields, e.g. ``"GPZDA,201530.00,04,07,2002,00,00"``.

    Raises
    ------
    NmeaError
        As `nmea_checksum`.
    """
    return f"${body}*{nmea_checksum(body):02X}"


def _split_checksummed(text: str) -> str:
    """Body of a ``$body*hh`` sentence whose checksum is verified."""
    s = text.strip()
    if not s:
        msg = "empty sentence"
        raise NmeaError(msg)
    if s[0] != "$":
        msg = f"does not start with '$': {s[:12]!r}"
        raise NmeaError(msg)
    star = s.find("*")
    if star < 0:
        msg = "truncated or no checksum: '*hh' missing at the end"
        raise NmeaError(msg)
    body, given = s[1:star], s[star + 1 :]
    _check_body(body)
    if len(given) < 2 and _HEX2.fullmatch(given.ljust(2, "0")):
        msg = f"truncated checksum '*{given}'"
        raise NmeaError(msg)
    if not _HEX2.fullmatch(given):
        msg = f"malformed checksum '*{given}' (expected two hex digits, then the end)"
        raise NmeaError(msg)
    computed = nmea_checksum(body)
    if int(given, 16) != computed:
        msg = f"bad checksum (got {given.upper()}, computed {computed:02X})"
        raise NmeaError(msg)
    return body


def _parse_zda(talker: str, f: list[str]) -> ZdaRecord:
    _field_count("ZDA", f, 6, 6)
    year = f[3]
    if year and not _DIGITS4.fullmatch(year):
        msg = f"field 'year' is not a four-digit year: {year!r}"
        raise NmeaError(msg)
    return ZdaRecord(
        talker=talker,
        utc_time_of_day_s=_time_of_day(f[0]),
        day=_int(f[1], "day"),
        month=_int(f[2], "month"),
        year=_int(year, "year"),
        zone_hours=_opt_int(f[4], "zone hours", signed=True),
        zone_minutes=_opt_int(f[5], "zone minutes", signed=True),
    )


def _unit(cell: str, name: str, value: float | None) -> None:
    if cell not in ("", "M") or (cell == "" and value is not None):
        msg = f"field {name!r} must be 'M' (metres), got {cell!r}"
        raise NmeaError(msg)


def _parse_gga(talker: str, f: list[str]) -> GgaRecord:
    _field_count("GGA", f, 14, 14)
    altitude = _opt_float(f[8], "altitude")
    _unit(f[9], "altitude unit", altitude)
    separation = _opt_float(f[10], "geoid separation")
    _unit(f[11], "geoid separation unit", separation)
    return GgaRecord(
        talker=talker,
        utc_time_of_day_s=_time_of_day(f[0]),
        lat_deg=_angle(f[1], f[2], "latitude", lat=True),
        lon_deg=_angle(f[3], f[4], "longitude", lat=False),
        fix_quality=_int(f[5], "fix quality"),
        n_satellites=_opt_int(f[6], "satellites"),
        hdop=_opt_float(f[7], "hdop"),
        altitude_msl_m=altitude,
        geoid_separation_m=separation,
        age_of_corrections_s=_opt_float(f[12], "age of corrections"),
        station_id=f[13] or None,
    )


def _parse_rmc(talker: str, f: list[str]) -> RmcRecord:
    # 11 fields (NMEA 2.0), + mode indicator (2.3), + navigational status (4.1).
    _field_count("RMC", f, 11, 13)
    status = _required(f[1], "status")
    if status not in ("A", "V"):
        msg = f"field 'status' must be A or V, got {status!r}"
        raise NmeaError(msg)
    m = _DATE6.fullmatch(_required(f[8], "date"))
    if m is None:
        msg = f"field 'date' is not ddmmyy: {f[8]!r}"
        raise NmeaError(msg)
    yy = int(m[3])
    variation = _opt_float(f[9], "magnetic variation")
    if variation is not None:
        direction = _required(f[10], "magnetic variation direction")
        if direction not in ("E", "W"):
            msg = f"field 'magnetic variation direction' must be E or W, got {direction!r}"
            raise NmeaError(msg)
        variation = -variation if direction == "W" else variation
    elif f[10] not in ("", "E", "W"):
        msg = f"field 'magnetic variation direction' must be E or W, got {f[10]!r}"
        raise NmeaError(msg)
    for i, name in ((11, "mode"), (12, "navigational status")):
        if i < len(f) and not re.fullmatch(r"[A-Z]?", f[i]):
            msg = f"field {name!r} must be one letter, got {f[i]!r}"
            raise NmeaError(msg)
    return RmcRecord(
        talker=talker,
        utc_time_of_day_s=_time_of_day(f[0]),
        status_valid=status == "A",
        lat_deg=_angle(f[2], f[3], "latitude", lat=True),
        lon_deg=_angle(f[4], f[5], "longitude", lat=False),
        speed_m_s=_float(f[6], "speed") * _KNOT_M_S,
        course_deg=_opt_float(f[7], "course"),
        day=int(m[1]),
        month=int(m[2]),
        year=(1900 if yy >= 80 else 2000) + yy,
        magnetic_variation_deg=variation,
    )


def _parse_hdt(talker: str, f: list[str]) -> HdtRecord:
    _field_count("HDT", f, 2, 2)
    if _required(f[1], "true") != "T":
        msg = f"field 'true' must be T, got {f[1]!r}"
        raise NmeaError(msg)
    return HdtRecord(talker=talker, heading_deg=_float(f[0], "heading"))


def _parse_pashr(f: list[str]) -> PashrRecord:
    if f and re.fullmatch(r"[A-Z]{3}", f[0]):
        msg = (
            f"unsupported sentence type 'PASHR,{f[0]}' (Ashtech proprietary); only the "
            "attitude PASHR (hhmmss.sss,heading,T,roll,pitch,heave,...) is read"
        )
        raise NmeaError(msg)
    # Applanix LVX ends with an empty twelfth field ("...,d,e,*hh").
    if len(f) == 12 and f[11] == "":
        f = f[:11]
    _field_count("PASHR", f, 6, 11)
    f = f + [""] * (11 - len(f))
    if f[2] not in ("T", ""):
        msg = f"field 'true heading flag' must be T or empty, got {f[2]!r}"
        raise NmeaError(msg)
    return PashrRecord(
        utc_time_of_day_s=_time_of_day(f[0]),
        heading_deg=_float(f[1], "heading"),
        heading_true=f[2] == "T",
        roll_deg=_float(f[3], "roll"),
        pitch_deg=_float(f[4], "pitch"),
        heave_m=_opt_float(f[5], "heave"),
        roll_std_deg=_opt_float(f[6], "roll accuracy"),
        pitch_std_deg=_opt_float(f[7], "pitch accuracy"),
        heading_std_deg=_opt_float(f[8], "heading accuracy"),
        aiding_status=_opt_int(f[9], "aiding status"),
        imu_status=_opt_int(f[10], "IMU status"),
    )


def parse_sentence(text: str | bytes) -> NmeaRecord:
    """Parse one NMEA sentence: ZDA, GGA, RMC, HDT (any talker) or PASHR.

    Parameters
    ----------
    text : str or bytes
        ``$<address>,<fields>*hh``; surrounding whitespace and CR LF are ignored. The
        checksum is required and verified (hex digits in either case).

    Returns
    -------
    ZdaRecord, GgaRecord, RmcRecord, HdtRecord or PashrRecord

    Raises
    ------
    NmeaError
        For any input that is not such a sentence, with a short reason: "not ASCII",
        "truncated", "bad checksum (got 4A, computed 4B)", "empty field 'day'",
        "unsupported sentence type 'GSV'", an out-of-range value, ...
    """
    body = _split_checksummed(_to_ascii(text))
    address, *fields = body.split(",")
    if not _ADDRESS.fullmatch(address):
        msg = f"malformed address field {address!r} (expected e.g. GPZDA or PASHR)"
        raise NmeaError(msg)
    if address[0] == "P":  # proprietary: P + manufacturer + type; no talker
        if address == "PASHR":
            return _parse_pashr(fields)
        msg = f"unsupported sentence type {address!r}"
        raise NmeaError(msg)
    if len(address) != 5:
        msg = f"malformed address field {address!r} (expected two-letter talker + type)"
        raise NmeaError(msg)
    talker, kind = address[:2], address[2:]
    if kind == "ZDA":
        return _parse_zda(talker, fields)
    if kind == "GGA":
        return _parse_gga(talker, fields)
    if kind == "RMC":
        return _parse_rmc(talker, fields)
    if kind == "HDT":
        return _parse_hdt(talker, fields)
    msg = f"unsupported sentence type {kind!r}"
    raise NmeaError(msg)


# ---------------------------------------------------------------------- attitude records
def _tss1_signed(sign: str, digits: str, name: str) -> int:
    if sign not in (" ", "+", "-"):
        msg = f"TSS1 {name} sign must be a space or '-', got {sign!r}"
        raise NmeaError(msg)
    if not _DIGITS4.fullmatch(digits):
        msg = f"TSS1 {name} must be four digits, got {digits!r}"
        raise NmeaError(msg)
    return -int(digits) if sign == "-" else int(digits)


def parse_tss1(text: str | bytes) -> Tss1Record:
    """Parse a TSS1 record ``:XXAAAA MHHHHQMRRRR MPPPP`` (CR LF optional).

    Parameters
    ----------
    text : str or bytes
        The 25-character record: ``:``, horizontal acceleration (2 hex digits,
        3.83 cm/s^2), vertical acceleration (4 hex digits, two's complement,
        0.0625 cm/s^2), space, heave sign and 4 digits (cm), status letter, roll sign
        and 4 digits (0.01 deg), space, pitch sign and 4 digits (0.01 deg). A sign is a
        space (or ``+``) when positive, ``-`` when negative.

    Returns
    -------
    Tss1Record
        Converted to m/s^2, m and degrees; signs as documented in the module.

    Raises
    ------
    NmeaError
        Any other input: wrong length ("truncated" when shorter), start character,
        separators, non-hex or non-digit fields, unknown status letter.
    """
    s = _to_ascii(text).rstrip("\r\n")
    if len(s) < 25:
        msg = f"truncated: TSS1 record has {len(s)} characters, expected 25"
        raise NmeaError(msg)
    if len(s) > 25:
        msg = f"TSS1 record has {len(s)} characters, expected 25"
        raise NmeaError(msg)
    if s[0] != ":":
        msg = f"TSS1 record must start with ':', got {s[0]!r}"
        raise NmeaError(msg)
    horizontal, vertical = s[1:3], s[3:7]
    if not (_HEX2.fullmatch(horizontal) and _HEX4.fullmatch(vertical)):
        msg = f"TSS1 accelerations must be hex digits, got {s[1:7]!r}"
        raise NmeaError(msg)
    if s[7] != " " or s[19] != " ":
        msg = "TSS1 record must have spaces at positions 7 and 19"
        raise NmeaError(msg)
    vertical_raw = int(vertical, 16)
    if vertical_raw >= 0x8000:
        vertical_raw -= 0x10000
    status = s[13]
    if status not in TSS1_STATUS:
        msg = f"TSS1 status must be one of {', '.join(TSS1_STATUS)}, got {status!r}"
        raise NmeaError(msg)
    return Tss1Record(
        horizontal_acc_m_s2=int(horizontal, 16) * _TSS1_HORIZONTAL_ACC_M_S2,
        vertical_acc_m_s2=vertical_raw * _TSS1_VERTICAL_ACC_M_S2,
        heave_m=_tss1_signed(s[8], s[9:13], "heave") / 100.0,
        status=status,
        roll_deg=_tss1_signed(s[14], s[15:19], "roll") / 100.0,
        pitch_deg=_tss1_signed(s[20], s[21:25], "pitch") / 100.0,
    )


def parse_em3000(data: bytes) -> Em3000Record:
    """Parse a Kongsberg EM3000 binary attitude datagram (exactly 10 bytes).

    Parameters
    ----------
    data : bytes
        Sync byte 1 / sensor status (``0x00`` or ``0x90``..``0xAF``), sync byte 2
        (``0x90``), roll, pitch, heave (int16) and heading (uint16), little-endian,
        0.01 deg / 0.01 m per bit.

    Returns
    -------
    Em3000Record

    Raises
    ------
    NmeaError
        Not bytes, not 10 bytes ("truncated" when shorter), a bad sync byte, or a value
        outside its valid range (which Kongsberg defines as not valid).
    """
    if not isinstance(data, bytes | bytearray | memoryview):
        msg = f"EM3000 datagram must be bytes, got {type(data).__name__}"
        raise NmeaError(msg)
    raw = bytes(data)
    if len(raw) < _EM3000_LENGTH:
        msg = f"truncated: EM3000 datagram has {len(raw)} bytes, expected {_EM3000_LENGTH}"
        raise NmeaError(msg)
    if len(raw) > _EM3000_LENGTH:
        msg = f"EM3000 datagram has {len(raw)} bytes, expected {_EM3000_LENGTH}"
        raise NmeaError(msg)
    status, sync2, roll, pitch, heave, heading = _EM3000_LAYOUT.unpack(raw)
    if sync2 != _EM3000_SYNC2:
        msg = f"EM3000 sync byte 2 must be 0x90, got 0x{sync2:02X}"
        raise NmeaError(msg)
    return Em3000Record(
        sensor_status=status,
        roll_deg=roll / 100.0,
        pitch_deg=pitch / 100.0,
        heave_m=heave / 100.0,
        heading_deg=heading / 100.0,
    )


# ---------------------------------------------------------------------- log file
NMEA_LOG_HEADER = ("t_local_s", "sentence")
"""Columns of an NMEA log file (``nmea.csv``)."""

MAX_NMEA_LOG_BYTES = 1 << 30
"""Largest NMEA log read (1 GiB; a day of 10 sentences per second is about 70 MB)."""

MAX_NMEA_LINE_BYTES = 4096
"""Longest line of an NMEA log (an NMEA sentence is at most 82 characters; with its time
and quotes a line is under 200 bytes): a longer one is rejected, shown cut to its first
80 bytes, and never held whole (the log is read line by line)."""

_SHOWN_BYTES = 80


def _log_lines(fh: BinaryIO, end: bytes) -> Iterator[tuple[bytes, bool]]:
    """Each line of a binary file, without its end, and whether it was cut short.

    ``end`` is the line end: LF (a CR before it is dropped too) or, for a file with
    CR-only line ends (old Mac style), CR. A line longer than `MAX_NMEA_LINE_BYTES`
    gives its first bytes only; the rest of it is read and dropped block by block, so
    memory stays bounded whatever the file holds.
    """
    pending = b""  # the current line so far, never longer than MAX_NMEA_LINE_BYTES
    cut: bytes | None = None  # the shown start of a line found too long, until its end
    while block := fh.read(1 << 16):
        pieces = block.split(end)
        for i, piece in enumerate(pieces):
            if cut is None:
                pending += piece
                if len(pending) > MAX_NMEA_LINE_BYTES:
                    cut, pending = pending[:_SHOWN_BYTES], b""
            if i == len(pieces) - 1:
                continue  # no line end after the block's last piece
            if cut is not None:
                yield cut, True
                cut = None
            else:
                yield pending.removesuffix(b"\r"), False
                pending = b""
    if cut is not None:
        yield cut, True
    elif pending:
        yield pending.removesuffix(b"\r"), False


def _line_end(fh: BinaryIO) -> bytes:
    """LF, or CR for a file whose first block holds CR line ends and no LF."""
    probe = fh.read(1 << 16)
    fh.seek(0)
    return b"\r" if b"\r" in probe and b"\n" not in probe else b"\n"


def _display(raw: bytes) -> str:
    return raw.decode("utf-8", "backslashreplace")


def _unquote(cell: bytes) -> bytes:
    s = cell.strip()
    if len(s) >= 2 and s[:1] == b'"' and s[-1:] == b'"':
        return s[1:-1].replace(b'""', b'"')
    return s


def _arrival_time(cell: bytes) -> float | str:
    """The arrival time of a line (s), or why it is not one."""
    s = cell.strip().decode("ascii", "replace")
    shown = _display(cell.strip()[:80])
    value = float(s) if _NUMBER.fullmatch(s) else math.nan
    if not math.isfinite(value):
        return f"t_local_s {shown!r} is not a finite number"
    if not TIME_S.low <= value <= TIME_S.high:
        return (
            f"t_local_s {shown!r} is outside {TIME_S.low:g} to {TIME_S.high:g} s, the "
            f"plausible span of {TIME_S.what}"
        )
    return value


def _read_line(line_no: int, raw: bytes) -> tuple[float, NmeaRecord, str] | RejectedLine:
    """One data line: (time, record, sentence) or the reason it is rejected."""
    time_cell, comma, sentence_cell = raw.partition(b",")
    if not comma:
        reason = "no comma: expected t_local_s,sentence"
        return RejectedLine(line_no, None, _display(raw.strip()), reason)
    sentence = _unquote(sentence_cell)
    t = _arrival_time(time_cell)
    if isinstance(t, str):
        return RejectedLine(line_no, None, _display(sentence), t)
    try:
        record = parse_sentence(sentence)
    except NmeaError as err:
        return RejectedLine(line_no, t, _display(sentence), str(err))
    return t, record, sentence.decode("ascii").strip()


def _check_header(path: Path, head: bytes, lines: Iterator[tuple[bytes, bool]]) -> None:
    """Refuse a first line that is not the header ``t_local_s,sentence``, saying why.

    ``lines`` (the rest of the file) is read only to tell an empty file from one whose
    first line is blank.
    """
    header_text = _display(head)
    header = tuple(c.strip().strip('"').strip() for c in header_text.split(","))
    if header != NMEA_LOG_HEADER:
        shown = header_text.strip()
        if len(shown) > _SHOWN_BYTES:
            shown = shown[:_SHOWN_BYTES] + "..."
        by_tab = tuple(c.strip().strip('"').strip() for c in header_text.split("\t"))
        if by_tab == NMEA_LOG_HEADER:
            msg = (
                f"{path}: line 1: the file looks tab-separated (t_local_s and sentence "
                "split by a tab); an NMEA log must use a comma: write each line as "
                "t_local_s,sentence"
            )
            raise NmeaError(msg)
        blank = not shown and not any(line.strip() for line, _ in lines)
        what = "empty file" if blank else f"header is {shown!r}"
        msg = f"{path}: line 1: {what}; expected the header t_local_s,sentence"
        raise NmeaError(msg)


def read_nmea_log(path: Path) -> NmeaLog:
    """Read an NMEA log ``nmea.csv`` (``t_local_s,sentence`` per line).

    Parameters
    ----------
    path : Path
        CSV file with the header ``t_local_s,sentence``; each line holds the local
        arrival time (end of reception, s) and the raw sentence, quoted or not
        (everything after the first comma; surrounding double quotes removed). Lines
        end with LF or CRLF, or with CR in a file without LF. Blank lines are skipped.
        Lines are decoded one by one, so a byte that is not ASCII rejects its line only.

    Returns
    -------
    NmeaLog
        Accepted records in file order; every other line in ``rejected`` with its reason
        (time not a finite number, not ASCII, truncated, bad checksum, unsupported
        type, empty or invalid field, ...).

    Raises
    ------
    NmeaError
        Naming the file (and line): missing or unreadable file, one larger than
        `MAX_NMEA_LOG_BYTES` or whose first line is not text
        (`kinsync.io.sanity.check_text_file`), missing or wrong header, no data line,
        no line usable.
    """
    path = Path(path)
    try:
        check_text_file(
            path,
            "NMEA log file",
            max_bytes=MAX_NMEA_LOG_BYTES,
            nul_after_first_line=True,
        )
        fh = path.open("rb")
    except InputError as err:
        raise NmeaError(str(err)) from err
    except OSError as err:
        msg = f"{path}: cannot read ({err})"
        raise NmeaError(msg) from err
    accepted: list[tuple[int, float, NmeaRecord, str]] = []
    rejected: list[RejectedLine] = []
    with fh:
        lines = _log_lines(fh, _line_end(fh))
        head, cut = next(lines, (b"", False))
        head = head.removeprefix(b"\xef\xbb\xbf")
        if cut:
            msg = (
                f"{path}: line 1: no line end in its first {MAX_NMEA_LINE_BYTES} bytes "
                f"(starts {_display(head)!r}); expected the header t_local_s,sentence and "
                "one line per sentence"
            )
            raise NmeaError(msg)
        _check_header(path, head, lines)
        for line_no, (raw, cut) in enumerate(lines, start=2):
            if cut:
                reason = f"line longer than {MAX_NMEA_LINE_BYTES} bytes: not an NMEA sentence"
                rejected.append(RejectedLine(line_no, None, _display(raw) + "...", reason))
                continue
            if not raw.strip():
                continue
            result = _read_line(line_no, raw)
            if isinstance(result, RejectedLine):
                rejected.append(result)
            else:
                accepted.append((line_no, *result))
    if not accepted:
        n = len(rejected)
        first = f" (line {rejected[0].line}: {rejected[0].reason})" if rejected else ""
        what = f"none of its {n} data lines is a usable sentence{first}" if n else "no data lines"
        msg = f"{path}: {what}; expected lines t_local_s,$GPZDA,...*hh"
        raise NmeaError(msg)
    return NmeaLog(
        source=str(path),
        t_local_s=np.array([a[1] for a in accepted], dtype=np.float64),
        records=tuple(a[2] for a in accepted),
        rejected=tuple(rejected),
        raw_sentences=tuple(a[3] for a in accepted),
        lines=tuple(a[0] for a in accepted),
    )
