"""The Method B apply pipeline: a scan file time-tagged and put in the scanner frame."""

from __future__ import annotations

import csv
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from kinsync.errors import InputError, KinsyncWarning
from kinsync.io.mount_file import write_mount
from kinsync.io.point_provenance import read_point_record, record_mount
from kinsync.io.points import iter_table_chunks
from kinsync.io.profile_scan import (
    write_profile_scan,
)
from kinsync.mount import Mount
from kinsync.pipelines.sync_apply import apply_profile_clock
from kinsync.sync.scan import ProfileScan

MOUNT = Mount(profiler_azimuth_deg=30.0)
_RNG = np.random.default_rng(0)
SCAN = ProfileScan(  # 700 returns over 50 profiles, angles both sides of nadir
    profile=np.sort(_RNG.integers(0, 50, 700)),
    angle_rad=_RNG.uniform(-2.3, 2.3, 700),
    range_m=_RNG.uniform(0.5, 40.0, 700),
    intensity=_RNG.uniform(0.0, 1.0, 700),
)


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_apply_adds_time_and_scanner_coordinates(tmp_path: Path, suffix: str) -> None:
    scan = SCAN
    src = tmp_path / f"scan{suffix}"
    write_profile_scan(scan, src, extra={"label": np.array([f"r{i}" for i in range(len(scan))])})
    out = tmp_path / f"out{suffix}"
    seen: list[int] = []
    n = apply_profile_clock(src, out, 100.0, 0.03, MOUNT, chunk_points=256, progress=seen.append)
    assert n == len(scan)
    assert seen == [256, 512, 700]
    (chunk,) = iter_table_chunks(out, 10_000, ("t_s", "x_m", "y_m", "z_m"))
    assert list(chunk)[:5] == ["profile", "angle_rad", "range_m", "intensity", "label"]
    assert chunk["label"].tolist() == [f"r{i}" for i in range(len(scan))]
    expected_t = 100.0 + (scan.profile + scan.angle_rad / (2 * np.pi)) * 0.03
    np.testing.assert_allclose(chunk["t_s"], expected_t, rtol=0, atol=1e-12)
    xyz = np.column_stack([chunk["x_m"], chunk["y_m"], chunk["z_m"]])
    np.testing.assert_allclose(
        xyz, MOUNT.profile_to_scanner(angle_rad=scan.angle_rad, range_m=scan.range_m)
    )
    # Azimuth 30 deg: the profile plane is the scanner Y-Z plane turned about Z.
    normal = np.array([np.cos(np.radians(30.0)), np.sin(np.radians(30.0)), 0.0])
    np.testing.assert_allclose(xyz @ normal, 0.0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(xyz, axis=1), scan.range_m)


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_apply_writes_no_negative_zero(tmp_path: Path, suffix: str) -> None:
    """Azimuth 0 gave x_m = -sin(0) y = -0.0, written as '-0.0' (a nadir angle -0.0 did in y_m)."""
    src = tmp_path / "scan.csv"
    src.write_text("profile,angle_rad,range_m\n0,0.5,2\n0,-0.0,3\n1,-0.5,2\n")
    out = tmp_path / f"out{suffix}"
    apply_profile_clock(src, out, 100.0, 0.03, Mount(profiler_azimuth_deg=0.0))
    (chunk,) = iter_table_chunks(out, 10, ("x_m", "y_m", "z_m"))
    for name in ("x_m", "y_m"):
        assert not np.any(np.signbit(chunk[name]) & (chunk[name] == 0.0)), name
    np.testing.assert_array_equal(chunk["x_m"], 0.0)
    if suffix == ".csv":  # the input's own angle -0.0 is carried as it is
        cells = [line.split(",")[-3:] for line in out.read_text().splitlines()[1:]]
        assert "-0.0" not in {cell for row in cells for cell in row}, cells


