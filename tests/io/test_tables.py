"""Numeric CSV reader/writer and atomic writes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from kinsync.errors import InputError
from kinsync.io.atomic import atomic_path, atomic_write_text
from kinsync.io.nav_csv import read_navigation
from kinsync.io.tables import read_csv_rows, read_numeric_csv, write_numeric_csv

finite = st.floats(allow_nan=False, allow_infinity=False, width=64)


@settings(max_examples=50, deadline=None)
@given(st.lists(st.tuples(finite, finite), min_size=1, max_size=20))
def test_round_trip_is_exact(
    tmp_path_factory: pytest.TempPathFactory, rows: list[tuple[float, float]]
) -> None:
    path = tmp_path_factory.mktemp("csv") / "t.csv"
    a = np.array([r[0] for r in rows])
    b = np.array([r[1] for r in rows])
    write_numeric_csv(path, {"a_m": a, "b_s": b})
    table = read_numeric_csv(path, ["a_m", "b_s"])
    np.testing.assert_array_equal(table.columns["a_m"], a)
    np.testing.assert_array_equal(table.columns["b_s"], b)
    assert table.n_rows == len(rows)


@pytest.mark.parametrize(
    ("text", "fragment"),
    [
        ("", "empty file"),
        ("a,b\n1,2\n", "missing column"),
        ("t_s,t_s\n1,2\n", "duplicated"),
        ("t_s,x\n1,2\n3,oops\n", "line 3, column 'x'"),
        ("t_s,x\n1,2\n3\n", "line 3 has 1 fields"),
        # Python's float() reads these, the CSV parser does not: no line was named
        ("t_s,x\n1,2\n1_000,3\n", r"line 3, column 't_s': '1_000' is not a plain number"),
        ("t_s,x\n1,2\n3,\u0661\u0662\n", r"line 3, column 'x': '\u0661\u0662' is not a plain"),
        ("t_s,x\n1,2\n3,\uff14\n", r"line 3, column 'x': '\uff14' is not a plain number"),
    ],
)
def test_bad_tables(tmp_path: Path, text: str, fragment: str) -> None:
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(InputError, match=fragment) as exc:
        read_numeric_csv(path, ["t_s"], ["x"])
    assert str(path) in str(exc.value)


def test_a_text_column_beside_the_numbers_is_left_out_not_refused(tmp_path: Path) -> None:
    """An IMU file with a `note` column was refused ("'x' is not a number") where one
    with a `temp_c` column was read: a column the reader does not use is no error."""
    path = tmp_path / "t.csv"
    path.write_bytes(b't_s,note,x,temp_c,flag\n1,ok,2,20,1\n3,"a, b",4,21,\n5,\xe9t\xe9,6,22.5,0\n')
    table = read_numeric_csv(path, ["t_s"], ["x"])
    assert table.header == ("t_s", "note", "x", "temp_c", "flag")
    assert list(table.columns) == ["t_s", "x", "temp_c"]  # numbers only: kept
    np.testing.assert_array_equal(table.columns["x"], [2.0, 4.0, 6.0])
    np.testing.assert_array_equal(table.columns["temp_c"], [20.0, 21.0, 22.5])
    with pytest.raises(InputError, match=r"line 2, column 'note': 'ok' is not a number"):
        read_numeric_csv(path, ["t_s", "note"])  # a column asked for must hold numbers
    path.write_bytes(b"t_s,note,x\n1,ok,2\n3,no,4,5\n")
    with pytest.raises(InputError, match="line 3 has 4 fields, the header has 3"):
        read_numeric_csv(path, ["t_s"])


def test_a_table_with_cr_line_ends_longer_than_the_probe_is_read(tmp_path: Path) -> None:
    """Old Mac line ends: the header ends at its CR, not "a first line longer than 64 KiB"."""
    path = tmp_path / "cr.csv"
    n = 10_000  # about 130 KiB: beyond the 64 KiB a reader probes for the header's end
    path.write_bytes(b"t_s,x\r" + b"".join(b"%d.5,%d\r" % (i, i) for i in range(n)))
    table = read_numeric_csv(path, ["t_s"])
    assert table.n_rows == n
    np.testing.assert_array_equal(table.columns["x"], np.arange(n))


@pytest.mark.parametrize("line", [1, 6, 191])
def test_a_byte_that_is_not_utf8_is_named_by_its_own_line(tmp_path: Path, line: int) -> None:
    """Within the first 8 KiB it was blamed on the header ("cannot read the header")."""
    names = b"t_s,lat_deg,lon_deg,h_m,roll_deg,pitch_deg,yaw_deg"
    rows = [names] + [b"%d.5,46.8,-71.2,10,0,0,%d" % (i, i) for i in range(300)]
    rows[line - 1] += b"\xe9"
    path = tmp_path / "u.csv"
    path.write_bytes(b"\n".join(rows) + b"\n")
    where = f"u.csv: line {line}: byte 0xE9 is not UTF-8 text"
    with pytest.raises(InputError, match=where):
        read_numeric_csv(path, ["t_s"], names.decode().split(","))
    with pytest.raises(InputError, match=where):
        read_navigation(path)
    with pytest.raises(InputError, match=where):
        read_csv_rows(path)


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="not found"):
        read_numeric_csv(tmp_path / "none.csv", ["t_s"])


def test_atomic_write_leaves_nothing_on_failure(tmp_path: Path) -> None:
    target = tmp_path / "out.txt"

    def fail_midway() -> None:
        with atomic_path(target) as tmp:
            tmp.write_text("partial")
            raise RuntimeError

    with pytest.raises(RuntimeError):
        fail_midway()
    assert not target.exists()
    assert list(tmp_path.iterdir()) == []
    atomic_write_text(target, "done")
    assert target.read_text() == "done"
    assert oct(target.stat().st_mode & 0o777) != oct(0o600)


def test_atomic_write_needs_an_existing_folder(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="does not exist"):
        atomic_write_text(tmp_path / "no" / "x.txt", "x")
