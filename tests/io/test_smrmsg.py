"""smrmsg (SBET accuracy) files: layout, round trip, units, companion lookup, bad input."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from kinsync.errors import InputError
from kinsync.io.sbet import SECONDS_PER_WEEK
from kinsync.io.smrmsg import (
    SMRMSG_DTYPE,
    SMRMSG_RECORD_BYTES,
    SmrmsgData,
    find_smrmsg_companion,
    read_smrmsg,
    read_smrmsg_records,
    smrmsg_companion_path,
    write_smrmsg,
)

ARCMIN_RAD = math.radians(1.0 / 60.0)


def _data(n: int = 40, t0: float = 345600.0, seed: int = 1) -> SmrmsgData:
    rng = np.random.default_rng(seed)
    return SmrmsgData(
        t_s=t0 + np.arange(n, dtype=np.float64),
        std_pos_ned_m=rng.uniform(0.01, 0.1, (n, 3)),
        std_vel_ned_m_s=rng.uniform(0.001, 0.01, (n, 3)),
        std_rpy_rad=rng.uniform(0.1, 3.0, (n, 3)) * ARCMIN_RAD,
    )


def _assert_same(a: SmrmsgData, b: SmrmsgData) -> None:
    np.testing.assert_array_equal(a.t_s, b.t_s)
    np.testing.assert_array_equal(a.std_pos_ned_m, b.std_pos_ned_m)
    np.testing.assert_array_equal(a.std_vel_ned_m_s, b.std_vel_ned_m_s)
    np.testing.assert_allclose(a.std_rpy_rad, b.std_rpy_rad, rtol=1e-15, atol=0)


def test_dtype_is_80_bytes_of_little_endian_float64() -> None:
    assert SMRMSG_RECORD_BYTES == SMRMSG_DTYPE.itemsize == 80
    assert len(SMRMSG_DTYPE.names or ()) == 10
    assert all(SMRMSG_DTYPE[i] == np.dtype("<f8") for i in range(10))


def test_hand_built_records_field_by_field_and_attitude_in_arc_minutes(tmp_path: Path) -> None:
    # The first records of PDAL's test file (test/unit/io/SmrmsgReaderTest.cpp).
    values = np.array(
        [
            [536258, 0.056279, 0.057791, 0.070774, 0.006642, 0.008034, 0.008131, 0.236985,
             0.239420, 3.010802],
            [536259, 0.054151, 0.055892, 0.068654, 0.006113, 0.007200, 0.007629, 0.235971,
             0.238542, 3.010596],
        ],
        dtype="<f8",
    )  # fmt: skip
    path = tmp_path / "smrmsg_hand.out"
    path.write_bytes(values.tobytes())
    rec = read_smrmsg_records(path)
    for i, name in enumerate(SMRMSG_DTYPE.names or ()):
        np.testing.assert_array_equal(rec[name], values[:, i], err_msg=name)
    data = read_smrmsg(path)
    np.testing.assert_array_equal(data.t_s, values[:, 0])
    np.testing.assert_array_equal(data.std_pos_ned_m, values[:, 1:4])
    np.testing.assert_array_equal(data.std_vel_ned_m_s, values[:, 4:7])
    # 3.0108 arc minutes of heading = 0.0502 deg.
    np.testing.assert_allclose(np.degrees(data.std_rpy_rad), values[:, 7:10] / 60.0, rtol=1e-14)
    week = 2200
    np.testing.assert_array_equal(
        read_smrmsg(path, gps_week=week).t_s, week * SECONDS_PER_WEEK + values[:, 0]
    )


def test_round_trip_seconds_of_week_and_continuous_gps_time(tmp_path: Path) -> None:
    data = _data()
    path = tmp_path / "smrmsg_a.out"
    write_smrmsg(data, path)
    assert path.stat().st_size == SMRMSG_RECORD_BYTES * len(data)
    _assert_same(read_smrmsg(path), data)
    week = 2301
    crossing = _data(t0=week * SECONDS_PER_WEEK + 604780.0)  # crosses into the next week
    write_smrmsg(crossing, path)
    assert float(read_smrmsg_records(path)["time_sow_s"][-1]) > SECONDS_PER_WEEK
    _assert_same(read_smrmsg(path, gps_week=week), crossing)


@settings(max_examples=40, deadline=None)
@given(
    values=arrays(
        np.float64,
        st.tuples(st.integers(1, 30), st.just(9)),
        elements=st.floats(0.0, 1e3, allow_nan=False, allow_infinity=False),
    ),
    t0=st.floats(0.0, 604000.0),
)
def test_round_trip_of_any_valid_record(
    tmp_path_factory: pytest.TempPathFactory, values: np.ndarray, t0: float
) -> None:
    data = SmrmsgData(
        t_s=t0 + np.arange(values.shape[0], dtype=np.float64),
        std_pos_ned_m=values[:, 0:3],
        std_vel_ned_m_s=values[:, 3:6],
        std_rpy_rad=values[:, 6:9],
    )
    path = tmp_path_factory.mktemp("rt") / "smrmsg.out"
    write_smrmsg(data, path)
    back = read_smrmsg(path)
    np.testing.assert_array_equal(back.t_s, data.t_s)
    np.testing.assert_array_equal(back.std_pos_ned_m, data.std_pos_ned_m)
    np.testing.assert_array_equal(back.std_vel_ned_m_s, data.std_vel_ned_m_s)
    np.testing.assert_allclose(back.std_rpy_rad, data.std_rpy_rad, rtol=1e-14, atol=1e-300)


def test_bad_files(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="not found"):
        read_smrmsg(tmp_path / "missing.out")
    (tmp_path / "empty.out").write_bytes(b"")
    with pytest.raises(InputError, match="empty file"):
        read_smrmsg(tmp_path / "empty.out")
    (tmp_path / "cut.out").write_bytes(b"\0" * (80 * 2 + 7))
    with pytest.raises(InputError, match=r"cut\.out.*2 whole records and 7 bytes left over"):
        read_smrmsg(tmp_path / "cut.out")
    rec = np.zeros(4, dtype=SMRMSG_DTYPE)
    rec["time_sow_s"] = [1.0, 2.0, 3.0, 4.0]
    rec["std_east_m"][2] = -0.1
    rec.tofile(tmp_path / "neg.out")
    with pytest.raises(InputError, match=r"neg\.out: record 2 \(byte 160\).*-0\.1 is negative"):
        read_smrmsg(tmp_path / "neg.out")
    rec["std_east_m"][2] = 0.1
    rec["std_heading_arcmin"][1] = np.nan
    rec.tofile(tmp_path / "nan.out")
    with pytest.raises(InputError, match=r"record 1 \(byte 80\), column .*: nan is not a finite"):
        read_smrmsg(tmp_path / "nan.out")
    with pytest.raises(InputError, match="gps_week must be >= 0"):
        read_smrmsg(tmp_path / "neg.out", gps_week=-1)


def test_container_validates_shapes() -> None:
    with pytest.raises(InputError, match=r"std_vel_ned_m_s: expected shape \(2, 3\)"):
        SmrmsgData(np.zeros(2), np.zeros((2, 3)), np.zeros((3, 3)), np.zeros((2, 3)))
    with pytest.raises(InputError, match="1-D"):
        SmrmsgData(np.zeros((2, 1)), np.zeros((2, 3)), np.zeros((2, 3)), np.zeros((2, 3)))


def test_companion_lookup(tmp_path: Path) -> None:
    sbet = tmp_path / "sbet_mission1.out"
    sbet.write_bytes(b"")
    assert find_smrmsg_companion(sbet) is None
    other = tmp_path / "smrmsg_other.out"
    other.write_bytes(b"")
    assert find_smrmsg_companion(sbet) == other  # the folder's only smrmsg*.out
    companion = tmp_path / "smrmsg_mission1.out"
    companion.write_bytes(b"")
    assert find_smrmsg_companion(sbet) == companion  # same rest of the name wins
    companion.unlink()
    (tmp_path / "SMRMSG_third.OUT").write_bytes(b"")
    assert find_smrmsg_companion(sbet) is None  # two candidates: no guess
    upper = tmp_path / "SBET_B.OUT"
    upper.write_bytes(b"")
    (tmp_path / "SMRMSG_B.OUT").write_bytes(b"")
    assert find_smrmsg_companion(upper) == tmp_path / "SMRMSG_B.OUT"
    nested = tmp_path / "sub"
    nested.mkdir()
    lone = nested / "trajectory.out"
    lone.write_bytes(b"")
    assert find_smrmsg_companion(lone) is None


@pytest.mark.parametrize("gps_week", [None, 2345])
def test_negative_seconds_of_week_are_refused_naming_the_record(
    tmp_path: Path, gps_week: int | None
) -> None:
    # Were read as times of an earlier week, as in SBET files (test_sbet).
    rec = np.zeros(4, dtype=SMRMSG_DTYPE)
    rec["time_sow_s"] = [-3.0, -2.0, -1.0, 0.0]
    rec.tofile(tmp_path / "negt.out")
    with pytest.raises(
        InputError, match=r"negt\.out: record 0 \(byte 0\), column 'time_sow_s'.*seconds of week"
    ):
        read_smrmsg(tmp_path / "negt.out", gps_week=gps_week)


@pytest.mark.parametrize(
    ("sbet", "smrmsg"),
    [
        ("sbet_mission1.out", "smrmsg_mission1.out"),
        ("SBET_A.OUT", "SMRMSG_A.OUT"),
        ("nav.sbet", "smrmsg_nav.out"),
    ],
)
def test_the_companion_is_written_where_it_is_looked_for(
    tmp_path: Path, sbet: str, smrmsg: str
) -> None:
    path = smrmsg_companion_path(tmp_path / sbet)
    assert path == tmp_path / smrmsg
    (tmp_path / sbet).write_bytes(b"")
    write_smrmsg(_data(), path)
    assert find_smrmsg_companion(tmp_path / sbet) == path
