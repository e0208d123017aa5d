"""``kinsync georef`` to CRSs in feet: X, Y, Z against pyproj, units in every output.

EPSG:2249 (NAD83 / Massachusetts Mainland (ftUS)) and EPSG:2222 (NAD83 / Arizona East
(ft), international feet) have no height axis: X, Y come out in feet, Z is the
ellipsoidal height in metres, and the outputs say so. EPSG:2249+6360 (NAVD88 height
(ftUS)) gives Z in US survey feet. The data lie near Québec, outside those CRSs' areas
of use: PROJ still projects them, and the warnings say so.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import laspy
import numpy as np
import pyarrow.parquet as pq
import pyproj
import pytest
from tests.cli.test_cli_georef import (
    MOUNT,
    RunCli,
    _expected_ecef,
    _gtx,
    _las_points,
    setup,  # noqa: F401 (the fixture)
)

from kinsync.crs import crs_to_ecef_transformer
from kinsync.crs_axes import output_units
from kinsync.io.cloud import cloud_crs
from kinsync.io.las import las_info

US_FT_M = 1200.0 / 3937.0
LAS_FORMATS = [(1, "1.2"), (6, "1.4")]


def _georef(
    run_cli: RunCli, s: dict[str, Path], src: Path, out: Path, *extra: str
) -> dict[str, Any]:
    code, stdout, err = run_cli(
        [
            "georef",
            "--points",
            str(src),
            "--trajectory",
            str(s["traj"]),
            "--mount",
            str(s["mount"]),
            "--out",
            str(out),
            "--json",
            *extra,
        ]
    )
    assert code == 0, err
    return dict(json.loads(stdout))


def _truth_ecef(s: dict[str, Path], src: Path) -> np.ndarray:
    """The kernel's ECEF positions of the input's points (as stored, 0.1 mm)."""
    las = laspy.read(src)
    xyz = np.column_stack([las.x, las.y, las.z])
    return _expected_ecef(s["traj"], np.asarray(las.gps_time) + 1e9, xyz, MOUNT)


def _read_xyz(path: Path) -> np.ndarray:
    if path.suffix == ".las":
        las = laspy.read(path)
        return np.column_stack([las.x, las.y, las.z])
    table = pq.read_table(path)
    return np.column_stack([table.column(c).to_numpy() for c in ("X", "Y", "Z")])


@pytest.mark.parametrize(("point_format", "version"), LAS_FORMATS)
@pytest.mark.parametrize(("crs", "unit"), [("EPSG:2249", "US survey foot"), ("EPSG:2222", "foot")])
def test_a_crs_in_feet_gives_feet_and_metres_said_everywhere_and_round_trips(
    run_cli: RunCli,
    setup: dict[str, Path],  # noqa: F811
    crs: str,
    unit: str,
    point_format: int,
    version: str,
) -> None:
    src = _las_points(setup["dir"] / "scan.las", point_format, version)
    out = setup["dir"] / "feet.las"
    doc = _georef(run_cli, setup, src, out, "--crs", crs)
    assert doc["crs"]["units"] == {"X": unit, "Y": unit, "Z": "metre"}
    assert any("ellipsoidal height in metres" in w for w in doc["warnings"])
    ecef = _truth_ecef(setup, src)
    truth = np.column_stack(
        pyproj.Transformer.from_crs(4978, crs, always_xy=True).transform(*ecef.T)
    )
    got = _read_xyz(out)
    # LAS integers at scale 1e-4 of each axis' unit (feet for X, Y; metres for Z)
    header = laspy.read(out).header
    np.testing.assert_allclose(header.scales, [1e-4] * 3)
    assert np.abs(got - truth).max() <= 0.5e-4 + 1e-7
    # the file's CRS names the units: Z in metres under X, Y in feet
    info = las_info(out)
    assert info.crs_wkt is not None
    declared = pyproj.CRS.from_wkt(info.crs_wkt)
    if point_format >= 6:
        assert output_units(declared) == (unit, unit, "metre")
        assert len(declared.axis_info) == 3
    else:
        keys = {
            k.id: k.value_offset for v in header.vlrs if hasattr(v, "geo_keys") for k in v.geo_keys
        }
        assert (keys[3072], keys[4099]) == (int(crs.split(":")[1]), 9001)
    # round trip: the file's own CRS takes the points back to the kernel's ECEF
    to_ecef = crs_to_ecef_transformer(info.crs_wkt)
    assert to_ecef is not None
    assert np.abs(to_ecef(got) - ecef).max() < 1e-3
    assert cloud_crs(out, crs) == crs  # --crs EPSG:2249 is the file's CRS


def test_a_parquet_output_names_the_units_of_x_y_z(
    run_cli: RunCli,
    setup: dict[str, Path],  # noqa: F811
) -> None:
    src = _las_points(setup["dir"] / "scan.las", 6, "1.4")
    out = setup["dir"] / "feet.parquet"
    _georef(run_cli, setup, src, out, "--crs", "EPSG:2249", "--chunk-points", "700")
    schema = pq.read_schema(out)
    units = [schema.field(c).metadata[b"unit"].decode() for c in ("X", "Y", "Z")]
    assert units == ["US survey foot", "US survey foot", "metre"]
    declared = pyproj.CRS.from_json(schema.metadata[b"crs"].decode())
    assert output_units(declared) == tuple(units)
    ecef = _truth_ecef(setup, src)
    truth = np.column_stack(
        pyproj.Transformer.from_crs(4978, 2249, always_xy=True).transform(*ecef.T)
    )
    assert np.abs(_read_xyz(out) - truth).max() < 1e-6


@pytest.mark.parametrize(("point_format", "version"), LAS_FORMATS)
def test_a_compound_crs_in_us_feet_gives_heights_in_us_feet(
    run_cli: RunCli,
    setup: dict[str, Path],  # noqa: F811
    point_format: int,
    version: str,
) -> None:
    src = _las_points(setup["dir"] / "scan.las", point_format, version)
    grid = _gtx(setup["dir"] / "geoid.gtx")
    out = setup["dir"] / "navd88_ftus.las"
    doc = _georef(run_cli, setup, src, out, "--crs", "EPSG:2249+6360", "--geoid", str(grid))
    assert doc["crs"]["units"] == {
        "X": "US survey foot",
        "Y": "US survey foot",
        "Z": "US survey foot",
    }
    assert not any("vertical axis" in w for w in doc["warnings"])
    ecef = _truth_ecef(setup, src)
    lon, lat, h = pyproj.Transformer.from_crs(4978, 4979, always_xy=True).transform(*ecef.T)
    geoid_n = -30.0 + 0.5 * (lat - 46.5) + 0.2 * (lon + 71.0)
    got = _read_xyz(out)
    # H = h - N in US survey feet (float32 grid, NAD83 = WGS 84 here to < 0.1 mm)
    assert np.abs(got[:, 2] - (h - geoid_n) / US_FT_M).max() < 1e-3
    # the file says so: vertical CRS NAVD88 height (ftUS), read back whole
    info = las_info(out)
    assert info.crs_wkt is not None
    assert pyproj.CRS.from_wkt(info.crs_wkt).equals(pyproj.CRS("EPSG:2249+6360"))
    if point_format < 6:
        header = laspy.read(out).header
        keys = {
            k.id: k.value_offset for v in header.vlrs if hasattr(v, "geo_keys") for k in v.geo_keys
        }
        assert (keys[3072], keys[4096], keys[4099]) == (2249, 6360, 9003)


def test_trajectory_export_in_feet_names_the_units(
    run_cli: RunCli,
    setup: dict[str, Path],  # noqa: F811
) -> None:
    out = setup["dir"] / "traj_feet.parquet"
    code, stdout, err = run_cli(
        [
            "trajectory",
            "export",
            str(setup["traj"]),
            "--out",
            str(out),
            "--crs",
            "EPSG:2249",
            "--json",
        ]
    )
    assert code == 0, err
    assert json.loads(stdout)["crs"]["units"]["Z"] == "metre"
    assert "ellipsoidal height in metres" in err
    schema = pq.read_schema(out)
    assert schema.field("X").metadata[b"unit"] == b"US survey foot"
    assert schema.field("Z").metadata[b"unit"] == b"metre"
