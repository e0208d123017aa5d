"""Quick-look lines: decimation and the GeoJSON / KML writers' refusals."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from kinsync.errors import InputError
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
