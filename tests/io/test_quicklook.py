"""Quick-look lines: decimation and the GeoJSON / KML writers' refusals."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from kinsync.errors import InputError
from kinsync.io import quicklook
from kinsync.io.quicklook import decimate, write_geojson_line, write_kml_line


@given(st.integers(1, 100_000), st.integers(2, 5_000))
def test_decimation_keeps_the_ends_and_the_bound(n: int, max_vertices: int) -> None:
    rows = decimate(n, max_vertices)
    assert rows[0] == 0
    assert rows[-1] == n - 1
    assert len(rows) == min(n, max_vertices)
    assert (np.diff(rows) > 0).all()


def test_writers_refuse_what_is_no_line(tmp_path: Path) -> None:
    with pytest.raises(InputError, match=">= 2"):
        decimate(10, 1)
    with pytest.raises(InputError, match=">= 2 vertices"):
        write_kml_line(tmp_path / "a.kml", np.zeros(1), np.zeros(1), "a")
    with pytest.raises(InputError, match="finite"):
        write_geojson_line(tmp_path / "a.geojson", np.array([0.0, np.nan]), np.zeros(2),
                           np.zeros(2), {})  # fmt: skip
    assert list(tmp_path.iterdir()) == []


def test_kml_escapes_the_name(tmp_path: Path) -> None:
    path = tmp_path / "a.kml"
    write_kml_line(path, np.array([1.0, 2.0]), np.array([3.0, 4.0]), "a<b&c")
    assert "a&lt;b&amp;c" in path.read_text()


def test_a_geojson_line_across_the_antimeridian_is_cut_there(tmp_path: Path) -> None:
    """Review L3: one LineString jumped from 179.99999 to -180 deg (RFC 7946 3.1.9: cut it)."""
    path = tmp_path / "a.geojson"
    lon = np.array([179.9, 179.95, -179.95, -179.9])
    lat = np.array([-16.0, -16.1, -16.2, -16.3])
    write_geojson_line(path, lon, lat, np.array([0.0, 10.0, 20.0, 30.0]), {})
    geometry = json.loads(path.read_text())["features"][0]["geometry"]
    assert geometry["type"] == "MultiLineString"
    west, east = (np.array(part) for part in geometry["coordinates"])
    np.testing.assert_allclose(west, [[179.9, -16.0, 0.0], [179.95, -16.1, 10.0],
                                      [180.0, -16.15, 15.0]], atol=1e-9)  # fmt: skip
    np.testing.assert_allclose(east, [[-180.0, -16.15, 15.0], [-179.95, -16.2, 20.0],
                                      [-179.9, -16.3, 30.0]], atol=1e-9)  # fmt: skip
    # a vertex on the antimeridian ends one part and starts the next, once each
    write_geojson_line(path, np.array([179.99999, -180.0, -179.99999]), np.zeros(3),
                       np.zeros(3), {})  # fmt: skip
    geometry = json.loads(path.read_text())["features"][0]["geometry"]
    assert geometry["coordinates"] == [
        [[179.99999, 0.0, 0.0], [180.0, 0.0, 0.0]],
        [[-180.0, 0.0, 0.0], [-179.99999, 0.0, 0.0]],
    ]


@pytest.mark.parametrize(
    ("lon", "parts"),
    [
        ([10.0, 20.0], 1),
        ([-179.9, 180.0, -179.8], 1),  # touches it and turns back
        ([180.0, -179.9], 1),
        ([179.9, -179.9, 179.9], 3),
    ],
)
def test_antimeridian_parts(lon: list[float], parts: int) -> None:
    got = quicklook.antimeridian_parts(
        np.array(lon), np.arange(len(lon), dtype=float), np.zeros(len(lon))
    )
    assert len(got) == parts
    for part in got:
        assert len(part) >= 2
        steps = np.diff([v[0] for v in part])
        assert (np.abs(steps) <= 180.0).all()  # no part jumps across the map
