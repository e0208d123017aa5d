"""A row of empty cells (``,,,,`` as Excel writes an empty row), or a line of spaces or a
tab, is named by its line: the numeric CSV tables said only "cannot read as a numeric CSV
table" (their search for the bad cell skipped such rows, the parser did not)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from kinsync.errors import InputError
from kinsync.io.clock_model import read_pps_csv
from kinsync.io.points import iter_table_chunks
from kinsync.io.tables import read_numeric_csv

HEADER = "t_s,x_m,y_m\n"
ROWS = ["1.0,2.0,3.0\n", "2.0,2.0,3.0\n", "3.0,2.0,3.0\n"]


@pytest.mark.parametrize(
    ("blank", "words"),
    [
        (",,\n", r"a row of empty cells \(only commas"),
        (" , ,\t\n", r"a row of empty cells \(only commas"),
        ("   \n", "only spaces or tabs"),
        ("\t\n", "only spaces or tabs"),
    ],
)
def test_a_row_of_blanks_is_named_by_its_line(tmp_path: Path, blank: str, words: str) -> None:
    path = tmp_path / "t.csv"
    path.write_text(HEADER + ROWS[0] + "\n" + ROWS[1] + blank + ROWS[2], encoding="utf-8")
    with pytest.raises(InputError, match=rf"t\.csv: line 5: {words}.*remove the line"):
        read_numeric_csv(path, ["t_s", "x_m", "y_m"])


def test_a_line_of_spaces_in_a_point_table_is_named_by_its_line(tmp_path: Path) -> None:
    path = tmp_path / "p.csv"
    path.write_text(HEADER + ROWS[0] + "  \n" + ROWS[1], encoding="utf-8")
    with pytest.raises(InputError, match=r"p\.csv: line 3: only spaces or tabs"):
        list(iter_table_chunks(path, 10, ("t_s", "x_m", "y_m")))


def test_a_blank_row_of_a_one_column_pps_log_is_named(tmp_path: Path) -> None:
    path = tmp_path / "pps.csv"
    path.write_text("t_local_s\n1000.0\n \n1001.0\n", encoding="utf-8")
    with pytest.raises(InputError, match=r"pps\.csv: line 3: only spaces or tabs"):
        read_pps_csv(path)


def test_an_empty_line_is_still_skipped(tmp_path: Path) -> None:
    path = tmp_path / "t.csv"
    path.write_text(HEADER + ROWS[0] + "\n\r\n" + ROWS[1], encoding="utf-8")
    table = read_numeric_csv(path, ["t_s", "x_m", "y_m"])
    np.testing.assert_array_equal(table.columns["t_s"], [1.0, 2.0])


@pytest.mark.parametrize("comment", ["# logger restarted\n", "// note, here\n", "; 2026-11-28\n"])
def test_a_comment_line_in_data_is_named_as_such(tmp_path: Path, comment: str) -> None:
    """It gave "line 3 has 1 fields, the header has 3" and nothing to do."""
    path = tmp_path / "t.csv"
    path.write_text(HEADER + ROWS[0] + comment + ROWS[1], encoding="utf-8")
    with pytest.raises(InputError, match=r"t\.csv: line 3 .*looks like a comment.*remove the line"):
        read_numeric_csv(path, ["t_s", "x_m", "y_m"])
    with pytest.raises(InputError, match=r"line 3.*looks like a comment"):
        list(iter_table_chunks(path, 10, ("t_s", "x_m", "y_m")))


def test_numbers_with_a_decimal_comma_are_named_as_such(tmp_path: Path) -> None:
    """A spreadsheet set to a decimal comma, exporting a one-column log or a point table
    with commas between the columns: "line 2 has 2 fields, the header has 1" and nothing
    to do."""
    pps = tmp_path / "pps.csv"
    pps.write_text("t_local_s\n1479384017,6300004\n1479384018,6299758\n", encoding="utf-8")
    with pytest.raises(InputError, match=r"pps\.csv: line 2 .*decimal comma\?.*with points"):
        read_pps_csv(pps)
    path = tmp_path / "t.csv"
    path.write_text(HEADER + "1,0,2,5,-3,25\n", encoding="utf-8")
    with pytest.raises(InputError, match=r"t\.csv: line 2 .*decimal comma\?"):
        read_numeric_csv(path, ["t_s", "x_m", "y_m"])
    with pytest.raises(InputError, match=r"line 2.*decimal comma\?"):
        list(iter_table_chunks(path, 10, ("t_s", "x_m", "y_m")))


def test_a_comma_too_many_is_not_called_a_decimal_comma(tmp_path: Path) -> None:
    path = tmp_path / "t.csv"
    path.write_text(HEADER + "1.0,2.0,3.0,\n" + "1.0,2.5,3\n", encoding="utf-8")
    with pytest.raises(InputError, match=r"line 2 has 4 fields") as exc:
        read_numeric_csv(path, ["t_s", "x_m", "y_m"])
    assert "decimal comma" not in str(exc.value)


@pytest.mark.parametrize("stamp", ["2024-05-17T16:53:02Z", "2024-05-17 16:53:02.5"])
def test_a_date_and_time_as_text_is_named_with_what_to_do(tmp_path: Path, stamp: str) -> None:
    """ISO-8601 times said only "is not a number" (and "fix or remove the row", for a
    whole column of them)."""
    path = tmp_path / "t.csv"
    path.write_text(HEADER + f"{stamp},2.0,3.0\n", encoding="utf-8")
    words = r"t\.csv: line 2, column 't_s': .* is a date and time as text.*convert the whole"
    with pytest.raises(InputError, match=words) as err:
        read_numeric_csv(path, ["t_s", "x_m", "y_m"])
    assert "utc_to_gps_s" in str(err.value)
    with pytest.raises(InputError, match=words) as err:
        list(iter_table_chunks(path, 10, ("t_s", "x_m", "y_m")))
    assert "fix or remove the row" not in str(err.value)
    pps = tmp_path / "pps.csv"
    pps.write_text(f"t_local_s\n{stamp}\n", encoding="utf-8")
    with pytest.raises(InputError, match=r"pps\.csv: line 2.*a date and time as text"):
        read_pps_csv(pps)
    # a word is still "not a number", with the row to fix
    path.write_text(HEADER + "soon,2.0,3.0\n", encoding="utf-8")
    with pytest.raises(InputError, match="'soon' is not a number; fix or remove the row"):
        list(iter_table_chunks(path, 10, ("t_s", "x_m", "y_m")))
