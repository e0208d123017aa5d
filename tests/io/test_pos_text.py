"""POSPac and Inertial Explorer ASCII trajectory exports."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from kinsync.errors import InputError
from kinsync.frames import quaternion_to_matrix
from kinsync.io.pos_text import read_pos_text, sniff_pos_text
from kinsync.io.trajectory import (
    read_trajectory_file,
    trajectory_file_format,
    trajectory_takes_gps_week,
)

WEEK = 2100
SOW0 = 302_400.0

POSPAC_HEADER = """\
**************************************************************************************
 POS Export Utility
 Copyright (C) 1997-2018 by Applanix Corporation      [May 17 2018]
 All rights reserved.
**************************************************************************************

 Parameter setup:
 POSPROC SBET file: C:\\Mission 1\\Proc\\sbet_Mission 1.out
 Mapping frame epoch: 2020.268000
 Mapping frame datum: WGS84  ; Mapping frame projection : TM;
 Lever arm values: lx =        0.0000 m, ly =        0.0000 m, lz =        0.0000 m.
 TIME, DISTANCE, EASTING, NORTHING, ELLIPSOID HEIGHT, LATITUDE, LONGITUDE, ELLIPSOID HEIGHT, \
ROLL, PITCH, HEADING, EAST VELOCITY, NORTH VELOCITY, UP VELOCITY, EAST SD, NORTH SD

  (time in Sec, distance in Meters, position in Meters, lat, long in Degrees, \
orientation angles and SD in Degrees, velocity in Meter/Sec, position SD in Meters)
"""

IE_HEADER = """\
Project:     drive_0412
Program:     Inertial Explorer Version 8.90.6611
Profile:     kinsync test
Source:      GNSS/INS Epochs(Combined,Smoothed)

Datum:       WGS84, (processing datum)
Remote:      Antenna height 0.000 m, to L1PC [Generic(NONE)]
UTC Offset:  18 s

