"""``kinsync ins run`` and ``kinsync ins compare`` on a NaveGo slice; bad input."""

from __future__ import annotations

import json
import math
import re
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from tests._trajectory_holes import with_gap

from kinsync.cli import _progress
from kinsync.ins.solution import NavSolution
from kinsync.io.nav_csv import read_nav_csv, read_navigation
from kinsync.io.sbet import read_sbet
from kinsync.io.smrmsg import find_smrmsg_companion, read_smrmsg
from kinsync.io.trajectory_csv import read_trajectory_csv, write_trajectory_csv
from kinsync.sim.drive import DriveSimConfig, simulate_drive, write_drive_simulation
from kinsync.trajectory_gaps import gap_threshold_shown_s

RunCli = Callable[[list[str]], tuple[int, str, str]]  # fixture run_cli in conftest.py
OneLineError = Callable[..., None]  # fixture assert_one_line_error in conftest.py

NAVEGO = Path(__file__).resolve().parents[3] / "shared" / "data" / "navego-synthetic"
CONFIG = Path(__file__).resolve().parents[2] / "configs" / "navego-adis16488.toml"
SLICE_S = 60.0
IMU_ROWS = 12_000  # 200 Hz for 60 s
GNSS_ROWS = 300  # 5 Hz
KEYS = ("imu", "gnss", "truth")


def _head(src: Path, dst: Path, rows: int) -> Path:
    with src.open() as fh:
        lines = [next(fh) for _ in range(rows + 1)]
    dst.write_text("".join(lines))
    return dst


