"""Whether a trajectory's velocities agree with its positions (`check_velocities`).

Part of the `kinsync.trajectory.Trajectory` container, kept apart for size: converted
or synthesised files often carry zero, scaled, swapped or unrotated velocities, and a
Hermite spline through them bends every position between records. `Trajectory`
checks its velocities here before its "auto" interpolation uses them, and
`kinsync.trajectory` exports these names.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from kinsync._typing import ArrayLike, FloatArray
from kinsync.errors import InputError, KinsyncWarning
from kinsync.trajectory_gaps import GAP_FACTOR

__all__ = [
    "VELOCITY_CHECK_ATOL_M",
    "VELOCITY_CHECK_RTOL",
    "VELOCITY_CHECK_WINDOW_S",
    "VELOCITY_HINT",
    "VelocityCheck",
    "VelocityConsistencyWarning",
    "check_velocities",
]

VELOCITY_CHECK_WINDOW_S = 1.0
"""Duration (s) of the windows over which velocities are integrated and compared with
the displacement of the positions (one record interval where records are sparser)."""

VELOCITY_CHECK_RTOL = 0.2
"""Largest RMS mismatch per window, as a fraction of the RMS displacement per window,
that consistent velocities may show (horizontal and vertical separately)."""

VELOCITY_CHECK_ATOL_M = 0.05
"""RMS mismatch per window (m) that passes whatever the motion: position noise and text
rounding of honest files, and the standstill of a vehicle with zero velocities."""

_VELOCITY_CHECK_GAP_FACTOR = GAP_FACTOR
"""Record intervals longer than this many median intervals (data gaps) are left out."""


_ZERO_SCALE = 0.05
"""A velocity scale below this (in magnitude) is reported as zero velocities."""


VELOCITY_HINT = (
    "Check the velocity fields: m/s, in the order north, east, down (down positive), "
    "SBET wander-frame velocities rotated by the wander angle"
)


class VelocityConsistencyWarning(KinsyncWarning):
    """A trajectory's velocities disagree with its positions; Hermite is not used."""


@dataclass(frozen=True)
class VelocityCheck:
    """Whether a trajectory's velocities agree with its positions (`check_velocities`).

    Attributes
    ----------
    consistent : bool
        True when Hermite position interpolation may use the velocities.
    window_s : float
        Window duration (s): about `VELOCITY_CHECK_WINDOW_S`, or one median record
        interval where records are sparser.
    n_windows : int
        Windows compared.
    rms_displacement_horizontal_m, rms_displacement_vertical_m : float
        RMS over the windows of the displacement the positions show (m): horizontal
        (north and east together) and vertical.
    rms_mismatch_horizontal_m, rms_mismatch_vertical_m : float
        RMS over the windows of the displacement minus the integrated velocity (m).
    velocity_scale : float or None
        Least-squares factor taking the displacement to the integrated velocity over
        every window and axis: 1 for consistent velocities, 0 for zero velocities, 3.6
        for km/h taken as m/s; None when the positions do not move at all.
    worst_t_s : float
        Start time (s) of the window with the largest mismatch.
    mix_up : str or None
        The swap or sign flip of the velocity components that makes them agree with the
        positions, in words ("north and east swapped", ...); None when none does or the
        velocities are consistent.
    """

    consistent: bool
    window_s: float
    n_windows: int
    rms_displacement_horizontal_m: float
    rms_displacement_vertical_m: float
    rms_mismatch_horizontal_m: float
    rms_mismatch_vertical_m: float
    velocity_scale: float | None
    worst_t_s: float
    mix_up: str | None = None

    @property
    def message(self) -> str:
        """What is wrong, what kinsync does about it and what to check ("" if consistent)."""
        if self.consistent:
            return ""
        return (
            f"{self.problem}; positions are interpolated linearly instead of by cubic "
            f"Hermite. {VELOCITY_HINT}"
        )

    @property
    def problem(self) -> str:
        """What is wrong, with the figures ("" if consistent)."""
        if self.consistent:
            return ""
        stats = (
            self.rms_mismatch_horizontal_m,
            self.rms_displacement_horizontal_m,
            self.rms_mismatch_vertical_m,
            self.rms_displacement_vertical_m,
        )
        if not all(math.isfinite(v) for v in stats):
            return (
                "trajectory velocities could not be checked against the positions (the "
                "differences overflow: absurdly large positions or velocities)"
            )
        scale = self.velocity_scale
        if self.mix_up is not None:
            how = f"they match the positions with {self.mix_up}"
        elif scale is None:
            how = "the velocities say the vehicle moves while the positions stand still"
        elif abs(scale) < _ZERO_SCALE:
            how = "the velocities are zero (or nearly) while the positions move"
        else:
            how = (
                f"integrated, the velocities cover {scale:.3g} times the displacement "
                "of the positions"
            )
        return (
            f"trajectory velocities disagree with the positions: {how} (RMS mismatch "
            f"per {self.window_s:.3g} s window: horizontal {stats[0]:.3g} m for "
            f"{stats[1]:.3g} m travelled, vertical {stats[2]:.3g} m for {stats[3]:.3g} m; "
            f"largest in the window from t={self.worst_t_s:.10g} s)"
        )

    def as_document(self) -> dict[str, Any]:
        """The check as a JSON-ready mapping (``message`` empty when consistent)."""
        return {
            "consistent": self.consistent,
            "window_s": self.window_s,
            "n_windows": self.n_windows,
            "rms_displacement_horizontal_m": self.rms_displacement_horizontal_m,
            "rms_displacement_vertical_m": self.rms_displacement_vertical_m,
            "rms_mismatch_horizontal_m": self.rms_mismatch_horizontal_m,
            "rms_mismatch_vertical_m": self.rms_mismatch_vertical_m,
            "velocity_scale": self.velocity_scale,
            "worst_t_s": self.worst_t_s,
            "message": self.message,
        }


