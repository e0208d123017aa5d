"""A solution and its reference on time scales a whole leap-second count apart.

GPS time runs ahead of UTC by the leap seconds (10 s in 1995 to 18 s since 2017). A
solution tagged in UTC compared with a reference in GPS time (or the other way round)
is compared at the wrong instants: a vehicle at 16 m/s shows 290 m of "error", and
`kinsync.ins.compare.compare_to_truth` would report it as the filter's. This module
finds the shift of 10 to 18 whole seconds at which the two agree far better.
"""

from __future__ import annotations

import math

import numpy as np

from kinsync._typing import FloatArray
from kinsync.trajectory import Trajectory

__all__ = ["LEAP_SECONDS_S", "leap_second_offset_text"]

LEAP_SECONDS_S = tuple(range(10, 19))
"""Whole seconds GPS time has run ahead of UTC (10 s in 1995 to 18 s since 2017)."""

_MIN_RMS_M = 1.0
_BETTER = 0.2
_SAMPLE = 2000


def _rms_at(
    t_s: FloatArray, pos_ecef_m: FloatArray, truth: Trajectory, shift_s: float, max_gap_s: float
) -> tuple[float, int]:
    """3-D RMS of the solution against the truth read ``shift_s`` later, and the epochs used."""
    inside = truth.contains(t_s + shift_s, max_gap_s=max_gap_s)
    n = int(np.count_nonzero(inside))
    if n == 0:
        return math.inf, 0
    ref = truth.interpolate(t_s[inside] + shift_s, max_gap_s=max_gap_s).pos_ecef_m()
    diff = pos_ecef_m[inside] - ref
    return float(np.sqrt(np.mean(np.sum(diff * diff, axis=1)))), n


def leap_second_offset_text(
    t_s: FloatArray, pos_ecef_m: FloatArray, truth: Trajectory, max_gap_s: float
) -> str:
    """Say when the solution agrees with the truth far better a leap-second count apart.

    Parameters
    ----------
    t_s : ndarray, shape (N,)
        Solution epochs inside the truth (s, the solution's time scale).
    pos_ecef_m : ndarray, shape (N, 3)
        Solution positions at them, ECEF (m).
    truth : Trajectory
        The reference.
    max_gap_s : float
        Longest truth record interval interpolated across (s).

    Returns
    -------
    str
        "" when the times as given agree best, when the vehicle hardly moved (3-D RMS
        below 1 m as given) or when no shift of 10 to 18 s (either way) brings the RMS
        below a fifth of it with at least half the epochs; else what was found and what
        to do.
    """
    if t_s.size == 0:
        return ""
    step = max(1, t_s.size // _SAMPLE)
    t, pos = t_s[::step], pos_ecef_m[::step]
    rms0, _ = _rms_at(t, pos, truth, 0.0, max_gap_s)
    if not rms0 > _MIN_RMS_M:
        return ""
    best = (rms0, 0)
    for whole in LEAP_SECONDS_S:
        for shift in (whole, -whole):
            rms, n = _rms_at(t, pos, truth, float(shift), max_gap_s)
            if n >= t.size / 2 and rms < best[0]:
                best = (rms, shift)
    rms, shift = best
    if shift == 0 or rms >= _BETTER * rms0:
        return ""
    side = "behind" if shift > 0 else "ahead of"
    return (
        f"the solution matches the reference {abs(shift)} s {'later' if shift > 0 else 'earlier'} "
        f"(3-D RMS {rms:.3g} m, against {rms0:.3g} m as given): its times are {abs(shift)} s "
        f"{side} the reference's, what GPS time runs ahead of UTC (leap seconds; 18 s since "
        "2017): is one in UTC and the other in GPS time? Put both on GPS time (add the "
        "leap seconds to the UTC times) and compare again"
    )
