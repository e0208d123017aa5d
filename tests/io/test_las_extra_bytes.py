"""Extra Bytes descriptors of written LAS/LAZ: min and max are those of the points written.

The descriptors are read back from the file's bytes (ASPRS LAS 1.4 R15: VLR LASF_Spec 4,
192 bytes per dimension; options at byte 3, name at 4, min at 64, max at 88), not
through laspy, whose own min/max tracking was the fault.
"""

from __future__ import annotations

import struct
from pathlib import Path
from typing import Any

import laspy
import numpy as np
import pytest

from kinsync.io.las_writer import LasChunkWriter

_MIN_MAX = 0b110  # options bits 1 and 2


def _descriptors(path: Path) -> dict[str, tuple[int, bytes, bytes]]:
    """``{name: (options, min field, max field)}`` of the file's Extra Bytes VLR."""
    data = path.read_bytes()
    header_size = struct.unpack_from("<H", data, 94)[0]
    n_vlrs = struct.unpack_from("<I", data, 100)[0]
    at = header_size
    for _ in range(n_vlrs):
        user_id = data[at + 2 : at + 18].rstrip(b"\0")
        record_id, length = struct.unpack_from("<HH", data, at + 18)
        body = data[at + 54 : at + 54 + length]
        if user_id == b"LASF_Spec" and record_id == 4:
            out = {}
            for k in range(0, length, 192):
                d = body[k : k + 192]
                name = d[4:36].rstrip(b"\0").decode()
                out[name] = (d[3], d[64:88], d[88:112])
            return out
        at += 54 + length
    raise AssertionError(f"{path}: no Extra Bytes VLR")


def _template() -> laspy.LasHeader:
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.add_extra_dims(
        [
            laspy.ExtraBytesParams("amplitude", "f8"),
            laspy.ExtraBytesParams("count", "i4"),
            laspy.ExtraBytesParams("band", "u2"),
            laspy.ExtraBytesParams("normal", "3f4"),
            laspy.ExtraBytesParams("depth", "i2", no_data=[-1], scales=[0.01], offsets=[0.0]),
            laspy.ExtraBytesParams("gap", "f4"),
        ]
    )
    return header


def _chunks(n: int, rng: np.random.Generator) -> list[Any]:
    """Two chunks whose extremes are neither point 1 of the file nor of a chunk."""
    pf = _template().point_format
    chunks = []
    for k in range(2):
        array = np.zeros(n, dtype=pf.dtype())
        array["amplitude"] = rng.uniform(0.3, 0.4, n)
        array["count"] = rng.integers(-5, 5, n)
        array["band"] = rng.integers(10, 20, n)
        array["normal"] = rng.uniform(-0.5, 0.5, (n, 3))
        array["depth"] = rng.integers(0, 100, n)
        array["gap"] = np.nan
        if k == 1:
            array["amplitude"][[3, 7]] = [0.25, 0.5]
            array["count"][5] = -70_000
            array["band"][4] = 65_535
            array["normal"][6] = [-0.9, 0.8, -0.7]
            array["depth"][2] = -1  # no data: not the minimum
            array["depth"][8] = 5_000
        chunks.append(laspy.ScaleAwarePointRecord(array, pf, np.full(3, 1e-3), np.zeros(3)))
    return chunks


def _write(path: Path, chunks: list[Any]) -> None:
    with LasChunkWriter(path, _template(), None, (0.0, 0.0, 0.0), 1e-3) as w:
        for chunk in chunks:
            w.write_stored(chunk)


@pytest.mark.parametrize("suffix", [".las", ".laz"])
def test_min_and_max_are_those_of_every_point_written(tmp_path: Path, suffix: str) -> None:
    chunks = _chunks(10, np.random.default_rng(1))
    out = tmp_path / f"o{suffix}"
    _write(out, chunks)
    got = _descriptors(out)
    both = np.concatenate([c.array for c in chunks])
    for name, kind in (("amplitude", "<f8"), ("count", "<i8"), ("band", "<u8")):
        options, lo, hi = got[name]
        assert options & _MIN_MAX == _MIN_MAX, name
        assert np.frombuffer(lo, kind)[0] == both[name].min(), name
        assert np.frombuffer(hi, kind)[0] == both[name].max(), name
    options, lo, hi = got["normal"]
    assert options & _MIN_MAX == _MIN_MAX
    np.testing.assert_array_equal(np.frombuffer(lo, "<f8"), both["normal"].min(axis=0))
    np.testing.assert_array_equal(np.frombuffer(hi, "<f8"), both["normal"].max(axis=0))
    options, lo, hi = got["depth"]  # stored values, the no-data value left out
    assert options & _MIN_MAX == _MIN_MAX
    assert np.frombuffer(lo, "<i8")[0] == both["depth"][both["depth"] != -1].min()
    assert np.frombuffer(hi, "<i8")[0] == 5_000
    options, lo, hi = got["gap"]  # only NaN: no min or max to claim
    assert options & _MIN_MAX == 0
    assert lo == hi == bytes(24)
    las = laspy.read(out)
    np.testing.assert_array_equal(np.asarray(las.points.array["count"]), both["count"])


def test_an_output_without_points_claims_no_min_or_max(tmp_path: Path) -> None:
    out = tmp_path / "empty.laz"
    _write(out, [])
    for name, (options, lo, hi) in _descriptors(out).items():
        assert options & _MIN_MAX == 0, name
        assert lo == hi == bytes(24), name
    assert len(laspy.read(out).points) == 0
