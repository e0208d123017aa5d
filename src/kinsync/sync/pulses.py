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
    "allowed_offsets",
    "pulse_offset",
]


def allowed_offsets(n_pulses: int, n_profiles: int) -> tuple[int, int]:
    """The pulse offsets k that ``n_pulses`` pulses for ``n_profiles`` profiles allow.

    One pulse per profile: the train starts with profile 0 (k = 0), with a pulse or
    more before it (k = P - N > 0, an extra first pulse gives 1), or ends with the
    last profile (k = 0 when P - N > 0, k = P - N when pulses are missing at the
    start), or anything between, give or take one pulse (a first or last pulse lost).

    Parameters
    ----------
    n_pulses : int
        P, pulses in the train.
    n_profiles : int
        N, profiles the scan spans (last profile number + 1).

    Returns
    -------
    (int, int)
        Smallest and largest k, ``min(P - N, 0) - 1`` and ``max(P - N, 0) + 1``.
    """
    extra = int(n_pulses) - int(n_profiles)
    return min(extra, 0) - 1, max(extra, 0) + 1


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
    allowed : (int, int) or None
        The offsets the pulse train allows for the scan (`allowed_offsets`), None when
        the number of profiles was not given.
    """

    offset: int
    fraction: float
    std: float
    reference_profile: int
    allowed: tuple[int, int] | None = None

    @property
    def plausible(self) -> bool:
        """True when the offset is one the pulse train allows (or nothing says which)."""
        return self.allowed is None or self.allowed[0] <= self.offset <= self.allowed[1]

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
    n_profiles: int | None = None,
    period_window_s: tuple[float, float] | None = None,
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
    n_profiles : int, optional
        Profiles the scan spans (last profile number + 1): the result then says which
        offsets the pulse train allows (`PulseOffset.plausible`).
    period_window_s : (float, float), optional
        Smallest and largest period (s) the scanner may have (the prior's window): when
        the pulses' period lies within it and disagrees with the clock's, the message
        names the clock (its sync points, the mount) as a suspect beside the pulses.

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
        head = (
            f"{source}: the pulses come every {pulse_period!r} s but the estimated period is "
            f"{clock.period_s!r} s (tolerance {tolerance:.3g} s)"
        )
        if period_window_s is not None and (
            period_window_s[0] <= pulse_period <= period_window_s[1]
        ):
            msg = (
                f"{head}; the pulses' period lies within the period prior's window "
                f"({period_window_s[0]:.6g} to {period_window_s[1]:.6g} s), as this scanner's "
                "would: either the clock from the sync points is wrong (sightings matched to "
                "the wrong crossings): check the sync points' coordinates (datum, heights) and "
                "the mount (lever arm, boresight, [profiler] azimuth_deg); or the pulses are "
                "not this scan's, or not on the trajectory's time scale"
            )
        else:
            msg = (
                f"{head}: they are not this scanner's profile pulses, or not on the "
                "trajectory's time scale"
            )
        raise ObservabilityError(msg)
    predicted = clock.t0_s + reference_profile * clock.period_s
    m_star = int(np.argmin(np.abs(p - predicted)))
    return PulseOffset(
        offset=m_star - int(reference_profile),
        fraction=float((p[m_star] - predicted) / clock.period_s),
        std=float(time_std_s) / clock.period_s,
        reference_profile=int(reference_profile),
        allowed=None if n_profiles is None else allowed_offsets(p.size, n_profiles),
    )
