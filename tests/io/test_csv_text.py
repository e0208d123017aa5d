"""CSV text: numbers bare, text quoted only when it must be, everything read back exactly."""

from __future__ import annotations

import csv
import io
import math

import numpy as np
import pyarrow as pa
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from kinsync.errors import InputError
from kinsync.io.csv_text import csv_header_bytes, csv_rows_bytes


def _text(table: pa.Table) -> str:
    data: bytes = csv_header_bytes(table.column_names) + csv_rows_bytes(table).to_pybytes()
    return data.decode()


def test_numbers_are_bare_and_text_is_quoted_only_when_needed() -> None:
    table = pa.table(
        {
            "x": np.array([1.0, 0.1, -2.5e-300, np.nan, np.inf]),
            "n": pa.array([1, -2, None, 4, 5], type=pa.int64()),
            "ok": pa.array([True, False, None, True, False]),
            "s": pa.array(["plain", "a,b", 'say "hi"', "two\nlines", None]),
            "f32": np.array([0.5, 1.0, 2.0, 3.0, 4.0], dtype=np.float32),
        }
    )
    assert _text(table).splitlines(keepends=True)[:4] == [
        "x,n,ok,s,f32\n",
        "1.0,1,true,plain,0.5\n",
        '0.1,-2,false,"a,b",1.0\n',
        '-2.5e-300,,,"say ""hi""",2.0\n',
    ]
    rows = list(csv.reader(io.StringIO(_text(table), newline="")))
    assert [r[3] for r in rows[1:]] == ["plain", "a,b", 'say "hi"', "two\nlines", ""]
    assert rows[4][0] == "nan"
    assert rows[5][0] == "inf"


def test_header_names_are_quoted_by_the_same_rule() -> None:
    assert csv_header_bytes(["t_s", "a,b", 'q"']) == b't_s,"a,b","q"""\n'


def test_a_one_column_table_never_writes_an_empty_line() -> None:
    """Readers skip empty lines: an empty value of a lone column is written as ``""``."""
    table = pa.table({"code": pa.array(["", "a", None])})
    assert csv_rows_bytes(table).to_pybytes() == b'""\na\n""\n'
    table = pa.table({"n": pa.array([None, 1], type=pa.int32())})
    assert csv_rows_bytes(table).to_pybytes() == b'""\n1\n'


def test_a_null_float_is_an_empty_field_and_nan_is_nan() -> None:
    """A null read back is a null (an empty cell), a NaN a NaN: they used to both be ``nan``."""
    table = pa.table(
        {
            "f": pa.array([1.0, None, float("nan")]),
            "f32": pa.array([None, 0.5, None], type=pa.float32()),
            "n": pa.array([None, 2, 3], type=pa.int16()),
        }
    )
    assert csv_rows_bytes(table).to_pybytes() == b"1.0,,\n,0.5,2\nnan,,3\n"
    lone = pa.table({"f": pa.array([None, 2.0])})
    assert csv_rows_bytes(lone).to_pybytes() == b'""\n2.0\n'


def test_a_sliced_table_writes_only_its_rows() -> None:
    table = pa.table({"a": [1, 2, 3], "s": ["x", "y", "z"]}).slice(1, 2)
    assert csv_rows_bytes(table).to_pybytes() == b"2,y\n3,z\n"
    assert csv_rows_bytes(table.slice(0, 0)).to_pybytes() == b""


def test_a_column_without_a_text_form_is_an_input_error() -> None:
    table = pa.table({"nested": pa.array([[1, 2], [3]])})
    with pytest.raises(InputError, match="column 'nested': cannot write type list"):
        csv_rows_bytes(table)


@settings(max_examples=60, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.floats(allow_nan=False, width=64),
            st.text(st.characters(codec="utf-8"), max_size=12),
        ),
        min_size=1,
        max_size=20,
    )
)
def test_floats_and_any_text_read_back_exactly(rows: list[tuple[float, str]]) -> None:
    x = np.array([r[0] for r in rows], dtype=np.float64)
    s = [r[1] for r in rows]
    text = _text(pa.table({"x": x, "s": pa.array(s)}))
    back = list(csv.reader(io.StringIO(text, newline="")))
    assert back[0] == ["x", "s"]
    assert [r[1] for r in back[1:]] == s
    got = np.array([float(r[0]) for r in back[1:]])
    assert all("." in r[0] or "e" in r[0] or not math.isfinite(float(r[0])) for r in back[1:])
    np.testing.assert_array_equal(got.view(np.int64), x.view(np.int64))
