"""NMEA sentences, TSS1 and EM3000 attitude records, and the NMEA arrival log."""

from __future__ import annotations

import contextlib
import datetime as dt
import math
import struct
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from kinsync.errors import InputError
from kinsync.io.nmea import (
    MAX_NMEA_LINE_BYTES,
    format_sentence,
    nmea_checksum,
    parse_em3000,
    parse_sentence,
    parse_tss1,
    read_nmea_log,
)
from kinsync.messages import (
    Em3000Record,
    GgaRecord,
    HdtRecord,
    NmeaError,
    NmeaLog,
    PashrRecord,
    RejectedLine,
    RmcRecord,
    Tss1Record,
    ZdaRecord,
)

# Published examples (checksums verified in test_published_checksums).
ZDA = "$GPZDA,201530.00,04,07,2002,00,00*60"
GGA = "$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*47"
RMC = "$GPRMC,123519,A,4807.038,N,01131.000,E,022.4,084.4,230394,003.1,W*6A"
HDT = "$GPHDT,274.07,T*03"
PASHR = "$PASHR,163029.000,158.09,T,-0.30,+0.31,+0.01,0.029,0.029,0.059,1,1*3B"  # NovAtel OEM7
PASHR_POSMV = "$PASHR,085335.000,224.19,T,-01.26,+00.83,+00.00,0.101,0.113,0.267,1,0*06"
TSS1 = ":00FFCA -0003F-0325  0319"  # NovAtel OEM7 TSS1 log example
VALID = (ZDA, GGA, RMC, HDT, PASHR, PASHR_POSMV)

KNOT_M_S = 1852.0 / 3600.0


def reason(text: str | bytes) -> str:
    with pytest.raises(NmeaError) as exc:
        parse_sentence(text)
    return str(exc.value)


def em3000(
    status: int, roll: int, pitch: int, heave: int, heading: int, sync2: int = 0x90
) -> bytes:
    return struct.pack("<BBhhhH", status, sync2, roll, pitch, heave, heading)


# ---------------------------------------------------------------------- checksums
@pytest.mark.parametrize("sentence", VALID)
def test_published_checksums(sentence: str) -> None:
    body, given_hex = sentence[1:].split("*")
    xor = 0
    for c in body:
        xor ^= ord(c)
    assert nmea_checksum(body) == xor == int(given_hex, 16)
    assert format_sentence(body) == sentence


def test_nmea_error_is_an_input_error() -> None:
    assert issubclass(NmeaError, InputError)


@pytest.mark.parametrize(
    ("body", "fragment"),
    [
        ("GPZDA,é", "not ASCII"),
        ("$GPZDA", "'\\$' inside"),
        ("GPZDA*12", "'\\*' inside"),
        ("GPZDA\r", "control character 0x0D"),
    ],
)
def test_checksum_rejects_bad_bodies(body: str, fragment: str) -> None:
    with pytest.raises(NmeaError, match=fragment):
        format_sentence(body)


def test_checksum_rejects_non_str() -> None:
    with pytest.raises(NmeaError, match="must be str"):
        nmea_checksum(b"GPZDA")  # type: ignore[arg-type]


# ---------------------------------------------------------------------- published sentences
def test_zda_fields() -> None:
    rec = parse_sentence(ZDA)
    assert rec == ZdaRecord(
        talker="GP",
        utc_time_of_day_s=20 * 3600 + 15 * 60 + 30.0,
        day=4,
        month=7,
        year=2002,
        zone_hours=0,
        zone_minutes=0,
    )
    expected = dt.datetime(2002, 7, 4, 20, 15, 30, tzinfo=dt.UTC).timestamp()
    assert rec.utc_posix_s == expected


def test_gga_fields() -> None:
    rec = parse_sentence(GGA)
    assert isinstance(rec, GgaRecord)
    assert rec.talker == "GP"
    assert rec.utc_time_of_day_s == 12 * 3600 + 35 * 60 + 19
    assert rec.lat_deg == pytest.approx(48 + 7.038 / 60, abs=1e-12)
    assert rec.lon_deg == pytest.approx(11 + 31.0 / 60, abs=1e-12)
    assert rec.fix_quality == 1
    assert rec.n_satellites == 8
    assert rec.hdop == 0.9
    assert rec.altitude_msl_m == 545.4
    assert rec.geoid_separation_m == 46.9
    assert rec.age_of_corrections_s is None
    assert rec.station_id is None


def test_rmc_fields() -> None:
    rec = parse_sentence(RMC)
    assert isinstance(rec, RmcRecord)
    assert rec.status_valid
    assert rec.utc_time_of_day_s == 12 * 3600 + 35 * 60 + 19
    assert rec.lat_deg == pytest.approx(48.1173, abs=1e-12)
    assert rec.lon_deg == pytest.approx(11.516666666666667, abs=1e-12)
    assert rec.speed_m_s == pytest.approx(22.4 * KNOT_M_S, rel=1e-15)
    assert rec.course_deg == 84.4
    assert (rec.day, rec.month, rec.year) == (23, 3, 1994)
    assert rec.magnetic_variation_deg == -3.1  # W is negative
    expected = dt.datetime(1994, 3, 23, 12, 35, 19, tzinfo=dt.UTC).timestamp()
    assert rec.utc_posix_s == expected


