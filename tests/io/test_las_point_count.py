"""A LAS/LAZ header's point count, scales and offsets, checked against the file.

Nothing is lost: a LAS 1.4 header that fills only the legacy 32-bit point count is
read whole (laspy reads the 64-bit count, 0: no point), a count below the points the
file holds is refused (it silently dropped the rest), and so are scale factors of 0,
NaN or inf and non-finite offsets (a Y scale of 0 put every point at Y = offset).
"""

from __future__ import annotations

import json
import struct
from pathlib import Path

import laspy
import numpy as np
import pytest
from laspy.vlrs.vlrlist import VLRList

from kinsync.errors import InputError
from kinsync.io.las import LasPointReader, las_info, read_las_points

from .test_las_real_world import _assert_one_line_error, _georef, _setup

_LEGACY_COUNT_AT = 107  # uint32, every LAS version
_COUNT_AT = 247  # uint64, LAS 1.4
_SCALES_AT = 131  # 3 doubles, then the 3 offsets
_OFFSETS_AT = 155
N = 3000


def _write(path: Path, point_format: int, version: str, n: int = N, evlr: bool = False) -> None:
    header = laspy.LasHeader(point_format=point_format, version=version)
    header.scales = np.full(3, 1e-3)
    las = laspy.LasData(header)
    rng = np.random.default_rng(point_format + n)
    las.x = rng.uniform(-10, 10, n)
    las.y = rng.uniform(1, 30, n)
    las.z = rng.uniform(-2, 2, n)
    las.intensity = rng.integers(0, 65535, n).astype(np.uint16)
    las.gps_time = np.sort(rng.uniform(100.0, 110.0, n))  # seconds of week
    if evlr:
        las.evlrs = VLRList([laspy.VLR(user_id="kinsync_test", record_id=7, record_data=b"e" * 90)])
    las.write(path, laz_backend=laspy.LazBackend.Lazrs if path.suffix == ".laz" else None)


def _patched(src: Path, dst: Path, fmt: str, at: int, value: float) -> Path:
    data = bytearray(src.read_bytes())
    struct.pack_into(fmt, data, at, value)
    dst.write_bytes(bytes(data))
    return dst


def _legacy_only(src: Path, dst: Path) -> Path:
    """The LAS 1.4 file with its count in the legacy field only (64-bit count 0)."""
    data = bytearray(src.read_bytes())
    n = struct.unpack_from("<Q", data, _COUNT_AT)[0]
    struct.pack_into("<I", data, _LEGACY_COUNT_AT, n)
    struct.pack_into("<Q", data, _COUNT_AT, 0)
    dst.write_bytes(bytes(data))
    return dst


# Point format 1 is LAZ "pointwise" (no count in a chunk), 6 "layered" (a count per chunk).
@pytest.mark.parametrize("point_format", [1, 6])
@pytest.mark.parametrize("suffix", [".las", ".laz"])
def test_a_las14_header_with_only_the_legacy_count_reads_every_point(
    tmp_path: Path, suffix: str, point_format: int
) -> None:
    original = tmp_path / f"original{suffix}"
    _write(original, point_format, "1.4")
    expected = laspy.read(original, laz_backend=laspy.LazBackend.Lazrs).points.array
    points = _legacy_only(original, tmp_path / f"legacy{suffix}")
    assert las_info(points).point_count == N
    np.testing.assert_array_equal(read_las_points(points, 0, N).array, expected)
    with LasPointReader(points, laz_threads=False) as reader:
        assert reader.point_count == N
        np.testing.assert_array_equal(reader.read(N - 7, 7).array, expected[-7:])


def _count_field(version: str) -> tuple[str, int]:
    return ("<Q", _COUNT_AT) if version == "1.4" else ("<I", _LEGACY_COUNT_AT)


@pytest.mark.parametrize("count", [N - 10, N - 1, 0])
@pytest.mark.parametrize(
    ("suffix", "point_format", "version", "held"),
    [
        (".las", 1, "1.2", f"holds {N} points of 28 bytes: "),
        (".las", 6, "1.4", f"holds {N} points of 30 bytes: "),
        (".laz", 1, "1.2", "LAZ chunk"),  # pointwise: the last chunk's bytes tell
        (".laz", 6, "1.4", f"the LAZ chunks hold {N}"),  # layered: the chunk's count
    ],
)
def test_a_count_below_the_stored_points_is_refused(
    tmp_path: Path, suffix: str, point_format: int, version: str, held: str, count: int
) -> None:
    original = tmp_path / f"original{suffix}"
    _write(original, point_format, version)
    fmt, at = _count_field(version)
    points = _patched(original, tmp_path / f"short{suffix}", fmt, at, count)
    for read in (las_info, lambda p: read_las_points(p, 0, 1)):
        with pytest.raises(InputError) as err:
            read(points)
        message = str(err.value)
        assert message.startswith(f"{points}: the header says {count} points"), message
        assert held in message, message
        assert "would be left out" in message, message
        assert "byte 107" in message, message  # which field to fix


def test_a_las_count_is_checked_up_to_the_extended_vlrs(tmp_path: Path) -> None:
    """The EVLRs after the points are no points: the whole file reads, a short count not."""
    original = tmp_path / "original.las"
    _write(original, 6, "1.4", evlr=True)
    assert las_info(original).point_count == N
    points = _patched(original, tmp_path / "short.las", "<Q", _COUNT_AT, N - 3)
    with pytest.raises(InputError) as err:
        las_info(points)
    assert f"up to extended VLRs) holds {N} points of 30 bytes: 3 would be left out" in str(
        err.value
    )


