"""``kinsync trajectory export``: tables in any CRS, KML and GeoJSON lines."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pyarrow.csv as pa_csv
import pyarrow.parquet as pq
import pyproj
import pytest

from kinsync.io.sbet import write_sbet
from kinsync.io.trajectory_csv import write_trajectory_csv
from kinsync.trajectory import Trajectory

RunCli = Callable[[list[str]], tuple[int, str, str]]
OneLineError = Callable[..., None]
T0 = 1.3e9
N = 3001


def _trajectory() -> Trajectory:
    t = T0 + np.arange(N) * 0.01
    s = t - T0
    llh = np.column_stack([46.8 + 1e-4 * s, -71.2 + 2e-4 * s, 10.0 + 0.1 * s])
    vel = np.column_stack([11.1 + 0.0 * s, 15.2 + 0.0 * s, -0.1 + 0.0 * s])
    return Trajectory.from_euler(
        t, 0.02 * np.sin(s), 0.01 * np.cos(s), 0.3 + 0.05 * s, lat_lon_h=llh, vel_ned_m_s=vel
    )


@pytest.fixture
def traj_csv(tmp_path: Path) -> Path:
    path = tmp_path / "traj.csv"
    write_trajectory_csv(_trajectory(), path)
    return path


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_table_in_utm_matches_pyproj(
    run_cli: RunCli, traj_csv: Path, tmp_path: Path, suffix: str
) -> None:
    out = tmp_path / f"t{suffix}"
    code, stdout, err = run_cli(
        ["trajectory", "export", str(traj_csv), "--out", str(out), "--crs", "EPSG:32619", "--json"]
    )
    assert code == 0, err
    doc = json.loads(stdout)
    assert doc["records"] == doc["written"] == N
    assert doc["crs"]["target"] == "WGS 84 / UTM zone 19N (EPSG:32619)"
    table = pa_csv.read_csv(out) if suffix == ".csv" else pq.read_table(out)
    assert table.column_names == [
        "t_s", "X", "Y", "Z", "roll_deg", "pitch_deg", "yaw_deg", "vn_m_s", "ve_m_s", "vd_m_s"
    ]  # fmt: skip
    traj = _trajectory()
    assert traj.lat_lon_h is not None
    to_utm = pyproj.Transformer.from_crs("EPSG:4979", "EPSG:32619", always_xy=True)
    e, n = to_utm.transform(traj.lat_lon_h[:, 1], traj.lat_lon_h[:, 0])[:2]
    np.testing.assert_allclose(table.column("X").to_numpy(), e, rtol=0, atol=1e-6)
    np.testing.assert_allclose(table.column("Y").to_numpy(), n, rtol=0, atol=1e-6)
    np.testing.assert_allclose(table.column("Z").to_numpy(), traj.lat_lon_h[:, 2], atol=1e-6)
    np.testing.assert_array_equal(table.column("t_s").to_numpy(), traj.t_s)
    rpy = np.degrees(traj.euler_rpy_rad())
    np.testing.assert_allclose(table.column("yaw_deg").to_numpy(), rpy[:, 2], atol=1e-9)


def test_default_table_is_wgs84_longitude_latitude_height(
    run_cli: RunCli, traj_csv: Path, tmp_path: Path
) -> None:
    out = tmp_path / "t.csv"
    code, _, err = run_cli(["trajectory", "export", str(traj_csv), "--out", str(out)])
    assert code == 0, err
    table = pa_csv.read_csv(out)
    traj = _trajectory()
    assert traj.lat_lon_h is not None
    np.testing.assert_allclose(table.column("X").to_numpy(), traj.lat_lon_h[:, 1], atol=1e-10)
    np.testing.assert_allclose(table.column("Y").to_numpy(), traj.lat_lon_h[:, 0], atol=1e-10)


def test_geojson_line_is_decimated_and_keeps_the_ends(
    run_cli: RunCli, traj_csv: Path, tmp_path: Path
) -> None:
    out = tmp_path / "t.geojson"
    code, stdout, err = run_cli(
        [
            "trajectory",
            "export",
            str(traj_csv),
            "--out",
            str(out),
            "--max-vertices",
            "100",
            "--json",
        ]
    )
    assert code == 0, err
    assert json.loads(stdout)["written"] == 100
    doc = json.loads(out.read_text())
    feature = doc["features"][0]
    assert feature["geometry"]["type"] == "LineString"
    coords = np.array(feature["geometry"]["coordinates"])
    assert coords.shape == (100, 3)
    traj = _trajectory()
    assert traj.lat_lon_h is not None
    first, last = traj.lat_lon_h[0], traj.lat_lon_h[-1]
    np.testing.assert_allclose(coords[0], [first[1], first[0], first[2]], atol=1e-9)
    np.testing.assert_allclose(coords[-1], [last[1], last[0], last[2]], atol=1e-9)
    assert feature["properties"]["records"] == N


def test_kml_line_from_an_sbet(run_cli: RunCli, tmp_path: Path) -> None:
    sbet = tmp_path / "sbet.out"
    traj = _trajectory()
    write_sbet(traj, sbet)
    out = tmp_path / "t.kml"
    code, _, err = run_cli(
        ["trajectory", "export", str(sbet), "--out", str(out), "--max-vertices", "10"]
    )
    assert code == 0, err
    ns = {"k": "http://www.opengis.net/kml/2.2"}
    root = ET.parse(out).getroot()
    text = root.find(".//k:LineString/k:coordinates", ns)
    assert text is not None
    assert text.text is not None
    pairs = np.array([[float(v) for v in p.split(",")] for p in text.text.split()])
    assert pairs.shape == (10, 2)
    assert traj.lat_lon_h is not None
    np.testing.assert_allclose(pairs[0], traj.lat_lon_h[0, [1, 0]], atol=1e-8)
    np.testing.assert_allclose(pairs[-1], traj.lat_lon_h[-1, [1, 0]], atol=1e-8)


def test_a_table_of_seconds_of_week_is_written_with_a_warning(
    run_cli: RunCli, tmp_path: Path
) -> None:
    """A CSV from an SBET without --gps-week holds seconds of week, which every kinsync
    input on GPS time misses (a CSV trajectory is read as GPS time): say so at export."""
    sbet = tmp_path / "sbet.out"
    write_sbet(_trajectory(), sbet)
    out = tmp_path / "t.csv"
    code, _, err = run_cli(["trajectory", "export", str(sbet), "--out", str(out)])
    assert code == 0, err
    assert "kinsync: warning: " in err
    assert "t.csv: its t_s are GPS seconds of week" in err
    assert "give --gps-week" in err
    week = str(int(T0 // 604800))
    code, _, err = run_cli(
        ["trajectory", "export", str(sbet), "--out", str(out), "--gps-week", week]
    )
    assert code == 0, err
    assert "warning" not in err


@pytest.mark.parametrize(
    ("args", "fragments"),
    [
        (["OUT.kml", "--crs", "EPSG:32619"], ["WGS 84 longitude/latitude", "--crs"]),
        (["OUT.txt"], ["unknown output type", ".geojson or .kml"]),
        (["OUT.csv", "--crs", "EPSG:99999999"], ["EPSG:99999999"]),
        (["OUT.geojson", "--max-vertices", "1"], ["--max-vertices"]),
        (["OUT.csv", "--max-vertices", "500"], ["--max-vertices thins", "keeps every record"]),
    ],
)
def test_bad_input_is_one_line_error(
    run_cli: RunCli,
    assert_one_line_error: OneLineError,
    traj_csv: Path,
    tmp_path: Path,
    args: list[str],
    fragments: list[str],
) -> None:
    out = tmp_path / args[0].replace("OUT", "t")
    code, stdout, err = run_cli(
        ["trajectory", "export", str(traj_csv), "--out", str(out), *args[1:]]
    )
    assert_one_line_error(code, stdout, err, *fragments)
    assert not out.exists()


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_a_table_is_written_in_blocks_with_the_same_bytes(
    run_cli: RunCli, traj_csv: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, suffix: str
) -> None:
    """A long trajectory is converted and written a block at a time (6.5 GB for 10 h at
    200 Hz, written at once): the file is the one a single write makes, byte for byte."""
    from kinsync.io.table_writer import TableChunkWriter  # noqa: PLC0415
    from kinsync.pipelines import trajectory_export  # noqa: PLC0415

    args = ["trajectory", "export", str(traj_csv), "--crs", "EPSG:32619", "--out"]
    whole = tmp_path / f"whole{suffix}"
    assert run_cli([*args, str(whole)])[0] == 0
    sizes: list[int] = []
    write = TableChunkWriter.write

    def spy(self: TableChunkWriter, columns: dict[str, np.ndarray]) -> None:
        sizes.append(len(columns["t_s"]))
        write(self, columns)

    monkeypatch.setattr(TableChunkWriter, "write", spy)
    monkeypatch.setattr(trajectory_export, "BLOCK_RECORDS", 1000)
    blocks = tmp_path / f"blocks{suffix}"
    assert run_cli([*args, str(blocks)])[0] == 0
    assert sizes == [1000, 1000, 1000, 1]
    # Parquet too: its row groups are of 2**20 rows whatever the blocks.
    assert blocks.read_bytes() == whole.read_bytes()
