"""Error messages show values as a user writes them (class 6 of issue 15)."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from kinsync.errors import InputError, KinsyncError, OutsideSpanError, plain_values


def test_numpy_scalar_reprs_become_plain_values() -> None:
    t = np.array([0.0, 1479384017.6300004, np.nan, -np.inf])
    err = InputError(
        f"line 3: repeated time t_s={t[0]!r}; {t[1]!r} after {t[1]!r}; {t[2]!r} {t[3]!r}; "
        f"{np.int64(7)!r} {np.uint8(3)!r} {np.float32(2.5)!r} {np.bool_(0)!r} "
        f"{np.str_('std_n_m')!r} (use nan)"
    )
    assert str(err) == (
        "line 3: repeated time t_s=0.0; 1479384017.6300004 after 1479384017.6300004; nan "
        "-inf; 7 3 2.5 False 'std_n_m' (use nan)"
    )


@pytest.mark.parametrize("cls", [KinsyncError, InputError, OutsideSpanError])
def test_every_error_class_and_a_pickled_copy_keep_the_plain_message(
    cls: type[KinsyncError],
) -> None:
    err = cls(f"value {np.float64(1.5)!r}")
    assert str(err) == "value 1.5"
    assert str(pickle.loads(pickle.dumps(err))) == "value 1.5"  # pool workers send errors


@given(st.text())
def test_text_without_numpy_reprs_is_unchanged(text: str) -> None:
    if "np." not in text:
        assert plain_values(text) == text


@given(st.floats())
def test_any_float64_repr_reads_back_as_the_same_value(value: float) -> None:
    shown = plain_values(repr(np.float64(value)))
    assert "np." not in shown
    assert np.array_equal(np.float64(shown), np.float64(value), equal_nan=True)


def test_a_quoted_cell_of_the_users_file_is_shown_as_written() -> None:
    # A cell holding the text np.float64(...) was shown as its number.
    cell = "np.float64(1418472013.2477386)"
    err = InputError(f"pts.csv: line 3, column 't_s': {cell!r} is not a number")
    assert str(err) == f"pts.csv: line 3, column 't_s': '{cell}' is not a number"
    mixed = InputError(f"the file's value {np.float64(1.5)!r} and {cell!r} at {np.int64(2)!r}")
    assert str(mixed) == f"the file's value 1.5 and '{cell}' at 2"
