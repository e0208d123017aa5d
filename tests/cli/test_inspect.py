"""``kinsync trajectory info`` on SBET files, with the accuracy of their smrmsg companion."""

from __future__ import annotations

import json
import math
import re
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from kinsync.io.gps_week import UNIX_MINUS_GPS_S, gps_time_now_s
from kinsync.io.sbet import SECONDS_PER_WEEK, write_sbet
from kinsync.io.smrmsg import SmrmsgData, write_smrmsg
from kinsync.io.trajectory_csv import write_trajectory_csv
from kinsync.trajectory import Trajectory

RunCli = Callable[[list[str]], tuple[int, str, str]]  # fixture run_cli in conftest.py
OneLineError = Callable[..., None]  # fixture assert_one_line_error in conftest.py

WEEK = 2301
T0 = WEEK * SECONDS_PER_WEEK + 345600.0


def _trajectory() -> Trajectory:
    t = T0 + np.arange(0.0, 20.0, 0.005)
    s = t - T0
    llh = np.column_stack([46.8 + 1e-5 * s, -71.2 + 2e-5 * s, 10.0 + 0.1 * s])
    return Trajectory.from_euler(
        t, 0.02 * np.sin(s), 0.01 * np.cos(s), 0.3 + 0.05 * s, lat_lon_h=llh
    )


def _accuracy(t0: float = T0) -> SmrmsgData:
    rng = np.random.default_rng(4)
    n = 21
    return SmrmsgData(
        t_s=t0 + np.arange(n, dtype=np.float64),
        std_pos_ned_m=rng.uniform(0.01, 0.05, (n, 3)),
        std_vel_ned_m_s=rng.uniform(0.001, 0.01, (n, 3)),
        std_rpy_rad=np.radians(rng.uniform(0.002, 0.05, (n, 3))),
    )


@pytest.fixture
def sbet(tmp_path: Path) -> Path:
    path = tmp_path / "sbet_run7.out"
    write_sbet(_trajectory(), path, wander_angle_rad=math.radians(20.0))
    return path


def test_sbet_info_reports_the_companion_accuracy(sbet: Path, run_cli: RunCli) -> None:
    acc = _accuracy()
    write_smrmsg(acc, sbet.with_name("smrmsg_run7.out"))
    code, out, err = run_cli(["trajectory", "info", str(sbet), "--gps-week", str(WEEK), "--json"])
    assert code == 0, err
    doc = json.loads(out)
    assert doc["format"] == "sbet"
    assert doc["records"] == 4000
    assert doc["t_start_s"] == T0
    # Times near 1.4e9 s hold 0.24 us steps: rounded to 1 us, 200 Hz reads as 200 Hz
    # (it read 199.9954225) and the intervals as 5 ms.
    assert doc["median_rate_hz"] == 200.0
    assert doc["longest_interval_s"] == 0.005
    assert doc["duration_s"] == round(3999 / 200.0, 6)
    sm = doc["smrmsg"]
    assert sm["path"] == str(sbet.with_name("smrmsg_run7.out"))
    assert sm["records"] == 21
    assert (sm["t_start_s"], sm["t_end_s"]) == (T0, T0 + 20.0)
    assert sm["overlaps_trajectory"] is True
    # the statistics of the records within the trajectory (it ends 5 ms before the last)
    assert sm["records_within_trajectory"] == 20
    w = slice(0, 20)
    np.testing.assert_allclose(sm["std_pos_ned_m"]["median"], np.median(acc.std_pos_ned_m[w], 0))
    np.testing.assert_allclose(sm["std_pos_ned_m"]["max"], acc.std_pos_ned_m[w].max(0))
    np.testing.assert_allclose(sm["std_vel_ned_m_s"]["max"], acc.std_vel_ned_m_s[w].max(0))
    np.testing.assert_allclose(
        sm["std_rpy_deg"]["median"], np.degrees(np.median(acc.std_rpy_rad[w], 0)), rtol=1e-12
    )
    code, out, err = run_cli(["trajectory", "info", str(sbet)])  # seconds of week, a table
    assert code == 0, err
    assert out.count("sigma") == 6  # position, velocity, attitude: median and max rows


