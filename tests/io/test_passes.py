"""Pass folders: CSV/LAS/LAZ round trips and one test per bad input."""

from __future__ import annotations

import datetime as dt
import tempfile
import warnings
from pathlib import Path

import laspy
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from tests._las import las_points

import kinsync.io.passes as passes_io
from kinsync._typing import FloatArray
from kinsync.errors import InputError, KinsyncWarning
from kinsync.io.las import ADJUSTED_GPS_OFFSET_S
from kinsync.io.las_header import generating_software
from kinsync.io.passes import pass_file_name, read_pass_file, read_passes, write_passes
from kinsync.io.tables import write_numeric_csv
from kinsync.latency.passes import SpherePass


def _passes(seed: int = 0, *, with_time: bool = True) -> list[SpherePass]:
    rng = np.random.default_rng(seed)
    out = []
    for i, rate in enumerate((6.0, -6.0, 18.0)):
        c = np.array([1.5, 0.2, -0.01])
        pts = c + rng.uniform(-0.3, 0.3, size=(200 + 17 * i, 3))
        t = 1.4e9 + 10.0 * i + np.sort(rng.uniform(0.0, 5.0, pts.shape[0])) if with_time else None
        axis = (0.0, 0.0, 1.0) if i != 1 else (1e-4, -2e-4, 1.0)
        out.append(SpherePass(f"p{i}", rate, pts, axis_ned=axis, t_s=t))
    return out


def _assert_same(
    a: list[SpherePass], b: list[SpherePass], *, tol_m: float, exact_time: bool = True
) -> None:
    assert len(a) == len(b)
    for p, q in zip(a, b, strict=True):
        assert q.rate_deg_s == p.rate_deg_s
        np.testing.assert_allclose(q.axis_ned, p.axis_ned, rtol=0, atol=1e-15)
        assert q.points_ned_m.shape == p.points_ned_m.shape
        assert np.max(np.abs(q.points_ned_m - p.points_ned_m)) <= tol_m
        if p.t_s is None:
            assert q.t_s is None
        else:
            assert q.t_s is not None
            if exact_time:
                np.testing.assert_array_equal(q.t_s, p.t_s)


# ---------------------------------------------------------------------- round trips
def test_csv_round_trip_is_exact(tmp_path: Path) -> None:
    ps = _passes()
    write_passes(tmp_path, ps)
    back = read_passes(tmp_path)
    _assert_same(ps, back, tol_m=0.0)
    assert [Path(p.source).name for p in back] == ["pass_000.csv", "pass_001.csv", "pass_002.csv"]
    header = (tmp_path / "pass_000.csv").read_text().splitlines()[0]
    assert header == "x_m,y_m,z_m,t_s"


@pytest.mark.parametrize("fmt", ["las", "laz"])
def test_las_round_trip_within_scale(tmp_path: Path, fmt: passes_io.PassFileFormat) -> None:
    ps = _passes()
    write_passes(tmp_path, ps, file_format=fmt)
    back = read_passes(tmp_path)
    # 1e-6 m scale: rounding to the nearest micrometre.
    _assert_same(ps, back, tol_m=0.5e-6 + 1e-12)
    las = laspy.read(tmp_path / f"pass_000.{fmt}")
    assert las.header.scales[0] <= 1e-5
    assert las.header.global_encoding.gps_time_type == laspy.header.GpsTimeType.STANDARD
    assert las.header.generating_software == generating_software()
    assert set(np.asarray(las.return_number).tolist()) == {1}  # 1 of 1, not 0 of 0
    assert set(np.asarray(las.number_of_returns).tolist()) == {1}
    assert las.header.creation_date == dt.date(2023, 11, 14)  # tests' SOURCE_DATE_EPOCH
    # Adjusted standard GPS time in the file, GPS time after reading.
    assert float(np.max(las.gps_time)) < ADJUSTED_GPS_OFFSET_S
    np.testing.assert_allclose(las.header.offsets, np.min(ps[0].points_ned_m, axis=0), atol=1e-6)


@pytest.mark.parametrize("fmt", ["csv", "las", "laz"])
def test_round_trip_without_times(tmp_path: Path, fmt: passes_io.PassFileFormat) -> None:
    ps = _passes(with_time=False)
    write_passes(tmp_path, ps, file_format=fmt)
    _assert_same(ps, read_passes(tmp_path), tol_m=0.5e-6 + 1e-12)


