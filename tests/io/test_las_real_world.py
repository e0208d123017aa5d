"""Real-world LAS/LAZ files (laspy's own test data) through the reader and ``kinsync georef``.

COPC (variable-size LAZ chunks in octree order), LAS 1.3 with internal waveform data,
LAZ 1.4 with external waveform data; and truncated or corrupt files, which must be a
one-line error (exit 2) naming the file and the points concerned.
"""

from __future__ import annotations

import json
import re
import struct
from contextlib import redirect_stderr, redirect_stdout
from io import StringIO
from pathlib import Path

import laspy
import lazrs
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from laspy.vlrs.vlrlist import VLRList

from kinsync.cli import main
from kinsync.errors import InputError
from kinsync.georef import GeorefTrajectory, georeference
from kinsync.io.las import (
    LasPointReader,
    iter_las_chunks,
    las_end_times,
    las_info,
    read_las_points,
)
from kinsync.io.mount_file import write_mount
from kinsync.io.trajectory_csv import read_trajectory_csv, write_trajectory_csv
from kinsync.mount import Mount
from kinsync.pipelines.georef import GeorefSummary, georeference_file
from kinsync.trajectory import Trajectory

DATA = Path(__file__).resolve().parent.parent / "data" / "las"
COPC = DATA / "simple.copc.laz"
LAS13_WAVEFORM = DATA / "simple1_3.las"
FULLWAVE = DATA / "fullwave.laz"
GPS_WEEK = 2000  # the files carry GPS seconds of week
WEEK_S = 604_800.0
MOUNT = Mount(lever_arm_body_m=(0.5, 0.1, -1.0), boresight_rpy_deg=(0.5, -0.3, 90.0))
_LAS_OFFSETS_AT = 155  # byte of the x, y, z offsets (3 doubles) in every LAS header


def _reference_points(path: Path) -> laspy.LasData:
    """All points as laspy reads them in one sequential pass (no seek: right for COPC)."""
    return laspy.read(path, laz_backend=laspy.LazBackend.Lazrs)


def _recentred(src: Path, folder: Path) -> Path:
    """A copy whose header offsets put the points within ~300 m of the scanner.

    Only the 24 offset bytes of the header change: the stored integers, VLRs,
    compressed chunks and waveform records stay byte for byte.
    """
    las = _reference_points(src)
    data = bytearray(src.read_bytes())
    offsets = np.array(struct.unpack_from("<3d", data, _LAS_OFFSETS_AT))
    centre = np.array([np.mean(las.x), np.mean(las.y), np.mean(las.z)]).round()
    struct.pack_into("<3d", data, _LAS_OFFSETS_AT, *(offsets - centre))
    dst = folder / src.name
    dst.write_bytes(bytes(data))
    return dst


def _setup(folder: Path, points: Path) -> dict[str, Path]:
    """Trajectory (GPS time, covering the points' times + 2 s) and mount files."""
    t_week = np.asarray(_reference_points(points).gps_time)
    t = GPS_WEEK * WEEK_S + np.arange(t_week.min() - 2.0, t_week.max() + 2.5, 0.5)
    s = t - t[0]
    llh = np.column_stack([46.8 + 1e-6 * s, -71.2 + 1e-6 * s, 10.0 + 0.01 * s])
    zero = np.zeros_like(s)
    traj = Trajectory.from_euler(t, 0.01 * np.sin(s), zero, 0.3 + zero, lat_lon_h=llh)
    write_trajectory_csv(traj, folder / "traj.csv")
    write_mount(MOUNT, folder / "mount.toml")
    return {"traj": folder / "traj.csv", "mount": folder / "mount.toml"}


def _run(argv: list[str]) -> tuple[int, str, str]:
    out, err = StringIO(), StringIO()
    with redirect_stdout(out), redirect_stderr(err), pytest.raises(SystemExit) as exc:
        main(argv)
    code = exc.value.code
    return (code if isinstance(code, int) else 0), out.getvalue(), err.getvalue()


def _georef(
    points: Path, files: dict[str, Path], out: Path, *extra: str, as_json: bool = True
) -> tuple[int, str, str]:
    return _run(
        [
            "georef",
            "--points",
            str(points),
            "--trajectory",
            str(files["traj"]),
            "--mount",
            str(files["mount"]),
            "--out",
            str(out),
            "--gps-week",
            str(GPS_WEEK),
            *(["--json"] if as_json else []),
            *extra,
        ]
    )


