"""GNSS CSV: optional groups, round trips, the NaveGo file, bad input."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from kinsync.errors import InputError
from kinsync.ins.measurements import GnssData
from kinsync.io.gnss_csv import read_gnss_csv, write_gnss_csv

NAVEGO = Path(__file__).resolve().parents[3] / "shared" / "data" / "navego-synthetic"
HEAD = "t_s,lat_deg,lon_deg,h_m"


def _gnss(n: int = 20, *, std: bool = True, vel: bool = True, std_vel: bool = True) -> GnssData:
    rng = np.random.default_rng(4)
    std_pos = rng.uniform(0.01, 3.0, (n, 3)) if std else np.full((n, 3), np.nan)
    if std:
        std_pos[3, 1] = np.nan  # one epoch without a σ: configured default
    return GnssData(
        t_s=1.3e9 + 0.2 * np.arange(n, dtype=np.float64),
        lat_deg=46.8 + rng.normal(0, 1e-4, n),
        lon_deg=-71.2 + rng.normal(0, 1e-4, n),
        h_m=rng.normal(50.0, 2.0, n),
        std_pos_ned_m=std_pos,
        vel_ned_m_s=rng.normal(0, 10, (n, 3)) if vel else None,
        std_vel_ned_m_s=rng.uniform(0.01, 0.2, (n, 3)) if (vel and std_vel) else None,
    )


def _assert_same(a: GnssData, b: GnssData) -> None:
    for name in ("t_s", "lat_deg", "lon_deg", "h_m", "std_pos_ned_m"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    for name in ("vel_ned_m_s", "std_vel_ned_m_s"):
        x, y = getattr(a, name), getattr(b, name)
        assert (x is None) == (y is None), name
        if x is not None:
            np.testing.assert_array_equal(x, y)


@pytest.mark.parametrize(
    ("std", "vel", "std_vel"),
    [(True, True, True), (False, False, False), (True, False, False), (False, True, False)],
)
def test_round_trip_is_exact(tmp_path: Path, std: bool, vel: bool, std_vel: bool) -> None:
    gnss = _gnss(std=std, vel=vel, std_vel=std_vel)
    path = tmp_path / "gnss.csv"
    write_gnss_csv(gnss, path)
    header = path.read_text().splitlines()[0].split(",")
    assert ("std_n_m" in header) == std
    assert ("vn_m_s" in header) == vel
    assert ("std_vn_m_s" in header) == std_vel
    _assert_same(gnss, read_gnss_csv(path))


@settings(max_examples=40, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.floats(1e-3, 100.0),
            st.floats(-90.0, 90.0),
            st.floats(-180.0, 180.0),
            st.floats(-500.0, 9000.0),
            st.one_of(st.just(float("nan")), st.floats(1e-6, 1e3)),
        ),
        min_size=2,
        max_size=12,
    )
)
def test_round_trip_property(
    tmp_path_factory: pytest.TempPathFactory, rows: list[tuple[float, ...]]
) -> None:
    arr = np.array(rows)
    gnss = GnssData(
        t_s=np.cumsum(arr[:, 0]),
        lat_deg=arr[:, 1],
        lon_deg=arr[:, 2],
        h_m=arr[:, 3],
        std_pos_ned_m=np.repeat(arr[:, 4:5], 3, axis=1),
    )
    path = tmp_path_factory.mktemp("gnss") / "g.csv"
    write_gnss_csv(gnss, path)
    _assert_same(gnss, read_gnss_csv(path))


def test_missing_sigma_group_means_defaults(tmp_path: Path) -> None:
    path = tmp_path / "g.csv"
    path.write_text(f"{HEAD},n_sats\n0,1,2,3,9\n1,1,2,3,8\n")
    gnss = read_gnss_csv(path)
    assert np.isnan(gnss.std_pos_ned_m).all()
    assert gnss.vel_ned_m_s is None
    assert gnss.std_vel_ned_m_s is None


def test_reads_the_navego_file() -> None:
    gnss = read_gnss_csv(NAVEGO / "gnss.csv")
    assert len(gnss) == 2187
    assert gnss.t_s[1] == 0.2
    assert gnss.lat_deg[0] == -32.8307853121
    assert gnss.vel_ned_m_s is not None
    np.testing.assert_array_equal(gnss.vel_ned_m_s[0], [-0.00547, 0.03916, 0.02082])
    assert np.isnan(gnss.std_pos_ned_m).all()


@pytest.mark.parametrize(
    ("text", "fragments"),
    [
        ("", ["empty file"]),
        ("t_s,lat_deg,lon_deg\n0,1,2\n", ["missing column", "h_m"]),
        (f"{HEAD}\n0,1,2,3\n", ["at least 2 epochs", "found 1"]),
        (f"{HEAD},std_n_m,std_e_m\n0,1,2,3,1,1\n1,1,2,3,1,1\n", ["std_d_m", "all of"]),
        (f"{HEAD},vn_m_s\n0,1,2,3,1\n1,1,2,3,1\n", ["ve_m_s", "all of"]),
        (
            f"{HEAD},std_vn_m_s,std_ve_m_s,std_vd_m_s\n0,1,2,3,1,1,1\n1,1,2,3,1,1,1\n",
            ["without the velocities"],
        ),
        (
            f"{HEAD},std_n_m,std_e_m,std_d_m\n0,1,2,3,1,1,1\n1,1,2,3,1,0,1\n",
            ["line 3", "std_e_m", "positive"],
        ),
        (
            f"{HEAD},std_n_m,std_e_m,std_d_m\n0,1,2,3,1,1,-2\n1,1,2,3,1,1,1\n",
            ["line 2", "std_d_m"],
        ),
        (
            (
                f"{HEAD},vn_m_s,ve_m_s,vd_m_s,std_vn_m_s,std_ve_m_s,std_vd_m_s\n"
                "0,1,2,3,0,0,0,1,1,1\n1,1,2,3,0,0,0,inf,1,1\n"
            ),
            ["line 3", "std_vn_m_s"],
        ),
        (f"{HEAD}\n0,1,2,3\n1,nan,2,3\n", ["line 3", "lat_deg", "finite"]),
        (f"{HEAD}\n0,1,2,3\n1,91,2,3\n", ["'lat_deg'", "outside -90 to 90", "line 3"]),
        (f"{HEAD}\n0,1,2,3\n0,1,2,3\n", ["duplicate", "row 1 (line 3)"]),
        (f"{HEAD}\n5,1,2,3\n4,1,2,3\n", ["decreasing", "line 3"]),
        (f"{HEAD},vn_m_s,ve_m_s,vd_m_s\n0,1,2,3,0,0,0\n1,1,2,3,0,nan,0\n", ["ve_m_s", "line 3"]),
        (f"{HEAD}\n0,1,2,3\n1,1,x,3\n", ["line 3", "lon_deg"]),
        # an empty σ cell is nan, an empty position cell is not a number
        (f"{HEAD},std_n_m,std_e_m,std_d_m\n0,1,2,3,,1,1\n1,1,,3,1,1,1\n", ["line 3", "lon_deg"]),
        (
            (
                f"{HEAD},vn_m_s,ve_m_s,vd_m_s,std_vn_m_s,std_ve_m_s,std_vd_m_s\n"
                "0,1,2,3,0,0,0,1,,1\n1,1,2,3,0,,0,1,1,1\n"
            ),
            ["line 3", "ve_m_s", "'' is not a number"],
        ),
    ],
)
def test_bad_files(tmp_path: Path, text: str, fragments: list[str]) -> None:
    path = tmp_path / "bad_gnss.csv"
    path.write_text(text)
    with pytest.raises(InputError) as exc:
        read_gnss_csv(path)
    message = str(exc.value)
    assert str(path) in message
    for frag in fragments:
        assert frag in message, message


def test_an_empty_sigma_cell_is_the_configured_default_as_nan_is(tmp_path: Path) -> None:
    """Review L5: an empty σ cell was refused as "'' is not a number", while a literal
    ``nan`` there means the configured default."""
    head = f"{HEAD},vn_m_s,ve_m_s,vd_m_s,std_n_m,std_e_m,std_d_m,std_vn_m_s,std_ve_m_s,std_vd_m_s"
    rows = ["0,1,2,3,0,0,0,0.5,,0.5,0.1,0.1,0.1", '1,1,2,3,0,0,0,0.5,0.5,0.5,0.1,0.1,""']
    path = tmp_path / "gnss.csv"
    path.write_text("\n".join([head, *rows]) + "\n")
    gnss = read_gnss_csv(path)
    assert gnss.std_vel_ned_m_s is not None
    np.testing.assert_array_equal(gnss.std_pos_ned_m, [[0.5, np.nan, 0.5], [0.5, 0.5, 0.5]])
    np.testing.assert_array_equal(gnss.std_vel_ned_m_s, [[0.1, 0.1, 0.1], [0.1, 0.1, np.nan]])
    path.write_text(path.read_text().replace(",,", ",nan,").replace('""', "nan"))
    as_nan = read_gnss_csv(path)
    np.testing.assert_array_equal(as_nan.std_pos_ned_m, gnss.std_pos_ned_m)
    np.testing.assert_array_equal(as_nan.std_vel_ned_m_s, gnss.std_vel_ned_m_s)


def test_a_file_without_header_says_so_and_names_the_columns(tmp_path: Path) -> None:
    """Review L5: rows without a header gave "duplicated column(s) ['0.01', '0.02'] in the
    header"."""
    path = tmp_path / "gnss.csv"
    path.write_text("0,1,2,3,0.01,0.01,0.02\n1,1,2,3,0.01,0.01,0.02\n")
    with pytest.raises(InputError) as info:
        read_gnss_csv(path)
    msg = str(info.value)
    assert msg.startswith(f"{path}: the first line holds numbers (0,1,2,3,...), not column names")
    assert "required: t_s, lat_deg, lon_deg, h_m; optional: std_n_m," in msg
    assert "duplicated" not in msg


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="not found"):
        read_gnss_csv(tmp_path / "none.csv")