def test_las_week_time_is_kept_as_written(tmp_path: Path) -> None:
    p = SpherePass("p", 2.0, np.ones((3, 3)) * [1.0, 2.0, 3.0], t_s=np.array([1.0, 2.0, 3.5]))
    write_passes(tmp_path, [p], file_format="las")
    las = laspy.read(tmp_path / "pass_000.las")
    assert las.header.global_encoding.gps_time_type == laspy.header.GpsTimeType.WEEK_TIME
    back = read_passes(tmp_path)[0]
    assert back.t_s is not None
    np.testing.assert_array_equal(back.t_s, [1.0, 2.0, 3.5])


finite = st.floats(-50.0, 50.0, allow_nan=False)


@settings(max_examples=25, deadline=None)
@given(
    pts=st.lists(st.tuples(finite, finite, finite), min_size=1, max_size=30),
    rate=st.floats(0.01, 90.0).flatmap(lambda r: st.sampled_from([r, -r])),
    axis=st.tuples(finite, finite, st.floats(0.5, 2.0)),
    fmt=st.sampled_from(["csv", "las", "laz"]),
)
def test_round_trip_property(
    pts: list[tuple[float, float, float]],
    rate: float,
    axis: tuple[float, float, float],
    fmt: passes_io.PassFileFormat,
) -> None:
    arr = np.array(pts, dtype=np.float64)
    t = 1.3e9 + np.arange(arr.shape[0], dtype=np.float64) * 0.01
    p = SpherePass("h", rate, arr, axis_ned=axis, t_s=t)
    with tempfile.TemporaryDirectory() as tmp:
        write_passes(Path(tmp), [p], file_format=fmt)
        back = read_passes(Path(tmp))
    tol = 0.0 if fmt == "csv" else 0.5e-6 + 1e-9
    _assert_same([p], back, tol_m=tol)


def test_hand_written_folder_defaults_and_extra_columns(tmp_path: Path) -> None:
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "a.csv").write_text("x_m,y_m,z_m,intensity\n1,2,3,10\n4,5,6,11\n")
    (tmp_path / "b.CSV").write_text("t_s,z_m,y_m,x_m\n0.5,3,2,1\n")
    (tmp_path / "passes.csv").write_text(
        " file , rate_deg_s ,comment\nsub/a.csv,-4.5,first\n\nb.CSV,2,second\n"
    )
    a, b = read_passes(tmp_path)
    assert a.rate_deg_s == -4.5
    assert a.axis_ned == (0.0, 0.0, 1.0)
    assert a.t_s is None
    np.testing.assert_array_equal(a.points_ned_m, [[1, 2, 3], [4, 5, 6]])
    np.testing.assert_array_equal(b.points_ned_m, [[1, 2, 3]])
    assert b.t_s is not None
    assert b.t_s.tolist() == [0.5]


def test_empty_axis_cells_take_the_default(tmp_path: Path) -> None:
    (tmp_path / "a.csv").write_text("x_m,y_m,z_m\n1,2,3\n")
    (tmp_path / "b.csv").write_text("x_m,y_m,z_m\n1,2,3\n")  # one file twice is refused
    (tmp_path / "passes.csv").write_text(
        "file,rate_deg_s,axis_n,axis_e,axis_d\na.csv,3,,,\nb.csv,3,0,1,0\n"
    )
    a, b = read_passes(tmp_path)
    assert a.axis_ned == (0.0, 0.0, 1.0)
    assert b.axis_ned == (0.0, 1.0, 0.0)


def test_pass_file_names() -> None:
    assert pass_file_name(7, 30) == "pass_007.csv"
    assert pass_file_name(12, 2000, "laz") == "pass_0012.laz"


