"""The kinsync record in a LAS file: replaced, never duplicated, never cut silently."""

from __future__ import annotations

import json
from pathlib import Path

import laspy
import numpy as np
import pytest

from kinsync.errors import InputError
from kinsync.io.las_writer import LasChunkWriter
from kinsync.io.ply import PlyChunkWriter
from kinsync.io.point_provenance import (
    PLY_PIECE_CHARS,
    ply_record_comments,
    point_document,
    read_point_record,
    record_mount,
    set_las_record,
)
from kinsync.mount import Mount, mount_to_toml_text

MOUNT = Mount(lever_arm_body_m=(0.5, 0.1, -1.0), latency_s=0.004)
COMMENTS = [f"# line {i}: {'x' * 90}" for i in range(800)]  # 78 KB: more than a VLR holds


def _mount_file(folder: Path, comments: list[str]) -> Path:
    path = folder / "mount.toml"
    path.write_text("\n".join(comments) + "\n\n" + mount_to_toml_text(MOUNT), encoding="utf-8")
    return path


def _written(path: Path, version: str, record: dict[str, object]) -> LasChunkWriter:
    """A LAS file of three points with ``record``, written by kinsync's writer."""
    header = laspy.LasHeader(point_format=1 if version == "1.2" else 6, version=version)
    points = laspy.ScaleAwarePointRecord.zeros(3, header=header)
    with LasChunkWriter(path, header, None, (0.0, 0.0, 0.0), 1e-3, record) as writer:
        writer.write(points, np.arange(3.0), np.zeros(3), np.ones(3))
    return writer


def test_a_record_longer_than_a_vlr_goes_whole_into_an_evlr_in_las_1_4(tmp_path: Path) -> None:
    doc = point_document("georef", MOUNT, _mount_file(tmp_path, COMMENTS), {})
    out = tmp_path / "geo.laz"
    writer = _written(out, "1.4", doc)
    assert writer.record_notes == ()
    with laspy.open(out) as reader:  # laspy reads it, and every point
        assert not [v for v in reader.header.vlrs if v.user_id == "kinsync"]
        (evlr,) = [v for v in reader.header.evlrs or [] if v.user_id == "kinsync"]
        assert len(evlr.record_data) > 65_535
        assert len(reader.read().x) == 3
    got = read_point_record(out)
    assert got["mount"]["file"]["header_comments"] == COMMENTS
    assert "left_out" not in got


def test_a_las_1_2_record_drops_the_mount_comments_and_says_so(tmp_path: Path) -> None:
    doc = point_document("georef", MOUNT, _mount_file(tmp_path, COMMENTS), {})
    out = tmp_path / "geo.las"
    writer = _written(out, "1.2", doc)
    (note,) = writer.record_notes
    assert note.startswith(f"{out}: its kinsync record (a VLR) leaves out the mount file header")
    assert "65535 bytes" in note
    las = laspy.read(out)
    (vlr,) = [v for v in las.header.vlrs if v.user_id == "kinsync"]
    assert len(vlr.record_data) <= 65_535
    got = read_point_record(out)
    assert got["left_out"] == ["mount file header comments"]
    assert got["mount"]["file"]["header_comments"] is None
    assert got["mount"]["file"]["sha256"] == doc["mount"]["file"]["sha256"]
    assert record_mount(got, out) == MOUNT


def test_a_short_record_is_one_vlr_and_replaces_the_headers_own(tmp_path: Path) -> None:
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.vlrs.append(laspy.VLR("kinsync", 1, "old", b"{}"))
    header.vlrs.append(laspy.VLR("kinsync", 2, "another id: not ours", b"keep"))
    header.evlrs = laspy.vlrs.vlrlist.VLRList([laspy.VLR("kinsync", 1, "old", b"{}")])
    doc = point_document("georef", MOUNT, None, {"outside": "error"})
    assert set_las_record(header, doc, tmp_path / "x.las") == ()
    ours = [v for v in [*header.vlrs, *header.evlrs] if v.user_id == "kinsync"]
    assert [(v.record_id, v.record_data) for v in ours] == [
        (2, b"keep"),
        (1, json.dumps(doc).encode("utf-8")),
    ]


def test_a_record_that_no_vlr_holds_even_shortened_keeps_the_mount(tmp_path: Path) -> None:
    doc = point_document("georef", MOUNT, None, {"crs": {"requested": "x" * 70_000}})
    doc["command"] = "kinsync georef --crs " + "x" * 70_000  # a CLI run's (None from Python)
    header = laspy.LasHeader(point_format=1, version="1.2")
    (note,) = set_las_record(header, doc, tmp_path / "x.las")
    assert note.startswith(f"{tmp_path / 'x.las'}: its kinsync record (a VLR) leaves out the ")
    assert note.endswith("a LAS 1.4 output holds it whole")
    (vlr,) = [v for v in header.vlrs if v.user_id == "kinsync"]
    got = json.loads(vlr.record_data)
    assert got["left_out"] == ["command", "crs"]  # no mount file: no comments to leave out
    assert got["mount"] == doc["mount"]
    assert record_mount(got, tmp_path / "x.las") == MOUNT


def test_a_damaged_record_is_named(tmp_path: Path) -> None:
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.vlrs.append(laspy.VLR("kinsync", 1, "damaged", b"{not json"))
    las = laspy.LasData(header)
    las.x, las.y, las.z = np.zeros(1), np.zeros(1), np.zeros(1)
    path = tmp_path / "bad.las"
    las.write(path)
    with pytest.raises(InputError, match=r"bad\.las: its kinsync record .* is not UTF-8 JSON"):
        read_point_record(path)


def _ply_with(path: Path, comments: list[str]) -> Path:
    with PlyChunkWriter(path, [(a, np.float64) for a in "xyz"], 1, comments) as ply:
        ply.write({a: np.zeros(1) for a in "xyz"})
    return path


def test_a_ply_record_is_cut_into_short_lines_that_join_back(tmp_path: Path) -> None:
    # Many spaces: no piece begins or ends with one (a reader may trim comment lines).
    doc = point_document("georef", MOUNT, None, {"note": "ab  cd   " * 2000, "é": "ü"})
    comments = ply_record_comments(doc)
    assert len(comments) > 20
    pieces = [c.split(" ", 2)[2] for c in comments]
    assert all(len(p) <= PLY_PIECE_CHARS for p in pieces)
    assert not [p for p in pieces if p != p.strip(" ")]
    assert json.loads("".join(pieces)) == doc
    path = _ply_with(tmp_path / "geo.ply", ["kinsync georef", *comments])
    assert read_point_record(path) == doc


def test_a_ply_record_missing_a_piece_is_named(tmp_path: Path) -> None:
    doc = point_document("georef", MOUNT, None, {"note": "x" * 3000})
    comments = ply_record_comments(doc)
    n = len(comments)  # 4 or more (the command, if a CLI test ran before, is in it)
    path = _ply_with(tmp_path / "cut.ply", [comments[0], *comments[2:]])
    why = rf"cut\.ply: its kinsync record's header comment 1 of {n - 1} begins '1/{n}', not 1/"
    with pytest.raises(InputError, match=why):
        read_point_record(path)


def test_a_missing_file_names_every_type_that_holds_a_record(tmp_path: Path) -> None:
    with pytest.raises(InputError, match=r"no such file; .*\(\.las, \.laz, \.parquet, \.ply\)"):
        read_point_record(tmp_path / "gone.ply")
