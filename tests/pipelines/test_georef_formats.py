"""``georeference_file`` between formats: LAS/LAZ <-> CSV/Parquet, PLY, column maps."""

from __future__ import annotations

from pathlib import Path

import laspy
import numpy as np
import pyarrow.csv as pa_csv
import pyarrow.parquet as pq
import pytest
from tests._las import las_points

from kinsync.crs import ecef_to_crs_transformer
from kinsync.errors import InputError
from kinsync.georef import GeorefTrajectory, georeference
from kinsync.io.column_map import parse_column_map
from kinsync.io.las import las_info
from kinsync.io.ply import read_ply_vertices
from kinsync.io.points import TableChunkWriter
from kinsync.io.trajectory_csv import write_trajectory_csv
from kinsync.mount import Mount
from kinsync.pipelines.georef import georeference_file
from kinsync.trajectory import Trajectory

T0 = 1.3e9
MOUNT = Mount(lever_arm_body_m=(0.5, 0.1, -1.0), boresight_rpy_deg=(0.5, -0.3, 90.0))
N = 1_200
CRS = "EPSG:32619"
KEYS = ("t_s", "x_m", "y_m", "z_m", "range_m", "angle_rad")


def _trajectory() -> Trajectory:
    t = T0 + np.arange(0.0, 10.0, 0.01)
    s = t - T0
    llh = np.column_stack([46.8 + 1e-5 * s, -71.2 + 2e-5 * s, 10.0 + 0.1 * s])
    return Trajectory.from_euler(
        t, 0.02 * np.sin(s), 0.01 * np.cos(s), 0.3 + 0.05 * s, lat_lon_h=llh
    )


