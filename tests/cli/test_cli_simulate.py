"""``kinsync simulate rotating-table`` and ``patch-test``: JSON, table, files, bad input."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from tests._cli_args import with_options

from kinsync.cli._options import parse_rates
from kinsync.errors import InputError
from kinsync.io.las import las_info, read_las_points
from kinsync.io.mount_file import read_mount, write_mount
from kinsync.io.passes import read_passes
from kinsync.io.sbet import read_sbet
from kinsync.mount import Mount
from kinsync.sim.patch_test import PatchTestConfig, simulate_patch_test

RunCli = Callable[[list[str]], tuple[int, str, str]]  # fixture run_cli in conftest.py

BASE = ["simulate", "rotating-table", "--rates-deg-s", "6", "--passes", "1"]


def test_json_summary_and_files(run_cli: RunCli, tmp_path: Path) -> None:
    out = tmp_path / "sim"
    code, stdout, _ = run_cli([*BASE, "--seed", "2", "--out", str(out), "--json"])
    assert code == 0
    doc = json.loads(stdout)
    assert doc["n_passes"] == 2
    assert doc["latency_s"] == pytest.approx(4.21e-3)
    assert doc["fifo_delay_s"] == 0.0
    assert doc["format"] == "csv"
    assert 1500 <= doc["mean_sphere_points_per_pass_by_rate"]["+6"] <= 2500
    passes = read_passes(out)
    assert [p.rate_deg_s for p in passes] == [6.0, -6.0]
    assert sum(p.n_points for p in passes) == doc["n_points"]
    truth = json.loads((out / "truth.json").read_text())
    assert truth["seed"] == 2
    assert truth["config"]["range_noise_m"] == 0.002
    assert truth["config"]["pass_attitude_error_deg"] == 0.0


def test_a_pass_attitude_error_is_simulated_and_in_the_truth(
    run_cli: RunCli, tmp_path: Path
) -> None:
    out = tmp_path / "sim"
    code, _, err = run_cli([*BASE, "--out", str(out), "--pass-attitude-error-deg", "0.004"])
    assert code == 0, err
    truth = json.loads((out / "truth.json").read_text())
    assert truth["config"]["pass_attitude_error_deg"] == 0.004
    errors = [p["attitude_error_ned_deg"] for p in truth["passes"]]
    assert len(errors) == 2
    assert all(len(e) == 3 and any(e) for e in errors)


def test_table_output(run_cli: RunCli, tmp_path: Path) -> None:
    code, stdout, _ = run_cli([*BASE, "--out", str(tmp_path / "t")])
    assert code == 0
    assert "passes written" in stdout
    assert "truth latency (ms)" in stdout
    assert "4.21" in stdout


def test_laz_raw_fifo_and_options(run_cli: RunCli, tmp_path: Path) -> None:
    out = tmp_path / "laz"
    argv = [*BASE, "--out", str(out), "--format", "laz", "--raw", "--json"]
    argv += ["--latency-ms", "2.5", "--fifo-bytes", "14", "--baud", "115200"]
    code, stdout, _ = run_cli([*argv, "--range-noise-m", "0.001"])
    assert code == 0
    doc = json.loads(stdout)
    assert doc["latency_s"] == pytest.approx(2.5e-3 + 14 * 10 / 115200)
    assert doc["imu_latency_s"] == pytest.approx(2.5e-3)
    assert (out / "pass_000.laz").is_file()
    assert (out / "raw" / "attitude.csv").is_file()
    assert (out / "raw" / "mount.toml").is_file()
    assert (out / "raw" / "pass_001.csv").is_file()
    assert len(read_passes(out)) == 2


@pytest.mark.parametrize(
    ("extra", "fragment"),
    [
        (["--passes", "-1"], "--passes -1: outside the span"),
        (["--rates-deg-s", "2,,x"], "item 2 is empty"),
        (["--rates-deg-s", "2,x"], "'x') is not a number"),
        (["--rates-deg-s", ""], "--rates-deg-s is empty"),
        (["--rates-deg-s", "0"], "must be a rate magnitude > 0"),
        (["--rates-deg-s", "-2"], "must be a rate magnitude > 0"),
        # A crash (1000: no profile at all in a pass) or passes latency sphere cannot use.
        (["--rates-deg-s", "6,1000"], "item 2 (1000): at 1000 deg/s the profiles cross"),
        (["--rates-deg-s", "400"], "the largest usable rate is 369 deg/s"),
        (
            ["--rates-deg-s", "0.001"],
            "--rates-deg-s 0.001 with --passes 1: the passes would scan 3,4",
        ),
        (["--format", "ply"], "--format must be csv, las or laz"),
        (["--fifo-bytes", "-3"], "--fifo-bytes -3: outside the span"),
        (["--range-noise-m", "-0.1"], "--range-noise-m -0.1: outside the span"),
        (["--pass-attitude-error-deg", "5"], "--pass-attitude-error-deg 5: outside the span"),
        (["--pass-attitude-error-deg", "nan"], "--pass-attitude-error-deg"),
        (["--passes", "two"], "--passes"),
        (["--baud", "9600"], "without --fifo-bytes there is no FIFO and it would not be used"),
    ],
)
def test_bad_input_exits_2_with_one_line(
    run_cli: RunCli, tmp_path: Path, extra: list[str], fragment: str
) -> None:
    code, stdout, stderr = run_cli(with_options([*BASE, "--out", str(tmp_path / "o")], extra))
    assert code == 2
    assert stdout == ""
    assert stderr.startswith("kinsync: error:")
    assert stderr.count("\n") == 1
    assert fragment in stderr
    assert not (tmp_path / "o").exists()


def test_the_rate_bound_in_the_help_is_the_simulators() -> None:
    from kinsync.cli.simulate import TABLE_MAX_RATE_DEG_S  # noqa: PLC0415
    from kinsync.sim.table_config import RotatingTableConfig  # noqa: PLC0415

    assert RotatingTableConfig().max_rate_deg_s == TABLE_MAX_RATE_DEG_S


def test_out_is_an_existing_file(run_cli: RunCli, tmp_path: Path) -> None:
    f = tmp_path / "file.txt"
    f.write_text("keep me")
    code, _, stderr = run_cli([*BASE, "--out", str(f)])
    assert code == 2
    assert "exists and is not a folder" in stderr
    assert f.read_text() == "keep me"


def test_out_is_required(run_cli: RunCli) -> None:
    code, _, stderr = run_cli(BASE)
    assert code == 2
    assert "--out" in stderr


def test_parse_rates() -> None:
    assert parse_rates(" 2, 4.5 ,18") == (2.0, 4.5, 18.0)
    with pytest.raises(InputError, match="inf"):
        parse_rates("2,inf")


# ---------------------------------------------------------------- simulate patch-test
PATCH = ["simulate", "patch-test", "--density", "0.01", "--passes", "1"]


def test_patch_test_json_summary_and_files(run_cli: RunCli, tmp_path: Path) -> None:

    out = tmp_path / "patch"
    code, stdout, stderr = run_cli([*PATCH, "--out", str(out), "--seed", "3", "--json"])
    assert code == 0, stderr
    doc = json.loads(stdout)
    assert doc["scenario"] == "vehicle"
    assert doc["seed"] == 3
    assert doc["format"] == "laz"
    assert doc["n_lines"] == 4
    assert doc["files"] == [
        "trajectory.out",
        "mount.toml",
        "line_01.laz",
        "line_02.laz",
        "line_03.laz",
        "line_04.laz",
        "truth.json",
    ]
    assert sorted(p.name for p in out.iterdir()) == sorted(doc["files"])
    assert [line["direction"] for line in doc["lines"]] == ["outbound", "return"] * 2
    assert [line["speed_m_s"] for line in doc["lines"]] == [5.0, 5.0, 12.0, 12.0]
    counts = [las_info(out / line["file"]).point_count for line in doc["lines"]]
    assert counts == [line["n_points"] for line in doc["lines"]]
    assert sum(counts) == doc["n_points"]
    assert doc["errors"]["latency_s"] == pytest.approx(0.005)
    truth = json.loads((out / "truth.json").read_text())
    assert truth["gps_week"] == doc["gps_week"] == 2345
    assert truth["mount_true"] == doc["mount_true"]
    nav = read_sbet(out / "trajectory.out", gps_week=doc["gps_week"])
    assert nav.t_start_s == pytest.approx(2345 * 604800.0 + 216000.0, abs=1e-6)
    nominal = read_mount(out / "mount.toml")
    assert list(nominal.boresight_rpy_deg) == doc["mount_nominal"]["boresight_rpy_deg"]


def test_patch_test_table_and_options(run_cli: RunCli, tmp_path: Path) -> None:
    out = tmp_path / "vessel"
    argv = [*PATCH, "--out", str(out), "--scenario", "vessel", "--format", "las"]
    argv += ["--latency-ms", "-2.5", "--boresight-error-deg", "0.1,0.2,-0.3"]
    argv += ["--lever-arm-error-m", "0,0,0.05", "--speeds-m-s", "3", "--no-spheres"]
    code, stdout, stderr = run_cli([*argv, "--range-noise-m", "0.005"])
    assert code == 0, stderr
    assert "Patch-test simulation (vessel)" in stdout
    assert "GPS week (--gps-week)" in stdout
    assert "line_02.las (return, 3 m/s)" in stdout
    truth = json.loads((out / "truth.json").read_text())
    assert truth["errors"]["latency_s"] == pytest.approx(-2.5e-3)
    assert truth["errors"]["boresight_rpy_deg"] == [0.1, 0.2, -0.3]
    assert truth["errors"]["lever_arm_body_m"] == [0.0, 0.0, 0.05]
    assert truth["config"]["range_noise_m"] == 0.005
    assert truth["scene"]["spheres"] == []
    assert len(truth["lines"]) == 2
    assert (out / "line_01.las").is_file()
    # running again into the same folder replaces the earlier simulation
    code, _, stderr = run_cli([*PATCH, "--out", str(out), "--json"])
    assert code == 0, stderr
    assert not (out / "line_01.las").exists()
    assert (out / "line_04.laz").is_file()


def test_patch_test_lines_georeference_onto_the_scene(run_cli: RunCli, tmp_path: Path) -> None:
    """kinsync georef with the true mount puts a written line back on the scene."""

    out = tmp_path / "patch"
    code, stdout, stderr = run_cli([*PATCH, "--out", str(out), "--json"])
    assert code == 0, stderr
    truth = json.loads((out / "truth.json").read_text())
    for which in ("mount_true", "mount_nominal"):
        m = truth[which]
        mount = Mount(
            lever_arm_body_m=tuple(m["lever_arm_body_m"]),
            boresight_rpy_deg=tuple(m["boresight_rpy_deg"]),
            latency_s=m["latency_s"],
            profiler_azimuth_deg=m["profiler_azimuth_deg"],
        )
        write_mount(mount, tmp_path / f"{which}.toml")
    # the same simulation in memory says which feature each return hit
    sim = simulate_patch_test(PatchTestConfig(density=0.01, passes_per_direction=1))
    rms = {}
    for which in ("mount_true", "mount_nominal"):
        geo = tmp_path / f"line_03_{which}.laz"
        argv = ["georef", "--points", str(out / "line_03.laz"), "--trajectory"]
        argv += [str(out / "trajectory.out"), "--gps-week", str(truth["gps_week"])]
        argv += ["--mount", str(tmp_path / f"{which}.toml"), "--out", str(geo), "--json"]
        code, stdout, stderr = run_cli(argv)
        assert code == 0, stderr
        assert json.loads(stdout)["points_rejected"] == 0
        pts = read_las_points(geo, 0, las_info(geo).point_count)
        ecef = np.column_stack([pts.x, pts.y, pts.z])
        d = sim.scene.distance_to_hit_feature_m(sim.scene.ecef_to_scene(ecef), sim.line_hit_ids[2])
        rms[which] = float(np.sqrt(np.mean(d**2)))
    assert rms["mount_true"] < 0.06  # the navigation errors: a few cm
    assert rms["mount_nominal"] > 1.3 * rms["mount_true"]


@pytest.mark.parametrize(
    ("extra", "fragment"),
    [
        (["--scenario", "plane"], "--scenario must be vehicle or vessel"),
        (["--format", "csv"], "--format must be laz or las"),
        (["--density", "0"], "--density 0: outside the span"),
        (["--density", "1.5"], "--density 1.5: outside the span"),
        (["--passes", "0"], "--passes 0: outside the span"),
        (["--latency-ms", "nan"], "--latency-ms nan: not a finite number"),
        (["--latency-ms", "900"], "latency error 0.9 s"),
        (["--speeds-m-s", "5,x"], "item 2 ('x') is not a number"),
        (["--speeds-m-s", "5,-1"], "must be a speed > 0 m/s"),
        (["--speeds-m-s", "5,100"], "outside [0.2, 40] m/s"),
        (["--boresight-error-deg", "1,2"], "--boresight-error-deg '1,2': expected three"),
        (["--boresight-error-deg", "0,9,0"], "within 5 deg"),
        (["--lever-arm-error-m", "a,b,c"], "--lever-arm-error-m"),
        (["--range-noise-m", "-1"], "--range-noise-m -1: outside the span"),
        (["--seed", "-1"], "--seed"),
    ],
)
def test_patch_test_bad_input_exits_2_with_one_line(
    run_cli: RunCli, tmp_path: Path, extra: list[str], fragment: str
) -> None:
    code, stdout, stderr = run_cli(with_options([*PATCH, "--out", str(tmp_path / "o")], extra))
    assert code == 2
    assert stdout == ""
    assert stderr.startswith("kinsync: error:")
    assert stderr.count("\n") == 1, stderr
    assert fragment in stderr
    assert not (tmp_path / "o").exists()


def test_patch_test_refuses_a_folder_of_other_files(run_cli: RunCli, tmp_path: Path) -> None:
    out = tmp_path / "busy"
    out.mkdir()
    (out / "survey.laz").write_bytes(b"not ours")
    code, stdout, stderr = run_cli([*PATCH, "--out", str(out)])
    assert code == 2
    assert stdout == ""
    assert "--out" in stderr
    assert "holds other files" in stderr
    assert (out / "survey.laz").read_bytes() == b"not ours"
    assert sorted(p.name for p in out.iterdir()) == ["survey.laz"]
