"""Method B step 6, counting faults: hardware profile pulses matched to the profile clock."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from kinsync._typing import ArrayLike
from kinsync.clock.profile import ProfileClock
from kinsync.errors import InputError, ObservabilityError

__all__ = [
    "PulseOffset",
    "pulse_offset",
]


@dataclass(frozen=True)
class PulseOffset:
    """Integer offset between hardware pulses and profile numbers.

    Attributes
    ----------
    offset : int
        k: ``pulse[n + k]`` is the pulse of profile n (1 with one extra first pulse).
    fraction : float
        Misfit of the matched pulse to the predicted profile start (profiles).
    std : float
        Sigma of the predicted profile start where the pulse was matched (profiles).
    reference_profile : int
        Profile at which the pulse was matched (least clock variance).
    """

    offset: int
    fraction: float
    std: float
    reference_profile: int

    @property
    def sure(self) -> bool:
        """True when the misfit is within 0.25 profile and 3 sigma within 0.5 profile."""
        return abs(self.fraction) <= 0.25 and 3.0 * self.std <= 0.5


def pulse_offset(
    pulses_t_s: ArrayLike,
    clock: ProfileClock,
    *,
    reference_profile: int = 0,
    time_std_s: float = 0.0,
    period_std_s: float = 0.0,
    source: str = "pulses",
    where: Callable[[int], str] | None = None,
) -> PulseOffset:
    """Integer offset k between pulses and profiles: ``pulse[n + k]`` belongs to profile n.

    Parameters
    ----------
    pulses_t_s : array_like, shape (P,)
        Pulse times (s), strictly increasing, one per profile (maybe one more first).
    clock : ProfileClock
        The estimated clock; a pulse marks ``t(n, 0)``.
    reference_profile : int
        Profile at which to match (best: where the clock is best known).
    time_std_s : float
        Sigma of ``t(reference_profile, 0)`` (s).
    period_std_s : float
        Sigma of the clock's period (s), to judge the pulse train's period.
    source : str
        Name for messages (the pulses' file).
    where : callable, optional
        ``where(i)`` names pulse i (0-based) as its file counts it (``"line 7"``);
        default ``"pulse i+1 of P"``.

    Returns
    -------
    PulseOffset

    Raises
    ------
    InputError
        Fewer than two pulses, non-finite or non-increasing times.
    ObservabilityError
        A gap in the pulse train (a missing pulse), or a pulse period that disagrees
        with the clock's: the offset would not be one number along the scan.
    """
    p = np.asarray(pulses_t_s, dtype=np.float64)
    if p.ndim != 1 or p.size < 2 or not np.all(np.isfinite(p)) or np.any(np.diff(p) <= 0):
        msg = f"{source}: pulse times must be at least 2 finite, strictly increasing times"
        raise InputError(msg)
    step = np.diff(p)
    median_step = float(np.median(step))
    gap = step > 1.5 * median_step
    if np.any(gap):
        m = int(np.flatnonzero(gap)[0])
        place = where or (lambda i: f"pulse {i + 1} of {p.size}")
        periods = step[m] / median_step
        missing = max(round(periods) - 1, 1)
        msg = (
            f"{source}: pulses at t_s={p[m]!r} ({place(m)}) and t_s={p[m + 1]!r} "
            f"({place(m + 1)}) are {periods:.2f} periods apart: about {missing} pulse(s) "
            "missing between them, so pulses and profiles cannot be counted with one offset; "
            "fill the gap or cut the scan there"
        )
        raise ObservabilityError(msg)
    n = np.arange(p.size, dtype=np.float64)
    pulse_period = float(np.polyfit(n, p, 1)[0])
    tolerance = 5.0 * period_std_s + 1e-5 * clock.period_s
    if abs(pulse_period - clock.period_s) > tolerance:
        msg = (
            f"{source}: the pulses come every {pulse_period!r} s but the estimated period is "
            f"{clock.period_s!r} s (tolerance {tolerance:.3g} s): they are not this scanner's "
            "profile pulses, or not on the trajectory's time scale"
        )
        raise ObservabilityError(msg)
    predicted = clock.t0_s + reference_profile * clock.period_s
    m_star = int(np.argmin(np.abs(p - predicted)))
    return PulseOffset(
        offset=m_star - int(reference_profile),
        fraction=float((p[m_star] - predicted) / clock.period_s),
        std=float(time_std_s) / clock.period_s,
        reference_profile=int(reference_profile),
    )
