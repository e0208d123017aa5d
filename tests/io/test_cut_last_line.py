"""A file cut mid-write ends mid-number without a line end: every text reader warns.

Its last number reads as complete (a yaw of 179.999983 cut to ``17``, a trajectory
point 10 m off): the control- and sync-point readers warned about such a last line, the
trajectory CSV, Inertial Explorer export, point table, CIDCO pass, pass index and PPS
readers read it silently. They all go through `kinsync.io.text_lines.warn_if_unended`.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from kinsync.errors import InputError, KinsyncWarning
from kinsync.io.cidco import CIDCO_COLUMNS, read_cidco_pass
from kinsync.io.clock_model import read_pps_csv
from kinsync.io.passes import read_pass_index
from kinsync.io.points import iter_table_chunks, plan_table_slices
from kinsync.io.pos_text import read_pos_text
from kinsync.io.tables import read_time_column
from kinsync.io.text_lines import unended_last_line, warn_if_unended
from kinsync.io.trajectory_csv import read_trajectory_csv

from .test_pos_text import _ie_text

TRAJECTORY = (
    "t_s,lat_deg,lon_deg,h_m,roll_deg,pitch_deg,yaw_deg\n"
    "1300000000.0,46.8,-71.2,10.0,0.0,0.0,179.9\n"
    "1300000000.1,46.8,-71.2,10.0,0.0,0.0,179.9\n"
    "1300000000.2,46.8,-71.2,10.0,0.0,0.0,17"
)
POINTS = "t_s,x_m,y_m,z_m\n1.0,0.0,1.0,2.0\n2.0,0.0,1.0,2.0\n3.0,0.0,1.0,2"
IE = _ie_text("100.0 46.8 -71.2 10.0 0.1 0.2 30.0\n100.1 46.8 -71.2 10.0 0.1 0.2 3")
CIDCO = "\n".join(" ".join(f"{10 * r + c}.5" for c in range(CIDCO_COLUMNS)) for r in range(3))
PASSES = "file,rate_deg_s\npass_01.csv,5.0\npass_02.csv,1"
CLOCK_IN = 't_s,note\n1300000000.0,a\n1300000001.0,"b c'


def _points_chunks(path: Path) -> Any:
    return list(iter_table_chunks(path, 10, ("t_s", "x_m", "y_m", "z_m")))


def _points_slices(path: Path) -> Any:
    return plan_table_slices(path, 10, ("t_s", "x_m", "y_m", "z_m"))


READERS: list[tuple[str, str, Callable[[Path], Any], int]] = [
    ("traj.csv", TRAJECTORY, read_trajectory_csv, 4),
    ("points.csv", POINTS, _points_chunks, 4),
    ("points.csv", POINTS, _points_slices, 4),
    ("export.txt", IE, read_pos_text, IE.count("\n") + 1),
    ("passage_1.txt", CIDCO, read_cidco_pass, 3),
    ("passes.csv", PASSES, read_pass_index, 3),
    ("in.csv", CLOCK_IN, lambda p: read_time_column(p, "t_s"), 3),
]


@pytest.mark.parametrize(("name", "text", "read", "line"), READERS)
def test_a_file_cut_mid_number_is_read_with_a_warning_naming_its_last_line(
    tmp_path: Path, name: str, text: str, read: Callable[[Path], Any], line: int
) -> None:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    pattern = rf"{name}: the file ends without a line end: .* check line {line}$"
    with pytest.warns(KinsyncWarning, match=pattern):
        read(path)


@pytest.mark.parametrize(("name", "text", "read", "line"), READERS)
@pytest.mark.parametrize("end", ["\n", "\r\n", "\r"])
def test_a_file_with_its_last_line_ended_reads_without_a_warning(
    tmp_path: Path, name: str, text: str, read: Callable[[Path], Any], line: int, end: str
) -> None:
    del line
    path = tmp_path / name
    path.write_bytes((text + "\n").replace("\n", end).encode("utf-8"))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        read(path)


@pytest.mark.parametrize(
    ("data", "line"),
    [
        (b"a\r\nb\rc\nd", 4),  # every kind of line end counts once
        (b"a\nb\n\n  ,,\n", None),
        (b"a\nb\n , ", None),  # a blank last line: no value to cut
        (b"", None),
        (b"a,b", 1),
    ],
)
def test_the_unended_last_line_is_counted_by_every_line_end(
    tmp_path: Path, data: bytes, line: int | None
) -> None:
    path = tmp_path / "f.txt"
    path.write_bytes(data)
    assert unended_last_line(path) == line


def test_a_header_alone_without_a_line_end_is_not_warned_about(tmp_path: Path) -> None:
    path = tmp_path / "h.csv"
    path.write_bytes(b"t_s,x_m")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warn_if_unended(path)


def test_a_cut_pps_line_that_goes_back_in_time_says_the_line_was_cut(tmp_path: Path) -> None:
    """1479381.0 cut to 147938 broke the order: the refusal said to sort the file."""
    path = tmp_path / "pps.csv"
    path.write_text("t_local_s\n1479379.0\n1479380.0\n147938", encoding="utf-8")
    with (
        pytest.warns(KinsyncWarning),
        pytest.raises(InputError, match=r"line 4.*sort the file.*ends without a line end"),
    ):
        read_pps_csv(path)


def test_a_row_cut_short_says_the_line_was_cut(tmp_path: Path) -> None:
    path = tmp_path / "traj.csv"
    path.write_text(TRAJECTORY.rsplit(",", 3)[0], encoding="utf-8")
    with (
        pytest.warns(KinsyncWarning),
        pytest.raises(InputError, match=r"line 4 has 4 fields.*ends without a line end"),
    ):
        read_trajectory_csv(path)


def test_a_cut_cidco_line_with_missing_numbers_says_the_line_was_cut(tmp_path: Path) -> None:
    path = tmp_path / "passage_1.txt"
    path.write_text(CIDCO[:-20], encoding="utf-8")
    with (
        pytest.warns(KinsyncWarning),
        pytest.raises(InputError, match=r"line 3 has .*ends without a line end"),
    ):
        read_cidco_pass(path)


def test_a_cut_points_file_keeps_its_rows(tmp_path: Path) -> None:
    """Warned about, not refused: every row is kept, the last as it reads."""
    path = tmp_path / "points.csv"
    path.write_text(POINTS, encoding="utf-8")
    with pytest.warns(KinsyncWarning):
        chunks = _points_chunks(path)
    np.testing.assert_array_equal(chunks[0]["z_m"], [2.0, 2.0, 2.0])
