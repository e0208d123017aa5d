"""The clock of a 2D profile scanner's mirror (SPEC section 4, Method B).

A profiler's mirror turns at a constant rate; the scanner records profile numbers n
and mirror angles phi but no usable time. The clock
``t(n, phi) = t0 + (n + phi / 2 pi) T`` gives each return its time from the shift
``t0`` and the period ``T`` (which also absorbs the drift of a free-running
oscillator); `kinsync.sync.object_space` estimates them from sync points.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from kinsync._text import shown_value
from kinsync._typing import ArrayLike, FloatArray
from kinsync._validate import finite_number, time_number
from kinsync.errors import InputError
from kinsync.mount import MAX_PROFILE_ANGLE_RAD

__all__ = ["PERIOD_SPAN_S", "ProfileClock"]

PERIOD_SPAN_S = (1e-5, 10.0)
"""Mirror periods (s) a `ProfileClock` may have: 10 us (100,000 profiles a second) to
10 s (0.1 Hz, the slowest profile rate ``kinsync simulate --profile-rate-hz`` takes;
``--period-s`` has the same span). Profilers turn 10 to 250 times a second (a period of
4 to 100 ms): a larger period is most often milliseconds given as seconds (30.3 for
0.0303 s)."""


@dataclass(frozen=True)
class ProfileClock:
    """The profile clock ``t(n, phi) = t0 + (n + phi / 2 pi) T`` (SPEC section 4).

    Attributes
    ----------
    t0_s : float
        Start of profile 0 (s, the trajectory's time scale, GPS time).
    period_s : float
        Mirror period T (s), within `PERIOD_SPAN_S`.

    Raises
    ------
    InputError
        ``t0_s`` not a finite, float64-precise time (a float32 GPS time is held in steps
        of 128 s), or ``period_s`` not a finite number within `PERIOD_SPAN_S`.
    """

    t0_s: float
    period_s: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "t0_s", time_number(self.t0_s, "profile clock t0_s"))
        period_s = finite_number(self.period_s, "profile clock period_s")
        low, high = PERIOD_SPAN_S
        if not low <= period_s <= high:
            msg = (
                f"profile clock period_s: {period_s!r} s is outside {low:g} to {high:g} s, "
                "the periods of a profiler's mirror; the period is in seconds per profile "
                f"(0.0303 s for 33 rev/s), not milliseconds ({period_s!r} ms would be "
                f"{period_s / 1e3!r} s)"
            )
            raise InputError(msg)
        object.__setattr__(self, "period_s", period_s)

    def time_s(self, profile: ArrayLike, angle_rad: ArrayLike) -> FloatArray:
        """Time (s) of returns at profile numbers and mirror angles (rad), same shape.

        Parameters
        ----------
        profile : array_like, shape (...)
            Profile numbers n, finite.
        angle_rad : array_like, shape (...)
            Mirror angles phi (rad), finite and within one turn either way
            (`kinsync.mount.MAX_PROFILE_ANGLE_RAD`, as `kinsync.Mount.profile_to_scanner`
            takes them), broadcastable with ``profile``.

        Returns
        -------
        ndarray of float64, the broadcast shape
            ``t0_s + (n + phi / 2 pi) * period_s`` (s, the trajectory's time scale).

        Raises
        ------
        InputError
            Values that are not real numbers (text, booleans, complex), a profile
            number not finite, an angle not finite or beyond one turn (degrees given
            as radians), naming its index.
        """
        n = _real_numbers(profile, "profile")
        _refuse(~np.isfinite(n), n, "profile", "is not a finite profile number")
        phi = _real_numbers(angle_rad, "angle_rad")
        wide = ~(np.abs(phi) <= MAX_PROFILE_ANGLE_RAD)  # NaN too
        turn = f"is not a finite angle within one turn (+-{MAX_PROFILE_ANGLE_RAD:.6g} rad)"
        _refuse(wide, phi, "angle_rad", f"{turn}: mirror angles are radians")
        out: FloatArray = self.t0_s + (n + phi / math.tau) * self.period_s
        return out


def _real_numbers(values: ArrayLike, name: str) -> FloatArray:
    """``values`` as float64, refused when not integer or float numbers."""
    arr = np.asarray(values)
    if arr.dtype.kind not in "iuf":
        msg = (
            f"profile clock time_s: {name}: expected numbers, got {arr.dtype} values "
            f"({shown_value(values)})"
        )
        raise InputError(msg)
    return arr.astype(np.float64)


def _refuse(bad: np.ndarray, values: FloatArray, name: str, why: str) -> None:
    """Raise `InputError` naming the first of ``values`` where ``bad`` holds."""
    if not bad.any():
        return
    index = np.unravel_index(int(np.flatnonzero(bad)[0]), bad.shape)
    shown = ", ".join(str(int(i)) for i in index)
    at = f"[{shown}]" if shown else ""
    msg = f"profile clock time_s: {name}{at} = {float(values[index])!r} {why}"
    raise InputError(msg)