def test_hdt_fields() -> None:
    assert parse_sentence(HDT) == HdtRecord(talker="GP", heading_deg=274.07)


def test_pashr_fields() -> None:
    rec = parse_sentence(PASHR)
    assert rec == PashrRecord(
        utc_time_of_day_s=16 * 3600 + 30 * 60 + 29.0,
        heading_deg=158.09,
        heading_true=True,
        roll_deg=-0.30,
        pitch_deg=0.31,
        heave_m=0.01,
        roll_std_deg=0.029,
        pitch_std_deg=0.029,
        heading_std_deg=0.059,
        aiding_status=1,
        imu_status=1,
    )
    rec2 = parse_sentence(PASHR_POSMV)
    assert isinstance(rec2, PashrRecord)
    assert (rec2.roll_deg, rec2.pitch_deg, rec2.heave_m, rec2.imu_status) == (-1.26, 0.83, 0.0, 0)


@pytest.mark.parametrize(
    ("body", "heave", "tail"),
    [
        # NovAtel before firmware 7.03: no IMU status field.
        ("PASHR,163029.000,158.09,T,-0.30,+0.31,+0.01,0.029,0.029,0.059,1", 0.01, (1, None)),
        # Trimble: heave reserved (empty); Applanix LVX: trailing empty field.
        ("PASHR,163029.000,158.09,T,-0.30,+0.31,,0.029,0.029,0.059,1,3,", None, (1, 3)),
        ("PASHR,163029.000,158.09,,-0.30,+0.31,+0.01", 0.01, (None, None)),
    ],
)
def test_pashr_variants(body: str, heave: float | None, tail: tuple[int | None, ...]) -> None:
    rec = parse_sentence(format_sentence(body))
    assert isinstance(rec, PashrRecord)
    assert rec.heave_m == heave
    assert (rec.aiding_status, rec.imu_status) == tail


def test_talker_agnostic_and_bytes_input() -> None:
    for talker in ("GN", "IN", "GL", "HE"):
        rec = parse_sentence(format_sentence(f"{talker}ZDA,201530.00,04,07,2002,,"))
        assert isinstance(rec, ZdaRecord)
        assert rec.talker == talker
        assert (rec.zone_hours, rec.zone_minutes) == (None, None)
    assert parse_sentence(ZDA.encode() + b"\r\n") == parse_sentence(ZDA)
    assert parse_sentence(bytearray(ZDA.encode())) == parse_sentence(ZDA)  # type: ignore[arg-type]
    assert parse_sentence("  " + ZDA + "\r\n") == parse_sentence(ZDA)


def test_lowercase_checksum_accepted() -> None:
    assert parse_sentence(RMC[:-2] + "6a") == parse_sentence(RMC)


def test_southern_and_western_hemispheres() -> None:
    gga = parse_sentence(
        format_sentence("GNGGA,000000.50,3351.600,S,15112.300,W,4,20,0.6,-12.0,M,-20.5,M,1.5,0042")
    )
    assert isinstance(gga, GgaRecord)
    assert gga.lat_deg == pytest.approx(-(33 + 51.6 / 60), abs=1e-12)
    assert gga.lon_deg == pytest.approx(-(151 + 12.3 / 60), abs=1e-12)
    assert gga.utc_time_of_day_s == 0.5
    assert (gga.fix_quality, gga.altitude_msl_m, gga.geoid_separation_m) == (4, -12.0, -20.5)
    assert (gga.age_of_corrections_s, gga.station_id) == (1.5, "0042")
    rmc = parse_sentence(
        format_sentence("GPRMC,235959.99,V,0000.000,S,18000.000,W,0.0,,010100,001.0,E,N")
    )
    assert isinstance(rmc, RmcRecord)
    assert not rmc.status_valid
    assert rmc.lat_deg == 0.0
    assert rmc.lon_deg == -180.0
    assert rmc.course_deg is None
    assert rmc.magnetic_variation_deg == 1.0  # E is positive
    assert (rmc.day, rmc.month, rmc.year) == (1, 1, 2000)


def test_empty_optional_fields() -> None:
    gga = parse_sentence(format_sentence("GPGGA,123519,4807.038,N,01131.000,E,0,,,,,,,,"))
    assert isinstance(gga, GgaRecord)
    assert (gga.n_satellites, gga.hdop, gga.altitude_msl_m, gga.geoid_separation_m) == (None,) * 4
    rmc = parse_sentence(format_sentence("GPRMC,123519,A,4807.038,N,01131.000,E,0.0,,230323,,"))
    assert isinstance(rmc, RmcRecord)
    assert (rmc.course_deg, rmc.magnetic_variation_deg, rmc.year) == (None, None, 2023)


def test_leap_second_time_of_day() -> None:
    rec = parse_sentence(format_sentence("GPZDA,235960.50,31,12,2016,,"))
    assert isinstance(rec, ZdaRecord)
    assert rec.utc_time_of_day_s == 86400.5
    # POSIX has no leap second: 23:59:60.5 maps onto 00:00:00.5 of the next day.
    assert rec.utc_posix_s == dt.datetime(2017, 1, 1, tzinfo=dt.UTC).timestamp() + 0.5


