"""GTX geoid grids: the layout PROJ reads (checked through PROJ in tests/test_crs.py)."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest

from kinsync.errors import InputError
from kinsync.io.gtx import write_gtx


def test_header_and_rows_south_to_north(tmp_path: Path) -> None:
    grid = np.arange(12.0).reshape(3, 4) - 30.0
    path = tmp_path / "g.gtx"
    write_gtx(path, 46.0, -72.0, 0.25, grid)
    data = path.read_bytes()
    assert struct.unpack(">4d2i", data[:40]) == (46.0, -72.0, 0.25, 0.25, 3, 4)
    np.testing.assert_array_equal(np.frombuffer(data[40:], ">f4").reshape(3, 4), grid)


@pytest.mark.parametrize(
    ("grid", "step", "what"),
    [
        (np.zeros(4), 0.1, "a GTX grid needs"),
        (np.zeros((1, 4)), 0.1, "a GTX grid needs"),
        (np.zeros((2, 2)), 0.0, "positive step"),
        (np.array([[0.0, np.nan], [0.0, 0.0]]), 0.1, "must be finite"),
    ],
)
def test_bad_grids_are_refused_and_nothing_written(
    tmp_path: Path, grid: np.ndarray, step: float, what: str
) -> None:
    path = tmp_path / "g.gtx"
    with pytest.raises(InputError, match=what):
        write_gtx(path, 46.0, -72.0, step, grid)
    assert not path.exists()