def test_explicit_smrmsg_and_none_found(sbet: Path, run_cli: RunCli, tmp_path: Path) -> None:
    code, out, err = run_cli(["trajectory", "info", str(sbet), "--json"])
    assert code == 0, err
    assert json.loads(out)["smrmsg"] is None
    code, out, err = run_cli(["trajectory", "info", str(sbet)])
    assert code == 0, err
    assert "none found" in out
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    write_smrmsg(_accuracy(t0=T0 + 1000.0), elsewhere / "acc.out")  # another span
    args = ["trajectory", "info", str(sbet), "--smrmsg", str(elsewhere / "acc.out")]
    code, out, err = run_cli([*args, "--gps-week", str(WEEK), "--json"])
    assert code == 0, err
    assert json.loads(out)["smrmsg"]["overlaps_trajectory"] is False


def test_csv_info_has_no_smrmsg(tmp_path: Path, run_cli: RunCli) -> None:
    path = tmp_path / "traj.csv"
    write_trajectory_csv(_trajectory(), path)
    code, out, err = run_cli(["trajectory", "info", str(path), "--json"])
    assert code == 0, err
    doc = json.loads(out)
    assert doc["format"] == "csv"
    assert "smrmsg" not in doc


@pytest.mark.parametrize(
    ("case", "fragments"),
    [
        ("smrmsg_as_trajectory", ["looks like an smrmsg accuracy file"]),
        ("truncated_smrmsg", ["smrmsg_run7.out", "1 whole records and 3 bytes left over"]),
        ("smrmsg_with_csv", ["--smrmsg", "trajectory CSV"]),
        ("unknown_suffix", ["traj.txt", "not a recognised trajectory export", "SBET"]),
    ],
)
def test_bad_input_is_one_line_error(
    sbet: Path,
    run_cli: RunCli,
    assert_one_line_error: OneLineError,
    case: str,
    fragments: list[str],
) -> None:
    acc = sbet.with_name("smrmsg_run7.out")
    write_smrmsg(_accuracy(), acc)
    args = ["trajectory", "info", str(sbet)]
    if case == "smrmsg_as_trajectory":
        args = ["trajectory", "info", str(acc)]
    elif case == "truncated_smrmsg":
        acc.write_bytes(acc.read_bytes()[:83])
    elif case == "smrmsg_with_csv":
        csv = sbet.with_name("traj.csv")
        write_trajectory_csv(_trajectory(), csv)
        args = ["trajectory", "info", str(csv), "--smrmsg", str(acc)]
    else:
        sbet.with_name("traj.txt").write_text("a text file\nthat is no trajectory\n")
        args = ["trajectory", "info", str(sbet.with_name("traj.txt"))]
    code, out, err = run_cli(args)
    assert_one_line_error(code, out, err, *fragments)


def _rows(out: str) -> dict[str, str]:
    """The table's rows: quantity -> value (one line each)."""
    rows = {}
    for line in out.splitlines():
        cells = [c.strip() for c in line.strip("│ ").split("│")]
        if len(cells) == 2:
            rows[cells[0]] = cells[1]
    return rows


@pytest.mark.parametrize("as_json", [True, False])
def test_the_default_gap_threshold_is_rounded_to_the_microsecond(
    sbet: Path, run_cli: RunCli, as_json: bool
) -> None:
    """10 intervals of 5 ms near 1.4e9 s printed 0.05000114441 (0.05000114440917969 s)."""
    args = ["trajectory", "info", str(sbet), "--gps-week", str(WEEK)]
    code, out, err = run_cli([*args, "--json"] if as_json else args)
    assert code == 0, err
    if as_json:
        assert json.loads(out)["gap_threshold_s"] == 0.05
    else:
        assert _rows(out)["gap_threshold_s"] == "0.05"


def test_a_given_gap_threshold_is_shown_as_given(sbet: Path, run_cli: RunCli) -> None:
    args = ["trajectory", "info", str(sbet), "--gps-week", str(WEEK), "--json"]
    code, out, err = run_cli([*args, "--max-gap-s", "0.0123456789"])
    assert code == 0, err
    assert json.loads(out)["gap_threshold_s"] == 0.0123456789


