"""The kinsync record of a georeferenced file: written by georef, read by mount from-points.

A LAS/LAZ output holds it in a VLR, a Parquet one in its schema metadata, a PLY one in a
header comment; a CSV has nowhere to keep it. ``kinsync mount from-points`` reads it back
and writes the mount applied as a TOML that reads back bit for bit.
"""

from __future__ import annotations

import hashlib
import json
import shlex
import shutil
import struct
from collections.abc import Callable
from pathlib import Path
from typing import Any

import laspy
import numpy as np
import pyarrow.parquet as pq
import pyproj
import pytest
from laspy.vlrs.vlrlist import VLRList
from tests._las import las_points

from kinsync.io.mount_file import read_mount
from kinsync.io.points import TableChunkWriter
from kinsync.io.trajectory_csv import write_trajectory_csv
from kinsync.mount import Mount, MountUncertainty, StdCorrelation, mount_to_toml_text
from kinsync.trajectory import Trajectory

RunCli = Callable[[list[str]], tuple[int, str, str]]  # fixture run_cli in conftest.py
OneLineError = Callable[..., None]  # fixture assert_one_line_error in conftest.py

T0 = 1.3e9  # GPS seconds
N = 400
HEADER = ["# vehicle 7, scanner SN 1234", "# lever arm surveyed 2024-05-01 (total station)"]
MOUNT = Mount(  # values whose shortest text is long: a rounded copy would differ
    lever_arm_body_m=(0.1 + 0.2, -1.0 / 3.0, 2.0**-30),
    boresight_rpy_deg=(0.5, -0.30000000000000004, 90.0 - 1e-13),
    antenna_lever_arm_body_m=(0.0, -0.0, 1.25),
    latency_s=0.0041234567891234,
    uncertainty=MountUncertainty(
        lever_arm_body_m=(0.01, 0.01, 0.02),
        boresight_rpy_deg=(0.011, 0.012, 0.03),
        latency_s=1.1e-5,
        correlation=StdCorrelation(("lever_x_m", "latency_ms"), ((1.0, -0.8), (-0.8, 1.0))),
    ),
)


def _trajectory() -> Trajectory:
    s = np.arange(0.0, 10.0, 0.01)
    llh = np.column_stack([46.8 + 1e-5 * s, -71.2 + 2e-5 * s, 10.0 + 0.1 * s])
    return Trajectory.from_euler(T0 + s, 0.02 * np.sin(s), 0.01 * s, 0.3 + 0.05 * s, lat_lon_h=llh)


def _columns() -> dict[str, np.ndarray]:
    rng = np.random.default_rng(3)
    return {
        "t_s": T0 + np.sort(rng.uniform(0.1, 9.9, N)),
        "x_m": rng.uniform(-1, 1, N),
        "y_m": rng.uniform(-20, 20, N),
        "z_m": rng.uniform(-5, 5, N),
    }


@pytest.fixture
def setup(tmp_path: Path) -> dict[str, Path]:
    write_trajectory_csv(_trajectory(), tmp_path / "traj.csv")
    (tmp_path / "mount.toml").write_text(
        "\n".join(HEADER) + "\n\n" + mount_to_toml_text(MOUNT), encoding="utf-8"
    )
    with TableChunkWriter(tmp_path / "points.parquet") as w:
        w.write(_columns())
    las_points(_columns()).write(tmp_path / "points.las")
    return {
        "dir": tmp_path,
        "traj": tmp_path / "traj.csv",
        "mount": tmp_path / "mount.toml",
        "points": tmp_path / "points.parquet",
    }


def _georef(s: dict[str, Path], out: Path, *extra: str, crs: str = "EPSG:32619") -> list[str]:
    return [
        "georef",
        *("--points", str(s["points"]), "--trajectory", str(s["traj"])),
        *("--mount", str(s["mount"]), "--out", str(out), "--crs", crs, *extra),
    ]


def _las_records(path: Path) -> list[laspy.VLR]:
    with laspy.open(path) as reader:
        header = reader.header
    return [v for v in [*header.vlrs, *(header.evlrs or [])] if v.user_id == "kinsync"]


