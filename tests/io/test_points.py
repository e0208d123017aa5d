"""CSV/Parquet point tables: chunked round trips, dtypes kept, bad input."""

from __future__ import annotations

import re
from collections.abc import Generator
from pathlib import Path
from typing import Any
from unittest import mock

import numpy as np
import pyarrow as pa
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from kinsync.errors import InputError
from kinsync.io import table_writer
from kinsync.io.points import (
    TableChunkWriter,
    count_table_rows,
    csv_text_columns,
    iter_table_chunks,
    plan_table_slices,
    read_table_slice,
)

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
    """A table written ``chunk`` rows at a time, in Parquet row groups of ``chunk`` rows."""
    n = len(cols["t_s"])
    with (
        mock.patch.object(table_writer, "PARQUET_ROW_GROUP_ROWS", chunk),
        TableChunkWriter(path) as w,
    ):
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


def test_parquet_dictionary_encodes_only_the_columns_whose_values_repeat(tmp_path: Path) -> None:
    # A dictionary of distinct floats is filled and thrown away: the writer ran at half speed.
    import pyarrow.parquet as pq  # noqa: PLC0415

    cols = _columns(2500)
    path = tmp_path / "pts.parquet"
    _write(path, cols, 700)
    group = pq.ParquetFile(path).metadata.row_group(0)
    dictionary = {
        group.column(i).path_in_schema
        for i in range(group.num_columns)
        if any("DICTIONARY" in e for e in group.column(i).encodings)
    }
    assert dictionary == {"intensity", "return_number", "label"}  # Parquet has none for bool


def _parquet_in_chunks(path: Path, cols: dict[str, np.ndarray[Any, Any]], cuts: list[int]) -> bytes:
    """A Parquet table written in the chunks that ``cuts`` (row numbers) make."""
    with TableChunkWriter(path, {"z_m": {"unit": "metre"}}, {"crs": "{}"}) as w:
        for a, b in zip([0, *cuts], [*cuts, len(cols["t_s"])], strict=True):
            w.write({k: v[a:b] for k, v in cols.items()})
    return path.read_bytes()


