"""`ObjectSpaceConfig` refuses, from Python, what ``kinsync sync object-space`` refuses."""

from __future__ import annotations

import pytest

from kinsync.cli._bounds import bounds_for
from kinsync.errors import InputError
from kinsync.sync import ObjectSpaceConfig
from kinsync.sync.config import (
    INTENSITY_THRESHOLD_SPAN,
    MAX_RANGE_SPAN_M,
    PERIOD_PRIOR_SPAN_S,
    PERIOD_TOLERANCE_SPAN,
    POSITION_CORR_TIME_SPAN_S,
    POSITION_STD_SPAN_M,
)

SPANS = {
    "period_prior_s": ("--period-prior-s", PERIOD_PRIOR_SPAN_S),
    "period_tolerance": ("--period-tolerance", PERIOD_TOLERANCE_SPAN),
    "intensity_threshold": ("--intensity-threshold", INTENSITY_THRESHOLD_SPAN),
    "max_range_m": ("--max-range-m", MAX_RANGE_SPAN_M),
    "position_std_m": ("--position-std-m", POSITION_STD_SPAN_M),
    "position_corr_time_s": ("--position-corr-time-s", POSITION_CORR_TIME_SPAN_S),
}


@pytest.mark.parametrize("field", sorted(SPANS))
def test_the_cli_spans_are_the_config_s(field: str) -> None:
    option, span = SPANS[field]
    bounds = bounds_for("sync object-space", option)
    assert bounds is not None
    assert (bounds.low, bounds.high) == span


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("period_prior_s", 1e-6),
        ("period_prior_s", 101.0),
        ("intensity_threshold", 1e13),
        ("intensity_threshold", -1e13),
        ("max_range_m", 0.05),
        ("max_range_m", 20_000.0),
        ("position_std_m", 1_000.0),
        ("position_std_m", -0.1),
        ("position_corr_time_s", 2e6),
        ("position_corr_time_s", -1.0),
    ],
)
def test_a_value_outside_the_cli_span_is_refused_from_python(field: str, value: float) -> None:
    """These went through to the search, which the program would never have run."""
    option, (low, high) = SPANS[field]
    with pytest.raises(InputError) as info:
        ObjectSpaceConfig(**{field: value})  # type: ignore[arg-type]
    msg = str(info.value)
    assert msg.startswith(f"{field} ({option}) {value:g}")
    assert f"outside the span kinsync accepts, {low:g} to {high:g}" in msg


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("period_prior_s", PERIOD_PRIOR_SPAN_S[0]),
        ("period_prior_s", 30.3),  # milliseconds: the search suggests the period
        ("period_prior_s", PERIOD_PRIOR_SPAN_S[1]),
        ("intensity_threshold", INTENSITY_THRESHOLD_SPAN[0]),
        ("max_range_m", MAX_RANGE_SPAN_M[1]),
        ("position_std_m", 0.0),
        ("position_std_m", POSITION_STD_SPAN_M[1]),
        ("position_corr_time_s", 0.0),
        ("position_corr_time_s", POSITION_CORR_TIME_SPAN_S[1]),
    ],
)
def test_a_value_within_the_span_is_accepted(field: str, value: float) -> None:
    assert getattr(ObjectSpaceConfig(**{field: value}), field) == value  # type: ignore[arg-type]


@pytest.mark.parametrize("tolerance", [PERIOD_TOLERANCE_SPAN[0], PERIOD_TOLERANCE_SPAN[1]])
def test_the_period_tolerance_span_is_open(tolerance: float) -> None:
    with pytest.raises(InputError, match=r"^period_tolerance \(--period-tolerance\) "):
        ObjectSpaceConfig(period_tolerance=tolerance)
