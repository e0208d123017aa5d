"""Records of serial navigation messages: NMEA 0183 sentences, TSS1 and EM3000 attitude.

The containers that `kinsync.io.nmea` parses sentences into and that the algorithms
read (the clock fit takes an `NmeaLog` and its `ZdaRecord` s): ZDA (UTC time and
date), GGA (position fix), RMC (minimum navigation data), HDT (true heading), the
proprietary attitude sentence PASHR, the TSS1 and Kongsberg EM3000 attitude records,
and an `NmeaLog` of records with their local arrival times. Each record checks its own
fields on construction and raises `NmeaError` (an `InputError`) naming the field.

Units and signs
---------------
Latitude and longitude in degrees, north and east positive. Heights in metres. Speed
in m/s (RMC knots x 1852/3600). Headings and courses in degrees clockwise from true
north. Magnetic variation in degrees, east positive. Times of day in seconds since UTC
midnight; a two-digit RMC year ``yy`` is 19yy for yy >= 80 and 20yy otherwise (the GPS
epoch is 1980). Roll, pitch and heave are returned as the device sends them:

- PASHR: roll positive port side up (starboard down), pitch positive bow up (POS MV's
  right-handed vessel frame; POS MV sends them in the Tait-Bryan or the TSS convention,
  a device setting: Applanix POS MV V5 guide, table 20). Heave in metres as sent: the
  NovAtel, Applanix and Trimble PASHR documents do not state its sign.
- TSS1: roll positive port side up, pitch positive bow up, heave positive up (cm on the
  wire), vertical acceleration positive up. Roll is in the TSS convention: the angle of
  the starboard axis from the horizontal plane, so ``sin(roll_tss) = sin(roll) cos(pitch)``
  with ``roll`` the DIN 9300 Euler roll; pitch is the Euler pitch.
- EM3000: roll positive port side up, pitch positive bow up, heave positive up (cm on
  the wire), heading clockwise (0.01 deg, unsigned). Whether roll is measured from the
  horizontal plane (TSS) or about the pitched X axis (Euler) is a sensor setting.

Port-up roll and bow-up pitch are the signs of kinsync's roll and pitch (Forward-Right-
Down body frame), so no sign changes; heave up is ``-`` the Down axis.

References
----------
NMEA 0183 Standard for Interfacing Marine Electronic Devices, v4.11 (2018).
Applanix POS MV V5 Installation and Operation Guide, tables 20 ($PASHR) and 22 (TSS1).
"""

from __future__ import annotations

import datetime as _dt
import math
import re
from dataclasses import dataclass
from typing import TypeAlias

import numpy as np

from kinsync._arrays import ReadOnlyArrays
from kinsync._typing import FloatArray
from kinsync.errors import InputError

__all__ = [
    "TSS1_STATUS",
    "UNSUPPORTED_REASON",
    "Em3000Record",
    "GgaRecord",
    "HdtRecord",
    "NmeaError",
    "NmeaLog",
    "NmeaRecord",
    "PashrRecord",
    "RejectedLine",
    "RmcRecord",
    "Tss1Record",
    "ZdaRecord",
]


class NmeaError(InputError):
    """An NMEA sentence, attitude record or NMEA log that cannot be used (the reason says why)."""


_SECONDS_PER_DAY = 86400
TSS1_STATUS = "UuGgHhFf"
"""Status letters of a TSS1 record (unaided, GNSS, heading, fully aided; lowercase settling)."""
"""Status characters a TSS1 record may carry (U/u unaided, G/g GNSS, H/h heading, F/f full)."""
_POSIX_EPOCH_ORDINAL = _dt.date(1970, 1, 1).toordinal()


def _check_range(name: str, value: float | None, lo: float, hi: float) -> None:
    """Raise `NmeaError` unless ``value`` is None or finite within ``[lo, hi]``."""
    if value is None:
        return
    finite = isinstance(value, int) or math.isfinite(value)  # isfinite(huge int) overflows
    if not (finite and lo <= value <= hi):
        msg = f"field {name!r} out of range {lo:g}..{hi:g}: {value!r}"
        raise NmeaError(msg)


