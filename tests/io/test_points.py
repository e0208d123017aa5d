"""CSV/Parquet point tables: chunked round trips, dtypes kept, bad input."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from kinsync.errors import InputError
from kinsync.io.points import TableChunkWriter, count_table_rows, iter_table_chunks

REQUIRED = ("t_s", "x_m", "y_m", "z_m")


def _columns(n: int, seed: int = 0) -> dict[str, np.ndarray[Any, Any]]:
    rng = np.random.default_rng(seed)
    return {
        "t_s": 1.4e9 + np.sort(rng.uniform(0, 10, n)),
        "x_m": rng.normal(0, 10, n),
        "y_m": np.round(rng.normal(0, 10, n)),  # integral floats stay floats
        "z_m": rng.normal(0, 1, n),
        "intensity": rng.integers(0, 65535, n).astype(np.int64),
        "return_number": rng.integers(1, 4, n).astype(np.int64),
        "valid": rng.random(n) > 0.5,
        "label": np.array([f"p{i}" for i in range(n)], dtype=object),
    }


def _write(path: Path, cols: dict[str, np.ndarray[Any, Any]], chunk: int) -> None:
    n = len(cols["t_s"])
    with TableChunkWriter(path) as w:
        for i in range(0, n, chunk):
            w.write({k: v[i : i + chunk] for k, v in cols.items()})


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_chunked_round_trip_keeps_columns_and_dtypes(tmp_path: Path, suffix: str) -> None:
    cols = _columns(2500)
    path = tmp_path / f"pts{suffix}"
    _write(path, cols, 700)
    assert count_table_rows(path) == 2500
    chunks = list(iter_table_chunks(path, 1000, REQUIRED))
    assert [len(c["t_s"]) for c in chunks] == [1000, 1000, 500]
    assert list(chunks[0]) == list(cols)
    for name, values in cols.items():
        got = np.concatenate([c[name] for c in chunks])
        if values.dtype == object:
            assert got.tolist() == values.tolist()
        else:
            assert got.dtype == values.dtype, name
            np.testing.assert_array_equal(got, values, err_msg=name)


def test_parquet_keeps_narrow_dtypes(tmp_path: Path) -> None:
    cols = {
        "t_s": np.arange(5.0),
        "x_m": np.zeros(5),
        "y_m": np.zeros(5),
        "z_m": np.zeros(5),
        "intensity": np.arange(5, dtype=np.uint16),
        "refl": np.linspace(0, 1, 5, dtype=np.float32),
    }
    path = tmp_path / "n.parquet"
    _write(path, cols, 2)
    (chunk,) = iter_table_chunks(path, 10, REQUIRED)
    assert chunk["intensity"].dtype == np.uint16
    assert chunk["refl"].dtype == np.float32


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_missing_columns(tmp_path: Path, suffix: str) -> None:
    cols = {k: v for k, v in _columns(5).items() if k != "y_m"}
    path = tmp_path / f"m{suffix}"
    _write(path, cols, 5)
    with pytest.raises(InputError, match=r"m\.\w+: missing column\(s\) \['y_m'\].*intensity"):
        next(iter_table_chunks(path, 10, REQUIRED))


def test_non_numeric_csv_cell_names_line(tmp_path: Path) -> None:
    path = tmp_path / "bad.csv"
    path.write_text("t_s,x_m,y_m,z_m,note\n1,2,3,4,a\n2,abc,3,4,b\n")
    with pytest.raises(InputError, match=r"bad\.csv: line 3 \(data row 1\), column 'x_m'"):
        list(iter_table_chunks(path, 10, REQUIRED))
    path.write_text("t_s,x_m,y_m,z_m\n1,2,3,4\n2,3,,4\n")
    with pytest.raises(InputError, match=r"data row 1, column 'y_m': empty"):
        list(iter_table_chunks(path, 10, REQUIRED))


def test_non_numeric_parquet_cell_names_row(tmp_path: Path) -> None:
    path = tmp_path / "bad.parquet"
    cols = {
        "t_s": np.arange(3.0),
        "x_m": np.array(["1", "2", "x"], dtype=object),
        "y_m": np.zeros(3),
        "z_m": np.zeros(3),
    }
    _write(path, cols, 3)
    with pytest.raises(InputError, match=r"bad\.parquet: data row 2, column 'x_m'"):
        list(iter_table_chunks(path, 10, REQUIRED))


def test_failing_writer_leaves_no_file_and_bad_suffix(tmp_path: Path) -> None:
    path = tmp_path / "out.parquet"
    with pytest.raises(RuntimeError, match="boom"), TableChunkWriter(path) as w:  # noqa: PT012
        w.write(_columns(10))
        raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(InputError, match="unknown table type"):
        TableChunkWriter(tmp_path / "o.txt")
    with (  # noqa: PT012
        pytest.raises(InputError, match="differ from the first"),
        TableChunkWriter(path) as w,
    ):
        w.write({"a": np.zeros(2)})
        w.write({"b": np.zeros(2)})
    assert not path.exists()