def _stored_record(path: Path) -> dict[str, Any]:
    """The record as another program finds it, without kinsync's reader."""
    suffix = path.suffix
    if suffix in (".las", ".laz"):
        (vlr,) = _las_records(path)
        assert vlr.record_id == 1
        assert len(vlr.description.encode()) <= 32
        doc = json.loads(bytes(vlr.record_data).decode("utf-8"))
    elif suffix == ".parquet":
        doc = json.loads(pq.read_schema(path).metadata[b"kinsync"])
    else:  # comment lines "kinsync_record <i>/<n> <piece>"
        head = path.read_bytes().split(b"end_header\n")[0].decode("ascii").splitlines()
        ours = [h.split(" ", 3)[2:] for h in head if h.startswith("comment kinsync_record ")]
        assert [i for i, _ in ours] == [f"{i}/{len(ours)}" for i in range(1, len(ours) + 1)]
        doc = json.loads("".join(piece for _, piece in ours))
    assert isinstance(doc, dict)
    return doc


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.mark.parametrize("suffix", [".las", ".laz", ".parquet", ".ply"])
def test_every_point_output_but_csv_holds_the_record(
    run_cli: RunCli, setup: dict[str, Path], suffix: str
) -> None:
    out = setup["dir"] / f"geo{suffix}"
    code, _, err = run_cli(_georef(setup, out))
    assert code == 0, err
    doc = _stored_record(out)
    assert doc["kinsync_record"] == 1
    assert doc["made_by"] == "georef"
    assert doc["software"].startswith("kinsync ")
    assert doc["command"] == shlex.join(["kinsync", *_georef(setup, out)])
    assert doc["utc"] == "2023-11-14T22:13:20Z"  # tests' SOURCE_DATE_EPOCH
    mount = doc["mount"]
    assert mount["values"] == json.loads(json.dumps(MOUNT.as_document()))
    assert mount["toml"] == mount_to_toml_text(MOUNT)
    assert mount["file"] == {
        "path": str(setup["mount"]),
        "bytes": setup["mount"].stat().st_size,
        "sha256": _sha256(setup["mount"]),
        "header_comments": HEADER,
    }
    assert doc["points"] == {"path": str(setup["points"])}
    assert doc["trajectory"]["path"] == str(setup["traj"])
    assert doc["trajectory"]["sha256"] == _sha256(setup["traj"])
    assert doc["time"] == {
        "trajectory": "gps",
        "gps_week": None,
        "points": "t_s",
        "las_time_offset_s": 0.0,
    }
    assert doc["crs"]["requested"] == "EPSG:32619"
    assert doc["crs"]["target"] == "WGS 84 / UTM zone 19N (EPSG:32619)"
    assert doc["outside"] == "error"


def test_no_ply_header_line_is_one_a_reader_refuses(
    run_cli: RunCli, setup: dict[str, Path]
) -> None:
    """Open3D's PLY reader (RPly) aborts on a header line of 1,024 characters or more.

    The record (kilobytes with a mount file's header comments) is cut into comment
    lines well under that; a --crs given as WKT (kilobytes, with degree signs, where a
    PLY header is ASCII) is named by its name and code. The record reads back whole.
    """
    header = [f"# note {i}: résumé {'x' * 150}" for i in range(300)]
    mount = setup["dir"] / "long.toml"
    mount.write_text("\n".join(header) + "\n\n" + mount_to_toml_text(MOUNT), encoding="utf-8")
    wkt = pyproj.CRS("EPSG:32619").to_wkt(pretty=True)
    out = setup["dir"] / "geo.ply"
    code, _, err = run_cli(_georef({**setup, "mount": mount}, out, crs=wkt))
    assert code == 0, err
    head = out.read_bytes().split(b"end_header\n")[0].split(b"\n")
    assert max(len(line) for line in head) < 1000
    assert len(head) > 60  # the record: 50 KB in lines of under 1,000 characters
    crs = b"comment kinsync georef, crs WGS 84 / UTM zone 19N (EPSG:32619), x y z in metre"
    assert head[2].startswith(crs)
    doc = _stored_record(out)
    assert doc["mount"]["file"]["header_comments"] == header
    assert doc["crs"]["requested"] == wkt
    back = setup["dir"] / "back.toml"
    code, _, err = run_cli(["mount", "from-points", str(out), "--out", str(back)])
    assert code == 0, err
    assert read_mount(back) == MOUNT
    assert "\n".join(header) in back.read_text(encoding="utf-8")


