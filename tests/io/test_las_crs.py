"""The CRS a LAS/LAZ file declares (issue 16 item 1): WKT, GeoTIFF keys, compound CRSs;
Z's unit from VerticalUnitsGeoKey without a vertical CRS."""

from __future__ import annotations

from pathlib import Path

import laspy
import numpy as np
import pyproj
import pytest
from tests._las import geotiff_las

from kinsync.crs_axes import declared_crs, output_units
from kinsync.errors import InputError
from kinsync.io.las_crs import las_crs, las_crs_keys, read_las_crs, set_las_crs


def _written(tmp_path: Path, point_format: int, version: str, crs: pyproj.CRS) -> laspy.LasData:
    header = laspy.LasHeader(point_format=point_format, version=version)
    path = tmp_path / "out.las"
    set_las_crs(header, crs, path)
    las = laspy.LasData(header)
    las.x = np.array([1.0])
    las.y = np.array([2.0])
    las.z = np.array([3.0])
    las.write(path)
    return laspy.read(path)


def _keys(las: laspy.LasData) -> dict[int, int]:
    return {
        k.id: k.value_offset for v in las.header.vlrs if hasattr(v, "geo_keys") for k in v.geo_keys
    }


@pytest.mark.parametrize(("point_format", "version"), [(1, "1.2"), (3, "1.4"), (0, "1.3")])
def test_a_compound_crs_in_geotiff_keys_has_its_vertical_key(
    tmp_path: Path, point_format: int, version: str
) -> None:
    las = _written(tmp_path, point_format, version, pyproj.CRS("EPSG:32618+5703"))
    keys = _keys(las)
    assert keys[1024] == 1  # projected
    assert keys[3072] == 32618
    assert keys[4096] == 5703
    assert keys[4099] == 9001
    assert las.header.parse_crs() == pyproj.CRS.from_epsg(32618)  # laspy reads the horizontal
    assert not las.header.global_encoding.wkt
    ascii_vlr = next(v for v in las.header.vlrs if type(v).__name__ == "GeoAsciiParamsVlr")
    assert "NAVD88" in ascii_vlr.strings[0]


def test_a_compound_crs_in_wkt_reads_back_whole(tmp_path: Path) -> None:
    crs = pyproj.CRS("EPSG:32619+5703")
    las = _written(tmp_path, 6, "1.4", crs)
    assert las.header.parse_crs() == crs
    assert las.header.global_encoding.wkt


def _wkt_record(las: laspy.LasData) -> str:
    record = next(v for v in las.header.vlrs if type(v).__name__ == "WktCoordinateSystemVlr")
    text = record.string
    return text.decode("ascii") if isinstance(text, bytes) else str(text)


@pytest.mark.parametrize(
    ("code", "keyword"),
    [
        ("EPSG:32619", "PROJCS["),
        ("EPSG:32619+5703", "COMPD_CS["),
        ("EPSG:4979", "COMPD_CS["),  # WKT1 has no 3D geographic CRS: GDAL's form
        ("EPSG:4978", "GEOCCS["),
        ("EPSG:2249", "COMPD_CS["),  # X, Y in US feet, Z the ellipsoidal height in metres
    ],
)
def test_wkt_records_are_wkt1_and_read_back_as_the_crs(
    tmp_path: Path, code: str, keyword: str
) -> None:
    """LAS 1.4 names OGC 01-009 (WKT1); LAStools and GDAL 2 read no WKT2."""
    crs = pyproj.CRS(code)
    header = laspy.LasHeader(point_format=6, version="1.4")
    assert set_las_crs(header, crs, tmp_path / "out.las") is None
    las = _written(tmp_path, 6, "1.4", crs)
    text = _wkt_record(las)
    assert text.startswith(keyword)
    assert not any(w in text for w in ("PROJCRS[", "GEOGCRS[", "GEODCRS[", "COMPOUNDCRS["))
    declared = declared_crs(crs)
    for back in (las_crs(las.header), las.header.parse_crs()):
        assert back is not None
        assert back.equals(declared, ignore_axis_order=True)
        assert output_units(back) == output_units(declared)
    if code in ("EPSG:32619", "EPSG:4979", "EPSG:4978"):
        assert las.header.parse_crs().to_epsg() == crs.to_epsg()


