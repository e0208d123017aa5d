"""LAS/LAZ chunked reading and writing: attributes, VLRs and CRS carried, atomic."""

from __future__ import annotations

import re
from pathlib import Path

import laspy
import numpy as np
import pyproj
import pytest
from laspy.vlrs.vlrlist import VLRList

from kinsync.errors import InputError
from kinsync.io.las import (
    LasPointReader,
    iter_las_chunks,
    las_end_times,
    las_header,
    las_info,
    las_takes_gps_week,
    las_time_offset_s,
    read_las_points,
    scaled_coordinates,
    store_coordinates,
)
from kinsync.io.las_writer import LasChunkWriter


def _make_las(path: Path, n: int = 1000, seed: int = 0) -> laspy.LasData:
    rng = np.random.default_rng(seed)
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.add_extra_dims([laspy.ExtraBytesParams(name="reflectance_db", type=np.float32)])
    header.scales = np.array([1e-4, 1e-4, 1e-4])
    header.offsets = np.array([0.0, 0.0, 0.0])
    header.global_encoding.gps_time_type = laspy.header.GpsTimeType.STANDARD
    header.vlrs.append(laspy.VLR(user_id="kinsync_test", record_id=42, record_data=b"hello"))
    las = laspy.LasData(header)
    las.x = rng.uniform(-50, 50, n)
    las.y = rng.uniform(-50, 50, n)
    las.z = rng.uniform(-5, 5, n)
    las.intensity = rng.integers(0, 65535, n).astype(np.uint16)
    las.return_number = rng.integers(1, 4, n).astype(np.uint8)
    las.number_of_returns = np.full(n, 3, np.uint8)
    las.classification = rng.integers(0, 20, n).astype(np.uint8)
    las.gps_time = 4.0e8 + np.sort(rng.uniform(0, 100, n))
    las.reflectance_db = rng.normal(-10, 3, n).astype(np.float32)
    las.evlrs = VLRList([laspy.VLR(user_id="kinsync_test", record_id=7, record_data=b"e" * 10)])
    las.write(path, laz_backend=laspy.LazBackend.Lazrs if path.suffix == ".laz" else None)
    return las


def _ecef(x: np.ndarray, y: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, ...]:
    return 4.3e6 + x, 5.0e5 + y, 4.6e6 + z


def _transform(src: Path, dst: Path, crs: pyproj.CRS | None, chunk: int = 300) -> None:
    with laspy.open(src, laz_backend=laspy.LazBackend.Lazrs) as r:
        template = r.header
    with LasChunkWriter(dst, template, crs, (4.3e6, 5.0e5, 4.6e6), 1e-4) as w:
        for pts in iter_las_chunks(src, chunk):
            w.write(pts, *_ecef(np.asarray(pts.x), np.asarray(pts.y), np.asarray(pts.z)))


@pytest.mark.parametrize("suffix", [".las", ".laz"])
@pytest.mark.parametrize("epsg", [4978, 32632])
def test_round_trip_keeps_every_attribute(tmp_path: Path, suffix: str, epsg: int) -> None:
    src = tmp_path / f"in{suffix}"
    las = _make_las(src)
    dst = tmp_path / f"out{suffix}"
    _transform(src, dst, pyproj.CRS.from_epsg(epsg))
    info = las_info(dst)
    assert info.point_count == 1000
    assert info.point_format_id == 6
    assert info.version == "1.4"
    assert info.gps_time_type == "adjusted_standard"
    assert info.scales == (1e-4, 1e-4, 1e-4)
    assert info.crs_wkt is not None
    assert pyproj.CRS.from_wkt(info.crs_wkt).to_epsg() == epsg
    out = laspy.read(dst, laz_backend=laspy.LazBackend.Lazrs)
    for dim in ("intensity", "return_number", "number_of_returns", "classification"):
        np.testing.assert_array_equal(out[dim], las[dim], err_msg=dim)
    np.testing.assert_array_equal(out.gps_time, las.gps_time)
    np.testing.assert_array_equal(out.reflectance_db, las.reflectance_db)
    ex, ey, ez = _ecef(np.asarray(las.x), np.asarray(las.y), np.asarray(las.z))
    np.testing.assert_allclose(out.x, ex, atol=6e-5)
    np.testing.assert_allclose(out.y, ey, atol=6e-5)
    np.testing.assert_allclose(out.z, ez, atol=6e-5)
    ids = [(v.user_id, v.record_id) for v in out.header.vlrs]
    assert ("kinsync_test", 42) in ids
    assert [(v.user_id, v.record_id) for v in out.header.evlrs] == [("kinsync_test", 7)]
    assert info.vlrs_count == len(out.header.vlrs) + 1


