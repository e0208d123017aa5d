"""Verdicts: a measured value and its σ judged against a tolerance stated beforehand.

A report that gives a verdict says what was measured, the number with its standard
deviation, the tolerance it is judged against and why that tolerance, then pass or
fail. One rule judges every check: the value must lie inside the tolerance with room
for `COVERAGE_FACTOR` standard deviations (``|value| + 2σ ≤ limit``), so that a lucky
value with a large σ does not pass; a value without a σ (a count, a largest error, a
p-value) is judged as it is. A value that is not a number fails.

References
----------
ISO 14253-1:2017, Geometrical product specifications (GPS) -- Inspection by
measurement of workpieces and measuring equipment -- Part 1: Decision rules for
verifying conformity or nonconformity with specifications.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

from kinsync.report.numbers import format_p_value, format_value

__all__ = [
    "COVERAGE_FACTOR",
    "JUDGING_RULE",
    "Bound",
    "Check",
    "Tolerance",
    "count_passed",
]

Bound = Literal["abs_at_most", "at_most", "at_least"]
"""How a value meets its limit: ``|value| ≤ limit``, ``value ≤ limit``, ``value ≥ limit``."""

COVERAGE_FACTOR = 2.0
"""Standard deviations a value must keep inside its tolerance (about 95 % for a normal)."""

JUDGING_RULE = (
    "A check passes when the measured value lies inside its tolerance with room for two "
    "standard deviations (for a limit on the size of an error: |value| + 2σ ≤ tolerance), "
    "so that a value that is small only by chance, with a large σ, does not pass: the "
    "decision rule of ISO 14253-1, with the expanded uncertainty 2σ. Values without a σ "
    "(counts, the largest error over a run, p-values) are judged as they are."
)
"""The rule in words, as a report states it."""

_BOUNDS = ("abs_at_most", "at_most", "at_least")


def _limit_text(limit: float, unit: str) -> str:
    return f"{limit:g} {unit}".strip()


@dataclass(frozen=True)
class Tolerance:
    """A limit stated before the measurement, and why it is that.

    Attributes
    ----------
    name : str
        Short name shown in the report's table of tolerances.
    limit : float
        The limit, in ``unit``.
    unit : str
        Unit of the limit and of the values judged against it ("" for counts, ratios
        and p-values).
    bound : {"abs_at_most", "at_most", "at_least"}
        ``|value| ≤ limit``, ``value ≤ limit`` or ``value ≥ limit``.
    why : str
        The reason for the limit, in words a surveyor can check.
    p_value : bool
        The values judged are p-values (written ``p < 0.001``; they carry no σ).
    """

    name: str
    limit: float
    unit: str
    bound: Bound
    why: str
    p_value: bool = False

    def __post_init__(self) -> None:
        if self.bound not in _BOUNDS:
            msg = f"tolerance {self.name!r}: bound must be one of {_BOUNDS}, got {self.bound!r}"
            raise ValueError(msg)
        if not math.isfinite(self.limit):
            msg = f"tolerance {self.name!r}: the limit must be a finite number"
            raise ValueError(msg)
        if not self.name.strip() or not self.why.strip():
            msg = "a tolerance needs a name and the reason for its limit"
            raise ValueError(msg)
        if self.p_value and not 0.0 <= self.limit <= 1.0:
            msg = f"tolerance {self.name!r}: a p-value limit lies in [0, 1]"
            raise ValueError(msg)

    def describe(self) -> str:
        """The limit as written in the report: ``±0.1 ms``, ``≤ 0``, ``p ≤ 0.01``."""
        if self.p_value:
            return f"p {'≥' if self.bound == 'at_least' else '≤'} {self.limit:g}"
        if self.bound == "abs_at_most":
            return f"±{_limit_text(self.limit, self.unit)}"
        sign = "≤" if self.bound == "at_most" else "≥"
        return f"{sign} {_limit_text(self.limit, self.unit)}"


@dataclass(frozen=True)
class Check:
    """One measured quantity judged against its tolerance.

    Attributes
    ----------
    quantity : str
        What was measured, in words ("latency error against the simulated truth").
    value : float
        The measured value, in the tolerance's unit.
    tolerance : Tolerance
        The limit it is judged against.
    sigma : float or None
        Its standard deviation (same unit); None where the quantity has none.
    detail : str
        Optional context shown beside the value ("estimate 4.2117 ms, truth 4.21 ms").
    """

    quantity: str
    value: float
    tolerance: Tolerance
    sigma: float | None = None
    detail: str = ""

    def __post_init__(self) -> None:
        if self.sigma is not None and self.sigma < 0.0:
            msg = f"{self.quantity}: a standard deviation cannot be negative ({self.sigma})"
            raise ValueError(msg)
        if self.tolerance.p_value and self.sigma is not None:
            msg = f"{self.quantity}: a p-value is judged as it is, without a σ"
            raise ValueError(msg)
        object.__setattr__(self, "value", float(self.value))

    @property
    def judged_value(self) -> float:
        """The value the rule compares with the limit: the value moved 2σ outwards."""
        spread = COVERAGE_FACTOR * (self.sigma or 0.0)
        if self.tolerance.bound == "abs_at_most":
            return abs(self.value) + spread
        if self.tolerance.bound == "at_most":
            return self.value + spread
        return self.value - spread

    @property
    def passed(self) -> bool:
        """True when the value (moved 2σ outwards) meets the limit; NaN never passes."""
        judged = self.judged_value
        if not math.isfinite(judged):
            return False
        if self.tolerance.bound == "at_least":
            return judged >= self.tolerance.limit
        return judged <= self.tolerance.limit

    @property
    def verdict(self) -> str:
        """``PASS`` or ``FAIL``."""
        return "PASS" if self.passed else "FAIL"

    def measured(self) -> str:
        """The value as written in the report: ``0.0017 ± 0.016 ms``, ``p < 0.001``."""
        if self.tolerance.p_value:
            return format_p_value(self.value)
        return format_value(self.value, self.sigma, self.tolerance.unit)

    def sentence(self) -> str:
        """One line: what, the value, the tolerance and the verdict."""
        detail = f" ({self.detail})" if self.detail else ""
        return (
            f"{self.quantity}: {self.measured()}{detail}; tolerance "
            f"{self.tolerance.describe()}: {self.verdict}."
        )


def count_passed(checks: Sequence[Check]) -> tuple[int, int]:
    """(checks passed, checks in all)."""
    return sum(c.passed for c in checks), len(checks)
