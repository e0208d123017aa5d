"""Units of the output X, Y, Z: CRSs in US survey feet and international feet.

A state plane CRS in feet has no height axis: PROJ passes the ellipsoidal height through
in metres. The output must say so (units, a warning, the declared CRS); a compound CRS
whose vertical part is in feet gets heights in feet, from PROJ or from a geoid grid.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pyproj
import pytest
from tests.test_crs import _ecef, _geoid, _quebec, write_grid

from kinsync.crs import crs_plan_transformer, plan_ecef_to_crs
from kinsync.crs_axes import declared_crs, mixed_units_note, output_units

US_FT_M = 1200.0 / 3937.0  # the US survey foot (m)
FT_M = 0.3048  # the international foot (m)


@pytest.mark.parametrize(
    ("crs", "units"),
    [
        ("EPSG:2249", ("US survey foot", "US survey foot", "metre")),
        ("EPSG:2222", ("foot", "foot", "metre")),
        ("EPSG:2249+6360", ("US survey foot",) * 3),
        ("EPSG:2222+8228", ("foot",) * 3),
        ("EPSG:2249+5703", ("US survey foot", "US survey foot", "metre")),
        ("EPSG:32619", ("metre",) * 3),
        ("EPSG:32619+5703", ("metre",) * 3),
        ("EPSG:4326", ("degree", "degree", "metre")),
        ("EPSG:4979", ("degree", "degree", "metre")),
        ("EPSG:4978", ("metre",) * 3),
    ],
)
def test_output_units_name_each_axis(crs: str, units: tuple[str, str, str]) -> None:
    assert output_units(pyproj.CRS(crs)) == units


@pytest.mark.parametrize("code", [2249, 2222])
def test_a_2d_crs_in_feet_is_declared_with_its_metre_height_axis(code: int) -> None:
    crs = pyproj.CRS.from_epsg(code)
    declared = declared_crs(crs)
    assert len(declared.axis_info) == 3
    height = declared.axis_info[2]
    assert height.unit_name == "metre"
    assert "ellipsoidal height" in height.name.lower()
    assert [a.unit_name for a in declared.axis_info[:2]] == [a.unit_name for a in crs.axis_info]
    assert declared.to_authority(min_confidence=20) == ("EPSG", str(code))
    assert output_units(declared) == output_units(crs)


@pytest.mark.parametrize("crs", ["EPSG:32619", "EPSG:4326", "EPSG:2249+6360", "EPSG:4978"])
def test_other_crss_are_declared_as_given(crs: str) -> None:
    given = pyproj.CRS(crs)
    assert declared_crs(given) == given


def test_the_note_suggests_a_compound_crs_in_the_same_foot() -> None:
    us = mixed_units_note(pyproj.CRS("EPSG:2249"), "EPSG:2249")
    assert us is not None
    assert "X and Y are in US survey foot" in us
    assert "ellipsoidal height in metres" in us
    assert "EPSG:2249+6360" in us
    international = mixed_units_note(pyproj.CRS("EPSG:2222"), "EPSG:2222")
    assert international is not None
    assert "EPSG:2222+8228" in international
    mixed = mixed_units_note(pyproj.CRS("EPSG:2249+5703"), "EPSG:2249+5703")
    assert mixed is not None
    assert "Z in metre" in mixed
    for same in ("EPSG:32619", "EPSG:4326", "EPSG:2249+6360", "EPSG:4978", "EPSG:32619+5703"):
        assert mixed_units_note(pyproj.CRS(same), same) is None


@pytest.mark.parametrize("code", [2249, 2222])
def test_georef_to_a_crs_in_feet_gives_feet_and_an_ellipsoidal_height_in_metres(
    code: int,
) -> None:
    lon, lat, h = _quebec()
    pos = _ecef(lon, lat, h)
    crs = f"EPSG:{code}"
    plan, info = plan_ecef_to_crs(crs, sample_ecef_m=pos)
    apply = crs_plan_transformer(plan)
    assert apply is not None
    got = apply(pos)
    # pyproj's truth: the CRS as given passes the height through, in metres
    truth = pyproj.Transformer.from_crs(
        pyproj.CRS(4978), pyproj.CRS(crs), always_xy=True
    ).transform(pos[:, 0], pos[:, 1], pos[:, 2])
    np.testing.assert_allclose(got, np.column_stack(truth), rtol=0, atol=1e-6)
    # X, Y in feet: the same projection in metres, divided by the foot
    foot = US_FT_M if code == 2249 else FT_M
    with warnings.catch_warnings():  # PROJ strings lose information: not needed here
        warnings.simplefilter("ignore", UserWarning)
        proj4 = pyproj.CRS(crs).to_proj4()
    assert proj4 is not None
    metres = pyproj.Transformer.from_crs(
        4978,
        pyproj.CRS(proj4.replace("+units=us-ft", "+units=m").replace("+units=ft", "+units=m")),
        always_xy=True,
    ).transform(pos[:, 0], pos[:, 1], pos[:, 2])
    np.testing.assert_allclose(got[:, 0] * foot, metres[0], rtol=0, atol=1e-6)
    np.testing.assert_allclose(got[:, 1] * foot, metres[1], rtol=0, atol=1e-6)
    assert np.all(np.abs(got[:, 2] - h) < 1e-3)  # NAD83 = WGS 84 (null Helmert): h itself
    unit = "US survey foot" if code == 2249 else "foot"
    assert info.units == (unit, unit, "metre")
    assert info.as_document()["units"] == {"X": unit, "Y": unit, "Z": "metre"}
    assert any("ellipsoidal height in metres" in w for w in info.warnings)


def test_a_utm_output_has_no_units_warning() -> None:
    lon, lat, h = _quebec()
    _, info = plan_ecef_to_crs("EPSG:32619", sample_ecef_m=_ecef(lon, lat, h))
    assert info.units == ("metre",) * 3
    assert not any("vertical axis" in w for w in info.warnings)


@pytest.mark.parametrize(
    ("crs", "foot", "sign"),
    [
        ("EPSG:2249+6360", US_FT_M, 1.0),  # NAVD88 height (ftUS)
        ("EPSG:2222+8228", FT_M, 1.0),  # NAVD88 height (ft)
        ("EPSG:2249+5703", 1.0, 1.0),  # NAVD88 height, metres under ftUS X, Y
        ("EPSG:2249+6358", US_FT_M, -1.0),  # NAVD88 depth (ftUS): positive down
    ],
)
def test_a_geoid_grid_gives_heights_in_the_vertical_crs_unit_and_direction(
    tmp_path: Path, crs: str, foot: float, sign: float
) -> None:
    lon, lat, h = _quebec()
    pos = _ecef(lon, lat, h)
    grid = write_grid(tmp_path / "geoid.gtx")
    plan, info = plan_ecef_to_crs(crs, geoid=str(grid), sample_ecef_m=pos)
    apply = crs_plan_transformer(plan)
    assert apply is not None
    got = apply(pos)
    # float32 grid values (1e-5 m); NAD83's GRS80 and WGS 84 heights differ by < 0.1 mm
    np.testing.assert_allclose(got[:, 2], sign * (h - _geoid(lon, lat)) / foot, rtol=0, atol=5e-4)
    horizontal = pyproj.CRS(crs).sub_crs_list[0].to_3d()
    e, n, _ = pyproj.Transformer.from_crs(4978, horizontal, always_xy=True).transform(
        pos[:, 0], pos[:, 1], pos[:, 2]
    )
    np.testing.assert_allclose(got[:, 0], e, rtol=0, atol=1e-5)
    np.testing.assert_allclose(got[:, 1], n, rtol=0, atol=1e-5)
    assert info.units[2] == pyproj.CRS(crs).sub_crs_list[1].axis_info[0].unit_name