def test_chunked_write_equals_one_shot(tmp_path: Path) -> None:
    src = tmp_path / "big.las"
    _make_las(src, n=100_000, seed=3)
    _transform(src, tmp_path / "chunked.las", pyproj.CRS.from_epsg(4978), chunk=10_000)
    _transform(src, tmp_path / "oneshot.las", pyproj.CRS.from_epsg(4978), chunk=100_000)
    a = (tmp_path / "chunked.las").read_bytes()
    b = (tmp_path / "oneshot.las").read_bytes()
    offset = laspy.open(tmp_path / "chunked.las").header.offset_to_point_data
    # Header and point records identical; laspy leaves the unused min/max fields of the
    # extra-bytes VLR unset, so those bytes are not compared.
    assert len(a) == len(b)
    assert a[:375] == b[:375]
    assert a[offset:] == b[offset:]
    assert las_info(tmp_path / "chunked.las").point_count == 100_000


def test_iter_chunks_sizes(tmp_path: Path) -> None:
    src = tmp_path / "in.laz"
    _make_las(src, n=1000)
    sizes = [len(c) for c in iter_las_chunks(src, 300)]
    assert sizes == [300, 300, 300, 100]


def test_failing_writer_leaves_no_file(tmp_path: Path) -> None:
    src = tmp_path / "in.laz"
    _make_las(src)
    dst = tmp_path / "out.laz"
    template = laspy.open(src).header
    with (  # noqa: PT012
        pytest.raises(RuntimeError, match="boom"),
        LasChunkWriter(dst, template, None, (0.0, 0.0, 0.0), 1e-4) as w,
    ):
        for pts in iter_las_chunks(src, 100):
            w.write(pts, np.asarray(pts.x), np.asarray(pts.y), np.asarray(pts.z))
            raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == [src]


def test_bad_coordinates_and_inputs(tmp_path: Path) -> None:
    src = tmp_path / "in.las"
    _make_las(src, n=10)
    template = laspy.open(src).header
    dst = tmp_path / "out.las"
    pts = next(iter_las_chunks(src, 10))
    x = np.asarray(pts.x) + 6.4e6  # ECEF-sized coordinates with a zero offset
    with (
        pytest.raises(InputError, match="cannot be stored"),
        LasChunkWriter(dst, template, None, (0.0, 0.0, 0.0), 1e-4) as w,
    ):
        w.write(pts, x, np.asarray(pts.y), np.asarray(pts.z))
    assert not dst.exists()
    with pytest.raises(InputError, match="unknown point cloud type"):
        LasChunkWriter(tmp_path / "o.txt", template, None, (0.0, 0.0, 0.0), 1e-4)
    with pytest.raises(InputError, match="scale_m"):
        LasChunkWriter(dst, template, None, (0.0, 0.0, 0.0), 0.0)
    with pytest.raises(InputError, match="not found"):
        las_info(tmp_path / "missing.las")
    (tmp_path / "trunc.las").write_bytes(src.read_bytes()[:200])
    with pytest.raises(InputError, match=r"trunc\.las"):
        list(iter_las_chunks(tmp_path / "trunc.las", 5))


@pytest.mark.parametrize("suffix", [".las", ".laz"])
def test_read_las_points_by_seek_equals_the_sequential_read(tmp_path: Path, suffix: str) -> None:
    path = tmp_path / f"s{suffix}"
    las = _make_las(path, n=130_000)  # LAZ chunks of 50 000 points: seeks inside them
    sequential = list(iter_las_chunks(path, 17_000))
    for k, chunk in enumerate(sequential):
        got = read_las_points(path, 17_000 * k, len(chunk))
        assert got.array.tobytes() == chunk.array.tobytes()
    with LasPointReader(path, laz_threads=False) as reader:  # any order, one open file
        for k in (3, 0, 1, 2, 7, 6):
            got = reader.read(17_000 * k, len(sequential[k]))
            assert got.array.tobytes() == sequential[k].array.tobytes()
    tail = read_las_points(path, 129_990, 10)
    np.testing.assert_array_equal(tail.gps_time, las.gps_time[-10:])
    assert len(read_las_points(path, 5, 0)) == 0


