"""The CRS of a validation cloud (`kinsync.io.cloud.cloud_crs`) when a LAS file's Z has a
unit (VerticalUnitsGeoKey) but no vertical CRS: the unit is used, the datum is assumed
ellipsoidal with a warning, and a given --crs supplies it."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pyproj
import pytest
from tests._las import geotiff_las

from kinsync.crs import crs_to_ecef_transformer
from kinsync.crs_axes import output_units
from kinsync.errors import InputError, KinsyncWarning
from kinsync.io.cloud import cloud_crs

_XY_2249 = (775_000.0, 2_950_000.0)  # Boston, US survey feet
_HEIGHT_M = 30.0
_FTUS_M = 1200 / 3937


def _feet_file(tmp_path: Path, keys: dict[int, int] | None = None) -> Path:
    keys = keys or {1024: 1, 3072: 2249, 4099: 9003}
    return geotiff_las(tmp_path / "feet.las", keys, (*_XY_2249, _HEIGHT_M / _FTUS_M))


def test_z_in_feet_is_converted_with_one_warning_naming_file_and_key(tmp_path: Path) -> None:
    path = _feet_file(tmp_path)
    with pytest.warns(KinsyncWarning) as record:
        crs_text = cloud_crs(path, None)
    assert len(record) == 1
    message = str(record[0].message)
    assert str(path) in message
    assert "VerticalUnitsGeoKey (4099) 9003" in message
    assert "--crs" in message
    assert output_units(pyproj.CRS.from_user_input(crs_text))[2] == "US survey foot"
    to_ecef = crs_to_ecef_transformer(crs_text)
    assert to_ecef is not None
    got = to_ecef(np.array([[*_XY_2249, _HEIGHT_M / _FTUS_M]]))
    want = pyproj.Transformer.from_crs(2249, 4978, always_xy=True).transform(*_XY_2249, _HEIGHT_M)
    assert np.allclose(got[0], want, atol=1e-6)


def test_kinsync_own_2249_reads_back_without_warning(tmp_path: Path) -> None:
    path = geotiff_las(
        tmp_path / "own.las", {1024: 1, 3072: 2249, 4099: 9001}, (*_XY_2249, _HEIGHT_M)
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        crs_text = cloud_crs(path, None)
    assert pyproj.CRS.from_user_input(crs_text) == pyproj.CRS.from_epsg(2249)
    assert cloud_crs(path, "EPSG:2249") == "EPSG:2249"


def _no_grid_check(monkeypatch: pytest.MonkeyPatch) -> None:
    """EPSG:2249+6360 needs a geoid grid PROJ lacks here; the CRS check is what is tested."""
    monkeypatch.setattr("kinsync.io.cloud.crs_to_ecef_transformer", lambda _text: None)


def test_a_given_crs_supplies_the_datum_but_not_another_unit(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = _feet_file(tmp_path)
    _no_grid_check(monkeypatch)
    # the horizontal CRS and Z's unit agree: the given compound CRS names the datum
    assert cloud_crs(path, "EPSG:2249+6360") == "EPSG:2249+6360"
    with pytest.raises(InputError, match=r"feet\.las: .*Z in US survey foot.*Z in metre"):
        cloud_crs(path, "EPSG:2249")  # Z in metres: not what the file says
    with pytest.raises(InputError, match=r"feet\.las: .*omit --crs"):
        cloud_crs(path, "EPSG:26986+5703")  # another horizontal CRS


def test_an_unknown_vertical_unit_is_refused_unless_crs_is_given(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = _feet_file(tmp_path, {1024: 1, 3072: 2249, 4099: 9102})
    with pytest.raises(
        InputError, match=r"feet\.las: .*VerticalUnitsGeoKey \(4099\) is 9102.*--crs"
    ):
        cloud_crs(path, None)
    _no_grid_check(monkeypatch)
    assert cloud_crs(path, "EPSG:2249+6360") == "EPSG:2249+6360"
