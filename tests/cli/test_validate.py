"""``kinsync validate``: control points and flatness from files, and every bad input.

The clouds are the real pipeline's output: a simulated scan written as files and
georeferenced by `kinsync.georef.georeference_file` (CSV, Parquet), or written as
LAS/LAZ (with adjusted standard GPS time, or in UTM with the CRS in the file).
"""

from __future__ import annotations

import json
import re
from collections.abc import Callable
from pathlib import Path

import laspy
import numpy as np
import pyarrow.csv as pa_csv
import pyproj
import pytest
from tests._las import add_geo_keys

from kinsync.io.control_points import read_control_points, write_control_points
from kinsync.io.las import ADJUSTED_GPS_OFFSET_S
from kinsync.io.mount_file import read_mount
from kinsync.io.points import TableChunkWriter
from kinsync.io.sbet import SECONDS_PER_WEEK
from kinsync.io.trajectory_csv import read_trajectory_csv, write_trajectory_csv
from kinsync.pipelines.georef import georeference_file
from kinsync.sim.validation_scene import control_target_scene, curved_wall_scene, write_scene
from kinsync.trajectory import Trajectory
from kinsync.trajectory_gaps import gap_threshold_shown_s
from kinsync.validation.control_points import ControlPoints

RunCli = Callable[[list[str]], tuple[int, str, str]]  # fixture run_cli in conftest.py
OneLineError = Callable[..., None]  # fixture assert_one_line_error in conftest.py

LATENCY_ERROR_S = 0.002
WALL_LATENCY_ERROR_S = 0.005
GPS_WEEK = 2149  # the scenes start at GPS time 1.3e9 s, in week 2149


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    base = tmp_path_factory.mktemp("validate")
    ctl_dir, wall_dir = base / "control", base / "wall"
    ctl_dir.mkdir()
    wall_dir.mkdir()
    ctl = write_scene(control_target_scene(targets_per_side=2, seed=21), ctl_dir)
    mount = read_mount(ctl["mount"])
    late = mount.with_latency(LATENCY_ERROR_S)
    georeference_file(ctl["points"], ctl["trajectory"], late, ctl_dir / "cloud.csv")
    georeference_file(ctl["points"], ctl["trajectory"], late, ctl_dir / "cloud.parquet")
    wall = write_scene(curved_wall_scene(seed=21), wall_dir)
    wall_mount = read_mount(wall["mount"])
    georeference_file(wall["points"], wall["trajectory"], wall_mount, wall_dir / "ok.csv")
    georeference_file(
        wall["points"],
        wall["trajectory"],
        wall_mount.with_latency(WALL_LATENCY_ERROR_S),
        wall_dir / "late.csv",
    )
    return {
        "control": ctl["control"],
        "trajectory": ctl["trajectory"],
        "cloud_csv": ctl_dir / "cloud.csv",
        "cloud_parquet": ctl_dir / "cloud.parquet",
        "wall_ok": wall_dir / "ok.csv",
        "wall_late": wall_dir / "late.csv",
        "box": wall["box"],
        "dir": base,
    }


def _box(files: dict[str, Path]) -> str:
    return files["box"].read_text().strip()


def _columns(path: Path) -> dict[str, np.ndarray]:
    table = pa_csv.read_csv(path)
    return {name: table.column(name).to_numpy() for name in table.column_names}