def test_table_prints_times_to_the_millisecond(sbet: Path, run_cli: RunCli) -> None:
    """Review G: 1418472301.61 printed as 1418472302 (10 significant digits)."""
    code, out, err = run_cli(["trajectory", "info", str(sbet), "--gps-week", str(WEEK)])
    assert code == 0, err
    rows = _rows(out)
    assert rows["t_start_s"] == f"{T0:.3f}"
    assert rows["t_end_s"] == f"{T0 + 19.995:.3f}"


def test_an_smrmsg_outside_the_trajectory_is_a_warning_without_statistics(
    sbet: Path, run_cli: RunCli, tmp_path: Path
) -> None:
    """Review G: only 'overlaps: False', exit 0, and sigmas shown as if they applied."""
    acc = tmp_path / "acc.out"
    write_smrmsg(_accuracy(t0=T0 + 3600.0), acc)
    args = ["trajectory", "info", str(sbet), "--smrmsg", str(acc), "--gps-week", str(WEEK)]
    code, out, err = run_cli(args)
    assert code == 0, err
    warning = [line for line in err.splitlines() if line.startswith(f"kinsync: warning: {acc}")]
    assert len(warning) == 1, err
    assert f"{acc}: the smrmsg spans {T0 + 3600.0:.3f} .. {T0 + 3620.0:.3f} s" in warning[0]
    assert f"the trajectory {T0:.3f} .. {T0 + 19.995:.3f} s" in warning[0]
    assert "do not overlap" in warning[0]
    assert "sigma position" not in out
    assert "not shown" in _rows(out)["sigma statistics"]
    code, out, err = run_cli([*args, "--json"])
    assert code == 0, err
    assert any("do not overlap" in w for w in json.loads(out)["warnings"])


def test_smrmsg_statistics_are_those_of_the_records_within_the_trajectory(
    sbet: Path, run_cli: RunCli, tmp_path: Path
) -> None:
    """Review G: an smrmsg reaching 10 s beyond the trajectory showed the sigmas of its
    records outside it (here 100 times larger) as the trajectory's."""
    acc = _accuracy()
    late = _accuracy(t0=T0 + 21.0)
    big = replace(late, std_pos_ned_m=late.std_pos_ned_m * 100.0)
    both = SmrmsgData(
        t_s=np.concatenate([acc.t_s, big.t_s]),
        std_pos_ned_m=np.concatenate([acc.std_pos_ned_m, big.std_pos_ned_m]),
        std_vel_ned_m_s=np.concatenate([acc.std_vel_ned_m_s, big.std_vel_ned_m_s]),
        std_rpy_rad=np.concatenate([acc.std_rpy_rad, big.std_rpy_rad]),
    )
    path = tmp_path / "acc.out"
    write_smrmsg(both, path)
    args = ["trajectory", "info", str(sbet), "--smrmsg", str(path), "--gps-week", str(WEEK)]
    code, out, err = run_cli([*args, "--json"])
    assert code == 0, err
    doc = json.loads(out)["smrmsg"]
    within = acc.t_s <= T0 + 19.995
    assert doc["records"] == 42
    assert doc["records_within_trajectory"] == int(np.count_nonzero(within))
    np.testing.assert_allclose(doc["std_pos_ned_m"]["max"], acc.std_pos_ned_m[within].max(axis=0))
    code, out, err = run_cli(args)
    assert code == 0, err
    assert "within the trajectory" in _rows(out)["smrmsg records"]


def test_reader_warnings_are_listed_with_the_others(tmp_path: Path, run_cli: RunCli) -> None:
    """A static CSV whose angles could be radians: said on stderr and under warnings."""
    path = tmp_path / "still.csv"
    t = 1.4e9 + np.arange(0.0, 30.0, 0.1)
    rows = "".join(f"{ti:.1f},46.8,-71.2,10.0,0.01,-0.02,1.2\n" for ti in t)
    path.write_text("t_s,lat_deg,lon_deg,h_m,roll_deg,pitch_deg,yaw_deg\n" + rows)
    code, out, err = run_cli(["trajectory", "info", str(path), "--json"])
    assert code == 0, err
    (warning,) = json.loads(out)["warnings"]
    assert "could not be checked" in warning
    assert err.count("could not be checked") == 1