def test_passes_csv_is_written_last(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    calls: list[Path] = []
    real = write_numeric_csv

    def failing(path: Path, columns: dict[str, FloatArray]) -> None:
        calls.append(path)
        if len(calls) == 2:
            raise OSError("disk full")
        real(path, columns)

    monkeypatch.setattr(passes_io, "write_numeric_csv", failing)
    with pytest.raises(OSError, match="disk full"):
        write_passes(tmp_path / "out", _passes())
    assert (tmp_path / "out" / "pass_000.csv").exists()
    assert not (tmp_path / "out" / "passes.csv").exists()
    assert not list((tmp_path / "out").glob("*.part"))


# ---------------------------------------------------------------------- bad input
def _folder(tmp_path: Path, index: str, files: dict[str, str] | None = None) -> Path:
    for name, text in (files or {"a.csv": "x_m,y_m,z_m\n1,2,3\n4,5,6\n"}).items():
        (tmp_path / name).write_text(text)
    (tmp_path / "passes.csv").write_text(index)
    return tmp_path


@pytest.mark.parametrize(
    ("index", "files", "fragments"),
    [
        ("", None, ["passes.csv", "empty file"]),
        ("file,rate_deg_s\n", None, ["passes.csv", "no passes listed"]),
        ("file,rate\na.csv,2\n", None, ["passes.csv", "line 1", "rate_deg_s"]),
        ("name,rate_deg_s\na.csv,2\n", None, ["passes.csv", "line 1", "'file'"]),
        ("file,rate_deg_s,file\na.csv,2,a.csv\n", None, ["line 1", "duplicated"]),
        ("file,rate_deg_s\na.csv,fast\n", None, ["passes.csv: line 2", "rate_deg_s", "'fast'"]),
        ("file,rate_deg_s\na.csv,nan\n", None, ["line 2", "not a finite number"]),
        ("file,rate_deg_s\n\na.csv,0\n", None, ["passes.csv: line 3", "rate_deg_s is 0"]),
        ("file,rate_deg_s\na.csv\n", None, ["line 2 has 1 fields"]),
        ("file,rate_deg_s\n,2\n", None, ["line 2", "'file': empty"]),
        ("file,rate_deg_s,axis_n,axis_d\na.csv,2,0,1\n", None, ["line 1", "partially"]),
        ("file,rate_deg_s,axis_n,axis_e,axis_d\na.csv,2,0,,1\n", None, ["line 2", "axis_e"]),
        ("file,rate_deg_s,axis_n,axis_e,axis_d\na.csv,2,0,up,1\n", None, ["line 2", "axis_e"]),
        ("file,rate_deg_s,axis_n,axis_e,axis_d\na.csv,2,0,0,0\n", None, ["line 2", "axis_ned"]),
        ("file,rate_deg_s\nmissing.csv,2\n", None, ["line 2", "'missing.csv' not found"]),
        ("file,rate_deg_s\na.csv,2\n", {"a.csv": "x_m,y_m\n1,2\n"}, ["line 2", "z_m"]),
        ("file,rate_deg_s\na.csv,2\n", {"a.csv": "x_m,y_m,z_m\n1,2,3\n1,b,3\n"}, ["line 3", "y_m"]),
        ("file,rate_deg_s\na.csv,2\n", {"a.csv": "x_m,y_m,z_m\n"}, ["line 2", "no points"]),
        ("file,rate_deg_s\na.csv,2\n", {"a.csv": ""}, ["line 2", "a.csv", "empty file"]),
        ("file,rate_deg_s\na.txt,2\n", {"a.txt": "x_m,y_m,z_m\n1,2,3\n"}, ["line 2", ".txt"]),
        ("file,rate_deg_s\na.las,2\n", {"a.las": "not a las file"}, ["line 2", "LAS/LAZ"]),
        ("file,rate_deg_s\na.laz,2\n", {"a.laz": "LASF garbage"}, ["line 2", "LAS/LAZ"]),
        # A pass listed twice would be counted twice (its sigma shrinks): refused.
        ("file,rate_deg_s\na.csv,2\na.csv,2\n", None, ["line 3", "listed twice (lines 2 and 3)"]),
        (
            "file,rate_deg_s\na.csv,2\nb.csv,-2\n./a.csv,-2\n",
            {"a.csv": "x_m,y_m,z_m\n1,2,3\n", "b.csv": "x_m,y_m,z_m\n1,2,3\n"},
            ["line 4", "'./a.csv' listed twice (lines 2 and 4)"],
        ),
    ],
)
def test_bad_folder(
    tmp_path: Path, index: str, files: dict[str, str] | None, fragments: list[str]
) -> None:
    folder = _folder(tmp_path, index, files)
    with pytest.raises(InputError) as exc:
        read_passes(folder)
    message = str(exc.value)
    for fragment in fragments:
        assert fragment in message, message


@pytest.mark.parametrize("line", [1, 3])
def test_a_byte_that_is_not_utf8_in_the_index_is_named_by_its_line(
    tmp_path: Path, line: int
) -> None:
    # It was "cannot read ('utf-8' codec can't decode byte 0xe9 in position 42 ...)".
    lines = [b"file,rate_deg_s", b"a.csv,2", b"b.csv,-2"]
    lines[line - 1] += b",caf\xe9"
    folder = tmp_path / "passes"
    folder.mkdir()
    (folder / "passes.csv").write_bytes(b"\n".join(lines) + b"\n")
    with pytest.raises(InputError) as exc:
        read_passes(folder)
    assert str(exc.value) == (
        f"{folder / 'passes.csv'}: line {line}: byte 0xE9 is not UTF-8 text; save the file as "
        "UTF-8 (or remove the damaged line)"
    )


def test_missing_folder(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="pass folder not found"):
        read_passes(tmp_path / "nope")


def test_folder_is_a_file(tmp_path: Path) -> None:
    f = tmp_path / "file"
    f.write_text("x")
    with pytest.raises(InputError, match="not a folder"):
        read_passes(f)


def test_missing_index(tmp_path: Path) -> None:
    with pytest.raises(InputError, match=r"passes\.csv: file not found"):
        read_passes(tmp_path)


def test_empty_las_pass(tmp_path: Path) -> None:
    header = laspy.LasHeader(point_format=6, version="1.4")
    laspy.LasData(header).write(tmp_path / "a.las")
    (tmp_path / "passes.csv").write_text("file,rate_deg_s\na.las,2\n")
    with pytest.raises(InputError, match=r"line 2: .*no points"):
        read_passes(tmp_path)


@pytest.mark.parametrize("kept", [0.5, 0.9, 0.99])
def test_truncated_laz_pass_names_the_file_and_its_line(tmp_path: Path, kept: float) -> None:
    # A LAZ pass cut short (an interrupted copy) is refused before lazrs reads past the
    # end ("LazrsError: failed to fill whole buffer" was an internal error), with the
    # chunk-table check that calibrate and georef use.
    write_passes(tmp_path, _passes(), file_format="laz")
    path = tmp_path / "pass_001.laz"
    data = path.read_bytes()
    path.write_bytes(data[: int(len(data) * kept)])
    with pytest.raises(InputError) as exc:
        read_passes(tmp_path)
    message = str(exc.value)
    for fragment in ("passes.csv: line 3", "pass_001.laz", "chunk table", "copy it again"):
        assert fragment in message, message


def test_unlisted_pass_files_are_named_in_a_warning(tmp_path: Path) -> None:
    write_passes(tmp_path, _passes())
    (tmp_path / "passes.csv").write_text(
        "\n".join((tmp_path / "passes.csv").read_text().splitlines()[:2]) + "\n"
    )
    (tmp_path / "notes.txt").write_text("not a pass")
    with pytest.warns(KinsyncWarning) as caught:
        back = read_passes(tmp_path)
    assert len(back) == 1
    assert len(caught) == 1
    message = str(caught[0].message)
    assert "2 files not listed in passes.csv" in message, message
    assert "pass_001.csv, pass_002.csv" in message, message
    assert "notes.txt" not in message


def test_a_fully_listed_folder_gives_no_warning(tmp_path: Path) -> None:
    write_passes(tmp_path, _passes(), file_format="laz")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        read_passes(tmp_path)


def test_read_pass_file_missing(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="not found"):
        read_pass_file(tmp_path / "x.laz")


def test_write_bad_input(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="no passes"):
        write_passes(tmp_path, [])
    with pytest.raises(InputError, match="format"):
        write_passes(tmp_path, _passes(), file_format="ply")  # type: ignore[arg-type]
    f = tmp_path / "file"
    f.write_text("x")
    with pytest.raises(InputError, match="not a folder"):
        write_passes(f, _passes())
    far = SpherePass("far", 2.0, np.array([[0.0, 0.0, 0.0], [1e6, 0.0, 0.0]]))
    with pytest.raises(InputError, match="too large for LAS"):
        write_passes(tmp_path / "far", [far], file_format="las")


def test_a_bad_pass_point_is_named_by_its_file_line_or_las_point(tmp_path: Path) -> None:
    """Past an empty line the CSV line is still right; a LAS point counts from 1 of all."""
    path = tmp_path / "p.csv"
    path.write_text("x_m,y_m,z_m\n1,2,3\n\n1,2,3\n1,2,1e9\n")
    with pytest.raises(InputError, match=r"p\.csv: line 5, column 'z_m'"):
        read_pass_file(path)
    las = las_points(
        {"x_m": np.zeros(3), "y_m": np.zeros(3), "z_m": np.zeros(3), "t_s": 1e9 + np.arange(3.0)}
    )
    times = np.asarray(las.gps_time).copy()
    times[2] = np.nan
    las.gps_time = times
    las.write(tmp_path / "p.las")
    with pytest.raises(InputError, match=r"p\.las: point 3 of 3, column 't_s'"):
        read_pass_file(tmp_path / "p.las")
