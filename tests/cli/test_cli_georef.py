"""``kinsync georef``: tables and LAS/LAZ through the streaming pipeline."""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import laspy
import numpy as np
import pyarrow as pa
import pyarrow.csv as pa_csv
import pyarrow.parquet as pq
import pyproj
import pytest
from tests._las import las_points

from kinsync.frames import ecef_to_geodetic, euler_rpy_to_matrix
from kinsync.georef import GeorefTrajectory, georeference
from kinsync.io.las import las_info
from kinsync.io.mount_file import write_mount
from kinsync.io.points import TableChunkWriter
from kinsync.io.sbet import write_sbet
from kinsync.io.trajectory_csv import read_trajectory_csv, write_trajectory_csv
from kinsync.mount import Mount
from kinsync.sim.turning_scan import TurningVehicle
from kinsync.trajectory import Trajectory

RunCli = Callable[[list[str]], tuple[int, str, str]]  # fixture run_cli in conftest.py
OneLineError = Callable[..., None]  # fixture assert_one_line_error in conftest.py

T0 = 1.3e9  # GPS seconds
MOUNT = Mount(lever_arm_body_m=(0.5, 0.1, -1.0), boresight_rpy_deg=(0.5, -0.3, 90.0))
N_POINTS = 2_500


def _trajectory() -> Trajectory:
    t = T0 + np.arange(0.0, 10.0, 0.01)
    s = t - T0
    lat = 46.8 + 1e-5 * s
    lon = -71.2 + 2e-5 * s
    llh = np.column_stack([lat, lon, 10.0 + 0.1 * s])
    roll = 0.02 * np.sin(s)
    pitch = 0.01 * np.cos(0.5 * s)
    yaw = 0.3 + 0.05 * s
    return Trajectory.from_euler(t, roll, pitch, yaw, lat_lon_h=llh)


