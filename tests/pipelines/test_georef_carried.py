"""A table's carried columns through ``georeference_file``: types, nulls, rejected rows.

Parquet columns come out with their Arrow types and nulls (Parquet) or as the text of
their values with empty cells for nulls (CSV); rows outside the trajectory's span go to
the rejected file the same way, and a CSV's rejected rows are its own lines.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import laspy
import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.csv as pa_csv
import pyarrow.parquet as pq
import pytest
from tests._georef_scan import T0, csv_points, nullable_points, write_trajectory

from kinsync.errors import InputError
from kinsync.mount import Mount
from kinsync.pipelines.georef import georeference_file

MOUNT = Mount(lever_arm_body_m=(0.5, 0.1, -1.0), boresight_rpy_deg=(0.5, -0.3, 90.0))
N = 900
CHUNK = 200
DURATION_S = 10.0


CARRIED = ("intensity", "return_id", "maybe", "ok", "refl", "label", "u8")


@pytest.fixture
def traj_path(tmp_path: Path) -> Path:
    path = tmp_path / "traj.csv"
    write_trajectory(path, DURATION_S)
    return path


def _read(path: Path, types: pa.Schema) -> pa.Table:
    """A table written by georef; a CSV read with the input's types, empty cells null."""
    if path.suffix == ".parquet":
        return pq.read_table(path)
    names = [f.name for f in types if f.name in CARRIED or f.name == "id"]
    options = pa_csv.ConvertOptions(
        column_types={n: types.field(n).type for n in names},
        null_values=[""],
        strings_can_be_null=True,
    )
    return pa_csv.read_csv(path, convert_options=options)


def _check_carried(got: pa.Table, table: pa.Table) -> None:
    """``got`` holds rows of ``table`` (by ``id``) with every carried column as it was."""
    rows = pa.array(got.column("id").to_numpy())
    for name in CARRIED:
        assert got.schema.field(name).type == table.schema.field(name).type, name
        assert got.column(name).to_pylist() == table.column(name).take(rows).to_pylist(), name


@pytest.mark.parametrize("suffix", [".parquet", ".csv"])
def test_parquet_carried_columns_keep_their_types_and_nulls(
    tmp_path: Path, traj_path: Path, suffix: str
) -> None:
    table = nullable_points(N, DURATION_S, seed=1)
    src = tmp_path / "points.parquet"
    pq.write_table(table, src, row_group_size=150)
    out = tmp_path / f"geo{suffix}"
    summary = georeference_file(
        src, traj_path, MOUNT, out, chunk_points=CHUNK, outside="reject", crs="EPSG:4979"
    )
    assert 0 < summary.points_rejected < N
    got = _read(out, table.schema)
    rejected = _read(tmp_path / f"geo.rejected{suffix}", table.schema)
    assert got.num_rows + rejected.num_rows == N
    _check_carried(got, table)
    _check_carried(rejected, table)
    if suffix == ".csv":  # integers as integer text, nulls as empty cells
        line = (tmp_path / "geo.csv").read_text().splitlines()[1].split(",")
        header = (tmp_path / "geo.csv").read_text().splitlines()[0].split(",")
        row = int(line[header.index("id")])
        assert line[header.index("return_id")] == str(2**62 + row)
        assert line[header.index("intensity")] == str(row % 4000)
        text = (tmp_path / "geo.csv").read_text()
        assert "nan" not in text


def _inside_only_nulls(table: pa.Table) -> pa.Table:
    """The table with its integer and boolean columns' nulls only where t_s is outside."""
    outside = table.column("t_s").to_numpy() < T0
    cols: dict[str, Any] = {}
    for name in table.column_names:
        col = table.column(name)
        if name in ("maybe", "ok"):
            values = col.to_pylist()
            fill = 0 if name == "maybe" else True
            col = pa.array(
                [
                    None if out else (fill if v is None else v)
                    for v, out in zip(values, outside, strict=True)
                ],
                col.type,
            )
        cols[name] = col
    return pa.table(cols).drop_columns(["label"])