"""


def _states(n: int = 50) -> dict[str, np.ndarray]:
    s = np.arange(n) * 0.1
    return {
        "sow": SOW0 + s,
        "lat": 46.8 + 1e-5 * s,
        "lon": -71.2 - 2e-5 * s,
        "h": 20.0 + 0.1 * s,
        "roll": 6.0 * np.sin(s),
        "pitch": -5.0 + 0.3 * s,
        "heading": (350.0 + 4.0 * s) % 360.0,
        "vn": 1.0 + 0.0 * s,
        "ve": -1.5 + 0.0 * s,
        "vu": 0.01 * s,
    }


def _write_pospac(path: Path, c: dict[str, np.ndarray]) -> None:
    rows = [
        f"{c['sow'][i]:.4f} {i * 2.0:.3f} 300000.000 5000000.000 {c['h'][i]:.4f} "
        f"{c['lat'][i]:.10f} {c['lon'][i]:.10f} {c['h'][i]:.4f} {c['roll'][i]:.8f} "
        f"{c['pitch'][i]:.8f} {c['heading'][i]:.8f} {c['ve'][i]:.4f} {c['vn'][i]:.4f} "
        f"{c['vu'][i]:.4f} 0.010 0.012"
        for i in range(len(c["sow"]))
    ]
    path.write_text(POSPAC_HEADER + "\n".join(rows) + "\n")


def _dms(value: float) -> str:
    sign = "-" if value < 0 else ""
    a = abs(value)
    d = int(a)
    m = int((a - d) * 60.0)
    sec = ((a - d) * 60.0 - m) * 60.0
    return f"{sign}{d} {m:02d} {sec:011.8f}"


def _write_ie(
    path: Path,
    c: dict[str, np.ndarray],
    *,
    dms: bool,
    week: bool,
    footer: str = "",
    date: bool = True,
) -> None:
    names = (["Date"] if date else []) + ["GPSTime"] + (["Week"] if week else [])
    names += ["Latitude", "Longitude", "H-Ell", "Heading", "HdngSD", "Pitch", "Roll"]
    names += ["VNorth", "VEast", "VUp", "Q"]
    units = (["(MDY)"] if date else []) + ["(sec)"] + (["(week)"] if week else [])
    angle = "(+/-D M S)" if dms else "(deg)"
    units += [angle, angle, "(m)", "(deg)", "(deg)", "(deg)", "(deg)", "(m/s)", "(m/s)"]
    units += ["(m/s)", ""]
    rows = []
    for i in range(len(c["sow"])):
        lat = _dms(c["lat"][i]) if dms else f"{c['lat'][i]:.10f}"
        lon = _dms(c["lon"][i]) if dms else f"{c['lon'][i]:.10f}"
        row = (["04/12/2020"] if date else []) + [f"{c['sow'][i]:.3f}"]
        row += [str(WEEK)] if week else []
        row += [lat, lon, f"{c['h'][i]:.4f}", f"{c['heading'][i]:.8f}", "0.0123"]
        row += [f"{c['pitch'][i]:.8f}", f"{c['roll'][i]:.8f}", f"{c['vn'][i]:.4f}"]
        row += [f"{c['ve'][i]:.4f}", f"{c['vu'][i]:.4f}", "1"]
        rows.append("  ".join(row))
    text = IE_HEADER + "  ".join(names) + "\n" + "  ".join(units) + "\n" + "\n".join(rows) + "\n"
    path.write_text(text + footer)


def test_pospac_export_reads_as_the_sbet_angles(tmp_path: Path) -> None:
    c = _states()
    path = tmp_path / "export.txt"
    _write_pospac(path, c)
    assert sniff_pos_text(path).producer == "pospac"
    traj, gps_time = read_pos_text(path)
    assert not gps_time
    np.testing.assert_array_equal(traj.t_s, c["sow"])
    assert traj.lat_lon_h is not None
    np.testing.assert_allclose(traj.lat_lon_h[:, 0], c["lat"], rtol=0, atol=1e-10)
    np.testing.assert_allclose(traj.lat_lon_h[:, 1], c["lon"], rtol=0, atol=1e-10)
    rpy = np.degrees(traj.euler_rpy_rad())
    np.testing.assert_allclose(rpy[:, 0], c["roll"], rtol=0, atol=1e-7)
    np.testing.assert_allclose(rpy[:, 1], c["pitch"], rtol=0, atol=1e-7)
    heading_error = np.mod(rpy[:, 2] - c["heading"] + 180.0, 360.0) - 180.0  # 0 and 360 agree
    np.testing.assert_allclose(heading_error, 0.0, rtol=0, atol=1e-7)
    assert traj.vel_ned_m_s is not None
    np.testing.assert_allclose(traj.vel_ned_m_s, np.column_stack([c["vn"], c["ve"], -c["vu"]]))
    traj2, scale = read_trajectory_file(path, gps_week=WEEK)
    assert scale == "gps"
    np.testing.assert_array_equal(traj2.t_s, WEEK * 604800.0 + c["sow"])
    assert trajectory_file_format(path) == "pospac"


@pytest.mark.parametrize(
    ("dms", "week", "footer", "lat0"),
    [(True, True, "\nEnd of file\n", 46.8), (True, False, "", -0.2), (False, False, "", 46.8)],
)
def test_inertial_explorer_export_uses_novatel_angles(
    tmp_path: Path, dms: bool, week: bool, footer: str, lat0: float
) -> None:
    # Without a footer or a date every line after the header is numbers (numpy reads
    # them at once); those send the file through the line-by-line reader: both checked.
    c = _states()
    c["lat"] = c["lat"] - 46.8 + lat0  # -0.2: a negative latitude with 0 degrees
    path = tmp_path / "ie.txt"
    _write_ie(path, c, dms=dms, week=week, footer=footer, date=bool(footer))
    assert fast_path_reads(path) == (not footer)
    assert sniff_pos_text(path).producer == "inertial-explorer"
    traj, scale = read_trajectory_file(path)
    assert scale == ("gps" if week else "week")
    np.testing.assert_array_equal(traj.t_s, c["sow"] + (WEEK * 604800.0 if week else 0.0))
    assert traj.lat_lon_h is not None
    np.testing.assert_allclose(traj.lat_lon_h[:, 0], c["lat"], rtol=0, atol=1e-9)
    np.testing.assert_allclose(traj.lat_lon_h[:, 1], c["lon"], rtol=0, atol=1e-9)
    np.testing.assert_allclose(traj.lat_lon_h[:, 2], c["h"], rtol=0, atol=1e-4)
    # Independent: NovAtel vehicle (x right, y fwd, z up) -> ENU, intrinsic Z-X-Y.
    vehicle_to_enu = Rotation.from_euler(
        "ZXY", np.column_stack([-c["heading"], c["pitch"], c["roll"]]), degrees=True
    ).as_matrix()
    swap = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
    expected = swap @ vehicle_to_enu @ swap
    np.testing.assert_allclose(quaternion_to_matrix(traj.q_body_to_ned), expected, atol=1e-9)


def test_novatel_angles_have_the_documented_signs(tmp_path: Path) -> None:
    c = _states(3)
    c["heading"][:] = 90.0
    c["pitch"][:] = 10.0
    c["roll"][:] = 0.0
    path = tmp_path / "ie.txt"
    _write_ie(path, c, dms=False, week=False)
    R = quaternion_to_matrix(read_pos_text(path)[0].q_body_to_ned)[0]
    forward = R @ [1.0, 0.0, 0.0]  # NED: east, and up (negative down) by the pitch
    np.testing.assert_allclose(forward, [0.0, np.cos(np.radians(10)), -np.sin(np.radians(10))])
    c["pitch"][:] = 0.0
    c["roll"][:] = 10.0
    _write_ie(path, c, dms=False, week=False)
    R = quaternion_to_matrix(read_pos_text(path)[0].q_body_to_ned)[0]
    right = R @ [0.0, 1.0, 0.0]  # facing east, the right side points south and down
    np.testing.assert_allclose(right, [-np.cos(np.radians(10)), 0.0, np.sin(np.radians(10))])


@pytest.mark.parametrize("tilt_deg", [5.0, 40.0, 80.0])
def test_novatel_and_din_9300_angles_agree_at_any_tilt(tmp_path: Path, tilt_deg: float) -> None:
    """The same numbers in a POSPac and an Inertial Explorer export: the same attitude.

    The module docstring once said they differ by up to roll x pitch in heading; the
    axis swap turns NovAtel's Z-X-Y sequence into DIN 9300's Z-Y-X (review G).
    """
    c = _states()
    c["roll"] = np.full(len(c["sow"]), tilt_deg)
    c["pitch"] = np.full(len(c["sow"]), -0.75 * tilt_deg)
    ie, pospac = tmp_path / "ie.txt", tmp_path / "pospac.txt"
    _write_ie(ie, c, dms=False, week=False)
    _write_pospac(pospac, c)
    a, b = read_pos_text(ie)[0], read_pos_text(pospac)[0]
    dots = np.abs(np.sum(a.q_body_to_ned * b.q_body_to_ned, axis=1))
    np.testing.assert_allclose(dots, 1.0, rtol=0, atol=1e-12)


def fast_path_reads(path: Path) -> bool:
    """Whether numpy's one-call parse reads the file (no text among the rows)."""
    from kinsync.io.pos_text import _find_layout, _parse_rows_fast  # noqa: PLC0415

    lines = path.read_text().splitlines()
    layout, first = _find_layout(path, lines)
    return _parse_rows_fast(lines, first, layout) is not None


