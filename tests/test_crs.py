"""CRS transformations (issue 16 items 1-2): geoid heights, missing grids, epochs, zones."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pyproj
import pytest
from hypothesis import given
from hypothesis import strategies as st

from kinsync.clock.leap_seconds import gps_to_decimal_year, utc_fields_to_gps_s
from kinsync.crs import (
    crs_plan_transformer,
    crs_to_ecef_transformer,
    data_area,
    ecef_to_crs_transformer,
    plan_ecef_to_crs,
    utm_zone_of,
)
from kinsync.errors import InputError
from kinsync.io.gtx import write_gtx

_LLH_TO_ECEF = pyproj.Transformer.from_crs(4979, 4978, always_xy=True)
QUEBEC_LON, QUEBEC_LAT = -71.2, 46.8


def _ecef(lon: np.ndarray, lat: np.ndarray, h: np.ndarray) -> np.ndarray:
    x, y, z = _LLH_TO_ECEF.transform(lon, lat, h)
    return np.column_stack([x, y, z])


def _quebec(n: int = 20) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    s = np.linspace(0.0, 1.0, n)
    return QUEBEC_LON + 0.05 * s, QUEBEC_LAT + 0.03 * s, 10.0 + 40.0 * s


def _geoid(lon: np.ndarray, lat: np.ndarray) -> np.ndarray:
    """A geoid model linear in longitude and latitude: bilinear interpolation is exact."""
    return -30.0 + 0.5 * (lat - 46.5) + 0.2 * (lon + 71.0)


def write_grid(path: Path, lat0: float = 46.0, lon0: float = -72.0, n: int = 41) -> Path:
    """A GTX grid (NOAA VDatum layout: big-endian header, rows south to north)."""
    step = 0.05
    lat = lat0 + step * np.arange(n)[:, None]
    lon = lon0 + step * np.arange(n)[None, :]
    write_gtx(path, lat0, lon0, step, _geoid(lon, lat))
    return path


# ------------------------------------------------------------------------- geoid heights
def test_a_geoid_grid_gives_orthometric_heights_and_the_same_horizontal(tmp_path: Path) -> None:
    lon, lat, h = _quebec()
    pos = _ecef(lon, lat, h)
    grid = write_grid(tmp_path / "geoid.gtx")
    plan, info = plan_ecef_to_crs("EPSG:32619+5703", geoid=str(grid), sample_ecef_m=pos)
    out = crs_plan_transformer(plan)
    assert out is not None
    got = out(pos)
    utm = pyproj.Transformer.from_crs(4979, 32619, always_xy=True)
    e, n = utm.transform(lon, lat)
    np.testing.assert_allclose(got[:, 0], e, rtol=0, atol=1e-6)
    np.testing.assert_allclose(got[:, 1], n, rtol=0, atol=1e-6)
    # float32 grid values: 1e-5 m
    np.testing.assert_allclose(got[:, 2], h - _geoid(lon, lat), rtol=0, atol=2e-5)
    assert info.heights.startswith("orthometric: NAVD88 height")
    assert info.geoid == str(grid.resolve())
    assert "vgridshift" in info.proj_pipeline
    assert str(grid.resolve()) in info.proj_pipeline
    assert info.as_document()["geoid"] == str(grid.resolve())


@pytest.mark.parametrize("folder", ["my grids", "a+b=c é", "plain"])
def test_a_geoid_grid_in_any_folder_gives_the_same_heights(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, folder: str
) -> None:
    # Spaces were refused (and the demo failed in an output folder with a space); a
    # relative path is taken from the working folder, whatever its name.
    lon, lat, h = _quebec()
    pos = _ecef(lon, lat, h)
    work = tmp_path / folder
    work.mkdir()
    write_grid(work / "geoid model.gtx")
    monkeypatch.chdir(work)
    plan, info = plan_ecef_to_crs("EPSG:32619+5703", geoid="geoid model.gtx", sample_ecef_m=pos)
    out = crs_plan_transformer(plan)
    assert out is not None
    np.testing.assert_allclose(out(pos)[:, 2], h - _geoid(lon, lat), rtol=0, atol=2e-5)
    assert info.geoid == str(work / "geoid model.gtx")


def test_a_link_to_a_geoid_grid_is_read_through_the_link(tmp_path: Path) -> None:
    lon, lat, h = _quebec()
    pos = _ecef(lon, lat, h)
    (tmp_path / "odd, folder").mkdir()
    grid = write_grid(tmp_path / "odd, folder" / "geoid.gtx")
    link = tmp_path / "geoid.gtx"
    link.symlink_to(grid)
    plan, info = plan_ecef_to_crs("EPSG:32619+5703", geoid=str(link), sample_ecef_m=pos)
    out = crs_plan_transformer(plan)
    assert out is not None
    np.testing.assert_allclose(out(pos)[:, 2], h - _geoid(lon, lat), rtol=0, atol=2e-5)
    assert info.geoid == str(link)


@pytest.mark.parametrize("name", ["a,b", 'a"b'])
def test_a_geoid_path_proj_cannot_quote_is_refused(tmp_path: Path, name: str) -> None:
    (tmp_path / name).mkdir()
    grid = write_grid(tmp_path / name / "geoid.gtx")
    with pytest.raises(InputError, match=r"comma or a double quote; copy or link it"):
        plan_ecef_to_crs("EPSG:32619+5703", geoid=str(grid))


def test_a_geoid_needs_a_compound_crs(tmp_path: Path) -> None:
    grid = write_grid(tmp_path / "geoid.gtx")
    with pytest.raises(InputError, match=r"compound --crs .*EPSG:32618\+5703"):
        plan_ecef_to_crs("EPSG:32619", geoid=str(grid))


def test_a_missing_geoid_file_is_named(tmp_path: Path) -> None:
    with pytest.raises(InputError, match=r"--geoid .*nope\.gtx: file not found"):
        plan_ecef_to_crs("EPSG:32619+5703", geoid=str(tmp_path / "nope.gtx"))


def test_a_corrupt_geoid_file_is_named(tmp_path: Path) -> None:
    bad = tmp_path / "bad.gtx"
    bad.write_bytes(b"not a grid")
    lon, lat, h = _quebec(3)
    with pytest.raises(InputError, match=r"--geoid .*bad\.gtx: PROJ cannot transform"):
        plan_ecef_to_crs("EPSG:32619+5703", geoid=str(bad), sample_ecef_m=_ecef(lon, lat, h))


def test_a_geoid_that_does_not_cover_the_data_is_named(tmp_path: Path) -> None:
    grid = write_grid(tmp_path / "geoid.gtx")
    far = _ecef(np.array([-60.0]), np.array([46.8]), np.array([0.0]))
    with pytest.raises(InputError, match=r"does not cover the data .*longitude -60\.0000"):
        plan_ecef_to_crs("EPSG:32620+5703", geoid=str(grid), sample_ecef_m=far)


# --------------------------------------------------------------------------- missing grids
def _skip_if_proj_has_grids() -> None:
    """These tests need PROJ without geoid grids (pyproj's wheels ship none)."""
    dirs = [pyproj.datadir.get_data_dir(), pyproj.datadir.get_user_data_dir()]  # type: ignore[attr-defined]
    network = bool(pyproj.network.is_network_enabled())  # type: ignore[attr-defined]
    if network or any(any(Path(d).glob("*.tif")) for d in dirs if Path(d).is_dir()):
        pytest.skip("PROJ has grids here (or fetches them)")


@pytest.mark.parametrize("crs", ["EPSG:32618+5703", "EPSG:32619+3855", "EPSG:2959+6647"])
def test_a_compound_crs_without_its_grid_is_refused_naming_the_grid(crs: str) -> None:
    """PROJ would keep ellipsoidal heights under the orthometric label (tens of metres)."""
    _skip_if_proj_has_grids()
    lon, lat, h = _quebec(3)
    with pytest.raises(InputError) as caught:
        plan_ecef_to_crs(crs, sample_ecef_m=_ecef(lon, lat, h))
    text = str(caught.value)
    grid, role = text.split("need the grid ")[1].split(",", maxsplit=1)[0].split(" ", 1)
    assert grid.endswith(".tif")
    assert role == "(geoid model)"
    assert f"projsync --file {grid}" in text
    assert "--geoid PATH" in text
    assert "PROJ_NETWORK=ON" in text


def test_every_grid_the_transformation_lacks_is_named_with_what_it_does() -> None:
    # NAD83 state plane feet + NAVD88 feet near Boston: the best transformation needs a
    # geoid model and a NAD83 datum shift grid. The message named the geoid only, then
    # listed datum-shift grids as "other grids that would do" (they give no heights).
    _skip_if_proj_has_grids()
    pos = _ecef(np.array([-71.06]), np.array([42.36]), np.array([10.0]))
    with pytest.raises(InputError) as caught:
        plan_ecef_to_crs("EPSG:2249+6360", sample_ecef_m=pos)
    text = str(caught.value)
    assert "would do" not in text
    head, rest = text.split("need the grid ", 1)[1].split(", which PROJ does not have", 1)
    geoid, role = head.split(" ", 1)
    assert role == "(geoid model)", text
    shifts = re.findall(r"and also (\S+\.tif) \(datum shift\)", rest)
    assert len(shifts) == 1, text
    for grid in (geoid, *shifts):
        assert f"`projsync --file {grid}`" in text
        assert f"https://cdn.proj.org/{grid}" in text
    assert "install them with" in text
    assert "Without them PROJ" in text


def test_reading_a_cloud_in_a_compound_crs_without_its_grid_is_refused() -> None:
    _skip_if_proj_has_grids()
    crs_to_ecef_transformer.cache_clear()
    with pytest.raises(InputError, match=r"need the grid .*projsync"):
        crs_to_ecef_transformer("EPSG:32619+3855")


# --------------------------------------------------------------------------- epochs
def test_a_time_dependent_transformation_uses_the_epoch_given() -> None:
    lon, lat, h = _quebec(5)
    pos = _ecef(lon, lat, h)  # taken as ITRF2014 coordinates
    plan, info = plan_ecef_to_crs(
        "EPSG:22719", source_crs="EPSG:7789", epoch_year=2024.5, sample_ecef_m=pos
    )
    assert info.time_dependent
    assert info.epoch_year == 2024.5
    assert "helmert" in info.proj_pipeline
    ref = pyproj.Transformer.from_crs(7789, 22719, always_xy=True)
    e, n, u, _ = ref.transform(pos[:, 0], pos[:, 1], pos[:, 2], np.full(len(pos), 2024.5))
    out = crs_plan_transformer(plan)
    assert out is not None
    np.testing.assert_allclose(out(pos), np.column_stack([e, n, u]), rtol=0, atol=1e-6)
    # the epoch matters: 14.5 years of plate motion in the North American frame move it
    plan_2010, _ = plan_ecef_to_crs(
        "EPSG:22719", source_crs="EPSG:7789", epoch_year=2010.0, sample_ecef_m=pos
    )
    other = crs_plan_transformer(plan_2010)
    assert other is not None
    assert np.abs(other(pos) - out(pos))[:, :2].max() > 0.05


def test_the_data_date_is_the_default_epoch_and_no_date_is_an_error() -> None:
    lon, lat, h = _quebec(3)
    pos = _ecef(lon, lat, h)
    _, info = plan_ecef_to_crs(
        "EPSG:22719", source_crs="EPSG:7789", sample_ecef_m=pos, observation_epoch_year=2023.25
    )
    assert info.epoch_year == 2023.25
    with pytest.raises(InputError, match=r"depends on time .*--epoch YEAR"):
        plan_ecef_to_crs("EPSG:22719", source_crs="EPSG:7789", sample_ecef_m=pos)


def test_an_epoch_that_changes_nothing_is_said() -> None:
    _, info = plan_ecef_to_crs("EPSG:32619", epoch_year=2020.0)
    assert not info.time_dependent
    assert any("changes nothing" in w for w in info.warnings)


@pytest.mark.parametrize("epoch", [1900.0, 2200.0, float("nan")])
def test_an_absurd_epoch_is_refused(epoch: float) -> None:
    with pytest.raises(InputError, match=r"--epoch .*decimal year"):
        plan_ecef_to_crs("EPSG:32619", epoch_year=epoch)


def test_gps_time_to_decimal_year() -> None:
    assert gps_to_decimal_year(utc_fields_to_gps_s(2024, 7, 2, 0.0)) == pytest.approx(2024.5)
    assert gps_to_decimal_year(utc_fields_to_gps_s(2023, 1, 1, 0.0)) == pytest.approx(2023.0)


# --------------------------------------------------------------------------- datums
def test_a_coarse_datum_change_is_a_warning_naming_the_trajectory_frame() -> None:
    lon, lat, h = _quebec(3)
    _, info = plan_ecef_to_crs("EPSG:2960", sample_ecef_m=_ecef(lon, lat, h))
    assert info.accuracy_m is not None
    assert info.accuracy_m > 0.5
    assert any("--trajectory-crs" in w for w in info.warnings)


def test_a_ballpark_datum_change_is_a_warning() -> None:
    lon, lat, h = _quebec(3)
    _, info = plan_ecef_to_crs(
        "EPSG:2960", source_crs="EPSG:7789", sample_ecef_m=_ecef(lon, lat, h)
    )
    assert info.ballpark
    assert any("ballpark" in w for w in info.warnings)


def test_the_trajectory_crs_must_be_geocentric() -> None:
    with pytest.raises(InputError, match=r"--trajectory-crs 'EPSG:4326' .*geocentric"):
        plan_ecef_to_crs("EPSG:32619", source_crs="EPSG:4326")


def test_ecef_output_is_the_identity() -> None:
    plan, info = plan_ecef_to_crs("EPSG:4978")
    assert crs_plan_transformer(plan) is None
    assert info.heights.startswith("none")


def test_an_unknown_crs_is_refused() -> None:
    with pytest.raises(InputError, match=r"--crs 'EPSG:1': unknown"):
        plan_ecef_to_crs("EPSG:1")


def test_the_plain_transformer_matches_pyproj() -> None:
    lon, lat, h = _quebec(4)
    out = ecef_to_crs_transformer("EPSG:32619")
    assert out is not None
    e, n, u = pyproj.Transformer.from_crs(4979, 32619, always_xy=True).transform(lon, lat, h)
    np.testing.assert_allclose(out(_ecef(lon, lat, h)), np.column_stack([e, n, u]), atol=1e-6)


@pytest.mark.parametrize("crs", ["EPSG:4979", "EPSG:32619"])
@pytest.mark.parametrize("moving", ["static", "due north", "due east"])
def test_data_on_a_point_or_a_meridian_have_a_transformation(crs: str, moving: str) -> None:
    """PROJ 9.2 finds no operation for an area of interest of zero width or height."""
    s = np.linspace(0.0, 0.01, 5)
    lon = QUEBEC_LON + (s if moving == "due east" else 0.0 * s)
    lat = QUEBEC_LAT + (s if moving == "due north" else 0.0 * s)
    pos = _ecef(lon, lat, 20.0 + 0.0 * s)
    plan, _ = plan_ecef_to_crs(crs, sample_ecef_m=pos)
    out = crs_plan_transformer(plan)
    assert out is not None
    expected = pyproj.Transformer.from_crs(4978, crs, always_xy=True).transform(*pos.T)
    np.testing.assert_allclose(out(pos), np.column_stack(expected), rtol=0, atol=1e-6)


# --------------------------------------------------------------------------- UTM zones
def test_a_utm_zone_far_from_the_data_is_a_warning_naming_the_right_one() -> None:
    lon, lat, h = _quebec(3)
    _, info = plan_ecef_to_crs("EPSG:32618", sample_ecef_m=_ecef(lon, lat, h))
    (warning,) = info.warnings
    assert "UTM zone 18N (EPSG:32618)" in warning
    assert "19N: WGS 84 / UTM zone 19N (EPSG:32619)" in warning
    assert "+6" in warning  # ppm: 600-700 at 3.8 deg from the central meridian
    _, info = plan_ecef_to_crs("EPSG:32619", sample_ecef_m=_ecef(lon, lat, h))
    assert info.warnings == ()


def test_the_zone_suggestion_keeps_the_datum() -> None:
    lon, lat, h = _quebec(3)
    _, info = plan_ecef_to_crs(
        "EPSG:2959", source_crs="EPSG:7789", sample_ecef_m=_ecef(lon, lat, h)
    )
    assert any("NAD83(CSRS) / UTM zone 19N (EPSG:2960)" in w for w in info.warnings)


@given(
    st.floats(-180.0, 179.999, allow_nan=False),
    st.floats(-80.0, 83.9, allow_nan=False),
)
def test_utm_zones_contain_their_points(lon: float, lat: float) -> None:
    zone, hemisphere = utm_zone_of(lon, lat)
    assert 1 <= zone <= 60
    assert hemisphere == ("N" if lat >= 0 else "S")
    central = -183.0 + 6.0 * zone
    special = (56.0 <= lat < 64.0 and 3.0 <= lon < 12.0) or (lat >= 72.0 and 0.0 <= lon < 42.0)
    if not special:
        assert abs(lon - central) <= 3.0 + 1e-9


def test_utm_zone_exceptions() -> None:
    assert utm_zone_of(5.0, 60.0) == (32, "N")  # south-west Norway
    assert utm_zone_of(15.0, 78.0) == (33, "N")  # Svalbard
    assert utm_zone_of(QUEBEC_LON, QUEBEC_LAT) == (19, "N")
    assert utm_zone_of(151.2, -33.9) == (56, "S")


def test_the_data_area_gives_extent_and_zones() -> None:
    area = data_area(np.array([46.7, 46.9]), np.array([-72.2, -71.9]), np.array([5.0, 50.0]))
    assert area.lat_deg == (46.7, 46.9)
    assert area.lon_deg == (-72.2, -71.9)
    assert area.h_m == (5.0, 50.0)
    assert area.zones_spanned == (18, 19)
    assert area.utm_epsg == "EPSG:32618"  # the centre, -72.05 deg, is in zone 18
    across = data_area(np.array([-17.0, -17.1]), np.array([179.9, -179.9]), np.zeros(2))
    assert across.lon_deg == pytest.approx((179.9, -179.9))
    assert across.utm_epsg in ("EPSG:32760", "EPSG:32701")


def test_data_across_the_antimeridian_span_zones_60_and_1() -> None:
    """Review L3: zones came sorted (1, 60), read as "zones 1-60"."""
    across = data_area(np.array([-16.5, -16.5]), np.array([179.99, -179.99]), np.zeros(2))
    assert across.zones_spanned == (60, 1)
    wide = data_area(np.full(4, -16.5), np.array([173.0, 179.0, -179.0, -173.0]), np.zeros(4))
    assert wide.zones_spanned == (59, 60, 1, 2)
    assert wide.lon_deg == (173.0, -173.0)
    assert wide.utm_epsg == "EPSG:32701"  # the centre, 180 deg, is where zone 1 starts


@pytest.mark.parametrize("crs", ["EPSG:32701", "EPSG:32760"])
def test_the_area_warning_across_the_antimeridian_names_the_zones_there(crs: str) -> None:
    """Review L3: the plain mean of 179.9999 and -179.9999 deg suggested zone 29S."""
    lon = np.array([179.9999, 179.99995, -179.99995, -179.9999])
    _, info = plan_ecef_to_crs(crs, sample_ecef_m=_ecef(lon, np.full(4, -16.5), np.zeros(4)))
    (warning,) = info.warnings
    assert "longitude 179.9999 to -179.9999 deg, across the antimeridian" in warning
    assert "29S" not in warning
    assert "-180.00 to 180.00" not in warning
    if crs == "EPSG:32760":
        assert "the data's zone is 1S: WGS 84 / UTM zone 1S (EPSG:32701)" in warning
    else:  # the zone asked for is the data's own (their centre is on 180 deg)
        assert "the data's zone" not in warning


@pytest.mark.parametrize(
    ("lat", "epsg", "name"), [(85.0, "EPSG:32661", "UPS North"), (-82.0, "EPSG:32761", "UPS South")]
)
def test_beyond_utms_limits_ups_is_suggested(lat: float, epsg: str, name: str) -> None:
    """Review L3: at 85 deg N zone 19N (EPSG:32619) was suggested, outside its 0-84 deg N."""
    area = data_area(np.full(2, lat), np.array([-71.2, -71.1]), np.zeros(2))
    assert (area.utm_zone, area.utm_epsg, area.zone_name) == (None, epsg, name)
    assert area.as_document()["utm_zone"] == name
    aou = pyproj.CRS(epsg).area_of_use
    assert aou is not None
    assert aou.south <= lat <= aou.north
    utm = "EPSG:32619" if lat > 0 else "EPSG:32719"
    sample = _ecef(np.array([-71.2, -71.1]), np.full(2, lat), np.zeros(2))
    (warning,) = plan_ecef_to_crs(utm, sample_ecef_m=sample)[1].warnings
    assert f"the data's zone is {name} (beyond UTM's" in warning
    assert f"({epsg})" in warning
    assert data_area(np.full(2, 84.0), np.array([-71.2, -71.1]), np.zeros(2)).utm_zone == 19