def test_read_las_points_bad_range_and_truncated_file(tmp_path: Path) -> None:
    path = tmp_path / "r.las"
    _make_las(path, n=100)
    with pytest.raises(InputError, match=r"points 95\.\.104 requested, the file holds 100"):
        read_las_points(path, 95, 10)
    with pytest.raises(InputError, match="requested"):
        read_las_points(path, -1, 2)
    cut = tmp_path / "cut.las"
    cut.write_bytes(path.read_bytes()[:-200])  # the last points cut off (EVLRs and some)
    # 3950 bytes: 96 whole points of 34 bytes from byte 680; the message names the missing.
    with pytest.raises(
        InputError,
        match=r"cut\.las: .*points 1\.\.96 are complete, points 97\.\.100 are missing.*truncated",
    ):
        read_las_points(cut, 90, 10)
    with pytest.raises(InputError, match="not found"):
        read_las_points(tmp_path / "missing.laz", 0, 1)


def test_scaled_coordinates_equal_laspy_scaling(tmp_path: Path) -> None:
    las = _make_las(tmp_path / "a.las", n=500)
    stored = laspy.read(tmp_path / "a.las")
    got = scaled_coordinates(stored.points.array, stored.header.scales, stored.header.offsets)
    expected = np.column_stack([np.asarray(stored.x), np.asarray(stored.y), np.asarray(stored.z)])
    np.testing.assert_array_equal(got, expected)
    np.testing.assert_allclose(got[:, 0], np.asarray(las.x), atol=0.5e-4)


def test_store_coordinates_masked_and_first_bad_index(tmp_path: Path) -> None:
    _make_las(tmp_path / "a.las", n=10)
    array = laspy.read(tmp_path / "a.las").points.array.copy()
    before = array.copy()
    xyz = np.column_stack([np.linspace(0.0, 1.0, 10), np.full(10, -2.5), np.full(10, 1e3)])
    mask = np.arange(10) % 2 == 0
    offsets, scales = (0.0, 0.0, 1000.0), (1e-3, 1e-3, 1e-2)
    assert store_coordinates(array, xyz, offsets, scales, mask) == -1
    np.testing.assert_array_equal(array["X"][mask], np.round(xyz[mask, 0] / 1e-3))
    np.testing.assert_array_equal(array["Y"][mask], -2500)
    np.testing.assert_array_equal(array["Z"][mask], 0)
    for name in ("X", "Y", "Z"):  # the others keep their integers
        np.testing.assert_array_equal(array[name][~mask], before[name][~mask])
    xyz[6, 1] = np.nan
    xyz[4, 2] = 1000.0 + 1e-2 * 2.0**31  # beyond int32 at this scale
    assert store_coordinates(array, xyz, offsets, scales) == 4
    assert store_coordinates(array, xyz, offsets, scales, np.arange(10) != 4) == 6


def test_per_axis_scales_and_write_stored(tmp_path: Path) -> None:
    _make_las(tmp_path / "a.laz", n=400)
    with laspy.open(tmp_path / "a.laz") as r:
        template = r.header
    offsets, scales = (-71.0, 46.0, 0.0), (1e-7, 1e-7, 1e-4)
    src = laspy.read(tmp_path / "a.laz")
    lon = -71.2 + 1e-4 * np.asarray(src.x)
    lat = 46.8 + 1e-4 * np.asarray(src.y)
    h = 800.0 + 100.0 * np.asarray(src.z)  # +- 500 m: beyond what 1e-7 would hold
    array = src.points.array.copy()
    assert store_coordinates(array, np.column_stack([lon, lat, h]), offsets, scales) == -1
    out = tmp_path / "b.laz"
    with LasChunkWriter(out, template, pyproj.CRS.from_epsg(4979), offsets, scales) as w:
        w.write_stored(laspy.ScaleAwarePointRecord(array, template.point_format, scales, offsets))
    back = laspy.read(out)
    assert back.header.scales.tolist() == list(scales)
    np.testing.assert_allclose(np.asarray(back.x), lon, atol=0.5e-7)
    np.testing.assert_allclose(np.asarray(back.z), h, atol=0.5e-4)
    np.testing.assert_array_equal(np.asarray(back.intensity), np.asarray(src.intensity))
    with pytest.raises(InputError, match="positive"):
        LasChunkWriter(out, template, None, offsets, (1e-7, 0.0, 1e-4))


