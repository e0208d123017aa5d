"""A UTF-8 byte order mark (Windows editors, Excel "CSV UTF-8") is accepted by every
reader of numeric CSV tables (`kinsync.io.tables.read_numeric_csv`) and the header
sniffers: the header once came back as ['\\ufefft_s', ...], "missing column(s) ['t_s']"."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from kinsync.io.clock_model import read_pps_csv
from kinsync.io.gnss_csv import read_gnss_csv, write_gnss_csv
from kinsync.io.imu_csv import read_imu_csv, write_imu_csv
from kinsync.io.nav_csv import (
    read_nav_csv,
    read_navigation,
    read_truth_csv,
    write_nav_csv,
    write_truth_csv,
)
from kinsync.io.passes import read_pass_file, read_passes, write_passes
from kinsync.io.points import table_columns
from kinsync.io.profile_scan import read_pulses, write_pulses
from kinsync.io.raw_passes import read_raw_attitude, read_raw_pass
from kinsync.io.tables import read_numeric_csv, write_numeric_csv
from kinsync.io.trajectory_csv import read_trajectory_csv, write_trajectory_csv

from .test_gnss_csv import _gnss
from .test_imu_csv import _imu
from .test_nav_csv import nav_solution
from .test_passes import _passes

BOM = b"\xef\xbb\xbf"


def _add_bom(path: Path) -> None:
    data = path.read_bytes()
    assert not data.startswith(BOM)
    path.write_bytes(BOM + data)


def _pps(path: Path) -> None:
    write_numeric_csv(path, {"t_local_s": 1000.0 + np.arange(5.0)})


def _raw_pass(path: Path) -> None:
    cols = {"t_s": np.arange(4.0), "x_m": np.ones(4), "y_m": np.zeros(4), "z_m": np.zeros(4)}
    write_numeric_csv(path, cols)


def _raw_attitude(path: Path) -> None:
    zeros = np.zeros(4)
    write_numeric_csv(
        path, {"t_s": np.arange(4.0), "roll_deg": zeros, "pitch_deg": zeros, "yaw_deg": zeros}
    )


def _points(path: Path) -> None:
    write_numeric_csv(path, {"x_m": np.arange(3.0), "y_m": np.ones(3), "z_m": np.zeros(3)})


WRITERS: dict[str, tuple[Callable[[Path], None], Callable[[Path], Any]]] = {
    "pps": (_pps, read_pps_csv),
    "imu": (lambda p: write_imu_csv(_imu(), p), read_imu_csv),
    "gnss": (lambda p: write_gnss_csv(_gnss(), p), read_gnss_csv),
    "nav": (lambda p: write_nav_csv(nav_solution(), p), read_nav_csv),
    "navigation": (lambda p: write_nav_csv(nav_solution(), p), read_navigation),
    "truth": (lambda p: write_truth_csv(nav_solution().to_trajectory(), p), read_truth_csv),
    "trajectory": (
        lambda p: write_trajectory_csv(nav_solution().to_trajectory(), p),
        read_trajectory_csv,
    ),
    "pulses": (lambda p: write_pulses(np.arange(5.0), p), read_pulses),
    "pass file": (_raw_pass, read_pass_file),
    "raw pass": (_raw_pass, read_raw_pass),
    "raw attitude": (_raw_attitude, read_raw_attitude),
    "points header": (_points, table_columns),
    "numeric": (_pps, lambda p: read_numeric_csv(p, ["t_local_s"]).columns),
}


def _same(a: Any, b: Any) -> None:
    if isinstance(a, tuple | list):
        assert len(a) == len(b)
        for x, y in zip(a, b, strict=True):
            _same(x, y)
    elif isinstance(a, dict):
        assert a.keys() == b.keys()
        for k in a:
            _same(a[k], b[k])
    elif isinstance(a, np.ndarray):
        np.testing.assert_array_equal(a, b)
    elif hasattr(a, "__dataclass_fields__"):
        for name in a.__dataclass_fields__:
            if name != "source":  # the file name
                _same(getattr(a, name), getattr(b, name))
    elif hasattr(a, "columns"):
        _same(a.columns, b.columns)
    else:
        assert a == b or (a is None and b is None)


@pytest.mark.parametrize("name", sorted(WRITERS))
def test_a_bom_is_accepted(name: str, tmp_path: Path) -> None:
    write, read = WRITERS[name]
    plain, bom = tmp_path / "plain.csv", tmp_path / "bom.csv"
    write(plain)
    write(bom)
    _add_bom(bom)
    _same(read(plain), read(bom))


def test_a_bom_in_a_pass_folder_is_accepted(tmp_path: Path) -> None:
    write_passes(tmp_path / "plain", _passes())
    write_passes(tmp_path / "bom", _passes())
    for path in (tmp_path / "bom").glob("*.csv"):
        _add_bom(path)
    _same(read_passes(tmp_path / "plain"), read_passes(tmp_path / "bom"))


def test_a_bad_cell_after_a_bom_is_still_named(tmp_path: Path) -> None:
    path = tmp_path / "pps.csv"
    path.write_bytes(BOM + b"t_local_s\n1.0\nabc\n")
    with pytest.raises(Exception, match=r"line 3, column 't_local_s'"):
        read_pps_csv(path)


def test_a_bom_on_a_clock_model_is_accepted(tmp_path: Path) -> None:
    # Was "line 1, column 1: not valid JSON (Unexpected UTF-8 BOM ...)", while CSV and
    # TOML files with one were read.
    from kinsync.clock import ClockModel  # noqa: PLC0415
    from kinsync.io.clock_model import read_clock_model, write_clock_model  # noqa: PLC0415

    model = ClockModel(
        reference_local_s=10.0, reference_gps_s=1.4e9, drift_ppm=3.0, span_local_s=(10.0, 20.0)
    )
    path = tmp_path / "model.json"
    write_clock_model(model, path)
    _add_bom(path)
    assert read_clock_model(path).reference_gps_s == 1.4e9