def _rms_per_window_m(values: FloatArray) -> float:
    return float(np.sqrt(np.mean(np.sum(values * values, axis=1))))


_HORIZONTAL_MIX_UPS = (
    ("north and east swapped", ((0.0, 1.0), (1.0, 0.0))),
    ("the signs of north and east flipped", ((-1.0, 0.0), (0.0, -1.0))),
    ("the sign of north flipped", ((-1.0, 0.0), (0.0, 1.0))),
    ("the sign of east flipped", ((1.0, 0.0), (0.0, -1.0))),
    ("north and east swapped and one sign flipped", ((0.0, -1.0), (1.0, 0.0))),
    ("north and east swapped and one sign flipped", ((0.0, 1.0), (-1.0, 0.0))),
)
"""Mix-ups of the horizontal velocity columns, each as the matrix that undoes it."""


def _passes(mismatch_rms_m: float, moved_rms_m: float) -> bool:
    return mismatch_rms_m <= VELOCITY_CHECK_RTOL * moved_rms_m + VELOCITY_CHECK_ATOL_M


def _mix_up(moved_w: FloatArray, integrated_w: FloatArray) -> str | None:
    """The swap or sign flip of the velocity components that makes the check pass, or None.

    ``moved_w`` and ``integrated_w``: per window, the positions' displacement and the
    integrated velocities (NED, m). The integral is linear in the velocities, so a
    swapped or flipped component is undone on it.
    """
    d_h, d_v = _rms_per_window_m(moved_w[:, :2]), _rms_per_window_m(moved_w[:, 2:])
    horizontal: str | None = None
    if not _passes(_rms_per_window_m(moved_w[:, :2] - integrated_w[:, :2]), d_h):
        # the first that passes: on a straight run several do, the commonest is named
        horizontal = next(
            (
                words
                for words, m in _HORIZONTAL_MIX_UPS
                if _passes(
                    _rms_per_window_m(moved_w[:, :2] - integrated_w[:, :2] @ np.array(m).T), d_h
                )
            ),
            None,
        )
        if horizontal is None:
            return None
    vertical: str | None = None
    if not _passes(_rms_per_window_m(moved_w[:, 2:] - integrated_w[:, 2:]), d_v):
        if not _passes(_rms_per_window_m(moved_w[:, 2:] + integrated_w[:, 2:]), d_v):
            return None
        vertical = "the sign of down flipped (up given as down)"
    if horizontal == "north and east swapped" and vertical is not None:
        return (
            "north and east swapped and the sign of down flipped: east, north, up (ENU) "
            "velocities in the north, east, down columns"
        )
    return " and ".join(w for w in (horizontal, vertical) if w is not None) or None


