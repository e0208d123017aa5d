"""``--columns`` maps: parsing, and checking against a file's header."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from kinsync.errors import InputError
from kinsync.io.column_map import ColumnMap, parse_column_map

KEYS = ("t_s", "x_m", "y_m", "z_m")


def test_pairs_are_parsed_with_spaces_around_them() -> None:
    m = parse_column_map(" t_s = GPS time , x_m=X", KEYS)
    assert m.pairs == (("t_s", "GPS time"), ("x_m", "X"))
    assert m.file_name("t_s") == "GPS time"
    assert m.file_name("y_m") == "y_m"
    assert m.kinsync_name("X") == "x_m"
    assert m.renames() == (("GPS time", "t_s"), ("X", "x_m"))
    assert m.text() == "t_s=GPS time,x_m=X"


@pytest.mark.parametrize("text", [None, "", "   "])
def test_nothing_given_is_an_empty_map(text: str | None) -> None:
    assert parse_column_map(text, KEYS) == ColumnMap()


@pytest.mark.parametrize(
    ("text", "fragment"),
    [
        ("t_s", "'t_s' is not KINSYNC_NAME=YOUR_COLUMN"),
        ("t_s=", "is not KINSYNC_NAME=YOUR_COLUMN"),
        ("=time", "is not KINSYNC_NAME=YOUR_COLUMN"),
        ("a=b=c", "is not KINSYNC_NAME=YOUR_COLUMN"),
        ("time=t_s", "'time' is not a column kinsync reads here; map one of t_s, x_m"),
        ("t_s=a,t_s=b", "t_s is mapped twice"),
        ("t_s=a,x_m=a", "your column 'a' is given for both t_s and x_m"),
    ],
)
def test_bad_maps_say_what_is_wrong(text: str, fragment: str) -> None:
    with pytest.raises(InputError, match="--columns") as info:
        parse_column_map(text, KEYS)
    assert fragment in str(info.value)


def test_a_map_is_checked_against_the_file() -> None:
    m = parse_column_map("t_s=time", KEYS)
    m.check_file(Path("p.csv"), ["time", "x_m"])
    with pytest.raises(InputError, match=r"p.csv: --columns maps t_s to column 'time'"):
        m.check_file(Path("p.csv"), ["t", "x_m"])
    with pytest.raises(InputError, match="has a column 't_s' of its own"):
        m.check_file(Path("p.csv"), ["time", "t_s"])


@given(st.lists(st.sampled_from(KEYS), unique=True), st.data())
def test_any_text_of_a_valid_map_parses_back_to_it(keys: list[str], data: st.DataObject) -> None:
    names = data.draw(
        st.lists(
            st.text(st.characters(codec="ascii", exclude_characters=",=\r\n"), min_size=1)
            .map(str.strip)
            .filter(bool),
            min_size=len(keys),
            max_size=len(keys),
            unique=True,
        )
    )
    m = ColumnMap(tuple(zip(keys, names, strict=True)))
    assert parse_column_map(m.text(), KEYS) == m
