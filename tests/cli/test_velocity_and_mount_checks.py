"""The command line on inconsistent trajectory velocities and on mount / INS TOML files.

Velocities that disagree with the positions: ``trajectory info`` and ``georef`` warn on
stderr (and under ``warnings`` with --json) and positions are interpolated linearly;
honest velocities give no warning. Mount files: a byte-order mark is accepted, a
missing ``latency_s`` or an absurd value is a one-line error naming the file and the key.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pyarrow.csv as pa_csv
import pytest

from kinsync.georef import GeorefTrajectory, georeference
from kinsync.io.mount_file import write_mount
from kinsync.io.points import TableChunkWriter
from kinsync.io.sbet import SECONDS_PER_WEEK, write_sbet
from kinsync.io.trajectory_csv import write_trajectory_csv
from kinsync.mount import Mount
from kinsync.sim._route import oval_route
from kinsync.sim.drive_truth import simulate_truth
from kinsync.trajectory import Trajectory

RunCli = Callable[[list[str]], tuple[int, str, str]]  # fixture run_cli in conftest.py
OneLineError = Callable[..., None]  # fixture assert_one_line_error in conftest.py

WEEK = 2300
T0 = WEEK * SECONDS_PER_WEEK + 200_000.0
MOUNT = Mount(lever_arm_body_m=(0.4, 0.1, -1.1), boresight_rpy_deg=(0.3, -0.2, 91.0))
N_POINTS = 1500
BOM = "\ufeff"


@pytest.fixture(scope="module")
def honest() -> Trajectory:
    """A 200 Hz drive on GPS time with its exact velocities."""
    return simulate_truth(
        oval_route(speed_m_s=6.0, straight_m=40.0, radius_m=12.0, static_s=2.0),
        rate_hz=200.0,
        t_start_s=T0,
        undulation_amplitude_m=0.2,
    )


def _zero_velocities(traj: Trajectory) -> Trajectory:
    return Trajectory(
        t_s=traj.t_s,
        q_body_to_ned=traj.q_body_to_ned,
        lat_lon_h=traj.lat_lon_h,
        vel_ned_m_s=np.zeros((len(traj), 3)),
    )


def _write_points(path: Path, traj: Trajectory) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(11)
    cols = {
        "t_s": np.sort(rng.uniform(traj.t_start_s + 1.0, traj.t_end_s - 1.0, N_POINTS)),
        "x_m": rng.uniform(-1.0, 1.0, N_POINTS),
        "y_m": rng.uniform(-15.0, 15.0, N_POINTS),
        "z_m": rng.uniform(-4.0, 4.0, N_POINTS),
    }
    with TableChunkWriter(path) as w:
        w.write(cols)
    return cols


# ---------------------------------------------------------------- trajectory info


def test_info_warns_about_zero_sbet_velocities(
    honest: Trajectory, tmp_path: Path, run_cli: RunCli
) -> None:
    path = tmp_path / "converted.out"
    write_sbet(_zero_velocities(honest), path)
    code, out, err = run_cli(["trajectory", "info", str(path), "--gps-week", str(WEEK), "--json"])
    assert code == 0, err
    doc = json.loads(out)  # stdout is the JSON object only
    check = doc["velocity_check"]
    assert check["consistent"] is False
    assert check["velocity_scale"] == pytest.approx(0.0, abs=1e-9)
    assert len(doc["warnings"]) == 1
    assert doc["warnings"][0].startswith(f"{path}: trajectory velocities disagree")
    assert err.count("\n") == 1
    assert err.startswith(f"kinsync: warning: {path}: ")
    assert "interpolated linearly" in err
    code, out, err = run_cli(["trajectory", "info", str(path)])  # the table
    assert code == 0, err
    assert "linearly (velocities disagree" in out
    assert "kinsync: warning:" in err


def test_info_is_silent_on_honest_velocities(
    honest: Trajectory, tmp_path: Path, run_cli: RunCli
) -> None:
    sbet = tmp_path / "honest.out"
    write_sbet(honest, sbet, wander_angle_rad=0.7)
    csv = tmp_path / "honest.csv"
    write_trajectory_csv(honest, csv)
    for path, extra in ((sbet, ["--gps-week", str(WEEK)]), (csv, [])):
        code, out, err = run_cli(["trajectory", "info", str(path), *extra, "--json"])
        assert code == 0, err
        assert err == ""
        doc = json.loads(out)
        assert doc["velocity_check"]["consistent"] is True
        assert doc["velocity_check"]["velocity_scale"] == pytest.approx(1.0, abs=1e-6)
        assert doc["warnings"] == []
        code, out, err = run_cli(["trajectory", "info", str(path), *extra])
        assert code == 0, err
        assert err == ""
        assert "cubic Hermite (velocities agree)" in out


def test_info_without_velocities_has_no_check(
    honest: Trajectory, tmp_path: Path, run_cli: RunCli
) -> None:
    path = tmp_path / "plain.csv"
    plain = Trajectory(
        t_s=honest.t_s, q_body_to_ned=honest.q_body_to_ned, lat_lon_h=honest.lat_lon_h
    )
    write_trajectory_csv(plain, path)
    code, out, err = run_cli(["trajectory", "info", str(path), "--json"])
    assert code == 0, err
    doc = json.loads(out)
    assert doc["velocity_check"] is None
    assert doc["warnings"] == []


# ---------------------------------------------------------------- georef


@pytest.mark.parametrize("kind", ["sbet", "csv"])
def test_georef_warns_and_interpolates_linearly(
    honest: Trajectory, tmp_path: Path, run_cli: RunCli, kind: str
) -> None:
    broken = _zero_velocities(honest)
    traj_path = tmp_path / ("traj.out" if kind == "sbet" else "traj.csv")
    if kind == "sbet":
        write_sbet(broken, traj_path)
    else:
        write_trajectory_csv(broken, traj_path)
    write_mount(MOUNT, tmp_path / "mount.toml")
    cols = _write_points(tmp_path / "points.csv", honest)
    out = tmp_path / "geo.csv"
    args = [
        "georef",
        "--points",
        str(tmp_path / "points.csv"),
        "--trajectory",
        str(traj_path),
        "--mount",
        str(tmp_path / "mount.toml"),
        "--out",
        str(out),
        *(["--gps-week", str(WEEK)] if kind == "sbet" else []),  # a CSV carries GPS time
    ]
    code, stdout, err = run_cli([*args, "--json"])
    assert code == 0, err
    doc = json.loads(stdout)
    assert doc["points_out"] == N_POINTS
    assert len(doc["warnings"]) == 1
    assert doc["warnings"][0].startswith(f"{traj_path}: trajectory velocities disagree")
    assert err.startswith(f"kinsync: warning: {traj_path}: ")
    assert err.count("\n") == 1
    # The output is the linear interpolation: what a trajectory without velocities gives.
    plain = Trajectory(
        t_s=honest.t_s, q_body_to_ned=honest.q_body_to_ned, lat_lon_h=honest.lat_lon_h
    )
    xyz = np.column_stack([cols["x_m"], cols["y_m"], cols["z_m"]])
    want, inside = georeference(cols["t_s"], xyz, GeorefTrajectory.from_trajectory(plain), MOUNT)
    assert inside.all()
    table = pa_csv.read_csv(out)
    got = np.column_stack([table.column(c).to_numpy() for c in ("X", "Y", "Z")])
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-6)
    out.unlink()
    code, stdout, err = run_cli(args)  # the table: the warning still on stderr
    assert code == 0, err
    assert "kinsync: warning:" in err
    assert "Georeferenced" in stdout


def test_georef_is_silent_on_honest_velocities(
    honest: Trajectory, tmp_path: Path, run_cli: RunCli
) -> None:
    write_sbet(honest, tmp_path / "traj.out")
    write_mount(MOUNT, tmp_path / "mount.toml")
    _write_points(tmp_path / "points.csv", honest)
    code, stdout, err = run_cli(
        [
            "georef",
            "--points",
            str(tmp_path / "points.csv"),
            "--trajectory",
            str(tmp_path / "traj.out"),
            "--mount",
            str(tmp_path / "mount.toml"),
            "--out",
            str(tmp_path / "geo.csv"),
            "--gps-week",
            str(WEEK),
            "--json",
        ]
    )
    assert code == 0, err
    assert err == ""
    assert json.loads(stdout)["warnings"] == []


# ---------------------------------------------------------------- mount files


def _georef_args(tmp_path: Path, mount: Path, *extra: str) -> list[str]:
    return [
        "georef",
        "--points",
        str(tmp_path / "points.csv"),
        "--trajectory",
        str(tmp_path / "traj.csv"),
        "--mount",
        str(mount),
        "--out",
        str(tmp_path / "geo.csv"),
        *extra,
    ]


@pytest.fixture
def survey(honest: Trajectory, tmp_path: Path) -> Path:
    write_trajectory_csv(honest, tmp_path / "traj.csv")
    _write_points(tmp_path / "points.csv", honest)
    return tmp_path


@pytest.mark.parametrize(
    ("text", "fragments"),
    [
        (
            "[mount]\nlever_arm_body_m = [0.1, 0.2, 0.3]\nboresight_rpy_deg = [0.0, 0.0, 90.0]\n",
            ["latency_s is missing", "latency_s = 0.0"],
        ),
        ("[mount]\nlatency_s = 1e308\n", ["latency_s = 1e+308 s", "+-10 s"]),
        ("[mount]\nlatency_s = 0.0\nlever_arm_body_m = [0, 0, 1e308]\n", ["lever_arm_body_m[2]"]),
        ("[mount]\nlatency_s = 0.0\nboresight_rpy_deg = [0, 1e5, 0]\n", ["boresight_rpy_deg[1]"]),
        ("[mount]\nlatency_s = = 0.1\n", ["line 2, column 13", "malformed TOML"]),
        ("[mount]\nlatency_s = 1" + "0" * 400 + "\n", ["latency_s", "digit integer"]),
    ],
    ids=["no-latency", "latency-1e308", "lever-arm-1e308", "boresight-1e5", "syntax", "huge-int"],
)
def test_bad_mount_is_one_line_error_in_every_reader(
    survey: Path,
    run_cli: RunCli,
    assert_one_line_error: OneLineError,
    text: str,
    fragments: list[str],
) -> None:
    mount = survey / "mount.toml"
    mount.write_text(text, encoding="utf-8")
    code, out, err = run_cli(["mount", "check", str(mount)])
    assert_one_line_error(code, out, err, str(mount), *fragments)
    code, out, err = run_cli(_georef_args(survey, mount))
    assert_one_line_error(code, out, err, str(mount), *fragments)
    assert "repeated" not in err
    assert not (survey / "geo.csv").exists()


def test_absurd_latency_option_is_named(
    survey: Path, run_cli: RunCli, assert_one_line_error: OneLineError
) -> None:
    write_mount(MOUNT, survey / "mount.toml")
    args = _georef_args(survey, survey / "mount.toml", "--latency-ms", "1e308")
    code, out, err = run_cli(args)
    assert_one_line_error(code, out, err, "latency", "10")  # the option or latency_s named
    assert "repeated" not in err


def test_mount_with_bom_is_read(survey: Path, run_cli: RunCli) -> None:
    mount = survey / "mount.toml"
    text = (
        "[mount]\r\nlever_arm_body_m = [0.4, 0.1, -1.1]\r\n"
        "boresight_rpy_deg = [0.3, -0.2, 91.0]\r\n"
        "antenna_lever_arm_body_m = [0.0, 0.0, 0.0]\r\nlatency_s = 0.0025\r\n"
    )
    mount.write_bytes((BOM + text).encode("utf-8"))
    code, out, err = run_cli(["mount", "check", str(mount), "--json"])
    assert code == 0, err
    assert json.loads(out)["latency_s"] == 0.0025
    code, out, err = run_cli([*_georef_args(survey, mount), "--json"])
    assert code == 0, err
    assert json.loads(out)["points_out"] == N_POINTS


def test_ins_configuration_bom_and_syntax_error(
    tmp_path: Path, run_cli: RunCli, assert_one_line_error: OneLineError
) -> None:
    config = tmp_path / "ins.toml"
    config.write_bytes(
        (
            BOM + "[imu]\ngyro_arw_rad_s_rthz = 1e-4\nacc_vrw_m_s2_rthz = 1e-3\n"
            "gyro_bias_sigma_rad_s = 1e-3\nacc_bias_sigma_m_s2 = 0.01\n"
            "gyro_bias_instability_rad_s = 1e-5\nacc_bias_instability_m_s2 = 1e-4\n"
        ).encode("utf-8")
    )
    args = [
        "ins",
        "run",
        "--imu",
        str(tmp_path / "imu.csv"),
        "--gnss",
        str(tmp_path / "gnss.csv"),
        "--config",
        str(config),
        "--out",
        str(tmp_path / "nav.csv"),
    ]
    code, out, err = run_cli(args)  # the configuration reads; the IMU file is missing
    assert_one_line_error(code, out, err, "imu.csv")
    assert str(config) not in err
    config.write_text("[imu]\ngyro_arw_rad_s_rthz = \n", encoding="utf-8")
    code, out, err = run_cli(args)
    assert_one_line_error(code, out, err, str(config), "line 2, column 23", "malformed TOML")