def _check_date(day: int, month: int, year: int) -> None:
    _check_range("year", year, 1, 9999)
    _check_range("month", month, 1, 12)
    try:
        _dt.date(year, month, day)
    except (ValueError, OverflowError):
        msg = f"field 'day' out of range for {year:04d}-{month:02d}: {day!r}"
        raise NmeaError(msg) from None


def _check_time_of_day(value: float) -> None:
    # 86401 s: a leap second 23:59:60.x is a valid UTC time of day.
    if not (math.isfinite(value) and 0.0 <= value < _SECONDS_PER_DAY + 1):
        msg = f"field 'time' out of range 0..86401 s: {value!r}"
        raise NmeaError(msg)


def _posix_s(day: int, month: int, year: int, utc_time_of_day_s: float) -> float:
    days = _dt.date(year, month, day).toordinal() - _POSIX_EPOCH_ORDINAL
    return float(days * _SECONDS_PER_DAY) + utc_time_of_day_s


@dataclass(frozen=True)
class ZdaRecord:
    """UTC time and date (``$--ZDA,hhmmss.ss,dd,mm,yyyy,zh,zm*hh``).

    Attributes
    ----------
    talker : str
        Talker identifier, e.g. ``"GP"``, ``"GN"``.
    utc_time_of_day_s : float
        Seconds since UTC midnight (``hhmmss.ss``; up to 86401 s in a leap second).
    day, month, year : int
        UTC date (four-digit year).
    zone_hours, zone_minutes : int or None
        Local zone description (hours -13..13, minutes -59..59), None when empty.
    """

    talker: str
    utc_time_of_day_s: float
    day: int
    month: int
    year: int
    zone_hours: int | None
    zone_minutes: int | None

    def __post_init__(self) -> None:
        _check_time_of_day(self.utc_time_of_day_s)
        _check_date(self.day, self.month, self.year)
        _check_range("zone hours", self.zone_hours, -13, 13)
        _check_range("zone minutes", self.zone_minutes, -59, 59)

    @property
    def utc_posix_s(self) -> float:
        """POSIX seconds (s since 1970-01-01T00:00:00 UTC, leap seconds not counted).

        A leap second 23:59:60.x maps onto the first second of the next day, as POSIX
        does; the UTC -> GPS conversion (leap-second table) is the caller's.
        """
        return _posix_s(self.day, self.month, self.year, self.utc_time_of_day_s)


@dataclass(frozen=True)
class GgaRecord:
    """GNSS position fix (``$--GGA``).

    Attributes
    ----------
    talker : str
        Talker identifier.
    utc_time_of_day_s : float
        Seconds since UTC midnight of the fix.
    lat_deg, lon_deg : float
        Geodetic latitude and longitude (deg, north and east positive).
    fix_quality : int
        0 invalid, 1 GNSS, 2 DGNSS, 3 PPS, 4 RTK fixed, 5 RTK float, 6 dead reckoning,
        7 manual, 8 simulation, 9 SBAS (some receivers).
    n_satellites : int or None
        Satellites in use.
    hdop : float or None
        Horizontal dilution of precision.
    altitude_msl_m : float or None
        Antenna height above mean sea level (geoid) (m).
    geoid_separation_m : float or None
        Geoid height above the ellipsoid (m); ellipsoidal height = altitude + separation.
    age_of_corrections_s : float or None
        Age of the differential corrections (s).
    station_id : str or None
        Differential reference station identifier.
    """

    talker: str
    utc_time_of_day_s: float
    lat_deg: float
    lon_deg: float
    fix_quality: int
    n_satellites: int | None
    hdop: float | None
    altitude_msl_m: float | None
    geoid_separation_m: float | None
    age_of_corrections_s: float | None
    station_id: str | None

    def __post_init__(self) -> None:
        _check_time_of_day(self.utc_time_of_day_s)
        _check_range("latitude", self.lat_deg, -90.0, 90.0)
        _check_range("longitude", self.lon_deg, -180.0, 180.0)
        _check_range("fix quality", self.fix_quality, 0, 9)
        _check_range("satellites", self.n_satellites, 0, 999)
        _check_range("hdop", self.hdop, 0.0, math.inf)
        _check_range("altitude", self.altitude_msl_m, -math.inf, math.inf)
        _check_range("geoid separation", self.geoid_separation_m, -math.inf, math.inf)
        _check_range("age of corrections", self.age_of_corrections_s, 0.0, math.inf)