@pytest.mark.parametrize("suffix", [".las", ".laz"])
def test_las_end_times(tmp_path: Path, suffix: str) -> None:
    las = _make_las(tmp_path / f"a{suffix}", n=120_000)
    t = np.asarray(las.gps_time)
    assert las_end_times(tmp_path / f"a{suffix}") == (float(t[0]), float(t[-1]))
    header = laspy.LasHeader(point_format=6, version="1.4")
    laspy.LasData(header).write(tmp_path / "empty.las")
    assert las_end_times(tmp_path / "empty.las") is None
    no_time = laspy.LasData(laspy.LasHeader(point_format=1, version="1.2"))
    no_time.x = np.zeros(3)
    no_time.write(tmp_path / "f1.las")
    assert las_end_times(tmp_path / "f1.las") is not None  # format 1 has gps_time
    no_time = laspy.LasData(laspy.LasHeader(point_format=0, version="1.2"))
    no_time.x = np.zeros(3)
    no_time.write(tmp_path / "f0.las")
    with pytest.raises(InputError, match=r"no gps_time; export the points .* with gps_time"):
        las_end_times(tmp_path / "f0.las")
    with pytest.raises(InputError) as err:
        las_time_offset_s(las_info(tmp_path / "f0.las"), "gps", None, needed_by="georeferencing")
    assert str(err.value) == (
        f"{tmp_path / 'f0.las'}: point format 0 has no gps_time; georeferencing needs a time "
        "per point: export the points from the scanner software in a point format with "
        "gps_time (1, 3 or 6-10; LAS 1.4 point format 6 is the usual one), or as a CSV/Parquet "
        "table t_s,x_m,y_m,z_m"
    )


@pytest.mark.parametrize("suffix", [".las", ".laz"])
def test_a_header_laspy_cannot_write_leaves_no_output(tmp_path: Path, suffix: str) -> None:
    """A damaged template fails in the writer's header: nothing appears, no temporary.

    A non-ASCII byte in the system identifier reads back but cannot be written. The
    writer used to close its file on this error as on success, so the unfinished file
    was renamed onto the output.
    """
    src = tmp_path / "src.las"
    _make_las(src, n=50)
    data = bytearray(src.read_bytes())
    data[26] = 0x80  # system identifier, bytes 26..57
    src.write_bytes(bytes(data))
    template = las_header(src)
    out = tmp_path / f"out{suffix}"
    with (
        pytest.raises(InputError, match="cannot write the header and VLRs taken from the input"),
        LasChunkWriter(out, template, None, (0.0, 0.0, 0.0), 1e-4),
    ):
        pass
    assert sorted(p.name for p in tmp_path.iterdir()) == ["src.las"]


def test_a_las_file_takes_a_gps_week_when_its_header_says_seconds_of_week(
    tmp_path: Path,
) -> None:
    adjusted = tmp_path / "adjusted.las"
    _make_las(adjusted, n=10)  # adjusted standard GPS time
    assert not las_takes_gps_week(adjusted)
    week = tmp_path / "week.las"
    las = laspy.read(adjusted)
    las.header.global_encoding.gps_time_type = laspy.header.GpsTimeType.WEEK_TIME
    las.write(week)
    assert las_takes_gps_week(week)
    broken = tmp_path / "broken.las"
    broken.write_bytes(b"LASF" + b"\0" * 20)
    assert las_takes_gps_week(broken)  # its reader says what is wrong


@pytest.mark.parametrize(
    ("at", "value", "words"),
    [
        # Was "cannot read the LAS/LAZ header (error: unpack requires a buffer of 8 bytes)".
        (25, 9, "LAS version 1.9 is not supported (1.0 to 1.4)"),
        # Was "PointFormatNotSupported: 35": the byte less the LAZ compression bits.
        (104, 99, "point data format 99 (header byte 104) is not a LAS point format"),
    ],
)
def test_an_unknown_version_or_point_format_is_named_as_written(
    tmp_path: Path, at: int, value: int, words: str
) -> None:
    path = tmp_path / "s.las"
    _make_las(path, n=10)
    data = bytearray(path.read_bytes())
    data[at] = value
    path.write_bytes(bytes(data))
    with pytest.raises(InputError, match=rf"^{path}: {re.escape(words)}"):
        las_info(path)