def _georef_file(
    points: Path, files: dict[str, Path], out: Path, chunk_points: int = 1_000_000
) -> GeorefSummary:
    return georeference_file(
        points,
        files["traj"],
        MOUNT,
        out,
        chunk_points=chunk_points,
        gps_week=GPS_WEEK,
    )


def _expected_ecef(points: Path, files: dict[str, Path]) -> np.ndarray:
    las = _reference_points(points)
    gt = GeorefTrajectory.from_trajectory(read_trajectory_csv(files["traj"]), MOUNT.latency_s)
    t = np.asarray(las.gps_time) + GPS_WEEK * WEEK_S
    xyz = np.column_stack([np.asarray(las.x), np.asarray(las.y), np.asarray(las.z)])
    ecef, inside = georeference(t, xyz, gt, MOUNT)
    assert inside.all()
    return ecef


def _assert_one_line_error(code: int, out: str, err: str, *fragments: str) -> None:
    assert code == 2, err
    assert out == ""
    assert err.count("\n") == 1, err
    assert err.startswith("kinsync: error: ")
    for fragment in fragments:
        assert fragment in err, err


def _laz_chunk_table(path: Path) -> list[tuple[int, int]]:
    with laspy.open(path) as reader:
        header = reader.header
    vlr = lazrs.LazVlr(header.vlrs[header.vlrs.index("LasZipVlr")].record_data)
    with path.open("rb") as fh:
        fh.seek(header.offset_to_point_data)
        return [(int(p), int(b)) for p, b in lazrs.read_chunk_table(fh, vlr)]


# ------------------------------------------------------------------------------- COPC
def test_copc_chunk_table_has_variable_size_chunks() -> None:
    table = _laz_chunk_table(COPC)
    assert len(table) == 65
    assert len({p for p, _ in table}) > 1  # chunks of different point counts


@pytest.mark.parametrize("laz_threads", [True, False])
def test_copc_runs_read_by_position_equal_the_sequential_read(laz_threads: bool) -> None:
    expected = _reference_points(COPC).points.array
    n = len(expected)
    firsts = np.cumsum([0] + [p for p, _ in _laz_chunk_table(COPC)])
    # Runs that start and end inside chunks, on chunk boundaries, span many chunks,
    # go backwards, and the file's last point (lazrs's own seek gets these wrong).
    runs = [(17, 1), (16, 2), (500, 1), (n - 1, 1), (0, n), (31, 300), (int(firsts[10]), 17)]
    runs += [(int(f) - 1, 3) for f in firsts[1:-1:7]]
    with LasPointReader(COPC, laz_threads=laz_threads) as reader:
        for start, count in [*runs, *runs[::-1]]:
            got = reader.read(start, count).array
            np.testing.assert_array_equal(got, expected[start : start + count], f"{start}+{count}")
    assert np.array_equal(read_las_points(COPC, 777, 5).array, expected[777:782])


@pytest.mark.parametrize("chunk_points", [1, 100, 1065, 5000])
def test_copc_streams_every_point_in_stored_order(chunk_points: int) -> None:
    expected = _reference_points(COPC).points.array
    chunks = list(iter_las_chunks(COPC, chunk_points))
    assert [len(c) for c in chunks[:-1]] == [chunk_points] * (len(chunks) - 1)
    np.testing.assert_array_equal(np.concatenate([c.array for c in chunks]), expected)


def test_copc_end_times_are_the_first_and_last_stored_points() -> None:
    t = np.asarray(_reference_points(COPC).gps_time)
    assert las_end_times(COPC) == (float(t[0]), float(t[-1]))


@pytest.mark.parametrize("chunk_points", [100, 1_000_000])
def test_copc_georeferences_every_point_and_says_the_index_is_dropped(
    tmp_path: Path, chunk_points: int
) -> None:
    points = _recentred(COPC, tmp_path)
    files = _setup(tmp_path, points)
    out = tmp_path / "geo.laz"
    summary = _georef_file(points, files, out, chunk_points)
    assert summary.points_in == summary.points_out == 1065
    [warning] = summary.warnings
    assert warning.startswith(f"{points}: ")
    assert "COPC index is not carried" in warning
    src, geo = _reference_points(points), _reference_points(out)
    np.testing.assert_array_equal(geo.gps_time, src.gps_time)  # same points, same order
    np.testing.assert_array_equal(geo.intensity, src.intensity)
    ecef = np.column_stack([np.asarray(geo.x), np.asarray(geo.y), np.asarray(geo.z)])
    np.testing.assert_allclose(ecef, _expected_ecef(points, files), rtol=0.0, atol=6e-5)
    ids = [v.user_id for v in geo.header.vlrs] + [v.user_id for v in geo.header.evlrs or []]
    assert "copc" not in ids  # the output does not claim an octree it does not have
    with pytest.raises(Exception, match=r"(?i)copc"):
        laspy.CopcReader.open(out)