def _ie_text(rows: str, names: str = "GPSTime Latitude Longitude H-Ell Roll Pitch Heading") -> str:
    units = "(sec) (deg) (deg) (m) (deg) (deg) (deg)"
    return IE_HEADER + names + "\n" + units + "\n" + rows


GOOD_ROWS = "100.0 46.8 -71.2 10.0 0.1 0.2 30.0\n100.1 46.8 -71.2 10.0 0.1 0.2 30.0\n"


@pytest.mark.parametrize(
    ("text", "fragments"),
    [
        ("hello\nworld\n", ["not a recognised trajectory export", "POS Export Utility"]),
        (_ie_text(GOOD_ROWS).replace("Inertial Explorer", "Something"), ["which program"]),
        (
            _ie_text("100.0 46.8 -71.2 10.0 0.1 0.2\n"),
            ["line 12", "6 fields", "header (line 10) gives 7", "1 too few", "cut short"],
        ),
        (  # review G: a field too many was asked about as a row cut short
            _ie_text("100.0 46.8 -71.2 10.0 5 0.1 0.2 30.0\n100.1 46.8 -71.2 10.0 0.1 0.2 30.0\n"),
            ["line 12", "8 fields", "header (line 10) gives 7", "1 too many", "two rows joined"],
        ),
        (
            _ie_text("100.0 46.8 -71.2 10.0 0.1 abc 30.0\n"),
            ["line 12, column 'Pitch'", "'abc' is not a number"],
        ),
        (
            _ie_text(GOOD_ROWS, "UTCTime Latitude Longitude H-Ell Roll Pitch Heading"),
            ["no GPS time", "UTC times only"],
        ),
        (
            _ie_text(GOOD_ROWS, "GPSTime Latitude Longitude H-Ell Roll Pitch Q"),
            ["lack HEADING"],
        ),
        (
            _ie_text(GOOD_ROWS + "footer\n" + GOOD_ROWS),
            ["line 15: a data row after the text at line 14"],
        ),
        (  # numpy's fast path skipped a '#' line: a row lost without a word
            _ie_text(GOOD_ROWS + "# paused\n" + GOOD_ROWS.replace("100.", "101.")),
            ["line 15: a data row after the text at line 14"],
        ),
        (_ie_text("100.0 46.8 -71.2 10.0 0.1 0.2 30.0\n"), ["at least 2 records"]),
        (_ie_text(GOOD_ROWS.replace("46.8", "96.8", 1)), ["line 12, column 'Latitude'", "96.8"]),
        (  # review G: attitude up to 1e6 deg was read (a pitch of 95 deg, a heading of 720)
            _ie_text(GOOD_ROWS.replace("0.2 30.0", "95.0 30.0", 1)),
            ["line 12, column 'Pitch'", "95", "-90 to 90"],
        ),
        (
            _ie_text(GOOD_ROWS.replace("0.2 30.0", "0.2 720.0", 1)),
            ["line 12, column 'Heading'", "720"],
        ),
        (
            _ie_text("100.0 46.8 -71.2 10.0 0.1 0.2 30.0\n100.0 46.8 -71.2 10.0 0.1 0.2 30.0\n"),
            ["line 13", "increasing"],
        ),
        (_ie_text(GOOD_ROWS).replace("(deg) (deg) (deg)\n", "(rad) (rad) (rad)\n"), ["radians"]),
        (  # review N3: a time in HMS was asked about as two rows joined
            _ie_text("12 00 00.0 46.8 -71.2 10.0 0.1 0.2 30.0\n").replace("(sec)", "(HMS)"),
            ["line 12", "2 too many", "line 11", "HMS", "does not read", "GPS seconds"],
        ),
        (  # the same with colons: one field that is not a number
            _ie_text("12:00:00.0 46.8 -71.2 10.0 0.1 0.2 30.0\n").replace("(sec)", "(HMS)"),
            ["line 12, column 'GPSTime'", "HMS", "does not read", "GPS seconds"],
        ),
        (  # a negative time of week was read as a time of the week before (as in SBET)
            _ie_text(GOOD_ROWS.replace("100.", "-100.")[:-1] + "\n"),
            ["line 12, column 'GPSTime'", "-100", "seconds of week"],
        ),
    ],
)
def test_bad_exports_name_the_file_and_line(
    tmp_path: Path, text: str, fragments: list[str]
) -> None:
    path = tmp_path / "traj.txt"
    path.write_text(text)
    with pytest.raises(InputError) as info:
        read_trajectory_file(path)
    message = str(info.value)
    assert str(path) in message
    for fragment in fragments:
        assert fragment in message