@dataclass(frozen=True)
class RmcRecord:
    """Recommended minimum navigation data (``$--RMC``).

    Attributes
    ----------
    talker : str
        Talker identifier.
    utc_time_of_day_s : float
        Seconds since UTC midnight.
    status_valid : bool
        True for status ``A`` (valid), False for ``V`` (navigation receiver warning).
    lat_deg, lon_deg : float
        Latitude and longitude (deg, north and east positive).
    speed_m_s : float
        Speed over ground (m/s; sent in knots).
    course_deg : float or None
        Course over ground (deg clockwise from true north); None when empty.
    day, month, year : int
        UTC date (two-digit year yy read as 19yy for yy >= 80, else 20yy).
    magnetic_variation_deg : float or None
        Magnetic variation (deg, east positive); None when empty.
    """

    talker: str
    utc_time_of_day_s: float
    status_valid: bool
    lat_deg: float
    lon_deg: float
    speed_m_s: float
    course_deg: float | None
    day: int
    month: int
    year: int
    magnetic_variation_deg: float | None

    def __post_init__(self) -> None:
        _check_time_of_day(self.utc_time_of_day_s)
        _check_range("latitude", self.lat_deg, -90.0, 90.0)
        _check_range("longitude", self.lon_deg, -180.0, 180.0)
        _check_range("speed", self.speed_m_s, 0.0, math.inf)
        _check_range("course", self.course_deg, 0.0, 360.0)
        _check_date(self.day, self.month, self.year)
        _check_range("magnetic variation", self.magnetic_variation_deg, -180.0, 180.0)

    @property
    def utc_posix_s(self) -> float:
        """POSIX seconds of the record's UTC instant (see `ZdaRecord.utc_posix_s`)."""
        return _posix_s(self.day, self.month, self.year, self.utc_time_of_day_s)


@dataclass(frozen=True)
class HdtRecord:
    """True heading (``$--HDT,x.x,T``).

    Attributes
    ----------
    talker : str
        Talker identifier (``HE`` gyro, ``GP``/``GN`` dual-antenna GNSS, ``IN`` INS).
    heading_deg : float
        Heading, degrees clockwise from true north, 0..360.
    """

    talker: str
    heading_deg: float

    def __post_init__(self) -> None:
        _check_range("heading", self.heading_deg, 0.0, 360.0)


@dataclass(frozen=True)
class PashrRecord:
    """Attitude sentence ``$PASHR,hhmmss.sss,HHH.HH,T,RRR.RR,PPP.PP,heave,rr,pp,hh,d,e``.

    Attributes
    ----------
    utc_time_of_day_s : float
        Seconds since UTC midnight of the attitude.
    heading_deg : float
        Heading (deg clockwise, 0..360).
    heading_true : bool
        True when the flag field is ``T`` (heading relative to true north), False when
        empty.
    roll_deg : float
        Roll (deg), positive port side up.
    pitch_deg : float
        Pitch (deg), positive bow up.
    heave_m : float or None
        Heave (m) as sent (sign not stated by the vendors); None when the field is
        empty (Trimble documents it as reserved).
    roll_std_deg, pitch_std_deg, heading_std_deg : float or None
        Standard deviations (deg); None when empty or absent.
    aiding_status : int or None
        GNSS aiding/quality flag (e.g. 0 none, 1 GNSS, 2 RTK or GNSS+GAMS).
    imu_status : int or None
        IMU status flag (e.g. POS MV: 0 IMU out, 1 satisfactory); None when absent
        (NovAtel firmware before 7.03 omits it).
    """

    utc_time_of_day_s: float
    heading_deg: float
    heading_true: bool
    roll_deg: float
    pitch_deg: float
    heave_m: float | None
    roll_std_deg: float | None
    pitch_std_deg: float | None
    heading_std_deg: float | None
    aiding_status: int | None
    imu_status: int | None

    def __post_init__(self) -> None:
        _check_time_of_day(self.utc_time_of_day_s)
        _check_range("heading", self.heading_deg, 0.0, 360.0)
        _check_range("roll", self.roll_deg, -180.0, 180.0)
        _check_range("pitch", self.pitch_deg, -180.0, 180.0)
        _check_range("heave", self.heave_m, -math.inf, math.inf)
        _check_range("roll accuracy", self.roll_std_deg, 0.0, math.inf)
        _check_range("pitch accuracy", self.pitch_std_deg, 0.0, math.inf)
        _check_range("heading accuracy", self.heading_std_deg, 0.0, math.inf)
        _check_range("aiding status", self.aiding_status, 0, 99)
        _check_range("IMU status", self.imu_status, 0, 99)