# --------------------------------------------------------------------------- waveform
def _assert_waveform_dropped(src: Path, out: Path) -> None:
    a, b = _reference_points(src), _reference_points(out)
    header = b.header
    assert header.start_of_waveform_data_packet_record == 0
    assert not header.global_encoding.waveform_data_packets_internal
    assert not header.global_encoding.waveform_data_packets_external
    records = list(header.vlrs) + list(header.evlrs or [])
    assert not [
        v
        for v in records
        if v.user_id == "LASF_Spec" and (100 <= v.record_id <= 354 or v.record_id == 65535)
    ]
    for name in ("wavepacket_index", "wavepacket_offset", "wavepacket_size", "x_t", "y_t", "z_t"):
        assert not np.any(np.asarray(b[name])), name
    assert not np.any(np.asarray(b.return_point_wave_location))
    for name in ("gps_time", "intensity", "return_number", "classification", "point_source_id"):
        np.testing.assert_array_equal(b[name], a[name], name)


def test_las13_internal_waveform_is_dropped_with_its_pointer_and_said(tmp_path: Path) -> None:
    points = _recentred(LAS13_WAVEFORM, tmp_path)
    with laspy.open(points) as reader:
        header = reader.header
        assert header.global_encoding.waveform_data_packets_internal
        assert 0 < header.start_of_waveform_data_packet_record < points.stat().st_size
    files = _setup(tmp_path, points)
    out = tmp_path / "geo.las"
    summary = _georef_file(points, files, out)
    assert summary.points_in == summary.points_out == 999
    [warning] = summary.warnings
    assert warning.startswith(f"{points}: ")
    assert "waveform data packets (internal, from byte 62728) are not carried" in warning
    _assert_waveform_dropped(points, out)
    with laspy.open(out) as reader:
        geo = reader.header
        # Nothing after the points: no dangling waveform record, no pointer into the points.
        assert out.stat().st_size == geo.offset_to_point_data + 999 * geo.point_format.size
    geo_points = _reference_points(out)
    ecef = np.column_stack([np.asarray(geo_points.x), geo_points.y, geo_points.z])
    np.testing.assert_allclose(ecef, _expected_ecef(points, files), rtol=0.0, atol=6e-5)


def test_external_waveform_laz_is_dropped_and_said(tmp_path: Path) -> None:
    points = _recentred(FULLWAVE, tmp_path)
    files = _setup(tmp_path, points)
    out = tmp_path / "geo.laz"
    summary = _georef_file(points, files, out, chunk_points=4000)
    assert summary.points_in == summary.points_out == 10750
    [warning] = summary.warnings
    assert "waveform data packets (in an external .wdp file) are not carried" in warning
    _assert_waveform_dropped(points, out)


def test_las14_internal_waveform_evlr_is_dropped(tmp_path: Path) -> None:
    n = 50
    header = laspy.LasHeader(point_format=9, version="1.4")
    header.scales = np.full(3, 1e-3)
    header.vlrs.append(laspy.VLR("LASF_Spec", 100, record_data=bytes(26)))  # descriptor 1
    las = laspy.LasData(header)
    las.x = np.linspace(-5, 5, n)
    las.y = np.linspace(1, 20, n)
    las.z = np.zeros(n)
    las.gps_time = np.linspace(1000.0, 1001.0, n)
    las.wavepacket_index = np.ones(n, np.uint8)
    las.wavepacket_size = np.full(n, 4, np.uint32)
    las.x_t = np.full(n, 1e-4, np.float32)
    las.evlrs = VLRList([laspy.VLR("LASF_Spec", 65535, record_data=bytes(range(200)))])
    points = tmp_path / "wave14.las"
    las.write(points)
    with laspy.open(points) as reader:
        first_evlr = reader.header.start_of_first_evlr
    with points.open("r+b") as fh:  # internal waveform: encoding bit 1 and the pointer
        fh.seek(6)
        fh.write((2 | int.from_bytes(points.read_bytes()[6:8], "little")).to_bytes(2, "little"))
        fh.seek(227)
        fh.write(struct.pack("<Q", first_evlr))
    files = _setup(tmp_path, points)
    out = tmp_path / "geo.las"
    [warning] = _georef_file(points, files, out).warnings
    assert f"internal, from byte {first_evlr}" in warning
    _assert_waveform_dropped(points, out)