def test_a_crs_wkt1_cannot_represent_is_declared_in_wkt2_with_a_warning(
    tmp_path: Path,
) -> None:
    crs = pyproj.CRS("+proj=ob_tran +o_proj=longlat +o_lon_p=10 +o_lat_p=80 +ellps=WGS84")
    header = laspy.LasHeader(point_format=6, version="1.4")
    note = set_las_crs(header, crs, tmp_path / "out.las")
    assert note is not None
    assert note.startswith(f"{tmp_path / 'out.las'}: its CRS")
    assert "cannot be written as WKT1" in note
    assert "WKT2-2019" in note
    las = _written(tmp_path, 6, "1.4", crs)
    assert _wkt_record(las).startswith("GEOGCRS[")
    assert las.header.parse_crs().to_wkt() == crs.to_wkt()


@pytest.mark.parametrize(
    ("crs", "model", "key"),
    [("EPSG:4978", 3, 2048), ("EPSG:4326", 2, 2048), ("EPSG:32619", 1, 3072)],
)
def test_geotiff_model_types(tmp_path: Path, crs: str, model: int, key: int) -> None:
    keys = _keys(_written(tmp_path, 1, "1.2", pyproj.CRS(crs)))
    assert keys[1024] == model
    assert keys[key] == pyproj.CRS(crs).to_epsg()


def test_a_crs_without_epsg_code_goes_in_wkt_in_las_1_4(tmp_path: Path) -> None:
    crs = pyproj.CRS("+proj=tmerc +lon_0=-71 +k=0.9999 +x_0=300000 +ellps=GRS80 +units=m")
    assert las_crs_keys(crs) is None
    las = _written(tmp_path, 1, "1.4", crs)
    assert las.header.parse_crs().equals(crs)


def test_a_crs_without_epsg_code_in_an_old_las_is_refused(tmp_path: Path) -> None:
    crs = pyproj.CRS("+proj=tmerc +lon_0=-71 +k=0.9999 +x_0=300000 +ellps=GRS80 +units=m")
    header = laspy.LasHeader(point_format=1, version="1.2")
    with pytest.raises(InputError, match=r"out\.las: LAS 1\.2 point format 1 .*EPSG codes"):
        set_las_crs(header, crs, tmp_path / "out.las")


def test_a_new_crs_replaces_the_old_one(tmp_path: Path) -> None:
    header = laspy.LasHeader(point_format=1, version="1.2")
    set_las_crs(header, pyproj.CRS("EPSG:32618"), tmp_path / "x.las")
    set_las_crs(header, pyproj.CRS("EPSG:32619+5703"), tmp_path / "x.las")
    names = [type(v).__name__ for v in header.vlrs]
    assert names.count("GeoKeyDirectoryVlr") == 1
    assert names.count("GeoAsciiParamsVlr") == 1


# ------------------------------------------- Z's unit: CRSs in feet (US survey, international)
@pytest.mark.parametrize(("crs", "unit"), [("EPSG:2249+6360", 9003), ("EPSG:2222+8228", 9002)])
@pytest.mark.parametrize(("point_format", "version"), [(1, "1.2"), (3, "1.4")])
def test_geotiff_vertical_units_are_the_vertical_crs_unit(
    tmp_path: Path, crs: str, unit: int, point_format: int, version: str
) -> None:
    las = _written(tmp_path, point_format, version, pyproj.CRS(crs))
    keys = _keys(las)
    assert keys[4096] == pyproj.CRS(crs).sub_crs_list[1].to_epsg()
    assert keys[4099] == unit
    # read back whole: Z in the vertical CRS's unit, not metres
    read = las_crs(las.header)
    assert read is not None
    assert read.equals(pyproj.CRS(crs))
    assert output_units(read)[2] == output_units(pyproj.CRS(crs))[2]


@pytest.mark.parametrize(("code", "unit"), [(2249, "US survey foot"), (2222, "foot")])
def test_a_2d_crs_in_feet_declares_z_in_metres(tmp_path: Path, code: int, unit: str) -> None:
    crs = pyproj.CRS.from_epsg(code)
    keys = _keys(_written(tmp_path, 1, "1.2", crs))
    assert (keys[3072], keys[4099]) == (code, 9001)  # projected CRS, vertical units metre
    assert 4096 not in keys
    wkt = _written(tmp_path, 6, "1.4", crs)
    read = las_crs(wkt.header)
    assert read is not None
    assert output_units(read) == (unit, unit, "metre")
    assert read.axis_info[2].name == "Ellipsoidal height"
    assert read.to_authority(min_confidence=20) == ("EPSG", str(code))


