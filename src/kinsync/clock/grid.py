"""The 1 s grid of a PPS log: each pulse's count of seconds, and the pulses off it.

Step 1 and 2 of `kinsync.clock.fit` (its module docstring): the local period and phase
from the pulses alone, then the iterative rejection of the pulses off the grid.
"""

from __future__ import annotations

import numpy as np

from kinsync._typing import BoolArray, FloatArray, IntArray
from kinsync.clock.steps import wrap
from kinsync.errors import InputError, ObservabilityError
from kinsync.robust import robust_sigma

__all__ = ["grid_labels", "line_fit", "unit_hint"]

_PERIOD_TOLERANCE = 0.01
"""Pulse intervals within 1 % of a whole number of seconds set the local period."""
_COARSE_TOLERANCE_S = 0.1
"""Pulses within this of the coarse grid seed the robust fit."""
_REJECT_SIGMAS = 6.0
_SMALL_SAMPLE_SIGMAS = 300.0
"""The rejection threshold is ``6 + 300 / n**2`` robust sigmas of the ``n`` kept pulses."""
_MIN_REJECT_THRESHOLD_S = 1e-5
_MAX_ITERATIONS = 50
_THRESHOLD_SHRINK = 10.0


_TIME_UNITS = ((1e3, "milliseconds"), (1e6, "microseconds"), (1e9, "nanoseconds"))
"""Pulse spacings (in the log's unit) that say the times are not in seconds."""


def unit_hint(spacing: float, what: str) -> str:
    """``"; ... look like milliseconds ..."`` for a median spacing of about 1000, else ""."""
    for per_second, unit in _TIME_UNITS:
        if abs(spacing - per_second) <= _PERIOD_TOLERANCE * per_second:
            return (
                f"; {what} are about {per_second:g} units apart, so they look like {unit}: "
                f"give every t_local_s in seconds (divide by {per_second:g})"
            )
    return ""


def _both_edges_s(t: FloatArray) -> float | None:
    """Spacing of two interleaved pulse phases (s) when the log holds both edges, else None.

    A capture that logs the rising and the falling edge of each pulse gives intervals
    alternating ``d`` and ``1 - d``: none is a whole second, every other one is.
    """
    d = np.diff(t)
    if len(d) < 3:
        return None
    short = d < 0.5
    if np.count_nonzero(short) * 3 < len(d):
        return None
    d2 = t[2:] - t[:-2]
    k2 = np.rint(d2)
    whole = (k2 >= 1.0) & (np.abs(d2 - k2) <= _PERIOD_TOLERANCE * k2)
    if 2 * np.count_nonzero(whole) <= len(d2):
        return None
    return float(np.median(d[short]))


def _local_period_s(t: FloatArray) -> float:
    """Median local duration of one GPS second, from the whole-second pulse intervals."""
    d = np.diff(t)
    two_phases_s = _both_edges_s(t)
    if two_phases_s is not None:
        msg = (
            f"the pulses fall in two phases {two_phases_s:.3g} s apart (intervals alternate "
            f"about {two_phases_s:.3g} s and {1.0 - two_phases_s:.3g} s): the pulse log holds "
            "both edges of each pulse (rising and falling); keep one edge (every other line)"
        )
        raise InputError(msg)
    spacing = float(np.median(d))
    hint = unit_hint(spacing, "the pulses")
    if hint:
        msg = f"the pulse log's times do not look like seconds{hint}"
        raise InputError(msg)
    k = np.rint(d)
    ok = (k >= 1.0) & (np.abs(d - k) <= _PERIOD_TOLERANCE * k)
    if not np.any(ok):
        msg = (
            "no two pulses are a whole number of seconds apart (within 1 %): the pulse log "
            "does not look like a pulse per second; check the file and its time unit"
        )
        raise InputError(msg)
    return float(np.median(d[ok] / k[ok]))


def line_fit(x: FloatArray, y: FloatArray) -> tuple[float, float]:
    """Least-squares intercept at x = 0 and slope of y on x."""
    xm = float(np.mean(x))
    ym = float(np.mean(y))
    sxx = float(np.sum((x - xm) ** 2))
    slope = float(np.sum((x - xm) * (y - ym)) / sxx) if sxx > 0.0 else 0.0
    return ym - slope * xm, slope


def _keep_closest_per_label(labels: IntArray, resid: FloatArray, keep: BoolArray) -> BoolArray:
    idx = np.flatnonzero(keep)
    order = idx[np.lexsort((np.abs(resid[idx]), labels[idx]))]
    first = np.ones(len(order), dtype=np.bool_)
    first[1:] = labels[order][1:] != labels[order][:-1]
    out = np.zeros_like(keep)
    out[order[first]] = True
    return out


