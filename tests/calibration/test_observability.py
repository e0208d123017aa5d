"""Observability rules: near-degenerate pairs, what is held after the solution, words."""

from __future__ import annotations

import numpy as np
import pytest

from kinsync.calibration.observability import (
    UNOBSERVABLE_THRESHOLDS,
    HeldAfterSolution,
    Observability,
    analyse,
    hold_after_solution,
    status_of,
)
from kinsync.calibration.parameters import PARAMETER_NAMES, REPORT_SCALE

YAW, LEVER_X, LEVER_Y, LATENCY = 2, 3, 4, 6


def _pair(rho: float) -> np.ndarray:
    return np.array([[1.0, rho], [rho, 1.0]]) * 1e6


@pytest.mark.parametrize(
    ("rho", "honest", "held"),
    [
        (0.99995, True, ()),  # the jackknife will judge: estimated
        (0.99995, False, (LEVER_Y,)),  # formal sigma only: the correlation decides
        (0.9999999, True, (LEVER_Y,)),  # a true degeneracy either way
        (0.99, False, ()),
    ],
)
def test_a_near_degenerate_pair(rho: float, honest: bool, held: tuple[int, ...]) -> None:
    found = analyse(_pair(rho), np.full(2, 1e6), (YAW, LEVER_Y), honest_sigma=honest)
    assert found.unobservable == held
    if held:  # the lever arm is held, not the boresight (it can be taped)
        (text,) = found.explanation()
        assert "boresight_yaw_deg and lever_y_m cannot be told apart" in text
        assert "lever_y_m held at its prior value" in text
        assert found.advice() == ("lever y: lines in both directions past walls",)


def test_unseen_parameter_is_unobservable() -> None:
    S = np.diag([1e6, 1e-3])
    found = analyse(S, np.array([1e6, 1e6]), (YAW, LATENCY))
    assert found.unobservable == (LATENCY,)
    assert found.explanation() == ("latency_ms is not seen by the data (the features absorb it)",)


def _internal(report: float, index: int) -> float:
    return float(report / REPORT_SCALE[index])


def test_hold_after_solution_holds_the_lever_not_the_boresight() -> None:
    # Pitch is too uncertain and moves with lever x (a sphere at one range): lever x,
    # first in HOLD_ORDER, is held; pitch stays, given the prior lever x.
    est = (1, LEVER_X)
    std = np.array([_internal(1.5, 1), _internal(0.05, LEVER_X)])
    cov = np.array([[1.0, 0.98], [0.98, 1.0]])
    held = hold_after_solution(est, std, [False, False], cov)
    assert isinstance(held, HeldAfterSolution)
    assert (held.index, held.cause, held.partners) == (LEVER_X, 1, (1,))
    assert held.std_report == pytest.approx(1.5)
    text = held.explanation()
    assert text.startswith("boresight_pitch_deg is determined only to +-1.5 by these data")
    assert "lever_x_m held at its prior value" in text
    assert "boresight_pitch_deg estimated as if that prior were right" in text
    obs = Observability(est, (), ()).without(held)
    assert obs.estimated == (1,)
    assert obs.held == (LEVER_X,)
    assert set(obs.advice()) == {
        "pitch boresight: a slope, a roof or a wall across the line, in both directions",
        "lever x: two speeds (it moves with the latency) and turns",
    }


def test_hold_after_solution_spares_what_the_data_moved() -> None:
    est = (LATENCY,)
    std = np.array([_internal(2.0 * UNOBSERVABLE_THRESHOLDS[LATENCY], LATENCY)])
    assert hold_after_solution(est, std, [True], np.eye(1)) is None
    held = hold_after_solution(est, std, [False], np.eye(1))
    assert isinstance(held, HeldAfterSolution)
    assert held.index == held.cause == LATENCY
    assert held.explanation().endswith("(more than 10): held at its prior value")
    within = np.array([_internal(0.5 * UNOBSERVABLE_THRESHOLDS[LATENCY], LATENCY)])
    assert hold_after_solution(est, within, [False], np.eye(1)) is None


def test_weak_threshold() -> None:
    assert status_of(PARAMETER_NAMES.index("latency_ms"), 0.9) == "estimated"
    assert status_of(PARAMETER_NAMES.index("latency_ms"), 1.1) == "weak"
    assert status_of(0, float("nan")) == "weak"
