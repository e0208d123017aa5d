"""LAS/LAZ output of the georeferencing pipeline: offsets, scales, blocks, write-behind."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import laspy
import numpy as np
import pyproj
import pytest

from kinsync.errors import InputError
from kinsync.frames import geodetic_to_ecef
from kinsync.georef import GeorefTrajectory, georeference
from kinsync.io.las_writer import LasChunkWriter
from kinsync.io.points import TableChunkWriter, read_table_slice
from kinsync.io.trajectory_csv import read_trajectory_csv, write_trajectory_csv
from kinsync.mount import Mount
from kinsync.pipelines.georef import georeference_file
from kinsync.trajectory import Trajectory

T0 = 1.3e9
MOUNT = Mount(lever_arm_body_m=(0.5, 0.1, -1.0), boresight_rpy_deg=(0.5, -0.3, 90.0))


def _line_trajectory(length_km: float, climb_m: float = 0.0) -> Trajectory:
    """A straight northbound line at 100 m/s (1 Hz records), from 40 deg N."""
    duration_s = length_km * 10.0
    s = np.arange(0.0, duration_s + 1.0, 1.0)
    lat = 40.0 + s * 100.0 / 111_000.0
    llh = np.column_stack([lat, np.full_like(s, -71.0), 50.0 + climb_m * s / duration_s])
    zeros = np.zeros_like(s)
    return Trajectory.from_euler(T0 + s, zeros, zeros, zeros, lat_lon_h=llh)


def _scan(folder: Path, traj: Trajectory, n: int, name: str = "scan.laz") -> Path:
    rng = np.random.default_rng(4)
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales = np.array([1e-4, 1e-4, 1e-4])
    header.offsets = np.zeros(3)
    header.global_encoding.gps_time_type = laspy.header.GpsTimeType.STANDARD
    las = laspy.LasData(header)
    las.x = rng.uniform(-1, 1, n)
    las.y = rng.uniform(-30, 30, n)
    las.z = rng.uniform(-10, 10, n)
    las.gps_time = np.sort(rng.uniform(traj.t_start_s, traj.t_end_s, n)) - 1e9
    las.intensity = rng.integers(0, 60000, n).astype(np.uint16)
    path = folder / name
    las.write(path)
    write_trajectory_csv(traj, folder / "traj.csv")
    return path


def _expected_ecef(folder: Path, src: Path) -> np.ndarray:
    gt = GeorefTrajectory.from_trajectory(read_trajectory_csv(folder / "traj.csv"))
    stored = laspy.read(src)
    t = np.asarray(stored.gps_time) + 1e9
    xyz = np.column_stack([np.asarray(stored.x), np.asarray(stored.y), np.asarray(stored.z)])
    out, inside = georeference(t, xyz, gt, MOUNT)
    assert inside.all()
    return out


def test_a_350_km_line_fits_with_offsets_at_the_middle_of_its_span(tmp_path: Path) -> None:
    """0.1 mm integers reach 214.7 km either way: a 350 km file fits around its middle,
    not around its first point."""
    traj = _line_trajectory(350.0)
    src = _scan(tmp_path, traj, 3_000)
    out = tmp_path / "geo.laz"
    georeference_file(src, tmp_path / "traj.csv", MOUNT, out, chunk_points=1_000)
    las = laspy.read(out)
    got = np.column_stack([np.asarray(las.x), np.asarray(las.y), np.asarray(las.z)])
    assert np.abs(got - _expected_ecef(tmp_path, src)).max() <= 0.5e-4 + 1e-9
    t = np.asarray(las.gps_time) + 1e9 - T0
    mid = geodetic_to_ecef(40.0 + 0.5 * (t[0] + t[-1]) * 100.0 / 111_000.0, -71.0, 50.0)
    np.testing.assert_allclose(las.header.offsets, np.round(mid / 1000.0) * 1000.0)
    assert las.header.scales.tolist() == [1e-4, 1e-4, 1e-4]
    assert np.abs(got - got[0]).max() > 2.0**31 * 1e-4


def test_a_span_too_long_for_las_integers_is_a_clear_error(tmp_path: Path) -> None:
    traj = _line_trajectory(700.0)
    src = _scan(tmp_path, traj, 2_000)
    out = tmp_path / "geo.laz"
    with pytest.raises(InputError, match=r"scan\.laz: point \d+ of 2000 georeferences .*split the"):
        georeference_file(src, tmp_path / "traj.csv", MOUNT, out, chunk_points=500)
    assert not out.exists()
    assert list(tmp_path.glob("*.laz")) == [src]


def test_geographic_output_keeps_heights_at_a_tenth_of_a_millimetre(tmp_path: Path) -> None:
    """Longitude/latitude at 1e-9 deg (0.11 mm; 1e-7 deg was 11 mm), height at 1e-4 m:
    heights 1 km apart fit."""
    traj = _line_trajectory(20.0, climb_m=1000.0)
    src = _scan(tmp_path, traj, 2_000)
    out = tmp_path / "geo.las"
    georeference_file(src, tmp_path / "traj.csv", MOUNT, out, crs="EPSG:4979", chunk_points=700)
    las = laspy.read(out)
    assert las.header.scales.tolist() == [1e-9, 1e-9, 1e-4]
    to_geo = pyproj.Transformer.from_crs(4978, 4979, always_xy=True)
    ecef = _expected_ecef(tmp_path, src)
    lon, lat, h = to_geo.transform(ecef[:, 0], ecef[:, 1], ecef[:, 2])
    assert np.ptp(h) > 900.0
    np.testing.assert_allclose(np.asarray(las.x), lon, rtol=0, atol=0.5e-9 + 1e-12)
    np.testing.assert_allclose(np.asarray(las.y), lat, rtol=0, atol=0.5e-9 + 1e-12)
    np.testing.assert_allclose(np.asarray(las.z), h, rtol=0, atol=0.5e-4 + 1e-9)


def _across_the_antimeridian() -> Trajectory:
    """A 2.1 km eastbound line at 16.5 deg S from 179.99 to -179.99 deg (20 m/s, 1 Hz)."""
    s = np.arange(0.0, 106.0, 1.0)
    lon = (179.99 + s * 0.02 / 105.0 + 180.0) % 360.0 - 180.0
    llh = np.column_stack([np.full_like(s, -16.5), lon, np.full_like(s, 10.0)])
    zeros = np.zeros_like(s)
    return Trajectory.from_euler(T0 + s, zeros, zeros, np.full_like(s, np.pi / 2), lat_lon_h=llh)


@pytest.mark.parametrize("source", ["scan.laz", "points.csv"])
def test_geographic_las_output_across_the_antimeridian(tmp_path: Path, source: str) -> None:
    """Review L3: points at 179.99 deg were "360 deg from the file's reference position"
    (-180 deg): longitudes are stored within 180 deg of the X offset, continuous."""
    traj = _across_the_antimeridian()
    src = _scan(tmp_path, traj, 2_000)
    want = _expected_ecef(tmp_path, src)
    if source == "points.csv":
        las = laspy.read(src)
        table = np.column_stack([np.asarray(las.gps_time) + 1e9, las.x, las.y, las.z])
        src = tmp_path / source
        np.savetxt(src, table, fmt="%.6f", delimiter=",", header="t_s,x_m,y_m,z_m", comments="")
    out = tmp_path / "geo.laz"
    georeference_file(src, tmp_path / "traj.csv", MOUNT, out, crs="EPSG:4979", chunk_points=700)
    las = laspy.read(out)
    lon = np.asarray(las.x)
    offset = float(las.header.offsets[0])
    assert abs(offset) == 180.0
    assert np.abs(lon - offset).max() < 0.05  # continuous: no jump of 360 deg
    assert las.header.maxs[0] - las.header.mins[0] < 0.05
    assert lon.min() < offset < lon.max()
    to_ecef = pyproj.Transformer.from_crs(4979, 4978, always_xy=True)  # 180.01 is -179.99
    got = to_ecef.transform(lon, np.asarray(las.y), np.asarray(las.z))
    np.testing.assert_allclose(np.column_stack(got), want, rtol=0, atol=1e-3)


def test_a_bad_time_beyond_the_first_block_is_named_by_its_index_in_the_chunk(
    tmp_path: Path,
) -> None:
    """Chunks are georeferenced in blocks of 65 536 points; errors still count in chunks."""
    traj = _line_trajectory(2.0)
    src = _scan(tmp_path, traj, 90_000, name="scan.las")
    las = laspy.read(src)
    t = np.asarray(las.gps_time).copy()
    t[70_001] = np.nan
    las.gps_time = t
    las.write(src)
    want = (
        r"scan\.las: point 70002 of 90000, column 'gps_time': point time nan is not finite; "
        r"1 such point\(s\) in the chunk of points 1\.\.80000 of 90000"
    )
    with pytest.raises(InputError, match=want):
        georeference_file(
            src, tmp_path / "traj.csv", MOUNT, tmp_path / "geo.las", chunk_points=80_000
        )
    assert not (tmp_path / "geo.las").exists()


@pytest.mark.parametrize("suffix", [".laz", ".csv"])
def test_a_failing_background_write_stops_the_run_and_leaves_nothing(
    tmp_path: Path, suffix: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Writes run behind the georeferencing; a failed one is raised at the next chunk."""
    traj = _line_trajectory(2.0)
    src = _scan(tmp_path, traj, 5_000)
    if suffix == ".csv":
        stored = laspy.read(src)
        src = tmp_path / "scan.csv"
        with TableChunkWriter(src) as w:
            w.write(
                {
                    "t_s": np.asarray(stored.gps_time) + 1e9,
                    "x_m": np.asarray(stored.x),
                    "y_m": np.asarray(stored.y),
                    "z_m": np.asarray(stored.z),
                }
            )
    calls: list[int] = []
    cls, method = (
        (LasChunkWriter, "write_stored") if suffix == ".laz" else (TableChunkWriter, "write")
    )
    original = getattr(cls, method)

    def failing(self: object, *args: object) -> None:
        calls.append(1)
        if len(calls) == 2:
            msg = "no space left on device"
            raise InputError(msg)
        original(self, *args)

    monkeypatch.setattr(cls, method, failing)
    out = tmp_path / f"geo{suffix}"
    with pytest.raises(InputError, match="no space left"):
        georeference_file(src, tmp_path / "traj.csv", MOUNT, out, chunk_points=1_000)
    assert len(calls) == 2  # the run stopped at the failed write
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        ["scan.laz", "traj.csv"] + (["scan.csv"] if suffix == ".csv" else [])
    )


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_las_output_frame_reads_only_the_time_column_of_a_table(
    tmp_path: Path, suffix: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The offsets need the first and last point's time: the other columns (a wide CSV's
    dozens of text columns took gigabytes) are read when the chunks are georeferenced."""
    traj = _line_trajectory(5.0)
    las = laspy.read(_scan(tmp_path, traj, 2_000))
    n = len(las.x)
    table = {
        "t_s": np.asarray(las.gps_time) + 1e9,
        "x_m": np.asarray(las.x),
        "y_m": np.asarray(las.y),
        "z_m": np.asarray(las.z),
        **{f"e{i}": np.full(n, i, dtype=np.int64) for i in range(8)},
    }
    src = tmp_path / f"points{suffix}"
    with TableChunkWriter(src) as writer:
        writer.write(table)
    columns_read: list[list[str]] = []

    def spy(*args: Any, **kwargs: Any) -> dict[str, Any]:
        got = read_table_slice(*args, **kwargs)
        columns_read.append(list(got))
        return got

    monkeypatch.setattr("kinsync.pipelines.georef.read_table_slice", spy)
    out = tmp_path / "geo.laz"
    georeference_file(src, tmp_path / "traj.csv", MOUNT, out, chunk_points=700)
    assert columns_read == [["t_s"], ["t_s"]]  # the first and the last slice
    assert laspy.read(out).header.point_count == n
