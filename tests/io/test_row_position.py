"""Bad points are named as the file counts them: CSV line, Parquet row of all, LAS point.

Users open the file to find the point: a 0-based index ("data row 1", "point 17") sent
them one row too early. Every reader that checks clouds chunk by chunk names the
absolute position in the file, past the first chunk too.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from tests._las import las_points

from kinsync.errors import InputError
from kinsync.io.cloud import check_finite_chunk, iter_cloud
from kinsync.io.row_position import point_position, position_span

N = 10


def _check(path: Path, chunk_points: int) -> None:
    done = 0
    for xyz, t, _ in iter_cloud(path, chunk_points, need_time=False):
        check_finite_chunk(path, xyz, done, t_s=t)
        done += xyz.shape[0]


def _cols(bad_row: int) -> dict[str, np.ndarray]:
    y = np.ones(N)
    y[bad_row] = np.nan
    return {"X": np.zeros(N), "Y": y, "Z": np.zeros(N)}


def test_a_parquet_cloud_names_the_row_of_all_past_the_first_chunk(tmp_path: Path) -> None:
    path = tmp_path / "c.parquet"
    pq.write_table(pa.table(_cols(N - 1)), path, row_group_size=3)  # the last row
    with pytest.raises(
        InputError,
        match=r"c\.parquet: row 10 of 10, column 'Y': nan is not a finite number; "
        r"1 such point\(s\) in rows 9\.\.10 of 10",
    ):
        _check(path, 4)
    with pytest.raises(InputError, match=r"row 10 of 10, column 'Y'.* in the file"):
        _check(path, 100)


def test_a_csv_cloud_names_the_file_line_past_the_first_chunk(tmp_path: Path) -> None:
    cols = _cols(1)  # the second data row, after a blank line: file line 4
    rows = [",".join(repr(float(cols[c][i])) for c in "XYZ") for i in range(N)]
    path = tmp_path / "c.csv"
    path.write_text("X,Y,Z\n" + rows[0] + "\n\n" + "\n".join(rows[1:]) + "\n")
    with pytest.raises(InputError, match=r"c\.csv: line 4, column 'Y': nan is not a finite"):
        _check(path, 100)
    cols = _cols(7)
    rows = [",".join(repr(float(cols[c][i])) for c in "XYZ") for i in range(N)]
    path.write_text("X,Y,Z\n" + rows[0] + "\n\n" + "\n".join(rows[1:]) + "\n")
    with pytest.raises(InputError, match=r"c\.csv: line 10, column 'Y'.* in lines 9\.\.11"):
        _check(path, 3)  # the third chunk: data rows 6..8, file lines 9..11


def test_a_las_cloud_names_the_point_of_all(tmp_path: Path) -> None:
    t = 1.0e9 + np.arange(N, dtype=np.float64)
    las = las_points({"x_m": np.zeros(N), "y_m": np.ones(N), "z_m": np.zeros(N), "t_s": t})
    times = np.asarray(las.gps_time).copy()
    times[N - 1] = np.nan
    las.gps_time = times
    path = tmp_path / "c.las"
    las.write(path)
    done = 0
    with pytest.raises(  # noqa: PT012
        InputError, match=r"c\.las: point 10 of 10, column 'gps_time': nan .* in points 9\.\.10"
    ):
        for xyz, _, _ in iter_cloud(path, 4, need_time=False):
            t_chunk = times[done : done + xyz.shape[0]]
            check_finite_chunk(path, xyz, done, t_s=t_chunk)
            done += xyz.shape[0]


def test_positions_and_spans() -> None:
    assert point_position(Path("a.parquet"), 0, 5) == "row 1 of 5"
    assert point_position(Path("a.LAZ"), 4, 5) == "point 5 of 5"
    assert position_span("line 2", "line 9") == "lines 2..9"
    assert position_span("row 3 of 9", "row 9 of 9") == "rows 3..9 of 9"
    assert position_span("point 1 of 1", "point 1 of 1") == "point 1 of 1"