# ---------------------------------------------------------------------- rejections
def test_bad_checksum_reason() -> None:
    assert reason(GGA[:-2] + "4A") == "bad checksum (got 4A, computed 47)"
    assert reason(ZDA[:-2] + "6b") == "bad checksum (got 6B, computed 60)"


def test_missing_checksum_reason() -> None:
    assert reason(ZDA[: ZDA.index("*")]) == "truncated or no checksum: '*hh' missing at the end"


@pytest.mark.parametrize("sentence", VALID)
def test_truncation_at_every_position(sentence: str) -> None:
    for k in range(len(sentence)):
        text = reason(sentence[:k])
        assert ("truncated" in text) if k else (text == "empty sentence"), (k, text)


def with_field(sentence: str, index: int, value: str) -> str:
    """``sentence`` with data field ``index`` (0 = first after the address) set to ``value``."""
    fields = sentence[1 : sentence.index("*")].split(",")
    fields[index + 1] = value
    return format_sentence(",".join(fields))


@pytest.mark.parametrize(
    ("sentence", "index", "value", "expected"),
    [
        (ZDA, 1, "", "empty field 'day'"),
        (ZDA, 0, "", "empty field 'time'"),
        (ZDA, 3, "02", "field 'year' is not a four-digit year: '02'"),
        (ZDA, 1, "32", "field 'day' out of range for 2002-07: 32"),
        (ZDA, 2, "13", "field 'month' out of range 1..12: 13"),
        (ZDA, 4, "14", "field 'zone hours' out of range -13..13: 14"),
        (ZDA, 5, "60", "field 'zone minutes' out of range -59..59: 60"),
        (ZDA, 0, "246000.00", "field 'time' is not a valid UTC time: '246000.00'"),
        (ZDA, 0, "201560.00", "field 'time' is not a valid UTC time: '201560.00'"),
        (ZDA, 0, "2015", "field 'time' is not hhmmss[.ss]: '2015'"),
        (ZDA, 0, "nan", "field 'time' is not hhmmss[.ss]: 'nan'"),
        (ZDA, 1, "0x4", "field 'day' is not an integer (up to 9 digits): '0x4'"),
        (ZDA, 1, "+4", "field 'day' is not an integer"),
        (ZDA, 1, "9" * 30, "field 'day' is not an integer (up to 9 digits)"),
        (ZDA, 2, "9" * 5000, "field 'month' is not an integer (up to 9 digits)"),
        (ZDA, 1, "999999999", "field 'day' out of range for 2002-07: 999999999"),
        (ZDA, 4, "-999999999", "field 'zone hours' out of range -13..13: -999999999"),
        (HDT, 0, "1" * 400, "field 'heading' out of range 0..360: inf"),
        (GGA, 1, "", "empty field 'latitude'"),
        (GGA, 1, "48x7.038", "field 'latitude' is not ddmm.mm: '48x7.038'"),
        (GGA, 1, "4870.038", "field 'latitude' has minutes >= 60: '4870.038'"),
        (GGA, 1, "9107.038", "field 'latitude' exceeds 90 degrees: '9107.038'"),
        (GGA, 2, "Q", "field 'latitude hemisphere' must be N or S, got 'Q'"),
        (GGA, 3, "1131.000", "field 'longitude' is not dddmm.mm: '1131.000'"),
        (GGA, 3, "18031.000", "field 'longitude' exceeds 180 degrees: '18031.000'"),
        (GGA, 4, "", "empty field 'longitude hemisphere'"),
        (GGA, 4, "N", "field 'longitude hemisphere' must be E or W, got 'N'"),
        (GGA, 5, "abc", "field 'fix quality' is not an integer (up to 9 digits): 'abc'"),
        (GGA, 5, "", "empty field 'fix quality'"),
        (GGA, 5, "10", "field 'fix quality' out of range 0..9: 10"),
        (GGA, 6, "-1", "field 'satellites' is not an integer (up to 9 digits): '-1'"),
        (GGA, 7, "inf", "field 'hdop' is not a decimal number: 'inf'"),
        (GGA, 8, "1e3", "field 'altitude' is not a decimal number: '1e3'"),
        (GGA, 9, "F", "field 'altitude unit' must be 'M' (metres), got 'F'"),
        (GGA, 9, "", "field 'altitude unit' must be 'M' (metres), got ''"),
        (RMC, 1, "X", "field 'status' must be A or V, got 'X'"),
        (RMC, 6, "", "empty field 'speed'"),
        (RMC, 6, "-22.4", "field 'speed' out of range 0..inf: -11.52"),
        (RMC, 7, "384.4", "field 'course' out of range 0..360: 384.4"),
        (RMC, 8, "2303", "field 'date' is not ddmmyy: '2303'"),
        (RMC, 8, "310294", "field 'day' out of range for 1994-02: 31"),
        (RMC, 8, "290203", "field 'day' out of range for 2003-02: 29"),
        (RMC, 10, "", "empty field 'magnetic variation direction'"),
        (RMC, 10, "X", "field 'magnetic variation direction' must be E or W, got 'X'"),
        (HDT, 1, "M", "field 'true' must be T, got 'M'"),
        (HDT, 0, "", "empty field 'heading'"),
        (HDT, 0, "abc", "field 'heading' is not a decimal number: 'abc'"),
        (HDT, 0, "1_0", "field 'heading' is not a decimal number: '1_0'"),
        (HDT, 0, "360.01", "field 'heading' out of range 0..360: 360.01"),
        (PASHR, 2, "X", "field 'true heading flag' must be T or empty, got 'X'"),
        (PASHR, 3, "-190.0", "field 'roll' out of range -180..180: -190.0"),
        (PASHR, 6, "-1", "field 'roll accuracy' out of range 0..inf: -1.0"),
        (PASHR, 9, "x", "field 'aiding status' is not an integer (up to 9 digits): 'x'"),
    ],
)
def test_field_rejections(sentence: str, index: int, value: str, expected: str) -> None:
    text = reason(with_field(sentence, index, value))
    assert text.startswith(expected), text