def test_a_binary_file_with_an_unknown_suffix_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "traj.bin"
    path.write_bytes(b"\x00\x01\x02" * 100)
    with pytest.raises(InputError, match=r"not a text file.*Trajectory files: \.csv"):
        read_trajectory_file(path)


@given(st.floats(min_value=-89.999, max_value=89.999, allow_nan=False))
def test_dms_fields_read_back_as_the_degrees(value: float) -> None:
    from kinsync.io.pos_text import _dms_to_deg  # noqa: PLC0415

    assert abs(_dms_to_deg(_dms(value).split()) - value) < 1e-10


def test_which_trajectory_files_take_a_gps_week(tmp_path: Path) -> None:
    c = _states()
    with_week, without, pospac = (tmp_path / n for n in ("w.txt", "n.txt", "p.txt"))
    _write_ie(with_week, c, dms=False, week=True)
    _write_ie(without, c, dms=False, week=False)
    _write_pospac(pospac, c)
    assert not trajectory_takes_gps_week(with_week)  # the export gives its own week
    assert trajectory_takes_gps_week(without)
    assert trajectory_takes_gps_week(pospac)
    assert trajectory_takes_gps_week(tmp_path / "t.sbet")  # seconds of week by format
    assert not trajectory_takes_gps_week(tmp_path / "t.csv")  # GPS time by format
    garbled = tmp_path / "g.txt"
    garbled.write_text("not an export\n")
    assert trajectory_takes_gps_week(garbled)  # its reader says what is wrong