@pytest.fixture(scope="module")
def navego(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The first 60 s of the NaveGo set."""
    d = tmp_path_factory.mktemp("navego")
    return {
        "dir": d,
        "imu": _head(NAVEGO / "imu.csv", d / "imu.csv", IMU_ROWS),
        "gnss": _head(NAVEGO / "gnss.csv", d / "gnss.csv", GNSS_ROWS),
        "truth": _head(NAVEGO / "truth.csv", d / "truth.csv", IMU_ROWS),
    }


def _run_args(navego: dict[str, Path], out: Path, *extra: str) -> list[str]:
    return [
        "ins",
        "run",
        "--imu",
        str(navego["imu"]),
        "--gnss",
        str(navego["gnss"]),
        "--config",
        str(CONFIG),
        "--init-from",
        str(navego["truth"]),
        "--out",
        str(out),
        *extra,
    ]


def test_run_json_then_compare(
    run_cli: RunCli, navego: dict[str, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(_progress, "HOLD_S", 0.0)  # stage lines however quick the run
    out = tmp_path / "nav.csv"
    code, stdout, stderr = run_cli(_run_args(navego, out, "--json"))
    assert code == 0, stderr
    assert stdout.count("\n") == 1
    doc = json.loads(stdout)
    assert doc["epochs"] == IMU_ROWS
    assert doc["gnss_used"] + doc["gnss_rejected"] == GNSS_ROWS
    assert doc["gnss_used"] >= 0.95 * GNSS_ROWS
    assert doc["seconds"] > 0
    assert doc["epochs_per_s"] == pytest.approx(IMU_ROWS / doc["seconds"])
    assert doc["out"] == str(out)
    assert doc["smoothed"] is False
    assert doc["warnings"] == []
    assert doc["error_states"] == 21  # --init-from: no levelled standstill
    # stderr is not a terminal here: one line per stage, the filter then the writing
    stages = [line.split(": ")[2].rsplit(" (", 1)[0] for line in stderr.splitlines()]
    assert [s for s in stages if not s.startswith("compiling")] == ["filter", "writing"]
    sol = read_nav_csv(out)
    assert len(sol) == IMU_ROWS

    code, stdout, stderr = run_cli(["ins", "compare", str(out), str(navego["truth"]), "--json"])
    assert code == 0, stderr
    cmp = json.loads(stdout)
    assert cmp["n_epochs"] == IMU_ROWS
    # GNSS σ 5/5/10 m: the 60 s forward solution stays within a few metres of the truth.
    assert max(cmp["rms_pos_ned_m"]) < 3.0, cmp
    assert max(cmp["rms_vel_ned_m_s"]) < 0.1, cmp
    roll, pitch, yaw = cmp["rms_att_deg"]
    assert max(roll, pitch) < 0.5, cmp
    assert yaw < 2.0, cmp  # heading converges over the first minute (measured ~1.0 deg)
    assert all(m >= r for m, r in zip(cmp["max_pos_ned_m"], cmp["rms_pos_ned_m"], strict=True))
    shares = cmp["within_3sigma"]
    for key in ("pos_n", "pos_e", "pos_d", "vel_n", "vel_e", "vel_d"):
        assert shares[key] > 0.9, (key, shares)


def test_run_with_calibrated_biases_and_scale_factors(
    run_cli: RunCli, navego: dict[str, Path], tmp_path: Path
) -> None:
    """``[init]`` turn-on biases and ``[imu]`` scale factor σ reach the filter: 27 states,
    the scale factor columns in the solution, the table's bias and scale rows."""
    text = CONFIG.read_text()
    text = text.replace(
        "[init]\n",
        "[init]\ngyro_bias_deg_s = [0.2, 0.2, 0.2]\ngyro_bias_std_deg_h = [36.0, 36.0, 36.0]\n"
        "acc_bias_mg = [16.0, 16.0, 16.0]\nacc_bias_std_mg = [1.0, 1.0, 1.0]\n",
    )
    text = text.replace(
        "[gnss]\n",
        "gyro_scale_factor_sigma_ppm = 1000.0\nacc_scale_factor_sigma_ppm = 1000.0\n\n[gnss]\n",
    )
    config = tmp_path / "calibrated.toml"
    config.write_text(text)
    out = tmp_path / "nav.csv"
    args = _run_args(navego, out, "--json")
    args[args.index("--config") + 1] = str(config)
    code, stdout, stderr = run_cli(args)
    assert code == 0, stderr
    doc = json.loads(stdout)
    assert doc["error_states"] == 27
    assert doc["turn_on_biases"] == "calibrated"
    assert len(doc["final_gyro_scale_ppm"]) == 3
    # started from 0.2 deg/s = 720 deg/h and known to 36 deg/h: it stays near there
    assert all(abs(b - 720.0) < 150.0 for b in doc["final_gyro_bias_deg_h"])
    sol = read_nav_csv(out)
    assert sol.gyro_scale_ppm is not None
    assert sol.std_acc_scale_ppm is not None
    assert (sol.std_acc_scale_ppm[-1] < 1000.0).all()  # the data told it something
    args = _run_args(navego, tmp_path / "table.csv")
    args[args.index("--config") + 1] = str(config)
    code, stdout, stderr = run_cli(args)
    assert code == 0, stderr
    assert "error states (turn-on biases calibrated)" in stdout
    assert "final gyro scale factor" in stdout


def test_run_smoothed_sbet_with_table(
    run_cli: RunCli, navego: dict[str, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(_progress, "HOLD_S", 0.0)  # stage lines however quick the run
    out = tmp_path / "nav.sbet"
    code, stdout, stderr = run_cli(_run_args(navego, out, "--smooth"))
    assert code == 0, stderr
    for text in ("epochs written", "12000", "smoothed (RTS)", "GNSS epochs used", "final σ"):
        assert text in stdout, stdout
    assert "kinsync: ins run: smoother (" in stderr  # the stage lines, not on stdout
    assert "kinsync:" not in stdout
    # times from 0: seconds of week already, their week unknown; σ beside the SBET
    assert re.search(r"SBET GPS week\s*│\s*not known", stdout), stdout
    assert "smrmsg_nav.out" in stdout
    assert (tmp_path / "smrmsg_nav.out").stat().st_size == 80 * IMU_ROWS
    assert "nav.sbet: the SBET's body accelerations (fields 11-13) are written as 0" in stderr
    nav = read_navigation(out)
    assert not isinstance(nav, NavSolution)
    assert len(nav) == IMU_ROWS
    code, stdout, stderr = run_cli(["ins", "compare", str(out), str(navego["truth"])])
    assert code == 0, stderr
    for text in ("position RMS (m)", "attitude max (deg)", "12000 epochs"):
        assert text in stdout, stdout
    assert "within 3σ" not in stdout  # an SBET carries no σ
    code, stdout, _ = run_cli(["ins", "compare", str(out), str(navego["truth"]), "--json"])
    cmp = json.loads(stdout)
    assert cmp["within_3sigma"] is None
    assert max(cmp["rms_pos_ned_m"]) < 2.0, cmp


def _shifted(src: Path, dst: Path, offset_s: float) -> Path:
    """A copy of a CSV whose first column (the time) is ``offset_s`` later."""
    lines = src.read_text().splitlines()
    rows = [
        f"{float(t) + offset_s:.4f},{rest}" for t, rest in (ln.split(",", 1) for ln in lines[1:])
    ]
    dst.write_text("\n".join([lines[0], *rows]) + "\n")
    return dst


def test_run_sbet_names_its_gps_week_and_writes_its_sigmas_beside_it(
    run_cli: RunCli, navego: dict[str, Path], tmp_path: Path
) -> None:
    """GPS-time inputs: the SBET's week is said, its σ are in the smrmsg found beside it."""
    offset_s = 2345 * 604_800.0 + 3_600.0
    shifted = {k: _shifted(navego[k], tmp_path / f"{k}.csv", offset_s) for k in KEYS}
    out, csv = tmp_path / "sbet_run.out", tmp_path / "run.csv"
    code, stdout, stderr = run_cli(_run_args(shifted | {"dir": tmp_path}, out, "--json"))
    assert code == 0, stderr
    doc = json.loads(stdout)
    assert doc["sbet_gps_week"] == 2345
    companion = tmp_path / "smrmsg_run.out"
    assert doc["smrmsg"] == str(companion)
    assert find_smrmsg_companion(out) == companion
    assert any("body accelerations (fields 11-13) are written as 0" in w for w in doc["warnings"])
    sbet = read_sbet(out, gps_week=2345)
    sigma = read_smrmsg(companion, gps_week=2345)
    np.testing.assert_allclose(sigma.t_s, sbet.t_s, rtol=0, atol=1e-6)
    assert sbet.t_s[0] == pytest.approx(offset_s, abs=1e-3)
    code, _, stderr = run_cli(_run_args(shifted | {"dir": tmp_path}, csv))
    assert code == 0, stderr
    sol = read_nav_csv(csv)
    np.testing.assert_allclose(sigma.std_pos_ned_m, sol.std_pos_ned_m, rtol=1e-12)
    np.testing.assert_allclose(sigma.std_vel_ned_m_s, sol.std_vel_ned_m_s, rtol=1e-12)
    np.testing.assert_allclose(sigma.std_rpy_rad, sol.std_rpy_rad(), rtol=1e-12)


def test_run_positions_only_warns_about_gnss_outside_the_imu_span(
    run_cli: RunCli, navego: dict[str, Path], tmp_path: Path
) -> None:
    gnss = _head(NAVEGO / "gnss.csv", tmp_path / "gnss_long.csv", GNSS_ROWS + 5)
    argv = _run_args(navego, tmp_path / "nav.csv", "--no-velocity", "--json")
    argv[argv.index(str(navego["gnss"]))] = str(gnss)
    code, stdout, stderr = run_cli(argv)
    assert code == 0, stderr
    assert stderr.startswith("kinsync: warning: ")
    assert "5 GNSS epoch(s) outside the IMU span" in stderr
    # each with its file line, as the errors name them (review N3: rows alone)
    assert "rows 300 (line 302), 301 (line 303), 302 (line 304), 303 (line 305), 304" in stderr
    doc = json.loads(stdout)
    assert doc["gnss_used"] + doc["gnss_rejected"] == GNSS_ROWS
    assert len(doc["warnings"]) == 1


def test_run_with_static_alignment_on_a_simulated_drive(run_cli: RunCli, tmp_path: Path) -> None:
    """Without --init-from: static levelling + GNSS heading (navigation-grade IMU, RTK)."""
    sim = simulate_drive(DriveSimConfig(duration_s=60.0, static_s=10.0, imu="navigation"))
    write_drive_simulation(sim, tmp_path)
    out = tmp_path / "nav.csv"
    argv = ["ins", "run", "--imu", str(tmp_path / "imu.csv"), "--gnss", str(tmp_path / "gnss.csv")]
    argv += ["--config", str(tmp_path / "ins.toml"), "--static-s", "8", "--out", str(out)]
    code, stdout, stderr = run_cli([*argv, "--json"])
    assert code == 0, stderr
    doc = json.loads(stdout)
    # every IMU epoch has a solution and every GNSS epoch was used or rejected
    assert doc["epochs"] == len(sim.imu)
    assert doc["gnss_used"] + doc["gnss_rejected"] == len(sim.gnss)
    assert doc["warnings"] == []
    # 27 with the preset's scale factors, and the levelled standstill's vertical support
    # is one more (it said 27)
    assert doc["error_states"] == 28
    code, stdout, stderr = run_cli(
        ["ins", "compare", str(out), str(tmp_path / "truth.csv"), "--json"]
    )
    assert code == 0, stderr
    cmp = json.loads(stdout)
    # Measured: RMS 6-8 mm, roll/pitch 0.03/0.02 deg, yaw 0.11 deg.
    assert max(cmp["rms_pos_ned_m"]) < 0.05, cmp
    roll, pitch, yaw = cmp["rms_att_deg"]
    assert max(roll, pitch) < 0.2, cmp
    assert yaw < 0.5, cmp


def test_gnss_times_late_against_the_imu_name_the_first_fix(
    run_cli: RunCli, tmp_path: Path, assert_one_line_error: OneLineError
) -> None:
    """Review N3: GNSS times 18 s late (UTC vs GPS) gave 'no GNSS fix during the static
    period' without the file, its first fix or the likely cause."""
    sim = simulate_drive(DriveSimConfig(duration_s=40.0, static_s=10.0, imu="navigation"))
    write_drive_simulation(sim, tmp_path)
    gnss = tmp_path / "gnss.csv"
    header, *rows = gnss.read_text(encoding="utf-8").splitlines()
    late = [f"{float(r.split(',', 1)[0]) + 18.0!r},{r.split(',', 1)[1]}" for r in rows]
    gnss.write_text("\n".join([header, *late]) + "\n", encoding="utf-8")
    argv = ["ins", "run", "--imu", str(tmp_path / "imu.csv"), "--gnss", str(gnss)]
    argv += ["--config", str(tmp_path / "ins.toml"), "--out", str(tmp_path / "nav.csv")]
    t1 = float(late[0].split(",", 1)[0])
    assert_one_line_error(
        *run_cli(argv),
        f"{gnss}: no GNSS fix during the static period",
        f"The first fix is at t_s {t1:.3f} (row 0, line 2), 18.000 s after",
        "one file in UTC and the other in GPS time",
    )


def test_run_help_lists_options(run_cli: RunCli) -> None:
    code, stdout, _ = run_cli(["ins", "run", "--help"])
    assert code == 0
    for option in ("--imu", "--gnss", "--config", "--init-from", "--no-velocity", "--smooth"):
        assert option in stdout


def test_bad_output_suffix_and_folder(
    run_cli: RunCli, navego: dict[str, Path], tmp_path: Path, assert_one_line_error: OneLineError
) -> None:
    assert_one_line_error(*run_cli(_run_args(navego, tmp_path / "nav.txt")), "'.txt'", ".sbet")
    missing = tmp_path / "no" / "nav.csv"
    assert_one_line_error(*run_cli(_run_args(navego, missing)), "does not exist")


def test_bad_inputs_are_one_line_errors(
    run_cli: RunCli, navego: dict[str, Path], tmp_path: Path, assert_one_line_error: OneLineError
) -> None:
    out = tmp_path / "nav.csv"
    # A gap of 0.5 s in the IMU record (rows 1000-1099 removed).
    lines = navego["imu"].read_text().splitlines(keepends=True)
    gap = tmp_path / "gap.csv"
    gap.write_text("".join(lines[:1001] + lines[1101:]))
    argv = _run_args(navego, out)
    argv[argv.index(str(navego["imu"]))] = str(gap)
    between = "rows 999 (line 1001) and 1000 (line 1002)"
    assert_one_line_error(*run_cli(argv), str(gap), between, "max_imu_gap_s")
    # IMU specific force in g.
    header, *rows = lines
    in_g = tmp_path / "in_g.csv"
    scaled = []
    for row in rows:
        cells = row.strip().split(",")
        cells[4:] = [repr(float(c) / 9.80665) for c in cells[4:]]
        scaled.append(",".join(cells) + "\n")
    in_g.write_text(header + "".join(scaled))
    argv[argv.index(str(gap))] = str(in_g)
    assert_one_line_error(*run_cli(argv), "looks like g")
    # GNSS on another time scale.
    far = tmp_path / "far.csv"
    g_lines = navego["gnss"].read_text().splitlines()
    far.write_text(
        "\n".join(
            [g_lines[0]]
            + [f"{float(r.split(',')[0]) + 1e5}," + r.split(",", 1)[1] for r in g_lines[1:]]
        )
        + "\n"
    )
    argv = _run_args(navego, out)
    argv[argv.index(str(navego["gnss"]))] = str(far)
    assert_one_line_error(*run_cli(argv), "0 GNSS epoch(s) inside", "same time scale")
    # Configuration with a typo.
    cfg = tmp_path / "cfg.toml"
    cfg.write_text(CONFIG.read_text().replace("max_imu_gap_s", "max_gap_s"))
    argv = _run_args(navego, out)
    argv[argv.index(str(CONFIG))] = str(cfg)
    assert_one_line_error(*run_cli(argv), str(cfg), "max_gap_s")
    # A gap setting below the sampling interval: the setting is named, not the IMU file.
    tiny = tmp_path / "tiny_gap.toml"
    tiny.write_text(re.sub(r"max_imu_gap_s = \S+", "max_imu_gap_s = 1e-9", CONFIG.read_text()))
    argv[argv.index(str(cfg))] = str(tiny)
    assert_one_line_error(*run_cli(argv), str(tiny), "max_imu_gap_s = 1e-09 s is below")
    # Initial state without velocities, and one that does not reach the IMU span.
    plain = tmp_path / "plain.csv"
    plain.write_text(
        "t_s,lat_deg,lon_deg,h_m,roll_deg,pitch_deg,yaw_deg\n0,1,2,3,0,0,0\n1,1,2,3,0,0,0\n"
    )
    argv = _run_args(navego, out)
    argv[argv.index(str(navego["truth"]))] = str(plain)
    assert_one_line_error(*run_cli(argv), "--init-from", "vn_m_s")
    late = tmp_path / "late.csv"
    late.write_text(
        "t_s,lat_deg,lon_deg,h_m,vn_m_s,ve_m_s,vd_m_s,roll_deg,pitch_deg,yaw_deg\n"
        "100,1,2,3,0,0,0,0,0,0\n101,1,2,3,0,0,0,0,0,0\n"
    )
    argv[argv.index(str(plain))] = str(late)
    assert_one_line_error(*run_cli(argv), "--init-from", "does not reach the IMU span")
    # The IMU starts inside a data gap of the reference: its state there is not a guess.
    t0 = float(navego["imu"].read_text().splitlines()[1].split(",")[0])
    holed = tmp_path / "holed.csv"
    rows = [f"{t0 + dt!r},1,2,3,0,0,0,0,0,0" for dt in (-1.0, -0.99, -0.98, -0.97, 1.0, 1.01)]
    holed.write_text(late.read_text().splitlines()[0] + "\n" + "\n".join(rows) + "\n")
    argv[argv.index(str(late))] = str(holed)
    assert_one_line_error(*run_cli(argv), "--init-from", "inside a data gap", f"{t0 - 0.97!r} ..")
    assert not out.exists()
    # No --init-from on data without a static start, and a bad static period.
    argv = _run_args(navego, out)
    i = argv.index("--init-from")
    del argv[i : i + 2]
    assert_one_line_error(*run_cli(argv), "static")
    assert_one_line_error(*run_cli([*argv, "--static-s", "-1"]), "--static-s -1: outside the span")
    assert_one_line_error(
        *run_cli([*argv, "--static-s", "0"]), "--static-s 0: the levelling needs a standstill"
    )
    # A static period beside a given initial state: one of the two is not used.
    assert_one_line_error(
        *run_cli([*_run_args(navego, out), "--static-s", "3"]), "--static-s 3", "leave one out"
    )
    # Missing input file.
    argv = _run_args(navego, out)
    argv[argv.index(str(navego["imu"]))] = str(tmp_path / "none.csv")
    assert_one_line_error(*run_cli(argv), "none.csv", "not found")


def test_init_from_a_reference_with_a_gap_at_the_imu_start(
    run_cli: RunCli,
    navego: dict[str, Path],
    tmp_path: Path,
    assert_one_line_error: OneLineError,
) -> None:
    """The IMU starts 1 s into the drive, inside a 1 s hole of the reference: refused by
    default, naming the threshold and --max-gap-s; with --max-gap-s above the hole the
    state is interpolated across it and the filter runs."""
    imu_lines = navego["imu"].read_text().splitlines()
    gnss_lines = navego["gnss"].read_text().splitlines()
    imu = tmp_path / "imu.csv"
    imu.write_text("\n".join([imu_lines[0], *imu_lines[201:1001]]) + "\n")  # 1 s .. 5 s
    gnss = tmp_path / "gnss.csv"
    gnss.write_text("\n".join([gnss_lines[0], *gnss_lines[5:26]]) + "\n")
    t0 = float(imu_lines[201].split(",")[0])
    truth = read_trajectory_csv(navego["truth"])
    holed = tmp_path / "holed.csv"
    write_trajectory_csv(with_gap(truth, t0 - 0.5, t0 + 0.5), holed)
    out = tmp_path / "nav.csv"
    argv = _run_args(navego, out, "--json")
    for name, path in (("imu", imu), ("gnss", gnss), ("truth", holed)):
        argv[argv.index(str(navego[name]))] = str(path)
    limit = 10.0 * float(np.median(np.diff(truth.t_s)))
    assert_one_line_error(
        *run_cli(argv), "--init-from", "inside a data gap",
        f"record intervals longer than {gap_threshold_shown_s(limit):.6g} s", "--max-gap-s",
    )  # fmt: skip
    assert not out.exists()
    code, stdout, stderr = run_cli([*argv, "--max-gap-s", "1.5"])
    assert code == 0, stderr
    assert json.loads(stdout)["epochs"] == 800
    # without --init-from there is no reference for the threshold to apply to
    i = argv.index("--init-from")
    assert_one_line_error(
        *run_cli([*argv[:i], *argv[i + 2 :], "--max-gap-s", "1.5"]), "--max-gap-s", "--init-from"
    )


def test_compare_leaves_out_epochs_in_a_gap_of_the_reference(
    run_cli: RunCli, navego: dict[str, Path], tmp_path: Path
) -> None:
    """The truth against itself with 10 s cut out of the reference: no error is made up.

    Interpolated across the hole, the reference made the identical solution look
    decimetres and degrees wrong; now those epochs are left out, counted and named.
    """
    lines = navego["truth"].read_text().splitlines()
    t = np.array([float(ln.split(",")[0]) for ln in lines[1:]])
    hole = (t[0] + 20.0, t[0] + 30.0)
    kept = [ln for ln, tk in zip(lines[1:], t, strict=True) if not hole[0] < tk < hole[1]]
    holed = tmp_path / "truth_hole.csv"
    holed.write_text("\n".join([lines[0], *kept]) + "\n")
    n_hole = int(np.count_nonzero((t > hole[0]) & (t < hole[1])))
    argv = ["ins", "compare", str(navego["truth"]), str(holed)]
    code, stdout, stderr = run_cli([*argv, "--json"])
    assert code == 0, stderr
    doc = json.loads(stdout)
    assert doc["n_epochs_in_truth_gaps"] == n_hole > 1900
    assert doc["n_epochs"] == t.size - n_hole
    assert doc["n_epochs_outside_truth"] == 0
    assert [[g["t_start_s"], g["t_end_s"]] for g in doc["truth_gaps"]] == [list(hole)]
    assert max(doc["max_pos_ned_m"]) < 1e-6
    assert max(doc["max_att_deg"]) < 1e-6
    assert stderr.count("\n") == 1
    assert f"{n_hole} solution epochs left out, in 1 data gap of the reference" in stderr
    limit = 10.0 * float(np.median(np.diff(t)))  # the default threshold, named with its option
    assert doc["gap_threshold_s"] == pytest.approx(limit)
    shown = f"{gap_threshold_shown_s(limit):.6g}"
    assert f"record intervals longer than {shown} s (the gap threshold: --max-gap-s" in stderr
    code, stdout, stderr = run_cli(argv)
    assert code == 0, stderr
    assert f"left out: 0 epoch(s) outside the reference's span, {n_hole} in its data gaps" in (
        " ".join(stdout.split())
    )
    assert f"(record intervals longer than {shown} s, --max-gap-s)" in " ".join(stdout.split())
    # A reference legitimately this sparse: a threshold above the hole compares every epoch.
    code, stdout, stderr = run_cli([*argv, "--max-gap-s", "12", "--json"])
    assert code == 0, stderr
    assert stderr == ""
    doc = json.loads(stdout)
    assert doc["gap_threshold_s"] == 12.0
    assert doc["n_epochs_in_truth_gaps"] == 0
    assert doc["truth_gaps"] == []
    assert doc["n_epochs"] == t.size


def test_compare_bad_inputs(
    run_cli: RunCli, navego: dict[str, Path], tmp_path: Path, assert_one_line_error: OneLineError
) -> None:
    later = tmp_path / "later.csv"
    later.write_text(
        "t_s,lat_deg,lon_deg,h_m,vn_m_s,ve_m_s,vd_m_s,roll_deg,pitch_deg,yaw_deg\n"
        "100,1,2,3,0,0,0,0,0,0\n101,1,2,3,0,0,0,0,0,0\n"
    )
    assert_one_line_error(
        *run_cli(["ins", "compare", str(later), str(navego["truth"])]), "no common times"
    )
    assert_one_line_error(
        *run_cli(["ins", "compare", str(tmp_path / "x.txt"), str(navego["truth"])]), "'.txt'"
    )
    assert_one_line_error(
        *run_cli(["ins", "compare", str(tmp_path / "none.csv"), str(navego["truth"])]),
        "not found",
    )


def test_static_alignment_with_calibrated_biases(run_cli: RunCli, tmp_path: Path) -> None:
    """[init] biases without --init-from: levelled with them, not refused as given twice."""
    sim = simulate_drive(DriveSimConfig(duration_s=40.0, static_s=10.0, imu="navigation"))
    write_drive_simulation(sim, tmp_path)
    config = tmp_path / "ins.toml"
    text = config.read_text(encoding="utf-8").replace(
        "[init]\n",
        "[init]\ngyro_bias_deg_h = [0.01, -0.02, 0.01]\ngyro_bias_std_deg_h = [0.05, 0.05, 0.05]\n"
        "acc_bias_mg = [0.1, 0.0, -0.1]\nacc_bias_std_mg = [0.2, 0.2, 0.2]\n",
    )
    config.write_text(text, encoding="utf-8")
    out = tmp_path / "nav.csv"
    argv = ["ins", "run", "--imu", str(tmp_path / "imu.csv"), "--gnss", str(tmp_path / "gnss.csv")]
    code, stdout, stderr = run_cli([*argv, "--config", str(config), "--out", str(out), "--json"])
    assert code == 0, stderr
    doc = json.loads(stdout)
    assert doc["turn_on_biases"] == "calibrated"
    assert doc["gnss_rejected"] == 0


def test_gyro_rates_in_degrees_on_a_calm_drive_are_refused(
    run_cli: RunCli, tmp_path: Path, assert_one_line_error: OneLineError
) -> None:
    """deg/s rates the median test cannot see (a calm drive): the χ² gate rejects most
    GNSS epochs, which is an error naming the likely causes, and nothing is written."""
    sim = simulate_drive(DriveSimConfig(duration_s=120.0, imu="navigation"))
    write_drive_simulation(sim, tmp_path)
    imu_csv = tmp_path / "imu.csv"
    lines = imu_csv.read_text(encoding="utf-8").splitlines()
    rows = [lines[0]]
    for line in lines[1:]:
        cells = line.split(",")
        cells[1:4] = [repr(math.degrees(float(c))) for c in cells[1:4]]
        rows.append(",".join(cells))
    del rows[3000:3002]  # two samples lost after the static start: an input warning
    imu_csv.write_text("\n".join(rows) + "\n", encoding="utf-8")
    out = tmp_path / "nav.csv"
    argv = ["ins", "run", "--imu", str(imu_csv), "--gnss", str(tmp_path / "gnss.csv")]
    argv += ["--config", str(tmp_path / "ins.toml"), "--out", str(out)]
    code, stdout, stderr = run_cli(argv)
    assert_one_line_error(
        code, stdout, stderr, "chi-square gate rejected", "deg/s", "no solution written"
    )
    # The one error line carries the input checks' warning, which may name the cause.
    assert "The input checks had warned:" in stderr
    assert "missing samples?" in stderr
    assert not out.exists()


def test_compare_near_90_deg_pitch_warns_and_gives_the_misorientation(
    run_cli: RunCli, tmp_path: Path
) -> None:
    from scipy.spatial.transform import Rotation  # noqa: PLC0415

    from kinsync.trajectory import Trajectory  # noqa: PLC0415

    t = 1.3e9 + np.arange(0.0, 10.0, 0.1)
    pitch = np.full(t.size, math.radians(89.99))
    zero = np.zeros(t.size)
    llh = np.tile([46.8, -71.2, 10.0], (t.size, 1))
    truth = tmp_path / "truth.csv"
    write_trajectory_csv(Trajectory.from_euler(t, zero, pitch, zero, lat_lon_h=llh), truth)
    turned = Rotation.from_rotvec([math.radians(0.005), 0.0, 0.0]) * Rotation.from_euler(
        "ZYX", np.column_stack([zero, pitch, zero])
    )
    rpy = turned.as_euler("ZYX")[:, ::-1]
    solution = tmp_path / "sol.csv"
    write_trajectory_csv(
        Trajectory.from_euler(t, rpy[:, 0], rpy[:, 1], rpy[:, 2], lat_lon_h=llh), solution
    )
    code, stdout, stderr = run_cli(["ins", "compare", str(solution), str(truth)])
    assert code == 0, stderr
    assert "the reference pitches to 89.99 deg" in stderr
    assert "misorientation RMS (deg, N/E/D)" in stdout
    code, stdout, _ = run_cli(["ins", "compare", str(solution), str(truth), "--json"])
    doc = json.loads(stdout)
    assert doc["rms_misorientation_ned_deg"][0] == pytest.approx(0.005, abs=1e-6)


def test_each_gnss_epoch_rejected_by_the_gate_is_named_by_its_time(
    run_cli: RunCli, navego: dict[str, Path], tmp_path: Path
) -> None:
    """A count alone left the user to find which fixes the χ² gate threw away."""
    lines = navego["gnss"].read_text().splitlines(keepends=True)
    row = 200  # t_s 40.0 (5 Hz): a fix 300 m too high (σ 10 m)
    fields = lines[row + 1].split(",")
    fields[3] = f"{float(fields[3]) + 300.0:.4f}"
    lines[row + 1] = ",".join(fields)
    gnss = tmp_path / "gnss_spike.csv"
    gnss.write_text("".join(lines))
    paths = navego | {"gnss": gnss}
    code, stdout, stderr = run_cli(_run_args(paths, tmp_path / "nav.csv", "--json"))
    assert code == 0, stderr
    doc = json.loads(stdout)
    assert float(fields[0]) in doc["gnss_rejected_t_s"]
    assert len(doc["gnss_rejected_t_s"]) == doc["gnss_rejected"]
    code, stdout, stderr = run_cli(_run_args(paths, tmp_path / "nav2.csv"))
    assert code == 0, stderr
    shown = rf"rejected.*\b{doc['gnss_rejected']} \(t_s [0-9., ]*{float(fields[0]):.3f}"
    assert re.search(shown, stdout), stdout
