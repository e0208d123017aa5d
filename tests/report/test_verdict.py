"""Verdicts: pass and fail at the tolerance's boundary, with and without σ."""

from __future__ import annotations

import math

import pytest

from kinsync.report.verdict import COVERAGE_FACTOR, Check, Tolerance, count_passed

MS = Tolerance("latency", 1.0, "ms", "abs_at_most", "a reason")
SHARE = Tolerance("share", 95.0, "%", "at_least", "a reason")
COUNT = Tolerance("count", 0.0, "", "at_most", "a reason")
DETECT = Tolerance("detect", 0.01, "", "at_most", "a reason", p_value=True)
NO_ALARM = Tolerance("no alarm", 0.01, "", "at_least", "a reason", p_value=True)


def _check(value: float, sigma: float | None = None, tol: Tolerance = MS) -> Check:
    return Check("error", value, tol, sigma)


def test_the_boundary_itself_passes() -> None:
    assert _check(1.0).passed
    assert _check(-1.0).passed
    assert not _check(math.nextafter(1.0, 2.0)).passed
    assert not _check(-1.0000001).passed


def test_sigma_must_fit_inside_the_tolerance_too() -> None:
    assert COVERAGE_FACTOR == 2.0
    assert _check(0.5, 0.25).passed  # 0.5 + 2 * 0.25 = 1.0: on the boundary
    assert not _check(0.5, 0.2500001).passed
    assert not _check(-0.5, 0.2500001).passed
    assert not _check(0.0, 0.6).passed  # a lucky zero with a large σ is no pass
    assert _check(0.0, 0.5).passed


def test_at_least_and_at_most() -> None:
    assert Check("share", 95.0, SHARE).passed
    assert not Check("share", 94.99, SHARE).passed
    assert Check("share", 97.0, SHARE, sigma=1.0).passed
    assert not Check("share", 97.0, SHARE, sigma=1.01).passed
    assert Check("faults", 0, COUNT).passed
    assert not Check("faults", 1, COUNT).passed


def test_p_value_checks() -> None:
    assert Check("detected", 0.01, DETECT).passed
    assert not Check("detected", 0.0101, DETECT).passed
    assert Check("no false alarm", 0.01, NO_ALARM).passed
    assert not Check("no false alarm", 0.0099, NO_ALARM).passed
    assert Check("detected", 1e-9, DETECT).measured() == "p < 0.001"
    with pytest.raises(ValueError, match="without a σ"):
        Check("detected", 0.001, DETECT, sigma=0.001)


def test_not_a_number_fails() -> None:
    assert not _check(math.nan).passed
    assert not _check(0.1, math.nan).passed
    assert not Check("detected", math.nan, DETECT).passed


def test_sentence_shows_value_sigma_tolerance_and_verdict() -> None:
    c = Check("latency error", 0.00171, MS, 0.01623, detail="truth 4.21 ms")
    assert c.measured() == "0.002 ± 0.016 ms"
    assert c.sentence() == (
        "latency error: 0.002 ± 0.016 ms (truth 4.21 ms); tolerance ±1 ms: PASS."
    )
    assert _check(2.0).sentence().endswith("tolerance ±1 ms: FAIL.")
    assert _check(2.0).verdict == "FAIL"


def test_tolerance_descriptions() -> None:
    assert MS.describe() == "±1 ms"
    assert SHARE.describe() == "≥ 95 %"
    assert COUNT.describe() == "≤ 0"
    assert DETECT.describe() == "p ≤ 0.01"
    assert NO_ALARM.describe() == "p ≥ 0.01"


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"bound": "below"}, "bound must be one of"),
        ({"limit": math.inf}, "finite"),
        ({"why": " "}, "reason"),
        ({"limit": 2.0, "p_value": True}, r"\[0, 1\]"),
    ],
)
def test_bad_tolerances_are_refused(kwargs: dict[str, object], match: str) -> None:
    fields: dict[str, object] = {
        "name": "n",
        "limit": 1.0,
        "unit": "",
        "bound": "at_most",
        "why": "w",
    }
    fields.update(kwargs)
    with pytest.raises(ValueError, match=match):
        Tolerance(**fields)  # type: ignore[arg-type]


def test_negative_sigma_is_refused() -> None:
    with pytest.raises(ValueError, match="negative"):
        _check(0.0, -1.0)


def test_count_passed() -> None:
    assert count_passed([_check(0.0), _check(2.0), _check(0.5)]) == (2, 3)
    assert count_passed([]) == (0, 0)