def test_a_crs_in_metres_is_declared_as_given(tmp_path: Path) -> None:
    crs = pyproj.CRS.from_epsg(32619)
    assert 4099 not in _keys(_written(tmp_path, 1, "1.2", crs))
    read = las_crs(_written(tmp_path, 6, "1.4", crs).header)
    assert read is not None
    assert read.to_epsg() == 32619


def test_a_vertical_key_that_is_no_vertical_crs_leaves_the_horizontal(tmp_path: Path) -> None:
    las = _written(tmp_path, 1, "1.2", pyproj.CRS("EPSG:32618+5703"))
    directory = next(v for v in las.header.vlrs if hasattr(v, "geo_keys"))
    for key in directory.geo_keys:
        if key.id == 4096:
            key.value_offset = 5103  # LAStools' NAVD88: the datum's code, not a CRS
    assert las_crs(las.header) == pyproj.CRS.from_epsg(32618)


# ---------------------- Z's unit from VerticalUnitsGeoKey without a vertical CRS (LAStools)
_POINT_2249_FTUS = (775_000.0, 2_950_000.0)  # Boston, in EPSG:2249 (US survey feet)
_POINT_32619_M = (330_000.0, 4_690_000.0)  # Boston, in EPSG:32619 (metres)


@pytest.mark.parametrize(
    ("keys", "xy", "unit", "metres_per_unit"),
    [
        ({1024: 1, 3072: 2249, 4099: 9003}, _POINT_2249_FTUS, "US survey foot", 1200 / 3937),
        (
            {1024: 1, 3072: 2249, 4096: 32767, 4099: 9003},
            _POINT_2249_FTUS,
            "US survey foot",
            1200 / 3937,
        ),
        ({1024: 1, 3072: 32619, 4099: 9002}, _POINT_32619_M, "foot", 0.3048),
        (
            {1024: 1, 3072: 32619, 4096: 5103, 4099: 9003},
            _POINT_32619_M,
            "US survey foot",
            1200 / 3937,
        ),
    ],
)
def test_vertical_units_without_a_vertical_crs_give_z_its_unit(
    tmp_path: Path,
    keys: dict[int, int],
    xy: tuple[float, float],
    unit: str,
    metres_per_unit: float,
) -> None:
    height_m = 30.0
    path = geotiff_las(tmp_path / "feet.las", keys, (*xy, height_m / metres_per_unit))
    read = read_las_crs(laspy.read(path).header)
    assert read.crs is not None
    assert output_units(read.crs)[2] == unit
    assert read.crs.to_2d().to_epsg() == keys[3072]
    assert read.note is not None
    assert "VerticalUnitsGeoKey (4099)" in read.note
    assert "ellipsoidal height" in read.note
    # PROJ converts Z: the same ECEF point as the 2D CRS with the height in metres
    h_unit = height_m / metres_per_unit
    feet = pyproj.Transformer.from_crs(read.crs, 4978, always_xy=True).transform(*xy, h_unit)
    metres = pyproj.Transformer.from_crs(keys[3072], 4978, always_xy=True).transform(*xy, height_m)
    assert np.allclose(feet, metres, atol=1e-6)


def test_kinsync_own_2d_feet_output_still_reads_z_in_metres(tmp_path: Path) -> None:
    """EPSG:2249 as kinsync writes it (VerticalUnitsGeoKey metre): the 2D CRS, no note;
    the same keys with US survey feet give Z in feet."""
    own = _written(tmp_path, 1, "1.2", pyproj.CRS.from_epsg(2249))
    read = read_las_crs(own.header)
    assert read.crs == pyproj.CRS.from_epsg(2249)
    assert output_units(read.crs) == ("US survey foot", "US survey foot", "metre")
    assert read.note is None
    feet = geotiff_las(tmp_path / "ft.las", {1024: 1, 3072: 2249, 4099: 9003}, (1, 2, 3))
    feet_crs = las_crs(laspy.read(feet).header)
    assert feet_crs is not None
    assert output_units(feet_crs)[2] == "US survey foot"


@pytest.mark.parametrize("code", [9102, 12345, 32767])
def test_a_vertical_unit_that_is_no_length_is_refused(tmp_path: Path, code: int) -> None:
    path = geotiff_las(tmp_path / "x.las", {1024: 1, 3072: 2249, 4099: code}, (1, 2, 3))
    with pytest.raises(
        InputError, match=rf"VerticalUnitsGeoKey \(4099\) is {code}, no EPSG length"
    ):
        las_crs(laspy.read(path).header)