def _columns(seed: int, t_lo: float = 0.1) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    return {
        "t_s": T0 + np.sort(rng.uniform(t_lo, 9.9, N)),
        "x_m": rng.uniform(-1, 1, N),
        "y_m": rng.uniform(-20, 20, N),
        "z_m": rng.uniform(-5, 5, N),
        "intensity": rng.integers(0, 1000, N),
        "amplitude": rng.normal(size=N),
        "label": np.array(["a", "b"] * (N // 2)),
    }


def _expected(cols: dict[str, np.ndarray], crs: str = CRS) -> tuple[np.ndarray, np.ndarray]:
    """Coordinates in ``crs`` of the points inside the span, and the inside mask."""
    gt = GeorefTrajectory.from_trajectory(_trajectory(), MOUNT.latency_s)
    xyz = np.column_stack([cols["x_m"], cols["y_m"], cols["z_m"]])
    pos, inside = georeference(cols["t_s"], xyz, gt, MOUNT)
    to_crs = ecef_to_crs_transformer(crs)
    assert to_crs is not None
    return to_crs(pos[inside]), inside


def _write_las(path: Path, cols: dict[str, np.ndarray]) -> None:
    las = las_points(cols)
    las.intensity = cols["intensity"].astype(np.uint16)
    las.classification = (cols["intensity"] % 7).astype(np.uint8)
    las.write(path)


@pytest.fixture
def traj_path(tmp_path: Path) -> Path:
    path = tmp_path / "traj.csv"
    write_trajectory_csv(_trajectory(), path)
    return path


def _stored_las_columns(path: Path) -> dict[str, np.ndarray]:
    """The LAS points as they are stored (0.1 mm coordinates)."""
    las = laspy.read(path)
    return {
        "t_s": np.asarray(las.gps_time) + 1e9,
        "x_m": np.asarray(las.x),
        "y_m": np.asarray(las.y),
        "z_m": np.asarray(las.z),
    }


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_las_to_table_has_every_dimension_and_exact_coordinates(
    tmp_path: Path, traj_path: Path, suffix: str
) -> None:
    cols = _columns(1)
    src = tmp_path / "scan.laz"
    _write_las(src, cols)
    out = tmp_path / f"geo{suffix}"
    summary = georeference_file(src, traj_path, MOUNT, out, crs=CRS, chunk_points=500)
    assert summary.points_in == summary.points_out == N
    table = pa_csv.read_csv(out) if suffix == ".csv" else pq.read_table(out)
    names = table.column_names
    assert names[:3] == ["X", "Y", "Z"]
    assert {"intensity", "classification", "return_number", "gps_time"} <= set(names)
    np.testing.assert_array_equal(table.column("intensity").to_numpy(), cols["intensity"])
    np.testing.assert_array_equal(table.column("classification").to_numpy(), cols["intensity"] % 7)
    stored = _stored_las_columns(src)
    np.testing.assert_array_equal(table.column("gps_time").to_numpy() + 1e9, stored["t_s"])
    expected, inside = _expected(stored)
    assert inside.all()
    got = np.column_stack([table.column(c).to_numpy() for c in ("X", "Y", "Z")])
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9)


@pytest.mark.parametrize("suffix", [".csv", ".parquet", ".ply"])
def test_scaled_extra_dimensions_are_written_as_their_real_values(
    tmp_path: Path, traj_path: Path, suffix: str
) -> None:
    """An int16 extra dimension with scale 0.01 holds 0.12, not 0: float64 out."""
    n = 10
    cols = {k: v[:n] for k, v in _columns(11).items()}
    las = las_points(cols)
    las.add_extra_dims(
        [
            laspy.ExtraBytesParams("refl", "i2", scales=np.array([0.01]), offsets=np.array([0.0])),
            laspy.ExtraBytesParams(
                "shift", "u1", scales=np.array([1.0]), offsets=np.array([100.0])
            ),
            laspy.ExtraBytesParams("raw", "i2"),
        ]
    )
    las.refl = np.arange(n) * 0.12
    las.shift = 100.0 + np.arange(n)
    las.raw = np.arange(n, dtype=np.int16) - 3
    src = tmp_path / "scan.las"
    las.write(src)
    out = tmp_path / f"geo{suffix}"
    georeference_file(src, traj_path, MOUNT, out, crs=CRS)
    if suffix == ".ply":
        got = read_ply_vertices(out)
    else:
        table = pa_csv.read_csv(out) if suffix == ".csv" else pq.read_table(out)
        got = {c: table.column(c).to_numpy() for c in ("refl", "shift", "raw")}
    assert got["refl"].dtype == got["shift"].dtype == np.float64
    np.testing.assert_allclose(got["refl"], np.arange(n) * 0.12, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(got["shift"], 100.0 + np.arange(n))
    assert got["raw"].dtype.kind == "i"  # unscaled: its own type (int16; CSV reads int64)
    np.testing.assert_array_equal(got["raw"], np.arange(n) - 3)


def test_las_to_csv_rejects_to_a_las_file_in_the_input_format(
    tmp_path: Path, traj_path: Path
) -> None:
    cols = _columns(2, t_lo=-2.0)  # points before the trajectory starts
    src = tmp_path / "scan.las"
    _write_las(src, cols)
    out = tmp_path / "geo.csv"
    summary = georeference_file(src, traj_path, MOUNT, out, crs=CRS, outside="reject")
    n_out = int((cols["t_s"] >= T0).sum())
    assert 0 < n_out < N
    assert (summary.points_out, summary.points_rejected) == (n_out, N - n_out)
    assert summary.rejected_path == tmp_path / "geo.csv.rejected.las"
    rejected = laspy.read(summary.rejected_path)
    assert len(rejected.points) + pa_csv.read_csv(out).num_rows == N
    np.testing.assert_array_equal(
        np.asarray(rejected.intensity), cols["intensity"][cols["t_s"] < T0]
    )


@pytest.mark.parametrize("suffix", [".las", ".laz"])
def test_table_to_las_stores_time_attributes_and_coordinates(
    tmp_path: Path, traj_path: Path, suffix: str
) -> None:
    cols = _columns(3)
    src = tmp_path / "points.parquet"
    with TableChunkWriter(src) as w:
        w.write(cols)
    out = tmp_path / f"geo{suffix}"
    summary = georeference_file(src, traj_path, MOUNT, out, crs=CRS, chunk_points=400)
    assert summary.points_out == N
    assert any("['label']" in w and "LAS cannot store" in w for w in summary.warnings)
    las = laspy.read(out)
    assert las.header.point_format.id == 6
    np.testing.assert_array_equal(np.asarray(las.intensity), cols["intensity"])
    np.testing.assert_array_equal(np.asarray(las["amplitude"]), cols["amplitude"])
    np.testing.assert_allclose(np.asarray(las.gps_time) + 1e9, cols["t_s"], rtol=0, atol=1e-6)
    expected, _ = _expected(cols)
    got = np.column_stack([np.asarray(las.x), np.asarray(las.y), np.asarray(las.z)])
    assert np.abs(got - expected).max() <= 0.5e-4 + 1e-9
    info = las_info(out)
    assert info.crs_wkt is not None


@pytest.mark.parametrize("given", ["none", "return_number"])
def test_table_to_las_without_returns_gives_single_returns(
    tmp_path: Path, traj_path: Path, given: str
) -> None:
    """LAS numbers returns 1 to 15: a table without them is 1 of 1, not 0 of 0."""
    cols = {k: v for k, v in _columns(12).items() if k in KEYS}
    if given == "return_number":
        cols["return_number"] = np.where(np.arange(N) % 3 == 0, 2, 1)
    src = tmp_path / "points.csv"
    with TableChunkWriter(src) as w:
        w.write(cols)
    out = tmp_path / "geo.laz"
    georeference_file(src, traj_path, MOUNT, out, crs=CRS, chunk_points=500)
    las = laspy.read(out)
    returns = np.asarray(las.return_number)
    if given == "none":
        assert (returns == 1).all()
    else:
        np.testing.assert_array_equal(returns, cols["return_number"])
    np.testing.assert_array_equal(np.asarray(las.number_of_returns), returns)
    by_return = list(las.header.number_of_points_by_return[:3])
    assert by_return == [int((returns == r).sum()) for r in (1, 2, 3)]


def test_table_to_las_refuses_an_intensity_that_does_not_fit(
    tmp_path: Path, traj_path: Path
) -> None:
    cols = _columns(4)
    cols["intensity"][5] = 70_000
    src = tmp_path / "points.csv"
    with TableChunkWriter(src) as w:
        w.write(cols)
    out = tmp_path / "geo.las"
    with pytest.raises(InputError, match=r"points\.csv: line 7, column 'intensity': 70000 does"):
        georeference_file(src, traj_path, MOUNT, out, crs=CRS)
    assert not out.exists()


@pytest.mark.parametrize(
    ("name", "value", "suffix"),
    [("Y", 1000, ".laz"), ("Y", 1000.5, ".las"), ("z", 7, ".las"), ("X", 0.25, ".laz")],
)
def test_table_to_las_refuses_a_column_named_as_a_coordinate(
    tmp_path: Path, traj_path: Path, name: str, value: float, suffix: str
) -> None:
    """LAS stores the georeferenced coordinates in X, Y, Z: a carried ``Y`` was lost."""
    cols = _columns(13)
    cols[name] = np.full(N, value)
    src = tmp_path / "points.csv"
    with TableChunkWriter(src) as w:
        w.write(cols)
    out = tmp_path / f"geo{suffix}"
    match = rf"points\.csv: column '{name}' would clash with the output coordinates X, Y, Z"
    with pytest.raises(InputError, match=match):
        georeference_file(src, traj_path, MOUNT, out, crs=CRS)
    assert not out.exists()


def test_table_to_las_names_the_range_of_a_flag(tmp_path: Path, traj_path: Path) -> None:
    cols = _columns(14)
    cols["synthetic"] = np.where(np.arange(N) == 3, 2, 0)
    src = tmp_path / "points.csv"
    with TableChunkWriter(src) as w:
        w.write(cols)
    match = r"line 5, column 'synthetic': 2 does not fit the LAS synthetic dimension \(0 or 1\)"
    with pytest.raises(InputError, match=match):
        georeference_file(src, traj_path, MOUNT, tmp_path / "geo.las", crs=CRS)


def test_table_to_las_refuses_part_of_an_rgb_triple(tmp_path: Path, traj_path: Path) -> None:
    cols = _columns(5)
    cols["red"] = np.zeros(N, dtype=np.int64)
    src = tmp_path / "points.csv"
    with TableChunkWriter(src) as w:
        w.write(cols)
    with pytest.raises(InputError, match="LAS stores colour as all three"):
        georeference_file(src, traj_path, MOUNT, tmp_path / "geo.las", crs=CRS)


@pytest.mark.parametrize("source", ["table", "las"])
def test_ply_output_reads_back_with_every_numeric_attribute(
    tmp_path: Path, traj_path: Path, source: str
) -> None:
    cols = _columns(6, t_lo=-1.0)
    if source == "las":
        src = tmp_path / "scan.las"
        _write_las(src, cols)
        stored = _stored_las_columns(src)
    else:
        src = tmp_path / "points.csv"
        with TableChunkWriter(src) as w:
            w.write(cols)
        stored = cols
    out = tmp_path / "geo.ply"
    summary = georeference_file(src, traj_path, MOUNT, out, crs=CRS, outside="reject")
    expected, inside = _expected(stored)
    assert summary.points_out == int(inside.sum()) < N
    ply = read_ply_vertices(out)
    assert list(ply)[:3] == ["x", "y", "z"]
    got = np.column_stack([ply["x"], ply["y"], ply["z"]])
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(ply["intensity"], cols["intensity"][inside])
    if source == "table":
        np.testing.assert_array_equal(ply["t_s"], cols["t_s"][inside])
        np.testing.assert_array_equal(ply["amplitude"], cols["amplitude"][inside])
        assert "label" not in ply
        assert summary.rejected_path == tmp_path / "geo.ply.rejected.csv"
    else:
        np.testing.assert_array_equal(ply["gps_time"] + 1e9, stored["t_s"][inside])
        assert summary.rejected_path == tmp_path / "geo.ply.rejected.las"


def test_outputs_of_one_name_and_two_formats_keep_their_own_rejected_files(
    tmp_path: Path, traj_path: Path
) -> None:
    # geo.csv and geo.las from one CSV input both rejected to geo.rejected.csv: the second
    # run removed (or replaced) the first run's rejected points.
    cols = _columns(2, t_lo=-2.0)  # points before the trajectory starts
    src = tmp_path / "scan.csv"
    with TableChunkWriter(src) as writer:
        writer.write(cols)
    table = georeference_file(src, traj_path, MOUNT, tmp_path / "geo.csv", outside="reject")
    las = georeference_file(src, traj_path, MOUNT, tmp_path / "geo.las", outside="reject")
    assert table.rejected_path == tmp_path / "geo.rejected.csv"
    assert las.rejected_path == tmp_path / "geo.las.rejected.csv"
    assert table.points_rejected == las.points_rejected > 0
    assert table.rejected_path.read_bytes() == las.rejected_path.read_bytes()
    inside = tmp_path / "inside.csv"  # a rerun to geo.las that rejects nothing
    with TableChunkWriter(inside) as writer:
        writer.write(_columns(3))
    rerun = georeference_file(inside, traj_path, MOUNT, tmp_path / "geo.las", outside="reject")
    assert rerun.points_rejected == 0
    assert not las.rejected_path.exists()  # its own earlier rejected file is removed
    assert table.rejected_path.exists()  # another output's is left alone


def test_a_column_map_reads_other_names_and_keeps_them(tmp_path: Path, traj_path: Path) -> None:
    cols = _columns(7)
    theirs = {"time": cols["t_s"], "sx": cols["x_m"], "sy": cols["y_m"], "sz": cols["z_m"]}
    theirs |= {"intensity": cols["intensity"]}
    src = tmp_path / "points.csv"
    with TableChunkWriter(src) as w:
        w.write(theirs)
    mapping = parse_column_map("t_s=time, x_m=sx,y_m=sy,z_m=sz", KEYS)
    out = tmp_path / "geo.csv"
    georeference_file(src, traj_path, MOUNT, out, crs=CRS, columns=mapping, chunk_points=300)
    table = pa_csv.read_csv(out)
    assert table.column_names == ["time", "X", "Y", "Z", "intensity"]
    expected, _ = _expected(cols)
    got = np.column_stack([table.column(c).to_numpy() for c in ("X", "Y", "Z")])
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9)
    las_out = tmp_path / "geo.las"
    georeference_file(src, traj_path, MOUNT, las_out, crs=CRS, columns=mapping)
    las = laspy.read(las_out)
    np.testing.assert_allclose(np.asarray(las.gps_time) + 1e9, cols["t_s"], rtol=0, atol=1e-6)


def test_a_column_map_on_a_las_input_is_refused(tmp_path: Path, traj_path: Path) -> None:
    src = tmp_path / "scan.las"
    _write_las(src, _columns(8))
    mapping = parse_column_map("t_s=time", KEYS)
    with pytest.raises(InputError, match="maps the columns of CSV/Parquet tables"):
        georeference_file(src, traj_path, MOUNT, tmp_path / "g.csv", columns=mapping)


def test_a_map_onto_a_name_the_file_already_has_is_refused(tmp_path: Path, traj_path: Path) -> None:
    cols = _columns(9)
    cols["time"] = cols["t_s"] + 0.0
    src = tmp_path / "points.csv"
    with TableChunkWriter(src) as w:
        w.write(cols)
    mapping = parse_column_map("t_s=time", KEYS)
    with pytest.raises(InputError, match="has a column 't_s' of its own"):
        georeference_file(src, traj_path, MOUNT, tmp_path / "g.csv", columns=mapping)


@pytest.mark.parametrize(
    ("src_name", "out_name"),
    [("scan.las", "geo.csv"), ("p.csv", "geo.las"), ("p.csv", "geo.ply"), ("scan.las", "geo.ply")],
)
def test_an_input_without_points_gives_an_empty_output(
    tmp_path: Path, traj_path: Path, src_name: str, out_name: str
) -> None:
    cols = {k: v[:0] for k, v in _columns(10).items()}
    src = tmp_path / src_name
    if src.suffix == ".las":
        _write_las(src, cols)
    else:
        with TableChunkWriter(src) as w:
            w.write(cols)
    out = tmp_path / out_name
    summary = georeference_file(src, traj_path, MOUNT, out, crs=CRS)
    assert summary.points_in == summary.points_out == 0
    if out.suffix == ".csv":
        assert pa_csv.read_csv(out).num_rows == 0
        assert "X" in pa_csv.read_csv(out).column_names
    elif out.suffix == ".las":
        assert len(laspy.read(out).points) == 0
    else:
        assert len(read_ply_vertices(out)["x"]) == 0


def test_worker_processes_write_the_serial_las_and_ply_from_a_table(
    tmp_path: Path, traj_path: Path
) -> None:
    cols = _columns(11, t_lo=-1.0)
    src = tmp_path / "points.csv"
    with TableChunkWriter(src) as w:
        w.write(cols)
    for suffix in (".laz", ".ply"):
        serial, parallel = tmp_path / f"s{suffix}", tmp_path / f"p{suffix}"
        for out, scheduler in ((serial, "local"), (parallel, "processes")):
            georeference_file(
                src,
                traj_path,
                MOUNT,
                out,
                crs=CRS,
                outside="reject",
                chunk_points=300,
                scheduler=scheduler,
                workers=2,
            )
        if suffix == ".laz":
            a, b = laspy.read(serial), laspy.read(parallel)
            np.testing.assert_array_equal(a.points.array, b.points.array)
        else:
            assert serial.read_bytes() == parallel.read_bytes()
