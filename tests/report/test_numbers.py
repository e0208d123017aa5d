"""How the report writes p-values and values with their σ."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from kinsync.report.numbers import format_p_value, format_value, plus_minus


@pytest.mark.parametrize(
    ("p", "text"),
    [
        (0.0, "p < 0.001"),
        (1e-12, "p < 0.001"),
        (0.000999, "p < 0.001"),
        (0.001, "p = 0.001"),
        (0.0042, "p = 0.004"),
        (0.0099, "p = 0.010"),
        (0.01, "p = 0.01"),
        (0.0449, "p = 0.04"),
        (0.79, "p = 0.79"),
        (0.99, "p = 0.99"),
        (0.995, "p > 0.99"),
        (1.0, "p > 0.99"),
    ],
)
def test_p_value_is_written_as_a_reader_expects(p: float, text: str) -> None:
    assert format_p_value(p) == text


def test_p_value_without_prefix_keeps_the_bounds() -> None:
    assert format_p_value(1e-9, prefix=False) == "< 0.001"
    assert format_p_value(0.5, prefix=False) == "0.50"
    assert format_p_value(1.0, prefix=False) == "> 0.99"
    assert format_p_value(math.nan, prefix=False) == "n/a"


def test_p_value_not_available() -> None:
    assert format_p_value(math.nan) == "p not available"


@pytest.mark.parametrize("p", [-0.1, 1.5, math.inf])
def test_p_value_outside_0_1_is_refused(p: float) -> None:
    with pytest.raises(ValueError, match=r"\[0, 1\]"):
        format_p_value(p)


@given(st.floats(min_value=0.0, max_value=1.0))
def test_p_value_never_shows_an_exponent(p: float) -> None:
    text = format_p_value(p)
    assert "e" not in text.replace("p ", "")
    assert text.startswith(("p < ", "p = ", "p > "))


def test_value_with_sigma_rounds_to_the_sigmas_second_digit() -> None:
    assert format_value(0.00171, 0.01623, "ms") == "0.002 ± 0.016 ms"
    assert format_value(4.21171, 0.01623, "ms") == "4.212 ± 0.016 ms"
    assert plus_minus(2.009, 0.0431) == "2.009 ± 0.043"


def test_value_without_sigma() -> None:
    assert format_value(8.7354, unit="mm") == "8.74 mm"
    assert format_value(0.02194, unit="mm") == "0.0219 mm"
    assert format_value(193.4, unit="mm") == "193 mm"
    assert format_value(1234.5) == "1234"
    assert format_value(3.0) == "3"
    assert format_value(math.nan, unit="mm") == "not available mm"
