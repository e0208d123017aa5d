"""Method B: what errors of the mount do to the profile clock (a consider covariance).

The crossings' times come from the trajectory and the mount (SPEC section 4, step 1),
and the clock ``t = t0 + (n + phi / 2 pi) T`` is fitted to them with the mount taken
as exact: its sigma holds the sightings' and the trajectory's errors only. A mount
value that is off moves the crossings of a pass alike, and the clock with them. On the
simulated drive (2 m/s, targets 4-17 m away): 1 cm of lever arm along the track moves
t0 by 4.9 ms (1 cm / 2 m/s) where the data sigma is 9.1 ms, 0.1 deg of boresight yaw
3.8 ms and the period 0.71 us (its sigma 1.55 us), 1 ms of latency t0 by 1 ms; a
boresight known to 1 deg, not 0.1, moves t0 by 38 ms.

As for a calibration that holds values (`kinsync.calibration.held`), the clock's
covariance adds ``D Sigma_h D'``: D the sensitivity of (t0, T) to each of the seven
mount values (lever arm, boresight, latency; ``[profiler] azimuth_deg`` has no
``[uncertainty]`` key and is taken as exact), ``Sigma_h`` the mount's
``[uncertainty]`` with its correlations (`kinsync.calibration.held.held_covariance`).
Each column of D comes from searching the crossings again with that value moved by its
reference error (`kinsync.calibration.held.REFERENCE_ERRORS`: 0.1 deg, 1 cm, 1 ms),
following each crossing to the same sync point's crossing nearest in time, and fitting
a line to the shifts with the clock's covariance (the fit is linear in the times: the
line through the shifts is how far the clock moves). The sightings are
kept: a mount error moves where the plane is, not where the scanner saw the target.

A value the mount gives no sigma for is taken as exact, as before; `exact_text` names
the ones whose reference error would move t0 or T by more than
`kinsync.calibration.held.ADVICE_SHARE` of their data sigma.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from kinsync._arrays import ReadOnlyArrays, readonly_array
from kinsync._typing import FloatArray
from kinsync.calibration.held import (
    ADVICE_SHARE,
    REFERENCE_ERRORS,
    REFERENCE_TEXT,
    held_covariance,
)
from kinsync.calibration.parameters import (
    PARAMETER_NAMES,
    REPORT_SCALE,
    mount_from_values,
    mount_values,
)
from kinsync.mount import Mount
from kinsync.sync.clock_line import gls_line
from kinsync.sync.config import ObjectSpaceConfig
from kinsync.sync.crossings import Crossing, search_crossings
from kinsync.sync.scan import SyncPoints
from kinsync.trajectory import Trajectory

__all__ = ["MAX_SHIFT_S", "MountEffect", "crossing_shifts", "exact_text", "mount_effect"]

MAX_SHIFT_S = 1.0
"""A crossing moved by more than this (s) by a reference error is not followed: the
nearest crossing of that sync point is another pass (a reference error moves a crossing
by milliseconds)."""

_REFERENCE_INTERNAL = REFERENCE_ERRORS / REPORT_SCALE
"""`REFERENCE_ERRORS` in internal units (rad, m, s)."""


def crossing_shifts(
    trajectory: Trajectory,
    mount: Mount,
    sync_points: SyncPoints,
    config: ObjectSpaceConfig,
    crossings: Sequence[Crossing],
) -> FloatArray:
    """How far each crossing moves per reference error of each mount value, shape (7, C).

    Parameters
    ----------
    trajectory : Trajectory
        Body trajectory, as for `kinsync.sync.crossings.search_crossings`.
    mount : Mount
        The mount the crossings were found with.
    sync_points : SyncPoints
        Target centres (WGS84).
    config : ObjectSpaceConfig
        As for the search.
    crossings : sequence of Crossing
        The crossings found with ``mount``.

    Returns
    -------
    ndarray, shape (7, C)
        Time shift (s) of crossing j when mount value k (`PARAMETER_NAMES` order) is
        moved by ``REFERENCE_ERRORS[k]``; NaN where that sync point has no crossing
        within `MAX_SHIFT_S` any more (the plane no longer sweeps it there).
    """
    values = mount_values(mount)
    t_c = np.array([c.t_s for c in crossings])
    out = np.full((len(PARAMETER_NAMES), len(crossings)), np.nan)
    for k, step in enumerate(_REFERENCE_INTERNAL):
        moved_values = values.copy()
        moved_values[k] += step
        moved = search_crossings(
            trajectory, mount_from_values(mount, moved_values), sync_points, config
        ).crossings
        for j, c in enumerate(crossings):
            times = np.array([m.t_s for m in moved if m.name == c.name])
            if times.size:
                shift = float(times[np.argmin(np.abs(times - t_c[j]))] - t_c[j])
                if abs(shift) <= MAX_SHIFT_S:
                    out[k, j] = shift
    return out


@dataclass(frozen=True, eq=False)
class MountEffect(ReadOnlyArrays):
    """What the mount's errors do to the clock (t0, T).

    Attributes
    ----------
    sensitivity_s : ndarray, shape (2, 7)
        Change of t0 (row 0) and T (row 1) in s per reference error
        (`kinsync.calibration.held.REFERENCE_ERRORS`) of each mount value, in
        `PARAMETER_NAMES` order; NaN where a crossing could not be followed.
    covariance : ndarray, shape (2, 2)
        ``D Sigma_h D'`` over the values with a stated sigma (s^2).
    exact : tuple of str
        Values the mount gives no sigma for, taken as exact.
    unfollowed : tuple of str
        Values with a stated sigma whose effect could not be computed (a crossing not
        followed): left out of ``covariance``.
    """

    sensitivity_s: FloatArray
    covariance: FloatArray
    exact: tuple[str, ...]
    unfollowed: tuple[str, ...]

    def __post_init__(self) -> None:
        # Own read-only copies, as every result's arrays (compared by identity: eq=False).
        object.__setattr__(self, "sensitivity_s", readonly_array(self.sensitivity_s))
        object.__setattr__(self, "covariance", readonly_array(self.covariance))

    def as_document(self) -> dict[str, Any]:
        """JSON-ready dict: per value its reference error and what it does to t0 and T."""
        return {
            "sensitivity": {
                name: {
                    "per": REFERENCE_TEXT[k],
                    "t0_s": _finite(self.sensitivity_s[0, k]),
                    "period_s": _finite(self.sensitivity_s[1, k]),
                }
                for k, name in enumerate(PARAMETER_NAMES)
            },
            "t0_std_s": math.sqrt(self.covariance[0, 0]),
            "period_std_s": math.sqrt(self.covariance[1, 1]),
            "exact": list(self.exact),
            "unfollowed": list(self.unfollowed),
        }


def _finite(value: float) -> float | None:
    """``value`` as a float, or None (JSON null) where it is NaN."""
    return float(value) if math.isfinite(value) else None


def mount_effect(
    x: FloatArray, cov_t: FloatArray, shifts_s: FloatArray, mount: Mount
) -> MountEffect:
    """The clock's sensitivity to the mount and the covariance its stated sigma add.

    Parameters
    ----------
    x : ndarray, shape (m,)
        Clock abscissae ``n + phi / 2 pi`` of the matched sightings (profiles).
    cov_t : ndarray, shape (m, m)
        The times' covariance the clock was fitted with (s^2).
    shifts_s : ndarray, shape (7, m)
        The matched crossings' columns of `crossing_shifts` (s per reference error).
    mount : Mount
        Its ``uncertainty`` gives ``Sigma_h``.

    Returns
    -------
    MountEffect
    """
    n = len(PARAMETER_NAMES)
    d_ref = np.full((2, n), np.nan)
    for k in range(n):
        if np.all(np.isfinite(shifts_s[k])):  # linear: the line through the shifts alone
            moved = gls_line(x, shifts_s[k], cov_t)
            d_ref[:, k] = (moved.t0_s, moved.period_s)
    sigma_h = held_covariance(mount)
    stated = np.isfinite(np.diag(sigma_h))
    use = stated & np.all(np.isfinite(d_ref), axis=0)
    d = d_ref[:, use] / _REFERENCE_INTERNAL[use]
    cov = d @ sigma_h[np.ix_(use, use)] @ d.T
    return MountEffect(
        sensitivity_s=d_ref,
        covariance=0.5 * (cov + cov.T),
        exact=tuple(PARAMETER_NAMES[k] for k in range(n) if not stated[k]),
        unfollowed=tuple(PARAMETER_NAMES[k] for k in range(n) if stated[k] and not use[k]),
    )


def exact_text(
    effect: MountEffect | None, data_covariance: tuple[tuple[float, float], tuple[float, float]]
) -> str | None:
    """A warning naming the exact-taken values whose reference error matters, or None.

    A value with no stated sigma is named where its reference error moves t0 or T by
    more than `ADVICE_SHARE` of their data sigma (``t0_std_s``, ``period_std_s``), with
    the larger of the two moves; a value with a stated sigma whose effect could not be
    computed is named too.

    Parameters
    ----------
    effect : MountEffect or None
        None: nothing to say.
    data_covariance : 2 x 2 tuple of float
        The clock's covariance from the data alone (s^2): t0, T.
    """
    if effect is None:
        return None
    t0_std_s, period_std_s = math.sqrt(data_covariance[0][0]), math.sqrt(data_covariance[1][1])
    parts = []
    for name in effect.exact:
        k = PARAMETER_NAMES.index(name)
        d_t0, d_period = effect.sensitivity_s[:, k]
        if not (math.isfinite(d_t0) and math.isfinite(d_period)):
            continue
        share_t0, share_period = abs(d_t0) / t0_std_s, abs(d_period) / period_std_s
        if max(share_t0, share_period) <= ADVICE_SHARE:
            continue
        moves = (
            f"t0 by {d_t0 * 1e3:+.3g} ms ({share_t0:.2g} sigma)"
            if share_t0 >= share_period
            else f"the period by {d_period * 1e6:+.3g} us ({share_period:.2g} sigma)"
        )
        parts.append(f"{REFERENCE_TEXT[k]} of {name} moves {moves}")
    text = []
    if parts:
        each = "each" if len(parts) > 1 else "it"
        text.append(
            "the clock's sigma takes the mount as exact where it gives no [uncertainty]: "
            + "; ".join(parts)
            + f": give the standard deviation of {each} in the mount file's [uncertainty] "
            "table so that the sigma holds it"
        )
    if effect.unfollowed:
        text.append(
            f"the effect of {', '.join(effect.unfollowed)} on the clock could not be "
            f"computed (a crossing moved more than {MAX_SHIFT_S:g} s or vanished with "
            "a small change of it), so the sigma leaves out its stated [uncertainty]"
        )
    return "; ".join(text) if text else None
