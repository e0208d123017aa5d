"""PLY writer and reader: binary little-endian, round trip, bad input."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from kinsync.errors import InputError
from kinsync.io.ply import PlyChunkWriter, ply_property_type, read_ply_vertices


def _columns(n: int, rng: np.random.Generator) -> dict[str, np.ndarray]:
    return {
        "x": rng.normal(size=n) * 1e5,
        "y": rng.normal(size=n),
        "z": rng.normal(size=n),
        "intensity": rng.integers(0, 65535, n).astype(np.uint16),
        "cls": rng.integers(0, 255, n).astype(np.uint8),
        "flag": rng.integers(0, 2, n).astype(bool),
        "count": rng.integers(-(2**40), 2**40, n),
        "amp": rng.normal(size=n).astype(np.float32),
        "i1": rng.integers(-128, 127, n).astype(np.int8),
        "i4": rng.integers(-(2**31), 2**31 - 1, n).astype(np.int32),
    }


def test_round_trip_in_chunks_with_fewer_points_than_announced(tmp_path: Path) -> None:
    cols = _columns(500, np.random.default_rng(1))
    path = tmp_path / "c.ply"
    props = [(n, v.dtype) for n, v in cols.items()]
    with PlyChunkWriter(path, props, max_points=10_000, comments=["crs EPSG:32619"]) as w:
        w.write({n: v[:200] for n, v in cols.items()})
        w.write({n: v[200:] for n, v in cols.items()})
        w.write({n: v[:0] for n, v in cols.items()})
    head = path.read_bytes()[:400]
    assert b"format binary_little_endian 1.0\ncomment crs EPSG:32619\n" in head
    assert b"element vertex 500  \n" in head  # padded to the width of 10000
    back = read_ply_vertices(path)
    assert list(back) == list(cols)
    types = {n: ply_property_type(v.dtype) for n, v in cols.items()}
    assert types["count"] == "double"
    assert types["flag"] == "uchar"
    assert types["i1"] == "char"
    for name, values in cols.items():
        np.testing.assert_array_equal(back[name], values.astype(back[name].dtype))
        assert back[name].dtype.kind in "fiu"


def test_nothing_appears_when_the_block_fails(tmp_path: Path) -> None:
    path = tmp_path / "c.ply"
    props = [("x", np.float64), ("y", np.float64), ("z", np.float64)]

    def fail_midway() -> None:
        with PlyChunkWriter(path, props, 10) as w:
            w.write({"x": np.zeros(2), "y": np.zeros(2), "z": np.zeros(2)})
            raise RuntimeError

    with pytest.raises(RuntimeError):
        fail_midway()
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("props", "comments", "fragment"),
    [
        ([("x", "f8"), ("y", "f8")], [], "needs properties x, y, z"),
        ([("x", "f8"), ("y", "f8"), ("z", "f8"), ("a b", "f8")], [], "cannot be a PLY property"),
        ([("x", "f8"), ("y", "f8"), ("z", "f8"), ("x", "f8")], [], "repeat"),
        ([("x", "f8"), ("y", "f8"), ("z", "f8"), ("s", "U3")], [], "property 's'"),
        ([("x", "f8"), ("y", "f8"), ("z", "f8")], ["two\nlines"], "one line"),
    ],
)
def test_bad_properties_are_refused(
    tmp_path: Path, props: list[tuple[str, str]], comments: list[str], fragment: str
) -> None:
    with pytest.raises(InputError, match=fragment):
        PlyChunkWriter(tmp_path / "c.ply", props, 10, comments)


def test_bad_chunks_are_refused(tmp_path: Path) -> None:
    props = [("x", "f8"), ("y", "f8"), ("z", "f8"), ("n", "i8")]
    ok = {"x": np.zeros(3), "y": np.zeros(3), "z": np.zeros(3), "n": np.zeros(3, np.int64)}
    with PlyChunkWriter(tmp_path / "c.ply", props, 5) as w:
        with pytest.raises(InputError, match="differ from"):
            w.write({"x": np.zeros(3)})
        with pytest.raises(InputError, match="one length"):
            w.write(ok | {"y": np.zeros(2)})
        with pytest.raises(InputError, match=r"point 2 of the output, n = 9007199254740993: PLY"):
            w.write(ok | {"n": np.array([0, 2**53 + 1, 0])})
        w.write(ok)
        with pytest.raises(InputError, match="more than the 9 the header"):
            w.write({k: np.tile(v, 3) for k, v in ok.items()})
    assert len(read_ply_vertices(tmp_path / "c.ply")["x"]) == 3


@pytest.mark.parametrize(
    ("data", "fragment"),
    [
        (b"hello", "not a PLY file"),
        (b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n1\n", "binary"),
        (
            (
                b"ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty double x\n"
                b"end_header\n\x00\x00"
            ),
            "2 vertices of 8 bytes announced, 2 bytes present",
        ),
        (
            b"ply\nformat binary_little_endian 1.0\nelement face 1\nend_header\n",
            "besides vertex",
        ),
    ],
)
def test_reader_refuses_what_it_does_not_read(tmp_path: Path, data: bytes, fragment: str) -> None:
    path = tmp_path / "bad.ply"
    path.write_bytes(data)
    with pytest.raises(InputError, match=fragment):
        read_ply_vertices(path)
