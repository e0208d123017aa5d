"""IMU CSV: rate and increment forms, round trips, the NaveGo file, bad input."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from kinsync.errors import InputError
from kinsync.ins.measurements import ImuData
from kinsync.io.imu_csv import IMU_INCREMENT_COLUMNS, IMU_RATE_COLUMNS, read_imu_csv, write_imu_csv

NAVEGO = Path(__file__).resolve().parents[3] / "shared" / "data" / "navego-synthetic"
RATE_HEADER = ",".join(IMU_RATE_COLUMNS)
INC_HEADER = ",".join(IMU_INCREMENT_COLUMNS)


def _imu(n: int = 200, seed: int = 0) -> ImuData:
    rng = np.random.default_rng(seed)
    t = 1000.0 + np.cumsum(rng.uniform(0.004, 0.006, n))
    gyro = rng.normal(0.0, 0.2, (n, 3))
    acc = rng.normal(0.0, 1.0, (n, 3)) + np.array([0.0, 0.0, -9.8])
    return ImuData(t_s=t, gyro_body_rad_s=gyro, acc_body_m_s2=acc)


def _assert_same(a: ImuData, b: ImuData, rtol: float = 0.0) -> None:
    np.testing.assert_array_equal(a.t_s, b.t_s)
    np.testing.assert_allclose(a.gyro_body_rad_s, b.gyro_body_rad_s, rtol=rtol, atol=0)
    np.testing.assert_allclose(a.acc_body_m_s2, b.acc_body_m_s2, rtol=rtol, atol=0)


finite = st.floats(-1e3, 1e3, allow_nan=False, width=64)


@settings(max_examples=40, deadline=None)
@given(
    st.lists(st.floats(1e-4, 10.0), min_size=1, max_size=15),
    st.data(),
)
def test_rate_round_trip_is_exact(
    tmp_path_factory: pytest.TempPathFactory, steps: list[float], data: st.DataObject
) -> None:
    t = np.cumsum([0.0, *steps]) + 12.5
    n = t.size
    vals = np.array(data.draw(st.lists(finite, min_size=6 * n, max_size=6 * n))).reshape(n, 6)
    imu = ImuData(t_s=t, gyro_body_rad_s=vals[:, :3], acc_body_m_s2=vals[:, 3:])
    path = tmp_path_factory.mktemp("imu") / "imu.csv"
    write_imu_csv(imu, path)
    _assert_same(imu, read_imu_csv(path))


def test_increment_round_trip(tmp_path: Path) -> None:
    imu = _imu()
    write_imu_csv(imu, tmp_path / "inc.csv", form="increments")
    assert (tmp_path / "inc.csv").read_text().splitlines()[0] == INC_HEADER
    _assert_same(imu, read_imu_csv(tmp_path / "inc.csv"), rtol=1e-13)


def test_increments_are_mean_rates_and_first_row_uses_median_interval(tmp_path: Path) -> None:
    # Irregular times: intervals 0.01, 0.01, 0.02, 0.01 -> median 0.01 for the first row.
    t = [5.0, 5.01, 5.02, 5.04, 5.05]
    dt = [0.01, 0.01, 0.01, 0.02, 0.01]
    rate = np.array([0.1, -0.2, 0.3])
    acc = np.array([0.5, 0.0, -9.81])
    lines = [INC_HEADER]
    for tk, dk in zip(t, dt, strict=True):
        cells = [tk, *(rate * dk), *(acc * dk)]
        lines.append(",".join(repr(float(c)) for c in cells))
    path = tmp_path / "inc.csv"
    path.write_text("\n".join(lines) + "\n")
    imu = read_imu_csv(path)
    np.testing.assert_allclose(imu.gyro_body_rad_s, np.tile(rate, (5, 1)), rtol=1e-12)
    np.testing.assert_allclose(imu.acc_body_m_s2, np.tile(acc, (5, 1)), rtol=1e-12)


def test_extra_columns_and_column_order_are_free(tmp_path: Path) -> None:
    path = tmp_path / "imu.csv"
    path.write_text(
        "temp_c,acc_z_m_s2,t_s,gyro_x_rad_s,gyro_y_rad_s,gyro_z_rad_s,acc_x_m_s2,acc_y_m_s2\n"
        "20,-9.8,0.0,0.1,0.2,0.3,0.4,0.5\n"
        "21,-9.7,0.01,0.1,0.2,0.3,0.4,0.5\n"
    )
    imu = read_imu_csv(path)
    np.testing.assert_array_equal(imu.acc_body_m_s2[:, 2], [-9.8, -9.7])
    np.testing.assert_array_equal(imu.gyro_body_rad_s[0], [0.1, 0.2, 0.3])


def test_reads_the_navego_file() -> None:
    imu = read_imu_csv(NAVEGO / "imu.csv")
    assert len(imu) == 87_450
    assert imu.t_s[0] == 0.0
    assert imu.t_s[1] == 0.005
    np.testing.assert_array_equal(
        imu.gyro_body_rad_s[0], [4.5386230879e-03, 5.3309053099e-03, 3.5979393677e-03]
    )
    np.testing.assert_array_equal(
        imu.acc_body_m_s2[0], [1.7104579610e-01, 1.6820052614e-01, -9.6121450173e00]
    )


def test_write_rejects_unknown_form(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="form"):
        write_imu_csv(_imu(), tmp_path / "x.csv", form="deltas")  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("text", "fragments"),
    [
        ("", ["empty file"]),
        ("time,gx\n1,2\n", ["missing column", "t_s"]),
        ("t_s,x\n0,1\n1,2\n", ["no IMU columns"]),
        (f"{RATE_HEADER},dtheta_x_rad\n0,1,1,1,1,1,1,1\n", ["mixes rate columns"]),
        ("t_s,gyro_x_rad_s,gyro_y_rad_s,acc_x_m_s2\n0,1,1,1\n", ["missing column", "gyro_z_rad_s"]),
        ("t_s,dtheta_x_rad\n0,1\n", ["missing column", "increments", "dv_x_m_s"]),
        (f"{RATE_HEADER}\n0,0,0,0,0,0,-9.8\n", ["at least 2 records", "found 1"]),
        (f"{RATE_HEADER}\n0,0,0,0,0,0,-9.8\n0,0,0,0,0,0,-9.8\n", ["duplicate", "row 1 (line 3)"]),
        (
            f"{RATE_HEADER}\n1,0,0,0,0,0,-9.8\n2,0,0,0,0,0,-9.8\n1.5,0,0,0,0,0,-9.8\n",
            ["decreasing", "row 2 (line 4)", "sort"],
        ),
        (f"{INC_HEADER}\n0,0,0,0,0,0,-0.1\n0,0,0,0,0,0,-0.1\n", ["duplicate", "line 3"]),
        (f"{RATE_HEADER}\n0,0,0,0,0,0,-9.8\n1,nan,0,0,0,0,-9.8\n", ["gyro_x", "line 3"]),
        (
            f"{RATE_HEADER}\n0,0,0,0,0,0,-9.8\nnan,0,0,0,0,0,-9.8\n",
            ["'t_s'", "not a finite", "line 3"],
        ),
        (f"{RATE_HEADER}\n0,0,0,0,0,0,-9.8\n1,0,0,0,0,0,g\n", ["line 3", "acc_z_m_s2"]),
        (f"{RATE_HEADER}\n0,0,0,0,0,0,-9.8\n1,0,0,0\n", ["line 3 has 4 fields"]),
    ],
)
def test_bad_files(tmp_path: Path, text: str, fragments: list[str]) -> None:
    path = tmp_path / "bad_imu.csv"
    path.write_text(text)
    with pytest.raises(InputError) as exc:
        read_imu_csv(path)
    message = str(exc.value)
    assert str(path) in message
    for frag in fragments:
        assert frag in message, message


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="not found"):
        read_imu_csv(tmp_path / "none.csv")