NmeaRecord: TypeAlias = ZdaRecord | GgaRecord | RmcRecord | HdtRecord | PashrRecord
"""Any record `parse_sentence` returns."""


@dataclass(frozen=True)
class Tss1Record:
    """TSS1 heave, roll and pitch record (``:XXAAAA MHHHHQMRRRR MPPPP``, 25 characters).

    Attributes
    ----------
    horizontal_acc_m_s2 : float
        Horizontal (sway) acceleration magnitude, 0..9.77 m/s^2 (3.83 cm/s^2 steps).
    vertical_acc_m_s2 : float
        Vertical (heave) acceleration, positive up, -20.48..20.48 m/s^2
        (0.0625 cm/s^2 steps).
    heave_m : float
        Heave (m), positive up (cm on the wire).
    status : str
        ``U``/``u`` unaided, ``G``/``g`` speed (GNSS) aided, ``H``/``h`` heading aided,
        ``F``/``f`` fully aided; uppercase settled, lowercase settling (unstable).
    roll_deg : float
        Roll (deg, TSS convention: from the horizontal plane), positive port side up.
    pitch_deg : float
        Pitch (deg), positive bow up.

    References
    ----------
    NovAtel OEM7 Commands and Logs Reference, TSS1; Applanix POS MV V5 guide, table 22;
    Kongsberg "Teledyne TSS1 datagram format".
    """

    horizontal_acc_m_s2: float
    vertical_acc_m_s2: float
    heave_m: float
    status: str
    roll_deg: float
    pitch_deg: float

    def __post_init__(self) -> None:
        _check_range("horizontal acceleration", self.horizontal_acc_m_s2, 0.0, 255 * 0.0383)
        _check_range("vertical acceleration", self.vertical_acc_m_s2, -20.48, 20.48)
        _check_range("heave", self.heave_m, -99.99, 99.99)
        if len(self.status) != 1 or self.status not in TSS1_STATUS:
            msg = f"TSS1 status must be one of {', '.join(TSS1_STATUS)}, got {self.status!r}"
            raise NmeaError(msg)
        _check_range("roll", self.roll_deg, -99.99, 99.99)
        _check_range("pitch", self.pitch_deg, -99.99, 99.99)

    @property
    def settled(self) -> bool:
        """True when the status letter is uppercase (sensor settled, data stable)."""
        return self.status.isupper()


@dataclass(frozen=True)
class Em3000Record:
    """Kongsberg EM3000 binary attitude datagram (10 bytes, little-endian).

    Layout: sync byte 1 / sensor status, sync byte 2 (``0x90``), then roll, pitch,
    heave as int16 two's complement and heading as uint16 (0..35999 does not fit an
    int16), least significant byte first; 0.01 deg and 0.01 m per bit. The datagram
    carries no time: it is tagged by its arrival time.

    Attributes
    ----------
    sensor_status : int
        First byte: ``0x00`` plain sync byte (no status), ``0x90`` valid with full
        accuracy, ``0x91``..``0x99`` valid with reduced accuracy (higher is worse),
        ``0x9A``..``0x9F`` not valid but normal operation (configuration,
        calibration), ``0xA0``..``0xAF`` sensor error.
    roll_deg : float
        Roll (deg), positive port side up, -179.99..179.99.
    pitch_deg : float
        Pitch (deg), positive bow up, -179.99..179.99.
    heave_m : float
        Heave (m), positive up, -9.99..9.99.
    heading_deg : float
        Heading (deg clockwise), 0..359.99.

    References
    ----------
    Kongsberg Maritime, "Kongsberg EM Attitude 3000 datagram format" (Simrad EK80 and
    EM series interface specifications).
    """

    sensor_status: int
    roll_deg: float
    pitch_deg: float
    heave_m: float
    heading_deg: float

    def __post_init__(self) -> None:
        s = self.sensor_status
        if not (s == 0x00 or 0x90 <= s <= 0xAF):
            msg = f"EM3000 sync byte 1 / sensor status must be 0x00 or 0x90..0xAF, got {s!r}"
            raise NmeaError(msg)
        _check_range("roll", self.roll_deg, -179.99, 179.99)
        _check_range("pitch", self.pitch_deg, -179.99, 179.99)
        _check_range("heave", self.heave_m, -9.99, 9.99)
        _check_range("heading", self.heading_deg, 0.0, 359.99)

    @property
    def valid(self) -> bool:
        """True for status ``0x00`` (none given) or ``0x90``..``0x99`` (valid data)."""
        return self.sensor_status == 0x00 or 0x90 <= self.sensor_status <= 0x99


