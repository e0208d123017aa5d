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

from kinsync._typing import ArrayLike, FloatArray
from kinsync._validate import finite_number, positive_number

__all__ = ["ProfileClock"]


@dataclass(frozen=True)
class ProfileClock:
    """The profile clock ``t(n, phi) = t0 + (n + phi / 2 pi) T`` (SPEC section 4).

    Attributes
    ----------
    t0_s : float
        Start of profile 0 (s, the trajectory's time scale, GPS time).
    period_s : float
        Mirror period T (s), > 0.
    """

    t0_s: float
    period_s: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "t0_s", finite_number(self.t0_s, "profile clock t0_s"))
        object.__setattr__(
            self, "period_s", positive_number(self.period_s, "profile clock period_s")
        )

    def time_s(self, profile: ArrayLike, angle_rad: ArrayLike) -> FloatArray:
        """Time (s) of returns at profile numbers and mirror angles (rad), same shape.

        Parameters
        ----------
        profile : array_like, shape (...)
            Profile numbers n (taken as float64, not checked).
        angle_rad : array_like, shape (...)
            Mirror angles phi (rad), broadcastable with ``profile``.

        Returns
        -------
        ndarray of float64, the broadcast shape
            ``t0_s + (n + phi / 2 pi) * period_s`` (s, the trajectory's time scale).
            Not checked: a NaN input gives NaN.
        """
        n = np.asarray(profile, dtype=np.float64)
        phi = np.asarray(angle_rad, dtype=np.float64)
        out: FloatArray = self.t0_s + (n + phi / math.tau) * self.period_s
        return out
