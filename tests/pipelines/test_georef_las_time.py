"""A LAS file whose times cannot be the seconds of week its header says."""

from __future__ import annotations

from pathlib import Path

import laspy
import numpy as np
import pytest
from tests._las import las_points
from tests.pipelines.test_georef_gaps import MOUNT, T0, _columns, gap_traj

from kinsync.errors import InputError
from kinsync.pipelines.georef import georeference_file

__all__ = ["gap_traj"]  # the fixture


def test_adjusted_time_with_the_encoding_bit_unset_is_named_as_such(
    tmp_path: Path, gap_traj: Path
) -> None:
    cols = _columns()
    las = las_points(cols)  # adjusted standard GPS time, ~3e8 s
    las.header.global_encoding.gps_time_type = laspy.header.GpsTimeType.WEEK_TIME
    src = tmp_path / "unset.laz"
    las.write(src)
    assert float(np.max(laspy.read(src).gps_time)) == pytest.approx(T0 + 9.9 - 1e9, abs=0.2)
    with pytest.raises(InputError) as err:
        georeference_file(src, gap_traj, MOUNT, tmp_path / "o.laz", gps_week=2000)
    msg = str(err.value)
    assert "cannot be GPS seconds of week (a week has 604800 s)" in msg
    assert "adjusted standard GPS time" in msg
    assert "bit unset" in msg
    assert "GpsTimeType.STANDARD" in msg
    assert not (tmp_path / "o.laz").exists()