def check_velocities(
    t_s: ArrayLike, displacement_ned_m: ArrayLike, vel_ned_m_s: ArrayLike
) -> VelocityCheck:
    """Check velocities against the displacement between records, window by window.

    Over one record interval ``h`` the velocities predict the displacement

        I = h (v0 + v1) / 2 + h² (a0 - a1) / 12,

    the trapezoid rule with its Euler-Maclaurin end correction (``a`` the accelerations
    from the velocities by central differences). For smooth motion it misses the true
    displacement by O(h⁵): the plain trapezoid alone would miss by ``h³ · jerk / 12``,
    which at a 1 Hz record rate is what turns and heave make of it. The mismatch
    ``displacement - I`` is summed over windows of consecutive intervals lasting about
    `VELOCITY_CHECK_WINDOW_S`: a wrong velocity accumulates over the window while white
    position noise enters only through the window's two end positions (sqrt(2) sigma,
    at any record rate). The velocities are inconsistent when, horizontally (north and
    east together) or vertically (down, kept apart because vertical motion is often a
    hundredth of the horizontal and a sign error in it would drown in a 3-D sum),

        RMS mismatch > VELOCITY_CHECK_RTOL · RMS displacement + VELOCITY_CHECK_ATOL_M

    over all windows. The test is global (sums of squares, cheap and robust to a few
    bad records); velocities wrong over a small part of the file only (under about 4 %
    of the moving time) pass it. Intervals longer than 10 median intervals (data gaps)
    are left out.

    Measured relative mismatch (RMS mismatch / RMS displacement, horizontal and
    vertical): honest trajectories at 200 Hz, 2e-5 and 3e-3 (1.3 mm) for the NaveGo
    reference trajectory, below 1e-7 for the simulated drives and SBETs of
    `kinsync.sim` (with navigation noise too), 2e-3 and 0.04 (3 mm) with 5 cm
    Gauss-Markov position noise; decimated to 1 Hz, 4e-3 for NaveGo and up to 0.06
    (horizontal, 15-20 m/s survey lines with turns) and 0.07 (vertical, 1 m heave of
    4 s period). Broken velocities: zero 1.0; km/h taken as m/s 2.6, the reverse 0.72;
    knots and m/s mixed up 0.49 or 0.94; north and east swapped 1.1-1.9; the sign of
    down flipped 2.0 (vertical); a 30 deg wander angle left unrotated 0.52.
    `VELOCITY_CHECK_RTOL` = 0.2 sits three times above the worst honest case and at
    least 2.4 times below these mistakes; what it lets through (scale errors under
    20 %, rotations under 11 deg) bends a Hermite position by at most
    ``0.2 · 0.096 h v`` (2 mm at 200 Hz and 20 m/s; the bend of a mismatch d is
    ``h d s (1 - s) (1 - 2 s)``, at most 0.096 h d).
    `VELOCITY_CHECK_ATOL_M` = 0.05 m absorbs position noise and text rounding (1e-7 deg
    of latitude is 1.1 cm), so that a standing vehicle's noise never fails, while zero
    velocities fail on any vehicle moving faster than about 6 cm/s.

    Parameters
    ----------
    t_s : array_like, shape (N,)
        Record times (s), strictly increasing, N >= 2.
    displacement_ned_m : array_like, shape (N-1, 3)
        Displacement between consecutive records in the local NED frame (m).
    vel_ned_m_s : array_like, shape (N, 3)
        Velocities at the records, NED (m/s).

    Returns
    -------
    VelocityCheck

    Raises
    ------
    InputError
        Mismatched shapes.
    """
    t = np.asarray(t_s, dtype=np.float64)
    dp = np.asarray(displacement_ned_m, dtype=np.float64)
    v = np.asarray(vel_ned_m_s, dtype=np.float64)
    n = t.size
    if t.ndim != 1 or n < 2 or dp.shape != (n - 1, 3) or v.shape != (n, 3):
        msg = (
            f"check_velocities: expected times (N,), displacements (N-1, 3) and velocities "
            f"(N, 3) with N >= 2, got {t.shape}, {dp.shape} and {v.shape}"
        )
        raise InputError(msg)
    with np.errstate(all="ignore"):  # absurd values overflow: reported, not warned
        h = np.diff(t)
        acc = np.gradient(v, t, axis=0)
        hh = h[:, None]
        integral = 0.5 * hh * (v[:-1] + v[1:]) + hh * hh * (acc[:-1] - acc[1:]) / 12.0
        median_h = float(np.median(h))
        kept = (h <= _VELOCITY_CHECK_GAP_FACTOR * median_h)[:, None]
        mismatch = np.where(kept, dp - integral, 0.0)
        moved = np.where(kept, dp, 0.0)
        per_window = max(1, round(VELOCITY_CHECK_WINDOW_S / median_h))
        starts = np.arange(0, n - 1, per_window)
        mismatch_w = np.add.reduceat(mismatch, starts, axis=0)
        moved_w = np.add.reduceat(moved, starts, axis=0)
        r_h, d_h = _rms_per_window_m(mismatch_w[:, :2]), _rms_per_window_m(moved_w[:, :2])
        r_v, d_v = _rms_per_window_m(mismatch_w[:, 2:]), _rms_per_window_m(moved_w[:, 2:])
        moved_sq = float(np.sum(moved_w * moved_w))
        scale = float(np.sum((moved_w - mismatch_w) * moved_w)) / moved_sq if moved_sq > 0 else None
        worst = int(np.argmax(np.sum(mismatch_w * mismatch_w, axis=1)))
    finite = all(math.isfinite(x) for x in (r_h, d_h, r_v, d_v)) and (
        scale is None or math.isfinite(scale)
    )
    consistent = finite and _passes(r_h, d_h) and _passes(r_v, d_v)
    mix_up = None
    if finite and not consistent:
        with np.errstate(all="ignore"):
            mix_up = _mix_up(moved_w, moved_w - mismatch_w)
    return VelocityCheck(
        consistent=consistent,
        window_s=per_window * median_h,
        n_windows=int(starts.size),
        rms_displacement_horizontal_m=d_h,
        rms_displacement_vertical_m=d_v,
        rms_mismatch_horizontal_m=r_h,
        rms_mismatch_vertical_m=r_v,
        velocity_scale=scale,
        worst_t_s=float(t[starts[worst]]),
        mix_up=mix_up,
    )