@pytest.mark.parametrize(
    ("body", "expected"),
    [
        ("GPGSV,3,1,11", "unsupported sentence type 'GSV'"),
        ("PGRMZ,246,f,3", "unsupported sentence type 'PGRMZ'"),
        ("PASHR,ATT,1", "unsupported sentence type 'PASHR,ATT'"),
        ("GPZDAX,1", "malformed address field 'GPZDAX'"),
        ("gpzda,1", "malformed address field 'gpzda'"),
        ("", "malformed address field ''"),
        ("GPZDA,201530.00,04,07", "truncated: ZDA needs 6 data fields, got 3"),
        ("GPZDA,201530.00,04,07,2002,00,00,1", "ZDA has 7 data fields, expected at most 6"),
        ("GPGGA,123519,4807.038,N,01131.000,E,1", "truncated: GGA needs 14 data fields, got 6"),
        ("GPRMC,123519,A,,,,,,,,,,,,", "RMC has 14 data fields, expected at most 13"),
        ("GPRMC,123519,A,4807.038,N,01131.000,E,0,,230394,,,AB", "field 'mode' must be one letter"),
        ("GPHDT,274.07", "truncated: HDT needs 2 data fields, got 1"),
        ("PASHR,163029.000,158.09,T,-0.30", "truncated: PASHR needs 6 data fields, got 4"),
    ],
)
def test_sentence_shape_rejections(body: str, expected: str) -> None:
    text = reason(format_sentence(body))
    assert text.startswith(expected), text


@pytest.mark.parametrize(
    ("sentence", "expected"),
    [
        ("", "empty sentence"),
        ("   \r\n", "empty sentence"),
        ("GPZDA,201530.00,04,07,2002,00,00*60", "does not start with '$'"),
        ("!AIVDM,1*00", "does not start with '$'"),
        ("$GPZDA,201530.00$GPHDT,274.07,T*03", "'$' inside the sentence at position 16"),
        ("$GPZDA,2015\t30.00*00", "control character 0x09"),
        ("$GPHDT,274.07,T*0", "truncated checksum '*0'"),
        ("$GPHDT,274.07,T*", "truncated checksum '*'"),
        ("$GPHDT,274.07,T*0G", "malformed checksum '*0G'"),
        ("$GPHDT,274.07,T*033", "malformed checksum '*033'"),
        ("$GPHDT,274.07,T*03*03", "malformed checksum '*03*03'"),
        ("$GPHDT,274.07,T*03 garbage", "malformed checksum"),
        ("$GPHDT,27é.07,T*03", "not ASCII: 'é' at position 9"),
        (b"$GPHDT,27\xe9.07,T*03", "not ASCII: byte 0xE9 at position 9"),
        (b"\xff\xfe", "not ASCII: byte 0xFF at position 0"),
    ],
)
def test_sentence_level_rejections(sentence: str | bytes, expected: str) -> None:
    assert reason(sentence).startswith(expected)


def test_non_text_input_is_an_nmea_error() -> None:
    for bad in (None, 42, ["$GPHDT,274.07,T*03"]):
        with pytest.raises(NmeaError, match="expected str or bytes"):
            parse_sentence(bad)  # type: ignore[arg-type]
        with pytest.raises(NmeaError):
            parse_tss1(bad)  # type: ignore[arg-type]
        with pytest.raises(NmeaError, match="must be bytes"):
            parse_em3000(bad)  # type: ignore[arg-type]
    with pytest.raises(NmeaError, match="must be bytes"):
        parse_em3000("0123456789")  # type: ignore[arg-type]


def test_records_validate_on_construction() -> None:
    with pytest.raises(NmeaError, match="'month' out of range"):
        ZdaRecord("GP", 0.0, 1, 13, 2020, None, None)
    with pytest.raises(NmeaError, match="'time' out of range"):
        ZdaRecord("GP", math.nan, 1, 1, 2020, None, None)
    with pytest.raises(NmeaError, match="'latitude' out of range"):
        GgaRecord("GP", 0.0, 91.0, 0.0, 1, None, None, None, None, None, None)
    with pytest.raises(NmeaError, match="'heading' out of range"):
        HdtRecord("HE", -1.0)
    with pytest.raises(NmeaError, match="TSS1 status"):
        Tss1Record(0.0, 0.0, 0.0, "X", 0.0, 0.0)
    with pytest.raises(NmeaError, match="sensor status"):
        Em3000Record(0x50, 0.0, 0.0, 0.0, 0.0)