def test_parquet_bytes_do_not_depend_on_the_chunks(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Rows are written in row groups of PARQUET_ROW_GROUP_ROWS whatever the chunks: one
    row group per chunk made --chunk-points change the bytes of georef's outputs."""
    import pyarrow.parquet as pq  # noqa: PLC0415

    cols = _columns(430)
    path = tmp_path / "pts.parquet"
    whole = _parquet_in_chunks(path, cols, [])
    assert _parquet_in_chunks(path, cols, list(range(7, 430, 7))) == whole
    assert pq.ParquetFile(path).metadata.num_row_groups == 1
    monkeypatch.setattr(table_writer, "PARQUET_ROW_GROUP_ROWS", 100)
    whole = _parquet_in_chunks(path, cols, [])
    for cuts in ([33, 33, 66, 66, 250], list(range(7, 430, 7)), [100, 200, 300, 400]):
        assert _parquet_in_chunks(path, cols, cuts) == whole, cuts  # empty chunks too
    meta = pq.ParquetFile(path).metadata
    sizes = [meta.row_group(i).num_rows for i in range(meta.num_row_groups)]
    assert sizes == [100, 100, 100, 100, 30]
    back = pq.read_table(path)
    assert back.schema.field("z_m").metadata == {b"unit": b"metre"}
    np.testing.assert_array_equal(back["label"].to_numpy(), cols["label"])


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_column_and_table_metadata_are_kept_in_parquet(tmp_path: Path, suffix: str) -> None:
    import pyarrow.parquet as pq  # noqa: PLC0415

    cols = _columns(2500)
    path = tmp_path / f"pts{suffix}"
    fields = {"x_m": {"unit": "US survey foot"}, "z_m": {"unit": "metre"}, "absent": {"a": "b"}}
    with TableChunkWriter(path, fields, {"crs": "{}"}) as w:
        for i in range(0, 2500, 700):  # later chunks are cast to the first one's schema
            w.write({k: v[i : i + 700] for k, v in cols.items()})
    chunks = list(iter_table_chunks(path, 1000, REQUIRED))
    np.testing.assert_array_equal(np.concatenate([c["z_m"] for c in chunks]), cols["z_m"])
    if suffix == ".csv":  # a CSV has nowhere to keep it: the header is the plain names
        assert path.read_text().splitlines()[0] == ",".join(cols)
        return
    schema = pq.read_schema(path)
    assert schema.field("x_m").metadata == {b"unit": b"US survey foot"}
    assert schema.field("z_m").metadata == {b"unit": b"metre"}
    assert schema.field("y_m").metadata is None
    assert schema.metadata is not None
    assert schema.metadata[b"crs"] == b"{}"


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
    with pytest.raises(InputError, match=r"bad\.csv: line 3, column 'x_m': 'abc' is not"):
        list(iter_table_chunks(path, 10, REQUIRED))
    path.write_text("t_s,x_m,y_m,z_m\n1,2,3,4\n2,3,,4\n")
    with pytest.raises(InputError, match=r"bad\.csv: line 3, column 'y_m': empty cell"):
        list(iter_table_chunks(path, 10, REQUIRED))


@pytest.mark.parametrize("cell", ["1_000", "\u0661\u0662\u0663", "\uff11\uff12\uff13", "\u00a01.5"])
def test_a_number_python_reads_but_the_csv_parser_does_not_names_its_line(
    tmp_path: Path, cell: str
) -> None:
    # Was "cannot read as CSV (In CSV column #1: Row #3: ...)": the parser's count of
    # non-empty rows (3 here), not the file line (5).
    path = tmp_path / "bad.csv"
    path.write_text(f"t_s,x_m,y_m,z_m\n1,2,3,4\n\n\n2,{cell},3,4\n", encoding="utf-8")
    with pytest.raises(
        InputError, match=r"bad\.csv: line 5, column 'x_m': '.*' is not a plain number"
    ):
        list(iter_table_chunks(path, 10, REQUIRED))
    with pytest.raises(InputError, match=r"bad\.csv: line 5, column 'x_m'"):
        plan_table_slices(path, 10, REQUIRED)


def test_non_numeric_parquet_cell_names_row(tmp_path: Path) -> None:
    path = tmp_path / "bad.parquet"
    cols = {
        "t_s": np.arange(3.0),
        "x_m": np.array(["1", "2", "x"], dtype=object),
        "y_m": np.zeros(3),
        "z_m": np.zeros(3),
    }
    _write(path, cols, 3)
    with pytest.raises(InputError, match=r"bad\.parquet: row 3 of 3, column 'x_m': 'x' is not"):
        list(iter_table_chunks(path, 10, REQUIRED))


def test_float32_times_or_coordinates_in_parquet_are_refused(tmp_path: Path) -> None:
    """float32 times near 1.4e9 s are stored in steps of 128 s (and UTM coordinates of
    0.03 m): they were widened to float64 without a word, every point georeferenced up to
    a minute away from its time. Both readers (chunks and slices) now refuse them."""
    times = 1.4e9 + np.array([10.0, 100.0, 200.0, 290.0])
    good: dict[str, np.ndarray[Any, Any]] = {
        "t_s": times,
        "x_m": np.ones(4, np.float32),
        "y_m": np.zeros(4),
        "z_m": np.zeros(4),
    }
    cases: tuple[tuple[str, np.ndarray[Any, Any], str], ...] = (
        ("t_s", times.astype(np.float32), r"float32 times near 1\.4e\+09 s .* steps of 128 s"),
        ("x_m", np.full(4, 402_133.0, np.float32), r"float32 coordinates near 402133 m"),
    )
    for name, bad, what in cases:
        path = tmp_path / f"f32_{name}.parquet"
        _write(path, good | {name: bad}, 4)
        match = rf"f32_{name}\.parquet: column '{name}': {what}.*write the column as float64"
        with pytest.raises(InputError, match=match):
            list(iter_table_chunks(path, 10, REQUIRED))
        layout, slices = plan_table_slices(path, 10, REQUIRED)
        with pytest.raises(InputError, match=match):
            read_table_slice(layout, slices[0])
    # float32 scanner coordinates near the scanner hold 0.1 mm steps: read as they are
    path = tmp_path / "near.parquet"
    _write(path, good | {"x_m": np.full(4, 12.345, np.float32)}, 4)
    (chunk,) = iter_table_chunks(path, 10, REQUIRED)
    assert chunk["x_m"].dtype == np.float64
    assert chunk["x_m"][0] == np.float32(12.345)


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


# ---------------------------------------------------------------------- slices
def _concat(chunks: list[dict[str, np.ndarray[Any, Any]]]) -> dict[str, list[Any]]:
    return {k: np.concatenate([c[k] for c in chunks]).tolist() for k in chunks[0]}


@pytest.mark.filterwarnings("ignore:.*ends without a line end:kinsync.errors.KinsyncWarning")
@settings(max_examples=60, deadline=None)
@given(
    n_rows=st.integers(1, 40),
    chunk_points=st.integers(1, 12),
    blank_after=st.sets(st.integers(0, 40), max_size=6),
    eol=st.sampled_from(["\n", "\r\n", "\r"]),
    trailing_newline=st.booleans(),
    scan_block=st.sampled_from([5, 64, 1 << 24]),
)
def test_csv_slices_cover_every_row_once_in_exact_chunks(
    tmp_path_factory: pytest.TempPathFactory,
    n_rows: int,
    chunk_points: int,
    blank_after: set[int],
    eol: str,
    trailing_newline: bool,
    scan_block: int,
) -> None:
    """Blank lines, LF, CRLF or CR line ends, no final line end, line ends at any block
    edge: the same rows as a read."""
    lines = ["t_s,x_m,y_m,z_m,label"]
    for i in range(n_rows):
        lines.append(f"{i}.5,{i},{-i},{2 * i},w{i}")
        if i in blank_after:
            lines.append("")
    text = eol.join(lines) + (eol if trailing_newline else "")
    path = tmp_path_factory.mktemp("slices") / "p.csv"
    path.write_bytes(text.encode())
    with pytest.MonkeyPatch.context() as patch:  # newlines at block edges too
        patch.setattr("kinsync.io.points._SCAN_BLOCK_BYTES", scan_block)
        layout, slices = plan_table_slices(path, chunk_points, REQUIRED)
    assert layout.total_rows == n_rows
    sizes = [s.n_rows for s in slices]
    assert sizes[:-1] == [chunk_points] * (len(sizes) - 1)
    assert 0 < sizes[-1] <= chunk_points
    assert [s.first_row for s in slices] == list(range(0, n_rows, chunk_points))
    chunks = [read_table_slice(layout, s) for s in slices]
    expected = _concat(list(iter_table_chunks(path, 1000, REQUIRED)))
    assert _concat(chunks) == expected
    # Each slice starts at a line start (first_line) and its first row is first_row.
    for s in slices:
        lines_here = text[s.byte_start : s.byte_end].split(eol)
        assert text.split(eol)[s.first_line - 1] == lines_here[0]
        assert next(x for x in lines_here if x).startswith(f"{s.first_row}.5,")


@settings(max_examples=80, deadline=None)
@given(
    header_end=st.sampled_from(["\n", "\r\n", "\r"]),
    rows=st.lists(
        st.tuples(st.sampled_from(["\n", "\r\n", "\r"]), st.sampled_from(["", "\n", "\r"])),
        min_size=1,
        max_size=30,
    ),
    chunk_points=st.integers(1, 7),
    scan_block=st.sampled_from([3, 7, 1 << 24]),
)
def test_csv_slices_of_mixed_line_ends_are_the_rows_every_reader_sees(
    tmp_path_factory: pytest.TempPathFactory,
    header_end: str,
    rows: list[tuple[str, str]],
    chunk_points: int,
    scan_block: int,
) -> None:
    """A header ended by CR and rows by LF, CRLF or CR (with blank lines of any kind):
    the slices hold every row once, as pyarrow's and Python's readers count them. The
    slicer once split on LF only: a CR-only file was a header and no data row."""
    text = "t_s,x_m,y_m,z_m,label" + header_end
    for i, (eol, blank) in enumerate(rows):
        text += f"{i}.5,{i},{-i},{2 * i},w{i}" + eol + blank
    path = tmp_path_factory.mktemp("mixed") / "p.csv"
    path.write_bytes(text.encode())
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr("kinsync.io.points._SCAN_BLOCK_BYTES", scan_block)
        layout, slices = plan_table_slices(path, chunk_points, REQUIRED)
    assert layout.total_rows == len(rows)
    assert [s.first_row for s in slices] == list(range(0, len(rows), chunk_points))
    got = _concat([read_table_slice(layout, s) for s in slices])
    assert got["label"] == [f"w{i}" for i in range(len(rows))]
    assert got == _concat(list(iter_table_chunks(path, 1000, REQUIRED)))
    lines = text.splitlines()  # Python's line ends: LF, CRLF, CR
    for s in slices:  # first_line: the file line of the slice's first byte
        assert lines[s.first_line - 1] == text[s.byte_start :].splitlines()[0]


def test_a_csv_with_cr_line_ends_is_read_whole(tmp_path: Path) -> None:
    """Old Mac line ends: every row planned and read, not a header and no data row."""
    path = tmp_path / "cr.csv"
    path.write_bytes(b"time,sx,sy,sz,note\r418472013.0,1,2,3,a\r418472013.1,1,2,3,b\r")
    layout, slices = plan_table_slices(path, 10, ("time", "sx", "sy", "sz"))
    assert layout.total_rows == 2
    assert layout.columns == ("time", "sx", "sy", "sz", "note")
    chunk = read_table_slice(layout, slices[0])
    assert chunk["time"].tolist() == [418472013.0, 418472013.1]
    assert chunk["note"].tolist() == ["a", "b"]


@pytest.mark.parametrize("line", [1, 6, 191])
def test_a_byte_that_is_not_utf8_is_named_by_its_own_line(tmp_path: Path, line: int) -> None:
    """Within the first 8 KiB (the text decoder's first read) it was blamed on the header:
    ``cannot read the header ('utf-8' codec can't decode byte 0xe9 ...)``."""
    rows = [b"t_s,x_m,y_m,z_m,note"] + [b"%d.5,1,2,3,ok" % i for i in range(300)]
    rows[line - 1] += b"caf\xe9"
    path = tmp_path / "u.csv"
    path.write_bytes(b"\n".join(rows) + b"\n")
    where = f"u.csv: line {line}: byte 0xE9 is not UTF-8 text"

    def read_planned() -> None:
        layout, slices = plan_table_slices(path, 100, REQUIRED)
        for sl in slices:
            read_table_slice(layout, sl)

    with pytest.raises(InputError, match=where):
        read_planned()
    with pytest.raises(InputError, match=where):
        list(iter_table_chunks(path, 100, REQUIRED, extra_as_text=True))


def test_csv_slice_errors_name_the_file_line_and_data_row(tmp_path: Path) -> None:
    path = tmp_path / "bad.csv"
    n = 150_000  # the bad rows lie beyond the first (1 MiB) block
    rows = [f"{i},1,2,3" for i in range(n)]
    rows[140_037] = "140037,1,zz,3"
    rows[145_044] = "145044,1,,3"
    path.write_text("t_s,x_m,y_m,z_m\n" + "\n\n".join(rows[:20]) + "\n" + "\n".join(rows[20:]))
    layout, slices = plan_table_slices(path, 5_000, REQUIRED)
    assert [s.n_rows for s in slices] == [5_000] * 30
    read_table_slice(layout, slices[27])
    with pytest.raises(
        InputError, match=r"bad\.csv: line 140058, column 'y_m': 'zz' is not a number"
    ):
        read_table_slice(layout, slices[28])
    with pytest.raises(InputError, match=r"bad\.csv: line 145065, column 'y_m': empty cell"):
        read_table_slice(layout, slices[29])


def test_csv_extra_columns_are_text_in_every_block(tmp_path: Path) -> None:
    """No type is inferred from the first block: a later ``5.5`` or ``007`` is read as
    written (a type fixed from the first rows used to refuse it, or turn 007 into 7)."""
    path = tmp_path / "t.csv"
    n = 120_000  # more than the first (1 MiB) block
    body = "".join(f"{i},0,0,0,{i % 7}\n" for i in range(n))
    path.write_text("t_s,x_m,y_m,z_m,n\n" + body + f"{n},0,0,0,5.5\n{n + 1},0,0,0,007\n")
    layout, slices = plan_table_slices(path, 10_000, REQUIRED)
    assert read_table_slice(layout, slices[0])["n"][:3].tolist() == ["0", "1", "2"]
    assert read_table_slice(layout, slices[-1])["n"][-2:].tolist() == ["5.5", "007"]


def test_changed_file_is_detected(tmp_path: Path) -> None:
    path = tmp_path / "c.csv"
    _write(path, _columns(30), 30)
    layout, slices = plan_table_slices(path, 10, REQUIRED)
    _, fine = plan_table_slices(path, 5, REQUIRED)
    path.write_bytes(path.read_bytes()[: fine[5].byte_start])  # rows 25.. cut off
    read_table_slice(layout, slices[1])
    with pytest.raises(InputError, match=r"c\.csv: lines 22\.\.: 10 rows were planned, 5 read"):
        read_table_slice(layout, slices[2])


def test_parquet_slices_follow_row_groups(tmp_path: Path) -> None:
    cols = _columns(2500)
    path = tmp_path / "p.parquet"
    _write(path, cols, 700)  # row groups 700, 700, 700, 400
    layout, slices = plan_table_slices(path, 1500, REQUIRED)
    assert [(s.row_groups, s.n_rows) for s in slices] == [((0, 1), 1400), ((2, 3), 1100)]
    layout, small = plan_table_slices(path, 300, REQUIRED)  # row groups split in pieces
    assert [s.n_rows for s in small] == [300, 300, 100] * 3 + [300, 100]
    assert {s.skip_rows for s in small} == {0, 300, 600}
    for plan in (slices, small):
        got = _concat([read_table_slice(layout, s) for s in plan])
        assert got == _concat([cols])
    assert layout.total_rows == 2500
    assert layout.schema.field("intensity").type == "int64"


@settings(max_examples=60, deadline=None)
@given(
    values=st.lists(
        st.floats(allow_nan=False, allow_infinity=True, width=64)
        | st.integers(-(2**53), 2**53).map(float),  # integral floats must stay floats
        min_size=1,
        max_size=50,
    )
)
def test_csv_floats_read_back_exactly_and_as_floats(
    tmp_path_factory: pytest.TempPathFactory, values: list[float]
) -> None:
    x = np.array(values, dtype=np.float64)
    n = x.size
    path = tmp_path_factory.mktemp("floats") / "f.csv"
    with TableChunkWriter(path) as w:
        w.write({"t_s": np.zeros(n), "x_m": x, "y_m": x, "z_m": x, "other": x})
    (chunk,) = iter_table_chunks(path, 1000, REQUIRED)
    assert chunk["other"].dtype == np.float64
    np.testing.assert_array_equal(chunk["other"].view(np.int64), x.view(np.int64))


def test_csv_text_columns_give_the_same_file(tmp_path: Path) -> None:
    cols = _columns(3000) | {"refl": np.linspace(0, 1, 3000, dtype=np.float32)}
    cols["x_m"][5] = np.nan
    direct, prepared = tmp_path / "direct.csv", tmp_path / "prepared.csv"
    _write(direct, cols, 1000)
    with TableChunkWriter(prepared) as w:
        for i in range(0, 3000, 1000):
            w.write(csv_text_columns({k: v[i : i + 1000] for k, v in cols.items()}))
    assert prepared.read_bytes() == direct.read_bytes()
    text = direct.read_text()
    assert ",nan," in text
    assert '"' not in text  # numbers are never quoted


def test_csv_text_columns_take_pyarrow_columns_with_nulls(tmp_path: Path) -> None:
    cols = {
        "f": pa.array([0.1, None, 3.0]),
        "chunked": pa.chunked_array([[1.5], [None, 2.0]], type=pa.float32()),
        "n": pa.array([None, 1, 2], type=pa.int32()),
        "s": pa.array(["a", None, "c,d"]),
    }
    direct, prepared = tmp_path / "direct.csv", tmp_path / "prepared.csv"
    with TableChunkWriter(direct) as w:
        w.write(cols)
    with TableChunkWriter(prepared) as w:
        w.write(csv_text_columns(cols))
    assert prepared.read_bytes() == direct.read_bytes()
    assert direct.read_text() == 'f,chunked,n,s\n0.1,1.5,,a\n,,1,\n3.0,2.0,2,"c,d"\n'


def test_parquet_slices_as_arrow_keep_types_and_nulls(tmp_path: Path) -> None:
    """As numpy an integer column with nulls turns into floats, NaN for null."""
    n = 10
    table = pa.table(
        {
            "t_s": np.arange(n, dtype=np.float64),
            "x_m": np.zeros(n),
            "y_m": np.zeros(n),
            "z_m": np.zeros(n),
            "i32": pa.array([None if i % 3 == 0 else i for i in range(n)], type=pa.int32()),
            "big": pa.array([2**62 + i for i in range(n)], type=pa.int64()),
            "ok": pa.array([None, True] * (n // 2)),
            "f32": pa.array([None, 1.5] * (n // 2), type=pa.float32()),
        }
    )
    path = tmp_path / "nulls.parquet"
    with TableChunkWriter(path) as w:
        for i in range(0, n, 4):
            w.write({c: table.column(c).slice(i, 4) for c in table.column_names})
    layout, slices = plan_table_slices(path, 6, REQUIRED)
    parts = [read_table_slice(layout, s, arrow=True) for s in slices]
    for name in ("i32", "big", "ok", "f32"):
        got = pa.chunked_array([c for p in parts for c in p[name].chunks])
        assert got.type == table.schema.field(name).type, name
        assert got.to_pylist() == table.column(name).to_pylist(), name
    assert all(isinstance(p["t_s"], np.ndarray) for p in parts)  # required: float64 numpy
    assert read_table_slice(layout, slices[0])["i32"].dtype == np.float64  # numpy as before


class _ClosingSpy:
    """A pyarrow streaming CSV reader that records whether it was closed."""

    instances: list[_ClosingSpy] = []  # noqa: RUF012 - the test's record

    def __init__(self, reader: Any) -> None:
        self.reader = reader
        self.closed = False
        _ClosingSpy.instances.append(self)

    def __iter__(self) -> Any:
        return iter(self.reader)

    def __getattr__(self, name: str) -> Any:
        return getattr(self.reader, name)

    def close(self) -> None:
        self.closed = True
        self.reader.close()


def test_the_csv_reader_is_closed_when_a_chunk_is_bad(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A bad cell ends the stream with the reader closed: left open, its read-ahead
    threads could abort the process at exit (exit 134 instead of 2)."""
    import pyarrow.csv as pa_csv  # noqa: PLC0415

    from kinsync.io import points  # noqa: PLC0415

    real = pa_csv.open_csv
    _ClosingSpy.instances.clear()
    monkeypatch.setattr(pa_csv, "open_csv", lambda *a, **k: _ClosingSpy(real(*a, **k)))
    rows = [f"{i}.5,1.0,2.0,3.0" for i in range(5000)]
    rows[3500] = "3500.5,1.0,,3.0"
    path = tmp_path / "bad.csv"
    path.write_text("t_s,x_m,y_m,z_m\n" + "\n".join(rows) + "\n")
    chunks = points.iter_table_chunks(path, 1000, ("t_s", "x_m", "y_m", "z_m"))
    with pytest.raises(InputError, match=r"bad\.csv: line 3502, column 'y_m': empty cell"):
        for _ in chunks:
            pass
    assert _ClosingSpy.instances
    assert all(spy.closed for spy in _ClosingSpy.instances)
    # and when the consumer stops early, closing the generator closes the reader
    _ClosingSpy.instances.clear()
    chunks = points.iter_table_chunks(path, 1000, ("t_s", "x_m", "y_m", "z_m"))
    next(chunks)
    assert isinstance(chunks, Generator)
    chunks.close()
    assert [spy.closed for spy in _ClosingSpy.instances] == [True]
    # counting rows closes its reader too
    _ClosingSpy.instances.clear()
    assert points.count_table_rows(path) == 5000
    assert [spy.closed for spy in _ClosingSpy.instances] == [True]


def test_planning_a_csv_opens_no_streaming_reader(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Georeferencing plans a CSV from its first block read into memory: no reader with
    read-ahead threads is left behind when the first chunk then fails (exit 134)."""
    import pyarrow.csv as pa_csv  # noqa: PLC0415

    from kinsync.io import points  # noqa: PLC0415

    opened: list[object] = []
    monkeypatch.setattr(pa_csv, "open_csv", lambda *a, **k: opened.append((a, k)))
    rows = [f"{i}.5,1.0,2.0,3.0,x{i}" for i in range(100_000)]
    rows[13] = "13.5,1.0,,3.0,y"
    path = tmp_path / "bad.csv"
    path.write_text("t_s,x_m,y_m,z_m,label\n" + "\n".join(rows) + "\n")
    layout, slices = points.plan_table_slices(path, 1000, ("t_s", "x_m", "y_m", "z_m"))
    assert opened == []
    assert layout.total_rows == 100_000
    assert layout.inferred.field("label").type == pa.string()
    with pytest.raises(InputError, match=r"bad\.csv: line 15, column 'y_m': empty cell"):
        points.read_table_slice(layout, slices[0])


@pytest.mark.parametrize("bad_row", [21, 90_000])
def test_a_row_with_another_field_count_is_named_by_line(tmp_path: Path, bad_row: int) -> None:
    """In the first block (read when planning) or in a later slice, and when streaming."""
    from kinsync.io import points  # noqa: PLC0415

    rows = [f"{i}.5,1.0,2.0,3.0,x{i}" for i in range(100_000)]
    rows[bad_row] += ",7"
    path = tmp_path / "extra.csv"
    path.write_text("t_s,x_m,y_m,z_m,label\n" + "\n".join(rows) + "\n")
    required = ("t_s", "x_m", "y_m", "z_m")
    where = f"extra.csv: line {bad_row + 2}: 6 field(s) where the header has 5"

    def read_planned() -> None:
        layout, slices = points.plan_table_slices(path, 10_000, required)
        for sl in slices:
            points.read_table_slice(layout, sl)

    with pytest.raises(InputError, match=re.escape(where)):
        read_planned()
    with pytest.raises(InputError, match=re.escape(where)):
        list(points.iter_table_chunks(path, 10_000, required))


def test_parquet_errors_name_the_row_from_one_of_all(tmp_path: Path) -> None:
    """A null past the first chunk and row group is named ``row N of M``, counted from 1
    in the whole file (it was ``data row 7``, 0-based, users looked one row too early)."""
    import pyarrow.parquet as pq  # noqa: PLC0415

    x = pa.array([1.0] * 7 + [None] + [1.0] * 2)
    table = pa.table({"t_s": np.arange(10.0), "x_m": x, "y_m": np.ones(10), "z_m": np.ones(10)})
    path = tmp_path / "holed.parquet"
    pq.write_table(table, path, row_group_size=3)
    want = r"holed\.parquet: row 8 of 10, column 'x_m': no value \(null\)"
    with pytest.raises(InputError, match=want):
        list(iter_table_chunks(path, 4, REQUIRED))
    layout, slices = plan_table_slices(path, 4, REQUIRED)
    assert slices[2].first_row == 6  # the null lies in the third slice, past the first
    with pytest.raises(InputError, match=want):
        read_table_slice(layout, slices[2])
    pq.write_table(table.slice(0, 8), path, row_group_size=3)  # the last row
    with pytest.raises(InputError, match=r"row 8 of 8, column 'x_m'"):
        list(iter_table_chunks(path, 4, REQUIRED))


@pytest.mark.parametrize("eol", ["\n", "\r\n"])
def test_csv_errors_name_the_file_line_past_blank_lines_and_chunks(
    tmp_path: Path, eol: str
) -> None:
    """An empty cell in a later chunk, after empty lines, is named by its file line."""
    rows = [f"{i}.5,1,2,3" for i in range(30)]
    rows[24] = "24.5,1,,3"  # data row 24 (0-based); blank lines before it push it down
    body = eol.join(rows[:10]) + eol + eol + eol + eol.join(rows[10:]) + eol
    path = tmp_path / "gaps.csv"
    path.write_bytes(("t_s,x_m,y_m,z_m" + eol + body).encode())
    want = r"gaps\.csv: line 28, column 'y_m': empty cell"  # 24 + header + 2 blank + 1
    assert path.read_bytes().split(eol.encode())[27].startswith(b"24.5,1,,3")
    with pytest.raises(InputError, match=want):
        list(iter_table_chunks(path, 7, REQUIRED))
    layout, slices = plan_table_slices(path, 7, REQUIRED)
    with pytest.raises(InputError, match=want):
        read_table_slice(layout, slices[3])


@pytest.mark.parametrize("eol", ["\n", "\r\n", "\r"])
@pytest.mark.parametrize("chunk_points", [4, 1000])
@pytest.mark.parametrize("scan_block", [5, 1 << 24])
def test_a_quoted_line_break_is_refused_naming_its_first_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, eol: str, chunk_points: int, scan_block: int
) -> None:
    """Planned slices cut the file's lines: a value holding a line break gave "rows were
    planned, ... read back" for a whole slice, or, cut between two slices, "5 field(s)
    where the header has 6" for its second half. Now the first such line is named before
    any slice is read; a quote inside an unquoted value (12") is no line break."""
    rows = [f'{i}.5,1,2,3,"a ""q"", b",{i}"' if i % 3 else f"{i}.5,1,2,3,x,{i}" for i in range(30)]
    rows[7] = '7.5,1,2,3,"two' + eol + 'lines",7'  # the value's first half: file line 9
    rows[20] = '20.5,1,2,3,"three' + eol + eol + 'lines",20'
    path = tmp_path / "broken.csv"
    path.write_bytes(eol.join(["t_s,x_m,y_m,z_m,note,size", *rows, ""]).encode())
    monkeypatch.setattr("kinsync.io.points._SCAN_BLOCK_BYTES", scan_block)
    want = (
        "broken.csv: line 9: a quoted value holds a line break (the line ends inside quotes), "
        "which kinsync does not read; remove the line breaks from the values, or close the quote"
    )
    with pytest.raises(InputError, match=re.escape(want)):
        plan_table_slices(path, chunk_points, REQUIRED)
    rows[7] = '7.5,1,2,3,"one line",7'
    rows[20] = "20.5,1,2,3,x,20"
    path.write_bytes(eol.join(["t_s,x_m,y_m,z_m,note,size", *rows, ""]).encode())
    layout, slices = plan_table_slices(path, chunk_points, REQUIRED)
    got = _concat([read_table_slice(layout, sl) for sl in slices])
    assert list(got["size"]) == [row.rsplit(",", 1)[1] for row in rows]


def test_csv_line_of_row_counts_non_empty_lines_across_blocks(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from kinsync.io import row_position  # noqa: PLC0415

    path = tmp_path / "l.csv"
    cases = {
        b"h\n1\n2\n": [2, 3, None],
        b"h\n1\n\n2": [2, 4, None],
        b"h\r\n1\r\n\r\n2\r\n": [2, 4, None],
        b"h\n\n\n1\n2\n\n": [4, 5, None],
    }
    for block in (1 << 24, 1, 2):
        monkeypatch.setattr(row_position, "_BLOCK_BYTES", block)
        for data, lines in cases.items():
            path.write_bytes(data)
            assert [row_position.csv_line_of_row(path, r) for r in range(3)] == lines, data
    assert row_position.point_position(tmp_path / "p.parquet", 1, 2) == "row 2 of 2"
    assert row_position.point_position(tmp_path / "p.laz", 0, 9) == "point 1 of 9"


def test_a_damaged_parquet_data_page_is_named(tmp_path: Path) -> None:
    """A damaged page read as an internal error (OSError: Corrupt snappy compressed data)."""
    import pyarrow.parquet as pq  # noqa: PLC0415

    path = tmp_path / "p.parquet"
    n = 5000
    cols = {"t_s": np.arange(n) % 7 * 1.0, "x": np.arange(n) % 5 * 1.0}
    pq.write_table(pa.table(cols), path, compression="snappy", use_dictionary=False)
    data = bytearray(path.read_bytes())
    data[40:60] = b"\xff" * 20  # the first page, well before the footer
    path.write_bytes(bytes(data))
    with pytest.raises(InputError, match=r"p\.parquet: the Parquet data is damaged \(.*\); copy"):
        list(iter_table_chunks(path, 1000, ("t_s", "x")))


def test_planning_a_file_of_inch_marks_is_linear_in_its_lines(tmp_path: Path) -> None:
    """Every line with an unquoted inch mark (``12"``) was checked by scanning the rest of
    its block again and reopening the file to read it: 80,000 such lines took 15 s to
    plan (0.05 s before the quoted-line-break check). Counted, not timed: the lines are
    read from the block in memory, the file opened once."""
    path = tmp_path / "inches.csv"
    rows = "".join(f'{i}.0,1.0,2.0,3.0,pipe 12"\n' for i in range(3000))
    path.write_text("t_s,x_m,y_m,z_m,label\n" + rows, encoding="utf-8")
    opened: list[Path] = []
    real_open = Path.open

    def counted(self: Path, *args: Any, **kwargs: Any) -> Any:
        opened.append(self)
        return real_open(self, *args, **kwargs)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(Path, "open", counted)
        plan = plan_table_slices(path, required=REQUIRED, chunk_points=1000)
    assert sum(p == path for p in opened) <= 10  # header, schema, the scan: not per line
    assert plan is not None
