"""Pieces of a large Parquet row group: each row decoded once when read in order."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from kinsync.errors import InputError
from kinsync.io import parquet_slices
from kinsync.io.points import TableLayout, TableSlice, plan_table_slices, read_table_slice

REQUIRED = ("t_s", "x_m", "y_m", "z_m")


def _file(path: Path, n: int, group: int) -> Path:
    rng = np.random.default_rng(3)
    table = pa.table(
        {
            "t_s": 1.4e9 + np.sort(rng.uniform(0, 10, n)),
            "x_m": rng.normal(0, 10, n),
            "y_m": rng.normal(0, 10, n),
            "z_m": rng.normal(0, 1, n),
            "intensity": pa.array(rng.integers(0, 65535, n), pa.int64()),
            "label": pa.array([f"p{i}" if i % 5 else None for i in range(n)], pa.string()),
        }
    )
    pq.write_table(table, path, row_group_size=group)
    return path


class _Counting:
    """Rows decoded by ``ParquetFile.iter_batches``."""

    rows = 0


@pytest.fixture
def counting(monkeypatch: pytest.MonkeyPatch) -> type[_Counting]:
    iter_batches = pq.ParquetFile.iter_batches

    def spy(self: Any, *args: Any, **kwargs: Any) -> Any:
        for batch in iter_batches(self, *args, **kwargs):
            _Counting.rows += batch.num_rows
            yield batch

    monkeypatch.setattr(pq.ParquetFile, "iter_batches", spy)
    _Counting.rows = 0
    parquet_slices.forget_cursor()
    return _Counting


def _read_before(layout: TableLayout, sl: TableSlice) -> Any:
    """The earlier reader of a row group piece: from the group's first row, every time."""
    pf = pq.ParquetFile(layout.path)
    parts, seen = [], 0
    for rb in pf.iter_batches(batch_size=min(sl.n_rows, 1 << 16), row_groups=[sl.row_groups[0]]):
        lo, hi = max(sl.skip_rows - seen, 0), min(sl.skip_rows + sl.n_rows - seen, rb.num_rows)
        if hi > lo:
            parts.append(rb.slice(lo, hi - lo))
        seen += rb.num_rows
        if seen >= sl.skip_rows + sl.n_rows:
            break
    return pa.Table.from_batches(parts, schema=pf.schema_arrow)


def _layout_of(columns: dict[str, Any]) -> list[list[int]]:
    return [[len(c) for c in v.chunks] for v in columns.values() if isinstance(v, pa.ChunkedArray)]


def test_pieces_read_in_order_decode_each_row_once(
    tmp_path: Path, counting: type[_Counting]
) -> None:
    """10 000 rows in one group, in 100 pieces: once through, not 50 times."""
    path = _file(tmp_path / "one.parquet", 10_000, 10_000)
    layout, slices = plan_table_slices(path, 100, REQUIRED)
    assert len(slices) == 100
    for sl in slices:
        read_table_slice(layout, sl)
    assert counting.rows == 10_000


def test_pieces_match_the_earlier_reader_batch_for_batch(tmp_path: Path) -> None:
    """Same values and the same record batches (a Parquet output depends on them),
    in order, out of order, read twice, and with a last piece of another size."""
    path = _file(tmp_path / "p.parquet", 200_000, 150_000)  # groups 150 000, 50 000
    for chunk in (7_000, 70_000, 140_000):
        parquet_slices.forget_cursor()
        layout, slices = plan_table_slices(path, chunk, REQUIRED)
        pieces = [s for s in slices if s.skip_rows or s.n_rows < 150_000]
        order = pieces + pieces[::-1] + pieces[1::3] + pieces[::2]
        for sl in order:
            got = read_table_slice(layout, sl, arrow=True)
            table = _read_before(layout, sl)
            want = {n: table.column(n) for n in table.column_names if n not in REQUIRED}
            assert _layout_of(got) == _layout_of(want), (chunk, sl)
            for name in table.column_names:
                values = got[name]
                if isinstance(values, pa.ChunkedArray):
                    assert values.equals(table.column(name)), name
                else:
                    np.testing.assert_array_equal(values, table.column(name).to_numpy())


def test_pool_worker_reading_every_other_piece_decodes_the_group_once(
    tmp_path: Path, counting: type[_Counting]
) -> None:
    path = _file(tmp_path / "w.parquet", 6_000, 6_000)
    layout, slices = plan_table_slices(path, 500, REQUIRED)
    for sl in slices[1::2]:
        read_table_slice(layout, sl)
    assert counting.rows <= 6_000


def test_only_some_columns(tmp_path: Path) -> None:
    path = _file(tmp_path / "c.parquet", 3_000, 3_000)
    layout, slices = plan_table_slices(path, 1_000, REQUIRED)
    got = read_table_slice(layout, slices[1], only=("t_s",))
    assert list(got) == ["t_s"]
    want = pq.read_table(path).column("t_s").to_numpy()[1_000:2_000]
    np.testing.assert_array_equal(got["t_s"], want)
    whole, (one,) = plan_table_slices(path, 5_000, REQUIRED)
    assert list(read_table_slice(whole, one, only=("label", "t_s"))) == ["t_s", "label"]


def test_a_rewritten_file_is_read_anew(tmp_path: Path) -> None:
    path = _file(tmp_path / "r.parquet", 4_000, 4_000)
    layout, slices = plan_table_slices(path, 1_000, REQUIRED)
    read_table_slice(layout, slices[0])
    _file(path, 4_000, 4_000)
    pq.write_table(pq.read_table(path).slice(2_000), path)  # another file, 2 000 rows
    with pytest.raises(InputError, match="1000 rows were planned, 0 read back"):
        read_table_slice(layout, slices[3])