# ---------------------------------------------------------------------- properties
@settings(max_examples=400, deadline=None)
@given(st.text())
def test_any_text_raises_only_nmea_error(text: str) -> None:
    for parse in (parse_sentence, parse_tss1):
        with contextlib.suppress(NmeaError):
            parse(text)


@settings(max_examples=400, deadline=None)
@given(st.binary())
def test_any_bytes_raise_only_nmea_error(data: bytes) -> None:
    for parse in (parse_sentence, parse_tss1, parse_em3000):
        with contextlib.suppress(NmeaError):
            parse(data)


_NMEA_ALPHABET = st.sampled_from(
    [*"$*,.-+0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZ ", "ZDA", "GP", "9" * 30, ",,,,"]
)


@settings(max_examples=300, deadline=None)
@given(st.lists(_NMEA_ALPHABET, max_size=60))
def test_nmea_like_text_checksummed_raises_only_nmea_error(parts: list[str]) -> None:
    """Random field soup with a correct checksum reaches the field parsers."""
    body = "".join(parts).replace("$", "").replace("*", "")
    for address in ("GPZDA,", "GNGGA,", "GPRMC,", "HEHDT,", "PASHR,"):
        with contextlib.suppress(NmeaError):
            parse_sentence(format_sentence(address + body))


@settings(max_examples=400, deadline=None)
@given(
    st.sampled_from(VALID),
    st.integers(min_value=0, max_value=200),
    st.characters(),
    st.sampled_from(["replace", "insert", "delete"]),
)
def test_mutated_sentences(sentence: str, pos: int, char: str, how: str) -> None:
    i = pos % len(sentence)
    if how == "replace":
        mutated = sentence[:i] + char + sentence[i + 1 :]
    elif how == "insert":
        mutated = sentence[:i] + char + sentence[i:]
    else:
        mutated = sentence[:i] + sentence[i + 1 :]
    assume(mutated != sentence)
    try:
        rec = parse_sentence(mutated)
    except NmeaError:
        return
    # Only harmless edits may parse: checksum hex case, or whitespace around the sentence,
    # and then the content is unchanged.
    assert mutated.strip()[:-2] == sentence[:-2]
    assert rec == parse_sentence(sentence)


@settings(max_examples=200, deadline=None)
@given(
    st.sampled_from(VALID),
    st.integers(min_value=0, max_value=200),
    st.characters(min_codepoint=0x80),
)
def test_non_ascii_anywhere_is_rejected(sentence: str, pos: int, char: str) -> None:
    i = pos % (len(sentence) + 1)
    mutated = sentence[:i] + char + sentence[i:]
    assert reason(mutated).startswith("not ASCII")
    encoded = mutated.encode("utf-8", "surrogatepass")
    assert reason(encoded).startswith("not ASCII: byte")


@settings(max_examples=300, deadline=None)
@given(
    st.sampled_from(["GP", "GN", "IN", "GL", "GA"]),
    st.datetimes(
        min_value=dt.datetime(1980, 1, 6), max_value=dt.datetime(2099, 12, 31, 23, 59, 59)
    ),
    st.integers(min_value=0, max_value=99),
    st.one_of(st.none(), st.integers(min_value=-13, max_value=13)),
    st.one_of(st.none(), st.integers(min_value=0, max_value=59)),
)
def test_zda_round_trip(
    talker: str, when: dt.datetime, centis: int, zone_h: int | None, zone_m: int | None
) -> None:
    when = when.replace(microsecond=0)
    zh = "" if zone_h is None else f"{zone_h:+03d}"
    zm = "" if zone_m is None else f"{zone_m:02d}"
    body = (
        f"{talker}ZDA,{when:%H%M%S}.{centis:02d},{when.day:02d},{when.month:02d},"
        f"{when.year:04d},{zh},{zm}"
    )
    sentence = format_sentence(body)
    assert sentence == f"${body}*{nmea_checksum(body):02X}"
    rec = parse_sentence(sentence)
    assert isinstance(rec, ZdaRecord)
    assert rec.talker == talker
    assert (rec.day, rec.month, rec.year) == (when.day, when.month, when.year)
    assert (rec.zone_hours, rec.zone_minutes) == (zone_h, zone_m)
    tod = when.hour * 3600 + when.minute * 60 + when.second + centis / 100
    assert rec.utc_time_of_day_s == pytest.approx(tod, abs=1e-9)
    posix = when.replace(tzinfo=dt.UTC).timestamp() + centis / 100
    assert rec.utc_posix_s == pytest.approx(posix, abs=1e-6)