def test_apply_bad_input(tmp_path: Path) -> None:
    src = tmp_path / "scan.csv"
    src.write_text("profile,angle_rad,range_m,t_s\n0,0.1,2,5\n1,0.1,2,5\n")
    with pytest.raises(InputError, match=r"already has column\(s\) \['t_s'\]"):
        apply_profile_clock(src, tmp_path / "o.csv", 0.0, 0.03, MOUNT)
    with pytest.raises(InputError, match=r"\[profiler\]"):
        apply_profile_clock(src, tmp_path / "o.csv", 0.0, 0.03, Mount())
    with pytest.raises(InputError, match="period_s > 0"):
        apply_profile_clock(src, tmp_path / "o.csv", 0.0, 0.0, MOUNT)
    lines = "profile,angle_rad,range_m\n" + "".join(f"{p},0.1,2\n" for p in [0, 1, 2, 3, 1])
    dec = tmp_path / "dec.csv"
    dec.write_text(lines)
    with pytest.raises(
        InputError, match=r"dec\.csv: line 6, column 'profile': profile number 1 after 3"
    ):
        apply_profile_clock(dec, tmp_path / "o.csv", 0.0, 0.03, MOUNT, chunk_points=2)
    assert not (tmp_path / "o.csv").exists()
    assert not list(tmp_path.glob("*.part"))
    pq.write_table(
        pa.table({n: pa.array([0.1] * 5) for n in ("angle_rad", "range_m")}).append_column(
            "profile", pa.array([0, 1, 2, 3, 1])
        ),
        tmp_path / "dec.parquet",
        row_group_size=2,
    )
    with pytest.raises(InputError, match=r"dec\.parquet: row 5 of 5, column 'profile': profile"):
        apply_profile_clock(
            tmp_path / "dec.parquet", tmp_path / "o.csv", 0.0, 0.03, MOUNT, chunk_points=2
        )


@pytest.mark.parametrize("bad_range", ["-0.5", "1e307", "nan"])
def test_apply_refuses_a_negative_or_absurd_range(tmp_path: Path, bad_range: str) -> None:
    src = tmp_path / "scan.csv"
    src.write_text(f"profile,angle_rad,range_m\n0,0.1,2\n1,0.1,{bad_range}\n2,0.1,3\n")
    with pytest.raises(InputError, match=r"scan\.csv: line 3: .*a range is a finite distance"):
        apply_profile_clock(src, tmp_path / "o.csv", 0.0, 0.03, MOUNT)
    assert not (tmp_path / "o.csv").exists()


@pytest.mark.parametrize("bad_angle", ["1e308", "-7.0", "nan"])
def test_apply_refuses_an_angle_beyond_one_turn(tmp_path: Path, bad_angle: str) -> None:
    # 1e308 gave the return a time of 4.8e305 s, and x, y, z from sin/cos of it.
    src = tmp_path / "scan.csv"
    src.write_text(f"profile,angle_rad,range_m\n0,0.1,2\n1,{bad_angle},2\n2,6.283,3\n")
    with pytest.raises(InputError, match=r"scan\.csv: line 3: .*radians within one turn"):
        apply_profile_clock(src, tmp_path / "o.csv", 0.0, 0.03, MOUNT)
    assert not (tmp_path / "o.csv").exists()


def test_apply_carries_extra_csv_columns_as_their_text(tmp_path: Path) -> None:
    src = tmp_path / "scan.csv"
    src.write_text("profile,angle_rad,range_m,code,big\n0,0.1,2,007,1180591620717411303424\n")
    apply_profile_clock(src, tmp_path / "o.csv", 0.0, 0.03, MOUNT)
    text = (tmp_path / "o.csv").read_text()
    assert ",007,1180591620717411303424," in text  # as written, and unquoted
    assert '"' not in text


