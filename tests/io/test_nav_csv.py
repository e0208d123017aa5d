"""Navigation solution CSV, truth reader, format dispatch, bad input."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from kinsync.errors import InputError
from kinsync.ins.solution import NavSolution
from kinsync.io.nav_csv import (
    NAV_BIAS_COLUMNS,
    NAV_COLUMNS,
    NAV_SCALE_COLUMNS,
    NAV_STD_COLUMNS,
    read_nav_csv,
    read_navigation,
    read_truth_csv,
    write_nav_csv,
    write_truth_csv,
)
from kinsync.io.sbet import write_sbet
from kinsync.io.trajectory_csv import write_trajectory_csv
from kinsync.trajectory import Trajectory

NAVEGO = Path(__file__).resolve().parents[3] / "shared" / "data" / "navego-synthetic"


def nav_solution(n: int = 40, seed: int = 2) -> NavSolution:
    rng = np.random.default_rng(seed)

    def pos(scale: float) -> np.ndarray:
        return rng.uniform(0.1, 1.0, (n, 3)) * scale

    return NavSolution(
        t_s=100.0 + 0.005 * np.arange(n, dtype=np.float64),
        lat_deg=-32.8 + 1e-5 * np.arange(n, dtype=np.float64),
        lon_deg=-68.8 + 2e-5 * np.arange(n, dtype=np.float64),
        h_m=700.0 + rng.normal(0, 0.1, n),
        vel_ned_m_s=rng.normal(0, 10, (n, 3)),
        rpy_rad=np.column_stack(
            [rng.uniform(-0.3, 0.3, n), rng.uniform(-0.3, 0.3, n), rng.uniform(-3.1, 3.1, n)]
        ),
        std_pos_ned_m=pos(2.0),
        std_vel_ned_m_s=pos(0.1),
        std_att_rad=pos(0.01),
        gyro_bias_rad_s=rng.normal(0, 1e-3, (n, 3)),
        acc_bias_m_s2=rng.normal(0, 1e-2, (n, 3)),
        std_gyro_bias_rad_s=pos(1e-4),
        std_acc_bias_m_s2=pos(1e-3),
        smoothed=False,
    )


def test_header_is_the_documented_layout(tmp_path: Path) -> None:
    write_nav_csv(nav_solution(), tmp_path / "nav.csv")
    header = (tmp_path / "nav.csv").read_text().splitlines()[0].split(",")
    assert header == [*NAV_COLUMNS, *NAV_STD_COLUMNS, *NAV_BIAS_COLUMNS]
    assert len(header) == 31
    assert header[19:22] == ["gyro_bias_x_rad_s", "gyro_bias_y_rad_s", "gyro_bias_z_rad_s"]
    assert header[-1] == "std_acc_bias_z_m_s2"


def test_round_trip(tmp_path: Path) -> None:
    sol = nav_solution()
    write_nav_csv(sol, tmp_path / "nav.csv")
    back = read_nav_csv(tmp_path / "nav.csv")
    for name in ("t_s", "lat_deg", "lon_deg", "h_m", "vel_ned_m_s", "std_pos_ned_m"):
        np.testing.assert_array_equal(getattr(back, name), getattr(sol, name))
    for name in ("gyro_bias_rad_s", "acc_bias_m_s2", "std_gyro_bias_rad_s", "std_acc_bias_m_s2"):
        np.testing.assert_array_equal(getattr(back, name), getattr(sol, name))
    np.testing.assert_array_equal(back.std_vel_ned_m_s, sol.std_vel_ned_m_s)
    # Degrees in the file: exact up to the deg <-> rad rounding.
    np.testing.assert_allclose(back.rpy_rad, sol.rpy_rad, rtol=1e-15, atol=1e-17)
    np.testing.assert_allclose(back.std_att_rad, sol.std_att_rad, rtol=1e-15)
    assert not back.smoothed


def test_scale_factor_columns_round_trip_when_modelled(tmp_path: Path) -> None:
    rng = np.random.default_rng(5)
    sol = nav_solution()
    n = len(sol)
    scaled = dataclasses.replace(
        sol,
        gyro_scale_ppm=rng.normal(0, 300, (n, 3)),
        acc_scale_ppm=rng.normal(0, 300, (n, 3)),
        std_gyro_scale_ppm=rng.uniform(10, 100, (n, 3)),
        std_acc_scale_ppm=rng.uniform(10, 100, (n, 3)),
    )
    write_nav_csv(scaled, tmp_path / "nav.csv")
    header = (tmp_path / "nav.csv").read_text().splitlines()[0].split(",")
    assert header == [*NAV_COLUMNS, *NAV_STD_COLUMNS, *NAV_BIAS_COLUMNS, *NAV_SCALE_COLUMNS]
    back = read_nav_csv(tmp_path / "nav.csv")
    for name in ("gyro_scale_ppm", "acc_scale_ppm", "std_gyro_scale_ppm", "std_acc_scale_ppm"):
        np.testing.assert_array_equal(getattr(back, name), getattr(scaled, name))
    assert read_nav_csv(_without_scale(tmp_path)).gyro_scale_ppm is None
    text = (tmp_path / "nav.csv").read_text().splitlines()
    cut = [",".join(line.split(",")[:-1]) for line in text]  # one scale column missing
    (tmp_path / "cut.csv").write_text("\n".join(cut) + "\n")
    with pytest.raises(InputError, match="all twelve scale factor columns or none"):
        read_nav_csv(tmp_path / "cut.csv")


def _without_scale(tmp_path: Path) -> Path:
    write_nav_csv(nav_solution(), tmp_path / "plain.csv")
    return tmp_path / "plain.csv"


def test_solution_csv_reads_as_trajectory_too(tmp_path: Path) -> None:
    sol = nav_solution()
    write_nav_csv(sol, tmp_path / "nav.csv")
    nav = read_navigation(tmp_path / "nav.csv")
    assert isinstance(nav, NavSolution)
    traj = read_truth_csv(tmp_path / "nav.csv")  # the first ten columns are the truth layout
    expected = sol.to_trajectory()
    assert traj.lat_lon_h is not None
    assert expected.lat_lon_h is not None
    np.testing.assert_allclose(traj.lat_lon_h, expected.lat_lon_h, rtol=0, atol=1e-12)
    dots = np.abs(np.sum(traj.q_body_to_ned * expected.q_body_to_ned, axis=1))
    np.testing.assert_allclose(dots, 1.0, atol=1e-14)
    assert traj.vel_ned_m_s is not None
    np.testing.assert_array_equal(traj.vel_ned_m_s, sol.vel_ned_m_s)


def test_reads_the_navego_truth() -> None:
    truth = read_truth_csv(NAVEGO / "truth.csv")
    assert len(truth) == 87_450
    assert truth.lat_lon_h is not None
    assert truth.vel_ned_m_s is not None
    np.testing.assert_array_equal(truth.lat_lon_h[0], [-32.83077399956, -68.79278200014, 700.0])
    np.testing.assert_allclose(np.degrees(truth.euler_rpy_rad()[0]), [0.0, 0.0, -15.0], atol=1e-12)
    np.testing.assert_array_equal(truth.vel_ned_m_s[0], [0.019319, -0.005176, -0.0])


def test_truth_csv_round_trip_in_the_navego_layout(tmp_path: Path) -> None:
    traj = nav_solution().to_trajectory()
    write_truth_csv(traj, tmp_path / "truth.csv")
    header = (tmp_path / "truth.csv").read_text().splitlines()[0]
    assert header == (NAVEGO / "truth.csv").read_text().splitlines()[0]
    back = read_truth_csv(tmp_path / "truth.csv")
    assert back.lat_lon_h is not None
    assert traj.lat_lon_h is not None
    np.testing.assert_array_equal(back.lat_lon_h, traj.lat_lon_h)
    assert back.vel_ned_m_s is not None
    assert traj.vel_ned_m_s is not None
    np.testing.assert_array_equal(back.vel_ned_m_s, traj.vel_ned_m_s)
    dots = np.abs(np.sum(back.q_body_to_ned * traj.q_body_to_ned, axis=1))
    np.testing.assert_allclose(dots, 1.0, atol=1e-14)


def test_truth_writer_needs_velocities(tmp_path: Path) -> None:
    traj = nav_solution().to_trajectory()
    plain = Trajectory(t_s=traj.t_s, q_body_to_ned=traj.q_body_to_ned, lat_lon_h=traj.lat_lon_h)
    with pytest.raises(InputError, match="velocities"):
        write_truth_csv(plain, tmp_path / "t.csv")
    assert not (tmp_path / "t.csv").exists()


def test_truth_without_velocities_is_rejected(tmp_path: Path) -> None:
    traj = nav_solution().to_trajectory()
    plain = Trajectory(t_s=traj.t_s, q_body_to_ned=traj.q_body_to_ned, lat_lon_h=traj.lat_lon_h)
    write_trajectory_csv(plain, tmp_path / "t.csv")
    with pytest.raises(InputError, match="needs the velocity columns"):
        read_truth_csv(tmp_path / "t.csv")
    nav = read_navigation(tmp_path / "t.csv")  # but it is a trajectory
    assert isinstance(nav, Trajectory)
    assert nav.vel_ned_m_s is None


def test_read_navigation_sbet(tmp_path: Path) -> None:
    traj = nav_solution().to_trajectory()
    write_sbet(traj, tmp_path / "nav.out")
    write_sbet(traj, tmp_path / "nav.sbet")
    for name in ("nav.out", "nav.sbet"):
        back = read_navigation(tmp_path / name)
        assert isinstance(back, Trajectory)
        np.testing.assert_allclose(back.t_s, traj.t_s, rtol=0, atol=1e-9)


def test_read_navigation_rejects_unknown_suffix(tmp_path: Path) -> None:
    with pytest.raises(InputError, match=r"unknown navigation file type '\.txt'"):
        read_navigation(tmp_path / "nav.txt")
    with pytest.raises(InputError, match="not found"):
        read_navigation(tmp_path / "nav.csv")


def _written(tmp_path: Path) -> list[str]:
    write_nav_csv(nav_solution(n=4), tmp_path / "nav.csv")
    return (tmp_path / "nav.csv").read_text().splitlines()


def _set_cell(lines: list[str], line_no: int, column: str, value: str) -> list[str]:
    header = lines[0].split(",")
    cells = lines[line_no - 1].split(",")
    cells[header.index(column)] = value
    out = list(lines)
    out[line_no - 1] = ",".join(cells)
    return out


@pytest.mark.parametrize(
    ("line_no", "column", "value", "fragments"),
    [
        (3, "std_e_m", "-1", ["line 3", "std_e_m"]),
        (4, "std_acc_bias_y_m_s2", "nan", ["line 4", "std_acc_bias_y_m_s2"]),
        (2, "lat_deg", "95", ["line 2", "lat_deg"]),
        (5, "roll_deg", "inf", ["line 5", "roll_deg"]),
        (3, "t_s", "100.0", ["line 3", "repeated"]),
        (4, "t_s", "99", ["line 4", "decreasing"]),
        (4, "h_m", "x", ["line 4", "h_m", "not a number"]),
    ],
)
def test_bad_cells(
    tmp_path: Path, line_no: int, column: str, value: str, fragments: list[str]
) -> None:
    path = tmp_path / "bad.csv"
    path.write_text("\n".join(_set_cell(_written(tmp_path), line_no, column, value)) + "\n")
    with pytest.raises(InputError) as exc:
        read_nav_csv(path)
    for frag in [str(path), *fragments]:
        assert frag in str(exc.value), str(exc.value)


def test_missing_column_and_short_file(tmp_path: Path) -> None:
    lines = _written(tmp_path)
    header = lines[0].split(",")
    drop = header.index("std_yaw_deg")
    cut = [",".join(c for i, c in enumerate(line.split(",")) if i != drop) for line in lines]
    (tmp_path / "a.csv").write_text("\n".join(cut) + "\n")
    with pytest.raises(InputError, match=r"missing column.*std_yaw_deg"):
        read_nav_csv(tmp_path / "a.csv")
    (tmp_path / "b.csv").write_text("\n".join(lines[:2]) + "\n")
    with pytest.raises(InputError, match="at least 2 records, found 1"):
        read_nav_csv(tmp_path / "b.csv")


def test_write_rejects_wrong_shapes(tmp_path: Path) -> None:
    sol = nav_solution(n=5)
    bad = NavSolution(**{**sol.__dict__, "std_att_rad": np.zeros((4, 3))})
    with pytest.raises(InputError, match=r"std_roll_deg.*shape \(5, 3\)"):
        write_nav_csv(bad, tmp_path / "x.csv")
    assert not (tmp_path / "x.csv").exists()


@settings(max_examples=30, deadline=None)
@given(  # any float within the plausible spans of heights and rates (kinsync.io.sanity)
    st.lists(st.floats(min_value=-1e3, max_value=1e3, width=64), min_size=2, max_size=10)
)
def test_any_float_round_trips_exactly(
    tmp_path_factory: pytest.TempPathFactory, values: list[float]
) -> None:
    n = len(values)
    v = np.array(values)
    sol = nav_solution(n=n)
    sol = NavSolution(**{**sol.__dict__, "h_m": v, "gyro_bias_rad_s": np.column_stack([v, -v, v])})
    path = tmp_path_factory.mktemp("nav") / "nav.csv"
    write_nav_csv(sol, path)
    back = read_nav_csv(path)
    np.testing.assert_array_equal(back.h_m, v)
    np.testing.assert_array_equal(back.gyro_bias_rad_s, sol.gyro_bias_rad_s)