def _points(
    rng: np.random.Generator, t_lo: float = 0.1, t_hi: float = 9.9
) -> dict[str, np.ndarray]:
    t = T0 + np.sort(rng.uniform(t_lo, t_hi, N_POINTS))
    return {
        "t_s": t,
        "x_m": rng.uniform(-1, 1, N_POINTS),
        "y_m": rng.uniform(-20, 20, N_POINTS),
        "z_m": rng.uniform(-5, 5, N_POINTS),
        "intensity": rng.integers(0, 1000, N_POINTS),
        "label": np.array(["a", "b"] * (N_POINTS // 2)),
    }


@pytest.fixture
def setup(tmp_path: Path) -> dict[str, Path]:
    traj = _trajectory()
    write_trajectory_csv(traj, tmp_path / "traj.csv")
    write_mount(MOUNT, tmp_path / "mount.toml")
    cols = _points(np.random.default_rng(3))
    with TableChunkWriter(tmp_path / "points.csv") as w:
        w.write(cols)
    return {
        "dir": tmp_path,
        "traj": tmp_path / "traj.csv",
        "mount": tmp_path / "mount.toml",
        "points": tmp_path / "points.csv",
    }


def _expected_ecef(traj_path: Path, t: np.ndarray, xyz: np.ndarray, mount: Mount) -> np.ndarray:
    gt = GeorefTrajectory.from_trajectory(read_trajectory_csv(traj_path), mount.latency_s)
    out, inside = georeference(t, xyz, gt, mount)
    assert inside.all()
    return out


def _args(s: dict[str, Path], out: Path, *extra: str) -> list[str]:
    return [
        "georef",
        "--points",
        str(s["points"]),
        "--trajectory",
        str(s["traj"]),
        "--mount",
        str(s["mount"]),
        "--out",
        str(out),
        *extra,
    ]


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_table_to_table_keeps_columns_and_matches_kernel(
    run_cli: RunCli, setup: dict[str, Path], suffix: str
) -> None:
    out = setup["dir"] / f"geo{suffix}"
    code, stdout, err = run_cli(_args(setup, out, "--json", "--chunk-points", "700"))
    assert code == 0, err
    doc = json.loads(stdout)
    assert doc["points_in"] == doc["points_out"] == N_POINTS
    assert doc["points_rejected"] == 0
    assert set(doc) == {
        "points_in",
        "points_out",
        "points_rejected",
        "rejected_file",
        "seconds",
        "points_per_s",
        "crs",
        "gap_threshold_s",
        "mount",
        "warnings",
        "provenance",
    }
    assert doc["warnings"] == []
    assert set(doc["provenance"]) == {"software", "command", "utc"}
    assert doc["provenance"]["command"].startswith("kinsync georef --points ")
    assert doc["provenance"]["utc"] == "2023-11-14T22:13:20Z"  # tests' SOURCE_DATE_EPOCH
    assert doc["rejected_file"] is None
    assert doc["mount"] == {
        "lever_arm_body_m": [0.5, 0.1, -1.0],
        "boresight_rpy_deg": [0.5, -0.3, 90.0],
        "latency_s": 0.0,
        "profiler_azimuth_deg": None,
    }
    # the gap threshold used: 10 median record intervals of the trajectory
    t_rec = read_trajectory_csv(setup["traj"]).t_s
    assert doc["gap_threshold_s"] == pytest.approx(10.0 * float(np.median(np.diff(t_rec))))
    assert doc["crs"]["target"] == "WGS 84 (EPSG:4978)"
    assert doc["crs"]["heights"].startswith("none")
    table = pq.read_table(out) if suffix == ".parquet" else None
    if table is None:
        table = pa_csv.read_csv(out)
    assert table.column_names == ["t_s", "X", "Y", "Z", "intensity", "label"]
    cols = _points(np.random.default_rng(3))
    xyz = np.column_stack([cols["x_m"], cols["y_m"], cols["z_m"]])
    expected = _expected_ecef(setup["traj"], cols["t_s"], xyz, MOUNT)
    got = np.column_stack([table.column(c).to_numpy() for c in ("X", "Y", "Z")])
    assert np.abs(got - expected).max() < 1e-6
    # A CSV's other columns are carried as their text (a Parquet output holds strings).
    intensity = [int(v) for v in table.column("intensity").to_pylist()]
    assert intensity == cols["intensity"].tolist()
    np.testing.assert_array_equal(table.column("label").to_pylist(), cols["label"].tolist())


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_a_table_without_points_gives_an_empty_output_with_every_column(
    run_cli: RunCli, setup: dict[str, Path], suffix: str
) -> None:
    cols = {k: v[:0] for k, v in _points(np.random.default_rng(3)).items()}
    cols["intensity"] = cols["intensity"].astype(np.int16)
    empty = setup["dir"] / f"empty{suffix}"
    if suffix == ".csv":
        empty.write_text("t_s,x_m,y_m,z_m,intensity,label\n")
    else:
        pq.write_table(pa.table(cols), empty)
    out = setup["dir"] / f"geo{suffix}"
    code, stdout, err = run_cli([*_args({**setup, "points": empty}, out), "--json"])
    assert code == 0, err
    doc = json.loads(stdout)
    assert (doc["points_in"], doc["points_out"], doc["points_rejected"]) == (0, 0, 0)
    table = pq.read_table(out) if suffix == ".parquet" else pa_csv.read_csv(out)
    assert table.num_rows == 0
    assert table.column_names == ["t_s", "X", "Y", "Z", "intensity", "label"]
    if suffix == ".parquet":  # the types a chunk would have: carried columns unchanged
        assert [str(t) for t in table.schema.types] == [
            "double",
            "double",
            "double",
            "double",
            "int16",
            "string",
        ]


@pytest.mark.parametrize("suffix", [".las", ".laz"])
def test_a_table_without_points_gives_a_las_file_without_points(
    run_cli: RunCli, setup: dict[str, Path], suffix: str
) -> None:
    """As for a table output (and ``sync apply``): a valid file, not an error."""
    empty = setup["dir"] / "empty.csv"
    empty.write_text("t_s,x_m,y_m,z_m,intensity\n")
    out = setup["dir"] / f"geo{suffix}"
    code, stdout, err = run_cli([*_args({**setup, "points": empty}, out), "--json"])
    assert code == 0, err
    assert json.loads(stdout)["points_out"] == 0
    assert las_info(out).point_count == 0
    assert las_info(out).crs_wkt is not None


def test_a_csv_with_cr_line_ends_gives_every_point_and_rejects_its_own_lines(
    run_cli: RunCli, setup: dict[str, Path]
) -> None:
    """Old Mac line ends (CR alone): once read as a header and no point, exit 0."""
    cols = _points(np.random.default_rng(4), t_lo=-1.0, t_hi=9.9)
    n_outside = int(np.count_nonzero(cols["t_s"] < T0))
    with TableChunkWriter(setup["points"]) as w:
        w.write(cols)
    lf = setup["points"].read_bytes()
    cr = setup["dir"] / "cr.csv"
    cr.write_bytes(lf.replace(b"\n", b"\r"))
    want, got = setup["dir"] / "lf_geo.csv", setup["dir"] / "cr_geo.csv"
    for points, out in ((setup["points"], want), (cr, got)):
        args = _args({**setup, "points": points}, out, "--outside", "reject", "--json")
        code, stdout, err = run_cli([*args, "--chunk-points", "600"])
        assert code == 0, err
        doc = json.loads(stdout)
        assert (doc["points_in"], doc["points_rejected"]) == (N_POINTS, n_outside)
    assert got.read_bytes() == want.read_bytes()
    rejected = (setup["dir"] / "cr_geo.rejected.csv").read_bytes()
    assert rejected == (setup["dir"] / "lf_geo.rejected.csv").read_bytes().replace(b"\n", b"\r")


@pytest.mark.parametrize("which", ["points", "traj"])
def test_a_byte_that_is_not_utf8_near_the_top_is_named_by_its_line(
    run_cli: RunCli, setup: dict[str, Path], assert_one_line_error: OneLineError, which: str
) -> None:
    """Line 6, within the first 8 KiB, was blamed on the header ("cannot read the header
    ('utf-8' codec can't decode ...)"); line 191 was named."""
    lines = setup[which].read_bytes().split(b"\n")
    lines[5] = lines[5][:-1] + b"\xe9"
    setup[which].write_bytes(b"\n".join(lines))
    out = setup["dir"] / "geo.csv"
    code, stdout, err = run_cli(_args(setup, out))
    assert_one_line_error(code, stdout, err, f"{setup[which]}: line 6: byte 0xE9 is not UTF-8")
    assert not out.exists()


def test_latency_option_and_geographic_crs(run_cli: RunCli, setup: dict[str, Path]) -> None:
    out = setup["dir"] / "geo.parquet"
    code, stdout, err = run_cli(
        _args(setup, out, "--latency-ms", "12.5", "--crs", "EPSG:4979", "--json")
    )
    assert code == 0, err
    # the JSON log says which latency was applied: the option's, not the mount file's
    assert json.loads(stdout)["mount"]["latency_s"] == pytest.approx(0.0125, abs=1e-15)
    cols = _points(np.random.default_rng(3))
    xyz = np.column_stack([cols["x_m"], cols["y_m"], cols["z_m"]])
    mount = MOUNT.with_latency(0.0125)
    llh = ecef_to_geodetic(_expected_ecef(setup["traj"], cols["t_s"], xyz, mount))
    table = pq.read_table(out)
    np.testing.assert_allclose(table.column("X").to_numpy(), llh[:, 1], atol=1e-10)  # lon first
    np.testing.assert_allclose(table.column("Y").to_numpy(), llh[:, 0], atol=1e-10)
    np.testing.assert_allclose(table.column("Z").to_numpy(), llh[:, 2], atol=1e-6)


def test_outside_span_error_and_reject(
    run_cli: RunCli, setup: dict[str, Path], assert_one_line_error: OneLineError
) -> None:
    cols = _points(np.random.default_rng(4), t_lo=-1.0, t_hi=9.9)
    n_out = int(np.count_nonzero(cols["t_s"] < T0))
    assert n_out > 0
    with TableChunkWriter(setup["points"]) as w:
        w.write(cols)
    out = setup["dir"] / "geo.csv"
    code, stdout, err = run_cli(_args(setup, out, "--chunk-points", "500"))
    assert_one_line_error(code, stdout, err, f"{n_out} point(s)", "outside the trajectory span")
    assert not out.exists()
    assert list(setup["dir"].glob("*.part")) == []
    code, stdout, err = run_cli(_args(setup, out, "--outside", "reject", "--json"))
    assert code == 0, err
    doc = json.loads(stdout)
    assert doc["points_rejected"] == n_out
    assert doc["points_out"] == N_POINTS - n_out
    assert doc["rejected_file"] == str(setup["dir"] / "geo.rejected.csv")
    rejected = pa_csv.read_csv(setup["dir"] / "geo.rejected.csv")
    assert rejected.num_rows == n_out
    assert rejected.column_names == list(cols)
    assert (rejected.column("t_s").to_numpy() < T0).all()


def test_a_mount_warning_is_listed_in_the_json(run_cli: RunCli, setup: dict[str, Path]) -> None:
    """The mount file's "beyond +-100 m" warning, printed on stderr, is in --json too."""
    far = replace(MOUNT, lever_arm_body_m=(0.5, 0.1, -175.0))
    write_mount(far, setup["mount"])
    code, stdout, err = run_cli(_args(setup, setup["dir"] / "geo.csv", "--json"))
    assert code == 0, err
    printed = [
        line.removeprefix("kinsync: warning: ")
        for line in err.splitlines()
        if line.startswith("kinsync: warning: ")
    ]
    assert len(printed) == 1, err
    assert "beyond +-100 m" in printed[0]
    assert json.loads(stdout)["warnings"] == printed


def _write_las(path: Path, cols: dict[str, np.ndarray], *, adjusted: bool) -> None:
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales = np.array([1e-4, 1e-4, 1e-4])
    header.offsets = np.zeros(3)
    if adjusted:
        header.global_encoding.gps_time_type = laspy.header.GpsTimeType.STANDARD
    las = laspy.LasData(header)
    las.x, las.y, las.z = cols["x_m"], cols["y_m"], cols["z_m"]
    las.gps_time = cols["t_s"] - (1e9 if adjusted else 0.0)
    las.intensity = cols["intensity"].astype(np.uint16)
    las.write(path)


def test_las_to_laz_keeps_attributes_and_writes_crs(
    run_cli: RunCli, setup: dict[str, Path]
) -> None:
    cols = _points(np.random.default_rng(5))
    src = setup["dir"] / "scan.las"
    _write_las(src, cols, adjusted=True)
    setup["points"] = src
    out = setup["dir"] / "geo.laz"
    code, stdout, err = run_cli(_args(setup, out, "--json", "--chunk-points", "1000"))
    assert code == 0, err
    assert json.loads(stdout)["points_out"] == N_POINTS
    las = laspy.read(out)
    assert len(las.points) == N_POINTS
    np.testing.assert_array_equal(np.asarray(las.intensity), cols["intensity"])
    np.testing.assert_allclose(np.asarray(las.gps_time), cols["t_s"] - 1e9, rtol=0, atol=1e-6)
    stored = laspy.read(src)
    t = np.asarray(stored.gps_time) + 1e9
    xyz = np.column_stack([np.asarray(stored.x), np.asarray(stored.y), np.asarray(stored.z)])
    expected = _expected_ecef(setup["traj"], t, xyz, MOUNT)
    got = np.column_stack([np.asarray(las.x), np.asarray(las.y), np.asarray(las.z)])
    assert np.abs(got - expected).max() <= 0.5e-4 + 1e-9
    info = las_info(out)
    assert info.crs_wkt is not None
    assert pyproj.CRS.from_wkt(info.crs_wkt).equals(pyproj.CRS.from_epsg(4978))


def test_las_output_of_a_too_long_trajectory_says_to_split_the_file(
    run_cli: RunCli, setup: dict[str, Path], assert_one_line_error: OneLineError
) -> None:
    # An aircraft line of 600 km in 2000 s: ECEF at 0.1 mm reaches 214 km from the
    # offsets (the middle of the file's span), so the ends cannot be stored.
    t = T0 + np.linspace(0.0, 2000.0, 201)
    s = (t - T0) / 2000.0
    llh = np.column_stack([46.8 + 0.0 * s, -74.0 + 7.9 * s, 3000.0 + 0.0 * s])
    traj = Trajectory.from_euler(t, 0.0 * s, 0.0 * s, 0.0 * s + np.pi / 2, lat_lon_h=llh)
    write_trajectory_csv(traj, setup["traj"])
    n = 200
    cols = {
        "t_s": T0 + np.linspace(1.0, 1999.0, n),
        "x_m": np.zeros(n),
        "y_m": np.zeros(n),
        "z_m": np.full(n, 100.0),
        "intensity": np.zeros(n, dtype=np.int64),
    }
    src = setup["dir"] / "long.las"
    _write_las(src, cols, adjusted=True)
    setup["points"] = src
    out = setup["dir"] / "geo.las"
    code, stdout, err = run_cli(_args(setup, out))
    assert_one_line_error(
        code,
        stdout,
        err,
        "long.las: point 1 of 200 georeferences",
        " m from the file's reference position",
        "reach only 214748 m either way",
        "split the file into shorter time spans",
    )
    assert not out.exists()


def test_an_already_georeferenced_las_is_said_to_be_so_and_the_count_is_the_chunks(
    run_cli: RunCli, setup: dict[str, Path], assert_one_line_error: OneLineError
) -> None:
    # UTM coordinates where scanner-frame ones belong: the count covers the chunk read
    # (it read like a total), and the file's CRS says why.
    cols = _points(np.random.default_rng(8))
    cols["x_m"] = cols["x_m"] + 330_000.0
    cols["y_m"] = cols["y_m"] + 5_190_000.0
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales = np.array([1e-3, 1e-3, 1e-3])
    header.offsets = np.array([330_000.0, 5_190_000.0, 0.0])
    header.global_encoding.gps_time_type = laspy.header.GpsTimeType.STANDARD
    header.add_crs(pyproj.CRS.from_epsg(32619))
    las = laspy.LasData(header)
    las.x, las.y, las.z = cols["x_m"], cols["y_m"], cols["z_m"]
    las.gps_time = cols["t_s"] - 1e9
    src = setup["dir"] / "utm.las"
    las.write(src)
    setup["points"] = src
    out = setup["dir"] / "geo.las"
    code, stdout, err = run_cli(_args(setup, out, "--chunk-points", "1000"))
    assert_one_line_error(
        code,
        stdout,
        err,
        "utm.las: point 1 of 2500",
        "1000 such point(s) in the chunk of points 1..1000 of 2500 (the rest of the file not "
        "checked)",
        "this file is already georeferenced (EPSG:32619); --points takes points in the "
        "scanner frame",
    )
    assert not out.exists()


def test_a_time_dependent_output_warns_that_the_file_does_not_record_its_epoch(
    run_cli: RunCli, setup: dict[str, Path]
) -> None:
    out = setup["dir"] / "geo.parquet"
    argv = _args(setup, out, "--trajectory-crs", "EPSG:7789", "--crs", "EPSG:22819")
    code, _, err = run_cli(argv)
    assert code == 0, err
    (warning,) = [line for line in err.splitlines() if "coordinate epoch" in line]
    assert warning.startswith("kinsync: warning: ")
    assert "which the file does not record" in warning
    assert "keep the epoch with the file" in warning
    code, _, err = run_cli(_args(setup, out, "--crs", "EPSG:32619"))
    assert code == 0, err
    assert "coordinate epoch" not in err


def test_sbet_week_time_with_las_adjusted_time_needs_gps_week(
    run_cli: RunCli, setup: dict[str, Path], assert_one_line_error: OneLineError
) -> None:
    traj = _trajectory()
    sbet = setup["dir"] / "traj.out"
    write_sbet(traj, sbet)
    cols = _points(np.random.default_rng(6))
    src = setup["dir"] / "scan.las"
    _write_las(src, cols, adjusted=True)
    setup["points"], setup["traj"] = src, sbet
    out = setup["dir"] / "geo.las"
    code, stdout, err = run_cli(_args(setup, out))
    assert_one_line_error(code, stdout, err, "--gps-week")
    week = int(T0 // 604800)
    code, stdout, err = run_cli(_args(setup, out, "--gps-week", str(week), "--json"))
    assert code == 0, err
    assert json.loads(stdout)["points_out"] == N_POINTS


@pytest.mark.parametrize(
    ("change", "fragments"),
    [
        ("out_suffix", ["unknown output type", ".txt"]),
        ("missing_column", ["z_m"]),
        ("nan", ["not finite"]),
        ("absurd", ["points.csv: line 19, column 'y_m'", "beyond the 100000 m any laser"]),
        ("columns_key", ["--columns", "'t' is not a column kinsync reads", "t_s, x_m"]),
        ("columns_missing", ["--columns maps t_s to column 'time'", "its columns are"]),
        ("workers_local", ["--workers", "--scheduler local runs every chunk in this process"]),
    ],
)
def test_bad_input_is_one_line_error(
    run_cli: RunCli,
    setup: dict[str, Path],
    assert_one_line_error: OneLineError,
    change: str,
    fragments: list[str],
) -> None:
    out = setup["dir"] / "geo.csv"
    cols = _points(np.random.default_rng(7))
    if change == "out_suffix":
        out = setup["dir"] / "geo.txt"
    elif change == "missing_column":
        del cols["z_m"]
        with TableChunkWriter(setup["points"]) as w:
            w.write(cols)
    elif change in ("nan", "absurd"):
        cols["y_m"][17] = np.nan if change == "nan" else 1e307
        with TableChunkWriter(setup["points"]) as w:
            w.write(cols)
    extra = {
        "columns_key": ["--columns", "t=time"],
        "columns_missing": ["--columns", "t_s=time"],
        "workers_local": ["--workers", "4"],  # the default scheduler is local
    }
    code, stdout, err = run_cli(_args(setup, out, *extra.get(change, [])))
    assert_one_line_error(code, stdout, err, *fragments)
    assert not out.exists()


@pytest.mark.parametrize(("separator", "name"), [(";", "semicolon"), ("\t", "tab")])
@pytest.mark.parametrize("which", ["points", "traj"])
def test_a_semicolon_or_tab_separated_csv_is_said_to_be_so(
    run_cli: RunCli,
    setup: dict[str, Path],
    assert_one_line_error: OneLineError,
    separator: str,
    name: str,
    which: str,
) -> None:
    # Read with commas, the header is one column: the message must name the separator,
    # not blame --columns or the missing columns.
    path = setup[which]
    lines = path.read_text(encoding="utf-8").splitlines()
    path.write_text("\n".join(line.replace(",", separator) for line in lines) + "\n")
    out = setup["dir"] / "geo.csv"
    extra = ["--columns", "t_s=t_s,x_m=x_m"] if which == "points" else []
    code, stdout, err = run_cli(_args(setup, out, *extra))
    assert_one_line_error(
        code, stdout, err, f"{path.name}: line 1: the file looks {name}-separated", "use commas"
    )
    assert not out.exists()


def test_scheduler_processes_gives_the_serial_output(
    run_cli: RunCli, setup: dict[str, Path]
) -> None:
    serial, scaled = setup["dir"] / "serial.csv", setup["dir"] / "scaled.csv"
    code, _, err = run_cli(_args(setup, serial, "--chunk-points", "600"))
    assert code == 0, err
    extra = ("--chunk-points", "600", "--scheduler", "processes", "--workers", "2", "--json")
    code, stdout, err = run_cli(_args(setup, scaled, *extra))
    assert code == 0, err
    assert json.loads(stdout)["points_out"] == N_POINTS
    assert scaled.read_bytes() == serial.read_bytes()


@pytest.mark.parametrize(
    "scheduler",
    [
        ("--scheduler", "local"),
        ("--scheduler", "processes", "--workers", "2", "--chunk-points", "600"),
    ],
)
def test_a_quoted_line_break_is_named_by_its_line_whatever_the_scheduler(
    run_cli: RunCli,
    setup: dict[str, Path],
    assert_one_line_error: OneLineError,
    scheduler: tuple[str, ...],
) -> None:
    """'lines 2..: 2500 rows were planned, 2499 read back' (local) or, the value cut
    between two chunks, 'line 602: 1 field(s) where the header has 7' (processes): now
    both name the line where the quoted value breaks."""
    path = setup["points"]
    lines = path.read_text().splitlines()
    rows = [line + ",x" for line in lines[1:]]
    rows[599] = rows[599][:-1] + '"two'  # file line 601, the last of the first chunk
    rows[600] = 'lines"'  # the value's end: the row has as many fields as the header
    path.write_text("\n".join([lines[0] + ",note", *rows]) + "\n")
    out = setup["dir"] / "geo.csv"
    assert_one_line_error(
        *run_cli(_args(setup, out, *scheduler)),
        f"{path}: line 601: a quoted value holds a line break",
        "remove the line breaks from the values",
    )
    assert not out.exists()


def test_unreachable_scheduler_is_one_line_error(
    run_cli: RunCli,
    setup: dict[str, Path],
    assert_one_line_error: OneLineError,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    pytest.importorskip("dask.distributed")
    monkeypatch.setattr("kinsync.pipelines.schedulers.DASK_CONNECT_TIMEOUT_S", 1.0)
    out = setup["dir"] / "geo.csv"
    code, stdout, err = run_cli(_args(setup, out, "--scheduler", "tcp://127.0.0.1:9"))
    assert_one_line_error(code, stdout, err, "cannot reach the Dask scheduler at tcp://127.0.0.1:9")
    assert not out.exists()


# ---------------------------------------------------------------------- profile scanners
VEHICLE = TurningVehicle()  # 20 m/s on a 200 m radius, rolling and pitching, t0 = 1e9 s
PROFILE_AZIMUTH_DEG = 12.5


def _profile_columns(rng: np.random.Generator, n: int = N_POINTS) -> dict[str, np.ndarray]:
    t_rel = np.sort(rng.uniform(0.05, 9.95, n))
    return {
        "t_s": VEHICLE.t0_s + t_rel,
        "range_m": rng.uniform(3.0, 30.0, n),
        "angle_rad": rng.uniform(-np.pi, np.pi, n),
        "intensity": rng.integers(0, 1000, n),
    }


def _profile_truth(cols: dict[str, np.ndarray], mount: Mount, azimuth_deg: float) -> np.ndarray:
    r, phi = cols["range_m"], cols["angle_rad"]
    in_plane = np.column_stack([np.zeros_like(r), r * np.sin(phi), r * np.cos(phi)])
    xyz = in_plane @ euler_rpy_to_matrix(0.0, 0.0, np.radians(azimuth_deg)).T
    return VEHICLE.truth_ecef_m(cols["t_s"] - VEHICLE.t0_s, xyz, mount)


@pytest.fixture
def profile_setup(tmp_path: Path) -> dict[str, Path]:
    write_trajectory_csv(VEHICLE.trajectory(10.0, 100.0), tmp_path / "traj.csv")
    write_mount(replace(MOUNT, profiler_azimuth_deg=PROFILE_AZIMUTH_DEG), tmp_path / "mount.toml")
    write_mount(MOUNT, tmp_path / "plain_mount.toml")
    with TableChunkWriter(tmp_path / "profile.csv") as w:
        w.write(_profile_columns(np.random.default_rng(31)))
    return {
        "dir": tmp_path,
        "traj": tmp_path / "traj.csv",
        "mount": tmp_path / "mount.toml",
        "points": tmp_path / "profile.csv",
    }


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_profile_table_within_a_tenth_of_a_millimetre_of_analytic_truth(
    run_cli: RunCli, profile_setup: dict[str, Path], suffix: str
) -> None:
    cols = _profile_columns(np.random.default_rng(31))
    if suffix == ".parquet":
        profile_setup["points"] = profile_setup["dir"] / "profile.parquet"
        with TableChunkWriter(profile_setup["points"]) as w:
            w.write(cols)
    out = profile_setup["dir"] / f"geo{suffix}"
    code, stdout, err = run_cli(_args(profile_setup, out, "--json", "--chunk-points", "700"))
    assert code == 0, err
    assert json.loads(stdout)["points_out"] == N_POINTS
    table = pq.read_table(out) if suffix == ".parquet" else pa_csv.read_csv(out)
    assert table.column_names == ["t_s", "range_m", "angle_rad", "intensity", "X", "Y", "Z"]
    for name in ("t_s", "range_m", "angle_rad", "intensity"):
        np.testing.assert_array_equal(table.column(name).to_numpy(), cols[name], err_msg=name)
    got = np.column_stack([table.column(c).to_numpy() for c in ("X", "Y", "Z")])
    err_m = np.linalg.norm(got - _profile_truth(cols, MOUNT, PROFILE_AZIMUTH_DEG), axis=1)
    assert err_m.max() < 1e-4


def test_profile_azimuth_option_overrides_the_mount(
    run_cli: RunCli, profile_setup: dict[str, Path]
) -> None:
    cols = _profile_columns(np.random.default_rng(31))
    first, second = profile_setup["dir"] / "first.csv", profile_setup["dir"] / "second.csv"
    option = ("--profiler-azimuth-deg", "-35.0", "--chunk-points", "600")
    code, _, err = run_cli(_args(profile_setup, first, *option))
    assert code == 0, err
    table = pa_csv.read_csv(first)
    got = np.column_stack([table.column(c).to_numpy() for c in ("X", "Y", "Z")])
    assert np.linalg.norm(got - _profile_truth(cols, MOUNT, -35.0), axis=1).max() < 1e-4
    # A mount without [profiler] works with the option (and fails without it, below).
    profile_setup["mount"] = profile_setup["dir"] / "plain_mount.toml"
    code, _, err = run_cli(_args(profile_setup, second, *option))
    assert code == 0, err
    assert second.read_bytes() == first.read_bytes()


@pytest.mark.parametrize(
    ("change", "extra", "fragments"),
    [
        ("no_azimuth", (), ["[profiler] azimuth_deg", "--profiler-azimuth-deg"]),
        ("both_sets", (), ["x_m,y_m,z_m and range_m,angle_rad", "--point-columns"]),
        ("neither_set", (), ["range_m,angle_rad", "x_m,y_m,z_m", "the file has columns"]),
        ("xyz_with_azimuth", ("--profiler-azimuth-deg", "3"), ["applies to profile files"]),
        ("clash", (), ["['X']", "clash with the output coordinates"]),
        ("nan_range", (), ["profile.csv: line 42, column 'range_m': nan is not finite"]),
        ("negative_range", (), ["profile.csv: line 9, column 'range_m': range -1.0 is negative"]),
        ("none", ("--point-columns", "polar"), ["--point-columns must be"]),
        ("none", ("--profiler-azimuth-deg", "inf"), ["--profiler-azimuth-deg", "finite"]),
    ],
)
def test_bad_profile_input_is_one_line_error(
    run_cli: RunCli,
    profile_setup: dict[str, Path],
    assert_one_line_error: OneLineError,
    change: str,
    extra: tuple[str, ...],
    fragments: list[str],
) -> None:
    cols: dict[str, np.ndarray] = _profile_columns(np.random.default_rng(32))
    if change == "no_azimuth":
        profile_setup["mount"] = profile_setup["dir"] / "plain_mount.toml"
    elif change in ("both_sets", "xyz_with_azimuth"):
        n = N_POINTS
        cols |= {"x_m": np.zeros(n), "y_m": np.ones(n), "z_m": np.ones(n)}
        if change == "xyz_with_azimuth":
            del cols["range_m"], cols["angle_rad"]
    elif change == "neither_set":
        del cols["angle_rad"]
    elif change == "clash":
        cols["X"] = np.zeros(N_POINTS)
    elif change == "nan_range":
        cols["range_m"][40] = np.nan
    elif change == "negative_range":
        cols["range_m"][7] = -1.0
    with TableChunkWriter(profile_setup["points"]) as w:
        w.write(cols)
    out = profile_setup["dir"] / "geo.csv"
    code, stdout, err = run_cli(_args(profile_setup, out, *extra))
    assert_one_line_error(code, stdout, err, *fragments)
    assert not out.exists()


def test_profile_columns_can_be_chosen_when_both_sets_exist(
    run_cli: RunCli, profile_setup: dict[str, Path]
) -> None:
    cols = _profile_columns(np.random.default_rng(33))
    rng = np.random.default_rng(34)
    xyz = {c: rng.uniform(-5, 5, N_POINTS) for c in ("x_m", "y_m", "z_m")}
    with TableChunkWriter(profile_setup["points"]) as w:
        w.write(cols | xyz)
    out_p, out_x = profile_setup["dir"] / "p.parquet", profile_setup["dir"] / "x.parquet"
    code, _, err = run_cli(_args(profile_setup, out_p, "--point-columns", "profile"))
    assert code == 0, err
    table = pq.read_table(out_p)
    assert table.column_names == [*cols, "x_m", "y_m", "z_m", "X", "Y", "Z"]
    got = np.column_stack([table.column(c).to_numpy() for c in ("X", "Y", "Z")])
    truth = _profile_truth(cols, MOUNT, PROFILE_AZIMUTH_DEG)
    assert np.linalg.norm(got - truth, axis=1).max() < 1e-4
    code, _, err = run_cli(_args(profile_setup, out_x, "--point-columns", "xyz"))
    assert code == 0, err
    table = pq.read_table(out_x)
    assert table.column_names == [*cols, "X", "Y", "Z"]  # x_m,y_m,z_m replaced in place
    got = np.column_stack([table.column(c).to_numpy() for c in ("X", "Y", "Z")])
    scanner = np.column_stack([xyz["x_m"], xyz["y_m"], xyz["z_m"]])
    truth = VEHICLE.truth_ecef_m(cols["t_s"] - VEHICLE.t0_s, scanner, MOUNT)
    assert np.linalg.norm(got - truth, axis=1).max() < 1e-4


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_extra_csv_columns_come_out_as_the_same_text(
    run_cli: RunCli, setup: dict[str, Path], suffix: str
) -> None:
    """Codes with leading zeros, integers beyond 64 bits, quoted commas, empty cells and
    unusual float spellings are carried through as they were written (issue 15, class 5)."""
    t = [repr(T0 + 1.0), repr(T0 + 2.0), repr(T0 + 3.0)]
    extra = [
        ("000", str(2**70), '"a,b"', "0.10", ""),
        ("001", str(2**70 + 1), "x", "1E-320", "y"),
        ("010", "-0", "", "+3", "z"),
    ]
    lines = ["t_s,x_m,y_m,z_m,code,big,label,flt,opt"]
    lines += [f"{ti},1.0,2.0,3.0,{','.join(e)}" for ti, e in zip(t, extra, strict=True)]
    setup["points"].write_text("\n".join(lines) + "\n")
    out = setup["dir"] / f"geo{suffix}"
    code, _, err = run_cli(_args(setup, out))
    assert code == 0, err
    names = ["code", "big", "label", "flt", "opt"]
    table = pq.read_table(out) if suffix == ".parquet" else None
    if table is None:
        table = pa_csv.read_csv(
            out,
            convert_options=pa_csv.ConvertOptions(
                column_types=dict.fromkeys(names, pa.string()), strings_can_be_null=False
            ),
        )
    for j, name in enumerate(names):
        want = [e[j].strip('"') for e in extra]
        assert table.column(name).to_pylist() == want, name


# ------------------------------------------------------- CRS: heights, datums, zones (#16)
def _gtx(path: Path) -> Path:
    """A geoid grid around the trajectory: N = -30 + 0.5 (lat - 46.5) + 0.2 (lon + 71)."""
    import struct  # noqa: PLC0415

    lat0, lon0, step, n = 46.5, -71.5, 0.05, 13
    lat = lat0 + step * np.arange(n)[:, None]
    lon = lon0 + step * np.arange(n)[None, :]
    values = -30.0 + 0.5 * (lat - 46.5) + 0.2 * (lon + 71.0)
    path.write_bytes(struct.pack(">4d2i", lat0, lon0, step, step, n, n))
    with path.open("ab") as f:
        f.write(values.astype(">f4").tobytes())
    return path


def _las_points(path: Path, point_format: int, version: str) -> Path:
    cols = _points(np.random.default_rng(3))
    las_points(cols, point_format, version).write(path)
    return path


def test_a_compound_crs_without_its_geoid_grid_is_one_line_naming_it(
    run_cli: RunCli, setup: dict[str, Path], assert_one_line_error: OneLineError
) -> None:
    if pyproj.network.is_network_enabled():  # type: ignore[attr-defined]
        pytest.skip("PROJ_NETWORK is on")
    out = setup["dir"] / "geo.csv"
    code, stdout, err = run_cli(_args(setup, out, "--crs", "EPSG:32619+5703"))
    assert_one_line_error(code, stdout, err, "need the grid", "projsync --file", "--geoid PATH")
    assert not out.exists()


@pytest.mark.parametrize(("point_format", "version"), [(1, "1.2"), (6, "1.4")])
def test_georef_with_a_geoid_writes_orthometric_heights_and_a_compound_crs(
    run_cli: RunCli, setup: dict[str, Path], point_format: int, version: str
) -> None:
    src = _las_points(setup["dir"] / "scan.las", point_format, version)
    grid = _gtx(setup["dir"] / "geoid.gtx")
    base = ["--trajectory", str(setup["traj"]), "--mount", str(setup["mount"]), "--json"]
    ellipsoidal, orthometric = setup["dir"] / "h.las", setup["dir"] / "H.las"
    code, _, err = run_cli(
        ["georef", "--points", str(src), *base, "--out", str(ellipsoidal), "--crs", "EPSG:32619"]
    )
    assert code == 0, err
    code, stdout, err = run_cli(
        [
            "georef",
            "--points",
            str(src),
            *base,
            "--out",
            str(orthometric),
            "--crs",
            "EPSG:32619+5703",
            "--geoid",
            str(grid),
        ]
    )
    assert code == 0, err
    doc = json.loads(stdout)["crs"]
    assert doc["heights"].startswith("orthometric: NAVD88 height (geoid grid")
    assert "vgridshift" in doc["proj_pipeline"]
    assert doc["accuracy_m"] == 0.0
    assert doc["epoch_year"] is None
    h, big_h = laspy.read(ellipsoidal), laspy.read(orthometric)
    lon, lat = pyproj.Transformer.from_crs(32619, 4326, always_xy=True).transform(h.x, h.y)
    geoid_n = -30.0 + 0.5 * (lat - 46.5) + 0.2 * (lon + 71.0)
    np.testing.assert_allclose(np.asarray(h.x), np.asarray(big_h.x), rtol=0, atol=1e-9)
    np.testing.assert_allclose(
        np.asarray(big_h.z), np.asarray(h.z) - geoid_n, rtol=0, atol=1e-4 + 2e-5
    )
    if point_format < 6:
        keys = {
            k.id: k.value_offset
            for v in big_h.header.vlrs
            if hasattr(v, "geo_keys")
            for k in v.geo_keys
        }
        assert (keys[3072], keys[4096]) == (32619, 5703)
    else:
        assert big_h.header.parse_crs() == pyproj.CRS("EPSG:32619+5703")


def test_georef_json_and_table_carry_the_crs_pipeline_accuracy_and_epoch(
    run_cli: RunCli, setup: dict[str, Path]
) -> None:
    """ITRF2014 -> NAD83(CSRS)v7 is time-dependent: the epoch is the data's date (2021)."""
    out = setup["dir"] / "geo.csv"
    argv = _args(setup, out, "--crs", "EPSG:22719", "--trajectory-crs", "EPSG:7789", "--json")
    code, stdout, err = run_cli(argv)
    assert code == 0, err
    doc = json.loads(stdout)["crs"]
    assert doc["time_dependent"]
    assert doc["epoch_year"] == pytest.approx(2021.2, abs=0.05)  # GPS 1.3e9 s: 2021-03
    assert "helmert" in doc["proj_pipeline"]
    out2 = setup["dir"] / "geo2.csv"
    code, stdout, err = run_cli(
        [
            *_args(setup, out2, "--crs", "EPSG:22719", "--trajectory-crs", "EPSG:7789"),
            "--epoch",
            "2010.0",
        ]
    )
    assert code == 0, err
    assert "coordinate epoch (year)" in stdout
    assert "PROJ pipeline: proj=pipeline" in stdout
    a, b = pa_csv.read_csv(out), pa_csv.read_csv(out2)
    shift = np.hypot(
        np.asarray(a["X"]) - np.asarray(b["X"]), np.asarray(a["Y"]) - np.asarray(b["Y"])
    )
    assert shift.min() > 0.05  # 11 years of the transformation's rates


def test_georef_warns_of_a_utm_zone_far_from_the_data(
    run_cli: RunCli, setup: dict[str, Path]
) -> None:
    out = setup["dir"] / "geo.csv"
    code, _, err = run_cli(_args(setup, out, "--crs", "EPSG:32618"))
    assert code == 0, err
    (line,) = [x for x in err.splitlines() if x.startswith("kinsync: warning:")]
    assert "outside the area of use of WGS 84 / UTM zone 18N" in line
    assert "EPSG:32619" in line


def test_trajectory_info_gives_extent_zone_and_time_scale(
    run_cli: RunCli, setup: dict[str, Path], tmp_path: Path
) -> None:
    code, stdout, err = run_cli(["trajectory", "info", str(setup["traj"]), "--json"])
    assert code == 0, err
    doc = json.loads(stdout)
    assert doc["time"]["scale"] == "GPS time"
    assert doc["time"]["start_utc"].startswith("2021-03-")
    area = doc["area"]
    assert area["utm_zone"] == "19N"
    assert area["utm_epsg"] == "EPSG:32619"
    assert area["lat_deg"][0] == pytest.approx(46.8)
    assert area["lon_deg"][0] == pytest.approx(-71.2)
    code, stdout, _ = run_cli(["trajectory", "info", str(setup["traj"])])
    assert code == 0
    assert "suggested UTM zone" in stdout
    # an SBET without --gps-week: seconds of week, no date
    write_sbet(_trajectory(), tmp_path / "t.out")
    code, stdout, err = run_cli(["trajectory", "info", str(tmp_path / "t.out"), "--json"])
    assert code == 0, err
    assert json.loads(stdout)["time"]["scale"] == "GPS seconds of week"


@pytest.mark.parametrize("suffix", [".csv", ".laz"])
def test_a_folder_given_as_points_or_trajectory_is_named_a_folder(
    run_cli: RunCli,
    setup: dict[str, Path],
    assert_one_line_error: OneLineError,
    suffix: str,
) -> None:
    # Both were "file not found" (points) or "length 4096 bytes is not a multiple of the
    # 136-byte SBET record" (a folder named like an SBET).
    folder = setup["dir"] / f"scan{suffix}"
    folder.mkdir()
    out = setup["dir"] / "out.csv"
    args = _args(setup, out)
    args[args.index("--points") + 1] = str(folder)
    assert_one_line_error(*run_cli(args), f"{folder}: is a folder, not a file")
    sbet = setup["dir"] / "trajectory.out"
    sbet.mkdir()
    args = _args(setup, out, "--gps-week", "2345")
    args[args.index("--trajectory") + 1] = str(sbet)
    assert_one_line_error(*run_cli(args), f"{sbet}: is a folder; give the path of an SBET file")
    assert not out.exists()