def test_info_across_the_antimeridian_gives_the_zones_there(
    tmp_path: Path, run_cli: RunCli
) -> None:
    """Review L3: data in zones 60 and 1 were said to "span zones 1-60"."""
    path = tmp_path / "traj.csv"
    path.write_text(
        "t_s,lat_deg,lon_deg,h_m,roll_deg,pitch_deg,yaw_deg\n"
        "1400000000.0,-16.5,179.99999,10.0,0,0,90\n"
        "1400000001.0,-16.5,-179.99999,10.0,0,0,90\n"
    )
    code, out, err = run_cli(["trajectory", "info", str(path), "--json"])
    assert code == 0, err
    area = json.loads(out)["area"]
    assert area["lon_deg"] == [179.99999, -179.99999]
    assert area["zones_spanned"] == [60, 1]
    assert area["utm_epsg"] in ("EPSG:32760", "EPSG:32701")
    code, out, err = run_cli(["trajectory", "info", str(path)])
    assert code == 0, err
    assert "1-60" not in out
    assert "data span zones 60, 1" in out


def test_ground_speed_is_shown_in_m_s_and_knots_leaving_gaps_out(
    tmp_path: Path, run_cli: RunCli
) -> None:
    """An airborne user checks the ground speed first: 60 m/s (116.6 kn) here, from the
    positions, with the 30 s hole in the records left out (its average would read 0)."""
    t = T0 + np.concatenate([np.arange(0.0, 20.0, 0.01), np.arange(50.0, 70.0, 0.01)])
    s = t - T0
    north_m = np.where(s < 30.0, 60.0 * s, 1200.0 + 40.0 * (s - 50.0))  # 60, then 40 m/s
    lat = 46.8 + np.degrees(north_m / 6_366_000.0)  # about the meridian radius there
    traj = Trajectory.from_euler(
        t, 0 * s, 0 * s, 0 * s,
        lat_lon_h=np.column_stack([lat, np.full_like(s, -71.2), np.full_like(s, 1000.0)]),
    )  # fmt: skip
    path = tmp_path / "flight.csv"
    write_trajectory_csv(traj, path)
    code, out, err = run_cli(["trajectory", "info", str(path), "--json"])
    assert code == 0, err
    doc = json.loads(out)["ground_speed_m_s"]
    expect = traj.ground_speed_m_s()
    assert expect.min() < 1.0  # across the hole
    assert doc["min"] == pytest.approx(40.0, rel=2e-3)
    assert doc["max"] == pytest.approx(60.0, rel=2e-3)
    assert doc["median"] == pytest.approx(50.0, rel=2e-3)  # as many intervals at each speed
    code, out, err = run_cli(["trajectory", "info", str(path)])
    assert code == 0, err
    rows = _rows(out)
    speeds = {k: re.findall(r"[0-9.]+", v) for k, v in rows.items() if "ground speed" in k}
    assert [float(v) for v in speeds["ground speed (m/s)"]] == pytest.approx([40, 50, 60], abs=0.1)
    kn = [float(v) for v in speeds["ground speed (kn)"]]
    assert kn == pytest.approx([v * 3600 / 1852 for v in (40, 50, 60)], abs=0.15)


def test_trajectory_info_refuses_a_unix_time_trajectory(
    run_cli: RunCli, assert_one_line_error: OneLineError, tmp_path: Path
) -> None:
    """It printed 'GPS time' and a span ten years ahead, exit 0 and no warning."""
    t_gps = math.floor(gps_time_now_s() - 86_400.0)
    n = 5
    llh = np.column_stack([np.full(n, 46.8), np.full(n, -71.2), np.full(n, 10.0)])
    z = np.zeros(n)
    traj = Trajectory.from_euler(t_gps + UNIX_MINUS_GPS_S + np.arange(n), z, z, z, lat_lon_h=llh)
    write_trajectory_csv(traj, tmp_path / "unix.csv")
    code, out, err = run_cli(["trajectory", "info", str(tmp_path / "unix.csv")])
    assert_one_line_error(code, out, err, "unix.csv: line 2", "Unix time", "315964800")