@settings(max_examples=200, deadline=None)
@given(
    st.floats(min_value=-89.999, max_value=89.999),
    st.floats(min_value=-179.999, max_value=179.999),
)
def test_gga_position_round_trip(lat: float, lon: float) -> None:
    def ddmm(value: float, width: int) -> str:
        deg = int(abs(value))
        minutes = (abs(value) - deg) * 60
        return f"{deg:0{width}d}{minutes:09.6f}"

    body = (
        f"GPGGA,101010.00,{ddmm(lat, 2)},{'N' if lat >= 0 else 'S'},"
        f"{ddmm(lon, 3)},{'E' if lon >= 0 else 'W'},1,10,1.0,10.0,M,1.0,M,,"
    )
    rec = parse_sentence(format_sentence(body))
    assert isinstance(rec, GgaRecord)
    assert rec.lat_deg == pytest.approx(lat, abs=1e-7)
    assert rec.lon_deg == pytest.approx(lon, abs=1e-7)


# ---------------------------------------------------------------------- TSS1
def test_tss1_published_example() -> None:
    rec = parse_tss1(TSS1 + "\r\n")
    assert rec == Tss1Record(
        horizontal_acc_m_s2=0.0,
        vertical_acc_m_s2=-54 * 0.000625,  # 0xFFCA two's complement, 0.0625 cm/s^2
        heave_m=-0.03,
        status="F",
        roll_deg=-3.25,
        pitch_deg=3.19,
    )
    assert rec.settled
    assert parse_tss1(TSS1.encode()) == rec


def test_tss1_positive_values_and_units() -> None:
    rec = parse_tss1(":1A0100  1234g+0500 -8999")
    assert rec.horizontal_acc_m_s2 == pytest.approx(26 * 0.0383)
    assert rec.vertical_acc_m_s2 == pytest.approx(256 * 0.000625)
    assert rec.heave_m == 12.34
    assert (rec.status, rec.settled) == ("g", False)
    assert rec.roll_deg == 5.0
    assert rec.pitch_deg == -89.99


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        (":00FFCA -0003F-0325  031", "truncated: TSS1 record has 24 characters, expected 25"),
        (TSS1 + "0", "TSS1 record has 26 characters, expected 25"),
        ("#00FFCA -0003F-0325  0319", "TSS1 record must start with ':'"),
        (":0GFFCA -0003F-0325  0319", "TSS1 accelerations must be hex digits"),
        (":00FFCA_-0003F-0325  0319", "TSS1 record must have spaces"),
        (":00FFCA *0003F-0325  0319", "TSS1 heave sign must be a space or '-'"),
        (":00FFCA -00a3F-0325  0319", "TSS1 heave must be four digits"),
        (":00FFCA -0003X-0325  0319", "TSS1 status must be one of"),
        (":00FFCA -0003F-0325  03 9", "TSS1 pitch must be four digits"),
        (":00FFCA -0003F-0325 é0319", "not ASCII"),
    ],
)
def test_tss1_rejections(text: str, expected: str) -> None:
    with pytest.raises(NmeaError) as exc:
        parse_tss1(text)
    assert str(exc.value).startswith(expected)


def test_tss1_truncation_at_every_position() -> None:
    for k in range(len(TSS1)):
        with pytest.raises(NmeaError, match="truncated"):
            parse_tss1(TSS1[:k])


@settings(max_examples=400, deadline=None)
@given(st.text(alphabet=":0123456789ABCDEFabcdef -+UuGgHhFfX", min_size=25, max_size=25))
def test_tss1_like_text_raises_only_nmea_error(text: str) -> None:
    try:
        rec = parse_tss1(text)
    except NmeaError:
        return
    assert text[0] == ":"
    assert abs(rec.roll_deg) <= 99.99


# ---------------------------------------------------------------------- EM3000
def test_em3000_values_units_and_signs() -> None:
    rec = parse_em3000(em3000(0x90, -325, 319, -3, 35999))
    assert rec == Em3000Record(
        sensor_status=0x90, roll_deg=-3.25, pitch_deg=3.19, heave_m=-0.03, heading_deg=359.99
    )
    assert rec.valid
    # Byte order: little-endian, LSB first.
    raw = bytes([0x00, 0x90, 0x01, 0x02, 0xFF, 0xFF, 0x10, 0x00, 0x28, 0x23])
    rec = parse_em3000(raw)
    assert (rec.roll_deg, rec.pitch_deg, rec.heave_m, rec.heading_deg) == (5.13, -0.01, 0.16, 90.0)
    assert rec.valid  # 0x00: plain sync byte, no status
    assert parse_em3000(bytearray(raw)) == rec  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("status", "valid"),
    [
        (0x00, True),
        (0x90, True),
        (0x95, True),
        (0x99, True),
        (0x9A, False),
        (0xA0, False),
        (0xAF, False),
    ],
)
def test_em3000_status(status: int, valid: bool) -> None:
    assert parse_em3000(em3000(status, 0, 0, 0, 0)).valid is valid