# ------------------------------------------------------------------ control points
@pytest.mark.parametrize("cloud", ["cloud_csv", "cloud_parquet"])
def test_control_points_json(run_cli: RunCli, files: dict[str, Path], cloud: str) -> None:
    code, out, err = run_cli(
        [
            "validate", "control-points", "--cloud", str(files[cloud]),
            "--control", str(files["control"]), "--trajectory", str(files["trajectory"]),
            "--centre", "sphere", "--target-radius-m", "0.2", "--json",
        ]
    )  # fmt: skip
    assert code == 0, err
    doc = json.loads(out)
    assert doc["n_control_points"] == 4
    assert doc["n_observations"] == 4 * 8
    assert doc["n_missing"] == 0
    assert doc["n_passes"] == 8
    te = doc["time_error"]
    assert te["significant"] is True
    assert abs(te["time_error_s"] - LATENCY_ERROR_S) < 4 * te["time_error_std_s"]
    assert abs(te["time_error_s"] - LATENCY_ERROR_S) < 0.2 * LATENCY_ERROR_S
    assert doc["heading_error"]["significant"] is False
    obs = doc["observations"][0]
    assert set(obs) >= {"name", "dx_m", "dy_m", "dz_m", "speed_m_s", "side", "n_points"}
    assert obs["side"] in ("left", "right")
    assert doc["png"] is None


def test_inconsistent_trajectory_velocities_are_one_warning_line(
    run_cli: RunCli, files: dict[str, Path], tmp_path: Path
) -> None:
    """Any command, not only georef: a KinsyncWarning is one line on stderr, once."""
    traj = read_trajectory_csv(files["trajectory"])
    assert traj.vel_ned_m_s is not None
    zero = Trajectory(
        t_s=traj.t_s,
        q_body_to_ned=traj.q_body_to_ned,
        lat_lon_h=traj.lat_lon_h,
        vel_ned_m_s=np.zeros_like(traj.vel_ned_m_s),
    )
    write_trajectory_csv(zero, tmp_path / "zero.csv")
    code, out, err = run_cli(
        [
            "validate", "control-points", "--cloud", str(files["cloud_csv"]),
            "--control", str(files["control"]), "--trajectory", str(tmp_path / "zero.csv"),
            "--centre", "sphere", "--target-radius-m", "0.2", "--json",
        ]
    )  # fmt: skip
    assert code == 0, err
    json.loads(out)
    assert err.count("\n") == 1, err
    assert err.startswith("kinsync: warning: trajectory velocities disagree with the positions")
    assert "interpolated linearly" in err


def test_control_points_table_and_figure(run_cli: RunCli, files: dict[str, Path]) -> None:
    png = files["dir"] / "cp.png"
    code, out, err = run_cli(
        [
            "validate", "control-points", "--cloud", str(files["cloud_csv"]),
            "--control", str(files["control"]), "--trajectory", str(files["trajectory"]),
            "--centre", "sphere", "--target-radius-m", "0.2", "--png", str(png),
        ]
    )  # fmt: skip
    assert code == 0, err
    for fragment in ("dY fwd", "time error (ms)", "heading error (deg)", "SIGNIFICANT", "W1"):
        assert fragment in out
    assert png.read_bytes().startswith(b"\x89PNG")


def test_control_point_without_target_is_reported_not_fatal(
    run_cli: RunCli, files: dict[str, Path]
) -> None:
    cp = read_control_points(files["control"])
    far = cp.pos_ecef_m[0] + np.array([0.0, 0.0, 40.0])
    extra = files["dir"] / "control_extra.csv"
    write_control_points(
        ControlPoints((*cp.names, "GHOST"), np.vstack([cp.pos_ecef_m, far])), extra, form="ecef"
    )
    code, out, err = run_cli(
        [
            "validate", "control-points", "--cloud", str(files["cloud_csv"]),
            "--control", str(extra), "--trajectory", str(files["trajectory"]), "--json",
        ]
    )  # fmt: skip
    assert code == 0, err
    doc = json.loads(out)
    assert [m["name"] for m in doc["missing"]] == ["GHOST"]
    assert "within 0.5 m" in doc["missing"][0]["reason"]
    assert doc["n_observations"] == 4 * 8
    # With the Tukey centroid of spheres the time error still shows (the cap's bias is
    # lateral, not along-track).
    assert doc["time_error"]["significant"] is True


