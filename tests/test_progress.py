"""`kinsync.progress`: shares of the work, stages, and the reports reaching 100 %."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from kinsync.progress import Stages, part, report

Seen = list[tuple[float, str]]


def test_report_clamps_and_ignores_none() -> None:
    seen: Seen = []
    report(lambda f, s: seen.append((f, s)), 1.7, "a")
    report(lambda f, s: seen.append((f, s)), -0.2, "b")
    report(None, 0.5, "nothing")  # no progress: no call, no error
    assert seen == [(1.0, "a"), (0.0, "b")]


@given(
    start=st.floats(0.0, 1.0),
    width=st.floats(0.0, 1.0),
    fractions=st.lists(st.floats(0.0, 1.0), min_size=1, max_size=20),
)
def test_part_maps_onto_its_share(start: float, width: float, fractions: list[float]) -> None:
    stop = min(1.0, start + width)
    seen: Seen = []
    inner = part(lambda f, s: seen.append((f, s)), start, stop)
    assert inner is not None
    for f in sorted(fractions):
        inner(f, "x")
    got = [f for f, _ in seen]
    assert got == sorted(got)
    assert all(start - 1e-12 <= f <= stop + 1e-12 for f in got)
    inner(1.0, "x")
    assert seen[-1][0] == pytest.approx(stop)


def test_part_of_none_is_none_and_a_fixed_label_wins() -> None:
    assert part(None, 0.0, 0.5) is None
    seen: Seen = []
    inner = part(lambda f, s: seen.append((f, s)), 0.5, 1.0, "smoother")
    assert inner is not None
    inner(0.5, "anything")
    assert seen == [(0.75, "smoother")]


def test_stages_reach_one_in_order_and_skip() -> None:
    seen: Seen = []
    stages = Stages(lambda f, s: seen.append((f, s)), {"read": 1.0, "work": 2.0, "write": 1.0})
    sub = stages.start("read")
    assert sub is not None
    sub(0.5, "ignored label")  # half of the first quarter
    stages.say("reading the header")
    stages.start("write", "writing out.csv")  # "work" skipped: its share passed over
    stages.finish()
    assert seen == [
        (0.0, "read"),
        (0.125, "read"),
        (0.125, "reading the header"),  # never back
        (0.75, "writing out.csv"),
        (1.0, "write"),
    ]


def test_stages_without_progress_report_nothing() -> None:
    stages = Stages(None, {"only": 1.0})
    assert stages.start("only") is None
    stages.say("still nothing")
    stages.finish()


@pytest.mark.parametrize("weights", [{}, {"a": 0.0}, {"a": 1.0, "b": -1.0}])
def test_stages_refuse_bad_weights(weights: dict[str, float]) -> None:
    with pytest.raises(ValueError, match="positive weights"):
        Stages(None, weights)


def test_unknown_stage_is_named() -> None:
    stages = Stages(None, {"read": 1.0})
    with pytest.raises(ValueError, match="'wirte'"):
        stages.start("wirte")
