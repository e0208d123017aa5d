"""The CRS a LAS/LAZ file declares (issue 16 item 1): WKT, GeoTIFF keys, compound CRSs."""

from __future__ import annotations

from pathlib import Path

import laspy
import numpy as np
import pyproj
import pytest

from kinsync.crs_axes import output_units
from kinsync.errors import InputError
from kinsync.io.las_crs import las_crs, las_crs_keys, set_las_crs


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