@pytest.mark.parametrize(
    ("data", "expected"),
    [
        (em3000(0x90, 0, 0, 0, 0)[:9], "truncated: EM3000 datagram has 9 bytes, expected 10"),
        (em3000(0x90, 0, 0, 0, 0) + b"\x00", "EM3000 datagram has 11 bytes"),
        (em3000(0x50, 0, 0, 0, 0), "EM3000 sync byte 1 / sensor status must be 0x00 or 0x90..0xAF"),
        (em3000(0xB0, 0, 0, 0, 0), "EM3000 sync byte 1 / sensor status"),
        (em3000(0x90, 0, 0, 0, 0, sync2=0x91), "EM3000 sync byte 2 must be 0x90, got 0x91"),
        (em3000(0x90, 18000, 0, 0, 0), "field 'roll' out of range"),
        (em3000(0x90, 0, -18000, 0, 0), "field 'pitch' out of range"),
        (em3000(0x90, 0, 0, 1000, 0), "field 'heave' out of range"),
        (em3000(0x90, 0, 0, 0, 36000), "field 'heading' out of range"),
    ],
)
def test_em3000_rejections(data: bytes, expected: str) -> None:
    with pytest.raises(NmeaError) as exc:
        parse_em3000(data)
    assert str(exc.value).startswith(expected)


@settings(max_examples=400, deadline=None)
@given(st.binary(min_size=10, max_size=10))
def test_em3000_any_ten_bytes(data: bytes) -> None:
    try:
        rec = parse_em3000(data)
    except NmeaError:
        return
    assert data[1] == 0x90
    assert 0.0 <= rec.heading_deg <= 359.99


# ---------------------------------------------------------------------- log file
def _write(path: Path, data: bytes) -> Path:
    path.write_bytes(data)
    return path


def test_read_nmea_log_counts_and_reasons(tmp_path: Path) -> None:
    zda2 = format_sentence("GPZDA,201531.00,04,07,2002,00,00")
    GSV = format_sentence("GPGSV,1,1,00")
    lines = [
        b"t_local_s,sentence",
        f"100.015,{ZDA}".encode(),  # 2 good, unquoted
        f'100.020,"{GGA}"'.encode(),  # 3 good, CSV-quoted
        f"100.030,{GGA[:-2]}4A".encode(),  # 4 bad checksum
        b"100.040,$GPZDA,201530.00,04,07,20",  # 5 truncated
        b"100.050,$GPHDT,27\xe9.07,T*03",  # 6 not UTF-8
        "100.060,$GPHDT,27é.07,T*03".encode(),  # 7 UTF-8 but not ASCII
        f"100.070,{GSV}".encode(),  # 8 unsupported
        f"abc,{HDT}".encode(),  # 9 time not a number
        f"nan,{HDT}".encode(),  # 10 time not finite
        b"",  # 11 blank: skipped
        b"no comma here",  # 12
        f"101.015,{zda2}\r".encode(),  # 13 good, CRLF
        f"101.020, {PASHR} ".encode(),  # 14 good, padded
    ]
    path = _write(tmp_path / "nmea.csv", b"\n".join(lines) + b"\n")
    log = read_nmea_log(path)
    assert isinstance(log, NmeaLog)
    assert log.source == str(path)
    np.testing.assert_array_equal(log.t_local_s, [100.015, 100.020, 101.015, 101.020])
    assert [type(r) for r in log.records] == [ZdaRecord, GgaRecord, ZdaRecord, PashrRecord]
    assert log.raw_sentences == (ZDA, GGA, zda2, PASHR)
    assert log.lines == (2, 3, 13, 14)
    assert log.rejected == (
        RejectedLine(4, 100.03, f"{GGA[:-2]}4A", "bad checksum (got 4A, computed 47)"),
        RejectedLine(
            5,
            100.04,
            "$GPZDA,201530.00,04,07,20",
            "truncated or no checksum: '*hh' missing at the end",
        ),
        RejectedLine(6, 100.05, "$GPHDT,27\\xe9.07,T*03", "not ASCII: byte 0xE9 at position 9"),
        RejectedLine(7, 100.06, "$GPHDT,27é.07,T*03", "not ASCII: byte 0xC3 at position 9"),
        RejectedLine(8, 100.07, GSV, "unsupported sentence type 'GSV'"),
        RejectedLine(9, None, HDT, "t_local_s 'abc' is not a finite number"),
        RejectedLine(10, None, HDT, "t_local_s 'nan' is not a finite number"),
        RejectedLine(12, None, "no comma here", "no comma: expected t_local_s,sentence"),
    )
    t_zda, zdas = log.zda()
    np.testing.assert_array_equal(t_zda, [100.015, 101.015])
    assert zdas == (parse_sentence(ZDA), parse_sentence(zda2))
    assert zdas[1].utc_posix_s - zdas[0].utc_posix_s == 1.0
    assert not log.t_local_s.flags.writeable


def test_read_nmea_log_accepts_bom_and_quoted_header(tmp_path: Path) -> None:
    path = _write(tmp_path / "n.csv", b'\xef\xbb\xbf"t_local_s","sentence"\r\n1.0,' + HDT.encode())
    log = read_nmea_log(path)
    assert log.records == (HdtRecord("GP", 274.07),)


def test_read_nmea_log_reads_cr_line_ends(tmp_path: Path) -> None:
    """A log with CR line ends (no LF) is read line by line, not refused as one header
    line holding the whole file."""
    path = _write(tmp_path / "n.csv", f"t_local_s,sentence\r1.0,{HDT}\r\r2.0,{HDT}\r".encode())
    log = read_nmea_log(path)
    assert log.records == (HdtRecord("GP", 274.07),) * 2
    assert log.lines == (2, 4)