def _typed_scan(n: int, profile_type: pa.DataType | None = None) -> pa.Table:
    """A scan with carried columns of every kind, a null in each, and narrow number types."""
    rows = np.arange(n)
    null = rows % 7 == 3
    return pa.table(
        {
            "profile": pa.array(rows // 4).cast(profile_type or pa.int32()),
            "angle_rad": pa.array(np.linspace(-2.0, 2.0, n), pa.float32()),
            "range_m": np.linspace(1.0, 30.0, n),
            "intensity": pa.array(rows.astype(np.int32), pa.int32(), mask=null),
            "valid": pa.array(rows % 2 == 0, mask=rows % 5 == 1),
            "label": pa.array([f"r{i}" if i % 6 else None for i in range(n)]),
            "stamp": pa.array(rows * 1000, pa.timestamp("us"), mask=rows % 9 == 2),
            "power": pa.array(rows * 0.5, mask=rows % 8 == 5),
        }
    )


@pytest.mark.parametrize("profile_type", [pa.int32(), pa.uint16(), pa.float64()])
def test_apply_keeps_parquet_types_and_nulls(tmp_path: Path, profile_type: pa.DataType) -> None:
    scan = _typed_scan(23, profile_type)
    src = tmp_path / "scan.parquet"
    pq.write_table(scan, src, row_group_size=7)  # chunks of 5 cut across row groups
    out = tmp_path / "o.parquet"
    seen: list[int] = []
    n = apply_profile_clock(src, out, 10.0, 0.1, MOUNT, chunk_points=5, progress=seen.append)
    assert n == 23
    assert seen == [5, 10, 15, 20, 23]
    got = pq.read_table(out)
    assert got.column_names == [*scan.column_names, "t_s", "x_m", "y_m", "z_m"]
    assert got.select(scan.column_names).schema == scan.schema
    assert got.select(scan.column_names).to_pylist() == scan.to_pylist()
    angle = scan.column("angle_rad").to_numpy().astype(np.float64)
    expected_t = 10.0 + (scan.column("profile").to_numpy() + angle / (2 * np.pi)) * 0.1
    np.testing.assert_allclose(got.column("t_s").to_numpy(), expected_t, rtol=0, atol=1e-12)


def test_apply_parquet_to_csv_writes_integers_and_empty_cells(tmp_path: Path) -> None:
    scan = _typed_scan(23)
    src = tmp_path / "scan.parquet"
    pq.write_table(scan, src, row_group_size=7)
    out = tmp_path / "o.csv"
    apply_profile_clock(src, out, 10.0, 0.1, MOUNT, chunk_points=5)
    with out.open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 23

    def text(name: str) -> list[str]:
        return [row[name] for row in rows]

    def expected(name: str, form: Callable[[object], str]) -> list[str]:
        return ["" if v is None else form(v) for v in scan.column(name).to_pylist()]

    assert text("intensity") == expected("intensity", str)  # 3, not 3.0; null: empty
    assert text("profile") == expected("profile", str)
    assert text("valid") == expected("valid", lambda v: str(v).lower())
    assert text("label") == expected("label", str)
    assert text("power") == expected("power", repr)  # a null float is empty, not nan
    assert "nan" not in out.read_text()
    assert text("stamp")[3] == "1970-01-01 00:00:00.003000"
    assert text("stamp")[2] == ""


def test_apply_csv_to_csv_keeps_the_text_of_carried_columns(tmp_path: Path) -> None:
    carried = ['007,true,"a,b",1e3', ",,,", '12,false,"say ""hi""",-0', "99,, x ,inf"]
    lines = [f"{i // 2},0.{i + 1}1,{i + 2},{carried[i % 4]}" for i in range(11)]
    src = tmp_path / "scan.csv"
    src.write_text("profile,angle_rad,range_m,code,ok,note,raw\n" + "\n".join(lines) + "\n")
    out = tmp_path / "o.csv"
    assert apply_profile_clock(src, out, 0.0, 0.1, MOUNT, chunk_points=4) == 11
    got = out.read_text().splitlines()
    assert got[0] == "profile,angle_rad,range_m,code,ok,note,raw,t_s,x_m,y_m,z_m"
    for i, line in enumerate(got[1:]):
        required, rest = line.split(",", 3)[:3], line.split(",", 3)[3]
        assert required == [str(i // 2), f"0.{i + 1}1", f"{i + 2}.0"]  # profile whole
        assert rest.rsplit(",", 4)[0] == carried[i % 4]  # byte for byte


def test_apply_csv_to_parquet_carries_text_and_whole_profiles(tmp_path: Path) -> None:
    src = tmp_path / "scan.csv"
    src.write_text("profile,angle_rad,range_m,code,ok\n0,0.1,2,007,true\n1,0.2,3,,\n3,0.3,4,8,\n")
    out = tmp_path / "o.parquet"
    apply_profile_clock(src, out, 0.0, 0.1, MOUNT, chunk_points=2)
    got = pq.read_table(out)
    assert got.schema.field("profile").type == pa.int64()
    assert got.column("profile").to_pylist() == [0, 1, 3]
    assert got.schema.field("code").type == pa.string()  # as georef carries a CSV's columns
    assert got.column("code").to_pylist() == ["007", "", "8"]
    assert got.column("ok").to_pylist() == ["true", "", ""]


@pytest.mark.parametrize("column", ["profile", "angle_rad", "range_m"])
def test_apply_refuses_a_null_in_a_required_column(tmp_path: Path, column: str) -> None:
    scan = _typed_scan(23)
    values = scan.column(column).to_pylist()
    values[17] = None  # in the fourth chunk
    scan = scan.set_column(scan.column_names.index(column), column, pa.array(values))
    src = tmp_path / "scan.parquet"
    pq.write_table(scan, src, row_group_size=7)
    with pytest.raises(
        InputError, match=rf"scan\.parquet: row 18 of 23, column '{column}': no value"
    ):
        apply_profile_clock(src, tmp_path / "o.parquet", 0.0, 0.1, MOUNT, chunk_points=5)
    lines = [f"{i // 2},0.1,2" for i in range(9)]
    lines[6] = {"profile": ",0.1,2", "angle_rad": "3,,2", "range_m": "3,0.1,"}[column]
    csv_src = tmp_path / "scan.csv"
    csv_src.write_text("profile,angle_rad,range_m\n" + "\n".join(lines) + "\n")
    with pytest.raises(InputError, match=rf"scan\.csv: line 8, column '{column}': empty cell"):
        apply_profile_clock(csv_src, tmp_path / "o.csv", 0.0, 0.1, MOUNT, chunk_points=4)
    assert not list(tmp_path.glob("o.*"))


@pytest.mark.parametrize("out_suffix", [".csv", ".parquet"])
def test_a_scan_without_rows_gives_an_output_with_every_column(
    tmp_path: Path, out_suffix: str
) -> None:
    """A header-only scan once gave an empty file (0 bytes), which kinsync then refused
    ("empty file; expected a header line"): like georef, apply writes the header."""
    src = tmp_path / "h.csv"
    src.write_text("profile,angle_rad,range_m,intensity,label\n")
    out = tmp_path / f"o{out_suffix}"
    assert apply_profile_clock(src, out, 10.0, 0.1, MOUNT) == 0
    names = ["profile", "angle_rad", "range_m", "intensity", "label", "t_s", "x_m", "y_m", "z_m"]
    if out_suffix == ".csv":
        assert out.read_text() == ",".join(names) + "\n"
    else:  # the types a chunk would have: profile whole, carried CSV columns as text
        schema = pq.read_schema(out)
        assert schema.names == names
        types = ["int64", "double", "double", "string", "string", *["double"] * 4]
        assert [str(t) for t in schema.types] == types
    assert list(iter_table_chunks(out, 10, ("t_s", "x_m", "y_m", "z_m"))) == []


def test_a_parquet_scan_without_rows_keeps_its_types(tmp_path: Path) -> None:
    scan = _typed_scan(0, pa.int32())
    src = tmp_path / "scan.parquet"
    pq.write_table(scan, src)
    out = tmp_path / "o.parquet"
    assert apply_profile_clock(src, out, 10.0, 0.1, MOUNT) == 0
    got = pq.read_table(out)
    assert got.num_rows == 0
    assert got.column_names == [*scan.column_names, "t_s", "x_m", "y_m", "z_m"]
    assert got.select(scan.column_names).schema == scan.schema


def test_a_scan_without_rows_that_has_an_output_column_is_refused(tmp_path: Path) -> None:
    src = tmp_path / "h.csv"
    src.write_text("profile,angle_rad,range_m,x_m\n")
    with pytest.raises(InputError, match=r"already has column\(s\) \['x_m'\]"):
        apply_profile_clock(src, tmp_path / "o.csv", 0.0, 0.03, MOUNT)
    assert not (tmp_path / "o.csv").exists()


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_apply_refuses_zero_ranges_naming_the_first_and_the_count(
    tmp_path: Path, suffix: str
) -> None:
    """A range of 0 (a 'no return' code) put the return at the scanner itself (exit 0)."""
    scan = ProfileScan(
        profile=np.array([0, 0, 1, 1, 2, 2]),
        angle_rad=np.full(6, 0.1),
        range_m=np.array([2.0, 3.0, 0.0, 2.0, 0.0, 0.0]),
        intensity=np.full(6, 0.5),
    )
    src = tmp_path / f"scan{suffix}"
    write_profile_scan(scan, src)
    where = "line 4" if suffix == ".csv" else "row 3 of 6"
    with pytest.raises(InputError, match=rf"{where}: range_m is 0 \(3 of 6 returns\).*remove"):
        apply_profile_clock(src, tmp_path / f"o{suffix}", 0.0, 0.03, MOUNT, chunk_points=2)
    assert not (tmp_path / f"o{suffix}").exists()
    assert not list(tmp_path.glob("*.part"))


def test_apply_warns_of_ranges_in_millimetres(tmp_path: Path) -> None:
    """Ranges in mm (45,043 for 45 m) were written 45 km from the scanner without a word."""
    src = tmp_path / "scan.csv"
    src.write_text("profile,angle_rad,range_m\n0,0.1,45043\n0,0.2,1500\n1,0.1,45100\n")
    with pytest.warns(KinsyncWarning, match=r"2 of 3 ranges .* are the ranges in millimetres"):
        apply_profile_clock(src, tmp_path / "o.csv", 0.0, 0.03, MOUNT)
    src.write_text("profile,angle_rad,range_m\n0,0.1,45043\n0,0.2,1500\n1,0.1,45\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        apply_profile_clock(src, tmp_path / "o2.csv", 0.0, 0.03, MOUNT)


def test_a_parquet_output_holds_the_kinsync_record(tmp_path: Path) -> None:
    """The mount (its profiler azimuth made x_m, y_m, z_m), its file and the clock."""
    src = tmp_path / "scan.parquet"
    write_profile_scan(SCAN, src)
    mount_file = tmp_path / "mount.toml"
    write_mount(MOUNT, mount_file)
    out = tmp_path / "out.parquet"
    apply_profile_clock(src, out, 100.0, 0.03, MOUNT, mount_file=mount_file)
    doc = read_point_record(out)
    assert doc["made_by"] == "sync apply"
    assert doc["points"] == {"path": str(src)}
    assert doc["clock"] == {"t0_s": 100.0, "period_s": 0.03, "file": None}
    assert doc["mount"]["file"]["path"] == str(mount_file)
    assert record_mount(doc, out) == MOUNT
    csv_out = tmp_path / "out.csv"  # a CSV has nowhere to keep it: header line first
    apply_profile_clock(src, csv_out, 100.0, 0.03, MOUNT, mount_file=mount_file)
    assert csv_out.read_text().splitlines()[0].startswith("profile,angle_rad,range_m")


def test_a_parquet_output_does_not_depend_on_the_chunks(tmp_path: Path) -> None:
    """One row group per chunk made chunk_points change the bytes (the same table)."""
    src = tmp_path / "scan.parquet"
    write_profile_scan(SCAN, src)
    out = tmp_path / "out.parquet"
    apply_profile_clock(src, out, 100.0, 0.03, MOUNT)
    whole = out.read_bytes()
    apply_profile_clock(src, out, 100.0, 0.03, MOUNT, chunk_points=9)
    assert out.read_bytes() == whole
