"""Streaming a CSV point table: pyarrow's block bounded whatever the width and chunk size."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pyarrow.csv as pa_csv
import pytest

from kinsync.io.points import iter_table_chunks

REQUIRED = ("t_s", "x_m", "y_m", "z_m")


def _write(path: Path, n: int, extra: int, tail: str = "") -> Path:
    head = ",".join([*REQUIRED, *(f"e{i}" for i in range(extra))])
    rows = "".join(f"{i}.5,1,2,3{',7' * extra}\n" for i in range(n))
    path.write_text(f"{head}\n{rows}{tail}")
    return path


def _blocks(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """The block sizes pyarrow's streaming reader is opened with."""
    sizes: list[int] = []
    open_csv = pa_csv.open_csv

    def spy(*args: Any, **kwargs: Any) -> Any:
        sizes.append(kwargs["read_options"].block_size)
        return open_csv(*args, **kwargs)

    monkeypatch.setattr(pa_csv, "open_csv", spy)
    return sizes


@pytest.mark.parametrize("extra_as_text", [True, False])
def test_block_does_not_grow_with_the_chunk_or_the_columns(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, extra_as_text: bool
) -> None:
    """The reader decodes blocks ahead: a block sized to a 1 M-row chunk of 30 columns
    (480 MB) held gigabytes (sync apply: 3.1 GB where 100 000-row chunks took 1.4)."""
    sizes = _blocks(monkeypatch)
    path = _write(tmp_path / "wide.csv", 50, 26)
    (chunk,) = iter_table_chunks(path, 1_000_000, REQUIRED, extra_as_text=extra_as_text)
    assert len(chunk["t_s"]) == 50
    assert sizes
    assert max(sizes) <= 1 << 24


def test_a_row_longer_than_the_block_is_read_as_before(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A row as long as a chunk's block allowed is still read: the reader starts again,
    past the rows given, with that block."""
    monkeypatch.setattr("kinsync.io.csv_stream.STREAM_BLOCK_BYTES", 1 << 16)
    sizes = _blocks(monkeypatch)
    path = tmp_path / "long.csv"
    n = 20_000
    rows = [f"{i}.5,1,2,3,n{i}" for i in range(n)]
    rows[12_345] = f"12345.5,1,2,3,{'x' * 200_000}"  # beyond the block, within 1 MiB
    path.write_text("t_s,x_m,y_m,z_m,note\n" + "\n".join(rows) + "\n")
    chunks = list(iter_table_chunks(path, 3_000, REQUIRED, extra_as_text=True))
    assert sizes[0] == 1 << 16
    assert sizes[-1] == 1 << 20  # the block 3 000 rows of 5 columns had
    assert [len(c["t_s"]) for c in chunks] == [3_000] * 6 + [2_000]
    t = np.concatenate([c["t_s"] for c in chunks])
    np.testing.assert_array_equal(t, np.arange(n) + 0.5)
    notes = [v for c in chunks for v in c["note"].tolist()]
    assert notes[12_345] == "x" * 200_000
    assert notes[:2] + notes[-1:] == ["n0", "n1", f"n{n - 1}"]


def test_types_are_inferred_from_the_block_a_chunk_had(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A column read as numbers keeps the type inferred from the first block of the
    chunk's size, though pyarrow reads smaller blocks: a 0.5 after 100 000 integers is a
    float column (not 'a column's values change type')."""
    monkeypatch.setattr("kinsync.io.csv_stream.STREAM_BLOCK_BYTES", 1 << 16)
    path = _write(tmp_path / "late.csv", 100_000, 1, tail="100000.5,1,2,3,0.5\n")
    chunks = list(iter_table_chunks(path, 200_000, REQUIRED))
    values = np.concatenate([c["e0"] for c in chunks])
    assert values.dtype == np.float64
    assert values[-2:].tolist() == [7.0, 0.5]
