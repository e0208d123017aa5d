"""Control-point CSV: round trips (geodetic and ECEF) and every bad file a user can give."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from kinsync.errors import InputError, KinsyncWarning
from kinsync.frames import geodetic_to_ecef
from kinsync.io.control_points import read_control_points, write_control_points
from kinsync.validation.control_points import ControlPoints

names_st = st.lists(
    st.text(
        alphabet=st.characters(blacklist_categories=("Cs", "Cc", "Zs", "Zl", "Zp")),
        min_size=1,
        max_size=12,
    ),
    min_size=1,
    max_size=8,
    unique=True,
)
lat_st = st.floats(-89.9, 89.9)
lon_st = st.floats(-180.0, 180.0)
h_st = st.floats(-500.0, 9000.0)

GROUND_ECEF_M = (1_409_555.2, -4_140_559.2, 4_626_601.8)  # near Quebec City, 11 m up


@settings(max_examples=40, deadline=None)
@given(names=names_st, data=st.data())
def test_geodetic_round_trip(
    tmp_path_factory: pytest.TempPathFactory, names: list[str], data: st.DataObject
) -> None:
    n = len(names)
    lat = np.array(data.draw(st.lists(lat_st, min_size=n, max_size=n)))
    lon = np.array(data.draw(st.lists(lon_st, min_size=n, max_size=n)))
    h = np.array(data.draw(st.lists(h_st, min_size=n, max_size=n)))
    points = ControlPoints.from_geodetic(names, lat, lon, h)
    path = tmp_path_factory.mktemp("cp") / "control.csv"
    write_control_points(points, path)
    back = read_control_points(path)
    assert back.names == tuple(names)
    # Geodetic -> ECEF -> text -> ECEF: pyproj's iterative inverse, well below 1 um.
    np.testing.assert_allclose(back.pos_ecef_m, points.pos_ecef_m, rtol=0, atol=1e-6)
    np.testing.assert_allclose(back.pos_ecef_m, geodetic_to_ecef(lat, lon, h), rtol=0, atol=1e-6)


@settings(max_examples=40, deadline=None)
@given(
    names=names_st,
    coords=st.lists(
        st.tuples(*[st.floats(-1.0, 1.0)] * 3).filter(lambda v: np.linalg.norm(v) > 0.1),
        min_size=8,
        max_size=8,
    ),
    height_m=st.floats(-11_000.0, 9_000.0),
)
def test_ecef_round_trip_is_exact(
    tmp_path_factory: pytest.TempPathFactory,
    names: list[str],
    coords: list[tuple[float, float, float]],
    height_m: float,
) -> None:
    """Any ECEF point near the ground (the container refuses others)."""
    v = np.array(coords[: len(names)])
    u = v / np.linalg.norm(v, axis=1, keepdims=True)
    a, b = 6_378_137.0, 6_356_752.314245  # WGS84 radii: the ellipsoid along u, then up
    surface = a * b / np.sqrt(b**2 * (1.0 - u[:, 2] ** 2) + a**2 * u[:, 2] ** 2)
    pos = u * (surface + height_m)[:, None]
    points = ControlPoints(tuple(names), pos)
    path = tmp_path_factory.mktemp("cp") / "control.csv"
    write_control_points(points, path, form="ecef")
    back = read_control_points(path)
    assert back.names == tuple(names)
    np.testing.assert_array_equal(back.pos_ecef_m, pos)


def test_extra_columns_blank_lines_and_bom_are_fine(tmp_path: Path) -> None:
    path = tmp_path / "c.csv"
    path.write_text(
        "\ufeffname, x_m ,y_m,z_m,comment\n A ,6378137.5,2.5,3.5,on the wall\n\n"
        "B,4,5,6356752.25,\n",
        encoding="utf-8",
    )
    cp = read_control_points(path)
    assert cp.names == ("A", "B")
    np.testing.assert_array_equal(cp.pos_ecef_m, [[6378137.5, 2.5, 3.5], [4.0, 5.0, 6356752.25]])
    assert cp.source == str(path)
    np.testing.assert_allclose(
        ControlPoints.from_geodetic(["P"], [46.8], [-71.2], [10.0]).lat_lon_h(),
        [[46.8, -71.2, 10.0]],
        atol=1e-9,
    )


@pytest.mark.parametrize(
    ("text", "fragments"),
    [
        ("", ["empty file"]),
        ("name,lat_deg,lon_deg,h_m\n", ["no control points"]),
        ("id,lat_deg,lon_deg,h_m\nA,1,2,3\n", ["missing column 'name'"]),
        ("name,lat_deg,lon_deg\nA,1,2\n", ["missing coordinate columns", "name,x_m,y_m,z_m"]),
        ("name,lat_deg,lon_deg,h_m,x_m,y_m,z_m\nA,1,2,3,4,5,6\n", ["both geodetic"]),
        ("name,x_m,x_m,y_m,z_m\nA,1,1,2,3\n", ["duplicated column"]),
        ("name,x_m,y_m,z_m\nA,1,2\n", ["line 2 has 3 fields"]),
        ("name,x_m,y_m,z_m\n ,1,2,3\n", ["line 2: empty name"]),
        ("name,x_m,y_m,z_m\nA,1,2,3\nA,4,5,6\n", ["line 3", "'A' already used on line 2"]),
        ("name,x_m,y_m,z_m\nA,1,two,3\n", ["line 2, column 'y_m'", "'two'"]),
        ("name,x_m,y_m,z_m\nA,1,nan,3\n", ["line 2, column 'y_m'", "not a finite number"]),
        ("name,x_m,y_m,z_m\nA,1,,3\n", ["line 2, column 'y_m'"]),
        ("name,lat_deg,lon_deg,h_m\nA,95,2,3\n", ["line 2, column 'lat_deg': 95.0 is outside"]),
        # field software: comment lines, a spreadsheet set to a decimal comma
        (
            "name,lat_deg,lon_deg,h_m\n# surveyed 2026-11-02\nA,46.8,-71.2,10\n",
            ["line 2 has 1 fields", "looks like a comment", "remove the line"],
        ),
        (
            "# GNSS rover, NAD83(CSRS)\nname,lat_deg,lon_deg,h_m\nA,46.8,-71.2,10\n",
            ["missing column 'name'", "looks like a comment"],
        ),
        (
            "name;lat_deg;lon_deg;h_m\nA;46,8;-71,2;10,0\n",
            ["line 1", "semicolon-separated", "use commas", "point as the decimal mark"],
        ),
        ("name\tlat_deg\tlon_deg\th_m\nA\t46.8\t-71.2\t10\n", ["tab-separated"]),
        (
            "name,lat_deg,lon_deg,h_m\n12,46,8,-71,2,10,0\n",
            ["line 2 has 7 fields", "decimal comma?"],
        ),
    ],
)
def test_bad_files(tmp_path: Path, text: str, fragments: list[str]) -> None:
    path = tmp_path / "bad.csv"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(InputError) as exc:
        read_control_points(path)
    assert str(path) in str(exc.value)
    for frag in fragments:
        assert frag in str(exc.value)


def test_missing_and_unreadable_files(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="not found"):
        read_control_points(tmp_path / "none.csv")
    binary = tmp_path / "bin.csv"
    binary.write_bytes(b"\xff\xfe\x00\x81garbage")
    with pytest.raises(InputError, match=r"not a text file.*UTF-16"):
        read_control_points(binary)


def test_container_checks() -> None:
    # One name as a str was split into its characters: "P1" made points 'P' and '1'.
    with pytest.raises(InputError, match=r"names: expected a sequence of names, got the single"):
        ControlPoints("AB", np.tile(GROUND_ECEF_M, (2, 1)))  # type: ignore[arg-type]
    with pytest.raises(InputError, match=r"names: expected a sequence of names, got the single"):
        ControlPoints.from_geodetic("P1", [46.8, 46.8], [-71.2, -71.2], [10.0, 10.0])  # type: ignore[arg-type]
    with pytest.raises(InputError, match="shape"):
        ControlPoints(("A", "B"), np.tile(GROUND_ECEF_M, (3, 1)))
    with pytest.raises(InputError, match="non-finite"):
        ControlPoints(("A",), np.array([[0.0, np.inf, 0.0]]))
    with pytest.raises(InputError, match="duplicated"):
        ControlPoints(("A", "A"), np.tile(GROUND_ECEF_M, (2, 1)))
    with pytest.raises(InputError, match="empty name"):
        ControlPoints(("A", " "), np.tile(GROUND_ECEF_M, (2, 1)))
    with pytest.raises(InputError, match="no control points"):
        ControlPoints((), np.zeros((0, 3)))
    with pytest.raises(InputError, match="numbers"):
        ControlPoints(("A",), np.array([["x", 0, 0]]))
    with pytest.raises(InputError, match="not ECEF"):
        ControlPoints(("A",), np.array([[1.0, 2.0, 3.0]]))
    cp = ControlPoints(("A",), np.array([[6378137.0, 2.0, 3.0]]))
    assert len(cp) == 1
    assert not cp.pos_ecef_m.flags.writeable


def test_write_rejects_unknown_form_and_missing_folder(tmp_path: Path) -> None:
    cp = ControlPoints(("A",), np.array([[6378137.0, 0.0, 0.0]]))
    with pytest.raises(InputError, match="form"):
        write_control_points(cp, tmp_path / "c.csv", form="utm")  # type: ignore[arg-type]
    with pytest.raises(InputError, match="does not exist"):
        write_control_points(cp, tmp_path / "nowhere" / "c.csv")
    assert not (tmp_path / "c.csv").exists()


@pytest.mark.parametrize("end", ["", "\n", "\r\n"])
def test_a_file_without_a_final_line_end_is_read_with_a_warning(tmp_path: Path, end: str) -> None:
    """A file cut mid-number (11.1 for 11.199) is still read, but its last row is named."""
    path = tmp_path / "cut.csv"
    text = "name,lat_deg,lon_deg,h_m\nA,46.8,-71.2,11.0\n\nB,46.81,-71.2,11.1"
    path.write_text(text + end, encoding="utf-8")
    if end:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            points = read_control_points(path)
    else:
        with pytest.warns(KinsyncWarning, match=r"ends without a line end: .* check line 4"):
            points = read_control_points(path)
    assert points.names == ("A", "B")


@pytest.mark.parametrize(
    ("text", "fragments"),
    [
        (
            "name,lat_deg,lon_deg,h_m\nA,46.8,-71.2,11.0\nB,46.8,-71.2,11199.6\n",
            ["line 3, column 'h_m'", "11199.6 m is not near the ground", "mm"],
        ),
        (
            "name,x_m,y_m,z_m\nA,1409.555,-4140.558,4626.602\n",
            ["line 2:", "6352 km below", "not ECEF coordinates"],
        ),
    ],
)
def test_a_point_off_the_ground_is_named_by_its_line(
    tmp_path: Path, text: str, fragments: list[str]
) -> None:
    path = tmp_path / "cp.csv"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(InputError) as err:
        read_control_points(path)
    for fragment in fragments:
        assert fragment in str(err.value)
    assert "0-based" not in str(err.value)


def test_float32_geodetic_control_points_are_refused_as_float32_ecef_is() -> None:
    """from_geodetic converted float32 latitudes, 0.27 m off, where ControlPoints refused
    float32 ECEF."""
    lat, lon, h = np.array([46.8, 46.81]), np.array([-71.2, -71.21]), np.array([10.0, 12.0])
    f32 = np.float32
    with pytest.raises(InputError, match=r"<control points>: lat_deg: float32 degrees .*float64"):
        ControlPoints.from_geodetic(["A", "B"], lat.astype(f32), lon, h)
    with pytest.raises(InputError, match=r"pts\.csv: lon_deg: float32 degrees near 71\.21 deg"):
        ControlPoints.from_geodetic(["A", "B"], lat, lon.astype(f32), h, source="pts.csv")
    with pytest.raises(InputError, match=r"h_m: float16 coordinates near 12 m"):
        ControlPoints.from_geodetic(["A", "B"], lat, lon, h.astype(np.float16))
    ok = ControlPoints.from_geodetic(["A", "B"], lat, lon, h.astype(f32))  # 1 um steps
    assert ok.pos_ecef_m == pytest.approx(geodetic_to_ecef(lat, lon, h))


def test_from_geodetic_refuses_coordinates_that_do_not_match_the_names() -> None:
    # One latitude for two names was broadcast to both points without a word.
    with pytest.raises(InputError, match=r"one value per point.*names \(2,\), lat_deg \(1,\)"):
        ControlPoints.from_geodetic(["a", "b"], [46.8], [-71.2, -71.0], [10.0, 10.0])
    one = ControlPoints.from_geodetic(["a"], 46.8, -71.2, 10.0)  # one point, as scalars
    np.testing.assert_allclose(one.lat_lon_h(), [[46.8, -71.2, 10.0]], atol=1e-9)