def test_a_parquet_output_keeps_its_crs_metadata_beside_the_record(
    run_cli: RunCli, setup: dict[str, Path]
) -> None:
    out = setup["dir"] / "geo.parquet"
    code, _, err = run_cli(_georef(setup, out))
    assert code == 0, err
    metadata = pq.read_schema(out).metadata
    assert b"kinsync" in metadata
    assert len(metadata) > 1  # the CRS (kinsync.crs_axes.coordinate_metadata) stays


def test_a_csv_output_holds_no_record_and_from_points_says_so(
    run_cli: RunCli, setup: dict[str, Path], assert_one_line_error: OneLineError
) -> None:
    out = setup["dir"] / "geo.csv"
    code, _, err = run_cli(_georef(setup, out))
    assert code == 0, err
    assert out.read_text().splitlines()[0] == "t_s,X,Y,Z"
    code, stdout, err = run_cli(["mount", "from-points", str(out)])
    assert_one_line_error(code, stdout, err, str(out), "holds no kinsync record", ".laz")


@pytest.mark.parametrize("suffix", [".las", ".laz", ".parquet", ".ply"])
def test_two_runs_at_one_source_date_epoch_are_byte_identical(
    run_cli: RunCli, setup: dict[str, Path], suffix: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    out = setup["dir"] / f"geo{suffix}"
    first = setup["dir"] / f"first{suffix}"
    code, _, err = run_cli(_georef(setup, out))
    assert code == 0, err
    shutil.copyfile(out, first)
    code, _, err = run_cli(_georef(setup, out))
    assert code == 0, err
    assert out.read_bytes() == first.read_bytes()
    # How the work ran is left out of the record: the same bytes with other chunks and
    # schedulers, and with a JSON summary printed (the record names the command without
    # them; --json's own record keeps them). Chunks of 7 points: a Parquet file's row
    # groups do not follow them.
    how = ["--chunk-points", "7", "--scheduler=processes", "--json", "--workers", "2"]
    code, stdout, err = run_cli([*_georef(setup, out), *how])
    assert code == 0, err
    assert out.read_bytes() == first.read_bytes()
    assert _stored_record(out)["command"] == _stored_record(first)["command"]
    assert json.loads(stdout)["provenance"]["command"].endswith(shlex.join(how))
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1700000001")  # the record's time: one second on
    code, _, err = run_cli(_georef(setup, out))
    assert code == 0, err
    assert out.read_bytes() != first.read_bytes()
    assert _stored_record(out)["utc"] == "2023-11-14T22:13:21Z"


def _floats(mount: Mount) -> list[bytes]:
    """Every float of a mount as its 8 bytes (-0.0 and 0.0 differ)."""
    doc = mount.as_document()
    values = [*doc["lever_arm_body_m"], *doc["boresight_rpy_deg"]]
    values += [*doc["antenna_lever_arm_body_m"], doc["latency_s"]]
    unc = doc["uncertainty"]
    values += [*unc["lever_arm_body_m"], *unc["boresight_rpy_deg"], unc["latency_s"]]
    values += [v for row in unc["correlation"]["matrix"] for v in row]
    return [struct.pack("<d", v) for v in values]


@pytest.mark.parametrize("suffix", [".laz", ".parquet"])
def test_from_points_writes_the_mount_back_bit_for_bit(
    run_cli: RunCli, setup: dict[str, Path], suffix: str
) -> None:
    out = setup["dir"] / f"geo{suffix}"
    code, _, err = run_cli(_georef(setup, out))
    assert code == 0, err
    back = setup["dir"] / "back.toml"
    code, _, err = run_cli(["mount", "from-points", str(out), "--out", str(back)])
    assert code == 0, err
    again = read_mount(back)
    assert again == MOUNT
    assert _floats(again) == _floats(MOUNT)
    assert mount_to_toml_text(again) == mount_to_toml_text(MOUNT)
    text = back.read_text(encoding="utf-8")
    assert text.startswith("# written by kinsync ")
    assert f"# its command: kinsync georef --points {setup['points']}" in text
    assert "\n".join(["# mount.toml's header:", *HEADER]) in text
    # Georeferenced again with the mount written back: the same coordinates.
    redo = setup["dir"] / f"redo{suffix}"
    code, _, err = run_cli(_georef({**setup, "mount": back}, redo))
    assert code == 0, err
    if suffix == ".laz":
        a, b = laspy.read(out), laspy.read(redo)
        for axis in ("X", "Y", "Z"):
            np.testing.assert_array_equal(a[axis], b[axis])
    else:
        assert pq.read_table(out).equals(pq.read_table(redo))


def test_the_recorded_mount_is_the_one_applied(run_cli: RunCli, setup: dict[str, Path]) -> None:
    """--latency-ms replaces the mount file's latency: the record holds the one applied."""
    out = setup["dir"] / "geo.laz"
    code, _, err = run_cli(_georef(setup, out, "--latency-ms", "12.5"))
    assert code == 0, err
    doc = _stored_record(out)
    assert doc["mount"]["values"]["latency_s"] == 0.0125
    assert doc["mount"]["file"]["path"] == str(setup["mount"])  # where the rest came from
    code, stdout, err = run_cli(["mount", "from-points", str(out), "--json"])
    assert code == 0, err
    shown = json.loads(stdout)
    assert shown["file"] == str(out)
    assert shown["record"] == doc
    assert shown["record"]["mount"]["values"]["latency_s"] == 0.0125


def test_from_points_prints_the_record(run_cli: RunCli, setup: dict[str, Path]) -> None:
    out = setup["dir"] / "geo.laz"
    code, _, err = run_cli(_georef(setup, out))
    assert code == 0, err
    code, stdout, err = run_cli(["mount", "from-points", str(out)])
    assert code == 0, err
    for shown in ("kinsync georef", "latency_s", "0.00412346", "sigma latency_s", "EPSG:32619"):
        assert shown in stdout, shown


@pytest.mark.parametrize("name", ["points.las", "nothing.laz"])
def test_from_points_without_a_record_is_a_one_line_error(
    run_cli: RunCli, setup: dict[str, Path], assert_one_line_error: OneLineError, name: str
) -> None:
    path = setup["dir"] / name
    code, stdout, err = run_cli(["mount", "from-points", str(path)])
    why = "has no kinsync record" if path.exists() else "no such file"
    assert_one_line_error(code, stdout, err, str(path), why)


@pytest.mark.parametrize("version", ["1.2", "1.4"])
def test_an_inputs_record_is_replaced_and_its_other_records_kept(
    run_cli: RunCli, setup: dict[str, Path], version: str
) -> None:
    """A LAS input that holds a kinsync record (VLR, or EVLR in LAS 1.4): one record out."""
    las = las_points(_columns(), point_format=1 if version == "1.2" else 6, version=version)
    las.header.vlrs.append(laspy.VLR("ACME", 7, "scanner serial", b"SN 1234"))
    old = laspy.VLR("kinsync", 1, "an earlier record", b'{"made_by": "earlier"}')
    if version == "1.4":
        las.header.evlrs = laspy.vlrs.vlrlist.VLRList([old])
    else:
        las.header.vlrs.append(old)
    src = setup["dir"] / "scan.las"
    las.write(src)
    assert len(_las_records(src)) == 1
    out = setup["dir"] / "geo.las"
    code, _, err = run_cli(_georef({**setup, "points": src}, out))
    assert code == 0, err
    (record,) = _las_records(out)
    assert json.loads(record.record_data)["made_by"] == "georef"
    header = laspy.read(out).header
    acme = [v for v in header.vlrs if v.user_id == "ACME"]
    assert [bytes(v.record_data) for v in acme] == [b"SN 1234"]


def _edited(out: Path, edit: Callable[[dict[str, Any]], None]) -> Path:
    """A copy of the LAS file ``out`` whose record was edited by hand."""
    las = laspy.read(out)
    (vlr,) = [v for v in las.header.vlrs if v.user_id == "kinsync"]
    doc = json.loads(vlr.record_data)
    edit(doc)
    others = [v for v in las.header.vlrs if v.user_id != "kinsync"]
    data = json.dumps(doc).encode("utf-8")  # lone surrogates as \ud800 escapes
    las.header.vlrs = VLRList([*others, laspy.VLR("kinsync", 1, "edited", data)])
    edited = out.with_name("edited.las")
    las.write(edited)
    return edited


def _set(keys: str, value: Any) -> Callable[[dict[str, Any]], None]:
    def edit(doc: dict[str, Any]) -> None:
        *parents, last = keys.split(".")
        for key in parents:
            doc = doc[key]
        doc[last] = value(doc[last]) if callable(value) else value

    return edit


@pytest.mark.parametrize(
    ("edit", "why"),
    [
        (_set("mount.file", "mount.toml"), 'mount.file is a text ("mount.toml"), not an object'),
        (_set("crs.epoch_year", "2024.5"), 'crs.epoch_year is a text ("2024.5"), not a number'),
        (_set("crs.epoch_year", value=True), "crs.epoch_year is true/false (true), not a number"),
        (_set("mount.file.header_comments", "abc"), 'header_comments is a text ("abc")'),
        (_set("mount.file.header_comments", ["# a", 1]), "not a list of texts"),
        (_set("left_out", {"a": 1}), 'left_out is an object ({"a": 1}), not a list of texts'),
    ],
)
@pytest.mark.parametrize("extra", [[], ["--json"], ["--out"]])
def test_a_record_edited_by_hand_is_a_one_line_error_and_writes_nothing(
    run_cli: RunCli,
    setup: dict[str, Path],
    assert_one_line_error: OneLineError,
    edit: Callable[[dict[str, Any]], None],
    why: str,
    extra: list[str],
) -> None:
    """A field of another JSON type was an internal error (exit 1), after --out wrote."""
    out = setup["dir"] / "geo.las"
    code, _, err = run_cli(_georef(setup, out))
    assert code == 0, err
    edited = _edited(out, edit)
    toml = setup["dir"] / "back.toml"
    args = [*extra, str(toml)] if extra == ["--out"] else extra
    code, stdout, err = run_cli(["mount", "from-points", str(edited), *args])
    assert_one_line_error(code, stdout, err, f"{edited}: ", why)
    assert not toml.exists()


def test_a_mount_toml_that_would_not_read_back_is_not_written(
    run_cli: RunCli, setup: dict[str, Path], assert_one_line_error: OneLineError
) -> None:
    """A record's mount TOML holding a lone surrogate (a valid JSON escape, no UTF-8)."""
    out = setup["dir"] / "geo.las"
    code, _, err = run_cli(_georef(setup, out))
    assert code == 0, err
    edited = _edited(out, _set("mount.toml", lambda t: "# \ud800\n" + t))
    back = setup["dir"] / "back.toml"
    code, stdout, err = run_cli(["mount", "from-points", str(edited), "--out", str(back)])
    assert_one_line_error(code, stdout, err, f"{edited}: ", "does not read back as the record's")
    assert not back.exists()


def test_header_comments_are_written_back_as_valid_toml_comments(
    run_cli: RunCli, setup: dict[str, Path]
) -> None:
    """A comment without '#', with a line break, a control character or a lone surrogate
    made --out write a mount file that `mount check` refused (exit 0)."""
    odd = ["no hash sign", "# two\nlines", "# nul \x00 and del \x7f", "# lone \ud800", "#ok"]
    out = setup["dir"] / "geo.las"
    code, _, err = run_cli(_georef(setup, out))
    assert code == 0, err
    edited = _edited(out, _set("mount.file.header_comments", odd))
    back = setup["dir"] / "back.toml"
    code, _, err = run_cli(["mount", "from-points", str(edited), "--out", str(back)])
    assert code == 0, err
    code, _, err = run_cli(["mount", "check", str(back)])
    assert code == 0, err
    assert read_mount(back) == MOUNT
    text = back.read_text(encoding="utf-8")
    shown = ["# no hash sign", "# two lines", "# nul \\x00 and del \\x7f", "# lone \\ud800", "#ok"]
    assert "\n".join(["# mount.toml's header:", *shown]) in text