def test_the_command_says_what_the_output_does_not_carry(tmp_path: Path) -> None:
    """``--json`` lists the notes under "warnings"; the table run says them on stderr."""
    points = _recentred(LAS13_WAVEFORM, tmp_path)
    files = _setup(tmp_path, points)
    code, stdout, err = _georef(points, files, tmp_path / "geo.las")
    assert code == 0, err
    doc = json.loads(stdout)
    assert doc["points_out"] == 999
    assert any("waveform data packets" in w and str(points) in w for w in doc["warnings"]), doc
    code, stdout, err = _georef(points, files, tmp_path / "geo2.las", as_json=False)
    assert code == 0, err
    assert "warning" in err
    assert "waveform data packets" in err


# ----------------------------------------------------------- truncated or corrupt files
def _small_las(path: Path, n: int = 100) -> None:
    header = laspy.LasHeader(point_format=1, version="1.2")
    header.scales = np.full(3, 1e-3)
    las = laspy.LasData(header)
    rng = np.random.default_rng(1)
    las.x = rng.uniform(-10, 10, n)
    las.y = rng.uniform(1, 30, n)
    las.z = rng.uniform(-2, 2, n)
    las.gps_time = np.sort(rng.uniform(100.0, 110.0, n))
    las.write(path)


@pytest.mark.parametrize(("cut", "complete"), [(1, 99), (28, 99), (29, 98), (28 * 40 + 5, 59)])
def test_truncated_las_names_exactly_the_missing_points(
    tmp_path: Path, cut: int, complete: int
) -> None:
    whole = tmp_path / "whole.las"
    _small_las(whole)  # 100 points of 28 bytes
    points = tmp_path / "cut.las"
    points.write_bytes(whole.read_bytes()[:-cut])
    files = _setup(tmp_path, whole)
    out = tmp_path / "geo.las"
    code, stdout, err = _georef(points, files, out, "--chunk-points", "30")
    # Counted from 1, as every message naming LAS points ("point 101 of 54191").
    missing = (
        "point 100 is missing" if complete == 99 else f"points {complete + 1}..100 are missing"
    )
    _assert_one_line_error(
        code,
        stdout,
        err,
        str(points),
        f"points 1..{complete} are complete, {missing}",
        "truncated",
    )
    assert not out.exists()
    with pytest.raises(InputError, match=re.escape(missing)):
        read_las_points(points, 0, 1)


def test_truncated_laz_is_a_one_line_error(tmp_path: Path) -> None:
    whole = tmp_path / "whole.laz"
    _small_las(whole, n=2000)
    files = _setup(tmp_path, whole)
    for keep in (0.5, 0.99):
        points = tmp_path / "cut.laz"
        data = whole.read_bytes()
        points.write_bytes(data[: int(len(data) * keep)])
        code, stdout, err = _georef(points, files, tmp_path / "geo.laz")
        _assert_one_line_error(code, stdout, err, str(points), "LAZ chunk table", "truncated")


def test_corrupt_laz_chunk_names_its_points(tmp_path: Path) -> None:
    """A damaged COPC chunk: the error names its points, its chunk and its bytes."""
    table = _laz_chunk_table(COPC)
    with laspy.open(COPC) as reader:
        data_start = reader.header.offset_to_point_data + 8
    k = 10
    first_point = sum(p for p, _ in table[:k])
    first_byte = data_start + sum(b for _, b in table[:k])
    data = bytearray(_recentred(COPC, tmp_path).read_bytes())
    data[first_byte : first_byte + table[k][1]] = bytes(table[k][1])
    points = tmp_path / "bad.copc.laz"
    points.write_bytes(bytes(data))
    files = _setup(tmp_path, COPC)
    last = first_point + table[k][0] - 1
    # counted from 1, as every message counts LAS points (and the chunks)
    expected = f"points {first_point + 1}..{last + 1} (LAZ chunk {k + 1}, bytes {first_byte}.."
    for extra in ([], ["--chunk-points", "100"]):
        code, stdout, err = _georef(points, files, tmp_path / "geo.laz", *extra)
        _assert_one_line_error(code, stdout, err, str(points), expected, "corrupt")
    for threads in (True, False):
        with LasPointReader(points, laz_threads=threads) as reader:
            reader.read(0, first_point)  # the chunks before are fine
            with pytest.raises(InputError, match=rf"points {first_point + 1}\.\.{last + 1} "):
                reader.read(first_point - 5, 10)