@pytest.mark.parametrize(
    ("data", "fragment"),
    [
        (b"", "line 1: empty file; expected the header t_local_s,sentence"),
        (b"time,sentence\n1.0,$GPHDT,274.07,T*03\n", "line 1: header is 'time,sentence'"),
        (b"1.0,$GPHDT,274.07,T*03\n", "line 1: header is '1.0,$GPHDT,274.07,T*03'"),
        (b"t_local_s,sentence\n", "no data lines"),
        # A tab-separated log showed its raw header 't_local_s\tsentence'.
        (
            b"t_local_s\tsentence\n1.0\t$GPHDT,274.07,T*03\n",
            "line 1: the file looks tab-separated (t_local_s and sentence split by a tab)",
        ),
        (
            b"t_local_s,sentence\n1.0,$GPHDT,274.07,T*04\n2.0,x\n",
            "none of its 2 data lines is a usable sentence (line 2: bad checksum (got 04, ",
        ),
    ],
)
def test_read_nmea_log_file_errors(tmp_path: Path, data: bytes, fragment: str) -> None:
    path = _write(tmp_path / "nmea.csv", data)
    with pytest.raises(NmeaError) as exc:
        read_nmea_log(path)
    assert str(exc.value).startswith(f"{path}: ")
    assert fragment in str(exc.value)


def test_a_line_without_end_is_rejected_without_being_held(tmp_path: Path) -> None:
    # A 20 MB line (a binary dump, a lost line end) was read whole with the file, and
    # its text kept in the rejected line.
    big = b"100.020,$GPZDA" + b"A" * 20_000_000
    data = b"t_local_s,sentence\n" + f"100.015,{ZDA}\n".encode() + big + b"\n"
    path = _write(tmp_path / "nmea.csv", data + f"101.020,{HDT}".encode())
    tracemalloc.start()
    try:
        log = read_nmea_log(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 2_000_000, peak
    assert log.lines == (2, 4)
    (rejected,) = log.rejected
    assert rejected.line == 3
    assert rejected.reason == f"line longer than {MAX_NMEA_LINE_BYTES} bytes: not an NMEA sentence"
    assert rejected.sentence == "100.020,$GPZDA" + "A" * 66 + "..."


def test_a_log_without_line_ends_is_refused_in_a_short_message(tmp_path: Path) -> None:
    lines = [b"t_local_s,sentence", *(f"{100 + k}.015,{ZDA}".encode() for k in range(400))]
    path = _write(tmp_path / "nmea.csv", b" ".join(lines))
    with pytest.raises(NmeaError) as exc:
        read_nmea_log(path)
    message = str(exc.value)
    assert message.startswith(f"{path}: line 1: no line end in its first {MAX_NMEA_LINE_BYTES}")
    assert len(message) < 400, len(message)  # it echoed the whole file (35 kB)


@pytest.mark.parametrize("end", [b"\n", b"\r\n", b"\r"], ids=["LF", "CRLF", "CR"])
def test_a_long_line_is_cut_whatever_the_line_ends(tmp_path: Path, end: bytes) -> None:
    big = b"100.020,$GPZDA" + b"A" * 200_000  # spans several read blocks
    lines = [b"t_local_s,sentence", f"100.015,{ZDA}".encode(), big, f"101.020,{HDT}".encode()]
    log = read_nmea_log(_write(tmp_path / "nmea.csv", end.join(lines) + end))
    assert log.lines == (2, 4)
    assert [r.line for r in log.rejected] == [3]
    assert log.rejected[0].sentence == "100.020,$GPZDA" + "A" * 66 + "..."


def test_a_long_wrong_header_is_shown_cut(tmp_path: Path) -> None:
    path = _write(tmp_path / "nmea.csv", b"x" * 3000 + b"\n1.0," + HDT.encode())
    with pytest.raises(NmeaError) as exc:
        read_nmea_log(path)
    assert f"line 1: header is '{'x' * 80}...'; expected" in str(exc.value)


def test_read_nmea_log_missing_or_unreadable(tmp_path: Path) -> None:
    with pytest.raises(NmeaError, match="file not found"):
        read_nmea_log(tmp_path / "none.csv")
    with pytest.raises(NmeaError, match="cannot read"):
        read_nmea_log(tmp_path)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.binary(max_size=60), max_size=8))
def test_read_nmea_log_any_bytes(
    tmp_path_factory: pytest.TempPathFactory, rows: list[bytes]
) -> None:
    path = tmp_path_factory.mktemp("nmea") / "nmea.csv"
    _write(path, b"t_local_s,sentence\n" + b"\n".join([b"1.5," + HDT.encode(), *rows]))
    log = read_nmea_log(path)
    assert log.records[0] == HdtRecord("GP", 274.07)
    n_lines = len([r for r in b"\n".join(rows).split(b"\n") if r.rstrip(b"\r").strip()])
    assert len(log.records) + len(log.rejected) == 1 + n_lines


def test_nmea_log_validates_lengths() -> None:
    with pytest.raises(NmeaError, match="shape"):
        NmeaLog("x", np.zeros(2), (HdtRecord("GP", 1.0),), (), (HDT,))