def _phase_mode(phase: FloatArray) -> float:
    """Middle of the densest window of width ``2 * _COARSE_TOLERANCE_S`` of the phases.

    Phases are in grid counts, in [-0.5, 0.5]; windows wrap around. Unlike a circular
    mean, the mode of a log with a step of the local clock is the phase of its larger
    part, not a phase between the two that no pulse has.
    """
    p = np.sort(phase)
    ext = np.concatenate([p, p + 1.0])
    ends = np.searchsorted(ext, p + 2.0 * _COARSE_TOLERANCE_S, side="left")
    i = int(np.argmax(ends - np.arange(len(p))))
    return float(np.median(ext[i : int(ends[i])]))


_THEIL_SEN_POINTS = 200
"""Pulses (evenly spread) whose pairwise slopes the robust start takes the median of."""


def _theil_sen(x: FloatArray, y: FloatArray) -> tuple[float, float]:
    """Robust intercept at x = 0 and slope of y on x: median of pairwise slopes."""
    if len(x) > _THEIL_SEN_POINTS:
        pick = np.linspace(0, len(x) - 1, _THEIL_SEN_POINTS).round().astype(np.int64)
        x, y = x[pick], y[pick]
    i, j = np.triu_indices(len(x), k=1)
    dx = x[j] - x[i]
    ok = dx > 0.0
    slope = float(np.median((y[j] - y[i])[ok] / dx[ok]))
    return float(np.median(y - slope * x)), slope


def _reject_threshold_s(resid: FloatArray) -> float:
    """Rejection threshold for pulse residuals: ``max(k(n) * scale, 1 us)`` (s).

    ``scale`` is the robust sigma (1.4826 * MAD) of the residuals of the ``n`` pulses
    within 0.1 s of the grid, kept or not: taken from the kept pulses alone, a few
    that happen to lie on a line shrank it pass after pass and rejected good pulses.
    ``k(n) = 6 + 300 / n**2``: 6 for a long log, more for a handful of pulses, whose
    MAD is often far below their spread (for 7 pulses, 3 % of logs had a good pulse
    beyond 6 scales; with k(n), under 0.5 % for any n).
    """
    r = resid[np.abs(resid) < _COARSE_TOLERANCE_S]
    n = len(r)
    scale = robust_sigma(r - np.median(r)) if n else 0.0
    k = _REJECT_SIGMAS + _SMALL_SAMPLE_SIGMAS / max(n, 1) ** 2
    return max(k * scale, _MIN_REJECT_THRESHOLD_S)


def grid_labels(t: FloatArray) -> tuple[IntArray, BoolArray, float, float]:
    """Label each pulse with a count of seconds and flag the pulses on the 1 s grid.

    Returns labels (relative counts), the good-pulse mask, and the relative model
    ``count(t) = alpha + beta * (t - t[0])`` fitted on the good pulses.
    """
    x = t - t[0]
    period = _local_period_s(t)
    beta = 1.0 / period
    tau = x * beta
    phase = wrap(tau)
    phi0 = _phase_mode(phase)
    near = np.abs(wrap(phase - phi0)) < _COARSE_TOLERANCE_S
    if np.count_nonzero(near) < 3:
        msg = (
            f"the {len(t)} pulses do not share a 1 s grid (fewer than 3 within 0.1 s of "
            "a common phase); check that the file holds PPS edges in seconds"
        )
        raise ObservabilityError(msg)
    phi0 += float(np.median(wrap(phase[near] - phi0)))
    # Counts start at the grid position of the first pulse: alpha = -phi0.
    alpha = -phi0
    labels = np.rint(alpha + beta * x).astype(np.int64)
    resid = labels - (alpha + beta * x)
    # First cut on a robust line (Theil-Sen) through the pulses near the grid, not on a
    # least-squares line: in a short log one pulse 50 ms off tilts that enough to keep
    # itself.
    near = np.abs(resid) < _COARSE_TOLERANCE_S
    alpha, beta = _theil_sen(x[near], labels[near].astype(np.float64))
    u = alpha + beta * x
    labels = np.rint(u).astype(np.int64)
    resid = labels - u
    threshold = min(_COARSE_TOLERANCE_S, _reject_threshold_s(resid))
    good = _keep_closest_per_label(labels, resid, np.abs(resid) <= threshold)
    for _ in range(_MAX_ITERATIONS):
        if np.count_nonzero(good) < 3:
            break
        alpha, beta = line_fit(x[good], labels[good].astype(np.float64))
        u = alpha + beta * x
        labels = np.rint(u).astype(np.int64)
        resid = labels - u
        target = _reject_threshold_s(resid)
        # Shrink by at most 10x per pass: a fit tilted by an outlier still inside the
        # coarse tolerance must not reject the good pulses along with it.
        threshold = max(target, threshold / _THRESHOLD_SHRINK)
        new_good = _keep_closest_per_label(labels, resid, np.abs(resid) <= threshold)
        if np.array_equal(new_good, good) and threshold == target:
            break
        good = new_good
    if np.count_nonzero(good) < 3:
        msg = (
            f"only {int(np.count_nonzero(good))} of {len(t)} pulses lie on a common 1 s grid; "
            "at least 3 are needed to fit offset, drift and their uncertainty"
        )
        raise ObservabilityError(msg)
    return labels, good, alpha, beta
