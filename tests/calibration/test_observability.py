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


def test_a_cause_held_after_its_partner_is_told_once_and_never_as_estimated() -> None:
    """A yaw 45 deg off: pitch (+-13.3) could not be told apart from the latency, which was
    held, then pitch itself (+-13.2). It read "... latency_ms held at its prior value;
    boresight_roll_deg and boresight_pitch_deg estimated as if that prior were right",
    then pitch again, held: twice, and once called estimated while held."""
    roll, pitch = 0, 1
    first = HeldAfterSolution(LATENCY, pitch, 13.3, (roll, pitch))
    then = HeldAfterSolution(pitch, pitch, 13.2, (roll,))
    obs = Observability((roll, pitch, LATENCY), (), ()).without(first).without(then)
    assert obs.estimated == (roll,)
    want = (
        "boresight_pitch_deg is determined only to +-13.2 by these data (more than 1), even "
        "with latency_ms held at its prior value (the two cannot be told apart): both held at "
        "their prior values; boresight_roll_deg estimated as if those priors were right"
    )
    assert obs.explanation() == (want,)


def test_a_partner_held_later_is_not_said_to_be_estimated() -> None:
    pitch = 1
    first = HeldAfterSolution(LEVER_X, pitch, 1.5, (pitch, YAW))
    then = HeldAfterSolution(YAW, YAW, 3.0)
    obs = Observability((pitch, YAW, LEVER_X), (), ()).without(first).without(then)
    text = obs.explanation()
    assert len(text) == 2
    assert text[0].endswith(
        "lever_x_m held at its prior value; boresight_pitch_deg estimated as if that prior "
        "were right"
    )
    assert text[1] == (
        "boresight_yaw_deg is determined only to +-3 by these data (more than 1): held at its "
        "prior value"
    )


def test_a_null_direction_partner_held_later_is_not_said_to_be_estimated() -> None:
    direction = ((LEVER_X, 0.7), (LATENCY, 0.7))
    later = HeldAfterSolution(LEVER_X, LEVER_X, 0.5)
    obs = Observability((LEVER_X, YAW), (LATENCY,), (direction,)).without(later)
    assert obs.explanation()[0] == (
        "lever_x_m and latency_ms cannot be told apart by these data: latency_ms held at its "
        "prior value"
    )


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


def test_a_boresight_near_90_deg_pitch_is_warned_about() -> None:
    """At a boresight pitch of 90 deg the same data gave roll and yaw σ of 2 deg
    (`weak`) where the frame turned away from 90 deg gave 0.018 deg (`estimated`)."""
    from kinsync.calibration.parameters import gimbal_lock_warning  # noqa: PLC0415

    assert gimbal_lock_warning(0.0) is None
    assert gimbal_lock_warning(-80.0) is None
    # (180, -150, 210) is the rotation (0, -30, 30), 60 deg from gimbal lock: it was
    # warned about by its pitch's size; (180, 95, 180) is (0, 85, 0), near it.
    assert gimbal_lock_warning(-149.63) is None
    assert gimbal_lock_warning(180.0) is None
    for pitch in (85.0, 90.83, -89.0, 95.0, -94.0):
        text = gimbal_lock_warning(pitch)
        assert text is not None
        assert f"the boresight pitch is {pitch:.2f} deg" in text
        assert "gimbal lock" in text