@pytest.mark.parametrize("suffix", [".las", ".ply"])
def test_parquet_to_las_or_ply_refuses_a_null_it_cannot_store(
    tmp_path: Path, traj_path: Path, suffix: str
) -> None:
    """A null integer used to be cast from NaN into a garbage integer, a null boolean to
    fail deep in pyarrow."""
    table = nullable_points(N, DURATION_S, seed=3).drop_columns(["label", "return_id"])
    src = tmp_path / "points.parquet"
    pq.write_table(table, src)
    out = tmp_path / f"geo{suffix}"
    with pytest.raises(InputError, match=r"row 251 of 900, column 'maybe': no value \(null\)"):
        georeference_file(src, traj_path, MOUNT, out, chunk_points=CHUNK, outside="reject")
    assert not out.exists()


def test_parquet_to_las_keeps_nulls_of_the_rejected_rows(tmp_path: Path, traj_path: Path) -> None:
    table = _inside_only_nulls(nullable_points(N, DURATION_S, seed=4)).drop_columns(["return_id"])
    src = tmp_path / "points.parquet"
    pq.write_table(table, src, row_group_size=150)
    out = tmp_path / "geo.las"
    summary = georeference_file(
        src, traj_path, MOUNT, out, chunk_points=CHUNK, outside="reject", crs="EPSG:32619"
    )
    assert summary.rejected_path == tmp_path / "geo.las.rejected.parquet"
    rejected = pq.read_table(summary.rejected_path)
    assert rejected.num_rows == summary.points_rejected > 0
    assert rejected.schema == table.schema
    assert rejected.column("maybe").null_count == rejected.num_rows
    ids = rejected.column("id").to_numpy()
    assert rejected.equals(table.take(pa.array(ids)))
    las = laspy.read(out)
    inside = table.filter(pc.greater_equal(table.column("t_s"), T0))
    np.testing.assert_array_equal(las.intensity, inside.column("intensity").to_numpy())
    np.testing.assert_array_equal(las["maybe"], inside.column("maybe").to_numpy())


# ------------------------------------------------------------------ CSV rejected rows
@pytest.mark.parametrize("suffix", [".csv", ".las", ".ply"])
def test_rejected_csv_rows_are_the_input_lines_byte_for_byte(
    tmp_path: Path, traj_path: Path, suffix: str
) -> None:
    """The rejected rows used to be re-formatted from floats (a time
    ``1299999999.123456789`` came back ``1299999999.1234567``, ``1.50`` as ``1.5``)."""
    src, header, lines = csv_points(tmp_path)
    out = tmp_path / f"geo{suffix}"
    summary = georeference_file(
        src, traj_path, MOUNT, out, chunk_points=7, outside="reject", crs="EPSG:32619"
    )
    assert summary.points_rejected == 3
    name = "geo.rejected.csv" if suffix == ".csv" else f"geo{suffix}.rejected.csv"
    assert summary.rejected_path == tmp_path / name
    assert summary.rejected_path.read_bytes() == header + b"".join(lines)


def test_csv_to_parquet_rejects_keep_the_carried_text(tmp_path: Path, traj_path: Path) -> None:
    """A CSV's other columns stay the text they were (no type is inferred, so that ``007``
    and a 2**66 integer come back as written); ``t_s`` is a float64 in Parquet."""
    src, _, _ = csv_points(tmp_path)
    out = tmp_path / "geo.parquet"
    georeference_file(src, traj_path, MOUNT, out, chunk_points=7, outside="reject")
    rejected = pq.read_table(tmp_path / "geo.rejected.parquet")
    assert rejected.column("code").to_pylist() == ["007", "a,b", "x"]
    assert rejected.column("big").to_pylist() == [str(2**66), "1", "2"]
    assert rejected.column("amp").to_pylist() == ["", "1E-320", "3"]
    assert rejected.column("t_s").to_pylist() == [1299999999.123456789, 1299999999.5, 1.3e9 + 100]