UNSUPPORTED_REASON = "unsupported sentence type"
"""Start of the reason of a `RejectedLine` for a sentence type kinsync does not read."""
_UNSUPPORTED = re.compile(UNSUPPORTED_REASON + r" '([^']*)'")


@dataclass(frozen=True)
class RejectedLine:
    """A line of an NMEA log that was not used.

    Attributes
    ----------
    line : int
        1-based line number in the file (header = line 1).
    t_local_s : float or None
        Arrival time on the line, None when it was not a finite number.
    sentence : str
        The sentence text (bytes that are not UTF-8 shown as backslash escapes).
    reason : str
        Why it was not used.
    """

    line: int
    t_local_s: float | None
    sentence: str
    reason: str

    @property
    def unsupported_type(self) -> str | None:
        """Type of a well-formed sentence kinsync does not read, else None.

        ``'GSV'``, ``'PASHR,XYZ'``, ...; None for a line rejected as corrupt or invalid.
        Such lines are not errors: the receiver sends more than kinsync reads.
        """
        m = _UNSUPPORTED.match(self.reason)
        return None if m is None else m[1]


@dataclass(frozen=True, eq=False)
class NmeaLog(ReadOnlyArrays):
    """Sentences of an NMEA log with their local arrival times.

    Attributes
    ----------
    source : str
        File the log came from (for messages).
    t_local_s : ndarray, shape (N,)
        Local clock time of the end of reception of each accepted record (s), in file
        order.
    records : tuple of NmeaRecord, length N
        Parsed records, aligned with ``t_local_s``.
    rejected : tuple of RejectedLine
        Every non-blank data line not used, with its reason.
    raw_sentences : tuple of str, length N
        Each accepted record's sentence as received, ``$`` to checksum, without CR LF
        (its transmission takes ``len + 2`` characters).
    lines : tuple of int, length N or 0
        File line of each accepted record (empty when not known).
    """

    source: str
    t_local_s: FloatArray
    records: tuple[NmeaRecord, ...]
    rejected: tuple[RejectedLine, ...]
    raw_sentences: tuple[str, ...]
    lines: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        t = np.array(self.t_local_s, dtype=np.float64)
        n = len(self.records)
        if t.shape != (n,) or len(self.raw_sentences) != n or len(self.lines) not in (0, n):
            msg = (
                f"{self.source}: NmeaLog needs t_local_s of shape ({n},) and {n} raw "
                f"sentences for {n} records, got shape {t.shape} and "
                f"{len(self.raw_sentences)} sentences ({len(self.lines)} lines)"
            )
            raise NmeaError(msg)
        if not np.all(np.isfinite(t)):
            msg = f"{self.source}: NmeaLog t_local_s must be finite"
            raise NmeaError(msg)
        t.flags.writeable = False
        object.__setattr__(self, "t_local_s", t)

    def zda(self) -> tuple[FloatArray, tuple[ZdaRecord, ...]]:
        """Arrival times (s, shape (M,)) and the ZDA records only, in file order."""
        idx = [i for i, r in enumerate(self.records) if isinstance(r, ZdaRecord)]
        zdas = tuple(r for r in self.records if isinstance(r, ZdaRecord))
        return self.t_local_s[np.asarray(idx, dtype=np.int64)].copy(), zdas
