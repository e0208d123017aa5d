"""The lines of a CSV as they are in the file: chosen data rows of a slice, the header."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from kinsync.errors import InputError
from kinsync.io.csv_lines import CsvLineWriter, csv_header_line, csv_slice_lines
from kinsync.io.points import plan_table_slices, read_table_slice

REQUIRED = ("t_s", "x_m", "y_m", "z_m")


def test_rows_come_back_byte_for_byte_with_their_own_line_ends(tmp_path: Path) -> None:
    path = tmp_path / "p.csv"
    lines = [
        b"1300000000.123456789,1.50,+2,-3e0,007\r\n",
        b"\r\n",  # empty lines are not data rows
        b"\n",
        b'1300000001,0.1, 2.0,3,"a,b"\n',
        b"1300000002.000,1,2,3,x\r\n",
        b"1300000003,1,2,3,last",  # no line end
    ]
    path.write_bytes(b"\xef\xbb\xbft_s,x_m,y_m,z_m,code\r\n" + b"".join(lines))
    layout, slices = plan_table_slices(path, 2, REQUIRED)
    assert [s.n_rows for s in slices] == [2, 2]
    assert csv_header_line(path) == b"\xef\xbb\xbft_s,x_m,y_m,z_m,code\r\n"
    first, second = slices
    assert csv_slice_lines(layout, first, np.array([True, True])) == lines[0] + lines[3]
    assert csv_slice_lines(layout, first, np.array([False, True])) == lines[3]
    assert csv_slice_lines(layout, second, np.array([True, False])) == lines[4]
    assert csv_slice_lines(layout, second, np.array([False, True])) == lines[5] + b"\n"
    assert csv_slice_lines(layout, second, np.array([False, False])) == b""
    # the rows given are the rows read
    t = read_table_slice(layout, second)["t_s"]
    assert t.tolist() == [1300000002.0, 1300000003.0]


def test_a_header_without_a_line_end_gets_one(tmp_path: Path) -> None:
    path = tmp_path / "h.csv"
    path.write_bytes(b"t_s,x_m,y_m,z_m")
    assert csv_header_line(path) == b"t_s,x_m,y_m,z_m\n"


def test_a_changed_file_and_a_wrong_mask_are_errors(tmp_path: Path) -> None:
    path = tmp_path / "c.csv"
    path.write_text("t_s,x_m,y_m,z_m\n" + "".join(f"{i},1,2,3\n" for i in range(10)))
    layout, slices = plan_table_slices(path, 4, REQUIRED)
    with pytest.raises(ValueError, match=r"expected shape \(4,\)"):
        csv_slice_lines(layout, slices[0], np.ones(3, dtype=bool))
    path.write_text("t_s,x_m,y_m,z_m\n" + "".join(f"{i},1,2,3,4,5,6,7\n" for i in range(10)))
    with pytest.raises(InputError, match=r"c\.csv: lines 2\.\. hold 2 data rows where 4"):
        csv_slice_lines(layout, slices[0], np.ones(4, dtype=bool))


@pytest.mark.filterwarnings("ignore:.*ends without a line end:kinsync.errors.KinsyncWarning")
@settings(max_examples=60, deadline=None)
@given(
    rows=st.lists(
        st.tuples(
            st.text(alphabet="0123456789.e+- x", min_size=1, max_size=12),
            st.sampled_from([b"\n", b"\r\n", b"\r"]),
            st.booleans(),  # an empty line after it
            st.booleans(),  # chosen
        ),
        min_size=1,
        max_size=40,
    ),
    chunk=st.integers(1, 9),
    end=st.booleans(),
    header_end=st.sampled_from([b"\n", b"\r\n", b"\r"]),
)
def test_chosen_rows_are_the_lines_written(
    tmp_path_factory: pytest.TempPathFactory,
    rows: list[tuple[str, bytes, bool, bool]],
    chunk: int,
    end: bool,
    header_end: bytes,
) -> None:
    """Each chosen row's line with its own line end: LF, CRLF or a CR alone."""
    path = tmp_path_factory.mktemp("lines") / "p.csv"
    body = [f"{i},{cell},1,2,3".encode() for i, (cell, *_) in enumerate(rows)]
    data = b"t_s,code,x_m,y_m,z_m" + header_end
    for i, (line, (_, eol, blank, _)) in enumerate(zip(body, rows, strict=True)):
        last = i == len(rows) - 1
        data += line + (eol if end or not last else b"") + (eol if blank and not last else b"")
    path.write_bytes(data)
    layout, slices = plan_table_slices(path, chunk, ("t_s", "x_m", "y_m", "z_m"))
    got = b""
    for sl in slices:
        chosen = np.array([r[3] for r in rows[sl.first_row : sl.first_row + sl.n_rows]])
        got += csv_slice_lines(layout, sl, chosen)
    want = b"".join(
        line + (eol if end or i < len(rows) - 1 else b"\n")
        for i, (line, (_, eol, _, pick)) in enumerate(zip(body, rows, strict=True))
        if pick
    )
    assert got == want
    assert csv_header_line(path) == b"t_s,code,x_m,y_m,z_m" + header_end


def test_a_cr_only_file_gives_its_lines_with_their_cr(tmp_path: Path) -> None:
    """Old Mac line ends: the header is the first line, not the whole file, and the
    rows come back as they are, so that a rejected file reads like the input."""
    path = tmp_path / "cr.csv"
    path.write_bytes(b"t_s,x_m,y_m,z_m,note\r1,1,2,3,a\r\r2,1,2,3,b\r3,1,2,3,c")
    layout, slices = plan_table_slices(path, 10, REQUIRED)
    assert csv_header_line(path) == b"t_s,x_m,y_m,z_m,note\r"
    assert csv_slice_lines(layout, slices[0], np.array([True, False, True])) == (
        b"1,1,2,3,a\r3,1,2,3,c\n"
    )
    assert csv_slice_lines(layout, slices[0], np.array([False, True, False])) == b"2,1,2,3,b\r"


def test_line_writer_is_atomic(tmp_path: Path) -> None:
    path = tmp_path / "r.csv"
    with CsvLineWriter(path, b"a,b\r\n") as w:
        w.write(b"1,2\r\n")
        w.write(b"3,4\n")
    assert path.read_bytes() == b"a,b\r\n1,2\r\n3,4\n"

    def fail_midway() -> None:
        with CsvLineWriter(tmp_path / "x.csv", b"a\n") as w:
            w.write(b"1\n")
            raise RuntimeError

    with pytest.raises(RuntimeError):
        fail_midway()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.csv"]
    with pytest.raises(InputError, match="outside its 'with' block"):
        CsvLineWriter(tmp_path / "y.csv", b"a\n").write(b"1\n")
