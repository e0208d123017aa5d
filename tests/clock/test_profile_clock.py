"""The profile clock ``t(n, phi) = t0 + (n + phi / 2 pi) T`` of a profile scanner's mirror."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from kinsync.clock.profile import ProfileClock
from kinsync.errors import InputError

T0_S = 1.4e9 + 0.31
PERIOD_S = 0.0307
CLOCK = ProfileClock(T0_S, PERIOD_S)
NEAR = ProfileClock(1000.0, PERIOD_S)  # small times: differences resolved to 1e-11 s


def test_time_of_a_return_within_its_profile() -> None:
    # A quarter turn of the mirror after the start of profile 10 is a quarter period
    # after it, whichever side of nadir: the angle counts forward in time.
    n = np.array([10, 10, 10, 10, 10])
    phi = np.array([0.0, math.pi / 2, math.pi, -math.pi / 2, 1.0])
    expected = T0_S + PERIOD_S * np.array([10.0, 10.25, 10.5, 9.75, 10.0 + 1.0 / (2 * math.pi)])
    np.testing.assert_allclose(CLOCK.time_s(n, phi), expected, rtol=0, atol=1e-9)


@given(
    n=st.integers(0, 10**6),
    phi=st.floats(-math.pi, math.pi, allow_nan=False),
    dphi=st.floats(1e-3, 3.0),
)
def test_time_runs_forward_with_the_mirror(n: int, phi: float, dphi: float) -> None:
    t = NEAR.time_s(np.array([n, n, n + 1]), np.array([phi, phi + dphi, phi]))
    assert t[1] - t[0] == pytest.approx(dphi / (2 * math.pi) * PERIOD_S, rel=1e-6, abs=1e-9)
    assert t[2] - t[0] == pytest.approx(PERIOD_S, rel=1e-6, abs=1e-9)
    # one more turn of the mirror is the next profile at the same angle (one less, the
    # one before: angles beyond one turn either way are refused)
    k = 1 if phi <= 0.0 else -1
    turn = NEAR.time_s(np.array([n]), np.array([phi + k * 2 * math.pi]))
    same = NEAR.time_s(np.array([n + k]), np.array([phi]))
    assert turn[0] == pytest.approx(same[0], rel=0, abs=1e-8)


def test_shape_follows_the_input() -> None:
    out = CLOCK.time_s(np.zeros((2, 3)), np.zeros((2, 3)))
    assert out.shape == (2, 3)
    assert float(CLOCK.time_s(0, 0.0)) == T0_S


@pytest.mark.parametrize(
    ("t0_s", "period_s", "fragment"),
    [(math.nan, 0.03, "t0_s"), (0.0, 0.0, "period_s"), (0.0, -0.03, "period_s")],
)
def test_bad_clock(t0_s: float, period_s: float, fragment: str) -> None:
    with pytest.raises(InputError, match=fragment):
        ProfileClock(t0_s, period_s)


def test_a_float32_start_time_is_refused() -> None:
    # np.float32(1.4e9 + 0.437) was taken as 1.4e9: t0_s 0.437 s early, silently.
    with pytest.raises(InputError, match=r"^profile clock t0_s: float32 times near 1\.4e\+09 s"):
        ProfileClock(np.float32(1.4e9 + 0.437), PERIOD_S)  # type: ignore[arg-type]
    for bad in (True, 1.4e9 + 1j, "1.4e9"):
        with pytest.raises(InputError, match=r"^profile clock t0_s: expected a number"):
            ProfileClock(bad, PERIOD_S)  # type: ignore[arg-type]
    assert ProfileClock(np.float64(T0_S), PERIOD_S).t0_s == T0_S


@pytest.mark.parametrize("period_s", [30.3, 10.5, 5e-6])
def test_a_period_no_mirror_has_is_refused(period_s: float) -> None:
    # 30.3 (ms given as s) was accepted: every return timed 1000 times too late.
    with pytest.raises(InputError, match=r"^profile clock period_s: .* s is outside 1e-05 to 10 s"):
        ProfileClock(T0_S, period_s)


def test_the_cli_period_span_is_the_clock_s() -> None:
    from kinsync.cli._bounds import OPTION_BOUNDS  # noqa: PLC0415
    from kinsync.clock.profile import PERIOD_SPAN_S  # noqa: PLC0415

    span = OPTION_BOUNDS["--period-s"]
    assert (span.low, span.high) == PERIOD_SPAN_S
