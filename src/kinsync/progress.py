"""Progress of long work, reported to the caller (algorithms never print).

Work that can take more than a few seconds (the INS filter and smoother, georeferencing
a file, applying a clock, calibrating a mount, the simulators, the demo) takes an
optional ``progress`` argument of type `Progress` and calls it as it advances:
``progress(fraction, stage)``, where ``fraction`` is the share of the whole work done
(0 to 1, never decreasing, 1 once the work is complete) and ``stage`` a short lower-case
label of what is being done now ("filter", "smoother", "writing"). The caller decides
how to show it: the command line draws a bar with the percentage and the time left on a
terminal and writes one plain line per stage otherwise (`kinsync.cli`).

Work made of parts reports each part on a share of the whole: `Stages` gives each named
stage a relative weight, and `part` maps a part's own 0..1 onto its share.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Protocol

__all__ = ["Progress", "Stages", "part", "report"]


class Progress(Protocol):
    """``progress(fraction, stage)``: the share of the work done (0..1) and what is running."""

    def __call__(self, fraction: float, stage: str, /) -> None:
        """Report that ``fraction`` of the work is done and ``stage`` is running now."""


def report(progress: Progress | None, fraction: float, stage: str) -> None:
    """Call ``progress(fraction, stage)`` when there is a ``progress`` (a no-op otherwise)."""
    if progress is not None:
        progress(min(1.0, max(0.0, fraction)), stage)


def part(
    progress: Progress | None, start: float, stop: float, stage: str | None = None
) -> Progress | None:
    """The `Progress` of one part of the work, which takes ``start`` to ``stop`` of it.

    Parameters
    ----------
    progress : Progress or None
        The whole work's progress (None: the part reports nothing either).
    start, stop : float
        The part's share of the whole, ``0 <= start <= stop <= 1``.
    stage : str, optional
        The label reported for every step of the part; default the part's own labels.

    Returns
    -------
    Progress or None
        Maps the part's fraction ``f`` to ``start + f (stop - start)``.
    """
    if progress is None:
        return None
    outer = progress
    lo = min(1.0, max(0.0, start))
    hi = min(1.0, max(lo, stop))

    def inner(fraction: float, inner_stage: str, /) -> None:
        f = min(1.0, max(0.0, fraction))
        outer(lo + f * (hi - lo), inner_stage if stage is None else stage)

    return inner


class Stages:
    """Named stages of one piece of work, each with a relative weight (its expected time).

    ``stages.start(name)`` reports the start of stage ``name`` and returns the
    `Progress` of that stage (its own 0..1 on the stage's share of the whole);
    ``stages.say(label)`` reports what the current stage does now (at the share done
    so far), and ``stages.finish()`` reports the work complete. Stages may be skipped
    (their share is passed over) but not run out of order; the fractions reported
    never decrease.

    Parameters
    ----------
    progress : Progress or None
        Where the whole work's progress goes (None: nothing is reported).
    weights : mapping of str to float
        The stages in the order they run, with their weights (> 0).
    """

    def __init__(self, progress: Progress | None, weights: Mapping[str, float]) -> None:
        if not weights or any(not w > 0.0 for w in weights.values()):
            msg = f"Stages needs at least one stage and positive weights, got {dict(weights)}"
            raise ValueError(msg)
        total = float(sum(weights.values()))
        self._progress = progress
        self._bounds: dict[str, tuple[float, float]] = {}
        acc = 0.0
        for name, weight in weights.items():
            self._bounds[name] = (acc / total, (acc + weight) / total)
            acc += weight
        self._last = next(iter(weights))
        self._done = 0.0

    def _emit(self, fraction: float, label: str, /) -> None:
        self._done = max(self._done, min(1.0, fraction))
        report(self._progress, self._done, label)

    def start(self, stage: str, label: str | None = None) -> Progress | None:
        """Report the start of ``stage`` (as ``label``, default the stage's name).

        Returns the stage's own `Progress`, labelled ``stage``.
        """
        if stage not in self._bounds:
            msg = f"unknown stage {stage!r}; the stages are {list(self._bounds)}"
            raise ValueError(msg)
        self._last = stage
        lo, hi = self._bounds[stage]
        self._emit(lo, stage if label is None else label)
        return part(self._emit if self._progress is not None else None, lo, hi, stage)

    def say(self, label: str) -> None:
        """Report what the current stage is doing now (``label``), at the share done.

        For a stage whose parts report only what they do, not how far they are.
        """
        self._emit(self._done, label)

    def finish(self) -> None:
        """Report the whole work done (fraction 1, the last stage started)."""
        self._emit(1.0, self._last)