def test_a_laz_count_that_leaves_a_whole_chunk_out_is_refused(tmp_path: Path) -> None:
    """Fixed-size chunks (laspy: 50,000 points): a count that ends before the last chunk."""
    original = tmp_path / "original.laz"
    _write(original, 1, "1.2", n=60_000)
    points = _patched(original, tmp_path / "short.laz", "<I", _LEGACY_COUNT_AT, 50_000)
    with pytest.raises(InputError, match="the LAZ chunk table lists 2 chunks of 50000 points"):
        las_info(points)


@pytest.mark.parametrize("n", [2, 3, 17, 50_002])
@pytest.mark.parametrize("point_format", [0, 3])
def test_a_pointwise_laz_with_the_right_count_is_read_whole(
    tmp_path: Path, point_format: int, n: int
) -> None:
    """The last chunk's bytes are all needed for its last point: no false refusal."""
    points = tmp_path / "points.laz"
    header = laspy.LasHeader(point_format=point_format, version="1.2")
    las = laspy.LasData(header)
    rng = np.random.default_rng(n)
    las.x, las.y, las.z = (rng.normal(0, 100, n) for _ in range(3))
    las.intensity = rng.integers(0, 65535, n).astype(np.uint16)
    las.write(points, laz_backend=laspy.LazBackend.Lazrs)
    expected = laspy.read(points, laz_backend=laspy.LazBackend.Lazrs).points.array
    np.testing.assert_array_equal(read_las_points(points, 0, n).array, expected)


def test_an_empty_laz_is_still_read_as_empty(tmp_path: Path) -> None:
    for point_format, version in ((1, "1.2"), (6, "1.4")):
        points = tmp_path / f"empty{point_format}.laz"
        _write(points, point_format, version, n=0)
        assert las_info(points).point_count == 0
        assert len(read_las_points(points, 0, 0)) == 0


@pytest.mark.parametrize("value", [0.0, -0.0, float("nan"), float("inf"), -float("inf")])
@pytest.mark.parametrize("axis", [0, 1, 2])
@pytest.mark.parametrize("suffix", [".las", ".laz"])
def test_a_zero_or_non_finite_scale_factor_is_refused(
    tmp_path: Path, suffix: str, axis: int, value: float
) -> None:
    original = tmp_path / f"original{suffix}"
    _write(original, 6, "1.4", n=100)
    points = _patched(original, tmp_path / f"scale{suffix}", "<d", _SCALES_AT + 8 * axis, value)
    name = "XYZ"[axis]
    for read in (las_info, LasPointReader):
        with pytest.raises(InputError) as err:
            read(points)
        message = str(err.value)
        assert message.startswith(f"{points}: the header's {name} scale factor"), message
        assert f"(byte {_SCALES_AT + 8 * axis}) is {value!r}" in message, message


@pytest.mark.parametrize("value", [float("nan"), float("inf"), -float("inf")])
@pytest.mark.parametrize("axis", [0, 1, 2])
def test_a_non_finite_offset_is_refused(tmp_path: Path, axis: int, value: float) -> None:
    original = tmp_path / "original.las"
    _write(original, 6, "1.4", n=100)
    points = _patched(original, tmp_path / "offset.las", "<d", _OFFSETS_AT + 8 * axis, value)
    with pytest.raises(InputError, match=f"the header's {'XYZ'[axis]} offset"):
        las_info(points)


def test_a_negative_scale_factor_is_read_as_stored(tmp_path: Path) -> None:
    """Legal and exact (integer x scale + offset): kinsync reads it, it does not refuse it."""
    original = tmp_path / "original.las"
    _write(original, 6, "1.4", n=100)
    points = _patched(original, tmp_path / "mirrored.las", "<d", _SCALES_AT, -1e-3)
    expected = laspy.read(original)
    got = read_las_points(points, 0, 100)
    np.testing.assert_array_equal(np.asarray(got.x), -np.asarray(expected.x))
    np.testing.assert_array_equal(np.asarray(got.y), np.asarray(expected.y))


def test_georef_reads_a_legacy_count_and_refuses_a_broken_header(tmp_path: Path) -> None:
    """Through the command: every point georeferenced, or one line, exit 2, no output."""
    original = tmp_path / "original.laz"
    _write(original, 6, "1.4")
    files = _setup(tmp_path, original)
    out = tmp_path / "geo.csv"
    code, stdout, err = _georef(_legacy_only(original, tmp_path / "legacy.laz"), files, out)
    assert code == 0, err
    summary = json.loads(stdout)
    assert (summary["points_in"], summary["points_out"]) == (N, N)
    las = tmp_path / "original.las"
    _write(las, 6, "1.4")
    broken = {
        "short.las": ("<Q", _COUNT_AT, N - 10, f"the header says {N - 10} points"),
        "short.laz": ("<Q", _COUNT_AT, 0, "the header says 0 points"),
        "yscale0.las": ("<d", _SCALES_AT + 8, 0.0, "the header's Y scale factor (byte 139)"),
        "znan.las": ("<d", _SCALES_AT + 16, float("nan"), "the header's Z scale factor"),
        "xoff.las": ("<d", _OFFSETS_AT, float("inf"), "the header's X offset (byte 155)"),
    }
    for name, (fmt, at, value, fragment) in broken.items():
        src = original if name.endswith(".laz") else las
        points = _patched(src, tmp_path / name, fmt, at, value)
        out = tmp_path / f"geo-{name}.csv"
        code, stdout, err = _georef(points, files, out)
        _assert_one_line_error(code, stdout, err, f"{points}: {fragment}")
        assert not out.exists()