def test_a_visit_in_a_trajectory_gap_is_reported_missing(
    run_cli: RunCli, files: dict[str, Path]
) -> None:
    """One second cut out of the trajectory around a visit: that visit is missing, with
    the gap as the reason, and the rest is validated as before."""
    argv = [
        "validate", "control-points", "--cloud", str(files["cloud_csv"]),
        "--control", str(files["control"]), "--centre", "sphere", "--target-radius-m", "0.2",
        "--json", "--trajectory",
    ]  # fmt: skip
    code, out, err = run_cli([*argv, str(files["trajectory"])])
    assert code == 0, err
    t_visit = sorted(o["t_s"] for o in json.loads(out)["observations"])
    t_hole = t_visit[len(t_visit) // 2]
    lines = files["trajectory"].read_text(encoding="utf-8").splitlines()
    kept = [ln for ln in lines[1:] if abs(float(ln.split(",")[0]) - t_hole) > 0.5]
    holed = files["dir"] / "trajectory_hole.csv"
    holed.write_text("\n".join([lines[0], *kept]) + "\n", encoding="utf-8")
    n_hole = sum(abs(t - t_hole) < 0.49 for t in t_visit)
    code, out, err = run_cli([*argv, str(holed)])
    assert code == 0, err
    doc = json.loads(out)
    assert doc["n_missing"] == n_hole >= 1
    assert doc["n_observations"] == len(t_visit) - n_hole
    assert all("data gap of the trajectory" in m["reason"] for m in doc["missing"])
    assert t_hole in [m["t_s"] for m in doc["missing"]]
    # the threshold used (10 median record intervals) is in the document and the reason,
    # with the option that sets it
    t_rec = np.array([float(ln.split(",")[0]) for ln in kept])
    limit = 10.0 * float(np.median(np.diff(t_rec)))
    assert doc["gap_threshold_s"] == pytest.approx(limit)
    for m in doc["missing"]:
        assert f"record intervals longer than {gap_threshold_shown_s(limit):.6g} s" in m["reason"]
        assert "--max-gap-s" in m["reason"]
    # a threshold above the hole: every visit is read across it
    code, out, err = run_cli([*argv[:-1], "--max-gap-s", "1.5", "--trajectory", str(holed)])
    assert code == 0, err
    doc = json.loads(out)
    assert doc["gap_threshold_s"] == 1.5
    assert doc["n_missing"] == 0
    assert sorted(o["t_s"] for o in doc["observations"]) == t_visit


def test_a_visit_cut_by_the_end_of_the_cloud_file_is_reported_missing(
    run_cli: RunCli, files: dict[str, Path]
) -> None:
    """A cloud file split in the middle of a visit (files per line or per minute): the
    half-visit at its end would give a centre tens of mm off; it is reported missing,
    and the visits before it are validated as before."""
    argv = [
        "validate", "control-points", "--control", str(files["control"]),
        "--trajectory", str(files["trajectory"]), "--centre", "sphere",
        "--target-radius-m", "0.2", "--json", "--cloud",
    ]  # fmt: skip
    code, out, err = run_cli([*argv, str(files["cloud_csv"])])
    assert code == 0, err
    whole = {(o["name"], o["t_s"]): o for o in json.loads(out)["observations"]}
    t_cut = sorted(t for _, t in whole)[len(whole) // 2]  # the median time of a visit
    lines = files["cloud_csv"].read_text(encoding="utf-8").splitlines()
    t_col = lines[0].split(",").index("t_s")
    kept = [ln for ln in lines[1:] if float(ln.split(",")[t_col]) <= t_cut]
    cut = files["dir"] / "cloud_cut.csv"
    cut.write_text("\n".join([lines[0], *kept]) + "\n", encoding="utf-8")
    code, out, err = run_cli([*argv, str(cut)])
    assert code == 0, err
    doc = json.loads(out)
    # the cut visit, and any other ending within the 1 s that separates visits
    missing = doc["missing"]
    assert missing
    for m in missing:
        assert "visit cut by the end of the cloud?" in m["reason"]
        assert "validate one cloud that holds the whole pass (join its files)" in m["reason"]
    (cut_visit,) = [k for k in whole if k[1] == t_cut]
    assert cut_visit[0] in [m["name"] for m in missing]
    got = {(o["name"], o["t_s"]): o for o in doc["observations"]}
    assert got.keys() <= whole.keys()
    assert len(got) + len(missing) == sum(t <= t_cut for _, t in whole)
    for key, obs in got.items():
        assert obs["dx_m"] == whole[key]["dx_m"]


def _control_las(files: dict[str, Path], path: Path, *, adjusted: bool) -> None:
    cols = _columns(files["cloud_csv"])
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales = np.full(3, 1e-4)
    header.offsets = np.round(np.array([cols["X"][0], cols["Y"][0], cols["Z"][0]]))
    if adjusted:
        header.global_encoding.gps_time_type = laspy.header.GpsTimeType.STANDARD
    las = laspy.LasData(header)
    las.x, las.y, las.z = cols["X"], cols["Y"], cols["Z"]
    t = cols["t_s"]
    las.gps_time = t - ADJUSTED_GPS_OFFSET_S if adjusted else t - GPS_WEEK * SECONDS_PER_WEEK
    las.intensity = cols["intensity"].astype(np.uint16)
    las.write(path, laz_backend=laspy.LazBackend.Lazrs if path.suffix == ".laz" else None)


def test_las_clouds_on_both_gps_time_scales(
    run_cli: RunCli, assert_one_line_error: OneLineError, files: dict[str, Path]
) -> None:
    adjusted, week = files["dir"] / "cloud.laz", files["dir"] / "cloud_week.las"
    _control_las(files, adjusted, adjusted=True)
    _control_las(files, week, adjusted=False)
    args = ["--control", str(files["control"]), "--trajectory", str(files["trajectory"])]
    sphere = ["--centre", "sphere", "--target-radius-m", "0.2", "--json"]
    for cloud, extra in ((adjusted, []), (week, ["--gps-week", str(GPS_WEEK)])):
        code, out, err = run_cli(
            ["validate", "control-points", "--cloud", str(cloud), *args, *sphere, *extra]
        )
        assert code == 0, err
        te = json.loads(out)["time_error"]
        assert abs(te["time_error_s"] - LATENCY_ERROR_S) < 0.2 * LATENCY_ERROR_S
    code, out, err = run_cli(["validate", "control-points", "--cloud", str(week), *args])
    assert_one_line_error(code, out, err, "GPS seconds of week", "--gps-week")
    # A radius with another centre would not be used: refused, not ignored.
    radius = ["--target-radius-m", "0.2"]
    code, out, err = run_cli(
        ["validate", "control-points", "--cloud", str(adjusted), *args, *radius]
    )
    assert_one_line_error(code, out, err, "--target-radius-m", "with --centre tukey")


def _state_plane_las(files: dict[str, Path], path: Path, z_unit_code: int) -> None:
    """The control cloud in EPSG:2249 (X, Y in US survey feet), GeoTIFF keys as LAStools
    writes them: VerticalUnitsGeoKey ``z_unit_code`` (9001 metre, 9003 US survey foot)
    and no vertical CRS; Z the ellipsoidal height in that unit."""
    cols = _columns(files["cloud_csv"])
    to_sp = pyproj.Transformer.from_crs(4978, pyproj.CRS.from_epsg(2249).to_3d(), always_xy=True)
    e, n, h_m = to_sp.transform(cols["X"], cols["Y"], cols["Z"])
    z = h_m if z_unit_code == 9001 else h_m / (1200 / 3937)
    header = laspy.LasHeader(point_format=1, version="1.2")
    add_geo_keys(header, {1024: 1, 3072: 2249, 4099: z_unit_code})
    header.scales = np.full(3, 1e-4)
    header.offsets = np.round(np.array([e[0], n[0], z[0]]))
    header.global_encoding.gps_time_type = laspy.header.GpsTimeType.STANDARD
    las = laspy.LasData(header)
    las.x, las.y, las.z = e, n, z
    las.gps_time = cols["t_s"] - ADJUSTED_GPS_OFFSET_S
    las.intensity = cols["intensity"].astype(np.uint16)
    las.write(path)


def test_a_cloud_with_z_in_feet_gives_the_metre_cloud_differences(
    run_cli: RunCli, files: dict[str, Path]
) -> None:
    """VerticalUnitsGeoKey US survey foot without a vertical CRS: Z was read as metres,
    3.28 times too high, and no point was found near a control point."""
    metres, feet = files["dir"] / "sp_m.las", files["dir"] / "sp_ftus.las"
    _state_plane_las(files, metres, 9001)
    _state_plane_las(files, feet, 9003)
    args = ["--control", str(files["control"]), "--trajectory", str(files["trajectory"])]
    sphere = ["--centre", "sphere", "--target-radius-m", "0.2", "--json"]
    docs, errs = [], []
    for cloud in (metres, feet):
        code, out, err = run_cli(
            ["validate", "control-points", "--cloud", str(cloud), *args, *sphere]
        )
        assert code == 0, err
        docs.append(json.loads(out))
        errs.append(err)
    assert errs[0] == ""  # kinsync's own form of EPSG:2249: Z in metres, nothing assumed
    assert errs[1].count("\n") == 1
    assert errs[1].startswith(f"kinsync: warning: {feet}: ")
    assert "VerticalUnitsGeoKey (4099) 9003" in errs[1]
    assert "ellipsoidal height" in errs[1]
    by_name = [{o["name"]: o for o in doc["observations"]} for doc in docs]
    assert by_name[0].keys() == by_name[1].keys()
    for name, obs in by_name[0].items():
        for key in ("dx_m", "dy_m", "dz_m"):
            assert by_name[1][name][key] == pytest.approx(obs[key], abs=1e-4)
    te = [doc["time_error"]["time_error_s"] for doc in docs]
    assert te[1] == pytest.approx(te[0], abs=1e-5)
    assert abs(te[0] - LATENCY_ERROR_S) < 0.2 * LATENCY_ERROR_S


def test_non_finite_cells_name_the_point(
    run_cli: RunCli, assert_one_line_error: OneLineError, files: dict[str, Path], tmp_path: Path
) -> None:
    cols = _columns(files["cloud_csv"])
    cols["t_s"] = cols["t_s"].copy()
    cols["t_s"][17] = np.nan
    path = tmp_path / "nan.csv"
    with TableChunkWriter(path) as w:
        w.write(cols)
    code, out, err = run_cli(
        ["validate", "control-points", "--cloud", str(path), "--control", str(files["control"]),
         "--trajectory", str(files["trajectory"])]
    )  # fmt: skip
    # Data row 17 (0-based) is file line 19, below the header: was "point 17 has a
    # non-finite time", neither the line nor the column.
    assert_one_line_error(code, out, err, str(path), "line 19, column 't_s': nan is not a finite")


def test_non_finite_coordinate_names_the_file_line_and_column(
    run_cli: RunCli, assert_one_line_error: OneLineError, files: dict[str, Path], tmp_path: Path
) -> None:
    lines = files["cloud_csv"].read_text().splitlines()
    header = lines[0].split(",")
    cells = lines[99].split(",")
    cells[header.index("Y")] = "nan"
    lines[99] = ",".join(cells)
    lines.insert(50, "")  # a blank line: the NaN is now on file line 101
    path = tmp_path / "nan.csv"
    path.write_text("\n".join(lines) + "\n")
    code, out, err = run_cli(
        ["validate", "control-points", "--cloud", str(path), "--control", str(files["control"]),
         "--trajectory", str(files["trajectory"])]
    )  # fmt: skip
    assert_one_line_error(code, out, err, f"{path}: line 101, column 'Y': nan is not a finite")


# ------------------------------------------------------------------ flatness
def test_flatness_flags_the_late_wall_only(run_cli: RunCli, files: dict[str, Path]) -> None:
    png = files["dir"] / "wall.png"
    docs = {}
    for key in ("wall_ok", "wall_late"):
        code, out, err = run_cli(
            ["validate", "flatness", "--cloud", str(files[key]), "--box", _box(files), "--json"]
            + (["--png", str(png)] if key == "wall_late" else [])
        )
        assert code == 0, err
        docs[key] = json.loads(out)
    ok, late = docs["wall_ok"], docs["wall_late"]
    assert ok["curvature_significant"] is False
    assert late["curvature_significant"] is True
    assert late["curvature_p_value"] < 1e-6
    assert late["bow_m"] > 0.006
    assert ok["bow_m"] < 0.001
    assert ok["rms_m"] == pytest.approx(0.005, rel=0.1)
    assert ok["n_points"] + ok["n_rejected"] == ok["n_selected"]
    assert 20.0 < ok["extent_u_m"] < 26.0
    assert png.read_bytes().startswith(b"\x89PNG")
    assert late["png"] == str(png)
    # The bow comes with its sigma, and each verdict says what it cannot tell.
    assert 0.0 < late["bow_std_m"] < late["bow_m"] / 3
    assert 0.0 < ok["bow_std_m"] < 0.001
    assert late["drive_noise_m"] >= 0.0
    assert "time error OR a mount error" in late["verdict"]
    assert "no proof of synchronisation" in ok["verdict"]
    assert "control-points" in late["verdict"]


def test_flatness_table(run_cli: RunCli, files: dict[str, Path]) -> None:
    code, out, err = run_cli(
        ["validate", "flatness", "--cloud", str(files["wall_late"]), "--box", _box(files)]
    )
    assert code == 0, err
    assert "curvature significant" in out
    assert "YES" in out
    assert "bow" in out
    # A bend is not the test of the time error alone (a lever arm or boresight error
    # bends the wall as well): the verdict line says so, and the bow has its sigma.
    assert "time error OR a mount error (lever arm, boresight)" in " ".join(out.split())
    assert "control-points" in out
    assert "±" in out


def _utm_las(files: dict[str, Path], crs_in_file: bool) -> tuple[Path, str]:
    cols = _columns(files["wall_late"])
    to_utm = pyproj.Transformer.from_crs(4978, 32619, always_xy=True)
    e, n, h = to_utm.transform(cols["X"], cols["Y"], cols["Z"])
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales = np.full(3, 1e-4)
    header.offsets = np.round(np.array([e[0], n[0], h[0]]))
    if crs_in_file:
        header.add_crs(pyproj.CRS.from_epsg(32619))
    las = laspy.LasData(header)
    las.x, las.y, las.z = e, n, h
    las.gps_time = cols["t_s"] - ADJUSTED_GPS_OFFSET_S
    las.intensity = cols["intensity"].astype(np.uint16)
    path = files["dir"] / f"wall_utm_{crs_in_file}.las"
    las.write(path)
    lo = np.array([np.min(e), np.min(n), np.min(h)]) - 0.1
    hi = np.array([np.max(e), np.max(n), np.max(h)]) + 0.1
    return path, ",".join(repr(float(v)) for v in (*lo, *hi))


def test_flatness_las_in_utm_reads_the_crs_from_the_file(
    run_cli: RunCli, assert_one_line_error: OneLineError, files: dict[str, Path]
) -> None:
    path, box = _utm_las(files, crs_in_file=True)
    code, out, err = run_cli(["validate", "flatness", "--cloud", str(path), "--box", box, "--json"])
    assert code == 0, err
    doc = json.loads(out)
    assert doc["curvature_significant"] is True
    assert doc["bow_m"] > 0.006
    code, out, err = run_cli(
        [
            "validate",
            "flatness",
            "--cloud",
            str(path),
            "--box",
            box,
            "--crs",
            "EPSG:32619",
            "--json",
        ]
    )
    assert code == 0, err
    code, out, err = run_cli(
        ["validate", "flatness", "--cloud", str(path), "--box", box, "--crs", "EPSG:4978"]
    )
    assert_one_line_error(code, out, err, "WGS 84 / UTM zone 19N", "omit --crs")
    bare, box = _utm_las(files, crs_in_file=False)
    code, out, err = run_cli(
        [
            "validate",
            "flatness",
            "--cloud",
            str(bare),
            "--box",
            box,
            "--crs",
            "EPSG:32619",
            "--json",
        ]
    )
    assert code == 0, err
    assert json.loads(out)["bow_m"] == pytest.approx(doc["bow_m"], abs=2e-4)


# ------------------------------------------------------------------ bad input
def test_empty_box(
    run_cli: RunCli, assert_one_line_error: OneLineError, files: dict[str, Path]
) -> None:
    code, out, err = run_cli(
        ["validate", "flatness", "--cloud", str(files["wall_ok"]), "--box", "0,0,0,1,1,1"]
    )
    assert_one_line_error(code, out, err, "no point inside the box", "the cloud's", "span X")


@pytest.mark.parametrize(
    ("box", "shown"),
    [
        # a tiny box: printed with %g, xmin and xmax both read 1.40955e+06
        ("1409550.0001,-4140559,4626600,1409550.0002,-4140558,4626601", "1409550.0001,"),
        ("46.8,-71.2,0,46.81,-71.19,100", "46.8,-71.2,0.0,46.81,-71.19,100.0"),  # lat/lon
    ],
)
def test_an_empty_box_is_shown_whole_with_the_cloud_crs(
    run_cli: RunCli,
    assert_one_line_error: OneLineError,
    files: dict[str, Path],
    box: str,
    shown: str,
) -> None:
    cloud = str(files["wall_ok"])
    code, out, err = run_cli(["validate", "flatness", "--cloud", cloud, "--box", box])
    hint = "give --box in the cloud's CRS (EPSG:4978)"
    assert_one_line_error(code, out, err, f"no point inside the box {shown}", hint)
    if shown.startswith("1409550"):
        assert "1409550.0002," in err


def test_too_few_and_degenerate_points(
    run_cli: RunCli, assert_one_line_error: OneLineError, tmp_path: Path
) -> None:
    base = np.array([1409555.0, -4140560.0, 4626600.0])
    few = tmp_path / "few.csv"
    with TableChunkWriter(few) as w:
        pts = base + np.random.default_rng(0).uniform(0, 1, (7, 3))
        w.write({"X": pts[:, 0], "Y": pts[:, 1], "Z": pts[:, 2]})
    box = ",".join(str(v) for v in (*(base - 1), *(base + 2)))
    code, out, err = run_cli(["validate", "flatness", "--cloud", str(few), "--box", box])
    assert_one_line_error(code, out, err, "too few points for a plane: 7 selected", str(few))
    line = tmp_path / "line.csv"
    with TableChunkWriter(line) as w:
        pts = base + np.linspace(0, 1, 40)[:, None] * np.array([1.0, 0.5, 0.2])
        w.write({"X": pts[:, 0], "Y": pts[:, 1], "Z": pts[:, 2]})
    code, out, err = run_cli(["validate", "flatness", "--cloud", str(line), "--box", box])
    assert_one_line_error(code, out, err, "lie on a line")


@pytest.mark.parametrize(
    ("box", "fragment"),
    [
        ("1,2,3", "expected 6"),
        ("1,2,3,4,5,x", "item 6 ('x') is not a number"),
        ("5,0,0,1,1,1", "xmin 5.0 must be below xmax 1.0"),
    ],
)
def test_bad_box(
    run_cli: RunCli,
    assert_one_line_error: OneLineError,
    files: dict[str, Path],
    box: str,
    fragment: str,
) -> None:
    code, out, err = run_cli(
        ["validate", "flatness", "--cloud", str(files["wall_ok"]), "--box", box]
    )
    assert_one_line_error(code, out, err, fragment)


def test_unknown_crs(
    run_cli: RunCli, assert_one_line_error: OneLineError, files: dict[str, Path]
) -> None:
    code, out, err = run_cli(
        ["validate", "flatness", "--cloud", str(files["wall_ok"]), "--box", _box(files),
         "--crs", "EPSG:999999"]
    )  # fmt: skip
    assert_one_line_error(code, out, err, "--crs 'EPSG:999999'", "unknown coordinate reference")


def test_missing_columns_and_files(
    run_cli: RunCli, assert_one_line_error: OneLineError, files: dict[str, Path], tmp_path: Path
) -> None:
    cols = _columns(files["cloud_csv"])
    no_intensity = tmp_path / "no_intensity.csv"
    with TableChunkWriter(no_intensity) as w:
        w.write({k: v for k, v in cols.items() if k != "intensity"})
    args = ["--control", str(files["control"]), "--trajectory", str(files["trajectory"])]
    code, out, err = run_cli(["validate", "control-points", "--cloud", str(no_intensity), *args])
    assert_one_line_error(code, out, err, "missing column(s) ['intensity']")
    code, out, err = run_cli(
        ["validate", "control-points", "--cloud", str(tmp_path / "none.csv"), *args]
    )
    assert_one_line_error(code, out, err, "file not found")
    code, out, err = run_cli(
        ["validate", "flatness", "--cloud", str(tmp_path / "c.txt"), "--box", "0,0,0,1,1,1"]
    )
    assert_one_line_error(code, out, err, "file not found")
    bad_control = tmp_path / "control.csv"
    bad_control.write_text("name,northing,easting\nA,1,2\n")
    code, out, err = run_cli(
        ["validate", "control-points", "--cloud", str(files["cloud_csv"]),
         "--control", str(bad_control), "--trajectory", str(files["trajectory"])]
    )  # fmt: skip
    assert_one_line_error(code, out, err, "missing coordinate columns")


def test_no_control_point_found(
    run_cli: RunCli, assert_one_line_error: OneLineError, files: dict[str, Path], tmp_path: Path
) -> None:
    cp = read_control_points(files["control"])
    elsewhere = tmp_path / "elsewhere.csv"
    write_control_points(ControlPoints(cp.names, cp.pos_ecef_m + 100.0), elsewhere)
    code, out, err = run_cli(
        ["validate", "control-points", "--cloud", str(files["cloud_csv"]),
         "--control", str(elsewhere), "--trajectory", str(files["trajectory"])]
    )  # fmt: skip
    assert_one_line_error(code, out, err, "no point within 0.5 m of any of the 4 control points")
    # how far off they are (173 m each, the cloud's centre a few metres from the targets)
    far_m = float(re.search(r"about ([\d,.]+) m from the nearest control point", err)[1])  # type: ignore[index]
    assert 150.0 < far_m < 200.0
    code, out, err = run_cli(
        ["validate", "control-points", "--cloud", str(files["cloud_csv"]),
         "--control", str(files["control"]), "--trajectory", str(files["trajectory"]),
         "--min-intensity", "1e9"]
    )  # fmt: skip
    assert_one_line_error(code, out, err, "no control point found in the cloud", "W1:")


@pytest.mark.parametrize(
    ("extra", "fragment"),
    [
        (["--centre", "mean"], "--centre must be tukey, median or sphere"),
        (["--centre", "sphere"], "needs the target radius"),
        (["--centre", "sphere", "--target-radius-m", "0.8"], "smaller than the search radius"),
        (["--level", "2"], "--level"),
        # Help and check agree (help said x>=0, the check said "search_radius_m must be
        # positive"): the option is named with its span.
        (["--search-radius-m", "0"], "--search-radius-m 0: outside the span"),
        (["--centre", "sphere", "--target-radius-m", "0"], "--target-radius-m 0: outside the span"),
    ],
)
def test_bad_options(
    run_cli: RunCli,
    assert_one_line_error: OneLineError,
    files: dict[str, Path],
    extra: list[str],
    fragment: str,
) -> None:
    code, out, err = run_cli(
        ["validate", "control-points", "--cloud", str(files["cloud_csv"]),
         "--control", str(files["control"]), "--trajectory", str(files["trajectory"]), *extra]
    )  # fmt: skip
    assert_one_line_error(code, out, err, fragment)
