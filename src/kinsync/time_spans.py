"""Two recordings at the same time: one file given twice, or two sensors.

One scanner records one line (or one pass) at a time, so two recordings whose time
spans overlap by more than `SAME_TIME_SHARE` of the shorter are the same recording
given twice (a copy or a link under another name), which would count twice as
independent data, or recordings of two scanners.
"""

from __future__ import annotations

__all__ = ["SAME_TIME_SHARE", "recorded_together"]

SAME_TIME_SHARE = 0.5
"""Two recordings whose time spans overlap by more than this share of the shorter one's
were recorded at the same time."""


def recorded_together(span_a_s: tuple[float, float], span_b_s: tuple[float, float]) -> bool:
    """Whether two recordings' time spans (first, last; s) overlap as one recording's would.

    Parameters
    ----------
    span_a_s, span_b_s : tuple of 2 float
        First and last time of each recording (s).

    Returns
    -------
    bool
        The overlap exceeds `SAME_TIME_SHARE` of the shorter span (for a span of zero
        length: the spans touch).
    """
    (a0, a1), (b0, b1) = span_a_s, span_b_s
    overlap = min(a1, b1) - max(a0, b0)
    shorter = min(a1 - a0, b1 - b0)
    return overlap > SAME_TIME_SHARE * shorter if shorter > 0 else overlap >= 0