def test_laz_header_claiming_more_points_than_its_chunks(tmp_path: Path) -> None:
    """COPC lists every chunk's points: the missing ones are named."""
    data = bytearray(_recentred(COPC, tmp_path).read_bytes())
    struct.pack_into("<Q", data, 247, 1100)  # LAS 1.4 point count (1065 in the chunks)
    points = tmp_path / "more.copc.laz"
    points.write_bytes(bytes(data))
    files = _setup(tmp_path, COPC)
    code, stdout, err = _georef(points, files, tmp_path / "geo.laz")
    _assert_one_line_error(
        code,
        stdout,
        err,
        str(points),
        "the header says 1100 points, the LAZ chunk table holds 1065 (points 1066..1100 are "
        "missing)",
    )


def test_laz_fixed_size_chunk_shorter_than_the_header_says(tmp_path: Path) -> None:
    """Fixed-size chunks do not list their points: the chunk that falls short is named."""
    whole = tmp_path / "whole.laz"
    _small_las(whole, n=500)
    data = bytearray(whole.read_bytes())
    struct.pack_into("<I", data, 107, 800)  # legacy point count (LAS 1.2)
    points = tmp_path / "more.laz"
    points.write_bytes(bytes(data))
    files = _setup(tmp_path, whole)
    code, stdout, err = _georef(points, files, tmp_path / "geo.laz")
    _assert_one_line_error(
        code, stdout, err, str(points), "points 1..800 (LAZ chunk 1, bytes", "corrupt"
    )


def _fixed_chunk_laz14(path: Path, n: int = 3000) -> None:
    """A LAS 1.4 LAZ with fixed-size chunks (laspy writes 50,000-point chunks)."""
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales = np.full(3, 1e-3)
    las = laspy.LasData(header)
    rng = np.random.default_rng(2)
    las.x = rng.uniform(-10, 10, n)
    las.y = rng.uniform(1, 30, n)
    las.z = rng.uniform(-2, 2, n)
    las.gps_time = np.sort(rng.uniform(100.0, 110.0, n))  # seconds of week
    las.write(path, laz_backend=laspy.LazBackend.Lazrs)


@pytest.mark.parametrize("count", [2**32 - 1, 2**63, 2**64 - 1])
@pytest.mark.parametrize("chunks", ["variable (COPC)", "fixed"])
def test_laz_header_with_an_absurd_point_count_is_refused_when_read(
    tmp_path: Path, count: int, chunks: str
) -> None:
    """The header is checked against the chunk table as soon as it is read.

    A count of 2**64 - 1 made georef plan work for every point the header claimed (and
    hang) before any chunk was read; with fixed-size chunks it overflowed int64.
    """
    if chunks == "fixed":
        source = tmp_path / "fixed.laz"
        _fixed_chunk_laz14(source)
    else:
        source = _recentred(COPC, tmp_path)
    data = bytearray(source.read_bytes())
    struct.pack_into("<Q", data, 247, count)  # LAS 1.4 point count
    points = tmp_path / "absurd.laz"
    points.write_bytes(bytes(data))
    with pytest.raises(InputError, match=f"the header says {count} points"):
        las_info(points)
    files = _setup(tmp_path, source)
    code, stdout, err = _georef(points, files, tmp_path / "geo.laz")
    _assert_one_line_error(code, stdout, err, str(points), f"the header says {count} points")


@pytest.fixture(scope="module")
def two_chunk_laz(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, np.ndarray]:
    """A LAZ of 120,000 points in fixed-size chunks (laspy: 50,000), and its points."""
    path = tmp_path_factory.mktemp("laz") / "fixed.laz"
    _fixed_chunk_laz14(path, n=120_000)
    return path, _reference_points(path).points.array


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    runs=st.lists(
        st.tuples(st.integers(0, 119_999), st.integers(0, 70_000)), min_size=1, max_size=8
    ),
    sequential=st.booleans(),
    laz_threads=st.booleans(),
)
def test_any_runs_read_by_one_reader_equal_laspys_read(
    two_chunk_laz: tuple[Path, np.ndarray],
    runs: list[tuple[int, int]],
    sequential: bool,
    laz_threads: bool,
) -> None:
    """Runs in any order and of any length, or in file order (the pipeline's case, which
    starts each run in the chunk the previous one left part of), give laspy's points."""
    path, expected = two_chunk_laz
    n = len(expected)
    s = runs[0][0]
    with LasPointReader(path, laz_threads=laz_threads) as reader:
        for start, count in runs:
            s = s if sequential else start  # sequential: each run starts where one ended
            c = min(count, n - s)
            got = reader.read(s, c).array
            np.testing.assert_array_equal(got, expected[s : s + c], f"{s}+{c}")
            s += c
